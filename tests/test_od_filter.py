"""Sequential estimation (vv.filter_orbit): the EKF and its smoother against batch least squares
on a nearly linear problem, consistency (NEES, NIS) on simulated tracking with J2, process noise
against an unmodelled drag, editing, divergence, a TDM fed to the filter, and bad input."""

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from scipy import stats

import visviva as vv
from visviva.od import simulate_observations
from visviva.od.dynamics import Dynamics

EPOCH = Time("2024-03-01T00:00:00", scale="utc")
KMS = u.km / u.s
GM = vv.EARTH.gm_km3_s2
Y_ECC = np.r_[6800.0, 100.0, 300.0, -0.1, 5.0, 5.7]  # the od tests' orbit (perigee 77 km, apogee 541 km: no drag)
Y_LEO = np.r_[6778.0, 0.0, 0.0, 0.0, 4.7645, 6.0102]  # near-circular, 400 km, 51.6 deg
STATIONS = [vv.GroundStation(40 * u.deg, -105 * u.deg, 1.6 * u.km, name="GOLD"),
            vv.GroundStation(-30 * u.deg, 20 * u.deg, 0.3 * u.km, name="HART")]
J2 = [vv.J2(vv.EARTH)]
#: 10 m and 1 cm/s: an initial uncertainty that a linear map carries over a gap between passes
P0 = np.diag([0.01**2] * 3 + [1e-5**2] * 3)


def _state(y, epoch=EPOCH):
    return vv.StateVectors(y[:3] * u.km, y[3:] * KMS, vv.EARTH, epoch=epoch)


def _vec(s):
    return np.r_[s.r.to_value(u.km), s.v.to_value(KMS)]


def _truth_at(y0, forces, offsets):
    y, _ = Dynamics(GM, forces, EPOCH, (0, offsets.max()), 1e-13, 1e-13).propagate(y0, offsets)
    return y


def _sigmas_apart(d, P):
    """Largest component of the whitened difference L^-1 d (P = L L^T)."""
    return float(np.max(np.abs(np.linalg.solve(np.linalg.cholesky(P), d))))


def _nees(e, P):
    return np.einsum("ti,ti->t", e, np.linalg.solve(P, e[..., None])[..., 0])


def _noisy(exact, rng):
    """The exact table with fresh Gaussian noise of its sigmas."""
    noise = rng.standard_normal((len(exact), 3)) * exact.sigmas[:, None]
    vals = [exact.values[i, :exact.dims[i]] + noise[i, :exact.dims[i]] for i in range(len(exact))]
    return vv.Observations(time=exact.times, kind=list(exact.kinds), value=vals,
                           sigma=list(exact.sigmas), station=exact.stations)


@pytest.fixture(scope="module")
def positions():
    t = EPOCH + np.arange(60, 3 * 3600, 120) * u.s
    return simulate_observations(_state(Y_ECC), t, "position", 0.001 * u.km, seed=3)


def test_filter_equals_batch_on_a_nearly_linear_problem(positions):
    """Position fixes, two-body, no process noise: EKF final = batch mapped to the last epoch,
    RTS smoother's first = batch at the epoch (1e-3 sigma, covariances 1 %)."""
    guess = _state(Y_ECC + [0.005, -0.003, 0.002, 3e-6, 0.0, -2e-6])
    prior = np.diag([1.0] * 3 + [1e-4] * 3)  # 1 km, 10 m/s: weak against 90 fixes
    f = vv.filter_orbit(positions, guess, prior, smoother=True, editing_sigma=None)
    fit = vv.fit_orbit(positions, guess, outlier_sigma=None)
    xb = _vec(fit.state)
    # the smoother at the initial epoch against the batch estimate there
    assert _sigmas_apart(_vec(f.first_state) - xb, fit.covariance) < 1e-3
    np.testing.assert_allclose(np.diag(f.first_covariance), np.diag(fit.covariance), rtol=0.01)
    assert f.first_state.epoch == fit.state.epoch
    # the filter at the last epoch against the batch estimate mapped there
    y, phi = Dynamics(GM, None, EPOCH, (0, f.offsets_s[-1]), 1e-13, 1e-13).propagate(
        xb, f.offsets_s[-1:])
    Pb = phi[0] @ fit.covariance @ phi[0].T
    assert _sigmas_apart(f.states[-1] - y[0], Pb) < 1e-3
    np.testing.assert_allclose(np.diag(f.covariance), np.diag(Pb), rtol=0.01)
    np.testing.assert_array_equal(_vec(f.state), f.states[-1])
    assert abs((f.state.epoch - positions.times[-1]).sec) < 1e-6
    # every covariance of the Joseph update is symmetric positive definite
    for P in (f.covariances, f.smoothed_covariances):
        np.testing.assert_array_equal(P, np.swapaxes(P, 1, 2))
        assert np.all(np.linalg.eigvalsh(P) > 0)
    # post-fit residuals are smaller than pre-fit ones once the orbit is known
    late = f.epoch_index > 10
    assert np.sqrt(np.mean(f.postfit_residuals[late] ** 2)) < np.sqrt(
        np.mean(f.prefit_residuals[late] ** 2))
    text = repr(f)
    assert "91 epochs" in text and "90 observations" in text and "smoothed" in text


