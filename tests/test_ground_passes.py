"""Pass tables: columns, masks at the window's edges, visibility against astropy's Sun and the
eclipse function of visviva.satellites, CSV/ECSV export, the command line and the sky plot."""

import importlib.resources

import numpy as np
import pytest
from astropy import units as u
from astropy.coordinates import AltAz, get_body
from astropy.table import QTable
from astropy.time import Time

import visviva as vv
from visviva.cli import main
from visviva.ground import plot_sky_track, twilight, visual_magnitude, write_passes

ISS_1 = "1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927"
ISS_2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537"
T0 = Time("2008-09-20T12:00:00", scale="utc")


@pytest.fixture(scope="module")
def iss():
    return vv.Satellite.from_tle(ISS_1, ISS_2, name="ISS")


@pytest.fixture(scope="module")
def sites():
    return [vv.GroundStation(40.0 * u.deg, -75.0 * u.deg, 50 * u.m, name="PHL"),
            vv.GroundStation(52.2 * u.deg, 0.12 * u.deg, 30 * u.m, name="CAM"),
            vv.GroundStation(-33.9 * u.deg, 18.4 * u.deg, name="CPT")]


@pytest.fixture(scope="module")
def table(iss, sites):
    return vv.find_passes(iss, sites, T0, T0 + 1 * u.day, 10 * u.deg, standard_magnitude=-1.8)


def test_table_matches_find_events_per_station(iss, sites, table):
    assert isinstance(table, QTable)
    for name in ("satellite", "station", "rise_time", "culmination_time", "set_time",
                 "max_elevation", "rise_azimuth", "set_azimuth", "sunlit", "station_dark"):
        assert name in table.colnames
    assert np.all(np.diff(table["rise_time"].jd) >= 0)  # sorted by rise
    for site in sites:
        times, kinds = site.find_events(iss, T0, T0 + 1 * u.day, 10 * u.deg)
        rows = table[table["station"] == site.name]
        assert len(rows) == (kinds == 0).sum()
        np.testing.assert_allclose(rows["rise_time"].jd, times[kinds == 0].jd, atol=1e-9)
        np.testing.assert_allclose(rows["set_time"].jd, times[kinds == 2].jd, atol=1e-9)
        look = site.look(iss, rows["culmination_time"])
        np.testing.assert_allclose(rows["max_elevation"].to_value(u.deg),
                                   look.elevation.to_value(u.deg), atol=1e-8)
        rise = site.look(iss, rows["rise_time"])
        np.testing.assert_allclose(rows["rise_azimuth"].to_value(u.deg),
                                   rise.azimuth.to_value(u.deg), atol=1e-8)
    dur = (table["set_time"] - table["rise_time"]).to_value(u.s)
    np.testing.assert_allclose(table["duration"].to_value(u.s), dur, atol=1e-3)


def test_sunlight_and_darkness_against_astropy_and_the_eclipse_function(iss, sites, table):
    from visviva.satellites.groundtrack import eclipse_fraction

    tc = table["culmination_time"]
    frac = eclipse_fraction(iss, tc)
    np.testing.assert_allclose(table["sun_fraction"], frac, atol=1e-3)
    np.testing.assert_array_equal(table["sunlit"], frac > 0)
    assert table["sunlit"].any() and not table["sunlit"].all()
    by_name = {s.name: s for s in sites}
    for row in table:
        site = by_name[row["station"]]
        sun = get_body("sun", row["culmination_time"], location=site.location)
        alt = sun.transform_to(AltAz(obstime=row["culmination_time"], location=site.location)).alt
        assert row["sun_elevation"].to_value(u.deg) == pytest.approx(alt.deg, abs=0.05)
        assert row["station_dark"] == (alt.deg < -6)
    # visible at the culmination -> visible (the pass can be visible elsewhere too)
    assert np.all(table["visible"][table["sunlit"] & table["station_dark"]])
    lit = table["sunlit"]
    assert np.all(np.isfinite(table["magnitude"][lit].value))
    assert np.all(table["magnitude"].mask[~lit])


