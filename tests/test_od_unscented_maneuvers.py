"""The unscented filter of vv.filter_orbit (method="ukf") through manoeuvres and with estimated
drag/SRP coefficients: equal to the extended filter on nearly linear problems (an impulse, a
finite burn, a burn at the epoch, Cd in the state), consistent (Monte Carlo NEES) through a burn
with execution error, Cd recovered from a wrong prior, per-sigma-point coefficients in the
compiled propagation."""

import numpy as np
import pytest
from astropy import units as u
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

import visviva as vv
from test_od_maneuvers import EPOCH, FILTER_BURN_T, FILTER_DV, KMS, TRUTH, Y_TRUE, _positions
from test_od_parameters import AM, LEO, M2KG, _leo_forces, _leo_positions
from visviva.core import force_block as fb
from visviva.od.dynamics import Dynamics
from visviva.od.unscented import sigma_points, through_impulses, unscented_weights
from visviva.satellites.burn_partials import impulse_jacobians
from visviva.satellites.burn_segments import burn_schedule


def _whitened(d, P):
    """Largest |L^-1 d| (P = L L^T): a difference in sigmas."""
    return float(np.abs(np.linalg.solve(np.linalg.cholesky(P), d)).max())


def _cov_apart(Pa, Pb):
    """Largest |L^-1 (Pa - Pb) L^-T|, Pb = L L^T (0.01: a 1 % change along some direction)."""
    L = np.linalg.cholesky(Pb)
    return float(np.abs(np.linalg.solve(L, np.linalg.solve(L, Pa - Pb).T)).max())


@pytest.mark.parametrize("finite", [False, True])
def test_ukf_equals_ekf_through_a_known_burn(finite):
    """Two-body position fixes, a 10 m / 1 cm/s prior, a 2 m/s RTN impulse or 5-minute RTN
    finite burn, with a 5 cm/s execution error: the UKF's filtered and smoothed states are the
    EKF's to 1e-4 sigma at every epoch (measured 1.0e-5 and 2.9e-5), its filtered covariances
    to 1e-5 (8.9e-7), smoothed ones to 1e-3 (1.2e-4) (the burn's local frame turns with each
    sigma point; its execution noise is averaged over them)."""
    c = np.diag([0.05, 0.05, 0.05]) ** 2 * 1e-6
    burn = (vv.FiniteBurn(FILTER_BURN_T, 300 * u.s, FILTER_DV, "RTN",
                          acceleration=np.linalg.norm(FILTER_DV) / 300 * u.km / u.s**2)
            if finite else
            vv.ImpulsiveBurn(FILTER_BURN_T, FILTER_DV * KMS, "RTN", delta_v_covariance=c))
    obs = _positions([burn], 3)
    guess = vv.StateVectors(TRUTH.r + [5, -3, 2] * u.m, TRUTH.v + [3, 0, -2] * u.mm / u.s,
                            vv.EARTH, epoch=EPOCH)
    prior = np.diag([1e-4] * 3 + [1e-10] * 3)
    kw = dict(maneuvers=[burn], smoother=True, editing_sigma=None)
    e = vv.filter_orbit(obs, guess, prior, **kw)
    f = vv.filter_orbit(obs, guess, prior, method="ukf", **kw)
    for k in range(len(f.times)):
        assert _whitened(f.states[k] - e.states[k], e.covariances[k]) < 1e-4
        assert _whitened(f.predicted_states[k] - e.predicted_states[k],
                         e.predicted_covariances[k]) < 1e-4
        assert _cov_apart(f.covariances[k], e.covariances[k]) < 1e-5
        assert _whitened(f.smoothed_states[k] - e.smoothed_states[k],
                         e.smoothed_covariances[k]) < 1e-4
        assert _cov_apart(f.smoothed_covariances[k], e.smoothed_covariances[k]) < 1e-3
    if not finite:  # the execution error is in: the predicted spread jumps at the burn
        k = int(np.searchsorted(f.offsets_s, FILTER_BURN_T.to_value(u.s)))
        assert f.predicted_covariances[k][3, 3] > f.covariances[k - 1][3, 3] + 0.5 * c[0, 0]
    # without the burn the unscented filter loses the orbit at it too
    with pytest.raises(vv.ConvergenceError, match="diverged"):
        vv.filter_orbit(obs, guess, prior, maneuvers=[], method="ukf")


