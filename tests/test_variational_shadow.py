"""The variational integrator of the fits (core/variational.py) ends its steps at the shadow
boundaries of SRP like propagate_cowell (core/cowell_events.py, "Shadow boundaries"), and its
STM carries the shadow: the saltation matrix at the cylindrical shadow's jump, the gradient of
the visible fraction of the Sun in the conical penumbra.

Before, its steps straddled the boundaries: 0.24 m (conical) / 0.29 m (cylindrical) off a tight
reference after a LEO day, 2.8 mm / 22 mm after three GEO days in eclipse season; a fit of
perfect position fixes of a LEO day with SRP and a shadow was 18 cm / 13 cm off the truth.
Measured now: 0.02 to 0.24 mm, 0.01 to 0.04 mm; the fit 0.3 mm.
"""

from __future__ import annotations

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv
from test_cowell_shadow import AM, EPOCH, TIGHT, forces, leo
from test_od_fit import _fd_stm
from visviva.od.dynamics import Dynamics

KMS = u.km / u.s


def vec(state):
    return np.r_[state.r.to_value(u.km), state.v.to_value(KMS)]


@pytest.mark.parametrize("shadow", ["conical", "cylindrical"])
@pytest.mark.parametrize("sign", [1, -1], ids=["forward", "backward"])
def test_variational_trajectory_matches_cowell_across_the_shadow(shadow, sign):
    # 6 h of LEO (about 8 shadow boundaries), sparse outputs as a fit has them (long steps)
    t = np.sort(sign * np.linspace(0.0, 0.25, 7)) * u.day
    ref = vv.propagate_cowell(leo(), t, forces(shadow), max_step=2 * u.s, **TIGHT)
    dyn = Dynamics(vv.EARTH.gm_km3_s2, forces(shadow), EPOCH, (t.min().to_value(u.s),
                                                                 t.max().to_value(u.s)))
    y, _ = dyn.propagate(vec(leo()), t.to_value(u.s))
    err_mm = np.linalg.norm(y[:, :3] - ref.r.to_value(u.km), axis=-1).max() * 1e6
    assert err_mm < 1.0  # before: 90 to 160 mm; now ~0.05 mm
    plain = vv.propagate_cowell(leo(), t, forces(None))  # SRP's shadow did act
    assert np.linalg.norm((plain.r - ref.r).to_value(u.mm), axis=-1).max() > 100 * err_mm


@pytest.mark.parametrize("shadow", ["conical", "cylindrical"])
def test_stm_across_eclipses_matches_finite_differences_of_cowell(shadow):
    # the shadow's effect on Phi is ~1e-6 of it after 6 h (the jump of SRP's 1.4e-10 km/s^2
    # times the shift of the crossing time per km); with it the STM agrees with central
    # differences to their own floor, ~4e-9 (the same as without a shadow)
    t = np.array([-3000.0, 6000.0, 21600.0])
    f = forces(shadow)
    _, phi = Dynamics(vv.EARTH.gm_km3_s2, f, EPOCH, (t.min(), t.max()), 1e-13,
                      1e-13).propagate(vec(leo()), t)  # fmt: skip
    fd = _fd_stm(f, t, leo())
    rel = np.abs(fd - phi).max(axis=(1, 2)) / np.abs(fd).max(axis=(1, 2))
    assert rel.max() < 3e-8  # without the shadow terms: 1e-6 after 6 h
    # the default tolerances of the fits: the STM's own integration error, ~2e-8
    _, phi = Dynamics(vv.EARTH.gm_km3_s2, f, EPOCH, (t.min(), t.max())).propagate(vec(leo()), t)
    assert (np.abs(fd - phi).max(axis=(1, 2)) / np.abs(fd).max(axis=(1, 2))).max() < 1e-7


