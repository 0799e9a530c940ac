"""Gauss-Markov process noise on the coefficients filter_orbit estimates (parameter_noise=):
the 1-D recursion (stationary variance, steps that compose), the no-noise limit against the
constant coefficients of before, and a truth whose drag coefficient jumps mid-arc (the filter
with a constant B diverges, the Gauss-Markov one stays consistent)."""

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from hypothesis import given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva.errors import InvalidInputError, UnitsError
from visviva.od import simulate_observations
from visviva.od.gauss_markov import GaussMarkov

EPOCH = Time("2024-03-01T00:00:00", scale="utc")
KMS = u.km / u.s
M2KG = u.m**2 / u.kg
AM = 0.01  # area-to-mass, m^2/kg: B = Cd AM
R_LEO = 6378.137 + 350.0
_V = np.sqrt(vv.EARTH.gm_km3_s2 / R_LEO)
_INC = np.radians(51.6)
LEO = vv.StateVectors([R_LEO, 0.0, 0.0] * u.km, [0.0, _V * np.cos(_INC), _V * np.sin(_INC)] * KMS,
                      vv.EARTH, epoch=EPOCH)
P0 = np.diag([0.05**2] * 3 + [5e-5**2] * 3)  # 50 m, 5 cm/s
ARC_S, JUMP_S, STEP_S = 12 * 3600.0, 6 * 3600.0, 120.0
CD_BEFORE, CD_AFTER = 2.2, 3.0
SIGMA_B = {"drag": 0.5 * AM * M2KG}
NOISE = {"drag": (0.5 * AM * M2KG, 3 * u.hour)}  # the jump of 0.8 in Cd is 1.6 sigma


def _forces(cd):
    return [vv.J2(vv.EARTH), vv.AtmosphericDrag(cd * AM * M2KG)]


@pytest.fixture(scope="module")
def jump():
    """12 h of 10 m GCRS positions every 2 min of a LEO satellite whose Cd jumps from 2.2 to
    3.0 at 6 h (truth integrated in two pieces); the true (x, B) at each time (T, 7)."""
    t = np.arange(0.0, ARC_S, STEP_S)
    before, after = t[t < JUMP_S], t[t >= JUMP_S]
    o1 = simulate_observations(LEO, EPOCH + before * u.s, "position", 0.01 * u.km,
                               perturbations=_forces(CD_BEFORE), seed=1)
    path = vv.propagate_cowell(LEO, EPOCH + np.r_[before, JUMP_S] * u.s, _forces(CD_BEFORE),
                               rtol=1e-13, atol=1e-13)
    mid = vv.StateVectors(path.r[-1], path.v[-1], vv.EARTH, epoch=EPOCH + JUMP_S * u.s)
    o2 = simulate_observations(mid, EPOCH + after * u.s, "position", 0.01 * u.km,
                               perturbations=_forces(CD_AFTER), seed=2)
    rest = vv.propagate_cowell(mid, EPOCH + after * u.s, _forces(CD_AFTER), rtol=1e-13,
                               atol=1e-13)
    obs = vv.Observations(time=EPOCH + t * u.s, kind="position",
                          value=np.vstack([o1.values, o2.values])[:, :3], sigma=0.01)
    r = np.vstack([path.r[:-1].to_value(u.km), rest.r.to_value(u.km)])
    v = np.vstack([path.v[:-1].to_value(KMS), rest.v.to_value(KMS)])
    truth = np.c_[r, v, np.where(t < JUMP_S, CD_BEFORE, CD_AFTER) * AM]
    return obs, truth


def _nees(flt, truth):
    """The filtered (x, B) NEES at each time."""
    x = np.c_[flt.states, flt.parameters["drag"].to_value(M2KG)]
    P = np.asarray(flt.full_covariances)
    e = x - truth
    return np.einsum("ti,ti->t", e, np.linalg.solve(P, e[..., None])[..., 0])


