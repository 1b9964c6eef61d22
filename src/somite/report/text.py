"""The pieces ``index.md`` is written with: numbers as cells, tables, figures, the paper's
claims and the rows of a comparison's tests. The core sections (:mod:`.markdown`) and each
experiment kind's section (:mod:`.sections`) write with them."""

from __future__ import annotations

import math
import re

from .._visible import visible

FIGURES = "figures"
"""The report's folder of figures, as index.md links it."""


def number(value, digits: int = 3) -> str:
    """A table cell: a float to ``digits`` decimals, ``n/a`` for None or non-finite."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "n/a"
    return f"{value:.{digits}f}" if isinstance(value, float) else str(value)


def median_sd(summary: dict, digits: int = 3) -> str:
    """``median ± sd`` of a :func:`~somite.analysis.stats.describe` summary."""
    if not summary or not summary.get("n"):
        return "n/a"
    return f"{number(summary['median'], digits)} ± {number(summary['std'], digits)}"


def p_value(value) -> str:
    if value is None or not math.isfinite(value):
        return "n/a"
    return "< 0.001" if value < 0.001 else f"{value:.3g}"


def plain(text) -> str:
    """Text a campaign file or pack supplies (a name, a title, a label), as markdown shows it:
    control characters written out (:func:`somite._visible.visible`), and the characters that
    would make it a link, an image (fetched when the page opens) or split a table's row
    escaped. Emphasis is left: it cannot reach outside the text."""
    return _MARKDOWN.sub(r"\\\g<0>", visible(text))


_MARKDOWN = re.compile(r"[\\\[\]|]")


def table(header: list[str], rows: list[list]) -> list[str]:
    """A markdown table; each cell through :func:`plain` (labels and titles are the user's)."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(plain(c) for c in row) + " |" for row in rows]
    return lines + [""]


NO_TASK = "*No finished task for this figure.*"
"""What :func:`images` says of a figure with no image."""


def images_of(figures) -> list[str]:
    """:func:`images` of each (files, alt) of one figure drawn in several images; one line
    saying so when none has any (not one an image)."""
    figures = list(figures)
    if not any(files for files, _ in figures):
        return [NO_TASK, ""]
    return [line for files, alt in figures for line in images(files, alt)]


def images(files, alt: str) -> list[str]:
    """A figure's PNG shown, its other formats linked; a line saying so when it has none."""
    if not files:
        return [NO_TASK, ""]
    png = next((f for f in files if f.endswith(".png")), files[0])
    others = ", ".join(f"[{f.rsplit('.', 1)[-1].upper()}]({FIGURES}/{f})" for f in files
                       if f != png)
    return [f"![{alt}]({FIGURES}/{png})", "", others, ""] if others else [
        f"![{alt}]({FIGURES}/{png})", ""]


def claim(reported: dict) -> str:
    return f"Paper ({reported['where']}): {reported['text']}."


def p_noted(test: dict) -> str:
    """A test's p-value, with its caveat beside it where its groups are too small."""
    caveat = test.get("caveat")
    return f"{p_value(test['p'])} ({caveat})" if caveat else p_value(test["p"])


TESTS_HEADER = ["sample", "pair", "n_a", "n_b", "U", "p (two-sided)"]


def tests_table(tests: list[list], first: str = "sample") -> list[str]:
    """The pairwise tests' table (rows of :func:`pair_rows`), or a line saying why there is
    none: an empty table reads as a fault of the report."""
    if not tests:
        return ["*No pair to test: no shape has finished tasks in two groups.*", ""]
    return table([first, *TESTS_HEADER[1:]], tests)


def pair_rows(comparison: dict, label: str) -> list[list]:
    """One table row per pairwise test of a comparison (:func:`.evolution.compare`)."""
    return [[label, f"{t['a']} vs {t['b']}", t["n_a"], t["n_b"], number(t["u"], 1),
             p_noted(t)] for t in comparison["tests"]]


__all__ = ["FIGURES", "claim", "images", "median_sd", "number", "p_noted", "p_value", "plain",
           "pair_rows", "table", "tests_table"]
