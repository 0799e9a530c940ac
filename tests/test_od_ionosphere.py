"""The ionosphere in the station measurement models (``Observations(ionosphere=...,
frequency_hz=...)``): the Klobuchar broadcast model against a hand computation from IS-GPS-200,
the f^-2 scaling, the thin-shell mapping, the range rate's term as the derivative of the
range's, the range partials against central differences, fits of S-band range data that need
the model, and bad input refused."""

import math

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

import visviva as vv
from visviva.od import simulate_observations
from visviva.od.ionosphere import (
    K_GROUP,
    TECU,
    ionosphere_from,
    klobuchar_l1_s,
    vtec_mapping,
)

EPOCH = Time("2024-03-01T00:00:00", scale="utc")
KMS = u.km / u.s
Y0 = np.array([6878.0, 0.0, 0.0, 0.0, 4.7, 5.9])  # 500 km, i = 51.5 deg
TRUTH = vv.StateVectors(Y0[:3] * u.km, Y0[3:] * KMS, vv.EARTH, epoch=EPOCH)
STATION = vv.GroundStation(40 * u.deg, -10 * u.deg, 0.1 * u.km)
S_BAND = 2.2e9
C_M_S = 299_792_458.0
# a navigation message's coefficients (the classic example set)
ALPHA = (3.82e-8, 1.49e-8, -1.79e-7, 0.0)
BETA = (1.43e5, 0.0, -3.28e5, 1.13e5)


@pytest.fixture(scope="module")
def visible(visible_times):
    """Times over a day when the station sees the satellite above 5 deg (every 20 s)."""
    return visible_times(TRUTH, STATION)


def test_klobuchar_against_a_hand_computation_from_the_spec():
    # IS-GPS-200 20.3.3.5.2.5, user at 40 N 100 W, satellite at azimuth 210 deg, elevation
    # 20 deg, GPS time of week 593100 s; each step by hand (semicircles):
    e = 20 / 180  # 0.11111
    psi = 0.0137 / (e + 0.11) - 0.022  # 0.039960
    phi_i = 40 / 180 + psi * math.cos(math.radians(210))  # 0.187616 (inside +-0.416)
    lam_i = -100 / 180 + psi * math.sin(math.radians(210)) / math.cos(phi_i * math.pi)
    phi_m = phi_i + 0.064 * math.cos((lam_i - 1.617) * math.pi)
    t = (4.32e4 * lam_i + 593100) % 86400  # local time of the pierce point, s
    amp = ALPHA[0] + ALPHA[1] * phi_m + ALPHA[2] * phi_m**2 + ALPHA[3] * phi_m**3
    per = BETA[0] + BETA[1] * phi_m + BETA[2] * phi_m**2 + BETA[3] * phi_m**3
    x = 2 * math.pi * (t - 50400) / max(per, 72000)
    f = 1 + 16 * (0.53 - e) ** 3
    assert abs(x) < 1.57 and amp > 0  # the day-side branch
    hand = f * (5e-9 + amp * (1 - x**2 / 2 + x**4 / 24))
    got = klobuchar_l1_s(math.radians(40), math.radians(-100), math.radians(210),
                         math.radians(20), 593100.0, ALPHA, BETA)
    assert got == pytest.approx(hand, rel=1e-12)
    # the worked numbers: psi, phi_i, lambda_i, phi_m, local time 13.79 h, F and 23.784 m at L1
    assert psi == pytest.approx(0.039960, abs=1e-6) and phi_i == pytest.approx(0.187616, abs=1e-6)
    assert lam_i == pytest.approx(-0.579591, abs=1e-6) and phi_m == pytest.approx(0.239793,
                                                                                 abs=1e-6)
    assert t == pytest.approx(49661.67, abs=0.01) and f == pytest.approx(2.17602, abs=1e-5)
    assert got * C_M_S == pytest.approx(23.784, abs=1e-3)
    # at night (local time 2 h at the pierce point) only the 5 ns floor, times F
    night = klobuchar_l1_s(0.0, 0.0, 0.0, math.pi / 2, 7200.0, ALPHA, BETA)
    assert night == pytest.approx(5e-9 * (1 + 16 * (0.53 - 0.5) ** 3), rel=1e-12)


