"""How closely somite's physics follows the paper's simulator (2D-VSR-Sim 1.9.2 on dyn4j 3.3.0).

Runs the open-loop sine gaits of ``shared/reference/vsr-sine-sweep.csv`` (worm and biped; flat and
three hilly terrains; 5 frequencies x 5 phases) in somite and prints, per shape, as JSON:

- ``rank_all``: Spearman rank correlation of v_x over all cells, somite against the reference;
- ``rank_per_gait``: the same over the 25 gaits, each gait's v_x averaged over the hilly terrains;
- ``best_ratio``: per terrain, somite's fastest gait over the reference's fastest gait;
- ``fastest_ratio``: somite's fastest cell over the reference's fastest cell of the shape;
- pathology rates in both simulators: tipping past 90 degrees, stalls (a gait that does at least
  0.5 m/s on flat but under 0.1 m/s on a hilly terrain, over the hilly episodes of such gaits),
  the highest and the median jump (lowest point above the ground), the highest centre of mass
  above the ground, its top speed, and the smallest signed voxel area ratio;
- ``com_height_ratio``: somite's highest centre of mass over the reference's, averaged over
  the synchronous gaits (phase 0, from 1.5 Hz: the ones that jump) and over all the others.

With ``--substeps-against N`` it also reruns somite with N substeps and gives the rank
correlations of that run against the first (convergence in the time step); with ``--chaos``,
the same for amplitude 0.999 instead of 1 (somite's own chaos, to set beside the reference's);
with ``--reference-chaos PATH`` (the reference's cells at amplitude 0.999), the reference's own;
with ``--reference-variant PATH`` (repeatable; the same cells in 2D-VSR-Sim with one of its
parameters changed, ``benchmarks/reference/variants/``), how far the reference moves from itself
when its physics changes a little, and how close somite is to each variant.
``benchmarks/reference/`` holds more cells measured in 2D-VSR-Sim, on gaits and terrains that
the fit never saw (its README).
Single cells are chaotic in both simulators (README of the reference data), so look at
rankings and rates.

    python benchmarks/fidelity.py [--reference PATH] [--option NAME=VALUE ...]
                                  [--substeps-against 16] [--amplitude 0.999]
                                  [--reference-chaos PATH] [--reference-variant PATH ...]
"""

from __future__ import annotations

import argparse
import csv
import json
import math
from collections import defaultdict
from pathlib import Path

import numpy as np
from scipy.stats import spearmanr

from somite.brain.controllers import Sine
from somite.sim.body import Body
from somite.sim.config import SimConfig
from somite.sim.terrain import parse_terrain
from somite.tasks.episode import (
    D_FLIPPED,
    D_MAX_COM_HEIGHT,
    D_MAX_COM_SPEED,
    D_MAX_GAP,
    D_MAX_TILT,
)
from somite.tasks.locomotion import simulate_batch

SHAPES = {"worm-6x2": "worm", "biped-4x3": "biped"}
DEFAULT_REFERENCE = Path(__file__).resolve().parents[2] / "shared/reference/vsr-sine-sweep.csv"
STALL_FLAT, STALL_HILLY = 0.5, 0.1
CHAOS_AMPLITUDE = 0.999
"""The reference README's measure of a simulator's own chaos: the same grid at 0.999x."""
FLOAT_OPTIONS = {"substeps": int, "touch_window": int, "velocity_window": int}


