"""Start-up cost: ``import visviva`` and the first call in a fresh process, numba cache warm.

Rows (each the median over several fresh Python processes; the first process, untimed, fills
numba's on-disk cache):

* ``import visviva``: the import statement alone (numpy included). Budget 0.5 s (issue 2).
* ``first call, plain floats``: ``vv.solve_kepler(1.0, 0.5)`` right after ``import visviva``.
  Budget 0.3 s.
* ``first call, Quantities``: ``vv.StateVectors(r, v, vv.EARTH.gm).to_elements()`` right after
  ``import visviva``, with astropy.units already imported (the user's script imported it to
  build ``r`` and ``v``). Budget 0.3 s.
* ``import + first call``: the two together, the time to a first result (no budget of its own).

The budget rows have no reference library: the "reference" column holds the budget, so that
``ratio = time / budget`` and the row is met when the ratio is at most 1. ``import visviva``
imports numba's modules ahead of the first call (:mod:`visviva._startup`), which splits numba's
fixed start-up cost between the two budgets. The notes give numba's own floor
for comparison: the first call of a trivial ``@njit(cache=True)`` function in a fresh process
(numba's import plus the initialisation of its compiler target, which also imports scipy.linalg
to look for BLAS). Interpreter start-up (about 20 ms) is excluded; numba's own import and the one-time initialisation of its compiler
target when the first cached function is loaded are included (see docs/design.md).

Run: ``python -m benchmarks --only startup`` or ``python -m benchmarks.bench_startup``.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

try:  # as part of the package (python -m benchmarks) or as a script
    from .common import result, skipped
except ImportError:  # pragma: no cover
    from common import result, skipped

_IMPORT = """
import time
t0 = time.perf_counter()
import visviva
print(time.perf_counter() - t0)
"""

_FIRST_FLOATS = """
import time
import visviva as vv
t0 = time.perf_counter()
vv.solve_kepler(1.0, 0.5)
print(time.perf_counter() - t0)
"""

_FIRST_QUANTITIES = """
import time
from astropy import units as u
r = [7000.0, 0.0, 0.0] * u.km
v = [0.0, 7.5, 1.0] * u.km / u.s
import visviva as vv
t0 = time.perf_counter()
vv.StateVectors(r, v, vv.EARTH.gm).to_elements()
print(time.perf_counter() - t0)
"""

_IMPORT_AND_FIRST = """
import time
t0 = time.perf_counter()
import visviva as vv
vv.solve_kepler(1.0, 0.5)
print(time.perf_counter() - t0)
"""


#: the floor any numba library pays: one trivial cached function, first call in a fresh process
_NUMBA_FLOOR_MODULE = """
import numba


@numba.njit(cache=True)
def plus_one(x):
    return x + 1.0
"""

_NUMBA_FLOOR = """
import time
t0 = time.perf_counter()
import numba_floor_module
numba_floor_module.plus_one(1.0)
print(time.perf_counter() - t0)
"""


def fresh_process_seconds(code: str, runs: int, cwd: str | None = None) -> list[float]:
    """Run ``code`` in ``runs`` fresh interpreters; return the seconds each one printed."""
    out = []
    for _ in range(runs):
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              check=True, timeout=300, cwd=cwd)
        out.append(float(proc.stdout.strip().splitlines()[-1]))
    return out


def numba_floor_seconds(runs: int) -> float:
    """Median first-call time of a trivial ``@njit(cache=True)`` function (warm cache)."""
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "numba_floor_module.py").write_text(_NUMBA_FLOOR_MODULE)
        fresh_process_seconds(_NUMBA_FLOOR, 1, cwd=tmp)  # compiles and fills the cache
        return statistics.median(fresh_process_seconds(_NUMBA_FLOOR, runs, cwd=tmp))


def run(quick: bool = False) -> list[dict]:
    runs = 3 if quick else 7
    rows = []
    try:
        floor = numba_floor_seconds(runs)
    except (subprocess.SubprocessError, ValueError):  # pragma: no cover
        floor = float("nan")
    cases = (("import visviva", _IMPORT, 0.5),
             ("first call, plain floats: solve_kepler(1.0, 0.5)", _FIRST_FLOATS, 0.3),
             ("first call, Quantities: StateVectors(...).to_elements()", _FIRST_QUANTITIES, 0.3),
             ("import + first call: solve_kepler(1.0, 0.5)", _IMPORT_AND_FIRST, None))
    for name, code, budget in cases:
        try:
            fresh_process_seconds(code, 1)  # fills numba's cache if it is cold
            times = fresh_process_seconds(code, runs)
        except (subprocess.SubprocessError, ValueError) as exc:  # pragma: no cover
            rows.append(skipped(name, f"the subprocess failed: {exc}"))
            continue
        median = statistics.median(times)
        if budget is None:  # the time to a first result, compared with numba's own floor
            rows.append(result(
                f"{name} (fresh process, warm numba cache)", median,
                "numba's floor: import numba + first call of a trivial cached function", floor,
                notes=f"median of {runs} processes; numpy's import included in both; 1 thread"))
            continue
        rows.append(result(
            f"{name} (fresh process, warm numba cache)", median, f"budget {budget:g} s (issue 2)",
            budget, target=1.0,
            notes=(f"median of {runs} processes, min {min(times) * 1e3:.0f} ms, "
                   f"max {max(times) * 1e3:.0f} ms; numba's own floor (a trivial cached "
                   f"function, first call in a fresh process) {floor * 1e3:.0f} ms; 1 thread")))
    return rows


if __name__ == "__main__":  # pragma: no cover
    for row in run():
        print(row)
