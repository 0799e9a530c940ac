"""Refraction of elevations: the radio bending integral against an independent quadrature,
ITU-R P.834-9's fits and the textbook high-elevation limit; humid against dry air as the
refractivity says; slopes against central differences; the standard air at the station's
height in look(); the weather dict shared with Observations(troposphere=...); bad input."""

import math

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

import visviva as vv
from visviva.ground import refraction_deg, refraction_slope
from visviva.ground.air import radio_refractivity, saturation_vapour_hpa, standard_atmosphere
from visviva.ground.refraction import bend, lowest_geometric_deg, radio_bending_deg

ITU_DECAY_PER_KM = 0.1361  # P.834-9 eq. 8: n(h) = 1 + 315e-6 exp(-0.1361 h)
ISS_1 = "1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927"
ISS_2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537"


def _p834_eq14(h_km, e_deg):
    """ITU-R P.834-9 eq. 14: the bending (deg) at the geometric elevation, reference air."""
    return 1.0 / (1.728 + 0.5411 * e_deg + 0.03723 * e_deg**2
                  + h_km * (0.1815 + 0.06272 * e_deg + 0.01138 * e_deg**2)
                  + h_km**2 * (0.01727 + 0.008288 * e_deg))


def _p834_eq9(h_km, theta_deg):
    """ITU-R P.834-9 eq. 9: the bending (deg) at the apparent elevation, reference air."""
    return 1.0 / (1.314 + 0.6437 * theta_deg + 0.02869 * theta_deg**2
                  + h_km * (0.2305 + 0.09428 * theta_deg + 0.01096 * theta_deg**2)
                  + 0.008583 * h_km**2)


def _dry_air(n_s):
    """(pressure hPa, temperature deg C) of dry air at 15 deg C with radio refractivity n_s."""
    return n_s * 288.15 / 77.6, 15.0


def _radio(e_deg, n_s):
    p, t = _dry_air(n_s)
    return refraction_deg(e_deg, p, t, relative_humidity=0.0, model="radio")


@pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")
def test_the_bending_integral_against_an_independent_quadrature():
    # adaptive quadrature in the height (r = r0 + x^2 removes the horizon's singularity)
    r0, eps = 6370.0, 315e-6

    def n(r):
        return 1.0 + eps * np.exp(-ITU_DECAY_PER_KM * (r - r0))

    def tau(theta):
        c = n(r0) * r0 * np.cos(np.radians(theta))

        def f(x):
            r = r0 + x * x
            dn = -ITU_DECAY_PER_KM * (n(r) - 1.0)
            return -dn / n(r) * c / np.sqrt((n(r) * r) ** 2 - c * c) * 2.0 * x

        return np.degrees(sum(quad(f, lo, hi, epsabs=1e-15, epsrel=1e-12, limit=200)[0]
                              for lo, hi in [(0, 0.3), (0.3, 1), (1, 3), (3, 11)]))

    theta = np.array([1e-4, 1.0, 3.0, 10.0, 45.0])
    np.testing.assert_allclose(radio_bending_deg(theta, 315.0), [tau(x) for x in theta],
                               rtol=2e-8)


def test_the_bending_integral_against_a_ray_trace():
    # the ray equation d/ds (n dr/ds) = grad n, integrated through the atmosphere: the angle
    # between the ray's first and last directions is the total bending (no Snell invariant used)
    from scipy.integrate import solve_ivp

    r0, eps = 6370.0, 311e-6

    def rhs(_, y):
        r = np.hypot(y[0], y[1])
        n = 1.0 + eps * np.exp(-ITU_DECAY_PER_KM * (r - r0))
        g = -ITU_DECAY_PER_KM * (n - 1.0) / r
        return [y[2] / n, y[3] / n, g * y[0], g * y[1]]

    def top(_, y):
        return np.hypot(y[0], y[1]) - (r0 + 150.0)

    top.terminal = True
    for theta in (0.0, 2.0, 10.0):
        t = np.radians(theta)
        n0 = 1.0 + eps
        sol = solve_ivp(rhs, [0, 5000], [0.0, r0, n0 * np.cos(t), n0 * np.sin(t)], events=top,
                        rtol=1e-12, atol=1e-12, max_step=10.0)
        px, pz = sol.y_events[0][0][2:]
        bending = np.degrees(np.arctan2(pz, px)) - theta
        assert -bending == pytest.approx(radio_bending_deg([theta], 311.0)[0], rel=1e-6)


