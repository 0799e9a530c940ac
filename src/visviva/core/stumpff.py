"""The Stumpff functions c0..c3 of the universal variable psi, in float64 without cancellation.

For small |psi| a Taylor series in (-psi) summed with fma and the rounding residuals of its
coefficients carried along (so that the result is correctly rounded to about 0.5 ulp); beyond
:data:`SERIES_LIMIT` the closed forms with half-angle identities. Used by the universal-variable
propagation (:mod:`visviva.core.universal`) and the universal-variable Lambert solver
(:mod:`visviva.core.lambert`).

References
----------
Stumpff, K., *Himmelsmechanik*, vol. 1, 1959; Danby, J. M. A., *Fundamentals of Celestial
Mechanics*, 2nd ed. 1992, sec. 6.9; Vallado (2013), sec. 2.2 (c2, c3).
"""

from __future__ import annotations

import math

from ._intrinsics import fma as _fma
from ._jit import inline_kernel, kernel

__all__ = ["stumpff_c2c3", "stumpff_c0123", "SERIES_LIMIT"]

#: |psi| below which the Stumpff functions come from their Taylor series (no cancellation).
SERIES_LIMIT = 4.0

#: 1/(2k+2)! and 1/(2k+3)!, k = 0..12: Taylor coefficients of c2 and c3 in (-psi).
_C2 = tuple(1.0 / math.factorial(2 * k + 2) for k in range(13))
_C3 = tuple(1.0 / math.factorial(2 * k + 3) for k in range(13))


def _rounding_residual(n):
    """``1/n! - fl(1/n!)``, correctly rounded (exact integer arithmetic, one final rounding)."""
    p, q = (1.0 / math.factorial(n)).as_integer_ratio()
    nf = math.factorial(n)
    return (q - p * nf) / (q * nf)


#: What rounding the coefficients to float64 left out, k = 0..3 (``1/6`` is stored 0.25 ulp
#: low, ``1/24`` 0.25 ulp low, ...). Without it the series c3 is 0.25 ulp low on average: a
#: systematic error, which made every drift lower the Kepler energy by ~0.01 eps on average.
_C2_LO = tuple(_rounding_residual(2 * k + 2) for k in range(4))
_C3_LO = tuple(_rounding_residual(2 * k + 3) for k in range(4))


@inline_kernel
def _series_c2c3(psi):
    # c2 = sum (-psi)^k / (2k+2)!,  c3 = sum (-psi)^k / (2k+3)!, k = 0..K by Horner, with
    # K = 5, 8, 12 for |psi| <= 1/64, 1/2, 4: the first omitted term (which has one sign, so
    # would be a bias) stays below 2e-21 of the sum (1e-5 ulp)
    z = -psi
    a = abs(psi)
    top = 5 if a <= 0.015625 else (8 if a <= 0.5 else 12)
    c2 = _C2[top]
    c3 = _C3[top]
    for k in range(top - 1, 3, -1):
        c2 = _fma(c2, z, _C2[k])
        c3 = _fma(c3, z, _C3[k])
    # Horner steps k = 3..0 add the coefficient's rounding residual lo_k to the exact product
    # (one fused multiply-add), then the coefficient: the exact value rounded last is the true
    # partial sum plus a rounding error of the fine product, so the result is unbiased.
    for k in range(3, -1, -1):
        c2 = _C2[k] + _fma(c2, z, _C2_LO[k])
        c3 = _C3[k] + _fma(c3, z, _C3_LO[k])
    return c2, c3


@inline_kernel
def stumpff_all(psi):
    """c0, c1, c2, c3 of psi without cancellation (series for |psi| < 4, half angles beyond)."""
    if psi > SERIES_LIMIT:
        x = math.sqrt(psi)
        sh = math.sin(0.5 * x)
        ch = math.cos(0.5 * x)
        sin_x = 2.0 * sh * ch
        c0 = (ch - sh) * (ch + sh)
        c1 = sin_x / x
        c2 = 2.0 * sh * sh / psi
        c3 = (x - sin_x) / (x * psi)
    elif psi < -SERIES_LIMIT:
        x = math.sqrt(-psi)
        eh = math.exp(0.5 * x) if x < 1418.0 else math.inf  # overflow -> inf, never an error
        ieh = 1.0 / eh
        sh = 0.5 * (eh - ieh)
        ch = 0.5 * (eh + ieh)
        sinh_x = 2.0 * sh * ch
        c0 = 1.0 + 2.0 * sh * sh
        c1 = sinh_x / x
        c2 = -2.0 * sh * sh / psi
        c3 = (sinh_x - x) / (-x * psi)
    else:
        c2, c3 = _series_c2c3(psi)
        c0 = 1.0 - psi * c2
        c1 = 1.0 - psi * c3
    return c0, c1, c2, c3


@kernel
def stumpff_c0123(psi):
    """Stumpff functions c0, c1, c2, c3 of ``psi`` (any sign), free of cancellation.

    Parameters
    ----------
    psi : float
        The argument ``psi = alpha chi**2 = beta s**2`` (dimensionless), any sign and size.

    Returns
    -------
    c0, c1, c2, c3 : float
        ``cos x, sin x / x, (1 - cos x) / x**2, (x - sin x) / x**3`` with ``x = sqrt(psi)``
        (hyperbolic functions for ``psi < 0``).

    Notes
    -----
    For ``|psi| < 4`` the Taylor series ``c_k = sum_j (-psi)**j / (k + 2j)!`` is used (6, 9 or 13
    terms for ``|psi|`` up to 1/64, 1/2, 4), with the rounding residuals of the first four
    coefficients added through fused multiply-adds, so the result is not only accurate but
    unbiased (module notes); beyond it the closed forms with half angles,
    ``1 - cos x = 2 sin(x/2)**2``. The relative error stays within a few ulp everywhere (the worst
    case, ``x - sin x`` at ``x = 2``, loses one bit).
    Reference: Danby (1992) sec. 6.9; Vallado (2013) Algorithm 1.
    """
    return stumpff_all(psi)


@kernel
def stumpff_c2c3(psi):
    """Stumpff functions ``c2(psi)`` and ``c3(psi)`` (Vallado's Algorithm 1), any sign of psi.

    Parameters
    ----------
    psi : float
        ``alpha chi**2`` (dimensionless).

    Returns
    -------
    c2, c3 : float
        ``(1 - cos sqrt(psi)) / psi`` and ``(sqrt(psi) - sin sqrt(psi)) / sqrt(psi)**3``
        (hyperbolic forms for ``psi < 0``; ``1/2`` and ``1/6`` at ``psi = 0``).

    Notes
    -----
    Series near zero (no cancellation), half-angle closed forms beyond ``|psi| = 4``. Overflows
    to ``inf`` only for ``psi < -(1420)**2``. See :func:`stumpff_c0123`.
    """
    c0, c1, c2, c3 = stumpff_all(psi)
    return c2, c3
