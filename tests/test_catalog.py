"""Catalogue files and N x T batch propagation (SGP4 via SatrecArray, Kepler, secular J2)."""

from __future__ import annotations

import importlib.resources
import re
import warnings

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv
from visviva.satellites.catalog import (
    Catalog,
    parse_tle_text,
    propagate_j2_batch,
    propagate_kepler_batch,
    propagate_sgp4_batch,
    read_tle_file,
)
from visviva.satellites.tle import SGP4Error, TLEFormatError

ONE_MM = 1e-6  # km

ISS_1 = "1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927"
ISS_2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537"


def _verification_text():
    """The SGP4 verification TLEs shipped with sgp4, without comments and extra columns."""
    text = (importlib.resources.files("sgp4") / "SGP4-VER.TLE").read_text()
    lines = [ln[:69] if ln.startswith("2 ") else ln for ln in text.splitlines()]
    return "\n".join(ln for ln in lines if not ln.startswith("#"))


@pytest.fixture(scope="module")
def catalog():
    return parse_tle_text(_verification_text(), verify_checksum=False)


@pytest.fixture(scope="module")
def times():
    return Time("2006-06-25T00:00:00", scale="utc") + np.linspace(-0.3, 1.0, 17) * u.day


def test_reads_two_and_three_line_files(tmp_path, catalog):
    three = tmp_path / "three.txt"
    three.write_text("ISS (ZARYA)\n" + ISS_1 + "\n" + ISS_2 + "\n\n0 SECOND ISS\n" + ISS_1
                     + "\n" + ISS_2 + "\n")
    cat = read_tle_file(three)
    assert len(cat) == 2 and cat.names == ["ISS (ZARYA)", "SECOND ISS"]
    assert cat["SECOND ISS"].satnum == 25544
    assert len(catalog) == 33 and catalog.names[0] == "00005"
    with open(three) as f:
        assert len(read_tle_file(f)) == 2


def test_names_survive_any_encoding(tmp_path):
    # names were read as ASCII with '?' marks for every other byte, and a byte-order mark
    # became part of the first name
    body = ISS_1 + "\n" + ISS_2 + "\n"
    cases = [("КОСМОС 2251", "utf-8"), ("ISS (ZARYA)", "utf-8-sig"), ("SAT é", "latin-1")]
    for name, encoding in cases:
        path = tmp_path / f"{encoding}.txt"
        path.write_bytes((name + "\n" + body).encode(encoding))
        assert read_tle_file(path).names == [name]
    path = tmp_path / "bad.txt"
    path.write_text("X\n" + ISS_1.replace("98067A", "98067\u00c5") + "\n" + ISS_2 + "\n",
                    encoding="utf-8")
    with pytest.raises(TLEFormatError, match="line 2 of .*non-ASCII character 'Å' in column 15"):
        read_tle_file(path)


@pytest.mark.parametrize(
    "text, needle",
    [
        ("NAME\n" + ISS_1 + "\n" + ISS_2[:-1] + "0\n", "line 3 of"),
        (ISS_1 + "\n" + ISS_2 + "\n" + ISS_1 + "\nGARBAGE\n", "line 4 of"),
        (ISS_1 + "\n" + ISS_2 + "\n" + ISS_2 + "\n", "line 3 of"),
        ("A\nB\n" + ISS_1 + "\n" + ISS_2 + "\n", "line 2 of"),
        (ISS_1[:50] + "\n" + ISS_2 + "\n", "line 1 of"),
    ],
)
def test_bad_line_is_named_by_number(tmp_path, text, needle):
    path = tmp_path / "bad.txt"
    path.write_text(text)
    with pytest.raises(TLEFormatError) as info:
        read_tle_file(path)
    assert needle in str(info.value) and "bad.txt" in str(info.value)


def test_sgp4_batch_equals_per_satellite_bit_for_bit(catalog, times):
    batch = propagate_sgp4_batch(catalog, times, on_error="nan")
    assert batch.r.shape == (33, 17, 3) and batch.status.shape == (33, 17)
    for i, sat in enumerate(catalog):
        if batch.status[i].any():
            with pytest.raises(SGP4Error):
                sat.teme(times)
            continue
        one = sat.teme(times)
        np.testing.assert_array_equal(batch.r[i].value, one.r.value)
        np.testing.assert_array_equal(batch.v[i].value, one.v.value)


def test_sgp4_batch_errors_raise_or_report(catalog, times):
    with pytest.raises(SGP4Error) as info:
        propagate_sgp4_batch(catalog, times)
    assert info.value.satellite in catalog.names
    assert info.value.satellite in str(info.value)
    batch = propagate_sgp4_batch(catalog, times, on_error="nan")
    bad = batch.status != 0
    assert bad.any() and np.isnan(batch.r.value[bad]).all()
    assert np.isfinite(batch.r.value[~bad]).all()


