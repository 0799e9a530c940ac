"""Collision probability against published reference values.

References (numbers copied from the public test files, not code):

* NASA CARA Analysis Tools, ``DistributedMatlab/ProbabilityOfCollision/UnitTests/
  PcCircle_UnitTest.m`` (github.com/nasa/CARA_Analysis_Tools): the Omitron cases and the
  multiple-HBR case, asserted there to 1e-10 relative; ``Pc2D_Foster_UnitTest.m`` (same cases).
* Alfano (2009) test cases 3 and 5 and Chan's (2008, table 5.1) cases as 2-D encounter-plane
  data, with the reference values of Orekit's ``Laas2015Test.java`` (Serra et al. 2016 method,
  an exact series with error bounds) and ``Chan1997Test.java`` (github.com/CS-SI/Orekit).
* CARA's Alfano 2009 table, ``Pc3D_Hall_Utils/Output_AlfanoTestCases_Pc3D/
  A09TestCases_01_12_Distributed.csv``: 2-D Pc of case 3 = 0.100351017066071, case 5 =
  0.044492344523551 (used for the encounter-plane data above at its 7-digit rounding).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from astropy import units as u
from scipy import integrate, stats

import visviva as vv
from visviva.conjunctions import (
    CovarianceRepairWarning,
    collision_probability,
    max_collision_probability,
    monte_carlo_probability,
)
from visviva.core import collision as kern
from visviva.errors import InvalidInputError, ShapeError

# --- CARA PcCircle_UnitTest: Omitron case 1 (km, km^2; HBR 0.020 km) -------------------------
OM_R1 = np.array([378.39559, 4305.721887, 5752.767554])
OM_V1 = np.array([2.360800244, 5.580331936, -4.322349039])
OM_C1 = np.array([[44.5757544811362, 81.6751751052616, -67.8687662707124],
                  [81.6751751052616, 158.453402956163, -128.616921644857],
                  [-67.8687662707124, -128.616921644858, 105.490542562701]])
OM_R2 = np.array([374.5180598, 4307.560983, 5751.130418])
OM_V2 = np.array([-5.388125081, -3.946827739, 3.322820358])
OM_C2 = np.array([[2.31067077720423, 1.69905293875632, -1.4170164577661],
                  [1.69905293875632, 1.24957388457206, -1.04174164279599],
                  [-1.4170164577661, -1.04174164279599, 0.869260558223714]])
OM_PC = 2.706023476569787e-05

# --- Omitron case 2 ----------------------------------------------------------------------------
C2_R1 = np.array([-3239.128337196251, 2404.575152356222, 5703.228541709001])
C2_V1 = np.array([-3.745768373154199, 5.012339015927846, -4.231864565717194])
C2_R2 = np.array([-3239.138264917246, 2404.568320465936, 5703.235605231182])
C2_V2 = np.array([6.110192790100711, -1.767321407894830, 4.140369261741708])
C2_C1 = np.array([[0.342072996423899, -0.412677096778269, 0.371500417511149],
                  [-0.412677096778269, 0.609905946319294, -0.540401385544286],
                  [0.371500417511149, -0.540401385544286, 0.521238634755377]]) * 1e-3
C2_C2 = np.array([[0.028351300975134, -0.008204103437377, 0.019253747960155],
                  [-0.008204103437377, 0.002404377774847, -0.005586512197914],
                  [0.019253747960155, -0.005586512197914, 0.013289250260317]])

# --- multiple-HBR case (m, m^2) ----------------------------------------------------------------
MH_R1 = np.array([-6.227006552549310e+06, -3.000839638747010e+06, -1.932569099062626e+05])
MH_V1 = np.array([2.983983865443772e+03, -5.973188938878403e+03, -3.622262843716804e+03])
MH_C1 = np.array([[2.329248149898317e+04, -4.624097512511387e+04, -2.810352472705708e+04],
                  [-4.624097512511387e+04, 9.189373058443272e+04, 5.583858286675660e+04],
                  [-2.810352472705708e+04, 5.583858286675660e+04, 3.396506000245927e+04]])
MH_R2 = np.array([-6.231009268962734e+06, -2.993196148130401e+06, -1.761401651747054e+05])
MH_V2 = np.array([-3.255968208692156e+02, 9.946514541875586e+02, -7.507340539210305e+03])
MH_C2 = np.array([[3.689149893147051e+07, -1.200669748208798e+08, 9.002535247181211e+08],
                  [-1.200669748208798e+08, 3.907735722225543e+08, -2.929990982074453e+09],
                  [9.002535247181211e+08, -2.929990982074453e+09, 2.196888928197153e+10]])
MH_HBR = [0.0, 1e1, 1e2, 1e3, 3e3, 1e4, 3e4, math.inf]
MH_PC = [0.0, 2.514939701718358e-15, 1.232312816404174e-05, 6.343318773183237e-03,
         1.917884657463699e-02, 6.389821634646267e-02, 1.900663422510684e-01, 1.0]


# --- CARA's non-positive-definite case (m, m/s, m^2) ----------------------------------------------
NPD_CASE = (
    np.array([-6711923.276204407, 2115987.639388162, 596903.033311516]),
    np.array([-3633.024009735033, -8343.876216289187, 1529.269073307224]),
    np.array([[10651.06865424844, 25162.51806981900, -4653.47179860534],
              [25162.51806981901, 61873.55078822979, -11370.63814221593],
              [-4653.47179860534, -11370.63814221593, 2108.71780971058]]),
    np.array([-6703689.997789211, 2066645.266249834, 601175.621383896]),
    np.array([-499.951545210059, -8271.763735723972, -3673.287518932014]),
    np.array([[38324418857.201, 409236977944.646, 182366534533.406],
              [409236977944.646, 4369926131386.673, 1947351616381.380],
              [182366534533.406, 1947351616381.380, 867790027954.990]]),
)


def _km_to_m(r1, v1, c1, r2, v2, c2):
    return r1 * 1e3, v1 * 1e3, c1 * 1e6, r2 * 1e3, v2 * 1e3, c2 * 1e6


def test_cara_omitron_case1_to_1e10():
    args = _km_to_m(OM_R1, OM_V1, OM_C1, OM_R2, OM_V2, OM_C2)
    assert collision_probability(*args, 20.0) == pytest.approx(OM_PC, rel=1e-10)


def test_quantities_give_the_same_number():
    pc = collision_probability(OM_R1 * u.km, OM_V1 * u.km / u.s, OM_C1 * u.km**2,
                               OM_R2 * u.km, OM_V2 * u.km / u.s, OM_C2 * u.km**2, 20 * u.m)
    assert pc == pytest.approx(OM_PC, rel=1e-10)
    assert vv.collision_probability is collision_probability


def test_cara_omitron_case2_to_1e10():
    pc = collision_probability(*_km_to_m(C2_R1, C2_V1, C2_C1, C2_R2, C2_V2, C2_C2), 20.0)
    assert pc == pytest.approx(1.807363058494765e-01, rel=1e-10)


@pytest.mark.parametrize("hbr, expected", list(zip(MH_HBR, MH_PC, strict=True)))
def test_cara_multiple_hbr(hbr, expected):
    pc = collision_probability(MH_R1, MH_V1, MH_C1, MH_R2, MH_V2, MH_C2, hbr)
    if expected in (0.0, 1.0):
        assert pc == expected
    elif hbr <= 100:
        assert pc == pytest.approx(expected, rel=1e-10)
    else:
        # HBR >> minor sigma (18.6 m): CARA's 64-point Gauss-Chebyshev rule is ~1e-4 off here;
        # our value is checked against the integral taken in the other order (over the minor
        # axis, the major one by the normal CDF) with scipy's adaptive quad
        assert pc == pytest.approx(expected, rel=4e-4)
        plane = vv.conjunctions.encounter_plane(MH_R1, MH_V1, MH_C1, MH_R2, MH_V2, MH_C2, hbr)
        (xm, zm), (sx, sz) = plane.principal_miss, plane.sigma

        def g(z):
            w = math.sqrt(max(hbr * hbr - (z - zm) ** 2, 0.0))
            return stats.norm.pdf(z, 0, sz) * (stats.norm.cdf((xm + w) / sx)
                                               - stats.norm.cdf((xm - w) / sx))

        lo, hi = max(zm - hbr, -60 * sz), min(zm + hbr, 60 * sz)
        ref = integrate.quad(g, lo, hi, epsabs=0, epsrel=1e-13, limit=500,
                             points=[0.0] if lo < 0 < hi else None)[0]
        assert pc == pytest.approx(ref, rel=1e-10)


def test_cara_npd_case_warns_and_is_zero():
    r1, v1, c1, r2, v2, c2 = NPD_CASE
    with pytest.warns(CovarianceRepairWarning, match="not positive semi-definite"):
        pc = collision_probability(r1, v1, c1, r2, v2, c2, 52.84)
    assert pc == 0.0  # CARA: 0 (underflow); here ln Pc ~ -9.8e12 is still available:
    with pytest.warns(CovarianceRepairWarning):
        lp = collision_probability(r1, v1, c1, r2, v2, c2, 52.84, log=True)
    assert -1e13 < lp < -9e12


# --- encounter-plane (2-D) reference cases -----------------------------------------------------
# (xm, zm, sx, sz, R, Laas2015 value, its absolute tolerance, Chan1997 value, its tolerance)
PLANE_CASES = [
    (0, 10, 25, 50, 5, 9.742e-3, 1e-6, 9.754e-3, 1e-6),
    (10, 0, 25, 50, 5, 9.181e-3, 1e-6, 9.189e-3, 1e-6),
    (0, 10, 25, 75, 5, 6.571e-3, 1e-6, 6.586e-3, 1e-6),
    (10, 0, 25, 75, 5, 6.125e-3, 1e-6, 6.135e-3, 1e-6),
    (0, 1000, 1000, 3000, 10, 1.577e-5, 1e-8, 1.577e-5, 1e-8),
    (1000, 0, 1000, 3000, 10, 1.011e-5, 1e-8, 1.011e-5, 1e-8),
    (0, 10000, 1000, 3000, 10, 6.443e-8, 1e-11, 6.443e-8, 1e-11),
    (10000, 0, 1000, 3000, 10, 3.219e-27, 1e-30, 3.216e-27, 1e-30),
    (0, 10000, 1000, 10000, 10, 3.033e-6, 1e-9, 3.033e-6, 1e-9),
    (10000, 0, 1000, 10000, 10, 9.656e-28, 1e-31, 9.645e-28, 1e-31),
    (0, 5000, 1000, 3000, 50, 1.039e-4, 1e-7, 1.039e-4, 1e-7),
    (5000, 0, 1000, 3000, 50, 1.564e-9, 1e-12, 1.556e-9, 1e-12),
    (84.875546, 60.583685, 57.918666, 152.8814468, 10.3, 1.9002e-3, 1e-7, 1.8934e-3, 1e-7),
    (-81.618369, 115.055899, 15.988242, 5756.840725, 1.3, 2.0553e-11, 1e-15, 2.0135e-11, 1e-15),
    (102.177247, 693.405893, 94.230921, 643.409272, 5.3, 7.2003e-5, 1e-9, 7.2000e-5, 1e-9),
    (-752.672701, 644.939441, 445.859950, 6095.858688, 3.5, 5.3904e-7, 1e-11, 5.3903e-7, 1e-11),
    (-692.362272, 4475.456261, 193.454603, 562.027293, 13.2, 2.2796e-20, 1e-24, 2.2880e-20,
     1e-24),
    # Alfano (2009) case 3 in its encounter plane (CARA 2-D: 0.100351017)
    (-3.8872073, 0.1591646, 1.4101830, 114.2585190, 15, 1.0038e-1, 1e-5, 3.1264e-2, 1e-6),
]


def _foster(xm, zm, sx, sz, r):
    lp, status = kern.log_pc_circle(abs(xm), abs(zm), sx, sz, r, kern.GAUSS_LO, kern.GAUSS_HI,
                                    1e-13)
    assert status == 0
    return math.exp(lp)


@pytest.mark.parametrize("case", PLANE_CASES)
def test_foster_kernel_matches_laas_and_chan_matches_orekit(case):
    xm, zm, sx, sz, r, laas, laas_tol, chan, chan_tol = case
    assert _foster(xm, zm, sx, sz, r) == pytest.approx(laas, abs=laas_tol)
    assert math.exp(kern.log_pc_chan(abs(xm), abs(zm), sx, sz, r)) == pytest.approx(
        chan, abs=chan_tol)


def test_alfano_case5_plane_and_chan_series_converged():
    # Alfano (2009) case 5: Laas2015 reference 4.4507e-2 (CARA 2-D 0.0444923)
    assert _foster(1.2217895, 2.1230067, 0.0373279, 177.8109003, 10) == pytest.approx(
        4.4507e-2, abs=3e-6)
    # Chan's series summed to convergence: 8.76184970762617e-184 (mpmath, 60 digits); Orekit's
    # 1.7346e-202 stops the series early
    lp = kern.log_pc_chan(1.2217895, 2.1230067, 0.0373279, 177.8109003, 10)
    assert math.exp(lp) == pytest.approx(8.76184970762617e-184, rel=1e-10)


def test_foster_against_adaptive_dblquad_random_geometries():
    rng = np.random.default_rng(3)
    for _ in range(6):
        sx, sz = rng.uniform(1, 300, 2)
        xm, zm = rng.uniform(0, 400, 2)
        r = rng.uniform(1, 100)

        def f(z, x, sx=sx, sz=sz):
            return stats.norm.pdf(x, 0, sx) * stats.norm.pdf(z, 0, sz)

        def half(x, r=r, xm=xm):
            return math.sqrt(max(r * r - (x - xm) ** 2, 0.0))

        ref = integrate.dblquad(f, xm - r, xm + r, lambda x, zm=zm, half=half: zm - half(x),
                                lambda x, zm=zm, half=half: zm + half(x), epsabs=0,
                                epsrel=1e-12)[0]
        assert _foster(xm, zm, sx, sz, r) == pytest.approx(ref, rel=1e-10)


def test_tiny_probability_keeps_relative_accuracy():
    # circular covariance: Pc = int_0^R (rho/s^2) exp(-(rho^2 + d^2)/(2 s^2)) I0(rho d/s^2) drho
    # (the Rice distribution), with mpmath at 40 digits
    mpmath = pytest.importorskip("mpmath")
    mpmath.mp.dps = 40
    for d in (300.0, 370.0, 420.0):
        s, r = 10.0, 1.0
        exact = float(mpmath.log(mpmath.quad(
            lambda x, d=d, s=s: x / s**2 * mpmath.exp(-(x * x + d * d) / (2 * s * s))
            * mpmath.besseli(0, x * d / s**2), [0, r])))
        lp, status = kern.log_pc_circle(d, 0.0, s, s, r, kern.GAUSS_LO, kern.GAUSS_HI, 1e-13)
        assert status == 0
        assert lp == pytest.approx(exact, rel=1e-9)
    # ~1e-300 as a float: not underflowed, not zero
    lp, _ = kern.log_pc_circle(370.0, 0.0, 10.0, 10.0, 1.0, kern.GAUSS_LO, kern.GAUSS_HI, 1e-13)
    assert 1e-310 < math.exp(lp) < 1e-290


def _tail_reference_log_pc(x0, s, r):
    """ln Pc for a circular N(0, s^2) and the circle of radius r centred at (r + x0, 0), x0 > 0
    and s << r: the Gaussian's tail beyond x0 less what the chords near the edge miss,
    Pc = Q(x0 / s) - int_0 pdf(x0 + d) erfc(h(d) / (s sqrt 2)) dd, h = sqrt(2 r d - d^2)
    (scipy's quad on a one-sided, rapidly decaying integrand, scaled by pdf(x0))."""
    from scipy import special

    z = x0 / s
    q = 0.5 * special.erfcx(z / math.sqrt(2)) * s * math.sqrt(2 * math.pi)  # Q / pdf(x0)

    def g(d):
        return (math.exp(-(x0 * d + d * d / 2) / s**2)
                * special.erfc(math.sqrt(2 * r * d - d * d) / (s * math.sqrt(2))))

    c = integrate.quad(g, 0, 1e-3, epsabs=0, epsrel=1e-13, limit=500,
                       points=[1e-9, 1e-8, 1e-7, 1e-6, 1e-5, 1e-4])[0]
    return -0.5 * z * z - math.log(s * math.sqrt(2 * math.pi)) + math.log(q - c)


@pytest.mark.parametrize("xm, zm, sx, sz, hbr, ref", [
    # thin covariances beside a large HBR, the circle's edge in the tail or near the mean: the
    # adaptive integration chased rounding noise below 1e-13 and raised ConvergenceError
    # ("report this case"); references by scipy's quad (x integral, chord mass by ndtr)
    (15.90469771686402, 29.772161088104593, 0.003375088886962092, 0.003375088886962092,
     33.750888869620916, -1.7791828916401329),
    (0.5552847507928528, 6.096439338862985, 0.0015002389014957685, 0.0006120576351375006,
     6.120576351375005, -3.2403093719416503),
    (-26.045859784325614, 84.62589961950549, 45314.457706944435, 0.008444591261023895,
     84.44591261023895, -243.54327071407172),
])
def test_foster_kernel_thin_covariance_beside_a_large_hbr_converges(xm, zm, sx, sz, hbr, ref):
    lp, status = kern.log_pc_circle(xm, zm, sx, sz, hbr, kern.GAUSS_LO, kern.GAUSS_HI, 1e-13)
    assert status == 0
    assert lp == pytest.approx(ref, abs=1e-11)


def test_thin_covariance_with_the_miss_just_outside_the_hbr():
    # combined sigma 1 mm (CARA's clip raises it to 1e-4 HBR = 2 mm), HBR 20 m, miss 20.0355 m:
    # Pc ~ 1e-70, which collision_probability refused with ConvergenceError (found by audit10)
    ref = _tail_reference_log_pc(0.0355, 0.002, 20.0)
    for xm, zm in ((20.0355, 0.0), (0.0, 20.0355)):
        lp, status = kern.log_pc_circle(xm, zm, 0.002, 0.002, 20.0, kern.GAUSS_LO, kern.GAUSS_HI,
                                        1e-13)
        assert status == 0
        assert lp == pytest.approx(ref, abs=1e-9)
    r1, v1 = np.array([7e6, 0.0, 0.0]), np.array([0.0, 7.5e3, 0.0])
    r2, v2 = r1 + [20.0355, 0.0, 0.0], np.array([0.0, 0.0, 7.5e3])
    c = np.eye(3) * 1e-6
    lp = collision_probability(r1, v1, c, r2, v2, c * 0, 20.0, log=True)
    # the miss as the positions 7000 km out carry it (to ~5e-10 m: 4e-6 in ln Pc here)
    x0 = float(np.linalg.norm(r2 - r1)) - 20.0
    assert lp == pytest.approx(_tail_reference_log_pc(x0, 0.002, 20.0), abs=1e-9)


@pytest.mark.parametrize("d, s", [(5e3, 3.0), (2e4, 1.0), (1e6, 1.0)])
def test_chan_series_far_miss_equals_the_exact_rice_integral(d, s):
    # For a circular covariance Chan's series is exact (the Rice distribution), so it must equal
    # the Foster kernel, itself checked against mpmath above; here ln Pc was computed with mpmath
    # too (substituting x = R - y in the Rice integral): -1377811.0942761686, -199600214.2753042,
    # -499980000220.14435. Many sigmas of miss put the Poisson mode v/2 at 1e6..5e11 while the
    # largest term sits near sqrt(u v)/2: the series once walked down from v/2 term by term
    # (13 s at v/2 = 2e8, hours at 1e11; a hang for CARA's repaired covariances).
    lp_foster, status = kern.log_pc_circle(d, 0.0, s, s, 20.0, kern.GAUSS_LO, kern.GAUSS_HI,
                                           1e-13)
    assert status == 0
    assert kern.log_pc_chan(d, 0.0, s, s, 20.0) == pytest.approx(lp_foster, rel=1e-12)


def test_chan_on_cara_repaired_covariance_is_zero_not_a_hang():
    # CARA's non-positive-definite case (test_cara_npd_case_warns_and_is_zero): after the repair
    # the minor sigma is 1e-4 HBR, the miss ~1e6 sigmas, v/2 ~ 1e13
    r1, v1, c1, r2, v2, c2 = NPD_CASE
    with pytest.warns(CovarianceRepairWarning):
        assert collision_probability(r1, v1, c1, r2, v2, c2, 52.84, method="chan") == 0.0
    with pytest.warns(CovarianceRepairWarning):
        lp_chan = collision_probability(r1, v1, c1, r2, v2, c2, 52.84, method="chan", log=True)
    with pytest.warns(CovarianceRepairWarning):
        lp_foster = collision_probability(r1, v1, c1, r2, v2, c2, 52.84, log=True)
    # Chan's equivalent-area circle is an approximation for this 1e9:1 ellipse: ln Pc within 1 %
    assert lp_chan == pytest.approx(lp_foster, rel=1e-2)
    # the Monte Carlo estimate draws from the same repaired plane: it must say so too
    with pytest.warns(CovarianceRepairWarning, match="not positive semi-definite"):
        res = monte_carlo_probability(r1, v1, c1, r2, v2, c2, 52.84, samples=1000, seed=1)
    assert res.pc == 0.0
    with pytest.warns(CovarianceRepairWarning, match="not positive semi-definite"):
        with pytest.warns(UserWarning, match="none of the 1000 samples"):  # audit48
            assert collision_probability(r1, v1, c1, r2, v2, c2, 52.84, method="monte_carlo",
                                         samples=1000, seed=1) == 0.0


def test_monte_carlo_interval_covers_foster():
    args = _km_to_m(C2_R1, C2_V1, C2_C1, C2_R2, C2_V2, C2_C2)
    res = monte_carlo_probability(*args, 20.0, samples=400_000, seed=7)
    assert res.low <= 1.807363058494765e-01 <= res.high
    assert res.high - res.low < 0.01
    est = collision_probability(*args, 20.0, method="monte_carlo", samples=200_000, seed=1)
    assert est == pytest.approx(0.1807, abs=0.005)


def test_chan_close_to_foster_for_cara_case():
    args = _km_to_m(OM_R1, OM_V1, OM_C1, OM_R2, OM_V2, OM_C2)
    assert collision_probability(*args, 20.0, method="chan") == pytest.approx(OM_PC, rel=1e-3)


def test_3d_equals_foster_for_a_fast_encounter():
    args = _km_to_m(OM_R1, OM_V1, OM_C1, OM_R2, OM_V2, OM_C2)
    p3 = collision_probability(*args, 20.0, method="3d")
    assert p3 == pytest.approx(OM_PC, rel=1e-4)


@pytest.mark.parametrize("sig_x, sig_y, sig_z, miss, hbr", [
    (1000.0, 1.0, 100.0, 50.0, 20.0),  # 3d was 5e-4 of foster
    (300.0, 1.0, 300.0, 100.0, 10.0),  # 0.82 of foster
    (100.0, 0.1, 100.0, 10.0, 10.0),  # 4.5e-5 of foster
    (5.0, 1e-9, 5.0, 5.0, 20.0),  # clipped to 1e-4 HBR along u
])
def test_3d_equals_foster_for_a_covariance_thin_along_the_relative_velocity(sig_x, sig_y, sig_z,
                                                                            miss, hbr):
    # the rate is a spike ~ sigma_y / |u| wide; the time grid scaled with the largest sigma
    # stepped over it, and "3d" returned a Pc orders of magnitude low, silently (audit10)
    r1, v1 = np.array([7e6, 0.0, 0.0]), np.array([0.0, 7.5e3, 0.0])
    r2, v2 = r1 + [miss, 0.0, 0.0], np.array([0.0, 0.0, 7.5e3])
    axes = np.array([[1.0, 0, 0], [0, 1, -1], [0, 1, 1]]) / [[1.0], [math.sqrt(2)],
                                                               [math.sqrt(2)]]
    c1 = axes.T @ np.diag([sig_x, sig_y, sig_z]) ** 2 @ axes  # y along u = v1 - v2
    p2 = collision_probability(r1, v1, c1, r2, v2, c1 * 0, hbr)
    p3 = collision_probability(r1, v1, c1, r2, v2, c1 * 0, hbr, method="3d")
    assert p3 == pytest.approx(p2, rel=1e-6)


@pytest.mark.parametrize("miss", [1.0, 5.0, 15.0])
def test_probability_never_exceeds_one(miss):
    # a covariance of 1 mm inside a 20 m HBR: Foster gave 1.0000000000000782 (ln Pc > 0),
    # Alfano's maximum 1.0000000000000346 (audit10)
    r1, v1 = np.array([7e6, 0.0, 0.0]), np.array([0.0, 7.5e3, 0.0])
    r2, v2 = r1 + [miss, 0.0, 0.0], np.array([0.0, 0.0, 7.5e3])
    c = np.eye(3) * 1e-6
    for method in ("foster", "chan", "3d"):
        lp = collision_probability(r1, v1, c, r2, v2, c * 0, 20.0, method=method, log=True)
        assert -1e-7 < lp <= 0.0, method  # Chan: an approximation, 3e-8 off here
        assert collision_probability(r1, v1, c, r2, v2, c * 0, 20.0, method=method) <= 1.0
    assert 1.0 - 1e-12 < max_collision_probability(r1, v1, r2, v2, 20.0) <= 1.0


@pytest.mark.parametrize("kwargs, match", [
    ({"confidence": 1.5}, "confidence"),  # the interval was (nan, nan), silently
    ({"confidence": -1.0}, "confidence"),  # low 1, high 0
    ({"confidence": math.nan}, "confidence"),
    ({"samples": 2.7}, "whole number"),  # 2 samples, silently
    ({"samples": "many"}, "whole number"),  # int()'s ValueError
    ({"samples": math.nan}, "whole number"),
])
def test_monte_carlo_refuses_a_bad_level_or_sample_count(kwargs, match):
    args = _km_to_m(OM_R1, OM_V1, OM_C1, OM_R2, OM_V2, OM_C2)
    with pytest.raises(InvalidInputError, match=match):
        monte_carlo_probability(*args, 20.0, seed=1, **{"samples": 1000, **kwargs})


def test_zero_relative_velocity_points_to_the_method_that_handles_it():
    # the message sent users to method='3d' or 'monte_carlo', which refuse the same case
    r1, v1 = np.array([7e6, 0.0, 0.0]), np.array([0.0, 7.5e3, 0.0])
    c = np.diag([100.0, 400.0, 100.0, 1e-2, 1e-2, 1e-2])
    for method in ("foster", "chan", "3d", "monte_carlo"):
        with pytest.raises(InvalidInputError, match="pc3d_hall"):
            collision_probability(r1, v1, c, r1 + [10.0, 0, 0], v1, c, 5.0, method=method)
    # co-moving 10 m apart: the rate never falls off over the orbit, so the default window's
    # value (half an orbit either side) comes with a Pc3dWindowWarning naming window=
    from visviva import Pc3dWindowWarning

    with pytest.warns(Pc3dWindowWarning, match="window="):
        pc = collision_probability(r1, v1, c, r1 + [10.0, 0, 0], v1, c, 5.0, method="pc3d_hall")
    assert 0.0 < pc < 1.0


def test_alfano_max_probability_circular_limit():
    # circular covariance, R << d: Pc_max = R^2 / (e d^2) (Alfano 2005)
    r1, v1 = np.array([7e6, 0, 0.0]), np.array([0, 7.5e3, 0.0])
    r2, v2 = np.array([7e6 + 500.0, 0, 0]), np.array([0, 0, 7.5e3])
    pmax = max_collision_probability(r1, v1, r2, v2, 2.0)
    assert pmax == pytest.approx(4.0 / (math.e * 500.0**2), rel=1e-4)
    # and no covariance size gives more
    for s in (100.0, 353.55, 1000.0):
        c = np.eye(3) * s**2
        assert collision_probability(r1, v1, c, r2, v2, c * 0, 2.0) <= pmax * (1 + 1e-9)


def test_hbr_zero_and_infinite():
    args = _km_to_m(OM_R1, OM_V1, OM_C1, OM_R2, OM_V2, OM_C2)
    assert collision_probability(*args, 0.0) == 0.0
    assert collision_probability(*args, math.inf) == 1.0


def test_bad_inputs_raise_clear_errors():
    args = list(_km_to_m(OM_R1, OM_V1, OM_C1, OM_R2, OM_V2, OM_C2))
    with pytest.raises(InvalidInputError, match="method"):
        collision_probability(*args, 20.0, method="foo")
    with pytest.raises(InvalidInputError, match=">= 0"):
        collision_probability(*args, -1.0)
    bad = list(args)
    bad[0] = np.array([np.nan, 0, 0])
    with pytest.raises(InvalidInputError, match="NaN"):
        collision_probability(*bad, 20.0)
    bad = list(args)
    bad[2] = np.ones((4, 4))
    with pytest.raises(ShapeError, match="6x6 or 3x3"):
        collision_probability(*bad, 20.0)
    bad = list(args)
    bad[2] = np.array([[1.0, 2, 0], [0, 1, 0], [0, 0, 1]])
    with pytest.raises(InvalidInputError, match="symmetric"):
        collision_probability(*bad, 20.0)
    same = list(args)
    same[4] = same[1]
    with pytest.raises(InvalidInputError, match="relative velocity is zero"):
        collision_probability(*same, 20.0)
    with pytest.raises(u.UnitsError):
        collision_probability(OM_R1 * u.s, *args[1:], 20.0)


def test_six_by_six_uses_position_block():
    args = list(_km_to_m(OM_R1, OM_V1, OM_C1, OM_R2, OM_V2, OM_C2))
    for k in (2, 5):
        c6 = np.eye(6) * 1e-2
        c6[:3, :3] = args[k]
        args[k] = c6
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert collision_probability(*args, 20.0) == pytest.approx(OM_PC, rel=1e-10)


@pytest.mark.slow
def test_3d_agrees_with_two_body_monte_carlo_for_a_slow_encounter():
    """4 m/s relative speed, ~150 s encounter: sample both 6-D states, propagate each sample on
    its two-body orbit (universal variables) every 0.5 s, count minimum distances below the HBR."""
    from visviva.core.universal import propagate_many

    gm = 398600.4418
    r = 6878.0
    vc = math.sqrt(gm / r)
    r1, v1 = np.array([r, 0, 0]), np.array([0, vc, 0])
    r2, v2 = r1 + np.array([0.030, 0, 0]), v1 + np.array([0, 0, 0.004])
    c = np.diag([100.0**2, 300.0**2, 100.0**2, 0.05**2, 0.05**2, 0.05**2])
    p3 = collision_probability(r1 * 1e3, v1 * 1e3, c, r2 * 1e3, v2 * 1e3, c, 20.0, method="3d")
    rng = np.random.default_rng(1)
    n = 20_000
    chol = np.linalg.cholesky(c)
    states = []
    for r0, v0 in ((r1, v1), (r2, v2)):
        d = rng.standard_normal((n, 6)) @ chol.T * 1e-3
        states.append((r0 + d[:, :3], v0 + d[:, 3:]))
    dmin = np.full(n, np.inf)
    out = [(np.empty((n, 3)), np.empty((n, 3))) for _ in range(2)]
    st = np.empty(n, dtype=np.int64)
    gms = np.full(n, gm)
    for t in np.arange(-400.0, 400.5, 0.5):
        for (rs, vs), (ro, vo) in zip(states, out, strict=True):
            propagate_many(rs, vs, gms, np.full(n, t), ro, vo, st)
        dmin = np.minimum(dmin, np.linalg.norm(out[0][0] - out[1][0], axis=1) * 1e3)
    hits = np.count_nonzero(dmin < 20.0)
    assert abs(hits / n - p3) < 3 * math.sqrt(hits) / n


def test_3d_method_repairs_a_non_psd_covariance_in_3d_as_pc3d_hall_and_says_how_much():
    # it warned that "the encounter-plane covariance" was clipped (the 2-D methods' repair)
    # while the 3-D integral used the non-PSD 3x3 as given, dropping silently the times where
    # its variance along the relative velocity was <= 0
    r1, v1, c1, r2, v2, c2 = NPD_CASE
    with pytest.warns(CovarianceRepairWarning, match=r"not positive semi-definite, and the "
                      r"relative position covariance is not at \d+ of the 768 times .*smallest "
                      r"eigenvalue -\d.*Pc3D_Hall.*clipped to \(1e-4 HBR\)\^2 = 2\.792e-05 m\^2"):
        lp = collision_probability(r1, v1, c1, r2, v2, c2, 52.84, method="3d", log=True)
    assert -1e13 < lp < -1e9  # Pc = 0, as CARA and the 2-D methods give


def test_3d_clip_matches_cara_eigenvalue_clipping():
    from visviva.conjunctions.probability import _clip_3d

    rng = np.random.default_rng(7)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    cov = (q * [-5.0, 1e-9, 4e4]) @ q.T
    repairs = []
    fixed = _clip_3d(cov, 1e-6, repairs)
    assert np.allclose(np.linalg.eigvalsh(fixed), [1e-6, 1e-6, 4e4], rtol=1e-9, atol=1e-12)
    assert repairs == [pytest.approx((-5.0, 4e4))]
    # a positive-definite one is returned as it is (the same bits), and nothing is recorded
    good = (q * [2.0, 3.0, 4e4]) @ q.T
    assert _clip_3d(good, 1e-6, repairs) is good and len(repairs) == 1
