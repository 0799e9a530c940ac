"""UTC Julian dates of 86,400-s days (sgp4's clock) on and around leap-second days.

astropy's UTC ``jd1/jd2`` stretch a leap-second day to 86,401 s; sgp4 (``jday``,
``jdsatepoch``) and skyfield count 86,400-s days. Handing one to the other put every SGP4
state on 2016-12-31 up to 1 s (7.7 km for the ISS) off skyfield and ``Satellite.epoch`` 0.5 s
off the TLE's own epoch.
"""

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time, TimeDelta
from hypothesis import given, settings
from hypothesis import strategies as st
from sgp4.api import jday

import visviva as vv
from visviva.satellites.utc_days import time_to_utc_days, utc_days_to_time


def _fix(line):
    s = sum(int(c) if c.isdigit() else (1 if c == "-" else 0) for c in line[:68])
    return line[:68] + str(s % 10)


# the ISS with its epoch at noon of the leap-second day 2016-12-31 (day 366 of 2016)
L1 = _fix("1 25544U 98067A   16366.50000000  .00016717  00000-0  10270-3 0  9005")
L2 = _fix("2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537")

LEAP_DAY = ["2016-12-31T00:00:00", "2016-12-31T06:00:00", "2016-12-31T12:00:00",
            "2016-12-31T18:00:00.25", "2016-12-31T23:59:59.999", "2017-01-01T00:00:00",
            "2015-06-30T23:00:00", "2024-05-01T03:04:05.123456"]


def _jday(iso):
    date, clock = iso.split("T")
    y, m, d = (int(x) for x in date.split("-"))
    hh, mm, ss = clock.split(":")
    return jday(y, m, d, int(hh), int(mm), float(ss))


@pytest.mark.parametrize("iso", LEAP_DAY)
def test_time_to_utc_days_matches_sgp4_jday(iso):
    jd, fr = time_to_utc_days(Time(iso, scale="utc"))
    ref_jd, ref_fr = _jday(iso)
    assert abs(((jd - ref_jd) + (fr - ref_fr)) * 86400.0) < 1e-6  # s


def test_time_to_utc_days_any_scale_and_shape():
    t = Time(LEAP_DAY, scale="utc").reshape(2, 4)
    jd_u, fr_u = time_to_utc_days(t)
    for scale in ("tai", "tt", "tdb"):
        jd, fr = time_to_utc_days(getattr(t, scale))
        assert jd.shape == (2, 4)
        np.testing.assert_allclose(((jd - jd_u) + (fr - fr_u)) * 86400.0, 0.0, atol=1e-6)


@settings(max_examples=200, deadline=None)
@given(st.floats(0.0, 3.0 * 86400.0))
def test_utc_days_round_trip_across_a_leap_second(sec):
    t = Time("2016-12-30T00:00:00", scale="utc") + sec * u.s
    jd, fr = time_to_utc_days(t)
    back = utc_days_to_time(jd, fr)
    # the leap second itself maps to the first second of the next day (sgp4 cannot name it)
    expected = 1.0 if "23:59:60" in t.isot else 0.0
    assert abs((back - t).to_value(u.s) - expected) < 1e-6


def test_satellite_epoch_is_the_tle_epoch_on_a_leap_second_day():
    sat = vv.Satellite.from_tle(L1, L2)
    # day 366.5 of 2016 is 2016-12-31 12:00:00 UTC exactly (was 12:00:00.500)
    assert abs((sat.epoch - Time("2016-12-31T12:00:00", scale="utc")).to_value(u.s)) < 1e-6
    assert vv.Catalog([sat]).epochs[0].isot == "2016-12-31T12:00:00.000"


@pytest.mark.parametrize("iso", LEAP_DAY[:6])
def test_teme_on_a_leap_second_day_matches_skyfield(iso):
    from skyfield.api import EarthSatellite, load

    ts = load.timescale(builtin=True)
    ref = EarthSatellite(L1, L2, ts=ts)
    date, clock = iso.split("T")
    y, m, d = (int(x) for x in date.split("-"))
    hh, mm, ss = clock.split(":")
    r_ref, v_ref, _ = ref._position_and_velocity_TEME_km(ts.utc(y, m, d, int(hh), int(mm),
                                                                 float(ss)))
    sat = vv.Satellite.from_tle(L1, L2)
    t = Time(iso, scale="utc")
    # was up to 7.7 km (1 s) off on 2016-12-31; a TT time is the same instant
    for when in (t, t.tt):
        st_ = sat.teme(when)
        assert np.linalg.norm(st_.r.to_value(u.km) - r_ref) < 1e-6
        assert np.linalg.norm(st_.v.to_value(u.km / u.s) - v_ref) < 1e-9
    batch = vv.Catalog([sat]).propagate(t[None])
    assert np.linalg.norm(batch.r.to_value(u.km)[0, 0] - r_ref) < 1e-6


