"""MEGNO with WHFast (visviva.core.nbody_wh_tangent): the tangent map of the Kepler drift against
finite differences, the tangent vector against REBOUND's WHFast variational particles and
against two nearby WHFast runs, MEGNO and the Lyapunov exponent against REBOUND's."""

from __future__ import annotations

import math

import numpy as np
import pytest

import visviva as vv
from visviva.core import nbody_wh_tangent as wt
from visviva.core import nbody_whfast as wh
from visviva.core.status import OK
from visviva.core.universal import propagate_one
from visviva.errors import InvalidInputError

ORBIT = 2.0 * math.pi  # the inner planet's period (G = 1, M = 1, a = 1)
DT = ORBIT / 100
REGULAR_A2 = 1.6  # quasi-periodic (outside the Hill-stability limit; tests/test_nbody_megno.py)
CHAOTIC_A2 = 1.25  # chaotic (inside it)


def _delta(n=3, seed=3):
    d = np.random.default_rng(seed).standard_normal((n, 6))
    return d / np.linalg.norm(d)  # init_megno scales to unit length; REBOUND keeps it as given


def _rebound(a2):
    rebound = pytest.importorskip("rebound")
    r = rebound.Simulation()
    r.add(m=1.0)
    r.add(m=1e-3, a=1.0)
    r.add(m=1e-3, a=a2, f=2.0)
    r.move_to_com()
    return r


def _visviva(r, offset=None, **kw):
    kw.setdefault("exact_finish_time", False)
    sim = vv.Simulation(integrator="whfast", dt=DT, **kw)
    for i, p in enumerate(r.particles):
        s = np.array([p.x, p.y, p.z, p.vx, p.vy, p.vz])
        if offset is not None:
            s = s + offset[i]
        sim.add(p.m, r=s[:3], v=s[3:])
    return sim


def _pair(a2, delta):
    """The same system and initial tangent vector in visviva's and REBOUND's WHFast."""
    r = _rebound(a2)
    sim = _visviva(r)
    sim.init_megno(delta=delta)
    r.integrator = "whfast"
    r.dt = DT
    r.init_megno(seed=1)
    for i, p in enumerate(r.var_config[0].particles):
        p.x, p.y, p.z, p.vx, p.vy, p.vz = delta[i]
    return sim, r


def _rebound_tangent(r):
    return np.array([[p.x, p.y, p.z, p.vx, p.vy, p.vz] for p in r.var_config[0].particles])


@pytest.mark.parametrize("x0, v0, h", [
    ([1.0, 0.2, 0.1], [0.1, 1.05, 0.2], 0.7),  # ellipse, a fraction of an orbit
    ([1.0, 0.2, 0.1], [0.1, 1.05, 0.2], -23.0),  # ellipse, backwards over several orbits
    ([1.0, 0.2, 0.1], [0.3, 1.6, 0.2], 3.0),  # hyperbola
    ([0.5, -0.3, 0.0], [0.9, 1.5, 0.1], 2.0),  # near-parabolic (beta ~ 0.01)
    ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], 0.0),  # no drift: the identity
])
def test_kepler_tangent_is_the_derivative_of_the_drift(x0, v0, h):
    """The tangent of the universal-variable drift against central differences of
    propagate_one (step 1e-6: the difference quotient is good to ~1e-10)."""
    x0 = np.array(x0)
    v0 = np.array(v0)
    d = np.random.default_rng(5).standard_normal(6)
    rows = np.zeros((6, 2, 3))  # row 1 of (2, 3) arrays: x0, v0, dx, dv, xo, vo
    rows[:4, 1] = x0, v0, d[:3], d[3:]
    assert wt.kepler_tangent(*rows[:4], 1, 1.0, h, *rows[4:])[0] == OK
    dx, dv, xo, vo = rows[2:, 1]

    def drift(x, v):
        r, w = np.zeros(3), np.zeros(3)
        propagate_one(x, v, 1.0, h, r, w)
        return np.concatenate([r, w])

    eps = 1e-6
    fd = (drift(x0 + eps * d[:3], v0 + eps * d[3:])
          - drift(x0 - eps * d[:3], v0 - eps * d[3:])) / (2 * eps)
    np.testing.assert_allclose(np.concatenate([dx, dv]), fd, rtol=0, atol=1e-8 * np.abs(fd).max())
    np.testing.assert_allclose(np.concatenate([xo, vo]), drift(x0, v0), rtol=0, atol=1e-14)


def test_regular_whfast_megno_and_tangent_match_rebound():
    """Quasi-periodic: after 500 orbits (50,000 steps of P/100) <Y> is within 0.1 % of REBOUND's
    WHFast (measured 1.958680 vs 1.958864) and ~2; the tangent vector is REBOUND's to 4e-9
    (the same linear map of the same vector)."""
    d = _delta()
    sim, r = _pair(REGULAR_A2, d)
    t = 50000 * DT
    sim.integrate(t)
    r.integrate(t)
    assert sim.t == r.t
    assert sim.megno() == pytest.approx(r.megno(), rel=1e-3)
    assert sim.megno() == pytest.approx(2.0, abs=0.05)
    assert abs(sim.lyapunov()) < 1e-3
    dr = _rebound_tangent(r)
    np.testing.assert_allclose(sim.tangent_vector, dr, rtol=0, atol=1e-7 * np.abs(dr).max())


