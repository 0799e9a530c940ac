"""Pieces shared by the compiled N-body integrators: state layout, forces, events, outputs.

Every integrator kernel (:mod:`.nbody_leapfrog`, :mod:`.nbody_ias15`, :mod:`.nbody_whfast`) has the
same signature, :data:`RUN_SIGNATURE`::

    run(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params,
        t_out, out_t, out_x, out_v) -> status

and advances the state in place through every requested output time in ONE compiled call.
Each integrator has two such kernels around one run body: ``<name>_run`` (gravity by any
kernel, chosen at run time from ``istate[I_PARALLEL]`` and N) and ``<name>_run_few`` (the
serial few-body gravity alone, :data:`FEW`: one thread, fewer than
:data:`visviva.core.gravity.PAIR_MIN_N` massive particles; the same bits, and a fraction of the
compile time on a fresh install). ``visviva.nbody.integrators.few_bodies`` chooses.

``x, v`` (N, 3)
    positions and velocities, updated in place.
``m`` (N,), ``massive`` (N_massive,) int64, ``radius`` (N,)
    masses (0 = test particle), ascending indices of the massive ones, collision radii.
``fstate`` float64 (:data:`N_FSTATE`,) and ``istate`` int64 (:data:`N_ISTATE`,)
    the scalar state; the slots are named by the ``F_*`` and ``I_*`` constants below.
``buf`` (K, N, 3)
    the integrator's own arrays (IAS15's b and e, WHFast's Jacobi state, ...).
``gwork`` (GWORK_ROWS, N)
    scratch of the gravity kernels (:data:`visviva.core.gravity.GWORK_ROWS`).
``force``, ``params``
    the additional force ``force(t, x, v, m, params, acc)`` (a first-class compiled function that
    ADDS to ``acc``) and its float64 parameter array.
``t_out`` (T,), ``out_t`` (T,), ``out_x``, ``out_v`` (T, N, 3)
    absolute output times (monotonic in the direction of integration), the times actually
    reached (equal to ``t_out`` unless ``istate[I_EXACT_FINISH]`` is 0) and the snapshots. ``istate[I_NOUT]`` counts the outputs written, so a run interrupted by an event
    (collision, encounter, escape) can be resumed from where it stopped.
"""

from __future__ import annotations

import math

from numba import types

from ._jit import kernel, step_kernel
from .gravity import FEW, gravity
from .gravity_split import gravity_split
from .status import COLLISION, ENCOUNTER, ESCAPE, OK

__all__ = [
    "RUN_SIGNATURE",
    "FORCE_SIGNATURE",
    "FORCE_TYPE",
    "accelerations",
    "accelerations_split",
    "check_events",
    "N_FSTATE",
    "N_ISTATE",
    "FEW",
]

# ---- scalar state slots ------------------------------------------------------------------------
F_T = 0  #: simulation time
F_DT = 1  #: (next) time step
F_DT_LAST = 2  #: last step actually done
F_EPSILON = 3  #: IAS15 accuracy parameter (1e-9)
F_MIN_DT = 4  #: smallest step an adaptive integrator may take
F_SOFT2 = 5  #: softening length squared
F_G = 6  #: gravitational constant
F_ENCOUNTER = 7  #: encounter distance (0 = off)
F_EXIT = 8  #: escape radius from the origin (0 = off)
F_T0 = 9  #: fixed-step integrators: time origin, t = t0 + k |dt| (no accumulated round-off)
F_DT_REF = 10  #: the |dt| that origin was set with (0 forces a new origin)
F_WH_H = 11  #: WHFast: the signed step its unsynchronised internal state was built with
F_T_INT = 12  #: IAS15: time of the internal state (outputs are reached on copies)
F_DT_FLOOR = 13  #: IAS15: the step floor that was hit (set with STEP_TOO_SMALL)
F_DT_FAILED = 14  #: IAS15: the proposed step that fell below it
# MEGNO (visviva.core.nbody_variational): accumulators over the time since init_megno, tau
F_MG_T0 = 15  #: the simulation time at which MEGNO was started (for the record)
F_MG_YS = 16  #: 2 int_0^tau s f(s) ds, f = delta'.delta / delta.delta (Y = F_MG_YS / tau)
F_MG_YSS = 17  #: int_0^tau Y(s) ds (MEGNO <Y> = F_MG_YSS / tau)
F_MG_N = 18  #: number of MEGNO updates (steps), as a float
F_MG_MEAN_T = 19  #: running mean of tau over the updates
F_MG_MEAN_Y = 20  #: running mean of <Y> over the updates
F_MG_COV = 21  #: co-moment of (tau, <Y>) over the updates (Welford)
F_MG_VAR = 22  #: second moment of tau over the updates
F_MG_TAU = 23  #: tau, the time since the start: the sum of the steps taken since
F_MG_DT_PREV = 24  #: IAS15: the last step the tangent vector took (its predictor's scale)
F_MG_LN = 25  #: ln(|delta| / |delta_0|) at the last update (rescalings included)
F_MG_ILN = 26  #: int_0^tau ln(|delta| / |delta_0|) ds
F_MG_LN_SHIFT = 27  #: ln of the factors the tangent vector was divided by (rescalings)
#: WHFast (Jacobi, between outputs): the largest squared ratio |a_int| r^2 / (G eta_i) of a
#: body's interaction acceleration to its Kepler one over the steps since the last read
#: (``visviva.nbody.step_check.check_run`` reads and clears it: a close encounter between two
#: checked states), the squared interaction acceleration, the time and the body at that peak
F_WATCH_RHO2 = 28
F_WATCH_A2 = 29
F_WATCH_T = 30
F_WATCH_BODY = 31
N_FSTATE = 32

