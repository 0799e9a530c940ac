"""CCSDS messages exchanged with other tools: spans, user-defined units, SGP4-XP element sets.

Regression tests of the second CCSDS audit (audit16); the messages are written by hand in the
layout of CCSDS 502.0-B-3.
"""

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv
from visviva.ccsds.timeframes import FRAME_BIAS

# a two-body arc sampled every minute (exact states: interpolation errors are the method's)
_T0 = Time("2024-01-31T00:00:00", scale="utc")


def _segment_text(start="2024-01-31T00:00:00", stop="2024-01-31T00:10:00", extra=""):
    state = vv.StateVectors([7000.0, 0.0, 0.0] * u.km, [0.0, 7.546, 1.0] * u.km / u.s,
                            vv.EARTH)
    lines = []
    for k in range(11):
        s = state.propagate(k * 60 * u.s)
        r, v = s.r.to_value(u.km), s.v.to_value(u.km / u.s)
        epoch = (_T0 + k * 60 * u.s).isot
        lines.append(f"{epoch} " + " ".join(repr(float(x)) for x in (*r, *v)))
    return (f"CCSDS_OEM_VERS = 2.0\nCREATION_DATE = 2024-01-31T00:00:00\nORIGINATOR = TEST\n"
            f"META_START\nOBJECT_NAME = SAT\nOBJECT_ID = 2024-999A\nCENTER_NAME = EARTH\n"
            f"REF_FRAME = EME2000\nTIME_SYSTEM = UTC\nSTART_TIME = {start}\n{extra}"
            f"STOP_TIME = {stop}\nINTERPOLATION = LAGRANGE\nINTERPOLATION_DEGREE = 5\n"
            f"META_STOP\n" + "\n".join(lines) + "\n")


@pytest.mark.parametrize("start, stop, query", [
    ("2024-01-30T23:00:00", "2024-01-31T00:10:00", "2024-01-30T23:30:00"),
    ("2024-01-31T00:00:00", "2024-01-31T01:00:00", "2024-01-31T00:40:00"),
    ("2024-01-31T00:00:00", "2024-01-31T01:00:00", "2024-01-31T00:10:00.5"),
])
def test_a_span_wider_than_the_states_is_not_extrapolated(start, stop, query):
    """START_TIME/STOP_TIME beyond the first/last state: a time there was extrapolated by the
    interpolating polynomial (1e12 m off, silently); now refused, saying where the states end."""
    oem = vv.read_oem(_segment_text(start, stop))
    t = Time(query, scale="utc")
    for call in (oem.interpolate, oem.segments[0].interpolate):
        with pytest.raises(vv.InvalidInputError, match="does not extrapolate"):
            call(t)
    # inside the states it still interpolates (two-body truth to 1 cm at degree 5)
    inside = Time("2024-01-31T00:05:30", scale="utc")
    truth = vv.StateVectors([7000.0, 0.0, 0.0] * u.km, [0.0, 7.546, 1.0] * u.km / u.s,
                            vv.EARTH).propagate((inside - _T0).to(u.s))
    got = oem.interpolate(inside)  # (EME2000 numbers, read on the GCRS axes: B.T r)
    assert np.linalg.norm(got.r.to_value(u.m) - FRAME_BIAS.T @ truth.r.to_value(u.m)) < 1e-2


def test_the_segment_boundary_still_picks_the_later_segment_within_its_states():
    """Two segments whose metadata spans overlap the other's states: each time takes a segment
    whose states cover it (the later one at a shared boundary)."""
    a = vv.read_oem(_segment_text(stop="2024-01-31T00:20:00"))
    b = vv.read_oem(_segment_text())
    eph = vv.ccsds.Ephemeris([a.segments[0], b.segments[0]])
    with pytest.raises(vv.InvalidInputError, match="covered by no segment"):
        eph.interpolate(Time("2024-01-31T00:15:00", scale="utc"))


@pytest.mark.parametrize("extra, line, words", [
    ("USEABLE_START_TIME = 2024-01-30T23:59:00\n", 11, "USEABLE_START_TIME = 2024-01-30T23:59"),
    ("USEABLE_STOP_TIME = 2024-01-31T00:11:00\n", 11, "USEABLE_STOP_TIME = 2024-01-31T00:11"),
    ("USEABLE_START_TIME = 2024-01-31T00:06:00\nUSEABLE_STOP_TIME = 2024-01-31T00:04:00\n", 12,
     "USEABLE_STOP_TIME is before USEABLE_START_TIME"),
])
def test_a_useable_span_outside_the_segment_names_its_line(extra, line, words):
    """A USEABLE_START/STOP_TIME outside START_TIME .. STOP_TIME was read, and times there
    extrapolated; now a CCSDSFormatError naming the line."""
    with pytest.raises(vv.CCSDSFormatError, match=words) as info:
        vv.read_oem(_segment_text(extra=extra))
    assert info.value.line == line


