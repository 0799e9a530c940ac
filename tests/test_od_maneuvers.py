"""Orbit determination through manoeuvres: simulated tracking with burns, batch fits with known
burns and with a burn's Δv estimated (recovery within its sigma, NEES over noise seeds), the
propagated covariance of such a fit against differenced propagate_cowell runs, and the
refusals."""

from __future__ import annotations

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from scipy import stats

import visviva as vv
from visviva.od import simulate_observations, simulate_tracking

EPOCH = Time("2024-03-01T00:00:00", scale="utc")
KMS = u.km / u.s
TRUTH = vv.StateVectors([6800.0, 100.0, 300.0] * u.km, [-0.1, 5.0, 5.7] * KMS, vv.EARTH,
                        epoch=EPOCH)
Y_TRUE = np.r_[TRUTH.r.to_value(u.km), TRUTH.v.to_value(KMS)]
STATIONS = [vv.GroundStation(40 * u.deg, -105 * u.deg, 1.6 * u.km),
            vv.GroundStation(-30 * u.deg, 20 * u.deg, 0.3 * u.km),
            vv.GroundStation(15 * u.deg, 150 * u.deg, 0.0 * u.km)]
FORCES = [vv.J2(vv.EARTH)]
BURN_T = 3 * 3600 * u.s
DV_TRUE = np.array([0.0005, 0.0015, -0.001])  # RTN, km/s: 1.9 m/s
TRUE_BURN = vv.ImpulsiveBurn(BURN_T, DV_TRUE * KMS, "RTN")


@pytest.fixture(scope="module")
def plan():
    """The rows of 8 h of range, range-rate and az/el tracking of the burning truth."""
    obs = simulate_tracking(TRUTH, STATIONS, EPOCH + np.arange(0, 8 * 3600, 60) * u.s, FORCES,
                            maneuvers=[TRUE_BURN], seed=False)
    return obs.times, list(obs.kinds), list(obs.sigmas), list(obs.stations)


def _obs(plan, seed):
    t, kinds, sigmas, stations = plan
    return simulate_observations(TRUTH, t, kinds, sigmas, stations, FORCES,
                                 maneuvers=[TRUE_BURN], seed=seed)


def _error(fit):
    return np.r_[fit.state.r.to_value(u.km), fit.state.v.to_value(KMS)] - Y_TRUE


def test_simulated_observations_fly_the_burn():
    t = EPOCH + np.array([0.0, 5000.0, 10800.0, 20000.0]) * u.s
    obs = simulate_observations(TRUTH, t, "position", 1e-3 * u.km, None, FORCES,
                                maneuvers=[TRUE_BURN], seed=False)
    ref = vv.propagate_cowell(TRUTH, t, FORCES, maneuvers=[TRUE_BURN])
    assert np.abs(obs.values - ref.r.to_value(u.km)).max() < 1e-6  # 1 mm


def test_fit_estimates_a_burn_from_zero_within_its_sigma(plan):
    obs = _obs(plan, 1)
    start = vv.ImpulsiveBurn(BURN_T, [0, 0, 0] * KMS, "RTN")
    fit = vv.fit_orbit(obs, TRUTH, FORCES, maneuvers=[start], estimate_maneuvers=True)
    assert fit.estimated_maneuvers == [0] and fit.delta_v.shape == (1, 3)
    err = fit.delta_v.to_value(KMS)[0] - DV_TRUE
    assert np.all(np.abs(err) < 3 * fit.delta_v_sigma.to_value(KMS)[0])
    assert fit.delta_v_sigma.to_value(u.m / u.s).max() < 0.05  # well determined: < 5 cm/s
    assert fit.full_covariance.shape == (9, 9) and fit.dof == int(obs.dims.sum()) - 9
    assert np.allclose(fit.full_covariance[:6, :6], fit.covariance)
    assert 0.7 < fit.rms < 1.3
    assert np.allclose(fit.maneuvers[0].delta_v.to_value(KMS), fit.delta_v.to_value(KMS)[0])
    assert not start.delta_v.value.any()  # the caller's burn is left alone


