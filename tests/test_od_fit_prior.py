"""Batch least squares with an a priori state covariance (vv.fit_orbit(apriori_covariance=)):
a vague prior changes nothing, a previous fit as prior plus new data equals the fit of all the
data, a prior makes an under-determined problem solvable as the Bayes (Kalman) combination, the
RTS smoother with the same prior agrees, the NEES over seeds, and the refusals."""

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from scipy import stats

import visviva as vv
from visviva.errors import InvalidInputError, ShapeError
from visviva.od import simulate_observations

EPOCH = Time("2024-03-01T00:00:00", scale="utc")
KMS = u.km / u.s
Y_TRUE = np.r_[6800.0, 100.0, 300.0, -0.1, 5.0, 5.7]
#: 100 m and 10 cm/s per axis, with correlations (a previous solution's shape)
_L = np.diag([0.1] * 3 + [1e-4] * 3) @ (np.eye(6) + 0.3 * np.tri(6, 6, -1))
P_BAR = _L @ _L.T


def _state(y):
    return vv.StateVectors(y[:3] * u.km, y[3:] * KMS, vv.EARTH, epoch=EPOCH)


def _vec(s):
    return np.r_[s.r.to_value(u.km), s.v.to_value(KMS)]


def _sigmas_apart(d, P):
    """Largest component of the whitened difference L^-1 d (P = L L^T)."""
    return float(np.max(np.abs(np.linalg.solve(np.linalg.cholesky(P), d))))


TRUTH = _state(Y_TRUE)
GUESS = _state(Y_TRUE + [10.0, -10.0, 10.0, -0.01, 0.01, -0.01])


def _positions(seed, t_s, sigma=0.05):
    return simulate_observations(TRUTH, EPOCH + np.asarray(t_s, float) * u.s, "position",
                                 sigma * u.km, seed=seed)


def test_a_vague_prior_gives_the_fit_of_the_data_alone():
    obs = _positions(3, np.linspace(0, 5400, 30))
    alone = vv.fit_orbit(obs, GUESS, outlier_sigma=None)
    vague = vv.fit_orbit(obs, GUESS, outlier_sigma=None,
                         apriori_covariance=np.diag([1e6] * 3 + [1.0] * 3))  # 1000 km, 1 km/s
    assert _sigmas_apart(_vec(vague.state) - _vec(alone.state), alone.covariance) < 1e-6
    np.testing.assert_allclose(vague.covariance, alone.covariance, rtol=1e-6)
    assert alone.apriori_covariance is None
    np.testing.assert_array_equal(vague.apriori_covariance, np.diag([1e6] * 3 + [1.0] * 3))
    assert vague.dof == alone.dof + 6
    assert "with a priori" in repr(vague) and "a priori" not in repr(alone)


def test_a_previous_fit_as_prior_plus_new_data_is_the_fit_of_all_the_data():
    """Information combination: fit the first half, then the second half from that estimate
    and covariance; the result is the fit of both halves at once."""
    t = np.linspace(0, 5400, 40)
    halves = [_positions(7, t[:20]), _positions(8, t[20:])]
    obs = vv.Observations(time=EPOCH + t * u.s, kind="position",
                          value=np.vstack([h.values for h in halves]) * u.km,
                          sigma=0.05 * u.km)
    first = vv.fit_orbit(halves[0], GUESS, outlier_sigma=None)
    second = vv.fit_orbit(halves[1], first.state, outlier_sigma=None,
                          apriori_covariance=first.covariance)
    both = vv.fit_orbit(obs, GUESS, outlier_sigma=None)
    assert _sigmas_apart(_vec(second.state) - _vec(both.state), both.covariance) < 1e-3
    np.testing.assert_allclose(second.covariance, both.covariance, rtol=1e-3,
                               atol=1e-6 * np.sqrt(np.outer(np.diag(both.covariance),
                                                            np.diag(both.covariance))).max())
    # and the second half alone is another (worse) estimate: the prior did something
    alone = vv.fit_orbit(halves[1], first.state, outlier_sigma=None)
    assert _sigmas_apart(_vec(alone.state) - _vec(both.state), both.covariance) > 1e-2


