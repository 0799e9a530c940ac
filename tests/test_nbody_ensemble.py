"""Ensembles: many simulations advanced together equal each run alone, bit for bit."""

from __future__ import annotations

import numba
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva.errors import (
    BackendUnavailableError,
    Collision,
    InvalidInputError,
    InvalidStateError,
    ShapeError,
)


@pytest.fixture(autouse=True)
def _ensemble_kernel_itself(monkeypatch):
    """These tests check the ensemble kernel itself: the member-by-member shortcut of a fresh
    install's first small ensemble (visviva.nbody.tier.ensemble_would_compile) is off here and
    tested on its own below."""
    from visviva.core import tier as core_tier

    monkeypatch.setitem(core_tier.spent, "off", True)


def planets(integrator, a=1.0, extra=0, **kw):
    sim = vv.Simulation(integrator, dt=0.01, **kw)
    sim.add(1.0, radius=0.005)
    sim.add(1e-3, a=a, e=0.05, primary=0)
    sim.add(1e-4, a=1.6 * a, e=0.02, inc=0.02, primary=None)
    for j in range(extra):  # ragged: test particles
        sim.add(0.0, a=3.0 + 0.1 * j, primary=0)
    sim.move_to_com()
    return sim


@pytest.mark.parametrize("integrator", ["leapfrog", "whfast", "ias15"])
def test_every_member_equals_running_it_alone_bit_for_bit(integrator):
    sims = [planets(integrator, a=1.0 + 0.07 * k, extra=k % 3) for k in range(7)]
    ens = vv.Ensemble.from_simulations(sims)
    assert len(ens) == 7 and ens.integrator == integrator
    for t in (12.3, 30.0):  # off and on the step grid; two calls continue the same trajectory
        ens.integrate(t)
        for k, sim in enumerate(sims):
            sim.integrate(t)
            member = ens[k]
            np.testing.assert_array_equal(member.positions, sim.positions)
            np.testing.assert_array_equal(member.velocities, sim.velocities)
            assert member.steps_done == sim.steps_done and member.t == sim.t == t
    np.testing.assert_array_equal(ens.t, np.full(7, 30.0))
    np.testing.assert_array_equal(ens.energy(), [s.energy() for s in sims])


def test_ragged_members_are_padded_with_nan():
    sims = [planets("whfast", extra=k) for k in range(3)]
    ens = vv.Ensemble.from_simulations(sims)
    assert ens.n_particles.tolist() == [3, 4, 5]
    pos = ens.positions
    assert pos.shape == (3, 5, 3)
    assert np.isnan(pos[0, 3:]).all() and np.isfinite(pos[2]).all()
    np.testing.assert_array_equal(ens.masses[1, :4], sims[1].masses)
    np.testing.assert_array_equal(ens.velocities[2], sims[2].velocities)


def test_energy_is_conserved_per_member_like_rebound_would():
    # WHFast on a two-planet system: bounded energy error, per member
    sims = [planets("whfast", a=a) for a in np.linspace(1.0, 2.0, 5)]
    ens = vv.Ensemble.from_simulations(sims)
    e0 = ens.energy()
    ens.integrate(100.0)
    rel = np.abs(ens.energy() / e0 - 1)
    assert rel.max() < 1e-5


def test_members_are_copies_and_conversion_back():
    sim = planets("leapfrog")
    ens = vv.Ensemble.from_simulations([sim, sim])
    ens.integrate(1.0)
    assert sim.t == 0.0  # the ensemble owns copies
    back = ens.to_simulations()
    assert [s.t for s in back] == [1.0, 1.0]
    back[0].integrate(2.0)
    assert ens.t.tolist() == [1.0, 1.0]
    assert len(ens[0:1]) == 1 and ens[-1].t == 1.0


def test_save_and_load_restart_exactly(tmp_path):
    sims = [planets("ias15", a=1.0 + 0.1 * k, extra=k) for k in range(3)]
    ens = vv.Ensemble.from_simulations(sims)
    ens.integrate(5.5)
    path = tmp_path / "ens.npz"
    ens.save(path)
    back = vv.Ensemble.load(path)
    assert len(back) == 3 and back.integrator == "ias15"
    ens.integrate(9.0)
    back.integrate(9.0)
    np.testing.assert_array_equal(back.positions, ens.positions)
    np.testing.assert_array_equal(back.velocities, ens.velocities)
    with pytest.raises(InvalidInputError, match="not a visviva.nbody.simulation file"):
        vv.Simulation.load(path)
    ens.integrate(10.0)
    ens.save(path)  # overwritten atomically
    assert vv.Ensemble.load(path).t.tolist() == [10.0] * 3


