"""Two-body propagation with universal variables: compiled kernels.

One formulation covers every conic (ellipse, exact parabola, hyperbola) and radial motion
(zero angular momentum). Following Danby (1992, sec. 6.9) and Stiefel & Scheifele (1971), the
universal anomaly ``s`` is defined by ``ds = dt / r`` and the Stumpff-Danby functions

    G_k(beta, s) = s**k c_k(beta s**2),   beta = 2 gm / r0 - v0**2   (twice minus the energy)

give, with ``eta = r0 . v0``,

    t(s)  = r0 G1 + eta G2 + gm G3                        (universal Kepler equation)
    r(s)  = r0 G0 + eta G1 + gm G2  = dt/ds
    f = 1 - gm G2 / r0,   g = r0 G1 + eta G2,   fdot = -gm G1 / (r r0),   gdot = 1 - gm G2 / r

``s`` relates to Vallado's chi (Algorithm 8) by ``chi = sqrt(gm) s`` and to the eccentric anomaly
by ``E - E0 = sqrt(beta) s``.

Everything here takes plain floats in any consistent units (visviva uses km, km/s, s, km3/s2) and
returns an integer status from :mod:`visviva.core.status` instead of raising.

Round-off without bias
----------------------
WHFast repeats the drift 10^5 to 10^6 times. Unbiased rounding errors add up like a random walk,
but a systematic error of even 0.01 ulp per drift dominates after about 10^4 drifts, and as an
energy drift it makes the phase error grow like t^2 instead of t^1.5 (Brouwer 1937; Rein & Tamayo
2015). The kernel is therefore built so that every rounding has mean zero over random states.
Over 10^6 random states of an e = 0.2 orbit and dt = P/20 the mean relative energy change per
drift is (+0.2 +- 0.6)e-3 ulp (before: (-9.5 +- 0.8)e-3), its RMS 0.57 ulp (rounding the exact
result alone gives 0.49; before: 0.84); at dt = P/5 it went from +0.35 to (+2 +- 6)e-3 ulp.
The causes found, and what replaced them:

1. *Rounded series coefficients.* ``fl(1/6)`` is 0.25 ulp low, so the series c3 was 0.25 ulp
   low on average (and c1 = 1 - psi c3 with it). Horner steps k <= 3 now add the residual
   ``lo_k = 1/n! - fl(1/n!)`` to the exact product with one fused multiply-add,
   ``c = C_k + fma(c, z, lo_k)``: the sum then rounded is the true partial sum. (Adding lo_k to
   a rounded value is lost below half an ulp, or rounded the same way every time.)
2. *A final Taylor step of G0, G1, G2* from the last iterate: its increments are mostly a few
   ulp or less, so they are rounded in a fixed direction, and the sign of the step correlates
   with the state (-0.027 ulp per drift where it was taken). The G functions are now evaluated
   afresh at the final s.
3. *Selection by the stopping test.* The loop stops where the computed residual ``F(s)`` is zero
   or asks for a step below half an ulp, so it picks ``s`` by the rounding errors of F's terms.
   When F was built from the same rounded G1, G2 that are returned, it picked those errors too
   (+0.006 ulp per drift where it stopped so). F now uses ``r0 s - r0 s (psi c3)`` and
   ``(eta s)(s c2)``, rounded independently of the returned ``G1 = s c1``, ``G2 = s**2 c2``.
4. *The state as an increment*: ``r = r0 + fma(f - 1, r0, g v0)``,
   ``v = v0 + fma(fdot, r0, (gdot - 1) v0)`` with ``f - 1 = -gm G2 / r0`` and
   ``gdot - 1 = -gm G2 / r`` computed directly: fewer and smaller rounding errors (RMS).

The fused multiply-add ``fma(a, b, c) = fl(a b + c)`` is the error-free product transformation
of Ogita, Rump & Oishi (2005); numba has none, so ``llvm.fma`` is called through an intrinsic
(:mod:`visviva.core._intrinsics`; one instruction on CPUs with FMA, a correctly rounded library call otherwise, exact rational
arithmetic under ``NUMBA_DISABLE_JIT``); the results are the same bits everywhere.
``tests/test_core_universal.py`` asserts the absence of the bias (mean energy change over 10^5
drifts) and of any bias of the series.

References
----------
Danby, J. M. A., *Fundamentals of Celestial Mechanics*, 2nd ed., Willmann-Bell 1992, sec. 6.9.
Vallado, D. A., *Fundamentals of Astrodynamics and Applications*, 4th ed. 2013, Algorithm 8.
Battin, R. H., *An Introduction to the Mathematics and Methods of Astrodynamics*, AIAA 1999, ch. 4.
Conway, B. A., "An improved algorithm due to Laguerre for the solution of Kepler's equation",
Celestial Mechanics 39, 199-211 (1986).
Ogita, T., Rump, S. M. & Oishi, S., "Accurate sum and dot product", SIAM J. Sci. Comput. 26,
1955-1988 (2005).
Brouwer, D., "On the accumulation of errors in numerical integration", Astron. J. 46, 149 (1937).
Rein, H. & Tamayo, D., "WHFast: a fast and unbiased implementation of a symplectic Wisdom-Holman
integrator for long-term gravitational simulations", MNRAS 452, 376-388 (2015).
"""

