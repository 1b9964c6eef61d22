"""The order of one physics step, written once.

dyn4j's ``Island.solve`` (docs/original-system.md section 1.1; :mod:`somite.sim.physics`):
gravity and damping, the contacts set up; the joints set up and warm-started;
``velocity_iterations`` passes over the joints, then the contacts; the move; up to
``position_iterations`` position passes, until everything holds; the contacts for the next step
found. :func:`step` says that order over a *solver*, a named tuple that holds what one step
works on, and each phase is carried out by the solver's own kind:

- :class:`somite.sim.physics.Alone`: one robot, its arrays (the CUDA kernel, the stepper, a
  group of one);
- :class:`somite.sim.group.InLanes`: a group of robots with the same body, the joints in the
  lanes of vector instructions, the contacts robot by robot on their lanes.

A kind says how it does a phase with :func:`implements`; Numba picks the implementation by the
solver's type when it compiles :func:`step` (each phase is a Numba ``overload``), so choosing
costs nothing at run time; each phase is a call (BENCHMARKS.md, "Kernel round 2, the
layout"). The CUDA backend compiles :func:`step` for one robot: its twin
(``_jit.device_twin``) calls the twins of the phases' ``on_device`` implementations.

Every phase takes ``(solver, params)``; :func:`fix_positions` returns whether the contacts,
rope limits and welds all hold after its pass.
"""

from __future__ import annotations

from numba.extending import overload

from .._jit import OPTIONS, njit

_PHASE_OPTIONS = {**{k: v for k, v in OPTIONS.items() if k != "cache"}, "_nrt": False}


def _phase(name: str, doc: str):
    """A phase of :func:`step`: a function that Numba resolves by the solver's type; called
    from Python (``NUMBA_DISABLE_JIT=1``, to step through it), the same implementation by the
    solver's class, or a TypeError when no kind does it."""

    def phase(solver, params):
        function = phase.implementations.get(type(solver))
        if function is None:
            raise TypeError(f"no physics step for a solver of type {type(solver).__name__}")
        return function(solver, params)

    phase.__name__ = phase.__qualname__ = name
    phase.__doc__ = doc
    return phase


begin = _phase("begin", "Gravity and damping on the velocities; the contacts set up from the "
                        "positions.")
start_joints = _phase("start_joints", "The springs, rope limits and welds set up and "
                                      "warm-started.")
solve_joints = _phase("solve_joints", "One velocity pass over the springs, rope limits and welds.")
solve_contacts = _phase("solve_contacts", "One velocity pass over the contacts.")
move = _phase("move", "The bodies moved with their velocities and turned.")
fix_positions = _phase("fix_positions", "One position pass over the contacts, rope limits and "
                                        "welds: whether all hold.")
end = _phase("end", "The contacts for the next step found.")

PHASES = (begin, start_joints, solve_joints, solve_contacts, move, fix_positions, end)
"""The phases of :func:`step`, in its order (a phase's passes may repeat)."""


def implements(phase, kind, on_device: bool = False):
    """Register the decorated function (compiled with ``_jit.njit``, arguments
    ``(solver, params)``) as how solvers of the named-tuple class ``kind`` do ``phase``;
    ``on_device``: the CUDA kernel's too."""

    def register(function):
        phase.implementations[kind] = function
        if on_device:
            phase.on_device = function
        return function

    return register


def _overload(phase) -> None:
    phase.implementations = {}

    # Not inline="always": Numba's inlining of overloads mixed up the variables of the
    # phases' own inlined functions (a step then differed from the one-robot passes in
    # pos by 0.13 m). Compiled as separate functions with the kernels' options instead, which
    # LLVM may still inline.
    @overload(phase, jit_options=_PHASE_OPTIONS)
    def choose(solver, params):
        function = phase.implementations.get(getattr(solver, "instance_class", None))
        return None if function is None else function.py_func


for _phase in PHASES:
    _overload(_phase)


@njit(inline="always")
def step(solver, params):
    """One physics step of dt = ``params.dt`` of solver ``s`` (module docstring)."""
    begin(solver, params)
    start_joints(solver, params)
    for _ in range(params.velocity_iterations):
        solve_joints(solver, params)
        solve_contacts(solver, params)
    move(solver, params)
    for _ in range(params.position_iterations):
        if fix_positions(solver, params):
            break
    end(solver, params)
