"""GroundStation: geodetic site, ITRS position, GCRS position and velocity against astropy."""

import pickle

import numpy as np
import pytest
from astropy import units as u
from astropy.coordinates import GCRS, ITRS, CartesianRepresentation, EarthLocation
from astropy.time import Time

import visviva as vv
from visviva.ground import GroundStation

ONE_METER = 1e-3  # km
ONE_MM_S = 1e-6  # km/s


def test_vallado_example_7_1_site_ecef():
    # Vallado (2013), Example 7-1: phi_gd = 39.007 deg, lambda = -104.883 deg, h_ellp = 2187 m
    # gives r_site (ECEF) = (-1275.1219, -4797.9890, 3994.2975) km.
    site = GroundStation(39.007 * u.deg, -104.883 * u.deg, 2187 * u.m)
    np.testing.assert_allclose(site.itrs_km, [-1275.1219, -4797.9890, 3994.2975],
                               atol=ONE_METER)


def test_attributes_and_repr():
    site = GroundStation(52.2 * u.deg, -359.88 * u.deg, 30 * u.m, name="Cambridge")
    assert site.lat.unit == u.deg and site.lat.value == pytest.approx(52.2)
    assert site.lon.value == pytest.approx(0.12)
    assert site.height.to_value(u.m) == pytest.approx(30.0)
    assert site.name == "Cambridge"
    assert isinstance(site.location, EarthLocation)
    assert "Cambridge" in repr(site)
    geo = site.location.to_geodetic("WGS84")
    assert geo.lat.deg == pytest.approx(52.2, abs=1e-12)
    assert geo.height.to_value(u.m) == pytest.approx(30.0, abs=1e-6)


def test_enu_axes_orthonormal_and_up_is_ellipsoid_normal():
    site = GroundStation(-33.3 * u.deg, 149.1 * u.deg, 600 * u.m)
    m = site.enu_matrix
    np.testing.assert_allclose(m @ m.T, np.eye(3), atol=1e-15)
    assert np.linalg.det(m) == pytest.approx(1.0)  # right-handed east, north, up
    # moving 1 m up along the normal changes only the height
    up = GroundStation(-33.3 * u.deg, 149.1 * u.deg, 601 * u.m)
    np.testing.assert_allclose(up.itrs_km - site.itrs_km, m[2] * ONE_METER, atol=1e-9)


def test_from_earth_location_round_trip():
    loc = EarthLocation.from_geodetic(-70.7 * u.deg, -30.2 * u.deg, 2.7 * u.km)
    site = GroundStation.from_earth_location(loc, name="Pachon")
    np.testing.assert_allclose(site.itrs_km, loc.get_itrs().cartesian.xyz.to_value(u.km),
                               atol=1e-9)
    assert site.name == "Pachon"


def test_gcrs_position_velocity_against_astropy_itrs_transform():
    site = GroundStation(28.5 * u.deg, -80.6 * u.deg, 10 * u.m)
    t = Time("2024-06-01T00:00:00", scale="utc") + np.linspace(0, 2, 7).reshape(7, 1) * u.h \
        + np.array([0.0, 1.0]) * u.min
    r, v = site.gcrs_position_velocity(t)
    assert r.shape == (7, 2, 3) and v.shape == (7, 2, 3)
    assert r.dtype == np.float64 and isinstance(r, np.ndarray)
    itrs = ITRS(CartesianRepresentation(site.itrs_km * u.km), obstime=t)
    ref = itrs.transform_to(GCRS(obstime=t)).cartesian.xyz.to_value(u.km)
    np.testing.assert_allclose(r, np.moveaxis(ref, 0, -1), atol=ONE_METER)
    # velocity: the derivative of the position (central difference over 1 s)
    rp, _ = site.gcrs_position_velocity(t + 0.5 * u.s)
    rm, _ = site.gcrs_position_velocity(t - 0.5 * u.s)
    np.testing.assert_allclose(v, rp - rm, atol=ONE_MM_S)
    # speed: omega times the distance from the rotation axis (0.4087 km/s at 28.5 deg)
    rho = np.hypot(*site.itrs_km[:2])
    np.testing.assert_allclose(np.linalg.norm(v, axis=-1), 7.292115e-5 * rho, rtol=1e-4)


def test_gcrs_scalar_time():
    site = GroundStation(0 * u.deg, 0 * u.deg)
    r, v = site.gcrs_position_velocity(Time("2020-01-01", scale="utc"))
    assert r.shape == (3,) and v.shape == (3,)
    assert np.linalg.norm(r) == pytest.approx(6378.137, abs=1e-6)


def test_gcrs_position_velocity_refuses_masked_times():
    """A masked time (a masked pass-table cell) gave the site's place at the hidden date
    (audit50); look() already refused it."""
    site = GroundStation(52.2 * u.deg, 0.12 * u.deg)
    t = Time("2024-01-01T16:36:00", scale="utc") + np.arange(3) * 60 * u.s
    t[1] = np.ma.masked
    with pytest.raises(vv.InvalidInputError, match="masked"):
        site.gcrs_position_velocity(t)
    assert site.gcrs_position_velocity(t[[0, 2]])[0].shape == (2, 3)


