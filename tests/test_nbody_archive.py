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

    sim._state.x = Boom()
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
    assert b.steps_done > 2000
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.velocities, b.velocities)
    assert a.t == b.t == T


def _v1_system(integrator):
    # the system the files in tests/data/nbody_v1 were written from (visviva before the state
    # object: Simulation's arrays as private attributes), at t = 3.3
    sim = vv.Simulation(integrator, dt=0.01, collision="merge")
    sim.add(1.0, radius=0.005)
    sim.add(1e-3, a=1.0, e=0.05, primary=0, radius=1e-4)
    sim.add(1e-4, a=1.6, e=0.02, inc=0.02, primary=None)
    sim.move_to_com()
    return sim


@pytest.mark.parametrize("integrator", ["whfast", "ias15", "leapfrog"])
def test_files_of_format_version_1_still_load_and_continue(integrator):
    path = os.path.join(os.path.dirname(__file__), "data", "nbody_v1", f"{integrator}.npz")
    back = vv.Simulation.load(path)
    with np.load(path) as raw:
        for key, arr in back.state_arrays().items():
            np.testing.assert_array_equal(arr, raw[key])
    assert back.integrator == integrator and back.collision == "merge"
    assert back.energy_offset == 1e-9 and back.t == 3.3 and back.radii[0] == 0.005
    fresh = _v1_system(integrator)
    fresh.integrate(3.3)
    back.integrate(6.0)
    fresh.integrate(6.0)
    # bit for bit on the machine that wrote the files; other CPUs may vectorise the gravity sum
    # differently (last bits), hence the round-off tolerance
    np.testing.assert_allclose(back.positions, fresh.positions, rtol=0, atol=1e-12)


def test_archive_of_format_version_1_still_loads():
    path = os.path.join(os.path.dirname(__file__), "data", "nbody_v1", "archive_ias15.npz")
    archive = vv.nbody.Archive(path)
    assert len(archive) == 4 and list(archive.times) == [0.0, 1.0, 2.0, 3.0]
    snap = archive[2]
    fresh = _v1_system("ias15")
    fresh.integrate(1.0)
    fresh.integrate(2.0)
    np.testing.assert_allclose(snap.positions, fresh.positions, rtol=0, atol=1e-12)
    snap.integrate(3.0)
    fresh.integrate(3.0)
    np.testing.assert_allclose(snap.positions, fresh.positions, rtol=0, atol=1e-12)


def test_record_keeps_the_snapshots_before_an_event(tmp_path):
    # an Escape at t ~ 4.75 used to lose every snapshot not yet flushed (here: the whole file)
    path = tmp_path / "escape.npz"
    sim = vv.Simulation("ias15")
    sim.add(1.0)
    sim.add(1e-3, r=[1.0, 0.0, 0.0], v=[0.0, 1.3, 0.0])  # a = 1/(2 - 1.69) = 3.2, e = 0.69
    sim.exit_max_distance = 3.0
    with pytest.raises(vv.Escape) as info:
        vv.nbody.Archive.record(sim, path, interval=0.5, t_end=100.0)
    assert any("snapshot(s) recorded up to" in note for note in info.value.__notes__)
    archive = vv.nbody.Archive(path)
    assert len(archive) == 10  # t = 0, 0.5, ..., 4.5: every interval before the escape
    np.testing.assert_array_equal(archive.times, 0.5 * np.arange(10))
    assert archive.times[-1] < sim.t
    # each snapshot continues bit for bit to the next one
    again = archive[8]
    again.integrate(4.5)
    np.testing.assert_array_equal(again.positions, archive[9].positions)


def test_record_continues_an_archive_and_refuses_to_mix_runs(tmp_path):
    path = tmp_path / "run.npz"
    sim = two_planets("leapfrog")
    vv.nbody.Archive.record(sim.copy(), path, interval=1.0, t_end=3.0)
    # a second run from t = 0 into the same file used to append: times 0 1 2 3 0 1 2 3
    with pytest.raises(vv.InvalidInputError, match="would not continue it"):
        vv.nbody.Archive.record(sim.copy(), path, interval=1.0, t_end=3.0)
    assert len(vv.nbody.Archive(path)) == 4  # the file is untouched
    # continuing from the last snapshot stores it once (it used to appear twice)
    last = vv.nbody.Archive(path)[-1]
    archive = vv.nbody.Archive.record(last, path, interval=1.0, t_end=5.0)
    np.testing.assert_array_equal(archive.times, [0, 1, 2, 3, 4, 5])
    # recording backwards from the end of a forward archive would also mix directions
    with pytest.raises(vv.InvalidInputError, match="would not continue it"):
        vv.nbody.Archive.record(archive[-1], path, interval=1.0, t_end=0.0)
    # a recording to t_end == t stores the one snapshot once
    single = vv.nbody.Archive.record(sim.copy(), tmp_path / "one.npz", interval=1.0, t_end=0.0)
    np.testing.assert_array_equal(single.times, [0.0])


