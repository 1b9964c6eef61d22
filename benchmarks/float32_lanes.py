"""What an opt-in float32 solver could gain (issue 68, item 4): the joints' velocity passes of
a group in float64 with 8 robots a vector (physics 1) against float32 with 8 and 16, on this
CPU, and the bound that puts on a whole control step.

The passes are somite's own (``sim/lane_passes.py``; 16 lanes rendered from the same templates
into a temporary module), run on 96 worms' random joint rows and velocities, one thread,
thread CPU time, the least of ``--trials`` runs of ``--passes`` passes each. The bound takes the
worm's per-part times of a control step (``benchmarks/passes.py``, ``--parts``: a JSON file of
its output, or the figures given) and supposes every joint velocity pass and the joints'
set-up gain what the spring pass gains here, and nothing else changes: the float32 solver's
whole-step speed-up can be no larger (the issue keeps it only at >= 1.3x).

    NUMBA_NUM_THREADS=1 python benchmarks/float32_lanes.py [--trials 25] [--parts passes.json]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from somite._jit import uncounted
from somite.sim import joint_lanes, lane_passes, lane_templates
from somite.sim.body import Body
from somite.sim.physics import J_IMPULSE, J_MASS, N_SPRING_COLUMNS
from somite.sim.system import geometry

ROBOTS = 96


def lanes16():
    """``lane_passes`` rendered with 16 lanes, imported from a temporary file."""
    saved = lane_templates.LANES
    text = Path(lane_templates.__file__).read_text().replace(
        f"\nLANES = {saved}\n", "\nLANES = 16\n")
    spec = importlib.util.spec_from_loader("somite.sim._templates16", loader=None)
    module = importlib.util.module_from_spec(spec)
    module.__dict__["__package__"] = "somite.sim"
    module.__dict__["__file__"] = lane_templates.__file__
    exec(compile(text, "lane_templates16", "exec"), module.__dict__)
    source = module.render()
    folder = Path(tempfile.mkdtemp(prefix="somite-lanes16-"))
    path = folder / "lane_passes16.py"
    path.write_text(source.replace("from .._jit import", "from somite._jit import")
                    .replace("from .physics import", "from somite.sim.physics import")
                    .replace("from .trig import", "from somite.sim.trig import"))
    spec = importlib.util.spec_from_file_location("lane_passes16", path)
    passes = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(passes)
    return passes


def runner(passes):
    @uncounted
    def run(joints, work, vel, inv_mass, inv_inertia, repeats):
        for g in range(vel.shape[0]):
            for _ in range(repeats):
                passes.solve_springs(joints, work[g], vel[g], inv_mass, inv_inertia)
    return run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--trials", type=int, default=25)
    parser.add_argument("--passes", type=int, default=10)
    parser.add_argument("--parts", type=Path, help="benchmarks/passes.py's JSON (worm)")
    args = parser.parse_args()
    ends = np.ascontiguousarray(geometry(Body.build("worm")).springs.astype(np.int32))
    n_springs, n_points = ends.shape[0], int(ends.max()) + 1
    joints = (ends, joint_lanes.exact_order(ends, n_points))
    rng = np.random.default_rng(0)
    work0 = rng.normal(0.0, 0.1, (ROBOTS, n_springs, N_SPRING_COLUMNS))
    work0[:, :, J_MASS] = rng.uniform(0.05, 0.1, (ROBOTS, n_springs))
    work0[:, :, J_IMPULSE] = 0.0
    vel0 = rng.normal(0.0, 1.0, (ROBOTS, n_points, 3))

    def laned(a, width, dtype):
        return np.ascontiguousarray(a.reshape(ROBOTS // width, width, *a.shape[1:])
                                    .transpose(0, 2, 3, 1)).astype(dtype)

    run8, run16 = runner(lane_passes), runner(lanes16())
    cases = {"float64, 8 lanes (physics 1)": (run8, 8, np.float64),
             "float32, 8 lanes": (run8, 8, np.float32),
             "float32, 16 lanes": (run16, 16, np.float32)}
    best = dict.fromkeys(cases, np.inf)
    out = {}
    for trial in range(args.trials):
        for name, (run, width, dtype) in cases.items():
            work, vel = laned(work0, width, dtype), laned(vel0, width, dtype)
            inv_mass, inv_inertia = np.full(n_points, 1 / 0.36, dtype), np.full(n_points,
                                                                                 1 / 0.0864, dtype)
            start = time.thread_time()
            run(joints, work, vel, inv_mass, inv_inertia, args.passes)
            if trial > 0:  # the first run of each compiles
                best[name] = min(best[name], time.thread_time() - start)
            else:
                out[name] = vel.transpose(0, 3, 1, 2).reshape(ROBOTS, n_points, 3).astype(float)
    ns = {name: b * 1e9 / (ROBOTS * args.passes * n_springs) for name, b in best.items()}
    reference = out["float64, 8 lanes (physics 1)"]
    gain = ns["float64, 8 lanes (physics 1)"] / min(ns.values())
    if args.parts:
        measured = json.loads(args.parts.read_text())
        parts = {name: measured["us_per_control_step"][name]
                 for name in ("joints: set-up", "joints: velocity passes")}
        parts["the control step"] = measured["control_step_us"]
    else:  # BENCHMARKS.md, "Kernel round 3": the worm, the better of two runs
        parts = {"joints: set-up": 0.86, "joints: velocity passes": 6.66,
                 "the control step": 16.9}
    step = parts["the control step"]
    joints_time = parts["joints: set-up"] + parts["joints: velocity passes"]
    bound = step / (step - joints_time * (1.0 - 1.0 / gain))
    print(json.dumps({
        "benchmark": "the worm's spring velocity pass, 96 robots, 1 thread",
        "ns_per_robot_spring": {k: round(v, 3) for k, v in ns.items()},
        "max_relative_difference_after_first_run": {
            k: float(np.max(np.abs(o - reference)) / np.max(np.abs(reference)))
            for k, o in out.items()},
        "best_gain_over_physics_1": round(gain, 2),
        "control_step_parts_us": parts,
        "whole_step_bound": round(bound, 2),
    }, indent=1))


if __name__ == "__main__":
    sys.exit(main())
