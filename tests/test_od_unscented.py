"""The unscented Kalman filter and smoother of vv.filter_orbit (method="ukf"): the unscented
transform itself, equality with the EKF on a nearly linear problem, consistency where the EKF is
overconfident (a large a priori covariance), angles averaged across 0 / 2 pi, process noise, and
bad input."""

import numpy as np
import pytest
from astropy import units as u
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

import visviva as vv
from test_od_filter import (
    EPOCH,
    GM,
    J2,
    P0,
    STATIONS,
    Y_ECC,
    Y_LEO,
    _nees,
    _noisy,
    _sigmas_apart,
    _state,
    _truth_at,
    _vec,
)
from visviva.od import simulate_observations
from visviva.od.light_time import model
from visviva.od.unscented import sigma_points, unscented_weights


@given(st.floats(0.05, 2.0), st.floats(0.0, 3.0), st.floats(-2.0, 3.0), st.integers(0, 2**32 - 1))
@settings(max_examples=30, deadline=None)
def test_the_sigma_points_have_the_mean_and_covariance_they_stand_for(alpha, beta, kappa, seed):
    """Weights sum to 1; the points' weighted mean and covariance are (x, P) (a linear map is
    carried exactly), also for a singular P (a zero variance)."""
    scale, wm, wc = unscented_weights((alpha, beta, kappa))
    assert wm.sum() == pytest.approx(1.0, abs=1e-12)
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((6, 6)) * np.r_[1.0, 1.0, 1.0, 1e-3, 1e-3, 1e-3]
    x = np.r_[7000.0, 10.0, -20.0, 0.1, 7.5, 0.3]
    for P in (A @ A.T, np.diag([1.0, 1.0, 0.0, 1e-6, 1e-6, 1e-6])):
        X = sigma_points(x, P, scale)
        m = x + wm @ (X - x)
        np.testing.assert_allclose(m, x, rtol=0, atol=1e-9 * np.sqrt(np.diag(P)).max())
        d = X - x
        cov = (wc * d.T) @ d  # the central point's d is 0: its weight W_0^c drops out
        np.testing.assert_allclose(cov, P, rtol=0, atol=1e-9 * np.abs(P).max())


def _whitened_difference(Pa, Pb):
    """Largest |L^-1 (Pa - Pb) L^-T| over the epochs, Pb = L L^T (0 when equal; 0.01: a 1 %
    change of a variance along some direction)."""
    L = np.linalg.cholesky(Pb)
    d = np.linalg.solve(L, np.swapaxes(np.linalg.solve(L, Pa - Pb), 1, 2))
    return float(np.abs(d).max())


@pytest.fixture(scope="module")
def positions():
    t = EPOCH + np.arange(60, 3 * 3600, 120) * u.s
    return simulate_observations(_state(Y_ECC), t, "position", 0.001 * u.km, seed=3)


def test_ukf_equals_ekf_on_a_nearly_linear_problem(positions):
    """Position fixes, two-body, a 10 m / 1 cm/s prior: filtered and smoothed states agree to
    1e-3 sigma at every epoch (measured 1.2e-5 and 6.9e-5), filtered covariances to 1e-4
    (measured 1.1e-6), smoothed ones to 2e-3 (8.4e-4: the smoother takes the small difference
    of the prior's covariance, 100 times the final one, and the prediction's, where the sigma
    points' second-order terms remain); the UKF's smoothed first state is the batch estimate
    (9.5e-5 sigma; the EKF's 8.2e-5)."""
    guess = _state(Y_ECC + [0.005, -0.003, 0.002, 3e-6, 0.0, -2e-6])
    prior = np.diag([1e-2] * 3 + [1e-8] * 3)
    e = vv.filter_orbit(positions, guess, prior, smoother=True, editing_sigma=None)
    f = vv.filter_orbit(positions, guess, prior, smoother=True, editing_sigma=None,
                        method="UKF")  # fmt: skip
    assert f.method == "ukf" and e.method == "ekf"
    for k in range(len(f.times)):
        assert _sigmas_apart(f.states[k] - e.states[k], e.covariances[k]) < 1e-3
        assert _sigmas_apart(f.smoothed_states[k] - e.smoothed_states[k],
                             e.smoothed_covariances[k]) < 1e-3  # fmt: skip
    assert _whitened_difference(f.covariances, e.covariances) < 1e-4
    assert _whitened_difference(f.smoothed_covariances, e.smoothed_covariances) < 2e-3
    np.testing.assert_allclose(f.nis, e.nis, rtol=1e-4)
    fit = vv.fit_orbit(positions, guess, outlier_sigma=None)
    assert _sigmas_apart(_vec(f.first_state) - _vec(fit.state), fit.covariance) < 1e-3
    for P in (f.covariances, f.smoothed_covariances):
        np.testing.assert_array_equal(P, np.swapaxes(P, 1, 2))
        assert np.all(np.linalg.eigvalsh(P) > 0)
    assert repr(f).endswith("smoothed, unscented)") and "unscented" not in repr(e)


