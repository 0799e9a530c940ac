"""IAS15: 15th-order Gauss-Radau integrator with adaptive steps, the compiled N-body kernel.

Written from Everhart (1985) and Rein & Spiegel (2015). Within a step of length ``dt`` the
acceleration is expanded in the step fraction ``h`` in [0, 1]::

    a(h) = a0 + b0 h + b1 h**2 + ... + b6 h**7
         = a0 + g1 h + g2 h (h - h1) + ... + g7 h (h - h1) ... (h - h6)

with the Gauss-Radau spacings ``h1 ... h7``; integrating twice gives the predictor::

    v(h) = v0 + dt h (a0 + h (b0/2 + h (b1/3 + ... + h b6/8)))
    x(h) = x0 + dt h v0 + dt**2 h**2 (a0/2 + h (b0/6 + h (b1/12 + ... + h b6/72)))

Predictor-corrector: at each substep ``h_n`` the force gives ``g_n`` by divided differences and
the change of ``g_n`` updates ``b_0 ... b_{n-1}``; the sweep over the 7 substeps is repeated until
the change of ``b6`` relative to the acceleration is below 1e-16 or stops decreasing (at most 12
sweeps). The default step-size control (``adaptive_mode="prs23"``, ``istate[I_ADAPTIVE_MODE] = 1``)
is the criterion of Pham, Rein & Spiegel (2024), REBOUND's default::

    dt_new = (7! epsilon)**(1/7) tau,     tau**2 = 2 y2 / (y3 + sqrt(y2 y4)),  epsilon = 1e-9

with ``y2, y3, y4`` the squared acceleration, jerk and snap from the step's polynomial at its end,
summed over all particles (the paper's minimum over particles stalls when one particle's
acceleration passes through zero). ``adaptive_mode="rs15"`` (``I_ADAPTIVE_MODE = 0``) selects
Rein & Spiegel (2015, sec. 2.6, their eq. 11 "global" form), about twice the steps::

    err = max_i |b6_i| / max_i |a_i|,     dt_new = dt (epsilon / err)**(1/7)

Either way a step is rejected when ``dt_new < dt / 4`` (safety factor 0.25) and the step never
grows by more than a factor 4. Positions and velocities are updated with compensated (Kahan)
summation, so the state is ``x - csx`` in two parts. When a particle and a massive one are closer
than ``1 / SPLIT_RATIO`` of their distance from the origin (:func:`_tight_pair`, once per step),
the step evaluates gravity on those two-part positions
(:func:`visviva.core.gravity_split.gravity_split`): a tight, eccentric binary far from the origin then
keeps the relative precision of its separation (REBOUND's IAS15 rounds the positions; see
docs/nbody.md, "IAS15 on close encounters"); with fewer than seven massive particles that
gravity is a plain pair loop, faster than the packed kernel. Other steps are unchanged, bit for
bit. The next
step's ``b`` is predicted by re-expanding the converged polynomial about the new step start
(Everhart 1985 eq. 2.10) plus the correction the last prediction needed.

References
----------
Everhart, E. (1985), "An efficient integrator that uses Gauss-Radau spacings", in *Dynamics of
Comets: Their Origin and Evolution*, IAU Colloq. 83, 185-202.
Rein, H. & Spiegel, D. S. (2015), "IAS15: a fast, adaptive, high-order integrator for
gravitational dynamics, accurate to machine precision over a billion orbits", MNRAS 446, 1424.
Pham, D., Rein, H. & Spiegel, D. S. (2024), "Solving the N-body problem with IAS15: a new
timestep criterion", Open Journal of Astrophysics 7.
"""

from __future__ import annotations

import math