_OPM = """CCSDS_OPM_VERS = 3.0
CREATION_DATE = 2024-03-01T10:00:00
ORIGINATOR = TEST
OBJECT_NAME = SAT
OBJECT_ID = 2024-999A
CENTER_NAME = EARTH
REF_FRAME = GCRF
TIME_SYSTEM = UTC
EPOCH = 2024-03-01T00:00:00
X = 6503.514 [km]
Y = 1239.647 [km]
Z = -717.490 [km]
X_DOT = -0.873160 [km/s]
Y_DOT = 8.740420 [km/s]
Z_DOT = -4.191076 [km/s]
COMMENT spacecraft
MASS = 3000.0 [kg]
COMMENT user-defined
USER_DEFINED_ALTITUDE_BIAS = 12.5 [km]
USER_DEFINED_EARTH_MODEL = WGS-84
"""


@pytest.mark.parametrize("fmt", ["kvn", "xml"])
def test_the_unit_of_a_user_defined_parameter_is_kept(fmt):
    """USER_DEFINED_X = 12.5 [km]: the unit was dropped when read, so written back as a bare
    12.5 (a Space-Track/Orekit user reading it in m would be off by 1000)."""
    opm = vv.read_opm(_OPM)
    assert opm.sections["user_defined"].units == {"ALTITUDE_BIAS": "km"}
    text = vv.write_opm(opm, format=fmt)
    back = vv.read_opm(text)
    assert back.sections["user_defined"].values == {"ALTITUDE_BIAS": "12.5",
                                                    "EARTH_MODEL": "WGS-84"}
    assert back.sections["user_defined"].units == {"ALTITUDE_BIAS": "km"}
    if fmt == "kvn":
        assert "USER_DEFINED_ALTITUDE_BIAS = 12.5 [km]" in " ".join(text.split())
    # the OMM (a dict of keywords) keeps it too
    omm_text = vv.write_omm(vv.Satellite.from_tle(
        "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
        "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 10001").to_omm(),
        originator="TEST") + "USER_DEFINED_ALTITUDE_BIAS = 12.5 [km]\n"
    omm = vv.read_omm(vv.write_omm(vv.read_omm(omm_text), format=fmt))
    assert omm.units == {"USER_DEFINED_ALTITUDE_BIAS": "km"}
    assert omm["USER_DEFINED_ALTITUDE_BIAS"] == "12.5"


def test_a_user_defined_parameter_given_twice_names_its_line():
    """The second USER_DEFINED_X replaced the first silently (one value lost)."""
    text = _OPM + "USER_DEFINED_EARTH_MODEL = EGM-96\n"
    with pytest.raises(vv.CCSDSFormatError, match="given twice") as info:
        vv.read_opm(text)
    assert info.value.line == 21
    xml = vv.write_opm(vv.read_opm(_OPM), format="xml")
    twice = xml.replace('<USER_DEFINED parameter="EARTH_MODEL">WGS-84</USER_DEFINED>',
                        '<USER_DEFINED parameter="EARTH_MODEL">WGS-84</USER_DEFINED>'
                        '<USER_DEFINED parameter="EARTH_MODEL">EGM-96</USER_DEFINED>')
    assert twice != xml
    with pytest.raises(vv.CCSDSFormatError, match="given twice"):
        vv.read_opm(twice)


def test_an_unknown_keyword_after_a_comment_names_its_own_line():
    """The error named the COMMENT line before the unknown keyword ('unexpected
    'spacecraft' here: out of order'), not the keyword."""
    text = _OPM.replace("MASS = 3000.0 [kg]", "MASS_AT_LAUNCH = 3000.0 [kg]")
    with pytest.raises(vv.CCSDSFormatError, match="MASS_AT_LAUNCH: not a keyword of an OPM") as e:
        vv.read_opm(text)
    assert e.value.line == 17
    with pytest.raises(vv.CCSDSFormatError, match="belong to no section") as e:
        vv.read_opm(_OPM + "COMMENT end of file\n")
    assert e.value.line == 21


_L1 = "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009"
_L2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 10001"


def _with_checksum(line: str) -> str:
    body = line[:68]
    return body + str(sum(int(c) if c.isdigit() else c == "-" for c in body) % 10)