def test_mergers_are_resolved_per_member_as_alone():
    def crash(merge):
        sim = vv.Simulation("ias15", collision="merge" if merge else "halt")
        sim.add(1.0, radius=0.1)
        sim.add(1.0, r=[1.0, 0, 0], v=[-0.2, 0, 0], radius=0.1)
        return sim

    sims = [crash(True), planets("ias15"), crash(True)]
    ens = vv.Ensemble.from_simulations(sims)
    ens.integrate(3.0)
    for k, sim in enumerate(sims):
        sim.integrate(3.0)
        np.testing.assert_array_equal(ens[k].positions, sim.positions)
    assert ens.n_particles.tolist() == [1, 3, 1]
    np.testing.assert_allclose(ens.energy()[0], sims[0].energy(), rtol=0, atol=0)
    halting = vv.Ensemble.from_simulations([planets("ias15"), crash(False)])
    with pytest.raises(Collision) as info:
        halting.integrate(3.0)
    assert info.value.member == 1
    assert halting.t[0] == 3.0 and halting.t[1] < 3.0  # the others finish


def test_bad_input_says_what_to_do():
    with pytest.raises(InvalidInputError, match="at least one"):
        vv.Ensemble.from_simulations([])
    with pytest.raises(InvalidInputError, match="different integrators"):
        vv.Ensemble.from_simulations([planets("whfast"), planets("ias15")])
    with pytest.raises(InvalidInputError, match="not a visviva.Simulation"):
        vv.Ensemble.from_simulations([planets("whfast"), "x"])
    with pytest.raises(InvalidInputError, match="no particles"):
        vv.Ensemble.from_simulations([vv.Simulation()])
    with pytest.raises(InvalidInputError, match="backend"):
        vv.Ensemble.from_simulations([planets("whfast")], backend="tpu")
    with pytest.raises(InvalidInputError, match=r"one Simulation.*pass \[sim\]"):
        vv.Ensemble.from_simulations(planets("whfast"))  # was TypeError: not iterable
    with pytest.raises(InvalidInputError, match="list of visviva.Simulation"):
        vv.Ensemble.from_simulations(3)
    ens = vv.Ensemble.from_simulations([planets("whfast")])
    with pytest.raises(IndexError, match="member 1 is out of range: the ensemble has 1"):
        ens[1]
    assert ens[-1].N == ens[0].N
    assert ens[np.int64(0)].N == ens[0].N
    for index in (0.7, "0"):  # int(index) picked member 0 without a word
        with pytest.raises(InvalidInputError, match="indexed by an integer"):
            ens[index]
    with pytest.raises(ShapeError, match="one time"):
        ens.integrate([1.0, 2.0])
    with pytest.raises(InvalidInputError, match="client"):
        ens.integrate(1.0, client=42)


def test_cuda_backend_without_a_gpu_says_what_is_missing(monkeypatch):
    from visviva.core import cuda as vcuda

    monkeypatch.setattr(vcuda, "missing", lambda: "no NVIDIA GPU was found (test)")
    with pytest.raises(BackendUnavailableError, match="no NVIDIA GPU"):
        vv.Ensemble.from_simulations([planets("leapfrog")], backend="cuda")
    with pytest.raises(BackendUnavailableError, match="no NVIDIA GPU"):
        vv.Simulation("leapfrog", dt=0.01, backend="cuda")
    from visviva.satellites.catalog import propagate_kepler_batch

    with pytest.raises(BackendUnavailableError, match="no NVIDIA GPU"):
        propagate_kepler_batch(None, None, backend="cuda")  # checked before anything else


