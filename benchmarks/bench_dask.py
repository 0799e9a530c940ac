"""Scale-out on Dask: 2 process workers against the single-process path, same results.

Rows (ratio = Dask time / single-process time; below 1 Dask is faster; the target 0.625 is a
1.6x speed-up on 2 workers):

* ``dask sgp4 catalogue``: :func:`propagate_dask` (``method="sgp4"``) on a ``LocalCluster`` of 2
  process workers (1 thread each) vs :func:`propagate_sgp4_batch` in this process (sgp4's C++
  loop, one core). Timed twice: gathered into this process (``compute()``), and kept on the
  workers (``persist()``), as a large result should be.
* ``dask cowell batch``: a batch of Cowell propagations with J2 (``method="cowell"``) on the same
  cluster vs :func:`visviva.propagate_cowell` on the batch in this process with one numba
  thread; the notes add the in-process run with every numba thread.

Every Dask result is checked equal (bit for bit) to the single-process one. The notes give the
load average of the machine before and after (other processes compete for the same cores).
"""

from __future__ import annotations

import os
import time

import numpy as np

try:  # as part of the package (python -m benchmarks) or as a script
    from .bench_sgp4 import _cpu_seconds, _times, interleaved_medians, synthetic_catalog
    from .common import quick_from_env, result, skipped, threads
except ImportError:  # pragma: no cover
    from bench_sgp4 import _cpu_seconds, _times, synthetic_catalog
    from common import quick_from_env, result, skipped, threads


def _load() -> str:
    try:
        return "/".join(f"{x:.1f}" for x in os.getloadavg())
    except OSError:  # pragma: no cover
        return "n/a"


def _cpu_split(client, fn, rounds: int = 3):
    """Median CPU seconds of one ``fn()`` call: in each worker and in this process (client and
    scheduler). Insensitive to other processes on the machine, unlike wall time."""
    import statistics

    workers, here = [], []
    for _ in range(rounds):
        w0 = client.run(time.process_time)
        c0 = time.process_time()
        fn()
        here.append(time.process_time() - c0)
        w1 = client.run(time.process_time)
        workers.append(sorted(w1[k] - w0[k] for k in w1))
    per_worker = [statistics.median(w[i] for w in workers) for i in range(len(workers[0]))]
    return per_worker, statistics.median(here)


def _cpu_note(single_cpu: float, per_worker, here: float) -> str:
    """Speed-up on idle cores estimated from CPU time: the busiest worker bounds the wall time."""
    busiest = max(per_worker)
    return (f"CPU s: one process {single_cpu:.3g}; Dask workers "
            f"{', '.join(f'{w:.3g}' for w in per_worker)}, this process {here:.3g} -> on idle "
            f"cores about {single_cpu / max(busiest, here):.2f}x (single-process CPU / busiest "
            "Dask process)")


def _leo_states(n: int):
    from astropy import units as u
    from astropy.time import Time

    import visviva as vv

    rng = np.random.default_rng(3)
    el = vv.KeplerianElements.from_semi_major_axis(
        (6778.0 + rng.uniform(0, 1500, n)) * u.km, rng.uniform(0, 0.02, n),
        rng.uniform(0.1, 1.7, n) * u.rad, rng.uniform(0, 6, n) * u.rad,
        rng.uniform(0, 6, n) * u.rad, rng.uniform(-3, 3, n) * u.rad, vv.EARTH,
        epoch=Time("2024-03-01T00:00:00", scale="utc"))
    return el.to_state()