@pytest.mark.parametrize("kind", [1, 4, 5])
def test_an_element_set_for_another_theory_is_refused(kind):
    """EPHEMERIS_TYPE 4 (Space-Track's SGP4-XP elements; SGP8 in Spacetrack Report #3) was
    propagated with SGP4 as if it were SGP4's, with no word (STK's Sgp4Propagator refuses it)."""
    line1 = _with_checksum(_L1[:62] + str(kind) + _L1[63:])
    with pytest.raises(vv.TLEFormatError, match=f"column 63: ephemeris type {kind}"):
        vv.Satellite.from_tle(line1, _L2)
    fields = {**vv.Satellite.from_tle(_L1, _L2).to_omm(), "EPHEMERIS_TYPE": kind}
    with pytest.raises(vv.InvalidInputError, match=f"EPHEMERIS_TYPE = {kind}"):
        vv.Satellite.from_omm(fields)
    text = vv.write_omm(fields, originator="TEST")  # the message itself is read and written
    with pytest.raises(vv.InvalidInputError, match="ephemeris type"):
        vv.Satellite.from_omm(vv.read_omm(text))


@pytest.mark.parametrize("kind", [0, 2, 3])
def test_sgp4_ephemeris_types_still_propagate_as_before(kind):
    """Types 0 (today's), 2 and 3 (SGP4 and SDP4 in Spacetrack Report #3) are SGP4's."""
    line1 = _with_checksum(_L1[:62] + str(kind) + _L1[63:])
    sat = vv.Satellite.from_tle(line1, _L2)
    ref = vv.Satellite.from_tle(_L1, _L2)
    t = Time("2024-01-02T00:00:00", scale="utc")
    assert np.array_equal(sat.teme(t).r.to_value(u.km), ref.teme(t).r.to_value(u.km))
    assert sat.to_tle()[0] == line1


@pytest.mark.parametrize("row, line, words", [
    ("7.0E-1\n", 29, "row 2 of the covariance (lower triangle) holds 2 numbers, but this line has 1"),
    ("1.0E-6 [km**2]\n0 4.0E-6\n", 28, "holds 1 number, but this line has 2 ('1.0E-6 [km**2]'; a "
     "covariance row has no units)"),
])
def test_a_covariance_row_of_the_wrong_length_says_which_is_which(row, line, words):
    """The message said 'row 2 ... has 2 numbers, not 1' of a row of 1 number (the counts
    swapped)."""
    text = _segment_text()  # (25 lines: the covariance block starts on line 26)
    cov = ("COVARIANCE_START\nEPOCH = 2024-01-31T00:00:00\n" + (
        row if "[" in row else "1.0E-6\n" + row)
        + "0 0 1.0E-6\n0 0 0 1.0E-12\n0 0 0 0 1.0E-12\n0 0 0 0 0 1.0E-12\nCOVARIANCE_STOP\n")
    with pytest.raises(vv.CCSDSFormatError) as info:
        vv.read_oem(text + cov)
    assert words in str(info.value)
    assert info.value.line == line


def test_states_given_to_from_states_keep_their_frame():
    """OEM -> states -> OEM: a TEME segment's states rebuilt with from_states(t, r, v) were
    written REF_FRAME = GCRF (the default), 0.3 deg of rotation off with no word; the states
    themselves now carry their frame in, and a contradicting frame is refused."""
    from visviva.ccsds.oem import OEMSegment

    sat = vv.Satellite.from_tle(_L1, _L2)
    t = Time("2024-01-01T12:00:00", scale="utc") + np.arange(0, 600, 60) * u.s
    teme = sat.teme(t)
    seg = OEMSegment.from_states(teme, object_name="ISS")
    assert seg.frame == "TEME"
    states = vv.read_oem(vv.write_oem(seg)).segments[0].states
    again = OEMSegment.from_states(states, object_name="ISS")
    assert again.frame == "TEME" and again.epochs == seg.epochs
    assert np.array_equal(again.r_km, teme.r.to_value(u.km))
    assert OEMSegment.from_states(sat.itrs(t), object_name="ISS").frame == "ITRF"
    with pytest.raises(vv.InvalidInputError, match="states are in TEME"):
        OEMSegment.from_states(teme, object_name="ISS", frame="GCRF")
    with pytest.raises(vv.InvalidInputError, match="no r_km"):
        OEMSegment.from_states(teme, teme.r, teme.v, object_name="ISS")
    with pytest.raises(vv.InvalidInputError, match="needs times, r_km and v_km_s"):
        OEMSegment.from_states(t, object_name="ISS")
    # arrays, as before: GCRF unless told
    assert OEMSegment.from_states(t, teme.r, teme.v, object_name="ISS").frame == "GCRF"


