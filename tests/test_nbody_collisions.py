"""Collisions (merge, bounce, halt), encounters and escapes."""

from __future__ import annotations

import numpy as np
import pytest

import visviva as vv


def head_on(collision, restitution=1.0, integrator="ias15", G=1e-12):
    sim = vv.Simulation(integrator, G=G, dt=0.001, collision=collision, restitution=restitution)
    sim.add(2.0, r=[-1.0, 0.1, 0.0], v=[1.0, 0.0, 0.0], radius=0.2)
    sim.add(1.0, r=[1.0, 0.0, 0.0], v=[-0.5, 0.05, 0.0], radius=0.2)
    return sim


def test_halt_raises_collision_with_the_pair():
    sim = head_on("halt")
    with pytest.raises(vv.Collision) as info:
        sim.integrate(5.0)
    assert info.value.particles == (0, 1)
    assert 0.0 < info.value.t < 5.0 and sim.t == info.value.t
    d = np.linalg.norm(sim.positions[1] - sim.positions[0])
    assert d < 0.4


@pytest.mark.parametrize("integrator", ["ias15", "leapfrog", "whfast"])
def test_merge_conserves_mass_momentum_and_tracked_energy(integrator):
    sim = head_on("merge", integrator=integrator)
    p0 = sim.momentum()
    E0 = sim.energy()
    traj = sim.integrate(np.linspace(0.5, 3.0, 6))
    assert sim.N == 1
    assert sim.masses[0] == 3.0
    np.testing.assert_allclose(sim.momentum(), p0, rtol=0, atol=1e-13)  # steps' round-off
    # the kinetic energy lost in the merger is kept in energy_offset
    assert sim.energy_offset < 0 or sim.energy_offset > 0
    assert sim.energy() == pytest.approx(E0, rel=1e-12)
    # the merged particle's radius keeps the volume
    assert sim.radii[0] == pytest.approx(0.2 * 2 ** (1 / 3))
    # snapshots after the merger have NaN for the removed particle
    assert np.isnan(traj.positions[-1, 1]).all() and np.isfinite(traj.positions[-1, 0]).all()


def test_merge_itself_conserves_momentum_to_the_last_bit():
    from visviva.nbody.collisions import merge

    sim = head_on("halt")
    with pytest.raises(vv.Collision):
        sim.integrate(5.0)
    p0 = sim.momentum()
    merge(sim, 0, 1)
    np.testing.assert_allclose(sim.momentum(), p0, rtol=0, atol=2.3e-16)


@pytest.mark.parametrize("e", [1.0, 0.5, 0.0])
def test_bounce_conserves_momentum_and_loses_energy_as_restitution_says(e):
    sim = head_on("bounce", restitution=e)
    p0 = sim.momentum()
    K0 = sim.energy(include_offset=False)
    # normal relative speed at contact is needed for the expected loss: stop just before
    probe = head_on("halt")
    with pytest.raises(vv.Collision):
        probe.integrate(5.0)
    d = probe.positions[1] - probe.positions[0]
    n = d / np.linalg.norm(d)
    vn = (probe.velocities[1] - probe.velocities[0]) @ n
    mu = 2.0 / 3.0
    expected_loss = 0.5 * (1 - e**2) * mu * vn**2
    sim.integrate(5.0)
    np.testing.assert_allclose(sim.momentum(), p0, rtol=0, atol=4e-16)
    loss = K0 - sim.energy(include_offset=False)
    assert loss == pytest.approx(expected_loss, rel=1e-9, abs=1e-15)
    assert sim.energy() == pytest.approx(K0, rel=1e-13)
    # they separate afterwards
    d = sim.positions[1] - sim.positions[0]
    assert (sim.velocities[1] - sim.velocities[0]) @ d >= 0 or e == 0.0


def test_encounter_and_escape():
    sim = vv.Simulation("ias15", encounter_distance=0.5)
    sim.add(1.0)
    sim.add(1e-3, r=[3.0, 0.2, 0.0], v=[-1.0, 0.0, 0.0])
    with pytest.raises(vv.Encounter) as info:
        sim.integrate(10.0)
    assert info.value.particles == (0, 1)
    sim = vv.Simulation("leapfrog", dt=0.01, exit_max_distance=10.0)
    sim.add(1.0)
    sim.add(0.0, r=[1.0, 0, 0], v=[0, 2.0, 0])  # unbound
    with pytest.raises(vv.Escape) as info:
        sim.integrate(100.0)
    assert info.value.particles == (1,)
    assert np.linalg.norm(sim.positions[1]) > 10.0
