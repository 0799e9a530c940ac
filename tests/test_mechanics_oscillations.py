"""Oscillations: exact solutions, all damping regimes, resonance, normal modes, beats."""

import numpy as np
import pytest
from astropy import units as u
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import linalg
from scipy.integrate import solve_ivp

from visviva import mechanics as mech
from visviva.errors import DomainError, InvalidInputError, ShapeError, UnitsError


def _integrate(omega0, gamma, x0, v0, t, f0=0.0, omega=0.0):
    def rhs(time, y):
        return [y[1], f0 * np.cos(omega * time) - 2 * gamma * y[1] - omega0**2 * y[0]]

    sol = solve_ivp(rhs, (0, t[-1]), [x0, v0], t_eval=t, method="DOP853", rtol=1e-12, atol=1e-12)
    return sol.y[0]


@pytest.mark.parametrize("gamma", [0.0, 0.3, 1.999, 2.0, 2.001, 5.0, 40.0])
def test_damped_oscillator_matches_integration_in_every_regime(gamma):
    t = np.linspace(0, 6, 61)
    x = mech.damped_oscillator(0.7, -1.3, 2.0, gamma, t)
    np.testing.assert_allclose(x, _integrate(2.0, gamma, 0.7, -1.3, t), atol=1e-9)


@pytest.mark.parametrize("gamma", [0.0, 0.5, 2.0, 3.0, 1e5])
def test_damped_oscillator_initial_conditions_exact(gamma):
    assert mech.damped_oscillator(0.7, -1.3, 2.0, gamma, 0.0) == 0.7
    assert mech.damped_oscillator_velocity(0.7, -1.3, 2.0, gamma, 0.0) == -1.3
    # the velocity is the derivative of the displacement
    h = 1e-6
    t = 0.37
    num = (
        mech.damped_oscillator(0.7, -1.3, 2.0, gamma, t + h)
        - mech.damped_oscillator(0.7, -1.3, 2.0, gamma, t - h)
    ) / (2 * h)
    if gamma < 100:
        assert mech.damped_oscillator_velocity(0.7, -1.3, 2.0, gamma, t) == pytest.approx(
            num, rel=1e-7, abs=1e-9
        )


def test_critical_damping_closed_form_and_continuity():
    t = np.linspace(0, 10, 101)
    w0 = 2.0
    exact = (1.0 + (0.5 + w0) * t) * np.exp(-w0 * t)
    np.testing.assert_allclose(
        mech.damped_oscillator(1.0, 0.5, w0, w0, t), exact, rtol=1e-14, atol=1e-300
    )
    for eps in (1e-4, 1e-8, 1e-12, 1e-15):
        for g in (w0 * (1 - eps), w0 * (1 + eps)):
            x = mech.damped_oscillator(1.0, 0.5, w0, g, t)
            # difference from critical is O(eps) smooth, never a cancellation blow-up
            assert np.max(np.abs(x - exact)) < 10 * eps + 1e-15


def test_overdamped_no_overflow_and_slow_decay():
    t = np.array([0.0, 1e3, 1e5])
    x = mech.damped_oscillator(1.0, 0.0, 1.0, 1e3, t)
    assert np.all(np.isfinite(x))
    # slow root ~ omega0^2 / (2 gamma): x ~ exp(-t / 2000)
    assert x[1] == pytest.approx(np.exp(-1e3 * (1 / (1e3 + np.sqrt(1e6 - 1)))), rel=1e-6)


def test_simple_harmonic_and_units():
    t = np.linspace(0, 3, 7)
    np.testing.assert_allclose(
        mech.simple_harmonic(1.0, 2.0, 3.0, t),
        np.cos(3 * t) + 2 / 3 * np.sin(3 * t),
        rtol=1e-14,
        atol=1e-15,
    )
    x = mech.damped_oscillator(10 * u.cm, 0 * u.m / u.s, 2 / u.s, 0.1 / u.s, 1 * u.s)
    assert x.unit == u.m
    assert x.value == pytest.approx(mech.damped_oscillator(0.1, 0.0, 2.0, 0.1, 1.0))
    with pytest.raises(UnitsError):
        mech.damped_oscillator(1 * u.kg, 0, 1, 0.1, 1)
    # angular frequencies in rad/s are accepted (radians are dimensionless)
    x = mech.damped_oscillator(1 * u.m, 0 * u.m / u.s, 2 * u.rad / u.s, 0.1 / u.s, 1 * u.min)
    assert x.value == pytest.approx(mech.damped_oscillator(1.0, 0.0, 2.0, 0.1, 60.0), abs=1e-15)