def test_write_cdm_picks_xml_for_an_xml_path_as_the_other_writers(tmp_path):
    """write_cdm(msg, "c.xml") wrote KVN text into the .xml file (the other writers pick XML
    for that suffix); a tool that reads it as XML refused it."""
    from pathlib import Path

    msg = vv.read_cdm(Path(__file__).parent / "data" / "sample_cdm.kvn")
    text = vv.write_cdm(msg, tmp_path / "c.xml")
    assert text.startswith("<?xml") and (tmp_path / "c.xml").read_text() == text
    assert vv.read_cdm(tmp_path / "c.xml") == msg
    assert not vv.write_cdm(msg, tmp_path / "c.kvn").startswith("<")
    assert vv.write_cdm(msg, tmp_path / "k.xml", format="kvn").startswith("CCSDS")


_TDM = """CCSDS_TDM_VERS = 2.0
CREATION_DATE = 2024-045T12:00:00
ORIGINATOR = TEST
META_START
TIME_SYSTEM = UTC
START_TIME = 2024-02-14T10:00:00
STOP_TIME = 2024-02-14T10:00:10
PARTICIPANT_1 = DSS-65
PARTICIPANT_2 = SAT
MODE = SEQUENTIAL
PATH = 1,2,1
META_STOP
DATA_START
RANGE = 2024-02-14T10:00:00 1201.25
RANGE = 2024-02-14T10:00:10 1176.26
DATA_STOP
"""


@pytest.mark.parametrize("old, new, line, xml, words", [
    ("STOP_TIME = 2024-02-14T10:00:10", "STOP_TIME = 2024-02-14T09:00:10", 7,
     ("<STOP_TIME>2024-02-14T10:00:10", "<STOP_TIME>2024-02-14T09:00:10"),
     "STOP_TIME = 2024-02-14T09:00:10 is before START_TIME"),
    ("RANGE = 2024-02-14T10:00:10", "RANGE = 2024-02-14T10:00:11", 15,
     ("<EPOCH>2024-02-14T10:00:10", "<EPOCH>2024-02-14T10:00:11"),
     "2024-02-14T10:00:11 lies outside START_TIME .. STOP_TIME"),
    ("RANGE = 2024-02-14T10:00:00", "RANGE = 2024-02-14T09:59:59", 14,
     ("<EPOCH>2024-02-14T10:00:00", "<EPOCH>2024-02-14T09:59:59"),
     "2024-02-14T09:59:59 lies outside START_TIME .. STOP_TIME"),
])
def test_a_tdm_span_that_contradicts_itself_or_its_data_names_the_line(old, new, line, xml,
                                                                        words):
    """START_TIME after STOP_TIME, or data outside them, were read without a word (the OEM
    reader refuses both)."""
    good = vv.read_tdm(_TDM)
    assert good.keyword_counts() == {"RANGE": 2}
    with pytest.raises(vv.CCSDSFormatError, match=words) as info:
        vv.read_tdm(_TDM.replace(old, new))
    assert info.value.line == line
    text = vv.write_tdm(good, format="xml")
    assert xml[0] in text
    with pytest.raises(vv.CCSDSFormatError, match=words):
        vv.read_tdm(text.replace(*xml))


def test_a_segment_of_one_state_says_so():
    """The message of a one-state segment said 'use a degree between 1 and 0'."""
    lines = _segment_text().splitlines()
    text = "\n".join(lines[:14] + lines[14:15]).replace(
        "STOP_TIME = 2024-01-31T00:10:00", "STOP_TIME = 2024-01-31T00:00:00") + "\n"
    seg = vv.read_oem(text).segments[0]
    assert len(seg) == 1
    with pytest.raises(vv.InvalidInputError, match="holds one state"):
        seg.interpolate(_T0)


def test_a_path_with_an_equals_sign_is_read_as_a_path(tmp_path):
    """A file in 'run=1/' (a partitioned data folder) was taken for the message text: 'line 1:
    ... is not KEYWORD = value'; a missing one there now says the file is missing."""
    folder = tmp_path / "run=1"
    folder.mkdir()
    (folder / "sat.oem").write_text(_segment_text())
    assert len(vv.read_oem(str(folder / "sat.oem")).segments[0]) == 11
    (folder / "sat.opm").write_text(_OPM)
    assert vv.read_opm(str(folder / "sat.opm")).sections["state_vector"]["X"] == 6503.514
    with pytest.raises(FileNotFoundError, match="no such file"):
        vv.read_omm(str(folder / "missing.omm"))
    with pytest.raises(vv.CCSDSFormatError, match="lacks the mandatory"):
        vv.read_omm("CCSDS_OMM_VERS = 3.0")  # one line of text is still text


