"""First contact, fifth pass (audit51): what a new user pastes and asks first.

TLE lines pasted with an indent are read; OMM epochs written with a UTC offset of zero are
read (another offset is refused, named); a satellite whose OMM record has a ``DECAY_DATE``
warns when asked for positions after it; unnamed ground stations on one latitude and
longitude get names that tell them apart (and shared names warn); ``look`` at a target on the
station is refused instead of returning round-off angles.
"""

from __future__ import annotations

import warnings

import astropy.units as u
import numpy as np
import pytest
from astropy.time import Time

import visviva as vv
from visviva.errors import DecayedObjectWarning, DomainError, InvalidInputError
from visviva.satellites.catalog import parse_tle_text
from visviva.satellites.tle import TLEFormatError

ISS_1 = "1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927"
ISS_2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537"

OMM = dict(OBJECT_NAME="ISS (ZARYA)", OBJECT_ID="1998-067A", EPOCH="2008-09-20T12:25:40.104192",
           MEAN_MOTION=15.72125391, ECCENTRICITY=0.0006703, INCLINATION=51.6416,
           RA_OF_ASC_NODE=247.4627, ARG_OF_PERICENTER=130.536, MEAN_ANOMALY=325.0288,
           EPHEMERIS_TYPE=0, CLASSIFICATION_TYPE="U", NORAD_CAT_ID=25544, ELEMENT_SET_NO=292,
           REV_AT_EPOCH=56353, BSTAR=-1.1606e-05, MEAN_MOTION_DOT=-2.182e-05,
           MEAN_MOTION_DDOT=0.0)

KVN = """CCSDS_OMM_VERS = 2.0
CREATION_DATE = 2008-09-21T00:00:00
ORIGINATOR = TEST
OBJECT_NAME = ISS (ZARYA)
OBJECT_ID = 1998-067A
CENTER_NAME = EARTH
REF_FRAME = TEME
TIME_SYSTEM = UTC
MEAN_ELEMENT_THEORY = SGP4
EPOCH = 2008-09-20T12:25:40.104192{suffix}
MEAN_MOTION = 15.72125391
ECCENTRICITY = 0.0006703
INCLINATION = 51.6416
RA_OF_ASC_NODE = 247.4627
ARG_OF_PERICENTER = 130.536
MEAN_ANOMALY = 325.0288
EPHEMERIS_TYPE = 0
CLASSIFICATION_TYPE = U
NORAD_CAT_ID = 25544
ELEMENT_SET_NO = 292
REV_AT_EPOCH = 56353
BSTAR = -1.1606e-05
MEAN_MOTION_DOT = -2.182e-05
MEAN_MOTION_DDOT = 0
"""


# -- TLE lines pasted with an indent ---------------------------------------------------------
@pytest.mark.parametrize("indent", ["    ", "  ", "\t"])
def test_indented_tle_lines_are_read_as_the_plain_ones(tmp_path, indent):
    # was: TLEFormatError "expected TLE line 1 after the name line 'ISS (ZARYA)'" (a file),
    # "TLE line 1 has 73 characters" (from_tle)
    plain = vv.Satellite.from_tle(ISS_1, ISS_2, "ISS (ZARYA)")
    path = tmp_path / "pasted.tle"
    path.write_text(f"  ISS (ZARYA)\n{indent}{ISS_1}\n{indent}{ISS_2}\n")
    for sat in (vv.read_catalog_file(path)[0], vv.read_tle_file(path)[0],
                parse_tle_text(path.read_text())[0],
                vv.Satellite.from_tle(indent + ISS_1, indent + ISS_2, "ISS (ZARYA)")):
        assert sat.name == "ISS (ZARYA)" and sat.to_tle() == (ISS_1, ISS_2)
        t = plain.epoch + np.arange(3) * u.h
        assert np.array_equal(sat.teme(t).r.to_value(u.km), plain.teme(t).r.to_value(u.km))


def test_indented_tle_lines_still_have_their_checksums_checked():
    bad = ISS_1[:-1] + "0"
    with pytest.raises(TLEFormatError, match="checksum mismatch"):
        parse_tle_text(f"   {bad}\n   {ISS_2}\n")
    with pytest.raises(TLEFormatError, match="after its 2 leading blanks"):
        vv.Satellite.from_tle("  " + ISS_1[:-1], "  " + ISS_2)


