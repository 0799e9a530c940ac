"""Kepler's equation, 10^6 elliptic solves, timed against kepler.py (dfm's C++ solver).

Rows (ratio = visviva time / reference time; below 1 visviva is faster):

* ``solve_kepler, 1e6, 1 thread``: ``vv.solve_kepler(M, e)`` (public API: input checks,
  broadcasting, one kernel call, status check) with ``numba.set_num_threads(1)``, against
  ``kepler.solve(M, e)`` of the kepler.py package (single-threaded C++, Raposo-Pulido &
  Pelaez 2017 / Brandt et al. 2021). Target: at least as fast (ratio <= 1).
* ``solve_kepler, 1e6, 2 threads``: the same with two numba threads. Target: at least twice as
  fast as kepler.py on one thread (ratio <= 0.5).
* ``core kernel, 1e6, 1 thread``: ``visviva.core.kepler_arrays.solve_kepler_array`` on preallocated
  outputs (the compiled kernel alone), for reference (no target).
* ``mean_to_true, 1e6, 1 thread``: the public conversion for mixed e in [0, 3], against
  ``kepler.kepler`` (E, cos nu, sin nu for e < 1 only; no target).

M is uniform in [0, 2 pi), e uniform in [0, 1) (seeded). The notes give the largest residual
|E - e sin E - M| of both libraries on the same inputs and the largest |E_vv - E_kepler.py|.

Run: ``python -m benchmarks --only kepler`` or ``python -m benchmarks.bench_kepler``.
"""

from __future__ import annotations

import numpy as np

try:  # as part of the package (python -m benchmarks) or as a script
    from .common import compile_time, quick_from_env, result, skipped, threads, time_call
except ImportError:  # pragma: no cover
    from common import compile_time, quick_from_env, result, skipped, threads, time_call


def run(quick: bool = False) -> list[dict]:
    quick = quick or quick_from_env()
    import visviva as vv
    from visviva.core import kepler_arrays as core
    try:
        from importlib.metadata import version

        import kepler

        ref_name = f"kepler.py {version('kepler.py')} kepler.solve (C++, 1 thread)"
    except ImportError as exc:  # pragma: no cover (PackageNotFoundError is an ImportError)
        return [skipped("solve_kepler", f"kepler.py not installed: {exc}", "kepler.py")]

    n = 100_000 if quick else 1_000_000
    repeat = 3 if quick else 9
    rng = np.random.default_rng(1995)
    M = rng.uniform(0.0, 2.0 * np.pi, n)
    ecc = rng.uniform(0.0, 1.0, n)
    size = f"{n:.0e}".replace("+0", "")

    first = compile_time(vv.solve_kepler, M, ecc)
    E_vv = vv.solve_kepler(M, ecc)
    E_ref = kepler.solve(M, ecc)
    res_vv = float(np.max(np.abs(E_vv - ecc * np.sin(E_vv) - M)))
    res_ref = float(np.max(np.abs(E_ref - ecc * np.sin(E_ref) - M)))
    diff = float(np.max(np.abs(E_vv - E_ref)))
    accuracy = f"max residual vv {res_vv:.1e}, kepler.py {res_ref:.1e}; max |dE| {diff:.1e}"

    t_ref = time_call(kepler.solve, M, ecc, repeat=repeat, number=1)
    rows = []
    with threads(1):
        t1 = time_call(vv.solve_kepler, M, ecc, repeat=repeat, number=1)
    rows.append(result(f"solve_kepler, {size} elliptic, 1 thread", t1, ref_name, t_ref,
                       target=1.0, compile_s=first,
                       notes=f"1 thread; {n / t1.median / 1e6:.1f} M solves/s vs "
                             f"{n / t_ref.median / 1e6:.1f} M/s; {accuracy}"))  # fmt: skip
    with threads(2) as used:
        t2 = time_call(vv.solve_kepler, M, ecc, repeat=repeat, number=1)
    rows.append(result(f"solve_kepler, {size} elliptic, {used} threads", t2, ref_name, t_ref,
                       target=0.5,
                       notes=f"{used} thread(s) vs kepler.py on 1 thread; "
                             f"{n / t2.median / 1e6:.1f} M solves/s"))  # fmt: skip

    E_out = np.empty(n)
    status = np.empty(n, dtype=np.int8)
    with threads(1):
        tk = time_call(core.solve_kepler_array, M, ecc, E_out, status, repeat=repeat, number=1)
    rows.append(result(f"core solve_kepler_array, {size}, 1 thread", tk, ref_name, t_ref,
                       notes=f"1 thread; compiled kernel alone, preallocated outputs; "
                             f"{n / tk.median / 1e6:.1f} M solves/s"))  # fmt: skip

    ecc_mixed = rng.uniform(0.0, 3.0, n)
    first_nu = compile_time(vv.mean_to_true, M, ecc_mixed)
    with threads(1):
        tn = time_call(vv.mean_to_true, M, ecc_mixed, repeat=repeat, number=1)
    t_ref_nu = time_call(kepler.kepler, M, ecc, repeat=repeat, number=1)
    rows.append(result(f"mean_to_true, {size}, e in [0, 3], 1 thread", tn,
                       "kepler.py kepler.kepler (E, cos nu, sin nu; e < 1 only)", t_ref_nu,
                       compile_s=first_nu,
                       notes="1 thread; a third of the items hyperbolic (iterative)"))  # fmt: skip
    return rows


if __name__ == "__main__":  # pragma: no cover
    for row in run():
        print(row)
