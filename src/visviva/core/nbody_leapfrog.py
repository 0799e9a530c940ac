"""Leapfrog (Stoermer-Verlet, drift-kick-drift): the compiled N-body kernel.

One step of length ``h``::

    x_{1/2} = x_0 + v_0 h/2
    v_1     = v_0 + a(x_{1/2}, t + h/2) h
    x_1     = x_{1/2} + v_1 h/2

Second order, symplectic and time-reversible: running a number of steps forward and the same
number backward (``h -> -h``) returns the initial state up to round-off. Only forces that depend on
positions (and time) keep these properties; velocity-dependent forces are rejected by the wrapper.

Reference: Hairer, Lubich & Wanner, *Geometric Numerical Integration*, 2nd ed., Springer 2006,
sec. I.3.1 (Stoermer-Verlet).
"""

from __future__ import annotations

import math

from ._jit import kernel, step_kernel
from .nbody_common import (
    F_DT,
    F_DT_LAST,
    F_DT_REF,
    F_ENCOUNTER,
    F_EXIT,
    F_T,
    F_T0,
    FEW,
    I_COLLISIONS,
    I_EXACT_FINISH,
    I_FRESH,
    I_INT_VALID,
    I_K,
    I_MEGNO,
    I_NOUT,
    I_PARALLEL,
    I_STEPS,
    PAUSED,
    accelerations,
    check_events,
    run_direction,
    should_pause,
    write_output,
)
from .nbody_variational import leapfrog_tangent, megno_on
from .status import NON_FINITE, OK

__all__ = ["leapfrog_run", "leapfrog_run_few", "leapfrog_run_megno", "is_megno", "N_BUF"]

# slots of buf: acceleration, internal positions and velocities (on the step grid)
_ACC = 0
_XI = 1
_VI = 2
#: Number of (N, 3) slots in ``buf``.
N_BUF = 3


@kernel
def _dkd(x, v, m, massive, fstate, gwork, force, params, acc, t, h, parallel):
    n = x.shape[0]
    half = 0.5 * h
    for i in range(n):
        for c in range(3):
            x[i, c] += v[i, c] * half
    accelerations(t + half, x, v, m, massive, fstate, gwork, force, params, acc, parallel)
    for i in range(n):
        for c in range(3):
            v[i, c] += acc[i, c] * h
            x[i, c] += v[i, c] * half


@kernel
def leapfrog_run(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
                 out_t, out_x, out_v):
    """Advance through every output time with drift-kick-drift steps (see :func:`_leapfrog`);
    gravity by any kernel, chosen at run time (``istate[I_PARALLEL]``, N)."""
    return _leapfrog(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
                     out_t, out_x, out_v, istate[I_PARALLEL] != 0, ANY_CASE)


@kernel
def leapfrog_run_few(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
                     out_t, out_x, out_v):
    """:func:`leapfrog_run` with the serial few-body gravity alone (``FEW``; see
    :func:`visviva.core.nbody_whfast.whfast_run_few`)."""
    return _leapfrog(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
                     out_t, out_x, out_v, FEW, ANY_CASE)


#: The ``case`` argument of the run body: events chosen at run time (the general kernels) ...
ANY_CASE = None
#: ... or none compiled (:func:`leapfrog_run_megno`).
MEGNO_ONLY = True


def is_megno(istate, fstate):
    """True when a run may use :func:`leapfrog_run_megno` (plain Python, not compiled): MEGNO
    on, and none of collisions, encounters or an escape radius."""
    return ((istate[..., I_MEGNO] == 1) & (istate[..., I_COLLISIONS] == 0)
            & (fstate[..., F_ENCOUNTER] <= 0.0) & (fstate[..., F_EXIT] <= 0.0))


@kernel
def leapfrog_run_megno(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params,
                       t_out, out_t, out_x, out_v):
    """:func:`leapfrog_run_few` for a MEGNO run without events (:func:`is_megno`): the event
    checks are not compiled. The same bits; what a first MEGNO run compiles."""
    return _leapfrog(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
                     out_t, out_x, out_v, FEW, MEGNO_ONLY)


