"""KeplerianElements and ModifiedEquinoctialElements: published worked examples, agreement with
Skyfield, every conic, derived elements, validation."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from astropy import units as u
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import visviva as vv

DATA = json.loads((Path(__file__).parent / "data" / "textbook_examples.json").read_text())
KM = u.km
KMS = u.km / u.s
GM_UNIT = u.km**3 / u.s**2
MU = 398600.4418 * GM_UNIT
PI = math.pi
TWO_PI = 2 * PI
ONE_MM = 1e-6  # km


def deg(q):
    return float(q.to_value(u.deg))


def ang_diff(a, b):
    d = np.mod(np.asarray(a) - np.asarray(b) + PI, TWO_PI) - PI
    return np.abs(d)


# ---------------------------------------------------------------------------------------------
# published worked examples
# ---------------------------------------------------------------------------------------------
def vallado_2_5():
    ex = DATA["vallado_ex2_5_rv_to_elements"]
    s = vv.StateVectors(ex["inputs"]["r"] * KM, ex["inputs"]["v"] * KMS, ex["mu"] * GM_UNIT)
    return ex, s, s.to_elements()


def test_vallado_example_2_5_published():
    ex, s, el = vallado_2_5()
    pub, tol = ex["published"], ex["tol_published"]
    assert el.semi_latus_rectum.to_value(KM) == pytest.approx(pub["p"], abs=tol["p"])
    assert el.semi_major_axis.to_value(KM) == pytest.approx(pub["a"], abs=tol["a"])
    assert el.eccentricity == pytest.approx(pub["e"], abs=tol["e"])
    assert deg(el.inclination) == pytest.approx(pub["i"], abs=tol["i"])
    assert deg(el.longitude_of_ascending_node) == pytest.approx(pub["raan"], abs=tol["raan"])
    assert deg(el.argument_of_periapsis) == pytest.approx(pub["argp"], abs=tol["argp"])
    assert deg(el.true_anomaly) == pytest.approx(pub["nu"], abs=tol["nu"])
    # Vallado's "true longitude of periapsis" is the angle from x to the eccentricity vector
    ev = s.eccentricity_vector
    lon_per = math.degrees(math.acos(ev[0] / np.linalg.norm(ev)))
    lon_per = 360 - lon_per if ev[1] < 0 else lon_per
    assert lon_per == pytest.approx(pub["lon_periapsis_true"], abs=tol["lon_periapsis_true"])


def test_vallado_example_2_5_full_precision():
    ex, s, el = vallado_2_5()
    c = ex["computed"]
    rel, ang = ex["tol_computed"]["rel"], ex["tol_computed"]["angles"]
    assert el.specific_angular_momentum.value == pytest.approx(c["h"], rel=rel)
    assert el.semi_latus_rectum.value == pytest.approx(c["p"], rel=rel)
    assert el.semi_major_axis.value == pytest.approx(c["a"], rel=rel)
    assert el.eccentricity == pytest.approx(c["e"], rel=rel)
    assert deg(el.inclination) == pytest.approx(c["i"], abs=ang)
    assert deg(el.longitude_of_ascending_node) == pytest.approx(c["raan"], abs=ang)
    assert deg(el.argument_of_periapsis) == pytest.approx(c["argp"], abs=ang)
    assert deg(el.true_anomaly) == pytest.approx(c["nu"], abs=ang)
    assert deg(el.argument_of_latitude) == pytest.approx(c["arg_latitude"], abs=ang)
    assert deg(el.mean_anomaly) == pytest.approx(c["mean_anomaly"], abs=ang)
    assert el.specific_energy.value == pytest.approx(c["energy_km2_s2"], rel=rel)
    assert el.period.to_value(u.s) == pytest.approx(c["period_s"], rel=rel)
    assert s.radius.value == pytest.approx(c["rmag"], rel=rel)
    assert s.speed.value == pytest.approx(c["vmag"], rel=rel)
    back = el.to_state()
    assert np.abs((back.r - s.r).to_value(KM)).max() < 1e-11
    assert np.abs((back.v - s.v).to_value(KMS)).max() < 1e-14


def test_curtis_example_4_3_state_to_elements():
    """Curtis, *Orbital Mechanics for Engineering Students*, 3rd ed. (2014), Example 4.3
    (mu = 398600 km3/s2); printed values rounded to 4 significant figures."""
    s = vv.StateVectors(
        [-6045.0, -3490.0, 2500.0] * KM, [-3.457, 6.618, 2.533] * KMS, 398600.0 * GM_UNIT
    )
    el = s.to_elements()
    assert el.specific_angular_momentum.to_value(u.km**2 / u.s) == pytest.approx(58310, abs=5)
    assert el.eccentricity == pytest.approx(0.1712, abs=5e-5)
    assert deg(el.inclination) == pytest.approx(153.2, abs=0.05)
    assert deg(el.longitude_of_ascending_node) == pytest.approx(255.3, abs=0.05)
    assert deg(el.argument_of_periapsis) == pytest.approx(20.07, abs=0.005)
    assert deg(el.true_anomaly) == pytest.approx(28.45, abs=0.005)
    assert el.periapsis_distance.to_value(KM) == pytest.approx(7284, abs=1)
    assert el.apoapsis_distance.to_value(KM) == pytest.approx(10290, abs=5)
    assert el.semi_major_axis.to_value(KM) == pytest.approx(8788, abs=0.5)


def test_curtis_example_4_7_elements_to_state():
    """Curtis (2014), Example 4.7: h = 80000 km2/s, e = 1.4, i = 30, raan = 40, argp = 60,
    nu = 30 deg (a hyperbola) -> r = (-4040, 4815, 3629) km, v = (-10.39, -4.772, 1.744) km/s."""
    p = 80000.0**2 / 398600.0
    el = vv.KeplerianElements(
        p * KM, 1.4, 30 * u.deg, 40 * u.deg, 60 * u.deg, 30 * u.deg, 398600.0 * GM_UNIT
    )
    s = el.to_state()
    np.testing.assert_allclose(s.r.to_value(KM), [-4040, 4815, 3629], atol=0.5)
    np.testing.assert_allclose(s.v.to_value(KMS), [-10.39, -4.772, 1.744], atol=5e-3)
    assert el.semi_major_axis.value < 0 and el.period.value == np.inf


# ---------------------------------------------------------------------------------------------
# agreement with Skyfield
# ---------------------------------------------------------------------------------------------
def random_nondegenerate_states(n, seed):
    rng = np.random.default_rng(seed)
    r = rng.normal(size=(4 * n, 3)) * 10000.0
    v = rng.normal(size=(4 * n, 3)) * 4.0
    s = vv.StateVectors(r * KM, v * KMS, MU)
    el = s.to_elements()
    e = el.eccentricity
    i = el.inclination.value
    p_over_r = el.semi_latus_rectum.value / s.radius.value
    ok = (((e > 0.01) & (e < 0.99)) | ((e > 1.01) & (e < 10))) & (np.sin(i) > 0.01)
    ok &= p_over_r > 0.01
    idx = np.flatnonzero(ok)[:n]
    return r[idx], v[idx]


def test_agrees_with_skyfield_osculating_elements():
    from skyfield.elementslib import OsculatingElements
    from skyfield.units import Distance, Velocity

    r, v = random_nondegenerate_states(2000, seed=7)
    mu = MU.value
    sky = OsculatingElements(Distance(km=r.T), Velocity(km_per_s=v.T), None, mu)
    el = vv.StateVectors(r * KM, v * KMS, MU).to_elements()
    rel = 1e-10
    np.testing.assert_allclose(el.semi_latus_rectum.value, sky.semi_latus_rectum.km, rtol=rel)
    np.testing.assert_allclose(el.eccentricity, sky.eccentricity, rtol=rel)
    np.testing.assert_allclose(el.semi_major_axis.value, sky.semi_major_axis.km, rtol=rel)
    np.testing.assert_allclose(el.periapsis_distance.value, sky.periapsis_distance.km, rtol=rel)
    ell = el.eccentricity < 1
    np.testing.assert_allclose(
        el.apoapsis_distance.value[ell], sky.apoapsis_distance.km[ell], rtol=rel
    )
    np.testing.assert_allclose(el.period.to_value(u.day)[ell], sky.period_in_days[ell], rtol=rel)
    np.testing.assert_allclose(
        el.mean_motion.to_value(u.rad / u.day), sky.mean_motion_per_day.radians, rtol=rel
    )
    for ours, theirs in [
        (el.inclination, sky.inclination),
        (el.longitude_of_ascending_node, sky.longitude_of_ascending_node),
        (el.argument_of_periapsis, sky.argument_of_periapsis),
        (el.true_anomaly, sky.true_anomaly),
        (el.argument_of_latitude, sky.argument_of_latitude),
        (el.true_longitude, sky.true_longitude),
        (el.longitude_of_periapsis, sky.longitude_of_periapsis),
        (el.mean_anomaly, sky.mean_anomaly),
    ]:
        assert ang_diff(ours.to_value(u.rad), theirs.radians).max() < 1e-10


def test_to_state_agrees_with_skyfield_ele_to_vec():
    from skyfield.keplerlib import ele_to_vec

    r, v = random_nondegenerate_states(2000, seed=8)
    el = vv.StateVectors(r * KM, v * KMS, MU).to_elements()
    R, V = ele_to_vec(
        el.semi_latus_rectum.value,
        el.eccentricity,
        el.inclination.value,
        el.longitude_of_ascending_node.value,
        el.argument_of_periapsis.value,
        el.true_anomaly.value,
        MU.value,
    )
    s = el.to_state()
    scale_r = np.linalg.norm(r, axis=-1)[:, None]
    scale_v = np.linalg.norm(v, axis=-1)[:, None]
    assert (np.abs(s.r.value - R.T) / scale_r).max() < 1e-10
    assert (np.abs(s.v.value - V.T) / scale_v).max() < 1e-10


# ---------------------------------------------------------------------------------------------
# every conic: derived elements
# ---------------------------------------------------------------------------------------------
def test_derived_elements_every_conic():
    p = 10000.0
    el = vv.KeplerianElements(p * KM, [0.0, 0.5, 1.0, 2.0], 0.3, 0.2, 0.1, 0.4, MU)
    a = el.semi_major_axis.to_value(KM)
    assert a[0] == p and a[1] == pytest.approx(p / 0.75) and a[2] == np.inf
    assert a[3] == pytest.approx(-p / 3)
    assert list(el.apoapsis_distance.value[2:]) == [np.inf, np.inf]
    assert el.apoapsis_distance.value[1] == pytest.approx(p / 0.5)
    assert list(el.period.value[2:]) == [np.inf, np.inf]
    assert el.periapsis_distance.value == pytest.approx(p / np.array([1, 1.5, 2, 3]))
    n = el.mean_motion.to_value(u.rad / u.s)
    assert n[2] == pytest.approx(2 * math.sqrt(MU.value / p**3))
    assert n[1] == pytest.approx(math.sqrt(MU.value / a[1] ** 3))
    assert n[3] == pytest.approx(math.sqrt(MU.value / abs(a[3]) ** 3))
    assert el.period.value[1] == pytest.approx(TWO_PI / n[1])
    assert el.specific_energy.value[2] == 0.0
    assert el.specific_energy.value[0] == pytest.approx(-MU.value / (2 * p))
    assert el.specific_angular_momentum.value == pytest.approx(math.sqrt(MU.value * p))
    # mean anomaly conventions: E - e sin E, D + D^3/3, e sinh F - F
    M = el.mean_anomaly.to_value(u.rad)
    nu = 0.4
    E = 2 * math.atan(math.sqrt(0.5 / 1.5) * math.tan(nu / 2))
    assert M[1] == pytest.approx(E - 0.5 * math.sin(E), rel=1e-14)
    D = math.tan(nu / 2)
    assert M[2] == pytest.approx(D + D**3 / 3, rel=1e-14)
    F = 2 * math.atanh(math.sqrt(1 / 3) * math.tan(nu / 2))
    assert M[3] == pytest.approx(2 * math.sinh(F) - F, rel=1e-13)
    assert M[0] == pytest.approx(nu, rel=1e-15)
    # composite angles
    assert el.argument_of_latitude.value == pytest.approx(0.5)
    assert el.true_longitude.value == pytest.approx(0.7)
    assert el.longitude_of_periapsis.value == pytest.approx(0.3)
    assert el.inclination.unit == u.rad and el.true_anomaly.unit == u.rad
    # each conic's state matches the conic: energy and angular momentum
    s = el.to_state()
    np.testing.assert_allclose(s.specific_energy.value, el.specific_energy.value, atol=1e-12)
    np.testing.assert_allclose(
        np.linalg.norm(s.specific_angular_momentum.value, axis=-1),
        el.specific_angular_momentum.value,
        rtol=1e-14,
    )


def test_exact_parabola_from_state():
    r0 = 7000.0
    s = vv.StateVectors([r0, 0, 0] * KM, [0, math.sqrt(2 * MU.value / r0), 0] * KMS, MU)
    el = s.to_elements()
    assert el.eccentricity == 1.0
    assert el.semi_major_axis.value == np.inf
    assert el.semi_latus_rectum.value == pytest.approx(2 * r0, rel=1e-15)
    assert el.periapsis_distance.value == pytest.approx(r0, rel=1e-15)
    assert el.specific_energy.value == 0.0


def test_retrograde_equatorial_orbit():
    """i = pi exactly: raan = 0 and argp, nu measured in the direction of motion."""
    vc = math.sqrt(MU.value / 8000.0) * 1.1
    s = vv.StateVectors([0, 8000.0, 0] * KM, [vc, 0, 0] * KMS, MU)
    el = s.to_elements()
    assert el.inclination.value == PI
    assert el.longitude_of_ascending_node.value == 0.0
    # periapsis here (nu = 0): the position lies at the geometric angle -argp from x
    assert el.true_anomaly.value == pytest.approx(0.0, abs=1e-15)
    assert ang_diff(-el.argument_of_periapsis.value, PI / 2) < 1e-15
    back = el.to_state()
    assert np.abs((back.r - s.r).value).max() < 1e-11
    assert back.r.value[2] == 0.0 and back.v.value[2] == 0.0


# ---------------------------------------------------------------------------------------------
# containers: round trips through the public API, broadcasting, validation
# ---------------------------------------------------------------------------------------------
@settings(max_examples=100, deadline=None)
@given(
    p=st.floats(1000.0, 1e5),
    ecc=st.one_of(st.sampled_from([0.0, 1e-12, 1 - 1e-10, 1.0, 1 + 1e-10]), st.floats(0, 10)),
    inc=st.one_of(st.sampled_from([0.0, PI, 1e-12, PI - 1e-12]), st.floats(0.0, PI)),
    raan=st.floats(-TWO_PI, TWO_PI),
    argp=st.floats(-TWO_PI, TWO_PI),
    nu=st.floats(-PI, PI),
)
def test_public_round_trip(p, ecc, inc, raan, argp, nu):
    assume(1 + ecc * math.cos(nu) >= 1e-3)
    s = vv.KeplerianElements(p * KM, ecc, inc, raan, argp, nu, MU).to_state()
    back = s.to_elements().to_state()
    r, v = s.r.value, s.v.value
    assert np.linalg.norm(back.r.value - r) <= 1e-12 * np.linalg.norm(r)
    assert np.linalg.norm(back.v.value - v) <= 1e-12 * np.linalg.norm(v)


def test_from_semi_major_axis():
    el = vv.KeplerianElements.from_semi_major_axis(7000 * KM, 0.1, 0.1, 0.2, 0.3, 0.4, MU)
    assert el.semi_major_axis.value == pytest.approx(7000.0, rel=1e-15)
    assert el.semi_latus_rectum.value == pytest.approx(7000 * 0.99, rel=1e-15)
    hyp = vv.KeplerianElements.from_semi_major_axis(-7000 * KM, 2.0, 0.1, 0.2, 0.3, 0.4, MU)
    assert hyp.semi_major_axis.value == pytest.approx(-7000.0, rel=1e-15)
    with pytest.raises(vv.InvalidElementsError, match="use KeplerianElements\\(p"):
        vv.KeplerianElements.from_semi_major_axis(np.inf * KM, 1.0, 0, 0, 0, 0, MU)
    with pytest.raises(vv.InvalidElementsError, match="a must be < 0 for a hyperbola"):
        vv.KeplerianElements.from_semi_major_axis(7000 * KM, 2.0, 0, 0, 0, 0, MU)
    with pytest.raises(vv.InvalidElementsError, match="a must be > 0 for an ellipse"):
        vv.KeplerianElements.from_semi_major_axis(-7000 * KM, 0.5, 0, 0, 0, 0, MU)
    with pytest.raises(vv.UnitsError):
        vv.KeplerianElements.from_semi_major_axis(7000, 0.5, 0, 0, 0, 0, MU)


def test_validation_errors():
    good = dict(p=7000 * KM, ecc=0.1, inc=0.1, raan=0.2, argp=0.3, nu=0.4, gm=MU)

    def make(**change):
        return vv.KeplerianElements(**{**good, **change})

    with pytest.raises(vv.InvalidElementsError, match="ecc .* must be >= 0"):
        make(ecc=-0.1)
    with pytest.raises(vv.InvalidElementsError, match="p .* must be > 0"):
        make(p=0 * KM)
    with pytest.raises(vv.InvalidElementsError, match="p .* must be > 0"):
        make(p=[7000, -1] * KM)
    with pytest.raises(vv.InvalidElementsError, match=r"inc .* \[0, pi\]"):
        make(inc=-0.1)
    with pytest.raises(vv.InvalidElementsError, match=r"inc .* \[0, pi\]"):
        make(inc=4.0)
    with pytest.raises(vv.InvalidElementsError, match="asymptote"):
        make(ecc=2.0, nu=2.5)
    with pytest.raises(vv.InvalidElementsError, match="asymptote"):
        make(ecc=1.0, nu=PI)
    with pytest.raises(vv.InvalidInputError, match="gm must be > 0"):
        make(gm=-MU)
    with pytest.raises(vv.InvalidInputError, match="NaN"):
        make(nu=np.nan)
    with pytest.raises(vv.UnitsError):
        make(p=7000.0)
    with pytest.raises(vv.UnitsError):
        make(inc=1 * u.km)
    with pytest.raises(vv.ShapeError, match="broadcast"):
        make(ecc=[0.1, 0.2], nu=[0.1, 0.2, 0.3])
    # 180 deg converts to a float a hair above or at pi: accepted as pi
    el = make(inc=180 * u.deg)
    assert el.inclination.value == PI
    with pytest.raises(vv.InvalidInputError, match="NaN"):
        vv.KeplerianElements.from_semi_major_axis(np.nan * KM, 0.5, 0, 0, 0, 0, MU)
    with pytest.raises(vv.InvalidElementsError, match="p .* must be > 0"):
        vv.ModifiedEquinoctialElements(-1 * KM, 0.0, 0.0, 0.0, 0.0, 0.0, MU)
    with pytest.raises(vv.InvalidInputError, match="gm must be > 0"):
        vv.ModifiedEquinoctialElements(7000 * KM, 0.0, 0.0, 0.0, 0.0, 0.0, -MU)
    with pytest.raises(vv.UnitsError):
        vv.ModifiedEquinoctialElements(7000.0, 0.0, 0.0, 0.0, 0.0, 0.0, MU)
    # an equinoctial set beyond the asymptote
    with pytest.raises(vv.InvalidElementsError, match="asymptote"):
        vv.ModifiedEquinoctialElements(7000 * KM, 2.0, 0.0, 0.0, 0.0, PI, MU)


def test_broadcasting_and_indexing():
    nu = np.linspace(-1, 1, 7)
    el = vv.KeplerianElements(7000 * KM, [[0.1], [0.2]], 0.3, 0.2, 0.1, nu, vv.EARTH)
    assert el.shape == (2, 7) and len(el) == 2
    assert el.true_anomaly.shape == (2, 7)
    assert el.to_state().shape == (2, 7)
    assert el[1, 3].eccentricity == 0.2 and el[1, 3].true_anomaly.value == pytest.approx(0.0)
    assert el[:, 0].shape == (2,)
    assert "14 orbits" in repr(el)
    assert "KeplerianElements(p=7000 km" in repr(el[0, 0])
    scalar = vv.KeplerianElements(7000 * KM, 0.1, 0.3, 0.2, 0.1, 0.0, MU)
    assert scalar.shape == () and isinstance(scalar.eccentricity, float | np.floating)
    assert scalar.to_state().r.shape == (3,)


@pytest.mark.parametrize("flag", ["False", "no", 0, 2, np.array([False, True]), None])
def test_the_retrograde_factor_takes_only_booleans(flag):
    """retrograde="False" is truthy: the elements were read with I = -1, a different orbit
    (9,300 km from the one meant, no error); an array raised numpy's ValueError (audit13)."""
    with pytest.raises(vv.InvalidInputError, match="retrograde must be True or False"):
        vv.ModifiedEquinoctialElements(7000 * KM, 0.1, 0.2, 0.3, 0.4, 1.0, MU, retrograde=flag)
    s = vv.StateVectors([7000.0, 0, 0] * KM, [0, 7.5, 0.1] * KMS, MU)
    with pytest.raises(vv.InvalidInputError, match="retrograde must be True or False"):
        s.to_equinoctial(retrograde=flag)
    with pytest.raises(vv.InvalidInputError, match="retrograde must be True or False"):
        s.to_elements().to_equinoctial(retrograde=flag)
    for ok in (True, np.bool_(True)):  # numpy's booleans are booleans
        assert s.to_equinoctial(retrograde=ok).retrograde is True


