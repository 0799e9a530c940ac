"""The tangent vector of an N-body run and the chaos indicator MEGNO: compiled kernels.

A tangent (variational) vector ``delta = (dx, dv)`` of shape (2, N, 3) follows the first-order
variational equations of the N-body problem along the integrated trajectory::

    dx' = dv,    dv' = J(x) dx,
    (J dx)_i = sum_{j massive, j != i} G m_j [ dx_ij / r^3 - 3 r_ij (r_ij . dx_ij) / r^5 ]

with ``r_ij = x_j - x_i``, ``dx_ij = dx_j - dx_i`` and ``r^2 = |r_ij|^2 + softening^2``
(:func:`tangent_acceleration`). The integrators advance it after each of their own accepted
steps, from the step they took, without changing the physical state (its bits are those of a
run without MEGNO):

* leapfrog (:func:`leapfrog_tangent`): the linearised drift-kick-drift map of the same step,
  Jacobian at the mid-step positions (symplectic, like the step itself);
* IAS15 (:func:`ias15_tangent`): Gauss-Radau collocation of the linear tangent equations on
  the step's seven substeps, the positions there taken from the step's converged polynomial;
  predictor-corrector until the tangent ``b6`` changes by less than 1e-16 of the tangent
  acceleration (or stops decreasing). The step size is the physical state's alone.

MEGNO (Cincotta & Simo 2000; Cincotta, Giordano & Simo 2003), with ``tau`` the time since the
start and ``f = (dx.dv + dv.J dx) / |delta|^2 = d ln|delta| / dt``::

    Y(tau) = (2 / tau) int_0^tau f(s) s ds,     <Y>(tau) = (1 / tau) int_0^tau Y(s) ds

accumulated once per step of the integrator from ``L = ln(|delta| / |delta_0|)`` at the step
ends (:func:`megno_update`): since ``f = dL/dt``, integrating by parts gives
``int_0^tau s f(s) ds = tau L(tau) - int_0^tau L(s) ds``, and only the smooth ``L`` is integrated
(trapezoidal rule) instead of the rapidly oscillating ``s f(s)``; ``<Y>`` then adds
``Y(tau_n) h_n`` per step, as REBOUND does. (The trapezoidal rule on ``s f(s)`` itself was 0.43 %
low after 500 orbits of the regular test system at IAS15's default steps; this form is within
0.01 % of the converged value there.)

``<Y> -> 2`` for quasi-periodic orbits, ``0`` for stable periodic (isochronous) ones and
``<Y> ~ lambda tau / 2`` for chaotic ones (lambda the maximal Lyapunov exponent); the slope of a
least-squares line through ``(tau_n, <Y>_n)`` (the running moments in ``fstate``) estimates
``lambda / 2`` (Cincotta & Simo 2000, eq. 24). ``<Y>`` is invariant under a rescaling of
``delta`` (``L`` shifts by a constant, which cancels in ``tau L - int L``), so the tangent vector
is rescaled by ``RESCALE`` when ``|delta|^2`` exceeds
``RESCALE_ABOVE`` (an exponentially growing chaotic vector would otherwise overflow).

The tangent state lives in ``N_TANGENT_SLOTS`` slots of ``buf`` after the integrator's own
(``base`` = the integrator's ``N_BUF``), the accumulators in ``fstate[F_MG_*]``, the switch in
``istate[I_MEGNO]``: a saved or copied simulation carries them.

References
----------
Cincotta, P. M. & Simo, C. (2000), "Simple tools to study global dynamics in non-axisymmetric
galactic potentials - I", A&AS 147, 205.
Cincotta, P. M., Giordano, C. M. & Simo, C. (2003), "Phase space structure of multi-dimensional
systems by means of the mean exponential growth factor of nearby orbits", Physica D 182, 151.
Rein, H. & Tamayo, D. (2016), "Second-order variational equations for N-body simulations",
MNRAS 459, 2275.
"""

from __future__ import annotations

import math

from ._jit import kernel
from .gauss_radau import BG, CB, RINV, H
from .nbody_common import (
    F_G,
    F_MG_COV,
    F_MG_DT_PREV,
    F_MG_ILN,
    F_MG_LN,
    F_MG_LN_SHIFT,
    F_MG_MEAN_T,
    F_MG_MEAN_Y,
    F_MG_N,
    F_MG_TAU,
    F_MG_VAR,
    F_MG_YS,
    F_MG_YSS,
    F_SOFT2,
    I_MEGNO,
)