from ._jit import kernel, step_kernel
from .gauss_radau import BG, CB, RINV, H
from .gravity import PAIR_MIN_N
from .nbody_common import (
    F_DT,
    F_DT_FAILED,
    F_DT_FLOOR,
    F_DT_LAST,
    F_ENCOUNTER,
    F_EPSILON,
    F_EXIT,
    F_MIN_DT,
    F_T,
    F_T_INT,
    FEW,
    I_ADAPTIVE_MODE,
    I_COLLISIONS,
    I_EXACT_FINISH,
    I_FRESH,
    I_INT_VALID,
    I_ITERATIONS,
    I_MEGNO,
    I_NOUT,
    I_PARALLEL,
    I_REJECTED,
    I_STEPS,
    I_STOP_AT_STEP,
    I_VELOCITY_DEPENDENT,
    PAUSED,
    accelerations,
    accelerations_split,
    check_events,
    run_direction,
    should_pause,
    write_output,
)
from .nbody_variational import ias15_tangent, megno_on
from .status import NON_FINITE, OK, STEP_TOO_SMALL

__all__ = ["ias15_run", "ias15_run_few", "ias15_run_megno", "is_megno", "N_BUF", "H", "SAFETY", "MAX_ITERATIONS", "DT_FLOOR_REL"]

SAFETY = 0.25
#: A step evaluates gravity on two-part positions (hi + lo) when a pair is closer than
#: ``1 / SPLIT_RATIO`` of its distance from the origin (see :func:`_tight_pair`).
SPLIT_RATIO = 8.0
MAX_ITERATIONS = 12
#: Relative step floor: a proposed step below ``DT_FLOOR_REL * max(|t|, time span of the run)``
#: raises ``STEP_TOO_SMALL`` (the run would need more than ~1e15 steps, or ``t + dt == t``).
DT_FLOOR_REL = 1e-15

# slots of buf (each (N, 3))
_B = 0
_E = 7
_BL = 14  # converged b of the last accepted step
_EL = 21  # the prediction e that step started from
_G = 28
_CSX = 35
_CSV = 36
_A0 = 37
_XP = 38
_VP = 39
_F = 40
_XI = 41  # internal positions and velocities (the integrator's own state at F_T_INT)
_VI = 42
_BK = 43  # backup of slots _B.._EL+6, _CSX, _CSV, _XI, _VI while an output is computed
_N_BK = 32
_XL = 75  # low parts of the positions the forces are evaluated at (x = hi + lo)
#: Number of (N, 3) slots in ``buf``.
N_BUF = 76


@kernel
def _predict(buf, n, dtq, src_b, src_e):
    """Re-expand the converged b (slots src_b) for a step ``dtq`` times as long (Everhart 2.10).

    Writes e (the pure prediction) and b = e + (b_converged - e_old) into slots _E and _B.
    """
    q1 = dtq
    q2 = q1 * q1
    q3 = q2 * q1
    q4 = q2 * q2
    q5 = q3 * q2
    q6 = q3 * q3
    q7 = q4 * q3
    for i in range(n):
        for c in range(3):
            b0 = buf[src_b + 0, i, c]
            b1 = buf[src_b + 1, i, c]
            b2 = buf[src_b + 2, i, c]
            b3 = buf[src_b + 3, i, c]
            b4 = buf[src_b + 4, i, c]
            b5 = buf[src_b + 5, i, c]
            b6 = buf[src_b + 6, i, c]
            e0 = q1 * (b6 * 7.0 + b5 * 6.0 + b4 * 5.0 + b3 * 4.0 + b2 * 3.0 + b1 * 2.0 + b0)
            e1 = q2 * (b6 * 21.0 + b5 * 15.0 + b4 * 10.0 + b3 * 6.0 + b2 * 3.0 + b1)
            e2 = q3 * (b6 * 35.0 + b5 * 20.0 + b4 * 10.0 + b3 * 4.0 + b2)
            e3 = q4 * (b6 * 35.0 + b5 * 15.0 + b4 * 5.0 + b3)
            e4 = q5 * (b6 * 21.0 + b5 * 6.0 + b4)
            e5 = q6 * (b6 * 7.0 + b5)
            e6 = q7 * b6
            d0 = b0 - buf[src_e + 0, i, c]
            d1 = b1 - buf[src_e + 1, i, c]
            d2 = b2 - buf[src_e + 2, i, c]
            d3 = b3 - buf[src_e + 3, i, c]
            d4 = b4 - buf[src_e + 4, i, c]
            d5 = b5 - buf[src_e + 5, i, c]
            d6 = b6 - buf[src_e + 6, i, c]
            buf[_E + 0, i, c] = e0
            buf[_E + 1, i, c] = e1
            buf[_E + 2, i, c] = e2
            buf[_E + 3, i, c] = e3
            buf[_E + 4, i, c] = e4
            buf[_E + 5, i, c] = e5
            buf[_E + 6, i, c] = e6
            buf[_B + 0, i, c] = e0 + d0
            buf[_B + 1, i, c] = e1 + d1
            buf[_B + 2, i, c] = e2 + d2
            buf[_B + 3, i, c] = e3 + d3
            buf[_B + 4, i, c] = e4 + d4
            buf[_B + 5, i, c] = e5 + d5
            buf[_B + 6, i, c] = e6 + d6


