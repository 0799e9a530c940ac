"""vv.propagate_covariance: a covariance through Cowell's full force model (its STM from the
variational equations), checked against the two-body propagation of conjunctions, central
differences and a Monte Carlo of propagate_cowell, and for its invariants."""

from __future__ import annotations

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from hypothesis import given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva.conjunctions import inertial_to_rtn
from visviva.conjunctions import propagate_covariance as two_body_covariance

KMS = u.km / u.s
EPOCH = Time("2024-03-01T00:00:00", scale="utc")
#: 30 m / 3 cm/s on each axis with some correlation (km, km/s)
_A = np.r_[[3e-2] * 3, [3e-5] * 3][:, None] * np.random.default_rng(7).normal(size=(6, 6))
P0 = _A @ _A.T


def leo(a_km=7000.0):
    return vv.KeplerianElements.from_semi_major_axis(
        a_km * u.km, 0.001, 51.6 * u.deg, 0.3, 0.2, 0.1, vv.EARTH, epoch=EPOCH
    ).to_state()


def full_forces():
    am = 0.05 * u.m**2 / u.kg
    return [vv.Zonal(vv.EARTH, 4), vv.AtmosphericDrag(am), vv.ThirdBody(vv.SUN),
            vv.ThirdBody(vv.MOON), vv.SolarRadiationPressure(am, 1.3, shadow="conical")]


def fd_stm(state, t, forces):
    """Central differences (1 m, 1 mm/s) of propagate_cowell (rtol = atol = 1e-13) at offsets
    ``t`` (s): the STM (T, 6, 6); the 12 displaced states in one batch call."""
    y = np.r_[state.r.to_value(u.km), state.v.to_value(KMS)]
    d = np.r_[[1e-3] * 3, [1e-6] * 3]
    y0 = np.concatenate([y + np.diag(d), y - np.diag(d)])
    batch = vv.StateVectors(y0[:, :3] * u.km, y0[:, 3:] * KMS, vv.EARTH, epoch=state.epoch)
    res = vv.propagate_cowell(batch, t * u.s, forces, rtol=1e-13, atol=1e-13)
    yt = np.concatenate([res.r.to_value(u.km), res.v.to_value(KMS)], axis=-1)  # (12, T, 6)
    return np.transpose((yt[:6] - yt[6:]) / (2 * d[:, None, None]), (1, 2, 0))


def rel(a, b):
    return np.abs(a - b).max(axis=(-2, -1)) / np.abs(b).max(axis=(-2, -1))


def test_two_body_equals_the_conjunctions_two_body_propagation():
    t = np.array([-3000.0, 600.0, 2900.0, 5800.0])
    out = vv.propagate_covariance(leo(), P0, t * u.s, [])
    state = leo()
    for k, dt in enumerate(t):
        ref = two_body_covariance(P0, state.r, state.v, dt * u.s, vv.EARTH)
        assert rel(out.covariance[k], ref) < 1e-10  # measured 1e-12 to 3e-11
    # the states are propagate_cowell's
    cow = vv.propagate_cowell(state, t * u.s, [])
    assert np.abs((cow.r - out.r).to_value(u.km)).max() < 1e-6
    assert 0.5 * cow.n_steps < out.n_steps < 2 * cow.n_steps


def test_stm_matches_central_differences_of_cowell_over_a_leo_day():
    # J4, drag, Sun, Moon and SRP with a conical shadow (~15 penumbra crossings in a day);
    # the 12 displaced states go through propagate_cowell's batch mode in one call
    f = full_forces()
    state = leo()
    t = np.array([-5400.0, 21600.0, 86400.0])
    out = vv.propagate_covariance(state, P0, t * u.s, f, rtol=1e-13, atol=1e-13)
    fd = fd_stm(state, t, f)
    assert rel(out.stm, fd).max() < 5e-7  # measured 3e-9, 1e-8, 1.2e-7 at -1.5 h, 6 h, 1 day
    # and the map is what makes the covariance
    want = out.stm @ P0 @ np.swapaxes(out.stm, -1, -2)
    assert rel(out.covariance, want).max() < 1e-12


