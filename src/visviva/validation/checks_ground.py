"""Ground stations: look angles, range rate, passes and elevation masks against Skyfield.

* ``GroundStation.look`` (azimuth, elevation, range, range rate) of SGP4 satellites (ISS, Molniya)
  from three stations every 5 min over a day, against Skyfield's ``(EarthSatellite -
  wgs84.latlon).at(t).altaz()`` and ``frame_latlon_and_rates``. Like with like: Skyfield's
  builtin timescale has no polar motion, so the same offline IERS table astropy uses is
  installed into it (without it the two differ by the polar motion itself: 1.6" and 14 m), and
  Skyfield times are built from astropy's two-part Julian dates (``ts.from_astropy`` sums them
  into one float: ~20 us, 0.15 m in LEO); both through :mod:`._skyfield`.
* ``vv.find_passes`` / ``GroundStation.find_events`` rise, culmination and set times for the
  ISS, a Molniya and a never-setting GEO against Skyfield's ``find_events`` (the same event
  sequence; times to its half-second search epsilon) and against the crossings and maxima of
  Skyfield's own altitude function refined around each event.
* A flat ``vv.ElevationMask`` (four points at one elevation) against the scalar threshold:
  the same passes, bit for bit.
* A bumpy ``vv.ElevationMask`` (hills, a peak, a building's vertical edge) over one day of the
  ISS against a brute force on Skyfield's altitude and azimuth: ``el - mask(az)`` sampled every
  second through Skyfield's passes above the mask's lowest point, each sign change bisected to
  1e-4 s.
"""

from __future__ import annotations

import numpy as np

from ._skyfield import sky_time, timescale
from .base import Check

__all__ = ["checks"]

ARCSEC_DEG = 1.0 / 3600.0
SITES = ((40.0, -75.0, 50.0), (-33.9, 18.4, 100.0), (67.9, 21.1, 400.0))  # deg, deg, m
_WHY_UT1 = ("both sides use SGP4 in TEME, the IAU 2006/2000A precession-nutation and the same "
            "polar motion; what is left is UT1-UTC, interpolated from Skyfield's builtin "
            "finals table and from astropy-iers-data: up to 0.03 ms apart at these dates, "
            "which moves a station by up to 1.4 cm")


def _ref() -> str:
    import skyfield

    return (f"skyfield {skyfield.__version__} EarthSatellite - wgs84.latlon (builtin timescale, "
            "astropy-iers-data polar motion)")


def _look(ts) -> list[Check]:
    from astropy import units as u
    from skyfield.api import EarthSatellite, wgs84

    import visviva as vv

    from .checks_satellites import ISS, MOLNIYA

    worst = {"angle": 0.0, "range": 0.0, "rate": 0.0}
    n = 0
    for l1, l2 in (ISS, MOLNIYA):
        sat = vv.Satellite.from_tle(l1, l2)
        es = EarthSatellite(l1, l2, "x", ts)
        t = sat.epoch + np.arange(0.0, 86400.0, 300.0) * u.s
        st = sky_time(ts, t)
        for lat, lon, h in SITES:
            la = vv.GroundStation(lat * u.deg, lon * u.deg, h * u.m).look(sat, t)
            topos = wgs84.latlon(lat, lon, h)
            pos = (es - topos).at(st)
            alt, az, dist = pos.altaz()
            rate = pos.frame_latlon_and_rates(topos)[5].km_per_s
            el = la.elevation.to_value(u.deg)
            daz = (la.azimuth.to_value(u.deg) - az.degrees + 180.0) % 360.0 - 180.0
            angle = np.maximum(np.abs(el - alt.degrees), np.abs(daz * np.cos(np.radians(el))))
            worst["angle"] = max(worst["angle"], float(angle.max()) / ARCSEC_DEG)
            worst["range"] = max(worst["range"],
                                 float(np.abs(la.range.to_value(u.km) - dist.km).max()))
            worst["rate"] = max(worst["rate"], float(
                np.abs(la.range_rate.to_value(u.km / u.s) - rate).max()))
            n += t.size
    details = {"satellites": "ISS, Molniya (2024 epochs)", "stations": len(SITES),
               "samples": n, "step_s": 300.0}
    return [
        Check("look angles vs Skyfield: azimuth and elevation", "max |d angle| (arcsec; "
              "azimuth times cos el)", worst["angle"], 0.01, _ref(),
              dict(details, why=_WHY_UT1 + ": 0.007\" at the ISS's 420 km zenith range")),
        Check("look angles vs Skyfield: range", "max |d range| (km)", worst["range"], 3e-5,
              _ref(), dict(details, why=_WHY_UT1 + " (3 cm with the satellites' 2 mm)")),
        Check("look angles vs Skyfield: range rate", "max |d range rate| (km/s)", worst["rate"],
              2e-6, _ref(), dict(details, why=(
                  "Skyfield turns a station about the ITRS z axis, astropy (so visviva) about "
                  "the celestial intermediate pole: the station velocities differ by "
                  "omega R_earth times the polar motion (0.24-0.35\" in 2024), up to 1.1 mm/s; "
                  "the satellites' GCRS velocities differ by up to 0.3 mm/s")))]


