"""The orbit-path filter of conjunction screening (Hoots, Crawford & Roehrich 1984).

Two points closer than ``D`` lie within ``D`` of each other's orbit plane. A point of orbit 1
at angle ``alpha`` from the mutual node line (the intersection of the two planes) is
``r |sin alpha| sin I`` from plane 2 (``I`` the mutual inclination), so a close approach can only
happen within ``|sin alpha| <= D / (q sin I)`` of one of the two mutual nodes, on both orbits,
near the same node. There the radii must come within ``D``: if the radius ranges of the two
orbits over those arcs are more than ``D`` apart at both nodes, the orbit paths never come within
``D`` and the pair is dropped.

The planes and the perigees drift (J2: the node and the argument of perigee move secularly), so
the window is cut into chunks short enough that each object moves by at most 20 km through
the drift; the test runs at the middle of each chunk with ``D`` widened by that displacement.
A pair is dropped only when every chunk drops it. Planes within 30 deg of the coplanar case
(the arcs would be wide) always pass.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import inline_kernel, parallel_kernel, prange

__all__ = ["orbit_paths_close", "count_filter_survivors", "path_geometry", "path_rate",
           "path_schedule", "sampled_path_bounds", "PATH_ELEMENTS"]

#: columns of the element array: semi-latus rectum (km), eccentricity, inclination, node and
#: argument of perigee at the middle of the first chunk (rad), their secular rates (rad/s)
PATH_ELEMENTS = ("p", "e", "i", "node", "argp", "node_rate", "argp_rate")

_TWO_PI = 2.0 * math.pi


@inline_kernel
def _radius_range(p, e, nu_lo, nu_hi):
    """Smallest and largest radius of a conic over true anomalies [nu_lo, nu_hi]."""
    r_lo = p / (1.0 + e * math.cos(nu_lo))
    r_hi = p / (1.0 + e * math.cos(nu_hi))
    rmin = min(r_lo, r_hi)
    rmax = max(r_lo, r_hi)
    # perigee (nu = 0 mod 2 pi) or apogee (nu = pi mod 2 pi) inside the arc
    k0 = math.ceil(nu_lo / _TWO_PI)
    if k0 * _TWO_PI <= nu_hi:
        rmin = p / (1.0 + e)
    k1 = math.ceil((nu_lo - math.pi) / _TWO_PI)
    if k1 * _TWO_PI + math.pi <= nu_hi:
        rmax = p / (1.0 - e)
    return rmin, rmax


@inline_kernel
def _node_angle(nx, ny, nz, hx, hy, hz, px, py):
    # argument of latitude of the direction n: atan2(n . Q, n . P) with the node vector
    # P = (px, py, 0) and Q = h x P (P given, so that equatorial orbits keep their reference)
    qx = -hz * py
    qy = hz * px
    qz = hx * py - hy * px
    return math.atan2(nx * qx + ny * qy + nz * qz, nx * px + ny * py)


@inline_kernel
def orbit_paths_close(el1, g1, i, el2, g2, j, dist):
    """Whether the orbit paths of object ``i`` (of ``el1``) and ``j`` (of ``el2``) may come
    within ``dist`` (km) in some drift chunk.

    ``el1``, ``el2``: ``(N, 8)`` per-object constants from :func:`path_geometry` (``(0, 8)``
    when there are none, e.g. ephemerides: the filter is off); ``g1``, ``g2``: ``(N, C, 6)``
    plane normal (3), node vector (2) and argument of perigee of each object at each chunk
    middle.
    """
    if el1.shape[0] == 0 or el2.shape[0] == 0:
        return True
    p1, e1, q1, m1 = el1[i, 0], el1[i, 1], el1[i, 2], el1[i, 4]
    p2, e2, q2, m2 = el2[j, 0], el2[j, 1], el2[j, 2], el2[j, 4]
    d = dist + m1 + m2
    if max(el1[i, 3], el2[j, 3]) - min(q1, q2) <= d:
        return True  # every radius of one orbit is within d of every radius of the other
    for c in range(g1.shape[1]):
        h1x, h1y, h1z, w1 = g1[i, c, 0], g1[i, c, 1], g1[i, c, 2], g1[i, c, 5]
        h2x, h2y, h2z, w2 = g2[j, c, 0], g2[j, c, 1], g2[j, c, 2], g2[j, c, 5]
        nx = h1y * h2z - h1z * h2y
        ny = h1z * h2x - h1x * h2z
        nz = h1x * h2y - h1y * h2x
        sin_mut = math.sqrt(nx * nx + ny * ny + nz * nz)
        s1 = d / (q1 * max(sin_mut, 1e-300))
        s2 = d / (q2 * max(sin_mut, 1e-300))
        if s1 >= 0.5 or s2 >= 0.5:
            return True  # near-coplanar: the arcs are wide, no pruning
        a1 = math.asin(s1)
        a2 = math.asin(s2)
        u1 = _node_angle(nx, ny, nz, h1x, h1y, h1z, g1[i, c, 3], g1[i, c, 4])
        u2 = _node_angle(nx, ny, nz, h2x, h2y, h2z, g2[j, c, 3], g2[j, c, 4])
        for side in range(2):
            nu1 = u1 + side * math.pi - w1
            nu2 = u2 + side * math.pi - w2
            r1lo, r1hi = _radius_range(p1, e1, nu1 - a1, nu1 + a1)
            r2lo, r2hi = _radius_range(p2, e2, nu2 - a2, nu2 + a2)
            if r1lo - d <= r2hi and r2lo - d <= r1hi:
                return True
    return False


@parallel_kernel
def count_filter_survivors(q1, Q1, q2, Q2, el1, g1, el2, g2, self_mode, reach, out):
    """Pairs passing the apogee/perigee filter (``out[i, 0]``) and also the orbit-path filter
    (``out[i, 1]``), per primary ``i``: the pruning ratio of the chain."""
    n1 = q1.shape[0]
    n2 = q2.shape[0]
    for i in prange(n1):
        a = 0
        b = 0
        j0 = i + 1 if self_mode else 0
        for j in range(j0, n2):
            if max(q1[i], q2[j]) - min(Q1[i], Q2[j]) > reach:
                continue
            a += 1
            if orbit_paths_close(el1, g1, i, el2, g2, j, reach):
                b += 1
        out[i, 0] = a
        out[i, 1] = b


@parallel_kernel
def sampled_path_bounds(elements, dt, r, out):
    """Largest distance (km) of each object's sampled positions from its drifting mean path,
    and its smallest and largest sampled radius (km).

    Parameters
    ----------
    elements : ndarray, shape (N, 7)
        :data:`PATH_ELEMENTS` at ``t = 0`` (km, rad, rad/s).
    dt : float
        Sampling step, s: sample ``k`` is at ``t = k dt``.
    r : ndarray, shape (N, T, 3)
        Sampled positions (km), in the frame of the elements; samples with NaN are skipped.
    out : ndarray, shape (N, 3)
        Written: the largest residual, the smallest and the largest radius of each object
        (0, inf and -inf when it has no finite sample).

    Notes
    -----
    At each sample the node and the argument of perigee drift to ``t``; the position's
    argument of latitude ``u`` in the mean plane gives the true anomaly ``nu = u - argp``, and
    the residual is the distance to the point of the mean conic at that ``u``:
    ``sqrt((rho - p / (1 + e cos nu))^2 + z^2)`` with ``rho`` and ``z`` the in-plane and
    out-of-plane parts of the position. It holds the short-period terms, and what the secular
    drift leaves out: the decay of a dragged orbit (SGP4 lowers ``a`` with B*), the lunisolar
    changes of a deep-space one.
    """
    n = r.shape[0]
    nt = r.shape[1]
    for i in prange(n):
        p = elements[i, 0]
        e = elements[i, 1]
        si = math.sin(elements[i, 2])
        ci = math.cos(elements[i, 2])
        worst = 0.0
        rmin = math.inf
        rmax = -math.inf
        for k in range(nt):
            x = r[i, k, 0]
            y = r[i, k, 1]
            z = r[i, k, 2]
            if not (x == x and y == y and z == z):
                continue  # a failed propagation
            rad = math.sqrt(x * x + y * y + z * z)
            if rad < rmin:
                rmin = rad
            if rad > rmax:
                rmax = rad
            t = k * dt
            node = elements[i, 3] + elements[i, 5] * t
            cn = math.cos(node)
            sn = math.sin(node)
            # node vector P = (cn, sn, 0), Q = h x P = (-ci sn, ci cn, si), normal h
            xp = x * cn + y * sn
            yq = -x * ci * sn + y * ci * cn + z * si
            zh = x * si * sn - y * si * cn + z * ci
            nu = math.atan2(yq, xp) - (elements[i, 4] + elements[i, 6] * t)
            dr = math.sqrt(xp * xp + yq * yq) - p / (1.0 + e * math.cos(nu))
            res = math.sqrt(dr * dr + zh * zh)
            if res > worst:
                worst = res
        out[i, 0] = worst
        out[i, 1] = rmin
        out[i, 2] = rmax


def path_geometry(elements, span_s, rate_km_s, drift_km=20.0):
    """Per-object constants and per-chunk plane geometry of the orbit-path filter.

    Parameters
    ----------
    elements : ndarray, shape (N, 7)
        :data:`PATH_ELEMENTS` at the window start (km, rad, rad/s); ``(0, 7)``: none.
    span_s : float
        Window length, s.
    rate_km_s : float
        The drift speed setting the chunks (:func:`path_rate` of primaries and secondaries
        together, so that their chunks coincide).
    drift_km : float
        Largest displacement of any object through the drift over half a chunk, km.

    Returns
    -------
    el : ndarray, shape (N, 8)
        ``p, e, q, Q``, the drift displacement over half a chunk (km), three spare columns.
    geometry : ndarray, shape (N, C, 6)
        Unit normal of the orbit plane, node vector (x, y) and argument of perigee at each
        chunk middle.
    """
    n = elements.shape[0]
    if n == 0:
        return np.empty((0, 8)), np.empty((0, 1, 6))
    t_mid, length = path_schedule(rate_km_s, span_s, drift_km)
    p, e, inc = elements[:, 0], elements[:, 1], elements[:, 2]
    big = p / (1.0 - e)
    el = np.zeros((n, 8))
    el[:, 0], el[:, 1], el[:, 2], el[:, 3] = p, e, p / (1.0 + e), big
    el[:, 4] = big * (np.abs(elements[:, 5]) + np.abs(elements[:, 6])) * 0.5 * length
    node = elements[:, 3:4] + elements[:, 5:6] * t_mid[None, :]
    geometry = np.empty((n, t_mid.size, 6))
    si = np.sin(inc)[:, None]
    geometry[..., 0] = si * np.sin(node)
    geometry[..., 1] = -si * np.cos(node)
    geometry[..., 2] = np.cos(inc)[:, None]
    geometry[..., 3] = np.cos(node)
    geometry[..., 4] = np.sin(node)
    geometry[..., 5] = elements[:, 4:5] + elements[:, 6:7] * t_mid[None, :]
    return el, geometry


def path_rate(*element_sets):
    """Largest drift speed (km/s) over sets of :data:`PATH_ELEMENTS` (0 for none)."""
    rate = 0.0
    for el in element_sets:
        if el.shape[0]:
            big = el[:, 0] / (1.0 - el[:, 1])
            rate = max(rate, float(np.max(big * (np.abs(el[:, 5]) + np.abs(el[:, 6])))))
    return rate


def path_schedule(rate_km_s, span_s, drift_km=20.0):
    """Chunk middles (s) and length (s) over ``span_s`` with ``0.5 rate length <= drift_km``."""
    n = 1 if rate_km_s == 0.0 else max(1, int(math.ceil(span_s * rate_km_s / (2.0 * drift_km))))
    length = span_s / n
    return (np.arange(n) + 0.5) * length, float(length)