def test_covariance_matches_a_monte_carlo_while_linear():
    # 3000 samples of P0 (30 m, 3 cm/s) through one orbit with J2: the sample covariance of
    # the positions equals the linear one within sampling error (variance: sqrt(2/N) = 2.6 %)
    rng = np.random.default_rng(11)
    n = 3000
    state = leo()
    t = 5800.0
    f = [vv.J2(vv.EARTH)]
    out = vv.propagate_covariance(state, P0, t * u.s, f)
    y = np.r_[state.r.to_value(u.km), state.v.to_value(KMS)]
    samples = rng.multivariate_normal(y, P0, size=n)
    batch = vv.StateVectors(samples[:, :3] * u.km, samples[:, 3:] * KMS, vv.EARTH, epoch=EPOCH)
    res = vv.propagate_cowell(batch, t * u.s, f)
    yt = np.concatenate([res.r.to_value(u.km), res.v.to_value(KMS)], axis=-1)
    sample_cov = np.cov(yt.T)
    sd = np.sqrt(np.diag(out.covariance))
    corr_err = (sample_cov - out.covariance) / np.outer(sd, sd)
    assert np.abs(np.diag(corr_err)).max() < 4 * np.sqrt(2.0 / n)
    assert np.abs(corr_err).max() < 4 * np.sqrt(2.0 / n)
    # the sample mean is the propagated state (no bias at this size)
    mean_err = (yt.mean(axis=0) - np.r_[out.r.to_value(u.km), out.v.to_value(KMS)]) / sd
    assert np.abs(mean_err).max() < 4 / np.sqrt(n)


def test_linear_covariance_breaks_for_a_large_along_track_uncertainty():
    # 1 m/s along-track over a day spreads the samples ~150 km along the orbit: the cloud
    # bends (a banana) and its radial spread is far from the linear one; documented in
    # docs/cowell.md, "Covariance propagation"
    rng = np.random.default_rng(5)
    n = 2000
    state = leo()
    P = np.diag([1e-6, 1e-6, 1e-6, 1e-12, 1e-6, 1e-12])  # 1 m and 1 m/s along-track (RTN)
    t = 86400.0
    out = vv.propagate_covariance(state, P, t * u.s, [vv.J2(vv.EARTH)], frame="RTN")
    pin = vv.propagate_covariance(state, P, 0 * u.s, [], frame="RTN", output_frame="GCRS")
    y = np.r_[state.r.to_value(u.km), state.v.to_value(KMS)]
    samples = rng.multivariate_normal(y, pin.covariance, size=n)
    batch = vv.StateVectors(samples[:, :3] * u.km, samples[:, 3:] * KMS, vv.EARTH, epoch=EPOCH)
    res = vv.propagate_cowell(batch, t * u.s, [vv.J2(vv.EARTH)])
    yt = np.concatenate([res.r.to_value(u.km), res.v.to_value(KMS)], axis=-1)
    rtn = inertial_to_rtn(np.cov(yt.T), out.r, out.v)
    ratio = np.sqrt(np.diag(rtn)[:3] / np.diag(out.covariance)[:3])
    assert abs(ratio[1] - 1) < 0.1  # along-track still right
    assert ratio[0] > 2.0  # radial: the curvature of the orbit, absent from the linear map


def test_rtn_output_is_the_gcrs_output_rotated_and_input_frames_agree():
    f = [vv.J2(vv.EARTH)]
    t = np.array([-600.0, 0.0, 3000.0]) * u.s
    g = vv.propagate_covariance(leo(), P0, t, f)
    r = vv.propagate_covariance(leo(), P0, t, f, output_frame="RTN")
    assert r.frame == "RTN"
    from visviva._covariance import local_axes_of  # (what the CCSDS writers read)

    assert local_axes_of(r.covariance[1]) == "RTN" and local_axes_of(g.covariance[1]) is None
    # fed back in, the RTN matrix at t = 0 was read as a GCRS one (frame= left out), silently
    with pytest.raises(vv.InvalidInputError, match="on the RTN axes .* pass frame='RTN'"):
        vv.propagate_covariance(leo(), r.covariance[1], t, f)
    again = vv.propagate_covariance(leo(), r.covariance[1], t, f, frame="RTN")
    assert rel(again.covariance, r.covariance).max() < 1e-12
    want = inertial_to_rtn(g.covariance, g.r, g.v)
    assert rel(r.covariance, want).max() < 1e-14
    # a covariance given in RTN is the GCRS one rotated at the epoch
    p_rtn = inertial_to_rtn(P0, leo().r, leo().v)
    back = vv.propagate_covariance(leo(), p_rtn, t, f, frame="RTN", output_frame="GCRS")
    assert rel(back.covariance, g.covariance).max() < 1e-12
    np.testing.assert_array_equal(r.stm, g.stm)


