"""Archive of snapshots, atomic versioned files, progress bar."""

from __future__ import annotations

import os

import numpy as np
import pytest

import visviva as vv


def two_planets(integrator="whfast"):
    sim = vv.Simulation(integrator, dt=0.01)
    sim.add(1.0)
    sim.add(1e-3, a=1.0, e=0.05, primary=0)
    sim.add(1e-4, a=1.6, e=0.02, inc=0.02, primary=None)
    sim.move_to_com()
    return sim


@pytest.mark.parametrize("integrator", ["whfast", "ias15"])
def test_archive_snapshots_restart_bit_for_bit(integrator, tmp_path):
    path = tmp_path / "run.npz"
    sim = two_planets(integrator)
    archive = vv.nbody.Archive.record(sim, path, interval=2.0, t_end=10.0)
    assert len(archive) == 6
    np.testing.assert_allclose(archive.times, [0, 2, 4, 6, 8, 10])
    again = vv.nbody.Archive(path)
    assert len(again) == 6
    snap = again[3]
    assert snap.t == 6.0
    snap.integrate(8.0)  # the same output times as the recording run
    snap.integrate(10.0)
    np.testing.assert_array_equal(snap.positions, sim.positions)
    np.testing.assert_array_equal(snap.velocities, sim.velocities)
    assert [s.t for s in again[::2]] == [0.0, 4.0, 8.0]


def test_save_is_atomic_and_versioned(tmp_path):
    path = tmp_path / "sim.npz"
    sim = two_planets()
    sim.save(path)
    assert [p for p in os.listdir(tmp_path) if p.startswith(".tmp")] == []
    with np.load(path) as data:
        assert str(data["format"]) == "visviva.nbody.simulation"
        assert int(data["format_version"]) == 1
    # a failing write leaves the old file intact
    class Boom:
        def __array__(self, *a, **k):
            raise RuntimeError("disk full")

    sim._x = Boom()
    with pytest.raises(RuntimeError):
        sim.save(path)
    back = vv.Simulation.load(path)
    assert back.N == 3
    assert [p for p in os.listdir(tmp_path) if p.startswith(".tmp")] == []


def test_builtin_forces_survive_save_and_load(tmp_path):
    from visviva.nbody import GeneralRelativity

    sim = vv.Simulation("ias15", units=("au", "yr", "Msun"))
    sim.add(1.0)
    sim.add(0.0, a=0.387, e=0.2, primary=0)
    sim.add_force(GeneralRelativity(primary=0))
    sim.integrate(0.5)
    sim.save(tmp_path / "gr.npz")
    back = vv.Simulation.load(tmp_path / "gr.npz")
    assert len(back.forces) == 1 and back.forces[0].velocity_dependent
    sim.integrate(1.0)
    back.integrate(1.0)
    np.testing.assert_array_equal(sim.positions, back.positions)


@pytest.mark.parametrize("integrator", ["whfast", "ias15", "leapfrog"])
def test_progress_bar_does_not_change_the_trajectory(integrator, capsys):
    T = 400.0 if integrator == "ias15" else 50.0
    a = two_planets(integrator)
    b = two_planets(integrator)
    a.integrate(T)
    b.integrate(T, progress=True)  # paused every 2,000 steps and resumed
    assert b._istate[1] > 2000
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.velocities, b.velocities)
    assert a.t == b.t == T