def test_modified_equinoctial_container():
    el = vv.KeplerianElements(9000 * KM, 0.2, 0.4, 0.5, 0.6, 0.7, MU)
    m = el.to_equinoctial()
    assert m.semi_latus_rectum.value == pytest.approx(9000.0)
    assert math.hypot(m.f, m.g) == pytest.approx(0.2)
    assert m.f == pytest.approx(0.2 * math.cos(1.1))
    assert m.h == pytest.approx(math.tan(0.2) * math.cos(0.5))
    assert m.k == pytest.approx(math.tan(0.2) * math.sin(0.5))
    assert m.true_longitude.value == pytest.approx(1.8)
    m2 = vv.ModifiedEquinoctialElements(m.p, m.f, m.g, m.h, m.k, m.L, MU)
    back = m2.to_keplerian()
    assert back.argument_of_periapsis.value == pytest.approx(0.6)
    assert np.abs((m2.to_state().r - el.to_state().r).value).max() < 1e-11
    assert "ModifiedEquinoctialElements(p=9000 km" in repr(m2)


# --- robustness regression (ROBUSTNESS_BUGS.md #2) ---------------------------------------------
@pytest.mark.parametrize("h", [1e154, 1e155, 1e300])
def test_mee_huge_h_gives_finite_state(h):
    """h -> inf is i -> pi: h^2 must not overflow; the state matches the i = pi limit."""
    s = vv.ModifiedEquinoctialElements(7000 * KM, 0.1, 0, h, 0, 0.5, MU).to_state()
    r, v = s.r.to_value(KM), s.v.to_value(KMS)
    assert np.all(np.isfinite(r)) and np.all(np.isfinite(v))
    ref = vv.ModifiedEquinoctialElements(7000 * KM, 0.1, 0, 1e150, 0, 0.5, MU).to_state()
    np.testing.assert_allclose(r[:2], ref.r.to_value(KM)[:2], rtol=1e-14)
    np.testing.assert_allclose(v[:2], ref.v.to_value(KMS)[:2], rtol=1e-14)
    assert abs(r[2]) < 1e-100