@step_kernel
def _leapfrog(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
              out_t, out_x, out_v, parallel, case):
    """Advance through every output time with drift-kick-drift steps (see the module docstring).

    The integrator's own state (``buf``) advances on the grid ``t0 + k |dt|``; an output time
    between grid points is reached by one shortened step of a COPY, so output times never change
    the trajectory (and a saved run continues bit for bit). ``x, v`` hold the state at the last
    output. Arguments as in :mod:`visviva.core.nbody_common`; returns a status code.
    """
    n = x.shape[0]
    acc = buf[_ACC]
    xi = buf[_XI]
    vi = buf[_VI]
    dt = fstate[F_DT]
    adt = abs(dt)
    exact = istate[I_EXACT_FINISH] != 0
    direction = run_direction(fstate[F_T], t_out)
    h = math.copysign(adt, direction)
    events = istate[I_COLLISIONS] != 0 or fstate[F_ENCOUNTER] > 0.0 or fstate[F_EXIT] > 0.0
    valid = istate[I_INT_VALID] != 0 and istate[I_FRESH] == 0 and fstate[F_DT_REF] == adt
    megno = megno_on(istate, buf, N_BUF)
    istate[I_FRESH] = 0
    if not valid:
        for i in range(n):
            for c in range(3):
                xi[i, c] = x[i, c]
                vi[i, c] = v[i, c]
        fstate[F_T0] = fstate[F_T]
        fstate[F_DT_REF] = adt
        istate[I_K] = 0
        istate[I_INT_VALID] = 1
    for k in range(istate[I_NOUT], t_out.shape[0]):
        target = t_out[k]
        while True:
            t_grid = fstate[F_T0] + istate[I_K] * adt
            rem = target - t_grid
            if rem * direction <= 1e-9 * adt:
                break
            if exact and rem * direction < adt * (1.0 - 1e-9):
                break  # less than a step to go: the output comes from a copy
            _dkd(xi, vi, m, massive, fstate, gwork, force, params, acc, t_grid, h, parallel)
            if megno:  # the tangent vector, after (and apart from) the physical step
                leapfrog_tangent(xi, vi, m, massive, fstate, buf, N_BUF, h)
            istate[I_K] += 1 if h > 0.0 else -1
            istate[I_STEPS] += 1
            fstate[F_DT_LAST] = h
            if case is None and events:  # (the MEGNO kernel compiles no event check)
                status = check_events(xi, vi, radius, fstate, istate)
                if status != OK:
                    for i in range(n):
                        for c in range(3):
                            x[i, c] = xi[i, c]
                            v[i, c] = vi[i, c]
                    fstate[F_T] = fstate[F_T0] + istate[I_K] * adt
                    istate[I_INT_VALID] = 0  # the caller may change the state (merge, bounce)
                    return status
            if should_pause(istate):
                for i in range(n):
                    for c in range(3):
                        x[i, c] = xi[i, c]
                        v[i, c] = vi[i, c]
                fstate[F_T] = fstate[F_T0] + istate[I_K] * adt
                return PAUSED
        t_grid = fstate[F_T0] + istate[I_K] * adt
        for i in range(n):
            for c in range(3):
                x[i, c] = xi[i, c]
                v[i, c] = vi[i, c]
        rem = target - t_grid
        if exact and rem * direction > 1e-9 * adt:
            _dkd(x, v, m, massive, fstate, gwork, force, params, acc, t_grid, rem, parallel)
        fstate[F_T] = target if exact else t_grid
        for i in range(n):
            for c in range(3):
                if not (math.isfinite(x[i, c]) and math.isfinite(v[i, c])):
                    istate[I_INT_VALID] = 0
                    return NON_FINITE  # overflow or a singular force: report, never continue
        write_output(k, fstate[F_T], x, v, out_t, out_x, out_v)
        istate[I_NOUT] = k + 1
    return OK
