"""Look angles against astropy's AltAz and Skyfield; rates against finite differences; Doppler
and refraction against their formulas."""

import warnings

import numpy as np
import pytest
from astropy import units as u
from astropy.coordinates import ITRS, AltAz, CartesianRepresentation
from astropy.time import Time

import visviva as vv
from visviva.ground import doppler_shift, refraction_deg
from visviva.ground.look import look

ISS_1 = "1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927"
ISS_2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537"
ONE_METER = 1e-3  # km


@pytest.fixture(scope="module")
def iss():
    return vv.Satellite.from_tle(ISS_1, ISS_2, name="ISS")


@pytest.fixture(scope="module")
def site():
    return vv.GroundStation(40.0 * u.deg, -75.0 * u.deg, 50 * u.m, name="PHL")


@pytest.fixture(scope="module")
def times():
    # a pass of the ISS over Philadelphia (rise 22:51:52 UTC), and some time below the horizon
    return Time("2008-09-20T22:49:00", scale="utc") + np.arange(0, 600, 20) * u.s


def test_angles_equal_astropy_altaz(iss, site, times):
    la = site.look(iss, times)
    it = iss.itrs(times).r
    rel = it - site.location.get_itrs().cartesian.xyz.T
    topo = ITRS(CartesianRepresentation(rel.T), obstime=times, location=site.location)
    aa = topo.transform_to(AltAz(obstime=times, location=site.location))  # no refraction
    np.testing.assert_allclose(la.elevation.to_value(u.deg), aa.alt.deg, atol=1e-8)
    daz = (la.azimuth.to_value(u.deg) - aa.az.deg + 180) % 360 - 180
    np.testing.assert_allclose(daz, 0, atol=1e-8)
    np.testing.assert_allclose(la.range.to_value(u.km), aa.distance.km, atol=ONE_METER * 1e-3)
    assert la.azimuth.min() >= 0 * u.deg and la.azimuth.max() < 360 * u.deg


def test_angles_and_radec_agree_with_skyfield(iss, site, times):
    from skyfield.api import EarthSatellite, wgs84

    from visviva.validation._skyfield import sky_time, timescale

    ts = timescale()  # astropy's polar motion installed: with none, 1e-3 deg, 20 m, 0.1 m/s
    es = EarthSatellite(ISS_1, ISS_2, "ISS", ts)
    topos = wgs84.latlon(40.0, -75.0, 50)
    pos = (es - topos).at(sky_time(ts, times))
    alt, az, dist = pos.altaz()
    ra, dec, _ = pos.radec()  # ICRF axes, geometric
    la = site.look(iss, times)
    np.testing.assert_allclose(la.elevation.to_value(u.deg), alt.degrees, atol=1e-6)
    np.testing.assert_allclose(la.range.to_value(u.km), dist.km, atol=0.02 * ONE_METER)
    dra = (la.ra.to_value(u.deg) - ra._degrees + 180) % 360 - 180
    np.testing.assert_allclose(dra * np.cos(np.radians(dec.degrees)), 0, atol=2e-3)
    np.testing.assert_allclose(la.dec.to_value(u.deg), dec.degrees, atol=2e-3)
    rr = pos.frame_latlon_and_rates(topos)[5]  # range rate
    # 1 mm/s: Skyfield turns its stations about the ITRS z axis, not the pole (0.2-0.6 mm/s)
    np.testing.assert_allclose(la.range_rate.to_value(u.km / u.s), rr.km_per_s, atol=1e-6)


