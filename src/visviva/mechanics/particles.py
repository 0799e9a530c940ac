"""Newtonian particles: m r'' = F(t, r, v) for one or many particles, with user forces.

Forces are plain callables ``force(t, r, v) -> F`` on arrays of shape (N, d) (N particles in d
dimensions; a single particle may be given as shape (d,)), so one call evaluates every particle
(array in, array out). Integration is :func:`scipy.integrate.solve_ivp`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import InvalidInputError, ShapeError
from ._inputs import Inputs, callable_result, ivp_failure

__all__ = [
    "Trajectory",
    "solve_particles",
    "uniform_gravity",
    "linear_drag",
    "quadratic_drag",
    "projectile_linear_drag",
    "projectile",
]


@dataclass(frozen=True)
class Trajectory:
    """Positions and velocities of particles at output times (plain arrays, consistent units).

    Attributes
    ----------
    t : (n,) ndarray
        Times [s].
    r : (n, N, d) ndarray
        Positions [m] (a single particle given as shape (d,) gives (n, d)).
    v : (n, N, d) ndarray
        Velocities [m/s], same shape as ``r``.
    masses : (N,) ndarray
        Masses [kg] (shape () for a single particle).
    """

    t: np.ndarray
    r: np.ndarray
    v: np.ndarray
    masses: np.ndarray

    @cached_property
    def _m(self):
        return self.masses[..., None]

    @cached_property
    def kinetic_energy(self) -> np.ndarray:
        """(n,) total kinetic energy sum m ‖v‖^2 / 2 [J]."""
        k = 0.5 * self._m * self.v**2
        return k.reshape(k.shape[0], -1).sum(axis=1)

    @cached_property
    def momentum(self) -> np.ndarray:
        """(n, d) total linear momentum sum m v [kg m/s]."""
        p = self._m * self.v
        return p if p.ndim == 2 else p.sum(axis=1)

    @cached_property
    def angular_momentum(self) -> np.ndarray:
        """(n, 3) total angular momentum about the origin sum m r x v [kg m^2/s] (d = 3 only)."""
        if self.r.shape[-1] != 3:
            raise ShapeError("angular_momentum needs 3-D positions (d = 3).")
        h = self._m * np.cross(self.r, self.v)
        return h if h.ndim == 2 else h.sum(axis=1)


def check_times(t):
    """``t`` as a 1-D float array of at least 2 strictly increasing output times (InvalidInputError otherwise)."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if t.ndim != 1 or t.size < 2 or np.any(np.diff(t) <= 0):
        raise InvalidInputError(
            "t must be a 1-D array of at least 2 strictly increasing output times; the "
            "integration starts at t[0]."
        )
    return t


def particle_inputs(ins: Inputs, masses, r0, v0):
    """Initial positions, velocities and masses of one or many particles, converted and checked.

    Parameters
    ----------
    ins : Inputs
        The call's collector of converted arguments.
    masses : float or (N,) array_like or Quantity
        Masses [kg], > 0; a scalar is shared by all N particles.
    r0, v0 : (d,) or (N, d) array_like or Quantity
        Initial positions [m] and velocities [m/s], of the same shape.

    Returns
    -------
    r0, v0 : ndarray
        Shape (d,) or (N, d), SI.
    m : ndarray
        Shape () for one particle (r0 of shape (d,)), else (N,).

    Raises
    ------
    ShapeError
        Shapes of r0, v0 and masses that do not fit together.
    """
    r0 = ins.vector(r0, "m", "r0", dim=None)
    v0 = ins.vector(v0, "speed", "v0", dim=None)
    if r0.shape != v0.shape or r0.ndim > 2:
        raise ShapeError(
            f"r0 and v0 must both have shape (d,) or (N, d); got {r0.shape} and {v0.shape}."
        )
    m = ins.get(masses, "kg", "masses", positive=True)
    if r0.ndim == 2:
        n_particles = r0.shape[0]
        m = np.broadcast_to(m, (n_particles,)) if m.ndim == 0 else m
        if m.shape != (n_particles,):
            raise ShapeError(f"masses must have shape ({n_particles},); got {m.shape}.")
    elif m.ndim != 0:
        raise ShapeError("a single particle (r0 of shape (d,)) needs a scalar mass.")
    return r0, v0, m


