"""Conjunction screening and collision probability, timed against their natural references.

Rows (ratio = visviva time / reference time):

* ``screening``: :func:`visviva.screen_conjunctions` of a synthetic LEO catalogue against itself
  over one day vs plain SGP4 propagation of the same catalogue at 60 s steps (sgp4's
  ``SatrecArray``): the cost of the whole filter chain and refinement in units of "propagating
  the catalogue once". No target (all-vs-all screening grows as N^2, propagation as N).
* ``Pc foster``: one :func:`visviva.collision_probability` call (public API, units, checks) vs
  scipy's ``dblquad`` of the same 2-D Gaussian over the HBR circle at 1e-10 relative (the obvious
  way). The notes give the evaluations per second of the public call and of the compiled kernel
  over an array (``visviva.core.collision.log_pc_many``).
* ``Pc foster of K conjunctions``: :func:`visviva.collision_probabilities` over K = 10,000
  LEO conjunctions (quick: 1,000) vs a loop of K :func:`visviva.collision_probability` calls
  (the values are identical; the note says so).
* ``all-vs-all``: a 10,000-object catalogue over one day (quick: 1,000), single process vs Dask
  ``LocalCluster(processes=True)`` with 2 workers (blocks of primaries are independent).

Run: ``python -m benchmarks --only conjunctions`` or ``python -m benchmarks.bench_conjunctions``.
"""

from __future__ import annotations

import math
import os
import time

import numpy as np

try:  # as part of the package (python -m benchmarks) or as a script
    from .common import failed, interleaved, result, skipped, time_call
except ImportError:  # pragma: no cover
    from common import failed, interleaved, result, skipped, time_call


def _catalog(n, seed=1):
    from visviva.conjunctions.synthetic import synthetic_catalog

    return synthetic_catalog(n, seed=seed, crossing_pairs=2)


def _screen_row(n):
    import astropy.units as u

    from visviva.conjunctions.screening import screen_conjunctions

    cat = _catalog(n)
    t0 = cat.epochs[0]
    first = time.perf_counter()
    screen_conjunctions(cat[:20], None, t0, t0 + 1 * u.hour)
    first = time.perf_counter() - first
    t = time.perf_counter()
    tab = screen_conjunctions(cat, None, t0, t0 + 1 * u.day)
    ts = time.perf_counter() - t
    jd = np.full(1441, t0.utc.jd1)
    fr = t0.utc.jd2 + np.arange(1441) * 60.0 / 86400.0
    sat = cat.satrec_array
    tp = time_call(lambda: sat.sgp4(jd, fr), repeat=3).median
    return result(f"screening {n} objects x 1 day (self, 5 km)", ts,
                  "sgp4 SatrecArray, same catalogue at 60 s steps", tp, compile_s=first,
                  notes=f"{len(tab)} conjunctions found; one run")


def _pc_row():
    from scipy import integrate, stats

    import visviva as vv
    from visviva.core import collision as kern
    from visviva.validation.checks_conjunctions import om1_args

    r1, v1, c1, r2, v2, c2, hbr = om1_args()  # CARA Omitron case 1
    first = time.perf_counter()
    vv.collision_probability(r1, v1, c1, r2, v2, c2, hbr)
    first = time.perf_counter() - first
    tv = time_call(vv.collision_probability, r1, v1, c1, r2, v2, c2, hbr, repeat=5).median
    plane = vv.conjunctions.encounter_plane(r1, v1, c1, r2, v2, c2, hbr)
    (xm, zm), (sx, sz) = plane.principal_miss, plane.sigma

    def ref():
        def f(z, x):
            return stats.norm.pdf(x, 0, sx) * stats.norm.pdf(z, 0, sz)

        def half(x):
            return math.sqrt(max(hbr * hbr - (x - xm) ** 2, 0.0))

        return integrate.dblquad(f, xm - hbr, xm + hbr, lambda x: zm - half(x),
                                 lambda x: zm + half(x), epsabs=0, epsrel=1e-10)[0]

    tr = time_call(ref, repeat=3).median
    # the kernel over an array of 10^4 random geometries
    rng = np.random.default_rng(0)
    n = 10_000
    xs, zs = rng.uniform(0, 500, n), rng.uniform(0, 500, n)
    sxs, szs = rng.uniform(50, 2000, n), rng.uniform(5, 200, n)
    rs = rng.uniform(2, 30, n)
    out = np.empty(n)
    st = np.empty(n, dtype=np.int64)

    def many():
        kern.log_pc_many(xs, zs, np.maximum(sxs, szs), np.minimum(sxs, szs), rs, kern.GAUSS_LO,
                         kern.GAUSS_HI, 1e-13, out, st)

    many()
    tk = time_call(many, repeat=3).median
    return result("Pc foster (CARA Omitron case, 1e-10)", tv,
                  "scipy dblquad, epsrel 1e-10", tr, target=0.1, compile_s=first,
                  notes=f"public call {1 / tv:,.0f} Pc/s; kernel over 1e4 geometries "
                        f"{n / tk:,.0f} Pc/s")


