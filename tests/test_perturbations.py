"""Perturbing accelerations: closed forms, potential gradients, models and the ephemeris."""

from __future__ import annotations

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv
from visviva.core.perturbations import (
    VALLADO_EXPONENTIAL_TABLE,
    accel_drag,
    accel_srp,
    accel_third_body,
    accel_zonal,
    exponential_density,
    shadow_fraction,
)
from visviva.satellites import ephemeris
from visviva.satellites.cowell import ForceModel
from visviva.satellites.perturbations import SOLAR_PRESSURE_1AU_N_M2

GM = vv.EARTH.gm_km3_s2
R = vv.EARTH.radius_km
AU = vv.constants.AU_KM
EPOCH = Time("2024-06-01T00:00:00", scale="utc")


def zonal_potential(r, degree):
    """U = -GM/r sum J_n (R/r)^n P_n(z/r) with numpy's Legendre polynomials."""
    x, y, z = r
    rn = np.sqrt(x * x + y * y + z * z)
    s = z / rn
    total = 0.0
    for n in range(2, degree + 1):
        c = np.zeros(n + 1)
        c[n] = 1.0
        total += vv.EARTH.jn(n) * (R / rn) ** n * np.polynomial.legendre.legval(s, c)
    return GM / rn * total  # perturbing potential (sign: a = grad of this)


def test_j2_matches_closed_form():
    r = np.array([4000.0, -3000.0, 5000.0])
    a = np.zeros(3)
    zonal = np.array([0.0, 0.0, vv.EARTH.j2])
    accel_zonal(*r, GM, R, zonal, 2, 0.0, 0.0, a)
    x, y, z = r
    rn = np.linalg.norm(r)
    k = -1.5 * vv.EARTH.j2 * GM * R**2 / rn**5
    expect = k * np.array([x * (1 - 5 * z**2 / rn**2), y * (1 - 5 * z**2 / rn**2),
                           z * (3 - 5 * z**2 / rn**2)])  # fmt: skip
    assert np.allclose(a, expect, rtol=1e-13, atol=0)


@pytest.mark.parametrize("degree", [3, 4, 6])
def test_zonal_is_the_gradient_of_its_potential(degree):
    r = np.array([-5200.0, 2100.0, 4300.0])
    zonal = np.array([0.0, 0.0] + [vv.EARTH.jn(n) for n in range(2, degree + 1)])
    a = np.zeros(3)
    accel_zonal(*r, GM, R, zonal, degree, 0.0, 0.0, a)
    h = 1e-3
    grad = np.array(
        [
            (zonal_potential(r + h * e, degree) - zonal_potential(r - h * e, degree)) / (2 * h)
            for e in np.eye(3)
        ]
    )
    # U here is +GM/r sum J_n ... P_n; the acceleration is -grad of that
    assert np.allclose(a, -grad, rtol=1e-6, atol=1e-15)


def test_exponential_table_values():
    for h0, rho0, _ in VALLADO_EXPONENTIAL_TABLE:
        assert exponential_density(h0, VALLADO_EXPONENTIAL_TABLE) == pytest.approx(rho0)
    # continuity is not guaranteed by the table, but neighbouring layers stay within 20 %
    for h0 in VALLADO_EXPONENTIAL_TABLE[1:, 0]:
        lo = exponential_density(h0 - 1e-9, VALLADO_EXPONENTIAL_TABLE)
        hi = exponential_density(h0, VALLADO_EXPONENTIAL_TABLE)
        assert abs(lo / hi - 1) < 0.2
    drag = vv.AtmosphericDrag(0.01 * u.m**2 / u.kg)
    assert drag.density(300 * u.km).to_value(u.kg / u.m**3) == pytest.approx(2.418e-11)


def test_drag_opposes_relative_velocity_with_textbook_magnitude():
    r = np.array([R + 400.0, 0.0, 0.0])
    v = np.array([0.0, 7.67, 0.0])
    omega = 7.292115e-5
    bc = 0.01e-6  # km^2/kg
    a = np.zeros(3)
    accel_drag(*r, *v, bc, omega, R, 0.0, VALLADO_EXPONENTIAL_TABLE, 0.0, 0.0, a)
    w = v - np.cross([0, 0, omega], r)
    rho = 3.725e-12 * 1e9  # kg/km^3 at 400 km
    expect = -0.5 * rho * bc * np.linalg.norm(w) * w
    assert np.allclose(a, expect, rtol=1e-12)


def test_third_body_tidal_formula_and_symmetry():
    a = np.zeros(3)
    b = np.array([384400.0, 0.0, 0.0])
    gm_m = vv.MOON.gm_km3_s2
    accel_third_body(0.0, 0.0, 0.0, *b, gm_m, a)
    assert np.allclose(a, 0.0, atol=1e-20)  # at the centre the tidal term vanishes
    a = np.zeros(3)
    accel_third_body(7000.0, 0.0, 0.0, *b, gm_m, a)
    # tidal approximation along the line of centres: 2 GM d / D^3
    assert a[0] == pytest.approx(2 * gm_m * 7000.0 / 384400.0**3, rel=0.06)


