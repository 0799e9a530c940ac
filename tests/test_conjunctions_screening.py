"""Screening against brute-force one-second sampling with sgp4, covariance tools, CLI."""

from __future__ import annotations

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv
from visviva.cli import main
from visviva.conjunctions import (
    inertial_to_rtn,
    propagate_covariance,
    rtn_to_inertial,
    state_transition_matrix,
)
from visviva.conjunctions.synthetic import synthetic_catalog
from visviva.core.universal import propagate_one

ONE_METER = 1e-3  # km
ISS_L1 = "1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927"
ISS_L2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537"


def brute_force_minima(r, ts, threshold):
    """Local minima of every pair's sampled distance below ``threshold``: (i, j, t, d)."""
    out = []
    for i in range(r.shape[0]):
        d = np.linalg.norm(r[i + 1:] - r[i], axis=-1)
        for jj in np.flatnonzero(d.min(axis=1) < threshold):
            dd = d[jj]
            left = np.r_[True, dd[1:] <= dd[:-1]]
            right = np.r_[dd[:-1] < dd[1:], True]
            for k in np.flatnonzero((dd < threshold) & left & right):
                out.append((i, i + 1 + jj, ts[k], dd[k]))
    return out


@pytest.fixture(scope="module")
def catalog():
    return synthetic_catalog(120, seed=4, crossing_pairs=4)


@pytest.fixture(scope="module")
def screened(catalog):
    t0 = catalog.epochs[0]
    return vv.screen_conjunctions(catalog, None, t0, t0 + 3 * u.hour, threshold=20 * u.km)


def test_screening_misses_nothing_one_second_sampling_finds(catalog, screened):
    t0 = catalog.epochs[0]
    ts = np.arange(0.0, 3 * 3600 + 1)
    jd = np.full(ts.size, t0.utc.jd1)
    fr = t0.utc.jd2 + ts / 86400.0
    _, r, _ = catalog.satrec_array.sgp4(jd, fr)
    brute = brute_force_minima(r, ts, 20.0)
    assert len(brute) >= 4  # the crossing pairs meet
    tca_s = (screened["tca"] - t0).to_value(u.s)
    miss = screened["miss_distance"].to_value(u.km)
    for i, j, t, dmin in brute:
        sel = (screened["index1"] == i) & (screened["index2"] == j) & (np.abs(tca_s - t) <= 1.0)
        assert sel.sum() == 1, (i, j, t, dmin)
        # the refined miss is the true minimum: never above a sampled distance
        assert miss[sel][0] <= dmin + ONE_METER
    assert len(screened) == len(brute)


def test_tca_is_a_minimum_to_a_millisecond_and_rtn_is_consistent(catalog, screened):
    for row in screened[:5]:
        s1, s2 = catalog[int(row["index1"])], catalog[int(row["index2"])]
        t = row["tca"] + np.array([-1e-3, 0.0, 1e-3]) * u.s
        a, b = s1.teme(t), s2.teme(t)
        d = np.linalg.norm((b.r - a.r).to_value(u.km), axis=-1)
        assert d[1] <= d[0] + 1e-9 and d[1] <= d[2] + 1e-9
        assert d[1] == pytest.approx(row["miss_distance"].to_value(u.km), abs=ONE_METER)
        rtn = np.array([row["radial"].to_value(u.km), row["in_track"].to_value(u.km),
                        row["cross_track"].to_value(u.km)])
        assert np.linalg.norm(rtn) == pytest.approx(d[1], abs=1e-9)


def test_primary_against_catalog_finds_its_rows(catalog, screened):
    t0 = catalog.epochs[0]
    k = int(screened["index1"][0])
    rest = vv.Catalog([s for n, s in enumerate(catalog) if n != k])
    tab = vv.screen_conjunctions(catalog[k], rest, t0, t0 + 3 * u.hour, threshold=20 * u.km)
    expect = screened[(screened["index1"] == k) | (screened["index2"] == k)]
    assert len(tab) == len(expect)
    assert np.allclose(np.sort(tab["miss_distance"].value), np.sort(expect["miss_distance"].value))


def test_screen_rejects_bad_windows(catalog):
    t0 = catalog.epochs[0]
    with pytest.raises(vv.InvalidInputError, match="after t0"):
        vv.screen_conjunctions(catalog, None, t0, t0 - 1 * u.hour)
    with pytest.raises(vv.InvalidInputError, match="Time"):
        vv.screen_conjunctions(catalog, None, 0, 1)