from __future__ import annotations

import math

import numpy as np

from ._intrinsics import EPS as _EPS
from ._intrinsics import fma as _fma
from ._jit import inline_kernel, kernel, parallel_kernel, prange
from .status import BAD_GM, HITS_ATTRACTOR, NO_CONVERGENCE, NON_FINITE, OK, ZERO_POSITION
from .stumpff import SERIES_LIMIT, stumpff_all, stumpff_c0123, stumpff_c2c3

__all__ = [
    "stumpff_c2c3",
    "stumpff_c0123",
    "propagate_one",
    "propagate_many",
    "propagate_scalar",
    "solve_universal",
    "MAX_ITERATIONS",
]

#: Bounded number of safeguarded Laguerre iterations on the universal Kepler equation.
MAX_ITERATIONS = 60

#: A Laguerre step below this fraction of s is taken as the last one (cubic convergence).
_ACCEPT = 1e-6
_TWO_PI = 2.0 * math.pi
#: Cancellation factor of g = r0 G1 + eta G2 above which the perifocal form takes over.
_SWITCH = 16.0
#: Beyond this cancellation factor the increment form carries no digit: fail rather than guess.
_GIVE_UP = 1e12
#: |r x v| <= _RADIAL_TOL |r| |v| counts as radial (rectilinear) motion.
_RADIAL_TOL = 4.0 * _EPS


@inline_kernel
def _time_to_collision(r0, eta, beta, gm):
    """Radial orbit: time since the nearest passage through r = 0 (negative: collision ahead).

    From r = 0 the universal solution is r = gm G2(s), r.v = gm G1(s), t = gm G3(s), so
    tan(x/2) = sqrt(beta) r0 / eta with x = sqrt(beta) s (tanh for beta < 0, s = 2 r0/eta for
    beta = 0). For an ellipse the result lies in [-P/2, P/2].
    """
    if eta == 0.0:
        # at apoapsis of a radial ellipse (v = 0): half a period from the collision
        x = math.pi
        s = x / math.sqrt(beta)
    else:
        y = beta * r0 * r0 / (eta * eta)
        if y > 1e-8:
            q = math.sqrt(y)
            h = math.atan(q) / q
        elif y < -1e-8:
            q = math.sqrt(-y)
            h = math.atanh(q) / q
        else:
            # atan(q)/q = 1 - y/3 + y^2/5 - ...  (same series for atanh with y < 0)
            h = 1.0 - y / 3.0 + y * y / 5.0 - y * y * y / 7.0
        s = 2.0 * r0 / eta * h
    c2, c3 = stumpff_c2c3(beta * s * s)
    return gm * s * s * s * c3


