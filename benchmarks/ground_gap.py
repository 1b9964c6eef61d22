"""How deep block corners go into the ground, in somite and in 2D-VSR-Sim, for the same robots.

Evolution finds the physics' artefacts: a robot whose blocks sink into the ground, or into an
end wall, where the paper's simulator would stop them, walks on something that is not there.
This measures, per control step after the first 2 s, the robot's lowest block corner's height
above the terrain's line at that corner's x (somite's ``min_height`` diagnostic, step by step;
< 0: a corner inside the ground or, at the steep end walls, 10 m across for 100 m up, a corner
a tenth as far inside as it reads), in somite and in 2D-VSR-Sim (the variant driver's
``CL dump`` with ``GAP=1``), for each genome, terrain and engine: dyn4j as shipped
(``classes-dyn4j``) and without its continuous collision detection (``classes-dyn4j-noccd``),
the engine somite matches (benchmarks/reference/closed-loop/README.md). Both sides read the
run's own sensors at noise sigma 0, so they read the same numbers (the driver's noise stream
cannot be matched), on the driver's episode (30 s, v_x from 5 s).

Prints JSON: per genome, terrain and engine, ``start_min`` (the lowest gap in [2 s, 5 s], the
unscored start, where a robot may back against the left wall), ``min``, ``p1`` (1st
percentile) and ``below_5cm`` (share of steps under -0.05 m) in [5 s, 30 s], and v_x; per
genome and engine the medians of those over the terrains.

    python benchmarks/ground_gap.py RUN [RUN ...] [--terrains validation|NAME,...]
                                    [--engines classes-dyn4j,classes-dyn4j-noccd] [--vsr PATH]
                                    [--export PATH]

A RUN is a run directory (its ``best.json``, the last generation's best) or a saved genome
(``somite evolve``'s ``best.json``, run with the ``paper`` preset). Needs the driver built with
the variant of ``benchmarks/reference/closed-loop/variant-paper-sensors/`` (its README).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from transfer import (  # noqa: E402
    DEFAULT_EXPORT,
    DRIVER_DURATION,
    DRIVER_TRANSIENT,
    DYN4J,
    _last_line,
    check_export,
    driver_config,
    driver_sensors,
    find_java,
    parse_terrains,
)

from somite._io import parse_json, read_text  # noqa: E402
from somite.brain.genome import Genome  # noqa: E402
from somite.errors import SomiteError, bad  # noqa: E402
from somite.experiments.config import resolve  # noqa: E402
from somite.sim.config import CONTROL_HZ  # noqa: E402
from somite.tasks.episode import D_MIN_GAP, SETTLE_STEPS  # noqa: E402
from somite.tasks.stepper import Episode  # noqa: E402

ENGINES = (DYN4J, "classes-dyn4j-noccd")
BELOW = -0.05
"""A corner this far under the terrain's line [m] counts as into the ground."""


def load_genome(path: str) -> tuple[Genome, dict]:
    """A run directory's best (with its config) or a saved genome (the paper preset)."""
    folder = Path(path)
    config = {"preset": "paper"}
    if folder.is_dir():
        if not (folder / "best.json").is_file():
            raise bad("run", path, "no best.json in it (a run directory of somite evolve)")
        config = parse_json(read_text(folder / "config.json", "run"), "run",
                            str(folder / "config.json"))
        folder = folder / "best.json"
    try:
        return Genome.load(folder), config
    except (SomiteError, OSError, ValueError) as error:
        raise bad("run", path, f"not a genome ({error})") from None


def somite_gaps(genome: Genome, terrain, config) -> tuple[np.ndarray, float]:
    """The lowest corner's gap at every control step after the settling ones, and v_x."""
    episode = Episode([genome], terrain, config, seeds=0)
    gaps = []
    while not episode.done:
        episode.step()
        if episode.k > SETTLE_STEPS:
            gaps.append(float(episode.diagnostics[0, D_MIN_GAP]))
            # The diagnostic is a running minimum: reset it to read the next step's alone.
            episode._trace.diagnostics[0, D_MIN_GAP] = math.inf
    com = episode.trace.com[0, :, 0]
    first = int(round(DRIVER_TRANSIENT * CONTROL_HZ))
    return np.asarray(gaps), float((com[-1] - com[first]) / (DRIVER_DURATION - DRIVER_TRANSIENT))