def test_symmetric_positive_definite_and_det_phi_one_for_conservative_forces():
    f = [vv.Zonal(vv.EARTH, 4), vv.ThirdBody(vv.MOON), vv.ThirdBody(vv.SUN)]
    t = np.linspace(-43200, 86400, 7) * u.s
    out = vv.propagate_covariance(leo(), P0, t, f)
    c = out.covariance
    np.testing.assert_array_equal(c, np.swapaxes(c, -1, -2))
    assert np.all(np.linalg.eigvalsh(c)[:, 0] > 0)
    # Liouville: a Hamiltonian flow keeps phase-space volume (time-dependent third bodies too)
    assert np.abs(np.linalg.det(out.stm) - 1).max() < 1e-8
    # symplectic: Phi^T J Phi = J
    J = np.block([[np.zeros((3, 3)), np.eye(3)], [-np.eye(3), np.zeros((3, 3))]])
    sym = np.swapaxes(out.stm, -1, -2) @ J @ out.stm
    assert np.abs(sym - J).max() < 1e-7 * np.abs(out.stm).max() ** 2
    # drag takes volume away: det(Phi) < 1 over a day
    dr = vv.propagate_covariance(leo(6700.0), P0, 86400 * u.s,
                                 [vv.J2(vv.EARTH), vv.AtmosphericDrag(0.05 * u.m**2 / u.kg)])
    assert np.linalg.det(dr.stm) < 1 - 1e-6


@pytest.mark.parametrize("shadow, tol", [(None, 1e-7), ("conical", 5e-6)])
def test_backward_then_forward_returns_p0(shadow, tol):
    # half a day back, then forward from there: P0 again, to the conditioning of the map
    # (P grows ~1e4 times along-track in 12 h): measured 2e-8 without a shadow; 1.2e-6 with
    # the conical penumbra, whose gradient of the visible Sun fraction is a central difference
    # good to ~1e-6 (core/variational.py)
    am = 0.05 * u.m**2 / u.kg
    f = full_forces()[:-1] + [vv.SolarRadiationPressure(am, 1.3, shadow=shadow)]
    state = leo()
    back = vv.propagate_covariance(state, P0, -43200 * u.s, f)
    earlier = vv.StateVectors(back.r, back.v, vv.EARTH, epoch=EPOCH - 43200 * u.s)
    fwd = vv.propagate_covariance(earlier, back.covariance, 43200 * u.s, f)
    assert np.abs((fwd.r - state.r).to_value(u.km)).max() < 1e-6
    assert rel(fwd.covariance, P0) < tol
    # Phi(t0, t) = Phi(t, t0)^-1
    assert rel(fwd.stm, np.linalg.inv(back.stm)) < tol / 100


def test_j2_and_drag_reshape_the_covariance_against_two_body():
    state = leo(6700.0)
    f = [vv.J2(vv.EARTH), vv.AtmosphericDrag(0.05 * u.m**2 / u.kg)]
    full = vv.propagate_covariance(state, P0, 86400 * u.s, f, output_frame="RTN")
    kep = vv.propagate_covariance(state, P0, 86400 * u.s, [], output_frame="RTN")
    s_full = full.position_sigma.to_value(u.km)
    s_kep = kep.position_sigma.to_value(u.km)
    # the along-track sigma differs by more than 10 % (J2's secular rates change the
    # along-track drift per unit semi-major-axis error), the cross-track by more
    assert abs(s_full[1] / s_kep[1] - 1) > 0.1 or abs(s_full[2] / s_kep[2] - 1) > 0.1


def test_process_noise_adds_the_snc_growth():
    q = 1e-12  # km^2/s^3
    zero = np.zeros((6, 6))
    out = vv.propagate_covariance(leo(), zero, [5.0, 10.0] * u.s, [], process_noise=q)
    # over 10 s the motion is a straight line: sigma_x^2 = q t^3 / 3, sigma_v^2 = q t
    np.testing.assert_allclose(out.covariance[1, 0, 0], q * 1000 / 3, rtol=1e-3)
    np.testing.assert_allclose(out.covariance[1, 3, 3], q * 10, rtol=1e-3)
    np.testing.assert_allclose(out.covariance[1, 0, 3], q * 100 / 2, rtol=1e-3)
    # over an orbit, the SNC sum converges with its step (60 s vs 10 s: < 1 %)
    a = vv.propagate_covariance(leo(), P0, 5800 * u.s, [], process_noise=[q, 4 * q, q])
    b = vv.propagate_covariance(leo(), P0, 5800 * u.s, [], process_noise=[q, 4 * q, q],
                                noise_step=10 * u.s)
    c = vv.propagate_covariance(leo(), P0, 5800 * u.s, [])
    grow = a.covariance - c.covariance
    assert rel(grow, b.covariance - c.covariance) < 1e-2
    assert np.all(np.diag(grow) > 0)
    # backward: the noise adds too
    back = vv.propagate_covariance(leo(), P0, -5800 * u.s, [], process_noise=q)
    noiseless = vv.propagate_covariance(leo(), P0, -5800 * u.s, [])
    assert np.all(np.diag(back.covariance - noiseless.covariance) > 0)
    qq = vv.propagate_covariance(leo(), P0, 100 * u.s, [],
                                 process_noise=1e-6 * u.m**2 / u.s**3)
    np.testing.assert_allclose(qq.process_noise, 1e-12)


