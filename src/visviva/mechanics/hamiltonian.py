"""Hamiltonian mechanics: Legendre transform, Hamilton's equations, symplectic integrators,
phase portraits and Poincare sections.

The symplectic integrators take the two gradients of a separable H(q, p) = T(p) + V(q) as plain
callables and work on arrays of any shape; :class:`HamiltonianSystem` builds them from a sympy
Hamiltonian (itself from a Lagrangian by :func:`legendre_transform`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import DomainError, InvalidInputError, ShapeError
from ._inputs import finite_rhs, ivp_failure, ivp_method, model_parameters, si_array

__all__ = [
    "HamiltonianSystem",
    "legendre_transform",
    "leapfrog",
    "yoshida4",
    "symplectic_integrate",
    "SymplecticTrajectory",
    "phase_portrait",
    "poincare_section",
]

# Yoshida (1990) 4th-order triple-jump coefficients (identical to Forest & Ruth 1990).
_CBRT2 = 2.0 ** (1.0 / 3.0)
_W1 = 1.0 / (2.0 - _CBRT2)
_W0 = -_CBRT2 / (2.0 - _CBRT2)


@dataclass(frozen=True)
class SymplecticTrajectory:
    """Samples (t, q, p) of a symplectic integration; q, p have shape (n_samples, ...)."""

    t: np.ndarray
    q: np.ndarray
    p: np.ndarray


def _kick_drift_kick(dT_dp, dV_dq, q, p, h):
    p = p - 0.5 * h * dV_dq(q)
    q = q + h * dT_dp(p)
    p = p - 0.5 * h * dV_dq(q)
    return q, p


def leapfrog(dT_dp, dV_dq, q, p, dt):
    """One velocity-Verlet (kick-drift-kick leapfrog) step for H = T(p) + V(q).

    Parameters
    ----------
    dT_dp : callable
        p -> dT/dp (for T = p^2 / 2m: p / m).
    dV_dq : callable
        q -> dV/dq (minus the force).
    q, p : array_like
        Coordinates and momenta (any shape, consistent units).
    dt : float
        Time step.

    Returns
    -------
    q, p : ndarray
        After one step. Second order, symplectic and time-reversible: the energy error stays
        bounded, O(dt^2), with no secular drift (Hairer, Lubich & Wanner, *Geometric Numerical
        Integration*, 2006, sec. I.1 and IX.3).
    """
    return _kick_drift_kick(dT_dp, dV_dq, np.asarray(q, float), np.asarray(p, float), dt)


def yoshida4(dT_dp, dV_dq, q, p, dt):
    """One 4th-order symplectic step: Yoshida's triple jump of leapfrog steps.

    The composition S(w1 dt) S(w0 dt) S(w1 dt) of :func:`leapfrog` with
    w1 = 1 / (2 - 2^(1/3)), w0 = -2^(1/3) / (2 - 2^(1/3)) cancels the dt^3 error term
    (Yoshida 1990, *Phys. Lett. A* 150, 262; Forest & Ruth 1990, *Physica D* 43, 105).
    Arguments as for :func:`leapfrog`.
    """
    q = np.asarray(q, float)
    p = np.asarray(p, float)
    q, p = _kick_drift_kick(dT_dp, dV_dq, q, p, _W1 * dt)
    q, p = _kick_drift_kick(dT_dp, dV_dq, q, p, _W0 * dt)
    return _kick_drift_kick(dT_dp, dV_dq, q, p, _W1 * dt)


_STEPPERS = {"leapfrog": leapfrog, "yoshida4": yoshida4, "forest_ruth": yoshida4}


def symplectic_integrate(
    dT_dp, dV_dq, q0, p0, dt, n_steps, *, method: str = "yoshida4", save_every: int = 1, t0=0.0
) -> SymplecticTrajectory:
    """Integrate a separable Hamiltonian with a fixed-step symplectic method.

    Parameters
    ----------
    dT_dp, dV_dq : callable
        Gradients of the kinetic and potential parts (see :func:`leapfrog`).
    q0, p0 : array_like or Quantity
        Initial coordinates and momenta (same shape; any shape): plain numbers in the units of
        the gradients, or Quantities, converted to SI (``30 * u.deg`` is 0.5236 rad).
    dt : float or Quantity
        Step [s] (negative integrates backwards; a Quantity is converted to s).
    n_steps : int
        Number of steps.
    method : {"yoshida4", "leapfrog", "forest_ruth"}
        Integrator ("forest_ruth" is the same 4th-order triple jump).
    save_every : int
        Keep every k-th step (the initial state is always kept).
    t0 : float or Quantity
        Initial time [s].

    Returns
    -------
    SymplecticTrajectory
        t (m,), q and p of shape (m,) + the shape of q0.
    """
    if method not in _STEPPERS:
        raise InvalidInputError(f"method must be one of {sorted(_STEPPERS)}; got {method!r}.")
    step = _STEPPERS[method]
    q = si_array(q0, "q0")
    p = si_array(p0, "p0")
    dt = float(si_array(dt, "dt"))
    t0 = float(si_array(t0, "t0"))
    if q.shape != p.shape:
        raise ShapeError(f"q0 and p0 must have the same shape; got {q.shape} and {p.shape}.")
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(p)) and np.isfinite(dt)):
        raise InvalidInputError("q0, p0 and dt must be finite.")
    n_steps = _count(n_steps, "n_steps", 0)
    save_every = _count(save_every, "save_every", 1)
    ts, qs, ps = [t0], [q.copy()], [p.copy()]
    for i in range(1, n_steps + 1):
        q, p = step(dT_dp, dV_dq, q, p, dt)
        if i == 1 and (q.shape != qs[0].shape or p.shape != qs[0].shape):
            raise ShapeError(
                f"symplectic_integrate: dT_dp and dV_dq must return arrays shaped like q0 "
                f"{qs[0].shape}; the state became {q.shape} and {p.shape}."
            )
        if i % save_every == 0:
            ts.append(t0 + i * dt)
            qs.append(q.copy())
            ps.append(p.copy())
    Q, P = np.array(qs), np.array(ps)
    # NaN persists once it appears: the samples and the final state show it (checked once, in
    # bulk, so that the per-step cost stays that of the gradients)
    finite = np.isfinite(Q).reshape(len(qs), -1).all(axis=1) & np.isfinite(P).reshape(
        len(ps), -1).all(axis=1)
    if not (finite.all() and np.all(np.isfinite(q)) and np.all(np.isfinite(p))):
        bad = int(np.argmin(finite)) * save_every if not finite.all() else n_steps
        raise DomainError(
            f"symplectic_integrate: the state is not finite (NaN or inf) by step {bad} "
            f"(t = {t0 + bad * dt:.9g}): dT_dp or dV_dq returned NaN or inf there (a "
            "singularity of the potential, or outside its domain). Take smaller steps or stop "
            "before it."
        )
    return SymplecticTrajectory(np.array(ts), Q, P)


def _count(value, name: str, minimum: int) -> int:
    """A step count: an integer (or an integer-valued float) >= ``minimum``.

    ``int()`` truncated silently: n_steps = 0.3 / 0.1 = 2.9999999999999996 ran 2 steps, not 3.
    """
    if isinstance(value, bool) or not isinstance(value, int | np.integer | float | np.floating):
        raise InvalidInputError(f"{name} must be an integer; got {value!r}.")
    if not (np.isfinite(value) and float(value).is_integer()):
        raise InvalidInputError(
            f"{name} must be a whole number; got {value!r}. Pass round(...) of it rather than "
            "have it truncated (0.3 / 0.1 is 2.9999999999999996, which int() makes 2)."
        )
    if value < minimum:
        raise InvalidInputError(f"{name} must be >= {minimum}; got {value!r}.")
    return int(value)


def _real_branches(solutions, qs, momenta, t, L, vs) -> list:
    """The candidate inverses q'(p) that are real and solve p = dL/dq' at sampled real points.

    ``sympy.solve`` returns every complex root (three for p = q'^3, two for p = sinh q'); the
    physical inverse is the one that is real for every real p. Six points with coordinates,
    parameters (positive) and momenta (both signs) drawn from a fixed seed decide it.
    """
    import sympy as sp

    rng = np.random.default_rng(20261128)
    kept = []
    for cand in solutions:
        good = True
        for _ in range(6):
            point = {q: float(rng.uniform(0.3, 1.7)) for q in qs}
            point.update({p: float(rng.choice([-1.0, 1.0]) * rng.uniform(0.3, 2.0))
                          for p in momenta})
            point[t] = float(rng.uniform(0.0, 1.0))
            exprs = [sp.sympify(cand[v]) for v in vs]
            others = set().union(*(e.free_symbols for e in exprs)) | L.free_symbols
            for sym in others - set(point) - set(vs):
                point[sym] = float(rng.uniform(0.5, 2.0))
            try:
                vals = [complex(e.subs(point).evalf()) for e in exprs]
                vel = dict(zip(vs, vals, strict=True))
                resid = [complex(sp.sympify(L.diff(v)).subs(point).subs(vel).evalf()) - point[p]
                         for p, v in zip(momenta, vs, strict=True)]
            except (TypeError, ValueError, ZeroDivisionError):
                good = False
                break
            scale = 1.0 + max(abs(x) for x in vals)
            if any(abs(x.imag) > 1e-9 * scale for x in vals) or any(
                    abs(r) > 1e-8 * (1.0 + abs(point[p])) for r, p in zip(resid, momenta, strict=True)):
                good = False
                break
        if good:
            kept.append(cand)
    return kept


def legendre_transform(lagrangian, coordinates):
    """Hamiltonian H(q, p) = sum p q' - L of a Lagrangian, with p = dL/dq'.

    Parameters
    ----------
    lagrangian : sympy expression
        L(q, q', t) in sympy dynamicsymbols (as for
        :class:`~visviva.mechanics.LagrangianSystem`).
    coordinates : sequence of dynamicsymbols
        q_1 ... q_n.

    Returns
    -------
    H : sympy expression
        In the coordinates q_i(t) and new symbols p_i.
    momenta : tuple of sympy Symbols
        p_1 ... p_n (named ``p_<q>``).

    Raises
    ------
    InvalidInputError
        The map q' -> p cannot be inverted (singular Hessian d^2 L / dq'^2).

    Notes
    -----
    Goldstein 3rd ed. sec. 8.1. The velocities are found with ``sympy.solve`` from the linear
    system p = dL/dq' (L quadratic in q' for natural systems). Where sympy returns several
    roots (a non-quadratic kinetic term such as cosh q'), the one that is real and solves
    p = dL/dq' at six sampled real points is kept; none or several such roots are refused.
    """
    import sympy as sp
    from sympy.physics.mechanics import dynamicsymbols

    t = dynamicsymbols._t
    qs = list(coordinates)
    speeds = [q.diff(t) for q in qs]
    vs = sp.symbols(f"v0:{len(qs)}")
    momenta = sp.symbols(" ".join(f"p_{q.func.__name__}" for q in qs) + " ", seq=True)
    L = sp.sympify(lagrangian).subs(dict(zip(speeds, vs, strict=True)))
    eqs = [sp.Eq(p, L.diff(v)) for p, v in zip(momenta, vs, strict=True)]
    sol = sp.solve(eqs, vs, dict=True)
    if len(sol) > 1:  # sympy also returns complex branches: keep the real inverse, if unique
        sol = _real_branches(sol, qs, momenta, t, L, vs)
    if len(sol) != 1:
        raise InvalidInputError(
            "the Legendre transform needs p = dL/dq' to have exactly one real solution q'(p) "
            f"in closed form; {len(sol)} were found. L must be strictly convex in the velocities "
            "(q'^3/3 is not: p = q'^2 has two real roots), and sympy must write the inverse as "
            "one expression (q'^4/4 is convex, but its real inverse sign(p)|p|^(1/3) comes out "
            "branch by branch). Integrate the Euler-Lagrange equations with LagrangianSystem "
            "instead, or write H(q, p) yourself for HamiltonianSystem."
        )
    sol = sol[0]
    H = sum(p * sol[v] for p, v in zip(momenta, vs, strict=True)) - L.subs(sol)
    return sp.simplify(H), tuple(momenta)


class HamiltonianSystem:
    """Hamilton's equations q' = dH/dp, p' = -dH/dq compiled from a sympy H(q, p, t).

    Parameters
    ----------
    hamiltonian : sympy expression
        H in the coordinates and momenta.
    coordinates : sequence of sympy symbols or dynamicsymbols
    momenta : sequence of sympy symbols
    parameters : dict, optional
        Values for the other symbols.

    Notes
    -----
    Use :meth:`from_lagrangian` to start from L. :meth:`rhs` feeds solve_ivp;
    :attr:`is_separable` tells whether d^2 H / dq dp = 0, in which case :meth:`symplectic`
    integrates with :func:`leapfrog` or :func:`yoshida4`.
    """

    def __init__(self, hamiltonian, coordinates, momenta, parameters=None):
        import sympy as sp
        from sympy.physics.mechanics import dynamicsymbols

        self.time = dynamicsymbols._t
        self.coordinates = [sp.Symbol(c) if isinstance(c, str) else c for c in coordinates]
        self.momenta = [sp.Symbol(p) if isinstance(p, str) else p for p in momenta]
        if len(self.coordinates) != len(self.momenta) or not self.coordinates:
            raise ShapeError("coordinates and momenta must be non-empty and of equal length.")
        self.dof = len(self.coordinates)
        self._q = sp.symbols(f"q0:{self.dof}")
        H = sp.sympify(hamiltonian).subs(dict(zip(self.coordinates, self._q, strict=True)))
        H = H.subs(model_parameters(H, parameters, "H"))
        free = H.free_symbols - set(self._q) - set(self.momenta) - {self.time}
        if free:
            raise InvalidInputError(
                f"H has symbols without values: {', '.join(sorted(map(str, free)))}; pass "
                "parameters={symbol: value}."
            )
        self.hamiltonian = H
        self.dH_dq = [H.diff(q) for q in self._q]
        self.dH_dp = [H.diff(p) for p in self.momenta]
        self.is_separable = all(
            sp.simplify(dq.diff(p)) == 0 for dq in self.dH_dq for p in self.momenta
        ) and not H.has(self.time)
        args = [self.time, *self._q, *self.momenta]
        self._H = sp.lambdify(args, H, modules="numpy", cse=True)
        self._flow = sp.lambdify(args, [*self.dH_dp, *[-d for d in self.dH_dq]], "numpy", cse=True)
        self._args_q = [self.time, *self._q]
        if self.is_separable:
            zero_p = dict.fromkeys(self.momenta, 0)
            zero_q = dict.fromkeys(self._q, 0)
            self._dV = sp.lambdify(self._q, [d.subs(zero_p) for d in self.dH_dq], "numpy")
            self._dT = sp.lambdify(self.momenta, [d.subs(zero_q) for d in self.dH_dp], "numpy")

    @classmethod
    def from_lagrangian(cls, lagrangian, coordinates, parameters=None) -> HamiltonianSystem:
        """Build H by :func:`legendre_transform` of L and compile it."""
        H, momenta = legendre_transform(lagrangian, coordinates)
        return cls(H, coordinates, momenta, parameters)

    def energy(self, q, p, t=0.0):
        """H at arrays q, p of shape (..., dof)."""
        q = si_array(q, "q", finite=True)
        p = si_array(p, "p", finite=True)
        out = self._H(t, *np.moveaxis(q, -1, 0), *np.moveaxis(p, -1, 0))
        return np.broadcast_to(np.asarray(out, float), q.shape[:-1]).copy()

    def rhs(self, t, y):
        """Hamilton's equations for solve_ivp: y = (q, p) -> (dH/dp, -dH/dq)."""
        n = self.dof
        return np.array([float(v) for v in self._flow(t, *y[:n], *y[n:])])

    def _grad_T(self, p):
        return np.array(np.broadcast_arrays(*self._dT(*p)), dtype=float)

    def _grad_V(self, q):
        return np.array(np.broadcast_arrays(*self._dV(*q)), dtype=float)

    def symplectic(self, q0, p0, dt, n_steps, *, method="yoshida4", save_every=1):
        """Fixed-step symplectic integration (separable H only); see :func:`symplectic_integrate`."""
        if not self.is_separable:
            raise InvalidInputError(
                "this Hamiltonian is not separable (H != T(p) + V(q)); the explicit symplectic "
                "methods do not apply. Use rhs with solve_ivp (tight tolerances) instead."
            )
        return symplectic_integrate(
            self._grad_T, self._grad_V, q0, p0, dt, n_steps, method=method, save_every=save_every
        )

    def simulate(self, q0, p0, t, *, rtol=1e-12, atol=1e-12, method="DOP853"):
        """Integrate Hamilton's equations with solve_ivp; returns a SymplecticTrajectory-like record."""
        from scipy.integrate import solve_ivp

        q0 = np.atleast_1d(si_array(q0, "q0"))
        p0 = np.atleast_1d(si_array(p0, "p0"))
        if q0.shape != (self.dof,) or p0.shape != (self.dof,):
            raise ShapeError(
                f"q0 and p0 must have shape ({self.dof},); got {q0.shape} and {p0.shape}."
            )
        if not (np.all(np.isfinite(q0)) and np.all(np.isfinite(p0))):
            raise InvalidInputError("q0 and p0 must be finite.")
        t = np.atleast_1d(si_array(t, "t"))
        if t.ndim != 1 or t.size < 2 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise InvalidInputError("t must hold at least 2 finite, strictly increasing times.")
        y0 = np.concatenate([q0, p0])
        method = ivp_method(method, "HamiltonianSystem.simulate")
        sol = solve_ivp(finite_rhs(self.rhs, "HamiltonianSystem.simulate"), (t[0], t[-1]), y0,
                        t_eval=t, rtol=rtol, atol=atol, method=method)
        if sol.status == -1:
            raise ivp_failure(sol, "HamiltonianSystem.simulate", t[-1])
        n = self.dof
        return SymplecticTrajectory(sol.t, sol.y[:n].T.copy(), sol.y[n:].T.copy())


def phase_portrait(H, q_range, p_range, n=201):
    """Grid of H(q, p) for drawing level sets (contours) of a one-degree-of-freedom system.

    Parameters
    ----------
    H : callable or HamiltonianSystem
        ``H(q, p)`` vectorised over arrays (or a 1-dof HamiltonianSystem).
    q_range, p_range : (float, float)
        Limits of the grid.
    n : int or (int, int)
        Grid points along q and p.

    Returns
    -------
    Q, P, E : (n_p, n_q) ndarray
        Mesh and H values; ``plt.contour(Q, P, E, levels)`` draws the phase portrait, each
        contour being a trajectory (energy is conserved).
    """
    if not (isinstance(H, HamiltonianSystem) or callable(H)):
        raise InvalidInputError(
            f"phase_portrait: H must be a callable H(q, p) vectorised over arrays or a 1-dof "
            f"HamiltonianSystem; got {type(H).__name__}. Wrap a sympy expression in "
            "q and p as HamiltonianSystem(H, [q], [p]) or sympy.lambdify((q, p), H, 'numpy')."
        )
    nq, npts = (n, n) if np.isscalar(n) else n
    q = np.linspace(*q_range, _count(nq, "n", 2))
    p = np.linspace(*p_range, _count(npts, "n", 2))
    Q, P = np.meshgrid(q, p)
    if isinstance(H, HamiltonianSystem):
        if H.dof != 1:
            raise ShapeError("phase_portrait draws one degree of freedom; H has more.")
        E = H.energy(Q[..., None], P[..., None])
    else:
        E = np.broadcast_to(np.asarray(H(Q, P), float), Q.shape)
    return Q, P, np.array(E)


def poincare_section(
    rhs, y0, t_max, section, *, direction=1, max_points=None, rtol=1e-11, atol=1e-12
):
    """Points where a trajectory crosses a surface of section.

    Parameters
    ----------
    rhs : callable or HamiltonianSystem
        ``rhs(t, y)`` of the first-order system (or a HamiltonianSystem, using its ``rhs``).
    y0 : (n,) array_like
        Initial state.
    t_max : float
        Integration time.
    section : int or callable
        Index i of the state component whose zero is the section (y[i] = 0), or a function
        ``g(t, y)`` whose zeros define it.
    direction : {1, -1, 0}
        Count only crossings with g increasing (1), decreasing (-1) or both (0).
    max_points : int, optional
        Stop after this many crossings.

    Returns
    -------
    t_cross : (k,) ndarray
        Crossing times.
    y_cross : (k, n) ndarray
        States at the crossings, located to the solver's accuracy by event detection (dense
        output root finding), not by sampling.

    Notes
    -----
    Surfaces of section reduce a 2-dof Hamiltonian flow to an area-preserving map (Poincare;
    Henon & Heiles 1964, *Astron. J.* 69, 73). Regular orbits lie on closed curves, chaotic ones
    fill areas.
    """
    from scipy.integrate import solve_ivp

    fun = rhs.rhs if isinstance(rhs, HamiltonianSystem) else rhs
    if not (np.ndim(t_max) == 0 and np.isfinite(t_max) and t_max > 0):
        raise InvalidInputError(f"t_max must be a finite time > 0; got {t_max!r}.")
    y0 = np.atleast_1d(np.asarray(y0, float))
    if y0.ndim != 1 or not np.all(np.isfinite(y0)):
        raise InvalidInputError(f"y0 must be a finite 1-D state; got {y0.tolist()}.")
    if isinstance(rhs, HamiltonianSystem) and y0.size != 2 * rhs.dof:
        raise ShapeError(
            f"y0 must hold (q, p): {2 * rhs.dof} numbers for this {rhs.dof}-dof system; got "
            f"{y0.size}."
        )
    if callable(section):
        event = lambda t, y: section(t, y)  # noqa: E731
    else:
        idx = int(section)
        if not -y0.size <= idx < y0.size:
            raise InvalidInputError(
                f"section index {idx} is outside the state of size {y0.size}; give the index of "
                "the component whose zero is the section, or a function g(t, y)."
            )
        event = lambda t, y: y[idx]  # noqa: E731
    if isinstance(direction, bool) or direction not in (1, -1, 0):
        raise InvalidInputError(
            f"direction must be 1 (increasing), -1 (decreasing) or 0 (both); got {direction!r}."
        )
    event.direction = direction
    on_section = event(0.0, y0) == 0  # a crossing at t = 0 is reported by solve_ivp: skip it
    if max_points is not None:
        max_points = _count(max_points, "max_points", 1)
    event.terminal = int(max_points) + int(on_section) if max_points else False
    sol = solve_ivp(
        finite_rhs(fun, "poincare_section"), (0.0, float(t_max)), y0, events=event, rtol=rtol, atol=atol, method="DOP853"
    )
    if sol.status == -1:
        raise ivp_failure(sol, "poincare_section", t_max)
    t_cross = sol.t_events[0]
    y_cross = sol.y_events[0].reshape(-1, y0.size)
    # the state at t = 0 may sit on the section: drop that spurious crossing
    keep = t_cross > 0
    t_cross, y_cross = t_cross[keep], y_cross[keep]
    if max_points:
        t_cross, y_cross = t_cross[: int(max_points)], y_cross[: int(max_points)]
    return t_cross, y_cross
