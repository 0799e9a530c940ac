"""The frame code's fast start: ERFA rotations equal to astropy's, the IERS table cache, and a
``Satellite.gcrs`` process that never imports astropy.coordinates (issue 11, warm budget)."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings

import erfa
import numpy as np
import pytest
from astropy import units as u
from astropy.coordinates.builtin_frames import intermediate_rotation_transforms as irt
from astropy.time import Time
from astropy.utils import iers

import visviva as vv
from visviva import _iers_cache as iers_cache
from visviva._eop_table import EarthOrientationTable
from visviva.satellites import earth_rotation
from visviva.satellites.frames import gcrs_to_itrs, offline_iers

# 2019-2024 inside the installed IERS table (observed and predicted), 1900 before it, 2300
# beyond it (mean pole, UT1-UTC held: astropy warns)
INSIDE = Time("2019-12-09T16:38:29", scale="utc") + np.linspace(0.0, 4 * 365.25, 97) * u.day
with warnings.catch_warnings():
    warnings.simplefilter("ignore", erfa.ErfaWarning)  # "dubious year": no leap seconds known
    OUTSIDE = Time(["1900-06-01T00:00:00", "2300-01-01T12:00:00"], scale="utc")


@pytest.mark.parametrize("name", ["teme_to_itrs_mat", "gcrs_to_cirs_mat", "cirs_to_itrs_mat"])
@pytest.mark.parametrize("times", [INSIDE, INSIDE.tt, INSIDE[5], OUTSIDE, OUTSIDE[1]],
                         ids=["utc", "tt", "scalar", "outside", "outside-scalar"])
def test_matrices_equal_astropys_frame_graph_functions(name, times):
    """The same ERFA calls on the same time scales and IERS data: bit for bit equal."""
    with offline_iers(), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # outside the table both warn (mean pole, ERFA dubious)
        ours = getattr(earth_rotation, name)(times)
        theirs = getattr(irt, name)(times)
    assert ours.shape == np.shape(times) + (3, 3)
    np.testing.assert_array_equal(ours, theirs)


def test_outside_the_table_warns_and_uses_the_mean_pole():
    with offline_iers(), pytest.warns(Warning, match="polar motion"):
        xp, yp = earth_rotation.polar_motion_rad(OUTSIDE)
    mean = np.array(earth_rotation.MEAN_POLE_ARCSEC) * u.arcsec
    np.testing.assert_allclose(np.stack([xp, yp], -1), np.broadcast_to(mean.to_value(u.rad),
                                                                         (2, 2)), rtol=0)
    with offline_iers():  # inside: the table's values, ~0.1-0.5 arcsec
        xp, yp = earth_rotation.polar_motion_rad(INSIDE)
    assert np.all(np.abs(np.hypot(xp, yp)) < (1 * u.arcsec).to_value(u.rad))
    assert np.all(np.hypot(xp, yp) > 0)


@pytest.fixture
def fresh_table(monkeypatch, tmp_path):
    """No visviva table in this process (restored afterwards) and an empty cache directory."""
    monkeypatch.setattr(iers_cache, "_TABLE", None)
    monkeypatch.setenv("VISVIVA_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


def _assert_same_table(a, b):
    assert a.colnames == b.colnames and len(a) == len(b)
    for name in a.colnames:
        x, y = np.asarray(a[name]), np.asarray(b[name])
        if x.dtype.kind == "f":
            np.testing.assert_array_equal(x, y)
        else:
            assert (x == y).all(), name


def test_cache_round_trip_gives_astropys_table(fresh_table):
    with offline_iers():
        parsed = iers.earth_orientation_table.get()  # parsed by astropy and written
    assert type(parsed) is EarthOrientationTable and iers_cache._TABLE is parsed
    files = list(fresh_table.glob("iers_auto-*.pickle"))
    assert len(files) == 1
    loaded, from_file = iers_cache._load_or_parse()
    assert from_file and loaded is not parsed and type(loaded) is EarthOrientationTable
    _assert_same_table(loaded, parsed)
    assert loaded.meta["predictive_mjd"] == parsed.meta["predictive_mjd"]
    # and astropy's Time uses it: UT1 from the cached table equals UT1 from a fresh parse
    with offline_iers():
        ut1_cached = INSIDE.ut1.jd2
    with iers.earth_orientation_table.set(iers.IERS_Auto.read()):
        ut1_parsed = INSIDE.ut1.jd2
    np.testing.assert_array_equal(ut1_cached, ut1_parsed)


def test_astropys_own_table_is_neither_used_nor_changed(fresh_table, monkeypatch):
    table = iers.IERS_Auto.read()
    monkeypatch.setattr(iers.IERS_Auto, "iers_table", table)
    with offline_iers():
        assert type(iers.earth_orientation_table.get()) is EarthOrientationTable
    assert iers.IERS_Auto.iers_table is table
    assert iers.earth_orientation_table.get() is table  # outside visviva's calls: astropy's


def test_a_table_the_user_set_is_used_as_given(fresh_table):
    table = iers.IERS_B.open()
    with iers.earth_orientation_table.set(table), offline_iers():
        assert iers.earth_orientation_table.get() is table
    assert iers_cache._TABLE is None  # not even loaded


def test_damaged_cache_file_is_ignored_and_rewritten(fresh_table):
    path = iers_cache._cache_file(iers)
    path.parent.mkdir(parents=True)
    path.write_bytes(b"not a pickle")
    table, from_file = iers_cache._load_or_parse()  # parsed again
    assert not from_file and type(table) is EarthOrientationTable
    assert iers_cache._load_or_parse()[1] is True  # the rewritten file loads


def test_unwritable_cache_directory_still_works(fresh_table, monkeypatch, tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    monkeypatch.setenv("VISVIVA_CACHE_DIR", str(blocker / "cache"))  # cannot be created
    table, from_file = iers_cache._load_or_parse()
    assert not from_file and type(table) is EarthOrientationTable


def test_a_finals_file_in_the_working_directory_is_not_cached(fresh_table, monkeypatch,
                                                              tmp_path):
    parsed = iers.IERS_Auto.read()
    (tmp_path / "finals2000A.all").write_text("")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(iers.IERS_Auto, "read", lambda *a, **k: parsed)  # astropy reads it
    table, from_file = iers_cache._load_or_parse()
    assert not from_file and type(table) is EarthOrientationTable and len(table) > len(parsed)
    assert not fresh_table.exists()


def test_cache_dir_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.delenv("VISVIVA_CACHE_DIR", raising=False)
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "numba"))
    assert iers_cache.cache_dir() == tmp_path / "numba" / "visviva"
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert iers_cache.cache_dir() == tmp_path / "xdg" / "visviva"
    monkeypatch.setenv("VISVIVA_CACHE_DIR", str(tmp_path / "mine"))
    assert iers_cache.cache_dir() == tmp_path / "mine"


_SCRIPT = """
import sys
import numpy as np
from astropy import units as u
import visviva as vv
sat = vv.Satellite.from_tle(
    "1 25544U 98067A   19343.69339541  .00001764  00000-0  38792-4 0  9991",
    "2 25544  51.6439 211.2001 0007417  17.6667  85.6398 15.50103472202482")
