"""Events during Cowell propagation: eclipses, re-entry, nodes and apsides."""

from __future__ import annotations

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv
from visviva.errors import InvalidInputError
from visviva.satellites import (
    AltitudeCrossing,
    Apsides,
    AscendingNode,
    DescendingNode,
    Eclipse,
    ReEntry,
    propagate_cowell,
)
from visviva.satellites.ephemeris import sun_position

EPOCH = Time("2024-03-01T00:00:00", scale="utc")
R_E = vv.EARTH.radius_km


def circular(alt_km, inc_deg, epoch=EPOCH, raan_deg=30.0):
    return vv.KeplerianElements.from_semi_major_axis(
        (R_E + alt_km) * u.km, 0.0, inc_deg * u.deg, raan_deg * u.deg, 0.0, 0.0, vv.EARTH, epoch
    ).to_state()


def test_cylindrical_eclipse_times_match_brute_force_within_1_s():
    state = circular(500.0, 51.6)
    span = 0.5 * 86400.0
    out = propagate_cowell(state, span * u.s, [vv.J2(vv.EARTH)], events=[Eclipse()])
    # brute force: every second, the shadow test with the Sun straight from the ephemeris
    t = np.arange(0.0, span + 1.0, 1.0)
    fine = propagate_cowell(state, t * u.s, [vv.J2(vv.EARTH)])
    r = fine.r.to_value(u.km)
    s = sun_position(EPOCH + t * u.s).to_value(u.km)
    s_hat = s / np.linalg.norm(s, axis=1)[:, None]
    proj = (r * s_hat).sum(1)
    perp = np.linalg.norm(r - proj[:, None] * s_hat, axis=1)
    dark = (proj < 0) & (perp < R_E)
    flips = np.flatnonzero(np.diff(dark.astype(int)))
    brute_entries = t[flips[dark[flips + 1]]]
    brute_exits = t[flips[~dark[flips + 1]]]
    entries = np.array([e.t.to_value(u.s) for e in out.events_named("eclipse", "entry")])
    exits = np.array([e.t.to_value(u.s) for e in out.events_named("eclipse", "exit")])
    assert len(entries) == len(brute_entries) >= 7
    assert len(exits) == len(brute_exits)
    # the brute-force flip lies within the 1 s sample before the event
    assert np.all(np.abs(entries - (brute_entries + 0.5)) <= 1.0)
    assert np.all(np.abs(exits - (brute_exits + 0.5)) <= 1.0)
    # eclipses of a 500 km orbit last about 35 minutes
    n = min(len(entries), len(exits))
    durations = exits[exits > entries[0]][: n - 1] - entries[: n - 1]
    assert np.all((30 * 60 < durations) & (durations < 40 * 60))


def test_conical_penumbra_brackets_umbra_and_cylinder():
    state = circular(500.0, 51.6)
    out = propagate_cowell(
        state,
        0.2 * u.day,
        [],
        events=[Eclipse("conical"), Eclipse("conical", umbra=True), Eclipse("cylindrical")],
    )
    # every shadow model names its records "eclipse" (as the docs do); the umbra says so in what
    assert {e.name for e in out.events} == {"eclipse"}
    assert {e.what for e in out.events} <= {"entry", "exit", "umbra entry", "umbra exit"}
    entries = [e.t.value for e in out.events_named("eclipse", "entry")]  # penumbra and cylinder
    umb = [e.t.value for e in out.events_named("eclipse", "umbra entry")]
    pen, cyl = entries[0::2], entries[1::2]  # in time order the penumbra comes first
    assert len(pen) == len(umb) == len(cyl) >= 2
    for p, c, m in zip(pen, cyl, umb, strict=True):
        assert p < c < m  # penumbra first, then the cylinder's edge, then full shadow
        assert m - p < 20.0  # the penumbral passage of a LEO orbit takes ~10 s


def test_drag_decay_from_300_km_is_monotonic_and_ends_in_reentry():
    state = circular(300.0, 51.6, epoch=None)
    t = np.arange(0.0, 30 * 86400.0, 600.0) * u.s
    out = propagate_cowell(
        state, t, [vv.AtmosphericDrag(0.05 * u.m**2 / u.kg)], events=[ReEntry(100 * u.km)]
    )
    assert out.terminated
    last = out.events[-1]
    assert last.name == "reentry" and last.what == "descending" and last.terminal
    assert np.all(out.t <= last.t)
    assert len(out.t) < len(t)
    r = np.linalg.norm(out.r.to_value(u.km), axis=1)
    v = np.linalg.norm(out.v.to_value(u.km / u.s), axis=1)
    energy = 0.5 * v**2 - vv.EARTH.gm_km3_s2 / r
    assert np.all(np.diff(energy) < 0)  # drag only removes energy
    a = -vv.EARTH.gm_km3_s2 / (2 * energy)
    assert np.all(np.diff(a) < 0)  # so the (mean) altitude falls monotonically
    # the altitude at the event is the requested one
    # (exact WGS-84 height about the frame's z axis: no epoch, no pole)
    from astropy.coordinates import EarthLocation

    h = EarthLocation.from_geocentric(*last.r).height.to_value(u.km)
    assert abs(h - 100.0) < 1e-6  # km (first order in f before the eighteenth session: 25 m)
    assert 0.5 * 86400 < last.t.to_value(u.s) < 30 * 86400