def test_rates_are_derivatives(iss, site, times):
    # SGP4's velocity is not exactly the derivative of its position (it leaves out the rates of
    # some short-period terms): ~1 cm/s in LEO, the tolerance below
    la = site.look(iss, times)
    half = 0.05 * u.s
    lp = site.look(iss, times + half)
    lm = site.look(iss, times - half)
    span = 2 * half.to_value(u.s)
    np.testing.assert_allclose((lp.range - lm.range).to_value(u.km) / span,
                               la.range_rate.to_value(u.km / u.s), atol=2e-5)
    np.testing.assert_allclose((lp.elevation - lm.elevation).to_value(u.deg) / span,
                               la.elevation_rate.to_value(u.deg / u.s), atol=1e-5)
    daz = ((lp.azimuth - lm.azimuth).to_value(u.deg) + 180) % 360 - 180
    np.testing.assert_allclose(daz / span, la.azimuth_rate.to_value(u.deg / u.s), atol=1e-5)


def test_targets_and_shapes(iss, site, times):
    la = site.look(iss, times)
    gc = site.look(iss.gcrs(times))  # GCRS states: t defaults to their epoch
    np.testing.assert_allclose(gc.elevation.value, la.elevation.value, atol=1e-10)
    np.testing.assert_allclose(gc.ra.value, la.ra.value, atol=1e-10)
    cat = vv.Catalog([iss, iss])
    lc = site.look(cat, times.reshape(3, 10))
    assert lc.shape == (2, 3, 10)
    np.testing.assert_allclose(lc.elevation[1].ravel().value, la.elevation.value, atol=1e-10)
    one = site.look(iss, times[3])
    assert one.shape == () and "LookAngles" in repr(one)
    assert one.elevation.value == pytest.approx(la.elevation[3].value, abs=1e-10)


def test_light_time_moves_the_satellite_back_by_range_over_c(iss, site, times):
    geo = site.look(iss, times)
    lt = site.look(iss, times, light_time=True)
    tau = geo.range.to_value(u.km) / 299792.458
    # to first order the range changes by -(d range/dt) * tau plus the site's motion term
    # (Earth rotation during tau): check against the states at t - tau directly
    back = site.look(iss.gcrs(times - tau * u.s).to_state_vectors(), times)
    np.testing.assert_allclose(lt.range.to_value(u.km), back.range.to_value(u.km),
                               atol=ONE_METER)
    assert np.abs(lt.range - geo.range).max() > 5 * ONE_METER * u.km


def test_states_at_another_time_than_t_are_refused(iss, site, times):
    # a t one minute after the states' epoch used to rotate the states to the Earth-fixed frame
    # of the wrong time: another azimuth and elevation, silently
    states = iss.gcrs(times).to_state_vectors()
    with pytest.raises(vv.InvalidInputError, match="light time"):
        site.look(states, times + 60 * u.s)
    # omitting t uses the epoch; t equal to it gives the same answer
    a, b = site.look(states), site.look(states, times)
    np.testing.assert_array_equal(a.elevation, b.elevation)


def test_doppler_known_value_and_sign(iss, site, times):
    f = 437.8 * u.MHz
    shift = doppler_shift(f, -7.0 * u.km / u.s)
    assert shift.to_value(u.Hz) == pytest.approx(437.8e6 * 7.0 / 299792.458, rel=1e-12)
    la = site.look(iss, times, frequency=f)
    np.testing.assert_allclose(la.doppler.to_value(u.Hz),
                               -437.8e6 * la.range_rate.to_value(u.km / u.s) / 299792.458)
    assert la.doppler[0] > 0 * u.Hz > la.doppler[-1]  # approaching high, receding low
    with pytest.raises(vv.UnitsError):
        doppler_shift(437.8e6, 1 * u.km / u.s)
    with pytest.raises(vv.DomainError):
        doppler_shift(-1 * u.MHz, 1 * u.km / u.s)
    with pytest.raises(vv.ShapeError, match="do not broadcast"):  # was numpy's ValueError
        doppler_shift([1.0, 2.0, 3.0] * u.MHz, [1.0, 2.0] * u.km / u.s)


