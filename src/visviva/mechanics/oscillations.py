"""Oscillations: simple harmonic motion, the damped and the driven oscillator, normal modes, beats.

All functions take plain numbers in consistent units or astropy Quantities (converted to SI);
with any Quantity input, results come back as SI Quantities.
"""

from __future__ import annotations

import math

import numpy as np

from .._units import broadcast_or_raise
from ..errors import DomainError, InvalidInputError, ShapeError
from ._inputs import Inputs, square_matrix

__all__ = [
    "simple_harmonic",
    "damped_oscillator",
    "damped_oscillator_velocity",
    "damping_regime",
    "driven_response",
    "driven_oscillator",
    "amplitude_resonance_frequency",
    "normal_modes",
    "chain_matrices",
    "beats",
]


def simple_harmonic(x0, v0, omega0, t):
    """Simple harmonic motion x(t) = x0 cos(w0 t) + (v0 / w0) sin(w0 t).

    Parameters
    ----------
    x0 : float, array_like or Quantity
        Initial displacement [m].
    v0 : float, array_like or Quantity
        Initial velocity [m/s].
    omega0 : float, array_like or Quantity
        Angular frequency [rad/s or 1/s], >= 0 (0 gives free motion x0 + v0 t).
    t : float, array_like or Quantity
        Times [s]; everything broadcasts.

    Returns
    -------
    x : ndarray or Quantity
        Displacement [m].

    Notes
    -----
    The solution of x'' + w0^2 x = 0 (Taylor, *Classical Mechanics*, 2005, sec. 5.2). It is
    :func:`damped_oscillator` with gamma = 0.
    """
    return damped_oscillator(x0, v0, omega0, 0.0, t)


# The even and odd entire functions C(s) = cos(sqrt(s)) and S(s) = sin(sqrt(s))/sqrt(s) of
# s = (omega0^2 - gamma^2) t^2, which are cosh/sinh for s < 0: one formula for all three regimes.
_C_SERIES = [(-1.0) ** k / math.factorial(2 * k) for k in range(12)]
_S_SERIES = [(-1.0) ** k / math.factorial(2 * k + 1) for k in range(12)]


def _series(coeffs, s):
    out = np.zeros_like(s)
    for c in reversed(coeffs):
        out = out * s + c
    return out


def _propagator(omega0, gamma, t):
    """e^{-gamma t} C and e^{-gamma t} S t for x'' + 2 gamma x' + w0^2 x = 0 (broadcast arrays).

    x(t) = x0 * c + (v0 + gamma x0) * s,   with c = e^{-g t} C(s), s = e^{-g t} t S(s).
    """
    with np.errstate(over="ignore", invalid="ignore"):
        c, s, wd2 = _propagator_raw(omega0, gamma, t)
    if not (np.all(np.isfinite(c)) and np.all(np.isfinite(s))):
        raise DomainError(
            "the oscillator's solution overflows float64 at these times (e^{-gamma t} beyond "
            "1e308, reachable only for t < 0 with damping, or inputs of extreme magnitude): "
            "integrate over a shorter time span or rescale the inputs."
        )
    return c, s, wd2


def _propagator_raw(omega0, gamma, t):
    omega0, gamma, t = np.broadcast_arrays(omega0, gamma, t)
    # w_d^2 = (w0 - g)(w0 + g): no cancellation as gamma -> omega0. |w_d| is formed as
    # sqrt|w0 - g| sqrt(w0 + g) and z2 = +-(|w_d| t)^2, so huge omega0 or gamma do not overflow
    wd2 = (omega0 - gamma) * (omega0 + gamma)
    root = np.sqrt(np.abs(omega0 - gamma)) * np.sqrt(omega0 + gamma)
    z2 = np.copysign((root * t) ** 2, omega0 - gamma)
    c = np.empty(z2.shape)
    s = np.empty(z2.shape)
    small = np.abs(z2) < 1.0
    under = (~small) & (z2 > 0)
    over = (~small) & (z2 < 0)
    damp = np.exp(-gamma[small] * t[small])
    c[small] = damp * _series(_C_SERIES, z2[small])
    s[small] = damp * t[small] * _series(_S_SERIES, z2[small])
    if np.any(under):
        wd = root[under]
        tu = t[under]
        damp = np.exp(-gamma[under] * tu)
        c[under] = damp * np.cos(wd * tu)
        s[under] = damp * np.sin(wd * tu) / wd
    if np.any(over):
        # e^{-g t} cosh(w t) = (e^{-(g-w) t} + e^{-(g+w) t}) / 2, with g - w = w0^2 / (g + w):
        # no overflow for large t and no cancellation for g >> w0.
        w = root[over]
        to = t[over]
        g = gamma[over]
        slow = np.exp(-(omega0[over] * (omega0[over] / (g + w))) * to)
        fast = np.exp(-(g + w) * to)
        c[over] = 0.5 * (slow + fast)
        s[over] = 0.5 * (slow - fast) / w
    return c, s, wd2