def load_reference(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    for row in rows:
        for key in ("freq", "phase", "vx", "max_abs_tilt_deg", "flipped_frac", "max_air_gap",
                    "max_com_height", "max_com_speed", "min_quad_ratio"):
            row[key] = float(row[key])
    return rows


def run_somite(rows: list[dict], config: SimConfig, amplitude: float = 1.0) -> list[dict]:
    """Each reference cell run in somite: v_x and the same diagnostics. An ``amplitude`` a
    hair under 1 measures somite's own chaos, as the reference's README does for its own."""
    bodies = {name: Body.build(shape) for name, shape in SHAPES.items()}
    terrains = {name: parse_terrain(name) for name in {r["terrain"] for r in rows}}
    outcomes, trace = simulate_batch(
        [bodies[r["shape"]] for r in rows],
        [terrains[r["terrain"]] for r in rows],
        [Sine(freq=r["freq"], amp=amplitude, phase=r["phase"]) for r in rows],
        config,
        seeds=0,
    )
    scored = config.n_steps - config.transient_steps
    result = []
    for b, (row, outcome) in enumerate(zip(rows, outcomes)):
        d = trace.diagnostics[b]
        result.append({
            **{k: row[k] for k in ("shape", "terrain", "freq", "phase_name")},
            "vx": outcome.velocity,
            "max_abs_tilt_deg": float(d[D_MAX_TILT]),
            "flipped_frac": float(d[D_FLIPPED]) / scored,
            "max_air_gap": float(d[D_MAX_GAP]),
            "max_com_height": float(d[D_MAX_COM_HEIGHT]),
            "max_com_speed": float(d[D_MAX_COM_SPEED]),
            "min_quad_ratio": float(trace.min_area[b]),
        })
    return result


def _rank(a, b) -> float:
    return float(spearmanr(a, b).statistic)


def _per_gait_hilly(rows: list[dict]) -> dict:
    gaits = defaultdict(list)
    for r in rows:
        if r["terrain"].startswith("hilly"):
            gaits[(r["freq"], r["phase_name"])].append(r["vx"])
    return {g: float(np.mean(v)) for g, v in sorted(gaits.items())}


def _stalls(rows: list[dict]) -> tuple[int, int]:
    flat = {(r["freq"], r["phase_name"]): r["vx"] for r in rows if r["terrain"] == "flat"}
    good = [r for r in rows if r["terrain"] != "flat" and flat[(r["freq"], r["phase_name"])]
            >= STALL_FLAT]
    return sum(r["vx"] < STALL_HILLY for r in good), len(good)


def pathologies(rows: list[dict]) -> dict:
    stalls, episodes = _stalls(rows)
    tipped = sum(r["max_abs_tilt_deg"] > 90 for r in rows)
    return {
        "tipped": tipped,
        "tipped_rate": tipped / len(rows),
        "flipped_frac_mean": float(np.mean([r["flipped_frac"] for r in rows])),
        "stalls": stalls,
        "stall_episodes": episodes,
        "stall_rate": stalls / episodes if episodes else 0.0,
        "max_jump": max(r["max_air_gap"] for r in rows),
        "median_jump": float(np.median([r["max_air_gap"] for r in rows])),
        "max_com_height": max(r["max_com_height"] for r in rows),
        "max_com_speed": max(r["max_com_speed"] for r in rows),
        "min_signed_area_ratio": min(r["min_quad_ratio"] for r in rows),
        "negative_area_episodes": sum(r["min_quad_ratio"] < 0 for r in rows),
    }


SYNCHRONOUS_FREQ = 1.5
"""Gaits of phase 0 (every voxel in step) from this frequency on are the ones that jump."""


def com_height_ratios(mine: list[dict], theirs: list[dict]) -> dict:
    """Mean ratio of the highest centre of mass, somite over the reference, for the
    synchronous jumping gaits (phase 0, >= 1.5 Hz) and for all the others: where somite's jumps
    differ from the reference's, and whether it is the whole body or one kind of gait."""
    groups: dict[str, list[float]] = {"synchronous": [], "other": []}
    for a, b in zip(mine, theirs):
        sync = a["phase_name"] == "0" and a["freq"] >= SYNCHRONOUS_FREQ
        groups["synchronous" if sync else "other"].append(a["max_com_height"]
                                                         / b["max_com_height"])
    return {k: float(np.mean(v)) for k, v in groups.items() if v}


def _key(r: dict) -> tuple:
    return (r["shape"], r["terrain"], r["freq"], r["phase_name"])


def compare(ours: list[dict], ref: list[dict]) -> dict:
    """The fidelity figures of ``ours`` against ``ref``, per shape."""
    by_key = {_key(r): r for r in ref}
    report = {}
    for shape in SHAPES:
        mine = [r for r in ours if r["shape"] == shape]
        theirs = [by_key[_key(r)] for r in mine]
        gait_mine = _per_gait_hilly(mine)
        gait_theirs = _per_gait_hilly(theirs)
        best = {}
        for terrain in sorted({r["terrain"] for r in mine}):
            a = max(r["vx"] for r in mine if r["terrain"] == terrain)
            b = max(r["vx"] for r in theirs if r["terrain"] == terrain)
            best[terrain] = a / b
        ours_p, theirs_p = pathologies(mine), pathologies(theirs)
        report[shape] = {
            "rank_all": _rank([r["vx"] for r in mine], [r["vx"] for r in theirs]),
            "rank_per_gait": _rank(list(gait_mine.values()), list(gait_theirs.values())),
            "best_ratio": best,
            "best_ratio_in_range": sum(0.75 <= v <= 1.33 for v in best.values()),
            "fastest_ratio": max(r["vx"] for r in mine) / max(r["vx"] for r in theirs),
            "com_height_ratio": com_height_ratios(mine, theirs),
            "somite": ours_p,
            "reference": theirs_p,
        }
    return report


def convergence(first: list[dict], second: list[dict]) -> dict:
    report = {}
    for shape in SHAPES:
        a = [r for r in first if r["shape"] == shape]
        b = [r for r in second if r["shape"] == shape]
        report[shape] = {
            "rank_all": _rank([r["vx"] for r in a], [r["vx"] for r in b]),
            "rank_per_gait": _rank(list(_per_gait_hilly(a).values()),
                                   list(_per_gait_hilly(b).values())),
        }
    return report


def reference_chaos(ref: list[dict], other: list[dict]) -> dict:
    """The reference's own chaos: its rank agreement with ``other``, the same simulator on
    the same cells at amplitude 0.999 (over the cells that both files hold)."""
    by_key = {_key(r): r for r in other}
    mine = [r for r in ref if _key(r) in by_key]
    return convergence(mine, [by_key[_key(r)] for r in mine])


def reference_variant(ref: list[dict], variant: list[dict], ours: list[dict]) -> dict:
    """2D-VSR-Sim against a variant of itself (the same cells with one parameter changed), per
    shape: its rank agreement with the unchanged reference (:func:`reference_chaos`), its
    tipping rate, and somite's rank agreement with the variant (as with the reference)."""
    agreement = reference_chaos(ref, variant)
    against_variant = compare(ours, variant)
    for shape, figures in agreement.items():
        figures["tipped_rate"] = pathologies([r for r in variant
                                              if r["shape"] == shape])["tipped_rate"]
        figures["somite_rank_all"] = against_variant[shape]["rank_all"]
        figures["somite_rank_per_gait"] = against_variant[shape]["rank_per_gait"]
    return agreement


def parse_options(pairs: list[str]) -> dict:
    options = {}
    for pair in pairs:
        name, _, value = pair.partition("=")
        options[name] = FLOAT_OPTIONS.get(name, float)(value)
    return options


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reference", type=Path, default=DEFAULT_REFERENCE)
    parser.add_argument("--option", action="append", default=[], metavar="NAME=VALUE",
                        help="a SimConfig option (repeatable)")
    parser.add_argument("--substeps-against", type=int, default=0, metavar="N")
    parser.add_argument("--amplitude", type=float, default=1.0,
                        help="of the sine gaits (0.999: somite's own chaos, as in the reference)")
    parser.add_argument("--chaos", action="store_true",
                        help="also rerun at amplitude 0.999 and rank that against the first run")
    parser.add_argument("--reference-chaos", type=Path, metavar="PATH",
                        help="the reference's cells at amplitude 0.999: its own chaos floor")
    parser.add_argument("--reference-variant", type=Path, action="append", default=[],
                        metavar="PATH", help="the same cells in a variant of the reference "
                        "simulator (repeatable): how far the reference itself moves")
    parser.add_argument("--cells", type=Path, help="also write every cell's numbers (CSV)")
    args = parser.parse_args()
    ref = load_reference(args.reference)
    config = SimConfig().with_options(**parse_options(args.option))
    ours = run_somite(ref, config, args.amplitude)
    out = {"config": config.to_dict(), "amplitude": args.amplitude,
           "fidelity": compare(ours, ref)}
    if args.substeps_against:
        other = run_somite(ref, config.with_options(substeps=args.substeps_against),
                           args.amplitude)
        out["convergence"] = {"substeps": [config.substeps, args.substeps_against],
                              **convergence(ours, other)}
    if args.chaos:
        other = run_somite(ref, config, args.amplitude * CHAOS_AMPLITUDE)
        out["chaos"] = {"amplitude": args.amplitude * CHAOS_AMPLITUDE,
                        **convergence(ours, other)}
    if args.reference_chaos:
        out["reference_chaos"] = reference_chaos(ref, load_reference(args.reference_chaos))
    if args.reference_variant:
        out["reference_variants"] = {
            path.stem: reference_variant(ref, load_reference(path), ours)
            for path in args.reference_variant}
    if args.cells:
        with open(args.cells, "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(ours[0]))
            writer.writeheader()
            writer.writerows(ours)
    print(json.dumps(out, indent=2, default=lambda x: None if math.isnan(x) else x))


if __name__ == "__main__":
    main()
