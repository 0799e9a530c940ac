"""The pack's per-call shortcuts (nbody/ensemble_pack.py, gpu_plan.py): views instead of index
gathers when the members are all of one size, slot indices derived once per pack, the grid
counted once when every member is on it, and the checks done on whole arrays, each against the
general code it stands for; and packs rebuilt when a member changes size."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva.core import nbody_common as nc
from visviva.core import nbody_whfast as wh
from visviva.errors import InvalidInputError
from visviva.nbody.ensemble_pack import Pack
from visviva.nbody.gpu_plan import count_steps


@pytest.fixture(autouse=True)
def _ensemble_kernel_itself(monkeypatch):
    """The ensemble kernel itself, not a fresh install's member-by-member first small call."""
    from visviva.core import tier as core_tier

    monkeypatch.setitem(core_tier.spent, "off", True)


def _member(integrator, n, a=1.0, **kw):
    sim = vv.Simulation(integrator, dt=0.01, **kw)
    sim.add(1.0, radius=0.005)
    for j in range(1, n):
        sim.add(1e-4 if j < 3 else 0.0, a=a * (1.0 + 0.6 * j), e=0.03, primary=0)
    sim.move_to_com()
    return sim


def _pack(integrator, sizes, seed=0):
    pack = Pack.build([_member(integrator, n, a=1.0 + 0.01 * k) for k, n in enumerate(sizes)])
    pack.buf[:] = np.random.default_rng(seed).normal(size=pack.buf.shape)
    return pack


@settings(max_examples=25, deadline=None)
@given(integrator=st.sampled_from(["leapfrog", "whfast"]),
       sizes=st.lists(st.integers(1, 5), min_size=1, max_size=6),
       same=st.booleans(), data=st.data())
def test_slots_read_and_written_through_views_equal_the_indexed_slots(integrator, sizes, same,
                                                                     data):
    if same:
        sizes = [sizes[0]] * len(sizes)
    pack = _pack(integrator, sizes)
    assert pack.same_n == (sizes[0] if len(set(sizes)) == 1 else 0)
    s = data.draw(st.integers(0, pack.n_buf - 1))
    at = pack.slot(s)  # the indices the general code gathers and scatters with
    np.testing.assert_array_equal(pack.read_slot(s), pack.buf[at])
    values = np.random.default_rng(1).normal(size=(len(pack.x), 3))
    mask = np.array(data.draw(st.lists(st.booleans(), min_size=len(sizes),
                                       max_size=len(sizes))))
    expected = pack.buf.copy()
    rows = mask[pack.member_of]
    expected[at[rows]] = values[rows]
    pack.write_slot(s, values, mask)
    np.testing.assert_array_equal(pack.buf, expected)
    expected[at] = values
    pack.write_slot(s, values)
    np.testing.assert_array_equal(pack.buf, expected)
    # the members still view the packed arrays (what they hold is what the pack wrote)
    for k, sim in enumerate(pack.members):
        lo, hi = pack.poff[k], pack.poff[k + 1]
        np.testing.assert_array_equal(sim.state_arrays()["buf"][s], values[lo:hi])


@pytest.mark.parametrize("n", [3, 12])  # pair by pair; each member's row sorted
def test_shared_coordinates_are_found_in_packs_of_one_size_as_in_ragged_ones(n):
    pack = _pack("leapfrog", [n] * 5)
    assert not pack._maybe_coincident()
    pack.x[pack.poff[3] + n - 1, 0] = pack.x[pack.poff[3] + 1, 0]  # member 3: a shared x
    assert pack._maybe_coincident()
    pack.same_n = 0  # the general (ragged) check says the same
    assert pack._maybe_coincident()
    pack.same_n = n
    pack.fstate[3, nc.F_SOFT2] = 1e-6  # softened: the kernel copes, no check needed
    assert not pack._maybe_coincident()
    pack.fstate[3, nc.F_SOFT2] = 0.0
    pack.x[pack.poff[3] + n - 1, 0] += 1e-12
    pack.x[pack.poff[1]:pack.poff[2], 0] = np.nan  # NaN equals nothing (the kernel reports it)
    assert not pack._maybe_coincident()
    pack.same_n = 0
    assert not pack._maybe_coincident()