def test_window_cutting_a_pass_masks_its_edges(iss, sites, table):
    row = table[np.argmax(table["max_elevation"])]
    site = next(s for s in sites if s.name == row["station"])
    mid = row["culmination_time"]
    before = vv.find_passes(iss, site, mid - 3 * u.hour, mid, 10 * u.deg)
    last = before[-1]
    assert last["set_time"].mask and not last["rise_time"].mask
    assert np.ma.is_masked(last["set_azimuth"].value) and np.ma.is_masked(last["duration"].value)
    assert abs((last["rise_time"] - row["rise_time"]).to_value(u.s)) < 0.01
    after = vv.find_passes(iss, site, mid + 1 * u.s, mid + 3 * u.hour, 10 * u.deg)
    first = after[0]
    assert first["rise_time"].mask and not first["set_time"].mask
    assert first["culmination_time"].mask  # the highest point is the window's start
    assert abs((first["set_time"] - row["set_time"]).to_value(u.s)) < 0.01


def test_geostationary_satellite_is_up_all_window():
    text = (importlib.resources.files("sgp4") / "SGP4-VER.TLE").read_text()
    lines = [ln[:69] for ln in text.splitlines() if ln[:2] in ("1 ", "2 ")]
    pairs = {a[2:7]: (a, b) for a, b in zip(lines[::2], lines[1::2], strict=True)}
    geo = vv.Satellite.from_tle(*pairs["28626"], name="GEO")  # 0.0019 deg inclination
    sub = geo.geodetic(geo.epoch)[1]
    site = vv.GroundStation(10 * u.deg, sub, name="under")
    tab = vv.find_passes(geo, site, geo.epoch, geo.epoch + 12 * u.hour)
    assert len(tab) == 1
    assert tab["rise_time"].mask[0] and tab["set_time"].mask[0]
    assert tab["max_elevation"][0] > 70 * u.deg


def test_catalogue_and_multiple_stations_equal_single_runs(iss, sites):
    cat = vv.Catalog([iss, vv.Satellite.from_tle(ISS_1, ISS_2, name="ISS-2")])
    both = vv.find_passes(cat, sites[:2], T0, T0 + 6 * u.hour)
    one = vv.find_passes(iss, sites[1], T0, T0 + 6 * u.hour)
    sub = both[(both["satellite"] == "ISS-2") & (both["station"] == sites[1].name)]
    np.testing.assert_allclose(sub["rise_time"].jd, one["rise_time"].jd, atol=1e-12)


def test_a_satellite_given_twice_in_a_list_warns(iss, sites):
    # before: every pass listed twice without a word (audit51's left item)
    one = vv.find_passes([iss], sites[0], T0, T0 + 1 * u.day)
    with pytest.warns(UserWarning, match=r"satellites\[1\] repeats satellites\[0\].*25544") as rec:
        twice = vv.find_passes([iss, vv.Satellite.from_tle(ISS_1, ISS_2)], sites[0], T0,
                               T0 + 1 * u.day)
    assert rec[0].filename == __file__
    assert len(twice) == 2 * len(one) > 0


def test_visual_magnitude_and_twilight():
    assert visual_magnitude(-1.8, 1000.0, np.pi / 2) == pytest.approx(-1.8)
    assert visual_magnitude(-1.8, 2000.0, np.pi / 2) == pytest.approx(-1.8 + 5 * np.log10(2))
    assert visual_magnitude(0.0, 1000.0, 0.0) == pytest.approx(-2.5 * np.log10(np.pi))
    assert np.isinf(visual_magnitude(0.0, 1000.0, np.pi))
    np.testing.assert_array_equal(twilight([10, -3, -8, -15, -30]),
                                  ["day", "civil", "nautical", "astronomical", "night"])


def test_visual_magnitude_and_twilight_take_quantities_in_any_unit():
    # a Quantity's unit was dropped: 90 deg read as 90 rad, 1e6 m as 1e6 km, -0.2 rad of Sun
    # elevation as -0.2 deg ("day" instead of "nautical") (audit10)
    assert visual_magnitude(4.0, 1e6 * u.m, 90 * u.deg) == pytest.approx(4.0)
    assert visual_magnitude(4.0 * u.mag, 2000 * u.km, np.pi / 2) == pytest.approx(
        4.0 + 5 * np.log10(2))
    assert str(twilight(-0.2 * u.rad)) == "nautical"
    np.testing.assert_array_equal(twilight([-15.0, 5.0] * u.deg), ["astronomical", "day"])
    with pytest.raises(vv.UnitsError):
        twilight(-3 * u.km)


