"""The extended and unscented Kalman filters' square-root covariance forms
(visviva.od.square_root, visviva.od.extended, visviva.od.unscented): the same numbers as the covariance (Joseph) form when the problem is
well conditioned, and symmetric positive semi-definite covariances, filtered and smoothed, at
any conditioning (1 nm positions or 1 urad angles against a 1-100 km prior, rank-deficient
measurements, a component known exactly)."""

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from hypothesis import given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva.od import extended, simulate_observations
from visviva.od.dynamics import Dynamics
from visviva.od.square_root import (
    covariance,
    predict_factor,
    psd_factor,
    smooth_factor,
    smooth_factor_from_joint,
    smoother_gain,
    update_factor,
)

EPOCH = Time("2024-03-01T00:00:00", scale="utc")
GM = vv.EARTH.gm_km3_s2
Y_LEO = np.r_[6778.0, 0.0, 0.0, 0.0, 4.7645, 6.0102]  # near-circular, 400 km, 51.6 deg
EPS = np.finfo(float).eps


def _leo():
    return vv.StateVectors(Y_LEO[:3] * u.km, Y_LEO[3:] * u.km / u.s, vv.EARTH, epoch=EPOCH)


def _random_covariance(rng, n=6, scales=(1.0, 1.0, 1.0, 1e-3, 1e-3, 1e-3)):
    A = rng.standard_normal((n, n)) * np.asarray(scales)[:, None]
    return A @ A.T


def _least_eigenvalue_ratio(P):
    """Smallest eigenvalue over the largest, of the correlation matrix (units apart)."""
    d = np.sqrt(np.abs(np.diag(P)))
    d = np.where(d > 0, d, 1.0)
    lam = np.linalg.eigvalsh(P / np.outer(d, d))
    return lam[0] / lam[-1]


def _assert_psd(P, tol=1e-12):
    """Symmetric, variances >= 0, correlation eigenvalues >= 0 to round-off of the largest."""
    for p in np.reshape(P, (-1,) + np.shape(P)[-2:]):
        np.testing.assert_array_equal(p, p.T)
        assert np.all(np.diag(p) >= 0)
        assert _least_eigenvalue_ratio(p) >= -tol


def test_psd_factor_holds_semi_definite_matrices():
    rng = np.random.default_rng(1)
    P = _random_covariance(rng)
    L = psd_factor(P)
    np.testing.assert_allclose(L @ L.T, P, rtol=0, atol=1e-14 * np.abs(P).max())
    singular = P.copy()
    singular[2, :] = singular[:, 2] = 0.0  # a component known exactly
    L = psd_factor(singular)
    np.testing.assert_allclose(L @ L.T, singular, rtol=0, atol=1e-14 * np.abs(P).max())
    assert np.all(L[2] == 0.0)
    v = rng.standard_normal(6)
    rank1 = np.outer(v, v)  # rank 1: no Cholesky factor
    with pytest.raises(np.linalg.LinAlgError):
        np.linalg.cholesky(rank1)
    np.testing.assert_allclose(covariance(psd_factor(rank1)), rank1, rtol=0,
                               atol=1e-14 * np.abs(rank1).max())  # fmt: skip


