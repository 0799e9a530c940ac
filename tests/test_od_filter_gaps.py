"""The extended Kalman filter over gaps of days between tracking arcs: its prediction over the
gaps by the unscented transform (visviva.od.extended.UNSCENTED_GAP_S), of the state and, with
estimate=, of the coefficients (constant or Gauss-Markov), and its sigma-point update where the
curvature check fails after such a gap, against the truth (NEES) and the unscented filter, and
against the STM's prediction where no gap is that long (bit for bit)."""

import warnings

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from scipy import stats

import visviva as vv
import visviva.od.extended as extended
from test_od_filter import _nees, _noisy
from visviva.od.dynamics import Dynamics

EPOCH = Time("2024-03-01T00:00:00", scale="utc")
GM = vv.EARTH.gm_km3_s2
Y_ECC = np.r_[6800.0, 100.0, 300.0, -0.1, 5.0, 5.7]  # the od tests' orbit (perigee 77 km, apogee 541 km: no drag)
STATIONS = [vv.GroundStation(40 * u.deg, -105 * u.deg, 1.6 * u.km, name="GOLD"),
            vv.GroundStation(-30 * u.deg, 20 * u.deg, 0.3 * u.km, name="HART")]
J2 = [vv.J2(vv.EARTH)]
#: 100 m and 10 cm/s
P_WIDE = np.diag([0.1**2] * 3 + [1e-4**2] * 3)


def _state(y):
    return vv.StateVectors(y[:3] * u.km, y[3:] * u.km / u.s, vv.EARTH, epoch=EPOCH)


@pytest.fixture(scope="module")
def two_arcs():
    """Two 3-hour arcs of two stations (range, range rate, az/el every 30 s above 10 deg), 3
    days apart, J2; the truth at the filter's epochs."""
    off = np.r_[np.arange(0, 3 * 3600, 30), 3 * 86400 + np.arange(0, 3 * 3600, 30)]
    exact = vv.od.simulate_tracking(_state(Y_ECC), STATIONS, EPOCH + off * u.s, J2, seed=False)
    epochs = np.r_[0.0, np.unique(exact.offsets_s(EPOCH))]
    truth, _ = Dynamics(GM, J2, EPOCH, (0, epochs[-1]), 1e-13, 1e-13).propagate(Y_ECC, epochs)
    return exact, truth


def _run(exact, truth, seed, P0=P_WIDE, **kw):
    rng = np.random.default_rng(seed)
    obs = _noisy(exact, rng)
    x0 = Y_ECC + rng.multivariate_normal(np.zeros(6), P0)
    f = vv.filter_orbit(obs, _state(x0), P0, J2, editing_sigma=None, smoother=True, **kw)
    return (_nees(f.states - truth, f.covariances).mean(),
            _nees(f.smoothed_states - truth, f.smoothed_covariances).mean())


def test_the_ekf_stays_consistent_across_a_gap_of_days(two_arcs, monkeypatch):
    # leftfix8: over the 3-day gap the STM's linear map left the error 16 sigmas out along
    # the covariance's thinnest direction (the flow's second-order term), so this draw's
    # filter NEES averaged 138 and its smoother's 135 (chi-square mean 6); with the gaps flown
    # by sigma points 8.6 and 5.5, the unscented filter's own numbers
    nees, smoothed = _run(*two_arcs, seed=0)
    assert nees < 15 and smoothed < 15
    monkeypatch.setattr(extended, "UNSCENTED_GAP_S", np.inf)  # the STM's prediction
    old, old_smoothed = _run(*two_arcs, seed=0)
    assert old > 100 and old_smoothed > 100


def test_tracking_without_a_long_gap_keeps_the_stm_prediction_bit_for_bit(monkeypatch):
    grid = EPOCH + np.arange(0, 3 * 3600, 30) * u.s  # gaps of up to 80 min between passes
    obs = vv.od.simulate_tracking(_state(Y_ECC), STATIONS, grid, J2, seed=1)
    a = vv.filter_orbit(obs, _state(Y_ECC), P_WIDE, J2, smoother=True)
    monkeypatch.setattr(extended, "UNSCENTED_GAP_S", 0.0)  # every gap by sigma points
    b = vv.filter_orbit(obs, _state(Y_ECC), P_WIDE, J2, smoother=True)
    monkeypatch.setattr(extended, "UNSCENTED_GAP_S", np.inf)  # none
    c = vv.filter_orbit(obs, _state(Y_ECC), P_WIDE, J2, smoother=True)
    assert np.array_equal(a.states, c.states) and np.array_equal(a.smoothed_states,
                                                                 c.smoothed_states)
    assert not np.array_equal(a.states, b.states)  # the switch does switch


