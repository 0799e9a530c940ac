"""State and state-transition matrix of Cowell's force model, by the variational equations.

The state y = (r, v) and its state-transition matrix Phi(t, t0) = d y(t) / d y(t0) are
integrated together (42 components):

    y' = f(t, y),    Phi' = F(t, y) Phi,    Phi(t0) = I,

with F = [[0, I], [da/dr, da/dv]] the Jacobian of the right-hand side
:func:`visviva.core.perturbations.cowell_rhs`, evaluated analytically
(:func:`acceleration_partials`; Montenbruck & Gill 2000, sec. 7.2, eqs. 7.42-7.45;
Vallado 2013, sec. 10.4). The force model is the same flat parameter block that
:func:`visviva.core.cowell.integrate_cowell` reads (see :mod:`visviva.core.perturbations`), so
the trajectory is the one ``propagate_cowell`` computes, to the integration tolerance.

The partials F are :func:`visviva.core.force_partials.acceleration_partials` (each exact for its
force term; see that module).

Parameter sensitivities: with ``phi_out`` of 6 + N_PARAMETERS columns the matrix carries two more
columns, S = d y / d p on the force block's drag coefficient (``BALLISTIC``, Cd A / m) and SRP
coefficient (``SRP_COEFFICIENT``), integrated with the STM as S' = F S + [0; da/dp], S(t0) = 0
(the sensitivity matrix of Montenbruck & Gill 2000, sec. 7.1), the
accelerations being linear in their coefficients (da/dp is the acceleration of a unit coefficient,
:func:`visviva.core.force_partials.parameter_accelerations`). The steps, their error control on the
state and the saltation at the boundaries (which do not move with p) are those of the STM alone:
a run without the columns is bitwise the run it was before they existed.

Integration is DOP853 (the tableau of :mod:`visviva.core.cowell`) with the step-size control
on the six state components only; each step is shortened to land on the next output time, so
the STM at every output is that of the integrated trajectory. With SRP and a shadow model the
steps also end at the shadow's boundaries, as in :func:`visviva.core.cowell.integrate_cowell`
(:mod:`visviva.core.cowell_events`, "Shadow boundaries"; the boundaries are found on the dense
output of the state, from three extra stages of the state alone), so both integrators follow
the same trajectory to their tolerances; runs without a shadow take the same steps, with the
same bits, as before this handling.
"""

from __future__ import annotations

import math

import numpy as np

from . import force_block as fb
from . import status as st
from ._jit import kernel
from .cowell import dense_coefficients, rk_combine
from .cowell_events import (
    BOUNDARY_RTOL,
    boundary_gradient,
    boundary_plan,
    lock_shadow,
    penumbra_step,
    shadow_crossing,
    shadow_sides,
    srp_shadow_model,
)
from .drag_bands import altitude_gradient, band_crossing, bands_on, hold_band, start_band
from .force_partials import N_PARAMETERS, acceleration_partials, parameter_accelerations
from .perturbations import cowell_rhs

__all__ = ["acceleration_partials", "variational_rhs", "integrate_variational", "N_VAR"]

#: components of the augmented state: 6 (r, v) + 36 (Phi, row-major)
N_VAR = 42
_SAFETY = 0.9
_MIN_FACTOR = 0.2
_MAX_FACTOR = 10.0
_N_STAGES = 12