@pytest.mark.parametrize("epoch", ["2020-01-01", 2451545.0])
def test_elements_epoch_must_be_time(epoch):
    # KeplerianElements and ModifiedEquinoctialElements stored any object as the epoch (a
    # string came back from .epoch and broke to_state().propagate)
    with pytest.raises(vv.errors.InvalidInputError, match="astropy.time.Time"):
        vv.KeplerianElements(7000 * KM, 0.1, 0, 0, 0, 0, MU, epoch=epoch)
    with pytest.raises(vv.errors.InvalidInputError, match="astropy.time.Time"):
        vv.KeplerianElements.from_semi_major_axis(7000 * KM, 0.1, 0, 0, 0, 0, MU, epoch=epoch)
    with pytest.raises(vv.errors.InvalidInputError, match="astropy.time.Time"):
        vv.ModifiedEquinoctialElements(7000 * KM, 0.1, 0, 0, 0, 0, MU, epoch=epoch)


def test_elements_epoch_shape_is_checked():
    from astropy.time import Time

    three = Time("2024-01-01", scale="utc") + np.arange(3) * u.h
    with pytest.raises(vv.ShapeError, match="epoch"):
        vv.KeplerianElements([7000, 8000] * KM, 0.1, 0, 0, 0, 0, MU, epoch=three)
    with pytest.raises(vv.ShapeError, match="epoch"):
        vv.ModifiedEquinoctialElements([7000, 8000] * KM, 0.1, 0, 0, 0, 0, MU, epoch=three)
    el = vv.KeplerianElements([7000, 8000, 9000] * KM, 0.1, 0, 0, 0, 0, MU, epoch=three)
    assert el.epoch is three and el[2].epoch == three[2]


