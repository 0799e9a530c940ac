"""Leapfrog ensembles on the GPU: the host side of :func:`visviva.core.cuda.kernels.ensemble_leapfrog`.

The packed members (:class:`visviva.nbody.ensemble_pack.Pack`) are planned on the host with the
CPU kernel's expressions (:func:`visviva.nbody.gpu_plan.plan_many`: the step grid, the time
origin, the shortened last step of the output copy), then one GPU thread per member takes the
steps, with the members' additional force compiled for the device
(:mod:`visviva.nbody.gpu_forces`; the members of one call share their force functions, each
with its own parameters). A member with collision, encounter or escape checks is checked after
every step with the
CPU kernel's own check compiled for the device; where a check fires the member stops as
:func:`visviva.core.nbody_leapfrog.leapfrog_run` stops (its internal state is the output, the
time is its grid point, the internal state is marked invalid, the event's particles are in
``istate``), and the kernel returns the steps it took, so that the clock and counters here are
the CPU kernel's. :meth:`~visviva.nbody.ensemble_pack.Pack.finish` then finishes such a member
as the CPU ensemble does (a merger or bounce resolved and the member continued alone; a halt,
encounter or escape raised for that member); the other members run on undisturbed.

A pack of members with gravity only and no checks runs the resident kernel instead unless it is
switched off (:func:`resident_kernel`, :mod:`visviva.core.cuda.resident`: each member's state in
its thread's local arrays for the call; the same numbers; on by default since an H200 checked them).
"""

from __future__ import annotations

import numpy as np

from ..core import nbody_common as _nc
from ..core import status as _st
from .gpu_forces import kernel_for, launch
from .gpu_plan import plan_many, put

__all__ = ["run", "resident_kernel"]

# slots of the leapfrog's buf (see visviva.core.nbody_leapfrog)
_XI, _VI = 1, 2


def run(pack, target: float, t) -> list:
    """Advance the packed leapfrog members of ``pack`` to ``target`` (simulation units; ``t`` as
    the user gave it) on the GPU, one thread per member; returns ``[(index, exception), ...]``
    (members stopped by an event, or with non-finite numbers, finished as a lone run would be).
    """
    from numba import cuda

    from ..core.cuda import kernels as K

    fs, ist = pack.fstate, pack.istate
    n, h, rem, t_final, restart = plan_many(fs, ist, target)
    if restart.any():
        pack.write_slot(_XI, pack.x, restart)
        pack.write_slot(_VI, pack.v, restart)
    M = len(pack.members)
    d = {name: cuda.to_device(np.ascontiguousarray(a)) for name, a in (
        ("xi", pack.read_slot(_XI)), ("vi", pack.read_slot(_VI)), ("x", pack.x),
        ("v", pack.v))}
    resident = resident_kernel(pack)
    if resident is not None:  # gravity only, no checks: every step taken, nothing stops
        resident[K.blocks(M), K.THREADS](
            d["xi"], d["vi"], d["x"], d["v"], cuda.to_device(pack.m),
            cuda.to_device(pack.per_particle(fs[:, _nc.F_G]) * pack.m),
            cuda.to_device(pack.massive), cuda.to_device(pack.moff), cuda.to_device(pack.poff),
            cuda.to_device(np.ascontiguousarray(fs[:, _nc.F_SOFT2])), cuda.to_device(n),
            cuda.to_device(h), cuda.to_device(rem))
        done, status = n.copy(), np.full(M, _st.OK, dtype=np.int64)
    else:
        done, status = _global(pack, d, fs, n, h, rem)
    pack.write_slot(_XI, d["xi"].copy_to_host())
    pack.write_slot(_VI, d["vi"].copy_to_host())
    d["x"].copy_to_host(pack.x)  # into the packed array the members view
    d["v"].copy_to_host(pack.v)
    # the clock and counters as the CPU kernel leaves them (nbody_leapfrog._leapfrog)
    ist[:, _nc.I_K] += np.where(h > 0.0, done, -done)
    ist[:, _nc.I_STEPS] += done
    put(fs[:, _nc.F_DT_LAST], done != 0, h)
    stopped = status != _st.OK
    if stopped.any():
        at_event = fs[:, _nc.F_T0] + ist[:, _nc.I_K] * np.abs(fs[:, _nc.F_DT])
        fs[:, _nc.F_T] = np.where(stopped, at_event, t_final)
        ist[stopped, _nc.I_INT_VALID] = 0  # the caller may change the state (merge, bounce)
    else:
        fs[:, _nc.F_T] = t_final
    bad = ~pack.all_finite() & ~stopped
    if bad.any():
        status[bad] = _st.NON_FINITE  # overflow or a singular force, as the CPU kernel says
        ist[bad, _nc.I_INT_VALID] = 0
    put(ist[:, _nc.I_NOUT], status == _st.OK, 1)
    return pack.finish(status, t)


def resident_kernel(pack):
    """The resident kernel (:func:`visviva.core.cuda.resident.select`) that runs ``pack``, or
    None for the global-memory kernel: it runs members with an additional force or with
    collision, encounter or escape checks, packs with a member larger than the largest bucket,
    and every pack while the resident kernels are off."""
    from ..core.cuda import resident as R

    fs, ist = pack.fstate, pack.istate
    if pack.members[0].forces or np.any(
            (ist[:, _nc.I_COLLISIONS] != 0) | (fs[:, _nc.F_ENCOUNTER] > 0.0)
            | (fs[:, _nc.F_EXIT] > 0.0)):
        return None
    return R.select("leapfrog", pack.poff, pack.moff)


def _global(pack, d, fs, n, h, rem):
    """Launch the global-memory kernel (:func:`visviva.core.cuda.kernels.leapfrog_kernel`) on
    the device arrays ``d``; returns the steps taken and the status of every member."""
    from numba import cuda

    from ..core.cuda import kernels as K

    M = len(pack.members)
    done = cuda.device_array(M, dtype=np.int64)
    status = cuda.device_array(M, dtype=np.int64)
    gm = pack.per_particle(fs[:, _nc.F_G]) * pack.m
    massive = pack.massive + pack.poff[:-1].repeat(np.diff(pack.moff))
    first = pack.members[0]
    kernel = K.ensemble_leapfrog if not first.forces else kernel_for(
        "leapfrog", first, K.leapfrog_kernel)
    d_ist = cuda.to_device(np.ascontiguousarray(pack.istate))
    launch(kernel, first, K.blocks(M), K.THREADS,
           d["xi"], d["vi"], d["x"], d["v"], cuda.to_device(pack.m), cuda.to_device(gm),
           cuda.to_device(massive), cuda.to_device(pack.moff), cuda.to_device(pack.poff),
           cuda.to_device(np.ascontiguousarray(fs[:, _nc.F_SOFT2])),
           cuda.device_array((len(pack.x), 3)), cuda.to_device(n), cuda.to_device(h),
           cuda.to_device(rem), cuda.to_device(pack.radius), cuda.to_device(fs), d_ist,
           cuda.to_device(pack.params), cuda.to_device(pack.qoff), done, status)
    pack.istate[:] = d_ist.copy_to_host()  # the event's particles (I_EVENT_A, I_EVENT_B)
    return done.copy_to_host(), status.copy_to_host()