def test_damped_oscillator_bad_input():
    with pytest.raises(DomainError, match=">= 0"):
        mech.damped_oscillator(1, 0, 1, -0.1, 1)
    with pytest.raises(InvalidInputError, match="NaN"):
        mech.damped_oscillator(np.nan, 0, 1, 0.1, 1)
    assert mech.damping_regime(1, 0.5) == "underdamped"
    assert mech.damping_regime(1, 1) == "critical"
    assert mech.damping_regime(1, 2) == "overdamped"


def test_driven_oscillator_matches_integration_and_resonance_curve():
    t = np.linspace(0, 20, 201)
    x = mech.driven_oscillator(0.2, 0.0, 2.0, 0.15, 1.3, 1.7, t)
    np.testing.assert_allclose(x, _integrate(2.0, 0.15, 0.2, 0.0, t, 1.3, 1.7), atol=1e-9)
    # steady-state amplitude and phase by fitting the late motion
    w = np.linspace(0.5, 3.5, 7)
    A, delta = mech.driven_response(w, 2.0, 0.3, 1.0)
    for wi, Ai, di in zip(w, A, delta, strict=True):
        tt = np.linspace(60, 60 + 2 * np.pi / wi, 400)
        xi = _integrate(2.0, 0.3, 0.0, 0.0, np.concatenate([[0.0], tt]), 1.0, wi)[1:]
        design = np.column_stack([np.cos(wi * tt), np.sin(wi * tt)])
        a, b = np.linalg.lstsq(design, xi, rcond=None)[0]
        assert np.hypot(a, b) == pytest.approx(Ai, rel=1e-6)
        assert np.arctan2(b, a) == pytest.approx(di, abs=1e-6)
    wr = mech.amplitude_resonance_frequency(2.0, 0.3)
    grid = np.linspace(1.5, 2.5, 20001)
    assert grid[np.argmax(mech.driven_response(grid, 2.0, 0.3)[0])] == pytest.approx(wr, abs=1e-4)
    with pytest.raises(DomainError):
        mech.driven_response(2.0, 2.0, 0.0)


def test_normal_modes_two_masses_three_springs():
    m, k = 2.0, 3.0
    M, K = mech.chain_matrices([m, m], [k, k, k])
    omega, modes = mech.normal_modes(M, K)
    np.testing.assert_allclose(omega, [np.sqrt(k / m), np.sqrt(3 * k / m)], rtol=1e-14)
    np.testing.assert_allclose(modes.T @ M @ modes, np.eye(2), atol=1e-14)
    np.testing.assert_allclose(np.abs(modes), np.full((2, 2), 0.5), rtol=1e-14)


def test_normal_modes_uniform_chain_analytic():
    n, m, k = 12, 1.5, 4.0
    omega, modes = mech.normal_modes(*mech.chain_matrices(np.full(n, m), np.full(n + 1, k)))
    j = np.arange(1, n + 1)
    np.testing.assert_allclose(
        omega, 2 * np.sqrt(k / m) * np.sin(j * np.pi / (2 * (n + 1))), rtol=1e-12
    )


def test_normal_modes_free_chain_has_zero_mode_and_quantities():
    M, K = mech.chain_matrices([1.0, 2.0, 1.0], [0.0, 1.0, 1.0, 0.0])
    omega, modes = mech.normal_modes(M * u.kg, K * u.N / u.m)
    assert omega.unit == 1 / u.s
    assert omega[0].value == pytest.approx(0.0, abs=1e-7)
    np.testing.assert_allclose(omega[1:].value, [1.0, np.sqrt(2.0)], rtol=1e-12)


def test_normal_modes_errors():
    with pytest.raises(ShapeError):
        mech.normal_modes(np.eye(2), np.eye(3))
    with pytest.raises(InvalidInputError, match="symmetric"):
        mech.normal_modes(np.eye(2), [[1.0, 0.5], [0.0, 1.0]])
    with pytest.raises(InvalidInputError, match="positive definite"):
        mech.normal_modes(-np.eye(2), np.eye(2))
    with pytest.raises(DomainError, match="unstable"):
        mech.normal_modes(np.eye(2), -np.eye(2))


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 6), st.integers(0, 2**31 - 1))
def test_normal_modes_orthonormal_property(n, seed):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    M = A @ A.T + n * np.eye(n)
    B = rng.normal(size=(n, n))
    K = B @ B.T
    omega, modes = mech.normal_modes(M, K)
    assert np.all(np.diff(omega) >= 0)
    np.testing.assert_allclose(modes.T @ M @ modes, np.eye(n), atol=1e-10)
    np.testing.assert_allclose(
        modes.T @ K @ modes, np.diag(omega**2), atol=1e-9 * max(1, omega.max() ** 2)
    )


