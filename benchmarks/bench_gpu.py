"""Ensembles (numba threads, Dask workers) and the GPU backend, each beside the CPU baseline.

Rows
----
* Ensemble of M three-body WHFast systems (Sun, Jupiter, Saturn-like), 1,000 steps each: one
  ``Ensemble.integrate`` (numba threads over the members) against a loop of
  ``Simulation.integrate`` over the same systems, one thread (target <= 1.0x; ideal 1 / threads).
  The results are identical (checked here too).
* The same ensemble on a Dask LocalCluster of 2 process workers (1 thread each) against 1 worker
  (target <= 0.625x, i.e. a speed-up >= 1.6x; the notes give the speed-up).
* Direct summation on the GPU backend (leapfrog, N = 10^3 ... 10^6; ns per interaction; the
  tiled kernel) against the CPU backend on every core (target <= 0.02x, i.e. >= 50x); WHFast
  with its interaction step on the GPU (N = 10^4, 10^5); IAS15 with its gravity evaluations on
  the GPU (N = 10^4, 3 10^4; the same steps as the CPU run); ensembles of leapfrog systems on the GPU
  (system-steps per second) against the CPU ensemble. Without an NVIDIA GPU these rows are
  reported as skipped with the CPU figures in the notes. The GPU model is printed and given in
  the notes of every GPU row. One command on a GPU machine: ``python -m benchmarks --only gpu``.
* Kepler solves per second (``propagate_kepler_batch``'s solver) on the GPU twin against the CPU
  kernel on every core: from and to host arrays (the host-device copies included), and the
  kernel alone on arrays already on the device (``cuda.synchronize()`` inside the timed call).
"""

from __future__ import annotations

import contextlib
import os

import numpy as np

from benchmarks.common import (
    compile_time,
    interleaved_medians,
    n_threads,
    result,
    skipped,
    threads,
    time_call,
)

NAME = "gpu"


def _system(a, integrator="whfast", dt=0.05):
    import visviva as vv

    sim = vv.Simulation(integrator, dt=dt)
    sim.add(1.0)
    sim.add(9.5e-4, a=a, e=0.048, primary=0)
    sim.add(2.9e-4, a=a * 1.84, e=0.054, inc=0.04, primary=None)
    sim.move_to_com()
    return sim


def _from_arrays(integrator, x, v, m, backend, **settings):
    """A simulation of N particles built in one go (``sim.add`` per particle copies the arrays
    each time: O(N**2) at N = 10^6), through the friend constructor ``from_state``."""
    import visviva as vv
    from visviva.nbody.state import SimulationState

    template = vv.Simulation(integrator, **settings).state_arrays()
    state = SimulationState(np.ascontiguousarray(x), np.ascontiguousarray(v), m.copy(),
                            np.zeros(len(m)), template["fstate"].copy(),
                            template["istate"].copy())
    sim = vv.Simulation.from_state(state, integrator)
    sim.backend = backend
    return sim


def _cluster(n, backend, seed=1):
    """A Plummer-softened cluster of ``n`` equal masses (leapfrog, dt = 1e-3)."""
    rng = np.random.default_rng(seed)
    return _from_arrays("leapfrog", rng.normal(size=(n, 3)), 0.1 * rng.normal(size=(n, 3)),
                        np.full(n, 1.0 / n), backend, dt=1e-3, softening=0.01)


def _disc(n, backend, seed=2, integrator="whfast"):
    """A star and ``n - 1`` planetesimals on near-circular orbits at 1-3 (dt = 0.01: WHFast's
    step, IAS15's first guess)."""
    rng = np.random.default_rng(seed)
    a = rng.uniform(1.0, 3.0, n)
    phi = rng.uniform(0.0, 2 * np.pi, n)
    z = 0.01 * rng.normal(size=n)
    x = np.stack([a * np.cos(phi), a * np.sin(phi), z], -1)
    vc = 1.0 / np.sqrt(a)
    v = np.stack([-vc * np.sin(phi), vc * np.cos(phi), np.zeros(n)], -1)
    x[0] = v[0] = 0.0
    m = np.full(n, 1e-9)
    m[0] = 1.0
    return _from_arrays(integrator, x, v, m, backend, dt=0.01, softening=1e-3)


def _gpu_problem():
    from visviva.core import cuda

    return cuda.missing() if not cuda.simulator() else "numba's CUDA simulator is on"


