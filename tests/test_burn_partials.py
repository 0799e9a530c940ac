"""Covariances and STMs through manoeuvres (visviva.satellites.burn_partials): the local-frame
Jacobian against central differences, the STM across impulses and finite burns against
differenced propagate_cowell runs, the execution error against differenced Δv and a Monte
Carlo, backward runs, and the refusals."""

from __future__ import annotations

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from hypothesis import given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva.core.local_frames import to_inertial, to_inertial_jacobian

KMS = u.km / u.s
EPOCH = Time("2024-03-01T00:00:00", scale="utc")
P0 = np.diag([1e-4] * 3 + [1e-10] * 3)  # 10 m, 1 cm/s
FORCES = [vv.J2(vv.EARTH)]


def leo():
    return vv.KeplerianElements.from_semi_major_axis(
        7000.0 * u.km, 0.01, 51.6 * u.deg, 0.3, 0.2, 0.1, vv.EARTH, epoch=EPOCH).to_state()


def _y(state):
    return np.concatenate([state.r.to_value(u.km), state.v.to_value(KMS)], axis=-1)


def _batch(y0):
    return vv.StateVectors(y0[:, :3] * u.km, y0[:, 3:] * KMS, vv.EARTH, epoch=EPOCH)


def fd_stm(state, t, burns, forces=FORCES):
    """Central differences (1 m, 1 mm/s) of propagate_cowell through ``burns``: (T, 6, 6)."""
    y = _y(state)
    d = np.r_[[1e-3] * 3, [1e-6] * 3]
    res = vv.propagate_cowell(_batch(np.concatenate([y + np.diag(d), y - np.diag(d)])),
                              t * u.s, forces, maneuvers=burns, rtol=1e-13, atol=1e-13)
    yt = np.concatenate([res.r.to_value(u.km), res.v.to_value(KMS)], axis=-1)
    return np.transpose((yt[:6] - yt[6:]) / (2 * d[:, None, None]), (1, 2, 0))


def rel(a, b):
    return np.abs(a - b).max(axis=(-2, -1)) / np.abs(b).max(axis=(-2, -1))


@settings(max_examples=40, deadline=None)
@given(frame=st.sampled_from([0, 1, 2, 3]), seed=st.integers(0, 2**31))
def test_local_frame_jacobian_matches_central_differences(frame, seed):
    rng = np.random.default_rng(seed)
    for _ in range(3):
        y = np.r_[rng.normal(0, 5000, 3), rng.normal(0, 5, 3)]
        if np.linalg.norm(np.cross(y[:3], y[3:])) < 0.1 * np.linalg.norm(y[:3]) * np.linalg.norm(y[3:]):
            continue  # nearly radial: the frame is ill-conditioned, differences meaningless
        d = rng.normal(0, 1e-2, 3)
        jac = np.zeros((3, 6))
        to_inertial_jacobian(frame, y, *d, jac)
        num = np.zeros((3, 6))
        a, b = np.zeros(3), np.zeros(3)
        for j in range(6):
            h = 1e-3 if j < 3 else 1e-6
            yp, ym = y.copy(), y.copy()
            yp[j] += h
            ym[j] -= h
            to_inertial(frame, yp, *d, a)
            to_inertial(frame, ym, *d, b)
            num[:, j] = (a - b) / (2 * h)
        scale = np.linalg.norm(d) / np.array([np.linalg.norm(y[:3])] * 3 + [np.linalg.norm(y[3:])] * 3)
        assert np.all(np.abs(jac - num) <= 1e-7 * scale + 1e-18)  # measured ~1e-10 of scale
        if frame == 0:
            assert not jac.any()


