"""What ``import visviva`` loads ahead of the first call: numba's modules, nothing compiled.

The start-up budgets (issue 2) are ``import visviva`` <= 0.5 s and, with numba's cache warm, a
first call <= 0.3 s. numba's own start-up costs about 0.35 s on the 2-core CI machine (its import,
0.12 s; importing scipy.linalg, which numba does to look for BLAS the first time it loads compiled
code, 0.09 s; initialising its compiler target, 0.1 s), more than the first-call budget alone.
So the import pays the module imports (about 0.27 s with numpy, measured in
``benchmarks/bench_startup.py``) and the first call the rest (about 0.12 s: the compiler target
and the cached machine code of the kernels it needs). No kernel module is imported here and
nothing is compiled; astropy is still imported only when needed (see :mod:`visviva._units`).
"""

from __future__ import annotations

import numba  # noqa: F401
import scipy.linalg.cython_blas  # noqa: F401  (what numba imports when it first loads code)
