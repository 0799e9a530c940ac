"""WHFast in democratic heliocentric coordinates (Duncan, Levison & Lee 1998).

What holds for this splitting (and is tested here): the jump term |sum p_i|^2 / (2 m_0) does
not vanish for one planet, so unlike Jacobi WHFast the two-body map is NOT exact; it is
symplectic and time-symmetric, so the energy error is bounded, O((m_1/m_0) (n h)^2), and
oscillates without drift; angular and linear momentum are conserved to round-off; and the map is
the one REBOUND 5.2 uses for ``coordinates="democraticheliocentric"`` (agreement to round-off
after the same number of steps).
"""

from __future__ import annotations

import math
import subprocess
import sys

import numba
import numpy as np
import pytest

import visviva as vv
from visviva.validation.checks_nbody import outer_solar_system as _outer
from visviva.validation.checks_nbody import whfast_vs_rebound

DH = "democratic_heliocentric"


def kepler_pair(e=0.3, dt=0.1, m1=1e-3):
    sim = vv.Simulation("whfast", dt=dt, coordinates=DH)
    sim.add(1.0)
    sim.add(m1, a=1.0, e=e, primary=0)
    sim.move_to_com()
    return sim


def outer_solar_system(dt=0.5, coordinates=DH):
    """Sun + Jupiter..Neptune at J2000 (au, yr, Msun), barycentric, with WHFast."""
    return _outer("whfast", dt=dt, coordinates=coordinates)


# ---- the API ----------------------------------------------------------------------------------
def test_coordinates_parameter_alias_default_and_registry():
    assert vv.Simulation("whfast", dt=0.1).coordinates == "jacobi"
    assert vv.Simulation("whfast", dt=0.1, coordinates="democraticheliocentric").coordinates == DH
    assert vv.Simulation("whfast", dt=0.1, coordinates="Democratic_Heliocentric").coordinates == DH
    from visviva.nbody.integrators import INTEGRATORS

    assert INTEGRATORS["whfast"].coordinates == ("jacobi", DH)
    with pytest.raises(vv.InvalidInputError, match="choose one of"):
        vv.Simulation("whfast", dt=0.1, coordinates="whds")
    with pytest.raises(vv.InvalidInputError, match="only WHFast"):
        vv.Simulation("ias15", coordinates=DH)


def test_correctors_are_rejected_for_these_coordinates():
    with pytest.raises(vv.InvalidInputError, match="Jacobi"):
        vv.Simulation("whfast", dt=0.1, coordinates=DH, corrector=5)
    sim = vv.Simulation("whfast", dt=0.1, corrector=3)
    with pytest.raises(vv.InvalidInputError, match="corrector=0 first"):
        sim.coordinates = DH
    sim = vv.Simulation("whfast", dt=0.1, coordinates=DH)
    with pytest.raises(vv.InvalidInputError, match="do not apply"):
        sim.corrector = 7


def test_velocity_dependent_forces_are_rejected():
    sim = kepler_pair()
    with pytest.raises(vv.InvalidInputError, match="depends on velocities"):
        sim.add_force(vv.nbody.forces.GeneralRelativity(c=1e4))


# ---- two bodies: bounded energy error, no drift, momenta to round-off ---------------------------
@pytest.mark.parametrize("steps_per_orbit", [100, 20, 7])
@pytest.mark.filterwarnings("ignore:WHFast's step")  # 7 per orbit is coarse on purpose
def test_two_bodies_energy_bounded_without_drift_over_1000_orbits(steps_per_orbit):
    n_h = 2 * math.pi / steps_per_orbit  # mean motion times the step
    sim = kepler_pair(e=0.3, dt=n_h)
    E0, L0, P0 = sim.energy(), sim.angular_momentum(), sim.momentum()
    traj = sim.integrate(np.linspace(0.0, 2 * math.pi * 1000, 101)[1:])
    err = np.abs(traj.energy() / E0 - 1)
    # bounded: O((m1/m0) (n h)^2) (the jump term), and the same in both halves
    assert err.max() < 1e-3 * n_h**2 * 2.0
    assert err[50:].max() < 1.2 * err[:50].max()
    assert err.max() > 1e-12  # not exact (the Jacobi map is): the splitting error is there
    assert np.abs(sim.angular_momentum() - L0).max() < 1e-15
    assert np.abs(sim.momentum() - P0).max() < 1e-16


