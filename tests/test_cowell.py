"""Cowell propagation: agreement with Kepler, invariants, output handling and bad inputs."""

from __future__ import annotations

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from hypothesis import given, settings
from hypothesis import strategies as hs

import visviva as vv
from visviva.errors import InvalidInputError, ShapeError, UnitsError
from visviva.satellites import AltitudeCrossing, propagate_cowell
from visviva.validation.checks_cowell import srp_eccentricity_growth

ONE_MM = 1e-6  # km
ONE_M = 1e-3  # km
EPOCH = Time("2024-03-01T00:00:00", scale="utc")


def leo(epoch=None):
    return vv.StateVectors([7000.0, 0.0, 0.0] * u.km, [0.0, 5.0, 5.8] * u.km / u.s, vv.EARTH, epoch)


def test_no_perturbation_matches_kepler_within_1_mm_after_one_day():
    state = leo()
    t = np.linspace(0.0, 1.0, 97) * u.day
    out = propagate_cowell(state, t, [])
    kepler = state.propagate(t)
    err = np.linalg.norm((out.r - kepler.r).to_value(u.km), axis=-1)
    assert err.max() < ONE_MM
    verr = np.linalg.norm((out.v - kepler.v).to_value(u.km / u.s), axis=-1)
    assert verr.max() < 1e-9


@settings(max_examples=15, deadline=None)
@given(
    rp=hs.floats(6600.0, 20000.0),
    ecc=hs.floats(0.0, 0.8),
    inc=hs.floats(0.0, np.pi),
    raan=hs.floats(0.0, 2 * np.pi),
    argp=hs.floats(0.0, 2 * np.pi),
    nu=hs.floats(-np.pi, np.pi),
)
def test_no_perturbation_matches_kepler_over_elliptic_orbits(rp, ecc, inc, raan, argp, nu):
    el = vv.KeplerianElements(rp * (1 + ecc) * u.km, ecc, inc, raan, argp, nu, vv.EARTH)
    state = el.to_state()
    a = rp / (1 - ecc)
    period = 2 * np.pi * np.sqrt(a**3 / vv.EARTH.gm_km3_s2)
    t = np.linspace(0.0, 3 * period, 7) * u.s
    out = propagate_cowell(state, t, [])
    kepler = state.propagate(t)
    err = np.linalg.norm((out.r - kepler.r).to_value(u.km), axis=-1)
    assert err.max() < 10 * ONE_MM * max(1.0, a / 7000.0)


def test_forward_then_backward_returns_home():
    state = leo()
    out = propagate_cowell(state, 1 * u.day, [vv.Zonal(vv.EARTH, 6)])
    back = propagate_cowell(
        vv.StateVectors(out.r, out.v, vv.EARTH), -1 * u.day, [vv.Zonal(vv.EARTH, 6)]
    )
    assert np.linalg.norm((back.r - state.r).to_value(u.km)) < ONE_MM


def test_negative_and_positive_times_in_one_call():
    state = leo()
    t = np.array([-3000.0, -10.0, 0.0, 500.0, 4000.0]) * u.s
    out = propagate_cowell(state, t, [])
    kepler = state.propagate(t)
    assert out.r.shape == (5, 3)
    assert np.allclose(out.t.to_value(u.s), t.to_value(u.s))
    assert np.abs((out.r - kepler.r).to_value(u.km)).max() < ONE_MM


def test_outputs_from_one_integration_match_separate_runs():
    state = leo()
    t = np.array([600.0, 4321.0, 20000.0]) * u.s
    many = propagate_cowell(state, t, [vv.J2(vv.EARTH)])
    for k in range(3):
        one = propagate_cowell(state, t[k], [vv.J2(vv.EARTH)])
        assert one.r.shape == (3,)
        # dense output versus step end: both well inside the integration tolerance
        assert np.linalg.norm((one.r - many.r[k]).to_value(u.km)) < ONE_MM


def test_time_array_input_equals_offsets():
    state = leo(EPOCH)
    offsets = np.linspace(0, 6, 4) * u.hour
    a = propagate_cowell(state, offsets, [vv.J2(vv.EARTH)])
    b = propagate_cowell(state, EPOCH + offsets, [vv.J2(vv.EARTH)])
    assert np.abs((a.r - b.r).to_value(u.km)).max() < 1e-9
    assert np.all(np.abs((b.times - (EPOCH + offsets)).to_value(u.s)) < 1e-6)