def test_penumbra_gradient_matches_finite_differences_of_the_acceleration():
    # a point in the conical penumbra: the partials include the change of the visible fraction
    from visviva.core.perturbations import shadow_fraction
    from visviva.core.variational import acceleration_partials
    from visviva.satellites.cowell import ForceModel

    srp = [vv.SolarRadiationPressure(AM, 1.5, shadow="conical")]
    model = ForceModel(1.0, srp, (), EPOCH, (0.0, 100.0))
    kepler = ForceModel(1.0, [], (), EPOCH, (0.0, 100.0))
    from visviva.core import force_block as fb
    from visviva.core.perturbations import hermite_position

    force = model.force
    s = np.empty(3)
    hermite_position(0.0, int(force[fb.SUN_ROW]), force, model.eph_r,
                     model.eph_v, s)  # fmt: skip
    s_hat = s / np.linalg.norm(s)
    side = np.cross(s_hat, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    cands = [-5000.0 * s_hat + side * w for w in np.linspace(6300.0, 6500.0, 2001)]
    nus = [shadow_fraction(*p, *s, force[fb.RADIUS],
                           force[fb.SUN_RADIUS], 2) for p in cands]
    r = cands[int(np.argmin(np.abs(np.array(nus) - 0.5)))]
    y = np.r_[r, 0.0, 7.5, 0.0]

    def accel(y):
        return (model.acceleration(0.0, y[None, :3], y[None, 3:])[0]
                - kepler.acceleration(0.0, y[None, :3], y[None, 3:])[0])

    dadr, dadv, dadr_k = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
    acceleration_partials(0.0, y, *model.arrays(), dadr, dadv)
    acceleration_partials(0.0, y, *kepler.arrays(), dadr_k, dadv)
    fd = np.empty((3, 3))
    for j in range(3):
        yp, ym = y.copy(), y.copy()
        yp[j] += 0.01
        ym[j] -= 0.01
        fd[:, j] = (accel(yp) - accel(ym)) / 0.02
    assert np.abs(fd).max() > 1e-13  # the penumbra's gradient: ~1e-12 /s^2, the rest ~1e-18
    np.testing.assert_allclose(dadr - dadr_k, fd, rtol=0, atol=1e-4 * np.abs(fd).max())


def test_a_shadow_never_entered_changes_no_bit():
    # a dawn-dusk orbit at the solstice stays in sunlight: the boundary search finds nothing,
    # the steps and the force are those of SRP without a shadow, bit for bit
    epoch = Time("2024-06-21T00:00:00", scale="utc")
    state = vv.KeplerianElements.from_semi_major_axis(
        7000 * u.km, 0.0, 98 * u.deg, 0.0 * u.deg, 0.0, 0.0, vv.EARTH, epoch=epoch
    ).to_state()
    t = np.linspace(0.0, 6000.0, 11)
    out = []
    for shadow in ("conical", "cylindrical", None):
        dyn = Dynamics(vv.EARTH.gm_km3_s2, forces(shadow), epoch, (0.0, 6000.0))
        out.append(dyn.propagate(vec(state), t))
    ecl = vv.propagate_cowell(state, t * u.s, forces("conical"),
                              events=[vv.satellites.Eclipse("conical")])
    assert ecl.events == []
    for y, phi in out[:2]:
        np.testing.assert_array_equal(y, out[2][0])
        np.testing.assert_array_equal(phi, out[2][1])


@pytest.mark.parametrize("shadow", ["conical", "cylindrical"])
def test_fit_with_srp_and_shadow_recovers_the_truth(shadow):
    # position fixes (1 cm noise) every 15 min over a LEO day from a tight propagate_cowell run:
    # the fit's model now matches it, so the estimate is off by its statistics alone (with
    # perfect fixes 0.3 mm; before: 18 cm / 13 cm, residuals up to 28 cm, 30 sigma)
    from scipy import stats

    f = forces(shadow)
    t = np.linspace(0, 1.0, 97) * u.day
    ref = vv.propagate_cowell(leo(), t, f, max_step=2 * u.s, **TIGHT)
    rng = np.random.default_rng(7)
    sigma = 1e-5  # km
    obs = vv.Observations(time=EPOCH + t, kind="position",
                          value=list(ref.r.to_value(u.km) + sigma * rng.standard_normal((97, 3))),
                          sigma=sigma)  # fmt: skip
    guess = vv.StateVectors(leo().r + [0.5, -0.3, 0.2] * u.km,
                            leo().v + [1e-4, 2e-4, -1e-4] * KMS, vv.EARTH, epoch=EPOCH)
    fit = vv.fit_orbit(obs, guess, f)
    assert fit.converged and 0.8 < fit.rms < 1.2
    e = vec(fit.state) - vec(leo())
    assert np.linalg.norm(e[:3]) < 1e-5  # 1 cm
    assert e @ np.linalg.solve(fit.covariance, e) < stats.chi2.ppf(0.999, 6)
