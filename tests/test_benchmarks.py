"""The benchmark scripts run and print the JSON that BENCHMARKS.md quotes (at tiny sizes: no
timing is checked). One of them once broke unnoticed when the log gained a column."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT.parent / "shared/reference/vsr-sine-sweep.csv"
needs_reference = pytest.mark.skipif(not REFERENCE.exists(),
                                     reason="the reference measurements are not beside the clone")


def run_script(name: str, *args: str) -> dict | list:
    done = subprocess.run([sys.executable, str(ROOT / "benchmarks" / name), *args],
                          capture_output=True, text=True, cwd=ROOT, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    lines = done.stdout.strip().splitlines()
    if name == "calibrate.py":  # JSON lines
        return [json.loads(line) for line in lines]
    return json.loads(done.stdout)


def test_kernel_benchmark():
    out = run_script("kernel.py", "--robots", "4", "--duration", "0.5")
    assert {p["shape"] for p in out["populations"]} == {"worm", "biped"}
    for p in out["populations"]:
        assert p["robots"] == 4 and p["steps_per_robot"] == 30 and p["finite"]
        assert p["robot_control_steps_per_second"] > 0
    assert "loaded_from_cache" in out["compile"]


def test_stepper_benchmark():
    out = run_script("stepper.py", "--robots", "2", "--duration", "0.1", "--repeats", "1")
    assert out["robots"] == 2 and out["control_steps"] == 6
    assert set(out["first_call_seconds"]) == {"compiled_loop", "stepper"}
    for figures in out["by_threads"].values():
        assert set(figures["run_seconds"]) == {"compiled_loop", "stepper",
                                               "stepper_given_actuation"}


def test_robot_parts_benchmark():
    out = run_script("robot_parts.py", "--shape", "worm", "--calls", "2", "--repeats", "1")
    (worm,) = out
    assert worm["shape"] == "worm" and worm["robots"] == 8
    assert {"find_contacts", "sense", "controller", "lowest_gap"} <= set(worm["parts"])
    assert worm["exp"]["calls a step"] > worm["controller"]["nodes"]
    assert worm["controller"]["bit for bit"]


def test_generation_benchmark():
    out = run_script("generation.py", "--generations", "2", "--population", "4", "--evolved",
                     "2")
    assert out["population"] == 4
    assert set(out["seconds"]) >= {"select_and_mutate", "kernel", "log_and_bests"}
    assert out["generation_seconds"] == pytest.approx(sum(out["seconds"].values()), abs=1e-3)
    assert 0.0 <= out["python_overhead_fraction"] < 1.0


@needs_reference
def test_fidelity_benchmark():
    out = run_script("fidelity.py")
    for shape in ("worm-6x2", "biped-4x3"):
        figures = out["fidelity"][shape]
        assert -1.0 <= figures["rank_all"] <= 1.0
        assert len(figures["best_ratio"]) == 4
        assert set(figures["com_height_ratio"]) == {"synchronous", "other"}
        assert figures["somite"]["negative_area_episodes"] == 0


@needs_reference
def test_calibrate_scores_the_defaults_like_fidelity():
    rows = run_script("calibrate.py", "--jump-limit", "1.2", "search", "--count", "1",
                      "--range", "friction=1.48,1.48")
    assert len(rows) == 1
    assert rows[0]["options"] == {"friction": 1.48}
    assert len(rows[0]["misses"]) == 2 and rows[0]["score"] >= 0.0
    assert "synchronous_jump_ratio" in rows[0]["figures"]["worm-6x2"]


HELD_OUT = ROOT / "benchmarks/reference"
COLUMNS = ("shape,terrain,freq,phase_name,phase,vx,max_abs_tilt_deg,flipped_frac,max_air_gap,"
           "max_com_height,max_com_speed,min_quad_ratio,min_area_ratio,max_area_ratio")


@pytest.mark.parametrize("name, cells", [("heldout-1", 152), ("heldout-1-a0999", 128),
                                         ("heldout-2", 80), ("heldout-2-a0999", 80),
                                         ("heldout-3", 240), ("heldout-3-a0999", 240)])
def test_held_out_cells_have_the_reference_format(name, cells):
    lines = (HELD_OUT / f"{name}.csv").read_text().splitlines()
    assert lines[0] == COLUMNS
    assert len(lines) - 1 == cells
    assert {line.split(",")[0] for line in lines[1:]} == {"worm-6x2", "biped-4x3"}


def test_fidelity_on_the_held_out_cells():
    cells = HELD_OUT / "heldout-2.csv"
    out = run_script("fidelity.py", "--reference", str(cells),
                     "--reference-chaos", str(HELD_OUT / "heldout-2-a0999.csv"))
    rows = [line.split(",") for line in cells.read_text().splitlines()[1:]]
    for shape in ("worm-6x2", "biped-4x3"):
        figures = out["fidelity"][shape]
        assert len(figures["best_ratio"]) == 4  # flat and three hilly terrains
        assert figures["somite"]["negative_area_episodes"] == 0
        # The reference's own figures are read from the file, not simulated.
        tipped = sum(r[0] == shape and float(r[6]) > 90 for r in rows)
        assert figures["reference"]["tipped"] == tipped
        assert -1.0 <= out["reference_chaos"][shape]["rank_all"] < 1.0
    same = run_script("fidelity.py", "--reference", str(cells), "--reference-chaos", str(cells))
    for shape in ("worm-6x2", "biped-4x3"):
        assert same["reference_chaos"][shape]["rank_all"] == pytest.approx(1.0)
        assert same["reference_chaos"][shape]["rank_per_gait"] == pytest.approx(1.0)


def test_calibrate_adds_up_the_misses_of_several_grids(tmp_path):
    # Each held-out grid cut to both shapes on flat ground and one hilly terrain, every third
    # gait on each: the sums are as honest at a sixth of the simulation.
    grids = []
    for name in ("heldout-1.csv", "heldout-2.csv"):
        header, *rows = (HELD_OUT / name).read_text().splitlines()
        cells = [row.split(",") for row in rows]
        terrains = sorted({cell[1] for cell in cells})[:2]
        gaits = sorted({(cell[2], cell[3]) for cell in cells})[::3]
        kept = [row for row, cell in zip(rows, cells)
                if cell[1] in terrains and (cell[2], cell[3]) in gaits]
        (tmp_path / name).write_text("\n".join([header, *kept]) + "\n")
        grids.append(tmp_path / name)
    search = ("--jump-limit", "1.2", "search", "--count", "1", "--range", "friction=1.48,1.48")
    one = [run_script("calibrate.py", "--reference", str(grid), *search)[0] for grid in grids]
    both = run_script("calibrate.py", "--reference", str(grids[0]), "--reference",
                      str(grids[1]), *search)[0]
    assert both["options"] == {"friction": 1.48}
    assert set(both["references"]) == {"heldout-1.csv", "heldout-2.csv"}
    for name, alone in zip(("heldout-1.csv", "heldout-2.csv"), one):
        assert both["references"][name]["score"] == alone["score"]
        assert both["references"][name]["figures"] == alone["figures"]
    assert both["score"] == pytest.approx(one[0]["score"] + one[1]["score"])
    assert one[0]["score"] > 0.0 and one[1]["score"] > 0.0


VARIANTS = HELD_OUT / "variants"
VARIANT_NAMES = ("restitution-0", "friction-5", "angular-damping-10", "spring-damping-0.6",
                 "blocks-0.25")


@pytest.mark.parametrize("variant", VARIANT_NAMES)
@pytest.mark.parametrize("grid, cells", [("vsr-sine-sweep", 200), ("heldout-1", 152),
                                         ("heldout-3", 240)])
def test_variant_cells_are_those_of_their_grid(grid, cells, variant):
    lines = (VARIANTS / f"{grid}-{variant}.csv").read_text().splitlines()
    assert lines[0] == COLUMNS
    assert len(lines) - 1 == cells
    if grid != "vsr-sine-sweep":  # the shared grid is not in the clone
        ref = (HELD_OUT / f"{grid}.csv").read_text().splitlines()
        # Same cells in the same order (shape, terrain, freq, phase), different physics.
        assert [line.split(",")[:5] for line in lines] == [line.split(",")[:5] for line in ref]
        assert [line.split(",")[5] for line in lines[1:]] != [line.split(",")[5]
                                                               for line in ref[1:]]



@pytest.mark.parametrize("grid, cells, steps", [
    ("vsr-sine-sweep", 200, (120, 240, 480)), ("heldout-1", 152, (120,)),
    ("heldout-2", 80, (120,)), ("heldout-3", 240, (120,))])
def test_time_step_variants_hold_their_grid_cells(grid, cells, steps):
    ref = None if grid == "vsr-sine-sweep" else (HELD_OUT / f"{grid}.csv").read_text().splitlines()
    speeds = [] if ref is None else [[line.split(",")[5] for line in ref[1:]]]
    for n in steps:
        lines = (VARIANTS / f"{grid}-timestep-{n}.csv").read_text().splitlines()
        assert lines[0] == COLUMNS
        assert len(lines) - 1 == cells
        if ref is not None:  # the shared grid is not in the clone
            assert [line.split(",")[:5] for line in lines] == [line.split(",")[:5]
                                                               for line in ref]
        speeds.append([line.split(",")[5] for line in lines[1:]])
    # Each time step gives its own speeds: no file is a copy of another.
    assert len({tuple(s) for s in speeds}) == len(speeds)

def test_fidelity_against_a_variant_of_the_reference():
    cells = HELD_OUT / "heldout-1.csv"
    variant = VARIANTS / "heldout-1-restitution-0.csv"
    out = run_script("fidelity.py", "--reference", str(cells), "--reference-variant",
                     str(variant), "--reference-variant", str(cells))
    assert set(out["reference_variants"]) == {"heldout-1-restitution-0", "heldout-1"}
    rows = [line.split(",") for line in variant.read_text().splitlines()[1:]]
    for shape in ("worm-6x2", "biped-4x3"):
        moved = out["reference_variants"]["heldout-1-restitution-0"][shape]
        assert -1.0 <= moved["rank_all"] < 1.0
        shape_rows = [r for r in rows if r[0] == shape]
        assert moved["tipped_rate"] == pytest.approx(
            sum(float(r[6]) > 90 for r in shape_rows) / len(shape_rows))
        # Against itself, the reference agrees perfectly and somite's ranks are fidelity's.
        itself = out["reference_variants"]["heldout-1"][shape]
        assert itself["rank_all"] == pytest.approx(1.0)
        assert itself["somite_rank_all"] == out["fidelity"][shape]["rank_all"]
        assert itself["somite_rank_per_gait"] == out["fidelity"][shape]["rank_per_gait"]


def test_calibrate_tipping_band_scores_tipping_too_rarely():
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        from calibrate import miss
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    met = {"rank_all": 0.9, "rank_per_gait": 0.9, "fastest_ratio": 1.0,
           "best_ratio_in_range": 4, "com_height_ratio": {"synchronous": 1.0}}
    report = {
        "worm-6x2": {**met, "somite": {"tipped_rate": 0.0, "stall_rate": 0.0},
                     "reference": {"tipped_rate": 0.0, "stall_rate": 0.0}},
        "biped-4x3": {**met, "somite": {"tipped_rate": 0.05, "stall_rate": 0.0},
                      "reference": {"tipped_rate": 0.3, "stall_rate": 0.0}},
    }
    assert miss(report) == 0.0  # the targets cap tipping only from above
    assert miss(report, tipping_band=True) == pytest.approx(0.3 / 1.5 - 0.05)
    report["biped-4x3"]["somite"]["tipped_rate"] = 0.5
    assert miss(report) == miss(report, tipping_band=True) == pytest.approx(0.5 - 0.45)


def test_throughput_benchmark():
    out = run_script("throughput.py", "--duration", "0.1", "--repeats", "1", "--sizes", "1", "3")
    assert out["shape"] == "worm" and "loaded_from_cache" in out["compile"]
    for rows in out["by_threads"].values():
        assert [r["robots"] for r in rows] == [1, 3]
        assert all(r["robot_control_steps_per_second"] > 0 for r in rows)