@pytest.mark.parametrize("center", ["EARTH BARYCENTER", "JUPITER BARYCENTER", "PLUTO BARYCENTER"])
def test_a_barycentre_is_not_taken_for_its_body(center):
    """CENTER_NAME = EARTH BARYCENTER (the Earth-Moon barycentre, 4,671 km from the geocentre)
    gave states with the Earth's GM at the origin, as if Earth-centred: propagated, they fell
    about the wrong point; now refused, saying why."""
    from visviva.ccsds.timeframes import center_body

    assert center_body(center) is None
    assert center_body("MARS BARYCENTER") is vv.MARS and center_body("earth") is vv.EARTH
    oem = vv.read_oem(_segment_text().replace("CENTER_NAME = EARTH", f"CENTER_NAME = {center}"))
    seg = oem.segments[0]
    assert seg.r_km.shape == (11, 3)  # the numbers are there
    for call in (lambda: seg.states, lambda: oem.interpolate(_T0 + 90 * u.s)):
        with pytest.raises(vv.InvalidInputError, match="barycentre"):
            call()
    opm = vv.read_opm(_OPM.replace("CENTER_NAME = EARTH", f"CENTER_NAME = {center}"))
    with pytest.raises(vv.InvalidInputError, match="barycentre"):
        opm.state  # noqa: B018


@pytest.mark.parametrize("object_id", ["UNKNOWN", "1998-67A", "ISS"])
def test_an_omm_object_id_no_tle_holds_survives_the_satellite(object_id):
    """OMM -> Satellite -> OMM dropped an OBJECT_ID that is no COSPAR designator to "" (which
    write_omm then refused as empty): the text is kept; the TLE's field stays blank."""
    fields = {**vv.Satellite.from_tle(_L1, _L2).to_omm(), "OBJECT_ID": object_id}
    sat = vv.Satellite.from_omm(vv.read_omm(vv.write_omm(fields, originator="TEST")))
    assert sat.to_tle()[0][9:17] == " " * 8
    assert sat.to_omm()["OBJECT_ID"] == object_id
    assert vv.read_omm(vv.write_omm(sat.to_omm(), originator="TEST"))["OBJECT_ID"] == object_id


@pytest.mark.parametrize("old, new, line", [
    ("STOP_SCREEN_PERIOD                 = 2010-03-15T18:29:32.212",
     "STOP_SCREEN_PERIOD                 = 2010-03-11T18:29:32.212", 17),
    ("SCREEN_EXIT_TIME                   = 2010-03-13T22:37:52.824",
     "SCREEN_EXIT_TIME                   = 2010-03-13T22:37:50.824", 24),
])
def test_a_cdm_span_that_runs_backwards_names_its_line(old, new, line):
    """A screening period (or a passage through the screening volume) ending before it starts
    was read without a word."""
    from pathlib import Path

    text = (Path(__file__).parent / "data" / "sample_cdm.kvn").read_text()
    assert old in text
    key = new.split()[0]
    with pytest.raises(vv.CCSDSFormatError, match=f"{key} = .* is before") as info:
        vv.read_cdm(text.replace(old, new))
    assert info.value.line == line
    xml = vv.write_cdm(vv.read_cdm(text), format="xml")
    old_xml = f"<{key}>{old.split('= ')[1]}</{key}>"
    assert old_xml in xml
    with pytest.raises(vv.CCSDSFormatError, match=f"{key} = .* is before"):
        vv.read_cdm(xml.replace(old_xml, f"<{key}>{new.split('= ')[1]}</{key}>"))


def test_an_opm_covariance_in_rtn_goes_with_the_state():
    """COV_REF_FRAME = RTN: opm.covariance returned the RTN numbers, which
    vv.propagate_covariance(opm.state, opm.covariance, t) (the call docs/ccsds.md shows) took
    for inertial ones; it is now on the state's axes, as the od command rotated it."""
    from visviva._covariance import to_local
    from visviva.ccsds.covariance import values_from_matrix
    from visviva.ccsds.opm import OPM
    from visviva.core.local_frames import FRAME_CODES

    base = vv.read_opm(_OPM)
    r, v = base.state.r.to_value(u.km), base.state.v.to_value(u.km / u.s)
    inertial = np.diag([1e-2, 4e-2, 9e-2, 1e-8, 4e-8, 9e-8])
    inertial[0, 1] = inertial[1, 0] = 5e-3
    for name in ("RTN", "TNW", "VNB", "RSW"):
        local = to_local(inertial, r, v, FRAME_CODES[name])
        sections = {**base.sections, "covariance": {"COV_REF_FRAME": name,
                                                    **values_from_matrix(local)}}
        opm = vv.read_opm(vv.write_opm(OPM(sections)))
        got = opm.covariance
        assert np.allclose(got[:3, :3], inertial[:3, :3], rtol=1e-12, atol=1e-15), name
        assert np.allclose(got[3:, :], inertial[3:, :], rtol=1e-12, atol=1e-20), name
        assert opm.sections["covariance"]["CX_X"] == local[0, 0]  # as written
    same = {**base.sections, "covariance": {"COV_REF_FRAME": "EME2000",
                                            **values_from_matrix(inertial)}}
    # GCRF state, EME2000 axes: rotated by the frame bias, B.T C B
    b6 = np.kron(np.eye(2), FRAME_BIAS)
    np.testing.assert_allclose(OPM(same).covariance, b6.T @ inertial @ b6, rtol=1e-12, atol=0)
    assert not np.array_equal(OPM(same).covariance, inertial)
    other = {**base.sections, "covariance": {"COV_REF_FRAME": "ITRF",
                                             **values_from_matrix(inertial)}}
    with pytest.raises(vv.InvalidInputError, match="COV_REF_FRAME = ITRF is neither"):
        OPM(other).covariance  # noqa: B018
    itrf = {**base.sections, "metadata": {**base.metadata.values, "REF_FRAME": "ITRF"},
            "covariance": {"COV_REF_FRAME": "RTN", **values_from_matrix(inertial)}}
    with pytest.raises(vv.InvalidInputError, match="Earth-fixed"):
        OPM(itrf).covariance  # noqa: B018


