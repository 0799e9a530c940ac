"""Conjunction screening kernel: the filter chain on sampled ephemerides.

For every pair of objects (one ``prange`` loop over the rows of primaries), the kernel applies

1. the apogee/perigee filter (Hoots, Crawford & Roehrich 1984): the radial shells
   ``[q, Q]`` of the two orbits, widened by ``limit + margin``, must overlap;
   then their orbit-path filter: near the mutual nodes of the two (drifting) orbit planes the
   radii must come within ``limit + margin`` (:mod:`visviva.core.orbit_path`);
2. the time filter on the sampled relative motion: an interval ``[t_k, t_k+1]`` holds a local
   minimum of the distance exactly when the range rate ``rho . rho_dot`` changes sign from
   negative to positive (positions and velocities are sampled, so no minimum between samples is
   missed); a lower bound of the distance over the interval rejects most of them;
   While a pair is far apart, the samples it cannot use are skipped: from a distance ``d`` it
   cannot come within ``limit`` for ``(d - limit) / speed_bound`` seconds;
3. a cubic Hermite model of the relative position over the surviving intervals, whose minimum
   (bisection on ``rho . rho_dot``) must be below ``limit + margin``.

The minima at the two ends of the window (distance still decreasing at the end, or increasing
from the start) are reported with ``k = -1`` (start) and ``k = T - 1`` (end). Samples containing
NaN (an object that failed to propagate) are skipped.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import inline_kernel, parallel_kernel, prange
from .hermite import hermite_basis, hermite_basis_rate
from .orbit_path import orbit_paths_close

__all__ = ["screen_rows"]


@inline_kernel
def _hermite_g(s, p0, p1, m0, m1, h):
    # relative position and velocity on the cubic Hermite segment at s in [0, 1]
    h00, h10, h01, h11 = hermite_basis(s)
    d00, d10, d01, d11 = hermite_basis_rate(s)
    d00 /= h
    d01 /= h
    g = 0.0
    d2 = 0.0
    for c in range(3):
        x = h00 * p0[c] + h10 * h * m0[c] + h01 * p1[c] + h11 * h * m1[c]
        xd = d00 * p0[c] + d10 * m0[c] + d01 * p1[c] + d11 * m1[c]
        g += x * xd
        d2 += x * x
    return g, d2


@inline_kernel
def _pair(a, i, j, r1, v1, r2, v2, dt, reach, speed_bound, cnt, out_j, out_k, out_d, p0, p1,
          m0, m1):
    """Scan the sampled relative motion of the pair (i, j); returns the updated count.

    While the pair is far apart, whole stretches of samples are skipped: from a distance ``d``
    the pair cannot come within ``reach`` during ``(d - reach) / speed_bound`` seconds.
    """
    nt = r1.shape[1]
    cap = out_j.shape[1]
    reach2 = reach * reach
    step_reach = speed_bound * dt
    g_prev = 0.0
    ok_prev = False
    k = 0
    while k < nt:
        g = 0.0
        d2 = 0.0
        u2 = 0.0
        for c in range(3):
            x = r2[j, k, c] - r1[i, k, c]
            u = v2[j, k, c] - v1[i, k, c]
            g += x * u
            d2 += x * x
            u2 += u * u
        ok = g == g  # not NaN (an object that failed to propagate)
        if ok and k == 0 and g >= 0.0 and d2 < reach2:
            if cnt < cap:
                out_j[a, cnt] = j
                out_k[a, cnt] = -1
                out_d[a, cnt] = math.sqrt(d2)
            cnt += 1
        if ok and k == nt - 1 and g < 0.0 and d2 < reach2:
            if cnt < cap:
                out_j[a, cnt] = j
                out_k[a, cnt] = nt - 1
                out_d[a, cnt] = math.sqrt(d2)
            cnt += 1
        if ok and ok_prev and g_prev < 0.0 and g >= 0.0:
            # a local minimum of the distance inside [t_{k-1}, t_k]
            da2 = 0.0
            ua2 = 0.0
            for c in range(3):
                p0[c] = r2[j, k - 1, c] - r1[i, k - 1, c]
                p1[c] = r2[j, k, c] - r1[i, k, c]
                m0[c] = v2[j, k - 1, c] - v1[i, k - 1, c]
                m1[c] = v2[j, k, c] - v1[i, k, c]
                da2 += p0[c] * p0[c]
                ua2 += m0[c] * m0[c]
            dmin = min(math.sqrt(da2), math.sqrt(d2))
            umax = max(math.sqrt(ua2), math.sqrt(u2))
            if dmin - 0.55 * dt * umax <= reach:
                lo = 0.0
                hi = 1.0
                for _ in range(40):
                    mid = 0.5 * (lo + hi)
                    gm, _d = _hermite_g(mid, p0, p1, m0, m1, dt)
                    if gm < 0.0:
                        lo = mid
                    else:
                        hi = mid
                _g, dm2 = _hermite_g(0.5 * (lo + hi), p0, p1, m0, m1, dt)
                if dm2 < reach2:
                    if cnt < cap:
                        out_j[a, cnt] = j
                        out_k[a, cnt] = k - 1
                        out_d[a, cnt] = math.sqrt(dm2)
                    cnt += 1
        if ok and d2 > (reach + 3.0 * step_reach) ** 2:
            skip = int((math.sqrt(d2) - reach) / step_reach)
            k += skip
            ok_prev = False
            continue
        g_prev = g
        ok_prev = ok
        k += 1
    return cnt


#: primaries screened together against each secondary, so that the secondary's samples are read
#: from memory once per tile (the loop is memory-bound otherwise)
TILE = 16


@parallel_kernel
def screen_rows(r1, v1, q1, Q1, rows, r2, v2, q2, Q2, self_mode, dt, limit, margin,
                fine_margin, speed_bound, out_j, out_k, out_d, counts, el1, g1, el2, g2):
    """Candidate close approaches of the primaries ``rows`` against every secondary.

    Parameters
    ----------
    r1, v1 : ndarray, shape (N1, T, 3)
        Sampled positions and velocities of the primaries (km, km/s), times ``t_0 + k dt``.
    q1, Q1 : ndarray, shape (N1,)
        Perigee and apogee radii of the primaries (km).
    rows : ndarray of int64, shape (m,)
        The primaries handled by this call.
    r2, v2, q2, Q2
        The same for the N2 secondaries.
    self_mode : bool
        Secondaries are the primaries: only pairs ``j > i``.
    dt : float
        Sampling step (s).
    limit : float
        Screening distance (km).
    margin : float
        Extra distance on the apogee/perigee filter (km): SGP4's mean-element perigee and apogee
        differ from its osculating radii.
    fine_margin : float
        Extra distance on the sampled-motion filters (km): the error of the Hermite model.
    speed_bound : float
        An upper bound of every relative speed (km/s), e.g. the sum of the largest speeds.
    out_j, out_k : ndarray of int64, shape (m, cap)
        Written: the secondary index and the interval index of each candidate.
    out_d : ndarray of float64, shape (m, cap)
        Written: the estimated minimum distance (km).
    counts : ndarray of int64, shape (m,)
        Written: number of candidates per row (may exceed ``cap``: then call again with more).
    el1, g1, el2, g2 : ndarray
        The orbit-path filter's per-object constants and per-chunk plane geometry
        (:func:`visviva.core.orbit_path.path_geometry`; ``(0, 8)`` constants: no filter).

    Notes
    -----
    The rows are processed in tiles of :data:`TILE` primaries, one tile per thread: for each
    secondary, the tile's pairs are scanned while the secondary's samples stay in cache.
    """
    n2 = r2.shape[0]
    m = rows.shape[0]
    reach = limit + margin
    fine = limit + fine_margin
    n_tiles = (m + TILE - 1) // TILE
    for t in prange(n_tiles):
        a0 = t * TILE
        a1 = min(m, a0 + TILE)
        p0 = np.empty(3)
        p1 = np.empty(3)
        m0 = np.empty(3)
        m1 = np.empty(3)
        jmin = n2
        for a in range(a0, a1):
            counts[a] = 0
            j0 = rows[a] + 1 if self_mode else 0
            jmin = min(jmin, j0)
        for j in range(jmin, n2):
            for a in range(a0, a1):
                i = rows[a]
                if self_mode and j <= i:
                    continue
                if max(q1[i], q2[j]) - min(Q1[i], Q2[j]) > reach:
                    continue
                if not orbit_paths_close(el1, g1, i, el2, g2, j, reach):
                    continue
                counts[a] = _pair(a, i, j, r1, v1, r2, v2, dt, fine, speed_bound, counts[a],
                                  out_j, out_k, out_d, p0, p1, m0, m1)