def test_ukf_applies_a_burn_at_the_epoch_as_the_ekf():
    """An impulse (with a 10 cm/s execution error) at the initial epoch: applied to the state
    given (it is before the burn), its error added, as the EKF does it."""
    c = np.diag([0.1, 0.1, 0.1]) ** 2 * 1e-6
    burn = vv.ImpulsiveBurn(0 * u.s, FILTER_DV * KMS, "RTN", delta_v_covariance=c)
    obs = _positions([burn], 4)
    p0 = np.diag([1e-4] * 3 + [1e-10] * 3)
    e = vv.filter_orbit(obs, TRUTH, p0, maneuvers=[burn])
    f = vv.filter_orbit(obs, TRUTH, p0, maneuvers=[burn], method="ukf")
    ref = vv.propagate_covariance(TRUTH, p0, 0 * u.s, maneuvers=[burn])
    np.testing.assert_allclose(f.states[0][3:], ref.v.to_value(KMS), rtol=0, atol=1e-12)
    assert _cov_apart(f.covariances[0], ref.covariance) < 1e-6
    assert _whitened(f.states[-1] - e.states[-1], e.covariances[-1]) < 1e-3


# (the UKF's NEES through a burn with execution error: test_od_maneuvers.py,
# test_filter_with_execution_error_is_consistent_across_the_burn[ukf])


def test_sigma_points_fly_their_own_coefficients():
    """propagate_many with per-state factors on the drag slot: state i is the run with its own
    B (the same bits as a single run with that block); without them the same bits as before."""
    dyn = Dynamics(vv.EARTH.gm_km3_s2, _leo_forces(2.2), EPOCH, (0.0, 3600.0))
    y0 = np.r_[LEO.r.to_value(u.km), LEO.v.to_value(KMS)]
    Y0 = np.repeat(y0[None], 3, axis=0)
    b = np.array([1.0, 2.0, 3.0]) * AM
    base = dyn.model.force[fb.BALLISTIC]
    plain = dyn.propagate_many(Y0, np.array([3600.0]), threads=False)
    dyn.model.force[fb.BALLISTIC] = 1e-6  # a unit B (m^2/kg -> km^2/kg)
    each = dyn.propagate_many(Y0, np.array([3600.0]), threads=False,
                              per_state={fb.BALLISTIC: b})
    for i in range(3):
        dyn.model.force[fb.BALLISTIC] = 1e-6 * b[i]
        one = dyn.propagate_many(y0[None], np.array([3600.0]), threads=False)
        assert np.array_equal(each[i], one[0])
    dyn.model.force[fb.BALLISTIC] = base
    assert np.array_equal(dyn.propagate_many(Y0, np.array([3600.0]), threads=False), plain)
    # more drag, lower orbit: the runs differ by tens of metres after an hour
    assert np.linalg.norm(each[2, 0, :3] - each[0, 0, :3]) > 0.01


def _srp_forces(cr):
    return [vv.J2(vv.EARTH), vv.SolarRadiationPressure(0.02 * M2KG, reflectivity=cr,
                                                       shadow="cylindrical"),
            vv.ThirdBody(vv.SUN)]


