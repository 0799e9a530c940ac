"""Light time in the measurement models, against a direct computation that shares none of it.

The reference iterates each flight time with the numerical integrator itself (the satellite
re-propagated to the exact bounce time, not a Taylor step), takes the station's position at the
transmit time from astropy's GCRS transformation, differentiates the two-way range numerically
for the range rate, and, for RA/Dec referred to the stars, does the light-time iteration in the
barycentric frame with astropy's built-in ephemeris of the Earth.
"""

import numpy as np
import pytest
from astropy import units as u
from astropy.coordinates import get_body_barycentric_posvel
from astropy.time import Time
from scipy import stats

import visviva as vv
from visviva.constants import C_KM_S
from visviva.od import simulate_observations
from visviva.od.dynamics import Dynamics
from visviva.od.light_time import predict_light_time
from visviva.od.measurements import predict

EPOCH = Time("2024-03-01T00:00:00", scale="utc")
KMS = u.km / u.s
GM = vv.EARTH.gm_km3_s2
#: a 1000 x 20000 km orbit: ranges of 2000-20000 km, flight times up to 70 ms
Y0 = np.array([7378.0, 0.0, 0.0, 0.0, 7.2, 5.6])
TRUTH = vv.StateVectors(Y0[:3] * u.km, Y0[3:] * KMS, vv.EARTH, epoch=EPOCH)
STATION = vv.GroundStation(20 * u.deg, 10 * u.deg, 0.5 * u.km)
ONE_MM = 1e-6  # km
MAS = np.radians(1 / 3.6e6)  # rad


