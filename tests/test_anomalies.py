"""Tests of the public anomaly layer (visviva.anomalies): published values, units, broadcasting,
typed errors, and hypothesis round trips mean -> true -> mean over every regime."""

from __future__ import annotations

import math

import numpy as np
import pytest
from astropy import units as u
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import visviva as vv

EPS = np.finfo(float).eps
GM_EARTH_KM3_S2 = 398600.4418


# ---------------------------------------------------------------------------------------------
# Published worked examples
# ---------------------------------------------------------------------------------------------
def test_vallado_example_2_1_elliptic():
    """Vallado (2013) Example 2-1: M = 235.4 deg, e = 0.4 -> E = 220.512074767522 deg."""
    E = vv.solve_kepler(235.4 * u.deg, 0.4)
    assert isinstance(E, u.Quantity) and E.unit == u.rad
    assert E.to_value(u.deg) == pytest.approx(220.512074767522, abs=1e-11)


def test_vallado_example_2_3_hyperbolic():
    """Vallado (2013) Example 2-3: M = 235.4 deg, e = 2.4 -> H = 1.601376144 rad.

    Vallado's iteration stops at a tolerance of 1e-8 (ours: 1.6013761449325)."""
    F = vv.solve_kepler_hyperbolic(235.4 * u.deg, 2.4)
    assert F.to_value(u.rad) == pytest.approx(1.601376144, abs=1e-8)
    assert vv.hyperbolic_to_mean(F, 2.4).to_value(u.deg) == pytest.approx(235.4, rel=4 * EPS)


def test_vallado_example_2_2_parabolic():
    """Vallado (2013) Example 2-2: p = 25512 km, dt = 53.7874 min -> B = 0.8178 (rounded)."""
    p_km = 25512.0
    M = 2.0 * math.sqrt(GM_EARTH_KM3_S2 / p_km**3) * 53.7874 * 60.0
    D = vv.solve_barker(M)
    assert D == pytest.approx(0.8178, abs=1e-4)
    assert D + D**3 / 3 == pytest.approx(M, rel=4 * EPS)


def test_curtis_examples():
    """Curtis, Orbital Mechanics for Engineering Students, worked examples of Ch. 3.

    Ellipse: e = 0.37255, M = 3.6029 rad (3 h after perigee) -> E = 3.4794 rad, nu = 193.2 deg.
    Parabola: M_p = 6.7737 (Curtis's M_p = D/2 + D^3/6, i.e. half of ours) -> nu = 144.75 deg.
    Hyperbola: e = 2.7696, nu = 100 deg -> F = 2.2927, M = 11.279; M = 40.690 -> F = 3.4631,
    nu = 107.78 deg.
    """
    assert vv.solve_kepler(3.6029, 0.37255) == pytest.approx(3.4794, abs=1e-4)
    assert math.degrees(vv.mean_to_true(3.6029, 0.37255)) == pytest.approx(193.2, abs=0.05)
    assert math.degrees(vv.mean_to_true(2 * 6.7737, 1.0)) == pytest.approx(144.75, abs=0.005)
    nu = 100 * u.deg
    assert vv.true_to_hyperbolic(nu, 2.7696).value == pytest.approx(2.2927, abs=1e-4)
    assert vv.true_to_mean(nu, 2.7696).value == pytest.approx(11.279, abs=1e-3)
    assert vv.solve_kepler_hyperbolic(40.690, 2.7696) == pytest.approx(3.4631, abs=1e-4)
    assert math.degrees(vv.mean_to_true(40.690, 2.7696)) == pytest.approx(107.78, abs=0.005)


# ---------------------------------------------------------------------------------------------
# Units, types and broadcasting
# ---------------------------------------------------------------------------------------------
def test_plain_in_plain_out_and_quantity_in_quantity_out():
    E = vv.solve_kepler(0.5, 0.1)
    assert isinstance(E, float) and not isinstance(E, u.Quantity)
    E_arr = vv.solve_kepler([0.5, 1.0], 0.1)
    assert isinstance(E_arr, np.ndarray) and E_arr.shape == (2,)
    E_q = vv.solve_kepler(0.5 * u.rad, 0.1)
    assert isinstance(E_q, u.Quantity) and E_q.unit == u.rad
    assert E_q.value == E
    # degrees are converted, result in rad
    E_deg = vv.solve_kepler(np.degrees(0.5) * u.deg, 0.1)
    assert E_deg.to_value(u.rad) == pytest.approx(E, rel=1e-15)
    # dimensionless Quantity eccentricity accepted
    assert vv.solve_kepler(0.5, 0.1 * u.one) == E


