"""WHFast warns about a step too long for the orbits (visviva.nbody.step_check)."""

from __future__ import annotations

import math
import re
import warnings

import numpy as np
import pytest

import visviva as vv
from visviva.nbody.step_check import MAX_STEP_FRACTION, shortest_timescale


def two_planets(integrator="whfast", dt=None, coordinates="jacobi"):
    sim = vv.Simulation(integrator, dt=dt, coordinates=coordinates)
    sim.add(1.0)
    sim.add(1e-3, a=1.0, e=0.1, primary=0)
    sim.add(1e-3, a=1.6, e=0.05, primary=0)
    return sim


def test_a_step_of_a_third_of_the_period_is_warned_about_and_is_wrong():
    # dt = P/3 ran without a word: positions 0.5 off (the orbits' size) after 100 time units,
    # with a relative energy error of only 1.7e-3
    P = 2 * math.pi
    ref = two_planets("ias15")
    ref.integrate(100.0)
    sim = two_planets(dt=P / 3)
    with pytest.warns(UserWarning, match=r"step dt = .* 0\.39 of the shortest orbital timescale"):
        sim.integrate(100.0)
    assert np.abs(sim.positions - ref.positions).max() > 0.1  # what the warning is about
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim.integrate(110.0)  # checked once for these particles and this dt
        good = two_planets(dt=P / 20)
        good.integrate(10.0)


def test_two_bodies_are_exact_in_jacobi_coordinates_at_any_step_but_not_in_dh():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim = vv.Simulation("whfast", dt=5.0)  # 0.8 of the period: exact for two bodies
        sim.add(1.0)
        sim.add(1e-3, a=1.0, e=0.3, primary=0)
        sim.integrate(50.0)
    sim = vv.Simulation("whfast", dt=5.0, coordinates="democratic_heliocentric")
    sim.add(1.0)
    sim.add(1e-3, a=1.0, e=0.3, primary=0)
    with pytest.warns(UserWarning, match="democratic_heliocentric coordinates"):
        sim.integrate(50.0)


def test_the_timescale_is_the_period_at_the_pericentre_distance():
    sim = two_planets()
    sim.add(0.0, r=[5.0, 0.0, 0.0], v=[0.0, 2.0, 0.0])  # hyperbolic, pericentre 5: not the least
    x, v, m = sim.positions, sim.velocities, sim.masses
    # particle 1 placed at a = 1, e = 0.1 about particle 0 with G (m0 + m1)
    inner = 2 * math.pi * math.sqrt(0.9**3 / 1.001)
    for jacobi in (True, False):
        assert shortest_timescale(x, v, m, sim.G, jacobi) == pytest.approx(inner, rel=1e-12)
    assert shortest_timescale(x[[0, 3]], v[[0, 3]], m[[0, 3]], 1.0) == pytest.approx(
        2 * math.pi * 5.0**1.5, rel=1e-12)
    assert 0 < MAX_STEP_FRACTION < 0.5


def test_a_test_particle_falling_onto_the_star_is_warned_about():
    # it came out of the pericentre unbound (specific energy -1 -> +0.78 at t = 2, dt = 0.01 =
    # 1/200 of its period) in silence: the total energy, which it does not enter, was fine
    sim = vv.Simulation("whfast", dt=0.01)
    sim.add(1.0)
    sim.add(1e-3, a=3.0, primary=0)
    sim.add(0.0, r=[1.0, 0.0, 0.0])
    with pytest.warns(UserWarning, match="comes out of its pericentre unbound"):
        sim.integrate(2.0)
    w = sim.velocities[2] - sim.velocities[0]
    assert 0.5 * w @ w - 1 / np.linalg.norm(sim.positions[2] - sim.positions[0]) > 0  # unbound