def test_export_csv_and_ecsv(table, tmp_path):
    write_passes(table, tmp_path / "p.ecsv")
    back = QTable.read(tmp_path / "p.ecsv")
    np.testing.assert_allclose(back["max_elevation"].to_value(u.deg),
                               table["max_elevation"].to_value(u.deg))
    for name in ("rise_time", "culmination_time", "set_time"):
        # the times came back cut to the millisecond (0.46 ms off; audit25)
        assert back[name].scale == table[name].scale
        assert np.all(np.abs((back[name] - table[name]).to_value(u.s)) < 1e-8)
    write_passes(table, tmp_path / "p.csv")
    text = (tmp_path / "p.csv").read_text().splitlines()
    assert text[0].startswith("satellite,") and len(text) == len(table) + 1
    with pytest.raises(vv.InvalidInputError, match="csv"):
        write_passes(table, tmp_path / "p.txt")


def test_command_line(tmp_path, capsys):
    tle = tmp_path / "iss.tle"
    tle.write_text(f"ISS (ZARYA)\n{ISS_1}\n{ISS_2}\n")
    out_csv = tmp_path / "passes.csv"
    rc = main(["passes", str(tle), "--lat", "40", "--lon", "-75", "--height", "50",
               "--start", "2008-09-20T12:00:00", "--hours", "24", "--min-elevation", "10",
               "--csv", str(out_csv)])
    out = capsys.readouterr().out
    assert rc == 0
    assert "2008-09-20 22:51:52" in out and "5 pass(es)" in out
    # times rounded to the second (set 22:55:11.77 was shown cut to 22:55:11)
    assert "2008-09-20 22:55:12" in out and "22:55:11" not in out
    # a start with a UTC offset is that instant (was refused as no ISO time)
    assert main(["passes", str(tle), "--lat", "40", "--lon", "-75", "--height", "50",
                 "--start", "2008-09-20T08:00:00-04:00", "--hours", "24",
                 "--min-elevation", "10"]) == 0
    assert capsys.readouterr().out.splitlines()[:7] == out.splitlines()[:7]
    assert len(out_csv.read_text().splitlines()) == 6
    assert main(["passes", str(tle), "--lat", "40", "--lon", "-75", "--start", "nonsense"]) == 2
    # bad arguments: a clear one-line message and exit code 2, as `visviva screen` (these gave 1)
    assert main(["passes", str(tmp_path / "missing.tle"), "--lat", "40", "--lon", "-75",
                 "--start", "2008-09-20T12:00:00"]) == 2
    assert "missing.tle" in capsys.readouterr().err
    assert main(["passes", str(tle), "--lat", "95", "--lon", "-75",
                 "--start", "2008-09-20T12:00:00"]) == 2
    assert "outside [-90, 90]" in capsys.readouterr().err
    assert main(["passes", str(tle), "--lat", "40", "--lon", "-75", "--min-elevation", "100",
                 "--start", "2008-09-20T12:00:00"]) == 2
    assert "min_elevation" in capsys.readouterr().err
    assert main(["passes", str(tle), "--lat", "40", "--lon", "-75", "--hours", "2",
                 "--start", "2008-09-20T12:00:00", "--csv",
                 str(tmp_path / "no_such_dir" / "p.csv")]) == 2
    err = capsys.readouterr().err
    assert "cannot write" in err and "no_such_dir" in err and len(err.strip().splitlines()) == 1
    # a bad date: one short reason (not astropy's list of every format); --hours inf refused
    assert main(["passes", str(tle), "--lat", "40", "--lon", "-75", "--start", "2008-13-20"]) == 2
    err = capsys.readouterr().err
    assert "bad month" in err and "byear_str" not in err and len(err.splitlines()) == 1
    with pytest.raises(SystemExit) as exc:  # (refused as the arguments are read)
        main(["passes", str(tle), "--lat", "40", "--lon", "-75", "--start",
              "2008-09-20T12:00:00", "--hours", "inf"])
    assert exc.value.code == 2
    assert "--hours: 'inf' is not a positive number of hours" in capsys.readouterr().err


def test_sky_plot(iss, sites, table):
    row = table[0]
    site = next(s for s in sites if s.name == row["station"])
    fig = plot_sky_track(site, iss, row["rise_time"] - 1 * u.min, row["set_time"] + 1 * u.min,
                         min_elevation=10 * u.deg)
    ax = fig.axes[0]
    assert ax.name == "polar"
    r = ax.lines[0].get_ydata()
    assert np.nanmax(r) <= 80 + 1e-6 and np.nanmin(r) == pytest.approx(
        90 - row["max_elevation"].to_value(u.deg), abs=0.5)


