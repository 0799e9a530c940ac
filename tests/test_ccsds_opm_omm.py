"""OPM and OMM: reading, writing (KVN and XML), the physics objects, errors naming the line."""

import math

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from hypothesis import given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva.ccsds.opm import OPM

OPM_KVN = """CCSDS_OPM_VERS = 3.0
COMMENT written for the visviva tests, in the layout of CCSDS 502.0-B-3 annex G
CREATION_DATE = 2024-03-01T10:00:00
ORIGINATOR = VISVIVA TESTS

COMMENT metadata
OBJECT_NAME = TESTSAT
OBJECT_ID = 2024-999A
CENTER_NAME = EARTH
REF_FRAME = GCRF
TIME_SYSTEM = UTC

COMMENT state vector
EPOCH = 2024-03-01T00:00:00.000
X = 6503.514000 [km]
Y = 1239.647000 [km]
Z = -717.490000 [km]
X_DOT = -0.873160 [km/s]
Y_DOT = 8.740420 [km/s]
Z_DOT = -4.191076 [km/s]

SEMI_MAJOR_AXIS = 15951.2370 [km]
ECCENTRICITY = 0.5914452
INCLINATION = 25.720971 [deg]
RA_OF_ASC_NODE = 177.790676 [deg]
ARG_OF_PERICENTER = 174.842602 [deg]
TRUE_ANOMALY = 19.531881 [deg]
GM = 398600.4415 [km**3/s**2]

MASS = 3000.0 [kg]
SOLAR_RAD_AREA = 18.77 [m**2]
SOLAR_RAD_COEFF = 1.0
DRAG_AREA = 18.77 [m**2]
DRAG_COEFF = 2.5

COV_REF_FRAME = RTN
CX_X = 3.331349476038534e-04 [km**2]
CY_X = 4.618927349220216e-04 [km**2]
CY_Y = 6.782421679971363e-04 [km**2]
CZ_X = -3.070007847730449e-04 [km**2]
CZ_Y = -4.221234189514228e-04 [km**2]
CZ_Z = 3.231931992380369e-04 [km**2]
CX_DOT_X = -3.349365033922630e-07 [km**2/s]
CX_DOT_Y = -4.686084221046758e-07 [km**2/s]
CX_DOT_Z = 2.484949578400095e-07 [km**2/s]
CX_DOT_X_DOT = 4.296022805587290e-10 [km**2/s**2]
CY_DOT_X = -2.211832501084875e-07 [km**2/s]
CY_DOT_Y = -2.864186892102733e-07 [km**2/s]
CY_DOT_Z = 1.798098699846038e-07 [km**2/s]
CY_DOT_X_DOT = 2.608899201686016e-10 [km**2/s**2]
CY_DOT_Y_DOT = 1.767514756338532e-10 [km**2/s**2]
CZ_DOT_X = -3.041346050686871e-07 [km**2/s]
CZ_DOT_Y = -4.989496988610662e-07 [km**2/s]
CZ_DOT_Z = 3.540310904497689e-07 [km**2/s]
CZ_DOT_X_DOT = 1.869263192954590e-10 [km**2/s**2]
CZ_DOT_Y_DOT = 1.008862586240695e-10 [km**2/s**2]
CZ_DOT_Z_DOT = 6.224444338635500e-10 [km**2/s**2]

COMMENT first burn
MAN_EPOCH_IGNITION = 2024-03-01T09:00:34.1
MAN_DURATION = 132.60 [s]
MAN_DELTA_MASS = -18.418 [kg]
MAN_REF_FRAME = EME2000
MAN_DV_1 = -0.02325700 [km/s]
MAN_DV_2 = 0.01683160 [km/s]
MAN_DV_3 = -0.00893444 [km/s]

COMMENT second burn
MAN_EPOCH_IGNITION = 2024-03-02T09:00:34.1
MAN_DURATION = 0.0 [s]
MAN_DELTA_MASS = 0.0 [kg]
MAN_REF_FRAME = RTN
MAN_DV_1 = 0.001 [km/s]
MAN_DV_2 = 0.0 [km/s]
MAN_DV_3 = 0.0 [km/s]
USER_DEFINED_EARTH_MODEL = WGS-84
"""

OMM_KVN = """CCSDS_OMM_VERS = 3.0
CREATION_DATE = 2024-01-02T00:00:00
ORIGINATOR = VISVIVA TESTS
OBJECT_NAME = ISS (ZARYA)
OBJECT_ID = 1998-067A
CENTER_NAME = EARTH
REF_FRAME = TEME
TIME_SYSTEM = UTC
MEAN_ELEMENT_THEORY = SGP4
COMMENT mean elements
EPOCH = 2024-01-01T12:00:00.000000
MEAN_MOTION = 15.49815350 [rev/day]
ECCENTRICITY = 0.0006703
INCLINATION = 51.6416 [deg]
RA_OF_ASC_NODE = 247.4627 [deg]
ARG_OF_PERICENTER = 130.5360 [deg]
MEAN_ANOMALY = 325.0288 [deg]
EPHEMERIS_TYPE = 0
CLASSIFICATION_TYPE = U
NORAD_CAT_ID = 25544
ELEMENT_SET_NO = 900
REV_AT_EPOCH = 1000
BSTAR = 0.00010270 [1/ER]
MEAN_MOTION_DOT = 0.00016717 [rev/day**2]
MEAN_MOTION_DDOT = 0.0 [rev/day**3]
"""
ISS = ("1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
       "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 10001")