def test_quantity_covariance_and_absolute_times():
    P_m = P0 * 1e6 * u.m**2
    t = EPOCH + [0, 1] * u.h
    a = vv.propagate_covariance(leo(), P_m, t, [vv.J2(vv.EARTH)])
    b = vv.propagate_covariance(leo(), P0, [0, 3600] * u.s, [vv.J2(vv.EARTH)])
    assert rel(a.covariance, b.covariance).max() < 1e-14
    s = vv.propagate_covariance(leo(), P0, 60 * u.s, [])
    assert s.covariance.shape == (6, 6) and s.r.shape == (3,)


@pytest.mark.parametrize("cov, match", [
    (P0[:3, :3], "6x6"),
    (np.triu(P0), "not symmetric"),
    (np.where(np.eye(6) == 1, np.nan, P0), "NaN"),
    (P0 - 2 * np.diag(np.diag(P0)), "negative variance"),
    ("corr", None),
    ("zero-variance", None),
])
def test_bad_covariances_are_refused(cov, match):
    if isinstance(cov, str) and cov == "corr":  # a correlation above 1
        bad = np.diag([1e-6] * 6)
        bad[0, 1] = bad[1, 0] = 2e-6
        match = "not positive semi-definite"
    elif isinstance(cov, str):  # no uncertainty on x, yet correlated
        bad = np.diag([0.0] + [1e-6] * 5)
        bad[0, 1] = bad[1, 0] = 1e-7
        match = "row is not"
    else:
        bad = np.array(cov, dtype=float)
    with pytest.raises(vv.VisvivaError, match=match):
        vv.propagate_covariance(leo(), bad, 60 * u.s, [])


def test_bad_arguments_are_refused():
    with pytest.raises(vv.UnitsError, match="area unit"):
        vv.propagate_covariance(leo(), P0 * u.m, 60 * u.s, [])
    with pytest.raises(vv.InvalidInputError, match="output_frame"):
        vv.propagate_covariance(leo(), P0, 60 * u.s, [], output_frame="ECEF")
    with pytest.raises(vv.InvalidInputError, match="process_noise must be >= 0"):
        vv.propagate_covariance(leo(), P0, 60 * u.s, [], process_noise=-1.0)
    with pytest.raises(vv.InvalidInputError, match="strictly increasing"):
        vv.propagate_covariance(leo(), P0, [60, 0] * u.s, [])
    two = vv.StateVectors([[7000.0, 0, 0]] * 2 * u.km, [[0, 7.5, 0]] * 2 * KMS, vv.EARTH)
    with pytest.raises(vv.ShapeError, match="one state"):
        vv.propagate_covariance(two, P0, 60 * u.s, [])
    with pytest.raises(vv.SurfaceImpact):
        vv.propagate_covariance(leo(6450.0), P0, 2 * u.day,
                                [vv.J2(vv.EARTH), vv.AtmosphericDrag(0.05 * u.m**2 / u.kg)])



def test_noise_step_is_read_as_filter_orbit_reads_it():
    # was: TypeError "only 0-dimensional arrays ..." for two steps, UnitsError for plain
    # seconds (which filter_orbit takes): one reader of noise_step now serves both
    a = vv.propagate_covariance(leo(), P0, 600 * u.s, [], process_noise=1e-12,
                                noise_step=30 * u.s)
    b = vv.propagate_covariance(leo(), P0, 600 * u.s, [], process_noise=1e-12, noise_step=30.0)
    c = vv.propagate_covariance(leo(), P0, 600 * u.s, [], process_noise=1e-12,
                                noise_step=0.5 * u.min)
    assert np.array_equal(a.covariance, b.covariance) and np.array_equal(a.covariance, c.covariance)
    for step, error, match in (([30.0, 40.0] * u.s, vv.ShapeError, "one interval"),
                               (-1 * u.s, vv.InvalidInputError, "> 0"),
                               (0.0, vv.InvalidInputError, "> 0"),
                               (np.nan * u.s, vv.InvalidInputError, "finite|NaN"),
                               (30 * u.m, vv.UnitsError, None)):
        with pytest.raises(error, match=match):
            vv.propagate_covariance(leo(), P0, 600 * u.s, [], process_noise=1e-12,
                                    noise_step=step)

