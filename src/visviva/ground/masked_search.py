"""The event search over elevation masks: rise and set where the satellite crosses the mask.

With an :class:`~visviva.ground.mask.ElevationMask` the search runs in two stages:

1. **Flat search.** :func:`visviva.ground.search.search_events` with the scalar threshold
   at the LOWEST elevation of all the masks: the satellite is above a mask only while it is
   above that, so every masked pass lies inside one of these passes.
2. **Mask crossings** (:func:`apply_masks`). Each of those passes is sampled on SGP4 every
   :data:`SKY_STEP_DEG` of the satellite's motion on the sky (the step from its fastest
   angular rate at the pass's events; at most :data:`MAX_STEP_S`), with its culminations as
   samples: ``f = sin(el) - sin(E_mask(az))`` (``el`` apparent with ``refraction``).
   Between two samples on one side of the mask, ``|df/dt|`` is bounded by the elevation
   and azimuth rates at the ends and the mask's steepest side (x 1.5), which bounds ``f``
   there (and ``el`` by the rate of motion on the sky against the mask's top): an
   interval where the satellite may cross the mask unseen, or that spans a vertical step
   of the mask, is halved, again and again down to :data:`SPLIT_TOL_S` (a pass that dips
   under a peak of the mask between samples, or peeks over a notch). Every sign change is
   then refined by regula falsi (Illinois) with a bisection every third step, so a corner
   or a vertical step of the mask (``f`` not smooth, or not continuous) still converges, to
   :data:`ROOT_TOL_S`.

A pass that dips under the mask in its middle (a mountain in front of the culmination)
becomes two passes, as STK's access intervals do. The culmination of each piece is the
geometric pass's highest point when the satellite is above the mask there; a piece without
it has its highest point at its own rise or set (then ``culmination_time`` is masked in the
pass table, as when the window cuts a pass). A rise of the flat search where the mask is at
its lowest (the same equation) is kept as it is: a flat mask gives the scalar search's
events bit for bit.

Only a crossing pair closer together than :data:`SPLIT_TOL_S` (a peek over the mask, or a
dip under it, shorter than 1 ms) can be missed, or one where the rates change by more than
half between two samples (they are at most :data:`SKY_STEP_DEG` apart on the sky).
"""

from __future__ import annotations

import math

import numpy as np

from ..core import topocentric as _topo
from .search import WINDOW_START, EventSet, search_events, sgp4_teme

__all__ = ["search_masked", "apply_masks", "SKY_STEP_DEG", "MAX_STEP_S", "ROOT_TOL_S"]

#: the first samples along a pass are this far apart on the sky (at the fastest rate seen)
SKY_STEP_DEG = 4.0
#: and this far apart in time at most (slow, high orbits), s
MAX_STEP_S = 240.0
#: the crossings of the mask are found to this, s
ROOT_TOL_S = 1e-6
_MIN_STEP_S = 0.02
_CHUNK = 100_000  # first samples per chunk
#: intervals between samples are halved down to this where a crossing may hide, s
SPLIT_TOL_S = 1e-3