def _cases():
    from .checks_satellites import ISS, MOLNIYA, verification_set

    geo = next(c[:2] for c in verification_set() if c[0][2:7] == "28626")  # i 0.002 deg
    # name, (line1, line2), (lat deg, lon deg, height m), min elevation deg, start d, span d
    return [("ISS", ISS, (52.2053, 0.1218, 20.0), 10.0, 0.25, 1.0),
            ("Molniya", MOLNIYA, (67.9, 21.1, 400.0), 5.0, 0.2, 2.0),
            ("GEO (never sets)", geo, (10.0, -80.0, 0.0), 0.0, 0.1, 1.5)]


def _events(ts) -> list[Check]:
    from astropy import units as u
    from skyfield.api import EarthSatellite, wgs84

    import visviva as vv

    mismatched = 0
    n_events = 0
    vs_find = vs_cross = vs_max = 0.0
    culm_el = 0.0
    rows = {}
    for name, (l1, l2), (lat, lon, h), el_min, start, span in _cases():
        sat = vv.Satellite.from_tle(l1, l2)
        station = vv.GroundStation(lat * u.deg, lon * u.deg, h * u.m)
        t0 = sat.epoch + start * u.day
        t1 = t0 + span * u.day
        table = vv.find_passes(sat, station, t0, t1, min_elevation=el_min * u.deg)
        times, kinds = station.find_events(sat, t0, t1, el_min * u.deg)
        rows[name] = len(table)
        es = EarthSatellite(l1, l2, "x", ts)
        topos = wgs84.latlon(lat, lon, h)
        diff = es - topos
        t_sky, k_sky = es.find_events(topos, sky_time(ts, t0), sky_time(ts, t1),
                                      altitude_degrees=el_min)
        n_events += len(kinds)
        if len(kinds) != len(k_sky) or np.any(kinds != k_sky):
            mismatched += abs(len(kinds) - len(k_sky)) + 1
            continue
        # the table's passes are made of these events: a rise or set cell for each rise or
        # set (masked where the window cuts the pass: GEO's one pass has neither)
        culm = table["culmination_time"]
        for col, kind in (("rise_time", 0), ("set_time", 2)):
            mismatched += abs(int(np.sum(~table[col].mask)) - int(np.sum(kinds == kind)))

        def alt(t, diff=diff):
            return diff.at(sky_time(ts, t)).altaz()[0].degrees

        dt = ((times.tt.jd1 - t_sky.whole) + (times.tt.jd2 - t_sky.tt_fraction)) * 86400.0
        cross = kinds != 1
        if cross.any():
            vs_find = max(vs_find, float(np.abs(dt[cross]).max()))
            # the crossing of Skyfield's altitude: the secant through +-0.05 s of ours
            tc = times[cross]
            a = alt(tc - 0.05 * u.s) - el_min
            b = alt(tc + 0.05 * u.s) - el_min
            vs_cross = max(vs_cross, float(np.abs(-0.05 + 0.1 * a / (a - b)).max()))
        top = ~cross
        tm = times[top]
        shown = table[~culm.mask]
        if tm.size == 0 or len(shown) == 0:  # every case here has culminations
            mismatched += 1
            continue
        if name.startswith("GEO"):  # flat to 1e-7 arcsec over +-2 s: no time to match
            grid = np.linspace(-60.0, 60.0, 41)
            a_sky = np.stack([alt(tm + g * u.s) for g in grid]).max(axis=0)
        else:  # the vertex of the parabola through Skyfield's altitude at -h, 0, +h
            h_s = 0.5
            am, a0, ap = (alt(tm + k * h_s * u.s) for k in (-1, 0, 1))
            curv = am - 2.0 * a0 + ap
            vs_max = max(vs_max, float(np.abs(0.5 * h_s * (am - ap) / curv).max()))
            a_sky = a0 - (am - ap) ** 2 / (8.0 * curv)
        # the table's highest elevation of each pass against Skyfield's altitude maximum
        near = np.abs((shown["culmination_time"][:, None] - tm[None, :]).to_value(u.s))
        k = near.argmin(axis=1)
        mismatched += int(np.sum(near[np.arange(len(k)), k] > 1e-3))
        el_vv = shown["max_elevation"].to_value(u.deg)
        culm_el = max(culm_el, float(np.abs(el_vv - a_sky[k]).max()) / ARCSEC_DEG)
    details = {"cases": ", ".join(f"{k}: {v} passes" for k, v in rows.items()),
               "events": n_events}
    sky = _ref()
    return [
        Check("find_passes/find_events vs Skyfield find_events: same events (ISS, Molniya, GEO)",
              "events that differ in kind or number", float(mismatched), 0.0, sky,
              dict(details, why="the same SGP4 trajectory seen from the same site: every rise, "
                                "culmination and set must be there on both sides")),
        Check("rise/set vs Skyfield find_events", "max |dt| (s)", vs_find, 0.5, sky,
              dict(details, why="Skyfield's find_events stops its search at half a second")),
        Check("rise/set vs the crossing of Skyfield's altitude", "max |dt| (s)", vs_cross, 0.1,
              sky, dict(details, why=(
                  "find_passes promises 0.1 s on SGP4's trajectory; the two frame models agree "
                  "to 0.01\" in elevation, under 1 ms of the slowest rise here (Molniya)"))),
        Check("culmination vs the maximum of Skyfield's altitude (ISS, Molniya)", "max |dt| (s)",
              vs_max, 0.1, sky, dict(details, why="the same 0.1 s as the crossings; the vertex "
                                     "of a parabola through +-0.5 s is exact to ~1e-4 s there")),
        Check("highest elevation of each pass vs Skyfield's maximum altitude (incl. GEO)",
              "max |d elevation| (arcsec)", culm_el, 0.01, sky,
              dict(details, why="as the look angles (0.01\"); second order in the time of the "
                                "maximum, so well conditioned even on GEO's flat top")),
    ]