def test_nees_of_state_and_delta_v_is_chi_square_9(plan):
    nees = []
    start = vv.ImpulsiveBurn(BURN_T, [0, 0, 0] * KMS, "RTN")
    for seed in range(25):
        fit = vv.fit_orbit(_obs(plan, 100 + seed), TRUTH, FORCES, maneuvers=[start],
                           estimate_maneuvers=[0], outlier_sigma=None)
        e = np.r_[_error(fit), fit.delta_v.to_value(KMS)[0] - DV_TRUE]
        nees.append(float(e @ np.linalg.solve(fit.full_covariance, e)))
    # the mean of 25 chi-square(9) draws lies in [9 - 3.5 sd, 9 + 3.5 sd], sd = sqrt(18 / 25)
    assert abs(np.mean(nees) - 9.0) < 3.5 * np.sqrt(18 / 25)
    assert max(nees) < stats.chi2.ppf(0.9999, 9)


def test_fit_with_the_burn_known_equals_the_truth_to_noise(plan):
    obs = _obs(plan, 2)
    fit = vv.fit_orbit(obs, TRUTH, FORCES, maneuvers=[TRUE_BURN])
    e = _error(fit)
    assert e @ np.linalg.solve(fit.covariance, e) < stats.chi2.ppf(0.999, 6)
    assert 0.7 < fit.rms < 1.3 and fit.estimated_maneuvers == [] and fit.delta_v.shape == (0, 3)
    # the burn left out: no orbit fits the data
    with pytest.warns(RuntimeWarning, match="converged with an RMS of"):  # and says so
        blind = vv.fit_orbit(obs, TRUTH, FORCES, maneuvers=[], outlier_sigma=None)
    assert blind.rms > 20 * fit.rms


def test_fit_propagate_carries_the_delta_v_uncertainty_and_its_correlation(plan):
    fit = vv.fit_orbit(_obs(plan, 3), TRUTH, FORCES,
                       maneuvers=[vv.ImpulsiveBurn(BURN_T, [0, 0, 0] * KMS, "RTN")],
                       estimate_maneuvers=True)
    t = np.array([-600.0, 3 * 3600.0 + 900.0])
    out = fit.propagate(t * u.s)
    # the Jacobian of y(t) on (x0, Δv) by central differences of propagate_cowell
    x0 = np.r_[fit.state.r.to_value(u.km), fit.state.v.to_value(KMS)]
    dv0 = fit.delta_v.to_value(KMS)[0]
    jac = np.zeros((2, 6, 9))
    for j in range(9):
        h = (1e-3 if j < 3 else 1e-6)
        ends = []
        for sign in (1, -1):
            x, dv = x0.copy(), dv0.copy()
            if j < 6:
                x[j] += sign * h
            else:
                dv[j - 6] += sign * h
            s = vv.StateVectors(x[:3] * u.km, x[3:] * KMS, vv.EARTH, epoch=EPOCH)
            o = vv.propagate_cowell(s, t * u.s, FORCES, rtol=1e-13, atol=1e-13,
                                    maneuvers=[vv.ImpulsiveBurn(BURN_T, dv * KMS, "RTN")])
            ends.append(np.concatenate([o.r.to_value(u.km), o.v.to_value(KMS)], axis=-1))
        jac[:, :, j] = (ends[0] - ends[1]) / (2 * h)
    ref = jac @ fit.full_covariance @ np.swapaxes(jac, -1, -2)
    for k in range(2):
        assert np.abs(out.covariance[k] - ref[k]).max() < 1e-5 * np.abs(ref[k]).max()
    # leaving out the Δv's uncertainty and correlation changes the answer after the burn
    plain = vv.propagate_covariance(fit.state, fit.covariance, t * u.s, FORCES,
                                    maneuvers=fit.maneuvers)
    assert np.allclose(plain.covariance[0], out.covariance[0], rtol=1e-9, atol=1e-20)
    assert np.abs(plain.covariance[1] - ref[1]).max() > 1e-2 * np.abs(ref[1]).max()
    rtn = fit.propagate(t * u.s, output_frame="RTN")
    assert rtn.frame == "RTN"
    assert np.isclose(np.trace(rtn.covariance[1][:3, :3]), np.trace(out.covariance[1][:3, :3]))


def test_pending_opm_state_is_fitted_with_its_burns(plan):
    from visviva._containers import PENDING_MANEUVERS_ATTRIBUTE

    obs = _obs(plan, 4)
    state = vv.StateVectors(TRUTH.r, TRUTH.v, vv.EARTH, epoch=EPOCH)
    setattr(state, PENDING_MANEUVERS_ATTRIBUTE, 1)
    with pytest.raises(vv.InvalidInputError, match="maneuvers=opm.burns"):
        vv.fit_orbit(obs, state, FORCES)
    with pytest.raises(vv.InvalidInputError, match="maneuvers=opm.burns"):
        simulate_observations(state, EPOCH + [0, 60] * u.s, "position", 0.01 * u.km)
    fit = vv.fit_orbit(obs, state, FORCES, maneuvers=[TRUE_BURN])
    assert 0.7 < fit.rms < 1.3