@pytest.fixture(scope="module")
def tracking_j2():
    """Two stations, range / range rate / az-el every 30 s when above 10 deg, 3 h, J2."""
    grid = EPOCH + np.arange(0, 3 * 3600, 30) * u.s
    return vv.od.simulate_tracking(_state(Y_ECC), STATIONS, grid, J2, seed=False)


def test_filter_is_consistent_on_simulated_tracking(tracking_j2):
    """NEES averages ~6 within the chi-square band of the runs; NIS per kind within its band."""
    rng = np.random.default_rng(5)
    runs = 20
    nees, smoothed, nis_sum = [], [], {}
    truth = None
    for _ in range(runs):
        obs = _noisy(tracking_j2, rng)
        x0 = Y_ECC + rng.multivariate_normal(np.zeros(6), P0)
        f = vv.filter_orbit(obs, _state(x0), P0, J2, smoother=True, editing_sigma=None)
        if truth is None:
            truth = _truth_at(Y_ECC, J2, f.offsets_s)
        nees.append(_nees(f.states - truth, f.covariances))
        smoothed.append(_nees(f.smoothed_states - truth, f.smoothed_covariances))
        for k in ("range", "range_rate", "azel"):
            nis_sum[k] = nis_sum.get(k, 0.0) + f.nis[obs.kinds == k].sum()
    nees, smoothed = np.array(nees), np.array(smoothed)
    lo, hi = stats.chi2.ppf([0.001, 0.999], 6 * runs) / runs
    assert lo < nees.mean() < hi and lo < smoothed.mean() < hi
    per_epoch = nees.mean(axis=0)  # a Monte Carlo mean at every epoch
    assert np.all(per_epoch < stats.chi2.ppf(0.9999, 6 * runs) / runs)
    for k, total in nis_sum.items():
        dof = runs * int(tracking_j2.dims[tracking_j2.kinds == k].sum())
        assert stats.chi2.ppf(0.0005, dof) < total < stats.chi2.ppf(0.9995, dof), k


@pytest.fixture(scope="module")
def tracking_drag():
    """The same tracking of a 400 km orbit over 6 h whose truth has drag (0.05 m^2/kg)."""
    grid = EPOCH + np.arange(0, 6 * 3600, 30) * u.s
    forces = J2 + [vv.AtmosphericDrag(0.05 * u.m**2 / u.kg)]
    obs = vv.od.simulate_tracking(_state(Y_LEO), STATIONS, grid, forces, seed=11)
    return obs, forces


def test_process_noise_absorbs_an_unmodelled_drag_where_none_diverges(tracking_drag):
    obs, truth_forces = tracking_drag
    rng = np.random.default_rng(2)
    x0 = Y_LEO + rng.multivariate_normal(np.zeros(6), P0)
    # the filter's dynamics lack the drag (3e-9 km/s^2): without process noise it loses the orbit
    with pytest.raises(vv.ConvergenceError, match=r"diverged at 2024-03-01T0\d:\d\d.*consecutive"):
        vv.filter_orbit(obs, _state(x0), P0, J2)
    # and with editing off it still refuses to go on (5 sigma)
    with pytest.raises(vv.ConvergenceError, match="5 sigma"):
        vv.filter_orbit(obs, _state(x0), P0, J2, editing_sigma=None)
    # SNC q = 1e-14 km^2/s^3 ~ a^2 x (the gap between passes, ~5000 s) keeps it consistent
    f = vv.filter_orbit(obs, _state(x0), P0, J2, process_noise=1e-14)
    e = f.states - _truth_at(Y_LEO, truth_forces, f.offsets_s)
    nees = _nees(e, f.covariances)
    assert 3.0 < nees.mean() < 10.0  # one run, correlated epochs: about 6
    assert np.mean(nees < stats.chi2.ppf(0.999, 6)) > 0.95
    dof = int(obs.dims.sum())
    assert stats.chi2.ppf(0.0005, dof) < f.nis.sum() < stats.chi2.ppf(0.9995, dof)
    assert not f.rejected.any()
    assert np.linalg.norm(e[-1, :3]) < 0.03  # 10 m class at the end, where q = 0 had diverged
    # the density in other units and in GCRS axes is taken too
    g = vv.filter_orbit(obs, _state(x0), P0, J2, process_noise=[1e-8] * 3 * u.m**2 / u.s**3,
                        process_noise_frame="gcrs")
    assert g.process_noise_frame == "GCRS"
    np.testing.assert_allclose(g.process_noise, 1e-14)


