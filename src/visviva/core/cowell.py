"""Cowell's method: a compiled adaptive Dormand-Prince 8(5,3) integrator with dense output
and event location, over the right-hand side :func:`visviva.core.perturbations.cowell_rhs`.

The whole integration (steps, step-size control, dense output at the requested times, event
detection and root finding) runs in one compiled call; nothing returns to Python per step.

The Butcher tableau of DOP853 (Hairer, Norsett & Wanner 1993, Solving Ordinary Differential
Equations I, sec. II.10; Fortran code DOP853 by Hairer & Wanner) is passed in as arrays
``A`` (16, 16), ``B`` (12,), ``C`` (16,), ``E3``, ``E5`` (13,), ``D`` (4, 16): 12 stages for
the step, one FSAL stage, three extra stages for the 7th-degree dense output. The step-size
control follows Hairer's DOP853: the error estimate combines the 5th- and 3rd-order embedded
estimates, err = |h| e5^2 / sqrt(n (e5^2 + 0.01 e3^2)), and the step changes by
0.9 err^(-1/8), clipped to [0.2, 10].

Event kinds (``ev_kind``), each with a parameter ``ev_param`` and a direction ``ev_dir``
(+1: only rising zero crossings, -1: only falling, 0: both; rising and falling in physical
time, also when integrating backwards):

====  =====================================================================
0     altitude: g = h_geodetic(r) - param (km)
1     cylindrical shadow: g = |r_perp| - R when r . s_hat < 0, else |r| (falls on entry)
2     penumbra (conical): g = c - (a + b) (Montenbruck & Gill eq. 3.85), falls on entry
3     umbra (conical): g = c - (b - a), falls on entry
4     node crossing: g = z (rises at the ascending node)
5     apsis: g = r . v (rises at periapsis, falls at apoapsis)
====  =====================================================================

Events are located on the dense output with the Illinois variant of regula falsi to
``ev_tol`` seconds; ``ev_terminal`` events stop the integration at the event
(:mod:`visviva.core.cowell_events`).

Shadow boundaries. With solar radiation pressure and a shadow model in the force block, steps
end exactly at the shadow's boundaries (the functions of kinds 1, or 2 and 3) and never cross
one: a step that would is dropped and redone up to the boundary, and the integration restarts
there with a fresh derivative (:mod:`visviva.core.cowell_events`, "Shadow boundaries"). Without
SRP's shadow but with eclipse events (kinds 1 to 3), the steps end at the boundaries of the
events' shadow the same way, with no change of the force there, and at those of a second
shadow model when eclipse events of both models are asked for (or with SRP's shadow, events of
the other model; :func:`~visviva.core.cowell_events.boundary_models`), so that a shadow entered
and left within a step is found. Without either, nothing changes (the same bits as without this
handling).
"""

from __future__ import annotations

import math

import numpy as np

from . import force_block as fb
from . import status as st
from ._jit import inline_kernel, kernel, parallel_kernel, prange, step_kernel
from .cowell_events import (
    BOUNDARY_RTOL,
    boundary_models,
    boundary_plan,
    dense_eval,
    end_sample_value,
    event_function,
    event_value,
    fix_boundary_events,
    locate_zero,
    lock_shadow,
    penumbra_step,
    shadow_boundary_kind,
    shadow_crossing,
    shadow_sides,
)
from .drag_bands import band_crossing, bands_on, hold_band, start_band
from .perturbations import cowell_rhs, zonal_rhs

__all__ = ["WORK_ROWS", "integrate_cowell", "integrate_cowell_many", "event_function", "dense_eval"]

_SAFETY = 0.9
_MIN_FACTOR = 0.2
_MAX_FACTOR = 10.0
_N_STAGES = 12
#: Rows of the ``work`` array of :func:`integrate_cowell` (16 stages, 7 dense-output rows, 7
#: state vectors, 2 rows of shadow boundary samples, the Sun's position for them, 2 rows of
#: samples of a second shadow model's boundaries, 2 rows of altitude samples for the
#: exponential atmosphere's band edges; 6 columns).
WORK_ROWS = 37


