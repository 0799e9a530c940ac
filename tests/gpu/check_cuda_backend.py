"""Run the CUDA backend (a GPU, or numba's simulator when NUMBA_ENABLE_CUDASIM=1) beside the CPU
backend and print ``key=value`` lines with the largest relative differences."""

from __future__ import annotations

import importlib.resources
import os
import tempfile

import numpy as np
from astropy import units as u

import visviva as vv
from visviva.nbody.forces import J2Force


def system(backend, n=6, seed=0, softening=0.0, integrator="leapfrog"):
    rng = np.random.default_rng(seed)
    sim = vv.Simulation(integrator, dt=0.01, backend=backend, softening=softening)
    sim.add(1.0)
    for k in range(1, n):
        sim.add(1e-3 * rng.uniform(0.1, 1.0), a=1.0 + 0.4 * k, e=0.05 * rng.uniform(),
                inc=0.05 * rng.uniform(), mean_anomaly=rng.uniform(0, 6.28), primary=0)
    sim.add(0.0, a=0.7, e=0.1, primary=0)  # a test particle
    sim.move_to_com()
    return sim


#: numba's CUDA simulator runs each GPU thread in Python: the sizes that need many blocks and
#: tiles on a real GPU are cut there to sizes that still span several of the simulator's
#: 16-thread blocks and tiles (CI's time)
SIMULATOR = os.environ.get("NUMBA_ENABLE_CUDASIM") == "1"


def host(a):
    """A numpy array, copied from the device when ``a`` is a device array."""
    return a if isinstance(a, np.ndarray) else a.copy_to_host()


