"""The interpreter tier of the N-body integrators (:mod:`visviva.core.tier`), in slices of steps.

With an empty numba cache, the first WHFast or IAS15 run of a process would compile its kernel
for 11-14 s of CPU, while a three-body run to ``t = 10`` takes 0.1-0.4 s with the kernel's own
Python source in the interpreter. A few-body run (:func:`visviva.nbody.integrators.few_bodies`,
fewer than :data:`MAX_MASSIVE` massive particles) whose machine code is neither in memory nor
in numba's cache therefore starts interpreted, in slices of steps: the kernels pause at a step
count and resume without changing a bit (as for the progress bar). Once the process's
interpreted calls have used :data:`visviva.core.tier.BUDGET_S` of CPU, the run compiles (saying
so on stderr, once) and goes on in machine code from the step it reached: the same bits as a
run compiled from the start (the few-body gravity sums in a fixed order,
:func:`visviva.core.gravity.sum_rows`; tests compare every integrator and option bit for bit,
runs that switch tier midway included).
"""

from __future__ import annotations

import time

import numpy as np

from ..core import nbody_common as _nc
from ..core import tier as _core_tier

__all__ = ["interpreted_kernel", "run_slice", "MAX_MASSIVE", "SLICE_S", "SMALL_ENSEMBLE",
           "SMALL_ENSEMBLE_STEPS", "ensemble_would_compile"]

#: Runs with this many massive particles or more always compile (the interpreter costs about
#: 1 us per pair interaction, the machine code about 3 ns).
MAX_MASSIVE = 16
#: CPU seconds aimed at per slice (the kernel pauses at a step count estimated from the last one).
SLICE_S = 0.1

#: Ensembles of at most this many members run member by member, each as a lone run (through
#: this tier), while their ensemble call would compile: the ensemble kernel and the members'
#: kernel cost about 22 s of CPU to compile on a fresh install, a lone few-body run 1-2 s
#: (interpreted) or its one kernel's compile; the results are the same bits (a member equals its
#: lone run, tests/test_nbody_ensemble.py).
SMALL_ENSEMBLE = 64
#: ... and at most this many member-steps in all (a long run compiles and runs in parallel).
SMALL_ENSEMBLE_STEPS = 100_000

#: The interpreted cost of one step in the last slice (CPU seconds), for the next slice's length.
_per_step = {"s": None}


def interpreted_kernel(info, few: bool, istate, fstate, n_massive: int):
    """The interpreted kernel a run should use now, or ``None`` for the compiled one.

    ``None`` when the run is not a few-body run (``few``) or has :data:`MAX_MASSIVE` massive
    particles or more, or when :func:`visviva.core.tier.interpreted_if_cold` says so (tier off,
    budget used, or machine code ready).
    """
    if not few or n_massive >= MAX_MASSIVE:
        return None
    import importlib

    kernel = getattr(importlib.import_module(info.module), info.variant(few, istate, fstate))
    return _core_tier.interpreted_if_cold(kernel, _nc.RUN_SIGNATURE)


def run_slice(kernel, args: tuple, istate: np.ndarray, stop: int) -> int | None:
    """Run the interpreted ``kernel`` on ``args`` for one slice of steps.

    ``stop`` is the caller's own pause step (``istate[I_STOP_AT_STEP]``, 0 for none). Returns
    the kernel's status (``PAUSED`` at the end of a slice: call again), or ``None`` when Python
    raised (:func:`visviva.core.tier.run_guarded`: the arrays are as before the slice and the
    caller runs the machine code).
    """
    own = int(istate[_nc.I_STEPS]) + _slice_steps()
    istate[_nc.I_STOP_AT_STEP] = min(own, stop) if stop > 0 else own
    steps0 = int(istate[_nc.I_STEPS])
    t0 = time.process_time()
    ok, status = _core_tier.run_guarded(kernel, args)
    istate[_nc.I_STOP_AT_STEP] = stop
    if not ok:
        return None
    done = int(istate[_nc.I_STEPS]) - steps0
    if done > 0:
        _per_step["s"] = (time.process_time() - t0) / done
    return int(status)


def _slice_steps() -> int:
    # steps for about SLICE_S of CPU (and no more than the budget left), from the last slice
    per_step = _per_step["s"]
    if per_step is None:
        return 50
    left = max(_core_tier.BUDGET_S - _core_tier.spent["cpu_s"], 0.0)
    return int(min(max(min(SLICE_S, left) / max(per_step, 1e-7), 10), 1_000_000))


def ensemble_would_compile(members, t: float) -> bool:
    """True when an in-process CPU ensemble call on ``members`` (Simulations of one integrator)
    to the time ``t`` (simulation units) is small (:data:`SMALL_ENSEMBLE`,
    :data:`SMALL_ENSEMBLE_STEPS`; an adaptive member without a step yet counts 1,000 steps) and
    would compile, on a process where the tier is on: the ensemble kernel or the members' kernel
    has machine code neither in memory nor in numba's cache (found there, it is loaded)."""
    import importlib

    import numba

    from ..core.gravity import PAIR_MIN_N
    from ..core.nbody_ensemble import ENSEMBLE_SIGNATURE, ensemble_run

    if len(members) > SMALL_ENSEMBLE or _core_tier.spent["off"] or numba.config.DISABLE_JIT:
        return False
    steps = 0.0
    for s in members:
        span, dt = abs(t - s.t), abs(s.dt)
        steps += span / dt if dt > 0 else 1000.0
    if not steps <= SMALL_ENSEMBLE_STEPS:
        return False
    info = members[0].integrator_info
    few = max(np.count_nonzero(s.state_arrays()["m"]) for s in members) < PAIR_MIN_N
    rows = [s.state_arrays() for s in members]
    name = info.pack_variant(few, np.stack([r["istate"] for r in rows]),
                             np.stack([r["fstate"] for r in rows]))
    member_kernel = getattr(importlib.import_module(info.module), name)
    return not all(_core_tier.in_memory(k) or k.load_cached(sig) for k, sig in (
        (ensemble_run, ENSEMBLE_SIGNATURE), (member_kernel, _nc.RUN_SIGNATURE)))
