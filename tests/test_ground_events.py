"""Rise/culmination/set against Skyfield's find_events and a brute-force reference on Skyfield's
own altitude function; grazing passes; eccentric and deep-space orbits; bad input."""

import importlib.resources

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from hypothesis import given, settings
from hypothesis import strategies as st

import visviva as vv

ISS_1 = "1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927"
ISS_2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537"
TENTH_SECOND = 0.1


def _verification_tles():
    text = (importlib.resources.files("sgp4") / "SGP4-VER.TLE").read_text()
    lines = [ln[:69] for ln in text.splitlines() if ln[:2] in ("1 ", "2 ")]
    return {a[2:7]: (a, b) for a, b in zip(lines[::2], lines[1::2], strict=True)}


TLES = _verification_tles()


def _skyfield(l1, l2, lat, lon, h_m):
    from skyfield.api import EarthSatellite, load, wgs84

    ts = load.timescale()
    return ts, EarthSatellite(l1, l2, "x", ts), wgs84.latlon(lat, lon, h_m)


def _true_crossings(ts, es, topos, times: Time, threshold_deg):
    """Bisect Skyfield's altitude to 1e-4 s in [t - 2 s, t + 2 s] around each given time."""
    diff = es - topos
    lo = times - 2 * u.s
    hi = times + 2 * u.s

    def f(t):
        return diff.at(ts.from_astropy(t)).altaz()[0].degrees - threshold_deg

    flo = f(lo)
    assert np.all(np.sign(flo) != np.sign(f(hi))), "no crossing within 2 s"
    for _ in range(16):
        mid = lo + (hi - lo) * 0.5
        fm = f(mid)
        same = np.sign(fm) == np.sign(flo)
        lo = Time(np.where(same, mid.jd1, lo.jd1), np.where(same, mid.jd2, lo.jd2),
                  format="jd", scale=lo.scale)
        hi = Time(np.where(same, hi.jd1, mid.jd1), np.where(same, hi.jd2, mid.jd2),
                  format="jd", scale=hi.scale)
        flo = np.where(same, fm, flo)
    return lo + (hi - lo) * 0.5


CASES = [  # satellite, site (lat, lon), minimum elevation (deg)
    ("ISS", 40.0, -75.0, 0.0),
    ("ISS", 40.0, -75.0, 10.0),
    ("06251", -33.9, 18.4, 10.0),  # LEO, southern site
    ("28057", 67.9, 21.1, 5.0),  # sun-synchronous, Arctic site
    ("16925", 40.0, -75.0, 0.0),  # e = 0.56, 5 orbits per day
]


def _sat(key):
    l1, l2 = (ISS_1, ISS_2) if key == "ISS" else TLES[key]
    return l1, l2, vv.Satellite.from_tle(l1, l2, name=key)


def _events_and_skyfield(key, lat, lon, el_min, start_day, span_day):
    """Our events of satellite ``key`` over a site 100 m up, and Skyfield's objects for it."""
    l1, l2, sat = _sat(key)
    site = vv.GroundStation(lat * u.deg, lon * u.deg, 100 * u.m)
    t0 = sat.epoch + start_day * u.day
    t1 = t0 + span_day * u.day
    times, kinds = site.find_events(sat, t0, t1, el_min * u.deg)
    return t0, t1, times, kinds, _skyfield(l1, l2, lat, lon, 100)


