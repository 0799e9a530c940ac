"""Lambert's problem: the orbit through two positions in a given time of flight.

Two independent solvers, each written once as a scalar kernel with a ``prange`` array version:

* :func:`izzo_one`: Izzo (2015), "Revisiting Lambert's problem", Celest. Mech. Dyn. Astron.
  121, 1-15. One non-dimensional variable x, Lancaster-Blanchard time of flight (Battin's
  hypergeometric series near x = 1, Lagrange's form near it), Householder (3rd-order) iterations
  from Izzo's starters; for M >= 1 revolutions, the minimum time T_min(M) by Halley iterations,
  and the two solutions on either side of it: the **left** branch (x < x_Tmin, started from
  x0 = ((M pi + pi)/(8T))^(2/3) mapped to (-1, 1)) and the **right** branch (x > x_Tmin).
* :func:`universal_one`: the universal-variable method of Bate, Mueller & White (1971, sec. 5.3)
  as in Vallado (2013), Algorithm 58, solved by bisection in psi (robust, slower); for M >= 1
  psi is confined to (4 M^2 pi^2, 4 (M+1)^2 pi^2), where t(psi) has one minimum: golden-section
  search finds it, then bisection on the high-psi side (Izzo's left branch) or the low-psi side
  (right branch).

Both return status ``OK``, ``DOMAIN`` (no solution with M revolutions in this time, or r1, r2
collinear so the transfer plane is undefined), ``NON_FINITE``, ``BAD_GM``, ``ZERO_POSITION``
or ``NO_CONVERGENCE``.
"""

from __future__ import annotations

import math

from . import status as st
from ._intrinsics import EPS
from ._jit import inline_kernel, kernel, parallel_kernel, prange
from .stumpff import stumpff_c2c3

__all__ = ["izzo_one", "izzo_many", "universal_one", "universal_many", "izzo_tof"]

_PI = math.pi


@inline_kernel
def _hyp2f1b(z):
    """Battin's hypergeometric series 2F1(3, 1; 5/2; z) to machine precision (|z| < 1)."""
    s = 1.0
    cj = 1.0
    j = 0
    while j < 1000:
        cj = cj * (3.0 + j) * (1.0 + j) / (2.5 + j) * z / (j + 1.0)
        s += cj
        if abs(cj) < 1e-16 * abs(s):
            break
        j += 1
    return s


@kernel
def izzo_tof(x, lam, M):
    """Non-dimensional time of flight T(x) of Izzo (2015), eqs. 18-20 and Battin's series."""
    return _izzo_tof(x, lam, M, 1.0 - lam * lam)