def test_a_plunge_that_ends_in_a_collision_is_not_warned_about():
    # a body falling straight onto the star (pericentre 0: a timescale of 0, which divided by
    # zero in the message) is fine when collisions are on and the radii will meet first
    sim = vv.Simulation("whfast", dt=0.01, collision="merge")
    sim.add(1.0, radius=0.05)
    sim.add(1e-3, a=3.0, primary=0)
    sim.add(1e-6, r=[1.0, 0.0, 0.0], radius=0.01)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim.integrate(2.0)
    assert sim.N == 2  # merged with the star
    sim = vv.Simulation("whfast", dt=0.01, coordinates="democratic_heliocentric")
    sim.add(1.0)
    sim.add(1e-3, a=3.0, primary=0)
    sim.add(1e-6, r=[1.0, 0.0, 0.0])  # at rest beside the star at rest: q = 0 exactly
    with pytest.warns(UserWarning, match="is inf of the shortest"):
        sim.integrate(0.1)


@pytest.mark.parametrize("integrator", ["leapfrog", "whfast"])
def test_a_run_of_more_than_1e15_fixed_steps_is_refused(integrator):
    # integrate(1e300) with dt = 0.01 hung in one uninterruptible compiled call (IAS15 has a
    # relative step floor; the fixed-step integrators had none)
    sim = two_planets(integrator, dt=0.01)
    with pytest.raises(vv.InvalidInputError, match="over 10\\^15 steps"):
        sim.integrate(1e300)
    with pytest.raises(vv.InvalidInputError, match="over 10\\^15 steps"):
        sim.integrate(np.array([1.0, 1e16]))
    assert sim.t == 0.0
    sim.integrate(np.array([]))  # nothing to do
    sim.integrate(1.0)
    assert sim.t == 1.0


def test_an_ensemble_member_with_a_step_too_short_is_named():
    # only member 0 was checked on the ensemble's fast path: member 1 would hang
    sims = [two_planets("leapfrog", dt=0.01), two_planets("leapfrog", dt=1e-17)]
    ens = vv.Ensemble.from_simulations(sims)
    with pytest.raises(vv.InvalidInputError, match="over 10\\^15 steps") as info:
        ens.integrate(1.0)
    assert info.value.member == 1
    assert ens.t.tolist() == [1.0, 0.0]


def _user_warnings(run) -> list:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run()
    caught = [w for w in caught if issubclass(w.category, UserWarning)]
    assert all(w.filename == __file__ for w in caught)  # at the user's call
    return [str(w.message) for w in caught]


def test_ensemble_members_with_a_step_too_long_are_named_in_one_warning():
    # the ensemble's fast path checked member 0 alone: members 1 and 3 (dt = P/3 and P/2, off
    # by the orbits' size) ran without a word; the per-member path warned once per member
    P = 2 * math.pi
    third = two_planets(dt=P / 40)
    third.add(1e-4, a=3.0, primary=0)  # four particles: members of different N
    sims = [two_planets(dt=P / 40), two_planets(dt=P / 3), third,
            two_planets(dt=P / 2, coordinates="democratic_heliocentric")]
    ens = vv.Ensemble.from_simulations(sims)
    messages = _user_warnings(lambda: ens.integrate(10.0))
    assert len(messages) == 1, messages
    assert "too long for the orbits of 2 of the 4 ensemble members (1, 3)" in messages[0]
    lone = _user_warnings(lambda: sims[3].copy().integrate(10.0))  # the worst member, alone
    assert len(lone) == 1 and "0.59 of the shortest" in lone[0]
    assert f"the worst, member 3: {lone[0]}" in messages[0]  # the same numbers and advice
    assert _user_warnings(lambda: ens.integrate(20.0)) == []  # checked once, as a lone run
    assert ens.t.tolist() == [20.0] * 4
    fine = vv.Ensemble.from_simulations([sims[0], third])
    assert _user_warnings(lambda: fine.integrate(10.0)) == []


