"""OEM: reading and writing KVN and XML, interpolation, covariance, malformed files naming the line.

The example messages are written here by hand in the layout of CCSDS 502.0-B-3 (annex G
examples): two segments around a manoeuvre, accelerations, covariance matrices, comments.
"""

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from hypothesis import given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva.ccsds.oem import Ephemeris, OEMSegment
from visviva.ccsds.timeframes import FRAME_BIAS

ONE_MM = 1e-6  # km

OEM_KVN = """CCSDS_OEM_VERS = 3.0
COMMENT  example written for the visviva tests
CREATION_DATE = 2024-01-31T00:00:00
ORIGINATOR = VISVIVA TESTS
MESSAGE_ID = OEM-0001

META_START
COMMENT first segment, before the burn
OBJECT_NAME = TESTSAT
OBJECT_ID = 2024-999A
CENTER_NAME = EARTH
REF_FRAME = EME2000
TIME_SYSTEM = UTC
START_TIME = 2024-01-31T00:00:00
USEABLE_START_TIME = 2024-01-31T00:00:00
USEABLE_STOP_TIME = 2024-01-31T00:03:00
STOP_TIME = 2024-01-31T00:03:00
INTERPOLATION = HERMITE
INTERPOLATION_DEGREE = 1
META_STOP

COMMENT states in km and km/s
2024-01-31T00:00:00 7000.0 0.0 0.0 0.0 7.5 0.0
2024-01-31T00:01:00 6995.1 449.9 0.1 -0.163 7.49 0.001
2024-01-31T00:02:00 6980.4 898.6 0.2 -0.326 7.47 0.002
2024-01-31T00:03:00 6956.0 1345.0 0.3 -0.489 7.44 0.003

COVARIANCE_START
EPOCH = 2024-01-31T00:00:00
COV_REF_FRAME = RTN
 1.0E-3
 2.0E-5  4.0E-3
 3.0E-6  5.0E-7  9.0E-4
 1.0E-8  2.0E-9  3.0E-10 1.0E-7
 4.0E-9  5.0E-10 6.0E-11 7.0E-12 2.0E-7
 8.0E-10 9.0E-11 1.0E-12 2.0E-13 3.0E-14 3.0E-7
COMMENT a second matrix, in the segment's frame
EPOCH = 2024-01-31T00:03:00
 1
 0 1
 0 0 1
 0 0 0 1
 0 0 0 0 1
 0 0 0 0 0 1
COVARIANCE_STOP

META_START
OBJECT_NAME = TESTSAT
OBJECT_ID = 2024-999A
CENTER_NAME = EARTH
REF_FRAME = EME2000
TIME_SYSTEM = UTC
START_TIME = 2024-032T00:03:00
STOP_TIME = 2024-032T00:05:00
INTERPOLATION = LAGRANGE
INTERPOLATION_DEGREE = 2
META_STOP
2024-032T00:03:00 6956.0 1345.0 0.3 -0.489 7.54 0.003 -0.0027 -0.0005 0.0
2024-032T00:04:00 6921.8 1796.9 0.4 -0.652 7.51 0.004 -0.0028 -0.00058 0.0
2024-032T00:05:00 6878.0 2246.2 0.5 -0.815 7.47 0.005 -0.0026 -0.00067 0.0
"""


def test_read_kvn_example_every_field():
    oem = vv.read_oem(OEM_KVN)
    assert oem.header["MESSAGE_ID"] == "OEM-0001"
    assert oem.header.comments == ["example written for the visviva tests"]
    first, second = oem.segments
    assert (first.frame, first.center, first.visviva_frame) == ("EME2000", "EARTH", "gcrs")
    assert first.metadata.comments == ["first segment, before the burn"]
    assert first.data_comments == ["states in km and km/s"]
    assert first.interpolation == ("HERMITE", 1) and second.interpolation == ("LAGRANGE", 2)
    assert len(first) == 4 and len(second) == 3 and first.a_km_s2 is None
    np.testing.assert_array_equal(second.a_km_s2[:, 0], [-0.0027, -0.0028, -0.0026])
    assert first.times.scale == "utc"
    assert abs((second.times[0] - Time("2024-02-01T00:03:00", scale="utc")).sec) < 1e-9
    states = first.states
    assert isinstance(states, vv.StateVectors) and states.shape == (4,)
    np.testing.assert_array_equal(first.r_km[1], [6995.1, 449.9, 0.1])  # as written
    # EME2000 numbers on the GCRS axes: B.T r (the 23 mas frame bias, 0.8 m here)
    np.testing.assert_allclose(states.r[1].to_value(u.km),
                               FRAME_BIAS.T @ [6995.1, 449.9, 0.1], rtol=1e-15, atol=0)
    assert 0.5 < np.linalg.norm(states.r[1].to_value(u.m) - [6995.1e3, 449.9e3, 0.1e3]) < 1
    assert abs(states.gm[0].to_value(u.km**3 / u.s**2) - vv.EARTH.gm_km3_s2) == 0
    cov0, cov1 = first.covariances
    assert cov0.frame == "RTN" and cov1.frame is None and cov1.comments == [
        "a second matrix, in the segment's frame"]
    assert cov0.matrix[1, 0] == cov0.matrix[0, 1] == 2.0e-5 and cov0.matrix[5, 5] == 3.0e-7
    np.testing.assert_array_equal(cov1.matrix, np.eye(6))


