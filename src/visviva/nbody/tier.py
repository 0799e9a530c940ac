"""The interpreter tier: a small N-body run on a fresh install starts at once.

With an empty numba cache, the first WHFast or IAS15 run of a process compiles its kernel for
11-14 s of CPU, while a three-body run to ``t = 10`` takes 0.1 s when the kernel's own Python
source runs in the interpreter. So, as the JIT compilers of the JVM and of JavaScript engines
do, a few-body run whose machine code is neither in memory nor in numba's on-disk cache starts
in the interpreter, in slices of steps (the kernels pause at a step count and resume without
changing a bit, as for the progress bar). Once the interpreted slices of the process have used
:data:`BUDGET_S` seconds of CPU, the run compiles (saying so on stderr, once) and goes on in
machine code; from then on the machine code is cached on disk and every later run, in any
process, uses it. ``visviva warmup`` fills the cache ahead.

The interpreted kernel is the same source (:func:`visviva.core._jit.interpreted`): the same
operations in the same order on IEEE doubles, so the same bits as the machine code (the
few-body gravity sums in a fixed order, see :func:`visviva.core.gravity.sum_rows`; tests compare
whole runs of every integrator and option bit for bit, also runs that switch tier midway).
Where the interpreter raises instead of returning ``inf``/``nan`` (a division by zero, an
overflow), the slice's arrays are restored and the machine code runs it. Only few-body runs
(:func:`visviva.nbody.integrators.few_bodies`, fewer than :data:`MAX_MASSIVE` massive
particles) are interpreted; ``VISVIVA_INTERPRET=0`` in the environment switches the tier off.
"""

from __future__ import annotations

import os
import time

import numpy as np

from ..core import nbody_common as _nc

__all__ = ["interpreted_kernel", "run_slice", "MAX_MASSIVE", "BUDGET_S"]

#: Runs with this many massive particles or more always compile (the interpreter costs about
#: 1 us per pair interaction, the machine code about 3 ns).
MAX_MASSIVE = 16
#: CPU seconds a process spends in interpreted slices before it compiles instead.
BUDGET_S = 1.0
#: CPU seconds aimed at per slice (the kernel pauses at a step count estimated from the last one).
SLICE_S = 0.1

#: What the process has spent, its cost per step estimate, and whether the tier is off
#: (after Python raised where the machine code would not).
_spent = {"cpu_s": 0.0, "per_step_s": None, "off": os.environ.get("VISVIVA_INTERPRET") == "0"}


def interpreted_kernel(info, few: bool, istate, fstate, n_massive: int):
    """The interpreted kernel a run should use now, or ``None`` for the compiled one.

    ``None`` when the run is not a few-body run (``few``) or has :data:`MAX_MASSIVE` massive
    particles or more, when the process has used its :data:`BUDGET_S`, when the tier is off,
    or when the kernel's machine code is in memory or in numba's cache (it is then loaded).
    """
    if not few or n_massive >= MAX_MASSIVE or _spent["off"] or _spent["cpu_s"] >= BUDGET_S:
        return None
    import importlib

    from ..core._jit import interpreted

    kernel = getattr(importlib.import_module(info.module), info.variant(few, istate, fstate))
    load_cached = getattr(kernel, "load_cached", None)
    if load_cached is None or load_cached(_nc.RUN_SIGNATURE):
        return None  # machine code ready (or numba's JIT is disabled: the kernel is Python)
    return interpreted(kernel)


def run_slice(kernel, args: tuple, istate: np.ndarray, stop: int) -> int | None:
    """Run the interpreted ``kernel`` on ``args`` for one slice of steps.

    ``stop`` is the caller's own pause step (``istate[I_STOP_AT_STEP]``, 0 for none). Returns
    the kernel's status (``PAUSED`` at the end of a slice: call again), or ``None`` when Python
    raised: the arrays are then as they were before the slice, the tier is off for the process,
    and the caller runs the machine code.
    """
    steps = _slice_steps()
    own = int(istate[_nc.I_STEPS]) + steps
    istate[_nc.I_STOP_AT_STEP] = min(own, stop) if stop > 0 else own
    saved = [(a, a.copy()) for a in args if isinstance(a, np.ndarray)]
    steps0 = int(istate[_nc.I_STEPS])
    t0 = time.process_time()
    try:
        with np.errstate(all="ignore"):
            status = int(kernel(*args))
    except Exception:  # noqa: BLE001 - any difference from the machine code: let it run the slice
        for a, copy in saved:
            a[...] = copy
        _spent["off"] = True
        return None
    finally:
        _spent["cpu_s"] += time.process_time() - t0
    done = int(istate[_nc.I_STEPS]) - steps0
    if done > 0:
        _spent["per_step_s"] = (time.process_time() - t0) / done
    istate[_nc.I_STOP_AT_STEP] = stop
    return status


def _slice_steps() -> int:
    # steps for about SLICE_S of CPU (and no more than the budget left), from the last slice
    per_step = _spent["per_step_s"]
    if per_step is None:
        return 50
    left = max(BUDGET_S - _spent["cpu_s"], 0.0)
    return int(min(max(min(SLICE_S, left) / max(per_step, 1e-7), 10), 1_000_000))
