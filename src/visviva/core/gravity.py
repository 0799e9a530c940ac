"""Newtonian N-body gravity by direct summation: compiled kernels.

The acceleration of particle ``i`` is

    a_i = sum_{j massive, j != i} G m_j (x_j - x_i) / (|x_j - x_i|**2 + eps**2)**(3/2)

where ``eps`` is the (optional) Plummer softening length. Test particles (``m = 0``) feel the
massive ones and pull on nothing, so a step costs O(N * N_massive).

Layout and determinism
----------------------
The massive particles are first copied into contiguous structure-of-arrays rows ``x_j, y_j, z_j,
G m_j`` of the scratch ``work`` (:data:`GWORK_ROWS` rows of length N), the positions of the
particles ``i`` into three more. :func:`sum_rows` loops over ``j`` outside and over ``i`` inside,
branch-free (the self term and coincident particles without softening are masked
arithmetically: ``r2 == 0`` is replaced by 1 and the term is ``0 * ...``): each ``a_i`` is the
strict left-to-right sum over ``j``, and LLVM vectorises the inner loop across particles without
any fast-math flag. Every path (serial, multi-threaded with ``prange`` over chunks of ``i``, and
the interpreter of :mod:`visviva.core.tier`) runs the same loop, so they return the same bits
whatever the number of threads or the width of the CPU's vectors.

Large N: each pair once, fixed work items
-----------------------------------------
From :data:`PAIR_MIN_N` massive particles on, both paths switch to a second kernel, about 2.1x
faster per interaction on one thread (0.42 against 0.87 ns at N = 4,000 on a 2-core Zen 4 EPYC):

* each massive pair is evaluated once (Newton's third law: ``a_i += G m_j d r**-3`` and
  ``a_j -= G m_i d r**-3``), which halves the work;
* ``r**-3`` by multiply-adds, no divide or square root: on AVX-512 CPUs from the ``vrsqrt14pd``
  estimate and one fourth-order step folded into the cube (max relative error 1.1e-16, tested),
  elsewhere from the bit-level guess and two third-order steps of :func:`inv_r3` (2.7e-16; the
  correctly rounded ``1 / (r2 sqrt(r2))`` has 2.6e-16);
* the three inner loops are explicit 8-double vectors in LLVM IR
  (:mod:`visviva.core.gravity_simd`; 1.3-1.8x faster than the auto-vectorised scalar loops
  :func:`pair_row`, :func:`pair_row_head` and :func:`row_acceleration_fast`, kept as the
  references the tests compare with and as what runs under ``NUMBA_DISABLE_JIT``), over a
  private copy of the massive particles as rows ``x, y, z, G m`` starting on 64-byte boundaries;
  every row of pairs starts on a multiple of 8 columns and is padded to a multiple of 16 with
  massless dummies far from every particle (aligned loads, no remainder loop).

Determinism: the triangle of pairs (rows ``i``, columns ``j > i``) is cut into ``2 *``
:data:`PAIR_ITEMS` blocks of rows; work item ``k`` takes blocks ``k`` and ``nb - 1 - k`` (equal work
in total). The number of items is fixed in advance (not the thread count); each item accumulates
into its own buffer; the buffers are summed per particle in item order. Threads take the items
dynamically (an atomic counter: a thread that another process holds up takes fewer) and the one
that finishes the last item sums the buffers (one parallel region per call): who ran what never
changes the bits, so they do not depend on the number of threads (serial and parallel agree;
tested). Test particles use a one-sided row with the same ``r**-3``. The large-N bits differ from
the small-N ones (summation order, ``r**-3`` within an ulp) and between CPUs with and without
AVX-512; systems below :data:`PAIR_MIN_N` massive particles (planetary systems compared with
REBOUND at tight tolerances) keep the small-N kernel, bit for bit. Coordinates beyond about
``1e100`` or separations below ``1e-100`` may overflow differently in the two paths; a coincident
pair without softening contributes exactly 0 in both.

All inputs are plain float64 arrays in any consistent units (``G`` in the same units).

References
----------
Aarseth, S. J., *Gravitational N-Body Simulations*, Cambridge University Press 2003, ch. 1-2.
Lomont, C., *Fast inverse square root*, Purdue University tech. report, 2003 (the magic constant).
Householder, A. S., *The Numerical Treatment of a Single Nonlinear Equation*, McGraw-Hill 1970
(higher-order iterations).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from . import gravity_simd
from ._intrinsics import float_bits as _bits
from ._intrinsics import float_from_bits as _from_bits
from ._jit import inline_kernel, kernel, parallel_kernel, prange, prefer_wide_vectors, simd_kernel

__all__ = [
    "sum_rows",
    "pack_massive",
    "GWORK_ROWS",
    "gravity_serial",
    "gravity_parallel",
    "gravity",
    "gravity_few",
    "FEW",
    "energy",
    "kinetic_energy",
    "potential_energy",
    "no_force",
    "PARALLEL_MIN_N",
    "PAIR_MIN_N",
    "inv_r3",
]

#: From this many particles on, the simulation uses the multi-threaded kernel by default.
PARALLEL_MIN_N = 512
#: Rows of the gravity scratch ``work`` (shape ``(GWORK_ROWS, N)``): 0-3 the massive particles as
#: ``x, y, z, G m``; 4-6 their low parts (:mod:`visviva.core.gravity_split`); 7-9 the positions of
#: the particles ``i``; 10-12 their sums; 13-15 the low parts of their positions (split).
GWORK_ROWS = 16
#: Below this many massive particles the few-body gravity is one plain loop over the pairs (no
#: packing into ``work``); the same bits as the packed rows.
PLAIN_N = 8
#: Particles ``i`` per work item of the multi-threaded kernel.
CHUNK = 64
#: From this many massive particles on, gravity evaluates each pair once (large-N kernel).
PAIR_MIN_N = 256
#: Work items of the large-N kernel: fixed, so that the bits do not depend on the thread count.
PAIR_ITEMS = 16
#: Columns ``j`` per tile of the large-N kernel (seven arrays of this length stay in cache).
PAIR_COL_BLOCK = 4096
#: The large-N kernel's rows are padded to a multiple of this many columns (8-double vectors,
#: unrolled twice by LLVM) with massless far-away dummies, so no scalar remainder loop runs.
PAIR_PAD = 16
#: The ``parallel`` argument of :func:`gravity` and
#: :func:`visviva.core.gravity_split.gravity_split` that compiles the few-body serial path alone
#: (a type, not a value: ``None`` makes numba drop the other paths when it compiles the caller).
FEW = None
#: Bit-level first guess of ``1/sqrt(x)`` for doubles (Lomont 2003).
_RSQRT_MAGIC = gravity_simd.RSQRT_MAGIC


@kernel
def no_force(t, x, v, m, params, acc):
    """The additional force that adds nothing (the default user force)."""
    return


@kernel
def sum_rows(xm, ym, zm, gmm, soft2, xs, ys, zs, sx, sy, sz):
    """Accelerations of the particles ``lo <= i < hi`` from all massive ones, strict order.

    Parameters
    ----------
    xm, ym, zm : ndarray of float64, shape (N_massive,)
        Positions of the massive particles, contiguous (length).
    gmm : ndarray of float64, shape (N_massive,)
        ``G m_j`` of the massive particles (length**3 / time**2).
    soft2 : float
        Square of the Plummer softening length (length**2); 0 for none.
    xs, ys, zs : ndarray of float64, shape (n,)
        Positions of the particles ``i``, contiguous (length).
    sx, sy, sz : ndarray of float64, shape (n,)
        Overwritten with ``sum_j G m_j d / (|d|**2 + eps**2)**(3/2)``,
        ``d = x_j - x_i`` (length / time**2).

    Notes
    -----
    The loop over ``j`` is the outer one: each ``a_i`` is summed in the order of ``j``, exactly
    as the plain left-to-right loop would, and the inner loop over ``i`` has no reduction, so
    LLVM vectorises it without reassociating anything (IEEE semantics, no fast-math flags).
    The bits are therefore those of the strict sum on every CPU (any vector width) and in the
    interpreter (:mod:`visviva.core.tier`), and as fast as the reassociated row sum it replaced
    (2.4 against 3.2 ns per interaction for 9 bodies, 1.1 against 1.0 at 100, on one thread).
    Branch-free: a zero ``r2`` (the particle itself, or a coincident one without softening,
    where ``d = 0`` exactly) is replaced by 1, so its term is exactly ``0``.
    """
    n = xs.shape[0]  # loops from 0 over views: no negative-index wrap-around, so they vectorise
    for i in range(n):
        sx[i] = 0.0
        sy[i] = 0.0
        sz[i] = 0.0
    nm = xm.shape[0]
    for b in range(0, nm - 1, 2):  # two j per pass over i: half the loads/stores of the sums
        xb, yb, zb, gb = xm[b], ym[b], zm[b], gmm[b]
        xc, yc, zc, gc = xm[b + 1], ym[b + 1], zm[b + 1], gmm[b + 1]
        for i in range(n):
            dx = xb - xs[i]
            dy = yb - ys[i]
            dz = zb - zs[i]
            r2 = dx * dx + dy * dy + dz * dz + soft2
            r2 += 1.0 if r2 == 0.0 else 0.0
            s = gb / (r2 * math.sqrt(r2))
            ex = xc - xs[i]
            ey = yc - ys[i]
            ez = zc - zs[i]
            q2 = ex * ex + ey * ey + ez * ez + soft2
            q2 += 1.0 if q2 == 0.0 else 0.0
            q = gc / (q2 * math.sqrt(q2))
            sx[i] = (sx[i] + dx * s) + ex * q  # the order of j: the same bits as one at a time
            sy[i] = (sy[i] + dy * s) + ey * q
            sz[i] = (sz[i] + dz * s) + ez * q
    if nm % 2 == 1:
        b = nm - 1
        xb, yb, zb, gb = xm[b], ym[b], zm[b], gmm[b]
        for i in range(n):
            dx = xb - xs[i]
            dy = yb - ys[i]
            dz = zb - zs[i]
            r2 = dx * dx + dy * dy + dz * dz + soft2
            r2 += 1.0 if r2 == 0.0 else 0.0
            s = gb / (r2 * math.sqrt(r2))
            sx[i] += dx * s
            sy[i] += dy * s
            sz[i] += dz * s


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
def _plain_rows(x, m, G, soft2, massive, acc):
    # few massive particles: one plain loop over the pairs, no packing (cheaper below PLAIN_N);
    # each sum in the order of j, so the bits are those of sum_rows (a skipped self term and a
    # masked one give the same sum: a sum that starts at +0.0 never becomes -0.0)
    for i in range(x.shape[0]):
        ax = 0.0
        ay = 0.0
        az = 0.0
        for b in range(massive.shape[0]):
            j = massive[b]
            dx = x[j, 0] - x[i, 0]
            dy = x[j, 1] - x[i, 1]
            dz = x[j, 2] - x[i, 2]
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
def _rows(lo, hi, x, nm, soft2, work, acc):
    # the accelerations of particles lo <= i < hi (rows 7-12 of work at lo:hi, see GWORK_ROWS)
    for i in range(lo, hi):
        work[7, i] = x[i, 0]
        work[8, i] = x[i, 1]
        work[9, i] = x[i, 2]
    sum_rows(work[0, :nm], work[1, :nm], work[2, :nm], work[3, :nm], soft2, work[7, lo:hi],
             work[8, lo:hi], work[9, lo:hi], work[10, lo:hi], work[11, lo:hi], work[12, lo:hi])
    for i in range(lo, hi):
        acc[i, 0] = work[10, i]
        acc[i, 1] = work[11, i]
        acc[i, 2] = work[12, i]


# ---- large-N kernel: each pair once, r**-3 without divide or square root -----------------------
@inline_kernel
def inv_r3(r2):
    """``r2**-1.5`` with multiply-adds only (no divide, no square root), within about one ulp.

    Parameters
    ----------
    r2 : float
        Squared distance, positive and normal (length**2).

    Returns
    -------
    float
        ``1 / (r2 sqrt(r2))`` (length**-3).

    Notes
    -----
    A first guess ``y0`` of ``1/sqrt(r2)`` from the bits (``0x5FE6EB50C7B537A9 - bits(r2) / 2``,
    Lomont 2003; relative error below 3.5 %), then with ``e = 1 - r2 y**2`` (so that
    ``1/sqrt(r2) = y (1 - e)**-1/2``) one third-order step
    ``y1 = y0 (1 + e/2 + 3 e**2/8 + 5 e**3/16)`` (error ~ 35/128 e**4 < 1e-5), and a final step
    folded into the cube, ``r2**-1.5 = y1**3 (1 + 3e/2 + 15 e**2/8 + 35 e**3/16)`` (truncation
    < 1e-19). Vectorises (integer and float multiply-adds only). Measured max relative error
    against the exact value: 3.3e-16 (``1 / (r2 sqrt(r2))`` in float64: 2.7e-16).
    """
    y = _from_bits(_RSQRT_MAGIC - (_bits(r2) >> 1))
    e = 1.0 - r2 * (y * y)
    y = y + y * (e * (0.5 + e * (0.375 + e * 0.3125)))
    y2 = y * y
    e = 1.0 - r2 * y2
    y3 = y2 * y
    return y3 + y3 * (e * (1.5 + e * (1.875 + e * 2.1875)))


@simd_kernel
def pair_row(xi, yi, zi, gmi, p, lo, hi, soft2, b):
    """Pairs ``(i, j)`` for massive ``j`` in ``[lo, hi)`` (``i`` not in it): returns the sum
    ``sum_j G m_j d / r**3`` on ``i`` (``d = x_j - x_i``, length / time**2) and subtracts the
    reaction ``G m_i d / r**3`` from ``b[:, j]``.

    ``p`` holds the massive particles as rows ``x, y, z, G m`` (length; length**3 / time**2),
    ``soft2`` the squared softening length (length**2). With softening ``r2 >= soft2 > 0``;
    without, a coincident pair is given ``r2 = 1`` so its term is exactly 0. The scalar
    reference of :func:`visviva.core.gravity_simd.pair_row`, which the compiled kernel runs (this
    loop, auto-vectorised with 512-bit vectors, was the kernel before). The unsigned index
    avoids numba's negative-index wraparound (which stops vectorisation); two 2-d arguments
    rather than seven 1-d ones let numba prune their reference counting (~75 ns a call).
    """
    prefer_wide_vectors()
    ax = 0.0
    ay = 0.0
    az = 0.0
    if soft2 > 0.0:
        for j in range(np.uint64(lo), np.uint64(hi)):
            dx = p[0, j] - xi
            dy = p[1, j] - yi
            dz = p[2, j] - zi
            r3 = inv_r3(dx * dx + dy * dy + dz * dz + soft2)
            si = p[3, j] * r3
            sj = gmi * r3
            ax += dx * si
            ay += dy * si
            az += dz * si
            b[0, j] -= dx * sj
            b[1, j] -= dy * sj
            b[2, j] -= dz * sj
    else:
        for j in range(np.uint64(lo), np.uint64(hi)):
            dx = p[0, j] - xi
            dy = p[1, j] - yi
            dz = p[2, j] - zi
            r2 = dx * dx + dy * dy + dz * dz
            if r2 == 0.0:
                r2 = 1.0
            r3 = inv_r3(r2)
            si = p[3, j] * r3
            sj = gmi * r3
            ax += dx * si
            ay += dy * si
            az += dz * si
            b[0, j] -= dx * sj
            b[1, j] -= dy * sj
            b[2, j] -= dz * sj
    return ax, ay, az


@simd_kernel
def pair_row_head(xi, yi, zi, gmi, i, p, lo, hi, soft2, b):
    """:func:`pair_row` for the columns ``j`` in ``[lo, hi)`` with ``j > i`` only: the pairs of
    row ``i`` before its aligned main part (``lo`` the multiple of 8 at or below ``i``,
    ``hi = lo + 16``).

    Two 8-wide vector steps instead of a scalar loop over the ragged start: the terms with
    ``j <= i`` (the particle itself included: ``r2 = 1`` if zero) are multiplied by 0. (``hi`` is
    an argument: LLVM would unroll a loop of constant length 16 fully instead of vectorising
    it.) Returns the sum on ``i``. The scalar reference of
    :func:`visviva.core.gravity_simd.pair_row_head`.
    """
    prefer_wide_vectors()
    ax = 0.0
    ay = 0.0
    az = 0.0
    for j in range(np.uint64(lo), np.uint64(hi)):
        dx = p[0, j] - xi
        dy = p[1, j] - yi
        dz = p[2, j] - zi
        r2 = dx * dx + dy * dy + dz * dz + soft2
        if r2 == 0.0:
            r2 = 1.0
        w = 1.0 if j > i else 0.0
        r3 = inv_r3(r2) * w
        si = p[3, j] * r3
        sj = gmi * r3
        ax += dx * si
        ay += dy * si
        az += dz * si
        b[0, j] -= dx * sj
        b[1, j] -= dy * sj
        b[2, j] -= dz * sj
    return ax, ay, az


@simd_kernel
def row_acceleration_fast(xi, yi, zi, p, nm, soft2):
    """:func:`sum_rows` for one particle over the first ``nm`` columns of ``p`` (rows ``x, y, z, G m``)
    with ``r**-3`` from :func:`inv_r3` and wide vectors (large-N kernel, for test particles);
    the same result to about one ulp per term. The scalar reference of
    :func:`visviva.core.gravity_simd.one_sided_row`."""
    prefer_wide_vectors()
    ax = 0.0
    ay = 0.0
    az = 0.0
    for j in range(np.uint64(nm)):
        dx = p[0, j] - xi
        dy = p[1, j] - yi
        dz = p[2, j] - zi
        r2 = dx * dx + dy * dy + dz * dz + soft2
        if r2 == 0.0:
            r2 = 1.0
        s = p[3, j] * inv_r3(r2)
        ax += dx * s
        ay += dy * s
        az += dz * s
    return ax, ay, az


if numba.config.DISABLE_JIT:  # pure Python: the scalar references above
    _row, _head, _one_sided = pair_row, pair_row_head, row_acceleration_fast
    _ticket = gravity_simd.ticket_py
else:  # the same loops written as explicit 8-double vectors (visviva.core.gravity_simd)
    _row, _head, _one_sided = (gravity_simd.pair_row, gravity_simd.pair_row_head,
                               gravity_simd.one_sided_row)
    _ticket = gravity_simd.ticket


@kernel
def _aligned_rows(k, n):
    # an uninitialised (k, n) array whose rows start on 64-byte boundaries when n is a multiple of 8
    # (a 512-bit load that straddles two cache lines costs about 20 % here)
    raw = np.empty(k * n + 8)
    off = (8 - (raw.ctypes.data // 8) % 8) % 8
    return raw[off:off + k * n].reshape((k, n))


@kernel
def _pad_massive(x, m, G, massive):
    # the massive particles as rows x, y, z, G m, then massless dummies at (D, D, D),
    # D = 2 max|x| + 1, up to a multiple of PAIR_PAD with at least PAIR_PAD of them: every row
    # can then end on a multiple of PAIR_PAD columns past its aligned start (and the 16-column
    # head of the last rows stays inside). The dummies are at
    # least 1 away from every particle in each coordinate, so their r**-3 stays finite and their
    # terms on the real particles are exactly 0 (their own accumulators are ignored).
    nm = massive.shape[0]
    p = _aligned_rows(4, (nm + 2 * PAIR_PAD - 1) // PAIR_PAD * PAIR_PAD)
    big = 0.0
    for b in range(nm):
        j = massive[b]
        p[0, b] = x[j, 0]
        p[1, b] = x[j, 1]
        p[2, b] = x[j, 2]
        p[3, b] = G * m[j]
        big = max(big, abs(x[j, 0]), abs(x[j, 1]), abs(x[j, 2]))
    for b in range(nm, p.shape[1]):
        p[0, b] = 2.0 * big + 1.0
        p[1, b] = 2.0 * big + 1.0
        p[2, b] = 2.0 * big + 1.0
        p[3, b] = 0.0
    return p


@kernel
def _pair_block(lo, hi, nm, p, soft2, b):
    # the pairs (i, j > i) of the rows lo <= i < hi. Row i, with s_i the multiple of 8 at or
    # below i: first the j < s_i + 16 (one masked 16-wide step), then from s_i + 16 on (64-byte
    # aligned loads) in tiles of PAIR_COL_BLOCK columns, the last one padded to a multiple of
    # PAIR_PAD (dummies)
    for i in range(lo, hi):
        s = i // 8 * 8
        ax, ay, az = _head(p[0, i], p[1, i], p[2, i], p[3, i], i, p, s, s + 16, soft2, b)
        b[0, i] += ax
        b[1, i] += ay
        b[2, i] += az
    for t in range(0, nm - (lo // 8 * 8 + 16), PAIR_COL_BLOCK):
        for i in range(lo, hi):
            j0 = i // 8 * 8 + 16 + t
            if j0 >= nm:
                break
            j1 = j0 + PAIR_COL_BLOCK
            if j1 > nm:
                j1 = j0 + (nm - j0 + PAIR_PAD - 1) // PAIR_PAD * PAIR_PAD
            ax, ay, az = _row(p[0, i], p[1, i], p[2, i], p[3, i], p, j0, j1, soft2, b)
            b[0, i] += ax
            b[1, i] += ay
            b[2, i] += az


@kernel
def _pair_item(k, nm, p, soft2, buf):
    # work item k of PAIR_ITEMS: zero its buffer, then the row blocks k and nb - 1 - k of the
    # nb <= 2 PAIR_ITEMS blocks (together about 1 / PAIR_ITEMS of the pairs); p from _pad_massive
    b = buf[k]
    b[:, :] = 0.0
    rows = (nm + 2 * PAIR_ITEMS - 1) // (2 * PAIR_ITEMS)
    nb = (nm + rows - 1) // rows
    q = nb - 1 - k
    if k <= q:
        _pair_block(k * rows, min(nm, (k + 1) * rows), nm, p, soft2, b)
    if k < q:
        _pair_block(q * rows, min(nm, (q + 1) * rows), nm, p, soft2, b)


@kernel
def _pair_reduce(nm, buf, massive, acc):
    # acc of the massive particles: the item buffers summed in item order, into item 0's buffer
    # (items outer, particles inner: the inner loop vectorises, each sum keeps the item order)
    for k in range(1, buf.shape[0]):
        for c in range(3):
            for b in range(nm):
                buf[0, c, b] += buf[k, c, b]
    for b in range(nm):
        i = massive[b]
        acc[i, 0] = buf[0, 0, b]
        acc[i, 1] = buf[0, 1, b]
        acc[i, 2] = buf[0, 2, b]


@kernel
def _test_indices(n, massive):
    # the particles not in massive (ascending), i.e. the test particles
    tests = np.empty(n - massive.shape[0], dtype=np.int64)
    b = 0
    t = 0
    for i in range(n):
        if b < massive.shape[0] and massive[b] == i:
            b += 1
        else:
            tests[t] = i
            t += 1
    return tests


@kernel
def _test_rows(lo, hi, tests, x, p, nm, soft2, acc):
    # the test particles tests[lo:hi], one-sided rows over the massive ones
    for t in range(lo, hi):
        i = tests[t]
        ax, ay, az = _one_sided(x[i, 0], x[i, 1], x[i, 2], p, nm, soft2)
        acc[i, 0] = ax
        acc[i, 1] = ay
        acc[i, 2] = az


@kernel
def _gravity_pairs_serial(x, m, G, soft2, massive, acc):
    # the large-N kernel on one thread: the same items, in the same order, as the parallel one
    nm = massive.shape[0]
    p = _pad_massive(x, m, G, massive)
    buf = _aligned_rows(3 * PAIR_ITEMS, p.shape[1]).reshape((PAIR_ITEMS, 3, p.shape[1]))
    for k in range(PAIR_ITEMS):
        _pair_item(k, nm, p, soft2, buf)
    _pair_reduce(nm, buf, massive, acc)
    tests = _test_indices(x.shape[0], massive)
    _test_rows(0, tests.shape[0], tests, x, p, nm, soft2, acc)


@parallel_kernel
def _gravity_pairs_parallel(x, m, G, soft2, massive, acc):
    # the large-N kernel: work items over threads, then the sums and the test particles
    nm = massive.shape[0]
    p = _pad_massive(x, m, G, massive)
    buf = _aligned_rows(3 * PAIR_ITEMS, p.shape[1]).reshape((PAIR_ITEMS, 3, p.shape[1]))
    # items are shared dynamically: the first iteration each thread runs takes the next item
    # until none is left (the others find none), so a thread that another process holds up
    # takes fewer (a static split would wait for it); the thread that finishes the last item
    # sums the buffers (no second parallel region to wait for). The bits do not depend on who
    # ran what.
    tickets = np.zeros(2, dtype=np.int64)  # next item, items done
    for _ in prange(PAIR_ITEMS):
        k = _ticket(tickets, 0)
        while k < PAIR_ITEMS:
            _pair_item(k, nm, p, soft2, buf)
            if _ticket(tickets, 1) == PAIR_ITEMS - 1:
                _pair_reduce(nm, buf, massive, acc)
            k = _ticket(tickets, 0)
    if x.shape[0] > nm:  # test particles (no parallel region when there are none)
        tests = _test_indices(x.shape[0], massive)
        nt = tests.shape[0]
        for c in prange((nt + CHUNK - 1) // CHUNK):
            _test_rows(c * CHUNK, min(nt, (c + 1) * CHUNK), tests, x, p, nm, soft2, acc)


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
    work : ndarray of float64, shape (GWORK_ROWS, >= N)
        Scratch (the particles as structure of arrays, see :data:`GWORK_ROWS`).

    Notes
    -----
    Below :data:`PAIR_MIN_N` massive particles, :func:`sum_rows` over all particles; from
    there on, the large-N kernel (each pair once, see the module docstring), which allocates
    ``(3 PAIR_ITEMS + 4) (N_massive + 16..31)`` doubles of scratch per call (``work`` is not
    used).
    """
    if massive.shape[0] >= PAIR_MIN_N:
        _gravity_pairs_serial(x, m, G, soft2, massive, acc)
        return
    gravity_few(x, m, G, soft2, massive, acc, work)


