"""Every public name fixed by API.md, called exactly as an outside acceptance check would.

One test per section of API.md; the physics of each name is tested in depth in its own module.
"""

import math

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv

KM, KMS = u.km, u.km / u.s
ISS_TLE = (
    "1 25544U 98067A   19343.69339541  .00001764  00000-0  38792-4 0  9991",
    "2 25544  51.6439 211.2001 0007417  17.6667  85.6398 15.50103472202482",
)


def test_bodies_and_constants():
    planets = [vv.MERCURY, vv.VENUS, vv.EARTH, vv.MARS, vv.JUPITER, vv.SATURN, vv.URANUS,
               vv.NEPTUNE]
    for body in [vv.SUN, vv.MOON, *planets]:
        assert body.gm.unit.is_equivalent(u.km**3 / u.s**2) and body.gm.value > 0
        assert body.radius.unit.is_equivalent(u.km) and body.radius.value > 0
        assert isinstance(body.name, str)
    assert 1.08e-3 < vv.EARTH.j2 < 1.09e-3


def test_state_vectors_and_elements_round_trip():
    r = [[7000.0, 0.0, 0.0], [0.0, 42164.0, 0.0]] * KM
    v = [[0.0, 7.5, 1.0], [-3.07, 0.0, 0.0]] * KMS
    state = vv.StateVectors(r, v, vv.EARTH)
    assert state.r.shape == (2, 3) and state.v.unit.is_equivalent(KMS)
    assert state.gm.unit.is_equivalent(u.km**3 / u.s**2)
    elements = state.to_elements()
    assert isinstance(elements, vv.KeplerianElements)
    back = elements.to_state()
    np.testing.assert_allclose(back.r.to_value(KM), r.value, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(back.v.to_value(KMS), v.value, rtol=1e-12, atol=1e-12)
    for name in ("semi_latus_rectum", "semi_major_axis", "periapsis_distance",
                 "apoapsis_distance"):
        assert getattr(elements, name).unit.is_equivalent(KM)
    for name in ("inclination", "longitude_of_ascending_node", "argument_of_periapsis",
                 "true_anomaly", "mean_anomaly", "argument_of_latitude", "true_longitude",
                 "longitude_of_periapsis"):
        assert getattr(elements, name).unit.is_equivalent(u.rad), name
    assert elements.period.unit.is_equivalent(u.s)
    assert elements.mean_motion.unit.is_equivalent(u.rad / u.s)
    assert elements.specific_energy.unit.is_equivalent(u.km**2 / u.s**2)
    assert elements.specific_angular_momentum.unit.is_equivalent(u.km**2 / u.s)
    assert np.shape(elements.eccentricity) == (2,)


def test_exact_parabola_and_hyperbola_conventions():
    parabola = vv.KeplerianElements(7000 * KM, 1.0, 0.3, 0.1, 0.2, 0.5, vv.EARTH)
    assert np.isinf(parabola.semi_major_axis) and np.isinf(parabola.period)
    assert parabola.periapsis_distance.to_value(KM) == pytest.approx(3500.0)
    hyperbola = vv.KeplerianElements.from_semi_major_axis(-20000 * KM, 1.5, 0.3, 0.1, 0.2, 0.5,
                                                          vv.EARTH)
    assert hyperbola.semi_major_axis.to_value(KM) == pytest.approx(-20000.0)
    assert hyperbola.semi_latus_rectum.to_value(KM) == pytest.approx(25000.0)
    # propagation works on every conic, forwards and backwards
    for elements in (parabola, hyperbola):
        state = elements.to_state()
        home = state.propagate(3 * u.h).propagate(-3 * u.h)
        np.testing.assert_allclose(home.r.to_value(KM), state.r.to_value(KM), rtol=1e-12)


def test_equatorial_retrograde_round_trip_is_exact():
    state = vv.StateVectors([-7000.0, 0.0, 0.0] * KM, [0.0, 7.2, 0.0] * KMS, vv.EARTH)  # h along -z
    elements = state.to_elements()
    assert elements.inclination.to_value(u.rad) == pytest.approx(math.pi)
    np.testing.assert_allclose(elements.to_state().r.to_value(KM), [-7000.0, 0.0, 0.0],
                               atol=1e-9)


def test_propagate_broadcasts_times_against_states():
    state = vv.StateVectors([7000.0, 0.0, 0.0] * KM, [0.0, 7.5, 0.0] * KMS, vv.EARTH)
    later = state.propagate([-10.0, 0.0, 10.0, 20.0] * u.min)
    assert later.r.shape == (4, 3)
    np.testing.assert_array_equal(later.r[1].to_value(KM), [7000.0, 0.0, 0.0])


def test_anomalies():
    E = vv.solve_kepler(np.array([0.0, 1.0, 3.0]), 0.7)
    np.testing.assert_allclose(E - 0.7 * np.sin(E), [0.0, 1.0, 3.0], atol=1e-15)
    F = vv.solve_kepler_hyperbolic(np.array([0.5, 10.0]), 2.5)
    np.testing.assert_allclose(2.5 * np.sinh(F) - F, [0.5, 10.0], rtol=1e-14)
    for ecc in (0.0, 0.5, 1.0, 3.0):
        nu = vv.mean_to_true(0.4, ecc)
        assert vv.true_to_mean(nu, ecc) == pytest.approx(0.4, rel=1e-14)
    with pytest.raises(vv.VisvivaError):
        vv.solve_kepler(1.0, 1.5)


def test_central_force_names():
    assert vv.vis_viva(7000 * KM, 7000 * KM, vv.EARTH).to_value(KMS) == pytest.approx(
        math.sqrt(vv.EARTH.gm.value / 7000.0))
    assert vv.effective_potential(1.0, 1.0, lambda r: -1.0 / r) == -0.5
    orbit = vv.orbit_equation(lambda r: -1.0 / r**2, r0=1.0, h=0.9)
    assert orbit.apsidal_angle == pytest.approx(math.pi, abs=1e-9)


def test_nbody_simulation(tmp_path):
    sim = vv.Simulation(integrator="ias15", G=1.0)
    assert sim.add(1.0, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]) == 0
    assert sim.add(1e-3, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]) == 1
    e0 = sim.energy()
    sim.integrate(5.0)
    assert sim.t == 5.0
    assert sim.positions.shape == (2, 3) and sim.velocities.shape == (2, 3)
    assert sim.masses.shape == (2,)
    assert abs(sim.energy() / e0 - 1) < 1e-13
    assert np.shape(sim.angular_momentum()) == (3,)
    path = tmp_path / "sim.npz"
    sim.save(path)
    loaded = vv.Simulation.load(path)
    sim.integrate(9.0)
    loaded.integrate(9.0)
    np.testing.assert_array_equal(loaded.positions, sim.positions)
    rebound_sim = sim.to_rebound()
    again = vv.Simulation.from_rebound(rebound_sim)
    np.testing.assert_array_equal(again.positions, sim.positions)
    for name in ("leapfrog", "whfast"):
        vv.Simulation(integrator=name, dt=0.01)


