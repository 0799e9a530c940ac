"""Catalogue-scale SGP4, secular J2 and Dask, timed against sgp4's SatrecArray in one process.

Rows (ratio = visviva time / reference time; below 1 visviva is faster):

* ``sgp4 batch``: :func:`visviva.satellites.catalog.propagate_sgp4_batch` (Time in, Quantities
  out, error check) vs a bare ``SatrecArray.sgp4(jd, fr)`` on prepared Julian dates. Target:
  at least 0.95x the throughput, i.e. ratio <= 1/0.95.
* ``secular J2 batch``: :func:`propagate_j2_batch` vs ``SatrecArray``. Target: 3x faster.

Dask scale-out (process workers) is timed in ``benchmarks/bench_dask.py``.

Run: ``python -m benchmarks`` (all) or ``python -m benchmarks.bench_sgp4``.
"""

from __future__ import annotations

import time

import numpy as np

try:  # as part of the package (python -m benchmarks) or as a script
    from .common import (
        compile_time,
        interleaved_medians,
        quick_from_env,
        result,
        time_call,
    )
except ImportError:  # pragma: no cover
    from common import compile_time, quick_from_env, result, time_call


def synthetic_catalog(n: int, seed: int = 0, *, prefix: str = "SYN", first_id: int = 10000,
                      epoch: str = "2024-01-01T00:00:00.000000",
                      mean_motion: tuple = (11.0, 15.6), eccentricity: tuple = (1e-4, 0.02),
                      inclination: tuple = (0.0, 110.0)):
    """``n`` element sets (OMM records) with spread-out angles and drag terms, as a Catalog.

    The defaults span LEO to MEO; the keywords narrow a population (e.g. LEO only).

    Parameters
    ----------
    n : int
        Number of satellites.
    seed : int
        Seed of the random generator (same seed and keywords, same catalog).
    prefix : str
        ``OBJECT_NAME`` is ``f"{prefix}-{k:05d}"``.
    first_id : int
        ``NORAD_CAT_ID`` of the first satellite; the others count up.
    epoch : str
        ``EPOCH`` of every element set (ISO, UTC).
    mean_motion, eccentricity, inclination : (float, float)
        Uniform ranges of the mean motion (rev/day), the eccentricity and the inclination
        (deg). Node, argument of perigee and mean anomaly are uniform in [0, 360) deg, B* in
        [0, 2e-4) 1/earth radii.
    """
    from visviva.satellites.catalog import Catalog
    from visviva.satellites.tle import Satellite

    rng = np.random.default_rng(seed)
    records = []
    for k in range(n):
        records.append({
            "OBJECT_NAME": f"{prefix}-{k:05d}",
            "NORAD_CAT_ID": first_id + k,
            "EPOCH": epoch,
            "MEAN_MOTION": float(rng.uniform(*mean_motion)),
            "ECCENTRICITY": float(rng.uniform(*eccentricity)),
            "INCLINATION": float(rng.uniform(*inclination)),
            "RA_OF_ASC_NODE": float(rng.uniform(0.0, 360.0)),
            "ARG_OF_PERICENTER": float(rng.uniform(0.0, 360.0)),
            "MEAN_ANOMALY": float(rng.uniform(0.0, 360.0)),
            "BSTAR": float(rng.uniform(0.0, 2e-4)),
            "MEAN_MOTION_DOT": 0.0,
            "MEAN_MOTION_DDOT": 0.0,
        })
    return Catalog([Satellite.from_omm(r) for r in records])


def _times(m: int):
    from astropy import units as u
    from astropy.time import Time

    return Time("2024-01-01T00:00:00", scale="utc") + np.linspace(0.0, 1.0, m) * u.day


def _cpu_seconds(fn, rounds: int = 3) -> float:
    """Median process CPU time of ``fn()`` (all threads), insensitive to other processes."""
    import statistics

    out = []
    for _ in range(rounds):
        c0 = time.process_time()
        fn()
        out.append(time.process_time() - c0)
    return statistics.median(out)


def run(quick: bool = False) -> list[dict]:
    from visviva.satellites import catalog as vcat

    quick = quick or quick_from_env()
    rows = []
    n, m = (300, 300) if quick else (1000, 1000)
    cat = synthetic_catalog(n)
    t = _times(m)
    tu = t.utc
    jd, fr = np.ascontiguousarray(tu.jd1), np.ascontiguousarray(tu.jd2)
    sa = cat.satrec_array

    first = compile_time(vcat.propagate_sgp4_batch, cat, t)
    time_call(sa.sgp4, jd, fr, repeat=1, number=1)  # warm caches
    ref, ours = interleaved_medians(lambda: sa.sgp4(jd, fr), lambda: vcat.propagate_sgp4_batch(cat, t),
                            rounds=9)
    rows.append(result(
        f"sgp4 batch, {n} satellites x {m} times", ours,
        f"sgp4 SatrecArray.sgp4 ({n * m / ref / 1e6:.2f} M/s)", ref, target=1 / 0.95,
        compile_s=first,
        notes=f"visviva {n * m / ours / 1e6:.2f} M propagations/s; 1 thread (sgp4 C++); "
        "medians of alternating rounds",
    ))

    first = compile_time(vcat.propagate_j2_batch, cat, t)
    ref2, j2 = interleaved_medians(lambda: sa.sgp4(jd, fr), lambda: vcat.propagate_j2_batch(cat, t),
                           rounds=9)
    cpu_j2, cpu_ref = _cpu_seconds(lambda: vcat.propagate_j2_batch(cat, t)), _cpu_seconds(
        lambda: sa.sgp4(jd, fr))
    rows.append(result(
        f"secular J2 batch, {n} x {m}", j2, "sgp4 SatrecArray.sgp4", ref2, target=1 / 3.0,
        compile_s=first,
        notes=f"{n * m / j2 / 1e6:.2f} M propagations/s; CPU time per call {cpu_j2:.3f} s "
        f"vs sgp4 {cpu_ref:.3f} s (all threads; wall time gains up to the core count on an "
        "idle machine)",
    ))

    return rows


if __name__ == "__main__":  # pragma: no cover
    import sys

    for row in run(quick="--quick" in sys.argv):
        print(row)
