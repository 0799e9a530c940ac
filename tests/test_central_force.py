"""Central-force tools against closed forms, published values and the Binet equation."""

import math

import numpy as np
import pytest
from astropy import units as u
from hypothesis import given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva.central_force import (
    apsides,
    areal_velocity,
    bertrand_apsidal_angle,
    circular_speed,
    effective_potential,
    escape_speed,
    kepler_potential,
    mean_motion,
    orbit_equation,
    orbital_period,
    power_law_force,
    semi_major_axis_from_period,
    specific_angular_momentum,
    specific_energy,
    turning_points,
)

MU = vv.EARTH.gm.to_value(u.km**3 / u.s**2)
KM = u.km
KMS = u.km / u.s


@settings(max_examples=200, deadline=None)
@given(
    r=st.floats(6400.0, 1e6),
    ecc=st.floats(0.0, 10.0).filter(lambda e: abs(e - 1.0) > 1e-6),
)
def test_vis_viva_is_the_energy_integral(r, ecc):
    # choose a orbit through r: r_p <= r (and r <= r_a for ellipses)
    r_p = r / (1.0 + ecc) if ecc < 1 else r / 2.0
    a = r_p / (1.0 - ecc)
    v = vv.vis_viva(r * KM, a * KM, vv.EARTH).to_value(KMS)
    energy = specific_energy(r * KM, v * KMS, vv.EARTH).to_value(u.km**2 / u.s**2)
    assert energy == pytest.approx(-MU / (2.0 * a), rel=1e-12, abs=1e-12 * MU / r)


def test_vis_viva_special_cases():
    r = np.array([7000.0, 8000.0]) * KM
    np.testing.assert_allclose(vv.vis_viva(r, r, vv.EARTH), circular_speed(r, vv.EARTH), rtol=1e-15)
    np.testing.assert_allclose(vv.vis_viva(r, np.inf * KM, vv.EARTH), escape_speed(r, vv.EARTH),
                               rtol=1e-15)
    # broadcasting over r and a
    assert vv.vis_viva(r[:, None], [7000.0, 9000.0, -20000.0] * KM, vv.EARTH).shape == (2, 3)


def test_published_values():
    # Earth's sidereal year from Kepler's third law with the Sun's GM: 365.256 d (a = 1.000001 au)
    year = orbital_period(1.00000102 * u.au, vv.SUN.gm + vv.EARTH.gm + vv.MOON.gm)
    assert year.to_value(u.day) == pytest.approx(365.2564, abs=2e-3)
    # geostationary radius 42,164 km (Vallado, sec. 2.2); sidereal day 86164.0905 s
    assert semi_major_axis_from_period(86164.0905 * u.s, vv.EARTH).to_value(KM) == pytest.approx(
        42164.17, abs=0.02
    )
    # escape speed at Earth's surface 11.18 km/s, circular LEO speed 7.9 km/s at the surface
    assert escape_speed(vv.EARTH.radius, vv.EARTH).to_value(KMS) == pytest.approx(11.18, abs=5e-3)
    assert circular_speed(vv.EARTH.radius, vv.EARTH).to_value(KMS) == pytest.approx(7.905, abs=5e-4)


@settings(max_examples=100, deadline=None)
@given(a=st.floats(1e3, 1e9), gm=st.floats(1.0, 1e12))
def test_third_law_round_trip(a, gm):
    T = orbital_period(a * KM, gm * u.km**3 / u.s**2)
    a_back = semi_major_axis_from_period(T, gm * u.km**3 / u.s**2).to_value(KM)
    assert a_back == pytest.approx(a, rel=4e-16 * 4)
    n = mean_motion(a * KM, gm * u.km**3 / u.s**2)
    assert (n * T).to_value(u.rad) == pytest.approx(2 * math.pi, rel=1e-15)


def test_apsides():
    r_p, r_a = apsides([7000.0, -7000.0] * KM, [0.1, 2.0])
    np.testing.assert_allclose(r_p.to_value(KM), [6300.0, 7000.0], rtol=1e-15)
    assert r_a[0].to_value(KM) == pytest.approx(7700.0, rel=1e-15) and np.isinf(r_a[1])
    with pytest.raises(vv.DomainError, match="p / 2"):
        apsides(7000 * KM, 1.0)
    with pytest.raises(vv.InvalidInputError, match="a must be > 0 for e < 1"):
        apsides(-7000 * KM, 0.5)


