"""N-body simulations: :class:`Simulation`, the integrators registry, forces, archives.

``vv.Simulation(integrator="ias15", G=1.0, dt=None)`` holds particles in plain float64 arrays;
``integrate(t)`` runs ONE compiled kernel through all the steps to the absolute time ``t``.
Integrators: ``leapfrog``, ``whfast``, ``ias15`` (see :mod:`visviva.nbody.integrators`).
:class:`Ensemble` advances many simulations together (numba threads, Dask workers or a GPU).
"""

from __future__ import annotations

from .ensemble import Ensemble
from .forces import Force, GeneralRelativity, GeneralRelativityPotential, J2Force, LinearDrag
from .integrators import INTEGRATORS, Integrator, get_integrator
from .simulation import COLLISION_MODES, Simulation, Trajectory

# solar_system is bound eagerly (light imports): a lazy binding was lost to the submodule of the
# same name as soon as anything imported ``visviva.nbody.solar_system`` (pytest's
# --doctest-modules collection does), after which ``vv.solar_system`` was the module
from .solar_system import solar_system

__all__ = [
    "Simulation",
    "Ensemble",
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
    if name == "Archive":
        from .archive import Archive

        return Archive
    if name == "J2":
        from . import forces

        return forces.J2
    raise AttributeError(f"module 'visviva.nbody' has no attribute {name!r}")