I_NOUT = 0  #: outputs written in this run
I_STEPS = 1  #: steps done (total)
I_PARALLEL = 2  #: 1: parallel gravity kernel
I_COLLISIONS = 3  #: 1: detect collisions by radius
I_EVENT_A = 4  #: first particle of the last event
I_EVENT_B = 5  #: second particle (or -1)
I_ITERATIONS = 6  #: IAS15 predictor-corrector iterations (total)
I_REJECTED = 7  #: IAS15 rejected steps (total)
I_CORRECTOR = 8  #: WHFast symplectic corrector order (0 = none)
I_FRESH = 9  #: 1: the integrator's internal state must be (re)initialised
I_STOP_AT_STEP = 10  #: > 0: pause (return PAUSED) once istate[I_STEPS] reaches this count
I_EXACT_FINISH = 11  #: 1: land exactly on output times; 0: stop at the first step at or past them
I_K = 12  #: fixed-step integrators: signed number of whole steps since the time origin F_T0
I_WH_VALID = 13  #: WHFast: 1 when buf holds a valid unsynchronised internal state
I_VELOCITY_DEPENDENT = 14  #: 1 when an additional force reads the velocities
I_INT_VALID = 15  #: leapfrog/IAS15: 1 when buf holds the internal state (on its own step grid)
I_ADAPTIVE_MODE = 16  #: IAS15 step-size control: 0 = Rein & Spiegel 2015 global, 1 = PRS23
I_WH_COORDINATES = 17  #: WHFast splitting: 0 = Jacobi, 1 = democratic heliocentric
I_MEGNO = 18  #: 1: integrate the tangent vector and MEGNO; 0: off; -1: dropped (particles changed)
N_ISTATE = 32

#: Returned (not an error) when a run paused at ``istate[I_STOP_AT_STEP]`` steps.
PAUSED = -1

_f64 = types.float64
_a1 = types.Array(_f64, 1, "C")
_a2 = types.Array(_f64, 2, "C")
_a3 = types.Array(_f64, 3, "C")
_i1 = types.Array(types.int64, 1, "C")

#: Signature every additional force has: ``force(t, x, v, m, params, acc) -> None``.
FORCE_SIGNATURE = types.void(_f64, _a2, _a2, _a1, _a1, _a2)
#: The numba type of a compiled force passed as a first-class function.
FORCE_TYPE = types.FunctionType(FORCE_SIGNATURE)
#: Signature of every integrator kernel (see the module docstring).
RUN_SIGNATURE = types.int64(
    _a2, _a2, _a1, _i1, _a1, _a1, _i1, _a3, _a2, FORCE_TYPE, _a1, _a1, _a1, _a3, _a3
)


@step_kernel
def accelerations(t, x, v, m, massive, fstate, gwork, force, params, acc, parallel):
    """Gravity (direct summation) plus the additional force, written into ``acc``.

    ``parallel``: the gravity kernel's choice (``istate[I_PARALLEL] != 0``), or ``FEW`` in a
    few-body kernel (see :func:`visviva.core.gravity.gravity`)."""
    gravity(x, m, fstate[F_G], fstate[F_SOFT2], massive, acc, gwork, parallel)
    force(t, x, v, m, params, acc)


@step_kernel
def accelerations_split(t, x, xlo, v, m, massive, fstate, gwork, force, params, acc, parallel):
    """:func:`accelerations` with positions in two parts ``x + xlo`` for gravity (IAS15).

    The additional force sees ``x`` (the high parts) only. (Numba's cache checks only the
    stamp of the defining file: after editing :func:`visviva.core.gravity_split.gravity_split`, touch
    this file and :mod:`.nbody_ias15`.)
    """
    gravity_split(x, xlo, m, fstate[F_G], fstate[F_SOFT2], massive, acc, gwork, parallel)
    force(t, x, v, m, params, acc)