def test_delay_scales_as_one_over_f_squared():
    kl = {"klobuchar": (ALPHA, BETA)}
    args = (math.radians(40), math.radians(-100), math.radians(210), math.radians(20), 593100.0)
    l1 = ionosphere_from(kl, 1575.42e6).slant_delay_m(*args)
    s = ionosphere_from(kl, S_BAND).slant_delay_m(*args)
    x = ionosphere_from(kl, 8.4e9 * u.Hz).slant_delay_m(*args)
    assert l1 == pytest.approx(23.784, abs=1e-3)
    assert s == pytest.approx(l1 * (1575.42 / 2200) ** 2, rel=1e-12)  # 12.2 m in S band
    assert x == pytest.approx(l1 * (1575.42 / 8400) ** 2, rel=1e-12)
    # the vertical TEC: 40.3 TEC / f^2 at the zenith: 20 TECU is 1.665 m in S band
    v = ionosphere_from({"vtec_tecu": 20.0}, S_BAND)
    assert v.slant_delay_m(0.0, 0.0, 0.0, math.pi / 2, 0.0) == pytest.approx(
        40.3 * 20e16 / S_BAND**2, rel=1e-12)
    assert K_GROUP * TECU / S_BAND**2 == pytest.approx(0.0833, abs=1e-4)  # m per TECU
    assert ionosphere_from({"vtec_tecu": 20.0}, 2 * S_BAND).slant_delay_m(
        0.0, 0.0, 0.0, 1.0, 0.0) == pytest.approx(v.slant_delay_m(0.0, 0.0, 0.0, 1.0, 0.0) / 4)


def test_the_mapping_is_one_at_the_zenith_and_grows_toward_the_horizon():
    el = np.radians(np.linspace(0, 90, 91))
    m, dm = vtec_mapping(el, 350.0)
    assert m[-1] == pytest.approx(1.0, abs=1e-15)
    assert np.all(np.diff(m) < 0)  # larger the lower the satellite
    k = 6371 / 6721
    assert m[0] == pytest.approx(1 / math.sqrt(1 - k * k), rel=1e-12)  # 3.14 at the horizon
    assert 3.0 < m[0] < 3.2
    # at 30 deg: sin z' = k cos 30 deg
    assert m[30] == pytest.approx(1 / math.sqrt(1 - (k * math.cos(math.radians(30))) ** 2))
    fd = (vtec_mapping(el + 1e-7, 350.0)[0] - vtec_mapping(el - 1e-7, 350.0)[0]) / 2e-7
    assert np.allclose(dm[1:], fd[1:], rtol=1e-6, atol=1e-9)
    # a higher shell maps less steeply
    assert vtec_mapping(0.1, 450.0)[0] < vtec_mapping(0.1, 350.0)[0]


@settings(max_examples=200, deadline=None)
@given(lat=st.floats(-89.9, 89.9), lon=st.floats(-180, 180), az=st.floats(0, 359.9),
       el=st.floats(0, 90), gps=st.floats(0, 604800), f=st.floats(1e8, 3e10))
def test_klobuchar_is_bounded_and_scales_with_frequency(lat, lon, az, el, gps, f):
    # between the night floor (5 ns times F) and F (5 ns + alpha_0 + ...) at any place and time
    args = (math.radians(lat), math.radians(lon), math.radians(az), math.radians(el), gps)
    t = klobuchar_l1_s(*args, ALPHA, BETA)
    floor = 5e-9 * (1 + 16 * (0.53 - el / 180) ** 3)
    assert floor * (1 - 1e-12) <= t <= floor * (1 + 20)
    delay = ionosphere_from({"klobuchar": (ALPHA, BETA)}, f).slant_delay_m(*args)
    assert delay == pytest.approx(t * C_M_S * (1575.42e6 / f) ** 2, rel=1e-12)


IONO = {"vtec": {"vtec_tecu": 25.0, "shell_km": 350.0}, "klobuchar": {"klobuchar": (ALPHA, BETA)}}


def _pair(times, kind, sigma, iono, **kw):
    a = simulate_observations(TRUTH, times, kind, sigma, STATION, seed=False, **kw)
    b = simulate_observations(TRUTH, times, kind, sigma, STATION, seed=False,
                              ionosphere=iono, frequency_hz=S_BAND, **kw)
    return a, b


@pytest.mark.parametrize("which", ["vtec", "klobuchar"])
def test_the_range_rate_term_is_the_derivative_of_the_range_delay(visible, which):
    iono = IONO[which]
    t = visible[5:40:5]
    dt = 0.5
    plus, minus = (_pair(t + s * u.s, "range", 0.005, iono) for s in (dt, -dt))
    rate_fd = ((plus[1].values - plus[0].values) - (minus[1].values - minus[0].values))[:, 0] \
        / (2 * dt)
    a, b = _pair(t, "range_rate", 1e-6, iono)
    rate = (b.values - a.values)[:, 0]
    assert np.abs(rate_fd).max() > 1e-6  # mm/s to cm/s along a LEO pass
    assert np.abs(rate - rate_fd).max() < 2e-9 + 1e-3 * np.abs(rate_fd).max()  # km/s
    # carrier Doppler: the phase advance's rate, the opposite sign
    _, c = _pair(t, "range_rate", 1e-6, {**iono, "doppler": "phase"})
    assert np.allclose(c.values[:, 0] - a.values[:, 0], -rate, rtol=1e-9, atol=1e-15)