@pytest.mark.parametrize("frame", ["TDR", "GRC", "GTOD", "ITRF1993"])
def test_a_local_covariance_about_other_earth_fixed_frames_is_refused(frame):
    """COV_REF_FRAME = RTN about a state in SANA's other Earth-fixed frames (TDR, GRC, GTOD)
    was rotated with the Earth-fixed velocity, whose in-track and cross-track axes are tilted
    by degrees in LEO: a 1 km in-track sigma put ~60 m into the cross-track variance, silently
    (only REF_FRAME names that map to 'itrs' were refused); the OEM's covariance(k) too."""
    from visviva.ccsds.covariance import values_from_matrix
    from visviva.ccsds.opm import OPM

    base = vv.read_opm(_OPM)
    rtn = np.diag([1e-4, 1.0, 1e-4, 1e-8, 1e-8, 1e-8])
    sections = {**base.sections, "metadata": {**base.metadata.values, "REF_FRAME": frame},
                "covariance": {"COV_REF_FRAME": "RTN", **values_from_matrix(rtn)}}
    with pytest.raises(vv.InvalidInputError, match="Earth-fixed"):
        OPM(sections).covariance  # noqa: B018
    tod = {**sections, "metadata": {**base.metadata.values, "REF_FRAME": "TOD"}}
    assert OPM(tod).covariance[1, 1] != rtn[1, 1]  # quasi-inertial: rotated, as before


@pytest.mark.parametrize("key, value, words", [
    ("START_TIME", "2024-01-31T00:05:00", "lies outside START_TIME .. STOP_TIME"),
    ("USEABLE_START_TIME", "2024-01-30T00:00:00", "USEABLE_START_TIME = 2024-01-30T00:00:00"),
    ("STOP_TIME", "2024-01-30T00:00:00", "STOP_TIME is before START_TIME"),
    ("START_TIME", None, "the metadata lacks START_TIME"),
])
def test_write_oem_refuses_spans_its_reader_refuses(key, value, words):
    """A segment built in code with contradictory spans was written, and the file then refused
    by read_oem."""
    from visviva.ccsds.oem import OEMSegment

    seg = vv.read_oem(_segment_text()).segments[0]
    meta = {**seg.metadata.values, key: value}
    if value is None:
        del meta[key]
    bad = OEMSegment(meta, seg.epochs, seg.r_km, seg.v_km_s)
    with pytest.raises(vv.InvalidInputError, match=words):
        vv.write_oem(bad)


def test_write_tdm_refuses_a_span_its_reader_refuses():
    """A TDM whose STOP_TIME was edited to before its START_TIME was written, and the file then
    refused by read_tdm."""
    tdm = vv.read_tdm(_TDM)
    tdm.segments[0].metadata.values["STOP_TIME"] = "2024-02-14T09:00:00"
    with pytest.raises(vv.CCSDSFormatError, match="STOP_TIME = 2024-02-14T09:00:00 is before"):
        vv.write_tdm(tdm)


def test_an_omm_with_a_semi_major_axis_says_sgp4_needs_a_mean_motion():
    """The message said the record 'lacks MEAN_MOTION; pass every mean element (CelesTrak's GP
    data ...)' of a message that gives its SEMI_MAJOR_AXIS (CCSDS allows either)."""
    fields = vv.Satellite.from_tle(_L1, _L2).to_omm()
    del fields["MEAN_MOTION"]
    fields["SEMI_MAJOR_AXIS"] = 6796.0
    omm = vv.read_omm(vv.write_omm(fields, originator="TEST"))
    with pytest.raises(vv.InvalidInputError, match="gives SEMI_MAJOR_AXIS, not MEAN_MOTION"):
        vv.Satellite.from_omm(omm)