def test_refraction_saemundsson_against_bennett():
    h = np.array([0.0, 1.0, 5.0, 15.0, 45.0, 89.0])
    r = refraction_deg(h)
    # Bennett's formula (apparent altitude in, refraction out), Meeus eq. 16.3
    ha = h + r
    bennett = 1.0 / np.tan(np.radians(ha + 7.31 / (ha + 4.4))) / 60.0
    np.testing.assert_allclose(r, bennett, atol=0.1 / 60)
    assert r[0] == pytest.approx(0.483, abs=0.005)  # ~29' at the horizon
    assert refraction_deg(-5.0) == 0.0


def test_refracted_elevation(iss, site, times):
    # refraction=True: the standard air at the station's height (50 m: 1007.3 hPa, 14.7 deg C;
    # it was 1010 hPa and 10 deg C at any height, tests/test_ground_refraction.py)
    from visviva.ground.air import standard_atmosphere

    geo = site.look(iss, times)
    app = site.look(iss, times, refraction=True)
    d = (app.elevation - geo.elevation).to_value(u.deg)
    el = geo.elevation.to_value(u.deg)
    # the offset of a satellite at its range (0.93-0.95 of a star's at the horizon)
    rng = geo.range.to_value(u.km)
    np.testing.assert_allclose(d, refraction_deg(el, *standard_atmosphere(50.0), range_km=rng),
                               rtol=1e-12)
    star = refraction_deg(el, *standard_atmosphere(50.0))
    on = el > -1.0  # both 0 below
    assert np.all(d[on] < star[on]) and np.all(d[on] > 0.9 * star[on])


def test_refracted_elevation_rate_is_the_derivative_of_the_refracted_elevation(iss, site,
                                                                               times):
    # the rate stayed geometric: 15 % off at the horizon, where refraction falls fastest
    app = site.look(iss, times, refraction=True)
    half = 0.05 * u.s
    lp = site.look(iss, times + half, refraction=True)
    lm = site.look(iss, times - half, refraction=True)
    fd = (lp.elevation - lm.elevation).to_value(u.deg) / (2 * half.to_value(u.s))
    up = app.elevation > -1 * u.deg
    assert up.sum() > 5
    np.testing.assert_allclose(app.elevation_rate.to_value(u.deg / u.s)[up], fd[up], atol=1e-5)


def test_refraction_takes_angle_quantities_and_checks_the_air():
    # a Quantity's unit was dropped: 0.1 rad read as 0.1 deg (0.47 deg of refraction, not 0.15)
    np.testing.assert_allclose(refraction_deg(0.1 * u.rad).to_value(u.deg),
                               refraction_deg(np.degrees(0.1)), rtol=1e-14)
    assert refraction_deg(10 * u.deg).unit == u.deg
    with pytest.raises(vv.UnitsError):
        refraction_deg(10 * u.km)
    assert abs(refraction_deg(90.0)) < 1e-8  # Meeus' zenith term (was -3.2e-5 deg)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert refraction_deg(-5.11) == 0.0  # at the formula's pole: no RuntimeWarning
    with pytest.raises(vv.InvalidInputError, match="temperature_c"):
        refraction_deg(10.0, temperature_c=-273.0)  # was ZeroDivisionError
    with pytest.raises(vv.InvalidInputError, match="pressure_hpa"):
        refraction_deg(10.0, pressure_hpa=np.nan)


def test_bad_targets(iss, site, times):
    with pytest.raises(vv.InvalidInputError, match="astropy Time"):
        site.look(iss, 0.0)
    with pytest.raises(vv.InvalidInputError, match="Satellite, a Catalog or StateVectors"):
        site.look("ISS", times)
    with pytest.raises(vv.InvalidInputError, match="empty"):
        site.look(vv.Catalog([]), times)
    with pytest.raises(vv.InvalidInputError, match="epoch"):
        site.look(vv.StateVectors([7000, 0, 0] * u.km, [0, 7.5, 0] * u.km / u.s, vv.EARTH))


