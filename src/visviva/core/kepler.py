"""Kepler's equation in every regime, and the conversions between the anomalies.

Scalar kernels return ``(value, status)`` with ``status`` from :mod:`visviva.core.status`; the
array versions are one ``prange`` loop over flattened inputs that write an output and a status
array. Angles are in radians.

Conventions (M = n t, with t the time since periapsis):

==========  =======================  ===========================  =========================
regime      anomaly                  mean anomaly                 mean motion n
==========  =======================  ===========================  =========================
0 <= e < 1  eccentric E              M = E - e sin E              sqrt(mu / a^3)
e = 1       D = tan(nu / 2)          M = D + D^3 / 3 (Barker)     2 sqrt(mu / p^3)
e > 1       hyperbolic F             M = e sinh F - F             sqrt(mu / (-a)^3)
==========  =======================  ===========================  =========================

Accuracy. Every solver returns the anomaly to (nearly) full relative precision in all regimes:

* Elliptic, away from the near-parabolic corner: Markley's (1995) cubic starter and one
  fifth-order correction (non-iterative; one sin/cos pair).
* Elliptic with ``1 - e cos E < 0.3`` (e -> 1, small E) and hyperbolic: Newton iterations on the
  residual written without cancellation, ``(1 - e) E + e (E - sin E) - M`` and
  ``(e - 1) F + e (sinh F - F) - M``, with ``E - sin E`` and ``sinh F - F`` from their Taylor
  series for ``|x| < 2`` (the idea of Farnocchia, Bracali Cioci & Milani 2013, applied in the E
  and F variables). The starter is the root of the cubic ``(1 - e) E + e E^3 / 6 = M`` (a bound
  of the root), so the iteration converges monotonically in a few steps; the
  loop is bounded and returns ``NO_CONVERGENCE`` if it ever runs out.
* Parabolic: Barker's cubic in closed (cancellation-free Cardano) form.

References
----------
Markley, F. L. (1995). Kepler equation solver. Celest. Mech. Dyn. Astron. 63, 101-111.
Farnocchia, D., Bracali Cioci, D., Milani, A. (2013). Robust resolution of Kepler's equation in
all eccentricity regimes. Celest. Mech. Dyn. Astron. 116, 21-34.
Vallado, D. A. (2013). Fundamentals of Astrodynamics and Applications, 4th ed., Sec. 2.2-2.3.
"""

from __future__ import annotations

import math

import numpy as np

from ._intrinsics import cbrt
from ._jit import inline_kernel, kernel
from .status import (
    BAD_ECCENTRICITY,
    NO_CONVERGENCE,
    NON_FINITE,
    OK,
    OVERFLOW,
    UNREACHABLE_ANOMALY,
)

__all__ = [
    "eccentric_anomaly",
    "hyperbolic_anomaly",
    "parabolic_anomaly",
    "mean_to_true_anomaly",
    "true_to_mean_anomaly",
    "true_from_eccentric",
    "eccentric_from_true",
    "true_from_hyperbolic",
    "hyperbolic_from_true",
    "true_from_parabolic",
    "parabolic_from_true",
    "mean_from_eccentric",
    "mean_from_hyperbolic",
    "mean_from_parabolic",
]

PI = math.pi
TWO_PI = 2.0 * math.pi
NAN = math.nan
#: Markley's constants
_INV_PI2_MINUS_6 = 1.0 / (math.pi**2 - 6.0)
_3PI2 = 3.0 * math.pi**2
_1P6PI = 1.6 * math.pi
_SIXTH = 1.0 / 6.0
_TWENTYFOURTH = 1.0 / 24.0
_HALF_PI = 0.5 * math.pi
_LN2 = math.log(2.0)
#: Taylor coefficients (-1)^k / (2k+1)! and (-1)^k / (2k)! for the inline sin/cos
(_S0, _S1, _S2, _S3, _S4, _S5, _S6, _S7, _S8, _S9, _S10, _S11) = (
    (-1.0) ** k / math.factorial(2 * k + 1) for k in range(12)
)
#: 1 / (2j + 1)! for j = 1 .. 13: the series of x - sin x and sinh x - x
(_T1, _T2, _T3, _T4, _T5, _T6, _T7, _T8, _T9, _T10, _T11, _T12, _T13) = (
    1.0 / math.factorial(2 * j + 1) for j in range(1, 14)
)
(_C0, _C1, _C2, _C3, _C4, _C5, _C6, _C7, _C8, _C9, _C10, _C11, _C12) = (
    (-1.0) ** k / math.factorial(2 * k) for k in range(13)
)
#: switch to the cancellation-free iteration where 1 - e cos E falls below this
NEAR_PARABOLIC = 0.3
#: below this |M| the elliptic solver evaluates sin E and cos E with libm (relative accuracy)
SMALL_M = 0.25
#: Newton stops once the step is below this fraction of the anomaly (error after it ~ step^2)
_STEP_TOL = 1e-11
_MAX_ITER = 40
#: above this hyperbolic anomaly, sinh F = exp(F)/2 to double precision
_F_LARGE = 20.0


