"""Gravity on two-part positions ``x + xlo`` (IAS15's compensated positions): compiled kernels.

A tight pair far from the origin has its separation rounded to about eps |x| when the positions
are single doubles; IAS15 keeps each position as a value ``x`` plus the compensated-summation part
``xlo``, and while a pair is tight (closer than 1/8 of its distance from the origin) its gravity
is summed on the differences ``(x_j - x_i) + (xlo_j - xlo_i)``, which keep the separation to
eps d. :func:`gravity_split` dispatches: a plain pair loop below :data:`SPLIT_FEW_N` massive
particles, the packed vectorised rows (as :mod:`visviva.core.gravity`) up to
:data:`visviva.core.gravity.PAIR_MIN_N`, and from there the large-N kernel on the rounded
positions. The result does not depend on the number of threads.
"""

from __future__ import annotations

import math

from ._jit import kernel, parallel_kernel, prange, simd_kernel
from .gravity import (
    CHUNK,
    PAIR_MIN_N,
    gravity,
    pack_massive,
)

__all__ = ["gravity_split", "row_acceleration_split", "SPLIT_FEW_N"]

#: Below this many massive particles :func:`gravity_split` sums the pairs in one plain loop.
SPLIT_FEW_N = 7


@simd_kernel
def row_acceleration_split(xi, yi, zi, lxi, lyi, lzi, xm, ym, zm, gmm, lxm, lym, lzm, soft2):
    """:func:`row_acceleration` for positions given in two parts, ``x = hi + lo``.

    Parameters
    ----------
    xi, yi, zi, lxi, lyi, lzi : float
        High and low parts of the particle's position (length).
    xm, ym, zm, lxm, lym, lzm : ndarray of float64, shape (N_massive,)
        High and low parts of the positions of the massive particles, contiguous (length).
    gmm : ndarray of float64, shape (N_massive,)
        ``G m_j`` of the massive particles (length**3 / time**2).
    soft2 : float
        Square of the Plummer softening length (length**2); 0 for none.

    Returns
    -------
    ax, ay, az : float
        The acceleration (length / time**2).

    Notes
    -----
    The separation is ``d = (x_j - x_i) + (lo_j - lo_i)``: for two particles close to each other
    far from the origin, ``x_j - x_i`` is exact (Sterbenz's lemma) and the low parts restore the
    digits that rounding the positions to doubles would lose, so ``d`` is accurate to about one
    ulp of ``|d|`` instead of one ulp of ``|x|``. (No ``nsz`` flag, so LLVM does not reassociate
    the four-term sum; only the reductions ``ax, ay, az`` are reordered for SIMD.)
    """
    ax = 0.0
    ay = 0.0
    az = 0.0
    for b in range(xm.shape[0]):
        dx = (xm[b] - xi) + (lxm[b] - lxi)
        dy = (ym[b] - yi) + (lym[b] - lyi)
        dz = (zm[b] - zi) + (lzm[b] - lzi)
        r2 = dx * dx + dy * dy + dz * dz + soft2
        r2 += 1.0 if r2 == 0.0 else 0.0
        s = gmm[b] / (r2 * math.sqrt(r2))
        ax += dx * s
        ay += dy * s
        az += dz * s
    return ax, ay, az


@kernel
def _rows_split(lo, hi, x, xlo, xm, ym, zm, gmm, lxm, lym, lzm, soft2, acc):
    for i in range(lo, hi):
        ax, ay, az = row_acceleration_split(x[i, 0], x[i, 1], x[i, 2], xlo[i, 0], xlo[i, 1],
                                            xlo[i, 2], xm, ym, zm, gmm, lxm, lym, lzm, soft2)
        acc[i, 0] = ax
        acc[i, 1] = ay
        acc[i, 2] = az


@kernel
def _pack_split(x, xlo, m, G, massive, work):
    # the massive particles as rows x, y, z, G m, lo_x, lo_y, lo_z of work
    nm = pack_massive(x, m, G, massive, work)
    for b in range(nm):
        j = massive[b]
        work[4, b] = xlo[j, 0]
        work[5, b] = xlo[j, 1]
        work[6, b] = xlo[j, 2]
    return nm