@kernel
def variational_rhs(t, y, force, zonal, atm, eph_r, eph_v, eph_gm, sh, dy, dadr, dadv):
    """Derivative of the augmented state (r, v, Phi): 42 components, Phi row-major; or
    6 + 6 (6 + N_PARAMETERS) components, Phi with the sensitivities S = d y / d p on the
    force block's drag and SRP coefficients as its last columns (S' = F S + [0; da/dp])."""
    cowell_rhs(t, y[:6], force, zonal, atm, eph_r, eph_v, eph_gm, sh, dy[:6])
    acceleration_partials(t, y[:6], force, zonal, atm, eph_r, eph_v, eph_gm, sh, dadr, dadv)
    nc = (y.shape[0] - 6) // 6  # 6, or 6 + N_PARAMETERS with the parameters' columns
    # Phi' = F Phi with F = [[0, I], [dadr, dadv]]
    for j in range(nc):
        for i in range(3):
            dy[6 + i * nc + j] = y[6 + (i + 3) * nc + j]
        for i in range(3):
            acc = 0.0
            for m in range(3):
                acc += dadr[i, m] * y[6 + m * nc + j] + dadv[i, m] * y[6 + (m + 3) * nc + j]
            dy[6 + (i + 3) * nc + j] = acc
    if nc > 6:
        # S' = F S + [0; d a / d p]: the partials on the coefficients (dadr is free now)
        parameter_accelerations(t, y[:6], force, atm, eph_r, eph_v, dadr)
        for p in range(N_PARAMETERS):
            for i in range(3):
                dy[6 + (i + 3) * nc + 6 + p] += dadr[p, i]


@kernel
def _boundary_jump(model, which, t, y, a_old, a_new, force, eph_r, eph_v, s, grad):
    """Apply the saltation matrix of a jump of the acceleration from ``a_old`` to ``a_new``
    (km/s^2) at shadow boundary ``which`` (crossed at t, y) to the STM in ``y[6:]``.

    A trajectory started at x0 + dx0 reaches the boundary g = 0 at t + dt, dt = -grad g . dx /
    g_dot, and spends dt longer (or shorter) under the old force: after the boundary its
    deviation is dx + (f_new - f_old) grad g . dx / g_dot. So Phi+ = (I + (f_new - f_old)
    grad g^T / g_dot) Phi- (the saltation matrix; Hiskens & Pai 2000), with g the boundary
    function (:func:`visviva.core.cowell_events.boundary_gradient`, position only) and f the
    derivative of the state, which jumps in its acceleration only."""
    rate = boundary_gradient(model, which, t, y, force, eph_r, eph_v, s, grad)
    _saltation(y, a_old, a_new, grad, rate)


@kernel
def _saltation(y, a_old, a_new, grad, rate):
    """Phi+ = (I + (f_new - f_old) grad g^T / g_dot) Phi- on the STM in ``y[6:]``: the jump of
    the acceleration from ``a_old`` to ``a_new`` at a boundary g = 0 of position gradient
    ``grad`` crossed at the rate ``rate`` (:func:`_boundary_jump`)."""
    if rate == 0.0:
        return
    nc = (y.shape[0] - 6) // 6  # the boundary does not move with p: S jumps as Phi does
    for j in range(nc):
        w = (grad[0] * y[6 + j] + grad[1] * y[6 + nc + j] + grad[2] * y[6 + 2 * nc + j]) / rate
        for i in range(3):
            y[6 + (3 + i) * nc + j] += (a_new[i] - a_old[i]) * w


