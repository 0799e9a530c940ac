"""Two-body state-transition matrix by integrating the variational equations.

``d/dt [r, v, Phi] = [v, -gm r / |r|^3, A(r) Phi]`` with ``A = [[0, I], [G(r), 0]]`` and the
gravity gradient ``G = gm (3 r r^T / |r|^5 - I / |r|^3)``, integrated by the classical fourth-order
Runge-Kutta method with a step of at most 1/2000 of the orbital period (or of |r|/|v| on open
orbits): ~1e-10 relative to the exact Keplerian STM (the test compares with finite differences of
:func:`visviva.core.universal.propagate_one`).
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import inline_kernel, kernel

__all__ = ["two_body_stm"]


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


@kernel
def two_body_stm(r0, v0, gm, dt, phi):
    """Write the 6x6 STM from ``(r0, v0)`` over ``dt`` into ``phi``; return the final (r, v).

    ``r0``, ``v0`` of length 3, any consistent units with ``gm`` and ``dt``; ``phi`` (6, 6).
    Returns ``(r, v, status)``: status 0, or 4 (non-finite input) / 5 (zero position).
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
    vn2 = v0[0] ** 2 + v0[1] ** 2 + v0[2] ** 2
    energy = 0.5 * vn2 - gm / rn
    if energy < 0.0:
        a = -gm / (2.0 * energy)
        period = 2.0 * math.pi * math.sqrt(a * a * a / gm)
        # the step must also resolve periapsis: scale by (r_p / a)^1.5 through e
        hx = r0[1] * v0[2] - r0[2] * v0[1]
        hy = r0[2] * v0[0] - r0[0] * v0[2]
        hz = r0[0] * v0[1] - r0[1] * v0[0]
        p = (hx * hx + hy * hy + hz * hz) / gm
        e = math.sqrt(max(0.0, 1.0 - p / a))
        h_max = period / 2000.0 * (1.0 - e) ** 1.5
    else:
        h_max = rn / math.sqrt(vn2 + 2.0 * gm / rn) / 200.0
    n = max(16, int(math.ceil(abs(dt) / h_max)))
    h = dt / n
    k1 = np.empty(42)
    k2 = np.empty(42)
    k3 = np.empty(42)
    k4 = np.empty(42)
    tmp = np.empty(42)
    for _ in range(n):
        _deriv(y, gm, k1)
        for i in range(42):
            tmp[i] = y[i] + 0.5 * h * k1[i]
        _deriv(tmp, gm, k2)
        for i in range(42):
            tmp[i] = y[i] + 0.5 * h * k2[i]
        _deriv(tmp, gm, k3)
        for i in range(42):
            tmp[i] = y[i] + h * k3[i]
        _deriv(tmp, gm, k4)
        for i in range(42):
            y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    for i in range(6):
        for j in range(6):
            phi[i, j] = y[6 + i * 6 + j]
    for i in range(3):
        r[i] = y[i]
        v[i] = y[3 + i]
    return r, v, 0
