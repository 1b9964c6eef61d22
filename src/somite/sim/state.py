"""What the physics owns of a robot's episode: its :class:`BodyState`, described once.

A step of the physics reads and writes the blocks' state, the joints' rows and the contacts'
rows, and nothing else of an episode (the sensors, the controller and the tally are the task
layer's: :mod:`somite.tasks.work`). :data:`BODY_PARTS` describes those arrays, by what they
hold; the functions that allocate a robot's own (:func:`~somite.sim.state_views.new_body`) and
take a robot's views of a batch's (:func:`~somite.sim.state_views.body_row`) are generated from
it (:mod:`somite.sim.layout`), not written beside it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .._jit import njit
from .physics import N_CONTACT_COLUMNS, N_ROPE_COLUMNS, N_SPRING_COLUMNS, N_WELD_COLUMNS

BODY_PARTS = {
    "blocks": {  # the corner bodies and the voxel corners they carry
        "inv_mass": (("P",), np.float64),
        "inv_inertia": (("P",), np.float64),
        "cos": (("P",), np.float64),
        "sin": (("P",), np.float64),
        "body_pos": (("P", 3), np.float64),
        "body_vel": (("P", 3), np.float64),
        "pos": (("P", 2), np.float64),
        "vel": (("P", 2), np.float64),
    },
    "joints": {  # the springs' rest lengths, the joints' rows of the solver
        "rest": (("S",), np.float64),
        "spring": (("S", N_SPRING_COLUMNS), np.float64),
        "rope": (("Y", N_ROPE_COLUMNS), np.float64),
        "weld": (("W", N_WELD_COLUMNS), np.float64),
    },
    "collisions": {  # contact rows (this step's, last step's), the search's scratch
        "contacts": (("C", N_CONTACT_COLUMNS), np.float64),
        "previous": (("C", N_CONTACT_COLUMNS), np.float64),
        "counts": ((2,), np.int64),
        "polygon": ((2, 4, 4), np.float64),
        "clipped": ((2, 4), np.float64),
        "contact": (("P",), np.bool_),
        "segment": (("P+1",), np.int64),
    },
}
"""The physics' per-robot arrays, by what they hold: part -> name -> (shape, dtype). A shape's
names are one robot's counts (:func:`body_sizes`): P blocks, S springs, Y ropes, W welds, C
contact rows (:func:`contact_capacity`). ``body_pos``, ``body_vel`` are the corner bodies'
state (centre of mass and angle, their rates); ``pos``, ``vel`` the voxel corners that they
carry; ``cos``, ``sin`` the bodies' rotations as the last step left them; ``rest`` the springs'
rest lengths under the actuation in force; ``counts`` the rows of ``contacts`` and of
``previous``; ``contact`` whether a block touches the ground; ``segment`` the terrain segment
under each block, then under the robot's left end."""

BODY_FIELDS = {name: spec for fields in BODY_PARTS.values() for name, spec in fields.items()}
"""Every field of :data:`BODY_PARTS`, by name, in :class:`BodyState`'s order."""

BODY_COUNTS = ("P", "S", "Y", "W", "C")
"""The counts that :data:`BODY_PARTS` names (``P+1`` is P's), as the generated functions take
them."""

BodyState = NamedTuple("BodyState", [(name, np.ndarray) for name in BODY_FIELDS])
BodyState.__doc__ = """One robot's arrays of :data:`BODY_PARTS` (or a batch's, robot axis
first): everything a step of the physics reads and writes besides the robot's build
(:class:`~somite.sim.robot.Robot`) and its terrain."""


@njit
def contact_capacity(n_points: int, n_pairs: int) -> int:
    """Room for a robot's contact points: two per block and terrain segment under it, for up
    to three segments a block (hilly segments are at least 1 m long, a block 1.7 m wide at
    most), and two per colliding pair. Steppy terrains' short risers can bring more; the
    contacts that find the table full wait for the next step."""
    return 6 * n_points + 2 * n_pairs


@njit(inline="always")
def body_sizes(system, b):
    """Robot ``b``'s counts of :data:`BODY_COUNTS` in ``system``."""
    p = system.n_points[b]
    return (p, system.n_springs[b], system.n_ropes[b], system.n_welds[b],
            contact_capacity(p, system.n_pairs[b]))


def padded_body_sizes(system) -> dict:
    """:data:`BODY_COUNTS` of a batch, padded to its largest robot."""
    p = system.initial_pos.shape[1]
    return {"P": p, "S": system.spring_ends.shape[1], "Y": system.rope_ends.shape[1],
            "W": system.weld_ends.shape[1],
            "C": int(contact_capacity(p, system.pair_ends.shape[1]))}