def _mask() -> list[Check]:
    from astropy import units as u

    import visviva as vv

    from .checks_satellites import ISS

    sat = vv.Satellite.from_tle(*ISS)
    station = vv.GroundStation(52.2053 * u.deg, 0.1218 * u.deg, 20 * u.m)
    t0 = sat.epoch + 0.25 * u.day
    t1 = t0 + 1 * u.day
    flat = vv.ElevationMask([0, 90, 180, 270] * u.deg, [10, 10, 10, 10] * u.deg)
    a = vv.find_passes(sat, station, t0, t1, min_elevation=10 * u.deg)
    b = vv.find_passes(sat, station, t0, t1, min_elevation=flat)
    worst = 0.0 if len(a) == len(b) else np.inf
    if np.isfinite(worst):
        for col in ("rise_time", "culmination_time", "set_time"):
            d = (b[col] - a[col]).to_value(u.s)
            worst = max(worst, float(np.abs(np.ma.filled(d, 0.0)).max()))
            worst = max(worst, float(np.sum(a[col].mask != b[col].mask)))
        for col in ("max_elevation", "rise_azimuth", "set_azimuth", "culmination_range"):
            d = np.ma.filled(np.abs(b[col].value - a[col].value), 0.0)
            worst = max(worst, float(np.max(d)))
    return [Check("ElevationMask flat (4 points at 10 deg) vs min_elevation=10 deg (ISS, 1 day)",
                  "max |difference| (s, deg, km): bit for bit", worst, 0.0,
                  "visviva's scalar threshold search", {"passes": len(a),
                  "why": "a flat mask is the scalar search itself"})]


# a bumpy horizon: hills, a 35 deg peak, a 28 deg hill at 150 deg that splits one ISS pass in
# two, a building's vertical edge at 200 deg (two points at one azimuth: 4 deg on the lower
# side, 25 deg on the higher one; one pass rises from behind it)
BUMPY_AZ_DEG = (0.0, 30.0, 55.0, 80.0, 120.0, 150.0, 200.0, 200.0, 240.0, 270.0, 300.0, 330.0)
BUMPY_EL_DEG = (8.0, 14.0, 3.0, 35.0, 6.0, 28.0, 4.0, 25.0, 18.0, 2.0, 10.0, 20.0)


def _crossings(f, windows, tol_s):
    """Every sign change of ``f`` (a function of seconds) sampled every second over each
    ``(start, stop)`` window, bisected to ``tol_s``: (times s, +1 for a rise / -1 for a set)."""
    x = np.concatenate([np.arange(a, b + 1.0) for a, b in windows])
    up = f(x) > 0.0
    k = np.flatnonzero((up[1:] != up[:-1]) & (np.diff(x) == 1.0))  # not across two windows
    lo, hi = x[k], x[k + 1]
    rising = ~up[k]
    while (hi - lo).max(initial=0.0) > tol_s:
        mid = 0.5 * (lo + hi)
        before = (f(mid) > 0.0) != rising  # still on the side of lo
        lo, hi = np.where(before, mid, lo), np.where(before, hi, mid)
    return 0.5 * (lo + hi), np.where(rising, 1, -1)


