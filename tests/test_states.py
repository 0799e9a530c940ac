"""StateVectors: validation, broadcasting, indexing, derived quantities, conversions."""

import math

import numpy as np
import pytest
from astropy import units as u

import visviva as vv

MU = 398600.4418 * u.km**3 / u.s**2
KM = u.km
KMS = u.km / u.s
ONE_MM = 1e-6  # km


def leo(shape=()):
    rng = np.random.default_rng(42)
    r = rng.normal(size=shape + (3,)) * 3000 + np.array([7000.0, 0, 0])
    v = rng.normal(size=shape + (3,)) * 0.5 + np.array([0, 7.5, 1.0])
    return vv.StateVectors(r * KM, v * KMS, MU)


def test_attributes_units_and_repr():
    s = vv.StateVectors([7000.0, 0, 0] * KM, [0, 7.5, 0] * KMS, vv.EARTH)
    assert s.r.unit == KM and s.v.unit == KMS
    assert s.gm.to_value(u.km**3 / u.s**2) == pytest.approx(vv.EARTH.gm_km3_s2)
    assert s.shape == () and s.epoch is None
    text = repr(s)
    assert "StateVectors" in text and "7000" in text and "km3 / s2" in text
    with pytest.raises(TypeError, match="len"):
        len(s)
    with pytest.raises(TypeError, match="cannot be indexed"):
        s[0]
    # other units are converted once
    s2 = vv.StateVectors(
        [7e6, 0, 0] * u.m, [0, 7500.0, 0] * u.m / u.s, 3.986004418e14 * u.m**3 / u.s**2
    )
    assert np.allclose(s2.r.value, [7000.0, 0, 0]) and s2.gm.value == pytest.approx(398600.4418)
    big = leo((5,))
    assert "5 states" in repr(big)


def test_broadcasting_shapes():
    for shape in [(), (3,), (4, 3), (2, 4, 3)]:
        r = np.broadcast_to([7000.0, 100.0, 0.0], shape + (3,)) * KM
        s = vv.StateVectors(r, [0, 7.5, 0.1] * KMS, MU)
        assert s.shape == shape
        assert s.r.shape == shape + (3,) and s.v.shape == shape + (3,)
        assert s.radius.shape == shape and s.specific_energy.shape == shape
        el = s.to_elements()
        assert el.shape == shape and el.semi_latus_rectum.shape == shape
        back = el.to_state()
        assert back.shape == shape
        assert np.abs((back.r - s.r).to_value(KM)).max() < ONE_MM
    # gm per item
    s = vv.StateVectors(
        [[7000.0, 0, 0], [0, 7000.0, 0]] * KM,
        [0, 0, 7.5] * KMS,
        [398600.4418, 1.0] * u.km**3 / u.s**2,
    )
    assert s.gm.shape == (2,)
    # (T, N, 3) with r (N, 3) against v (T, 1, 3)
    r = leo((5,)).r
    v = np.array([[[0, 7.5, 0]], [[0, 7.6, 0]]]) * KMS
    s = vv.StateVectors(r, v, MU)
    assert s.shape == (2, 5)


def test_indexing_and_len():
    s = leo((4, 5))
    assert len(s) == 4
    assert s[1].shape == (5,)
    assert s[1, 2].shape == ()
    assert s[..., 3].shape == (4,)
    assert s[:, 1:3].shape == (4, 2)
    assert np.array_equal(s[1, 2].r.value, s.r.value[1, 2])
    el = s.to_elements()
    assert el[1, 2].semi_latus_rectum.value == el.semi_latus_rectum.value[1, 2]
    with pytest.raises(IndexError, match="leading axes"):
        s[0, 0, 0]


def test_derived_quantities():
    s = leo((50,))
    r = s.r.to_value(KM)
    v = s.v.to_value(KMS)
    mu = MU.value
    rm = np.linalg.norm(r, axis=-1)
    assert np.allclose(s.radius.to_value(KM), rm, rtol=1e-15)
    assert np.allclose(s.speed.to_value(KMS), np.linalg.norm(v, axis=-1), rtol=1e-15)
    assert s.specific_energy.unit == u.km**2 / u.s**2
    assert np.allclose(s.specific_energy.value, 0.5 * (v**2).sum(-1) - mu / rm, rtol=1e-14)
    h = s.specific_angular_momentum
    assert h.unit == u.km**2 / u.s and h.shape == (50, 3)
    el = s.to_elements()
    assert np.allclose(
        np.linalg.norm(h.value, axis=-1), el.specific_angular_momentum.value, rtol=1e-14
    )
    ev = s.eccentricity_vector
    assert np.allclose(np.linalg.norm(ev, axis=-1), el.eccentricity, rtol=1e-12, atol=1e-15)
    # the eccentricity vector points to periapsis: along the state at nu = 0
    assert np.allclose(el.specific_energy.value, s.specific_energy.value, rtol=1e-12)
    # cached: same object on the second access
    assert s.radius is s.radius