t = np.linspace(0, 86400, 1441) * u.s
sat.gcrs(t).r, sat.itrs(t).r, sat.gcrs(t).altitude, sat.geodetic(t)
vv.satellites.ground_track(sat, t)
vv.GroundStation(52.0 * u.deg, 4.4 * u.deg).look(sat.gcrs(t))
print(sorted(m for m in sys.modules if m.startswith("astropy.coordinates")))
"""


def test_satellite_frames_do_not_import_astropy_coordinates(tmp_path):
    """The import of astropy.coordinates (~0.2-0.4 s) is not needed for TEME/GCRS/ITRS, the
    geodetic height, a ground track or look angles."""
    env = dict(os.environ, VISVIVA_CACHE_DIR=str(tmp_path))
    out = subprocess.run([sys.executable, "-c", _SCRIPT], capture_output=True, text=True,
                         check=True, env=env, timeout=600)
    assert out.stdout.strip().splitlines()[-1] == "[]"
    assert list(tmp_path.glob("iers_auto-*.pickle"))  # and the parsed table was kept


def test_geodetic_equals_astropys_earth_location():
    from astropy.coordinates import EarthLocation

    from visviva.satellites.frames import itrs_to_geodetic

    rng = np.random.default_rng(11)
    r = rng.normal(size=(500, 3)) * rng.uniform(100.0, 45000.0, size=(500, 1))
    r = np.concatenate([r, [[-7000.0, 0.0, 0.0], [-7000.0, -0.0, 10.0], [0.0, 0.0, 6400.0]]])
    lat, lon, h = itrs_to_geodetic(r * u.km)
    geo = EarthLocation.from_geocentric(*r.T, unit=u.km).to_geodetic("WGS84")
    np.testing.assert_allclose(lat.to_value(u.deg), geo.lat.deg, rtol=0, atol=1e-12)
    np.testing.assert_allclose(h.to_value(u.km), geo.height.to_value(u.km), rtol=0, atol=1e-9)
    dlon = (lon.to_value(u.deg) - geo.lon.wrap_at(180 * u.deg).deg + 180.0) % 360.0 - 180.0
    np.testing.assert_allclose(dlon, 0.0, atol=1e-12)
    assert np.all((lon.to_value(u.deg) >= -180.0) & (lon.to_value(u.deg) < 180.0))
    lat0, lon0, h0 = itrs_to_geodetic([6378.137, 0.0, 0.0])  # a scalar, plain km
    assert lat0.shape == () and abs(h0.to_value(u.km)) < 1e-12 and lon0.to_value(u.deg) == 0


def test_station_itrs_equals_astropys_earth_location():
    from astropy.coordinates import EarthLocation

    import visviva as vv

    for lat, lon, h in ((52.0, 4.4, 0.0), (-33.9, -70.7, 2400.0), (89.9, 179.99, -30.0)):
        site = vv.GroundStation(lat * u.deg, lon * u.deg, h * u.m)
        ref = EarthLocation.from_geodetic(lon * u.deg, lat * u.deg, h * u.m, ellipsoid="WGS84")
        np.testing.assert_allclose(site.itrs_km, ref.get_itrs().cartesian.xyz.to_value(u.km),
                                   rtol=0, atol=1e-11)
        assert site.itrs_km.shape == (3,) and site.itrs_km.dtype == np.float64


#: Delta T = TT - UT1 (s) on 1 January, USNO's historic table (Astronomical Almanac); years
#: whose 1 January is no step of the 1960s UTC (1965, 1972: the interpolation spans the step)
PUBLISHED_DELTA_T = {1963: 34.47, 1964: 35.03, 1966: 36.54, 1967: 37.43,
                     1968: 38.29, 1969: 39.20, 1970: 40.18, 1971: 41.17, 1973: 43.37}


def test_ut1_and_pole_before_the_bulletin_a_file_come_from_eop_c04():
    """1962-1972: UT1-UTC was held at 1973-01-02's 0.808 s (Delta T 0.5-0.8 s wrong, ~400 m
    of Earth rotation at the equator) and the pole at the 50-year mean."""
    t = Time([f"{y}-01-01" for y in PUBLISHED_DELTA_T], scale="tt")
    with offline_iers(), warnings.catch_warnings():
        warnings.simplefilter("error")  # no "polar motion ... before IERS data" any more
        ut1 = t.ut1
        xp, yp = earth_rotation.polar_motion_rad(t)
        b = iers.IERS_B.open()
        xb, yb = b.pm_xy(t)
    delta_t = ((t.jd1 - ut1.jd1) + (t.jd2 - ut1.jd2)) * 86400.0
    np.testing.assert_allclose(delta_t, list(PUBLISHED_DELTA_T.values()), atol=0.01)
    np.testing.assert_allclose(xp, xb.to_value(u.rad), rtol=1e-12)
    np.testing.assert_allclose(yp, yb.to_value(u.rad), rtol=1e-12)
    with offline_iers():  # from 1973 on the table is astropy's own, row for row
        table = iers.earth_orientation_table.get()
        ref = iers.IERS_Auto.read()
        k = len(table) - len(ref)
        assert k > 0 and table["MJD"][k] == ref["MJD"][0]
        np.testing.assert_array_equal(np.asarray(table["UT1_UTC"][k:]), np.asarray(ref["UT1_UTC"]))
        assert table.meta["predictive_index"] - k == ref.meta["predictive_index"]


_LOAD_ORDER_SCRIPT = """
import numpy as np
from astropy import units as u
from astropy.time import Time
t = Time(["1966-01-01", "1969-01-01"], scale="tt")
t.ut1  # astropy loads its own IERS table (no C04 rows before 1973) before visviva's first call
from visviva.satellites.frames import gcrs_to_itrs, offline_iers
t = Time(["1966-01-01", "1969-01-01"], scale="tt")  # a fresh Time, no UT1 cached on it
r = np.array([[7000.0, 0.0, 0.0], [0.0, 7000.0, 0.0]])
v = np.array([[0.0, 7.5, 0.0], [-7.5, 0.0, 0.0]])
ri, vi = gcrs_to_itrs(r * u.km, v * u.km / u.s, t)
with offline_iers():
    ut1 = t.ut1
