"""CCSDS time systems and frames, third audit (audit55): a 'Z' or zero UTC offset in a message
whose TIME_SYSTEM is not UTC, an OMM's GM, REF_FRAME = J2000, TEME with a REF_FRAME_EPOCH,
Earth-fixed frames visviva cannot rotate, and sat.teme(t).to_state_vectors()."""

import warnings

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv
from test_ccsds_opm_omm import OMM_KVN, OPM_KVN
from visviva.errors import InvalidInputError
from visviva.satellites.satellite_states import require_gcrs

_EPOCH = "EPOCH = 2024-03-01T00:00:00.000"


def _opm(system, suffix=""):
    return OPM_KVN.replace("TIME_SYSTEM = UTC", f"TIME_SYSTEM = {system}").replace(
        _EPOCH, _EPOCH + suffix)


def _oem(frame_and_time, start, stop, rows):
    """A one-segment OEM (KVN) whose metadata says ``frame_and_time`` (REF_FRAME, TIME_SYSTEM and
    any keyword between them), from ``start`` to ``stop``, with the data lines ``rows``."""
    return f"""CCSDS_OEM_VERS = 2.0
CREATION_DATE = 2024-03-01T00:00:00
ORIGINATOR = VISVIVA TESTS
META_START
OBJECT_NAME = SAT
OBJECT_ID = 2024-999A
CENTER_NAME = EARTH
{frame_and_time}
START_TIME = {start}
STOP_TIME = {stop}
META_STOP
{rows}"""


# -- 'Z' and '+00:00' in a message whose TIME_SYSTEM is not UTC ---------------------------------
@pytest.mark.parametrize("system, scale", [("TT", "tt"), ("TDB", "tdb"), ("TAI", "tai"),
                                           ("GPS", None)])
@pytest.mark.parametrize("suffix", ["Z", "+00:00"])
def test_a_utc_designator_under_another_time_system_warns_naming_the_line(system, scale, suffix):
    # was: read in the TIME_SYSTEM without a word, a UTC time written by an ISO 8601 writer
    # ('Z', datetime.isoformat's '+00:00') 69.184 s off in TT, 19 s in GPS
    plain = vv.read_opm(_opm(system)).epoch
    with pytest.warns(UserWarning, match=f"line 14: the epoch .*'Z'.*TIME_SYSTEM = {system}; "
                                         f"it is read in {system}"):
        marked = vv.read_opm(_opm(system, suffix)).epoch
    # CCSDS 502.0-B-3: 'Z' ends the epoch, which is in the TIME_SYSTEM: read as without it
    assert abs((marked - plain).sec) < 1e-9
    if scale is not None:
        assert abs((marked - Time("2024-03-01T00:00:00", scale=scale)).sec) < 1e-9
    else:  # GPS = TAI - 19 s
        assert abs((marked - Time("2024-03-01T00:00:19", scale="tai")).sec) < 1e-9


@pytest.mark.parametrize("suffix", ["", "Z", "+00:00"])
def test_a_utc_designator_in_utc_and_plain_epochs_do_not_warn(suffix):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        vv.read_opm(_opm("UTC", suffix))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        vv.read_opm(_opm("TT"))


def test_oem_data_lines_with_z_in_tdb_warn_naming_the_first_such_line():
    text = _oem("REF_FRAME = GCRF\nTIME_SYSTEM = TDB", "2024-03-01T00:00:00",
                "2024-03-01T00:02:00", """2024-03-01T00:00:00 7000.0 0.0 0.0 0.0 7.546 0.0
2024-03-01T00:01:00Z 6998.0 452.7 0.0 -0.49 7.53 0.0
2024-03-01T00:02:00Z 6992.0 905.0 0.0 -0.98 7.48 0.0
""")
    with pytest.warns(UserWarning, match="line 14: the epoch '2024-03-01T00:01:00Z'.*TDB"):
        t = vv.read_oem(text).segments[0].times
    assert abs((t[1] - Time("2024-03-01T00:01:00", scale="tdb")).sec) < 1e-9


# -- an OMM's GM ------------------------------------------------------------------------------
def _omm(gm):
    return OMM_KVN.replace("MEAN_ANOMALY = 325.0288 [deg]",
                           f"MEAN_ANOMALY = 325.0288 [deg]\nGM = {gm} [km**3/s**2]")


def test_an_omm_gm_1e9_times_the_earths_warns_naming_its_line():
    # was: read without a word (SGP4 does not use GM; an OPM's is refused)
    with pytest.warns(UserWarning, match=r"line 18: GM = 398600441800000\.0 km\*\*3/s\*\*2 is "
                                         r"1e\+09 times the GM of CENTER_NAME = EARTH"):
        omm = vv.read_omm(_omm("398600441800000.0"))
    assert omm["GM"] == 398600441800000.0  # kept as written; SGP4's satellite unchanged
    assert vv.Satellite.from_omm(omm).epoch == vv.Satellite.from_omm(vv.read_omm(OMM_KVN)).epoch