def _bumpy(ts) -> list[Check]:
    from astropy import units as u
    from skyfield.api import EarthSatellite, wgs84

    import visviva as vv

    from .checks_satellites import ISS

    lat, lon, h = 52.2053, 0.1218, 20.0
    mask = vv.ElevationMask(BUMPY_AZ_DEG * u.deg, BUMPY_EL_DEG * u.deg)
    sat = vv.Satellite.from_tle(*ISS)
    t0 = sat.epoch + 0.25 * u.day
    span_s = 86400.0
    table = vv.find_passes(sat, vv.GroundStation(lat * u.deg, lon * u.deg, h * u.m), t0,
                           t0 + span_s * u.s, min_elevation=mask)
    es, topos = EarthSatellite(*ISS, "ISS", ts), wgs84.latlon(lat, lon, h)
    diff = es - topos
    tt = t0.tt

    def above(x):  # Skyfield's elevation over the mask, x s after t0
        alt, az, _ = diff.at(ts.tt_jd(tt.jd1, tt.jd2 + x / 86400.0)).altaz()
        return alt.degrees - mask(az.degrees * u.deg).value

    # the satellite is above the mask only while above its lowest point: sample the passes
    # of Skyfield's own search at that elevation (+-30 s), not the 23 hours between them
    ends = [sky_time(ts, t0), sky_time(ts, t0 + span_s * u.s)]
    t_ev, k_ev = es.find_events(topos, *ends, altitude_degrees=min(BUMPY_EL_DEG))
    x_ev = (t_ev.tt - tt.jd1 - tt.jd2) * 86400.0
    rises, sets = x_ev[k_ev == 0], x_ev[k_ev == 2]
    if rises.size == 0 or (sets.size and sets[0] < rises[0]):  # up at the window's start
        rises = np.concatenate([[0.0], rises])
    if sets.size < rises.size:  # up at its end
        sets = np.concatenate([sets, [span_s]])
    starts, stops = rises, sets
    windows = [(max(0.0, np.floor(a) - 30.0), min(span_s, np.ceil(b) + 30.0))
               for a, b in zip(starts, stops, strict=True)]
    tx, sense = _crossings(above, windows, 1e-4)
    rate = np.abs(above(tx + 0.5) - above(tx - 0.5))  # deg/s, across each crossing
    ours = {}
    for col, kind in (("rise_time", 1), ("set_time", -1)):
        cells = table[col]
        ours[kind] = np.sort((cells[~cells.mask] - t0).to_value(u.s))
    missed = 0
    worst = 0.0
    for kind in (1, -1):
        ref = tx[sense == kind]
        missed += abs(ref.size - ours[kind].size)
        if ref.size == ours[kind].size and ref.size:
            worst = max(worst, float(np.abs(ours[kind] - ref).max()))
    details = {"passes": len(table), "crossings": int(tx.size), "step_s": 1.0,
               "bisection_s": 1e-4, "slowest_crossing_deg_s": float(rate.min(initial=np.inf)),
               "mask": "12 points, 2-35 deg, a vertical step at 200 deg"}
    sky = _ref()
    return [
        Check("ElevationMask bumpy: the same rises and sets as Skyfield brute force (ISS, 1 day)",
              "crossings missed or invented", float(missed), 0.0, sky,
              dict(details, why="el - mask(az) from Skyfield's altaz sampled every second: "
                                "every crossing of the mask is on both sides")),
        Check("ElevationMask bumpy: rise/set vs the crossings of Skyfield's el - mask(az)",
              "max |dt| (s)", worst, 2e-4, sky, dict(details, why=(
                  "the bisection's 5e-5 s, plus the look angles' 0.01\" over the slowest "
                  "crossing of el - mask(az) here (0.07 deg/s: 4e-5 s), plus find_passes' own "
                  "1e-6 s; the crossing at the mask's vertical step is set by the azimuth "
                  "(0.01\" at 0.2 deg/s: 1e-5 s); one pass dips under the 28 deg hill at "
                  "150 deg and comes out as two, as in STK"))),
    ]


def checks(full: bool = False) -> list[Check]:
    """Run the ground-station comparisons live (a few seconds)."""
    ts = timescale()
    return _look(ts) + _events(ts) + _mask() + _bumpy(ts)