def gpu_model() -> str:
    """The GPU's name and compute capability (for the notes of every GPU row)."""
    from numba import cuda

    dev = cuda.get_current_device()
    name = dev.name.decode() if isinstance(dev.name, bytes) else str(dev.name)
    return f"{name} (cc {dev.compute_capability[0]}.{dev.compute_capability[1]})"


class _Rows(list):
    """The rows, each printed as it is made (and appended as a JSON line to the file named by
    ``VISVIVA_BENCH_ROWS``): a run cut short on a lent GPU machine keeps what it measured."""

    def append(self, row):
        import json
        import os
        import sys

        super().append(row)
        print(f"row: {json.dumps(row)}", file=sys.stderr, flush=True)
        path = os.environ.get("VISVIVA_BENCH_ROWS")
        if path:
            from visviva._text import replace_text_file

            # the file rewritten whole with the new line (a few rows): a run cut off while
            # writing leaves the earlier rows intact, never a half line
            try:
                with open(path, encoding="utf-8") as fh:
                    before = fh.read()
            except FileNotFoundError:
                before = ""
            if before and not before.endswith("\n"):
                before += "\n"
            replace_text_file(path, before + json.dumps(row) + "\n")


#: the sections, in the order :func:`run` takes them (``sections=`` picks some)
SECTIONS = ("cpu-ensemble", "direct", "kepler", "gpu-ensemble", "whfast", "ias15")


def run(quick: bool = False, sections=SECTIONS) -> list[dict]:
    """Every section's rows (``sections``: a subset of :data:`SECTIONS`, run in that order)."""
    rows = _Rows()
    for name in sections:
        globals()["_" + name.replace("-", "_")](rows, quick)
    return rows


def _cpu_ensemble(rows, quick):
    import visviva as vv

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

        import dask

        from benchmarks.bench_dask import _cpu_split, _load
        from benchmarks.bench_sgp4 import _cpu_seconds

        with threads(1):
            single_cpu = _cpu_seconds(ensemble)
        timings = {}
        # the workers' statistical profiler off, as in visviva's own LocalCluster (client=True)
        with dask.config.set({"distributed.worker.profile.enabled": False}):
            for workers in (1, 2):
                with LocalCluster(n_workers=workers, processes=True, threads_per_worker=1,
                                  dashboard_address=":0") as cluster, Client(cluster) as client:
                    on(client)  # workers import visviva and load the compiled kernels
                    timings[workers] = time_call(on, client, repeat=5, number=1)
                    if workers == 2:
                        per_worker, here = _cpu_split(client, lambda c=client: on(c))
        speedup = timings[1].median / timings[2].median
        critical = max(per_worker) + here
        rows.append(result(
            f"ensemble {M} x 3-body whfast on Dask, 2 process workers", timings[2],
            "the same on 1 worker", timings[1], target=1 / 1.6,
            notes=(f"speed-up {speedup:.2f}x (wall) on {n_threads()} core(s), load {_load()}; "
                   f"CPU s: in-process ensemble on 1 thread {single_cpu:.3g}, on 2 workers the "
                   f"busiest worker {max(per_worker):.3g} + this process {here:.3g} -> on idle "
                   f"cores at least {single_cpu / critical:.2f}x the in-process ensemble "
                   "(client and worker CPU added: conservative); results identical to the "
                   "in-process ensemble (tests/test_nbody_ensemble.py)"),
        ))


def _gpu():
    """(what prevents GPU runs or "", the GPU model or "")."""
    problem = _gpu_problem()
    return problem, "" if problem else gpu_model()


def _direct(rows, quick):
    problem, model = _gpu()
    sizes = (1000, 10_000) if quick or problem else (1000, 10_000, 100_000, 1_000_000)
    for n in sizes:
        cpu = _cluster(n, "cpu")
        nsteps = 2 if n <= 10_000 else 1
        repeat = 3 if n <= 100_000 else 1  # 10^12 interactions per CPU step at N = 10^6

        def step(sim=cpu, k=nsteps):
            sim.integrate(sim.t + k * 1e-3)

        with threads(None):
            if n <= 100_000:
                step()  # compiled at the smallest N; a warm-up run at N = 10^6 costs minutes
            t_cpu = time_call(step, repeat=repeat, number=1, warmup=1 if n <= 100_000 else 0)
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
        t_gpu = time_call(gstep, repeat=3, number=1, warmup=0)  # compile_time warmed it
        ns_gpu = t_gpu.median * 1e9 / (float(n) * n * nsteps)
        rows.append(result(name, t_gpu, "CPU backend, every core", t_cpu, target=0.02,
                           compile_s=c,
                           notes=f"{ns_gpu:.3g} ns/interaction (CPU {ns_cpu:.3g}); fp64, tiled "
                                 f"kernel; {model}"))
        if n >= 100_000:
            rows.append(_direct_kernels(n, model))