def test_finite_members_are_found_without_a_false_alarm_from_an_overflowing_sum():
    pack = _pack("leapfrog", [3] * 4)
    pack.x[:] = 1e308  # finite, but their sum is not: each member is looked at
    assert pack.all_finite().tolist() == [True] * 4
    pack.v[pack.poff[2] + 1, 2] = np.nan
    pack.x[pack.poff[3], 0] = -np.inf
    assert pack.all_finite().tolist() == [True, True, False, False]
    pack.x[pack.poff[3], 0] = np.inf
    pack.x[pack.poff[0], 1] = -np.inf  # inf - inf = NaN: still found
    assert pack.all_finite().tolist() == [False, True, False, False]


@settings(max_examples=60, deadline=None)
@given(t0=st.sampled_from([0.0, 0.37, -2.5, 1e3]), k0=st.integers(-500, 500),
       adt=st.sampled_from([0.01, 0.0137, 1.0 / 3.0, 0.5]), exact=st.booleans(),
       target=st.floats(-10.0, 10.0, allow_nan=False), members=st.integers(2, 5))
def test_members_on_one_grid_count_the_steps_each_alone_counts(t0, k0, adt, exact, target,
                                                               members):
    def count(t0s, k0s, adts, exacts):
        t0s, adts = np.array(t0s, dtype=float), np.array(adts, dtype=float)
        direction = np.where(target >= t0s + np.array(k0s) * adts, 1.0, -1.0)
        return count_steps(target, t0s, np.array(k0s, dtype=np.int64), adts, direction,
                           np.array(exacts))

    alone = count([t0], [k0], [adt], [exact])  # one member: the general expressions
    n, t_grid = count([t0] * members, [k0] * members, [adt] * members, [exact] * members)
    assert n.dtype == np.int64 and n.tolist() == [alone[0][0]] * members
    assert t_grid.tobytes() == np.full(members, alone[1][0]).tobytes()
    # one member off the common grid: every member counted for itself
    n, t_grid = count([t0] * members, [k0] * (members - 1) + [k0 + 7], [adt] * members,
                      [exact] * members)
    assert n[:-1].tolist() == [alone[0][0]] * (members - 1)
    other = count([t0], [k0 + 7], [adt], [exact])
    assert (n[-1], t_grid[-1]) == (other[0][0], other[1][0])


def test_plain_whfast_rows_are_found_row_by_row():
    sims = [_member("whfast", 3), _member("whfast", 3, coordinates="democraticheliocentric"),
            _member("whfast", 3, collision="merge"), _member("whfast", 3)]
    sims[3].corrector = 5
    rows = [s.state_arrays() for s in sims]
    istate = np.stack([r["istate"] for r in rows])
    fstate = np.stack([r["fstate"] for r in rows])
    assert wh.is_plain(istate, fstate).tolist() == [
        bool(wh.is_plain(r["istate"], r["fstate"])) for r in rows] == [True, False, False,
                                                                       False]


@pytest.mark.parametrize("integrator", ["leapfrog", "whfast"])
def test_a_member_that_merges_makes_the_pack_ragged_and_results_stay_those_of_lone_runs(
        integrator):
    # three members of 3 bodies (a pack of one size); in member 1 two bodies meet and merge,
    # so the pack is rebuilt ragged (3, 2, 3); then member 1 is changed (its step) between
    # calls and starts its internal state again; every member is its lone run, bit for bit
    crash = vv.Simulation(integrator, dt=0.01, collision="merge")
    crash.add(1.0, radius=0.1)
    crash.add(1e-3, r=[1.0, 0, 0], v=[-0.5, 0, 0], radius=0.1)
    crash.add(1e-3, r=[0.5, 3.0, 0], v=[-0.57, 0, 0], radius=0.01)
    sims = [_member(integrator, 3), crash, _member(integrator, 3, a=1.3)]
    ens = vv.Ensemble.from_simulations(sims)
    ens.integrate(0.5)
    assert ens._pack.same_n == 3
    for t in (1.0, 2.5, 2.2, 3.0):
        if t == 2.2:
            ens._members[1].dt = sims[1].dt = 0.007  # the member's own view of the pack
        ens.integrate(t)
        for sim in sims:
            sim.integrate(t)
        for k, sim in enumerate(sims):
            np.testing.assert_array_equal(ens[k].positions, sim.positions)
            np.testing.assert_array_equal(ens[k].velocities, sim.velocities)
            assert ens[k].t == sim.t and ens[k].steps_done == sim.steps_done
    assert ens.n_particles.tolist() == [3, 2, 3]
    assert ens._pack is not None and ens._pack.same_n == 0


