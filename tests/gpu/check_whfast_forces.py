"""WHFast ensembles whose members have additional forces (J2Force with two J2 values, a user's
numba.njit force fused with J2, GeneralRelativityPotential with a corrector, democratic
heliocentric coordinates with J2 and with J2 and the user's force, one member without forces)
on the CUDA backend (a GPU, or numba's simulator when NUMBA_ENABLE_CUDASIM=1) beside the same ensemble
on the CPU and each member run alone; prints ``key=value`` lines (read by
``tests/test_nbody_gpu_whfast.py``)."""

from __future__ import annotations

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from check_ensemble_events import compare, on_the, rel, swirl  # noqa: E402
from check_whfast_general import member  # noqa: E402

import visviva as vv  # noqa: E402
from visviva.nbody import GeneralRelativity, GeneralRelativityPotential, J2Force  # noqa: E402

TIMES = (0.123, 0.198, 0.15)  # off the grid, on it, backwards (the internal state built again)


def forced(k):
    """Member ``k``: 0 and 1 J2 of the star (two J2 values: one kernel call), 2 the user's force
    fused with J2, 3 democratic heliocentric with J2, 4 no force, 5 the GR potential with the
    5th-order corrector, 6 democratic heliocentric with the user's force fused with J2 (its own
    parameters). Three sets of force functions: three general kernels, each compiled for about
    a minute on a real GPU (NVVM), so no more than that."""
    sim = member(k, coordinates="democratic_heliocentric" if k in (3, 6) else "jacobi",
                 corrector=5 if k == 5 else 0)
    if k in (0, 1, 2, 3, 6):
        sim.add_force(J2Force(0, 1e-3 * (1 + 2 * (k == 1)), 0.3))
    if k in (2, 6):
        sim.add_force(swirl, params=[0.5 * (1 + k), 3.0 + k])
    if k == 5:
        sim.add_force(GeneralRelativityPotential(c=5.0))
    return sim


def main():
    members = [forced(k) for k in range(7)]
    alone = [s.copy() for s in members]
    bare = [member(k, coordinates=s.coordinates, corrector=s.corrector)
            for k, s in enumerate(members)]
    cpu = vv.Ensemble.from_simulations(members)
    gpu = vv.Ensemble.from_simulations(members, backend="cuda")
    for t in TIMES:
        cpu.integrate(t)
        gpu.integrate(t)
        for sim in alone + bare:
            sim.integrate(t)
    compare(gpu, cpu, "force")
    from visviva.nbody.gpu_forces import _KERNELS  # one WHFast kernel per set of force functions

    print(f"force_kernels={sum(key[0] == 'whfast' for key in _KERNELS)!r}")
    print(f"force_t_equal={np.array_equal(gpu.t, cpu.t)!r}")
    print(f"force_steps={min(s.steps_done for s in gpu)!r}")
    # each member against its lone CPU run
    print(f"alone_pos={max(rel(g.positions, s.positions) for g, s in zip(gpu, alone, strict=True))!r}")
    print(f"alone_vel={max(rel(g.velocities, s.velocities) for g, s in zip(gpu, alone, strict=True))!r}")
    print(f"alone_t_diff={max(abs(g.t - s.t) for g, s in zip(gpu, alone, strict=True))!r}")
    print(f"alone_steps_equal={[g.steps_done for g in gpu] == [s.steps_done for s in alone]!r}")
    # the forces move the members (the smallest effect, relative), member 4 has none
    effect = [rel(g.positions, b.positions) for g, b in zip(gpu, bare, strict=True)]
    print(f"effect_min={min(effect[:4] + effect[5:])!r}")
    print(f"effect_none={effect[4]!r}")
    # saved on the GPU, continued on the CPU (and the other way)
    back = on_the(gpu, "cpu")
    back.integrate(0.25)
    cpu.integrate(0.25)
    compare(back, cpu, "restart")
    ahead = on_the(cpu, "cuda")
    ahead.integrate(0.3)
    cpu.integrate(0.3)
    compare(ahead, cpu, "to_gpu")
    # a velocity-dependent force: WHFast refuses it as on the CPU
    try:
        members[0].add_force(GeneralRelativity(0, c=30.0))
        print("velocity_refused=none")
    except vv.VisvivaError as exc:
        print(f"velocity_refused={type(exc).__name__}: {exc}")


if __name__ == "__main__":
    main()
