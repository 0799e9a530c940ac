"""The orbit-path filter of conjunction screening (Hoots, Crawford & Roehrich 1984).

Two points closer than ``D`` lie within ``D`` of each other's orbit plane. A point of orbit 1
at angle ``alpha`` from the mutual node line (the intersection of the two planes) is
``r |sin alpha| sin I`` from plane 2 (``I`` the mutual inclination), so a close approach can only
happen within ``|sin alpha| <= D / (q sin I)`` of one of the two mutual nodes, on both orbits,
near the same node. There the radii must come within ``D``: if the radius ranges of the two
orbits over those arcs are more than ``D`` apart at both nodes, the orbit paths never come within
``D`` and the pair is dropped.

The planes and the perigees drift (J2: the node and the argument of perigee move secularly), so
the window is cut into chunks short enough that each object moves by at most a few km through
the drift; the test runs at the middle of each chunk with ``D`` widened by that displacement.
A pair is dropped only when every chunk drops it. Planes within 30 deg of the coplanar case
(the arcs would be wide) always pass.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import inline_kernel, parallel_kernel, prange

__all__ = ["orbit_paths_close", "count_filter_survivors", "path_schedule", "PATH_ELEMENTS"]

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
def _plane(inc, node):
    # unit normal and the node vector of a plane
    si = math.sin(inc)
    hx = si * math.sin(node)
    hy = -si * math.cos(node)
    hz = math.cos(inc)
    return hx, hy, hz, math.cos(node), math.sin(node)


@inline_kernel
def _node_angle(nx, ny, nz, hx, hy, hz, px, py):
    # argument of latitude of the direction n in the plane (normal h, node vector (px, py, 0))
    qx = hy * 0.0 - hz * py
    qy = hz * px - hx * 0.0
    qz = hx * py - hy * px
    return math.atan2(nx * qx + ny * qy + nz * qz, nx * px + ny * py)


@inline_kernel
def orbit_paths_close(el1, i, el2, j, t_mid, dist, drift_chunk):
    """Whether the orbit paths of object ``i`` of ``el1`` and ``j`` of ``el2`` may come within
    ``dist`` (km).

    ``el1``, ``el2``: ``(N, 7)`` elements (:data:`PATH_ELEMENTS`), or ``(0, 7)`` when there are
    none (ephemerides: the filter is off); ``t_mid``: chunk middles (s from the element
    reference); ``drift_chunk``: chunk length (s). True if any chunk passes.
    """
    if el1.shape[0] == 0 or el2.shape[0] == 0:
        return True
    p1, e1, i1 = el1[i, 0], el1[i, 1], el1[i, 2]
    p2, e2, i2 = el2[j, 0], el2[j, 1], el2[j, 2]
    q1, q2 = p1 / (1.0 + e1), p2 / (1.0 + e2)
    big1, big2 = p1 / (1.0 - e1), p2 / (1.0 - e2)
    # displacement through the drift over half a chunk (the radius at a fixed direction moves
    # by at most a e (1 + e) / (1 - e) per radian of perigee motion, the plane by r per radian)
    m1 = big1 * (abs(el1[i, 5]) + abs(el1[i, 6])) * 0.5 * drift_chunk
    m2 = big2 * (abs(el2[j, 5]) + abs(el2[j, 6])) * 0.5 * drift_chunk
    d = dist + m1 + m2
    for c in range(t_mid.shape[0]):
        t = t_mid[c]
        n1 = el1[i, 3] + el1[i, 5] * t
        w1 = el1[i, 4] + el1[i, 6] * t
        n2 = el2[j, 3] + el2[j, 5] * t
        w2 = el2[j, 4] + el2[j, 6] * t
        h1x, h1y, h1z, p1x, p1y = _plane(i1, n1)
        h2x, h2y, h2z, p2x, p2y = _plane(i2, n2)
        nx = h1y * h2z - h1z * h2y
        ny = h1z * h2x - h1x * h2z
        nz = h1x * h2y - h1y * h2x
        sin_mut = math.sqrt(nx * nx + ny * ny + nz * nz)
        s1 = d / (q1 * max(sin_mut, 1e-300))
        s2 = d / (q2 * max(sin_mut, 1e-300))
        if s1 >= 0.5 or s2 >= 0.5:
            return True  # near-coplanar: the arcs are wide, no pruning
        nx /= sin_mut
        ny /= sin_mut
        nz /= sin_mut
        a1 = math.asin(s1)
        a2 = math.asin(s2)
        u1 = _node_angle(nx, ny, nz, h1x, h1y, h1z, p1x, p1y)
        u2 = _node_angle(nx, ny, nz, h2x, h2y, h2z, p2x, p2y)
        for side in range(2):
            nu1 = u1 + side * math.pi - w1
            nu2 = u2 + side * math.pi - w2
            r1lo, r1hi = _radius_range(p1, e1, nu1 - a1, nu1 + a1)
            r2lo, r2hi = _radius_range(p2, e2, nu2 - a2, nu2 + a2)
            if r1lo - d <= r2hi and r2lo - d <= r1hi:
                return True
    return False


@parallel_kernel
def count_filter_survivors(q1, Q1, q2, Q2, el1, el2, self_mode, reach, t_mid, drift_chunk,
                           out):
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
            if orbit_paths_close(el1, i, el2, j, t_mid, reach, drift_chunk):
                b += 1
        out[i, 0] = a
        out[i, 1] = b


def path_schedule(el_list, span_s, drift_km=10.0):
    """Chunk middles (s) and chunk length (s) for a window of ``span_s`` seconds: each object's
    drift displacement over a chunk stays below ``drift_km`` (see :func:`orbit_paths_close`)."""
    rate = 0.0
    for el in el_list:
        if el.shape[0]:
            big = el[:, 0] / (1.0 - el[:, 1])
            rate = max(rate, float(np.max(big * (np.abs(el[:, 5]) + np.abs(el[:, 6])))))
    n = 1 if rate == 0.0 else max(1, int(math.ceil(span_s * rate / (2.0 * drift_km))))
    length = span_s / n
    return (np.arange(n) + 0.5) * length, float(length)
