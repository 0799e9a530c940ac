"""Batches on Dask: the same call chunked over objects (and times), run on process workers.

:func:`propagate_dask` builds dask arrays whose blocks are calls of the in-memory batch functions
on one chunk of objects (and, for the analytic methods, one chunk of times): for a catalogue
SGP4 through sgp4's ``SatrecArray``, secular J2 or Kepler (:mod:`visviva.satellites.catalog`);
for N state vectors a batch of Cowell propagations with perturbations
(:func:`visviva.propagate_cowell`). Every block equals the corresponding slice of the in-memory
result bit for bit. :meth:`DaskBatch.compute` runs the graph on a ``dask.distributed`` cluster
and gathers the result; :meth:`DaskBatch.persist` and :meth:`DaskBatch.to_zarr` keep large
results distributed (in the workers' memory, or written by the workers to a Zarr store).

The default cluster is a ``LocalCluster`` of **process** workers (one numba thread each),
started on first use: sgp4's C++ loop holds the GIL, so threads cannot run it in parallel, and
processes give real parallelism to the compiled Cowell integrator too. Any scheduler can be
given instead, by its address (``"tcp://host:8786"``) or as a ``Client``: a dask-jobqueue
(SLURM, PBS) or dask-kubernetes cluster runs the same graph (docs/satellites.md).

Satellites travel to remote workers as their element sets (sgp4's ``Satrec`` does not pickle);
each worker rebuilds its chunk's ``SatrecArray`` once per task.

Requires the ``scale`` extra (``pip install visviva[scale]``: dask[array,distributed]).
"""

from __future__ import annotations

import uuid
import weakref

import numpy as np
from astropy.time import Time

from .._dask import NUMBA_LOCK, close_local_cluster, get_client
from .._dask import require_dask as _require_dask
from .._units import advance_epoch, to_quantity
from ..errors import InvalidInputError
from .batch_states import BatchStates, absolute_times, check_on_error
from .catalog import (
    Catalog,
    as_catalog,
    j2_grid,
    kepler_grid,
    sgp4_grid,
    warn_stale_times,
)
from .tle_checks import sgp4_times

__all__ = ["propagate_dask", "propagate_sgp4_dask", "DaskBatch", "get_client", "close_local_cluster"]

#: the in-memory batches (propagate_sgp4_batch, propagate_j2_batch, propagate_kepler_batch) on
#: checked arguments; each block runs quiet, propagate_dask warns of stale element sets once
_METHODS = {"sgp4": sgp4_grid, "j2": j2_grid, "kepler": kepler_grid}
#: objects per Cowell block when ``chunks`` is not given: several blocks per worker
_COWELL_CHUNK = 256


def _block(cat: Catalog, t: Time, method: str, on_error: str):
    if method == "sgp4":  # stale element sets: warned once by propagate_dask, on the client
        out = sgp4_grid(cat, t, on_error, warn_stale=False)
    else:
        with NUMBA_LOCK:
            out = _METHODS[method](cat, t, on_error, warn_stale=False)
    return out.r.value, out.v.value, out.status


def _cowell_block(r0, v0, gm, epoch, t, perturbations, options):
    """One chunk of the Cowell batch: (n, T, 3) positions and velocities and zero status."""
    from ..states import StateVectors
    from .cowell import propagate_cowell

    state = StateVectors._from_canonical(r0, v0, gm, epoch)
    with NUMBA_LOCK:
        out = propagate_cowell(state, t, perturbations, **options)
    r = np.ascontiguousarray(out.r.to_value("km"))
    v = np.ascontiguousarray(out.v.to_value("km/s"))
    return r, v, np.zeros(r.shape[:-1], dtype=np.uint8)


#: result arrays of in-process computations, by key: blocks running in this process write
#: straight into them (no second copy of the N x T x 6 result)
_SHARED: dict = {}


def _block_into(key, a, b, c, d, method: str, on_error: str):
    status, r, v, full_cat, full_t = _SHARED[key]
    cat, t = _slice(full_cat, a, b), full_t[c:d]
    if method == "sgp4" and c == 0 and d == r.shape[1]:
        # whole rows: contiguous slices, sgp4 writes its output in place
        sgp4_grid(cat, t, on_error, out=(status[a:b], r[a:b], v[a:b]), warn_stale=False)
        return None
    rr, vv, ss = _block(cat, t, method, on_error)
    r[a:b, c:d] = rr
    v[a:b, c:d] = vv
    status[a:b, c:d] = ss
    return None


