"""The catalogue batch on Dask: the same call chunked over objects and times.

:func:`propagate_dask` builds dask arrays whose blocks are calls of the in-memory batch functions
of :mod:`visviva.satellites.catalog` (SGP4 through sgp4's ``SatrecArray``, secular J2, Kepler)
on one chunk of satellites and one chunk of times, so every block equals the corresponding slice
of the in-memory result bit for bit. :meth:`DaskBatch.compute` runs the graph on a
``dask.distributed`` cluster: a ``LocalCluster`` started on first use by default, or any
scheduler given its address (``"tcp://host:8786"``).

Satellites travel to remote workers as their element sets (sgp4's ``Satrec`` does not pickle);
each worker rebuilds its chunk's ``SatrecArray`` once per task.

Requires the ``scale`` extra (``pip install visviva[scale]``: dask[array,distributed]).
"""

from __future__ import annotations

import threading
import uuid

import numpy as np
from astropy.time import Time

from .._dask import close_local_cluster, get_client
from .._dask import require_dask as _require_dask
from .._units import to_quantity
from ..errors import InvalidInputError
from .catalog import (
    BatchStates,
    Catalog,
    _absolute_times,
    _as_catalog,
    _check_on_error,
    propagate_j2_batch,
    propagate_kepler_batch,
    propagate_sgp4_batch,
)

__all__ = ["propagate_dask", "propagate_sgp4_dask", "DaskBatch", "get_client", "close_local_cluster"]

_METHODS = {"sgp4": propagate_sgp4_batch, "j2": propagate_j2_batch, "kepler": propagate_kepler_batch}
#: numba's parallel kernels (J2, Kepler) already use every core, and numba's "workqueue"
#: threading layer must not be entered from two threads at once: one block at a time per process.
_NUMBA_LOCK = threading.Lock()


def _block(cat: Catalog, t: Time, method: str, on_error: str):
    if method == "sgp4":
        out = _METHODS[method](cat, t, on_error=on_error)
    else:
        with _NUMBA_LOCK:
            out = _METHODS[method](cat, t, on_error=on_error)
    return out.r.value, out.v.value, out.status


#: result arrays of in-process computations, by key: blocks running in this process write
#: straight into them (no second copy of the N x T x 6 result)
_SHARED: dict = {}


def _block_into(key, a, b, c, d, method: str, on_error: str):
    status, r, v, full_cat, full_t = _SHARED[key]
    cat, t = _slice(full_cat, a, b), full_t[c:d]
    if method == "sgp4" and c == 0 and d == r.shape[1]:
        # whole rows: contiguous slices, sgp4 writes its output in place
        propagate_sgp4_batch(cat, t, on_error=on_error, out=(status[a:b], r[a:b], v[a:b]))
        return None
    rr, vv, ss = _block(cat, t, method, on_error)
    r[a:b, c:d] = rr
    v[a:b, c:d] = vv
    status[a:b, c:d] = ss
    return None


def _in_process(client) -> bool:
    """True when every worker of ``client`` runs in this process (a threads LocalCluster)."""
    import os

    cached = getattr(client, "_visviva_in_process", None)
    if cached is None:
        pid = os.getpid()
        try:
            pids = client.run(os.getpid)
            cached = bool(pids) and all(p == pid for p in pids.values())
        except Exception:  # pragma: no cover - exotic clusters
            cached = False
        try:
            client._visviva_in_process = cached
        except AttributeError:  # pragma: no cover
            pass
    return cached


class DaskBatch:
    """Lazy N x T states as dask arrays.

    Attributes
    ----------
    r, v : dask.array.Array, shape (N, T, 3)
        Positions (km) and velocities (km/s) as plain float64 dask arrays.
    status : dask.array.Array, shape (N, T)
        Error codes as in :class:`~visviva.satellites.catalog.BatchStates`.
    t : astropy Time, shape (T,)
    names : list of str
    """

    def __init__(self, r, v, status, t, names, frame, plan=None):
        self.r, self.v, self.status, self.t, self.names, self.frame = r, v, status, t, names, frame
        self._plan = plan  # (catalog, method, row splits, column splits, on_error)

    @property
    def shape(self):
        return self.r.shape[:-1]

    def compute(self, client=None, address: str | None = None) -> BatchStates:
        """Run the graph on ``client`` (or the cluster at ``address``, or a LocalCluster).

        Returns
        -------
        BatchStates
            In-memory results, equal to the in-memory batch call.
        """
        if client is None:
            client = get_client(address)
        if self._plan is not None and _in_process(client):
            r, v, status = self._compute_in_place(client)
        else:
            r, v, status = client.compute([self.r, self.v, self.status], sync=True)
        return BatchStates(
            to_quantity(r, "length"), to_quantity(v, "speed"), self.t, status, self.names,
            self.frame,
        )

    def _compute_in_place(self, client):
        """Same blocks as the dask arrays, run as tasks that write into one preallocated result
        (workers share this process), so the result is not assembled by a second copy."""
        cat, method, rows, cols, on_error = self._plan
        n, m = self.shape
        out = (np.empty((n, m), np.uint8), np.empty((n, m, 3)), np.empty((n, m, 3)))
        key = uuid.uuid4().hex
        # tasks carry only the key and indices: the catalogue (with its cached SatrecArrays)
        # and the times are looked up in this process, never pickled
        _SHARED[key] = out + (cat, self.t)
        try:
            futures = [
                client.submit(_block_into, key, a, b, c, d, method, on_error, pure=False)
                for a, b in rows
                for c, d in cols
            ]
            client.gather(futures)
        finally:
            _SHARED.pop(key, None)
        status, r, v = out
        return r, v, status

    def __repr__(self):
        return f"DaskBatch(shape={self.shape}, chunks={self.r.chunks[:2]})"


