"""Two-body state-transition matrix by integrating the variational equations.

``d/dt [r, v, Phi] = [v, -gm r / |r|^3, A(r) Phi]`` with ``A = [[0, I], [G(r), 0]]`` and the
gravity gradient ``G = gm (3 r r^T / |r|^5 - I / |r|^3)``, integrated by the classical fourth-order
Runge-Kutta method. Each step spans 1/300 of the *local* time scale r / sqrt(v^2 + 2 gm / r)
(~r^1.5 / sqrt(gm), the usual time-step regularisation; 1/3265 of the period on a circle), so
the periapsis passage of every conic is resolved wherever the arc starts. Against finite
differences of a 60-digit mpmath propagation (max |error| / max |Phi|): LEO over a day 3e-11, a
GTO (e = 0.73) over a day 4e-10, a parabola through periapsis over 2e6 s 1e-8, a hyperbola
far out 6e-14; the error scales as the step^4. A step fixed from the *initial* state (before
audit47) left hyperbolic and parabolic arcs that start far out and pass periapsis 0.3 % to 10^3
relative wrong, silently (tests/test_core_stm.py).
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import inline_kernel, kernel

__all__ = ["two_body_stm"]

#: Each Runge-Kutta step spans this fraction of the local time scale r / sqrt(v^2 + 2 gm / r)
#: (1/3265 of the period on a circle).
_STEP_FRACTION = 1.0 / 300.0
#: Refuse arcs needing more steps than this (about 30 000 low-orbit revolutions, ~40 s of
#: stepping; bound orbits are refused at once from :func:`_steps_estimate`).
_MAX_STEPS = 100_000_000


@inline_kernel
def _local_time_scale(y, gm):
    """r / sqrt(v^2 + 2 gm / r) (s): the time to cross a distance r at the local speed, or at
    the escape speed if slower; proportional to r^1.5 / sqrt(gm) near periapsis of every conic."""
    r = math.sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2])
    v2 = y[3] * y[3] + y[4] * y[4] + y[5] * y[5]
    return r / math.sqrt(v2 + 2.0 * gm / r)


@inline_kernel
def _deriv(y, gm, out):
    x0 = y[0]
    x1 = y[1]
    x2 = y[2]
    r2 = x0 * x0 + x1 * x1 + x2 * x2
    r = math.sqrt(r2)
    ir3 = 1.0 / (r2 * r)
    ir5 = ir3 / r2
    out[0] = y[3]
    out[1] = y[4]
    out[2] = y[5]
    out[3] = -gm * x0 * ir3
    out[4] = -gm * x1 * ir3
    out[5] = -gm * x2 * ir3
    p = (x0, x1, x2)
    # Phi is stored row-major in y[6:42]; dPhi = A Phi
    for j in range(6):
        for i in range(3):
            out[6 + i * 6 + j] = y[6 + (i + 3) * 6 + j]
        for i in range(3):
            s = 0.0
            for k in range(3):
                g = 3.0 * gm * p[i] * p[k] * ir5
                if i == k:
                    g -= gm * ir3
                s += g * y[6 + k * 6 + j]
            out[6 + (i + 3) * 6 + j] = s


@inline_kernel
def _steps_estimate(r0, v0, gm, dt):
    """Steps the integration of a bound orbit will take over ``dt`` (0 for open orbits, whose
    steps grow with r and number ~ 300 ln(dt)).

    With v^2 = gm (2/r - 1/a) and dt = r dE / (n a), dt / tau = sqrt(4 a / r - 1) dE: the
    steps per period are _STEP_FRACTION^-1 times the integral of sqrt(4 / (1 - e cos E) - 1)
    over one revolution (a 64-point midpoint sum: within a few per cent, enough for the refusal).
    """
    rn = math.sqrt(r0[0] ** 2 + r0[1] ** 2 + r0[2] ** 2)
    vn2 = v0[0] ** 2 + v0[1] ** 2 + v0[2] ** 2
    inv_a = 2.0 / rn - vn2 / gm
    if not inv_a > 0.0:
        return 0.0
    a = 1.0 / inv_a
    hx = r0[1] * v0[2] - r0[2] * v0[1]
    hy = r0[2] * v0[0] - r0[0] * v0[2]
    hz = r0[0] * v0[1] - r0[1] * v0[0]
    one_minus_e2 = (hx * hx + hy * hy + hz * hz) / gm * inv_a
    e = math.sqrt(1.0 - one_minus_e2) if one_minus_e2 < 1.0 else 0.0
    total = 0.0
    for k in range(64):
        E = (k + 0.5) * (2.0 * math.pi / 64.0)
        total += math.sqrt(4.0 / (1.0 - e * math.cos(E)) - 1.0)
    per_period = total * (2.0 * math.pi / 64.0) / _STEP_FRACTION
    period = 2.0 * math.pi * math.sqrt(a * a * a / gm)
    return abs(dt) / period * per_period


@kernel
def two_body_stm(r0, v0, gm, dt, phi):
    """Write the 6x6 STM from ``(r0, v0)`` over ``dt`` into ``phi``; return the final (r, v).

    ``r0``, ``v0`` of length 3, any consistent units with ``gm`` and ``dt``; ``phi`` (6, 6).
    Returns ``(r, v, status)``: status 0, or 4 (non-finite input) / 5 (zero position) /
    6 (gm <= 0) / 9 (the arc falls into the centre) / 1 (the arc needs more than ``_MAX_STEPS`` steps: ~30 000 low-orbit revolutions).
    """
    r = np.empty(3)
    v = np.empty(3)
    for i in range(6):
        for j in range(6):
            phi[i, j] = 1.0 if i == j else 0.0
    for i in range(3):
        if not (math.isfinite(r0[i]) and math.isfinite(v0[i])):
            return r, v, 4
    rn = math.sqrt(r0[0] ** 2 + r0[1] ** 2 + r0[2] ** 2)
    if rn == 0.0:
        return r, v, 5
    y = np.empty(42)
    for i in range(3):
        y[i] = r0[i]
        y[3 + i] = v0[i]
    for i in range(36):
        y[6 + i] = 1.0 if i % 7 == 0 else 0.0
    if not (math.isfinite(gm) and math.isfinite(dt)):
        return r, v, 4
    if not gm > 0.0:
        return r, v, 6
    if _steps_estimate(r0, v0, gm, dt) > _MAX_STEPS:
        return r, v, 1  # refused at once rather than after a minute of stepping
    k1 = np.empty(42)
    k2 = np.empty(42)
    k3 = np.empty(42)
    k4 = np.empty(42)
    tmp = np.empty(42)
    t = 0.0
    span = abs(dt)
    sgn = 1.0 if dt >= 0.0 else -1.0
    steps = 0
    while t < span:
        h = _STEP_FRACTION * _local_time_scale(y, gm)
        left = span - t
        if h >= left:
            h = left
        elif 2.0 * h > left:  # two even steps rather than a last sliver
            h = 0.5 * left
        steps += 1
        if steps > _MAX_STEPS:
            return r, v, 1
        if not (h > 0.0 and t + h > t):  # the steps shrink to nothing: a fall into the centre
            return r, v, 9
        hs = sgn * h
        _deriv(y, gm, k1)
        for i in range(42):
            tmp[i] = y[i] + 0.5 * hs * k1[i]
        _deriv(tmp, gm, k2)
        for i in range(42):
            tmp[i] = y[i] + 0.5 * hs * k2[i]
        _deriv(tmp, gm, k3)
        for i in range(42):
            tmp[i] = y[i] + hs * k3[i]
        _deriv(tmp, gm, k4)
        for i in range(42):
            y[i] += hs / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        t = span if h == left else t + h
    for i in range(6):
        for j in range(6):
            phi[i, j] = y[6 + i * 6 + j]
    for i in range(3):
        r[i] = y[i]
        v[i] = y[3 + i]
    return r, v, 0