@pytest.mark.parametrize("key, lat, lon, el_min", CASES)
def test_same_events_as_skyfield_and_within_a_tenth_of_a_second(key, lat, lon, el_min):
    t0, t1, times, kinds, (ts, es, topos) = _events_and_skyfield(key, lat, lon, el_min,
                                                                 0.25, 1.5)
    t_sky, k_sky = es.find_events(topos, ts.from_astropy(t0), ts.from_astropy(t1),
                                  altitude_degrees=el_min)
    assert len(kinds) > 3
    np.testing.assert_array_equal(kinds, k_sky)
    # Skyfield's own times are good to its half-second epsilon (culminations, where the
    # elevation is flat, to a few seconds)
    cross = kinds != 1
    dt = (times.tt.jd - t_sky.tt) * 86400
    np.testing.assert_allclose(dt[cross], 0, atol=0.5)
    np.testing.assert_allclose(dt[~cross], 0, atol=3.0)
    # ours are within 0.1 s of the true crossing of Skyfield's altitude function
    ref = _true_crossings(ts, es, topos, times[cross], el_min)
    err = np.abs((times[cross] - ref).to_value(u.s))
    assert err.max() < TENTH_SECOND
    # culminations: Skyfield's altitude is lower one second either side
    diff = es - topos
    for tc in times[~cross]:
        a = diff.at(ts.from_astropy(tc + [-1.0, 0.0, 1.0] * u.s)).altaz()[0].degrees
        assert a[1] >= a[0] - 1e-6 and a[1] >= a[2] - 1e-6


@pytest.mark.parametrize("key, lat, lon, el_min", [
    ("08195", 67.9, 21.1, 5.0),  # Molniya
    ("28623", 40.0, -75.0, 0.0),  # e = 0.62, GTO-like
    ("23599", -33.9, 18.4, 10.0),  # GTO
    ("28129", 40.0, -75.0, 0.0),  # GPS
    ("09998", 40.0, -75.0, 0.0),  # 24 h, i = 9.5 deg
])
def test_eccentric_and_high_orbits_against_a_dense_scan(key, lat, lon, el_min):
    # Skyfield's find_events misses passes of these (its coarse step assumes near-circular
    # orbits), so the reference is Skyfield's altitude sampled every 10 s
    t0, _, times, kinds, (ts, es, topos) = _events_and_skyfield(key, lat, lon, el_min, 0.3, 2)
    grid = t0 + np.arange(0, 2 * 86400 + 1, 10) * u.s
    alt = (es - topos).at(ts.from_astropy(grid)).altaz()[0].degrees - el_min
    sign_change = np.flatnonzero(np.diff(np.sign(alt)) != 0)
    cross = kinds != 1
    assert cross.sum() == sign_change.size
    # every dense-scan crossing lies within its 10 s cell around one of ours
    dt = (times[cross] - grid[sign_change]).to_value(u.s)
    assert np.all((dt >= -TENTH_SECOND) & (dt <= 10 + TENTH_SECOND))
    ref = _true_crossings(ts, es, topos, times[cross], el_min)
    assert np.abs((times[cross] - ref).to_value(u.s)).max() < TENTH_SECOND
    np.testing.assert_array_equal(kinds[cross], np.where(np.diff(alt)[sign_change] > 0, 0, 2))


def test_short_grazing_pass_is_found_and_not_invented():
    _, _, iss = _sat("ISS")
    site = vv.GroundStation(40.0 * u.deg, -75.0 * u.deg, 50 * u.m)
    t0 = Time("2008-09-20T12:00:00", scale="utc")
    t1 = t0 + 1 * u.day
    passes = vv.find_passes(iss, site, t0, t1)
    low = passes[np.argmin(passes["max_elevation"])]
    top = low["max_elevation"]
    # just below the highest point: a pass of a few seconds must still be found
    times, kinds = site.find_events(iss, low["rise_time"] - 5 * u.min,
                                    low["set_time"] + 5 * u.min, top - 0.001 * u.deg)
    np.testing.assert_array_equal(kinds, [0, 1, 2])
    assert (times[2] - times[0]).to_value(u.s) < 30
    times, kinds = site.find_events(iss, low["rise_time"] - 5 * u.min,
                                    low["set_time"] + 5 * u.min, top + 0.001 * u.deg)
    assert len(kinds) == 0


