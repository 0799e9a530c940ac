"""The interpreter tier (core/tier.py, nbody/tier.py): a cold small call runs interpreted.

What it must never do is change a result: an interpreted run, a compiled run and a run that
switches from one to the other midway give the same bits, for every integrator and option.
"""

from __future__ import annotations

import numba
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva.core import nbody_common as nc
from visviva.core import tier as core_tier
from visviva.nbody import tier

# (integrator, settings) cases: every kernel variant a few-body run can take
CASES = [
    ("whfast", {}),  # whfast_run_plain
    ("whfast", {"corrector": 5}),  # whfast_run_few
    ("whfast", {"corrector": 7}),
    ("whfast", {"coordinates": "democratic_heliocentric"}),
    ("ias15", {}),
    ("ias15", {"adaptive_mode": "rs15"}),
    ("leapfrog", {}),
]


def _system(integrator, options, n, seed, test_particles=0, soft=0.0):
    rng = np.random.default_rng(seed)
    kw = {} if integrator == "ias15" else {"dt": 0.013}
    sim = vv.Simulation(integrator=integrator, G=1.0, softening=soft, **kw)
    sim.add(1.0, [0, 0, 0], [0, 0, 0])
    for k in range(1, n):
        a = 1.0 + 0.45 * k + 0.05 * rng.random()
        e, inc = 0.3 * rng.random(), 0.2 * rng.random()
        m = 0.0 if k > n - 1 - test_particles else 10 ** rng.uniform(-6, -3)
        phase = 6.28 * rng.random()
        r, speed = a * (1 - e), ((1 + e) / (a * (1 - e))) ** 0.5  # at pericentre
        sim.add(m, [r * np.cos(phase), r * np.sin(phase), 0.0],
                [-speed * np.sin(phase) * np.cos(inc), speed * np.cos(phase),
                 speed * np.sin(phase) * np.sin(inc)])
    for key, value in options.items():
        setattr(sim, key, value)
    return sim


def _run(sim, t):
    out = sim.integrate(t)
    st_ = sim._state
    istate = st_.istate.copy()
    istate[nc.I_STOP_AT_STEP] = 0
    return (st_.x.copy(), st_.v.copy(), st_.fstate.copy(), istate, st_.buf.copy(),
            None if out is None else (out.t.copy(), out.positions.copy(), out.velocities.copy()))


def _assert_same(a, b):
    for u, w in zip(a, b, strict=True):
        if u is None:
            assert w is None
        elif isinstance(u, tuple):
            _assert_same(u, w)
        else:
            np.testing.assert_array_equal(u, w)


@pytest.mark.parametrize("integrator, options", CASES)
def test_interpreted_run_gives_the_compiled_bits(force_tier, integrator, options):
    times = np.array([0.7, 1.9, 3.1])
    results = []
    for mode in ("interpreted", "compiled"):
        force_tier(mode)
        sim = _system(integrator, options, n=5, seed=3, test_particles=1)
        results.append(_run(sim, times))
        if mode == "interpreted":
            assert core_tier.spent["cpu_s"] > 0  # it did run interpreted
    _assert_same(*results)


