"""WHFast with ``backend="cuda"``: the interaction step's gravity on the GPU.

For one large simulation a WHFast step costs O(N) for the Kepler drifts and the Jacobi transforms
and O(N N_massive) for the direct-sum gravity of the interaction kick. This driver runs the
WHFast map of :func:`visviva.core.nbody_whfast.whfast_run` step by step from Python: the Kepler
drifts, the Jacobi transforms and the kick use the CPU kernels of :mod:`visviva.core.nbody_whfast`
(the same compiled functions the CPU integrator is built from), and the inertial accelerations
come from the tiled direct sum on the GPU (a :class:`visviva.nbody.gpu.DeviceGravity`, handed
over by :func:`visviva.nbody.gpu.integrate_simulation`; positions go to the device and
accelerations come back once per step, 48 bytes per particle against N_massive pair
evaluations). The step grid, the internal state ``P`` kept in ``buf``
(Jacobi coordinates just after a kick), the synchronised output copy and the shortened last step
to an output time follow the CPU kernel's fast path operation for operation, so a run agrees with
the CPU backend to the round-off of the gravity sums (added in another order) and can be saved,
loaded and continued on either backend.

Supported: Jacobi coordinates without symplectic corrector (the defaults), gravity only, one
output time per call. Correctors, democratic heliocentric coordinates, additional forces and
event checks raise :class:`~visviva.errors.InvalidInputError` saying to use ``backend="cpu"``.
"""

from __future__ import annotations

import math

import numpy as np

from ..core import nbody_common as _nc
from ..core import nbody_whfast as _wh
from ..core.status import OK
from ..errors import InvalidInputError

__all__ = ["integrate_whfast", "check_supported"]

# slots of buf (see visviva.core.nbody_whfast)
_XJ, _VJ, _ACC, _AJ, _ETA, _XS, _VS = range(7)


def check_supported(istate) -> None:
    """Raise :class:`~visviva.errors.InvalidInputError` for WHFast settings (``istate``) that the
    GPU path does not run: a symplectic corrector, democratic heliocentric coordinates."""
    if istate[_nc.I_CORRECTOR] != 0 or istate[_nc.I_WH_COORDINATES] != _wh.JACOBI:
        raise InvalidInputError(
            "backend='cuda' runs WHFast in Jacobi coordinates without symplectic corrector so "
            "far: set corrector=0 and coordinates='jacobi', or use backend='cpu'."
        )


class _Stepper:
    """The pieces of a WHFast step on one simulation's arrays (Jacobi, no corrector)."""

    def __init__(self, state, gravity):
        self.x, self.v, self.m = state["x"], state["v"], state["m"]
        self.buf = buf = state["buf"]
        self.G = float(state["fstate"][_nc.F_G])
        # the cumulative masses, summed in index order as the CPU kernel sums them
        self.eta = np.cumsum(self.m)
        buf[_ETA, :, 0] = self.eta
        self.gravity = gravity

    def drift(self, xj, vj, h) -> int:
        """Every body on its Kepler orbit for ``h``; the centre of mass on a straight line."""
        return int(_wh.kepler_drift(xj, vj, self.eta, self.G, h, False))

    def kick(self, xj, vj, h) -> None:
        """Interaction kick ``h``: inertial positions, GPU gravity, Jacobi accelerations."""
        acc, aj = self.buf[_ACC], self.buf[_AJ]
        _wh.from_jacobi(xj, self.m, self.eta, self.x)
        self.gravity.host(self.x, acc)
        _wh.to_jacobi(acc, self.m, self.eta, aj)
        _wh.interaction_kick(xj, vj, aj, self.eta, self.G, h)

    def to_internal(self, xj, vj) -> None:
        _wh.to_jacobi(self.x, self.m, self.eta, xj)
        _wh.to_jacobi(self.v, self.m, self.eta, vj)

    def to_inertial(self, xj, vj) -> None:
        _wh.from_jacobi(xj, self.m, self.eta, self.x)
        _wh.from_jacobi(vj, self.m, self.eta, self.v)

    def first_half(self, xj, vj, h) -> int:
        """Internal state from the inertial ``x, v`` through the first kick of a step ``h``."""
        self.to_internal(xj, vj)
        st = self.drift(xj, vj, 0.5 * h)
        if st == OK:
            self.kick(xj, vj, h)
        return st

    def synchronise(self, half) -> int:
        """Inertial ``x, v`` from a copy of ``P`` drifted by the last half step."""
        xs, vs = self.buf[_XS], self.buf[_VS]
        xs[:] = self.buf[_XJ]
        vs[:] = self.buf[_VJ]
        st = self.drift(xs, vs, half)
        if st == OK:
            self.to_inertial(xs, vs)
        return st

    def dkd(self, h) -> int:
        """One synchronised drift-kick-drift step ``h`` of the inertial ``x, v`` (via the
        scratch slots, ``P`` untouched)."""
        xs, vs = self.buf[_XS], self.buf[_VS]
        st = self.first_half(xs, vs, h)
        if st == OK:
            st = self.drift(xs, vs, 0.5 * h)
        if st == OK:
            self.to_inertial(xs, vs)
        return st


