"""Find where the general WHFast ensemble kernel goes wrong on a real GPU (not a test: a
diagnosis to run on the next lent GPU, ``python tests/gpu/diagnose_whfast_general.py [--inline]``).

On an NVIDIA H200 (2026-11-26) :func:`visviva.core.cuda.whfast.build_general`'s kernel gave
wrong numbers (0.5-1.3 relative in positions) for democratic heliocentric members, members with
additional forces and event checks, and right ones (1e-16) for Jacobi members with correctors;
under numba's CUDA simulator it equals the CPU ensemble bit for bit. This script runs one
setting at a time, as ensembles of three members, after one step and after ten, and prints
``case_member_steps=relative position difference`` lines, so one call separates the settings
(DH alone, the events path alone, J2 alone, a force that adds nothing) and shows whether the
error is there from the first step (a logic or lowering error) or grows (arithmetic).
``--inline`` builds the kernel with the Kepler solver inlined at every call site as before
:func:`visviva.core.cuda.twins.never_inlined` (its first launch then compiles for minutes),
to tell whether keeping it out of line matters.
"""

from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.dirname(__file__))
import numba  # noqa: E402
from check_whfast_ensemble import member, rel  # noqa: E402

import visviva as vv  # noqa: E402
from visviva.nbody import J2Force  # noqa: E402


@numba.njit
def nothing(t, x, v, m, params, acc):
    """An additional force that adds 0 (through the force path)."""
    for i in range(x.shape[0]):
        acc[i, 0] += 0.0 * params[0]


CASES = {
    "events_never_fire": {"exit_max_distance": 1e6},  # the general kernel's Jacobi event path
    "corrector5": {"corrector": 5},  # right on the H200: the control
    "dh": {"coordinates": "democratic_heliocentric"},
    "dh_events_never_fire": {"coordinates": "democratic_heliocentric", "exit_max_distance": 1e6},
    "j2": {"force": "j2"},
    "zero_force": {"force": "nothing"},
}


def build(k, settings):
    sim = member(k)
    for name, value in settings.items():
        if name == "force":
            if value == "j2":
                sim.add_force(J2Force(0, 1e-3, 0.3))
            else:
                sim.add_force(nothing, params=[1.0])
        else:
            setattr(sim, name, value)
    return sim


def main():
    os.environ["VISVIVA_GPU_WHFAST_GENERAL"] = "1"
    if "--inline" in sys.argv:
        from visviva.core.cuda import twins

        twins.never_inlined = lambda twin: twin  # build_general imports it when it builds
    for case, settings in CASES.items():
        members = [build(k, settings) for k in (0, 1, 2)]
        cpu = vv.Ensemble.from_simulations(members)
        gpu = vv.Ensemble.from_simulations(members, backend="cuda")
        for steps in (1, 10):
            t = steps * 0.0125  # past the members' own dt (0.01 + 0.002 k): 1 and ~10 steps
            try:
                cpu.integrate(t)
                gpu.integrate(t)
            except Exception as exc:  # print and go on to the next case
                print(f"{case}_error={type(exc).__name__}: {str(exc)[:120]}")
                break
            for k in range(3):
                print(f"{case}_{k}_{steps}={rel(gpu[k].positions, cpu[k].positions)!r}")
            print(f"{case}_steps_{steps}={[s.steps_done for s in gpu]}/"
                  f"{[s.steps_done for s in cpu]}")


if __name__ == "__main__":
    main()
