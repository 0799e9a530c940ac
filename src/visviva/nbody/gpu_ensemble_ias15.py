"""IAS15 ensembles on the GPU: the host side of :mod:`visviva.core.cuda.ias15`.

An ensemble of IAS15 members runs one GPU thread per member through IAS15's own adaptive
steps, compiled for the device from the CPU kernel's source, with the members' additional
forces compiled for the device (one kernel per set of force functions,
:mod:`visviva.nbody.gpu_forces`) and the CPU kernel's collision, encounter and escape checks
after every step (a member stopped by one is finished
by :meth:`~visviva.nbody.ensemble_pack.Pack.finish` as the CPU ensemble finishes it: a merger
or bounce resolved and the member continued alone, a halt, encounter or escape raised). The whole state (``fstate``, ``istate`` and ``buf``: the integrator's own
positions and velocities, the compensated-summation terms, the predictor's ``b`` and ``e``) goes
to the device and back as the CPU kernel leaves it, so a GPU run can be saved and continued on
the CPU, and a member's status (a step below the floor, non-finite numbers) is finished by
:meth:`visviva.nbody.ensemble_pack.Pack.finish` as on the CPU, raising the same exception.
A member with :data:`ALONE_MIN_MASSIVE` massive particles or more runs as its own GPU
simulation instead (:func:`visviva.nbody.gpu.integrate_ensemble`), with the result of its lone
``backend="cuda"`` run.
"""

from __future__ import annotations

import numpy as np

from ..core.gravity import PAIR_MIN_N, massive_indices
from .gpu_forces import kernel_for, launch

__all__ = ["run", "runs_alone", "any_alone", "ALONE_MIN_MASSIVE"]

#: An IAS15 member with this many massive particles or more does not join the one-thread-per-
#: member kernel (one thread would sum its ``N**2`` pairs serially, and the CPU sums such a
#: member's gravity with its large-N kernel, which the device does not run): it runs as its
#: own ``Simulation(..., backend="cuda")`` run, every gravity sum tiled over the GPU
#: (:mod:`visviva.nbody.gpu_ias15`), so it gives what its lone run gives.
ALONE_MIN_MASSIVE = PAIR_MIN_N


def runs_alone(sim) -> bool:
    """True when the IAS15 member ``sim`` runs as a lone GPU simulation, not in the ensemble
    kernel (:data:`ALONE_MIN_MASSIVE` massive particles or more)."""
    return len(massive_indices(sim.state_arrays()["m"])) >= ALONE_MIN_MASSIVE


def any_alone(moff) -> bool:
    """True when a packed member (massive particles ``moff[k]:moff[k + 1]``) runs alone."""
    return bool(np.any(np.diff(moff) >= ALONE_MIN_MASSIVE))


def run(pack, target: float, t) -> list:
    """Advance the packed IAS15 members of ``pack`` (:class:`visviva.nbody.ensemble_pack.Pack`)
    to ``target`` (simulation units; ``t`` as the user gave it) on the GPU, one thread per
    member; returns ``[(index, exception), ...]`` (members whose kernel reported a status other
    than OK, or whose numbers are not finite, are finished as a lone run would be)."""
    from numba import cuda

    from ..core.cuda import ias15 as I
    from ..core.cuda import kernels as K

    kernel = kernel_for("ias15", pack.members[0], I.build)
    M = len(pack.members)
    d = pack.to_device(("x", "v", "fstate", "istate", "buf"))
    status = cuda.device_array(M, dtype=np.int64)
    launch(kernel, pack.members[0], K.blocks(M), K.THREADS,
           d["x"], d["v"], cuda.to_device(pack.m), cuda.to_device(pack.massive),
           cuda.to_device(pack.moff), cuda.to_device(pack.poff), cuda.to_device(pack.radius),
           d["fstate"], d["istate"], d["buf"], cuda.to_device(pack.params),
           cuda.to_device(pack.qoff), cuda.device_array(pack.fstate.shape),
           cuda.device_array(pack.istate.shape, dtype=np.int64), float(target), status)
    pack.from_device(d)  # in place: the members' states view these arrays
    return pack.finish(status.copy_to_host(), t)