def test_broadcasting():
    M = np.linspace(-3, 3, 5)[:, None]
    ecc = np.array([0.0, 0.3, 0.9])
    E = vv.solve_kepler(M, ecc)
    assert E.shape == (5, 3)
    assert np.allclose(E - ecc * np.sin(E), M, atol=1e-15)
    nu = vv.mean_to_true(M, np.array([0.5, 1.0, 2.0]))
    assert nu.shape == (5, 3)
    back = vv.true_to_mean(nu, np.array([0.5, 1.0, 2.0]))
    assert np.allclose(back, np.broadcast_to(M, (5, 3)), rtol=1e-13, atol=1e-15)
    with pytest.raises(vv.ShapeError):
        vv.solve_kepler(np.zeros(3), np.zeros(2))


def test_conversion_helpers_are_inverse():
    E = np.linspace(-10, 10, 101)
    e = 0.7
    assert np.allclose(vv.true_to_eccentric(vv.eccentric_to_true(E, e), e), E, atol=1e-13)
    assert np.allclose(vv.eccentric_to_mean(vv.solve_kepler(E, e), e), E, atol=1e-13)
    F = np.linspace(-5, 5, 101)
    assert np.allclose(vv.true_to_hyperbolic(vv.hyperbolic_to_true(F, 1.5), 1.5), F, atol=1e-12)
    assert np.allclose(vv.solve_kepler_hyperbolic(vv.hyperbolic_to_mean(F, 1.5), 1.5), F)
    D = np.linspace(-30, 30, 101)
    assert np.allclose(vv.true_to_parabolic(vv.parabolic_to_true(D)), D, rtol=1e-13)


# ---------------------------------------------------------------------------------------------
# Typed errors with useful messages
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "call, exc, words",
    [
        (lambda: vv.solve_kepler(np.nan, 0.1), vv.InvalidInputError, "NaN"),
        (lambda: vv.solve_kepler(0.1, np.inf), vv.InvalidInputError, "NaN or infinite"),
        (lambda: vv.solve_kepler(0.1, -0.1), vv.DomainError, "solve_kepler_hyperbolic"),
        (lambda: vv.solve_kepler([0.1, 0.2], [0.5, 1.0]), vv.DomainError, "index (1,)"),
        (lambda: vv.solve_kepler_hyperbolic(0.1, 0.5), vv.DomainError, "e > 1"),
        (lambda: vv.solve_kepler_hyperbolic(0.1, 1.0), vv.DomainError, "mean_to_true"),
        (lambda: vv.mean_to_true(0.1, -1.0), vv.DomainError, "ecc=-1"),
        (lambda: vv.true_to_mean(2.5, 2.0), vv.InvalidElementsError, "arccos(-1/e)"),
        (lambda: vv.true_to_mean(np.pi, 1.0), vv.InvalidElementsError, "asymptote"),
        (lambda: vv.solve_kepler(1 * u.km, 0.1), vv.UnitsError, "angle"),
        (lambda: vv.eccentric_to_true(1.0, 1.0), vv.DomainError, "0 <= e < 1"),
    ],
)
def test_bad_input_raises_typed_error(call, exc, words):
    with pytest.raises(exc) as info:
        call()
    assert words in str(info.value)


def test_errors_are_builtin_subclasses():
    with pytest.raises(ValueError):
        vv.solve_kepler(0.1, 2.0)


# ---------------------------------------------------------------------------------------------
# Property tests over every regime
# ---------------------------------------------------------------------------------------------
SPECIAL_E = [
    0.0, 1e-300, 1e-12, 0.5, 0.9, 0.99, 0.999, 0.9999, 0.99999, 1 - 1e-10, 1 - 2.0**-53,
    1.0, 1 + 2.0**-52, 1 + 1e-10, 1.0001, 1.001, 1.01, 1.1, 2.0, 10.0, 1e3, 1e8,
]  # fmt: skip
eccentricities = st.one_of(
    st.sampled_from(SPECIAL_E),
    st.floats(0.0, 1.0, exclude_max=True),
    st.floats(1.0, 20.0),
    st.floats(20.0, 1e12),
)
mean_anomalies = st.one_of(
    st.sampled_from([0.0, -0.0, 5e-324, -5e-324, math.pi, -math.pi, 2 * math.pi, 1e-300]),
    st.floats(-1e-6, 1e-6),
    st.floats(-10.0, 10.0),
    st.floats(-1e6, 1e6),
    st.floats(-1e200, 1e200),
    st.floats(1e-300, 1e-10),
)