__all__ = ["tangent_acceleration", "megno_update", "leapfrog_tangent", "ias15_tangent",
           "megno_on", "ln_norm_rescaled", "N_TANGENT_SLOTS", "DX", "DV", "RESCALE_ABOVE",
           "RESCALE"]

# slots after the integrator's own (offsets from base)
DX = 0  #: tangent positions
DV = 1  #: tangent velocities
_DA = 2  # tangent acceleration at the step start
_XP = 3  # physical positions at a substep (scratch)
_TXP = 4  # tangent positions at a substep (scratch)
_TB = 5  # 7 slots: the tangent acceleration's b coefficients (IAS15)
_TG = 12  # 7 slots: its g coefficients
_TF = 19  # the tangent acceleration at a substep
_X0 = 20  # the physical state at the step start (IAS15, from the step's polynomial)
_V0 = 21
#: Number of (N, 3) slots the tangent state takes in ``buf``.
N_TANGENT_SLOTS = 22
#: Rescale the tangent vector by :data:`RESCALE` when ``|delta|^2`` exceeds this.
RESCALE_ABOVE = 1e200
RESCALE = 1e-100
_MAX_ITERATIONS = 12


@kernel
def megno_on(istate, buf, base):
    """True when the run integrates the tangent vector (``istate[I_MEGNO] == 1`` and ``buf``
    has its slots)."""
    return istate[I_MEGNO] == 1 and buf.shape[0] >= base + N_TANGENT_SLOTS


@kernel
def tangent_acceleration(x, dx, m, massive, G, soft2, out):
    """``out = J(x) dx``: the first-order change of the gravitational accelerations of all
    particles for position changes ``dx`` (module docstring; Plummer-softened when
    ``soft2 > 0``). Only the massive particles (``massive``) attract."""
    n = x.shape[0]
    for i in range(n):
        ax = 0.0
        ay = 0.0
        az = 0.0
        for b in range(massive.shape[0]):
            j = massive[b]
            if j == i:
                continue
            rx = x[j, 0] - x[i, 0]
            ry = x[j, 1] - x[i, 1]
            rz = x[j, 2] - x[i, 2]
            ux = dx[j, 0] - dx[i, 0]
            uy = dx[j, 1] - dx[i, 1]
            uz = dx[j, 2] - dx[i, 2]
            inv2 = 1.0 / (rx * rx + ry * ry + rz * rz + soft2)
            inv = math.sqrt(inv2)
            gm3 = G * m[j] * inv2 * inv
            k = 3.0 * (rx * ux + ry * uy + rz * uz) * inv2
            ax += gm3 * (ux - k * rx)
            ay += gm3 * (uy - k * ry)
            az += gm3 * (uz - k * rz)
        out[i, 0] = ax
        out[i, 1] = ay
        out[i, 2] = az


@kernel
def megno_update(fstate, h, ln_delta):
    """Add one step of length ``h`` (``tau``, the time since the start, advances by ``h``: the
    sum of the steps, so that assigning ``sim.t`` moves nothing), after which
    ``ln|delta| = ln_delta`` (before the rescalings, ``fstate[F_MG_LN_SHIFT]``), to the MEGNO
    accumulators (module docstring: ``int_0^tau s f ds = tau L(tau) - int_0^tau L ds`` with
    ``L = ln(|delta| / |delta_0|)``, the last integral by the trapezoidal rule)."""
    tau = fstate[F_MG_TAU] + h
    fstate[F_MG_TAU] = tau
    ln1 = ln_delta + fstate[F_MG_LN_SHIFT]
    fstate[F_MG_ILN] += 0.5 * h * (fstate[F_MG_LN] + ln1)
    fstate[F_MG_LN] = ln1
    ys = 2.0 * (tau * ln1 - fstate[F_MG_ILN])
    fstate[F_MG_YS] = ys
    if tau == 0.0:
        return
    fstate[F_MG_YSS] += ys / tau * h
    mean_y = fstate[F_MG_YSS] / tau
    n = fstate[F_MG_N] + 1.0
    d_t = tau - fstate[F_MG_MEAN_T]
    fstate[F_MG_MEAN_T] += d_t / n
    fstate[F_MG_MEAN_Y] += (mean_y - fstate[F_MG_MEAN_Y]) / n
    fstate[F_MG_COV] += d_t * (mean_y - fstate[F_MG_MEAN_Y])
    fstate[F_MG_VAR] += d_t * (tau - fstate[F_MG_MEAN_T])
    fstate[F_MG_N] = n


