"""Drag and SRP coefficients in orbit determination: their sensitivities in the variational
equations (against finite differences of propagate_cowell), their estimation by fit_orbit
(estimate=, parameter_sigma=) and their consider covariance (consider=, against a Monte Carlo
over the coefficient)."""

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from scipy import stats

import visviva as vv
from visviva.errors import InvalidInputError, UnitsError
from visviva.od import simulate_observations
from visviva.od.dynamics import Dynamics

EPOCH = Time("2024-03-01T00:00:00", scale="utc")
KMS = u.km / u.s
M2KG = u.m**2 / u.kg
AM = 0.01  # area-to-mass of the LEO satellite, m^2/kg: B = Cd AM
R_LEO = 6378.137 + 350.0
_V = np.sqrt(vv.EARTH.gm_km3_s2 / R_LEO)
_INC = np.radians(51.6)
LEO = vv.StateVectors([R_LEO, 0.0, 0.0] * u.km, [0.0, _V * np.cos(_INC), _V * np.sin(_INC)] * KMS,
                      vv.EARTH, epoch=EPOCH)
LEO_GUESS = vv.StateVectors(LEO.r + [0.5, -0.3, 0.2] * u.km, LEO.v + [1e-4, 0, -1e-4] * KMS,
                            vv.EARTH, epoch=EPOCH)
STATIONS = [vv.GroundStation(40 * u.deg, -105 * u.deg, 1.6 * u.km),
            vv.GroundStation(-30 * u.deg, 20 * u.deg, 0.3 * u.km),
            vv.GroundStation(15 * u.deg, 150 * u.deg, 0.0 * u.km),
            vv.GroundStation(60 * u.deg, 10 * u.deg, 0.0 * u.km)]


def _leo_forces(cd):
    return [vv.J2(vv.EARTH), vv.AtmosphericDrag(cd * AM * M2KG)]


def _y(state):
    return np.r_[state.r.to_value(u.km), state.v.to_value(KMS)]


def _forces_srp(bc, cr, shadow):
    return [vv.J2(vv.EARTH), vv.AtmosphericDrag(bc * M2KG),
            vv.SolarRadiationPressure(0.02 * M2KG, reflectivity=cr, shadow=shadow),
            vv.ThirdBody(vv.SUN)]


@pytest.mark.parametrize("shadow", ["cylindrical", "conical"])
def test_sensitivities_match_finite_differences_of_propagate_cowell(shadow):
    """d y / d B and d y / d Cr over a LEO day (drag bands, shadow boundaries) against central
    differences of propagate_cowell runs with perturbed coefficients."""
    y0 = np.array([6728.0, 10.0, 20.0, -0.01, 4.9, 5.9])
    t = np.linspace(0, 86400, 40)
    dyn = Dynamics(vv.EARTH.gm_km3_s2, _forces_srp(0.026, 1.3, shadow), EPOCH, (0, 86400))
    dyn.propagate(y0, t, parameters=True)
    s = dyn.parameter_partials  # per km^2/kg and per km/s^2
    state = vv.StateVectors(y0[:3] * u.km, y0[3:] * KMS, vv.EARTH, epoch=EPOCH)

    def run(bc, cr):
        r = vv.propagate_cowell(state, t * u.s, _forces_srp(bc, cr, shadow), rtol=1e-13,
                                atol=1e-13)
        return np.c_[r.r.to_value(u.km), r.v.to_value(KMS)]

    h = 1e-5 * 0.026  # 1e-5 relative (1e-6 left 1.2e-5 of rounding noise: 2.6e-7 measured)
    fd = (run(0.026 + h, 1.3) - run(0.026 - h, 1.3)) / (2 * h * 1e-6)
    assert np.abs(s[-1, :3, 0]).max() * 0.026e-6 > 0.1  # drag moves the LEO by > 100 m a day
    np.testing.assert_allclose(s[..., 0], fd, rtol=0, atol=1e-5 * np.abs(s[..., 0]).max())
    # SRP moves the position by ~30 m a day: a step of 1e-6 in Cr (3e-5 mm) drowns in the
    # integration's rounding, so 1e-2 (linear force: the central difference is exact but for it)
    h = 1e-2 * 1.3
    fd = (run(0.026, 1.3 + h) - run(0.026, 1.3 - h)) / (2 * h)
    unit = vv.SolarRadiationPressure(0.02 * M2KG, reflectivity=1.0).coefficient_km_s2
    np.testing.assert_allclose(s[..., 1] * unit, fd, rtol=0,
                               atol=5e-5 * np.abs(s[..., 1] * unit).max())