@pytest.mark.parametrize("name", ["drag", "srp"])
def test_ukf_equals_ekf_with_a_coefficient_estimated(name):
    """Position fixes of a 350 km orbit over 6 h, B (truth Cd 2.6, prior at it +- 0.1 in Cd)
    or Cr (truth 1.3 +- 0.1, through the Earth's shadow) in the state: the UKF's states and
    coefficient are the EKF's to 5e-3 sigma at every epoch (measured 7.8e-4 for B), its (x, p)
    covariances to 1e-5 (2.9e-7), the smoothed coefficient to 3e-3 sigma (2.7e-4) and its
    sigma to 1e-6 (both linear in the coefficient; the differences are the sigma points'
    second-order terms in the state)."""
    if name == "drag":
        forces, truth = _leo_forces(2.6), _leo_forces(2.6)
        sigma, unit = {"drag": 0.1 * AM * M2KG}, M2KG
        obs = _leo_positions(2.6, seed=5)
    else:
        forces, truth = _srp_forces(1.3), _srp_forces(1.3)
        sigma, unit = {"srp": 0.1}, u.dimensionless_unscaled
        t = EPOCH + np.arange(0, 6 * 3600, 120) * u.s
        obs = vv.od.simulate_observations(LEO, t, "position", 0.01 * u.km, None, truth, seed=6)
    p0 = np.diag([0.01**2] * 3 + [1e-5**2] * 3)
    kw = dict(estimate=name, parameter_sigma=sigma, smoother=True)
    e = vv.filter_orbit(obs, LEO, p0, forces, **kw)
    f = vv.filter_orbit(obs, LEO, p0, forces, method="ukf", **kw)
    assert f.full_covariances.shape == (len(f.times), 7, 7)
    pe, pf = (u.Quantity(x.parameters[name]).to_value(unit) for x in (e, f))
    for k in range(len(f.times)):
        z_e = np.r_[e.states[k], pe[k]]
        z_f = np.r_[f.states[k], pf[k]]
        assert _whitened(z_f - z_e, e.full_covariances[k]) < 5e-3
        assert _cov_apart(f.full_covariances[k], e.full_covariances[k]) < 1e-5
    sp_e = u.Quantity(e.smoothed_parameter_sigma[name]).to_value(unit)
    sm_e = u.Quantity(e.smoothed_parameters[name]).to_value(unit)
    sm_f = u.Quantity(f.smoothed_parameters[name]).to_value(unit)
    assert np.abs(sm_f - sm_e).max() < 3e-3 * sp_e.min()
    np.testing.assert_allclose(u.Quantity(f.smoothed_parameter_sigma[name]).to_value(unit),
                               sp_e, rtol=1e-6)


def test_ukf_recovers_cd_from_a_wrong_prior():
    """From Cd 2.2 +- 0.5 (truth 2.6) and a 100 m / 10 cm/s prior the UKF ends at the truth's
    Cd within 3 sigma, its (x, B) NEES within chi-square(7)'s 99.9 % bound; with Cd held at 2.2
    it loses the orbit. The smoother's Cd at the start is the truth's within 3 sigma too."""
    obs = _leo_positions(2.6, seed=7, hours=12)
    p0 = np.diag([0.1**2] * 3 + [1e-4**2] * 3)
    guess = vv.StateVectors(LEO.r + [0.1, -0.1, 0.05] * u.km, LEO.v + [1e-4, 0, -1e-4] * KMS,
                            vv.EARTH, epoch=EPOCH)
    f = vv.filter_orbit(obs, guess, p0, _leo_forces(2.2), estimate="drag", method="ukf",
                        parameter_sigma={"drag": 0.5 * AM * M2KG}, smoother=True)
    b = f.parameters["drag"].to_value(M2KG)
    sb = f.parameter_sigma["drag"].to_value(M2KG)
    assert b[0] == 2.2 * AM and sb[0] == pytest.approx(0.5 * AM)
    assert abs(b[-1] - 2.6 * AM) < 3 * sb[-1] < 0.05 * AM
    sm = f.smoothed_parameters["drag"].to_value(M2KG)
    assert abs(sm[0] - 2.6 * AM) < 3 * f.smoothed_parameter_sigma["drag"].to_value(M2KG)[0]
    end = vv.propagate_cowell(LEO, f.state.epoch, _leo_forces(2.6), rtol=1e-13, atol=1e-13)
    err = np.r_[(f.state.r - end.r).to_value(u.km), (f.state.v - end.v).to_value(KMS),
                b[-1] - 2.6 * AM]
    assert err @ np.linalg.solve(f.full_covariances[-1], err) < stats.chi2.ppf(0.999, 7)
    drag = [p for p in f.perturbations if isinstance(p, vv.AtmosphericDrag)][0]
    assert drag.ballistic_coefficient_m2_kg == b[-1]
    with pytest.raises(vv.ConvergenceError, match="diverged"):
        vv.filter_orbit(obs, guess, p0, _leo_forces(2.2), method="ukf")


