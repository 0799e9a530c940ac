"""Eclipse events of propagate_cowell in runs whose force model has no SRP shadow (two-body, J2):
the integrator ends its steps at the events' shadow boundaries (core/cowell_events.py,
``boundary_models``), so eclipses shorter than a step and grazes are found.

Before, the shadow functions were looked at only at the ends of the steps: a 4 s graze of the
cylinder in LEO, a 0.5 s penumbra-only graze, and a 5-minute penumbra pass in GEO (steps of
~25 min) were all missed. Every entry and exit is checked here against an independent
reference: scipy's DOP853 (rtol 1e-13) on two-body + J2 written out below, the Sun from
Skyfield reading JPL DE430, the shadow geometry written out (Montenbruck & Gill 2000,
sec. 3.4.2), zeros by bisection on a 1 s grid with the minima between samples searched too.
Measured: within 1e-5 s. For the grazes the reference reads the Sun from DE421 (visviva's
ephemeris through jplephem, not the integrator's tabulation of it): DE430 and DE421 place the
Sun 0.28 km apart (2e-9 rad), which moves a graze's boundary by ~1 cm and its crossing times,
where the shadow function's rate is only ~10 m/s, by 2 ms (4 s graze) and 12 ms (0.5 s graze).
"""

from __future__ import annotations

import os

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv
from visviva.satellites import Eclipse

EPOCH = Time("2015-03-01T00:00:00", scale="utc")  # within skyfield's DE430 excerpt
R_E = vv.EARTH.radius_km
KMS = u.km / u.s


class Reference:
    """Shadow functions of a two-body (+ J2) trajectory from ``state`` over [0, t_end] s."""

    def __init__(self, state, t_end, j2, sun="DE430"):
        import skyfield
        from scipy.integrate import solve_ivp
        from scipy.interpolate import CubicSpline
        from skyfield.api import load
        from skyfield.jpllib import SpiceKernel

        path = os.path.join(os.path.dirname(skyfield.__file__), "tests", "data",
                            "de430-2015-03-02.bsp")  # fmt: skip
        if not os.path.exists(path):
            pytest.skip("skyfield's DE430 test excerpt is not installed")
        from visviva.core.geodetic import body_pole
        from visviva.satellites.cowell import ForceModel

        mu, j2c = vv.EARTH.gm_km3_s2, vv.EARTH.j2 if j2 else 0.0
        pole = ForceModel(mu, [vv.J2(vv.EARTH)], epoch=state.epoch,
                          span_s=(min(0.0, t_end), max(0.0, t_end)))  # J2 about the Earth's pole

        def rhs(t, y):
            r = y[:3]
            rn = np.linalg.norm(r)
            p = np.array(body_pole(t, pole.force) + (0.0,))
            p[2] = np.sqrt(1.0 - p[0] ** 2 - p[1] ** 2)
            s = r @ p / rn
            k = -1.5 * j2c * mu * R_E**2 / rn**4
            return np.r_[y[3:], -mu * r / rn**3
                         + k * ((1 - 5 * s * s) * r / rn + 2 * s * p)]  # fmt: skip

        y0 = np.r_[state.r.to_value(u.km), state.v.to_value(KMS)]
        self.sol = solve_ivp(rhs, (0.0, t_end), y0, method="DOP853", rtol=1e-13, atol=1e-12,
                             dense_output=True).sol  # fmt: skip
        kernel, ts = SpiceKernel(path), load.timescale(builtin=True)
        self.lo, self.hi = sorted((0.0, t_end))
        tg = np.arange(self.lo - 120.0, self.hi + 180.0, 60.0)
        if sun == "DE430":
            tsf = ts.from_astropy(state.epoch + tg * u.s)
            s = (kernel["sun"].at(tsf).position.km - kernel["earth"].at(tsf).position.km).T
        else:  # DE421 through jplephem, visviva's ephemeris (not its tabulation)
            from visviva.satellites.ephemeris import sun_position

            s = np.array([sun_position(state.epoch + x * u.s).to_value(u.km) for x in tg])
        self.sun = CubicSpline(tg, s)

    def g(self, t, kind):
        """Event function ``kind`` (1 cylinder, 2 penumbra, 3 umbra) at times ``t``."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        p, s = self.sol(t)[:3].T, self.sun(t)
        if kind == 1:
            sh = s / np.linalg.norm(s, axis=1)[:, None]
            along = np.sum(p * sh, axis=1)
            perp = np.linalg.norm(p - along[:, None] * sh, axis=1) - R_E
            return np.where(along >= 0, np.linalg.norm(p, axis=1), perp)
        d = s - p
        dn, pn = np.linalg.norm(d, axis=1), np.linalg.norm(p, axis=1)
        a, b = np.arcsin(vv.constants.R_SUN_KM / dn), np.arcsin(R_E / pn)
        c = np.arccos(np.clip(-np.sum(p * d, axis=1) / (pn * dn), -1, 1))
        return c - (a + b) if kind == 2 else c - (b - a)

    def crossings(self, kind, dt=1.0):
        """Sorted [(t, "entry"/"exit")] of function ``kind``: sign changes on a grid of ``dt`` s
        and dips below zero between grid points (each local minimum of the samples searched)."""
        from scipy.optimize import brentq, minimize_scalar

        def f(x):
            return float(self.g(x, kind)[0])

        def root(a, b):
            return brentq(f, a, b, xtol=1e-9, rtol=1e-15)

        t = np.linspace(self.lo, self.hi, int(np.ceil((self.hi - self.lo) / dt)) + 1)
        v = self.g(t, kind)
        out = [(root(t[i], t[i + 1]), "exit" if v[i + 1] > v[i] else "entry")
               for i in np.flatnonzero(np.sign(v[:-1]) != np.sign(v[1:]))]
        for k in np.flatnonzero((v[1:-1] > 0) & (v[1:-1] <= v[:-2]) & (v[1:-1] <= v[2:])) + 1:
            m = minimize_scalar(f, bounds=(t[k - 1], t[k + 1]), method="bounded",
                                options={"xatol": 1e-9})  # fmt: skip
            if m.fun < 0:
                out += [(root(t[k - 1], m.x), "entry"), (root(m.x, t[k + 1]), "exit")]
        return sorted(out)


def circular(a_km, inc_deg, raan_deg):
    return vv.KeplerianElements.from_semi_major_axis(
        a_km * u.km, 0.0, inc_deg * u.deg, raan_deg * u.deg, 0.0, 0.0, vv.EARTH, epoch=EPOCH
    ).to_state()


def labelled(events, kinds):
    """The reference crossings of the events' functions, labelled as propagate_cowell does."""
    return [(t, f"umbra {w}" if e.umbra else w) for e in events for t, w in kinds[e.kind]]