@pytest.fixture(scope="module")
def tracking_j2():
    """Two stations, range / range rate / az-el every 30 s when above 10 deg, 3 h, J2."""
    grid = EPOCH + np.arange(0, 3 * 3600, 30) * u.s
    return vv.od.simulate_tracking(_state(Y_ECC), STATIONS, grid, J2, seed=False)


def test_ukf_is_consistent_from_a_large_prior_where_the_ekf_is_not(tracking_j2):
    """An IOD-like prior, 1 km and 1 m/s, 20 Monte Carlo runs: the EKF's NEES averages 14.1,
    above the chi-square band (3.9-8.7), and 25 at the last epoch; the UKF's averages 6.2, its
    smoother's 7.7, both inside; the UKF's final position and velocity errors match its formal
    sigmas. The NIS per kind is in its band for both filters (range, range rate, az/el at
    1.01, 1.03, 0.96 of the chi-square mean for the UKF, 1.02, 1.04, 0.96 for the EKF): the
    innovations do not show the EKF's overconfidence, the errors against the truth do."""
    rng = np.random.default_rng(7)
    runs = 20
    prior = np.diag([1.0**2] * 3 + [1e-3**2] * 3)
    nees = {"ekf": [], "ukf": []}
    smoothed, err2, formal2, nis = [], [], [], {}
    truth = None
    for _ in range(runs):
        obs = _noisy(tracking_j2, rng)
        x0 = Y_ECC + rng.multivariate_normal(np.zeros(6), prior)
        for method in ("ekf", "ukf"):
            f = vv.filter_orbit(obs, _state(x0), prior, J2, smoother=method == "ukf",
                                editing_sigma=None, method=method)  # fmt: skip
            if truth is None:
                truth = _truth_at(Y_ECC, J2, f.offsets_s)
            nees[method].append(_nees(f.states - truth, f.covariances))
            for k in ("range", "range_rate", "azel"):
                nis[method, k] = nis.get((method, k), 0.0) + f.nis[obs.kinds == k].sum()
        smoothed.append(_nees(f.smoothed_states - truth, f.smoothed_covariances))
        d = f.states[-1] - truth[-1]
        err2.append([d[:3] @ d[:3], d[3:] @ d[3:]])
        formal2.append([np.trace(f.covariances[-1][:3, :3]), np.trace(f.covariances[-1][3:, 3:])])
    lo, hi = stats.chi2.ppf([0.001, 0.999], 6 * runs) / runs
    ekf, ukf = np.array(nees["ekf"]), np.array(nees["ukf"])
    assert ekf.mean() > hi  # overconfident (14.1)
    assert lo < ukf.mean() < hi and lo < np.mean(smoothed) < hi
    per_epoch = ukf.mean(axis=0)
    assert np.all(per_epoch < stats.chi2.ppf(0.9999, 6 * runs) / runs)
    assert ekf.mean(axis=0)[-1] > stats.chi2.ppf(0.9999, 6 * runs) / runs
    for (method, k), total in nis.items():
        dof = runs * int(tracking_j2.dims[tracking_j2.kinds == k].sum())
        if method == "ukf":
            assert stats.chi2.ppf(0.0005, dof) < total < stats.chi2.ppf(0.9995, dof), k
    # position and velocity errors against the truth at the last epoch, as the covariance says
    rms, formal = np.sqrt(np.mean(err2, axis=0)), np.sqrt(np.mean(formal2, axis=0))
    assert rms[0] < 0.02 and rms[1] < 5e-5  # km, km/s (8.2 m, 23 mm/s; formal 8.5 m, 24 mm/s)
    assert np.all((0.5 < rms / formal) & (rms / formal < 1.5))