@inline_kernel
def rk_combine(n, y, K, w, n_stages, h, out):
    """out[j] = y[j] + h * sum(w[m] K[m, j] for m < n_stages), j < n: a Runge-Kutta stage/update.

    ``w`` is a row of the tableau (``A[s]`` for stage ``s`` with ``n_stages = s``, or ``B``); the
    sum runs left to right, so the stage values are the same bits wherever this is called.
    """
    for j in range(n):
        acc = 0.0
        for m in range(n_stages):
            acc += w[m] * K[m, j]
        out[j] = y[j] + h * acc


@inline_kernel
def dense_coefficients(n, h, y, y_new, K, D, F):
    """The 7 rows of DOP853's dense output of the step (y, h) -> y_new from its 16 stages ``K``
    (12 of the step, the FSAL one, 3 extra; first ``n`` components) into ``F`` (7, n), as
    :func:`visviva.core.cowell_events.dense_eval` reads them."""
    for j in range(n):
        dlt = y_new[j] - y[j]
        F[0, j] = dlt
        F[1, j] = h * K[0, j] - dlt
        F[2, j] = 2.0 * dlt - h * (K[_N_STAGES, j] + K[0, j])
        for i in range(4):
            acc = 0.0
            for m in range(16):
                acc += D[i, m] * K[m, j]
            F[3 + i, j] = h * acc


#: The ``full`` argument of :func:`integrate_cowell` for a force model of the two-body and
#: zonal terms alone and no events but altitude crossings (a type, not a value: with ``None``
#: numba compiles :func:`visviva.core.perturbations.zonal_rhs` alone, not the drag, third-body,
#: SRP, shadow and harmonics kernels nor the other event functions and the shadow boundaries:
#: about a third of the compile time of a first call, and half the run time of a J2 run).
ZONAL_ONLY = None
#: The ``full`` argument for any other force model or other events.
FULL = True


def rhs_kind(force, ev_kind=()):
    """:data:`ZONAL_ONLY` when ``force`` (the force block) has no term beyond the two-body,
    zonal and relativistic ones (no thrust either) and every event of ``ev_kind`` is an altitude crossing (kind 0: the surface of
    :mod:`visviva.satellites.surface` that bounds every perturbed run, ``AltitudeCrossing``,
    ``ReEntry``), else :data:`FULL` (plain Python, not compiled)."""
    zonal_only = (all(int(k) == 0 for k in ev_kind) and force[fb.HARMONICS_DEGREE] < 2.0
                  and force[fb.DRAG_ON] == 0.0 and int(force[fb.N_THIRD_BODIES]) == 0
                  and force[fb.SRP_ON] == 0.0 and force[fb.THRUST_ON] == 0.0)
    return ZONAL_ONLY if zonal_only else FULL


@step_kernel
def _rhs(t, y, force, zonal, atm, eph_r, eph_v, eph_gm, sh, dy, full):
    # cowell_rhs, or zonal_rhs alone when full is ZONAL_ONLY (numba drops the other branch)
    if full is None:
        zonal_rhs(t, y, force, zonal, dy)
    else:
        cowell_rhs(t, y, force, zonal, atm, eph_r, eph_v, eph_gm, sh, dy)


@kernel
def _rms_norm(v, scale):
    acc = 0.0
    for i in range(v.shape[0]):
        q = v[i] / scale[i]
        acc += q * q
    return math.sqrt(acc / v.shape[0])