def _rates(ins, omega0, gamma):
    """The natural angular frequency and the damping rate [1/s], both >= 0, through ``ins``.

    Parameters
    ----------
    ins : Inputs
        The call's collector of converted arguments.
    omega0, gamma : float, array_like or Quantity
        omega0 [rad/s or 1/s] and gamma [1/s] of x'' + 2 gamma x' + omega0^2 x = 0.

    Returns
    -------
    omega0, gamma : ndarray
        In 1/s.
    """
    omega0 = ins.get(omega0, "angular_rate", "omega0", nonnegative=True)
    return omega0, ins.get(gamma, "rate", "gamma", nonnegative=True)


def _initial_state(ins, x0, v0):
    """Initial displacement [m] and velocity [m/s] of an oscillator, converted through ``ins``."""
    return ins.get(x0, "m", "x0"), ins.get(v0, "speed", "v0")


def _oscillator_inputs(x0, v0, omega0, gamma, t):
    ins = Inputs()
    x0, v0 = _initial_state(ins, x0, v0)
    omega0, gamma = _rates(ins, omega0, gamma)
    t = ins.get(t, "s", "t")
    ins.broadcast("damped oscillator", x0=x0, v0=v0, omega0=omega0, gamma=gamma, t=t)
    return ins, x0, v0, omega0, gamma, t


def damped_oscillator(x0, v0, omega0, gamma, t):
    """Displacement of the damped oscillator x'' + 2 gamma x' + omega0^2 x = 0.

    Parameters
    ----------
    x0 : float, array_like or Quantity
        Displacement at t = 0 [m].
    v0 : float, array_like or Quantity
        Velocity at t = 0 [m/s].
    omega0 : float, array_like or Quantity
        Undamped angular frequency [1/s], >= 0.
    gamma : float, array_like or Quantity
        Damping rate [1/s], >= 0 (the force per mass is -2 gamma x').
    t : float, array_like or Quantity
        Times [s]; all arguments broadcast together.

    Returns
    -------
    x : ndarray or Quantity
        Displacement x(t) [m], with x(0) = x0 and x'(0) = v0 exactly.

    Raises
    ------
    DomainError
        Negative omega0 or gamma.
    InvalidInputError
        NaN or infinite input.

    Notes
    -----
    With w_d^2 = omega0^2 - gamma^2 and s = w_d^2 t^2,

        x(t) = e^{-gamma t} [ x0 C(s) + (v0 + gamma x0) t S(s) ],
        C(s) = cos sqrt(s),   S(s) = sin(sqrt(s)) / sqrt(s),

    which is cos/sin for under-damping, cosh/sinh for over-damping (s < 0) and 1, t at critical
    damping (Taylor, *Classical Mechanics*, 2005, sec. 5.4). C and S are entire functions of s,
    evaluated by their Taylor series for abs(s) < 1, so the solution is smooth and accurate to
    rounding through critical damping; w_d^2 is formed as (omega0 - gamma)(omega0 + gamma) to
    avoid cancellation. Over-damped exponentials use gamma - w = omega0^2 / (gamma + w).

    Examples
    --------
    >>> x = damped_oscillator(1.0, 0.0, 2.0, 2.0, 1.0)   # critical: (1 + 2 t) e^{-2 t}
    >>> print(f"{x:.12f}")
    0.406005849710
    """
    ins, x0, v0, omega0, gamma, t = _oscillator_inputs(x0, v0, omega0, gamma, t)
    c, s, _ = _propagator(omega0, gamma, t)
    with np.errstate(over="ignore", invalid="ignore"):
        x = x0 * c + (v0 + gamma * x0) * s
    return ins.out(ins.finite(x, "damped_oscillator"), "m")


