"""Holonomic constraints f(r, t) = 0 through Lagrange multipliers, with drift stabilisation.

The equations of motion of particles with masses m under applied forces F and k constraints are

    M a = F + J^T lambda,      J a = -c - 2 alpha f' - beta^2 f,

where J = df/dr is the (k, n) constraint Jacobian (the real gradient, from the user or from
central differences of f, never from samples of a trajectory), c = d^2/ds^2 f(r + s v, t + s)
collects the velocity-dependent terms v^T H v + 2 f_rt v + f_tt (by Ridders-extrapolated
central differences along the motion), and alpha, beta are Baumgarte's
stabilisation rates that make a constraint violation decay instead of drift (Baumgarte 1972,
*Comput. Methods Appl. Mech. Eng.* 1, 1). Output samples can additionally be projected back onto
the constraint manifold (mass-weighted least-squares correction of r, then of v).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InvalidInputError, ShapeError
from ._inputs import Inputs, callable_result, finite_rhs, ivp_failure
from .particles import Trajectory, check_times, particle_inputs

__all__ = ["ConstrainedTrajectory", "solve_constrained", "pendulum_constraint"]

_EPS = np.finfo(float).eps


@dataclass(frozen=True)
class ConstrainedTrajectory(Trajectory):
    """A :class:`~visviva.mechanics.Trajectory` plus the constraint multipliers and forces.

    Attributes
    ----------
    multipliers : (n, k) ndarray
        Lagrange multipliers lambda at each output time.
    constraint_forces : (n, ...) ndarray
        J^T lambda, the forces the constraints exert, shaped like ``r`` [N].
    violation : (n, k) ndarray
        f(r, t) at the outputs (after projection when it was asked for).
    """

    multipliers: np.ndarray = None
    constraint_forces: np.ndarray = None
    violation: np.ndarray = None


def ridders_extrapolate(estimate, h0, *, shrink=1.6, levels=14):
    """Ridders' polynomial extrapolation of a difference quotient with an error series in h^2.

    ``estimate(h)`` returns a central first or second difference (an array); the Neville table
    extrapolates h -> 0 and the entry with the smallest estimated error is returned (Ridders
    1982, *Adv. Eng. Software* 4, 75; Press et al., *Numerical Recipes*, 3rd ed., sec. 5.7).
    Accurate to ~1e-12 relative for smooth functions, whatever their length scale.
    """
    h = h0
    table = [[np.asarray(estimate(h), dtype=float)]]
    best = table[0][0]
    err = np.inf
    s2 = shrink * shrink
    for i in range(1, levels):
        h /= shrink
        row = [np.asarray(estimate(h), dtype=float)]
        fac = s2
        for j in range(1, i + 1):
            row.append((row[j - 1] * fac - table[i - 1][j - 1]) / (fac - 1.0))
            fac *= s2
            # ndarray.max(): np.max's dispatch costs more than these few-element arrays
            errt = max(
                float(np.abs(row[j] - row[j - 1]).max()),
                float(np.abs(row[j] - table[i - 1][j - 1]).max()),
            )
            if errt <= err:
                err, best = errt, row[j]
        if float(np.abs(row[i] - table[i - 1][i - 1]).max()) >= 2 * err:
            break
        table.append(row)
    return best


class _Constraint:
    def __init__(self, f, jac, shape, time_dependent):
        self.f = f
        self.jac = jac
        self.shape = shape
        self.n = int(np.prod(shape))
        self.tau = 1.0 if time_dependent else 0.0

    def value(self, x, t):
        f = np.atleast_1d(np.asarray(self.f(x.reshape(self.shape), t), dtype=float)).ravel()
        return callable_result(f, f.shape, "constraint(r, t)", t)

    def jacobian(self, x, t):
        if self.jac is not None:
            J = np.asarray(self.jac(x.reshape(self.shape), t), dtype=float)
            J = callable_result(J, J.shape, "jacobian(r, t)", t)
            k = J.size // self.n
            if J.size != k * self.n or k == 0:
                raise ShapeError(
                    f"jacobian returned shape {J.shape}; it must be (k, {self.n}) or (k, "
                    f"*{self.shape}) for k constraints."
                )
            return J.reshape(k, self.n)
        # central differences of f, one coordinate at a time, extrapolated (Ridders)
        cols = []
        for j in range(self.n):
            e = np.zeros(self.n)
            e[j] = 1.0

            def central(h, e=e):
                return (self.value(x + h * e, t) - self.value(x - h * e, t)) / (2 * h)

            cols.append(ridders_extrapolate(central, 2e-3 * max(1.0, abs(x[j]))))
        return np.column_stack(cols)

    def time_derivative(self, x, t):
        if not self.tau:
            return 0.0

        def central(h):
            return (self.value(x, t + h) - self.value(x, t - h)) / (2 * h)

        return ridders_extrapolate(central, 2e-3 * max(1.0, abs(t)))

    def rate(self, x, v, t):
        """f' = J v + f_t."""
        return self.jacobian(x, t) @ v + self.time_derivative(x, t)

    def curvature(self, x, v, t):
        """c = d^2/ds^2 f(x + s v, t + s tau) at s = 0 (= v^T H v + 2 f_rt v + f_tt)."""
        speed = max(np.sqrt(v @ v), self.tau)
        if speed == 0:
            return np.zeros_like(self.value(x, t))
        h0 = 2e-3 * max(1.0, np.sqrt(x @ x), abs(t) * self.tau) / speed
        if self.jac is not None:

            def first(h):  # d/ds (J v) along the path: the Jacobian's own first differences
                plus = self.jacobian(x + h * v, t + h * self.tau) @ v
                minus = self.jacobian(x - h * v, t - h * self.tau) @ v
                return (plus - minus) / (2 * h)

            c = ridders_extrapolate(first, h0)
            if not self.tau:
                return c
            # + d/ds f_t along the path: the mixed difference of F(a, b) = f(x + a v, t + a + b),
            # whose error is a series in h^2 too (4 calls of f per level; differencing the
            # extrapolated f_t instead nested two Ridders tables: ~30x the calls)

            def mixed(h):
                def F(a, b):
                    return self.value(x + a * v, t + a + b)

                return (F(h, h) - F(h, -h) - F(-h, h) + F(-h, -h)) / (4 * h * h)

            return c + ridders_extrapolate(mixed, h0)
        f0 = self.value(x, t)

        def second(h):
            plus = self.value(x + h * v, t + h * self.tau)
            minus = self.value(x - h * v, t - h * self.tau)
            return (plus - 2 * f0 + minus) / (h * h)

        return ridders_extrapolate(second, h0)