#: whether each client's workers all run in this process, asked once per client
_IN_PROCESS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _in_process(client) -> bool:
    """True when every worker of ``client`` runs in this process (a threads LocalCluster)."""
    import os

    try:
        cached = _IN_PROCESS.get(client)
    except TypeError:  # pragma: no cover - a client that cannot be weakly referenced
        cached = None
    if cached is None:
        pid = os.getpid()
        try:
            pids = client.run(os.getpid)
            cached = bool(pids) and all(p == pid for p in pids.values())
        except Exception:  # pragma: no cover - exotic clusters
            cached = False
        try:
            _IN_PROCESS[client] = cached
        except TypeError:  # pragma: no cover
            pass
    return cached


def _gather_blocks(client, arrays):
    """Compute dask arrays block by block and assemble each into one preallocated ndarray.

    Gathering the blocks themselves (instead of computing the concatenated arrays) spares the
    workers a concatenation and a copy of the whole result before it is sent.
    """
    keys, where = [], []
    for k, arr in enumerate(arrays):
        offsets = [np.concatenate([[0], np.cumsum(c)]) for c in arr.chunks]
        for idx, block in np.ndenumerate(arr.to_delayed(optimize_graph=False)):
            keys.append(block)
            where.append((k, tuple(slice(int(o[i]), int(o[i + 1]))
                                   for o, i in zip(offsets, idx, strict=True))))
    outs = [np.empty(arr.shape, dtype=arr.dtype) for arr in arrays]
    for (k, index), block in zip(where, client.gather(client.compute(keys)), strict=True):
        outs[k][index] = block
    return outs


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

    def __init__(self, r, v, status, t, names, frame, plan=None, client=None):
        self.r, self.v, self.status, self.t, self.names, self.frame = r, v, status, t, names, frame
        self._plan = plan  # (catalog, method, row splits, column splits, on_error)
        self._client = client

    def _resolve(self, client=None, address=None):
        if client is not None:
            return client
        if address is None and self._client is not None:
            return self._client
        return get_client(address)

    @property
    def shape(self):
        return self.r.shape[:-1]

    def compute(self, client=None, address: str | None = None) -> BatchStates:
        """Run the graph on ``client`` (or the cluster at ``address``, or a LocalCluster).

        Parameters
        ----------
        client : distributed.Client, optional
            Where to run (default: the client given to :func:`propagate_dask`, else the one at
            ``address``, else the current one, else a process LocalCluster).
        address : str, optional
            Scheduler address, e.g. ``"tcp://10.0.0.5:8786"``.

        Returns
        -------
        BatchStates
            In-memory results, equal to the in-memory batch call.
        """
        client = self._resolve(client, address)
        if self._plan is not None and _in_process(client):
            r, v, status = self._compute_in_place(client)
        else:
            r, v, status = _gather_blocks(client, (self.r, self.v, self.status))
        return BatchStates(
            to_quantity(r, "length"), to_quantity(v, "speed"), self.t, status, self.names,
            self.frame,
        )

    def persist(self, client=None, address: str | None = None) -> DaskBatch:
        """Compute every block and keep it in the workers' memory (nothing is gathered).

        Returns
        -------
        DaskBatch
            The same arrays backed by the computed blocks on the cluster: reductions such as
            ``batch.r[..., 2].max().compute()`` then move only their result.
        """
        client = self._resolve(client, address)
        r, v, status = client.persist([self.r, self.v, self.status])
        return DaskBatch(r, v, status, self.t, self.names, self.frame, client=client)

    def to_zarr(self, store, client=None, address: str | None = None, *, overwrite=False):
        """Write ``r``, ``v`` and ``status`` to a Zarr store, block by block on the workers.

        Parameters
        ----------
        store : str or os.PathLike
            A directory (or any URL Zarr understands, e.g. ``s3://...`` with fsspec), reachable
            by every worker.
        client, address
            As in :meth:`compute`.
        overwrite : bool
            Replace existing arrays.

        Returns
        -------
        zarr.Group
            Arrays ``r`` (km), ``v`` (km/s), ``status`` and attributes ``names``, ``frame``
            and the times ``t_utc`` (ISO strings, UTC, to the nanosecond) or ``t_s`` (seconds).

        Notes
        -----
        Requires ``zarr`` (in the ``scale`` extra). The result never passes through this
        process: each worker writes its own blocks.
        """
        import os

        import dask.array as da
        import zarr

        client = self._resolve(client, address)
        store = os.fspath(store)
        writes = [
            da.to_zarr(arr, store, component=name, overwrite=overwrite, compute=False)
            for name, arr in (("r", self.r), ("v", self.v), ("status", self.status))
        ]
        client.compute(writes, sync=True)
        group = zarr.open_group(store, mode="r+")
        group.attrs["names"] = list(self.names)
        group.attrs["frame"] = self.frame
        if isinstance(self.t, Time):
            iso = self.t.utc.copy(format="isot")
            iso.precision = 9  # nanoseconds: astropy's default 3 digits lose up to 0.5 ms
            group.attrs["t_utc"] = [str(x) for x in np.ravel(iso.value)]
        else:
            group.attrs["t_s"] = [float(x) for x in np.ravel(self.t.to_value("s"))]
        group.attrs["units"] = {"r": "km", "v": "km/s"}
        return group

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