# ---------------------------------------------------------------------------------------------
# Cancellation-free pieces
# ---------------------------------------------------------------------------------------------
@inline_kernel
def _x_minus_sin(x):
    """x - sin x without cancellation (Taylor series for |x| < 2, terms to x^27)."""
    if abs(x) >= 2.0:
        return x - math.sin(x)
    z = x * x
    # x^3 * sum_{j>=0} (-1)^j z^j / (2j+3)!, Horner from the smallest term
    s = _T12 - z * _T13
    s = _T11 - z * s
    s = _T10 - z * s
    s = _T9 - z * s
    s = _T8 - z * s
    s = _T7 - z * s
    s = _T6 - z * s
    s = _T5 - z * s
    s = _T4 - z * s
    s = _T3 - z * s
    s = _T2 - z * s
    s = _T1 - z * s
    return x * z * s


@inline_kernel
def _sinh_minus_x(x):
    """sinh x - x without cancellation (Taylor series for |x| < 2, terms to x^27)."""
    if abs(x) >= 2.0:
        return math.sinh(x) - x
    z = x * x
    s = _T12 + z * _T13
    s = _T11 + z * s
    s = _T10 + z * s
    s = _T9 + z * s
    s = _T8 + z * s
    s = _T7 + z * s
    s = _T6 + z * s
    s = _T5 + z * s
    s = _T4 + z * s
    s = _T3 + z * s
    s = _T2 + z * s
    s = _T1 + z * s
    return x * z * s


@inline_kernel
def _cubic_root(a, b, c):
    """The real root of a x^3 + b x = c for a >= 0, b > 0 (or a > 0, b >= 0), c >= 0.

    Cardano in the form without cancellation: with x = u - b / (3 a u),
    x = c / (a (u^2 + b / (3 a) + (b / (3 a))^2 / u^2)).
    """
    if c == 0.0:
        return 0.0
    if a == 0.0:
        return c / b
    p3 = b / (3.0 * a)  # p / 3 of the depressed cubic x^3 + p x = q
    h = 0.5 * c / a  # q / 2
    if p3 > 1e100 or h > 1e100:
        # scale to avoid overflow of p3^3 or h^2: x^3 + p x = q is homogeneous in
        # (x, p, q) ~ (s, s^2, s^3)
        s = max(math.sqrt(p3), cbrt(h))
        ps = p3 / (s * s)
        hs = h / (s * s * s)
        u3 = hs + math.sqrt(hs * hs + ps * ps * ps)
        u = cbrt(u3)
        return s * (2.0 * hs) / (u * u + ps + ps * ps / (u * u))
    u3 = h + math.sqrt(h * h + p3 * p3 * p3)
    u = cbrt(u3)
    if u == 0.0:  # both tiny: fall back to the dominant term
        return c / b
    return (2.0 * h) / (u * u + p3 + p3 * p3 / (u * u))


# ---------------------------------------------------------------------------------------------
# Mean anomaly from the eccentric / hyperbolic / parabolic anomaly (no cancellation)
# ---------------------------------------------------------------------------------------------
@inline_kernel
def _mean_elliptic(E, ecc):
    """E - e sin E, accurate to a few ulp relative also for e -> 1, E -> 0."""
    if E == 0.0:
        return E  # keeps the sign of zero
    if ecc > 0.5 and abs(E) < 2.0:
        return (1.0 - ecc) * E + ecc * _x_minus_sin(E)
    return E - ecc * math.sin(E)


@inline_kernel
def _mean_hyperbolic(F, ecc):
    """e sinh F - F, accurate to a few ulp relative also for e -> 1, F -> 0."""
    if F == 0.0:
        return F
    if ecc < 2.0 and abs(F) < 2.0:
        return (ecc - 1.0) * F + ecc * _sinh_minus_x(F)
    return ecc * math.sinh(F) - F


