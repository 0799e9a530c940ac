"""Dask clients shared by the packages that scale out (satellite batches, N-body ensembles).

:func:`get_client` returns a ``dask.distributed.Client``: to a scheduler address, the current
client, or a ``LocalCluster`` started once and reused; :func:`close_local_cluster` closes the ones
started here. Requires the ``scale`` extra (``pip install visviva[scale]``).
"""

from __future__ import annotations

import threading

__all__ = ["require_dask", "get_client", "close_local_cluster", "NUMBA_LOCK"]

#: numba's parallel kernels already use every core, and numba's "workqueue" threading layer
#: must not be entered from two threads at once: blocks that call them take this lock (one at a
#: time per process; satellites.dask_batch, ground.dask_passes).
NUMBA_LOCK = threading.Lock()

_LOCAL = {}


def require_dask():
    try:
        import dask.array  # noqa: F401
        import distributed  # noqa: F401
    except ImportError as exc:  # pragma: no cover - the scale extra is installed in CI
        raise ImportError(
            "Dask needs dask[array,distributed]: pip install 'visviva[scale]'"
        ) from exc


def get_client(address: str | None = None, *, n_workers: int | None = None,
               processes: bool = True, threads_per_worker: int = 1):
    """A ``dask.distributed.Client``: to ``address`` if given, else the current client, else a
    ``LocalCluster`` started once and reused.

    Parameters
    ----------
    address : str, optional
        Scheduler address of an existing cluster, e.g. ``"tcp://10.0.0.5:8786"``.
    n_workers : int, optional
        Workers of the LocalCluster started when no address is given and no client exists
        (default: one per CPU core available to this process).
    processes : bool
        Process workers (default): real parallelism for sgp4's C++ loop (which holds the GIL)
        and the compiled integrators, at the price of sending results between processes.
        ``False`` runs thread workers in this process (no copies, no parallel sgp4).
    threads_per_worker : int
        Threads per worker; each process worker's numba uses as many
        (``NUMBA_NUM_THREADS``), so workers do not oversubscribe the cores.

    Returns
    -------
    distributed.Client
    """
    require_dask()
    from distributed import Client, LocalCluster

    if address is not None:
        key = ("address", address)
        if key not in _LOCAL or _LOCAL[key].status == "closed":
            _LOCAL[key] = Client(address)
        return _LOCAL[key]
    try:
        from distributed import get_client as current

        return current()
    except ValueError:
        pass
    if n_workers is None:
        import os

        n_workers = max(len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
                        else (os.cpu_count() or 1), 1)
    key = ("local", n_workers, processes, threads_per_worker)
    client = _LOCAL.get(key)
    if client is None or client.status == "closed":
        import dask

        extra = {"env": {"NUMBA_NUM_THREADS": str(threads_per_worker)}} if processes else {}
        # the workers' statistical profiler samples every 10 ms: CPU the compute could use
        with dask.config.set({"distributed.worker.profile.enabled": False}):
            cluster = LocalCluster(
                n_workers=n_workers, processes=processes, threads_per_worker=threads_per_worker,
                dashboard_address=None, **extra,
            )
        client = Client(cluster)
        if processes:
            client.run(_reload_numba_config)
        _LOCAL[key] = client
    return client


def _reload_numba_config() -> None:
    """Worker side: make numba read ``NUMBA_NUM_THREADS`` again.

    The nanny sets a worker's environment only after the worker process has started, and a
    process started by ``spawn`` imports the user's main script first: a script that imports
    numba at the top (every script defining an ``@numba.njit`` force) left numba configured
    for every core while the environment said one thread. The first compilation on the worker
    (a user force, fused into the integrators there) then re-read the environment after the
    thread pool had started and numba raised "Cannot set NUMBA_NUM_THREADS to a different
    value once the threads have been launched". Reading it here, before any thread starts,
    makes the two agree (and the worker use the one thread it was given).
    """
    from numba.core import config

    try:
        config.reload_config()
    except RuntimeError:  # pragma: no cover - the pool already runs: nothing left to align
        pass


def close_local_cluster() -> None:
    """Close the clients (and LocalClusters) this module started."""
    for client in list(_LOCAL.values()):
        cluster = client.cluster
        client.close()
        if cluster is not None:
            cluster.close()
    _LOCAL.clear()