def test_sensitivities_leave_state_and_stm_bitwise_and_exist_at_zero_coefficient():
    """The parameter columns change nothing in the state or the STM (the same steps, the same
    bits); with Cr = 0 the SRP column is that of a unit coefficient (not zero)."""
    y0 = np.array([6728.0, 10.0, 20.0, -0.01, 4.9, 5.9])
    t = np.linspace(0, 20000, 15)
    forces = _forces_srp(0.026, 0.0, "cylindrical")
    plain = Dynamics(vv.EARTH.gm_km3_s2, forces, EPOCH, (0, 20000))
    y, phi = plain.propagate(y0, t)
    aug = Dynamics(vv.EARTH.gm_km3_s2, forces, EPOCH, (0, 20000))
    y2, phi2 = aug.propagate(y0, t, parameters=True)
    assert np.array_equal(y, y2) and np.array_equal(phi, phi2)
    assert aug.n_steps == plain.n_steps
    assert np.abs(aug.parameter_partials[-1, :3, 1]).max() > 0
    # two-body: both columns vanish
    tb = Dynamics(vv.EARTH.gm_km3_s2, None, EPOCH, (0, 20000))
    tb.propagate(y0, t, parameters=True)
    assert not np.any(tb.parameter_partials)


@pytest.fixture(scope="module")
def leo_tracking():
    """1.5 days of range, range rate and az/el from four stations, truth Cd = 2.6."""
    grid = EPOCH + np.arange(0, 1.5 * 86400, 60) * u.s
    return vv.od.simulate_tracking(LEO, STATIONS, grid, _leo_forces(2.6), seed=1)


def test_fit_estimates_drag_coefficient(leo_tracking):
    """From Cd = 2.2 the fit finds the truth's 2.6 within 3 sigma; its dynamics fly it."""
    fit = vv.fit_orbit(leo_tracking, LEO_GUESS, _leo_forces(2.2), estimate="drag")
    b = fit.parameters["drag"].to_value(M2KG)
    sb = fit.parameter_sigma["drag"].to_value(M2KG)
    assert abs(b - 2.6 * AM) < 3 * sb
    assert sb < 0.01 * AM  # Cd to better than 0.01 from 1.5 days at 350 km
    assert 0.8 < fit.rms < 1.2
    assert fit.full_covariance.shape == (7, 7)
    assert fit.parameter_covariance.shape == (1, 1)
    assert fit.dof == int((~fit.rejected[:, None] & (np.arange(3) < leo_tracking.dims[:, None]))
                          .sum()) - 7
    drag = [p for p in fit.perturbations if isinstance(p, vv.AtmosphericDrag)][0]
    assert drag._bc_m2_kg == b
    # the estimate flies its coefficient: propagate_cowell of the result stays with the truth
    t = np.linspace(0, 1.5 * 86400, 10) * u.s
    got = vv.propagate_cowell(fit.state, t, fit.perturbations)
    ref = vv.propagate_cowell(LEO, t, _leo_forces(2.6))
    assert np.abs(got.r - ref.r).to_value(u.km).max() < 0.01
    held = vv.propagate_cowell(fit.state, t, _leo_forces(2.2))
    assert np.abs(held.r - ref.r).to_value(u.km).max() > 1.0


