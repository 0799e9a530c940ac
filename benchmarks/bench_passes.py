"""Passes of a LEO catalogue over ground stations: visviva vs a loop of Skyfield's find_events.

Rows (ratio = visviva time / Skyfield time per satellite-station-day; below 1 visviva is faster):

* ``passes, N LEO satellites x 1 station x 1 day``: :func:`visviva.find_passes` (events, the
  pass table, sunlight and twilight columns) for the whole catalogue vs Skyfield's
  ``EarthSatellite.find_events`` looped over a subset of the same satellites (events only),
  both per satellite. Target: 20x faster (ratio <= 0.05), aim 50x.
* ``passes, N x 10 stations``: the same catalogue over ten stations (the SGP4 work is shared by
  all stations) vs Skyfield per satellite-station pair.
* ``events only`` (informational): the event search without the table, one station.
* ``apparent horizon`` (informational): the pass table with ``refraction=True`` (rise and set
  where the refracted elevation crosses the threshold) vs the geometric one, same catalogue,
  ten stations at ten heights (ten airs: one scan each).

The two sides are timed alternately (A B A B ...) so that load changes hit both alike.

Run: ``python -m benchmarks`` (all) or ``python -m benchmarks.bench_passes``.
"""

from __future__ import annotations

import numpy as np

try:  # as part of the package (python -m benchmarks) or as a script
    from .bench_sgp4 import synthetic_catalog
    from .common import compile_time, interleaved_medians, quick_from_env, result, skipped
except ImportError:  # pragma: no cover
    from bench_sgp4 import synthetic_catalog
    from common import compile_time, quick_from_env, result, skipped


def leo_catalog(n: int, seed: int = 1):
    """``n`` LEO element sets (OMM records: 14-15.6 rev/day, inclinations 30-100 deg)."""
    return synthetic_catalog(n, seed, prefix="LEO", first_id=20000,
                             epoch="2024-03-01T00:00:00.000000", mean_motion=(14.0, 15.6),
                             eccentricity=(1e-4, 0.01), inclination=(30.0, 100.0))


def _stations(k: int, heights_m=None):
    from astropy import units as u

    import visviva as vv

    rng = np.random.default_rng(7)
    heights_m = [100.0] * k if heights_m is None else heights_m
    return [vv.GroundStation(float(lat) * u.deg, float(lon) * u.deg, float(h) * u.m,
                             name=f"GS{i}")
            for i, (lat, lon, h) in enumerate(zip(rng.uniform(-60, 60, k),
                                                  rng.uniform(-180, 180, k), heights_m,
                                                  strict=True))]


def run(quick: bool = False) -> list[dict]:
    try:
        from skyfield.api import EarthSatellite, load, wgs84
    except ImportError as exc:  # pragma: no cover
        return [skipped("passes", f"skyfield not installed: {exc}")]
    from astropy import units as u
    from astropy.time import Time

    import visviva as vv

    quick = quick or quick_from_env()
    n, n_sky = (200, 20) if quick else (400, 40)
    cat = leo_catalog(n)
    t0 = Time("2024-03-01T06:00:00", scale="utc")
    t1 = t0 + 1 * u.day
    ts = load.timescale()
    a, b = ts.from_astropy(t0), ts.from_astropy(t1)
    rows = []
    for n_st in (1, 10):
        stations = _stations(n_st)
        sky_sats = [EarthSatellite.from_satrec(s.satrec, ts) for s in cat.satellites[:n_sky]]
        sky_sites = [wgs84.latlon(s.lat.value, s.lon.value, s.height.to_value(u.m))
                     for s in stations]
        if n_st > 1:  # Skyfield per pair: a few pairs suffice
            sky_sats = sky_sats[: max(4, n_sky // n_st)]

        def sky(sky_sats=sky_sats, sky_sites=sky_sites):
            for es in sky_sats:
                for site in sky_sites:
                    es.find_events(site, a, b)

        def ours(stations=stations):
            vv.find_passes(cat, stations, t0, t1)

        first = compile_time(ours)
        sky_s, ours_s = interleaved_medians(sky, ours, rounds=3 if quick else 5)
        per_sky = sky_s / (len(sky_sats) * n_st)
        per_ours = ours_s / (n * n_st)
        rows.append(result(
            f"passes, {n} LEO satellites x {n_st} station{'s' if n_st > 1 else ''} x 1 day",
            per_ours, f"skyfield find_events loop ({per_sky * 1e3:.2f} ms per satellite-station-"
            "day)", per_sky, target=1 / 20.0, compile_s=first,
            notes=f"per satellite-station-day; visviva {per_ours * 1e6:.0f} us (whole "
            f"catalogue in one call, with the pass table and sunlight/twilight columns), "
            f"speed-up {per_sky / per_ours:.0f}x; Skyfield timed on {len(sky_sats)} of the "
            "satellites; alternating rounds",
        ))
    # informational: the event search alone (what Skyfield's find_events computes), no table
    from visviva.ground.search import search_events

    stations = _stations(1)
    sky_sats = [EarthSatellite.from_satrec(s.satrec, ts) for s in cat.satellites[:n_sky]]
    site = wgs84.latlon(stations[0].lat.value, stations[0].lon.value, 100.0)

    def sky_one():
        for es in sky_sats:
            es.find_events(site, a, b)

    sky_s, ev_s = interleaved_medians(sky_one, lambda: search_events(cat, stations, t0, t1, 0.0),
                              rounds=3 if quick else 5)
    per_sky, per_ev = sky_s / len(sky_sats), ev_s / n
    rows.append(result(
        f"events only (visviva.ground.search.search_events), {n} LEO x 1 station x 1 day",
        per_ev, "skyfield find_events loop", per_sky, target=None,
        notes=f"informational: rise/culmination/set of every pair, without the pass table and "
        f"the visibility columns; speed-up {per_sky / per_ev:.0f}x; alternating rounds",
    ))
    # informational: passes on the apparent horizon against the geometric ones
    stations = _stations(10, heights_m=np.linspace(0.0, 4500.0, 10))

    def geometric():
        vv.find_passes(cat, stations, t0, t1)

    def apparent():
        vv.find_passes(cat, stations, t0, t1, refraction=True)

    compile_time(apparent)
    geo_s, app_s = interleaved_medians(geometric, apparent, rounds=3 if quick else 5)
    rows.append(result(
        f"passes on the apparent horizon (refraction=True), {n} LEO x 10 stations at 10 "
        "heights x 1 day", app_s / (n * 10), "the same without refraction", geo_s / (n * 10),
        target=None,
        notes=f"informational: per satellite-station-day; refracted {app_s * 1e3:.0f} ms, "
        f"geometric {geo_s * 1e3:.0f} ms for the whole table ({app_s / geo_s:.2f}x: one scan "
        "per distinct air, the refraction and the satellite's range factor at every SGP4 "
        "correction); alternating rounds",
    ))
    return rows


if __name__ == "__main__":  # pragma: no cover
    import sys

    for row in run(quick="--quick" in sys.argv):
        print(row)