def test_opm_physics_objects():
    opm = vv.read_opm(OPM_KVN)
    assert (opm.frame, opm.center, opm.visviva_frame) == ("GCRF", "EARTH", "gcrs")
    assert abs((opm.epoch - Time("2024-03-01T00:00:00", scale="utc")).sec) < 1e-9
    s = opm.state
    assert isinstance(s, vv.StateVectors) and s.gm.to_value(u.km**3 / u.s**2) == 398600.4415
    np.testing.assert_array_equal(s.v.to_value(u.km / u.s), [-0.873160, 8.740420, -4.191076])
    first, second = opm.maneuvers
    assert first.frame == "EME2000" and first.duration == 132.6 * u.s
    assert first.delta_mass == -18.418 * u.kg
    np.testing.assert_array_equal(first.delta_v.to_value(u.km / u.s), [-0.023257, 0.0168316, -0.00893444])
    assert abs((second.epoch - first.epoch).to_value(u.day) - 1) < 1e-12
    written = opm.sections["covariance"]  # (COV_REF_FRAME = RTN: opm.covariance is rotated)
    assert written["CX_DOT_X"] == -3.349365033922630e-07
    assert written["CZ_DOT_Y_DOT"] == 1.008862586240695e-10
    cov = opm.covariance
    assert cov.shape == (6, 6) and np.allclose(cov, cov.T, rtol=1e-12, atol=0)
    assert opm.sections["user_defined"]["EARTH_MODEL"] == "WGS-84"
    assert opm.sections["maneuvers"][1].comments == ["second burn"]
    assert opm.sections["spacecraft_parameters"]["DRAG_COEFF"] == 2.5


@pytest.mark.parametrize("fmt", ["kvn", "xml"])
def test_opm_round_trip_every_field(fmt, tmp_path):
    opm = vv.read_opm(OPM_KVN)
    text = vv.write_opm(opm, tmp_path / f"m.{fmt}")
    assert text.lstrip().startswith("<" if fmt == "xml" else "CCSDS_OPM_VERS")
    back = vv.read_opm(tmp_path / f"m.{fmt}")
    for name, record in opm.sections.items():
        other = back.sections[name]
        if isinstance(record, list):
            assert [r.values for r in record] == [r.values for r in other]
            assert [r.comments for r in record] == [r.comments for r in other]
        else:
            assert record.values == other.values and record.comments == other.comments
    assert vv.write_opm(back, format=fmt) == text


@pytest.mark.parametrize("edit, marker, words", [
    (("X_DOT = -0.873160 [km/s]", "X_DOT = -0.873160 [m/s]"), "X_DOT", r"X_DOT must be in \[km/s\]"),
    (("Z = -717.490000 [km]\n", ""), "EPOCH =", "lacks the mandatory keyword Z"),
    (("TRUE_ANOMALY = 19.531881 [deg]",
      "MEAN_ANOMALY = 4.102193 [deg]\nTRUE_ANOMALY = 19.531881 [deg]"),
     "SEMI_MAJOR", "exactly one of TRUE_ANOMALY and MEAN_ANOMALY"),
    (("MAN_DV_2 = 0.0 [km/s]\n", ""), "MAN_EPOCH_IGNITION = 2024-03-02",
     "lacks the mandatory keyword MAN_DV_2"),
    (("MAN_DURATION = 132.60 [s]", "MAN_DURATION = -132.60 [s]"), "MAN_DURATION",
     "MAN_DURATION = -132.6 s: a burn lasts >= 0 s"),
    (("MAN_DELTA_MASS = -18.418 [kg]", "MAN_DELTA_MASS = 18.418 [kg]"), "MAN_DELTA_MASS",
     "a manoeuvre spends mass"),
    (("CY_Y = 6.782", "CY_Y = -6.782"), "CY_Y", "CY_Y = -0.000678.* is a variance"),
    (("DRAG_COEFF = 2.5", "DRAG_COEF = 2.5"), "DRAG_COEF ", "DRAG_COEF: not a keyword of an OPM"),
    (("EPOCH = 2024-03-01T00:00:00.000", "EPOCH = 2024-03-01 00:00"), "EPOCH =",
     "not a CCSDS epoch"),
    (("MASS = 3000.0 [kg]\n", "MASS = 3000.0 [kg]\nMASS = 1 [kg]\n"), "MASS = 1 ",
     r"given twice .*\(first on line 30\)"),
    # a bad date named the TIME_SYSTEM line; a manoeuvre's was not checked at read at all
    (("EPOCH = 2024-03-01T00:00:00.000", "EPOCH = 2024-02-30T00:00:00.000"), "EPOCH =",
     "2024-02-30T00:00:00.000' is not a date that exists .day 30 of a month of 29 days"),
    (("MAN_EPOCH_IGNITION = 2024-03-02T09:00:34.1", "MAN_EPOCH_IGNITION = 2024-03-02T25:00:34.1"),
     "MAN_EPOCH_IGNITION = 2024-03-02", "is not a date that exists .time 25:00:34.1"),
    # impossible values were read silently
    (("ECCENTRICITY = 0.5914452", "ECCENTRICITY = -0.5914452"), "ECCENTRICITY",
     "ECCENTRICITY = -0.5914452"),
    (("GM = 398600.4415", "GM = -398600.4415"), "GM =", "GM = -398600.4415"),
    (("MASS = 3000.0", "MASS = -3000.0"), "MASS =", "MASS = -3000.0"),
    (("DRAG_AREA = 18.77", "DRAG_AREA = -18.77"), "DRAG_AREA", "DRAG_AREA = -18.77"),
    (("SEMI_MAJOR_AXIS = 15951.2370", "SEMI_MAJOR_AXIS = -15951.2370"), "SEMI_MAJOR_AXIS",
     "SEMI_MAJOR_AXIS = -15951.237 .* ECCENTRICITY = 0.5914452"),
    (("CREATION_DATE = 2024-03-01T10:00:00", "CREATION_DATE = 2024-02-30T10:00:00"),
     "CREATION_DATE", "not a date that exists .day 30 of a month of 29 days"),
])
def test_opm_errors_name_the_line(edit, marker, words):
    assert edit[0] in OPM_KVN
    text = OPM_KVN.replace(edit[0], edit[1], 1)
    line = next(k for k, s in enumerate(text.splitlines(), 1) if s.startswith(marker))
    with pytest.raises(vv.CCSDSFormatError, match=words) as info:
        vv.read_opm(text)
    assert info.value.line == line, str(info.value)