@pytest.mark.parametrize("kwargs, error", [
    ({"lat": 52.0, "lon": 0.0 * u.deg}, vv.UnitsError),
    ({"lat": 52.0 * u.deg, "lon": 0.0}, vv.UnitsError),
    ({"lat": 91.0 * u.deg, "lon": 0.0 * u.deg}, vv.DomainError),
    ({"lat": 2.0 * u.rad, "lon": 0.0 * u.deg}, vv.DomainError),
    ({"lat": np.nan * u.deg, "lon": 0.0 * u.deg}, vv.InvalidInputError),
    ({"lat": 10 * u.m, "lon": 0.0 * u.deg}, vv.UnitsError),
    ({"lat": [1, 2] * u.deg, "lon": 0.0 * u.deg}, vv.ShapeError),
    ({"lat": 1 * u.deg, "lon": 0.0 * u.deg, "height": 5.0}, vv.UnitsError),
    ({"lat": 1 * u.deg, "lon": 0.0 * u.deg, "height": -500 * u.km}, vv.DomainError),
    ({"lat": 1 * u.deg, "lon": 0.0 * u.deg, "height": np.inf * u.m}, vv.InvalidInputError),
    ({"lat": 1 * u.deg, "lon": np.inf * u.deg}, vv.InvalidInputError),
    ({"lat": 1 * u.deg, "lon": np.nan * u.deg}, vv.InvalidInputError),
])
def test_bad_input(kwargs, error):
    with pytest.raises(error):
        GroundStation(**kwargs)


def test_wrong_angle_unit_message_does_not_suggest_plain_floats():
    # the generic units message ended "(or a plain float in radians)", which GroundStation
    # refuses: the advice contradicted the rule
    for kwargs in ({"lat": 10 * u.m, "lon": 0.0 * u.deg}, {"lat": 1 * u.deg, "lon": 3 * u.s}):
        with pytest.raises(vv.UnitsError) as info:
            GroundStation(**kwargs)
        msg = str(info.value)
        assert "plain float" not in msg and "u.deg" in msg


def test_gcrs_needs_time():
    with pytest.raises(vv.InvalidInputError, match="astropy Time"):
        GroundStation(0 * u.deg, 0 * u.deg).gcrs_position_velocity(2451545.0)


def test_pickle_and_equality():
    site = GroundStation(10 * u.deg, 20 * u.deg, 5 * u.m, name="x")
    again = pickle.loads(pickle.dumps(site))
    assert again == site and hash(again) == hash(site)
    np.testing.assert_array_equal(again.itrs_km, site.itrs_km)


@pytest.mark.parametrize(("height", "lon"), [
    (1e6 * u.km, 0 * u.deg),      # regression: accepted (a site 1e6 km above the ellipsoid)
    (100.001 * u.km, 0 * u.deg),
    (-12.001 * u.km, 0 * u.deg),
    (-100 * u.km, 0 * u.deg),     # accepted before (the old floor was -100 km)
    (30 * u.m, 400 * u.deg),      # regression: accepted and wrapped to 40 deg
    (30 * u.m, -360.5 * u.deg),
    (30 * u.m, 7 * u.rad),
])
def test_heights_off_the_earth_and_longitudes_beyond_a_turn_are_refused(height, lon):
    with pytest.raises(vv.DomainError) as info:
        GroundStation(10 * u.deg, lon, height)
    msg = str(info.value)
    assert ("[-12, 100] km" in msg) if "height" in msg else ("[-360, 360] deg" in msg)


@pytest.mark.parametrize(("height", "lon", "wrapped"), [
    (-11 * u.km, 142.2 * u.deg, 142.2),     # Challenger Deep sea floor
    (8.849 * u.km, 86.925 * u.deg, 86.925),  # Everest
    (20 * u.km, 360 * u.deg, 0.0),           # a high-altitude platform, lon 360 = 0
    (53 * u.km, -360 * u.deg, 0.0),          # a balloon's record height
    (100 * u.km, 270 * u.deg, -90.0),        # the Karman line; 0..360 east longitude
    (-12 * u.km, -180 * u.deg, -180.0),
])
def test_sites_on_or_near_the_earth_are_accepted(height, lon, wrapped):
    site = GroundStation(10 * u.deg, lon, height)
    assert site.height.to_value(u.km) == pytest.approx(height.to_value(u.km), rel=1e-15)
    assert site.lon.to_value(u.deg) == pytest.approx(wrapped, abs=1e-12)
    # the position is that of astropy's geodetic conversion at that height
    loc = EarthLocation.from_geodetic(lon, 10 * u.deg, height)
    np.testing.assert_allclose(site.itrs_km, loc.get_itrs().cartesian.xyz.to_value(u.km),
                               atol=1e-9)


def test_cli_passes_refuses_a_site_off_the_earth_in_one_line(tmp_path, capsys):
    from visviva.cli import main

    tle = tmp_path / "iss.tle"
    tle.write_text("ISS\n1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927\n"
                   "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537\n")
    for extra, why in ((["--lon", "-75", "--height", "1e9"], "[-12, 100] km"),
                       (["--lon", "400"], "[-360, 360] deg")):
        code = main(["passes", str(tle), "--lat", "40", *extra, "--start", "2008-09-20",
                     "--hours", "1"])
        err = capsys.readouterr().err
        assert code == 2 and why in err and len(err.strip().splitlines()) == 1