@pytest.mark.parametrize("fmt", ["kvn", "xml"])
def test_round_trip_reproduces_every_field(fmt, tmp_path):
    oem = vv.read_oem(OEM_KVN)
    path = tmp_path / f"x.{fmt}"
    text = vv.write_oem(oem, path, format=fmt)
    assert path.read_text() == text and text.lstrip().startswith("<" if fmt == "xml" else "C")
    back = vv.read_oem(path)
    assert back.header.values == oem.header.values
    assert back.header.comments == oem.header.comments
    for a, b in zip(oem.segments, back.segments, strict=True):
        assert a.metadata.values == b.metadata.values
        assert a.metadata.comments == b.metadata.comments and a.data_comments == b.data_comments
        assert a.epochs == b.epochs
        for name in ("r_km", "v_km_s", "a_km_s2"):
            x, y = getattr(a, name), getattr(b, name)
            assert (x is None and y is None) or np.array_equal(x, y)
        assert len(a.covariances) == len(b.covariances)
        for ca, cb in zip(a.covariances, b.covariances, strict=True):
            assert (ca.epoch, ca.frame, ca.comments) == (cb.epoch, cb.frame, cb.comments)
            np.testing.assert_array_equal(ca.matrix, cb.matrix)
    # the writer adds no keyword: the second write is identical to the first
    assert vv.write_oem(back, format=fmt) == text


def _two_body_segment(method, degree, step_s=60.0, n=60, with_acc=False):
    s0 = vv.StateVectors([7000.0, 0.0, 1000.0] * u.km, [0.0, 7.2, 1.5] * u.km / u.s, vv.EARTH)
    t0 = Time("2024-01-31T00:00:00", scale="utc")
    dt = np.arange(n) * step_s
    states = s0.propagate(dt * u.s)
    r, v = states.r.to_value(u.km), states.v.to_value(u.km / u.s)
    acc = -vv.EARTH.gm_km3_s2 * r / np.linalg.norm(r, axis=-1, keepdims=True) ** 3
    seg = OEMSegment.from_states(t0 + dt * u.s, r, v, object_name="KEPLER", degree=degree,
                                 interpolation=method, a_km_s2=acc if with_acc else None)
    return seg, s0, t0


@pytest.mark.parametrize("method, degree, tol_r, tol_v", [
    ("LAGRANGE", 8, 10 * ONE_MM, 1e-8),
    ("HERMITE", 4, 1 * ONE_MM, 1e-9),
    ("HERMITE", 2, 1e3 * ONE_MM, 1e-6),
])
def test_interpolation_matches_kepler_between_nodes(method, degree, tol_r, tol_v):
    seg, s0, t0 = _two_body_segment(method, degree)
    dt = np.linspace(0, 59 * 60.0, 401)
    exact = s0.propagate(dt * u.s)
    got = seg.interpolate(t0 + dt * u.s)
    err_r = np.abs(got.r.to_value(u.km) - exact.r.to_value(u.km)).max()
    err_v = np.abs(got.v.to_value(u.km / u.s) - exact.v.to_value(u.km / u.s)).max()
    assert err_r < tol_r and err_v < tol_v, (err_r, err_v)
    # at the nodes the interpolant is the table
    nodes = seg.interpolate(seg.times)
    np.testing.assert_allclose(nodes.r.to_value(u.km), seg.r_km, rtol=0, atol=1e-9)


def test_hermite_uses_accelerations_for_velocity():
    seg, s0, t0 = _two_body_segment("HERMITE", 3, with_acc=True)
    dt = np.linspace(0, 59 * 60.0, 101)
    exact = s0.propagate(dt * u.s)
    got = seg.interpolate(t0 + dt * u.s)
    assert np.abs(got.v.to_value(u.km / u.s) - exact.v.to_value(u.km / u.s)).max() < 1e-9


def test_ephemeris_interpolates_across_segments_and_refuses_gaps():
    oem = vv.read_oem(OEM_KVN)
    t = Time(["2024-01-31T00:01:30", "2024-02-01T00:03:30", "2024-02-01T00:03:00"], scale="utc")
    states = oem.interpolate(t)
    assert states.shape == (3,)
    np.testing.assert_allclose(states.r[1].to_value(u.km),
                               oem.segments[1].interpolate(t[1]).r.to_value(u.km), rtol=0, atol=0)
    # the boundary belongs to the later segment: its first state
    np.testing.assert_allclose(states.v[2].to_value(u.km / u.s),
                               FRAME_BIAS.T @ oem.segments[1].v_km_s[0], rtol=1e-15, atol=0)
    with pytest.raises(vv.InvalidInputError, match="covered by no segment"):
        oem.interpolate(Time("2024-01-31T12:00:00", scale="utc"))
    with pytest.raises(vv.InvalidInputError, match="outside the segment"):
        oem.segments[0].interpolate(Time("2024-01-31T00:03:01", scale="utc"))
    with pytest.raises(vv.InvalidInputError, match="needs 4 states, the segment has 3"):
        oem.segments[1].metadata.values["INTERPOLATION_DEGREE"] = 3
        oem.segments[1].interpolate(t[1])


