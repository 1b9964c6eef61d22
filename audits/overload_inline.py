"""Why the phases of ``somite.sim.step`` are not inlined: Numba's ``overload(inline="always")``
gives wrong numbers on them (Numba 0.68.1).

One physics step of a worm mid-episode, done three ways from the same state: the phases called
one by one as plain functions (the truth), ``sim.step.step`` as shipped (each phase a call), and
the same order over phases registered with ``overload(..., inline="always")``. Prints the
largest difference of each from the truth in positions and velocities; the first is 0, the
second was 0.13 m and 7.6 m/s when this was written. Run: ``python audits/overload_inline.py``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from numba.extending import overload

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.test_reference_step import random_state  # noqa: E402

from somite._jit import njit  # noqa: E402
from somite.sim import physics as ph  # noqa: E402
from somite.sim import step as order  # noqa: E402


def _inlined(phase):
    def stub(solver, params):
        raise TypeError(type(solver).__name__)

    @overload(stub, inline="always")
    def choose(solver, params):
        return phase.implementations[solver.instance_class].py_func

    return stub


begin, start_joints, solve_joints, solve_contacts, move, fix_positions, end = (
    _inlined(phase) for phase in order.PHASES)


@njit(cache=False)
def truth(robot, ground, scratch, pos, vel, params):
    s = ph.Alone(robot, ground, scratch, pos, vel)
    ph._begin(s, params)
    ph._start_joints(s, params)
    for _ in range(params.velocity_iterations):
        ph._solve_joints(s, params)
        ph._solve_contacts(s, params)
    ph._move(s, params)
    for _ in range(params.position_iterations):
        if ph._fix_positions(s, params):
            break
    ph._end(s, params)


@njit(cache=False)
def shipped(robot, ground, scratch, pos, vel, params):
    order.step(ph.Alone(robot, ground, scratch, pos, vel), params)


@njit(cache=False)
def inlined(robot, ground, scratch, pos, vel, params):
    s = ph.Alone(robot, ground, scratch, pos, vel)
    begin(s, params)
    start_joints(s, params)
    for _ in range(params.velocity_iterations):
        solve_joints(s, params)
        solve_contacts(s, params)
    move(s, params)
    for _ in range(params.position_iterations):
        if fix_positions(s, params):
            break
    end(s, params)


def main() -> None:
    for name, way in (("shipped", shipped), ("inlined overloads", inlined)):
        robot, ground, scratch, pos, vel, params = random_state("worm", "flat", 0)
        copy = type(scratch)(*(a.copy() for a in scratch))
        pos2, vel2 = pos.copy(), vel.copy()
        truth(robot, ground, scratch, pos, vel, params)
        way(robot, ground, copy, pos2, vel2, params)
        print(f"{name}: largest difference in pos {np.abs(pos - pos2).max():.3g} m, "
              f"in vel {np.abs(vel - vel2).max():.3g} m/s")


if __name__ == "__main__":
    main()
