"""A perturbed Cowell run stops at the central body's surface with SurfaceImpact, not silently
below it (visviva.satellites.surface)."""

from __future__ import annotations

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv
from visviva.satellites import AltitudeCrossing, ReEntry
from visviva.satellites.surface import altitude_km

EPOCH = Time("2024-01-01T00:00:00", scale="utc")
KMS = u.km / u.s
#: 200 km up with a third of the circular speed: falls to the ground in about 225 s
FALLING = vv.StateVectors([6578.0, 0.0, 0.0] * u.km, [0.0, 3.0, 0.0] * KMS, vv.EARTH, epoch=EPOCH)
#: a 400 km circular orbit inclined 51.6 deg
CIRCULAR = vv.KeplerianElements.from_semi_major_axis(
    6778.0 * u.km, 0.0, np.radians(51.6), 0.3, 0.0, 0.0, vv.EARTH, epoch=EPOCH).to_state()


def test_a_falling_state_raises_at_the_surface_with_the_run_up_to_it():
    t = np.linspace(0.0, 3.0, 13) * u.hour
    with pytest.raises(vv.SurfaceImpact, match="surface of earth at t = 22[0-9]\\.") as info:
        vv.propagate_cowell(FALLING, t, [vv.J2(vv.EARTH)])
    exc = info.value
    # the same crossing as a terminal altitude event of the user's, to the event tolerance
    user = vv.propagate_cowell(FALLING, t, [vv.J2(vv.EARTH)],
                               events=[AltitudeCrossing(0.0 * u.km, -1, terminal=True)])
    assert user.terminated
    assert exc.t.to_value(u.s) == pytest.approx(user.events[-1].t.to_value(u.s), abs=1e-5)
    # the drop of 200 km under ~7.8 m/s^2 (gravity less the centrifugal term): ~225 s
    assert 215.0 < exc.t.to_value(u.s) < 235.0
    # nothing lost: the outputs before the impact, and the impact state on the surface
    res = exc.result
    assert res.terminated and res.t.size == 1 and res.t[0] == 0.0 * u.s
    hit = res.events[-1]
    # on the surface about the Earth's pole of the run (the CIP: J2 tabulates it; ERFA here)
    import erfa

    tt = (EPOCH + hit.t).tt
    pole = erfa.xys06a(tt.jd1, tt.jd2)[:2]
    assert hit.name == "surface" and abs(altitude_km(hit.r.to_value(u.km), vv.EARTH, pole)) < 1e-6
    np.testing.assert_array_equal(res.r.to_value(u.km), user.r.to_value(u.km))