@settings(max_examples=6, deadline=None)
@given(lat=st.floats(-80, 80), lon=st.floats(-180, 180), el=st.floats(-5, 60))
def test_events_sit_on_the_threshold_and_alternate(lat, lon, el):
    _, _, iss = _sat("ISS")
    site = vv.GroundStation(lat * u.deg, lon * u.deg)
    t0 = Time("2008-09-20T12:00:00", scale="utc")
    times, kinds = site.find_events(iss, t0, t0 + 8 * u.hour, el * u.deg)
    if len(kinds) == 0:
        return
    look = site.look(iss, times)
    cross = kinds != 1
    np.testing.assert_allclose(look.elevation[cross].to_value(u.deg), el, atol=1e-6)
    assert np.all(look.elevation[~cross] > el * u.deg)
    # rate at a rise is positive, at a set negative
    assert np.all(look.elevation_rate[kinds == 0] > 0)
    assert np.all(look.elevation_rate[kinds == 2] < 0)
    # a culmination is the maximum of the elevation (of SGP4's positions, on which it is found)
    # to within 0.025 s: not below the elevation 0.05 s before or after (the issue asks 0.1 s).
    # (The elevation rate there is not exactly 0: it comes from SGP4's velocity, which is not
    # exactly the derivative of SGP4's positions.)
    culminations = times[kinds == 1]
    if len(culminations):
        top = look.elevation[kinds == 1]
        for dt in (-0.05, 0.05):
            assert np.all(site.look(iss, culminations + dt * u.s).elevation <= top)
    assert np.all(np.diff(times.jd) > 0)
    real = kinds[kinds != 1]
    assert np.all(real[1:] != real[:-1])  # rise and set alternate


def test_bad_input():
    _, _, iss = _sat("ISS")
    site = vv.GroundStation(40.0 * u.deg, -75.0 * u.deg)
    t0 = Time("2008-09-20T12:00:00", scale="utc")
    with pytest.raises(vv.InvalidInputError, match="later than t0"):
        site.find_events(iss, t0, t0)
    with pytest.raises(vv.InvalidInputError, match="astropy Time"):
        site.find_events(iss, 0.0, t0)
    with pytest.raises(vv.DomainError, match="outside"):
        site.find_events(iss, t0, t0 + 1 * u.hour, 95 * u.deg)
    with pytest.raises(vv.UnitsError):
        site.find_events(iss, t0, t0 + 1 * u.hour, 10)
    with pytest.raises(vv.InvalidInputError, match="one Satellite"):
        site.find_events(vv.Catalog([iss]), t0, t0 + 1 * u.hour)


def test_shallow_pass_crossings_converge():
    # found by hypothesis: a pass 0.15 deg above the threshold, 50 s long
    _, _, iss = _sat("ISS")
    site = vv.GroundStation(63.5625 * u.deg, 0 * u.deg)
    t0 = Time("2008-09-20T12:00:00", scale="utc")
    times, kinds = site.find_events(iss, t0, t0 + 12 * u.hour, 8 * u.deg)
    look = site.look(iss, times[kinds != 1])
    np.testing.assert_allclose(look.elevation.to_value(u.deg), 8.0, atol=1e-6)


def test_decaying_satellite_gives_events_up_to_the_failure_and_warns():
    l1, l2 = TLES["28350"]  # SGP4 fails on 2006-06-17 near 05:46 UTC (decay)
    sat = vv.Satellite.from_tle(l1, l2, name="28350")
    site = vv.GroundStation(40.0 * u.deg, -75.0 * u.deg, 100 * u.m)
    t0 = sat.epoch + 0.3 * u.day
    with pytest.warns(RuntimeWarning, match="SGP4 failed inside the window"):
        times, kinds = site.find_events(sat, t0, t0 + 2 * u.day)
    assert len(kinds) >= 3
    assert times[-1] < Time("2006-06-17T05:50:00", scale="utc")
    look = site.look(sat, times[kinds != 1])
    np.testing.assert_allclose(look.elevation.to_value(u.deg), 0.0, atol=1e-6)


def test_rise_and_set_on_a_leap_second_day_match_skyfield():
    """On 2016-12-31 (86,401 s long) the SGP4 states behind the events were up to 1 s late
    (astropy's stretched UTC Julian day): rises and sets up to 1.0 s off Skyfield's crossings."""
    from test_utc_days import L1, L2

    sat = vv.Satellite.from_tle(L1, L2)
    site = vv.GroundStation(40 * u.deg, -75 * u.deg, 100 * u.m)
    t0 = Time("2016-12-31T12:00:00", scale="utc")
    times, kinds = site.find_events(sat, t0, t0 + 15 * u.hour)
    cross = kinds != 1
    assert cross.sum() >= 10 and (times > Time("2017-01-01", scale="utc")).any()
    ts, es, topos = _skyfield(L1, L2, 40.0, -75.0, 100)
    ref = _true_crossings(ts, es, topos, times[cross], 0.0)
    assert np.abs((times[cross] - ref).to_value(u.s)).max() < TENTH_SECOND