def test_srp_magnitude_at_one_au_and_shadow():
    a = np.zeros(3)
    coef = SOLAR_PRESSURE_1AU_N_M2 * 1.0 * 1.0 * 1e-3
    accel_srp(AU, 0.0, 0.0, 0.0, 0.0, 0.0, coef, AU, 1.0, a)
    assert np.allclose(a, [coef, 0, 0], rtol=1e-14)
    sun = np.array([AU, 0.0, 0.0])
    assert shadow_fraction(7000.0, 0.0, 0.0, *sun, R, 695700.0, 2) == 1.0
    assert shadow_fraction(-7000.0, 0.0, 0.0, *sun, R, 695700.0, 2) == 0.0
    assert shadow_fraction(-7000.0, 0.0, 0.0, *sun, R, 695700.0, 1) == 0.0
    # across the penumbra the visible fraction goes from 0 to 1 monotonically
    ys = np.linspace(R - 60, R + 60, 61)
    nus = [shadow_fraction(-7000.0, y, 0.0, *sun, R, 695700.0, 2) for y in ys]
    assert nus[0] == 0.0 and nus[-1] == 1.0
    assert np.all(np.diff(nus) >= 0)
    assert any(0 < n < 1 for n in nus)


def test_force_model_total_acceleration():
    state = vv.StateVectors([7000.0, 0, 0] * u.km, [0, 7.5, 0] * u.km / u.s, vv.EARTH, EPOCH)
    model = ForceModel(GM, [vv.ThirdBody(vv.SUN), vv.ThirdBody(vv.MOON)], (), EPOCH, (0, 3600))
    acc = model.acceleration(1800.0, state.r.value[None], state.v.value[None])[0]
    kepler = -GM * state.r.value / 7000.0**3
    pert = acc - kepler
    # luni-solar tidal accelerations in LEO: 1e-10 .. 1e-8 km/s^2
    assert 1e-10 < np.linalg.norm(pert) < 1e-8
    sun = ephemeris.sun_position(EPOCH + 1800 * u.s).to_value(u.km)
    moon = ephemeris.moon_position(EPOCH + 1800 * u.s).to_value(u.km)
    expect = np.zeros(3)
    accel_third_body(*state.r.value, *sun, vv.SUN.gm_km3_s2, expect)
    accel_third_body(*state.r.value, *moon, vv.MOON.gm_km3_s2, expect)
    # Hermite interpolation of the hourly table: relative error far below 1e-6
    assert np.allclose(pert, expect, rtol=1e-6, atol=1e-18)


def test_central_body_follows_the_state_gm():
    """A state around the Moon gets the Sun's tide relative to the Moon (it was relative to the
    Earth: 0.26 % off in direction and size, silently); a field of another body is refused."""
    gm_moon = vv.MOON.gm_km3_s2
    model = ForceModel(gm_moon, [vv.ThirdBody(vv.SUN)], (), EPOCH, (0, 3600))
    assert model.central_body.name == "moon"
    r = np.array([[2000.0, 300.0, -100.0]])
    acc = model.acceleration(1800.0, r, np.zeros((1, 3)))[0]
    pert = acc + gm_moon * r[0] / np.linalg.norm(r[0]) ** 3
    t = EPOCH + 1800 * u.s
    sun_from_moon = (ephemeris.sun_position(t) - ephemeris.moon_position(t)).to_value(u.km)
    expect = np.zeros(3)
    accel_third_body(*r[0], *sun_from_moon, vv.SUN.gm_km3_s2, expect)
    assert np.allclose(pert, expect, rtol=1e-6, atol=1e-20)
    with pytest.raises(vv.InvalidInputError, match="moon is the central body"):
        ForceModel(gm_moon, [vv.ThirdBody(vv.MOON)], (), EPOCH, (0, 3600))
    mars = vv.StateVectors([4000.0, 0, 0] * u.km, [0, 3.2, 0] * u.km / u.s, vv.MARS, EPOCH)
    with pytest.raises(vv.InvalidInputError, match=r"J2\(earth\) refers to earth.*is mars's"):
        vv.propagate_cowell(mars, 60 * u.s, [vv.J2(vv.EARTH)])


def test_ephemeris_agrees_with_astropy_builtin():
    """DE421 (jplephem) against astropy's built-in ERFA ephemeris: a few km."""
    from astropy.coordinates import get_body_barycentric, solar_system_ephemeris

    t = EPOCH + np.arange(4) * 30 * u.day
    with solar_system_ephemeris.set("builtin"):
        earth = get_body_barycentric("earth", t)
        s2 = (get_body_barycentric("sun", t) - earth).xyz.to_value(u.km).T
        m2 = (get_body_barycentric("moon", t) - earth).xyz.to_value(u.km).T
    assert np.linalg.norm(ephemeris.sun_position(t).to_value(u.km) - s2, axis=1).max() < 20
    assert np.linalg.norm(ephemeris.moon_position(t).to_value(u.km) - m2, axis=1).max() < 50
    r, v = ephemeris.planet_heliocentric("mars", EPOCH)
    assert 1.3 < np.linalg.norm(r.to_value(u.km)) / AU < 1.7
    assert 20 < np.linalg.norm(v.to_value(u.km / u.s)) < 27


def test_ephemeris_errors():
    with pytest.raises(vv.InvalidInputError, match="unknown body"):
        ephemeris.position_velocity("vulcan", EPOCH)
    with pytest.raises(vv.InvalidInputError, match="astropy Time"):
        ephemeris.sun_position(2451545.0)