def test_the_delays_along_a_pass_and_angles_untouched(visible):
    t = visible[:60]
    a, b = _pair(t, "range", 0.005, IONO["vtec"])
    el = simulate_observations(TRUTH, t, "azel", 1e-9, STATION, seed=False).values[:, 1]
    delay_m = (b.values[:, 0] - a.values[:, 0]) * 1e3
    zenith = 40.3 * 25e16 / S_BAND**2  # 2.08 m
    assert np.all(delay_m > zenith) and np.all(delay_m < 3.2 * zenith)
    assert np.all(np.diff(delay_m[np.argsort(el)]) < 0)
    for kind in ("azel", "radec"):
        a, b = _pair(t, kind, 1e-6, IONO["klobuchar"])
        assert np.array_equal(a.values, b.values)


@pytest.mark.parametrize("which", ["vtec", "klobuchar"])
def test_range_partials_carry_the_delay_slope(visible, which):
    from visviva.od.dynamics import Dynamics
    from visviva.od.light_time import model

    gm = vv.EARTH.gm_km3_s2
    t = visible[:20]
    obs, plain = (simulate_observations(TRUTH, t, "range", 0.005, STATION, seed=False, **kw)
                  for kw in ({"ionosphere": IONO[which], "frequency_hz": S_BAND}, {}))
    dyn = Dynamics(gm, [], EPOCH, (0, 86400), 1e-13, 1e-13)
    y = dyn.propagate(Y0, obs.offsets_s(EPOCH))[0]
    part = model(obs, y, gm)[1] - model(plain, y, gm)[1]
    assert np.abs(part[:, 0, :3]).max() > 3e-6  # km of delay per km
    for j in range(3):
        yp, ym = y.copy(), y.copy()
        yp[:, j] += 1e-2
        ym[:, j] -= 1e-2
        delay = [model(obs, z, gm)[0] - model(plain, z, gm)[0] for z in (yp, ym)]
        fd = (delay[0] - delay[1])[:, 0] / 2e-2
        assert np.abs(part[:, 0, j] - fd).max() < 1e-4 * np.abs(part[:, 0, :3]).max() + 1e-11


def test_fits_of_s_band_range_need_the_ionosphere(visible):
    t = visible
    guess = vv.StateVectors((Y0[:3] + [0.2, -0.1, 0.1]) * u.km, (Y0[3:] + 2e-4) * KMS,
                            vv.EARTH, epoch=EPOCH)
    iono = {"vtec_tecu": 40.0}
    obs = simulate_observations(TRUTH, t, "range", 0.001, STATION, seed=7, ionosphere=iono,
                                frequency_hz=S_BAND)
    fit = vv.fit_orbit(obs, guess)
    e = np.r_[fit.state.r.to_value(u.km), fit.state.v.to_value(KMS)] - Y0
    assert 0.8 < fit.rms < 1.2
    assert e @ np.linalg.solve(fit.covariance, e) < stats.chi2.ppf(0.999, 6)
    flat = obs.without_media()
    bad = vv.fit_orbit(flat, guess, outlier_sigma=None)
    e_bad = np.r_[bad.state.r.to_value(u.km), bad.state.v.to_value(KMS)] - Y0
    # measured: with the model RMS 0.94, 0.72 m from the truth; without it RMS 7.7, 1.9 m off
    # and NEES 1785 (40 TECU in S band: 3.3 m at the zenith, 10 m near the horizon)
    assert bad.rms > 3 and e_bad @ np.linalg.solve(bad.covariance, e_bad) > 100
    assert np.linalg.norm(e_bad[:3]) > 2 * np.linalg.norm(e[:3])