def _flyby(nu: float, dt: float = 0.05):
    """A star, a planet at a = 1 and a test particle on a hyperbola (q = 0.01, e = 2) at true
    anomaly ``nu`` (> 0: receding from the star, 0.18 from it at nu = 2)."""
    sim = vv.Simulation("whfast", dt=dt)
    sim.add(1.0)
    sim.add(1e-3, a=1.0, primary=0)
    sim.add(0.0, p=0.03, e=2.0, nu=nu, primary=0)
    return sim


def test_an_open_orbit_receding_along_the_run_is_not_warned_about_its_past_pericentre():
    # was: a flyby leaving the star (0.18 from it, q = 0.01 behind it) was warned at dt = 0.05,
    # "8 of the shortest orbital timescale", with the advice of a step 160 times shorter; its
    # timescale along this run is that of its present distance. The same orbit approaching,
    # or run backward in time (towards its pericentre), is still warned about.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _flyby(2.0).integrate(1.0)
        ens = vv.Ensemble.from_simulations([_flyby(2.0), _flyby(2.05)])
        ens.integrate(1.0)
    for sim, t in ((_flyby(-2.0), 1.0), (_flyby(2.0), -1.0)):
        assert len(_user_warnings(lambda s=sim, t=t: s.integrate(t))) == 1
    ens = vv.Ensemble.from_simulations([_flyby(2.0), _flyby(-2.0)])
    messages = _user_warnings(lambda: ens.integrate(1.0))
    assert len(messages) == 1 and "of the 2 ensemble members (1)" in messages[0]
    back = _user_warnings(lambda: vv.Ensemble.from_simulations([_flyby(2.0)]).integrate(-1.0))
    assert len(back) == 1


def _coorbital_pair(dt, coordinates="jacobi"):
    sim = vv.Simulation("whfast", dt=dt, coordinates=coordinates)
    sim.add(1.0)
    sim.add(1e-3, a=1.0, primary=0)
    sim.add(1e-3, a=1.0, nu=0.05, inc=5e-4, primary=0)  # 0.05 away: 0.57 mutual Hill radii
    return sim


@pytest.mark.parametrize("coordinates", ["jacobi", "democratic_heliocentric"])
def test_a_pair_within_a_few_hill_radii_is_warned_about(coordinates):
    # audit45: two Jupiters 0.05 apart on one orbit (bound to each other, falling together to
    # 1.4e-3) ran without a word at dt = 5e-4: |dE/E| up to 3.5 over 20 time units (0.25 at
    # dt = 0.05, which the orbits' check did not see either: their Jacobi and heliocentric
    # orbits are near circles)
    sim = _coorbital_pair(5e-4, coordinates)
    E0 = sim.energy()
    with pytest.warns(UserWarning, match=r"particles 1 and 2 are within 3 mutual Hill radii"):
        sim.integrate(2.0)
    assert abs(sim.energy() / E0 - 1) > 1e-2  # what the warning is about
    # a moon of a Jupiter about a star: warned at dt = P_moon / 100 (75 % of its orbit off
    # after 90 orbits), not at P_moon / 1000 (0.8 %)
    P = 2 * math.pi * math.sqrt(0.003**3 / 1e-3)
    for fraction, warned in ((1e-2, True), (1e-3, False)):
        moon = vv.Simulation("whfast", dt=fraction * P, coordinates=coordinates)
        moon.add(1.0)
        moon.add(1e-3, a=5.2, primary=0)
        moon.add(0.0, a=0.003, e=0.01, primary=1)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            moon.integrate(3 * moon.dt)
        assert any("mutual Hill radii" in str(w.message) for w in caught) is warned
    # planets 0.6 apart (a = 1 and 1.6), and two stars of a hierarchical triple: no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        two_planets(dt=2 * math.pi / 40, coordinates=coordinates).integrate(1.0)
        triple = vv.Simulation("whfast", dt=0.05, coordinates=coordinates)
        triple.add(1.0)
        triple.add(0.5, a=0.3, primary=0)
        triple.add(0.1, a=2.0)
        triple.integrate(1.0)