def test_perturbation_reprs_and_bad_inputs():
    assert "J2(earth)" == repr(vv.J2(vv.EARTH))
    assert "degree=4" in repr(vv.Zonal(vv.EARTH, 4))
    assert "moon" in repr(vv.ThirdBody(vv.MOON))
    assert "Cr=1.3" in repr(vv.SolarRadiationPressure(0.01 * u.m**2 / u.kg))
    with pytest.raises(vv.InvalidInputError, match="shadow"):
        vv.SolarRadiationPressure(0.01 * u.m**2 / u.kg, shadow="square")
    with pytest.raises(vv.InvalidInputError, match="Cr"):
        vv.SolarRadiationPressure(0.01 * u.m**2 / u.kg, reflectivity=3.0)
    with pytest.raises(vv.InvalidInputError, match="area_to_mass"):
        vv.SolarRadiationPressure()
    with pytest.raises(vv.InvalidInputError, match="ThirdBody"):
        vv.ThirdBody("pluto_charon")


# ------------------------------------------------------------------ spherical harmonics

from visviva.core.perturbations import accel_harmonics  # noqa: E402

GFC_HEADER = """product_type gravity_field
modelname test_field_from_egm2008_low_degree
earth_gravity_constant 3.986004415E+14
radius 6378136.3
max_degree 4
norm fully_normalized
tide_system tide_free
key n m C S sigmaC sigmaS
end_of_head
"""
# fully normalised coefficients, rounded from EGM2008 (Pavlis et al. 2012)
GFC_ROWS = [
    (0, 0, 1.0, 0.0),
    (2, 0, -4.84165143790815e-04, 0.0),
    (2, 1, -2.06615509074176e-10, 1.38441389137979e-09),
    (2, 2, 2.43938357328313e-06, -1.40027370385934e-06),
    (3, 0, 9.57161207093473e-07, 0.0),
    (3, 1, 2.03046201047864e-06, 2.48200415856872e-07),
    (3, 2, 9.04787894809528e-07, -6.19005475177618e-07),
    (3, 3, 7.21321757121568e-07, 1.41434926192941e-06),
    (4, 0, 5.39965866638991e-07, 0.0),
    (4, 1, -5.36157389388867e-07, -4.73567346518086e-07),
    (4, 2, 3.50501623962649e-07, 6.62480026275829e-07),
    (4, 3, 9.90856766672321e-07, -2.00956723567452e-07),
    (4, 4, -1.88519633023033e-07, 3.08803882149194e-07),
]


@pytest.fixture
def gfc_file(tmp_path):
    path = tmp_path / "field.gfc"
    lines = [f"gfc {n} {m} {c:.15e} {s:.15e} 0 0" for n, m, c, s in GFC_ROWS]
    path.write_text(GFC_HEADER + "\n".join(lines) + "\n")
    return path


def test_gfc_reading_and_normalisation(gfc_file):
    from visviva.satellites.perturbations import SphericalHarmonics

    field = SphericalHarmonics(gfc_file)
    assert field.degree == 4
    # unnormalised C20 = -J2 = sqrt(5) * C20bar
    assert field.coefficients[0, 2, 0] == pytest.approx(np.sqrt(5) * -4.84165143790815e-4)
    # C22 = sqrt(2 * 5 * 0! / 4!) C22bar
    assert field.coefficients[0, 2, 2] == pytest.approx(np.sqrt(10 / 24) * 2.43938357328313e-6)
    assert SphericalHarmonics(gfc_file, degree=3).coefficients.shape == (2, 5, 5)
    with pytest.raises(vv.InvalidInputError, match="degree"):
        SphericalHarmonics(gfc_file, degree=7)


def test_bad_gfc_file(tmp_path):
    from visviva.satellites.perturbations import SphericalHarmonics

    bad = tmp_path / "bad.gfc"
    bad.write_text("hello\n")
    with pytest.raises(vv.InvalidInputError, match="ICGEM"):
        SphericalHarmonics(bad)
    with pytest.raises(vv.InvalidInputError, match="cannot read"):
        SphericalHarmonics(tmp_path / "missing.gfc")


def test_harmonics_zonal_part_equals_zonal_kernel():
    sh = np.zeros((2, 6, 6))
    for n in range(2, 5):
        sh[0, n, 0] = -vv.EARTH.jn(n)
    r = np.array([-5200.0, 2100.0, 4300.0])
    a = np.zeros(3)
    accel_harmonics(*r, GM, R, sh, 4, a)
    b = np.zeros(3)
    accel_zonal(*r, GM, R, np.array([0, 0] + [vv.EARTH.jn(n) for n in range(2, 5)]), 4, 0.0, 0.0, b)
    assert np.allclose(a, b, rtol=1e-12, atol=1e-20)


def test_harmonics_are_the_gradient_of_the_potential(gfc_file):
    from scipy.special import lpmv

    from visviva.satellites.perturbations import SphericalHarmonics

    sh = SphericalHarmonics(gfc_file).scaled(GM, R)

    def potential(p):
        x, y, z = p
        r = np.sqrt(x * x + y * y + z * z)
        lon = np.arctan2(y, x)
        s = z / r
        total = 0.0
        for n in range(2, 5):
            for m in range(n + 1):
                pnm = (-1) ** m * lpmv(m, n, s)  # remove the Condon-Shortley phase
                total += (R / r) ** n * pnm * (sh[0, n, m] * np.cos(m * lon)
                                                + sh[1, n, m] * np.sin(m * lon))  # fmt: skip
        return GM / r * total

    p = np.array([3100.0, -4700.0, 4200.0])
    a = np.zeros(3)
    accel_harmonics(*p, GM, R, sh, 4, a)
    h = 1e-2
    grad = np.array([(potential(p + h * e) - potential(p - h * e)) / (2 * h) for e in np.eye(3)])
    assert np.allclose(a, grad, rtol=1e-6, atol=1e-16)


