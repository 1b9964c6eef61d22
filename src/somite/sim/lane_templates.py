"""The source of :mod:`somite.sim.lane_passes`: the passes of a group's robots as vector lanes,
written out lane by lane from the templates below.

A template line holds ``{l}`` where a robot's lane goes. Each pass loads every lane's values of
one joint (or block), computes each lane's new values with :mod:`somite.sim.physics`'s own
functions of values, and only then stores them: with nothing stored before everything is
loaded, LLVM's SLP vectoriser (``somite._jit``) takes the lanes' identical arithmetic as vector
instructions. A loop over the lanes would store lane 1's values before it loads lane 2's, and
the compiler could not prove that they do not overlap; so the lanes are written out, and the
result is checked in as ordinary source (``tests/test_lane_passes.py`` fails when it is stale).
After editing a template: ``python -m somite.sim.lane_templates``.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

LANES = 8
"""Robots a group advances together (`somite bench`, 96 worms, 2 threads, one sitting on an
AVX-512 Xeon, 2026-12-03: 4 lanes 114k-117k robot-control-steps a second, 8 lanes 128k-136k, 16
lanes 122k-128k)."""

PHYSICS = ("rotated", "spring_terms", "spring_impulse", "pushed", "unit", "rope_impulse",
           "weld_pushed", "weld_impulse", "weld_terms", "moved", "rope_fixed", "weld_fixed",
           "BLOCK_SIDE",
           "J_RAX", "J_RAY", "J_RBX", "J_RBY", "J_NX", "J_NY", "J_MASS", "J_GAMMA", "J_BIAS",
           "J_IMPULSE", "R_NX", "R_NY", "R_MASS", "R_IMPULSE", "R_ACTIVE", "W_RBX", "W_RBY",
           "W_JX", "W_JY", "W_JZ", "W_K00", "W_K01", "W_K02", "W_K11", "W_K12", "W_K22", "W_C00",
           "W_C01", "W_C02", "W_DET")
"""What the generated passes take from :mod:`somite.sim.physics`."""

# A joint pass takes ``joints`` = (ends, order) and goes over the joints in ``order``
# (joint_lanes.exact_order: an order of the same bits that puts joints on other blocks side by
# side, so that their chains of dependent arithmetic overlap).
_JOINTS = ("for i in range(order.shape[0]):", "m = order[i]", "a = ends[m, 0]",
           "b = ends[m, 1]")
_PASSES: list[str] = []


def _pass(name: str, args: str, joint: list[str], load: list[str], compute: list[str],
          store: list[str], before: list[str] = (), after: list[str] = (),
          loop: tuple[str, ...] = _JOINTS, doc: str = "", unpack: tuple[str, ...] = ()) -> None:
    """Pass ``name(args)``: the lines of ``unpack`` once; each line of ``before`` for every
    lane; then for each joint m of ``ends`` (or each item of another ``loop``) ``joint`` once,
    then each line of ``load``, ``compute`` and ``store`` for every lane in turn; then
    ``after`` for every lane."""
    # Called, not inlined: a pass is long enough that a call costs nothing, and each is
    # compiled once (inlining its eight copies of the arithmetic into every caller cost a
    # minute of compiling).
    if loop is _JOINTS:
        unpack = ("ends, order = joints", *unpack)
    lines = ["", "", "@uncounted", f"def {name}({args}):", f'    """{doc}"""']
    lines += ["    " + line for line in unpack]
    lines += ["    " + line.format(l=lane) for line in before for lane in range(LANES)]
    lines += ["    " + loop[0]] + ["        " + line for line in loop[1:]]
    lines += ["        " + line for line in joint]
    for part in (load, compute, store):
        for line in part:
            lines += ["        " + line.format(l=lane) for lane in range(LANES)]
    lines += ["    " + line.format(l=lane) for line in after for lane in range(LANES)]
    _PASSES.append("\n".join(lines))


_MASSES = ["ima = inv_mass[a]", "iia = inv_inertia[a]", "imb = inv_mass[b]",
           "iib = inv_inertia[b]", "va = vel[a]", "vb = vel[b]", "w = work[m]"]
_VELOCITIES = ["a0_{l} = va[0, {l}]", "a1_{l} = va[1, {l}]", "a2_{l} = va[2, {l}]",
               "b0_{l} = vb[0, {l}]", "b1_{l} = vb[1, {l}]", "b2_{l} = vb[2, {l}]"]
_STORE_VELOCITIES = ["va[0, {l}] = a0_{l}", "va[1, {l}] = a1_{l}", "va[2, {l}] = a2_{l}",
                     "vb[0, {l}] = b0_{l}", "vb[1, {l}] = b1_{l}", "vb[2, {l}] = b2_{l}"]
_NEW = "a0_{l}, a1_{l}, a2_{l}, b0_{l}, b1_{l}, b2_{l} = "
_OLD = "a0_{l}, a1_{l}, a2_{l}, b0_{l}, b1_{l}, b2_{l}"

_pass(
    "start_springs", "joints, anchor, rest, work, state, masses, terms",
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
    + _STORE_VELOCITIES,
    doc="""Each spring set up for this step and warm-started (``physics.spring_setup``):
    ``state`` = (pos, vel, cos, sin), ``masses`` = (inv_mass, inv_inertia), ``terms`` = (dt,
    omega, damping_ratio).""",
    unpack=("pos, vel, cos, sin = state", "inv_mass, inv_inertia = masses",
            "dt, omega, damping_ratio = terms"))

_pass(
    "solve_springs", "joints, work, vel, inv_mass, inv_inertia", _MASSES,
    _VELOCITIES + ["rax_{l} = w[J_RAX, {l}]", "ray_{l} = w[J_RAY, {l}]",
                   "rbx_{l} = w[J_RBX, {l}]", "rby_{l} = w[J_RBY, {l}]",
                   "nx_{l} = w[J_NX, {l}]", "ny_{l} = w[J_NY, {l}]",
                   "mass_{l} = w[J_MASS, {l}]", "bias_{l} = w[J_BIAS, {l}]",
                   "gamma_{l} = w[J_GAMMA, {l}]", "impulse_{l} = w[J_IMPULSE, {l}]"],
    ["j_{l} = spring_impulse(rax_{l}, ray_{l}, rbx_{l}, rby_{l}, nx_{l}, ny_{l}, mass_{l}, "
     "bias_{l}, gamma_{l}, impulse_{l}, " + _OLD + ")",
     _NEW + "pushed(" + _OLD + ", rax_{l}, ray_{l}, rbx_{l}, rby_{l}, nx_{l} * j_{l}, "
     "ny_{l} * j_{l}, ima, iia, imb, iib)"],
    ["w[J_IMPULSE, {l}] = impulse_{l} + j_{l}"] + _STORE_VELOCITIES,
    doc="""One velocity pass over the springs (``physics.spring_solve``).""")

_pass(
    "start_ropes", "joints, work, pos, vel, inv_mass, inv_inertia",
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
     "a0_{l} = chosen(on_{l}, n0_{l}, a0_{l})", "a1_{l} = chosen(on_{l}, n1_{l}, a1_{l})",
     "a2_{l} = chosen(on_{l}, n2_{l}, a2_{l})", "b0_{l} = chosen(on_{l}, n3_{l}, b0_{l})",
     "b1_{l} = chosen(on_{l}, n4_{l}, b1_{l})", "b2_{l} = chosen(on_{l}, n5_{l}, b2_{l})"],
    ["w[R_NX, {l}] = chosen(on_{l}, nx_{l}, nx0_{l})",
     "w[R_NY, {l}] = chosen(on_{l}, ny_{l}, ny0_{l})",
     "w[R_MASS, {l}] = chosen(on_{l}, mass, mass0_{l})",
     "w[R_ACTIVE, {l}] = chosen(on_{l}, 1.0, 0.0)",
     "w[R_IMPULSE, {l}] = chosen(on_{l}, j_{l}, 0.0)"] + _STORE_VELOCITIES,
    doc="""Each rope limit set up for this step and warm-started (``physics.rope_setup``).""")

_pass(
    "solve_ropes", "joints, work, vel, inv_mass, inv_inertia", _MASSES,
    _VELOCITIES + ["on_{l} = w[R_ACTIVE, {l}] != 0.0", "nx_{l} = w[R_NX, {l}]",
                   "ny_{l} = w[R_NY, {l}]", "mass_{l} = w[R_MASS, {l}]",
                   "impulse_{l} = w[R_IMPULSE, {l}]"],
    ["j_{l} = rope_impulse(nx_{l}, ny_{l}, mass_{l}, a0_{l}, a1_{l}, b0_{l}, b1_{l})",
     "n0_{l}, n1_{l}, n2_{l}, n3_{l}, n4_{l}, n5_{l} = pushed(" + _OLD + ", 0.0, 0.0, 0.0, 0.0, "
     "nx_{l} * j_{l}, ny_{l} * j_{l}, ima, iia, imb, iib)",
     "a0_{l} = chosen(on_{l}, n0_{l}, a0_{l})", "a1_{l} = chosen(on_{l}, n1_{l}, a1_{l})",
     "a2_{l} = chosen(on_{l}, n2_{l}, a2_{l})", "b0_{l} = chosen(on_{l}, n3_{l}, b0_{l})",
     "b1_{l} = chosen(on_{l}, n4_{l}, b1_{l})", "b2_{l} = chosen(on_{l}, n5_{l}, b2_{l})"],
    ["w[R_IMPULSE, {l}] = chosen(on_{l}, impulse_{l} + j_{l}, impulse_{l})"]
    + _STORE_VELOCITIES,
    doc="""One velocity pass over the active rope limits (``physics.rope_solve``).""")

# A weld's terms (physics.weld_terms): set up once a step, loaded by each velocity pass.
_WELD_TERMS = ("k00", "k01", "k02", "k11", "k12", "k22", "c00", "c01", "c02", "det")
_K = ", ".join(name + "_{l}" for name in _WELD_TERMS)

_pass(
    "start_welds", "joints, anchor, work, vel, cos, sin, inv_mass, inv_inertia",
    _MASSES + ["cb = cos[b]", "sb = sin[b]", "obx = anchor[m, 0]", "oby = anchor[m, 1]"],
    _VELOCITIES + ["cb_{l} = cb[{l}]", "sb_{l} = sb[{l}]", "jx_{l} = w[W_JX, {l}]",
                   "jy_{l} = w[W_JY, {l}]", "jz_{l} = w[W_JZ, {l}]"],
    ["rbx_{l}, rby_{l} = rotated(obx, oby, cb_{l}, sb_{l})",
     _K + " = weld_terms(ima, iia, imb, iib, rbx_{l}, rby_{l})",
     _NEW + "weld_pushed(" + _OLD + ", rbx_{l}, rby_{l}, jx_{l}, jy_{l}, jz_{l}, ima, iia, imb, "
     "iib)"],
    ["w[W_RBX, {l}] = rbx_{l}", "w[W_RBY, {l}] = rby_{l}"]
    + [f"w[W_{name.upper()}, {{l}}] = {name}_{{l}}" for name in _WELD_TERMS] + _STORE_VELOCITIES,
    doc="""Each weld set up for this step and warm-started (``physics.weld_setup``).""")

_pass(
    "solve_welds", "joints, work, vel, inv_mass, inv_inertia", _MASSES,
    _VELOCITIES + ["rbx_{l} = w[W_RBX, {l}]", "rby_{l} = w[W_RBY, {l}]",
                   "sx_{l} = w[W_JX, {l}]", "sy_{l} = w[W_JY, {l}]", "sz_{l} = w[W_JZ, {l}]"]
    + [f"{name}_{{l}} = w[W_{name.upper()}, {{l}}]" for name in _WELD_TERMS],
    ["jx_{l}, jy_{l}, jz_{l} = weld_impulse(rbx_{l}, rby_{l}, (" + _K + "), " + _OLD + ")",
     _NEW + "weld_pushed(" + _OLD + ", rbx_{l}, rby_{l}, jx_{l}, jy_{l}, jz_{l}, ima, iia, imb, "
     "iib)"],
    ["w[W_JX, {l}] = sx_{l} + jx_{l}", "w[W_JY, {l}] = sy_{l} + jy_{l}",
     "w[W_JZ, {l}] = sz_{l} + jz_{l}"] + _STORE_VELOCITIES,
    doc="""One velocity pass over the welds (``physics.weld_solve``).""")


# Position passes (after the move): a lane whose ``flags`` row says DONE keeps its bodies
# where they are.
_POSITIONS = ["pa0_{l} = pa[0, {l}]", "pa1_{l} = pa[1, {l}]", "pa2_{l} = pa[2, {l}]",
              "pb0_{l} = pb[0, {l}]", "pb1_{l} = pb[1, {l}]", "pb2_{l} = pb[2, {l}]"]
_OLD_POSITIONS = "pa0_{l}, pa1_{l}, pa2_{l}, pb0_{l}, pb1_{l}, pb2_{l}"
_STORE_MOVED = ["pa[0, {l}] = chosen(move_{l}, n0_{l}, pa0_{l})",
                "pa[1, {l}] = chosen(move_{l}, n1_{l}, pa1_{l})",
                "pa[2, {l}] = chosen(move_{l}, n2_{l}, pa2_{l})",
                "pb[0, {l}] = chosen(move_{l}, n3_{l}, pb0_{l})",
                "pb[1, {l}] = chosen(move_{l}, n4_{l}, pb1_{l})",
                "pb[2, {l}] = chosen(move_{l}, n5_{l}, pb2_{l})"]
_BUSY = ["busy_{l} = not flags[{l}, DONE]", "held_{l} = True"]

_pass(
    "move", "pos, vel, cos, sin, dt", ["q = pos[p]", "v = vel[p]"],
    ["p0_{l} = q[0, {l}]", "p1_{l} = q[1, {l}]", "p2_{l} = q[2, {l}]", "v0_{l} = v[0, {l}]",
     "v1_{l} = v[1, {l}]", "v2_{l} = v[2, {l}]"],
    ["p0_{l}, p1_{l}, p2_{l}, v0_{l}, v1_{l}, v2_{l} = moved(p0_{l}, p1_{l}, p2_{l}, v0_{l}, "
     "v1_{l}, v2_{l}, dt)", "c_{l}, s_{l} = sincos(p2_{l})"],
    ["q[0, {l}] = p0_{l}", "q[1, {l}] = p1_{l}", "q[2, {l}] = p2_{l}", "v[0, {l}] = v0_{l}",
     "v[1, {l}] = v1_{l}", "v[2, {l}] = v2_{l}", "cos[p, {l}] = c_{l}", "sin[p, {l}] = s_{l}"],
    loop=("for p in range(pos.shape[0]):",),
    doc="""Every lane's bodies moved with their velocities and turned (``physics.positions``).""")