def test_bad_input_is_refused():
    t = EPOCH + [0, 60] * u.s
    kw = {"time": t, "kind": "range", "value": [1000.0, 1001.0], "sigma": 0.01,
          "station": STATION}
    bad = [
        ({"ionosphere": {"vtec_tecu": 20.0}}, "frequency_hz"),  # no frequency
        ({"ionosphere": {"vtec_tecu": 20.0}, "frequency_hz": 0.0}, "> 0"),
        ({"ionosphere": {"vtec_tecu": 20.0}, "frequency_hz": -2e9}, "> 0"),
        ({"ionosphere": {"vtec_tecu": 20.0}, "frequency_hz": [2e9, 3e9, 4e9]}, "one number"),
        ({"ionosphere": {"vtec_tecu": 20.0}, "frequency_hz": float("nan")}, "finite"),
        ({"ionosphere": {"vtec_tecu": 20.0}, "frequency_hz": 2.2 * u.km}, "Hz"),
        ({"ionosphere": {"vtec_tecu": -1.0}, "frequency_hz": S_BAND}, ">= 0"),
        ({"ionosphere": {"vtec_tecu": float("nan")}, "frequency_hz": S_BAND}, "finite"),
        ({"ionosphere": {"vtec_tecu": 20.0, "shell_km": 0}, "frequency_hz": S_BAND}, "shell"),
        ({"ionosphere": {"klobuchar": (ALPHA, BETA[:3])}, "frequency_hz": S_BAND}, "beta"),
        ({"ionosphere": {"klobuchar": ((np.nan, 0, 0, 0), BETA)}, "frequency_hz": S_BAND},
         "alpha"),
        ({"ionosphere": {"klobuchar": ALPHA}, "frequency_hz": S_BAND},
         r"\(alpha\[4\], beta\[4\]\)"),
        ({"ionosphere": {"vtec_tecu": True}, "frequency_hz": S_BAND}, "finite number"),
        ({"ionosphere": {"vtec_tecu": "20"}, "frequency_hz": S_BAND}, "finite number"),
        ({"ionosphere": {"vtec_tecu": 20.0}, "frequency_hz": True}, "one number"),
        ({"ionosphere": {"vtec_tecu": 20.0}, "frequency_hz": "2.2e9"}, "one number"),
        ({"ionosphere": {"tec": 20.0}, "frequency_hz": S_BAND}, "vtec_tecu"),
        ({"ionosphere": {"vtec_tecu": 20.0, "doppler": "carrier"}, "frequency_hz": S_BAND},
         "phase"),
        ({"ionosphere": 20.0, "frequency_hz": S_BAND}, "vtec_tecu"),
    ]
    for extra, words in bad:
        with pytest.raises(vv.InvalidInputError, match=words):
            vv.Observations(**kw, **extra)
    ok = vv.Observations(**kw, ionosphere={"vtec_tecu": 0.0}, frequency_hz=2.2 * u.GHz)
    assert ok.ionosphere.frequency_hz == pytest.approx(2.2e9)


def test_the_tdm_reader_and_the_cli_carry_the_ionosphere(visible, tmp_path, capsys):
    # a TDM of S-band range from one station written with the delay of 30 TECU in it: the
    # od command with --ionosphere fits it as fit_orbit does on to_observations(ionosphere=)
    from visviva import cli

    station = vv.GroundStation(40 * u.deg, -10 * u.deg, 100 * u.m, name="SITE")
    plan = vv.od.simulate_tracking(TRUTH, [station], visible[::2], seed=False,
                                   measurements={"range": 0.002, "azel": 0.01 * u.deg},
                                   min_elevation=5 * u.deg)
    iono = {"vtec_tecu": 30.0}
    delayed = simulate_observations(TRUTH, plan.times, list(plan.kinds), list(plan.sigmas),
                                    plan.stations, seed=3, ionosphere=iono, frequency_hz=S_BAND)
    tdm = tmp_path / "s.tdm"
    vv.write_tdm(delayed, tdm)
    sigma = {"range": 2 * u.m, "azel": 0.01 * u.deg}
    read = vv.read_tdm(tdm).to_observations({"SITE": station}, sigma, ionosphere=iono,
                                            frequency_hz=S_BAND)
    assert read.ionosphere.vtec_tecu == 30.0 and read.ionosphere.frequency_hz == S_BAND
    from visviva.ccsds.opm import OPM

    guess = vv.StateVectors((Y0[:3] + [0.2, -0.1, 0.1]) * u.km, (Y0[3:] + 2e-4) * KMS,
                            vv.EARTH, epoch=EPOCH)
    first = tmp_path / "guess.opm"
    vv.write_opm(OPM.from_state(guess, object_name="SAT-1"), first)
    fit = vv.fit_orbit(read, vv.read_opm(first).state)
    plain = vv.fit_orbit(vv.read_tdm(tdm).to_observations({"SITE": station}, sigma),
                         vv.read_opm(first).state, outlier_sigma=None)
    assert np.linalg.norm((plain.state.r - fit.state.r).to_value(u.km)) > 3e-4  # metres
    opm = tmp_path / "s.opm"
    args = [str(tdm), "--station", "SITE=40,-10,100", "--sigma", "range=2m,angle=0.01deg",
            "--initial", str(first), "--opm", str(opm)]
    code = cli.main(["od", *args, "--ionosphere", "vtec=30,shell=350km", "--frequency",
                     "2.2GHz"])
    err = capsys.readouterr().err
    assert code == 0, err
    np.testing.assert_allclose(vv.read_opm(opm).state.r.to_value(u.km),
                               fit.state.r.to_value(u.km), rtol=0, atol=1e-9)
    for extra, words in ((["--ionosphere", "vtec=30"], "--frequency"),
                         (["--frequency", "2.2GHz"], "add --ionosphere"),
                         (["--ionosphere", "vtec=-3", "--frequency", "2.2GHz"], ">= 0"),
                         (["--ionosphere", "tec=3", "--frequency", "2.2GHz"], "vtec=TECU"),
                         (["--ionosphere", "vtec=3", "--frequency", "2.2"], "no unit"),
                         (["--ionosphere", "klobuchar=1,2,3", "--frequency", "2GHz"],
                          "klobuchar=A0")):
        code = cli.main(["od", *args, "--overwrite", *extra])
        err = capsys.readouterr().err
        assert code == 2 and words in err, (extra, err)