def test_a_decaying_orbit_with_drag_raises_where_it_would_have_gone_underground():
    # perigee 75 km: drag brings it down within the first revolution
    s = vv.StateVectors([6800.0, 100.0, 300.0] * u.km, [-0.1, 5.0, 5.7] * KMS, vv.EARTH,
                        epoch=EPOCH)
    forces = [vv.J2(vv.EARTH), vv.AtmosphericDrag(0.02 * u.m**2 / u.kg)]
    with pytest.raises(vv.SurfaceImpact) as info:
        vv.propagate_cowell(s, np.linspace(0.0, 6000.0, 61) * u.s, forces)
    res = info.value.result
    assert 3500.0 < info.value.t.to_value(u.s) < 4500.0
    assert res.t.size == int(info.value.t.to_value(u.s) // 100) + 1
    import erfa

    pole = erfa.xys06a(EPOCH.tt.jd1, EPOCH.tt.jd2)[:2]  # the run's (J2 and drag tabulate it)
    assert altitude_km(res.r.to_value(u.km), vv.EARTH, pole).min() > -1e-9  # the last: impact
    # a terminal ReEntry of the user's comes first: a normal, terminated result
    run = vv.propagate_cowell(s, np.linspace(0.0, 6000.0, 61) * u.s, forces,
                              events=[ReEntry()])
    assert run.terminated and run.events[-1].name == "reentry"
    assert run.events[-1].t < info.value.t


def test_backwards_into_the_surface_raises_too():
    up = vv.StateVectors(FALLING.r, -FALLING.v, vv.EARTH, epoch=EPOCH)
    with pytest.raises(vv.SurfaceImpact):
        vv.propagate_cowell(up, [-1.0, -0.5] * u.hour, [vv.J2(vv.EARTH)])


def test_two_body_motion_and_orbits_above_the_surface_are_not_touched():
    # no perturbations: the conic through the attractor is the two-body problem's solution
    t = np.linspace(0.0, 1.0, 5) * u.hour
    res = vv.propagate_cowell(FALLING, t, [])
    kep = FALLING.propagate(t)
    assert np.linalg.norm(res.r.to_value(u.km), axis=-1).min() < 3000.0
    np.testing.assert_allclose(res.r.to_value(u.km), kep.r.to_value(u.km), atol=1e-5)
    # a LEO day with J2 and drag: as before, no event, no error
    day = vv.propagate_cowell(CIRCULAR, np.linspace(0.0, 1.0, 25) * u.day,
                              [vv.J2(vv.EARTH), vv.AtmosphericDrag(0.01 * u.m**2 / u.kg)])
    assert not day.terminated and day.events == []
    assert altitude_km(day.r.to_value(u.km), vv.EARTH).min() > 350.0


def test_a_start_below_the_surface_is_refused():
    inside = vv.StateVectors([6000.0, 0.0, 0.0] * u.km, [0.0, 8.0, 0.0] * KMS, vv.EARTH,
                             epoch=EPOCH)
    with pytest.raises(vv.InvalidStateError, match="378.137 km below the surface of earth"):
        vv.propagate_cowell(inside, 1.0 * u.hour, [vv.J2(vv.EARTH)])
    both = vv.StateVectors(np.stack([CIRCULAR.r, inside.r]), np.stack([CIRCULAR.v, inside.v]),
                           vv.EARTH, epoch=EPOCH)
    with pytest.raises(vv.InvalidStateError, match="state 1 starts"):
        vv.propagate_cowell(both, 1.0 * u.hour, [vv.J2(vv.EARTH)])


def test_a_batch_names_the_state_that_went_below_the_surface():
    states = vv.StateVectors(np.stack([CIRCULAR.r, FALLING.r, CIRCULAR.r]),
                             np.stack([CIRCULAR.v, FALLING.v, CIRCULAR.v]), vv.EARTH, epoch=EPOCH)
    t = np.linspace(0.0, 600.0, 11) * u.s
    with pytest.raises(vv.SurfaceImpact, match="state 1 of the batch") as info:
        vv.propagate_cowell(states, t, [vv.J2(vv.EARTH)])
    exc = info.value
    assert exc.state == 1
    # the impact itself, as one state's run finds it (was: the first output time below, 240 s)
    with pytest.raises(vv.SurfaceImpact) as one:
        vv.propagate_cowell(FALLING, t, [vv.J2(vv.EARTH)])
    assert exc.t.to_value(u.s) == pytest.approx(one.value.t.to_value(u.s), abs=1e-9)
    assert exc.result.r.shape == (3, 11, 3)  # every state at every output time
    alone = vv.propagate_cowell(CIRCULAR, t, [vv.J2(vv.EARTH)])
    np.testing.assert_array_equal(exc.result.r[0].to_value(u.km), alone.r.to_value(u.km))
    # the falling state: its outputs before the impact as one state's, NaN after it
    reached = one.value.result.r.to_value(u.km)
    np.testing.assert_array_equal(exc.result.r[1, :len(reached)].to_value(u.km), reached)
    assert np.isnan(exc.result.r[1, len(reached):].value).all()
    # what a Dask worker sends back keeps the attributes
    import pickle

    back = pickle.loads(pickle.dumps(exc))
    assert str(back) == str(exc) and back.state == 1 and back.t == exc.t
    np.testing.assert_array_equal(back.result.r.to_value(u.km), exc.result.r.to_value(u.km))


@pytest.mark.parametrize("burn", [False, True])
def test_a_batch_state_that_decays_between_two_outputs_stops_at_the_surface(burn):
    """audit21: a batch was checked at its output times only, so a state decaying between two
    outputs (days apart) flew on underground through the extrapolated atmosphere until the
    10-million-step budget ran out (60 s, then StepSizeError 'raise max_steps')."""
    low = vv.KeplerianElements.from_semi_major_axis(
        6678.0 * u.km, 0.0, np.radians(51.6), 0.0, 0.0, 0.0, vv.EARTH, epoch=EPOCH).to_state()
    high = vv.KeplerianElements.from_semi_major_axis(
        7078.0 * u.km, 0.0, np.radians(51.6), 0.0, 0.0, 0.0, vv.EARTH, epoch=EPOCH).to_state()
    states = vv.StateVectors(np.stack([high.r, low.r]), np.stack([high.v, low.v]), vv.EARTH,
                             epoch=EPOCH)
    forces = [vv.AtmosphericDrag(0.05 * u.m**2 / u.kg)]
    # an impulse of 0 m/s after a day splits the run into segments (the burns' path)
    burns = [vv.ImpulsiveBurn(1 * u.day, [0.0, 0.0, 0.0] * u.m / u.s, "RTN")] if burn else None
    t = [0.0, 20.0] * u.day
    with pytest.raises(vv.SurfaceImpact, match="state 1 of the batch") as info:
        vv.propagate_cowell(states, t, forces, max_steps=200_000, maneuvers=burns)
    with pytest.raises(vv.SurfaceImpact) as one:
        vv.propagate_cowell(low, t, forces, maneuvers=burns)
    assert 8.0 < info.value.t.to_value(u.day) < 11.0
    assert info.value.t.to_value(u.s) == pytest.approx(one.value.t.to_value(u.s), abs=1e-6)
    r = info.value.result.r.to_value(u.km)
    assert np.isnan(r[1, 1]).all() and np.isfinite(r[:, 0]).all()