def test_fit_drag_nees_of_state_and_coefficient_over_seeds():
    """(x, B) - truth normalised by the full covariance follows chi-square(7) (8 seeds)."""
    grid = EPOCH + np.arange(0, 86400, 60) * u.s
    truth = np.r_[_y(LEO), 2.6 * AM]
    nees = []
    for seed in range(8):
        obs = vv.od.simulate_tracking(LEO, STATIONS[:3], grid, _leo_forces(2.6), seed=100 + seed)
        fit = vv.fit_orbit(obs, LEO_GUESS, _leo_forces(2.2), estimate=["drag"])
        e = np.r_[_y(fit.state), fit.parameters["drag"].to_value(M2KG)] - truth
        nees.append(float(e @ np.linalg.solve(fit.full_covariance, e)))
    total = sum(nees)
    assert stats.chi2.ppf(0.001, 56) < total < stats.chi2.ppf(0.999, 56), nees


def test_fit_estimates_srp_coefficient_of_high_area_to_mass_geo():
    """A GEO of A/m = 0.05 m^2/kg tracked for 2 days: Cr 1.5 found from 1.2 within 3 sigma."""
    r = 42164.0
    v = np.sqrt(vv.EARTH.gm_km3_s2 / r)
    truth = vv.StateVectors([r, 0, 0] * u.km, [0, v * np.cos(0.01), v * np.sin(0.01)] * KMS,
                            vv.EARTH, epoch=EPOCH)
    guess = vv.StateVectors(truth.r + [0.5, -0.3, 0.2] * u.km,
                            truth.v + [1e-5, 0, -1e-5] * KMS, vv.EARTH, epoch=EPOCH)

    def forces(cr):
        return [vv.J2(vv.EARTH), vv.ThirdBody(vv.SUN), vv.ThirdBody(vv.MOON),
                vv.SolarRadiationPressure(0.05 * M2KG, reflectivity=cr)]

    stations = [vv.GroundStation(20 * u.deg, lon * u.deg, 0 * u.km) for lon in (0, 120, 240)]
    obs = vv.od.simulate_tracking(truth, stations, EPOCH + np.arange(0, 2 * 86400, 600) * u.s,
                                  forces(1.5), seed=2)
    fit = vv.fit_orbit(obs, guess, forces(1.2), estimate="srp")
    cr, s = fit.parameters["srp"], fit.parameter_sigma["srp"]
    assert abs(cr - 1.5) < 3 * s and s < 0.02
    srp = [p for p in fit.perturbations if isinstance(p, vv.SolarRadiationPressure)][0]
    assert srp._cr == cr
    e = np.r_[_y(fit.state), cr] - np.r_[_y(truth), 1.5]
    assert e @ np.linalg.solve(fit.full_covariance, e) < stats.chi2.ppf(0.999, 7)


def _leo_positions(truth_cd, seed, hours=6.0, sigma=0.01):
    t = EPOCH + np.arange(0, hours * 3600, 120) * u.s
    return simulate_observations(LEO, t, "position", sigma * u.km, None, _leo_forces(truth_cd),
                                 seed=seed)


def test_parameter_sigma_is_an_a_priori_pseudo_observation():
    """A tight a priori holds the coefficient at its starting value (the fit is then the one
    with Cd known); a loose one leaves the data's estimate; the sigma never exceeds it."""
    obs = _leo_positions(2.6, seed=5)
    known = vv.fit_orbit(obs, LEO_GUESS, _leo_forces(2.2))
    tight = vv.fit_orbit(obs, LEO_GUESS, _leo_forces(2.2), estimate="drag",
                         parameter_sigma={"drag": 1e-9 * M2KG})
    assert abs(tight.parameters["drag"].to_value(M2KG) - 2.2 * AM) < 1e-8
    np.testing.assert_allclose(_y(tight.state), _y(known.state), rtol=0, atol=1e-6)
    assert tight.dof == known.dof  # one more unknown, one more (pseudo-)observation
    free = vv.fit_orbit(obs, LEO_GUESS, _leo_forces(2.2), estimate="drag")
    loose = vv.fit_orbit(obs, LEO_GUESS, _leo_forces(2.2), estimate="drag",
                         parameter_sigma={"drag": 0.5 * AM * M2KG})
    sf = free.parameter_sigma["drag"].to_value(M2KG)
    sl = loose.parameter_sigma["drag"].to_value(M2KG)
    assert sl < sf and sl < 0.5 * AM
    b = free.parameters["drag"].to_value(M2KG)
    assert abs(b - 2.6 * AM) < 3 * sf


