"""Orbit determination through manoeuvres at the edges of what users give: the same burn object
listed twice (flown twice, as propagate_cowell does), and an estimated burn whose only later
observation is a position fix at the burn's own time (which its Δv does not move)."""

from __future__ import annotations

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv
from visviva.od import simulate_observations

EPOCH = Time("2024-03-01T00:00:00", scale="utc")
KMS = u.km / u.s
TRUTH = vv.StateVectors([6800.0, 100.0, 300.0] * u.km, [-0.1, 5.0, 5.7] * KMS, vv.EARTH,
                        epoch=EPOCH)
TIMES = EPOCH + np.arange(0, 4 * 3600, 120) * u.s


def _burn(dv_m_s=(0.5, 1.5, -1.0)):
    return vv.ImpulsiveBurn(EPOCH + 1 * u.h, list(dv_m_s) * u.m / u.s, "RTN")


def test_the_same_burn_object_twice_is_flown_twice_as_two_equal_burns():
    # one object listed twice raised numpy's broadcast ValueError in the STM walk
    burn = _burn()
    same = [burn, burn]
    equal = [burn, _burn()]
    t = EPOCH + [0.5, 2.0, 3.0] * u.h
    a = vv.propagate_covariance(TRUTH, np.eye(6) * 1e-6, t, [], maneuvers=same)
    b = vv.propagate_covariance(TRUTH, np.eye(6) * 1e-6, t, [], maneuvers=equal)
    ref = vv.propagate_cowell(TRUTH, t, [], maneuvers=same)
    assert np.array_equal(a.r.value, b.r.value) and np.array_equal(a.covariance, b.covariance)
    assert np.abs((a.r - ref.r).to_value(u.m)).max() < 1e-3
    once = vv.propagate_cowell(TRUTH, t, [], maneuvers=[burn])
    assert np.abs((a.r - once.r).to_value(u.km)).max() > 1.0  # flown twice, not once
    obs_same = simulate_observations(TRUTH, TIMES, "position", 10 * u.m, maneuvers=same, seed=2)
    obs_equal = simulate_observations(TRUTH, TIMES, "position", 10 * u.m, maneuvers=equal,
                                      seed=2)
    assert np.array_equal(obs_same.values, obs_equal.values)
    # a fit with the object twice, the second occurrence's Δv estimated from zero
    plan = _burn((0.0, 0.0, 0.0))
    fit = vv.fit_orbit(obs_same, TRUTH, maneuvers=[burn, burn], estimate_maneuvers=[1])
    ref_fit = vv.fit_orbit(obs_same, TRUTH, maneuvers=[burn, plan], estimate_maneuvers=[1])
    sigma = fit.delta_v_sigma.to_value(KMS)
    assert np.abs(fit.delta_v.to_value(KMS) - ref_fit.delta_v.to_value(KMS)).max() < 1e-3 * sigma.min()
    assert np.all(np.abs(fit.delta_v.to_value(KMS) - [0.0005, 0.0015, -0.001]) < 4 * sigma)
    assert burn.delta_v_km_s.tolist() == [0.0005, 0.0015, -0.001]  # the input untouched


def test_a_position_fix_at_the_burn_time_is_no_information_on_its_delta_v():
    # the last fix at the burn's epoch: d r / d Δv = 0 there; the fit's check looked at the
    # state's partials (non-zero velocity rows) and the SVD then refused with "no information
    # on some state component", which names neither the burn nor what to do
    t_burn = TIMES[-1]
    flown = vv.ImpulsiveBurn(t_burn, [0.5, 1.5, -1.0] * u.m / u.s, "RTN")
    obs = simulate_observations(TRUTH, TIMES, "position", 10 * u.m, maneuvers=[flown], seed=2)
    plan = vv.ImpulsiveBurn(t_burn, [0, 0, 0] * KMS, "RTN")
    with pytest.raises(vv.InvalidInputError, match=r"maneuvers\[0\].*no observation after it"):
        vv.fit_orbit(obs, TRUTH, maneuvers=[plan], estimate_maneuvers=True)