@kernel
def mean_from_eccentric(E, ecc):
    """Mean anomaly M = E - e sin E (rad) of an ellipse, 0 <= e < 1.

    Any real E; the result keeps the revolutions (M(E + 2 pi k) = M(E) + 2 pi k).
    """
    if not (math.isfinite(E) and math.isfinite(ecc)):
        return NAN, NON_FINITE
    if not (0.0 <= ecc < 1.0):
        return NAN, BAD_ECCENTRICITY
    return _mean_elliptic(E, ecc), OK


@kernel
def mean_from_hyperbolic(F, ecc):
    """Hyperbolic mean anomaly M = e sinh F - F (rad), e > 1."""
    if not (math.isfinite(F) and math.isfinite(ecc)):
        return NAN, NON_FINITE
    if not ecc > 1.0:
        return NAN, BAD_ECCENTRICITY
    M = _mean_hyperbolic(F, ecc)
    if not math.isfinite(M):
        return M, OVERFLOW
    return M, OK


@kernel
def mean_from_parabolic(D):
    """Parabolic mean anomaly M = D + D^3 / 3 (Barker's equation), D = tan(nu / 2)."""
    if not math.isfinite(D):
        return NAN, NON_FINITE
    M = D + D * D * D / 3.0
    if not math.isfinite(M):
        return M, OVERFLOW
    return M, OK


# ---------------------------------------------------------------------------------------------
# Elliptic Kepler equation
# ---------------------------------------------------------------------------------------------
@inline_kernel
def sincos_0_pi(x):
    """(sin x, cos x) for 0 <= x <= pi to ~3e-16 absolute, inline (no libm call).

    Taylor series of cos y and sin y about y = x - pi/2 in [-pi/2, pi/2] (terms to y^24), so
    sin x = cos y and cos x = -sin y. Inlining lets the compiler overlap consecutive solves,
    which makes the elliptic solver about 3x faster than calling libm's sin and cos.
    """
    y = x - _HALF_PI
    z = y * y
    s = _S10 + z * _S11
    s = _S9 + z * s
    s = _S8 + z * s
    s = _S7 + z * s
    s = _S6 + z * s
    s = _S5 + z * s
    s = _S4 + z * s
    s = _S3 + z * s
    s = _S2 + z * s
    s = _S1 + z * s
    sy = y * (_S0 + z * s)
    c = _C11 + z * _C12
    c = _C10 + z * c
    c = _C9 + z * c
    c = _C8 + z * c
    c = _C7 + z * c
    c = _C6 + z * c
    c = _C5 + z * c
    c = _C4 + z * c
    c = _C3 + z * c
    c = _C2 + z * c
    c = _C1 + z * c
    cy = _C0 + z * c
    return cy, -sy


@inline_kernel
def markley_starter(M, ecc):
    """Markley's (1995, eq. 20) starter for 0 <= M <= pi, 0 <= e < 1: the root of a cubic
    approximating Kepler's equation, without branches."""
    alpha = (_3PI2 + _1P6PI * (PI - M) / (1.0 + ecc)) * _INV_PI2_MINUS_6
    d = 3.0 * (1.0 - ecc) + alpha * ecc
    q = 2.0 * alpha * d * (1.0 - ecc) - M * M
    r = 3.0 * alpha * d * (d - 1.0 + ecc) * M + M * M * M
    w = abs(r) + math.sqrt(max(q * q * q + r * r, 0.0))
    w = cbrt(w * w)
    den = w * w + w * q + q * q
    return (2.0 * r * w + M * den) / (den * d)


@inline_kernel
def markley_correction(E, M, ecc, sE, cE):
    """Markley's (1995, eqs. 21-24) fifth-order correction of E, given sin E and cos E.

    Returns ``(E, f1)`` with ``f1 = 1 - e cos E`` at the starter; the result has full precision
    when ``f1 >= 0.3`` (elsewhere the caller switches to the near-parabolic iteration).
    """
    f1 = 1.0 - ecc * cE
    f0 = E - ecc * sE - M
    f2 = ecc * sE
    f3 = 1.0 - f1
    d3 = -f0 * f1 / (f1 * f1 - 0.5 * f0 * f2)
    d4 = -f0 / (f1 + d3 * (0.5 * f2 + d3 * f3 * _SIXTH))
    d5 = -f0 / (f1 + d4 * (0.5 * f2 + d4 * (f3 * _SIXTH - d4 * f2 * _TWENTYFOURTH)))
    return E + d5, f1