@kernel
def _gravity_split_serial(x, xlo, m, G, soft2, massive, acc, work):
    nm = _pack_split(x, xlo, m, G, massive, work)
    _rows_split(0, x.shape[0], x, xlo, work[0, :nm], work[1, :nm], work[2, :nm], work[3, :nm],
                work[4, :nm], work[5, :nm], work[6, :nm], soft2, acc)


@parallel_kernel
def _gravity_split_parallel(x, xlo, m, G, soft2, massive, acc, work):
    nm = _pack_split(x, xlo, m, G, massive, work)
    n = x.shape[0]
    for k in prange((n + CHUNK - 1) // CHUNK):
        lo = k * CHUNK
        _rows_split(lo, min(n, lo + CHUNK), x, xlo, work[0, :nm], work[1, :nm], work[2, :nm],
                    work[3, :nm], work[4, :nm], work[5, :nm], work[6, :nm], soft2, acc)


@kernel
def _gravity_split_few(x, xlo, m, G, soft2, massive, acc):
    # few massive particles: one plain loop over the pairs, no packing (the packed, vectorised
    # rows cost more than they save below SPLIT_FEW_N)
    for i in range(x.shape[0]):
        ax = 0.0
        ay = 0.0
        az = 0.0
        for b in range(massive.shape[0]):
            j = massive[b]
            dx = (x[j, 0] - x[i, 0]) + (xlo[j, 0] - xlo[i, 0])
            dy = (x[j, 1] - x[i, 1]) + (xlo[j, 1] - xlo[i, 1])
            dz = (x[j, 2] - x[i, 2]) + (xlo[j, 2] - xlo[i, 2])
            r2 = dx * dx + dy * dy + dz * dz + soft2
            if r2 == 0.0:
                continue  # the particle itself (or a coincident one without softening)
            s = G * m[j] / (r2 * math.sqrt(r2))
            ax += dx * s
            ay += dy * s
            az += dz * s
        acc[i, 0] = ax
        acc[i, 1] = ay
        acc[i, 2] = az


@kernel
def gravity_split(x, xlo, m, G, soft2, massive, acc, work, parallel):
    """:func:`gravity` for positions given in two parts, ``x + xlo`` (IAS15's compensated state).

    Parameters
    ----------
    x, xlo : ndarray of float64, shape (N, 3)
        High and low parts of the positions (length); ``|xlo|`` at most about one ulp of ``x``.
    m, G, soft2, massive, acc, parallel
        As in :func:`gravity_serial` (``acc`` is overwritten, length / time**2).
    work : ndarray of float64, shape (7, >= N_massive)
        Scratch: the massive particles as rows ``x, y, z, G m, lo_x, lo_y, lo_z``.

    Notes
    -----
    Separations are formed as ``(x_j - x_i) + (lo_j - lo_i)`` (see
    :func:`row_acceleration_split`), so a tight pair far from the origin keeps its relative
    precision. Below :data:`SPLIT_FEW_N` massive particles (serial) one plain loop over the
    pairs (no packing: about half the time of :func:`gravity` for three bodies); up to
    :data:`PAIR_MIN_N` the packed, vectorised rows of :func:`row_acceleration_split` (about 1.3x
    the time of :func:`gravity`); from :data:`PAIR_MIN_N` massive particles on, the large-N
    kernel runs on the high parts alone (as :func:`gravity` does).
    """
    if parallel is None:  # FEW: the serial few-body paths alone (see gravity.gravity)
        if massive.shape[0] < SPLIT_FEW_N:
            _gravity_split_few(x, xlo, m, G, soft2, massive, acc)
        else:
            _gravity_split_serial(x, xlo, m, G, soft2, massive, acc, work)
    elif massive.shape[0] >= PAIR_MIN_N:
        gravity(x, m, G, soft2, massive, acc, work, parallel)
    elif massive.shape[0] < SPLIT_FEW_N and not parallel:
        _gravity_split_few(x, xlo, m, G, soft2, massive, acc)
    elif parallel:
        _gravity_split_parallel(x, xlo, m, G, soft2, massive, acc, work)
    else:
        _gravity_split_serial(x, xlo, m, G, soft2, massive, acc, work)