@kernel
def _zero_predictor(buf, n):
    for s in range(_B, _G):
        for i in range(n):
            for c in range(3):
                buf[s, i, c] = 0.0


@kernel
def _tight_pair(x, massive):
    """True when a particle and a massive one are closer than ``1 / SPLIT_RATIO`` of their
    distance from the origin (and fewer than ``PAIR_MIN_N`` particles are massive).

    Rounded to doubles, such a pair's separation would carry the round-off of its absolute
    positions (``eps |x|`` instead of ``eps |d|``); the step then evaluates gravity on the
    two-part positions ``x - csx`` (:func:`visviva.core.gravity_split.gravity_split`).
    """
    nm = massive.shape[0]
    if nm >= PAIR_MIN_N:
        return False
    k2 = SPLIT_RATIO * SPLIT_RATIO
    for i in range(x.shape[0]):
        ri2 = x[i, 0] * x[i, 0] + x[i, 1] * x[i, 1] + x[i, 2] * x[i, 2]
        for b in range(nm):
            j = massive[b]
            if j == i:
                continue
            dx = x[j, 0] - x[i, 0]
            dy = x[j, 1] - x[i, 1]
            dz = x[j, 2] - x[i, 2]
            rj2 = x[j, 0] * x[j, 0] + x[j, 1] * x[j, 1] + x[j, 2] * x[j, 2]
            if max(ri2, rj2) > k2 * (dx * dx + dy * dy + dz * dz):
                return True
    return False


