"""The joints' velocity passes for :data:`LANES` robots of one body at once, robots innermost.

Every robot of a group (:mod:`somite.tasks.lanes`) has the same body, so a joint joins the same
two blocks in each, and only the state differs. Here the state is stored robots innermost:
``pos`` and ``vel`` (P, 3, LANES), ``cos`` and ``sin`` (P, LANES), a joint's work row (columns,
LANES); one joint's values of the LANES robots are adjacent in memory. Each function loads
them all, computes each robot's new values with :mod:`somite.sim.physics`'s own functions of
values (``spring_terms``, ``spring_impulse``, ``pushed``, ...), and only then stores them.
Because nothing is stored before everything is loaded, the compiler may take the LANES robots'
identical arithmetic as vector instructions (LLVM's SLP vectoriser, which somite turns on:
``somite._jit``), with each robot's numbers exactly those of the one-robot passes.

Loads, computations and stores are written out once per robot: the functions are generated
from the templates below (a loop over the robots would store robot 1's values before it loads
robot 2's, and the compiler cannot prove that they do not overlap). A template line holds
``{l}`` where the robot's lane goes.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .._jit import njit
from . import physics
from .trig import sincos

LANES = 8
"""Robots a group advances together (`somite bench`, 96 worms, 2 threads, one sitting: 4 lanes
114k-117k robot-control-steps a second, 8 lanes 128k-136k, 16 lanes 122k-128k)."""

# Columns of a group's flags (LANES, 4), a row a lane: its robot's position passes are over
# (or it holds no running robot), and what this pass found of its contacts, ropes, welds.
DONE, CONTACTS_HELD, ROPES_HELD, WELDS_HELD = range(4)

_LANE_NAMES = ("rotated", "spring_terms", "spring_impulse", "pushed", "unit", "rope_impulse",
               "weld_pushed", "weld_impulse", "BLOCK_SIDE", "moved", "rope_fixed", "weld_fixed")
_COLUMNS = [name for name in dir(physics) if name[:2] in ("J_", "R_", "W_")]


def _generated(name: str, args: str, joint: list[str], load: list[str], compute: list[str],
               store: list[str], before: list[str] = (), after: list[str] = (),
               loop: tuple[str, ...] = ("for m in range(ends.shape[0]):", "a = ends[m, 0]",
                                        "b = ends[m, 1]")):
    """The compiled pass ``name(args)`` from generated source: each line of ``before`` for
    every lane, then for each joint m of ``ends`` (or each item of another ``loop``): ``joint``
    once, then each line of ``load``, ``compute`` and ``store`` for every lane in turn; then
    ``after`` for every lane."""
    lines = [f"def {name}({args}):"]
    lines += ["    " + line.format(l=lane) for line in before for lane in range(LANES)]
    lines += ["    " + loop[0]] + ["        " + line for line in loop[1:]]
    lines += ["        " + line for line in joint]
    for part in (load, compute, store):
        for line in part:
            lines += ["        " + line.format(l=lane) for lane in range(LANES)]
    lines += ["    " + line.format(l=lane) for line in after for lane in range(LANES)]
    namespace = {name: getattr(physics, name) for name in (*_LANE_NAMES, *_COLUMNS)}
    namespace.update(sincos=sincos, DONE=DONE, ROPES_HELD=ROPES_HELD, WELDS_HELD=WELDS_HELD)
    namespace["__name__"] = __name__
    exec(compile("\n".join(lines), __file__, "exec"), namespace)
    # Called, not inlined: a pass is long enough that a call costs nothing, and each is
    # compiled once (inlining its eight copies of the arithmetic into every caller cost
    # a minute of compiling).
    return njit(_nrt=False)(namespace[name])


_MASSES = ["ima = inv_mass[a]", "iia = inv_inertia[a]", "imb = inv_mass[b]",
           "iib = inv_inertia[b]", "va = vel[a]", "vb = vel[b]", "w = work[m]"]
_VELOCITIES = ["a0_{l} = va[0, {l}]", "a1_{l} = va[1, {l}]", "a2_{l} = va[2, {l}]",
               "b0_{l} = vb[0, {l}]", "b1_{l} = vb[1, {l}]", "b2_{l} = vb[2, {l}]"]
_STORE_VELOCITIES = ["va[0, {l}] = a0_{l}", "va[1, {l}] = a1_{l}", "va[2, {l}] = a2_{l}",
                     "vb[0, {l}] = b0_{l}", "vb[1, {l}] = b1_{l}", "vb[2, {l}] = b2_{l}"]
_NEW = "a0_{l}, a1_{l}, a2_{l}, b0_{l}, b1_{l}, b2_{l} = "
_OLD = "a0_{l}, a1_{l}, a2_{l}, b0_{l}, b1_{l}, b2_{l}"

start_springs = _generated(
    "start_springs", "ends, anchor, rest, work, pos, vel, cos, sin, inv_mass, inv_inertia, dt, "
    "omega, damping_ratio",
    _MASSES + ["pa = pos[a]", "pb = pos[b]", "ca = cos[a]", "sa = sin[a]", "cb = cos[b]",
               "sb = sin[b]", "oax = anchor[m, 0]", "oay = anchor[m, 1]", "obx = anchor[m, 2]",
               "oby = anchor[m, 3]"],
    _VELOCITIES + ["pa0_{l} = pa[0, {l}]", "pa1_{l} = pa[1, {l}]", "pb0_{l} = pb[0, {l}]",
                   "pb1_{l} = pb[1, {l}]", "ca_{l} = ca[{l}]", "sa_{l} = sa[{l}]",
                   "cb_{l} = cb[{l}]", "sb_{l} = sb[{l}]", "rest_{l} = rest[m, {l}]",
                   "j_{l} = w[J_IMPULSE, {l}]"],
    ["rax_{l}, ray_{l} = rotated(oax, oay, ca_{l}, sa_{l})",
     "rbx_{l}, rby_{l} = rotated(obx, oby, cb_{l}, sb_{l})",
     "nx_{l}, ny_{l}, mass_{l}, gamma_{l}, bias_{l} = spring_terms(pa0_{l}, pa1_{l}, pb0_{l}, "
     "pb1_{l}, rax_{l}, ray_{l}, rbx_{l}, rby_{l}, rest_{l}, ima, iia, imb, iib, dt, omega, "
     "damping_ratio)",
     _NEW + "pushed(" + _OLD + ", rax_{l}, ray_{l}, rbx_{l}, rby_{l}, nx_{l} * j_{l}, "
     "ny_{l} * j_{l}, ima, iia, imb, iib)"],
    ["w[J_RAX, {l}] = rax_{l}", "w[J_RAY, {l}] = ray_{l}", "w[J_RBX, {l}] = rbx_{l}",
     "w[J_RBY, {l}] = rby_{l}", "w[J_NX, {l}] = nx_{l}", "w[J_NY, {l}] = ny_{l}",
     "w[J_MASS, {l}] = mass_{l}", "w[J_GAMMA, {l}] = gamma_{l}", "w[J_BIAS, {l}] = bias_{l}"]
    + _STORE_VELOCITIES)
"""Each spring set up for this step and warm-started (``physics.spring_setup``)."""

solve_springs = _generated(
    "solve_springs", "ends, work, vel, inv_mass, inv_inertia", _MASSES,
    _VELOCITIES + ["rax_{l} = w[J_RAX, {l}]", "ray_{l} = w[J_RAY, {l}]",
                   "rbx_{l} = w[J_RBX, {l}]", "rby_{l} = w[J_RBY, {l}]",
                   "nx_{l} = w[J_NX, {l}]", "ny_{l} = w[J_NY, {l}]",
                   "mass_{l} = w[J_MASS, {l}]", "bias_{l} = w[J_BIAS, {l}]",
                   "gamma_{l} = w[J_GAMMA, {l}]", "impulse_{l} = w[J_IMPULSE, {l}]"],
    ["j_{l} = spring_impulse(rax_{l}, ray_{l}, rbx_{l}, rby_{l}, nx_{l}, ny_{l}, mass_{l}, "
     "bias_{l}, gamma_{l}, impulse_{l}, " + _OLD + ")",
     _NEW + "pushed(" + _OLD + ", rax_{l}, ray_{l}, rbx_{l}, rby_{l}, nx_{l} * j_{l}, "
     "ny_{l} * j_{l}, ima, iia, imb, iib)"],
    ["w[J_IMPULSE, {l}] = impulse_{l} + j_{l}"] + _STORE_VELOCITIES)
"""One velocity pass over the springs (``physics.spring_solve``)."""

start_ropes = _generated(
    "start_ropes", "ends, work, pos, vel, inv_mass, inv_inertia",
    _MASSES + ["pa = pos[a]", "pb = pos[b]", "mass = 1.0 / (ima + imb)"],
    _VELOCITIES + ["pa0_{l} = pa[0, {l}]", "pa1_{l} = pa[1, {l}]", "pb0_{l} = pb[0, {l}]",
                   "pb1_{l} = pb[1, {l}]", "j_{l} = w[R_IMPULSE, {l}]",
                   "nx0_{l} = w[R_NX, {l}]", "ny0_{l} = w[R_NY, {l}]",
                   "mass0_{l} = w[R_MASS, {l}]"],
    ["nx_{l}, ny_{l}, length_{l} = unit(pa0_{l} - pb0_{l}, pa1_{l} - pb1_{l})",
     "on_{l} = length_{l} < BLOCK_SIDE",
     "n0_{l}, n1_{l}, n2_{l}, n3_{l}, n4_{l}, n5_{l} = pushed(" + _OLD + ", 0.0, 0.0, 0.0, 0.0, "
     "nx_{l} * j_{l}, ny_{l} * j_{l}, ima, iia, imb, iib)",
     # An inactive limit keeps its velocities and its stale direction and mass (never read
     # while it is inactive), as physics.rope_setup leaves them.
     "a0_{l} = n0_{l} if on_{l} else a0_{l}", "a1_{l} = n1_{l} if on_{l} else a1_{l}",
     "a2_{l} = n2_{l} if on_{l} else a2_{l}", "b0_{l} = n3_{l} if on_{l} else b0_{l}",
     "b1_{l} = n4_{l} if on_{l} else b1_{l}", "b2_{l} = n5_{l} if on_{l} else b2_{l}"],
    ["w[R_NX, {l}] = nx_{l} if on_{l} else nx0_{l}",
     "w[R_NY, {l}] = ny_{l} if on_{l} else ny0_{l}",
     "w[R_MASS, {l}] = mass if on_{l} else mass0_{l}",
     "w[R_ACTIVE, {l}] = 1.0 if on_{l} else 0.0",
     "w[R_IMPULSE, {l}] = j_{l} if on_{l} else 0.0"] + _STORE_VELOCITIES)
"""Each rope limit set up for this step and warm-started (``physics.rope_setup``)."""

solve_ropes = _generated(
    "solve_ropes", "ends, work, vel, inv_mass, inv_inertia", _MASSES,
    _VELOCITIES + ["on_{l} = w[R_ACTIVE, {l}] != 0.0", "nx_{l} = w[R_NX, {l}]",
                   "ny_{l} = w[R_NY, {l}]", "mass_{l} = w[R_MASS, {l}]",
                   "impulse_{l} = w[R_IMPULSE, {l}]"],
    ["j_{l} = rope_impulse(nx_{l}, ny_{l}, mass_{l}, a0_{l}, a1_{l}, b0_{l}, b1_{l})",
     "n0_{l}, n1_{l}, n2_{l}, n3_{l}, n4_{l}, n5_{l} = pushed(" + _OLD + ", 0.0, 0.0, 0.0, 0.0, "
     "nx_{l} * j_{l}, ny_{l} * j_{l}, ima, iia, imb, iib)",
     "a0_{l} = n0_{l} if on_{l} else a0_{l}", "a1_{l} = n1_{l} if on_{l} else a1_{l}",
     "a2_{l} = n2_{l} if on_{l} else a2_{l}", "b0_{l} = n3_{l} if on_{l} else b0_{l}",
     "b1_{l} = n4_{l} if on_{l} else b1_{l}", "b2_{l} = n5_{l} if on_{l} else b2_{l}"],
    ["w[R_IMPULSE, {l}] = impulse_{l} + j_{l} if on_{l} else impulse_{l}"]
    + _STORE_VELOCITIES)
"""One velocity pass over the active rope limits (``physics.rope_solve``)."""

start_welds = _generated(
    "start_welds", "ends, anchor, work, vel, cos, sin, inv_mass, inv_inertia",
    _MASSES + ["cb = cos[b]", "sb = sin[b]", "obx = anchor[m, 0]", "oby = anchor[m, 1]"],
    _VELOCITIES + ["cb_{l} = cb[{l}]", "sb_{l} = sb[{l}]", "jx_{l} = w[W_JX, {l}]",
                   "jy_{l} = w[W_JY, {l}]", "jz_{l} = w[W_JZ, {l}]"],
    ["rbx_{l}, rby_{l} = rotated(obx, oby, cb_{l}, sb_{l})",
     _NEW + "weld_pushed(" + _OLD + ", rbx_{l}, rby_{l}, jx_{l}, jy_{l}, jz_{l}, ima, iia, imb, "
     "iib)"],
    ["w[W_RBX, {l}] = rbx_{l}", "w[W_RBY, {l}] = rby_{l}"] + _STORE_VELOCITIES)
"""Each weld set up for this step and warm-started (``physics.weld_setup``)."""

solve_welds = _generated(
    "solve_welds", "ends, work, vel, inv_mass, inv_inertia", _MASSES,
    _VELOCITIES + ["rbx_{l} = w[W_RBX, {l}]", "rby_{l} = w[W_RBY, {l}]",
                   "sx_{l} = w[W_JX, {l}]", "sy_{l} = w[W_JY, {l}]", "sz_{l} = w[W_JZ, {l}]"],
    ["jx_{l}, jy_{l}, jz_{l} = weld_impulse(rbx_{l}, rby_{l}, ima, iia, imb, iib, " + _OLD + ")",
     _NEW + "weld_pushed(" + _OLD + ", rbx_{l}, rby_{l}, jx_{l}, jy_{l}, jz_{l}, ima, iia, imb, "
     "iib)"],
    ["w[W_JX, {l}] = sx_{l} + jx_{l}", "w[W_JY, {l}] = sy_{l} + jy_{l}",
     "w[W_JZ, {l}] = sz_{l} + jz_{l}"] + _STORE_VELOCITIES)
"""One velocity pass over the welds (``physics.weld_solve``)."""


# Position passes (after the move): a lane whose ``flags`` row says DONE keeps its bodies
# where they are.
_POSITIONS = ["pa0_{l} = pa[0, {l}]", "pa1_{l} = pa[1, {l}]", "pa2_{l} = pa[2, {l}]",
              "pb0_{l} = pb[0, {l}]", "pb1_{l} = pb[1, {l}]", "pb2_{l} = pb[2, {l}]"]
_OLD_POSITIONS = "pa0_{l}, pa1_{l}, pa2_{l}, pb0_{l}, pb1_{l}, pb2_{l}"
_STORE_MOVED = ["pa[0, {l}] = n0_{l} if move_{l} else pa0_{l}",
                "pa[1, {l}] = n1_{l} if move_{l} else pa1_{l}",
                "pa[2, {l}] = n2_{l} if move_{l} else pa2_{l}",
                "pb[0, {l}] = n3_{l} if move_{l} else pb0_{l}",
                "pb[1, {l}] = n4_{l} if move_{l} else pb1_{l}",
                "pb[2, {l}] = n5_{l} if move_{l} else pb2_{l}"]
_BUSY = ["busy_{l} = not flags[{l}, DONE]", "held_{l} = True"]

move = _generated(
    "move", "pos, vel, cos, sin, dt", ["q = pos[p]", "v = vel[p]"],
    ["p0_{l} = q[0, {l}]", "p1_{l} = q[1, {l}]", "p2_{l} = q[2, {l}]", "v0_{l} = v[0, {l}]",
     "v1_{l} = v[1, {l}]", "v2_{l} = v[2, {l}]"],
    ["p0_{l}, p1_{l}, p2_{l}, v0_{l}, v1_{l}, v2_{l} = moved(p0_{l}, p1_{l}, p2_{l}, v0_{l}, "
     "v1_{l}, v2_{l}, dt)", "c_{l}, s_{l} = sincos(p2_{l})"],
    ["q[0, {l}] = p0_{l}", "q[1, {l}] = p1_{l}", "q[2, {l}] = p2_{l}", "v[0, {l}] = v0_{l}",
     "v[1, {l}] = v1_{l}", "v[2, {l}] = v2_{l}", "cos[p, {l}] = c_{l}", "sin[p, {l}] = s_{l}"],
    loop=("for p in range(pos.shape[0]):",))
"""Every lane's bodies moved with their velocities and turned (``physics.positions``)."""

