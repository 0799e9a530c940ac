"""Events on the dense output of a Cowell step: the event functions, their root finding, and the
shadow boundaries of solar radiation pressure at which the integrator ends its steps.

The event kinds (``kind``) are listed in :mod:`visviva.core.cowell`. Zeros are located on the
DOP853 dense output of a step with the Illinois variant of regula falsi (:func:`locate_zero`).

Shadow boundaries. With SRP and a shadow model the force is not smooth at the shadow's edge:
the cylindrical shadow switches SRP off (a jump), the conical one has kinks where the penumbra
and the umbra begin and end. DOP853's error estimate does not see either, so
:func:`visviva.core.cowell.integrate_cowell` never steps across such a boundary (as Orekit and
GMAT handle force discontinuities): each side of each boundary function (the event functions of
kinds 1, or 2 and 3) is recorded at the start of a step; a step whose dense output leaves a side
(:func:`shadow_crossing`, at :data:`SHADOW_SAMPLES` points) is dropped, the boundary located on it
to :data:`BOUNDARY_RTOL` of the step (just past it), and the step redone up to there; the side
is then flipped and the integration restarts with a fresh derivative. The cylindrical shadow
is evaluated on the recorded side for a whole step (:func:`lock_shadow`): every stage of the
step up to the boundary sees the force from before it, every stage after it the force from
after, whatever side rounding puts a stage near the boundary on. The conical shadow fraction
is continuous; its stages near a kink differ from the one-sided force by the kink's slope times
the (1e-9 relative) overshoot.

The same boundaries serve :func:`visviva.core.variational.integrate_variational` (the fits'
trajectory and state-transition matrix: :func:`boundary_gradient` gives the saltation matrix
at the cylindrical shadow's jump) and, without SRP's shadow, eclipse events
(:func:`boundary_models`); :func:`boundary_plan` is what either integrator does with a
boundary found in its step.
"""

from __future__ import annotations

import math

import numpy as np

from . import force_block as fb
from ._jit import inline_kernel, kernel, step_kernel
from .geodetic import body_pole, pole_altitude
from .perturbations import hermite_position

__all__ = ["event_function", "event_value", "dense_eval", "locate_zero", "SHADOW_SAMPLES", "BOUNDARY_RTOL",
           "PENUMBRA_STEPS", "PENUMBRA_IMPULSE", "penumbra_step", "shadow_boundary_kind", "lock_shadow", "fix_boundary_events", "shadow_values",
           "shadow_sides", "shadow_crossing", "boundary_gradient", "srp_shadow_model",
           "boundary_models", "boundary_plan", "step_sample", "dip_vertex", "first_crossing",
           "end_sample_value"]

@kernel
def event_function(kind, param, t, y, force, eph_r, eph_v):
    """Value of event function ``kind`` at (t, y); the kinds are listed in :mod:`visviva.core.cowell`."""
    x = y[0]
    yy = y[1]
    z = y[2]
    if kind == 0:
        return pole_altitude(t, x, yy, z, force) - param
    if kind == 4:  # param 1: the Earth's equator of date (r . pole), else the frame's xy plane
        if param == 0.0:
            return z
        px, py = body_pole(t, force)
        return px * x + py * yy + math.sqrt(1.0 - px * px - py * py) * z
    if kind == 5:
        return x * y[3] + yy * y[4] + z * y[5]
    # shadow events need the Sun
    sun = int(force[fb.SUN_ROW])
    if sun < 0:
        return 1.0
    s = np.empty(3)
    hermite_position(t, sun, force, eph_r, eph_v, s)
    g0, g1 = _shadow_pair(1 if kind == 1 else 2, x, yy, z, s, force[fb.RADIUS],
                          force[fb.SUN_RADIUS])
    return g1 if kind == 3 else g0