def test_the_square_root_updates_equal_the_covariance_forms_when_well_conditioned():
    """Array-form measurement update = Joseph form (state and covariance), QR time update =
    Phi P Phi^T + N, square-root smoother step = the RTS covariance, to 1e-10 relative."""
    rng = np.random.default_rng(7)
    for _ in range(20):
        P = _random_covariance(rng)
        L = psd_factor(P)
        x = rng.standard_normal(6)
        m = int(rng.integers(1, 4))
        H = rng.standard_normal((m, 6))
        r = rng.uniform(0.1, 2.0, m)
        z = rng.standard_normal(m)
        S = H @ P @ H.T + np.diag(r)
        K = np.linalg.solve(S, H @ P).T
        ikh = np.eye(6) - K @ H
        joseph = ikh @ P @ ikh.T + (K * r) @ K.T
        x_new, L_new = update_factor(x, L, H, r, z)
        np.testing.assert_allclose(x_new, x + K @ z, rtol=1e-10, atol=1e-10 * np.abs(x).max())
        np.testing.assert_allclose(covariance(L_new), joseph, rtol=0,
                                   atol=1e-10 * np.abs(joseph).max())  # fmt: skip
        phi = np.eye(6) + 0.1 * rng.standard_normal((6, 6))
        N = _random_covariance(rng, scales=[1e-3] * 6)
        Lp = predict_factor(L_new, phi, psd_factor(N))
        Pp = phi @ joseph @ phi.T + N
        assert np.allclose(Lp, np.tril(Lp), rtol=0, atol=0)  # triangular: the smoother's solves
        np.testing.assert_allclose(covariance(Lp), Pp, rtol=0, atol=1e-10 * np.abs(Pp).max())
        C = smoother_gain(L_new, phi, Lp)
        np.testing.assert_allclose(C @ Pp, joseph @ phi.T, rtol=0,  # C P- = P Phi^T
                                   atol=1e-10 * np.abs(joseph).max())  # fmt: skip
        Ps_next = Pp - 0.3 * N  # some smoothed covariance below the predicted one
        smoothed = joseph + C @ (Ps_next - Pp) @ C.T
        Ls = smooth_factor(L_new, phi, psd_factor(N), C, psd_factor(Ps_next))
        np.testing.assert_allclose(covariance(Ls), smoothed, rtol=0,
                                   atol=1e-10 * np.abs(smoothed).max())  # fmt: skip
        # the unscented smoother's form, from the joint square root of (x_k, x-_k+1)
        J = np.block([[joseph, joseph @ phi.T], [phi @ joseph, Pp]])
        Lj = smooth_factor_from_joint(np.linalg.cholesky(0.5 * (J + J.T)), C,
                                      psd_factor(Ps_next))
        np.testing.assert_allclose(covariance(Lj), smoothed, rtol=0,
                                   atol=1e-10 * np.abs(smoothed).max())  # fmt: skip


def _covariance_form(monkeypatch):
    """The filter's old covariance form (Joseph update, Phi P Phi^T + N prediction, the
    smoother's P + C (P^s - P^-) C^T with C from the scaled predicted covariance) in place of
    the square-root updates, each result handed on as a factor."""
    from visviva.od import square_root

    def joseph(x, L, H, r, z):
        P = covariance(L)
        S = H @ P @ H.T + np.diag(r)
        K = np.linalg.solve(S, H @ P).T
        ikh = np.eye(P.shape[0]) - K @ H
        P = ikh @ P @ ikh.T + (K * r) @ K.T
        return x + K @ z, psd_factor(0.5 * (P + P.T))

    def predict(L, phi, noise):
        P = phi @ covariance(L) @ phi.T + (0.0 if noise is None else covariance(noise))
        return np.linalg.cholesky(0.5 * (P + P.T))

    def gain(L, phi, L_pred):
        Pp = covariance(L_pred)
        d = 1.0 / np.sqrt(np.diag(Pp))
        return (d[:, None] * np.linalg.solve(Pp * np.outer(d, d),
                                             d[:, None] * (phi @ covariance(L)))).T

    def smooth(L, phi, noise, C, L_next):
        P = covariance(L)
        Pp = phi @ P @ phi.T + (0.0 if noise is None else covariance(noise))
        Ps = P + C @ (covariance(L_next) - Pp) @ C.T
        return psd_factor(0.5 * (Ps + Ps.T))

    monkeypatch.setattr(extended, "update_factor", joseph)
    monkeypatch.setattr(extended, "predict_factor", predict)
    monkeypatch.setattr(square_root, "smoother_gain", gain)
    monkeypatch.setattr(square_root, "smooth_factor", smooth)


def _same_covariances(a, b, tol=1e-10):
    """Equal covariances to ``tol`` relative to their standard deviations."""
    s = np.sqrt(np.diagonal(b, axis1=1, axis2=2))
    s = np.where(s > 0, s, 1.0)
    np.testing.assert_allclose(a / s[:, :, None] / s[:, None, :],
                               b / s[:, :, None] / s[:, None, :], rtol=0, atol=tol)