fix_ropes = _generated(
    "fix_ropes", "ends, pos, inv_mass, inv_inertia, flags",
    ["ima = inv_mass[a]", "iia = inv_inertia[a]", "imb = inv_mass[b]", "iib = inv_inertia[b]",
     "pa = pos[a]", "pb = pos[b]"],
    _POSITIONS,
    ["jx_{l}, jy_{l}, slack_{l}, ok_{l} = rope_fixed(pa0_{l}, pa1_{l}, pb0_{l}, pb1_{l}, ima, "
     "imb)",
     "move_{l} = busy_{l} & (not slack_{l})",
     "n0_{l}, n1_{l}, n2_{l}, n3_{l}, n4_{l}, n5_{l} = pushed(" + _OLD_POSITIONS
     + ", 0.0, 0.0, 0.0, 0.0, jx_{l}, jy_{l}, ima, iia, imb, iib)",
     "held_{l} = held_{l} & ok_{l}"],
    _STORE_MOVED, before=_BUSY, after=["flags[{l}, ROPES_HELD] = held_{l}"])
"""One position pass over the rope limits of the busy lanes (``physics.rope_fix``);
``flags[l, ROPES_HELD]``: whether lane l's all hold."""

fix_welds = _generated(
    "fix_welds", "ends, anchor, pos, cos, sin, inv_mass, inv_inertia, flags",
    ["ima = inv_mass[a]", "iia = inv_inertia[a]", "imb = inv_mass[b]", "iib = inv_inertia[b]",
     "pa = pos[a]", "pb = pos[b]", "ca = cos[a]", "sa = sin[a]", "cb = cos[b]", "sb = sin[b]",
     "obx = anchor[m, 0]", "oby = anchor[m, 1]"],
    _POSITIONS + ["ca_{l} = ca[{l}]", "sa_{l} = sa[{l}]", "cb_{l} = cb[{l}]",
                  "sb_{l} = sb[{l}]"],
    ["move_{l} = busy_{l}",
     "rbx_{l}, rby_{l} = rotated(obx, oby, cb_{l}, sb_{l})",
     "jx_{l}, jy_{l}, jz_{l}, ok_{l} = weld_fixed(" + _OLD_POSITIONS + ", rbx_{l}, rby_{l}, "
     "ima, iia, imb, iib)",
     "n0_{l}, n1_{l}, n2_{l}, n3_{l}, n4_{l}, n5_{l} = weld_pushed(" + _OLD_POSITIONS
     + ", rbx_{l}, rby_{l}, jx_{l}, jy_{l}, jz_{l}, ima, iia, imb, iib)",
     "nca_{l}, nsa_{l} = sincos(n2_{l})", "ncb_{l}, nsb_{l} = sincos(n5_{l})",
     "held_{l} = held_{l} & ok_{l}"],
    _STORE_MOVED + ["ca[{l}] = nca_{l} if busy_{l} else ca_{l}",
                    "sa[{l}] = nsa_{l} if busy_{l} else sa_{l}",
                    "cb[{l}] = ncb_{l} if busy_{l} else cb_{l}",
                    "sb[{l}] = nsb_{l} if busy_{l} else sb_{l}"],
    before=_BUSY, after=["flags[{l}, WELDS_HELD] = held_{l}"])