@inline_kernel
def _shadow_pair(model, x, yy, z, s, radius, sun_radius):
    """The shadow boundary functions at r = (x, yy, z) with the Sun at ``s``: model 1, (the
    cylinder's, 1.0) (event kind 1); model 2, (the penumbra's, the umbra's) (kinds 2, 3)."""
    r = math.sqrt(x * x + yy * yy + z * z)
    if model == 1:
        sn = math.sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2])
        proj = (x * s[0] + yy * s[1] + z * s[2]) / sn
        if proj >= 0.0:
            return r, 1.0
        px = x - proj * s[0] / sn
        py = yy - proj * s[1] / sn
        pz = z - proj * s[2] / sn
        return math.sqrt(px * px + py * py + pz * pz) - radius, 1.0
    dx = s[0] - x
    dy = s[1] - yy
    dz = s[2] - z
    d = math.sqrt(dx * dx + dy * dy + dz * dz)
    a = math.asin(min(1.0, sun_radius / d))
    b = math.asin(min(1.0, radius / r))
    cosc = -(x * dx + yy * dy + z * dz) / (r * d)
    c = math.acos(max(-1.0, min(1.0, cosc)))
    return c - (a + b), c - (b - a)


@kernel
def shadow_values(model, t, y, force, eph_r, eph_v, s):
    """Both boundary functions of SRP shadow ``model`` at (t, y) (:func:`_shadow_pair`; the
    values of :func:`event_function` of their kinds, without its scratch array: the Sun's
    position goes to ``s``, 3 values)."""
    hermite_position(t, int(force[fb.SUN_ROW]), force, eph_r, eph_v, s)
    return _shadow_pair(model, y[0], y[1], y[2], s, force[fb.RADIUS], force[fb.SUN_RADIUS])


@kernel
def dense_eval(t, t_old, h, y_old, F, out):
    """Evaluate the DOP853 dense-output polynomial of the last step at time t."""
    xx = (t - t_old) / h
    n = y_old.shape[0]
    for j in range(n):
        acc = 0.0
        for i in range(F.shape[0] - 1, -1, -1):
            acc += F[i, j]
            # the innermost coefficient (i = 6) is multiplied by x, then alternately 1-x, x ...
            if (F.shape[0] - 1 - i) % 2 == 0:
                acc *= xx
            else:
                acc *= 1.0 - xx
        out[j] = y_old[j] + acc



@step_kernel
def event_value(kind, param, t, y, force, eph_r, eph_v, full):
    """:func:`event_function`, or with ``full`` None (the ZONAL_ONLY kernel of
    :func:`visviva.core.cowell.integrate_cowell`, whose events are altitude crossings only:
    :func:`visviva.core.cowell.rhs_kind`) the altitude function alone, so that numba compiles
    none of the other kinds there (same value: kind 0 of :func:`event_function`)."""
    if full is None:
        return pole_altitude(t, y[0], y[1], y[2], force) - param
    return event_function(kind, param, t, y, force, eph_r, eph_v)


@step_kernel
def locate_zero(kind, param, ta, tb, fa, fb, tol, t, h, y, F, y_tmp, force, eph_r, eph_v, full):
    """Bracket [ta, tb] (either order) of a zero of event function ``kind`` on the dense output
    of the step (t, h), narrowed to ``tol`` s by the Illinois variant of regula falsi from the
    values ``fa``, ``fb`` of opposite signs at its ends (``full`` as for :func:`event_value`).
    Returns the narrowed (ta, tb): ``ta`` on ``fa``'s side, ``tb`` on ``fb``'s (both the zero
    when it is hit exactly)."""
    side = 0
    tc = tb
    for _ in range(200):
        if abs(tb - ta) <= tol:
            break
        tc = (fa * tb - fb * ta) / (fa - fb)
        lo = ta if ta < tb else tb  # no min/max: numba compiles their overloads in every process
        hi = tb if ta < tb else ta
        if not (lo < tc < hi):
            tc = 0.5 * (ta + tb)
        dense_eval(tc, t, h, y, F, y_tmp)
        fc = event_value(kind, param, tc, y_tmp, force, eph_r, eph_v, full)
        if fc == 0.0:
            ta = tc
            tb = tc
            break
        if (fc < 0.0) == (fb < 0.0):
            tb = tc
            fb = fc
            if side == -1:
                fa *= 0.5
            side = -1
        else:
            ta = tc
            fa = fc
            if side == 1:
                fb *= 0.5
            side = 1
        if abs(tb - ta) <= tol:
            break
    return ta, tb