def _refuse_hidden_time_dependence(con, x0, t):
    """InvalidInputError if f(r0, t) changes with t although time_dependent is False.

    The partial derivatives of f with respect to t enter f' and f'' only for rheonomic
    constraints; left out, the motion follows a constraint frozen at each instant (a bead on a
    rotating hoop slides off its equilibrium) while f = 0 still holds to rounding.
    """
    J = con.jacobian(x0, t[0])
    size = max(1.0, np.max(np.abs(x0)))
    # the initial positions and a point next to them (a moving constraint can be still at r0,
    # e.g. a hoop rotating about an axis through the bead)
    for k, x in enumerate((x0, x0 + 1e-3 * size * np.sin(np.arange(1.0, x0.size + 1.0)))):
        try:
            values = [con.value(x, time) for time in np.linspace(t[0], t[-1], 9)]
        except InvalidInputError:
            if k == 0:
                raise
            return  # f is not defined off the constraint surface: the probe at r0 must do
        f0 = values[0]
        scale = max(np.max(np.abs(J)) * size, np.max(np.abs(f0)), np.finfo(float).tiny)
        for time, value in zip(np.linspace(t[0], t[-1], 9)[1:], values[1:], strict=True):
            change = np.max(np.abs(value - f0))
            if change > 1e-12 * scale:
                raise InvalidInputError(
                    "solve_constrained: constraint(r, t) depends on t explicitly (at fixed "
                    f"positions it changes by {change:.3g} between t = {t[0]:.9g} and "
                    f"t = {time:.9g}), but time_dependent is False, which leaves out the terms in "
                    "df/dt and the motion would be wrong with f = 0 still holding. Pass "
                    "time_dependent=True for a moving constraint (a rotating hoop or wire)."
                )


