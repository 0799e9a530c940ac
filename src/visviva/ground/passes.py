"""Rise, culmination and set events, and pass tables for catalogues x ground stations.

:func:`find_passes` and :meth:`GroundStation.find_events <visviva.GroundStation.find_events>`
share one search (:mod:`visviva.ground.search`): SGP4 at coarse nodes for the whole catalogue,
one compiled scan of every (satellite, station) pair, and a final correction of each event on
SGP4. A pass table has one row per pass, with the visibility columns of
:mod:`visviva.ground.visibility`.
"""

from __future__ import annotations

import io

import numpy as np
from astropy import units as u
from astropy.time import Time

from .._text import replace_text_file
from ..core import topocentric as _topo
from ..errors import InvalidInputError
from .mask import station_thresholds
from .masked_search import search_masked
from .search import (
    WINDOW_END,
    WINDOW_START,
    EventSet,
    as_catalog,
    check_window,
)
from .station import as_stations

__all__ = ["find_passes", "write_passes"]


def find_passes(satellites, stations, t0, t1, min_elevation=0.0 * u.deg, *,
                standard_magnitude=None, refraction=False):
    """Every pass of every satellite over every station in a window, as a table.

    Parameters
    ----------
    satellites : Satellite, Catalog or list of Satellite
    stations : GroundStation or list of GroundStation
    t0, t1 : astropy Time
        The window (scalars, ``t1 > t0``).
    min_elevation : Quantity (angle), ElevationMask, or list of them
        The elevation a pass must exceed, in [-90, 90] deg (default 0 deg); an
        :class:`~visviva.ground.mask.ElevationMask` (a terrain / elevation mask: the minimum
        elevation per azimuth) for every station; or a list with one Quantity or mask per
        station, in the stations' order. With a mask, passes rise and set where the
        satellite crosses it, and a pass that dips under it in its middle is two passes
        (:mod:`visviva.ground.masked_search`).
    standard_magnitude : float or array_like (mag), optional
        Standard visual magnitude (at 1000 km, 90 deg phase) of all satellites or of each; adds
        a ``magnitude`` column (estimate at culmination, masked when in the umbra, dimmed in
        the penumbra by the part of the Sun's disc the satellite sees).
    refraction : bool, {"optical", "radio"} or dict
        Rise and set on the APPARENT horizon: where the refracted elevation (as
        :func:`visviva.ground.look.look` gives it with the same ``refraction``: False, True or
        ``"optical"``, ``"radio"``, or a weather dict; each station's air at its height)
        crosses ``min_elevation``. False (default): the geometric elevation. Refraction
        raises the satellite: the rise comes earlier and the set later, by the refraction at
        the threshold over the elevation rate (about 20-30 s in LEO at 0 deg); the
        culmination is the same. A ``min_elevation`` below the lowest apparent elevation the
        model covers (optical: that of -1 deg geometric, about -0.36 deg at sea level; radio:
        -1 deg) is refused.

    Returns
    -------
    astropy.table.QTable
        One row per pass per (satellite, station), sorted by rise time (a pass already under
        way at ``t0`` sorts at ``t0``). Columns: ``satellite``, ``satnum``, ``station``,
        ``rise_time``, ``culmination_time``, ``set_time`` (UTC Time, masked where the window
        cuts the pass, or for ``culmination_time`` when the highest point is at the window's
        edge), ``duration`` (s, masked when cut), ``max_elevation`` (deg),
        ``culmination_azimuth`` (deg), ``culmination_range`` (km), ``rise_azimuth``,
        ``set_azimuth`` (deg, masked when cut), ``sunlit`` (the satellite is outside the
        Earth's umbra at the highest point), ``sun_fraction`` (of the solar disc seen from
        the satellite there: 1 sunlit, 0 umbra), ``sun_elevation`` (deg, at the station),
        ``station_dark`` (Sun below -6 deg at the station; all four at the highest point)
        and ``visible`` (the satellite is sunlit while the station is dark at some time of
        the pass, sampled every 10 s: an evening pass that enters the shadow before its
        culmination is visible on its way up), ``visible_start`` and ``visible_end`` (UTC
        Time: the first and last such time, to 0.01 s, masked when not visible; the penumbra
        counts as sunlit). ``max_elevation`` is apparent with
        ``refraction`` (its column description and ``table.meta["elevation"]`` say which:
        ``"geometric"`` or ``"apparent (optical refraction)"`` / ``"apparent (radio
        refraction)"``); ``sun_elevation`` is always geometric.

    Notes
    -----
    Every event time is within 0.1 s of the true crossing of SGP4's trajectory (in practice
    ~1e-6 deg in elevation after the final Newton steps; see :mod:`visviva.ground.search`). The
    first call compiles the scan kernel (a few seconds, then cached on disk). Satellites whose
    SGP4 fails inside the window (decayed) are left out with a ``RuntimeWarning``.

    Examples
    --------
    >>> import visviva as vv
    >>> from astropy import units as u
    >>> from astropy.time import Time
    >>> iss = vv.Satellite.from_tle(
    ...     "1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927",
    ...     "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537", name="ISS")
    >>> site = vv.GroundStation(40.0 * u.deg, -75.0 * u.deg, name="Philadelphia")
    >>> t0 = Time("2008-09-20T12:00:00", scale="utc")
    >>> passes = vv.find_passes(iss, site, t0, t0 + 1 * u.day, min_elevation=10 * u.deg)
    >>> len(passes)
    5
    """
    return passes_of(satellites, stations, t0, t1, min_elevation, standard_magnitude,
                     refraction, warn_stale=True)


