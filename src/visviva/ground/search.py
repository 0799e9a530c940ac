"""The event search behind ``find_events`` and ``find_passes``: coarse node states shared by all
stations, a compiled scan of every (satellite, station) pair, and a final correction on SGP4.

1. **Nodes.** The satellites are grouped by the node spacing their orbit needs: ``h`` about
   1/8 of the time the satellite takes to sweep one radian at perigee,
   ``h ~ 2 pi / (8 n (1 + e)^2 / (1 - e^2)^(3/2))`` rounded down to 75 s x 2^k (LEO: 600 s;
   GTO and Molniya about the same, their perigee being as fast as LEO; GEO: 4800 s).
   Near-Earth satellites take SGP4's secular J2 theory at the nodes (checked against SGP4 at
   three nodes, see :func:`_nodes`), deep-space ones one ``SatrecArray`` call; one set of
   astropy anchors (:class:`~visviva.ground.earthfixed.EarthFixedMap`) turns the states
   Earth-fixed. Every station shares them.
2. **Scan.** :func:`visviva.core.topocentric.scan_passes` samples ``sin(el)`` on the cubic
   Hermite polynomials through the nodes (``m`` = 6 samples per interval), refines every
   extremum and every crossing of ``min_elevation`` on the polynomial, for all pairs at once;
   maxima a little below the threshold come out as candidates.
3. **Correction** (:func:`_correct`). Each event is corrected on SGP4 itself: Newton steps on
   ``f = sin(el) - sin(el_min)`` for rises and sets, parabola vertices through SGP4 positions
   for culminations; candidates and grazing passes are settled on SGP4 (their rise and set
   re-seeded from the parabola), fakes dropped. SGP4 runs only at the event times: one
   ``sgp4_array`` call per satellite with events per round (the sgp4 library takes
   per-satellite time lists no other way). The states at the window's edges come from SGP4.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
from astropy import units as u
from astropy.time import Time

from .._callsite import outside_stacklevel
from ..core import topocentric as _topo
from ..satellites.tle_checks import STALE_DAYS, flag_beyond_earth_orbit
from ..satellites.utc_days import time_to_utc_days, utc_days_to_time
from .earthfixed import EarthFixedMap
from .pass_inputs import as_catalog, check_window, min_elevation_rad, warn_stale_element_sets

__all__ = ["EventSet", "search_events", "as_catalog", "check_window", "min_elevation_rad",
           "WINDOW_START", "WINDOW_END", "sgp4_teme", "warn_stale_element_sets", "STALE_DAYS"]

_BASE_STEP_S = 75.0
_SAMPLES = 6
_CHUNK_PAIRS = 4096
#: maxima within this of the threshold (in sin(el)) are settled on SGP4: ~0.3 deg, far above
#: the polynomial's error (~0.05 deg in LEO with 600 s nodes)
_NEAR = 5e-3
#: pseudo-event kinds: the satellite is above the threshold at the window's start / end
WINDOW_START = 3
WINDOW_END = 4


def node_step_s(satrecs) -> np.ndarray:
    """Node spacing per satellite, s (see the module docstring)."""
    n = np.array([s.no_kozai for s in satrecs]) / 60.0  # rad/s
    e = np.clip(np.array([s.ecco for s in satrecs]), 0.0, 0.99)
    rate = n * (1.0 + e) ** 2 / (1.0 - e * e) ** 1.5
    target = 2.0 * np.pi / (8.0 * rate)
    k = np.floor(np.log2(np.maximum(target / _BASE_STEP_S, 1.0)))
    return _BASE_STEP_S * 2.0 ** np.clip(k, 0, 6)


class EventSet:
    """Events of every (satellite, station) pair, corrected on SGP4.

    Attributes
    ----------
    sat, station, kind : ndarray of int64, shape (E,)
    t_s : ndarray (E,)
        Seconds after ``t_ref``.
    t_ref : astropy Time
    az, el, rng, rng_rate : ndarray (E,)
        rad, rad, km, km/s at the event; ``el`` apparent when the search was refracted.
    elevation : str
        What ``el`` is: ``"geometric"`` or ``"apparent (optical refraction)"`` (or radio).
    r_itrs : ndarray (E, 3)
        Earth-fixed position at the event (for the Sun and the shadow), km.
    kind : also :data:`WINDOW_START` / :data:`WINDOW_END` at ``t0`` / ``t1`` for pairs above
        the threshold there.
    skipped : list of (int, float)
        Satellites whose SGP4 failed inside the window (decayed, ...) and the time (s after
        ``t_ref``) where their search stopped.
    """

    def __init__(self, **fields):
        self.__dict__.update(fields)

    def times(self, index=None) -> Time:
        """The event times (UTC), all or ``t_s[index]``."""
        t = self.t_s if index is None else self.t_s[index]
        clock = self.__dict__.get("clock")
        if clock is not None and clock.leap_free:
            jd1, jd2 = clock.parts(t)
            out = utc_days_to_time(jd1, jd2)
        else:  # (astropy's cached .utc is read-only: the pass table masks cells of it)
            out = (self.t_ref + t * u.s).utc
        out.precision = 3
        return out.copy(format="isot")


class _Clock:
    """Seconds after ``t_ref`` -> sgp4's (jd, fr) UTC Julian-date parts, for one window.

    Straight arithmetic on ``t_ref``'s UTC date when no leap second falls in
    ``[lo_s, hi_s]`` (checked once: the usual case); astropy's conversion otherwise.
    """

    def __init__(self, t_ref, lo_s: float, hi_s: float):
        self.t_ref = t_ref
        jd1, jd2 = time_to_utc_days(t_ref)  # sgp4's UTC days of 86,400 s
        self.jd1 = float(jd1)
        self.jd2 = float(jd2)
        e1, e2 = time_to_utc_days(t_ref + np.array([lo_s, hi_s]) * u.s)
        exact = ((e1 - self.jd1) + (e2 - self.jd2)) * 86400.0
        self.leap_free = bool(np.abs(exact - np.array([lo_s, hi_s])).max() < 1e-3)

    def parts(self, t_s):
        t_s = np.ascontiguousarray(t_s, dtype=np.float64)
        if self.leap_free:
            return np.full(t_s.shape, self.jd1), self.jd2 + t_s / 86400.0
        jd1, jd2 = time_to_utc_days(self.t_ref + t_s * u.s)
        return (np.ascontiguousarray(jd1, dtype=np.float64),
                np.ascontiguousarray(jd2, dtype=np.float64))


def sgp4_teme(satrecs, sat_idx, clock, t_s):
    """TEME states of ``satrecs[sat_idx[k]]`` at ``t_ref + t_s[k]``; status per event (0 OK;
    sgp4's codes, or :data:`~visviva.satellites.tle_checks.SGP4_BEYOND_EARTH_ORBIT`).

    One ``sgp4_array`` call per satellite with events (the sgp4 library takes per-satellite
    time lists no other way), on contiguous slices of the events sorted by satellite.
    """
    n = len(sat_idx)
    if n == 0:
        return np.empty((0, 3)), np.empty((0, 3)), np.empty(0, dtype=np.int64)
    jd, fr = clock.parts(t_s)
    order = np.argsort(sat_idx, kind="stable")
    ss = sat_idx[order]
    jd_s = np.ascontiguousarray(jd[order])
    fr_s = np.ascontiguousarray(fr[order])
    starts = np.flatnonzero(np.r_[True, ss[1:] != ss[:-1]])
    ends = np.r_[starts[1:], n]
    r_s = np.empty((n, 3))
    v_s = np.empty((n, 3))
    e_s = np.empty(n, dtype=np.int64)
    first = ss[starts].tolist()
    for k, a, b in zip(first, starts.tolist(), ends.tolist(), strict=True):
        e, rr, vv = satrecs[k].sgp4_array(jd_s[a:b], fr_s[a:b])
        r_s[a:b] = rr
        v_s[a:b] = vv
        e_s[a:b] = e
    r = np.empty((n, 3))
    v = np.empty((n, 3))
    err = np.empty(n, dtype=np.int64)
    r[order] = r_s
    v[order] = v_s
    err[order] = e_s
    flag_beyond_earth_orbit(err, r)  # (as Satellite.teme: no Earth orbit is a failure)
    return r, v, err


def _slant_range_km(satrecs, el_rad: float) -> np.ndarray:
    """Range at elevation ``el`` to a satellite at its perigee altitude (spherical Earth)."""
    re = 6378.137
    hp = np.array([s.a * s.radiusearthkm * (1.0 - s.ecco) for s in satrecs]) - re
    hp = np.maximum(hp, 100.0)
    se = math.sin(el_rad)
    return -re * se + np.sqrt((re * se) ** 2 + 2.0 * re * hp + hp * hp)


def _nodes(cat, idx, h, clock, span_s, pad_s, secular, rho_min):
    """TEME node states of satellites ``idx`` and each one's near-threshold margin in f.

    Near-Earth satellites (``secular``) take the secular J2 model of their SGP4 mean elements
    (:func:`visviva.satellites.catalog.propagate_j2_batch`, a compiled loop, ~20x cheaper than
    SGP4), checked against SGP4 at the first, middle and last node: the margin is
    ``(2 eps + 15 km) / rho_min`` with ``eps`` the largest difference there, so a maximum that
    SGP4 might put above the threshold is always settled on SGP4. A satellite whose secular
    states are off by more than 50 km, or whose SGP4 fails at a check node, and every
    deep-space satellite, take SGP4 at every node.
    """
    from ..satellites.catalog import Catalog, j2_grid

    nodes = int(math.ceil((span_s + 2 * pad_s) / h)) + 1
    times_s = np.arange(nodes) * h - pad_s
    jd, fr = clock.parts(times_s)
    n = len(idx)
    r = np.empty((n, nodes, 3))
    v = np.empty((n, nodes, 3))
    e = np.zeros((n, nodes), dtype=np.uint8)
    near = np.full(n, _NEAR)
    exact = ~secular[idx]
    js = np.flatnonzero(~exact)
    if js.size:
        whole = js.size == len(cat)  # the usual LEO catalogue: its cached secular setup
        sub = cat if whole else Catalog([cat.satellites[int(i)] for i in idx[js]])
        try:
            # (stale element sets: warned once by the search, over its window)
            b = j2_grid(sub, clock.t_ref + times_s * u.s, "nan", warn_stale=False)
            r_sec = b.r.to_value(u.km)
            v_sec = b.v.to_value(u.km / u.s)
            k3 = np.array([0, nodes // 2, nodes - 1])
            e3, r3, _ = sub.satrec_array.sgp4(jd[k3], fr[k3])
            flag_beyond_earth_orbit(e3, r3)
            eps = np.linalg.norm(r3 - r_sec[:, k3], axis=-1).max(axis=1)
            good = (e3 == 0).all(axis=1) & (b.status == 0).all(axis=1) & (eps < 50.0)
        except Exception:  # noqa: BLE001 (an orbit outside the secular theory: use SGP4)
            good = np.zeros(js.size, dtype=bool)  # (r_sec, eps may not exist: not read)
        if good.any():
            ok = js[good]
            r[ok] = r_sec[good]
            v[ok] = v_sec[good]
            near[ok] = np.maximum(_NEAR, (2.0 * eps[good] + 15.0) / rho_min[idx[ok]])
        exact[js[~good]] = True
    je = np.flatnonzero(exact)
    if je.size:
        sub = cat if je.size == len(cat) else Catalog([cat.satellites[int(i)] for i in idx[je]])
        ee, rr, vv = sub.satrec_array.sgp4(jd, fr)
        flag_beyond_earth_orbit(ee, rr)  # no Earth orbit: a failed node, as sgp4's errors
        r[je], v[je], e[je] = rr, vv, ee
    return r, v, e, near, times_s


def _coarse_scan(cat, idx, h, clock, span_s, pad_s, earth, sites, ups, sin_geo, secular,
                 rho_min):
    """Scan satellites ``idx`` (one node spacing ``h``) against all sites; raw events.

    ``sin_geo`` (S,): each site's geometric threshold; one scan per distinct value (one in
    all for a geometric threshold, or refracted stations sharing their air)."""
    r, v, e, near, times_s = _nodes(cat, idx, h, clock, span_s, pad_s, secular, rho_min)
    nodes = times_s.size
    bad = (e != 0) | ~np.isfinite(r).all(-1) | ~np.isfinite(v).all(-1)
    r[bad] = 0.0  # never read: each satellite's window (and t_reach) stops before its first
    v[bad] = 0.0  # failed node
    r, v = earth.apply(r, v, times_s)
    t_lo = np.full(len(idx), pad_s)
    t_hi = np.full(len(idx), pad_s + span_s)
    t_reach = np.full(len(idx), (nodes - 1) * h)  # the nodes' reach (finite states)
    if bad.any():
        first_bad = np.where(bad.any(axis=1), bad.argmax(axis=1), nodes)
        t_reach = np.minimum(t_reach, (first_bad - 1) * h)
        t_hi = np.minimum(t_hi, t_reach)
        cut = t_hi < pad_s + span_s
    else:
        cut = np.zeros(len(idx), dtype=bool)
    # the scan reaches one sampling interval (100 s in LEO) past each edge of the window: its
    # crossings can be seconds off SGP4's, more under refraction (it scans for a star's
    # geometric threshold, and a satellite's, less lifted, lies up to ~0.1 deg higher), and a
    # rise a few seconds after the start was lost when its scan crossing fell before it. The
    # correction clips to the window and drops what stays outside. Whole sampling intervals
    # (multiples of 12.5 s, exact in binary) keep the samples where they were.
    margin = h / _SAMPLES
    scan_lo = t_lo - margin
    scan_hi = np.minimum(t_hi + margin, t_reach)
    out_sat, out_sta, out_t, out_k = [], [], [], []
    cap = max(8, int(3 * span_s / h / 4) + 8)
    levels = np.unique(sin_geo)
    for level in levels:
        group = (np.arange(len(sites)) if levels.size == 1
                 else np.flatnonzero(sin_geo == level))
        g_sites = sites if levels.size == 1 else np.ascontiguousarray(sites[group])
        g_ups = ups if levels.size == 1 else np.ascontiguousarray(ups[group])
        ns = len(group)
        for lo in range(0, len(idx), max(1, _CHUNK_PAIRS // ns)):
            hi = min(len(idx), lo + max(1, _CHUNK_PAIRS // ns))
            rc = np.ascontiguousarray(r[lo:hi])
            vc = np.ascontiguousarray(v[lo:hi])
            while True:
                ot, ok, of, cnt, st, fe = _topo.empty_outputs((hi - lo) * ns, cap)
                _topo.scan_passes(rc, vc, h, scan_lo[lo:hi], scan_hi[lo:hi], t_reach[lo:hi],
                                  _SAMPLES, g_sites, g_ups, float(level),
                                  np.ascontiguousarray(near[lo:hi]), ot, ok, of, cnt, st, fe)
                if not (st == _topo.PAIR_OVERFLOW).any():
                    break
                cap = int(cnt.max()) + 8
            sel = np.arange(ot.shape[1])[None, :] < cnt[:, None]
            p_local, col = np.nonzero(sel)
            p = p_local + lo * ns
            out_sat.append(idx[p // ns])
            out_sta.append(group[p % ns])
            out_t.append(ot[p_local, col] - pad_s)
            out_k.append(ok[p_local, col].astype(np.int64))
    return (np.concatenate(out_sat), np.concatenate(out_sta), np.concatenate(out_t),
            np.concatenate(out_k), near, t_hi - pad_s, cut)


def _window_edges(cat, clock, earth, span_s, sites, ups, horizon, t_end):
    """``f`` on SGP4 at the window's start and at each satellite's end, (N, S, 2)."""
    n = len(cat)
    jd, fr = clock.parts(np.array([0.0, span_s]))
    e, r, v = cat.satrec_array.sgp4(jd, fr)
    flag_beyond_earth_orbit(e, r)
    if (t_end < span_s).any():  # decayed inside the window: its own end
        cut = np.flatnonzero(t_end < span_s)
        r2, v2, e2 = sgp4_teme(cat.__dict__["_pass_setup"][0], cut, clock, t_end[cut])
        e[cut, 1], r[cut, 1], v[cut, 1] = e2, r2, v2
    ri, vi = earth.apply(r, v, np.array([0.0, span_s])[None, :].repeat(n, 0)
                        if not (t_end < span_s).any()
                        else np.stack([np.zeros(n), t_end], axis=1))
    ns = len(sites)
    out = np.empty((n, ns, 2))
    for s in range(ns):
        fd = horizon.f(ri.reshape(-1, 3), vi.reshape(-1, 3), sites, ups,
                       np.full(n * 2, s, dtype=np.int64))
        out[:, s, :] = fd[:, 0].reshape(n, 2)
    out[(e != 0)[:, None, :].repeat(ns, 1)] = -1.0
    return out


def search_events(cat, stations, t0, t1, min_el_rad: float, refraction=False, *,
                  warn_stale: bool = True) -> EventSet:
    """Rise, culmination and set of every satellite of ``cat`` at every station in [t0, t1].

    ``refraction`` (as :func:`visviva.ground.look.look`'s; False: geometric) puts the rise and
    the set where the apparent elevation crosses ``min_el_rad``
    (:class:`~visviva.ground.horizon.Horizon`); the events' ``el`` is then apparent too.
    Stale element sets warn (:func:`warn_stale_element_sets`) unless ``warn_stale`` is False:
    the caller has warned already (a Dask chunk of a catalogue the client checked whole).
    Warnings point at the user's line, the first frame outside visviva."""
    from .horizon import Horizon

    horizon = Horizon(stations, min_el_rad, refraction)
    if warn_stale:
        warn_stale_element_sets(cat, t0, t1)
    setup = cat.__dict__.get("_pass_setup")  # per catalogue: satrecs and node spacings
    if setup is None:
        satrecs = [s.satrec for s in cat.satellites]
        secular = np.array([s.method == "n" and s.ecco < 0.2 for s in satrecs], dtype=bool)
        setup = (satrecs, node_step_s(satrecs), secular)
        cat.__dict__["_pass_setup"] = setup
    satrecs, steps, secular = setup
    rho_min = _slant_range_km(satrecs, min(min_el_rad, horizon.lowest_geometric_rad))
    sites = np.ascontiguousarray([s.itrs_km for s in stations], dtype=np.float64)
    enu = np.ascontiguousarray([s.enu_matrix for s in stations], dtype=np.float64)
    ups = np.ascontiguousarray(enu[:, 2])
    t_ref = t0.tai
    span_s = float((t1 - t0).to_value(u.s))
    pad_max = float(steps.max())
    earth = EarthFixedMap(t_ref, -pad_max, span_s + pad_max + 1.0)
    clock = _Clock(t_ref, -pad_max, span_s + pad_max + 1.0)

    parts = []
    skipped = []
    near_sat = np.full(len(cat), _NEAR)
    t_end = np.full(len(cat), span_s)
    for h in np.unique(steps):
        idx = np.flatnonzero(steps == h)
        s_i, s_s, s_t, s_k, near, t_e, cut = _coarse_scan(
            cat, idx, float(h), clock, span_s, float(h), earth, sites, ups, horizon.sin_geo,
            secular, rho_min)
        parts.append((s_i, s_s, s_t, s_k))
        near_sat[idx] = near
        t_end[idx] = t_e
        skipped.extend((int(i), float(te)) for i, te in zip(idx[cut], t_e[cut], strict=True))
    # pairs above the threshold at t0 or at the end (on SGP4): WINDOW_START / WINDOW_END
    f_edge = _window_edges(cat, clock, earth, span_s, sites, ups, horizon, t_end)
    for col, kind in ((0, WINDOW_START), (1, WINDOW_END)):
        i_s, s_s = np.nonzero(f_edge[:, :, col] > 0.0)
        when = np.zeros(i_s.size) if col == 0 else t_end[i_s]
        parts.append((i_s, s_s, when, np.full(i_s.size, kind, dtype=np.int64)))
    sat_i = np.concatenate([p[0] for p in parts])
    sta_i = np.concatenate([p[1] for p in parts])
    t_s = np.concatenate([p[2] for p in parts])
    kind = np.concatenate([p[3] for p in parts])
    if skipped:
        names = ", ".join(f"{cat.names[i]!r} after {(t_ref + max(te, 0.0) * u.s).utc.isot}"
                          for i, te in skipped[:5])
        warnings.warn(
            f"SGP4 failed inside the window for {len(skipped)} satellite(s) ({names}"
            f"{', ...' if len(skipped) > 5 else ''}): decayed or invalid element sets, or sets "
            "run so far from their epochs that SGP4 left every Earth orbit; their events stop "
            "there.", RuntimeWarning, stacklevel=outside_stacklevel())
    ev = _correct(satrecs, sat_i, sta_i, t_s, kind, clock, earth, sites, ups, enu, horizon,
                  span_s, near_sat, steps)
    ev.el = horizon.apparent_rad(ev.el, ev.station, ev.rng)
    ev.elevation = horizon.label
    ev.earth = earth
    ev.clock = clock
    ev.skipped = skipped
    return ev


def _evaluate(satrecs, sat_i, sta_i, t_s, clock, earth, sites, ups, horizon, geometric=None):
    """SGP4 -> Earth-fixed state, and f, f' at the given events (``geometric``: see
    :meth:`Horizon.f <visviva.ground.horizon.Horizon.f>`)."""
    r, v, err = sgp4_teme(satrecs, sat_i, clock, t_s)
    ri, vi = earth.apply(r, v, t_s)
    fd = horizon.f(ri, vi, sites, ups, sta_i, geometric)
    return r, ri, vi, fd, err


def _correct(satrecs, sat_i, sta_i, t_s, kind, clock, earth, sites, ups, enu, horizon, span_s,
             near_sat, steps):
    """Correct every event on SGP4 itself; settle grazing passes; drop fakes.

    Three rounds, each one SGP4 evaluation of all events together:

    * maxima (culminations and near-maxima) move to the vertex of the parabola through ``f``
      at ``t - 1 s``, ``t``, ``t + 1 s`` (in the first two rounds; the third evaluates ``f``
      at the vertex). Positions only: SGP4's velocity is not exactly the
      derivative of its position (it leaves out the rates of some periodic terms: ~1 cm/s in
      LEO, more with the deep-space terms), which would move a flat culmination by seconds;
    * rises and sets take a Newton step on ``f`` (``f'`` from SGP4's velocity is only the
      slope; the root ``f = 0`` is a property of the positions).

    Then a maximum below the threshold on SGP4 is dropped (with its rise and set), and one
    above it by less than ``_NEAR`` is a grazing pass: its rise and set are re-seeded from
    the parabola, ``t_c -+ sqrt(2 f_c / k)`` with ``k = -f''``, and take three Newton steps.

    Maxima still moving by 0.5 s after two rounds (flat: a GEO's elevation changes 1e-6 deg
    in half an hour) take more steps (:func:`_flat_maxima`, at most ``h / 20``); two that meet are one.
    """
    t = t_s.copy()
    t_seed = t_s.copy()  # the scan's order of the events, for the orphans (see below)
    kind = kind.copy()
    delta = 1.0  # s, half-width of the parabola
    mi = np.flatnonzero((kind == _topo.CULMINATION) | (kind == _topo.NEAR_MAXIMUM))
    xi = np.flatnonzero((kind == _topo.RISE) | (kind == _topo.SET))
    fixed = np.flatnonzero(kind >= WINDOW_START)
    fixed = fixed[(kind[fixed] == WINDOW_START) | (kind[fixed] == WINDOW_END)]
    nm, nx = mi.size, xi.size
    f_c = np.empty(nm)
    k_c = np.empty(nm)
    state_r = np.empty((t.size, 3))
    state_v = np.empty((t.size, 3))
    ok_m = np.ones(nm, dtype=bool)
    inside = np.ones(nm, dtype=bool)
    clip_m = np.maximum(30.0, steps[sat_i[mi]] / 20.0)  # s
    for it in range(3):
        last = it == 2  # the last round needs f at the vertex only (k from the round before)
        idx = np.concatenate([mi, xi] + ([fixed] if last else []))
        side = [] if last else [t[mi] - delta, t[mi] + delta]
        tt = np.concatenate([t[mi], t[xi]] + ([t[fixed]] if last else []) + side)
        ii = np.concatenate([idx] + ([] if last else [mi, mi]))
        # the maxima's parabolas on the geometric elevation (its highest point); their f
        # at the vertex, in the last round, on the threshold's (apparent) one
        geometric = None
        if not last and horizon.refracted:
            geometric = np.zeros(ii.size, dtype=bool)
            geometric[:nm] = True
            geometric[idx.size:] = True
        _, ri, vi, fd, err = _evaluate(satrecs, sat_i[ii], sta_i[ii], tt, clock, earth, sites,
                                       ups, horizon, geometric)
        n0 = idx.size
        state_r[idx] = ri[:n0]
        state_v[idx] = vi[:n0]
        f0 = fd[:nm, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            step_x = -fd[nm:nm + nx, 0] / fd[nm:nm + nx, 1]
        if last:
            f_c = np.where(ok_m & inside & (err[:nm] == 0), f0, -1.0)
        else:
            fm = fd[n0:n0 + nm, 0]
            fp = fd[n0 + nm:, 0]
            ok_m = (err[:nm] == 0) & (err[n0:n0 + nm] == 0) & (err[n0 + nm:] == 0)
            curv = fm - 2.0 * f0 + fp
            k_c = -curv / delta**2
            with np.errstate(divide="ignore", invalid="ignore"):
                step_m = np.where(curv < 0, delta * (fm - fp) / (2.0 * curv), 0.0)
            step_m = np.where(ok_m & np.isfinite(step_m), np.clip(step_m, -clip_m, clip_m), 0.0)
            moved = t[mi] + step_m
            # a vertex outside the window (after the last parabola) is no culmination in it: the
            # window's edge stands for it
            inside = (moved > 0.0) & (moved < span_s)
            t[mi] = np.clip(moved, 0.0, span_s)
            if it == 1:
                _flat_maxima(mi[np.abs(step_m) > 0.5], t, mi, k_c, ok_m, inside, clip_m,
                             delta, span_s, (satrecs, sat_i, sta_i, clock, earth, sites, ups,
                                             horizon))
        ok_x = (err[nm:nm + nx] == 0) & np.isfinite(step_x)
        step_x = np.where(ok_x, np.clip(step_x, -30.0, 30.0), 0.0)
        t[xi] = np.clip(t[xi] + step_x, 0.0, span_s)
    # crossings of shallow passes (small f') may need a few more Newton steps
    pending = xi[np.abs(step_x) > 1e-4] if nx else xi
    for _ in range(6):
        if pending.size == 0:
            break
        _, ri, vi, fd, err = _evaluate(satrecs, sat_i[pending], sta_i[pending], t[pending],
                                       clock, earth, sites, ups, horizon)
        state_r[pending] = ri
        state_v[pending] = vi
        with np.errstate(divide="ignore", invalid="ignore"):
            step = -fd[:, 0] / fd[:, 1]
        step = np.where((err == 0) & np.isfinite(step), np.clip(step, -30.0, 30.0), 0.0)
        t[pending] = np.clip(t[pending] + step, 0.0, span_s)
        moving = (np.abs(step) > 1e-4) & (t[pending] > 0.0) & (t[pending] < span_s)
        pending = pending[moving]  # converged, or pushed to the window's edge (dropped below)
    # a crossing pushed to the window's edge is not one (the edge pseudo-events tell that)
    edge_x = xi[(t[xi] <= 0.0) | (t[xi] >= span_s)]
    keep = np.ones(t.size, dtype=bool)
    keep[edge_x] = False
    keep[mi[f_c <= 0.0]] = False
    kind[mi[f_c > 0.0]] = _topo.CULMINATION
    graze = np.flatnonzero((f_c > 0.0) & (f_c < near_sat[sat_i[mi]]) & (k_c > 0.0))
    if graze.size:
        new = []
        cross = (kind == _topo.RISE) | (kind == _topo.SET)
        for g in graze:  # few: maxima within ~0.3 deg of the threshold
            e = mi[g]
            half = float(np.sqrt(2.0 * f_c[g] / k_c[g]))
            keep[cross & (sat_i == sat_i[e]) & (sta_i == sta_i[e])
                 & (np.abs(t - t[e]) < half + 120.0)] = False
            # in the scan's order (the orphans below) the new crossings sit either side of
            # the culmination's scan time, which can be a second off its vertex: placed by
            # their own times, the crossings of a pass shorter than that (a threshold within
            # 1e-3 deg of a high pass's maximum) came out as an orphan pair and were dropped
            new += [(sat_i[e], sta_i[e], when, kk, t_seed[e] + sign * half)
                    for when, kk, sign in ((t[e] - half, _topo.RISE, -1.0),
                                           (t[e] + half, _topo.SET, 1.0))
                    if 0.0 < when < span_s]
        if new:
            ns_, nt_, nw_, nk_, seed_ = (np.array(c) for c in zip(*new, strict=True))
            nw_ = nw_.astype(np.float64)
            t_seed = np.concatenate([t_seed, seed_.astype(np.float64)])
            for _ in range(5):
                _, ri, vi, fd, err = _evaluate(satrecs, ns_, nt_, nw_, clock, earth, sites, ups,
                                               horizon)
                with np.errstate(divide="ignore", invalid="ignore"):
                    step = -fd[:, 0] / fd[:, 1]
                nw_ = np.clip(nw_ + np.where((err == 0) & np.isfinite(step),
                                             np.clip(step, -30.0, 30.0), 0.0), 0.0, span_s)
            sat_i = np.concatenate([sat_i, ns_])
            sta_i = np.concatenate([sta_i, nt_])
            t = np.concatenate([t, nw_])
            kind = np.concatenate([kind, nk_.astype(np.int64)])
            keep = np.concatenate([keep, np.ones(nw_.size, dtype=bool)])
            state_r = np.concatenate([state_r, ri])
            state_v = np.concatenate([state_v, vi])
    # a rise and a set left with no culmination between them: in the scan's order too, since
    # Newton steps on a pass that does not reach the threshold (no root) can carry its rise
    # past its set (a "set, rise" pair with no culmination, kept before)
    # a crossing the scan found past the window's edge (its margin) whose Newton steps went
    # in may have reached the other crossing of a short pass (a rise before t0 on the set
    # after it): its elevation rate has the wrong sign; the edge pseudo-events stand for it
    out = np.flatnonzero(keep & ((kind == _topo.RISE) | (kind == _topo.SET))
                         & ((t_seed < 0.0) | (t_seed > span_s)))
    if out.size:
        rates = np.empty((out.size, 6))
        _topo.razel_many(np.ascontiguousarray(state_r[out] - sites[sta_i[out]]),
                         np.ascontiguousarray(state_v[out]), enu,
                         np.ascontiguousarray(sta_i[out], dtype=np.int64), rates)
        keep[out[np.where(kind[out] == _topo.RISE, rates[:, 5] < 0.0, rates[:, 5] > 0.0)]] = False
    # maxima that met on their way to the same vertex (flat ones, above) are one
    cm = np.flatnonzero(keep & (kind == _topo.CULMINATION))
    cm = cm[np.lexsort((t[cm], sta_i[cm], sat_i[cm]))]
    keep[cm[1:][(sat_i[cm[1:]] == sat_i[cm[:-1]]) & (sta_i[cm[1:]] == sta_i[cm[:-1]])
                & (t[cm[1:]] - t[cm[:-1]] < 1.0)]] = False
    keep &= ~_orphans(sat_i, sta_i, t, kind, keep)
    keep &= ~_orphans(sat_i, sta_i, t_seed, kind, keep)
    keep &= (kind <= _topo.SET) | (kind == WINDOW_START) | (kind == WINDOW_END)
    sel = np.flatnonzero(keep)
    sat_i, sta_i, t, kind = sat_i[sel], sta_i[sel], t[sel], kind[sel]
    ri, vi = state_r[sel], state_v[sel]
    rho = ri - sites[sta_i]
    res = np.empty((t.size, 6))
    _topo.razel_many(np.ascontiguousarray(rho), np.ascontiguousarray(vi), enu,
                     np.ascontiguousarray(sta_i, dtype=np.int64), res)
    order = np.lexsort((kind, t, sta_i, sat_i))
    return EventSet(sat=sat_i[order], station=sta_i[order], kind=kind[order], t_s=t[order],
                    t_ref=clock.t_ref, rng=res[order, 0], az=res[order, 1], el=res[order, 2],
                    rng_rate=res[order, 3], r_itrs=ri[order])


def _flat_maxima(todo, t, mi, k_c, ok_m, inside, clip_m, delta, span_s, geo) -> None:
    """Up to 40 more parabola steps for maxima ``todo``; ``t``, ``k_c``, ... in place."""
    satrecs, sat_i, sta_i, clock, earth, sites, ups, horizon = geo
    pos = np.searchsorted(mi, todo)  # (mi is sorted: flatnonzero)
    for _ in range(40):
        pos = pos[ok_m[pos] & inside[pos]]
        if pos.size == 0:
            return
        e = mi[pos]
        tt = np.concatenate([t[e], t[e] - delta, t[e] + delta])
        ii = np.concatenate([e, e, e])
        geometric = np.ones(ii.size, dtype=bool) if horizon.refracted else None
        fd, err = _evaluate(satrecs, sat_i[ii], sta_i[ii], tt, clock, earth, sites, ups,
                            horizon, geometric)[3:]
        f0, fm, fp = fd[:, 0].reshape(3, -1)
        curv = fm - 2.0 * f0 + fp
        ok_m[pos] &= (err.reshape(3, -1) == 0).all(axis=0)
        ok = ok_m[pos] & (curv < 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(ok, delta * (fm - fp) / (2.0 * curv), 0.0)
        step = np.clip(np.where(np.isfinite(step), step, 0.0), -clip_m[pos], clip_m[pos])
        k_c[pos] = np.where(ok_m[pos], -curv / delta**2, k_c[pos])
        moved = t[e] + step
        inside[pos] = (moved > 0.0) & (moved < span_s)
        t[e] = np.clip(moved, 0.0, span_s)
        pos = pos[np.abs(step) > 1e-3]


def _orphans(sat_i, sta_i, t, kind, keep) -> np.ndarray:
    """Rises and sets left with no culmination between them after grazing culminations went."""
    out = np.zeros(t.size, dtype=bool)
    order = np.lexsort((kind, t, sta_i, sat_i))
    o = order[keep[order]]
    a, b = o[:-1], o[1:]
    pair = ((sat_i[a] == sat_i[b]) & (sta_i[a] == sta_i[b]) & (kind[a] == _topo.RISE)
            & (kind[b] == _topo.SET))
    out[a[pair]] = True
    out[b[pair]] = True
    return out