def test_axisymmetric_field_conserves_energy_and_hz():
    """Zonal harmonics: the energy with the zonal potential and h_z are constants of motion."""
    state = leo()
    t = np.linspace(0, 1, 50) * u.day
    out = propagate_cowell(state, t, [vv.J2(vv.EARTH)])
    r = out.r.to_value(u.km)
    v = out.v.to_value(u.km / u.s)
    hz = r[:, 0] * v[:, 1] - r[:, 1] * v[:, 0]
    assert np.ptp(hz) / abs(hz[0]) < 1e-11
    gm, R, j2 = vv.EARTH.gm_km3_s2, vv.EARTH.radius_km, vv.EARTH.j2
    rn = np.linalg.norm(r, axis=1)
    s = r[:, 2] / rn
    energy = 0.5 * (v**2).sum(1) - gm / rn + gm * j2 * R**2 / rn**3 * (1.5 * s**2 - 0.5)
    assert np.ptp(energy) / abs(energy[0]) < 1e-11


def test_j2_drifts_node_westward_for_prograde_orbit():
    state = leo()
    out = propagate_cowell(state, [0.0, 1.0] * u.day, [vv.J2(vv.EARTH)])
    el = vv.StateVectors(out.r, out.v, vv.EARTH).to_elements()
    d = np.angle(np.exp(1j * np.diff(el.longitude_of_ascending_node.to_value(u.rad))))
    assert d[0] < 0


def test_third_bodies_and_srp_run_and_move_the_orbit_a_little():
    state = leo(EPOCH)
    t = np.linspace(0, 1, 5) * u.day
    base = propagate_cowell(state, t, [])
    full = propagate_cowell(
        state,
        t,
        [
            vv.ThirdBody(vv.SUN),
            vv.ThirdBody(vv.MOON),
            vv.SolarRadiationPressure(0.02 * u.m**2 / u.kg, shadow="conical"),
        ],
    )
    d = np.linalg.norm((full.r - base.r).to_value(u.km), axis=1)
    # luni-solar effects after one LEO day: tens of metres to a few km, never zero
    assert 1e-3 < d[-1] < 20.0


def test_result_repr_and_states():
    out = propagate_cowell(leo(EPOCH), np.linspace(0, 1, 3) * u.hour, [vv.J2(vv.EARTH)])
    assert "3 times" in repr(out)
    states = out.to_states()
    assert states.r.shape == (3, 3)


# ---------------------------------------------------------------------------- bad inputs


def test_times_out_of_order_raise():
    with pytest.raises(InvalidInputError, match="strictly increasing"):
        propagate_cowell(leo(), [0.0, 100.0, 50.0] * u.s, [])


def test_missing_time_unit_raises():
    with pytest.raises(UnitsError, match="time"):
        propagate_cowell(leo(), [0.0, 100.0], [])


def test_nan_time_raises():
    with pytest.raises(InvalidInputError, match="NaN"):
        propagate_cowell(leo(), [0.0, np.nan] * u.s, [])


def test_nan_state_raises():
    bad = type("S", (), {})()
    bad.r = [np.nan, 0, 0] * u.km
    bad.v = [0, 7.5, 0] * u.km / u.s
    bad.gm = vv.EARTH.gm
    with pytest.raises(InvalidInputError, match="NaN"):
        propagate_cowell(bad, 1 * u.s, [])


def test_batch_of_states_equals_single_runs():
    el = vv.KeplerianElements.from_semi_major_axis(
        [7000.0, 8000.0, 26000.0] * u.km, [0.001, 0.05, 0.7], [0.9, 0.1, 1.1], 0.3, 0.2,
        [0.1, 2.0, -1.0], vv.EARTH, epoch=EPOCH,
    )  # fmt: skip
    states = el.to_state()
    t = np.array([-600.0, 0.0, 3000.0, 20000.0]) * u.s
    forces = [vv.Zonal(vv.EARTH, 4), vv.ThirdBody(vv.MOON)]
    batch = propagate_cowell(states, t, forces)
    assert batch.r.shape == (3, 4, 3) and batch.v.shape == (3, 4, 3)
    for k in range(3):
        one = propagate_cowell(states[k], t, forces)
        assert np.array_equal(one.r.value, batch.r[k].value)
    scalar = propagate_cowell(states, 3000 * u.s, forces)
    assert scalar.r.shape == (3, 3)
    # (the Moon table starts at another grid point: equal to well below a millimetre)
    assert np.allclose(scalar.r.value, batch.r[:, 2].value, rtol=0, atol=ONE_MM)