def test_opm_from_state_refuses_impossible_manoeuvres():
    from visviva.ccsds.opm import Maneuver

    epoch = Time("2025-01-01T00:00:00", scale="utc")
    state = vv.StateVectors([7000, 0, 0] * u.km, [0, 7.5, 0] * u.km / u.s, vv.EARTH, epoch=epoch)
    dv = [0, 1, 0] * u.m / u.s
    for burn, words in ((Maneuver(epoch, -1 * u.s, -1 * u.kg, "RTN", dv), "lasts >= 0 s"),
                        (Maneuver(epoch, 1 * u.s, 1 * u.kg, "RTN", dv), "spends mass")):
        with pytest.raises(vv.InvalidInputError, match=words):
            OPM.from_state(state, object_name="H", maneuvers=[burn])
    with pytest.raises(vv.InvalidInputError, match="variances >= 0"):
        OPM.from_state(state, object_name="H", covariance=-np.eye(6))


def test_opm_from_state_keeps_manoeuvres_given_as_a_generator():
    # the manoeuvres were iterated twice (checks, then the section): a generator was used up by
    # the checks and the OPM was written without its manoeuvres, silently
    from visviva.ccsds.opm import Maneuver

    epoch = Time("2025-01-01T00:00:00", scale="utc")
    state = vv.StateVectors([7000, 0, 0] * u.km, [0, 7.5, 0] * u.km / u.s, vv.EARTH, epoch=epoch)
    burns = [Maneuver(epoch + k * u.h, 0 * u.s, -1 * u.kg, "RTN", [0, 1, 0] * u.m / u.s)
             for k in (1, 2)]
    opm = vv.read_opm(vv.write_opm(OPM.from_state(state, object_name="G",
                                                  maneuvers=(b for b in burns))))
    assert [round(float((m.epoch - epoch).to_value(u.s)), 6) for m in opm.maneuvers] == [3600.0, 7200.0]


@pytest.mark.parametrize("field, value, error, words", [
    ("mass", 100.0, vv.UnitsError, "mass"),
    ("mass", 5 * u.m, vv.UnitsError, "mass"),
    ("mass", [1, 2] * u.kg, vv.InvalidInputError, "one value"),
    ("delta_mass", -1 * u.m, vv.UnitsError, "delta_mass"),
    ("duration", 1 * u.kg, vv.UnitsError, "duration"),
    ("delta_v", [0, 1] * u.m / u.s, vv.InvalidInputError, "shape"),
    ("delta_v", [0, 1, 0] * u.m, vv.UnitsError, "delta_v"),
    ("epoch", 600 * u.s, vv.InvalidInputError, "astropy Time"),
])
def test_opm_from_state_refuses_bad_masses_and_manoeuvre_fields(field, value, error, words):
    # were astropy's UnitConversionError, numpy's TypeError or an AttributeError ('Quantity'
    # object has no 'utc' member)
    from visviva.ccsds.opm import Maneuver

    epoch = Time("2025-01-01T00:00:00", scale="utc")
    state = vv.StateVectors([7000, 0, 0] * u.km, [0, 7.5, 0] * u.km / u.s, vv.EARTH, epoch=epoch)
    fields = {"epoch": epoch + 60 * u.s, "duration": 0 * u.s, "delta_mass": -1 * u.kg,
              "frame": "RTN", "delta_v": [0, 1, 0] * u.m / u.s}
    mass = 100 * u.kg
    if field == "mass":
        mass = value
    else:
        fields[field] = value
    with pytest.raises(error, match=words):
        OPM.from_state(state, object_name="H", maneuvers=[Maneuver(**fields)], mass=mass)