def test_two_body_energy_error_scales_with_the_mass_ratio_and_dt_squared():
    errs = {}
    for m1 in (1e-3, 1e-5):
        for steps in (100, 50):
            sim = kepler_pair(e=0.3, dt=2 * math.pi / steps, m1=m1)
            E0 = sim.energy()
            traj = sim.integrate(np.linspace(0.0, 2 * math.pi * 10, 201)[1:])
            errs[m1, steps] = np.abs(traj.energy() / E0 - 1).max()
    assert errs[1e-3, 50] / errs[1e-3, 100] == pytest.approx(4.0, rel=0.15)
    assert errs[1e-3, 100] / errs[1e-5, 100] == pytest.approx(100.0, rel=0.05)


def test_circular_orbit_energy_error_oscillates_without_drift():
    # the slowest case: the error of a circular orbit oscillates with a period of ~2,000 orbits
    sim = kepler_pair(e=0.0, dt=2 * math.pi / 7)
    E0 = sim.energy()
    traj = sim.integrate(np.linspace(0.0, 2 * math.pi * 10000, 101)[1:])
    err = np.abs(traj.energy() / E0 - 1)
    assert err[50:].max() < 1.05 * err[:50].max()
    assert err.max() < 1e-8


@pytest.mark.parametrize("e,steps_per_orbit", [(0.0, 20), (0.3, 100), (0.3, 20)])
def test_two_bodies_agree_with_rebound_over_1000_orbits(e, steps_per_orbit):
    pytest.importorskip("rebound")
    sim = kepler_pair(e=e, dt=2 * math.pi / steps_per_orbit)
    rel, dE, _, det = whfast_vs_rebound(sim, 2 * math.pi * 1000, samples=4)
    assert "DEMOCRATICHELIOCENTRIC" in det["rebound"]
    # measured 3e-11 .. 2e-10: round-off of the same map (at e = 0.3 and 7 steps per orbit
    # the map amplifies round-off: 7e-11 .. 1.6e-9 depending on the Kepler solver's last bits)
    assert rel.max() < 1e-9
    assert dE < 1e-12


# ---- the outer solar system ---------------------------------------------------------------------
def test_outer_solar_system_energy_bounded_without_drift_1e5_steps():
    sim = outer_solar_system(dt=0.5)  # 1/24 of Jupiter's period
    E0 = sim.energy()
    traj = sim.integrate(np.linspace(500.0, 50000.0, 100))
    err = np.abs(traj.energy() / E0 - 1)
    assert err.max() < 1e-5
    assert err[50:].max() < 2.0 * err[:50].max()


def test_agrees_with_rebound_democratic_heliocentric_outer_solar_system_1000_years():
    """The issue's requirement: same dt (4.4 d), no correctors, after the same number of steps
    (83,011), every planet within 1e-10 relative (measured 2.6e-11, Jupiter; Jacobi 3.4e-11)."""
    pytest.importorskip("rebound")
    sim = outer_solar_system(dt=4.4 / 365.25)
    rel, dE, e_max, det = whfast_vs_rebound(sim, 1000.0, samples=5)
    assert "DEMOCRATICHELIOCENTRIC" in det["rebound"]
    assert det["steps"] == 83011
    assert rel.max() < 1e-10
    assert dE < 1e-13
    assert e_max < 1e-8  # measured 5.2e-10


