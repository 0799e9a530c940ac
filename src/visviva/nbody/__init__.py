"""N-body simulations: :class:`Simulation`, the integrators registry, forces, archives.

``vv.Simulation(integrator="ias15", G=1.0, dt=None)`` holds particles in plain float64 arrays;
``integrate(t)`` runs ONE compiled kernel through all the steps to the absolute time ``t``.
Integrators: ``leapfrog``, ``whfast``, ``ias15`` (see :mod:`visviva.nbody.integrators`).
"""

from __future__ import annotations

from .forces import Force, GeneralRelativity, GeneralRelativityPotential, J2Force, LinearDrag
from .integrators import INTEGRATORS, Integrator, get_integrator
from .simulation import COLLISION_MODES, Simulation, Trajectory

__all__ = [
    "Simulation",
    "Trajectory",
    "solar_system",
    "Archive",
    "Force",
    "J2Force",
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
    if name == "J2":
        from . import forces

        return forces.J2
    raise AttributeError(f"module 'visviva.nbody' has no attribute {name!r}")