def test_beats_identity():
    t = np.linspace(0, 50, 1001)
    x, env = mech.beats(0.5, 10.0, 10.6, t)
    np.testing.assert_allclose(x, 0.5 * np.cos(10 * t) + 0.5 * np.cos(10.6 * t), atol=1e-13)
    assert np.all(np.abs(x) <= env + 1e-15)


def test_damped_oscillator_against_50_digit_reference():
    mp = pytest.importorskip("mpmath")
    mp.mp.dps = 50

    def exact(x0, v0, w0, g, t):
        x0, v0, w0, g, t = map(mp.mpf, (x0, v0, w0, g, t))
        wd2 = w0**2 - g**2
        if wd2 > 0:
            w = mp.sqrt(wd2)
            return mp.e ** (-g * t) * (x0 * mp.cos(w * t) + (v0 + g * x0) * mp.sin(w * t) / w)
        if wd2 < 0:
            w = mp.sqrt(-wd2)
            return mp.e ** (-g * t) * (x0 * mp.cosh(w * t) + (v0 + g * x0) * mp.sinh(w * t) / w)
        return mp.e ** (-g * t) * (x0 + (v0 + g * x0) * t)

    for g in (2 * (1 - 1e-3), 2 * (1 - 1e-8), 2.0, 2 * (1 + 1e-8), 2 * (1 + 1e-3), 0.5, 3.0):
        for t in (0.01, 0.3, 1.0, 2.7, 10.0):
            ref = float(exact(0.7, -1.3, 2.0, g, t))
            assert mech.damped_oscillator(0.7, -1.3, 2.0, g, t) == pytest.approx(ref, rel=1e-13)


@settings(max_examples=150, deadline=None)
@given(
    st.floats(-10, 10),
    st.floats(-10, 10),
    st.floats(0.01, 10),
    st.floats(0, 20),
    st.floats(0.0, 5.0),
)
def test_damped_oscillator_solves_its_equation_property(x0, v0, w0, g, t):
    x = mech.damped_oscillator(x0, v0, w0, g, t)
    v = mech.damped_oscillator_velocity(x0, v0, w0, g, t)
    h = 1e-5
    a = (
        mech.damped_oscillator_velocity(x0, v0, w0, g, t + h)
        - mech.damped_oscillator_velocity(x0, v0, w0, g, t - h)
    ) / (2 * h)
    xdot = (
        mech.damped_oscillator(x0, v0, w0, g, t + h) - mech.damped_oscillator(x0, v0, w0, g, t - h)
    ) / (2 * h)
    scale = (abs(x0) + abs(v0) + 1.0) * (1 + w0**2 + g**2)
    assert xdot == pytest.approx(v, abs=1e-6 * scale)
    assert a + 2 * g * v + w0**2 * x == pytest.approx(0.0, abs=1e-6 * scale)


def test_normal_modes_accepts_mass_vector():
    M, K = mech.chain_matrices([1.0, 2.0, 3.0], [1.0, 2.0, 3.0, 4.0])
    w1, m1 = mech.normal_modes(M, K)
    w2, m2 = mech.normal_modes([1.0, 2.0, 3.0], K)
    np.testing.assert_array_equal(w1, w2)
    np.testing.assert_array_equal(m1, m2)


def test_overflow_is_a_typed_error_not_inf():
    with pytest.raises(DomainError, match="overflows"):
        mech.damped_oscillator(1.0, 0.0, 1.0, 1000.0, -10.0)


@pytest.mark.parametrize(
    "masses, springs",
    [
        ([1.0, 2.0, 3.0], [0.0, 1.0, 1.0, 0.0]),
        ([1e-3, 5.0, 0.2, 40.0], [0.0, 7.0, 0.01, 300.0, 0.0]),
    ],
)
def test_normal_modes_free_chain_zero_mode_is_exactly_zero(masses, springs):
    # audit19: the translation mode came back as sqrt(rounding) ~ 5e-9 rad/s, not 0 as documented
    M, K = mech.chain_matrices(masses, springs)
    omega, modes = mech.normal_modes(M, K)
    assert omega[0] == 0.0
    assert np.all(omega[1:] > 0)
    # the zero mode is the rigid translation: all entries equal, M-normalised
    np.testing.assert_allclose(modes[:, 0], 1.0 / np.sqrt(np.sum(masses)), rtol=1e-10)
    lam = linalg.eigh(K, M, eigvals_only=True)
    np.testing.assert_allclose(omega[1:], np.sqrt(lam[1:]), rtol=1e-9)


