"""Work and energy: conservative forces with their potentials, work along trajectories,
conservation diagnostics.

A conservative force object has ``potential(r)`` (energy, shape (...,)) and ``force(r)``
(shape (..., d)) with F = -grad V, and is itself a force callable ``obj(t, r, v)`` for
:func:`visviva.mechanics.solve_particles`. Plain numbers are in consistent units (SI in the
examples); Quantities are converted to SI.
"""

from __future__ import annotations

import functools

import numpy as np

from ..errors import InvalidInputError, InvalidStateError, ShapeError
from ._inputs import Inputs, callable_result

__all__ = [
    "UniformGravity",
    "Spring",
    "InverseSquare",
    "Coulomb",
    "InverseSquarePairs",
    "work",
    "cumulative_work",
    "work_along_curve",
    "conservation_report",
]

#: Coulomb constant 1 / (4 pi eps0) [N m^2 / C^2] (CODATA 2018 via eps0).
COULOMB_K = 8.9875517923e9


def _si_field(unit: str):
    """Decorate ``potential(r)``/``force(r)``: a Quantity r is converted to m, and the result is
    then an SI Quantity (``unit``: "energy" or "force").

    ``np.asarray`` stripped the unit: UniformGravity(1).potential([0, 0, 100] * u.cm) was 981 J.
    Plain arrays (the integrators' calls) pass straight through.
    """

    def decorate(method):
        @functools.wraps(method)
        def wrapped(self, r):
            if not hasattr(r, "unit"):
                return method(self, r)
            ins = Inputs()
            return ins.out(method(self, ins.get(r, "m", "r")), unit)

        return wrapped

    return decorate


class _Conservative:
    """Base: a force field F(r) = -grad V(r) usable as ``force(t, r, v)``."""

    def __call__(self, t, r, v):
        return self.force(r)

    def potential(self, r):  # pragma: no cover - abstract
        raise NotImplementedError

    def force(self, r):  # pragma: no cover - abstract
        raise NotImplementedError


class UniformGravity(_Conservative):
    """Uniform gravity on masses m: V = m g z (z = last coordinate), F = -m g e_z.

    Parameters
    ----------
    masses : float or (N,) array_like or Quantity
        Masses [kg] (scalar for one particle of shape (d,)).
    g : float or Quantity
        Gravitational acceleration [m/s^2] (9.80665 by default).
    """

    def __init__(self, masses, g=9.80665):
        ins = Inputs()
        self.masses = ins.get(masses, "kg", "masses", positive=True)
        self.g = float(ins.get(g, "accel", "g"))

    @_si_field("energy")
    def potential(self, r):
        r = np.asarray(r, dtype=float)
        return self.masses * self.g * r[..., -1]

    @_si_field("force")
    def force(self, r):
        r = np.asarray(r, dtype=float)
        F = np.zeros_like(r)
        F[..., -1] = -self.masses * self.g
        return F


class Spring(_Conservative):
    """Hooke spring from a fixed anchor: V = k (‖r - a‖ - L0)^2 / 2.

    Parameters
    ----------
    k : float or Quantity
        Spring constant [N/m], > 0.
    anchor : (d,) array_like or Quantity
        Fixed end [m] (origin by default, 3-D).
    rest_length : float or Quantity
        Natural length L0 [m], >= 0 (0: the linear spring F = -k (r - a)).
    """

    def __init__(self, k, anchor=(0.0, 0.0, 0.0), rest_length=0.0):
        ins = Inputs()
        self.k = float(ins.get(k, "stiffness", "k", positive=True))
        self.anchor = ins.vector(anchor, "m", "anchor", dim=None)
        self.rest_length = float(ins.get(rest_length, "m", "rest_length", nonnegative=True))

    @_si_field("energy")
    def potential(self, r):
        d = np.asarray(r, dtype=float) - self.anchor
        if self.rest_length == 0:
            return 0.5 * self.k * np.sum(d * d, axis=-1)
        return 0.5 * self.k * (np.linalg.norm(d, axis=-1) - self.rest_length) ** 2

    @_si_field("force")
    def force(self, r):
        d = np.asarray(r, dtype=float) - self.anchor
        if self.rest_length == 0:
            return -self.k * d
        dist = np.linalg.norm(d, axis=-1, keepdims=True)
        if np.any(dist == 0):
            raise InvalidStateError(
                "Spring.force: the particle sits on the anchor of a spring with a rest length, "
                "where the force direction is undefined. Move it off the anchor."
            )
        return -self.k * (dist - self.rest_length) * d / dist