def test_save_refuses_to_replace_a_file_of_another_kind(tmp_path):
    # Simulation.save and Ensemble.save over an archive (or a user's .npz, or any other file)
    # replaced it silently: six snapshots (or the user's data) were lost without a word
    archive_path = tmp_path / "run.npz"
    vv.nbody.Archive.record(two_planets(), archive_path, interval=1.0, t_end=5.0)
    user_npz = tmp_path / "data.npz"
    np.savez(user_npz, a=np.arange(5))
    notes = tmp_path / "notes.txt"
    notes.write_text("precious")
    ensemble = vv.Ensemble.from_simulations([two_planets(), two_planets()])
    for save in (two_planets().save, ensemble.save):
        for path in (archive_path, user_npz, notes):
            with pytest.raises(vv.InvalidInputError, match="would be replaced and lost"):
                save(path)
    assert len(vv.nbody.Archive(archive_path)) == 6
    np.testing.assert_array_equal(np.load(user_npz)["a"], np.arange(5))
    assert notes.read_text() == "precious"
    ensemble.save(tmp_path / "ens.npz")
    with pytest.raises(vv.InvalidInputError, match="is a visviva.nbody.ensemble file"):
        two_planets().save(tmp_path / "ens.npz")
    # a checkpoint saved again over itself is replaced (the same kind of file)
    sim = two_planets()
    sim.save(tmp_path / "sim.npz")
    sim.integrate(1.0)
    sim.save(tmp_path / "sim.npz")
    assert vv.Simulation.load(tmp_path / "sim.npz").t == 1.0
    ensemble.save(tmp_path / "ens.npz")


def test_archive_append_refuses_a_time_that_goes_back(tmp_path):
    # record() refused to mix runs, append() took any simulation: an archive ending at t = 3
    # took a snapshot at t = 0 (times 0 1 2 3 0)
    path = tmp_path / "run.npz"
    archive = vv.nbody.Archive.record(two_planets("leapfrog"), path, interval=1.0, t_end=3.0)
    with pytest.raises(vv.InvalidInputError, match="would not continue it"):
        archive.append(two_planets("leapfrog"))
    assert len(vv.nbody.Archive(path)) == 4 and len(archive) == 4
    later = archive[-1]
    later.integrate(3.5)
    archive.append(later)
    archive.append(later)  # the same time again (e.g. after changing a particle) is kept
    np.testing.assert_array_equal(vv.nbody.Archive(path).times, [0, 1, 2, 3, 3.5, 3.5])
    # backwards archives keep their direction
    back = vv.nbody.Archive.record(two_planets("leapfrog"), tmp_path / "b.npz", 1.0, -2.0)
    with pytest.raises(vv.InvalidInputError, match="would not continue it"):
        back.append(two_planets("leapfrog"))


def test_record_refuses_an_interval_that_makes_too_many_snapshots(tmp_path):
    # interval = 1e-300 looped (and filled the memory) building 1e300 output times
    with pytest.raises(vv.InvalidInputError, match="1e\\+300 snapshots"):
        vv.nbody.Archive.record(two_planets(), tmp_path / "x.npz", interval=1e-300, t_end=1.0)
    assert not (tmp_path / "x.npz").exists()


