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
  so the result equals the untiled sum bit for bit; :data:`accelerations_split` is the same
  kernel on IAS15's two-part positions ``x + xlo`` and :func:`tight_pairs` the test that
  selects it (see :mod:`visviva.nbody.gpu_ias15`); :data:`accelerations_rsqrt` the same tiles
  with each pull from a reciprocal square root (fewer fp64 instructions, not the same bits:
  measured beside the default by the benchmarks: 1.7x faster on an H200; used by no
  simulation yet);
* :func:`drift`, :func:`kick_drift` - the two halves of a leapfrog step around it, one thread per
  particle (``x += v h/2``; ``v += a h``, ``x += v h/2``, in the CPU kernel's order);
* :func:`ensemble_leapfrog` - one thread per member of an ensemble: ``nsteps[k]`` full steps of
  the member's internal state, then its output state, with a last shortened step ``rem[k]`` when
  an output time lies between grid points (as :func:`visviva.core.nbody_leapfrog.leapfrog_run`);
  :func:`leapfrog_kernel` builds it for members with an additional force (compiled for the
  device: :mod:`visviva.nbody.gpu_forces`); a member with collision, encounter or escape checks
  runs the CPU kernel's check after every step (:func:`visviva.core.nbody_common.check_events`
  compiled for the device) and stops where it fires, as the CPU kernel stops.

