"""WHFast: the Wisdom-Holman map in Jacobi coordinates, the compiled N-body kernel.

Written from Wisdom & Holman (1991) and Rein & Tamayo (2015). With ``eta_i = m_0 + ... + m_i``,
the Jacobi coordinates are

    x'_i = x_i - X_{i-1},   X_{i-1} = (m_0 x_0 + ... + m_{i-1} x_{i-1}) / eta_{i-1}   (i >= 1)

and ``x'_0`` = the centre of mass (the same for velocities and accelerations). The motion of
``x'_i`` is split into a Kepler problem with ``GM_i = G eta_i`` plus the interaction

    dv'_i/dt = a'_i + G eta_i x'_i / |x'_i|**3

which depends on positions only (``a'_i`` is the Jacobi transform of the full accelerations,
gravity plus position-dependent additional forces). One step of length ``h`` is drift-kick-drift::

    Kepler(h/2) -> interaction kick(h) -> Kepler(h/2)

with every Kepler drift solved exactly by the universal-variable kernel
:func:`visviva.core.universal.propagate_scalar` (any conic), and the centre of mass moving on a
straight line. Between outputs the half drifts of consecutive steps are fused (one Kepler
solve per body per step); the internal state is saved with the simulation, so runs can be
stopped, saved and resumed bit for bit. For two bodies the interaction vanishes and the map
is exact to round-off at any step size. Second order, symplectic, time-reversible.

References
----------
Wisdom, J. & Holman, M. (1991), "Symplectic maps for the N-body problem", AJ 102, 1528.
Rein, H. & Tamayo, D. (2015), "WHFAST: a fast and unbiased implementation of a symplectic
Wisdom-Holman integrator for long-term gravitational simulations", MNRAS 452, 376.
"""

from __future__ import annotations

import math