def test_cuda_backend_refuses_what_it_does_not_run_yet(monkeypatch, tmp_path):
    from visviva.core import cuda as vcuda

    monkeypatch.setattr(vcuda, "missing", lambda: None)  # as if a GPU were there
    vv.Simulation("ias15", backend="cuda")  # one large system: IAS15 and WHFast run
    from visviva.nbody import GeneralRelativityPotential, J2Force, LinearDrag
    from visviva.nbody.gpu import check_backend

    with pytest.raises(InvalidInputError, match="ensembles of the"):  # a future integrator
        check_backend("cuda", "mercurius", ensemble=True)
    # IAS15 and leapfrog ensembles run additional forces and events (test_nbody_gpu_events.py)
    for name in ("ias15", "leapfrog"):
        forced = planets(name)
        forced.add_force(LinearDrag(0.1) if name == "ias15" else J2Force(0, 1e-3, 1e-3))
        odd = [planets(name), planets(name, collision="merge"),
               planets(name, encounter_distance=0.1), forced]
        assert vv.Ensemble.from_simulations(odd, backend="cuda").backend == "cuda"
    # an IAS15 member with PAIR_MIN_N massive particles or more is taken too (it runs as its
    # lone GPU simulation: tests/gpu/check_ias15_ensemble.py), when built and when loaded
    from visviva.nbody.gpu_ensemble_ias15 import runs_alone

    crowd = planets("ias15")
    for j in range(256):
        crowd.add(1e-9, r=[5.0 + j, 0.0, 0.0], v=[0.0, 0.4, 0.0])
    assert runs_alone(crowd) and not runs_alone(planets("ias15"))
    assert vv.Ensemble.from_simulations([crowd], backend="cuda").backend == "cuda"
    path = tmp_path / "e.npz"
    vv.Ensemble.from_simulations([planets("ias15"), crowd]).save(path)
    assert vv.Ensemble.load(path, backend="cuda").backend == "cuda"
    # WHFast ensembles: any setting (correctors, event checks, position-dependent forces,
    # democratic heliocentric coordinates: refused on real GPUs until the general kernel's
    # fault was found on an H200, 2026-11-28)
    plain = vv.Ensemble.from_simulations([planets("whfast"), planets("whfast")], backend="cuda")
    assert plain.backend == "cuda"
    forced = planets("whfast")
    forced.add_force(GeneralRelativityPotential(c=30.0))
    for options in ({}, {"corrector": 5}, {"collision": "merge"}):
        members = [planets("whfast", **options), forced]
        assert vv.Ensemble.from_simulations(members, backend="cuda").backend == "cuda"
    for name in ("democraticheliocentric", "democratic_heliocentric"):
        members = [planets("whfast", coordinates=name), forced]
        assert vv.Ensemble.from_simulations(members, backend="cuda").backend == "cuda"
    # (one leapfrog simulation with forces or events runs on the GPU: tests/test_nbody_gpu.py)
    # (an array of output times runs on the GPU: tests/test_nbody_gpu.py)


