"""Newtonian N-body gravity by direct summation: compiled kernels.

The acceleration of particle ``i`` is

    a_i = sum_{j massive, j != i} G m_j (x_j - x_i) / (|x_j - x_i|**2 + eps**2)**(3/2)

where ``eps`` is the (optional) Plummer softening length. Test particles (``m = 0``) feel the
massive ones and pull on nothing, so a step costs O(N * N_massive).

Layout and determinism
----------------------
The massive particles are first copied into contiguous structure-of-arrays rows ``x_j, y_j, z_j,
G m_j`` (the scratch ``work``). One row kernel, :func:`row_acceleration`, sums the terms of one
``a_i`` over all of them in a branch-free loop (the self term and coincident particles without
softening are masked arithmetically: ``r2 == 0`` is replaced by 1 and the term is ``0 * ...``),
with the three sums in local scalars. It is compiled with :data:`visviva.core._jit.simd_kernel`
(reassociation allowed for this reduction only), so LLVM vectorises it: the partial sums live in
SIMD lanes and are combined in an order fixed by the compiled code, not by the data or the threads.
Every path (serial, multi-threaded with ``prange`` over ``i``) calls the same row kernel, so they
return the same bits whatever the number of threads. (The sum is not the strict left-to-right sum:
it differs from it in the last bits.)

All inputs are plain float64 arrays in any consistent units (``G`` in the same units).

References
----------
Aarseth, S. J., *Gravitational N-Body Simulations*, Cambridge University Press 2003, ch. 1-2.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import kernel, parallel_kernel, prange, simd_kernel

__all__ = [
    "row_acceleration",
    "pack_massive",
    "gravity_serial",
    "gravity_parallel",
    "gravity",
    "energy",
    "kinetic_energy",
    "potential_energy",
    "no_force",
    "PARALLEL_MIN_N",
]

#: From this many particles on, the simulation uses the multi-threaded kernel by default.
PARALLEL_MIN_N = 512
#: Particles ``i`` per work item of the multi-threaded kernel.
CHUNK = 64


@kernel
def no_force(t, x, v, m, params, acc):
    """The additional force that adds nothing (the default user force)."""
    return


@simd_kernel
def row_acceleration(xi, yi, zi, xm, ym, zm, gmm, soft2):
    """Acceleration of one particle from all massive ones (a vectorised reduction).

    Parameters
    ----------
    xi, yi, zi : float
        Position of the particle (length).
    xm, ym, zm : ndarray of float64, shape (N_massive,)
        Positions of the massive particles, contiguous (length).
    gmm : ndarray of float64, shape (N_massive,)
        ``G m_j`` of the massive particles (length**3 / time**2).
    soft2 : float
        Square of the Plummer softening length (length**2); 0 for none.

    Returns
    -------
    ax, ay, az : float
        ``sum_j G m_j d / (|d|**2 + eps**2)**(3/2)`` with ``d = x_j - x_i`` (length / time**2).

    Notes
    -----
    Branch-free: a zero ``r2`` (the particle itself, or a coincident one without softening,
    where ``d = 0`` exactly) is replaced by 1, so its term is exactly ``0``. Compiled with
    ``fastmath={"reassoc", "contract"}`` so that the three sums vectorise.
    """
    ax = 0.0
    ay = 0.0
    az = 0.0
    for b in range(xm.shape[0]):
        dx = xm[b] - xi
        dy = ym[b] - yi
        dz = zm[b] - zi
        r2 = dx * dx + dy * dy + dz * dz + soft2
        r2 += 1.0 if r2 == 0.0 else 0.0
        s = gmm[b] / (r2 * math.sqrt(r2))
        ax += dx * s
        ay += dy * s
        az += dz * s
    return ax, ay, az


@kernel
def pack_massive(x, m, G, massive, work):
    """Copy the massive particles into ``work[0:4, :N_massive]`` as ``x, y, z, G m``; return
    ``N_massive``."""
    nm = massive.shape[0]
    for b in range(nm):
        j = massive[b]
        work[0, b] = x[j, 0]
        work[1, b] = x[j, 1]
        work[2, b] = x[j, 2]
        work[3, b] = G * m[j]
    return nm


@kernel
def _rows(lo, hi, x, xm, ym, zm, gmm, soft2, acc):
    # the accelerations of particles lo <= i < hi, one row kernel call each
    for i in range(lo, hi):
        ax, ay, az = row_acceleration(x[i, 0], x[i, 1], x[i, 2], xm, ym, zm, gmm, soft2)
        acc[i, 0] = ax
        acc[i, 1] = ay
        acc[i, 2] = az


@kernel
def gravity_serial(x, m, G, soft2, massive, acc, work):
    """Accelerations by direct summation on one thread.

    Parameters
    ----------
    x : ndarray of float64, shape (N, 3)
        Positions (length).
    m : ndarray of float64, shape (N,)
        Masses (mass); zero for test particles (they feel the others and pull on nothing).
    G : float
        Gravitational constant (length**3 / (mass time**2)).
    soft2 : float
        Square of the softening length (length**2); 0 for none.
    massive : ndarray of int64, shape (N_massive,)
        Indices of the particles with m > 0, ascending.
    acc : ndarray of float64, shape (N, 3)
        Overwritten with the accelerations (length / time**2).
    work : ndarray of float64, shape (>= 4, >= N_massive)
        Scratch (the massive particles as structure of arrays).
    """
    nm = pack_massive(x, m, G, massive, work)
    _rows(0, x.shape[0], x, work[0, :nm], work[1, :nm], work[2, :nm], work[3, :nm], soft2, acc)


@parallel_kernel
def gravity_parallel(x, m, G, soft2, massive, acc, work):
    """:func:`gravity_serial` with chunks of :data:`CHUNK` particles ``i`` spread over threads.

    Same arguments and the same bits as :func:`gravity_serial`, for any number of threads: each
    row is summed by the same :func:`row_acceleration`.
    """
    nm = pack_massive(x, m, G, massive, work)
    n = x.shape[0]
    for k in prange((n + CHUNK - 1) // CHUNK):
        lo = k * CHUNK
        _rows(lo, min(n, lo + CHUNK), x, work[0, :nm], work[1, :nm], work[2, :nm], work[3, :nm],
              soft2, acc)


@kernel
def gravity(x, m, G, soft2, massive, acc, work, parallel):
    """Dispatch: :func:`gravity_parallel` when ``parallel``, else :func:`gravity_serial`
    (same bits)."""
    if parallel:
        gravity_parallel(x, m, G, soft2, massive, acc, work)
    else:
        gravity_serial(x, m, G, soft2, massive, acc, work)


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
