"""``visviva convert`` between TLE, OMM and OEM, checked against sgp4 directly."""

import numpy as np
import pytest
from astropy import units as u
from sgp4.api import Satrec

import visviva as vv
from visviva import cli

ISS = ("ISS (ZARYA)",
       "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
       "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 10001")


@pytest.fixture
def tle_file(tmp_path):
    path = tmp_path / "iss.tle"
    path.write_text("\n".join(ISS) + "\n")
    return path


@pytest.mark.parametrize("suffix", [".omm", ".xml"])
def test_tle_to_omm_to_tle_is_the_same_text(tle_file, tmp_path, suffix):
    omm_path = tmp_path / f"iss{suffix}"
    extra = ["--to", "omm"] if suffix == ".xml" else []
    assert cli.main(["convert", str(tle_file), str(omm_path), *extra]) == 0
    omm = vv.read_omm(omm_path)
    assert omm["ORIGINATOR"] == "VISVIVA" and omm["NORAD_CAT_ID"] == 25544
    back = tmp_path / "back.tle"
    assert cli.main(["convert", str(omm_path), str(back)]) == 0
    assert back.read_text().splitlines() == list(ISS)


@pytest.mark.parametrize("frame", ["TEME", "GCRF", "EME2000"])
def test_tle_to_oem_samples_sgp4(tle_file, tmp_path, frame):
    out = tmp_path / "iss.oem"
    assert cli.main(["convert", str(tle_file), str(out), "--hours", "2", "--step", "60",
                     "--frame", frame]) == 0
    seg = vv.read_oem(out).segments[0]
    assert len(seg) == 121 and seg.frame == frame and seg.interpolation == ("LAGRANGE", 7)
    if frame == "TEME":  # the states are sgp4's own (to the split of the Julian dates: 1 um)
        sat = Satrec.twoline2rv(ISS[1], ISS[2])
        jd = seg.times.utc.jd1
        fr = seg.times.utc.jd2
        err, r, v = sat.sgp4_array(jd, fr)
        assert not err.any()
        np.testing.assert_allclose(seg.r_km, r, rtol=0, atol=1e-9)
        np.testing.assert_allclose(seg.v_km_s, v, rtol=0, atol=1e-12)
    # between the samples the file's interpolation stays within a metre of SGP4
    t = seg.times[0] + np.arange(30, 7000, 97.0) * u.s
    sat = vv.Satellite.from_tle(*ISS[1:])
    ref = sat.teme(t) if frame == "TEME" else sat.gcrs(t)
    if frame == "EME2000":  # written turned by the frame bias (GCRS numbers were written, 0.8 m)
        from visviva.ccsds.timeframes import FRAME_BIAS

        gcrs = sat.gcrs(seg.times).r.to_value(u.km)
        np.testing.assert_allclose(seg.r_km, gcrs @ FRAME_BIAS.T, rtol=0, atol=1e-9)
        assert np.linalg.norm(seg.r_km - gcrs, axis=1).min() > 4e-4  # km
    got = seg.interpolate(t)
    assert np.abs(got.r.to_value(u.km) - ref.r.to_value(u.km)).max() < 1e-3


def test_errors(tle_file, tmp_path, capsys):
    two = tmp_path / "two.tle"
    from visviva.satellites.tle_export import tle_checksum

    other = [s.replace("25544", "25545")[:68] for s in ISS[1:]]
    other = [s + str(tle_checksum(s)) for s in other]
    two.write_text("\n".join(ISS) + "\nOTHER\n" + "\n".join(other) + "\n")
    # bad input exits with code 2 and one line, like every command (these exited with 1)
    assert cli.main(["convert", str(two), str(tmp_path / "x.omm"), "--to", "omm"]) == 2
    assert "visviva convert: " in (err := capsys.readouterr().err) and "holds 2 element" in err
    assert "KVN OMM holds one" in err and "--format xml" in err and "--satnum" in err
    assert cli.main(["convert", str(two), str(tmp_path / "x.oem")]) == 2
    assert "an OEM is sampled from one: pick one with --satnum" in capsys.readouterr().err
    assert cli.main(["convert", str(tle_file), str(tmp_path / "x.dat")]) == 2
    assert "cannot tell the output kind" in capsys.readouterr().err
    assert cli.main(["convert", str(tle_file), str(tmp_path / "x.oem"),
                     "--start", "2024-13-01"]) == 2
    assert "--start '2024-13-01' is not an ISO time" in capsys.readouterr().err  # (a traceback)
    with pytest.raises(SystemExit) as exc:  # refused as the arguments are read
        cli.main(["convert", str(tle_file), str(tmp_path / "x.oem"), "--step", "0"])
    assert exc.value.code == 2
    assert "--step: '0' is not a positive number of seconds" in capsys.readouterr().err
    bad = tmp_path / "bad.omm"
    bad.write_text("CCSDS_OMM_VERS = 3.0\nCREATION_DATE = 2024\n")
    assert cli.main(["convert", str(bad), str(tmp_path / "x.tle")]) == 2
    assert "line 2" in capsys.readouterr().err


