"""The Dask batch equals the in-memory batch, on a LocalCluster of 2 process workers (the
default for CPU-bound work), 1 thread each; one test uses an in-process threads cluster."""

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

    with LocalCluster(n_workers=2, processes=True, threads_per_worker=1,
                      dashboard_address=None, env={"NUMBA_NUM_THREADS": "1"}) as cl, \
            Client(cl) as client:
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


def test_dask_graph_and_in_place_paths_agree(catalog, times):
    """compute() on an in-process (threads) cluster writes blocks into one result (whole rows go
    straight from sgp4); the dask arrays themselves stay usable on any cluster. Both equal
    in-memory."""
    from distributed import Client, LocalCluster

    mem = propagate_sgp4_batch(catalog, times, on_error="nan")
    with LocalCluster(n_workers=1, processes=False, threads_per_worker=2,
                      dashboard_address=None) as cl, Client(cl, set_as_default=False) as client:
        _graph_and_in_place(client, catalog, times, mem)


def _graph_and_in_place(client, catalog, times, mem):
    import warnings

    from visviva.errors import StaleElementSetWarning

    for chunks in [(8, 1000), (5, 7)]:
        with pytest.warns(StaleElementSetWarning):  # once, on the client (the set: 1957-2006)
            lazy = propagate_dask(catalog, times, chunks=chunks, on_error="nan")
        with warnings.catch_warnings():
            warnings.simplefilter("error", StaleElementSetWarning)  # not again per block
            in_place = lazy.compute(client=client)
            r_graph, v_graph = client.compute([lazy.r, lazy.v], sync=True)
        for r, v in [(in_place.r.value, in_place.v.value), (r_graph, v_graph)]:
            np.testing.assert_array_equal(r, mem.r.value)
            np.testing.assert_array_equal(v, mem.v.value)
        np.testing.assert_array_equal(in_place.status, mem.status)


@pytest.mark.parametrize("method", ["j2", "kepler"])
def test_analytic_dask_warns_of_stale_sets_once_on_the_client(catalog, times, method):
    """propagate_dask(method="j2"|"kepler") said nothing about element sets years from the
    times (only "sgp4" warned): one warning when the batch is built, at the caller's line, in
    the in-memory batch's words; the blocks stay quiet (an error filter would fail them)."""
    import warnings

    from distributed import Client, LocalCluster

    from visviva.errors import StaleElementSetWarning

    good = catalog[:6]
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        lazy = propagate_dask(good, times, method=method, chunks=(4, 7))
        mem = (propagate_j2_batch if method == "j2" else propagate_kepler_batch)(good, times)
    stale = [x for x in w if issubclass(x.category, StaleElementSetWarning)]
    assert len(stale) == 2 and all(x.filename == __file__ for x in stale)
    assert str(stale[0].message) == str(stale[1].message)
    assert "3 of 6 element set(s)" in str(stale[0].message)
    with LocalCluster(n_workers=1, processes=False, threads_per_worker=2,
                      dashboard_address=None) as cl, Client(cl, set_as_default=False) as client:
        with warnings.catch_warnings():
            warnings.simplefilter("error", StaleElementSetWarning)  # not again per block
            out = lazy.compute(client=client)
    np.testing.assert_array_equal(out.r.value, mem.r.value)


def test_workers_are_processes_by_default(cluster):
    import inspect
    import os

    _, client = cluster
    assert inspect.signature(get_client).parameters["processes"].default is True
    pids = client.run(os.getpid)
    assert len(pids) == 2 and os.getpid() not in pids.values()
    threads = client.run(lambda: __import__("numba").config.NUMBA_NUM_THREADS)
    assert set(threads.values()) == {1}  # no oversubscription: one numba thread per worker


@pytest.fixture(scope="module")
def leo_states():
    import visviva as vv

    rng = np.random.default_rng(7)
    n = 7
    el = vv.KeplerianElements.from_semi_major_axis(
        (6778.0 + rng.uniform(0, 800, n)) * u.km, rng.uniform(0, 0.02, n),
        rng.uniform(0.1, 1.7, n) * u.rad, rng.uniform(0, 6, n) * u.rad,
        rng.uniform(0, 6, n) * u.rad, rng.uniform(-3, 3, n) * u.rad, vv.EARTH,
        epoch=Time("2024-03-01T00:00:00", scale="utc"))
    return el.to_state()


def test_cowell_batch_on_dask_equals_in_memory(cluster, leo_states):
    import visviva as vv

    _, client = cluster
    perts = [vv.J2(vv.EARTH), vv.AtmosphericDrag(0.01 * u.m**2 / u.kg)]
    t = np.linspace(0, 6, 9) * u.hour
    mem = vv.propagate_cowell(leo_states, t, perts)
    lazy = vv.satellites.propagate_dask(leo_states, t, method="cowell", perturbations=perts,
                                        chunks=3, client=client)
    assert lazy.r.shape == (7, 9, 3) and lazy.r.numblocks == (3, 1, 1)
    out = lazy.compute()  # on the client given to propagate_dask
    np.testing.assert_array_equal(out.r.value, mem.r.value)
    np.testing.assert_array_equal(out.v.value, mem.v.value)
    assert not out.status.any()
    assert (out.t - leo_states.epoch).to_value(u.hour)[-1] == pytest.approx(6.0)
    # drag lowers every orbit a little: the physics is the in-memory physics
    assert np.all(out.altitude[:, -1] < out.altitude[:, 0] + 100 * u.km)


