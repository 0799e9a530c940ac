"""Floating-point primitives numba does not expose, as LLVM intrinsics (one place for them).

* :func:`fma`: ``a * b + c`` with one rounding (``llvm.fma``: one instruction on CPUs with FMA,
  a correctly rounded library call otherwise), the error-free product transformation of
  Ogita, Rump & Oishi (2005); used where rounding must be unbiased (:mod:`visviva.core.universal`).
* :func:`float_bits` / :func:`float_from_bits`: the IEEE-754 bits of a float64 as an int64 and
  back (a bitcast, free), for bit-level first guesses (:func:`visviva.core.gravity.inv_r3`).

Under ``NUMBA_DISABLE_JIT`` (pure-Python coverage runs) each has a plain equivalent that gives
the same bits. Code-generation flags live in :mod:`visviva.core._jit`, not here.

References
----------
Ogita, T., Rump, S. M. & Oishi, S., "Accurate sum and dot product", SIAM J. Sci. Comput. 26,
1955-1988 (2005).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import types
from numba.extending import intrinsic

from ._jit import PYTHON_EQUIVALENTS

__all__ = ["fma", "float_bits", "float_from_bits", "fma_py", "float_bits_py", "float_from_bits_py",
           "EPS"]

#: Machine epsilon of float64, ``2**-52`` (the one definition the kernels share).
EPS = 2.220446049250313e-16


@intrinsic
def fma(typingctx, a, b, c):
    """``a * b + c`` with one rounding (IEEE fused multiply-add)."""
    def codegen(context, builder, signature, args):
        return builder.fma(*args)

    return types.float64(types.float64, types.float64, types.float64), codegen


@intrinsic
def float_bits(typingctx, x):
    """The IEEE-754 bits of a float64 as an int64."""
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(types.int64))

    return types.int64(types.float64), codegen


@intrinsic
def float_from_bits(typingctx, n):
    """The float64 whose IEEE-754 bits are the int64 ``n``."""
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(types.float64))

    return types.float64(types.int64), codegen


def fma_py(a, b, c):
    """``fl(a b + c)`` correctly rounded, in pure Python (exact rational arithmetic)."""
    a, b, c = float(a), float(b), float(c)
    if not (math.isfinite(a) and math.isfinite(b) and math.isfinite(c)):
        return a * b + c
    pa, qa = a.as_integer_ratio()
    pb, qb = b.as_integer_ratio()
    pc, qc = c.as_integer_ratio()
    return (pa * pb * qc + pc * qa * qb) / (qa * qb * qc)  # int / int: correctly rounded


def float_bits_py(x):
    """The bits of the double ``x`` as an int64, in pure Python."""
    return int(np.float64(x).view(np.int64))


def float_from_bits_py(n):
    """The double whose bits are the int64 ``n``, in pure Python."""
    return float(np.int64(n).view(np.float64))


# the interpreter tier (visviva.core._jit.interpreted) runs the plain equivalents
PYTHON_EQUIVALENTS.update({fma: fma_py, float_bits: float_bits_py,
                           float_from_bits: float_from_bits_py})

if numba.config.DISABLE_JIT:  # pure Python: the same bits by other means
    fma = fma_py  # noqa: F811
    float_bits = float_bits_py  # noqa: F811
    float_from_bits = float_from_bits_py  # noqa: F811
