"""Earth satellites: TLE/OMM through sgp4, frames through astropy, catalogue-scale batches, Dask,
ground tracks; Cowell propagation with perturbations, events and mission design.

Names load lazily (PEP 562) from the module listed in ``_EXPORTS``, so that importing
``visviva.satellites`` neither imports sgp4/astropy/dask nor compiles anything, and a module that
is being edited does not break the others (one mechanism for every package:
:func:`visviva._lazy.lazy_attributes`). To add a public name: one line ``"Name": "module"``.
"""

from __future__ import annotations

from .. import _lazy

#: public name -> submodule of visviva.satellites that defines it
_EXPORTS = {
    # TLE/OMM, frames, catalogue batches, Dask, ground tracks and plots:
    "Satellite": "tle",
    "SatelliteStates": "satellite_states",
    "SatelliteElements": "satellite_states",
    "SatelliteEquinoctialElements": "satellite_states",
    "TLEFormatError": "tle_checks",
    "SGP4Error": "tle_checks",
    "SatelliteDecayedError": "tle_checks",
    "teme_to_gcrs": "frames",
    "teme_to_itrs": "frames",
    "gcrs_to_itrs": "frames",
    "itrs_to_geodetic": "frames",
    "Catalog": "catalog",
    "read_tle_file": "catalog",
    "read_omm_file": "catalog",
    "read_catalog_file": "catalog",
    "propagate_sgp4_batch": "catalog",
    "propagate_kepler_batch": "catalog",
    "propagate_j2_batch": "catalog",
    "propagate_sgp4_dask": "dask_batch",
    "propagate_dask": "dask_batch",
    "BatchStates": "catalog",
    "DaskBatch": "dask_batch",
    "ground_track": "groundtrack",
    "eclipse_fraction": "groundtrack",
    "plot_ground_track": "plots",
    "plot_orbit_3d": "plots",
    "plot_altitude_eclipse": "plots",
    # Cowell, perturbations, events, mission design:
    "propagate_cowell": "cowell",
    "CowellResult": "cowell",
    "propagate_covariance": "covariance",
    "CovarianceResult": "covariance",
    "J2": "perturbations",
    "Zonal": "perturbations",
    "AtmosphericDrag": "perturbations",
    "ThirdBody": "perturbations",
    "SolarRadiationPressure": "perturbations",
    "SphericalHarmonics": "perturbations",
    "Relativity": "relativity",
    "Eclipse": "events",
    "ReEntry": "events",
    "AltitudeCrossing": "events",
    "AscendingNode": "events",
    "DescendingNode": "events",
    "Apsides": "events",
    "EventRecord": "events",
    "sun_position": "ephemeris",
    "moon_position": "ephemeris",
    "planet_heliocentric": "ephemeris",
    "lambert": "lambert_solvers",
    "Maneuver": "maneuvers",
    "ImpulsiveBurn": "burns",
    "FiniteBurn": "burns",
    "BurnRecord": "burns",
    "Impulse": "maneuvers",
    "hohmann_delta_v": "maneuvers",
    "bielliptic_delta_v": "maneuvers",
    "plane_change_delta_v": "maneuvers",
    "hohmann_plane_change_delta_v": "combined_maneuvers",
    "porkchop": "porkchop_plot",
    "Porkchop": "porkchop_plot",
    "j2_secular_rates": "secular",
    "propagate_j2_secular": "secular",
    "sun_synchronous_inclination": "secular",
    "sun_synchronous_semi_major_axis": "secular",
    "frozen_eccentricity": "secular",
    "repeat_ground_track_semi_major_axis": "secular",
}

__all__ = sorted(_EXPORTS)


__getattr__, __dir__ = _lazy.lazy_attributes(globals(), _EXPORTS, prefix=f"{__name__}.")