def test_dask_process_workers_give_identical_results(monkeypatch):
    pytest.importorskip("distributed")
    from distributed import Client, LocalCluster

    from visviva.nbody import ensemble_dask

    sims = [planets("whfast", a=1.0 + 0.05 * k, extra=k % 2) for k in range(5)]
    here = vv.Ensemble.from_simulations(sims)
    there = vv.Ensemble.from_simulations(sims)
    here.integrate(20.0)
    with LocalCluster(n_workers=2, processes=True, threads_per_worker=1,
                      dashboard_address=":0") as cluster, Client(cluster) as client:
        there.integrate(20.0, client=client)
        assert there.t.tolist() == [20.0] * 5
        np.testing.assert_array_equal(there.positions, here.positions)
        np.testing.assert_array_equal(there.velocities, here.velocities)
        # by scheduler address too, and with the blocks scattered first (large ensembles)
        monkeypatch.setattr(ensemble_dask, "SCATTER_BYTES", 0)
        there.integrate(25.0, client=cluster.scheduler_address)
        monkeypatch.undo()
        # an event in one member on a worker: raised here with the member's index, the others
        # (on both workers) reach the time as in this process
        wide = [planets("whfast", a=1.0 + 0.05 * k) for k in range(4)]
        wide[2].exit_max_distance = 1.2  # the outer planet (a = 1.76) escapes the sphere
        far = vv.Ensemble.from_simulations(wide)
        with pytest.raises(vv.Escape) as info:
            far.integrate(5.0, client=client)
        assert info.value.member == 2 and info.value.members == [2]
        # plain ints, as in this process (they were numpy.int64 from the block bounds)
        assert type(info.value.member) is int and type(info.value.members[0]) is int
        alone = wide[0].copy()
        alone.integrate(5.0)
        assert far.t[[0, 1, 3]].tolist() == [5.0] * 3 and far.t[2] < 5.0
        np.testing.assert_array_equal(far[0].positions, alone.positions)
    here.integrate(25.0)
    np.testing.assert_array_equal(there.positions, here.positions)
    from visviva._dask import close_local_cluster

    close_local_cluster()


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    sizes=st.lists(st.integers(min_value=1, max_value=6), min_size=1, max_size=6),
    t=st.floats(min_value=0.0, max_value=3.0),
    seed=st.integers(min_value=0, max_value=2**16),
)
def test_property_any_ragged_ensemble_equals_its_members_alone(sizes, t, seed):
    rng = np.random.default_rng(seed)
    sims = []
    for n in sizes:
        sim = vv.Simulation("leapfrog", dt=0.013, softening=0.05)
        for _ in range(n):
            sim.add(float(rng.choice([0.0, rng.uniform(0.01, 1.0)])), rng.normal(size=3),
                    0.3 * rng.normal(size=3))
        sims.append(sim)
    ens = vv.Ensemble.from_simulations(sims)
    ens.integrate(t)
    for k, sim in enumerate(sims):
        sim.integrate(t)
        np.testing.assert_array_equal(ens[k].positions, sim.positions)
        np.testing.assert_array_equal(ens[k].velocities, sim.velocities)


# ---- the packed fast path (nbody/ensemble_pack.py) ----------------------------------------------
@pytest.mark.parametrize("integrator", ["leapfrog", "whfast", "ias15"])
def test_packed_calls_keep_equal_to_lone_runs_call_after_call(integrator):
    sims = [planets(integrator, a=1.0 + 0.05 * k, extra=k % 2) for k in range(5)]
    ens = vv.Ensemble.from_simulations(sims)
    for t in (0.5, 0.73, 2.0, 2.0, 1.1, 3.37):  # repeated and backwards times too
        ens.integrate(t)
        assert ens._pack is not None  # the packed call ran (no member needed the slow path)
        for sim in sims:
            sim.integrate(t)
        np.testing.assert_array_equal(ens.t, [s.t for s in sims])
        for k, sim in enumerate(sims):
            np.testing.assert_array_equal(ens.positions[k, :sim.N], sim.positions)
            np.testing.assert_array_equal(ens.velocities[k, :sim.N], sim.velocities)
            assert ens[k].steps_done == sim.steps_done
    # a member taken out continues alone as the ensemble would have continued it
    alone = ens[3]
    ens.integrate(4.0)
    alone.integrate(4.0)
    np.testing.assert_array_equal(ens[3].positions, alone.positions)


def test_a_merger_in_a_packed_call_is_resolved_and_the_pack_rebuilt():
    crash = vv.Simulation("ias15", dt=0.01, collision="merge")
    crash.add(1.0, radius=0.1)
    crash.add(1.0, r=[1.0, 0, 0], v=[-0.2, 0, 0], radius=0.1)
    sims = [planets("ias15"), crash, planets("ias15", a=1.3)]
    ens = vv.Ensemble.from_simulations(sims)
    for t in (1.0, 3.0, 4.5):
        ens.integrate(t)
        for sim in sims:
            sim.integrate(t)
        for k, sim in enumerate(sims):
            np.testing.assert_array_equal(ens[k].positions, sim.positions)
    assert ens.n_particles.tolist() == [3, 1, 3]
    assert ens._pack is not None  # built again after the merger


def test_a_member_with_coincident_particles_stops_alone():
    bad = vv.Simulation("leapfrog", dt=0.01)
    bad.add(1.0)
    bad.add(1.0)  # at the same place, no softening: infinite gravity
    good = planets("leapfrog")
    ens = vv.Ensemble.from_simulations([good, bad, planets("leapfrog", a=1.2)])
    with pytest.raises(InvalidStateError, match="same position") as info:
        ens.integrate(1.0)
    assert info.value.member == 1
    assert ens.t.tolist() == [1.0, 0.0, 1.0]
    good.integrate(1.0)
    np.testing.assert_array_equal(ens[0].positions, good.positions)