def test_an_ensemble_member_with_a_close_pair_is_named():
    members = [two_planets(dt=2 * math.pi / 40), _coorbital_pair(2 * math.pi / 40),
               two_planets(dt=2 * math.pi / 40)]
    ens = vv.Ensemble.from_simulations(members)
    with pytest.warns(UserWarning, match=r"1 of the 3 ensemble members have two bodies within "
                      r"3 mutual Hill radii \(1\); member 1: particles 1 and 2"):
        ens.integrate(0.5)


def test_a_leapfrog_step_too_long_for_the_orbits_is_warned_about():
    # audit45: the leapfrog had no check at all: two planets at dt = P/3 were 44 off IAS15
    # after 100 time units (|dE/E| = 0.87), at P/5 3.7 off (0.45), and a test particle falling
    # radially onto the star (dt = 0.01) came out with specific energy +593 (from -1)
    P = 2 * math.pi
    ref = two_planets("ias15")
    ref.integrate(100.0)
    sim = two_planets("leapfrog", dt=P / 3)
    with pytest.warns(UserWarning, match=r"the leapfrog step dt = .* 0\.39 of the shortest"):
        sim.integrate(100.0)
    assert np.abs(sim.positions - ref.positions).max() > 1.0  # what the warning is about
    plunge = vv.Simulation("leapfrog", dt=0.01)
    plunge.add(1.0)
    plunge.add(1e-3, a=1.6, primary=0)
    plunge.add(0.0, r=[1.0, 0.0, 0.0], v=[0.0, 0.01, 0.0])
    with pytest.warns(UserWarning, match="the leapfrog step"):
        plunge.integrate(0.02)
    members = [two_planets("leapfrog", dt=P / 40), two_planets("leapfrog", dt=P / 3)]
    with pytest.warns(UserWarning, match=r"The leapfrog step is too long for the orbits of 1 "
                      r"of the 2 ensemble members \(1\)"):
        vv.Ensemble.from_simulations(members).integrate(0.5)
    with warnings.catch_warnings():  # P/40, and a softened cluster: no warning
        warnings.simplefilter("error")
        two_planets("leapfrog", dt=P / 40).integrate(1.0)
        soft = vv.Simulation("leapfrog", dt=0.5, softening=0.1)
        soft.add(1.0)
        soft.add(1.0, r=[1.0, 0.0, 0.0], v=[0.0, 0.5, 0.0])
        soft.integrate(1.0)


def _crossing(integrator="whfast", dt=None):
    # two Jupiters on crossing orbits (a = 1, e = 0; a = 1.3, e = 0.3): 17 mutual Hill radii
    # apart at the start, they first meet (within 3) after two orbits
    sim = vv.Simulation(integrator, dt=dt) if dt else vv.Simulation(integrator)
    sim.add(1.0)
    sim.add(1e-3, a=1.0, primary=0)
    sim.add(1e-3, a=1.3, e=0.3, argp=2.0, nu=3.0, inc=0.01, primary=0)
    sim.move_to_com()
    return sim


def test_a_close_encounter_met_during_the_run_is_warned_about_once():
    # nbodyleft: the check saw the start of a call only; two Jupiters on crossing orbits that
    # meet after two orbits ran in silence with WHFast at dt = P/40 (|dE/E| 4e-8 before their
    # encounters, 0.054 after 100 orbits); now one warning names the time and the pair
    P = 2 * math.pi
    sim = _crossing(dt=P / 40)
    E0 = sim.energy()
    caught = _user_warnings(lambda: sim.integrate(np.linspace(0.0, 100 * P, 2001)[1:]))
    assert len(caught) == 1
    assert re.match(r"during the run, at t = 1[234]\.\d+ \(the start of the call, t = 0\.0, "
                    r"was fine.*particles 1 and 2 are within 3 mutual Hill radii", caught[0])
    assert abs(sim.energy() / E0 - 1) > 1e-2  # what the warning is about
    assert _user_warnings(lambda: sim.integrate(110 * P)) == []  # once: not at every call


