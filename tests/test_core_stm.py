"""The two-body state-transition matrix kernel (visviva.core.stm) on every conic.

References: finite differences of the universal-variable propagator
(:func:`visviva.core.universal.propagate_one`, itself checked against mpmath in
test_core_universal.py); the STM of a Hamiltonian flow is symplectic.
"""

import numpy as np
import pytest

from visviva.core.stm import two_body_stm
from visviva.core.universal import propagate_one

MU = 398600.4418  # km^3/s^2
R_P = 7000.0  # km
V_ESC = np.sqrt(2 * MU / R_P)


def _start(v_factor, back):
    """The state ``back`` seconds before periapsis (7000 km) of the conic with periapsis speed
    ``v_factor`` times the escape speed."""
    r, v = np.empty(3), np.empty(3)
    propagate_one(np.array([R_P, 0.0, 0.0]), np.array([0.0, v_factor * V_ESC, 0.0]), MU,
                  -back, r, v)
    return r, v


def _finite_differences(r0, v0, dt):
    x0 = np.r_[r0, v0]
    ro, vo = np.empty(3), np.empty(3)
    fd = np.empty((6, 6))
    for k in range(6):
        h = 1e-7 * (np.linalg.norm(r0) if k < 3 else np.linalg.norm(v0))
        cols = []
        for sgn in (1, -1):
            x = x0.copy()
            x[k] += sgn * h
            propagate_one(x[:3].copy(), x[3:].copy(), MU, dt, ro, vo)
            cols.append(np.r_[ro, vo])
        fd[:, k] = (cols[0] - cols[1]) / (2 * h)
    return fd


@pytest.mark.parametrize(
    "v_factor, back",
    [(1.2, 5e4), (2.0, 5e4), (1.0, 1e6), (np.sqrt(1 - 1e-4), 1e5)],
    ids=["hyperbola-1.2", "hyperbola-2", "parabola", "ellipse-e-0.9999"],
)
def test_stm_through_periapsis_from_far_out(v_factor, back):
    """An arc that starts far out, passes periapsis and leaves again (audit47: the Runge-Kutta
    step was fixed from the initial radius, so the periapsis passage got a handful of steps:
    the STM was 0.3 % (hyperbola) to 10^3 (parabola) relative wrong and the state 120 km to
    5e6 km off, silently; now ~1e-11 against mpmath, <1e-6 against these finite differences)."""
    r0, v0 = _start(v_factor, back)
    dt = 2 * back
    phi = np.empty((6, 6))
    r1, v1, status = two_body_stm(r0, v0, MU, dt, phi)
    assert status == 0
    ro, vo = np.empty(3), np.empty(3)
    propagate_one(r0, v0, MU, dt, ro, vo)
    assert np.linalg.norm(r1 - ro) < 1e-5 * np.linalg.norm(ro)  # km-level before
    fd = _finite_differences(r0, v0, dt)
    assert np.abs(phi - fd).max() < 1e-6 * np.abs(fd).max()
    j = np.block([[np.zeros((3, 3)), np.eye(3)], [-np.eye(3), np.zeros((3, 3))]])
    scale = np.abs(phi).max() ** 2
    assert np.abs(phi.T @ j @ phi - j).max() < 1e-8 * scale


def test_stm_backwards_is_the_inverse():
    r0, v0 = _start(1.5, 2e4)
    fwd, back = np.empty((6, 6)), np.empty((6, 6))
    r1, v1, s1 = two_body_stm(r0, v0, MU, 4e4, fwd)
    _, _, s2 = two_body_stm(r1, v1, MU, -4e4, back)
    assert s1 == s2 == 0
    assert np.abs(back @ fwd - np.eye(6)).max() < 1e-8 * np.abs(fwd).max()


def test_stm_refuses_a_fall_into_the_centre_and_bad_gm():
    """A radial fall reaching r = 0 within dt (status 9, was a silent garbage matrix), gm <= 0 or
    NaN (6, 4: gm was not checked)."""
    phi = np.empty((6, 6))
    r0, v0 = np.array([R_P, 0.0, 0.0]), np.array([0.1, 0.0, 0.0])
    assert two_body_stm(r0, v0, MU, 5000.0, phi)[2] == 9  # falls in after ~1100 s
    assert two_body_stm(r0, v0, MU, 500.0, phi)[2] == 0
    v0 = np.array([0.0, 7.5, 0.0])
    assert two_body_stm(r0, v0, -MU, 60.0, phi)[2] == 6
    assert two_body_stm(r0, v0, np.nan, 60.0, phi)[2] == 4
    assert two_body_stm(r0, v0, MU, np.inf, phi)[2] == 4


def test_public_state_transition_matrix_of_a_flyby_and_a_fall():
    """The public wrapper: a hyperbolic flyby from 5e4 s before periapsis to 5e4 s after (the
    STM was 0.3 % off, the state 123 km off, audit47), and a radial fall refused by name."""
    import astropy.units as u

    import visviva as vv
    from visviva.conjunctions import state_transition_matrix

    r0, v0 = _start(1.2, 5e4)
    phi, r1, v1 = state_transition_matrix(r0 * u.km, v0 * u.km / u.s, 1e5 * u.s,
                                          MU * u.km**3 / u.s**2)
    ro, vo = np.empty(3), np.empty(3)
    propagate_one(r0, v0, MU, 1e5, ro, vo)
    assert np.linalg.norm(r1 - ro) < 1e-6 * np.linalg.norm(ro)
    fd = _finite_differences(r0, v0, 1e5)
    assert np.abs(phi - fd).max() < 1e-6 * np.abs(fd).max()
    with pytest.raises(vv.InvalidStateError, match="collision"):
        state_transition_matrix([R_P, 0, 0] * u.km, [0.1, 0, 0] * u.km / u.s, 5000 * u.s,
                                vv.EARTH)


def test_a_span_of_tens_of_thousands_of_revolutions_is_refused_at_once():
    """10 years of LEO (~58 000 revolutions, ~2e8 steps) is refused before stepping, with a
    message saying why; 1000 revolutions (3.3e6 steps) still run."""
    import time

    import astropy.units as u

    import visviva as vv
    from visviva.conjunctions import state_transition_matrix

    r0 = [R_P, 0, 0] * u.km
    v0 = [0, 7.546, 0.1] * u.km / u.s
    start = time.perf_counter()
    with pytest.raises(vv.InvalidInputError, match="10\\^8 integration steps"):
        state_transition_matrix(r0, v0, 3650 * u.day, vv.EARTH)
    assert time.perf_counter() - start < 1.0
    phi = np.empty((6, 6))
    assert two_body_stm(r0.value, v0.value, MU, 1000 * 5828.5, phi)[2] == 0
