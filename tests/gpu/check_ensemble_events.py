"""Leapfrog and IAS15 ensembles whose members meet events (an escape, mergers, an encounter, a
halting collision) or have additional forces (J2Force, a user's numba.njit force, both) on the
CUDA backend (a GPU, or numba's simulator when NUMBA_ENABLE_CUDASIM=1) beside the same ensembles
on the CPU; prints ``key=value`` lines (largest relative differences, flags), keys prefixed
``lf_``, ``ias15_`` (events), ``lf_force_`` and ``ias15_force_`` (forces)."""

from __future__ import annotations

import math
import os
import tempfile

import numba
import numpy as np
from check_whfast_ensemble import rel, rel_same_time  # (this folder)

import visviva as vv
from visviva.nbody import GeneralRelativity, J2Force


@numba.njit
def swirl(t, x, v, m, params, acc):
    """A user's force, position- and time-dependent: ``a += p0 sin(p1 t) (y, -x, 0)`` on every
    particle but the first."""
    s = params[0] * math.sin(params[1] * t)
    for i in range(1, x.shape[0]):
        acc[i, 0] += s * x[i, 1]
        acc[i, 1] -= s * x[i, 0]

#: what each member meets (index: kind), and the times the ensembles are integrated to
EVENTS = {1: "escape", 2: "merge", 3: "encounter", 5: "halt"}
TIMES = (0.13, 0.7, 1.0)


def member(integrator, k):
    """A star and planets; member 1 launches a test particle out past its exit distance, members
    2 and 5 send two planets into each other (merged; halted), member 3 brings two planets within
    its encounter distance, members 0, 4 and 6 run on (4 softened with collision checks on that
    never fire, 6 with its own time step)."""
    kind = EVENTS.get(k, "none")
    settings = {"dt": 0.01 + 0.002 * (k == 6)} if integrator == "leapfrog" else {}
    sim = vv.Simulation(
        integrator, softening=0.01 * (k == 4),
        collision={"merge": "merge", "halt": "halt"}.get(kind, "merge" if k == 4 else "none"),
        encounter_distance=0.1 if kind == "encounter" else None,
        exit_max_distance=1.6 if kind == "escape" else None, **settings)
    sim.add(1.0, radius=0.01)
    rng = np.random.default_rng(k)
    for j in range(1, 3):
        sim.add(1e-4 * rng.uniform(0.5, 1.5), a=0.2 + 0.2 * j, e=0.05 * rng.uniform(),
                mean_anomaly=rng.uniform(0, 6.28), primary=0, radius=1e-4)
    if kind == "escape":
        sim.add(0.0, r=[1.0, 0.0, 0.0], v=[0.6, 1.6, 0.0])
    if kind in ("merge", "halt", "encounter"):
        r = 0.05 if kind != "encounter" else 0.0
        # the faster planet catches up with the slower one; merged, they orbit on
        sim.add(1e-3, r=[1.0, 0.0, 0.0], v=[0.0, 1.4, 0.0], radius=r)
        sim.add(2e-3, r=[1.0, 0.3 + 0.05 * (k == 5), 0.0], v=[-0.05, 0.6, 0.0], radius=r)
    sim.move_to_com()
    return sim


def outcome(ens, t):
    """Integrate ``ens`` to ``t``; the exception it raised (type, message, members) or None."""
    try:
        ens.integrate(t)
    except vv.VisvivaError as exc:
        return type(exc).__name__, str(exc), exc.member, tuple(exc.members)
    return None


def kind(raised):
    """An :func:`outcome` without the message: the type and the members."""
    return raised and raised[:1] + raised[2:]


def on_the(ens, backend):
    """``ens`` saved and loaded on ``backend``."""
    path = os.path.join(tempfile.mkdtemp(), "e.npz")
    ens.save(path)
    return vv.Ensemble.load(path, backend=backend)


