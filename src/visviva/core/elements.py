"""State vectors <-> classical and modified equinoctial orbital elements (compiled kernels).

Every conversion is written once as a scalar ``@kernel`` and vectorised by one ``prange`` loop
(the ``*_array`` functions). All inputs are plain float64 values in any consistent units (visviva
uses km, km/s, rad, km3/s2); every kernel returns an integer status from
:mod:`visviva.core.status` instead of raising.

Conventions (see ``docs/conventions.md``): the orbit orientation is
R = Rz(raan) Rx(inc) Rz(argp); the semi-latus rectum ``p`` is used instead of ``a`` so that the
exact parabola is representable; undefined angles are set (equatorial: raan = 0; circular:
argp = 0, nu = argument of latitude / true longitude) and the next angle of the chain absorbs
them, so that state -> elements -> state is exact to rounding for every conic and geometry.

Numerical method
----------------
No ``arccos`` of a rounded dot product is used. With **h** = r x v:

* inc = atan2(sqrt(hx^2 + hy^2), hz), raan = atan2(hx, -hy);
* e cos(nu) = p/r - 1 and e sin(nu) = h (r . v)/(mu r), so nu = atan2(h (r . v)/mu, p - r) and
  e = hypot(...)/r (Vallado 2013, eqs. 2-82/2-83 rearranged);
* the argument of latitude u is obtained from the true longitude measured in the equinoctial
  frame (f, g, w) of Walker, Ireland & Owens (1985), built from **h** with the Rodrigues formula
  of the minimal rotation that takes z to h/|h| (prograde, hz >= 0) or to Rx(pi) h/|h|
  (retrograde). That frame is well conditioned for every inclination, so u = l - raan (prograde)
  or u = l_r + raan (retrograde) keeps full precision in the round trip even when raan itself is
  ill conditioned (i -> 0 or i -> pi).

References
----------
Vallado, D. A. (2013). *Fundamentals of Astrodynamics and Applications*, 4th ed., Algorithms 9
(RV2COE) and 10 (COE2RV).
Walker, M. J. H., Ireland, B. & Owens, J. (1985). A set of modified equinoctial orbit elements.
*Celestial Mechanics* 36, 409-419.
Broucke, R. A. & Cefola, P. J. (1972). On the equinoctial orbit elements. *Celestial Mechanics*
5, 303-310 (the retrograde factor I).
"""

from __future__ import annotations

import math

import numpy as np

from . import status as st
from ._intrinsics import EPS as _EPS
from ._jit import inline_kernel, kernel, parallel_kernel, prange

__all__ = [
    "ECC_CIRCULAR",
    "ECC_PARABOLIC",
    "RADIAL_TOL",
    "P_OVER_R_MIN",
    "rv_to_coe",
    "coe_to_rv",
    "rv_to_mee",
    "mee_to_rv",
    "empty_elements",
    "empty_states",
    "rv_to_coe_array",
    "coe_to_rv_array",
    "rv_to_mee_array",
    "mee_to_rv_array",
    "scan_states",
    "scan_coe",
]

_PI = math.pi
_TWO_PI = 2.0 * math.pi
_NAN = math.nan

#: Below this eccentricity the orbit is treated as circular: e = 0, argp = 0, nu = u.
ECC_CIRCULAR = 16.0 * _EPS
#: Within this distance of 1 the eccentricity is set to exactly 1 (parabola).
ECC_PARABOLIC = 4.0 * _EPS
#: |r x v| <= RADIAL_TOL |r| |v| is radial motion: the cross product is rounding noise.
RADIAL_TOL = _EPS
#: p <= P_OVER_R_MIN r is numerically radial too: 1 + e cos(nu) = p/r would round to zero, so the
#: elements could not give the state back (slow, nearly radial falls).
P_OVER_R_MIN = 16.0 * _EPS  # > ECC_PARABOLIC plus rounding, so snapping e to 1 keeps p/r > 0