def test_nodes_and_apsides():
    el = vv.KeplerianElements.from_semi_major_axis(8000 * u.km, 0.1, 0.7, 0.2, 0.4, -1.0, vv.EARTH)
    period = 2 * np.pi * np.sqrt(8000.0**3 / vv.EARTH.gm_km3_s2)
    out = propagate_cowell(
        el.to_state(),
        3 * period * u.s,
        [],
        events=[AscendingNode(), DescendingNode(), Apsides()],
    )
    asc = out.events_named("ascending node")
    desc = out.events_named("descending node")
    peri = out.events_named("apsis", "periapsis")
    apo = out.events_named("apsis", "apoapsis")
    assert len(asc) == len(desc) == len(peri) == len(apo) == 3
    for e in asc:
        assert abs(e.r[2].to_value(u.km)) < 1e-6 and e.v[2] > 0
    for e in desc:
        assert abs(e.r[2].to_value(u.km)) < 1e-6 and e.v[2] < 0
    for e in peri:
        assert abs(np.linalg.norm(e.r.value) - 8000 * 0.9) < 1e-6
    for e in apo:
        assert abs(np.linalg.norm(e.r.value) - 8000 * 1.1) < 1e-6
    # successive periapsis passages one period apart (two-body)
    tp = np.array([e.t.value for e in peri])
    assert np.allclose(np.diff(tp), period, atol=1e-3)


def test_altitude_crossing_both_ways():
    el = vv.KeplerianElements.from_semi_major_axis(
        (R_E + 1000) * u.km, 0.05, 0.3, 0.0, 0.0, 0.0, vv.EARTH
    )
    out = propagate_cowell(el.to_state(), 2 * u.hour, [], events=[AltitudeCrossing(1000 * u.km)])
    whats = [e.what for e in out.events]
    assert "ascending" in whats and "descending" in whats
    assert not out.terminated


def test_eclipse_without_epoch_raises():
    with pytest.raises(InvalidInputError, match="epoch"):
        propagate_cowell(circular(500, 50, epoch=None), 1 * u.hour, [], events=[Eclipse()])


def test_bad_event_arguments():
    with pytest.raises(InvalidInputError, match="cylindrical"):
        Eclipse("round")
    with pytest.raises(InvalidInputError, match="direction"):
        AltitudeCrossing(100 * u.km, direction=2)
    with pytest.raises(InvalidInputError, match="not an event"):
        propagate_cowell(circular(500, 50), 1 * u.hour, [], events=["eclipse"])