def test_a_state_with_pending_manoeuvres_is_refused():
    from visviva._containers import PENDING_MANEUVERS_ATTRIBUTE

    state = leo()
    setattr(state, PENDING_MANEUVERS_ATTRIBUTE, 1)
    with pytest.raises(vv.InvalidInputError, match="manoeuvre"):
        vv.propagate_covariance(state, P0, 60 * u.s, [])


def _fit():
    truth = vv.StateVectors([6878.0, 0.0, 0.0] * u.km, [0.0, 4.727, 5.967] * KMS, vv.EARTH,
                            epoch=EPOCH)
    forces = [vv.J2(vv.EARTH), vv.AtmosphericDrag(0.01 * u.m**2 / u.kg)]
    times = EPOCH + np.arange(0, 3 * 3600, 120) * u.s
    obs = vv.od.simulate_observations(truth, times, "position", 0.01 * u.km, None, forces, seed=3)
    return vv.fit_orbit(obs, truth, forces), truth, forces


def test_fit_to_covariance_at_tca_to_collision_probability():
    fit, truth, forces = _fit()
    tca = EPOCH + 1 * u.day
    at_tca = fit.propagate(tca)
    # one call equals the explicit one with the fit's dynamics
    same = vv.propagate_covariance(fit.state, fit.covariance, tca, forces)
    np.testing.assert_array_equal(at_tca.covariance, same.covariance)
    # the truth at TCA is inside the propagated uncertainty (chi-square, 6 dof, 99.9 %: 22.5)
    true_tca = vv.propagate_cowell(truth, tca, forces)
    dx = np.r_[(at_tca.r - true_tca.r).to_value(u.km), (at_tca.v - true_tca.v).to_value(KMS)]
    assert dx @ np.linalg.solve(at_tca.covariance, dx) < 22.5
    # a secondary 100 m above, crossing at right angles, 50 m sigma: Foster's Pc with the
    # propagated covariance (km^2 as a Quantity) equals Pc from the same matrix in m^2
    r1, v1 = at_tca.r, at_tca.v
    up = (r1 / np.linalg.norm(r1)).value
    normal = np.cross(r1.value, v1.value)
    r2 = r1 + 0.1 * u.km * up
    v2 = np.linalg.norm(v1) * normal / np.linalg.norm(normal)
    cov2 = np.diag([2.5e-3] * 3 + [1e-8] * 3)
    pc = vv.collision_probability(r1, v1, at_tca.covariance * u.km**2, r2, v2, cov2 * u.km**2,
                                  20 * u.m)
    pc_m = vv.collision_probability(r1.to(u.m), v1.to(u.m / u.s), at_tca.covariance * 1e6,
                                    r2.to(u.m), v2.to(u.m / u.s), cov2 * 1e6, 20 * u.m)
    assert 1e-3 < pc < 0.1
    np.testing.assert_allclose(pc, pc_m, rtol=1e-12)
    # and into a CDM (RTN, m) and back: the same covariance and probability
    cdm = vv.ConjunctionDataMessage.from_states(tca, r1, v1, at_tca.covariance * u.km**2, r2, v2,
                                                cov2 * u.km**2, collision_probability=pc)
    back = vv.read_cdm(cdm.to_kvn())
    c1 = back.object1.covariance
    assert rel(c1, at_tca.covariance * 1e6) < 1e-6
    again = vv.collision_probability(back.object1.r, back.object1.v, c1, back.object2.r,
                                     back.object2.v, back.object2.covariance, 20 * u.m)
    np.testing.assert_allclose(again, pc, rtol=1e-4)


