"""Open-loop controllers: the zero controller, the travelling sine wave and periodic tables.

``sine``: a_v(t) = amp * sin(2 pi freq t + phase * x_v), x_v the voxel's grid column; a negative
phase makes a wave that travels forward (to +x). ``table``: a_v at step k is row k mod period.
"""

from __future__ import annotations

import math

from .._jit import njit


@njit
def sine_actuation(t, freq, amp, phase, n_voxels, voxel_x, actuation):
    for v in range(n_voxels):
        actuation[v] = amp * math.sin(2.0 * math.pi * freq * t + phase * voxel_x[v])


@njit
def table_actuation(step, table, period, n_voxels, actuation):
    row = step % period
    for v in range(n_voxels):
        actuation[v] = table[row, v]
