"""The one place that sets numba flags for every kernel in visviva.

Every compiled function in :mod:`visviva.core` (and the few kernels elsewhere) is decorated with
one of the decorators below, so that caching, the error model and threading are decided once.

* ``cache=True``: compiled machine code is written next to the source and reused across processes.
* ``error_model="numpy"``: a division by zero gives ``inf``/``nan`` instead of raising inside the
  kernel; kernels check degenerate cases explicitly and return a status code instead
  (see :mod:`visviva.core.status`).
* ``fastmath`` is never used, except by :data:`simd_kernel`: iterative solvers rely on IEEE
  semantics.
* :data:`simd_kernel` (added for the N-body gravity sum) allows only ``reassoc`` and ``contract``:
  a floating-point reduction (``s += f(j)``) vectorises only when the compiler may reassociate
  the sum, and ``contract`` allows fused multiply-adds. No ``nnan``/``ninf``/``arcp``: NaN, inf and
  comparisons keep IEEE meaning. The result is deterministic for a given compiled function (the
  order of the partial sums is fixed by the code, not by the data or the threads) but differs in
  the last bits from a strict left-to-right sum. Use it only for a reduction in a leaf function;
  never for iterative solvers (Newton, Kepler, predictor-corrector loops).
* :func:`prefer_wide_vectors` (called first thing in the large-N gravity loops) makes LLVM use
  the CPU's widest SIMD registers for the calling function (512-bit on AVX-512, where LLVM's
  default is 256): the one per-function code-generation flag, so it lives here too.
* Nothing is compiled at import: no eager signatures are given, so the first call compiles
  (or loads from the cache).
"""

from __future__ import annotations

import numba
from numba import types
from numba.extending import intrinsic

__all__ = ["kernel", "parallel_kernel", "prange", "inline_kernel", "simd_kernel",
           "prefer_wide_vectors"]

_FLAGS = {"cache": True, "nogil": True, "error_model": "numpy", "fastmath": False}

#: Decorator for a serial compiled kernel (scalar or array).
kernel = numba.njit(**_FLAGS)

#: Decorator for a kernel whose outer loop uses :func:`prange` over independent items.
parallel_kernel = numba.njit(parallel=True, **_FLAGS)


#: Decorator for a serial leaf kernel whose float reduction must vectorise (see above): the
#: flags of :data:`kernel` plus ``fastmath={"reassoc", "contract"}``.
simd_kernel = numba.njit(**{**_FLAGS, "fastmath": {"reassoc", "contract"}})


def inline_kernel(fn):
    """Decorator for a small scalar helper that numba always inlines into its callers."""
    return numba.njit(inline="always", **_FLAGS)(fn)


prange = numba.prange


@intrinsic
def prefer_wide_vectors(typingctx):
    """Compile the calling function for the widest SIMD registers the CPU has (no-op call).

    LLVM's default on AVX-512 CPUs is to vectorise with 256-bit registers; this sets the function
    attribute ``"prefer-vector-width"="512"`` on the caller, so its loops use 512-bit ones (8
    doubles). Targets without such registers ignore it.
    """
    def codegen(context, builder, signature, args):
        # llvmlite knows only a fixed list of function attributes: add the string one directly
        set.add(builder.function.attributes, '"prefer-vector-width"="512"')
        return context.get_dummy_value()

    return types.none(), codegen


if numba.config.DISABLE_JIT:  # pure Python (coverage runs): the intrinsic is a plain no-op
    def prefer_wide_vectors():  # noqa: F811
        return None