def test_consider_covariance_matches_monte_carlo_over_the_coefficient():
    """Cd is held at 2.2 while the truth's Cd is drawn from N(2.2, 0.3^2): the spread of the
    fitted states is the consider covariance, not the data-only one."""
    rng = np.random.default_rng(7)
    sigma_b = 0.3 * AM
    nees_c, nees_n, errors = [], [], []
    fit = None
    for k in range(25):
        cd = 2.2 + 0.3 * rng.standard_normal()
        obs = _leo_positions(cd, seed=200 + k)
        fit = vv.fit_orbit(obs, LEO_GUESS, _leo_forces(2.2), consider={"drag": sigma_b * M2KG})
        e = _y(fit.state) - _y(LEO)
        errors.append(e)
        nees_c.append(float(e @ np.linalg.solve(fit.covariance, e)))
        nees_n.append(float(e @ np.linalg.solve(fit.noise_covariance, e)))
    assert stats.chi2.ppf(0.001, 150) < sum(nees_c) < stats.chi2.ppf(0.999, 150), nees_c
    assert sum(nees_n) > 10 * stats.chi2.ppf(0.999, 150)  # the data-only one is overconfident
    # the coefficient dominates: the sample spread of the positions matches P_c's within 35 %
    spread = np.sqrt(np.mean(np.square(errors), axis=0))[:3]
    np.testing.assert_allclose(spread, fit.sigma_position_km, rtol=0.35)
    assert np.all(np.sqrt(np.diag(fit.noise_covariance))[:3] < 0.2 * fit.sigma_position_km)
    # P_c = P + S C S^T
    s = fit.consider_sensitivity[:6]
    np.testing.assert_allclose(fit.covariance, fit.noise_covariance + sigma_b**2 * np.outer(s, s),
                               rtol=1e-10, atol=1e-20)
    assert fit.considered["drag"].to_value(M2KG) == sigma_b


def test_parameter_arguments_are_checked():
    obs = _leo_positions(2.6, seed=1, hours=2)
    with pytest.raises(InvalidInputError, match="not a parameter"):
        vv.fit_orbit(obs, LEO_GUESS, _leo_forces(2.2), estimate="cd")
    with pytest.raises(InvalidInputError, match="exactly one"):
        vv.fit_orbit(obs, LEO_GUESS, [vv.J2(vv.EARTH)], estimate="drag")
    with pytest.raises(InvalidInputError, match="exactly one"):
        vv.fit_orbit(obs, LEO_GUESS, _leo_forces(2.2), consider={"srp": 0.1})
    with pytest.raises(InvalidInputError, match="both estimated and considered"):
        vv.fit_orbit(obs, LEO_GUESS, _leo_forces(2.2), estimate="drag",
                     consider={"drag": 0.001 * M2KG})
    with pytest.raises(InvalidInputError, match="estimate= does not name"):
        vv.fit_orbit(obs, LEO_GUESS, _leo_forces(2.2), parameter_sigma={"drag": 0.001 * M2KG})
    with pytest.raises(UnitsError):
        vv.fit_orbit(obs, LEO_GUESS, _leo_forces(2.2), estimate="drag",
                     parameter_sigma={"drag": 0.5})
    with pytest.raises(InvalidInputError, match="> 0"):
        vv.fit_orbit(obs, LEO_GUESS, _leo_forces(2.2), consider={"drag": 0 * M2KG})
    with pytest.raises(InvalidInputError, match="mapping"):
        vv.fit_orbit(obs, LEO_GUESS, _leo_forces(2.2), consider="drag")
    with pytest.raises(InvalidInputError, match="exactly one"):
        vv.propagate_covariance(LEO, np.eye(6) * 1e-6, 60 * u.s, None, consider={"drag": 0.1})