def test_members_of_different_time_units_never_share_a_pack_so_plain_times_stay_refused():
    # Ensemble.integrate checks a plain number against the members' time units only while
    # it has no pack: a pack is only ever built of members with one set of units
    a = vv.Simulation("leapfrog", dt=0.01, units=("AU", "yr", "Msun"))
    b = vv.Simulation("leapfrog", dt=0.01, units=("AU", "day", "Msun"))
    for sim in (a, b):
        sim.add(1.0)
        sim.add(1e-3, a=1.0, primary=0)
    ens = vv.Ensemble.from_simulations([a, b])
    import astropy.units as u

    ens.integrate(0.1 * u.yr)
    assert ens._pack is None  # per member
    with pytest.raises(InvalidInputError, match="different time units"):
        ens.integrate(0.2)
    same = vv.Ensemble.from_simulations([a, a])
    same.integrate(0.2)
    assert same._pack is not None
    same.integrate(0.3)
    assert same.t.tolist() == [0.3, 0.3]


SIMULATOR_SCRIPT = textwrap.dedent("""
    import numpy as np
    import visviva as vv
    from visviva.core import tier
    tier.spent["off"] = True

    def member(integrator, n, a):
        sim = vv.Simulation(integrator, dt=0.01)
        sim.add(1.0)
        for j in range(1, n):
            sim.add(1e-4 if j < 3 else 0.0, a=a * (1.0 + 0.6 * j), e=0.03, primary=0)
        sim.move_to_com()
        return sim

    for integrator in ("leapfrog", "whfast"):
        for layout, sizes in (("same", [3] * 6), ("ragged", [3, 4, 2, 3, 5, 3])):
            sims = [member(integrator, n, 1.0 + 0.05 * k) for k, n in enumerate(sizes)]
            gpu = vv.Ensemble.from_simulations(sims, backend="cuda")
            cpu = vv.Ensemble.from_simulations(sims)
            same = True
            for t in (0.3, 0.55, 0.55, 0.2, 0.61):
                if t == 0.2:  # two members start their internal state again
                    for ens in (gpu, cpu):
                        ens._members[1].dt = ens._members[4].dt = 0.0071
                gpu.integrate(t)
                cpu.integrate(t)
                same &= gpu._pack is not None and gpu._pack.same_n == (
                    3 if layout == "same" else 0)
                for k in range(len(sims)):
                    a, b = gpu[k], cpu[k]
                    same &= (a.positions.tobytes() == b.positions.tobytes()
                             and a.velocities.tobytes() == b.velocities.tobytes()
                             and a.t == b.t and a.steps_done == b.steps_done)
            print(f"{integrator}_{layout}_bits={same}")
""")


@pytest.mark.slow
def test_gpu_packs_of_one_size_and_ragged_give_the_cpu_ensembles_bits(tmp_path):
    # under numba's CUDA simulator (the CPU's arithmetic): the views of a pack of one size and
    # the index gathers of a ragged one move the same numbers, restarts of some members too
    from test_nbody_gpu import _run

    script = tmp_path / "check_pack_layouts.py"
    script.write_text(SIMULATOR_SCRIPT)
    out = _run({"NUMBA_ENABLE_CUDASIM": "1"}, str(script))
    for integrator in ("leapfrog", "whfast"):
        for layout in ("same", "ragged"):
            assert out[f"{integrator}_{layout}_bits"] == "True", (integrator, layout)


def test_put_writes_the_chosen_rows_of_a_strided_column_only():
    from visviva.nbody.gpu_plan import put

    fstate = np.zeros((4, nc.N_FSTATE))
    h = np.array([0.1, 0.2, 0.3, 0.4])
    put(fstate[:, nc.F_DT_LAST], np.array([True, False, True, False]), h)
    put(fstate[:, nc.F_T], np.ones(4, dtype=bool), h)
    put(fstate[:, nc.F_T0], np.zeros(4, dtype=bool), h)
    put(fstate[:, nc.F_DT], np.array([False, True, False, False]), 7.0)
    assert fstate[:, nc.F_DT_LAST].tolist() == [0.1, 0.0, 0.3, 0.0]
    assert fstate[:, nc.F_T].tolist() == h.tolist() and not fstate[:, nc.F_T0].any()
    assert fstate[:, nc.F_DT].tolist() == [0.0, 7.0, 0.0, 0.0]
    assert np.count_nonzero(fstate) == 7  # no other column touched