def test_normal_modes_small_genuine_frequency_kept():
    # a soft spring far above rounding (omega ratio 1e-4) is not mistaken for a zero mode
    M, K = mech.chain_matrices([1.0, 1.0], [1e-8, 1.0, 1e-8])
    omega, _ = mech.normal_modes(M, K)
    np.testing.assert_allclose(omega, np.sqrt([1e-8, 2.0 + 1e-8]), rtol=1e-6)


def test_damping_regime_refuses_arrays_clearly():
    # audit19: arrays raised a bare TypeError ("only 0-dimensional arrays ...")
    with pytest.raises(ShapeError, match="one oscillator"):
        mech.damping_regime([1.0, 2.0], [1.0, 1.0])
    with pytest.raises(ShapeError, match="one oscillator"):
        mech.damping_regime(1.0, np.array([0.5]))
    assert mech.damping_regime(np.float64(2.0), 2.0 / u.s) == "critical"
    assert mech.damping_regime(2.0, 2.0 * (1 + 1e-15)) == "overdamped"


def test_angular_frequencies_refuse_hertz():
    # audit19: omega0 = 1 Hz was read as 1 rad/s (astropy: Hz = 1/s), 2 pi too slow, silently:
    # damped_oscillator(1 m, 0, 1 Hz, 0, 0.5 s) gave cos(0.5) = 0.878 m, not cos(pi) = -1 m
    with pytest.raises(UnitsError, match="angular frequency"):
        mech.damped_oscillator(1 * u.m, 0 * u.m / u.s, 1 * u.Hz, 0 / u.s, 0.5 * u.s)
    with pytest.raises(UnitsError, match="2 pi"):
        mech.driven_response(2 * u.kHz, 1.0 / u.s, 0.1 / u.s)
    with pytest.raises(UnitsError, match="omega1"):
        mech.beats(1.0 * u.m, 10 * u.Hz, 11 / u.s, 1 * u.s)
    with pytest.raises(UnitsError, match="omega3"):
        mech.torque_free_precession_rate(1.0, 2.0, 3 * u.Hz)
    # cycles per second and rad/s convert correctly: 1 cycle/s for 0.5 s is half a turn
    x = mech.damped_oscillator(1 * u.m, 0 * u.m / u.s, 1 * u.cycle / u.s, 0 / u.s, 0.5 * u.s)
    assert x.to_value(u.m) == pytest.approx(-1.0, abs=1e-15)
    x = mech.damped_oscillator(1 * u.m, 0 * u.m / u.s, np.pi * u.rad / u.s, 0 / u.s, 0.5 * u.s)
    assert x.to_value(u.m) == pytest.approx(0.0, abs=1e-15)
    # a damping rate is a rate, not an angle: gamma in Hz (= 1/s) stays accepted
    x = mech.damped_oscillator(1.0, 0.0, 2.0, 2.0 * u.Hz, 1.0)
    assert x.to_value(u.m) == pytest.approx(3.0 * np.exp(-2.0), rel=1e-14)


def test_driven_response_free_damped_particle_message():
    # audit19: omega = omega0 = 0 with gamma > 0 was reported as "undamped ... at resonance"
    with pytest.raises(DomainError, match="terminal velocity"):
        mech.driven_response(0.0, 0.0, 0.1)
    with pytest.raises(DomainError, match="undamped"):
        mech.driven_response([1.0, 2.0], 2.0, 0.0)
    # the motion itself: x'' + 2 gamma x' = f0 from rest drifts at f0 / (2 gamma)
    g, f0, t = 0.1, 1.0, 200.0
    x = mech.driven_oscillator(0.0, 0.0, 0.0, g, f0, 0.0, t)
    exact = f0 / (2 * g) * (t - (1 - np.exp(-2 * g * t)) / (2 * g))
    assert x == pytest.approx(exact, rel=1e-12)


def test_beats_shape_mismatch_is_a_shape_error():
    # audit26: a bare numpy ValueError from deep inside
    with pytest.raises(ShapeError, match="beats"):
        mech.beats(1.0, [1.0, 2.0], 3.0, [0.0, 1.0, 2.0])


def test_chain_matrices_keep_quantities():
    # audit26: Quantities in gave plain arrays out (the only mechanics function to drop them)
    M, K = mech.chain_matrices([2000.0, 2000.0] * u.g, [3.0, 3.0, 3.0] * u.N / u.cm)
    assert M.unit == u.kg and K.unit == u.N / u.m
    omega, _ = mech.normal_modes(M, K)
    np.testing.assert_allclose(omega.to_value(1 / u.s), [np.sqrt(300 / 2), np.sqrt(900 / 2)],
                               rtol=1e-14)