class InverseSquare(_Conservative):
    """Inverse-square central force about a fixed centre: V = -k / r, F = -k r_hat / r^2.

    ``k > 0`` attracts (gravity: k = G M m), ``k < 0`` repels. Units: k [N m^2] = [J m].
    """

    def __init__(self, k, center=(0.0, 0.0, 0.0)):
        ins = Inputs()
        self.k = float(ins.get(k, "energy_length", "k"))
        self.center = ins.vector(center, "m", "center", dim=None)

    def _d(self, r):
        d = np.asarray(r, dtype=float) - self.center
        dist = np.linalg.norm(d, axis=-1, keepdims=True)
        if np.any(dist == 0):
            raise InvalidStateError(
                "the inverse-square force is singular at the centre (r = 0); keep the particle "
                "away from it or soften the potential."
            )
        return d, dist

    @_si_field("energy")
    def potential(self, r):
        d, dist = self._d(r)
        return -self.k / dist[..., 0]

    @_si_field("force")
    def force(self, r):
        d, dist = self._d(r)
        return -self.k * d / dist**3


class Coulomb(InverseSquare):
    """Coulomb force of a fixed charge Q on a charge q: V = k_e q Q / r (repulsive for qQ > 0).

    Parameters
    ----------
    q, Q : float or Quantity
        Charges [C].
    center : (3,) array_like
        Position of Q [m].
    k_e : float
        Coulomb constant [N m^2/C^2], 8.9875517923e9 by default (use 1 for Gaussian-like units).
    """

    def __init__(self, q, Q, center=(0.0, 0.0, 0.0), k_e=COULOMB_K):
        from astropy import units as u

        q = q.to_value(u.C) if hasattr(q, "unit") else float(q)
        Q = Q.to_value(u.C) if hasattr(Q, "unit") else float(Q)
        super().__init__(-k_e * q * Q, center)


class InverseSquarePairs:
    """Mutual inverse-square forces between particles: V = -G sum_{i<j} m_i m_j / r_ij.

    With ``charges`` instead, the Coulomb interaction V = k_e sum q_i q_j / r_ij. Use as a force
    callable for :func:`visviva.mechanics.solve_particles` (positions (N, d)).

    Parameters
    ----------
    masses : (N,) array_like
        Masses [kg] (for gravity).
    G : float
        Coupling constant (6.67430e-11 SI by default; 1 for N-body units).
    charges : (N,) array_like, optional
        Charges [C]; if given the interaction is Coulomb with constant ``k_e``.
    """

    def __init__(self, masses, G=6.67430e-11, charges=None, k_e=COULOMB_K):
        ins = Inputs()
        m = np.atleast_1d(ins.get(masses, "kg", "masses", positive=True))
        if charges is None:
            self.coupling = -G * np.outer(m, m)
        else:
            q = np.atleast_1d(ins.get(charges, "charge", "charges"))
            if q.shape != m.shape:
                raise ShapeError("charges must have the same shape as masses.")
            self.coupling = k_e * np.outer(q, q)

    def _pairs(self, r):
        r = np.asarray(r, dtype=float)
        if r.ndim != 2 or r.shape[0] != self.coupling.shape[0]:
            raise ShapeError(f"positions must have shape (N, d) with N = {self.coupling.shape[0]}.")
        d = r[:, None, :] - r[None, :, :]
        dist = np.linalg.norm(d, axis=-1)
        np.fill_diagonal(dist, np.inf)
        if np.any(dist == 0):
            raise InvalidStateError("two particles coincide; the pair force is singular.")
        return d, dist

    @_si_field("energy")
    def potential(self, r):
        d, dist = self._pairs(r)
        return 0.5 * np.sum(self.coupling / dist)

    @_si_field("force")
    def force(self, r):
        d, dist = self._pairs(r)
        # F_i = sum_j c_ij (r_i - r_j) / r_ij^3 (c < 0 attracts)
        return np.einsum("ij,ijk->ik", self.coupling / dist**3, d)

    def __call__(self, t, r, v):
        return self.force(r)


