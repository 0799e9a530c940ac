"""The extended filter (vv.filter_orbit, method="ekf") with estimated drag/SRP coefficients
through known burns: the augmented transition's coefficient columns S = d x / d p through an
impulse and a finite burn against central differences of the propagation, the filter equal to
the unscented one on a nearly linear problem, and Cd recovered from a wrong prior across a burn
(the combination was refused before the twelfth session)."""

import numpy as np
import pytest
from astropy import units as u

import visviva as vv
from test_od_parameters import AM, LEO, M2KG, _leo_forces
from test_od_unscented_maneuvers import _cov_apart, _whitened
from visviva.od.coefficient_prediction import predict_coefficients
from visviva.od.dynamics import Dynamics
from visviva.satellites.burn_segments import burn_schedule
from visviva.satellites.force_parameters import coefficients

KMS = u.km / u.s
EPOCH = LEO.epoch
X0 = np.r_[LEO.r.to_value(u.km), LEO.v.to_value(KMS)]


def _burns(kind):
    c = np.diag([0.02, 0.02, 0.02]) ** 2 * 1e-6  # 2 cm/s per axis, (km/s)^2
    if kind == "impulse":
        return [vv.ImpulsiveBurn(3000 * u.s, [0.0, 0.002, 0.0005] * KMS, "RTN",
                                 delta_v_covariance=c)]
    return [vv.FiniteBurn(2900 * u.s, 300 * u.s, [0.0002, 0.002, 0.0], "RTN",
                          acceleration=0.002 / 300 * u.km / u.s**2)]


#: the state at the prediction's start (600 s; every burn is later), the same for every B
T_FROM = 600.0
Y_FROM = vv.propagate_cowell(LEO, EPOCH + T_FROM * u.s, _leo_forces(2.6), rtol=1e-13,
                             atol=1e-13)


def _predict(burns, b, t_from=T_FROM, dt=5400.0):
    """(z, P, Phi_z) of one prediction of (x, B) from ``t_from`` over ``dt`` s."""
    forces = _leo_forces(b / AM)
    dyn = Dynamics(vv.EARTH.gm_km3_s2, forces, EPOCH, (0.0, t_from + dt))
    est, _ = coefficients(forces, "drag", {"drag": 0.1 * AM * M2KG}, None)
    schedule = burn_schedule(burns, LEO, EPOCH)
    schedule.snap(np.array([0.0, t_from, t_from + dt]))
    z = np.r_[Y_FROM.r.to_value(u.km), Y_FROM.v.to_value(KMS), b]
    P = np.diag([1e-6] * 3 + [1e-12] * 3 + [(0.1 * AM) ** 2])
    return predict_coefficients(dyn, schedule, z, P, t_from, np.array([dt]), None, 0, est)


@pytest.mark.parametrize("kind", ["impulse", "finite"])
def test_the_coefficient_columns_through_a_burn_are_the_propagation_s_derivative(kind):
    """d x(t) / d B across a 2 m/s RTN impulse or a 5-minute finite burn (5400 s of 350 km
    drag): the transition's column equals the central difference of the predicted state in B
    (step 1e-3 of B) to 1e-5 relative (measured 1.1e-7 / 5.4e-8; the difference's own
    truncation and the integrator's tolerance set the floor); the burn changes the column by
    0.7 %."""
    burns = _burns(kind)
    b = 2.6 * AM
    z, P, phi = _predict(burns, b)
    h = 1e-3 * b
    zp = _predict(burns, b + h)[0]
    zm = _predict(burns, b - h)[0]
    fd = (zp[:6] - zm[:6]) / (2 * h)
    col = phi[:6, 6]
    assert np.linalg.norm(col - fd) < 1e-5 * np.linalg.norm(fd)
    assert np.linalg.norm(fd[:3]) > 1.0  # km per m^2/kg: drag moves the orbit visibly
    # the burn is crossed: without it the column is not the same
    assert np.linalg.norm(col - _predict([], b)[2][:6, 6]) > 1e-3 * np.linalg.norm(col)
    if kind == "impulse":  # the execution error is in the predicted covariance
        assert P[3:6, 3:6].trace() > _predict([], b)[1][3:6, 3:6].trace() + 0.5 * 3 * 0.02e-3**2


@pytest.mark.parametrize("kind", ["impulse", "finite"])
def test_ekf_equals_ukf_with_cd_estimated_through_a_burn(kind):
    """Position fixes every 2 min for 4 h at 350 km, a burn at 50 min, B in the state (prior at
    the truth's Cd 2.6 +- 0.1): the two filters agree at every epoch to 5e-3 sigma in (x, B)
    (measured 4.9e-4 / 5.7e-4) and 1e-5 in their covariances (6e-8 / 1e-7) (the EKF's coefficient columns cross the burn with its
    Jacobians; each sigma point flies its own B through it)."""
    burns = _burns(kind)
    t = EPOCH + np.arange(0, 4 * 3600, 120) * u.s
    obs = vv.od.simulate_observations(LEO, t, "position", 0.01 * u.km, None, _leo_forces(2.6),
                                      maneuvers=burns, seed=21)
    p0 = np.diag([0.01**2] * 3 + [1e-5**2] * 3)
    kw = dict(estimate="drag", parameter_sigma={"drag": 0.1 * AM * M2KG}, maneuvers=burns)
    e = vv.filter_orbit(obs, LEO, p0, _leo_forces(2.6), **kw)
    f = vv.filter_orbit(obs, LEO, p0, _leo_forces(2.6), method="ukf", **kw)
    pe, pf = (x.parameters["drag"].to_value(M2KG) for x in (e, f))
    for k in range(len(e.times)):
        d = np.r_[f.states[k] - e.states[k], pf[k] - pe[k]]
        assert _whitened(d, e.full_covariances[k]) < 5e-3
        assert _cov_apart(f.full_covariances[k], e.full_covariances[k]) < 1e-5
    assert not e.rejected.any()


def test_ekf_recovers_cd_from_a_wrong_prior_across_a_burn():
    """From Cd 2.2 +- 0.5 (truth 2.6) across a 1 m/s RTN impulse at 3 h (12 h of 10 m fixes),
    the extended filter ends within 3 sigma of the truth's B, that sigma under 5 % of B; with
    Cd held at 2.2 it loses the orbit."""
    burn = vv.ImpulsiveBurn(3 * 3600 * u.s, [0.0, 0.001, 0.0] * KMS, "RTN")
    t = EPOCH + np.arange(0, 12 * 3600, 120) * u.s
    obs = vv.od.simulate_observations(LEO, t, "position", 0.01 * u.km, None, _leo_forces(2.6),
                                      maneuvers=[burn], seed=9)
    p0 = np.diag([0.01**2] * 3 + [1e-5**2] * 3)
    f = vv.filter_orbit(obs, LEO, p0, _leo_forces(2.2), estimate="drag", maneuvers=[burn],
                        parameter_sigma={"drag": 0.5 * AM * M2KG}, smoother=True)
    b = f.parameters["drag"].to_value(M2KG)
    sb = f.parameter_sigma["drag"].to_value(M2KG)
    assert abs(b[-1] - 2.6 * AM) < 3 * sb[-1] < 0.05 * AM
    assert not f.rejected.any()
    sm = f.smoothed_parameters["drag"].to_value(M2KG)
    assert abs(sm[0] - 2.6 * AM) < 3 * f.smoothed_parameter_sigma["drag"].to_value(M2KG)[0]
    with pytest.raises(vv.ConvergenceError, match="diverged"):
        vv.filter_orbit(obs, LEO, p0, _leo_forces(2.2), maneuvers=[burn])
