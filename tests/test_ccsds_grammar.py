"""The shared CCSDS grammar: KVN lexer, XML tree, sections, records, errors naming the line."""

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from visviva.ccsds.grammar import CCSDSFormatError, Keyword, Section, format_float, parse_value
from visviva.ccsds.grammar import Keyword as K
from visviva.ccsds.kvn import KVNCursor, tokenize
from visviva.ccsds.layout import read_message, write_message
from visviva.ccsds.ndmxml import parse
from visviva.ccsds.timeframes import center_body, epochs_to_time, time_to_epochs, visviva_frame
from visviva.errors import InvalidInputError, VisvivaError

HEADER = Section("header", (K("CCSDS_TST_VERS", "text", None, True),
                            K("CREATION_DATE", "epoch", None, True),
                            K("ORIGINATOR", "text", None, True), K("MESSAGE_ID")), "header")
STATE = Section("state", (K("EPOCH", "epoch", None, True), K("X", "float", "km", True),
                          K("N", "int")), "body/segment/data/stateVector")
MAN = Section("man", (K("MAN_EPOCH", "epoch", None, True), K("DV", "float", "km/s", True)),
              "body/segment/data/maneuverParameters", optional=True, repeat=True)
USER = Section("user", (), "body/segment/data/userDefinedParameters", optional=True,
               user_defined=True)
SECTIONS = (HEADER, STATE, MAN, USER)

KVN = """CCSDS_TST_VERS = 3.0
COMMENT made by hand
CREATION_DATE = 2024-01-31T00:00:00
ORIGINATOR = ME

COMMENT the state
EPOCH = 2024-032T12:00:00.5Z
X = 6678.137 [km]
N = 3
MAN_EPOCH = 2024-02-01T13:00:00
DV = 0.001 [KM/S]
MAN_EPOCH = 2024-02-01T14:00:00
DV = -2.5E-3
USER_DEFINED_OWNER = somebody
"""


def test_tokenize_kinds_and_line_numbers():
    lines = tokenize("A = 1 [km]\n\nCOMMENT hi there\nMETA_START\n2024-01-01T00:00:00 1 2 3\n"
                     "META_STOP\n")
    assert [(x.kind, x.line, x.key) for x in lines] == [
        ("keyword", 1, "A"), ("comment", 3, "COMMENT"), ("start", 4, "META"),
        ("data", 5, ""), ("stop", 6, "META")]
    assert lines[0].value == "1" and lines[0].unit == "km"
    assert lines[1].value == "hi there"
    assert lines[3].tokens == ["2024-01-01T00:00:00", "1", "2", "3"]


@pytest.mark.parametrize("text, line, words", [
    ("A = 1\nb = 2\n", 2, "KEYWORD = value"),
    ("A = 1\nB = 2 [km\n", 2, "closing bracket"),
    ("A = 1\nB =\n", 2, "no value"),
])
def test_tokenize_errors_name_the_line(text, line, words):
    with pytest.raises(CCSDSFormatError, match=words) as info:
        tokenize(text, "f.kvn")
    assert info.value.line == line and f"f.kvn, line {line}" in str(info.value)
    assert isinstance(info.value, InvalidInputError) and isinstance(info.value, VisvivaError)


def test_cursor_blocks_and_errors():
    cur = KVNCursor("COMMENT a\nMETA_START\nX = 1\nMETA_STOP\n1 2\n3 4\n", "f")
    assert cur.take_comments() == ["a"]
    cur.expect_block("META")
    with pytest.raises(CCSDSFormatError, match="line 3: expected META_STOP"):
        cur.expect_block("META", "stop")
    cur.next()
    cur.expect_block("META", "stop")
    assert [d.tokens for d in cur.data_lines()] == [["1", "2"], ["3", "4"]]
    assert cur.at_end()
    with pytest.raises(CCSDSFormatError, match="ends too early"):
        cur.next()