def test_cowell_with_gfc_field(gfc_file):
    from visviva.satellites import propagate_cowell
    from visviva.satellites.perturbations import SphericalHarmonics

    state = vv.StateVectors([7000.0, 0, 0] * u.km, [0, 5.0, 5.8] * u.km / u.s, vv.EARTH, EPOCH)
    t = np.linspace(0, 1, 5) * u.day
    field = propagate_cowell(state, t, [SphericalHarmonics(gfc_file)])
    zonal = propagate_cowell(state, t, [vv.Zonal(vv.EARTH, 4)])
    d = np.linalg.norm((field.r - zonal.r).to_value(u.km), axis=1)
    # tesseral terms and the true pole (precession since J2000) move the orbit by metres to km
    assert 1e-3 < d[-1] < 20.0
    with pytest.raises(vv.InvalidInputError, match="one gravity field"):
        propagate_cowell(state, t, [SphericalHarmonics(gfc_file), vv.J2(vv.EARTH)])


# ------------------------------------------------------------------ NRLMSIS drag


def test_nrlmsis_grid_matches_pymsis_and_decays():
    pytest.importorskip("pymsis")
    from pymsis import msis

    from visviva.core.perturbations import grid_density_at
    from visviva.satellites import propagate_cowell
    from visviva.satellites.frames import gcrs_to_itrs, itrs_to_geodetic

    drag = vv.AtmosphericDrag(
        0.02 * u.m**2 / u.kg, model="nrlmsis", f107=150.0, f107a=150.0, ap=4.0
    )
    model = ForceModel(GM, [drag], (), EPOCH, (0.0, 3600.0))
    sun = ephemeris.sun_position(EPOCH).to_value(u.km)
    rng = np.random.default_rng(3)
    n = 400
    r = rng.normal(size=(n, 3))
    r *= ((R + rng.uniform(150.0, 900.0, n)) / np.linalg.norm(r, axis=1))[:, None]
    # NRLMSIS at each point's own WGS-84 geodetic latitude, longitude and height (pymsis
    # takes geodetic coordinates; one fly-through call)
    ri = np.array([gcrs_to_itrs(x, np.zeros(3), EPOCH)[0] for x in r])
    lat, lon, h = itrs_to_geodetic(ri * u.km)
    ref = msis.run(np.full(n, np.datetime64(EPOCH.utc.isot[:19])), lon.value, lat.value, h.value,
                   f107s=np.full(n, 150.0), f107as=np.full(n, 150.0),
                   aps=np.full((n, 7), 4.0))[:, 0]  # fmt: skip
    rho = np.array([grid_density_at(0.0, *x, sun, model.force, model.atm) for x in r])
    # tricubic B-spline of ln(rho) on 10 km x 5 deg x 15 deg, read at the exact geodetic
    # latitude and the hour angle about the Earth's pole: 3.1e-4 at most (1000 points; before
    # the eighteenth session, first order in f about GCRS z: 3.7e-3); trilinear, before: 1.7e-2;
    # the geocentric latitude read on the geodetic grid (audit21): 8.0e-3
    err = np.abs(rho / ref - 1)
    assert err.max() < 1e-3 and np.median(err) < 1e-4
    state = vv.KeplerianElements.from_semi_major_axis(
        (R + 400) * u.km, 0.0, 51.6 * u.deg, 0, 0, 0, vv.EARTH, epoch=EPOCH
    ).to_state()
    out = propagate_cowell(state, np.linspace(0, 1, 25) * u.day, [drag])
    r = np.linalg.norm(out.r.to_value(u.km), axis=1)
    v = np.linalg.norm(out.v.to_value(u.km / u.s), axis=1)
    energy = 0.5 * v**2 - GM / r
    assert np.all(np.diff(energy) < 0)
    da = -GM / (2 * energy[-1]) + GM / (2 * energy[0])
    assert -2.0 < da < -0.05  # km per day at 400 km, moderate activity


def test_nrlmsis_needs_indices():
    with pytest.raises(vv.InvalidInputError, match="space-weather"):
        vv.AtmosphericDrag(0.02 * u.m**2 / u.kg, model="nrlmsis")
    with pytest.raises(vv.InvalidInputError, match="model"):
        vv.AtmosphericDrag(0.02 * u.m**2 / u.kg, model="jacchia")


def test_force_block_layout_tiles_the_block_and_every_slot_has_one_writer():
    from visviva.core import force_block as fb
    from visviva.satellites import perturbations as pm
    from visviva.satellites.cowell import ForceModel

    covered = []
    for name, first, size, unit, meaning in fb.LAYOUT:
        assert getattr(fb, name) == first and size >= 1 and meaning and isinstance(unit, str)
        covered.extend(range(first, first + size))
    assert covered == list(range(fb.FORCE_SIZE))  # in order, no gap, no overlap
    from visviva.satellites.burns import FiniteBurn
    from visviva.satellites.relativity import Relativity

    classes = [pm.Zonal, pm.AtmosphericDrag, pm.ThirdBody, pm.SolarRadiationPressure,
               pm.SphericalHarmonics, Relativity]
    writers = list(ForceModel.SHARED_PARAMETERS) + list(FiniteBurn.PARAMETERS)
    for cls in classes:
        assert cls.PARAMETERS, cls
        assert [row[0] for row in cls.parameters()] == list(cls.PARAMETERS)
        writers.extend(cls.PARAMETERS)
    assert sorted(writers) == sorted(row[0] for row in fb.LAYOUT)
    assert pm.J2.PARAMETERS == pm.Zonal.PARAMETERS


