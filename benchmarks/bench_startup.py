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
* ``cold start, whole process`` (not with ``--quick``): the first calls of issue 11 (elements
  from states, two-body propagation, ``Satellite.gcrs`` on 1441 times, a WHFast and an IAS15
  integration, ``propagate_cowell`` with J2), each a whole script in a fresh process with an
  EMPTY numba cache (a new ``NUMBA_CACHE_DIR`` per case; small calls run in the interpreter
  tier, :mod:`visviva.core.tier`), then compiling (``VISVIVA_INTERPRET=0``), then again warm.
  Budgets: 5 s cold, 1.5 s warm. Reported as CPU time (the machine may be shared), wall time in the notes.
* ``cold start, whole process: ... + MEGNO`` (not with ``--quick``): the same for a first MEGNO
  run of each integrator and of an ensemble (:data:`MEGNO_CASES`; too long for the interpreter
  tier, so each compiles its integrator's MEGNO kernel). The same budgets, not met: the row
  tracks the compile time (docs/performance.md).

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

import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

try:  # as part of the package (python -m benchmarks) or as a script
    from .common import failed, result
except ImportError:  # pragma: no cover
    from common import failed, result

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


#: the first calls of issue 11, each a whole script (imports included)
_COLD_CASES = {
"elements": """
from astropy import units as u
import visviva as vv
r = [[7000.0, 0.0, 0.0], [0.0, 42164.0, 0.0]] * u.km
v = [[0.0, 7.5, 1.0], [-3.07, 0.0, 0.0]] * u.km / u.s
vv.StateVectors(r, v, vv.EARTH).to_elements().semi_major_axis
""",
"propagate": """
from astropy import units as u
import visviva as vv
r = [[7000.0, 0.0, 0.0], [0.0, 42164.0, 0.0]] * u.km
v = [[0.0, 7.5, 1.0], [-3.07, 0.0, 0.0]] * u.km / u.s
vv.StateVectors(r, v, vv.EARTH).propagate(3600 * u.s).r
""",
"gcrs": """
from astropy import units as u
import numpy as np
import visviva as vv
sat = vv.Satellite.from_tle("1 25544U 98067A   19343.69339541  .00001764  00000-0  38792-4 0  9991",
    "2 25544  51.6439 211.2001 0007417  17.6667  85.6398 15.50103472202482")
sat.gcrs(np.linspace(0, 86400, 1441) * u.s).r
""",
"whfast": """
import visviva as vv
sim = vv.Simulation(integrator="whfast", G=1.0, dt=0.01)
sim.add(1.0, [0,0,0], [0,0,0]); sim.add(1e-3, [1,0,0], [0,1,0]); sim.add(1e-3, [2,0,0], [0,0.7,0])
sim.integrate(10.0); sim.energy()
""",
"ias15": """
import visviva as vv
sim = vv.Simulation(integrator="ias15", G=1.0)
sim.add(1.0, [0,0,0], [0,0,0]); sim.add(1e-3, [1,0,0], [0,1,0]); sim.add(1e-3, [2,0,0], [0,0.7,0])
sim.integrate(10.0); sim.energy()
""",
"ensemble": """
import visviva as vv
sims = []
for a2 in (1.3, 1.6, 1.9):
    sim = vv.Simulation("whfast", dt=0.15)
    sim.add(1.0); sim.add(1e-3, a=1.0, primary=0); sim.add(3e-4, a=a2)
    sims.append(sim)
ens = vv.Ensemble.from_simulations(sims)
ens.integrate(100.0); ens.energy()
""",
"cowell": """
from astropy import units as u
import numpy as np
import visviva as vv
s = vv.StateVectors([7000.0, 0.0, 0.0] * u.km, [0.0, 7.5, 1.0] * u.km / u.s, vv.EARTH)
vv.propagate_cowell(s, np.linspace(0, 86400, 145) * u.s, perturbations=[vv.J2(vv.EARTH)]).r
""",
}


#: a fixed-step integrator's first MEGNO run: two planets at a = 1 and 1.6 to t = 100
_FIXED_STEP_MEGNO = """
import visviva as vv
sim = vv.Simulation(integrator="{integrator}", G=1.0, dt={dt})
sim.add(1.0); sim.add(1e-3, a=1.0, primary=0); sim.add(1e-3, a=1.6, primary=0)
sim.init_megno(seed=1)
sim.integrate(100.0); sim.megno()
"""

#: First MEGNO runs (the nineteenth and twentieth sessions' feature), each a whole script
MEGNO_CASES = {
"whfast + MEGNO": _FIXED_STEP_MEGNO.format(integrator="whfast", dt=0.01),
"ias15 + MEGNO": """
import visviva as vv
sim = vv.Simulation(integrator="ias15")
sim.add(1.0); sim.add(1e-3, a=1.0, primary=0); sim.add(1e-3, a=1.25, primary=0)
sim.move_to_com()
sim.init_megno(seed=1)
sim.integrate(300.0); sim.megno(), sim.lyapunov()
""",
"leapfrog + MEGNO": _FIXED_STEP_MEGNO.format(integrator="leapfrog", dt=0.005),
"ensemble + MEGNO": """
import visviva as vv
sims = []
for a2 in (1.3, 1.6, 1.9):
    sim = vv.Simulation("whfast", dt=0.01)
    sim.add(1.0); sim.add(1e-3, a=1.0, primary=0); sim.add(3e-4, a=a2, primary=0)
    sim.init_megno(seed=1)
    sims.append(sim)
ens = vv.Ensemble.from_simulations(sims)
ens.integrate(100.0); ens.megno()
""",
}


def whole_process_seconds(code: str, env: dict) -> tuple[float, float]:
    """Run ``code`` in a fresh interpreter; return (wall, CPU) seconds of the whole process.

    CPU time (user + system, all threads, from ``RUSAGE_CHILDREN``) is the figure to compare on
    a shared machine: other processes stretch the wall time, not the CPU time.
    """
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                   timeout=1800, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def cold_rows(runs: int = 3, cases: dict | None = None) -> list[dict]:
    """One row per case: the whole process with an empty numba cache, then compiled, then warm.

    Each case gets a fresh ``NUMBA_CACHE_DIR``. The first process is what a new user meets
    (cold: the interpreter tier runs the small call, :mod:`visviva.core.tier`). The second runs
    with ``VISVIVA_INTERPRET=0`` on the still empty cache: it compiles every kernel it needs
    (what a call too large for the interpreter costs the first time) and fills the cache. The
    next ``runs`` load the machine code from that cache (warm, median). Budgets (issue 11):
    cold <= 5 s (goal 2 s), warm <= 1.5 s, whole process. The row's time is the cold CPU time;
    the compiling and warm CPU times and the wall times are in the notes.
    """
    rows = []
    for name, code in (cases or _COLD_CASES).items():
        label = f"cold start, whole process: {name} (empty numba cache, CPU time)"
        with tempfile.TemporaryDirectory() as cache:
            env = dict(os.environ, NUMBA_CACHE_DIR=cache)
            try:
                cold_wall, cold_cpu = whole_process_seconds(code, env)
                _, compiled_cpu = whole_process_seconds(code, dict(env, VISVIVA_INTERPRET="0"))
                warm = [whole_process_seconds(code, env) for _ in range(runs)]
            except (subprocess.SubprocessError, OSError) as exc:  # pragma: no cover
                rows.append(failed(label, exc))
                continue
        warm_wall = statistics.median(w for w, _ in warm)
        warm_cpu = statistics.median(c for _, c in warm)
        rows.append(result(
            label, cold_cpu, "budget 5 s (issue 11; goal 2 s)", 5.0, target=1.0,
            notes=(f"cold wall {cold_wall:.1f} s; compiling instead (VISVIVA_INTERPRET=0, "
                   f"empty cache) CPU {compiled_cpu:.1f} s; warm (cache filled, median of "
                   f"{runs}) CPU {warm_cpu:.2f} s, wall {warm_wall:.2f} s (budget 1.5 s); "
                   "imports included")))
    return rows


def fresh_process_seconds(code: str, runs: int, cwd: str | None = None) -> list[float]:
    """Run ``code`` in ``runs`` fresh interpreters; return the seconds each one printed."""
    out = []
    for _ in range(runs):
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              check=True, timeout=300, cwd=cwd)
        out.append(float(proc.stdout.strip().splitlines()[-1]))
    return out