def test_chaotic_whfast_megno_lyapunov_and_growth_match_rebound():
    """Chaotic: at t = 300 (4775 steps, ~20 Lyapunov times) <Y> within 1 % of REBOUND's
    (measured 7.2693 vs 7.2735), lambda within 5 % of 2 x REBOUND's lyapunov() (0.04064 vs
    0.04058) and the tangent vector's growth ln|delta(t)/delta(0)| / t within 1e-3 of REBOUND's
    variational particles'."""
    d = _delta()
    sim, r = _pair(CHAOTIC_A2, d)
    t = 4775 * DT
    sim.integrate(t)
    r.integrate(t)
    assert sim.megno() > 5.0
    assert sim.megno() == pytest.approx(r.megno(), rel=0.01)
    assert sim.lyapunov() == pytest.approx(2.0 * r.lyapunov(), rel=0.05)
    growth = math.log(np.linalg.norm(_rebound_tangent(r))) / t
    assert math.log(np.linalg.norm(sim.tangent_vector)) / t == pytest.approx(growth, rel=1e-3)


@pytest.mark.parametrize("a2, steps", [(REGULAR_A2, 3183), (CHAOTIC_A2, 1592)])
def test_tangent_vector_is_the_difference_of_two_nearby_runs(a2, steps):
    """The tangent vector against central differences of two WHFast runs started eps * delta
    apart (eps = 1e-7): agreement to 1e-6 of its size (measured 2e-8 and 8e-8)."""
    d = _delta()
    r = _rebound(a2)
    sim = _visviva(r)
    sim.init_megno(delta=d)
    t = steps * DT
    sim.integrate(t)
    eps = 1e-7
    plus = _visviva(r, eps * d)
    plus.integrate(t)
    minus = _visviva(r, -eps * d)
    minus.integrate(t)
    fd = np.concatenate([plus.positions - minus.positions,
                         plus.velocities - minus.velocities], axis=1) / (2 * eps)
    np.testing.assert_allclose(sim.tangent_vector, fd, rtol=0, atol=1e-6 * np.abs(fd).max())


def test_whfast_megno_leaves_the_trajectory_bit_identical_and_resumes_bit_for_bit(tmp_path):
    """The particles are those of a run without MEGNO (which takes the plain kernel); output
    times between steps (copies) change nothing; a saved run continues bit for bit; a run
    backwards counts |t|."""
    r = _rebound(CHAOTIC_A2)
    plain = _visviva(r, exact_finish_time=True)
    assert wh.is_plain(plain._state.istate, plain._state.fstate)
    plain.integrate(40 * ORBIT)
    one = _visviva(r, exact_finish_time=True)
    one.init_megno(seed=7)
    assert not wh.is_plain(one._state.istate, one._state.fstate)
    one.integrate(40 * ORBIT)
    assert np.array_equal(plain.positions, one.positions)
    assert np.array_equal(plain.velocities, one.velocities)
    outputs = _visviva(r, exact_finish_time=True)
    outputs.init_megno(seed=7)
    outputs.integrate(np.linspace(0.37, 20 * ORBIT + 0.37, 13))
    outputs.save(tmp_path / "s.npz")
    back = vv.Simulation.load(tmp_path / "s.npz")
    for s in (outputs, back):
        s.integrate(40 * ORBIT)
        assert s.megno() == one.megno() and s.lyapunov() == one.lyapunov()
        assert np.array_equal(s.tangent_vector, one.tangent_vector)
    backwards = _visviva(r)
    backwards.init_megno(seed=7)
    backwards.integrate(-40 * ORBIT)
    assert backwards.megno() > 3.0 and backwards.lyapunov() > 0.01


def test_whfast_megno_in_a_packed_ensemble_matches_lone_runs():
    from visviva.nbody.ensemble_pack import Pack

    def members():
        out = []
        for a2 in (REGULAR_A2, CHAOTIC_A2, 1.4):
            s = _visviva(_rebound(a2))
            s.init_megno(seed=3)
            out.append(s)
        return out

    lone = members()
    for s in lone:
        s.integrate(100.0)
    packed = members()
    pack = Pack.build(packed)
    assert pack is not None and pack.advance(100.0) == []
    np.testing.assert_array_equal([s.megno() for s in packed], [s.megno() for s in lone])
    assert packed[1].megno() > packed[0].megno()
    # a member's own setting without a tangent map is refused, not run without MEGNO
    ens = vv.Ensemble(members())
    ens.integrate(10.0)
    ens._members[2].corrector = 3
    with pytest.raises(InvalidInputError, match="corrector"):
        ens.integrate(20.0)


def test_whfast_megno_refuses_what_it_has_no_tangent_map_for():
    r = _rebound(REGULAR_A2)
    sim = _visviva(r, coordinates="democratic_heliocentric")
    with pytest.raises(InvalidInputError, match="coordinates = 'jacobi'"):
        sim.init_megno()
    sim = _visviva(r, corrector=5)
    with pytest.raises(InvalidInputError, match="corrector = 0"):
        sim.init_megno()
    for setting, value in (("collision", "halt"), ("encounter_distance", 0.01),
                           ("exit_max_distance", 100.0)):
        sim = _visviva(r)
        sim.init_megno(seed=1)
        setattr(sim, setting, value)
        with pytest.raises(InvalidInputError, match="collision='none'"):
            sim.integrate(1.0)
