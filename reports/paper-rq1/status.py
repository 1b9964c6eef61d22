"""Write STATUS.md: where each run of the paper-rq1 campaign stands, from its log.csv.

    python reports/paper-rq1/status.py [CAMPAIGN_DIR]   (default: reports/paper-rq1/campaign)

Per run: the last logged generation, its best v_x (the luckiest draw of that generation's
terrain and noise), the last validation v_x (the same best re-run on the fixed validation
terrains, every 50 generations) and |G| (nodes + edges of the best)."""

from __future__ import annotations

import csv
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def rows(campaign: Path):
    for log in sorted(campaign.glob("*/*/log.csv")):
        with log.open() as f:
            lines = list(csv.DictReader(f))
        if not lines:
            continue
        last = lines[-1]
        validated = [line for line in lines if line["validation_velocity"]]
        check = validated[-1] if validated else None
        yield (str(log.parent.relative_to(campaign)), int(last["generation"]),
               float(last["best_velocity"]),
               f"{float(check['validation_velocity']):.2f} (gen {check['generation']})"
               if check else "-", int(last["best_size"]))


def main() -> None:
    campaign = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE / "campaign"
    lines = ["# paper-rq1: where each run stands at the last pack", "",
             "| run | generation | logged best v_x [m/s] | validation v_x [m/s] | G |",
             "|---|---|---|---|---|"]
    lines += [f"| {run} | {gen}/3000 | {best:.2f} | {check} | {size} |"
              for run, gen, best, check, size in rows(campaign)]
    lines += ["", "Runs not listed have not started. Logged best: the generation's luckiest "
              "draw; validation: the best re-run on the fixed validation terrains."]
    target = HERE / "STATUS.md"
    temporary = target.with_suffix(".tmp")
    temporary.write_text("\n".join(lines) + "\n")
    temporary.replace(target)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