@step_kernel
def _step(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t, dt,
          parallel):
    """Try one step of length ``dt``. Returns (status, accepted, dt_new).

    The (N, 3) arrays are processed as flat vectors of length 3N (one loop, no inner xyz loop).
    Velocities are predicted at the substeps only when a velocity-dependent force is present.
    """
    n = x.shape[0]
    n3 = 3 * n
    a0 = buf[_A0]
    xp = buf[_XP]
    vp = buf[_VP]
    F = buf[_F]
    bf = buf.reshape((buf.shape[0], n3))
    xf = x.reshape(n3)
    vf = v.reshape(n3)
    a0f = bf[_A0]
    xpf = bf[_XP]
    vpf = bf[_VP]
    Ff = bf[_F]
    csx = bf[_CSX]
    csv = bf[_CSV]
    xl = buf[_XL]
    xlf = bf[_XL]
    vel_dep = istate[I_VELOCITY_DEPENDENT] != 0
    # the state is x - csx; with a tight pair far from the origin, gravity sees both parts so
    # that the pair keeps its relative precision (decided once per step)
    split = _tight_pair(x, massive)
    if split:
        for q in range(n3):
            xlf[q] = -csx[q]
        accelerations_split(t, x, xl, v, m, massive, fstate, gwork, force, params, a0, parallel)
    else:
        accelerations(t, x, v, m, massive, fstate, gwork, force, params, a0, parallel)
    for q in range(n3):
        if not math.isfinite(a0f[q]):
            return NON_FINITE, False, dt  # a singular or overflowing force: report it
    if not vel_dep:
        for q in range(n3):
            vpf[q] = vf[q]
    # g from the predicted b
    for q in range(n3):
        for k in range(1, 8):
            acc_g = 0.0
            for j in range(k - 1, 7):
                acc_g += bf[_B + j, q] * BG[j, k]
            bf[_G + k - 1, q] = acc_g
    pc_last = 2.0
    for it in range(MAX_ITERATIONS):
        pc_err = 0.0
        for sub in range(1, 8):
            h = H[sub]
            cx7 = 7.0 * h / 9.0
            cx6 = 3.0 * h / 4.0
            cx5 = 5.0 * h / 7.0
            cx4 = 2.0 * h / 3.0
            cx3 = 3.0 * h / 5.0
            cx2 = h / 2.0
            cx1 = h / 3.0
            dth2 = dt * h / 2.0
            dth = dt * h
            for q in range(n3):
                b0 = bf[_B + 0, q]
                b1 = bf[_B + 1, q]
                b2 = bf[_B + 2, q]
                b3 = bf[_B + 3, q]
                b4 = bf[_B + 4, q]
                b5 = bf[_B + 5, q]
                b6 = bf[_B + 6, q]
                dxq = -csx[q] + (
                    (((((((b6 * cx7 + b5) * cx6 + b4) * cx5 + b3) * cx4 + b2) * cx3 + b1) * cx2
                      + b0) * cx1 + a0f[q]) * dth2 + vf[q]
                ) * dth
                xpf[q] = dxq + xf[q]
                xlf[q] = dxq
            if split:
                for q in range(n3):
                    # the rounding error of xp = dx + x, exactly (Knuth's two-sum)
                    bb = xpf[q] - xf[q]
                    xlf[q] = (xf[q] - (xpf[q] - bb)) + (xlf[q] - bb)
            if vel_dep:
                cv7 = 7.0 * h / 8.0
                cv6 = 6.0 * h / 7.0
                cv5 = 5.0 * h / 6.0
                cv4 = 4.0 * h / 5.0
                cv3 = 3.0 * h / 4.0
                cv2 = 2.0 * h / 3.0
                cv1 = h / 2.0
                for q in range(n3):
                    b0 = bf[_B + 0, q]
                    b1 = bf[_B + 1, q]
                    b2 = bf[_B + 2, q]
                    b3 = bf[_B + 3, q]
                    b4 = bf[_B + 4, q]
                    b5 = bf[_B + 5, q]
                    b6 = bf[_B + 6, q]
                    vpf[q] = -csv[q] + (
                        (((((((b6 * cv7 + b5) * cv6 + b4) * cv5 + b3) * cv4 + b2) * cv3 + b1)
                          * cv2 + b0) * cv1 + a0f[q]) * dth
                    ) + vf[q]
            if split:
                accelerations_split(t + h * dt, xp, xl, vp, m, massive, fstate, gwork, force,
                                    params, F, parallel)
            else:
                accelerations(t + h * dt, xp, vp, m, massive, fstate, gwork, force, params, F,
                              parallel)
            maxa = 0.0
            maxdb6 = 0.0
            for q in range(n3):
                # new g_sub by divided differences, then its change updates b_0 .. b_{sub-1}
                gk = (Ff[q] - a0f[q]) * RINV[sub, 0]
                for k in range(1, sub):
                    gk = (gk - bf[_G + k - 1, q]) * RINV[sub, k]
                dg = gk - bf[_G + sub - 1, q]
                bf[_G + sub - 1, q] = gk
                for k in range(sub):
                    bf[_B + k, q] += dg * CB[sub, k]
                if sub == 7:
                    ad = abs(dg)
                    if ad > maxdb6:
                        maxdb6 = ad
                    af = abs(Ff[q])
                    if af > maxa:
                        maxa = af
            if sub == 7:
                pc_err = maxdb6 / maxa if maxa > 0.0 else 0.0
        istate[I_ITERATIONS] += 1
        if not (pc_err == pc_err):
            return NON_FINITE, False, dt
        if pc_err < 1e-16:
            break
        if it >= 2 and pc_err >= pc_last:
            break
        pc_last = pc_err
    if istate[I_ADAPTIVE_MODE] == 1:
        # Pham, Rein & Spiegel (2024): dt = (7! epsilon)^(1/7) tau with
        # tau^2 = 2 |a|^2 / (|a'|^2 + |a| |a''|) from the step's polynomial at its end
        tau2_min = math.inf
        y2 = 0.0
        y3 = 0.0
        y4 = 0.0
        for i in range(n):
            for c in range(3):
                q = 3 * i + c
                b0 = bf[_B + 0, q]
                b1 = bf[_B + 1, q]
                b2 = bf[_B + 2, q]
                b3 = bf[_B + 3, q]
                b4 = bf[_B + 4, q]
                b5 = bf[_B + 5, q]
                b6 = bf[_B + 6, q]
                a1 = a0f[q] + b0 + b1 + b2 + b3 + b4 + b5 + b6
                j1 = b0 + 2.0 * b1 + 3.0 * b2 + 4.0 * b3 + 5.0 * b4 + 6.0 * b5 + 7.0 * b6
                s1 = 2.0 * b1 + 6.0 * b2 + 12.0 * b3 + 20.0 * b4 + 30.0 * b5 + 42.0 * b6
                y2 += a1 * a1
                y3 += j1 * j1
                y4 += s1 * s1
        # sums over all particles: a single particle passing through a zero of its acceleration
        # (the figure-eight's crossing) would otherwise shrink the steps geometrically (Zeno)
        den = y3 + math.sqrt(y2 * y4)
        if den > 0.0:
            tau2_min = 2.0 * y2 / den  # in units of dt^2
        if math.isfinite(tau2_min) and tau2_min > 0.0:
            dt_new = dt * math.sqrt(tau2_min) * (5040.0 * fstate[F_EPSILON]) ** (1.0 / 7.0)
        else:
            dt_new = dt / SAFETY
    else:
        # Rein & Spiegel (2015), global error estimate
        maxa = 0.0
        maxb6 = 0.0
        for q in range(n3):
            aa = abs(a0f[q])
            if aa > maxa:
                maxa = aa
            bb = abs(bf[_B + 6, q])
            if bb > maxb6:
                maxb6 = bb
        err = maxb6 / maxa if maxa > 0.0 else 0.0
        if err > 0.0 and math.isfinite(err):
            dt_new = dt * (fstate[F_EPSILON] / err) ** (1.0 / 7.0)
        else:
            dt_new = dt / SAFETY
    if not math.isfinite(dt_new):
        return NON_FINITE, False, dt
    if abs(dt_new) < SAFETY * abs(dt):
        return OK, False, dt_new  # reject
    if abs(dt_new) > abs(dt) / SAFETY:
        dt_new = dt / SAFETY
    # accept: x += dt v0 + dt^2 (a0/2 + b0/6 + ... + b6/72), compensated summation
    for q in range(n3):
        b0 = bf[_B + 0, q]
        b1 = bf[_B + 1, q]
        b2 = bf[_B + 2, q]
        b3 = bf[_B + 3, q]
        b4 = bf[_B + 4, q]
        b5 = bf[_B + 5, q]
        b6 = bf[_B + 6, q]
        ac = a0f[q]
        dx = (
            b6 / 72.0 + b5 / 56.0 + b4 / 42.0 + b3 / 30.0 + b2 / 20.0 + b1 / 12.0 + b0 / 6.0
            + ac / 2.0
        ) * dt * dt + vf[q] * dt
        dv = (b6 / 8.0 + b5 / 7.0 + b4 / 6.0 + b3 / 5.0 + b2 / 4.0 + b1 / 3.0 + b0 / 2.0
              + ac) * dt
        y = dx - csx[q]
        sm = xf[q] + y
        csx[q] = (sm - xf[q]) - y
        xf[q] = sm
        y = dv - csv[q]
        sm = vf[q] + y
        csv[q] = (sm - vf[q]) - y
        vf[q] = sm
    return OK, True, dt_new