def search_masked(cat, stations, t0, t1, flat_rad, masks, refraction=False, *,
                  warn_stale: bool = True) -> EventSet:
    """:func:`~visviva.ground.search.search_events` at ``flat_rad``, then the crossings of
    ``masks`` (one :class:`~visviva.ground.mask.ElevationMask` per station; None: the flat
    search alone)."""
    if masks is not None and refraction is not False:
        from ..errors import InvalidInputError
        from .horizon import Horizon

        try:
            Horizon(stations, flat_rad, refraction)
        except InvalidInputError as exc:
            raise InvalidInputError(
                f"the elevation mask's lowest point ({math.degrees(flat_rad):.6g} deg) is the "
                f"threshold of the first search, and: {exc} (raise the mask's lowest points)."
            ) from None
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
        self.slope = np.array([m.max_slope for m in masks])
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

    def sample(self, sat, sta, t):
        """``(f, el, el rate, az, az rate)`` at the given times: ``el`` apparent, rad; the
        rates rad/s (geometric; infinite where SGP4 failed: never cleared)."""
        res, _, err = self.look(sat, sta, t)
        ok = err == 0
        f = np.where(ok, np.sin(res[:, 2]) - np.sin(self.mask_rad(sta, res[:, 1])), -1.0)
        el = np.where(ok, res[:, 2], -np.pi / 2)
        er = np.where(ok & np.isfinite(res[:, 5]), res[:, 5], np.inf)
        ar = np.where(ok & np.isfinite(res[:, 4]), res[:, 4], np.inf)
        return f, el, er, res[:, 1], ar

    def spans_step(self, sta, az_a, az_b):
        """Does the shorter arc from ``az_a`` to ``az_b`` (rad) hold a vertical step of the
        mask of station ``sta``?"""
        out = np.zeros(az_a.size, dtype=bool)
        for m, members in self.groups:
            steps = m.step_azimuths_rad
            if steps.size == 0:
                continue
            k = np.flatnonzero(np.isin(sta, members))
            span = np.mod(az_b[k] - az_a[k], 2 * np.pi)
            back = span > np.pi
            start = np.where(back, az_b[k], az_a[k])
            width = np.where(back, 2 * np.pi - span, span)
            d = np.mod(steps[None, :] - start[:, None], 2 * np.pi)
            out[k] = (d <= width[:, None]).any(axis=1)
        return out

    def f(self, sat, sta, t):
        """``f`` (M,) at the given times."""
        return self.sample(sat, sta, t)[0] if t.size else np.empty(0)


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
    # the step: SKY_STEP_DEG at the fastest sky rate of the pass's events
    res, _, _ = geo.look(ev.sat, ev.station, ev.t_s)
    rate = np.hypot(res[:, 5], np.cos(res[:, 2]) * res[:, 4])
    rate = np.maximum.reduceat(np.where(np.isfinite(rate), rate, 0.0), starts)
    step = np.clip(math.radians(SKY_STEP_DEG) / np.maximum(rate, 1e-12), _MIN_STEP_S,
                   MAX_STEP_S)
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
    t[np.cumsum(counts) - 1] = t_b[chunk]  # (exactly: the flat search's set)
    is_culm = np.r_[np.full(p.size, -1, dtype=np.int64), c_ev]  # event index, -1: a sample
    p = np.concatenate([p, c_pid])
    t = np.concatenate([t, c_t])
    order = np.lexsort((t, p))
    p, t, is_culm = p[order], t[order], is_culm[order]
    smp = geo.sample(sat_p[p], sta_p[p], t)
    # a flat rise / set that is the mask's crossing: f = 0 there, its side its neighbour's
    head = np.r_[True, p[1:] != p[:-1]]
    tail = np.r_[p[1:] != p[:-1], True]
    forced = (head & root_a[p]) | (tail & root_b[p])
    smp[0][forced] = 0.0
    p, t, is_culm, smp = _subdivide(geo, sat_p, sta_p, p, t, is_culm, smp, forced)
    f = smp[0]
    head = np.r_[True, p[1:] != p[:-1]]
    tail = np.r_[p[1:] != p[:-1], True]
    above = f > 0.0
    fa = head & root_a[p]
    fb = tail & root_b[p]
    above[fa] = np.r_[above[1:], False][fa]
    above[fb] = np.r_[False, above[:-1]][fb]
    p_begin = p[head & above]
    p_end = p[tail & above]
    keep_c = (is_culm >= 0) & above
    # the sign changes between neighbours of one pass
    k = np.flatnonzero(~tail[:-1] & (above[:-1] != above[1:]))
    up = ~above[k]
    roots = _refine(geo, sat_p[p[k]], sta_p[p[k]], t[k], t[k + 1], f[k], f[k + 1], up)
    return (p_begin, p_end, is_culm[keep_c], p[k], roots,
            np.where(up, _topo.RISE, _topo.SET))


