"""The general WHFast GPU kernel's device-twin tree compiled for the CPU (a probe, not a test).

``python tests/gpu/twin_on_cpu.py [democratic_heliocentric|jacobi]`` builds the run body of
:func:`visviva.core.cuda.whfast.build_general` with ``numba.njit`` in place of
``numba.cuda.jit`` (the same swaps: the few-body gravity rows, the no-op force) and runs it
beside the CPU's own kernel (``whfast_run_few``) on the same packed members, member by member
as the GPU's threads do, printing the largest relative position difference after each call.
On 2026-11-26 the two agreed bit for bit for democratic heliocentric members while the real
GPU's kernel was wrong: the fault lies in the GPU compile or launch, not in the shared source
(see ``tests/gpu/diagnose_whfast_general.py``).
"""

from __future__ import annotations

import os
import sys

import numba
import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from check_whfast_ensemble import member, rel  # noqa: E402

from visviva.core import _intrinsics, gravity, nbody_common  # noqa: E402
from visviva.core import nbody_whfast as W  # noqa: E402
from visviva.core.cuda import twins  # noqa: E402
from visviva.core.gravity import GWORK_ROWS, no_force  # noqa: E402
from visviva.core.nbody_common import F_G, F_SOFT2  # noqa: E402
from visviva.nbody.ensemble_pack import Pack  # noqa: E402


class _CpuJit:
    """Stands in for ``numba.cuda`` in :mod:`visviva.core.cuda.twins`: ``jit`` is ``njit``."""

    @staticmethod
    def jit(fn=None, device=False, **options):
        return numba.njit if fn is None else numba.njit(fn)


twins.cuda = _CpuJit
twins._fma = lambda: _intrinsics.fma  # the CPU's fused multiply-add
twins._numpy = lambda: np
rows = twins.device_twin(gravity._plain_rows)
force = twins.device_twin(no_force)
N_BUF = W.N_BUF


@numba.njit
def gravity_few(x, m, G, soft2, massive, acc, work, parallel):
    rows(x, m, G, soft2, massive, acc)


@numba.njit
def accelerations(t, x, v, m, massive, fstate, gwork, unused, params, acc, parallel):
    rows(x, m, fstate[F_G], fstate[F_SOFT2], massive, acc)
    force(t, x, v, m, params, acc)


run = twins.device_twin(W._whfast, {gravity.gravity: gravity_few,
                                    nbody_common.accelerations: accelerations})


@numba.njit
def twin_member(k, x, v, m, massive, moff, radius, poff, fstate, istate, buf, params, qoff,
                t_out, out_t, out_x, out_v):
    """What thread ``k`` of the GPU kernel runs (its arguments as the kernel passes them)."""
    lo, hi = poff[k], poff[k + 1]
    n, T = hi - lo, t_out.shape[0]
    X = x[lo:hi]
    return run(X, v[lo:hi], m[lo:hi], massive[moff[k]:moff[k + 1]], radius[lo:hi], fstate[k],
               istate[k], buf[3 * N_BUF * lo:3 * N_BUF * hi].reshape((N_BUF, n, 3)), X, force,
               params[qoff[k]:qoff[k + 1]], t_out, out_t[k],
               out_x[3 * T * lo:3 * T * hi].reshape((T, n, 3)),
               out_v[3 * T * lo:3 * T * hi].reshape((T, n, 3)), 0, True)


@numba.njit
def cpu_member(k, x, v, m, massive, moff, radius, poff, fstate, istate, buf, params, qoff,
               t_out, out_t, out_x, out_v):
    """The CPU ensemble's call of its own few-body kernel for member ``k``."""
    lo, hi = poff[k], poff[k + 1]
    n, T = hi - lo, t_out.shape[0]
    gwork = np.zeros(GWORK_ROWS * n).reshape((GWORK_ROWS, n))
    return W.whfast_run_few(
        x[lo:hi], v[lo:hi], m[lo:hi], massive[moff[k]:moff[k + 1]], radius[lo:hi], fstate[k],
        istate[k], buf[3 * N_BUF * lo:3 * N_BUF * hi].reshape((N_BUF, n, 3)), gwork, no_force,
        params[qoff[k]:qoff[k + 1]], t_out, out_t[k],
        out_x[3 * T * lo:3 * T * hi].reshape((T, n, 3)),
        out_v[3 * T * lo:3 * T * hi].reshape((T, n, 3)))


def positions(kernel, coordinates, times):
    members = []
    for k in range(3):
        sim = member(k)
        sim.coordinates = coordinates
        if coordinates == "jacobi":
            sim.exit_max_distance = 1e6  # the general kernel's event path, never firing
        members.append(sim)
    out = []
    for t in times:
        pack = Pack.build(members)
        target = pack.target(t)
        M, P = len(members), len(pack.x)
        buffers = np.zeros((M, 1)), np.zeros(3 * P), np.zeros(3 * P)
        status = [kernel(k, pack.x, pack.v, pack.m, pack.massive, pack.moff, pack.radius,
                         pack.poff, pack.fstate, pack.istate, pack.buf, pack.params, pack.qoff,
                         np.array([target]), *buffers) for k in range(M)]
        pack.finish(np.array(status), t)
        out.append([sim.positions.copy() for sim in members])
    return out


def main():
    coordinates = sys.argv[1] if len(sys.argv) > 1 else "democratic_heliocentric"
    times = (0.0125, 0.125)
    twin = positions(twin_member, coordinates, times)
    cpu = positions(cpu_member, coordinates, times)
    for t, a, b in zip(times, twin, cpu, strict=True):
        print(f"twin_vs_cpu_{t}={[rel(p, q) for p, q in zip(a, b, strict=True)]}")


if __name__ == "__main__":
    main()