def _slice(cat: Catalog, a: int, b: int) -> Catalog:
    """``cat[a:b]``, kept on ``cat`` so repeated graphs reuse its SatrecArray (threads)."""
    cache = cat.__dict__.setdefault("_dask_slices", {})
    if (a, b) not in cache:
        cache[(a, b)] = cat[a:b]
    return cache[(a, b)]


def _splits(n: int, size: int):
    size = max(int(size), 1)
    return [(a, min(a + size, n)) for a in range(0, n, size)]


def propagate_dask(satellites, t, *, method: str = "sgp4", chunks=(1000, 1000),
                   on_error: str = "raise") -> DaskBatch:
    """Build the N x T batch as dask arrays chunked over objects and times.

    Parameters
    ----------
    satellites : Catalog or sequence of Satellite
        The N objects.
    t : astropy Time, shape (T,)
        Absolute times.
    method : {"sgp4", "j2", "kepler"}
        The in-memory batch function each block calls.
    chunks : (int, int)
        Objects and times per block.
    on_error : {"raise", "nan"}
        As in :func:`~visviva.satellites.catalog.propagate_sgp4_batch`; with ``"raise"`` the
        typed error surfaces from ``compute()``.

    Returns
    -------
    DaskBatch
        Lazy ``r``, ``v`` and ``status``; call ``.compute()`` to run on a cluster.
    """
    _require_dask()
    import dask
    import dask.array as da

    if method not in _METHODS:
        raise InvalidInputError(f"method must be one of {sorted(_METHODS)}, got {method!r}.")
    _check_on_error(on_error)
    cat = _as_catalog(satellites)
    t = _absolute_times(t, "propagate_dask")
    try:
        n_chunk, t_chunk = chunks
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"chunks must be (objects, times), got {chunks!r}.") from exc
    rows_r, rows_v, rows_s = [], [], []
    tag = uuid.uuid4().hex
    for a, b in _splits(len(cat), n_chunk):
        part = dask.delayed(_slice(cat, a, b), name=f"visviva-catalog-{tag}-{a}")
        cols_r, cols_v, cols_s = [], [], []
        for c, d in _splits(len(t), t_chunk):
            blk = dask.delayed(_block, pure=False, nout=3)(part, t[c:d], method, on_error)
            n, m = b - a, d - c
            cols_r.append(da.from_delayed(blk[0], (n, m, 3), dtype=np.float64))
            cols_v.append(da.from_delayed(blk[1], (n, m, 3), dtype=np.float64))
            cols_s.append(da.from_delayed(blk[2], (n, m), dtype=np.uint8))
        rows_r.append(da.concatenate(cols_r, axis=1))
        rows_v.append(da.concatenate(cols_v, axis=1))
        rows_s.append(da.concatenate(cols_s, axis=1))
    plan = (cat, method, _splits(len(cat), n_chunk), _splits(len(t), t_chunk), on_error)
    return DaskBatch(
        da.concatenate(rows_r, axis=0), da.concatenate(rows_v, axis=0),
        da.concatenate(rows_s, axis=0), t, cat.names, "teme", plan,
    )


def propagate_sgp4_dask(satellites, t, *, chunks=(1000, 1000), on_error: str = "raise",
                        compute: bool = False, client=None, address: str | None = None):
    """SGP4 for N satellites at T times on Dask (see :func:`propagate_dask`).

    With ``compute=True`` the graph runs at once on ``client`` / ``address`` / a LocalCluster and
    a :class:`~visviva.satellites.catalog.BatchStates` is returned; otherwise a
    :class:`DaskBatch`.
    """
    lazy = propagate_dask(satellites, t, method="sgp4", chunks=chunks, on_error=on_error)
    return lazy.compute(client=client, address=address) if compute else lazy