@pytest.mark.parametrize("fmt", ["kvn", "xml"])
def test_comments_at_the_end_of_an_oem_after_its_covariance_are_kept(fmt):
    """COMMENT lines after the last COVARIANCE_STOP were dropped (no segment took them)."""
    cov = ("COVARIANCE_START\nEPOCH = 2024-01-31T00:00:00\n1.0E-6\n0 1.0E-6\n0 0 1.0E-6\n"
           "0 0 0 1.0E-12\n0 0 0 0 1.0E-12\n0 0 0 0 0 1.0E-12\nCOVARIANCE_STOP\n")
    text = _segment_text() + cov + "COMMENT produced by the test\nCOMMENT end of file\n"
    seg = vv.read_oem(text).segments[0]
    assert seg.state_comments == {11: ["produced by the test", "end of file"]}
    back = vv.read_oem(vv.write_oem(vv.read_oem(text), format=fmt)).segments[0]
    assert back.state_comments == seg.state_comments and len(back.covariances) == 1


def test_oem_covariance_on_the_state_axes_as_the_opm_gives_it():
    # seg.covariance(k): an RTN covariance rotated with the segment's state at its epoch (a
    # state epoch or an interpolated one), the same matrix the OPM's covariance gives for that
    # state; the frame itself or another name of the same axes kept; others refused
    from visviva._covariance import from_local
    from visviva.core.local_frames import FRAME_CODES

    rtn = np.diag([1e-6, 4e-6, 9e-6, 1e-12, 4e-12, 9e-12])
    rtn[0, 1] = rtn[1, 0] = 1e-6
    lines = ["CCSDS_OEM_VERS = 2.0", "CREATION_DATE = 2024-01-31T00:00:00", "ORIGINATOR = T",
             "META_START", "OBJECT_NAME = S", "OBJECT_ID = 2024-001A", "CENTER_NAME = EARTH",
             "REF_FRAME = EME2000", "TIME_SYSTEM = UTC", "START_TIME = 2024-01-31T00:00:00",
             "STOP_TIME = 2024-01-31T00:04:00", "INTERPOLATION = HERMITE",
             "INTERPOLATION_DEGREE = 1", "META_STOP",
             "2024-01-31T00:00:00 7000.0 0.0 0.0 0.0 7.546 0.0",
             "2024-01-31T00:02:00 6968.0 904.4 0.0 -0.532 7.512 0.0",
             "2024-01-31T00:04:00 6873.0 1799.9 0.0 -1.061 7.410 0.0", "COVARIANCE_START"]
    for epoch, frame in (("2024-01-31T00:02:00", "RTN"), ("2024-01-31T00:01:00", "RTN"),
                         ("2024-01-31T00:03:00", "EME2000"), ("2024-01-31T00:03:00", "GCRF"),
                         ("2024-01-31T00:03:00", "ITRF")):
        lines += [f"EPOCH = {epoch}", f"COV_REF_FRAME = {frame}"]
        lines += [" ".join(f"{rtn[i, j]:.6e}" for j in range(i + 1)) for i in range(6)]
    lines.append("COVARIANCE_STOP")
    seg = vv.read_oem("\n".join(lines) + "\n").segments[0]
    # at a state epoch: that state's RTN axes
    want = from_local(rtn, seg.r_km[1], seg.v_km_s[1], FRAME_CODES["RTN"])
    b6 = np.kron(np.eye(2), FRAME_BIAS)  # (EME2000 axes -> the GCRS axes of seg.states)
    np.testing.assert_allclose(seg.covariance(0), b6.T @ want @ b6, rtol=1e-12, atol=0)
    assert not np.allclose(seg.covariance(0), rtn)  # the axes turned (7.4 deg)
    # between states: the interpolated state's axes
    t = Time("2024-01-31T00:01:00", scale="utc")
    s = seg.interpolate(t)
    want = from_local(rtn, s.r.to_value(u.km), s.v.to_value(u.km / u.s), FRAME_CODES["RTN"])
    np.testing.assert_allclose(seg.covariance(1), want, rtol=1e-12,  # (rounding of the bias)
                               atol=1e-15 * np.abs(want).max())
    # on the GCRS axes of seg.states: EME2000 rotated by the frame bias, GCRF as written; an
    # Earth-fixed one refused
    np.testing.assert_allclose(seg.covariance(2), b6.T @ seg.covariances[2].matrix @ b6,
                               rtol=1e-12, atol=0)
    np.testing.assert_allclose(seg.covariance(3), seg.covariances[3].matrix, rtol=1e-12,
                               atol=1e-15 * np.abs(seg.covariances[3].matrix).max())
    with pytest.raises(vv.InvalidInputError, match="neither REF_FRAME = EME2000"):
        seg.covariance(4)