def test_km_covariances_passed_as_returned_are_not_read_as_m2():
    # fit.covariance and propagate_covariance's .covariance are km-based; collision_probability
    # and the CDM read plain arrays as m^2: passed as returned they were read 10^6 too small
    # (a Pc of a well-tracked pair far off, silently); now converted from km, while arithmetic
    # on them gives a plain array read by the documented convention
    fit, _, _ = _fit()
    at_tca = fit.propagate(EPOCH + 1 * u.day)
    r1, v1 = at_tca.r, at_tca.v
    up = (r1 / np.linalg.norm(r1)).value
    normal = np.cross(r1.value, v1.value)
    r2 = r1 + 0.1 * u.km * up
    v2 = np.linalg.norm(v1) * normal / np.linalg.norm(normal)
    cov2 = np.diag([2.5e-3] * 3 + [1e-8] * 3) * u.km**2
    pc_q = vv.collision_probability(r1, v1, at_tca.covariance * u.km**2, r2, v2, cov2, 20 * u.m)
    pc = vv.collision_probability(r1, v1, at_tca.covariance, r2, v2, cov2, 20 * u.m)
    np.testing.assert_allclose(pc, pc_q, rtol=1e-13)
    pc_m = vv.collision_probability(r1, v1, at_tca.covariance * 1e6, r2, v2, cov2, 20 * u.m)
    np.testing.assert_allclose(pc_m, pc_q, rtol=1e-13)  # converted by hand: not twice
    np.testing.assert_allclose(
        vv.collision_probability(r1, v1, fit.covariance, r1 + 0.05 * u.km * up, v2, cov2,
                                 20 * u.m),
        vv.collision_probability(r1, v1, fit.covariance * u.km**2, r1 + 0.05 * u.km * up, v2,
                                 cov2, 20 * u.m), rtol=1e-13)
    cdm = vv.ConjunctionDataMessage.from_states(EPOCH + 1 * u.day, r1, v1, at_tca.covariance,
                                                r2, v2, cov2)
    assert rel(cdm.object1.covariance, at_tca.covariance * 1e6) < 1e-9
    # slices keep the unit; the printed form is a plain array's
    assert repr(at_tca.covariance[0]).startswith("array(")
    pos = at_tca.covariance[0][:3, :3] if at_tca.covariance.ndim == 3 else \
        at_tca.covariance[:3, :3]
    np.testing.assert_allclose(
        vv.collision_probability(r1, v1, pos, r2, v2, cov2[:3, :3], 20 * u.m), pc, rtol=1e-6)


def test_oem_segment_carries_propagated_covariances():
    fit, _, _ = _fit()
    t = EPOCH + np.arange(0, 4) * u.h
    out = fit.propagate(t, output_frame="RTN")
    from visviva.ccsds.oem import OEMSegment

    seg = OEMSegment.from_states(out.times, out.r.to_value(u.km), out.v.to_value(KMS),
                                 object_name="SAT", covariance=out.covariance,
                                 covariance_frame=out.frame)
    eph = vv.read_oem(vv.write_oem(seg))
    covs = eph.segments[0].covariances
    assert len(covs) == 4 and covs[0].frame == "RTN"
    # the matrices know their RTN axes: without covariance_frame= the OEM writer wrote them
    # as on REF_FRAME's axes (and OPM.from_state rotated them as such), silently
    from visviva._covariance import local_axes_of

    assert local_axes_of(out.covariance[2]) == "RTN"
    plain = OEMSegment.from_states(out.times, out.r.to_value(u.km), out.v.to_value(KMS),
                                   object_name="SAT", covariance=out.covariance)
    assert [c.frame for c in plain.covariances] == ["RTN"] * 4
    got = np.array([c.matrix for c in covs])
    assert rel(got, out.covariance).max() < 1e-15
    with pytest.raises(vv.InvalidInputError, match="one 6x6 matrix per epoch"):
        OEMSegment.from_states(out.times, out.r.to_value(u.km), out.v.to_value(KMS),
                               object_name="SAT", covariance=out.covariance[:2])


def test_a_covariance_in_m2_given_as_km2_warns():
    # a CDM's covariance (m^2) passed as plain numbers reads 1e6 too large: 100 km sigma
    cdm_like = np.diag([1e4, 4e4, 1e4, 1e-2, 1e-2, 1e-2])
    with pytest.warns(UserWarning, match="Quantity"):
        vv.propagate_covariance(leo(), cdm_like, 60 * u.s, [])
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = vv.propagate_covariance(leo(), cdm_like * u.m**2, 60 * u.s, [])
    assert out.position_sigma.to_value(u.m)[0] < 500


def _random_covariance(seed, scales=(3e-2, 3e-5)):
    rng = np.random.default_rng(seed)
    a = np.r_[[scales[0]] * 3, [scales[1]] * 3][:, None] * rng.normal(size=(6, 6))
    return a @ a.T


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31), frame=st.sampled_from(["RTN", "TNW", "VNB", "RIC", "gcrs"]),
       dt=st.floats(-7200.0, 7200.0))
def test_frames_round_trip_and_outputs_stay_covariances(seed, frame, dt):
    P = _random_covariance(seed)
    state = leo()
    # given in a frame, returned in the same frame at t = 0: the input back
    local = vv.propagate_covariance(state, P, 0 * u.s, [], output_frame=frame)
    back = vv.propagate_covariance(state, local.covariance, 0 * u.s, [], frame=frame,
                                  output_frame="GCRS")
    assert rel(back.covariance, vv.propagate_covariance(state, P, 0 * u.s, []).covariance) < 1e-13
    # at any time: symmetric, positive definite, and the local output is the GCRS one rotated
    g = vv.propagate_covariance(state, P, dt * u.s, [vv.J2(vv.EARTH)])
    f = vv.propagate_covariance(state, P, dt * u.s, [vv.J2(vv.EARTH)], output_frame=frame)
    np.testing.assert_array_equal(f.covariance, f.covariance.T)
    assert np.linalg.eigvalsh(f.covariance)[0] > 0
    np.testing.assert_allclose(np.trace(f.covariance[:3, :3]), np.trace(g.covariance[:3, :3]),
                               rtol=1e-12)


