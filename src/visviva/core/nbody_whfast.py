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

Democratic heliocentric coordinates (``istate[I_WH_COORDINATES] = 1``; Duncan, Levison & Lee
1998): heliocentric positions ``Q_i = x_i - x_0`` and barycentric velocities
``V_i = v_i - V_cm`` (``i >= 1``; row 0 holds the centre of mass), in which

    H = sum_i [ p_i**2 / (2 m_i) - G m_0 m_i / |Q_i| ]        Kepler, GM = G m_0 for every body
      + |sum_i p_i|**2 / (2 m_0)                             jump: dQ_i/dt = sum_j m_j V_j / m_0
      - sum_{0<i<j} G m_i m_j / |Q_i - Q_j|                  interaction: planets only

and one step is ``Kepler(h/2) Jump(h/2) Interaction(h) Jump(h/2) Kepler(h/2)`` (the order REBOUND
5.2 uses for ``coordinates="democraticheliocentric"``; fused between outputs into
``Interaction(h) Jump(h/2) Kepler(h) Jump(h/2)``). The interaction kick adds the additional
(position-dependent) force minus its barycentric mean, which also moves the centre of mass. The
jump term does not vanish for one planet, so the two-body map is NOT exact: its energy error is
bounded, O((m_1/m_0) (h/P)**2), without drift. The symplectic correctors are derived for the
two-part Jacobi splitting and are not used with these coordinates.