from ._jit import kernel
from .nbody_common import (
    F_DT,
    F_DT_LAST,
    F_ENCOUNTER,
    F_EXIT,
    F_G,
    F_T,
    F_WH_H,
    I_COLLISIONS,
    I_EXACT_FINISH,
    I_FRESH,
    I_NOUT,
    I_STEPS,
    I_WH_VALID,
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
from .universal import propagate_scalar

__all__ = ["whfast_run", "to_jacobi", "from_jacobi", "N_BUF"]

# slots of buf: Jacobi positions, Jacobi velocities, inertial accelerations, Jacobi accelerations,
# (slot 4, column 0) the cumulative masses eta_i, and scratch copies for synchronising
_XJ = 0
_VJ = 1
_ACC = 2
_AJ = 3
_ETA = 4
_XS = 5
_VS = 6
#: Number of (N, 3) slots in ``buf``.
N_BUF = 7


@kernel
def to_jacobi(x, m, eta, xj):
    """Inertial -> Jacobi (positions, velocities or accelerations alike); ``xj[0]`` = COM.

    With ``X_0 = x_0``: ``x'_i = x_i - X_{i-1}``, ``X_i = X_{i-1} + (m_i / eta_i) x'_i``. The
    inverse :func:`from_jacobi` undoes the same operations in reverse order, so the round trip is
    free of a systematic scale error (two separately rounded factors ``eta_{i-1}/eta_i`` and
    ``m_i/eta_i`` whose sum is not exactly 1 would shrink or stretch the relative motion every
    step and make the energy drift).
    """
    n = x.shape[0]
    Xx = x[0, 0]
    Xy = x[0, 1]
    Xz = x[0, 2]
    for i in range(1, n):
        dx = x[i, 0] - Xx
        dy = x[i, 1] - Xy
        dz = x[i, 2] - Xz
        xj[i, 0] = dx
        xj[i, 1] = dy
        xj[i, 2] = dz
        q = m[i] / eta[i]
        Xx += q * dx
        Xy += q * dy
        Xz += q * dz
    xj[0, 0] = Xx
    xj[0, 1] = Xy
    xj[0, 2] = Xz


@kernel
def from_jacobi(xj, m, eta, x):
    """Jacobi -> inertial: ``X_{i-1} = X_i - (m_i / eta_i) x'_i``, ``x_i = X_{i-1} + x'_i``."""
    n = x.shape[0]
    Xx = xj[0, 0]
    Xy = xj[0, 1]
    Xz = xj[0, 2]
    for i in range(n - 1, 0, -1):
        q = m[i] / eta[i]
        Xx -= q * xj[i, 0]
        Xy -= q * xj[i, 1]
        Xz -= q * xj[i, 2]
        x[i, 0] = Xx + xj[i, 0]
        x[i, 1] = Xy + xj[i, 1]
        x[i, 2] = Xz + xj[i, 2]
    x[0, 0] = Xx
    x[0, 1] = Xy
    x[0, 2] = Xz


@kernel
def _kepler_drift(xj, vj, eta, G, h):
    n = xj.shape[0]
    for c in range(3):
        xj[0, c] += vj[0, c] * h
    for i in range(1, n):
        st, x, y, z, vx, vy, vz = propagate_scalar(
            xj[i, 0], xj[i, 1], xj[i, 2], vj[i, 0], vj[i, 1], vj[i, 2], G * eta[i], h
        )
        if st != OK:
            return st
        xj[i, 0] = x
        xj[i, 1] = y
        xj[i, 2] = z
        vj[i, 0] = vx
        vj[i, 1] = vy
        vj[i, 2] = vz
    return OK


@kernel
def _interaction_kick(xj, vj, aj, eta, G, h):
    n = xj.shape[0]
    for c in range(3):
        vj[0, c] += aj[0, c] * h
    for i in range(1, n):
        r2 = xj[i, 0] * xj[i, 0] + xj[i, 1] * xj[i, 1] + xj[i, 2] * xj[i, 2]
        k = G * eta[i] / (r2 * math.sqrt(r2))
        for c in range(3):
            vj[i, c] += (aj[i, c] + k * xj[i, c]) * h


@kernel
def _synchronise(xj, vj, xs, vs, m, eta, G, half, x, v):
    """Inertial ``x, v`` from the internal state: a copy drifted by the last half step."""
    n = xj.shape[0]
    for i in range(n):
        for c in range(3):
            xs[i, c] = xj[i, c]
            vs[i, c] = vj[i, c]
    st = _kepler_drift(xs, vs, eta, G, half)
    from_jacobi(xs, m, eta, x)
    from_jacobi(vs, m, eta, v)
    return st


@kernel
def whfast_run(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
               out_t, out_x, out_v):
    """Advance through every output time with Wisdom-Holman steps (see the module docstring).

    Particle 0 must have mass (the central body). Output times that are not a whole number of
    steps away are reached with one shortened (synchronised) step.

    Without event detection the half drifts of consecutive steps are fused: the internal state
    ``P`` (Jacobi coordinates just after a kick, kept in ``buf``) advances by
    ``P <- Kick(h) Kepler(h) P``, and the inertial ``x, v`` at an output are a synchronised COPY,
    ``Kepler(h/2) P``. The internal trajectory therefore does not depend on the output times,
    and saving ``buf`` lets a loaded run continue bit for bit. With collisions, encounters or an
    escape radius every step is synchronised (events are checked on the true state).
    Arguments as in :mod:`visviva.core.nbody_common`; returns a status code.
    """
    n = x.shape[0]
    G = fstate[F_G]
    xj = buf[_XJ]
    vj = buf[_VJ]
    acc = buf[_ACC]
    aj = buf[_AJ]
    xs = buf[_XS]
    vs = buf[_VS]
    eta = buf[_ETA, :, 0]
    s = 0.0
    for i in range(n):
        s += m[i]
        eta[i] = s
    dt = fstate[F_DT]
    adt = abs(dt)
    exact = istate[I_EXACT_FINISH] != 0
    start_clock(fstate, istate)
    direction = run_direction(fstate[F_T], t_out)
    fast = istate[I_COLLISIONS] == 0 and fstate[F_ENCOUNTER] <= 0.0 and fstate[F_EXIT] <= 0.0
    valid = istate[I_WH_VALID] != 0 and istate[I_FRESH] == 0
    istate[I_FRESH] = 0
    need_sync = False
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
            if fast and abs(h) == adt:
                if valid and fstate[F_WH_H] == h:
                    st = _kepler_drift(xj, vj, eta, G, h)
                else:
                    if need_sync:  # (direction changed) synchronise before rebuilding
                        st = _synchronise(xj, vj, xs, vs, m, eta, G, 0.5 * fstate[F_WH_H], x, v)
                        if st != OK:
                            return st
                    to_jacobi(x, m, eta, xj)
                    to_jacobi(v, m, eta, vj)
                    st = _kepler_drift(xj, vj, eta, G, half)
                    fstate[F_WH_H] = h
                    valid = True
                if st != OK:
                    return st
                from_jacobi(xj, m, eta, x)  # mid-step positions (x is scratch until synced)
                accelerations(t + half, x, v, m, massive, fstate, istate, gwork, force, params,
                              acc)
                to_jacobi(acc, m, eta, aj)
                _interaction_kick(xj, vj, aj, eta, G, h)
                need_sync = True
            else:
                if need_sync:
                    st = _synchronise(xj, vj, xs, vs, m, eta, G, 0.5 * fstate[F_WH_H], x, v)
                    if st != OK:
                        return st
                    need_sync = False
                valid = False
                to_jacobi(x, m, eta, xj)
                to_jacobi(v, m, eta, vj)
                st = _kepler_drift(xj, vj, eta, G, half)
                if st != OK:
                    return st
                from_jacobi(xj, m, eta, x)
                accelerations(t + half, x, v, m, massive, fstate, istate, gwork, force, params,
                              acc)
                to_jacobi(acc, m, eta, aj)
                _interaction_kick(xj, vj, aj, eta, G, h)
                st = _kepler_drift(xj, vj, eta, G, half)
                if st != OK:
                    return st
                from_jacobi(xj, m, eta, x)
                from_jacobi(vj, m, eta, v)
            advance_clock(fstate, istate, h, last, exact, target)
            fstate[F_DT_LAST] = h
            istate[I_STEPS] += 1
            if not fast:
                status = check_events(x, v, radius, fstate, istate)
                if status != OK:
                    istate[I_WH_VALID] = 0
                    return status
            if last:
                break
            if should_pause(istate):
                if need_sync:
                    st = _synchronise(xj, vj, xs, vs, m, eta, G, 0.5 * fstate[F_WH_H], x, v)
                    if st != OK:
                        return st
                istate[I_WH_VALID] = 1 if valid else 0
                return PAUSED
        if need_sync:
            st = _synchronise(xj, vj, xs, vs, m, eta, G, 0.5 * fstate[F_WH_H], x, v)
            if st != OK:
                return st
            need_sync = False
        write_output(k, fstate[F_T], x, v, out_t, out_x, out_v)
        istate[I_NOUT] = k + 1
    istate[I_WH_VALID] = 1 if valid else 0
    return OK