def compare(gpu, cpu, key):
    """Print how two ensembles differ: positions, velocities, times, steps, particle counts."""
    print(f"{key}_pos={rel(gpu.positions, cpu.positions)!r}")
    print(f"{key}_vel={rel(gpu.velocities, cpu.velocities)!r}")
    print(f"{key}_t={rel(gpu.t, cpu.t)!r}")
    pos, vel = rel_same_time(gpu, cpu)
    print(f"{key}_pos_same_t={pos!r}")
    print(f"{key}_vel_same_t={vel!r}")
    print(f"{key}_steps_equal={[s.steps_done for s in gpu] == [s.steps_done for s in cpu]!r}")
    print(f"{key}_n_equal={np.array_equal(gpu.n_particles, cpu.n_particles)!r}")


def check(integrator, prefix):
    members = [member(integrator, k) for k in range(7)]
    cpu = vv.Ensemble.from_simulations(members)
    gpu = vv.Ensemble.from_simulations(members, backend="cuda")
    raised = []
    for t in TIMES:
        raised.append((outcome(cpu, t), outcome(gpu, t)))
    print(f"{prefix}_raised_equal={all(c == g for c, g in raised)!r}")
    # the exception's type and members (its message names the event's time, which on a GPU may
    # differ from the CPU's in the last digit where IAS15's step sizes do)
    print(f"{prefix}_raised_kind_equal="
          f"{all(kind(c) == kind(g) for c, g in raised)!r}")
    first = raised[-1][1]
    print(f"{prefix}_raised={first[0] if first else None}")
    print(f"{prefix}_stopped={','.join(map(str, first[3])) if first else ''}")
    print(f"{prefix}_n={','.join(map(str, gpu.n_particles))}")
    print(f"{prefix}_n0={','.join(str(s.N) for s in members)}")
    print(f"{prefix}_on_time={','.join(str(k) for k in range(7) if gpu.t[k] == TIMES[-1])}")
    print(f"{prefix}_steps={min(s.steps_done for s in gpu)!r}")
    compare(gpu, cpu, prefix)

    back = on_the(gpu, "cpu")  # saved after the events on the GPU, continued on the CPU
    ahead = on_the(cpu, "cuda")  # and the CPU's saved, continued on the GPU
    g, c = outcome(back, 1.4), outcome(cpu, 1.4)
    print(f"{prefix}_restart_raised_equal={g == c!r}")
    print(f"{prefix}_restart_raised_kind_equal={kind(g) == kind(c)!r}")
    compare(back, cpu, f"{prefix}_restart")
    print(f"{prefix}_to_gpu_raised_kind_equal={kind(outcome(ahead, 1.4)) == kind(c)!r}")
    compare(ahead, cpu, f"{prefix}_to_gpu")


def forced(integrator, k, user_force):
    """Members with forces: 0 none, 1 and 6 J2 of the star (their own J2; IAS15's 6 with the
    velocity-dependent 1PN force too), 2 and 5 the user's force (their own parameters), 3 both,
    4 J2 and a merger (forces and events together)."""
    sim = member(integrator, 2 if k == 4 else 0)
    if k in (1, 3, 4, 6):
        sim.add_force(J2Force(0, 1e-3 * (1 + k), 0.05))
    if k in (2, 3, 5):
        sim.add_force(user_force, params=[0.01 * (1 + k), 3.0 + k])
    if k == 6 and integrator == "ias15":  # velocity-dependent: IAS15's predictor on velocities
        sim.add_force(GeneralRelativity(0, c=30.0))
    return sim


def check_forces(integrator, prefix):
    import check_ensemble_events as me  # the user's force from an importable module (save)

    members = [forced(integrator, k, me.swirl) for k in range(7)]
    cpu = vv.Ensemble.from_simulations(members)
    gpu = vv.Ensemble.from_simulations(members, backend="cuda")
    for t in TIMES[:2]:
        cpu.integrate(t)
        gpu.integrate(t)
    print(f"{prefix}_steps={min(s.steps_done for s in gpu)!r}")
    print(f"{prefix}_n={','.join(map(str, gpu.n_particles))}")
    compare(gpu, cpu, prefix)
    back = on_the(gpu, "cpu")
    back.integrate(TIMES[2])
    cpu.integrate(TIMES[2])
    compare(back, cpu, f"{prefix}_restart")


def main():
    check("leapfrog", "lf")
    check("ias15", "ias15")
    check_forces("leapfrog", "lf_force")
    check_forces("ias15", "ias15_force")


if __name__ == "__main__":
    main()