@pytest.mark.parametrize("edit, line, words", [
    (("7000.0 0.0 0.0 0.0 7.5 0.0", "7000.0 0.0 0.0 0.0 7.5"), 23, "has 5"),
    (("6995.1 449.9", "6995.1 4x9.9"), 24, "not a number"),
    (("2024-01-31T00:02:00 6980.4", "2024-01-31T00:00:30 6980.4"), 25, "must increase"),
    (("2024-01-31T00:03:00 6956.0", "2024-01-31T00:04:00 6956.0"), 26, "outside START_TIME"),
    (("REF_FRAME = EME2000\nTIME", "REF_FRAME = EME2000\nFRAME = X\nTIME"), 13,
     "FRAME is not an OEM metadata keyword"),
    (("CENTER_NAME = EARTH\nREF_FRAME = EME2000\nTIME_SYSTEM = UTC\nSTART_TIME = 2024-01-31",
      "CENTER_NAME = EARTH\nTIME_SYSTEM = UTC\nSTART_TIME = 2024-01-31"), 9,
     "lacks the mandatory keyword REF_FRAME"),
    ((" 2.0E-5  4.0E-3\n", " 2.0E-5\n"), 32, "row 2 of the covariance"),
    (("COVARIANCE_STOP\n", ""), 46, "expected EPOCH"),
    (("INTERPOLATION = HERMITE", "INTERPOLATION = SPLINE"), 18, "INTERPOLATION = SPLINE"),
    ((" 2.0E-5  4.0E-3\n", " 2.0E-5 -4.0E-3\n"), 32, "CY_Y = -0.004 is a variance"),
    (("INTERPOLATION_DEGREE = 1", "INTERPOLATION_DEGREE = -1"), 19,
     "INTERPOLATION_DEGREE = -1: the degree .* is at least 1"),
    (("MESSAGE_ID = OEM-0001", "MESSAGE_ID = OEM-0001\nOBJECT_NAME = X"), 6,
     "expected META_START"),
    (("TIME_SYSTEM = UTC\nSTART_TIME = 2024-01-31", "TIME_SYSTEM = MET\nSTART_TIME = 2024-01-31"),
     13, "TIME_SYSTEM MET counts time from the launch epoch.*pass mission_epoch=Time"),
    (("TIME_SYSTEM = UTC\nSTART_TIME = 2024-01-31", "TIME_SYSTEM = SCLK\nSTART_TIME = 2024-01-31"),
     13, "TIME_SYSTEM 'SCLK' is not supported"),
])
def test_malformed_kvn_names_the_line(edit, line, words):
    assert edit[0] in OEM_KVN
    with pytest.raises(vv.CCSDSFormatError, match=words) as info:
        vv.read_oem(OEM_KVN.replace(edit[0], edit[1], 1))
    assert info.value.line == line, str(info.value)
    assert f"line {line}" in str(info.value)


def test_malformed_xml_names_the_line():
    text = vv.write_oem(vv.read_oem(OEM_KVN), format="xml")
    lines = text.splitlines()
    k = next(i for i, s in enumerate(lines) if "<Y_DOT" in s)
    bad = "\n".join(lines[:k] + [lines[k].replace('units="km/s"', 'units="m/s"')] + lines[k + 1:])
    with pytest.raises(vv.CCSDSFormatError, match=r"Y_DOT must be in \[km/s\]") as info:
        vv.read_oem(bad)
    assert info.value.line == k + 1
    k = next(i for i, s in enumerate(lines) if "<Z>" in s or "<Z " in s)
    bad = "\n".join(lines[:k] + lines[k + 1:])
    with pytest.raises(vv.CCSDSFormatError, match="lacks the mandatory keyword Z") as info:
        vv.read_oem(bad)
    with pytest.raises(vv.CCSDSFormatError, match="not well formed"):
        vv.read_oem(text[:-20])
    k = next(i for i, s in enumerate(lines) if "<CZ_DOT_Z_DOT" in s)
    bad = "\n".join(lines[:k] + [lines[k].replace(">", ">-", 1)] + lines[k + 1:])
    with pytest.raises(vv.CCSDSFormatError, match="CZ_DOT_Z_DOT = -.* cannot be negative") as info:
        vv.read_oem(bad)
    assert info.value.line == k + 1


def test_from_states_converts_quantities():
    # a position in metres was stored as that many kilometres, silently
    t = Time("2024-01-31T00:00:00", scale="utc") + np.arange(3) * 60 * u.s
    r = np.array([[7000.0, 0, 0], [6990.0, 450.0, 0], [6960.0, 900.0, 0]])
    v = np.array([[0, 7.5, 0], [-0.5, 7.48, 0], [-1.0, 7.43, 0]])
    seg = OEMSegment.from_states(t, r * 1000 * u.m, v * 1000 * u.m / u.s, object_name="X",
                                 a_km_s2=np.zeros((3, 3)) * u.m / u.s**2)
    np.testing.assert_allclose(seg.r_km, r, rtol=1e-15)
    np.testing.assert_allclose(seg.v_km_s, v, rtol=1e-15)
    with pytest.raises(vv.UnitsError, match="r_km has unit 's'"):
        OEMSegment.from_states(t, r * u.s, v, object_name="X")
    assert len(Ephemeris(seg).segments) == 1  # one segment, not in a list
    with pytest.raises(vv.InvalidInputError, match=r"segments\[1\] is a int, not an OEMSegment"):
        Ephemeris([seg, 1])  # was TypeError: object of type 'int' has no len()


@pytest.mark.parametrize("degree", [0, -2, 2.5])
def test_from_states_refuses_a_degree_no_reader_accepts(degree):
    t = Time("2024-01-31T00:00:00", scale="utc") + np.arange(3) * 60 * u.s
    with pytest.raises(vv.InvalidInputError, match="interpolation degree is an integer >= 1"):
        OEMSegment.from_states(t, np.full((3, 3), 7000.0), np.ones((3, 3)), object_name="X",
                               degree=degree)


