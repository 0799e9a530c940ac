"""Elevation masks: the mask itself (interpolation, wrap-around, steps, the file reader, bad
input) and passes over masked stations against a brute-force reference on Skyfield's own
altitude and azimuth (sampled every second, crossings bisected to 1e-4 s)."""

import pickle
import re

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv
from visviva.errors import DomainError, InvalidInputError, ShapeError

ISS_1 = "1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927"
ISS_2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537"
T0 = Time("2008-09-20T22:30:00", scale="utc")  # seven passes in ten hours
LAT, LON = 40.0, -75.0
TENTH_SECOND = 0.1
#: a hill in the east, a dip to 0 deg in the west (continuous: np.interp is its reference)
HILL = ([0.0, 90.0, 180.0, 270.0], [5.0, 40.0, 5.0, 0.0])


@pytest.fixture(scope="module")
def iss():
    return vv.Satellite.from_tle(ISS_1, ISS_2, name="ISS")


@pytest.fixture(scope="module")
def site():
    return vv.GroundStation(LAT * u.deg, LON * u.deg, name="Philadelphia")


@pytest.fixture(scope="module")
def sky():
    from skyfield.api import EarthSatellite, load, wgs84

    ts = load.timescale()
    return ts, EarthSatellite(ISS_1, ISS_2, "x", ts) - wgs84.latlon(LAT, LON, 0.0)


def _alt_az(sky, t: Time):
    ts, diff = sky
    alt, az, _ = diff.at(ts.from_astropy(t)).altaz()
    return alt.degrees, az.degrees


def _interp_mask(az_pts, el_pts):
    return lambda az: np.interp(az, az_pts, el_pts, period=360.0)


def _brute(sky, mask_deg, hours=10.0, lowest=-15.0):
    """Crossings of ``alt - mask(az)`` (Skyfield): samples every 20 s find where the ISS is
    above ``lowest``, every second there, sign changes bisected to 1e-4 s. Returns
    (seconds after T0, +1 rise / -1 set)."""
    coarse = np.arange(0.0, hours * 3600.0 + 20.0, 20.0)
    alt, _ = _alt_az(sky, T0 + coarse * u.s)
    near = np.convolve(alt > lowest, np.ones(3), mode="same") > 0
    fine = np.unique(np.concatenate([np.arange(c - 20.0, c + 21.0, 1.0)
                                     for c in coarse[near]]))
    fine = fine[(fine >= 0.0) & (fine <= hours * 3600.0)]

    def g(t_s):
        a, z = _alt_az(sky, T0 + t_s * u.s)
        return a - mask_deg(z)

    gv = g(fine)
    k = np.flatnonzero((np.diff(fine) == 1.0) & ((gv[:-1] > 0) != (gv[1:] > 0)))
    lo, hi, glo = fine[k], fine[k + 1], gv[k]
    for _ in range(14):
        mid = 0.5 * (lo + hi)
        gm = g(mid)
        same = (gm > 0) == (glo > 0)
        lo, hi, glo = np.where(same, mid, lo), np.where(same, hi, mid), np.where(same, gm, glo)
    return 0.5 * (lo + hi), np.where(gv[k + 1] > 0, 1, -1)


def _events_s(times, kinds):
    t = (times - T0).to_value(u.s)
    sel = kinds != 1
    return t[sel], np.where(kinds[sel] == 0, 1, -1)


# the mask itself ------------------------------------------------------------------------------
def test_linear_in_azimuth_with_wrap_around():
    m = vv.ElevationMask(*(np.array(c) * u.deg for c in HILL))
    az = np.array([0.0, 45.0, 90.0, 135.0, 225.0, 300.0, 315.0, 359.0, 360.0, 405.0])
    want = np.interp(az, HILL[0], HILL[1], period=360.0)
    np.testing.assert_allclose(m(az * u.deg).to_value(u.deg), want, atol=1e-12)
    assert m(np.pi / 2 * u.rad).to_value(u.deg) == pytest.approx(40.0)
    # a mask across north: 350 deg -> 10 deg through 0
    wall = vv.ElevationMask([10, 350, 180] * u.deg, [30, 30, 0] * u.deg)
    np.testing.assert_allclose(wall([0, 5, 355, 95] * u.deg).to_value(u.deg),
                               [30, 30, 30, 15], atol=1e-12)