def test_bad_input(iss, sites):
    with pytest.raises(vv.InvalidInputError, match="empty"):
        vv.find_passes(vv.Catalog([]), sites, T0, T0 + 1 * u.hour)
    with pytest.raises(vv.InvalidInputError, match="empty"):
        vv.find_passes(iss, [], T0, T0 + 1 * u.hour)
    with pytest.raises(vv.InvalidInputError, match="GroundStation"):
        vv.find_passes(iss, ["PHL"], T0, T0 + 1 * u.hour)
    with pytest.raises(vv.InvalidInputError, match="later than t0"):
        vv.find_passes(iss, sites, T0, T0 - 1 * u.hour)
    with pytest.raises(vv.DomainError):
        vv.find_passes(iss, sites, T0, T0 + 1 * u.hour, -91 * u.deg)


@pytest.mark.parametrize("mag, match", [
    ([1.0, 2.0], "one per satellite"),  # was numpy's "could not be broadcast"
    (np.nan, "not a finite magnitude"),  # was: every magnitude masked, silently
    ([np.inf], "standard_magnitude\\[0\\] is inf"),
    ("bright", "one number per satellite"),  # was numpy's "could not convert string"
    (3.0 * u.km, "unit 'km'"),
])
def test_bad_standard_magnitude_is_refused_before_the_search(iss, sites, mag, match):
    with pytest.raises(vv.InvalidInputError, match=match):
        vv.find_passes(iss, sites, T0, T0 + 1 * u.hour, standard_magnitude=mag)


def test_standard_magnitude_per_satellite_and_in_mag(iss, sites, table):
    one = vv.find_passes(iss, sites, T0, T0 + 1 * u.day, 10 * u.deg,
                         standard_magnitude=[-1.8] * u.mag)
    np.testing.assert_array_equal(one["magnitude"].unmasked, table["magnitude"].unmasked)


def _omm(epoch):
    return vv.Satellite.from_omm({
        "OBJECT_NAME": "X", "NORAD_CAT_ID": 1, "EPOCH": epoch, "MEAN_MOTION": 15.5,
        "ECCENTRICITY": 0.001, "INCLINATION": 51.6, "RA_OF_ASC_NODE": 10.0,
        "ARG_OF_PERICENTER": 0.0, "MEAN_ANOMALY": 0.0, "BSTAR": 0.0001,
        "MEAN_MOTION_DOT": 0.0, "MEAN_MOTION_DDOT": 0.0})


# 2040 is beyond the leap-second table: ERFA (through astropy's UTC conversions) says "dubious
# year" for every such time, as astropy does for any Time there; that warning is astropy's.
@pytest.mark.filterwarnings("ignore:ERFA function .*dubious year")
def test_offline_earth_orientation_for_recent_and_far_future_dates():
    from astropy.utils import iers
    from astropy.utils.exceptions import AstropyWarning

    site = vv.GroundStation(40 * u.deg, -75 * u.deg)
    # the installed IERS-A predictions are used however old the file is (no download); a day
    # holds passes of this orbit over this site whatever the date (12 hours may not)
    recent = Time.now().utc
    sat = _omm(recent.isot[:10] + "T00:00:00")
    tab = vv.find_passes(sat, site, recent, recent + 24 * u.hour)
    assert len(tab) >= 1
    assert iers.conf.auto_download  # only switched off inside visviva's calls
    # beyond the table: a warning, not an error and not a download
    far = Time("2040-01-01T06:00:00", scale="utc")
    with pytest.warns(AstropyWarning, match="IERS"):
        tab = vv.find_passes(_omm("2040-01-01T00:00:00"), site, far, far + 6 * u.hour)
    assert len(tab) >= 1