def test_files_pack_the_members_and_version_1_files_still_load(tmp_path):
    from visviva.nbody.snapshot import atomic_savez, state_dict

    # ragged members, different settings, one never integrated (no internal arrays yet)
    sims = [planets("whfast", a=1.0 + 0.1 * k, extra=k) for k in range(4)]
    sims[1].collision = "merge"
    ens = vv.Ensemble.from_simulations(sims)
    ens.integrate(2.0)
    fresh = vv.Ensemble.from_simulations(sims)  # members with buf=None
    members = ens.to_simulations()[:2] + fresh.to_simulations()[2:]
    mixed = vv.Ensemble(members)
    path = tmp_path / "v2.npz"
    mixed.save(path)
    with np.load(path) as data:
        assert int(data["format_version"]) == 2 and len(data.files) == 15
        assert len(data["meta"]) == 2  # the distinct settings, stored once each
    # version 1: one set of arrays per member under e<k>_<key>, as the first release wrote
    v1 = {"format": np.array("visviva.nbody.ensemble"), "format_version": np.array(1),
          "count": np.array(4), "backend": np.array('"cpu"')}
    for k, sim in enumerate(members):
        v1.update({f"e{k}_{key}": value for key, value in state_dict(sim).items()})
    atomic_savez(tmp_path / "v1.npz", v1)
    for name in ("v2.npz", "v1.npz"):
        back = vv.Ensemble.load(tmp_path / name)
        assert back.n_particles.tolist() == mixed.n_particles.tolist()
        assert back[1].collision == "merge" and back[0].collision == "none"
        twin = vv.Ensemble(mixed.to_simulations())
        back.integrate(3.3)
        twin.integrate(3.3)
        np.testing.assert_array_equal(back.positions, twin.positions)
        np.testing.assert_array_equal(back.velocities, twin.velocities)


def test_a_fresh_install_runs_a_small_first_ensemble_member_by_member(force_tier):
    from visviva.nbody import tier as nbody_tier

    sims = [planets("whfast", a=1.0 + 0.1 * k, extra=k) for k in range(3)]
    ens = vv.Ensemble.from_simulations(sims)
    force_tier("interpreted")  # no machine code anywhere, as on a fresh install
    assert nbody_tier.ensemble_would_compile(ens._members, 1.0)
    ens.integrate(1.0)
    assert ens._pack is None  # each member ran as a lone run (interpreted: no compile)
    force_tier("compiled")
    ens.integrate(1.5)
    assert ens._pack is not None  # the ensemble kernel
    for k, sim in enumerate(sims):
        sim.integrate(1.5)
        np.testing.assert_array_equal(ens[k].positions, sim.positions)
        np.testing.assert_array_equal(ens[k].velocities, sim.velocities)
    force_tier("interpreted")
    many = vv.Ensemble.from_simulations([planets("leapfrog")] * (nbody_tier.SMALL_ENSEMBLE + 1))
    assert not nbody_tier.ensemble_would_compile(many._members, 1.0)  # large: compile
    assert not nbody_tier.ensemble_would_compile(ens._members, 1e6)  # long: compile


def test_an_incomplete_ensemble_file_says_what_is_wrong(tmp_path):
    ens = vv.Ensemble.from_simulations([planets("leapfrog"), planets("leapfrog", a=1.2)])
    ens.integrate(0.5)
    path = tmp_path / "e.npz"
    ens.save(path)
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    for broken, match in (({k: v for k, v in arrays.items() if k != "buf"}, "'buf'.*missing"),
                          ({**arrays, "count": np.array(3)}, "3 members but offsets for 2")):
        np.savez(tmp_path / "bad.npz", **broken)
        with pytest.raises(InvalidInputError, match=match):
            vv.Ensemble.load(tmp_path / "bad.npz")