@pytest.mark.slow
def test_full_force_covariance_matches_a_monte_carlo_over_a_leo_day():
    # 2000 samples (10 m, 1 cm/s) through J4, drag, Sun, Moon and SRP with a conical shadow:
    # measured 0.012 (6 h) and 0.009 (1 day) of the correlation scale, RTN sigmas within 0.5 %
    rng = np.random.default_rng(11)
    n = 2000
    f = full_forces()
    t = np.array([21600.0, 86400.0])
    P = np.diag([1e-4] * 3 + [1e-10] * 3)
    out = vv.propagate_covariance(leo(), P, t * u.s, f)
    y = np.r_[leo().r.to_value(u.km), leo().v.to_value(KMS)]
    samples = rng.multivariate_normal(y, P, size=n)
    batch = vv.StateVectors(samples[:, :3] * u.km, samples[:, 3:] * KMS, vv.EARTH, epoch=EPOCH)
    res = vv.propagate_cowell(batch, t * u.s, f)
    yt = np.concatenate([res.r.to_value(u.km), res.v.to_value(KMS)], axis=-1)
    for k in range(t.size):
        sd = np.sqrt(np.diag(out.covariance[k]))
        err = (np.cov(yt[:, k].T) - out.covariance[k]) / np.outer(sd, sd)
        assert np.abs(err).max() < 4 * np.sqrt(2.0 / n)


def test_full_gravity_field_stm_matches_central_differences(tmp_path):
    # a degree-4 field (tesseral terms, the body frame turning): before, the STM held its
    # zonal part only, 5.6e-3 off after a day (the covariance 1.1 %); now 1.5e-8
    from test_perturbations import GFC_HEADER, GFC_ROWS
    from visviva.satellites.perturbations import SphericalHarmonics

    path = tmp_path / "field.gfc"
    path.write_text(GFC_HEADER + "\n".join(f"gfc {n} {m} {c:.15e} {s:.15e} 0 0"
                                           for n, m, c, s in GFC_ROWS) + "\n")
    f = [SphericalHarmonics(path, 4)]
    state = leo()
    t = np.array([5800.0, 86400.0])
    out = vv.propagate_covariance(state, P0, t * u.s, f, rtol=1e-13, atol=1e-13)
    fd = fd_stm(state, t, f)
    assert rel(out.stm, fd).max() < 1e-7


def test_gridded_density_partials_include_the_horizontal_gradient():
    # NRLMSIS drag: d a / d r against central differences of the right-hand side (1 m), the
    # drag part alone; before, the altitude slope alone (now the analytic gradient of the
    # B-spline density)
    pytest.importorskip("pymsis")
    from visviva.core.perturbations import cowell_rhs
    from visviva.core.variational import acceleration_partials
    from visviva.satellites.cowell import ForceModel

    drag = [vv.AtmosphericDrag(0.05 * u.m**2 / u.kg, model="nrlmsis", f107=150, f107a=150, ap=4)]
    model = ForceModel(vv.EARTH.gm_km3_s2, drag, (), EPOCH, (0.0, 86400.0))
    kepler = ForceModel(vv.EARTH.gm_km3_s2, [], (), EPOCH, (0.0, 86400.0))
    state = leo(6700.0)
    y = np.r_[state.r.to_value(u.km), state.v.to_value(KMS)]
    for t in (0.0, 40000.0):
        dadr, dadv, kep, _ = (np.zeros((3, 3)) for _ in range(4))
        acceleration_partials(t, y, *model.arrays(), dadr, dadv)
        acceleration_partials(t, y, *kepler.arrays(), kep, _)
        fd = np.zeros((3, 3))
        for j in range(3):
            a, b = np.zeros(6), np.zeros(6)
            yp, ym = y.copy(), y.copy()
            yp[j] += 1e-3
            ym[j] -= 1e-3
            cowell_rhs(t, yp, *model.arrays(), a)
            cowell_rhs(t, ym, *model.arrays(), b)
            fd[:, j] = (a[3:] - b[3:]) / 2e-3
        assert np.abs(dadr - fd).max() < 1e-4 * np.abs(dadr - kep).max()  # measured 3.6e-6


