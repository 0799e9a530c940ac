"""N-body simulations: :class:`Simulation`, the integrators registry, forces, archives.

``vv.Simulation(integrator="ias15", G=1.0, dt=None)`` holds particles in plain float64 arrays;
``integrate(t)`` runs ONE compiled kernel through all the steps to the absolute time ``t``.
Integrators: ``leapfrog``, ``whfast``, ``ias15`` (see :mod:`visviva.nbody.integrators`).
:class:`Ensemble` advances many simulations together (numba threads, Dask workers or a GPU).
"""

from __future__ import annotations

from .ensemble import Ensemble
from .forces import J2, Force, GeneralRelativity, GeneralRelativityPotential, LinearDrag
from .integrators import INTEGRATORS, Integrator, get_integrator
from .simulation import COLLISION_MODES, Simulation, Trajectory

__all__ = [
    "Simulation",
    "Ensemble",
    "Trajectory",
    "solar_system",
    "Archive",
    "Force",
    "J2",
    "GeneralRelativity",
    "GeneralRelativityPotential",
    "LinearDrag",
    "INTEGRATORS",
    "Integrator",
    "get_integrator",
    "COLLISION_MODES",
]


def __getattr__(name):
    if name == "solar_system":
        from .solar_system import solar_system

        return solar_system
    if name == "Archive":
        from .archive import Archive

        return Archive
    raise AttributeError(f"module 'visviva.nbody' has no attribute {name!r}")