def test_sgp4_batch_needs_absolute_times(catalog):
    with pytest.raises(vv.UnitsError, match="absolute times"):
        propagate_sgp4_batch(catalog, np.arange(3) * u.min)


def test_catalog_gcrs_equals_satellite_gcrs(catalog, times):
    cat = catalog[:3]
    batch = cat.propagate(times, frame="gcrs")
    for i, sat in enumerate(cat):
        g = sat.gcrs(times)
        assert np.abs((batch.r[i] - g.r).to_value(u.km)).max() < ONE_MM
        assert np.abs((batch.v[i] - g.v).to_value(u.km / u.s)).max() < 1e-9


def test_kepler_batch_conserves_energy_and_starts_at_sgp4(catalog):
    cat = Catalog([catalog[i] for i in range(6)])
    t = cat.epochs[0] + np.linspace(-2, 2, 9) * u.day
    k = propagate_kepler_batch(cat, t)
    r, v = k.r.to_value(u.km), k.v.to_value(u.km / u.s)
    gm = np.array([s.satrec.mu for s in cat])[:, None]
    energy = 0.5 * np.sum(v * v, -1) - gm / np.linalg.norm(r, axis=-1)
    h = np.cross(r, v)
    assert np.abs(energy / energy[:, :1] - 1).max() < 1e-12
    assert np.abs(h - h[:, :1]).max() / np.abs(h).max() < 1e-12
    # at each epoch the two-body state is the SGP4 (osculating TEME) state
    for i, sat in enumerate(cat):
        k0 = propagate_kepler_batch(cat[i : i + 1], sat.epoch)
        np.testing.assert_allclose(k0.r[0, 0].value, sat.teme(0 * u.s).r.value, rtol=0,
                                   atol=ONE_MM)


def test_kepler_batch_refuses_what_two_body_motion_cannot_carry():
    # propagate_kepler_batch took ITRS states as inertial (thousands of km off within the hour,
    # where sat.itrs(t).propagate refuses), flew through an OPM state's manoeuvres, and
    # labelled TOD states "gcrs" (audit13)
    from visviva._containers import PENDING_MANEUVERS_ATTRIBUTE
    from visviva.satellites.satellite_states import framed_states

    sat = vv.Satellite.from_tle(ISS_1, ISS_2)
    t0 = sat.epoch
    times = t0 + [0, 600] * u.s
    with pytest.raises(vv.InvalidInputError, match="ITRS rotates with the Earth"):
        propagate_kepler_batch(sat.itrs(t0 + [0, 1] * u.s), times)
    teme = sat.teme(t0 + [0, 1] * u.s)
    batch = propagate_kepler_batch(teme, times)
    assert batch.frame == "teme"
    # (the batch's offsets come from Time differences: equal to ~1e-12 s)
    np.testing.assert_allclose(batch.r[0, 1].value, teme[0].propagate(600 * u.s).r.value,
                               rtol=0, atol=ONE_MM * 1e-3)
    pending = vv.StateVectors(teme.r, teme.v, teme.gm, epoch=teme.epoch)
    setattr(pending, PENDING_MANEUVERS_ATTRIBUTE, 2)  # as an OPM's state carries it
    with pytest.raises(vv.InvalidInputError, match=r"2 manoeuvre\(s\).*propagate_kepler_batch"):
        propagate_kepler_batch(pending, times)
    tod = framed_states(teme.r.value, teme.v.value, 398600.4418, teme.epoch, "TOD",
                        foreign="TOD")
    assert propagate_kepler_batch(tod, times).frame == "tod"
    assert propagate_kepler_batch(vv.StateVectors(teme.r, teme.v, teme.gm, epoch=teme.epoch),
                                  times).frame == "gcrs"  # plain states are taken as GCRS


def test_j2_batch_tracks_sgp4_for_a_day():
    pytest.importorskip("visviva.satellites.secular")
    cat = Catalog([vv.Satellite.from_tle(ISS_1, ISS_2)])
    t = cat.epochs[0] + np.linspace(0, 1, 25) * u.day
    j2 = propagate_j2_batch(cat, t)
    sg = propagate_sgp4_batch(cat, t)
    # mean elements used as osculating (~10 km short-period terms), no drag: 13 km over a day
    assert np.linalg.norm((j2.r - sg.r).to_value(u.km), axis=-1).max() < 30.0
    assert np.isfinite(j2.r.value).all()