def _all_vs_all_rows(n, log=None):
    import astropy.units as u

    from visviva.conjunctions.screening import screen_conjunctions

    def say(text):
        if log is not None:
            print(text, file=log, flush=True)

    cat = _catalog(n, seed=7)
    t0 = cat.epochs[0]
    screen_conjunctions(cat[:20], None, t0, t0 + 1 * u.hour)
    t = time.perf_counter()
    tab = screen_conjunctions(cat, None, t0, t0 + 1 * u.day)
    single = time.perf_counter() - t
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    say(f"single process: {single:.1f} s, {len(tab)} conjunctions, load {load:.1f}")
    rows = [result(f"all-vs-all {n} objects x 1 day, single process", single, "", None,
                   notes=f"{len(tab)} conjunctions < 5 km; numba threads; "
                         f"load average {load:.1f} at the end")]
    try:
        import dask
        from distributed import Client, LocalCluster
    except ImportError:
        return rows + [skipped("all-vs-all on Dask", "dask.distributed not installed")]
    try:
        with dask.config.set({"distributed.comm.timeouts.connect": "300s",
                              "distributed.comm.timeouts.tcp": "300s"}), \
                LocalCluster(n_workers=2, processes=True, threads_per_worker=1,
                             dashboard_address=None) as cluster, Client(cluster) as client:
            client.run(lambda: None)
            t = time.perf_counter()
            tab2 = screen_conjunctions(cat, None, t0, t0 + 1 * u.day, client=client)
            dask_s = time.perf_counter() - t
            load2 = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    except Exception as exc:  # keep the single-process row; the failure shows as a row
        return rows + [failed("all-vs-all on Dask", exc)]
    say(f"dask: {dask_s:.1f} s, {len(tab2)} conjunctions")
    rows.append(result(f"all-vs-all {n} objects x 1 day: Dask 2 process workers", dask_s,
                       "the same screen in a single process (numba threads)", single,
                       notes=f"{len(tab2)} conjunctions < 5 km (single process: {len(tab)}); "
                             "1 thread per worker; each worker propagates the catalogue once; "
                             f"load average {load2:.1f} at the end"))
    return rows


def _pruning_row(n):
    """Pairs left by the apogee/perigee filter and by the orbit-path filter after it."""
    from visviva.conjunctions.screening import filter_statistics
    from visviva.conjunctions.sources import SgpSource

    cat = _catalog(n, seed=7)
    t0 = cat.epochs[0]
    src = SgpSource(cat, float(t0.utc.jd1), float(t0.utc.jd2))
    t = time.perf_counter()
    # the filters alone, on the mean elements (step_s=None: no sampling; the synthetic LEO
    # objects are not widened by their samples, so the counts are the screen's)
    after_ap, after_path = filter_statistics(src, src, 86400.0, 5.0, step_s=None)
    tp = time.perf_counter() - t
    pairs = n * (n - 1) // 2
    return result(f"orbit-path filter, {n} objects x 1 day", tp, "", None,
                  notes=f"{pairs:,} pairs; apogee/perigee keeps {after_ap:,} "
                        f"({after_ap / pairs:.1%}); orbit path keeps {after_path:,} "
                        f"({after_path / max(after_ap, 1):.1%} of those)")


def _alfano_cases():
    """Alfano's (2009) twelve conjunctions (tests/data/alfano2009_cara.csv): case number ->
    (collision_probability's positional arguments, the A09 half window in s)."""
    import csv
    import io
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "tests" / "data" / "alfano2009_cara.csv"
    rows = [ln for ln in path.read_text().splitlines(keepends=True) if not ln.startswith("#")]
    cases = {}
    for row in csv.DictReader(io.StringIO("".join(rows))):
        args = []
        for o in "12":
            args.append(np.array([float(row[f"r{o}_{a}_m"]) for a in "xyz"]))
            args.append(np.array([float(row[f"v{o}_{a}_m_s"]) for a in "xyz"]))
            args.append(np.array([float(row[f"cov{o}_{i}{j}"]) for i in range(1, 7)
                                  for j in range(1, 7)]).reshape(6, 6))
        args.append(float(row["hbr_m"]))
        cases[int(row["case"])] = (tuple(args), float(row["a09_final_time_s"]))
    return cases