@settings(max_examples=20, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(case=st.sampled_from(CASES), n=st.integers(2, 7), seed=st.integers(0, 10**6),
       soft=st.sampled_from([0.0, 1e-3]), t=st.floats(-2.0, 2.0).filter(lambda t: abs(t) > 0.05),
       budget=st.sampled_from([1e9, 0.02]))
def test_any_few_body_run_is_bit_identical_across_tiers(force_tier, case, n, seed, soft, t,
                                                        budget):
    # budget 0.02 s: the run switches from the interpreter to the machine code midway
    integrator, options = case
    if integrator == "whfast" and options.get("coordinates") and soft:
        soft = 0.0
    results = []
    for mode in ("interpreted", "compiled"):
        force_tier(mode, budget)
        sim = _system(integrator, options, n=n, seed=seed, test_particles=seed % 2, soft=soft)
        results.append(_run(sim, t))
    _assert_same(*results)


def test_restart_and_progress_pauses_keep_the_bits(force_tier):
    # integrate(1) then integrate(2) interpreted, with a progress bar (its own pauses), equals
    # one compiled integrate(2)
    force_tier("interpreted")
    a = _system("ias15", {}, n=4, seed=9)
    a.integrate(1.0, progress=True)
    ra = _run(a, 2.0)
    force_tier("compiled")
    b = _system("ias15", {}, n=4, seed=9)
    rb = _run(b, 2.0)
    _assert_same(ra, rb)


def test_python_raising_falls_back_to_machine_code_with_the_state_restored(force_tier,
                                                                           monkeypatch):
    # where the interpreter raises (a division by zero, an overflow...) the slice's arrays are
    # put back and the machine code runs it: same result, and the tier is off for the process
    force_tier("interpreted")
    calls = []

    def broken(kernel):
        def run(*args):
            calls.append(1)
            kernel(*args)  # changes the state in place ...
            raise ZeroDivisionError("float division by zero")  # ... then fails
        return run

    original = tier.interpreted_kernel

    def wrapped(*a, **k):
        kern = original(*a, **k)
        return None if kern is None else broken(kern)

    monkeypatch.setattr(tier, "interpreted_kernel", wrapped)
    sim = _system("whfast", {}, n=4, seed=5)
    r1 = _run(sim, 1.5)
    assert calls and core_tier.spent["off"]
    force_tier("compiled")
    sim2 = _system("whfast", {}, n=4, seed=5)
    _assert_same(r1, _run(sim2, 1.5))


def test_large_runs_are_not_interpreted(force_tier):
    force_tier("interpreted")
    sim = _system("leapfrog", {}, n=tier.MAX_MASSIVE + 1, seed=1)
    sim.integrate(0.1)
    assert core_tier.spent["cpu_s"] == 0.0


_COLD = """
import sys
import numpy as np
import visviva as vv
kw = {"dt": 0.01} if sys.argv[1] != "ias15" else {}
sim = vv.Simulation(integrator=sys.argv[1], G=1.0, **kw)
sim.add(1.0, [0,0,0], [0,0,0]); sim.add(1e-3, [1,0,0], [0,1,0]); sim.add(1e-3, [2,0,0], [0,0.7,0])
sim.integrate(10.0)
state = np.r_[sim.positions.ravel(), sim.velocities.ravel()]
print(sorted(n for n in compiled if "_run" in n), state.tobytes().hex())
"""


@pytest.mark.parametrize("integrator", ["whfast", "ias15"])
def test_cold_first_run_compiles_no_integrator_and_matches_the_warm_bits(cold_and_warm,
                                                                          integrator):
    # a fresh install (empty numba cache): the three-body run of the README compiles no
    # integrator kernel, and gives the bits the compiled kernel gives once the cache is warm
    cold, warm = cold_and_warm(_COLD, integrator)
    assert cold[0] == "[]"
    assert cold[-1] == warm[-1]


@numba.njit
def _user_push(t, x, v, m, params, acc):
    # a user's own compiled force: it stays compiled (it may use fast-math flags), called from
    # the interpreted kernel
    for i in range(1, x.shape[0]):
        acc[i, 0] += params[0] * x[i, 1]


@pytest.mark.parametrize("integrator, forces", [
    ("ias15", lambda: [vv.nbody.forces.GeneralRelativity(c=30.0)]),
    ("ias15", lambda: [vv.nbody.forces.GeneralRelativity(c=30.0),
                       vv.nbody.forces.LinearDrag(1e-4)]),
    ("whfast", lambda: [vv.nbody.forces.GeneralRelativityPotential(c=30.0)]),
    ("whfast", lambda: [(_user_push, (1e-5,))]),
], ids=["ias15-gr", "ias15-gr-drag", "whfast-grpotential", "whfast-user-force"])
def test_runs_with_additional_forces_are_bit_identical_across_tiers(force_tier, integrator,
                                                                   forces):
    results = []
    for mode in ("interpreted", "compiled"):
        force_tier(mode)
        sim = _system(integrator, {}, n=4, seed=2)
        for f in forces():
            if isinstance(f, tuple):
                sim.add_force(f[0], params=f[1])
            else:
                sim.add_force(f)
        results.append(_run(sim, np.array([0.5, 1.5])))
        if mode == "interpreted":
            assert core_tier.spent["cpu_s"] > 0 and not core_tier.spent["off"]
    _assert_same(*results)


@pytest.mark.parametrize("integrator", ["ias15", "leapfrog"])
def test_runs_with_megno_are_bit_identical_across_tiers(force_tier, integrator):
    """The tangent vector and the MEGNO sums (buf, fstate) too: interpreted = compiled."""
    results = []
    for mode in ("interpreted", "compiled"):
        force_tier(mode)
        sim = _system(integrator, {}, n=4, seed=5, test_particles=1)
        sim.init_megno(seed=8)
        results.append(_run(sim, np.array([0.7, 1.9, 3.1])) + (sim.megno(), sim.lyapunov()))
        if mode == "interpreted":
            assert core_tier.spent["cpu_s"] > 0
    _assert_same(results[0][:6], results[1][:6])
    assert results[0][6:] == results[1][6:]
