"""Catalogue numbers above sgp4's alpha-5 limit (339999): 6- to 9-digit NORAD_CAT_IDs, which
18 SDS publishes in OMMs only (visviva.satellites.catalog_numbers)."""

from __future__ import annotations

import csv
import json
import pickle
import re
import warnings

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from hypothesis import given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva.satellites.catalog_numbers import (
    ALPHA5_MAX,
    CATALOGUE_MAX,
    SGP4_PLACEHOLDER,
    catalogue_number,
    tle_number,
)

ISS = {"OBJECT_NAME": "ISS (ZARYA)", "OBJECT_ID": "1998-067A",
       "EPOCH": "2024-01-01T12:00:00.000000", "MEAN_MOTION": 15.4981535,
       "ECCENTRICITY": 0.0006703, "INCLINATION": 51.6416, "RA_OF_ASC_NODE": 247.4627,
       "ARG_OF_PERICENTER": 130.536, "MEAN_ANOMALY": 325.0288, "EPHEMERIS_TYPE": 0,
       "CLASSIFICATION_TYPE": "U", "NORAD_CAT_ID": 25544, "ELEMENT_SET_NO": 999,
       "REV_AT_EPOCH": 43000, "BSTAR": 0.0001027, "MEAN_MOTION_DOT": 0.00016717,
       "MEAN_MOTION_DDOT": 0.0}  # fmt: skip
#: one number per length, six to nine digits (the ranges 18 SDS assigns: Space Fence objects,
#: internal use 700,000,000+, uncorrelated tracks 900,000,000+)
BIG = [340000, 1234567, 12345678, 270000001 + 99999999, 900000123, CATALOGUE_MAX]


def _big(number, **more):
    return vv.Satellite.from_omm({**ISS, "NORAD_CAT_ID": number, **more})


def test_sgp4_itself_refuses_numbers_above_alpha5():
    # the reason the number is kept on visviva's side: sgp4.api.Satrec.sgp4init raises, and its
    # satnum is read-only (sgp4 2.x keeps the number in the TLE's five characters)
    from sgp4.api import WGS72, Satrec

    rec = Satrec()
    with pytest.raises(ValueError, match="339999"):
        rec.sgp4init(WGS72, "i", ALPHA5_MAX + 1, 25000.5, 1e-4, 0.0, 0.0, 0.001, 1.0, 0.9,
                     1.0, 0.06, 1.0)  # fmt: skip


@pytest.mark.parametrize("number", BIG)
def test_omm_with_a_large_number_propagates_bit_for_bit_as_a_five_digit_one(number):
    ref = vv.Satellite.from_omm(ISS)
    sat = _big(number)
    assert sat.satnum == number
    assert sat.satrec.satnum == SGP4_PLACEHOLDER
    t = np.linspace(-2.0, 5.0, 97) * u.day
    a, b = ref.teme(t), sat.teme(t)
    np.testing.assert_array_equal(a.r.to_value(u.km), b.r.to_value(u.km))
    np.testing.assert_array_equal(a.v.to_value(u.km / u.s), b.v.to_value(u.km / u.s))
    g1, g2 = ref.gcrs(t[:5]), sat.gcrs(t[:5])
    np.testing.assert_array_equal(g1.r.to_value(u.km), g2.r.to_value(u.km))


def test_catalog_batch_of_large_numbers_equals_the_five_digit_batch():
    numbers = [25544, 340000, 123456789, CATALOGUE_MAX]
    cat = vv.Catalog(_big(n, MEAN_ANOMALY=10.0 * k) for k, n in enumerate(numbers))
    ref = vv.Catalog(_big(25544, MEAN_ANOMALY=10.0 * k) for k in range(len(numbers)))
    np.testing.assert_array_equal(cat.satnums, numbers)
    t = Time("2024-01-02T00:00:00") + np.arange(30) * u.min
    a, b = cat.propagate(t), ref.propagate(t)
    np.testing.assert_array_equal(a.r.value, b.r.value)
    np.testing.assert_array_equal(a.v.value, b.v.value)
    back = pickle.loads(pickle.dumps(cat))  # Dask workers rebuild the satellites
    np.testing.assert_array_equal(back.satnums, numbers)


def test_large_number_survives_pickle_and_names_an_unnamed_satellite():
    fields = {k: v for k, v in ISS.items() if k != "OBJECT_NAME"}
    sat = vv.Satellite.from_omm({**fields, "NORAD_CAT_ID": 123456789})
    assert sat.name == "123456789"  # not sgp4's placeholder "00000"
    back = pickle.loads(pickle.dumps(sat))
    assert (back.satnum, back.name) == (123456789, "123456789")
    assert "satnum=123456789" in repr(sat)