def driver_gaps(exported: Path, terrain: str, sensors: str, hidden: str,
                java: tuple[str, str], tmp: Path) -> tuple[np.ndarray, np.ndarray, float]:
    """2D-VSR-Sim's lowest gap and times at every control step, and v_x (``CL dump``)."""
    executable, classpath = java
    out = tmp / "dump.csv"
    env = {**os.environ, "GAP": "1", "SENSORS": sensors, "HIDDEN": hidden}
    done = subprocess.run([executable, "-cp", classpath, "CL", "dump", str(exported), "best",
                           terrain, "0", str(out)], capture_output=True, text=True, env=env)
    if done.returncode != 0 or not out.is_file():
        raise bad("vsr", classpath, f"the driver failed: {_last_line(done.stderr)}")
    rows = np.loadtxt(out, delimiter=",", ndmin=2)
    vx = float(done.stdout.split("vx=")[1].split()[0])
    return rows[:, -1], rows[:, 1], vx


def summary(gaps: np.ndarray, times: np.ndarray, vx: float) -> dict:
    start = gaps[(times > SETTLE_STEPS / CONTROL_HZ) & (times <= DRIVER_TRANSIENT)]
    scored = gaps[times > DRIVER_TRANSIENT]
    return {"start_min": float(start.min()), "min": float(scored.min()),
            "p1": float(np.percentile(scored, 1)),
            "below_5cm": float(np.mean(scored < BELOW)), "vx": vx}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+")
    parser.add_argument("--terrains", default="validation")
    parser.add_argument("--engines", default=",".join(ENGINES))
    parser.add_argument("--vsr", default=os.environ.get("VSR"))
    parser.add_argument("--export", default=str(DEFAULT_EXPORT))
    args = parser.parse_args(argv)
    try:
        terrains = parse_terrains(args.terrains)
        engines = [e.strip() for e in args.engines.split(",") if e.strip()]
        javas = {e: find_java(args.vsr, e, "own") for e in engines}
        export = check_export(args.export)
        report = []
        for path in args.runs:
            genome, saved = load_genome(path)
            config = driver_config(resolve(saved), "own").with_options(noise_sigma=0.0)
            sensors = driver_sensors(config, path)
            with tempfile.TemporaryDirectory(prefix="somite-gap-") as folder:
                tmp = Path(folder)
                source = tmp / "genome.jsonl"
                source.write_text(json.dumps({"name": "best", "genome": genome.to_dict()}) + "\n")
                done = subprocess.run([sys.executable, str(export), str(source)],
                                      capture_output=True, text=True)
                if done.returncode != 0:
                    raise bad("export", str(export), f"failed: {_last_line(done.stderr)}")
                exported = tmp / "genome.txt"
                exported.write_text(done.stdout)
                cells = {}
                for terrain in terrains:
                    gaps, vx = somite_gaps(genome, terrain, config)
                    times = (np.arange(len(gaps)) + SETTLE_STEPS + 1) / CONTROL_HZ
                    cells[terrain.name] = {"somite": summary(gaps, times, vx)}
                    for engine in engines:
                        g, t, v = driver_gaps(exported, terrain.name, sensors,
                                              config.hidden_activation, javas[engine], tmp)
                        cells[terrain.name][engine] = summary(g, t, v)
                    print(f"{path} {terrain.name}: " + ", ".join(
                        f"{k} {c['start_min']:.2f}/{c['min']:.2f}" for k, c in
                        cells[terrain.name].items()), file=sys.stderr, flush=True)
            medians = {side: {key: float(np.median([c[side][key] for c in cells.values()]))
                              for key in ("start_min", "min", "p1", "below_5cm", "vx")}
                       for side in ("somite", *engines)}
            report.append({"run": path, "terrains": cells, "medians": medians})
    except SomiteError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(json.dumps({"runs": report}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