@kernel
def integrate_cowell(
    y0,
    t_out,
    t_end,
    rtol,
    atol,
    h_max,
    max_steps,
    force,
    zonal,
    atm,
    eph_r,
    eph_v,
    eph_gm,
    sh,
    ev_kind,
    ev_param,
    ev_dir,
    ev_terminal,
    ev_tol,
    A,
    B,
    C,
    E3,
    E5,
    D,
    y_out,
    ev_t,
    ev_y,
    ev_which,
    info,
    full,
    work,
):
    """Integrate y' = cowell_rhs(t, y) from t = 0 to ``t_end`` (either sign).

    Parameters
    ----------
    y0 : ndarray (6,)
        Initial position (km) and velocity (km/s).
    t_out : ndarray (T,)
        Output times in s from the start, monotonic in the direction of integration,
        within [0, t_end].
    t_end : float
        Final time, s.
    rtol, atol : float
        Relative and absolute tolerances (atol in km and km/s).
    h_max : float
        Largest step, s (inf for none).
    max_steps : int
        Step budget; exceeding it stops with ``STEP_TOO_SMALL``.
    force, zonal, atm, eph_r, eph_v, eph_gm, sh : ndarray
        The force model (see :mod:`visviva.core.perturbations`).
    ev_kind, ev_param, ev_dir, ev_terminal : ndarray (E,)
        The events to detect (see the module docstring).
    ev_tol : float
        Time tolerance of the event root finding, s.
    A, B, C, E3, E5, D : ndarray
        The DOP853 tableau.
    y_out : ndarray (T, 6)
        Output: the states at ``t_out``.
    ev_t, ev_y, ev_which : ndarray (M,), (M, 6), (M,)
        Output: event times, states, and which event: +(index + 1) for a crossing of event
        ``index`` rising in physical time (whatever the direction of integration),
        -(index + 1) for a falling one.
    info : ndarray (6,)
        Output: [outputs written, events found (may exceed M: then rerun larger), steps
        (accepted by the error control; with a shadow, also those redone up to a boundary),
        rhs evaluations, final time reached, index of the terminal event or -1].
    full : None or bool
        :data:`ZONAL_ONLY` (``None``) for a force model of the two-body and zonal terms alone
        with no events but altitude crossings (compiles only those; same bits), else
        :data:`FULL`; see :func:`rhs_kind`.
    work : ndarray (WORK_ROWS, 6)
        Scratch space from the caller (its contents are ignored and overwritten). The kernel
        allocates no array (the event values are copies of ``ev_param``, which numba's array
        copy makes without an overload) and calls no ``min``/``max``: numba compiles its ``np.empty``,
        ``np.zeros``, ``min`` and ``max`` overloads anew in every process for every signature,
        0.4 s of a first call's CPU (see docs/performance.md, "Cold start").

    Returns
    -------
    int
        Status code (``OK`` or ``STEP_TOO_SMALL``).
    """
    n = 6
    n_ev = ev_kind.shape[0]
    n_out = t_out.shape[0]
    cap = ev_t.shape[0]
    K = work[0:16]
    F = work[16:23]
    y = work[23]
    y_new = work[24]
    y_tmp = work[25]
    f = work[26]
    scale = work[27]
    err5 = work[28]
    err3 = work[29]
    gs0 = work[30]
    gs1 = work[31]
    sun_s = work[32]
    gs2 = work[33]
    gs3 = work[34]
    gb0 = work[35]
    gb1 = work[36]
    for i in range(WORK_ROWS):
        for j in range(n):
            work[i, j] = 0.0
    for j in range(n):
        y[j] = y0[j]
    g_old = ev_param.copy()  # event values (array copies need no np.empty overload)
    g_new = ev_param.copy()
    direction = 1.0 if t_end >= 0.0 else -1.0
    t = 0.0
    nfev = 0
    n_steps = 0
    n_found = 0
    written = 0
    terminal_index = -1
    info[5] = -1.0
    # SRP with a shadow (FULL kernel only): steps end at the shadow boundaries, never cross them
    # (module docstring, "Shadow boundaries"); side0/side1: +1 outside the boundary, -1 inside
    rforce = force
    sh_model = 0
    n_sh = 0
    side0 = 1.0
    side1 = 1.0
    # Eclipse events without SRP's shadow: steps end at the boundaries of the events' shadow
    # (no force changes there), so that an eclipse shorter than a step or a graze is found; the
    # second model's (sh2, sides side2, side3): eclipse events of the other model
    lock = False  # SRP's shadow: the force is locked on a side during a step
    sh2 = 0
    n_sh2 = 0
    side2 = 1.0
    side3 = 1.0
    if full is not None:
        sh_model, sh2, lock = boundary_models(force, ev_kind)
        if sh_model > 0:
            n_sh = 1 if sh_model == 1 else 2
            side0, side1 = shadow_sides(sh_model, t, y, force, eph_r, eph_v, sun_s)
        if sh2 > 0:
            n_sh2 = 1 if sh2 == 1 else 2
            side2, side3 = shadow_sides(sh2, t, y, force, eph_r, eph_v, sun_s)
        if lock or bands_on(force):
            rforce = force.copy()
        if lock:
            lock_shadow(rforce, sh_model, side0)
    # drag in the exponential table: steps end at its band edges, the band held in a step
    # (visviva.core.drag_bands)
    band = -1
    if full is not None:
        if bands_on(force):
            band = start_band(t, rforce, y, atm)
    bnd_pending = False  # the step being tried ends at the boundary t_bnd
    t_bnd = 0.0
    bnd_which = -1
    h_keep = 0.0  # the step size before the step was cut at a boundary
    pen_cap = math.inf  # the largest step in the penumbra
    n_here = 0  # boundaries crossed at the current t without a step (guard)

    # outputs at the start time
    while written < n_out and t_out[written] * direction <= 0.0:
        for j in range(n):
            y_out[written, j] = y[j]
        written += 1

    _rhs(t, y, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, f, full)
    nfev += 1
    for e in range(n_ev):
        g_old[e] = event_value(ev_kind[e], ev_param[e], t, y, force, eph_r, eph_v, full)

    interval = abs(t_end)
    if interval == 0.0:
        info[0] = written
        info[1] = 0
        info[2] = 0
        info[3] = nfev
        info[4] = 0.0
        return st.OK

    # initial step (Hairer, Norsett & Wanner, sec. II.4)
    for j in range(n):
        scale[j] = atol + abs(y[j]) * rtol
    d0 = _rms_norm(y, scale)
    d1 = _rms_norm(f, scale)
    if d0 < 1e-5 or d1 < 1e-5:
        h0 = 1e-6
    else:
        h0 = 0.01 * d0 / d1
    h0 = interval if interval < h0 else h0  # min(h0, interval), also below: same selections
    for j in range(n):
        y_tmp[j] = y[j] + h0 * direction * f[j]
    _rhs(t + h0 * direction, y_tmp, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, y_new, full)
    nfev += 1
    for j in range(n):
        err5[j] = y_new[j] - f[j]
    d2 = _rms_norm(err5, scale) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = h0 * 1e-3 if h0 * 1e-3 > 1e-6 else 1e-6
    else:
        h1 = (0.01 / (d2 if d2 > d1 else d1)) ** (1.0 / 8.0)
    h_abs = 100.0 * h0  # min(100 h0, h1, interval, h_max)
    h_abs = h1 if h1 < h_abs else h_abs
    h_abs = interval if interval < h_abs else h_abs
    h_abs = h_max if h_max < h_abs else h_abs

    status = st.OK
    finished = False
    while not finished:
        if n_steps >= max_steps:
            status = st.STEP_TOO_SMALL
            break
        min_step = 10.0 * abs(math.nextafter(t, direction * math.inf) - t)
        if h_abs > h_max:
            h_abs = h_max
        if full is not None:
            if side0 < 0.0 and side1 > 0.0 and h_abs > pen_cap and pen_cap > 100.0 * min_step:
                h_abs = pen_cap  # in the penumbra (conical shadow)
        if h_abs < min_step:
            status = st.STEP_TOO_SMALL
            break
        accepted = False
        rejected = False
        h = 0.0
        t_new = 0.0
        while not accepted:
            if h_abs < min_step:
                break
            h = h_abs * direction
            t_new = t + h
            if direction * (t_new - t_end) > 0.0:
                t_new = t_end
            if full is not None:
                if bnd_pending and direction * (t_new - t_bnd) > -BOUNDARY_RTOL * h_abs:
                    t_new = t_bnd
            h = t_new - t
            h_abs = abs(h)
            # stages
            for j in range(n):
                K[0, j] = f[j]
            for s in range(1, _N_STAGES):
                rk_combine(n, y, K, A[s], s, h, y_tmp)
                _rhs(t + C[s] * h, y_tmp, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, K[s], full)
            rk_combine(n, y, K, B, _N_STAGES, h, y_new)
            _rhs(t + h, y_new, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, K[_N_STAGES], full)
            nfev += _N_STAGES
            for j in range(n):
                ay = abs(y[j])
                an = abs(y_new[j])
                scale[j] = atol + (an if an > ay else ay) * rtol
                a5 = 0.0
                a3 = 0.0
                for m in range(_N_STAGES + 1):
                    a5 += E5[m] * K[m, j]
                    a3 += E3[m] * K[m, j]
                err5[j] = a5 / scale[j]
                err3[j] = a3 / scale[j]
            e5 = 0.0
            e3 = 0.0
            for j in range(n):
                e5 += err5[j] * err5[j]
                e3 += err3[j] * err3[j]
            if e5 == 0.0 and e3 == 0.0:
                err = 0.0
            else:
                err = h_abs * e5 / math.sqrt((e5 + 0.01 * e3) * n)
            if err < 1.0:
                if err == 0.0:
                    factor = _MAX_FACTOR
                else:
                    factor = _SAFETY * err ** (-1.0 / 8.0)
                    factor = factor if factor < _MAX_FACTOR else _MAX_FACTOR
                if rejected and not factor < 1.0:
                    factor = 1.0
                h_abs *= factor
                accepted = True
            else:
                shrink = _SAFETY * err ** (-1.0 / 8.0)
                h_abs *= shrink if shrink > _MIN_FACTOR else _MIN_FACTOR
                rejected = True
        if not accepted:
            status = st.STEP_TOO_SMALL
            break
        n_steps += 1

        # dense output coefficients for [t, t + h]
        for s in range(_N_STAGES + 1, 16):
            rk_combine(n, y, K, A[s], s, h, y_tmp)
            _rhs(t + C[s] * h, y_tmp, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, K[s], full)
        nfev += 3
        dense_coefficients(n, h, y, y_new, K, D, F)

        # a shadow boundary crossed within the step: redo the step up to it
        flip = -1
        resync = False
        fresh = 0  # 1: the shadow samples of sh_model are at t_new, 2: those of sh2 too
        if full is not None:
            if n_sh > 0 or band >= 0:
                at_boundary = bnd_pending and t_new == t_bnd
                bnd_pending = False
                if at_boundary:
                    flip = bnd_which
                elif n_here > 2 * (n_sh + n_sh2) + (2 if band >= 0 else 0):
                    resync = True  # found at t again and again: take the step, sides from its end
                else:
                    ta_b = t
                    tb_b = t
                    which_b = -1
                    if n_sh > 0:
                        ta_b, tb_b, which_b = shadow_crossing(sh_model, n_sh, side0, side1, t, h,
                                                              y, y_new, F, y_tmp, gs0, gs1, sun_s,
                                                              force, eph_r, eph_v)  # fmt: skip
                        if t + h == t_new:  # (the last sample's time: the events' own)
                            fresh = 2 if sh2 > 0 else 1
                    if sh2 > 0:
                        ta_2, tb_2, which_2 = shadow_crossing(sh2, n_sh2, side2, side3, t, h, y,
                                                              y_new, F, y_tmp, gs2, gs3, sun_s,
                                                              force, eph_r, eph_v)  # fmt: skip
                        if which_2 >= 0 and (which_b < 0 or (tb_2 - tb_b) * h < 0.0):
                            ta_b = ta_2
                            tb_b = tb_2
                            which_b = which_2 + 2  # 2, 3: the second model's boundaries
                    if band >= 0:
                        ta_3, tb_3, which_3 = band_crossing(band, atm, t, h, y, y_new, F, y_tmp,
                                                            gb0, gb1, force, eph_r, eph_v)
                        if which_3 >= 0 and (which_b < 0 or (tb_3 - tb_b) * h < 0.0):
                            ta_b = ta_3
                            tb_b = tb_3
                            which_b = which_3 + 4  # 4, 5: the band's lower, upper edge
                    if which_b >= 0:
                        if which_b >= 4:
                            at_t, _, _, t_bnd, h_keep, h_abs = boundary_plan(
                                ta_b, tb_b, 0, t, h, h_abs, min_step, 1.0, 1.0)
                        elif which_b < 2:
                            at_t, side0, side1, t_bnd, h_keep, h_abs = boundary_plan(
                                ta_b, tb_b, which_b, t, h, h_abs, min_step, side0, side1)
                        else:
                            at_t, side2, side3, t_bnd, h_keep, h_abs = boundary_plan(
                                ta_b, tb_b, which_b - 2, t, h, h_abs, min_step, side2, side3)
                        if at_t:
                            # the boundary is at t (within the tolerance): crossed here
                            if lock and which_b < 2:
                                lock_shadow(rforce, sh_model, side0)
                                _rhs(t, y, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, f, full)
                                nfev += 1
                            if which_b >= 4:
                                band += 2 * which_b - 9  # 4: one band down, 5: one up
                                hold_band(rforce, band)
                                _rhs(t, y, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, f, full)
                                nfev += 1
                            n_here += 1
                        else:
                            bnd_pending = True
                            bnd_which = which_b
                        continue

        # events in (t, t_new] (altitude crossings only in the ZONAL_ONLY kernel: rhs_kind)
        t_stop = t_new
        if n_ev > 0:
            for e in range(n_ev):
                # eclipse events: the shadow functions' last samples, taken at (t_new, y_new)
                done = False
                if full is not None:
                    if fresh > 0:
                        done, g_new[e] = end_sample_value(ev_kind[e], sh_model, side0, side1,
                                                          gs0, gs1)
                    if fresh > 1 and not done:
                        done, g_new[e] = end_sample_value(ev_kind[e], sh2, side2, side3, gs2, gs3)
                if not done:
                    g_new[e] = event_value(ev_kind[e], ev_param[e], t_new, y_new, force, eph_r,
                                           eph_v, full)
            if full is not None:
                if flip >= 0:
                    # the step ends at a shadow boundary: an event on the same boundary
                    # function takes the side beyond it (its value there may round to either
                    # side)
                    if flip < 2:
                        fix_boundary_events(ev_kind, g_new, shadow_boundary_kind(sh_model, flip),
                                            -(side0 if flip == 0 else side1))
                    elif flip < 4:
                        fix_boundary_events(ev_kind, g_new, shadow_boundary_kind(sh2, flip - 2),
                                            -(side2 if flip == 2 else side3))
            # find all crossings in this step, ordered in time
            while True:
                best_t = t_stop
                best_e = -1
                best_sign = 0.0
                for e in range(n_ev):
                    ga = g_old[e]
                    gb = g_new[e]
                    if ga == 0.0 or (ga < 0.0) == (gb < 0.0) and gb != 0.0:
                        continue
                    # rising in physical time: integrating backwards, g_new is the earlier value
                    rising = (gb > ga) == (direction > 0.0)
                    if ev_dir[e] > 0 and not rising:
                        continue
                    if ev_dir[e] < 0 and rising:
                        continue
                    # Illinois regula falsi on the dense output between t and t_stop
                    ta, tb = locate_zero(ev_kind[e], ev_param[e], t, t_new, ga, gb, ev_tol, t, h,
                                         y, F, y_tmp, force, eph_r, eph_v, full)
                    # the crossing lies within [ta, tb], narrower than ev_tol: report its middle
                    tc = 0.5 * (ta + tb)
                    if direction * (tc - best_t) < 0.0 or best_e < 0:
                        if direction * (tc - t_stop) <= 0.0:
                            best_t = tc
                            best_e = e
                            best_sign = 1.0 if rising else -1.0
                if best_e < 0:
                    break
                # record it
                if n_found < cap:
                    ev_t[n_found] = best_t
                    dense_eval(best_t, t, h, y, F, y_tmp)
                    for j in range(n):
                        ev_y[n_found, j] = y_tmp[j]
                    ev_which[n_found] = (best_e + 1) * best_sign
                n_found += 1
                # mark this event as done for this step
                g_old[best_e] = g_new[best_e]
                if ev_terminal[best_e] != 0:
                    t_stop = best_t
                    terminal_index = best_e
                    break
                # other events before this one were already handled (each event at most once per
                # step: the step is short compared with an orbit)
        # outputs in (t, t_stop]
        while written < n_out and direction * (t_out[written] - t_stop) <= 0.0:
            if t_out[written] == t_new and terminal_index < 0:
                for j in range(n):
                    y_out[written, j] = y_new[j]
            else:
                dense_eval(t_out[written], t, h, y, F, y_tmp)
                for j in range(n):
                    y_out[written, j] = y_tmp[j]
            written += 1
        if terminal_index >= 0:
            t = t_stop
            info[5] = terminal_index
            finished = True
            break
        for e in range(n_ev):
            g_old[e] = g_new[e]
        t = t_new
        for j in range(n):
            y[j] = y_new[j]
            f[j] = K[_N_STAGES, j]
        if full is not None:
            if flip >= 0 or resync:
                if 0 <= flip < 2 and sh_model == 2 and lock:
                    v = math.sqrt(y[3] * y[3] + y[4] * y[4] + y[5] * y[5])
                    pen_cap = penumbra_step(gs0[0] * side0, gs1[0] * side1, flip, h,
                                            force[fb.SRP_COEFFICIENT], atol + rtol * v)
                if flip == 0:
                    side0 = -side0
                elif flip == 1:
                    side1 = -side1
                elif flip == 2:
                    side2 = -side2
                elif flip == 3:
                    side3 = -side3
                elif flip >= 4:
                    band += 2 * flip - 9  # 4: one band down, 5: one up
                else:
                    if sh_model > 0:
                        side0, side1 = shadow_sides(sh_model, t, y, force, eph_r, eph_v, sun_s)
                    if sh2 > 0:
                        side2, side3 = shadow_sides(sh2, t, y, force, eph_r, eph_v, sun_s)
                    if band >= 0:
                        band = start_band(t, rforce, y, atm)
                if band >= 0 and (flip >= 4 or resync):
                    # the density jumps at the edge: the next band, a fresh derivative (no FSAL)
                    hold_band(rforce, band)
                    _rhs(t, y, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, f, full)
                    nfev += 1
                if sh_model == 1 and lock and flip < 2:
                    # the force changes at the boundary: a fresh derivative (no FSAL)
                    lock_shadow(rforce, sh_model, side0)
                    _rhs(t, y, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, f, full)
                    nfev += 1
                if flip >= 0 and h_keep > h_abs:
                    h_abs = h_keep
            n_here = 0
        if direction * (t - t_end) >= 0.0:
            finished = True

    info[0] = written
    info[1] = n_found
    info[2] = n_steps
    info[3] = nfev
    info[4] = t
    return status


