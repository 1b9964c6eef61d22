"""Generation 0 of the paper-rq1 runs in 2D-VSR-Sim: is the paper's starting speed the misfire?

The paper's Figure 3 starts near 0.5 m/s; somite's runs log 0.006-0.087 m/s at generation 0.
This rebuilds each run's 96 initial genomes and the training terrain and noise seed each drew
(``GraphEA(...).ask()`` and ``Locomotion.episodes(...)`` from the run's ``config.json`` and
seed, as the runner draws them), checks that somite's fitness of them is the run's logged
generation 0 to the last digit, then runs every genome on its own training terrain in
2D-VSR-Sim through the driver of ``shared/tools/closed-loop-2dvsrsim/`` (``CL pairs``, 30 s,
v_x over [5 s, 30 s], noise sigma 0.01), on its own sensors (the variant driver of
``benchmarks/reference/closed-loop/variant-paper-sensors/``, ``SENSORS=paper HIDDEN=tanh``),
with dyn4j as shipped (``stock``) and without its collision misfire (``noccd``).

    python reports/paper-rq1/generation0.py CAMPAIGN --vsr $VSR [--out reports/paper-rq1/generation0]
                                            [--engines stock,noccd] [--runs rq1/biped-s0,...]

``CAMPAIGN``: the unpacked pack (``somite campaign unpack reports/paper-rq1/paper-rq1.pack
--out DIR``); the ablation runs' generation 0 is the graph runs' (same seeds), so the six
``rq1/`` runs cover all twelve. ``$VSR``: the driver's build with ``classes-main-sensors/`` and
``classes-dyn4j-noccd/`` (benchmarks/reference/closed-loop/README.md says how). Each
(run, engine) writes ``OUT/RUN-ENGINE.csv`` (the driver's rows) and is skipped when that file
is there, so an interrupted measurement resumes; ``OUT/generation0.csv`` (one row a genome) and
``OUT/summary.json`` (median and max per run and engine) are written from what is there. One
Java process at a time, ``THREADS`` (default 1) threads: about 2 s an episode a thread.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from somite.evolution.ea import GraphEA
from somite.experiments.config import resolve

REPO = Path(__file__).resolve().parents[2]
EXPORT = REPO.parent / "shared/tools/closed-loop-2dvsrsim/export_genomes.py"
RUNS = tuple(f"rq1/{shape}-s{seed}" for shape in ("biped", "worm") for seed in (0, 1, 2))
DYN4J = {"stock": "classes-dyn4j", "noccd": "classes-dyn4j-noccd"}
SIGMA = "0.01"


def generation0(run: Path):
    """The run's 96 initial genomes, their training terrains' names, and somite's fitness."""
    config = resolve(json.loads((run / "config.json").read_text()))
    body = config.body()
    ea = GraphEA(body, seed=config.seed, config=config.ga, partition=config.setup.partition)
    genomes = ea.ask()
    task = config.task(body)
    state = ea.rng_evaluation.bit_generator.state
    episodes = task.episodes(genomes, ea.rng_evaluation)
    ea.rng_evaluation.bit_generator.state = state
    fitness = task.evaluate(genomes, rng=ea.rng_evaluation)
    with open(run / "log.csv", newline="") as handle:
        logged = float(next(csv.DictReader(handle))["best_velocity"])
    if float(np.nanmax(fitness)) != logged:
        raise SystemExit(f"{run}: rebuilt generation 0's best {np.nanmax(fitness)!r} is not "
                         f"the logged {logged!r}")
    return genomes, [t.name for t in episodes.terrains], [float(f) for f in fitness]


def measure(name: str, genomes, terrains, engine: str, vsr: Path, out: Path) -> None:
    target = out / f"{name.replace('/', '-')}-{engine}.csv"
    if target.exists():
        return
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for i, genome in enumerate(genomes):
            genome.save(tmp / f"g{i:02d}.json")
        exported = subprocess.run(
            [sys.executable, str(EXPORT), *[str(tmp / f"g{i:02d}.json") for i in
                                            range(len(genomes))]],
            capture_output=True, text=True, check=True).stdout
        (tmp / "genomes.txt").write_text(exported)
        (tmp / "pairs.txt").write_text(
            "".join(f"g{i:02d} {t}\n" for i, t in enumerate(terrains)))
        cp = os.pathsep.join(str(vsr / p) for p in
                             ("classes-main-sensors", "classes-hmsr", DYN4J[engine], "lib/*"))
        env = {**os.environ, "SENSORS": "paper", "HIDDEN": "tanh",
               "THREADS": os.environ.get("THREADS", "1")}
        subprocess.run(["java", "-cp", cp, "CL", "pairs", "genomes.txt", "pairs.txt", SIGMA,
                        "out.csv"], cwd=tmp, env=env, check=True)
        target.write_text((tmp / "out.csv").read_text())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("campaign", type=Path)
    parser.add_argument("--vsr", type=Path, default=os.environ.get("VSR"))
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "generation0")
    parser.add_argument("--engines", default="stock,noccd")
    parser.add_argument("--runs", default=",".join(RUNS))
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    engines = [e for e in args.engines.split(",") if e]
    runs = [r for r in args.runs.split(",") if r]
    built = {name: generation0(args.campaign / name) for name in runs}
    for engine in engines:  # all runs in one engine first: stock answers the question
        for name in runs:
            genomes, terrains, _ = built[name]
            print(f"{name}: {engine}", file=sys.stderr, flush=True)
            measure(name, genomes, terrains, engine, args.vsr, args.out)
    rows, summary = [], {}
    for name, (genomes, terrains, fitness) in built.items():
        vsr = {}
        for engine in DYN4J:
            path = args.out / f"{name.replace('/', '-')}-{engine}.csv"
            if path.exists():
                with open(path, newline="") as handle:
                    vsr[engine] = {r["name"]: float(r["vx"]) for r in csv.DictReader(handle)}
        for i, (terrain, vx) in enumerate(zip(terrains, fitness)):
            rows.append({"run": name, "genome": i, "terrain": terrain, "somite_vx": vx,
                         **{f"vsr_{e}_vx": vsr[e][f"g{i:02d}"] for e in vsr}})
        summary[name] = {
            "somite": {"median": statistics.median(fitness), "max": max(fitness)},
            **{e: {"median": statistics.median(v.values()), "max": max(v.values()),
                   "above_0.1": sum(x > 0.1 for x in v.values())} for e, v in vsr.items()}}
    columns = ["run", "genome", "terrain", "somite_vx",
               *[f"vsr_{e}_vx" for e in DYN4J if all(f"vsr_{e}_vx" in r for r in rows)]]
    with open(args.out / "generation0.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, columns, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    (args.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    print(json.dumps(summary, indent=2))


if __name__ == "__main__":
    main()