def test_one_point_is_flat_and_points_are_sorted():
    flat = vv.ElevationMask([123.0] * u.deg, [7.5] * u.deg)
    assert flat.is_flat
    np.testing.assert_allclose(flat([0, 90, 359.9] * u.deg).to_value(u.deg), 7.5)
    m = vv.ElevationMask([270, 0, 180, 90] * u.deg, [0, 5, 5, 40] * u.deg)
    np.testing.assert_array_equal(m.azimuth.to_value(u.deg), [0, 90, 180, 270])
    np.testing.assert_array_equal(m.elevation.to_value(u.deg), [5, 40, 5, 0])
    assert m.lowest.to_value(u.deg) == 0.0 and m.highest.to_value(u.deg) == 40.0


def test_two_points_at_one_azimuth_are_a_vertical_step():
    # a building from 100 to 120 deg azimuth, 30 deg high, on a 0 deg horizon
    m = vv.ElevationMask([0, 100, 100, 120, 120] * u.deg, [0, 0, 30, 30, 0] * u.deg)
    got = m([99.999, 100, 110, 120, 120.001, 200] * u.deg).to_value(u.deg)
    np.testing.assert_allclose(got, [0, 30, 30, 30, 0, 0], atol=1e-9)
    # 0 and 360 deg are one azimuth: a step at north (360: the side below north)
    north = vv.ElevationMask([0, 180, 360] * u.deg, [20, 20, 0] * u.deg)
    np.testing.assert_allclose(north([0, 90, 270, 359.99] * u.deg).to_value(u.deg),
                               [20, 20, 10, 0.0011], atol=1e-4)


def test_pickle_and_equality():
    m = vv.ElevationMask(*(np.array(c) * u.deg for c in HILL))
    back = pickle.loads(pickle.dumps(m))
    assert back == m and hash(back) == hash(m)
    assert back != vv.ElevationMask([0] * u.deg, [5] * u.deg)
    assert "ElevationMask" in repr(m)


@pytest.mark.parametrize("az, el, error, words", [
    ([0, 90] * u.deg, [5, np.nan] * u.deg, InvalidInputError, "point 1"),
    ([0, 400] * u.deg, [5, 5] * u.deg, DomainError, "outside [0, 360]"),
    ([0, -10] * u.deg, [5, 5] * u.deg, DomainError, "azimuth -10"),
    ([0, 90] * u.deg, [5, 95] * u.deg, DomainError, "outside [-90, 90]"),
    ([] * u.deg, [] * u.deg, InvalidInputError, "at least one point"),
    ([0, 90] * u.deg, [5] * u.deg, ShapeError, "same length"),
    ([0, 90, 90, 90] * u.deg, [5, 1, 2, 3] * u.deg, InvalidInputError, "more than two"),
])
def test_bad_masks_are_refused(az, el, error, words):
    with pytest.raises(error, match=words.replace("[", r"\[").replace("]", r"\]")):
        vv.ElevationMask(az, el)


def test_plain_numbers_are_refused():
    with pytest.raises(vv.errors.UnitsError, match="Quantity"):
        vv.ElevationMask([0, 90], [5, 10])
    m = vv.ElevationMask([0] * u.deg, [5] * u.deg)
    with pytest.raises(vv.errors.UnitsError, match="Quantity"):
        m(45.0)


def test_file_reader(tmp_path):
    path = tmp_path / "mask.txt"
    path.write_text("# site horizon, azimuth deg, elevation deg\n\n270 0\n0, 5  # north\n"
                    "90\t40\n180 5\n")
    m = vv.ElevationMask.from_file(path)
    assert m == vv.ElevationMask(*(np.array(c) * u.deg for c in HILL))


@pytest.mark.parametrize("text, words", [
    ("0 5\n90 40 3\n", "line 2: expected two numbers"),
    ("0 5\n\n# c\nninety 40\n", "line 4: 'ninety 40' is not two numbers"),
    ("0 5\n90 nan\n", "line 2: azimuth 90.0 deg, elevation nan deg is not finite"),
    ("0 5\n361 4\n", "line 2: azimuth 361 deg is outside"),
    ("0 5\n10 -91\n", "line 2: elevation -91 deg is outside"),
    ("# nothing\n\n", "holds no points"),
    ("0 5\n90 1\n90 2\n90 3\n", "line 2; .*line 3; .*line 4"),
])
def test_file_reader_names_the_line(tmp_path, text, words):
    path = tmp_path / "m.txt"
    path.write_text(text)
    with pytest.raises(InvalidInputError, match=words):
        vv.ElevationMask.from_file(path)