References
----------
Wisdom, J. & Holman, M. (1991), "Symplectic maps for the N-body problem", AJ 102, 1528.
Rein, H. & Tamayo, D. (2015), "WHFAST: a fast and unbiased implementation of a symplectic
Wisdom-Holman integrator for long-term gravitational simulations", MNRAS 452, 376.
Duncan, M. J., Levison, H. F. & Lee, M. H. (1998), "A multiple time step symplectic algorithm
for integrating close encounters", AJ 116, 2067.
Rein, H., Tamayo, D. & Brown, G. (2019), "High-order symplectic integrators for planetary
dynamics and their implementation in REBOUND", MNRAS 489, 4632.
"""

from __future__ import annotations

import math

from ._jit import kernel, step_kernel
from .gravity import FEW, gravity
from .nbody_common import (
    F_DT,
    F_DT_LAST,
    F_DT_REF,
    F_ENCOUNTER,
    F_EXIT,
    F_G,
    F_SOFT2,
    F_T,
    F_T0,
    F_WATCH_A2,
    F_WATCH_BODY,
    F_WATCH_RHO2,
    F_WATCH_T,
    F_WH_H,
    I_COLLISIONS,
    I_CORRECTOR,
    I_EXACT_FINISH,
    I_FRESH,
    I_K,
    I_MEGNO,
    I_NOUT,
    I_PARALLEL,
    I_STEPS,
    I_WH_COORDINATES,
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
from .nbody_variational import megno_on
from .nbody_wh_maps import (
    dh_interaction_kick,
    drift,
    from_democratic_heliocentric,
    from_internal,
    from_jacobi,
    interaction_kick,
    jump,
    kepler_drift,
    to_democratic_heliocentric,
    to_internal,
    to_jacobi,
)
from .nbody_wh_tangent import whfast_tangent, whfast_tangent_start
from .status import OK
from .wh_corrector import CORRECTOR_A, CORRECTOR_B

# the step's maps under the names this module's run body (and its GPU twins and tests, as
# ``nbody_whfast._name``) have always used
_to_internal = to_internal
_from_internal = from_internal
_kepler_drift = kepler_drift
_jump = jump
_drift = drift
_interaction_kick = interaction_kick
_dh_interaction_kick = dh_interaction_kick

__all__ = [
    "whfast_run",
    "whfast_run_few",
    "whfast_run_plain",
    "whfast_run_megno",
    "is_plain",
    "is_megno",
    "to_jacobi",
    "from_jacobi",
    "to_democratic_heliocentric",
    "from_democratic_heliocentric",
    "kepler_drift",
    "interaction_kick",
    "N_BUF",
    "JACOBI",
    "DEMOCRATIC_HELIOCENTRIC",
]

#: Values of ``istate[I_WH_COORDINATES]``.
JACOBI = 0
DEMOCRATIC_HELIOCENTRIC = 1

# slots of buf: Jacobi positions, Jacobi velocities, inertial accelerations, Jacobi accelerations,
# (slot 4, column 0) the cumulative masses eta_i, and scratch copies for synchronising. In
# democratic heliocentric coordinates slots 0/1 hold Q, V and slot 3 the additional force.
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
def _kick(t, xj, vj, m, eta, G, h, x, v, massive, fstate, istate, gwork, force, params, acc, aj,
          dh, parallel):
    """Interaction kick ``h`` of the internal velocities with the forces at time ``t``.

    Jacobi: the Jacobi transform of the full accelerations minus each body's Kepler term.
    Democratic heliocentric: the gravity of the massive bodies other than the central one
    (``massive[1:]``: the central body is ``massive[0] = 0``) plus the additional force
    (into ``aj``) minus its mass-weighted mean. ``x`` receives the inertial positions the forces
    were evaluated at.
    """
    if dh:
        from_democratic_heliocentric(xj, m, eta, x, False)
        gravity(x, m, G, fstate[F_SOFT2], massive[1:], acc, gwork, parallel)
        aj[:, :] = 0.0
        force(t, x, v, m, params, aj)
        _dh_interaction_kick(vj, acc, aj, m, eta, h)
    else:
        from_jacobi(xj, m, eta, x)
        accelerations(t, x, v, m, massive, fstate, gwork, force, params, acc, parallel)
        to_jacobi(acc, m, eta, aj)
        _interaction_kick(xj, vj, aj, eta, G, h)


@kernel
def _dh_step(tk, xj, vj, m, eta, G, h, x, v, massive, fstate, istate, gwork, force, params, acc,
             fa, parallel):
    """One fused democratic heliocentric step of the internal state: ``Jump(h/2) Kepler(h)
    Jump(h/2)``, then the interaction kick ``h`` with the forces at ``tk``."""
    # _drift and _kick(dh) written out: through those generic calls the step is ~20% slower
    _jump(xj, vj, m, 0.5 * h)
    st = _kepler_drift(xj, vj, eta, G, h, True)
    if st != OK:
        return st
    _jump(xj, vj, m, 0.5 * h)
    from_democratic_heliocentric(xj, m, eta, x, False)
    gravity(x, m, G, fstate[F_SOFT2], massive[1:], acc, gwork, parallel)
    fa[:, :] = 0.0
    force(tk, x, v, m, params, fa)
    _dh_interaction_kick(vj, acc, fa, m, eta, h)
    return OK


@step_kernel
def _watched_kick(xj, vj, aj, eta, G, h, fstate, t):
    """:func:`.nbody_wh_maps.interaction_kick` (the same bits) that also keeps the peak, over
    the steps, of each body's interaction acceleration relative to its Kepler one,
    ``rho = |a_i| r_i^2 / (G eta_i)`` (squared, in ``fstate[F_WATCH_RHO2]``), with its squared
    acceleration, the time ``t`` and the body (``F_WATCH_A2``, ``F_WATCH_T``,
    ``F_WATCH_BODY``): a close encounter that begins and ends between two checked states
    leaves its peak there (:func:`visviva.nbody.step_check.check_run`). A few multiplications
    per body and step, no division but at a new peak."""
    n = xj.shape[0]
    for c in range(3):
        vj[0, c] += aj[0, c] * h
    peak = fstate[F_WATCH_RHO2]
    for i in range(1, n):
        r2 = xj[i, 0] * xj[i, 0] + xj[i, 1] * xj[i, 1] + xj[i, 2] * xj[i, 2]
        gm = G * eta[i]
        k = gm / (r2 * math.sqrt(r2))
        ax = aj[i, 0] + k * xj[i, 0]
        ay = aj[i, 1] + k * xj[i, 1]
        az = aj[i, 2] + k * xj[i, 2]
        vj[i, 0] += ax * h
        vj[i, 1] += ay * h
        vj[i, 2] += az * h
        a2 = ax * ax + ay * ay + az * az
        if a2 * (r2 * r2) > peak * (gm * gm):
            peak = a2 * (r2 * r2) / (gm * gm)
            fstate[F_WATCH_RHO2] = peak
            fstate[F_WATCH_A2] = a2
            fstate[F_WATCH_T] = t
            fstate[F_WATCH_BODY] = i


@kernel
def _phase_kick(xj, vj, m, eta, G, ah, bh, t, x, v, massive, fstate, istate, gwork, force,
                params, acc, aj, parallel):
    """Kepler drift by ``ah``, interaction kick ``bh``, Kepler drift back by ``-ah`` (Jacobi)."""
    st = _kepler_drift(xj, vj, eta, G, ah, False)
    if st != OK:
        return st
    _kick(t, xj, vj, m, eta, G, bh, x, v, massive, fstate, istate, gwork, force, params, acc, aj,
          False, parallel)
    return _kepler_drift(xj, vj, eta, G, -ah, False)


@kernel
def _corrector(order, inverse, h, xj, vj, m, eta, G, t, x, v, massive, fstate, istate, gwork,
               force, params, acc, aj, parallel):
    """Apply the symplectic corrector C (``inverse`` false) or its inverse to Jacobi ``xj, vj``.

    ``C = prod_j Y(a_j, b_j) Y(-a_j, -b_j)`` with ``Y(a, b)`` = drift ``a h``, kick ``b h``,
    drift ``-a h``; the inverse applies ``Y(a, -b)`` in reverse order.
    """
    npairs = 0
    for j in range(CORRECTOR_A.shape[1]):
        if CORRECTOR_A[order, j] != 0.0:
            npairs = j + 1
    for jj in range(2 * npairs):
        # pair j, its first or second map: one call site (a device twin inlines each site)
        j = npairs - 1 - jj // 2 if inverse else jj // 2
        a = CORRECTOR_A[order, j] * h
        b = CORRECTOR_B[order, j] * h
        if jj % 2 == 0:
            a = -a if inverse else a
        else:
            a = a if inverse else -a
            b = -b
        st = _phase_kick(xj, vj, m, eta, G, a, b, t, x, v, massive, fstate, istate, gwork,
                         force, params, acc, aj, parallel)
        if st != OK:
            return st
    return OK


@kernel
def _synchronise(xj, vj, xs, vs, m, eta, G, half, x, v, order, t, massive, fstate, istate,
                 gwork, force, params, acc, aj, dh, parallel):
    """Inertial ``x, v`` from the internal state: a copy drifted by the last half step (and
    taken back through the inverse corrector when one is used)."""
    n = xj.shape[0]
    for i in range(n):
        for c in range(3):
            xs[i, c] = xj[i, c]
            vs[i, c] = vj[i, c]
    st = _drift(xs, vs, m, eta, G, half, half, 0.0, dh)
    if st != OK:
        return st
    if order is not None and order > 0:
        st = _corrector(order, True, 2.0 * half, xs, vs, m, eta, G, t, x, v, massive, fstate,
                        istate, gwork, force, params, acc, aj, parallel)
        if st != OK:
            return st
    _from_internal(xs, vs, m, eta, x, v, dh)
    return OK


@kernel
def _first_half(x, v, m, eta, G, h, t, xj, vj, massive, fstate, istate, gwork, force, params,
                acc, aj, order, dh, parallel):
    """Internal state from inertial ``x, v`` at ``t``, through the first kick of a step ``h``:
    (corrector,) drift ``h/2`` (then jump ``h/2``), kick ``h``."""
    half = 0.5 * h
    _to_internal(x, v, m, eta, xj, vj, dh)
    if order is not None and order > 0:
        st = _corrector(order, False, h, xj, vj, m, eta, G, t, x, v, massive, fstate, istate,
                        gwork, force, params, acc, aj, parallel)
        if st != OK:
            return st
    st = _drift(xj, vj, m, eta, G, half, 0.0, half, dh)
    if st != OK:
        return st
    _kick(t + half, xj, vj, m, eta, G, h, x, v, massive, fstate, istate, gwork, force, params,
          acc, aj, dh, parallel)
    return OK


@kernel
def _dkd_step(x, v, m, eta, G, h, t, xj, vj, massive, fstate, istate, gwork, force, params,
              acc, aj, order, dh, parallel):
    """One synchronised drift-kick-drift step of ``x, v`` (inertial in, inertial out),
    conjugated by the corrector for this step length when ``order > 0``."""
    half = 0.5 * h
    st = _first_half(x, v, m, eta, G, h, t, xj, vj, massive, fstate, istate, gwork, force,
                     params, acc, aj, order, dh, parallel)
    if st != OK:
        return st
    st = _drift(xj, vj, m, eta, G, half, half, 0.0, dh)
    if st != OK:
        return st
    if order is not None and order > 0:
        st = _corrector(order, True, h, xj, vj, m, eta, G, t + h, x, v, massive, fstate, istate,
                        gwork, force, params, acc, aj, parallel)
        if st != OK:
            return st
    _from_internal(xj, vj, m, eta, x, v, dh)
    return OK


@kernel
def _tangent_start(mg, x, v, m, eta, buf):
    """MEGNO (``mg`` true; ``None`` compiles nothing): remember the synchronised state where
    the internal state is built afresh (:func:`.nbody_wh_tangent.whfast_tangent_start`)."""
    if mg is not None and mg:
        whfast_tangent_start(x, v, m, eta, buf, N_BUF)


@kernel
def _tangent_step(mg, xj, vj, x, m, massive, eta, fstate, buf, h):
    """MEGNO (``mg`` true; ``None`` compiles nothing): the tangent vector over the Jacobi step
    ``h`` just taken (:func:`.nbody_wh_tangent.whfast_tangent`); returns a status code."""
    if mg is not None and mg:
        return whfast_tangent(xj, vj, x, m, massive, eta, fstate, buf, N_BUF, h)
    return OK


@kernel
def whfast_run(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
               out_t, out_x, out_v):
    """Advance through every output time with Wisdom-Holman steps (see the module docstring and
    :func:`_whfast`); gravity by any kernel, chosen at run time (``istate[I_PARALLEL]``, N)."""
    return _whfast(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
                   out_t, out_x, out_v, istate[I_PARALLEL] != 0, ANY_CASE, PLAIN)


@kernel
def whfast_run_few(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
                   out_t, out_x, out_v):
    """:func:`whfast_run` compiled with the serial few-body gravity alone (``FEW``): for one
    thread and fewer than :data:`visviva.core.gravity.PAIR_MIN_N` massive particles, the same
    bits and a fraction of the compile time (no ``prange`` region, no large-N kernel)."""
    return _whfast(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
                   out_t, out_x, out_v, FEW, ANY_CASE, PLAIN)


#: The ``plain`` argument of the run body for the default case: Jacobi coordinates, no
#: symplectic corrector, no MEGNO, no collisions, encounters or escape radius (a type, not a
#: value: numba then drops the corrector, the MEGNO hooks, the democratic heliocentric step and
#: the event path; see :func:`is_plain`). ``dh`` stays a run-time ``False`` for the callees:
#: passing ``None`` there too dropped 3 s more of compiling but made the warm step loop 5-7 %
#: slower.
PLAIN = None
#: The ``plain`` argument for every other case (chosen at run time from ``istate``).
ANY_CASE = True
#: The ``megno`` argument of the run body with ``plain = PLAIN``: the tangent vector's hooks
#: compiled in (``PLAIN`` there: none); the general kernels choose at run time and pass
#: ``PLAIN`` (unused).
MEGNO_ON = True


def is_plain(istate, fstate):
    """True when a run may use :func:`whfast_run_plain` (plain Python, not compiled): Jacobi
    coordinates, no corrector, no MEGNO, and none of collisions, encounters or an escape
    radius. On an ensemble's stacked rows (2-D ``istate``/``fstate``) an array: the answer for
    each row."""
    return ((istate[..., I_WH_COORDINATES] == JACOBI) & (istate[..., I_CORRECTOR] == 0)
            & (istate[..., I_COLLISIONS] == 0) & (fstate[..., F_ENCOUNTER] <= 0.0)
            & (fstate[..., F_EXIT] <= 0.0) & (istate[..., I_MEGNO] != 1))


@kernel
def whfast_run_plain(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
                     out_t, out_x, out_v):
    """:func:`whfast_run_few` for the default case alone (:func:`is_plain`): Jacobi
    coordinates, no corrector, no events. The same bits; what a first WHFast run compiles."""
    return _whfast(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
                   out_t, out_x, out_v, FEW, PLAIN, PLAIN)


def is_megno(istate, fstate):
    """True when a run may use :func:`whfast_run_megno` (plain Python, not compiled): the case
    of :func:`is_plain` (Jacobi coordinates, no corrector, no events) with MEGNO on, the only
    one ``init_megno`` accepts. On an ensemble's stacked rows an array, as :func:`is_plain`."""
    return ((istate[..., I_WH_COORDINATES] == JACOBI) & (istate[..., I_CORRECTOR] == 0)
            & (istate[..., I_COLLISIONS] == 0) & (fstate[..., F_ENCOUNTER] <= 0.0)
            & (fstate[..., F_EXIT] <= 0.0) & (istate[..., I_MEGNO] == 1))