def test_batch_shape_and_event_errors():
    r = np.full((2, 2, 3), 7000.0) * u.km
    v = np.full((2, 2, 3), 1.0) * u.km / u.s
    with pytest.raises(ShapeError, match=r"\(N, 3\)"):
        propagate_cowell(vv.StateVectors(r, v, vv.EARTH), 1 * u.s, [])
    two = vv.StateVectors(r[0], v[0], vv.EARTH)
    from visviva.satellites import Apsides

    with pytest.raises(InvalidInputError, match="one state at a time"):
        propagate_cowell(two, 1 * u.s, [], events=[Apsides()])


def test_unknown_body_raises():
    with pytest.raises(InvalidInputError, match="vv.EARTH"):
        vv.ThirdBody("vulcan")
    with pytest.raises(InvalidInputError, match="degree"):
        vv.Zonal(vv.EARTH, 9)
    with pytest.raises(InvalidInputError, match="zonal"):
        vv.J2(vv.MARS)


def test_not_a_perturbation_raises():
    with pytest.raises(InvalidInputError, match="not a perturbation"):
        propagate_cowell(leo(), 1 * u.s, ["J2"])


def test_third_body_without_epoch_raises():
    with pytest.raises(InvalidInputError, match="epoch"):
        propagate_cowell(leo(), 1 * u.s, [vv.ThirdBody(vv.SUN)])


def test_absolute_times_without_epoch_raise():
    with pytest.raises(InvalidInputError, match="epoch"):
        propagate_cowell(leo(), EPOCH, [])


def test_drag_needs_units():
    with pytest.raises(UnitsError):
        vv.AtmosphericDrag(0.01)
    with pytest.raises(InvalidInputError):
        vv.AtmosphericDrag(-0.01 * u.m**2 / u.kg)


def test_double_zonal_raises():
    with pytest.raises(InvalidInputError, match="one zonal"):
        propagate_cowell(leo(), 1 * u.s, [vv.J2(vv.EARTH), vv.Zonal(vv.EARTH, 4)])


@pytest.mark.parametrize(("year", "lo", "hi"), [("2006", 0.88, 1.0), ("2015", 0.70, 0.82)])
def test_geostationary_inclination_growth_from_sun_and_moon(year, lo, hi):
    """A GEO satellite starting at i = 0 gains 0.75-0.95 deg of inclination per year from the
    Sun and Moon, the most near 2006 (lunar orbit at 28.6 deg to the equator) and the least
    near 2015 (18.3 deg) (Soop 1994, Handbook of Geostationary Orbits)."""
    epoch = Time(f"{year}-01-01T00:00:00", scale="utc")
    geo = vv.KeplerianElements.from_semi_major_axis(
        42164.17 * u.km, 0.0, 0.0, 0.0, 0.0, 0.0, vv.EARTH, epoch=epoch
    ).to_state()
    forces = [vv.J2(vv.EARTH), vv.ThirdBody(vv.SUN), vv.ThirdBody(vv.MOON)]
    out = propagate_cowell(geo, [0.0, 365.25] * u.day, forces, rtol=1e-10)
    inc = vv.StateVectors(out.r, out.v, vv.EARTH).to_elements().inclination.to_value(u.deg)
    assert lo < inc[-1] < hi


def test_srp_eccentricity_growth_matches_gauss_equations():
    """Constant in-plane SRP on a circular orbit grows |e| at 3/2 F cos(dec) / v (Gauss's
    equations averaged over an orbit; Montenbruck & Gill 2000, sec. 3.4; Vallado 2013, 9.6)."""
    err, details = srp_eccentricity_growth()
    assert err < 5e-3, details