def test_file_reader_takes_a_byte_order_mark_and_says_how_to_keep_a_header(tmp_path):
    # was: a file saved as UTF-8 with a byte-order mark (Windows Notepad) was refused as
    # "line 1: '\ufeff0 5' is not two numbers" (audit40)
    path = tmp_path / "bom.txt"
    path.write_bytes(b"\xef\xbb\xbf270 0\r\n0 5\r\n90 40\r\n180 5\r\n")
    assert vv.ElevationMask.from_file(path) == vv.ElevationMask(
        *(np.array(c) * u.deg for c in HILL))
    path.write_text("azimuth elevation\n0 5\n")
    with pytest.raises(InvalidInputError, match="line 1: .* start a header or note with '#'"):
        vv.ElevationMask.from_file(path)


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such file.*elevation mask"):
        vv.ElevationMask.from_file(tmp_path / "none.txt")


# passes over a mask ---------------------------------------------------------------------------
def _check_against_brute(iss, site, sky, mask, mask_deg, hours=10.0, refraction=False):
    times, kinds = site.find_events(iss, T0, T0 + hours * u.h, min_elevation=mask,
                                    refraction=refraction)
    # every culmination lies inside a piece: kinds read (rise, culmination*, set)*
    text = "".join(map(str, kinds))
    assert re.fullmatch(r"(1*2)?(01*2)*(01*)?", text), text
    got_t, got_k = _events_s(times, kinds)
    want_t, want_k = _brute(sky, mask_deg, hours)
    assert got_t.size == want_t.size, (got_t, want_t)
    np.testing.assert_array_equal(got_k, want_k)
    assert np.abs(got_t - want_t).max() < TENTH_SECOND
    return got_t


def test_rise_and_set_on_the_mask_brute_force(iss, site, sky):
    mask = vv.ElevationMask(*(np.array(c) * u.deg for c in HILL))
    got = _check_against_brute(iss, site, sky, mask, _interp_mask(*HILL))
    assert got.size >= 6


def test_wrap_around_mask_brute_force(iss, site, sky):
    pts = ([20.0, 300.0, 340.0], [25.0, 0.0, 25.0])  # a wall across north, 340 -> 20 deg
    mask = vv.ElevationMask(*(np.array(c) * u.deg for c in pts))
    _check_against_brute(iss, site, sky, mask, _interp_mask(*pts))


def test_a_mountain_in_the_middle_splits_the_pass(iss, site, sky):
    flat = vv.find_passes(iss, site, T0, T0 + 10 * u.h)
    top = flat[np.argmax(flat["max_elevation"])]
    az_c = top["culmination_azimuth"].to_value(u.deg)
    el_c = top["max_elevation"].to_value(u.deg)
    pts = ([0.0, az_c - 6.0, az_c, az_c + 6.0], [0.0, 0.0, el_c + 5.0, 0.0])
    mask = vv.ElevationMask(*(np.array(c) * u.deg for c in pts))
    _check_against_brute(iss, site, sky, mask, _interp_mask(*pts))
    masked = vv.find_passes(iss, site, T0, T0 + 10 * u.h, min_elevation=mask)
    near = masked[np.abs((masked["rise_time"] - top["rise_time"]).to_value(u.s)) < 900]
    assert len(near) == 2
    # neither piece holds the hidden culmination: its highest point is at its set / rise
    assert near["culmination_time"].mask.all()
    assert near["set_time"][0] < top["culmination_time"] < near["rise_time"][1]
    edges = Time([near["set_time"][0], near["rise_time"][1]])
    np.testing.assert_allclose(near["max_elevation"].to_value(u.deg),
                               site.look(iss, edges).elevation.to_value(u.deg), atol=1e-4)


