"""TEME -> GCRS -> ITRS -> geodetic through astropy, checked against astropy and Skyfield."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from astropy import units as u
from astropy.coordinates import (
    GCRS,
    ITRS,
    TEME,
    CartesianDifferential,
    CartesianRepresentation,
)
from astropy.time import Time
from astropy.utils import iers

import visviva as vv
from visviva.satellites.frames import (
    WGS84_A_KM,
    gcrs_to_itrs,
    itrs_to_gcrs,
    itrs_to_geodetic,
    teme_to_gcrs,
    teme_to_itrs,
    transform_matrices,
)

ONE_MM = 1e-6  # km
ONE_M = 1e-3  # km
TEN_M = 1e-2  # km

# ISS (ZARYA), a 2024 element set: inside the installed IERS tables (no extrapolation)
ISS_1 = "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009"
ISS_2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340"
# a Molniya orbit (deep space, SDP4) from the SGP4 verification set
MOLNIYA_1 = "1 08195U 75081A   24176.33215444  .00000099  00000-0  11873-3 0   813"
MOLNIYA_2 = "2 08195  64.1586 279.0717 6877146 264.7651  20.2257  2.00491383225656"


@pytest.fixture(scope="module")
def sats():
    return [
        vv.Satellite.from_tle(ISS_1, ISS_2, name="ISS"),
        vv.Satellite.from_tle(MOLNIYA_1, MOLNIYA_2, name="MOLNIYA", verify_checksum=False),
    ]


def _times(sat):
    return sat.epoch + np.linspace(-0.5, 2.0, 11) * u.day


def test_gcrs_and_itrs_agree_with_astropy_frames(sats):
    for sat in sats:
        t = _times(sat)
        teme = sat.teme(t)
        rep = CartesianRepresentation(
            teme.r.T, differentials=CartesianDifferential(teme.v.T)
        )
        with iers.conf.set_temp("auto_download", False):
            coord = TEME(rep, obstime=t)
            g = coord.transform_to(GCRS(obstime=t))
            i = coord.transform_to(ITRS(obstime=t))
        ours_g, ours_i = sat.gcrs(t), sat.itrs(t)
        assert np.abs((ours_g.r - g.cartesian.xyz.T).to_value(u.km)).max() < ONE_MM
        assert np.abs((ours_g.v - g.velocity.d_xyz.T).to_value(u.km / u.s)).max() < 1e-9
        assert np.abs((ours_i.r - i.cartesian.xyz.T).to_value(u.km)).max() < ONE_MM
        assert np.abs((ours_i.v - i.velocity.d_xyz.T).to_value(u.km / u.s)).max() < 1e-9


def test_agree_with_skyfield_earth_satellite(sats, skyfield_ts):
    from skyfield.api import EarthSatellite
    from skyfield.framelib import itrs

    for sat, (l1, l2) in zip(sats, [(ISS_1, ISS_2), (MOLNIYA_1, MOLNIYA_2)], strict=True):
        es = EarthSatellite(l1, l2, sat.name, skyfield_ts)
        t = _times(sat)
        at = es.at(skyfield_ts.from_astropy(t))
        g = sat.gcrs(t)
        assert np.abs(g.r.to_value(u.km) - at.position.km.T).max() < ONE_M
        assert np.abs(g.v.to_value(u.km / u.s) - at.velocity.km_per_s.T).max() < 1e-6
        r_itrs, v_itrs = at.frame_xyz_and_velocity(itrs)
        i = sat.itrs(t)
        assert np.abs(i.r.to_value(u.km) - r_itrs.km.T).max() < TEN_M
        assert np.abs(i.v.to_value(u.km / u.s) - v_itrs.km_per_s.T).max() < 1e-5


def test_geodetic_agrees_with_skyfield_wgs84(sats, skyfield_ts):
    from skyfield.api import EarthSatellite, wgs84

    sat = sats[0]
    es = EarthSatellite(ISS_1, ISS_2, sat.name, skyfield_ts)
    t = _times(sat)
    where = wgs84.geographic_position_of(es.at(skyfield_ts.from_astropy(t)))
    lat, lon, height = sat.geodetic(t)
    # 10 m on the ground is 1e-4 deg
    assert np.abs(lat.to_value(u.deg) - where.latitude.degrees).max() < 1e-4
    dlon = (lon.to_value(u.deg) - where.longitude.degrees + 180) % 360 - 180
    assert np.abs(dlon).max() < 1e-4
    assert np.abs(height.to_value(u.km) - where.elevation.km).max() < TEN_M
    assert lat.unit == u.deg and np.all(np.abs(lon.to_value(u.deg)) <= 180)


def test_round_trips_and_norms():
    rng = np.random.default_rng(1)
    r = rng.normal(size=(4, 5, 3)) * 7000 * u.km
    v = rng.normal(size=(4, 5, 3)) * u.km / u.s
    t = Time("2020-03-01T00:00:00", scale="utc") + np.linspace(0, 1, 5) * u.day
    rg, vg = teme_to_gcrs(r, v, t)
    assert rg.shape == (4, 5, 3)
    # rotations keep lengths
    np.testing.assert_allclose(
        np.linalg.norm(rg, axis=-1).to_value(u.km), np.linalg.norm(r, axis=-1).to_value(u.km),
        rtol=1e-13,
    )
    ri, vi = gcrs_to_itrs(rg, vg, t)
    rb, vb = itrs_to_gcrs(ri, vi, t)
    assert np.abs((rb - rg).to_value(u.km)).max() < ONE_MM
    assert np.abs((vb - vg).to_value(u.km / u.s)).max() < 1e-9
    ri2, vi2 = teme_to_itrs(r, v, t)
    assert np.abs((ri2 - ri).to_value(u.km)).max() < ONE_MM


def test_geodetic_of_known_points():
    a, f = 6378.137, 1 / 298.257223563
    b = a * (1 - f)
    r = np.array([[a + 1.0, 0, 0], [0, a, 0], [0, 0, b + 2.0], [-a, 0, 0]]) * u.km
    lat, lon, h = itrs_to_geodetic(r)
    np.testing.assert_allclose(lat.to_value(u.deg), [0, 0, 90, 0], atol=1e-12)
    np.testing.assert_allclose(lon.to_value(u.deg)[:2], [0, 90], atol=1e-12)
    assert abs(abs(lon.to_value(u.deg)[3]) - 180) < 1e-12
    np.testing.assert_allclose(h.to_value(u.km), [1.0, 0.0, 2.0, 0.0], atol=1e-9)


def test_frames_need_a_time():
    with pytest.raises(vv.InvalidInputError, match="astropy Time"):
        teme_to_gcrs(np.zeros(3) * u.km + 7000 * u.km, np.ones(3) * u.km / u.s, 0.0)


def test_ground_track_segments_and_plots(sats, tmp_path):
    from visviva.satellites.groundtrack import eclipse_fraction, ground_track
    from visviva.satellites.plots import plot_altitude_eclipse, plot_ground_track, plot_orbit_3d

    sat = sats[0]
    t = np.linspace(0, 190, 240) * u.min
    track = ground_track(sat, t)
    lon = track.longitude.to_value(u.deg)
    for seg in track.segments():
        assert np.all(np.abs(np.diff(lon[seg])) < 180)
    # the ISS never goes beyond its inclination in latitude
    assert np.abs(track.latitude.to_value(u.deg)).max() < 51.6416 + 0.2
    frac = eclipse_fraction(sat, t)
    assert frac.shape == (240,) and np.all((frac >= 0) & (frac <= 1))
    # a low orbit spends ~35 % of each revolution in the Earth's shadow
    assert 0.25 < np.mean(frac < 1) < 0.45
    for k, fig in enumerate(
        [plot_ground_track(sat, t), plot_orbit_3d(sat, t), plot_altitude_eclipse(sat, t)]
    ):
        assert fig.axes and fig.axes[0].lines
        path = tmp_path / f"p{k}.png"
        fig.savefig(path)
        assert path.stat().st_size > 10_000


def test_eclipse_agrees_with_a_cylindrical_shadow_from_astropy_sun(sats):
    from astropy.coordinates import get_body

    from visviva.satellites.groundtrack import eclipse_fraction

    sat = sats[0]
    t = sat.epoch + np.linspace(0, 190, 380) * u.min
    with iers.conf.set_temp("auto_download", False):
        sun = get_body("sun", t).cartesian.xyz.to_value(u.km).T
    r = sat.gcrs(t).r.to_value(u.km)
    s_hat = sun / np.linalg.norm(sun, axis=-1, keepdims=True)
    along = np.sum(r * s_hat, axis=-1)
    perp = np.linalg.norm(r - along[:, None] * s_hat, axis=-1)
    in_cylinder = (along < 0) & (perp < vv.EARTH.radius.to_value(u.km))
    frac = eclipse_fraction(sat, t)
    # conical and cylindrical shadows differ only within ~10 s of the shadow edges
    clear = (frac == 0) | (frac == 1)
    assert clear.mean() > 0.95
    assert np.mean((frac[clear] == 0) == in_cylinder[clear]) > 0.98


@pytest.mark.parametrize("source, target", [("teme", "gcrs"), ("teme", "itrs"),
                                            ("gcrs", "itrs"), ("itrs", "gcrs")])
def test_batch_transform_equals_astropy_per_state(source, target):
    from visviva.satellites.frames import _transform, transform_batch

    rng = np.random.default_rng(3)
    t = Time("2024-03-01T00:00:00", scale="utc") + np.linspace(0, 2, 7) * u.day
    r = rng.normal(size=(9, 7, 3)) * 7000.0
    v = rng.normal(size=(9, 7, 3)) * 5.0
    rb, vb = transform_batch(r, v, t, source, target)
    rd, vd = _transform(r, v, t, source, target)
    assert np.abs(rb - rd).max() < 1e-9  # km
    assert np.abs(vb - vd).max() < 1e-9  # km/s


@pytest.mark.parametrize("shape", [(0,), (4, 0)])
def test_empty_states_convert_to_empty_states(shape):
    from visviva.satellites.frames import itrs_to_geodetic, teme_to_gcrs, teme_to_itrs

    t = Time("2024-03-01T00:00:00", scale="utc") + np.zeros(shape) * u.s
    r = np.zeros(shape + (3,)) * u.km
    v = np.zeros(shape + (3,)) * (u.km / u.s)
    for convert in (teme_to_gcrs, teme_to_itrs):
        ro, vo = convert(r, v, t)
        assert ro.shape == vo.shape == shape + (3,) and ro.unit == u.km
    lat, lon, h = itrs_to_geodetic(r)
    assert lat.shape == h.shape == shape


@pytest.mark.parametrize("step_min", [1.0, 7.0, 600.0, 2880.0])
def test_dense_and_sparse_times_agree_with_astropy_frames(sats, step_min):
    """Dense times use the interpolated precession-nutation matrix, sparse ones astropy's own at
    every time: both equal astropy's frame graph (GCRS, ITRS, GCRS <-> ITRS)."""
    sat = sats[0]
    t = sat.epoch + np.arange(40) * step_min * u.min
    teme = sat.teme(t)
    rep = CartesianRepresentation(teme.r.T, differentials=CartesianDifferential(teme.v.T))
    with iers.conf.set_temp("auto_download", False):
        g = TEME(rep, obstime=t).transform_to(GCRS(obstime=t))
        i = g.transform_to(ITRS(obstime=t))
    ours_g = sat.gcrs(t)
    ours_i = gcrs_to_itrs(ours_g.r, ours_g.v, t)
    back = itrs_to_gcrs(*ours_i, t)
    for (r, v), ref in (((ours_g.r, ours_g.v), g), (ours_i, i), (back, g)):
        assert np.abs((r - ref.cartesian.xyz.T).to_value(u.km)).max() < 1e-9  # 1 micrometre
        assert np.abs((v - ref.velocity.d_xyz.T).to_value(u.km / u.s)).max() < 1e-10