def test_latin1_tle_converts(tmp_path, capsys):
    """A TLE whose name line is Latin-1 (not UTF-8) converts, as read_tle_file reads it; a
    CCSDS message with the same byte is still refused naming its line."""
    path = tmp_path / "latin1.tle"
    path.write_bytes("ESPAÑA-SAT\n".encode("latin-1") + "\n".join(ISS[1:]).encode() + b"\n")
    assert vv.read_tle_file(path)[0].name == "ESPAÑA-SAT"
    out = tmp_path / "out.omm"
    assert cli.main(["convert", str(path), str(out)]) == 0
    omm = vv.read_omm(out)
    assert omm["OBJECT_NAME"] == "ESPAÑA-SAT" and omm["NORAD_CAT_ID"] == 25544
    back = tmp_path / "back.tle"
    assert cli.main(["convert", str(out), str(back)]) == 0
    assert back.read_text(encoding="utf-8").splitlines() == ["ESPAÑA-SAT", *ISS[1:]]
    text = out.read_text(encoding="utf-8").replace("ESPAÑA", "ESPA\xd1A")
    bad = tmp_path / "bad.omm"
    bad.write_bytes(text.encode("latin-1"))
    assert cli.main(["convert", str(bad), str(tmp_path / "x.tle")]) == 2
    err = capsys.readouterr().err
    line = 1 + text[:text.index("ESPA\xd1A")].count("\n")
    assert f"line {line}" in err and "not UTF-8" in err and str(bad) in err, err


def test_read_catalog_file_kvn_matches_read_omm(tmp_path, write_catalog_files):
    """read_catalog_file's KVN OMM (parsed in the satellites layer, which may not import
    ccsds) gives the satellite vv.read_omm does; every kind gives the TLE's satellite."""
    iss = vv.Satellite.from_tle(*ISS[1:], ISS[0])
    paths = write_catalog_files([iss])
    full = vv.Catalog.from_omm([vv.read_omm(paths["kvn"])])[0]
    for kind, path in paths.items():
        sat = vv.read_catalog_file(path)[0]
        assert sat.to_tle() == iss.to_tle() == full.to_tle() and sat.name == ISS[0], kind
    # a KVN line without '=' and a repeated keyword name their lines
    text = paths["kvn"].read_text().splitlines()
    for k, edit in ((5, "OBJECT_NAME ISS"), (6, text[5])):
        bad = tmp_path / f"bad{k}.dat"
        bad.write_text("\n".join(text[:k] + [edit] + text[k + 1:]) + "\n")
        with pytest.raises(vv.InvalidInputError, match=f"line {k + 1}"):
            vv.read_catalog_file(bad)
    # a TLE whose names start like JSON or XML is still a TLE
    for name in ("[+] ISS", "<ISS>", "{ISS}"):
        odd = tmp_path / "odd.dat"
        odd.write_text(f"{name}\n{ISS[1]}\n{ISS[2]}\n")
        assert vv.read_catalog_file(odd)[0].name == name
    # other CCSDS messages and XML documents are refused by name, not read as TLE lines
    oem = tmp_path / "x.dat"
    oem.write_text("COMMENT made by hand\nCCSDS_OPM_VERS = 3.0\n")
    with pytest.raises(vv.InvalidInputError, match="CCSDS OPM"):
        vv.read_catalog_file(oem)
    oem.write_text('<?xml version="1.0"?>\n<oem><header/></oem>\n')
    with pytest.raises(vv.InvalidInputError, match="without <omm>"):
        vv.read_catalog_file(oem)