DV_PLAN = np.array([0.5, 1.5, -1.0]) * 1e-3  # RTN, km/s
EXEC_COV = np.eye(3) * 0.05e-3**2  # 5 cm/s per axis, km^2/s^2
Y_TRUE = np.r_[TRUTH.r.to_value(u.km), TRUTH.v.to_value(KMS)]


def _planned():
    return vv.ImpulsiveBurn(EPOCH + 1 * u.h, DV_PLAN * KMS, "RTN", delta_v_covariance=EXEC_COV)


def test_a_known_burns_execution_error_is_in_the_fit_covariance():
    # fit_orbit flew a known burn's plan as exact: over 6 truths whose Δv was drawn from its
    # execution covariance the fit's NEES averaged 2.6e5 (expect 6), 90 at the end of the arc
    rng = np.random.default_rng(1)
    nees, nees_end = [], []
    for seed in range(6):
        dv = DV_PLAN + rng.multivariate_normal(np.zeros(3), EXEC_COV)
        flown = vv.ImpulsiveBurn(EPOCH + 1 * u.h, dv * KMS, "RTN")
        obs = simulate_observations(TRUTH, TIMES, "position", 10 * u.m, maneuvers=[flown],
                                    seed=seed)
        fit = vv.fit_orbit(obs, TRUTH, maneuvers=[_planned()])
        assert fit.considered_maneuvers == [0]
        e = np.r_[fit.state.r.to_value(u.km), fit.state.v.to_value(KMS)] - Y_TRUE
        nees.append(e @ np.linalg.solve(fit.covariance, e))
        end = EPOCH + 4 * u.h
        p = fit.propagate(end)
        truth = vv.propagate_cowell(TRUTH, end, [], maneuvers=[flown])
        e = np.r_[(p.r - truth.r).to_value(u.km), (p.v - truth.v).to_value(KMS)]
        nees_end.append(e @ np.linalg.solve(np.asarray(p.covariance).reshape(6, 6), e))
    # the sum of 6 NEES is chi-square(36): 99.9 % within [15.3, 67.9]
    assert 15.3 / 6 < np.mean(nees) < 67.9 / 6
    assert 15.3 / 6 < np.mean(nees_end) < 67.9 / 6
    assert np.all(np.linalg.eigvalsh(fit.covariance - fit.noise_covariance) > -1e-18)


def test_the_fit_sensitivity_to_a_known_burn_equals_differenced_fits():
    # S_b = d x_hat / d Δv against fits of noise-free data of truths flying Δv_plan +- h
    h = 1e-6  # km/s
    fits = []
    for sign in (1.0, -1.0):
        dv = DV_PLAN + sign * np.array([h, 0.0, 0.0])
        flown = vv.ImpulsiveBurn(EPOCH + 1 * u.h, dv * KMS, "RTN")
        obs = simulate_observations(TRUTH, TIMES, "position", 10 * u.m, maneuvers=[flown],
                                    seed=False)
        fits.append(vv.fit_orbit(obs, TRUTH, maneuvers=[_planned()], tol=1e-12))
    diff = np.r_[(fits[0].state.r - fits[1].state.r).to_value(u.km),
                 (fits[0].state.v - fits[1].state.v).to_value(KMS)] / (2 * h)
    # S_b is d x_hat / d (the fit's Δv); a truth flying plan + δ fitted with the plan is the
    # fit's Δv off by -δ: x_hat - x_true = -S_b δ
    s_b = fits[0].maneuver_consider_sensitivity[:, 0]
    assert np.abs(diff + s_b).max() < 1e-4 * np.abs(s_b).max()


