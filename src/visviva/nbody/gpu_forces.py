"""Additional forces in GPU ensembles: the members' force functions compiled for the device.

A lone run hands its integrator kernel the fused force
(:func:`visviva.nbody.forces.combine` of its forces' compiled functions) and its parameters;
the CPU ensemble calls its kernel once per group of members whose forces are the same
functions, each member with its own parameters. The GPU ensembles (leapfrog, IAS15 and WHFast:
``kernel_for("leapfrog" | "ias15" | "whfast", ...)``) do the same: the members of
one call share their forces' functions (:func:`visviva.nbody.forces.force_key`), and :func:`device_force` compiles
each function's own source for the device (:func:`visviva.core.cuda.twins.device_twin`: a
user's ``numba.njit`` function as well as the built-in :class:`~visviva.nbody.forces.J2Force`,
:class:`~visviva.nbody.forces.GeneralRelativity`,
:class:`~visviva.nbody.forces.GeneralRelativityPotential` and
:class:`~visviva.nbody.forces.LinearDrag`), fused by the same :func:`~visviva.nbody.forces.combine`
with ``numba.cuda.jit(device=True)``. Each member's parameters are those its lone run passes
(:meth:`visviva.Simulation.kernel_inputs`), so each member adds the same numbers in the same
order as it would alone.

A force whose source numba-cuda cannot compile raises
:class:`~visviva.errors.InvalidInputError` when the ensemble's kernel is built, saying to use
``backend="cpu"``.
"""

from __future__ import annotations

from ..errors import InvalidInputError
from .forces import force_key

__all__ = ["device_force", "kernel_for", "launch"]

#: force key -> (the forces' functions, kept alive so that their ids stay theirs; the kernel)
_KERNELS: dict = {}


def device_force(sim):
    """``sim``'s fused force compiled for the device (the no-op force without forces)."""
    from numba import cuda

    from ..core.cuda.twins import device_twin
    from ..core.gravity import no_force
    from .forces import combine

    if not sim.forces:
        return device_twin(no_force)
    sizes = [len(f.parameters(sim)) for f in sim.forces]
    return combine([device_twin(f.fn) for f in sim.forces], sizes, cuda.jit(device=True))


def kernel_for(name: str, sim, build):
    """The GPU ensemble kernel ``name`` for members with ``sim``'s forces, built once per force
    key with ``build(device_force)``."""
    key = (name, force_key(sim))
    if key not in _KERNELS:
        _KERNELS[key] = ([f.fn for f in sim.forces], build(device_force(sim)))
    return _KERNELS[key][1]


def launch(kernel, sim, grid, threads, *args) -> None:
    """Launch ``kernel[grid, threads](*args)``; a force the device cannot compile raises
    :class:`~visviva.errors.InvalidInputError` naming it."""
    from numba.core.errors import NumbaError

    try:
        kernel[grid, threads](*args)
    except NumbaError as exc:
        if not sim.forces:
            raise
        names = ", ".join(f.name for f in sim.forces)
        raise InvalidInputError(
            f"the additional force(s) {names} do not compile for the GPU (numba-cuda said: "
            f"{str(exc).splitlines()[0][:300]}): use backend='cpu' for this ensemble."
        ) from exc