@kernel
def integrate_variational(y0, t_out, rtol, atol, h_max, max_steps, force, zonal, atm, eph_r,
                          eph_v, eph_gm, sh, A, B, C, E3, E5, D, y_out, phi_out, info):  # fmt: skip
    """Integrate the state and its STM from t = 0 to each of the output times ``t_out``.

    Parameters
    ----------
    y0 : ndarray (6,)
        State at t = 0: position (km), velocity (km/s).
    t_out : ndarray (T,)
        Output times, s, monotonic (all >= 0 increasing, or all <= 0 decreasing).
    rtol, atol : float
        Tolerances of the state's local error (atol in km and km/s).
    h_max : float
        Largest step, s.
    max_steps : int
        Step budget; beyond it the status is ``STEP_TOO_SMALL``.
    force, zonal, atm, eph_r, eph_v, eph_gm, sh : ndarray
        The force model (:mod:`visviva.core.perturbations`).
    A, B, C, E3, E5, D : ndarray
        The DOP853 tableau (``D``: the dense output, used with a shadow only).
    y_out : ndarray (T, 6)
        Output: states at ``t_out``.
    phi_out : ndarray (T, 6, 6) or (T, 6, 6 + N_PARAMETERS)
        Output: Phi(t_out, 0); with 8 columns also the sensitivities d y(t_out) / d p on
        ``force[BALLISTIC]`` and ``force[SRP_COEFFICIENT]`` (p(0) = 0 columns, integrated
        alongside Phi with the same steps; the error control is on the state only).
    info : ndarray (3,)
        Output: [outputs written, steps (with a shadow, also those redone up to a boundary),
        right-hand-side evaluations].

    Returns
    -------
    int
        ``OK`` or ``STEP_TOO_SMALL``.
    """
    nc = phi_out.shape[2]  # 6, or 6 + N_PARAMETERS: the coefficients' sensitivities too
    n = 6 + 6 * nc
    n_out = t_out.shape[0]
    y = np.zeros(n)
    for j in range(6):
        y[j] = y0[j]
        y[6 + j * nc + j] = 1.0
    K = np.zeros((16, n))
    y_new = np.empty(n)
    y_tmp = np.empty(n)
    f = np.empty(n)
    dadr = np.empty((3, 3))
    dadv = np.empty((3, 3))
    direction = 1.0
    for k in range(n_out):
        if t_out[k] < 0.0:
            direction = -1.0
    t = 0.0
    written = 0
    n_steps = 0
    nfev = 0
    status = st.OK
    # SRP with a shadow: steps end at the shadow boundaries, as in integrate_cowell (see
    # visviva.core.cowell_events, "Shadow boundaries"); side0/side1 +1 outside, -1 inside
    rforce = force
    sh_model = 0
    n_sh = 0
    side0 = 1.0
    side1 = 1.0
    F = np.zeros((7, 6))
    # rows: the dense state, two sample rows, the Sun, a_old, grad, two rows of altitudes
    scr = np.zeros((8, 6))
    if srp_shadow_model(force) > 0:
        sh_model = srp_shadow_model(force)
        n_sh = 1 if sh_model == 1 else 2
        side0, side1 = shadow_sides(sh_model, t, y, force, eph_r, eph_v, scr[3])
        rforce = force.copy()
        lock_shadow(rforce, sh_model, side0)
    # drag in the exponential table: steps end at its band edges (visviva.core.drag_bands)
    band = -1
    if bands_on(force):
        if n_sh == 0:
            rforce = force.copy()
        band = start_band(t, rforce, y, atm)
    bnd_pending = False
    t_bnd = 0.0
    bnd_which = -1
    h_keep = 0.0
    pen_cap = math.inf
    n_here = 0
    variational_rhs(t, y, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, f, dadr, dadv)
    nfev += 1
    # a first step of 1/200 of the orbital period-ish: |r|/|v| / 20
    rr = math.sqrt(y[0] ** 2 + y[1] ** 2 + y[2] ** 2)
    vv = math.sqrt(y[3] ** 2 + y[4] ** 2 + y[5] ** 2)
    h_abs = min(h_max, 0.05 * rr / max(vv, 1e-12))
    while written < n_out:
        target = t_out[written]
        if direction * (target - t) <= 0.0:
            for j in range(6):
                y_out[written, j] = y[j]
                for m in range(nc):
                    phi_out[written, j, m] = y[6 + j * nc + m]
            written += 1
            continue
        if n_steps >= max_steps:
            status = st.STEP_TOO_SMALL
            break
        min_step = 10.0 * abs(math.nextafter(t, direction * math.inf) - t)
        if n_sh > 0 and side0 < 0.0 and side1 > 0.0 and h_abs > pen_cap > 100.0 * min_step:
            h_abs = pen_cap  # in the penumbra (conical shadow)
        accepted = False
        rejected = False
        h = 0.0
        landing = False
        at_bnd = False
        while not accepted:
            if h_abs < 1e-14 * max(1.0, abs(t)):
                break
            h = min(h_abs, h_max) * direction
            landing = direction * (t + h - target) >= 0.0
            if landing:
                h = target - t
            at_bnd = False
            if bnd_pending and direction * (t + h - t_bnd) > -BOUNDARY_RTOL * abs(h):
                h = t_bnd - t
                at_bnd = True
                landing = t_bnd == target
            for j in range(n):
                K[0, j] = f[j]
            for s in range(1, _N_STAGES):
                rk_combine(n, y, K, A[s], s, h, y_tmp)
                variational_rhs(t + C[s] * h, y_tmp, rforce, zonal, atm, eph_r, eph_v, eph_gm,
                                sh, K[s], dadr, dadv)  # fmt: skip
            rk_combine(n, y, K, B, _N_STAGES, h, y_new)
            variational_rhs(t + h, y_new, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh,
                            K[_N_STAGES], dadr, dadv)  # fmt: skip
            nfev += _N_STAGES
            e5 = 0.0
            e3 = 0.0
            for j in range(6):
                scale = atol + max(abs(y[j]), abs(y_new[j])) * rtol
                a5 = 0.0
                a3 = 0.0
                for m in range(_N_STAGES + 1):
                    a5 += E5[m] * K[m, j]
                    a3 += E3[m] * K[m, j]
                e5 += (a5 / scale) ** 2
                e3 += (a3 / scale) ** 2
            if e5 == 0.0 and e3 == 0.0:
                err = 0.0
            else:
                err = abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * 6)
            if err < 1.0:
                factor = _MAX_FACTOR if err == 0.0 else min(_MAX_FACTOR,
                                                            _SAFETY * err ** (-1.0 / 8.0))
                if rejected:
                    factor = min(1.0, factor)
                if not (landing or at_bnd) or factor < 1.0:
                    h_abs = abs(h) * factor
                accepted = True
            else:
                h_abs = abs(h) * max(_MIN_FACTOR, _SAFETY * err ** (-1.0 / 8.0))
                rejected = True
        if not accepted:
            status = st.STEP_TOO_SMALL
            break
        n_steps += 1
        flip = -1
        resync = False
        if n_sh > 0 or band >= 0:
            bnd_pending = False
            if at_bnd:
                flip = bnd_which
            elif n_here > 2 * n_sh + (2 if band >= 0 else 0):
                resync = True
            else:
                # the state's dense output (its own three extra stages, state only)
                for s in range(_N_STAGES + 1, 16):
                    rk_combine(6, y, K, A[s], s, h, y_tmp)
                    cowell_rhs(t + C[s] * h, y_tmp[:6], rforce, zonal, atm, eph_r, eph_v,
                               eph_gm, sh, K[s, :6])  # fmt: skip
                nfev += 3
                dense_coefficients(6, h, y, y_new, K, D, F)
                ta_b = t
                tb_b = t
                which_b = -1
                if n_sh > 0:
                    ta_b, tb_b, which_b = shadow_crossing(sh_model, n_sh, side0, side1, t, h,
                                                          y[:6], y_new[:6], F, scr[0], scr[1],
                                                          scr[2], scr[3], force, eph_r, eph_v)  # fmt: skip
                if band >= 0:
                    ta_3, tb_3, which_3 = band_crossing(band, atm, t, h, y[:6], y_new[:6], F,
                                                        scr[0], scr[6], scr[7], force, eph_r,
                                                        eph_v)  # fmt: skip
                    if which_3 >= 0 and (which_b < 0 or (tb_3 - tb_b) * h < 0.0):
                        ta_b = ta_3
                        tb_b = tb_3
                        which_b = which_3 + 4  # 4, 5: the band's lower, upper edge
                if which_b >= 0:
                    side_before = side0
                    if which_b >= 4:
                        at_t, _, _, t_bnd, h_keep, h_abs = boundary_plan(
                            ta_b, tb_b, 0, t, h, h_abs, min_step, 1.0, 1.0)
                    else:
                        at_t, side0, side1, t_bnd, h_keep, h_abs = boundary_plan(
                            ta_b, tb_b, which_b, t, h, h_abs, min_step, side0, side1)
                    if at_t:
                        # the boundary is at t: crossed here
                        if which_b >= 4:
                            band += 2 * which_b - 9
                            _cross_band(band, t, y, f, rforce, zonal, atm, eph_r, eph_v, eph_gm,
                                        sh, dadr, dadv, scr)  # fmt: skip
                        else:
                            _cross(sh_model, which_b, t, y, f, rforce, zonal, atm, eph_r, eph_v,
                                   eph_gm, sh, side_before, dadr, dadv, scr)  # fmt: skip
                        nfev += 2
                        n_here += 1
                    else:
                        bnd_pending = True
                        bnd_which = which_b
                    continue
        t_old = t
        if landing:
            t = target
        elif at_bnd:
            t = t_bnd
        else:
            t = t + h
        for j in range(n):
            y[j] = y_new[j]
            f[j] = K[_N_STAGES, j]
        if band >= 0 and (flip >= 4 or resync):
            if flip >= 4:
                band += 2 * flip - 9  # 4: one band down, 5: one up
                _cross_band(band, t, y, f, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, dadr,
                            dadv, scr)  # fmt: skip
                nfev += 2
                if h_keep > h_abs:
                    h_abs = h_keep
            else:
                band = start_band(t, rforce, y, atm)
                variational_rhs(t, y, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, f, dadr,
                                dadv)  # fmt: skip
                nfev += 1
            if flip >= 4:
                flip = -2  # done: not a shadow boundary
            n_here = 0
        if n_sh > 0:
            if 0 <= flip < 4 or resync:
                if flip >= 0 and sh_model == 2:
                    pen_cap = penumbra_step(scr[1, 0] * side0, scr[2, 0] * side1, flip,
                                            t - t_old, force[fb.SRP_COEFFICIENT],
                                            atol + rtol * math.sqrt(y[3] ** 2 + y[4] ** 2
                                                                    + y[5] ** 2))  # fmt: skip
                if flip >= 0:
                    if sh_model == 1:
                        _cross(sh_model, flip, t, y, f, rforce, zonal, atm, eph_r, eph_v,
                               eph_gm, sh, side0, dadr, dadv, scr)  # fmt: skip
                        nfev += 2
                    if flip == 0:
                        side0 = -side0
                    else:
                        side1 = -side1
                    if h_keep > h_abs:
                        h_abs = h_keep
                else:
                    side0, side1 = shadow_sides(sh_model, t, y, force, eph_r, eph_v, scr[3])
                    if sh_model == 1:
                        lock_shadow(rforce, sh_model, side0)
                        variational_rhs(t, y, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, f,
                                        dadr, dadv)  # fmt: skip
                        nfev += 1
        n_here = 0  # a step was taken
    info[0] = written
    info[1] = n_steps
    info[2] = nfev
    return status