@inline_kernel
def solve_universal(A, B, C, beta, tau, s_start):
    """Solve ``A G1(s) + B G2(s) + C G3(s) = tau`` for s; returns ``(converged, s)``.

    With ``(A, B, C) = (r0, r0.v0, gm)`` this is the universal Kepler equation from the initial
    state; with ``(q, 0, gm)`` the one from periapsis. The left side is monotonic
    (its derivative ``A G0 + B G1 + C G2`` is the distance r >= 0), so safeguarded
    Laguerre-Conway steps (n = 5) with bisection inside a bracket always converge. For an ellipse
    the caller has reduced ``|tau|`` to at most one period: ``|s| < 2 pi / sqrt(beta)``.
    ``s_start`` (NaN: none) replaces the starter when it lies inside the bracket. Returns
    ``(converged, s, G0, G1, G2)`` at the root.
    """
    sgn = 1.0 if tau > 0.0 else -1.0
    if beta > 0.0:
        # t(+-2 pi / sqrt(beta)) = +-P >= |tau|: the root lies inside
        s_max = _TWO_PI / math.sqrt(beta)
        s0 = beta * tau / C  # mean motion guess, Vallado Algorithm 8
    else:
        s_max = math.inf
        s0 = tau / A if A > 0.0 else math.inf
        if beta < 0.0:
            # Vallado Algorithm 8 hyperbolic starter (chi0 / sqrt(gm))
            a = C / beta
            den = a * (B + sgn * math.sqrt(-C * a) * (1.0 - A / a))
            arg = -2.0 * C * tau / den if den != 0.0 else 0.0
            if arg > 1.0:
                s0 = sgn * math.sqrt(-a) * math.log(arg) / math.sqrt(C)
        # cube-root (parabolic, r0 -> 0) guess bounds the linear one when the flight is long
        s_cub = sgn * (6.0 * abs(tau) / C) ** (1.0 / 3.0)
        if abs(s_cub) < abs(s0):
            s0 = s_cub
    if sgn > 0.0:
        lo = 0.0
        hi = s_max
    else:
        lo = -s_max
        hi = 0.0
    if lo < s_start < hi:
        s0 = s_start
    if not (lo < s0 < hi) or s0 == 0.0:
        s0 = 0.5 * sgn * min(abs(tau) / A if A > 0.0 else 1.0, s_max)
        if s0 == 0.0:
            s0 = sgn * 1e-300

    s = s0
    for _ in range(MAX_ITERATIONS):
        psi = beta * s * s
        c0, c1, c2, c3 = stumpff_all(psi)
        if abs(c0) > 1e200:
            # cosh(x) > 1e200: t(s) is astronomically beyond any tau; bisect toward the start
            # (this also keeps inf - inf from ever forming)
            if s > 0.0:
                hi = s
            else:
                lo = s
            s = 0.5 * (lo + hi)
            continue
        G1 = s * c1
        G2 = s * s * c2
        # t_A = A G1 and t_B = B G2, but rounded independently of the G1, G2 returned (see
        # the module notes: the stopping test must not select on their rounding errors)
        As = A * s
        t_A = As - As * (psi * c3) if abs(psi) < SERIES_LIMIT else As * c1
        t_B = (B * s) * (s * c2)
        t_C = C * s * s * s * c3
        F = t_A + t_B + t_C - tau
        dF = A * c0 + B * G1 + C * G2
        ddF = B * c0 + (C - beta * A) * G1
        if F < 0.0:
            lo = s
        else:
            hi = s  # also for F = NaN (overflow far out): too far
        if F == 0.0:
            return True, s, c0, G1, G2
        # Laguerre (n = 5): 5 F / (F' + sqrt|16 F'^2 - 20 F F''|), scaled by F' (no overflow)
        delta = math.nan  # F' = 0 (at r = 0): bisect below
        if dF > 0.0:
            f_d = F / dF
            delta = 5.0 * f_d / (1.0 + math.sqrt(abs(16.0 - 20.0 * f_d * (ddF / dF))))
        s_new = s - delta
        noise = 0.0
        if dF > 0.0:
            noise = 4.0 * _EPS * (abs(t_A) + abs(t_B) + abs(t_C) + abs(tau)) / dF
        # Laguerre converges cubically: once a step is below 1e-6 of s, the next one would be
        # below 1e-17, so the step is taken and the loop ends without another residual. The G
        # functions are evaluated afresh at the new s (a Taylor step from s would round its
        # few-ulp increments in a fixed direction: an energy bias, see the module notes).
        if abs(delta) <= _ACCEPT * abs(s) + noise:
            if not lo < s_new < hi:
                return True, s, c0, G1, G2
            c0, c1, c2, c3 = stumpff_all(beta * s_new * s_new)
            return True, s_new, c0, s_new * c1, s_new * s_new * c2
        if not (lo < s_new < hi):
            # step left the bracket (or was NaN): bisect, or expand an open bracket
            if math.isinf(hi):
                s_new = 2.0 * s if s > lo else lo + 2.0 * abs(lo) + 1e-300
            elif math.isinf(lo):
                s_new = 2.0 * s if s < hi else hi - 2.0 * abs(hi) - 1e-300
            else:
                s_new = 0.5 * (lo + hi)
        width = hi - lo
        if s_new == s or (math.isfinite(width) and width <= 2.0 * _EPS * max(abs(lo), abs(hi))):
            return True, s, c0, G1, G2
        s = s_new
    return False, s, math.nan, math.nan, math.nan


