"""Ensembles (numba threads, Dask workers) and the GPU backend, each beside the CPU baseline.

Rows
----
* Ensemble of M three-body WHFast systems (Sun, Jupiter, Saturn-like), 1,000 steps each: one
  ``Ensemble.integrate`` (numba threads over the members) against a loop of
  ``Simulation.integrate`` over the same systems, one thread (target <= 1.0x; ideal 1 / threads).
  The results are identical (checked here too).
* The same ensemble on a Dask LocalCluster of 2 process workers (1 thread each) against 1 worker
  (target <= 0.625x, i.e. a speed-up >= 1.6x; the notes give the speed-up).
* Direct summation on the GPU backend (leapfrog, N = 10^3 ... 10^6; ns per interaction) against
  the CPU backend on every core (target <= 0.02x, i.e. >= 50x); ensembles of leapfrog systems on
  the GPU (system-steps per second) against the CPU ensemble. Without an NVIDIA GPU these rows
  are reported as skipped with the CPU figures in the notes.
* Kepler solves per second (``propagate_kepler_batch``'s solver) on the GPU twin against the CPU
  kernel on every core.
"""

from __future__ import annotations

import numpy as np

from benchmarks.common import compile_time, n_threads, result, skipped, threads, time_call

NAME = "gpu"


def _system(a, integrator="whfast", dt=0.05):
    import visviva as vv

    sim = vv.Simulation(integrator, dt=dt)
    sim.add(1.0)
    sim.add(9.5e-4, a=a, e=0.048, primary=0)
    sim.add(2.9e-4, a=a * 1.84, e=0.054, inc=0.04, primary=None)
    sim.move_to_com()
    return sim


def _cluster(n, backend, seed=1):
    import visviva as vv

    rng = np.random.default_rng(seed)
    sim = vv.Simulation("leapfrog", dt=1e-3, softening=0.01, backend=backend)
    for x, v in zip(rng.normal(size=(n, 3)), 0.1 * rng.normal(size=(n, 3)), strict=True):
        sim.add(1.0 / n, x, v)
    return sim


def _gpu_problem():
    from visviva.core import cuda

    return cuda.missing() if not cuda.simulator() else "numba's CUDA simulator is on"


