"""``java.util.Random``, the generator of the authors' code: in Python (:class:`JavaRandom`,
the sensors' noise and the tests' oracle) and its nextDouble step compiled (:func:`next_double`,
for the hilly terrains a training run builds for every evaluation)."""

from __future__ import annotations

import math

import numpy as np

from .._jit import njit


class JavaRandom:
    """``java.util.Random``: the 48-bit LCG with Java's nextDouble, nextInt and nextGaussian."""

    _MULT = 0x5DEECE66D
    _MASK = (1 << 48) - 1

    def __init__(self, seed: int) -> None:
        self._seed = (int(seed) ^ self._MULT) & self._MASK
        self._next_gaussian: float | None = None

    def _next(self, bits: int) -> int:
        self._seed = (self._seed * self._MULT + 0xB) & self._MASK
        value = self._seed >> (48 - bits)
        return value - (1 << bits) if value >= 1 << (bits - 1) else value

    def next_double(self) -> float:
        hi = self._next(26) & ((1 << 26) - 1)
        lo = self._next(27) & ((1 << 27) - 1)
        return ((hi << 27) + lo) * 2.0**-53

    def next_int(self, bound: int) -> int:
        if bound & -bound == bound:
            return (bound * (self._next(31) & 0x7FFFFFFF)) >> 31
        while True:
            bits = self._next(31) & 0x7FFFFFFF
            value = bits % bound
            if bits - value + (bound - 1) < 1 << 31:
                return value

    def next_gaussian(self) -> float:
        if self._next_gaussian is not None:
            value, self._next_gaussian = self._next_gaussian, None
            return value
        while True:
            v1 = 2 * self.next_double() - 1
            v2 = 2 * self.next_double() - 1
            s = v1 * v1 + v2 * v2
            if 0 < s < 1:
                break
        multiplier = math.sqrt(-2 * math.log(s) / s)
        self._next_gaussian = v2 * multiplier
        return v1 * multiplier


MULT = np.uint64(0x5DEECE66D)
ADD = np.uint64(0xB)
MASK = np.uint64((1 << 48) - 1)


@njit
def next_double(state):
    """java.util.Random.nextDouble on a 48-bit state: (value, new state)."""
    state = (state * MULT + ADD) & MASK
    high = state >> np.uint64(22)  # next(26)
    state = (state * MULT + ADD) & MASK
    low = state >> np.uint64(21)  # next(27)
    return (float(high) * 134217728.0 + float(low)) * 2.0**-53, state


__all__ = ["ADD", "MASK", "MULT", "JavaRandom", "next_double"]