def test_the_filter_gives_the_covariance_forms_numbers_on_a_normal_case(monkeypatch):
    """Range, range-rate and az/el from a station over 40 min, J2, process noise, 100 m and
    10 cm/s prior: states and covariances equal the Joseph-form filter's to 1e-10 relative."""
    st_ = vv.GroundStation(40 * u.deg, -105 * u.deg, 1.6 * u.km, name="GOLD")
    n = 80
    t = EPOCH + np.repeat(np.arange(60.0, 60.0 + 30.0 * n, 30.0), 3) * u.s
    obs = simulate_observations(_leo(), t, ["range", "range_rate", "azel"] * n,
                                [0.01, 1e-5, 1e-4] * n, station=st_,
                                perturbations=[vv.J2(vv.EARTH)], seed=2)  # fmt: skip
    start = vv.StateVectors((Y_LEO[:3] + 0.05) * u.km, Y_LEO[3:] * u.km / u.s, vv.EARTH,
                            epoch=EPOCH)  # fmt: skip
    P0 = np.diag([0.1**2] * 3 + [1e-4**2] * 3)
    kw = dict(perturbations=[vv.J2(vv.EARTH)], process_noise=1e-14, editing_sigma=None)
    # rows every 30 s for 40 min, seen or not: synthetic through-the-Earth rows (the algebra
    # of the two forms is under test, not visibility), which the filter names
    with pytest.warns(vv.errors.TrackingDataWarning, match="below their horizon"):
        new = vv.filter_orbit(obs, start, P0, **kw)
    with monkeypatch.context() as mp, pytest.warns(vv.errors.TrackingDataWarning):
        _covariance_form(mp)
        old = vv.filter_orbit(obs, start, P0, **kw)
    np.testing.assert_allclose(new.states, old.states, rtol=1e-10)
    _same_covariances(new.covariances, old.covariances)
    np.testing.assert_allclose(new.nis, old.nis, rtol=1e-9)


def test_coefficients_burns_and_smoother_give_the_covariance_forms_numbers(monkeypatch):
    """The prediction's noise taken as the prediction from P = 0 (burn execution error,
    Gauss-Markov drag, process noise) and the smoother: the same states and covariances,
    filtered and smoothed, as the covariance form, to 1e-10 relative."""
    m2kg = u.m**2 / u.kg
    forces = [vv.J2(vv.EARTH), vv.AtmosphericDrag(2.2 * 0.01 * m2kg)]
    burn = vv.ImpulsiveBurn(900 * u.s, [0.0, 0.002, 0.0] * u.km / u.s, "RTN",
                            delta_v_covariance=np.eye(3) * 1e-10)  # fmt: skip
    t = EPOCH + np.arange(60.0, 1800.0, 60.0) * u.s
    obs = simulate_observations(_leo(), t, "position", 0.01 * u.km, perturbations=forces,
                                maneuvers=[burn], seed=5)  # fmt: skip
    kw = dict(maneuvers=[burn], estimate="drag", parameter_sigma={"drag": 0.005 * m2kg},
              parameter_noise={"drag": (0.002 * m2kg, 3600 * u.s)}, process_noise=1e-14,
              editing_sigma=None, smoother=True)
    P0 = np.diag([0.1**2] * 3 + [1e-4**2] * 3)
    new = vv.filter_orbit(obs, _leo(), P0, forces, **kw)
    with monkeypatch.context() as mp:
        _covariance_form(mp)
        old = vv.filter_orbit(obs, _leo(), P0, forces, **kw)
    for a, b in ((new.states, old.states), (new.smoothed_states, old.smoothed_states)):
        np.testing.assert_allclose(a, b, rtol=1e-10)
    _same_covariances(new.full_covariances, old.full_covariances)
    _same_covariances(new.smoothed_covariances, old.smoothed_covariances)
    np.testing.assert_allclose(new.smoothed_parameter_sigma["drag"].value,
                               old.smoothed_parameter_sigma["drag"].value, rtol=1e-9)


def _positions(sigma_km, span_s=600.0):
    t = EPOCH + np.arange(0.0, span_s, 60.0) * u.s
    obs = simulate_observations(_leo(), t, "position", sigma_km * u.km, seed=1)
    return vv.Observations(time=t, kind="position", value=obs.values[:, :3], sigma=sigma_km)


def _truth(offsets):
    y, _ = Dynamics(GM, None, EPOCH, (0, offsets.max()), 1e-13, 1e-13).propagate(Y_LEO, offsets)
    return y