"""One position pass over the welds of the busy lanes (``physics.weld_fix``);
``flags[l, WELDS_HELD]``: whether lane l's all hold."""

class Lanes(NamedTuple):
    """A group's joints (its first robot's: every robot of a group has the same body) and
    its robots' state, robots innermost (lane g: the group's robot g)."""

    ends: np.ndarray  # (S, 2) int32
    anchor: np.ndarray  # (S, 4)
    rope_ends: np.ndarray  # (Y, 2) int32
    weld_ends: np.ndarray  # (W, 2) int32
    weld_anchor: np.ndarray  # (W, 2)
    inv_mass: np.ndarray  # (P,)
    inv_inertia: np.ndarray  # (P,)
    pos: np.ndarray  # (P, 3, LANES)
    vel: np.ndarray  # (P, 3, LANES)
    cos: np.ndarray  # (P, LANES)
    sin: np.ndarray  # (P, LANES)
    rest: np.ndarray  # (S, LANES)
    spring: np.ndarray  # (S, N_SPRING_COLUMNS, LANES)
    rope: np.ndarray  # (Y, N_ROPE_COLUMNS, LANES)
    weld: np.ndarray  # (W, N_WELD_COLUMNS, LANES)


@njit(inline="always")
def take(lanes, g, pos, vel, cos, sin):
    """Robot g's bodies (its ``pos``, ``vel`` (P, 3), ``cos``, ``sin``) into lane g."""
    for p in range(lanes.pos.shape[0]):
        for c in range(3):
            lanes.pos[p, c, g] = pos[p, c]
            lanes.vel[p, c, g] = vel[p, c]
        lanes.cos[p, g] = cos[p]
        lanes.sin[p, g] = sin[p]