@kernel
def _izzo_tof(x, lam, M, om):
    """:func:`izzo_tof` with ``om`` = 1 - lambda^2 = c/s given without cancellation (|lambda| -> 1
    near 0 and 360 deg): z = sqrt(om + lambda^2 x^2), and on the elliptic Lancaster form
    1 + g (or 1 - g), where acos(g) is ill-conditioned, from positive terms (audit53: T(x) had a
    relative error eps / (dnu')^2 there, and between equal radii 1e-8 rad short of 360 deg the
    arrival missed r2 by 6e-5 km)."""
    dist = abs(x - 1.0)
    if 0.01 < dist < 0.2:
        # Lagrange's form
        a = 1.0 / (1.0 - x * x)
        if a > 0.0:
            alfa = 2.0 * math.acos(max(-1.0, min(1.0, x)))
            beta = 2.0 * math.asin(min(1.0, math.sqrt(lam * lam / a)))
            if lam < 0.0:
                beta = -beta
            return a * math.sqrt(a) * ((alfa - math.sin(alfa)) - (beta - math.sin(beta))
                                       + 2.0 * _PI * M) / 2.0  # fmt: skip
        alfa = 2.0 * math.acosh(x)
        beta = 2.0 * math.asinh(math.sqrt(-lam * lam / a))
        if lam < 0.0:
            beta = -beta
        return -a * math.sqrt(-a) * ((beta - math.sinh(beta)) - (alfa - math.sinh(alfa))) / 2.0
    K = lam * lam
    E = x * x - 1.0
    rho = abs(E)
    z = math.sqrt(om + K * x * x)
    if dist < 0.01:
        # Battin's series
        eta = z - lam * x
        S1 = 0.5 * (1.0 - lam - x * eta)
        Q = 4.0 / 3.0 * _hyp2f1b(S1)
        return (eta * eta * eta * Q + 4.0 * lam * eta) / 2.0 + M * _PI / rho**1.5
    # Lancaster's form
    y = math.sqrt(rho)
    g = x * z - lam * E
    if E < 0.0:
        al = abs(lam)
        ax = abs(x)
        if lam < 0.0 and x < 0.0:  # g -> -1: 1 + g = (1 - |l|) om (1 - x^2) / ((z + |x|)(|l x| + z))
            one_p_g = om / (1.0 + al) * om * (-E) / ((z + ax) * (al * ax + z))
            acg = _PI - 2.0 * math.asin(min(1.0, math.sqrt(0.5 * one_p_g)))
        elif lam > 0.0 and x > 0.0:  # g -> +1: 1 - g = (1 - l) om (1 - x^2) / ((z + x)(z + l x))
            one_m_g = om / (1.0 + al) * om * (-E) / ((z + ax) * (z + al * ax))
            acg = 2.0 * math.asin(min(1.0, math.sqrt(0.5 * one_m_g)))
        else:
            acg = math.acos(max(-1.0, min(1.0, g)))
        d = M * _PI + acg
    else:
        f = y * (z - lam * x)
        d = math.log(f + g)
    return (x - lam * z - d / y) / E


@inline_kernel
def _dtdx(x, T, lam):
    """First three derivatives of T(x) (Izzo 2015, eq. 22)."""
    l2 = lam * lam
    l3 = l2 * lam
    umx2 = 1.0 - x * x
    y = math.sqrt(1.0 - l2 * umx2)
    y2 = y * y
    y3 = y2 * y
    d1 = (3.0 * T * x - 2.0 + 2.0 * l3 * x / y) / umx2
    d2 = (3.0 * T + 5.0 * x * d1 + 2.0 * (1.0 - l2) * l3 / y3) / umx2
    d3 = (7.0 * x * d2 + 8.0 * d1 - 6.0 * (1.0 - l2) * l2 * l3 * x / y3 / y2) / umx2
    return d1, d2, d3


@kernel
def _householder(T, x0, lam, M, om):
    """Solve T(x) = T by Householder's 3rd-order iteration; returns (x, converged)."""
    x = x0
    for _ in range(60):
        tof = _izzo_tof(x, lam, M, om)
        d1, d2, d3 = _dtdx(x, tof, lam)
        delta = tof - T
        d1sq = d1 * d1
        den = d1 * (d1sq - delta * d2) + d3 * delta * delta / 6.0
        if den == 0.0 or not math.isfinite(den):
            break
        xn = x - delta * (d1sq - delta * d2 / 2.0) / den
        if not math.isfinite(xn):
            break
        # keep x in the domain (-1, inf): halve towards the old x if needed
        if xn <= -1.0:
            xn = 0.5 * (x - 1.0)
        err = abs(xn - x)
        x = xn
        if err < 1e-14 * max(1.0, abs(x)):
            # tiny steps also happen when the iteration is pinned against x = -1: check T(x)
            return x, abs(_izzo_tof(x, lam, M, om) - T) <= 1e-9 * max(1.0, T)
    tof = _izzo_tof(x, lam, M, om)
    return x, abs(tof - T) <= 1e-11 * max(1.0, T)