def _pc3d_rows(quick: bool):
    """Hall's 3D-Nc per conjunction on Alfano's cases, beside the Foster 2-D integral and the
    linear-motion "3d" flux integral, timed in alternation in one process."""
    import warnings

    from visviva.conjunctions import collision_probability
    from visviva.errors import Pc3dAccuracyWarning

    cases = _alfano_cases()
    numbers = [1, 5, 9] if quick else [n for n in cases if n != 12]  # 12: no relative velocity

    def every(method, windowed):
        def go():
            for n in numbers:
                args, w = cases[n]
                kw = {"window": (-w, w)} if windowed else {}
                collision_probability(*args, method=method, gm=3.986004418e5, **kw)
        return go

    args, w = cases[numbers[0]]
    t0 = time.perf_counter()  # the first call compiles the kernels or loads them from the cache
    collision_probability(*args, method="pc3d_hall", gm=3.986004418e5, window=(-w, w))
    first = time.perf_counter() - t0
    with warnings.catch_warnings():  # "3d" is checked against 3D-Nc (in its time), and warns
        warnings.simplefilter("ignore", Pc3dAccuracyWarning)
        hall, foster, flux = interleaved([every("pc3d_hall", True), every("foster", False),
                                          every("3d", False)], rounds=2 if quick else 3)
    k = len(numbers)
    label = f"Alfano cases {numbers[0]}-{numbers[-1]}" if not quick else "Alfano cases 1, 5, 9"
    notes = ("per conjunction (mean over the cases); adaptive time integral 1e-6, "
             "density-adapted sphere rule")
    return [result(f"Pc3D_Hall (3D-Nc) per conjunction, {label}", hall.median / k,
                   "Foster 2-D, same cases", foster.median / k, notes=notes,
                   compile_s=first),
            result(f"Pc3D_Hall (3D-Nc) per conjunction, {label}", hall.median / k,
                   'method="3d" (flux integral, checked against 3D-Nc), same cases', flux.median / k,
                   notes=notes)]


def _batch_pc_row(k):
    """vv.collision_probabilities of K LEO conjunctions at TCA (miss ~300 m, sigmas ~100 m,
    HBR 5-50 m, 3x3 covariances) vs a loop of K vv.collision_probability calls (same values)."""
    import warnings

    import visviva as vv

    rng = np.random.default_rng(1)
    r1 = np.array([7.0e6, 0.0, 0.0]) + rng.normal(0.0, 1e3, (k, 3))
    v1 = np.array([0.0, 7.5e3, 0.0]) + rng.normal(0.0, 10.0, (k, 3))
    v2 = np.array([0.0, 0.0, 7.5e3]) + rng.normal(0.0, 500.0, (k, 3))
    d = rng.normal(0.0, 300.0, (k, 3))
    rel = v1 - v2
    d -= (np.sum(d * rel, 1) / np.sum(rel * rel, 1))[:, None] * rel
    a = rng.normal(0.0, 100.0, (2, k, 3, 3))
    c = a @ np.swapaxes(a, -1, -2) + np.eye(3) * 1e-2
    args = (r1, v1, c[0], r1 - d, v2, c[1], rng.uniform(5.0, 50.0, k))

    def batch():
        return vv.collision_probabilities(*args)

    def loop():
        return np.array([vv.collision_probability(*(x[i] for x in args)) for i in range(k)])

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tb, tl = interleaved([batch, loop], rounds=3)
        same = bool(np.array_equal(batch(), loop()))
    return result(f"Pc foster of {k} conjunctions: collision_probabilities", tb,
                  f"loop of {k} collision_probability calls", tl,
                  notes=f"{k / tb.median:,.0f} Pc/s batched, {k / tl.median:,.0f} Pc/s looped; "
                        f"values identical: {same}")


def run(quick: bool = False) -> list[dict]:
    rows = [_screen_row(300 if quick else 2000), _pc_row(), _batch_pc_row(1000 if quick else 10_000),
            _pruning_row(1000 if quick else 10_000),
            *_pc3d_rows(quick)]
    rows.extend(_all_vs_all_rows(1000 if quick else 10_000))
    return rows


if __name__ == "__main__":  # pragma: no cover
    import sys

    for row in run(quick="--quick" in sys.argv):
        print(row)