def test_cli_screen(tmp_path, capsys):
    from sgp4.exporter import export_tle

    cat = synthetic_catalog(0, crossing_pairs=2, seed=1)
    lines = []
    for s in cat:
        l1, l2 = export_tle(s.satrec)
        lines += [s.name, l1, l2]
    path = tmp_path / "cat.tle"
    path.write_text("\n".join(lines) + "\n")
    out_csv = tmp_path / "out.csv"
    code = main(["screen", str(path), "--threshold", "20", "--start", "2024-01-01T00:00:00",
                 "--hours", "2", "--csv", str(out_csv), "--quiet"])
    assert code == 0
    text = capsys.readouterr().out
    assert "close approaches below 20 km" in text and "SYN60000" in text
    assert out_csv.read_text().startswith("object1,object2,tca")
    assert main(["screen", str(tmp_path / "none.tle"), "--start", "2024-01-01",
                 "--hours", "1"]) == 2
    capsys.readouterr()
    # an unknown --primary named the key only ("visviva screen: 'NOPE'"); an unwritable --csv
    # was a FileNotFoundError traceback (exit 1)
    assert main(["screen", str(path), "--primary", "NOPE", "--start", "2024-01-01T00:00:00",
                 "--hours", "1", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "no object named 'NOPE'" in err and "SYN60000" in err
    assert main(["screen", str(path), "--start", "2024-01-01T00:00:00", "--hours", "1",
                 "--quiet", "--csv", str(tmp_path / "no_such_dir" / "x.csv")]) == 2
    err = capsys.readouterr().err
    assert "cannot write" in err and "no_such_dir" in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize(("start", "hours", "why"), [
    ("2019-13-10", "2", "is not an ISO time"),
    ("2024-01-01", "inf", "--hours: 'inf' is not a positive number of hours"),
    ("2024-01-01", "-1", "--hours: '-1' is not a positive number of hours"),
    # 114,000 years at 60 s: was a numpy MemoryError traceback (447 GiB for the time grid)
    ("2024-01-01", "1e9", "more than half of this machine's memory"),
])
def test_screen_cli_bad_window_is_one_short_reason(tmp_path, capsys, start, hours, why):
    from visviva.cli import main

    path = tmp_path / "cat.tle"
    path.write_text("ISS\n" + ISS_L1 + "\n" + ISS_L2 + "\n")
    if not why.startswith("--hours:"):
        assert main(["screen", str(path), "--start", start, "--hours", hours, "--quiet"]) == 2
    else:  # (refused as the arguments are read)
        with pytest.raises(SystemExit) as exc:
            main(["screen", str(path), "--start", start, "--hours", hours, "--quiet"])
        assert exc.value.code == 2
    err = capsys.readouterr().err
    # one short reason; astropy's warnings on the way (ERFA's "dubious year" for a window
    # ending in the year 116,000) come before it, one line each
    lines = [ln for ln in err.strip().splitlines() if not ln.startswith("visviva: warning: ")]
    assert len(lines) == 1 and why in lines[0]


def test_an_empty_catalogue_is_refused_not_screened(tmp_path, capsys):
    # `visviva screen` on an empty TLE file printed "0 close approaches ... (0 objects)" and
    # exited 0, as if a catalogue had been screened; `visviva passes` exits 2 there

    t0 = Time("2024-01-01T00:00:00", scale="utc")
    with pytest.raises(vv.InvalidInputError, match="primaries hold no object"):
        vv.screen_conjunctions(vv.Catalog([]), None, t0, t0 + 1 * u.h)
    path = tmp_path / "empty.tle"
    path.write_text("")
    assert main(["screen", str(path), "--start", "2024-01-01T00:00:00", "--hours", "1",
                 "--quiet"]) == 2
    assert "empty.tle: the file is empty" in capsys.readouterr().err  # (named: audit14)


def test_an_object_whose_sgp4_fails_inside_the_window_is_named_in_a_warning():
    # its samples after the failure (decay) were skipped silently: the rest of the window was
    # not screened for it and the table did not say so (audit10)
    import importlib.resources

    text = (importlib.resources.files("sgp4") / "SGP4-VER.TLE").read_text()
    lines = [ln[:69] for ln in text.splitlines() if ln[:2] in ("1 ", "2 ")]
    tles = {a[2:7]: (a, b) for a, b in zip(lines[::2], lines[1::2], strict=True)}
    decaying = vv.Satellite.from_tle(*tles["28350"], name="DECAYING")  # fails 2006-06-17 05:46
    t0 = decaying.epoch + 0.3 * u.day
    others = synthetic_catalog(5, seed=1, epoch=t0.isot)
    with pytest.warns(RuntimeWarning, match=r"SGP4 failed inside the window for 1 object\(s\) "
                      r"\('DECAYING' from 2006-06-17T05:4"):
        vv.screen_conjunctions(vv.Catalog([decaying]), others, t0, t0 + 2 * u.day)
    with pytest.warns(RuntimeWarning, match="'DECAYING' from"):  # as a secondary, self-screen
        vv.screen_conjunctions(vv.Catalog([*others, decaying]), None, t0, t0 + 2 * u.day)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # before the failure: nothing to say
        vv.screen_conjunctions(vv.Catalog([decaying]), others, t0, t0 + 0.5 * u.day)


def test_screen_threshold_and_step_need_units():
    sat = vv.Satellite.from_tle(ISS_L1, ISS_L2)
    t0 = Time("2024-01-01T00:00:00", scale="utc")
    with pytest.raises(vv.UnitsError, match="threshold"):
        vv.screen_conjunctions(sat, sat, t0, t0 + 1 * u.h, threshold=5)
    with pytest.raises(vv.UnitsError, match="step"):
        vv.screen_conjunctions(sat, sat, t0, t0 + 1 * u.h, 5 * u.km, step=60)
    with pytest.raises(vv.UnitsError, match="threshold"):
        vv.screen_conjunctions(sat, sat, t0, t0 + 1 * u.h, threshold=5 * u.s)
    # audit54: one message for both ("threshold and step must be positive.") named neither
    # the value nor which of the two
    with pytest.raises(vv.errors.InvalidInputError, match=r"threshold must be positive; got 0 km"):
        vv.screen_conjunctions(sat, sat, t0, t0 + 1 * u.h, threshold=0 * u.m)
    with pytest.raises(vv.errors.InvalidInputError, match=r"threshold .* got -0\.005 km"):
        vv.screen_conjunctions(sat, sat, t0, t0 + 1 * u.h, threshold=-5 * u.m)
    with pytest.raises(vv.errors.InvalidInputError, match=r"step must be positive; got -60 s"):
        vv.screen_conjunctions(sat, sat, t0, t0 + 1 * u.h, 5 * u.km, step=-1 * u.min)


# --- covariance tools ------------------------------------------------------------------------
R0 = np.array([6778.0, 120.0, -40.0])
V0 = np.array([0.1, 7.2, 2.5])
GM = 398600.4418


def test_rtn_round_trip_and_radial_axis():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(6, 6))
    c = a @ a.T
    back = inertial_to_rtn(rtn_to_inertial(c, R0 * u.km, V0 * u.km / u.s), R0, V0)
    assert np.allclose(back, c, rtol=1e-12, atol=1e-12)
    # a pure radial variance lies along r in the inertial frame
    crtn = np.zeros((3, 3))
    crtn[0, 0] = 1.0
    ci = rtn_to_inertial(crtn, R0, V0)
    rhat = R0 / np.linalg.norm(R0)
    assert np.allclose(ci, np.outer(rhat, rhat), atol=1e-15)


def test_stm_matches_finite_differences_of_the_universal_propagator():
    dt = 2400.0
    phi, r1, v1 = state_transition_matrix(R0 * u.km, V0 * u.km / u.s, dt * u.s, GM)
    ro, vo = np.empty(3), np.empty(3)
    propagate_one(R0, V0, GM, dt, ro, vo)
    assert np.allclose(r1, ro, atol=1e-6) and np.allclose(v1, vo, atol=1e-9)
    x0 = np.r_[R0, V0]
    fd = np.empty((6, 6))
    for k in range(6):
        h = 1e-3 if k < 3 else 1e-6
        cols = []
        for sgn in (1, -1):
            x = x0.copy()
            x[k] += sgn * h
            propagate_one(x[:3].copy(), x[3:].copy(), GM, dt, ro, vo)
            cols.append(np.r_[ro, vo])
        fd[:, k] = (cols[0] - cols[1]) / (2 * h)
    assert np.allclose(phi, fd, rtol=1e-6, atol=1e-8 * np.abs(fd).max())
    # symplectic: Phi^T J Phi = J
    j = np.block([[np.zeros((3, 3)), np.eye(3)], [-np.eye(3), np.zeros((3, 3))]])
    assert np.allclose(phi.T @ j @ phi, j, atol=1e-8)


def test_propagated_covariance_grows_along_track():
    c = np.diag([100.0, 100.0, 100.0, 1e-4, 1e-4, 1e-4])  # m, m/s
    later = propagate_covariance(c, R0, V0, 3000 * u.s, vv.EARTH)
    phi, r1, v1 = state_transition_matrix(R0, V0, 3000.0, vv.EARTH)
    rtn = inertial_to_rtn(later, r1, v1)
    assert rtn[1, 1] > 10 * rtn[0, 0]
    assert np.all(np.linalg.eigvalsh(later) > 0)


def test_cli_screen_reads_every_catalogue_kind(tmp_path, capsys, write_catalog_files):
    """``visviva screen`` on the same catalogue as TLE, OMM JSON, CSV and CelesTrak XML (no
    telling suffix): the same close approaches, line for line."""
    cat = synthetic_catalog(0, crossing_pairs=2, seed=1)
    outputs = {}
    for kind, path in write_catalog_files(list(cat)).items():
        assert main(["screen", str(path), "--threshold", "20", "--start",
                     "2024-01-01T00:00:00", "--hours", "2", "--quiet"]) == 0
        outputs[kind] = capsys.readouterr().out
    assert set(outputs) == {"tle", "json", "csv", "ndm"}
    assert "SYN60000" in outputs["tle"] and "(4 objects)" in outputs["tle"]
    assert not outputs["tle"].startswith("0 close")
    for kind, out in outputs.items():
        assert out == outputs["tle"], kind
    # a CSV with a bad record: exit 2, one line naming the file, the record and its line
    bad = tmp_path / "bad.csv"
    text = write_catalog_files(list(cat), "bad")["csv"].read_text().splitlines()
    text[2] = text[2].replace("SYN60001,", "SYN60001,,", 1)
    bad.write_text("\n".join(text) + "\n")
    assert main(["screen", str(bad), "--start", "2024-01-01T00:00:00", "--hours", "1",
                 "--quiet"]) == 2
    err = capsys.readouterr().err
    assert str(bad) in err and "record 2" in err and "line 3" in err, err
    assert len(err.strip().splitlines()) == 1


def test_tca_is_the_minimum_of_sgp4_positions_for_deep_space_orbits():
    # TCA was the root of rho . rho_dot with SGP4's velocities, which leave out the rates of
    # some periodic terms: for 16925 (e = 0.56, deep space) 4-17 s off the minimum of the
    # positions' distance, with miss distances up to 250 m too large (audit10)
    import importlib.resources

    text = (importlib.resources.files("sgp4") / "SGP4-VER.TLE").read_text()
    lines = [ln[:69] for ln in text.splitlines() if ln[:2] in ("1 ", "2 ")]
    tles = {a[2:7]: (a, b) for a, b in zip(lines[::2], lines[1::2], strict=True)}
    sats = [vv.Satellite.from_tle(*tles[k], name=k)
            for k in ("00005", "06251", "09880", "16925", "28057", "29238")]
    cat = vv.Catalog(sats)
    t0 = Time("2006-07-01T00:00:00", scale="utc")
    tab = vv.screen_conjunctions(cat, None, t0, t0 + 1 * u.day, threshold=3000 * u.km)
    inner = tab[(tab["tca"] > t0 + 1 * u.s) & (tab["tca"] < t0 + (86400 - 1) * u.s)]
    assert len(inner) >= 10 and "16925" in set(inner["object1"]) | set(inner["object2"])
    for row in inner:
        a, b = sats[row["index1"]], sats[row["index2"]]
        t = row["tca"] + [-0.05, 0.0, 0.05] * u.s
        d = np.linalg.norm((b.teme(t).r - a.teme(t).r).to_value(u.km), axis=-1)
        assert d[1] <= d[0] + 1e-9 and d[1] <= d[2] + 1e-9, (row["object1"], row["object2"])
        assert row["miss_distance"].to_value(u.km) == pytest.approx(d[1], abs=1e-9)


def _same_rows(a, b):
    assert len(a) == len(b)
    assert list(a["index1"]) == list(b["index1"]) and list(a["index2"]) == list(b["index2"])
    assert list(a["object1"]) == list(b["object1"]) and list(a["object2"]) == list(b["object2"])
    for col in ("miss_distance", "relative_speed", "radial", "in_track", "cross_track"):
        assert np.array_equal(a[col].value, b[col].value), col
    assert np.array_equal((a["tca"] - b["tca"]).to_value(u.s), np.zeros(len(a)))


def test_a_catalogue_against_itself_reports_each_pair_once(catalog, screened):
    """Regression: screen_conjunctions(cat, cat) reported every pair twice (once from each
    object's side) where screen_conjunctions(cat, None) reports it once."""
    t0 = catalog.epochs[0]
    twice = vv.screen_conjunctions(catalog, catalog, t0, t0 + 3 * u.hour, threshold=20 * u.km)
    assert len(screened) >= 4
    _same_rows(twice, screened)
    assert np.all(twice["index1"] < twice["index2"])


def test_one_file_read_twice_is_one_catalogue(tmp_path):
    """Distinct Satellite objects with equal element sets are one object each: no pair of an
    object with itself, each pair once, the rows of the all-against-all screening."""
    from sgp4.exporter import export_tle

    cat = synthetic_catalog(10, crossing_pairs=2, seed=1)
    text = "".join(f"{s.name}\n" + "\n".join(export_tle(s.satrec)) + "\n" for s in cat)
    path = tmp_path / "cat.tle"
    path.write_text(text)
    a, b = vv.read_tle_file(path), vv.read_tle_file(path)
    assert a[0] is not b[0]
    t0 = a.epochs[0]
    window = (t0, t0 + 2 * u.hour)
    alone = vv.screen_conjunctions(a, None, *window, threshold=20 * u.km)
    assert len(alone) >= 2
    _same_rows(vv.screen_conjunctions(a, b, *window, threshold=20 * u.km), alone)
    # overlapping lists: the pairs inside the overlap once, an object never against itself
    k1, k2 = int(alone["index1"][0]), int(alone["index2"][0])
    prim = vv.Catalog([a[k1], a[k2]])
    both = vv.screen_conjunctions(prim, b, *window, threshold=20 * u.km)
    names = {frozenset((r["object1"], r["object2"])) for r in both}
    assert len(names) == len(both)  # no unordered pair twice
    assert all(r["object1"] != r["object2"] for r in both)
    expect = alone[(alone["index1"] == k1) | (alone["index2"] == k1)
                   | (alone["index1"] == k2) | (alone["index2"] == k2)]
    assert len(both) == len(expect)
    assert np.allclose(np.sort(both["miss_distance"].value),
                       np.sort(expect["miss_distance"].value), rtol=0, atol=1e-9)


def test_screening_samples_beyond_any_earth_orbit_are_failures():
    """SGP4 positions ~3e8 km away (the ISS's 2024 set run back to 1900) came back with error
    code 0 and were screened as states; Satellite.teme refuses them. The screening source now
    marks them failed (NaN), as it does sgp4's errors, so the failure warning names them."""
    from visviva.conjunctions.sources import SgpSource
    from visviva.satellites.utc_days import time_to_utc_days

    iss24 = vv.Satellite.from_tle(
        "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
        "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340", name="ISS")
    jd0, fr0 = (float(x) for x in time_to_utc_days(iss24.epoch))
    src = SgpSource(vv.Catalog([iss24]), jd0, fr0)
    ts = np.array([0.0, 600.0, -45290.5 * 86400.0])  # the epoch, 10 min later, 1900
    r, v = src.sample(ts)
    assert np.all(np.linalg.norm(r[0, :2], axis=-1) < 7000.0)
    assert np.isnan(r[0, 2]).all() and np.isnan(v[0, 2]).all()


def test_screening_stale_element_sets_warns_at_the_callers_line():
    """find_passes warned about element sets far from its window; screen_conjunctions screened
    the ISS's 2024-01 set in June 2024 (152 days out, SGP4 kilometres to tens of km off)
    without a word. Now the same StaleElementSetWarning, pointing at the caller."""
    import warnings

    iss24 = vv.Satellite.from_tle(
        "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
        "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340", name="ISS")
    other = vv.Satellite.from_tle(
        "1 25544U 98067A   24150.50000000  .00016717  00000-0  10270-3 0  9001",
        "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340", name="FRESH",
        verify_checksum=False)
    t0 = Time("2024-06-01T00:00:00", scale="utc")
    for args in ((vv.Catalog([iss24, other]), None), ([other], [iss24])):
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            vv.screen_conjunctions(*args, t0, t0 + 1 * u.h)
        stale = [x for x in w if issubclass(x.category, vv.StaleElementSetWarning)]
        assert len(stale) == 1 and stale[0].filename == __file__
        assert "1 of " in str(stale[0].message) and "ISS (152 d)" in str(stale[0].message)
        assert "close approaches can be kilometres off" in str(stale[0].message)
