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
from .search import (
    WINDOW_END,
    WINDOW_START,
    as_catalog,
    check_window,
    min_elevation_rad,
    search_events,
)
from .station import as_stations

__all__ = ["find_passes", "write_passes"]


def find_passes(satellites, stations, t0, t1, min_elevation=0.0 * u.deg, *,
                standard_magnitude=None):
    """Every pass of every satellite over every station in a window, as a table.

    Parameters
    ----------
    satellites : Satellite, Catalog or list of Satellite
    stations : GroundStation or list of GroundStation
    t0, t1 : astropy Time
        The window (scalars, ``t1 > t0``).
    min_elevation : Quantity (angle)
        The elevation a pass must exceed, in [-90, 90] deg (default 0 deg).
    standard_magnitude : float or array_like (mag), optional
        Standard visual magnitude (at 1000 km, 90 deg phase) of all satellites or of each; adds
        a ``magnitude`` column (estimate at culmination, masked when in the umbra).

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
        ``station_dark`` (Sun below -6 deg at the station) and ``visible`` (``sunlit`` and
        ``station_dark``).

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
    cat = as_catalog(satellites)
    sts = as_stations(stations)
    t0, t1 = check_window(t0, t1)
    el_min = min_elevation_rad(min_elevation)
    if standard_magnitude is not None:
        from .visibility import standard_magnitudes

        standard_magnitude = standard_magnitudes(standard_magnitude, len(cat))
    ev = search_events(cat, sts, t0, t1, el_min)
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

    def masked_time(idx, ok):
        t = times[idx].copy() if idx.size else Time([], format="jd", scale="utc")
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
        "visible": sunlit & dark,
    }
    if standard_magnitude is not None:
        m_std = standard_magnitude  # checked by find_passes
        sat_r = ev.r_itrs[top]
        to_sun = sun - sat_r
        to_obs = site - sat_r
        cosphi = np.sum(to_sun * to_obs, -1) / (np.linalg.norm(to_sun, axis=-1)
                                                * np.linalg.norm(to_obs, axis=-1))
        mag = visual_magnitude(m_std[ev.sat[top]], ev.rng[top],
                               np.arccos(np.clip(cosphi, -1, 1)))
        cols["magnitude"] = Masked(mag * u.mag, mask=~sunlit | ~np.isfinite(mag))
    table = QTable(cols)
    sort_key = np.argsort(ev.t_s[starts], kind="stable")
    table = table[sort_key]
    table.meta.update({"t0": t0.utc.isot, "t1": t1.utc.isot})
    return table


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
        ECSV keeps units and masks; CSV writes ISO times and plain numbers (empty where
        masked).
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
    text = io.StringIO()
    out.write(text, format="ascii.ecsv" if fmt == "ecsv" else "ascii.csv")
    if hasattr(path, "write"):  # an open text file (as astropy's writer takes)
        path.write(text.getvalue())
    else:
        replace_text_file(path, text.getvalue())
