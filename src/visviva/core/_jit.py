"""The one place that sets numba flags for every kernel in visviva.

Every compiled function in :mod:`visviva.core` (and the few kernels elsewhere) is decorated with
one of the decorators below, so that caching, the error model and threading are decided once.

* ``cache=True``: compiled machine code is written next to the source and reused across processes.
* ``error_model="numpy"``: a division by zero gives ``inf``/``nan`` instead of raising inside the
  kernel; kernels check degenerate cases explicitly and return a status code instead
  (see :mod:`visviva.core.status`).
* ``fastmath`` is never used: iterative solvers rely on IEEE semantics.
* Nothing is compiled at import: no eager signatures are given, so the first call compiles
  (or loads from the cache).
"""

from __future__ import annotations

import numba

__all__ = ["kernel", "parallel_kernel", "prange", "inline_kernel"]

_FLAGS = {"cache": True, "nogil": True, "error_model": "numpy", "fastmath": False}

#: Decorator for a serial compiled kernel (scalar or array).
kernel = numba.njit(**_FLAGS)

#: Decorator for a kernel whose outer loop uses :func:`prange` over independent items.
parallel_kernel = numba.njit(parallel=True, **_FLAGS)


def inline_kernel(fn):
    """Decorator for a small scalar helper that numba always inlines into its callers."""
    return numba.njit(inline="always", **_FLAGS)(fn)


prange = numba.prange