def test_drag_decay_rate_matches_analytic_with_corotation():
    """Equatorial circular orbit: da/dt = -(a^2/mu) rho B (v - omega a)^2 v (King-Hele 1987,
    with the co-rotating atmosphere; Vallado 2013, eq. 9-25 for omega = 0)."""
    from visviva.core.perturbations import VALLADO_EXPONENTIAL_TABLE, exponential_density

    R, mu = vv.EARTH.radius_km, vv.EARTH.gm_km3_s2
    omega = vv.constants.EARTH_ROTATION_RAD_S
    state = vv.KeplerianElements.from_semi_major_axis(
        (R + 420.0) * u.km, 0.0, 0.0, 0.0, 0.0, 0.0, vv.EARTH
    ).to_state()
    B = 0.02  # m^2/kg
    out = propagate_cowell(state, [0.0, 86400.0] * u.s, [vv.AtmosphericDrag(B * u.m**2 / u.kg)])
    r = np.linalg.norm(out.r.to_value(u.km), axis=1)
    v = np.linalg.norm(out.v.to_value(u.km / u.s), axis=1)
    a = -mu / (2 * (v**2 / 2 - mu / r))
    a_mid = a.mean()
    rho = exponential_density(a_mid - R, VALLADO_EXPONENTIAL_TABLE) * 1e9  # kg/km^3
    vc = np.sqrt(mu / a_mid)
    expect = -(a_mid**2 / mu) * rho * B * 1e-6 * (vc - omega * a_mid) ** 2 * vc * 86400.0
    assert abs((a[-1] - a[0]) / expect - 1) < 1e-3


@pytest.mark.parametrize("ecc", [0.95, 1.0, 1.5, 4.0])
def test_open_and_highly_eccentric_orbits_match_kepler(ecc):
    el = vv.KeplerianElements(10000.0 * u.km, ecc, 0.5, 0.2, 0.3, -0.5, vv.EARTH)
    state = el.to_state()
    t = np.linspace(0.0, 6.0, 7) * u.hour
    out = propagate_cowell(state, t, [])
    kepler = state.propagate(t)
    scale = np.linalg.norm(kepler.r.to_value(u.km), axis=-1)
    err = np.linalg.norm((out.r - kepler.r).to_value(u.km), axis=-1)
    assert np.all(err < 1e-11 * scale * 100 + ONE_MM)


# --- robustness regressions (ROBUSTNESS_BUGS #9, #16) ---------------------------------------


def test_empty_times_and_single_perturbation():
    state = leo()
    with pytest.raises(InvalidInputError, match="at least one output time"):
        propagate_cowell(state, np.zeros(0) * u.s)
    t = [0.0, 600.0] * u.s
    single = propagate_cowell(state, t, vv.J2(vv.EARTH))
    listed = propagate_cowell(state, t, [vv.J2(vv.EARTH)])
    assert np.linalg.norm((single.r - listed.r).to_value(u.km)) == 0.0
    with pytest.raises(InvalidInputError, match="list of perturbations"):
        propagate_cowell(state, t, 3.0)


def test_step_budget_exhausted_says_so():
    state = leo()
    with pytest.raises(vv.StepSizeError, match="step budget.*raise max_steps"):
        propagate_cowell(state, [0.0, 1e5] * u.s, max_steps=10)
    batch = vv.StateVectors(np.tile(state.r, (2, 1)), np.tile(state.v, (2, 1)), vv.EARTH)
    with pytest.raises(vv.StepSizeError, match="step budget"):
        propagate_cowell(batch, [0.0, 1e5] * u.s, max_steps=10)
    for bad in (0, -5, 2.5):
        with pytest.raises(InvalidInputError, match="max_steps must be an integer > 0"):
            propagate_cowell(state, 100 * u.s, max_steps=bad)