_pass(
    "fix_ropes", "joints, pos, inv_mass, inv_inertia, flags",
    ["ima = inv_mass[a]", "iia = inv_inertia[a]", "imb = inv_mass[b]", "iib = inv_inertia[b]",
     "pa = pos[a]", "pb = pos[b]"],
    _POSITIONS,
    ["jx_{l}, jy_{l}, slack_{l}, ok_{l} = rope_fixed(pa0_{l}, pa1_{l}, pb0_{l}, pb1_{l}, ima, "
     "imb)",
     "move_{l} = busy_{l} & (not slack_{l})",
     "n0_{l}, n1_{l}, n2_{l}, n3_{l}, n4_{l}, n5_{l} = pushed(" + _OLD_POSITIONS
     + ", 0.0, 0.0, 0.0, 0.0, jx_{l}, jy_{l}, ima, iia, imb, iib)",
     "held_{l} = held_{l} & ok_{l}"],
    _STORE_MOVED, before=_BUSY, after=["flags[{l}, ROPES_HELD] = held_{l}"],
    doc="""One position pass over the rope limits of the busy lanes (``physics.rope_fix``);
``flags[l, ROPES_HELD]``: whether lane l's all hold.""")

_pass(
    "fix_welds", "joints, anchor, pos, cos, sin, inv_mass, inv_inertia, flags",
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
    _STORE_MOVED + ["ca[{l}] = chosen(busy_{l}, nca_{l}, ca_{l})",
                    "sa[{l}] = chosen(busy_{l}, nsa_{l}, sa_{l})",
                    "cb[{l}] = chosen(busy_{l}, ncb_{l}, cb_{l})",
                    "sb[{l}] = chosen(busy_{l}, nsb_{l}, sb_{l})"],
    before=_BUSY, after=["flags[{l}, WELDS_HELD] = held_{l}"],
    doc="""One position pass over the welds of the busy lanes (``physics.weld_fix``);
``flags[l, WELDS_HELD]``: whether lane l's all hold.""")