def _dM_dnu(M, ecc):
    """dM/dnu at the mean anomaly M: the conditioning of the maps between M and nu.

    Written with the eccentric / hyperbolic / parabolic anomaly from the solvers, which stays
    accurate next to the asymptote where 1 + e cos nu cancels:
    dM/dnu = (1 - e cos E)^2 / sqrt(1 - e^2), (e cosh F - 1)^2 / sqrt(e^2 - 1), (1 + D^2)^2 / 2.
    """
    if ecc < 1:
        E = vv.solve_kepler(M, ecc)
        g = (1.0 - ecc) + 2.0 * ecc * math.sin(0.5 * E) ** 2
        return g * g / math.sqrt((1.0 - ecc) * (1.0 + ecc))
    if ecc == 1:
        D = vv.solve_barker(M)
        return (1.0 + D * D) ** 2 / 2.0
    F = vv.solve_kepler_hyperbolic(M, ecc)
    if abs(F) > 700:
        return math.inf
    g = (ecc - 1.0) + 2.0 * ecc * math.sinh(0.5 * F) ** 2
    return g * g / math.sqrt((ecc - 1.0) * (ecc + 1.0))


TINY = 5e-324  # spacing of the subnormal numbers


@settings(max_examples=250, deadline=None)
@given(M=mean_anomalies, ecc=eccentricities)
def test_mean_true_mean_round_trip(M, ecc):
    if ecc < 1:
        assume(abs(M) <= 1e12)  # beyond, the reduction modulo 2 pi is meaningless anyway
    nu = vv.mean_to_true(M, ecc)
    assert np.isfinite(nu)
    if ecc >= 1:
        # far out on the hyperbola nu rounds onto the asymptote, which no body reaches
        assume(abs(nu) < math.acos(-1.0 / ecc))
    else:
        assert abs(nu - M) <= math.pi + 1e-9 * max(1.0, abs(M))  # same revolution
    assert math.copysign(1.0, nu) == math.copysign(1.0, M)
    # skip where one rounding of nu moves M by more than ~1e-6 M (next to the asymptote)
    slope = _dM_dnu(M, ecc)
    assume(slope * abs(nu) <= 1e10 * abs(M) or M == 0)
    M2 = vv.true_to_mean(nu, ecc)
    # nu carries a relative rounding error of a few eps; M inherits it through dM/dnu
    # (plus the spacing of subnormal anomalies scaled by dM/dF ~ e)
    tol = 16 * EPS * (abs(M) + slope * abs(nu)) + 4 * TINY * max(1.0, ecc, slope)
    assert abs(M2 - M) <= tol


true_fractions = st.one_of(
    st.floats(-0.999999, 0.999999), st.sampled_from([0.0, -0.0, 1e-300, 1e-9, 0.5, -0.9])
)


@settings(max_examples=250, deadline=None)
@given(frac=true_fractions, ecc=eccentricities)
def test_true_mean_true_round_trip(frac, ecc):
    limit = math.pi if ecc < 1 else math.acos(-1.0 / ecc)
    nu = frac * limit
    M = vv.true_to_mean(nu, ecc)
    assert math.copysign(1.0, M) == math.copysign(1.0, nu)
    nu2 = vv.mean_to_true(M, ecc)
    slope = _dM_dnu(M, ecc)
    # M carries a relative rounding error of a few eps (or the subnormal spacing); nu inherits
    # it through dnu/dM
    tol = 16 * EPS * abs(nu) + (16 * EPS * abs(M) + 4 * TINY) / slope + 2 * TINY
    assert abs(nu2 - nu) <= tol