def test_byte_order_mark_is_not_part_of_the_message(tmp_path):
    # Windows editors start UTF-8 files with a BOM; it used to make line 1 "not KEYWORD = value"
    path = tmp_path / "bom.oem"
    path.write_text(OEM_KVN, encoding="utf-8-sig")
    plain = vv.read_oem(OEM_KVN)
    for source in (path, "\ufeff" + OEM_KVN):
        seg = vv.read_oem(source).segments[0]
        assert np.array_equal(seg.r_km, plain.segments[0].r_km)
    assert vv.write_oem(vv.read_oem(path)) == vv.write_oem(plain)


def test_paths_errors_and_empty():
    with pytest.raises(vv.MissingFileError, match="no such file"):  # (a FileNotFoundError)
        vv.read_oem("/nonexistent/file.oem")
    with pytest.raises(vv.CCSDSFormatError, match="empty"):
        vv.read_oem("\n\n")
    with pytest.raises(vv.CCSDSFormatError, match="starts with CCSDS_OEM_VERS"):
        vv.read_oem("CCSDS_OPM_VERS = 3.0\n")
    with pytest.raises(vv.CCSDSFormatError, match="no segment"):
        vv.read_oem("CCSDS_OEM_VERS = 3.0\nCREATION_DATE = 2024-01-01T00:00:00\nORIGINATOR = X\n")


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(-1e5, 1e5, allow_nan=False), min_size=6, max_size=6),
       st.integers(2, 6), st.sampled_from(["kvn", "xml"]), st.booleans())
def test_hypothesis_round_trip_bit_for_bit(r_v, n, fmt, with_cov):
    t = Time("2030-06-30T23:59:58.5", scale="tai") + np.arange(n) * 7.25 * u.s
    rng = np.random.default_rng(n)
    r = np.asarray(r_v[:3]) + rng.normal(size=(n, 3)) * 1e3
    v = np.asarray(r_v[3:]) * 1e-5 + rng.normal(size=(n, 3))
    seg = OEMSegment.from_states(t, r, v, object_name="H", time_system="TAI", frame="ITRF",
                                 interpolation="LAGRANGE", degree=1)
    if with_cov:
        a = rng.normal(size=(6, 6))
        from visviva.ccsds.oem import OEMCovariance

        seg.covariances.append(OEMCovariance(seg.epochs[0], a @ a.T, "RSW", ["c"]))
    back = vv.read_oem(vv.write_oem(Ephemeris([seg]), format=fmt)).segments[0]
    assert np.array_equal(back.r_km, seg.r_km) and np.array_equal(back.v_km_s, seg.v_km_s)
    assert back.epochs == seg.epochs and back.metadata.values == seg.metadata.values
    assert np.abs((back.times - t).to_value(u.s)).max() < 1e-9
    if with_cov:
        np.testing.assert_array_equal(back.covariances[0].matrix, seg.covariances[0].matrix)


@pytest.mark.parametrize("method", ["LAGRANGE", "HERMITE"])
def test_interpolation_in_blocks_equals_one_pass(method, monkeypatch):
    from visviva.core import interpolation  # (the arithmetic, since audit39; ccsds re-exports)

    seg, _, t0 = _two_body_segment(method, 5)
    t = t0 + np.linspace(0, 59 * 60.0, 101) * u.s
    whole = seg.interpolate(t)
    monkeypatch.setattr(interpolation, "_CHUNK", 7)
    blocks = seg.interpolate(t)
    np.testing.assert_array_equal(blocks.r.to_value(u.km), whole.r.to_value(u.km))
    np.testing.assert_array_equal(blocks.v.to_value(u.km / u.s), whole.v.to_value(u.km / u.s))


def test_default_interpolation_when_the_file_names_none():
    text = OEM_KVN.replace("INTERPOLATION = HERMITE\nINTERPOLATION_DEGREE = 1\n", "")
    text = text.replace("INTERPOLATION = LAGRANGE\n", "")
    first, second = vv.read_oem(text).segments
    assert first.interpolation == ("LAGRANGE", 3)  # 4 states
    assert second.interpolation == ("LAGRANGE", 2)  # degree named, method not
    seg, _, _ = _two_body_segment("HERMITE", 5)
    del seg.metadata.values["INTERPOLATION"], seg.metadata.values["INTERPOLATION_DEGREE"]
    assert seg.interpolation == ("LAGRANGE", 7)


def test_states_in_other_frames_match_astropy_via_satellite():
    sat = vv.Satellite.from_tle(
        "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
        "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 10001")
    t = sat.epoch + np.arange(0, 3600, 600.0) * u.s
    teme = sat.teme(t)
    seg = OEMSegment.from_states(t, teme.r.to_value(u.km), teme.v.to_value(u.km / u.s),
                                 object_name="ISS", frame="TEME")
    for frame, ref in (("gcrs", sat.gcrs(t)), ("itrs", sat.itrs(t))):
        got = seg.states_in(frame)
        assert np.abs(got.r.to_value(u.km) - ref.r.to_value(u.km)).max() < 1e-6  # 1 mm
        assert np.abs(got.v.to_value(u.km / u.s) - ref.v.to_value(u.km / u.s)).max() < 1e-9
    with pytest.raises(vv.InvalidInputError, match="not supported"):
        seg.states_in("icrs")