@kernel
def _bisect_zero_rev(T, lam, om):
    """Solve T(x) = T for M = 0 by bisection (T decreases from inf at x = -1 to 0 at inf).

    The fallback when Householder's iteration fails, which happens for very long times of
    flight (x -> -1, where T ~ pi / (2 (1 + x))^(3/2)).
    """
    lo = -1.0
    hi = 0.0
    for _ in range(2100):
        if _izzo_tof(hi, lam, 0, om) <= T:
            break
        hi = 2.0 * hi + 1.0
    x = 0.5 * (lo + hi)
    for _ in range(2200):
        x = 0.5 * (lo + hi)
        if x <= lo or x >= hi:
            break
        if _izzo_tof(x, lam, 0, om) > T:
            lo = x
        else:
            hi = x
    tof = _izzo_tof(x, lam, 0, om)
    # near x = -1 the spacing of doubles limits T(x) ~ (1 + x)^(-3/2) to a relative precision
    # of ~1.5 eps / (1 + x); the velocities stay accurate (they are smooth in x there)
    if not (x > -1.0 and math.isfinite(tof)):
        return x, False
    return x, abs(tof - T) <= (1e-10 + 8.0 * 2.220446049250313e-16 / (1.0 + x)) * max(1.0, T)


@inline_kernel
def _half_sum_norm(ir1, ir2):
    """|r1_hat + r2_hat| / 2 = |cos(dnu/2)|, accurate also near dnu = 180 deg (no cancellation)."""
    sx = ir1[0] + ir2[0]
    sy = ir1[1] + ir2[1]
    sz = ir1[2] + ir2[2]
    return 0.5 * math.sqrt(sx * sx + sy * sy + sz * sz)


@inline_kernel
def _check_problem(r1, r2, tof, gm, M, v1, v2):
    """Common prologue of the solvers: NaN into ``v1``, ``v2``, then the input checks.

    Returns ``(status, |r1|, |r2|)``; status is ``OK`` when the problem can be solved
    (finite inputs, gm > 0, tof > 0, M >= 0, neither position zero).
    """
    for i in range(3):
        v1[i] = math.nan
        v2[i] = math.nan
    for i in range(3):
        if not (math.isfinite(r1[i]) and math.isfinite(r2[i])):
            return st.NON_FINITE, 0.0, 0.0
    if not (math.isfinite(tof) and math.isfinite(gm)):
        return st.NON_FINITE, 0.0, 0.0
    if not gm > 0.0:
        return st.BAD_GM, 0.0, 0.0
    if not tof > 0.0 or M < 0:
        return st.DOMAIN, 0.0, 0.0
    R1 = math.sqrt(r1[0] ** 2 + r1[1] ** 2 + r1[2] ** 2)
    R2 = math.sqrt(r2[0] ** 2 + r2[1] ** 2 + r2[2] ** 2)
    if R1 == 0.0 or R2 == 0.0:
        return st.ZERO_POSITION, R1, R2
    return st.OK, R1, R2


