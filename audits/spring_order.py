"""What the order of the springs costs in the lanes' velocity pass (issue 68, item 3).

``lane_passes.solve_springs`` over 12 groups of 8 worms' random states, 20 passes, in four
orders that give the same bits (a voxel's springs join only its own four blocks): index order,
``joint_lanes.exact_order`` and the voxel-interleaved order (spring k of every voxel, then k + 1),
each through the order array the pass takes ("indirect") and with the springs' ends permuted
and the order the identity ("permuted"). Thread CPU time, the least of 25 trials, in ns a
spring and lane. Prints JSON.

    NUMBA_NUM_THREADS=1 python audits/spring_order.py
"""

from __future__ import annotations

import json
import time

import numpy as np

from somite._jit import uncounted
from somite.sim import joint_lanes as jl
from somite.sim import lane_passes as lp
from somite.sim.body import Body
from somite.sim.physics import J_IMPULSE, J_MASS, N_SPRING_COLUMNS
from somite.sim.system import geometry

GROUPS, PASSES, TRIALS = 12, 20, 25


@uncounted
def run(joints, work, vel, inv_mass, inv_inertia, passes):
    for group in range(vel.shape[0]):
        for _ in range(passes):
            lp.solve_springs(joints, work[group], vel[group], inv_mass, inv_inertia)


def main() -> None:
    body = Body.build("worm")
    ends = np.ascontiguousarray(geometry(body).springs.astype(np.int32))
    springs, points, voxels = ends.shape[0], 4 * body.shape.n_voxels, body.shape.n_voxels
    rng = np.random.default_rng(0)
    work0 = rng.normal(0.0, 0.1, (GROUPS, springs, N_SPRING_COLUMNS, lp.LANES))
    work0[:, :, J_MASS] = rng.uniform(0.05, 0.1, (GROUPS, springs, lp.LANES))
    work0[:, :, J_IMPULSE] = 0.0
    vel0 = rng.normal(0.0, 1.0, (GROUPS, points, 3, lp.LANES))
    inv_mass, inv_inertia = np.full(points, 1 / 0.36), np.full(points, 1 / 0.0864)
    identity = np.arange(springs)
    exact = jl.exact_order(ends, points)
    per = springs // voxels
    interleaved = np.array([v * per + k for k in range(per) for v in range(voxels)])
    cases = {"index order": (ends, identity),
             "exact order, indirect": (ends, exact),
             "exact order, permuted": (np.ascontiguousarray(ends[exact]), identity),
             "voxel-interleaved, indirect": (ends, interleaved),
             "voxel-interleaved, permuted": (np.ascontiguousarray(ends[interleaved]), identity)}
    best = dict.fromkeys(cases, np.inf)
    for _ in range(TRIALS):
        for name, joints in cases.items():
            work, vel = work0.copy(), vel0.copy()
            start = time.thread_time()
            run(joints, work, vel, inv_mass, inv_inertia, PASSES)
            best[name] = min(best[name], time.thread_time() - start)
    scale = 1e9 / (GROUPS * lp.LANES * PASSES * springs)
    print(json.dumps({"benchmark": "lanes' spring velocity pass, ns a spring and lane",
                      **{name: round(b * scale, 3) for name, b in best.items()}}, indent=1))


if __name__ == "__main__":
    main()