@inline_kernel
def _wrap_2pi(x):
    """Angle in [0, 2 pi), never -0.0; for |x| < 4 pi (sums of two wrapped angles)."""
    y = x
    if y < 0.0:
        y += _TWO_PI
        if y < 0.0:
            y += _TWO_PI
    if y >= _TWO_PI:
        y -= _TWO_PI
        if y >= _TWO_PI:
            y -= _TWO_PI
    return y + 0.0


@inline_kernel
def _wrap_pi(x):
    """Angle in (-pi, pi], never -0.0; angles already inside are returned unchanged (wrapping
    them through [0, 2 pi) would round small negative angles to multiples of ulp(2 pi))."""
    if -_PI < x <= _PI:
        return x + 0.0
    y = _wrap_2pi(x)
    if y > _PI:
        y -= _TWO_PI
    return y + 0.0


@inline_kernel
def _sin_cos_inc(inc):
    """sin and cos of the inclination, with float(pi) taken as exactly pi."""
    si = math.sin(inc)  # sin and cos side by side: LLVM fuses them into one sincos call
    ci = math.cos(inc)
    if inc == _PI:
        si = 0.0
        ci = -1.0
    return si, ci



@inline_kernel
def _check_state(rx, ry, rz, vx, vy, vz, gm):
    """Status of a state given to rv_to_coe / rv_to_mee, and |r| and v^2 when it is usable.

    NON_FINITE for NaN or inf, BAD_GM for gm <= 0, ZERO_POSITION for r = 0, OVERFLOW when
    |r|^2 or |v|^2 exceeds float64 (|r| or |v| beyond ~1.3e154: the radial-orbit test would
    otherwise compare against inf and call every such state radial), else OK.
    """
    if not (
        math.isfinite(rx)
        and math.isfinite(ry)
        and math.isfinite(rz)
        and math.isfinite(vx)
        and math.isfinite(vy)
        and math.isfinite(vz)
        and math.isfinite(gm)
    ):
        return st.NON_FINITE, 0.0, 0.0
    if not gm > 0.0:
        return st.BAD_GM, 0.0, 0.0
    rm = math.sqrt(rx * rx + ry * ry + rz * rz)
    if rm == 0.0:
        return st.ZERO_POSITION, 0.0, 0.0
    v2 = vx * vx + vy * vy + vz * vz
    if not (rm < math.inf and v2 < math.inf):
        return st.OVERFLOW, 0.0, 0.0
    return st.OK, rm, v2