@kernel
def izzo_one(r1, r2, tof, gm, M, prograde, right, v1, v2):
    """Izzo's Lambert solver for one problem (see the module docstring).

    Parameters
    ----------
    r1, r2 : ndarray (3,)
        Initial and final positions (length).
    tof : float
        Time of flight (time), > 0.
    gm : float
        Gravitational parameter (length^3/time^2), > 0.
    M : int
        Number of complete revolutions, >= 0.
    prograde : bool
        True: the transfer moves counter-clockwise about +z (h_z > 0).
    right : bool
        For M >= 1, the right branch (else the left); ignored for M = 0.
    v1, v2 : ndarray (3,)
        Output velocities at r1 and r2 (NaN on failure).

    Returns
    -------
    int
        Status code.
    """
    status, R1, R2 = _check_problem(r1, r2, tof, gm, M, v1, v2)
    if status != st.OK:
        return status
    cx = r2[0] - r1[0]
    cy = r2[1] - r1[1]
    cz = r2[2] - r1[2]
    c = math.sqrt(cx * cx + cy * cy + cz * cz)
    s = 0.5 * (R1 + R2 + c)
    ir1 = (r1[0] / R1, r1[1] / R1, r1[2] / R1)
    ir2 = (r2[0] / R2, r2[1] / R2, r2[2] / R2)
    hx = ir1[1] * ir2[2] - ir1[2] * ir2[1]
    hy = ir1[2] * ir2[0] - ir1[0] * ir2[2]
    hz = ir1[0] * ir2[1] - ir1[1] * ir2[0]
    hn = math.sqrt(hx * hx + hy * hy + hz * hz)
    if hn < 1e-12:
        return st.DOMAIN
    ih = (hx / hn, hy / hn, hz / hn)
    # lambda^2 = 1 - c/s = r1 r2 cos^2(dnu/2) / s^2, with 2 |cos(dnu/2)| = |r1_hat + r2_hat|:
    # 1 - c/s cancels to nothing within ~1e-8 rad of 180 deg, the sum of unit vectors does not
    lam = min(1.0, math.sqrt(R1 * R2) * _half_sum_norm(ir1, ir2) / s)
    om = c / s  # 1 - lambda^2, exact where |lambda| -> 1 (0 and 360 deg)
    # tangential unit vectors, in the direction of motion
    sign = 1.0
    # the same test as universal_one, on the raw cross product: h_z = 0 (a transfer plane
    # containing the z axis) counts as prograde for the short way
    if r1[0] * r2[1] - r1[1] * r2[0] < 0.0:
        lam = -lam
        sign = -1.0
    if not prograde:
        lam = -lam
        sign = -sign
    it1 = (
        sign * (ih[1] * ir1[2] - ih[2] * ir1[1]),
        sign * (ih[2] * ir1[0] - ih[0] * ir1[2]),
        sign * (ih[0] * ir1[1] - ih[1] * ir1[0]),
    )
    it2 = (
        sign * (ih[1] * ir2[2] - ih[2] * ir2[1]),
        sign * (ih[2] * ir2[0] - ih[0] * ir2[2]),
        sign * (ih[0] * ir2[1] - ih[1] * ir2[0]),
    )
    T = math.sqrt(2.0 * gm / (s * s * s)) * tof

    # number of revolutions possible
    lam2 = lam * lam
    lam3 = lam2 * lam
    T00 = math.acos(lam) + lam * math.sqrt(1.0 - lam2)
    T1 = 2.0 / 3.0 * (1.0 - lam3)
    if M > 0:
        T0M = T00 + M * _PI
        if T < T0M:
            # minimum time of flight for M revolutions by Halley iterations from x = 0
            x_old = 0.0
            T_min = T0M
            for _ in range(50):
                d1, d2, d3 = _dtdx(x_old, T_min, lam)
                if d1 == 0.0:
                    break
                x_new = x_old - d1 * d2 / (d2 * d2 - d1 * d3 / 2.0)
                if abs(x_new - x_old) < 1e-13:
                    x_old = x_new
                    T_min = _izzo_tof(x_new, lam, M, om)
                    break
                x_old = x_new
                T_min = _izzo_tof(x_new, lam, M, om)
            if T_min > T:
                return st.DOMAIN
        if right:
            tmp = (8.0 * T / (M * _PI)) ** (2.0 / 3.0)
        else:
            tmp = ((M * _PI + _PI) / (8.0 * T)) ** (2.0 / 3.0)
        x0 = (tmp - 1.0) / (tmp + 1.0)
    else:
        if T >= T00:
            x0 = -(T - T00) / (T - T00 + 4.0)
        elif T <= T1:
            x0 = T1 * (T1 - T) / (2.0 / 5.0 * (1.0 - lam2 * lam3) * T) + 1.0
        else:
            x0 = (T / T00) ** (0.69314718055994529 / math.log(T1 / T00)) - 1.0
    x, ok = _householder(T, x0, lam, M, om)
    if not ok and M == 0:
        x, ok = _bisect_zero_rev(T, lam, om)
    if not ok:
        return st.NO_CONVERGENCE

    gamma = math.sqrt(gm * s / 2.0)
    rho = (R1 - R2) / c
    # sigma = sqrt(1 - rho^2) = 2 sqrt(r1 r2) |sin(dnu/2)| / c with 2 |sin(dnu/2)| =
    # |r1_hat - r2_hat|: 1 - rho^2 cancels near a 0/360 deg transfer, the difference does not
    dx = ir1[0] - ir2[0]
    dy = ir1[1] - ir2[1]
    dz = ir1[2] - ir2[2]
    sigma = math.sqrt(R1 * R2) * math.sqrt(dx * dx + dy * dy + dz * dz) / c
    y = math.sqrt(1.0 - lam2 + lam2 * x * x)
    vr1 = gamma * ((lam * y - x) - rho * (lam * y + x)) / R1
    vr2 = -gamma * ((lam * y - x) + rho * (lam * y + x)) / R2
    vt = gamma * sigma * (y + lam * x)
    vt1 = vt / R1
    vt2 = vt / R2
    for i in range(3):
        v1[i] = vr1 * ir1[i] + vt1 * it1[i]
        v2[i] = vr2 * ir2[i] + vt2 * it2[i]
    return st.OK


