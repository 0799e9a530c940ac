"""Newtonian N-body gravity by direct summation: compiled kernels.

The acceleration of particle ``i`` is

    a_i = sum_{j massive, j != i} G m_j (x_j - x_i) / (|x_j - x_i|**2 + eps**2)**(3/2)

where ``eps`` is the (optional) Plummer softening length. Test particles (``m = 0``) feel the
massive ones and pull on nothing, so a step costs O(N * N_massive).

Determinism
-----------
Every kernel here adds the terms of ``a_i`` in ONE fixed order: over the massive particles ``j`` in
increasing index order, starting from zero, each term evaluated as
``d * (G m_j * inv_r3)`` with ``inv_r3 = 1 / (r2 * sqrt(r2))``. The serial pairwise kernel (which
uses Newton's third law, ``d_ji = -d_ij`` exactly in IEEE arithmetic) and the parallel blocked
kernel (``j`` outer, a block of ``i`` inner, blocks spread over threads) therefore return the same
bits, whatever the number of threads.

All inputs are plain float64 arrays in any consistent units (``G`` in the same units).

References
----------
Aarseth, S. J., *Gravitational N-Body Simulations*, Cambridge University Press 2003, ch. 1-2.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import kernel, parallel_kernel, prange

__all__ = [
    "gravity_serial",
    "gravity_parallel",
    "gravity_blocked",
    "gravity",
    "energy",
    "kinetic_energy",
    "potential_energy",
    "no_force",
    "BLOCK",
    "PARALLEL_MIN_N",
]

#: Number of particles ``i`` per block of the parallel kernel (the block's accumulators stay in L1).
BLOCK = 256
#: From this many particles on, the simulation uses the multi-threaded kernel by default.
PARALLEL_MIN_N = 512
#: Below this many particles :func:`gravity` uses the pairwise kernel (Newton's third law).
BLOCKED_MIN_N = 64


@kernel
def no_force(t, x, v, m, params, acc):
    """The additional force that adds nothing (the default user force)."""
    return


@kernel
def gravity_serial(x, m, G, soft2, massive, acc):
    """Accelerations by direct summation, serial, pairwise (Newton's third law).

    Parameters
    ----------
    x : ndarray of float64, shape (N, 3)
        Positions (length).
    m : ndarray of float64, shape (N,)
        Masses (mass); zero for test particles.
    G : float
        Gravitational constant (length**3 / (mass time**2)).
    soft2 : float
        Square of the softening length (length**2); 0 for none.
    massive : ndarray of int64, shape (N_massive,)
        Indices of the particles with m > 0, ascending.
    acc : ndarray of float64, shape (N, 3)
        Overwritten with the accelerations (length / time**2).
    """
    n = x.shape[0]
    nm = massive.shape[0]
    for i in range(n):
        acc[i, 0] = 0.0
        acc[i, 1] = 0.0
        acc[i, 2] = 0.0
    # massive-massive pairs: row a adds its terms to every later partner, so each a_i still
    # receives its terms in increasing j order (the canonical order)
    for a in range(nm):
        i = massive[a]
        gmi = G * m[i]
        xi = x[i, 0]
        yi = x[i, 1]
        zi = x[i, 2]
        axi = acc[i, 0]
        ayi = acc[i, 1]
        azi = acc[i, 2]
        for b in range(a + 1, nm):
            j = massive[b]
            dx = x[j, 0] - xi
            dy = x[j, 1] - yi
            dz = x[j, 2] - zi
            r2 = dx * dx + dy * dy + dz * dz + soft2
            if r2 > 0.0:
                inv_r3 = 1.0 / (r2 * math.sqrt(r2))
            else:
                inv_r3 = 0.0  # coincident particles without softening: no force, like _row
            sj = G * m[j] * inv_r3
            si = gmi * inv_r3
            axi += dx * sj
            ayi += dy * sj
            azi += dz * sj
            acc[j, 0] += (-dx) * si
            acc[j, 1] += (-dy) * si
            acc[j, 2] += (-dz) * si
        acc[i, 0] = axi
        acc[i, 1] = ayi
        acc[i, 2] = azi
    # test particles: feel every massive particle, in increasing j order
    if nm < n:
        for i in range(n):
            if m[i] != 0.0:
                continue
            xi = x[i, 0]
            yi = x[i, 1]
            zi = x[i, 2]
            axi = 0.0
            ayi = 0.0
            azi = 0.0
            for b in range(nm):
                j = massive[b]
                dx = x[j, 0] - xi
                dy = x[j, 1] - yi
                dz = x[j, 2] - zi
                r2 = dx * dx + dy * dy + dz * dz + soft2
                inv_r3 = 1.0 / (r2 * math.sqrt(r2)) if r2 > 0.0 else 0.0
                sj = G * m[j] * inv_r3
                axi += dx * sj
                ayi += dy * sj
                azi += dz * sj
            acc[i, 0] = axi
            acc[i, 1] = ayi
            acc[i, 2] = azi


@kernel
def _row(nb, xj, yj, zj, gmj, soft2, bx, by, bz, bax, bay, baz):
    # one source j on a block of targets i (zero-based views, branch-free: vectorises);
    # r2 = 0 (the particle itself, or a coincident one without softening) adds exactly +0
    for i in range(nb):
        dx = xj - bx[i]
        dy = yj - by[i]
        dz = zj - bz[i]
        r2 = dx * dx + dy * dy + dz * dz + soft2
        s = gmj * (1.0 / (r2 * math.sqrt(r2))) if r2 > 0.0 else 0.0
        bax[i] += dx * s
        bay[i] += dy * s
        baz[i] += dz * s


@kernel
def _block(lo, hi, xs, ys, zs, gm, soft2, massive, ax, ay, az):
    bx = xs[lo:hi]
    by = ys[lo:hi]
    bz = zs[lo:hi]
    bax = ax[lo:hi]
    bay = ay[lo:hi]
    baz = az[lo:hi]
    nb = hi - lo
    for i in range(nb):
        bax[i] = 0.0
        bay[i] = 0.0
        baz[i] = 0.0
    for b in range(massive.shape[0]):
        j = massive[b]
        _row(nb, xs[j], ys[j], zs[j], gm[j], soft2, bx, by, bz, bax, bay, baz)


@parallel_kernel
def gravity_parallel(x, m, G, soft2, massive, acc, work):
    """Accelerations by direct summation, blocks of particles spread over threads.

    Same arguments and the same bits as :func:`gravity_serial`; ``work`` is a scratch array of
    shape (7, N). Each block of :data:`BLOCK` particles ``i`` loops over the massive ``j`` (outer)
    and its own ``i`` (inner, contiguous structure-of-arrays, vectorisable), so blocks are
    independent and the result does not depend on the number of threads.
    """
    n = x.shape[0]
    xs = work[0]
    ys = work[1]
    zs = work[2]
    gm = work[3]
    ax = work[4]
    ay = work[5]
    az = work[6]
    for i in range(n):
        xs[i] = x[i, 0]
        ys[i] = x[i, 1]
        zs[i] = x[i, 2]
        gm[i] = G * m[i]
    nblocks = (n + BLOCK - 1) // BLOCK
    for k in prange(nblocks):
        lo = k * BLOCK
        hi = min(n, lo + BLOCK)
        _block(lo, hi, xs, ys, zs, gm, soft2, massive, ax, ay, az)
    for i in range(n):
        acc[i, 0] = ax[i]
        acc[i, 1] = ay[i]
        acc[i, 2] = az[i]


@kernel
def gravity_blocked(x, m, G, soft2, massive, acc, work):
    """:func:`gravity_parallel` on one thread without the thread pool (same bits)."""
    n = x.shape[0]
    xs = work[0]
    ys = work[1]
    zs = work[2]
    gm = work[3]
    ax = work[4]
    ay = work[5]
    az = work[6]
    for i in range(n):
        xs[i] = x[i, 0]
        ys[i] = x[i, 1]
        zs[i] = x[i, 2]
        gm[i] = G * m[i]
    nblocks = (n + BLOCK - 1) // BLOCK
    for k in range(nblocks):
        lo = k * BLOCK
        hi = min(n, lo + BLOCK)
        _block(lo, hi, xs, ys, zs, gm, soft2, massive, ax, ay, az)
    for i in range(n):
        acc[i, 0] = ax[i]
        acc[i, 1] = ay[i]
        acc[i, 2] = az[i]


@kernel
def gravity(x, m, G, soft2, massive, acc, work, parallel):
    """Dispatch: :func:`gravity_parallel` when ``parallel``, else the vectorised
    :func:`gravity_blocked` for N >= :data:`BLOCKED_MIN_N`, else the pairwise
    :func:`gravity_serial`. All three give the same bits."""
    if parallel:
        gravity_parallel(x, m, G, soft2, massive, acc, work)
    elif x.shape[0] >= BLOCKED_MIN_N:
        gravity_blocked(x, m, G, soft2, massive, acc, work)
    else:
        gravity_serial(x, m, G, soft2, massive, acc)


@kernel
def kinetic_energy(v, m):
    """Kinetic energy ``sum m v**2 / 2`` (mass length**2 / time**2)."""
    T = 0.0
    for i in range(v.shape[0]):
        T += 0.5 * m[i] * (v[i, 0] * v[i, 0] + v[i, 1] * v[i, 1] + v[i, 2] * v[i, 2])
    return T


@kernel
def potential_energy(x, m, G, soft2):
    """Potential energy ``-sum_{i<j} G m_i m_j / sqrt(r_ij**2 + eps**2)``."""
    n = x.shape[0]
    U = 0.0
    for i in range(n):
        if m[i] == 0.0:
            continue
        for j in range(i + 1, n):
            if m[j] == 0.0:
                continue
            dx = x[j, 0] - x[i, 0]
            dy = x[j, 1] - x[i, 1]
            dz = x[j, 2] - x[i, 2]
            U -= G * m[i] * m[j] / math.sqrt(dx * dx + dy * dy + dz * dz + soft2)
    return U


@kernel
def energy(x, v, m, G, soft2):
    """Total energy, kinetic plus potential (mass length**2 / time**2)."""
    return kinetic_energy(v, m) + potential_energy(x, m, G, soft2)


@kernel
def energy_history(xs, vs, m, G, soft2, out):
    """Total energy of each snapshot: ``xs``, ``vs`` of shape (T, N, 3), ``out`` of shape (T,)."""
    for k in range(xs.shape[0]):
        out[k] = energy(xs[k], vs[k], m, G, soft2)


def massive_indices(m):
    """Indices of the particles with non-zero mass, ascending, as int64 (helper, not compiled)."""
    return np.flatnonzero(np.asarray(m) != 0.0).astype(np.int64)
