"""Lagrangian mechanics: Euler-Lagrange equations from L(q, q', t) written in sympy.

The equations are derived by :class:`sympy.physics.mechanics.LagrangesMethod` (no symbolic engine
of our own) in the form M(q, q', t) q'' = f(q, q', t), and compiled once with
:func:`sympy.lambdify` into a numeric right-hand side for :func:`scipy.integrate.solve_ivp`.
sympy (the ``mechanics`` extra) is imported only when these tools are used.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import InvalidInputError, ShapeError
from ._inputs import (
    Inputs,
    callable_result,
    finite_rhs,
    ivp_failure,
    ivp_method,
    model_parameters,
    si_array,
)

__all__ = [
    "LagrangianSystem",
    "LagrangianTrajectory",
    "pendulum",
    "double_pendulum",
    "spring_pendulum",
    "central_potential",
]


def _sympy():
    try:
        import sympy
        from sympy.physics import mechanics
    except ImportError as exc:  # pragma: no cover - sympy is in the mechanics extra
        raise ImportError(
            "the Lagrangian tools need sympy: pip install 'visviva[mechanics]'"
        ) from exc
    return sympy, mechanics


@dataclass(frozen=True)
class LagrangianTrajectory:
    """Generalised coordinates and velocities at output times.

    Attributes
    ----------
    t : (n,) ndarray
    q : (n, dof) ndarray
    qdot : (n, dof) ndarray
    system : LagrangianSystem
    """

    t: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    system: LagrangianSystem

    @cached_property
    def energy(self) -> np.ndarray:
        """(n,) the energy function h = sum q' dL/dq' - L (conserved when L has no explicit t)."""
        return self.system.energy(self.q, self.qdot, self.t)


class LagrangianSystem:
    """A mechanical system given by its Lagrangian.

    Parameters
    ----------
    lagrangian : sympy expression
        L(q, q', t) in terms of ``coordinates`` (sympy ``dynamicsymbols``), their first time
        derivatives, the time symbol ``sympy.physics.mechanics.dynamicsymbols._t`` and
        parameters.
    coordinates : sequence of sympy dynamicsymbols
        The generalised coordinates q_1 ... q_n.
    parameters : dict, optional
        Numerical values for every other symbol in L, ``{symbol: value}``; plain numbers in any
        consistent units, or Quantities (converted to SI).
    forces : callable, optional
        Generalised non-conservative forces ``Q(t, q, qdot) -> (n,)`` added to the right-hand
        side: d/dt dL/dq' - dL/dq = Q.

    Attributes
    ----------
    equations : sympy Matrix
        The Euler-Lagrange expressions d/dt(dL/dq') - dL/dq (each = 0 on the motion).
    mass_matrix, forcing : sympy Matrix
        M and f with M q'' = f.

    Notes
    -----
    Goldstein, Poole & Safko, *Classical Mechanics*, 3rd ed., sec. 1.4 and 2.3; sympy's
    LagrangesMethod (Kane & Levinson style mechanics module). The numeric right-hand side
    solves M q'' = f + Q at each call (M is symmetric positive definite for a natural system).

    Examples
    --------
    >>> import sympy as sp
    >>> from sympy.physics.mechanics import dynamicsymbols
    >>> x = dynamicsymbols("x")
    >>> m, k = sp.symbols("m k", positive=True)
    >>> sys = LagrangianSystem(m * x.diff() ** 2 / 2 - k * x**2 / 2, [x], {m: 1.0, k: 4.0})
    >>> sys.equations[0]
    k*x(t) + m*Derivative(x(t), (t, 2))
    >>> tr = sys.simulate([1.0], [0.0], [0.0, 3.141592653589793])
    >>> print(f"{tr.q[-1, 0]:.8f}")
    1.00000000
    """

    def __init__(self, lagrangian, coordinates, parameters=None, forces=None):
        sp, me = _sympy()
        self.lagrangian = sp.sympify(lagrangian)
        self.coordinates = list(coordinates)
        if not self.coordinates:
            raise InvalidInputError("coordinates must list at least one generalised coordinate.")
        self.parameters = model_parameters(self.lagrangian, parameters, "the Lagrangian")
        self.forces = forces
        self.time = me.dynamicsymbols._t
        self.dof = len(self.coordinates)
        method = me.LagrangesMethod(self.lagrangian, self.coordinates)
        self.equations = method.form_lagranges_equations()
        self.mass_matrix = method.mass_matrix
        self.forcing = method.forcing
        speeds = [q.diff(self.time) for q in self.coordinates]
        self.energy_expression = sum(u * self.lagrangian.diff(u) for u in speeds) - self.lagrangian
        self._q = sp.symbols(f"q0:{self.dof}")
        self._u = sp.symbols(f"u0:{self.dof}")
        self._speeds = speeds

    def _plain(self, expr):
        """Replace q(t), q'(t) by plain symbols and substitute the parameter values."""
        sp, _ = _sympy()
        expr = expr.subs(dict(zip(self._speeds, self._u, strict=True)))
        expr = expr.subs(dict(zip(self.coordinates, self._q, strict=True)))
        expr = expr.subs(self.parameters)
        free = expr.free_symbols - set(self._q) - set(self._u) - {self.time}
        if free:
            names = ", ".join(sorted(str(s) for s in free))
            raise InvalidInputError(
                f"the Lagrangian has symbols without values: {names}. Pass them in "
                "parameters={symbol: value}."
            )
        return sp.sympify(expr)

    @cached_property
    def _compiled(self):
        sp, _ = _sympy()
        args = [self.time, *self._q, *self._u]
        M = self._plain(self.mass_matrix)
        f = self._plain(self.forcing)
        # scalar evaluation: the math module is several times faster than numpy per call
        fn = sp.lambdify(args, [M.tolist(), list(f)], modules="math", cse=True)
        energy = sp.lambdify(args, self._plain(self.energy_expression), modules="numpy", cse=True)
        return fn, energy

    def rhs(self, t, y):
        """Numeric right-hand side for solve_ivp: y = (q, q'), returns (q', q'')."""
        fn, _ = self._compiled
        n = self.dof
        M, f = fn(t, *y.tolist())
        if self.forces is not None:
            Q = callable_result(self.forces(t, y[:n], y[n:]), (n,), "forces(t, q, qdot)", t)
            f = [fi + Qi for fi, Qi in zip(f, Q.tolist(), strict=True)]
        out = np.empty(2 * n)
        out[:n] = y[n:]
        if n == 1:
            out[1] = f[0] / M[0][0]
        elif n == 2:  # Cramer's rule: cheaper than a LAPACK call for 2 x 2
            det = M[0][0] * M[1][1] - M[0][1] * M[1][0]
            out[2] = (f[0] * M[1][1] - M[0][1] * f[1]) / det
            out[3] = (M[0][0] * f[1] - M[1][0] * f[0]) / det
        else:
            out[n:] = np.linalg.solve(np.array(M, dtype=float), np.array(f, dtype=float))
        return out

    def energy(self, q, qdot, t=0.0):
        """Energy function h = sum q' dL/dq' - L at arrays q, qdot of shape (..., dof)."""
        _, energy = self._compiled
        q = si_array(q, "q", finite=True)
        qdot = si_array(qdot, "qdot", finite=True)
        out = energy(t, *np.moveaxis(q, -1, 0), *np.moveaxis(qdot, -1, 0))
        return np.broadcast_to(np.asarray(out, dtype=float), q.shape[:-1]).copy()

    def simulate(
        self,
        q0,
        qdot0,
        t,
        *,
        method: str = "DOP853",
        rtol: float = 1e-12,
        atol: float = 1e-12,
    ) -> LagrangianTrajectory:
        """Integrate from (q0, q'0) at ``t[0]`` and sample at the increasing times ``t``.

        Parameters
        ----------
        q0, qdot0 : (dof,) array_like or Quantity
            Initial coordinates and velocities: plain numbers in the units of the parameters
            (angles in radians), or Quantities, converted to SI (``30 * u.deg`` is 0.5236 rad,
            ``u.deg / u.s`` becomes rad/s).
        t : (n,) array_like or Quantity
            Output times (a Quantity is converted to s); integration from t[0]. The trajectory
            holds plain SI numbers.
        method, rtol, atol
            solve_ivp settings (default DOP853 with tight tolerances 1e-12).
        """
        from scipy.integrate import solve_ivp

        q0 = np.atleast_1d(si_array(q0, "q0"))
        qdot0 = np.atleast_1d(si_array(qdot0, "qdot0"))
        if q0.shape != (self.dof,) or qdot0.shape != (self.dof,):
            raise ShapeError(f"q0 and qdot0 must have shape ({self.dof},).")
        t = np.atleast_1d(si_array(t, "t"))
        if t.ndim != 1 or t.size < 2 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise InvalidInputError("t must hold at least 2 finite, strictly increasing times.")
        if not (np.all(np.isfinite(q0)) and np.all(np.isfinite(qdot0))):
            raise InvalidInputError("q0 and qdot0 must be finite.")
        method = ivp_method(method, "LagrangianSystem.simulate")
        sol = solve_ivp(
            finite_rhs(self.rhs, "LagrangianSystem.simulate"),
            (t[0], t[-1]),
            np.concatenate([q0, qdot0]),
            method=method,
            t_eval=t,
            rtol=rtol,
            atol=atol,
        )
        if sol.status == -1:
            raise ivp_failure(sol, "LagrangianSystem.simulate", t[-1])
        n = self.dof
        return LagrangianTrajectory(sol.t, sol.y[:n].T.copy(), sol.y[n:].T.copy(), self)


def _symbolic_potential(potential, r, sp):
    """``potential(r)`` for the sympy function r(t), checked to be a sympy expression."""
    try:
        V = sp.sympify(potential(r), strict=True)
    except (TypeError, AttributeError, sp.SympifyError) as exc:
        raise InvalidInputError(
            f"central_potential: potential(r) failed on the sympy symbol r ({type(exc).__name__}: "
            f"{exc}). It must build a sympy expression: use sympy functions (sympy.exp, "
            "sympy.log), not numpy or math ones, e.g. lambda r: -sympy.exp(-r) / r."
        ) from exc
    if not isinstance(V, sp.Expr):
        raise InvalidInputError(
            f"central_potential: potential(r) must return a sympy expression; got {V!r}."
        )
    return V


def _physical(value, unit: str, name: str, *, positive: bool = True) -> float:
    """A finite scalar parameter of a ready-made system, in SI (> 0, or >= 0 for g)."""
    arr = Inputs().get(value, unit, name, positive=positive, nonnegative=not positive)
    if arr.size != 1:
        raise ShapeError(f"{name} must be a scalar; got shape {arr.shape}.")
    return float(arr.reshape(()))


def pendulum(m=1.0, length=1.0, g=9.81) -> LagrangianSystem:
    """Simple pendulum, L = m l^2 theta'^2 / 2 + m g l cos(theta) (theta from the downward vertical)."""
    sp, me = _sympy()
    th = me.dynamicsymbols("theta")
    M, ell, gg = sp.symbols("m l g", positive=True)
    L = M * ell**2 * th.diff() ** 2 / 2 + M * gg * ell * sp.cos(th)
    return LagrangianSystem(L, [th], {
        M: _physical(m, "kg", "m"),
        ell: _physical(length, "m", "length"),
        gg: _physical(g, "accel", "g", positive=False),
    })


def double_pendulum(m1=1.0, m2=1.0, l1=1.0, l2=1.0, g=9.81) -> LagrangianSystem:
    """Planar double pendulum with point masses, angles theta1, theta2 from the downward vertical.

    L = (m1 + m2) l1^2 th1'^2 / 2 + m2 l2^2 th2'^2 / 2 + m2 l1 l2 th1' th2' cos(th1 - th2)
        + (m1 + m2) g l1 cos(th1) + m2 g l2 cos(th2)   (Goldstein 3rd ed., ex. 1.x; Taylor 11.4)
    """
    sp, me = _sympy()
    t1, t2 = me.dynamicsymbols("theta1 theta2")
    M1, M2, L1, L2, gg = sp.symbols("m1 m2 l1 l2 g", positive=True)
    w1, w2 = t1.diff(), t2.diff()
    T = (M1 + M2) * L1**2 * w1**2 / 2 + M2 * L2**2 * w2**2 / 2
    T += M2 * L1 * L2 * w1 * w2 * sp.cos(t1 - t2)
    V = -(M1 + M2) * gg * L1 * sp.cos(t1) - M2 * gg * L2 * sp.cos(t2)
    return LagrangianSystem(T - V, [t1, t2], {
        M1: _physical(m1, "kg", "m1"),
        M2: _physical(m2, "kg", "m2"),
        L1: _physical(l1, "m", "l1"),
        L2: _physical(l2, "m", "l2"),
        gg: _physical(g, "accel", "g", positive=False),
    })


def spring_pendulum(m=1.0, k=10.0, rest_length=1.0, g=9.81) -> LagrangianSystem:
    """Elastic pendulum in polar coordinates (r, theta from the downward vertical).

    L = m (r'^2 + r^2 theta'^2) / 2 - k (r - l0)^2 / 2 + m g r cos(theta).
    """
    sp, me = _sympy()
    r, th = me.dynamicsymbols("r theta")
    M, K, l0, gg = sp.symbols("m k l0 g", positive=True)
    L = M * (r.diff() ** 2 + r**2 * th.diff() ** 2) / 2 - K * (r - l0) ** 2 / 2
    L += M * gg * r * sp.cos(th)
    return LagrangianSystem(L, [r, th], {
        M: _physical(m, "kg", "m"),
        K: _physical(k, "stiffness", "k"),
        l0: _physical(rest_length, "m", "rest_length", positive=False),
        gg: _physical(g, "accel", "g", positive=False),
    })


def central_potential(potential=None, m=1.0, k=1.0) -> LagrangianSystem:
    """Particle in a central potential, polar coordinates (r, phi).

    L = m (r'^2 + r^2 phi'^2) / 2 - V(r). ``potential`` is a callable taking the sympy symbol r
    and returning V(r) as a sympy expression; default the Kepler potential V = -k / r.
    The conjugate momentum of phi, m r^2 phi', is conserved (phi is cyclic).
    """
    sp, me = _sympy()
    r, ph = me.dynamicsymbols("r phi")
    M, K = sp.symbols("m k", positive=True)
    V = -K / r if potential is None else _symbolic_potential(potential, r, sp)
    L = M * (r.diff() ** 2 + r**2 * ph.diff() ** 2) / 2 - V
    k = Inputs().get(k, "energy_length", "k")  # any sign: attractive (> 0) or repulsive
    return LagrangianSystem(L, [r, ph], {M: _physical(m, "kg", "m"), K: float(k)})