def test_test_particles_agree_with_rebound():
    pytest.importorskip("rebound")
    sim = outer_solar_system(dt=4.4 / 365.25)
    sim.add(0.0, primary=0, a=3.1, e=0.1, inc=0.05)  # an asteroid
    sim.add(0.0, primary=0, a=42.0, e=0.05, inc=0.1, nu=1.0)  # a Kuiper-belt object
    rel, dE, _, det = whfast_vs_rebound(sim, 100.0, samples=3)
    assert rel.max() < 1e-10  # measured 1.4e-12
    assert dE < 1e-13


def test_differs_from_jacobi_by_the_splitting_error_only():
    a = outer_solar_system(dt=0.05)
    b = outer_solar_system(dt=0.05, coordinates="jacobi")
    ref = outer_solar_system(coordinates="jacobi")
    ref.integrator = "ias15"
    for s in (a, b, ref):
        s.integrate(100.0)
    for s in (a, b):
        d = np.linalg.norm(s.positions - ref.positions, axis=1)[1:]
        assert (d / np.linalg.norm(ref.positions, axis=1)[1:]).max() < 1e-5


# ---- symmetry, restart, outputs -----------------------------------------------------------------
def test_forward_then_backward_returns_home():
    sim = outer_solar_system(dt=0.3)
    x0, v0 = sim.positions, sim.velocities
    sim.integrate(300.0)
    sim.integrate(0.0)
    assert sim.t == 0.0
    # 2,000 steps of round-off, as for the other reversible integrators: ~1e-11 au
    np.testing.assert_allclose(sim.positions, x0, rtol=0, atol=5e-11)  # au
    np.testing.assert_allclose(sim.velocities, v0, rtol=0, atol=5e-11)  # au/yr


def test_save_load_in_process_and_in_a_fresh_process_bit_for_bit(tmp_path):
    one_go = outer_solar_system(dt=0.3)
    one_go.integrate(60.1)
    first = outer_solar_system(dt=0.3)
    first.integrate(30.05)  # off the step grid
    path = tmp_path / "dh.npz"
    first.save(path)
    back = vv.Simulation.load(path)
    assert back.coordinates == DH
    np.testing.assert_array_equal(first.state_arrays()["buf"], back.state_arrays()["buf"])  # the unsynchronised DH state
    back.integrate(60.1)
    np.testing.assert_array_equal(back.positions, one_go.positions)
    out = tmp_path / "dh.npy"
    code = (f"import numpy as np, visviva as vv\nsim = vv.Simulation.load({str(path)!r})\n"
            f"assert sim.coordinates == {DH!r}\nsim.integrate(60.1)\n"
            f"np.save({str(out)!r}, np.concatenate([sim.positions, sim.velocities]))")
    subprocess.run([sys.executable, "-c", code], check=True)
    res = np.load(out)
    np.testing.assert_array_equal(res[:5], one_go.positions)
    np.testing.assert_array_equal(res[5:], one_go.velocities)


def test_archive_keeps_the_coordinates(tmp_path):
    sim = outer_solar_system(dt=0.3)
    archive = vv.nbody.Archive.record(sim, tmp_path / "a.npz", interval=10.0, t_end=30.0)
    snap = vv.nbody.Archive(tmp_path / "a.npz")[1]
    assert snap.coordinates == DH
    snap.integrate(30.0)
    np.testing.assert_array_equal(snap.positions, sim.positions)
    assert len(archive) == 4


def test_files_without_the_coordinates_slot_load_as_jacobi(tmp_path):
    # files written before democratic heliocentric coordinates existed have 0 in that slot
    sim = outer_solar_system(dt=0.3, coordinates="jacobi")
    sim.integrate(3.0)
    sim.save(tmp_path / "old.npz")
    assert vv.Simulation.load(tmp_path / "old.npz").coordinates == "jacobi"