def test_validation_messages():
    r = [7000.0, 0, 0] * KM
    v = [0, 7.5, 0] * KMS
    with pytest.raises(vv.UnitsError, match="u.km"):
        vv.StateVectors([7000.0, 0, 0], v, MU)
    with pytest.raises(vv.UnitsError, match="cannot be converted"):
        vv.StateVectors(r, [0, 7.5, 0] * KM, MU)
    with pytest.raises(vv.UnitsError):
        vv.StateVectors(r, v, 398600.4418)
    with pytest.raises(vv.ShapeError, match=r"\(\.\.\., 3\)"):
        vv.StateVectors([7000.0, 0] * KM, v, MU)
    with pytest.raises(vv.ShapeError, match="broadcast"):
        vv.StateVectors(np.ones((4, 3)) * KM, np.ones((5, 3)) * KMS, MU)
    with pytest.raises(vv.InvalidInputError, match="NaN"):
        vv.StateVectors([np.nan, 0, 0] * KM, v, MU)
    with pytest.raises(vv.InvalidInputError, match="NaN"):
        vv.StateVectors(r, [0, np.inf, 0] * KMS, MU)
    with pytest.raises(vv.InvalidInputError, match="gm must be > 0"):
        vv.StateVectors(r, v, -MU)
    with pytest.raises(vv.InvalidInputError, match="gm must be > 0"):
        vv.StateVectors(r, v, 0 * MU)
    with pytest.raises(vv.InvalidStateError, match="zero length"):
        vv.StateVectors([[7000.0, 0, 0], [0.0, -0.0, 0.0]] * KM, v, MU)


def test_radial_state_cannot_give_elements():
    s = vv.StateVectors([[7000.0, 0, 0], [7000.0, 0, 0]] * KM, [[0, 7.5, 0], [3.0, 0, 0]] * KMS, MU)
    with pytest.raises(vv.InvalidStateError, match=r"radial.*index \(1,\)"):
        s.to_elements()
    with pytest.raises(vv.InvalidStateError, match="radial"):
        s.to_equinoctial()


def test_to_equinoctial_round_trip_and_retrograde():
    s = leo((20,))
    for retro in (False, True):
        m = s.to_equinoctial(retrograde=retro)
        assert m.retrograde is retro and m.shape == (20,)
        back = m.to_state()
        assert np.abs((back.r - s.r).to_value(KM)).max() < ONE_MM * 1e-3
        k = m.to_keplerian()
        assert np.allclose(k.eccentricity, s.to_elements().eccentricity, rtol=1e-12)
    vc = math.sqrt(MU.value / 7000.0)
    retro_eq = vv.StateVectors([7000.0, 0, 0] * KM, [0, -vc, 0] * KMS, MU)
    with pytest.raises(vv.DomainError, match="retrograde=True"):
        retro_eq.to_equinoctial()
    m = retro_eq.to_equinoctial(retrograde=True)
    assert m.h == 0.0 and m.k == 0.0
    assert np.abs((m.to_state().r - retro_eq.r).to_value(KM)).max() < 1e-12


def test_propagate_delegates_to_kepler_propagation():
    pytest.importorskip("visviva.propagation")
    s = vv.StateVectors([7000.0, 0, 0] * KM, [0, 7.5, 0] * KMS, MU)
    el = s.to_elements()
    back = s.propagate(el.period)
    assert isinstance(back, vv.StateVectors)
    assert np.abs((back.r - s.r).to_value(KM)).max() < ONE_MM


def test_epoch_is_carried_and_indexed():
    from astropy.time import Time

    t = Time("2024-01-01T00:00:00", scale="utc") + np.arange(3) * u.h
    s = vv.StateVectors([[7000.0, 0, 0]] * 3 * KM, [0, 7.5, 0] * KMS, MU, epoch=t)
    assert s.epoch is t
    el = s.to_elements()
    assert el.epoch is t
    assert el[1].epoch == t[1] and s[2].epoch == t[2]
    assert el.to_state().epoch is t
    assert s.to_equinoctial().epoch is t
    scalar_epoch = vv.StateVectors([[7000.0, 0, 0]] * 3 * KM, [0, 7.5, 0] * KMS, MU, epoch=t[0])
    assert scalar_epoch[1].epoch == t[0]


def test_empty_arrays():
    s = vv.StateVectors(np.empty((0, 3)) * KM, np.empty((0, 3)) * KMS, MU)
    assert s.shape == (0,) and len(s) == 0 and "no states" in repr(s)
    el = s.to_elements()
    assert el.shape == (0,) and "no orbits" in repr(el)
    assert el.to_state().shape == (0,) and el.mean_anomaly.shape == (0,)
    assert s.to_equinoctial().to_state().shape == (0,)