@kernel
def gravity_few(x, m, G, soft2, massive, acc, work):
    """:func:`gravity_serial` below :data:`PAIR_MIN_N` massive particles (the same bits): one
    :func:`sum_rows` over all particles, on one thread. The only path compiled into the
    integrators' few-body kernels (see :func:`gravity`)."""
    if massive.shape[0] < PLAIN_N:
        _plain_rows(x, m, G, soft2, massive, acc)
        return
    nm = pack_massive(x, m, G, massive, work)
    _rows(0, x.shape[0], x, nm, soft2, work, acc)


@parallel_kernel
def gravity_parallel(x, m, G, soft2, massive, acc, work):
    """:func:`gravity_serial` with chunks of :data:`CHUNK` particles ``i`` spread over threads.

    Same arguments and the same bits as :func:`gravity_serial`, for any number of threads: each
    chunk is summed by the same :func:`sum_rows`. From :data:`PAIR_MIN_N` massive particles
    on, the :data:`PAIR_ITEMS` fixed work items of the large-N kernel are spread over threads
    instead (same bits as its serial run).
    """
    if massive.shape[0] >= PAIR_MIN_N:
        _gravity_pairs_parallel(x, m, G, soft2, massive, acc)
        return
    nm = pack_massive(x, m, G, massive, work)
    n = x.shape[0]
    for k in prange((n + CHUNK - 1) // CHUNK):
        lo = k * CHUNK
        _rows(lo, min(n, lo + CHUNK), x, nm, soft2, work, acc)


@kernel
def gravity(x, m, G, soft2, massive, acc, work, parallel):
    """Dispatch: :func:`gravity_parallel` when ``parallel``, else :func:`gravity_serial`
    (same bits).

    ``parallel=None`` (the integrators' few-body kernels, :data:`FEW`) compiles
    :func:`gravity_few` alone: numba removes the other branch when it types the call, so no
    ``prange`` region and no large-N kernel is compiled. Valid only on one thread below
    :data:`PAIR_MIN_N` massive particles, where it gives the same bits as the others.
    """
    if parallel is None:
        gravity_few(x, m, G, soft2, massive, acc, work)
    elif parallel:
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