@pytest.mark.parametrize("h_km", [0.0, 1.0, 2.0, 4.0])
def test_radio_refraction_against_itu_r_p834(h_km):
    # the ITU-R reference atmosphere at the station's height: N_s = 315 exp(-0.1361 h)
    n_s = 315.0 * np.exp(-ITU_DECAY_PER_KM * h_km)
    e = np.array([0.0, 0.5, 1.0, 2.0, 3.0, 5.0])
    r = _radio(e, n_s)
    # P.834's fits of the same bending: eq. 14 in the geometric elevation (0.583 against
    # 0.579 deg at the sea-level horizon) and eq. 9 in the apparent one, within 5 %
    np.testing.assert_allclose(r, _p834_eq14(h_km, e), rtol=0.05)
    np.testing.assert_allclose(r, _p834_eq9(h_km, e + r), rtol=0.05)
    if h_km == 0.0:
        assert r[0] == pytest.approx(_p834_eq14(0.0, 0.0), rel=0.01)
        assert r[0] == pytest.approx(0.583, abs=5e-4)


def test_radio_refraction_follows_laplaces_series_at_high_elevation():
    # away from the horizon the bending depends on the profile through its scale height only:
    # R = a (1 - b) tan z - a (b - a / 2) tan^3 z with a = n_s - 1, b = H / r0, z the apparent
    # zenith distance (Laplace; Smart, Spherical Astronomy, sec. 60); a cot(theta) to 0.4 %
    b = 1.0 / ITU_DECAY_PER_KM / 6370.0
    for n_s in (200.0, 315.0, 400.0):
        a = n_s * 1e-6
        for e in (30.0, 45.0, 70.0):
            r = _radio(e, n_s)
            tz = np.tan(np.radians(90.0 - (e + r)))
            series = np.degrees(a * (1 - b) * tz - a * (b - a / 2) * tz**3)
            assert r == pytest.approx(series, rel=1e-4)
            assert r == pytest.approx(np.degrees(a * tz), rel=5e-3)
    assert abs(_radio(90.0, 315.0)) < 1e-8


def test_the_standard_atmosphere_at_the_horizon():
    # textbook: 0.5-0.6 deg of radio bending at the horizon (0.58 deg ITU-R reference), the
    # optical 0.48 deg (Saemundsson, 29'); radio 0.1 deg more in the standard air
    p, t = standard_atmosphere(0.0)
    radio = refraction_deg(0.0, p, t, relative_humidity=0.5, model="radio")
    optical = refraction_deg(0.0, p, t)
    assert 0.55 < radio < 0.6 and radio == pytest.approx(0.5766, abs=1e-4)
    assert optical == pytest.approx(0.4762, abs=1e-4)


@pytest.mark.parametrize("t_c", [0.0, 15.0, 30.0])
def test_radio_over_optical_in_humid_and_dry_air_as_the_refractivity_says(t_c):
    # the optical formula ignores vapour; the radio bending grows with the wet term
    # 3.73e5 e / T^2: above 20 deg the humid/dry ratio of radio/optical is N_humid / N_dry
    p, t_k = 1013.25, t_c + 273.15
    e = np.array([20.0, 30.0, 45.0, 60.0])
    optical = refraction_deg(e, p, t_c)
    dry = refraction_deg(e, p, t_c, relative_humidity=0.0, model="radio")
    humid = refraction_deg(e, p, t_c, relative_humidity=0.8, model="radio")
    n_dry = radio_refractivity(p, t_k, 0.0)
    n_humid = radio_refractivity(p, t_k, 0.8 * saturation_vapour_hpa(t_c))
    np.testing.assert_allclose((humid / optical) / (dry / optical), n_humid / n_dry, rtol=3e-3)
    assert np.all(humid > dry)
    # optical is blind to humidity
    np.testing.assert_array_equal(refraction_deg(e, p, t_c, relative_humidity=0.9), optical)