def rel(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def main():
    # numba.cuda is imported here, in the subprocess that set NUMBA_ENABLE_CUDASIM
    from numba import cuda

    from visviva.core import universal
    from visviva.core.cuda import arith, kernels
    from visviva.satellites.catalog import Catalog, parse_tle_text, propagate_kepler_batch

    cpu, gpu = system("cpu"), system("cuda")
    for t in (0.237, 0.5):  # off the grid, then on it: 23 + 27 steps and a shortened step
        cpu.integrate(t)
        gpu.integrate(t)
    print(f"sim_pos={rel(gpu.positions, cpu.positions)!r}")
    print(f"sim_vel={rel(gpu.velocities, cpu.velocities)!r}")
    print(f"steps_equal={(gpu.steps_done == cpu.steps_done)!r}")
    print(f"times_equal={(gpu.t == cpu.t)!r}")

    # arrays of output times: the CPU's Trajectory (off the grid, a time repeated, then
    # backwards in a second call), leapfrog and WHFast
    for key, integrator in (("lf", "leapfrog"), ("wh", "whfast")):
        runs = {b: system(b, n=4, seed=3, integrator=integrator) for b in ("cpu", "cuda")}
        pairs = [[sim.integrate(times) for sim in runs.values()]
                 for times in ([0.013, 0.05, 0.05, 0.0871, 0.12], [0.1, 0.031, -0.02])]
        pos = max(rel(g.positions, c.positions) for c, g in pairs)
        vel = max(rel(g.velocities, c.velocities) for c, g in pairs)
        same_t = all((g.t == c.t).all() for c, g in pairs)
        cpu_sim, gpu_sim = runs.values()
        print(f"traj_{key}_pos={pos!r}")
        print(f"traj_{key}_vel={vel!r}")
        print(f"traj_{key}_times_equal={same_t and gpu_sim.t == cpu_sim.t == -0.02!r}")
        print(f"traj_{key}_steps_equal={gpu_sim.steps_done == cpu_sim.steps_done!r}")

    # restart: the GPU state saved and continued on the CPU

    path = os.path.join(tempfile.mkdtemp(), "g.npz")
    gpu.save(path)
    back = vv.Simulation.load(path)  # a CPU simulation with the GPU run's internal state
    back.integrate(0.8)
    cpu.integrate(0.8)
    print(f"restart_pos={rel(back.positions, cpu.positions)!r}")

    # ensembles: ragged members, one GPU thread each
    members = [system("cpu", n=3 + k % 3, seed=k, softening=0.01 * (k % 2)) for k in range(5)]
    ens_cpu = vv.Ensemble.from_simulations(members)
    ens_gpu = vv.Ensemble.from_simulations(members, backend="cuda")
    for t in (0.113, 0.3):
        ens_cpu.integrate(t)
        ens_gpu.integrate(t)
    print(f"ens_pos={rel(np.nan_to_num(ens_gpu.positions), np.nan_to_num(ens_cpu.positions))!r}")
    print(f"ens_vel={rel(np.nan_to_num(ens_gpu.velocities), np.nan_to_num(ens_cpu.velocities))!r}")
    alone = members[2].copy()
    alone.backend = "cuda"
    alone.integrate(0.113)
    alone.integrate(0.3)
    print(f"ens_bits_vs_sim={bool((ens_gpu[2].positions == alone.positions).all())!r}")
    # the packed call (nbody/ensemble_pack.py) against the member-by-member GPU path
    from visviva.nbody.ensemble import _advance_each

    each = [m.copy() for m in members]
    for t in (0.113, 0.3):
        _advance_each(each, t, "cuda")
    print(f"ens_packed={ens_gpu._pack is not None!r}")
    same = all((e.positions == ens_gpu[k].positions).all()
               and (e.velocities == ens_gpu[k].velocities).all()
               and e.steps_done == ens_gpu[k].steps_done for k, e in enumerate(each))
    print(f"ens_pack_bits_vs_each={same!r}")

    # the device arithmetic's CPU twin against the device kernel, one evaluation


    rng = np.random.default_rng(5)
    x = rng.normal(size=(50, 3))
    gm = rng.uniform(0.1, 1.0, 50)
    massive = np.arange(50, dtype=np.int64)
    acc_d = cuda.device_array((50, 3))
    d_x = cuda.to_device(x)
    kernels.accelerations[kernels.blocks(50), kernels.THREADS](
        d_x, d_x, cuda.to_device(gm), cuda.to_device(massive), 0.0, acc_d)
    twin = np.zeros((50, 3))
    arith.member_accelerations_cpu(x, gm, massive, 0, 50, 0, 50, 0.0, twin)
    print(f"twin_acc={rel(acc_d.copy_to_host(), twin)!r}")

    # the tiled kernel over several blocks and tiles (300 particles, 200 massive: 3 blocks and
    # 2 tiles of 128 on a GPU; 96 and 64 under the simulator: 6 blocks and 4 tiles of 16),
    # softened: the pulls are added in the twin's order, so equal bits
    n = 96 if SIMULATOR else 300
    x = rng.normal(size=(n, 3))
    gm = rng.uniform(0.1, 1.0, n)
    gm[::3] = 0.0
    massive = np.flatnonzero(gm).astype(np.int64)
    acc_d = cuda.device_array((n, 3))
    d_x = cuda.to_device(x)
    kernels.accelerations[kernels.blocks(n), kernels.THREADS](
        d_x, d_x, cuda.to_device(gm), cuda.to_device(massive), 1e-4, acc_d)
    twin = np.zeros((n, 3))
    arith.member_accelerations_cpu(x, gm, massive, 0, len(massive), 0, n, 1e-4, twin)
    print(f"tiled_acc={rel(acc_d.copy_to_host(), twin)!r}")
    print(f"tiled_bits={bool((acc_d.copy_to_host() == twin).all())!r}")
    # the same tiles with each pull from a reciprocal square root: round-off, not the bits
    kernels.accelerations_rsqrt[kernels.blocks(n), kernels.THREADS](
        d_x, d_x, cuda.to_device(gm), cuda.to_device(massive), 1e-4, acc_d)
    print(f"rsqrt_acc={rel(acc_d.copy_to_host(), twin)!r}")
    # unsoftened: each massive particle's own pull (r = 0) is 0, not NaN
    kernels.accelerations_rsqrt[kernels.blocks(n), kernels.THREADS](
        d_x, d_x, cuda.to_device(gm), cuda.to_device(massive), 0.0, acc_d)
    twin = np.zeros((n, 3))
    arith.member_accelerations_cpu(x, gm, massive, 0, len(massive), 0, n, 0.0, twin)
    print(f"rsqrt_acc_unsoftened={rel(acc_d.copy_to_host(), twin)!r}")

    # WHFast with the interaction step's gravity on the GPU: a star and 139 planetesimals (more
    # massive bodies than one tile; 40 under the simulator, whose tiles are 16), off the grid
    # then on it, then continued on the CPU
    def disc(backend, n=40 if SIMULATOR else 139, **settings):
        rng = np.random.default_rng(11)
        sim = vv.Simulation("whfast", dt=0.02, backend=backend, **settings)
        sim.add(1.0)
        for k in range(n):
            sim.add(1e-7 * rng.uniform(0.5, 1.5), a=1.0 + 0.01 * k, e=0.05 * rng.uniform(),
                    inc=0.02 * rng.uniform(), mean_anomaly=rng.uniform(0, 6.28), primary=None)
        sim.move_to_com()
        return sim

    wc, wg = disc("cpu"), disc("cuda")
    for t in (0.05, 0.1):
        wc.integrate(t)
        wg.integrate(t)
    print(f"whfast_pos={rel(wg.positions, wc.positions)!r}")
    print(f"whfast_vel={rel(wg.velocities, wc.velocities)!r}")
    print(f"whfast_steps_equal={(wg.steps_done == wc.steps_done and wg.t == wc.t)!r}")
    gpu_path = os.path.join(tempfile.mkdtemp(), "w.npz")
    wg.save(gpu_path)
    back = vv.Simulation.load(gpu_path)  # the GPU run's internal state, continued on the CPU
    back.integrate(0.14)
    wc.integrate(0.14)
    print(f"whfast_restart_pos={rel(back.positions, wc.positions)!r}")

    # democratic heliocentric coordinates, and Jacobi with a 5th-order corrector: 3 planets and
    # 20 planetesimals, off the grid then on it, then continued on the CPU from the saved state
    # (and democratic heliocentric with J2 of the star: the additional force's slot)
    for key, settings in (("dh", {"coordinates": "democratic_heliocentric"}),
                          ("corrector", {"corrector": 5}),
                          ("dh_j2", {"coordinates": "democratic_heliocentric"})):
        wc, wg = disc("cpu", n=20, **settings), disc("cuda", n=20, **settings)
        for sim in (wc, wg):
            for j in (1, 2, 3):
                sim.set_particle(j, m=1e-3 / j)
            sim.move_to_com()
            if key == "dh_j2":
                sim.add_force(J2Force(0, 0.05, 0.3))
            sim.integrate(0.07)
            sim.integrate(0.16)
        print(f"whfast_{key}_pos={rel(wg.positions, wc.positions)!r}")
        print(f"whfast_{key}_vel={rel(wg.velocities, wc.velocities)!r}")
        print(f"whfast_{key}_steps_equal={(wg.steps_done == wc.steps_done > 5)!r}")
        wg.save(gpu_path)
        back = vv.Simulation.load(gpu_path)
        back.integrate(0.3)
        wc.integrate(0.3)
        print(f"whfast_{key}_restart_pos={rel(back.positions, wc.positions)!r}")

    # the leapfrog with an additional force, and with mergers: its CPU kernel, the gravity on
    # the GPU (nbody/gpu_force.every_call)
    lc, lg = system("cpu"), system("cuda")
    for sim in (lc, lg):
        sim.add_force(J2Force(0, 0.05, 0.3))
        sim.integrate(0.237)
        sim.integrate(0.5)
    print(f"lf_force_pos={rel(lg.positions, lc.positions)!r}")
    print(f"lf_force_vel={rel(lg.velocities, lc.velocities)!r}")
    print(f"lf_force_steps_equal={(lg.steps_done == lc.steps_done == 50)!r}")
    runs = []
    for backend in ("cpu", "cuda"):
        sim = vv.Simulation("leapfrog", dt=0.01, backend=backend, collision="merge")
        sim.add(1.0, radius=0.1)
        sim.add(1e-3, r=[0.6, 0.0, 0.0], v=[-0.3, 0.2, 0.0], radius=0.05)  # falls in
        sim.add(1e-3, r=[-0.7, 0.0, 0.0], v=[0.4, -1.1, 0.0], radius=0.05)
        sim.integrate(0.8)  # the merger comes before t = 0.5
        runs.append(sim)
    print(f"lf_merge_n={runs[0].N!r},{runs[1].N!r}")
    print(f"lf_merge_pos={rel(runs[1].positions, runs[0].positions)!r}")

    # batch two-body propagation: the universal-variable solver's device twin against the CPU



    text = (importlib.resources.files("sgp4") / "SGP4-VER.TLE").read_text()
    lines = [ln[:69] if ln.startswith("2 ") else ln for ln in text.splitlines()]
    cat = parse_tle_text("\n".join(ln for ln in lines if ln[:2] in ("1 ", "2 ")),
                         verify_checksum=False)
    cat = Catalog([cat[i] for i in range(6)])  # as tests/test_catalog.py
    when = cat.epochs[0] + np.linspace(-3, 3, 7) * u.day
    kc = propagate_kepler_batch(cat, when, on_error="nan")
    kg = propagate_kepler_batch(cat, when, on_error="nan", backend="cuda")
    print(f"kepler_status_equal={bool((kc.status == kg.status).all())!r}")
    print(f"kepler_pos={rel(np.nan_to_num(kg.r.value), np.nan_to_num(kc.r.value))!r}")
    print(f"kepler_vel={rel(np.nan_to_num(kg.v.value), np.nan_to_num(kc.v.value))!r}")

    # random conics (elliptic and hyperbolic, forwards and backwards): the kernels directly

    rng = np.random.default_rng(7)
    n = 200
    r0 = rng.normal(size=(n, 3)) * 9000.0
    v0 = rng.normal(size=(n, 3)) * 5.0
    gm = np.full(n, 398600.4418)
    dt = rng.uniform(-2e4, 2e4, n)
    out_c = (np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n, np.int64))
    out_g = (np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n, np.int64))
    universal.propagate_many(r0, v0, gm, dt, *out_c)
    kernels.propagate_many(r0, v0, gm, dt, *out_g)
    energy = 0.5 * np.sum(v0 * v0, -1) - gm / np.linalg.norm(r0, axis=-1)
    print(f"conics_hyperbolic={int((energy > 0).sum())!r}")
    print(f"conics_status_equal={bool((out_c[2] == out_g[2]).all())!r}")
    print(f"conics_pos={rel(out_g[0], out_c[0])!r}")
    # device arrays in and out (used in place, no copies), all of them or some: the same bits
    on_dev = (cuda.device_array((n, 3)), cuda.device_array((n, 3)), cuda.device_array(n, np.int64))
    kernels.propagate_many(*(cuda.to_device(a) for a in (r0, v0, gm, dt)), *on_dev)
    cuda.synchronize()
    mixed = (cuda.device_array((n, 3)), np.zeros((n, 3)), cuda.device_array(n, np.int64))
    kernels.propagate_many(cuda.to_device(r0), v0, cuda.to_device(gm), dt, *mixed)
    same = all((host(a) == b).all() for outs in (on_dev, mixed)
               for a, b in zip(outs, out_g, strict=True))
    print(f"conics_device_bits={same!r}")
    print(f"conics_device_pos={rel(on_dev[0].copy_to_host(), out_c[0])!r}")


if __name__ == "__main__":
    main()