def test_ukf_estimates_cd_through_a_burn():
    """estimate= with maneuvers=: the UKF flies both (the truth's Cd found within 3 sigma
    across a 1 m/s impulse; the extended filter: tests/test_od_ekf_coefficients_burns.py)."""
    burn = vv.ImpulsiveBurn(3 * 3600 * u.s, [0.0, 0.001, 0.0] * KMS, "RTN")
    t = EPOCH + np.arange(0, 12 * 3600, 120) * u.s
    obs = vv.od.simulate_observations(LEO, t, "position", 0.01 * u.km, None, _leo_forces(2.6),
                                      maneuvers=[burn], seed=9)
    p0 = np.diag([0.01**2] * 3 + [1e-5**2] * 3)
    kw = dict(estimate="drag", parameter_sigma={"drag": 0.5 * AM * M2KG}, maneuvers=[burn])
    f = vv.filter_orbit(obs, LEO, p0, _leo_forces(2.2), method="ukf", **kw)
    b = f.parameters["drag"].to_value(M2KG)
    sb = f.parameter_sigma["drag"].to_value(M2KG)
    assert abs(b[-1] - 2.6 * AM) < 3 * sb[-1] < 0.05 * AM
    assert not f.rejected.any()


@given(st.integers(6, 8), st.floats(0.3, 2.0), st.integers(0, 2**32 - 1))
@settings(max_examples=30, deadline=None)
def test_sigma_points_of_an_augmented_state_keep_mean_and_covariance(n, alpha, seed):
    """With k = n - 6 coefficients the 2n + 1 points and weights still stand for (x, P)."""
    scale, wm, wc = unscented_weights((alpha, 2.0, 0.0), n)
    assert wm.shape == (2 * n + 1,) and wm.sum() == pytest.approx(1.0, abs=1e-12)
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n)) * np.r_[[1.0] * 3, [1e-3] * 3, [1e-4] * (n - 6)]
    x = np.r_[7000.0, 10.0, -20.0, 0.1, 7.5, 0.3, [0.02] * (n - 6)]
    X = sigma_points(x, A @ A.T, scale)
    np.testing.assert_allclose(x + wm @ (X - x), x, rtol=0, atol=1e-12)
    np.testing.assert_allclose((wc * (X - x).T) @ (X - x), A @ A.T, rtol=0,
                               atol=1e-9 * np.abs(A @ A.T).max())


@given(st.sampled_from(["RTN", "TNW", "VNB", "GCRS"]), st.integers(0, 2**32 - 1))
@settings(max_examples=30, deadline=None)
def test_an_impulse_on_sigma_points_moves_each_on_its_own_axes(frame, seed):
    """Every point gets the Δv on its own local axes (the burn's delta_v_inertial at its r, v);
    the noise added is sum W_i G_i C G_i^T, which for points that coincide is the EKF's
    G C G^T at the state (impulse_jacobians)."""
    rng = np.random.default_rng(seed)
    dv = rng.normal(0.0, 1e-3, 3)
    a = rng.standard_normal((3, 3)) * 1e-5
    c = a @ a.T
    burn = vv.ImpulsiveBurn(0 * u.s, dv * KMS, frame, delta_v_covariance=c)
    schedule = burn_schedule([burn], TRUTH, EPOCH)
    x = Y_TRUE + rng.normal(0.0, [1.0] * 3 + [1e-3] * 3)
    scale, wm, _ = unscented_weights()
    X = sigma_points(x, np.diag([1.0] * 3 + [1e-6] * 3), scale)
    Y, noise = through_impulses(schedule, 0.0, X, wm)
    for i in range(X.shape[0]):
        want = X[i, 3:] + burn.delta_v_inertial(X[i, :3], X[i, 3:])
        np.testing.assert_allclose(Y[i, 3:], want, rtol=0, atol=1e-15)
    assert np.array_equal(Y[:, :3], X[:, :3]) and np.all(noise[:3] == 0)
    same = np.repeat(x[None], X.shape[0], axis=0)
    _, one = through_impulses(schedule, 0.0, same, wm)
    g = impulse_jacobians(burn, x)[1]
    np.testing.assert_allclose(one, g @ c @ g.T, rtol=1e-12, atol=1e-30)
    # the points' own frames: the average differs from the central point's by their spread
    assert np.allclose(noise, one, rtol=0.05, atol=1e-3 * np.abs(one).max())
