"""IAS15 with ``backend="cuda"`` (a GPU, or numba's simulator when NUMBA_ENABLE_CUDASIM=1)
beside the CPU backend: prints ``key=value`` lines (largest relative differences, flags)."""

from __future__ import annotations

import os
import tempfile

import numpy as np

import visviva as vv
from visviva import errors
from visviva.nbody.forces import GeneralRelativity


def planets(backend, n=8, tp=3, seed=0):
    """A star, ``n - 1`` planets (more than the split's few-body path) and ``tp`` test
    particles."""
    rng = np.random.default_rng(seed)
    sim = vv.Simulation("ias15", dt=0.05, backend=backend)
    sim.add(1.0)
    for k in range(1, n):
        sim.add(1e-3 * rng.uniform(0.1, 1.0), a=1.0 + 0.4 * k, e=0.05 * rng.uniform(),
                inc=0.05 * rng.uniform(), mean_anomaly=rng.uniform(0, 6.28), primary=0)
    for k in range(tp):
        sim.add(0.0, a=0.6 + 0.15 * k, e=0.1, mean_anomaly=2.0 * k, primary=0)
    sim.move_to_com()
    return sim


def far_binary(backend):
    """A tight eccentric binary 100 length units from the origin, a third star and a test
    particle: the CPU kernel sums gravity on two-part positions in these steps."""
    sim = vv.Simulation("ias15", dt=1e-3, backend=backend)
    sim.add(1.0, r=[100.0, 0.0, 0.0], v=[0.0, 0.1, 0.0])
    sim.add(0.5, a=0.05, e=0.6, primary=0)
    sim.add(1.0, r=[-100.0, 0.0, 0.0], v=[0.0, -0.1, 0.0])
    sim.add(0.0, a=0.2, e=0.1, primary=0)
    return sim


