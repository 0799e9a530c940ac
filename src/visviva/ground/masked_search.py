"""The event search over elevation masks: rise and set where the satellite crosses the mask.

With an :class:`~visviva.ground.mask.ElevationMask` the search runs in two stages:

1. **Flat search.** :func:`visviva.ground.search.search_events` with the scalar threshold
   at the LOWEST elevation of all the masks: the satellite is above a mask only while it is
   above that, so every masked pass lies inside one of these passes.
2. **Mask crossings** (:func:`apply_masks`). Each of those passes is sampled on SGP4 every
   :data:`SKY_STEP_DEG` of the satellite's motion on the sky (the step from its fastest
   angular rate at the pass's events; at most :data:`MAX_STEP_S`), with its culminations as
   samples, ``f = sin(el) - sin(E_mask(az))`` at each (``el`` apparent with ``refraction``).
   A sampled local minimum above the mask, or maximum below it, within twice the change
   between neighbouring samples of zero is bracketed and refined (golden section on SGP4):
   a pass that dips under the mask between samples (a peak of the mask, a vertex) is split,
   one that peeks over it found. Every sign change is refined by regula falsi (Illinois)
   with a bisection every third step, so a corner or a vertical step of the mask (``f`` not
   smooth, or not continuous) still converges, to :data:`ROOT_TOL_S`.

A pass that dips under the mask in its middle (a mountain in front of the culmination)
becomes two passes, as STK's access intervals do. The culmination of each piece is the
geometric pass's highest point when the satellite is above the mask there; a piece without
it has its highest point at its own rise or set (then ``culmination_time`` is masked in the
pass table, as when the window cuts a pass). A rise of the flat search where the mask is at
its lowest (the same equation) is kept as it is: a flat mask gives the scalar search's
events bit for bit.

Features of the mask narrower than about :data:`SKY_STEP_DEG` along the track (a pole, a
slot between two buildings) may be missed when no sample falls in them.
"""

from __future__ import annotations

import math

import numpy as np

from ..core import topocentric as _topo
from .search import WINDOW_START, EventSet, search_events, sgp4_teme

__all__ = ["search_masked", "apply_masks", "SKY_STEP_DEG", "MAX_STEP_S", "ROOT_TOL_S"]

#: the samples along a pass are this far apart on the sky at most (at the fastest rate seen)
SKY_STEP_DEG = 0.5
#: and this far apart in time at most (slow, high orbits), s
MAX_STEP_S = 30.0
#: the crossings of the mask are found to this, s
ROOT_TOL_S = 1e-6
_MIN_STEP_S = 0.02
#: the coarse samples are this many fine steps apart
_COARSE = 8
_CHUNK = 50_000  # coarse samples per chunk (up to ~8x as many fine ones)
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def search_masked(cat, stations, t0, t1, flat_rad, masks, refraction=False, *,
                  warn_stale: bool = True) -> EventSet:
    """:func:`~visviva.ground.search.search_events` at ``flat_rad``, then the crossings of
    ``masks`` (one :class:`~visviva.ground.mask.ElevationMask` per station; None: the flat
    search alone)."""
    ev = search_events(cat, stations, t0, t1, flat_rad, refraction, warn_stale=warn_stale)
    if masks is None:
        return ev
    return apply_masks(ev, cat, stations, flat_rad, masks, refraction)


class _Geometry:
    """``f = sin(el) - sin(E_mask(az))`` and the look angles on SGP4, for the events' window."""

    def __init__(self, ev, cat, stations, flat_rad, masks, refraction):
        from .horizon import Horizon

        self.ev = ev
        self.satrecs = cat.__dict__["_pass_setup"][0]
        self.sites = np.ascontiguousarray([s.itrs_km for s in stations], dtype=np.float64)
        self.enu = np.ascontiguousarray([s.enu_matrix for s in stations], dtype=np.float64)
        self.horizon = Horizon(stations, flat_rad, refraction)
        self.flat_rad = flat_rad
        self.groups = []  # (mask, station indices) for each distinct mask
        self.highest = np.array([m.highest.to_value("rad") for m in masks])
        for m in dict.fromkeys(masks, None):
            self.groups.append((m, np.array([k for k, x in enumerate(masks) if x == m])))

    def look(self, sat, sta, t):
        """(range, az, el apparent, range rate, az rate, el rate) (M, 6), Earth-fixed
        positions (M, 3), SGP4 status (M,)."""
        ev = self.ev
        r, v, err = sgp4_teme(self.satrecs, sat, ev.clock, t)
        bad = err != 0
        r[bad] = 1e4  # (a failed state: not above any mask, below)
        v[bad] = 0.0
        ri, vi = ev.earth.apply(r, v, t)
        res = np.empty((t.size, 6))
        sta = np.ascontiguousarray(sta, dtype=np.int64)
        _topo.razel_many(np.ascontiguousarray(ri - self.sites[sta]), np.ascontiguousarray(vi),
                         self.enu, sta, res)
        res[:, 2] = self.horizon.apparent_rad(res[:, 2], sta, res[:, 0])
        return res, ri, err

    def mask_rad(self, sta, az):
        out = np.empty(az.size)
        for m, members in self.groups:
            k = np.isin(sta, members)
            out[k] = m.elevation_rad(az[k])
        return out

    def f(self, sat, sta, t, rates=False):
        """``f`` (M,); with ``rates`` also the elevation (rad) and the rate of motion on the
        sky (rad/s)."""
        if t.size == 0:
            return (np.empty(0),) * 3 if rates else np.empty(0)
        res, _, err = self.look(sat, sta, t)
        fv = np.where(err == 0, np.sin(res[:, 2]) - np.sin(self.mask_rad(sta, res[:, 1])), -1.0)
        if not rates:
            return fv
        rate = np.hypot(res[:, 5], np.cos(res[:, 2]) * res[:, 4])
        return fv, np.where(err == 0, res[:, 2], -np.pi / 2), np.where(np.isfinite(rate), rate,
                                                                       np.inf)