@pytest.mark.parametrize("gm", ["398600.8", "398600.4418", "398600.4415"])
def test_an_omm_with_a_published_earth_gm_reads_quietly(gm):
    with warnings.catch_warnings():  # WGS-72, WGS-84, EGM-96
        warnings.simplefilter("error")
        assert vv.read_omm(_omm(gm))["GM"] == float(gm)


# -- REF_FRAME = J2000 ------------------------------------------------------------------------
def test_j2000_states_refused_by_gcrs_users_say_which_name_to_write():
    base = OPM_KVN.split("SEMI_MAJOR_AXIS")[0]
    opm = vv.read_opm(base.replace("REF_FRAME = GCRF", "REF_FRAME = J2000"))
    assert opm.frame == "J2000" and opm.visviva_frame is None
    assert "REF_FRAME            = J2000" in vv.write_opm(opm)  # written back by its name
    np.testing.assert_array_equal(opm.state.r.to_value(u.km), [6503.514, 1239.647, -717.49])
    with pytest.raises(InvalidInputError, match="REF_FRAME = EME2000.*SPICE's J2000.*ICRF"):
        require_gcrs(opm.state, "propagate_cowell")
    tod = vv.read_opm(base.replace("REF_FRAME = GCRF", "REF_FRAME = TOD"))
    with pytest.raises(InvalidInputError, match="convert them to one of those first.$"):
        require_gcrs(tod.state, "propagate_cowell")


# -- REF_FRAME = TEME with a REF_FRAME_EPOCH: TEME of that epoch, not of date -----------------
def _teme_of_epoch_oem(ref_epoch="2024-03-01T00:00:00"):
    from visviva.satellites.frames import transform_matrices

    t0 = Time("2024-03-01T00:00:00", scale="utc")
    t = t0 + np.array([0.0, 1.0, 3.0]) * u.day
    r_g = np.array([[42164.0, 0.0, 0.0]] * 3)  # GEO, GCRS
    v_g = np.array([[0.0, 3.0747, 0.0]] * 3)
    m0 = transform_matrices(t0, "teme", "gcrs")[:3, :3]  # (TEME of t0 -> GCRS)
    r_e, v_e = r_g @ m0, v_g @ m0  # (m0.T applied to each row)
    rows = "\n".join(f"{ti.isot} " + " ".join(f"{x:.10f}" for x in (*r, *v))
                     for ti, r, v in zip(t, r_e, v_e, strict=True))
    ref = "" if ref_epoch is None else f"REF_FRAME_EPOCH = {ref_epoch}\n"
    text = _oem(f"REF_FRAME = TEME\n{ref}TIME_SYSTEM = UTC", t[0].isot, t[-1].isot, rows + "\n")
    return text, t, r_g, v_g


def test_teme_states_of_a_ref_frame_epoch_are_turned_to_teme_of_date():
    # was: REF_FRAME_EPOCH ignored, TEME of epoch read as TEME of date: a GEO state 28 m off
    # after a day, 86 m after three (precession and nutation of the axes), silently
    from visviva.satellites.frames import teme_to_gcrs

    for ref, worst_m in ((None, 80.0), ("2024-03-01T00:00:00", 1e-3)):
        text, t, r_g, v_g = _teme_of_epoch_oem(ref)
        states = vv.read_oem(text).segments[0].states
        assert states.frame == "teme"
        r, v = teme_to_gcrs(states.r.to_value(u.km), states.v.to_value(u.km / u.s), t)
        err_m = np.linalg.norm(r - r_g, axis=-1) * 1e3
        if ref is None:  # (the file without REF_FRAME_EPOCH: what the old reader computed)
            assert err_m[0] < 1e-3 and 25.0 < err_m[1] < 32.0 and err_m[2] > worst_m
        else:
            assert err_m.max() < worst_m
            assert np.linalg.norm(v - v_g, axis=-1).max() < 1e-9  # km/s
            gcrs = vv.read_oem(text).segments[0].states_in("gcrs")  # (its own rotation path)
            assert np.linalg.norm(gcrs.r.to_value(u.km) - r_g, axis=-1).max() < 1e-6


def test_an_omm_whose_ref_frame_epoch_is_not_its_epoch_is_refused_by_sgp4():
    omm = vv.read_omm(OMM_KVN.replace("TIME_SYSTEM = UTC",
                                      "REF_FRAME_EPOCH = 2024-01-01T12:00:00\nTIME_SYSTEM = UTC"))
    vv.Satellite.from_omm(omm)  # (the epoch itself: TEME of date)
    other = vv.read_omm(OMM_KVN.replace("TIME_SYSTEM = UTC",
                                        "REF_FRAME_EPOCH = 2000-01-01T12:00:00Z\nTIME_SYSTEM = UTC"))
    with pytest.raises(InvalidInputError, match="REF_FRAME_EPOCH = 2000-01-01T12:00:00Z .*TEME "
                                                "axes of that epoch"):
        vv.Satellite.from_omm(other)
    with pytest.raises(InvalidInputError, match="OMM REF_FRAME_EPOCH 'yesterday' is not a UTC"):
        vv.Satellite.from_omm({**omm, "REF_FRAME_EPOCH": "yesterday"})