def damped_oscillator_velocity(x0, v0, omega0, gamma, t):
    """Velocity x'(t) of :func:`damped_oscillator` (same arguments) [m/s].

    Notes
    -----
    Differentiating the propagator form gives x'(t) = v0 c - (omega0^2 x0 + gamma v0) s with the
    same c, s as the displacement (the velocity obeys the same equation, with x'(0) = v0 and
    x''(0) = -2 gamma v0 - omega0^2 x0).
    """
    ins, x0, v0, omega0, gamma, t = _oscillator_inputs(x0, v0, omega0, gamma, t)
    c, s, _ = _propagator(omega0, gamma, t)
    with np.errstate(over="ignore", invalid="ignore"):
        v = v0 * c - (omega0 * (omega0 * x0) + gamma * v0) * s
    return ins.out(ins.finite(v, "damped_oscillator_velocity"), "speed")


def damping_regime(omega0, gamma) -> str:
    """``"undamped"``, ``"underdamped"``, ``"critical"`` or ``"overdamped"`` (scalars) [1/s].

    Raises :class:`~visviva.errors.ShapeError` for arrays (one regime per call: loop, or
    compare gamma with omega0 directly for arrays).
    """
    ins = Inputs()
    w0, g = _rates(ins, omega0, gamma)
    if w0.ndim or g.ndim:
        raise ShapeError(
            "damping_regime classifies one oscillator: omega0 and gamma must be scalars; got "
            f"shapes {w0.shape} and {g.shape}. Call it once per oscillator (or compare gamma "
            "with omega0 directly for arrays)."
        )
    w0, g = float(w0), float(g)
    if g == 0:
        return "undamped"
    if g < w0:
        return "underdamped"
    return "critical" if g == w0 else "overdamped"


def driven_response(omega, omega0, gamma, f0=1.0):
    """Steady-state amplitude and phase lag of x'' + 2 gamma x' + omega0^2 x = f0 cos(omega t).

    Parameters
    ----------
    omega : float, array_like or Quantity
        Driving angular frequency [1/s].
    omega0 : float, array_like or Quantity
        Natural angular frequency [1/s], >= 0.
    gamma : float, array_like or Quantity
        Damping rate [1/s], >= 0.
    f0 : float, array_like or Quantity
        Driving force per unit mass [m/s^2].

    Returns
    -------
    amplitude : ndarray or Quantity
        A = f0 / sqrt((omega0^2 - omega^2)^2 + 4 gamma^2 omega^2) [m].
    phase : ndarray
        Lag delta = atan2(2 gamma omega, omega0^2 - omega^2) in [0, pi] [rad] (pi more, in
        [pi, 2 pi], for f0 < 0, A staying positive); the steady motion is
        x = A cos(omega t - delta).

    Raises
    ------
    DomainError
        Undamped driving at resonance (infinite amplitude), or negative omega0/gamma.

    Notes
    -----
    Taylor, *Classical Mechanics* (2005), eqs. 5.64-5.65. The resonance curve is A(omega).
    """
    ins = Inputs()
    w = ins.get(omega, "angular_rate", "omega", nonnegative=True)
    w0, g = _rates(ins, omega0, gamma)
    f0 = ins.get(f0, "accel", "f0")
    detuning = (w0 - w) * (w0 + w)
    denom = np.hypot(detuning, 2.0 * g * w)
    if np.any(denom == 0):
        if np.any((denom == 0) & (np.broadcast_to(g, np.shape(denom)) > 0)):
            raise DomainError(
                "driven_response: omega = omega0 = 0 is a constant force on a free damped "
                "particle, which drifts at the terminal velocity f0 / (2 gamma): there is no "
                "bounded steady state. Use driven_oscillator for the motion."
            )
        raise DomainError(
            "driven_response: undamped oscillator driven exactly at resonance has no steady "
            "state (the amplitude grows linearly). Give gamma > 0 or omega != omega0."
        )
    amplitude = np.abs(f0) / denom
    phase = np.arctan2(2.0 * g * w, detuning) + np.where(f0 < 0, np.pi, 0.0)
    return ins.out(amplitude, "m"), np.asarray(phase)[()]


