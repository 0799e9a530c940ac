"""The interpreter tier: a small first call on a fresh install runs at once instead of compiling.

With an empty numba cache the first call of a kernel compiles it: 1.5-4 s of CPU for the
two-body propagator or a Cowell run, 11-14 s for an N-body integrator, while the same small
call takes milliseconds to a few tenths of a second when the kernel's own Python source runs in
the interpreter. So, as the JIT compilers of the JVM and of JavaScript engines do, a call whose
machine code is neither in memory nor in numba's on-disk cache, and whose work the caller
judges small, runs interpreted (:func:`visviva.core._jit.interpreted`). Once the interpreted
calls of a process have used :data:`BUDGET_S` seconds of CPU, every call compiles (saying so on
stderr, once) and runs in machine code; the machine code is then cached on disk and every later
call, in any process, uses it. ``visviva warmup`` fills the cache ahead.

The interpreted kernel is the same source: the same operations in the same order on IEEE
doubles, so the same bits as the machine code (the tests compare whole runs bit for bit). Where
the interpreter raises instead of returning ``inf``/``nan`` (a division by zero, an overflow),
the arrays the call was given are restored and the machine code runs it. The tier is off when
``VISVIVA_INTERPRET=0`` is set, when numba's JIT is disabled, and when numba uses Intel's SVML
(its vectorised transcendental functions round differently from the C library's).

Callers: the state and element constructors' scans, :meth:`visviva.StateVectors.to_elements`,
:meth:`visviva.KeplerianElements.to_state`, two-body propagation (:mod:`visviva.propagation`),
the anomaly functions (:mod:`visviva.anomalies`), :func:`visviva.lambert`,
:func:`visviva.propagate_cowell` (one state), and the N-body integrators in slices of steps
(:mod:`visviva.nbody.tier`).
"""

from __future__ import annotations

import os
import time

import numba
import numpy as np

from ._jit import interpreted

__all__ = ["BUDGET_S", "SMALL_ITEMS", "in_memory", "interpreted_if_cold", "run_guarded", "call", "spent",
           "budget_left"]

#: CPU seconds a process spends in interpreted calls before every call compiles instead.
BUDGET_S = 1.0
#: Array calls (elements, two-body propagation) of up to this many items are small (about
#: 20-100 us each interpreted).
SMALL_ITEMS = 1000

#: What the process has spent, and whether the tier is off (switched off by the environment,
#: or after the interpreter raised where the machine code would not).
spent = {"cpu_s": 0.0, "off": os.environ.get("VISVIVA_INTERPRET") == "0"}


def _available() -> bool:
    return not (spent["off"] or spent["cpu_s"] >= BUDGET_S or numba.config.DISABLE_JIT
                or numba.config.USING_SVML)


def in_memory(kernel) -> bool:
    """True when ``kernel`` has machine code in memory (for any signature): the warm path,
    which then skips every other check of the tier (they cost about 30 us a call)."""
    return bool(getattr(kernel, "overloads", None))


def interpreted_if_cold(kernel, signature):
    """The interpreted ``kernel`` when it should run interpreted now, else ``None``.

    ``None`` when the tier is off or its budget is used, or when the machine code for
    ``signature`` (a numba signature, or the tuple of argument types of a call from Python) is
    in memory or in numba's cache (it is then loaded, as a call would).
    """
    if not _available() or in_memory(kernel):
        return None
    load_cached = getattr(kernel, "load_cached", None)
    if load_cached is None or load_cached(signature):
        return None
    return interpreted(kernel)


def run_guarded(fn, args: tuple, accept=None):
    """``(True, fn(*args))``, or ``(False, None)`` when ``fn`` raised (the tier is then off for
    the process) or ``accept(result)`` is False (the call stopped at a step cap of the caller's):
    the arrays in ``args`` are then as they were before the call, for the machine code to run
    it. The CPU time is counted against :data:`BUDGET_S`."""
    saved = [(a, a.copy()) for a in args if isinstance(a, np.ndarray) and a.flags.writeable]
    t0 = time.process_time()
    try:
        with np.errstate(all="ignore"):
            result = fn(*args)
    except Exception:  # noqa: BLE001 - any difference from the machine code: let it run instead
        result, spent["off"] = None, True
    finally:
        spent["cpu_s"] += time.process_time() - t0
    if spent["off"] or (accept is not None and not accept(result)):
        for a, copy in saved:
            a[...] = copy
        return False, None
    return True, result


def budget_left() -> float:
    """CPU seconds the process may still spend in interpreted calls."""
    return max(BUDGET_S - spent["cpu_s"], 0.0) if _available() else 0.0


def call(kernel, *args, small: bool = True):
    """``kernel(*args)``: interpreted when ``small`` and its machine code is not ready (see
    the module docstring), in machine code otherwise. The same result either way."""
    # (a plain Python callable, e.g. a kernel wrapped by a caller's instrumentation, is called)
    if small and _available() and not in_memory(kernel) and hasattr(kernel, "typeof_pyval"):
        fn = interpreted_if_cold(kernel, tuple(kernel.typeof_pyval(a) for a in args))
        if fn is not None:
            ok, result = run_guarded(fn, args)
            if ok:
                return result
    return kernel(*args)