@pytest.mark.parametrize("nu", [1e-300, 1e-15, -1e-15, 1e-12, -1e-12, -1e-8, 3.0, -3.0, PI])
def test_small_true_anomalies_keep_their_digits(nu):
    # wrapping into (-pi, pi] as pi - ((pi - nu) mod 2 pi) rounded small angles to multiples of
    # ulp(2 pi): nu = -1e-15 came back as -8.9e-16 (11 % off), -1e-12 as -1.0000889e-12, and
    # 1e-300 as 0, both from KeplerianElements(...) and from states just before periapsis
    el = vv.KeplerianElements(7000 * KM, 0.3, 0.1, 0.2, 0.3, nu, MU)
    assert el.true_anomaly.to_value(u.rad) == nu
    mu = MU.to_value(GM_UNIT)
    p, e = 7000.0, 0.3
    r = p / (1 + e * math.cos(nu)) * np.array([math.cos(nu), math.sin(nu), 0.0])
    v = math.sqrt(mu / p) * np.array([-math.sin(nu), e + math.cos(nu), 0.0])
    back = vv.StateVectors(r * KM, v * KMS, MU).to_elements().true_anomaly.to_value(u.rad)
    assert back == pytest.approx(nu, rel=1e-12, abs=0)


# --- auditmech: modified equinoctial elements over every conic and both retrograde factors ------
@settings(max_examples=60, deadline=None)
@given(
    ecc=st.one_of(st.just(0.0), st.floats(0.0, 0.95), st.just(1.0), st.floats(1.05, 20.0)),
    inc=st.one_of(st.sampled_from([0.0, 1e-12, math.pi / 2, math.pi - 1e-12, math.pi]),
                  st.floats(0.0, math.pi)),
    raan=st.floats(0.0, 6.28),
    argp=st.floats(0.0, 6.28),
    nu_frac=st.floats(-0.9, 0.9),
    retrograde=st.booleans(),
)
def test_equinoctial_definitions_and_round_trip_every_conic(ecc, inc, raan, argp, nu_frac,
                                                            retrograde):
    # f, g, h, k, L equal their definitions from the classical elements (Walker et al. 1985
    # with the retrograde factor I), and the state round trip holds, for circles, ellipses,
    # parabolas and hyperbolas at every inclination; exactly at the one singular inclination
    # (i = pi for I = +1, i = 0 for I = -1) a DomainError is raised, never garbage
    nu_max = math.pi if ecc < 1 else math.acos(-1 / ecc)
    nu = nu_frac * nu_max
    el = vv.KeplerianElements(12000 * KM, ecc, inc, raan, argp, nu, MU)
    state = el.to_state()
    I = -1 if retrograde else 1  # noqa: E741
    ref = state.to_elements()  # the documented convention for undefined angles
    i_ref = ref.inclination.to_value(u.rad)
    if (I == 1 and i_ref == math.pi) or (I == -1 and i_ref == 0.0):
        with pytest.raises(vv.DomainError, match="singular"):
            state.to_equinoctial(retrograde=retrograde)
        return
    m = state.to_equinoctial(retrograde=retrograde)
    e = ref.eccentricity
    O, w = ref.longitude_of_ascending_node.to_value(u.rad), ref.argument_of_periapsis.to_value(u.rad)
    t = math.tan(i_ref / 2) ** I
    assert m.f == pytest.approx(e * math.cos(w + I * O), abs=1e-12)
    assert m.g == pytest.approx(e * math.sin(w + I * O), abs=1e-12)
    assert m.h == pytest.approx(t * math.cos(O), abs=1e-12 * (1 + t))
    assert m.k == pytest.approx(t * math.sin(O), abs=1e-12 * (1 + t))
    L = w + I * O + ref.true_anomaly.to_value(u.rad)
    assert abs(math.remainder(m.true_longitude.to_value(u.rad) - L, 2 * math.pi)) < 1e-12
    back = m.to_state()
    r0 = np.linalg.norm(state.r.to_value(KM))
    np.testing.assert_allclose(back.r.to_value(KM), state.r.to_value(KM), rtol=0, atol=1e-13 * r0)
    v0 = np.linalg.norm(state.v.to_value(KMS))
    np.testing.assert_allclose(back.v.to_value(KMS), state.v.to_value(KMS), rtol=0, atol=1e-13 * v0)


