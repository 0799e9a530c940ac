"""WHFast with ``backend="cuda"``: the interaction step's gravity on the GPU.

For one large simulation a WHFast step costs O(N) for the Kepler drifts, the coordinate
transforms (and the symplectic corrector's extra drifts) and O(N N_massive) for the direct-sum
gravity of the interaction kick. The CPU kernel (:func:`visviva.core.nbody_whfast.whfast_run`'s
few-body and plain variants) runs every step, with the gravity from the GPU
(:mod:`visviva.nbody.gpu_force`): the step grid, the internal state ``P`` kept in ``buf``, the
synchronised output copies, the shortened last step to an output time and the correctors are
the CPU backend's, so a run agrees with it to the round-off of the gravity sums (added in
another order) and can be saved, loaded and continued on either backend.

Both coordinate systems run: in Jacobi coordinates the kernel asks for the inertial
accelerations (slot ``acc`` of ``buf``), which the GPU sum adds; in democratic heliocentric
coordinates it sums the gravity of the bodies other than the central one into ``acc`` and then
asks for the additional force in slot ``aj`` (whose barycentric mean it subtracts): the GPU sum
over ``massive[1:]`` then goes into ``acc``, and the simulation's own forces, if any, into ``aj``,
exactly the CPU kernel's arithmetic.
"""

from __future__ import annotations

from ..core import nbody_common as _nc
from ..core import nbody_whfast as _wh
from .gpu_force import DeviceGravity, GravityEvaluator

__all__ = ["evaluator", "WHFAST_SLOTS", "interacting"]

#: Slots of WHFast's ``buf`` the evaluator recognises (see :mod:`visviva.core.nbody_whfast`): the
#: inertial accelerations and the Jacobi accelerations / democratic heliocentric additional
#: force. Checked against the kernel's layout by ``tests/test_nbody_gpu.py``.
WHFAST_SLOTS = {"acc": 2, "aj": 3}


def interacting(istate, massive):
    """The massive particles whose gravity the interaction step sums: all of them in Jacobi
    coordinates, all but the central body (particle 0) in democratic heliocentric ones."""
    dh = int(istate[_nc.I_WH_COORDINATES]) == _wh.DEMOCRATIC_HELIOCENTRIC
    return massive[1:] if dh else massive


class _WHFastGravity(GravityEvaluator):
    """The kernel's gravity in Jacobi (added where asked) or democratic heliocentric (into
    ``acc`` when the additional force is asked for in ``aj``) coordinates."""

    def __init__(self, buf, gravity):
        super().__init__(buf, gravity)
        self.acc = buf[WHFAST_SLOTS["acc"]]
        self.jacobi = self.address(WHFAST_SLOTS["acc"])
        self.democratic = self.address(WHFAST_SLOTS["aj"])

    def __call__(self, x, acc) -> None:
        where = acc.ctypes.data
        if where == self.jacobi:
            self.gravity.add(x, acc)
        elif where == self.democratic:
            self.gravity.add(x, self.acc)  # the kernel zeroed acc: its own sum had no body
        else:
            raise self.unexpected("into accelerations")


def evaluator(sim, massive) -> GravityEvaluator:
    """The GPU gravity of one WHFast run of ``sim`` (prepared by
    :func:`visviva.nbody.gpu.begin_gpu_run`; ``massive``: the indices of its massive particles),
    summed over :func:`interacting`, for :func:`visviva.nbody.gpu_force.run_with_gpu_gravity`."""
    state = sim.state_arrays()
    gravity = DeviceGravity(sim.G * state["m"], interacting(state["istate"], massive),
                            state["fstate"][_nc.F_SOFT2])
    return _WHFastGravity(state["buf"], gravity)