def apply_masks(ev, cat, stations, flat_rad, masks, refraction) -> EventSet:
    """The events of ``ev`` (a flat search at ``flat_rad``, the masks' lowest elevation) cut
    to the masks (see the module docstring)."""
    geo = _Geometry(ev, cat, stations, flat_rad, masks, refraction)
    kind = ev.kind
    n = kind.size
    if n == 0:
        return ev
    new_pair = np.ones(n, dtype=bool)
    new_pair[1:] = (np.diff(ev.sat) != 0) | (np.diff(ev.station) != 0)
    begin = (kind == _topo.RISE) | (kind == WINDOW_START) | new_pair
    pid = np.cumsum(begin) - 1
    starts = np.flatnonzero(begin)
    last = np.r_[starts[1:], n] - 1
    sat_p, sta_p = ev.sat[starts], ev.station[starts]
    t_a, t_b = ev.t_s[starts], ev.t_s[last]
    # the coarse step: _COARSE x SKY_STEP_DEG at the fastest sky rate of the pass's events
    res, _, _ = geo.look(ev.sat, ev.station, ev.t_s)
    rate = np.hypot(res[:, 5], np.cos(res[:, 2]) * res[:, 4])
    rate = np.maximum.reduceat(np.where(np.isfinite(rate), rate, 0.0), starts)
    step = np.clip(_COARSE * math.radians(SKY_STEP_DEG) / np.maximum(rate, 1e-12), _MIN_STEP_S,
                   _COARSE * MAX_STEP_S)
    # forced roots: a rise / set of the flat search where the mask is at the flat level
    az_ev = res[:, 1]
    at_flat = geo.mask_rad(ev.station, az_ev) == flat_rad
    root_a = (kind[starts] == _topo.RISE) & at_flat[starts]
    root_b = (kind[last] == _topo.SET) & at_flat[last]
    culm = np.flatnonzero(kind == _topo.CULMINATION)

    counts = np.maximum(np.ceil((t_b - t_a) / step).astype(np.int64), 1) + 1
    out = []
    bounds = np.searchsorted(np.cumsum(counts), np.arange(_CHUNK, counts.sum(), _CHUNK))
    for chunk in np.split(np.arange(starts.size), np.unique(bounds[bounds > 0])):
        if chunk.size:
            c_culm = culm[np.isin(pid[culm], chunk)]
            out.append(_cut_passes(geo, chunk, counts[chunk], t_a, t_b, sat_p, sta_p,
                                   root_a, root_b, pid[c_culm], ev.t_s[c_culm], c_culm))
    keep_ev = np.zeros(n, dtype=bool)
    new_sat, new_sta, new_t, new_k = [], [], [], []
    for p_begin, p_end, kept_culm, x_pass, x_t, x_kind in out:
        keep_ev[starts[p_begin]] = True
        keep_ev[last[p_end]] = True
        keep_ev[kept_culm] = True
        new_sat.append(sat_p[x_pass])
        new_sta.append(sta_p[x_pass])
        new_t.append(x_t)
        new_k.append(x_kind)
    sel = np.flatnonzero(keep_ev)
    x_sat, x_sta = np.concatenate(new_sat), np.concatenate(new_sta)
    x_t, x_k = np.concatenate(new_t), np.concatenate(new_k).astype(np.int64)
    x_res, x_ri, _ = geo.look(x_sat, x_sta, x_t)
    sat_i = np.concatenate([ev.sat[sel], x_sat])
    sta_i = np.concatenate([ev.station[sel], x_sta])
    t = np.concatenate([ev.t_s[sel], x_t])
    kinds = np.concatenate([kind[sel], x_k])
    order = np.lexsort((kinds, t, sta_i, sat_i))

    def field(old, new):
        return np.concatenate([old[sel], new])[order]

    return EventSet(sat=sat_i[order], station=sta_i[order], kind=kinds[order], t_s=t[order],
                    t_ref=ev.t_ref, rng=field(ev.rng, x_res[:, 0]), az=field(ev.az, x_res[:, 1]),
                    el=field(ev.el, x_res[:, 2]), rng_rate=field(ev.rng_rate, x_res[:, 3]),
                    r_itrs=field(ev.r_itrs, x_ri), elevation=ev.elevation, earth=ev.earth,
                    clock=ev.clock, skipped=ev.skipped)