@pytest.mark.parametrize("seed", [1, 4])
def test_ukf_survives_a_10_km_prior_where_the_ekf_diverges(tracking_j2, seed):
    """A 10 km, 10 m/s prior (a start 9.5 and 18 km off): the EKF loses the orbit
    (ConvergenceError in its first pass), the UKF ends 14 and 4 m from the truth (formal 9 m),
    its smoother's first state 29 and 63 m (formal 65 m)."""
    prior = np.diag([10.0**2] * 3 + [1e-2**2] * 3)
    x0 = Y_ECC + np.random.default_rng(seed).multivariate_normal(np.zeros(6), prior)
    obs = _noisy(tracking_j2, np.random.default_rng(100 + seed))
    with pytest.raises(vv.ConvergenceError, match="diverged"):
        vv.filter_orbit(obs, _state(x0), prior, J2)
    f = vv.filter_orbit(obs, _state(x0), prior, J2, method="ukf", smoother=True)
    truth = _truth_at(Y_ECC, J2, f.offsets_s)
    err = np.linalg.norm(f.states[-1, :3] - truth[-1, :3])
    assert err < 0.02 and err < 3 * np.sqrt(np.trace(f.covariances[-1][:3, :3]))
    e0 = np.linalg.norm(f.smoothed_states[0, :3] - truth[0, :3])
    assert e0 < 2 * np.sqrt(np.trace(f.smoothed_covariances[0][:3, :3]))


def _line_of_sight_case(kind):
    """A state 1500 km from GOLD looking along GCRS +x (RA = 0) or due north (az = 0), its
    noise-free angles, and a guess 300 m off across the line of sight."""
    t = EPOCH + [0.0] * u.s
    probe = vv.Observations(time=t, kind=kind, value=[[0.0, 0.0]], sigma=[1e-5],
                            station=[STATIONS[0]], light_time=False)  # fmt: skip
    site, _, enu = probe.sites()
    east, north, up = enu[0]
    if kind == "radec":
        los, across = np.r_[np.cos(0.4), 0.0, np.sin(0.4)], np.r_[0.0, 1.0, 0.0]
    else:
        los, across = np.cos(0.5) * north + np.sin(0.5) * up, east
    r = site[0] + 1500.0 * los
    w = np.cross(np.r_[0.0, 0.0, 1.0], r)
    truth = np.r_[r, np.sqrt(GM / np.linalg.norm(r)) * w / np.linalg.norm(w)]
    h, _ = model(probe, truth[None], GM)
    obs = vv.Observations(time=t, kind=kind, value=[h[0, :2]], sigma=[1e-5],
                          station=[STATIONS[0]], light_time=False)  # fmt: skip
    return obs, truth, truth - np.r_[0.3 * across, 0, 0, 0]


@pytest.mark.parametrize("kind", ["radec", "azel"])
def test_angles_of_sigma_points_on_both_sides_of_zero_are_averaged_as_angles(kind):
    """The sigma points' azimuth / right ascension straddle 0 = 2 pi (some near 0, some near
    2 pi): the predicted angle is their circular mean, so the UKF update equals the EKF's
    (0.01 sigma apart, the same pre-fit residual, nothing rejected); an arithmetic mean would be
    near pi and the row rejected."""
    obs, truth, x0 = _line_of_sight_case(kind)
    prior = np.diag([1.0] * 3 + [1e-6] * 3)
    scale, _, _ = unscented_weights()
    h, _ = model(obs, sigma_points(x0, prior, scale), GM, np.zeros(13, dtype=int))
    assert h[:, 0].max() > 6.28 and h[:, 0].min() < 0.01  # both sides of 0 = 2 pi
    start = _state(x0)
    e = vv.filter_orbit(obs, start, prior)
    f = vv.filter_orbit(obs, start, prior, method="ukf")
    assert not f.rejected.any()
    assert f.prefit_residuals[0, 0] == pytest.approx(e.prefit_residuals[0, 0], abs=1e-9)
    assert abs(f.prefit_residuals[0, 0]) < 3e-4  # the 300 m offset, not ~pi
    assert f.nis[0] == pytest.approx(e.nis[0], rel=1e-3)
    assert _sigmas_apart(f.states[0] - e.states[0], e.covariances[0]) < 0.05
    assert np.linalg.norm(f.states[0, :3] - truth[:3]) < 0.001  # km: the offset is observed


@pytest.fixture(scope="module")
def tracking_drag():
    """Tracking of a 400 km orbit over 6 h whose truth has drag (0.05 m^2/kg)."""
    grid = EPOCH + np.arange(0, 6 * 3600, 30) * u.s
    forces = J2 + [vv.AtmosphericDrag(0.05 * u.m**2 / u.kg)]
    obs = vv.od.simulate_tracking(_state(Y_LEO), STATIONS, grid, forces, seed=11)
    return obs, forces