def test_angular_momentum_and_areal_velocity():
    r = [[7000.0, 0.0, 0.0], [0.0, 8000.0, 0.0]] * KM
    v = [[0.0, 7.5, 0.0], [-1.0, 0.0, 2.0]] * KMS
    h = specific_angular_momentum(r, v)
    np.testing.assert_allclose(h.to_value(u.km**2 / u.s), [[0, 0, 52500.0], [16000.0, 0, 8000.0]])
    np.testing.assert_allclose(areal_velocity(r, v).value, 0.5 * np.linalg.norm(h.value, axis=-1))


def test_effective_potential_minimum_is_the_circular_orbit():
    h = 52000.0 * u.km**2 / u.s
    r = np.geomspace(3000, 3e5, 20001) * KM
    veff = effective_potential(r, h, kepler_potential(vv.EARTH))
    i = np.argmin(veff)
    r_circ = (h**2 / vv.EARTH.gm).to(KM)
    assert r[i].to_value(KM) == pytest.approx(r_circ.value, rel=1e-3)
    assert veff[i].to_value(u.km**2 / u.s**2) == pytest.approx(
        -(MU**2) / (2 * h.value**2), rel=1e-6
    )
    # plain numbers in consistent units
    assert effective_potential(1.0, 1.0, kepler_potential(1.0)) == -0.5


@pytest.mark.parametrize("ecc", [0.0001, 0.3, 0.9, 0.999])
def test_turning_points_are_the_kepler_apsides(ecc):
    a = 20000.0
    p = a * (1 - ecc**2)
    h = math.sqrt(MU * p)
    energy = -MU / (2 * a)
    roots = turning_points(energy * u.km**2 / u.s**2, h * u.km**2 / u.s, kepler_potential(vv.EARTH),
                           1 * KM, 1e6 * KM)
    # near a double root (e -> 0) V_eff - E cancels: the roots carry ~eps/e relative error
    rtol = max(1e-12, 4 * np.finfo(float).eps / ecc)
    np.testing.assert_allclose(roots.to_value(KM), [a * (1 - ecc), a * (1 + ecc)], rtol=rtol)


def test_turning_points_below_a_barrier_top_are_found():
    # V = -1/r - beta/r^3 (the form of the relativistic correction): V_eff has a barrier. Just
    # below its top the two turning points are closer than the grid spacing and V_eff - E is
    # negative at every grid point: they must still be found (not an empty "no turning point").
    beta, h = 0.05, 1.0
    potential = lambda r: -1.0 / r - beta / r**3  # noqa: E731
    # V_eff' = 0: r^2 - h^2 r + 3 beta = 0, the barrier at the smaller root
    r_top = (h**2 - math.sqrt(h**4 - 12 * beta)) / 2
    e_top = h**2 / (2 * r_top**2) + potential(r_top)
    d2 = 3 * h**2 / r_top**4 - 2 / r_top**3 - 12 * beta / r_top**5  # V_eff'' < 0 at the top
    for d_e in (1e-6, 1e-9, 1e-11):
        roots = turning_points(e_top - d_e, h, potential, 0.05, 100.0)
        assert roots.size == 2
        half_width = math.sqrt(2 * d_e / -d2)  # V_eff ~ E_top + V''(r - r_top)^2 / 2
        np.testing.assert_allclose(roots, [r_top - half_width, r_top + half_width],
                                   rtol=0, atol=half_width * 1e-3 + 1e-12)
        np.testing.assert_allclose(effective_potential(roots, h, potential), e_top - d_e,
                                   rtol=0, atol=1e-13)