def propagate_dask(states, t, *, method: str = "sgp4", perturbations=(), chunks=None,
                   on_error: str = "raise", client=None, **cowell_options) -> DaskBatch:
    """Build a batch of propagations as dask arrays chunked over objects (and times).

    Parameters
    ----------
    states : Catalog, sequence of Satellite, or StateVectors of shape (N,)
        A catalogue for ``"sgp4"``, ``"j2"`` and ``"kepler"``; N state vectors sharing GM and
        epoch for ``"cowell"``.
    t : astropy Time, shape (T,), or Quantity (Cowell: offsets from the states' epoch)
        Output times. Catalogue methods warn once (:class:`~visviva.StaleElementSetWarning`)
        when element sets lie more than 30 days from them.
    method : {"sgp4", "j2", "kepler", "cowell"}
        The in-memory batch function each block calls
        (:func:`~visviva.satellites.catalog.propagate_sgp4_batch`,
        :func:`~visviva.satellites.catalog.propagate_j2_batch`,
        :func:`~visviva.satellites.catalog.propagate_kepler_batch`, or
        :func:`visviva.propagate_cowell` on a slice of the states).
    perturbations : list of Perturbation
        Cowell only: e.g. ``[vv.J2(vv.EARTH), vv.AtmosphericDrag(...)]``.
    chunks : int or (int, int), optional
        Objects (and times) per block. Default ``(1000, 1000)`` for the catalogue methods and
        64 objects (all times) for Cowell, whose blocks always hold every time.
    on_error : {"raise", "nan"}
        Catalogue methods: as in :func:`~visviva.satellites.catalog.propagate_sgp4_batch`; with
        ``"raise"`` the typed error surfaces from ``compute()``. Cowell always raises.
    client : distributed.Client, optional
        The cluster that :meth:`DaskBatch.compute`, ``persist`` and ``to_zarr`` use by default;
        ``None``: the current client, else a process-based ``LocalCluster`` started on first
        use (:func:`get_client`).
    **cowell_options
        Cowell only: ``rtol``, ``atol``, ``max_step``, ``max_steps`` of
        :func:`visviva.propagate_cowell`.

    Returns
    -------
    DaskBatch
        Lazy ``r``, ``v`` and ``status``; ``.compute()`` gathers a
        :class:`~visviva.satellites.catalog.BatchStates` equal to the in-memory batch.

    Examples
    --------
    >>> import numpy as np, visviva as vv                                 # doctest: +SKIP
    >>> from astropy import units as u                                    # doctest: +SKIP
    >>> lazy = vv.satellites.propagate_dask(states, np.linspace(0, 1, 97) * u.day,  # doctest: +SKIP
    ...                                     method="cowell", perturbations=[vv.J2(vv.EARTH)])
    >>> out = lazy.compute()                                              # doctest: +SKIP
    """
    _require_dask()
    if method == "cowell":
        return _cowell_dask(states, t, perturbations, chunks, client, cowell_options)
    if method not in _METHODS:
        raise InvalidInputError(
            f"method must be one of {sorted(_METHODS) + ['cowell']}, got {method!r}."
        )
    if perturbations or cowell_options:
        raise InvalidInputError(
            "perturbations and integrator options apply to method='cowell' only; the catalogue "
            f"method {method!r} takes the element sets' own force model."
        )
    import dask
    import dask.array as da

    check_on_error(on_error)
    cat = as_catalog(states)
    t = absolute_times(t, "propagate_dask")
    # once here, for every catalogue method: on process workers a block's warning would be lost
    warn_stale_times(cat, *sgp4_times(t, 0.0, 0.0)[:2])
    chunks = (1000, 1000) if chunks is None else chunks
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
        da.concatenate(rows_s, axis=0), t, cat.names, "teme", plan, client=client,
    )


