"""CUDA kernels of the GPU backend (imported only when a ``backend="cuda"`` run starts).

The device functions are the source of :mod:`.arith` compiled with
``numba.cuda.jit(device=True)``; the kernels below only map threads to work:

* :func:`accelerations` - one thread per particle ``i`` of one large system (direct summation
  over the massive particles: O(N N_massive) per step, N threads), tiled through shared memory:
  the threads of a block load one tile of :data:`THREADS` massive particles (positions and
  ``G m``) into shared memory together, wait, and each adds that tile's pulls on its particle
  before the next tile is loaded (the scheme of Nyland, Harris & Prins 2007, GPU Gems 3 ch. 31),
  so every position is read from global memory once per block instead of once per thread. The
  pulls are added in the order of ``massive``, as :func:`.arith.particle_acceleration` adds them,
  so the result equals the untiled sum bit for bit;
* :func:`drift`, :func:`kick_drift` - the two halves of a leapfrog step around it, one thread per
  particle (``x += v h/2``; ``v += a h``, ``x += v h/2``, in the CPU kernel's order);
* :func:`ensemble_leapfrog` - one thread per member of an ensemble: ``nsteps[k]`` full steps of
  the member's internal state, then its output state, with a last shortened step ``rem[k]`` when
  an output time lies between grid points (as :func:`visviva.core.nbody_leapfrog.leapfrog_run`).

fp64 throughout.
"""

from __future__ import annotations

from numba import cuda, float64

from . import arith

__all__ = ["accelerations", "drift", "kick_drift", "ensemble_leapfrog", "propagate_many", "THREADS"]

#: Threads per block of every kernel.
THREADS = 128

_device = cuda.jit(device=True)
_pair = _device(arith.pair_acceleration)
_particle = _device(arith.rebind(arith.particle_acceleration, _pair=_pair))
_member_acc = _device(arith.rebind(arith.member_accelerations, _particle=_particle))
_member_dkd = _device(arith.rebind(arith.member_dkd, _member_acc=_member_acc))


@cuda.jit
def accelerations(x, gm, massive, soft2, acc):
    """``acc[i]`` from every massive particle, one thread per particle (one system), the massive
    particles streamed through shared memory in tiles of :data:`THREADS`."""
    tx = cuda.shared.array(THREADS, float64)
    ty = cuda.shared.array(THREADS, float64)
    tz = cuda.shared.array(THREADS, float64)
    tg = cuda.shared.array(THREADS, float64)
    i = cuda.grid(1)
    lane = cuda.threadIdx.x
    mine = i < x.shape[0]
    n_massive = massive.shape[0]
    xi = yi = zi = 0.0
    if mine:
        xi = x[i, 0]
        yi = x[i, 1]
        zi = x[i, 2]
    ax = ay = az = 0.0
    for base in range(0, n_massive, THREADS):
        b = base + lane
        if b < n_massive:  # every thread of the block loads one member of the tile
            j = massive[b]
            tx[lane] = x[j, 0]
            ty[lane] = x[j, 1]
            tz[lane] = x[j, 2]
            tg[lane] = gm[j]
        cuda.syncthreads()
        if mine:
            for k in range(min(THREADS, n_massive - base)):
                px, py, pz = _pair(tx[k] - xi, ty[k] - yi, tz[k] - zi, tg[k], soft2)
                ax += px
                ay += py
                az += pz
        cuda.syncthreads()  # the tile is read by all before the next one overwrites it
    if mine:
        acc[i, 0] = ax
        acc[i, 1] = ay
        acc[i, 2] = az


@cuda.jit
def drift(x, v, half):
    """``x += v half`` for every particle."""
    i = cuda.grid(1)
    if i < x.shape[0]:
        for c in range(3):
            x[i, c] += v[i, c] * half


@cuda.jit
def kick_drift(x, v, acc, h, half):
    """``v += acc h`` then ``x += v half`` for every particle."""
    i = cuda.grid(1)
    if i < x.shape[0]:
        for c in range(3):
            v[i, c] += acc[i, c] * h
            x[i, c] += v[i, c] * half


@cuda.jit
def ensemble_leapfrog(xi, vi, x, v, gm, massive, moff, poff, soft2, acc, nsteps, h, rem):
    """Member ``k`` (one thread): ``nsteps[k]`` steps ``h[k]`` of ``xi, vi``, copy to ``x, v``,
    then one step ``rem[k]`` of ``x, v`` when it is not 0."""
    k = cuda.grid(1)
    if k < nsteps.shape[0]:
        lo = poff[k]
        hi = poff[k + 1]
        for _ in range(nsteps[k]):
            _member_dkd(xi, vi, gm, massive, moff[k], moff[k + 1], lo, hi, soft2[k], acc, h[k])
        for i in range(lo, hi):
            for c in range(3):
                x[i, c] = xi[i, c]
                v[i, c] = vi[i, c]
        if rem[k] != 0.0:
            _member_dkd(x, v, gm, massive, moff[k], moff[k + 1], lo, hi, soft2[k], acc, rem[k])


def blocks(n: int) -> int:
    """Blocks of :data:`THREADS` threads that cover ``n`` items."""
    return max(1, (n + THREADS - 1) // THREADS)


# ---- batch two-body propagation ------------------------------------------------------------------
def _kepler_kernel():
    from ..universal import propagate_scalar
    from .twins import device_twin

    propagate = device_twin(propagate_scalar)

    @cuda.jit
    def propagate_many(r0, v0, gm, dt, r_out, v_out, status):
        """One thread per item: :func:`visviva.core.universal.propagate_scalar` compiled for the
        GPU from the same source (the twin of :func:`visviva.core.universal.propagate_many`)."""
        i = cuda.grid(1)
        if i < r0.shape[0]:
            st, x, y, z, vx, vy, vz = propagate(r0[i, 0], r0[i, 1], r0[i, 2], v0[i, 0],
                                                v0[i, 1], v0[i, 2], gm[i], dt[i])
            r_out[i, 0], r_out[i, 1], r_out[i, 2] = x, y, z
            v_out[i, 0], v_out[i, 1], v_out[i, 2] = vx, vy, vz
            status[i] = st

    return propagate_many


_KEPLER = []


def propagate_many(r0, v0, gm, dt, r_out, v_out, status):
    """The GPU twin of :func:`visviva.core.universal.propagate_many` on host arrays (same
    arguments and outputs; the kernel is built on first use)."""
    if not _KEPLER:
        _KEPLER.append(_kepler_kernel())
    n = r0.shape[0]
    d_r, d_v, d_s = cuda.device_array((n, 3)), cuda.device_array((n, 3)), cuda.device_array(
        n, dtype=status.dtype)
    _KEPLER[0][blocks(n), THREADS](cuda.to_device(r0), cuda.to_device(v0), cuda.to_device(gm),
                                   cuda.to_device(dt), d_r, d_v, d_s)
    r_out[:] = d_r.copy_to_host()
    v_out[:] = d_v.copy_to_host()
    status[:] = d_s.copy_to_host()