# -- OMM epochs with a UTC offset ------------------------------------------------------------
@pytest.mark.parametrize("suffix", ["Z", "+00:00", "-00:00", "+0000", "+00"])
def test_omm_epoch_with_a_zero_utc_offset_is_the_same_epoch(tmp_path, suffix):
    # was: InvalidInputError "OMM EPOCH '...+00:00' is not a UTC date-time" (datetime.isoformat
    # writes '+00:00'), CCSDSFormatError for a KVN file
    plain = vv.Satellite.from_omm(OMM)
    sat = vv.Satellite.from_omm({**OMM, "EPOCH": OMM["EPOCH"] + suffix})
    assert sat.epoch == plain.epoch
    path = tmp_path / "iss.omm"
    path.write_text(KVN.format(suffix=suffix))
    assert vv.read_catalog_file(path)[0].epoch == plain.epoch
    vv.read_omm(path)  # the CCSDS reader, too


@pytest.mark.parametrize("suffix", ["+02:00", "-05:30", "+0100"])
def test_omm_epoch_with_another_utc_offset_is_refused_naming_it(tmp_path, suffix):
    with pytest.raises(InvalidInputError, match=f"UTC offset \\{suffix}"):
        vv.Satellite.from_omm({**OMM, "EPOCH": OMM["EPOCH"] + suffix})
    path = tmp_path / "iss.omm"
    path.write_text(KVN.format(suffix=suffix))
    with pytest.raises(InvalidInputError, match=f"line 10.*UTC offset \\{suffix}"):
        vv.read_catalog_file(path)
    with pytest.raises(Exception, match=f"line 10: EPOCH .* UTC offset \\{suffix}"):
        vv.read_omm(path)


# -- propagation after a DECAY_DATE ----------------------------------------------------------
def _decayed():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DecayedObjectWarning)
        return vv.Satellite.from_omm({**OMM, "DECAY_DATE": "2008-09-22"})


def test_positions_after_the_decay_date_warn_once():
    # was: silent (the record warned when read, then SGP4 gave positions of no object)
    sat = _decayed()
    assert sat.decay_date == "2008-09-22" and vv.Satellite.from_tle(ISS_1, ISS_2).decay_date is None
    before = sat.epoch + np.arange(0, 30, 5) * u.h  # up to 2008-09-21T13:25
    with warnings.catch_warnings():
        warnings.simplefilter("error", DecayedObjectWarning)
        sat.teme(before)
    after = Time("2008-09-23T00:00:00") + np.arange(3) * u.min
    with pytest.warns(DecayedObjectWarning, match=r"'ISS \(ZARYA\)' \(DECAY_DATE 2008-09-22, "
                      r"asked 1\.0 days after"):
        sat.gcrs(after)
    with warnings.catch_warnings():  # once per satellite
        warnings.simplefilter("error", DecayedObjectWarning)
        sat.teme(after)


def test_a_catalogue_propagated_after_a_decay_date_warns():
    cat = vv.Catalog([_decayed(), vv.Satellite.from_tle(ISS_1, ISS_2, "ALIVE")])
    with pytest.warns(DecayedObjectWarning, match="ISS \\(ZARYA\\)") as rec:
        cat.propagate(Time("2008-09-25T00:00:00") + np.arange(2) * u.min)
    assert "ALIVE" not in str(rec[0].message)


# -- ground stations -------------------------------------------------------------------------
def test_unnamed_stations_at_one_place_but_different_heights_have_different_names():
    # was: both '40.0000, -75.0000'
    low = vv.GroundStation(40 * u.deg, -75 * u.deg)
    high = vv.GroundStation(40 * u.deg, -75 * u.deg, 500 * u.m)
    assert low.name == "40.0000, -75.0000"
    assert high.name == "40.0000, -75.0000, 500 m"


def test_different_stations_with_one_name_warn_in_a_network():
    from visviva.ground.station import as_stations

    a = vv.GroundStation(40 * u.deg, -75 * u.deg, name="SITE")
    b = vv.GroundStation(41 * u.deg, -75 * u.deg, name="SITE")
    with pytest.warns(UserWarning, match="stations\\[0\\] and stations\\[1\\] .* 'SITE'"):
        as_stations([a, b])
    near = [vv.GroundStation(40 * u.deg, -75 * u.deg),
            vv.GroundStation(40.00001 * u.deg, -75 * u.deg)]  # 1.1 m apart
    with pytest.warns(UserWarning, match="same name"):
        as_stations(near)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        as_stations([a, a, vv.GroundStation(40 * u.deg, -75 * u.deg, 500 * u.m)])