def test_convert_reads_gp_data(tmp_path, write_catalog_files, capsys):
    """CelesTrak GP data (JSON, CSV, an XML <ndm> of many OMMs; Space-Track's records hold
    CCSDS_OMM_VERS too) converts: --satnum picks the satellite, the TLE lines come back."""
    import json

    iss = vv.Satellite.from_tle(*ISS[1:], ISS[0])
    l1, l2 = (s.replace("25544", "25545")[:68] for s in ISS[1:])
    from visviva.satellites.tle_export import tle_checksum

    other = vv.Satellite.from_tle(l1 + str(tle_checksum(l1)), l2 + str(tle_checksum(l2)), "B")
    paths = write_catalog_files([other, iss])
    spacetrack = tmp_path / "st.json"
    records = json.loads(paths["json"].read_text())
    spacetrack.write_text(json.dumps([{"CCSDS_OMM_VERS": "2.0", **r} for r in records]))
    paths["spacetrack"] = spacetrack
    for kind, path in paths.items():
        if kind == "tle":
            continue
        out = tmp_path / f"{kind}.tle"
        assert cli.main(["convert", str(path), str(out), "--satnum", "25544"]) == 0, kind
        assert out.read_text().splitlines() == list(ISS), kind
        # without --satnum every element set, in the file's order (it was refused)
        assert cli.main(["convert", str(path), str(out), "--overwrite"]) == 0
        assert out.read_text().splitlines()[3:] == list(ISS), kind
        assert out.read_text().splitlines()[0] == "B"
    omm = tmp_path / "iss.omm"
    assert cli.main(["convert", str(paths["ndm"]), str(omm), "--satnum", "25544"]) == 0
    assert vv.read_omm(omm)["NORAD_CAT_ID"] == 25544


def test_an_ndm_of_one_omm_converts_as_the_message(tmp_path):
    # an <ndm> wrapping one OMM went through a Satellite: its comments, USER_DEFINED
    # parameters (and covariance, spacecraft data ...) were dropped without a word (audit25)
    from test_ccsds_opm_omm import OMM_KVN

    text = OMM_KVN.rstrip("\n") + "\nCOMMENT user block\nUSER_DEFINED_FOO = 12.5\n"
    xml = vv.write_omm(vv.read_omm(text), format="xml").split("\n", 1)[1]
    ndm = tmp_path / "one.xml"
    ndm.write_text(f"<ndm>\n{xml}</ndm>\n")
    out = tmp_path / "one.omm"
    assert cli.main(["convert", str(ndm), str(out)]) == 0
    assert vv.read_omm(out) == vv.read_omm(text)
    assert vv.read_omm(out).comments == vv.read_omm(text).comments


def test_one_omm_picked_from_kvn_gp_data_keeps_the_whole_message(tmp_path, capsys):
    # Space-Track's KVN GP data: an OMM picked with --satnum went through its SGP4 elements,
    # dropping its comments and USER_DEFINED_* parameters (object type, size ...) (audit25)
    from test_ccsds_opm_omm import OMM_KVN

    iss = OMM_KVN.rstrip("\n") + "\nCOMMENT user block\nUSER_DEFINED_OBJECT_TYPE = PAYLOAD\n"
    other = OMM_KVN.replace("25544", "25545").replace("ISS (ZARYA)", "OTHER")
    assert "NORAD_CAT_ID" in OMM_KVN and other != OMM_KVN
    gp = tmp_path / "gp.kvn"
    gp.write_text(other + iss)
    out = tmp_path / "iss.omm"
    assert cli.main(["convert", str(gp), str(out), "--satnum", "25544"]) == 0
    assert vv.read_omm(out) == vv.read_omm(iss)
    assert vv.read_omm(out).comments == vv.read_omm(iss).comments
    # an error in the message names the file's line
    gp.write_text(other + iss.replace("PAYLOAD", ""))
    bad = other.count("\n") + iss.count("\n")
    assert cli.main(["convert", str(gp), str(out), "--satnum", "25544", "--overwrite"]) == 2
    assert f"{gp}, line {bad}: " in capsys.readouterr().err