def test_consider_with_an_estimated_planned_burn():
    # consider= with an estimated burn that has an a priori (execution covariance) raised
    # numpy's matmul shape error: the consider partials were padded to the coefficients' a
    # priori rows only, not to the plan's three rows
    am = 0.01 * u.m**2 / u.kg
    leo = vv.StateVectors([6728.0, 0.0, 0.0] * u.km, [0.0, 4.80, 6.06] * KMS, vv.EARTH,
                          epoch=EPOCH)
    forces = [vv.AtmosphericDrag(2.2 * am)]
    flown = vv.ImpulsiveBurn(EPOCH + 1 * u.h, DV_PLAN * KMS, "RTN")
    obs = simulate_observations(leo, TIMES[:60], "position", 10 * u.m, None, forces,
                                maneuvers=[flown], seed=4)
    fit = vv.fit_orbit(obs, leo, forces, maneuvers=[_planned()], estimate_maneuvers=True,
                       consider={"drag": 0.3 * am})
    plain = vv.fit_orbit(obs, leo, forces, maneuvers=[_planned()], estimate_maneuvers=True)
    assert np.allclose(fit.noise_covariance, plain.covariance, rtol=1e-9, atol=0)
    assert np.all(np.diag(fit.covariance) >= np.diag(plain.covariance))
    sigma = fit.delta_v_sigma.to_value(KMS)
    assert np.all(np.abs(fit.delta_v.to_value(KMS) - DV_PLAN) < 4 * sigma)


def test_an_opm_from_a_fit_takes_its_state_covariance_in_the_right_units():
    # OPM.from_state wrote np.asarray(covariance): an m^2 Quantity (a CDM's) went out as km^2
    # (10^6 too large), a fit's full_covariance (state and Δv) was cut to its corner silently
    flown = _burn()
    obs = simulate_observations(TRUTH, TIMES, "position", 10 * u.m, maneuvers=[flown], seed=3)
    fit = vv.fit_orbit(obs, TRUTH, maneuvers=[_burn((0.0, 0.0, 0.0))], estimate_maneuvers=True)
    km = vv.ccsds.OPM.from_state(fit.state, object_name="X", covariance=fit.covariance)
    assert np.allclose(km.covariance, fit.covariance, rtol=1e-12, atol=0)
    metres = np.asarray(fit.covariance) * 1e6 * u.m**2
    m2 = vv.ccsds.OPM.from_state(fit.state, object_name="X", covariance=metres)
    assert np.allclose(m2.covariance, fit.covariance, rtol=1e-12, atol=0)
    with pytest.raises(vv.ShapeError, match="fit.covariance"):
        vv.ccsds.OPM.from_state(fit.state, object_name="X", covariance=fit.full_covariance)
    with pytest.raises(vv.UnitsError):
        vv.ccsds.OPM.from_state(fit.state, object_name="X", covariance=metres.value * u.m)


def test_inseparable_delta_vs_are_refused_by_name():
    # a burn at the epoch with no data before it, or two burns at one time: the SVD refused
    # with "the observations do not determine the orbit ... add observations of other kinds",
    # which names neither the burns nor the remedy
    at_epoch = vv.ImpulsiveBurn(EPOCH, DV_PLAN * KMS, "RTN")
    obs = simulate_observations(TRUTH, TIMES, "position", 10 * u.m, maneuvers=[at_epoch],
                                seed=2)
    zero = vv.ImpulsiveBurn(EPOCH, [0, 0, 0] * KMS, "RTN")
    with pytest.raises(vv.InvalidInputError, match=r"maneuvers\[0\].*epoch.*one unknown"):
        vv.fit_orbit(obs, TRUTH, maneuvers=[zero], estimate_maneuvers=True)
    two = [_burn((0.5, 0.0, 0.0)), _burn((0.0, 1.5, 0.0))]
    obs = simulate_observations(TRUTH, TIMES, "position", 10 * u.m, maneuvers=two, seed=2)
    plans = [_burn((0.0, 0.0, 0.0)), _burn((0.0, 0.0, 0.0))]
    with pytest.raises(vv.InvalidInputError, match=r"maneuvers\[0\] and maneuvers\[1\]"):
        vv.fit_orbit(obs, TRUTH, maneuvers=plans, estimate_maneuvers=True)
    # with execution errors as a priori the two are separated by their plans
    planned = [vv.ImpulsiveBurn(EPOCH + 1 * u.h, [0.5, 0.0, 0.0] * u.m / u.s, "RTN",
                                delta_v_covariance=EXEC_COV),
               vv.ImpulsiveBurn(EPOCH + 1 * u.h, [0.0, 1.5, 0.0] * u.m / u.s, "RTN",
                                delta_v_covariance=EXEC_COV)]
    fit = vv.fit_orbit(obs, TRUTH, maneuvers=planned, estimate_maneuvers=True)
    total = fit.delta_v.to_value(KMS).sum(axis=0)
    assert np.abs(total - [0.0005, 0.0015, 0.0]).max() < 2e-5  # the sum is what the data see