def test_command_line_reads_every_catalogue_kind(tmp_path, capsys, write_catalog_files):
    """``visviva passes`` on the same satellite as TLE, OMM JSON/CSV, CelesTrak XML and CCSDS
    OMM KVN/XML (files without a telling suffix): the same table, row for row."""
    iss = vv.Satellite.from_tle(ISS_1, ISS_2, "ISS (ZARYA)")
    outputs = {}
    for kind, path in write_catalog_files([iss]).items():
        out_csv = tmp_path / f"{kind}.csv"
        assert main(["passes", str(path), "--lat", "40", "--lon", "-75", "--start",
                     "2008-09-20T12:00:00", "--hours", "12", "--csv", str(out_csv)]) == 0
        outputs[kind] = (capsys.readouterr().out, out_csv.read_text())
    assert set(outputs) == {"tle", "json", "csv", "ndm", "kvn", "xml"}
    out, table = outputs["tle"]
    assert "ISS (ZARYA)" in out and "2008-09-20 22:5" in out and "0 pass(es)" not in out
    for kind, got in outputs.items():
        assert got == (out, table), kind
    # junk, an OEM, a bad OMM: exit 2 and one line naming the file and the line or record
    junk = tmp_path / "junk.txt"
    junk.write_text("hello\nworld\n")
    oem = tmp_path / "eph.oem"
    oem.write_text("CCSDS_OEM_VERS = 3.0\nCREATION_DATE = 2024-01-01\nORIGINATOR = X\n")
    bad_json = tmp_path / "bad.json"
    bad_json.write_text('[{"OBJECT_NAME": "X",\n "EPOCH": }]')
    for path, where in ((junk, "line 2"), (oem, "CCSDS OEM"), (bad_json, "line 2")):
        assert main(["passes", str(path), "--lat", "40", "--lon", "-75",
                     "--start", "2008-09-20T12:00:00"]) == 2
        err = capsys.readouterr().err
        assert str(path) in err and where in err and len(err.strip().splitlines()) == 1, err


def test_visible_means_sunlit_over_a_dark_station_at_some_time_of_the_pass(iss, sites):
    # "visible" was "sunlit and dark at the culmination": an evening pass entering the Earth's
    # shadow before its highest point (or a morning one leaving it after) was not visible, so
    # passes[passes["visible"]] and `visviva passes --visible` dropped passes seen for minutes
    # (30 of 88 over three days for four satellites at four sites against Skyfield's is_sunlit).
    # Reference: the eclipse function and astropy's Sun every 5 s along each pass.
    from visviva.satellites.groundtrack import eclipse_fraction

    table = vv.find_passes(iss, sites, T0, T0 + 2 * u.day, 10 * u.deg)
    by_name = {s.name: s for s in sites}
    partial = 0
    for row in table:
        if np.ma.is_masked(row["rise_time"]) or np.ma.is_masked(row["set_time"]):
            continue
        rise, set_ = Time(row["rise_time"].jd, format="jd"), Time(row["set_time"].jd, format="jd")
        t = rise + np.arange(0.0, (set_ - rise).to_value(u.s), 5.0) * u.s
        site = by_name[row["station"]]
        lit = eclipse_fraction(iss, t) > 0
        sun = get_body("sun", t, location=site.location)
        dark = sun.transform_to(AltAz(obstime=t, location=site.location)).alt.deg < -6
        seen = bool(np.any(lit & dark))
        assert seen == bool(row["visible"]), row
        partial += seen and not (row["sunlit"] and row["station_dark"])
    assert partial >= 2  # passes visible although their culmination is not


def test_a_satellite_decaying_in_the_window_has_its_passes_up_to_the_decay():
    # 28872 (SGP4-VER: perigee below the surface, decays ~1 h after its epoch): its secular
    # check raised inside the scan and the search died with UnboundLocalError (audit28); now
    # SGP4 takes every node, the events stop at the decay with a warning naming the satellite
    text = (importlib.resources.files("sgp4") / "SGP4-VER.TLE").read_text().splitlines()
    lines = [ln[:69] for ln in text if ln[2:7] == "28872" and ln[:2] in ("1 ", "2 ")]
    with pytest.warns(vv.SubsurfacePerigeeWarning):
        sat = vv.Satellite.from_tle(*lines)
    t0 = sat.epoch
    lat, lon = sat.geodetic(t0 + 20 * u.min)[:2]  # under it 20 min after the epoch
    station = vv.GroundStation(lat, lon)
    with pytest.warns(RuntimeWarning, match="28872.*events stop there"):
        times, kinds = station.find_events(sat, t0, t0 + 0.5 * u.day)
    assert list(kinds) == [0, 1, 2]  # the one pass before the decay, kept
    assert abs((times[1] - (t0 + 20 * u.min)).to_value(u.s)) < 5
    assert station.look(sat, times[1]).elevation > 85 * u.deg
    assert times[2] < t0 + 1 * u.hour
    with pytest.warns(RuntimeWarning, match="28872"):
        table = vv.find_passes(sat, station, t0, t0 + 0.5 * u.day)
    assert len(table) == 1 and table["max_elevation"][0] > 85 * u.deg