@pytest.mark.parametrize("frame", ["RTN", "TNW", "VNB", "GCRS"])
def test_stm_through_an_impulse_matches_differenced_cowell_runs(frame):
    burn = vv.ImpulsiveBurn(1800 * u.s, [0.01, 0.02, -0.005] * KMS, frame)
    t = np.array([-2000.0, 1000.0, 1800.0, 2500.0, 6000.0])
    out = vv.propagate_covariance(leo(), P0, t * u.s, FORCES, maneuvers=[burn])
    ref = vv.propagate_cowell(leo(), t * u.s, FORCES, maneuvers=[burn])
    assert np.abs(out.r.to_value(u.km) - ref.r.to_value(u.km)).max() < 1e-6  # 1 mm
    num = fd_stm(leo(), t, [burn])
    assert np.all(rel(out.stm, num) < 1e-6)  # measured 2e-7 at worst (the FD's own error)
    if frame != "GCRS":  # the impulse's Jacobian matters: with Phi_burn = I the STM is off
        from visviva.satellites.burn_partials import impulse_jacobians

        y_b = np.r_[out.r[2].to_value(u.km), out.v[2].to_value(KMS)]
        y_b[3:] = burn.pre_burn_velocity(y_b[:3], y_b[3:])
        phi_b, _ = impulse_jacobians(burn, y_b)
        after = out.stm[3:] @ np.linalg.inv(out.stm[2])  # Phi(t, t_b+)
        before = np.linalg.inv(phi_b) @ out.stm[2]  # Phi(t_b-, 0)
        wrong = after @ before  # Phi(t, t_b+) I Phi(t_b-, 0)
        assert np.all(rel(wrong, num[3:]) > 1e-5)


def test_stm_across_the_burn_is_not_the_identity_on_local_axes():
    """Regression: before, the velocity's Jacobian of an RTN Δv was left out (Phi_burn = I)."""
    from visviva.satellites.burn_partials import impulse_jacobians

    y = _y(leo())
    phi_b, g = impulse_jacobians(vv.ImpulsiveBurn(0 * u.s, [0.0, 0.1, 0.0] * KMS, "RTN"), y)
    # d(T)/dv: T turns with the velocity's radial component, d T / d v_r ~ -R / v_t
    assert np.abs(phi_b[3:, 3:] - np.eye(3)).max() > 1e-3
    assert np.allclose(g[3:] @ g[3:].T, np.eye(3), atol=1e-14)  # M^T: a rotation


def test_backward_through_an_impulse_matches_differences_and_round_trips():
    burn = vv.ImpulsiveBurn(-1500 * u.s, [0.02, -0.01, 0.01] * KMS, "TNW")
    t = np.array([-4000.0, -1500.0, -600.0, 900.0])
    out = vv.propagate_covariance(leo(), P0, t * u.s, FORCES, maneuvers=[burn])
    num = fd_stm(leo(), t, [burn])
    assert np.all(rel(out.stm, num) < 1e-6)
    # forward from the earliest state through the burn returns P0 at the epoch
    first = vv.StateVectors(out.r[0], out.v[0], vv.EARTH, epoch=EPOCH - 4000 * u.s)
    back = vv.propagate_covariance(first, out.covariance[0], [4000.0] * u.s, FORCES,
                                   maneuvers=[vv.ImpulsiveBurn(2500 * u.s, burn.delta_v, "TNW")])
    assert np.abs(back.r.to_value(u.km)[0] - _y(leo())[:3]).max() < 1e-6
    assert rel(back.covariance[0], P0) < 1e-6


def test_execution_error_matches_differenced_delta_v_and_adds_to_the_velocity():
    dv = np.array([0.0, 0.002, 0.0])
    c = np.diag([1e-8, 4e-8, 1e-8])  # 0.1 to 0.2 m/s on the RTN axes (km^2/s^2)
    burn = vv.ImpulsiveBurn(1200 * u.s, dv * KMS, "RTN", delta_v_covariance=c)
    t = np.array([600.0, 1200.0, 4000.0])
    zero = np.zeros((6, 6))
    out = vv.propagate_covariance(leo(), zero, t * u.s, FORCES, maneuvers=[burn])
    assert not out.covariance[0].any()  # before the burn: no uncertainty
    # at the burn: M^T C M on the velocity block
    from visviva.core.local_frames import RTN, local_axes

    y_at = np.r_[out.r[1].to_value(u.km), out.v[1].to_value(KMS) - 0.0]
    m = local_axes(y_at[:3], y_at[3:] - burn.delta_v_inertial(y_at[:3], y_at[3:] - 0), RTN)
    assert np.allclose(out.covariance[1][3:, 3:], m.T @ c @ m, rtol=1e-6, atol=1e-20)
    # later: S C S^T with S from differenced Δv
    s = np.zeros((6, 3))
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1e-6
        runs = [vv.propagate_cowell(leo(), t[2] * u.s, FORCES, rtol=1e-13, atol=1e-13,
                                    maneuvers=[vv.ImpulsiveBurn(1200 * u.s, (dv + sg * e) * KMS,
                                                                "RTN")]) for sg in (1, -1)]
        s[:, k] = (_y(runs[0]) - _y(runs[1])) / 2e-6
    assert rel(out.covariance[2], s @ c @ s.T) < 1e-6