def test_parse_value_types_and_units():
    assert parse_value(Keyword("X", "float", "km"), "1.5", "KM", 1, "f") == 1.5
    assert parse_value(Keyword("X", "float", "km**2"), "-2.D-3", "km^2", 1, "f") == -2e-3
    assert parse_value(Keyword("N", "int"), "+12", None, 1, "f") == 12
    with pytest.raises(CCSDSFormatError, match=r"line 7: X must be in \[km\], not \[m\]"):
        parse_value(Keyword("X", "float", "km"), "1", "m", 7, "f")
    with pytest.raises(CCSDSFormatError, match="takes no unit"):
        parse_value(Keyword("N", "int"), "1", "km", 7, "f")
    for bad in ("nan", "inf", "1.0.0", "", "1_0", "0x10"):
        with pytest.raises(CCSDSFormatError, match="not a number"):
            parse_value(Keyword("X", "float"), bad, None, 3, "f")
    with pytest.raises(CCSDSFormatError, match="overflows"):
        parse_value(Keyword("X", "float"), "1e999", None, 3, "f")
    with pytest.raises(CCSDSFormatError, match="not a CCSDS epoch"):
        parse_value(Keyword("E", "epoch"), "2024/01/01 00:00", None, 3, "f")
    # dates that match the pattern but do not exist, in every epoch keyword of every message
    # (an OPM's CREATION_DATE = 2024-02-30 was read as it stood)
    for bad, why in (("2024-02-30T00:00:00", "day 30 of a month of 29 days"),
                     ("2023-02-29T00:00:00", "day 29 of a month of 28 days"),
                     ("2024-13-01T00:00:00", "month 13"), ("2024-00-10T00:00:00", "month 0"),
                     ("2023-366T00:00:00", "day 366 of a year of 365 days"),
                     ("2024-000T00:00:00", "day 0"), ("2024-01-01T24:00:00", "time 24:00:00"),
                     ("2024-01-01T12:60:00", "time"), ("2024-01-01T12:00:61.5Z", "time")):
        with pytest.raises(CCSDSFormatError, match=f"line 4: E = .* not a date that exists "
                                                   f"\\({why}"):
            parse_value(Keyword("E", "epoch"), bad, None, 4, "f")
    for good in ("2024-02-29T23:59:59.999", "2024-366T00:00:00Z", "2016-12-31T23:59:60"):
        assert parse_value(Keyword("E", "epoch"), good, None, 4, "f") == good


@settings(max_examples=300, deadline=None)
@given(st.floats(allow_nan=False, allow_infinity=False))
def test_float_text_round_trips_bit_for_bit(x):
    text = format_float(x)
    back = parse_value(Keyword("X", "float"), text, None, 1, "f")
    assert back == x and math.copysign(1, back) == math.copysign(1, x)


def test_flat_message_kvn_read_and_round_trip_both_formats():
    parsed, fmt, name = read_message(KVN, SECTIONS, "tst", "CCSDS_TST_VERS")
    assert fmt == "kvn" and name == "<text>"
    assert parsed["header"]["CCSDS_TST_VERS"] == "3.0"
    assert parsed["header"].comments == ["made by hand"]
    assert parsed["state"]["X"] == 6678.137 and parsed["state"]["N"] == 3
    assert parsed["state"].lines["X"] == 8 and parsed["state"].comments == ["the state"]
    assert [m["DV"] for m in parsed["man"]] == [0.001, -2.5e-3]
    assert parsed["user"]["OWNER"] == "somebody"
    for out_fmt in ("kvn", "xml"):
        text = write_message(parsed, SECTIONS, "tst", "CCSDS_TST_VERS", fmt=out_fmt)
        again, fmt2, _ = read_message(text, SECTIONS, "tst", "CCSDS_TST_VERS")
        assert fmt2 == out_fmt
        for key in ("header", "state", "user"):
            assert again[key].values == parsed[key].values
            assert again[key].comments == parsed[key].comments
        assert [m.values for m in again["man"]] == [m.values for m in parsed["man"]]


@pytest.mark.parametrize("edit, line, words", [
    (("X = 6678.137 [km]", "X = 6678.137 [m]"), 8, r"X must be in \[km\]"),
    (("N = 3", "N = 3\nX = 1"), 10, r"X is given twice .* \(first on line 8\)"),
    (("X = 6678.137 [km]\n", ""), 7, "lacks the mandatory keyword X"),
    (("ORIGINATOR = ME", "ORIGINATOR = ME\nFOO = 1"), 5, "unexpected FOO"),
    (("DV = -2.5E-3", "DV = abc"), 13, "DV = 'abc' is not a number"),
    (("CCSDS_TST_VERS = 3.0", "CREATION = 3"), 1, "starts with CCSDS_TST_VERS"),
])
def test_flat_message_kvn_errors_name_the_line(edit, line, words):
    with pytest.raises(CCSDSFormatError, match=words) as info:
        read_message(KVN.replace(*edit), SECTIONS, "tst", "CCSDS_TST_VERS")
    assert info.value.line == line


