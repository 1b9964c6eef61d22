"""``index.md`` from report.json's data (and ``index.html`` from it, through markdown-it, which
rich already brings; without it there is no HTML). Numbers only: every one is in report.json."""

from __future__ import annotations

import math

from ..analysis.stats import MIN_GROUP_SIZE
from . import paper
from .sections import TITLES

FIGURES = "figures"


def _n(value, digits: int = 3) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "n/a"
    return f"{value:.{digits}f}" if isinstance(value, float) else str(value)


def _ms(summary: dict, digits: int = 3) -> str:
    """``median ± sd`` of a :func:`~somite.analysis.stats.describe` summary."""
    if not summary or not summary.get("n"):
        return "n/a"
    return f"{_n(summary['median'], digits)} ± {_n(summary['std'], digits)}"


def _p(value) -> str:
    if value is None or not math.isfinite(value):
        return "n/a"
    return "< 0.001" if value < 0.001 else f"{value:.3g}"


def _table(header: list[str], rows: list[list]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return lines + [""]


def _images(files, alt: str) -> list[str]:
    if not files:
        return ["*No finished task for this figure.*", ""]
    png = next((f for f in files if f.endswith(".png")), files[0])
    others = ", ".join(f"[{f.rsplit('.', 1)[-1].upper()}]({FIGURES}/{f})" for f in files
                       if f != png)
    return [f"![{alt}]({FIGURES}/{png})", "", others, ""] if others else [
        f"![{alt}]({FIGURES}/{png})", ""]


def _claim(reported: dict) -> str:
    return f"Paper ({reported['where']}): {reported['text']}."


def _p_noted(test: dict) -> str:
    """A test's p-value, with its caveat beside it where its groups are too small."""
    caveat = test.get("caveat")
    return f"{_p(test['p'])} ({caveat})" if caveat else _p(test["p"])


def _tests(comparison: dict, label: str) -> list[list]:
    return [[label, f"{t['a']} vs {t['b']}", t["n_a"], t["n_b"], _n(t["u"], 1), _p_noted(t)]
            for t in comparison["tests"]]


def render_markdown(report: dict) -> str:
    lines: list[str] = []
    for part in (_head, _status, _table1, _curves, _boxes, _rho, _eta, _discovery,
                 _discovered_reassembly, _validation, _transfer, _timelapse):
        lines += part(report)
    return "\n".join(lines).rstrip() + "\n"


def _head(report: dict) -> list[str]:
    c = report["campaign"]
    return [
        f"# Campaign report: {c['name']}", "",
        *_banner(report),
        f"Campaign `{c['directory']}` ({c['source'] or 'no source recorded'}), written by "
        "`somite report`. Every number below is also in `report.json`; figures are in "
        "`figures/` as PNG and SVG. Medians and standard deviations (ddof 0) are across runs; "
        "p-values are two-sided Mann-Whitney U tests (scipy); a p-value of a group of fewer "
        f"than {MIN_GROUP_SIZE} runs is marked *not meaningful* (with 2 and 2 no data can give "
        "a two-sided p below 1/3). The paper's numbers "
        "(Pigozzi & Medvet) stand beside ours, with where they come from.", "",
        "A run's logged best v_x is its luckiest terrain draw: each table also gives the same "
        f"robots' mean v_x on the {report['validation']['terrains']} fixed validation terrains "
        "(hilly-1-10-10000 on), never seen in training.", "",
    ]


def _banner(report: dict) -> list[str]:
    """The caveats that apply (report.json's ``caveats.banner``), before any number."""
    banner = (report.get("caveats") or {}).get("banner", [])
    return [line for text in banner for line in (f"> **Warning:** {text}.", "")]


def _status(report: dict) -> list[str]:
    lines = ["## Tasks", ""]
    experiments = report["campaign"]["experiments"]
    rows = []
    for name, s in report["status"]["experiments"].items():
        meta = experiments.get(name, {})
        rows.append([name, meta.get("title", ""), meta.get("paper", ""), s["tasks"], s["done"],
                     ", ".join(s["missing"]) or "none"])
    lines += _table(["experiment", "title", "paper", "tasks", "finished", "missing"], rows)
    for task, why in report["status"]["unreadable"].items():
        lines.append(f"- {task}: finished but unreadable, shown as missing ({why})")
    if report["status"]["unreadable"]:
        lines.append("")
    return lines + _missing_figures(report)


def _missing_figures(report: dict) -> list[str]:
    """One line: the figures no experiment of the campaign feeds, and why (report.json's
    ``figures.missing``; an experiment declares them in its ``figures`` table)."""
    missing = (report.get("figures") or {}).get("missing") or {}
    if not missing:
        return []
    reasons = "; ".join(f"{name}: {why}" for name, why in missing.items())
    return [f"Figures no experiment feeds (declared by an experiment's `figures` table in the "
            f"campaign file), left empty: {reasons}.", ""]


def _table1(report: dict) -> list[str]:
    lines = [f"## {TITLES['table1']}", "",
             "Median ± sd across runs of the best individual's |V|, |E|, |G| and v_x [m/s] at "
             "generation 0 and at the last generation; the paper's row (its RQ1, 10 runs, 3000 "
             "generations) below ours, for the experiment that declares `table1`.", ""]
    rows = []
    for row in report["table1"]:
        i, f = row["initial"], row["final"]
        rows.append([row["experiment"], row["shape"], f"{row['n']} of {row['tasks']}",
                     _n(row["generations"]["median"], 0),
                     _ms(i["nodes"], 1), _ms(i["edges"], 1), _ms(i["size"], 1),
                     _ms(i["velocity"]), _ms(f["nodes"], 1), _ms(f["edges"], 1),
                     _ms(f["size"], 1), _ms(f["velocity"]), _ms(row["validation"]) + (
                         f" ({row['validation_non_finite']} non-finite)"
                         if row["validation_non_finite"] else ""),
                     _n(row["size_increase"] * 100, 0) + " %"
                     if row["size_increase"] == row["size_increase"] else "n/a"])
        if row["paper"]:
            p = row["paper"]
            show = {w: {k: paper.Reported(**v).show() for k, v in p[w].items()}
                    for w in ("initial", "final")}
            rows.append(["paper", row["shape"], "10", "3000", show["initial"]["nodes"],
                         show["initial"]["edges"], show["initial"]["size"],
                         show["initial"]["velocity"], show["final"]["nodes"],
                         show["final"]["edges"], show["final"]["size"],
                         show["final"]["velocity"], "not measured",
                         _n(p["size_increase"]["value"] * 100, 0) + " %"])
    header = ["experiment", "shape", "runs", "generations", "initial \\|V\\|", "initial \\|E\\|",
              "initial \\|G\\|", "initial v_x", "final \\|V\\|", "final \\|E\\|",
              "final \\|G\\|", "final v_x (logged)", "final v_x (validation)",
              "\\|G\\| increase"]
    return lines + _table(header, rows)


def _curves(report: dict) -> list[str]:
    lines = []
    for key in ("figure3", "figure10"):
        title = TITLES[key]
        lines += [f"## {title}", "",
                  "Median ± sd across runs (line and band); dashed with dots: the median of the "
                  "logged validation v_x, where the runs measured it.", ""]
        if key == "figure3":
            lines += _figure3_beside_paper(report["figure3"])
        lines += _images(report[key]["files"], title)
    return lines


def _figure3_beside_paper(data: dict) -> list[str]:
    """Figure 3's curves at their two ends, median across runs, beside what the paper says
    (v_x from section 5.1, |G| from Table 1)."""
    reported = data.get("paper")
    rows = []
    for shape, groups in data["curves"].items():
        for group, c in groups.items():
            if not c["generation"]:
                continue
            last_validation = (f"{_n(c['validation_median'][-1])} (generation "
                               f"{_n(c['validation_generation'][-1], 0)})"
                               if c["validation_median"] else "n/a")
            rows.append([shape, group, len(c["runs"]), _n(c["generation"][-1], 0),
                         _n(c["velocity_median"][0]), _n(c["velocity_median"][-1]),
                         last_validation, _n(c["size_median"][0], 1),
                         _n(c["size_median"][-1], 1)])
            if reported and shape in reported["size"]:
                size = reported["size"][shape]
                rows.append(["paper", "", "10", "3000",
                             paper.Reported(**reported["velocity_start"]).show(),
                             paper.Reported(**reported["velocity_end"]).show(),
                             "not measured", paper.Reported(**size["initial"]).show(),
                             paper.Reported(**size["final"]).show()])
    if not rows:
        return []
    lines = ["The curves at both ends (median across runs), the paper's row below ours "
             "(v_x: section 5.1, averaged over both shapes; |G|: Table 1):", ""]
    return lines + _table(["shape", "group", "runs", "last generation", "v_x at generation 0",
                           "v_x at the last (logged)", "v_x at the last validation",
                           "\\|G\\| at generation 0", "\\|G\\| at the last"], rows)


def _boxes(report: dict) -> list[str]:
    lines = []
    for key in ("figure5", "figure11"):
        title = TITLES[key]
        data = report[key]
        lines += [f"## {title}", "", _claim(data["paper"]), ""]
        rows, tests = [], []
        for shape, c in data["comparison"].items():
            for group, logged in c["logged"]["groups"].items():
                validated = c["validation"]["groups"].get(group, {})
                rows.append([shape, group, logged["n"], _ms(logged), _ms(validated)])
            tests += _tests(c["logged"], f"{shape}, logged")
            tests += _tests(c["validation"], f"{shape}, validation")
        lines += _table(["shape", "group", "runs", "logged v_x", "v_x on validation terrains"],
                        rows)
        lines += _table(["sample", "pair", "n_a", "n_b", "U", "p (two-sided)"], tests)
        one_sided = [[f"{shape}, {which}", f"{t['a']} > {t['b']}", _n(t["u"], 1), _p_noted(t)]
                     for shape, tests in data.get("one_sided", {}).items()
                     for which, t in tests.items() if t is not None]
        if one_sided:
            lines += ["The paper's own test, one-sided:", ""]
            lines += _table(["sample", "alternative", "U", "p (one-sided)"], one_sided)
        lines += _images(data["files"]["logged"], title + " (logged)")
        lines += _images(data["files"]["validation"], title + " (validation)")
    return lines


def _rho_table(data: dict, reported=None) -> list[str]:
    rows, tests = [], []
    for shape, groups in data["curves"].items():
        for group, g in groups.items():
            start = [m[0] for m in [g["median"]] if m]
            claim = ""
            if reported and group == "homogeneous" and shape in reported:
                claim = reported[shape]["text"]
            rows.append([shape, group, len(g["tasks"]), _n(start[0] if start else None),
                         _n(g["median"][-1] if g["median"] else None), claim])
        tests += _tests(data["end"][shape], shape)
    lines = _table(["shape", "group", "re-optimisations", "median rho at the start",
                    "median rho at the end", "paper"], rows)
    if tests:
        lines += ["rho at the end of the re-optimisation, compared:", ""]
        lines += _table(["shape", "pair", "n_a", "n_b", "U", "p (two-sided)"], tests)
    return lines


def _rho(report: dict) -> list[str]:
    lines = ["## Figures 7 and 8: transferability rho during re-optimisation", "",
             "rho = v_x of the re-optimised robot's best / mean v_x of its two donors, every v_x "
             "the mean over the validation terrains (transfer.csv); the line is the median over "
             "the reassembled robots, the band ± sd. rho = 1 recovers the donors' velocity.", ""]
    lines += [f"### {TITLES['figure7']}", ""]
    lines += _rho_table(report["figure7"], report["figure7"]["paper"])
    lines += _images(report["figure7"]["files"], "Figure 7")
    lines += [f"### {TITLES['figure8']}", "",
              _claim(report["figure8"]["paper"]), ""]
    lines += _rho_table(report["figure8"])
    lines += _images(report["figure8"]["files"], "Figure 8")
    return lines


def _eta(report: dict) -> list[str]:
    data = report["figure9"]
    lines = [f"## {TITLES['figure9']}", "",
             "eta_num: share of the donors' edges that cross modules and are dropped; "
             "eta_weight: the same share of sum(|w| + |b|); pooled over both donors of each "
             "homogeneous reassembly (the authors' count).", "",
             _claim(data["paper"]), ""]
    rows, tests = [], []
    for shape, e in data["eta"].items():
        reported = e.get("paper_omega_1", {})
        for group in e["eta_num"]["groups"]:
            num, weight = e["eta_num"]["groups"][group], e["eta_weight"]["groups"][group]
            claim = ""
            if group == "omega 1" and reported:
                claim = (f"{reported['eta_num']['value']} / {reported['eta_weight']['value']} "
                         f"({reported['eta_num']['where']})")
            rows.append([shape, group, num["n"], _n(num["median"]), _n(weight["median"]), claim])
        tests += _tests(e["eta_num"], f"{shape}, eta_num")
        tests += _tests(e["eta_weight"], f"{shape}, eta_weight")
    lines += _table(["shape", "donors", "reassemblies", "median eta_num", "median eta_weight",
                     "paper (median eta_num / eta_weight)"], rows)
    lines += _table(["sample", "pair", "n_a", "n_b", "U", "p (two-sided)"], tests)
    for which, files in data["files"].items():
        lines += _images(files, f"Figure 9, {which}")
    return lines


def _discovery(report: dict) -> list[str]:
    data = report["discovery"]
    claim = data["summary"]["paper"]
    lines = ["## Figure 12: automatic module discovery", "",
             "Each evolved best partitioned around its most compact module (eq. 5; red in the "
             "figure). A module *spans* when it holds voxels of the body's first and last "
             f"column. {_claim(claim)}", ""]
    rows = [[shape, s["robots"], _n(s["modules"]["median"], 1), _n(s["best_size"]["median"], 1),
             _ms(s["compactness"]), f"{100 * s['spans_front_to_rear']:.0f} %"]
            for shape, s in data["summary"].items() if shape != "paper"]
    lines += _table(["shape", "robots", "median modules", "median size of the most compact",
                     "its compactness", "spans front to rear"], rows)
    rows = [[r["task"], r.get("grid", "missing"), _n(r.get("compactness")) + _tied(r),
             r.get("spans_front_to_rear", "")] for r in data["robots"]]
    lines += _table(["robot", "partition (rows from the top)", "compactness", "spans"], rows)
    return lines + _images(data["files"], "Figure 12")


def _tied(row: dict) -> str:
    """Beside a discovered module's compactness: how many other candidates share it."""
    tied = row.get("tied_with_best")
    if not tied:
        return ""
    others = "1 other candidate" if tied == 1 else f"{tied} other candidates"
    return f" (tied with {others}; the first ranked is taken)"


def _discovered_reassembly(report: dict) -> list[str]:
    lines = [f"## {TITLES['rq3_reassembly']}", ""]
    lines += _rho_table(report["rq3_reassembly"])
    return lines + _images(report["rq3_reassembly"]["files"], "rho along discovered modules")


def _validation(report: dict) -> list[str]:
    data = report["validation"]
    lines = ["## Beyond the paper: every final best on the validation terrains", "",
             f"Each run's final best re-run on the {data['terrains']} fixed validation terrains "
             "(mean v_x), beside its logged v_x (its training draw).", ""]
    rows = [[s["experiment"], s["shape"], s["n"], _ms(s["logged"]), _ms(s["validation"]),
             s["validation_non_finite"]] for s in data["summary"]]
    lines += _table(["experiment", "shape", "robots", "logged v_x", "v_x on validation terrains",
                     "non-finite on a validation terrain"], rows)
    rows = [[r["task"], _n(r["logged"]), _n(r["validation"]), _n(r["logged_validation"])]
            for r in data["robots"]]
    lines += _table(["robot", "logged v_x", "validation v_x (re-run)",
                     "validation v_x (run's own log)"], rows)
    return lines + _images(data["files"], "logged against validation v_x")


def _transfer(report: dict) -> list[str]:
    data = report.get("transfer") or {"present": False, "file": "transfer.csv", "rows": []}
    lines = ["## Transfer: the final bests in 2D-VSR-Sim, the paper's simulator", "",
             "Each run's final best re-run in 2D-VSR-Sim through the authors' controller "
             "(`benchmarks/transfer.py` and the Java driver of "
             "`shared/tools/closed-loop-2dvsrsim/`), with dyn4j as shipped (*stock*) and with "
             "its continuous collision detection off (*noccd*, where it misfires against the "
             "terrain); ratio = v_x there / v_x in somite, on the same terrains.", ""]
    if not data["present"]:
        return lines + [f"*Not measured yet: no `{data['file']}` in the campaign folder "
                        "(columns task, engine, generation, somite_vx, vsr_vx, ratio; one row "
                        "per run and engine, from `benchmarks/transfer.py`).*", ""]
    rows = [[s["experiment"], s["shape"], s["engine"], s["runs"], _n(s["median_ratio"]),
             s["not_finite"]] for s in data["summary"]]
    lines += _table(["experiment", "shape", "engine", "runs", "median ratio",
                     "ratio not finite"], rows)
    rows = [[r["task"] + ("" if r["known"] else " (not a finished run of this campaign)"),
             r["engine"], _n(r["generation"], 0) if r["generation"] is not None else "n/a",
             _n(r["somite_vx"]), _n(r["vsr_vx"]), _n(r["ratio"])] for r in data["rows"]]
    return lines + _table(["run", "engine", "generation", "v_x in somite", "v_x in 2D-VSR-Sim",
                           "ratio"], rows)


def _timelapse(report: dict) -> list[str]:
    lines = ["## Time-lapse of each experiment's best robot", "",
             "The robot with the highest validation v_x of each experiment and shape, on the "
             "first validation terrain (6 snapshots over the episode, left to right).", ""]
    if not report["timelapse"]:
        return lines + ["*No strip drawn.*", ""]
    for strip in report["timelapse"]:
        lines += [f"### {strip['experiment']}, {strip['shape']}: {strip['task']}", "",
                  f"Validation v_x {_n(strip['validation'])} m/s, logged {_n(strip['logged'])} "
                  f"m/s, on {strip['terrain']}.", "",
                  f"![{strip['task']}]({FIGURES}/{strip['file']})", ""]
    return lines


def render_html(text: str, title: str) -> str | None:
    """``text`` as a standalone HTML page, or None without markdown-it."""
    try:
        from markdown_it import MarkdownIt
    except ImportError:
        return None
    body = MarkdownIt("commonmark").enable("table").render(text)
    style = ("body{font-family:sans-serif;max-width:72em;margin:2em auto;padding:0 1em}"
             "table{border-collapse:collapse;font-size:0.85em}td,th{border:1px solid #ccc;"
             "padding:2px 6px}img{max-width:100%}")
    return (f"<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{_escape(title)}"
            f"</title><style>{style}</style></head><body>\n{body}</body></html>\n")


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


__all__ = ["render_html", "render_markdown"]