@inline_kernel
def _eccentric_near_parabolic(M, ecc):
    """E for 0 <= M, e > 0.7 and 1 - e cos E < 0.3 (|E| < 0.8): cancellation-free Newton.

    Starts from the root of (1 - e) E + e E^3 / 6 = M, a lower bound of the root
    (E - sin E <= E^3 / 6); the residual is convex there, so Newton overshoots once and then
    decreases monotonically. Returns (E, status).
    """
    E = _cubic_root(ecc / 6.0, 1.0 - ecc, M)
    for _ in range(_MAX_ITER):
        f0 = (1.0 - ecc) * E + ecc * _x_minus_sin(E) - M
        s = math.sin(0.5 * E)
        f1 = (1.0 - ecc) + 2.0 * ecc * s * s
        if not f1 > 0.0:
            return E, NO_CONVERGENCE
        step = f0 / f1
        E -= step
        if abs(step) <= _STEP_TOL * abs(E):
            return E, OK
    return E, NO_CONVERGENCE


@inline_kernel
def _eccentric_reduced(M, ecc):
    """E for 0 <= M <= pi, 0 < e < 1. Returns (E, status)."""
    E = markley_starter(M, ecc)
    if M >= SMALL_M:
        sE, cE = sincos_0_pi(E)  # absolute accuracy suffices here
    else:
        sE = math.sin(E)  # relative accuracy needed for small E
        cE = math.cos(E)
    E, f1 = markley_correction(E, M, ecc, sE, cE)
    if f1 >= NEAR_PARABOLIC:
        return E, OK
    return _eccentric_near_parabolic(M, ecc)


@inline_kernel
def _revolutions(x):
    """(x - r, r): r = x mod 2 pi in [-pi, pi], exact (fmod, then one exact subtraction), and
    the whole revolutions x - r; (0, x) untouched if |x| <= pi."""
    if abs(x) <= PI:
        return 0.0, x
    r = np.fmod(x, TWO_PI)
    if r > PI:
        r -= TWO_PI
    elif r < -PI:
        r += TWO_PI
    return x - r, r


@kernel
def eccentric_anomaly(M, ecc):
    """Eccentric anomaly E (rad) from the mean anomaly M (rad), 0 <= e < 1.

    Solves M = E - e sin E. M may be any real number: it is reduced to [-pi, pi] and the whole
    revolutions are added back, so E - e sin E = M holds for the returned E.

    Returns
    -------
    E : float
        Eccentric anomaly (rad); NaN only with a non-OK status.
    status : int
        ``OK``, ``NON_FINITE`` or ``BAD_ECCENTRICITY`` (e < 0 or e >= 1), ``NO_CONVERGENCE``.
    """
    if not (math.isfinite(M) and math.isfinite(ecc)):
        return NAN, NON_FINITE
    if not (0.0 <= ecc < 1.0):
        return NAN, BAD_ECCENTRICITY
    if ecc == 0.0:
        return M, OK
    base, Mr = _revolutions(M)
    if Mr < 0.0 or (Mr == 0.0 and math.copysign(1.0, Mr) < 0.0):
        E, st = _eccentric_reduced(-Mr, ecc)
        E = -E
    else:
        E, st = _eccentric_reduced(Mr, ecc)
    if base != 0.0:
        E = base + E
    return E, st


# ---------------------------------------------------------------------------------------------
# Hyperbolic Kepler equation
# ---------------------------------------------------------------------------------------------
@inline_kernel
def _hyperbolic_reduced(M, ecc):
    """F >= 0 for M >= 0, e > 1. Returns (F, status)."""
    if M == 0.0:
        return 0.0, OK
    # tiny M (down to subnormals): M = (e - 1) F + e F^3 / 6 + ..., so F = M / (e - 1) to full
    # precision once the cubic term is below half an ulp; Newton's relative step test cannot
    # be met with subnormal iterates
    F0 = M / (ecc - 1.0)
    if F0 < 1e-10 and ecc * F0 * F0 <= 1e-16 * (ecc - 1.0):
        return F0, OK
    Fl = math.asinh(M / ecc)  # lower bound: e sinh F = M + F >= M
    if Fl > _F_LARGE:
        # sinh F = exp(F) / 2 to double precision: F = log((M + F) / e) + log 2; the ratio
        # (M + F) / e = exp(F) / 2 is representable, and one log of it avoids the cancellation
        # of log M - log e when both are huge
        F = Fl
        for _ in range(_MAX_ITER):
            g = F - _LN2 - math.log((M + F) / ecc)
            step = g / (1.0 - 1.0 / (M + F))
            F -= step
            if abs(step) <= _STEP_TOL * F:
                return F, OK
        return F, NO_CONVERGENCE
    # upper bounds: the cubic (e - 1) F + e F^3 / 6 = M (sinh F - F >= F^3 / 6), then
    # F = asinh((M + F) / e) is monotone, so each pass keeps an upper bound
    F = _cubic_root(ecc / 6.0, ecc - 1.0, M)
    Fa = math.asinh((M + F) / ecc)
    if Fa < F:
        F = Fa
    # Newton on a convex increasing function from above converges monotonically
    for _ in range(_MAX_ITER):
        f0 = _mean_hyperbolic(F, ecc) - M
        s = math.sinh(0.5 * F)
        f1 = (ecc - 1.0) + 2.0 * ecc * s * s
        if f1 <= 0.0:
            return F, NO_CONVERGENCE
        step = f0 / f1
        F -= step
        if abs(step) <= _STEP_TOL * abs(F):
            return F, OK
    return F, NO_CONVERGENCE