@pytest.mark.parametrize("model", ["optical", "radio"])
@pytest.mark.parametrize("air", [(1010.0, 10.0, 0.5), (600.0, -12.0, 0.3),
                                 (1020.0, 32.0, 0.95)])
def test_the_slope_against_central_differences(model, air):
    p, t, rh = air
    e = np.array([-0.9, -0.5, 0.0, 0.3, 1.0, 2.5, 5.0, 12.0, 30.0, 60.0, 89.0])
    kw = {"relative_humidity": rh, "model": model}
    d = 1e-4
    fd = (refraction_deg(e + d, p, t, **kw) - refraction_deg(e - d, p, t, **kw)) / (2 * d)
    np.testing.assert_allclose(refraction_slope(e, p, t, **kw), fd, rtol=2e-5, atol=1e-8)
    below = lowest_geometric_deg(model, p, t, rh) - np.array([0.5, 2.0])
    assert np.all(refraction_slope(below, p, t, **kw) == 0.0)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-1.0, 90.0), min_size=2, max_size=30),
       st.floats(500.0, 1100.0), st.floats(-40.0, 45.0), st.floats(0.0, 1.0),
       st.sampled_from(["optical", "radio"]))
def test_refraction_is_finite_positive_and_decreasing(e, p, t, rh, model):
    e = np.sort(np.asarray(e))
    r = refraction_deg(e, p, t, relative_humidity=rh, model=model)
    slope = refraction_slope(e, p, t, relative_humidity=rh, model=model)
    assert np.all(np.isfinite(r)) and np.all(r >= 0.0) and np.all(r < 1.5)
    assert np.all(np.diff(r) <= 1e-12)
    assert np.all(np.isfinite(slope)) and np.all(slope <= 1e-12) and np.all(slope > -1.0)


@pytest.mark.parametrize("air", [(1100.0, 45.0, 1.0), (1100.0, -90.0, 0.0), (100.0, -56.5, 0.5)])
def test_radio_refraction_in_extreme_air(air):
    # hot saturated air (N = 622): the rays aimed below the horizon pass under the station into
    # the profile's ducting layer; the table raised ValueError (x not increasing) from NaNs
    p, t, rh = air
    e = np.linspace(-1.0, 90.0, 2001)
    r = refraction_deg(e, p, t, relative_humidity=rh, model="radio")
    slope = refraction_slope(e, p, t, relative_humidity=rh, model="radio")
    assert np.all(np.isfinite(r)) and np.all(r >= 0.0) and np.all(np.diff(r) <= 1e-12)
    assert np.all(np.isfinite(slope)) and np.all(slope <= 1e-12)


# look(): the station's air ------------------------------------------------------------------
@pytest.fixture(scope="module")
def iss():
    return vv.Satellite.from_tle(ISS_1, ISS_2, name="ISS")


@pytest.fixture(scope="module")
def times():
    return Time("2008-09-20T22:49:00", scale="utc") + np.arange(0, 600, 20) * u.s


def _lift(station, iss, times, refraction, star=True):
    """Geometric elevation and look()'s refraction; ``star``: scaled back to a target at
    infinity (look() gives the offset of the satellite at its range, tests/
    test_ground_finite_range.py), for the air's own checks."""
    geo = station.look(iss, times)
    app = station.look(iss, times, refraction=refraction)
    el = geo.elevation.to_value(u.deg)
    lift = (app.elevation - geo.elevation).to_value(u.deg)
    if star:
        from visviva.ground.refraction import station_air

        air = station_air(refraction, station.height.to_value(u.m))
        rng = geo.range.to_value(u.km)
        with np.errstate(invalid="ignore", divide="ignore"):
            k = bend(el, *air, range_km=rng)[0] / bend(el, *air)[0]
        on = el > lowest_geometric_deg(*air)  # the model's end (radio: -1 deg apparent)
        lift = np.where(on, lift / np.where(on, k, 1.0), lift)
    return el, lift


