"""Many independent N-body systems advanced in one compiled call, in parallel over the members.

The members of an ensemble are packed one after another ("ragged": any N per member) into flat
arrays; ``poff`` (M + 1,) are the particle offsets, so member ``k`` owns particles
``poff[k] <= i < poff[k + 1]``. For each member the kernel takes C-contiguous views of its rows
and calls the integrator's own ``run`` kernel (the common signature
:data:`visviva.core.nbody_common.RUN_SIGNATURE`, passed as a first-class function), so a member
takes exactly the steps, in the same order of operations, as the same system run alone: the
results are equal bit for bit. Members run in a ``prange`` loop; each member's gravity uses the
serial kernel (``istate[k, I_PARALLEL] = 0``, which gives the same bits as the threaded one).

Array layout (``K`` = the integrator's ``N_BUF``, ``T`` output times):

``x, v`` (sum N, 3); ``m, radius`` (sum N,)
    the members' particles, member after member.
``massive`` (sum N_massive,) int64, offsets ``moff`` (M + 1,)
    each member's massive-particle indices (local to the member).
``fstate`` (M, N_FSTATE), ``istate`` (M, N_ISTATE)
    one row per member.
``buf`` (K * sum N * 3,), ``gwork`` (GWORK_ROWS * sum N,)
    the integrator's arrays and the gravity scratch, member after member (reshaped per member).
``params`` (P,), offsets ``qoff`` (M + 1,)
    the additional force's parameters of each member.
``t_out`` (T,), ``out_t`` (M, T), ``out_x``, ``out_v`` (T * sum N * 3,)
    output times (the same for every member), times reached and snapshots (member after member,
    each ``(T, N, 3)``).
``status`` (M,) int64
    each member's status code (:mod:`visviva.core.status`).
"""

from __future__ import annotations

from numba import types

from ._jit import parallel_kernel, prange
from .gravity import GWORK_ROWS
from .nbody_common import RUN_SIGNATURE

__all__ = ["ensemble_run", "ENSEMBLE_SIGNATURE", "RUN_TYPE"]

#: The type of an integrator's ``run`` kernel passed as a first-class function.
RUN_TYPE = types.FunctionType(RUN_SIGNATURE)

_f1 = types.Array(types.float64, 1, "C")
_f2 = types.Array(types.float64, 2, "C")
_i1 = types.Array(types.int64, 1, "C")
_i2 = types.Array(types.int64, 2, "C")
_FORCE = RUN_SIGNATURE.args[9]

#: Signature of :func:`ensemble_run` (compiled once, cached).
ENSEMBLE_SIGNATURE = types.void(
    RUN_TYPE, types.int64, _f2, _f2, _f1, _i1, _i1, _f1, _f2, _i2, _f1, _f1, _FORCE, _f1, _i1,
    _f1, _f2, _f1, _f1, _i1, _i1,
)


@parallel_kernel
def ensemble_run(run, n_buf, x, v, m, massive, moff, radius, fstate, istate, buf, gwork, force,
                 params, qoff, t_out, out_t, out_x, out_v, poff, status):
    """Run every member through the output times with its integrator's ``run`` kernel.

    Arguments as in the module docstring; ``n_buf`` is the integrator's ``N_BUF``. Writes each
    member's status code into ``status``.
    """
    n_members = fstate.shape[0]
    T = t_out.shape[0]
    for k in prange(n_members):
        a = poff[k]
        b = poff[k + 1]
        n = b - a
        status[k] = run(
            x[a:b], v[a:b], m[a:b], massive[moff[k]:moff[k + 1]], radius[a:b], fstate[k],
            istate[k], buf[n_buf * a * 3:n_buf * b * 3].reshape((n_buf, n, 3)),
            gwork[GWORK_ROWS * a:GWORK_ROWS * b].reshape((GWORK_ROWS, n)), force,
            params[qoff[k]:qoff[k + 1]], t_out,
            out_t[k], out_x[T * a * 3:T * b * 3].reshape((T, n, 3)),
            out_v[T * a * 3:T * b * 3].reshape((T, n, 3)),
        )