@pytest.mark.parametrize("frame", ["TEME", "ITRF", "GCRF"])
def test_earth_states_read_from_a_file_know_their_frame(frame):
    # seg.states, oem.interpolate(t) and opm.state were plain StateVectors whatever REF_FRAME
    # said, so GroundStation.look read TEME as GCRS (9 km of range off) and ITRF (3,356 km off)
    from visviva.ccsds.opm import OPM

    sat = vv.Satellite.from_tle(
        "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
        "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 10001")
    t = sat.epoch + np.arange(0, 600, 60.0) * u.s
    mine = {"TEME": "teme", "ITRF": "itrs", "GCRF": "gcrs"}[frame]
    s = getattr(sat, mine)(t)
    oem = vv.read_oem(vv.write_oem(OEMSegment.from_states(
        t, s.r.to_value(u.km), s.v.to_value(u.km / u.s), object_name="ISS", frame=frame)))
    opm = vv.read_opm(vv.write_opm(OPM.from_state(
        vv.StateVectors(s.r[0], s.v[0], vv.EARTH, epoch=t[0]), object_name="ISS", frame=frame)))
    got = (oem.segments[0].states, oem.segments[0].interpolate(t), oem.interpolate(t), opm.state,
           oem.segments[0].states_in(mine))
    for states in got:
        assert states.frame == mine
    site = vv.GroundStation(52.2 * u.deg, 0.12 * u.deg)
    if mine == "itrs":
        with pytest.raises(vv.InvalidInputError, match="ITRS"):
            site.look(got[0])
        with pytest.raises(vv.InvalidInputError, match="ITRS"):
            vv.propagate_cowell(opm.state, 60 * u.s)
    else:
        truth = site.look(sat, t).range
        for states in got[:3]:
            assert np.abs(site.look(states).range - truth).max() < 1 * u.mm
        assert abs(site.look(opm.state).range - truth[0]) < 1 * u.mm
    moon = OEMSegment.from_states(t, s.r.to_value(u.km), s.v.to_value(u.km / u.s),
                                  object_name="X", center="MOON", frame=frame)
    assert getattr(moon.states, "frame", None) is None  # frames about other bodies: unlabelled


def _with_comments_among_states():
    text = OEM_KVN.replace(
        "2024-01-31T00:02:00 6980.4",
        "COMMENT tracking gap ends here\nCOMMENT (two notes)\n2024-01-31T00:02:00 6980.4")
    text = text.replace("\nCOVARIANCE_START", "COMMENT last state of the arc\n\nCOVARIANCE_START")
    return text.replace("2024-032T00:05:00 6878.0", "COMMENT after the burn\n2024-032T00:05:00 6878.0"
                        ) + "COMMENT end of file\n"


@pytest.mark.parametrize("fmt", ["kvn", "xml"])
def test_comments_among_state_lines_are_kept_and_written_back(fmt):
    text = _with_comments_among_states()
    oem = vv.read_oem(text)
    first, second = oem.segments
    assert first.data_comments == ["states in km and km/s"]
    assert first.state_comments == {2: ["tracking gap ends here", "(two notes)"],
                                     4: ["last state of the arc"]}
    assert second.state_comments == {2: ["after the burn"], 3: ["end of file"]}
    assert len(first) == 4 and len(first.covariances) == 2  # nothing else changed
    back = vv.read_oem(vv.write_oem(oem, format=fmt))
    for a, b in zip(oem.segments, back.segments, strict=True):
        assert a.data_comments == b.data_comments and a.state_comments == b.state_comments
        assert a.epochs == b.epochs and np.array_equal(a.r_km, b.r_km)
    # the KVN text keeps each note in its place: every COMMENT line of the input is written
    out = vv.write_oem(oem, format="kvn")
    assert [ln for ln in out.splitlines() if ln.startswith("COMMENT")] == [
        " ".join(ln.split()) for ln in text.splitlines() if ln.startswith("COMMENT")]
    lines = out.splitlines()
    k = lines.index("COMMENT tracking gap ends here")
    assert lines[k - 1].startswith("2024-01-31T00:01:00") and lines[k + 2].startswith(
        "2024-01-31T00:02:00")


def test_segment_interface_used_by_the_ephemeris():
    seg = vv.read_oem(OEM_KVN).segments[0]
    t = seg.times[0] + [30, 90] * u.s
    r, v = seg.interpolate_arrays(t)
    assert r.shape == v.shape == (2, 3)
    states = seg.interpolate(t)
    np.testing.assert_allclose(states.r.to_value(u.km), r @ FRAME_BIAS, rtol=1e-15, atol=0)
    assert seg.gm_km3_s2 == vv.EARTH.gm_km3_s2


def _met_oem():
    """The example's first segment in MET from a launch at 2024-01-30T22:00:00 UTC."""
    text = OEM_KVN.split("\nMETA_START", 2)
    first = "\nMETA_START" + text[1]
    first = first.replace("TIME_SYSTEM = UTC", "TIME_SYSTEM = MET")
    for hh_mm in ("00:00", "00:01", "00:02", "00:03"):
        first = first.replace(f"2024-01-31T{hh_mm}:00", f"0000-000T02:{hh_mm[3:]}:00")
    return text[0] + first


