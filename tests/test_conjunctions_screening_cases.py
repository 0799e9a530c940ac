"""Screening cases a catalogue holds: a dragged orbit decayed below its epoch's perigee, the
window's edges, an empty side, the Dask path (audit39; brute force on SGP4 as the reference)."""

from __future__ import annotations

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv
from visviva.conjunctions.synthetic import synthetic_catalog

ONE_METER = 1e-3  # km

# B* 0.01 at 400 km (epoch 2024-01-01), and a 97 deg circle at 285 km made on 2024-01-16 to pass
# through it: over fifteen days SGP4 lowers the first by 112 km, below the perigee of its
# epoch's mean elements (6775 km), where the second flies (6663 km)
DRAGGED = ("1 00001U          24001.00000000  .00000000  00000-0  10000-1 0    03",
           "2 00001  53.0000   0.0000 0005000   0.0000   0.0000 15.55742212    00")
CROSSING = ("1 00002U          24016.14047661  .00000000  00000-0  10000-4 0    02",
            "2 00002  97.0000 285.4375 0001000   0.0000   0.1300 15.95030490    05")
# two circles at 700 km, inclined 53 and 127 deg on one node line: they meet head-on at 9 km/s
HEAD_ON = (("1 00001U          24001.00000000  .00000000  00000-0  10000-4 0    06",
            "2 00001  53.0000   0.0000 0005000   0.0000   0.0000 14.57889791    05"),
           ("1 00002U          24001.00000000  .00000000  00000-0  10000-4 0    07",
            "2 00002 127.0000   0.0000 0005000   0.0000   0.0100 14.57889791    09"))


def _sgp4_distance(a, b, t0, ts):
    from visviva.satellites.utc_days import time_to_utc_days

    jd, fr = (float(x) for x in time_to_utc_days(t0))
    jds = np.full(ts.size, jd)
    _, r1, _ = a.satrec.sgp4_array(jds, fr + ts / 86400.0)
    _, r2, _ = b.satrec.sgp4_array(jds, fr + ts / 86400.0)
    return np.linalg.norm(r2 - r1, axis=-1)


def _brute_minima(a, b, t0, span_s, threshold_km):
    """Local minima below the threshold of the SGP4 distance sampled every second, each
    refined on a 1 ms grid: (t s, miss km)."""
    ts = np.arange(0.0, span_s + 0.5)
    d = _sgp4_distance(a, b, t0, ts)
    out = []
    for k in np.flatnonzero(np.r_[True, d[1:] <= d[:-1]] & np.r_[d[:-1] < d[1:], True]):
        fine = np.linspace(max(ts[k] - 1, 0), min(ts[k] + 1, span_s), 2001)
        dd = _sgp4_distance(a, b, t0, fine)
        if dd.min() < threshold_km:
            out.append((fine[dd.argmin()], dd.min()))
    return out


def test_an_orbit_decayed_below_its_epoch_perigee_is_still_screened():
    # the apogee/perigee and orbit-path filters took the shells and the path from the mean
    # elements at epoch: a 15-day-old element set (not stale) with B* 0.01 had sunk 112 km
    # below them, and all seven approaches below 5 km (0.53 km the closest) were dropped
    # without a word (0 rows; audit39)
    a = vv.Satellite.from_tle(*DRAGGED, name="DRAGGED")
    b = vv.Satellite.from_tle(*CROSSING, name="CROSSING")
    t0 = Time("2024-01-16T00:00:00", scale="utc")
    assert a.satrec.altp * a.satrec.radiusearthkm - (b.satrec.alta * b.satrec.radiusearthkm) > 100
    tab = vv.screen_conjunctions([a], [b], t0, t0 + 6 * u.hour, 5 * u.km)
    brute = _brute_minima(a, b, t0, 6 * 3600.0, 5.0)
    assert len(brute) == 7 and min(m for _, m in brute) < 0.6
    assert len(tab) == len(brute)
    tca = (tab["tca"] - t0).to_value(u.s)
    miss = tab["miss_distance"].to_value(u.km)
    for (t, m), tc, mi in zip(brute, tca, miss, strict=True):
        assert abs(tc - t) < 2e-3  # the reference's grid
        assert abs(mi - m) < ONE_METER
    # the same pair in a catalogue screened against itself
    both = vv.screen_conjunctions(vv.Catalog([a, b]), None, t0, t0 + 6 * u.hour, 5 * u.km)
    assert len(both) == 7