# ---- REBOUND interop ----------------------------------------------------------------------------
def test_to_and_from_rebound_carry_the_coordinates():
    rebound = pytest.importorskip("rebound")
    r = outer_solar_system().to_rebound()
    assert str(r.integrator.coordinates) == "DEMOCRATICHELIOCENTRIC"
    assert str(outer_solar_system(coordinates="jacobi").to_rebound().integrator.coordinates) == (
        "JACOBI")
    back = vv.Simulation.from_rebound(r)
    assert back.integrator == "whfast" and back.coordinates == DH
    r = rebound.Simulation()
    r.add(m=1.0)
    r.add(m=1e-3, a=1.0)
    r.integrator = "whfast"
    r.integrator.coordinates = "whds"
    with pytest.raises(vv.InvalidInputError, match="no visviva counterpart"):
        vv.Simulation.from_rebound(r)


# ---- forces, test particles, events -------------------------------------------------------------
@numba.njit
def uniform_field(t, x, v, m, params, acc):
    for i in range(x.shape[0]):
        acc[i, 0] += params[0]
        acc[i, 2] += params[1]


def test_uniform_field_moves_only_the_centre_of_mass():
    """A uniform acceleration g acts on the centre of mass only (its barycentric mean is g):
    every position shifts by g t^2 / 2 exactly, to round-off."""
    g = np.array([1e-3, -2e-4])
    a = outer_solar_system(dt=0.05)
    b = a.copy()
    b.add_force(uniform_field, params=g)
    a.integrate(100.0)
    b.integrate(100.0)
    g3 = np.array([g[0], 0.0, g[1]])
    np.testing.assert_allclose(b.positions - a.positions, np.tile(0.5 * g3 * 100.0**2, (5, 1)),
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(b.velocities - a.velocities, np.tile(g3 * 100.0, (5, 1)),
                               rtol=0, atol=1e-13)


def test_position_dependent_force_agrees_with_ias15():
    from visviva.nbody.forces import GeneralRelativityPotential

    a = outer_solar_system(dt=0.01)
    ref = outer_solar_system(coordinates="jacobi")
    ref.integrator = "ias15"
    for s in (a, ref):
        s.add_force(GeneralRelativityPotential(c=63241.077))  # au/yr
        s.integrate(50.0)
    rel = np.linalg.norm(a.positions - ref.positions, axis=1)[1:] / np.linalg.norm(
        ref.positions, axis=1)[1:]
    assert rel.max() < 1e-7


def test_events_path_is_the_same_map():
    """With an escape radius every step is synchronised (events are checked on the true
    state); the trajectory is the same up to round-off."""
    fast = outer_solar_system(dt=0.3)
    slow = outer_solar_system(dt=0.3)
    slow.exit_max_distance = 1e4
    fast.integrate(300.0)
    slow.integrate(300.0)
    np.testing.assert_allclose(slow.positions, fast.positions, rtol=0, atol=1e-10)
    slow.exit_max_distance = 25.0  # Neptune is at ~30 au
    with pytest.raises(vv.Escape) as info:
        slow.integrate(600.0)
    assert info.value.particles == (4,)


def test_merge_conserves_mass_momentum_and_tracked_energy():
    sim = vv.Simulation("whfast", G=1e-12, dt=0.001, collision="merge", coordinates=DH)
    sim.add(2.0, r=[-1.0, 0.1, 0.0], v=[1.0, 0.0, 0.0], radius=0.2)
    sim.add(1.0, r=[1.0, 0.0, 0.0], v=[-0.5, 0.05, 0.0], radius=0.2)
    p0, E0 = sim.momentum(), sim.energy()
    sim.integrate(3.0)
    assert sim.N == 1 and sim.masses[0] == 3.0
    np.testing.assert_allclose(sim.momentum(), p0, rtol=0, atol=1e-13)
    assert sim.energy() == pytest.approx(E0, rel=1e-12)


def test_progress_bar_pauses_do_not_change_the_trajectory():
    a = outer_solar_system(dt=0.01)
    b = a.copy()
    a.integrate(50.0)
    b.integrate(50.0, progress=True)  # paused every 2,000 steps and resumed
    assert b.steps_done > 2000
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.velocities, b.velocities)