@kernel
def hyperbolic_anomaly(M, ecc):
    """Hyperbolic anomaly F (rad) from the hyperbolic mean anomaly M = e sinh F - F, e > 1.

    Returns
    -------
    F : float
    status : int
        ``OK``, ``NON_FINITE``, ``BAD_ECCENTRICITY`` (e <= 1) or ``NO_CONVERGENCE``.
    """
    if not (math.isfinite(M) and math.isfinite(ecc)):
        return NAN, NON_FINITE
    if not ecc > 1.0:
        return NAN, BAD_ECCENTRICITY
    if M < 0.0 or (M == 0.0 and math.copysign(1.0, M) < 0.0):
        F, st = _hyperbolic_reduced(-M, ecc)
        return -F, st
    return _hyperbolic_reduced(M, ecc)


# ---------------------------------------------------------------------------------------------
# Parabolic (Barker)
# ---------------------------------------------------------------------------------------------
@kernel
def parabolic_anomaly(M):
    """D = tan(nu / 2) from the parabolic mean anomaly M = D + D^3 / 3 (Barker's equation).

    Closed-form root of the cubic D^3 + 3 D - 3 M = 0, written without cancellation.
    """
    if not math.isfinite(M):
        return NAN, NON_FINITE
    x = abs(M)
    if x > 1e300:
        c = cbrt(3.0) * cbrt(x)  # D^3 + 3D = 3M with D = c - 1/c + O(c^-5)
        D = c - 1.0 / c
    else:
        D = _cubic_root(1.0 / 3.0, 1.0, x)
        # one Newton polish in the well-conditioned form (f' = 1 + D^2 >= 1)
        D -= (D + D * D * D / 3.0 - x) / (1.0 + D * D)
    return math.copysign(D, M), OK


# ---------------------------------------------------------------------------------------------
# Direct conversions
# ---------------------------------------------------------------------------------------------
@kernel
def true_from_eccentric(E, ecc):
    """True anomaly nu (rad) from the eccentric anomaly E (rad), 0 <= e < 1.

    tan(nu / 2) = sqrt((1 + e) / (1 - e)) tan(E / 2), evaluated with atan2 so that E = +-pi is
    exact; whole revolutions of E are kept.
    """
    if not (math.isfinite(E) and math.isfinite(ecc)):
        return NAN, NON_FINITE
    if not (0.0 <= ecc < 1.0):
        return NAN, BAD_ECCENTRICITY
    base, Er = _revolutions(E)
    nu = 2.0 * math.atan2(
        math.sqrt(1.0 + ecc) * math.sin(0.5 * Er), math.sqrt(1.0 - ecc) * math.cos(0.5 * Er)
    )
    if base != 0.0:
        nu = base + nu
    return nu, OK


@kernel
def eccentric_from_true(nu, ecc):
    """Eccentric anomaly E (rad) from the true anomaly nu (rad), 0 <= e < 1 (keeps revolutions)."""
    if not (math.isfinite(nu) and math.isfinite(ecc)):
        return NAN, NON_FINITE
    if not (0.0 <= ecc < 1.0):
        return NAN, BAD_ECCENTRICITY
    base, nur = _revolutions(nu)
    E = 2.0 * math.atan2(
        math.sqrt(1.0 - ecc) * math.sin(0.5 * nur), math.sqrt(1.0 + ecc) * math.cos(0.5 * nur)
    )
    if base != 0.0:
        E = base + E
    return E, OK