def run(quick: bool = False) -> list[dict]:
    try:
        from distributed import Client, LocalCluster, futures_of, wait
    except ImportError:
        return [skipped("dask scale-out", "dask.distributed not installed")]
    from astropy import units as u

    import visviva as vv
    from visviva.satellites import catalog as vcat
    from visviva.satellites.dask_batch import propagate_dask

    quick = quick or quick_from_env()
    rows = []
    load0 = _load()
    import dask

    # as visviva.satellites.dask_batch.get_client starts its LocalCluster
    with dask.config.set({"distributed.worker.profile.enabled": False}), \
            LocalCluster(n_workers=2, processes=True, threads_per_worker=1,
                         dashboard_address=None, env={"NUMBA_NUM_THREADS": "1"}) as cluster, \
            Client(cluster, set_as_default=False) as client:
        # -- SGP4 catalogue ---------------------------------------------------------------------
        n, m = (2000, 720) if quick else (6000, 1440)
        cat = synthetic_catalog(n, seed=1)
        t = _times(m)
        chunks = (n // 8, m)
        mem = vcat.propagate_sgp4_batch(cat, t)
        out = propagate_dask(cat, t, chunks=chunks, client=client).compute()  # warm workers
        same = np.array_equal(out.r.value, mem.r.value) and np.array_equal(out.v.value,
                                                                             mem.v.value)
        del out

        def gathered():
            propagate_dask(cat, t, chunks=chunks, client=client).compute()

        def kept():
            batch = propagate_dask(cat, t, chunks=chunks, client=client).persist()
            with client.as_current():
                wait(futures_of([batch.r, batch.v, batch.status]))
            del batch

        rounds = 3 if quick else 5
        dk, single = interleaved_medians(gathered, lambda: vcat.propagate_sgp4_batch(cat, t), rounds)
        dk_kept, single2 = interleaved_medians(kept, lambda: vcat.propagate_sgp4_batch(cat, t), rounds)
        single_cpu = _cpu_seconds(lambda: vcat.propagate_sgp4_batch(cat, t))
        for label, ours, ref, fn in (("gathered by compute()", dk, single, gathered),
                                     ("kept on the workers by persist()", dk_kept, single2, kept)):
            rows.append(result(
                f"dask sgp4 catalogue {n} x {m}, 2 process workers, {label}", ours,
                "propagate_sgp4_batch in one process (sgp4 C++, 1 core)", ref,
                target=1 / 1.6,
                notes=f"speed-up {ref / ours:.2f}x (wall); {_cpu_note(single_cpu, *_cpu_split(client, fn))}; "
                f"results identical: {same}; chunks {chunks}; load average before {load0}, now "
                f"{_load()} (2 cores shared)",
            ))
        # -- Cowell batch -----------------------------------------------------------------------
        n_c = 256 if quick else 1024
        states = _leo_states(n_c)
        tc = np.linspace(0, 1.0, 97) * u.day
        perts = [vv.J2(vv.EARTH)]
        with threads(1):
            mem = vv.propagate_cowell(states, tc, perts)
        lazy = propagate_dask(states, tc, method="cowell", perturbations=perts, chunks=n_c // 8,
                              client=client)
        out = lazy.compute()  # warm: compiles or loads numba's cache in each worker
        same = np.array_equal(out.r.value, mem.r.value) and np.array_equal(out.v.value,
                                                                           mem.v.value)

        def cowell_dask():
            propagate_dask(states, tc, method="cowell", perturbations=perts, chunks=n_c // 8,
                           client=client).compute()

        def cowell_single():
            with threads(1):
                vv.propagate_cowell(states, tc, perts)

        dk, single = interleaved_medians(cowell_dask, cowell_single, rounds=3)
        cpu = _cpu_note(_cpu_seconds(cowell_single), *_cpu_split(client, cowell_dask))
        t0 = time.perf_counter()
        with threads(None) as k:
            vv.propagate_cowell(states, tc, perts)
        all_threads = time.perf_counter() - t0
        rows.append(result(
            f"dask cowell batch, {n_c} LEO states x {len(tc)} times over "
            f"{tc[-1].to_value(u.day):g} d with J2, 2 process workers", dk,
            "propagate_cowell on the batch in one process, 1 numba thread", single,
            target=1 / 1.6,
            notes=f"speed-up {single / dk:.2f}x (wall); {cpu}; results identical: {same}; in one "
            f"process with "
            f"{k} numba threads: {all_threads:.3g} s; load average before {load0}, now "
            f"{_load()} (2 cores shared)",
        ))
    return rows


if __name__ == "__main__":  # pragma: no cover
    import sys

    for row in run(quick="--quick" in sys.argv):
        print(row)