def test_a_prior_makes_two_fixes_at_one_time_solvable_as_the_kalman_update():
    """Two position fixes at the epoch leave the velocity undetermined; with the prior the fit
    is the Bayes combination x = x_bar + K (y - H x_bar), P = (I - K H) P_bar (exact: H is
    linear at the epoch)."""
    obs = _positions(11, [0.0, 0.0])
    with pytest.raises(InvalidInputError, match="information|determine"):
        vv.fit_orbit(obs, GUESS, outlier_sigma=None)
    prior = _state(Y_TRUE + np.linalg.cholesky(P_BAR) @ np.random.default_rng(1).normal(size=6))
    fit = vv.fit_orbit(obs, prior, outlier_sigma=None, apriori_covariance=P_BAR)
    H = np.vstack([np.eye(3, 6)] * 2)
    R = np.eye(6) * 0.05**2
    K = P_BAR @ H.T @ np.linalg.inv(H @ P_BAR @ H.T + R)
    x_bar = _vec(prior)
    x = x_bar + K @ (obs.values.reshape(-1) - H @ x_bar)
    P = (np.eye(6) - K @ H) @ P_BAR
    assert _sigmas_apart(_vec(fit.state) - x, P) < 1e-6
    np.testing.assert_allclose(fit.covariance, P, rtol=1e-6, atol=1e-12 * np.abs(P).max())
    # the velocity learned from the position through the prior's correlations only
    assert np.all(np.diag(fit.covariance)[3:] < np.diag(P_BAR)[3:])


def test_one_fix_later_with_a_prior_is_the_map_estimate():
    """One fix (3 < 6 components) an hour after the epoch: with the prior the fit stops where
    the gradient of J vanishes, P_bar^-1 (x - x_bar) = J^T R^-1 (y - h(x)), and its covariance
    is (P_bar^-1 + J^T R^-1 J)^-1 with J = [I 0] Phi(t, t0) at the estimate."""
    from visviva.od.dynamics import Dynamics

    obs = _positions(5, [3600.0], sigma=0.01)
    with pytest.raises(InvalidInputError, match="fewer than the 6 unknowns"):
        vv.fit_orbit(obs, GUESS)
    fit = vv.fit_orbit(obs, TRUTH, apriori_covariance=P_BAR)
    x = _vec(fit.state)
    y, phi = Dynamics(vv.EARTH.gm_km3_s2, None, EPOCH, (0, 3600), 1e-13, 1e-13).propagate(
        x, np.array([3600.0]))
    J = phi[0][:3]
    info = np.linalg.inv(P_BAR) + J.T @ J / 0.01**2
    np.testing.assert_allclose(fit.covariance, np.linalg.inv(info), rtol=1e-5,
                               atol=1e-9 * np.abs(P_BAR).max())
    grad = np.linalg.solve(P_BAR, x - Y_TRUE) - J.T @ (obs.values[0] - y[0, :3]) / 0.01**2
    assert np.linalg.norm(np.linalg.solve(info, grad) / np.sqrt(np.diag(fit.covariance))) < 1e-4


def test_the_rts_smoother_with_the_same_prior_agrees():
    """Two-body, position fixes, no process noise: the smoother's first state from a prior is
    the batch fit with that prior (1e-3 sigma, covariances 1 %)."""
    obs = _positions(13, np.arange(60, 3600, 300), sigma=0.1)
    prior = _state(Y_TRUE + [0.05, -0.03, 0.02, 3e-5, 0.0, -2e-5])
    f = vv.filter_orbit(obs, prior, P_BAR, smoother=True, editing_sigma=None)
    fit = vv.fit_orbit(obs, prior, outlier_sigma=None, apriori_covariance=P_BAR)
    alone = vv.fit_orbit(obs, prior, outlier_sigma=None)
    assert _sigmas_apart(_vec(f.first_state) - _vec(fit.state), fit.covariance) < 1e-3
    np.testing.assert_allclose(np.diag(f.first_covariance), np.diag(fit.covariance), rtol=0.01)
    # the prior matters here: without it the fit is another one
    assert _sigmas_apart(_vec(alone.state) - _vec(fit.state), fit.covariance) > 0.05


def test_nees_with_the_prior_over_seeds_is_chi_square_6():
    """x_bar drawn about the truth from P_bar, a few fixes of fresh noise: the normalised error
    of the combined estimate follows chi-square(6)."""
    rng = np.random.default_rng(2026)
    L = np.linalg.cholesky(P_BAR)
    nees = []
    for seed in range(120):
        prior = _state(Y_TRUE + L @ rng.standard_normal(6))
        obs = _positions(1000 + seed, [0.0, 600.0, 1200.0], sigma=0.1)
        fit = vv.fit_orbit(obs, prior, outlier_sigma=None, apriori_covariance=P_BAR)
        e = _vec(fit.state) - Y_TRUE
        nees.append(float(e @ np.linalg.solve(fit.covariance, e)))
    nees = np.array(nees)
    assert abs(nees.mean() - 6.0) < 4 * np.sqrt(12 / len(nees))
    assert stats.kstest(nees, stats.chi2(6).cdf).pvalue > 1e-3


