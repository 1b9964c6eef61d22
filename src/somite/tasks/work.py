"""The arrays of a robot's episode, described once: the physics' :class:`BodyState` and what
the task layer keeps beside it (the sensors' state, the controller's, the episode's tally).

:data:`WORK_PARTS` is the table; :func:`new_work` allocates a batch's arrays from it, and the
compiled functions that allocate one robot's (:func:`~somite.tasks.work_views.new_robot_work`)
and take robot ``b``'s views of a batch's (:func:`~somite.tasks.work_views.work_views`) are
generated from it (``python -m somite.tasks.layout``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .._jit import njit
from ..sim.state import BODY_FIELDS, BodyState, body_sizes, padded_body_sizes

# Slots of Work.tally: what an episode accumulates until finish() writes it to the trace, and
# the body's extent along x in voxel columns (fixed; start() finds it once).
T_FASTEST, T_SMALLEST, T_NON_FINITE, T_X_LO, T_X_HI = range(5)
N_TALLY = 5

WORK_PARTS = {
    "physics": BODY_FIELDS,  # the blocks, the joints' rows, the contacts: sim.state.BODY_PARTS
    "senses": {  # the voxels' state, the sensors' windows, the readings
        "voxels": (("V", 6), np.float64),
        "touch_hist": (("V", "touch"), np.float64),
        "vel_hist": (("V", "velocity", 2), np.float64),
        "readings": (("R",), np.float64),
    },
    "brain": {  # the actuation in force, the controller's two node buffers
        "actuation": (("V",), np.float64),
        "h_prev": (("N",), np.float64),
        "h_next": (("N",), np.float64),
    },
    "tally": {"tally": ((N_TALLY,), np.float64)},
}
"""The per-robot arrays of an episode, by what they hold: part -> name -> (shape, dtype). A
shape's names are one robot's counts (:func:`work_sizes`): those of
:data:`~somite.sim.state.BODY_PARTS` (the ``physics`` part), V voxels, R readings, N controller
nodes, the sensors' ``touch`` and ``velocity`` windows; ``tally`` holds T_*."""

WORK_COUNTS = ("P", "S", "Y", "W", "C", "V", "R", "N", "touch", "velocity")
"""The counts that :data:`WORK_PARTS` names (``P+1`` is P's), as the generated functions take
them."""

WORK_FIELDS = {name: spec for fields in WORK_PARTS.values() for name, spec in fields.items()}
"""Every field of :data:`WORK_PARTS`, by name."""


def _part(name: str, fields: dict) -> type:
    part = NamedTuple(name, [(field, np.ndarray) for field in fields])
    part.__doc__ = f"One robot's {name.lower()} arrays of :data:`WORK_PARTS` (or a batch's)."
    return part


Senses = _part("Senses", WORK_PARTS["senses"])
BrainState = _part("BrainState", WORK_PARTS["brain"])
PART_TYPES = {"physics": BodyState, "senses": Senses, "brain": BrainState}
"""The NamedTuple of each part of :data:`WORK_PARTS` but ``tally`` (an array)."""


class Work(NamedTuple):
    """One robot's arrays of :data:`WORK_PARTS` (or a batch's, robot axis first), by part."""

    physics: BodyState
    senses: Senses
    brain: BrainState
    tally: np.ndarray


def work_sizes(system, ctrl, params, b: int | None = None) -> dict:
    """The counts that :data:`WORK_FIELDS` names: robot ``b``'s, or the batch's padded ones."""
    if b is None:
        sizes = {**padded_body_sizes(system), "V": system.voxel_corners.shape[1],
                 "R": system.reading_code.shape[1],
                 # One node at least: a batch without graphs still has the field.
                 "N": max(1, ctrl.node_kind.shape[1]), "touch": int(params.touch_window),
                 "velocity": int(params.velocity_window)}
    else:
        sizes = dict(zip(WORK_COUNTS, (int(n) for n in work_counts(system, ctrl, params, b))))
    return {**sizes, "P+1": sizes["P"] + 1}


@njit(inline="always")
def work_counts(system, ctrl, params, b):
    """Robot ``b``'s :data:`WORK_COUNTS`, as the generated functions take them."""
    p, s, y, w, c = body_sizes(system, b)
    return (p, s, y, w, c, system.n_voxels[b], system.n_readings[b], ctrl.n_nodes[b],
            int(params.touch_window), int(params.velocity_window))


def work_shape(name: str, sizes: dict) -> tuple:
    """The shape of :data:`WORK_FIELDS` field ``name`` for ``sizes`` (:func:`work_sizes`)."""
    return tuple(sizes[n] if isinstance(n, str) else n for n in WORK_FIELDS[name][0])


def new_work(system, ctrl, params, empty=np.empty) -> Work:
    """The batch's :class:`Work`, robot axis first, padded: ``empty(shape, dtype)`` allocates
    each field (numpy's for the host; the CUDA backend passes its own)."""
    sizes = work_sizes(system, ctrl, params)
    n = system.n_points.shape[0]
    parts = {part: [empty((n, *work_shape(name, sizes)), dtype)
                    for name, (_, dtype) in fields.items()]
             for part, fields in WORK_PARTS.items()}
    return Work(*(PART_TYPES[part](*arrays) if part in PART_TYPES else arrays[0]
                  for part, arrays in parts.items()))
