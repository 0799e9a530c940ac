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

from ._jit import kernel, parallel_kernel, prange
from .gravity import (
    CHUNK,
    PAIR_MIN_N,
    gravity,
    pack_massive,
)

__all__ = ["gravity_split", "sum_rows_split", "SPLIT_FEW_N"]

#: Below this many massive particles :func:`gravity_split` sums the pairs in one plain loop.
SPLIT_FEW_N = 16


@kernel
def sum_rows_split(xm, ym, zm, gmm, lxm, lym, lzm, soft2, xs, ys, zs, lxs, lys, lzs,
                   sx, sy, sz):
    """:func:`visviva.core.gravity.sum_rows` for positions given in two parts, ``x = hi + lo``.

    Parameters
    ----------
    xm, ym, zm, lxm, lym, lzm : ndarray of float64, shape (N_massive,)
        High and low parts of the positions of the massive particles, contiguous (length).
    gmm : ndarray of float64, shape (N_massive,)
        ``G m_j`` of the massive particles (length**3 / time**2).
    soft2 : float
        Square of the Plummer softening length (length**2); 0 for none.
    xs, ys, zs, lxs, lys, lzs : ndarray of float64, shape (n,)
        High and low parts of the positions of the particles ``i`` (length).
    sx, sy, sz : ndarray of float64, shape (n,)
        Overwritten with the accelerations (length / time**2).

    Notes
    -----
    The separation is ``d = (x_j - x_i) + (lo_j - lo_i)``: for two particles close to each other
    far from the origin, ``x_j - x_i`` is exact (Sterbenz's lemma) and the low parts restore the
    digits that rounding the positions to doubles would lose, so ``d`` is accurate to about one
    ulp of ``|d|`` instead of one ulp of ``|x|``. Each sum runs over ``j`` in order (the loop over
    ``i`` inside is vectorised without fast-math flags): the same bits on every CPU and in the
    interpreter, and the same as :func:`_gravity_split_few`'s plain loop.
    """
    n = xs.shape[0]  # loops from 0 over views: no negative-index wrap-around, so they vectorise
    for i in range(n):
        sx[i] = 0.0
        sy[i] = 0.0
        sz[i] = 0.0
    for b in range(xm.shape[0]):
        xb = xm[b]
        yb = ym[b]
        zb = zm[b]
        lxb = lxm[b]
        lyb = lym[b]
        lzb = lzm[b]
        gb = gmm[b]
        for i in range(n):
            dx = (xb - xs[i]) + (lxb - lxs[i])
            dy = (yb - ys[i]) + (lyb - lys[i])
            dz = (zb - zs[i]) + (lzb - lzs[i])
            r2 = dx * dx + dy * dy + dz * dz + soft2
            r2 += 1.0 if r2 == 0.0 else 0.0
            s = gb / (r2 * math.sqrt(r2))
            sx[i] += dx * s
            sy[i] += dy * s
            sz[i] += dz * s


@kernel
def _rows_split(lo, hi, x, xlo, nm, soft2, work, acc):
    # particles lo <= i < hi: positions into rows 7-9 and 13-15 of work, sums in rows 10-12
    for i in range(lo, hi):
        work[7, i] = x[i, 0]
        work[8, i] = x[i, 1]
        work[9, i] = x[i, 2]
        work[13, i] = xlo[i, 0]
        work[14, i] = xlo[i, 1]
        work[15, i] = xlo[i, 2]
    sum_rows_split(work[0, :nm], work[1, :nm], work[2, :nm], work[3, :nm], work[4, :nm],
                   work[5, :nm], work[6, :nm], soft2, work[7, lo:hi], work[8, lo:hi],
                   work[9, lo:hi], work[13, lo:hi], work[14, lo:hi], work[15, lo:hi],
                   work[10, lo:hi], work[11, lo:hi], work[12, lo:hi])
    for i in range(lo, hi):
        acc[i, 0] = work[10, i]
        acc[i, 1] = work[11, i]
        acc[i, 2] = work[12, i]


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
    _rows_split(0, x.shape[0], x, xlo, nm, soft2, work, acc)


@parallel_kernel
def _gravity_split_parallel(x, xlo, m, G, soft2, massive, acc, work):
    nm = _pack_split(x, xlo, m, G, massive, work)
    n = x.shape[0]
    for k in prange((n + CHUNK - 1) // CHUNK):
        lo = k * CHUNK
        _rows_split(lo, min(n, lo + CHUNK), x, xlo, nm, soft2, work, acc)


@kernel
def _gravity_split_few(x, xlo, m, G, soft2, massive, acc):
    # few massive particles: one plain loop over the pairs, no packing (the packed, vectorised
    # rows cost more than they save below SPLIT_FEW_N); each sum in the order of j, so the bits
    # are those of sum_rows_split (a skipped self term and a masked one give the same sum: a
    # sum that starts at +0.0 never becomes -0.0)
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
    work : ndarray of float64, shape (GWORK_ROWS, >= N)
        Scratch (see :data:`visviva.core.gravity.GWORK_ROWS`).

    Notes
    -----
    Separations are formed as ``(x_j - x_i) + (lo_j - lo_i)`` (see
    :func:`sum_rows_split`), so a tight pair far from the origin keeps its relative
    precision. Below :data:`SPLIT_FEW_N` massive particles one plain loop over the
    pairs (no packing); up to :data:`PAIR_MIN_N` the packed rows of :func:`sum_rows_split`
    (the same bits, each sum in the order of ``j``); from :data:`PAIR_MIN_N` massive particles on, the large-N
    kernel runs on the high parts alone (as :func:`gravity` does).
    """
    if parallel is None:  # FEW: the serial few-body paths alone (see gravity.gravity)
        if massive.shape[0] < SPLIT_FEW_N:
            _gravity_split_few(x, xlo, m, G, soft2, massive, acc)
        else:
            _gravity_split_serial(x, xlo, m, G, soft2, massive, acc, work)
    elif massive.shape[0] >= PAIR_MIN_N:
        gravity(x, m, G, soft2, massive, acc, work, parallel)
    elif massive.shape[0] < SPLIT_FEW_N:
        _gravity_split_few(x, xlo, m, G, soft2, massive, acc)
    elif parallel:
        _gravity_split_parallel(x, xlo, m, G, soft2, massive, acc, work)
    else:
        _gravity_split_serial(x, xlo, m, G, soft2, massive, acc, work)