def test_j2_batch_refuses_a_decayed_satellite():
    # mean motion 17.6 rev/day: mean perigee 6237 km, inside the Earth; SGP4 says "decayed"
    # (error 6) but the secular batch returned positions 140 km underground as numbers
    line1 = "1 99999U          21067.00000000  .00000000  00000-0  00000+0 0    03"
    line2 = "2 99999  51.5662   0.0000 0010000   0.0000   0.0000 17.60000000    07"
    with pytest.warns(vv.errors.SubsurfacePerigeeWarning, match="140.8 km below"):
        sat = vv.Satellite.from_tle(line1, line2)
    with pytest.raises(vv.InvalidInputError, match="99999.*decayed"):
        propagate_j2_batch(Catalog([sat]), sat.epoch)


def test_j2_batch_with_nan_keeps_the_catalogue_beside_a_decayed_satellite():
    # on_error="nan" had refused the whole catalogue for one decayed member (and the pass
    # search fell back to SGP4 for every satellite); now that member alone is NaN, status 9
    from visviva.core.status import HITS_ATTRACTOR

    line1 = "1 99999U          21067.00000000  .00000000  00000-0  00000+0 0    03"
    line2 = "2 99999  51.5662   0.0000 0010000   0.0000   0.0000 17.60000000    07"
    with pytest.warns(vv.errors.SubsurfacePerigeeWarning):
        dead = vv.Satellite.from_tle(line1, line2)
    iss = vv.Satellite.from_tle(ISS_1, ISS_2)
    t = iss.epoch + np.linspace(0, 3, 4) * u.hour
    alone = propagate_j2_batch(Catalog([iss]), t)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vv.StaleElementSetWarning)  # the 2021 set
        both = propagate_j2_batch(Catalog([iss, dead]), t, on_error="nan")
        with pytest.raises(vv.InvalidInputError, match="99999.*decayed.*on_error='nan'"):
            propagate_j2_batch(Catalog([iss, dead]), t)
    assert np.array_equal(both.r[0].value, alone.r[0].value)  # the ISS untouched, bit for bit
    assert (both.status[0] == 0).all() and (both.status[1] == HITS_ATTRACTOR).all()
    assert np.isnan(both.r[1].value).all() and np.isnan(both.v[1].value).all()


def test_j2_batch_equals_the_secular_theory_of_visviva_satellites_secular(catalog):
    from visviva.satellites.secular import propagate_j2_secular
    from visviva.satellites.secular_batch import _mean_elements, _wgs72_body

    cat = Catalog([catalog[i] for i in (0, 2, 3, 7)])  # LEO and deep-space, e up to 0.69
    a, ecc, inc, raan, argp, M = _mean_elements([s.satrec for s in cat])
    body = _wgs72_body(cat[0].satrec)
    dt = np.array([-3600.0, 0.0, 5400.0, 86400.0])
    for i, sat in enumerate(cat):
        nu = vv.mean_to_true(M[i], ecc[i])
        nu = nu.to_value(u.rad) if hasattr(nu, "unit") else float(nu)
        el = vv.KeplerianElements.from_semi_major_axis(
            a[i] * u.km, ecc[i], inc[i], raan[i], argp[i], nu, body.gm
        )
        ref = propagate_j2_secular(el, dt * u.s, body).to_state()
        ours = propagate_j2_batch(cat[i : i + 1], sat.epoch + dt * u.s)
        assert np.abs((ours.r[0] - ref.r).to_value(u.km)).max() < ONE_MM
        assert np.abs((ours.v[0] - ref.v).to_value(u.km / u.s)).max() < 1e-9