def test_nrlmsis_drag_stm_matches_central_differences_after_a_day():
    # the analytic gradient of the B-spline density in the variational equations: the STM of a
    # LEO day at 322 km with NRLMSIS drag against central differences of propagate_cowell
    # (measured 8.6e-9 after one orbit, 4.5e-8 after a day, at rtol 1e-13 and at the defaults)
    pytest.importorskip("pymsis")
    drag = [vv.AtmosphericDrag(0.05 * u.m**2 / u.kg, model="nrlmsis", f107=150, f107a=150, ap=4)]
    state = leo(6700.0)
    t = np.array([5800.0, 86400.0])
    fd = fd_stm(state, t, drag)
    out = vv.propagate_covariance(state, P0, t * u.s, drag)
    assert rel(out.stm, fd).max() < 5e-7


@pytest.mark.parametrize("frame", ["RTN", "GCRS"])
def test_process_noise_equals_the_integral_of_the_noise_through_the_stm(frame):
    # the exact growth, int_0^T Phi(T, tau) B Qc(tau) B^T Phi(T, tau)^T dtau (B = [0; I]), by
    # Simpson's rule on 5-s nodes of the STM; the 60-s SNC sum is within 0.2 % of it
    # (measured 0.035 % RTN, 0.12 % GCRS)
    from scipy.integrate import simpson

    from visviva.core.local_frames import RTN, local_axes

    q = np.array([1e-12, 4e-12, 2e-12])
    f = [vv.J2(vv.EARTH)]
    T = 5800.0
    out = vv.propagate_covariance(leo(), np.zeros((6, 6)), T * u.s, f, process_noise=q,
                                  process_noise_frame=frame)
    tau = np.linspace(0.0, T, 1161)
    g = vv.propagate_covariance(leo(), np.zeros((6, 6)), tau * u.s, f)
    r, v = g.r.to_value(u.km), g.v.to_value(KMS)
    vals = np.empty((tau.size, 6, 6))
    for k in range(tau.size):
        b = (g.stm[-1] @ np.linalg.inv(g.stm[k]))[:, 3:]
        qc = np.diag(q)
        if frame == "RTN":
            m = local_axes(r[k], v[k], RTN)
            qc = m.T @ qc @ m
        vals[k] = b @ qc @ b.T
    assert rel(out.covariance, simpson(vals, x=tau, axis=0)) < 2e-3


def test_field_hessian_matches_central_differences_of_the_field():
    # random coefficients to degree and order 12, a tilted and turning body frame: the
    # analytic Hessian of the potential against central differences of the acceleration
    from scipy.spatial.transform import Rotation

    from visviva.core import force_block as fb
    from visviva.core.force_partials import _add_harmonics_gradient
    from visviva.core.perturbations import FORCE_SIZE, accel_harmonics_inertial

    rng = np.random.default_rng(3)
    n_max = 12
    sh = np.zeros((2, n_max + 1, n_max + 1))
    for n in range(2, n_max + 1):
        sh[0, n, : n + 1] = rng.normal(size=n + 1) * 1e-6
        sh[1, n, 1: n + 1] = rng.normal(size=n) * 1e-6
    force = np.zeros(FORCE_SIZE)
    force[fb.GM] = vv.EARTH.gm_km3_s2
    force[fb.RADIUS] = vv.EARTH.radius_km
    force[fb.ROTATION_RATE] = 7.292115e-5
    force[fb.HARMONICS_DEGREE] = n_max
    force[fb.FRAME_MATRIX:fb.FRAME_MATRIX + 9] = Rotation.from_rotvec([0.01, -0.02, 0.3]) \
        .as_matrix().ravel()
    for t, pos in ((0.0, [7000.0, 100.0, 300.0]), (5000.0, [-2000.0, 5000.0, 4500.0]),
                   (100.0, [10.0, 20.0, 7000.0])):
        G = np.zeros((3, 3))
        _add_harmonics_gradient(t, *pos, force, sh, G)
        fd = np.zeros((3, 3))
        for j in range(3):
            a, b = np.zeros(3), np.zeros(3)
            e = np.eye(3)[j] * 1e-3
            accel_harmonics_inertial(t, *(np.array(pos) + e), force, sh, a)
            accel_harmonics_inertial(t, *(np.array(pos) - e), force, sh, b)
            fd[:, j] = (a - b) / 2e-3
        assert np.abs(G - fd).max() < 1e-8 * np.abs(fd).max()  # measured ~5e-10 (the FD's)
        np.testing.assert_allclose(G, G.T, rtol=0, atol=1e-14 * np.abs(G).max())