def _cowell_dask(states, t, perturbations, chunks, client, options) -> DaskBatch:
    """The Cowell batch as dask arrays: blocks of objects, each with every output time."""
    import dask
    import dask.array as da
    from astropy import units as u

    from .._units import to_array, to_vector

    if not all(hasattr(states, k) for k in ("r", "v", "gm")):
        raise InvalidInputError(
            "method='cowell' takes N state vectors (vv.StateVectors of shape (N,)); got "
            f"{type(states).__name__}. For a catalogue use method='sgp4'."
        )
    from .satellite_states import require_gcrs

    require_gcrs(states, "propagate_dask(method='cowell')")
    from .burns import refuse_pending

    refuse_pending(states, "propagate_dask", "Use opm.propagate(t, perturbations), which "
                   "applies them.")
    unknown = set(options) - {"rtol", "atol", "max_step", "max_steps"}
    if unknown:
        raise InvalidInputError(
            f"unknown Cowell options {sorted(unknown)}; use rtol, atol, max_step, max_steps."
        )
    from .cowell import DEFAULT_ATOL, DEFAULT_RTOL
    from .dop853 import integration_tolerances

    integration_tolerances(options.get("rtol", DEFAULT_RTOL), options.get("atol", DEFAULT_ATOL))
    r0 = to_vector(states.r, "length", "states.r").reshape(-1, 3)
    v0 = to_vector(states.v, "speed", "states.v").reshape(-1, 3)
    gm = np.ravel(to_array(states.gm, "gm", "states.gm"))
    if r0.shape != v0.shape or gm.size not in (1, r0.shape[0]) or np.any(gm != gm[0]):
        raise InvalidInputError(
            "method='cowell' needs N states with r, v of shape (N, 3) and one GM for all."
        )
    epoch = getattr(states, "epoch", None)
    if epoch is not None and not epoch.isscalar:  # checked here, not in every worker's block
        if np.any((epoch - epoch.ravel()[0]).to_value(u.s) != 0):
            raise InvalidInputError(
                "method='cowell' needs states that share one epoch; propagate groups with "
                "equal epochs."
            )
        epoch = epoch.ravel()[0]
    if isinstance(t, Time):
        if epoch is None:
            raise InvalidInputError(
                "t is an astropy Time but the states have no epoch; give them epoch=... or "
                "pass t as offsets (e.g. np.linspace(0, 1, 97) * u.day)."
            )
        if t.ndim != 1:
            raise InvalidInputError(f"t must be 1-D; got shape {t.shape}.")
        times = t
    else:
        dt = to_array(t, "time", "t")
        if dt.ndim != 1:
            raise InvalidInputError(f"t must be a 1-D array of times; got shape {dt.shape}.")
        times = t if epoch is None else advance_epoch(epoch, dt)  # TT seconds, as Cowell
    if isinstance(chunks, (tuple, list)):
        chunks = chunks[0]
    n_chunk = _COWELL_CHUNK if chunks is None else int(chunks)
    g = float(gm[0])
    m = len(t)
    blocks_r, blocks_v, blocks_s = [], [], []
    # the force model's checks (types, central body, epoch) here, not later in a worker
    from .cowell import ForceModel, perturbation_list

    perturbations = list(perturbation_list(perturbations))
    ForceModel(g, perturbations, (), epoch, (0.0, 0.0))
    for a, b in _splits(r0.shape[0], n_chunk):
        blk = dask.delayed(_cowell_block, pure=False, nout=3)(
            r0[a:b], v0[a:b], g, epoch, t, perturbations, dict(options))
        n = b - a
        blocks_r.append(da.from_delayed(blk[0], (n, m, 3), dtype=np.float64))
        blocks_v.append(da.from_delayed(blk[1], (n, m, 3), dtype=np.float64))
        blocks_s.append(da.from_delayed(blk[2], (n, m), dtype=np.uint8))
    names = [str(i) for i in range(r0.shape[0])]
    frame = getattr(states, "frame", "gcrs")
    return DaskBatch(
        da.concatenate(blocks_r, axis=0), da.concatenate(blocks_v, axis=0),
        da.concatenate(blocks_s, axis=0), times, names, frame, client=client,
    )


def propagate_sgp4_dask(satellites, t, *, chunks=(1000, 1000), on_error: str = "raise",
                        compute: bool = False, client=None, address: str | None = None):
    """SGP4 for N satellites at T times on Dask (see :func:`propagate_dask`).

    With ``compute=True`` the graph runs at once on ``client`` / ``address`` / a LocalCluster and
    a :class:`~visviva.satellites.catalog.BatchStates` is returned; otherwise a
    :class:`DaskBatch`.
    """
    lazy = propagate_dask(satellites, t, method="sgp4", chunks=chunks, on_error=on_error,
                          client=client)
    return lazy.compute(client=client, address=address) if compute else lazy