def _solve_gram(A, b):
    """Solve (J W J^T) x = b, refusing a rank-deficient constraint Jacobian."""
    if A.shape[0] == 1:
        singular = not A[0, 0] > 0
    else:
        singular = np.linalg.cond(A) > 1e12
    if singular:
        raise InvalidInputError(
            "the constraint Jacobian is rank deficient (redundant or degenerate constraints, "
            "e.g. a zero gradient); drop the redundant constraints or write them so that their "
            "gradients are independent."
        )
    return np.linalg.solve(A, b)


def solve_constrained(
    masses,
    r0,
    v0,
    t,
    constraint,
    jacobian=None,
    force=None,
    *,
    time_dependent: bool = False,
    baumgarte=None,
    project: bool = True,
    method: str = "DOP853",
    rtol: float = 1e-10,
    atol: float = 1e-12,
) -> ConstrainedTrajectory:
    """Integrate particles subject to holonomic constraints f(r, t) = 0.

    Parameters
    ----------
    masses : float or (N,) array_like or Quantity
        Masses [kg], > 0.
    r0, v0 : (d,) or (N, d) array_like or Quantity
        Initial positions [m] and velocities [m/s]; they should satisfy f = 0 and f' = 0 (they
        are projected onto the constraints first when ``project`` is true).
    t : (n,) array_like or Quantity
        Strictly increasing output times [s].
    constraint : callable
        ``constraint(r, t) -> (k,)`` values of the k constraint functions (r shaped like r0).
    jacobian : callable, optional
        ``jacobian(r, t) -> (k, N*d)`` (or (k, N, d)): the gradient of each constraint with
        respect to the positions. If omitted, it is computed from ``constraint`` by central
        differences with Ridders' extrapolation (~1e-12 relative, at ~30 calls per coordinate:
        give the Jacobian when speed matters).
    force : callable, optional
        Applied force ``force(t, r, v)`` shaped like r [N]; none by default.
    time_dependent : bool
        True for rheonomic constraints (f depends on t explicitly).
    baumgarte : float, optional
        Stabilisation rate omega_s [1/s]: alpha = beta = omega_s in
        f'' + 2 alpha f' + beta^2 f = 0, so violations decay like exp(-omega_s t). Default
        10 / (t[-1] - t[0]); 0 switches stabilisation off.
    project : bool
        Project the initial state and every output sample onto f = 0, f' = 0 (default).
    method, rtol, atol
        Passed to :func:`scipy.integrate.solve_ivp`.

    Returns
    -------
    ConstrainedTrajectory
        With the multipliers, constraint forces and the remaining violation.

    Raises
    ------
    ShapeError, DomainError, InvalidInputError
        Bad shapes, non-positive masses, a singular constraint Jacobian (redundant or
        degenerate constraints).

    Notes
    -----
    With W = M^-1 the multipliers solve (J W J^T) lambda = -c - J W F - 2 alpha f' - beta^2 f
    (Goldstein 3rd ed. sec. 2.4; Baumgarte 1972). The projection minimises the mass-weighted
    correction: dr = -W J^T (J W J^T)^-1 f (Newton iterations), dv = -W J^T (J W J^T)^-1 f'.

    Examples
    --------
    A pendulum as a particle on a circle (see :func:`pendulum_constraint`):

    >>> import numpy as np
    >>> f, jac = pendulum_constraint(1.0)
    >>> g = lambda t, r, v: np.array([0.0, -9.81])
    >>> tr = solve_constrained(1.0, [1.0, 0.0], [0.0, 0.0], np.linspace(0, 1, 11), f, jac, g)
    >>> print(bool(np.max(np.abs(tr.violation)) < 1e-9))
    True
    """
    from scipy.integrate import solve_ivp

    ins = Inputs()
    r0, v0, m = particle_inputs(ins, masses, r0, v0)
    shape = r0.shape
    w = np.repeat(1.0 / m, shape[1]) if r0.ndim == 2 else np.full(r0.size, 1.0 / m)
    t = check_times(ins.get(t, "s", "t"))
    con = _Constraint(constraint, jacobian, shape, time_dependent)
    rate = 10.0 / (t[-1] - t[0]) if baumgarte is None else float(baumgarte)
    if rate < 0:
        raise InvalidInputError("baumgarte must be >= 0 (a rate in 1/s).")
    n = r0.size

    def applied(time, x, v):
        if force is None:
            return np.zeros(n)
        F = callable_result(force(time, x.reshape(shape), v.reshape(shape)), shape,
                            "force(t, r, v)", time, unit="force")
        return F.ravel()

    def multipliers(time, x, v):
        J = con.jacobian(x, time)
        F = applied(time, x, v)
        A = (J * w) @ J.T
        b = -con.curvature(x, v, time) - J @ (w * F)
        if rate:
            b = b - 2 * rate * (J @ v + con.time_derivative(x, time)) - rate**2 * con.value(x, time)
        return _solve_gram(A, b), J, F

    def rhs(time, y):
        x, v = y[:n], y[n:]
        lam, J, F = multipliers(time, x, v)
        return np.concatenate([v, w * (F + J.T @ lam)])

    def projected(x, v, time):
        for _ in range(8):
            fx = con.value(x, time)
            J = con.jacobian(x, time)
            dx = -(w[:, None] * J.T) @ _solve_gram((J * w) @ J.T, fx)
            x = x + dx
            if np.max(np.abs(dx)) <= 4 * _EPS * max(1.0, np.max(np.abs(x))):
                break
        J = con.jacobian(x, time)
        fv = J @ v + con.time_derivative(x, time)
        v = v - (w[:, None] * J.T) @ _solve_gram((J * w) @ J.T, fv)
        return x, v

    x0, u0 = r0.ravel(), v0.ravel()
    if not time_dependent:
        _refuse_hidden_time_dependence(con, x0, t)
    if project:
        x0, u0 = projected(x0, u0, t[0])
    sol = solve_ivp(
        finite_rhs(rhs, "solve_constrained"), (t[0], t[-1]), np.concatenate([x0, u0]), method=method, t_eval=t, rtol=rtol, atol=atol
    )
    if sol.status == -1:
        raise ivp_failure(sol, "solve_constrained", t[-1])
    X, V = sol.y[:n].T.copy(), sol.y[n:].T.copy()
    lams, forces, viol = [], [], []
    for i, ti in enumerate(sol.t):
        if project:
            X[i], V[i] = projected(X[i], V[i], ti)
        lam, J, _ = multipliers(ti, X[i], V[i])
        lams.append(lam)
        forces.append(J.T @ lam)
        viol.append(con.value(X[i], ti))
    nt = sol.t.size
    return ConstrainedTrajectory(
        t=sol.t,
        r=X.reshape((nt,) + shape),
        v=V.reshape((nt,) + shape),
        masses=m,
        multipliers=np.array(lams),
        constraint_forces=np.array(forces).reshape((nt,) + shape),
        violation=np.array(viol),
    )


def pendulum_constraint(length, pivot=None):
    """Constraint and Jacobian of a particle on a rigid massless rod of length L from a pivot.

    f(r) = (‖r - p‖^2 - L^2) / (2 L), with gradient (r - p)^T / L (a unit vector on the
    constraint), so the multiplier is a force: the rod pulls with J^T lambda = lambda (r - p)/L,
    i.e. the tension is T = -lambda (checked against m (g cos theta + L theta'^2)).

    Parameters
    ----------
    length : float
        L [m], > 0.
    pivot : (d,) array_like, optional
        The pivot [m]; the origin by default (any dimension).

    Returns
    -------
    (constraint, jacobian) : tuple of callables for :func:`solve_constrained`.
    """
    ins = Inputs()
    L = float(ins.get(length, "m", "length", positive=True))
    p = None if pivot is None else ins.vector(pivot, "m", "pivot", dim=None)

    def f(r, t):
        d = r - (0.0 if p is None else p)
        return np.array([(np.sum(d * d) - L * L) / (2 * L)])  # r of shape (d,) or (1, d)

    def jac(r, t):
        d = r - (0.0 if p is None else p)
        return d.reshape(1, -1) / L

    return f, jac