def test_a_close_encounter_at_the_end_of_a_run_without_outputs_is_warned_about():
    # nbodyleft: integrate(t) to a time the pair is close, 1,200 steps on (checked from 1,000)
    from visviva.nbody import step_check as sc

    P = 2 * math.pi
    probe = _crossing(dt=P / 100)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        traj = probe.integrate(np.arange(1, 3001) * P / 100)
    B = len(traj.t)
    _, close, _ = sc._criteria(traj.positions, traj.velocities,
                               np.repeat(probe.masses[None], B, axis=0), np.ones(B), True,
                               False, None, None, np.ones(B))
    bad = (P / 100 > sc.ENCOUNTER_STEP_FRACTION * close)
    inside = np.flatnonzero(bad[1:-1] & bad[:-2] & bad[2:]) + 1  # amid a close passage
    k = int(inside[inside >= sc.RUN_CHECK_STEPS + 200][0])
    sim = _crossing(dt=P / 100)
    caught = _user_warnings(lambda: sim.integrate(traj.t[k]))
    assert len(caught) == 1 and "particles 1 and 2" in caught[0], caught
    assert f"at t = {vv.errors.fmt_number(traj.t[k])}" in caught[0]
    # an ensemble checks its members' final states alike, in one warning naming them
    ens = vv.Ensemble.from_simulations([_crossing(dt=P / 100), two_planets(dt=P / 100),
                                        _crossing(dt=P / 100)])
    caught = _user_warnings(lambda: ens.integrate(traj.t[k]))
    assert len(caught) == 1, caught
    assert re.match(r"during the run: 2 of the 3 ensemble members .* \(0, 2; .*member 0, at "
                    r"t = .*particles 1 and 2", caught[0]), caught
    assert _user_warnings(lambda: ens.integrate(traj.t[k] + 15 * P)) == []  # once each


def test_a_leapfrog_orbit_made_eccentric_during_the_run_is_warned_about():
    # nbodyleft: a snapshot where a test particle's orbit has turned plunging (q = 1e-3)
    from visviva.nbody import step_check as sc

    sim = two_planets("leapfrog", dt=2 * math.pi / 100)
    sim.add(0.0, a=1.3, primary=0)
    x, v = sim.positions[None].repeat(2, axis=0), sim.velocities[None].repeat(2, axis=0)
    v[1, 3] = [0.0, 0.03, 0.0]  # at r = 1.3 nearly at rest: falls to q ~ 1e-3
    t = np.array([500.0, 1000.0]) * sim.dt
    caught = _user_warnings(lambda: sc.check_run(sim, 0.0, t, x, v, stacklevel=3))
    assert len(caught) == 1 and re.match(r"during the run, at t = 62\.83.*the leapfrog step",
                                         caught[0]), caught


def test_long_runs_of_well_resolved_systems_are_not_warned_about():
    # nbodyleft: the run's check raises no false alarm: the solar system over 1,000 yr (default
    # dt), a hierarchical triple and the two planets at P/40, with outputs and without
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sun = vv.nbody.solar_system()
        sun.integrate(np.linspace(0.0, 1000.0, 501)[1:])
        triple = vv.Simulation("whfast", dt=0.05)
        triple.add(1.0)
        triple.add(0.5, a=0.3, e=0.1, primary=0)
        triple.add(0.1, a=2.0, e=0.2, inc=0.3)
        triple.integrate(np.linspace(0.0, 200.0, 400)[1:])
        triple.integrate(400.0)
        for integrator in ("whfast", "leapfrog"):
            two_planets(integrator, dt=2 * math.pi / 40).integrate(300.0)
            ens = vv.Ensemble.from_simulations(
                [two_planets(integrator, dt=2 * math.pi / 40) for _ in range(3)])
            for t in (100.0, 200.0, 300.0):
                ens.integrate(t)


