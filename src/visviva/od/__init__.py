"""Orbit determination: initial orbits, measurement models, batch least squares, TLE fitting.

``import visviva as vv`` gives :func:`~visviva.gibbs`, :func:`~visviva.herrick_gibbs`,
:func:`~visviva.gauss_angles`, :class:`~visviva.Observations`, :func:`~visviva.fit_orbit` and
:func:`~visviva.fit_tle`; the rest is here (``vv.od.double_r``, ``vv.od.simulate_observations``).
Names load lazily (PEP 562): importing ``visviva.od`` compiles nothing.
"""

from __future__ import annotations

import importlib

#: public name -> submodule of visviva.od that defines it
_EXPORTS = {
    "gibbs": "iod",
    "herrick_gibbs": "iod",
    "gauss_angles": "iod",
    "double_r": "iod",
    "Observations": "observations",
    "fit_orbit": "batch",
    "OrbitFit": "batch",
    "fit_tle": "tle_fit",
    "TLEFit": "tle_fit",
    "fit_tle_batch": "tle_batch",
    "simulate_observations": "simulate",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        module = importlib.import_module(f"{__name__}.{_EXPORTS[name]}")
        value = getattr(module, name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