def test_bad_estimates_are_refused(plan):
    obs = _obs(plan, 5)
    finite = vv.FiniteBurn(BURN_T, 10 * u.s, [0, 1, 0], "RTN", acceleration=1e-7 * u.km / u.s**2)
    late = vv.ImpulsiveBurn(9 * 3600 * u.s, [0, 0, 0] * KMS, "RTN")
    for kw, match in (({"maneuvers": [finite], "estimate_maneuvers": [0]}, "ImpulsiveBurn"),
                      ({"maneuvers": [finite], "estimate_maneuvers": True}, "no vv.ImpulsiveBurn"),
                      ({"maneuvers": [TRUE_BURN], "estimate_maneuvers": [1]}, "not one of"),
                      ({"maneuvers": [TRUE_BURN], "estimate_maneuvers": [0, 0]}, "twice"),
                      ({"maneuvers": [TRUE_BURN], "estimate_maneuvers": "all"}, "indices"),
                      ({"maneuvers": [TRUE_BURN, late], "estimate_maneuvers": [1]},
                       "no observation after it")):
        with pytest.raises(vv.InvalidInputError, match=match):
            vv.fit_orbit(obs, TRUTH, FORCES, **kw)


# --- the filter through known burns -----------------------------------------------------------
POS_T = EPOCH + np.arange(60, 3 * 3600, 120) * u.s
FILTER_BURN_T = 5400 * u.s
FILTER_DV = np.array([0.0002, 0.002, 0.0003])  # RTN, km/s


def _positions(burns, seed, sigma=0.001):
    return simulate_observations(TRUTH, POS_T, "position", sigma * u.km, None, None,
                                 maneuvers=burns, seed=seed)


@pytest.mark.parametrize("finite", [False, True])
def test_filter_equals_batch_through_a_known_burn(finite):
    """Two-body position fixes, no process noise: the EKF's last estimate is the batch estimate
    (burn known) mapped there through the burn, the smoother's first the batch one; an impulse,
    or a 5-minute RTN burn (its thrust's partials in both)."""
    burn = (vv.FiniteBurn(FILTER_BURN_T, 300 * u.s, FILTER_DV, "RTN",
                          acceleration=np.linalg.norm(FILTER_DV) / 300 * u.km / u.s**2)
            if finite else vv.ImpulsiveBurn(FILTER_BURN_T, FILTER_DV * KMS, "RTN"))
    obs = _positions([burn], 3)
    guess = vv.StateVectors(TRUTH.r + [5, -3, 2] * u.m, TRUTH.v + [3, 0, -2] * u.mm / u.s,
                            vv.EARTH, epoch=EPOCH)
    prior = np.diag([1.0] * 3 + [1e-4] * 3)
    f = vv.filter_orbit(obs, guess, prior, maneuvers=[burn], smoother=True, editing_sigma=None)
    fit = vv.fit_orbit(obs, guess, maneuvers=[burn], outlier_sigma=None)
    at_end = fit.propagate(f.offsets_s[-1] * u.s)
    xb = np.r_[at_end.r.to_value(u.km), at_end.v.to_value(KMS)]
    d = np.linalg.solve(np.linalg.cholesky(at_end.covariance), f.states[-1] - xb)
    assert np.abs(d).max() < 1e-3
    np.testing.assert_allclose(np.diag(f.covariance), np.diag(at_end.covariance), rtol=0.01)
    x0 = np.r_[fit.state.r.to_value(u.km), fit.state.v.to_value(KMS)]
    d0 = np.linalg.solve(np.linalg.cholesky(fit.covariance),
                         np.r_[f.first_state.r.to_value(u.km), f.first_state.v.to_value(KMS)] - x0)
    assert np.abs(d0).max() < 1e-3
    # without the burn the filter loses the orbit at it
    with pytest.raises(vv.ConvergenceError, match="diverged"):
        vv.filter_orbit(obs, guess, prior, maneuvers=[])