def test_magnitude_and_pointing_sigma_build_the_gates_covariance():
    dv = np.array([0.003, 0.004, 0.0])  # 5 m/s
    burn = vv.ImpulsiveBurn(0 * u.s, dv * KMS, "VNB", magnitude_sigma=1 * u.percent,
                            pointing_sigma=1 * u.deg)
    c = burn.execution_covariance
    u_hat = dv / np.linalg.norm(dv)
    assert np.isclose(u_hat @ c @ u_hat, (0.01 * 0.005) ** 2, rtol=1e-12)
    across = np.array([-0.8, 0.6, 0.0])
    assert np.isclose(across @ c @ across, (np.radians(1) * 0.005) ** 2, rtol=1e-12)
    assert np.isclose(np.array([0, 0, 1.0]) @ c @ np.array([0, 0, 1.0]),
                      (np.radians(1) * 0.005) ** 2, rtol=1e-12)
    only_mag = vv.ImpulsiveBurn(0 * u.s, dv * KMS, magnitude_sigma=0.01)
    assert np.isclose(np.trace(only_mag.execution_covariance), (0.01 * 0.005) ** 2)
    q = vv.ImpulsiveBurn(0 * u.s, dv * KMS, delta_v_covariance=np.eye(3) * (u.m / u.s) ** 2)
    assert np.allclose(q.execution_covariance, np.eye(3) * 1e-6)


def test_execution_error_matches_a_monte_carlo_of_cowell():
    rng = np.random.default_rng(5)
    dv = np.array([0.0, 0.005, 0.001])
    burn = vv.ImpulsiveBurn(900 * u.s, dv * KMS, "RTN", magnitude_sigma=0.02,
                            pointing_sigma=1 * u.deg)
    t = 3600.0
    out = vv.propagate_covariance(leo(), P0, t * u.s, FORCES, maneuvers=[burn])
    # Monte Carlo: initial states from P0, and Δv errors drawn from the execution covariance
    n = 400
    y0 = _y(leo()) + rng.multivariate_normal(np.zeros(6), P0, n)
    dvs = dv + rng.multivariate_normal(np.zeros(3), burn.execution_covariance, n)
    ends = np.array([_y(vv.propagate_cowell(_batch(y0[i:i + 1]), t * u.s, FORCES,
                                            maneuvers=[vv.ImpulsiveBurn(900 * u.s, d * KMS,
                                                                        "RTN")]))[0]
                     for i, d in enumerate(dvs)])
    sample = np.cov(ends.T)
    sig_lin = np.sqrt(np.diag(out.covariance))
    sig_mc = np.sqrt(np.diag(sample))
    assert np.all(np.abs(sig_mc / sig_lin - 1) < 0.15)  # 400 samples: ~3.5 % sigma of a sigma


def test_finite_burn_stm_matches_differenced_cowell_runs():
    t = np.array([-200.0, 300.0, 700.0, 1500.0])
    for frame in ("RTN", "VNB"):
        burn = vv.FiniteBurn(200 * u.s, 600 * u.s, [0.2, 1.0, 0.1], frame, thrust=400 * u.N,
                             mass=800 * u.kg, isp=300 * u.s)
        out = vv.propagate_covariance(leo(), P0, t * u.s, FORCES, maneuvers=[burn])
        ref = vv.propagate_cowell(leo(), t * u.s, FORCES, maneuvers=[burn])
        assert np.abs(out.r.to_value(u.km) - ref.r.to_value(u.km)).max() < 1e-6
        num = fd_stm(leo(), t, [burn])
        assert np.all(rel(out.stm, num) < 1e-6)  # measured 3e-7 at worst (the FD)


def test_backward_through_a_finite_burn_matches_differences():
    burn = vv.FiniteBurn(-900 * u.s, 500 * u.s, [0, 1.0, 0], "TNW", acceleration=5e-6 * u.km / u.s**2)
    t = np.array([-1500.0, -600.0, 100.0])
    out = vv.propagate_covariance(leo(), P0, t * u.s, FORCES, maneuvers=[burn])
    assert np.all(rel(out.stm, fd_stm(leo(), t, [burn])) < 1e-6)