@kernel
def check_events(x, v, radius, fstate, istate):
    """Collision (radii overlap while approaching), encounter and escape checks after a step.

    Returns ``OK`` or ``COLLISION``/``ENCOUNTER``/``ESCAPE`` with the particles involved in
    ``istate[I_EVENT_A]``, ``istate[I_EVENT_B]``. Costs O(N**2) when collisions or encounters
    are switched on, nothing otherwise.
    """
    n = x.shape[0]
    exit_r = fstate[F_EXIT]
    if exit_r > 0.0:
        e2 = exit_r * exit_r
        for i in range(n):
            r2 = x[i, 0] * x[i, 0] + x[i, 1] * x[i, 1] + x[i, 2] * x[i, 2]
            if r2 > e2:
                istate[I_EVENT_A] = i
                istate[I_EVENT_B] = -1
                return ESCAPE
    coll = istate[I_COLLISIONS] != 0
    enc = fstate[F_ENCOUNTER]
    if not coll and enc <= 0.0:
        return OK
    enc2 = enc * enc
    for i in range(n):
        for j in range(i + 1, n):
            dx = x[j, 0] - x[i, 0]
            dy = x[j, 1] - x[i, 1]
            dz = x[j, 2] - x[i, 2]
            r2 = dx * dx + dy * dy + dz * dz
            if coll:
                rs = radius[i] + radius[j]
                if r2 < rs * rs:
                    dvx = v[j, 0] - v[i, 0]
                    dvy = v[j, 1] - v[i, 1]
                    dvz = v[j, 2] - v[i, 2]
                    if dx * dvx + dy * dvy + dz * dvz < 0.0:  # approaching
                        istate[I_EVENT_A] = i
                        istate[I_EVENT_B] = j
                        return COLLISION
            if r2 < enc2:
                istate[I_EVENT_A] = i
                istate[I_EVENT_B] = j
                return ENCOUNTER
    return OK


@kernel
def should_pause(istate):
    """True when the step budget of this call is used up (progress bars resume the run)."""
    stop = istate[I_STOP_AT_STEP]
    return stop > 0 and istate[I_STEPS] >= stop


@kernel
def start_clock(fstate, istate):
    """Fixed-step integrators: keep the time origin unless ``|dt|`` changed (then restart it)."""
    adt = abs(fstate[F_DT])
    if fstate[F_DT_REF] != adt:
        fstate[F_T0] = fstate[F_T]
        fstate[F_DT_REF] = adt
        istate[I_K] = 0


@kernel
def advance_clock(fstate, istate, h, last, exact, target):
    """Time after a fixed step ``h``: ``t0 + k |dt|`` for whole steps (no accumulated round-off
    over millions of steps), ``target`` exactly when landing on it (which restarts the origin)."""
    adt = fstate[F_DT_REF]
    if last and exact:
        fstate[F_T] = target
        fstate[F_T0] = target
        istate[I_K] = 0
    elif abs(h) == adt:
        istate[I_K] += 1 if h > 0.0 else -1
        fstate[F_T] = fstate[F_T0] + istate[I_K] * adt
    else:
        fstate[F_T] = fstate[F_T] + h
        fstate[F_T0] = fstate[F_T]
        istate[I_K] = 0


@kernel
def run_direction(t, t_out):
    """+1 when the last output time lies ahead of ``t`` (or at it), -1 when behind."""
    if t_out.shape[0] == 0:
        return 1.0
    return 1.0 if t_out[t_out.shape[0] - 1] >= t else -1.0


@kernel
def write_output(k, t, x, v, out_t, out_x, out_v):
    """Copy the state into snapshot ``k``."""
    out_t[k] = t
    for i in range(x.shape[0]):
        for c in range(3):
            out_x[k, i, c] = x[i, c]
            out_v[k, i, c] = v[i, c]


@kernel
def next_fixed_step(t, target, dt, exact, direction):
    """The step a fixed-step integrator takes from ``t`` towards ``target``.

    Returns ``(h, last)``: a full step ``h = +-|dt|`` in the direction of ``target``, or the
    remainder when it is shorter than ``|dt|`` (within a relative 1e-9, a full step is taken and
    ``last`` is true so that the caller snaps ``t`` to ``target``); ``h = 0`` when ``t`` is there.
    With ``exact`` false only full steps are taken (the last one may pass ``target``; nothing is
    done once ``t`` is at or past ``target`` in the ``direction`` of integration, +1 or -1).
    """
    rem = target - t
    adt = abs(dt)
    if rem == 0.0 or abs(rem) <= 1e-12 * adt:
        return 0.0, True
    h = math.copysign(adt, rem)
    if not exact:
        if rem * direction <= 0.0:
            return 0.0, True
        return h, abs(rem) <= adt * (1.0 + 1e-9)
    if abs(rem) <= adt * (1.0 + 1e-9):
        if abs(rem) >= adt * (1.0 - 1e-9):
            return h, True
        return rem, True
    return h, False