@kernel
def rv_to_coe(rx, ry, rz, vx, vy, vz, gm):
    """Classical elements of one state vector.

    Parameters
    ----------
    rx, ry, rz : float
        Position (km, or any length unit consistent with ``gm``).
    vx, vy, vz : float
        Velocity (km/s).
    gm : float
        Gravitational parameter mu (km3/s2), > 0.

    Returns
    -------
    p, ecc, inc, raan, argp, nu : float
        Semi-latus rectum (km), eccentricity, inclination in [0, pi], longitude of the ascending
        node and argument of periapsis in [0, 2 pi), true anomaly in (-pi, pi] (rad).
    status : int
        ``OK``; ``NON_FINITE``, ``BAD_GM``, ``ZERO_POSITION``, ``OVERFLOW`` (|r|^2, |v|^2 or
        |r x v| beyond float64) or ``RADIAL_ORBIT`` (then the elements are NaN). ``RADIAL_ORBIT`` means |r x v| <= eps |r| |v|, or p <= 16 eps r (a
        nearly radial fall whose 1 + e cos(nu) = p/r rounds to zero).

    Notes
    -----
    h = r x v, p = h^2/mu, r e cos(nu) = p - r, r e sin(nu) = h (r . v)/mu,
    i = atan2(|h_xy|, h_z), raan = atan2(h_x, -h_y); the argument of latitude comes from the true
    longitude in the equinoctial frame (module docstring). Undefined angles follow
    docs/conventions.md. Vallado (2013) Algorithm 9; Walker et al. (1985).
    """
    code, rm, v2 = _check_state(rx, ry, rz, vx, vy, vz, gm)
    if code != st.OK:
        return _NAN, _NAN, _NAN, _NAN, _NAN, _NAN, code
    vm = math.sqrt(v2)
    hx = ry * vz - rz * vy
    hy = rz * vx - rx * vz
    hz = rx * vy - ry * vx
    hxy = math.sqrt(hx * hx + hy * hy)
    hm = math.sqrt(hxy * hxy + hz * hz)
    if not hm < math.inf:  # |r| |v| beyond ~1e154 (or inf - inf = NaN in a component)
        return _NAN, _NAN, _NAN, _NAN, _NAN, _NAN, st.OVERFLOW
    if hm <= RADIAL_TOL * rm * vm:
        return _NAN, _NAN, _NAN, _NAN, _NAN, _NAN, st.RADIAL_ORBIT

    p = hm * hm / gm
    if p <= P_OVER_R_MIN * rm:
        return _NAN, _NAN, _NAN, _NAN, _NAN, _NAN, st.RADIAL_ORBIT
    rdotv = rx * vx + ry * vy + rz * vz
    ecos_r = p - rm  # r e cos(nu)
    esin_r = hm * rdotv / gm + 0.0  # r e sin(nu); + 0.0 removes a negative zero
    ecc = math.sqrt(ecos_r * ecos_r + esin_r * esin_r) / rm
    circular = ecc < ECC_CIRCULAR
    if circular:
        ecc = 0.0
    elif abs(ecc - 1.0) <= ECC_PARABOLIC:
        ecc = 1.0

    inc = math.atan2(hxy, hz)
    if hxy == 0.0:
        raan = 0.0  # equatorial: node undefined
    else:
        raan = _wrap_2pi(math.atan2(hx, -hy))

    # True longitude in the equinoctial frame, scaled by |h| (no normalisation needed).
    if hz >= 0.0:
        inv_d = 1.0 / (hm + hz)
        fx = hm - hx * hx * inv_d
        fy = -hx * hy * inv_d
        fz = -hx
        gx = fy
        gy = hm - hy * hy * inv_d
        gz = -hy
        lam = math.atan2(rx * gx + ry * gy + rz * gz + 0.0, rx * fx + ry * fy + rz * fz)
        u = _wrap_2pi(lam - raan)
    else:
        inv_d = 1.0 / (hm - hz)
        fx = hm - hx * hx * inv_d
        fy = -hx * hy * inv_d
        fz = hx
        gx = -fy
        gy = hy * hy * inv_d - hm
        gz = -hy
        lam = math.atan2(rx * gx + ry * gy + rz * gz + 0.0, rx * fx + ry * fy + rz * fz)
        u = _wrap_2pi(lam + raan)

    if circular:
        argp = 0.0
        nu = _wrap_pi(u)
    else:
        nu = _wrap_pi(math.atan2(esin_r, ecos_r))
        argp = _wrap_2pi(u - nu)
    return p, ecc, inc, raan, argp, nu, st.OK


@inline_kernel
def _element_set_status(p, e1, e2, e3, e4, e5, gm):
    """``NON_FINITE``, ``BAD_GM`` (gm <= 0), ``BAD_SEMI_LATUS_RECTUM`` (p <= 0) or ``OK``.

    The checks every element set shares, in this order: ``p`` first, five more elements, ``gm``.
    """
    if not (
        math.isfinite(p)
        and math.isfinite(e1)
        and math.isfinite(e2)
        and math.isfinite(e3)
        and math.isfinite(e4)
        and math.isfinite(e5)
        and math.isfinite(gm)
    ):
        return st.NON_FINITE
    if not gm > 0.0:
        return st.BAD_GM
    if not p > 0.0:
        return st.BAD_SEMI_LATUS_RECTUM
    return st.OK


