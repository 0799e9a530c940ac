"""find_passes on a Dask cluster equals the in-memory pass table."""

import importlib.resources

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv

pytest.importorskip("distributed")

from visviva.ground import find_passes_dask  # noqa: E402
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
    with LocalCluster(n_workers=2, processes=False, threads_per_worker=1,
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
    with pytest.raises(vv.InvalidInputError, match="chunk_size"):
        find_passes_dask(cat, sites, t0, t1, chunk_size=0, client=object())