@kernel
def true_from_hyperbolic(F, ecc):
    """True anomaly nu (rad) from the hyperbolic anomaly F (rad), e > 1.

    tan(nu / 2) = sqrt((e + 1) / (e - 1)) tanh(F / 2).
    """
    if not (math.isfinite(F) and math.isfinite(ecc)):
        return NAN, NON_FINITE
    if not ecc > 1.0:
        return NAN, BAD_ECCENTRICITY
    nu = 2.0 * math.atan2(math.sqrt(ecc + 1.0) * math.tanh(0.5 * F), math.sqrt(ecc - 1.0))
    return nu, OK


@kernel
def hyperbolic_from_true(nu, ecc):
    """Hyperbolic anomaly F (rad) from the true anomaly nu (rad), e > 1, |nu| < arccos(-1/e).

    tanh(F / 2) = sqrt((e - 1) / (e + 1)) tan(nu / 2); ``UNREACHABLE_ANOMALY`` beyond the
    asymptote.
    """
    if not (math.isfinite(nu) and math.isfinite(ecc)):
        return NAN, NON_FINITE
    if not ecc > 1.0:
        return NAN, BAD_ECCENTRICITY
    if abs(nu) >= math.acos(-1.0 / ecc):
        return NAN, UNREACHABLE_ANOMALY
    x = math.sqrt((ecc - 1.0) / (ecc + 1.0)) * math.tan(0.5 * nu)
    if abs(x) >= 1.0:
        return NAN, UNREACHABLE_ANOMALY
    return 2.0 * math.atanh(x), OK


@kernel
def true_from_parabolic(D):
    """True anomaly nu = 2 arctan(D) (rad) from D = tan(nu / 2) (parabola)."""
    if not math.isfinite(D):
        return NAN, NON_FINITE
    return 2.0 * math.atan(D), OK


@kernel
def parabolic_from_true(nu):
    """D = tan(nu / 2) from the true anomaly nu (rad) of a parabola, |nu| < pi."""
    if not math.isfinite(nu):
        return NAN, NON_FINITE
    if abs(nu) >= PI:
        return NAN, UNREACHABLE_ANOMALY
    return math.tan(0.5 * nu), OK


# ---------------------------------------------------------------------------------------------
# Mean <-> true for every e >= 0
# ---------------------------------------------------------------------------------------------
@kernel
def mean_to_true_anomaly(M, ecc):
    """True anomaly nu (rad) from the mean anomaly M (rad) for every e >= 0.

    M is the elliptic (E - e sin E), parabolic (D + D^3/3) or hyperbolic (e sinh F - F) mean
    anomaly according to e. Elliptic M keeps its revolutions; for e >= 1, |nu| < arccos(-1/e).
    """
    if not (math.isfinite(M) and math.isfinite(ecc)):
        return NAN, NON_FINITE
    if ecc < 0.0:
        return NAN, BAD_ECCENTRICITY
    if ecc < 1.0:
        E, st = eccentric_anomaly(M, ecc)
        if st != OK:
            return NAN, st
        nu, st = true_from_eccentric(E, ecc)
        return nu, st
    if ecc == 1.0:
        D, st = parabolic_anomaly(M)
        return 2.0 * math.atan(D), st
    F, st = hyperbolic_anomaly(M, ecc)
    if st != OK:
        return NAN, st
    return true_from_hyperbolic(F, ecc)


@kernel
def true_to_mean_anomaly(nu, ecc):
    """Mean anomaly M (rad) from the true anomaly nu (rad) for every e >= 0.

    ``UNREACHABLE_ANOMALY`` if e >= 1 and |nu| >= arccos(-1/e). Elliptic nu keeps revolutions.
    """
    if not (math.isfinite(nu) and math.isfinite(ecc)):
        return NAN, NON_FINITE
    if ecc < 0.0:
        return NAN, BAD_ECCENTRICITY
    if ecc < 1.0:
        E, st = eccentric_from_true(nu, ecc)
        if st != OK:
            return NAN, st
        base, Er = _revolutions(E)
        M = _mean_elliptic(Er, ecc)
        if base != 0.0:
            M = base + M
        return M, OK
    if ecc == 1.0:
        D, st = parabolic_from_true(nu)
        if st != OK:
            return NAN, st
        return mean_from_parabolic(D)
    F, st = hyperbolic_from_true(nu, ecc)
    if st != OK:
        return NAN, st
    return mean_from_hyperbolic(F, ecc)