def test_binet_gravity_gives_the_conic():
    mu, h, r0 = 1.0, 0.8, 0.5  # start at periapsis: e = h^2/(mu r0) - 1
    ecc = h * h / (mu * r0) - 1.0
    orbit = orbit_equation(power_law_force(mu, -2), r0=r0, h=h, theta_max=6 * math.pi)
    p = h * h / mu
    np.testing.assert_allclose(orbit.r, p / (1 + ecc * np.cos(orbit.theta)), rtol=1e-10)
    assert orbit.apsidal_angle == pytest.approx(math.pi, abs=1e-9)
    assert orbit.is_closed()
    np.testing.assert_allclose(orbit.apsis_r[::2], r0, rtol=1e-10)


def test_binet_inverse_cube_term_has_the_exact_apsidal_angle():
    # F = -mu/r^2 - lam/r^3 gives u'' + (1 - lam/h^2) u = mu/h^2: apsidal angle pi/sqrt(1 - lam/h^2)
    mu, lam, h = 1.0, 0.05, 1.0
    orbit = orbit_equation(lambda r: -mu / r**2 - lam / r**3, r0=0.6, h=h, theta_max=20.0)
    exact = math.pi / math.sqrt(1.0 - lam / h**2)
    assert orbit.apsidal_angle == pytest.approx(exact, rel=1e-9)
    assert orbit.precession_per_orbit == pytest.approx(2 * exact - 2 * math.pi, rel=1e-8)
    assert not orbit.is_closed(tol=1e-6)


@pytest.mark.parametrize("n", [-2.0, 1.0])
def test_bertrand_closed_orbits_at_large_amplitude(n):
    # far from circular: the apsidal angle is still exactly pi (gravity) or pi/2 (Hooke)
    orbit = orbit_equation(power_law_force(1.0, n), r0=0.4, h=0.8, theta_max=4 * math.pi)
    assert orbit.apsidal_angle == pytest.approx(bertrand_apsidal_angle(n), rel=1e-9)
    assert orbit.is_closed()


@pytest.mark.parametrize("n", [-1.5, -0.5, 0.5, 2.0])
def test_near_circular_apsidal_angle_follows_bertrand(n):
    # circular radius for h: h^2 = k r^(n+3); start 1e-4 off it
    h = 1.0
    r_c = 1.0
    orbit = orbit_equation(lambda r: -(h**2) * r**n, r0=r_c * (1 + 1e-4), h=h, theta_max=12.0)
    assert orbit.apsidal_angle == pytest.approx(bertrand_apsidal_angle(n), rel=1e-3)
    assert not orbit.is_closed(max_turns=6, tol=1e-5)


def test_binet_with_quantities():
    orbit = orbit_equation(lambda r: -MU / r**2, r0=7000 * KM, h=55000 * u.km**2 / u.s)
    assert orbit.apsidal_angle == pytest.approx(math.pi, abs=1e-9)
    assert orbit.apsis_r.min() == pytest.approx(7000.0, rel=1e-12)


def test_bad_input_gets_clear_errors():
    with pytest.raises(vv.UnitsError, match="u.km"):
        vv.vis_viva(7000.0, 7000 * KM, vv.EARTH)
    with pytest.raises(vv.InvalidInputError, match="gm must be > 0"):
        circular_speed(7000 * KM, -1 * u.km**3 / u.s**2)
    with pytest.raises(vv.InvalidInputError, match="NaN"):
        escape_speed([7000, np.nan] * KM, vv.EARTH)
    with pytest.raises(vv.DomainError, match="beyond the apoapsis"):
        vv.vis_viva(20000 * KM, 7000 * KM, vv.EARTH)
    with pytest.raises(vv.DomainError, match="open"):
        orbital_period(-7000 * KM, vv.EARTH)
    with pytest.raises(vv.UnitsError, match="both as Quantities"):
        effective_potential(7000 * KM, 50000.0, kepler_potential(vv.EARTH))
    with pytest.raises(vv.DomainError, match="unbound"):
        orbit_equation(power_law_force(1.0, -2), r0=1.0, h=2.0, theta_max=10.0)
    with pytest.raises(vv.InvalidInputError, match="h must be finite and > 0"):
        orbit_equation(power_law_force(1.0, -2), r0=1.0, h=0.0)
    with pytest.raises(vv.InvalidInputError, match="radial"):  # audit43: h = 0 is named
        orbit_equation(power_law_force(1.0, -2), r0=1.0, h=0.0)
    with pytest.raises(vv.DomainError, match="n <= -3"):
        bertrand_apsidal_angle(-3.5)