def _direct_kernels(n, model):
    """The direct-sum kernel alone, positions on the device: the reciprocal-square-root variant
    (``kernels.accelerations_rsqrt``) against the exact pulls (``kernels.accelerations``, what
    simulations use), interleaved in one process."""
    from numba import cuda

    from visviva.core.cuda import kernels as K

    rng = np.random.default_rng(3)
    d_x = cuda.to_device(rng.normal(size=(n, 3)))
    d_gm = cuda.to_device(rng.uniform(0.5, 1.5, n) / n)
    d_massive = cuda.to_device(np.arange(n, dtype=np.int64))
    d_acc = cuda.device_array((n, 3))

    def launcher(kernel):
        def call():
            kernel[K.blocks(n), K.THREADS](d_x, d_x, d_gm, d_massive, 1e-6, d_acc)
            cuda.synchronize()
        return call

    exact, fast = launcher(K.accelerations), launcher(K.accelerations_rsqrt)
    exact()
    fast()
    t_exact, t_fast = interleaved_medians(exact, fast, rounds=5)
    per = 1e9 / (float(n) * n)
    return result(f"direct-sum kernel with rsqrt pulls, N={n}", t_fast,
                  "the same kernel with exact pulls (sqrt and division)", t_exact,
                  notes=f"{t_fast * per:.3g} against {t_exact * per:.3g} ns/interaction, "
                        f"kernel only (positions on the device); fp64; {model}")


def _whfast(rows, quick):
    """WHFast with the interaction step's gravity on the GPU (Kepler drifts on the CPU)."""
    problem, model = _gpu()
    for n in (10_000,) if quick or problem else (10_000, 100_000):
        cpu = _disc(n, "cpu")
        nsteps = 4 if n <= 10_000 else 2

        def wstep(sim=cpu, k=nsteps):
            sim.integrate(sim.t + k * 0.01)

        with threads(None):
            wstep()
            t_cpu = time_call(wstep, repeat=3, number=1)
        name = f"WHFast on the GPU (interaction step), star + {n - 1} planetesimals"
        if problem:
            rows.append(skipped(name, f"no GPU ({problem}); CPU backend: "
                                      f"{t_cpu.median / nsteps * 1e3:.3g} ms per step"))
            continue
        gpu = _disc(n, "cuda")

        def gwstep(sim=gpu, k=nsteps):
            sim.integrate(sim.t + k * 0.01)

        c = compile_time(gwstep)
        t_gpu = time_call(gwstep, repeat=3, number=1)
        rows.append(result(name, t_gpu, "CPU backend, every core", t_cpu, target=0.1,
                           compile_s=c,
                           notes=f"{t_gpu.median / nsteps * 1e3:.3g} ms per step (CPU "
                                 f"{t_cpu.median / nsteps * 1e3:.3g}); fp64; {model}"))


def _ias15(rows, quick):
    """IAS15 with every gravity evaluation of its predictor-corrector on the GPU: the GPU and
    the CPU runs take the same steps (the same kernel decides them), so the ratio of the times
    over one time span is the ratio per step."""
    problem, model = _gpu()
    for n in (2_000,) if quick or problem else (10_000, 30_000):
        cpu = _disc(n, "cpu", integrator="ias15")
        span = 0.2 if n <= 10_000 else 0.1  # about 3 and 1-2 steps

        def istep(sim=cpu, dt=span):
            sim.integrate(sim.t + dt)

        with threads(None):
            istep()
            s0 = cpu.steps_done
            t_cpu = time_call(istep, repeat=3 if n <= 10_000 else 1, number=1)
        per_step = (cpu.steps_done - s0) / (3 if n <= 10_000 else 1)
        name = f"IAS15 on the GPU (gravity evaluations), star + {n - 1} planetesimals"
        if problem:
            rows.append(skipped(name, f"no GPU ({problem}); CPU backend: {t_cpu.median:.3g} s "
                                      f"per {span} time units (~{per_step:.3g} steps)"))
            continue
        gpu = _disc(n, "cuda", integrator="ias15")

        def gistep(sim=gpu, dt=span):
            sim.integrate(sim.t + dt)

        c = compile_time(gistep)
        t_gpu = time_call(gistep, repeat=3 if n <= 10_000 else 1, number=1)
        rows.append(result(name, t_gpu, "CPU backend, every core", t_cpu, target=0.1,
                           compile_s=c,
                           notes=f"{t_gpu.median:.3g} s per {span} time units (~{per_step:.3g} "
                                 f"steps; CPU {t_cpu.median:.3g} s); the same steps as the "
                                 f"CPU run; fp64; {model}"))