@kernel
def propagate_scalar(x, y, z, vx, vy, vz, gm, dt):
    """Two-body propagation of one state given as scalars (the core of every wrapper).

    Parameters
    ----------
    x, y, z : float
        Position (length, e.g. km).
    vx, vy, vz : float
        Velocity (length / time, e.g. km/s).
    gm : float
        Gravitational parameter (length**3 / time**2), > 0.
    dt : float
        Time of flight (time), any sign.

    Returns
    -------
    status : int
        ``OK`` or a code from :mod:`visviva.core.status`; on failure the six outputs are NaN.
    x, y, z, vx, vy, vz : float
        The state after ``dt``.

    Notes
    -----
    See :func:`propagate_one`. When the solver fails at extreme magnitudes (gm = 1e300 or
    1e-300 km3/s2, say, or a tiny r0) it is run again in units where |r0| ~ 1 and the larger
    of |v0| and the circular speed ~ 1: length unit L = 2^a (a even) near |r0|, time unit
    T = 2^b with L / T near max(|v0|, sqrt(gm / r0)). Powers of two scale
    every float operation exactly, so this changes nothing but the exponent range.
    """
    rmax = max(abs(x), abs(y), abs(z))
    vmax = max(abs(vx), abs(vy), abs(vz))
    # squares of r and v cannot over- or underflow in this range: the caller's units are used
    ordinary = 1e-140 < rmax < 1e140 and vmax < 1e140 and (vmax == 0.0 or vmax > 1e-140)
    # at most two attempts through ONE call site (a device twin inlines every call site of the
    # solver): the caller's units, then the power-of-two units; a, av: their exponents
    a = 0
    av = 0
    px, py, pz, pvx, pvy, pvz, pgm, pdt = x, y, z, vx, vy, vz, gm, dt
    out = (OK, x, y, z, vx, vy, vz)
    for attempt in range(2):
        res = _propagate_unscaled(px, py, pz, pvx, pvy, pvz, pgm, pdt)
        if attempt == 1:
            break
        out = res
        if ordinary and out[0] != NO_CONVERGENCE and out[0] != ZERO_POSITION:
            return out
        if not (rmax > 0.0 and gm > 0.0 and math.isfinite(rmax) and math.isfinite(gm)):
            return out
        if not (math.isfinite(vmax) and math.isfinite(dt)):
            return out
        a = math.frexp(rmax)[1]
        a -= a % 2
        # speed unit: the larger of |v| and the circular speed sqrt(gm / r0), as exponents of 2
        c = (math.frexp(gm)[1] - a) // 2
        if vmax > 0.0:
            c = max(c, math.frexp(vmax)[1])
        b = a - c
        av = b - a  # velocity scale exponent: v' = v T / L
        px = math.ldexp(x, -a)
        py = math.ldexp(y, -a)
        pz = math.ldexp(z, -a)
        pvx = math.ldexp(vx, av)
        pvy = math.ldexp(vy, av)
        pvz = math.ldexp(vz, av)
        pgm = math.ldexp(gm, 2 * b - 3 * a)
        pdt = math.ldexp(dt, -b)
    st, xs, ys, zs, vxs, vys, vzs = res
    if st != OK:
        return out
    rx = math.ldexp(xs, a)
    ry = math.ldexp(ys, a)
    rz = math.ldexp(zs, a)
    ux = math.ldexp(vxs, -av)
    uy = math.ldexp(vys, -av)
    uz = math.ldexp(vzs, -av)
    if not (
        math.isfinite(rx)
        and math.isfinite(ry)
        and math.isfinite(rz)
        and math.isfinite(ux)
        and math.isfinite(uy)
        and math.isfinite(uz)
    ):
        return out
    return OK, rx, ry, rz, ux, uy, uz


