"""IAS15 with ``backend="cuda"``: the predictor-corrector's gravity evaluations on the GPU.

A step of IAS15 evaluates the forces at the step start and at the 7 Gauss-Radau substeps of
every predictor-corrector sweep: for one large simulation that is O(N N_massive) work each time,
while the predictor, the divided differences and the ``b``/``e`` updates, the convergence test,
the step-size control and the compensated update of the state are O(N). The CPU kernel
(:func:`visviva.core.nbody_ias15.ias15_run_few`) runs all of it, with the gravity from the GPU
(:mod:`visviva.nbody.gpu_force`): the step grid, the step control, the output copies and the
stored state are the CPU backend's, the gravity sums are added in another order (round-off).

With fewer than :data:`visviva.core.gravity.PAIR_MIN_N` massive particles the CPU kernel
evaluates a step on IAS15's two-part positions ``x + xlo`` when a particle is close to a massive
one far from the origin (see :mod:`visviva.core.nbody_ias15`). The evaluator here makes the same
decision once per step (the test on the GPU, :func:`visviva.core.cuda.kernels.tight_pairs`) and
rebuilds the same low parts from the kernel's ``buf`` (the compensated-summation terms at the
step start, Knuth's two-sum of the substep increment at the substeps), then sums on the GPU with
:data:`visviva.core.cuda.kernels.accelerations_split`: a tight binary far from the origin keeps
its relative precision as on the CPU.
"""

from __future__ import annotations

from ..core import nbody_common as _nc
from ..core.gravity import PAIR_MIN_N
from ..core.nbody_ias15 import SPLIT_RATIO
from .gpu_force import DeviceGravity, GravityEvaluator

__all__ = ["evaluator", "IAS15_SLOTS"]

#: Slots of IAS15's ``buf`` the evaluator reads (see :mod:`visviva.core.nbody_ias15`): the
#: compensated-summation terms of the positions, the predicted positions of a substep, the
#: internal positions and the position increments of a substep (``xl`` while the kernel's own
#: split is off). Checked against the kernel's layout by ``tests/test_nbody_gpu.py``.
IAS15_SLOTS = {"csx": 35, "xp": 38, "xi": 41, "xl": 75}


class _IAS15Gravity(GravityEvaluator):
    """Which call of the step this is (by the slot of ``x``), the split, the GPU sum."""

    def __init__(self, buf, gravity, n_massive: int):
        super().__init__(buf, gravity)
        self.slots = {name: buf[k] for name, k in IAS15_SLOTS.items()}
        self.starts = self.address(IAS15_SLOTS["xi"])
        self.substeps = self.address(IAS15_SLOTS["xp"])
        # the CPU kernel's test for two-part positions applies below PAIR_MIN_N massive
        self.may_split = 0 < n_massive < PAIR_MIN_N
        self.split = False

    def __call__(self, x, acc) -> None:
        s = self.slots
        where = x.ctypes.data
        if where == self.starts:  # the step start, at the internal state: decide the split
            self.split = self.may_split and self.gravity.tight(x, SPLIT_RATIO)
            lo = -s["csx"] if self.split else None
        elif where == self.substeps:  # a substep: the kernel left x + dx in xp, dx in xl
            lo = None
            if self.split:  # the rounding error of xp = dx + x, exactly (Knuth's two-sum)
                xf, xp, dx = s["xi"], s["xp"], s["xl"]
                bb = xp - xf
                lo = (xf - (xp - bb)) + (dx - bb)
        else:
            raise self.unexpected("at positions")
        self.gravity.add(x, acc, lo)


def evaluator(sim, massive) -> GravityEvaluator:
    """The GPU gravity of one IAS15 run of ``sim`` (prepared by
    :func:`visviva.nbody.gpu.begin_gpu_run`; ``massive``: the indices of its massive particles),
    for :func:`visviva.nbody.gpu_force.run_with_gpu_gravity`."""
    state = sim.state_arrays()
    gravity = DeviceGravity(sim.G * state["m"], massive, state["fstate"][_nc.F_SOFT2])
    return _IAS15Gravity(state["buf"], gravity, len(massive))