_IMPORTS = "".join(f"    {name},\n" for name in sorted(PHYSICS, key=lambda n: (not n.isupper(), n)))
_HEADER = f'''"""Generated by ``python -m somite.sim.lane_templates``: do not edit.

The passes of a group's robots as vector lanes (:mod:`somite.sim.lane_templates` says how and
why); :mod:`somite.sim.joint_lanes` holds the group's state and calls them.
"""

# ruff: noqa: E501

from .._jit import uncounted
from .physics import (
{_IMPORTS})
from .trig import sincos

LANES = {LANES}


@uncounted
def chosen(on, yes, no):
    """``yes if on else no``. A call, where the passes would otherwise hold hundreds of
    conditional expressions: each is a branch in Numba's IR, and Numba's SSA pass takes time
    in the product of the branches and the variables they define (``fix_welds``, 80 of them,
    took 6.1 s of CPU to compile, 4.1 s with calls; BENCHMARKS.md, "The first compile on two
    cores"). LLVM inlines it back into the same selects."""
    return yes if on else no

# Columns of a group's flags (LANES, 4), a row a lane: its robot's position passes are over (or
# it holds no running robot), and what this pass found of its contacts, ropes, welds.
DONE, CONTACTS_HELD, ROPES_HELD, WELDS_HELD = range(4)
'''

SOURCE = Path(__file__).with_name("lane_passes.py")


def render() -> str:
    """The text of ``lane_passes.py``."""
    return _HEADER + "".join(_PASSES) + "\n"


def write(path: Path = SOURCE) -> None:
    """Write :func:`render` to ``path`` (through a temporary file and a rename)."""
    handle, temporary = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
    with os.fdopen(handle, "w") as out:
        out.write(render())
    os.replace(temporary, path)


if __name__ == "__main__":
    write()
    print(f"wrote {SOURCE}", file=sys.stderr)