def test_an_outlier_is_rejected_and_reported(tracking_j2):
    rng = np.random.default_rng(9)
    obs = _noisy(tracking_j2, rng)
    values = [obs.values[i, :obs.dims[i]].copy() for i in range(len(obs))]
    bad = 40
    assert obs.kinds[bad] == "range_rate"
    values[bad][0] += 100 * obs.sigmas[bad]
    spoiled = vv.Observations(time=obs.times, kind=list(obs.kinds), value=values,
                              sigma=list(obs.sigmas), station=obs.stations)
    clean = vv.filter_orbit(obs, _state(Y_ECC), P0, J2)
    f = vv.filter_orbit(spoiled, _state(Y_ECC), P0, J2)
    assert np.flatnonzero(f.rejected).tolist() == [bad]
    assert f.prefit_ratios[bad] > 50
    np.testing.assert_allclose(f.prefit_residuals[bad, 0] - clean.prefit_residuals[bad, 0],
                               100 * obs.sigmas[bad], rtol=1e-6)
    # the rejected row did not move the estimate: only the other rows at its epoch did
    assert _sigmas_apart(f.states[-1] - clean.states[-1], clean.covariance) < 0.5
    kept = vv.filter_orbit(spoiled, _state(Y_ECC), P0, J2, editing_sigma=None,
                           divergence_count=10**6)
    assert not kept.rejected.any()
    assert _sigmas_apart(kept.states[-1] - clean.states[-1], clean.covariance) > 1


def test_a_tdm_feeds_the_filter(tracking_j2):
    obs = _noisy(tracking_j2, np.random.default_rng(4))
    text = vv.write_tdm(obs, participant="SAT-1")
    tracked = vv.read_tdm(text).to_observations(
        {s.name: s for s in STATIONS},
        {"range": 10 * u.m, "range_rate": 1 * u.cm / u.s, "azel": 0.01 * u.deg})
    direct = vv.filter_orbit(obs, _state(Y_ECC), P0, J2)
    f = vv.filter_orbit(tracked, _state(Y_ECC), P0, J2)
    assert len(f.times) == len(direct.times)
    assert np.max(np.abs(f.states[-1, :3] - direct.states[-1, :3])) < 1e-6  # 1 mm
    e = f.states[-1] - _truth_at(Y_ECC, J2, f.offsets_s[-1:])[0]
    assert _nees(e[None], f.covariance[None])[0] < stats.chi2.ppf(0.999, 6)


def test_observations_at_the_epoch_update_the_first_state(positions):
    t = EPOCH + np.arange(0, 600, 60) * u.s
    obs = simulate_observations(_state(Y_ECC), t, "position", 0.001 * u.km, seed=1)
    f = vv.filter_orbit(obs, _state(Y_ECC + [0.02, 0, 0, 0, 0, 0]), np.diag([1e-2] * 3 + [1e-6] * 3))
    assert len(f.times) == 10 and f.offsets_s[0] == 0.0
    assert abs(f.states[0, 0] - Y_ECC[0]) < 0.005  # pulled from 20 m off to the fix
    assert f.covariances[0, 0, 0] < 2e-6