@inline_kernel
def _uv_tof(psi, r1n, r2n, A, gm):
    """Time of flight t(psi) and y(psi) of the universal-variable formulation; -inf if y < 0."""
    c2, c3 = stumpff_c2c3(psi)
    y = r1n + r2n + A * (psi * c3 - 1.0) / math.sqrt(c2)
    if y < 0.0:
        return -math.inf, y
    if psi < -1.0:
        # hyperbolic: with s = sqrt(-psi), S = sinh(s/2), C = cosh(s/2), chi^3 c3 + A sqrt(y)
        # = sqrt(y) [(r1 + r2)(sinh s - s) - sqrt(2) A (2 S - s C)] / (2 sqrt(2) S^3), a sum of
        # terms of one sign on either way; chi^3 c3 and A sqrt(y) nearly cancel on a short
        # long-way transfer (A < 0), resolving tof only to eps sinh^2(s/2) (v1 2e-8 off)
        s = math.sqrt(-psi)
        sh = math.sinh(0.5 * s)
        ch = math.cosh(0.5 * s)
        sh2 = sh * sh
        sh3 = sh2 * sh
        bracket = (r1n + r2n) * (2.0 * ch / sh2 - s / sh3) - math.sqrt(2.0) * A * (
            2.0 / sh2 - s * ch / sh3)
        return math.sqrt(y) * bracket / (2.0 * math.sqrt(2.0) * math.sqrt(gm)), y
    chi = math.sqrt(y / c2)
    return (chi * chi * chi * c3 + A * math.sqrt(y)) / math.sqrt(gm), y


@inline_kernel
def _uv_tof_of_y(y, r1n, r2n, A, gm):
    """t(y) on the hyperbolic short way (A > 0, psi < 0), with y itself the unknown.

    From y = r1 + r2 - A (1 - psi c3)/sqrt(c2) = r1 + r2 - sqrt(2) A cosh(sqrt(-psi)/2), psi
    follows from y without cancellation: cosh(s/2) = (r1 + r2 - y)/(sqrt(2) A), psi = -s^2.
    """
    q = (r1n + r2n - y) / (math.sqrt(2.0) * A)
    s = 2.0 * math.acosh(max(q, 1.0))
    c2, c3 = stumpff_c2c3(-s * s)
    chi = math.sqrt(y / c2)
    return (chi * chi * chi * c3 + A * math.sqrt(y)) / math.sqrt(gm)


