"""A block's cosine and sine without libm: straight-line arithmetic that the compiler can inline,
and vectorise across the robots of a group (:mod:`somite.sim.joint_lanes`).

The physics turns every block once a step and again after every position-pass push
(docs/simulator.md); libm's ``cos`` and ``sin`` there were calls that no vector lane could
take. :func:`sincos` reduces the angle by multiples of pi/2 (Cody and Waite: pi/2 in three
parts, the first two short enough that their products with the multiple are exact) and
evaluates minimax polynomials on [-pi/4, pi/4] (fdlibm's published coefficients), then picks
the quadrant by selects, not branches. Its results are within 1 ulp of libm's for |angle| up
to 100 rad and within 2 ulp up to 1e5 rad (``tests/test_trig.py``, 200,000 angles a range);
10-20% of them differ from libm's in the last bit. 0 gives exactly (1, 0), so a still robot
stays exactly still; a non-finite angle gives NaNs.
"""

from __future__ import annotations

import math

from .._jit import njit

TWO_OVER_PI = 0.6366197723675814
# pi/2 = PIO2_1 + PIO2_2 + PIO2_3, PIO2_1 and PIO2_2 with 33 significant bits each (so that
# n * PIO2_k is exact for |n| < 2**20, angles up to ~1.6e6 rad).
PIO2_1 = 1.5707963267341256
PIO2_2 = 6.077100506303966e-11
PIO2_3 = 2.0222662487959506e-21
_ROUND = 6755399441055744.0  # 1.5 * 2**52: x + _ROUND - _ROUND rounds x to an integer

# Minimax polynomials on [-pi/4, pi/4]: sin r = r + r^3 (S1 + r^2 S2 + ...), cos r =
# 1 - r^2/2 + r^4 (C1 + r^2 C2 + ...).
S1, S2, S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
S4, S5, S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
C1, C2, C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
C4, C5, C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11


# Called, not inlined by Numba: LLVM inlines it all the same, and the lane passes call it 16
# times in one function, where Numba's inlining and its four selects cost seconds of compiling.
@njit
def sincos(x):
    """(cos x, sin x)."""
    n = (x * TWO_OVER_PI + _ROUND) - _ROUND
    r = ((x - n * PIO2_1) - n * PIO2_2) - n * PIO2_3
    z = r * r
    s = r + r * z * (S1 + z * (S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)))))
    # 1 - z/2 split so that its rounding error is carried (|r| near pi/4 loses a bit
    # otherwise).
    half = 0.5 * z
    w = 1.0 - half
    tail = z * z * (C1 + z * (C2 + z * (C3 + z * (C4 + z * (C5 + z * C6)))))
    c = w + (((1.0 - w) - half) + tail)
    q = n - 4.0 * math.floor(n * 0.25)  # the quadrant, 0 .. 3 (NaN for a non-finite x)
    odd = (q == 1.0) | (q == 3.0)
    cos_x = s if odd else c
    sin_x = c if odd else s
    cos_x = -cos_x if (q == 1.0) | (q == 2.0) else cos_x
    sin_x = -sin_x if q >= 2.0 else sin_x
    return cos_x, sin_x