def test_scalar_only_potential_gets_a_clear_error():
    # turning_points evaluates V on a whole grid: a callable using float(r) raised numpy's
    # "only 0-dimensional arrays can be converted" TypeError
    with pytest.raises(vv.InvalidInputError, match="vectorised"):
        turning_points(-0.3, 1.0, lambda r: -1.0 / float(r), 0.01, 100.0)
    roots = turning_points(-0.3, 1.0, np.vectorize(lambda r: -1.0 / float(r)), 0.01, 100.0)
    np.testing.assert_allclose(roots, [0.61257411, 2.72075922], rtol=1e-8)


def test_binet_orbit_matches_cartesian_integration_for_a_yukawa_force():
    # F = -(1 + r/lam) e^(-r/lam) / r^2 (screened gravity): no closed form. The Binet orbit r(theta)
    # must equal a Cartesian integration of r'' = F(r) r_hat (scipy DOP853, theta carried along
    # as theta' = h / r^2 and the samples located by root finding on it)
    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq

    lam = 2.0

    def force(r):
        return -(1.0 + r / lam) * math.exp(-r / lam) / r**2

    r0, h = 1.0, 0.75
    orbit = orbit_equation(force, r0=r0, h=h, theta_max=5 * math.pi, n_points=60)

    def rhs(_t, y):
        x, yy, vx, vy, _th = y
        r = math.hypot(x, yy)
        a = force(r) / r
        return [vx, vy, a * x, a * yy, h / r**2]

    sol = solve_ivp(rhs, (0, 60), [r0, 0, 0, h / r0, 0], method="DOP853", rtol=1e-13,
                    atol=1e-14, dense_output=True)
    assert sol.y[4, -1] > 5 * math.pi
    radii = []
    for theta in orbit.theta[1:]:
        t_hit = brentq(lambda t, th=theta: sol.sol(t)[4] - th, 0, 60, xtol=1e-14)
        x, yy = sol.sol(t_hit)[:2]
        radii.append(math.hypot(x, yy))
        assert math.atan2(yy, x) == pytest.approx(math.remainder(theta, 2 * math.pi), abs=1e-9)
    np.testing.assert_allclose(orbit.r[1:], radii, rtol=1e-10)


@pytest.mark.parametrize("lam", [1.0, 2.0, 10.0])  # stable circles need r/lam < 1.618
def test_near_circular_apsidal_angle_of_a_yukawa_force(lam):
    # textbook apsidal angle of a nearly circular orbit for ANY central force (Goldstein sec. 3.6,
    # problem 3.x): pi / sqrt(3 + d ln F / d ln r); for Yukawa d ln F / d ln r has a closed form,
    # -2 - (r/lam)^2 / (1 + r/lam)
    r_c = 1.3
    f_c = (1.0 + r_c / lam) * math.exp(-r_c / lam) / r_c**2
    h = math.sqrt(f_c * r_c**3)  # circular: h^2 / r^3 = |F|
    dlnf = -2.0 - (r_c / lam) ** 2 / (1.0 + r_c / lam)
    orbit = orbit_equation(lambda r: -(1.0 + r / lam) * math.exp(-r / lam) / r**2,
                           r0=r_c * (1 + 1e-5), h=h, theta_max=20.0)
    assert orbit.apsidal_angle == pytest.approx(math.pi / math.sqrt(3.0 + dlnf), rel=1e-7)


def test_quantity_potential_with_plain_radii_says_what_to_do():
    # audit19: the error said the potential's km3/s2 "cannot be converted to length" and
    # suggested "potential(r)=7000 * u.km"; it now says to give r and h as Quantities
    from visviva.errors import UnitsError

    V = kepler_potential(vv.EARTH)
    with pytest.raises(UnitsError, match="r and h as Quantities"):
        effective_potential(7000.0, 52000.0, V)
    with pytest.raises(UnitsError, match="r and h as Quantities"):
        turning_points(-20.0, 60000.0, V, 100.0, 1e6)
    # the same orbit with Quantities: a(1 -+ e) from E = -20 km2/s2, h = 60000 km2/s
    radii = turning_points(-20 * KM**2 / u.s**2, 60000 * KM**2 / u.s, V, 100 * KM, 1e6 * KM)
    a = MU / 40.0
    e = math.sqrt(1.0 - 60000.0**2 / (MU * a))
    np.testing.assert_allclose(radii.to_value(KM), [a * (1 - e), a * (1 + e)], rtol=1e-12)