def test_catalog_gcrs_equals_each_satellite(sats):
    t = sats[0].epoch + np.arange(0, 1441, 30) * u.min
    cat = vv.Catalog([sats[0], sats[0]])
    batch = cat.propagate(t, frame="gcrs")
    one = sats[0].gcrs(t)
    np.testing.assert_allclose(batch.r.value[1], one.r.value, rtol=0, atol=1e-9)
    np.testing.assert_allclose(batch.v.value[1], one.v.value, rtol=0, atol=1e-12)


def test_geodetic_of_a_missing_position_is_nan_not_the_pole():
    """ERFA's gc2gde answers NaN with the north pole at -6356.75 km (and inf with longitude 0):
    the failed rows of a batch (``on_error="nan"``) read as a satellite at the pole inside the
    Earth. Now NaN in every coordinate; finite rows unchanged (a Quantity with NaN is refused
    by the unit conversion)."""
    r = np.array([[np.nan, 0.0, 0.0], [7000.0, np.nan, 0.0], [0.0, 0.0, np.inf],
                  [7000.0, 0.0, 0.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # and no RuntimeWarning from ERFA
        lat, lon, h = itrs_to_geodetic(r)
    for q in (lat, lon, h):
        assert np.isnan(q[:3]).all()
    assert lat[3].to_value(u.deg) == 0.0 and lon[3].to_value(u.deg) == 0.0
    assert abs(h[3].to_value(u.km) - (7000.0 - WGS84_A_KM)) < 1e-9
    lat0, lon0, h0 = itrs_to_geodetic(np.array([np.nan, 1.0, 2.0]))  # a scalar stays one
    assert lat0.shape == () and np.isnan(lat0) and np.isnan(lon0) and np.isnan(h0)


def test_frame_names_any_case_and_refusals_that_say_what_to_pass(sats):
    """"GCRS", "Teme", "ITRF", "GCRF" were refused ("cannot convert teme to 'GCRS'; choose
    'gcrs' or 'itrs'", a GCRS batch could not go to TEME at all); other frames are refused
    with what to pass instead (EME2000/J2000: the frame bias)."""
    from visviva.satellites.frames import frame_name, transform_matrices

    cat = vv.Catalog(sats[:1])  # (the Molniya set is 175 days from the ISS's epoch)
    t = sats[0].epoch + np.arange(3) * u.min
    ref = cat.propagate(t, frame="gcrs")
    for name in ("GCRS", "Gcrs", " gcrf "):
        got = cat.propagate(t, frame=name)
        assert got.frame == "gcrs"
        np.testing.assert_array_equal(got.r.value, ref.r.value)
    assert cat.propagate(t, frame="ITRF").frame == "itrs"
    back = ref.to_frame("TEME")  # GCRS -> TEME: the SGP4 states again
    teme = cat.propagate(t, frame="teme")
    assert back.frame == "teme"
    assert np.abs(back.r.to_value(u.km) - teme.r.to_value(u.km)).max() < ONE_MM
    np.testing.assert_array_equal(transform_matrices(t, "TEME", "ITRS"),
                                  transform_matrices(t, "teme", "itrs"))
    for name, words in (("EME2000", "frame bias"), ("J2000", "frame bias"), ("ICRS", "'gcrs'"),
                        ("TOD", "equation of the equinoxes"), ("bogus", "'teme', 'gcrs'"),
                        (None, "got None")):
        with pytest.raises(vv.InvalidInputError, match=words):
            frame_name(name)
        with pytest.raises(vv.InvalidInputError, match=words):
            cat.propagate(t, frame=name)


@pytest.mark.filterwarnings("ignore::erfa.ErfaWarning")
def test_times_beyond_astropys_years_are_refused_clearly():
    """Year -4986 raised ERFA's bare 'taiutc ... unacceptable date'; year 10,001 and JD 1e8
    (year ~269,000) returned a rotation from polynomials far outside their fit, silently."""
    r, v = np.array([7000.0, 0.0, 0.0]), np.array([0.0, 7.5, 0.0])
    for jd in (-100000.5, 5373884.5, 1e8):
        t = Time(jd, format="jd", scale="tt")
        for f in (teme_to_gcrs, teme_to_itrs, gcrs_to_itrs):
            with pytest.raises(vv.DomainError, match="years -4712 to 9999"):
                f(r, v, t)
    t = Time([2451545.0, 1e8], format="jd", scale="tt")
    with pytest.raises(vv.DomainError, match="JD 100000000.0"):
        transform_matrices(t, "teme", "gcrs")
    ri, _ = teme_to_itrs(r, v, Time(5373484.0, format="jd", scale="tt"))  # 9999: still served
    assert np.isfinite(ri).all()
