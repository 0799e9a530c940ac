"""A velocity in m/s given where km/s are read warns (ImplausibleVelocityWarning), once per call.

A LEO state with v = 7500 "km/s" has e ~ 1e6; the fast legitimate states (an Earth flyby at
15 km/s or at the 72 km/s of the fastest meteors, GEO, the Moon's distance, a heliocentric
sun-grazer) stay silent.
"""

import math
import warnings

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from hypothesis import given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva.constants import GM_EARTH_KM3_S2

KM = u.km
KMS = u.km / u.s


def _silent(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("error", vv.ImplausibleVelocityWarning)
        return fn(*args, **kwargs)


def test_leo_in_m_s_warns_and_keeps_the_state():
    with pytest.warns(vv.ImplausibleVelocityWarning,
                      match=r"velocity 7500 km/s is far above escape speed .*were m/s given as km/s"):
        s = vv.StateVectors([7000.0, 0, 0] * KM, [0, 7500.0, 0] * KMS, vv.EARTH)
    # not refused: the state is what was given (e ~ 1e6, wildly hyperbolic)
    assert s.to_elements().eccentricity > 1e5


@pytest.mark.parametrize("r_km, v_kms", [
    ([7000.0, 0, 0], [0, 15.0, 0]),            # hyperbolic flyby in LEO
    ([6578.0, 0, 0], [0, 72.0, 0]),            # the fastest meteors (~72 km/s)
    ([42164.0, 0, 0], [0, 3.0747, 0]),         # GEO
    ([384400.0, 0, 0], [0, 1.022, 0]),         # the Moon's distance
    ([9.9e5, 0, 0], [0, 0.5, 0.2]),            # near the edge of the Hill sphere
    ([7000.0, 0, 0], [0, 99.0, 0]),            # just under 100 km/s
])
def test_fast_but_legitimate_earth_states_are_silent(r_km, v_kms):
    _silent(vv.StateVectors, r_km * KM, v_kms * KMS, vv.EARTH)


def test_heliocentric_sun_grazer_is_silent_but_its_m_s_version_warns():
    # a sun-grazing comet at 1.2 solar radii: ~560 km/s (parabolic), legitimate
    r = 1.2 * 695700.0
    v = math.sqrt(2 * vv.SUN.gm.to_value(u.km**3 / u.s**2) / r)
    _silent(vv.StateVectors, [r, 0, 0] * KM, [0, v, 0] * KMS, vv.SUN)
    # the Earth's heliocentric velocity in m/s (29780 "km/s") at 1 au warns
    with pytest.warns(vv.ImplausibleVelocityWarning):
        vv.StateVectors([1.496e8, 0, 0] * KM, [0, 29780.0, 0] * KMS, vv.SUN)


def test_one_warning_per_call_naming_the_first_state_and_the_count():
    rng = np.random.default_rng(1)
    r = np.tile([7000.0, 0, 0], (1000, 1)) + rng.normal(size=(1000, 3))
    v = np.tile([0, 7.5, 0], (1000, 1))
    v[[17, 400, 999]] *= 1000.0
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        vv.StateVectors(r * KM, v * KMS, vv.EARTH)
    hits = [w for w in caught if issubclass(w.category, vv.ImplausibleVelocityWarning)]
    assert len(hits) == 1
    text = str(hits[0].message)
    assert "index (17,)" in text and "3 states in all" in text
    # the warning points at the caller, not at visviva's internals
    assert hits[0].filename == __file__


def test_broadcast_gm_and_leading_shape():
    r = np.array([[[7000.0, 0, 0]], [[7000.0, 0, 0]]])          # (2, 1, 3)
    v = np.array([[0, 7.5, 0], [0, 7500.0, 0]])                  # (2, 3)
    gm = np.array([GM_EARTH_KM3_S2, GM_EARTH_KM3_S2]) * u.km**3 / u.s**2
    with pytest.warns(vv.ImplausibleVelocityWarning, match=r"index \(0, 1\)"):
        vv.StateVectors(r * KM, v * KMS, gm)


@settings(max_examples=60, deadline=None)
@given(
    radius=st.floats(6378.0, 1.0e6),
    fraction=st.floats(0.0, 1.0),
    direction=st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(
        lambda d: math.hypot(*d) > 1e-3),
)
def test_bound_orbits_are_silent_and_their_m_s_versions_warn(radius, fraction, direction):
    v_esc = math.sqrt(2 * GM_EARTH_KM3_S2 / radius)
    speed = 0.2 + fraction * (v_esc - 0.2) if v_esc > 0.2 else v_esc
    d = np.array(direction) / math.hypot(*direction)
    r = np.array([radius, 0.0, 0.0]) * KM
    _silent(vv.StateVectors, r, d * speed * KMS, vv.EARTH)
    if speed >= 0.2:
        with pytest.warns(vv.ImplausibleVelocityWarning):
            vv.StateVectors(r, d * speed * 1000.0 * KMS, vv.EARTH)


def test_oem_from_states_warns_for_m_s_plain_numbers():
    from visviva.ccsds.oem import OEMSegment

    t = Time("2024-01-01T00:00:00", scale="utc") + np.arange(3) * 60 * u.s
    r = np.array([[7000.0, 0, 0], [6990.0, 450.0, 0], [6970.0, 900.0, 0]])
    v = np.array([[0, 7.5, 0], [-0.48, 7.48, 0], [-0.96, 7.44, 0]])
    _silent(OEMSegment.from_states, t, r, v, object_name="X")
    with pytest.warns(vv.ImplausibleVelocityWarning, match="OEMSegment.from_states"):
        OEMSegment.from_states(t, r, v * 1000.0, object_name="X")


def test_state_transition_matrix_warns_for_m_s():
    from visviva.conjunctions.covariance import state_transition_matrix

    _silent(state_transition_matrix, [7000.0, 0, 0] * KM, [0, 7.5, 0] * KMS, 60 * u.s, vv.EARTH)
    with pytest.warns(vv.ImplausibleVelocityWarning, match="state_transition_matrix"):
        state_transition_matrix([7000.0, 0, 0], [0, 7500.0, 0], 1e-3, vv.EARTH)


def test_message_gives_the_speed_even_where_its_square_overflows():
    with pytest.warns(vv.ImplausibleVelocityWarning, match=r"velocity 1e\+200 km/s"):
        vv.StateVectors([7000.0, 0, 0] * KM, [0, 1e200, 0] * KMS, vv.EARTH)