def test_omm_reads_into_satellite_like_the_tle():
    omm = vv.read_omm(OMM_KVN)
    assert isinstance(omm, dict) and omm["NORAD_CAT_ID"] == 25544 and omm["BSTAR"] == 1.027e-4
    assert omm.comments["mean_elements"] == ["mean elements"] and omm.lines["BSTAR"] == 23
    from_omm = vv.Satellite.from_omm(omm)
    from_tle = vv.Satellite.from_tle(*ISS)
    t = from_tle.epoch + np.linspace(0, 1, 5) * u.day
    np.testing.assert_allclose(from_omm.teme(t).r.to_value(u.km), from_tle.teme(t).r.to_value(u.km),
                               rtol=0, atol=1e-6)


@pytest.mark.parametrize("fmt", ["kvn", "xml"])
def test_omm_round_trip(fmt):
    omm = vv.read_omm(OMM_KVN)
    back = vv.read_omm(vv.write_omm(omm, format=fmt))
    assert dict(back) == dict(omm) and back.comments == omm.comments


def test_omm_errors():
    with pytest.raises(vv.CCSDSFormatError, match=r"line 12: MEAN_MOTION must be in \[rev/day\]"):
        vv.read_omm(OMM_KVN.replace("15.49815350 [rev/day]", "15.49815350 [rev/s]"))
    with pytest.raises(vv.CCSDSFormatError, match="exactly one of SEMI_MAJOR_AXIS and MEAN_MOTION"):
        vv.read_omm(OMM_KVN.replace("MEAN_MOTION = 15.49815350 [rev/day]\n", ""))
    with pytest.raises(vv.InvalidInputError, match="FOO is not an OMM keyword"):
        vv.write_omm({**vv.read_omm(OMM_KVN), "FOO": 1})
    with pytest.raises(vv.InvalidInputError, match="no ORIGINATOR"):
        vv.write_omm(vv.Satellite.from_tle(*ISS).to_omm())
    with pytest.raises(vv.InvalidInputError, match="BSTAR = 'x' is not a valid float"):
        vv.write_omm({**vv.read_omm(OMM_KVN), "BSTAR": "x"})
    # both (or neither) of SEMI_MAJOR_AXIS and MEAN_MOTION were written, into a file that
    # read_omm refuses
    with pytest.raises(vv.InvalidInputError, match="exactly one of SEMI_MAJOR_AXIS"):
        vv.write_omm({**vv.read_omm(OMM_KVN), "SEMI_MAJOR_AXIS": 6790.0})
    neither = dict(vv.read_omm(OMM_KVN))
    del neither["MEAN_MOTION"]
    with pytest.raises(vv.InvalidInputError, match="refuses neither"):
        vv.write_omm(neither)


def test_to_tle_reproduces_the_lines_and_sgp4_exporter():
    from sgp4.exporter import export_omm, export_tle

    sat = vv.Satellite.from_tle(*ISS)
    assert sat.to_tle() == ISS == export_tle(sat.satrec)
    ours, theirs = sat.to_omm(), export_omm(sat.satrec, sat.name)
    assert ours.keys() == theirs.keys()
    for key, value in theirs.items():
        if key == "EPOCH":  # rounded here, truncated by sgp4: within a microsecond
            assert abs((Time(ours[key]) - Time(value)).to_value(u.us)) <= 1.0
        else:
            assert ours[key] == value or abs(ours[key] - value) <= 4e-16 * abs(value), key


def test_alpha5_and_checksums():
    from sgp4.api import Satrec

    l1 = "1 A0001U 24001A   24001.50000000 -.00000112  00000-0 -14157-3 0  9990"
    l2 = "2 A0001  98.7000  10.0000 0012000  90.0000 270.0000 14.20000000    10"
    sat = vv.Satellite.from_tle(l1, l2, verify_checksum=False)
    assert sat.satnum == 100001
    line1, line2 = sat.to_tle()
    assert line1[2:7] == "A0001" == line2[2:7]
    assert len(line1) == len(line2) == 69
    for line in (line1, line2):  # the checksum is the sum of digits with '-' as 1, modulo 10
        assert int(line[68]) == sum(int(c) if c.isdigit() else c == "-" for c in line[:68]) % 10
    ref = Satrec.twoline2rv(line1, line2)
    assert ref.satnum == 100001 and ref.bstar == sat.satrec.bstar


@settings(max_examples=60, deadline=None)
@given(n=st.floats(1.0, 16.5), e=st.floats(0.0, 0.9), i=st.floats(0.0, 180.0),
       raan=st.floats(0.0, 359.9999), argp=st.floats(0.0, 359.9999), m=st.floats(0.0, 359.9999),
       bstar=st.floats(-1e-2, 1e-2), satnum=st.integers(1, 339999),
       ndot=st.floats(-0.5, 0.5), day=st.floats(1.0, 365.9))