print(repr([ri.to_value(u.km).tolist(), (((t.jd1 - ut1.jd1) + (t.jd2 - ut1.jd2)) * 86400).tolist()]))
"""


def test_the_c04_rows_are_used_whatever_table_astropy_loaded_first(tmp_path):
    """A Time(...).ut1 before visviva's first call left astropy's table without the 1962-1972
    rows in place, and visviva used it: Delta T 0.75 s wrong in 1966 (~350 m in ITRS)."""
    env = dict(os.environ, VISVIVA_CACHE_DIR=str(tmp_path))
    out = subprocess.run([sys.executable, "-c", _LOAD_ORDER_SCRIPT], capture_output=True,
                         text=True, check=True, env=env, timeout=600)
    r_itrs, delta_t = eval(out.stdout.strip().splitlines()[-1])  # noqa: S307 (our own print)
    np.testing.assert_allclose(delta_t, [PUBLISHED_DELTA_T[1966], PUBLISHED_DELTA_T[1969]],
                               atol=0.01)
    # the reference: astropy's frame graph with the EOP C04 table (IERS-B) set explicitly
    from astropy.coordinates import GCRS, ITRS, CartesianRepresentation

    t = Time(["1966-01-01", "1969-01-01"], scale="tt")
    r = np.array([[7000.0, 0.0, 0.0], [0.0, 7000.0, 0.0]])
    with iers.earth_orientation_table.set(iers.IERS_B.open()):
        ref = GCRS(CartesianRepresentation(r.T * u.km), obstime=t).transform_to(ITRS(obstime=t))
    ref_km = ref.cartesian.xyz.to_value(u.km).T
    # 0.01 s of Earth rotation is 5 m at 7000 km
    np.testing.assert_allclose(r_itrs, ref_km, rtol=0, atol=0.005)


def test_times_past_the_table_warn_naming_the_date_and_the_error(fresh_table):
    import visviva as vv

    sat = vv.Satellite.from_tle(
        "1 25544U 98067A   19343.69339541  .00001764  00000-0  38792-4 0  9991",
        "2 25544  51.6439 211.2001 0007417  17.6667  85.6398 15.50103472202482")
    site = vv.GroundStation(52.0 * u.deg, 4.4 * u.deg)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # inside the table (observed and predicted): silent
        warnings.simplefilter("ignore", vv.StaleElementSetWarning)  # a 2019 TLE, years away
        sat.itrs(INSIDE)
        site.look(sat.gcrs(INSIDE))
    late = Time("2030-06-01T00:00:00", scale="utc") + np.arange(3) * u.hour
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sat.itrs(late)
    ours = [w for w in caught if issubclass(w.category, vv.EarthOrientationWarning)]
    assert len(ours) == 1  # once per call, however many conversions the call makes
    msg = str(ours[0].message)
    assert "2030-06-01" in msg and "2027-10-29" in msg and "UT1-UTC is held" in msg
    assert "~2.6 s" in msg and "~1.2 km" in msg  # 2.6 years at up to 1 s a year, 0.465 km/s
    states = sat.gcrs(late)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        site.look(states)
    ours = [w for w in caught if issubclass(w.category, vv.EarthOrientationWarning)]
    assert len(ours) == 1 and "2030-06-01" in str(ours[0].message)
    assert ours[0].filename == __file__  # it points at the caller's line, not astropy's
    # TEME -> GCRS does not depend on UT1 (GMST and the Earth rotation angle cancel): silent,
    # unless the times themselves are in UT1 (converted to UTC for SGP4 with the held value)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sat.gcrs(late)
    assert not [w for w in caught if issubclass(w.category, vv.EarthOrientationWarning)
                or "polar motion" in str(w.message)]
    with pytest.warns(vv.EarthOrientationWarning, match="times given in UT1"):
        sat.gcrs(Time("2030-06-01T00:00:00", scale="ut1"))
    with pytest.warns(vv.EarthOrientationWarning, match="before the IERS table"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", erfa.ErfaWarning)
            gcrs_to_itrs([7000.0, 0, 0] * u.km, [0, 7.5, 0] * u.km / u.s,
                         Time("1955-01-01", scale="utc"))
    # the held values are astropy's own: the same numbers as astropy's IERS_Auto there
    with offline_iers(), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ours_ut1 = late.ut1
        with iers.earth_orientation_table.set(iers.IERS_Auto.read()):
            theirs_ut1 = late.ut1
    np.testing.assert_array_equal(ours_ut1.jd2, theirs_ut1.jd2)


def test_a_time_carrying_another_tables_ut1_says_so():
    """astropy caches t.ut1 on the Time: one computed with astropy's own table (0.808 s held
    before 1973) was used silently, 0.86 s of rotation (0.4 km at the equator) off in 1966."""
    t = Time(["1966-01-01", "1969-01-01"], scale="tt")
    with iers.earth_orientation_table.set(iers.IERS_Auto.read()):
        t.ut1  # noqa: B018 (cached on t with astropy's table)
    r = np.array([[7000.0, 0.0, 0.0], [0.0, 7000.0, 0.0]]) * u.km
    v = np.zeros((2, 3)) * u.km / u.s
    with pytest.warns(vv.EarthOrientationWarning, match=r"carries UT1-UTC = \+0\.8079 s"):
        gcrs_to_itrs(r, v, t)
    fresh = Time(t.jd1, t.jd2, format="jd", scale="tt")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        gcrs_to_itrs(r, v, fresh)
        gcrs_to_itrs(r, v, fresh)  # now carrying visviva's own value: silent
        with offline_iers():
            ut1 = fresh.ut1
    delta_t = ((fresh.jd1 - ut1.jd1) + (fresh.jd2 - ut1.jd2)) * 86400.0
    np.testing.assert_allclose(delta_t, [PUBLISHED_DELTA_T[1966], PUBLISHED_DELTA_T[1969]],
                               atol=0.01)


# The fractional UTC steps of the 1960s inside the EOP C04 rows (TAI - UTC jumped by these, s)
UTC_STEPS = {"1963-11-01": 0.1, "1965-01-01": 0.1, "1968-02-01": -0.1, "1972-01-01": 0.107758}


def _ut1_minus_tai_s(t):
    with offline_iers():
        ut1, tai = t.ut1, t.tai
    return ((ut1.jd1 - tai.jd1) + (ut1.jd2 - tai.jd2)) * 86400.0


@pytest.mark.parametrize("day", list(UTC_STEPS))
def test_ut1_is_continuous_across_the_1960s_utc_steps(day):
    """UT1 - TAI is smooth (the Earth's rotation has no steps: it changes by < 5 ms a day).
    astropy interpolated UT1 - UTC across a 0.1 s step of UTC, so UT1 ran up to 0.1 s wrong
    over the day before it (51 m in a LEO's ITRS position) and jumped back at 00:00 (before:
    jumps of 0.096-0.108 s; after: < 0.05 ms per 15 min)."""
    t0 = Time(day, scale="utc")
    t = t0 + np.arange(-96, 97) * (15 * u.min)  # two days, every 15 min (t0 + 0 s included)
    jumps = np.abs(np.diff(_ut1_minus_tai_s(t)))
    assert jumps.max() < 1e-4  # 5 ms a day is 52 us per 15 min


def _teme_to_itrs_from_c04_rows(r_km, t):
    """Independent TEME -> ITRS: UT1 = TAI + (UT1 - TAI) interpolated linearly between the
    EOP C04 (astropy IERS_B) rows, where UT1 - TAI = (UT1 - UTC) - (TAI - UTC at 0h)."""
    b = iers.IERS_B.open()
    mjd_rows = np.asarray(b["MJD"].to_value(u.d))
    tai = t.tai
    mjd_tai = (tai.jd1 - 2400000.5) + tai.jd2
    k = np.nonzero((mjd_rows > mjd_tai - 3) & (mjd_rows < mjd_tai + 3))[0]
    iy, im, iday, _ = erfa.jd2cal(2400000.5, mjd_rows[k])
    ut1_tai = np.asarray(b["UT1_UTC"][k].to_value(u.s)) - erfa.dat(iy, im, iday, 0.0)
    # the rows are at 0h UTC: their TAI is 0h + TAI - UTC (< 11 s, negligible here)
    ut1_minus_tai = np.interp(mjd_tai, mjd_rows[k] + erfa.dat(iy, im, iday, 0.0) / 86400.0,
                              ut1_tai)
    gmst = erfa.gmst82(tai.jd1, tai.jd2 + ut1_minus_tai / 86400.0)
    with offline_iers():
        xp, yp = earth_rotation.polar_motion_rad(t)
    m = erfa.c2tcio(np.eye(3), gmst, erfa.pom00(xp, yp, 0.0))
    return m @ r_km


@pytest.mark.parametrize("when", ["1964-12-31T23:59:00", "1965-01-01T00:00:00",
                                  "1968-01-31T20:00:00", "1971-12-31T23:00:00",
                                  "1966-06-15T21:00:00"])
def test_itrs_on_a_1960s_utc_step_day_matches_the_c04_rows(when):
    """TEME -> ITRS near the 1960s UTC steps against an independent UT1 from the C04 rows:
    1964-12-31T23:59 was 50.9 m off (0.1 s of rotation at 7000 km), 00:00 reached as
    ``t0 + 0 s`` (held by astropy as the end of the previous day) 50.9 m too; now < 1 cm."""
    from visviva.satellites.frames import teme_to_itrs

    r = np.array([7000.0, 100.0, 50.0])
    t = Time(when, scale="utc")
    for tk in (t, t + 0 * u.s):  # astropy holds the latter as the previous day's end at 00:00
        ri, _ = teme_to_itrs(r, np.array([0.0, 7.5, 0.0]), tk)
        np.testing.assert_allclose(ri, _teme_to_itrs_from_c04_rows(r, tk), rtol=0,
                                   atol=1e-5)  # 1 cm


def test_from_1972_on_ut1_is_astropys_number_for_number():
    """The 1960s correction leaves the leap-second era alone: astropy's own interpolation."""
    t = Time("1972-01-02", scale="utc") + np.linspace(0.0, 50 * 365.25, 401) * u.day
    with offline_iers():
        table = iers.earth_orientation_table.get()
        ours = table.ut1_utc(t.jd1, t.jd2)
    theirs = iers.IERS.ut1_utc(table, t.jd1, t.jd2)
    np.testing.assert_array_equal(ours, theirs)


def test_the_mean_pole_warning_comes_once_per_call():
    """A rotation with its velocity evaluates the pole at t and t +- 0.5 s: astropy's "polar
    motions ... 50-yr mean" warning came three times per call (beside visviva's
    EarthOrientationWarning); now once, pointing at the caller's line."""
    from astropy.utils.exceptions import AstropyWarning

    from visviva.satellites.frames import teme_to_itrs

    t = Time("2029-06-01", scale="utc") + np.arange(5) * u.min
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        teme_to_itrs(np.array([7000.0, 0, 0]), np.array([0, 7.5, 0]), t)
    pole = [w for w in caught if issubclass(w.category, AstropyWarning)
            and "polar motions" in str(w.message)]
    assert len(pole) == 1 and pole[0].filename == __file__
    assert sum(issubclass(w.category, vv.EarthOrientationWarning) for w in caught) == 1