@pytest.mark.parametrize("method", ["ekf", "ukf"])
def test_drag_jump_constant_coefficient_diverges_gauss_markov_stays_consistent(jump, method):
    """With B a constant the filter is sure of Cd 2.2 by the jump and loses the orbit after it
    (ConvergenceError); with Gauss-Markov noise (sigma 0.5 in Cd, tau 3 h) the (x, B) NEES
    averages 5.8 (chi-square mean 7), the normalised innovations 2.8 (3 components), Cd ends
    at 2.90 +- 0.32 (truth 3.0) and the smoothed Cd is within 3 sigma of the truth 1.5 h
    away from the jump (1.2 sigma at most), 3.5 sigma at it."""
    obs, truth = jump
    with pytest.raises(vv.ConvergenceError, match="diverged"):
        vv.filter_orbit(obs, LEO, P0, _forces(CD_BEFORE), estimate="drag",
                        parameter_sigma=SIGMA_B, method=method)
    flt = vv.filter_orbit(obs, LEO, P0, _forces(CD_BEFORE), estimate="drag",
                          parameter_sigma=SIGMA_B, parameter_noise=NOISE, method=method,
                          smoother=True)
    nees = _nees(flt, truth)
    assert 4.5 < nees.mean() < 8.0
    assert 4.5 < nees[flt.offsets_s >= JUMP_S].mean() < 8.0
    assert 2.5 < flt.nis.mean() < 3.5 and not flt.rejected.any()
    cd = flt.parameters["drag"].to_value(M2KG) / AM
    sd = flt.parameter_sigma["drag"].to_value(M2KG) / AM
    assert abs(cd[-1] - CD_AFTER) < 3 * sd[-1] and 0.2 < sd[-1] < 0.5
    assert np.all(sd <= 0.5 + 1e-12)  # the variance relaxes towards sigma^2, never beyond
    scd = flt.smoothed_parameters["drag"].to_value(M2KG) / AM
    ssd = flt.smoothed_parameter_sigma["drag"].to_value(M2KG) / AM
    ratio = np.abs(scd - truth[:, 6] / AM) / ssd
    # a step is not a Gauss-Markov path: the smoother blurs it over ~tau (3.5 sigma at it)
    assert ratio.max() < 4.0 and ratio[np.abs(flt.offsets_s - JUMP_S) > 5400].max() < 3.0
    assert np.all(ssd <= sd + 1e-12)  # the smoother only adds information
    early, late = flt.offsets_s < JUMP_S - 3600, flt.offsets_s > JUMP_S + 3600
    assert abs(scd[early].mean() - CD_BEFORE) < 0.15 and abs(scd[late].mean() - CD_AFTER) < 0.15