def test_xml_tree_keeps_lines_and_reports_bad_xml():
    root = parse('<?xml version="1.0"?>\n<a x="1">\n  <b units="km"> 2 </b>\n  <b/>\n</a>\n')
    assert root.tag == "a" and root.line == 2 and root.attrib == {"x": "1"}
    assert [(b.line, b.text, b.attrib) for b in root.findall("b")] == [
        (3, "2", {"units": "km"}), (4, "", {})]
    with pytest.raises(CCSDSFormatError, match="line 3: the XML is not well formed"):
        parse("<a>\n<b>\n</a>\n", "f.xml")


def test_xml_message_errors_name_the_line():
    parsed, _, _ = read_message(KVN, SECTIONS, "tst", "CCSDS_TST_VERS")
    text = write_message(parsed, SECTIONS, "tst", "CCSDS_TST_VERS", fmt="xml")
    bad = text.replace("<N>3</N>", "<N>3</N>\n<Q>1</Q>")
    line = bad.splitlines().index("<Q>1</Q>") + 1
    with pytest.raises(CCSDSFormatError, match=r"<Q> does not belong in <stateVector>") as info:
        read_message(bad, SECTIONS, "tst", "CCSDS_TST_VERS")
    assert info.value.line == line
    with pytest.raises(CCSDSFormatError, match=r"must be in \[km\]"):
        read_message(text.replace('units="km"', 'units="m"'), SECTIONS, "tst", "CCSDS_TST_VERS")
    with pytest.raises(CCSDSFormatError, match="root element is <tst>, expected <opm>"):
        read_message(text, SECTIONS, "opm", "CCSDS_TST_VERS")


def test_epochs_time_systems_frames_centres():
    from astropy.time import Time

    t = epochs_to_time(["2024-01-31T12:00:00.5", "2024-031T12:00:00.5Z"], "UTC")
    assert t.scale == "utc" and abs((t[1] - t[0]).sec) < 1e-9
    assert abs((t[0] - Time("2024-01-31T12:00:00.5", scale="utc")).sec) < 1e-9
    gps = epochs_to_time("2024-01-31T12:00:00", "GPS")
    # GPS = TAI - 19 s (IS-GPS-200); TAI - UTC = 37 s in 2024, so GPS - UTC = 18 s
    assert abs((gps - Time("2024-01-31T11:59:42", scale="utc")).sec) < 1e-9
    assert time_to_epochs(gps, "GPS") == ["2024-01-31T12:00:00.000000000"]
    assert time_to_epochs(t[:1], "TAI") == ["2024-01-31T12:00:37.500000000"]
    with pytest.raises(CCSDSFormatError, match="TIME_SYSTEM 'SCLK' is not supported"):
        epochs_to_time("2024-01-31T12:00:00", "SCLK", line=4)
    with pytest.raises(CCSDSFormatError, match="line 4.*MET counts time from the launch"):
        epochs_to_time("0000-001T12:00:00", "MET", line=4)
    launch = Time("2024-01-01T00:00:00", scale="utc")
    met = epochs_to_time(["0000-000T00:00:00", "0001-010T01:02:03.5"], "MET", mission_epoch=launch)
    # one Julian year (365.25 d) + 10 d + 1 h 2 min 3.5 s, counted in SI seconds from the launch
    assert abs((met[1] - launch).sec - (375.25 * 86400 + 3723.5)) < 1e-9
    assert time_to_epochs(met, "MET", mission_epoch=launch) == [
        "0000-000T00:00:00.000000000", "0001-010T01:02:03.500000000"]
    assert visviva_frame("EME2000") == "gcrs" and visviva_frame("itrf2014") == "itrs"
    assert visviva_frame("TEME") == "teme" and visviva_frame("RTN") is None
    assert center_body("EARTH").name == "earth"
    assert center_body("MARS BARYCENTER").name == "mars" and center_body("DIONE") is None