def solve_particles(
    force,
    masses,
    r0,
    v0,
    t,
    *,
    method: str = "DOP853",
    rtol: float = 1e-10,
    atol: float = 1e-12,
    events=None,
) -> Trajectory:
    """Integrate m r'' = F(t, r, v) for one or many particles.

    Parameters
    ----------
    force : callable
        ``force(t, r, v) -> F`` with r, v and F of shape (N, d) (or (d,) for a single particle)
        [N]. Called once per right-hand-side evaluation for all particles together.
    masses : float, (N,) array_like or Quantity
        Masses [kg], > 0.
    r0, v0 : (d,) or (N, d) array_like or Quantity
        Initial positions [m] and velocities [m/s].
    t : (n,) array_like or Quantity
        Strictly increasing output times [s]; the integration starts at ``t[0]``.
    method, rtol, atol
        Passed to :func:`scipy.integrate.solve_ivp` (default DOP853, rtol 1e-10, atol 1e-12).
    events : callable or list, optional
        solve_ivp events taking ``(t, r, v)``; the integration stops at a terminal event and the
        trajectory ends at the last output time before it.

    Returns
    -------
    Trajectory
        Plain arrays in the units of the inputs (SI when Quantities were given).

    Raises
    ------
    ShapeError
        r0, v0 shapes differ, or masses do not match N.
    DomainError
        Non-positive masses.
    ConvergenceError
        The integrator failed (stiff or singular force).

    Notes
    -----
    First-order form y = (r, v), y' = (v, F / m) (Taylor, *Classical Mechanics*, 2005, ch. 1).

    Examples
    --------
    >>> import numpy as np
    >>> spring = lambda t, r, v: -4.0 * r
    >>> tr = solve_particles(spring, 1.0, [1.0], [0.0], np.linspace(0, np.pi, 3))
    >>> print(f"{tr.r[-1, 0]:.9f}")
    1.000000000
    """
    from scipy.integrate import solve_ivp

    ins = Inputs()
    r0, v0, m = particle_inputs(ins, masses, r0, v0)
    t = check_times(ins.get(t, "s", "t"))
    shape = r0.shape
    size = r0.size
    inv_m = (1.0 / m)[..., None] if r0.ndim == 2 else 1.0 / m

    def rhs(time, y):
        r = y[:size].reshape(shape)
        v = y[size:].reshape(shape)
        F = callable_result(force(time, r, v), shape, "force(t, r, v)", time, unit="force")
        return np.concatenate([y[size:], (F * inv_m).ravel()])

    wrapped = None
    if events is not None:
        evs = events if isinstance(events, list | tuple) else [events]
        wrapped = []
        for ev in evs:

            def w(time, y, _ev=ev):
                return _ev(time, y[:size].reshape(shape), y[size:].reshape(shape))

            w.terminal = getattr(ev, "terminal", False)
            w.direction = getattr(ev, "direction", 0)
            wrapped.append(w)
    y0 = np.concatenate([r0.ravel(), v0.ravel()])
    sol = solve_ivp(
        rhs, (t[0], t[-1]), y0, method=method, t_eval=t, rtol=rtol, atol=atol, events=wrapped
    )
    if sol.status == -1:
        raise ivp_failure(sol, "solve_particles", t[-1])
    Y = sol.y.T
    n = Y.shape[0]
    return Trajectory(
        t=sol.t,
        r=Y[:, :size].reshape((n,) + shape),
        v=Y[:, size:].reshape((n,) + shape),
        masses=m,
    )


def _weight(m, r, g, axis=-1):
    F = np.zeros_like(r)
    F[..., axis] = -m * g
    return F


def _gravity_inputs(masses, g):
    """Masses [kg] (> 0) and g [m/s^2] (finite) of the force builders, in SI."""
    ins = Inputs()
    return ins.get(masses, "kg", "masses", positive=True), float(ins.get(g, "accel", "g"))


def uniform_gravity(masses, g=9.81, axis: int = -1):
    """Force callable ``F(t, r, v)`` = -m g along ``axis`` (the last coordinate by default) [N].

    ``masses`` [kg] (> 0) is a scalar for one particle of shape (d,), or (N,) for positions
    (N, d); ``g`` [m/s^2] finite.
    """
    m, g = _gravity_inputs(masses, g)
    if isinstance(axis, bool) or not isinstance(axis, int | np.integer):
        raise InvalidInputError(f"axis must be an integer (the vertical coordinate); got {axis!r}.")

    def force(t, r, v):
        d = np.shape(r)[-1] if np.ndim(r) else 0
        if not -d <= axis < d:
            raise ShapeError(
                f"uniform_gravity: axis {axis} is not a coordinate of positions with d = {d} "
                f"components; give axis in [-{d}, {d - 1}] (the vertical one)."
            )
        return _weight(m, r, g, axis)

    return force


def linear_drag(b, g=0.0, masses=1.0):
    """Force callable F = -b v - m g e_last (linear/Stokes drag, optional gravity) [N].

    ``b`` [kg/s] (>= 0) is a scalar or (N, 1) per particle.
    """
    m, g = _gravity_inputs(masses, g)
    b = Inputs().get(b, "drag_linear", "b", nonnegative=True)

    def force(t, r, v):
        return -b * v + _weight(m, r, g)

    return force