@kernel
def _advance(xi, vi, m, massive, radius, fstate, istate, buf, gwork, force, params, target,
             direction, mode, events, span, parallel):
    """Adaptive steps of the internal state towards ``target``.

    ``mode`` 0: stop before a step would pass ``target``; 1: land exactly on it (the last step
    shortened); 2: stop at the first step at or past it. ``span`` is the time span of the run
    (for the relative step floor :data:`DT_FLOOR_REL`). Returns a status code.
    """
    n = xi.shape[0]
    while True:
        t = fstate[F_T_INT]
        rem = target - t
        if rem == 0.0 or rem * direction < 0.0:
            return OK
        dt = fstate[F_DT]
        if dt == 0.0 or (dt > 0.0) != (direction > 0.0):
            # first step, or a change of direction: start small and restart the predictor
            dt = math.copysign(abs(dt) if dt != 0.0 else abs(rem), direction)
            _zero_predictor(buf, n)
            fstate[F_DT_LAST] = 0.0
            fstate[F_DT] = dt
        last = False
        trial = False
        if abs(dt) >= abs(rem):
            if mode == 0:
                dl = fstate[F_DT_LAST]
                if dl != 0.0 and abs(dt) <= abs(dl) / SAFETY:
                    return OK
                # a step step control never proposed (a user's dt, a first step, a new
                # direction) would wait for ever behind the output times while copies do the
                # work (a dt beyond the run left the integrator at t0 and every output cost
                # the whole span again): try it now as the natural run will when it gets here.
                # A rejection is kept (the same one, on the same state); an accepted step is
                # undone, to be taken by the natural run unchanged
                trial = True
                _backup(buf, False)
            else:
                last = True
                if mode == 1:
                    dt = rem
        status, accepted, dt_new = _step(
            xi, vi, m, massive, radius, fstate, istate, buf, gwork, force, params, t, dt, parallel
        )
        if status != OK:
            return status
        if trial and accepted:
            _backup(buf, True)
            return OK
        # the step floor: min_dt, and a relative floor (below it the run could never finish,
        # or t + dt == t; a singular configuration such as coincident particles ends here
        # instead of looping forever). Not checked after a step shortened to land on target.
        if not (accepted and last and mode == 1):
            # (the relative floor only while the step shrinks: a tiny first guess may grow)
            floor = DT_FLOOR_REL * max(abs(t), span) if abs(dt_new) < abs(dt) else 0.0
            if abs(dt_new) < fstate[F_MIN_DT] or abs(dt_new) < floor or dt_new == 0.0:
                fstate[F_DT_FLOOR] = max(fstate[F_MIN_DT], floor)
                fstate[F_DT_FAILED] = dt_new
                return STEP_TOO_SMALL
        if not accepted:
            istate[I_REJECTED] += 1
            fstate[F_DT] = dt_new
            dl = fstate[F_DT_LAST]
            if dl != 0.0:
                _predict(buf, n, dt_new / dl, _BL, _EL)
            else:
                _zero_predictor(buf, n)
            continue
        fstate[F_T_INT] = target if (last and mode == 1) else t + dt
        istate[I_STEPS] += 1
        if mode != 1 and megno_on(istate, buf, N_BUF):
            # the tangent vector over the step just taken (not over an output's copy: mode 1)
            ias15_tangent(xi, vi, m, massive, fstate, buf, N_BUF, _B, _A0, dt)
        # remember the converged b and its prediction e, then predict the next step
        for sl in range(7):
            for i in range(n):
                for c in range(3):
                    buf[_BL + sl, i, c] = buf[_B + sl, i, c]
                    buf[_EL + sl, i, c] = buf[_E + sl, i, c]
        dt_next = dt_new
        if last and mode == 1 and abs(fstate[F_DT]) > abs(dt_next):
            dt_next = fstate[F_DT]  # the step was shortened to land on the output time
        ratio = dt_next / dt
        if abs(ratio) > 20.0:
            _zero_predictor(buf, n)
        else:
            _predict(buf, n, ratio, _BL, _EL)
        fstate[F_DT_LAST] = dt
        fstate[F_DT] = dt_next
        if events is not None and events:  # (None: the MEGNO kernel compiles no check)
            status = check_events(xi, vi, radius, fstate, istate)
            if status != OK:
                return status
        if last:
            return OK
        if should_pause(istate):
            return PAUSED