# -- Earth-fixed REF_FRAMEs visviva cannot rotate: no two-body motion, no elements -------------
@pytest.mark.parametrize("frame", ["GTOD", "PEF", "GRC", "TDR", "ECEF", "ITRF-2014"])
def test_states_on_earth_fixed_axes_are_refused_by_two_body_users(frame):
    # was: taken as inertial: the elements of the sample state on GTOD axes had a = 15,951 km,
    # its inertial velocity (v + w x r) gives 24,443 km; propagate() moved it as if inertial
    base = OPM_KVN.split("SEMI_MAJOR_AXIS")[0]
    state = vv.read_opm(base.replace("REF_FRAME = GCRF", f"REF_FRAME = {frame}")).state
    match = f"REF_FRAME = {frame}, whose axes turn with the Earth"
    for call in (lambda: state.propagate(600 * u.s), state.to_elements, state.to_equinoctial):
        with pytest.raises(InvalidInputError, match=match):
            call()


def test_itrs_and_gcrs_written_as_ref_frame_are_visvivas_frames():
    base = OPM_KVN.split("SEMI_MAJOR_AXIS")[0]
    for name, frame in (("ITRS", "itrs"), ("GCRS", "gcrs")):
        opm = vv.read_opm(base.replace("REF_FRAME = GCRF", f"REF_FRAME = {name}"))
        assert opm.visviva_frame == frame and opm.state.frame == frame
        assert f"REF_FRAME            = {name}" in vv.write_opm(opm)
    tod = vv.read_opm(base.replace("REF_FRAME = GCRF", "REF_FRAME = TOD")).state
    assert tod.to_elements().semi_major_axis.to_value(u.km) == pytest.approx(15951.237, abs=1e-2)


# -- sat.teme(t).to_state_vectors() keeps TEME -------------------------------------------------
ISS = ("1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
       "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 10001")


def test_plain_states_of_teme_states_stay_teme():
    # was: plain states, taken for GCRS: propagate_cowell ran TEME numbers as GCRS ones, and
    # vv.fit_tle fitted them as GCRS (a TLE 35.5 km from the satellite over half a day)
    from visviva.ccsds.oem import OEMSegment

    iss = vv.Satellite.from_tle(*ISS)
    t = np.linspace(0.0, 0.25, 13) * u.day
    plain = iss.teme(t).to_state_vectors()
    assert type(plain) is vv.StateVectors
    with pytest.raises(InvalidInputError, match="in TEME .*teme_to_gcrs"):
        vv.propagate_cowell(plain[0], 60 * u.s)
    fitted = vv.fit_tle(plain)
    err = np.linalg.norm(fitted.teme(t).r.to_value(u.km) - plain.r.to_value(u.km), axis=-1)
    assert err.max() < 1e-6  # km
    seg = OEMSegment.from_states(plain, object_name="ISS")
    assert seg.frame == "TEME"
    with pytest.raises(InvalidInputError, match="in TEME"):
        OEMSegment.from_states(plain, object_name="ISS", frame="GCRF")
    gcrs = iss.gcrs(t).to_state_vectors()  # (GCRS ones stay plain and unmarked)
    assert getattr(gcrs, "_foreign_frame", None) is None


def test_fit_tle_refuses_plain_states_of_a_frame_it_cannot_rotate():
    # was: TOD states (an OEM's seg.states) fitted as GCRS
    text, *_ = _teme_of_epoch_oem(None)
    states = vv.read_oem(text.replace("REF_FRAME = TEME", "REF_FRAME = TOD")).segments[0].states
    with pytest.raises(InvalidInputError, match="REF_FRAME = TOD .*cannot rotate"):
        vv.fit_tle(states)


def test_look_angles_of_plain_teme_states_and_of_tod_states():
    # was: plain states taken for GCRS: TEME ones (to_state_vectors) 27.7 km in range and
    # 0.73 deg in elevation off over a fifth of a day at this site; TOD ones likewise
    iss = vv.Satellite.from_tle(*ISS)
    site = vv.GroundStation(40.4 * u.deg, -4.25 * u.deg, 0.8 * u.km)
    t = iss.epoch + np.linspace(0.0, 0.2, 40) * u.day
    framed = iss.teme(t)
    a, b = site.look(framed), site.look(framed.to_state_vectors())
    np.testing.assert_array_equal(a.range.to_value(u.km), b.range.to_value(u.km))
    np.testing.assert_array_equal(a.elevation.to_value(u.deg), b.elevation.to_value(u.deg))
    text, *_ = _teme_of_epoch_oem(None)
    tod = vv.read_oem(text.replace("REF_FRAME = TEME", "REF_FRAME = TOD")).segments[0].states
    with pytest.raises(InvalidInputError, match="REF_FRAME = TOD, which visviva cannot rotate"):
        site.look(tod)
    from visviva.conjunctions.sources import _frame

    assert _frame(framed.to_state_vectors(), "primary") == "TEME"
    with pytest.raises(InvalidInputError, match=r"primary\[0\] is in REF_FRAME = TOD"):
        _frame(tod, "primary[0]")