def test_pending_state_needs_maneuvers_and_is_used_with_them():
    from visviva._containers import PENDING_MANEUVERS_ATTRIBUTE

    state = leo()
    setattr(state, PENDING_MANEUVERS_ATTRIBUTE, 1)
    with pytest.raises(vv.InvalidInputError, match="maneuvers=opm.burns"):
        vv.propagate_covariance(state, P0, 60 * u.s, [])
    burn = vv.ImpulsiveBurn(30 * u.s, [0, 0.001, 0] * KMS, "RTN")
    out = vv.propagate_covariance(state, P0, 60 * u.s, [], maneuvers=[burn])
    assert out.covariance.shape == (6, 6)


def test_bad_execution_errors_are_refused():
    dv = [0, 0.001, 0] * KMS
    for kw, match in (({"delta_v_covariance": np.eye(2)}, "3 x 3"),
                      ({"delta_v_covariance": np.eye(3) * u.m**2}, "speed"),
                      ({"delta_v_covariance": -np.eye(3)}, "negative"),
                      ({"delta_v_covariance": np.eye(3), "magnitude_sigma": 0.1}, "not both"),
                      ({"magnitude_sigma": -0.1}, ">= 0"), ({"pointing_sigma": [1, 2] * u.deg}, "one")):
        with pytest.raises((vv.InvalidInputError, vv.UnitsError), match=match):
            vv.ImpulsiveBurn(0 * u.s, dv, "RTN", **kw)
    with pytest.raises(vv.InvalidInputError, match="zero"):
        vv.ImpulsiveBurn(0 * u.s, [0, 0, 0] * KMS, magnitude_sigma=0.1)


@pytest.mark.parametrize("t_burn", [0.0, 1300.0, -1300.0])
def test_process_noise_through_a_burn_keeps_its_execution_error(t_burn):
    """With a vanishing process noise the recursion through the burn (the execution error added
    on arrival past it) gives the covariance of the plain map, either side of the epoch, with
    the burn at the epoch too."""
    burn = vv.ImpulsiveBurn(t_burn * u.s, [0.0, 0.003, 0.001] * KMS, "RTN",
                            magnitude_sigma=0.05, pointing_sigma=2 * u.deg)
    t = np.array([-3000.0, -1300.0, 0.0, 1300.0, 3000.0])
    plain = vv.propagate_covariance(leo(), P0, t * u.s, FORCES, maneuvers=[burn])
    noisy = vv.propagate_covariance(leo(), P0, t * u.s, FORCES, maneuvers=[burn],
                                    process_noise=1e-30, noise_step=100 * u.s)
    assert np.all(rel(noisy.covariance, plain.covariance) < 1e-8)
    crossed = (t >= t_burn) if t_burn >= 0 else (t < t_burn)
    grew = np.trace(plain.covariance[:, 3:, 3:], axis1=-2, axis2=-1)
    base = vv.propagate_covariance(leo(), P0, t * u.s, FORCES,
                                   maneuvers=[vv.ImpulsiveBurn(t_burn * u.s, burn.delta_v, "RTN")])
    extra = grew - np.trace(base.covariance[:, 3:, 3:], axis1=-2, axis2=-1)
    assert np.all(extra[crossed] > 1e-9) and np.allclose(extra[~crossed], 0.0, atol=1e-18)


def test_an_opm_covariance_is_carried_through_its_manoeuvre():
    from visviva.ccsds.opm import OPM, Maneuver

    state = leo()
    cov = np.diag([1e-4] * 3 + [1e-10] * 3)
    man = Maneuver(EPOCH + 1200 * u.s, 0 * u.s, 0 * u.kg, "RTN", [0.0, 0.003, 0.0] * KMS)
    opm = vv.read_opm(vv.write_opm(OPM.from_state(state, object_name="SAT", maneuvers=[man],
                                                  covariance=cov)))
    out = vv.propagate_covariance(opm.state, opm.covariance, [600, 3000] * u.s,
                                  maneuvers=opm.burns())
    ref = vv.propagate_covariance(leo(), cov, [600, 3000] * u.s,
                                  maneuvers=[vv.ImpulsiveBurn(1200 * u.s, man.delta_v, "RTN")])
    assert np.all(rel(out.covariance, ref.covariance) < 1e-9)
    assert len(out.impulses) == 1 and out.delta_v_partials.shape == (2, 6, 3)
    assert not out.delta_v_partials[0].any() and out.delta_v_partials[1].any()