def check(out, ref, events, tol_s=1e-4):
    want = sorted(labelled(events, {e.kind: ref.crossings(e.kind) for e in events}))
    got = sorted((e.t.to_value(u.s), e.what) for e in out.events)
    assert [w for _, w in got] == [w for _, w in want]
    np.testing.assert_allclose([t for t, _ in got], [t for t, _ in want], rtol=0, atol=tol_s)
    return want


# (a km, inc deg, {J2: RAAN deg}, span s, events, dip s): the RAAN found by bisection on the
# reference for the dip's length (two-body and J2 orbits need different ones)
GRAZES = {
    "cylinder 4 s": (7000.0, 98.0, {True: 46.9542346188, False: 46.8684721953}, 7200.0,
                     [Eclipse("cylindrical")], 4.0),
    "penumbra only 0.5 s": (7000.0, 98.0, {True: 47.2284751550, False: 47.1427137638}, 7200.0,
                            [Eclipse("conical"), Eclipse("conical", umbra=True)], 0.5),
    "GEO penumbra 5 min": (42164.0, 1.5, {True: 229.953842, False: 229.953842}, 86400.0,
                           [Eclipse("conical"), Eclipse("conical", umbra=True)], 300.0),
}


@pytest.mark.parametrize("j2", [True, False], ids=["J2", "two-body"])
@pytest.mark.parametrize("case", list(GRAZES))
def test_grazes_shorter_than_a_step_are_found_without_srp(case, j2):
    a, inc, raan, span, events, dip = GRAZES[case]
    state = circular(a, inc, raan[j2])
    forces = [vv.J2(vv.EARTH)] if j2 else []
    out = vv.propagate_cowell(state, [0.0, span] * u.s, forces, events=events)
    want = check(out, Reference(state, span, j2, sun="DE421"), events)
    assert [w for _, w in want] == ["entry", "exit"]  # the penumbra grazes reach no umbra
    assert want[1][0] - want[0][0] == pytest.approx(dip, rel=0.05)
    # the dip is shorter than the run's steps
    plain = vv.propagate_cowell(state, [0.0, span] * u.s, forces)
    assert dip < 0.5 * span / plain.n_steps


