"""Property: an ensemble member gives, bit for bit, what the same simulation gives alone.

Hypothesis draws the members over the settings a user combines (every integrator; per member:
ragged particle counts with test particles, step sizes, softening, WHFast coordinates and
correctors, IAS15 step control and exact finish times, additional forces with their own
parameters, mergers and escapes) and a sequence of calls (forwards, repeated, backwards). The
ensemble must match each member's lone run in state, clock, step count, particle count and in
the exception a stopped member raises.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva.nbody import GeneralRelativityPotential, J2Force, LinearDrag


@pytest.fixture(autouse=True)
def _ensemble_kernel_itself(monkeypatch):
    """The ensemble kernel itself, not a fresh install's member-by-member shortcut."""
    from visviva.core import tier as core_tier

    monkeypatch.setitem(core_tier.spent, "off", True)


def _options(draw, integrator):
    opts = {"dt": draw(st.sampled_from([0.005, 0.01, 0.0173, 0.03])),
            "softening": draw(st.sampled_from([0.0, 0.0, 0.01]))}
    if integrator == "whfast":
        coordinates = draw(st.sampled_from(["jacobi", "democraticheliocentric"]))
        opts["coordinates"] = coordinates
        if coordinates == "jacobi":
            opts["corrector"] = draw(st.sampled_from([0, 3, 5, 7]))
    if integrator == "ias15":
        opts["adaptive_mode"] = draw(st.sampled_from(["prs23", "rs15"]))
        opts["exact_finish_time"] = draw(st.booleans())
    events = draw(st.sampled_from(["none", "none", "merge", "escape"]))
    if events == "merge":
        opts["collision"] = "merge"
    elif events == "escape":
        opts["exit_max_distance"] = draw(st.sampled_from([2.5, 6.0]))
    return opts


@st.composite
def members(draw, integrator):
    """One member: a star, 0-4 planets (some crossing, for mergers and escapes), 0-2 test
    particles, perhaps a force with its own parameters."""
    sim = vv.Simulation(integrator, **_options(draw, integrator))
    sim.add(1.0, radius=0.02)
    for _ in range(draw(st.integers(0, 4))):
        sim.add(draw(st.sampled_from([1e-5, 1e-3, 3e-3])),
                a=draw(st.floats(0.6, 2.2)), e=draw(st.floats(0.0, 0.6)),
                inc=draw(st.floats(0.0, 0.3)), mean_anomaly=draw(st.floats(0.0, 6.28)),
                primary=0, radius=0.02)
    for _ in range(draw(st.integers(0, 2))):
        sim.add(0.0, a=draw(st.floats(0.8, 3.0)), e=draw(st.floats(0.0, 0.3)),
                mean_anomaly=draw(st.floats(0.0, 6.28)), primary=0)
    force = draw(st.sampled_from(["none", "j2", "gr"] + (["drag"] if integrator == "ias15"
                                                         else [])))
    if force == "j2":
        sim.add_force(J2Force(0, draw(st.sampled_from([1e-3, 3e-3])), 0.05))
    elif force == "gr":
        sim.add_force(GeneralRelativityPotential(c=draw(st.sampled_from([20.0, 60.0]))))
    elif force == "drag":
        sim.add_force(LinearDrag(draw(st.sampled_from([1e-3, 1e-2]))))
    sim.move_to_com()
    return sim


@st.composite
def cases(draw):
    integrator = draw(st.sampled_from(["leapfrog", "whfast", "ias15"]))
    sims = draw(st.lists(members(integrator), min_size=1, max_size=5))
    times = draw(st.lists(st.sampled_from([0.0, 0.29, 0.5, 0.5, 1.37, 2.0, -0.4]), min_size=1,
                          max_size=3))
    return sims, times


def _outcome(run):
    try:
        run()
    except vv.VisvivaError as exc:
        return type(exc).__name__
    return None


@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(case=cases())
def test_property_every_member_equals_its_lone_run_over_any_settings_and_calls(case):
    sims, times = case
    ens = vv.Ensemble.from_simulations(sims)
    alone = [s.copy() for s in sims]
    stopped = set()
    for t in times:
        try:
            ens.integrate(t)
            raised = set()
        except vv.VisvivaError as exc:
            raised = set(exc.members)
            assert exc.member == min(exc.members)
        for k, sim in enumerate(alone):
            if k in stopped:
                continue
            error = _outcome(lambda sim=sim, t=t: sim.integrate(t))
            assert (error is not None) == (k in raised), (k, error, raised)
            if error is not None:
                stopped.add(k)  # the member and its lone run stopped at the same event
            member = ens[k]
            assert member.N == sim.N and member.t == sim.t
            assert member.steps_done == sim.steps_done
            np.testing.assert_array_equal(member.positions, sim.positions)
            np.testing.assert_array_equal(member.velocities, sim.velocities)
            np.testing.assert_array_equal(member.masses, sim.masses)
        if stopped:
            break  # a member that raised stays where it stopped: the next call is a new run