# two user forces fused: the split of the concatenated parameters is baked into the fused
# function, so members whose first force has parameters of another length need their own call
@numba.njit
def _push_by_sum(t, x, v, m, params, acc):
    s = 0.0
    for k in range(params.shape[0]):
        s += params[k]
    for i in range(x.shape[0]):
        acc[i, 0] += s


@numba.njit
def _pull_down(t, x, v, m, params, acc):
    for i in range(x.shape[0]):
        acc[i, 1] -= params[0]


def test_members_with_fused_forces_of_other_parameter_lengths_equal_their_lone_runs():
    def member(push):
        sim = vv.Simulation("leapfrog", dt=0.01)
        sim.add(1.0)
        sim.add(1e-3, a=1.0)
        sim.add_force(_push_by_sum, params=push)
        sim.add_force(_pull_down, params=[1e-3])
        return sim

    members = [member([1e-4]), member([1e-4, 2e-4, 3e-4]), member([5e-4])]
    alone = [s.copy() for s in members]
    for s in alone:
        s.integrate(1.0)
    ens = vv.Ensemble.from_simulations(members)
    ens.integrate(1.0)
    for k, s in enumerate(alone):  # was 4e-4 off for the second member: a silent wrong number
        np.testing.assert_array_equal(ens[k].positions, s.positions)
        np.testing.assert_array_equal(ens[k].velocities, s.velocities)


def test_a_plain_time_for_members_of_different_time_units_is_refused():
    u = pytest.importorskip("astropy.units")
    in_years = vv.Simulation("ias15", units=("au", "yr", "Msun"))
    in_days = vv.Simulation("ias15", units=("au", "day", "Msun"))
    for sim in (in_years, in_days):
        sim.add(1.0)
        sim.add(1e-3, a=1.0, primary=0)
    ens = vv.Ensemble.from_simulations([in_years, in_days])
    ens.integrate(1.0 * u.yr)  # a Quantity: one instant for every member
    np.testing.assert_allclose(ens.t, [1.0, 365.25], rtol=1e-15)
    # 2.0 meant 2 yr for one member and 2 days for the other, which went back 363 days
    with pytest.raises(InvalidInputError, match="different time units"):
        ens.integrate(2.0)
    np.testing.assert_allclose(ens.t, [1.0, 365.25], rtol=1e-15)  # nothing moved
    same = vv.Ensemble.from_simulations([in_years, in_years])
    same.integrate(2.0)  # one time unit: a plain number is unambiguous
    assert same.t.tolist() == [2.0, 2.0]


_SCRIPT_WITH_A_FORCE = '''
import numba
import numpy as np
import visviva as vv


@numba.njit
def drag(t, x, v, m, params, acc):
    for i in range(x.shape[0]):
        for c in range(3):
            acc[i, c] -= params[0] * v[i, c]


def worker_threads():
    return numba.config.NUMBA_NUM_THREADS


if __name__ == "__main__":
    from visviva._dask import close_local_cluster, get_client

    sims = []
    for k in range(3):
        s = vv.Simulation("ias15")
        s.add(1.0)
        s.add(1e-3, a=1.0 + 0.1 * k, primary=0)
        s.add_force(drag, params=[1e-3], velocity_dependent=True)
        sims.append(s)
    here = vv.Ensemble.from_simulations(sims)
    here.integrate(2.0)
    there = vv.Ensemble.from_simulations(sims)
    there.integrate(2.0, client=True)
    assert np.array_equal(there.positions, here.positions)
    print("threads", sorted(set(get_client(n_workers=2, processes=True,
                                           threads_per_worker=1).run(worker_threads).values())))
    close_local_cluster()
'''


@pytest.mark.slow
def test_dask_ensemble_with_a_force_from_a_script_that_imports_numba(tmp_path):
    # a script defining an @njit force imports numba at the top; the spawned workers import it
    # before the nanny sets NUMBA_NUM_THREADS=1, and the force's compilation on the worker
    # raised "Cannot set NUMBA_NUM_THREADS to a different value once the threads have been
    # launched" (InvalidInputError: the force "does not compile")
    import subprocess
    import sys

    pytest.importorskip("distributed")
    script = tmp_path / "run_ensemble.py"
    script.write_text(_SCRIPT_WITH_A_FORCE)
    proc = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                          timeout=600, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "threads [1]" in proc.stdout  # one numba thread per worker, as configured
