"""How closely somite follows the paper's simulator (2D-VSR-Sim 1.9.2) in closed loop, 1-30 Hz.

Runs the cells of ``shared/reference/closed-loop/`` (its README: genomes and sines measured in
2D-VSR-Sim with the authors' controller and sensors) in somite's ``original-code`` preset and
prints, per shape (worm-6x2, biped-4x3), as JSON:

- ``still``: N random constant poses (actuation per voxel U(-1, 1)) on flat ground, 30 s: the
  mean and the largest |v_x| and the share above 0.05 m/s, beside 2D-VSR-Sim's figures (worm:
  mean 0.0036, max 0.015; biped: 0.0018, 0.007) and the targets (mean <= 0.005, max <= 0.02);
  and how deep the robot gets into the ground after the first 2 s (its lowest voxel corner);
- ``loops``: the feedback-loop genomes (``*-arealoop-wW``, ``*-touchloop``) on flat and
  ``hilly-1-10-10000``, noise 0.01: the fastest loop on flat in both simulators and their ratio
  (target for the worm 0.6-1.6x), somite over the reference for every loop that the reference
  takes faster than 1 m/s (target 0.5-2x), and the actuation's dominant frequency beside the
  reference's ``f_peak``;
- ``init``: the 96 initial genomes per shape on the four terrains of ``java-init-*.csv``, noise
  sigma 0.01 and 0: per terrain and sigma, the Spearman rank of v_x against the reference and
  the median and 90% quantile in both (targets: mean rank with noise >= 0.5, |median| and
  |q90| differences <= 0.02 m/s); and noise sensitivity, the rank of noise-on against noise-off
  v_x within each simulator;
- ``sines``: the open-loop sines of ``java-sine-1-30hz.csv`` (1-30 Hz): Spearman rank over all
  cells (target >= 0.7) and per band (1-3, 5-10, 15-30 Hz), somite's fastest cell over the
  reference's per terrain (target <= 1.5), and the voxels' deformation per frequency: ``ar_h1``,
  the amplitude of the area ratio's first harmonic over t = 5-30 s, mean over voxels, computed
  as CL.java's ``areaStats`` does; with ``java-sine-1-30hz-a0999.csv`` beside it (the same cells
  at amplitude 0.999), the reference's own floor: its rank against itself;
- ``grid``: the worm's and the biped's area loop at gains 12-32 (``loop-grid.csv``: the
  ``-arealoop-w16`` genome with its weight W and bias -W tanh(0.5)), on three terrains and four
  noise levels: per shape and terrain the median v_x and how many cells pass 1 m/s in each
  simulator. A loop's speed is chaotic in both (which way the voxels lock, and whether they
  do, changes with the noise level), so this grid, not one cell, is what compares.

``--measured DIR`` reads the reference's measurements (``java-*.csv``, ``loop-grid.csv``) from
DIR where it has them, the rest from ``--reference``, whose genomes run:
``benchmarks/reference/closed-loop/`` holds more cells measured in 2D-VSR-Sim as it is
(``stock/``) and the same cells without its continuous collision detection (``no-ccd/``; its
README says why that matters).

``--only`` picks sections; ``--limit K`` runs only the first K genomes or sine cells of each
shape's list (quick checks); ``--option`` sets SimConfig options on top of the preset (the
sections' own noise sigma still applies); ``--cells`` writes every somite cell to CSV.
Single cells are chaotic in both simulators: look at ranks and rates.

    python benchmarks/closed_loop.py [--only still,loops,init,sines,grid] [--poses 100] [--seed 0]
                                     [--limit K] [--option NAME=VALUE ...] [--cells PATH]
                                     [--reference DIR] [--measured DIR]
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import subprocess
import sys
import time
import warnings
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np
from scipy.stats import spearmanr

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fidelity import SHAPES  # noqa: E402

from somite.brain.compile import compile_genome  # noqa: E402
from somite.brain.controllers import Sine, Table  # noqa: E402
from somite.brain.genome import Genome  # noqa: E402
from somite.sim.body import Body  # noqa: E402
from somite.sim.config import CONTROL_HZ, VOXEL_SIDE, SimConfig, preset  # noqa: E402
from somite.sim.system import geometry  # noqa: E402
from somite.sim.terrain import parse_terrain  # noqa: E402
from somite.tasks.episode import SETTLE_STEPS  # noqa: E402
from somite.tasks.locomotion import simulate_batch  # noqa: E402

DEFAULT_REFERENCE = Path(__file__).resolve().parents[2] / "shared/reference/closed-loop"
SECTIONS = ("still", "loops", "init", "sines", "grid")
PRESET = "original-code"

STILL_REFERENCE = {"worm-6x2": {"mean_abs_vx": 0.0036, "max_abs_vx": 0.015},
                   "biped-4x3": {"mean_abs_vx": 0.0018, "max_abs_vx": 0.007}}
"""2D-VSR-Sim's constant poses on flat ground (the reference README)."""
STILL_TARGET = {"mean_abs_vx": 0.005, "max_abs_vx": 0.02}
GLIDE = 0.05
"""[m/s] a constant pose faster than this glides."""
LOOP_TERRAINS = ("flat", "hilly-1-10-10000")
LOOP_NOISE = 0.01
LOOP_FAST = 1.0
"""[m/s] the loops that the reference takes faster than this are compared one by one."""
LOOP_FASTEST_TARGET = (0.6, 1.6)
LOOP_RATIO_TARGET = (0.5, 2.0)
INIT_RANK_TARGET = 0.5
INIT_QUANTILE_TARGET = 0.02
BACKWARD = -0.012
"""[m/s] an initial genome slower than this moves backwards (the reference README)."""
SINE_RANK_TARGET = 0.7
SINE_BEST_TARGET = 1.5
BANDS = {"1-3": (1.0, 3.0), "5-10": (5.0, 10.0), "15-30": (15.0, 30.0)}
FIRST_SCORED = 301
"""The first control step of the scored window (t = 5 s), as CL.java's recordings."""


