"""Collisions: conservation laws exactly, restitution, explosive separation, 3-D impulses."""

import numpy as np
import pytest
from astropy import units as u
from hypothesis import given, settings
from hypothesis import strategies as st

from visviva import mechanics as mech
from visviva.errors import DomainError, InvalidInputError, InvalidStateError, ShapeError

masses = st.floats(1e-8, 1e8)
speeds = st.floats(-1e6, 1e6)


def test_elastic_textbook_cases():
    assert mech.elastic_collision_1d(1.0, 1.0, 1.0, 0.0) == (0.0, 1.0)
    v1, v2 = mech.elastic_collision_1d(1.0, 2.0, 3.0, 0.0)
    assert (v1, v2) == (pytest.approx(-1.0), pytest.approx(1.0))
    # a light ball on a heavy one at rest bounces back at nearly its speed
    v1, v2 = mech.elastic_collision_1d(1.0, 1.0, 1e9, 0.0)
    assert v1 == pytest.approx(-1.0, rel=1e-8) and v2 == pytest.approx(2e-9, rel=1e-6)


@settings(max_examples=200, deadline=None)
@given(masses, speeds, masses, speeds, st.floats(0, 1))
def test_collisions_conserve_momentum_and_obey_restitution(m1, v1, m2, v2, e):
    a, b = mech.inelastic_collision_1d(m1, v1, m2, v2, e)
    scale = m1 * abs(v1) + m2 * abs(v2) + 1e-300
    assert abs((m1 * a + m2 * b) - (m1 * v1 + m2 * v2)) <= 1e-14 * scale
    assert (a - b) == pytest.approx(-e * (v1 - v2), rel=1e-12, abs=1e-12 * (abs(v1) + abs(v2)))
    k0 = 0.5 * m1 * v1**2 + 0.5 * m2 * v2**2
    k1 = 0.5 * m1 * a**2 + 0.5 * m2 * b**2
    mu = m1 * m2 / (m1 + m2)
    assert k0 - k1 == pytest.approx(
        0.5 * (1 - e**2) * mu * (v1 - v2) ** 2, rel=1e-9, abs=1e-12 * k0 + 1e-300
    )  # + 1e-300: energies in the subnormal range (v ~ 1e-159) have few significant bits


@settings(max_examples=100, deadline=None)
@given(masses, speeds, masses, speeds)
def test_elastic_conserves_energy(m1, v1, m2, v2):
    a, b = mech.elastic_collision_1d(m1, v1, m2, v2)
    k0 = m1 * v1**2 + m2 * v2**2
    assert m1 * a**2 + m2 * b**2 == pytest.approx(k0, rel=1e-12, abs=1e-300)


def test_perfectly_inelastic_and_explosive():
    v = mech.perfectly_inelastic_collision_1d(2.0, 3.0, 1.0, 0.0)
    assert v == pytest.approx(2.0)
    # explosion from rest: Q shared inversely to mass, momentum zero
    a, b = mech.explosive_separation_1d(1.0, 0.0, 3.0, 0.0, 6.0)
    assert 1.0 * a + 3.0 * b == pytest.approx(0.0, abs=1e-15)
    assert 0.5 * a**2 + 1.5 * b**2 == pytest.approx(6.0, rel=1e-14)
    assert b > 0 > a
    # restitution above 1 needs explosive=True
    with pytest.raises(DomainError, match="explosive=True"):
        mech.inelastic_collision_1d(1, 1, 1, 0, 1.5)
    a, b = mech.inelastic_collision_1d(1, 1, 1, 0, 1.5, explosive=True)
    assert b - a == pytest.approx(1.5)


def test_collision_input_errors():
    with pytest.raises(DomainError, match="> 0"):
        mech.elastic_collision_1d(-1.0, 1.0, 1.0, 0.0)
    with pytest.raises(InvalidInputError, match="NaN"):
        mech.elastic_collision_1d(1.0, np.nan, 1.0, 0.0)
    with pytest.raises(DomainError):
        mech.inelastic_collision_1d(1, 1, 1, 0, -0.1)
    with pytest.raises(InvalidStateError, match="coincide"):
        mech.collision_impulse(1, 1, [0, 0, 0], [0, 0, 0], [1, 0, 0], [0, 0, 0], 1)
    with pytest.raises(ShapeError):
        mech.collision_impulse(1, 1, [0, 0], [1, 0], [1, 0], [0, 0], 1)