def _cut_passes(geo, chunk, counts, t_a, t_b, sat_p, sta_p, root_a, root_b, c_pid, c_t, c_ev):
    """Sample passes ``chunk`` and find their pieces above the mask.

    Returns the passes whose first / last event stays (``p_begin``, ``p_end``), the kept
    culminations (``c_ev``: their event indices), and the new crossings (pass, time, kind)."""
    p = np.repeat(chunk, counts)
    first = np.cumsum(counts) - counts
    frac = (np.arange(p.size) - np.repeat(first, counts)) / np.repeat(counts - 1, counts)
    t = t_a[p] + frac * (t_b - t_a)[p]
    end = np.cumsum(counts) - 1
    t[end] = t_b[chunk]  # (exactly: the flat search's set)
    is_culm = np.r_[np.full(p.size, -1, dtype=np.int64), c_ev]  # event index, -1: a sample
    p = np.concatenate([p, c_pid])
    t = np.concatenate([t, c_t])
    order = np.lexsort((t, p))
    p, t, is_culm = p[order], t[order], is_culm[order]
    f, el, rate = geo.f(sat_p[p], sta_p[p], t, rates=True)
    # between coarse samples: every SKY_STEP_DEG (at the faster end's rate, x 1.5) where the
    # satellite may come below the mask's highest point (|d el / dt| <= the sky rate)
    k = np.flatnonzero(p[:-1] == p[1:])
    dt = t[k + 1] - t[k]
    fast = 1.5 * np.maximum(rate[k], rate[k + 1])
    low = 0.5 * (el[k] + el[k + 1] - fast * dt)
    k_f = np.flatnonzero(~(low > geo.highest[sta_p[p[k]]]))
    n_f = np.clip(np.ceil(np.minimum(fast[k_f] * dt[k_f] / math.radians(SKY_STEP_DEG),
                                     1e6)), 1, None).astype(np.int64)
    n_f = np.maximum(n_f, np.ceil(dt[k_f] / MAX_STEP_S).astype(np.int64))
    q = np.repeat(k_f, n_f - 1)
    j = np.arange(q.size) - np.repeat(np.cumsum(n_f - 1) - (n_f - 1), n_f - 1) + 1
    t_f = t[k[q]] + dt[q] * j / np.repeat(n_f, n_f - 1)
    p_f = p[k[q]]
    p = np.concatenate([p, p_f])
    t = np.concatenate([t, t_f])
    f = np.concatenate([f, geo.f(sat_p[p_f], sta_p[p_f], t_f)])
    is_culm = np.concatenate([is_culm, np.full(t_f.size, -1, dtype=np.int64)])
    # dips under the mask (or peaks over it) between samples: their extremum, refined
    for _ in range(2):
        order = np.lexsort((t, p))
        p, t, f, is_culm = p[order], t[order], f[order], is_culm[order]
        forced = ((np.r_[True, p[1:] != p[:-1]] & root_a[p])
                  | (np.r_[p[1:] != p[:-1], True] & root_b[p]))
        ext_t, ext_f, ext_p = _hidden_extrema(geo, sat_p, sta_p, p, t, f, forced)
        if ext_t.size == 0:
            break
        p = np.concatenate([p, ext_p])
        t = np.concatenate([t, ext_t])
        f = np.concatenate([f, ext_f])
        is_culm = np.concatenate([is_culm, np.full(ext_t.size, -1, dtype=np.int64)])
    order = np.lexsort((t, p))
    p, t, f, is_culm = p[order], t[order], f[order], is_culm[order]
    head = np.r_[True, p[1:] != p[:-1]]
    tail = np.r_[p[1:] != p[:-1], True]
    above = f > 0.0
    # a flat rise / set that is the mask's crossing: its side is its neighbour's
    fa = head & root_a[p]
    fb = tail & root_b[p]
    above[fa] = np.r_[above[1:], False][fa]
    above[fb] = np.r_[False, above[:-1]][fb]
    p_begin = p[head & above]
    p_end = p[tail & above]
    keep_c = (is_culm >= 0) & above
    # the sign changes between neighbours of one pass
    k = np.flatnonzero(~tail[:-1] & (above[:-1] != above[1:])) if p.size > 1 else np.empty(
        0, dtype=np.int64)
    up = ~above[k]
    roots = _refine(geo, sat_p[p[k]], sta_p[p[k]], t[k], t[k + 1], f[k], f[k + 1], up)
    return (p_begin, p_end, is_culm[keep_c], p[k], roots,
            np.where(up, _topo.RISE, _topo.SET))


