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

from ._jit import kernel
from .nbody_common import (
    F_DT,
    F_DT_LAST,
    F_T,
    I_EXACT_FINISH,
    I_NOUT,
    I_STEPS,
    PAUSED,
    accelerations,
    advance_clock,
    check_events,
    next_fixed_step,
    run_direction,
    should_pause,
    start_clock,
    write_output,
)
from .status import OK

__all__ = ["leapfrog_run", "N_BUF"]

#: Slots of ``buf``: 0 = acceleration.
N_BUF = 1


@kernel
def leapfrog_run(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
                 out_t, out_x, out_v):
    """Advance through every output time with drift-kick-drift steps (see the module docstring).

    Arguments as in :mod:`visviva.core.nbody_common`; returns a status code.
    """
    n = x.shape[0]
    acc = buf[0]
    dt = fstate[F_DT]
    exact = istate[I_EXACT_FINISH] != 0
    start_clock(fstate, istate)
    direction = run_direction(fstate[F_T], t_out)
    for k in range(istate[I_NOUT], t_out.shape[0]):
        target = t_out[k]
        while True:
            t = fstate[F_T]
            h, last = next_fixed_step(t, target, dt, exact, direction)
            if h == 0.0:
                if exact and fstate[F_T] != target:
                    advance_clock(fstate, istate, 0.0, True, True, target)
                break
            half = 0.5 * h
            for i in range(n):
                for c in range(3):
                    x[i, c] += v[i, c] * half
            accelerations(t + half, x, v, m, massive, fstate, istate, gwork, force, params, acc)
            for i in range(n):
                for c in range(3):
                    v[i, c] += acc[i, c] * h
                    x[i, c] += v[i, c] * half
            advance_clock(fstate, istate, h, last, exact, target)
            fstate[F_DT_LAST] = h
            istate[I_STEPS] += 1
            status = check_events(x, v, radius, fstate, istate)
            if status != OK:
                return status
            if last:
                break
            if should_pause(istate):
                return PAUSED
        write_output(k, fstate[F_T], x, v, out_t, out_x, out_v)
        istate[I_NOUT] = k + 1
    return OK