@kernel
def _backup(buf, restore):
    n = buf.shape[1]
    for s in range(_N_BK):
        src = s if s < 28 else (_CSX, _CSV, _XI, _VI)[s - 28]
        for i in range(n):
            for c in range(3):
                if restore:
                    buf[src, i, c] = buf[_BK + s, i, c]
                else:
                    buf[_BK + s, i, c] = buf[src, i, c]


@kernel
def _expose(xi, vi, x, v):
    for i in range(x.shape[0]):
        for c in range(3):
            x[i, c] = xi[i, c]
            v[i, c] = vi[i, c]


@kernel
def ias15_run(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
              out_t, out_x, out_v):
    """Advance through every output time with IAS15 (see :func:`_ias15`); gravity by any
    kernel, chosen at run time (``istate[I_PARALLEL]``, N)."""
    return _ias15(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
                  out_t, out_x, out_v, istate[I_PARALLEL] != 0, ANY_CASE)


@kernel
def ias15_run_few(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
                  out_t, out_x, out_v):
    """:func:`ias15_run` with the serial few-body gravity alone (``FEW``; see
    :func:`visviva.core.nbody_whfast.whfast_run_few`)."""
    return _ias15(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
                  out_t, out_x, out_v, FEW, ANY_CASE)


#: The ``case`` argument of the run body: events chosen at run time (the general kernels) ...
ANY_CASE = None
#: ... or none compiled (:func:`ias15_run_megno`).
MEGNO_ONLY = True