def test_propagate_covariance_consider_adds_s_c_s_from_finite_differences():
    """propagate_covariance(consider={"drag": s}) adds S C S^T, S the finite difference of
    propagate_cowell runs in the ballistic coefficient; ``.parameter_partials`` holds S."""
    p0 = np.diag([1e-4, 1e-4, 1e-4, 1e-10, 1e-10, 1e-10])
    t = np.linspace(600, 86400, 5) * u.s
    sigma = 0.003
    plain = vv.propagate_covariance(LEO, p0, t, _leo_forces(2.2))
    con = vv.propagate_covariance(LEO, p0, t, _leo_forces(2.2), consider={"drag": sigma * M2KG})
    h = 1e-4 * 2.2 * AM  # central: O(h^2), below the noise of a smaller step
    up = vv.propagate_cowell(LEO, t, [vv.J2(vv.EARTH), vv.AtmosphericDrag((2.2 * AM + h) * M2KG)],
                             rtol=1e-13, atol=1e-13)
    dn = vv.propagate_cowell(LEO, t, [vv.J2(vv.EARTH), vv.AtmosphericDrag((2.2 * AM - h) * M2KG)],
                             rtol=1e-13, atol=1e-13)
    s = np.c_[(up.r - dn.r).to_value(u.km), (up.v - dn.v).to_value(KMS)] / (2 * h)
    np.testing.assert_allclose(con.parameter_partials[..., 0], s, rtol=0,
                               atol=1e-5 * np.abs(s).max())
    extra = sigma**2 * s[:, :, None] * s[:, None, :]
    np.testing.assert_allclose(con.covariance - plain.covariance, extra, rtol=0,
                               atol=1e-4 * np.abs(extra).max())
    assert con.position_sigma[-1].to_value(u.km).max() > 1.0  # a day of drag: km along-track


def test_fit_propagate_carries_the_coefficients_uncertainty(leo_tracking):
    """fit.propagate maps the state and B together: its covariance a day past the arc matches
    the spread of propagate_cowell runs from samples of (x0, B) ~ N(estimate, full covariance)
    (within 20 %); at the epoch it is fit.covariance; with consider= it is fit.covariance too
    and grows beyond the data-only one."""
    fit = vv.fit_orbit(leo_tracking, LEO_GUESS, _leo_forces(2.2), estimate="drag")
    t = [0.0, 2.5 * 86400] * u.s
    out = fit.propagate(t)
    np.testing.assert_allclose(out.covariance[0], fit.covariance, rtol=1e-8, atol=1e-20)
    rng = np.random.default_rng(3)
    mean = np.r_[_y(fit.state), fit.parameters["drag"].to_value(M2KG)]
    draws = rng.multivariate_normal(mean, fit.full_covariance, size=150)
    ends = []
    for d in draws:
        st = vv.StateVectors(d[:3] * u.km, d[3:6] * KMS, vv.EARTH, epoch=EPOCH)
        end = vv.propagate_cowell(st, t[1:], [vv.J2(vv.EARTH), vv.AtmosphericDrag(d[6] * M2KG)])
        ends.append(end.r.to_value(u.km)[-1])
    spread = np.sqrt(np.diag(np.cov(np.array(ends).T)))
    np.testing.assert_allclose(spread, out.position_sigma[1].to_value(u.km), rtol=0.2)
    known = vv.fit_orbit(leo_tracking, LEO_GUESS, _leo_forces(2.6))
    assert np.all(known.propagate(t).position_sigma[1] < out.position_sigma[1])
    con = vv.fit_orbit(leo_tracking, LEO_GUESS, _leo_forces(2.6),
                       consider={"drag": 0.001 * M2KG})
    pc = con.propagate(t, output_frame="RTN")
    np.testing.assert_allclose(con.propagate(t).covariance[0], con.covariance, rtol=1e-8,
                               atol=1e-20)
    pk = known.propagate(t, output_frame="RTN")
    assert pc.position_sigma[1][1] > 10 * pk.position_sigma[1][1]  # along-track