def test_hypothesis_tle_and_omm_round_trip_through_sgp4(n, e, i, raan, argp, m, bstar, satnum,
                                                        ndot, day):
    """TLE text -> Satrec -> to_tle gives the same text; to_omm -> from_omm the same record."""
    from sgp4.alpha5 import to_alpha5
    from sgp4.api import Satrec

    from visviva.satellites.tle_export import format_exponent, tle_checksum

    num = to_alpha5(satnum) if satnum > 99999 else f"{satnum:05d}"
    l1 = (f"1 {num}U 24001A   24{day:012.8f} {f'{ndot: .8f}'.replace('0.', '.', 1)} "
          f"{format_exponent(0.0, 'x', '-')} {format_exponent(bstar, 'B*')} 0  999")
    l2 = (f"2 {num} {i:8.4f} {raan:8.4f} {f'{e:.7f}'[2:]} {argp:8.4f} {m:8.4f} {n:11.8f}12345")
    l1, l2 = l1 + str(tle_checksum(l1)), l2 + str(tle_checksum(l2))
    sat = vv.Satellite.from_tle(l1, l2)
    assert sat.to_tle() == (l1, l2)
    again = vv.Satellite.from_omm(sat.to_omm()).satrec
    ref = Satrec.twoline2rv(l1, l2)
    for key in ("no_kozai", "ecco", "inclo", "nodeo", "argpo", "mo", "bstar", "ndot", "satnum"):
        # exact, except where sgp4's OMM reader (one multiplication) cannot hit the TLE's value:
        # then the nearest float it can reach, one unit in the last place away
        a, b = getattr(again, key), getattr(ref, key)
        assert abs(a - b) <= math.ulp(b), key
    # the OMM epoch is rounded to the microsecond: within 0.5 us (5.8e-12 day)
    dt_day = (again.jdsatepoch - ref.jdsatepoch) + (again.jdsatepochF - ref.jdsatepochF)
    assert abs(dt_day) * 86400e6 <= 0.5 + 1e-3


_finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)


@settings(max_examples=30, deadline=None)
@given(r=st.lists(st.floats(-5e4, 5e4).filter(lambda x: abs(x) > 1.0), min_size=3, max_size=3),
       v=st.lists(_finite.map(lambda x: x * 1e-5), min_size=3, max_size=3),
       dv=st.lists(_finite.map(lambda x: x * 1e-8), min_size=3, max_size=3),
       fmt=st.sampled_from(["kvn", "xml"]), with_cov=st.booleans(),
       seconds=st.floats(0, 86400 * 365))
def test_hypothesis_opm_round_trip(r, v, dv, fmt, with_cov, seconds):
    from visviva.ccsds.opm import Maneuver

    epoch = Time("2025-01-01T00:00:00", scale="utc") + seconds * u.s
    state = vv.StateVectors(r * u.km, v * u.km / u.s, vv.EARTH, epoch=epoch)
    burn = Maneuver(epoch + 60 * u.s, 12.5 * u.s, -0.25 * u.kg, "RTN", dv * (u.km / u.s))
    a = np.arange(36.0).reshape(6, 6)
    opm = OPM.from_state(state, object_name="H", maneuvers=[burn],
                         covariance=a @ a.T if with_cov else None)
    back = vv.read_opm(vv.write_opm(opm, format=fmt))
    np.testing.assert_array_equal(back.state.r.to_value(u.km), r)
    np.testing.assert_array_equal(back.state.v.to_value(u.km / u.s), v)
    assert abs((back.epoch - epoch).to_value(u.s)) < 1e-9
    np.testing.assert_array_equal(back.maneuvers[0].delta_v.to_value(u.km / u.s), dv)
    if with_cov:
        np.testing.assert_array_equal(back.covariance, a @ a.T)
    for name, record in back.sections.items():
        if name != "maneuvers":  # everything as given, plus the CREATION_DATE the writer added
            added = {"CREATION_DATE"} if name == "header" else set()
            assert set(record.values) == set(opm.sections[name].values) | added
            assert all(record[k] == v for k, v in opm.sections[name].values.items())
    assert back.sections["maneuvers"][0].values == opm.sections["maneuvers"][0].values


@settings(max_examples=30, deadline=None)
@given(values=st.fixed_dictionaries({
    "MEAN_MOTION": st.floats(0.5, 17.0), "ECCENTRICITY": st.floats(0.0, 0.99),
    "INCLINATION": st.floats(0.0, 180.0), "RA_OF_ASC_NODE": st.floats(0.0, 360.0),
    "ARG_OF_PERICENTER": st.floats(0.0, 360.0), "MEAN_ANOMALY": st.floats(0.0, 360.0),
    "BSTAR": st.floats(-1.0, 1.0), "NORAD_CAT_ID": st.integers(1, 999_999_999),
    "MEAN_MOTION_DOT": st.floats(-1.0, 1.0), "MEAN_MOTION_DDOT": st.floats(-1.0, 1.0)}),
    fmt=st.sampled_from(["kvn", "xml"]))
def test_hypothesis_omm_round_trip(values, fmt):
    omm = dict(vv.read_omm(OMM_KVN))
    omm.update(values)
    back = vv.read_omm(vv.write_omm(omm, format=fmt))
    assert dict(back) == omm
    vv.Satellite.from_omm(back)  # what the OMM is for