def test_a_plain_true_longitude_beyond_two_pi_warns_as_keplerian_angles_do():
    # KeplerianElements(raan=400) warns that a plain 400 is taken in radians; the equinoctial
    # L = 400 (degrees meant) was taken as 400 rad without a word: another point of the orbit
    with pytest.warns(UserWarning, match=r"L = 400.0 is a plain number.*L=400.0 \* u.deg"):
        vv.ModifiedEquinoctialElements(7000 * u.km, 0.1, 0, 0, 0, 400, vv.EARTH)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        vv.ModifiedEquinoctialElements(7000 * u.km, 0.1, 0, 0, 0, 400 * u.deg, vv.EARTH)
        vv.ModifiedEquinoctialElements(7000 * u.km, 0.1, 0, 0, 0, 6.0, vv.EARTH)


def test_a_negative_zero_inclination_is_stored_as_plus_zero():
    """-0.0 passed the [0, pi] check and came back as inclination -0.0 rad (audit47); the other
    angles were already wrapped without negative zeros."""
    el = vv.KeplerianElements(7000 * u.km, 0.1, [-0.0, 0.0] * u.deg, 0.0, 0.0, 0.0, vv.EARTH)
    assert not np.signbit(el.inclination.value).any()


# --- audit57: absurd scales refused or warned, legitimate extremes untouched ----------------------
def test_subnormal_gm_refused_instead_of_zero_velocity():
    # before: gm = 1e-320 gave v = [0, 0, 0] km/s exactly (gm/p underflowed)
    with pytest.raises(vv.InvalidElementsError, match="float64"):
        vv.KeplerianElements(7000 * KM, 0.1, 0, 0, 0, 0, 1e-320 * GM_UNIT)