def test_zonal_only_kernel_gives_the_full_kernels_bits(monkeypatch):
    # a two-body + zonal model without events runs the ZONAL_ONLY variant (only zonal_rhs
    # compiled, for a short first call); forced onto the full right-hand side it gives the
    # same bits, one state and a batch
    from visviva.core import cowell as core_cowell
    from visviva.satellites import cowell as sat_cowell

    state = leo()
    batch = vv.StateVectors([[7000.0, 0.0, 0.0], [0.0, 8000.0, 10.0]] * u.km,
                            [[0.0, 7.5, 1.0], [-6.9, 0.0, 1.5]] * u.km / u.s, vv.EARTH)
    t = np.linspace(0.0, 6 * 3600.0, 13) * u.s
    model = [vv.Zonal(vv.EARTH, 4)]
    zeros = np.zeros(core_cowell.fb.FORCE_SIZE)
    assert core_cowell.rhs_kind(zeros) is None
    # altitude crossings (the surface that bounds every perturbed run, ReEntry) stay ZONAL_ONLY:
    # the surface watch had put every J2 run on the full kernel (twice the run time, three
    # times the first compile); other events need the full one
    assert core_cowell.rhs_kind(zeros, np.array([0, 0])) is None
    assert core_cowell.rhs_kind(zeros, np.array([0, 4])) is True
    events = [AltitudeCrossing(700 * u.km), AltitudeCrossing(900 * u.km, direction=-1)]
    few = [propagate_cowell(s, t, model) for s in (state, batch)]
    few_ev = propagate_cowell(state, t, model, events=events)
    monkeypatch.setattr(sat_cowell, "rhs_kind", lambda force, ev_kind=(): core_cowell.FULL)
    full = [propagate_cowell(s, t, model) for s in (state, batch)]
    full_ev = propagate_cowell(state, t, model, events=events)
    for a, b in zip([*few, few_ev], [*full, full_ev], strict=True):
        np.testing.assert_array_equal(a.r.to_value(u.km), b.r.to_value(u.km))
        np.testing.assert_array_equal(a.v.to_value(u.km / u.s), b.v.to_value(u.km / u.s))
    assert len(few_ev.events) > 0
    assert [(e.what, e.t.value) for e in few_ev.events] == [(e.what, e.t.value)
                                                            for e in full_ev.events]


@pytest.mark.parametrize("frame", ["teme", "itrs"])
def test_satellite_states_in_another_frame_than_gcrs_are_refused(frame):
    # sat.teme(t) was integrated as if GCRS: 37 km off after 10 min (ITRS: 7,000 km), no error
    sat = vv.Satellite.from_tle(
        "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
        "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340")
    with pytest.raises(vv.InvalidInputError, match=f"{frame.upper()}.*gcrs"):
        vv.propagate_cowell(getattr(sat, frame)(sat.epoch), 600 * u.s, [vv.J2()])
    out = vv.propagate_cowell(sat.gcrs(sat.epoch), 600 * u.s, [vv.J2()])
    assert np.linalg.norm((out.r - sat.gcrs(sat.epoch + 600 * u.s).r).to_value(u.km)) < 0.1


def test_tolerances_as_quantities_are_refused_not_read_by_their_value():
    """atol=1 * u.m was read as 1 (km): a run 200 km off after a day, silently (audit21)."""
    state = leo(EPOCH)
    for kw in (dict(atol=1 * u.m), dict(atol=1e-9 * u.km / u.s), dict(rtol=1e-10 * u.one)):
        with pytest.raises(InvalidInputError, match="plain number"):
            propagate_cowell(state, 1 * u.hour, [vv.J2(vv.EARTH)], **kw)
        with pytest.raises(InvalidInputError, match="plain number"):
            vv.propagate_covariance(state, np.eye(6) * 1e-6, 1 * u.hour, [vv.J2(vv.EARTH)], **kw)
    with pytest.raises(InvalidInputError, match=r"atol=0\.001"):
        propagate_cowell(state, 1 * u.hour, [], atol=1 * u.m)
    for bad in (True, "1e-12", [1e-12], float("nan"), 0.0):
        with pytest.raises(InvalidInputError, match="atol"):
            propagate_cowell(state, 1 * u.hour, [], atol=bad)
    # below the float64 precision: was 10 million steps, then 'raise max_steps'
    with pytest.raises(InvalidInputError, match="below the float64 precision"):
        propagate_cowell(state, 1 * u.day, [vv.J2(vv.EARTH)], rtol=1e-20, atol=1e-20,
                         max_steps=1000)
    # numpy scalars are numbers, the same run as the float
    a = propagate_cowell(state, 1 * u.hour, [], rtol=np.float32(1e-10), atol=np.float64(1e-10))
    b = propagate_cowell(state, 1 * u.hour, [], rtol=float(np.float32(1e-10)), atol=1e-10)
    assert np.array_equal(a.r.value, b.r.value)