def test_satellites_from_tle_and_omm():
    sat = vv.Satellite.from_tle(*ISS_TLE)
    assert isinstance(sat.epoch, Time)
    one = sat.teme(sat.epoch)
    assert one.r.unit.is_equivalent(KM) and one.v.unit.is_equivalent(KMS)
    many = sat.teme(np.arange(3) * u.min)
    assert many.r.shape == (3, 3)
    gcrs = sat.gcrs(sat.epoch + np.arange(2) * u.h)
    assert gcrs.r.shape == (2, 3)
    # the same orbit through OMM fields
    fields = {
        "OBJECT_NAME": "ISS (ZARYA)", "OBJECT_ID": "1998-067A", "EPOCH": "2019-12-09T16:38:29.363424",
        "MEAN_MOTION": 15.50103472, "ECCENTRICITY": 0.0007417, "INCLINATION": 51.6439,
        "RA_OF_ASC_NODE": 211.2001, "ARG_OF_PERICENTER": 17.6667, "MEAN_ANOMALY": 85.6398,
        "EPHEMERIS_TYPE": 0, "CLASSIFICATION_TYPE": "U", "NORAD_CAT_ID": 25544,
        "ELEMENT_SET_NO": 999, "REV_AT_EPOCH": 20248, "BSTAR": 3.8792e-05,
        "MEAN_MOTION_DOT": 1.764e-05, "MEAN_MOTION_DDOT": 0,
    }
    omm = vv.Satellite.from_omm(fields)
    np.testing.assert_allclose(omm.teme(30 * u.min).r.to_value(KM), sat.teme(30 * u.min).r.to_value(KM),
                               atol=1e-3)