def test_met_and_mrt_count_from_the_mission_epoch_the_user_gives():
    launch = Time("2024-01-30T22:00:00", scale="utc")
    utc = vv.read_oem(OEM_KVN).segments[0]
    with pytest.raises(vv.CCSDSFormatError, match="pass mission_epoch"):
        vv.read_oem(_met_oem())
    met = vv.read_oem(_met_oem(), mission_epoch=launch).segments[0]
    assert met.time_system == "MET" and met.epochs[1] == "0000-000T02:01:00"
    assert np.abs((met.times - utc.times).to_value(u.s)).max() < 1e-9
    t = utc.times[0] + 90 * u.s
    np.testing.assert_allclose(met.interpolate(t).r.to_value(u.km),
                               utc.interpolate(t).r.to_value(u.km), rtol=0, atol=ONE_MM)
    # written back as it was, and a segment made in code in MRT round-trips to the nanosecond
    assert vv.write_oem(vv.read_oem(_met_oem(), mission_epoch=launch)).count("0000-000T02:0") >= 6
    ref = Time("2023-06-01T00:00:00", scale="tai")
    times = Time("2024-01-31T00:00:00", scale="utc") + np.arange(5) * 60.123456789 * u.s
    seg = OEMSegment.from_states(times, utc.r_km[[0, 1, 2, 3, 3]] + np.arange(5)[:, None],
                                 np.ones((5, 3)), object_name="X", time_system="MRT",
                                 mission_epoch=ref)  # fmt: skip
    assert seg.epochs[0] == "0000-244T00:00:37.000000000"  # 244 days + TAI - UTC = 37 s
    back = vv.read_oem(vv.write_oem(seg), mission_epoch=ref).segments[0]
    assert back.epochs == seg.epochs
    assert np.abs((back.times - times).to_value(u.s)).max() < 1e-9
    with pytest.raises(vv.InvalidInputError, match="before the mission epoch"):
        OEMSegment.from_states(times, np.ones((5, 3)), np.ones((5, 3)), object_name="X",
                               time_system="MET", mission_epoch=times[-1])
    with pytest.raises(vv.CCSDSFormatError, match="elapsed time written YYYY-DDDThh:mm:ss"):
        vv.read_oem(OEM_KVN.replace("TIME_SYSTEM = UTC", "TIME_SYSTEM = MRT", 1),
                    mission_epoch=ref)