@pytest.mark.parametrize("method", ["ekf", "ukf"])
def test_filter_with_execution_error_is_consistent_across_the_burn(method):
    """The truth flies the planned Δv plus an error drawn from the burn's execution covariance;
    the filter's NEES after the burn stays chi-square(6) (and is far off without it), for the
    EKF (the burn's Jacobian) and the UKF (every sigma point through the burn, the execution
    error added as the points' mean of G C G^T)."""
    rng = np.random.default_rng(8)
    c = np.diag([0.05, 0.05, 0.05]) ** 2 * 1e-6  # 5 cm/s per RTN axis (km^2/s^2)
    planned = vv.ImpulsiveBurn(FILTER_BURN_T, FILTER_DV * KMS, "RTN", delta_v_covariance=c)
    blind = vv.ImpulsiveBurn(FILTER_BURN_T, FILTER_DV * KMS, "RTN")
    p0 = np.diag([1e-4] * 3 + [1e-10] * 3)
    runs = 15
    nees, nees_blind = [], []
    for _ in range(runs):
        flown = vv.ImpulsiveBurn(FILTER_BURN_T,
                                 (FILTER_DV + rng.multivariate_normal(np.zeros(3), c)) * KMS, "RTN")
        obs = _positions([flown], rng, sigma=0.01)
        truth = vv.propagate_cowell(TRUTH, obs.times, maneuvers=[flown])
        y = np.concatenate([truth.r.to_value(u.km), truth.v.to_value(KMS)], axis=-1)
        x0 = Y_TRUE + rng.multivariate_normal(np.zeros(6), p0)
        s0 = vv.StateVectors(x0[:3] * u.km, x0[3:] * KMS, vv.EARTH, epoch=EPOCH)
        after = slice(46, 49)  # the three fixes just after the burn (at 5460 s ...)
        for burn, out in ((planned, nees), (blind, nees_blind)):
            f = vv.filter_orbit(obs, s0, p0, maneuvers=[burn], editing_sigma=None,
                                divergence_count=1000, method=method)
            e = f.predicted_states[1:][after] - y[after]
            P = f.predicted_covariances[1:][after]
            out.append(np.einsum("ti,ti->t", e, np.linalg.solve(P, e[..., None])[..., 0]))
    lo, hi = stats.chi2.ppf([0.001, 0.999], 6 * runs) / runs
    assert lo < np.mean(nees, axis=0).min() and np.mean(nees, axis=0).max() < hi
    assert np.mean(nees_blind, axis=0)[0] > 3 * hi


def test_filter_applies_a_burn_at_the_epoch_and_accepts_a_pending_state():
    from visviva._containers import PENDING_MANEUVERS_ATTRIBUTE

    burn = vv.ImpulsiveBurn(0 * u.s, FILTER_DV * KMS, "TNW",
                            delta_v_covariance=np.eye(3) * (0.1 * u.m / u.s) ** 2)
    obs = _positions([burn], 4)
    state = vv.StateVectors(TRUTH.r, TRUTH.v, vv.EARTH, epoch=EPOCH)
    setattr(state, PENDING_MANEUVERS_ATTRIBUTE, 1)
    p0 = np.diag([1e-4] * 3 + [1e-10] * 3)
    with pytest.raises(vv.InvalidInputError, match="maneuvers=opm.burns"):
        vv.filter_orbit(obs, state, p0)
    f = vv.filter_orbit(obs, state, p0, maneuvers=[burn])
    ref = vv.propagate_covariance(TRUTH, p0, 0 * u.s, maneuvers=[burn])
    np.testing.assert_allclose(f.states[0][3:], ref.v.to_value(KMS), rtol=0, atol=1e-15)
    # the filter's square-root form: the same covariance to round-off of its scale
    d = np.sqrt(np.diag(np.asarray(ref.covariance)))
    np.testing.assert_allclose(np.asarray(f.covariances[0]) / np.outer(d, d),
                               np.asarray(ref.covariance) / np.outer(d, d), rtol=0, atol=1e-12)
    assert f.covariances[0][3, 3] > 1e-10 + 0.5e-8  # the 10 cm/s execution error is in
    assert not f.rejected.any()