@kernel
def coe_to_rv(p, ecc, inc, raan, argp, nu, gm):
    """State vector of one set of classical elements.

    Parameters
    ----------
    p : float
        Semi-latus rectum (km), > 0.
    ecc : float
        Eccentricity, >= 0 (exactly 1 for a parabola).
    inc, raan, argp, nu : float
        Inclination, longitude of the ascending node, argument of periapsis, true anomaly (rad).
        ``inc == numpy.pi`` is taken as exactly pi.
    gm : float
        Gravitational parameter mu (km3/s2), > 0.

    Returns
    -------
    rx, ry, rz, vx, vy, vz : float
        Position (km) and velocity (km/s).
    status : int
        ``OK``; ``NON_FINITE``, ``BAD_GM``, ``BAD_SEMI_LATUS_RECTUM``, ``BAD_ECCENTRICITY`` or
        ``UNREACHABLE_ANOMALY`` (1 + e cos nu <= 0 on an open orbit); NaN outputs then.

    Notes
    -----
    With u = argp + nu and r = p/(1 + e cos nu), in the node frame
    r = r (cos u, sin u, 0), v = sqrt(mu/p) (-(sin u + e sin argp), cos u + e cos argp, 0),
    rotated by Rz(raan) Rx(inc). Vallado (2013) Algorithm 10.
    """
    s = _element_set_status(p, ecc, inc, raan, argp, nu, gm)
    if s == st.OK and ecc < 0.0:
        s = st.BAD_ECCENTRICITY
    if s != st.OK:
        return _NAN, _NAN, _NAN, _NAN, _NAN, _NAN, s
    cn = math.cos(nu)
    sn = math.sin(nu)
    denom = 1.0 + ecc * cn
    if not denom > 0.0:
        return _NAN, _NAN, _NAN, _NAN, _NAN, _NAN, st.UNREACHABLE_ANOMALY
    rm = p / denom
    si, ci = _sin_cos_inc(inc)
    so = math.sin(raan)
    co = math.cos(raan)
    sw = math.sin(argp)
    cw = math.cos(argp)
    # u = argp + nu by the addition formulas (one sin/cos pair fewer; error ~ 2 ulp either way)
    su = sw * cn + cw * sn
    cu = cw * cn - sw * sn
    # + 0.0: no negative zeros in the output (e.g. z of an equatorial orbit)
    rx = rm * (co * cu - so * su * ci) + 0.0
    ry = rm * (so * cu + co * su * ci) + 0.0
    rz = rm * su * si + 0.0
    k = math.sqrt(gm / p)
    a1 = -k * (su + ecc * sw)
    a2 = k * (cu + ecc * cw)
    vx = a1 * co - a2 * so * ci + 0.0
    vy = a1 * so + a2 * co * ci + 0.0
    vz = a2 * si + 0.0
    return rx, ry, rz, vx, vy, vz, st.OK


@inline_kernel
def _equinoctial_frame(hh, kk, retro):
    """Unit vectors f, g of the equinoctial frame from h, k and the retrograde factor I.

    h and k are divided by m = max(1, |h|, |k|) first (every ratio is homogeneous of degree 0),
    so h^2 and k^2 cannot overflow near the singular inclination; for m = 1 nothing changes.
    """
    m = max(1.0, abs(hh), abs(kk))
    hh = hh / m
    kk = kk / m
    one = 1.0 / m / m
    h2 = hh * hh
    k2 = kk * kk
    s2 = one + h2 + k2
    fx = (one + h2 - k2) / s2
    fy = 2.0 * hh * kk / s2
    fz = -2.0 * retro * kk / (m * s2)
    gx = 2.0 * retro * hh * kk / s2
    gy = retro * (one - h2 + k2) / s2
    gz = 2.0 * hh / (m * s2)
    return fx, fy, fz, gx, gy, gz


