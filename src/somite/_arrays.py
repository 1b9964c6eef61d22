"""Array helpers shared by the simulator's and the controller's batch packing."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def pad(rows: Sequence[np.ndarray], tail: tuple, dtype, fill=0) -> np.ndarray:
    """Stack rows of different lengths into (len(rows), longest, *tail), filling with ``fill``."""
    longest = max(1, max((len(r) for r in rows), default=0))
    out = np.full((len(rows), longest) + tail, fill, dtype=dtype)
    for i, row in enumerate(rows):
        if len(row):
            out[i, : len(row)] = row
    return out