@pytest.fixture(scope="module")
def visible():
    """Times over 8 h when the station sees the satellite above 5 deg."""
    t = EPOCH + np.arange(0, 8 * 3600, 120.0) * u.s
    look = simulate_observations(TRUTH, t, "azel", 1e-9, STATION, seed=False, light_time=False)
    idx = np.flatnonzero(look.values[:, 1] > np.radians(5))
    assert idx.size > 20
    return t[idx[:: max(1, idx.size // 12)]]


def _state_at(dyn, epoch, times):
    return dyn.propagate(Y0, (times.tt - epoch.tt).sec)[0]


def _reference(times):
    """Two-way range, one-way az/el and GCRS RA/Dec, by direct iteration (see module doc)."""
    dyn = Dynamics(GM, [], EPOCH, (-600, 9 * 3600), 1e-13, 1e-13)
    out = []
    for t in times:
        R, _ = STATION.gcrs_position_velocity(t[None])
        R = R[0]
        tau_d = 0.0
        for _ in range(5):
            rb = _state_at(dyn, EPOCH, (t - tau_d * u.s)[None])[0, :3]
            tau_d = np.linalg.norm(rb - R) / C_KM_S
        rb = _state_at(dyn, EPOCH, (t - tau_d * u.s)[None])[0, :3]
        tau_u = tau_d
        for _ in range(5):
            Rt, _ = STATION.gcrs_position_velocity((t - (tau_d + tau_u) * u.s)[None])
            tau_u = np.linalg.norm(rb - Rt[0]) / C_KM_S
        rho = rb - R
        rot = STATION.enu_matrix @ vv.satellites.frames.transform_matrices(
            t[None], "gcrs", "itrs")[0, :3, :3]
        e, n, z = rot @ rho
        out.append({
            "range": 0.5 * C_KM_S * (tau_d + tau_u),
            "azel": [np.mod(np.arctan2(e, n), 2 * np.pi), np.arcsin(z / np.linalg.norm(rho))],
            "radec": [np.mod(np.arctan2(rho[1], rho[0]), 2 * np.pi),
                      np.arcsin(rho[2] / np.linalg.norm(rho))],
        })  # fmt: skip
    return out


def test_two_way_range_and_one_way_angles_match_a_direct_iteration(visible):
    t = visible
    n = len(t)
    kinds = ["range", "azel", "radec"]
    rows = {k: simulate_observations(TRUTH, t, k, 1.0, STATION, seed=False) for k in kinds}
    geo = simulate_observations(TRUTH, t, "range", 1.0, STATION, seed=False, light_time=False)
    ref = _reference(t)
    for i in range(n):
        assert rows["range"].values[i, 0] == pytest.approx(ref[i]["range"], abs=ONE_MM)
        for k in ("azel", "radec"):
            d = rows[k].values[i, :2] - ref[i][k]
            d[0] = (d[0] + np.pi) % (2 * np.pi) - np.pi
            assert np.all(np.abs(d) < 2 * MAS), (k, i, d / MAS)
    # and the effect is real: the two-way range differs from the geometric one by metres to
    # a hundred metres (range rate x flight time)
    assert np.max(np.abs(rows["range"].values[:, 0] - geo.values[:, 0])) > 0.02


def test_two_way_range_rate_is_the_derivative_of_the_two_way_range(visible):
    t = visible[:8]
    h = 0.5  # s
    rr = simulate_observations(TRUTH, t, "range_rate", 1.0, STATION, seed=False)
    plus = simulate_observations(TRUTH, t + h * u.s, "range", 1.0, STATION, seed=False)
    minus = simulate_observations(TRUTH, t - h * u.s, "range", 1.0, STATION, seed=False)
    fd = (plus.values[:, 0] - minus.values[:, 0]) / (2 * h)
    np.testing.assert_allclose(rr.values[:, 0], fd, atol=2e-8)  # 20 um/s
    geo = simulate_observations(TRUTH, t, "range_rate", 1.0, STATION, seed=False,
                                light_time=False)  # fmt: skip
    assert np.max(np.abs(rr.values[:, 0] - geo.values[:, 0])) > 1e-5  # > 10 um/s: it matters


def test_radec_against_the_stars_is_the_barycentric_light_time_direction(visible):
    t = visible[:6]
    obs = simulate_observations(TRUTH, t, "radec", 1.0, STATION, seed=False,
                                radec_reference="stars")  # fmt: skip
    nat = simulate_observations(TRUTH, t, "radec", 1.0, STATION, seed=False)
    dyn = Dynamics(GM, [], EPOCH, (-600, 9 * 3600), 1e-13, 1e-13)
    for i, ti in enumerate(t):
        R, _ = STATION.gcrs_position_velocity(ti[None])
        xe_r = get_body_barycentric_posvel("earth", ti)[0].xyz.to_value(u.km)
        x_obs = xe_r + R[0]
        tau = 0.0
        for _ in range(5):
            tb = ti - tau * u.s
            xe_b = get_body_barycentric_posvel("earth", tb)[0].xyz.to_value(u.km)
            x_sat = xe_b + _state_at(dyn, EPOCH, tb[None])[0, :3]
            tau = np.linalg.norm(x_sat - x_obs) / C_KM_S
        d = x_sat - x_obs
        want = [np.mod(np.arctan2(d[1], d[0]), 2 * np.pi), np.arcsin(d[2] / np.linalg.norm(d))]
        diff = obs.values[i, :2] - want
        diff[0] = (diff[0] + np.pi) % (2 * np.pi) - np.pi
        assert np.all(np.abs(diff) < 5 * MAS), diff / MAS
    # the two references differ by at most the Earth's velocity over c (29.3-30.3 km/s: 20-21")
    sep = np.hypot((obs.values[:, 0] - nat.values[:, 0]) * np.cos(nat.values[:, 1]),
                   obs.values[:, 1] - nat.values[:, 1])  # fmt: skip
    assert 1.0 < np.degrees(sep.max()) * 3600 < 21.0


def test_light_time_partials_match_finite_differences(visible):
    t = visible[:6]
    kinds = np.array(["range", "range_rate", "azel", "radec", "range", "azel"])
    obs = simulate_observations(TRUTH, t, list(kinds), [1.0] * 6, STATION, seed=False)
    site_r, site_v, enu = obs.sites()
    y = Dynamics(GM, [], EPOCH, (0, 9 * 3600)).propagate(Y0, obs.offsets_s(EPOCH))[0]
    h, H = predict_light_time(kinds, y, site_r, site_v, enu, GM)
    for j in range(6):
        d = 1e-3 if j < 3 else 1e-6
        yp, ym = y.copy(), y.copy()
        yp[:, j] += d
        ym[:, j] -= d
        fd = (predict_light_time(kinds, yp, site_r, site_v, enu, GM)[0]
              - predict_light_time(kinds, ym, site_r, site_v, enu, GM)[0]) / (2 * d)
        # the partials neglect d(tau)/dy: O(v/c) = 3e-5 relative
        np.testing.assert_allclose(H[:, :, j], fd, rtol=2e-4,
                                   atol=2e-4 * np.abs(fd).max(axis=0, keepdims=True).max())
    # without stations the model is the geometric one
    pos = np.array(["position"] * 6)
    np.testing.assert_array_equal(predict_light_time(pos, y, site_r, site_v, enu, GM)[0],
                                  predict(pos, y, site_r, site_v, enu)[0])


def test_fit_needs_the_light_time_model_of_the_data():
    t = EPOCH + np.arange(0, 8 * 3600, 120.0) * u.s
    look = simulate_observations(TRUTH, t, "azel", 1e-9, STATION, seed=False, light_time=False)
    t = t[look.values[:, 1] > np.radians(5)]
    kinds = ["range", "azel"] * len(t)
    tt = t[np.repeat(np.arange(len(t)), 2)]
    sig = [0.005, np.radians(0.002)] * len(t)
    guess = vv.StateVectors((Y0[:3] + [3.0, -2.0, 1.0]) * u.km, (Y0[3:] + 1e-3) * KMS, vv.EARTH,
                            epoch=EPOCH)  # fmt: skip
    obs = simulate_observations(TRUTH, tt, kinds, sig, STATION, seed=3)
    assert obs.light_time
    fit = vv.fit_orbit(obs, guess)
    assert 0.8 < fit.rms < 1.2
    e = np.r_[fit.state.r.to_value(u.km), fit.state.v.to_value(KMS)] - Y0
    assert e @ np.linalg.solve(fit.covariance, e) < stats.chi2.ppf(0.999, 6)
    # the same data read as geometric: the fit absorbs the delay into a wrong orbit (RMS only
    # ~1.1, but ~800 m and thousands of sigmas from the truth)
    geo = vv.Observations(time=obs.times, kind=list(obs.kinds),
                          value=[obs.values[i, :obs.dims[i]] for i in range(len(obs))],
                          sigma=list(obs.sigmas), station=obs.stations, light_time=False)
    bad = vv.fit_orbit(geo, guess, outlier_sigma=None)
    e_bad = np.r_[bad.state.r.to_value(u.km), bad.state.v.to_value(KMS)] - Y0
    assert np.linalg.norm(e_bad[:3]) > 0.3 > 10 * np.linalg.norm(e[:3])
    assert e_bad @ np.linalg.solve(bad.covariance, e_bad) > 1000


def test_light_time_options_are_checked():
    t = EPOCH + [0, 60] * u.s
    with pytest.raises(vv.InvalidInputError, match="radec_reference"):
        vv.Observations(time=t, kind="range", value=[7000, 7001] * u.km, sigma=0.01,
                        station=STATION, radec_reference="icrs")
    with pytest.raises(vv.InvalidInputError, match="light_time=True"):
        vv.Observations(time=t, kind="range", value=[7000, 7001] * u.km, sigma=0.01,
                        station=STATION, light_time=False, radec_reference="stars")


def _leo_and_geo():
    """An ISS-like orbit (420 km, passing 5 deg of arc from the zenith at EPOCH) and a
    geostationary one 30 deg east of the station's meridian, as GCRS states at EPOCH."""
    R0 = STATION.gcrs_position_velocity(EPOCH[None])[0][0]
    up = R0 / np.linalg.norm(R0)
    east = np.cross([0.0, 0.0, 1.0], up)
    east /= np.linalg.norm(east)
    north = np.cross(up, east)
    a, d = 6378.137 + 420.0, np.radians(5.0)
    rhat = np.cos(d) * up - np.sin(d) * (east + north) / np.sqrt(2.0)
    normal = np.cross(rhat, 0.8 * north + 0.6 * east)
    vhat = np.cross(normal / np.linalg.norm(normal), rhat)
    leo = np.r_[a * rhat, np.sqrt(GM / a) * vhat]
    a, lon = 42164.17, np.arctan2(R0[1], R0[0]) + np.radians(30.0)
    geo = np.r_[a * np.cos(lon), a * np.sin(lon), 0.0,
                np.sqrt(GM / a) * np.array([-np.sin(lon), np.cos(lon), 0.0])]  # fmt: skip
    return {"leo": (leo, [-240.0, -120.0, 0.0, 120.0, 240.0]),
            "geo": (geo, [0.0, 3600.0, 7200.0])}  # fmt: skip


def _richardson(f, h=0.5):
    """d f / dt at 0 from central differences at h and h/2, extrapolated (error O(h^4))."""
    d1 = (f(h) - f(-h)) / (2 * h)
    d2 = (f(h / 2) - f(-h / 2)) / h
    return (4 * d2 - d1) / 3


@pytest.mark.parametrize("orbit", ["leo", "geo"])
def test_two_way_range_rate_in_leo_and_geo_is_the_rate_of_the_round_trip(orbit):
    """The two-way range rate (Doppler) against (a) a Richardson derivative of the model's own
    two-way range, (b) the same derivative of a direct GCRS iteration (the satellite
    re-propagated to the bounce time, astropy's station at the reception and transmit times)
    and (c) the two legs' Doppler ratio at the bounce, (c - u.v_b)(c + u_d.V_r) /
    ((c - u_u.V_t)(c + u_d.v_b)), from the direct iteration's states. Measured: (a), (b)
    0.2-12 um/s (astropy's station velocity omits the precession-nutation rate of the site's
    GCRS position, 13 um/s along z), (c) 0.5 um/s in LEO, 2.5 um/s at GEO (the model turns the
    site back about the GCRS z axis, not the pole)."""
    y0, offsets = _leo_and_geo()[orbit]
    truth = vv.StateVectors(y0[:3] * u.km, y0[3:] * KMS, vv.EARTH, epoch=EPOCH)
    t = EPOCH + np.array(offsets) * u.s
    rr = simulate_observations(truth, t, "range_rate", 1.0, STATION, seed=False).values[:, 0]
    own = _richardson(lambda h: simulate_observations(truth, t + h * u.s, "range", 1.0,
                                                      STATION, seed=False).values[:, 0])
    dyn = Dynamics(GM, [], EPOCH, (offsets[0] - 60, offsets[-1] + 60), 1e-13, 1e-13)

    def direct(tr):
        """Two-way range (km) at reception times tr, and the states of the Doppler ratio."""
        R, V = STATION.gcrs_position_velocity(tr)
        tau_d = np.zeros(len(tr))
        for _ in range(5):
            yb = np.stack([_state_of(dyn, y0, ti) for ti in tr - tau_d * u.s])
            tau_d = np.linalg.norm(yb[:, :3] - R, axis=-1) / C_KM_S
        tau_u = tau_d
        for _ in range(5):
            Rt, Vt = STATION.gcrs_position_velocity(tr - (tau_d + tau_u) * u.s)
            tau_u = np.linalg.norm(yb[:, :3] - Rt, axis=-1) / C_KM_S
        return 0.5 * C_KM_S * (tau_d + tau_u), (yb, R, V, Rt, Vt)

    ref = _richardson(lambda h: direct(t + h * u.s)[0])
    yb, R, V, Rt, Vt = direct(t)[1]
    u_d = (yb[:, :3] - R) / np.linalg.norm(yb[:, :3] - R, axis=-1)[:, None]
    u_u = (yb[:, :3] - Rt) / np.linalg.norm(yb[:, :3] - Rt, axis=-1)[:, None]
    dot = lambda a, b: np.sum(a * b, axis=-1)  # noqa: E731
    ratio = ((C_KM_S - dot(u_u, yb[:, 3:])) * (C_KM_S + dot(u_d, V))
             / ((C_KM_S - dot(u_u, Vt)) * (C_KM_S + dot(u_d, yb[:, 3:]))))  # fmt: skip
    doppler = 0.5 * C_KM_S * (1.0 - ratio)
    tol = 0.1 * ONE_MM  # 0.1 mm/s
    np.testing.assert_allclose(rr, own, rtol=0, atol=tol)
    np.testing.assert_allclose(rr, ref, rtol=0, atol=tol)
    np.testing.assert_allclose(rr, doppler, rtol=0, atol=0.01 * ONE_MM)  # 10 um/s
    geo = simulate_observations(truth, t, "range_rate", 1.0, STATION, seed=False,
                                light_time=False).values[:, 0]  # fmt: skip
    # the light time matters in LEO (0.16-0.17 m/s: -v^2/c and the legs' timing), not at GEO
    if orbit == "leo":
        assert np.all(np.abs(rr - geo) > 0.1e-3)


def _state_of(dyn, y0, t):
    return dyn.propagate(y0, np.array([(t.tt - EPOCH.tt).sec]))[0][0]