@kernel
def rv_to_mee(rx, ry, rz, vx, vy, vz, gm, retro):
    """Modified equinoctial elements of one state vector.

    Parameters
    ----------
    rx, ry, rz, vx, vy, vz : float
        Position (km) and velocity (km/s).
    gm : float
        Gravitational parameter mu (km3/s2), > 0.
    retro : float
        Retrograde factor I: +1.0 (standard set, singular at i = pi) or -1.0 (singular at i = 0).

    Returns
    -------
    p, f, g, h, k, L : float
        Semi-latus rectum (km), f = e cos(argp + I raan), g = e sin(argp + I raan),
        h = tan^I(i/2) cos(raan), k = tan^I(i/2) sin(raan), true longitude
        L = argp + I raan + nu in [0, 2 pi) (rad).
    status : int
        As :func:`rv_to_coe`, plus ``EQUINOCTIAL_SINGULAR`` when **h** is exactly anti-parallel to
        I z (i = pi for I = +1, i = 0 for I = -1).

    Notes
    -----
    The frame vectors are (Walker et al. 1985, eq. 2; Broucke & Cefola 1972)
    f = (1 + h^2 - k^2, 2hk, -2Ik)/s^2, g = (2Ihk, I(1 - h^2 + k^2), 2h)/s^2 with
    s^2 = 1 + h^2 + k^2; L = atan2(r . g, r . f); f = e cos(L - nu) and g = e sin(L - nu) from
    r e cos(nu) = p - r, r e sin(nu) = h (r . v)/mu and cos L = (r . f)/r, sin L = (r . g)/r, which
    avoids the cancellation of the eccentricity-vector formula far out on open orbits (and makes
    1 + f cos L + g sin L = p/r consistent to rounding). h = -h_y/d and k = h_x/d with
    d = |h| + I h_z, evaluated without cancellation as (h_x^2 + h_y^2)/(|h| - I h_z) when I h_z < 0.
    """
    code, rm, v2 = _check_state(rx, ry, rz, vx, vy, vz, gm)
    if code != st.OK:
        return _NAN, _NAN, _NAN, _NAN, _NAN, _NAN, code
    hx = ry * vz - rz * vy
    hy = rz * vx - rx * vz
    hz = rx * vy - ry * vx
    hxy2 = hx * hx + hy * hy
    hm = math.sqrt(hxy2 + hz * hz)
    if not hm < math.inf:  # as in rv_to_coe
        return _NAN, _NAN, _NAN, _NAN, _NAN, _NAN, st.OVERFLOW
    if hm <= RADIAL_TOL * rm * math.sqrt(v2) or hm * hm / gm <= P_OVER_R_MIN * rm:
        return _NAN, _NAN, _NAN, _NAN, _NAN, _NAN, st.RADIAL_ORBIT
    ihz = retro * hz
    if ihz >= 0.0:
        d = hm + ihz
    else:
        d = hxy2 / (hm - ihz)
    if not d > 0.0:
        return _NAN, _NAN, _NAN, _NAN, _NAN, _NAN, st.EQUINOCTIAL_SINGULAR
    kk = hx / d + 0.0
    hh = -hy / d + 0.0
    if not math.isfinite(hh * hh + kk * kk):  # tan^I(i/2) ~ 1e154 or more: overflow
        return _NAN, _NAN, _NAN, _NAN, _NAN, _NAN, st.EQUINOCTIAL_SINGULAR
    fx, fy, fz, gx, gy, gz = _equinoctial_frame(hh, kk, retro)
    rf = rx * fx + ry * fy + rz * fz  # r cos L
    rg = rx * gx + ry * gy + rz * gz + 0.0  # r sin L
    lam = _wrap_2pi(math.atan2(rg, rf))
    # f = e cos(L - nu), g = e sin(L - nu) from r e cos(nu) = p - r and r e sin(nu) = h (r.v)/mu
    # (not from the eccentricity vector, whose terms cancel far out on open orbits)
    p = hm * hm / gm
    rdotv = rx * vx + ry * vy + rz * vz
    ec = (p - rm) / rm
    es = hm * rdotv / (gm * rm)
    cl = rf / rm
    sl = rg / rm
    f = ec * cl + es * sl + 0.0
    g = ec * sl - es * cl + 0.0
    return p, f, g, hh, kk, lam, st.OK


