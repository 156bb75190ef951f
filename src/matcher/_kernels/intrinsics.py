"""LLVM intrinsics the kernels share: a 64-bit popcount, an atomic fetch-and-add and a fused
multiply-add.

Scheduling with :func:`fetch_add`: the parallel kernels run ``prange`` over the worker threads
and let each worker take rows (or strips) from a shared atomic counter, so a worker that another
process keeps off its core does not hold up a statically assigned half of the rows.
"""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

__all__ = ["fetch_add", "fma", "popcount64"]


@intrinsic
def popcount64(typingctx, x):  # pragma: no cover - compiled
    """LLVM ``ctpop`` on a uint64 (a ``popcnt`` instruction, or a vector popcount)."""
    sig = types.uint64(types.uint64)

    def codegen(context, builder, signature, args):
        return builder.ctpop(args[0])

    return sig, codegen


@intrinsic
def fetch_add(typingctx, counter, increment):  # pragma: no cover - compiled
    """Atomically add ``increment`` to ``counter[0]`` (a 1-D int64 array); return the old value."""
    if not (isinstance(counter, types.Array) and counter.dtype == types.int64):
        return None
    sig = types.int64(counter, types.int64)

    def codegen(context, builder, signature, args):
        ary = context.make_array(signature.args[0])(context, builder, args[0])
        ptr = cgutils.get_item_pointer(context, builder, signature.args[0], ary,
                                       [context.get_constant(types.intp, 0)])
        return builder.atomic_rmw("add", ptr, args[1], "monotonic")

    return sig, codegen


@intrinsic
def fma(typingctx, a, b, c):  # pragma: no cover - compiled
    """``a * b + c`` on float64 with one rounding (LLVM ``fma``: the instruction where the CPU
    has one, a correctly rounded library call where not, so the same bits everywhere)."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        t = ir.DoubleType()
        fn = builder.module.declare_intrinsic("llvm.fma", [t], ir.FunctionType(t, [t, t, t]))
        return builder.call(fn, args)

    return sig, codegen