#: Points of the dense output (fractions of the step, the end last) where the shadow boundary
#: functions are sampled to find a boundary crossed within a step (also one entered and left
#: again between the step's ends).
SHADOW_SAMPLES = 3
#: Tolerance of the shadow boundary location, relative to the step.
BOUNDARY_RTOL = 1e-9


@kernel
def shadow_boundary_kind(model, which):
    """Event kind of boundary ``which`` of SRP shadow ``model`` (1 cylindrical: its one
    boundary, event kind 1; 2 conical: ``which`` 0 the penumbra, kind 2, 1 the umbra, kind 3)."""
    if model == 1:
        return 1
    return 2 + which


@kernel
def boundary_plan(ta, tb, which, t, h, h_abs, min_step, side0, side1):
    """What an integrator does with the boundary crossing (``ta``, ``tb``, ``which``) that
    :func:`shadow_crossing` found in its step (t, h) of size ``h_abs`` (after the error
    control): when the crossing lies at t (``ta`` is t, or ``tb`` within 2 ``min_step`` of it),
    cross it there, with the side of boundary ``which`` flipped, and retry the step (|h|);
    else redo the step up to ``tb``, keeping ``h_abs`` to resume with after the boundary.

    Returns (at_t, side0, side1, t_bnd, h_keep, h_abs)."""
    if ta == t or abs(tb - t) < 2.0 * min_step:
        if which == 0:
            side0 = -side0
        else:
            side1 = -side1
        return True, side0, side1, tb, h_abs, abs(h)
    return False, side0, side1, tb, h_abs, abs(tb - t)


@kernel
def srp_shadow_model(force):
    """The shadow model of SRP in the force block (1 cylindrical, 2 conical) when SRP is on and
    the Sun tabulated, else 0: the boundaries the integrators end their steps at."""
    if force[fb.SRP_ON] != 0.0 and force[fb.SUN_ROW] >= 0.0 and force[fb.SHADOW_MODEL] > 0.0:
        return int(force[fb.SHADOW_MODEL])
    return 0


@kernel
def boundary_models(force, ev_kind):
    """The shadow models (1 cylindrical, 2 conical) whose boundaries end the steps of
    :func:`visviva.core.cowell.integrate_cowell`: (first, second, lock).

    ``first`` is SRP's shadow (``lock`` True: the force changes at its boundaries and is locked
    on one side during a step, :func:`lock_shadow`) or, without it, that of the eclipse events
    among ``ev_kind`` (kinds 1 to 3; conical when any is), with no change of the force there;
    ``second`` the other model when eclipse events of it are asked for too, else 0. So every
    crossing of an eclipse event's function is found, also where a shadow is entered and left
    within what would have been one step. 0 for none (no eclipse events, no tabulated Sun)."""
    first = srp_shadow_model(force)
    lock = first > 0
    cyl = False
    con = False
    if force[fb.SUN_ROW] >= 0.0:
        for e in range(ev_kind.shape[0]):
            if ev_kind[e] == 1:
                cyl = True
            elif ev_kind[e] == 2 or ev_kind[e] == 3:
                con = True
    if first == 0:
        first = 2 if con else (1 if cyl else 0)
    second = 0
    if first == 2 and cyl:
        second = 1
    elif first == 1 and con:
        second = 2
    return first, second, lock


