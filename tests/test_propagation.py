"""Public Kepler propagation: units, broadcasting (many orbits x many times in one kernel call),
epochs, typed errors, and StateVectors.propagate."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv
from visviva import propagation
from visviva.errors import (
    InvalidInputError,
    InvalidStateError,
    ShapeError,
    UnitsError,
)

DATA = Path(__file__).parent / "data" / "textbook_examples.json"
ONE_MM = 1e-6  # km
KM = u.km
KMS = u.km / u.s
GM_EARTH = 398600.4418 * u.km**3 / u.s**2


def leo():
    return vv.StateVectors([7000.0, 0.0, 0.0] * KM, [0.0, 7.5, 1.0] * KMS, GM_EARTH)


def test_vallado_example_2_4_through_the_public_layer():
    ex = json.loads(DATA.read_text())["vallado_ex2_4_kepler_propagation"]
    gm = ex["mu"] * u.km**3 / u.s**2
    s = vv.StateVectors(ex["inputs"]["r0"] * KM, ex["inputs"]["v0"] * KMS, gm)
    out = s.propagate(ex["inputs"]["dt"] * u.s)
    assert isinstance(out, vv.StateVectors)
    np.testing.assert_allclose(
        out.r.to_value(KM), ex["computed"]["r"], atol=ex["tol_computed"]["r"]
    )
    np.testing.assert_allclose(
        out.v.to_value(KMS), ex["computed"]["v"], atol=ex["tol_computed"]["v"]
    )
    # the same in minutes, and through the module function
    out2 = propagation.propagate_kepler(s, 40 * u.min)
    np.testing.assert_allclose(out2.r.to_value(KM), out.r.to_value(KM), rtol=0, atol=ONE_MM)


def test_dt_units_are_converted_and_required():
    s = leo()
    a = s.propagate(1.5 * u.h).r.to_value(KM)
    b = s.propagate(5400.0 * u.s).r.to_value(KM)
    np.testing.assert_array_equal(a, b)
    with pytest.raises(UnitsError, match="Quantity"):
        s.propagate(5400.0)
    with pytest.raises(UnitsError, match="time"):
        s.propagate(5400.0 * u.km)
    with pytest.raises(InvalidInputError, match="NaN"):
        s.propagate(np.nan * u.s)


def test_not_a_state_is_refused():
    with pytest.raises(InvalidInputError, match="StateVectors"):
        propagation.propagate_kepler(([7000, 0, 0], [0, 7.5, 0]), 1 * u.s)


def test_bad_states_are_refused_by_the_container():
    with pytest.raises(InvalidInputError):
        vv.StateVectors([np.nan, 0, 0] * KM, [0, 7.5, 0] * KMS, GM_EARTH)
    with pytest.raises(InvalidInputError):
        vv.StateVectors([7000.0, 0, 0] * KM, [0, 7.5, 0] * KMS, -1.0 * GM_EARTH.unit)
    with pytest.raises(UnitsError):
        vv.StateVectors([7000.0, 0, 0], [0, 7.5, 0] * KMS, GM_EARTH)
    with pytest.raises(ShapeError):
        vv.StateVectors([7000.0, 0] * KM, [0, 7.5] * KMS, GM_EARTH)


def test_many_orbits_times_many_times_in_one_kernel_call(monkeypatch):
    rng = np.random.default_rng(3)
    n, t = 50, 7
    r = rng.normal(size=(n, 3)) * 8000.0
    v = rng.normal(size=(n, 3)) * 4.0
    s = vv.StateVectors(r * KM, v * KMS, GM_EARTH)
    times = np.linspace(-3e4, 3e4, t)[:, None] * u.s  # (T, 1) against (N,)

    from visviva.core import universal

    calls = []
    real = universal.propagate_many

    def counting(*args):
        calls.append(args[0].shape)
        return real(*args)

    monkeypatch.setattr(universal, "propagate_many", counting)
    out = s.propagate(times)
    assert calls == [(t * n, 3)]  # ONE kernel call over every (time, orbit) pair
    assert out.shape == (t, n)
    assert out.r.shape == (t, n, 3) and out.v.shape == (t, n, 3)
    # each entry equals the single-state, single-time propagation
    for i, j in [(0, 0), (3, 17), (6, 49)]:
        single = vv.StateVectors(r[j] * KM, v[j] * KMS, GM_EARTH).propagate(times[i, 0])
        np.testing.assert_array_equal(out.r[i, j].to_value(KM), single.r.to_value(KM))
        np.testing.assert_array_equal(out.v[i, j].to_value(KMS), single.v.to_value(KMS))


def test_one_time_per_state_and_scalar_time():
    r = np.array([[7000.0, 0, 0], [0, 9000.0, 0]])
    v = np.array([[0, 7.5, 0], [-6.0, 0, 1.0]])
    s = vv.StateVectors(r * KM, v * KMS, GM_EARTH)
    out = s.propagate([100.0, 200.0] * u.s)
    assert out.shape == (2,)
    ref = vv.StateVectors(r[1] * KM, v[1] * KMS, GM_EARTH).propagate(200 * u.s)
    np.testing.assert_array_equal(out.r[1].to_value(KM), ref.r.to_value(KM))
    assert s.propagate(100 * u.s).shape == (2,)
    with pytest.raises(ShapeError, match=r"\(T, 1\)"):
        s.propagate([1.0, 2.0, 3.0] * u.s)


def test_scalar_state_with_time_array():
    out = leo().propagate(np.linspace(0, 5400, 4) * u.s)
    assert out.shape == (4,)
    np.testing.assert_array_equal(out.r[0].to_value(KM), [7000.0, 0.0, 0.0])


def test_zero_dt_returns_input_exactly():
    s = leo()
    out = s.propagate(0 * u.s)
    np.testing.assert_array_equal(out.r.to_value(KM), s.r.to_value(KM))
    np.testing.assert_array_equal(out.v.to_value(KMS), s.v.to_value(KMS))


def test_per_state_gm_is_kept():
    gm = [398600.4418, 4902.800066] * u.km**3 / u.s**2
    s = vv.StateVectors([[7000.0, 0, 0], [2000.0, 0, 0]] * KM, [[0, 7.5, 0], [0, 1.6, 0]] * KMS, gm)
    out = s.propagate(600 * u.s)
    np.testing.assert_allclose(out.gm.to_value(gm.unit), gm.value)
    moon = vv.StateVectors([2000.0, 0, 0] * KM, [0, 1.6, 0] * KMS, gm[1]).propagate(600 * u.s)
    np.testing.assert_array_equal(out.r[1].to_value(KM), moon.r.to_value(KM))


def test_epoch_advances():
    t0 = Time("2024-03-01T00:00:00", scale="tdb")
    s = vv.StateVectors([7000.0, 0, 0] * KM, [0, 7.5, 0] * KMS, GM_EARTH, epoch=t0)
    out = s.propagate(90 * u.min)
    assert abs((out.epoch - t0).to_value(u.s) - 5400.0) < 1e-6
    grid = s.propagate(np.arange(3) * u.h)
    assert grid.epoch.shape == (3,)
    assert abs((grid.epoch[2] - t0).to_value(u.h) - 2.0) < 1e-9
    # (T, 1) times x (N,) states: the epoch is broadcast to the result's shape
    many = vv.StateVectors(
        [[7000.0, 0, 0], [8000.0, 0, 0]] * KM, [0, 7.5, 0] * KMS, GM_EARTH, epoch=t0
    )
    out = many.propagate(np.arange(3)[:, None] * u.h)
    assert out.shape == (3, 2) and out.epoch.shape == (3, 2)
    assert abs((out[2, 1].epoch - t0).to_value(u.h) - 2.0) < 1e-9
    assert leo().propagate(1 * u.s).epoch is None


def test_radial_infall_raises_typed_error():
    s = vv.StateVectors([7000.0, 0, 0] * KM, [-1.0, 0, 0] * KMS, GM_EARTH)
    with pytest.raises(InvalidStateError, match="collision"):
        s.propagate(2 * u.h)
    ok = s.propagate(60 * u.s)  # before the collision
    assert 0 < ok.r[0].to_value(KM) < 7000.0


def test_every_conic_conserves_energy_and_angular_momentum():
    gm = GM_EARTH.to_value(u.km**3 / u.s**2)
    r0 = 7000.0
    v_circ = math.sqrt(gm / r0)
    speeds = v_circ * np.array([1.0, 1.2, math.sqrt(2.0), 1.5, 3.0])  # circle ... hyperbola
    r = np.tile([r0, 0.0, 0.0], (5, 1))
    v = np.zeros((5, 3))
    v[:, 1] = speeds
    s = vv.StateVectors(r * KM, v * KMS, GM_EARTH)
    out = s.propagate(np.array([-1e5, -10.0, 3e3, 1e6])[:, None] * u.s)
    e0 = s.specific_energy.to_value(u.km**2 / u.s**2)
    e1 = out.specific_energy.to_value(u.km**2 / u.s**2)
    scale = 0.5 * np.sum(out.v.to_value(KMS) ** 2, axis=-1) + gm / out.radius.to_value(KM)
    assert np.all(np.abs(e1 - e0) <= 1e-13 * np.maximum(scale, 0.5 * speeds**2 + gm / r0))
    h0 = np.cross(r, v)
    h1 = np.cross(out.r.to_value(KM), out.v.to_value(KMS))
    # h = r x v is computed from the vectors: its rounding scale is |r| |v| at either end
    h_scale = np.maximum(
        np.linalg.norm(h0, axis=-1),
        out.radius.to_value(KM) * np.linalg.norm(out.v.to_value(KMS), axis=-1),
    )
    assert np.all(np.linalg.norm(h1 - h0, axis=-1) <= 1e-13 * h_scale)


# --- robustness regression (ROBUSTNESS_BUGS.md #20) --------------------------------------------
@pytest.mark.parametrize("k", [490, -500])
def test_extreme_gm_propagates_like_rescaled_earth_orbit(k):
    """gm = 4e300 or 4e-296 km3/s2 is an Earth orbit in another time unit (exact power of 2)."""
    r = [7000.0, 0, 0] * KM
    v = np.array([0.0, 8.5, 0.3])
    lam = math.ldexp(1.0, k)
    ref = vv.StateVectors(r, v * KMS, GM_EARTH).propagate(1234.0 * u.s)
    out = vv.StateVectors(r, v * lam * KMS, GM_EARTH * lam * lam).propagate(1234.0 / lam * u.s)
    np.testing.assert_allclose(out.r.to_value(KM), ref.r.to_value(KM), rtol=1e-14, atol=ONE_MM)
    np.testing.assert_allclose(out.v.to_value(KMS) / lam, ref.v.to_value(KMS), rtol=1e-14)


def test_tiny_position_propagates_in_rescaled_units():
    """|r0| = 1e-200 km: r0^2 underflows, yet the orbit is an exactly rescaled Earth orbit."""
    lam = math.ldexp(1.0, -600)  # length unit; time unit tau: gm unchanged for lam^3 = tau^2
    tau = math.ldexp(1.0, -900)
    r = np.array([7000.0, 0, 0])
    v = np.array([0.0, 8.5, 0.3])
    ref = vv.StateVectors(r * KM, v * KMS, GM_EARTH).propagate(1234.0 * u.s)
    out = vv.StateVectors(r * lam * KM, v * (lam / tau) * KMS, GM_EARTH).propagate(
        1234.0 * tau * u.s
    )
    np.testing.assert_allclose(out.r.to_value(KM) / lam, ref.r.to_value(KM), rtol=1e-14, atol=1e-9)
    np.testing.assert_allclose(out.v.to_value(KMS) * tau / lam, ref.v.to_value(KMS), rtol=1e-14)


@pytest.mark.filterwarnings("ignore::visviva.ImplausibleVelocityWarning")  # 1e200 km/s is meant
@pytest.mark.parametrize("r_km, v_kms", [(1.0, 1e200), (1e200, 7.5)])
def test_out_of_range_magnitudes_say_so(r_km, v_kms):
    """Not a collision nor a solver bug: the magnitudes do not fit float64."""
    gm = 1e-300 * u.km**3 / u.s**2
    s = vv.StateVectors([r_km, 0, 0] * KM, [0, v_kms, 0.1 * v_kms] * KMS, gm)
    with pytest.raises(vv.errors.DomainError, match="out of float64's range"):
        s.propagate(1000.0 * u.s)


# --- audit57: a propagation whose phase is rounding noise warns ----------------------------------
def test_phase_rounding_warning_beyond_1e12_revolutions():
    import warnings

    s = vv.StateVectors([7000.0, 0, 0] * u.km, [0, 7.2, 1.1] * u.km / u.s, vv.EARTH)
    period = s.to_elements().period.to_value(u.s)
    # 1e9 revolutions: error ~6 m (60-digit check, docs/propagation): no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error", vv.PhaseRoundingWarning)
        s.propagate(1e9 * period * u.s)
    # before: 1e13 revolutions (error ~58 km vs 60 digits) returned with no word
    with pytest.warns(vv.PhaseRoundingWarning, match="revolutions"):
        s.propagate(1e13 * period * u.s)
    # only the offending item is counted; hyperbolas are exempt however long dt
    hyp = vv.StateVectors([7000.0, 0, 0] * u.km, [0, 12.0, 0] * u.km / u.s, vv.EARTH)
    with warnings.catch_warnings():
        warnings.simplefilter("error", vv.PhaseRoundingWarning)
        hyp.propagate(1e18 * u.s)
