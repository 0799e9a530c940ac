"""EME2000 (mean equator and equinox of J2000) is the GCRS rotated by the constant frame bias.

visviva took EME2000 numbers for GCRS ones (4.7 m at GEO, 0.8 m in LEO, silently) while Orekit,
STK and GMAT apply the bias; now the readers rotate EME2000 states and covariances to the GCRS
axes (``B.T``) and the writers rotate them back (``B``). References: IERS Conventions (2010),
TN 36, eq. 5.21 (dα0 = -14.6 mas, ξ0 = -16.617 mas, η0 = -6.819 mas); ERFA ``bp06``.
"""

import erfa
import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv
from visviva.ccsds.oem import Ephemeris, OEMSegment
from visviva.ccsds.opm import OPM
from visviva.ccsds.timeframes import FRAME_BIAS, from_gcrs_axes, to_gcrs_axes
from visviva.satellites.satellite_states import framed_states

MAS = np.pi / 180 / 3.6e6
EPOCH = Time("2024-03-01T00:00:00", scale="utc")


def _close(a, b):
    """Vectors equal to 1e-12 of their length."""
    a, b = np.asarray(a), np.asarray(b)
    assert np.linalg.norm(a - b, axis=-1).max() <= 1e-12 * np.linalg.norm(b, axis=-1).max()


def _geo():
    r = 42164.0 * np.array([np.cos(0.3), np.sin(0.3), 0.0])
    v = 3.0747 * np.array([-np.sin(0.3), np.cos(0.3), 0.0])
    return framed_states(r, v, vv.EARTH.gm_km3_s2, EPOCH, "gcrs")


def test_frame_bias_is_erfa_bp06_at_any_date_and_the_iers_angles():
    for jd in (2451545.0, 2460371.5, 2400000.5):
        np.testing.assert_allclose(FRAME_BIAS, erfa.bp06(jd, 0.0)[0], rtol=0, atol=1e-15)
    # first order: B = 1 - [0, dα0, -ξ0; -dα0, 0, -η0; ξ0, η0, 0] (IERS 2010 eq. 5.24)
    da, xi, eta = -14.6 * MAS, -16.617 * MAS, -6.819 * MAS
    first = np.array([[1, da, -xi], [-da, 1, -eta], [xi, eta, 1]])
    # (bp06's IAU 2006 bias and these IAU 2000 angles agree to 0.002 mas: 0.4 mm at GEO)
    np.testing.assert_allclose(FRAME_BIAS, first, rtol=0, atol=1e-11)
    np.testing.assert_allclose(FRAME_BIAS @ FRAME_BIAS.T, np.eye(3), rtol=0, atol=1e-15)


@pytest.mark.parametrize("fmt", ["kvn", "xml"])
def test_a_geo_state_written_in_eme2000_is_4_7_m_from_its_gcrs_numbers_and_round_trips(fmt):
    state = _geo()
    t = EPOCH + np.arange(5) * 60 * u.s
    eph = state.propagate((t - EPOCH).to(u.s))
    eph = framed_states(
        eph.r.to_value(u.km), eph.v.to_value(u.km / u.s), vv.EARTH.gm_km3_s2, t, "gcrs")
    seg = OEMSegment.from_states(eph, object_name="G", frame="EME2000")
    text = vv.write_oem(Ephemeris([seg]), format=fmt)
    back = vv.read_oem(text).segments[0]
    written = back.r_km[0]
    gcrs = eph.r[0].to_value(u.km)
    assert 4.0 < np.linalg.norm(written - gcrs) * 1e3 < 4.8  # the 23 mas bias at GEO
    _close(written, FRAME_BIAS @ gcrs)
    got = back.states
    assert got.frame == "gcrs"
    _close(got.r.to_value(u.km), eph.r.to_value(u.km))  # 1e-12 relative
    _close(got.v.to_value(u.km / u.s), eph.v.to_value(u.km / u.s))
    # GCRF is the GCRS: written as they are
    same = OEMSegment.from_states(eph, object_name="G", frame="GCRF")
    np.testing.assert_array_equal(same.r_km, eph.r.to_value(u.km))


