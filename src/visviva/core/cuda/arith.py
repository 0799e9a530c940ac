"""Per-pair and per-member N-body arithmetic, written once for the CPU and the GPU.

These are plain Python functions on scalars and arrays, compiled by :mod:`.kernels` with
``numba.cuda.jit(device=True)`` and here with ``numba.njit`` (the CPU twins, ``*_cpu``). They use
only arithmetic, ``math.sqrt`` and indexing, which both targets compile alike. The formula is the
one of the CPU gravity kernel :func:`visviva.core.gravity.row_acceleration_fast`:

    a_i = sum_{j massive, j != i} G m_j (x_j - x_i) / (|x_j - x_i|**2 + eps**2)**(3/2)

summed in index order (the CPU kernel sums in SIMD lanes; the two agree to round-off, about
1e-16 relative per evaluation).

Arrays of a member ``k`` live in flat ensemble layouts: particles ``lo <= i < hi`` of ``x, v``
(shape (sum N, 3)), its massive particles ``massive[mlo:mhi]`` (global indices) with ``gm`` the
products ``G m`` of every particle.
"""

from __future__ import annotations

import math

from .._jit import inline_kernel, kernel

__all__ = ["pair_acceleration", "member_accelerations", "member_dkd", "particle_acceleration"]


def pair_acceleration(dx, dy, dz, gm, soft2):
    """Acceleration on particle i from one massive particle j, ``d = x_j - x_i`` (length).

    Parameters
    ----------
    dx, dy, dz : float
        Separation ``x_j - x_i`` (length).
    gm : float
        ``G m_j`` (length**3 / time**2).
    soft2 : float
        Plummer softening length squared (length**2).

    Returns
    -------
    ax, ay, az : float
        ``G m_j d / (|d|**2 + eps**2)**1.5`` (length / time**2); zero for ``r2 == 0`` (the
        particle itself, or a coincident one without softening), as in the CPU kernel.
    """
    r2 = dx * dx + dy * dy + dz * dz + soft2
    if r2 == 0.0:
        return 0.0, 0.0, 0.0
    s = gm / (r2 * math.sqrt(r2))
    return dx * s, dy * s, dz * s


def particle_acceleration(i, x, gm, massive, mlo, mhi, soft2):
    """Acceleration of particle ``i`` from the massive particles ``massive[mlo:mhi]``."""
    ax = 0.0
    ay = 0.0
    az = 0.0
    for b in range(mlo, mhi):
        j = massive[b]
        px, py, pz = _pair(x[j, 0] - x[i, 0], x[j, 1] - x[i, 1], x[j, 2] - x[i, 2], gm[j], soft2)
        ax += px
        ay += py
        az += pz
    return ax, ay, az


def member_accelerations(x, gm, massive, mlo, mhi, lo, hi, soft2, acc):
    """Accelerations of particles ``lo <= i < hi`` into ``acc``."""
    for i in range(lo, hi):
        ax, ay, az = _particle(i, x, gm, massive, mlo, mhi, soft2)
        acc[i, 0] = ax
        acc[i, 1] = ay
        acc[i, 2] = az


def member_dkd(x, v, m, gm, massive, mlo, mhi, lo, hi, soft2, acc, t, h, force, params):
    """One drift-kick-drift leapfrog step of length ``h`` (time) from time ``t`` of one member,
    in place; ``force(t, x, v, m, params, acc)`` adds the additional force of the member's
    particles (their rows of ``x, v, m, acc``) at the middle of the step.

    The same operations in the same order as :func:`visviva.core.nbody_leapfrog._dkd`.
    """
    half = 0.5 * h
    for i in range(lo, hi):
        for c in range(3):
            x[i, c] += v[i, c] * half
    _member_acc(x, gm, massive, mlo, mhi, lo, hi, soft2, acc)
    force(t + half, x[lo:hi], v[lo:hi], m[lo:hi], params, acc[lo:hi])
    for i in range(lo, hi):
        for c in range(3):
            v[i, c] += acc[i, c] * h
            x[i, c] += v[i, c] * half


# ---- the CPU twins --------------------------------------------------------------------------------
# The functions above call their helpers through the names ``_pair``, ``_particle`` and
# ``_member_acc``; here they are bound to the CPU compilations, and :func:`rebind` gives the same
# source with them bound to other compilations (the GPU device functions in .kernels).
_pair = pair_acceleration_cpu = inline_kernel(pair_acceleration)
_particle = particle_acceleration_cpu = inline_kernel(particle_acceleration)
_member_acc = member_accelerations_cpu = kernel(member_accelerations)
member_dkd_cpu = kernel(member_dkd)


def rebind(fn, **helpers):
    """``fn``'s source as a new Python function whose helper names refer to ``helpers``."""
    import types

    scope = dict(fn.__globals__)
    scope.update(helpers)
    return types.FunctionType(fn.__code__, scope, fn.__name__, fn.__defaults__, fn.__closure__)