@kernel
def lock_shadow(rforce, model, side0):
    """Set the SRP slots of ``rforce`` (the integrator's copy of the force block) so that the
    cylindrical shadow stays on one side during a step: ``side0`` +1 lit (no shadow test), -1 in
    the shadow (no SRP). The conical shadow fraction is continuous: nothing to lock."""
    if model != 1:
        return
    if side0 > 0.0:
        rforce[fb.SRP_ON] = 1.0
        rforce[fb.SHADOW_MODEL] = 0.0
    else:
        rforce[fb.SRP_ON] = 0.0


@kernel
def fix_boundary_events(ev_kind, g, kind, side):
    """Give the events of ``kind`` in ``g`` (their values at the end of a step that ends on that
    shadow boundary) the sign of ``side`` (+1 outside, -1 inside): the boundary is crossed there,
    whatever side rounding put the step's end on, so the event is reported in this step (at the
    boundary, to its time tolerance) and not missed or reported again in the next."""
    for e in range(ev_kind.shape[0]):
        if ev_kind[e] == kind and (g[e] == 0.0 or (g[e] > 0.0) != (side > 0.0)):
            ga = abs(g[e])
            g[e] = side * (ga if ga > 0.0 else 1e-300)


#: Steps across the conical shadow's penumbra, at least (:func:`penumbra_step`).
PENUMBRA_STEPS = 4
#: The penumbra gets :data:`PENUMBRA_STEPS` steps when the velocity SRP gives across it exceeds
#: this many times the velocity tolerance (:func:`penumbra_step`).
PENUMBRA_IMPULSE = 1000.0


@kernel
def penumbra_step(g0, g1, which, h, srp_accel, v_tol):
    """The largest step in the penumbra just entered, s: its crossing time over
    :data:`PENUMBRA_STEPS`, when SRP (``srp_accel``, km/s^2) gives more than
    :data:`PENUMBRA_IMPULSE` times the velocity tolerance ``v_tol`` (km/s) across it; else, or
    where it cannot be estimated, ``inf``.

    ``g0``, ``g1`` are the penumbra and umbra functions at the start of the step of length ``h``
    that ended on boundary ``which``: the penumbra is 2a wide in them (a, the Sun's apparent
    radius: g1 - g0 = 2a) and is crossed at about the rate |g_which| / |h|. The fraction of the
    Sun seen varies like depth^(3/2) near the penumbra's edges (the overlap of two discs), so
    the force's second derivative is unbounded there, and DOP853's error estimate lets one step
    take the whole penumbra: 6 mm off after 10 days of GEO in eclipse season, 0.24 mm with
    this limit. In LEO (a penumbra of ~10 s, 12 times shorter) the limit is not needed at the
    default tolerances (0.15 mm after a day without it) and would cost 16 % more steps."""
    g = g0 if which == 0 else g1
    two_a = g1 - g0
    if g == 0.0 or not two_a > 0.0:
        return math.inf
    crossing = abs(two_a * h / g)
    if srp_accel * crossing <= PENUMBRA_IMPULSE * v_tol:
        return math.inf
    return crossing / PENUMBRA_STEPS


@step_kernel
def shadow_sides(model, t, y, force, eph_r, eph_v, s):
    """The sides (+1 outside, -1 inside) of the boundaries of SRP shadow ``model`` at (t, y)."""
    g0, g1 = shadow_values(model, t, y, force, eph_r, eph_v, s)
    return (1.0 if g0 >= 0.0 else -1.0), (1.0 if g1 >= 0.0 else -1.0)


@kernel
def step_sample(k, t, h, y, y_new, F, out):
    """The state at sample ``k`` of :data:`SHADOW_SAMPLES` of the step (t, h) into ``out`` (k = 0:
    ``y``, the last: ``y_new``, between: the dense output); returns its time."""
    if k == 0:
        for j in range(6):
            out[j] = y[j]
        return t
    if k == SHADOW_SAMPLES:
        for j in range(6):
            out[j] = y_new[j]
        return t + h
    tk = t + h * k / SHADOW_SAMPLES
    dense_eval(tk, t, h, y, F, out)
    return tk


