"""Ground stations: look angles, Doppler, rise/culmination/set, visible passes for catalogues.

Names load lazily (PEP 562) from the module listed in ``_EXPORTS``, as in
:mod:`visviva.satellites`: importing ``visviva.ground`` imports neither astropy's coordinates
nor sgp4, and compiles nothing.
"""

from __future__ import annotations

from .. import _lazy

#: public name -> submodule of visviva.ground that defines it
_EXPORTS = {
    "GroundStation": "station",
    "ElevationMask": "mask",
    "find_passes": "passes",
    "write_passes": "passes",
    "visual_magnitude": "visibility",
    "LookAngles": "look",
    "refraction_deg": "refraction",
    "refraction_slope": "refraction",
    "doppler_shift": "doppler",
    "plot_sky_track": "plots",
    "find_passes_dask": "dask_passes",
    "twilight": "visibility",
}

__all__ = sorted(_EXPORTS)

#: submodules reachable as attributes (``vv.ground.search``, ...)
_SUBMODULES = {"station", "look", "doppler", "search", "passes", "visibility", "plots",
               "earthfixed", "dask_passes", "cli", "air", "refraction", "mask",
               "masked_search"}

__getattr__, __dir__ = _lazy.lazy_attributes(globals(), _EXPORTS, _SUBMODULES,
                                             prefix="visviva.ground.")