def test_look_takes_the_standard_air_at_the_station_height(iss, times):
    # a station at 4205 m (Mauna Kea's height) has 600 hPa, -12.3 deg C: the old 1010 hPa,
    # 10 deg C made its refraction 1.55 times too large (0.483 against 0.312 deg at 0 deg)
    high = vv.GroundStation(40.0 * u.deg, -75.0 * u.deg, 4205 * u.m)
    el, lift = _lift(high, iss, times, True)
    up = el > -1.0
    p, t = standard_atmosphere(4205.0)
    assert p == pytest.approx(600.07, abs=0.01) and t == pytest.approx(-12.3325)
    np.testing.assert_allclose(lift, refraction_deg(el, p, t), rtol=1e-12)
    np.testing.assert_allclose(lift[up] / refraction_deg(el[up]), 0.6450, rtol=1e-3)
    # at sea level the new default (1013.25 hPa, 15 deg C) is the old one (1010 hPa, 10 deg C)
    # times Meeus' (1013.25 / 1010) (283 / (273 + 15)) = 0.9858
    sea = vv.GroundStation(40.0 * u.deg, -75.0 * u.deg, 0 * u.m)
    el, lift = _lift(sea, iss, times, True)
    up = el > -1.0
    np.testing.assert_allclose(lift[up] / refraction_deg(el[up]),
                               (1013.25 / 1010.0) * (283.0 / 288.0), rtol=1e-12)
    # "optical" is True's meaning
    np.testing.assert_array_equal(_lift(sea, iss, times, "optical")[1], lift)


def test_look_radio_and_the_weather_dict(iss, times):
    site = vv.GroundStation(40.0 * u.deg, -75.0 * u.deg, 1600 * u.m)
    p, t = standard_atmosphere(1600.0)
    el, radio = _lift(site, iss, times, "radio")
    np.testing.assert_allclose(radio, refraction_deg(el, p, t, model="radio"), rtol=1e-12)
    # the dict of Observations(troposphere=...): keys left out come from the standard air
    air = {"pressure_hpa": 900.0, "relative_humidity": 0.8, "refraction": "radio"}
    _, lift = _lift(site, iss, times, air)
    np.testing.assert_allclose(lift, refraction_deg(el, 900.0, t, relative_humidity=0.8,
                                                    model="radio"), rtol=1e-12)
    _, lift = _lift(site, iss, times, {"temperature_c": 25.0})
    np.testing.assert_allclose(lift, refraction_deg(el, p, 25.0), rtol=1e-12)
    assert vv.Observations(times[:1], "azel", [[1.0, 0.5]], 1e-4, site,
                           troposphere=air).troposphere.refraction == "radio"
    # the elevation rate carries the radio slope
    app = site.look(iss, times, refraction="radio")
    half = 0.05 * u.s
    fd = (site.look(iss, times + half, refraction="radio").elevation
          - site.look(iss, times - half, refraction="radio").elevation).to_value(u.deg) / 0.1
    up = el > -0.5
    np.testing.assert_allclose(app.elevation_rate.to_value(u.deg / u.s)[up], fd[up],
                               atol=1e-5)