@kernel
def dip_vertex(gs, k):
    """Where the parabola through the samples gs[k - 1], gs[k], gs[k + 1] (distances from a
    boundary, positive on the current side) has a minimum below half their least value, in
    sample units from k (-1..1); 2.0 where it has none."""
    p0 = gs[k - 1]
    p1 = gs[k]
    p2 = gs[k + 1]
    curv = 0.5 * (p0 - 2.0 * p1 + p2)
    if curv <= 0.0:
        return 2.0
    slope = 0.5 * (p2 - p0)
    u = -slope / (2.0 * curv)
    if u < -1.0 or u > 1.0:
        return 2.0
    low = p0 if p0 < p1 else p1
    low = p2 if p2 < low else low
    if p1 - slope * slope / (4.0 * curv) >= 0.5 * low:
        return 2.0
    return u


@step_kernel
def first_crossing(kind, param, side, gs, t, h, y, F, y_tmp, tol, force, eph_r, eph_v):
    """The first crossing in the step (t, t + h) of the zero of event function ``kind``
    (``param``) away from ``side`` (+1: g >= 0 at t, -1: g < 0), from its samples ``gs`` (side *
    g at the :data:`SHADOW_SAMPLES` + 1 points of :func:`step_sample`: positive on the current
    side), located to ``tol`` s on the dense output ``F``. Returns (found, ta, tb): the zero in
    [ta, tb], tb on the new side.

    A crossing shows as a sample on the other side; one entered and left again between two
    samples (grazing) as a minimum between them: where the parabola through three neighbouring
    samples dips below half their least value, its vertex is sampled too (the functions are
    smooth on the scale of a step, so the parabola finds the minimum of a dip shorter than the
    samples' spacing). Shared by the shadow boundaries (:func:`shadow_crossing`) and the
    exponential atmosphere's band edges (:func:`visviva.core.drag_bands.band_crossing`)."""
    ka = -1  # the crossing lies after sample ka (gs[ka] on the old side) and before tb
    tb = t
    gb = 0.0
    for k in range(1, SHADOW_SAMPLES + 1):
        if (gs[k] * side >= 0.0) != (side > 0.0):
            ka = k - 1
            tb = t + h if k == SHADOW_SAMPLES else t + h * k / SHADOW_SAMPLES
            gb = gs[k] * side
            break
    if ka < 0:
        for k in range(1, SHADOW_SAMPLES):
            u = dip_vertex(gs, k)
            if u > 1.0:
                continue
            tv = t + h * (k + u) / SHADOW_SAMPLES
            dense_eval(tv, t, h, y, F, y_tmp)
            g = event_value(kind, param, tv, y_tmp, force, eph_r, eph_v, True)
            if (g >= 0.0) != (side > 0.0):
                ka = k - 1 if u < 0.0 else k
                tb = tv
                gb = g
                break
    if ka < 0:
        return False, t, t
    ta = t + h * ka / SHADOW_SAMPLES if ka > 0 else t
    # the value at ta on the old side (at t, a value just past the boundary may have the new
    # side's sign: then take one of the size of gb)
    ga = side * gs[ka]
    if (ga >= 0.0) != (side > 0.0) or ga == 0.0:
        ga = side * abs(gb) if gb != 0.0 else side
    if gb == 0.0:
        gb = -side * abs(ga)
    ta, tb = locate_zero(kind, param, ta, tb, ga, gb, tol, t, h, y, F, y_tmp, force, eph_r,
                         eph_v, True)
    return True, ta, tb


