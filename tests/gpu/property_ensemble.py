"""Property under numba's CUDA simulator (NUMBA_ENABLE_CUDASIM=1): a ``backend="cuda"``
ensemble gives the CPU ensemble's bits, member by member, over the settings and call sequences
``tests/test_nbody_ensemble_properties.py`` draws (every integrator; WHFast coordinates and
correctors; IAS15 step control; forces with their own parameters; mergers and escapes), and
raises the same exception for the same members. Prints ``key=value`` lines.

Not a ``check_*.py`` script: ``benchmarks/on_gpu.sh`` does not run it on a real GPU, where each
drawn set of forces would compile its own WHFast kernel (about a minute each) and agreement is
to round-off, not bits.
"""

from __future__ import annotations

import os
import sys

import numpy as np
from hypothesis import HealthCheck, given, settings

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import visviva as vv  # noqa: E402
from test_nbody_ensemble_properties import cases  # noqa: E402 (the tests folder)

failures: list = []
counts = {"examples": 0, "raised": 0}


def _step(ens, t):
    try:
        ens.integrate(t)
    except vv.VisvivaError as exc:
        return type(exc).__name__, tuple(exc.members)
    return None


def _differs(a, b):
    return not (a.N == b.N and a.t == b.t and a.steps_done == b.steps_done
                and np.array_equal(a.positions, b.positions)
                and np.array_equal(a.velocities, b.velocities))


@settings(max_examples=int(os.environ.get("EXAMPLES", "30")), deadline=None, database=None,
          suppress_health_check=list(HealthCheck))
@given(case=cases())
def run(case):
    sims, times = case
    counts["examples"] += 1
    gpu = vv.Ensemble.from_simulations(sims, backend="cuda")
    cpu = vv.Ensemble.from_simulations(sims)
    for t in times:
        eg, ec = _step(gpu, t), _step(cpu, t)
        bad = [k for k in range(len(sims)) if _differs(gpu[k], cpu[k])]
        if eg != ec or bad:
            failures.append((sims[0].integrator, t, eg, ec, bad))
            return
        if ec:
            counts["raised"] += 1
            return


def main():
    from visviva.core import tier as core_tier

    core_tier.spent["off"] = True  # the ensemble kernels themselves
    run()
    print(f"property_examples={counts['examples']!r}")
    print(f"property_raised={counts['raised']!r}")
    print(f"property_failures={len(failures)!r}")
    for f in failures[:5]:
        print(f"failure: {f!r}")


if __name__ == "__main__":
    main()