def test_t_final_of_a_backward_run_is_where_it_ended():
    """audit21: a run with only negative output times reported t_final = 0 (the epoch), not
    the time it integrated back to; one state and a batch alike."""
    state = leo(EPOCH)
    f = [vv.J2(vv.EARTH)]
    assert propagate_cowell(state, [-3600.0, -1800.0] * u.s, f).t_final == -3600.0 * u.s
    assert propagate_cowell(state, -600.0 * u.s, f).t_final == -600.0 * u.s
    assert propagate_cowell(state, [-3600.0, 0.0] * u.s, f).t_final == 0.0 * u.s
    assert propagate_cowell(state, [-3600.0, 600.0] * u.s, f).t_final == 600.0 * u.s
    batch = vv.StateVectors(np.stack([state.r, state.r * 1.01]), np.stack([state.v, state.v]),
                            vv.EARTH, epoch=EPOCH)
    for t, end in (([-3600.0, -1800.0], -3600.0), ([-3600.0, 0.0], 0.0), ([-60.0, 600.0], 600.0)):
        assert propagate_cowell(batch, t * u.s, f).t_final == end * u.s
        assert vv.propagate_covariance(state, np.eye(6) * 1e-8, t * u.s, f).t_final == end * u.s


def test_a_lunar_orbiter_feels_the_earths_tide():
    """``ThirdBody(vv.EARTH)`` about the Moon against an independent integration: scipy's
    DOP853 with the Earth's tide (Vallado eq. 8-35) from the ephemeris relative to the Moon,
    splined on a one-minute grid; refused as a third body of a state about the Earth."""
    from scipy.integrate import solve_ivp
    from scipy.interpolate import CubicSpline

    from visviva.satellites.ephemeris import position_velocity

    gm_moon, gm_earth = vv.MOON.gm_km3_s2, vv.EARTH.gm_km3_s2
    r0 = vv.MOON.radius_km + 100.0
    state = vv.StateVectors([r0, 0.0, 0.0] * u.km,
                            np.array([0.0, 0.6, 0.8]) * np.sqrt(gm_moon / r0) * u.km / u.s,
                            vv.MOON, epoch=EPOCH)
    t = np.linspace(0.0, 6 * 3600.0, 7)
    tide = propagate_cowell(state, t * u.s, [vv.ThirdBody(vv.EARTH)])
    alone = propagate_cowell(state, t * u.s, [])
    grid = np.arange(-60.0, t[-1] + 120.0, 60.0)
    earth = CubicSpline(grid, position_velocity("earth", EPOCH + grid * u.s,
                                                center="moon")[0].to_value(u.km))

    def rhs(s, y):
        r, d = y[:3], earth(s) - y[:3]
        rb = earth(s)
        a = -gm_moon * r / np.linalg.norm(r) ** 3 + gm_earth * (
            d / np.linalg.norm(d) ** 3 - rb / np.linalg.norm(rb) ** 3)
        return np.r_[y[3:], a]

    ref = solve_ivp(rhs, (0.0, t[-1]), np.r_[state.r.to_value(u.km), state.v.to_value(u.km / u.s)],
                    method="DOP853", t_eval=t, rtol=1e-12, atol=1e-12).y[:3].T
    moved = np.linalg.norm(tide.r.to_value(u.km) - alone.r.to_value(u.km), axis=1).max()
    err = np.linalg.norm(tide.r.to_value(u.km) - ref, axis=1).max()
    # measured: the tide moves the orbit 145 m in 6 h; visviva agrees with scipy to 3 microns
    assert moved > 0.05
    assert err < 1e-3 * moved and err < 1e-4  # km
    about_earth = vv.StateVectors([7000.0, 0, 0] * u.km, [0, 7.5, 0] * u.km / u.s, vv.EARTH,
                                  epoch=EPOCH)
    with pytest.raises(InvalidInputError, match="central body"):
        propagate_cowell(about_earth, 60 * u.s, [vv.ThirdBody(vv.EARTH)])
