"""``index.md`` from report.json's data (and ``index.html`` from it, through markdown-it, which
rich already brings; without it there is no HTML). Numbers only: every one is in report.json.

The head, the tasks, and the sections every run shares (validation, transfer, time-lapses) are
written here; each experiment kind's between them, by its section (:mod:`.sections`)."""

from __future__ import annotations

from ..analysis.stats import MIN_GROUP_SIZE
from ..campaigns.figures import FIGURES as DECLARABLE
from . import sections
from .._visible import visible
from .text import FIGURES, images, median_sd, number, plain, table
from .transfer import NEAR_ZERO


def render_markdown(report: dict) -> str:
    lines: list[str] = []
    kinds = [sections.SECTIONS[kind].render for kind in sections.shown(report)]
    for part in (_head, _status, *kinds, _validation, _transfer, _timelapse):
        lines += part(report)
    return "\n".join(lines).rstrip() + "\n"


def _head(report: dict) -> list[str]:
    c = report["campaign"]
    return [
        f"# Campaign report: {plain(c['name'])}", "",
        *_banner(report),
        f"Campaign `{_code(c['directory'])}` ({plain(c['source'] or 'no source recorded')}), "
        "written by "
        "`somite report`. Every number below is also in `report.json`; figures are in "
        "`figures/` as PNG and SVG. Medians and standard deviations (ddof 0) are across runs; "
        "p-values are two-sided Mann-Whitney U tests (scipy), but for Figure 5's one-sided "
        "test (the paper's), which its table and images name as such; a p-value of a group "
        "of fewer "
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
    lines += table(["experiment", "title", "paper", "tasks", "finished", "missing"], rows)
    for task, why in report["status"]["unreadable"].items():
        lines.append(f"- {task}: finished but unreadable, shown as missing ({plain(why)})")
    if report["status"]["unreadable"]:
        lines.append("")
    return lines + _missing_figures(report)


ALWAYS_SHOWN = {"table1": "Table 1 shows every evolve experiment"}
"""Figures shown whether an experiment declares them or not: a declaration puts the paper's
numbers beside an experiment's."""


def left_empty(missing: dict) -> dict:
    """The figures of report.json's ``figures.missing`` that the report leaves empty (those
    of :data:`ALWAYS_SHOWN` it shows without the paper's numbers)."""
    return {name: why for name, why in missing.items() if name not in ALWAYS_SHOWN}


def _missing_figures(report: dict) -> list[str]:
    """A line for the figures no experiment of the campaign feeds, and why (report.json's
    ``figures.missing``; an experiment declares them in its ``figures`` table), and one for
    the sections left out, of the kinds no experiment has (their figures are not repeated)."""
    kinds = sections.shown(report)
    missing = {name: why for name, why in
               ((report.get("figures") or {}).get("missing") or {}).items()
               if name not in DECLARABLE or DECLARABLE[name].kind in kinds}
    lines = []
    if (report.get("figures") or {}).get("declared") is False:
        lines += ["Figures: not declared (no experiment of the campaign file has a `figures` "
                  "table; docs/guide.md, Campaigns). Shown: every evolve experiment in Table 1 "
                  "and Figures 3 and 5, a group per experiment and variant, and every "
                  "reassembly in Figure 7, under their own names; none beside the paper's "
                  "numbers.", ""]
    for name, shown in ALWAYS_SHOWN.items():
        if name in missing:
            lines += [f"{shown}, the paper's row beside none ({name}: {missing[name]}).", ""]
    missing = left_empty(missing)
    if missing:
        reasons = "; ".join(f"{name}: {why}" for name, why in missing.items())
        lines += [f"Figures no experiment feeds (declared by an experiment's `figures` table "
                  f"in the campaign file), left empty: {reasons}.", ""]
    absent = [kind for kind in sections.SECTIONS if kind not in kinds]
    if absent:
        lines += [f"The campaign has no {' or '.join(absent)} experiment: the report leaves "
                  "out their sections.", ""]
    return lines


def _validation(report: dict) -> list[str]:
    data = report["validation"]
    robots = data["robots"]
    # Reports written before the fresh re-runs (or with --fresh 0) have none: no column.
    fresh = bool(robots) and all("fresh" in r for r in robots)
    lines = ["## Beyond the paper: every final best on the validation terrains", "",
             f"Each run's final best re-run on the {data['terrains']} fixed validation terrains "
             "(mean v_x), beside its logged v_x (its training draw)."
             + (_fresh_sentence(robots[0]) if fresh else ""), ""]
    rows = [[s["experiment"], s["shape"], s["n"], median_sd(s["logged"]),
             median_sd(s["validation"]), s["validation_non_finite"]]
            + ([median_sd(s["fresh"]), s["fresh_non_finite"]] if fresh else [])
            for s in data["summary"]]
    lines += table(["experiment", "shape", "robots", "logged v_x", "v_x on validation terrains",
                    "non-finite on a validation terrain"]
                   + (["v_x on fresh terrains", "non-finite on a fresh terrain"] if fresh
                      else []), rows)
    # Reports written before the ratio was kept have none: no column.
    ratio = bool(robots) and all("logged_over_validation" in r for r in robots)
    rows = [[r["task"], number(r["logged"]), number(r["validation"]),
             number(r["logged_validation"])] + ([number(r["fresh"])] if fresh else [])
            + ([number(r["logged_over_validation"], 2)] if ratio else [])
            for r in robots]
    lines += table(["robot", "logged v_x", "validation v_x (re-run)",
                    "validation v_x (run's own log)"]
                   + (["v_x on fresh terrains"] if fresh else [])
                   + (["logged / validation"] if ratio else []), rows)
    if ratio:
        lines += ["logged / validation: how many times its validation v_x a robot's logged v_x "
                  "is, above 1 by the luck of its training draw (n/a where the validation v_x "
                  "is not positive).", ""]
    return lines + images(data["files"], "logged against validation v_x")


def _fresh_sentence(robot: dict) -> str:
    names = robot["fresh_terrains"]
    return (f" And on {len(names)} fresh terrains ({names[0]} on: neither training nor "
            "validation terrains, which a run logs its best on and the report picks the robots "
            f"it draws by) under sensor noise of seed {robot['fresh_noise_seed']} (the "
            "validation episodes draw seed 0): the robots' speed where nothing chose them.")


def _transfer(report: dict) -> list[str]:
    data = report.get("transfer") or {"present": False, "file": "transfer.csv", "rows": []}
    lines = ["## Transfer: the final bests in 2D-VSR-Sim, the paper's simulator", "",
             "Each run's final best re-run in 2D-VSR-Sim through the authors' controller "
             "(`benchmarks/transfer.py` and the Java driver of "
             "`shared/tools/closed-loop-2dvsrsim/`), with dyn4j as shipped (*stock*) and with "
             "its continuous collision detection off (*noccd*, where it misfires against the "
             "terrain), on the same terrains, the driver reading the authors' code's sensors "
             "(*code*) or the run's own preset's (*own*, a variant of the driver). somite "
             "re-runs each best on the sensors the driver read: ratio = v_x in 2D-VSR-Sim / v_x "
             "in somite on the same sensors, the physics alone; overall = v_x in 2D-VSR-Sim / "
             "v_x in somite on the run's own sensors, what the robot keeps of its speed there "
             "(with *own*, the same number).", ""]
    if not data["present"]:
        return lines + [f"*Not measured yet: no `{data['file']}` in the campaign folder "
                        "(columns task, engine, sensors, generation, somite_vx, vsr_vx, ratio, "
                        "somite_own_vx, overall_ratio; one row per run, engine and sensors, from "
                        "`benchmarks/transfer.py`).*", ""]
    rows = [[s["experiment"], s["shape"], s["engine"], s.get("sensors", "code"), s["runs"],
             number(s["median_ratio"]), number(s.get("median_overall_ratio")), s["not_finite"],
             s.get("near_zero", "n/a")]
            for s in data["summary"]]
    lines += table(["experiment", "shape", "engine", "sensors", "runs",
                    "median ratio (physics)", "median overall ratio", "ratio not finite",
                    "ratio over a v_x near 0"], rows)
    rows = [[r["task"] + ("" if r["known"] else " (not a finished run of this campaign)"),
             r["engine"], r.get("sensors", "code"),
             number(r["generation"], 0) if r["generation"] is not None else "n/a",
             number(r.get("somite_own_vx")), number(r["somite_vx"]), number(r["vsr_vx"]),
             _flagged(r["ratio"], r.get("ratio_near_zero")),
             _flagged(r.get("overall_ratio"), r.get("overall_near_zero"))] for r in data["rows"]]
    if any(r.get("ratio_near_zero") or r.get("overall_near_zero") for r in data["rows"]):
        lines += [f"A ratio marked *near 0* divides by a v_x in somite under {NEAR_ZERO} m/s in "
                  "magnitude: centimetres of difference make it large, or negative; it says "
                  "little of the physics.", ""]
    return lines + table(["run", "engine", "sensors", "generation",
                          "v_x in somite, own sensors", "v_x in somite, the sensors read",
                          "v_x in 2D-VSR-Sim", "ratio (physics)", "overall ratio"], rows)


def _flagged(ratio, near_zero) -> str:
    """A ratio's cell, marked where its denominator is near zero."""
    return number(ratio) + (" (*near 0*)" if near_zero and ratio is not None else "")


def _timelapse(report: dict) -> list[str]:
    lines = ["## Time-lapse of each experiment's best robot", "",
             "The robot with the highest validation v_x of each experiment and shape, on the "
             "first validation terrain (6 snapshots over the episode, left to right); its "
             "replay page (one HTML file, for a browser) plays the whole episode.", ""]
    if not report["timelapse"]:
        lines += ["*No strip drawn.*", ""]
    for strip in report["timelapse"]:
        lines += [f"### {strip['experiment']}, {strip['shape']}: {strip['task']}", "",
                  f"Validation v_x {number(strip['validation'])} m/s, logged "
                  f"{number(strip['logged'])} m/s, on {strip['terrain']}.", "",
                  f"![{strip['task']}]({FIGURES}/{strip['file']})", "",
                  f"Gait: {strip['gait']}. [Replay page]({FIGURES}/{strip['replay']}).", ""]
    return lines + _under_way_strips(report)


def _under_way_strips(report: dict) -> list[str]:
    """The best so far of each run under way (an interim report), after the finished ones."""
    lines = []
    for task, run in ((report.get("status") or {}).get("under_way") or {}).items():
        strip = run.get("strip")
        if strip is None:
            continue
        lines += [f"### Under way: {task}, its best at generation {strip['generation']}", "",
                  f"Logged v_x {number(strip['logged'])} m/s (its generation's draw), on "
                  f"{strip['terrain']}.", "",
                  f"![{task}]({FIGURES}/{strip['file']})", "",
                  f"Gait: {strip['gait']}. [Replay page]({FIGURES}/{strip['replay']}).", ""]
    return lines


def render_html(text: str, title: str) -> str | None:
    """``text`` as a standalone HTML page, or None without markdown-it."""
    try:
        from markdown_it import MarkdownIt
    except ImportError:
        return None
    # Raw HTML off: a title or label of a campaign file (or a pack) is shown as text, never
    # run as a script; markdown-it also refuses javascript: and data: links.
    body = MarkdownIt("commonmark", {"html": False}).enable("table").render(text)
    style = ("body{font-family:sans-serif;max-width:72em;margin:2em auto;padding:0 1em}"
             "table{border-collapse:collapse;font-size:0.85em}td,th{border:1px solid #ccc;"
             "padding:2px 6px}img{max-width:100%}")
    title = _escape(visible(title))
    return (f"<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{title}"
            f"</title><style>{style}</style></head><body>\n{body}</body></html>\n")


def _code(text: str) -> str:
    """A path inside a code span: a backtick would end it."""
    return visible(text).replace("`", "'")


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


__all__ = ["render_html", "render_markdown"]
