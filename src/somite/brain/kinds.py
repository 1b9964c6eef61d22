"""Node kinds of the graph controller, defined once (docs/original-system.md section 4.1).

A node is a sensor (one scalar reading of its voxel), a hidden node or an actuator (its voxel's
actuator). Genomes and their files name a kind by its string; arrays (:class:`GenomeIndex`, the
compiled controller and the episode kernel) hold its code, the kind's position in
:data:`NODE_KINDS`, as :data:`KIND_DTYPE`.
"""

from __future__ import annotations

import numpy as np

NODE_KINDS = ("sensor", "hidden", "actuator")
"""Kind names; a kind's position here is its code."""

SENSOR, HIDDEN, ACTUATOR = (NODE_KINDS.index(name) for name in ("sensor", "hidden", "actuator"))

KIND_DTYPE = np.int32
"""The dtype of kind codes in every array."""

KIND_CODE = {name: code for code, name in enumerate(NODE_KINDS)}
"""Kind name -> code."""

RELAY = len(NODE_KINDS)
"""The code of a relay node, which only a compiled controller holds, never a genome: one step of
an edge's extra delay (:mod:`somite.brain.delays`). Its value is its one incoming edge's sum,
passed on unchanged (no activation)."""

__all__ = ["ACTUATOR", "HIDDEN", "KIND_CODE", "KIND_DTYPE", "NODE_KINDS", "RELAY", "SENSOR"]
