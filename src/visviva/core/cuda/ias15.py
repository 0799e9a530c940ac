"""The GPU kernel of IAS15 ensembles: one thread per member, the CPU kernel's own step.

:func:`ensemble_ias15` runs, for every member of a packed ensemble, what
:func:`visviva.core.nbody_ias15.ias15_run_few` runs for one output time: a fresh start of the
integrator's own state when it is not valid, its natural adaptive steps towards the output time
(:func:`visviva.core.nbody_ias15._advance`: the predictor-corrector, the step control of
``adaptive_mode``, rejected steps, the compensated summation, the two-part positions of a tight
pair), and, with ``exact_finish_time``, the shortened last step of a copy of that state, which is
then restored (so output times never change the trajectory). Without ``exact_finish_time`` the
output is the state after the first step at or past the time. A member with collision,
encounter or escape checks runs the CPU kernel's check after every step and stops where it
fires, leaving its state, clock and status as the CPU kernel leaves them.

Every piece of arithmetic is the CPU kernel compiled for the device from its own source
(:func:`.twins.device_twin`); only the gravity dispatch is swapped: the CPU's few-body kernel
calls :func:`visviva.core.nbody_common.accelerations` (the few-body gravity sum, then the
additional force through its first-class function argument), the device calls the plain pair
loops :func:`visviva.core.gravity._plain_rows` and
:func:`visviva.core.gravity_split._gravity_split_few` directly, which give the bits of every
few-body gravity path below :data:`visviva.core.gravity.PAIR_MIN_N` massive particles, then the
members' additional force compiled for the device (one kernel per force:
:mod:`visviva.nbody.gpu_forces`), on the parameters each member's lone run passes. The device runs the CPU's own
``_start`` (a fresh start of an invalid state) and ``_to_output`` (one output time: the natural
steps, then the shortened copy); only the loop over output times of ``_ias15``, which allocates
its save rows, is written here, for one time (the save rows come as scratch).
Under numba's CUDA simulator the results equal the CPU ensemble's bit for bit; on a GPU the
step-size control's ``x ** (1/7)`` is libdevice's ``pow`` (within an ulp of the CPU's).
"""

from __future__ import annotations

from numba import cuda

__all__ = ["build"]


def build(force):
    """Compile (lazily, on first launch) and return the kernel :func:`ensemble_ias15` whose
    members add the additional force ``force`` (a device function of the signature of
    :data:`visviva.core.nbody_common.FORCE_SIGNATURE`; the no-op force for gravity only)."""
    from .. import gravity, gravity_split, nbody_common, nbody_variational
    from .. import nbody_ias15 as I
    from ..nbody_common import (
        F_ENCOUNTER,
        F_EXIT,
        F_G,
        F_SOFT2,
        F_T_INT,
        I_COLLISIONS,
        I_NOUT,
    )
    from ..status import OK
    from .twins import device_twin

    plain_rows = device_twin(gravity._plain_rows)
    split_rows = device_twin(gravity_split._gravity_split_few)

    @cuda.jit(device=True)
    def accelerations(t, x, v, m, massive, fstate, gwork, unused, params, acc, parallel):
        # nbody_common.accelerations of the few-body kernel
        plain_rows(x, m, fstate[F_G], fstate[F_SOFT2], massive, acc)
        force(t, x, v, m, params, acc)

    @cuda.jit(device=True)
    def accelerations_split(t, x, xlo, v, m, massive, fstate, gwork, unused, params, acc,
                            parallel):
        # nbody_common.accelerations_split of the few-body kernel
        split_rows(x, xlo, m, fstate[F_G], fstate[F_SOFT2], massive, acc)
        force(t, x, v, m, params, acc)

    @cuda.jit(device=True)
    def megno_off(istate, buf, base):
        # the GPU backend refuses MEGNO (visviva.nbody.chaos): no tangent step is compiled
        return False

    @cuda.jit(device=True)
    def no_tangent(xi, vi, m, massive, fstate, buf, base, b_slot, a0_slot, dt):
        return

    swaps = {nbody_common.accelerations: accelerations,
             nbody_common.accelerations_split: accelerations_split,
             nbody_variational.megno_on: megno_off, nbody_variational.ias15_tangent: no_tangent}
    start = device_twin(I._start)
    to_output = device_twin(I._to_output, swaps)
    n_buf = I.N_BUF

    @cuda.jit(device=True)
    def run_one(x, v, m, massive, radius, fstate, istate, buf, params, fsave, isave, target):
        # nbody_ias15._ias15 for the one output time ``target`` (gwork and the force argument
        # are stand-ins it does not use: the gravity and the force are swapped in)
        start(x, v, fstate, istate, buf)
        direction = 1.0 if target >= fstate[F_T_INT] else -1.0  # nbody_common.run_direction
        span = abs(target - fstate[F_T_INT])
        events = istate[I_COLLISIONS] != 0 or fstate[F_ENCOUNTER] > 0.0 or fstate[F_EXIT] > 0.0
        if istate[I_NOUT] >= 1:
            return OK
        status = to_output(x, v, m, massive, radius, fstate, istate, buf, buf, 0, params,
                           target, direction, events, False, span, 0, fsave, isave)
        if status == OK:
            istate[I_NOUT] = 1
        return status

    @cuda.jit
    def ensemble_ias15(x, v, m, massive, moff, poff, radius, fstate, istate, buf, params, qoff,
                       fsave, isave, target, status):
        """Member ``k`` (one thread) to the output time ``target``; ``status[k]`` its code.

        ``x, v`` (one row per particle, member after member: ``poff``), ``m``, ``radius``;
        ``massive`` local indices (``moff``); ``fstate, istate`` one row per member, ``fsave,
        isave`` scratch of their shapes; ``buf`` the members' ``(N_BUF, N_k, 3)`` arrays one
        after another, flat; ``params`` the force's parameters of every member (``qoff``). A
        member with collision, encounter or escape checks stops where one fires, as the CPU
        kernel stops (the status code, the particles in ``istate``).
        """
        k = cuda.grid(1)
        if k >= fstate.shape[0]:
            return
        lo = poff[k]
        hi = poff[k + 1]
        member_buf = buf[3 * n_buf * lo:3 * n_buf * hi].reshape((n_buf, hi - lo, 3))
        status[k] = run_one(x[lo:hi], v[lo:hi], m[lo:hi], massive[moff[k]:moff[k + 1]],
                            radius[lo:hi], fstate[k], istate[k], member_buf,
                            params[qoff[k]:qoff[k + 1]], fsave[k], isave[k], target)

    return ensemble_ias15