def _with_stderr(exc: BaseException) -> BaseException:
    """``exc``, with the last lines of a failed subprocess's stderr in its message."""
    err = getattr(exc, "stderr", None)
    if not err:
        return exc
    tail = " | ".join(str(err).strip().splitlines()[-3:])
    return RuntimeError(f"{exc}; stderr: {tail}")


def numba_floor_seconds(runs: int) -> float:
    """Median first-call time of a trivial ``@njit(cache=True)`` function (warm cache)."""
    from visviva._text import replace_text_file

    with tempfile.TemporaryDirectory() as tmp:
        replace_text_file(Path(tmp, "numba_floor_module.py"), _NUMBA_FLOOR_MODULE)
        fresh_process_seconds(_NUMBA_FLOOR, 1, cwd=tmp)  # compiles and fills the cache
        return statistics.median(fresh_process_seconds(_NUMBA_FLOOR, runs, cwd=tmp))


def run(quick: bool = False) -> list[dict]:
    runs = 3 if quick else 7
    rows = []
    try:
        floor = numba_floor_seconds(runs)
    except (subprocess.SubprocessError, ValueError) as exc:  # pragma: no cover
        floor = None
        rows.append(failed("numba's floor (trivial cached function)", _with_stderr(exc)))
    cases = (("import visviva", _IMPORT, 0.5),
             ("first call, plain floats: solve_kepler(1.0, 0.5)", _FIRST_FLOATS, 0.3),
             ("first call, Quantities: StateVectors(...).to_elements()", _FIRST_QUANTITIES, 0.3),
             ("import + first call: solve_kepler(1.0, 0.5)", _IMPORT_AND_FIRST, None))
    for name, code, budget in cases:
        try:
            fresh_process_seconds(code, 1)  # fills numba's cache if it is cold
            times = fresh_process_seconds(code, runs)
        except (subprocess.SubprocessError, ValueError) as exc:  # pragma: no cover
            rows.append(failed(name, _with_stderr(exc)))
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
    if not quick:  # minutes of CPU: every kernel compiled from scratch once per case
        rows += cold_rows(runs)
        rows += cold_rows(runs, MEGNO_CASES)
    return rows


if __name__ == "__main__":  # pragma: no cover
    for row in run():
        print(row)