# --- robustness regressions (ROBUSTNESS_BUGS.md #6, #22) ---------------------------------------
def test_overflowing_energy_raises_domain_error_not_inf():
    with pytest.warns(vv.ImplausibleVelocityWarning):
        s = vv.StateVectors([7000.0, 0, 0] * KM, [0, 1e200, 0] * KMS, MU)
    assert s.speed.value == pytest.approx(1e200, rel=1e-15)  # the norm itself must not overflow
    with pytest.raises(vv.errors.DomainError, match="overflows float64"):
        _ = s.specific_energy
    with pytest.raises(vv.errors.DomainError, match="overflows float64"):
        _ = s.eccentricity_vector


def test_tiny_gm_elements_raise_instead_of_inf():
    s = vv.StateVectors([7000.0, 0, 0] * KM, [0, 7.5, 0] * KMS, 1e-300 * u.km**3 / u.s**2)
    with pytest.raises(vv.errors.DomainError, match="overflows float64"):
        s.to_elements()


@pytest.mark.filterwarnings("ignore::visviva.ImplausibleVelocityWarning")  # meant
@pytest.mark.parametrize("r, v", [
    ([1.4e154, 0, 0], [0, 1.7e-72, 0]),  # a circular orbit just past |r|^2 = 1.8e308
    ([1e200, 0, 0], [0, 1e-3, 0]),
    ([7000.0, 0, 0], [0, 1e160, 0]),  # |v|^2 overflows
    ([1e200, 1e200, 0], [1e200, 1e200, 1.0]),  # r x v = inf - inf = NaN in a component
])
def test_magnitudes_beyond_float64_are_an_overflow_not_a_radial_orbit(r, v):
    # was: InvalidStateError "the angular momentum r x v is zero (radial, rectilinear motion)":
    # |r|^2 (or |v|^2, |r x v|) overflowed, and the radial test compared |h| with inf
    s = vv.StateVectors(r * KM, v * KMS, MU)
    for convert in (s.to_elements, s.to_equinoctial, lambda: s.to_equinoctial(True)):
        with pytest.raises(vv.errors.DomainError,
                           match=r"\(scale r, v and gm to other units\): the result overflows "
                                 r"float64") as err:
            convert()
        assert not isinstance(err.value, vv.errors.InvalidStateError)
        assert "radial" not in str(err.value)


def test_largest_circular_orbit_before_overflow_still_converts():
    # the overflow test must not move the boundary: |r| = 1.3e154 km (|r|^2 < 1.8e308) works
    r = 1.3e154
    vc = math.sqrt(MU.to_value(KM**3 / u.s**2) / r)
    s = vv.StateVectors([[r, 0, 0], [7000.0, 0, 0]] * KM, [[0, vc, 0], [0, 7.5, 1.0]] * KMS, MU)
    el = s.to_elements()
    assert el.eccentricity[0] == 0.0
    assert el.semi_latus_rectum[0].to_value(KM) == pytest.approx(r, rel=1e-14)
    np.testing.assert_allclose(el.to_state().r.to_value(KM), s.r.to_value(KM), rtol=1e-13)
    bad = vv.StateVectors([[7000.0, 0, 0], [1.4e154, 0, 0]] * KM,
                          [[0, 7.5, 1.0], [0, 1.7e-72, 0]] * KMS, MU)
    with pytest.raises(vv.errors.DomainError, match=r"overflows float64 .*at index \(1,\)"):
        bad.to_elements()


@pytest.mark.parametrize("epoch", ["yesterday", 2451545.0])
def test_epoch_must_be_time(epoch):
    with pytest.raises(vv.errors.InvalidInputError, match="astropy.time.Time"):
        vv.StateVectors([7000.0, 0, 0] * KM, [0, 7.5, 0] * KMS, MU, epoch=epoch)


def test_epoch_that_does_not_match_the_states_raises_shape_error():
    # an epoch of 3 times for 2 states was stored silently; s[1].epoch then gave all 3 times
    from astropy.time import Time

    r = [[7000.0, 0, 0], [8000.0, 100.0, 0]] * KM
    three = Time("2024-01-01", scale="utc") + np.arange(3) * u.h
    with pytest.raises(vv.ShapeError, match="epoch"):
        vv.StateVectors(r, [0, 7.5, 1.0] * KMS, MU, epoch=three)


def test_epoch_broadcasts_to_the_leading_shape():
    # (N,) epochs against (T, N) states: every state gets its own time, so indexing is right
    from astropy.time import Time

    t = Time("2024-01-01", scale="tdb") + np.arange(2) * u.day
    r = np.tile([7000.0, 0.0, 0.0], (3, 2, 1)) * KM
    s = vv.StateVectors(r, [0, 7.5, 1.0] * KMS, MU, epoch=t)
    assert s.epoch.shape == (3, 2)
    assert s[2, 1].epoch == t[1] and s[0].epoch.shape == (2,)
    moved = s.propagate(1 * u.h).epoch  # one hour of TT later, still in TDB (as Cowell counts)
    assert moved.shape == (3, 2) and moved.scale == "tdb"
    np.testing.assert_allclose((moved.tt - t.tt).to_value(u.s), 3600.0, rtol=0, atol=1e-6)