def test_omm_inside_an_ndm_wrapper():
    xml = vv.write_omm(vv.read_omm(OMM_KVN), format="xml")
    body = xml.split("\n", 1)[1]
    wrapped = f'<?xml version="1.0" encoding="UTF-8"?>\n<ndm>\n{body}</ndm>\n'
    assert dict(vv.read_omm(wrapped)) == dict(vv.read_omm(OMM_KVN))
    with pytest.raises(vv.CCSDSFormatError, match="holds 2 <omm> messages"):
        vv.read_omm(f"<ndm>\n{body}{body}</ndm>\n")


def test_xml_unknown_elements_name_the_line():
    xml = vv.write_opm(vv.read_opm(OPM_KVN), format="xml")
    lines = xml.splitlines()
    k = next(i for i, s in enumerate(lines) if "<stateVector>" in s)
    bad = "\n".join(lines[:k] + ["<orbitStuff>1</orbitStuff>"] + lines[k:])
    with pytest.raises(vv.CCSDSFormatError, match="<orbitStuff> does not belong in <data>") as e:
        vv.read_opm(bad)
    assert e.value.line == k + 1


def test_opm_in_mission_elapsed_time():
    launch = Time("2024-03-01T10:00:00", scale="utc")
    epoch = launch + (2 * 86400 + 3661.25) * u.s
    state = vv.StateVectors([7000, 0, 0] * u.km, [0, 7.5, 0] * u.km / u.s, vv.EARTH, epoch=epoch)
    opm = OPM.from_state(state, object_name="M", time_system="MET", mission_epoch=launch)
    assert opm.sections["state_vector"]["EPOCH"] == "0000-002T01:01:01.250000000"
    text = vv.write_opm(opm)
    with pytest.raises(vv.CCSDSFormatError, match="MET counts time from the launch epoch"):
        vv.read_opm(text)
    back = vv.read_opm(text, mission_epoch=launch)
    assert abs((back.epoch - epoch).sec) < 1e-9


# -- audit -----------------------------------------------------------------------------------------


@pytest.mark.parametrize("edit, words", [
    # each was propagated with SGP4 as if it said UTC / TEME / SGP4 / EARTH: a TDB epoch is
    # 69 s late (about 500 km along a low orbit), other mean elements are not SGP4's
    (("TIME_SYSTEM = UTC", "TIME_SYSTEM = TDB"), "TIME_SYSTEM = TDB"),
    (("REF_FRAME = TEME", "REF_FRAME = GCRF"), "REF_FRAME = GCRF"),
    (("MEAN_ELEMENT_THEORY = SGP4", "MEAN_ELEMENT_THEORY = DSST"), "MEAN_ELEMENT_THEORY = DSST"),
    (("CENTER_NAME = EARTH", "CENTER_NAME = MOON"), "CENTER_NAME = MOON"),
])
def test_from_omm_refuses_mean_elements_sgp4_cannot_use(edit, words):
    omm = vv.read_omm(OMM_KVN.replace(*edit))
    with pytest.raises(vv.InvalidInputError, match=words):
        vv.Satellite.from_omm(omm)
    # the same in lower case or with spaces is accepted when it says what SGP4 needs
    ok = vv.read_omm(OMM_KVN.replace("TIME_SYSTEM = UTC", "TIME_SYSTEM = utc"))
    assert vv.Satellite.from_omm(ok).satnum == 25544


@pytest.mark.parametrize("year", ["2060", "1950"])
def test_to_tle_refuses_an_epoch_its_two_digit_year_cannot_hold(year):
    # a TLE's year has two digits, 57..99 for 1957..1999 and 00..56 for 2000..2056: an epoch
    # in 2060 was written "60" and read back as 1960, silently a century off
    sat = vv.Satellite.from_omm(vv.read_omm(OMM_KVN.replace("EPOCH = 2024", f"EPOCH = {year}")))
    with pytest.raises(vv.InvalidInputError, match="1957 .. 2056"):
        sat.to_tle()
    assert vv.Satellite.from_omm(sat.to_omm()).epoch == sat.epoch  # the OMM holds it
    for ok in ("2056", "1957"):
        s = vv.Satellite.from_omm(vv.read_omm(OMM_KVN.replace("EPOCH = 2024", f"EPOCH = {ok}")))
        assert vv.Satellite.from_tle(*s.to_tle()).epoch.isot == s.epoch.isot


def test_opm_from_satellite_states_writes_their_frame():
    # OPM.from_state(sat.teme(t)) wrote TEME numbers under REF_FRAME = GCRF (its default), ~40 km
    # off for anyone reading the file, with no error
    from visviva.ccsds.opm import OPM

    sat = vv.Satellite.from_tle(
        "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
        "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340")
    for mine, ccsds in (("teme", "TEME"), ("gcrs", "GCRF"), ("itrs", "ITRF")):
        state = getattr(sat, mine)(sat.epoch)
        opm = vv.read_opm(vv.write_opm(OPM.from_state(state, object_name="ISS")))
        assert opm.frame == ccsds and opm.state.frame == mine
        np.testing.assert_array_equal(opm.state.r, state.r)
    assert OPM.from_state(sat.gcrs(sat.epoch), object_name="ISS", frame="EME2000").frame == "EME2000"
    with pytest.raises(vv.InvalidInputError, match="TEME.*GCRF"):
        OPM.from_state(sat.teme(sat.epoch), object_name="ISS", frame="GCRF")
    plain = sat.gcrs(sat.epoch).to_state_vectors()
    assert OPM.from_state(plain, object_name="ISS").frame == "GCRF"  # plain states: as before


