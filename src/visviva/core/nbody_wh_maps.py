"""The maps of a Wisdom-Holman step: coordinate transforms, Kepler drift, jump and kicks.

The pieces :mod:`visviva.core.nbody_whfast` composes into WHFast's step (see its module docstring
for the splittings): inertial <-> Jacobi and inertial <-> democratic heliocentric coordinates, the
Kepler drift of every body by the universal-variable kernel
:func:`visviva.core.universal.propagate_scalar`, the democratic heliocentric jump, and the
interaction kicks in either coordinate system. Each is a scalar loop over the bodies; the GPU
backend compiles the same functions as device twins (:mod:`visviva.core.cuda.whfast`). The
tangent (linearised) maps of the same pieces, for MEGNO, are in :mod:`.nbody_wh_tangent`.

References
----------
Wisdom, J. & Holman, M. (1991), "Symplectic maps for the N-body problem", AJ 102, 1528.
Rein, H. & Tamayo, D. (2015), "WHFAST: a fast and unbiased implementation of a symplectic
Wisdom-Holman integrator for long-term gravitational simulations", MNRAS 452, 376.
Duncan, M. J., Levison, H. F. & Lee, M. H. (1998), "A multiple time step symplectic algorithm
for integrating close encounters", AJ 116, 2067.
"""

from __future__ import annotations

import math

from ._jit import kernel
from .status import OK
from .universal import propagate_scalar

__all__ = [
    "to_jacobi",
    "from_jacobi",
    "to_democratic_heliocentric",
    "from_democratic_heliocentric",
    "to_internal",
    "from_internal",
    "kepler_drift",
    "jump",
    "drift",
    "interaction_kick",
    "dh_interaction_kick",
]


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
def to_democratic_heliocentric(x, m, eta, q, barycentric):
    """Inertial -> democratic heliocentric, one array (positions or velocities).

    ``q[0]`` = the centre of mass ``sum m_i x_i / M`` (``M = eta[-1]``); for ``i >= 1``
    ``q_i = x_i - x_0`` (positions: heliocentric) or, with ``barycentric``, ``q_i = x_i - q_0``
    (velocities: barycentric, i.e. the canonical momenta divided by the masses).
    """
    n = x.shape[0]
    M = eta[n - 1]
    for c in range(3):
        s = 0.0
        for i in range(n):
            s += m[i] * x[i, c]
        X = s / M
        origin = X if barycentric else x[0, c]
        for i in range(1, n):
            q[i, c] = x[i, c] - origin
        q[0, c] = X


@kernel
def from_democratic_heliocentric(q, m, eta, x, barycentric):
    """Democratic heliocentric -> inertial, the inverse of :func:`to_democratic_heliocentric`.

    Positions: ``x_0 = q_0 - sum_{i>=1} m_i q_i / M``, ``x_i = q_i + x_0``. Velocities
    (``barycentric``): ``v_0 = q_0 - sum_{i>=1} m_i q_i / m_0``, ``v_i = q_i + q_0``.
    """
    n = x.shape[0]
    M = eta[n - 1]
    for c in range(3):
        s = 0.0
        for i in range(1, n):
            s += m[i] * q[i, c]
        if barycentric:
            x[0, c] = q[0, c] - s / m[0]
            origin = q[0, c]
        else:
            origin = q[0, c] - s / M
            x[0, c] = origin
        for i in range(1, n):
            x[i, c] = q[i, c] + origin


@kernel
def to_internal(x, v, m, eta, xj, vj, dh):
    """Inertial ``x, v`` -> the internal coordinates (Jacobi, or democratic heliocentric)."""
    if dh:
        to_democratic_heliocentric(x, m, eta, xj, False)
        to_democratic_heliocentric(v, m, eta, vj, True)
    else:
        to_jacobi(x, m, eta, xj)
        to_jacobi(v, m, eta, vj)


@kernel
def from_internal(xj, vj, m, eta, x, v, dh):
    """The internal coordinates -> inertial ``x, v``."""
    if dh:
        from_democratic_heliocentric(xj, m, eta, x, False)
        from_democratic_heliocentric(vj, m, eta, v, True)
    else:
        from_jacobi(xj, m, eta, x)
        from_jacobi(vj, m, eta, v)


@kernel
def kepler_drift(xj, vj, eta, G, h, dh):
    """Every body on its Kepler orbit for ``h`` (GM = ``G eta_i``, or ``G m_0`` with ``dh``);
    the centre of mass (row 0) on a straight line."""
    n = xj.shape[0]
    for c in range(3):
        xj[0, c] += vj[0, c] * h
    for i in range(1, n):
        gm = G * eta[0] if dh else G * eta[i]
        st, x, y, z, vx, vy, vz = propagate_scalar(
            xj[i, 0], xj[i, 1], xj[i, 2], vj[i, 0], vj[i, 1], vj[i, 2], gm, h
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
def jump(q, vb, m, h):
    """The democratic heliocentric jump: every ``Q_i += h sum_{j>=1} m_j V_j / m_0``."""
    n = q.shape[0]
    px = 0.0
    py = 0.0
    pz = 0.0
    for i in range(1, n):
        px += m[i] * vb[i, 0]
        py += m[i] * vb[i, 1]
        pz += m[i] * vb[i, 2]
    k = h / m[0]
    for i in range(1, n):
        q[i, 0] += k * px
        q[i, 1] += k * py
        q[i, 2] += k * pz


@kernel
def drift(xj, vj, m, eta, G, h, jump_before, jump_after, dh):
    """The part of a step between kicks: Kepler drift ``h``, with ``dh`` between the jumps
    ``jump_before`` and ``jump_after`` (step lengths; 0 for none)."""
    if dh and jump_before != 0.0:
        jump(xj, vj, m, jump_before)
    st = kepler_drift(xj, vj, eta, G, h, dh)
    if st != OK:
        return st
    if dh and jump_after != 0.0:
        jump(xj, vj, m, jump_after)
    return OK


@kernel
def interaction_kick(xj, vj, aj, eta, G, h):
    n = xj.shape[0]
    for c in range(3):
        vj[0, c] += aj[0, c] * h
    for i in range(1, n):
        r2 = xj[i, 0] * xj[i, 0] + xj[i, 1] * xj[i, 1] + xj[i, 2] * xj[i, 2]
        k = G * eta[i] / (r2 * math.sqrt(r2))
        for c in range(3):
            vj[i, c] += (aj[i, c] + k * xj[i, c]) * h


@kernel
def dh_interaction_kick(vj, acc, fa, m, eta, h):
    """Democratic heliocentric kick ``h``: ``V_i += (g_i + f_i - a_cm) h`` with ``g`` the gravity
    of the bodies other than the central one, ``f`` the additional force and ``a_cm`` its
    mass-weighted mean, which kicks the centre-of-mass velocity ``V_0`` (row 0)."""
    n = vj.shape[0]
    M = eta[n - 1]
    for c in range(3):
        s = 0.0
        for i in range(n):
            s += m[i] * fa[i, c]
        a_cm = s / M
        vj[0, c] += a_cm * h
        for i in range(1, n):
            vj[i, c] += (acc[i, c] + (fa[i, c] - a_cm)) * h
