"""Collision-probability kernels in the encounter plane (log space, no underflow).

Every function works on the encounter-plane description of a conjunction in the principal axes
of the combined position covariance: the miss vector ``(xm, zm)`` and the standard deviations
``(sx, sz)`` along the two axes, with a hard-body radius ``hbr`` in the same length unit. Results
are returned as natural logarithms of the probability, so that values down to 1e-300 (and far
below) keep their full relative accuracy; ``-inf`` means exactly zero.

* :func:`log_pc_circle`: Foster's 2-D integral over the hard-body circle, reduced to a 1-D integral
  along the ``x`` axis (the ``z`` direction done with the normal CDF), integrated by an adaptive
  Gauss-Legendre scheme to ~1e-13 relative.
* :func:`log_pc_chan`: Chan's series (equivalent-area circle in a Rician approximation).
* :func:`log_pc_many`: the Foster kernel over arrays (one ``prange`` loop).
* :func:`log_pc_chan_many`: Chan's series over arrays (one ``prange`` loop).

References: Foster & Estes (1992), NASA JSC-25898; Alfano, J. Astronaut. Sci. 53 (2005) 103;
Chan, *Spacecraft Collision Probability*, Aerospace Press (2008), ch. 5.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import inline_kernel, kernel, parallel_kernel, prange

__all__ = ["log_ndtr", "log_normal_interval", "log_pc_circle", "log_pc_chan", "log_pc_many",
           "log_pc_chan_many",
           "GAUSS_LO", "GAUSS_HI"]

_LOG_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)
_SQRT1_2 = math.sqrt(0.5)


def _legendre(n):
    x, w = np.polynomial.legendre.leggauss(n)
    return np.ascontiguousarray(np.stack([x, w]))


#: Gauss-Legendre nodes (row 0) and weights (row 1) on [-1, 1]: a 10-point rule and a 21-point
#: rule; their difference is the error estimate of the adaptive integration.
GAUSS_LO = _legendre(10)
GAUSS_HI = _legendre(21)
#: uniform pieces of theta in [-pi/2, pi/2] before adaptive bisection
_GRID = 8


@inline_kernel
def log_ndtr(z):
    """log of the standard normal CDF, accurate in both tails (asymptotic series below -20)."""
    if z > 6.0:
        return math.log1p(-0.5 * math.erfc(z * _SQRT1_2))
    if z > -20.0:
        return math.log(0.5 * math.erfc(-z * _SQRT1_2))
    # Phi(z) = phi(z)/|z| * (1 - 1/z^2 + 3/z^4 - 15/z^6 + ...): error < 1e-17 for z < -20
    z2 = z * z
    term = 1.0
    s = 1.0
    for k in range(1, 11):
        term *= -(2.0 * k - 1.0) / z2
        s += term
    return -0.5 * z2 - math.log(-z) - _LOG_SQRT_2PI + math.log(s)


@inline_kernel
def log_normal_interval(m, d):
    """log(Phi(m + d) - Phi(m - d)) for d >= 0: the standard normal mass of [m - d, m + d].

    Narrow intervals use the Hermite series of the integral (no cancellation), wide ones the
    difference of the two log-CDFs taken in the lower tail.
    """
    if d <= 0.0:
        return -math.inf
    if math.isinf(d):
        return 0.0
    am = abs(m)
    if d < 0.5 and am * d < 2.0:
        # int_{-d}^{d} phi(m + t) dt = phi(m) * 2d * sum_{n even} He_n(m) d^n / (n+1)!
        d2 = d * d
        he0 = 1.0  # He_k
        he1 = m  # He_{k+1}
        k = 0
        coef = 1.0  # d^k / (k+1)!
        s = 1.0
        for _ in range(60):
            he2 = m * he1 - (k + 1) * he0
            he3 = m * he2 - (k + 2) * he1
            k += 2
            coef *= d2 / (k * (k + 1.0))
            term = he2 * coef
            s += term
            he0 = he2
            he1 = he3
            if abs(term) < 1e-17 * abs(s):
                break
        return -0.5 * m * m - _LOG_SQRT_2PI + math.log(2.0 * d) + math.log(s)
    lo = m - d
    hi = m + d
    if lo >= 0.0:  # both in the upper tail: mirror into the lower one
        lo, hi = -hi, -lo
    if hi <= 0.0:
        la = log_ndtr(lo)
        lb = log_ndtr(hi)
        return lb + math.log1p(-math.exp(la - lb))
    return math.log(0.5 * (math.erf(hi * _SQRT1_2) - math.erf(lo * _SQRT1_2)))


@inline_kernel
def _log_integrand(theta, xm, zm, sx, sz, hbr):
    # x = xm + R sin(theta), half chord h = R cos(theta): the circle as a 1-D integral over x
    c = math.cos(theta)
    if c <= 0.0:
        return -math.inf
    x = (xm + hbr * math.sin(theta)) / sx
    h = hbr * c
    return (math.log(h) - math.log(sx) - 0.5 * x * x - _LOG_SQRT_2PI
            + log_normal_interval(zm / sz, h / sz))


@inline_kernel
def _rule(a, b, xm, zm, sx, sz, hbr, nodes, shift):
    half = 0.5 * (b - a)
    mid = 0.5 * (b + a)
    s = 0.0
    for k in range(nodes.shape[1]):
        L = _log_integrand(mid + half * nodes[0, k], xm, zm, sx, sz, hbr)
        s += nodes[1, k] * math.exp(L - shift)
    return s * half


@kernel
def log_pc_circle(xm, zm, sx, sz, hbr, lo_rule, hi_rule, rtol):
    """Natural log of the probability mass of N((0, 0), diag(sx^2, sz^2)) in the circle of
    radius ``hbr`` centred on ``(xm, zm)``; ``-inf`` for zero.

    Adaptive bisection of ``theta`` in ``x = xm + hbr sin(theta)`` (the substitution removes the
    square-root end points of the chord), with ``lo_rule``/``hi_rule`` Gauss-Legendre pairs
    (:data:`GAUSS_LO`, :data:`GAUSS_HI`), until the estimated error is below ``rtol`` of the total
    (or, where the inputs' rounding allows no more, below the condition floor
    ``16 eps (hbr + |miss|) / min(sx, sz) (4 + sqrt(2 |ln f_max|))``: a covariance thin beside a
    large circle whose edge lies in its tail). The integrand is scaled by its largest value, so
    nothing underflows.
    Returns ``(log_pc, status)``; status 1 means the tolerance was not reached.
    """
    if hbr <= 0.0:
        return -math.inf, 0
    if math.isinf(hbr):
        return 0.0, 0
    half_pi = 0.5 * math.pi
    # break points: the theta where x = 0 (peak of the x Gaussian) and where the half chord
    # equals |zm| (the z factor changes fastest there), plus a uniform grid
    nb = 0
    brk = np.empty(64)
    brk[nb] = -half_pi
    nb += 1
    brk[nb] = half_pi
    nb += 1
    if abs(xm) < hbr:
        brk[nb] = math.asin(-xm / hbr)
        nb += 1
    if abs(zm) < hbr:
        t = math.acos(abs(zm) / hbr)
        brk[nb] = t
        nb += 1
        brk[nb] = -t
        nb += 1
    for k in range(1, _GRID):
        brk[nb] = -half_pi + math.pi * k / _GRID
        nb += 1
    # scale: the largest log-integrand on the break points, refined by golden-section search
    shift = -math.inf
    best = 0.0
    for k in range(nb):
        L = _log_integrand(brk[k], xm, zm, sx, sz, hbr)
        if L > shift:
            shift = L
            best = brk[k]
    lo_t = max(-half_pi, best - math.pi / _GRID)
    hi_t = min(half_pi, best + math.pi / _GRID)
    g = 0.5 * (math.sqrt(5.0) - 1.0)
    for _ in range(60):
        t1 = hi_t - g * (hi_t - lo_t)
        t2 = lo_t + g * (hi_t - lo_t)
        if _log_integrand(t1, xm, zm, sx, sz, hbr) > _log_integrand(t2, xm, zm, sx, sz, hbr):
            hi_t = t2
        else:
            lo_t = t1
    peak = 0.5 * (lo_t + hi_t)
    L = _log_integrand(peak, xm, zm, sx, sz, hbr)
    if L > shift:
        shift = L
    else:
        peak = best
    if shift == -math.inf:
        return -math.inf, 0
    # width of the peak from the drop of the log-integrand, then break points at geometrically
    # growing distances around it, so that a very narrow peak is resolved from the start
    delta = math.pi / _GRID
    drop = 0.0
    for _ in range(60):
        la = _log_integrand(max(-half_pi, peak - delta), xm, zm, sx, sz, hbr)
        lb = _log_integrand(min(half_pi, peak + delta), xm, zm, sx, sz, hbr)
        drop = shift - 0.5 * (la + lb)
        if drop <= 8.0 or delta < 1e-15:
            break
        delta *= 0.25
    width = delta / math.sqrt(2.0 * drop) if drop > 0.0 else delta
    brk[nb] = peak
    nb += 1
    w = width
    for _ in range(14):
        if peak - w > -half_pi:
            brk[nb] = peak - w
            nb += 1
        if peak + w < half_pi:
            brk[nb] = peak + w
            nb += 1
        w *= 4.0
    b = np.sort(brk[:nb])
    # when ln(Pc) is huge and negative, the log-integrand carries an absolute rounding error of
    # ~eps |shift|, which bounds the relative accuracy of Pc itself (still exact in ln Pc);
    # and the circle's edge is only known to ~eps (hbr + miss), i.e. to that over the smaller
    # sigma in standard deviations, where the Gaussian's log falls at a rate ~sqrt(2 |shift|):
    # a covariance thin beside a large HBR with the edge in its tail bounds the accuracy there
    # (Pc's own condition number for its rounded inputs; demanding more made the adaptive
    # integration chase rounding noise and fail)
    eps = 2.220446049250313e-16
    edge = (hbr + math.hypot(xm, zm)) / min(sx, sz)
    rtol = max(rtol, 16.0 * eps * abs(shift),
               16.0 * eps * edge * (4.0 + math.sqrt(2.0 * abs(shift))))
    # global adaptive integration over the pieces
    cap = 4000
    ia = np.empty(cap)
    ib = np.empty(cap)
    iv = np.empty(cap)
    ie = np.empty(cap)
    n = 0
    for k in range(nb - 1):
        if b[k + 1] > b[k]:
            ia[n] = b[k]
            ib[n] = b[k + 1]
            hi = _rule(b[k], b[k + 1], xm, zm, sx, sz, hbr, hi_rule, shift)
            lo = _rule(b[k], b[k + 1], xm, zm, sx, sz, hbr, lo_rule, shift)
            iv[n] = hi
            ie[n] = abs(hi - lo)
            n += 1
    status = 1
    for _ in range(cap):
        total = 0.0
        err = 0.0
        worst = 0
        for k in range(n):
            total += iv[k]
            err += ie[k]
            if ie[k] > ie[worst]:
                worst = k
        if err <= rtol * total or total == 0.0:
            status = 0
            break
        if n + 1 >= cap:
            break
        a0 = ia[worst]
        b0 = ib[worst]
        m0 = 0.5 * (a0 + b0)
        for j in range(2):
            aa = a0 if j == 0 else m0
            bb = m0 if j == 0 else b0
            hi = _rule(aa, bb, xm, zm, sx, sz, hbr, hi_rule, shift)
            lo = _rule(aa, bb, xm, zm, sx, sz, hbr, lo_rule, shift)
            k = worst if j == 0 else n
            ia[k] = aa
            ib[k] = bb
            iv[k] = hi
            ie[k] = abs(hi - lo)
        n += 1
    total = 0.0
    for k in range(n):
        total += iv[k]
    if total <= 0.0:
        return -math.inf, status
    return shift + math.log(total), status


@parallel_kernel
def log_pc_many(xm, zm, sx, sz, hbr, lo_rule, hi_rule, rtol, out, status):
    """:func:`log_pc_circle` over 1-D arrays (one ``prange`` loop)."""
    for i in prange(xm.shape[0]):
        out[i], status[i] = log_pc_circle(xm[i], zm[i], sx[i], sz[i], hbr[i], lo_rule, hi_rule,
                                          rtol)


@inline_kernel
def _log_add(a, b):
    if a == -math.inf:
        return b
    if b == -math.inf:
        return a
    if a > b:
        return a + math.log1p(math.exp(b - a))
    return b + math.log1p(math.exp(a - b))


@inline_kernel
def _log_gammainc_lower(a, x):
    """log of the regularised lower incomplete gamma function P(a, x), a >= 1, x > 0."""
    if x <= 0.0:
        return -math.inf
    if x < a + 1.0:
        # series: P = x^a e^-x / Gamma(a+1) * sum_n x^n / ((a+1)...(a+n))
        term = 1.0
        s = 1.0
        ap = a
        for _ in range(2000):
            ap += 1.0
            term *= x / ap
            s += term
            if term < 1e-17 * s:
                break
        return a * math.log(x) - x - math.lgamma(a + 1.0) + math.log(s)
    # continued fraction for Q = 1 - P (modified Lentz)
    tiny = 1e-300
    bb = x + 1.0 - a
    c = 1.0 / tiny
    d = 1.0 / bb
    h = d
    for i in range(1, 2000):
        an = -i * (i - a)
        bb += 2.0
        d = an * d + bb
        if abs(d) < tiny:
            d = tiny
        c = bb + an / c
        if abs(c) < tiny:
            c = tiny
        d = 1.0 / d
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < 1e-16:
            break
    log_q = a * math.log(x) - x - math.lgamma(a) + math.log(h)
    return math.log1p(-math.exp(log_q))


@inline_kernel
def _chan_term(m, log_lam, lam, mu):
    """log of the m-th term of Chan's series, Poisson(m; lam) * P(m + 1, mu)."""
    lp = (m * log_lam if m > 0.0 else 0.0) - lam - math.lgamma(m + 1.0)
    return lp + _log_gammainc_lower(m + 1.0, mu)