@dataclass
class Cell:
    """One somite episode: what it runs, and what it gives (``result``) beside the reference's
    numbers (``reference``)."""

    section: str
    shape: str
    terrain: str
    sigma: float
    controller: object
    name: str = ""
    freq: float = math.nan
    phase_name: str = ""
    reference: dict = field(default_factory=dict)
    result: dict = field(default_factory=dict)

    def row(self) -> dict:
        """The cell as one CSV row: somite's numbers, then the reference's as ``ref_*``."""
        out = {"section": self.section, "shape": self.shape, "name": self.name,
               "terrain": self.terrain, "sigma": self.sigma,
               "freq": "" if math.isnan(self.freq) else self.freq,
               "phase_name": self.phase_name}
        out.update(self.result)
        out.update({f"ref_{k}": v for k, v in self.reference.items()})
        return out


# -- reading the reference ------------------------------------------------------------------------

def read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def read_genomes(path: Path) -> list[tuple[str, Genome]]:
    with open(path) as f:
        return [(d["name"], Genome.from_dict(d["genome"]))
                for d in (json.loads(line) for line in f if line.strip())]


def shape_of(genome: Genome) -> str:
    """The reference's name of a genome's body (worm-6x2 or biped-4x3)."""
    grid = genome.body.shape.grid_string()
    for name, short in SHAPES.items():
        if Body.build(short).shape.grid_string() == grid:
            return name
    raise ValueError(f"not a reference body: {grid}")


def measurement(measured: Path, reference: Path, name: str) -> Path:
    """A measurement file: ``measured``'s if it has one, else the reference's."""
    return measured / name if (measured / name).is_file() else reference / name


def _floats(row: dict, *keys: str) -> dict:
    """The row's numbers under ``keys``; NaN where the measurement has no such column."""
    return {k: float(row[k]) if row.get(k) not in (None, "") else math.nan for k in keys}


# -- the sections' cells --------------------------------------------------------------------------

def still_cells(poses: int, seed: int) -> list[Cell]:
    cells = []
    for shape, short in SHAPES.items():
        voxels = Body.build(short).shape.n_voxels
        for i, pose in enumerate(np.random.default_rng(seed).uniform(-1, 1, (poses, voxels))):
            cells.append(Cell("still", shape, "flat", LOOP_NOISE, Table(pose[None, :]),
                              name=f"{short}-pose-{i:03d}"))
    return cells