def test_read_omm_json_and_csv_equal_the_tles(tmp_path, catalog):
    import csv
    import json

    from sgp4.exporter import export_omm

    from visviva.satellites.catalog import read_omm_file

    sats = [catalog[i] for i in (0, 2, 3)]
    records = [export_omm(s.satrec, s.name) for s in sats]
    (tmp_path / "gp.json").write_text(json.dumps(records))
    with open(tmp_path / "gp.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(records[0]))
        writer.writeheader()
        writer.writerows(records)
    t = Time("2006-06-25T00:00:00", scale="utc") + np.linspace(0, 1, 5) * u.day
    ref = propagate_sgp4_batch(Catalog(sats), t)
    for name in ("gp.json", "gp.csv"):
        cat = read_omm_file(tmp_path / name)
        assert cat.names == [s.name for s in sats]
        out = propagate_sgp4_batch(cat, t)
        # OMM epochs are written to the microsecond: agree to well below a metre
        assert np.abs((out.r - ref.r).to_value(u.km)).max() < 1e-3
    # a byte-order mark: JSON failed and the CSV's first column (OBJECT_NAME) was lost
    for name in ("gp.json", "gp.csv"):
        text = (tmp_path / name).read_text()
        (tmp_path / f"bom-{name}").write_text(text, encoding="utf-8-sig")
        assert read_omm_file(tmp_path / f"bom-{name}").names == [s.name for s in sats]
    (tmp_path / "cut.json").write_text(json.dumps(records)[:300])
    with pytest.raises(vv.InvalidInputError, match=r"cut.json, line 1, column \d+: not valid JSON"):
        read_omm_file(tmp_path / "cut.json")
    (tmp_path / "cut.xml").write_text("<ndm><omm>\n<body>")
    with pytest.raises(vv.InvalidInputError, match="cut.xml, line 2: the XML is not well formed"):
        read_omm_file(tmp_path / "cut.xml")
    records[1].pop("MEAN_MOTION")
    (tmp_path / "bad.json").write_text(json.dumps(records))
    with pytest.raises(vv.InvalidInputError, match="record 2 of"):
        read_omm_file(tmp_path / "bad.json")


def test_sgp4_batch_writes_into_given_arrays(catalog, times):
    cat = catalog[:3]
    ref = propagate_sgp4_batch(cat, times)
    status = np.empty((3, 17), np.uint8)
    r = np.empty((3, 17, 3))
    v = np.empty((3, 17, 3))
    out = propagate_sgp4_batch(cat, times, out=(status, r, v))
    assert np.shares_memory(out.r.value, r)
    np.testing.assert_array_equal(r, ref.r.value)
    np.testing.assert_array_equal(v, ref.v.value)
    with pytest.raises(vv.ShapeError):
        propagate_sgp4_batch(cat, times, out=(status, r[:, ::2], v))


def test_out_of_range_elements_in_files_name_the_line_or_record(tmp_path):
    """ROBUSTNESS_BUGS #3/#4: a valid checksum does not make a day 400 or a 200 deg inclination."""
    import json

    from sgp4.exporter import export_omm

    from visviva.satellites.catalog import read_omm_file

    def checksum(line):
        return line[:68] + str(sum(int(c) if c.isdigit() else c == "-" for c in line[:68]) % 10)

    bad_2 = checksum(ISS_2[:8] + "200.0000" + ISS_2[16:])
    with pytest.raises(TLEFormatError, match="line 4 of .*inclination"):
        parse_tle_text(ISS_1 + "\n" + ISS_2 + "\n" + ISS_1 + "\n" + bad_2 + "\n")
    bad_1 = checksum(ISS_1[:20] + "400" + ISS_1[23:])
    with pytest.raises(TLEFormatError, match="line 1 of .*day of year"):
        parse_tle_text(bad_1 + "\n" + ISS_2 + "\n")
    good = export_omm(vv.Satellite.from_tle(ISS_1, ISS_2).satrec, "ISS")
    (tmp_path / "gp.json").write_text(json.dumps([good, {**good, "MEAN_MOTION": -15.7}]))
    with pytest.raises(vv.InvalidElementsError, match="record 2 of .*MEAN_MOTION"):
        read_omm_file(tmp_path / "gp.json")


def test_a_catalogue_travels_once_per_process():
    """Pickled catalogues (Dask tasks) carry one payload and a content token: a process that
    has unpickled the same content reuses that catalogue and its SatrecArray."""
    import pickle

    from visviva.satellites.catalog import _UNPICKLED, Catalog

    iss = vv.Satellite.from_tle(
        "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
        "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340", name="ISS")
    cat = Catalog([iss, iss])
    _UNPICKLED.clear()
    first = pickle.loads(pickle.dumps(cat))
    arr = first.satrec_array
    again = pickle.loads(pickle.dumps(Catalog([iss, iss])))  # equal content, new object
    assert again is first and again.satrec_array is arr
    assert first.names == ["ISS", "ISS"] and first is not cat
    other = pickle.loads(pickle.dumps(Catalog([iss])))
    assert other is not first and len(other) == 1
    t = iss.epoch + np.arange(3) * u.min
    np.testing.assert_array_equal(first.propagate(t).r.value, cat.propagate(t).r.value)


def test_a_kvn_omm_file_is_read_one_message_or_many(tmp_path):
    # vv.write_omm writes KVN by default; read_omm_file said only "pass format='json', 'csv' or
    # 'xml'", then pointed to vv.read_omm (one message). Space-Track's KVN GP data holds many
    # OMMs one after another (the only text format besides JSON/CSV/XML that carries the
    # 6-9 digit catalogue numbers): read_omm_file and read_catalog_file read them all
    from visviva.satellites.catalog import read_omm_file

    sat = vv.Satellite.from_tle(
        "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
        "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340", name="ISS")
    path = tmp_path / "iss.omm"
    vv.write_omm(sat.to_omm(), path, originator="TEST")
    assert read_omm_file(path)[0].to_tle() == sat.to_tle()
    assert vv.Catalog.from_omm([vv.read_omm(path)])[0].to_tle() == sat.to_tle()
    other = vv.Satellite.from_omm({**sat.to_omm(), "NORAD_CAT_ID": 123456789, "OBJECT_NAME": "X"})
    many = tmp_path / "gp.kvn"
    many.write_text(path.read_text() + vv.write_omm(other.to_omm(), originator="TEST"))
    for cat in (read_omm_file(many), vv.read_catalog_file(many)):
        assert list(cat.satnums) == [25544, 123456789] and cat.names == ["ISS", "X"]
    broken = tmp_path / "broken.kvn"
    lines = many.read_text().splitlines()
    k = max(i for i, line in enumerate(lines) if line.startswith("MEAN_MOTION "))
    broken.write_text("\n".join(lines[:k + 1] + [lines[k]] + lines[k + 1:]))
    start = max(i for i, line in enumerate(lines) if line.startswith("CCSDS_OMM_VERS")) + 1
    with pytest.raises(vv.InvalidInputError, match=f"line {k + 2}: MEAN_MOTION appears twice "
                                                   f"in the OMM that starts on line {start}"):
        read_omm_file(broken)


def test_sgp4_batch_nan_mode_leaves_no_decayed_state_with_numbers():
    """sgp4 fills a decayed object's states (code 6) with points below the surface; with
    on_error="nan" they were returned as numbers, 4500 km inside the Earth (audit of
    2026-11-26): every state whose status is not 0 is NaN, in every frame."""
    iss = vv.Satellite.from_tle(ISS_1, ISS_2)
    line1 = ISS_1[:53] + " 50000-1" + ISS_1[61:]  # B* = 0.05: decays within days
    line1 = line1[:68] + str(sum(int(c) if c.isdigit() else c == "-" for c in line1[:68]) % 10)
    falling = vv.Satellite.from_tle(line1, ISS_2, name="FALLING")
    cat = Catalog([iss, falling])
    t = iss.epoch + np.linspace(0, 20, 21) * u.day
    with pytest.raises(vv.SatelliteDecayedError):
        propagate_sgp4_batch(cat, t)
    for frame in ("teme", "gcrs", "itrs"):
        batch = cat.propagate(t, frame=frame, on_error="nan")
        bad = batch.status != 0
        assert (batch.status[1] == 6).sum() >= 3 and not bad[0].any()
        assert np.isnan(batch.r.value[bad]).all() and np.isnan(batch.v.value[bad]).all()
        assert np.isfinite(batch.r.value[~bad]).all() and np.isfinite(batch.v.value[~bad]).all()
        good = ~bad[1]  # the states before the decay are sgp4's, unchanged
        ref = getattr(falling, frame)(t[good])
        np.testing.assert_allclose(batch.r.value[1][good], ref.r.to_value(u.km), rtol=0,
                                   atol=ONE_MM)


@pytest.mark.parametrize("fmt", ["kvn", "xml"])
@pytest.mark.parametrize(("key", "good", "bad", "value"), [
    ("INCLINATION", "deg", "rad", "0.9013"),
    ("MEAN_MOTION", "rev/day", "rad/s", "0.0011271"),
])
def test_omm_file_with_another_unit_is_refused_not_misread(tmp_path, fmt, key, good, bad, value):
    """read_omm_file / read_catalog_file dropped a KVN '[unit]' (and an XML units= attribute)
    unread, so 'INCLINATION = 0.9013 [rad]' became 0.9013 deg, while vv.read_omm refuses it
    (audit of 2026-11-26). The standard's own unit, in any spelling, still reads."""
    sat = vv.Satellite.from_tle(ISS_1, ISS_2)
    text = vv.write_omm(sat.to_omm(), None, fmt, originator="AUDIT")
    if fmt == "kvn":
        lines = [f"{key} = {value} [{bad}]" if ln.startswith(key + " ") else ln
                 for ln in text.splitlines()]
        ok = text.replace(f"[{good}]", f"[{good.upper()}]")
    else:
        lines = [f'<{key} units="{bad}">{value}</{key}>' if f"<{key} " in ln else ln
                 for ln in text.splitlines()]
        ok = text
    path = tmp_path / f"bad.{fmt}"
    path.write_text("\n".join(lines) + "\n")
    for reader in (vv.read_omm_file, vv.read_catalog_file):
        with pytest.raises(vv.InvalidInputError, match=rf"{key} must be in \[{good}\], not "
                                                       rf"\[{re.escape(bad)}\]"):
            reader(path)
    with pytest.raises(Exception, match=rf"\[{re.escape(bad)}\]"):  # the CCSDS reader agrees
        vv.read_omm(path)
    path.write_text(ok)
    again = vv.read_omm_file(path)[0]
    t = np.arange(3) * u.h
    np.testing.assert_array_equal(again.teme(t).r.value, sat.teme(t).r.value)


def test_omm_unit_table_is_the_ccsds_readers():
    from visviva.ccsds.omm import SECTIONS
    from visviva.satellites.catalog_files import OMM_UNITS

    ccsds = {k.name: k.unit for section in SECTIONS for k in section.keywords
             if k.unit and section.name != "covariance"}
    assert ccsds == OMM_UNITS


def test_kepler_batch_refuses_states_on_more_than_one_axis_with_a_shape_error():
    # (2, 3) states were flattened to six while their (2, 3) epochs stayed: numpy's "input
    # operand has more dimensions than allowed by the axis remapping" from deep inside
    from visviva.errors import ShapeError

    epoch = Time("2024-01-01", scale="utc") + np.arange(3) * u.h
    el = vv.KeplerianElements(np.full((2, 3), 7000.0) * u.km, 0.1, 0.5, 0.1, 0.2,
                              np.linspace(-3, 3, 6).reshape(2, 3), vv.EARTH, epoch=epoch)
    t = Time("2024-01-02", scale="utc") + np.arange(4) * u.h
    with pytest.raises(ShapeError, match="one axis"):
        propagate_kepler_batch(el.to_state(), t)
    flat = el[0].to_state()  # (3,) states with (3,) epochs: the documented form still works
    out = propagate_kepler_batch(flat, t)
    one = flat[2].propagate((t - epoch[2]).to(u.s))
    np.testing.assert_allclose(out.r[2].to_value(u.km), one.r.to_value(u.km), rtol=0, atol=1e-6)


def test_sgp4_batch_warns_once_naming_stale_element_sets():
    """propagate_sgp4_batch (and Catalog.propagate) ran element sets any distance from their
    epochs without a word, while Satellite.teme and find_passes warned: one warning per call
    now, naming the stalest sets, pointing at the caller."""
    import warnings

    iss = vv.Satellite.from_tle(
        "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
        "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340", name="ISS")
    unnamed = vv.Satellite.from_tle(
        "1 25544U 98067A   24100.50000000  .00016717  00000-0  10270-3 0  9009",
        "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340")
    t = iss.epoch + np.array([0.0, 10.0, 20.0]) * u.day
    with warnings.catch_warnings():
        warnings.simplefilter("error", vv.StaleElementSetWarning)
        propagate_sgp4_batch([iss], t)  # within 30 days: quiet
    with pytest.warns(vv.StaleElementSetWarning) as rec:
        propagate_sgp4_batch([iss, unnamed], t)
    ours = [w for w in rec if w.category is vv.StaleElementSetWarning]
    assert len(ours) == 1 and ours[0].filename == __file__
    assert ("1 of 2 element set(s) lie more than 30 days from the requested times (up to 99 "
            "days: 25544 (99 d))") in str(ours[0].message)


def test_sgp4_batch_flags_or_refuses_positions_beyond_any_earth_orbit(catalog, times):
    """Satellite.teme refused an SGP4 position more than 1e6 km from the geocentre (no Earth
    orbit: SGP4 far outside its span); propagate_sgp4_batch and Catalog.propagate returned it
    with status 0: 29141 of the verification set, six to seven days past its epoch, came back
    4e9 to 2.3e10 km away between sgp4's error-1 states. Now status 100
    (SGP4_BEYOND_EARTH_ORBIT) and NaN, or the typed error naming the satellite and the time."""
    from visviva.core import status as core_status
    from visviva.satellites.tle_checks import (
        MAX_SGP4_RADIUS_KM,
        SGP4_BEYOND_EARTH_ORBIT,
        sgp4_times,
    )

    # the code collides with none of sgp4's (1-6) nor visviva.core.status's
    core_codes = {v for k, v in vars(core_status).items() if k.isupper() and isinstance(v, int)}
    assert SGP4_BEYOND_EARTH_ORBIT not in set(range(7)) | core_codes
    k = catalog.names.index("29141")
    one = Catalog([catalog[k]])
    e, r, _ = one.satrec_array.sgp4(*sgp4_times(times, 0.0, 0.0)[:2])  # sgp4 itself
    far = (e[0] == 0) & (np.linalg.norm(r[0], axis=-1) > MAX_SGP4_RADIUS_KM)
    assert far.sum() == 8 and ((e[0] != 0) | far).all()
    for batch in (propagate_sgp4_batch(catalog, times, on_error="nan"),
                  catalog.propagate(times, on_error="nan")):
        row = batch.status[k]
        assert (row[far] == SGP4_BEYOND_EARTH_ORBIT).all()
        assert (row[~far] == e[0][~far]).all()  # sgp4's own codes kept
        assert np.isnan(batch.r.value[k][far]).all() and np.isnan(batch.v.value[k][far]).all()
    with pytest.raises(SGP4Error, match=r"4\.139e\+09 km from the geocentre for satellite "
                       r"'29141' at 2006-06-24T16:48:00\.000 UTC") as info:
        propagate_sgp4_batch(one, times)
    assert info.value.code == SGP4_BEYOND_EARTH_ORBIT
    assert info.value.reason == "position beyond any Earth orbit"
    with pytest.raises(SGP4Error, match="beyond any Earth orbit"):  # the single path agrees
        catalog[k].teme(times[:1])


def test_stale_warning_of_catalogue_calls_points_at_the_users_line():
    """Catalog.propagate's StaleElementSetWarning pointed at catalog.py (the fixed stacklevel
    of propagate_sgp4_batch, one frame short), ground_track's and eclipse_fraction's at
    groundtrack.py: now at the caller, the first frame outside visviva."""
    import warnings

    from visviva.satellites.groundtrack import eclipse_fraction, ground_track

    iss = vv.Satellite.from_tle(
        "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
        "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340", name="ISS")
    cat = Catalog([iss])
    t = Time("2024-06-01T00:00:00", scale="utc") + np.arange(3) * u.min  # 152 days out
    calls = (lambda: cat.propagate(t), lambda: cat.propagate(t, frame="gcrs"),
             lambda: ground_track(iss, t), lambda: ground_track(cat, t),
             lambda: eclipse_fraction(iss, t))
    for call in calls:
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            call()
        stale = [x for x in w if issubclass(x.category, vv.StaleElementSetWarning)]
        assert len(stale) == 1 and stale[0].filename == __file__, stale[0].filename


def test_j2_and_kepler_batches_warn_of_stale_element_sets_at_the_users_line():
    """Catalog.propagate(method="j2"|"kepler"), propagate_j2_batch and propagate_kepler_batch
    ran element sets any distance from their epochs without a word (the SGP4 batch warned),
    though both start from SGP4 at each epoch: one warning per call now, at the caller's line.
    A pass search, which runs the J2 batch inside and warns over its window, still warns once."""
    import warnings

    iss = vv.Satellite.from_tle(
        "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
        "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340", name="ISS")
    cat = Catalog([iss])
    near = iss.epoch + np.array([0.0, 10.0, 20.0]) * u.day
    far = Time("2024-06-01T00:00:00", scale="utc") + np.arange(3) * u.min  # 152 days out
    calls = (lambda t: cat.propagate(t, method="j2"), lambda t: cat.propagate(t, method="kepler"),
             lambda t: propagate_j2_batch([iss], t), lambda t: propagate_kepler_batch(iss, t),
             lambda t: cat.propagate(t, method="kepler", frame="gcrs"))
    for call in calls:
        with warnings.catch_warnings():
            warnings.simplefilter("error", vv.StaleElementSetWarning)
            call(near)  # within 30 days: quiet
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            call(far)
        stale = [x for x in w if issubclass(x.category, vv.StaleElementSetWarning)]
        assert len(stale) == 1 and stale[0].filename == __file__, stale[0].filename
        assert "1 of 1 element set(s) lie more than 30 days from the requested times (up to " \
               "152 days: ISS (152 d))" in str(stale[0].message)
    states = iss.teme(iss.epoch + [0, 60] * u.s)  # state vectors: no element set, no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error", vv.StaleElementSetWarning)
        propagate_kepler_batch(states, far)
    station = vv.GroundStation(40.0 * u.deg, -75.0 * u.deg, 0.0 * u.m)
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        vv.find_passes(iss, station, far[0], far[0] + 6 * u.h)
    stale = [x for x in w if issubclass(x.category, vv.StaleElementSetWarning)]
    assert len(stale) == 1 and stale[0].filename == __file__, [str(x.message) for x in stale]


def test_a_name_shared_by_several_satellites_is_refused_with_what_to_do():
    """cat["NAME"] returned the first of several satellites of that name, silently: in an
    element-set history the oldest set (five days stale here), among debris of one breakup any
    one object. It raises now, naming the positions and what to use; a unique name, positions
    and slices are as before, and other index types are refused clearly."""
    older = vv.Satellite.from_tle(ISS_1, ISS_2, name="ISS")
    newer = vv.Satellite.from_omm(older.to_omm() | {"EPOCH": "2008-09-25T12:25:40.104192"})
    debris = [vv.Satellite.from_omm(older.to_omm() | {"NORAD_CAT_ID": n,
                                                      "OBJECT_NAME": "DEB"})
              for n in (90001, 90002)]
    cat = Catalog([older, newer, *debris])
    with pytest.raises(vv.InvalidInputError, match=r"2 satellites of this catalogue are named "
                       r"'ISS' \(positions 0, 1\); they are element sets of one object "
                       r"\(25544\): cat\.latest\(\)\['ISS'\] picks the newest"):
        cat["ISS"]
    assert cat.latest()["ISS"] is newer
    with pytest.raises(vv.InvalidInputError, match=r"positions 2, 3\); they are 2 objects "
                       r"\(catalogue numbers 90001, 90002\)"):
        cat["DEB"]
    with pytest.raises(KeyError):
        cat["NOT THERE"]
    assert cat[1] is newer and cat[np.int64(-1)] is debris[1] and len(cat[1:]) == 3
    assert Catalog([older, *debris])["ISS"] is older
    for bad in ([0, 1], 1.0, True, np.array([0])):
        with pytest.raises(vv.InvalidInputError, match="indexed by position"):
            cat[bad]


@pytest.mark.parametrize("method", ["sgp4", "j2", "kepler"])
def test_an_empty_catalogue_propagates_to_empty_states(method):
    # the J2 batch raised a bare IndexError (its setup read the first element set); SGP4 and
    # Kepler returned (0, T, 3)
    t = Time("2024-01-01T00:00:00", scale="utc") + np.arange(4) * u.min
    out = Catalog([]).propagate(t, method=method, frame="gcrs")
    assert out.r.shape == out.v.shape == (0, 4, 3) and out.status.shape == (0, 4)
    assert out.names == [] and out.frame == "gcrs"


def test_kepler_batch_nan_mode_keeps_the_other_satellites(catalog, times):
    # on_error="nan" raised the SGP4 error of 33334 (error 3 at its own epoch) for the whole
    # catalogue; now that satellite's row is NaN with NON_FINITE and the others propagate
    from visviva.core.status import NON_FINITE

    k = catalog.names.index("33334")
    with pytest.raises(SGP4Error, match="'33334'"):
        propagate_kepler_batch(catalog, times[:2])
    out = propagate_kepler_batch(catalog, times[:2], on_error="nan")
    assert (out.status[k] == NON_FINITE).all() and np.isnan(out.r.value[k]).all()
    others = np.delete(np.arange(len(catalog)), k)
    one = propagate_kepler_batch(catalog[:k], times[:2], on_error="nan")
    np.testing.assert_array_equal(out.r.value[:k], one.r.value)
    assert np.isfinite(out.r.value[others][out.status[others] == 0]).all()


def test_a_catalogue_cannot_be_changed_in_place_under_its_cached_arrays():
    # Catalog.satellites was a plain list: after cat.satellites[0] = geo, propagate() returned
    # the cached SatrecArray's ISS positions (|r| = 6720 km) labelled 'GEO' (42136 km)
    iss = vv.Satellite.from_tle(ISS_1, ISS_2, name="ISS")
    cat = Catalog([iss])
    t = iss.epoch + np.arange(2) * u.min
    before = cat.propagate(t)
    with pytest.raises((TypeError, AttributeError)):
        cat.satellites[0] = iss
    with pytest.raises(AttributeError):
        cat.satellites = [iss]
    with pytest.raises(AttributeError):
        cat.satellites.append(iss)
    assert isinstance(cat.satellites, tuple)
    grown = Catalog([*cat, iss])  # the way to change one: a new catalogue
    np.testing.assert_array_equal(grown.propagate(t).r.value[1], before.r.value[0])
    import pickle

    again = pickle.loads(pickle.dumps(cat))
    assert isinstance(again.satellites, tuple)
    np.testing.assert_array_equal(again.propagate(t).r.value, before.r.value)


def test_space_track_records_of_decayed_objects_are_warned_about(tmp_path):
    # audit49: Space-Track's GP JSON keeps the last sets of re-entered objects, with their
    # DECAY_DATE; they were read and propagated past that date without a word
    import json
    import pickle

    from visviva.errors import DecayedObjectWarning
    from visviva.satellites.catalog import read_catalog_file

    iss = vv.Satellite.from_tle(ISS_1, ISS_2, "ISS (ZARYA)").to_omm()
    gone = {k: str(v) for k, v in iss.items()} | {"OBJECT_NAME": "GONE", "NORAD_CAT_ID": "25545",
                                                   "DECAY_DATE": "2008-09-25"}
    live = {k: str(v) for k, v in iss.items()} | {"DECAY_DATE": None}
    path = tmp_path / "gp.json"
    path.write_text(json.dumps([live, gone, gone | {"NORAD_CAT_ID": "25546"}]))
    with pytest.warns(DecayedObjectWarning, match=r"2 element set\(s\) of objects that "
                      r"re-entered \(DECAY_DATE\): GONE on 2008-09-25, GONE on") as got:
        cat = read_catalog_file(path)
    assert len(cat) == 3 and len([w for w in got if w.category is DecayedObjectWarning]) == 1
    with pytest.warns(DecayedObjectWarning, match="GONE on 2008-09-25"):
        sat = vv.Satellite.from_omm(gone)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pickle.loads(pickle.dumps(sat))  # warned once, when it was read
        vv.Satellite.from_omm(live)