def test_look_at_a_target_on_the_station_is_refused():
    # was: az 255.4 deg, el -28.8 deg at a range of 3e-12 km (round-off); NaN at exactly 0
    site = vv.GroundStation(40 * u.deg, -75 * u.deg, 100 * u.m)
    t = Time("2024-01-01T00:00:00")
    r, v = site.gcrs_position_velocity(t)
    states = vv.StateVectors(r * u.km, v * u.km / u.s, vv.EARTH, epoch=t)
    with pytest.raises(DomainError, match="m from the station .* undefined"):
        site.look(states, t)
    up = vv.StateVectors((r + 0.01 * r / np.linalg.norm(r)) * u.km, v * u.km / u.s, vv.EARTH,
                         epoch=t)  # 10 m above: a target, read
    assert abs(site.look(up, t).elevation.to_value(u.deg) - 90.0) < 0.5


# -- a whole text where a line or a path is expected -----------------------------------------
def test_a_tle_text_given_as_one_line_or_as_a_path_says_so():
    # was: "TLE line 1 has 139 characters" and "no such file" (the text taken for a file name)
    text = f"ISS (ZARYA)\n{ISS_1}\n{ISS_2}\n"
    with pytest.raises(TLEFormatError, match="holds 2 lines: pass the two lines"):
        vv.Satellite.from_tle(ISS_1 + "\n" + ISS_2, ISS_2)
    for reader in (vv.read_tle_file, vv.read_catalog_file, vv.read_omm_file):
        with pytest.raises(InvalidInputError, match="got a text of 3 lines where the path"):
            reader(text)
    assert vv.Satellite.from_tle(*text.splitlines()[-2:]).satnum == 25544


# -- a Skyfield user's times -----------------------------------------------------------------
def test_a_skyfield_time_or_a_datetime_is_refused_saying_how_to_convert_it():
    # was: "t must be an astropy Time ..., got Time" (a Skyfield Time), "got datetime"
    import datetime as dt

    from skyfield.api import load

    ts = load.timescale(builtin=True)
    sat = vv.Satellite.from_tle(ISS_1, ISS_2, "ISS")
    site = vv.GroundStation(40 * u.deg, -75 * u.deg)
    t = ts.utc(2008, 9, 20, 12)
    calls = [lambda t: sat.teme(t), lambda t: site.look(sat, t),
             lambda t: vv.find_passes(sat, site, t, t),
             lambda t: vv.StateVectors([7000, 0, 0] * u.km, [0, 7.5, 0] * u.km / u.s, vv.EARTH,
                                       epoch=t)]
    for call in calls:
        with pytest.raises(vv.VisvivaError, match=r"skyfield\.timelib\.Time \(a Skyfield time: "
                           r"pass t\.to_astropy\(\)\)"):
            call(t)
        with pytest.raises(vv.VisvivaError, match=r"datetime\.datetime \(pass astropy's "
                           r"Time\(dt\); aware: it is converted to UTC\)"):
            call(dt.datetime(2008, 9, 20, 12, tzinfo=dt.UTC))
    # and the conversion said gives the same positions as skyfield's own SGP4
    ours = sat.teme(t.to_astropy()).r.to_value(u.km)
    from skyfield.api import EarthSatellite

    theirs = EarthSatellite(ISS_1, ISS_2, "ISS", ts).at(t)
    from skyfield.sgp4lib import TEME

    r_teme = theirs.frame_xyz(TEME).km
    assert np.max(np.abs(ours - r_teme)) < 1e-6  # km


def test_fit_tle_given_element_sets_says_what_it_is_for(tmp_path, capsys):
    # was: only "line 1: an OEM starts with CCSDS_OEM_VERS = <version>"
    from visviva import cli

    path = tmp_path / "iss.tle"
    path.write_text(f"ISS (ZARYA)\n{ISS_1}\n{ISS_2}\n")
    assert cli.main(["fit-tle", str(path)]) == 2
    err = capsys.readouterr().err
    assert "holds element sets (TLE), not an ephemeris" in err and "visviva convert" in err


def test_tab_completion_offers_no_future_import():
    # was: dir(vv) listed 'annotations' (the `from __future__ import annotations` binding)
    import visviva.mechanics

    for module in (vv, visviva.mechanics):
        names = dir(module)
        assert "annotations" not in names
        assert {"Satellite", "GroundStation", "find_passes"} <= set(dir(vv))