def test_large_results_stay_distributed(cluster, catalog, times, leo_states, tmp_path):
    import dask.array as da
    import zarr

    import visviva as vv

    _, client = cluster
    good = catalog[:6]
    mem = propagate_sgp4_batch(good, times)
    kept = propagate_dask(good, times, chunks=(2, 8), client=client).persist()
    assert isinstance(kept.r, da.Array)
    np.testing.assert_array_equal(kept.r.max().compute(), mem.r.value.max())
    group = kept.to_zarr(tmp_path / "batch.zarr")
    np.testing.assert_array_equal(zarr.open_group(tmp_path / "batch.zarr")["r"][...],
                                  mem.r.value)
    assert group.attrs["names"] == mem.names and group.attrs["frame"] == "teme"
    assert len(group.attrs["t_utc"]) == len(times)
    # the times come back to the nanosecond (were written to the millisecond: up to 4 m in LEO)
    back = Time(group.attrs["t_utc"], scale="utc")
    assert np.abs((back - times).to_value(u.s)).max() < 1e-9
    t = np.linspace(0, 1, 4) * u.hour
    cow = vv.satellites.propagate_dask(leo_states, t, method="cowell", chunks=4)
    cow.to_zarr(tmp_path / "cowell.zarr", client=client)
    ref = vv.propagate_cowell(leo_states, t)
    np.testing.assert_array_equal(zarr.open_group(tmp_path / "cowell.zarr")["v"][...],
                                  ref.v.value)


def test_cowell_dask_refuses_what_it_cannot_do(catalog, leo_states, times):
    import visviva as vv

    with pytest.raises(vv.InvalidInputError, match="method='sgp4'"):
        propagate_dask(catalog, times, method="cowell")
    with pytest.raises(vv.InvalidInputError, match="apply to method='cowell' only"):
        propagate_dask(catalog, times, perturbations=[vv.J2(vv.EARTH)])
    with pytest.raises(vv.InvalidInputError, match="unknown Cowell options"):
        propagate_dask(leo_states, np.arange(3) * u.min, method="cowell", tolerance=1e-9)
    with pytest.raises(vv.InvalidInputError, match="method must be one of"):
        propagate_dask(catalog, times, method="rk4")
    teme = catalog[0].teme(catalog[0].epoch + np.arange(3) * u.min)  # was integrated as GCRS
    with pytest.raises(vv.InvalidInputError, match="TEME: pass sat.gcrs"):
        propagate_dask(teme, np.arange(3) * u.min, method="cowell")
    # a bad force model is refused when the graph is built, not later inside a worker (where it
    # logged a worker traceback at compute time)
    no_epoch = vv.StateVectors(leo_states.r, leo_states.v, vv.EARTH)
    for states, perturbations, match in (
            (leo_states, ["J2"], "not a perturbation"),
            (leo_states, [vv.ThirdBody(vv.SUN), vv.ThirdBody(vv.SUN)], "listed twice"),
            (no_epoch, [vv.ThirdBody(vv.SUN)], "epoch")):
        with pytest.raises(vv.InvalidInputError, match=match):
            propagate_dask(states, np.arange(3) * u.min, method="cowell",
                           perturbations=perturbations)
    # audit21: states with different epochs, and a tolerance with a unit, raised in a worker
    shifted = vv.StateVectors(leo_states.r, leo_states.v, vv.EARTH,
                              epoch=leo_states.epoch + np.arange(7) * u.s)
    for states, options, match in ((shifted, {}, "share one epoch"),
                                   (leo_states, {"atol": 1 * u.m}, "plain number")):
        with pytest.raises(vv.InvalidInputError, match=match):
            propagate_dask(states, np.arange(3) * u.min, method="cowell",
                           perturbations=[vv.J2(vv.EARTH)], **options)


def test_cowell_dask_labels_offsets_in_tt_seconds_for_a_tdb_epoch():
    # the labels were epoch + dt added in TDB seconds while the workers integrate dt TT seconds
    # (propagate_cowell's offsets): 2.7 ms off after 180 days; the graph is only built here
    import visviva as vv

    epoch = Time("2024-03-01T00:00:00", scale="tdb")
    states = vv.StateVectors([[1.0, 0.2, 0.0]] * u.AU, [[-5, 29.5, 0.3]] * u.km / u.s, vv.SUN,
                             epoch=epoch)
    dt = np.array([0.0, 50.0, 180.0]) * u.day
    batch = propagate_dask(states, dt, method="cowell")
    assert batch.t.scale == "tdb"
    np.testing.assert_allclose((batch.t.tt - epoch.tt).to_value(u.s), dt.to_value(u.s),
                               rtol=0, atol=1e-6)


def test_stale_element_sets_warn_once_on_the_client(cluster, catalog, times):
    """propagate_dask(method="sgp4") said nothing about element sets years from the times: the
    blocks' warnings stayed on the process workers. Now one warning when the batch is built,
    at the caller's line, as propagate_sgp4_batch gives."""
    import warnings

    from visviva.errors import StaleElementSetWarning

    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        lazy = propagate_dask(catalog, times, chunks=(8, 10), on_error="nan")
        propagate_sgp4_batch(catalog, times, on_error="nan")
    stale = [x for x in w if issubclass(x.category, StaleElementSetWarning)]
    assert len(stale) == 2 and all(x.filename == __file__ for x in stale)
    assert str(stale[0].message) == str(stale[1].message)  # the in-memory batch's own words
    assert "of 33 element set(s)" in str(stale[0].message)
    assert lazy.r.shape == (33, 23, 3)