def test_ukf_process_noise_absorbs_an_unmodelled_drag_where_none_diverges(tracking_drag):
    """The EKF's SNC on the UKF's sub-steps: the same NEES (5.65) and final error (8.8 m) as
    the EKF; without process noise the UKF loses the orbit (ConvergenceError) like the EKF."""
    obs, forces = tracking_drag
    with pytest.raises(vv.ConvergenceError, match="diverged"):
        vv.filter_orbit(obs, _state(Y_LEO), P0, J2, method="ukf")
    e = vv.filter_orbit(obs, _state(Y_LEO), P0, J2, process_noise=1e-14)
    f = vv.filter_orbit(obs, _state(Y_LEO), P0, J2, process_noise=1e-14, method="ukf",
                        smoother=True)  # fmt: skip
    truth = _truth_at(Y_LEO, forces, f.offsets_s)
    nees = _nees(f.states - truth, f.covariances)
    assert 3.0 < nees.mean() < 10.0
    assert nees.mean() == pytest.approx(_nees(e.states - truth, e.covariances).mean(), rel=0.02)
    assert np.linalg.norm(f.states[-1, :3] - truth[-1, :3]) < 0.01
    assert not f.rejected.any()
    for k in range(len(f.times)):
        assert _sigmas_apart(f.states[k] - e.states[k], e.covariances[k]) < 0.05


def test_ukf_bad_input(positions):
    good = _state(Y_ECC)
    with pytest.raises(vv.InvalidInputError, match='"ekf".*"ukf".*got \'kalman\''):
        vv.filter_orbit(positions, good, P0, method="kalman")
    with pytest.raises(vv.InvalidInputError, match="method must be"):
        vv.filter_orbit(positions, good, P0, method=None)
    with pytest.raises(vv.InvalidInputError, match='method="ukf"'):
        vv.filter_orbit(positions, good, P0, sigma_points=(1.0, 2.0, 0.0))
    with pytest.raises(vv.InvalidInputError, match="three numbers"):
        vv.filter_orbit(positions, good, P0, method="ukf", sigma_points=(1.0, 2.0))
    with pytest.raises(vv.InvalidInputError, match="alpha > 0"):
        vv.filter_orbit(positions, good, P0, method="ukf", sigma_points=(0.0, 2.0, 0.0))
    with pytest.raises(vv.InvalidInputError, match="kappa > -6"):
        vv.filter_orbit(positions, good, P0, method="ukf", sigma_points=(1.0, 2.0, -6.0))