@njit(inline="always")
def give(lanes, g, pos, vel, cos, sin):
    """Lane g's bodies back to robot g's ``pos``, ``vel`` (P, 3), ``cos``, ``sin``."""
    for p in range(lanes.pos.shape[0]):
        for c in range(3):
            pos[p, c] = lanes.pos[p, c, g]
            vel[p, c] = lanes.vel[p, c, g]
        cos[p] = lanes.cos[p, g]
        sin[p] = lanes.sin[p, g]


@njit(inline="always")
def start_joints(lanes, params):
    """The joints of every lane set up for this step and warm-started."""
    omega = 2.0 * math.pi * params.spring_hz
    start_springs(lanes.ends, lanes.anchor, lanes.rest, lanes.spring, lanes.pos, lanes.vel,
                  lanes.cos, lanes.sin, lanes.inv_mass, lanes.inv_inertia, params.dt, omega,
                  params.damping_ratio)
    start_ropes(lanes.rope_ends, lanes.rope, lanes.pos, lanes.vel, lanes.inv_mass,
                lanes.inv_inertia)
    start_welds(lanes.weld_ends, lanes.weld_anchor, lanes.weld, lanes.vel, lanes.cos,
                lanes.sin, lanes.inv_mass, lanes.inv_inertia)


@njit(inline="always")
def fix_joints(lanes, flags):
    """One position pass over the rope limits, then the welds, of every busy lane."""
    fix_ropes(lanes.rope_ends, lanes.pos, lanes.inv_mass, lanes.inv_inertia, flags)
    fix_welds(lanes.weld_ends, lanes.weld_anchor, lanes.pos, lanes.cos, lanes.sin,
              lanes.inv_mass, lanes.inv_inertia, flags)


@njit(inline="always")
def solve_joints(lanes):
    """One velocity pass over the joints of every lane: springs, rope limits, welds."""
    solve_springs(lanes.ends, lanes.spring, lanes.vel, lanes.inv_mass, lanes.inv_inertia)
    solve_ropes(lanes.rope_ends, lanes.rope, lanes.vel, lanes.inv_mass, lanes.inv_inertia)
    solve_welds(lanes.weld_ends, lanes.weld, lanes.vel, lanes.inv_mass, lanes.inv_inertia)