def test_od_azel_rows_take_the_radio_bending():
    from visviva.od import simulate_observations

    epoch = Time("2024-03-01T00:00:00", scale="utc")
    truth = vv.StateVectors([6878.0, 0.0, 0.0] * u.km, [0.0, 4.7, 5.9] * u.km / u.s, vv.EARTH,
                            epoch=epoch)
    station = vv.GroundStation(40 * u.deg, -10 * u.deg, 1.6 * u.km)
    t = epoch + np.arange(0, 86400, 60.0) * u.s
    geo = simulate_observations(truth, t, "azel", 1e-9, station, seed=False, light_time=False)
    keep = np.flatnonzero(geo.values[:, 1] > np.radians(2.0))[:30]
    t = t[keep]

    def lift(tropo):
        obs = simulate_observations(truth, t, "azel", 1e-9, station, seed=False,
                                    light_time=False, troposphere=tropo)
        return np.degrees(obs.values[:, 1]) - np.degrees(geo.values[keep, 1])

    el = np.degrees(geo.values[keep, 1])
    # the satellite's offset at its range (tests/test_ground_finite_range.py)
    rng = simulate_observations(truth, t, "range", 1e-9, station, seed=False,
                                light_time=False).values[:, 0]
    p, t_c = standard_atmosphere(1600.0)
    np.testing.assert_allclose(lift({"refraction": "radio"}),
                               refraction_deg(el, p, t_c, model="radio", range_km=rng),
                               atol=1e-11)
    np.testing.assert_allclose(lift(True), refraction_deg(el, p, t_c, range_km=rng), atol=1e-11)
    assert np.all(lift(True) < refraction_deg(el, p, t_c))


def test_nan_geometry_stays_nan_inside_look():
    # look() and the OD model pass their geometry through bend(): a NaN elevation (an SGP4
    # failure) must not come back as a finite refraction (the optical formula gave 0.48 deg)
    from visviva.ground.refraction import bend

    for model in ("optical", "radio"):
        r, slope = bend(np.array([np.nan, 10.0]), model, 1010.0, 10.0, 0.5)
        assert np.isnan(r[0]) and np.isnan(slope[0]) and np.isfinite(r[1])


def test_bad_input_is_refused_clearly():
    with pytest.raises(vv.InvalidInputError, match="NaN"):
        refraction_deg(np.array([1.0, np.nan]))  # was 0 refraction, silently
    with pytest.raises(vv.InvalidInputError, match="NaN"):
        refraction_slope(np.inf)
    with pytest.raises(vv.InvalidInputError, match="zenith distance"):
        refraction_deg(95.0)
    with pytest.raises(vv.InvalidInputError, match="pressure_hpa"):
        refraction_deg(5.0, -10.0, model="radio")
    with pytest.raises(vv.InvalidInputError, match="percentage: pass 0.7"):
        refraction_deg(5.0, relative_humidity=70, model="radio")
    with pytest.raises(vv.InvalidInputError, match="fraction"):
        refraction_deg(5.0, relative_humidity=-0.1)
    with pytest.raises(vv.InvalidInputError, match="fraction"):
        refraction_deg(5.0, relative_humidity=True, model="radio")
    with pytest.raises(vv.InvalidInputError, match="'optical'"):
        refraction_deg(5.0, model="microwave")
    with pytest.raises(vv.InvalidInputError, match="exceeds the air pressure"):
        refraction_deg(5.0, 20.0, 40.0, relative_humidity=1.0, model="radio")
    with pytest.raises(vv.InvalidInputError, match="pressure_hpa"):
        refraction_deg(5.0, 5000.0, 0.0, model="radio")  # Pa read as hPa
    site = vv.GroundStation(40.0 * u.deg, -75.0 * u.deg)
    sat = vv.Satellite.from_tle(ISS_1, ISS_2)
    t = Time("2008-09-20T22:55:00", scale="utc")
    for bad, match in [({"relative_humidity": 65}, "percentage: pass 0.65"),
                       ({"pressure_hpa": 1013.25, "humidity": 0.5}, "unknown keys"),
                       ({"refraction": "sonar"}, "'radio'"), ("sonar", "'radio'"),
                       (1, "weather dict"), ({"pressure_hpa": -5.0}, "pressure_hpa")]:
        with pytest.raises(vv.InvalidInputError, match=match):
            site.look(sat, t, refraction=bad)
    with pytest.raises(vv.InvalidInputError, match="percentage"):
        vv.od.troposphere.weather_from({"relative_humidity": 50})