def _hidden_extrema(geo, sat_p, sta_p, p, t, f, forced):
    """Refine the sampled local minima above the mask and maxima below it that lie within
    twice the change to their neighbours of zero (a pass's first and last samples too, on
    their one side, unless ``forced``: a flat rise or set on the mask); returns those whose
    extremum is on the other side (time, f, pass)."""
    none = np.empty(0), np.empty(0), np.empty(0, dtype=np.int64)
    if p.size < 2:
        return none
    idx = np.arange(p.size)
    prev = np.where(np.r_[False, p[1:] == p[:-1]], idx - 1, idx)
    nxt = np.where(np.r_[p[:-1] == p[1:], False], idx + 1, idx)
    fl, fc, fr = f[prev], f, f[nxt]
    reach = 2.0 * np.maximum(np.abs(fc - fl), np.abs(fr - fc))
    dip = (fc > 0.0) & (fc <= fl) & (fc <= fr) & (fc < reach)
    peak = (fc <= 0.0) & (fc >= fl) & (fc >= fr) & (-fc < reach)
    c = np.flatnonzero((dip | peak) & (prev != nxt) & ~forced)
    if c.size == 0:
        return none
    sign = np.where(f[c] > 0.0, 1.0, -1.0)  # minimise sign * f
    lo, hi = t[prev[c]], t[nxt[c]]
    sat, sta = sat_p[p[c]], sta_p[p[c]]
    x1 = hi - _GOLDEN * (hi - lo)
    x2 = lo + _GOLDEN * (hi - lo)
    g = np.r_[sign, sign] * geo.f(np.r_[sat, sat], np.r_[sta, sta], np.r_[x1, x2])
    g1, g2 = g[:c.size], g[c.size:]
    for _ in range(40):  # golden section, to 1e-3 s
        if (hi - lo).max() < 1e-3:
            break
        left = g1 < g2  # the minimum lies in [lo, x2]
        hi = np.where(left, x2, hi)
        lo = np.where(left, lo, x1)
        xn = np.where(left, hi - _GOLDEN * (hi - lo), lo + _GOLDEN * (hi - lo))
        gn = sign * geo.f(sat, sta, xn)
        x1, x2 = np.where(left, xn, x2), np.where(left, x1, xn)
        g1, g2 = np.where(left, gn, g2), np.where(left, g1, gn)
    best = np.where(g1 < g2, x1, x2)
    fb = geo.f(sat, sta, best)
    flip = sign * fb <= 0.0
    return best[flip], fb[flip], p[c][flip]


def _refine(geo, sat, sta, a, b, fa, fb, up):
    """The crossing in each bracket ``[a, b]`` (``f`` changes sign): regula falsi (Illinois),
    every third step a bisection, to :data:`ROOT_TOL_S`; the final bracket's middle."""
    a, b, fa, fb = a.copy(), b.copy(), fa.copy(), fb.copy()
    side = np.zeros(a.size, dtype=np.int64)
    todo = np.flatnonzero(b - a > ROOT_TOL_S)
    for it in range(120):
        if todo.size == 0:
            break
        aa, bb, ga, gb = a[todo], b[todo], fa[todo], fb[todo]
        if it % 3 == 2:
            x = 0.5 * (aa + bb)
        else:
            with np.errstate(divide="ignore", invalid="ignore"):
                x = aa + ga * (bb - aa) / (ga - gb)
            x = np.where(np.isfinite(x), x, 0.5 * (aa + bb))
            x = np.clip(x, aa + 0.1 * ROOT_TOL_S, bb - 0.1 * ROOT_TOL_S)
        g = geo.f(sat[todo], sta[todo], x)
        left = (g > 0.0) == (gb > 0.0)  # the root lies in [a, x]
        s = side[todo]
        a[todo] = np.where(left, aa, x)
        b[todo] = np.where(left, x, bb)
        fa[todo] = np.where(left, np.where(s == -1, 0.5 * ga, ga), g)
        fb[todo] = np.where(left, g, np.where(s == 1, 0.5 * gb, gb))
        side[todo] = np.where(left, -1, 1)
        todo = todo[b[todo] - a[todo] > ROOT_TOL_S]
    return 0.5 * (a + b)