def test_each_perturbation_writes_only_its_own_slots():
    from visviva.core import force_block as fb
    from visviva.satellites.cowell import ForceModel

    epoch = Time("2024-03-01T00:00:00", scale="utc")
    base = ForceModel(vv.EARTH.gm_km3_s2, [], epoch=epoch).force
    rows = {row[0]: row for row in fb.LAYOUT}
    for p in (vv.Zonal(vv.EARTH, 4), vv.AtmosphericDrag(0.02 * u.m**2 / u.kg),
              vv.SolarRadiationPressure(area_to_mass=0.02 * u.m**2 / u.kg), vv.Relativity()):
        force = ForceModel(vv.EARTH.gm_km3_s2, [p], epoch=epoch, span_s=(0.0, 600.0)).force
        own = set()
        for name in type(p).PARAMETERS:
            own.update(range(rows[name][1], rows[name][1] + rows[name][2]))
        shared = set()
        for name in ForceModel.SHARED_PARAMETERS:
            shared.update(range(rows[name][1], rows[name][1] + rows[name][2]))
        # the slots only: the pole's table after them is the force model's (shared POLE)
        changed = {int(i) for i in np.flatnonzero(force[:fb.FORCE_SIZE] != base[:fb.FORCE_SIZE])}
        assert changed - shared <= own, (p, changed)
        assert changed & own, p


def test_nrlmsis_drag_from_an_epoch_in_a_leap_second():
    """Was ValueError 'Seconds out of range in datetime string "2016-12-31T23:59:60"'."""
    pytest.importorskip("pymsis")
    drag = vv.AtmosphericDrag(0.02 * u.m**2 / u.kg, model="nrlmsis", f107=150.0, f107a=150.0,
                              ap=4.0)
    leap = Time("2016-12-31T23:59:60.5", scale="utc")
    state = vv.KeplerianElements.from_semi_major_axis(
        (R + 400) * u.km, 0.0, 51.6 * u.deg, 0, 0, 0, vv.EARTH, epoch=leap).to_state()
    out = vv.propagate_cowell(state, 600 * u.s, [drag])
    # the same state a second later: the same arc (the atmosphere barely turns in a second)
    later = vv.propagate_cowell(
        vv.StateVectors(state.r, state.v, vv.EARTH, epoch=leap + 1 * u.s), 600 * u.s, [drag])
    kepler = state.propagate(600 * u.s)
    assert np.linalg.norm((out.r - later.r).to_value(u.km)) < 1e-5
    assert 0 < np.linalg.norm((out.r - kepler.r).to_value(u.km)) < 1.0  # drag acts, a little


def _msis_spline(sun_longitude=0.3):
    """The NRLMSIS spline table at EPOCH, the Sun at ``sun_longitude`` (rad, ITRS), in a force
    block of its own."""
    from visviva.core import force_block as fb

    drag = vv.AtmosphericDrag(0.02 * u.m**2 / u.kg, model="nrlmsis", f107=150.0, f107a=150.0,
                              ap=4.0)  # fmt: skip
    table, meta = drag.msis_grid(EPOCH, sun_longitude)
    force = np.zeros(fb.FORCE_SIZE)
    force[fb.RADIUS] = R
    force[fb.FLATTENING] = vv.constants.EARTH_FLATTENING
    force[fb.ELLIPSOID_RADIUS] = vv.constants.EARTH_ELLIPSOID_RADIUS_KM
    force[fb.DENSITY_GRID:fb.DENSITY_GRID_SIZES + 3] = meta
    return force, table


def test_nrlmsis_spline_passes_through_pymsis_at_the_grid_nodes():
    # the spline interpolates: at every node it is NRLMSIS itself (checks the layout of the
    # coefficients: hour-angle wrap, the poles, the altitude margin)
    pytest.importorskip("pymsis")
    from pymsis import msis

    from visviva.core.perturbations import grid_log_density

    force, table = _msis_spline(0.3)
    rng = np.random.default_rng(5)
    hours = rng.integers(-12, 12, 12) * 15.0
    lats = np.r_[-90.0, 90.0, rng.integers(-17, 18, 10) * 5.0]
    alts = np.r_[80.0, 1000.0, rng.integers(8, 100, 10) * 10.0]
    ref = msis.run(np.array([np.datetime64(EPOCH.utc.isot[:19])]),
                   np.mod(np.degrees(0.3) + hours + 180.0, 360.0) - 180.0, lats, alts,
                   f107s=[150.0], f107as=[150.0], aps=[[4.0] * 7], version=2.1)[0, ..., 0].astype(float)  # fmt: skip
    for i, ha in enumerate(np.radians(hours)):
        for j, lat in enumerate(np.radians(lats)):
            for k, h in enumerate(alts):
                val = grid_log_density(h, lat, ha, force, table)[0]
                assert abs(val - np.log(ref[i, j, k])) < 1e-9