def test_coefficient_partials_through_burns_match_differences():
    """Through an impulse and a finite burn whose mass flow scales A/m (800 -> 719 kg), the
    partials on B and Cr (propagate_covariance(consider=...).parameter_partials) match
    central differences of propagate_cowell runs with the same burns."""
    finite = vv.FiniteBurn(2000 * u.s, 600 * u.s, [0.2, 1.0, 0.1], "RTN", thrust=400 * u.N,
                           mass=800 * u.kg, isp=300 * u.s)
    kick = vv.ImpulsiveBurn(5000 * u.s, [0.0, 2.0, 0.5] * u.m / u.s, "RTN")
    burns = [finite, kick]
    t = np.array([-1800.0, 1000.0, 2300.0, 4000.0, 9000.0, 20000.0])
    state = vv.StateVectors([6728.0, 10.0, 20.0] * u.km, [-0.01, 4.9, 5.9] * KMS, vv.EARTH,
                            epoch=EPOCH)
    out = vv.propagate_covariance(state, np.eye(6) * 1e-8, t * u.s,
                                  _forces_srp(0.026, 1.3, "conical"), maneuvers=burns,
                                  consider={"drag": 0.001 * M2KG, "srp": 0.1})

    def run(bc, cr):
        r = vv.propagate_cowell(state, t * u.s, _forces_srp(bc, cr, "conical"), maneuvers=burns,
                                rtol=1e-13, atol=1e-13)
        return np.c_[r.r.to_value(u.km), r.v.to_value(KMS)]

    h = 1e-4 * 0.026
    fd = (run(0.026 + h, 1.3) - run(0.026 - h, 1.3)) / (2 * h)
    s = out.parameter_partials
    np.testing.assert_allclose(s[..., 0], fd, rtol=0, atol=1e-5 * np.abs(fd).max())
    h = 1e-2 * 1.3
    fd = (run(0.026, 1.3 + h) - run(0.026, 1.3 - h)) / (2 * h)
    np.testing.assert_allclose(s[..., 1], fd, rtol=0, atol=1e-4 * np.abs(fd).max())


def test_fit_estimates_drag_and_a_burn_together():
    """12 h of tracking across a 2 m/s RTN impulse at 6 h: its Δv (from zero) and Cd (from
    2.2) are found together within 3 sigma; fit.propagate flies both."""
    flown = vv.ImpulsiveBurn(EPOCH + 6 * u.h, [0.5, 1.5, -1.0] * u.m / u.s, "RTN")
    obs = vv.od.simulate_tracking(LEO, STATIONS, EPOCH + np.arange(0, 12 * 3600, 60) * u.s,
                                  _leo_forces(2.6), maneuvers=[flown], seed=4)
    plan = vv.ImpulsiveBurn(EPOCH + 6 * u.h, [0, 0, 0] * u.m / u.s, "RTN")
    fit = vv.fit_orbit(obs, LEO_GUESS, _leo_forces(2.2), maneuvers=[plan],
                       estimate_maneuvers=True, estimate="drag")
    assert fit.full_covariance.shape == (10, 10)
    dv = fit.delta_v.to_value(u.km / u.s)[0]
    e = np.r_[_y(fit.state), dv, fit.parameters["drag"].to_value(M2KG)]
    e = e - np.r_[_y(LEO), [0.5e-3, 1.5e-3, -1.0e-3], 2.6 * AM]
    assert e @ np.linalg.solve(fit.full_covariance, e) < stats.chi2.ppf(0.999, 10)
    b, sb = fit.parameters["drag"].to_value(M2KG), fit.parameter_sigma["drag"].to_value(M2KG)
    assert abs(b - 2.6 * AM) < 3 * sb < 0.1 * AM
    out = fit.propagate([0.0, 8 * 3600.0] * u.s)
    np.testing.assert_allclose(out.covariance[0], fit.covariance, rtol=1e-8, atol=1e-20)
    ref = vv.propagate_cowell(LEO, 8 * u.h, _leo_forces(2.6), maneuvers=[flown])
    err = (out.r[1] - ref.r).to_value(u.km)
    p = out.covariance[1][:3, :3]
    assert err @ np.linalg.solve(p, err) < stats.chi2.ppf(0.999, 3)