def test_a_dip_between_samples_is_found(iss, site, sky):
    """A narrow peak of the mask just over the culmination of a high pass (2 deg of azimuth
    wide, its vertex 0.05 deg above the track): the satellite is hidden for a fraction of a
    second, shorter than the sampling step; the sampled minimum is refined and the pass split."""
    flat = vv.find_passes(iss, site, T0, T0 + 10 * u.h)
    top = flat[np.argmax(flat["max_elevation"])]
    az_c = top["culmination_azimuth"].to_value(u.deg)
    el_c = top["max_elevation"].to_value(u.deg)
    pts = ([0.0, az_c - 1.01, az_c - 1.0, az_c, az_c + 1.0, az_c + 1.01],
           [0.0, 0.0, el_c - 0.2, el_c + 0.05, el_c - 0.2, 0.0])
    mask = vv.ElevationMask(*(np.array(c) * u.deg for c in pts))
    times, kinds = site.find_events(iss, T0, T0 + 10 * u.h, min_elevation=mask)
    t_s, k = _events_s(times, kinds)
    t_c = (top["culmination_time"] - T0).to_value(u.s)
    inner = np.abs(t_s - t_c) < 3.0
    np.testing.assert_array_equal(k[inner], [-1, 1])  # a set, then a rise, around the peak
    # against Skyfield sampled every 2 ms there
    fine = t_c - 3.0 + np.arange(0.0, 6.0, 0.002)
    a, z = _alt_az(sky, T0 + fine * u.s)
    g = a - _interp_mask(*pts)(z)
    flips = fine[np.flatnonzero((g[:-1] > 0) != (g[1:] > 0))] + 0.001
    assert flips.size == 2
    assert 0.02 < flips[1] - flips[0] < 1.0
    assert np.abs(t_s[inner] - flips).max() < 0.01


def test_a_step_of_the_mask_brute_force(iss, site, sky):
    """A building: vertical edges (two points at one azimuth), f not continuous there."""
    flat = vv.find_passes(iss, site, T0, T0 + 10 * u.h)
    top = flat[np.argmax(flat["max_elevation"])]
    az_c = top["culmination_azimuth"].to_value(u.deg)
    a0, a1 = (az_c - 15.0) % 360.0, (az_c + 15.0) % 360.0
    assert a0 < a1
    mask = vv.ElevationMask([0, a0, a0, a1, a1] * u.deg, [0, 0, 80, 80, 0] * u.deg)

    def mask_deg(az):
        return np.where((az >= a0) & (az <= a1), 80.0, 0.0)

    _check_against_brute(iss, site, sky, mask, mask_deg)


def test_mask_with_refraction_brute_force(iss, site):
    """The apparent elevation (look with the same refraction) is what meets the mask."""
    mask = vv.ElevationMask(*(np.array(c) * u.deg for c in HILL))
    times, kinds = site.find_events(iss, T0, T0 + 6 * u.h, min_elevation=mask,
                                    refraction="optical")
    t_s, k = _events_s(times, kinds)
    assert t_s.size >= 2
    for tt, sign in zip(t_s, k, strict=True):
        probe = T0 + (tt + np.array([-0.05, 0.05])) * u.s
        la = site.look(iss, probe, refraction="optical")
        g = la.elevation.to_value(u.deg) - mask(la.azimuth).to_value(u.deg)
        assert g[0] * sign < 0 < g[1] * sign, (tt, g)


def test_a_flat_mask_is_the_scalar_threshold_bit_for_bit(iss, site):
    scalar = vv.find_passes(iss, site, T0, T0 + 1 * u.day, min_elevation=10 * u.deg)
    for mask in (vv.ElevationMask([0] * u.deg, [10] * u.deg),
                 vv.ElevationMask([0, 90, 200] * u.deg, [10, 10, 10] * u.deg),
                 [10 * u.deg]):
        table = vv.find_passes(iss, site, T0, T0 + 1 * u.day, min_elevation=mask)
        for col in ("rise_time", "culmination_time", "set_time"):
            assert (table[col] == scalar[col]).all()
        np.testing.assert_array_equal(table["max_elevation"], scalar["max_elevation"])


def test_per_station_thresholds(iss, site):
    other = vv.GroundStation(45.0 * u.deg, -73.0 * u.deg, name="Montreal")
    mask = vv.ElevationMask(*(np.array(c) * u.deg for c in HILL))
    both = vv.find_passes(iss, [site, other], T0, T0 + 10 * u.h,
                          min_elevation=[mask, 15 * u.deg])
    alone_a = vv.find_passes(iss, site, T0, T0 + 10 * u.h, min_elevation=mask)
    alone_b = vv.find_passes(iss, other, T0, T0 + 10 * u.h, min_elevation=15 * u.deg)
    for alone, name in ((alone_a, "Philadelphia"), (alone_b, "Montreal")):
        mine = both[both["station"] == name]
        assert len(mine) == len(alone)
        for col in ("rise_time", "set_time"):
            assert np.abs((mine[col] - alone[col]).to_value(u.s)).max() < 1e-4
    per_station = vv.find_passes(iss, [site, other], T0, T0 + 10 * u.h,
                                 min_elevation=[12, 15] * u.deg)
    assert len(per_station) == len(
        vv.find_passes(iss, [site, other], T0, T0 + 10 * u.h,
                       min_elevation=[12 * u.deg, 15 * u.deg]))
    with pytest.raises(ShapeError, match="one threshold"):
        vv.find_passes(iss, [site, other], T0, T0 + 1 * u.h, min_elevation=[mask])
    with pytest.raises(vv.errors.UnitsError, match=r"min_elevation\[1\]"):
        vv.find_passes(iss, [site, other], T0, T0 + 1 * u.h, min_elevation=[mask, 5.0])


