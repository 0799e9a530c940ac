"""Ground stations: look angles, Doppler, rise/culmination/set, visible passes for catalogues.

Names load lazily (PEP 562) from the module listed in ``_EXPORTS``, as in
:mod:`visviva.satellites`: importing ``visviva.ground`` imports neither astropy's coordinates
nor sgp4, and compiles nothing.
"""

from __future__ import annotations

import importlib

#: public name -> submodule of visviva.ground that defines it
_EXPORTS = {
    "GroundStation": "station",
    "find_passes": "passes",
    "write_passes": "passes",
    "visual_magnitude": "visibility",
    "LookAngles": "look",
    "refraction_deg": "look",
    "doppler_shift": "doppler",
    "plot_sky_track": "plots",
    "find_passes_dask": "dask_passes",
    "twilight": "visibility",
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
