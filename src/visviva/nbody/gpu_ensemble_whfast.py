"""WHFast ensembles on the GPU: the host side of :mod:`visviva.core.cuda.whfast`.

Every WHFast member runs on the GPU, one thread per member. A pack of members without
additional forces, all in the plain case of the CPU kernel
(:func:`visviva.core.nbody_whfast.is_plain`: Jacobi coordinates, no symplectic corrector, no
collisions, encounters or escape radius) runs the plain kernel: :func:`plan` decides on the
host, for all members at once and with the CPU kernel's expressions, whether a member's
internal state is still valid or must be built again (the grid origin then moves to the
member's current time), how many fused steps it takes and the length of the shortened step of
its output copy; :func:`run` launches the kernel and does the CPU kernel's bookkeeping (step
counter, grid index, clock: :func:`account`); unless the resident kernels are switched off
(:mod:`visviva.core.cuda.resident`: on by default) and no member of more than 32
particles, the plain kernel's resident variant runs instead (the same numbers). Any other pack (democratic heliocentric
coordinates, a corrector, event checks, additional forces, in any mix) runs
:func:`run_general`: the CPU kernel's whole run body on the device, on the members' whole
state, bookkeeping included, with the members' force compiled for the device (the members of
one pack share their force functions; one kernel per set of them,
:mod:`visviva.nbody.gpu_forces`) on the parameters each member's lone run passes; members whose
check fired are finished by :meth:`visviva.nbody.ensemble_pack.Pack.finish` as in the CPU
ensemble. Either way the step grid, the time origin and the saved internal state are the CPU
kernel's: a GPU run can be saved and continued on the CPU, and agrees with the CPU ensemble to
round-off (bit for bit under the simulator).

Democratic heliocentric members were refused on real GPUs from 2026-11-26 to 2026-11-28: the
general kernel sliced the members' (P, 3) positions and velocities as ``x[lo:hi]`` and gave
wrong numbers for them on an NVIDIA H200 (0.67 relative after one step) while right for Jacobi
members; it now takes them flat, as it takes ``buf`` (:func:`visviva.core.cuda.whfast.build_general`),
and agrees with the CPU ensemble to 4e-17 there (``tests/gpu/check_whfast_general.py``).
"""

from __future__ import annotations

import numpy as np

from ..core import nbody_common as _nc
from ..core import nbody_whfast as _wh
from ..core import status as _st
from .gpu_forces import kernel_for, launch
from .gpu_plan import count_steps, put

__all__ = ["plan", "account", "run", "run_general"]

_KERNEL: list = []


def plan(fstate, istate, target: float):
    """The work of every member (rows of ``fstate``/``istate``, updated as the CPU kernel
    updates them before its loop) for one run to ``target``.

    Returns
    -------
    mode : ndarray of int64
        :data:`visviva.core.cuda.whfast.SKIP` (an output at the current time of a member
        without a valid internal state: nothing moves), ``CONTINUE`` or ``RESTART`` (build the
        internal state from the inertial one first, which takes the first step).
    n : ndarray of int64
        Fused steps after that.
    h : ndarray of float64
        The signed step (time).
    rem : ndarray of float64
        The shortened step of the output copy (0: none).
    t_final : ndarray of float64
        The time each member reaches.
    """
    from ..core.cuda.whfast import CONTINUE, RESTART, SKIP

    adt = np.abs(fstate[:, _nc.F_DT])
    exact = istate[:, _nc.I_EXACT_FINISH] != 0
    direction = np.where(target >= fstate[:, _nc.F_T], 1.0, -1.0)
    h = np.copysign(adt, direction)
    fresh = istate[:, _nc.I_FRESH] != 0
    valid = ((istate[:, _nc.I_WH_VALID] != 0) & ~fresh
             & (fstate[:, _nc.F_WH_H] == h) & (fstate[:, _nc.F_DT_REF] == adt))
    put(istate[:, _nc.I_FRESH], fresh, 0)
    skip = ~valid & (fstate[:, _nc.F_T] == target)
    restart = ~valid & ~skip
    if restart.any():
        fstate[restart, _nc.F_T0] = fstate[restart, _nc.F_T]
        fstate[restart, _nc.F_DT_REF] = adt[restart]
        istate[restart, _nc.I_K] = np.where(h[restart] > 0.0, 1, -1)
        istate[restart, _nc.I_STEPS] += 1
        fstate[restart, _nc.F_WH_H] = h[restart]
        istate[restart, _nc.I_WH_VALID] = 1
    n, t_grid = count_steps(target, fstate[:, _nc.F_T0], istate[:, _nc.I_K], adt, direction,
                            exact)
    n[skip] = 0
    rem = target - t_grid
    rem = np.where(exact & ~skip & (np.abs(rem) > 1e-9 * adt), rem, 0.0)
    t_final = np.where(skip, fstate[:, _nc.F_T], np.where(exact, target, t_grid))
    mode = np.where(skip, SKIP, np.where(restart, RESTART, CONTINUE)).astype(np.int64)
    return mode, n, h, rem, t_final