@inline_kernel
def _uv_tof_near_end(w, end, sgn, r1n, r2n, A, gm, vers_half):
    """t and y at psi = (end + sgn w)^2 from w = |sqrt(psi) - end| itself.

    ``end`` is 2 pi (M + 1) (``sgn = -1``: long, nearly parabolic arcs) or 2 pi M
    (``sgn = +1``: the right branch's low end), where t(psi) is singular. There psi cannot
    carry w to better than ulp(psi)/end, and 1 - cos sqrt(psi) and psi c3 - 1 cancel; from w:
    sin^2(x/2) = sin^2(w/2), sin x = sgn sin w and (psi c3 - 1)/sqrt(c2) = -sgn sqrt(2) cos(w/2).

    With A = +-sqrt(2 r1 r2) cos(dnu/2), y = r1 + r2 -+ 2 sqrt(r1 r2) cos(dnu/2) cos(w/2); where
    sgn A > 0 (the long way near 360 deg, the right branch's short way near 0 deg) that is a
    difference of nearly equal terms when r1 ~ r2, and y -> 0: it is summed from positive terms,
    (sqrt r1 - sqrt r2)^2 + 2 sqrt(r1 r2) [(1 - cos(dnu/2)) + cos(dnu/2) 2 sin^2(w/4)], with
    ``vers_half`` = 1 - cos(dnu/2) from |r1_hat - r2_hat| (y had an absolute error eps (r1 + r2),
    and v1 missed r2 by 44 km 1e-6 rad short of 360 deg in LEO).
    """
    x = end + sgn * w
    sw = math.sin(0.5 * w)
    c2 = 2.0 * sw * sw / (x * x)
    c3 = (x - sgn * math.sin(w)) / (x * x * x)
    if sgn * A > 0.0:
        cos_half = 1.0 - vers_half
        s4 = math.sin(0.25 * w)
        d = (r1n - r2n) / (math.sqrt(r1n) + math.sqrt(r2n))
        y = d * d + 2.0 * math.sqrt(r1n * r2n) * (vers_half + cos_half * 2.0 * s4 * s4)
    else:
        y = r1n + r2n - sgn * math.sqrt(2.0) * A * math.cos(0.5 * w)
    if y < 0.0:
        return -math.inf, y
    chi = math.sqrt(y / c2)
    return (chi * chi * chi * c3 + A * math.sqrt(y)) / math.sqrt(gm), y