def test_nrlmsis_spline_value_and_gradient_are_continuous_across_cell_faces():
    # C2: on both sides of a cell face (1e-9 of a cell away) the value and all three partials
    # agree to round-off (the trilinear table, before, had slope jumps of 1e-2 relative); the
    # analytic partials equal central differences of the value
    pytest.importorskip("pymsis")
    from visviva.core.perturbations import grid_log_density

    force, table = _msis_spline(0.3)
    steps = np.array([10.0, np.radians(5.0), np.radians(15.0)])
    rng = np.random.default_rng(11)
    for _ in range(30):
        x = np.array([rng.uniform(150.0, 900.0), rng.uniform(-1.5, 1.5), rng.uniform(-3.1, 3.1)])
        axis = rng.integers(3)
        start = (80.0, -np.pi / 2, -np.pi)[axis]
        x[axis] = start + steps[axis] * np.round((x[axis] - start) / steps[axis])
        lo, hi = x.copy(), x.copy()
        lo[axis] -= 1e-9 * steps[axis]
        hi[axis] += 1e-9 * steps[axis]
        a = np.array(grid_log_density(*lo, force, table))
        b = np.array(grid_log_density(*hi, force, table))
        scale = np.abs(a[1:]) * steps + 1e-3  # each partial times its cell size
        # the value moves by the slope times the 2e-9 cells between the two points
        assert abs(b[0] - a[0] - a[1 + axis] * 2e-9 * steps[axis]) < 1e-12
        assert np.all(np.abs(a[1:] - b[1:]) * steps < 1e-7 * scale.max())
        for j in range(3):
            d = np.zeros(3)
            d[j] = 1e-4 * steps[j]
            up = grid_log_density(*(x + d), force, table)[0]
            down = grid_log_density(*(x - d), force, table)[0]
            fd = (up - down) / (2 * d[j])
            assert abs(fd - grid_log_density(*x, force, table)[1 + j]) * steps[j] < 1e-7


def test_nrlmsis_spline_gradient_in_space_matches_differences_and_is_continuous_at_the_pole():
    # the position gradient of ln(rho) (chain rule through altitude, latitude, hour angle)
    # equals central differences of 1 m; across the pole (the meridian continues on the
    # opposite hour angle) the value is continuous, and the horizontal gradient, which a
    # tensor spline in (latitude, hour angle) leaves slightly direction-dependent at the pole
    # point itself, differs by 1.4 % of the vertical one 1 m either side (measured)
    pytest.importorskip("pymsis")
    from visviva.core.perturbations import grid_log_density_gradient_at

    force, table = _msis_spline(0.3)
    sun = np.array([1.0e8, 0.4e8, 0.2e8])
    z = R * (1 - vv.constants.EARTH_FLATTENING) + 400.0
    g1, g2, g = np.zeros(3), np.zeros(3), np.zeros(3)
    v1 = grid_log_density_gradient_at(0.0, 1e-3, 2e-4, z, sun, force, table, g1)
    v2 = grid_log_density_gradient_at(0.0, -1e-3, -2e-4, z, sun, force, table, g2)
    assert abs(v1 - v2) < 2.1e-3 * np.abs(g1).max()
    assert np.abs(g1 - g2).max() < 0.03 * np.abs(g1).max()
    # near the pole, mid-latitude 400 km, 1200 km and 50 km (beyond the grid: extrapolated)
    for pos in ([30.0, 20.0, z - 1.0], [300.0, -200.0, z - 20.0], [5000.0, 3000.0, 3000.0],
                [-7000.0, 2500.0, -1200.0], [4560.0, 3040.0, 3340.0]):  # fmt: skip
        pos = np.array(pos)
        grid_log_density_gradient_at(0.0, *pos, sun, force, table, g)
        for j in range(3):
            d = np.zeros(3)
            d[j] = 1e-3
            up = grid_log_density_gradient_at(0.0, *(pos + d), sun, force, table, np.zeros(3))
            down = grid_log_density_gradient_at(0.0, *(pos - d), sun, force, table, np.zeros(3))
            assert abs((up - down) / 2e-3 - g[j]) < 1e-7 * np.abs(g).max()
    # an integer position is accepted
    assert grid_log_density_gradient_at(0.0, 6778, 0, 0, sun, force, table, g) == pytest.approx(
        grid_log_density_gradient_at(0.0, 6778.0, 0.0, 0.0, sun, force, table, g), abs=1e-12)


def test_nrlmsis_density_beyond_the_grid_continues_exponentially():
    # above 1000 km and below the ground (the table starts at 0 km since audit42, 80 km
    # before) ln(rho) continues linearly with the end slope
    pytest.importorskip("pymsis")
    from visviva.core.perturbations import grid_log_density

    force, table = _msis_spline(0.3)
    for edge, beyond in ((1000.0, 1150.0), (0.0, -5.0)):
        val, slope, _, _ = grid_log_density(edge, 0.2, 0.5, force, table)
        out = grid_log_density(beyond, 0.2, 0.5, force, table)
        assert slope < 0
        assert out[0] == pytest.approx(val + slope * (beyond - edge), abs=1e-12)
        assert out[1] == slope