def amplitude_resonance_frequency(omega0, gamma):
    """Driving frequency of largest amplitude, sqrt(omega0^2 - 2 gamma^2) [1/s].

    Raises :class:`~visviva.errors.DomainError` when gamma >= omega0 / sqrt(2) (no peak: the
    amplitude falls monotonically from omega = 0).
    """
    ins = Inputs()
    w0, g = _rates(ins, omega0, gamma)
    arg = w0**2 - 2.0 * g**2
    if np.any(arg <= 0):
        raise DomainError(
            "amplitude_resonance_frequency: gamma >= omega0/sqrt(2) has no resonance peak; the "
            "amplitude is largest at omega = 0."
        )
    return ins.out(np.sqrt(arg), "rate")


def driven_oscillator(x0, v0, omega0, gamma, f0, omega, t):
    """Full motion of x'' + 2 gamma x' + omega0^2 x = f0 cos(omega t), from x0, v0 at t = 0.

    Parameters are those of :func:`damped_oscillator` plus ``f0`` [m/s^2] and the driving
    frequency ``omega`` [1/s]. Returns x(t) [m]. Every regime works, including undamped driving
    exactly at resonance (the amplitude then grows linearly, x = f0 t sin(omega0 t) / (2 omega0)
    from rest).

    Notes
    -----
    x = (free motion from x0, v0, :func:`damped_oscillator`) + f0 x_f(t), where x_f is the
    response from rest to cos(omega t) (Taylor 2005, sec. 5.5). With the roots lambda_1, lambda_2
    of z^2 + 2 gamma z + omega0^2 and lambda = i omega, the response from rest to e^{lambda t} is
    the divided difference of z -> e^{z t} at (lambda, lambda_1, lambda_2) (residues of the
    Laplace transform), evaluated as

        x_f = Re[(e[lambda, lambda_1] - e[lambda_1, lambda_2]) / (lambda - lambda_2)],

    with lambda_1 the root nearest lambda; e[lambda_1, lambda_2] is the propagator
    e^{-gamma t} sin(w_d t) / w_d of :func:`damped_oscillator` and e[lambda, lambda_1] uses expm1
    when (lambda - lambda_1) t is small. Near resonance this avoids the cancellation between the
    steady state A cos(omega t - delta), whose amplitude diverges, and the transient (which lost
    up to 12 digits at omega - omega0 = 1e-12 omega0). When all three nodes times t lie within
    the unit disc, the Taylor series sum_k h_k(lambda t, lambda_1 t, lambda_2 t) t^2 / (k + 2)!
    (h_k the complete homogeneous symmetric polynomials) is used instead.
    """
    ins = Inputs()
    x0, v0 = _initial_state(ins, x0, v0)
    w0, g = _rates(ins, omega0, gamma)
    f0 = ins.get(f0, "accel", "f0")
    w = ins.get(omega, "angular_rate", "omega", nonnegative=True)
    t = ins.get(t, "s", "t")
    _broadcast("driven_oscillator", x0=x0, v0=v0, omega0=w0, gamma=g, f0=f0, omega=w, t=t)
    c, s, _ = _propagator(w0, g, t)
    with np.errstate(over="ignore", invalid="ignore"):
        x = x0 * c + (v0 + g * x0) * s + f0 * _forced_from_rest(w0, g, w, t, s)
    if not np.all(np.isfinite(x)):
        raise DomainError(
            "driven_oscillator: the solution overflows float64 at these times (reachable only "
            "for t < 0 with damping, or for extreme f0): use a shorter time span."
        )
    return ins.out(x, "m")


_DD_TERMS = 30  # Taylor terms of the divided-difference series (all |node t| <= ~1.5)
_DD_FACT = [1.0 / math.factorial(k + 2) for k in range(_DD_TERMS)]


def _expm1_complex(z):
    """e^z - 1 for complex z without cancellation: expm1(x) cos y - 2 sin^2(y/2) + i e^x sin y."""
    x, y = z.real, z.imag
    return (np.expm1(x) * np.cos(y) - 2.0 * np.sin(0.5 * y) ** 2) + 1j * (np.exp(x) * np.sin(y))


def _cdiv(a, b):
    """a / b for complex arrays, scaled so that |b| near the underflow threshold stays exact."""
    scale = np.maximum(np.abs(b.real), np.abs(b.imag))
    scale = np.where(scale > 0, scale, 1.0)
    a = np.asarray(a, dtype=complex)
    b = np.asarray(b, dtype=complex)
    # scale the parts as reals: complex / real would be promoted to a complex division again
    a_n = (a.real / scale) + 1j * (a.imag / scale)
    b_n = (b.real / scale) + 1j * (b.imag / scale)
    return a_n / b_n