def test_fit_through_a_known_finite_burn_and_a_burn_estimated_before_the_epoch(plan):
    """A finite RTN burn known in the dynamics (its thrust partials in the STM) and an impulse
    before the epoch estimated from the tracking before it (the partials carried backwards)."""
    t, kinds, sigmas, stations = plan
    finite = vv.FiniteBurn(5 * 3600 * u.s, 300 * u.s, [0.1, 1.0, 0.0], "RTN", thrust=20 * u.N,
                           mass=500 * u.kg, isp=220 * u.s)
    early = vv.ImpulsiveBurn(-2 * 3600 * u.s, [0.0, -0.001, 0.0005] * KMS, "TNW")
    times = t - 4 * u.h  # the same geometry of rows, from 4 h before the epoch
    obs = simulate_observations(TRUTH, times, kinds, sigmas, stations, FORCES,
                                maneuvers=[early, finite], seed=6)
    start = vv.ImpulsiveBurn(-2 * 3600 * u.s, [0, 0, 0] * KMS, "TNW")
    # rows shifted 4 h keep their stations but not their passes: synthetic through-the-Earth
    # rows (the burns' partials are under test, not visibility), which the fit names
    with pytest.warns(vv.errors.TrackingDataWarning, match="below their horizon"):
        fit = vv.fit_orbit(obs, TRUTH, FORCES, maneuvers=[start, finite],
                           estimate_maneuvers=[0])
    err = fit.delta_v.to_value(KMS)[0] - early.delta_v.to_value(KMS)
    assert np.all(np.abs(err) < 3.5 * fit.delta_v_sigma.to_value(KMS)[0])
    e = np.r_[_error(fit), err]
    assert e @ np.linalg.solve(fit.full_covariance, e) < stats.chi2.ppf(0.999, 9)
    assert 0.7 < fit.rms < 1.3
    assert fit.maneuvers[1] is finite


def test_a_planned_burn_with_an_execution_error_is_an_a_priori(plan):
    obs = _obs(plan, 7)
    free = vv.fit_orbit(obs, TRUTH, FORCES, estimate_maneuvers=True,
                        maneuvers=[vv.ImpulsiveBurn(BURN_T, [0, 0, 0] * KMS, "RTN")])
    loose = vv.fit_orbit(obs, TRUTH, FORCES, estimate_maneuvers=True, maneuvers=[
        vv.ImpulsiveBurn(BURN_T, [0, 0, 0] * KMS, "RTN",
                         delta_v_covariance=np.eye(3) * (100 * u.m / u.s) ** 2)])
    d = (loose.delta_v - free.delta_v).to_value(KMS)[0]
    assert np.all(np.abs(d) < 1e-3 * free.delta_v_sigma.to_value(KMS)[0])
    assert loose.dof == free.dof + 3
    # a burn after the last observation: the estimate is the plan, its covariance the prior's
    c = np.diag([0.02, 0.05, 0.01]) ** 2 * 1e-6
    late = vv.ImpulsiveBurn(9 * 3600 * u.s, [0.0, 0.001, 0.0] * KMS, "TNW", delta_v_covariance=c)
    fit = vv.fit_orbit(obs, TRUTH, FORCES, maneuvers=[TRUE_BURN, late], estimate_maneuvers=[1])
    assert np.allclose(fit.delta_v.to_value(KMS)[0], [0.0, 0.001, 0.0], rtol=0, atol=1e-15)
    assert np.allclose(fit.delta_v_covariance[0], c, rtol=1e-8, atol=0)
    assert np.abs(fit.full_covariance[:6, 6:]).max() < 1e-12 * np.sqrt(c.max())
    # a plan drawn around the truth with a prior comparable to the data: NEES chi-square(9)
    rng = np.random.default_rng(12)
    tight = np.diag([0.002, 0.0005, 0.005]) ** 2 * 1e-6  # 2, 0.5, 5 mm/s (km^2/s^2)
    nees = []
    for seed in range(15):
        planned = DV_TRUE + rng.multivariate_normal(np.zeros(3), tight)
        f = vv.fit_orbit(_obs(plan, 200 + seed), TRUTH, FORCES, estimate_maneuvers=True,
                         outlier_sigma=None, maneuvers=[
                             vv.ImpulsiveBurn(BURN_T, planned * KMS, "RTN", delta_v_covariance=tight)])
        e = np.r_[_error(f), f.delta_v.to_value(KMS)[0] - DV_TRUE]
        nees.append(float(e @ np.linalg.solve(f.full_covariance, e)))
        assert np.all(f.delta_v_sigma.to_value(KMS)[0] < np.sqrt(np.diag(tight)))
    lo, hi = stats.chi2.ppf([0.001, 0.999], 9 * 15) / 15
    assert lo < np.mean(nees) < hi
    with pytest.raises(vv.InvalidInputError, match="zero execution covariance"):
        vv.fit_orbit(obs, TRUTH, FORCES, estimate_maneuvers=True, maneuvers=[
            vv.ImpulsiveBurn(BURN_T, DV_TRUE * KMS, "RTN", delta_v_covariance=np.zeros((3, 3)))])