def test_states_about_another_body_are_refused(iss, site, times):
    # StateVectors about the Moon or the Sun were taken as geocentric GCRS: an elevation, a
    # range and RA/Dec came back for a position that is not relative to the Earth at all
    g = iss.gcrs(times)
    for body in (vv.MOON, vv.SUN):
        with pytest.raises(vv.InvalidInputError, match=f"{body.name}'s"):
            site.look(vv.StateVectors(g.r, g.v, body, epoch=times))
    # the Earth's GM, as a body or a Quantity, is what look() expects
    ref = site.look(iss, times)
    for gm in (vv.EARTH, vv.EARTH.gm, vv.EARTH.gm.to(u.m**3 / u.s**2)):
        la = site.look(vv.StateVectors(g.r, g.v, gm, epoch=times))
        np.testing.assert_allclose(la.elevation.to_value(u.deg), ref.elevation.to_value(u.deg),
                                   atol=1e-9)


def test_razel_against_vallados_rv2razel():
    # Vallado's RAZEL (Algorithm 27) as run by his own rv2razel for an Earth-fixed state seen
    # from the site of his Example 7-1 (39.007 deg N, 104.883 deg W, 2.102 km); the values are
    # the reference outputs in the tests of the valladopy port of his software
    # (tests/astro/twobody/test_frame_conversions.py, TestAzEl). His site uses R = 6378.1363 km
    # (WGS-84 here: 0.7 m apart), hence the tolerances.
    from visviva.core.topocentric import razel_many

    site = vv.GroundStation(39.007 * u.deg, -104.883 * u.deg, 2.102 * u.km)
    r = np.array([[-5225.545532658024, -3070.9865969614993, 3501.8159870845006]])
    v = np.array([[-5.373672578283977, -3.3021038634286506, 4.020523711114683]])
    out = np.empty((1, 6))
    razel_many(r - site.itrs_km, v, site.enu_matrix[None], np.zeros(1, dtype=np.int64), out)
    rng, az, el, rdot, azdot, eldot = out[0]
    assert rng == pytest.approx(4339.444884044615, abs=2e-3)
    assert az == pytest.approx(2 * np.pi - 1.5639427896150881, abs=1e-6)
    assert el == pytest.approx(-0.18973540227923288, abs=1e-6)
    assert rdot == pytest.approx(3.1216042513457634, abs=3e-6)
    assert azdot == pytest.approx(5.093097833129788e-05, rel=1e-4)
    assert eldot == pytest.approx(0.0015655515448868324, rel=1e-5)


_ISS_2024 = ("1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
             "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340")


_CALLS = {  # the user's calls, written in this file
    "look Satellite": lambda site, sat, t: site.look(sat, t),
    "look function": lambda site, sat, t: look(site, sat, t),
    "look Catalog": lambda site, sat, t: site.look(vv.Catalog([sat]), t),
    "find_events": lambda site, sat, t: site.find_events(sat, t[0], t[0] + 2 * u.h),
    "find_passes": lambda site, sat, t: vv.find_passes(sat, site, t[0], t[0] + 2 * u.h),
    "find_passes Catalog": lambda site, sat, t: vv.find_passes(vv.Catalog([sat]), [site], t[0],
                                                               t[0] + 2 * u.h),
}


@pytest.mark.parametrize("call", sorted(_CALLS))
def test_stale_element_set_warning_points_at_the_users_line(site, call):
    """The StaleElementSetWarning of look() pointed into visviva (look.py: teme was called one
    frame deeper than its fixed stacklevel assumed); find_passes' and Satellite.teme's were
    right by luck of their depth. Every path now names the first frame outside visviva."""
    sat = vv.Satellite.from_tle(*_ISS_2024, name="ISS")
    t = Time("2024-06-01T00:00:00", scale="utc") + np.arange(3) * u.min  # 152 days out
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        _CALLS[call](site, sat, t)
    stale = [x for x in w if issubclass(x.category, vv.StaleElementSetWarning)]
    assert len(stale) == 1 and "152" in str(stale[0].message)
    assert stale[0].filename == __file__