def test_a_prior_in_square_metres_is_the_same_fit():
    obs = _positions(17, [0.0, 600.0])
    # a prior centred 10 km off with a sigma of ~100 m that the data contradict: the misfit
    # warning is due (the units are under test)
    with pytest.warns(RuntimeWarning, match="converged with an RMS of"):
        km = vv.fit_orbit(obs, GUESS, apriori_covariance=P_BAR)
    with pytest.warns(RuntimeWarning, match="converged with an RMS of"):
        m = vv.fit_orbit(obs, GUESS, apriori_covariance=P_BAR * 1e6 * u.m**2)
    np.testing.assert_allclose(_vec(m.state), _vec(km.state), rtol=0, atol=1e-9)
    np.testing.assert_allclose(m.covariance, km.covariance, rtol=1e-9)


def test_a_singular_prior_holds_its_zero_variance_direction():
    """x and vx correlated +1 (a rank-5 P_bar): the combination x/sx - vx/svx of the prior is
    held, the other directions fitted."""
    P = np.diag([0.1**2] * 3 + [1e-4**2] * 3)
    P[0, 3] = P[3, 0] = 0.1 * 1e-4
    obs = _positions(19, [0.0, 600.0, 1200.0])
    with pytest.warns(RuntimeWarning, match="converged with an RMS of"):  # 10 km prior offset
        fit = vv.fit_orbit(obs, GUESS, apriori_covariance=P)
    d = _vec(fit.state) - _vec(GUESS)
    assert abs(d[0] / 0.1 - d[3] / 1e-4) < 1e-5
    assert abs(d[0]) > 1e-3  # x itself moved with the data


def test_apriori_refusals():
    obs = _positions(23, [0.0, 600.0])
    with pytest.raises(InvalidInputError, match=r"apriori_covariance\[3, 3\] is zero.*vx"):
        vv.fit_orbit(obs, GUESS, apriori_covariance=np.diag([1.0, 1.0, 1.0, 0.0, 1.0, 1.0]))
    bad = np.diag([1.0] * 3 + [1e-4] * 3)
    bad[0, 1] = bad[1, 0] = 2.0  # correlation 2
    with pytest.raises(InvalidInputError, match="apriori_covariance"):
        vv.fit_orbit(obs, GUESS, apriori_covariance=bad)
    with pytest.raises(ShapeError, match="apriori_covariance"):
        vv.fit_orbit(obs, GUESS, apriori_covariance=np.eye(3))
    with pytest.raises(InvalidInputError, match="NaN"):
        vv.fit_orbit(obs, GUESS, apriori_covariance=np.full((6, 6), np.nan))
    with pytest.raises(InvalidInputError, match="covariance of the initial state"):
        vv.fit_orbit(obs, None, apriori_covariance=P_BAR)


@pytest.mark.parametrize("prior", [None, P_BAR])
def test_consider_with_an_a_priori_burn_lines_up_the_rows(prior):
    """Regression: a consider parameter with an estimated burn that has an execution covariance
    (a priori rows) raised a shape error; the consider sensitivity S_xc = d x / d Cr now matches
    the difference of two fits with Cr moved, and the state prior joins them."""
    m2kg = u.m**2 / u.kg

    def forces(cr):
        return [vv.SolarRadiationPressure(0.02 * m2kg, reflectivity=cr)]

    burn = vv.ImpulsiveBurn(1800 * u.s, [0.0, 0.001, 0.0] * KMS, "RTN",
                            delta_v_covariance=np.eye(3) * 1e-8)
    obs = simulate_observations(TRUTH, EPOCH + np.linspace(0, 5400, 30) * u.s, "position",
                                0.01 * u.km, None, forces(1.3), maneuvers=[burn], seed=1)
    kw = {"maneuvers": [burn], "estimate_maneuvers": True, "outlier_sigma": None,
          "apriori_covariance": prior}
    fit = vv.fit_orbit(obs, TRUTH, forces(1.3), consider={"srp": 0.2}, **kw)
    moved = vv.fit_orbit(obs, TRUTH, forces(1.4), **kw)
    base = vv.fit_orbit(obs, TRUTH, forces(1.3), **kw)
    fd = (_vec(moved.state) - _vec(base.state)) / 0.1
    np.testing.assert_allclose(fit.consider_sensitivity[:6, 0], fd, rtol=1e-3,
                               atol=1e-3 * np.abs(fd).max())
    assert np.all(np.diag(fit.covariance) >= np.diag(fit.noise_covariance))


@pytest.mark.parametrize("size", [3, 7])
def test_an_apriori_covariance_of_another_size_is_refused_as_6x6_only(size):
    # a 7x7 got "must be 6x6 or 3x3", then a 3x3 was refused as well: the message names 6x6
    obs = vv.Observations(time=EPOCH + [0.0, 60.0] * u.s, kind="position",
                          value=np.zeros((2, 3)) + [7000.0, 0, 0], sigma=0.01)
    with pytest.raises(vv.errors.ShapeError, match="must be 6x6 on") as info:
        vv.fit_orbit(obs, TRUTH, apriori_covariance=np.eye(size))
    assert "3x3" not in str(info.value)
