"""The CPU's cycle counter, for kernels that time their own parts when a benchmark asks
(``benchmarks/passes.py``): the kernel's step is then the timed one, not a copy of it."""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from ._jit import njit


@intrinsic
def cycles(typingctx):
    """The cycle counter (``llvm.readcyclecounter``), uint64."""

    def codegen(context, builder, signature, args):
        counter = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(ir.IntType(64), []), "llvm.readcyclecounter")
        return builder.call(counter, [])

    return types.uint64(), codegen


@njit(inline="always")
def tick(spent, part, since, timed):
    """With ``timed``: the cycles since ``since`` added to ``spent[part]``, and now; else
    ``since`` unchanged (a kernel not being timed reads no counter)."""
    if not timed:
        return since
    now = cycles()
    spent[part] += now - since
    return now


@njit
def now():
    """The cycle counter, from Python."""
    return cycles()