@pytest.mark.parametrize("method", ["ekf", "ukf"])
def test_the_filters_carry_the_ionosphere(visible, method):
    # S-band range (1 m) and range rate (1 mm/s) with the Klobuchar delay (5-12 m): a filter
    # from the truth with the model accepts every row and ends within its sigmas of the truth;
    # the same filter without the model rejects rows or diverges
    t = visible[::2]
    kinds = ["range", "range_rate"] * len(t)
    tt = t[np.repeat(np.arange(len(t)), 2)]
    obs = simulate_observations(TRUTH, tt, kinds, [0.001, 1e-6] * len(t), STATION, seed=11,
                                ionosphere=IONO["klobuchar"], frequency_hz=S_BAND)
    p0 = np.diag([1e-4] * 3 + [1e-10] * 3)
    f = vv.filter_orbit(obs, TRUTH, p0, method=method)
    assert f.rejected.sum() == 0
    truth = vv.propagate_cowell(TRUTH, f.times[-1:], [])
    e = np.r_[f.state.r.to_value(u.km) - truth.r.to_value(u.km).reshape(3),
              f.state.v.to_value(KMS) - truth.v.to_value(KMS).reshape(3)]
    assert e @ np.linalg.solve(f.covariance, e) < stats.chi2.ppf(0.999, 6)
    flat = obs.without_media()
    try:
        bad = vv.filter_orbit(flat, TRUTH, p0, method=method)
    except vv.ConvergenceError:
        return
    assert bad.rejected.sum() > 10


def test_klobuchar_partials_are_one_sided_at_the_night_switch():
    # the Klobuchar delay jumps at |x| = 1.57 (its cosine's 4th-order series is 0.0213 of the
    # amplitude there, the night value 0): a central difference across it is no derivative
    from visviva.od.ionosphere import _klobuchar, slopes

    iono = ionosphere_from({"klobuchar": (ALPHA, BETA)}, S_BAND)
    lat, lon, az, el = math.radians(40), math.radians(-10), math.radians(120), math.radians(30)
    grid = 50400.0 + np.arange(0.0, 43200.0, 60.0)  # from local noon on: the evening switch
    day = _klobuchar(lat, lon, az, el, grid, ALPHA, BETA)[1] % 2 == 1
    k = int(np.flatnonzero(day[:-1] & ~day[1:])[0])
    lo, hi = grid[k], grid[k + 1]
    for _ in range(50):  # bisect to the switch
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _klobuchar(lat, lon, az, el, mid, ALPHA, BETA)[1] % 2 else (lo, mid)
    args = [np.array([v]) for v in (lat, lon, az, el)]

    def fd(t, step):  # a one-sided finite difference of 1 ms that stays on t's side
        return (iono.slant_delay_m(*args, np.array([t + step]))
                - iono.slant_delay_m(*args, np.array([t]))) / step

    jump = (iono.slant_delay_m(*args, np.array([lo])) - iono.slant_delay_m(*args, np.array([hi])))
    assert jump[0] > 1e-3  # m: the switch is a jump, not a kink
    for t, step in ((lo - 0.3, -1e-3), (hi + 0.3, 1e-3)):  # day side, then night side
        _, _, dt = slopes(iono, *args, np.array([t]))
        np.testing.assert_allclose(dt, fd(t, step), rtol=1e-3, atol=1e-9)
    assert abs(fd(lo - 0.3, -1e-3)[0]) > 1e-7  # m/s: the day side does move