@kernel
def mee_to_rv(p, f, g, h, k, L, gm, retro):
    """State vector of one set of modified equinoctial elements.

    Parameters
    ----------
    p : float
        Semi-latus rectum (km), > 0.
    f, g, h, k : float
        Equinoctial elements (dimensionless), see :func:`rv_to_mee`.
    L : float
        True longitude (rad).
    gm : float
        Gravitational parameter mu (km3/s2), > 0.
    retro : float
        Retrograde factor I, +1.0 or -1.0.

    Returns
    -------
    rx, ry, rz, vx, vy, vz : float
        Position (km) and velocity (km/s).
    status : int
        ``OK``, ``NON_FINITE``, ``BAD_GM``, ``BAD_SEMI_LATUS_RECTUM`` or ``UNREACHABLE_ANOMALY``
        (1 + f cos L + g sin L <= 0).

    Notes
    -----
    r = p/w with w = 1 + f cos L + g sin L; r = r (cos L f + sin L g),
    v = sqrt(mu/p) (-(g + sin L) f + (f + cos L) g) (Walker et al. 1985, eqs. 3-4).
    """
    s = _element_set_status(p, f, g, h, k, L, gm)
    if s != st.OK:
        return _NAN, _NAN, _NAN, _NAN, _NAN, _NAN, s
    cl = math.cos(L)
    sl = math.sin(L)
    w = 1.0 + f * cl + g * sl
    if not w > 0.0:
        return _NAN, _NAN, _NAN, _NAN, _NAN, _NAN, st.UNREACHABLE_ANOMALY
    rm = p / w
    fx, fy, fz, gx, gy, gz = _equinoctial_frame(h, k, retro)
    a = rm * cl
    b = rm * sl
    q = math.sqrt(gm / p)
    c = -q * (g + sl)
    e = q * (f + cl)
    return (
        a * fx + b * gx,
        a * fy + b * gy,
        a * fz + b * gz,
        c * fx + e * gx,
        c * fy + e * gy,
        c * fz + e * gz,
        st.OK,
    )


# ----------------------------------------------------------------------------------------------
# Array versions: one prange loop each over flattened, broadcast inputs.
# ----------------------------------------------------------------------------------------------


def empty_elements(n: int) -> tuple:
    """Outputs for :func:`rv_to_coe_array` / :func:`rv_to_mee_array`: six float64 arrays of shape
    ``(n,)`` and the int64 status array (plain Python: the wrapper owns the allocation)."""
    return (np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n),
            np.empty(n, dtype=np.int64))


def empty_states(n: int) -> tuple:
    """Outputs for :func:`coe_to_rv_array` / :func:`mee_to_rv_array`: ``r``, ``v`` of shape
    ``(n, 3)`` (float64) and the int64 status array of shape ``(n,)``."""
    return np.empty((n, 3)), np.empty((n, 3)), np.empty(n, dtype=np.int64)


@inline_kernel
def _put_elements(e0, e1, e2, e3, e4, e5, status, i, res):
    """Store item ``i`` of a 7-tuple ``res`` (six elements, then the status) into the outputs."""
    e0[i] = res[0]
    e1[i] = res[1]
    e2[i] = res[2]
    e3[i] = res[3]
    e4[i] = res[4]
    e5[i] = res[5]
    status[i] = res[6]


@inline_kernel
def _put_state(r, v, status, i, res):
    """Store item ``i`` of a 7-tuple ``res`` (x, y, z, vx, vy, vz, status) into ``r``, ``v``."""
    r[i, 0] = res[0]
    r[i, 1] = res[1]
    r[i, 2] = res[2]
    v[i, 0] = res[3]
    v[i, 1] = res[4]
    v[i, 2] = res[5]
    status[i] = res[6]


@parallel_kernel
def rv_to_coe_array(r, v, gm, p, ecc, inc, raan, argp, nu, status):
    """:func:`rv_to_coe` over ``r``, ``v`` of shape (n, 3) and ``gm`` of shape (n,), written into
    ``p, ecc, inc, raan, argp, nu`` (float64, (n,)) and ``status`` (int64, (n,)); see
    :func:`empty_elements`."""
    for i in prange(r.shape[0]):
        res = rv_to_coe(r[i, 0], r[i, 1], r[i, 2], v[i, 0], v[i, 1], v[i, 2], gm[i])
        _put_elements(p, ecc, inc, raan, argp, nu, status, i, res)


