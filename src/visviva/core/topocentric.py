"""Topocentric geometry and pass search on plain float64 arrays (Earth-fixed frame, km, s).

Everything here works in the Earth-fixed frame (ITRS), where a ground site is at rest and its
east-north-up axes are constant:

* :func:`razel` and :func:`razel_many`: range, azimuth, elevation and their rates from the
  site-to-satellite vector ``rho`` and its rate (Vallado 2013, Algorithm 27, RAZEL).
* :func:`scan_passes`: the coarse search and root refinement of the pass finder. The satellite's
  Earth-fixed states at uniformly spaced nodes are joined by cubic Hermite polynomials (position
  and velocity at both ends; error ~ ``r (n h)^4 / 384`` for a step ``h``); the elevation
  function ``f(t) = sin(el) - sin(el_min) = (rho . up) / |rho| - sin(el_min)`` is sampled at
  ``m`` points per node interval; every discrete extremum is refined by golden-section search on
  the polynomial; ``f`` is monotonic between consecutive extrema, so each sign change between
  them holds exactly one crossing, found by Illinois regula falsi. This is Skyfield's
  ``find_discrete`` / ``find_maxima`` idea (sample, bracket, refine), written once as a streaming
  scalar loop over the samples of one (satellite, station) pair and run for all pairs with
  ``prange``.
* :func:`elevation_rate_many`: ``f`` and ``df/dt`` from exact states, for the final Newton and
  secant corrections that the caller does on the SGP4 states themselves.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import inline_kernel, kernel, parallel_kernel, prange
from .hermite import hermite_basis

__all__ = ["razel", "razel_many", "scan_passes", "elevation_rate_many", "RISE", "CULMINATION",
           "SET", "NEAR_MAXIMUM", "teme_to_itrs_anchored", "PAIR_OK", "PAIR_NON_FINITE", "PAIR_OVERFLOW"]

#: event kinds (Skyfield's convention)
RISE = 0
CULMINATION = 1
SET = 2
#: a maximum just below the threshold on the interpolating polynomial (a candidate)
NEAR_MAXIMUM = 5

#: per-pair status of :func:`scan_passes`
PAIR_OK = 0
PAIR_NON_FINITE = 1  # empty window (SGP4 failed from its start): pair skipped
PAIR_OVERFLOW = 2  # more events than the output capacity: count holds the number needed

_GOLDEN = 0.3819660112501051  # 2 - golden ratio


@inline_kernel
def razel(px, py, pz, vx, vy, vz, east, north, up):
    """Range, azimuth, elevation and their rates from the site-to-target vector.

    Parameters
    ----------
    px, py, pz : float
        ``rho``, target minus site, Earth-fixed, km.
    vx, vy, vz : float
        ``d rho / dt`` in the Earth-fixed frame, km/s.
    east, north, up : ndarray (3,)
        The site's local unit vectors, Earth-fixed axes.

    Returns
    -------
    (rng, az, el, rng_rate, az_rate, el_rate) : floats
        km, rad in [0, 2 pi), rad, km/s, rad/s, rad/s. At the zenith (horizontal distance 0)
        the azimuth is taken from the velocity and its rate is 0.
    """
    e = px * east[0] + py * east[1] + pz * east[2]
    n = px * north[0] + py * north[1] + pz * north[2]
    z = px * up[0] + py * up[1] + pz * up[2]
    ed = vx * east[0] + vy * east[1] + vz * east[2]
    nd = vx * north[0] + vy * north[1] + vz * north[2]
    zd = vx * up[0] + vy * up[1] + vz * up[2]
    rng = math.sqrt(e * e + n * n + z * z)
    hor2 = e * e + n * n
    hor = math.sqrt(hor2)
    el = math.atan2(z, hor)
    rng_rate = (e * ed + n * nd + z * zd) / rng
    if hor > 1e-12 * rng:
        az = math.atan2(e, n)
        az_rate = (ed * n - nd * e) / hor2
        el_rate = (zd - rng_rate * z / rng) / (hor / rng) / rng
    else:  # overhead: the azimuth of the motion (Vallado's convention), no defined rate
        az = math.atan2(ed, nd)
        az_rate = 0.0
        el_rate = 0.0
    if az < 0.0:
        az += 2.0 * math.pi
    return rng, az, el, rng_rate, az_rate, el_rate


@kernel
def razel_many(rho, rho_dot, enu, site_index, out):
    """:func:`razel` for M vectors; ``out[k]`` = (range, az, el, range rate, az rate, el rate).

    Parameters
    ----------
    rho, rho_dot : ndarray (M, 3)
        Earth-fixed site-to-target vectors (km) and their rates (km/s).
    enu : ndarray (S, 3, 3)
        Rows east, north, up of each site.
    site_index : ndarray (M,) int64
        The site of each vector.
    out : ndarray (M, 6)
    """
    for k in range(rho.shape[0]):
        m = enu[site_index[k]]
        res = razel(rho[k, 0], rho[k, 1], rho[k, 2], rho_dot[k, 0], rho_dot[k, 1],
                    rho_dot[k, 2], m[0], m[1], m[2])
        for c in range(6):
            out[k, c] = res[c]


@kernel
def elevation_rate_many(r, v, sites, ups, site_index, sin_min, out):
    """``f = sin(el) - sin_min`` and ``df/dt`` for M exact Earth-fixed states.

    ``f' = (rho_dot . up) / |rho| - (rho . up)(rho . rho_dot) / |rho|^3``.

    Parameters
    ----------
    r, v : ndarray (M, 3)
        Earth-fixed satellite states (km, km/s).
    sites, ups : ndarray (S, 3)
        Site positions (km) and their up unit vectors.
    site_index : ndarray (M,) int64
    sin_min : float
    out : ndarray (M, 2)
    """
    for k in range(r.shape[0]):
        s = site_index[k]
        px = r[k, 0] - sites[s, 0]
        py = r[k, 1] - sites[s, 1]
        pz = r[k, 2] - sites[s, 2]
        rho = math.sqrt(px * px + py * py + pz * pz)
        z = px * ups[s, 0] + py * ups[s, 1] + pz * ups[s, 2]
        zd = v[k, 0] * ups[s, 0] + v[k, 1] * ups[s, 1] + v[k, 2] * ups[s, 2]
        rr = px * v[k, 0] + py * v[k, 1] + pz * v[k, 2]
        out[k, 0] = z / rho - sin_min
        out[k, 1] = zd / rho - z * rr / (rho * rho * rho)


@inline_kernel
def _f_at(r, v, i, t, h, nodes, sx, sy, sz, ux, uy, uz, sin_min):
    """``sin(el) - sin_min`` on the Hermite polynomial of satellite ``i`` at grid time ``t``."""
    j = int(t / h)
    if j > nodes - 2:
        j = nodes - 2
    if j < 0:
        j = 0
    h00, h10, h01, h11 = hermite_basis(t / h - j)
    h10 *= h
    h11 *= h
    px = h00 * r[i, j, 0] + h10 * v[i, j, 0] + h01 * r[i, j + 1, 0] + h11 * v[i, j + 1, 0] - sx
    py = h00 * r[i, j, 1] + h10 * v[i, j, 1] + h01 * r[i, j + 1, 1] + h11 * v[i, j + 1, 1] - sy
    pz = h00 * r[i, j, 2] + h10 * v[i, j, 2] + h01 * r[i, j + 1, 2] + h11 * v[i, j + 1, 2] - sz
    return (px * ux + py * uy + pz * uz) / math.sqrt(px * px + py * py + pz * pz) - sin_min


@inline_kernel
def _crossing(r, v, i, h, nodes, sx, sy, sz, ux, uy, uz, sin_min, lo, hi, flo, fhi):
    """The one root of ``f`` in ``[lo, hi]`` (``f`` monotonic there, signs differ): Illinois
    regula falsi to 1e-2 s."""
    side = 0
    for _ in range(200):
        x = (lo * fhi - hi * flo) / (fhi - flo)
        if not (lo < x < hi):
            x = 0.5 * (lo + hi)
        fx = _f_at(r, v, i, x, h, nodes, sx, sy, sz, ux, uy, uz, sin_min)
        if (fx <= 0.0) == (flo <= 0.0):
            lo = x
            flo = fx
            if side == -1:
                fhi *= 0.5
            side = -1
        else:
            hi = x
            fhi = fx
            if side == 1:
                flo *= 0.5
            side = 1
        if hi - lo < 1e-2:
            break
    return 0.5 * (lo + hi)


@kernel
def _pair_events(r, v, i, h, t_start, t_end, t_reach, m, site, up, sin_min, near, out_t, out_k,
                 out_f, cap):
    """Stream the samples of one pair; write its events; return how many there are.

    One sample either side of the window (where the nodes reach, ``[0, t_reach]``) lets a
    maximum in its first or last sampling interval be bracketed; extrema outside the window
    are not reported (the caller's window-edge values stand for them).
    """
    nodes = r.shape[1]
    sx, sy, sz = site[0], site[1], site[2]
    ux, uy, uz = up[0], up[1], up[2]
    dt = h / m
    nsamp = int(math.ceil((t_end - t_start) / dt - 1e-9)) + 1
    count = 0
    # last breakpoint (window start, or the latest refined extremum)
    bt = t_start
    bf = _f_at(r, v, i, t_start, h, nodes, sx, sy, sz, ux, uy, uz, sin_min)
    t_a = t_start
    f_a = bf
    t_b = t_start
    f_b = bf
    t_c = t_start
    f_c = bf
    et = t_start
    ef = bf
    # a sample before the window, when the nodes reach it with finite states
    k_first = 2
    if t_start - dt >= 0.0:
        t_a = t_start - dt
        f_a = _f_at(r, v, i, t_a, h, nodes, sx, sy, sz, ux, uy, uz, sin_min)
        k_first = 1
    has_post = t_end + dt <= t_reach
    for k in range(1, nsamp + 1):
        last = k == nsamp
        if not last:
            t_c = min(t_start + k * dt, t_end)
            f_c = _f_at(r, v, i, t_c, h, nodes, sx, sy, sz, ux, uy, uz, sin_min)
        elif has_post:  # a sample after the window
            t_c = t_end + dt
            f_c = _f_at(r, v, i, t_c, h, nodes, sx, sy, sz, ux, uy, uz, sin_min)
        is_ext = False
        ext_max = False
        if k >= k_first and (not last or has_post):
            if f_b > f_a and f_b >= f_c:
                is_ext = True
                ext_max = True
            elif f_b < f_a and f_b <= f_c:
                is_ext = True
        if is_ext:
            # golden-section search for the extremum in [t_a, t_c]
            lo = t_a
            hi = t_c
            sgn = 1.0 if ext_max else -1.0
            x1 = lo + _GOLDEN * (hi - lo)
            x2 = hi - _GOLDEN * (hi - lo)
            g1 = sgn * _f_at(r, v, i, x1, h, nodes, sx, sy, sz, ux, uy, uz, sin_min)
            g2 = sgn * _f_at(r, v, i, x2, h, nodes, sx, sy, sz, ux, uy, uz, sin_min)
            while hi - lo > 0.5:
                if g1 > g2:
                    hi = x2
                    x2 = x1
                    g2 = g1
                    x1 = lo + _GOLDEN * (hi - lo)
                    g1 = sgn * _f_at(r, v, i, x1, h, nodes, sx, sy, sz, ux, uy, uz, sin_min)
                else:
                    lo = x1
                    x1 = x2
                    g1 = g2
                    x2 = hi - _GOLDEN * (hi - lo)
                    g2 = sgn * _f_at(r, v, i, x2, h, nodes, sx, sy, sz, ux, uy, uz, sin_min)
            et = 0.5 * (lo + hi)
            if et <= t_start or et >= t_end:
                is_ext = False  # outside the window: its edge's value stands for it
            else:
                ef = _f_at(r, v, i, et, h, nodes, sx, sy, sz, ux, uy, uz, sin_min)
        for stage in range(2):  # the extremum (if any), then the window's end (last sample)
            if stage == 0 and not is_ext:
                continue
            if stage == 1:
                if not last:
                    break
                et = t_end
                ef = _f_at(r, v, i, t_end, h, nodes, sx, sy, sz, ux, uy, uz, sin_min)
            # one crossing between the breakpoints when the sign differs (f is monotonic there)
            if (bf <= 0.0) != (ef <= 0.0):
                if count < cap:
                    out_t[count] = _crossing(r, v, i, h, nodes, sx, sy, sz, ux, uy, uz, sin_min,
                                             bt, et, bf, ef)
                    out_k[count] = RISE if ef > bf else SET
                    out_f[count] = 0.0
                count += 1
            if stage == 0 and ext_max and ef > -near:
                if count < cap:
                    out_t[count] = et
                    out_k[count] = CULMINATION if ef > 0.0 else NEAR_MAXIMUM
                    out_f[count] = ef
                count += 1
            bt = et
            bf = ef
        t_a = t_b
        f_a = f_b
        t_b = t_c
        f_b = f_c
    return count


@parallel_kernel
def scan_passes(r, v, h, t_start, t_end, t_reach, m, sites, ups, sin_min, near, out_t, out_k,
                out_f, count, status, f_ends):
    """Rise, culmination and set of every (satellite, site) pair on Hermite-joined nodes.

    Parameters
    ----------
    r, v : ndarray (N, T, 3)
        Earth-fixed states (km, km/s) at grid times ``0, h, ..., (T - 1) h`` s.
    h : float
        Node spacing, s.
    t_start, t_end : ndarray (N,)
        Each satellite's search window on the grid's time axis, s
        (``0 <= t_start < t_end <= (T - 1) h``; the caller cuts it where the node states stop
        being finite). A satellite with ``t_end <= t_start`` is skipped.
    t_reach : ndarray (N,)
        Each satellite's last grid time with finite node states (``>= t_end``): one sample
        before ``t_start`` (when ``>= 0``) and one after ``t_end`` (when ``<= t_reach``) bracket
        a maximum in the window's first or last sampling interval.
    m : int
        Samples per node interval (>= 2).
    sites, ups : ndarray (S, 3)
        Site positions (km) and up unit vectors, Earth-fixed.
    sin_min : float
        Sine of the minimum elevation.
    near : ndarray (N,)
        Per satellite: maxima with ``-near < f <= 0`` on the polynomial are reported as
        :data:`NEAR_MAXIMUM`: the caller checks them on the exact trajectory (grazing passes
        the polynomial's error could hide).
    out_t, out_k, out_f : ndarray (N * S, cap)
        Event times (grid s), kinds (:data:`RISE`, :data:`CULMINATION`, :data:`SET`,
        :data:`NEAR_MAXIMUM`) and, for maxima, ``f`` there. Pair ``p = i * S + s``.
    count : ndarray (N * S,) int64
        Events found per pair (may exceed ``cap``: then status is :data:`PAIR_OVERFLOW`).
    status : ndarray (N * S,) int64
        :data:`PAIR_OK`, :data:`PAIR_NON_FINITE` (empty window: pair skipped) or
        :data:`PAIR_OVERFLOW`.
    f_ends : ndarray (N * S, 2)
        ``sin(el) - sin_min`` at ``t_start`` and ``t_end`` (NaN for skipped pairs).
    """
    n = r.shape[0]
    ns = sites.shape[0]
    cap = out_t.shape[1]
    for p in prange(n * ns):
        i = p // ns
        s = p - i * ns
        ts = t_start[i]
        te = t_end[i]
        if not te > ts:
            count[p] = 0
            status[p] = PAIR_NON_FINITE
            f_ends[p, 0] = np.nan
            f_ends[p, 1] = np.nan
            continue
        st = sites[s]
        u = ups[s]
        f_ends[p, 0] = _f_at(r, v, i, ts, h, r.shape[1], st[0], st[1], st[2], u[0], u[1],
                             u[2], sin_min)
        f_ends[p, 1] = _f_at(r, v, i, te, h, r.shape[1], st[0], st[1], st[2], u[0], u[1],
                             u[2], sin_min)
        c = _pair_events(r, v, i, h, ts, te, t_reach[i], m, st, u, sin_min, near[i], out_t[p],
                         out_k[p], out_f[p], cap)
        count[p] = c
        status[p] = PAIR_OVERFLOW if c > cap else PAIR_OK


@kernel
def teme_to_itrs_anchored(r, v, t_s, t_first, anchor_s, mats, omega, r_out, v_out):
    """TEME -> ITRS states from 6 x 6 anchor maps and the sidereal rotation in between.

    ``y = (R3(theta) r, R3(theta) v)`` with ``theta = omega (t - t_k)`` and ``t_k`` the nearest
    anchor; the result is ``mats[k] @ y`` (see :mod:`visviva.ground.earthfixed`).

    Parameters
    ----------
    r, v : ndarray (M, 3)
        TEME states, km and km/s.
    t_s : ndarray (M,)
        Times, s on the anchors' axis.
    t_first, anchor_s : float
        Time of the first anchor and the spacing, s.
    mats : ndarray (A, 6, 6)
        The anchors' TEME -> ITRS state maps.
    omega : float
        Rate of the sidereal angle, rad/s.
    r_out, v_out : ndarray (M, 3)
    """
    na = mats.shape[0]
    for k in range(r.shape[0]):
        a = int(math.floor((t_s[k] - t_first) / anchor_s + 0.5))
        if a < 0:
            a = 0
        if a > na - 1:
            a = na - 1
        th = omega * (t_s[k] - (t_first + a * anchor_s))
        c = math.cos(th)
        s = math.sin(th)
        y0 = c * r[k, 0] + s * r[k, 1]
        y1 = -s * r[k, 0] + c * r[k, 1]
        y2 = r[k, 2]
        y3 = c * v[k, 0] + s * v[k, 1]
        y4 = -s * v[k, 0] + c * v[k, 1]
        y5 = v[k, 2]
        m = mats[a]
        for i in range(3):
            r_out[k, i] = (m[i, 0] * y0 + m[i, 1] * y1 + m[i, 2] * y2 + m[i, 3] * y3
                           + m[i, 4] * y4 + m[i, 5] * y5)
            v_out[k, i] = (m[3 + i, 0] * y0 + m[3 + i, 1] * y1 + m[3 + i, 2] * y2
                           + m[3 + i, 3] * y3 + m[3 + i, 4] * y4 + m[3 + i, 5] * y5)


def empty_outputs(pairs: int, cap: int):
    """Output arrays for :func:`scan_passes`."""
    return (np.empty((pairs, cap)), np.empty((pairs, cap), dtype=np.int8),
            np.empty((pairs, cap)), np.empty(pairs, dtype=np.int64),
            np.empty(pairs, dtype=np.int64), np.empty((pairs, 2)))