def loop_cells(reference: Path, measured: Path, limit: int | None) -> list[Cell]:
    ref = {(r["name"], r["terrain"]): r
           for r in read_csv(measurement(measured, reference, "java-loops.csv"))}
    cells = []
    per_shape: dict[str, int] = {}
    for name, genome in read_genomes(reference / "loop-genomes.jsonl"):
        shape = shape_of(genome)
        per_shape[shape] = per_shape.get(shape, 0) + 1
        if limit is not None and per_shape[shape] > limit:
            continue
        arrays = compile_genome(genome)
        for terrain in LOOP_TERRAINS:
            r = ref[(name, terrain)]
            cells.append(Cell("loops", shape, terrain, LOOP_NOISE, arrays, name=name,
                              reference=_floats(r, "vx", "act_sd", "hf5", "hf15", "f_peak",
                                                "area_sd")))
    return cells


def init_cells(reference: Path, measured: Path, limit: int | None) -> list[Cell]:
    cells = []
    for short in ("worm", "biped"):
        rows = read_csv(measurement(measured, reference, f"java-init-{short}.csv"))
        ref = {(r["name"], r["terrain"], float(r["sigma"])): r for r in rows}
        terrains = list(dict.fromkeys(r["terrain"] for r in rows))
        sigmas = sorted({float(r["sigma"]) for r in rows}, reverse=True)
        genomes = read_genomes(reference / f"initial-genomes-{short}.jsonl")[:limit]
        for name, genome in genomes:
            arrays = compile_genome(genome)
            for terrain in terrains:
                for sigma in sigmas:
                    r = ref[(name, terrain, sigma)]
                    cells.append(Cell("init", r["shape"], terrain, sigma, arrays, name=name,
                                      reference=_floats(r, "vx")))
    return cells


def sine_cells(reference: Path, measured: Path, limit: int | None) -> list[Cell]:
    rows = read_csv(measurement(measured, reference, "java-sine-1-30hz.csv"))
    floor = measurement(measured, reference, "java-sine-1-30hz-a0999.csv")
    chaos = ({(r["shape"], r["terrain"], r["freq"], r["phase_name"]): float(r["vx"])
              for r in read_csv(floor)} if floor.is_file() else {})
    cells = []
    for shape in SHAPES:
        for r in [r for r in rows if r["shape"] == shape][:limit]:
            cells.append(Cell("sines", shape, r["terrain"], LOOP_NOISE,
                              Sine(freq=float(r["freq"]), amp=1.0, phase=float(r["phase"])),
                              freq=float(r["freq"]), phase_name=r["phase_name"],
                              reference={**_floats(r, "vx", "ar_h1", "ar_halfrange", "ar_sd",
                                                   "ar_mean"),
                                         "vx_a0999": chaos.get((shape, r["terrain"], r["freq"],
                                                                r["phase_name"]), math.nan)}))
    return cells


GRID_BASE = "-arealoop-w16"
"""The loop genome whose gain the grid changes (a = tanh(W (tanh(r) - tanh(0.5))))."""
GRID_FILE = "loop-grid.csv"


def grid_genome(base: dict, gain: float) -> Genome:
    """The area-loop genome ``base`` (JSON) with every edge's weight W and bias -W tanh(0.5)."""
    data = json.loads(json.dumps(base))
    edges = []
    for e in data["edges"]:
        if isinstance(e, dict):
            edges.append({**e, "weight": gain, "bias": -gain * math.tanh(0.5)})
        else:
            edges.append([e[0], e[1], gain, -gain * math.tanh(0.5)])
    data["edges"] = edges
    return Genome.from_dict(data)


