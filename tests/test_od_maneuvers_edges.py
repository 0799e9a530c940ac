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
