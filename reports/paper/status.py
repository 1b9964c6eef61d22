"""Write STATUS.md: where each task of the paper campaign stands, from its folder.

    python reports/paper/status.py [CAMPAIGN_DIR]   (default: reports/paper/campaign)

Per task, what ``somite campaign status`` reads from the disk: its state, the generation a
run (evolution or re-optimisation) has logged, its logged best v_x (the luckiest draw of a
generation's terrains and noise), its last validation v_x (a reassembly's: the reassembled
robot's, before re-optimisation) and, for a reassembly and its re-optimisation, rho: that v_x
over the mean of the donors' v_x on the same terrains (the reassembly's report.json), as the
report's Figures 7 and 8 read it at the end. Then the robot-control-steps done and left, and
the hours left at the runs' recent pace, one task at a time and two at a time (this machine's
2 cores).
The 12 RQ1 and ablation runs (from paper-rq1, finished) are summed up in one line, and the
finished runs that still lack ``check-finished.sh``'s checks are named with its command.
"""

from __future__ import annotations

import json
import statistics
import sys
from pathlib import Path

from somite.campaigns import directory as campaign_dir
from somite.campaigns.kinds import estimate
from somite.campaigns.progress import seconds_left, snapshot, states

HERE = Path(__file__).resolve().parent
FROM_RQ1 = ("rq1", "ablation")


def _cell(value, digits: int = 3) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def donors_mean(campaign: Path, task: dict) -> float | None:
    """The mean of the donors' validation v_x of a reassembly (or of the reassembly a
    re-optimisation starts from), from its report.json."""
    start = task["options"].get("start") if task["kind"] == "reoptimize" else task["id"]
    report = campaign / str(start) / "report.json"
    if task["kind"] not in ("reassemble", "reoptimize") or not report.is_file():
        return None
    validation = json.loads(report.read_text())["validation"]
    return (validation["v_donor1"] + validation["v_donor2"]) / 2


def table(campaign: Path, doc: dict, infos: list[dict]) -> list[str]:
    lines = ["| task | kind | state | generation | logged best v_x | validation v_x | rho |",
             "|---|---|---|---|---|---|---|"]
    for task, info in zip(doc["tasks"], infos):
        if task["experiment"] in FROM_RQ1:
            continue
        generation = "-" if info["generations"] is None else \
            f"{info['generation'] if info['generation'] is not None else '-'}" \
            f"/{info['generations']}"
        donors = donors_mean(campaign, task)
        rho = None if donors is None or info["validation"] is None else \
            info["validation"] / donors
        lines.append(f"| {task['id']} | {task['kind']} | {info['state']} | {generation} | "
                     f"{_cell(info['best'])} | {_cell(info['validation'])} | {_cell(rho)} |")
    return lines


def checks_line(tasks: list[str]) -> str:
    if not tasks:
        return "Every finished run has its checks (2D-VSR-Sim, fresh terrains, ground gap)."
    return ("Finished runs still without their checks: " + ", ".join(tasks) + " (`CAMPAIGN="
            "reports/paper/campaign sh reports/paper-rq1/check-finished.sh " + " ".join(tasks)
            + "`, README beside this file).")


def unchecked(campaign: Path, doc: dict, infos: list[dict]) -> list[str]:
    """The finished runs (evolutions, re-optimisations) without check-finished.sh's checks
    (their 20 fresh terrains' file is its last)."""
    return [task["id"] for task, info in zip(doc["tasks"], infos)
            if task["kind"] in ("evolve", "reoptimize") and info["state"] == "done"
            and not (campaign / "checks" / f"{task['id'].replace('/', '-')}-fresh.json").is_file()]


def pace_now(doc: dict, infos: list[dict], steps_left: float) -> tuple[float, float] | None:
    """The median pace (robot-control-steps a second) of the runs going now (running or
    partial, over their last generations), and the seconds ``steps_left`` take at it one at a
    time; None where no run is going. The campaign's own figure takes the median over every
    run it has timed, most of them on older kernels or beside other work."""
    paces = [estimate(t) / i["generations"] / i["seconds_per_generation"]
             for t, i in zip(doc["tasks"], infos)
             if i["state"] in ("running", "partial") and i.get("seconds_per_generation")
             and i["generations"]]
    if not paces:
        return None
    pace = statistics.median(paces)
    return pace, steps_left / pace


def main() -> None:
    campaign = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE / "campaign"
    doc = campaign_dir.read(campaign)
    infos = states(campaign, doc)
    now = snapshot(doc, infos)
    rq1 = [i for t, i in zip(doc["tasks"], infos) if t["experiment"] in FROM_RQ1]
    left = seconds_left(doc, infos)
    hours = "-" if not left else f"{left / 3600:.0f} h one task at a time, " \
        f"{left / 7200:.0f} h two at a time"
    going = pace_now(doc, infos, now.steps[1] - now.steps[0])
    if going:
        hours += (f" (at the pace of the runs going now, {going[0] / 1e3:.0f}k "
                  f"robot-control-steps a second each: {going[1] / 7200:.0f} h two at a time)")
    lines = ["# paper: where each task stands at the last pack", "",
             f"Campaign `{doc['name']}` ({doc['source']}), {len(doc['tasks'])} tasks: " +
             ", ".join(f"{n} {k}" for k, n in now.counts.items()) + ".",
             f"Robot-control-steps: {now.steps[0]:.3g} of {now.steps[1]:.3g} "
             f"({now.fraction:.1%}); left at the runs' recent pace: {hours}.",
             "",
             f"RQ1 and its ablation (from paper-rq1): {sum(i['state'] == 'done' for i in rq1)} "
             f"of {len(rq1)} runs done (reports/paper-rq1/STATUS.md).", "",
             checks_line(unchecked(campaign, doc, infos)), "",
             *table(campaign, doc, infos), ""]
    (HERE / "STATUS.md").write_text("\n".join(lines))
    print(f"wrote {HERE / 'STATUS.md'}")


if __name__ == "__main__":
    main()