def test_filter_bad_input(positions):
    good = _state(Y_ECC)
    with pytest.raises(vv.InvalidInputError, match="vv.Observations"):
        vv.filter_orbit([1, 2], good, P0)
    with pytest.raises(vv.InvalidInputError, match="NaN"):
        vv.filter_orbit(positions, good, np.full((6, 6), np.nan))
    with pytest.raises(vv.ShapeError, match="6x6"):
        vv.filter_orbit(positions, good, np.eye(3))
    negative = P0.copy()
    negative[0, 0] = -1e-4
    with pytest.raises(vv.InvalidInputError, match="negative variance"):
        vv.filter_orbit(positions, good, negative)
    not_psd = P0.copy()
    not_psd[0, 1] = not_psd[1, 0] = 2 * P0[0, 0]  # a correlation of 2
    with pytest.raises(vv.InvalidInputError, match="not positive semi-definite"):
        vv.filter_orbit(positions, good, not_psd)
    with pytest.raises(vv.InvalidInputError, match="symmetric"):
        vv.filter_orbit(positions, good, P0 + np.triu(np.ones((6, 6)), 1) * 1e-6)
    with pytest.raises(vv.InvalidInputError, match="zero"):
        vv.filter_orbit(positions, good, np.zeros((6, 6)))
    with pytest.raises(vv.UnitsError):
        vv.filter_orbit(positions, good, P0 * u.s)
    late = _state(Y_ECC, EPOCH + 600 * u.s)
    with pytest.raises(vv.InvalidInputError, match="observation 0 .* before the initial"):
        vv.filter_orbit(positions, late, P0)
    pending = _state(Y_ECC)
    pending._pending_maneuvers = 1
    with pytest.raises(vv.InvalidInputError, match="manoeuvre"):
        vv.filter_orbit(positions, pending, P0)
    for kw, match in (({"process_noise": -1e-14}, ">= 0"), ({"process_noise": [1e-14] * 2}, "three"),
                      ({"process_noise": 1e-14, "process_noise_frame": "XYZ"}, "RTN"),
                      ({"process_noise": 1e-14 * u.km}, None), ({"editing_sigma": 0}, "> 0"),
                      ({"divergence_count": 0}, ">= 1"), ({"smoother": "yes"}, "True or False"),
                      ({"noise_step": -1 * u.s}, "> 0"), ({"rtol": np.nan}, "finite"),
                      ({"editing_sigma": True}, "number"), ({"process_noise": np.nan}, "NaN"),
                      ({"covariance": np.diag([np.inf] * 6)}, "infinite")):
        args = {"covariance": P0} | kw
        with pytest.raises(vv.VisvivaError, match=match):
            vv.filter_orbit(positions, good, **args)


def test_covariance_in_other_units_is_the_same_filter(positions):
    good = _state(Y_ECC)
    a = vv.filter_orbit(positions, good, P0)
    b = vv.filter_orbit(positions, good, P0 * 1e6 * u.m**2)  # read in m and s
    c = vv.filter_orbit(positions, good, P0.tolist())
    np.testing.assert_array_equal(a.states, c.states)
    # a plain noise step is seconds, as its Quantity
    d = vv.filter_orbit(positions, good, P0, process_noise=1e-14, noise_step=30.0)
    e = vv.filter_orbit(positions, good, P0, process_noise=1e-14, noise_step=0.5 * u.min)
    np.testing.assert_array_equal(d.covariances, e.covariances)
    assert np.all(d.covariances[-1].diagonal() > a.covariances[-1].diagonal())
    np.testing.assert_allclose(a.states, b.states, rtol=1e-13, atol=0)
    np.testing.assert_allclose(a.covariances, b.covariances, rtol=1e-9, atol=0)