def grid_cells(reference: Path, measured: Path, limit: int | None) -> list[Cell]:
    with open(reference / "loop-genomes.jsonl") as f:
        bases = {d["name"]: d["genome"] for d in (json.loads(line) for line in f if line.strip())}
    cells, compiled = [], {}
    per_shape: dict[str, int] = {}
    for r in read_csv(measurement(measured, reference, GRID_FILE)):
        short, _, gain = r["name"].rpartition("-arealoop-w")
        if r["name"] not in compiled:
            per_shape[short] = per_shape.get(short, 0) + 1
            if limit is not None and per_shape[short] > limit:
                continue
            compiled[r["name"]] = compile_genome(grid_genome(bases[short + GRID_BASE],
                                                             float(gain)))
        cells.append(Cell("grid", r["shape"], r["terrain"], float(r["sigma"]),
                          compiled[r["name"]], name=r["name"], reference=_floats(r, "vx")))
    return cells


# -- running them ---------------------------------------------------------------------------------

RECORDED = {"still", "loops", "sines"}
"""The sections whose cells need the recorded episode (corners, actuation)."""


def run_cells(cells: list[Cell], config: SimConfig) -> list[dict]:
    """Run every cell in somite, one ``simulate_batch`` batch per (noise sigma, recording), and fill
    in each cell's ``result``. Returns what each batch cost."""
    bodies = {shape: Body.build(short) for shape, short in SHAPES.items()}
    terrains = {name: parse_terrain(name) for name in {c.terrain for c in cells}}
    groups: dict[tuple[float, bool], list[Cell]] = {}
    for c in cells:
        groups.setdefault((c.sigma, c.section in RECORDED), []).append(c)
    batches = []
    for (sigma, record), group in sorted(groups.items()):
        started = time.perf_counter()
        outcomes, trace = simulate_batch([bodies[c.shape] for c in group],
                                   [terrains[c.terrain] for c in group],
                                   [c.controller for c in group],
                                   config.with_options(noise_sigma=sigma), seeds=0,
                                   record=record)
        for b, (c, outcome) in enumerate(zip(group, outcomes)):
            c.result["vx"] = outcome.velocity
            if record:
                c.result.update(recorded(c, trace, b, bodies[c.shape], terrains[c.terrain]))
        del trace
        batches.append({"sigma": sigma, "recorded": record, "robots": len(group),
                        "seconds": round(time.perf_counter() - started, 2)})
    return batches