def test_weather_in_the_wrong_units_is_refused_not_scaled():
    # audit22: the optical formula scales with P / T, so a pressure in Pa gave 8.9 deg of
    # refraction at 10 deg (100 times too much) and a temperature in K 10 times too little,
    # silently; a Quantity or an array of pressures crashed with a TypeError
    for model in ("optical", "radio"):
        with pytest.raises(vv.InvalidInputError, match="looks like Pa: pass 1013.25 hPa"):
            refraction_deg(10.0, 101325.0, 15.0, model=model)
        with pytest.raises(vv.InvalidInputError, match="looks like kelvin: pass 15 deg C"):
            refraction_deg(10.0, 1013.25, 288.15, model=model)
        with pytest.raises(vv.InvalidInputError, match="looks like Pa"):
            refraction_slope(10.0, 101325.0, 15.0, model=model)
    with pytest.raises(vv.InvalidInputError, match="plain number in hPa"):
        refraction_deg(10.0, 1013.0 * u.hPa)
    with pytest.raises(vv.InvalidInputError, match="plain number in deg C"):
        refraction_deg(10.0, 1013.0, 15.0 * u.deg_C)
    with pytest.raises(vv.InvalidInputError, match="one number"):
        refraction_deg([10.0, 20.0], np.array([1013.0, 900.0]))
    with pytest.raises(vv.InvalidInputError, match="temperature_c"):
        refraction_deg(10.0, 1013.0, np.nan)
    # the range's ends still work: no air, and the coldest and warmest air of a weather dict
    assert refraction_deg(10.0, 0.0, 15.0) == 0.0
    assert 0.0 < refraction_deg(10.0, 1100.0, -90.0) < refraction_deg(0.0, 1100.0, 60.0)


def test_refraction_slope_converts_an_angle_quantity():
    # audit22: refraction_slope read 0.1 rad as 0.1 deg (-0.140 instead of -0.0184), silently
    np.testing.assert_allclose(refraction_slope(0.1 * u.rad),
                               refraction_slope(math.degrees(0.1)), rtol=1e-13)
    np.testing.assert_allclose(refraction_slope(5.0 * u.deg), refraction_slope(5.0), rtol=1e-13)
    e = np.array([2.0, 5.0, 30.0])
    np.testing.assert_allclose(
        refraction_slope(np.radians(e) * u.rad, model="radio", range_km=800.0 * u.km),
        refraction_slope(e, model="radio", range_km=800.0), rtol=1e-6)


def test_radio_refraction_of_tropical_air_is_not_cut_off_above_the_horizon():
    # audit22: the radio model was zero below -1 deg geometric; in hot, humid air (31 deg C,
    # 80 %: N_s = 402) the bending there is 1.01 deg, so a satellite at -1.01 deg geometric,
    # seen 0.0 deg above the horizon, came back at -1.01 deg (a 1-deg jump in look()), and a
    # pass search at the default min_elevation 0 was refused as "below the models' range"
    p, t, rh = 1009.0, 31.0, 0.8
    low = lowest_geometric_deg("radio", p, t, rh)
    assert -3.1 < low < -2.9
    e = np.linspace(low + 1e-6, 3.0, 4001)
    app = e + refraction_deg(e, p, t, relative_humidity=rh, model="radio")
    assert np.all(np.diff(app) > 0.0)  # monotonic, no jump
    assert app[0] == pytest.approx(-1.0, abs=1e-5)  # the table's end: -1 deg apparent
    r = refraction_deg(np.array([-1.01, -1.5, -2.5]), p, t, relative_humidity=rh, model="radio")
    np.testing.assert_allclose(r, radio_bending_deg(
        np.array([-1.01, -1.5, -2.5]) + r, radio_refractivity(p, t + 273.15, rh * float(
            saturation_vapour_hpa(t)))), rtol=1e-6)
    assert r[0] > 1.0
    # the optical formula's end is still -1 deg geometric
    assert lowest_geometric_deg("optical", p, t, rh) == -1.0
    assert float(refraction_deg(-1.01, p, t)) == 0.0


