"""Text a campaign file or a pack supplies, where it is shown (issue 71): the report's HTML
opened in a real browser runs none of it, its markdown and the terminal show control
characters rather than send them."""

from __future__ import annotations

import re

from somite.campaigns import directory as campaign_dir
from somite.campaigns.expansion import expand
from somite.campaigns.spec import parse
from somite.cli import main
from somite.report.markdown import _head, _status, render_html
from tests.test_replay import browser, needs_chromium

# Each sets the body's data-ran when it runs: in the page, none may.
SCRIPTS = ['<img src=x onerror="document.body.dataset.ran=1">',
           '<script>document.body.dataset.ran=1</script>',
           '[link](javascript:document.body.dataset.ran=1)',
           '<svg onload="document.body.dataset.ran=1"></svg>']
ESCAPES = "\x1b[2J\x1b]0;owned\x07\u202e|[bold]"
"""A terminal's clear screen and window title, a right-to-left override, a table's column
bar and rich's markup."""


def _report(name: str) -> dict:
    """What the report's head and task table read of report.json."""
    experiments = {f"e{i}": {"title": text, "paper": text} for i, text in enumerate(SCRIPTS)}
    return {"campaign": {"name": name, "directory": "c", "source": name + ".toml",
                         "experiments": experiments},
            "validation": {"terrains": 10}, "caveats": {"banner": []},
            "status": {"experiments": {e: {"tasks": 1, "done": 0, "missing": ["x"]}
                                       for e in experiments},
                       "unreadable": {"e0/x": SCRIPTS[1]}}}


def _markdown(name: str) -> str:
    report = _report(name)
    return "\n".join(_head(report) + _status(report))


def test_the_reports_html_holds_no_tag_or_link_of_a_title():
    page = render_html(_markdown(SCRIPTS[0]), SCRIPTS[1])
    assert "<img" not in page and "<script" not in page and "<svg" not in page
    assert "javascript:" not in re.sub(r">[^<]*<", "><", page)  # in text only, not an href
    assert "&lt;img src=x onerror=" in page


@needs_chromium
def test_the_report_opened_in_a_browser_runs_no_script_of_a_title(tmp_path):
    page = tmp_path / "index.html"
    page.write_text(render_html(_markdown(SCRIPTS[0] + SCRIPTS[1]), SCRIPTS[1]))
    done = browser(tmp_path, "--dump-dom", page.resolve().as_uri())
    assert done.returncode == 0, done.stderr[-2000:]
    body = re.search(r"<body([^>]*)>", done.stdout).group(1)
    assert "data-ran" not in body
    assert "onerror=" in done.stdout  # shown as text: the title is there, not dropped


def test_markdown_shows_control_characters_and_keeps_rows_whole():
    text = _markdown("c" + ESCAPES)
    assert "\x1b" not in text and "\x07" not in text and "\u202e" not in text
    assert "# Campaign report: c\\\\x1b[2J" not in text  # a bracket is escaped too
    assert "\\\\x1b" in text and "\\\\u202e" in text
    row = next(line for line in text.splitlines() if line.startswith("| e0 |"))
    assert row.count(" | ") == 5  # six cells: no title splits its row


def test_campaign_status_shows_escapes_in_a_name_rather_than_sending_them(tmp_path, capsys):
    campaign = parse({"experiments": {"rq1": {"kind": "evolve", "shapes": ["worm"],
                                              "seeds": [0]}}},
                     name="evil" + ESCAPES, source="evil.toml")
    root = tmp_path / "c"
    campaign_dir.prepare(root, campaign_dir.document(campaign, expand(campaign)),
                         resume=False)
    capsys.readouterr()
    assert main(["campaign", "status", str(root)]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\x07" not in out and "\u202e" not in out
    assert "\\x1b[2J" in out and "[bold]" in out  # shown, markup and all


def test_a_label_that_reads_as_mathtext_is_drawn_as_written():
    import io

    import matplotlib.pyplot as plt
    import numpy as np

    from somite.viz.plots import plot_samples

    figure, axes = plt.subplots()
    label = r"a$\frac{$b"  # as mathtext, a parse error that ended `somite report`
    plot_samples(axes, {label: np.array([1.0, 2.0, 3.0]), "b": np.array([2.0, 3.0, 4.0])}, "v")
    figure.savefig(io.BytesIO(), format="png")
    plt.close(figure)
    assert [t.get_text() for t in axes.get_xticklabels()] == [r"a\$\frac{\$b", "b"]