def test_step_warnings_have_their_own_class_to_filter_or_record():
    # a stability map expects them for its unstable members: the class lets it record or
    # filter them without silencing every UserWarning (they were plain UserWarnings)
    sim = two_planets(dt=2 * math.pi / 3)
    with pytest.warns(vv.errors.StepSizeWarning, match="of the shortest orbital timescale"):
        sim.integrate(10.0)
    assert issubclass(vv.errors.StepSizeWarning, UserWarning)


def _planet_flyby(dt, T=1.0):
    # two Jupiters: an inclined flyby 0.01 apart (0.12 mutual Hill radii) at t = 0; at t = -T
    # they are 4.9 Hill radii apart, at +T 9: neither end of the run shows it
    ref = vv.Simulation("ias15")
    ref.add(1.0)
    ref.add(1e-3, r=[1.0, 0.0, 0.0], v=[0.0, 1.0, 0.0])
    ref.add(1e-3, r=[0.99, 0.0, 0.0], v=[0.0, 0.7, 0.7])
    ref.move_to_com()
    ref.integrate(-T)
    sim = vv.Simulation("whfast", dt=dt)
    for m, r, v in zip(ref.masses, ref.positions, ref.velocities, strict=True):
        sim.add(m, r=r, v=v)
    sim.t = -T
    return sim


def test_a_flyby_between_two_checked_states_is_warned_about():
    # audit58: a flyby that begins and ends within one call (or between two checked states)
    # was not seen: WHFast at dt = P/40 changed the energy by 7.6e-2 (REBOUND 5.2.2's WHFast
    # alike, to all digits), P/100 by 5.3e-2, in silence; the kernel now keeps the peak of the
    # bodies' interaction acceleration at every step
    P = 2 * math.pi
    for dt in (P / 40, P / 100):
        sim = _planet_flyby(dt)
        E0 = sim.energy()
        caught = _user_warnings(lambda s=sim: s.integrate(1.0))
        assert abs(sim.energy() / E0 - 1) > 1e-2  # what the warning is about
        assert len(caught) == 1, caught
        m = re.match(r"during the run, near t = (\S+) \(the start of the call, t = -1\.0, was "
                     r"fine.*particle [12] passed within 3 mutual Hill radii", caught[0])
        assert m and abs(float(m.group(1))) < dt, caught  # the encounter's time, to a step
        assert _user_warnings(lambda s=sim: s.integrate(2.0)) == []  # once
    # in calls of a few steps each (fewer than 1,000 steps: no state was checked)
    sim = _planet_flyby(P / 40)
    caught = _user_warnings(lambda: [sim.integrate(t) for t in np.linspace(-0.8, 1.0, 10)])
    assert len(caught) == 1 and "passed within 3 mutual Hill radii" in caught[0], caught


def test_the_encounter_watch_is_quiet_for_planets_that_do_not_meet():
    # the planets at a = 1 and 1.6 (5 mutual Hill radii at their closest) at dt = P/40 and
    # P/10, in one call and in 300 calls of 5 steps; a hierarchical triple
    P = 2 * math.pi
    for dt in (P / 40, P / 10):
        sim = two_planets(dt=dt)
        assert _user_warnings(lambda s=sim: s.integrate(100 * P)) == []
        sim = two_planets(dt=dt)
        assert _user_warnings(
            lambda s=sim, h=dt: [s.integrate(k * 5 * h) for k in range(1, 301)]) == []
    sim = vv.Simulation("whfast", dt=P / 40)
    sim.add(1.0)
    sim.add(0.5, a=1.0, e=0.2, primary=0)
    sim.add(1e-3, a=8.0, e=0.1, inc=0.3)
    assert _user_warnings(lambda: sim.integrate(50 * P)) == []