def quadratic_drag(c, g=0.0, masses=1.0):
    """Force callable F = -c ‖v‖ v - m g e_last (quadratic/Newton drag, optional gravity) [N].

    ``c`` [kg/m] (>= 0) is a scalar or (N, 1) per particle.
    """
    m, g = _gravity_inputs(masses, g)
    c = Inputs().get(c, "drag_quadratic", "c", nonnegative=True)

    def force(t, r, v):
        return -c * np.linalg.norm(v, axis=-1, keepdims=True) * v + _weight(m, r, g)

    return force


def projectile_linear_drag(r0, v0, t, k, g=9.81):
    """Exact projectile motion with linear drag, r'' = g_vec - k r' (k = b/m).

    Parameters
    ----------
    r0, v0 : (d,) array_like or Quantity
        Initial position [m] and velocity [m/s]; gravity acts along -e_last.
    t : (n,) array_like or Quantity
        Times since launch [s].
    k : float or Quantity
        Drag rate b/m [1/s], >= 0 (0 is the vacuum parabola).
    g : float or Quantity
        Gravitational acceleration [m/s^2].

    Returns
    -------
    r, v : (n, d) ndarray or Quantity
        Position [m] and velocity [m/s].

    Notes
    -----
    With terminal velocity v_T = g_vec / k: v = v_T + (v0 - v_T) e^{-k t} and
    r = r0 + v_T t + (v0 - v_T)(1 - e^{-k t}) / k (Taylor 2005, sec. 2.4). Written with
    E = -expm1(-k t) / k and the combination v_T (t - E) = g_vec (t - E)/k, evaluated by a series
    when k t is small, so the k -> 0 limit (the parabola) is reached smoothly and without
    cancellation.
    """
    ins = Inputs()
    r0 = ins.vector(r0, "m", "r0", dim=None)
    v0 = ins.vector(v0, "speed", "v0", dim=None)
    t = np.atleast_1d(ins.get(t, "s", "t"))
    if r0.shape != v0.shape or r0.ndim != 1 or t.ndim != 1:
        raise ShapeError(
            "projectile_linear_drag flies one projectile: r0 and v0 must both have shape (d,) and "
            f"t be 1-D; got {r0.shape}, {v0.shape} and {t.shape}."
        )
    t = t[:, None]
    k = float(ins.get(k, "rate", "k", nonnegative=True))
    g = float(ins.get(g, "accel", "g"))
    gvec = np.zeros(r0.shape[-1])
    gvec[-1] = -g
    x = k * t
    # E = (1 - e^{-x})/k ; D = (t - E)/k = t^2 (x - 1 + e^{-x})/x^2
    E = np.where(x > 0, -np.expm1(-x) / np.where(k > 0, k, 1.0), t)
    small = np.abs(x) < 1e-2
    xs = np.where(small, x, 0.0)
    D_series = t * t * (0.5 - xs / 6 + xs**2 / 24 - xs**3 / 120 + xs**4 / 720 - xs**5 / 5040)
    xl = np.where(small, 1.0, x)
    D_direct = t * t * (xl - 1.0 + np.exp(-xl)) / (xl * xl)
    D = np.where(small, D_series, D_direct)
    decay = np.exp(-x)
    r = r0 + v0 * E + gvec * D
    v = v0 * decay + gvec * E
    return ins.out(r, "m"), ins.out(v, "speed")


def projectile(r0, v0, t, *, drag: str | None = None, k: float = 0.0, g: float = 9.81, **kw):
    """Projectile trajectory by integration: no drag, linear (k = b/m) or quadratic (k = c/m).

    Returns the :class:`Trajectory` of a unit-mass particle with r'' = -g e_last - k v
    (``drag="linear"``) or - k ‖v‖ v (``drag="quadratic"``). Extra keywords go to
    :func:`solve_particles`. For linear drag the exact answer is :func:`projectile_linear_drag`;
    for quadratic drag from rest, v(t) = v_T tanh(g t / v_T) with v_T = sqrt(g / k).
    ``r0`` and ``v0`` hold at ``t[0]``, where the integration starts (``projectile_linear_drag``
    counts its times from launch: compare it at ``t - t[0]``).
    """
    if drag not in (None, "linear", "quadratic"):
        raise InvalidInputError(f"drag must be None, 'linear' or 'quadratic'; got {drag!r}.")
    unit = {None: "rate", "linear": "rate", "quadratic": "per_m"}[drag]
    k = float(Inputs().get(k, unit, "k", nonnegative=True))
    if drag is None and k != 0:
        raise InvalidInputError(
            f"k = {k!r} was given without a drag law: pass drag='linear' or drag='quadratic' "
            "(or leave k = 0 for the vacuum parabola)."
        )
    # k = c/m or b/m for the unit mass integrated below
    force = quadratic_drag(k, g) if drag == "quadratic" else linear_drag(k, g)
    return solve_particles(force, 1.0, r0, v0, t, **kw)