def _verification_catalogue():
    """The SGP4 verification element sets shipped with sgp4 (near-Earth and deep-space), the
    first set of each object, without the two whose perigee is below the surface and one that
    SGP4 cannot propagate (error 3 at its epoch); named."""
    import importlib.resources

    from visviva.satellites.catalog import parse_tle_text

    text = (importlib.resources.files("sgp4") / "SGP4-VER.TLE").read_text()
    lines = [ln[:69] if ln.startswith("2 ") else ln for ln in text.splitlines()]
    with pytest.warns(vv.SubsurfacePerigeeWarning):
        sats = parse_tle_text("\n".join(ln for ln in lines if not ln.startswith("#")),
                              verify_checksum=False)
    out, seen = [], set()
    for s in sats:
        if s.satnum not in seen and s.satnum not in (28872, 33333, 33334):
            seen.add(s.satnum)
            out.append(s)
    return out


def test_a_catalogue_converts_whole_to_omm_xml_and_to_tle(tmp_path, capsys):
    # leftfix8: a file of several element sets was refused without --satnum; now TLE -> OMM
    # writes an XML <ndm> of one <omm> each (as CelesTrak's GP XML) and TLE -> TLE all of them
    sats = _verification_catalogue()
    assert len(sats) == 29
    tle = tmp_path / "cat.tle"
    tle.write_text("".join(f"OBJECT {s.satnum}\n{s.to_tle()[0]}\n{s.to_tle()[1]}\n"
                           for s in sats))
    xml = tmp_path / "cat.xml"
    assert cli.main(["convert", str(tle), str(xml), "--to", "omm"]) == 0
    text = xml.read_text()
    assert text.count("<omm ") == 29 and text.count("<ndm ") == 1
    back = vv.read_catalog_file(xml)
    assert [s.satnum for s in back] == [s.satnum for s in sats]
    assert back.names == [f"OBJECT {s.satnum}" for s in sats]
    worst = []
    for a, b in zip(vv.read_catalog_file(tle), back, strict=True):  # the same SGP4 states
        t = a.epoch + np.array([-30.0, 0.0, 10.0, 95.0]) * u.min
        ra, rb = a.teme(t), b.teme(t)
        worst.append(np.abs(ra.r.to_value(u.km) - rb.r.to_value(u.km)).max())
        fa, fb = a.to_omm(), b.to_omm()
        fa["OBJECT_ID"] = fa["OBJECT_ID"] or "UNKNOWN"  # (a blank designator is written so)
        assert fa.keys() == fb.keys(), a.satnum  # every element, designator and name
        for key, value in fa.items():
            if isinstance(value, float):
                assert value == pytest.approx(fb[key], rel=1e-15, abs=0), (a.satnum, key)
            else:
                assert value == fb[key], (a.satnum, key)
    # not to the bit: sgp4 reads an OMM with other float steps than a TLE (the epoch as one
    # float of days since 1949, ~1e-12 day off the TLE's day fraction; rev/day / 720 * pi
    # against / (1440 / 2 pi)), as it does for one object: 7 objects of 29 give the same
    # states, the others differ by at most 4.1 mm over 95 min (median 1.5e-7 m; measured)
    assert max(worst) < 1e-5  # km: 1 cm
    # and back to TLE: the same file, every object
    again = tmp_path / "again.tle"
    assert cli.main(["convert", str(xml), str(again)]) == 0
    assert again.read_text() == tle.read_text()
    # KVN has no container for several OMMs: refused with the way out
    assert cli.main(["convert", str(tle), str(tmp_path / "cat.omm")]) == 2
    assert "XML <ndm> of OMMs" in capsys.readouterr().err
    # --satnum still picks one, as a bare OMM
    one = tmp_path / "one.xml"
    assert cli.main(["convert", str(tle), str(one), "--to", "omm", "--satnum", "11801"]) == 0
    assert "<ndm" not in one.read_text() and vv.read_omm(one)["NORAD_CAT_ID"] == 11801


def test_write_omm_ndm_names_a_bad_message():
    from visviva.ccsds.omm import write_omm_ndm

    good = vv.Satellite.from_tle(*ISS[1:], ISS[0]).to_omm()
    with pytest.raises(vv.InvalidInputError, match="OMM 1: .*BOGUS is not an OMM keyword"):
        write_omm_ndm([good, {**good, "BOGUS": 1}], originator="TEST")
    with pytest.raises(vv.InvalidInputError, match="at least one"):
        write_omm_ndm([])