def test_filter_statistics_counts_the_pairs_the_screen_keeps():
    # leftfix7: filter_statistics used the mean-element filters at epoch while the screen widens
    # them per object from its samples (audit39): it counted the dragged pair, which the screen
    # finds seven times, as pruned by both filters; now it samples and widens as the screen does
    # (step_s=None still gives the unwidened mean-element counts)
    from visviva.conjunctions.screening import filter_statistics
    from visviva.conjunctions.sources import SgpSource
    from visviva.satellites.utc_days import time_to_utc_days

    a = vv.Satellite.from_tle(*DRAGGED, name="DRAGGED")
    b = vv.Satellite.from_tle(*CROSSING, name="CROSSING")
    t0 = Time("2024-01-16T00:00:00", scale="utc")
    jd, fr = (float(x) for x in time_to_utc_days(t0))
    src1, src2 = SgpSource(vv.Catalog([a]), jd, fr), SgpSource(vv.Catalog([b]), jd, fr)
    assert filter_statistics(src1, src2, 6 * 3600.0, 5.0) == (1, 1)
    assert filter_statistics(src1, src2, 6 * 3600.0, 5.0, step_s=None) == (0, 0)
    both = SgpSource(vv.Catalog([a, b]), jd, fr)
    assert filter_statistics(both, both, 6 * 3600.0, 5.0) == (1, 1)
    with pytest.raises(vv.errors.InvalidInputError, match="step_s must be > 0"):
        filter_statistics(both, both, 6 * 3600.0, 5.0, step_s=0.0)


def test_filters_keep_what_the_samples_show_and_only_that():
    # the widening comes from the samples: ordinary LEO objects (short-period terms ~10 km)
    # keep their mean-element filters unchanged
    from visviva.conjunctions.screening import _bounds
    from visviva.conjunctions.sources import SgpSource
    from visviva.satellites.utc_days import time_to_utc_days

    cat = synthetic_catalog(40, seed=1)
    jd, fr = (float(x) for x in time_to_utc_days(cat.epochs[0]))
    src = SgpSource(cat, jd, fr)
    r, _ = src.sample(np.arange(0.0, 86401.0, 60.0))
    q, big, _, extra = _bounds(src, 60.0, r)
    q0, big0 = src.shells()
    assert np.all(extra == 0.0)
    assert np.all(q == q0) and np.all(big == big0)  # J2's short-period terms: in the margin
    rad = np.linalg.norm(r, axis=-1)
    assert np.all(q - rad.min(axis=1) < 12.0) and np.all(rad.max(axis=1) - big < 12.0)


@pytest.mark.parametrize(("start", "end"), [(0.3, 600.0), (-600.0, -0.3), (-0.2, 0.2)])
def test_minima_at_the_window_edges_are_reported_at_the_edge(start, end):
    # a head-on pair (9 km/s) whose closest approach (0.98 km) lies just outside the window, or
    # a window of 0.4 s around it: the edge distance is the window's minimum, and it is the row
    a = vv.Satellite.from_tle(*HEAD_ON[0], name="PROGRADE")
    b = vv.Satellite.from_tle(*HEAD_ON[1], name="RETROGRADE")
    t_ref = Time("2024-01-01T00:30:00", scale="utc")
    full = vv.screen_conjunctions([a], [b], t_ref, t_ref + 0.5 * u.hour, 10 * u.km)
    assert len(full) == 1 and full["relative_speed"][0] > 9 * u.km / u.s
    tca = full["tca"][0]
    t0, t1 = tca + start * u.s, tca + end * u.s
    tab = vv.screen_conjunctions([a], [b], t0, t1, 10 * u.km)
    span = (t1 - t0).to_value(u.s)
    ts = np.linspace(0.0, span, 4001)
    d = _sgp4_distance(a, b, t0, ts)
    got = (tab["tca"] - t0).to_value(u.s)
    k = int(np.argmin(np.abs(got - ts[d.argmin()])))
    assert abs(got[k] - ts[d.argmin()]) <= max(1e-3, span / 4000)
    assert tab["miss_distance"][k].to_value(u.km) <= d.min() + ONE_METER


def test_an_empty_side_is_named_not_taken_for_another_frame():
    # an empty list of secondaries was refused as "GCRS ephemerides" against SGP4 objects
    cat = synthetic_catalog(3, seed=1)
    t0 = cat.epochs[0]
    with pytest.raises(vv.InvalidInputError, match="the secondaries hold no object"):
        vv.screen_conjunctions(cat, [], t0, t0 + 1 * u.hour)


