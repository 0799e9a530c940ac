"""Orbit determination: initial orbits, measurement models, batch least squares, TLE fitting.

``import visviva as vv`` gives :func:`~visviva.gibbs`, :func:`~visviva.herrick_gibbs`,
:func:`~visviva.gauss_angles`, :class:`~visviva.Observations`, :func:`~visviva.fit_orbit`,
:func:`~visviva.filter_orbit` (sequential: EKF and smoother) and :func:`~visviva.fit_tle`,
:func:`~visviva.read_tdm` and :class:`~visviva.TDM` (tracking data from CCSDS TDM files); the
rest is here (``vv.od.double_r``, ``vv.od.simulate_observations``).
Names load lazily (PEP 562): importing ``visviva.od`` compiles nothing.
"""

from __future__ import annotations

from .. import _lazy

#: public name -> submodule of visviva.od that defines it
_EXPORTS = {
    "gibbs": "iod",
    "herrick_gibbs": "iod",
    "gauss_angles": "angles",
    "double_r": "angles",
    "initial_orbit": "first_orbit",
    "Observations": "observations",
    "fit_orbit": "batch",
    "filter_orbit": "sequential",
    "FilteredOrbit": "sequential",
    "OrbitFit": "batch",
    "fit_tle": "tle_fit",
    "TLEFit": "tle_fit",
    "fit_tle_batch": "tle_batch",
    "simulate_observations": "simulate",
    "simulate_tracking": "simulate",
    "read_tdm": "tracking_data",
    "TDM": "tracking_data",
}

__all__ = sorted(_EXPORTS)


__getattr__, __dir__ = _lazy.lazy_attributes(globals(), _EXPORTS, prefix=f"{__name__}.")