@pytest.mark.parametrize("shift_days, stale", [(-45.0, True), (-29.0, False), (0.0, False),
                                               (29.5, False), (31.0, True)])
def test_find_passes_and_find_events_warn_on_element_sets_far_from_the_window(
        iss, sites, shift_days, stale):
    # was: only the `visviva passes` command said so; the library listed 0 passes of a 2024
    # TLE over a 2026 window without a word. One hour windows, ending at t0 + 1 h: the set is
    # stale when the window starts > 30 days after the epoch or ends > 30 days before it
    import warnings

    t0 = iss.epoch + shift_days * u.day
    t1 = t0 + 1 * u.h
    for call in (lambda: vv.find_passes(iss, sites[0], t0, t1),
                 lambda: sites[0].find_events(iss, t0, t1)):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            call()
        ours = [w for w in caught if issubclass(w.category, vv.StaleElementSetWarning)]
        assert len(ours) == int(stale), [str(w.message) for w in caught]
        if stale:
            assert issubclass(vv.StaleElementSetWarning, UserWarning)
            assert "1 of 1 element set(s) lie more than 30 days from the window" in str(
                ours[0].message)
            assert f"up to {abs(shift_days):.0f} days" in str(ours[0].message)
            assert ours[0].filename == __file__  # points at the caller's line



def _tle_line1_at_day(day: float) -> str:
    """ISS_1 with its epoch moved to ``day`` of 2008 (checksum redone)."""
    body = ISS_1[:18] + f"08{day:012.8f}" + ISS_1[32:68]
    digits = sum(int(c) if c.isdigit() else (1 if c == "-" else 0) for c in body)
    return body + str(digits % 10)