@pytest.mark.parametrize("dh", [0.0, 1e-12, 1e-10, 1e-8])
def test_orbit_equation_parabola_and_just_unbound_raise(dh):
    # audit26: the parabola (h^2 = 2 mu r0 at periapsis) came back as a "closed" bound orbit
    # with apsidal angle pi and an apoapsis of 1e14 r0, and a hyperbola with e - 1 = 4e-8 as a
    # bound orbit with a NEGATIVE apoapsis: u = 1/r dips below 0 over an arc narrower than a step
    h = math.sqrt(2.0) * (1.0 + dh)
    with pytest.raises(vv.DomainError, match="escapes to r = infinity"):
        orbit_equation(power_law_force(1.0, -2), r0=1.0, h=h)


def test_orbit_equation_very_eccentric_bound_orbit_still_resolved():
    # e = 1 - 4e-10 just below the parabola: apoapsis h^2 / (1 - e) = 5e9 r0
    h = math.sqrt(2.0) * (1.0 - 1e-10)
    orbit = orbit_equation(power_law_force(1.0, -2), r0=1.0, h=h)
    e = h * h - 1.0
    np.testing.assert_allclose(orbit.apsis_r[1], h * h / (1.0 - e), rtol=1e-4)
    np.testing.assert_allclose(orbit.apsidal_angle, math.pi, rtol=1e-9)


def test_turning_points_plain_energy_refuses_quantity_interval():
    # audit26: a plain energy with r_min, r_max as Quantities read the interval in km whatever the
    # potential's units (1 m became 0.001), silently; effective_potential refuses such a mix
    with pytest.raises(vv.UnitsError, match="plain numbers"):
        turning_points(-0.3, 0.9, kepler_potential(1.0), 10 * u.m, 100 * u.km)
    np.testing.assert_allclose(turning_points(-0.3, 0.9, kepler_potential(1.0), 0.01, 100.0),
                               np.sort(np.roots([-0.6, 2.0, -0.81])), rtol=1e-13)


def test_orbit_equation_force_may_return_a_quantity():
    # audit26: a force returning a Quantity in km/s2 (or m/s2) was refused with "must return one
    # float"; it is converted now, and a wrong unit is named
    def force_m(r):
        return -MU * 1e3 / r**2 * u.m / u.s**2

    orbit = orbit_equation(force_m, r0=7000 * KM, h=55000 * u.km**2 / u.s)
    plain = orbit_equation(lambda r: -MU / r**2, r0=7000.0, h=55000.0)
    np.testing.assert_allclose(orbit.apsis_r, plain.apsis_r, rtol=1e-12)
    with pytest.raises(vv.UnitsError, match="km / s2"):
        orbit_equation(lambda r: -vv.EARTH.gm / r**2, r0=7000 * KM, h=55000 * u.km**2 / u.s)
    with pytest.raises(vv.UnitsError, match="plain numbers"):
        orbit_equation(force_m, r0=7000.0, h=55000.0)


