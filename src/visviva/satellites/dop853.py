"""The Dormand-Prince 8(5,3) tableau for the compiled integrators (Cowell, orbit determination)."""

from __future__ import annotations

import functools

import numpy as np

__all__ = ["dop853_tableau"]


@functools.lru_cache(maxsize=1)
def dop853_tableau():
    """The DOP853 coefficients (Hairer & Wanner), as contiguous float64 arrays.

    Taken from scipy, which transcribes Hairer's Fortran DOP853; scipy is a dependency of
    visviva, and the compiled integrator in :mod:`visviva.core.cowell` receives them as arrays.
    The module (plain numpy arrays) is loaded from its file: importing it by name would first
    import ``scipy.integrate`` and with it ``scipy.optimize`` (0.2 s of a first call's process).
    """
    dc = _scipy_dop853_module()

    def arr(a):
        return np.ascontiguousarray(a, dtype=np.float64)

    return (arr(dc.A), arr(dc.B), arr(dc.C), arr(dc.E3), arr(dc.E5), arr(dc.D))


def _scipy_dop853_module():
    """scipy's ``dop853_coefficients`` module, executed from its file (it imports numpy only)."""
    import importlib.util
    import sys
    from pathlib import Path

    name = "scipy.integrate._ivp.dop853_coefficients"
    if name in sys.modules:  # scipy.integrate already imported: the same module
        return sys.modules[name]
    scipy_dir = Path(importlib.util.find_spec("scipy").origin).parent
    path = scipy_dir / "integrate" / "_ivp" / "dop853_coefficients.py"
    if not path.is_file():  # another scipy layout: import it by name (slower, same arrays)
        import importlib

        return importlib.import_module(name)
    spec = importlib.util.spec_from_file_location("_visviva_scipy_dop853", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