def passes_of(satellites, stations, t0, t1, min_elevation, standard_magnitude, refraction,
              warn_stale: bool):
    """:func:`find_passes`, stale element sets warned when ``warn_stale``
    (:func:`~visviva.ground.search.search_events`); False for a chunk of a catalogue whose
    caller warned once, whole (:func:`~visviva.ground.dask_passes.find_passes_dask`)."""
    cat = as_catalog(satellites)
    sts = as_stations(stations)
    t0, t1 = check_window(t0, t1)
    flat_rad, masks = station_thresholds(min_elevation, len(sts))
    if standard_magnitude is not None:
        from .visibility import standard_magnitudes

        standard_magnitude = standard_magnitudes(standard_magnitude, len(cat))
    ev = search_masked(cat, sts, t0, t1, flat_rad, masks, refraction, warn_stale=warn_stale)
    return _pass_table(cat, sts, ev, t0, t1, standard_magnitude)


def _pass_table(cat, sts, ev, t0, t1, standard_magnitude):
    from astropy.table import QTable
    from astropy.utils.masked import Masked

    from .visibility import (
        DARK_SUN_ELEVATION_DEG,
        sun_elevation_rad,
        sun_fraction,
        sun_itrs_km,
        visual_magnitude,
    )

    kind = ev.kind
    new_pair = np.ones(kind.size, dtype=bool)
    new_pair[1:] = (np.diff(ev.sat) != 0) | (np.diff(ev.station) != 0)
    # a pass begins at a rise, at the window's start, or (defensively) at a pair's first event
    begin = (kind == _topo.RISE) | (kind == WINDOW_START) | new_pair
    pid = np.cumsum(begin) - 1  # pass id of each event (events sorted by pair, then time)
    starts = np.flatnonzero(begin)
    npass = starts.size
    ends_mask = (kind == _topo.SET) | (kind == WINDOW_END)
    # the last event of each pass (the set, or the window's end)
    last = np.r_[starts[1:], kind.size] - 1 if npass else np.empty(0, dtype=np.int64)
    # highest event of each pass (a culmination, or an edge of the window)
    order = np.lexsort((ev.el, pid))
    top = order[np.r_[np.flatnonzero(np.diff(pid[order])), pid.size - 1]] if npass else last
    rise_ok = kind[starts] == _topo.RISE
    set_ok = (kind[last] == _topo.SET) & ends_mask[last]
    culm_ok = kind[top] == _topo.CULMINATION

    times = ev.times()
    sun = sun_itrs_km(ev.t_ref, ev.t_s[top], ev.earth)
    frac = sun_fraction(ev.r_itrs[top], sun) if npass else np.empty(0)
    site = np.array([s.itrs_km for s in sts])[ev.station[top]]
    up = np.array([s.enu_matrix[2] for s in sts])[ev.station[top]]
    sun_el = np.degrees(sun_elevation_rad(site, up, sun)) if npass else np.empty(0)
    sunlit = frac > 0.0
    dark = sun_el < DARK_SUN_ELEVATION_DEG

    visible, vis_first, vis_last = _seen_in_pass(cat, sts, ev, starts, top, last)

    def masked_time(idx, ok, t_s=None):
        if t_s is not None:  # times of their own (seconds after t_ref), not events'
            t_s = np.where(ok, t_s, ev.t_s[idx])
            at = EventSet(t_s=t_s, t_ref=ev.t_ref, clock=ev.clock).times()
        t = (times[idx].copy() if t_s is None else at) if idx.size else Time(
            [], format="jd", scale="utc")
        if idx.size and (~ok).any():
            t[~ok] = np.ma.masked
        return t

    deg = np.degrees
    cols = {
        "satellite": np.array(cat.names, dtype=object)[ev.sat[starts]].astype(str),
        "satnum": np.asarray(cat.satnums)[ev.sat[starts]],
        "station": np.array([s.name for s in sts], dtype=object)[ev.station[starts]].astype(str),
        "rise_time": masked_time(starts, rise_ok),
        "culmination_time": masked_time(top, culm_ok),
        "set_time": masked_time(last, set_ok),
        "duration": Masked((ev.t_s[last] - ev.t_s[starts]) * u.s, mask=~(rise_ok & set_ok)),
        "max_elevation": deg(ev.el[top]) * u.deg,
        "culmination_azimuth": deg(ev.az[top]) * u.deg,
        "culmination_range": ev.rng[top] * u.km,
        "rise_azimuth": Masked(deg(ev.az[starts]) * u.deg, mask=~rise_ok),
        "set_azimuth": Masked(deg(ev.az[last]) * u.deg, mask=~set_ok),
        "sunlit": sunlit,
        "sun_fraction": frac,
        "sun_elevation": sun_el * u.deg,
        "station_dark": dark,
        "visible": visible,
        "visible_start": masked_time(starts, visible, vis_first),
        "visible_end": masked_time(starts, visible, vis_last),
    }
    if standard_magnitude is not None:
        m_std = standard_magnitude  # checked by find_passes
        sat_r = ev.r_itrs[top]
        to_sun = sun - sat_r
        to_obs = site - sat_r
        cosphi = np.sum(to_sun * to_obs, -1) / (np.linalg.norm(to_sun, axis=-1)
                                                * np.linalg.norm(to_obs, axis=-1))
        mag = visual_magnitude(m_std[ev.sat[top]], ev.rng[top],
                               np.arccos(np.clip(cosphi, -1, 1)), np.clip(frac, 0.0, 1.0))
        cols["magnitude"] = Masked(mag * u.mag, mask=~sunlit | ~np.isfinite(mag))
    table = QTable(cols)
    sort_key = np.argsort(ev.t_s[starts], kind="stable")
    table = table[sort_key]
    table.meta.update({"t0": t0.utc.isot, "t1": t1.utc.isot})
    describe_elevations(table, ev.elevation)
    return table