def test_radio_refraction_at_a_station_above_the_atmosphere_says_so():
    # the standard air at 80 km: 0.0105 hPa, below the 0.0139 hPa of 50 % humidity at
    # -56.5 deg C; this read "not air; check pressure_hpa" for a pressure nobody gave
    from visviva.ground.air import _TOP_KM, Weather
    from visviva.ground.refraction import station_air

    p80, t80 = standard_atmosphere(80e3)
    assert p80 < 0.5 * saturation_vapour_hpa(t80)
    assert 72.0 < _TOP_KM < 73.0  # where the two meet
    for call in (lambda: station_air("radio", 80e3),
                 lambda: Weather(None, "radio").at(80e3)):
        with pytest.raises(vv.InvalidInputError, match=r"80\.0 km up, above the atmosphere.*"
                           r"refraction=False.*troposphere=False"):
            call()
    model, p, t, rh = station_air("radio", 72e3)  # below the end: refraction ~0, no error
    assert abs(refraction_deg(10.0, p, t, relative_humidity=rh, model="radio")) < 1e-4  # deg
    assert station_air("optical", 80e3)[0] == "optical"  # optical needs no vapour: ~0
    given = station_air({"refraction": "radio", "pressure_hpa": 500.0}, 80e3)
    assert given[1] == 500.0  # air the user gives is used as given
    with pytest.raises(vv.InvalidInputError, match="above the atmosphere.*relative_humidity=0"):
        refraction_deg(10.0, 0.01, -56.5, relative_humidity=0.5, model="radio")


def test_a_station_below_the_standard_atmosphere_needs_its_air_given():
    """A sea-floor station (-11 km) with refraction=True was refused with "pressure_hpa must
    be a finite number in [0, 1500] hPa; got 3248.85", a pressure nobody gave (the standard
    air extrapolated under the sea), and Observations(troposphere=True) took that air
    silently: a zenith delay of 9.9 m against 2.4 m at sea level. Below ISO 2533's -2 km the
    air must be given (audit50); the Dead Sea's shore keeps its standard air."""
    iss = vv.Satellite.from_tle(ISS_1, ISS_2)
    t = Time("2008-09-20T22:52:00", scale="utc") + np.arange(3) * u.s
    deep = vv.GroundStation(-10 * u.deg, 150 * u.deg, -11 * u.km)
    for refraction in (True, "radio", {"relative_humidity": 0.2}):
        with pytest.raises(vv.InvalidInputError, match="below the standard atmosphere's lowest"):
            deep.look(iss, t, refraction=refraction)
    with pytest.raises(vv.InvalidInputError, match="under water or rock"):
        vv.find_passes(iss, deep, t[0], t[0] + 1 * u.hour, refraction=True)
    air = {"pressure_hpa": 1000.0, "temperature_c": 10.0}
    geometric = deep.look(iss, t).elevation
    assert np.all(deep.look(iss, t, refraction=air).elevation >= geometric)
    dead_sea = vv.GroundStation(31.5 * u.deg, 35.5 * u.deg, -430 * u.m)
    p, _ = standard_atmosphere(-430.0)
    np.testing.assert_allclose(p, 1065.9, atol=0.5)  # ICAO at -430 m
    assert np.isfinite(dead_sea.look(iss, t, refraction=True).elevation).all()
    from visviva.od import simulate_observations

    states = iss.gcrs(t)
    truth = vv.StateVectors(states.r[0], states.v[0], vv.EARTH, epoch=t[0])
    with pytest.raises(vv.InvalidInputError, match="troposphere=False in Observations"):
        simulate_observations(truth, t, "range", 1e-3, deep, troposphere=True)