def _omm_with_covariance(cov_frame, theory="SGP4"):
    """OMM_KVN with the OPM's covariance section (COV_REF_FRAME = cov_frame, or none)."""
    cov = OPM_KVN[OPM_KVN.index("CX_X ="):]
    head = "" if cov_frame is None else f"COV_REF_FRAME = {cov_frame}\n"
    return (OMM_KVN.replace("MEAN_ELEMENT_THEORY = SGP4", f"MEAN_ELEMENT_THEORY = {theory}")
            + head + cov[:cov.index("\n\n") + 1 if "\n\n" in cov else len(cov)])


def test_omm_covariance_is_rotated_from_a_local_frame_about_sgp4s_state():
    """An OMM's covariance was kept as written, never rotated: a COV_REF_FRAME = RTN matrix
    was on the RTN axes of an unknown state while opm.covariance and seg.covariance(k) rotate
    theirs. omm.covariance now gives it on the TEME axes of omm.state (SGP4 at EPOCH), as the
    OPM does; TEME itself is kept, other frames and non-SGP4 elements are refused saying why."""
    from visviva.ccsds.covariance import from_state_axes, matrix_from_values
    from visviva.conjunctions.covariance import rtn_to_inertial

    omm = vv.read_omm(_omm_with_covariance("RTN"))
    written = matrix_from_values(omm)
    state = omm.state
    assert state.frame == "teme" and abs((state.epoch - Time("2024-01-01T12:00:00",
                                                             scale="utc")).sec) < 1e-6
    sat = vv.Satellite.from_omm(omm)
    np.testing.assert_array_equal(state.r.to_value(u.km), sat.teme(0 * u.s).r.to_value(u.km))
    r, v = state.r.to_value(u.km), state.v.to_value(u.km / u.s)
    cov = omm.covariance
    np.testing.assert_allclose(cov, rtn_to_inertial(written, r, v), rtol=0, atol=1e-15)
    # the in-track variance is the variance along the in-track direction of the TEME state
    s_hat = np.cross(np.cross(r, v), r)
    s_hat /= np.linalg.norm(s_hat)
    assert s_hat @ cov[:3, :3] @ s_hat == pytest.approx(written[1, 1], rel=1e-12)
    for fmt in ("kvn", "xml"):  # kept through writing, rotated the same when read back
        back = vv.read_omm(vv.write_omm(omm, format=fmt))
        np.testing.assert_allclose(back.covariance, cov, rtol=0, atol=1e-15)
    # a rotating frame: the inverse of the writer's rotation, with SGP4's WGS-72 GM
    lvlh = vv.read_omm(_omm_with_covariance("LVLH_ROTATING"))
    again = from_state_axes(lvlh.covariance, "LVLH_ROTATING", r, v, gm=398600.8)
    np.testing.assert_allclose(again, written, rtol=1e-12, atol=1e-18)
    for same in (None, "TEME"):  # the state's own axes: the matrix as written
        np.testing.assert_array_equal(vv.read_omm(_omm_with_covariance(same)).covariance,
                                      written)
    assert vv.read_omm(OMM_KVN).covariance is None
    with pytest.raises(vv.InvalidInputError, match=r"line 26: COV_REF_FRAME = EME2000 is "
                       r"neither REF_FRAME = TEME nor a local orbital frame"):
        _ = vv.read_omm(_omm_with_covariance("EME2000")).covariance
    with pytest.raises(vv.InvalidInputError, match="NSW axes need the Sun.*not on REF_FRAME "
                       "= TEME"):
        _ = vv.read_omm(_omm_with_covariance("NSW_INERTIAL")).covariance
    other = vv.read_omm(_omm_with_covariance("RTN", theory="DSST"))
    with pytest.raises(vv.InvalidInputError, match=r"COV_REF_FRAME = RTN, a local orbital "
                       r"frame, needs the state at EPOCH.*MEAN_ELEMENT_THEORY = DSST"):
        _ = other.covariance
    np.testing.assert_array_equal(vv.read_omm(_omm_with_covariance("TEME", "DSST")).covariance,
                                  written)
    # writing one in a local frame (docs/ccsds.md): the TEME matrix comes back
    from visviva.ccsds.covariance import values_from_matrix

    fields = sat.to_omm() | {"COV_REF_FRAME": "TNW",
                             **values_from_matrix(from_state_axes(cov, "TNW", r, v))}
    text = vv.write_omm(fields, originator="TESTS")
    np.testing.assert_allclose(vv.read_omm(text).covariance, cov, rtol=1e-12, atol=1e-18)


def test_opm_gm_in_m3_s2_is_refused_naming_its_line():
    """GM = 3.986e14 (m**3/s**2, the unit left out) was read silently and became the GM of
    opm.state: 1e9 times the Earth's, so every propagation of it was wrong."""
    text = OPM_KVN.replace("GM = 398600.4415 [km**3/s**2]", "GM = 3.986004415E14")
    line = next(k for k, s in enumerate(text.splitlines(), 1) if s.startswith("GM ="))
    with pytest.raises(vv.CCSDSFormatError, match=r"1e\+09 times the GM of CENTER_NAME = EARTH") \
            as info:
        vv.read_opm(text)
    assert info.value.line == line
    # a GM of another convention (EGM-96, WGS-84, DE440) is the same body's: read as written
    for gm in ("398600.4418", "398600.435507"):
        opm = vv.read_opm(OPM_KVN.replace("398600.4415", gm))
        assert opm.state.gm.to_value(u.km**3 / u.s**2) == float(gm)


