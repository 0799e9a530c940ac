"""Where a GPU ensemble's per-call cost goes (not a test: a measurement for a lent GPU,
``python tests/gpu/profile_ensemble_call.py [MEMBERS]``).

On an NVIDIA H200 (2026-11-27) a 1-step ``Ensemble.integrate`` of 131,072 three-body leapfrog
members took 188-240 ms on the GPU (the CPU ensemble's took 79 ms on 16 cores), while 1,000
steps in the resident kernel took only ~5 ms more: the call's fixed cost, not the kernel, bounds
short calls. This prints a profile of one such call (``profile_*`` lines: the functions with
the largest own time) and the host-device copy rates of pageable and pinned memory for an array
of the size of the ensemble's positions (``copy_*`` lines, GB/s), so the next change aims at
what dominates.
"""

from __future__ import annotations

import cProfile
import io
import os
import pstats
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", ".."))


def copy_rates(n_particles):
    """Host-to-device and back, pageable and pinned, GB/s (median of 5)."""
    from numba import cuda

    a = np.random.default_rng(0).normal(size=(n_particles, 3))
    pinned = cuda.pinned_array(a.shape)
    pinned[:] = a
    d = cuda.to_device(a)
    for name, host in (("pageable", a), ("pinned", pinned)):
        up, down = [], []
        for _ in range(5):
            t0 = time.perf_counter()
            cuda.to_device(host, to=d)
            cuda.synchronize()
            up.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            d.copy_to_host(host)
            down.append(time.perf_counter() - t0)
        print(f"copy_{name}_up_GBs={a.nbytes / np.median(up) / 1e9:.3g}")
        print(f"copy_{name}_down_GBs={a.nbytes / np.median(down) / 1e9:.3g}")
    t0 = time.perf_counter()
    for _ in range(5):
        cuda.device_array(a.shape)
    print(f"alloc_ms={(time.perf_counter() - t0) / 5 * 1e3:.3g}")


def main():
    import benchmarks.bench_gpu as b

    import visviva as vv

    members = int(sys.argv[1]) if len(sys.argv) > 1 else 131_072
    os.environ["VISVIVA_GPU_RESIDENT"] = "1"
    proto = [b._system(1.0 + k / 4096, "leapfrog", dt=0.01) for k in range(4096)]
    ens = vv.Ensemble.from_simulations((proto * (members // 4096 + 1))[:members],
                                       backend="cuda")
    ens.integrate(0.01)
    for k in range(3):
        t0 = time.perf_counter()
        ens.integrate(float(ens.t.max()) + 0.01)
        print(f"call_1step_ms_{k}={(time.perf_counter() - t0) * 1e3:.4g}")
    prof = cProfile.Profile()
    prof.enable()
    ens.integrate(float(ens.t.max()) + 0.01)
    prof.disable()
    for order, restriction in (("tottime", 18), ("cumulative", "visviva")):
        out = io.StringIO()
        stats = pstats.Stats(prof, stream=out).sort_stats(order)
        stats.print_stats(*((restriction, 15) if isinstance(restriction, str) else (restriction,)))
        for line in out.getvalue().splitlines():
            if line.strip() and line.strip()[0].isdigit():
                print(f"profile_{order}=" + " ".join(line.split()))
    copy_rates(3 * members)


if __name__ == "__main__":
    main()
