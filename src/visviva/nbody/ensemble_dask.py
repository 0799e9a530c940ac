"""An :class:`~visviva.Ensemble` spread over Dask workers (``Ensemble.integrate(t, client=...)``).

The members are cut into contiguous blocks, one per worker thread slot (so that a block's compiled
call keeps one core busy); each block travels to a worker as ONE bytes object (the block's
simulations pickled here at protocol 5: the complete state, integrator internals included), runs
there as an ensemble of its own with as many numba threads as the worker has threads, and comes
back the same way. Every member runs the same kernel on the same numbers as in this process, so
the results are identical. Requires the ``scale`` extra.

Why one bytes object per block: handed a list of simulations, Dask's serialisation walks it and
frames every array of every member separately (about eight per member); for 512 three-body
members that cost 0.2-0.35 s of CPU in this process alone per call, as much as the integration it
distributes (measured: a round trip of 512 members to one worker, 0.4-0.9 s as objects,
0.07-0.2 s as one pickled block). Blocks above :data:`SCATTER_BYTES` are scattered to the workers
first rather than embedded in the task graph.
"""

from __future__ import annotations

import pickle

import numpy as np

from ..errors import InvalidInputError

__all__ = ["integrate_on_dask", "resolve_client", "SCATTER_BYTES"]

#: Blocks larger than this (bytes, pickled) are scattered to the workers before the tasks start.
SCATTER_BYTES = 8 * 2**20


def resolve_client(client):
    """A ``dask.distributed.Client`` from what :meth:`Ensemble.integrate` accepts.

    ``True`` or ``"local"``: a LocalCluster of two process workers with one thread each (started
    once, reused; see :func:`visviva._dask.get_client`); a string: the scheduler at that address;
    a client: itself.
    """
    from .._dask import get_client, require_dask

    require_dask()
    if client is True or (isinstance(client, str) and client == "local"):
        return get_client(n_workers=2, processes=True, threads_per_worker=1)
    if isinstance(client, str):
        return get_client(client)
    if not hasattr(client, "submit"):
        raise InvalidInputError(
            f"client must be a dask.distributed.Client, a scheduler address such as "
            f"'tcp://host:8786', or True/'local' for a local cluster; got {client!r}."
        )
    return client


def _pack(obj) -> bytes:
    return pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)


def _run_block(blob: bytes, t, advance) -> bytes:
    """Worker side: unpack a block, give ``advance`` this worker's numba threads, run it on the
    block and pack ``(members, errors)`` for the way back."""
    import numba

    threads = 1
    try:
        from distributed import get_worker

        threads = max(1, int(get_worker().state.nthreads))
    except (ImportError, ValueError, AttributeError):  # pragma: no cover - outside a worker
        pass
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    return _pack(advance(pickle.loads(blob), t))


def integrate_on_dask(members: list, t, client, advance) -> list:
    """Advance ``members`` in place on the workers of ``client``; returns the errors.

    ``advance(block, t) -> (block, [(index in block, exception), ...])`` runs on a worker (it
    must pickle by reference: a module-level function or a ``functools.partial`` of one); the
    caller (:meth:`visviva.Ensemble.integrate`) supplies it, so this module does not know the
    ensemble class.
    """
    client = resolve_client(client)
    workers = client.scheduler_info().get("workers", {})
    slots = sum(int(w.get("nthreads", 1)) for w in workers.values()) or 1
    n_blocks = min(len(members), slots)
    bounds = np.linspace(0, len(members), n_blocks + 1).round().astype(int)
    blocks = [_pack(members[a:b]) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
    if max(len(b) for b in blocks) > SCATTER_BYTES:
        blocks = client.scatter(blocks, hash=False)
    futures = client.map(_run_block, blocks, t=t, advance=advance, pure=False)
    errors = []
    for a, blob in zip(bounds[:-1], client.gather(futures), strict=True):
        done, block_errors = pickle.loads(blob)
        members[a:a + len(done)] = done
        errors.extend((int(a) + k, exc) for k, exc in block_errors)
    return errors
