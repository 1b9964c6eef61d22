"""Write STATUS.md: where each task of the paper campaign stands, from its folder.

    python reports/paper/status.py [CAMPAIGN_DIR]   (default: reports/paper/campaign)

Per task, what ``somite campaign status`` reads from the disk: its state, the generation a
run (evolution or re-optimisation) has logged, its logged best v_x (the luckiest draw of a
generation's terrains and noise), its last validation v_x (a reassembly's: the reassembled
robot's, before re-optimisation). Then the robot-control-steps done and left, and the hours
left at the runs' recent pace, one task at a time and two at a time (this machine's 2 cores).
The 12 RQ1 and ablation runs (from paper-rq1, finished) are summed up in one line.
"""

from __future__ import annotations

import sys
from pathlib import Path

from somite.campaigns import directory as campaign_dir
from somite.campaigns.progress import seconds_left, snapshot, states

HERE = Path(__file__).resolve().parent
FROM_RQ1 = ("rq1", "ablation")


def _cell(value, digits: int = 3) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def table(doc: dict, infos: list[dict]) -> list[str]:
    lines = ["| task | kind | state | generation | logged best v_x | validation v_x |",
             "|---|---|---|---|---|---|"]
    for task, info in zip(doc["tasks"], infos):
        if task["experiment"] in FROM_RQ1:
            continue
        generation = "-" if info["generations"] is None else \
            f"{info['generation'] if info['generation'] is not None else '-'}" \
            f"/{info['generations']}"
        lines.append(f"| {task['id']} | {task['kind']} | {info['state']} | {generation} | "
                     f"{_cell(info['best'])} | {_cell(info['validation'])} |")
    return lines


def main() -> None:
    campaign = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE / "campaign"
    doc = campaign_dir.read(campaign)
    infos = states(campaign, doc)
    now = snapshot(doc, infos)
    rq1 = [i for t, i in zip(doc["tasks"], infos) if t["experiment"] in FROM_RQ1]
    left = seconds_left(doc, infos)
    hours = "-" if not left else f"{left / 3600:.0f} h one task at a time, " \
        f"{left / 7200:.0f} h two at a time"
    lines = ["# paper: where each task stands at the last pack", "",
             f"Campaign `{doc['name']}` ({doc['source']}), {len(doc['tasks'])} tasks: " +
             ", ".join(f"{n} {k}" for k, n in now.counts.items()) + ".",
             f"Robot-control-steps: {now.steps[0]:.3g} of {now.steps[1]:.3g} "
             f"({now.fraction:.1%}); left at the runs' recent pace: {hours}.",
             "",
             f"RQ1 and its ablation (from paper-rq1): {sum(i['state'] == 'done' for i in rq1)} "
             f"of {len(rq1)} runs done (reports/paper-rq1/STATUS.md).", "",
             *table(doc, infos), ""]
    (HERE / "STATUS.md").write_text("\n".join(lines))
    print(f"wrote {HERE / 'STATUS.md'}")


if __name__ == "__main__":
    main()