def test_to_tle_refuses_a_number_no_tle_can_hold_and_says_to_write_an_omm():
    assert vv.Satellite.from_omm({**ISS, "NORAD_CAT_ID": ALPHA5_MAX}).to_tle()[0][2:7] == "Z9999"
    with pytest.raises(vv.InvalidInputError, match=r"340000 cannot be written in a TLE.*OMM"):
        _big(340000).to_tle()
    with pytest.raises(vv.InvalidInputError, match="to_omm"):
        tle_number(CATALOGUE_MAX)


@pytest.mark.parametrize("fmt", ["kvn", "xml"])
def test_omm_written_back_with_the_real_number(fmt, tmp_path):
    sat = _big(123456789)
    fields = sat.to_omm()
    assert fields["NORAD_CAT_ID"] == 123456789
    path = tmp_path / f"big.{fmt}"
    text = vv.write_omm(fields, path, format=fmt, originator="TEST")
    assert "123456789" in text
    back = vv.read_omm(path)
    assert back["NORAD_CAT_ID"] == 123456789
    again = vv.Satellite.from_omm(back)
    assert again.satnum == 123456789
    t = np.arange(0, 600, 60) * u.min
    np.testing.assert_array_equal(again.teme(t).r.value, sat.teme(t).r.value)
    # the catalogue reader tells KVN and XML OMMs from their content
    assert list(vv.read_catalog_file(path).satnums) == [123456789]