def test_a_restarted_filter_continues_the_same_run(tracking_drag):
    """Near real time: filtering the first half, then the rest from the last state and
    covariance, gives the run over everything (with process noise)."""
    obs, _ = tracking_drag
    x0 = Y_LEO + [0.005, -0.002, 0.001, 1e-6, 0.0, -1e-6]
    whole = vv.filter_orbit(obs, _state(x0), P0, J2, process_noise=1e-14)
    cut = len(obs) // 2
    while obs.times[cut] == obs.times[cut - 1]:
        cut += 1

    def part(sl):
        return vv.Observations(time=obs.times[sl], kind=list(obs.kinds[sl]),
                               value=[v[:d] for v, d in zip(obs.values[sl], obs.dims[sl],
                                                            strict=True)],
                               sigma=list(obs.sigmas[sl]), station=obs.stations[sl])

    first = vv.filter_orbit(part(slice(0, cut)), _state(x0), P0, J2, process_noise=1e-14)
    rest = vv.filter_orbit(part(slice(cut, None)), first.state, first.covariance, J2,
                           process_noise=1e-14)
    assert len(first.times) + len(rest.times) - 1 == len(whole.times)
    np.testing.assert_allclose(rest.states[-1], whole.states[-1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(rest.covariance, whole.covariance, rtol=1e-7,
                               atol=1e-9 * np.abs(whole.covariance).max())
    np.testing.assert_array_equal(np.r_[first.rejected, rest.rejected], whole.rejected)


def test_snc_is_the_covariance_of_integrated_white_noise():
    """Q(dt) = int_0^dt Phi_cv(s) B Qc B^T Phi_cv(s)^T ds for constant-velocity motion."""
    from scipy.integrate import quad_vec

    from visviva.satellites.covariance import snc_covariance

    a = np.array([[1e-14, 2e-15, 0], [2e-15, 3e-14, 1e-15], [0, 1e-15, 5e-15]])
    B = np.vstack([np.zeros((3, 3)), np.eye(3)])

    def integrand(s):
        phi = np.eye(6)
        phi[:3, 3:] = s * np.eye(3)
        return phi @ B @ a @ B.T @ phi.T

    for dt in (1.0, 60.0, 5400.0):
        ref, _ = quad_vec(integrand, 0.0, dt, epsabs=0, epsrel=1e-12)
        np.testing.assert_allclose(snc_covariance(dt, a), ref, rtol=1e-10, atol=0)
    assert np.all(np.linalg.eigvalsh(snc_covariance(600.0, a)) > -1e-20)


def test_rtn_noise_grows_the_along_track_uncertainty_most(positions):
    """Noise on the T axis only: the predicted covariance's growth over a short gap lies along
    the velocity."""
    t = EPOCH + np.array([0.0, 30.0]) * u.s
    obs = simulate_observations(_state(Y_ECC), t, "position", 0.001 * u.km, seed=2)
    q = [0.0, 1e-10, 0.0]
    f = vv.filter_orbit(obs, _state(Y_ECC), P0, process_noise=q)
    g = vv.filter_orbit(obs, _state(Y_ECC), P0)
    growth = f.predicted_covariances[1] - g.predicted_covariances[1]
    w, vecs = np.linalg.eigh(growth[:3, :3])
    v_hat = Y_ECC[3:] / np.linalg.norm(Y_ECC[3:])
    t_hat = np.cross(np.cross(Y_ECC[:3], Y_ECC[3:]), Y_ECC[:3])
    t_hat /= np.linalg.norm(t_hat)
    assert abs(vecs[:, -1] @ t_hat) > 0.999
    np.testing.assert_allclose(w[-1], 1e-10 * 30.0**3 / 3.0, rtol=0.01)
    assert abs(vecs[:, -1] @ v_hat) > 0.99


def test_filter_and_smoother_are_consistent_when_the_truth_has_white_noise_acceleration():
    """A truth kicked by a white-noise acceleration of density q (velocity kicks N(0, q h) every
    h = 5 s) and the filter told that q: filtered and smoothed NEES average ~6."""
    from visviva.od.extended import _propagate

    q, h, span, sig, runs = 1e-12, 5.0, 5400.0, 0.01, 12
    dyn = Dynamics(GM, None, EPOCH, (0, span))
    rng = np.random.default_rng(3)
    steps = np.arange(1, int(span / h) + 1) * h
    t_obs = np.arange(60.0, span, 60.0)
    at_obs = np.searchsorted(steps, t_obs)
    nees, smoothed = [], []
    for _ in range(runs):
        x, t, path = Y_ECC.copy(), 0.0, []
        for t_next in steps:
            x = _propagate(dyn, x, t, [t_next])[0][-1].copy()
            x[3:] += rng.standard_normal(3) * np.sqrt(q * h)
            path.append(x)
            t = t_next
        truth = np.array(path)[at_obs]
        pos = truth[:, :3] + rng.standard_normal((t_obs.size, 3)) * sig
        obs = vv.Observations(time=EPOCH + t_obs * u.s, kind="position", value=pos * u.km,
                              sigma=sig * u.km)
        x0 = Y_ECC + rng.multivariate_normal(np.zeros(6), P0)
        f = vv.filter_orbit(obs, _state(x0), P0, process_noise=q, process_noise_frame="GCRS",
                            noise_step=h * u.s, smoother=True)
        truth = np.vstack([Y_ECC, truth])  # the a priori epoch first
        nees.append(_nees(f.states - truth, f.covariances))
        smoothed.append(_nees(f.smoothed_states - truth, f.smoothed_covariances))
    lo, hi = stats.chi2.ppf([0.001, 0.999], 6 * runs) / runs
    assert lo < np.mean(nees) < hi
    assert lo < np.mean(smoothed) < hi


@pytest.mark.parametrize("light_time, reference", [(True, "gcrs"), (True, "stars"),
                                                    (False, "gcrs")])
def test_the_model_of_some_rows_is_those_rows_of_the_whole_model(light_time, reference):
    """light_time.model(rows=): what the filter evaluates at one epoch."""
    from visviva.od.light_time import model

    t = EPOCH + np.array([0.0, 0.0, 10.0, 10.0, 20.0]) * u.s
    kinds = ["range", "radec", "azel", "range_rate", "position"]
    st = STATIONS[0]
    obs = simulate_observations(_state(Y_ECC), t, kinds, [0.01, 1e-5, 1e-5, 1e-5, 0.01],
                                [st, st, st, st, None], seed=False, light_time=light_time,
                                radec_reference=reference)
    y = _truth_at(Y_ECC, None, obs.offsets_s(EPOCH) + 1e-9)
    h, H = model(obs, y, GM)
    rows = np.array([1, 3, 4])
    h2, H2 = model(obs, y[rows], GM, rows)
    np.testing.assert_array_equal(h2, h[rows])
    np.testing.assert_array_equal(H2, H[rows])


def test_each_interval_restarts_the_full_force_model_at_its_own_time():
    """Exact data of a truth under zonals, drag, Sun, Moon and SRP with a conical shadow (time-
    dependent forces): the filter started on the truth stays on it to the integrator's
    precision, so every interval's force model is the one at its own dates."""
    forces = [vv.Zonal(vv.EARTH, 4), vv.AtmosphericDrag(0.01 * u.m**2 / u.kg),
              vv.ThirdBody(vv.MOON), vv.ThirdBody(vv.SUN),
              vv.SolarRadiationPressure(0.02 * u.m**2 / u.kg, shadow="conical")]
    grid = EPOCH + np.arange(0, 6 * 3600, 60) * u.s
    obs = vv.od.simulate_tracking(_state(Y_LEO), STATIONS, grid, forces, seed=False)
    f = vv.filter_orbit(obs, _state(Y_LEO), P0, forces)
    truth = _truth_at(Y_LEO, forces, f.offsets_s)
    assert np.abs(f.states[:, :3] - truth[:, :3]).max() < 1e-6  # 1 mm (measured 12 um)
    assert f.prefit_ratios.max() < 1e-3


def test_the_ekf_warns_when_its_linearisation_fails_across_its_prior():
    # audit44: one pass of range rates from a 10 km, 100 m/s prior centred on the truth: the
    # measurements' curvature across the prior shifts their mean by ~20-60 sigmas, which the
    # linearised update leaves out; the EKF ended 24 km from the truth with a formal 0.8 km
    # (NEES 4e5) without a word. The unscented filter on the same data stays consistent.
    truth = _state(Y_ECC)
    obs = vv.od.simulate_tracking(truth, STATIONS[:1], EPOCH + np.arange(0, 1200, 30) * u.s,
                                  None, seed=0, measurements={"range_rate": 1 * u.cm / u.s})
    start = vv.propagate_cowell(truth, obs.times[0], [])
    wide = np.diag([10.0**2] * 3 + [0.1**2] * 3)
    with pytest.warns(RuntimeWarning, match="linearisation fails") as rec:
        ekf = vv.filter_orbit(obs, start, wide, None)
    assert rec[0].filename == __file__  # points at the caller
    x_end = _vec(vv.propagate_cowell(truth, ekf.state.epoch, []))
    assert _sigmas_apart(_vec(ekf.state) - x_end, ekf.covariance) > 30  # what it warns about
    ukf = vv.filter_orbit(obs, start, wide, None, method="ukf")  # no warning (errors here)
    assert _sigmas_apart(_vec(ukf.state) - x_end, ukf.covariance) < 5
    # a prior the linearisation carries: no warning (pytest turns visviva's RuntimeWarnings
    # into errors)
    vv.filter_orbit(obs, start, np.diag([1.0] * 3 + [1e-6] * 3), None)