def run(pack, target: float, t) -> list:
    """Advance the packed WHFast members of ``pack`` (:class:`visviva.nbody.ensemble_pack.Pack`)
    to ``target`` (simulation units; ``t`` as the user gave it) on the GPU, one thread per
    member; returns ``[(index, exception), ...]`` (members whose kernel failed or whose numbers
    are not finite are finished as a lone run would be)."""
    from numba import cuda

    from ..core.cuda import kernels as K
    from ..core.cuda import resident as R
    from ..core.cuda import whfast as W

    if pack.members[0].forces or not _wh.is_plain(pack.istate, pack.fstate).all():
        return run_general(pack, target, t)
    fs, ist = pack.fstate, pack.istate
    mode, n, h, rem, t_final = plan(fs, ist, target)
    P, M = len(pack.x), len(pack.members)

    def dev(a):
        return cuda.to_device(np.ascontiguousarray(a))

    d = {"x": dev(pack.x), "v": dev(pack.v), "xj": dev(pack.read_slot(_wh._XJ)),
         "vj": dev(pack.read_slot(_wh._VJ))}
    status = cuda.device_array(M, dtype=np.int64)
    shared = (dev(pack.massive), dev(pack.moff), dev(pack.poff), dev(fs[:, _nc.F_G]),
              dev(fs[:, _nc.F_SOFT2]), dev(h), dev(mode), dev(n), dev(rem), status)
    resident = R.select("whfast", pack.poff, pack.moff)
    if resident is not None:  # each thread's rows in its local memory for the call
        resident[K.blocks(M), K.THREADS](
            d["x"], d["v"], dev(pack.m), d["xj"], d["vj"], *shared)
    else:
        if not _KERNEL:
            _KERNEL.append(W.build())
        _KERNEL[0][K.blocks(M), K.THREADS](
            d["x"], d["v"], dev(pack.m), d["xj"], d["vj"],
            *(cuda.device_array((P, 3)) for _ in range(4)), cuda.device_array(P), *shared)
    d["x"].copy_to_host(pack.x)  # into the packed array the members view
    d["v"].copy_to_host(pack.v)
    pack.write_slot(_wh._XJ, d["xj"].copy_to_host())
    pack.write_slot(_wh._VJ, d["vj"].copy_to_host())
    status = status.copy_to_host()
    account(fs, ist, n, h, t_final)
    failed = status != _st.OK
    if failed.any():
        ist[failed, _nc.I_WH_VALID] = 0  # a failed member builds P again next time
    return pack.finish(status, t)


def account(fstate, istate, n, h, t_final) -> None:
    """The CPU kernel's bookkeeping after its loop, for the members' rows: grid index, step
    counter, last step, clock and output count (``n, h, t_final`` from :func:`plan`)."""
    istate[:, _nc.I_K] += np.where(h > 0.0, n, -n)
    istate[:, _nc.I_STEPS] += n
    put(fstate[:, _nc.F_DT_LAST], n != 0, h)
    fstate[:, _nc.F_T] = t_final
    istate[:, _nc.I_NOUT] = 1


def run_general(pack, target: float, t) -> list:
    """:func:`run` for members in any setting (democratic heliocentric coordinates, a
    symplectic corrector, collision, encounter and escape checks, additional forces): each GPU
    thread runs the CPU kernel's own run body (:func:`visviva.core.cuda.whfast.build_general`,
    one kernel per set of force functions: :func:`visviva.nbody.gpu_forces.kernel_for`) on the
    member's whole state and its force's parameters as its lone run passes them; the state goes
    to the device and back as the CPU kernel leaves it (clock, step counter, internal state,
    status and ``istate[I_EVENT_A/B]``); a member whose check fired is then finished by
    :meth:`~visviva.nbody.ensemble_pack.Pack.finish` as in the CPU ensemble (merged and
    continued, or its Escape/Encounter raised)."""
    from numba import cuda

    from ..core.cuda import kernels as K
    from ..core.cuda import whfast as W

    first = pack.members[0]
    kernel = kernel_for("whfast", first, W.build_general)
    M, P = len(pack.members), len(pack.x)
    state = pack.to_device(("fstate", "istate", "buf"))  # in and out
    flat = {k: cuda.to_device(getattr(pack, k).reshape(-1)) for k in ("x", "v")}  # (3P,)
    d = {**pack.to_device(("m", "massive", "moff", "radius", "poff", "params", "qoff")),
         **state, **flat}
    status = cuda.device_array(M, dtype=np.int64)
    out_x, out_v = cuda.device_array(3 * P), cuda.device_array(3 * P)  # the output snapshot
    launch(kernel, first, K.blocks(M), K.THREADS,
           *(d[k] for k in ("x", "v", "m", "massive", "moff", "radius", "poff", "fstate",
                            "istate", "buf", "params", "qoff")),
           cuda.to_device(np.array([target])), cuda.device_array((M, 1)), out_x, out_v, status)
    pack.from_device(state)
    for k, arr in flat.items():
        getattr(pack, k)[:] = arr.copy_to_host().reshape(-1, 3)
    return pack.finish(status.copy_to_host(), t)