def test_orbit_equation_plunge_into_the_centre_is_named():
    # audit43: F = -r^-4 with h = 0.5 from an apsis at r0 = 1 falls into r = 0 at a finite polar
    # angle; orbit_equation failed with scipy's "Required step size is less than spacing between
    # numbers" (an InvalidInputError about the inputs). The angle of the plunge follows from the
    # first integral of u'' + u = u^2 / h^2: u'^2 / 2 + u^2 / 2 - 4 u^3 / 3 = -5 / 6.
    from scipy.integrate import quad

    def dtheta(u_):
        return 1.0 / np.sqrt(2.0 * (-5.0 / 6.0 - u_ * u_ / 2.0 + 4.0 * u_**3 / 3.0))

    theta_plunge = quad(lambda s: 2.0 * s * dtheta(1.0 + s * s), 0.0, 1.0)[0]
    theta_plunge += quad(dtheta, 2.0, np.inf)[0]  # 1.59624222
    with pytest.raises(vv.DomainError, match="falls into the centre") as err:
        orbit_equation(power_law_force(1.0, -4), 1.0, 0.5, theta_max=10 * np.pi)
    reported = float(str(err.value).split("approaches ")[1].split(" rad")[0])
    assert reported == pytest.approx(theta_plunge, rel=1e-7)
    # before the plunge the orbit is returned, and r(theta) obeys the same first integral
    orbit = orbit_equation(power_law_force(1.0, -4), 1.0, 0.5, theta_max=1.5, n_points=4)
    u_s = 1.0 / orbit.r
    theta_exact = [quad(lambda s: 2.0 * s * dtheta(1.0 + s * s), 0.0, np.sqrt(x - 1.0))[0]
                   for x in u_s[1:]]
    np.testing.assert_allclose(theta_exact, orbit.theta[1:], rtol=1e-8)


# --- audit57: h^2 / (2 r^2) under/overflowed alone in scaled units --------------------------------
@pytest.mark.parametrize("s", [1e-160, 1e-170, 1e-200, 1e160, 1e200])
def test_turning_points_of_a_scaled_kepler_orbit(s):
    """Kepler ellipse a = s, e = 0.5, mu = s (speeds ~1): apsides at 0.5 s and 1.5 s.

    Before: h^2 and r^2 were formed separately, so for s = 1e-160 (h^2 subnormal) r_p came out
    0.50024 s (4.9e-4 off) and for s = 1e-170, 1e-200, 1e160 no turning point at all.
    """
    from visviva.central_force import effective_potential, turning_points

    h = s * math.sqrt(0.75)
    r = np.asarray(turning_points(-0.5, h, lambda r: -s / r, 0.1 * s, 10 * s))
    np.testing.assert_allclose(r / s, [0.5, 1.5], rtol=1e-12)
    # V_eff at the minimum r = h^2/mu = 0.75 s is -mu^2/(2 h^2) = -2/3
    assert effective_potential(0.75 * s, h, lambda r: -s / r) == pytest.approx(-2 / 3, rel=1e-14)


def test_speeds_do_not_underflow_or_overflow_through_gm_over_r():
    """audit57: gm / r was formed alone: circular_speed(1e300 km, 1e-300 km3/s2) gave 0 km/s
    (true 1e-300), vis_viva(1e200, -1e200, 1e-300) gave 0 (true sqrt(3) 1e-250) and
    escape_speed(1e-300 km, 1e10 km3/s2) raised an overflow (true sqrt(2) 1e155 km/s)."""
    from visviva.central_force import circular_speed, escape_speed, vis_viva

    GM = u.km**3 / u.s**2
    kms = u.km / u.s
    assert circular_speed(1e300 * u.km, 1e-300 * GM).to_value(kms) == pytest.approx(1e-300, rel=1e-15)
    assert vis_viva(1e200 * u.km, -1e200 * u.km, 1e-300 * GM).to_value(kms) == pytest.approx(
        math.sqrt(3) * 1e-250, rel=1e-15)
    assert escape_speed(1e-300 * u.km, 1e10 * GM).to_value(kms) == pytest.approx(
        math.sqrt(2) * 1e155, rel=1e-15)
    # ordinary values unchanged to rounding: LEO circular speed, vis-viva at perigee of a GTO
    assert circular_speed(6778 * u.km, vv.EARTH).to_value(kms) == pytest.approx(
        math.sqrt(vv.EARTH.gm.to_value(GM) / 6778), rel=2e-16)
    a, rp = 24396.0, 6578.0
    assert vis_viva(rp * u.km, a * u.km, vv.EARTH).to_value(kms) == pytest.approx(
        math.sqrt(vv.EARTH.gm.to_value(GM) * (2 / rp - 1 / a)), rel=4e-16)
