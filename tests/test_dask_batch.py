"""The Dask batch equals the in-memory batch, on a LocalCluster of 2 workers."""

from __future__ import annotations

import importlib.resources

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

pytest.importorskip("distributed")

from visviva.satellites.catalog import (  # noqa: E402
    parse_tle_text,
    propagate_j2_batch,
    propagate_kepler_batch,
    propagate_sgp4_batch,
)
from visviva.satellites.dask_batch import (  # noqa: E402
    DaskBatch,
    close_local_cluster,
    get_client,
    propagate_dask,
    propagate_sgp4_dask,
)
from visviva.satellites.tle import SGP4Error  # noqa: E402


@pytest.fixture(scope="module")
def cluster():
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, processes=False, threads_per_worker=1,
                      dashboard_address=None) as cl, Client(cl) as client:
        yield cl, client
        close_local_cluster()  # the client opened by address below


@pytest.fixture(scope="module")
def catalog():
    text = (importlib.resources.files("sgp4") / "SGP4-VER.TLE").read_text()
    lines = [ln[:69] if ln.startswith("2 ") else ln for ln in text.splitlines()]
    return parse_tle_text("\n".join(ln for ln in lines if not ln.startswith("#")),
                          verify_checksum=False)


@pytest.fixture(scope="module")
def times():
    return Time("2006-06-25T00:00:00", scale="utc") + np.linspace(-0.2, 0.8, 23) * u.day


def test_sgp4_dask_equals_in_memory(cluster, catalog, times):
    _, client = cluster
    mem = propagate_sgp4_batch(catalog, times, on_error="nan")
    lazy = propagate_dask(catalog, times, chunks=(8, 10), on_error="nan")
    assert isinstance(lazy, DaskBatch) and lazy.r.shape == (33, 23, 3)
    assert lazy.r.numblocks == (5, 3, 1)
    out = lazy.compute(client=client)
    np.testing.assert_array_equal(out.r.value, mem.r.value)
    np.testing.assert_array_equal(out.v.value, mem.v.value)
    np.testing.assert_array_equal(out.status, mem.status)


@pytest.mark.parametrize(
    ("method", "in_memory"), [("kepler", propagate_kepler_batch), ("j2", propagate_j2_batch)]
)
def test_analytic_dask_equals_in_memory(cluster, catalog, times, method, in_memory):
    _, client = cluster
    good = catalog[:6]
    mem = in_memory(good, times)
    out = propagate_dask(good, times, method=method, chunks=(4, 7)).compute(client=client)
    np.testing.assert_array_equal(out.r.value, mem.r.value)
    np.testing.assert_array_equal(out.v.value, mem.v.value)


def test_errors_surface_from_compute(cluster, catalog, times):
    _, client = cluster
    with pytest.raises(SGP4Error):
        propagate_dask(catalog, times, chunks=(8, 10)).compute(client=client)


def test_cluster_by_address_and_default_client(cluster, catalog, times):
    cl, client = cluster
    mem = propagate_sgp4_batch(catalog[:4], times)
    by_address = propagate_sgp4_dask(
        catalog[:4], times, chunks=(2, 12), compute=True, address=cl.scheduler_address
    )
    np.testing.assert_array_equal(by_address.r.value, mem.r.value)
    # with a client active, get_client() returns it instead of starting a cluster
    assert get_client() is not None
    default = propagate_sgp4_dask(catalog[:4], times, chunks=(3, 5), compute=True)
    np.testing.assert_array_equal(default.v.value, mem.v.value)


def test_dask_graph_and_in_place_paths_agree(cluster, catalog, times):
    """compute() on an in-process cluster writes blocks into one result (whole rows go straight
    from sgp4); the dask arrays themselves stay usable on any cluster. Both equal in-memory."""
    _, client = cluster
    mem = propagate_sgp4_batch(catalog, times, on_error="nan")
    for chunks in [(8, 1000), (5, 7)]:
        lazy = propagate_dask(catalog, times, chunks=chunks, on_error="nan")
        in_place = lazy.compute(client=client)
        r_graph, v_graph = client.compute([lazy.r, lazy.v], sync=True)
        for r, v in [(in_place.r.value, in_place.v.value), (r_graph, v_graph)]:
            np.testing.assert_array_equal(r, mem.r.value)
            np.testing.assert_array_equal(v, mem.v.value)
        np.testing.assert_array_equal(in_place.status, mem.status)
