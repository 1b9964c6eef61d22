"""Write STATUS.md: where each run of the paper-rq1 campaign stands, from its log.csv.

    python reports/paper-rq1/status.py [CAMPAIGN_DIR]   (default: reports/paper-rq1/campaign)

Per run: the last logged generation, its best v_x (the luckiest draw of that generation's
terrain and noise), the last validation v_x (the same best re-run on the fixed validation
terrains, every 50 generations), |G| (nodes + edges of the best) and the seconds its last 100
generations took here (``elapsed_seconds`` of the log: one core each, shared with whatever else
ran; see :data:`ELSEWHERE`).
From the rates, the remaining cost of the whole campaign (3 seeds), twice: at each run's
fastest 100 generations among its last 500 (the closest to an idle machine) and at its latest
100 (the machine as shared lately)."""

from __future__ import annotations

import csv
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
GENERATIONS = 3000
RUNS = [f"{variant}/{shape}-s{seed}" for variant in ("rq1", "ablation")
        for shape in ("biped", "worm") for seed in range(3)]
"""Every run of the built-in paper-rq1 campaign (3 seeds)."""
RECENT = 100
WINDOW = 500
ELSEWHERE = {"ablation/biped-s0": 215, "ablation/worm-s0": 194}
"""Runs whose first generations, up to these, were computed on another machine (16 cores, 7
Numba threads a run: README.md): their rates are not this machine's, so a run's rate is read
from its later rows only."""


def rows(campaign: Path):
    for log in sorted(campaign.glob("*/*/log.csv")):
        with log.open() as f:
            lines = list(csv.DictReader(f))
        if not lines:
            continue
        last = lines[-1]
        run = str(log.parent.relative_to(campaign))
        validated = [line for line in lines if line["validation_velocity"]]
        check = validated[-1] if validated else None
        here = [line for line in lines if int(line["generation"]) > ELSEWHERE.get(run, -1)]
        elapsed = [float(line["elapsed_seconds"]) for line in here[-WINDOW - 1:]]
        rates = [(elapsed[i + RECENT] - elapsed[i]) / RECENT
                 for i in range(0, len(elapsed) - RECENT, 10)]
        rate = ((elapsed[-1] - elapsed[-RECENT - 1]) / RECENT, min(rates)) if rates else None
        yield (run, int(last["generation"]),
               float(last["best_velocity"]),
               f"{float(check['validation_velocity']):.2f} (gen {check['generation']})"
               if check else "-", int(last["best_size"]), rate)


def remaining_hours(found: list[tuple], which: int) -> float | None:
    """Core-hours left for every run of the campaign at rate ``which`` (0: the latest, 1: the
    fastest): a started run's generations left at its own rate, a run not started at the
    slowest rate of a started run of its shape (the graph runs' also for the weights-only ones,
    whose graphs stay small: an upper bound); None when a shape has no rate yet."""
    by_run = {run: (gen, rate[which] if rate else None) for run, gen, _, _, _, rate in found}
    by_shape = {}
    for run, (_, rate) in by_run.items():
        if rate is not None:
            by_shape.setdefault(run.split("/")[1].split("-")[0], []).append(rate)
    seconds = 0.0
    for run in RUNS:
        gen, rate = by_run.get(run, (0, None))
        shape = run.split("/")[1].split("-")[0]
        if rate is None:
            if shape not in by_shape:
                return None
            rate = max(by_shape[shape])
        seconds += (GENERATIONS - gen) * rate
    return seconds / 3600


def main() -> None:
    campaign = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE / "campaign"
    found = list(rows(campaign))
    lines = ["# paper-rq1: where each run stands at the last pack", "",
             "| run | generation | logged best v_x [m/s] | validation v_x [m/s] | G | "
             f"s a generation (last {RECENT}) |",
             "|---|---|---|---|---|---|"]
    lines += [f"| {run} | {gen}/{GENERATIONS} | {best:.2f} | {check} | {size} | "
              + (f"{rate[0]:.1f} |" if rate is not None else "- |")
              for run, gen, best, check, size, rate in found]
    done = sum(gen for _, gen, *_ in found)
    lines += ["", "Runs not listed have not started. Logged best: the generation's luckiest "
              "draw; validation: the best re-run on the fixed validation terrains.", "",
              f"Generations done: {done} of {GENERATIONS * len(RUNS)} "
              f"({100 * done / (GENERATIONS * len(RUNS)):.1f}% of the {len(RUNS)} runs)."]
    fast, latest = remaining_hours(found, 1), remaining_hours(found, 0)
    # Two cores run two unfinished runs side by side, but a last run alone gains from the second
    # core only through its threads, which its measured seconds a generation already show.
    unfinished = len(RUNS) - sum(gen >= GENERATIONS for _, gen, *_ in found)
    cores = max(1, min(2, unfinished))
    if fast is not None and latest is not None:
        lines += [f"Remaining cost: about {fast / cores:.1f} h of 2 cores at each run's fastest "
                  f"{RECENT} generations of its last {WINDOW} (the closest to an idle machine), "
                  f"{latest / cores:.1f} h at its latest {RECENT} (the machine shared as lately)."]
    target = HERE / "STATUS.md"
    temporary = target.with_suffix(".tmp")
    temporary.write_text("\n".join(lines) + "\n")
    temporary.replace(target)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
