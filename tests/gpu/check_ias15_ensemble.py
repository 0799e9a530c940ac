"""Run an IAS15 ensemble on the CUDA backend (a GPU, or numba's simulator when
NUMBA_ENABLE_CUDASIM=1) beside the same ensemble on the CPU and print ``key=value`` lines."""

from __future__ import annotations

import numpy as np
from check_whfast_ensemble import (  # (this folder)
    continue_on,
    each_vs_packed,
    rel,
    rel_same_time,
    same,
)

import visviva as vv


def member(k):
    """Ragged members (3 to 6 particles, a test particle in some); one uses the rs15 step
    control, one is softened, one outputs the state after the first step past the time, one
    has a moon close to its planet (IAS15's two-part positions for a tight pair)."""
    rng = np.random.default_rng(k)
    sim = vv.Simulation("ias15", softening=0.01 * (k == 3), exact_finish_time=k != 4,
                        adaptive_mode="rs15" if k == 1 else "prs23")
    sim.add(1.0)
    for j in range(1, 3 + k % 3):
        sim.add(1e-3 * rng.uniform(0.1, 1.0), a=1.0 + 0.5 * j, e=0.1 * rng.uniform(),
                inc=0.05 * rng.uniform(), mean_anomaly=rng.uniform(0, 6.28), primary=0)
    if k == 2:
        sim.add(1e-6, a=0.02, e=0.05, primary=1)  # a moon: a tight pair far from the origin
    if k % 2:
        sim.add(0.0, a=0.6, e=0.2, primary=0)
    sim.move_to_com()
    return sim


def main():
    members = [member(k) for k in range(5)]
    cpu = vv.Ensemble.from_simulations(members)
    gpu = vv.Ensemble.from_simulations(members, backend="cuda")
    # at the start time (nothing moves), between steps, a second call continues, backwards
    for t in (0.0, 0.15, 0.4, 0.3):
        cpu.integrate(t)
        gpu.integrate(t)
    print(f"ens_pos={rel(gpu.positions, cpu.positions)!r}")
    print(f"ens_vel={rel(gpu.velocities, cpu.velocities)!r}")
    print(f"ens_bits={same(gpu, cpu)!r}")
    print(f"ens_t={rel(gpu.t, cpu.t)!r}")
    pos, vel = rel_same_time(gpu, cpu)
    print(f"ens_pos_same_t={pos!r}")
    print(f"ens_vel_same_t={vel!r}")
    print(f"ens_steps_equal={[s.steps_done for s in gpu] == [s.steps_done for s in cpu]!r}")
    print(f"ens_steps={min(s.steps_done for s in gpu)!r}")
    print(f"ens_packed={gpu._pack is not None!r}")

    continue_on(gpu, cpu, "cpu", 0.5, "restart")  # saved on the GPU, continued on the CPU
    continue_on(cpu, cpu, "cuda", 0.6, "to_gpu")  # saved on the CPU, continued on the GPU
    each_vs_packed(members, (0.113, 0.2))

    # a member whose step falls below its floor stops with the CPU's exception
    bad = [member(0), member(1)]
    bad[1].min_dt = 10.0
    errs = []
    for backend in ("cpu", "cuda"):
        ens = vv.Ensemble.from_simulations(bad, backend=backend)
        try:
            ens.integrate(0.2)
            errs.append("none")
        except Exception as exc:  # the ensemble raises the member's error
            errs.append(f"{type(exc).__name__}: {exc}")
    print(f"min_dt_same_error={errs[0] == errs[1] and errs[0] != 'none'!r}")
    # the type and the text before the numbers (the step size's last digits may differ)
    print(f"min_dt_same_kind={errs[0].split(' at t')[0] == errs[1].split(' at t')[0]!r}")
    print(f"min_dt_errors={errs!r}")
    print(f"min_dt_error={errs[1][:80]!r}")
    alone()


def crowd():
    """A star and 256 light bodies: PAIR_MIN_N massive particles and one more."""
    sim = vv.Simulation("ias15")
    sim.add(1.0)
    for j in range(256):
        sim.add(1e-9, r=[1.0 + 0.05 * j, 0.0, 0.01 * j], v=[0.0, (1.0 + 0.05 * j) ** -0.5, 0.0])
    return sim


def alone():
    """Members with ALONE_MIN_MASSIVE massive particles or more run as lone GPU simulations
    beside the packed ones: on a GPU a real crowd (257 massive particles); under the simulator,
    which sums 257**2 pairs in Python far too slowly, the limit is lowered so that member 2
    (five massive particles and a moon) takes that path."""
    from visviva.core.cuda import simulator
    from visviva.nbody import gpu, gpu_ensemble_ias15

    if simulator():
        gpu_ensemble_ias15.ALONE_MIN_MASSIVE = 5
        members = [member(k) for k in range(4)]
        big = 2
    else:
        members = [member(0), member(1), crowd(), member(3)]
        big = 2
    assert [gpu_ensemble_ias15.runs_alone(s) for s in members] == [k == big for k in range(4)]
    ens = vv.Ensemble.from_simulations(members, backend="cuda")
    cpu = vv.Ensemble.from_simulations(members)
    lone_gpu = members[big].copy()
    lone_gpu.backend = "cuda"
    lone_cpu = members[big].copy()
    alone_runs = []
    run_alone = gpu.integrate_simulation

    def counted(sim, t, progress=False):  # the ensemble's lone runs (lone_gpu's are not)
        alone_runs.append(sim.N)
        return run_alone(sim, t, progress)

    gpu.integrate_simulation = counted
    for t in (0.1, 0.25, 0.2):  # the fast path's pack sends the call to the per-member path
        ens.integrate(t)
        gpu.integrate_simulation = run_alone
        cpu.integrate(t)
        lone_gpu.integrate(t)
        gpu.integrate_simulation = counted
        lone_cpu.integrate(t)
    gpu.integrate_simulation = run_alone
    small = [k for k in range(4) if k != big]
    print(f"alone_runs={len(alone_runs)!r},{set(alone_runs) == {members[big].N}!r}")
    print(f"alone_flags={[gpu_ensemble_ias15.runs_alone(s) for s in ens]!r}")
    print(f"alone_bits_vs_lone_gpu={same_state(ens[big], lone_gpu)!r}")
    print(f"alone_pos={rel(ens[big].positions, lone_cpu.positions)!r}")
    print(f"alone_vel={rel(ens[big].velocities, lone_cpu.velocities)!r}")
    print(f"alone_t={ens[big].t!r},{lone_cpu.t!r}")
    print(f"alone_steps={ens[big].steps_done!r},{lone_cpu.steps_done!r}")
    print(f"alone_others_pos={max(rel(ens[k].positions, cpu[k].positions) for k in small)!r}")
    print(f"alone_others_bits={all(same_state(ens[k], cpu[k]) for k in small)!r}")


def same_state(a, b):
    return bool(np.array_equal(a.positions, b.positions)
                and np.array_equal(a.velocities, b.velocities) and a.t == b.t)


if __name__ == "__main__":
    main()
