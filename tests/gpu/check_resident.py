"""The resident GPU ensemble kernels (visviva.core.cuda.resident: each member's state in its
thread's local arrays for a whole call) beside the CPU ensemble and the global-memory kernels,
on a GPU or under numba's simulator (NUMBA_ENABLE_CUDASIM=1); prints ``key=value`` lines.

The resident kernels are switched on for the GPU runs here with VISVIVA_GPU_RESIDENT=1 (the
default since this script passed on an H200, 2026-11-27) and off (=0) for the global-memory
reference.
"""

from __future__ import annotations

import os
import sys
import tempfile

import numpy as np

import visviva as vv
from visviva.core.cuda import resident as R

#: the members' particle counts: ragged, at the bucket boundaries (4, 8) and between them
SIZES = (3, 4, 5, 8, 6, 3, 4, 7)
#: the output times: the start, off the grid, on it (0.36 is a grid point of dt 0.01, 0.012),
#: backwards (WHFast builds its internal state again), forwards again
TIMES = (0.0, 0.237, 0.36, 0.3, 0.41)

LAUNCHED: list = []


def _record(builder, name):
    def wrapped(nmax, exact=False):
        LAUNCHED.append((name, nmax, exact))
        return builder(nmax, exact)

    return wrapped


R.leapfrog = _record(R.leapfrog, "leapfrog")
R.whfast = _record(R.whfast, "whfast")


def member(k, integrator, n=None, test_particle=True):
    """A star and ``n - 1`` planets (the last a test particle in odd members unless not
    ``test_particle``), its own step; member 2 softened, member 4 lands on its output times by
    grid points only."""
    n = SIZES[k % len(SIZES)] if n is None else n
    rng = np.random.default_rng(k)
    sim = vv.Simulation(integrator, dt=0.01 + 0.002 * (k % 3), softening=0.01 * (k == 2),
                        exact_finish_time=k != 4)
    sim.add(1.0)
    for j in range(1, n):
        mass = 0.0 if (test_particle and k % 2 and j == n - 1) else 1e-3 * rng.uniform(0.1, 1.0)
        sim.add(mass, a=1.0 + 0.3 * j, e=0.1 * rng.uniform(), inc=0.05 * rng.uniform(),
                mean_anomaly=rng.uniform(0, 6.28), primary=0)
    sim.move_to_com()
    return sim


def rel(a, b):
    a, b = np.nan_to_num(a), np.nan_to_num(b)
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def same(a, b):
    return (np.array_equal(a.t, b.t)
            and bool(np.array_equal(np.nan_to_num(a.positions), np.nan_to_num(b.positions)))
            and bool(np.array_equal(np.nan_to_num(a.velocities), np.nan_to_num(b.velocities)))
            and [s.steps_done for s in a] == [s.steps_done for s in b])


def on(value):
    os.environ[R.RESIDENT] = value


def compare(key, members, times):
    """CPU ensemble, resident GPU kernel, global-memory GPU kernel through ``times``."""
    cpu = vv.Ensemble.from_simulations(members)
    res = vv.Ensemble.from_simulations(members, backend="cuda")
    glo = vv.Ensemble.from_simulations(members, backend="cuda")
    del LAUNCHED[:]
    for t in times:
        cpu.integrate(t)
        on("1")
        res.integrate(t)
        on("0")
        glo.integrate(t)
    print(f"{key}_launched={sorted(set(LAUNCHED))!r}")
    print(f"{key}_packed={res._pack is not None and glo._pack is not None!r}")
    print(f"{key}_pos={rel(res.positions, cpu.positions)!r}")
    print(f"{key}_vel={rel(res.velocities, cpu.velocities)!r}")
    print(f"{key}_t_equal={np.array_equal(res.t, cpu.t)!r}")
    print(f"{key}_t_diff={float(np.max(np.abs(res.t - cpu.t)))!r}")
    print(f"{key}_steps_equal={[s.steps_done for s in res] == [s.steps_done for s in cpu]!r}")
    print(f"{key}_bits_vs_cpu={same(res, cpu)!r}")
    print(f"{key}_bits_vs_global={same(res, glo)!r}")
    print(f"{key}_global_pos={rel(glo.positions, cpu.positions)!r}")
    return cpu, res


def restart(key, ens, ref, t):
    """``ens`` saved and loaded on the CPU, ``ref`` (CPU) saved and loaded on the GPU with the
    resident kernels, each continued to ``t`` beside the other's original."""
    folder = tempfile.mkdtemp()
    ens.save(os.path.join(folder, "gpu.npz"))
    ref.save(os.path.join(folder, "cpu.npz"))
    to_cpu = vv.Ensemble.load(os.path.join(folder, "gpu.npz"), backend="cpu")
    to_gpu = vv.Ensemble.load(os.path.join(folder, "cpu.npz"), backend="cuda")
    on("1")
    for e in (to_cpu, to_gpu, ens, ref):
        e.integrate(t)
    print(f"{key}_to_cpu_pos={rel(to_cpu.positions, ref.positions)!r}")
    print(f"{key}_to_gpu_pos={rel(to_gpu.positions, ref.positions)!r}")
    print(f"{key}_continued_pos={rel(ens.positions, ref.positions)!r}")
    print(f"{key}_bits={same(to_cpu, ref) and same(to_gpu, ref) and same(ens, ref)!r}")


def main():
    # the benchmark's case first (members of 3 massive bodies: the kernel for exactly 3), then
    # the ragged pack with its restarts, then the other edges of the kernels' choice
    # (R.select): on a real GPU each kernel compiles at its first launch, and the lines printed
    # so far come back if the script runs out of time
    short = (0.0, 0.031, 0.05, 0.02)  # (the simulator runs device code as Python)
    if sys.argv[1:]:  # only the cases named (e.g. ``whfast_n32 whfast_n33``)
        for key in sys.argv[1:]:
            integrator, size = key.split("_")
            n, tp, where = {"exact3": (3, False, None), "n4": (4, True, None),
                            "exact8": (8, False, None), "n9": (9, False, None),
                            "n32": (32, True, 1), "n33": (33, True, 1)}[size]
            compare(key, [member(k, integrator, n if where in (None, k) else None, tp)
                          for k in range(3)], short)
        return
    for integrator in ("leapfrog", "whfast"):
        compare(f"{integrator}_exact3", [member(k, integrator, 3, False) for k in range(3)],
                short)
    for integrator in ("leapfrog", "whfast"):
        # 20 members: two blocks of threads under the simulator (16 threads per block there)
        members = [member(k, integrator) for k in range(20)]
        cpu, res = compare(integrator, members, TIMES)
        restart(f"{integrator}_restart", res, cpu, 0.55)
    for integrator in ("leapfrog", "whfast"):
        # three calls off and on the grid, and backwards, for packs of 4 bodies with test
        # particles (the bucket of 4); of 8 and of 9 bodies, all massive (exactly 8 =
        # EXACT_MAX; the bucket of 16); a member of 32 bodies (the largest bucket) and one of
        # 33 (larger than every bucket: the global-memory kernel runs its pack)
        for key, n, tp, where in (("n4", 4, True, None), ("exact8", 8, False, None),
                                  ("n9", 9, False, None), ("n32", 32, True, 1),
                                  ("n33", 33, True, 1)):
            compare(f"{integrator}_{key}",
                    [member(k, integrator, n if where in (None, k) else None, tp)
                     for k in range(3)], short)


if __name__ == "__main__":
    main()