@pytest.mark.parametrize("reference", ["gcrs", "stars"])
def test_the_model_without_partials_gives_the_same_values(tracking_j2, reference):
    """``model(..., partials=False)`` (the sigma points' predictions) skips only the chain rule
    through the flight time: the same values, bit for bit, for every kind."""
    obs = tracking_j2
    t = obs.times[: 2 * (len(obs) // 2)]
    radec = vv.Observations(time=t, kind="radec", value=[[1.0, 0.2]] * len(t),
                            sigma=[1e-5] * len(t), station=obs.stations[: len(t)],
                            radec_reference=reference)  # fmt: skip
    for table in (obs, radec):
        y = _truth_at(Y_ECC, J2, table.offsets_s(EPOCH))
        h, H = model(table, y, GM)
        h2, H2 = model(table, y, GM, partials=False)
        np.testing.assert_array_equal(h2, h)
        assert H2 is None and H.shape == (len(table), 3, 6)


def _part(obs, sl):
    return vv.Observations(time=obs.times[sl], kind=list(obs.kinds[sl]),
                           value=[v[:d] for v, d in zip(obs.values[sl], obs.dims[sl], strict=True)],
                           sigma=list(obs.sigmas[sl]), station=obs.stations[sl])  # fmt: skip


def test_a_restarted_ukf_continues_the_same_run(tracking_drag):
    """Filtering the first half with the UKF, then the rest from its last state and covariance,
    gives the run over everything (with process noise): the UKF's state is (x, P) alone."""
    obs, _ = tracking_drag
    x0 = Y_LEO + [0.005, -0.002, 0.001, 1e-6, 0.0, -1e-6]
    kw = dict(process_noise=1e-14, method="ukf")
    whole = vv.filter_orbit(obs, _state(x0), P0, J2, **kw)
    cut = len(obs) // 2
    while obs.times[cut] == obs.times[cut - 1]:
        cut += 1
    first = vv.filter_orbit(_part(obs, slice(0, cut)), _state(x0), P0, J2, **kw)
    rest = vv.filter_orbit(_part(obs, slice(cut, None)), first.state, first.covariance, J2, **kw)
    assert len(first.times) + len(rest.times) - 1 == len(whole.times)
    np.testing.assert_allclose(rest.states[-1], whole.states[-1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(rest.covariance, whole.covariance, rtol=1e-7,
                               atol=1e-9 * np.abs(whole.covariance).max())  # fmt: skip
    np.testing.assert_array_equal(np.r_[first.rejected, rest.rejected], whole.rejected)


def _least_correlation_eigenvalue(P):
    d = np.sqrt(np.abs(np.diag(P)))
    return float(np.linalg.eigvalsh(P / np.outer(d, d))[0])


@pytest.mark.parametrize("sigma_km", [1e-8, 1e-10, 1e-12])
def test_a_precise_measurement_leaves_a_positive_definite_covariance(sigma_km):
    """was: P+ = P- - K S K^T cancelled to round-off when 10 um - 1 nm positions met a 1 km
    prior, and went negative: four negative position variances (a correlation eigenvalue of
    -3.6; NaN sigmas, silently). The Joseph-equivalent form keeps every filtered covariance
    symmetric positive definite; the estimate stays within its sigma of the truth."""
    leo = vv.StateVectors(Y_LEO[:3] * u.km, Y_LEO[3:] * u.km / u.s, vv.EARTH, epoch=EPOCH)
    t = EPOCH + np.arange(0.0, 600.0, 60.0) * u.s
    obs = simulate_observations(leo, t, "position", sigma_km * u.km, seed=1)
    obs = vv.Observations(time=t, kind="position", value=obs.values[:, :3], sigma=sigma_km)
    prior = np.diag([1.0] * 3 + [1e-6] * 3)  # 1 km, 1 m/s
    flt = vv.filter_orbit(obs, leo, prior, method="ukf", editing_sigma=None)
    P = np.asarray(flt.covariances)
    np.testing.assert_array_equal(P, np.swapaxes(P, 1, 2))
    assert np.all(np.diagonal(P, axis1=1, axis2=2) > 0)
    assert min(_least_correlation_eigenvalue(p) for p in P) > 0
    sig_r = np.sqrt(np.diag(P[-1])[:3])
    assert np.all(sig_r < 2 * sigma_km)  # the data fixed the position to their own precision
    err = flt.states[-1] - _truth_at(Y_LEO, None, flt.offsets_s)[-1]
    assert np.all(np.abs(err[:3]) < 5 * sig_r + 1e-12)


def test_the_square_root_update_equals_the_textbook_one():
    """On a well-conditioned case the array update through the factor
    (:func:`visviva.od.unscented.array_update`) gives x + K z and P - K S K^T (K = P_xz S^-1),
    for the sigma-point weights the filter takes: W_0^c > 0 (1, 2, 0) and (0.5, 2, 1), W_0^c < 0
    (0.5, 2, 0: the centred residue rows; and (0.5, 0, 0), gamma = 0)."""
    from visviva.od.square_root import covariance
    from visviva.od.unscented import _points, array_update

    rng = np.random.default_rng(3)
    A = rng.standard_normal((6, 6)) * np.r_[1.0, 1.0, 1.0, 1e-3, 1e-3, 1e-3]
    P = A @ A.T
    L = np.linalg.cholesky(P)
    H = rng.standard_normal((3, 6))
    for params in WEIGHT_CASES:
        weights = unscented_weights(params)
        scale, wm, wc = weights
        X = _points(np.zeros(6), L, scale)
        Z = X @ H.T + 0.1 * (X[:, :3] ** 2)  # mildly nonlinear
        dZ = Z - wm @ Z
        R = np.array([0.5, 0.2, 0.1])
        S = (wc * dZ.T) @ dZ + np.diag(R)
        Pxz = (wc * X.T) @ dZ
        K = np.linalg.solve(S, Pxz.T).T
        z = np.array([0.3, -0.2, 0.1])
        x, Lp = array_update(np.zeros(6), L, dZ, weights, R, z)
        np.testing.assert_allclose(x, K @ z, rtol=0, atol=1e-12)
        np.testing.assert_allclose(covariance(Lp), P - K @ S @ K.T, rtol=0,
                                   atol=1e-12 * np.abs(P).max())


WEIGHT_CASES = ((1.0, 2.0, 0.0), (0.5, 2.0, 1.0), (0.5, 2.0, 0.0), (0.5, 0.0, 0.0))


@pytest.mark.parametrize("params", WEIGHT_CASES)
def test_the_predicted_factor_is_the_sigma_points_covariance(params):
    """The square root from the statistically linearised split (F, residue rows, noise root)
    of a nonlinear transform of the points is a factor of sum_i W_i^c dY_i dY_i^T + N, for
    every weight case (W_0^c < 0 without a Cholesky downdate)."""
    from visviva.od.square_root import covariance
    from visviva.od.unscented import _factor, _linearised, _moments, _points

    rng = np.random.default_rng(8)
    A = rng.standard_normal((6, 6)) * np.r_[1.0, 1.0, 1.0, 1e-3, 1e-3, 1e-3]
    L = np.linalg.cholesky(A @ A.T)
    N = np.zeros((6, 6))
    N[3:, 3:] = np.diag([1e-8, 2e-8, 3e-8])  # rank 3, as SNC
    weights = unscented_weights(params)
    _, wm, wc = weights
    X = _points(np.r_[7000.0, 0, 0, 0, 7.5, 0], L, weights[0])
    Y = X + 1e-4 * np.c_[X[:, 3:] ** 2, X[:, :3] ** 2 * 1e-6]  # nonlinear
    m, dY = _moments(Y, wm)
    want = (wc * dY.T) @ dY + N
    got = covariance(_factor(*_linearised(dY, weights, N)))
    s = np.sqrt(np.diag(want))
    np.testing.assert_allclose(got / np.outer(s, s), want / np.outer(s, s), rtol=0, atol=1e-12)


@pytest.mark.parametrize("params", WEIGHT_CASES)
def test_the_joint_factor_chained_over_linear_steps_is_exact(params):
    """Two linear steps x_a = A1 x_k + e1, x_b = A2 x_a + e2 (the unscented transform is exact
    for them): the joint factor of (x_k, x_b) chained through each step's linearisation
    (:func:`visviva.od.unscented._chain`) has the Gram matrix [[P, P A^T], [A P, A P A^T +
    A2 N1 A2^T + N2]], A = A2 A1."""
    from visviva.od.unscented import _chain, _factor, _linearised, _moments, _points

    rng = np.random.default_rng(9)
    B = rng.standard_normal((6, 6))
    P = B @ B.T
    A1, A2 = np.eye(6) + 0.3 * rng.standard_normal((2, 6, 6))
    N1, N2 = (C @ C.T for C in 0.1 * rng.standard_normal((2, 6, 6)))
    weights = unscented_weights(params)
    L = np.linalg.cholesky(P)
    T = None
    for A_, N_ in ((A1, N1), (A2, N2)):
        X = _points(np.zeros(6), L, weights[0])
        _, dY = _moments(X @ A_.T, weights[1])
        F, rows = _linearised(dY, weights, N_)
        T = _chain(T, L, F, rows)
        L = _factor(F, rows)
    A = A2 @ A1
    want = np.block([[P, P @ A.T], [A @ P, A @ P @ A.T + A2 @ N1 @ A2.T + N2]])
    np.testing.assert_allclose(T @ T.T, want, rtol=0, atol=1e-11 * np.abs(want).max())


def test_sigma_points_that_reach_the_surface_say_so():
    # audit21 left propagate_many (the UKF's sigma points) unwatched: a point on an orbit
    # through the Earth was integrated on below the surface (or ran out of steps with "a
    # decaying orbit?"); it stops at the surface, naming the point and the time
    from visviva.od.dynamics import Dynamics

    y = np.array([[6878.0, 0.0, 0.0, 0.0, 4.7, 5.9],  # 500 km, perigee about 230 km
                  [6878.0, 0.0, 0.0, 0.0, 2.0, 2.5]])  # perigee deep inside the Earth
    dyn = Dynamics(vv.EARTH.gm_km3_s2, [vv.J2(vv.EARTH)], EPOCH, (0, 3000))
    with pytest.raises(vv.errors.SurfaceImpact, match="state 1 of 2") as info:
        dyn.propagate_many(y, np.array([3000.0]), threads=False)
    assert info.value.state == 1 and 0 < info.value.t.to_value(u.s) < 3000
    ok = dyn.propagate_many(y[:1], np.array([3000.0]), threads=False)  # the other one flies
    assert np.all(np.isfinite(ok)) and np.linalg.norm(ok[0, 0, :3]) > 6500