def test_a_mission_epoch_for_a_message_without_met_or_mrt_is_refused(tmp_path, capsys):
    # leftfix4: read_oem(utc_text, mission_epoch=launch) read the UTC epochs and dropped the
    # launch epoch in silence (and so did `visviva fit-tle --mission-epoch`, read_opm)
    from test_ccsds_opm_omm import OPM_KVN
    from visviva.cli import main

    launch = Time("2024-01-30T22:00:00", scale="utc")
    with pytest.raises(vv.InvalidInputError,
                       match=r"line 13: mission_epoch was given, but the message's TIME_SYSTEM "
                             r"is UTC, not MET or MRT"):
        vv.read_oem(OEM_KVN, mission_epoch=launch)
    with pytest.raises(vv.InvalidInputError, match="TIME_SYSTEM is UTC, not MET or MRT"):
        vv.read_oem(vv.write_oem(vv.read_oem(OEM_KVN), format="xml"), mission_epoch=launch)
    with pytest.raises(vv.InvalidInputError, match="TIME_SYSTEM is UTC, not MET or MRT"):
        vv.read_opm(OPM_KVN, mission_epoch=launch)
    # one MET segment beside a UTC one still takes it (the epoch is used there)
    mixed = _met_oem() + "\nMETA_START" + OEM_KVN.split("\nMETA_START", 2)[2]
    assert [s.time_system for s in vv.read_oem(mixed, mission_epoch=launch).segments] == [
        "MET", "UTC"]
    path = tmp_path / "utc.oem"
    path.write_text(OEM_KVN)
    assert main(["fit-tle", str(path), "--mission-epoch", "2024-01-30T22:00:00"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("visviva fit-tle: ") and "not MET or MRT" in err
    assert err.count("\n") == 1


# -- audit -----------------------------------------------------------------------------------------


@pytest.mark.parametrize("good, bad", [
    ("2024-01-31T00:01:00", "2024-13-31T00:01:00"),   # month 13
    ("2024-01-31T00:02:00", "2024-01-31T24:02:00"),   # hour 24
    ("2024-032T00:04:00", "2024-032T00:61:00"),       # minute 61, day-of-year form
])
def test_an_impossible_state_date_names_its_own_line(good, bad):
    # the error named the TIME_SYSTEM line (13 or 52) and carried astropy's two-line ERFA
    # message, whatever state line held the bad date
    text = OEM_KVN.replace(good + " ", bad + " ", 1)
    line = next(k for k, s in enumerate(text.splitlines(), 1) if s.startswith(bad))
    with pytest.raises(vv.CCSDSFormatError, match="is not a valid date-time") as info:
        vv.read_oem(text)
    assert info.value.line == line, str(info.value)
    assert bad in str(info.value) and "\n" not in str(info.value)
    xml = vv.write_oem(vv.read_oem(OEM_KVN), format="xml")
    k = next(i for i, s in enumerate(xml.splitlines(), 1) if f">{good}<" in s)
    xml = xml.replace(f">{good}<", f">{bad}<", 1)  # the writer keeps the epochs as read
    with pytest.raises(vv.CCSDSFormatError, match="is not a valid date-time") as info:
        vv.read_oem(xml)
    assert info.value.line == k, str(info.value)


@pytest.mark.parametrize("system", ["UTC", "TDB"])
def test_interpolation_does_not_depend_on_the_scale_of_the_query(system):
    # the time from the first node was taken in the query's scale: the same instant given in
    # TDB and in UTC landed 0.57 us apart (TDB's periodic term over half an hour), 4 mm at
    # 7.4 km/s, ten thousand times the interpolation error of Hermite on these nodes
    t0 = Time("2024-01-31T00:00:00", scale=system.lower())
    ts = np.arange(0.0, 3601.0, 60.0)
    state = vv.StateVectors([7000.0, 0, 100] * u.km, [0, 7.4, 1.0] * u.km / u.s, vv.EARTH,
                            epoch=t0)
    eph = state.propagate(ts * u.s)
    from visviva.ccsds.oem import Ephemeris, OEMSegment

    seg = OEMSegment.from_states(t0 + ts * u.s, eph.r, eph.v, object_name="S",
                                 object_id="2024-999A", center="EARTH", frame="EME2000",
                                 time_system=system, interpolation="HERMITE", degree=5)
    oem = vv.read_oem(vv.write_oem(Ephemeris([seg])))
    t = t0 + 1800.5 * u.s
    ref = oem.interpolate(t).r.to_value(u.km)
    for other in (t.utc, t.tdb, t.tt, t.tai):
        assert np.linalg.norm(oem.interpolate(other).r.to_value(u.km) - ref) < 1e-9  # 1 um
        assert np.linalg.norm(oem.segments[0].interpolate(other).r.to_value(u.km) - ref) < 1e-9
    # (the arrays were written as EME2000 numbers: read back on the GCRS axes, B.T r)
    truth = FRAME_BIAS.T @ state.propagate(1800.5 * u.s).r.to_value(u.km)
    assert np.linalg.norm(ref - truth) < 1e-6  # Hermite of degree 5 on 1-min nodes: < 1 mm


def test_writers_refuse_what_their_reader_would_refuse():
    # from_states took an empty or two-line OBJECT_NAME and INTERPOLATION = SPLINE and wrote
    # files that read_oem then refused ("has no value", a broken metadata block, SPLINE)
    from visviva.ccsds.oem import Ephemeris, OEMSegment

    t = Time("2024-01-01", scale="utc") + np.arange(5) * 60 * u.s
    r = np.tile([7000.0, 0, 0], (5, 1)) + np.arange(5)[:, None] * [0, 450, 0]
    v = np.tile([0, 7.5, 0], (5, 1))
    with pytest.raises(vv.InvalidInputError, match="SPLINE"):
        OEMSegment.from_states(t, r, v, object_name="X", interpolation="SPLINE")
    for name in ("", "A\nB", "  "):
        seg = OEMSegment.from_states(t, r, v, object_name=name)
        for fmt in ("kvn", "xml"):
            with pytest.raises(vv.InvalidInputError, match="OBJECT_NAME"):
                vv.write_oem(Ephemeris([seg]), format=fmt)
    ok = vv.read_oem(vv.write_oem(Ephemeris([OEMSegment.from_states(t, r, v, object_name="A=B")])))
    assert ok.segments[0].metadata["OBJECT_NAME"] == "A=B"


def test_a_file_that_is_not_text_names_the_line(tmp_path):
    # a Latin-1 byte raised UnicodeDecodeError; a directory IsADirectoryError
    path = tmp_path / "latin1.oem"
    path.write_bytes(OEM_KVN.replace("OBJECT_NAME = TESTSAT", "OBJECT_NAME = TESTS\xe4T").encode("latin-1"))
    with pytest.raises(vv.CCSDSFormatError, match="not UTF-8") as info:
        vv.read_oem(path)
    assert info.value.line == 9
    with pytest.raises(vv.CCSDSFormatError, match="directory"):
        vv.read_oem(tmp_path)


def _leap_oem(system, epochs):
    head = ("CCSDS_OEM_VERS = 3.0\nCREATION_DATE = 2024-01-31T00:00:00\nORIGINATOR = VISVIVA\n"
            "META_START\nOBJECT_NAME = X\nOBJECT_ID = 2016-999A\nCENTER_NAME = EARTH\n"
            f"REF_FRAME = EME2000\nTIME_SYSTEM = {system}\nSTART_TIME = {epochs[0]}\n"
            f"STOP_TIME = {epochs[-1]}\nMETA_STOP\n")  # states start on line 13
    rows = [f"{e} {7000.0 + k} 0.0 0.0 0.0 7.5 0.0" for k, e in enumerate(epochs)]
    return head + "\n".join(rows) + "\n"


def test_a_leap_second_epoch_is_read_and_written_back_to_the_nanosecond(tmp_path):
    epochs = ["2016-12-31T23:59:59.5", "2016-12-31T23:59:60.25", "2017-01-01T00:00:00.75"]
    eph = vv.read_oem(_leap_oem("UTC", epochs))
    t = eph.segments[0].times
    # the leap second 2016-12-31T23:59:60 counts: 0.75 s then 1.5 s of TAI apart
    np.testing.assert_allclose(np.diff(t.tai.jd1 * 86400.0 + t.tai.jd2 * 86400.0), [0.75, 1.5],
                               atol=1e-6)
    vv.write_oem(eph, tmp_path / "leap.oem")
    again = vv.read_oem(tmp_path / "leap.oem").segments[0].times
    assert np.abs((again - t).to_value(u.s)).max() < 1e-9
    assert "2016-12-31T23:59:60.25 " in (tmp_path / "leap.oem").read_text()
    # from states (no text kept): astropy writes the leap second as 23:59:60
    st_ = eph.segments[0].states
    made = OEMSegment.from_states(t, st_.r.to_value(u.km), st_.v.to_value(u.km / u.s),
                                  object_name="X", degree=1)
    vv.write_oem(Ephemeris([made]), tmp_path / "made.oem")
    assert "2016-12-31T23:59:60.250000000" in (tmp_path / "made.oem").read_text()
    again = vv.read_oem(tmp_path / "made.oem").segments[0].times
    assert np.abs((again - t).to_value(u.s)).max() < 1e-9


@pytest.mark.parametrize(("system", "epoch"), [
    ("UTC", "2017-01-01T23:59:60.5"),   # no leap second that day: was read as 01-02T00:00:00.5
    ("UTC", "2016-06-30T23:59:60.0"),   # the leap second was 2015-06-30: was 07-01T00:00:00
    ("TAI", "2016-12-31T23:59:60.5"),   # uniform scales have no second 60: was 1 min later
    ("TT", "2016-366T23:59:60.5"),
    ("GPS", "2016-12-31T23:59:60.0"),
])
def test_a_second_60_that_is_no_leap_second_names_its_line(system, epoch):
    text = _leap_oem(system, ["2016-12-31T23:59:00", epoch])
    with pytest.raises(vv.CCSDSFormatError, match="second 60") as info:
        vv.read_oem(text)
    assert "line 14" in str(info.value) or "line 11" in str(info.value)


def test_states_in_refuses_a_centre_other_than_the_earth():
    # a Moon-centred EME2000 segment was rotated about the geocentre's axes with the Earth's
    # spin term and came back labelled 'teme' / 'itrs' (geocentric frames) without a word
    sat = vv.Satellite.from_tle(
        "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
        "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 10001")
    t = sat.epoch + np.arange(0, 180, 60.0) * u.s
    r = np.array([[1838.0, 97.8 * k, 0.0] for k in range(3)])
    v = np.array([[0.0, 1.63, 0.0]] * 3)
    seg = OEMSegment.from_states(t, r, v, object_name="LRO", center="MOON", frame="EME2000",
                                 degree=2)
    for frame in ("teme", "itrs", "gcrs"):
        with pytest.raises(vv.InvalidInputError, match="CENTER_NAME = MOON"):
            seg.states_in(frame)
    earth = OEMSegment.from_states(t, r * 4, v * 4.6, object_name="X", frame="EME2000",
                                   degree=2)
    assert earth.states_in("gcrs").frame == "gcrs"


@pytest.mark.parametrize("edit, off", [(lambda a: 0 * a, "100%"), (lambda a: a * 1e3, "998"),
                                       (lambda a: -a, "200%")])
def test_accelerations_that_do_not_give_the_velocities_change_are_warned_about(edit, off):
    """Zeros written for want of accelerations (or m/s**2, or the wrong sign) were read
    silently, and HERMITE interpolated the velocities with them: zeros put a LEO velocity
    5.5 m/s off between 60 s states (1e-11 m/s with the true accelerations)."""
    t = Time("2024-01-31T00:00:00", scale="utc") + np.arange(20) * 60 * u.s
    n = np.sqrt(vv.EARTH.gm_km3_s2 / 7000.0**3)
    th = n * np.arange(20) * 60.0
    c, s_ = np.cos(th), np.sin(th)
    r = 7000.0 * np.stack([c, s_, 0 * c], 1)
    v = 7000.0 * n * np.stack([-s_, c, 0 * c], 1)
    a = -n**2 * r
    good = vv.write_oem(OEMSegment.from_states(t, r, v, a_km_s2=a, object_name="X", degree=3,
                                               frame="GCRF"))
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        exact = vv.read_oem(good).segments[0]  # consistent: no warning
    bad = vv.write_oem(OEMSegment.from_states(t, r, v, a_km_s2=edit(a), object_name="X",
                                              degree=3, frame="GCRF"))
    first = next(k for k, s in enumerate(bad.splitlines(), 1) if s.startswith("2024-01-31T"))
    with pytest.warns(UserWarning, match=rf"line {first}: the accelerations .*\(off by {off}"):
        seg = vv.read_oem(bad).segments[0]
    tq = t[5] + 30 * u.s
    want = 7000.0 * n * np.array([-np.sin(n * 330.0), np.cos(n * 330.0), 0.0])
    assert np.linalg.norm(exact.interpolate_arrays(tq)[1][0] - want) < 1e-12  # km/s
    if off == "100%":
        assert np.linalg.norm(seg.interpolate_arrays(tq)[1][0] - want) > 5e-3  # 5.5 m/s
    seg.a_km_s2 = None  # the remedy the warning names
    assert np.linalg.norm(seg.interpolate_arrays(tq)[1][0] - want) < 1e-9


def test_segments_of_different_objects_are_not_stitched_by_interpolate():
    """An OEM gives one object's states; a file holding two (OBJECT_ID 2024-999A, 2020-001B)
    over the same hour was interpolated with the later segment's object, silently (a state of
    another satellite). Refused like different frames; each segment still interpolates."""
    oem = vv.read_oem(OEM_KVN)
    other = OEMSegment(dict(oem.segments[1].metadata.values, OBJECT_ID="2020-001B"),
                       oem.segments[1].epochs, oem.segments[1].r_km, oem.segments[1].v_km_s)
    two = vv.read_oem(vv.write_oem(Ephemeris([oem.segments[0], other])))
    t = Time("2024-02-01T00:04:00", scale="utc")
    with pytest.raises(vv.InvalidInputError, match=r"differ in OBJECT_ID \(\['2020-001B', "
                       r"'2024-999A'\]\)"):
        two.interpolate(t)
    np.testing.assert_array_equal(two.segments[1].interpolate(t).r, oem.interpolate(t).r)