@pytest.mark.parametrize("case", ["cylinder 4 s", "penumbra only 0.5 s"])
def test_grazes_are_found_backwards(case):
    a, inc, raan, span, events, _ = GRAZES[case]
    start = vv.propagate_cowell(circular(a, inc, raan[True]), span * u.s, [vv.J2(vv.EARTH)])
    state = vv.StateVectors(start.r, start.v, vv.EARTH, epoch=EPOCH + span * u.s)
    out = vv.propagate_cowell(state, [-span, 0.0] * u.s, [vv.J2(vv.EARTH)], events=events)
    want = check(out, Reference(state, -span, True, sun="DE421"), events)
    assert len(want) == 2


ORBITS = {  # a km, e, inc, RAAN, arg. of perigee (deg); days; events at least
    "LEO": ((7000.0, 0.001, 51.6, 17.19, 11.46), 1.0, 70),
    "GTO": ((24400.0, 0.73, 7.0, 340.0, 180.0), 1.8, 20),
}


@pytest.mark.parametrize("sign", [1, -1], ids=["forward", "backward"])
@pytest.mark.parametrize("orbit", list(ORBITS))
def test_days_of_eclipses_match_the_reference(orbit, sign):
    # all three functions at once (the boundaries of both models end steps): LEO 15 eclipses
    # a day, GTO 4 or 5 in 1.8 days (23-minute
    # ones near apogee, one cut by the start); the Sun from DE430 (skyfield)
    (a, e, inc, raan, argp), days, n_events = ORBITS[orbit]
    state = vv.KeplerianElements.from_semi_major_axis(
        a * u.km, e, inc * u.deg, raan * u.deg, argp * u.deg, 0.1, vv.EARTH, epoch=EPOCH,
    ).to_state()
    events = [Eclipse("cylindrical"), Eclipse("conical"), Eclipse("conical", umbra=True)]
    span = sign * days * 86400.0
    t = np.sort([0.0, span]) * u.s
    out = vv.propagate_cowell(state, t, [vv.J2(vv.EARTH)], events=events)
    assert len(check(out, Reference(state, span, True), events, tol_s=1e-3)) >= n_events
    # the steps end at the shadow's boundaries: a few more steps, the same trajectory
    plain = vv.propagate_cowell(state, t, [vv.J2(vv.EARTH)])
    assert plain.n_steps < out.n_steps < 1.3 * plain.n_steps  # LEO: 744 -> 909
    np.testing.assert_allclose(out.r.to_value(u.km), plain.r.to_value(u.km), rtol=0, atol=1e-6)


def test_a_graze_of_the_cylinder_is_found_beside_the_conical_shadow():
    # the cylinder lies inside the penumbra: its 4 s dip falls within the step from the
    # penumbra's entry to its exit, so its boundaries end steps too (a second model)
    a, inc, raan, span, _, _ = GRAZES["cylinder 4 s"]
    state = circular(a, inc, raan[True])
    events = [Eclipse("cylindrical"), Eclipse("conical"), Eclipse("conical", umbra=True)]
    out = vv.propagate_cowell(state, [0.0, span] * u.s, [vv.J2(vv.EARTH)], events=events)
    want = check(out, Reference(state, span, True, sun="DE421"), events)
    assert [w for _, w in want] == ["entry", "entry", "exit", "exit"]  # penumbra, cylinder


@pytest.mark.parametrize(("srp_shadow", "event"), [("conical", "cylindrical"),
                                                  ("cylindrical", "conical")])
def test_grazes_of_the_other_model_are_found_with_srp_and_its_shadow(srp_shadow, event):
    # SRP's shadow ends the steps at its boundaries (and switches the force there); an eclipse
    # event of the other model adds its own boundaries. The cylinder's 4 s graze, far shorter
    # than a step (the penumbra around it: 4.5 min): against 0.1 s steps at 1e-13
    a, inc, raan, span, _, _ = GRAZES["cylinder 4 s"]
    state = circular(a, inc, raan[True])
    forces = [vv.J2(vv.EARTH), vv.SolarRadiationPressure(0.02 * u.m**2 / u.kg, 1.5,
                                                         shadow=srp_shadow)]  # fmt: skip
    t = [0.0, span] * u.s
    out = vv.propagate_cowell(state, t, forces, events=[Eclipse(event)])
    ref = vv.propagate_cowell(state, t, forces, events=[Eclipse(event)], max_step=0.1 * u.s,
                              rtol=1e-13, atol=1e-13)  # fmt: skip
    assert [e.what for e in ref.events] == ["entry", "exit"]
    assert [e.what for e in out.events] == ["entry", "exit"]
    np.testing.assert_allclose([e.t.to_value(u.s) for e in out.events],
                               [e.t.to_value(u.s) for e in ref.events], rtol=0, atol=1e-4)
    if event == "cylindrical":  # the 4 s dip, in a run of ~100 s steps
        plain = vv.propagate_cowell(state, t, forces)
        assert (out.events[1].t - out.events[0].t).to_value(u.s) < 0.2 * span / plain.n_steps
    np.testing.assert_allclose(out.r.to_value(u.km), ref.r.to_value(u.km), rtol=0, atol=1e-6)