def test_dask_client_gives_the_serial_table():
    distributed = pytest.importorskip("distributed")
    cat = synthetic_catalog(30, seed=4, crossing_pairs=3)
    t0 = cat.epochs[0]
    t1 = t0 + 2 * u.hour
    serial = vv.screen_conjunctions(cat, None, t0, t1, 20 * u.km)
    serial2 = vv.screen_conjunctions(cat[-4:], cat, t0, t1, 20 * u.km)
    assert len(serial) >= 3 and len(serial2) >= 2
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        par = vv.screen_conjunctions(cat, None, t0, t1, 20 * u.km, client=client)
        par2 = vv.screen_conjunctions(cat[-4:], cat, t0, t1, 20 * u.km, client=client)
    for a, b in ((serial, par), (serial2, par2)):
        assert list(a["object1"]) == list(b["object1"])
        assert list(a["object2"]) == list(b["object2"])
        assert np.all(a["miss_distance"] == b["miss_distance"])
        assert np.all((a["tca"] - b["tca"]).to_value(u.s) == 0.0)


def test_a_long_window_from_the_epochs_is_stale_at_its_far_end():
    # the staleness was measured from the window's nearer end: a 40-day window starting at the
    # epochs was screened without a word, its last ten days 30-40 days from the element sets
    import warnings

    cat = synthetic_catalog(2, seed=1)
    t0 = cat.epochs[0]
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        vv.screen_conjunctions(cat, None, t0, t0 + 40 * u.day, 5 * u.km)
    stale = [x for x in w if issubclass(x.category, vv.StaleElementSetWarning)]
    assert len(stale) == 1 and "2 of 2" in str(stale[0].message)
    assert "(40 d)" in str(stale[0].message) and stale[0].filename == __file__
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # within 30 days of the epochs: nothing to say
        vv.screen_conjunctions(cat, None, t0, t0 + 2 * u.hour, 5 * u.km)


def test_a_decaying_object_is_named_from_its_last_screened_sample():
    # the screening of an object stops at its last sample before SGP4 fails (the interval that
    # ends on the failed sample is not scanned); the warning named the failed sample's time
    import importlib.resources
    import re

    from visviva.satellites.utc_days import time_to_utc_days

    text = (importlib.resources.files("sgp4") / "SGP4-VER.TLE").read_text()
    lines = [ln[:69] for ln in text.splitlines() if ln[:2] in ("1 ", "2 ")]
    tles = {a[2:7]: (a, b) for a, b in zip(lines[::2], lines[1::2], strict=True)}
    decaying = vv.Satellite.from_tle(*tles["28350"], name="DECAYING")
    t0 = decaying.epoch + 0.3 * u.day
    t1 = t0 + 2 * u.day
    others = synthetic_catalog(2, seed=1, epoch=t0.isot)
    with pytest.warns(RuntimeWarning, match="'DECAYING' from") as record:
        vv.screen_conjunctions(vv.Catalog([decaying]), others, t0, t1)
    named = Time(re.search(r"'DECAYING' from (\S+?)[,)]", str(record[0].message)).group(1))
    n_steps = int(np.ceil((t1 - t0).to_value(u.s) / 60.0)) + 1
    ts = np.arange(n_steps) * ((t1 - t0).to_value(u.s) / (n_steps - 1))
    jd, fr = (float(x) for x in time_to_utc_days(t0))
    err, _, _ = decaying.satrec.sgp4_array(np.full(ts.size, jd), fr + ts / 86400.0)
    last_good = ts[np.flatnonzero(err != 0)[0] - 1]
    assert abs((named - t0).to_value(u.s) - last_good) < 1.0


def test_array_windows_and_thresholds_are_refused_clearly():
    # numpy's "only 0-dimensional arrays can be converted to Python scalars" before
    cat = synthetic_catalog(2, seed=1)
    t0 = cat.epochs[0]
    with pytest.raises(vv.InvalidInputError, match="threshold must be one value"):
        vv.screen_conjunctions(cat, None, t0, t0 + 1 * u.hour, [5, 6] * u.km)
    with pytest.raises(vv.InvalidInputError, match="step must be one value"):
        vv.screen_conjunctions(cat, None, t0, t0 + 1 * u.hour, step=[60, 30] * u.s)
    with pytest.raises(vv.InvalidInputError, match="single times"):
        vv.screen_conjunctions(cat, None, t0 + [0, 1] * u.s, t0 + 1 * u.hour)