def test_nrlmsis_drag_day_at_default_tolerances_matches_a_fine_step_run():
    # the smooth (C2) density lets the step control see the force: a LEO day at 300 km at the
    # default tolerances is within a few mm of max_step = 5 s at rtol 1e-13 (measured 0.2 mm;
    # the trilinear table, before: 3.0 m)
    pytest.importorskip("pymsis")
    drag = [vv.AtmosphericDrag(0.05 * u.m**2 / u.kg, model="nrlmsis", f107=150.0, f107a=150.0,
                               ap=4.0)]  # fmt: skip
    state = vv.KeplerianElements.from_semi_major_axis(
        (R + 300.0) * u.km, 0.001, 51.6 * u.deg, 0.3, 0.2, 0.1, vv.EARTH, epoch=EPOCH
    ).to_state()
    a = vv.propagate_cowell(state, 1 * u.day, [drag[0]])
    b = vv.propagate_cowell(state, 1 * u.day, drag, rtol=1e-13, max_step=5 * u.s)
    kepler = state.propagate(1 * u.day)
    assert np.linalg.norm((a.r - b.r).to_value(u.m)) < 5e-3
    assert np.linalg.norm((a.r - kepler.r).to_value(u.km)) > 1.0  # drag matters here


@pytest.mark.parametrize("kwargs", [
    {"area_to_mass": [0.02, 0.03] * u.m**2 / u.kg},
    {"area_to_mass": 0.02 * u.m**2 / u.kg, "reflectivity": [1.2, 1.5]},
])
def test_srp_with_arrays_is_refused_with_a_clear_error(kwargs):
    # float() of the array raised "TypeError: only 0-dimensional arrays can be converted to
    # Python scalars" (audit of 2026-11-26); AtmosphericDrag already said what to do
    with pytest.raises(vv.InvalidInputError, match="must be scalars"):
        vv.SolarRadiationPressure(**kwargs)


def test_drag_about_another_body_needs_its_own_atmosphere():
    """audit21: AtmosphericDrag(bc, body=vv.MOON) flew the Moon through the Earth's atmosphere
    (Vallado's table): a 100 km lunar orbit hit the ground within an hour, silently."""
    from visviva.bodies import MARS, MOON

    for body in (MOON, MARS, "mars"):
        with pytest.raises(vv.InvalidInputError, match="the Earth's atmosphere, not"):
            vv.AtmosphericDrag(0.02 * u.m**2 / u.kg, body=body)
    with pytest.raises(vv.InvalidInputError, match="NRLMSIS is the Earth's atmosphere"):
        vv.AtmosphericDrag(0.02 * u.m**2 / u.kg, body=MARS, model="nrlmsis", f107=150,
                           f107a=150, ap=4)
    # a body's own table is used as given: a Mars orbit decays by the predicted amount,
    # da = -rho B sqrt(GM a) dt (circular orbit, an atmosphere at rest: Mars has no rotation
    # rate here), with a constant density of 1e-11 kg/m^3 over one orbit
    drag = vv.AtmosphericDrag(0.02 * u.m**2 / u.kg, body=MARS, table=[[0.0, 1e-11, 1e9]])
    assert drag.body is MARS
    a0 = MARS.radius_km + 300.0
    state = vv.KeplerianElements.from_semi_major_axis(a0 * u.km, 0.0, 0.5, 0, 0, 0,
                                                      MARS).to_state()
    period = 2 * np.pi * np.sqrt(a0**3 / MARS.gm_km3_s2)
    out = vv.propagate_cowell(state, [0.0, period] * u.s, [drag])
    a = out.to_states().to_elements().semi_major_axis.to_value(u.km)
    expected = -1e-11 * 1e9 * 0.02e-6 * np.sqrt(MARS.gm_km3_s2 * a0) * period
    assert a[1] - a[0] == pytest.approx(expected, rel=1e-3)


@pytest.mark.parametrize("shadow", ["conical", "cylindrical", None])
def test_srp_about_the_sun_is_never_in_the_suns_own_shadow(shadow):
    """audit21: a heliocentric state with SolarRadiationPressure(body=vv.SUN) and the default
    conical shadow sat in the umbra of the Sun itself (the occulting body at the light's
    source): no SRP at all (0.2 km after 30 days of a sail's 213,000 km; 0 km cylindrical)."""
    from scipy.integrate import solve_ivp

    from visviva.constants import AU_KM

    epoch = Time("2024-03-01T00:00:00", scale="utc")
    state = vv.KeplerianElements.from_semi_major_axis(
        1.0 * u.AU, 0.0167, 0.0, 0, 0, 0, vv.SUN, epoch=epoch).to_state()
    srp = vv.SolarRadiationPressure(10 * u.m**2 / u.kg, shadow=shadow, body=vv.SUN)
    assert srp.shadow is None
    t = 30 * 86400.0
    out = vv.propagate_cowell(state, t * u.s, [srp])
    gm = vv.SUN.gm_km3_s2
    k = SOLAR_PRESSURE_1AU_N_M2 * 1.3 * 10.0 * 1e-3 * AU_KM**2  # km^3/s^2, pushing outward

    def rhs(_, y):
        r = np.linalg.norm(y[:3])
        return np.concatenate([y[3:], (k - gm) * y[:3] / r**3])

    y0 = np.concatenate([state.r.to_value(u.km), state.v.to_value(u.km / u.s)])
    ref = solve_ivp(rhs, (0.0, t), y0, method="DOP853", rtol=1e-12, atol=1e-6).y[:3, -1]
    kepler = state.propagate(t * u.s).r.to_value(u.km)
    assert np.linalg.norm(ref - kepler) > 1e5  # the sail's push: ~2e5 km in a month
    assert np.linalg.norm(out.r.to_value(u.km) - ref) < 1e-3