def test_three_eclipse_events_over_a_leo_day_run_the_integration_once(monkeypatch):
    # the room for events was 64 whatever the run: 90 crossings (penumbra, umbra, cylinder
    # over 15 orbits) overflowed it and the whole integration was done again (11 ms, now 7)
    import visviva.satellites.cowell as sc
    from visviva.satellites.events import event_capacity

    state = vv.KeplerianElements.from_semi_major_axis(
        7000 * u.km, 0.001, 51.6 * u.deg, 0.3, 0.2, 0.1, vv.EARTH, epoch=EPOCH).to_state()
    events = [Eclipse("conical"), Eclipse("conical", umbra=True), Eclipse("cylindrical")]
    calls = []
    original = sc._integrate
    monkeypatch.setattr(sc, "_integrate", lambda args, info: calls.append(1) or original(args, info))
    run = vv.propagate_cowell(state, [0, 1] * u.day, [vv.J2(vv.EARTH)], events=events)
    assert len(run.events) > 64 and len(calls) == 1
    # the same records as with the old room (the kernel's bits do not depend on it)
    monkeypatch.setattr(sc, "event_capacity", lambda *a: 64)
    calls.clear()
    old = vv.propagate_cowell(state, [0, 1] * u.day, [vv.J2(vv.EARTH)], events=events)
    assert len(calls) == 2
    assert [(e.t.value, e.what) for e in old.events] == [(e.t.value, e.what) for e in run.events]
    assert all(np.array_equal(a.r.value, b.r.value) for a, b in zip(old.events, run.events, strict=True))
    # room for the crossings of any bound orbit; a minimum of 64, a cap of 2**20
    y0 = np.r_[state.r.to_value(u.km), state.v.to_value(KMS)]
    gm = vv.EARTH.gm_km3_s2
    assert event_capacity(y0, 86400.0, gm, 3) >= 2 * 3 * 86400.0 / 5830.0
    assert event_capacity(y0, 0.0, gm, 1) == 64 and event_capacity(y0, 1e12, gm, 9) == 2**20
    assert event_capacity(np.r_[y0[:3], 3 * y0[3:]], 1e6, gm, 2) == 64  # hyperbolic


def test_eclipse_events_at_a_steps_end_reuse_the_shadow_samples_bit_for_bit():
    # the integrator takes the events' values at the end of a step from the shadow boundary
    # samples taken there (one Sun position and one shadow geometry for the three events):
    # they must be event_function's values exactly, on either side of each boundary
    from visviva.core.cowell_events import (
        SHADOW_SAMPLES,
        end_sample_value,
        event_function,
        shadow_values,
    )
    from visviva.satellites.cowell import ForceModel

    model = ForceModel(vv.EARTH.gm_km3_s2, [], [Eclipse("conical")], EPOCH, (0.0, 7000.0))
    force, _, _, er, ev, _, _ = model.arrays()
    rng = np.random.default_rng(11)
    s = np.empty(3)
    gs0, gs1 = np.zeros(SHADOW_SAMPLES + 1), np.zeros(SHADOW_SAMPLES + 1)
    for _ in range(200):
        t = rng.uniform(0.0, 7000.0)
        y = np.r_[rng.normal(size=3) * 7000.0, rng.normal(size=3)]
        for model_id, kinds in ((1, (1,)), (2, (2, 3))):
            g0, g1 = shadow_values(model_id, t, y, force, er, ev, s)
            side0, side1 = rng.choice([-1.0, 1.0], 2)
            gs0[-1], gs1[-1] = side0 * g0, side1 * g1
            for kind in (1, 2, 3):
                ok, value = end_sample_value(kind, model_id, side0, side1, gs0, gs1)
                assert ok == (kind in kinds)
                if ok:
                    assert value == event_function(kind, 0.0, t, y, force, er, ev)