def test_collision_impulse_head_on_and_oblique():
    J, a, b = mech.collision_impulse(1.0, 1.0, [0, 0, 0], [1, 0, 0], [1, 0, 0], [0, 0, 0], 1.0)
    np.testing.assert_allclose(J, [1, 0, 0])
    np.testing.assert_allclose(a, [0, 0, 0], atol=1e-16)
    np.testing.assert_allclose(b, [1, 0, 0])
    # billiards: equal masses at 45 degrees leave at right angles
    n = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    J, a, b = mech.collision_impulse(1.0, 1.0, [0, 0, 0], n, [1, 0, 0], [0, 0, 0], 1.0)
    assert np.dot(a, b) == pytest.approx(0.0, abs=1e-15)
    np.testing.assert_allclose(b, [0.5, 0.5, 0.0], rtol=1e-15)
    # separating bodies exchange nothing
    J, a, b = mech.collision_impulse(1.0, 1.0, [0, 0, 0], [1, 0, 0], [-1, 0, 0], [0, 0, 0], 1.0)
    np.testing.assert_array_equal(J, 0.0)


def test_collision_impulse_units_and_broadcast():
    J, a, b = mech.collision_impulse(
        [1.0, 2.0] * u.kg,
        3.0 * u.kg,
        [[0, 0, 0]] * 2 * u.m,
        [[1, 0, 0], [0, 2, 0]] * u.m,
        [[1, 0, 0], [0, 1, 0]] * u.m / u.s,
        [0, 0, 0] * u.km / u.s,
        0.5,
    )
    assert J.unit == u.N * u.s and a.unit == u.m / u.s
    assert J.shape == (2, 3)
    np.testing.assert_allclose(J.value[1], [0, 1.5 * 2 * 3 / 5, 0])


vec = st.lists(st.floats(-100, 100), min_size=3, max_size=3)


@settings(max_examples=150, deadline=None)
@given(masses, masses, vec, vec, vec, st.floats(0, 1))
def test_collision_impulse_properties(m1, m2, d, v1, v2, e):
    d = np.array(d)
    if np.linalg.norm(d) < 1e-6:
        d = np.array([1.0, 0.0, 0.0])
    v1, v2 = np.array(v1), np.array(v2)
    J, a, b = mech.collision_impulse(m1, m2, np.zeros(3), d, v1, v2, e)
    p0 = m1 * v1 + m2 * v2
    scale = m1 * np.abs(v1) + m2 * np.abs(v2) + 1e-12
    assert np.all(np.abs(m1 * a + m2 * b - p0) <= 1e-13 * scale.max())
    n = d / np.linalg.norm(d)
    un0 = np.dot(v1 - v2, n)
    un1 = np.dot(a - b, n)
    tol = 1e-9 * (np.abs(v1).max() + np.abs(v2).max() + 1)
    if un0 > 0:
        assert un1 == pytest.approx(-e * un0, abs=tol)
    # tangential relative velocity unchanged
    t0 = (v1 - v2) - un0 * n
    t1 = (a - b) - un1 * n
    np.testing.assert_allclose(t1, t0, atol=tol)
    k0 = 0.5 * m1 * v1 @ v1 + 0.5 * m2 * v2 @ v2
    k1 = 0.5 * m1 * a @ a + 0.5 * m2 * b @ b
    assert k1 <= k0 * (1 + 1e-12) + 1e-12


def test_kinetic_energy():
    assert mech.kinetic_energy(2.0, [3.0, 4.0, 0.0]) == pytest.approx(25.0)
    np.testing.assert_allclose(mech.kinetic_energy([1.0, 2.0], [1.0, 1.0]), [0.5, 1.0])


def test_kinetic_energy_mismatched_masses_is_a_shape_error():
    # audit26: 3 masses against 2 velocity vectors raised a bare numpy ValueError
    with pytest.raises(ShapeError, match="kinetic_energy"):
        mech.kinetic_energy([2.0, 1.0, 1.0], [[3.0, 4.0, 0.0], [1.0, 1.0, 1.0]])
    np.testing.assert_allclose(mech.kinetic_energy([2.0, 1.0], [[3.0, 4.0, 0.0], [1.0, 1.0, 1.0]]),
                               [25.0, 1.5])


def test_kinetic_energy_of_one_mass_with_many_velocity_vectors():
    # audit26: m = 2 with v of shape (2, 3) returned the per-component array
    # [[9, 16, 0], [1, 1, 1]] instead of the energies [25, 3]
    np.testing.assert_allclose(mech.kinetic_energy(2.0, [[3.0, 4.0, 0.0], [1.0, 1.0, 1.0]]),
                               [25.0, 3.0])
    assert mech.kinetic_energy(2.0, [3.0, 4.0, 0.0]) == 25.0
    np.testing.assert_allclose(mech.kinetic_energy([2.0, 1.0], [3.0, 4.0]), [9.0, 8.0])
    np.testing.assert_allclose(mech.kinetic_energy([2.0, 1.0], np.ones((5, 2, 3))),
                               np.tile([3.0, 1.5], (5, 1)))
