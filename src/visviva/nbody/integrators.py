"""The registry of N-body integrators and what each can do.

Each entry names a compiled kernel with the common signature of
:mod:`visviva.core.nbody_common` and declares its capabilities; tests are parametrized over the
registry and select integrators by capability.

=============  ==========  ========  =========================  =====================================
name           symplectic  adaptive  velocity-dependent forces  reference
=============  ==========  ========  =========================  =====================================
``leapfrog``   yes         no        no                         Stoermer-Verlet, drift-kick-drift
``whfast``     yes         no        no                         Wisdom & Holman 1991; Rein & Tamayo 2015
``ias15``      no          yes       yes                        Everhart 1985; Rein & Spiegel 2015
=============  ==========  ========  =========================  =====================================

WHFast splits the Hamiltonian in one of two coordinate systems (``Simulation(...,
coordinates=...)``): ``"jacobi"`` (the default; Wisdom & Holman 1991) or
``"democratic_heliocentric"`` (heliocentric positions, barycentric velocities; Duncan, Levison &
Lee 1998; REBOUND's spelling ``"democraticheliocentric"`` is accepted). See docs/nbody.md.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

import numpy as np

from ..errors import InvalidInputError

__all__ = ["Integrator", "INTEGRATORS", "get_integrator", "COORDINATES", "parse_coordinates",
           "few_bodies"]

#: Coordinate systems of the Wisdom-Holman splitting -> ``istate[I_WH_COORDINATES]``.
COORDINATES = {"jacobi": 0, "democratic_heliocentric": 1}
#: Other accepted spellings (REBOUND's first).
_COORDINATE_ALIASES = {"democraticheliocentric": "democratic_heliocentric"}


@dataclass(frozen=True)
class Integrator:
    """One integrator: its compiled kernel and its capabilities.

    Attributes
    ----------
    name : str
        Registry key.
    module, kernel_name : str
        Where the compiled ``run`` kernel lives.
    symplectic : bool
        Conserves a shadow Hamiltonian: bounded energy error, no secular drift.
    adaptive : bool
        Chooses its own step size (``dt`` is only the first guess).
    velocity_dependent_forces : bool
        Accepts additional forces that depend on the velocities.
    time_reversible : bool
        Stepping forward then backward returns home to round-off.
    needs_dt : bool
        A step size must be given.
    order : int
        Order of accuracy.
    coordinates : tuple of str
        The coordinate systems its splitting can use (keys of :data:`COORDINATES`), the default
        first; empty when the integrator has no such choice.
    """

    name: str
    module: str
    kernel_name: str
    symplectic: bool
    adaptive: bool
    velocity_dependent_forces: bool
    time_reversible: bool
    needs_dt: bool
    order: int
    description: str = ""
    coordinates: tuple = ()

    @property
    def core(self):
        return importlib.import_module(self.module)

    @property
    def n_buf(self) -> int:
        return int(self.core.N_BUF)

    def kernel(self, few: bool = False, istate=None, fstate=None):
        """The compiled kernel (compiled or loaded from numba's cache on first use).

        ``few``: the variant ``<kernel_name>_few`` compiled with the serial few-body gravity
        alone (:data:`visviva.core.gravity.FEW`), valid when :func:`few_bodies` says so: the
        same bits, and a fraction of the compile time on a fresh install. Given the run's
        ``istate`` and ``fstate``, an integrator whose module has ``is_plain`` (WHFast) takes
        ``<kernel_name>_plain`` when that says so: the few-body kernel for the default case
        alone (no other coordinates, corrector or events compiled); one whose module has
        ``is_megno`` takes ``<kernel_name>_megno`` for a MEGNO run it covers: the few-body
        kernel with the tangent vector and without the paths MEGNO refuses (events, WHFast's
        corrector and democratic heliocentric coordinates), the same bits.
        """
        name = self.variant(few, istate, fstate)
        return compiled_kernel(self.module, name)

    def variant(self, few: bool = False, istate=None, fstate=None) -> str:
        """The name of the kernel :meth:`kernel` returns for these arguments."""
        plain = getattr(self.core, "is_plain", None)
        if few and istate is not None and plain is not None and plain(istate, fstate):
            return self.kernel_name + "_plain"
        megno = getattr(self.core, "is_megno", None)
        if few and istate is not None and megno is not None and megno(istate, fstate):
            return self.kernel_name + "_megno"
        if few:
            return self.kernel_name + "_few"
        return self.kernel_name

    def pack_variant(self, few: bool, istate, fstate) -> str:
        """The name of the kernel a packed ensemble call runs for members with the stacked
        ``istate``/``fstate`` rows (shapes (M, N_ISTATE), (M, N_FSTATE)): the MEGNO kernel when
        ``is_megno`` covers every member (the kernel their lone runs take, and the one
        ``visviva warmup`` compiles), else :meth:`variant` without the state (a pack of plain
        members keeps the few-body kernel)."""
        megno = getattr(self.core, "is_megno", None)
        if few and megno is not None and bool(np.all(megno(istate, fstate))):
            return self.kernel_name + "_megno"
        return self.variant(few)

    def pack_kernel(self, few: bool, istate, fstate):
        """The compiled kernel :meth:`pack_variant` names."""
        return compiled_kernel(self.module, self.pack_variant(few, istate, fstate))


def few_bodies(istate, massive) -> bool:
    """True when a run may use an integrator's few-body kernel (``Integrator.kernel(few=True)``):
    gravity on one thread (``istate[I_PARALLEL] == 0``) and fewer than
    :data:`visviva.core.gravity.PAIR_MIN_N` massive particles (a run never adds particles)."""
    from ..core.gravity import PAIR_MIN_N
    from ..core.nbody_common import I_PARALLEL

    return int(istate[I_PARALLEL]) == 0 and len(massive) < PAIR_MIN_N


_CACHE: dict = {}


def compiled_kernel(module: str, name: str, signature=None):
    """The kernel ``module.name`` compiled for ``signature`` (default: the integrators' common
    :data:`~visviva.core.nbody_common.RUN_SIGNATURE`), once per process (numba's thread pool is
    started by the kernel's own compile, ``visviva.core._jit._threads_up``)."""
    key = (module, name)
    if key not in _CACHE:
        from ..core.nbody_common import RUN_SIGNATURE

        fn = getattr(importlib.import_module(module), name)
        # One signature with the force as a first-class function type: one machine code for
        # every user force (cached on disk), the force is called through a function pointer.
        fn.compile(RUN_SIGNATURE if signature is None else signature)
        fn.disable_compile()
        _CACHE[key] = fn
    return _CACHE[key]


INTEGRATORS: dict[str, Integrator] = {
    "leapfrog": Integrator(
        "leapfrog", "visviva.core.nbody_leapfrog", "leapfrog_run",
        symplectic=True, adaptive=False, velocity_dependent_forces=False, time_reversible=True,
        needs_dt=True, order=2, description="drift-kick-drift Stoermer-Verlet",
    ),
    "ias15": Integrator(
        "ias15", "visviva.core.nbody_ias15", "ias15_run",
        symplectic=False, adaptive=True, velocity_dependent_forces=True, time_reversible=False,
        needs_dt=False, order=15, description="15th-order Gauss-Radau, adaptive (Rein & Spiegel 2015; PRS23 step control)",
    ),
    "whfast": Integrator(
        "whfast", "visviva.core.nbody_whfast", "whfast_run",
        symplectic=True, adaptive=False, velocity_dependent_forces=False, time_reversible=True,
        needs_dt=True, order=2,
        description="Wisdom-Holman in Jacobi or democratic heliocentric coordinates, "
        "universal-variable Kepler drift",
        coordinates=("jacobi", "democratic_heliocentric"),
    ),
}


def get_integrator(name: str) -> Integrator:
    """Look up an integrator by name (case-insensitive)."""
    key = str(name).lower()
    if key not in INTEGRATORS:
        raise InvalidInputError(
            f"unknown integrator {name!r}; choose one of {sorted(INTEGRATORS)}."
        )
    return INTEGRATORS[key]


def parse_coordinates(name: str, integrator: Integrator) -> str:
    """The canonical name of the coordinate system ``name`` (case-insensitive; aliases such as
    REBOUND's ``"democraticheliocentric"`` accepted), checked against ``integrator``."""
    key = str(name).lower()
    key = _COORDINATE_ALIASES.get(key, key)
    allowed = integrator.coordinates or ("jacobi",)
    if key not in allowed:
        if not integrator.coordinates:
            raise InvalidInputError(
                f"coordinates={name!r}: the {integrator.name!r} integrator has no choice of "
                "coordinates (only WHFast does); leave coordinates at 'jacobi' or use "
                "integrator='whfast'."
            )
        raise InvalidInputError(
            f"unknown coordinates {name!r} for {integrator.name!r}; choose one of "
            f"{list(allowed)} (REBOUND's 'democraticheliocentric' is accepted too)."
        )
    return key