def test_stale_element_set_warning_names_the_stalest_satellites(iss, sites):
    # a catalogue of mixed ages (was: "7 of 8 element set(s)" and no name): the warning names
    # the stale ones, stalest first, five at most
    import warnings

    t0 = iss.epoch + 40 * u.day  # 40 days after ISS_1's epoch (day 264.51782528)
    sats = [vv.Satellite.from_tle(_tle_line1_at_day(264.51782528 + 39), ISS_2, name="FRESH")]
    for k, age in enumerate((35, 50, 31, 60, 33, 45, 38)):  # epochs `age` days before t0
        line1 = _tle_line1_at_day(264.51782528 + 40 - age)
        sats.append(vv.Satellite.from_tle(line1, ISS_2, name=f"OLD{k}"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        vv.find_passes(sats, sites[0], t0, t0 + 1 * u.h)
    ours = [w for w in caught if issubclass(w.category, vv.StaleElementSetWarning)]
    assert len(ours) == 1
    text = str(ours[0].message)
    assert ("7 of 8 element set(s) lie more than 30 days from the window (up to 60 days: "
            "OLD3 (60 d), OLD1 (50 d), OLD5 (45 d), OLD6 (38 d), OLD0 (35 d) and 2 more)") in text
    assert "FRESH" not in text


@pytest.mark.filterwarnings("ignore::erfa.ErfaWarning")  # 1900: ERFA's "dubious year"
@pytest.mark.filterwarnings("ignore::UserWarning")  # Earth orientation before the IERS table
@pytest.mark.filterwarnings("ignore::visviva.StaleElementSetWarning")
def test_states_beyond_any_earth_orbit_give_no_passes_and_a_warning():
    """The ISS's 2024 element set run back to 1900 gives SGP4 positions ~3e8 km away without an
    error code (Satellite.teme refuses them): the pass search swept that point across the sky
    and listed 18 passes a day, with only the stale-set warning. Now those states fail as
    sgp4's errors do: no passes, and the RuntimeWarning naming the satellite."""
    iss24 = vv.Satellite.from_tle(
        "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
        "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340", name="ISS")
    site = vv.GroundStation(52.2 * u.deg, 0.12 * u.deg, name="CAM")
    t0 = Time("1900-01-01", scale="utc")
    with pytest.warns(RuntimeWarning, match=r"SGP4 failed inside the window for 1 satellite\(s\) "
                      r"\('ISS' after 1900-01-01T00:00:00.000\).*left every Earth orbit"):
        table = vv.find_passes(iss24, site, t0, t0 + 1 * u.day)
    assert len(table) == 0
    with pytest.raises(vv.SGP4Error, match="beyond any Earth orbit"):  # as look(iss24, t0)
        site.look(vv.Catalog([iss24]), t0 + [0, 60] * u.s)


def test_visible_start_and_end_against_skyfield_geometry():
    # audit37: the table said whether a pass was visible, not when: a pass entering the Earth's
    # shadow mid-pass was listed from rise to set. visible_start / visible_end are the first
    # and last times the satellite sees part of the Sun while the station's Sun is below
    # -6 deg. Reference: Skyfield's positions (DE430 excerpt shipped with Skyfield, the
    # satellite from its own SGP4) scanned every 0.05 s, with the shadow's outer edge
    # (the Sun's disc just touching the Earth's limb, spherical Earth) and Skyfield's geometric
    # Sun altitude. Skyfield's is_sunlit (the Sun's centre) ends inside the penumbra, seconds later.
    import os

    skyfield = pytest.importorskip("skyfield")
    from skyfield.api import EarthSatellite, load, wgs84
    from skyfield.jpllib import SpiceKernel

    path = os.path.join(os.path.dirname(skyfield.__file__), "tests", "data",
                        "de430-2015-03-02.bsp")
    if not os.path.exists(path):
        pytest.skip("skyfield's DE430 test excerpt is not installed")
    eph, ts = SpiceKernel(path), load.timescale(builtin=True)
    l1 = "1 25544U 98067A   15060.00000000  .00016717  00000-0  10270-3 0  9009"
    l2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.54815350 12346"
    sat, es = vv.Satellite.from_tle(l1, l2, name="ISS"), EarthSatellite(l1, l2, "ISS", ts)
    site = vv.GroundStation(-33.9 * u.deg, 18.4 * u.deg, name="CPT")
    top = wgs84.latlon(-33.9, 18.4)
    table = vv.find_passes(sat, site, Time("2015-02-28T12:00", scale="utc"),
                           Time("2015-03-02T06:00", scale="utc"), 10 * u.deg)
    assert table["visible_start"].mask.tolist() == (~table["visible"]).tolist()

    def seen(t):  # sunlit (any of the Sun's disc) over a dark station, on Skyfield's geometry
        tt = ts.tt_jd(t.tt.jd1, t.tt.jd2)
        r = es.at(tt).position.km
        s = (eph["sun"] - eph["earth"]).at(tt).position.km - r
        ang = np.arccos(np.sum(-r * s, 0) / np.linalg.norm(r, axis=0) / np.linalg.norm(s, axis=0))
        lit = ang > (np.arcsin(vv.constants.R_EARTH_KM / np.linalg.norm(r, axis=0))
                     - np.arcsin(vv.constants.R_SUN_KM / np.linalg.norm(s, axis=0)))
        sun_from_site = (eph["sun"] - eph["earth"] - top).at(tt)  # geometric, as ours
        return lit & (sun_from_site.frame_latlon(top)[0].degrees < -6)

    inner_edges = 0
    for row in table[table["visible"]]:
        rise, set_ = (Time(row[k].utc.jd1, row[k].utc.jd2, format="jd", scale="utc")
                      for k in ("rise_time", "set_time"))
        t = rise + np.r_[np.arange(0.0, (set_ - rise).to_value(u.s), 2.0),
                         (set_ - rise).to_value(u.s)] * u.s
        k = np.flatnonzero(seen(t))
        for ours, a, edge, pick in ((row["visible_start"], k[0], k[0] == 0, 0),
                                    (row["visible_end"], k[-1], k[-1] == t.size - 1, -1)):
            if edge:  # the rise or set itself
                assert abs((ours - t[a]).to_value(u.s)) < 1e-3
                continue
            fine = t[a] + np.arange(-2.0, 2.0, 0.02) * u.s  # the 2 s cell, every 0.02 s
            ref = fine[np.flatnonzero(seen(fine))[pick]]
            assert abs((ours - ref).to_value(u.s)) < 0.05
            inner_edges += 1
    assert inner_edges >= 3  # edges inside passes (the Earth's shadow, or twilight's end)


def test_pass_table_over_a_leap_second():
    """A window holding a leap second (2016-12-31T23:59:60) raised "Time object is read-only"
    from find_passes and visviva passes (astropy's cached UTC times, masked in place where a
    pass was not visible); now the table is made, its rises and sets are find_events' and
    lie on the horizon (audit50)."""
    from test_utc_days import L1, L2

    sat = vv.Satellite.from_tle(L1, L2, name="ISS")
    site = vv.GroundStation(40.0 * u.deg, -75.0 * u.deg, 100 * u.m, name="PHL")
    t0, t1 = Time("2016-12-31T18:00:00", scale="utc"), Time("2017-01-01T06:00:00", scale="utc")
    table = vv.find_passes(sat, site, t0, t1)
    times, kinds = site.find_events(sat, t0, t1)
    rise = table["rise_time"][~table["rise_time"].mask]
    assert len(rise) == (kinds == 0).sum() >= 4 and len(table) >= len(rise)
    assert (~table["visible"]).any() and table["visible_start"].mask.any()
    assert (rise > Time("2017-01-01", scale="utc")).any()
    np.testing.assert_allclose((rise - times[kinds == 0]).to_value(u.s), 0, atol=1e-3)
    el = site.look(sat, rise).elevation.to_value(u.deg)
    np.testing.assert_allclose(el, 0.0, atol=1e-4)
    times[0] = times[1]  # find_events' times are the user's to edit, as elsewhere


def test_command_line_over_a_leap_second(tmp_path, capsys):
    """visviva passes over 2016-12-31T23:59:60 ended in a traceback (audit50)."""
    from test_utc_days import L1, L2

    tle = tmp_path / "iss.tle"
    tle.write_text(f"ISS\n{L1}\n{L2}\n")
    out_ecsv = tmp_path / "passes.ecsv"
    assert main(["passes", str(tle), "--lat", "40", "--lon", "-75", "--start",
                 "2016-12-31T18:00", "--hours", "12", "--ecsv", str(out_ecsv)]) == 0
    assert "2017-01-01 00:16:06" in capsys.readouterr().out
    back = QTable.read(out_ecsv)
    assert back["rise_time"].scale == "utc" and len(back) >= 5


def test_magnitude_in_the_penumbra_dims_with_the_sunlit_fraction_of_the_disc(iss):
    """A pass culminating in the penumbra had the magnitude of a fully lit satellite: a
    third of the Sun's disc gives a third of the light, 1.2 mag fainter, which the column
    left out (audit50). The station sits under the ISS as it crosses the penumbra; the phase
    angle comes from astropy's Sun here."""
    from astropy.coordinates import ITRS, CartesianRepresentation, get_sun

    from visviva.satellites import eclipse_fraction

    t = T0 + np.arange(900, 1100, 1.0) * u.s  # the ISS enters the shadow near 12:16:36
    frac = eclipse_fraction(iss, t)
    tp = t[np.argmin(np.abs(frac - 0.3))]
    below = ITRS(CartesianRepresentation(iss.itrs(tp).r.T), obstime=tp).earth_location
    geo = below.to_geodetic("WGS84")
    site = vv.GroundStation(float(geo.lat.deg) * u.deg, float(geo.lon.deg) * u.deg)
    row = vv.find_passes(iss, site, tp - 15 * u.min, tp + 15 * u.min,
                         standard_magnitude=-1.8)[0]
    assert 0.2 < row["sun_fraction"] < 0.4 and row["max_elevation"] > 89 * u.deg
    tc = row["culmination_time"]
    sat = iss.gcrs(tc).r.to_value(u.km)
    obs = site.gcrs_position_velocity(tc)[0]
    sun = get_sun(tc).cartesian.xyz.to_value(u.km)
    to_sun, to_obs = sun - sat, obs - sat
    phase = np.arccos(to_sun @ to_obs / np.linalg.norm(to_sun) / np.linalg.norm(to_obs))
    full = visual_magnitude(-1.8, np.linalg.norm(to_obs), phase)
    expected = full - 2.5 * np.log10(row["sun_fraction"])
    mag = float(row["magnitude"].unmasked.to_value(u.mag))
    assert mag == pytest.approx(expected, abs=0.01) and mag - full > 1.0
    assert np.isinf(visual_magnitude(-1.8, 1000.0, 1.0, sun_fraction=0.0))
    with pytest.raises(vv.InvalidInputError, match="sun_fraction"):
        visual_magnitude(-1.8, 1000.0, 1.0, sun_fraction=1.5)


def test_twilight_refuses_nan():
    """twilight(NaN) was 'day' (np.digitize puts NaN past the last bin; audit50)."""
    with pytest.raises(vv.InvalidInputError, match="NaN"):
        twilight([-10.0, np.nan])
    with pytest.raises(vv.InvalidInputError, match="NaN"):
        twilight(np.nan * u.deg)