def test_offsets_and_times_agree_on_a_leap_second_day():
    sat = vv.Satellite.from_tle(L1, L2)
    t = Time("2016-12-31T18:00:00", scale="utc")
    by_time = sat.teme(t).r.to_value(u.km)
    by_offset = sat.teme(6 * u.hour).r.to_value(u.km)
    assert np.linalg.norm(by_time - by_offset) < 1e-6  # was 1.9 km
    # a TimeDelta is an offset too (as StateVectors.propagate takes it): was a UnitsError
    by_delta = sat.teme(TimeDelta(6 * 3600.0, format="sec")).r.to_value(u.km)
    np.testing.assert_array_equal(by_delta, by_offset)


def test_omm_round_trip_keeps_a_leap_second_day_epoch():
    sat = vv.Satellite.from_tle(L1, L2)
    again = vv.Satellite.from_omm(sat.to_omm())
    assert abs((again.epoch - sat.epoch).to_value(u.s)) < 1e-6
    assert again.epoch.isot == "2016-12-31T12:00:00.000"


def test_ut1_times_use_the_installed_iers_table_never_a_download(monkeypatch, tmp_path):
    """A time in UT1 past the table's last observed day, once that day is 30 days old, made
    astropy try to download a new table and then raise ValueError ('predictive values more than
    30 days old') from Satellite.teme, find_passes, screen_conjunctions, propagate_cowell and a
    TIME_SYSTEM = UT1 OEM (interpolate, states_in, write)."""
    import astropy.utils.data
    from astropy.utils import iers

    from visviva.satellites.frames import offline_iers

    def no_download(*args, **kwargs):
        raise AssertionError(f"a download was attempted: {args!r}")

    with offline_iers():
        table = iers.earth_orientation_table.get()
    last = Time(table.meta["predictive_mjd"], format="mjd", scale="utc")
    monkeypatch.setattr(astropy.utils.data, "download_file", no_download)
    monkeypatch.setattr(iers.IERS_Auto, "time_now", property(lambda self: last + 365 * u.day))
    monkeypatch.setattr(iers.conf, "auto_max_age", 30.0)
    t_ut1 = Time((last + 10 * u.day).utc.isot, scale="ut1")
    with offline_iers():  # the test's own reference conversions
        t_tai = t_ut1.tai
    fields = vv.Satellite.from_tle(L1, L2).to_omm()
    sat = vv.Satellite.from_omm({**fields, "EPOCH": t_tai.utc.isot})  # elements of that day
    np.testing.assert_allclose(sat.teme(t_ut1).r.to_value(u.km),
                               sat.teme(t_tai).r.to_value(u.km), atol=1e-9)
    site = vv.GroundStation(40 * u.deg, -75 * u.deg)
    vv.find_passes(sat, site, t_ut1, t_ut1 + 2 * u.hour)
    site.find_events(sat, t_ut1, t_ut1 + 1 * u.hour)
    vv.screen_conjunctions(sat, None, t_ut1, t_ut1 + 1 * u.hour)
    state = sat.gcrs(t_tai).to_state_vectors()
    out = vv.propagate_cowell(state, t_ut1 + [0, 60] * u.s)
    assert abs(out.t[-1].to_value(u.s) - 60.0) < 1e-6
    at_ut1 = vv.StateVectors(state.r, state.v, vv.EARTH, epoch=t_ut1)  # the Sun's position
    vv.propagate_cowell(at_ut1, 60 * u.s, [vv.J2(), vv.ThirdBody(vv.SUN)])
    times = t_ut1 + np.arange(4) * 60 * u.s
    times_tai = t_tai + np.arange(4) * 60 * u.s
    gcrs = sat.gcrs(times_tai)
    from visviva.ccsds.oem import Ephemeris, OEMSegment

    seg = OEMSegment.from_states(times, gcrs.r.to_value(u.km), gcrs.v.to_value(u.km / u.s),
                                 object_name="X", time_system="UT1", degree=3)
    vv.write_oem(Ephemeris([seg]), tmp_path / "ut1.oem")
    eph = vv.read_oem(tmp_path / "ut1.oem")
    assert eph.segments[0].times.scale == "ut1"
    mid = eph.interpolate(times_tai[1] + 30 * u.s)
    assert np.linalg.norm((mid.r - sat.gcrs(times_tai[1] + 30 * u.s).r).to_value(u.km)) < 1e-3
    eph.segments[0].states_in("itrs")
    obs = vv.Observations(time=times, kind=["range"] * 4, value=[1000.0] * 4,
                          sigma=[0.01] * 4, station=[site] * 4)
    np.testing.assert_allclose(obs.offsets_s(t_tai), np.arange(4) * 60.0, atol=1e-6)