def is_megno(istate, fstate):
    """True when a run may use :func:`ias15_run_megno` (plain Python, not compiled): MEGNO on,
    and none of collisions, encounters or an escape radius."""
    return ((istate[..., I_MEGNO] == 1) & (istate[..., I_COLLISIONS] == 0)
            & (fstate[..., F_ENCOUNTER] <= 0.0) & (fstate[..., F_EXIT] <= 0.0))


@kernel
def ias15_run_megno(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
                    out_t, out_x, out_v):
    """:func:`ias15_run_few` for a MEGNO run without events (:func:`is_megno`): the event
    checks are not compiled. The same bits; what a first MEGNO run compiles."""
    return _ias15(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
                  out_t, out_x, out_v, FEW, MEGNO_ONLY)


@step_kernel
def _ias15(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, t_out,
           out_t, out_x, out_v, parallel, case):
    """Advance through every output time with IAS15 (see the module docstring).

    The integrator's own state (``buf``: positions, velocities, b and e arrays, compensated
    summation terms) takes its natural adaptive steps. An output time is reached by a shortened
    step of a COPY of that state (restored afterwards), so output times never change the
    trajectory and a saved run continues bit for bit. With ``exact_finish_time`` off the output
    is the state after the first step at or past the time. ``x, v`` hold the last output.
    Arguments as in :mod:`visviva.core.nbody_common`; returns a status code.
    """
    _start(x, v, fstate, istate, buf)
    direction = run_direction(fstate[F_T_INT], t_out)
    span = abs(t_out[t_out.shape[0] - 1] - fstate[F_T_INT]) if t_out.shape[0] > 0 else 0.0
    fsave = fstate.copy()
    isave = istate.copy()
    if case is None:
        events = istate[I_COLLISIONS] != 0 or fstate[F_ENCOUNTER] > 0.0 or fstate[F_EXIT] > 0.0
        quiet = False  # the copy that lands on an output time checks no events
    else:
        events = None  # the MEGNO kernel: no event checks compiled (is_megno)
        quiet = None
    for k in range(istate[I_NOUT], t_out.shape[0]):
        status = _to_output(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params,
                            t_out[k], direction, events, quiet, span, parallel, fsave, isave)
        if status != OK:
            return status
        write_output(k, fstate[F_T], x, v, out_t, out_x, out_v)
        istate[I_NOUT] = k + 1
    return OK