@kernel
def _cross(model, which, t, y, f, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, side0, dadr,
           dadv, scr):  # fmt: skip
    """Cross boundary ``which`` of SRP shadow ``model`` at (t, y) (the state with its STM; the
    side of boundary 0 before the crossing ``side0``): the cylindrical shadow's force jumps, so
    the shadow is locked on the new side, the STM takes the saltation matrix of the jump
    (:func:`_boundary_jump`) and ``f`` the derivative after it. The conical shadow's force is
    continuous: nothing changes (the caller flips the side)."""
    if model != 1:
        return
    for i in range(3):
        scr[4, i] = f[3 + i]
    lock_shadow(rforce, model, -side0)
    variational_rhs(t, y, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, f, dadr, dadv)
    _boundary_jump(model, which, t, y, scr[4, :3], f[3:6], rforce, eph_r, eph_v, scr[3], scr[5])
    variational_rhs(t, y, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, f, dadr, dadv)


@kernel
def _cross_band(band, t, y, f, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, dadr, dadv, scr):
    """Cross into band ``band`` of the exponential atmosphere at (t, y) (the state with its
    STM): the band is held, the density jumps, so the STM takes the saltation matrix of the
    jump across the altitude boundary (:func:`_saltation`, with the altitude's gradient,
    :func:`visviva.core.drag_bands.altitude_gradient`) and ``f`` the derivative after it."""
    for i in range(3):
        scr[4, i] = f[3 + i]
    hold_band(rforce, band)
    variational_rhs(t, y, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, f, dadr, dadv)
    rate = altitude_gradient(t, y, rforce, scr[5])
    _saltation(y, scr[4, :3], f[3:6], scr[5, :3], rate)
    variational_rhs(t, y, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, f, dadr, dadv)