def _advance(state, target, step: _Stepper) -> int:
    """The fast path of :func:`visviva.core.nbody_whfast.whfast_run` for one output time."""
    fstate, istate, buf = state["fstate"], state["istate"], state["buf"]
    xj, vj = buf[_XJ], buf[_VJ]
    adt = abs(float(fstate[_nc.F_DT]))
    exact = istate[_nc.I_EXACT_FINISH] != 0
    direction = 1.0 if target >= fstate[_nc.F_T] else -1.0
    h = math.copysign(adt, direction)
    sign = 1 if h > 0.0 else -1
    valid = (istate[_nc.I_WH_VALID] != 0 and istate[_nc.I_FRESH] == 0
             and fstate[_nc.F_WH_H] == h and fstate[_nc.F_DT_REF] == adt)
    istate[_nc.I_FRESH] = 0
    if not valid and target == fstate[_nc.F_T]:
        istate[_nc.I_NOUT] = 1  # an output at the current time needs no step
        return OK
    if not valid:
        fstate[_nc.F_T0] = fstate[_nc.F_T]
        fstate[_nc.F_DT_REF] = adt
        istate[_nc.I_K] = 0
        st = step.first_half(xj, vj, h)
        if st != OK:
            return st
        istate[_nc.I_K] = sign
        istate[_nc.I_STEPS] += 1
        fstate[_nc.F_WH_H] = h
        istate[_nc.I_WH_VALID] = 1
    while True:
        rem = target - (fstate[_nc.F_T0] + istate[_nc.I_K] * adt)
        if rem * direction <= 1e-9 * adt or (exact and rem * direction < adt * (1.0 - 1e-9)):
            break  # at or past the target, or less than a step to go (a copy finishes)
        st = step.drift(xj, vj, h)
        if st != OK:
            return st
        step.kick(xj, vj, h)
        istate[_nc.I_K] += sign
        istate[_nc.I_STEPS] += 1
        fstate[_nc.F_DT_LAST] = h
    t_grid = fstate[_nc.F_T0] + istate[_nc.I_K] * adt
    st = step.synchronise(0.5 * h)
    if st != OK:
        return st
    rem = target - t_grid
    if exact and abs(rem) > 1e-9 * adt:
        st = step.dkd(rem)  # a shortened step of the copy lands on the output time
        if st != OK:
            return st
    fstate[_nc.F_T] = target if exact else t_grid
    istate[_nc.I_NOUT] = 1
    return OK


def integrate_whfast(sim, state, target: float, gravity) -> None:
    """Integrate ``sim`` (WHFast, ``backend="cuda"``) to the absolute time ``target``.

    Parameters
    ----------
    sim : Simulation
        A WHFast simulation in Jacobi coordinates without corrector, gravity only, prepared by
        :func:`visviva.nbody.gpu.begin_gpu_run`.
    state : dict
        Its live arrays (:meth:`visviva.Simulation.state_arrays`).
    target : float
        Absolute time (simulation units).
    gravity : DeviceGravity
        The GPU direct sum of its particles.

    Raises
    ------
    InvalidStateError
        Non-finite positions or velocities (as on the CPU).
    """
    sim.after_kernel(_advance(state, target, _Stepper(state, gravity)))