def describe_elevations(table, elevation: str) -> None:
    """Say in ``table`` which elevations it holds (``elevation``: ``"geometric"`` or
    ``"apparent (... refraction)"``): ``meta["elevation"]`` and the column descriptions."""
    table["max_elevation"].info.description = f"{elevation} elevation at culmination"
    table["sun_elevation"].info.description = "geometric elevation of the Sun at culmination"
    table.meta["elevation"] = elevation


#: sampling step of the visibility test along a pass, s
VISIBILITY_STEP_S = 10.0
#: passes longer than this (s) are always sampled for visibility (see _seen_in_pass)
LONG_PASS_S = 1800.0
#: most samples of one pass (longer passes get a longer step) and of one chunk of passes
MAX_PASS_SAMPLES = 2000
CHUNK_SAMPLES = 400_000
#: most samples of a long pass already seen visible at one of its events (for the edges of
#: the visible part: every 9 s in a 30 min pass, 7 min in a day of a geosynchronous one)
MAX_EDGE_SAMPLES = 200


def _lit_and_dark(satrecs, ev, sites, ups, sat, sta, t_s) -> np.ndarray:
    """Per time: is satellite ``sat[k]`` sunlit (``sun_fraction > 0``) while station ``sta[k]``
    is dark (Sun below -6 deg) at ``t_s[k]`` (s after ``ev.t_ref``)? SGP4 where it is dark."""
    from .search import sgp4_teme
    from .visibility import DARK_SUN_ELEVATION_DEG, sun_elevation_rad, sun_fraction, sun_itrs_km

    out = np.zeros(t_s.size, dtype=bool)
    if t_s.size == 0:
        return out
    sun = sun_itrs_km(ev.t_ref, t_s, ev.earth)
    k = np.flatnonzero(np.degrees(sun_elevation_rad(sites[sta], ups[sta], sun))
                       < DARK_SUN_ELEVATION_DEG)
    if k.size:
        r, _, err = sgp4_teme(satrecs, sat[k], ev.clock, t_s[k])
        ok = err == 0
        r_i, _ = ev.earth.apply(np.where(ok[:, None], r, 1e4), np.zeros_like(r), t_s[k])
        out[k] = ok & (sun_fraction(r_i, sun[k]) > 0.0)
    return out