@pytest.mark.parametrize("fmt", ["kvn", "xml"])
def test_an_opm_state_and_covariance_in_eme2000_rotate_with_the_bias(fmt):
    state = _geo()
    cov = np.diag([1e-2, 4e-2, 9e-2, 1e-8, 4e-8, 9e-8])
    cov[0, 1] = cov[1, 0] = 5e-3
    opm = OPM.from_state(state, object_name="G", object_id="2024-001A", frame="EME2000",
                         covariance=cov)
    b6 = np.kron(np.eye(2), FRAME_BIAS)
    written = np.array([opm.sections["state_vector"][k] for k in ("X", "Y", "Z")])
    _close(written, FRAME_BIAS @ state.r.to_value(u.km))
    back = vv.read_opm(vv.write_opm(opm, format=fmt))
    _close(back.state.r.to_value(u.km), state.r.to_value(u.km))
    np.testing.assert_allclose(back.covariance, cov, rtol=1e-12, atol=1e-15 * cov.max())
    # the matrix written is B C B.T: a rotated covariance (off-diagonal terms appear)
    from visviva.ccsds.covariance import matrix_from_values

    raw = matrix_from_values(back.sections["covariance"].values)
    np.testing.assert_allclose(raw, b6 @ cov @ b6.T, rtol=1e-9, atol=1e-9 * cov.max())
    assert raw[0, 2] != 0.0


def test_eme2000_about_another_centre_takes_the_same_axes():
    r = np.array([[3000.0, 1000.0, 500.0], [3001.0, 1001.0, 501.0]])
    v = np.array([[0.1, 1.5, 0.2], [0.1, 1.5, 0.2]])
    t = EPOCH + [0, 1] * u.s
    seg = OEMSegment.from_states(t, r, v, object_name="M", center="MARS", frame="EME2000")
    _close(seg.states.r.to_value(u.km), r @ FRAME_BIAS)


def test_helpers_leave_other_frames_alone_and_invert():
    x = np.arange(6.0).reshape(2, 3)
    for name in ("GCRF", "ICRF", "TEME", "ITRF", "TOD"):
        assert to_gcrs_axes(name, x)[0] is x and from_gcrs_axes(name, x)[0] is x
    np.testing.assert_allclose(from_gcrs_axes("eme2000", *to_gcrs_axes("EME2000", x))[0], x,
                               rtol=1e-15, atol=1e-15)


@pytest.mark.parametrize("fmt", ["kvn", "xml"])
def test_an_opm_manoeuvre_in_eme2000_is_turned_to_the_gcrs_axes_and_burns_round_trip(fmt):
    # MAN_REF_FRAME = EME2000 was flown on the GCRS axes as written: 6.6e-8 of the Δv off
    from visviva.ccsds.opm import Maneuver

    state = _geo()
    dv = np.array([0.1, 0.2, 0.3])
    man = Maneuver(EPOCH + 600 * u.s, 0 * u.s, 0 * u.kg, "EME2000", dv * u.km / u.s)
    opm = vv.read_opm(vv.write_opm(OPM.from_state(state, object_name="G", frame="EME2000",
                                                  maneuvers=[man]), format=fmt))
    (burn,) = opm.burns()
    assert burn.frame == "GCRF"
    _close(burn.delta_v_km_s, FRAME_BIAS.T @ dv)
    assert np.linalg.norm(burn.delta_v_km_s - dv) > 5e-8 * np.linalg.norm(dv)
    np.testing.assert_array_equal(opm.maneuvers[0].delta_v.to_value(u.km / u.s), dv)  # as written
    # the burn written back (an impulse on the GCRS axes) is EME2000 with the bias, and reads
    # back as itself
    again = OPM.from_state(state, object_name="G", frame="EME2000", maneuvers=[burn])
    rec = again.sections["maneuvers"][0]
    assert rec["MAN_REF_FRAME"] == "EME2000"
    _close([rec[f"MAN_DV_{i}"] for i in (1, 2, 3)], dv)
    (back,) = vv.read_opm(vv.write_opm(again, format=fmt)).burns()
    _close(back.delta_v_km_s, burn.delta_v_km_s)
    # a finite burn or another object is refused, saying what to give
    with pytest.raises(vv.InvalidInputError, match="FiniteBurn"):
        OPM.from_state(state, object_name="G", maneuvers=[vv.FiniteBurn(
            EPOCH, 60 * u.s, [1, 0, 0], "RTN", acceleration=1e-6 * u.km / u.s**2)])
    with pytest.raises(vv.InvalidInputError, match="Maneuver or a visviva.ImpulsiveBurn"):
        OPM.from_state(state, object_name="G", maneuvers=[(EPOCH, dv)])
    j2000 = OPM.from_state(state, object_name="G", maneuvers=[Maneuver(
        EPOCH, 0 * u.s, 0 * u.kg, "J2000", dv * u.km / u.s)])
    with pytest.raises(vv.InvalidInputError, match="MAN_REF_FRAME = J2000 .* is EME2000"):
        vv.read_opm(vv.write_opm(j2000)).burns()