@kernel
def ln_norm_rescaled(fstate, buf, base, with_b):
    """``ln|delta|`` of the tangent vector; when ``|delta|^2`` exceeds :data:`RESCALE_ABOVE` the
    vector (and IAS15's tangent ``b``, its predictor) is first multiplied by :data:`RESCALE` and
    the factor remembered in ``fstate[F_MG_LN_SHIFT]``."""
    n = buf.shape[1]
    d2 = 0.0
    for i in range(n):
        for c in range(3):
            d2 += buf[base + DX, i, c] ** 2 + buf[base + DV, i, c] ** 2
    if d2 > RESCALE_ABOVE:
        last = base + (_TB + 7 if with_b else DV + 1)
        for s in range(base, last):
            for i in range(n):
                for c in range(3):
                    buf[s, i, c] *= RESCALE
        fstate[F_MG_LN_SHIFT] -= math.log(RESCALE)
        d2 *= RESCALE * RESCALE
    return 0.5 * math.log(d2) if d2 > 0.0 else -math.inf


@kernel
def leapfrog_tangent(xi, vi, m, massive, fstate, buf, base, h):
    """Advance the tangent vector over the leapfrog step of length ``h`` just taken (``xi, vi``:
    the physical state after it) by the linearised drift-kick-drift map, and update MEGNO."""
    n = xi.shape[0]
    dx = buf[base + DX]
    dv = buf[base + DV]
    da = buf[base + _DA]
    xh = buf[base + _XP]
    half = 0.5 * h
    for i in range(n):
        for c in range(3):
            xh[i, c] = xi[i, c] - vi[i, c] * half  # the mid-step positions of the kick
            dx[i, c] += dv[i, c] * half
    tangent_acceleration(xh, dx, m, massive, fstate[F_G], fstate[F_SOFT2], da)
    for i in range(n):
        for c in range(3):
            dv[i, c] += da[i, c] * h
            dx[i, c] += dv[i, c] * half
    megno_update(fstate, h, ln_norm_rescaled(fstate, buf, base, False))


@kernel
def _displacement(bf, b, a0, v0, q, h, dt):
    """Gauss-Radau position change at the fraction ``h`` of a step ``dt`` (component ``q``;
    ``b``: the slot of ``b0`` in the flat ``bf``; IAS15's predictor, Everhart 1985)."""
    p = bf[b + 6, q] * (7.0 * h / 9.0) + bf[b + 5, q]
    p = p * (3.0 * h / 4.0) + bf[b + 4, q]
    p = p * (5.0 * h / 7.0) + bf[b + 3, q]
    p = p * (2.0 * h / 3.0) + bf[b + 2, q]
    p = p * (3.0 * h / 5.0) + bf[b + 1, q]
    p = p * (h / 2.0) + bf[b, q]
    p = p * (h / 3.0) + a0[q]
    return (p * (dt * h / 2.0) + v0[q]) * (dt * h)


@kernel
def _velocity_change(bf, b, a0, q, dt):
    """Gauss-Radau velocity change over a whole step ``dt`` (component ``q``)."""
    return (bf[b + 6, q] / 8.0 + bf[b + 5, q] / 7.0 + bf[b + 4, q] / 6.0 + bf[b + 3, q] / 5.0
            + bf[b + 2, q] / 4.0 + bf[b + 1, q] / 3.0 + bf[b, q] / 2.0 + a0[q]) * dt


@kernel
def _reexpand(bf, b, n3, q1):
    """Replace the b coefficients in slots ``b..b+6`` of the flat ``bf`` by those of the same
    polynomial about the end of its step, for a step ``q1`` times as long (Everhart 1985,
    eq. 2.10; ``q1 = 0`` zeroes them)."""
    q2 = q1 * q1
    q3 = q2 * q1
    q4 = q2 * q2
    q5 = q3 * q2
    q6 = q3 * q3
    q7 = q4 * q3
    for q in range(n3):
        b0 = bf[b, q]
        b1 = bf[b + 1, q]
        b2 = bf[b + 2, q]
        b3 = bf[b + 3, q]
        b4 = bf[b + 4, q]
        b5 = bf[b + 5, q]
        b6 = bf[b + 6, q]
        bf[b, q] = q1 * (7.0 * b6 + 6.0 * b5 + 5.0 * b4 + 4.0 * b3 + 3.0 * b2 + 2.0 * b1 + b0)
        bf[b + 1, q] = q2 * (21.0 * b6 + 15.0 * b5 + 10.0 * b4 + 6.0 * b3 + 3.0 * b2 + b1)
        bf[b + 2, q] = q3 * (35.0 * b6 + 20.0 * b5 + 10.0 * b4 + 4.0 * b3 + b2)
        bf[b + 3, q] = q4 * (35.0 * b6 + 15.0 * b5 + 5.0 * b4 + b3)
        bf[b + 4, q] = q5 * (21.0 * b6 + 6.0 * b5 + b4)
        bf[b + 5, q] = q6 * (7.0 * b6 + b5)
        bf[b + 6, q] = q7 * b6