def test_unobservable_or_runaway_coefficients_are_refused():
    """Cr from 10 minutes of a LEO (no visible effect) without an a priori: refused up front or
    as an estimate outside the force's domain, never returned as a silent wrong number; with
    an a priori it stays at its starting value within its sigma."""
    obs = _leo_positions(2.2, seed=9, hours=0.2)
    forces = _leo_forces(2.2) + [vv.SolarRadiationPressure(0.01 * M2KG, reflectivity=1.3,
                                                           shadow=None), vv.ThirdBody(vv.SUN)]
    try:
        fit = vv.fit_orbit(obs, LEO_GUESS, forces, estimate="srp")
    except (InvalidInputError, vv.ConvergenceError) as exc:
        assert "srp" in str(exc) or "determine" in str(exc)
    else:  # the data determine it only loosely: an honest, huge sigma
        assert fit.parameter_sigma["srp"] > 10
    held = vv.fit_orbit(obs, LEO_GUESS, forces, estimate="srp", parameter_sigma={"srp": 0.2})
    assert abs(held.parameters["srp"] - 1.3) < 0.2 * 0.01
    assert 0.19 < held.parameter_sigma["srp"] <= 0.2
    # a coefficient with no trace at all in the data (e.g. SRP of an arc in the umbra)
    from visviva.od.parameters import check_observable, coefficients

    est, _ = coefficients(forces, "srp", None, None)
    with pytest.raises(InvalidInputError, match="no effect"):
        check_observable(np.zeros((5, 3, 1)), est)
    est, _ = coefficients(forces, "srp", {"srp": 0.2}, None)
    check_observable(np.zeros((5, 3, 1)), est)  # an a priori alone determines it


def test_drag_partial_with_the_nrlmsis_grid_matches_differences():
    """The NRLMSIS density grid (model 1) gives the drag partial the right-hand side's density."""
    pytest.importorskip("pymsis")
    y0 = np.array([6728.0, 10.0, 20.0, -0.01, 4.9, 5.9])
    t = np.linspace(0, 20000, 8)

    def forces(bc):
        return [vv.J2(vv.EARTH), vv.AtmosphericDrag(bc * M2KG, model="nrlmsis", f107=150,
                                                    f107a=150, ap=4)]

    dyn = Dynamics(vv.EARTH.gm_km3_s2, forces(0.026), EPOCH, (0, 20000))
    dyn.propagate(y0, t, parameters=True)
    state = vv.StateVectors(y0[:3] * u.km, y0[3:] * KMS, vv.EARTH, epoch=EPOCH)
    h = 1e-4 * 0.026
    up = vv.propagate_cowell(state, t * u.s, forces(0.026 + h), rtol=1e-13, atol=1e-13)
    dn = vv.propagate_cowell(state, t * u.s, forces(0.026 - h), rtol=1e-13, atol=1e-13)
    fd = np.c_[(up.r - dn.r).to_value(u.km), (up.v - dn.v).to_value(KMS)] / (2 * h * 1e-6)
    s = dyn.parameter_partials[..., 0]
    assert np.abs(s[-1, :3]).max() * 0.026e-6 > 0.01  # > 10 m in 5.5 h
    np.testing.assert_allclose(s, fd, rtol=0, atol=1e-5 * np.abs(fd).max())