def test_a_nan_execution_covariance_is_named_as_nan():
    # the message said "must be a finite 3 x 3 matrix; got shape (3, 3)"
    with pytest.raises(vv.InvalidInputError, match="NaN or infinite"):
        vv.ImpulsiveBurn(EPOCH, DV_PLAN * KMS, "RTN",
                         delta_v_covariance=np.diag([np.nan, 1e-10, 1e-10]))
    with pytest.raises(vv.InvalidInputError, match=r"got shape \(2, 2\)"):
        vv.ImpulsiveBurn(EPOCH, DV_PLAN * KMS, "RTN", delta_v_covariance=np.eye(2) * 1e-10)


@pytest.mark.parametrize("bad", [[0.9], [True], [np.float64(1.0)], 1, "0", [[0]]])
def test_estimate_maneuvers_takes_integer_indices_only(bad):
    # [0.9] was int()-ed to 0 and [True] to 1 (another burn's Δv estimated in silence)
    two = [_burn(), vv.ImpulsiveBurn(EPOCH + 2 * u.h, DV_PLAN * KMS, "RTN")]
    obs = simulate_observations(TRUTH, TIMES, "position", 10 * u.m, maneuvers=two, seed=2)
    with pytest.raises(vv.InvalidInputError, match="integer indices"):
        vv.fit_orbit(obs, TRUTH, maneuvers=two, estimate_maneuvers=bad)
    fit = vv.fit_orbit(obs, TRUTH, maneuvers=two, estimate_maneuvers=np.array([1]))
    assert fit.estimated_maneuvers == [1]


def test_the_smoother_reports_the_smoothed_coefficients():
    # the smoother smoothed the coefficients with the state but dropped them: no output held
    # them. A constant without process noise smooths to its last filtered value everywhere.
    am = 0.01 * u.m**2 / u.kg
    leo = vv.StateVectors([6728.0, 0.0, 0.0] * u.km, [0.0, 4.80, 6.06] * KMS, vv.EARTH,
                          epoch=EPOCH)
    obs = simulate_observations(leo, TIMES[:60], "position", 10 * u.m, None,
                                [vv.AtmosphericDrag(2.6 * am)], seed=7)
    flt = vv.filter_orbit(obs, leo, np.diag([1e-4] * 3 + [1e-10] * 3),
                          [vv.AtmosphericDrag(2.2 * am)], estimate="drag",
                          parameter_sigma={"drag": 0.5 * am}, smoother=True)
    b = flt.smoothed_parameters["drag"].to_value(u.m**2 / u.kg)
    sigma = flt.smoothed_parameter_sigma["drag"].to_value(u.m**2 / u.kg)
    last = flt.parameters["drag"][-1].to_value(u.m**2 / u.kg)
    assert b.shape == (len(flt.times),)
    assert np.abs(b - last).max() < 1e-3 * sigma[-1]
    assert np.allclose(sigma, flt.parameter_sigma["drag"][-1].to_value(u.m**2 / u.kg),
                       rtol=1e-3)
    assert abs(b[0] / 0.01 - 2.6) < 4 * sigma[0] / 0.01
    plain = vv.filter_orbit(obs, leo, np.diag([1e-4] * 3 + [1e-10] * 3),
                            [vv.AtmosphericDrag(2.6 * am)])
    assert plain.smoothed_parameters is None