@settings(max_examples=200, deadline=None)
@given(
    M=st.floats(-1e3, 1e3),
    e1=eccentricities,
    e2=eccentricities,
)
def test_true_anomaly_monotonic_in_time(M, e1, e2):
    """A later time (larger M) means a larger true anomaly, on every conic."""
    for ecc in (e1, e2):
        nu = vv.mean_to_true(np.array([M, M + 1e-3 * max(1.0, abs(M))]), ecc)
        assert nu[1] >= nu[0]


@settings(max_examples=200, deadline=None)
@given(Mp=st.floats(-1e4, 1e4), log_d=st.floats(-15.5, -3.0))
def test_mean_to_true_continuous_through_parabola(Mp, log_d):
    """At fixed time since periapsis (parabolic mean anomaly Mp), nu(e) is continuous at e = 1."""
    d = 10.0**log_d
    nu_p = vv.mean_to_true(Mp, 1.0)
    for ecc in (1.0 - d, 1.0 + d):
        M = Mp * abs((1.0 - ecc) * (1.0 + ecc)) ** 1.5 / 2.0
        nu = vv.mean_to_true(M, ecc)
        # |d nu / d e| is O(1) at fixed t (from the series of Farnocchia et al. 2013, eq. 17)
        assert abs(nu - nu_p) <= 4 * d * (1.0 + abs(Mp)) ** (2.0 / 3.0) + 1e-12


REGIMES = [0.0, 1e-12, 0.5, 0.9, 0.99, 0.999, 0.9999, 0.99999, 1 - 1e-10, 1.0, 1 + 1e-10,
           1.0001, 1.001, 1.01, 1.1, 2.0, 10.0, 1e4]  # fmt: skip


@pytest.mark.parametrize("ecc", REGIMES)
def test_regime_sweep_round_trip(ecc):
    """Dense sweep of M in every regime (vectorised): M -> nu -> M within the conditioning."""
    M = np.concatenate([-np.logspace(4, -300, 3000), [0.0], np.logspace(-300, 4, 3000)])
    nu = vv.mean_to_true(M, ecc)
    assert np.all(np.isfinite(nu)) and np.all(np.diff(nu) >= 0)  # monotonic in time
    if ecc >= 1:
        keep = np.abs(nu) < math.acos(-1.0 / ecc) - 1e-9
        M, nu = M[keep], nu[keep]
    M2 = vv.true_to_mean(nu, ecc)
    slope = np.array([_dM_dnu(m, ecc) for m in M])
    tol = 16 * EPS * (np.abs(M) + slope * np.abs(nu)) + 4 * TINY * max(1.0, ecc)
    assert np.all(np.abs(M2 - M) <= tol)


# --- robustness regressions (ROBUSTNESS_BUGS.md #15, #18) --------------------------------------
@pytest.mark.parametrize("M", [5e-324, 2.2250738585e-313, -1e-310, 1e-300])
@pytest.mark.parametrize("ecc", [1.0 + 1e-9, 1.5, 8.625763021194716])
def test_hyperbolic_tiny_and_subnormal_mean_anomaly(M, ecc):
    F = vv.solve_kepler_hyperbolic(M, ecc)
    assert F == pytest.approx(M / (ecc - 1.0), rel=4 * EPS, abs=1e-323)
    nu = vv.mean_to_true(M, ecc)
    gain = math.sqrt((ecc + 1) / (ecc - 1))  # nu ~ gain F; a subnormal F has fewer bits
    assert nu == pytest.approx(gain * F, rel=8 * EPS, abs=1e-322 * gain)


def test_hyperbolic_to_mean_overflow_is_named():
    with pytest.raises(vv.errors.DomainError, match="overflows float64"):
        vv.hyperbolic_to_mean(1e300, 2.0)


def test_a_list_of_angle_quantities_gives_a_quantity():
    # [10 * u.deg, 0.2 * u.rad] was converted correctly but came back as a plain ndarray,
    # unlike one Quantity (docs/conventions.md: Quantity in, Quantity in rad out)
    E = vv.solve_kepler([10 * u.deg, 0.2 * u.rad], 0.1)
    assert E.unit == u.rad
    np.testing.assert_allclose(E.value, vv.solve_kepler(np.array([np.radians(10), 0.2]), 0.1),
                               rtol=4e-16)
    assert vv.mean_to_true([30 * u.deg], 1.0).unit == u.rad