def _forced_from_rest(omega0, gamma, omega, t, s):
    """Response x_f(t) to cos(omega t) from x = x' = 0 (see :func:`driven_oscillator`).

    ``s`` is the propagator e[lambda_1, lambda_2] from :func:`_propagator` (same broadcast).
    """
    omega0, gamma, omega, t = np.broadcast_arrays(omega0, gamma, omega, t)
    wd2 = (omega0 - gamma) * (omega0 + gamma)
    under = wd2 >= 0
    root = np.sqrt(np.abs(wd2))  # w_d (under-damped) or w (over-damped)
    lam = 1j * omega
    # lambda_1: the root nearest i omega; lambda_2 the other one
    lam1 = np.where(under, -gamma + 1j * root, -omega0 * (omega0 / np.where(under, 1.0, gamma + root)))
    lam2 = np.where(under, -gamma - 1j * root, -(gamma + root) + 0j)
    z = (lam - lam1) * t
    small = np.abs(z) <= 1.0
    e_lam1 = np.exp(lam1 * t)
    with np.errstate(invalid="ignore", divide="ignore"):
        phi1 = np.where(z == 0, 1.0 + 0j, _cdiv(_expm1_complex(z), np.where(z == 0, 1.0, z)))
        direct = _cdiv(np.exp(lam * t) - e_lam1, np.where(small, 1.0, lam - lam1))
    dd1 = np.where(small, e_lam1 * t * phi1, direct)
    d2 = lam - lam2
    with np.errstate(invalid="ignore", divide="ignore"):
        pair = _cdiv(dd1 - s, np.where(d2 == 0, 1.0, d2))
    series_mask = np.abs(d2 * t) < 1.0
    out = pair
    if np.any(series_mask):
        a, b, cc, tt = (x[series_mask] for x in (lam * t, lam1 * t, lam2 * t, t))
        ha = np.ones_like(a)
        hab = np.ones_like(a)
        habc = np.ones_like(a)
        total = habc * _DD_FACT[0]
        for k in range(1, _DD_TERMS):
            ha = ha * a
            hab = ha + b * hab
            habc = hab + cc * habc
            total = total + habc * _DD_FACT[k]
        out = np.array(pair, copy=True)
        out[series_mask] = total * tt * tt
    return np.real(out)


_broadcast = broadcast_or_raise  # ShapeError unless the arguments broadcast together


def normal_modes(M, K):
    """Normal modes of M q'' + K q = 0: angular frequencies and M-orthonormal mode shapes.

    Parameters
    ----------
    M : (n, n) array_like or Quantity
        Symmetric positive-definite mass matrix [kg] (any consistent units); a 1-D array of n
        masses stands for the diagonal matrix.
    K : (n, n) array_like or Quantity
        Symmetric positive-semidefinite stiffness matrix [N/m].

    Returns
    -------
    omega : (n,) ndarray or Quantity
        Angular frequencies, ascending [1/s]; zero modes (free translation) give exactly 0
        (an eigenvalue omega^2 within 8 n eps max(omega^2) of zero, eigh's rounding, is taken
        as 0: frequencies below ~1e-7 max(omega) cannot be resolved from rounding anyway).
    modes : (n, n) ndarray
        Mode shapes as columns, normalised so that ``modes.T @ M @ modes = I`` (and
        ``modes.T @ K @ modes = diag(omega**2)``); the largest-magnitude entry of each column is
        positive, so the result is deterministic. Units kg^-1/2 when M is in kg.

    Raises
    ------
    ShapeError
        M and K not square or of different sizes.
    InvalidInputError
        Non-symmetric matrices, NaN, or M not positive definite.
    DomainError
        K with a clearly negative eigenvalue (an unstable equilibrium, imaginary frequency).

    Notes
    -----
    Solves the generalised symmetric eigenproblem K a = omega^2 M a with
    :func:`scipy.linalg.eigh` (Cholesky reduction), which keeps the symmetry that
    ``eig(inv(M) @ K)`` loses (Goldstein, Poole & Safko, *Classical Mechanics*, 3rd ed., sec. 6.2).

    Examples
    --------
    >>> omega, modes = normal_modes([[1.0, 0.0], [0.0, 1.0]], [[2.0, -1.0], [-1.0, 2.0]])
    >>> print(f"{omega[0]:.6f} {omega[1]:.6f}")
    1.000000 1.732051
    """
    from scipy import linalg

    ins = Inputs()
    if np.ndim(M) == 1:  # a vector of masses: the diagonal mass matrix
        M = ins.get(M, "kg", "M")
        M = np.diag(M)
    M = square_matrix(M, "M", ins, "kg")
    K = square_matrix(K, "K", ins, "stiffness")
    if M.shape != K.shape:
        raise ShapeError(f"M and K must have the same shape; got {M.shape} and {K.shape}.")
    try:
        lam, modes = linalg.eigh(K, M)
    except linalg.LinAlgError as exc:
        raise InvalidInputError(
            "normal_modes: the mass matrix M is not positive definite; every mass (and every "
            "kinetic-energy quadratic form) must be positive."
        ) from exc
    scale = max(np.max(np.abs(lam)), np.finfo(float).tiny)
    if np.any(lam < -1e-10 * scale):
        raise DomainError(
            f"normal_modes: K has a negative generalised eigenvalue ({lam.min():.6g}): the "
            "equilibrium is unstable (imaginary frequency). Check the sign of K (the potential "
            "energy is q.T K q / 2, K must be positive semidefinite)."
        )
    # an eigenvalue within eigh's rounding of zero (|error| ~ n eps max|lam|) is a zero mode
    # (free translation or rotation): return exactly 0, not the square root of the rounding
    # noise (~1e-8 max(omega) for a free chain)
    lam = np.where(lam <= 8.0 * lam.size * np.finfo(float).eps * scale, 0.0, lam)
    order = np.argsort(lam, kind="stable")
    lam, modes = lam[order], modes[:, order]
    pivot = modes[np.argmax(np.abs(modes), axis=0), np.arange(modes.shape[1])]
    modes = modes * np.where(pivot < 0, -1.0, 1.0)
    return ins.out(np.sqrt(lam), "rate"), modes