@pytest.mark.slow
@pytest.mark.parametrize("P0", [P_WIDE, np.diag([0.01**2] * 3 + [1e-5**2] * 3)],
                         ids=["100m", "10m"])
def test_the_ekf_and_its_smoother_are_consistent_over_ten_draws(two_arcs, P0):
    # measured (10 draws from 100 m, 10 cm/s): filter 38.6 -> 6.5, smoother 4196 -> 5.6; the
    # unscented filter 6.5 and 6.2 over 5 draws (5 draws from 10 m, 1 cm/s: 36.6 -> 8.7 and
    # 102 -> 7.9, the unscented filter's 8.7 and 7.9)
    runs = 10
    out = np.array([_run(*two_arcs, seed=s, P0=P0) for s in range(runs)])
    lo, hi = stats.chi2.ppf([0.001, 0.999], 6 * runs) / runs
    assert lo < out[:, 0].mean() < hi and lo < out[:, 1].mean() < hi, out.mean(axis=0)


# --- with estimate=: the coefficients ride the sigma points over the gaps too -------------

AM = 0.01  # area-to-mass, m^2/kg: B = Cd AM
M2KG = u.m**2 / u.kg
B_TRUE, SIGMA_B = 2.2 * AM, 0.3 * AM  # Cd 2.2 +- 0.3
_V = np.sqrt(GM / 6800.0)
#: a circular 422 km orbit (51.6 deg): drag moves it km along track over 3 days
Y_LEO = np.r_[6800.0, 0.0, 0.0, 0.0, _V * np.cos(np.radians(51.6)), _V * np.sin(np.radians(51.6))]


def _drag(b):
    return [vv.J2(vv.EARTH), vv.AtmosphericDrag(b * M2KG)]


@pytest.fixture(scope="module")
def drag_arcs():
    """The two 3-hour arcs 3 days apart of the two stations, of the 422 km orbit with J2 and
    drag (Cd 2.2); the truth (x, B) at the filter's epochs."""
    off = np.r_[np.arange(0, 3 * 3600, 30), 3 * 86400 + np.arange(0, 3 * 3600, 30)]
    exact = vv.od.simulate_tracking(_state(Y_LEO), STATIONS, EPOCH + off * u.s, _drag(B_TRUE),
                                    seed=False)  # fmt: skip
    epochs = np.r_[0.0, np.unique(exact.offsets_s(EPOCH))]
    truth, _ = Dynamics(GM, _drag(B_TRUE), EPOCH, (0, epochs[-1]), 1e-13, 1e-13).propagate(
        Y_LEO, epochs)
    return exact, np.c_[truth, np.full(len(epochs), B_TRUE)]


def _run_drag(exact, truth, seed, **kw):
    """Filter (smoother on) a noisy draw of ``exact`` from a prior (state and B) drawn about
    the truth; the filtered (x, B) NEES at each epoch, the smoothed B's error over its sigma
    at each epoch and the result."""
    rng = np.random.default_rng(seed)
    obs = _noisy(exact, rng)
    x0 = Y_LEO + rng.multivariate_normal(np.zeros(6), P_WIDE)
    b0 = B_TRUE + SIGMA_B * rng.standard_normal()
    f = vv.filter_orbit(obs, _state(x0), P_WIDE, _drag(b0), estimate="drag",
                        parameter_sigma={"drag": SIGMA_B * M2KG}, editing_sigma=None,
                        smoother=True, **kw)
    z = np.c_[f.states, f.parameters["drag"].to_value(M2KG)]
    zb = ((f.smoothed_parameters["drag"] - B_TRUE * M2KG) / f.smoothed_parameter_sigma["drag"])
    return _nees(z - truth, f.full_covariances), zb.to(u.one).value, f


@pytest.mark.filterwarnings("ignore:the extended Kalman filter's linearisation")
def test_the_ekf_estimating_drag_stays_consistent_across_a_gap_of_days(drag_arcs, monkeypatch):
    # odgap: with estimate= the EKF still mapped the 3-day gap with the STM (Phi_z = [[Phi, S],
    # [0, 1]]): this draw's (x, B) NEES averaged 1.3e4 over the epochs (2.6e4 after the gap,
    # 6.7 for the state alone: the state-B correlation was wrong) and other draws diverged in
    # the second arc (2 of 5); with (x, B) flown by sigma points 6.7 (the UKF's 6.7)
    nees, zb, _ = _run_drag(*drag_arcs, seed=0)
    assert nees.mean() < 15 and np.abs(zb).max() < 3
    monkeypatch.setattr(extended, "UNSCENTED_GAP_S", np.inf)  # the old prediction
    old, _, _ = _run_drag(*drag_arcs, seed=0)
    assert old.mean() > 1000