def run(quick: bool = False) -> list[dict]:
    import visviva as vv

    rows = []
    M = 64 if quick else 512
    steps = 1000
    T = steps * 0.05
    sims = [_system(1.0 + 0.5 * k / M) for k in range(M)]

    def loop():
        out = [s.copy() for s in sims]
        for s in out:
            s.integrate(T)
        return out

    def ensemble():
        ens = vv.Ensemble.from_simulations(sims)
        ens.integrate(T)
        return ens

    c = compile_time(ensemble)
    with threads(None) as nth:
        t_ens = time_call(ensemble, repeat=3, number=1)
    with threads(1):
        t_loop = time_call(loop, repeat=3, number=1)
        t_ens1 = time_call(ensemble, repeat=3, number=1)
    same = np.array_equal(ensemble().positions, np.stack([s.positions for s in loop()]))
    rows.append(result(
        f"ensemble {M} x 3-body whfast, {steps} steps", t_ens, "loop of Simulation.integrate, "
        "1 thread", t_loop, target=1.0, compile_s=c,
        notes=(f"{nth} thread(s); ensemble on 1 thread {t_ens1.median:.3g} s; "
               f"{M * steps / t_ens.median:.3g} system-steps/s; members equal the lone runs "
               f"bit for bit: {same}"),
    ))

    # -- Dask: 2 process workers against 1 -------------------------------------------------------
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        rows.append(skipped("ensemble on Dask", "distributed not installed"))
    else:
        def on(client):
            ens = vv.Ensemble.from_simulations(sims)
            ens.integrate(T, client=client)
            return ens

        timings = {}
        for workers in (1, 2):
            with LocalCluster(n_workers=workers, processes=True, threads_per_worker=1,
                              dashboard_address=":0") as cluster, Client(cluster) as client:
                on(client)  # workers import visviva and load the compiled kernels
                timings[workers] = time_call(on, client, repeat=3, number=1)
        speedup = timings[1].median / timings[2].median
        rows.append(result(
            f"ensemble {M} x 3-body whfast on Dask, 2 process workers", timings[2],
            "the same on 1 worker", timings[1], target=1 / 1.6,
            notes=(f"speed-up {speedup:.2f}x on {n_threads()} core(s); results identical to "
                   "the in-process ensemble (tests/test_nbody_ensemble.py)"),
        ))

    # -- GPU ---------------------------------------------------------------------------------------
    problem = _gpu_problem()
    sizes = (1000, 10_000) if quick or problem else (1000, 10_000, 100_000, 1_000_000)
    for n in sizes:
        cpu = _cluster(n, "cpu")
        nsteps = 2 if n <= 10_000 else 1

        def step(sim=cpu, k=nsteps):
            sim.integrate(sim.t + k * 1e-3)

        with threads(None):
            step()
            t_cpu = time_call(step, repeat=3, number=1)
        ns_cpu = t_cpu.median * 1e9 / (float(n) * n * nsteps)
        name = f"direct summation on the GPU, leapfrog, N={n}"
        if problem:
            rows.append(skipped(name, f"no GPU ({problem}); CPU backend: {ns_cpu:.3g} "
                                      "ns/interaction on every core"))
            continue
        gpu = _cluster(n, "cuda")

        def gstep(sim=gpu, k=nsteps):
            sim.integrate(sim.t + k * 1e-3)

        c = compile_time(gstep)
        t_gpu = time_call(gstep, repeat=3, number=1)
        ns_gpu = t_gpu.median * 1e9 / (float(n) * n * nsteps)
        rows.append(result(name, t_gpu, "CPU backend, every core", t_cpu, target=0.02,
                           compile_s=c,
                           notes=f"{ns_gpu:.3g} ns/interaction (CPU {ns_cpu:.3g}); fp64"))

    members = 4096 if quick else 131_072
    lf = [_system(1.0 + k / members, "leapfrog", dt=0.01) for k in range(min(members, 4096))]
    lf = (lf * (members // len(lf) + 1))[:members]
    Tlf = 1.0  # 100 steps
    with threads(None):
        ens = vv.Ensemble.from_simulations(lf)
        ens.integrate(0.01)
        t_cpu = time_call(lambda: vv.Ensemble.from_simulations(lf).integrate(Tlf), repeat=3,
                          number=1)
    rate_cpu = members * 100 / t_cpu.median
    name = f"ensemble of {members} 3-body leapfrog systems on the GPU, 100 steps"
    if problem:
        rows.append(skipped(name, f"no GPU ({problem}); CPU ensemble: {rate_cpu:.3g} "
                                  "system-steps/s on every core"))
    else:
        t_gpu = time_call(lambda: vv.Ensemble.from_simulations(lf, backend="cuda").integrate(Tlf),
                          repeat=3, number=1)
        rows.append(result(name, t_gpu, "CPU ensemble, every core", t_cpu, target=0.02,
                           notes=f"{members * 100 / t_gpu.median:.3g} system-steps/s "
                                 f"(CPU {rate_cpu:.3g}); fp64"))

    # -- Kepler solves: the universal-variable solver, CPU kernel and its GPU twin -----------------
    from visviva.core import universal

    n = 100_000 if quick else 10_000_000
    rng = np.random.default_rng(2)
    r0 = rng.normal(size=(n, 3)) * 9000.0
    v0 = rng.normal(size=(n, 3)) * 5.0
    gm = np.full(n, 398600.4418)
    dt = rng.uniform(-2e4, 2e4, n)
    out = (np.empty((n, 3)), np.empty((n, 3)), np.empty(n, np.int64))
    with threads(None):
        universal.propagate_many(r0[:10], v0[:10], gm[:10], dt[:10], *(o[:10] for o in out))
        t_cpu = time_call(universal.propagate_many, r0, v0, gm, dt, *out, repeat=3, number=1)
    name = f"propagate_kepler_batch on the GPU, {n:.0e} state-time pairs"
    if problem:
        rows.append(skipped(name, f"no GPU ({problem}); CPU backend: {n / t_cpu.median:.3g} "
                                  "Kepler solves/s on every core"))
    else:
        from visviva.core.cuda import kernels

        c = compile_time(kernels.propagate_many, r0, v0, gm, dt, *out)
        t_gpu = time_call(kernels.propagate_many, r0, v0, gm, dt, *out, repeat=3, number=1)
        rows.append(result(name, t_gpu, "CPU backend, every core", t_cpu, target=0.02,
                           compile_s=c, notes=f"{n / t_gpu.median:.3g} solves/s (CPU "
                           f"{n / t_cpu.median:.3g}) including host-device copies; fp64"))
    return rows