def _assert_consistent(flt, bound=30.0):
    """Finite NEES, mean below ``bound``, of the filtered and the smoothed states (the first
    epoch, the prior's, left out)."""
    truth = _truth(flt.offsets_s)
    for states, covs in ((flt.states, flt.covariances),
                         (flt.smoothed_states, flt.smoothed_covariances)):
        nees = [_nees(e, p) for e, p in zip(states[1:] - truth[1:], covs[1:], strict=True)]
        assert np.all(np.isfinite(nees)) and np.mean(nees) < bound


def _nees(e, P):
    """e^T P^+ e, through the pseudo-inverse at the matrix's own round-off."""
    d = np.sqrt(np.diag(P))
    corr_inv = np.linalg.pinv(P / np.outer(d, d), rcond=1e-13, hermitian=True)
    w = e / d
    return float(w @ corr_inv @ w)


@pytest.mark.parametrize("sigma_km", [1e-9, 1e-12])
def test_nanometre_positions_against_a_kilometre_prior_stay_positive_definite(sigma_km):
    """was: the Joseph form lost the smallest eigenvalues of a condition-1e24 covariance to
    round-off: correlation eigenvalues of -0.08 (1 nm) to -1.96 (1e-12 km) and negative position
    variances, silently; the smoother stopped ("Eigenvalues did not converge" or a
    ConvergenceError). In square-root form every filtered and smoothed covariance is
    symmetric positive definite, and the estimate sits within its sigma (finite NEES)."""
    obs = _positions(sigma_km)
    prior = np.diag([1.0] * 3 + [1e-6] * 3)  # 1 km, 1 m/s
    flt = vv.filter_orbit(obs, _leo(), prior, editing_sigma=None, smoother=True)
    _assert_psd(flt.covariances)
    _assert_psd(flt.smoothed_covariances)
    assert min(_least_eigenvalue_ratio(p) for p in flt.covariances) > 1e-3
    sig_r = np.sqrt(np.diag(flt.covariance)[:3])
    assert np.all(sig_r < 2 * sigma_km)  # the data fixed the position to their own precision
    _assert_consistent(flt)


def test_microradian_angles_against_a_100_km_prior_stay_positive_definite():
    """1 urad right ascension/declination from two stations against a 100 km, 100 m/s prior
    (the linearisation is poor, but the covariances must be PSD and the NEES finite)."""
    stations = [vv.GroundStation(40 * u.deg, -105 * u.deg, 1.6 * u.km, name="GOLD"),
                vv.GroundStation(-30 * u.deg, -70 * u.deg, 2.4 * u.km, name="CTIO")]
    n = 30
    t = EPOCH + np.repeat(np.arange(0.0, 30.0 * n, 30.0), 2) * u.s
    obs = simulate_observations(_leo(), t, "radec", 1e-6 * u.rad, station=stations * n, seed=4)
    prior = np.diag([100.0**2] * 3 + [0.1**2] * 3)
    start = vv.StateVectors((Y_LEO[:3] + [3.0, -2.0, 1.0]) * u.km, Y_LEO[3:] * u.km / u.s,
                            vv.EARTH, epoch=EPOCH)  # fmt: skip
    # synthetic rows, seen or not (the conditioning is under test), which the filter names;
    # the poor linearisation is named too (audit44: 1 urad angles across a 100 km prior)
    with pytest.warns(vv.errors.TrackingDataWarning, match="below their horizon"), \
            pytest.warns(RuntimeWarning, match="linearisation fails"):
        flt = vv.filter_orbit(obs, start, prior, editing_sigma=None, smoother=True)
    _assert_psd(flt.covariances)
    _assert_psd(flt.smoothed_covariances)
    nees = [_nees(e, p) for e, p in zip(flt.states - _truth(flt.offsets_s), flt.covariances,
                                         strict=True)]  # fmt: skip
    assert np.all(np.isfinite(nees))


def test_a_rank_deficient_measurement_and_an_exactly_known_component():
    """The same position measured twice at each epoch (H of rank 3 in 6 rows) at 1 nm, from a
    prior that knows z exactly (a zero row: semi-definite, no Cholesky factor): PSD
    covariances, z's variance stays 0 where no process noise reaches it."""
    single = _positions(1e-9)
    obs = vv.Observations(time=single.times[np.repeat(np.arange(len(single)), 2)],
                          kind="position", value=np.repeat(single.values[:, :3], 2, axis=0),
                          sigma=1e-9)  # fmt: skip
    prior = np.diag([1.0, 1.0, 0.0, 1e-6, 1e-6, 1e-6])
    flt = vv.filter_orbit(obs, _leo(), prior, editing_sigma=None)
    _assert_psd(flt.covariances)
    assert flt.covariances[0, 2, 2] == 0.0
    twice = np.sqrt(np.diag(flt.covariance)[:3])
    once = np.sqrt(np.diag(vv.filter_orbit(single, _leo(), np.diag([1.0] * 3 + [1e-6] * 3),
                                           editing_sigma=None).covariance)[:3])  # fmt: skip
    # each epoch's two copies weigh as one of sigma / sqrt(2)
    np.testing.assert_allclose(twice[:2], once[:2] / np.sqrt(2), rtol=0.05)