def test_opm_keplerian_elements_are_checked_against_the_state_vector():
    """Elements that describe another orbit than the state vector (a = 7800 km, e = 0.1 for a
    state of a = 15951 km, e = 0.591) were read without a word; opm.state is the state
    vector's, while a user of the elements (Orekit's generateKeplerianOrbit) flies another."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        vv.read_opm(OPM_KVN)  # consistent to the digits written: no warning
        # the same state, its anomaly given as the mean anomaly
        vv.read_opm(OPM_KVN.replace("TRUE_ANOMALY = 19.531881", "MEAN_ANOMALY = 4.1021931"))
    wrong = OPM_KVN.replace("SEMI_MAJOR_AXIS = 15951.2370", "SEMI_MAJOR_AXIS = 7800.0")
    line = next(k for k, s in enumerate(wrong.splitlines(), 1) if s.startswith("SEMI_MAJOR"))
    with pytest.warns(UserWarning, match=rf"line {line}: the osculating Keplerian elements .* place "
                      r"the object \d+\.?\d* km .* from the state vector") as record:
        opm = vv.read_opm(wrong)
    assert "units (km, deg)" in str(record[0].message)
    assert opm.sections["keplerian_elements"]["SEMI_MAJOR_AXIS"] == 7800.0  # kept as written
    # the true anomaly written as MEAN_ANOMALY: 15.4 deg off along the orbit; the hint says so
    swapped = OPM_KVN.replace("TRUE_ANOMALY = 19.531881", "MEAN_ANOMALY = 19.531881")
    with pytest.warns(UserWarning, match="read as TRUE_ANOMALY, the MEAN_ANOMALY would agree"):
        vv.read_opm(swapped)
    # radians where degrees are due
    radians = OPM_KVN.replace("INCLINATION = 25.720971", "INCLINATION = 0.448920")
    with pytest.warns(UserWarning, match="do not describe the state vector's orbit"):
        vv.read_opm(radians)


def test_non_positive_definite_covariances_warn_when_read_and_are_kept():
    """A covariance with a correlation of 2.5 (CY_X = 2.5 sigma_x sigma_y) was read without a
    word; propagate_covariance later refused it and collision_probability repaired it. Reading
    an OEM (KVN, XML), OPM or OMM holding one now warns once per file, naming the first such
    block's line and its largest correlation, and keeps the numbers as written; the files as
    published, and rounding-level negatives (a -1e-18 relative eigenvalue), stay silent."""
    import warnings

    from test_ccsds_oem import OEM_KVN
    from visviva._covariance import not_psd

    # 5e-3 / sqrt(1e-3 * 4e-3) = 2.5, in the first of the two matrices
    oem_text = OEM_KVN.replace(" 2.0E-5  4.0E-3", " 5.0E-3  4.0E-3", 1)
    line = oem_text.splitlines().index("EPOCH = 2024-01-31T00:00:00") + 1
    with pytest.warns(UserWarning, match=rf"covariance at line {line} is not positive "
                      r"semi-definite.*largest correlation \|CY_X\|.* = 2\.5") as rec:
        eph = vv.read_oem(oem_text)
    assert sum("positive semi-definite" in str(w.message) for w in rec) == 1
    assert eph.segments[0].covariances[0].matrix[1, 0] == 5.0e-3  # kept as written
    xml = vv.write_oem(eph, format="xml")
    with pytest.warns(UserWarning, match=r"covariance at line \d+ is not positive semi-def"):
        assert vv.read_oem(xml).segments[0].covariances[0].matrix[1, 0] == 5.0e-3
    # OPM and OMM: CY_X = 2.5 sigma_x sigma_y
    sx, sy = math.sqrt(3.331349476038534e-04), math.sqrt(6.782421679971363e-04)
    cy_x = f"CY_X = {2.5 * sx * sy!r} [km**2]"
    opm_text = OPM_KVN.replace("CY_X = 4.618927349220216e-04 [km**2]", cy_x)
    with pytest.warns(UserWarning, match=r"not positive semi-definite.*\|CY_X\|.* = 2\.5"):
        vv.read_opm(opm_text)
    omm_text = _omm_with_covariance("RTN").replace("CY_X = 4.618927349220216e-04 [km**2]", cy_x)
    with pytest.warns(UserWarning, match=r"not positive semi-definite.*\|CY_X\|.* = 2\.5"):
        vv.read_omm(omm_text)
    m = np.diag([1.0, 1.0, 1e-3, 1e-7, 1e-7, 1e-7])
    m[0, 1] = m[1, 0] = 1.0 + 1e-18  # smallest eigenvalue -1e-18 of the largest
    assert not not_psd(m, full=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        vv.read_oem(OEM_KVN)
        vv.read_opm(OPM_KVN)
        vv.read_omm(_omm_with_covariance("RTN"))