def test_worker_blocks_in_threads_never_mix_two_screenings():
    # A Dask worker runs blocks in several threads sharing one cache (in-process clusters share
    # it across workers too): a block read the cache while another thread cleared it for another
    # screening (KeyError 'eph' in the twentieth session's CI), and could read the other
    # screening's samples. Blocks of two screenings interleaved in 8 threads must each give what
    # the block gives alone.
    from concurrent.futures import ThreadPoolExecutor

    from visviva.conjunctions import screening as scr
    from visviva.conjunctions.sources import as_source
    from visviva.satellites.utc_days import time_to_utc_days

    cat = synthetic_catalog(30, seed=4, crossing_pairs=3)
    t0 = cat.epochs[0].tai
    t1 = t0 + 2 * u.hour
    jd0, fr0 = (float(x) for x in time_to_utc_days(t0))
    a = as_source(cat, t0, t1, "primaries", jd0, fr0)
    b = as_source(cat[:12], t0, t1, "primaries", jd0, fr0)
    jobs = [(src, 121, np.arange(k, len(src), 3)) for src in (a, b) for k in range(3)]
    alone = [scr.screen_block(s, s, True, 60.0, n, 20.0, rows) for s, n, rows in jobs]
    scr._WORKER_CACHE.clear()
    with ThreadPoolExecutor(8) as pool:
        runs = list(pool.map(lambda job: scr._worker_block(job[0], job[0], True, 60.0, job[1],
                                                            20.0, job[2])[0], jobs * 6))
    assert sum(len(x) for x in alone) >= 3
    for k, found in enumerate(runs):
        assert found == alone[k % len(jobs)]


def test_synthetic_crossing_pairs_near_a_mean_anomaly_of_zero_are_built():
    # audit54: the second object of a crossing pair took mo + U(-4e-4, 4e-4) rad unwrapped, and
    # sgp4's TLE exporter refused 6.2832 rad ("Mean Anomaly must be between 0 and 2 pi"):
    # synthetic_catalog(2000, seed=5, crossing_pairs=15, ...) raised ValueError; so did seed
    # 12545's fourth pair (mean anomaly 6.28307 rad + 3.5e-4 rad)
    cat = synthetic_catalog(0, seed=12545, crossing_pairs=4)
    assert len(cat) == 8
    mo = np.array([s.satrec.mo for s in cat])
    assert np.all((mo >= 0.0) & (mo < 2 * np.pi))


def _geo(satnum, ecc, argp_deg, inc_deg, mo_deg, node_deg):
    """A GEO element set (sgp4init, WGS-72) at 2024-01-01 00:00 UTC, through TLE text."""
    import math

    from sgp4.api import WGS72, Satrec
    from sgp4.exporter import export_tle

    s = Satrec()
    s.sgp4init(WGS72, "i", satnum, 27029.0, 0.0, 0.0, 0.0, ecc, math.radians(argp_deg),
               math.radians(inc_deg), math.radians(mo_deg), 1.00273791 * 2 * math.pi / 1440.0,
               math.radians(node_deg))
    return vv.Satellite.from_tle(*export_tle(s), name=f"GEO{satnum}")


@pytest.mark.parametrize("step", [None, 1000 * u.s])
def test_co_located_geo_pair_drifting_at_17_cm_s_every_minimum_found(step):
    # audit54 (a check, no bug found): two co-located GEO satellites (mean longitudes 0.0005 deg
    # apart, eccentricity vectors 1e-4 apart) circle each other at 0.17-0.18 m/s, 2.4-5.0 km
    # apart: over two days five minima below 5 km, the first at the window's start. The
    # screen finds each, miss to 1 mm of SGP4 brute force; TCA to 20 ms only, as the distance
    # is flat to 1e-9 m over that (d(t) ~ d0 + v^2 t^2 / 2 d0), at the default step and at a
    # 1000 s step.
    a = _geo(40001, 0.00010, 0.0, 0.020, 10.0, 80.0)
    b = _geo(40002, 0.00011, 30.0, 0.021, 340.0005, 80.0)
    t0 = Time("2024-01-01T06:00:00", scale="utc")
    span = 2 * 86400.0
    tab = vv.screen_conjunctions([a], [b], t0, t0 + span * u.s, 5 * u.km, step=step)
    brute = _brute_minima(a, b, t0, span, 5.0)
    assert len(brute) == 5 and brute[0][0] == 0.0
    assert len(tab) == len(brute)
    assert np.all(tab["relative_speed"] < 0.2 * u.m / u.s)
    tca = (tab["tca"] - t0).to_value(u.s)
    for (t, m), tc, mi in zip(brute, tca, tab["miss_distance"].to_value(u.km), strict=True):
        assert abs(tc - t) < 0.02
        assert abs(mi - m) < 1e-6
