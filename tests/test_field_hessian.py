"""The spherical-harmonic Hessian kernel (core/force_partials.py) against the term-by-term
form it replaced: the same additions in the same order, so the same bits."""

import numba
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import visviva as vv
from visviva.core import force_block as fb
from visviva.core.force_partials import _add_harmonics_gradient
from visviva.core.geodetic import body_fixed_matrix
from visviva.core.perturbations import FORCE_SIZE, cunningham_vw


@numba.njit(cache=False)
def _derive_old(axis, n, m, a, b, ks, cvs, cws):
    # the earlier kernel's derivative rule, writing its terms into small arrays
    if axis == 2:
        g = -(n - m + 1.0)
        ks[0] = m
        cvs[0] = g * a
        cws[0] = g * b
        return 1
    f = (n - m + 2.0) * (n - m + 1.0)
    ks[0] = m + 1
    if axis == 0:
        cvs[0] = -0.5 * a
        cws[0] = -0.5 * b
        cv = 0.5 * f * a
        cw = 0.5 * f * b
    else:
        cvs[0] = 0.5 * b
        cws[0] = -0.5 * a
        cv = 0.5 * f * b
        cw = -0.5 * f * a
    if m >= 1:
        ks[1] = m - 1
        cvs[1] = cv
        cws[1] = cw
    else:
        fold = 1.0 / ((n + 1.0) * (n + 2.0))
        ks[1] = 1
        cvs[1] = -fold * cv
        cws[1] = fold * cw
    return 2


@numba.njit(cache=False)
def _hessian_old(t, x, yy, z, force, sh, G):
    # the earlier kernel, term by term (visviva before the odspeed change)
    M = np.empty((3, 3))  # the frame as the kernel has it (about the pole of date since audit42)
    body_fixed_matrix(t, force, M)
    bx = M[0, 0] * x + M[0, 1] * yy + M[0, 2] * z
    by = M[1, 0] * x + M[1, 1] * yy + M[1, 2] * z
    bz = M[2, 0] * x + M[2, 1] * yy + M[2, 2] * z
    n_max = int(force[fb.HARMONICS_DEGREE])
    radius = force[fb.RADIUS]
    V, W = cunningham_vw(bx, by, bz, radius, n_max + 3)
    k1 = np.empty(2, np.int64)
    c1 = np.empty(2)
    w1 = np.empty(2)
    k2 = np.empty(2, np.int64)
    c2 = np.empty(2)
    w2 = np.empty(2)
    H = np.zeros((3, 3))
    for n in range(2, n_max + 1):
        for m in range(n + 1):
            C = sh[0, n, m]
            S = sh[1, n, m]
            if C == 0.0 and S == 0.0:
                continue
            for b in range(3):
                n1 = _derive_old(b, n, m, C, S, k1, c1, w1)
                for i in range(n1):
                    for a in range(b, 3):
                        n2 = _derive_old(a, n + 1, k1[i], c1[i], w1[i], k2, c2, w2)
                        for j in range(n2):
                            kk = k2[j]
                            H[a, b] += c2[j] * V[n + 2, kk] + w2[j] * W[n + 2, kk]
    k = force[fb.GM] / (radius * radius * radius)
    for a in range(3):
        for b in range(a):
            H[b, a] = H[a, b]
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for p in range(3):
                for q in range(3):
                    acc += M[p, i] * H[p, q] * M[q, j]
            G[i, j] += k * acc


@pytest.mark.parametrize("n_max", [2, 5, 20, 40])
def test_field_hessian_is_bitwise_the_term_by_term_form(n_max):
    rng = np.random.default_rng(n_max)
    sh = np.zeros((2, n_max + 1, n_max + 1))
    for n in range(2, n_max + 1):
        sh[0, n, : n + 1] = rng.normal(size=n + 1) * 10.0 ** -(n / 4 + 5)
        sh[1, n, 1: n + 1] = rng.normal(size=n) * 10.0 ** -(n / 4 + 5)
    sh[:, 2, 1] = 0.0  # a skipped (zero) coefficient pair
    force = np.zeros(FORCE_SIZE)
    force[fb.GM] = vv.EARTH.gm_km3_s2
    force[fb.RADIUS] = vv.EARTH.radius_km
    force[fb.ROTATION_RATE] = 7.292115e-5
    force[fb.HARMONICS_DEGREE] = n_max
    force[fb.FRAME_MATRIX:fb.FRAME_MATRIX + 9] = Rotation.from_rotvec(
        rng.normal(size=3) * 0.1).as_matrix().ravel()
    for _ in range(40):
        r = rng.uniform(6500.0, 45000.0)
        u = rng.normal(size=3)
        pos = r * u / np.linalg.norm(u)
        t = rng.uniform(-1e5, 1e5)
        G_new = np.full((3, 3), 0.25)
        G_old = np.full((3, 3), 0.25)
        _add_harmonics_gradient(t, *pos, force, sh, G_new)
        _hessian_old(t, *pos, force, sh, G_old)
        np.testing.assert_array_equal(G_new, G_old)
        assert np.abs(G_new - 0.25).max() > 0  # the field added something


@numba.njit(cache=False)
def _vw_old(x, y, z, radius, N):
    # the earlier recursion, one column after the other
    r2 = x * x + y * y + z * z
    rr = radius * radius / r2
    x0 = radius * x / r2
    y0 = radius * y / r2
    z0 = radius * z / r2
    V = np.zeros((N, N))
    W = np.zeros((N, N))
    V[0, 0] = radius / np.sqrt(r2)
    for m in range(N):
        if m > 0:
            V[m, m] = (2 * m - 1) * (x0 * V[m - 1, m - 1] - y0 * W[m - 1, m - 1])
            W[m, m] = (2 * m - 1) * (x0 * W[m - 1, m - 1] + y0 * V[m - 1, m - 1])
        if m + 1 < N:
            V[m + 1, m] = (2 * m + 1) * z0 * V[m, m]
            W[m + 1, m] = (2 * m + 1) * z0 * W[m, m]
        for n in range(m + 2, N):
            V[n, m] = ((2 * n - 1) * z0 * V[n - 1, m] - (n + m - 1) * rr * V[n - 2, m]) / (n - m)
            W[n, m] = ((2 * n - 1) * z0 * W[n - 1, m] - (n + m - 1) * rr * W[n - 2, m]) / (n - m)
    return V, W


@pytest.mark.parametrize("rows", [1, 2, 3, 4, 7, 42, 43])
def test_cunningham_columns_in_pairs_are_bitwise_the_column_by_column_recursion(rows):
    rng = np.random.default_rng(rows)
    for _ in range(20):
        u = rng.normal(size=3)
        x, y, z = rng.uniform(6400.0, 42000.0) * u / np.linalg.norm(u)
        V, W = cunningham_vw(x, y, z, 6378.1363, rows)
        V0, W0 = _vw_old(x, y, z, 6378.1363, rows)
        np.testing.assert_array_equal(V, V0)
        np.testing.assert_array_equal(W, W0)
