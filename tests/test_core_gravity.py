"""The large-N direct-summation kernel (each pair once, r**-3 without divide or square root):
accuracy against an extended-precision sum, the same bits for every thread count and for the
serial path, coincident particles, and the small-N path left unchanged below PAIR_MIN_N."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from visviva.core import gravity as g
from visviva.core import gravity_simd as gs

ULP = np.finfo(float).eps  # 2.2e-16


@numba.njit(cache=True)
def _inv_r3_array(r2, out):
    for k in range(r2.shape[0]):
        out[k] = g.inv_r3(r2[k])


def _cluster(n, seed, frac_test=0.2, coincident=0):
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, 3))
    m = rng.uniform(0.5, 1.5, size=n) / n
    m[rng.uniform(size=n) < frac_test] = 0.0  # test particles
    for k in range(coincident):  # exact copies of other particles' positions
        x[n - 1 - k] = x[k]
    return x, m


def _reference(x, m, soft2):
    """Accelerations in extended precision (80-bit long double) and sum_j |term_ij| per i."""
    xl = x.astype(np.longdouble)
    ml = m.astype(np.longdouble)
    acc = np.zeros(x.shape, np.longdouble)
    scale = np.zeros(x.shape[0], np.longdouble)
    for i in range(x.shape[0]):
        d = xl - xl[i]
        r2 = (d * d).sum(1) + soft2
        zero = r2 == 0
        r2[zero] = 1
        f = ml / (r2 * np.sqrt(r2))
        f[zero] = 0
        acc[i] = (d * f[:, None]).sum(0)
        scale[i] = (np.abs(d) * f[:, None]).sum()
    return acc.astype(float), scale.astype(float)


def _r2_samples(seed):
    # log-uniform over 200 decades, plus exact powers of 2 and 4 (the guess's worst cases
    # sit at mantissa boundaries) and their neighbours; a multiple of 8 long
    rng = np.random.default_rng(seed)
    r2 = np.concatenate([
        10.0 ** rng.uniform(-100, 100, 400_000),
        np.ldexp(1.0, np.arange(-300, 300)),
        np.nextafter(np.ldexp(1.0, np.arange(-300, 300)), 0),
        1.0 + rng.uniform(0, 3, 100_000),
    ])
    return np.ascontiguousarray(r2[: r2.shape[0] // 8 * 8])


def _max_rel_error_r3(r2, out):
    rl = r2.astype(np.longdouble)
    exact = 1 / (rl * np.sqrt(rl))
    return float(np.abs((out - exact) / exact).astype(float).max())


def test_inv_r3_within_one_ulp_over_the_whole_range():
    r2 = _r2_samples(0)
    out = np.empty_like(r2)
    _inv_r3_array(r2, out)
    err = _max_rel_error_r3(r2, out)
    # measured 3.3e-16 (1.5 eps); 1 / (r2 sqrt(r2)) in float64 itself: 2.7e-16
    assert err <= 2 * ULP, err


@pytest.mark.parametrize("soft", [0.0, 0.01])
def test_large_n_kernel_matches_extended_precision_sum(soft):
    n = 1200
    x, m = _cluster(n, seed=11, coincident=2 if soft == 0 else 0)
    assert g.massive_indices(m).shape[0] >= g.PAIR_MIN_N
    ref, scale = _reference(x, m, soft**2)
    a = np.empty((n, 3))
    g.gravity_parallel(x, m, 1.0, soft**2, g.massive_indices(m), a, np.empty((g.GWORK_ROWS, n)))
    assert np.isfinite(a).all()
    # error of each component relative to the sum of the magnitudes of its terms: the round-off
    # floor of any summation order (the small-N kernel: 3e-16 here)
    err = np.abs(a - ref).max(1) / scale
    # measured 2.3e-16 .. 3.1e-16; with numba's JIT off the vector loops' Python stand-ins
    # (core/gravity_simd.py) round the r**-3 step differently: 1.1e-15, still round-off
    floor = 2e-15 if numba.config.DISABLE_JIT else 1e-15
    assert err.max() <= floor, err.max()
    # and relative to |a| itself (cancellation makes this larger for a few particles)
    rel = np.linalg.norm(a - ref, axis=1) / np.linalg.norm(ref, axis=1)
    assert rel.max() <= 1e-13, rel.max()


@pytest.mark.parametrize("soft", [0.0, 0.01])
def test_large_n_kernel_same_bits_for_every_thread_count_and_serial(soft):
    n = 1500  # about 1,200 massive particles and 300 test particles
    x, m = _cluster(n, seed=5, coincident=3)
    massive = g.massive_indices(m)
    assert massive.shape[0] >= g.PAIR_MIN_N and massive.shape[0] < n
    ref = np.empty((n, 3))
    g.gravity_serial(x, m, 1.0, soft**2, massive, ref, np.empty((g.GWORK_ROWS, n)))
    assert np.isfinite(ref).all()
    old = numba.get_num_threads()
    try:
        for nt in sorted({1, 2, old}):
            if nt > numba.config.NUMBA_NUM_THREADS:
                continue
            numba.set_num_threads(nt)
            a = np.full((n, 3), np.nan)
            g.gravity_parallel(x, m, 1.0, soft**2, massive, a, np.empty((g.GWORK_ROWS, n)))
            np.testing.assert_array_equal(a, ref)
            b = np.full((n, 3), np.nan)
            g.gravity(x, m, 1.0, soft**2, massive, b, np.empty((g.GWORK_ROWS, n)), True)
            np.testing.assert_array_equal(b, ref)
    finally:
        numba.set_num_threads(old)


def test_large_n_kernel_conserves_momentum_and_coincident_pairs_pull_nothing():
    n = 600
    x, m = _cluster(n, seed=2, frac_test=0.0)
    x[1] = x[0]  # a coincident massive pair, no softening
    a = np.empty((n, 3))
    g.gravity_serial(x, m, 1.0, 0.0, g.massive_indices(m), a, np.empty((g.GWORK_ROWS, n)))
    assert np.isfinite(a).all()
    # each pair once: the momentum balance holds to the round-off of the final sums
    p = (m[:, None] * a).sum(0)
    assert np.abs(p).max() <= 1e-14 * np.abs(m[:, None] * a).sum()
    # the coincident pair feels the same (finite) pull from the rest
    np.testing.assert_allclose(a[0], a[1], rtol=1e-12)


def _strict_sum(x, m, G, soft2, massive):
    # each a_i summed over the massive j in ascending order, left to right (numpy across i)
    acc = np.zeros_like(x)
    for j in massive:
        d = x[j] - x
        r2 = (d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2] + soft2
        r2 = r2 + np.where(r2 == 0.0, 1.0, 0.0)
        s = (G * m[j]) / (r2 * np.sqrt(r2))
        acc += d * s[:, None]
    return acc


def test_small_n_path_is_the_strict_sum_below_pair_min_n():
    # below PAIR_MIN_N massive particles each acceleration is the strict left-to-right sum over
    # j (the same bits on every CPU, any vector width, and in the interpreter tier); serial and
    # parallel agree; at PAIR_MIN_N it switches to the large-N kernel (about one ulp per term)
    for nm, same in ((3, True), (9, True), (16, True), (g.PAIR_MIN_N - 1, True),
                     (g.PAIR_MIN_N, False)):
        n = nm + 40
        rng = np.random.default_rng(nm)
        x = rng.normal(size=(n, 3))
        m = np.zeros(n)
        m[rng.permutation(n)[:nm]] = rng.uniform(size=nm)
        massive = g.massive_indices(m)
        ref = _strict_sum(x, m, 1.3, 1e-6, massive)
        a = np.empty((n, 3))
        g.gravity_serial(x, m, 1.3, 1e-6, massive, a, np.empty((g.GWORK_ROWS, n)))
        b = np.empty((n, 3))
        g.gravity_parallel(x, m, 1.3, 1e-6, massive, b, np.empty((g.GWORK_ROWS, n)))
        np.testing.assert_array_equal(a, b)
        if same:
            np.testing.assert_array_equal(a, ref)
        else:
            np.testing.assert_allclose(a, ref, rtol=1e-12, atol=1e-14 * np.abs(ref).max())


@pytest.mark.parametrize("scale", [1e-30, 1e-3, 1.5e8, 1e30])
def test_large_n_kernel_at_any_length_scale(scale):
    # the bit-level first guess and the far-away padding dummies work in any units: the large-N
    # kernel agrees with the small-N row kernel at every length scale
    n = 400
    x, m = _cluster(n, seed=7, coincident=1)
    x = x * scale
    soft2 = (1e-3 * scale) ** 2
    massive = g.massive_indices(m)
    for s2 in (0.0, soft2):
        rows = _strict_sum(x, m, 1.0, s2, massive)
        a = np.empty((n, 3))
        g.gravity_parallel(x, m, 1.0, s2, massive, a, np.empty((g.GWORK_ROWS, n)))
        assert np.isfinite(a).all()
        np.testing.assert_allclose(a, rows, rtol=0, atol=1e-13 * np.abs(rows).max())


def test_large_n_kernel_with_a_subset_of_the_massive_particles():
    # callers may pass a subset of the massive indices (WHFast's democratic heliocentric kick
    # passes massive[1:]): the particles left out feel the subset and pull on nothing, as in the
    # small-N kernel
    n = 600
    x, m = _cluster(n, seed=3, frac_test=0.1)
    massive = g.massive_indices(m)[1:]
    rows = _strict_sum(x, m, 1.0, 0.0, massive)
    a = np.empty((n, 3))
    g.gravity(x, m, 1.0, 0.0, massive, a, np.empty((g.GWORK_ROWS, n)), True)
    np.testing.assert_allclose(a, rows, rtol=0, atol=1e-13 * np.abs(rows).max())


# ---- the explicit-vector loops (visviva.core.gravity_simd) --------------------------------------
def _seeds():
    # the loops as compiled here (vrsqrt14pd with AVX-512), and the bit-level guess of CPUs
    # without it, compiled here too by patching the feature test (the code LLVM gets is the same)
    return [True, False] if not numba.config.DISABLE_JIT and gs.has_rsqrt14() else [False]


def _compiled(monkeypatch, rsqrt14):
    # fresh (uncached) kernels around the intrinsics, generated with the chosen first guess
    monkeypatch.setattr(gs, "has_rsqrt14", lambda context=None: rsqrt14)

    @numba.njit(cache=False)
    def inv_r3(r2, out):
        for k in range(0, r2.shape[0], 8):
            gs.inv_r3_x8(r2, out, k)

    @numba.njit(cache=False)
    def rows(i, p, lo, hi, soft2, b):
        return gs.pair_row(p[0, i], p[1, i], p[2, i], p[3, i], p, lo, hi, soft2, b)

    @numba.njit(cache=False)
    def head(i, p, lo, soft2, b):
        return gs.pair_row_head(p[0, i], p[1, i], p[2, i], p[3, i], i, p, lo, lo + 16, soft2, b)

    @numba.njit(cache=False)
    def one_sided(xi, p, nm, soft2):
        return gs.one_sided_row(xi[0], xi[1], xi[2], p, nm, soft2)

    return inv_r3, rows, head, one_sided


_JIT_ONLY = pytest.mark.skipif(numba.config.DISABLE_JIT, reason="LLVM intrinsics need numba's compiler")


@_JIT_ONLY
@pytest.mark.parametrize("rsqrt14", _seeds())
def test_vector_inv_r3_within_one_ulp_over_the_whole_range(monkeypatch, rsqrt14):
    r2 = _r2_samples(1)
    out = np.full_like(r2, np.nan)
    _compiled(monkeypatch, rsqrt14)[0](r2, out)
    err = _max_rel_error_r3(r2, out)
    # measured 1.1e-16 (vrsqrt14pd, one folded step) and 2.7e-16 (bit-level guess, two steps);
    # 1 / (r2 sqrt(r2)) in float64 itself: 2.6e-16
    assert err <= (1 if rsqrt14 else 2) * ULP, err


@_JIT_ONLY
@pytest.mark.parametrize("rsqrt14", _seeds())
@pytest.mark.parametrize("soft", [0.0, 0.01])
def test_vector_loops_match_their_scalar_references(monkeypatch, rsqrt14, soft):
    # each explicit-vector loop against the scalar loop it replaces (visviva.core.gravity):
    # the same sums to round-off (another summation order, r**-3 within an ulp), the masked
    # head counts the j > i only, and coincident particles pull nothing without softening
    _, rows, head, one_sided = _compiled(monkeypatch, rsqrt14)
    n = 301
    x, m = _cluster(n, seed=9, frac_test=0.0, coincident=2)
    p = g._pad_massive(x, m, 1.0, np.arange(n))
    s2 = soft**2

    def close(a, b, scale):
        np.testing.assert_allclose(a, b, rtol=0, atol=2e-15 * scale)

    for i in (0, 5, 150, n - 1):
        lo = i // 8 * 8
        # the head: columns lo .. lo + 16, only j > i
        b1, b2 = (g._aligned_rows(3, p.shape[1]) for _ in range(2))
        b1[:], b2[:] = 0.0, 0.0
        a1 = head(i, p, lo, s2, b1)
        a2 = g.pair_row_head(p[0, i], p[1, i], p[2, i], p[3, i], i, p, lo, lo + 16, s2, b2)
        scale = np.abs(a2).sum() + np.abs(b2).max() + 1e-300
        close(a1, a2, scale)
        close(b1, b2, scale)
        assert not b1[:, : i + 1].any()  # j <= i untouched (the particle itself included)
        # a row from the next multiple of 8 on, to the padded end
        j0 = lo + 16
        j1 = j0 + (n - j0 + g.PAIR_PAD - 1) // g.PAIR_PAD * g.PAIR_PAD
        if j0 < n:
            b1[:], b2[:] = 0.0, 0.0
            a1 = rows(i, p, j0, j1, s2, b1)
            a2 = g.pair_row(p[0, i], p[1, i], p[2, i], p[3, i], p, j0, j1, s2, b2)
            scale = np.abs(b2).max() * n
            close(a1, a2, scale)
            close(b1, b2, scale)
        # a test particle at the position of particle i (coincident: contributes 0 unsoftened)
        t1 = one_sided(np.ascontiguousarray(x[i]), p, n, s2)
        t2 = g.row_acceleration_fast(x[i, 0], x[i, 1], x[i, 2], p, n, s2)
        assert np.isfinite(t1).all()
        close(t1, t2, np.abs(t2).sum() * 10)
