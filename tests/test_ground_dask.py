"""find_passes on a Dask cluster of process workers equals the in-memory pass table."""

import importlib.resources

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv

pytest.importorskip("distributed")

from visviva.ground import find_passes_dask  # noqa: E402
from visviva.ground.passes import VISIBLE_EDGE_TOL_S  # noqa: E402
from visviva.satellites.catalog import parse_tle_text  # noqa: E402


def test_dask_pass_table_equals_in_memory():
    from distributed import Client, LocalCluster

    text = (importlib.resources.files("sgp4") / "SGP4-VER.TLE").read_text()
    lines = [ln[:69] if ln.startswith("2 ") else ln for ln in text.splitlines()]
    cat = parse_tle_text("\n".join(ln for ln in lines if not ln.startswith("#")),
                         verify_checksum=False)
    keep = [s for s in cat.satellites  # June 2006 epochs, without three that fail
            if s.epoch.utc.isot.startswith("2006-06") and s.satnum not in (28350, 29141, 33334)]
    cat = vv.Catalog(keep)
    sites = [vv.GroundStation(40 * u.deg, -75 * u.deg, name="A"),
             vv.GroundStation(-30 * u.deg, 20 * u.deg, name="B")]
    t0 = Time("2006-06-26T00:00:00", scale="utc")
    t1 = t0 + 12 * u.hour
    mem = vv.find_passes(cat, sites, t0, t1, 5 * u.deg)
    with LocalCluster(n_workers=2, processes=True, threads_per_worker=1,
                      dashboard_address=None) as cl, Client(cl) as client:
        out = find_passes_dask(cat, sites, t0, t1, 5 * u.deg, chunk_size=4, client=client)
    assert len(out) == len(mem) > 10
    key = np.lexsort  # compare in a canonical order: satellite, station, start

    def order(tab):
        start = np.where(tab["rise_time"].mask, 0.0, np.ma.getdata(
            tab["rise_time"].unmasked.jd))
        return key((start, np.asarray(tab["station"]), np.asarray(tab["satellite"])))
    a, b = mem[order(mem)], out[order(out)]
    np.testing.assert_array_equal(a["satellite"], b["satellite"])
    np.testing.assert_allclose(a["max_elevation"].value, b["max_elevation"].value, atol=1e-9)
    np.testing.assert_array_equal(a["set_time"].mask, b["set_time"].mask)
    assert a.colnames == b.colnames
    for name in a.colnames:  # every column, values and masks, through the process boundary
        ca, cb = a[name], b[name]
        mask = np.array(getattr(ca, "mask", False), dtype=bool)
        np.testing.assert_array_equal(mask, np.array(getattr(cb, "mask", False), dtype=bool))
        if isinstance(ca, Time):
            ja = np.asarray(getattr(ca, "unmasked", ca).jd, dtype=float)
            jb = np.asarray(getattr(cb, "unmasked", cb).jd, dtype=float)
            with np.errstate(invalid="ignore"):
                seconds = np.where(mask, 0.0, (ja - jb) * 86400.0)
            # the visible edges are found to 0.01 s from brackets (the events) that a chunk
            # of other satellites moves by microseconds: they agree to that tolerance
            tol = VISIBLE_EDGE_TOL_S if name.startswith("visible_") else 1e-4
            assert np.all(np.abs(seconds) < tol), name
        elif isinstance(ca, u.Quantity):
            va = np.ma.getdata(getattr(ca, "unmasked", ca).value)
            vb = np.ma.getdata(getattr(cb, "unmasked", cb).to_value(ca.unit))
            # the event refinement stops within microseconds; a chunk of other satellites can
            # stop it a few microseconds elsewhere (durations of hours agree to ~1e-10)
            np.testing.assert_allclose(np.where(mask, 0, va), np.where(mask, 0, vb), rtol=1e-8,
                                       atol=1e-6, err_msg=name)
        else:
            np.testing.assert_array_equal(np.asarray(ca), np.asarray(cb), err_msg=name)
    with pytest.raises(vv.InvalidInputError, match="chunk_size"):
        find_passes_dask(cat, sites, t0, t1, chunk_size=0, client=object())


def test_dask_passes_warn_about_stale_element_sets_once_on_the_client():
    # was: each chunk warned on its worker ("1 of 1 element set(s)" once per chunk on threads,
    # pointing into dask_passes.py; nothing at all reached the caller from process workers)
    import warnings

    from distributed import Client, LocalCluster

    iss_1 = "1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927"
    iss_2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537"
    sats = [vv.Satellite.from_tle(iss_1, iss_2, name=f"ISS-{k}") for k in range(3)]
    site = vv.GroundStation(40 * u.deg, -75 * u.deg)
    t0 = sats[0].epoch + 45 * u.day
    with LocalCluster(n_workers=1, processes=False, threads_per_worker=1,
                      dashboard_address=None) as cl, Client(cl) as client:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            find_passes_dask(sats, site, t0, t0 + 1 * u.h, chunk_size=1, client=client)
    ours = [w for w in caught if issubclass(w.category, vv.StaleElementSetWarning)]
    assert len(ours) == 1, [str(w.message) for w in ours]
    text = str(ours[0].message)
    assert "3 of 3 element set(s) lie more than 30 days" in text
    assert "ISS-0 (45 d), ISS-1 (45 d), ISS-2 (45 d)" in text
    assert ours[0].filename == __file__


def test_wire_round_trip_keeps_times_as_find_passes_shows_them():
    """find_passes_dask's times came back as Julian dates (format 'jd', printed as
    2460311.05...), find_passes' as ISO to the millisecond: the table was not the same to
    print (audit50). The wire keeps the format and precision, values and masks."""
    from visviva.ground.dask_passes import _table_from_wire, _table_to_wire

    iss = vv.Satellite.from_tle(
        "1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927",
        "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537")
    site = vv.GroundStation(40 * u.deg, -75 * u.deg)
    t0 = Time("2008-09-20T12:00:00", scale="utc")
    mem = vv.find_passes(iss, site, t0, t0 + 1 * u.day, 10 * u.deg)
    back = _table_from_wire(_table_to_wire(mem))
    for name in ("rise_time", "culmination_time", "set_time", "visible_start"):
        assert back[name].format == mem[name].format == "isot"
        assert back[name].precision == mem[name].precision == 3
        np.testing.assert_array_equal(back[name].mask, mem[name].mask)
        assert str(back[name][0]) == str(mem[name][0])
