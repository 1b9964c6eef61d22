"""Do modular runs (omega = 10) cut fewer edges than unmodular ones (omega = 0.1)?

Evolves the worm and the biped with both biases over several seeds at a small budget, cuts each
final best along the paper's partition and compares the cut ratios eta (the share of edges, and
of |w| + |b|, that cross modules) with a one-sided Mann-Whitney U test. Writes
audits/omega-cuts.json and prints a Markdown table.

Usage: python audits/omega_cuts.py [--seeds 5] [--generations 150] [--population 24]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.stats import mannwhitneyu

from somite.experiments.config import resolve
from somite.experiments.runner import evolve
from somite.modules.module import cut
from somite.sim.partition import Partition


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--generations", type=int, default=150)
    parser.add_argument("--population", type=int, default=24)
    parser.add_argument("--duration", type=float, default=10.0)
    parser.add_argument("--shapes", default="worm,biped")
    args = parser.parse_args()
    started = time.perf_counter()
    results = []
    with tempfile.TemporaryDirectory() as folder:
        for shape in args.shapes.split(","):
            for omega in (0.1, 10.0):
                for seed in range(args.seeds):
                    config = resolve({"shape": shape, "omega": omega, "modules": "paper",
                                      "seed": seed, "generations": args.generations,
                                      "population": args.population,
                                      "duration": args.duration})
                    state = evolve(config, Path(folder) / f"{shape}-{omega}-{seed}")
                    best = state.population.genomes[state.population.best()]
                    total = cut(best, Partition.preset("paper", best.body.shape)).total
                    results.append({"shape": shape, "omega": omega, "seed": seed,
                                    "edges": best.n_edges, "eta_num": total.eta_num,
                                    "eta_weight": total.eta_weight,
                                    "velocity": float(state.population.fitness.max())})
    summary = []
    for shape in args.shapes.split(","):
        row = {"shape": shape}
        for key in ("eta_num", "eta_weight"):
            low = [r[key] for r in results if r["shape"] == shape and r["omega"] == 0.1]
            high = [r[key] for r in results if r["shape"] == shape and r["omega"] == 10.0]
            row[key] = {"median_omega_0.1": float(np.median(low)),
                        "median_omega_10": float(np.median(high)),
                        "p_less": float(mannwhitneyu(high, low, alternative="less").pvalue)}
        summary.append(row)
    report = {"settings": vars(args), "seconds": round(time.perf_counter() - started, 1),
              "summary": summary, "runs": results}
    Path(__file__).with_name("omega-cuts.json").write_text(json.dumps(report, indent=2) + "\n")
    print("| shape | eta_num, omega 0.1 | eta_num, omega 10 | p | "
          "eta_weight, omega 0.1 | eta_weight, omega 10 | p |")
    print("|---|---|---|---|---|---|---|")
    for row in summary:
        n, w = row["eta_num"], row["eta_weight"]
        print(f"| {row['shape']} | {n['median_omega_0.1']:.3f} | {n['median_omega_10']:.3f} | "
              f"{n['p_less']:.4f} | {w['median_omega_0.1']:.3f} | {w['median_omega_10']:.3f} | "
              f"{w['p_less']:.4f} |")


if __name__ == "__main__":
    main()