def test_a_prior_negative_within_round_off_is_taken_as_semi_definite():
    """A prior whose correlation matrix has an eigenvalue of -1e-12 (round-off of a rank-5
    covariance: accepted by the 1e-10 check) is factored with that eigenvalue at 0; beyond
    round-off it is refused with the reason (as before)."""
    rng = np.random.default_rng(5)
    v = rng.standard_normal((6, 5)) * np.r_[1.0, 1.0, 1.0, 1e-3, 1e-3, 1e-3][:, None]
    P = v @ v.T
    d = np.sqrt(np.diag(P))
    lam, vec = np.linalg.eigh(P / np.outer(d, d))
    lam[0] = -1e-12
    P = (vec * lam) @ vec.T * np.outer(d, d)
    P = 0.5 * (P + P.T)
    flt = vv.filter_orbit(_positions(1e-6), _leo(), P, editing_sigma=None)
    _assert_psd(flt.covariances[1:])
    lam[0] = -1e-6
    bad = (vec * lam) @ vec.T * np.outer(d, d)
    with pytest.raises(vv.InvalidInputError, match="not positive semi-definite"):
        vv.filter_orbit(_positions(1e-6), _leo(), 0.5 * (bad + bad.T))


@settings(max_examples=40, deadline=None)
@given(log_sigma=st.floats(-9.0, 3.0), log_prior=st.floats(-6.0, 4.0),
       seed=st.integers(0, 2**32 - 1))
def test_square_root_updates_stay_psd_at_any_conditioning(log_sigma, log_prior, seed):
    """Property: position fixes of sigma 1e-9 .. 1e3 km updating a correlated prior of
    1e-6 .. 1e4 km (velocity sigma 1e-3 of it per s), with two-body-like predictions between
    them, leave symmetric PSD covariances, filtered, predicted and smoothed."""
    rng = np.random.default_rng(seed)
    s, p = 10.0**log_sigma, 10.0**log_prior
    P = _random_covariance(rng, scales=[p] * 3 + [1e-3 * p] * 3) + np.diag([p**2] * 3 + [1e-6 * p**2] * 3)
    L = psd_factor(P)
    H = np.hstack([np.eye(3), np.zeros((3, 3))])
    phi = np.eye(6)
    phi[:3, 3:] = 60.0 * np.eye(3)
    x = np.zeros(6)
    filtered, predicted = [L], [L]
    for _ in range(5):
        x, L = update_factor(x, L, H, np.full(3, s**2), rng.standard_normal(3) * s)
        filtered[-1] = L
        L = predict_factor(L, phi)
        predicted.append(L)
        filtered.append(L)
    x, L = update_factor(x, L, H, np.full(3, s**2), rng.standard_normal(3) * s)
    filtered[-1] = L
    smoothed = [filtered[-1]]
    for k in range(len(filtered) - 2, -1, -1):
        C = smoother_gain(filtered[k], phi, predicted[k + 1])
        smoothed.insert(0, smooth_factor(filtered[k], phi, None, C, smoothed[0]))
    for group in (filtered, predicted, smoothed):
        _assert_psd(np.array([covariance(f) for f in group]), tol=1e-10)
    assert np.all(np.isfinite(x))


@settings(max_examples=40, deadline=None)
@given(log_sigma=st.floats(-9.0, 3.0), log_prior=st.floats(-6.0, 4.0),
       seed=st.integers(0, 2**32 - 1),
       params=st.sampled_from([(1.0, 2.0, 0.0), (0.5, 2.0, 0.0), (0.7, 2.0, 1.0)]))