@pytest.mark.parametrize("method", ["ekf", "ukf"])
def test_no_noise_limit_is_the_constant_coefficient(jump, method):
    """sigma 0 and tau 1e30 s: the filter of a constant B, bit for bit where both integrate the
    same steps (without process noise; with it and noise_step over the observations' spacing);
    with process noise cut into 60 s steps the Gauss-Markov prediction integrates each step on
    its own, which moves the integrator's steps: states within 1 micrometre."""
    obs, _ = jump
    obs = vv.Observations(time=obs.times[:60], kind="position", value=obs.values[:60, :3],
                          sigma=0.01)
    for q, step in ((None, None), (1e-12, STEP_S + 1), (1e-12, None)):
        kw = {"estimate": "drag", "parameter_sigma": SIGMA_B, "method": method,
              "smoother": True, "process_noise": q, "noise_step": step}
        a = vv.filter_orbit(obs, LEO, P0, _forces(CD_BEFORE), **kw)
        b = vv.filter_orbit(obs, LEO, P0, _forces(CD_BEFORE), **kw,
                            parameter_noise={"drag": (0.0 * M2KG, 1e30 * u.s)})
        if step is not None or q is None:
            np.testing.assert_array_equal(a.states, b.states)
            np.testing.assert_array_equal(a.full_covariances, b.full_covariances)
            np.testing.assert_array_equal(a.smoothed_states, b.smoothed_states)
        else:
            np.testing.assert_allclose(b.states, a.states, rtol=0, atol=1e-9)
            np.testing.assert_allclose(b.smoothed_states, a.smoothed_states, rtol=0, atol=1e-9)
            np.testing.assert_allclose(b.full_covariances, a.full_covariances, rtol=1e-6,
                                       atol=1e-20)
        np.testing.assert_allclose(b.parameters["drag"].to_value(M2KG),  # 1e-7 of Cd
                                   a.parameters["drag"].to_value(M2KG), rtol=0, atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(sigma=st.floats(1e-6, 1e3), tau=st.floats(1.0, 1e7), dt=st.floats(1e-3, 1e6),
       dt2=st.floats(1e-3, 1e6), p=st.floats(-10, 10))
def test_one_dimensional_recursion(sigma, tau, dt, dt2, p):
    """P -> m^2 P + sigma^2 (1 - m^2): sigma^2 is stationary; two steps equal one of their sum
    (mean and variance); the mean decays towards the prior by exp(-dt / tau)."""
    gm = GaussMarkov([1.0], [sigma], [tau])
    z = np.r_[np.zeros(6), 1.0 + p]
    eye = np.eye(7)
    _, P, _ = gm.apply(z, np.diag(np.r_[np.ones(6), sigma**2]), eye, dt)
    assert P[6, 6] == pytest.approx(sigma**2, rel=1e-12)
    start = np.diag(np.r_[np.ones(6), 0.25 * sigma**2])
    z1, P1, f1 = gm.apply(*gm.apply(z, start, eye, dt), dt2)
    z2, P2, f2 = gm.apply(z, start, eye, dt + dt2)
    assert P1[6, 6] == pytest.approx(P2[6, 6], rel=1e-10)
    # the coefficient is held as prior + deviation: the deviation is known to the coefficient's
    # round-off (1 + |p| ulps), not relative to itself once it has decayed (dt >> tau)
    ulp = 4e-16 * (1.0 + abs(p))
    assert z1[6] - 1.0 == pytest.approx(z2[6] - 1.0, rel=1e-10, abs=ulp)
    # the decay factors keep their relative precision however far they decay (was: 1 - d
    # lost them: 1.3e-10 relative for dt = 1 then 16 with tau = 1)
    assert f1[6, 6] == pytest.approx(np.exp(-(dt + dt2) / tau), rel=1e-10, abs=1e-300)
    assert z2[6] - 1.0 == pytest.approx(p * np.exp(-(dt + dt2) / tau), rel=1e-12, abs=ulp)


def test_decay_factor_keeps_its_relative_precision_far_out():
    """was: m = 1 - (1 - m) lost m's digits once dt >> tau (two steps of 1 and 16 tau gave
    exp(-17) to 1.3e-10 relative)."""
    gm = GaussMarkov([1.0], [1.0], [1.0])
    eye = np.eye(7)
    z = np.r_[np.zeros(6), 1.0]
    start = np.eye(7)
    _, _, f1 = gm.apply(*gm.apply(z, start, eye, 1.0), 16.0)
    assert f1[6, 6] == pytest.approx(np.exp(-17.0), rel=1e-14)
    m, d, v = gm.step(40.0)
    assert m[0] == pytest.approx(np.exp(-40.0), rel=1e-15) and d[0] == 1.0


def test_state_block_and_cross_covariance():
    """The orbit state is untouched; its covariance with the coefficient scales by m."""
    gm = GaussMarkov([0.02], [0.003], [3600.0])
    rng = np.random.default_rng(3)
    a = rng.standard_normal((7, 7))
    P = a @ a.T
    z = rng.standard_normal(7)
    z2, P2, f = gm.apply(z, P, np.eye(7), 1800.0)
    m = np.exp(-0.5)
    np.testing.assert_array_equal(z2[:6], z[:6])
    np.testing.assert_array_equal(P2[:6, :6], P[:6, :6])
    np.testing.assert_allclose(P2[:6, 6], m * P[:6, 6], rtol=1e-15)
    np.testing.assert_allclose(P2[6, 6], m**2 * P[6, 6] + 0.003**2 * (1 - m**2), rtol=1e-14)
    assert z2[6] == pytest.approx(0.02 + m * (z[6] - 0.02), rel=1e-14)
    np.testing.assert_allclose(f, np.diag(np.r_[np.ones(6), m]), rtol=1e-15)


@pytest.mark.parametrize("noise, match", [
    ({"drag": (-0.001 * M2KG, 3600)}, "sigma must be a finite number >= 0"),
    ({"drag": (np.nan * M2KG, 3600)}, "sigma must be a finite number >= 0"),
    ({"drag": (0.001 * M2KG, 0 * u.s)}, "tau must be a finite time > 0"),
    ({"drag": (0.001 * M2KG, 30 * u.s)}, "give it as process_noise"),
    ({"drag": (0.001 * M2KG, np.inf * u.s)}, "leave it out of parameter_noise"),
    ({"drag": (0.001 * M2KG, None)}, "time"),
    ({"drag": (0.001 * M2KG, -5 * u.min)}, "tau must be a finite time > 0"),
    ({"drag": 0.001 * M2KG}, "must be a pair"),
    ({"srp": (0.1, 3600)}, "'srp', which estimate= does not name"),
    ([("drag", (0.001 * M2KG, 3600))], "must be a mapping"),
])
def test_bad_parameter_noise_is_refused(jump, noise, match):
    obs, _ = jump
    with pytest.raises((InvalidInputError, UnitsError), match=match):
        vv.filter_orbit(obs, LEO, P0, _forces(CD_BEFORE), estimate="drag",
                        parameter_sigma=SIGMA_B, parameter_noise=noise)


def test_a_variance_decayed_to_zero_is_smoothed_in_square_root_form(jump):
    """sigma 0 with tau 1 min: the coefficient's variance decays to 0 (the filter runs). was:
    the covariance-form unscented smoother's gain could not invert that and refused
    (ConvergenceError); the square-root smoother (gain by solves with the factors, smoothed
    factor from the joint factor) gives finite smoothed sigmas no larger than the filtered."""
    obs, _ = jump
    obs = vv.Observations(time=obs.times[:20], kind="position", value=obs.values[:20, :3],
                          sigma=0.01)
    kw = {"estimate": "drag", "parameter_sigma": SIGMA_B, "method": "ukf",
          "parameter_noise": {"drag": (0.0 * M2KG, 60 * u.s)}}
    flt = vv.filter_orbit(obs, LEO, P0, _forces(CD_BEFORE), **kw)
    sd = flt.parameter_sigma["drag"].to_value(M2KG)
    assert sd[-1] < 1e-10 * sd[0] and np.all(np.isfinite(flt.states))
    sm = vv.filter_orbit(obs, LEO, P0, _forces(CD_BEFORE), **kw, smoother=True)
    ss = sm.smoothed_parameter_sigma["drag"].to_value(M2KG)
    assert np.all(np.isfinite(ss)) and np.all(ss <= sd * (1 + 1e-3))
    assert np.all(np.isfinite(sm.smoothed_states))


def test_parameter_noise_needs_estimate_and_units(jump):
    obs, _ = jump
    with pytest.raises(InvalidInputError, match="estimate= does not name"):
        vv.filter_orbit(obs, LEO, P0, _forces(CD_BEFORE), parameter_noise=NOISE)
    with pytest.raises(UnitsError):  # B's sigma carries its unit, as parameter_sigma's
        vv.filter_orbit(obs, LEO, P0, _forces(CD_BEFORE), estimate="drag",
                        parameter_sigma=SIGMA_B, parameter_noise={"drag": (0.005, 3600)})


def test_only_the_named_coefficient_gets_noise(jump):
    """estimate drag and srp, noise on srp only: in the model the drag column is left bit for
    bit; in a filter (8 states) the SRP Cr stays less certain than with Cr constant, within
    its steady-state sigma."""
    gm = GaussMarkov([0.022, 1.3], [0.0, 0.2], [np.inf, 3600.0])
    rng = np.random.default_rng(5)
    a = rng.standard_normal((8, 8))
    P = a @ a.T
    z = rng.standard_normal(8)
    z2, P2, f = gm.apply(z, P, np.eye(8), 600.0)
    np.testing.assert_array_equal(z2[:7], z[:7])
    np.testing.assert_array_equal(P2[:7, :7], P[:7, :7])
    assert f[6, 6] == 1.0 and f[7, 7] == pytest.approx(np.exp(-600.0 / 3600.0), rel=1e-15)
    obs, _ = jump
    obs = vv.Observations(time=obs.times[:60], kind="position", value=obs.values[:60, :3],
                          sigma=0.01)
    forces = [*_forces(CD_BEFORE), vv.SolarRadiationPressure(0.01 * M2KG, reflectivity=1.3)]
    kw = {"estimate": ["drag", "srp"], "parameter_sigma": {**SIGMA_B, "srp": 0.3}}
    const = vv.filter_orbit(obs, LEO, P0, forces, **kw)
    noisy = vv.filter_orbit(obs, LEO, P0, forces, **kw, parameter_noise={"srp": (0.3, 600.0)})
    assert noisy.full_covariances.shape == (60, 8, 8)
    s_const, s_noisy = const.parameter_sigma["srp"], noisy.parameter_sigma["srp"]
    assert np.all(s_noisy[1:] > s_const[1:]) and np.all(s_noisy <= 0.3 + 1e-12)
    assert np.all(np.isfinite(noisy.parameters["srp"]))


@pytest.mark.parametrize("method", ["ekf", "ukf"])
def test_estimate_decays_to_the_prior_over_a_gap(jump, method):
    """One hour of data (truth Cd 2.2, nominal 2.6), a two-hour gap, then one row too coarse
    (1000 km) to move anything: across the gap the filtered Cd decays towards the nominal by
    exp(-2 h / tau) and its variance relaxes, m^2 P + sigma^2 (1 - m^2), as the 1-D model."""
    obs, _ = jump
    rows = np.r_[np.arange(30), 90]  # 0-58 min, then 3 h
    obs = vv.Observations(time=obs.times[rows], kind="position", value=obs.values[rows, :3],
                          sigma=[0.01] * 30 + [1000.0])
    sigma, tau = 0.5, 3600.0
    flt = vv.filter_orbit(obs, LEO, P0, _forces(2.6), estimate="drag", method=method,
                          parameter_sigma=SIGMA_B,
                          parameter_noise={"drag": (sigma * AM * M2KG, tau * u.s)})
    cd = flt.parameters["drag"].to_value(M2KG) / AM
    sd = flt.parameter_sigma["drag"].to_value(M2KG) / AM
    m = np.exp(-(flt.offsets_s[-1] - flt.offsets_s[-2]) / tau)
    assert abs(cd[-2] - 2.6) > 0.05  # the data moved it towards the truth
    assert cd[-1] - 2.6 == pytest.approx(m * (cd[-2] - 2.6), rel=1e-6)
    assert sd[-1] ** 2 == pytest.approx(m**2 * sd[-2] ** 2 + sigma**2 * (1 - m**2), rel=1e-6)


@pytest.mark.parametrize("method", ["ekf", "ukf"])
def test_filtered_orbit_records_the_parameter_noise_it_used(method):
    """was: FilteredOrbit recorded process_noise but not parameter_noise, so a printed or kept
    result could not say which Gauss-Markov noise its coefficients had. Now .parameter_noise
    holds {name: (sigma, tau)} for the coefficients that had noise (B in m^2/kg, tau in s),
    {} without, and the repr names it with the process noise."""
    t = EPOCH + np.arange(0.0, 1200.0, STEP_S) * u.s
    obs = simulate_observations(LEO, t, "position", 0.01 * u.km,
                                perturbations=_forces(CD_BEFORE), seed=3)
    obs = vv.Observations(time=t, kind="position", value=obs.values[:, :3], sigma=0.01)
    forces = [*_forces(CD_BEFORE), vv.SolarRadiationPressure(0.01 * M2KG, reflectivity=1.3)]
    kw = {"estimate": ["drag", "srp"], "parameter_sigma": {**SIGMA_B, "srp": 0.3},
          "method": method}
    noisy = vv.filter_orbit(obs, LEO, P0, forces, **kw, process_noise=1e-12,
                            process_noise_frame="rtn",
                            parameter_noise={"drag": (0.004 * M2KG, 3 * u.hour)})
    assert set(noisy.parameter_noise) == {"drag"}  # srp was a constant
    sigma, tau = noisy.parameter_noise["drag"]
    assert sigma.to_value(M2KG) == pytest.approx(0.004, rel=1e-15)
    assert tau.to_value(u.s) == pytest.approx(10800.0, rel=1e-15)
    text = repr(noisy)
    assert "process noise 1e-12 km^2/s^3 RTN" in text
    assert "drag Gauss-Markov sigma 0.004 m^2/kg tau 10800 s" in text
    srp = vv.filter_orbit(obs, LEO, P0, forces, **kw, parameter_noise={"srp": (0.2, 600.0)})
    assert srp.parameter_noise["srp"][0] == pytest.approx(0.2)
    assert srp.parameter_noise["srp"][1].to_value(u.s) == pytest.approx(600.0)
    assert "srp Gauss-Markov sigma 0.2 tau 600 s" in repr(srp)
    plain = vv.filter_orbit(obs, LEO, P0, forces, **kw)
    assert plain.parameter_noise == {} and "Gauss-Markov" not in repr(plain)
    assert "process noise" not in repr(plain)