def _cip_in_gcrs(epoch):
    """The Earth's rotation axis (the CIRS z axis) as a GCRS unit vector, through astropy's
    frame graph (independent of visviva's ERFA call)."""
    from astropy.coordinates import CIRS, GCRS, CartesianRepresentation

    z = CIRS(CartesianRepresentation(0.0, 0.0, 1.0, unit=u.km), obstime=epoch)
    g = z.transform_to(GCRS(obstime=epoch)).cartesian.xyz.to_value(u.km)
    return g / np.linalg.norm(g)


@pytest.mark.parametrize("inc_deg", [51.6, 98.0])
def test_zonal_harmonics_are_about_the_earths_pole_not_the_gcrs_z_axis(inc_deg):
    """The zonal field is symmetric about the Earth's axis, 0.134 deg from the GCRS z axis in
    2024 (precession since J2000). J2/Zonal used the GCRS z axis: a LEO state was 2.1 km
    (51.6 deg) and 3.8 km (98 deg) off after a day, 116 m and 252 m after one orbit, silently
    (SphericalHarmonics, which rotates GCRS -> ITRS, had it right). Reference: scipy's DOP853
    with J2..J4 written out about astropy's CIRS pole."""
    from scipy.integrate import solve_ivp

    epoch = Time("2024-03-01T00:00:00", scale="utc")
    el = vv.KeplerianElements.from_semi_major_axis(
        6878.0 * u.km, 0.001, inc_deg * u.deg, 0.3, 0.2, 0.1, vv.EARTH, epoch=epoch)
    state = el.to_state()
    pole = _cip_in_gcrs(epoch)
    assert np.degrees(np.arccos(pole[2])) == pytest.approx(0.134, abs=0.001)
    jn = {n: vv.EARTH.jn(n) for n in (2, 3, 4)}

    def rhs(t, y):
        r = y[:3]
        rn = np.linalg.norm(r)
        s = r @ pole / rn
        p = [1.0, s, 1.5 * s * s - 0.5, 2.5 * s**3 - 1.5 * s, (35 * s**4 - 30 * s * s + 3) / 8]
        dp = [0.0, 1.0, 3.0 * s, 7.5 * s * s - 1.5, (140 * s**3 - 60 * s) / 8]
        radial = sum(jn[n] * (R / rn) ** n * ((n + 1) * p[n] + s * dp[n]) for n in jn)
        axial = sum(jn[n] * (R / rn) ** n * dp[n] for n in jn)
        a = -GM * r / rn**3 + GM / rn**2 * (radial * r / rn - axial * pole)
        return np.r_[y[3:], a]

    t_end = 5700.0  # one orbit
    y0 = np.r_[state.r.to_value(u.km), state.v.to_value(u.km / u.s)]
    ref = solve_ivp(rhs, (0.0, t_end), y0, method="DOP853", rtol=1e-12, atol=1e-12).y[:3, -1]
    out = vv.propagate_cowell(state, t_end * u.s, [vv.Zonal(vv.EARTH, 4)])
    assert np.linalg.norm(out.r.to_value(u.km) - ref) < 2e-5  # 2 cm (was 116 m and 252 m)


def test_zonal_pole_is_the_same_in_runs_from_other_epochs():
    """Runs from other epochs (after a burn, from a fit's state, backwards) see the same pole at
    the same instant: its knots are fixed in absolute time (0h TT), and it follows the
    precession-nutation series (ERFA xys06a) to 0.003" between them."""
    import erfa

    from visviva.core import force_block as fb
    from visviva.core.geodetic import body_pole
    from visviva.satellites.cowell import ForceModel

    epoch = Time("2024-03-01T05:00:00", scale="utc")
    first = ForceModel(GM, [vv.J2(vv.EARTH)], epoch=epoch, span_s=(-43200.0, 86400.0))
    later = ForceModel(GM, [vv.J2(vv.EARTH)], epoch=epoch + 6 * u.h, span_s=(0.0, 3600.0))
    shifted = fb.with_time_origin(first.force, 6 * 3600.0)
    for dt in (-30000.0, 0.0, 9000.0, 50000.0):  # s after epoch + 6 h
        a = np.array(body_pole(dt + 21600.0, first.force))
        b = np.array(body_pole(dt, later.force))
        c = np.array(body_pole(dt, shifted))
        assert np.abs(a - b).max() < 1e-15 and np.abs(a - c).max() < 1e-15
        tt = (epoch + (dt + 21600.0) * u.s).tt
        x, y, _ = erfa.xys06a(tt.jd1, tt.jd2)
        assert np.hypot(a[0] - x, a[1] - y) < 1.5e-8  # rad (0.003")
    assert np.degrees(np.arcsin(np.hypot(*a))) == pytest.approx(0.134, abs=0.001)
    # without an epoch the frame's z axis, as before
    plain = ForceModel(GM, [vv.J2(vv.EARTH)])
    assert not plain.force[fb.POLE:fb.POLE + 4].any()
    assert body_pole(100.0, plain.force) == (0.0, 0.0)
