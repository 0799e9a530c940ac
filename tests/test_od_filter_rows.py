"""filter_orbit's post-fit residuals (one call of the measurement model after the pass) against
the model evaluated epoch by epoch on the rows there, and the light-time model's fixed-point
steps without the Jacobian: the same numbers, bit for bit."""

import numpy as np
from astropy import units as u
from astropy.time import Time

import visviva as vv
from visviva.od.light_time import _shift_back, model
from visviva.od.measurements import residuals

EPOCH = Time("2024-03-01T00:00:00", scale="utc")


def test_postfit_residuals_are_the_model_at_each_epochs_updated_state():
    truth = vv.StateVectors([6800.0, 100.0, 300.0] * u.km, [-0.1, 5.0, 5.7] * u.km / u.s,
                            vv.EARTH, epoch=EPOCH)
    stations = [vv.GroundStation(40 * u.deg, -105 * u.deg, 1.6 * u.km),
                vv.GroundStation(-30 * u.deg, 20 * u.deg, 0.3 * u.km),
                vv.GroundStation(15 * u.deg, 150 * u.deg, 0.0 * u.km)]
    forces = [vv.J2(vv.EARTH)]
    obs = vv.od.simulate_tracking(truth, stations, EPOCH + np.arange(0, 6 * 3600, 30) * u.s,
                                  forces, seed=3)
    guess = vv.StateVectors(truth.r + [1.0, -1.0, 0.5] * u.km,
                            truth.v + [1e-3, 0.0, -1e-3] * u.km / u.s, vv.EARTH, epoch=EPOCH)
    f = vv.filter_orbit(obs, guess, np.diag([1.0] * 3 + [1e-6] * 3), forces)
    assert len(set(obs.kinds)) >= 3 and len(f.times) > 20
    gm = vv.EARTH.gm_km3_s2
    for k in np.unique(f.epoch_index):
        rows = np.flatnonzero(f.epoch_index == k)
        h, _ = model(obs, np.repeat(f.states[k][None], rows.size, axis=0), gm, rows)
        z = residuals(obs.kinds[rows], obs.values[rows], h)
        comp = np.arange(3)[None, :] < obs.dims[rows][:, None]
        np.testing.assert_array_equal(f.postfit_residuals[rows], np.where(comp, z, 0.0))
    # the update pulls the residuals in: post-fit at most as large as pre-fit, in sum
    w = (f.postfit_residuals / obs.sigmas[:, None]) ** 2
    assert w.sum() < ((f.prefit_residuals / obs.sigmas[:, None]) ** 2).sum()


def test_shift_back_without_jacobian_gives_the_same_states():
    rng = np.random.default_rng(7)
    y = np.concatenate([rng.normal(size=(5, 3)) * 7000.0, rng.normal(size=(5, 3)) * 5.0], axis=1)
    tau = rng.uniform(0.001, 0.12, 5)
    full, jac = _shift_back(y, vv.EARTH.gm_km3_s2, tau)
    only, none = _shift_back(y, vv.EARTH.gm_km3_s2, tau, jacobian=False)
    np.testing.assert_array_equal(full, only)
    assert none is None and jac.shape == (5, 6, 6)