def test_light_time_range_rate_is_the_rate_of_the_light_time_range(iss, site, times):
    """With light_time=True the range rate is d(c tau)/dt, tau the flight time from the
    satellite at t - tau to the site at t (what the one-way Doppler measures), computed here
    in the GCRS from astropy's site and SGP4 states at t - tau. It used to project the
    satellite's Earth-fixed velocity at t on the retarded line of sight: 14-22 mm/s off for the
    ISS (its velocity at t - tau and omega x the shift left out), 22-143 mm/s from d(c tau)/dt.
    """
    from astropy.coordinates import EarthLocation

    from visviva.satellites.frames import offline_iers

    c = 299792.458
    t = times[(times >= Time("2008-09-20T22:52:00")) & (times <= Time("2008-09-20T22:59:00"))]
    loc = EarthLocation.from_geodetic(-75.0 * u.deg, 40.0 * u.deg, 50 * u.m)
    with offline_iers():
        p, v = loc.get_gcrs_posvel(t)
    p, v = p.xyz.to_value(u.km).T, v.xyz.to_value(u.km / u.s).T
    tau = np.zeros(len(t))
    for _ in range(4):
        g = iss.gcrs(t - tau * u.s)
        rho = g.r.to_value(u.km) - p
        tau = np.linalg.norm(rho, axis=-1) / c
    unit = rho / np.linalg.norm(rho, axis=-1)[:, None]
    sat_v = g.v.to_value(u.km / u.s)
    # c tau = |r(t - tau) - p(t)|: c tau' = u . (V (1 - tau') - v_site)
    rate = np.sum(unit * (sat_v - v), -1) / (1 + np.sum(unit * sat_v, -1) / c)
    lt = site.look(iss, t, light_time=True)
    assert len(t) >= 15
    np.testing.assert_allclose(lt.range.to_value(u.km), c * tau, atol=2 * ONE_METER * 1e-3)
    np.testing.assert_allclose(lt.range_rate.to_value(u.km / u.s), rate, atol=1e-6)  # 1 mm/s
    # and the same check of the instantaneous range rate, in the GCRS
    g0 = iss.gcrs(t)
    rho0 = g0.r.to_value(u.km) - p
    rate0 = np.sum(rho0 * (g0.v.to_value(u.km / u.s) - v), -1) / np.linalg.norm(rho0, axis=-1)
    np.testing.assert_allclose(site.look(iss, t).range_rate.to_value(u.km / u.s), rate0,
                               atol=1e-7)


def test_catalogue_frequencies_are_one_per_satellite(iss, site, times):
    """A catalogue's frequency per satellite, with as many times as satellites, was laid
    along the times by numpy: each satellite's Doppler used the other's frequency, silently
    (the 437.8 MHz satellite's shift off by kHz); with other counts it was refused (audit50)."""
    cat = vv.Catalog([iss, iss])
    f = [145.8, 437.8] * u.MHz
    for t in (times[10:12], times[10:13]):  # as many times as satellites, and not
        both = site.look(cat, t, frequency=f).doppler
        for k in range(2):
            one = site.look(iss, t, frequency=f[k]).doppler
            np.testing.assert_allclose(both[k].to_value(u.Hz), one.to_value(u.Hz), rtol=1e-12)
    assert abs(site.look(cat, times[10], frequency=f).doppler[1]) > 1 * u.kHz
    per_time = site.look(cat, times[10:13], frequency=[1.0, 2.0, 3.0] * u.GHz).doppler
    rr = site.look(iss, times[10:13]).range_rate
    np.testing.assert_allclose(per_time[0].to_value(u.Hz),
                               doppler_shift([1.0, 2.0, 3.0] * u.GHz, rr).to_value(u.Hz))