def test_cowell_and_perturbations():
    state = vv.StateVectors([7000.0, 0.0, 0.0] * KM, [0.0, 5.3, 5.3] * KMS, vv.EARTH,
                            epoch=Time("2024-03-20T12:00:00", scale="utc"))
    t = np.linspace(0, 2, 5) * u.h
    two_body = vv.propagate_cowell(state, t)
    kepler = state.propagate(t)
    np.testing.assert_allclose(two_body.r.to_value(KM), kepler.r.to_value(KM), atol=1e-6)
    perturbations = [vv.J2(vv.EARTH), vv.Zonal(vv.EARTH, 4),
                     vv.AtmosphericDrag(0.01 * u.m**2 / u.kg), vv.ThirdBody(vv.SUN),
                     vv.ThirdBody(vv.MOON), vv.SolarRadiationPressure(0.02 * u.m**2 / u.kg)]
    for perturbation in perturbations:
        perturbed = vv.propagate_cowell(state, t, perturbations=[perturbation])
        assert perturbed.r.shape == (5, 3)
        assert np.all(np.isfinite(perturbed.r.value))


def test_lambert_arc_arrives():
    r1, r2, tof = [7000.0, 0.0, 0.0] * KM, [0.0, 8000.0, 1000.0] * KM, 1 * u.h
    v1, v2 = vv.lambert(r1, r2, tof, vv.EARTH, revolutions=0, prograde=True)
    arrival = vv.StateVectors(r1, v1, vv.EARTH).propagate(tof)
    np.testing.assert_allclose(arrival.r.to_value(KM), r2.value, atol=1e-6)
    np.testing.assert_allclose(arrival.v.to_value(KMS), v2.to_value(KMS), atol=1e-9)


def test_mechanics_names():
    from scipy.spatial.transform import Rotation

    from visviva import mechanics as m

    M, K = np.diag([1.0, 2.0]), np.array([[3.0, -1.0], [-1.0, 1.0]])
    omega, modes = m.normal_modes(M, K)
    assert np.all(np.diff(omega) > 0)
    np.testing.assert_allclose(modes.T @ M @ modes, np.eye(2), atol=1e-14)
    np.testing.assert_allclose(K @ modes, M @ modes * omega**2, atol=1e-13)
    t = np.linspace(0, 5, 7)
    for gamma in (0.1, 1.0, 3.0):  # under, critical, over
        x = m.damped_oscillator(1.0, 0.5, 1.0, gamma, t)
        assert x[0] == pytest.approx(1.0, abs=1e-15)
    v1, v2 = m.elastic_collision_1d(1.0, 2.0, 3.0, -1.0)
    assert 1.0 * v1 + 3.0 * v2 == pytest.approx(1.0 * 2.0 + 3.0 * -1.0)
    J, w1, w2 = m.collision_impulse(1.0, 2.0, [0, 0, 0], [1, 0, 0], [1, 0, 0], [0, 0, 0], 0.5)
    np.testing.assert_allclose(np.asarray(w1) * 1.0 + np.asarray(w2) * 2.0, [1.0, 0.0, 0.0])
    assert m.inertia_tensor([1.0, 1.0], [[1, 0, 0], [-1, 0, 0]]).shape == (3, 3)
    angles = (0.3, 1.1, -0.7)
    np.testing.assert_allclose(m.rotation_matrix_313(*angles),
                               Rotation.from_euler("ZXZ", angles).as_matrix(), atol=1e-15)