@step_kernel
def _start(x, v, fstate, istate, buf):
    """A fresh start of the integrator's own state from ``x, v`` when it is not valid."""
    if istate[I_FRESH] != 0 or istate[I_INT_VALID] == 0:
        _zero_predictor(buf, x.shape[0])
        for i in range(x.shape[0]):
            for c in range(3):
                buf[_CSX, i, c] = 0.0
                buf[_CSV, i, c] = 0.0
        _expose(x, v, buf[_XI], buf[_VI])
        fstate[F_T_INT] = fstate[F_T]
        fstate[F_DT_LAST] = 0.0
        istate[I_FRESH] = 0
        istate[I_INT_VALID] = 1


@step_kernel
def _to_output(x, v, m, massive, radius, fstate, istate, buf, gwork, force, params, target,
               direction, events, quiet, span, parallel, fsave, isave):
    """One output time of :func:`_ias15` into ``x, v`` (``fsave, isave``: scratch of the shapes
    of ``fstate, istate``; ``quiet``: the ``events`` of the copy that lands on the output time,
    False or, in the MEGNO kernel, None, of the type of ``events``: one compiled ``_advance``);
    returns a status code."""
    xi = buf[_XI]
    vi = buf[_VI]
    exact = istate[I_EXACT_FINISH] != 0
    mode = 0 if exact else 2
    status = _advance(xi, vi, m, massive, radius, fstate, istate, buf, gwork, force, params,
                      target, direction, mode, events, span, parallel)
    if status != OK:
        _expose(xi, vi, x, v)
        fstate[F_T] = fstate[F_T_INT]
        if status != PAUSED:
            istate[I_INT_VALID] = 0  # the caller may change the state (merge, bounce)
        return status
    if exact and fstate[F_T_INT] != target:
        # land on the output time with a copy, then restore the integrator's own state
        _backup(buf, False)
        for q in range(fstate.shape[0]):
            fsave[q] = fstate[q]
        for q in range(istate.shape[0]):
            isave[q] = istate[q]
        istate[I_STOP_AT_STEP] = 0  # never pause inside the copy
        status = _advance(xi, vi, m, massive, radius, fstate, istate, buf, gwork, force,
                          params, target, direction, 1, quiet, span, parallel)
        _expose(xi, vi, x, v)
        _backup(buf, True)
        for q in range(fstate.shape[0]):
            fstate[q] = fsave[q]
        for q in range(istate.shape[0]):
            istate[q] = isave[q]
        if status != OK and status != PAUSED:
            return status
        fstate[F_T] = target
    else:
        _expose(xi, vi, x, v)
        fstate[F_T] = fstate[F_T_INT]
    return OK