@step_kernel
def shadow_crossing(model, n_sh, side0, side1, t, h, y, y_new, F, y_tmp, gs0, gs1, s, force,
                    eph_r, eph_v):  # fmt: skip
    """The first point of the step (t, t + h) where a shadow boundary function of SRP ``model``
    leaves the side it had at t (``side0``, ``side1``: +1 outside, -1 inside), located to
    ``BOUNDARY_RTOL`` |h| on the dense output. Returns (ta, tb, which): the zero lies in
    [ta, tb], tb on the new side; which = -1 when no boundary is crossed.

    The functions are sampled at :data:`SHADOW_SAMPLES` + 1 points of the step (into ``gs0``,
    ``gs1``, as side * g: positive on the current side; ``s``: scratch for the Sun), and each
    crossing found by :func:`first_crossing` (grazes included)."""
    for k in range(SHADOW_SAMPLES + 1):
        tk = step_sample(k, t, h, y, y_new, F, y_tmp)
        g0, g1 = shadow_values(model, tk, y_tmp, force, eph_r, eph_v, s)
        gs0[k] = side0 * g0
        gs1[k] = side1 * g1
    tol = BOUNDARY_RTOL * abs(h)
    best = -1
    best_a = t + h
    best_b = t + h
    for which in range(n_sh):
        found, ta, tb = first_crossing(shadow_boundary_kind(model, which), 0.0,
                                       side0 if which == 0 else side1, gs0 if which == 0 else gs1,
                                       t, h, y, F, y_tmp, tol, force, eph_r, eph_v)  # fmt: skip
        if found and (best < 0 or (tb - best_b) * h < 0.0):
            best_a = ta
            best_b = tb
            best = which
    return best_a, best_b, best


@kernel
def end_sample_value(kind, model, side0, side1, gs0, gs1):
    """(True, value) of the eclipse event ``kind`` (1 to 3) at the end of a step from the last
    samples ``gs0``, ``gs1`` (side * g) that :func:`shadow_crossing` took of the boundary
    functions of shadow ``model`` there, when the event is one of that model's (kind 1 of the
    cylindrical, 2 and 3 of the conical); else (False, 0.0). The same bits as
    :func:`event_function` at the same time and state: the sides are +1 or -1."""
    if (kind == 1 and model == 1) or ((kind == 2 or kind == 3) and model == 2):
        if kind == 3:
            return True, side1 * gs1[SHADOW_SAMPLES]
        return True, side0 * gs0[SHADOW_SAMPLES]
    return False, 0.0


@kernel
def boundary_gradient(model, which, t, y, force, eph_r, eph_v, s, grad):
    """The gradient of boundary function ``which`` of SRP shadow ``model`` with respect to the
    position at (t, y), 1 (into ``grad``, 3 values), and its rate along the trajectory, 1/s
    (returned), by central differences.

    The steps are 1e-3 km in each coordinate, and for the rate 1e-3 km along the straight line
    r + v dt (the acceleration's terms of the two sides cancel in a central difference, so the
    line and the trajectory give the same rate to second order). The functions are angles
    (conical) or distances (cylindrical) of curvature radius >= the body's radius, so the
    differences are good to ~1e-9 relative. Used by the state-transition matrix at a boundary
    where the force jumps (:mod:`visviva.core.variational`)."""
    dr = 1e-3
    p = np.empty(6)
    for j in range(6):
        p[j] = y[j]
    for k in range(3):
        p[k] = y[k] + dr
        gp0, gp1 = shadow_values(model, t, p, force, eph_r, eph_v, s)
        p[k] = y[k] - dr
        gm0, gm1 = shadow_values(model, t, p, force, eph_r, eph_v, s)
        p[k] = y[k]
        grad[k] = ((gp0 - gm0) if which == 0 else (gp1 - gm1)) / (2.0 * dr)
    v = math.sqrt(y[3] * y[3] + y[4] * y[4] + y[5] * y[5])
    dt = dr / v
    for k in range(3):
        p[k] = y[k] + y[3 + k] * dt
    gp0, gp1 = shadow_values(model, t + dt, p, force, eph_r, eph_v, s)
    for k in range(3):
        p[k] = y[k] - y[3 + k] * dt
    gm0, gm1 = shadow_values(model, t - dt, p, force, eph_r, eph_v, s)
    return ((gp0 - gm0) if which == 0 else (gp1 - gm1)) / (2.0 * dt)