@kernel
def _propagate_unscaled(x, y, z, vx, vy, vz, gm, dt):
    """Two-body propagation of one state in the caller's units, without rescaling.

    Parameters, returns and units are those of :func:`propagate_scalar`, which calls this
    once, and again in power-of-two units when the magnitudes are extreme.

    Notes
    -----
    See :func:`propagate_one`.
    """
    nan = math.nan
    if not (
        math.isfinite(x)
        and math.isfinite(y)
        and math.isfinite(z)
        and math.isfinite(vx)
        and math.isfinite(vy)
        and math.isfinite(vz)
        and math.isfinite(gm)
        and math.isfinite(dt)
    ):
        return NON_FINITE, nan, nan, nan, nan, nan, nan
    if not gm > 0.0:
        return BAD_GM, nan, nan, nan, nan, nan, nan
    r0 = math.sqrt(x * x + y * y + z * z)
    if r0 == 0.0:
        return ZERO_POSITION, nan, nan, nan, nan, nan, nan
    if dt == 0.0:
        return OK, x, y, z, vx, vy, vz

    v2 = vx * vx + vy * vy + vz * vz
    eta = x * vx + y * vy + z * vz
    beta = 2.0 * gm / r0 - v2

    # --- radial (rectilinear) motion: refuse to go through the attractor -------------------
    hx = y * vz - z * vy
    hy = z * vx - x * vz
    hz = x * vy - y * vx
    h = math.sqrt(hx * hx + hy * hy + hz * hz)
    if h <= _RADIAL_TOL * r0 * math.sqrt(v2):
        t_since = _time_to_collision(r0, eta, beta, gm)
        if beta > 0.0:
            period = _TWO_PI * gm / (beta * math.sqrt(beta))
            ahead = np.fmod(-t_since, period)
            if ahead <= 0.0:
                ahead += period
            behind = np.fmod(t_since, period)
            if behind <= 0.0:
                behind += period
            if (dt > 0.0 and dt >= ahead) or (dt < 0.0 and -dt >= behind):
                return HITS_ATTRACTOR, nan, nan, nan, nan, nan, nan
        else:
            if (dt > 0.0 and t_since < 0.0 and dt >= -t_since) or (
                dt < 0.0 and t_since > 0.0 and -dt >= t_since
            ):
                return HITS_ATTRACTOR, nan, nan, nan, nan, nan, nan

    # --- reduce whole revolutions, then solve the universal Kepler equation ----------------
    tau = dt
    if beta > 0.0:
        period = _TWO_PI * gm / (beta * math.sqrt(beta))
        if abs(tau) > 0.5 * period:
            # whole revolutions change nothing: reduce to |tau| <= P/2 (fmod is exact)
            tau = np.fmod(tau, period)
            if tau > 0.5 * period:
                tau -= period
            elif tau < -0.5 * period:
                tau += period
            if tau == 0.0:
                return OK, x, y, z, vx, vy, vz
    converged, s, G0, G1, G2 = solve_universal(r0, eta, gm, beta, tau, nan)

    # --- f and g (Danby's G-function form) -------------------------------------------------
    g = nan
    cancel = math.inf
    if converged:
        t_r0 = r0 * G1
        t_eta = eta * G2
        g = t_r0 + t_eta
        small = min(abs(g), abs(tau))
        cancel = (abs(t_r0) + abs(t_eta)) / small if small > 0.0 else math.inf
    if not cancel <= _SWITCH:
        # the increment form cancels (a far start falling in, or a deep periapsis passage
        # of a fast hyperbola) or failed: count the anomaly from periapsis instead
        out = _from_periapsis(x, y, z, vx, vy, vz, gm, tau, r0, eta, beta, s)
        if out[0] == OK or not cancel < _GIVE_UP:
            return out
    fm1 = -gm * G2 / r0
    r = r0 * G0 + eta * G1 + gm * G2
    if not r > 0.0:
        return NO_CONVERGENCE, nan, nan, nan, nan, nan, nan
    fdot = -gm * G1 / (r * r0)
    gdm1 = -gm * G2 / r
    return (
        OK,
        x + _fma(fm1, x, g * vx),
        y + _fma(fm1, y, g * vy),
        z + _fma(fm1, z, g * vz),
        vx + _fma(fdot, x, gdm1 * vx),
        vy + _fma(fdot, y, gdm1 * vy),
        vz + _fma(fdot, z, gdm1 * vz),
    )