@pytest.mark.parametrize("key, lat, lon, offsets", [
    ("ISS", 40.0, -75.0, (-90.0, -30.0, -5.0, 5.0, 30.0, 90.0)),
    ("08195", 67.9, 21.1, (-900.0, -300.0, -20.0, 20.0, 300.0, 900.0)),  # Molniya
])
def test_culmination_near_the_window_edge_is_found_as_skyfield_does(key, lat, lon, offsets):
    """A maximum in the first or last sampling interval of the window (100 s in LEO, 800 s for
    a Molniya orbit) was not bracketed: the culmination was missing from find_events, and the
    pass table gave the window edge's elevation as max_elevation (lower, silently)."""
    l1, l2, sat = _sat(key)
    site = vv.GroundStation(lat * u.deg, lon * u.deg, 100 * u.m)
    t0 = sat.epoch + 0.3 * u.day
    times, kinds = site.find_events(sat, t0, t0 + 1 * u.day, 10 * u.deg)
    ts, es, topos = _skyfield(l1, l2, lat, lon, 100)
    diff = es - topos

    def alt(t):
        return diff.at(ts.from_astropy(t)).altaz()[0].degrees

    culminations = times[kinds == 1][:2]
    assert len(culminations) == 2
    span = 3 * u.hour
    for tc in culminations:
        for off in offsets:  # edge - culmination, s
            edge = tc + off * u.s
            assert alt(edge) > 0.0  # the edge cuts the pass
            for a, b in ((edge, edge + span), (edge - span, edge)):
                got_t, got_k = site.find_events(sat, a, b)
                inside = bool(a < tc < b)
                # the culmination is reported exactly when it lies inside the window
                at_tc = (np.abs((got_t - tc).to_value(u.s)) < 1.0) & (got_k == 1)
                assert at_tc.sum() == int(inside), (key, off, got_k)
                table = vv.find_passes(sat, site, a, b)
                cut = table[0] if a == edge else table[-1]  # the pass the edge cuts
                top = alt(tc) if inside else alt(edge)
                np.testing.assert_allclose(cut["max_elevation"].to_value(u.deg), top,
                                           atol=2e-3)
                assert bool(cut["culmination_time"].mask) != inside


@pytest.mark.parametrize("key, per_pass", [
    ("28626", 3),  # geostationary: one pass all window, a culmination a day
    ("08195", 2),  # Molniya: a pass with two maxima (apogee and a near-perigee one)
])
def test_every_local_maximum_once_geo_and_heo(key, per_pass):
    # audit37: the GEO's flat elevation (1e-6 deg over half an hour) gave two culminations
    # 26 min either side of its one daily maximum: the scan's polynomial put two maxima
    # there and the parabola steps (30 s, two rounds) could not bring them together
    t0, _, times, kinds, (ts, es, topos) = _events_and_skyfield(key, 40.0, -75.0, 0.0, 0.2, 2)
    grid = t0 + np.arange(0, 2 * 86400 + 1, 20) * u.s
    alt = (es - topos).at(ts.tt_jd(grid.tt.jd1, grid.tt.jd2)).altaz()[0].degrees
    d = np.diff(alt)
    peak = np.flatnonzero((d[:-1] > 0) & (d[1:] <= 0)) + 1
    peak = peak[alt[peak] > 0.0]
    culm = times[kinds == 1]
    assert culm.size == peak.size
    # within a cell of the 20 s scan (the GEO's maximum is flat: 1e-8 deg lower 60 s away)
    assert np.abs((culm - grid[peak]).to_value(u.s)).max() < 20.0
    assert np.bincount(np.cumsum(kinds == 0)[kinds == 1]).max() == per_pass