def _power(force, trajectory):
    t, r, v = trajectory.t, trajectory.r, trajectory.v
    P = np.empty(t.size)
    for i in range(t.size):
        F = callable_result(force(t[i], r[i], v[i]), r[i].shape, "force(t, r, v)", t[i],
                            unit="force")
        P[i] = np.sum(F * v[i])
    return P


def _sampled_power(force, trajectory, context):
    """F . v at the samples, with a warning when Simpson's rule does not resolve it.

    The error of Simpson's rule on all samples is estimated as 1/15 of its difference from
    Simpson's rule on every other sample (Richardson: the rule is 4th order); above 1e-6 of
    int abs(F . v) dt a UserWarning gives the estimate.
    """
    import warnings

    from scipy.integrate import simpson, trapezoid

    P = _power(force, trajectory)
    if P.size < 3:
        raise InvalidInputError(f"{context} needs at least 3 samples of the trajectory.")
    t = trajectory.t
    if P.size >= 5:
        idx = np.arange(0, P.size, 2)
        if idx[-1] != P.size - 1:
            idx = np.append(idx, P.size - 1)
        error = abs(simpson(P, x=t) - simpson(P[idx], x=t[idx])) / 15.0
        scale = trapezoid(np.abs(P), t)
        if error > 1e-6 * scale:
            warnings.warn(
                f"{context}: the {P.size} samples of the trajectory do not resolve the power "
                f"F . v: Simpson's rule is uncertain by about {error:.3g} (relative "
                f"{error / scale:.2g} of int |F . v| dt). Sample the motion more densely (more "
                "output times t in solve_particles) for an accurate work.",
                UserWarning,
                stacklevel=3,
            )
    return P


def cumulative_work(force, trajectory):
    """Work done by ``force`` from the start to each output time: W(t) = int F . dr [J].

    Parameters
    ----------
    force : callable
        ``force(t, r, v)`` on one time's arrays (shape of ``trajectory.r[i]``) [N]; for several
        particles the work is summed over them.
    trajectory : Trajectory
        From :func:`solve_particles`, sampled densely enough to resolve F . v.

    Returns
    -------
    (n,) ndarray
        W(t_i), W(t_0) = 0.

    Notes
    -----
    W = int F . dr = int F . v dt along the actual motion (the line integral parametrised by
    time), integrated with :func:`scipy.integrate.cumulative_simpson` (4th order in the sample
    spacing). By the work-energy theorem the total work equals the change of kinetic energy.
    """
    from scipy.integrate import cumulative_simpson

    P = _sampled_power(force, trajectory, "cumulative_work")
    return np.concatenate([[0.0], cumulative_simpson(P, x=trajectory.t)])


def work(force, trajectory):
    """Total work of ``force`` along ``trajectory``, int F . v dt [J] (see :func:`cumulative_work`)."""
    from scipy.integrate import simpson

    P = _sampled_power(force, trajectory, "work")
    return float(simpson(P, x=trajectory.t))