def _subdivide(geo, sat_p, sta_p, p, t, is_culm, smp, forced):
    """Halve every interval between neighbouring samples (sorted by pass, then time) where
    the satellite may cross the mask unseen, until :data:`SPLIT_TOL_S`; returns the samples
    with the new ones, sorted.

    Between samples ``a``, ``b`` with ``f`` of one sign, ``|df/dt| <= L = 1.5 max(|el'| +
    S |az'|)`` at the two ends (``S`` the mask's steepest side, rad/rad), so
    ``(f_a + f_b - L dt) / 2 <= f <= (f_a + f_b + L dt) / 2``; and ``f >= sin(el_low) -
    sin(E_top)`` with ``el_low`` from the sky rate likewise. An interval whose bounds keep
    ``f`` on its side is done; one that spans a vertical step of the mask is halved to the
    end (``f`` jumps there); the others are halved."""
    f, el, el_rate, az, az_rate = smp
    parts = [(p, t, is_culm, f, el, el_rate, az, az_rate, forced)]
    k = np.flatnonzero(p[:-1] == p[1:])  # intervals (k, k + 1)
    lo = (p[k], t[k], f[k], el[k], el_rate[k], az[k], az_rate[k], forced[k])
    hi = (p[k + 1], t[k + 1], f[k + 1], el[k + 1], el_rate[k + 1], az[k + 1], az_rate[k + 1],
          forced[k + 1])
    for _ in range(64):
        if lo[0].size == 0:
            break
        pp, ta, fa_, ela, era, aza, ara, fca = lo
        tb, fb_, elb, erb, azb, arb, fcb = hi[1:]
        sta = sta_p[pp]
        dt = tb - ta
        fast = 1.5 * np.maximum(np.abs(era) + geo.slope[sta] * np.abs(ara),
                                np.abs(erb) + geo.slope[sta] * np.abs(arb))
        sky = 1.5 * np.maximum(np.hypot(era, np.cos(ela) * ara), np.hypot(erb, np.cos(elb) * arb))
        # a forced end (f = 0 on the mask) takes the side of the other end
        pos_a = np.where(fca, fb_ > 0.0, fa_ > 0.0)
        pos_b = np.where(fcb, fa_ > 0.0, fb_ > 0.0)
        low = np.maximum(0.5 * (fa_ + fb_ - fast * dt),
                         np.sin(np.clip(0.5 * (ela + elb - sky * dt), -np.pi / 2, np.pi / 2))
                         - np.sin(geo.highest[sta]))
        high = 0.5 * (fa_ + fb_ + fast * dt)
        with np.errstate(invalid="ignore"):
            clear = np.where(pos_a, low > 0.0, ~(high > 0.0))
        split = (pos_a == pos_b) & (dt > SPLIT_TOL_S) & (~clear | geo.spans_step(sta, aza, azb))
        if not split.any():
            break
        s_ = np.flatnonzero(split)
        tm = 0.5 * (ta[s_] + tb[s_])
        pm = pp[s_]
        fm, elm, erm, azm, arm = geo.sample(sat_p[pm], sta_p[pm], tm)
        no = np.zeros(s_.size, dtype=bool)
        parts.append((pm, tm, np.full(s_.size, -1, dtype=np.int64), fm, elm, erm, azm, arm, no))
        mid = (pm, tm, fm, elm, erm, azm, arm, no)
        lo = tuple(np.concatenate([x[s_], y]) for x, y in zip(lo, mid, strict=True))
        hi = tuple(np.concatenate([y, x[s_]]) for x, y in zip(hi, mid, strict=True))
    p, t, is_culm, f, el, el_rate, az, az_rate, _ = (np.concatenate(c) for c in zip(*parts,
                                                                                   strict=True))
    order = np.lexsort((t, p))
    return (p[order], t[order], is_culm[order],
            tuple(x[order] for x in (f, el, el_rate, az, az_rate)))


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
