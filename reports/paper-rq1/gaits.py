"""The gaits of the twelve paper-rq1 finals as `somite gait` sees them, and how their feet slide.

    python reports/paper-rq1/gaits.py CAMPAIGN [--terrain hilly-1-10-10000 ...] [--out DIR]
                                      [--runs TASK ...]
                                      (run with hilly-1-10-10000, -10001 and -10002)

CAMPAIGN: the unpacked pack (``somite campaign unpack reports/paper-rq1/paper-rq1.pack --out
DIR``). Each final's ``best.json`` runs one episode of its run's settings (30 s, the ``paper``
preset, noise seed 0) on each ``--terrain`` (default the first validation terrain), recorded, and
gets ``somite gait``'s analysis (:func:`somite.analysis.gait.analyse_gait`, the numbers of
``somite gait RUN --terrain T --json``), in one process so that the kernel loads once. Added:
``sliding``, over the analysed interval, of the control steps in which a corner is on the
ground at both ends, the share in which it moves along x faster than 1 m/s (a foot that
slides rather than grips), and ``ground_steps``, how many there are. The JSON of each run goes
to ``OUT/TERRAIN/EXPERIMENT-SHAPE-sSEED.json`` (default ``OUT``: ``reports/paper-rq1/gaits/``;
kept when there, written whole or not at all) and one line a run and terrain is printed.
``--runs`` names other finished evolve tasks than the twelve of paper-rq1, e.g. the omega
runs of ``reports/paper/``:

    python reports/paper-rq1/gaits.py CAMPAIGN --out reports/paper/gaits \
        --terrain hilly-1-10-10000 hilly-1-10-10001 hilly-1-10-10002 \
        --runs omega-10/biped-s0 omega-10/worm-s0
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from somite._io import write_atomic
from somite.analysis.gait import analyse_gait
from somite.brain.genome import Genome
from somite.experiments.config import resolve
from somite.sim.config import CONTROL_HZ
from somite.viz.video import record_episode

RUNS = tuple(f"{e}/{shape}-s{seed}" for e in ("rq1", "ablation") for shape in ("biped", "worm")
             for seed in (0, 1, 2))
SLIDING = 1.0  # [m/s]


def gait(run: Path, terrain: str) -> dict:
    config = resolve(json.loads((run / "config.json").read_text()))
    genome = Genome.load(run / "best.json")
    recording = record_episode(genome.body, genome, terrain, config.setup.sim, 0)
    found = analyse_gait(recording)
    first = int(round(found.start * CONTROL_HZ))
    x = recording.pos[first:, :, 0]
    touching = recording.contact[first:-1] & recording.contact[first + 1:]
    speed = np.abs(np.diff(x, axis=0)) * CONTROL_HZ
    return {"run": str(run.relative_to(run.parents[1])), "terrain": terrain,
            **found.to_dict(), "ground_steps": int(touching.sum()),
            "sliding": float((speed[touching] > SLIDING).mean()) if touching.any() else None}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("campaign", type=Path)
    parser.add_argument("--terrain", nargs="+", default=["hilly-1-10-10000"], metavar="TERRAIN")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "gaits")
    parser.add_argument("--runs", nargs="+", default=list(RUNS), metavar="TASK",
                        help="finished evolve tasks (default: paper-rq1's twelve)")
    args = parser.parse_args()
    for run in args.runs:
        if not (args.campaign / run / "done.json").is_file():
            parser.error(f"--runs: {run!r} has not finished in {args.campaign} "
                         "(no done.json)")
    for terrain in args.terrain:
        (args.out / terrain).mkdir(parents=True, exist_ok=True)
        for run in args.runs:
            show(args.campaign, run, terrain, args.out / terrain / f"{run.replace('/', '-')}.json")


def show(campaign: Path, run: str, terrain: str, target: Path) -> None:
    """Print ``run``'s gait line on ``terrain``, analysing it into ``target`` unless there."""
    if not target.exists():
        write_atomic(target, json.dumps(gait(campaign / run, terrain), indent=1) + "\n")
    g = json.loads(target.read_text())
    bottom = [v["duty_factor"] for v in g["voxels"] if v["y"] == 0]
    print(f"{run:18} {terrain}  v_x {g['velocity']:5.2f}  {g['frequency_hz']:5.2f} Hz  stride "
          f"{g['stride_frequency_hz']:5.2f} Hz  bottom duty {min(bottom):.2f}-"
          f"{max(bottom):.2f}  sliding {g['sliding']:.2f}  {g['pattern']}: "
          f"{g['description']}", flush=True)


if __name__ == "__main__":
    main()