def test_event_times_agree_with_root_finding_on_a_dense_sampling_and_skyfield_sun():
    """Every event kind against roots of the same function on the 2 s samples of the same
    trajectory (cubic splines, Brent), with the Sun from Skyfield reading JPL DE430 and the
    altitude from astropy's WGS-84 geodetic conversion. Measured: shadows 2.5e-6 s, nodes
    6e-7 s, apsides 3e-7 s; altitudes 1.8e-4 s (exact geodetic height about the Earth's pole since the
    eighteenth session; 0.15 s before, first order in f about the GCRS z axis)."""
    import os

    import skyfield
    from scipy.interpolate import CubicSpline
    from scipy.optimize import brentq
    from skyfield.api import load
    from skyfield.jpllib import SpiceKernel

    from visviva.satellites.frames import gcrs_to_itrs, itrs_to_geodetic

    path = os.path.join(os.path.dirname(skyfield.__file__), "tests", "data", "de430-2015-03-02.bsp")
    if not os.path.exists(path):
        pytest.skip("skyfield's DE430 test excerpt is not installed")
    kernel, ts = SpiceKernel(path), load.timescale(builtin=True)
    epoch = Time("2015-03-01T00:00:00", scale="utc")
    state = vv.KeplerianElements.from_semi_major_axis(
        (R_E + 1100) * u.km, 0.06, 63 * u.deg, 30 * u.deg, 40 * u.deg, 0.0, vv.EARTH, epoch
    ).to_state()
    span = 0.25 * 86400.0
    events = [Eclipse(), Eclipse("conical"), Eclipse("conical", umbra=True), AscendingNode(),
              DescendingNode(), Apsides(), AltitudeCrossing(700 * u.km)]  # fmt: skip
    out = propagate_cowell(state, span * u.s, [vv.J2(vv.EARTH)], events=events)
    t = np.arange(0.0, span + 1.0, 2.0)
    fine = propagate_cowell(state, t * u.s, [vv.J2(vv.EARTH)])
    r, v = fine.r.to_value(u.km), fine.v.to_value(u.km / u.s)
    tsf = ts.from_astropy(epoch + t * u.s)
    sun = (kernel["sun"].at(tsf).position.km - kernel["earth"].at(tsf).position.km).T
    h = itrs_to_geodetic(gcrs_to_itrs(r * u.km, v * u.km / u.s, epoch + t * u.s)[0])[2]
    rs, vs, ss, hs = CubicSpline(t, r), CubicSpline(t, v), CubicSpline(t, sun), CubicSpline(t, h)

    def cones(x):  # Montenbruck & Gill (2000), sec. 3.4.2, written out here
        p, d = rs(x), ss(x) - rs(x)
        a = np.arcsin(vv.constants.R_SUN_KM / np.linalg.norm(d))
        b = np.arcsin(R_E / np.linalg.norm(p))
        c = np.arccos(-(p @ d) / (np.linalg.norm(p) * np.linalg.norm(d)))
        return a, b, c

    def cylinder(x):
        p, s_hat = rs(x), ss(x) / np.linalg.norm(ss(x))
        along = p @ s_hat
        return 1.0 if along >= 0 else np.linalg.norm(p - along * s_hat) - R_E

    def roots(f):
        vals = np.array([f(x) for x in t])
        k = np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))
        return np.array([brentq(f, t[i], t[i + 1], xtol=1e-7) for i in k])

    def found(name, whats):
        return np.array([e.t.to_value(u.s) for e in out.events if e.name == name and e.what in whats])

    nodes = np.concatenate([found("ascending node", ("ascending node",)),
                            found("descending node", ("descending node",))])  # fmt: skip
    checks = [
        (cylinder, found("eclipse", ("entry", "exit")), 1e-3),
        (lambda x: (lambda a, b, c: c - (a + b))(*cones(x)), found("eclipse", ("entry", "exit")), 1e-3),
        (lambda x: (lambda a, b, c: c - (b - a))(*cones(x)), found("eclipse", ("umbra entry", "umbra exit")), 1e-3),
        (lambda x: rs(x)[2], nodes, 1e-3),
        (lambda x: rs(x) @ vs(x), found("apsis", ("periapsis", "apoapsis")), 1e-3),
        (lambda x: hs(x) - 700.0, found("altitude", ("ascending", "descending")), 2e-3),
    ]  # fmt: skip
    for f, ours, tol in checks:
        ref = roots(f)
        assert len(ref) >= 4
        assert max(np.min(np.abs(ours - x)) for x in ref) < tol  # seconds
    # one record per sampled crossing, each node on its own side
    assert len(nodes) == len(roots(lambda x: rs(x)[2]))
    for e in out.events:
        if e.name in ("ascending node", "descending node"):
            assert (e.v[2] > 0) == (e.name == "ascending node")


def test_backward_propagation_labels_events_by_their_physical_direction():
    # integrating to negative times, crossings were labelled by their sign in the direction of
    # integration: "periapsis" at r = 8800 km (the apoapsis), "ascending node" with v_z < 0,
    # "ascending" altitude crossings while falling, eclipse entry and exit swapped; and the
    # direction filters (AscendingNode, ReEntry's descending-only) picked the opposite crossings
    state = vv.KeplerianElements.from_semi_major_axis(
        8000 * u.km, 0.1, 0.5, 0.0, 0.0, 1.0, vv.EARTH, EPOCH
    ).to_state()
    events = [AscendingNode(), DescendingNode(), Apsides(), AltitudeCrossing(1500 * u.km),
              AltitudeCrossing(1500 * u.km, direction=-1), Eclipse()]  # fmt: skip
    forward = propagate_cowell(state, 20000 * u.s, [], events=events)
    backward = propagate_cowell(state, -20000 * u.s, [], events=events)
    for out in (forward, backward):
        assert len(out.events) > 20
        for e in out.events:
            r, v = e.r.to_value(u.km), e.v.to_value(u.km / u.s)
            rdot = r @ v / np.linalg.norm(r)
            if e.name == "ascending node":
                assert v[2] > 0
            elif e.name == "descending node":
                assert v[2] < 0
            elif e.what == "periapsis":
                assert np.linalg.norm(r) == pytest.approx(7200.0, abs=1e-3)
            elif e.what == "apoapsis":
                assert np.linalg.norm(r) == pytest.approx(8800.0, abs=1e-3)
            elif e.name == "altitude":
                assert (rdot > 0) == (e.what == "ascending")
    # one descending-only altitude crossing per orbit, in either direction of time
    for out in (forward, backward):
        alt = [e for e in out.events if e.name == "altitude"]
        assert sum(e.what == "descending" for e in alt) > sum(e.what == "ascending" for e in alt)
    # the shadow entered going forward is left going backward at the same instants
    ent_f = [e.t.value for e in forward.events_named("eclipse", "entry")]
    ent_b = [e.t.value for e in backward.events_named("eclipse", "entry")]
    period = 2 * np.pi * np.sqrt(8000.0**3 / vv.EARTH.gm_km3_s2)
    phase = lambda x: np.mod(np.asarray(x), period)  # noqa: E731
    # the Sun moves ~1 deg in 20000 s: entries recur at nearly the same orbital phase
    assert np.abs(phase(ent_b)[:, None] - phase(ent_f)[None, :]).min() < 60.0