def test_cli_mask(tmp_path, capsys):
    from visviva import cli

    tle = tmp_path / "iss.tle"
    tle.write_text(f"ISS\n{ISS_1}\n{ISS_2}\n")
    path = tmp_path / "mask.txt"
    path.write_text("0 5\n90 40\n180 5\n270 0\n")
    args = ["passes", str(tle), "--lat", "40", "--lon", "-75", "--start",
            "2008-09-20T22:30:00", "--hours", "10"]
    assert cli.main([*args, "--mask", str(path)]) == 0
    out = capsys.readouterr().out
    assert "above the mask of" in out and "(0 to 40 deg)" in out
    path.write_text("0 5\n90 forty\n")
    assert cli.main([*args, "--mask", str(path)]) == 2
    assert "line 2" in capsys.readouterr().err
    assert cli.main([*args, "--mask", str(path), "--min-elevation", "5"]) == 2


def test_a_mask_below_the_refraction_models_is_refused(iss, site):
    low = vv.ElevationMask([0, 180] * u.deg, [-5, 3] * u.deg)
    with pytest.raises(InvalidInputError, match="elevation mask's lowest point .-5 deg."):
        site.find_events(iss, T0, T0 + 1 * u.h, min_elevation=low, refraction=True)


def test_a_sliver_of_sky_is_found(iss, site):
    """A 90 deg wall with a 0.002 deg slot at north: the ISS is seen for ~1 ms as it crosses
    north (the interval halving goes down to 1 ms wherever a crossing may hide)."""
    wall = vv.ElevationMask([0, 0.001, 359.999] * u.deg, [0, 89, 89] * u.deg)
    times, kinds = site.find_events(iss, T0, T0 + 10 * u.h, min_elevation=wall)
    assert kinds.size >= 2 and (kinds != 1).all()
    np.testing.assert_array_equal(kinds, np.tile([0, 2], kinds.size // 2))
    gaps = (times[1::2] - times[::2]).to_value(u.s)
    assert (gaps > 0).all() and (gaps < 0.01).all()
    az = site.look(iss, times[::2] + (times[1::2] - times[::2]) * 0.5).azimuth.to_value(u.deg)
    assert (np.minimum(az, 360 - az) < 0.001).all()


def test_dask_path_takes_masks(iss, site):
    pytest.importorskip("distributed")
    from distributed import Client, LocalCluster

    from visviva.ground import find_passes_dask

    other = vv.GroundStation(45.0 * u.deg, -73.0 * u.deg, name="Montreal")
    sats = [vv.Satellite.from_tle(ISS_1, ISS_2, name=f"ISS-{k}") for k in range(2)]
    mask = vv.ElevationMask(*(np.array(c) * u.deg for c in HILL))
    thresholds = [mask, 15 * u.deg]
    mem = vv.find_passes(sats, [site, other], T0, T0 + 4 * u.h, min_elevation=thresholds)
    with LocalCluster(n_workers=1, processes=False, threads_per_worker=1,
                      dashboard_address=None) as cl, Client(cl) as client:
        out = find_passes_dask(sats, [site, other], T0, T0 + 4 * u.h, thresholds,
                               chunk_size=1, client=client)
    assert len(out) == len(mem) > 2
    for tab in (mem, out):
        tab.sort(["satellite", "station", "set_time"])
    assert np.abs((out["set_time"] - mem["set_time"]).to_value(u.s)).max() < 1e-6


def test_a_bumpy_mask_brute_force(iss, site, sky):
    """36 points at random between 0 and 10 deg: low passes skim along it, crossing it again
    and again (many intervals halved and refined together)."""
    az = np.arange(0.0, 360.0, 10.0)
    el = np.random.default_rng(3).uniform(0.0, 10.0, az.size)
    mask = vv.ElevationMask(az * u.deg, el * u.deg)
    got = _check_against_brute(iss, site, sky, mask, _interp_mask(az, el))
    assert got.size >= 14