def test_square_root_unscented_steps_stay_psd_at_any_conditioning(log_sigma, log_prior, seed,
                                                                   params):
    """Property, the unscented filter's steps (:mod:`visviva.od.unscented`): position fixes
    of sigma 1e-9 .. 1e3 km (through a mildly nonlinear model) updating a correlated prior of
    1e-6 .. 1e4 km through the sigma points (:func:`array_update`), predictions over 60 s of a
    mildly nonlinear transition (factor and joint factor), and the smoother from the joint
    factors: symmetric PSD covariances, filtered, predicted and smoothed, for weights with
    W_0^c > 0 and < 0."""
    from visviva.od.unscented import (
        _chain,
        _factor,
        _linearised,
        _moments,
        _points,
        array_update,
        unscented_weights,
    )

    rng = np.random.default_rng(seed)
    s, p = 10.0**log_sigma, 10.0**log_prior
    P = _random_covariance(rng, scales=[p] * 3 + [1e-3 * p] * 3) + np.diag([p**2] * 3 + [1e-6 * p**2] * 3)
    weights = unscented_weights(params)
    scale, wm, _ = weights
    x = np.r_[7000.0, 0.0, 0.0, 0.0, 7.5, 0.0]
    L = psd_factor(P)

    def measured(X):
        return X[:, :3] + 1e-6 * X[:, :3] ** 2 / 7000.0

    def flown(X):
        Y = X.copy()
        Y[:, :3] += 60.0 * X[:, 3:]
        Y[:, 3:] -= 60.0 * 1e-6 * X[:, :3]
        return Y

    filtered, predicted, joints = [], [L], [None]
    for k in range(6):
        X = _points(x, L, scale)
        Z = measured(X)
        _, dZ = _moments(Z, wm)
        x, L = array_update(x, L, dZ, weights, np.full(3, s**2), rng.standard_normal(3) * s)
        filtered.append(L)
        if k == 5:
            break
        X = _points(x, L, scale)
        x, dY = _moments(flown(X), wm)
        F, rows = _linearised(dY, weights)
        joints.append(_chain(None, L, F, rows))
        L = _factor(F, rows)
        predicted.append(L)
    n = 6
    smoothed = [filtered[-1]]
    for k in range(len(filtered) - 2, -1, -1):
        T = joints[k + 1]
        C = smoother_gain(T[:n, :n], None, predicted[k + 1], image=T[n:, :n])
        smoothed.insert(0, smooth_factor_from_joint(T, C, smoothed[0]))
    for group in (filtered, predicted, smoothed):
        _assert_psd(np.array([covariance(f) for f in group]), tol=1e-10)
    assert np.all(np.isfinite(x))


@pytest.mark.parametrize("sigma_km", [1e-9, 1e-12])
def test_the_square_root_unscented_filter_and_smoother_at_nanometres(sigma_km):
    """was: the unscented filter's Joseph-equivalent update on the full covariance left it
    singular to round-off after 1 nm positions against a 1 km prior (correlation eigenvalue
    3e-16) and its smoother raised ConvergenceError ("use method='ekf'"). In square-root form
    (:mod:`visviva.od.unscented`) every filtered and smoothed covariance is PSD with a least
    correlation eigenvalue far from round-off (measured 0.063 at 1 nm, 5e-7 at 1e-12 km),
    the position sigma is the data's and the NEES is finite (mean 4.4 / 6.3 filtered /
    smoothed at 1 nm, 9.4 / 11.6 at 1e-12 km)."""
    prior = np.diag([1.0] * 3 + [1e-6] * 3)
    flt = vv.filter_orbit(_positions(sigma_km), _leo(), prior, editing_sigma=None,
                          smoother=True, method="ukf")  # fmt: skip
    _assert_psd(flt.covariances)
    _assert_psd(flt.smoothed_covariances)
    assert min(_least_eigenvalue_ratio(p) for p in flt.smoothed_covariances) > 1e-8
    assert np.all(np.sqrt(np.diag(flt.covariance)[:3]) < 2 * sigma_km)
    _assert_consistent(flt)