def chain_matrices(masses, springs):
    """Mass and stiffness matrices of a chain of masses joined by springs, walls at both ends.

    Parameters
    ----------
    masses : (n,) array_like
        The masses, left to right [kg].
    springs : (n + 1,) array_like
        Spring constants [N/m]: wall-m1, m1-m2, ..., mn-wall. A zero end spring makes that end
        free.

    Returns
    -------
    M, K : (n, n) ndarray or Quantity
        ``diag(masses)`` [kg] and the tridiagonal stiffness matrix [N/m], for
        :func:`normal_modes` (SI Quantities when any input was a Quantity).
    """
    ins = Inputs()
    m = np.atleast_1d(ins.get(masses, "kg", "masses", positive=True))
    k = np.atleast_1d(ins.get(springs, "stiffness", "springs", nonnegative=True))
    if m.ndim != 1 or k.shape != (m.size + 1,):
        raise ShapeError(
            f"springs must have one more entry than masses (n + 1 = {m.size + 1}); got "
            f"{k.shape}. Include the wall springs at both ends (0 for a free end)."
        )
    K = np.diag(k[:-1] + k[1:]) - np.diag(k[1:-1], 1) - np.diag(k[1:-1], -1)
    # Quantities in: SI Quantities out, like every mechanics function (normal_modes then
    # returns omega in 1/s as a Quantity too)
    return ins.out(np.diag(m), "kg"), ins.out(K, "stiffness")


def beats(amplitude, omega1, omega2, t):
    """Superposition of two equal-amplitude oscillations and its beat envelope.

    Returns ``(x, envelope)`` with x = a cos(w1 t) + a cos(w2 t)
    = 2 a cos((w1 - w2) t / 2) cos((w1 + w2) t / 2) and envelope = 2 a abs(cos((w1 - w2) t / 2)) [m].
    The beat period is 2 pi / abs(w1 - w2) (Taylor 2005, problem 5.x; French, *Vibrations and Waves*).
    """
    ins = Inputs()
    a = ins.get(amplitude, "m", "amplitude")
    w1 = ins.get(omega1, "angular_rate", "omega1")
    w2 = ins.get(omega2, "angular_rate", "omega2")
    t = ins.get(t, "s", "t")
    ins.broadcast("beats", amplitude=a, omega1=w1, omega2=w2, t=t)
    slow = np.cos(0.5 * (w1 - w2) * t)
    x = 2.0 * a * slow * np.cos(0.5 * (w1 + w2) * t)
    return ins.out(x, "m"), ins.out(2.0 * np.abs(a) * np.abs(slow), "m")