def test_eme2000_frame_arguments_of_burns_and_covariances_are_refused_naming_the_bias():
    # ImpulsiveBurn(..., "EME2000") and propagate_covariance(frame="EME2000") took EME2000
    # numbers for GCRS ones (the 23 mas bias not applied); now refused, saying how to turn them
    state = _geo()
    with pytest.raises(vv.InvalidInputError, match="frame bias.*to_gcrs_axes"):
        vv.ImpulsiveBurn(EPOCH, [0, 0, 1e-3] * u.km / u.s, "EME2000")
    cov = np.diag([1e-2, 1e-2, 1e-2, 1e-8, 1e-8, 1e-8])
    for kw in ({"frame": "EME2000"}, {"output_frame": "J2000"}):
        with pytest.raises(vv.InvalidInputError, match="frame bias"):
            vv.propagate_covariance(state, cov, 60 * u.s, **kw)


@pytest.mark.parametrize("fmt", ["kvn", "xml"])
def test_an_omm_covariance_in_eme2000_is_turned_to_the_gcrs_axes_and_round_trips(fmt):
    # omm.covariance of REF_FRAME = EME2000 (non-SGP4 elements) was the matrix as written, while
    # opm.covariance and seg.covariance(k) turn EME2000 by the bias (6e-9 km^2 apart here)
    from test_ccsds_opm_omm import OMM_KVN
    from visviva.ccsds.covariance import values_from_matrix

    cov = np.diag([1e-2, 4e-2, 9e-2, 1e-8, 4e-8, 9e-8])
    cov[0, 1] = cov[1, 0] = 5e-3
    b6 = np.kron(np.eye(2), FRAME_BIAS)
    lines = "\n".join(f"{k} = {v!r}" for k, v in values_from_matrix(cov).items())
    for frame, theory, want in (("EME2000", "DSST", b6.T @ cov @ b6), ("GCRF", "BROUWER", cov),
                                ("TEME", "SGP4", cov)):
        text = (OMM_KVN.replace("REF_FRAME = TEME", f"REF_FRAME = {frame}")
                .replace("THEORY = SGP4", f"THEORY = {theory}") + lines + "\n")
        omm = vv.read_omm(vv.write_omm(vv.read_omm(text), format=fmt))
        np.testing.assert_allclose(omm.covariance, want, rtol=0, atol=1e-18)
        if frame == "EME2000":
            assert np.abs(omm.covariance - cov).max() > 5e-9
            with pytest.raises(vv.InvalidInputError, match="MEAN_ELEMENT_THEORY = DSST"):
                omm.state  # noqa: B018  (no state of DSST elements: refused, naming the theory)