def test_a_negative_centre_weight_needs_no_downdate_at_nanometres():
    """sigma_points (0.5, 2, 0): W_0^c = -0.25. was: a Cholesky downdate of the factor by the
    centre point (van der Merwe & Wan's form) failed at 1 mm and 1 nm positions against a 1 km
    prior (on the deterministic prediction's joint factor, where that term is round-off). The
    residue's positive form needs none: PSD covariances, and the state within 0.3 sigma of the
    extended filter's (measured 0.28). Weights whose unscented covariance is not positive by
    construction (beta + alpha^2 kappa / n < 0) are refused with the reason."""
    prior = np.diag([1.0] * 3 + [1e-6] * 3)
    obs = _positions(1e-9)
    flt = vv.filter_orbit(obs, _leo(), prior, editing_sigma=None, smoother=True, method="ukf",
                          sigma_points=(0.5, 2.0, 0.0))  # fmt: skip
    ekf = vv.filter_orbit(obs, _leo(), prior, editing_sigma=None)
    _assert_psd(flt.covariances)
    _assert_psd(flt.smoothed_covariances)
    assert np.all(np.abs(flt.states[-1] - ekf.states[-1])
                  < 0.5 * np.sqrt(np.diag(ekf.covariance)))  # fmt: skip
    with pytest.raises(vv.InvalidInputError, match="beta \\+ alpha\\^2 kappa"):
        vv.filter_orbit(obs, _leo(), prior, method="ukf", sigma_points=(0.5, -1.0, 0.0))


def test_an_unobserved_direction_keeps_its_prior_and_a_psd_covariance():
    """One right ascension/declination pair of 1 nrad at the epoch against a 1 km prior: the
    range along the line of sight is unobservable and keeps its 1 km^2, the two directions
    across it fall to centimetres: a covariance with one direction untouched, PSD, and PSD
    again after predicting it over 10 min and smoothing."""
    station = vv.GroundStation(40 * u.deg, -105 * u.deg, 1.6 * u.km, name="GOLD")
    t = EPOCH + np.array([0.0, 600.0]) * u.s
    obs = simulate_observations(_leo(), t, "radec", 1e-9 * u.rad, station=station, seed=6)
    # two synthetic rows (the covariance's algebra is under test), which the filter names;
    # 1 nrad angles across a 1 km prior are far from linear, which it names too (audit44)
    with pytest.warns(vv.errors.TrackingDataWarning, match="below their horizon"), \
            pytest.warns(RuntimeWarning, match="linearisation fails"):
        flt = vv.filter_orbit(obs, _leo(), np.diag([1.0] * 3 + [1e-6] * 3), editing_sigma=None,
                              smoother=True)  # fmt: skip
    for covs in (flt.covariances, flt.predicted_covariances, flt.smoothed_covariances):
        _assert_psd(covs)
    lam = np.linalg.eigvalsh(flt.covariances[0][:3, :3])
    np.testing.assert_allclose(lam[-1], 1.0, rtol=1e-6)
    # across it: the angles fix the position at the transmit time, r - v tau, so the 1 m/s
    # velocity prior times the light time (~0.03 s) leaves a few cm
    assert np.all(lam[:2] > 0) and np.all(lam[:2] < 1e-4**2)


@settings(max_examples=30, deadline=None)
@given(log_sigma=st.floats(-9.0, 3.0), log_prior=st.floats(-6.0, 4.0),
       noise=st.sampled_from([None, 1e-12]), method=st.sampled_from(["ekf", "ukf"]))
def test_the_filter_and_smoother_covariances_are_psd_at_any_conditioning(log_sigma, log_prior,
                                                                          noise, method):
    """Property, through vv.filter_orbit: positions of sigma 1e-9 .. 1e3 km against a prior of
    1e-6 .. 1e4 km (and 1e-3 of it in km/s), with or without process noise, extended or
    unscented (both in square-root form): every filtered, predicted and smoothed covariance
    symmetric PSD."""
    s, p = 10.0**log_sigma, 10.0**log_prior
    t = EPOCH + np.arange(0.0, 300.0, 60.0) * u.s
    obs = simulate_observations(_leo(), t, "position", s * u.km, seed=2)
    obs = vv.Observations(time=t, kind="position", value=obs.values[:, :3], sigma=s)
    prior = np.diag([p**2] * 3 + [(1e-3 * p) ** 2] * 3)
    flt = vv.filter_orbit(obs, _leo(), prior, editing_sigma=None, smoother=True,
                          process_noise=noise, method=method)  # fmt: skip
    for covs in (flt.covariances, flt.predicted_covariances, flt.smoothed_covariances):
        _assert_psd(covs, tol=1e-10)