@kernel
def whfast_run_megno(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
                     out_t, out_x, out_v):
    """:func:`whfast_run_plain` with the tangent vector (:func:`is_megno`): what a first MEGNO
    run compiles, without the corrector, the democratic heliocentric step and the event path of
    :func:`whfast_run_few` (24 s of CPU to compile on a fresh install, against 41 s for that
    kernel; docs/performance.md).
    The same bits as :func:`whfast_run_few`."""
    return _whfast(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
                   out_t, out_x, out_v, FEW, PLAIN, MEGNO_ON)


@step_kernel
def _whfast(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
            out_t, out_x, out_v, parallel, plain, megno):
    """Advance through every output time with Wisdom-Holman steps (see the module docstring).

    Particle 0 must have mass (the central body). ``istate[I_WH_COORDINATES]`` chooses Jacobi
    (0) or democratic heliocentric (1) coordinates; the corrector is used with Jacobi only.
    ``plain`` (:data:`PLAIN` or :data:`ANY_CASE`) and ``megno`` (:data:`PLAIN` or
    :data:`MEGNO_ON`, read only with ``plain = PLAIN``) choose, as types, what is compiled.

    Without event detection (the usual case) the half drifts of consecutive steps are fused:
    the internal state ``P`` (internal coordinates just after a kick, kept in ``buf``) advances
    on the grid ``t0 + k |dt|`` by ``P <- Kick(h) Drift(h) P`` (``Drift`` = Kepler, or
    jump-Kepler-jump), and the inertial ``x, v`` at an
    output are a COPY: ``C^-1 Kepler(h/2) P`` (``C`` the optional symplectic corrector), followed,
    for an output time between grid points, by one shortened drift-kick-drift step of the copy.
    The internal trajectory therefore never depends on the output times, and saving ``buf`` lets
    a loaded run continue bit for bit. With collisions, encounters or an escape radius every step
    is synchronised (events are checked on the true state) and an output between grid points is
    reached with a shortened step. Arguments as in :mod:`visviva.core.nbody_common`; returns a
    status code.
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
    if plain is None:
        dh = False  # Jacobi (a bool: see PLAIN)
        order = plain  # None: the callees compile no corrector
        # ... and the tangent vector only in the MEGNO kernel (megno_on: a run without MEGNO
        # taken there by mistake leaves buf's tangent slots alone)
        if megno is None:
            mg = megno
        else:
            mg = megno_on(istate, buf, N_BUF)
    else:
        dh = istate[I_WH_COORDINATES] == DEMOCRATIC_HELIOCENTRIC
        order = 0 if dh else istate[I_CORRECTOR]
        # MEGNO: Jacobi coordinates without a corrector and without events (init_megno checks)
        mg = megno_on(istate, buf, N_BUF) and not dh and order == 0
    dt = fstate[F_DT]
    adt = abs(dt)
    exact = istate[I_EXACT_FINISH] != 0
    direction = run_direction(fstate[F_T], t_out)
    fast = istate[I_COLLISIONS] == 0 and fstate[F_ENCOUNTER] <= 0.0 and fstate[F_EXIT] <= 0.0
    h = math.copysign(adt, direction)
    if fast:
        valid = (istate[I_WH_VALID] != 0 and istate[I_FRESH] == 0 and fstate[F_WH_H] == h
                 and fstate[F_DT_REF] == adt)
        istate[I_FRESH] = 0
        while not valid and istate[I_NOUT] < t_out.shape[0] and t_out[istate[I_NOUT]] == fstate[F_T]:
            # outputs at the current time need no step (and no internal state yet)
            k0 = istate[I_NOUT]
            write_output(k0, fstate[F_T], x, v, out_t, out_x, out_v)
            istate[I_NOUT] = k0 + 1
        if not valid and istate[I_NOUT] >= t_out.shape[0]:
            return OK
        if not valid:
            # build P from the state at the exposed time, which becomes the grid origin
            fstate[F_T0] = fstate[F_T]
            fstate[F_DT_REF] = adt
            istate[I_K] = 0
            _tangent_start(mg, x, v, m, eta, buf)
            st = _first_half(x, v, m, eta, G, h, fstate[F_T], xj, vj, massive, fstate, istate,
                             gwork, force, params, acc, aj, order, dh, parallel)
            if st != OK:
                return st
            st = _tangent_step(mg, xj, vj, x, m, massive, eta, fstate, buf, h)
            if st != OK:
                return st
            # P now belongs to the grid point t0 + h: count that step
            istate[I_K] = 1 if h > 0.0 else -1
            istate[I_STEPS] += 1
            fstate[F_WH_H] = h
            istate[I_WH_VALID] = 1
        for k in range(istate[I_NOUT], t_out.shape[0]):
            target = t_out[k]
            while True:
                t_grid = fstate[F_T0] + istate[I_K] * adt
                rem = target - t_grid
                if rem * direction <= 1e-9 * adt:
                    break  # the grid point is at or past the target
                if (not exact) or rem * direction >= adt * (1.0 - 1e-9):
                    # the Jacobi step written out and the democratic heliocentric one as one
                    # call: this keeps the loop small enough for LLVM to optimise (generic
                    # _drift/_kick calls here cost 10-15% for either coordinate system)
                    tk = t_grid + 0.5 * h
                    if plain is not None and dh:
                        st = _dh_step(tk, xj, vj, m, eta, G, h, x, v, massive, fstate, istate,
                                      gwork, force, params, acc, aj, parallel)
                        if st != OK:
                            return st
                    else:
                        st = _kepler_drift(xj, vj, eta, G, h, False)
                        if st != OK:
                            return st
                        from_jacobi(xj, m, eta, x)
                        accelerations(tk, x, v, m, massive, fstate, gwork, force, params, acc,
                                      parallel)
                        to_jacobi(acc, m, eta, aj)
                        _watched_kick(xj, vj, aj, eta, G, h, fstate, tk)
                        st = _tangent_step(mg, xj, vj, x, m, massive, eta, fstate, buf, h)
                        if st != OK:
                            return st
                    istate[I_K] += 1 if h > 0.0 else -1
                    istate[I_STEPS] += 1
                    fstate[F_DT_LAST] = h
                    if should_pause(istate):
                        st = _synchronise(xj, vj, xs, vs, m, eta, G, 0.5 * h, x, v, order,
                                          t_grid + h, massive, fstate, istate, gwork, force,
                                          params, acc, aj, dh, parallel)
                        if st != OK:
                            return st
                        fstate[F_T] = fstate[F_T0] + istate[I_K] * adt
                        return PAUSED
                else:
                    break  # less than a step to go: the output comes from a copy
            # P belongs to grid point t_grid: synchronise a copy there
            t_grid = fstate[F_T0] + istate[I_K] * adt
            st = _synchronise(xj, vj, xs, vs, m, eta, G, 0.5 * h, x, v, order, t_grid, massive,
                              fstate, istate, gwork, force, params, acc, aj, dh, parallel)
            if st != OK:
                return st
            rem = target - t_grid
            if exact and abs(rem) > 1e-9 * adt:
                # a shortened step of the copy lands on the output time (backwards when the
                # target lies within the first step, which P has already taken); P is untouched
                st = _dkd_step(x, v, m, eta, G, rem, t_grid, xs, vs, massive, fstate, istate,
                               gwork, force, params, acc, aj, order, dh, parallel)
                if st != OK:
                    return st
            fstate[F_T] = target if exact else t_grid
            write_output(k, fstate[F_T], x, v, out_t, out_x, out_v)
            istate[I_NOUT] = k + 1
        return OK
    if plain is None:
        return OK  # not reached: the plain kernel is chosen only for runs without events

    # ---- with event detection: every step synchronised --------------------------------------
    istate[I_WH_VALID] = 0
    istate[I_FRESH] = 0
    start_clock(fstate, istate)
    for k in range(istate[I_NOUT], t_out.shape[0]):
        target = t_out[k]
        while True:
            t = fstate[F_T]
            hh, last = next_fixed_step(t, target, dt, exact, direction)
            if hh == 0.0:
                if exact and fstate[F_T] != target:
                    advance_clock(fstate, istate, 0.0, True, True, target)
                break
            st = _dkd_step(x, v, m, eta, G, hh, t, xj, vj, massive, fstate, istate, gwork,
                           force, params, acc, aj, 0, dh, parallel)
            if st != OK:
                return st
            advance_clock(fstate, istate, hh, last, exact, target)
            fstate[F_DT_LAST] = hh
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