@parallel_kernel
def integrate_cowell_many(
    y0, t_out, t_end, rtol, atol, h_max, max_steps, force, zonal, atm, eph_r, eph_v, eph_gm, sh,
    A, B, C, E3, E5, D, y_out, status, info, full, ev_kind, ev_param, ev_dir,
):  # fmt: skip
    """:func:`integrate_cowell` for N initial states (rows of ``y0``) in parallel.

    ``force`` is (1, F), one block for every state, or (N, F), state k flying row k (an
    unscented filter's sigma points each with its own drag or SRP coefficient).
    ``y_out`` (N, T, 6), ``status`` (N,), ``info`` (N, 6) are written per state.
    ``ev_kind``, ``ev_param``, ``ev_dir`` (E,): terminal events only, the same for every state
    (the surface of :mod:`visviva.satellites.surface` that bounds a perturbed run; none: empty
    arrays): a state that meets one stops there, ``info[k, 5]`` its index (else -1),
    ``info[k, 4]`` the time, ``info[k, 0]`` the outputs written before it (the rest of
    ``y_out[k]`` is left as it was). Their records are not returned.
    """
    for k in prange(y0.shape[0]):
        force_k = force[k % force.shape[0]]  # row 0 for all, or row k
        ev_t = np.zeros(2)  # one terminal crossing is recorded, then the run stops
        ev_y = np.zeros((2, 6))
        ev_which = np.zeros(2)
        ev_terminal = np.ones(ev_kind.shape[0], dtype=np.int64)
        work = np.zeros((WORK_ROWS, 6))
        status[k] = integrate_cowell(
            y0[k], t_out, t_end, rtol, atol, h_max, max_steps, force_k, zonal, atm, eph_r,
            eph_v, eph_gm, sh, ev_kind, ev_param, ev_dir, ev_terminal, 1e-6, A, B, C, E3, E5, D,
            y_out[k], ev_t, ev_y, ev_which, info[k], full, work,
        )  # fmt: skip
