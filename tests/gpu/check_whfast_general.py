"""WHFast ensembles in every setting the GPU runs beyond the plain case (democratic
heliocentric coordinates, symplectic correctors, collision/encounter/escape checks) on the
CUDA backend (a GPU, or numba's simulator when NUMBA_ENABLE_CUDASIM=1) beside the same
ensembles on the CPU; prints ``key=value`` lines (read by ``tests/test_nbody_gpu_whfast.py``).
Small on purpose: the simulator runs every device function as Python."""

from __future__ import annotations

import os
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from check_whfast_ensemble import each_vs_packed, rel  # noqa: E402
from check_whfast_ensemble import member as plain_member  # noqa: E402

import visviva as vv  # noqa: E402


def member(k, **settings):
    """Member ``k`` of the plain ensemble check (ragged, own time steps, a test particle in odd
    ones, member 3 softened, member 4 landing on grid points only) with ``settings``."""
    sim = plain_member(k)
    for name, value in settings.items():
        setattr(sim, name, value)
    return sim


def crash():
    """Two bodies that meet head on (a merger, then a lone body)."""
    sim = vv.Simulation("whfast", dt=0.01, collision="merge")
    sim.add(1.0, radius=0.1)
    sim.add(1e-3, r=[1.0, 0, 0], v=[-2.0, 0.0, 0], radius=0.1)
    return sim


def both(members, times, key):
    """The members as a CPU and a GPU ensemble through ``times``: print how they differ; the
    exceptions (type, member, members) each raised; returns the two ensembles."""
    cpu = vv.Ensemble.from_simulations(members)
    gpu = vv.Ensemble.from_simulations(members, backend="cuda")
    raised = {"cpu": [], "gpu": []}
    for t in times:
        for name, ens in (("cpu", cpu), ("gpu", gpu)):
            try:
                ens.integrate(t)
            except Exception as exc:
                raised[name].append((type(exc).__name__, exc.member, exc.members))
    print(f"{key}_pos={rel(gpu.positions, cpu.positions)!r}")
    print(f"{key}_vel={rel(gpu.velocities, cpu.velocities)!r}")
    print(f"{key}_t_equal={np.array_equal(gpu.t, cpu.t)!r}")
    print(f"{key}_t_diff={float(np.max(np.abs(gpu.t - cpu.t)))!r}")
    print(f"{key}_n_equal={np.array_equal(gpu.n_particles, cpu.n_particles)!r}")
    print(f"{key}_steps_equal={[s.steps_done for s in gpu] == [s.steps_done for s in cpu]!r}")
    print(f"{key}_raised_equal={raised['gpu'] == raised['cpu']!r}")
    print(f"{key}_raised={raised['gpu']!r}")
    return cpu, gpu


def continue_on(ens, ref, backend, t, key):
    """Save ``ens``, load it on ``backend`` and continue it, and ``ref``, to ``t``; print how
    they differ and the exceptions each raised."""
    path = os.path.join(tempfile.mkdtemp(), "e.npz")
    ens.save(path)
    back = vv.Ensemble.load(path, backend=backend)
    raised = []
    for e in (back, ref):
        try:
            e.integrate(t)
            raised.append(None)
        except Exception as exc:
            raised.append((type(exc).__name__, exc.member, exc.members))
    print(f"{key}_pos={rel(back.positions, ref.positions)!r}")
    print(f"{key}_vel={rel(back.velocities, ref.velocities)!r}")
    print(f"{key}_steps_equal={[s.steps_done for s in back] == [s.steps_done for s in ref]!r}")
    print(f"{key}_raised_equal={raised[0] == raised[1]!r}")


def main():
    # forwards off the grid, on it, backwards (the internal state is built again)
    times = (0.123, 0.198, 0.15)
    dh = [member(k, coordinates="democratic_heliocentric") for k in range(5)]
    cpu, gpu = both(dh, times, "dh")
    continue_on(gpu, cpu, "cpu", 0.25, "dh_restart")  # saved on the GPU, continued on the CPU
    continue_on(cpu, gpu, "cuda", 0.3, "dh_to_gpu")  # and the other way
    print(f"dh_packed={gpu._pack is not None!r}")  # the fast path of Ensemble.integrate
    each_vs_packed(dh, (0.113, 0.2))  # the member-by-member GPU path: the same bits
    for order in (3, 7):
        both([member(k, corrector=order) for k in range(5)], times, f"corr{order}")
    # events: an escape (member 1), a merger (member 3), the others run on; democratic
    # heliocentric members with events too
    events = [member(k, coordinates="democratic_heliocentric" if k % 2 else "jacobi",
                     collision="merge" if k == 4 else "none") for k in range(5)]
    events[1].exit_max_distance = 2.1  # its outer planet (a = 2.5, e ~ 0.1) leaves at once
    events.insert(3, crash())
    # the 5th-order corrector with checks on (the CPU's event path takes none) and an
    # encounter (member 7: its planets at a = 1.5 and 2.0 come within 0.8)
    events.append(member(0, corrector=5, exit_max_distance=50.0, encounter_distance=0.01))
    events.append(member(2, encounter_distance=0.8))
    cpu, gpu = both(events, (0.123, 0.35), "events")
    # each member run alone on the CPU: its exception (by type) and its state
    alone, diff, times = [], 0.0, []
    for k, sim in enumerate(events):
        for t in (0.123, 0.35):
            try:
                sim.integrate(t)
            except Exception as exc:
                alone.append((k, type(exc).__name__))
        diff = max(diff, rel(gpu[k].positions, sim.positions))
        times.append(abs(sim.t - gpu.t[k]))
    print(f"events_alone_pos={diff!r}")
    print(f"events_alone_t_diff={float(max(times))!r}")
    print(f"events_alone_raised={sorted(set(alone))!r}")
    print(f"events_n={','.join(map(str, gpu.n_particles))}")
    print(f"events_t={','.join(repr(float(x)) for x in gpu.t)}")
    continue_on(gpu, cpu, "cpu", 0.4, "events_restart")


if __name__ == "__main__":
    main()