@inline_kernel
def _from_periapsis(x, y, z, vx, vy, vz, gm, tau, r0, eta, beta, s_guess):
    """Propagation in the perifocal frame with the universal anomaly counted from periapsis.

    Used when the increment form cancels (the start is far from the attractor and the path
    falls in: ``|r0 G1| + |eta G2| >> |g|``). From periapsis every term has one sign:
    ``t(sigma) = q sigma + gm e G3``, ``r = q + gm e G2``, ``r.v = gm e G1`` and, in the
    perifocal frame (P toward periapsis, Q = h x P / h),
    ``r = (q - gm G2) P + h G1 Q``, ``v = -(gm/r) G1 P + (h/r) G0 Q``
    (Danby 1992 sec. 6.9 with eta = 0 at periapsis). The starting anomaly sigma0 follows from
    ``G1(sigma0) = eta / (gm e)`` and ``G2(sigma0) = (r0 - q) / (gm e)``. Returns a non-OK
    status when the orbit is too close to circular for the frame (never the case when the
    increment form cancels) or the iteration fails; the caller then keeps the increment form.
    """
    nan = math.nan
    hx = y * vz - z * vy
    hy = z * vx - x * vz
    hz = x * vy - y * vx
    h2 = hx * hx + hy * hy + hz * hz
    h = math.sqrt(h2)
    # e = v x h / gm - r / r0 (no large cancellation far from the attractor)
    ex = (vy * hz - vz * hy) / gm - x / r0
    ey = (vz * hx - vx * hz) / gm - y / r0
    ez = (vx * hy - vy * hx) / gm - z / r0
    ecc = math.sqrt(ex * ex + ey * ey + ez * ez)
    if not ecc > 1e-3:
        return NO_CONVERGENCE, nan, nan, nan, nan, nan, nan
    px = ex / ecc
    py = ey / ecc
    pz = ez / ecc
    if h > 0.0:
        qx = (hy * pz - hz * py) / h
        qy = (hz * px - hx * pz) / h
        qz = (hx * py - hy * px) / h
    else:
        qx = qy = qz = 0.0
    q = h2 / (gm * (1.0 + ecc))
    mue = gm * ecc
    g1 = eta / mue
    if beta > 0.0:
        kb = math.sqrt(beta)
        sigma0 = math.atan2(kb * g1, 1.0 - beta * (r0 - q) / mue) / kb
    elif beta < 0.0:
        kb = math.sqrt(-beta)
        sigma0 = math.asinh(kb * g1) / kb
    else:
        sigma0 = g1
    c0, c1, c2, c3 = stumpff_all(beta * sigma0 * sigma0)
    T1 = q * sigma0 + mue * sigma0 * sigma0 * sigma0 * c3 + tau
    # t(sigma) = q G1 + gm G3 = q sigma + gm e G3: the universal equation from periapsis
    converged, sigma, G0, G1, G2 = solve_universal(q, 0.0, gm, beta, T1, sigma0 + s_guess)
    if not converged:
        converged, sigma, G0, G1, G2 = solve_universal(q, 0.0, gm, beta, T1, nan)
    if not converged or not math.isfinite(sigma):
        return NO_CONVERGENCE, nan, nan, nan, nan, nan, nan
    r = q + mue * G2
    if not r > 0.0:
        return HITS_ATTRACTOR, nan, nan, nan, nan, nan, nan
    X = q - gm * G2
    Y = h * G1
    VX = -gm * G1 / r
    VY = h * G0 / r
    return (
        OK,
        X * px + Y * qx,
        X * py + Y * qy,
        X * pz + Y * qz,
        VX * px + VY * qx,
        VX * py + VY * qy,
        VX * pz + VY * qz,
    )


