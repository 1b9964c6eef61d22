"""``benchmarks/closed_loop.py`` runs and prints the JSON of its sections (at tiny sizes: no
timing is checked, and the figures are only checked to be numbers of the right kind)."""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT.parent / "shared/reference/closed-loop"
MEASURED = ROOT / "benchmarks/reference/closed-loop"
pytestmark = pytest.mark.skipif(not (REFERENCE / "java-loops.csv").exists(),
                                reason="the reference measurements are not beside the clone")
SHAPES = ("worm-6x2", "biped-4x3")
TERRAINS = ("flat", "hilly-1-10-10000", "hilly-1-10-10001", "hilly-1-10-10002")
POSES, LIMIT = 3, 4


def run_script(*args: str) -> dict:
    done = subprocess.run([sys.executable, str(ROOT / "benchmarks/closed_loop.py"), *args],
                          capture_output=True, text=True, cwd=ROOT, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout)


def finite(value) -> bool:
    return isinstance(value, (int, float)) and math.isfinite(value)


def rank(value) -> bool:
    """A rank correlation, or None where it is not defined (too few cells)."""
    return value is None or -1.0 <= value <= 1.0


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    cells = tmp_path_factory.mktemp("closed-loop") / "cells.csv"
    out = run_script("--poses", str(POSES), "--limit", str(LIMIT), "--option", "friction=1.65",
                     "--cells", str(cells))
    with open(cells, newline="") as f:
        return out, list(csv.DictReader(f))


def test_every_section_is_there(tiny):
    out, _ = tiny
    assert {"still", "loops", "init", "sines"} <= set(out)
    # The shared reference has no loop grid: left out by default, and said so.
    assert out["grid"].startswith("skipped: no loop-grid.csv")
    assert out["preset"] == "original-code"
    assert out["options"] == {"friction": 1.65} and out["config"]["friction"] == 1.65
    assert out["config"]["hidden_activation"] == "sigmoid"
    assert sum(b["robots"] for b in out["batches"]) == (
        2 * POSES + 2 * LIMIT * 2 + 2 * LIMIT * len(TERRAINS) * 2 + 2 * LIMIT)


def test_still_poses(tiny):
    out, _ = tiny
    for shape in SHAPES:
        figures = out["still"][shape]
        assert figures["poses"] == POSES and figures["non_finite"] == 0
        assert 0.0 <= figures["mean_abs_vx"] <= figures["max_abs_vx"] < 1.0
        assert 0.0 <= figures["share_above"] <= 1.0
        # Resting on the ground: the lowest corner is within a few centimetres of it.
        assert -0.2 < figures["min_corner_height"] < 0.2
        assert figures["deepest_penetration"] >= 0.0
        assert figures["reference"]["max_abs_vx"] in (0.015, 0.007)


def test_loops(tiny):
    out, _ = tiny
    for shape in SHAPES:
        figures = out["loops"][shape]
        assert len(figures["cells"]) == LIMIT * 2
        for cell in figures["cells"].values():
            assert all(finite(v) for pair in cell.values() for v in pair)
        fastest = figures["fastest_flat"]
        assert finite(fastest["somite"]["vx"]) and finite(fastest["reference"]["vx"])
        assert 0 <= figures["fast_loops_in_range"] <= len(figures["fast_loops"])
    # The worm's first loops hold W 16, which 2D-VSR-Sim takes faster than 1 m/s.
    assert out["loops"]["worm-6x2"]["fast_loops"]


def test_initial_genomes(tiny):
    out, _ = tiny
    for shape in SHAPES:
        figures = out["init"][shape]
        assert set(figures["per_terrain"]) == set(TERRAINS)
        for per_sigma in figures["per_terrain"].values():
            assert set(per_sigma) == {"sigma=0.01", "sigma=0"}
            for f in per_sigma.values():
                assert f["genomes"] == LIMIT and f["non_finite"] == 0 and rank(f["rank"])
                assert finite(f["somite"]["median"]) and finite(f["reference"]["q90"])
                assert f["median_diff"] == pytest.approx(
                    f["somite"]["median"] - f["reference"]["median"])
        assert finite(figures["max_abs_median_diff_noise_on"])
        assert set(figures["noise_sensitivity_rank"]) == set(TERRAINS)
        for pair in figures["noise_sensitivity_rank"].values():
            assert rank(pair["somite"]) and rank(pair["reference"])


def test_sines(tiny):
    out, _ = tiny
    for shape in SHAPES:
        figures = out["sines"][shape]
        assert figures["cells"] == LIMIT and figures["non_finite"] == 0
        assert rank(figures["rank_all"])
        assert sum(b["cells"] for b in figures["rank_per_band"].values()) == LIMIT
        assert all(finite(v) and v > 0 for v in figures["best_ratio"].values())
        for freq, f in figures["ar_h1_per_freq"].items():
            # At 1-3 Hz, a voxel's area swings by about a fifth of its rest area.
            assert 0.0 < f["somite"] < 1.0 and 0.0 < f["reference"] < 1.0, freq


def test_cells_file_holds_every_cell(tiny):
    _, rows = tiny
    counts = {}
    for row in rows:
        counts[row["section"]] = counts.get(row["section"], 0) + 1
        assert math.isfinite(float(row["vx"]))
    assert counts == {"still": 2 * POSES, "loops": 2 * LIMIT * 2,
                      "init": 2 * LIMIT * len(TERRAINS) * 2, "sines": 2 * LIMIT}
    assert all(row["ref_vx"] for row in rows if row["section"] != "still")


def test_only_runs_the_sections_asked_for():
    out = run_script("--only", "still", "--poses", "2")
    assert "still" in out and not {"loops", "init", "sines"} & set(out)
    assert [b["robots"] for b in out["batches"]] == [4]
    assert out["still"]["worm-6x2"]["poses"] == 2


def test_the_loop_grid_and_the_reference_floor():
    out = run_script("--measured", str(MEASURED / "no-ccd"), "--only", "grid,sines",
                     "--limit", "2")
    for shape in SHAPES:
        grid = out["grid"][shape]
        assert set(grid["per_terrain"]) == {"flat", "hilly-1-10-10000", "hilly-1-10-10001"}
        for f in grid["per_terrain"].values():
            # Two gains a shape (--limit 2) at four noise levels.
            assert f["cells"] == 2 * 4 and all(finite(v) for v in f["median"])
            assert all(0 <= n <= f["cells"] for n in f["faster_than_1"])
        assert rank(grid["rank_all_cells"])
        floor = out["sines"][shape]["reference_floor"]
        assert floor["cells"] == 2 and rank(floor["rank_all"])
    assert sum(b["robots"] for b in out["batches"]) == 2 * 2 * 3 * 4 + 2 * 2


def test_the_grid_needs_its_measurements():
    done = subprocess.run([sys.executable, str(ROOT / "benchmarks/closed_loop.py"),
                           "--only", "grid"], capture_output=True, text=True, cwd=ROOT, timeout=900)
    assert done.returncode == 2 and "loop-grid.csv (--measured DIR)" in done.stderr
    # stock/ has the grid but not the loops: those come from the shared reference.
    out = run_script("--measured", str(MEASURED / "stock"), "--only", "grid,loops", "--limit", "1")
    assert out["grid"]["worm-6x2"]["per_terrain"]["flat"]["cells"] == 4
    assert len(out["loops"]["worm-6x2"]["cells"]) == 2
