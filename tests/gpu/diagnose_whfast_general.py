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
Each ``-`` option below tests one suspect (on 2026-11-27 every democratic heliocentric piece
alone, in a one-thread kernel, agreed with the CPU to 7e-19 on the H200:
``diagnose_dh_pieces.py``): ``--alone`` runs each member as its own one-member ensemble (one
thread; against interference between the threads of a launch), ``--stack BYTES`` raises the
CUDA stack limit of every thread first (against an overflowing call stack: the Kepler solver is
a real call), ``--opt0`` compiles the kernel without NVVM's optimisations (against a
miscompilation), ``--cases a,b`` runs only those cases.
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


def option(name, default=None):
    """The value after ``name`` on the command line (``default`` without it)."""
    return sys.argv[sys.argv.index(name) + 1] if name in sys.argv else default


def raise_stack_limit(size):
    """Set the CUDA stack limit of every thread to ``size`` bytes (the driver's own call, on
    numba's context) and print it before and after."""
    from cuda.bindings import driver
    from numba import cuda

    cuda.current_context()  # numba's context, made current on this thread
    limit = driver.CUlimit.CU_LIMIT_STACK_SIZE
    print(f"stack_before={driver.cuCtxGetLimit(limit)}")
    print(f"stack_set={driver.cuCtxSetLimit(limit, size)}")
    print(f"stack_after={driver.cuCtxGetLimit(limit)}")


def without_optimisation():
    """Make every later ``cuda.jit`` kernel compile with ``opt=False``."""
    from numba import cuda

    jit = cuda.jit

    def unoptimised(*args, **kwargs):
        if not kwargs.get("device"):
            kwargs.setdefault("opt", False)
        return jit(*args, **kwargs)

    cuda.jit = unoptimised


def main():
    if "--inline" in sys.argv:
        from visviva.core.cuda import twins

        twins.never_inlined = lambda twin: twin  # build_general imports it when it builds
    if "--stack" in sys.argv:
        raise_stack_limit(int(option("--stack")))
    if "--opt0" in sys.argv:
        without_optimisation()
    cases = option("--cases", ",".join(CASES)).split(",")
    for case in cases:
        members = [build(k, CASES[case]) for k in (0, 1, 2)]
        cpu = vv.Ensemble.from_simulations(members)
        if "--alone" in sys.argv:  # one thread per launch
            gpu = [vv.Ensemble.from_simulations([s], backend="cuda") for s in members]
        else:
            gpu = [vv.Ensemble.from_simulations(members, backend="cuda")]
        for steps in (1, 10):
            t = steps * 0.0125  # past the members' own dt (0.01 + 0.002 k): 1 and ~10 steps
            try:
                cpu.integrate(t)
                for ens in gpu:
                    ens.integrate(t)
            except Exception as exc:  # print and go on to the next case
                print(f"{case}_error={type(exc).__name__}: {str(exc)[:120]}")
                break
            done = [s for ens in gpu for s in ens]
            for k in range(3):
                print(f"{case}_{k}_{steps}={rel(done[k].positions, cpu[k].positions)!r}",
                      flush=True)
            print(f"{case}_steps_{steps}={[s.steps_done for s in done]}/"
                  f"{[s.steps_done for s in cpu]}", flush=True)


if __name__ == "__main__":
    main()