def test_estimated_and_considered_coefficients_together_propagate_in_their_order():
    """Cr estimated (with an a priori) while B is considered: fit.propagate maps the joint
    covariance of (state, Cr, B) with [Phi, S_Cr, S_B] (columns in the fit's order)."""
    forces = _leo_forces(2.2) + [vv.SolarRadiationPressure(0.01 * M2KG, reflectivity=1.3),
                                 vv.ThirdBody(vv.SUN)]
    obs = _leo_positions(2.2, seed=12, hours=3)
    fit = vv.fit_orbit(obs, LEO_GUESS, forces, estimate="srp", parameter_sigma={"srp": 0.3},
                       consider={"drag": 0.002 * M2KG})
    assert list(fit.parameters) == ["srp"] and list(fit.considered) == ["drag"]
    assert fit.full_covariance.shape == (7, 7) and fit.consider_sensitivity.shape == (7, 1)
    t = [0.0, 6 * 3600.0] * u.s
    out = fit.propagate(t)
    np.testing.assert_allclose(out.covariance[0], fit.covariance, rtol=1e-8, atol=1e-20)
    unit = vv.propagate_covariance(fit.state, np.zeros((6, 6)), t, fit.perturbations,
                                   consider={"drag": 1 * M2KG, "srp": 1.0})
    m = np.concatenate([unit.stm, unit.parameter_partials[..., [1, 0]]], axis=-1)
    c = 0.002**2
    joint = np.zeros((8, 8))
    joint[:7, :7] = fit.full_covariance
    joint[:7, 7] = joint[7, :7] = fit.consider_sensitivity[:, 0] * c
    joint[7, 7] = c
    want = m @ joint @ np.swapaxes(m, -1, -2)
    np.testing.assert_allclose(out.covariance, want, rtol=1e-7, atol=1e-14)


def test_filter_orbit_estimates_drag_as_an_augmented_state(leo_tracking):
    """The extended filter with B in its state (a priori Cd 2.2 +- 0.5) ends at the truth's
    Cd 2.6 within 3 sigma with a consistent (x, B) NEES; the same filter with Cd held at 2.2
    diverges. The smoother's first state is within 3 sigma of the truth."""
    p0 = np.diag([0.1**2] * 3 + [1e-4**2] * 3)
    guess = vv.StateVectors(LEO.r + [0.1, -0.1, 0.05] * u.km, LEO.v + [1e-4, 0, -1e-4] * KMS,
                            vv.EARTH, epoch=EPOCH)
    flt = vv.filter_orbit(leo_tracking, guess, p0, _leo_forces(2.2), estimate="drag",
                          parameter_sigma={"drag": 0.5 * AM * M2KG}, smoother=True)
    b = flt.parameters["drag"].to_value(M2KG)
    sb = flt.parameter_sigma["drag"].to_value(M2KG)
    assert b.shape == (len(flt.times),) and b[0] == 2.2 * AM and sb[0] == 0.5 * AM
    assert abs(b[-1] - 2.6 * AM) < 3 * sb[-1] < 0.01 * AM
    assert flt.full_covariances.shape == (len(flt.times), 7, 7)
    assert flt.covariances.shape == (len(flt.times), 6, 6) and flt.states.shape[1] == 6
    end = vv.propagate_cowell(LEO, flt.state.epoch, _leo_forces(2.6), rtol=1e-13, atol=1e-13)
    e = np.r_[(flt.state.r - end.r).to_value(u.km), (flt.state.v - end.v).to_value(KMS),
              b[-1] - 2.6 * AM]
    assert e @ np.linalg.solve(flt.full_covariances[-1], e) < stats.chi2.ppf(0.999, 7)
    e0 = (flt.first_state.r - LEO.r).to_value(u.km)
    assert np.all(np.abs(e0) < 3 * np.sqrt(np.diag(flt.first_covariance))[:3])
    drag = [p for p in flt.perturbations if isinstance(p, vv.AtmosphericDrag)][0]
    assert drag._bc_m2_kg == b[-1]
    with pytest.raises(vv.ConvergenceError, match="diverged"):
        vv.filter_orbit(leo_tracking, guess, p0, _leo_forces(2.2))
    with pytest.raises(InvalidInputError, match="a priori sigma"):
        vv.filter_orbit(leo_tracking, guess, p0, _leo_forces(2.2), estimate="drag")
    with pytest.raises(InvalidInputError, match="without estimate"):
        vv.filter_orbit(leo_tracking, guess, p0, _leo_forces(2.2),
                        parameter_sigma={"drag": 0.005 * M2KG})
