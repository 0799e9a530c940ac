"""Step plans of the GPU runs of fixed-step integrators, made on the host with the CPU kernels'
expressions (so the step grid, the time origin and the shortened last step to an output time
are the CPU kernels'): :func:`plan` for one leapfrog simulation, :func:`plan_many` for the
packed members of a leapfrog ensemble, and :func:`count_steps`, the stopping rule they and the
WHFast ensembles (:mod:`visviva.nbody.gpu_ensemble_whfast`) share.
"""

from __future__ import annotations

import math

import numpy as np

from ..core import nbody_common as _nc

__all__ = ["plan", "plan_many", "count_steps", "put"]

# slots of the leapfrog's buf (see visviva.core.nbody_leapfrog)
_XI, _VI = 1, 2


def plan(state: dict, target: float):
    """Prepare the leapfrog's internal state and count the steps to ``target``, exactly as
    :func:`visviva.core.nbody_leapfrog.leapfrog_run` does.

    Parameters
    ----------
    state : dict
        The simulation's live arrays (:meth:`visviva.Simulation.state_arrays`); ``fstate``,
        ``istate`` and (when the internal state restarts) ``buf`` are updated.
    target : float
        Absolute output time (simulation units).

    Returns
    -------
    n : int
        Full steps of the internal state.
    h : float
        Their signed length (time).
    rem : float
        Length of the shortened last step of the output copy (0: none).
    t_final : float
        The time reached.
    """
    fstate, istate, buf = state["fstate"], state["istate"], state["buf"]
    adt = abs(float(fstate[_nc.F_DT]))
    exact = istate[_nc.I_EXACT_FINISH] != 0
    direction = 1.0 if target >= fstate[_nc.F_T] else -1.0
    h = math.copysign(adt, direction)
    valid = (istate[_nc.I_INT_VALID] != 0 and istate[_nc.I_FRESH] == 0
             and fstate[_nc.F_DT_REF] == adt)
    istate[_nc.I_FRESH] = 0
    if not valid:
        buf[_XI] = state["x"]
        buf[_VI] = state["v"]
        fstate[_nc.F_T0] = fstate[_nc.F_T]
        fstate[_nc.F_DT_REF] = adt
        istate[_nc.I_K] = 0
        istate[_nc.I_INT_VALID] = 1
    t0, k0 = float(fstate[_nc.F_T0]), int(istate[_nc.I_K])
    sign = 1 if h > 0.0 else -1

    def stops(j):
        rem = target - (t0 + (k0 + sign * j) * adt)
        return rem * direction <= 1e-9 * adt or (exact and rem * direction < adt * (1.0 - 1e-9))

    n = max(0, int((target - (t0 + k0 * adt)) * direction / adt) - 2)
    while n > 0 and stops(n - 1):
        n -= 1
    while not stops(n):
        n += 1
    t_grid = t0 + (k0 + sign * n) * adt
    rem = target - t_grid
    rem = rem if exact and rem * direction > 1e-9 * adt else 0.0
    return n, h, rem, (target if exact else t_grid)


def plan_many(fstate, istate, target: float):
    """:func:`plan` for many members at once (rows of ``fstate``/``istate``), with the same
    expressions element by element; returns ``(n, h, rem, t_final, restart)``, ``restart``
    marking the members whose internal state must be set from their output state."""
    adt = np.abs(fstate[:, _nc.F_DT])
    exact = istate[:, _nc.I_EXACT_FINISH] != 0
    direction = np.where(target >= fstate[:, _nc.F_T], 1.0, -1.0)
    h = np.copysign(adt, direction)
    fresh = istate[:, _nc.I_FRESH] != 0
    restart = ~((istate[:, _nc.I_INT_VALID] != 0) & ~fresh & (fstate[:, _nc.F_DT_REF] == adt))
    put(istate[:, _nc.I_FRESH], fresh, 0)
    if restart.any():
        fstate[restart, _nc.F_T0] = fstate[restart, _nc.F_T]
        fstate[restart, _nc.F_DT_REF] = adt[restart]
        istate[restart, _nc.I_K] = 0
        istate[restart, _nc.I_INT_VALID] = 1
    n, t_grid = count_steps(target, fstate[:, _nc.F_T0], istate[:, _nc.I_K], adt, direction,
                            exact)
    rem = target - t_grid
    rem = np.where(exact & (rem * direction > 1e-9 * adt), rem, 0.0)
    return n, h, rem, np.where(exact, target, t_grid), restart


def put(column, rows, values) -> None:
    """``column[rows] = values[rows]`` (``values`` an array over the members, or one number),
    written as a whole column when every row is chosen and skipped when none is (a column of
    a pack's ``fstate``/``istate`` is a strided view: each pass over it costs)."""
    if rows.all():
        column[:] = values
    elif rows.any():
        column[rows] = values[rows] if np.ndim(values) else values


def count_steps(target: float, t0, k0, adt, direction, exact):
    """Full steps each member takes from grid point ``t0 + k0 |dt|`` towards ``target``, with
    the stopping rule of the CPU kernels' fixed-step loops (the grid point reached is at or
    past the target, or, with ``exact``, less than a step before it); element by element over
    members. Returns the steps ``n`` (int64) and the grid time reached ``t0 + (k0 +- n) |dt|``.

    Members on one grid (the same ``t0, k0, |dt|``, direction and ``exact``: an ensemble's
    usual state) are counted once, with the same expressions, and the answer repeated.
    """
    if len(t0) > 1 and all(bool(np.all(a == a[0])) for a in (t0, k0, adt, direction, exact)):
        n, t_grid = count_steps(target, t0[:1], k0[:1], adt[:1], direction[:1], exact[:1])
        return np.full(len(t0), n[0]), np.full(len(t0), t_grid[0])
    sign = np.where(direction > 0.0, 1, -1)

    def stops(j):
        rem = target - (t0 + (k0 + sign * j) * adt)
        return (rem * direction <= 1e-9 * adt) | (exact & (rem * direction < adt * (1.0 - 1e-9)))

    n = np.maximum(0, np.trunc((target - (t0 + k0 * adt)) * direction / adt).astype(np.int64) - 2)
    while (back := (n > 0) & stops(np.maximum(n - 1, 0))).any():
        n -= back
    while (ahead := ~stops(n)).any():
        n += ahead
    return n, t0 + (k0 + sign * n) * adt