def test_omm_files_json_csv_xml_with_six_to_nine_digit_ids(tmp_path):
    records = [{**ISS, "NORAD_CAT_ID": n, "OBJECT_NAME": f"OBJ {n}"} for n in [25544] + BIG]
    (tmp_path / "gp.json").write_text(json.dumps(records))
    with open(tmp_path / "gp.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(ISS))
        writer.writeheader()
        writer.writerows(records)
    segments = "".join(
        vv.write_omm(vv.Satellite.from_omm(r).to_omm(), format="xml",
                     originator="TEST").split("\n", 1)[1] for r in records)
    (tmp_path / "gp.xml").write_text(f'<?xml version="1.0" encoding="UTF-8"?>\n<ndm>\n'
                                     f"{segments}</ndm>\n")
    for name in ("gp.json", "gp.csv", "gp.xml"):
        for cat in (vv.read_omm_file(tmp_path / name), vv.read_catalog_file(tmp_path / name)):
            np.testing.assert_array_equal(cat.satnums, [25544] + BIG, err_msg=name)


@pytest.mark.parametrize("bad, why", [
    (CATALOGUE_MAX + 1, "more than nine digits"), ("-5", "neither a catalogue number"),
    ("I0001", "alpha-5 number"), (True, "boolean"), (12.5, "neither a catalogue number")])
def test_ids_that_are_no_catalogue_number_are_refused(bad, why):
    with pytest.raises(vv.InvalidInputError, match=why):
        vv.Satellite.from_omm({**ISS, "NORAD_CAT_ID": bad})


def test_read_omm_names_the_line_of_a_bad_catalogue_number():
    text = vv.write_omm(vv.Satellite.from_omm(ISS).to_omm(), originator="TEST")
    lines = text.splitlines()
    k = next(i for i, line in enumerate(lines) if line.startswith("NORAD_CAT_ID"))
    lines[k] = "NORAD_CAT_ID = 1000000000"
    with pytest.raises(vv.CCSDSFormatError, match=f"line {k + 1}: .*more than nine digits"):
        vv.read_omm("\n".join(lines))


def test_fit_tle_with_a_nine_digit_number():
    iss = vv.Satellite.from_omm(ISS)
    states = iss.teme(np.linspace(0, 0.25, 20) * u.day)
    fit = vv.fit_tle(states, satnum=987654321, fit_bstar=False, bstar=ISS["BSTAR"])
    assert fit.satnum == 987654321
    assert fit.to_omm()["NORAD_CAT_ID"] == 987654321
    assert fit.fit.rms_position_km < 1e-3
    with pytest.raises(vv.InvalidInputError, match="OMM"):
        fit.to_tle()
    with pytest.raises(vv.InvalidInputError, match="1..999999999"):
        vv.fit_tle(states, satnum=CATALOGUE_MAX + 1)


def test_passes_screening_and_cdm_carry_the_real_number():
    a = vv.Satellite.from_omm(ISS)
    b = _big(900000123, OBJECT_NAME="TRACK", MEAN_ANOMALY=325.03)
    station = vv.GroundStation(48 * u.deg, 11 * u.deg)
    t0 = Time("2024-01-01T12:00:00")
    passes = vv.find_passes(vv.Catalog([a, b]), station, t0, t0 + 6 * u.h)
    assert set(passes["satnum"]) == {25544, 900000123}
    rows = vv.screen_conjunctions(a, b, t0, t0 + 2 * u.h, threshold=50 * u.km)
    assert len(rows) > 0 and set(rows["object2"]) == {"TRACK"}
    tca = rows["tca"][0]
    s1, s2 = a.gcrs(tca), b.gcrs(tca)
    cov = np.diag([100.0, 100.0, 100.0, 0.01, 0.01, 0.01])
    msg = vv.ConjunctionDataMessage.from_states(
        tca, s1.r, s1.v, cov, s2.r, s2.v, cov, names=(a.name, b.name),
        designators=(a.satnum, b.satnum))
    back = vv.read_cdm(msg.to_kvn())
    assert back.object2.designator == "900000123"


@settings(max_examples=40, deadline=None)
@given(number=st.integers(1, CATALOGUE_MAX))
def test_hypothesis_any_catalogue_number_round_trips_through_the_omm(number):
    sat = _big(number)
    assert sat.satnum == number == catalogue_number(str(number))
    back = vv.Satellite.from_omm(sat.to_omm())
    assert back.satnum == number
    assert back.satrec.satnum == (number if number <= ALPHA5_MAX else SGP4_PLACEHOLDER)
    np.testing.assert_array_equal(back.teme(90 * u.min).r.value, sat.teme(90 * u.min).r.value)
    if number <= ALPHA5_MAX:
        line1, line2 = sat.to_tle()
        assert vv.Satellite.from_tle(line1, line2).satnum == number


# -- the catalogue readers: missing files, duplicate and mixed ids --------------------------
@pytest.mark.parametrize("reader", ["read_tle_file", "read_omm_file", "read_catalog_file"])
def test_a_missing_file_names_the_path_and_is_still_a_file_not_found_error(reader, tmp_path):
    path = tmp_path / "gp.json"
    with pytest.raises(vv.MissingFileError, match="gp.json': no such file; .*download") as err:
        getattr(vv, reader)(path)
    assert isinstance(err.value, FileNotFoundError) and isinstance(err.value, vv.VisvivaError)
    assert err.value.filename == str(path) and err.value.errno == 2
    again = pickle.loads(pickle.dumps(err.value))  # (raised on a Dask worker, say)
    assert str(again) == str(err.value)
    with pytest.raises(vv.InvalidInputError, match="is a directory"):
        getattr(vv, reader)(tmp_path)


def test_the_same_object_twice_warns_and_latest_keeps_the_newest_set(tmp_path):
    later = {**ISS, "EPOCH": "2024-01-01T18:00:00.000000", "MEAN_ANOMALY": 100.0}
    other = {**ISS, "NORAD_CAT_ID": 123456789, "OBJECT_NAME": "OTHER"}
    path = tmp_path / "gp.json"
    path.write_text(json.dumps([later, other, ISS]))
    with pytest.warns(UserWarning, match=r"catalogue number 25544 \(2 element sets\) appears "
                                         r"more than once.*latest\(\)"):
        cat = vv.read_omm_file(path)
    assert list(cat.satnums) == [25544, 123456789, 25544]
    newest = cat.latest()
    assert list(newest.satnums) == [25544, 123456789]
    assert newest[0].epoch.isot == "2024-01-01T18:00:00.000"


def test_screening_two_sets_of_one_object_says_they_are_not_a_conjunction():
    iss = vv.Satellite.from_omm(ISS)
    refit = vv.fit_tle(iss.teme(np.linspace(0.25, 0.75, 30) * u.day), initial=iss,
                       fit_bstar=False, bstar=ISS["BSTAR"])  # the same orbit, a later epoch
    t0 = Time("2024-01-01T12:00:00")
    with pytest.warns(UserWarning, match="pair an object with itself .*25544"):
        rows = vv.screen_conjunctions(vv.Catalog([iss, refit]), None, t0, t0 + 3 * u.h)
    assert len(rows) > 0 and (rows["miss_distance"] < 1 * u.m).all()  # kept, not dropped
    assert len(vv.screen_conjunctions(vv.Catalog([iss, refit]).latest(), None, t0,
                                      t0 + 3 * u.h)) == 0


def test_mixed_alpha5_and_numeric_ids_are_one_number(tmp_path):
    path = tmp_path / "gp.json"
    path.write_text(json.dumps([{**ISS, "NORAD_CAT_ID": "A0001"},
                                {**ISS, "NORAD_CAT_ID": 100001, "OBJECT_NAME": "SAME"},
                                {**ISS, "NORAD_CAT_ID": "Z9999"}]))
    with pytest.warns(UserWarning, match="100001"):
        cat = vv.read_omm_file(path)
    assert list(cat.satnums) == [100001, 100001, 339999]
    tle = tmp_path / "gp.tle"
    tle.write_text("\n".join(cat[0].to_tle() + cat[2].to_tle()) + "\n")
    assert list(vv.read_tle_file(tle).satnums) == [100001, 339999]


_IDS = st.one_of(
    st.integers(0, 2 * CATALOGUE_MAX), st.integers(0, 2 * CATALOGUE_MAX).map(str),
    st.from_regex(r"[A-Z][0-9]{4}", fullmatch=True), st.text("0123456789AIO -.e", max_size=11))


def _omm_text(number, fmt):
    """One OMM (KVN or an XML <omm>) of ISS whose NORAD_CAT_ID is written as ``number``."""
    text = vv.write_omm(vv.Satellite.from_omm(ISS).to_omm(), format=fmt, originator="TEST")
    if fmt == "kvn":
        return text.replace("NORAD_CAT_ID         = 25544", f"NORAD_CAT_ID = {number}")
    return text.split("\n", 1)[1].replace("<NORAD_CAT_ID>25544<", f"<NORAD_CAT_ID>{number}<")


@settings(max_examples=60, deadline=None)
@given(ids=st.lists(_IDS, min_size=1, max_size=4),
       fmt=st.sampled_from(["json", "csv", "xml", "kvn"]))
def test_hypothesis_catalogue_readers_take_any_id_or_name_the_record(ids, fmt, tmp_path_factory):
    path = tmp_path_factory.mktemp("ids") / f"gp.{fmt}"
    records = [{**ISS, "NORAD_CAT_ID": n} for n in ids]
    if fmt == "json":
        path.write_text(json.dumps(records))
    elif fmt == "csv":
        with open(path, "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(ISS))
            writer.writeheader()
            writer.writerows(records)
    elif fmt == "kvn":  # Space-Track's KVN: one OMM after another
        path.write_text("".join(_omm_text(n, "kvn") for n in ids))
    else:  # CelesTrak's XML: an <ndm> of <omm>s
        body = "".join(_omm_text(n, "xml") for n in ids)
        path.write_text(f'<?xml version="1.0" encoding="UTF-8"?>\n<ndm>\n{body}</ndm>\n')
    expected = []
    for n in ids:
        try:
            expected.append(catalogue_number(n))
        except ValueError:
            expected.append(None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # duplicates
        if None in expected:
            k = expected.index(None) + 1
            with pytest.raises(vv.InvalidInputError, match=f"record {k} of .*NORAD_CAT_ID"):
                vv.read_omm_file(path)
            return
        cat = vv.read_omm_file(path)
    assert list(cat.satnums) == expected


@settings(max_examples=150, deadline=None)
@given(data=st.data())
def test_hypothesis_mutated_kvn_catalogue_reads_or_names_the_line(data, tmp_path_factory):
    """Space-Track-style KVN (two OMMs one after another) with lines deleted, duplicated,
    swapped, cut or lower-cased: read_catalog_file reads it or raises a visviva error that
    names the line (or says the file is empty)."""
    text = _omm_text(25544, "kvn") + _omm_text(123456789, "kvn")
    lines = text.split("\n")
    for _ in range(data.draw(st.integers(1, 3))):
        i = data.draw(st.integers(0, len(lines) - 1))
        op = data.draw(st.integers(0, 4))
        if op == 0:
            del lines[i]
        elif op == 1:
            lines.insert(i, lines[data.draw(st.integers(0, len(lines) - 1))])
        elif op == 2:
            j = data.draw(st.integers(0, len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
        elif op == 3:
            lines[i] = lines[i][:data.draw(st.integers(0, len(lines[i])))]
        else:
            lines[i] = lines[i].lower()
        if not lines:
            break
    path = tmp_path_factory.mktemp("kvn") / "gp.kvn"
    path.write_text("\n".join(lines))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            cat = vv.read_catalog_file(path)
    except vv.VisvivaError as exc:
        assert re.search(r"line \d+", str(exc)) or "empty" in str(exc), str(exc)
        return
    assert all(np.isfinite(s.teme(0 * u.min).r.value).all() for s in cat)
    assert set(cat.satnums) <= {25544, 123456789}


def test_read_omm_on_many_messages_points_to_the_catalogue_reader():
    one = _omm_text(25544, "kvn")
    k = one.count("\n") + 1  # the line where the second message starts
    with pytest.raises(vv.CCSDSFormatError, match=f"line {k}: a second OMM starts here.*"
                                                  r"vv\.read_omm_file"):
        vv.read_omm(one + _omm_text(123456789, "kvn"))


def test_convert_of_a_many_omm_kvn_file_writes_all_or_the_one_picked(tmp_path, capsys):
    from visviva.cli import main

    path = tmp_path / "gp.kvn"
    path.write_text(_omm_text(25544, "kvn") + _omm_text(123456789, "kvn"))
    # a whole catalogue is converted since leftfix8: a TLE file cannot hold the nine-digit
    # number, and a KVN OMM holds one message (an XML <ndm> holds both)
    assert main(["convert", str(path), str(tmp_path / "x.tle")]) == 2
    assert "123456789 cannot be written in a TLE" in capsys.readouterr().err
    assert main(["convert", str(path), str(tmp_path / "x.omm")]) == 2
    err = capsys.readouterr().err
    assert "holds 2 element sets and a KVN OMM holds one" in err and "--satnum" in err
    assert main(["convert", str(path), str(tmp_path / "all.xml"), "--to", "omm"]) == 0
    assert list(vv.read_catalog_file(tmp_path / "all.xml").satnums) == [25544, 123456789]
    out = tmp_path / "big.omm"
    assert main(["convert", str(path), str(out), "--satnum", "123456789"]) == 0
    assert vv.read_omm(out)["NORAD_CAT_ID"] == 123456789
    assert main(["convert", str(path), str(tmp_path / "big.tle"), "--satnum", "123456789"]) == 2
    assert "cannot be written in a TLE" in capsys.readouterr().err


# -- ninth session: the CCSDS readers' missing files, KVN keyword lines, CLI warnings ---------
@pytest.mark.parametrize("reader", ["read_omm", "read_oem", "read_opm", "read_cdm"])
def test_ccsds_readers_raise_missing_file_error_like_the_catalogue_readers(reader, tmp_path):
    # they raised CCSDSFormatError("no such file"), not a FileNotFoundError
    path = tmp_path / "msg.kvn"
    with pytest.raises(vv.MissingFileError, match="msg.kvn': no such file; .*message text") as err:
        getattr(vv, reader)(path)
    assert isinstance(err.value, FileNotFoundError) and err.value.filename == str(path)
    with pytest.raises(vv.CCSDSFormatError, match="is a directory"):
        getattr(vv, reader)(tmp_path)


@pytest.mark.parametrize("key, bad", [("ECCENTRICITY", "1.5"), ("INCLINATION", "nan"),
                                      ("EPOCH", "2024-13-01T00:00:00"), ("NORAD_CAT_ID", "x")])
def test_a_bad_value_in_a_kvn_catalogue_names_its_own_line(key, bad, tmp_path):
    # it named the line where its OMM starts (28 here), not the keyword's
    lines = (_omm_text(25544, "kvn") + _omm_text(123456789, "kvn")).split("\n")
    start = max(i for i, line in enumerate(lines) if line.startswith("CCSDS_OMM_VERS")) + 1
    k = max(i for i, line in enumerate(lines) if line.split("=")[0].strip() == key)
    lines[k] = f"{key} = {bad}"
    path = tmp_path / "gp.kvn"
    path.write_text("\n".join(lines))
    with pytest.raises(vv.InvalidInputError, match=rf"record 2 of .*gp.kvn, line {k + 1} "
                                                   rf"\({key}; the OMM starts on line {start}\)"):
        vv.read_catalog_file(path)


def test_cli_commands_print_warnings_as_one_clean_line(tmp_path, capsys):
    # they printed Python's "file.py:65: UserWarning: ..." and the source line after it
    from visviva.cli import main

    path = tmp_path / "gp.kvn"
    path.write_text(_omm_text(25544, "kvn") * 2)
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        assert main(["convert", str(path), str(tmp_path / "x.omm"), "--satnum", "25544"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert any("pick one" in line for line in err)
    warned = [line for line in err if "appears more than once" in line]
    assert len(warned) == 1 and warned[0].startswith("visviva: warning: ")
    assert not any("UserWarning" in line or ".py:" in line for line in err), err
    # a warning from outside visviva keeps its category, still on one line
    from visviva.cli import _show_warning

    _show_warning(RuntimeWarning("overflow\nin exp"), RuntimeWarning, np.__file__, 1)
    assert capsys.readouterr().err == "visviva: warning: RuntimeWarning: overflow in exp\n"