def _pass_samples(t_a, t_b, t_top, most):
    """Sample times of passes (every :data:`VISIBILITY_STEP_S` from ``t_a`` to ``t_b``, at most
    ``most`` per pass, and the highest point ``t_top``), in chunks of about
    :data:`CHUNK_SAMPLES`: yields (pass numbers, sample times) sorted by pass, then time."""
    n = np.minimum(np.ceil((t_b - t_a) / VISIBILITY_STEP_S).astype(np.int64), most - 1)
    n = np.maximum(n, 1) + 1
    bounds = np.searchsorted(np.cumsum(n), np.arange(CHUNK_SAMPLES, n.sum(), CHUNK_SAMPLES))
    for chunk in np.split(np.arange(t_a.size), np.unique(bounds[bounds > 0])):
        if chunk.size == 0:
            continue
        nc = n[chunk]
        pid = np.repeat(chunk, nc)
        frac_k = (np.arange(pid.size) - np.repeat(np.cumsum(nc) - nc, nc)) / np.repeat(nc - 1, nc)
        t_s = np.concatenate([t_a[pid] + frac_k * (t_b - t_a)[pid], t_top[chunk]])
        pid = np.concatenate([pid, chunk])
        order = np.lexsort((t_s, pid))
        yield pid[order], t_s[order]