@parallel_kernel
def coe_to_rv_array(p, ecc, inc, raan, argp, nu, gm, r, v, status):
    """:func:`coe_to_rv` over arrays of shape (n,), written into ``r``, ``v`` (float64, (n, 3))
    and ``status`` (int64, (n,)); see :func:`empty_states`."""
    for i in prange(p.shape[0]):
        res = coe_to_rv(p[i], ecc[i], inc[i], raan[i], argp[i], nu[i], gm[i])
        _put_state(r, v, status, i, res)


@parallel_kernel
def rv_to_mee_array(r, v, gm, retro, p, f, g, h, k, L, status):
    """:func:`rv_to_mee` over ``r``, ``v`` (n, 3), ``gm`` (n,) and a scalar ``retro``, written
    into ``p, f, g, h, k, L`` (float64, (n,)) and ``status`` (int64, (n,)); see
    :func:`empty_elements`."""
    for i in prange(r.shape[0]):
        res = rv_to_mee(r[i, 0], r[i, 1], r[i, 2], v[i, 0], v[i, 1], v[i, 2], gm[i], retro)
        _put_elements(p, f, g, h, k, L, status, i, res)


@parallel_kernel
def mee_to_rv_array(p, f, g, h, k, L, gm, retro, r, v, status):
    """:func:`mee_to_rv` over arrays of shape (n,) and a scalar ``retro``, written into ``r``,
    ``v`` (float64, (n, 3)) and ``status`` (int64, (n,)); see :func:`empty_states`."""
    for i in prange(p.shape[0]):
        res = mee_to_rv(p[i], f[i], g[i], h[i], k[i], L[i], gm[i], retro)
        _put_state(r, v, status, i, res)


# ----------------------------------------------------------------------------------------------
# One-pass input scans for the public constructors (serial: memory bound, no parallel region).
# ----------------------------------------------------------------------------------------------


@kernel
def scan_states(r, v):
    """First invalid row of positions ``r`` and velocities ``v`` (both (n, 3)).

    Returns ``(index, status)``: ``NON_FINITE`` for NaN/inf, ``ZERO_POSITION`` for r = (0, 0, 0)
    (signed zeros too); ``(-1, OK)`` when every row is valid.
    """
    for i in range(r.shape[0]):
        for j in range(3):
            if not (math.isfinite(r[i, j]) and math.isfinite(v[i, j])):
                return i, st.NON_FINITE
        if r[i, 0] == 0.0 and r[i, 1] == 0.0 and r[i, 2] == 0.0:
            return i, st.ZERO_POSITION
    return -1, st.OK


@kernel
def scan_coe(p, ecc, inc, raan, argp, nu, gm, inc_slack):
    """First invalid item of flat, broadcast classical elements, as ``(index, status)``.

    ``NON_FINITE``, ``BAD_GM`` (gm <= 0), ``BAD_SEMI_LATUS_RECTUM`` (p <= 0),
    ``BAD_ECCENTRICITY`` (e < 0), ``DOMAIN`` (inclination outside [0, pi + inc_slack]) or
    ``UNREACHABLE_ANOMALY`` (1 + e cos nu <= 0); ``(-1, OK)`` when all are valid.
    """
    for i in range(p.shape[0]):
        s = _element_set_status(p[i], ecc[i], inc[i], raan[i], argp[i], nu[i], gm[i])
        if s != st.OK:
            return i, s
        if ecc[i] < 0.0:
            return i, st.BAD_ECCENTRICITY
        if inc[i] < 0.0 or inc[i] > _PI + inc_slack:
            return i, st.DOMAIN
        if ecc[i] >= 1.0 and not 1.0 + ecc[i] * math.cos(nu[i]) > 0.0:
            return i, st.UNREACHABLE_ANOMALY
    return -1, st.OK
