"""Tests of the compiled Kepler solvers and anomaly conversions (visviva.core.kepler).

Accuracy is asserted as residuals of Kepler's equation, against mpmath at 50 digits in the
near-parabolic corner, and as round trips; tolerances are in units of the double-precision
epsilon with the conditioning of each map written out.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from visviva.core import kepler as k
from visviva.core import kepler_arrays as ka
from visviva.core import status as st

EPS = np.finfo(float).eps


def run(fn, *args):
    """Call an array kernel on 1-D float64 copies of ``args``; return (out, status)."""
    args = [np.ascontiguousarray(np.asarray(a, dtype=np.float64)).ravel() for a in args]
    args = np.broadcast_arrays(*args)
    args = [np.ascontiguousarray(a) for a in args]
    out = np.empty(args[0].shape[0])
    status = np.empty(args[0].shape[0], dtype=np.int8)
    fn(*args, out, status)
    return out, status


# ---------------------------------------------------------------------------------------------
# Residuals of Kepler's equation
# ---------------------------------------------------------------------------------------------
def test_elliptic_residual_one_million():
    """|E - e sin E - M| <= 2e-15 max(1, |M|) over 10^6 random (M, e), one kernel call."""
    rng = np.random.default_rng(20130101)
    n = 1_000_000
    M = rng.uniform(-np.pi, np.pi, n)
    # a quarter of the items with large |M|, a quarter near e = 1, a quarter with tiny M
    M[: n // 4] = rng.uniform(-1e4, 1e4, n // 4)
    M[n // 4 : n // 2] *= 10.0 ** rng.uniform(-12, 0, n // 4)
    ecc = rng.uniform(0.0, 1.0, n)
    ecc[n // 2 : 3 * n // 4] = 1.0 - 10.0 ** rng.uniform(-16, -1, n // 4)
    E, status = run(ka.solve_kepler_array, M, ecc)
    assert not status.any()
    assert np.all(np.isfinite(E))
    residual = np.abs(E - ecc * np.sin(E) - M)
    assert np.all(residual <= 2e-15 * np.maximum(1.0, np.abs(M)))


def test_elliptic_array_equals_scalar_kernel():
    """The two-pass SIMD array kernel gives bit-identical results to the scalar kernel."""
    rng = np.random.default_rng(7)
    n = 20_000
    M = np.concatenate([rng.uniform(-7, 7, n), rng.uniform(-1e-3, 1e-3, n)])
    ecc = np.concatenate([rng.uniform(0, 1, n), 1 - 10.0 ** rng.uniform(-16, 0, n)])
    E, status = run(ka.solve_kepler_array, M, ecc)
    for i in range(0, 2 * n, 37):
        Ei, si = k.eccentric_anomaly(M[i], ecc[i])
        assert si == status[i] == st.OK
        assert Ei == E[i] or (np.isnan(Ei) and np.isnan(E[i]))


def test_mean_to_true_array_equals_scalar_kernel():
    rng = np.random.default_rng(8)
    n = 20_000
    M = np.concatenate([rng.uniform(-7, 7, n), rng.uniform(-1e-3, 1e-3, n), [np.nan, 1.0]])
    ecc = np.concatenate([rng.uniform(0, 2, n), 1 - 10.0 ** rng.uniform(-16, 0, n), [0.5, -1]])
    nu, status = run(ka.mean_to_true_array, M, ecc)
    for i in list(range(0, 2 * n, 37)) + [2 * n, 2 * n + 1]:
        nui, si = k.mean_to_true_anomaly(M[i], ecc[i])
        assert si == status[i]
        assert nui == nu[i] or (np.isnan(nui) and np.isnan(nu[i]))
    assert status[-2] == st.NON_FINITE and status[-1] == st.BAD_ECCENTRICITY


def test_hyperbolic_residual():
    """Hyperbolic residual within 2e-15 of max(1, |M|) plus the spacing of F itself."""
    rng = np.random.default_rng(11)
    n = 200_000
    M = rng.uniform(-60, 60, n)
    M[: n // 4] = np.sign(M[: n // 4]) * 10.0 ** rng.uniform(-300, 300, n // 4)
    M[n // 4 : n // 2] *= 10.0 ** rng.uniform(-12, 0, n // 4)
    ecc = 1.0 + 10.0 ** rng.uniform(-15, 1, n)
    ecc[: n // 8] = 10.0 ** rng.uniform(1, 300, n // 8)
    F, status = run(ka.solve_kepler_hyperbolic_array, M, ecc)
    assert not status.any()
    assert np.all(np.isfinite(F))
    with np.errstate(over="ignore"):
        # the best double F has |dF| <= ulp(F)/2, which moves the residual by f'(F) ulp(F)/2
        slope = np.abs(ecc * np.cosh(F) - 1.0)
        residual = np.abs(ecc * np.sinh(F) - F - M)
    scale = np.maximum(1.0, np.abs(M))
    finite = np.isfinite(residual) & np.isfinite(slope)
    assert finite.mean() > 0.9
    tol = 2e-15 * scale + 2.0 * EPS * np.abs(F) * slope
    assert np.all(residual[finite] <= tol[finite])
    # in the moderate range the plain relative criterion holds
    moderate = finite & (np.abs(F) < 5)
    assert moderate.sum() > n // 4
    assert np.all(residual[moderate] <= 2e-15 * scale[moderate] * 4)


def test_hyperbolic_large_anomaly_log_form():
    """Beyond F = 20 the solver uses log form; check against mpmath."""
    mpmath = pytest.importorskip("mpmath")
    mpmath.mp.dps = 50
    for M, e in [(1e9, 1.5), (1e300, 1.0001), (1.7e308, 1.0 + 1e-15), (1e20, 1e10)]:
        F, s = k.hyperbolic_anomaly(M, e)
        assert s == st.OK
        M_mp, e_mp = mpmath.mpf(M), mpmath.mpf(e)
        start = mpmath.log(2 * M_mp / e_mp)
        ref = mpmath.findroot(
            lambda x, M_mp=M_mp, e_mp=e_mp: (e_mp * mpmath.sinh(x) - x - M_mp) / M_mp, start
        )
        assert abs(F - float(ref)) <= 4 * EPS * abs(F)


def test_parabolic_residual():
    rng = np.random.default_rng(3)
    n = 200_000
    M = rng.uniform(-100, 100, n)
    M[: n // 2] = np.sign(M[: n // 2]) * 10.0 ** rng.uniform(-300, 300, n // 2)
    M[:100] = 10.0 ** rng.uniform(300, 308, 100)
    D, status = run(ka.parabolic_anomaly_array, M)
    assert not status.any()
    # relative residual, written to avoid overflow of D^3
    lhs = D * (1.0 + (D / 3.0) * D)
    assert np.all(np.abs(lhs[100:] - M[100:]) <= 4 * EPS * np.abs(M[100:]) + 1e-300)
    assert np.all(np.abs(lhs[:100] - M[:100]) <= 8 * EPS * np.abs(M[:100]))
    # huge M, close to overflow
    for M in (1e307, -1.7e308):
        D, s = k.parabolic_anomaly(M)
        assert s == st.OK and abs((D / 3.0) * D * D / M - 1.0) < 4 * EPS


# ---------------------------------------------------------------------------------------------
# Relative accuracy in the near-parabolic corner, against mpmath
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("one_minus_e", [0.3, 1e-2, 1e-5, 1e-10, 1e-14, 2.0**-53])
@pytest.mark.parametrize("M", [1e-300, 1e-30, 1e-12, 1e-6, 1e-3, 0.1, 1.0])
def test_elliptic_relative_accuracy_mpmath(one_minus_e, M):
    mpmath = pytest.importorskip("mpmath")
    mpmath.mp.dps = 60
    ecc = 1.0 - one_minus_e
    E, s = k.eccentric_anomaly(M, ecc)
    assert s == st.OK
    e_mp = mpmath.mpf(ecc)
    ref = mpmath.findroot(lambda x: x - e_mp * mpmath.sin(x) - M, mpmath.mpf(E))
    assert abs(mpmath.mpf(E) - ref) <= 4 * EPS * abs(ref)


@pytest.mark.parametrize("e_minus_one", [1e-2, 1e-5, 1e-10, 1e-14, 2.0**-52])
@pytest.mark.parametrize("M", [1e-300, 1e-30, 1e-12, 1e-6, 1e-3, 0.1, 1.0, 100.0])
def test_hyperbolic_relative_accuracy_mpmath(e_minus_one, M):
    mpmath = pytest.importorskip("mpmath")
    mpmath.mp.dps = 60
    ecc = 1.0 + e_minus_one
    F, s = k.hyperbolic_anomaly(M, ecc)
    assert s == st.OK
    e_mp = mpmath.mpf(ecc)
    ref = mpmath.findroot(lambda x: e_mp * mpmath.sinh(x) - x - M, mpmath.mpf(F))
    assert abs(mpmath.mpf(F) - ref) <= 4 * EPS * abs(ref)


def test_mean_from_anomaly_series_against_mpmath():
    """E - e sin E and e sinh F - F keep full relative precision where they cancel."""
    mpmath = pytest.importorskip("mpmath")
    mpmath.mp.dps = 60
    for x in (1e-8, 1e-3, 0.3, 1.0, 1.99, 2.5):
        for d in (1e-12, 1e-4, 0.2):
            M, s = k.mean_from_eccentric(x, 1.0 - d)
            ref = mpmath.mpf(x) - mpmath.mpf(1.0 - d) * mpmath.sin(x)
            assert s == st.OK and abs(M - ref) <= 4 * EPS * abs(ref)
            M, s = k.mean_from_hyperbolic(x, 1.0 + d)
            ref = mpmath.mpf(1.0 + d) * mpmath.sinh(x) - x
            assert s == st.OK and abs(M - ref) <= 4 * EPS * abs(ref)


# ---------------------------------------------------------------------------------------------
# Edge cases and status codes
# ---------------------------------------------------------------------------------------------
def test_signed_zero_and_special_values():
    for fn in (k.eccentric_anomaly, k.hyperbolic_anomaly, k.mean_to_true_anomaly):
        for e in [0.0, 0.5, 1 - 1e-16] if fn is k.eccentric_anomaly else [1.5, 1 + 1e-15]:
            for z in (0.0, -0.0):
                x, s = fn(z, e)
                assert s == st.OK and x == 0.0
                assert math.copysign(1.0, x) == math.copysign(1.0, z)
    D, s = k.parabolic_anomaly(-0.0)
    assert s == st.OK and D == 0.0 and math.copysign(1.0, D) < 0
    nu, s = k.mean_to_true_anomaly(-0.0, 1.0)
    assert s == st.OK and math.copysign(1.0, nu) < 0
    # M = +-pi: E = +-pi exactly, nu = +-pi
    for e in (0.0, 0.3, 0.99, 1 - 1e-15):
        E, s = k.eccentric_anomaly(math.pi, e)
        assert s == st.OK and abs(E - math.pi) <= 2 * EPS
        E, s = k.eccentric_anomaly(-math.pi, e)
        assert s == st.OK and abs(E + math.pi) <= 2 * EPS
    # subnormal mean anomaly
    E, s = k.eccentric_anomaly(5e-324, 0.5)
    assert s == st.OK and E == 1e-323
    # e = 0 is the identity, tiny e nearly so
    assert k.eccentric_anomaly(1.2345, 0.0) == (1.2345, st.OK)
    E, s = k.eccentric_anomaly(1.2345, 1e-300)
    assert s == st.OK and E == 1.2345


def test_revolutions_are_kept():
    rng = np.random.default_rng(5)
    M = rng.uniform(-np.pi, np.pi, 1000)
    e = rng.uniform(0, 0.999, 1000)
    E0, _ = run(ka.solve_kepler_array, M, e)
    for n_rev in (-7, 1, 3, 1000):
        E1, s = run(ka.solve_kepler_array, M + 2 * np.pi * n_rev, e)
        assert not s.any()
        assert np.allclose(
            E1 - 2 * np.pi * n_rev, E0, rtol=0, atol=4 * EPS * (1 + 2 * np.pi * abs(n_rev))
        )
        nu1, s = run(ka.mean_to_true_array, M + 2 * np.pi * n_rev, e)
        nu0, _ = run(ka.mean_to_true_array, M, e)
        assert np.allclose(nu1 - 2 * np.pi * n_rev, nu0, rtol=0, atol=1e-9 * (1 + abs(n_rev)))


@pytest.mark.parametrize(
    "fn, args, code",
    [
        (k.eccentric_anomaly, (math.nan, 0.1), st.NON_FINITE),
        (k.eccentric_anomaly, (0.1, math.inf), st.NON_FINITE),
        (k.eccentric_anomaly, (0.1, -0.1), st.BAD_ECCENTRICITY),
        (k.eccentric_anomaly, (0.1, 1.0), st.BAD_ECCENTRICITY),
        (k.hyperbolic_anomaly, (0.1, 1.0), st.BAD_ECCENTRICITY),
        (k.hyperbolic_anomaly, (math.inf, 2.0), st.NON_FINITE),
        (k.parabolic_anomaly, (math.nan,), st.NON_FINITE),
        (k.mean_to_true_anomaly, (0.1, -1e-300), st.BAD_ECCENTRICITY),
        (k.true_to_mean_anomaly, (2.1, 2.0), st.UNREACHABLE_ANOMALY),
        (k.true_to_mean_anomaly, (math.pi, 1.0), st.UNREACHABLE_ANOMALY),
        (k.true_to_mean_anomaly, (-4.0, 1.5), st.UNREACHABLE_ANOMALY),
        (k.hyperbolic_from_true, (math.acos(-1 / 3.0), 3.0), st.UNREACHABLE_ANOMALY),
        (k.parabolic_from_true, (-math.pi,), st.UNREACHABLE_ANOMALY),
        (k.true_from_eccentric, (1.0, 1.0), st.BAD_ECCENTRICITY),
        (k.true_from_hyperbolic, (1.0, 0.5), st.BAD_ECCENTRICITY),
    ],
)
def test_status_codes(fn, args, code):
    value, s = fn(*args)
    assert s == code
    assert math.isnan(value)


def test_array_kernels_report_status_per_item():
    M = np.array([0.5, np.nan, 0.5, 0.5, 4.0])
    e = np.array([0.5, 0.5, 1.5, -1.0, 0.2])
    E, s = run(ka.solve_kepler_array, M, e)
    assert list(s) == [st.OK, st.NON_FINITE, st.BAD_ECCENTRICITY, st.BAD_ECCENTRICITY, st.OK]
    assert np.isfinite(E[[0, 4]]).all() and np.isnan(E[1:4]).all()


# ---------------------------------------------------------------------------------------------
# Conversions, monotonicity, continuity through e = 1
# ---------------------------------------------------------------------------------------------
def test_direct_conversions_round_trip():
    rng = np.random.default_rng(9)
    n = 10_000
    e = rng.uniform(0, 1, n)
    E = rng.uniform(-3, 3, n)
    nu, s1 = run(ka.true_from_eccentric_array, E, e)
    E2, s2 = run(ka.eccentric_from_true_array, nu, e)
    assert not (s1.any() or s2.any())
    assert np.allclose(E2, E, rtol=1e-12, atol=1e-12)
    eh = 1 + 10.0 ** rng.uniform(-6, 2, n)
    F = rng.uniform(-10, 10, n)
    nu, s1 = run(ka.true_from_hyperbolic_array, F, eh)
    F2, s2 = run(ka.hyperbolic_from_true_array, nu, eh)
    assert not (s1.any() or s2.any())
    # tanh saturates for large |F|: compare through the conditioning dF/dnu
    assert np.allclose(F2[np.abs(F) < 5], F[np.abs(F) < 5], rtol=1e-10, atol=1e-12)
    D = np.tan(rng.uniform(-1.5, 1.5, n))
    nu, _ = run(ka.true_from_parabolic_array, D)
    D2, _ = run(ka.parabolic_from_true_array, nu)
    assert np.allclose(D2, D, rtol=1e-14)


@pytest.mark.parametrize(
    "ecc", [0.0, 1e-12, 0.5, 0.9, 0.99999, 1 - 1e-10, 1.0, 1 + 1e-10, 1.0001, 1.1, 10.0, 1e6]
)
def test_mean_anomaly_monotonic_in_true_anomaly(ecc):
    limit = math.pi if ecc < 1 else math.acos(-1.0 / ecc)
    nu = np.linspace(-limit, limit, 20_001)[1:-1]
    M, s = run(ka.true_to_mean_array, nu, np.full_like(nu, ecc))
    assert not s.any()
    assert np.all(np.diff(M) > 0)
    if ecc < 1:  # over several revolutions (near e = 1 the steps round away next to 2 pi k)
        nu = np.linspace(-3 * math.pi, 3 * math.pi, 20_001)
        M, s = run(ka.true_to_mean_array, nu, np.full_like(nu, ecc))
        assert not s.any()
        assert np.all(np.diff(M) >= 0) and M[-1] - M[0] == pytest.approx(6 * math.pi)


def _normalised_mean(M, ecc):
    """2 M / |1 - e^2|^(3/2): the parabolic mean anomaly 2 sqrt(mu/p^3) t at the same time."""
    if ecc == 1.0:
        return M
    return 2.0 * M / abs((1.0 - ecc) * (1.0 + ecc)) ** 1.5


@pytest.mark.parametrize("nu", [1e-6, 0.3, 1.5, 2.5, 3.0])
def test_continuity_through_parabolic(nu):
    """At fixed nu the time since periapsis (normalised mean anomaly) is continuous at e = 1."""
    Mp, s = k.true_to_mean_anomaly(nu, 1.0)
    assert s == st.OK
    for d in (1e-4, 1e-7, 1e-10, 1e-13):
        for ecc in (1.0 - d, 1.0 + d):
            M, s = k.true_to_mean_anomaly(nu, ecc)
            assert s == st.OK
            Mn = _normalised_mean(M, ecc)
            # first-order dependence on e - 1 (coefficient O(D^2) at most) plus rounding
            D = math.tan(nu / 2)
            assert abs(Mn - Mp) <= 10 * d * (1 + D * D) * abs(Mp) + 1e-13 * abs(Mp)
            # and back: the true anomaly at that time is continuous too
            nu2, s = k.mean_to_true_anomaly(M, ecc)
            assert s == st.OK and abs(nu2 - nu) <= 1e-12 * max(1.0, abs(nu)) / (1 + nu * nu) + 1e-12


def test_mean_to_true_sweeps_through_parabolic_smoothly():
    """nu(t) at fixed t and p: sweep e across 1 and check no jump."""
    Mp = 2.0  # parabolic mean anomaly
    ecc = 1.0 + np.concatenate([-np.logspace(-2, -15, 60), [0.0], np.logspace(-15, -2, 60)])
    nus = []
    for e in ecc:
        M = Mp if e == 1.0 else Mp * abs((1.0 - e) * (1.0 + e)) ** 1.5 / 2.0
        nu, s = k.mean_to_true_anomaly(M, e)
        assert s == st.OK
        nus.append(nu)
    nus = np.array(nus)
    nu_p = nus[60]
    dev = np.abs(nus - nu_p)
    assert np.all(dev <= 2.0 * np.abs(ecc - 1.0) + 1e-13)


def test_huge_mean_anomaly_stays_finite_and_consistent():
    """Past 2^53 the revolution is lost in rounding, but E stays finite with a tiny residual."""
    for M in (1e300, -1e20, 1e16, 2.0**60):
        for e in (0.0, 0.3, 0.999):
            E, s = k.eccentric_anomaly(M, e)
            assert s == st.OK and math.isfinite(E)
            assert abs(E - e * math.sin(E) - M) <= 2e-15 * abs(M)
            nu, s = k.mean_to_true_anomaly(M, e)
            assert s == st.OK and math.isfinite(nu) and abs(nu - M) <= 2e-15 * abs(M) + 4.0