def rel(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def main():
    from numba import cuda

    from visviva.core import gravity, gravity_split, nbody_ias15
    from visviva.core.cuda import kernels
    from visviva.nbody import gpu

    # several adaptive steps, off the grid (a shortened copy) then further
    cpu, dev = planets("cpu"), planets("cuda")
    for t in (0.13, 0.37):
        cpu.integrate(t)
        dev.integrate(t)
    print(f"ias15_pos={rel(dev.positions, cpu.positions)!r}")
    print(f"ias15_vel={rel(dev.velocities, cpu.velocities)!r}")
    print(f"ias15_steps={cpu.steps_done!r}")
    print(f"ias15_steps_equal={(dev.steps_done == cpu.steps_done)!r}")
    print(f"ias15_times_equal={(dev.t == cpu.t == 0.37)!r}")
    print(f"ias15_dt_rel={abs(dev.dt - cpu.dt) / abs(cpu.dt)!r}")
    print(f"ias15_energy_rel={abs(dev.energy() - cpu.energy()) / abs(cpu.energy())!r}")

    # the GPU run's state saved, loaded (a CPU simulation) and continued; a CPU run continued
    # on the GPU
    path = os.path.join(tempfile.mkdtemp(), "ias15.npz")
    dev.save(path)
    back = vv.Simulation.load(path)
    mid = cpu.copy()
    mid.backend = "cuda"
    back.integrate(0.5)
    mid.integrate(0.5)
    cpu.integrate(0.5)
    print(f"ias15_restart_pos={rel(back.positions, cpu.positions)!r}")
    print(f"ias15_continue_pos={rel(mid.positions, cpu.positions)!r}")
    print(f"ias15_restart_steps_equal={(back.steps_done == mid.steps_done == cpu.steps_done)!r}")

    # the two-part positions: a tight binary far from the origin; the split decisions recorded
    decisions = []
    tight = gpu.DeviceGravity.tight

    def recorded(self, x, ratio):
        decisions.append(tight(self, x, ratio))
        return decisions[-1]

    gpu.DeviceGravity.tight = recorded
    bc, bg = far_binary("cpu"), far_binary("cuda")
    bc.integrate(0.002)
    bg.integrate(0.002)
    sep_c = bc.positions[1] - bc.positions[0]
    sep_g = bg.positions[1] - bg.positions[0]
    print(f"split_steps={sum(decisions)!r}")
    print(f"split_pos={rel(bg.positions, bc.positions)!r}")
    print(f"split_vel={rel(bg.velocities, bc.velocities)!r}")
    print(f"split_separation={float(np.linalg.norm(sep_g - sep_c) / np.linalg.norm(sep_c))!r}")
    print(f"split_steps_equal={(bg.steps_done == bc.steps_done)!r}")
    gpu.DeviceGravity.tight = tight

    # the kernels on their own: the two-part sum against the CPU's, and the tight-pair test
    rng = np.random.default_rng(4)
    n = 40
    x = rng.normal(size=(n, 3)) + [50.0, 0.0, 0.0]
    x[1] = x[0] + 1e-3 * rng.normal(size=3)
    xlo = 1e-15 * rng.normal(size=(n, 3))
    m = rng.uniform(0.1, 1.0, n)
    m[::5] = 0.0
    massive = np.flatnonzero(m).astype(np.int64)
    acc = np.zeros((n, 3))
    work = np.zeros((gravity.GWORK_ROWS, n))
    gravity_split.gravity_split(x, xlo, m, 1.0, 0.0, massive, acc, work, False)
    d_acc = cuda.device_array((n, 3))
    kernels.accelerations_split[kernels.blocks(n), kernels.THREADS](
        cuda.to_device(x), cuda.to_device(xlo), cuda.to_device(m), cuda.to_device(massive),
        0.0, d_acc)
    print(f"split_kernel_acc={rel(d_acc.copy_to_host(), acc)!r}")
    flags = cuda.device_array(n, dtype=np.int32)
    same = True
    for scale in (1.0, 1e-3, 30.0):
        xs = x * [1.0, scale, scale]
        kernels.tight_pairs[kernels.blocks(n), kernels.THREADS](
            cuda.to_device(xs), cuda.to_device(massive[:5]), nbody_ias15.SPLIT_RATIO ** 2, flags)
        same &= bool(flags.copy_to_host().any()) == nbody_ias15._tight_pair(xs, massive[:5])
    print(f"tight_equal={same!r}")

    # an additional force (velocity-dependent: IAS15 predicts the velocities), added after the
    # GPU gravity as the CPU kernel adds it after its own
    fc, fg = planets("cpu", n=4, tp=1), planets("cuda", n=4, tp=1)
    for sim in (fc, fg):
        sim.add_force(GeneralRelativity(primary=0, c=30.0))
        sim.integrate(0.15)
    print(f"force_pos={rel(fg.positions, fc.positions)!r}")
    print(f"force_vel={rel(fg.velocities, fc.velocities)!r}")

    # events: two planets on crossing orbits merge (the GPU arrays are rebuilt for N - 1), or
    # raise Encounter at the same step
    def crossing(backend, **settings):
        sim = vv.Simulation("ias15", dt=0.02, backend=backend, **settings)
        sim.add(1.0, radius=0.01)
        sim.add(1e-3, r=[1.0, 0.0, 0.0], v=[0.0, 1.0, 0.0], radius=0.02)
        sim.add(1e-3, r=[np.cos(0.1), np.sin(0.1), 0.0], v=[np.sin(0.1), -np.cos(0.1), 0.0],
                radius=0.02)
        return sim

    mc, mg = crossing("cpu", collision="merge"), crossing("cuda", collision="merge")
    mc.integrate(0.06)
    mg.integrate(0.06)
    print(f"merge_n={mc.N!r},{mg.N!r}")
    print(f"merge_pos={rel(mg.positions, mc.positions)!r}")
    ec, eg = crossing("cpu", encounter_distance=0.1), crossing("cuda", encounter_distance=0.1)
    raised = []
    for sim in (ec, eg):
        try:
            sim.integrate(0.06)
        except errors.VisvivaError as exc:
            raised.append(type(exc).__name__)
    print(f"encounter={'/'.join(raised)}")
    # (the time of the step that met the encounter: t + dt, dt from the step control)
    print(f"encounter_t={abs(eg.t - ec.t) / ec.t!r}")
    print(f"encounter_before={(max(ec.t, eg.t) < 0.06)!r}")
    print(f"encounter_pos={rel(eg.positions, ec.positions)!r}")

    # an array of output times through the merger: the CPU's Trajectory (the merged planet's
    # column NaN after it), with a progress bar on the GPU run
    tc = crossing("cpu", collision="merge").integrate([0.01, 0.03, 0.03, 0.05, 0.08])
    tg = crossing("cuda", collision="merge").integrate([0.01, 0.03, 0.03, 0.05, 0.08],
                                                       progress=True)
    print(f"traj_merge_pos={rel(np.nan_to_num(tg.positions), np.nan_to_num(tc.positions))!r}")
    print(f"traj_merge_vel={rel(np.nan_to_num(tg.velocities), np.nan_to_num(tc.velocities))!r}")
    print(f"traj_merge_nan={int(np.isnan(tc.positions).any(-1).sum())!r},"
          f"{int(np.isnan(tg.positions).any(-1).sum())!r}")
    print(f"traj_merge_times_equal={bool((tg.t == tc.t).all())!r}")

    # an error inside the GPU call
    add = gpu.DeviceGravity.add

    def broken(self, *args):
        raise RuntimeError("device lost")

    gpu.DeviceGravity.add = broken
    s = planets("cuda", n=3, tp=0)
    x0 = s.positions
    try:
        s.integrate(0.1)
        print("broken=none")
    except RuntimeError as exc:
        print(f"broken={exc}")
    gpu.DeviceGravity.add = add
    print(f"broken_state_kept={bool((s.positions == x0).all() and s.t == 0.0)!r}")


if __name__ == "__main__":
    main()