fp64 throughout.
"""

from __future__ import annotations

import math

import numpy as np
from numba import cuda, float64, uint32

from ..gravity import no_force
from ..nbody_common import F_DT, F_ENCOUNTER, F_EXIT, F_T0, I_COLLISIONS, I_K, check_events
from ..status import OK
from . import arith, simulator
from .twins import device_twin

__all__ = ["accelerations", "accelerations_split", "accelerations_rsqrt", "tight_pairs", "drift",
           "kick_drift", "ensemble_leapfrog", "leapfrog_kernel", "propagate_many", "on_device",
           "member_dkd", "THREADS"]

#: Threads per block of every kernel (and the tile length of the direct sum): 128 on a GPU; 16
#: under numba's CUDA simulator, which runs every thread of a block as a Python thread (a launch
#: costs about 0.4 s at 128, 0.08 s at 16) and so covers several blocks and tiles at small N.
THREADS = 16 if simulator() else 128

_device = cuda.jit(device=True)
_pair = _device(arith.pair_acceleration)
_particle = _device(arith.rebind(arith.particle_acceleration, _pair=_pair))
_member_acc = _device(arith.rebind(arith.member_accelerations, _particle=_particle))
#: one leapfrog drift-kick-drift step of one member (the ensemble kernels, global and resident)
member_dkd = _device(arith.rebind(arith.member_dkd, _member_acc=_member_acc))
#: the CPU kernels' collision, encounter and escape check, compiled for the device
_check_events = device_twin(check_events)


def _rsqrt():
    """``1 / sqrt(x)`` on the device: libdevice's ``rsqrt`` on a GPU (the hardware's approximate
    reciprocal square root refined in fp64, within 1 ulp); under the simulator, where device code
    runs as Python, ``1 / math.sqrt(x)`` (``inf`` at 0, as the device's)."""
    if simulator():
        return _device(lambda r2: 1.0 / math.sqrt(r2) if r2 > 0.0 else math.inf)
    from numba.cuda import libdevice

    return libdevice.rsqrt


_inv_sqrt = _rsqrt()


@_device
def _pair_rsqrt(dx, dy, dz, gm, soft2):
    """:func:`.arith.pair_acceleration` with ``G m / r**3`` formed as ``G m (1/sqrt(r2))**3``:
    one reciprocal square root instead of a square root and a division, and a select instead
    of a branch for ``r2 == 0`` (the pull of the particle itself is 0). In the sm_90 machine
    code of the tiled kernel: 19 fp64 and 49 instructions per pair instead of 31 and 83; each
    pull within a few ulp of the exact form, not its bits."""
    r2 = dx * dx + dy * dy + dz * dz + soft2
    y = _inv_sqrt(r2)
    s = gm * (y * y * y) if r2 > 0.0 else 0.0
    return dx * s, dy * s, dz * s


def _tiled(split, pair=_pair):
    """The tiled direct-sum kernel; ``split``: the positions are given in two parts; ``pair``:
    the device function of one pull."""

    def accelerations(x, xlo, gm, massive, soft2, acc):
        tx = cuda.shared.array(THREADS, float64)
        ty = cuda.shared.array(THREADS, float64)
        tz = cuda.shared.array(THREADS, float64)
        tg = cuda.shared.array(THREADS, float64)
        lx = cuda.shared.array(THREADS, float64)
        ly = cuda.shared.array(THREADS, float64)
        lz = cuda.shared.array(THREADS, float64)
        i = cuda.grid(1)
        lane = cuda.threadIdx.x
        mine = i < x.shape[0]
        n_massive = massive.shape[0]
        xi = yi = zi = 0.0
        lxi = lyi = lzi = 0.0
        if mine:
            xi = x[i, 0]
            yi = x[i, 1]
            zi = x[i, 2]
            if split:
                lxi = xlo[i, 0]
                lyi = xlo[i, 1]
                lzi = xlo[i, 2]
        ax = ay = az = 0.0
        for base in range(0, n_massive, THREADS):
            b = base + lane
            if b < n_massive:  # every thread of the block loads one member of the tile
                j = massive[b]
                tx[lane] = x[j, 0]
                ty[lane] = x[j, 1]
                tz[lane] = x[j, 2]
                tg[lane] = gm[j]
                if split:
                    lx[lane] = xlo[j, 0]
                    ly[lane] = xlo[j, 1]
                    lz[lane] = xlo[j, 2]
            cuda.syncthreads()
            if mine:
                for kk in range(min(THREADS, n_massive - base)):
                    k = uint32(kk)  # unsigned: no wrap-around test for negative indices
                    dx = tx[k] - xi
                    dy = ty[k] - yi
                    dz = tz[k] - zi
                    if split:  # (x_j - x_i) + (lo_j - lo_i), as gravity_split forms it
                        dx += lx[k] - lxi
                        dy += ly[k] - lyi
                        dz += lz[k] - lzi
                    px, py, pz = pair(dx, dy, dz, tg[k], soft2)
                    ax += px
                    ay += py
                    az += pz
            cuda.syncthreads()  # the tile is read by all before the next one overwrites it
        if mine:
            acc[i, 0] = ax
            acc[i, 1] = ay
            acc[i, 2] = az

    return cuda.jit(accelerations)


#: ``accelerations[blocks, THREADS](x, xlo, gm, massive, soft2, acc)``: ``acc[i]`` from every
#: massive particle, one thread per particle (one system), the massive particles streamed
#: through shared memory in tiles of :data:`THREADS` (``xlo`` is not read: pass ``x``).
accelerations = _tiled(False)
#: The same on two-part positions ``x + xlo`` (IAS15's compensated state): the separations are
#: ``(x_j - x_i) + (xlo_j - xlo_i)``, as :func:`visviva.core.gravity_split.gravity_split` forms
#: them, so a tight pair far from the origin keeps its relative precision.
accelerations_split = _tiled(True)
#: :data:`accelerations` with each pull from a reciprocal square root (:func:`_pair_rsqrt`):
#: fewer fp64 instructions, results within a few ulp of :data:`accelerations` instead of its
#: bits. Measured beside it by ``benchmarks/bench_gpu.py`` (section ``direct``): 1.67-1.70x
#: faster on an H200 at N = 10^5 and 10^6, within 2.8e-16 of it (2026-11-26); simulations
#: switch to it once their real-GPU checks have run with it.
accelerations_rsqrt = _tiled(False, _pair_rsqrt)


@cuda.jit
def tight_pairs(x, massive, k2, flags):
    """``flags[i] = 1`` when particle ``i`` and a massive particle ``j != i`` are closer than
    ``1 / sqrt(k2)`` of the larger of their distances from the origin, else 0 (the test of
    :mod:`visviva.core.nbody_ias15` that switches a step to two-part positions)."""
    i = cuda.grid(1)
    if i < x.shape[0]:
        xi = x[i, 0]
        yi = x[i, 1]
        zi = x[i, 2]
        ri2 = xi * xi + yi * yi + zi * zi
        flag = 0
        for b in range(massive.shape[0]):
            j = massive[b]
            if j != i:
                dx = x[j, 0] - xi
                dy = x[j, 1] - yi
                dz = x[j, 2] - zi
                rj2 = x[j, 0] * x[j, 0] + x[j, 1] * x[j, 1] + x[j, 2] * x[j, 2]
                if max(ri2, rj2) > k2 * (dx * dx + dy * dy + dz * dz):
                    flag = 1
                    break
        flags[i] = flag


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


def leapfrog_kernel(force):
    """The kernel :func:`ensemble_leapfrog` whose members add the additional force ``force`` (a
    device function of the signature of :data:`visviva.core.nbody_common.FORCE_SIGNATURE`)."""

    @cuda.jit
    def ensemble_leapfrog(xi, vi, x, v, m, gm, massive, moff, poff, soft2, acc, nsteps, h, rem,
                          radius, fstate, istate, params, qoff, done, status):
        """Member ``k`` (one thread): ``nsteps[k]`` steps ``h[k]`` of ``xi, vi``, copy to
        ``x, v``, then one step ``rem[k]`` of ``x, v`` when it is not 0.

        Each step starts from the member's grid time ``t0 + k |dt|`` (``fstate[k]``,
        ``istate[k]``; the force is evaluated at its middle, with the member's parameters
        ``params[qoff[k]:qoff[k + 1]]``). With the member's collision, encounter or escape
        checks on (``istate[k]``, ``fstate[k]``, ``radius``) every step is followed by the CPU
        kernel's check (:func:`visviva.core.nbody_common.check_events`, compiled for the
        device); a check that fires stops the member there, as
        :func:`visviva.core.nbody_leapfrog.leapfrog_run` stops: its internal state copied to
        ``x, v``, the particles in ``istate[k, I_EVENT_A/B]``, no output step. ``done[k]`` is
        the number of steps taken, ``status[k]`` the status code.
        """
        k = cuda.grid(1)
        if k < nsteps.shape[0]:
            lo = poff[k]
            hi = poff[k + 1]
            fs = fstate[k]
            ist = istate[k]
            p = params[qoff[k]:qoff[k + 1]]
            events = ist[I_COLLISIONS] != 0 or fs[F_ENCOUNTER] > 0.0 or fs[F_EXIT] > 0.0
            adt = abs(fs[F_DT])
            sign = 1 if h[k] > 0.0 else -1
            status[k] = OK
            done[k] = 0
            for j in range(nsteps[k]):
                t_grid = fs[F_T0] + (ist[I_K] + sign * j) * adt  # the CPU kernel's clock
                member_dkd(xi, vi, m, gm, massive, moff[k], moff[k + 1], lo, hi, soft2[k], acc,
                            t_grid, h[k], force, p)
                done[k] += 1
                if events:
                    st = _check_events(xi[lo:hi], vi[lo:hi], radius[lo:hi], fs, ist)
                    if st != OK:
                        status[k] = st
                        break
            for i in range(lo, hi):
                for c in range(3):
                    x[i, c] = xi[i, c]
                    v[i, c] = vi[i, c]
            if rem[k] != 0.0 and status[k] == OK:
                t_grid = fs[F_T0] + (ist[I_K] + sign * done[k]) * adt
                member_dkd(x, v, m, gm, massive, moff[k], moff[k + 1], lo, hi, soft2[k], acc,
                            t_grid, rem[k], force, p)

    return ensemble_leapfrog


#: ``ensemble_leapfrog[blocks, THREADS](...)``: :func:`leapfrog_kernel` of members with gravity
#: only (the no-op force)
ensemble_leapfrog = leapfrog_kernel(device_twin(no_force))


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


def on_device(a):
    """``a`` as a numba device array when it lives on the GPU (a numba device array, or any
    object with ``__cuda_array_interface__``: used in place, no copy), else None."""
    if cuda.devicearray.is_cuda_ndarray(a):
        return a
    if hasattr(a, "__cuda_array_interface__"):
        return cuda.as_cuda_array(a)
    return None


def propagate_many(r0, v0, gm, dt, r_out, v_out, status):
    """The GPU twin of :func:`visviva.core.universal.propagate_many` (same arguments and
    outputs; the kernel is built on first use).

    Every argument may be a host numpy array or a device array (:func:`on_device`). Device
    inputs are read in place and device outputs written in place, with no host-device copy;
    host inputs are copied to the device, and host outputs filled from the device, as the call
    returns. With everything on the device the call only launches the kernel: call
    ``numba.cuda.synchronize()`` before timing or reading the results.
    """
    if not _KEPLER:
        _KEPLER.append(_kepler_kernel())
    n = r0.shape[0]
    ins = [on_device(a) for a in (r0, v0, gm, dt)]
    ins = [cuda.to_device(np.ascontiguousarray(a)) if d is None else d
           for a, d in zip((r0, v0, gm, dt), ins, strict=True)]
    outs = [(a, on_device(a)) for a in (r_out, v_out, status)]
    d_outs = [cuda.device_array(a.shape, dtype=a.dtype) if d is None else d for a, d in outs]
    _KEPLER[0][blocks(n), THREADS](*ins, *d_outs)
    for (host, d), dev in zip(outs, d_outs, strict=True):
        if d is None:
            host[:] = dev.copy_to_host()