@kernel
def universal_one(r1, r2, tof, gm, M, prograde, right, v1, v2):
    """Universal-variable Lambert solver (Vallado 2013, Algorithm 58) by bisection in psi.

    Same arguments and statuses as :func:`izzo_one`. For M >= 1 Izzo's "right" branch is the
    low-psi side of the minimum of t(psi), the "left" one the high-psi side.
    """
    status, r1n, r2n = _check_problem(r1, r2, tof, gm, M, v1, v2)
    if status != st.OK:
        return status
    ir1 = (r1[0] / r1n, r1[1] / r1n, r1[2] / r1n)
    ir2 = (r2[0] / r2n, r2[1] / r2n, r2[2] / r2n)
    hz = r1[0] * r2[1] - r1[1] * r2[0]
    hx = r1[1] * r2[2] - r1[2] * r2[1]
    hy = r1[2] * r2[0] - r1[0] * r2[2]
    if math.sqrt(hx * hx + hy * hy + hz * hz) < 1e-12 * r1n * r2n:
        return st.DOMAIN
    short = hz >= 0.0
    if not prograde:
        short = not short
    tm = 1.0 if short else -1.0
    # A = sqrt(r1 r2 (1 + cos dnu)) = sqrt(2 r1 r2) |cos(dnu/2)|, from the sum of the unit
    # vectors: 1 + cos dnu by a dot product loses every digit within ~1e-7 rad of 180 deg
    cos_half = _half_sum_norm(ir1, ir2)
    A = tm * math.sqrt(2.0 * r1n * r2n) * cos_half
    # 1 - cos(dnu/2) = sin^2(dnu/2) / (1 + cos(dnu/2)), sin(dnu/2) = |r1_hat - r2_hat| / 2:
    # without cancellation near 0 and 360 deg (for y near the ends of psi)
    dx = ir1[0] - ir2[0]
    dy = ir1[1] - ir2[1]
    dz = ir1[2] - ir2[2]
    sin_half2 = 0.25 * (dx * dx + dy * dy + dz * dz)
    vers_half = sin_half2 / (1.0 + cos_half)
    if A == 0.0:
        return st.DOMAIN
    two_pi2 = 4.0 * _PI * _PI
    if M == 0:
        lo = -400.0 * two_pi2
        hi = two_pi2 * (1.0 - 1e-12)
    else:
        lo = two_pi2 * M * M * (1.0 + 1e-12)
        hi = two_pi2 * (M + 1) * (M + 1) * (1.0 - 1e-12)
        # golden-section search for the minimum of t(psi)
        a = lo
        b = hi
        g = 0.5 * (math.sqrt(5.0) - 1.0)
        for _ in range(200):
            c1 = b - g * (b - a)
            c2 = a + g * (b - a)
            t1, _y1 = _uv_tof(c1, r1n, r2n, A, gm)
            t2, _y2 = _uv_tof(c2, r1n, r2n, A, gm)
            if t1 < t2:
                b = c2
            else:
                a = c1
            if b - a < 1e-13 * hi:
                break
        psi_min = 0.5 * (a + b)
        t_min, _y = _uv_tof(psi_min, r1n, r2n, A, gm)
        if t_min > tof:
            return st.DOMAIN
        if right:
            hi = psi_min
        else:
            lo = psi_min
    # bisection; t(psi) increases on [lo, hi] except on the right multi-rev branch (decreases)
    increasing = M == 0 or not right
    psi = 0.5 * (lo + hi)
    y = 0.0
    for _ in range(400):
        psi = 0.5 * (lo + hi)
        t, y = _uv_tof(psi, r1n, r2n, A, gm)
        if (t < tof) == increasing:
            lo = psi
        else:
            hi = psi
        if hi - lo <= 4e-16 * max(1.0, abs(psi)):
            break
    t, y = _uv_tof(psi, r1n, r2n, A, gm)
    if M == 0 and A > 0.0 and psi < 0.0 and 0.0 < y < 1e-3 * (r1n + r2n):
        # a short, fast hyperbolic transfer: y = r1 + r2 - A (1 - psi c3)/sqrt(c2) is a
        # difference of nearly equal terms, so y(psi) moves in steps of eps (r1 + r2) and
        # t(psi) resolves tof only to eps (r1 + r2)/y (1e-8 of v1 silently at y ~ 1e-8 r):
        # finish by bisection in y itself, where t(y) is smooth and increasing
        ylo = 0.0
        yhi = r1n + r2n - math.sqrt(2.0) * A  # the parabola (psi = 0)
        slack = 64.0 * EPS * (r1n + r2n)  # the rounding of y(psi), with room
        if y - slack > 0.0 and _uv_tof_of_y(y - slack, r1n, r2n, A, gm) < tof:
            ylo = y - slack
        if y + slack < yhi and _uv_tof_of_y(y + slack, r1n, r2n, A, gm) >= tof:
            yhi = y + slack
        for _ in range(200):
            ym = 0.5 * (ylo + yhi)
            if ym <= ylo or ym >= yhi:
                break
            if _uv_tof_of_y(ym, r1n, r2n, A, gm) < tof:
                ylo = ym
            else:
                yhi = ym
        y = 0.5 * (ylo + yhi)
        t = _uv_tof_of_y(y, r1n, r2n, A, gm)
        q = (r1n + r2n - y) / (math.sqrt(2.0) * A)
        s = 2.0 * math.acosh(max(q, 1.0))
        psi = -s * s
    w_final = -1.0
    sgn = 0.0
    top = 2.0 * _PI * (M + 1)
    bottom = 2.0 * _PI * M
    if increasing and psi > (top - 1.0) * (top - 1.0):
        end, sgn = top, -1.0  # a long, nearly parabolic arc
    elif not increasing and psi < (bottom + 1.0) * (bottom + 1.0):
        end, sgn = bottom, 1.0  # the right branch near its low end
    if sgn != 0.0:
        # finish by bisection in w = |sqrt(psi) - end|, t decreasing in w from t(0) = inf
        wlo = 0.0
        whi = 1.0
        if _uv_tof_near_end(whi, end, sgn, r1n, r2n, A, gm, vers_half)[0] < tof:
            for _ in range(2000):
                wm = 0.5 * (wlo + whi)
                if wm <= wlo or wm >= whi:
                    break
                if _uv_tof_near_end(wm, end, sgn, r1n, r2n, A, gm, vers_half)[0] < tof:
                    whi = wm
                else:
                    wlo = wm
            w_final = 0.5 * (wlo + whi)
            t, y = _uv_tof_near_end(w_final, end, sgn, r1n, r2n, A, gm,
                                            vers_half)
    if not (y > 0.0) or abs(t - tof) > 1e-8 * tof:
        return st.NO_CONVERGENCE
    # v1 = (r2 - f r1)/g, v2 = (gdot r2 - r1)/g with f = 1 - y/r1, gdot = 1 - y/r2 and
    # g = A sqrt(y/mu), rearranged without cancellation near 180 deg (where g -> 0):
    # r2 - f r1 = r2 (r1_hat + r2_hat) + D r1_hat and gdot r2 - r1 = -(r1 (r1_hat + r2_hat)
    # + D r2_hat), with D = y - r1 - r2 = A (psi c3 - 1)/sqrt(c2) computed directly
    # The component of r1_hat + r2_hat along r1_hat (or r2_hat) is 1 + cos dnu = 2 cos^2(dnu/2),
    # O(eps^2) near 180 deg: it is taken from cos_half, not from the rounded sum, whose
    # rounding noise (1e-16) divided by g ~ eps would tilt the radial velocity.
    root = math.sqrt(y / gm)
    if w_final >= 0.0:
        d_over_g = -sgn * math.sqrt(2.0) * math.cos(0.5 * w_final) / root
    else:
        c2, c3 = stumpff_c2c3(psi)
        d_over_g = (psi * c3 - 1.0) / (math.sqrt(c2) * root)
    sum_over_g = 1.0 / (A * root)
    par = 2.0 * cos_half * cos_half
    sx = ir1[0] + ir2[0]
    sy = ir1[1] + ir2[1]
    sz = ir1[2] + ir2[2]
    p1 = par - (sx * ir1[0] + sy * ir1[1] + sz * ir1[2])
    p2 = par - (sx * ir2[0] + sy * ir2[1] + sz * ir2[2])
    v1[0] = r2n * (sx + p1 * ir1[0]) * sum_over_g + d_over_g * ir1[0]
    v1[1] = r2n * (sy + p1 * ir1[1]) * sum_over_g + d_over_g * ir1[1]
    v1[2] = r2n * (sz + p1 * ir1[2]) * sum_over_g + d_over_g * ir1[2]
    v2[0] = -(r1n * (sx + p2 * ir2[0]) * sum_over_g + d_over_g * ir2[0])
    v2[1] = -(r1n * (sy + p2 * ir2[1]) * sum_over_g + d_over_g * ir2[1])
    v2[2] = -(r1n * (sz + p2 * ir2[2]) * sum_over_g + d_over_g * ir2[2])
    return st.OK


@parallel_kernel
def izzo_many(r1, r2, tof, gm, M, prograde, right, v1, v2, status):
    """:func:`izzo_one` over N flattened, broadcast problems (r1, r2 (N, 3); tof, gm (N,))."""
    for k in prange(r1.shape[0]):
        status[k] = izzo_one(r1[k], r2[k], tof[k], gm[k], M, prograde, right, v1[k], v2[k])


@parallel_kernel
def universal_many(r1, r2, tof, gm, M, prograde, right, v1, v2, status):
    """:func:`universal_one` over N flattened, broadcast problems."""
    for k in prange(r1.shape[0]):
        status[k] = universal_one(r1[k], r2[k], tof[k], gm[k], M, prograde, right, v1[k], v2[k])