def test_record_ends_exactly_at_t_end_and_never_goes_back(tmp_path):
    # t_end = 0.3 by 0.1 ended at 0.30000000000000004; t_end = 3 - 5e-10 by 1 recorded
    # 1, 2, 3 and then went back to t_end
    sim = two_planets("leapfrog")
    archive = vv.nbody.Archive.record(sim, tmp_path / "a.npz", interval=0.1, t_end=0.3)
    assert archive.times.tolist() == [0.0, 0.1, 0.2, 0.3] and sim.t == 0.3
    sim = two_planets("leapfrog")
    t_end = 3.0 - 5e-10
    archive = vv.nbody.Archive.record(sim, tmp_path / "b.npz", interval=1.0, t_end=t_end)
    assert archive.times.tolist() == [0.0, 1.0, 2.0, t_end] and sim.t == t_end
    back = vv.nbody.Archive.record(two_planets("leapfrog"), tmp_path / "c.npz", 0.1, -0.3)
    assert back.times.tolist() == [0.0, -0.1, -0.2, -0.3]


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_record_without_exact_finish_time_samples_as_a_trajectory_does(sign, tmp_path):
    # with exact_finish_time=False and an interval below IAS15's step, the run passed the next
    # time and the following call went back (0, 0.021, -0.043, ...: now refused by append);
    # the archive now holds what integrate(times) returns: the first step at or past each time
    sim = vv.Simulation("ias15", exact_finish_time=False)
    sim.add(1.0)
    sim.add(1e-3, a=1.0, primary=0)
    reference = sim.copy()
    archive = vv.nbody.Archive.record(sim, tmp_path / "a.npz", 0.01, sign * 0.2)
    traj = reference.integrate(sign * 0.01 * np.arange(1, 21))
    np.testing.assert_array_equal(archive.times[1:], traj.t)
    assert archive.times[1] == archive.times[2] and (np.diff(archive.times) * sign >= 0).all()
    for k in range(20):
        np.testing.assert_array_equal(archive[k + 1].positions, traj.positions[k])


def test_a_simulation_taken_from_an_archive_does_not_change_the_archive(tmp_path):
    # audit58: archive[k] shared its arrays with the archive's snapshot, so integrating it
    # changed what archive[k] returned afterwards (t = 15 -> 40, other positions) in silence
    sim = vv.Simulation("ias15")
    sim.add(1.0)
    sim.add(1e-3, a=1.0, primary=0)
    sim.add(1e-3, a=1.6, primary=0)
    archive = vv.nbody.Archive.record(sim, tmp_path / "a.npz", 5.0, 20.0)
    x3 = archive[3].positions.copy()
    first = archive[3]
    first.integrate(40.0)
    assert archive[3].t == 15.0
    np.testing.assert_array_equal(archive[3].positions, x3)
    again = archive[3]
    again.integrate(40.0)  # continues from the snapshot: the same bits as the first copy
    np.testing.assert_array_equal(again.positions, first.positions)


def _merging(integrator):
    sim = vv.Simulation(integrator, collision="merge",
                        dt=None if integrator == "ias15" else 0.01)
    sim.add(1.0, radius=0.005)
    sim.add(1e-3, a=1.0, primary=0, radius=0.01)
    sim.add(1e-3, a=1.0, nu=0.3, e=0.05, inc=1e-3, primary=0, radius=0.01)  # they collide
    sim.add(1e-5, a=2.0, primary=0, radius=1e-4)
    return sim


@pytest.mark.parametrize("integrator", ["ias15", "whfast"])
def test_continuing_from_an_archive_after_a_merger_and_a_removal_is_bit_for_bit(integrator,
                                                                                 tmp_path):
    sim = _merging(integrator)
    archive = vv.nbody.Archive.record(sim, tmp_path / "m.npz", 5.0, 60.0)
    n = [archive[k].N for k in range(len(archive))]
    assert n[0] == 4 and sim.N == 3  # merged during the recording
    k = n.index(3) + 1  # a snapshot after the merger
    again = archive[k]
    again.integrate(60.0)
    np.testing.assert_array_equal(again.positions, sim.positions)
    np.testing.assert_array_equal(again.velocities, sim.velocities)
    # particles removed, then recorded: continuing from a snapshot of that run is the same
    plain, recorded = archive[k], archive[k]
    plain.remove(plain.N - 1)
    recorded.remove(recorded.N - 1)
    t_end = plain.t + 20.0
    plain.integrate(t_end)
    second = vv.nbody.Archive.record(recorded, tmp_path / "r.npz", 5.0, t_end)
    np.testing.assert_array_equal(recorded.positions, plain.positions)
    mid = second[len(second) // 2]
    mid.integrate(t_end)
    np.testing.assert_array_equal(mid.positions, plain.positions)