def area_ratios(pos: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Each voxel's area over its rest area (T, V) from corner positions (T, P, 2)."""
    quads = pos[:, corners]  # (T, V, 4, 2), counter-clockwise
    x, y = quads[..., 0], quads[..., 1]
    area = 0.5 * (x * np.roll(y, -1, axis=2) - np.roll(x, -1, axis=2) * y).sum(axis=2)
    return area / VOXEL_SIDE**2


def area_stats(ar: np.ndarray, freq: float) -> dict:
    """CL.java's ``areaStats`` of area ratios ``ar`` (T, V) sampled at control steps 301, 302,
    ...: mean over voxels of the first harmonic's amplitude at ``freq`` (twice the DFT
    coefficient's modulus over T, once at the Nyquist frequency), half the 5-95% range, the
    standard deviation and the mean."""
    n = ar.shape[0]
    t = (np.arange(n) + FIRST_SCORED) / CONTROL_HZ
    dev = ar - ar.mean(axis=0)
    w = 2 * np.pi * freq * t
    re, im = np.cos(w) @ dev, np.sin(w) @ dev
    factor = 1.0 if abs(freq - CONTROL_HZ / 2) < 1e-9 else 2.0
    ordered = np.sort(ar, axis=0)
    half = (ordered[round(0.95 * (n - 1))] - ordered[round(0.05 * (n - 1))]) / 2
    return {"ar_h1": float(np.mean(factor * np.hypot(re, im) / n)),
            "ar_halfrange": float(np.mean(half)),
            "ar_sd": float(np.mean(ar.std(axis=0))),
            "ar_mean": float(np.mean(ar.mean(axis=0)))}


def actuation_stats(act: np.ndarray) -> dict:
    """The actuation (T, V) over the scored window: its spread (standard deviation over time,
    mean over voxels), the share of its variance above 5 and 15 Hz, and the frequency of the
    largest peak of its spectrum (summed over voxels, without the mean)."""
    n = act.shape[0]
    dev = act - act.mean(axis=0)
    power = np.abs(np.fft.rfft(dev, axis=0)) ** 2
    power[1:(n + 1) // 2] *= 2  # both halves of the spectrum but the Nyquist bin
    power = power.sum(axis=1)
    freqs = np.fft.rfftfreq(n, 1 / CONTROL_HZ)
    total = power[1:].sum()
    share = (lambda f: float(power[freqs > f].sum() / total)) if total > 0 else (lambda f: 0.0)
    return {"act_sd": float(np.mean(act.std(axis=0))), "hf5": share(5.0), "hf15": share(15.0),
            "f_peak": float(freqs[1 + np.argmax(power[1:])]) if total > 0 else 0.0}


def recorded(c: Cell, trace, b: int, body: Body, terrain) -> dict:
    """The numbers that a cell's section takes from its recorded episode."""
    g = geometry(body)
    pos = trace.pos[b, :, : len(g.points)]  # (n_steps + 1, P, 2), padding left out
    if c.section == "still":
        after = pos[SETTLE_STEPS + 1:]
        height = after[..., 1] - terrain.height_at(after[..., 0])
        return {"min_corner_height": float(height.min())}
    ar = area_ratios(pos[FIRST_SCORED:], g.corners)
    if c.section == "sines":
        return area_stats(ar, c.freq)
    act = trace.actuation[b, FIRST_SCORED:, : body.shape.n_voxels]
    return {**actuation_stats(act), "area_sd": float(np.mean(ar.std(axis=0)))}


# -- the figures ----------------------------------------------------------------------------------

def _rank(a, b) -> float | None:
    """Spearman's rank correlation over the pairs where both are finite (None when it is not
    defined: under 3 pairs, or one side constant)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    ok = np.isfinite(a) & np.isfinite(b)
    if ok.sum() < 3 or np.ptp(a[ok]) == 0 or np.ptp(b[ok]) == 0:
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return float(spearmanr(a[ok], b[ok]).statistic)


def _finite(values) -> np.ndarray:
    values = np.asarray(values, dtype=float)
    return values[np.isfinite(values)]


def _ratio(a: float, b: float) -> float | None:
    return a / b if b and math.isfinite(a) and math.isfinite(b) else None


def _mean(values) -> float | None:
    values = [v for v in values if v is not None]
    return float(np.mean(values)) if values else None


def _vx(cells: list[Cell]) -> tuple[list[float], list[float]]:
    return [c.result["vx"] for c in cells], [c.reference["vx"] for c in cells]


def still_figures(cells: list[Cell]) -> dict:
    report = {}
    for shape in SHAPES:
        mine = [c for c in cells if c.shape == shape]
        speed = np.abs([c.result["vx"] for c in mine])
        height = np.array([c.result["min_corner_height"] for c in mine])
        report[shape] = {
            "poses": len(mine),
            "mean_abs_vx": float(np.nanmean(speed)),
            "max_abs_vx": float(np.nanmax(speed)),
            "share_above": float(np.mean(speed > GLIDE)),
            "reference": STILL_REFERENCE[shape],
            "target": STILL_TARGET,
            "in_target": bool(np.nanmean(speed) <= STILL_TARGET["mean_abs_vx"]
                              and np.nanmax(speed) <= STILL_TARGET["max_abs_vx"]),
            "min_corner_height": float(height.min()),
            "median_min_corner_height": float(np.median(height)),
            "deepest_penetration": float(max(0.0, -height.min())),
            "non_finite": int(np.sum(~np.isfinite([c.result["vx"] for c in mine]))),
        }
    return {"glide_threshold": GLIDE,
            "penetration_measure": (
                "min over control steps after the first 2 s (record=True) of the lowest voxel "
                "corner's (lattice point's) height above the terrain under it [m]; negative: "
                "below the surface. The trace's diagnostics keep only the highest lowest point "
                "(D_MAX_GAP), and the blocks' other outline vertices are not recorded"),
            **report}


def loop_figures(cells: list[Cell]) -> dict:
    report = {}
    for shape in SHAPES:
        mine = [c for c in cells if c.shape == shape]
        flat = [c for c in mine if c.terrain == "flat"]
        if not flat:
            continue
        ours = max(flat, key=lambda c: c.result["vx"])
        theirs = max(flat, key=lambda c: c.reference["vx"])
        fast = []
        for c in mine:
            if c.reference["vx"] > LOOP_FAST:
                fast.append({"name": c.name, "terrain": c.terrain, "somite": c.result["vx"],
                             "reference": c.reference["vx"],
                             "ratio": _ratio(c.result["vx"], c.reference["vx"])})
        in_range = sum(r["ratio"] is not None
                       and LOOP_RATIO_TARGET[0] <= r["ratio"] <= LOOP_RATIO_TARGET[1]
                       for r in fast)
        report[shape] = {
            "fastest_flat": {
                "somite": {"name": ours.name, "vx": ours.result["vx"]},
                "reference": {"name": theirs.name, "vx": theirs.reference["vx"]},
                "ratio": _ratio(ours.result["vx"], theirs.reference["vx"]),
                "target": list(LOOP_FASTEST_TARGET) if shape == "worm-6x2" else None,
            },
            "fast_loops": fast,
            "fast_loops_in_range": in_range,
            "fast_loops_target": list(LOOP_RATIO_TARGET),
            "cells": {c.name + "@" + c.terrain: {
                "vx": [c.result["vx"], c.reference["vx"]],
                "f_peak": [c.result["f_peak"], c.reference["f_peak"]],
                "act_sd": [c.result["act_sd"], c.reference["act_sd"]],
                "area_sd": [c.result["area_sd"], c.reference["area_sd"]]} for c in mine},
        }
    return {"cells_are": "[somite, reference]", "fast_threshold": LOOP_FAST, **report}


def grid_figures(cells: list[Cell]) -> dict:
    report = {}
    for shape in SHAPES:
        mine = [c for c in cells if c.shape == shape]
        if not mine:
            continue
        per = {}
        for terrain in dict.fromkeys(c.terrain for c in mine):
            ours, theirs = _vx([c for c in mine if c.terrain == terrain])
            ours, theirs = _finite(ours), _finite(theirs)
            per[terrain] = {"cells": len(theirs),
                            "median": [float(np.median(ours)), float(np.median(theirs))],
                            "faster_than_1": [int(np.sum(ours > LOOP_FAST)),
                                              int(np.sum(theirs > LOOP_FAST))]}
        report[shape] = {"per_terrain": per, "rank_all_cells": _rank(*_vx(mine))}
    return {"figures_are": "[somite, reference]", **report}


def _quantiles(values) -> dict:
    values = _finite(values)
    return {"median": float(np.median(values)), "q90": float(np.quantile(values, 0.9)),
            "backward_share": float(np.mean(values < BACKWARD))}


def init_figures(cells: list[Cell]) -> dict:
    report = {}
    for shape in SHAPES:
        mine = [c for c in cells if c.shape == shape]
        if not mine:
            continue
        terrains = list(dict.fromkeys(c.terrain for c in mine))
        sigmas = sorted({c.sigma for c in mine}, reverse=True)
        per = {}
        for terrain in terrains:
            per[terrain] = {}
            for sigma in sigmas:
                group = [c for c in mine if c.terrain == terrain and c.sigma == sigma]
                ours, theirs = _vx(group)
                a, b = _quantiles(ours), _quantiles(theirs)
                per[terrain][f"sigma={sigma:g}"] = {
                    "genomes": len(group), "rank": _rank(ours, theirs),
                    "somite": a, "reference": b,
                    "median_diff": a["median"] - b["median"], "q90_diff": a["q90"] - b["q90"],
                    "non_finite": int(np.sum(~np.isfinite(ours)))}
        noisy = [f for t in per.values() for s, f in t.items() if s != "sigma=0"]
        sensitivity = {}
        if len(sigmas) == 2:
            for terrain in terrains:
                on = sorted((c for c in mine if c.terrain == terrain and c.sigma == sigmas[0]),
                            key=lambda c: c.name)
                off = sorted((c for c in mine if c.terrain == terrain and c.sigma == sigmas[1]),
                             key=lambda c: c.name)
                sensitivity[terrain] = {
                    "somite": _rank(_vx(on)[0], _vx(off)[0]),
                    "reference": _rank(_vx(on)[1], _vx(off)[1])}
        report[shape] = {
            "mean_rank_noise_on": _mean(f["rank"] for f in noisy),
            "max_abs_median_diff_noise_on": max(abs(f["median_diff"]) for f in noisy),
            "max_abs_q90_diff_noise_on": max(abs(f["q90_diff"]) for f in noisy),
            "targets": {"mean_rank_noise_on": f">= {INIT_RANK_TARGET}",
                        "abs_median_diff": f"<= {INIT_QUANTILE_TARGET}",
                        "abs_q90_diff": f"<= {INIT_QUANTILE_TARGET}"},
            "per_terrain": per,
            "noise_sensitivity_rank": sensitivity,
        }
    return {"backward_threshold": BACKWARD, **report}


def sine_figures(cells: list[Cell]) -> dict:
    report = {}
    for shape in SHAPES:
        mine = [c for c in cells if c.shape == shape]
        if not mine:
            continue
        bands = {}
        for band, (lo, hi) in BANDS.items():
            group = [c for c in mine if lo <= c.freq <= hi]
            bands[band] = {"cells": len(group), "rank": _rank(*_vx(group))}
        best, best_bands = {}, {}
        for terrain in dict.fromkeys(c.terrain for c in mine):
            group = [c for c in mine if c.terrain == terrain]
            ours, theirs = _vx(group)
            best[terrain] = _ratio(float(np.nanmax(ours)), max(theirs))
            best_bands[terrain] = {}
            for band, (lo, hi) in BANDS.items():
                sub = [c for c in group if lo <= c.freq <= hi]
                if sub:
                    a, b = _vx(sub)
                    best_bands[terrain][band] = {"somite": float(np.nanmax(a)),
                                                 "reference": max(b),
                                                 "ratio": _ratio(float(np.nanmax(a)), max(b))}
        deformation = {}
        for freq in sorted({c.freq for c in mine}):
            group = [c for c in mine if c.freq == freq]
            a = float(np.mean([c.result["ar_h1"] for c in group]))
            b = float(np.mean([c.reference["ar_h1"] for c in group]))
            deformation[f"{freq:g}"] = {"somite": a, "reference": b, "ratio": _ratio(a, b)}
        floor = [c for c in mine if math.isfinite(c.reference["vx_a0999"])]
        floor_bands = {band: _rank([c.reference["vx"] for c in floor if lo <= c.freq <= hi],
                                   [c.reference["vx_a0999"] for c in floor if lo <= c.freq <= hi])
                       for band, (lo, hi) in BANDS.items()} if floor else None
        report[shape] = {
            "cells": len(mine),
            "rank_all": _rank(*_vx(mine)),
            "reference_floor": None if not floor else {
                "rank_all": _rank([c.reference["vx"] for c in floor],
                                  [c.reference["vx_a0999"] for c in floor]),
                "rank_per_band": floor_bands, "cells": len(floor)},
            "rank_target": f">= {SINE_RANK_TARGET}",
            "rank_per_band": bands,
            "best_ratio": best,
            "best_ratio_target": f"<= {SINE_BEST_TARGET}",
            "best_ratio_in_target": sum(v is not None and v <= SINE_BEST_TARGET
                                        for v in best.values()),
            "best_per_band": best_bands,
            "ar_h1_per_freq": deformation,
            "non_finite": int(np.sum(~np.isfinite(_vx(mine)[0]))),
        }
    return {"ar_h1": "amplitude of the voxel area ratio's first harmonic at the sine's frequency,"
                     " control steps 301-1800 (t = 5-30 s), mean over voxels and over the cells "
                     "of that frequency (CL.java areaStats)", **report}


FIGURES = {"still": still_figures, "loops": loop_figures, "init": init_figures,
           "sines": sine_figures, "grid": grid_figures}


# -- the command ----------------------------------------------------------------------------------

def parse_options(pairs: list[str]) -> dict:
    """``NAME=VALUE`` pairs as SimConfig options, each value of its field's type."""
    types = {f.name: type(getattr(SimConfig(), f.name)) for f in fields(SimConfig)}
    options = {}
    for pair in pairs:
        name, _, value = pair.partition("=")
        kind = types.get(name, float)
        if kind is tuple:
            options[name] = tuple(float(v) for v in value.split(","))
        else:
            options[name] = kind(value)
    return options


def clean(value):
    """JSON-ready: NaN and infinities as null, numpy scalars as Python numbers."""
    if isinstance(value, dict):
        return {k: clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [clean(v) for v in value]
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    return value


def source_state() -> dict:
    """The commit that somite's results come from, and whether ``src/`` differs from it."""
    root = Path(__file__).resolve().parents[1]

    def git(*args: str) -> str | None:
        try:
            done = subprocess.run(["git", *args], cwd=root, capture_output=True, text=True,
                                  timeout=30)
        except (OSError, subprocess.SubprocessError):
            return None
        return done.stdout.strip() if done.returncode == 0 else None

    changes = git("status", "--porcelain", "--", "src")
    return {"commit": git("rev-parse", "HEAD"),
            "src_modified": None if changes is None else bool(changes)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reference", type=Path, default=DEFAULT_REFERENCE,
                        help="the folder of the closed-loop reference data")
    parser.add_argument("--measured", type=Path,
                        help="read 2D-VSR-Sim's measurements (java-*.csv, loop-grid.csv) from "
                        "here where it has them (default: --reference)")
    parser.add_argument("--only", default=",".join(SECTIONS),
                        help=f"comma-separated sections (default: {','.join(SECTIONS)})")
    parser.add_argument("--poses", type=int, default=100, help="constant poses per shape")
    parser.add_argument("--seed", type=int, default=0, help="of the constant poses")
    parser.add_argument("--limit", type=int, metavar="K",
                        help="only the first K genomes / sine cells of each shape")
    parser.add_argument("--option", action="append", default=[], metavar="NAME=VALUE",
                        help="a SimConfig option on top of the preset (repeatable)")
    parser.add_argument("--cells", type=Path, help="also write every somite cell (CSV)")
    args = parser.parse_args()
    sections = [s.strip() for s in args.only.split(",") if s.strip()]
    unknown = set(sections) - set(SECTIONS)
    if unknown:
        parser.error(f"unknown sections {sorted(unknown)}; use {','.join(SECTIONS)}")
    measured = args.measured or args.reference
    skipped = {}
    if "grid" in sections and not measurement(measured, args.reference, GRID_FILE).is_file():
        # The shared reference has no grid: by default the section is left out, and says so.
        if args.only != parser.get_default("only"):
            parser.error(f"--only grid needs {measured / GRID_FILE} (--measured DIR)")
        sections.remove("grid")
        skipped["grid"] = f"skipped: no {GRID_FILE} in {measured} (--measured DIR)"
    if args.poses < 1 or (args.limit is not None and args.limit < 1):
        parser.error("--poses and --limit must be at least 1")
    options = parse_options(args.option)
    config = preset(PRESET, **options)
    started = time.perf_counter()
    build = {"still": lambda: still_cells(args.poses, args.seed),
             "loops": lambda: loop_cells(args.reference, measured, args.limit),
             "init": lambda: init_cells(args.reference, measured, args.limit),
             "sines": lambda: sine_cells(args.reference, measured, args.limit),
             "grid": lambda: grid_cells(args.reference, measured, args.limit)}
    cells = {s: build[s]() for s in SECTIONS if s in sections}
    batches = run_cells([c for group in cells.values() for c in group], config)
    out = {"source": source_state(), "preset": PRESET, "options": options,
           "config": config.to_dict(),
           "noise_sigma": "per section, as in the reference (still, sines: 0.01, which the "
                          "open-loop controllers do not read; loops: 0.01; init: 0.01 and 0; grid: "
                          "each cell's own)",
           "limit": args.limit, "batches": batches}
    for section, group in cells.items():
        out[section] = FIGURES[section](group)
    out.update(skipped)
    out["seconds"] = round(time.perf_counter() - started, 1)
    if args.cells:
        rows = [c.row() for group in cells.values() for c in group]
        names = list(dict.fromkeys(k for r in rows for k in r))
        with open(args.cells, "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=names, restval="")
            writer.writeheader()
            writer.writerows(rows)
    print(json.dumps(clean(out), indent=2))


if __name__ == "__main__":
    main()