def test_writers_take_the_centre_from_the_states_gm():
    """OPM.from_state and OEMSegment.from_states wrote CENTER_NAME = EARTH for a Moon- or
    Sun-centred state (the default), and the message read back with the Earth's GM: 81 times
    the Moon's, silently. The centre now comes from the states' GM, and one that contradicts
    it is refused."""
    from visviva.ccsds.oem import OEMSegment
    from visviva.ccsds.opm import OPM

    t0 = Time("2024-03-01T12:00:00", scale="utc")
    moon = vv.StateVectors([1838.0, 0, 0] * u.km, [0, 1.633, 0] * u.km / u.s, vv.MOON, epoch=t0)
    back = vv.read_opm(vv.write_opm(OPM.from_state(moon, object_name="LRO")))
    assert back.center == "MOON"
    assert back.frame == "ICRF"  # (the GCRF is geocentric)
    assert back.state.gm.to_value(u.km**3 / u.s**2) == pytest.approx(4902.800118, rel=1e-9)
    states = moon.propagate(np.arange(3) * 60.0 * u.s)
    seg = OEMSegment.from_states(states, object_name="LRO", degree=2)
    assert vv.read_oem(vv.write_oem(seg)).segments[0].center == "MOON"
    assert seg.frame == "ICRF"
    arrays = OEMSegment.from_states(states.epoch, states.r, states.v, object_name="LRO",
                                    center="MOON", degree=2)
    assert arrays.frame == "ICRF" and arrays.center == "MOON"
    sun = vv.StateVectors([1.496e8, 0, 0] * u.km, [0, 29.78, 0] * u.km / u.s, vv.SUN, epoch=t0)
    assert OPM.from_state(sun, object_name="X").center == "SUN"
    with pytest.raises(vv.InvalidInputError, match="center = 'EARTH' has GM"):
        OPM.from_state(moon, object_name="LRO", center="EARTH")
    with pytest.raises(vv.InvalidInputError, match="no body's"):
        OPM.from_state(vv.StateVectors([1.0, 0, 0] * u.km, [0, 1.0, 0] * u.km / u.s,
                                       1.0 * u.km**3 / u.s**2, epoch=t0), object_name="X")
    earth = vv.StateVectors([7000.0, 0, 0] * u.km, [0, 7.5, 0] * u.km / u.s,
                            398600.4418 * u.km**3 / u.s**2, epoch=t0)  # another Earth GM
    assert OPM.from_state(earth, object_name="X").center == "EARTH"
    assert OPM.from_state(moon, object_name="LRO", center="EARTH BARYCENTER").center == \
        "EARTH BARYCENTER"  # (no body: the user's word)


def test_states_read_in_a_frame_visviva_cannot_rotate_are_written_back_in_it():
    """An OPM's or OEM's state in REF_FRAME = TOD (Earth-centred, no visviva rotation) given to
    OPM.from_state / OEMSegment.from_states was written REF_FRAME = GCRF: 0.33 deg of
    precession in 2024, ~40 km at LEO, silently. Its frame is now kept, and another asked for
    is refused."""
    from visviva.ccsds.oem import OEMSegment
    from visviva.ccsds.opm import OPM

    base = vv.read_opm(_OPM)
    tod = OPM({**base.sections, "metadata": {**base.metadata.values, "REF_FRAME": "TOD"}})
    again = vv.read_opm(vv.write_opm(OPM.from_state(tod.state, object_name="X")))
    assert again.frame == "TOD"
    assert np.array_equal(again.state.r.to_value(u.km), tod.state.r.to_value(u.km))
    assert OPM.from_state(tod.state, object_name="X", frame="tod").frame == "tod"
    with pytest.raises(vv.InvalidInputError, match="read in REF_FRAME = TOD"):
        OPM.from_state(tod.state, object_name="X", frame="GCRF")
    t = base.epoch + np.arange(3) * 60.0 * u.s
    seg = OEMSegment.from_states(t, np.array([[7000.0, 450.0 * k, 0] for k in range(3)]),
                                 np.array([[0, 7.5, 0]] * 3), object_name="X", frame="TOD",
                                 degree=2)
    read = vv.read_oem(vv.write_oem(seg)).segments[0]
    assert OEMSegment.from_states(read.states, object_name="X", degree=2).frame == "TOD"