def test_with_estimate_the_gap_switch_switches_and_short_tracking_keeps_the_stm(monkeypatch):
    # odgap: before, estimate= kept the STM's prediction whatever the gaps (the switch did
    # nothing); tracking without a 6-hour gap still runs the STM's code, bit for bit
    grid = EPOCH + np.arange(0, 3 * 3600, 30) * u.s  # gaps of up to 80 min between passes
    obs = vv.od.simulate_tracking(_state(Y_LEO), STATIONS, grid, _drag(B_TRUE), seed=1)
    kw = dict(estimate="drag", parameter_sigma={"drag": SIGMA_B * M2KG}, smoother=True)
    for noise in (None, {"drag": (SIGMA_B * M2KG, 3 * u.hour)}):
        a = vv.filter_orbit(obs, _state(Y_LEO), P_WIDE, _drag(B_TRUE), parameter_noise=noise,
                            **kw)
        monkeypatch.setattr(extended, "UNSCENTED_GAP_S", 0.0)  # every gap by sigma points
        b = vv.filter_orbit(obs, _state(Y_LEO), P_WIDE, _drag(B_TRUE), parameter_noise=noise,
                            **kw)
        monkeypatch.setattr(extended, "UNSCENTED_GAP_S", np.inf)  # none
        c = vv.filter_orbit(obs, _state(Y_LEO), P_WIDE, _drag(B_TRUE), parameter_noise=noise,
                            **kw)
        monkeypatch.undo()
        assert np.array_equal(a.full_covariances, c.full_covariances)
        assert np.array_equal(a.smoothed_states, c.smoothed_states)
        assert not np.array_equal(a.full_covariances, b.full_covariances)
        # and the sigma points agree with the STM where the flow is linear across P
        B = a.parameters["drag"].to_value(M2KG)
        assert np.allclose(b.parameters["drag"].to_value(M2KG), B, atol=0.05 * SIGMA_B)


def test_the_ekf_updates_by_sigma_points_where_a_gap_of_days_bends_the_measurements(
        drag_arcs, monkeypatch):
    # odgap: with Gauss-Markov drag (Cd 0.3, tau 1 day) the 3 days leave 9 km along track, and
    # the linearised update at the first epoch after the gap failed (a curvature shift of 3.4+
    # sigmas, warned): this draw's (x, B) NEES 262 there, 39.9 on average; updated by the
    # sigma points where the check fails (after the sigma-point prediction) 11.6 and 9.2, the
    # UKF's own numbers (as on draws 0-4: mean 74.8 -> 8.44, the UKF's 8.44)
    exact, truth = drag_arcs
    first = int(np.searchsorted(np.unique(exact.offsets_s(EPOCH)), 3 * 86400)) + 1
    noise = {"drag": (SIGMA_B * M2KG, 1 * u.day)}
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # nothing to warn about now
        nees, zb, _ = _run_drag(exact, truth, seed=1, parameter_noise=noise)
    assert nees[first] < 25 and nees.mean() < 15 and np.abs(zb).max() < 3
    monkeypatch.setattr(extended, "_sigma_point_update", lambda *a: extended._update(*a))
    with warnings.catch_warnings():  # (the linearised update warned here)
        warnings.simplefilter("ignore", RuntimeWarning)
        old, _, _ = _run_drag(exact, truth, seed=1, parameter_noise=noise)
    assert old[first] > 100


@pytest.mark.slow
@pytest.mark.parametrize("tau", [None, 1 * u.day], ids=["constant", "gauss-markov"])
def test_the_ekf_estimating_drag_matches_the_ukf_over_five_draws(drag_arcs, tau):
    # measured (draws 0-4, (x, B) NEES averaged over the epochs): B constant, the STM's
    # prediction 2 draws diverged, the other 3 1.3e4-9.6e5 -> 8.1 (the UKF 8.1); Gauss-Markov
    # (Cd 0.3, tau 1 day) 146 (1 diverged) -> 74.8 (sigma-point prediction, linear update)
    # -> 8.44 (the UKF 8.44); the smoothed B within 3 sigma of the truth throughout
    noise = None if tau is None else {"drag": (SIGMA_B * M2KG, tau)}
    runs = 5
    out = {}
    for method in ("ekf", "ukf"):
        res = [_run_drag(*drag_arcs, seed=s, parameter_noise=noise, method=method)
               for s in range(runs)]
        out[method] = np.array([r[0].mean() for r in res])
        assert max(np.abs(r[1]).max() for r in res) < 3
    lo, hi = stats.chi2.ppf([0.001, 0.999], 7 * runs) / runs
    assert lo < out["ekf"].mean() < hi, out
    assert np.allclose(out["ekf"], out["ukf"], rtol=0.1), out