@kernel
def log_pc_chan(xm, zm, sx, sz, hbr):
    """Chan's series for the circle of radius ``hbr`` (natural log).

    With ``u = hbr^2 / (sx sz)`` and ``v = xm^2/sx^2 + zm^2/sz^2``,
    ``Pc = sum_m Poisson(m; v/2) * P(m + 1, u/2)`` (``P`` the regularised lower incomplete gamma
    function), the form of Chan (2008) eq. 5.40 summed in log space. The terms are log-concave
    in ``m`` (a Poisson pmf times a Poisson tail), so their largest one is found by bisection on
    the sign of ``t(m + 1) - t(m)`` in ``[0, v/2]`` (it lies near ``sqrt(u v) / 2``, far below
    the Poisson mode ``v/2`` when the miss is many sigmas) and the sum runs outwards from it until
    the terms fall 45 nats below it: a few thousand terms even for ``v/2 = 1e11``.
    """
    if hbr <= 0.0:
        return -math.inf
    if math.isinf(hbr):
        return 0.0
    u = hbr * hbr / (sx * sz)
    v = (xm / sx) ** 2 + (zm / sz) ** 2
    lam = 0.5 * v
    mu = 0.5 * u
    log_lam = math.log(lam) if lam > 0.0 else -math.inf
    # the largest term: bisection over m in [0, floor(lam)] (terms decrease beyond the Poisson
    # mode, since P(m + 1, mu) decreases with m)
    lo = 0.0
    hi = math.floor(min(lam, 4e18))
    while hi - lo > 0.5:
        mid = math.floor(0.5 * (lo + hi))
        if _chan_term(mid + 1.0, log_lam, lam, mu) > _chan_term(mid, log_lam, lam, mu):
            lo = mid + 1.0
        else:
            hi = mid
    mode = lo
    best = _chan_term(mode, log_lam, lam, mu)
    total = best
    m = mode - 1.0
    while m >= 0.0:
        t = _chan_term(m, log_lam, lam, mu)
        total = _log_add(total, t)
        if t < best - 45.0 and m < mode - 5.0:
            break
        m -= 1.0
    if lam > 0.0:
        m = mode + 1.0
        while True:
            t = _chan_term(m, log_lam, lam, mu)
            total = _log_add(total, t)
            if t < best - 45.0 and m > mode + 5.0:
                break
            m += 1.0
    return total


@parallel_kernel
def log_pc_chan_many(xm, zm, sx, sz, hbr, out):
    """:func:`log_pc_chan` over 1-D arrays (one ``prange`` loop)."""
    for i in prange(xm.shape[0]):
        out[i] = log_pc_chan(xm[i], zm[i], sx[i], sz[i], hbr[i])
