"""Simulation.orbits(): osculating Jacobi and heliocentric elements against REBOUND 5.2.2.

audit45: a REBOUND user's ``sim.orbits()`` / ``particle.orbit()`` had no counterpart; the
elements had to be rebuilt by hand from positions, velocities and the right GM."""

from __future__ import annotations

import numpy as np
import pytest

import visviva as vv

ELEMENTS = [  # (mass, elements about the star)
    (1e-3, dict(a=0.4, e=0.2, inc=0.1, raan=0.5, argp=1.0, nu=2.0)),
    (0.0, dict(a=1.0, e=0.05, inc=np.pi - 0.2, raan=2.0, argp=4.0, nu=-1.0)),  # retrograde
    (2e-4, dict(a=-2.0, e=1.4, inc=0.7, raan=5.0, argp=0.3, nu=0.5)),  # hyperbolic
    (1e-5, dict(a=3.0, e=0.6, inc=0.3, raan=1.0, argp=2.0, nu=-3.0)),
]
_RB = {"raan": "Omega", "argp": "omega", "nu": "f"}


def _angle(a, b):
    return np.abs((np.asarray(a) - np.asarray(b) + np.pi) % (2 * np.pi) - np.pi)


def _systems():
    rebound = pytest.importorskip("rebound")
    sim, ref = vv.Simulation(), rebound.Simulation()
    sim.add(1.0)
    ref.add(m=1.0)
    for m, el in ELEMENTS:
        sim.add(m, primary=0, **el)
        ref.add(m=m, primary=ref.particles[0], **{_RB.get(k, k): val for k, val in el.items()})
    sim.move_to_com()
    ref.move_to_com()
    return sim, ref


@pytest.mark.parametrize("heliocentric", [False, True])
def test_orbits_equal_rebound(heliocentric):
    sim, ref = _systems()
    ours = sim.orbits(primary=0 if heliocentric else None)
    theirs = ref.orbits(primary=ref.particles[0]) if heliocentric else ref.orbits()
    assert ours.index.tolist() == [1, 2, 3, 4] and len(ours) == 4
    for k, orb in enumerate(theirs):
        assert ours.a[k] == pytest.approx(orb.a, rel=1e-14)
        assert ours.e[k] == pytest.approx(orb.e, abs=1e-14)
        for mine, name in (("inc", "inc"), ("raan", "Omega"), ("argp", "omega"), ("nu", "f"),
                           ("mean_anomaly", "M")):
            assert _angle(getattr(ours, mine)[k], getattr(orb, name)) < 5e-14, (k, mine)
        if orb.e < 1:
            assert ours.period[k] == pytest.approx(orb.P, rel=1e-14)
        else:  # REBOUND gives a negative "period" for a hyperbola
            assert ours.period[k] == np.inf and ours.a[k] < 0


@pytest.mark.parametrize("primary", [None, 0])
def test_orbits_put_back_by_add_give_the_same_particles(primary):
    sim, _ = _systems()
    el = sim.orbits(primary)
    again = vv.Simulation()
    again.add(sim.masses[0], r=sim.positions[0], v=sim.velocities[0])
    for i in range(1, sim.N):
        again.add(sim.masses[i], primary=primary, **el.elements(i))
    np.testing.assert_allclose(again.positions, sim.positions, rtol=0, atol=1e-14)
    np.testing.assert_allclose(again.velocities, sim.velocities, rtol=0, atol=1e-14)


def test_orbits_about_a_planet_and_refusals():
    sim = vv.Simulation()
    sim.add(1.0)
    sim.add(1e-3, a=1.0, primary=0)
    sim.add(0.0, a=0.01, e=0.1, nu=0.4, primary=1)  # a moon of the planet
    moon = sim.orbits(primary=1)
    assert moon.index.tolist() == [0, 2] and moon.primary == 1
    assert moon.a[1] == pytest.approx(0.01, rel=1e-12) and moon.e[1] == pytest.approx(0.1, rel=1e-10)
    assert moon.gm[1] == sim.G * 1e-3
    with pytest.raises(vv.InvalidInputError, match="no row"):
        moon.elements(1)
    with pytest.raises(vv.InvalidInputError, match="primary must be a particle index"):
        sim.orbits(primary=3)
    lone = vv.Simulation()
    lone.add(0.0)
    lone.add(0.0, r=[1.0, 0.0, 0.0], v=[0.0, 1.0, 0.0])
    with pytest.raises(vv.InvalidInputError, match="GM = 0"):
        lone.orbits()
    radial = vv.Simulation()
    radial.add(1.0)
    radial.add(0.0, r=[1.0, 0.0, 0.0], v=[0.5, 0.0, 0.0])
    with pytest.raises(vv.InvalidStateError, match="radial.*particle=1"):
        radial.orbits()


def test_particles_by_name_in_remove_set_particle_add_and_orbits():
    # audit45: REBOUND removes and finds particles by name (sim.remove(hash="jupiter"),
    # primary=sim.particles["earth"]); sim.remove("jupiter") raised "a particle index must be
    # an integer" although sim.names held the name
    sim = vv.Simulation()
    sim.add(1.0)
    sim.add(1e-3, a=1.0, primary=0)
    sim.add(3e-4, a=1.6, e=0.1, primary=0)
    sim.names = ["sun", "jupiter", "saturn"]
    sim.add(0.0, a=0.01, primary="jupiter")  # a moon, named "" (unnamed)
    assert sim.orbits(primary="jupiter").a[-1] == pytest.approx(0.01, rel=1e-12)
    np.testing.assert_array_equal(sim.orbits(primary="sun").a, sim.orbits(primary=0).a)
    sim.set_particle("saturn", m=2e-4)
    assert sim.masses[2] == 2e-4
    with pytest.raises(vv.InvalidInputError, match="no particle is named 'uranus'"):
        sim.remove("uranus")
    with pytest.raises(vv.InvalidInputError, match="no particle is named ''"):
        sim.remove("")
    sim.remove("jupiter", merged_into="saturn")
    assert sim.names == ["sun", "saturn", ""] and sim.masses.tolist() == [1.0, 2e-4, 0.0]
    sim.names = ["sun", "saturn", "saturn"]
    with pytest.raises(vv.InvalidInputError, match=r"2 particles are named 'saturn' \(indices"):
        sim.remove("saturn")


def test_orbits_keep_a_node_near_zero():
    # the Earth-Moon barycentre of vv.solar_system() has its node at 2.9e-6 rad in ICRF, where
    # REBOUND's Omega (an arc cosine) is 1.1e-11 off; visviva's atan2 keeps it to the round-off of the state (2e-17 here)
    sim = vv.Simulation()
    sim.add(1.0)
    sim.add(3e-6, a=1.0, e=0.0167, inc=0.409, raan=2.9e-6, argp=1.796, nu=-0.044, primary=0)
    el = sim.orbits(primary=0)
    assert abs(el.raan[0] - 2.9e-6) < 1e-15  # rad: the state's own round-off (REBOUND: 1.1e-11)
    assert el.e[0] == pytest.approx(0.0167, rel=1e-13) and el.inc[0] == pytest.approx(0.409, rel=1e-15)