def test_umbra_with_the_cylindrical_model_is_refused():
    # Eclipse("cylindrical", umbra=True) quietly gave the cylinder's entry/exit records
    with pytest.raises(InvalidInputError, match="conical"):
        Eclipse("cylindrical", umbra=True)
    assert Eclipse("conical", umbra=True).umbra


def test_event_switches_take_booleans_only():
    """audit21: the switches took any truthy value: Eclipse('conical', umbra='False') gave the
    umbra's records instead of the penumbra's and AltitudeCrossing(h, terminal='no') stopped
    the run; a direction of True passed as +1."""
    for bad in ("False", "no", 1, None):
        with pytest.raises(vv.InvalidInputError, match="umbra must be True or False"):
            Eclipse("conical", umbra=bad)
        with pytest.raises(vv.InvalidInputError, match="terminal must be True or False"):
            AltitudeCrossing(100 * u.km, terminal=bad)
    with pytest.raises(vv.InvalidInputError, match="direction"):
        AltitudeCrossing(100 * u.km, direction=True)
    assert not Eclipse("conical", umbra=np.False_).umbra
    assert AltitudeCrossing(100 * u.km, -1, terminal=np.True_).terminal is True


def test_nodes_on_the_equator_of_date_match_erfa_pole():
    """audit56: AscendingNode/DescendingNode(equator="of date") cross the Earth's true equator
    (normal to ERFA's CIP), 2.66 s from the GCRS node at 51.6 deg in 2024; before, only the
    frame's xy plane was offered."""
    import erfa
    from scipy.optimize import brentq

    state = vv.KeplerianElements.from_semi_major_axis(
        7000 * u.km, 0.001, 51.6 * u.deg, 0.3, 0.2, 0.1, vv.EARTH, epoch=EPOCH).to_state()
    forces = [vv.J2(vv.EARTH)]
    run = propagate_cowell(state, 3.5 * u.hour, forces,
                           events=[AscendingNode("of date"), AscendingNode(),
                                   DescendingNode("of date"), DescendingNode()])

    def across_equator_of_date(t_s):  # r . p, p the CIP from ERFA's series at each time
        r = propagate_cowell(state, t_s * u.s, forces).r.to_value(u.km)
        tt = (EPOCH + t_s * u.s).tt
        x, y, _ = erfa.xys06a(tt.jd1, tt.jd2)
        return float(r @ np.array([x, y, np.sqrt(1.0 - x * x - y * y)]))

    for name in ("ascending node", "descending node"):
        times = [e.t.to_value(u.s) for e in run.events if e.name == name]
        assert len(times) == 4  # two orbits in 3.5 h, each of date and the frame's, 2.66 s apart
        of_date, frame = times[0::2], times[1::2]
        assert np.allclose(np.abs(np.subtract(frame, of_date)), 2.66, atol=0.02)
        for t in of_date:
            ref = brentq(across_equator_of_date, t - 60.0, t + 60.0, xtol=1e-8)
            assert abs(t - ref) < 1e-4


def test_nodes_of_date_need_an_earth_state_with_an_epoch():
    bare = vv.StateVectors([7000.0, 0, 0] * u.km, [0, 5.0, 5.8] * u.km / u.s, vv.EARTH)
    with pytest.raises(InvalidInputError, match="equator 'of date'"):
        propagate_cowell(bare, 1 * u.hour, [], events=[AscendingNode("of date")])
    with pytest.raises(InvalidInputError, match="'frame'"):
        AscendingNode("J2000")