def _seen_in_pass(cat, sts, ev, starts, top, last):
    """Per pass: is the satellite sunlit while the station is dark at some time of it, and
    the first and last such time (s after ``ev.t_ref``; NaN where never)?

    Tested first at the pass's first, highest and last events. In a pass shorter than
    :data:`LONG_PASS_S` twilight moves one way and the satellite crosses the Earth's shadow at
    most once, so the visible part is one interval: found at one of those events, its ends
    are bisected between them; missed there, it lies inside the pass only when the satellite
    is lit at one event and the station dark at another. Those passes, and long (MEO, HEO)
    ones, are sampled every :data:`VISIBILITY_STEP_S` (SGP4 where the station is dark), and
    the first and last visible samples' edges bisected. Edges to :data:`VISIBLE_EDGE_TOL_S`;
    in a sampled pass a visible stretch shorter than the step can be missed, and in a long
    pass the satellite may be hidden for a while between the first and last visible times.
    """
    npass = starts.size
    first = np.full(npass, np.nan)
    final = np.full(npass, np.nan)
    if npass == 0:
        return np.zeros(0, dtype=bool), first, final
    satrecs = [s.satrec for s in cat.satellites]
    sites = np.array([s.itrs_km for s in sts])
    ups = np.array([s.enu_matrix[2] for s in sts])
    idx = np.stack([starts, top, last])  # (3, npass), in time order
    lit, dark = _lit_and_dark_events(ev, sites, ups, idx)
    seen3 = lit & dark
    out = seen3.any(axis=0)
    long_pass = ev.t_s[last] - ev.t_s[starts] > LONG_PASS_S
    sampled = (~out & np.any(lit, axis=0) & np.any(dark, axis=0)) | long_pass
    # brackets (pass, 0 first / 1 last, t seen, t not seen; equal: the pass's own edge)
    brackets = []
    short = np.flatnonzero(out & ~long_pass)
    if short.size:
        t3 = ev.t_s[idx[:, short]]
        s3 = seen3[:, short]
        k_first = np.argmax(s3, axis=0)
        k_last = 2 - np.argmax(s3[::-1], axis=0)
        cols = np.arange(short.size)
        brackets += [(short, 0, t3[k_first, cols], t3[0]), (short, 1, t3[k_last, cols], t3[2])]
    todo = np.flatnonzero(sampled)
    t_a, t_b, t_top = ev.t_s[starts[todo]], ev.t_s[last[todo]], ev.t_s[top[todo]]
    sat, sta = ev.sat[starts[todo]], ev.station[starts[todo]]
    # a long pass seen at an event is sampled for its edges only: MAX_EDGE_SAMPLES
    most = np.where(out[todo], MAX_EDGE_SAMPLES, MAX_PASS_SAMPLES)
    for pid, t_s in _pass_samples(t_a, t_b, t_top, most):
        seen = _lit_and_dark(satrecs, ev, sites, ups, sat[pid], sta[pid], t_s)
        hit = np.flatnonzero(seen)
        if hit.size == 0:
            continue
        p_hit = pid[hit]
        for which, k, step in ((0, hit[np.r_[True, p_hit[1:] != p_hit[:-1]]], -1),
                               (1, hit[np.r_[p_hit[1:] != p_hit[:-1], True]], 1)):
            nb = np.clip(k + step, 0, pid.size - 1)  # the unseen neighbour, in the same pass
            nb = np.where(pid[nb] == pid[k], nb, k)
            brackets.append((todo[pid[k]], which, t_s[k], t_s[nb]))
    if not brackets:
        return out, first, final
    p = np.concatenate([b[0] for b in brackets])
    which = np.concatenate([np.full(b[0].size, b[1]) for b in brackets])
    t_in = np.concatenate([b[2] for b in brackets])
    t_out = np.concatenate([b[3] for b in brackets])
    edge = _bisect_visible(satrecs, ev, sites, ups, ev.sat[starts[p]], ev.station[starts[p]],
                           t_in, t_out)
    out[p] = True
    first[p[which == 0]] = edge[which == 0]
    final[p[which == 1]] = edge[which == 1]
    return out, first, final


def _lit_and_dark_events(ev, sites, ups, idx):
    """Sunlit and dark flags at the events ``idx`` (their stored Earth-fixed positions)."""
    from .visibility import DARK_SUN_ELEVATION_DEG, sun_elevation_rad, sun_fraction, sun_itrs_km

    sta = ev.station[idx]
    sun = sun_itrs_km(ev.t_ref, ev.t_s[idx], ev.earth)
    el = np.degrees(sun_elevation_rad(sites[sta], ups[sta], sun))
    return sun_fraction(ev.r_itrs[idx], sun) > 0.0, el < DARK_SUN_ELEVATION_DEG


#: the first and last visible times of a pass are found to this, s
VISIBLE_EDGE_TOL_S = 0.01


def _visible_margin(satrecs, ev, sites, ups, sat, sta, t_s) -> np.ndarray:
    """A continuous margin, > 0 exactly where :func:`_lit_and_dark` is True (rad): the smaller
    of the shadow's (the apparent separation of the Earth's and the Sun's centres seen from
    the satellite, less the radii's difference: ``sun_fraction > 0`` beyond it) and the
    twilight's (-6 deg less the Sun's elevation)."""
    from ..constants import R_EARTH_KM, R_SUN_KM
    from .search import sgp4_teme
    from .visibility import DARK_SUN_ELEVATION_DEG, sun_elevation_rad, sun_itrs_km

    sun = sun_itrs_km(ev.t_ref, t_s, ev.earth)
    r, _, err = sgp4_teme(satrecs, sat, ev.clock, t_s)
    r, _ = ev.earth.apply(np.where(err[:, None] == 0, r, 1e4), np.zeros_like(r), t_s)
    d = sun - r
    rn, dn = np.linalg.norm(r, axis=-1), np.linalg.norm(d, axis=-1)
    c = np.arccos(np.clip(-np.sum(r * d, axis=-1) / (rn * dn), -1.0, 1.0))
    shadow = c - (np.arcsin(np.minimum(1.0, R_EARTH_KM / rn))
                  - np.arcsin(np.minimum(1.0, R_SUN_KM / dn)))
    dark = np.radians(DARK_SUN_ELEVATION_DEG) - sun_elevation_rad(sites[sta], ups[sta], sun)
    return np.where(err == 0, np.minimum(shadow, dark), -1.0)