def work_along_curve(field, curve, s_range, tangent=None, *, rtol=1e-11):
    """Line integral W = int F(r) . dr of a static force field along a parametrised curve.

    Parameters
    ----------
    field : callable
        ``field(r) -> F`` for one point r of shape (d,) [N] (a conservative object's ``force``
        works).
    curve : callable
        ``curve(s) -> r`` of shape (d,) [m].
    s_range : (float, float)
        Parameter interval [s0, s1] (the direction of travel is from s0 to s1).
    tangent : callable, optional
        ``tangent(s) -> dr/ds``; if omitted it is computed from ``curve`` by central differences
        with Ridders' extrapolation.
    rtol : float
        Relative tolerance of the adaptive quadrature.

    Returns
    -------
    float
        W [J]. For a conservative field W = V(r(s0)) - V(r(s1)) whatever the path; around a
        closed loop it is the circulation of F.

    Notes
    -----
    W = int_{s0}^{s1} F(r(s)) . r'(s) ds by :func:`scipy.integrate.quad` (adaptive Gauss-Kronrod).
    """
    from scipy.integrate import quad

    from .constraints import ridders_extrapolate

    s0, s1 = (float(s) for s in s_range)
    if not (np.isfinite(s0) and np.isfinite(s1)):
        raise InvalidInputError("s_range must be two finite numbers.")

    def dr_ds(s):
        if tangent is not None:
            return np.asarray(tangent(s), dtype=float)

        def central(h):
            return (np.asarray(curve(s + h), float) - np.asarray(curve(s - h), float)) / (2 * h)

        return ridders_extrapolate(central, 1e-3 * max(1.0, abs(s1 - s0)))

    def integrand(s):
        r = np.asarray(curve(s), dtype=float)
        F = callable_result(field(r), r.shape, "field(r)", s, at="s", unit="force")
        value = float(np.dot(F, dr_ds(s)))
        if not np.isfinite(value):
            raise InvalidInputError(
                f"work_along_curve: the curve or its tangent is not finite at s = {s:.9g} "
                f"(r = {r.tolist()}); check curve(s) (and tangent(s)) over s_range."
            )
        return value

    value, _ = quad(integrand, s0, s1, epsabs=0.0, epsrel=rtol, limit=200)
    return value


def conservation_report(trajectory, potential=None):
    """Largest relative drifts of energy, momentum and angular momentum along a trajectory.

    Parameters
    ----------
    trajectory : Trajectory
    potential : callable or list of callables, optional
        ``V(r) -> energy`` for the whole system at one time (e.g. ``UniformGravity(m).potential``
        summed over particles, or ``InverseSquarePairs(m).potential``); omit for free particles.

    Returns
    -------
    dict
        ``energy``: max abs(E - E0) / max(abs(E0), max T, tiny); ``momentum``: max ‖P - P0‖ /
        max(sum m ‖v‖); ``angular_momentum`` (3-D only): the same for L about the origin. Each is
        a relative drift, ~ the integrator tolerance when the quantity is conserved.
    """
    T = trajectory.kinetic_energy
    V = np.zeros_like(T)
    pots = [] if potential is None else (potential if isinstance(potential, list) else [potential])
    for pot in pots:
        for i, (ti, ri) in enumerate(zip(trajectory.t, trajectory.r, strict=True)):
            value = pot(ri)
            V[i] += np.sum(callable_result(value, np.shape(value), "potential(r)", ti,
                                           unit="energy"))
    E = T + V
    scale_E = max(abs(E[0]), np.max(np.abs(T)), np.finfo(float).tiny)
    m = trajectory.masses[..., None]
    p_scale = np.max(np.sum(np.abs(m * trajectory.v).reshape(T.size, -1), axis=1))
    p_scale = max(p_scale, np.finfo(float).tiny)
    P = trajectory.momentum
    out = {
        "energy": float(np.max(np.abs(E - E[0])) / scale_E),
        "momentum": float(np.max(np.abs(P - P[0])) / p_scale),
    }
    if trajectory.r.shape[-1] == 3:
        L = trajectory.angular_momentum
        l_scale = np.max(
            np.sum(
                (
                    m
                    * np.linalg.norm(trajectory.r, axis=-1, keepdims=True)
                    * np.linalg.norm(trajectory.v, axis=-1, keepdims=True)
                ).reshape(T.size, -1),
                axis=1,
            )
        )
        out["angular_momentum"] = float(
            np.max(np.abs(L - L[0])) / max(l_scale, np.finfo(float).tiny)
        )
    return out