@kernel
def ias15_tangent(xi, vi, m, massive, fstate, buf, base, b_slot, a0_slot, dt):
    """Advance the tangent vector over the IAS15 step of length ``dt`` just accepted (``xi, vi``:
    the physical state after it; ``buf[b_slot:b_slot+7]`` its converged b, ``buf[a0_slot]`` its
    initial acceleration) by Gauss-Radau collocation, and update MEGNO."""
    n3 = 3 * xi.shape[0]
    bf = buf.reshape((buf.shape[0], n3))
    xf = xi.reshape(n3)
    vf = vi.reshape(n3)
    a0 = bf[a0_slot]
    x0 = bf[base + _X0]
    v0 = bf[base + _V0]
    dx = bf[base + DX]
    dv = bf[base + DV]
    da = bf[base + _DA]
    xp = bf[base + _XP]
    txp = bf[base + _TXP]
    tf = bf[base + _TF]
    tb = base + _TB
    tg = base + _TG
    G = fstate[F_G]
    soft2 = fstate[F_SOFT2]
    # the physical state at the step start, from the step's polynomial (to round-off)
    for q in range(n3):
        v0[q] = vf[q] - _velocity_change(bf, b_slot, a0, q, dt)
    for q in range(n3):
        x0[q] = xf[q] - _displacement(bf, b_slot, a0, v0, q, 1.0, dt)
    tangent_acceleration(buf[base + _X0], buf[base + DX], m, massive, G, soft2, buf[base + _DA])
    # predictor: the last step's tangent polynomial re-expanded about this step's start, for
    # this step's length (Everhart 1985 eq. 2.10; no prediction after a change of direction)
    dtp = fstate[F_MG_DT_PREV]
    ratio = dt / dtp if dtp != 0.0 else 0.0
    if not (0.0 <= ratio <= 20.0):
        ratio = 0.0
    _reexpand(bf, tb, n3, ratio)
    for q in range(n3):
        for k in range(1, 8):
            g = 0.0
            for j in range(k - 1, 7):
                g += bf[tb + j, q] * BG[j, k]
            bf[tg + k - 1, q] = g
    pc_last = 2.0
    for it in range(_MAX_ITERATIONS):
        pc_err = 0.0
        maxa = 0.0
        maxdb6 = 0.0
        for sub in range(1, 8):
            h = H[sub]
            for q in range(n3):
                xp[q] = x0[q] + _displacement(bf, b_slot, a0, v0, q, h, dt)
                txp[q] = dx[q] + _displacement(bf, tb, da, dv, q, h, dt)
            tangent_acceleration(buf[base + _XP], buf[base + _TXP], m, massive, G, soft2,
                                 buf[base + _TF])
            for q in range(n3):
                gk = (tf[q] - da[q]) * RINV[sub, 0]
                for k in range(1, sub):
                    gk = (gk - bf[tg + k - 1, q]) * RINV[sub, k]
                dg = gk - bf[tg + sub - 1, q]
                bf[tg + sub - 1, q] = gk
                for k in range(sub):
                    bf[tb + k, q] += dg * CB[sub, k]
                if sub == 7:
                    if abs(dg) > maxdb6:
                        maxdb6 = abs(dg)
                    if abs(tf[q]) > maxa:
                        maxa = abs(tf[q])
            if sub == 7:
                pc_err = maxdb6 / maxa if maxa > 0.0 else 0.0
        if not pc_err >= 1e-16:  # converged (or NaN: left to the caller's finite check)
            break
        if it >= 2 and pc_err >= pc_last:
            break
        pc_last = pc_err
    for q in range(n3):
        ddx = _displacement(bf, tb, da, dv, q, 1.0, dt)
        dv[q] += _velocity_change(bf, tb, da, q, dt)
        dx[q] += ddx
    fstate[F_MG_DT_PREV] = dt
    megno_update(fstate, dt, ln_norm_rescaled(fstate, buf, base, True))