@kernel
def propagate_one(r0, v0, gm, dt, r_out, v_out):
    """Propagate one two-body state by ``dt`` with universal variables (every conic).

    Parameters
    ----------
    r0, v0 : ndarray of float64, shape (3,)
        Initial position (length) and velocity (length / time); views are fine.
    gm : float
        Gravitational parameter (length**3 / time**2), > 0.
    dt : float
        Time of flight (time); negative goes back in time, 0 returns the input exactly.
    r_out, v_out : ndarray of float64, shape (3,)
        Written with the final state (may be the same arrays as ``r0``, ``v0``: in-place update);
        NaN on failure.

    Returns
    -------
    int
        ``OK``; ``NON_FINITE``, ``BAD_GM``, ``ZERO_POSITION`` for bad input; ``HITS_ATTRACTOR``
        when a radial (h = 0) orbit reaches r = 0 within ``dt``; ``NO_CONVERGENCE`` if the
        bounded iteration failed (never seen in tests).

    Notes
    -----
    Solves the universal Kepler equation ``t(s) = r0 G1 + eta G2 + gm G3 = dt`` for the
    universal anomaly ``s`` (Danby 1992 sec. 6.9; ``s = chi / sqrt(gm)`` of Vallado's
    Algorithm 8) with Laguerre-Conway steps (Conway 1986) safeguarded by a bracket: ``t(s)`` is
    monotonic (``dt/ds = r >= 0``), so a step leaving the bracket is replaced by bisection.
    Elliptic ``dt`` is first reduced modulo the period to ``|dt| <= P/2`` (exact ``fmod``),
    which bounds the root by ``|s| <= 2 pi / sqrt(beta)``. Starters: mean motion (ellipse),
    Vallado's logarithm (hyperbola), ``cbrt(6 dt / gm)`` (near parabola, long flights).
    Then ``r = r0 + ((f - 1) r0 + g v0)``, ``v = v0 + (fdot r0 + (gdot - 1) v0)`` (each inner
    sum one fused multiply-add) with ``f - 1 = -gm G2/r0``, ``g = r0 G1 + eta G2``,
    ``fdot = -gm G1/(r r0)``, ``gdot - 1 = -gm G2/r``: the direct formula for gdot (not
    ``(1 + g fdot)/f``) because it does not divide by ``f``, which vanishes at quarter turns.
    Every rounding in the chain is unbiased, so repeated drifts do not drift in energy (module
    notes, "Round-off without bias").
    When the increment form cancels (``|r0 G1| + |eta G2| > 16 min(|g|, |dt|)``: a start far
    from the attractor falling in, or a fast hyperbola through a deep periapsis) the same
    solver runs on the equation counted from periapsis, ``q G1(sigma) + gm G3(sigma)``, whose
    terms all have one sign, and the state is built in the perifocal frame
    (:func:`_from_periapsis`); the error then stays at the conditioning of the problem.
    Radial motion (``|r x v| <= 4 eps |r||v|``) is followed exactly until the body reaches
    ``r = 0``; asking for a time at or beyond that returns ``HITS_ATTRACTOR``.
    """
    st, x, y, z, vx, vy, vz = propagate_scalar(r0[0], r0[1], r0[2], v0[0], v0[1], v0[2], gm, dt)
    r_out[0] = x
    r_out[1] = y
    r_out[2] = z
    v_out[0] = vx
    v_out[1] = vy
    v_out[2] = vz
    return st


@parallel_kernel
def propagate_many(r0, v0, gm, dt, r_out, v_out, status):
    """Propagate ``n`` independent two-body states in parallel (``prange`` over items).

    Parameters
    ----------
    r0, v0 : ndarray of float64, shape (n, 3)
        Initial positions (length) and velocities (length / time).
    gm, dt : ndarray of float64, shape (n,)
        Gravitational parameters (length**3 / time**2) and times of flight (time).
    r_out, v_out : ndarray of float64, shape (n, 3)
        Preallocated outputs (NaN where the status is not OK).
    status : ndarray of int, shape (n,)
        Preallocated; written with one status code per item.

    Notes
    -----
    Each item is :func:`propagate_scalar`; see :func:`propagate_one` for the method.
    """
    n = r0.shape[0]
    for i in prange(n):
        st, x, y, z, vx, vy, vz = propagate_scalar(
            r0[i, 0], r0[i, 1], r0[i, 2], v0[i, 0], v0[i, 1], v0[i, 2], gm[i], dt[i]
        )
        r_out[i, 0] = x
        r_out[i, 1] = y
        r_out[i, 2] = z
        v_out[i, 0] = vx
        v_out[i, 1] = vy
        v_out[i, 2] = vz
        status[i] = st