def test_superluminal_periapsis_speed_warns():
    # before: e = 1e160 gave a speed of 7.5e160 km/s with no word
    with pytest.warns(vv.ImplausibleVelocityWarning, match="speed of light"):
        el = vv.KeplerianElements(7000 * KM, 1e160, 0, 0, 0, 0, MU)
    assert el.eccentricity == 1e160  # kept as given


def test_period_underflow_raises_not_inf():
    # before: p = 1e300 km gave period = inf s (and only a numpy overflow warning)
    el = vv.KeplerianElements(1e300 * KM, 0.1, 0, 0, 0, 0, MU)
    with pytest.raises(vv.DomainError, match="underflows"):
        _ = el.period
    with pytest.raises(vv.DomainError, match="underflows"):
        _ = el.mean_motion


@pytest.mark.parametrize("p_km", [1e-3, 1.0, 1e12])
@pytest.mark.parametrize("gm", [1e-10, 1.0, 1e20])
@pytest.mark.parametrize("ecc", [0.0, 0.5, 1.0, 3.0])
def test_legitimate_extremes_need_no_warning(p_km, gm, ecc):
    import warnings

    fast = math.sqrt(gm / p_km) * (1 + ecc) > 299_792.458
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        if fast:  # e.g. gm = 1e20 km3/s2 at p = 1 km: inside the Schwarzschild radius
            with pytest.warns(vv.ImplausibleVelocityWarning):
                el = vv.KeplerianElements(p_km * KM, ecc, 0.1, 0, 0, 0.2, gm * GM_UNIT)
        else:
            el = vv.KeplerianElements(p_km * KM, ecc, 0.1, 0, 0, 0.2, gm * GM_UNIT)
        n = el.mean_motion.to_value(u.rad / u.s)
    # mean motion vs a log-space evaluation (no under/overflow possible there)
    a = p_km if ecc == 1.0 else abs(p_km / (1 - ecc * ecc))
    ref = 2 * math.sqrt(gm / p_km**3) if ecc == 1.0 else math.exp(0.5 * (math.log(gm) - 3 * math.log(a)))
    assert n == pytest.approx(ref, rel=1e-14)
    v = np.linalg.norm(el.to_state().v.to_value(KMS))
    assert v > 0 and np.isfinite(v)
