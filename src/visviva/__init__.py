"""visviva: orbital mechanics you can trust.

``import visviva as vv`` gives the public surface below. Submodules load on first use (PEP 562),
so importing visviva compiles nothing (it imports numba's modules ahead of the first call: see
:mod:`visviva._startup`); the first call of a compiled function compiles it once (or loads it
from numba's on-disk cache).

The expert layer of compiled kernels on plain float64 arrays is :mod:`visviva.core`.
"""

from __future__ import annotations

from . import _lazy, _startup  # noqa: F401  (_startup: numba's modules, see its docstring)

__version__ = "0.1.0"

#: public name -> module that defines it. One table; ``__all__`` is built from it.
_PUBLIC = {
    # bodies and constants
    "Body": "visviva.bodies",
    "SUN": "visviva.bodies",
    "MERCURY": "visviva.bodies",
    "VENUS": "visviva.bodies",
    "EARTH": "visviva.bodies",
    "MOON": "visviva.bodies",
    "MARS": "visviva.bodies",
    "JUPITER": "visviva.bodies",
    "SATURN": "visviva.bodies",
    "URANUS": "visviva.bodies",
    "NEPTUNE": "visviva.bodies",
    "PLUTO": "visviva.bodies",
    # errors
    "VisvivaError": "visviva.errors",
    "InvalidInputError": "visviva.errors",
    "UnitsError": "visviva.errors",
    "ShapeError": "visviva.errors",
    "InvalidStateError": "visviva.errors",
    "InvalidElementsError": "visviva.errors",
    "MissingFileError": "visviva.errors",
    "ConvergenceError": "visviva.errors",
    "DomainError": "visviva.errors",
    "StepSizeError": "visviva.errors",
    "Collision": "visviva.errors",
    "Encounter": "visviva.errors",
    "Escape": "visviva.errors",
    "BackendUnavailableError": "visviva.errors",
    "SurfaceImpact": "visviva.errors",
    "EarthOrientationWarning": "visviva.errors",
    "ChanAccuracyWarning": "visviva.errors",
    "Pc2dAccuracyWarning": "visviva.errors",
    "Pc3dAccuracyWarning": "visviva.errors",
    "Pc3dWindowWarning": "visviva.errors",
    "ImplausibleVelocityWarning": "visviva.errors",
    "PhaseRoundingWarning": "visviva.errors",
    "SubsurfacePerigeeWarning": "visviva.errors",
    "StaleElementSetWarning": "visviva.errors",
    # two-body core
    "StateVectors": "visviva.states",
    "KeplerianElements": "visviva.elements",
    "ModifiedEquinoctialElements": "visviva.equinoctial",
    "solve_kepler": "visviva.anomalies",
    "solve_kepler_hyperbolic": "visviva.anomalies",
    "mean_to_true": "visviva.anomalies",
    "true_to_mean": "visviva.anomalies",
    "solve_barker": "visviva.anomalies",
    "eccentric_to_true": "visviva.anomalies",
    "true_to_eccentric": "visviva.anomalies",
    "hyperbolic_to_true": "visviva.anomalies",
    "true_to_hyperbolic": "visviva.anomalies",
    "parabolic_to_true": "visviva.anomalies",
    "true_to_parabolic": "visviva.anomalies",
    "eccentric_to_mean": "visviva.anomalies",
    "hyperbolic_to_mean": "visviva.anomalies",
    "propagate_kepler": "visviva.propagation",
    # central force
    "vis_viva": "visviva.central_force",
    "effective_potential": "visviva.central_force",
    "orbit_equation": "visviva.central_force",
    # N-body
    "Simulation": "visviva.nbody",
    # animation
    "animate_orbit": "visviva.animation",
    "animate_simulation": "visviva.animation",
    "save_animation": "visviva.animation",
    "solar_system": "visviva.nbody",
    "Ensemble": "visviva.nbody",
    # satellites
    "Satellite": "visviva.satellites",
    "Catalog": "visviva.satellites",
    "read_tle_file": "visviva.satellites",
    "read_omm_file": "visviva.satellites",
    "read_catalog_file": "visviva.satellites",
    "TLEFormatError": "visviva.satellites",
    "SGP4Error": "visviva.satellites",
    "SatelliteDecayedError": "visviva.satellites",
    "propagate_cowell": "visviva.satellites",
    "propagate_covariance": "visviva.satellites",
    "J2": "visviva.satellites",
    "Zonal": "visviva.satellites",
    "AtmosphericDrag": "visviva.satellites",
    "ThirdBody": "visviva.satellites",
    "SolarRadiationPressure": "visviva.satellites",
    "Relativity": "visviva.satellites",
    "lambert": "visviva.satellites",
    "Maneuver": "visviva.satellites",
    "ImpulsiveBurn": "visviva.satellites",
    "FiniteBurn": "visviva.satellites",
    "hohmann_delta_v": "visviva.satellites",
    "porkchop": "visviva.satellites",
    "Eclipse": "visviva.satellites",
    "ReEntry": "visviva.satellites",
    "AltitudeCrossing": "visviva.satellites",
    "AscendingNode": "visviva.satellites",
    "DescendingNode": "visviva.satellites",
    "Apsides": "visviva.satellites",
    "j2_secular_rates": "visviva.satellites",
    "propagate_j2_secular": "visviva.satellites",
    "sun_synchronous_inclination": "visviva.satellites",
    # conjunctions
    "screen_conjunctions": "visviva.conjunctions",
    "collision_probability": "visviva.conjunctions",
    "collision_probabilities": "visviva.conjunctions",
    "max_collision_probability": "visviva.conjunctions",
    "monte_carlo_probability": "visviva.conjunctions",
    # orbit determination
    "gibbs": "visviva.od",
    "herrick_gibbs": "visviva.od",
    "gauss_angles": "visviva.od",
    "Observations": "visviva.od",
    "fit_orbit": "visviva.od",
    "filter_orbit": "visviva.od.sequential",
    "fit_tle": "visviva.od",
    # CCSDS orbit data messages
    "CCSDSFormatError": "visviva.ccsds.grammar",
    "read_oem": "visviva.ccsds.oem_io",
    "write_oem": "visviva.ccsds.oem_io",
    "read_opm": "visviva.ccsds.opm",
    "write_opm": "visviva.ccsds.opm",
    "read_omm": "visviva.ccsds.omm",
    "write_omm": "visviva.ccsds.omm",
    "read_cdm": "visviva.ccsds.cdm",
    "write_cdm": "visviva.ccsds.cdm",
    "ConjunctionDataMessage": "visviva.ccsds.cdm",
    "read_tdm": "visviva.od.tracking_data",
    "write_tdm": "visviva.ccsds.tdm_write",
    "TDM": "visviva.od.tracking_data",
    # ground stations and passes
    "GroundStation": "visviva.ground",
    "ElevationMask": "visviva.ground",
    "find_passes": "visviva.ground",
}

#: subpackages reachable as attributes: ``vv.mechanics``, ``vv.core``, ...
_SUBMODULES = {
    "core", "mechanics", "nbody", "satellites", "constants", "bodies", "errors", "central_force",
    "conjunctions", "ccsds", "ground", "od",
}

__all__ = sorted(_PUBLIC) + ["__version__"]


__getattr__, __dir__ = _lazy.lazy_attributes(globals(), _PUBLIC, _SUBMODULES)