def _gpu_ensemble(rows, quick):
    """Ensembles of three-body systems (leapfrog, WHFast, then IAS15), one GPU thread per
    member, against the CPU ensemble: each timed call advances the same ensemble by ``steps``
    steps of 0.01 (IAS15: by the same time span, in its own adaptive steps, counted; the
    per-call cost, checks and copies, is timed apart with 1-step calls and given in the notes).
    Building the ensemble from Simulation objects is Python work of the same size on both: left
    out."""
    for integrator in ("leapfrog", "whfast", "ias15"):
        _one_gpu_ensemble(rows, quick, integrator)


def _one_gpu_ensemble(rows, quick, integrator):
    import visviva as vv

    problem, model = _gpu()
    members = 4096 if quick else 131_072
    steps = 100 if quick else 1000
    lf = [_system(1.0 + k / members, integrator, dt=0.01) for k in range(min(members, 4096))]
    lf = (lf * (members // len(lf) + 1))[:members]

    def timed(ens, k):
        return time_call(lambda: ens.integrate(float(ens.t.max()) + k * 0.01), repeat=3,
                         number=1)

    def taken(ens):  # steps per member and call (IAS15 chooses its own)
        n0 = sum(s.steps_done for s in ens._members)
        t = timed(ens, steps)
        return t, (sum(s.steps_done for s in ens._members) - n0) / (3 * members)

    ens = vv.Ensemble.from_simulations(lf)
    with threads(None):
        ens.integrate(0.01)
        t_cpu, per_call = taken(ens)
        call_cpu = timed(ens, 1).median
    rate_cpu = members * per_call / t_cpu.median
    span = (f"{steps} steps" if integrator != "ias15"
            else f"{steps * 0.01:g} time units (~{per_call:.3g} adaptive steps)")
    name = f"ensemble of {members} 3-body {integrator} systems on the GPU, {span}"
    resident = name.replace("on the GPU,", "on the GPU, resident kernel,")
    if problem:
        rows.append(skipped(name, f"no GPU ({problem}); CPU ensemble: {rate_cpu:.3g} "
                                  f"system-steps/s on every core; a 1-step call "
                                  f"{call_cpu * 1e3:.3g} ms"))
        if integrator != "ias15":
            rows.append(skipped(resident, f"no GPU ({problem})"))
        return
    gens = vv.Ensemble.from_simulations(lf, backend="cuda")
    with _resident("0"):  # the global-memory kernels, whatever the environment says
        c = compile_time(gens.integrate, 0.01)
        t_gpu, _ = taken(gens)
        call_gpu = timed(gens, 1).median
    rows.append(result(name, t_gpu, "CPU ensemble, every core", t_cpu, target=0.02,
                       compile_s=c,
                       notes=f"{members * per_call / t_gpu.median:.3g} system-steps/s (CPU "
                             f"{rate_cpu:.3g}); a 1-step call {call_gpu * 1e3:.3g} ms (CPU "
                             f"{call_cpu * 1e3:.3g}); fp64; {model}"))
    if integrator != "ias15":
        _resident_row(rows, resident, lf, (ens, gens), (t_cpu, rate_cpu, call_cpu),
                      (members, steps), per_call, model)


@contextlib.contextmanager
def _resident(value):
    """The resident GPU ensemble kernels switched on ("1") or off ("0") inside the block
    (``VISVIVA_GPU_RESIDENT``), as before it afterwards."""
    from visviva.core.cuda.resident import RESIDENT

    before = os.environ.get(RESIDENT)
    os.environ[RESIDENT] = value
    try:
        yield
    finally:
        if before is None:
            del os.environ[RESIDENT]
        else:
            os.environ[RESIDENT] = before


def _resident_row(rows, name, lf, ensembles, cpu, size, per_call, model):
    """The same ensemble with the resident kernel (visviva.core.cuda.resident: each member's
    state in its thread's local arrays for a call; the default, switched on here explicitly for
    this row), timed as the row before; then the three ensembles (CPU, global-memory
    kernel, resident kernel) carried on to one later time and compared (relative, positions)."""
    import visviva as vv

    (ens, gens), (t_cpu, rate_cpu, call_cpu), (members, steps) = ensembles, cpu, size
    with _resident("1"):
        rens = vv.Ensemble.from_simulations(lf, backend="cuda")
        c = compile_time(rens.integrate, 0.01)
        t_res = time_call(lambda: rens.integrate(float(rens.t.max()) + steps * 0.01),
                          repeat=3, number=1)
        call_res = time_call(lambda: rens.integrate(float(rens.t.max()) + 0.01), repeat=3,
                             number=1).median
        t_long = time_call(lambda: rens.integrate(float(rens.t.max()) + LONG * steps * 0.01),
                           repeat=3, number=1)
        end = max(float(e.t.max()) for e in (ens, gens, rens)) + 0.05
        rens.integrate(end)
    with _resident("0"):
        gens.integrate(end)  # the global-memory kernel
    with threads(None):
        ens.integrate(end)

    def rel(a, b):
        return float(np.max(np.abs(a.positions - b.positions)) / np.max(np.abs(b.positions)))

    rows.append(result(name, t_res, "CPU ensemble, every core", t_cpu, target=0.02,
                       compile_s=c,
                       notes=f"{members * per_call / t_res.median:.3g} system-steps/s (CPU "
                             f"{rate_cpu:.3g}); a 1-step call {call_res * 1e3:.3g} ms; at "
                             f"t={end:.4g} relative to the CPU ensemble {rel(rens, ens):.2g}, "
                             f"to the global-memory kernel {rel(rens, gens):.2g} (the global "
                             f"kernel to the CPU {rel(gens, ens):.2g}); VISVIVA_GPU_RESIDENT=1; "
                             f"fp64; {model}"))
    # a long call (a stability map's run): the per-call cost (checks, packing, host-device
    # copies) spread over LONG times the steps; the CPU reference is its measured call
    # extrapolated from its per-step cost (the 1000-step call less a 1-step call) plus one
    # call's cost: its own per-call cost is not multiplied (conservative for the GPU)
    cpu_long = (float(t_cpu) - call_cpu) * LONG + call_cpu
    rows.append(result(name.replace(f"{steps} steps", f"{LONG * steps} steps per call"),
                       t_long, "CPU ensemble, every core (per-step cost measured at "
                       f"{steps} steps, times {LONG}, plus one call's cost)", cpu_long,
                       target=0.02,
                       notes=f"{members * per_call * LONG / t_long.median:.3g} system-steps/s "
                             f"(CPU {members * per_call * LONG / cpu_long:.3g}); "
                             f"VISVIVA_GPU_RESIDENT=1; fp64; {model}"))


#: the long resident call's steps, in units of the timed call's
LONG = 10


def _kepler(rows, quick):
    """Kepler solves: the universal-variable solver, CPU kernel and its GPU twin."""
    problem, model = _gpu()
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
                           f"{n / t_cpu.median:.3g}) including host-device copies; fp64; "
                           f"{model}"))
        rows.append(_kepler_on_device(kernels, (r0, v0, gm, dt), out, t_cpu, model))


def _kepler_on_device(kernels, inputs, out, t_cpu, model):
    """The Kepler kernel alone: inputs and outputs already on the device (no host-device copy;
    ``propagate_many`` uses device arrays in place), synchronised inside the timed call."""
    from numba import cuda

    n = inputs[0].shape[0]
    d_in = [cuda.to_device(a) for a in inputs]
    d_out = [cuda.device_array(a.shape, dtype=a.dtype) for a in out]

    def call():
        kernels.propagate_many(*d_in, *d_out)
        cuda.synchronize()

    t_gpu = time_call(call, repeat=5, number=1)
    moved = sum(a.nbytes for a in (*inputs, *out)) / 1e9
    return result(f"Kepler kernel on the GPU, {n:.0e} pairs already on the device", t_gpu,
                  "CPU backend, every core", t_cpu, target=0.02,
                  notes=f"{n / t_gpu.median:.3g} solves/s (CPU {n / t_cpu.median:.3g}); kernel "
                        f"only: the {moved:.2g} GB of inputs and outputs stay on the device; "
                        f"fp64; {model}")