def _bisect_visible(satrecs, ev, sites, ups, sat, sta, t_in, t_out):
    """The edge of the visible part between ``t_in`` (visible) and ``t_out`` (not; equal: no
    edge, the sample is the pass's own edge): regula falsi (Illinois) on
    :func:`_visible_margin`, to :data:`VISIBLE_EDGE_TOL_S`; about five SGP4 rounds."""
    t_in, t_out = t_in.copy(), t_out.copy()
    todo = np.flatnonzero(t_in != t_out)
    if todo.size == 0:
        return t_in

    def margin(k, t):
        return _visible_margin(satrecs, ev, sites, ups, sat[k], sta[k], t)

    both = margin(np.r_[todo, todo], np.r_[t_in[todo], t_out[todo]])
    g_in, g_out = both[:todo.size], np.minimum(both[todo.size:], 0.0)
    g_in = np.maximum(g_in, 1e-15)  # (visible by the samples' test: > 0)
    side = np.zeros(todo.size, dtype=np.int64)  # which end moved last: +1 in, -1 out
    for _ in range(40):
        wide = np.abs(t_out[todo] - t_in[todo]) > VISIBLE_EDGE_TOL_S
        if not wide.any():
            break
        k = todo[wide]
        a, b, ga, gb = t_in[k], t_out[k], g_in[wide], g_out[wide]
        t = a + ga * (b - a) / (ga - gb)
        # stay inside, and at least a tolerance from either end (a clear bracket shrink)
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        t = np.clip(t, lo + 0.4 * VISIBLE_EDGE_TOL_S, hi - 0.4 * VISIBLE_EDGE_TOL_S)
        g = margin(k, t)
        seen = g > 0.0
        sw = side[wide]
        # Illinois: the end that stays twice in a row has its margin halved
        g_in[wide] = np.where(seen, g, np.where(sw == -1, 0.5 * ga, ga))
        g_out[wide] = np.where(seen, np.where(sw == 1, 0.5 * gb, gb), g)
        t_in[k] = np.where(seen, t, a)
        t_out[k] = np.where(seen, b, t)
        side[wide] = np.where(seen, 1, -1)
    return 0.5 * (t_in + t_out)


def write_passes(table, path, format: str | None = None) -> None:
    """Write a pass table to CSV or ECSV (``format`` from the suffix when not given).

    Parameters
    ----------
    table : astropy.table.QTable
        A table from :func:`find_passes`.
    path : str, path-like or text file object
        The file to write (replaced in one step: an interrupted write leaves no partial file),
        or an open text file to write into (then ``format`` is required).
    format : {"csv", "ecsv"}, optional
        ECSV keeps units, masks, time scales and the times to the nanosecond (ISO with nine
        decimals; read back with ``QTable.read``); CSV writes ISO times to the millisecond and
        plain numbers (empty where masked).
    """
    from pathlib import Path

    fmt = format or Path(path).suffix.lstrip(".").lower()
    if fmt not in ("csv", "ecsv"):
        raise InvalidInputError(f"format must be 'csv' or 'ecsv' (or a .csv/.ecsv file name); "
                                f"got {fmt!r}.")
    out = table.copy()
    for name in out.colnames:
        if isinstance(out[name], Time):
            out[name].format = "isot"
            if fmt == "ecsv":  # (astropy's default, 3 decimals, cut the times to the ms)
                out[name].precision = 9
    text = io.StringIO()
    out.write(text, format="ascii.ecsv" if fmt == "ecsv" else "ascii.csv")
    if hasattr(path, "write"):  # an open text file (as astropy's writer takes)
        path.write(text.getvalue())
    else:
        replace_text_file(path, text.getvalue())
