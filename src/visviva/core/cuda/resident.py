"""Register/local-memory-resident GPU ensemble kernels: each thread keeps its member's state in
its own local arrays for a whole call.

The kernels :func:`visviva.core.cuda.kernels.ensemble_leapfrog` and
:func:`visviva.core.cuda.whfast.build` read and write the state of member ``k`` in the packed
global arrays at every step, members one after another: neighbouring threads touch addresses
``3 N`` doubles apart (uncoalesced), and an NVIDIA H200 ran the 131,072-member three-body
ensembles at under 1% of its fp64 peak (issue 16). Here each thread copies its member's rows into
``cuda.local.array((NMAX, 3), float64)`` arrays once per call, takes every step of the call on
them, and writes the state back once. Local memory is private to the thread and interleaved by
the hardware (the same local address of the 32 threads of a warp is one contiguous line), cached
in L1, and its fixed-size arrays may live in registers.

``NMAX`` must be a compile-time constant: one kernel per bucket of :data:`BUCKETS` (the smallest
bucket at least the pack's largest member, :func:`bucket`), built on first use and kept; the
loops run to each member's own ``N``, so the arrays stay in (cached) local memory. A pack whose
members all have the same ``N <= EXACT_MAX``, all massive, takes a kernel compiled for exactly
that ``N``: the compiler unrolls its loops and keeps the arrays in registers (the leapfrog's
PTX for ``N = 3`` declares no local memory). A pack with a member of more than
``BUCKETS[-1]`` particles runs the global-memory kernels (:func:`select` chooses).

The steps are the same device functions as the global-memory kernels (the leapfrog's
:func:`visviva.core.cuda.arith.member_dkd` with the no-op force; WHFast's
:func:`visviva.core.cuda.whfast.plain_member`) on the member's rows, in the same order, so the
results are the bits of the global-memory kernels (under numba's CUDA simulator: the bits of the
CPU ensemble). Covered: leapfrog members with gravity only and no collision, encounter or escape
checks; plain WHFast members (Jacobi coordinates, no corrector, no forces, no checks). Other
members run the global-memory kernels.

On an NVIDIA H200 (2026-11-27, ``tests/gpu/check_resident.py``) every case agreed with the CPU
ensemble to 1.3e-16 (relative, positions) and with the global-memory kernels bit for bit, and
the 131,072-member three-body ensembles ran 1.4x (leapfrog) and 1.1x (WHFast) faster per
1,000-step call; they are on by default since, :func:`enabled` (the environment variable
:data:`RESIDENT`, "0" for the global-memory kernels).
"""

from __future__ import annotations

import os

import numpy as np
from numba import cuda, float64, int64

from ..status import OK

__all__ = ["RESIDENT", "BUCKETS", "EXACT_MAX", "enabled", "bucket", "select", "leapfrog",
           "whfast"]

#: The environment variable that switches the resident kernels on ("1", or unset: the default,
#: on a real GPU and under numba's CUDA simulator) or off ("0", "off", "false" or "no": the
#: global-memory kernels).
RESIDENT = "VISVIVA_GPU_RESIDENT"

#: The compile-time member sizes (particles) of the resident kernels, smallest first.
BUCKETS = (4, 8, 16, 32)
#: Packs whose members all have the same number of particles, at most this many, all massive,
#: take a kernel compiled for exactly that number (:func:`select`).
EXACT_MAX = 8

_BUILT: dict = {}


def enabled() -> bool:
    """True when packed ensembles take the resident kernels (:data:`RESIDENT`)."""
    return os.environ.get(RESIDENT, "").strip().lower() not in ("0", "off", "false", "no")


def bucket(n_max: int) -> int | None:
    """The smallest of :data:`BUCKETS` that holds a member of ``n_max`` particles, or None
    (the member is larger than every bucket: the global-memory kernel runs the pack)."""
    for b in BUCKETS:
        if n_max <= b:
            return b
    return None


def select(kind: str, poff, moff):
    """The resident kernel of ``kind`` ("leapfrog" or "whfast") for a pack whose members'
    particles and massive particles start at the offsets ``poff`` and ``moff``, built on first
    use, or None (switched off: :func:`enabled`; or a member larger than every bucket).

    Members all of one size ``N <= EXACT_MAX``, every particle massive, take the kernel compiled
    for exactly ``N`` (``exact``: every loop bound known to the compiler, which unrolls the
    loops and can keep the arrays in registers); other packs the bucket of their largest member.
    """
    if not enabled():
        return None
    n = np.diff(poff)
    big = int(n.max())
    build = leapfrog if kind == "leapfrog" else whfast
    if big <= EXACT_MAX and bool(np.all(n == big)) and np.array_equal(np.diff(moff), n):
        return build(big, True)
    size = bucket(big)
    return None if size is None else build(size)


def leapfrog(nmax: int, exact: bool = False):
    """The resident leapfrog kernel for members of at most ``nmax`` particles (one of
    :data:`BUCKETS`; with ``exact``, members of exactly ``nmax`` particles, all massive), built
    once per ``(nmax, exact)``: ``kernel[blocks, THREADS](xi, vi, x, v, m, gm,
    massive, moff, poff, soft2, nsteps, h, rem)``.

    Member ``k`` (one thread): ``nsteps[k]`` drift-kick-drift steps ``h[k]`` of its internal
    state ``xi, vi`` (written back), its output state ``x, v`` the internal state then, with one
    more step ``rem[k]`` when that is not 0 (an output between grid points), as
    :func:`visviva.core.cuda.kernels.ensemble_leapfrog` for members with gravity only and no
    event checks. ``gm``: ``G m`` of every particle; ``massive``: the members' massive
    particles, indices local to the member (``moff``); ``soft2``: one per member.
    """
    key = ("leapfrog", nmax, exact)
    if key in _BUILT:
        return _BUILT[key]
    from ..gravity import no_force
    from .kernels import member_dkd
    from .twins import device_twin

    force = device_twin(no_force)

    @cuda.jit
    def ensemble_leapfrog_resident(xi, vi, x, v, m, gm, massive, moff, poff, soft2, nsteps, h,
                                   rem):
        k = cuda.grid(1)
        if k >= nsteps.shape[0]:
            return
        lo = poff[k]
        mlo = moff[k]
        if exact:  # every member has nmax particles, all massive: the loops' bounds known
            n = nm = nmax
        else:
            n = poff[k + 1] - lo
            nm = moff[k + 1] - mlo
        X = cuda.local.array((nmax, 3), float64)
        V = cuda.local.array((nmax, 3), float64)
        A = cuda.local.array((nmax, 3), float64)
        M = cuda.local.array(nmax, float64)
        GM = cuda.local.array(nmax, float64)
        MS = cuda.local.array(nmax, int64)
        for i in range(n):
            M[i] = m[lo + i]
            GM[i] = gm[lo + i]
            for c in range(3):
                X[i, c] = xi[lo + i, c]
                V[i, c] = vi[lo + i, c]
        for b in range(nm):
            MS[b] = b if exact else massive[mlo + b]
        s2 = soft2[k]
        step = h[k]
        # the no-op force ignores the time and its parameters (GM stands in for them)
        for _ in range(nsteps[k]):
            member_dkd(X, V, M, GM, MS, 0, nm, 0, n, s2, A, 0.0, step, force, GM)
        for i in range(n):
            for c in range(3):
                xi[lo + i, c] = X[i, c]
                vi[lo + i, c] = V[i, c]
        r = rem[k]
        if r != 0.0:  # the output copy's shortened step (the internal state is saved above)
            member_dkd(X, V, M, GM, MS, 0, nm, 0, n, s2, A, 0.0, r, force, GM)
        for i in range(n):
            for c in range(3):
                x[lo + i, c] = X[i, c]
                v[lo + i, c] = V[i, c]

    _BUILT[key] = ensemble_leapfrog_resident
    return ensemble_leapfrog_resident


def whfast(nmax: int, exact: bool = False):
    """The resident plain WHFast kernel for members of at most ``nmax`` particles (one of
    :data:`BUCKETS`; with ``exact``, members of exactly ``nmax`` particles, all massive), built
    once per ``(nmax, exact)``: ``kernel[blocks, THREADS](x, v, m, xj, vj,
    massive, moff, poff, G, soft2, h, mode, nsteps, rem, status)``, the arguments of
    :func:`visviva.core.cuda.whfast.build`'s kernel less its scratch arrays (each thread's
    are local). Member ``k`` runs :func:`visviva.core.cuda.whfast.plain_member` on local copies
    of its rows; ``x, v, xj, vj`` are written back whatever its status (as the global-memory
    kernel leaves them in place)."""
    key = ("whfast", nmax, exact)
    if key in _BUILT:
        return _BUILT[key]
    from .whfast import SKIP, plain_member

    member = plain_member()

    @cuda.jit
    def ensemble_whfast_resident(x, v, m, xj, vj, massive, moff, poff, G, soft2, h, mode,
                                 nsteps, rem, status):
        k = cuda.grid(1)
        if k >= mode.shape[0]:
            return
        status[k] = OK
        if mode[k] == SKIP:
            return
        lo = poff[k]
        mlo = moff[k]
        if exact:  # every member has nmax particles, all massive: the loops' bounds known
            n = nm = nmax
        else:
            n = poff[k + 1] - lo
            nm = moff[k + 1] - mlo
        X = cuda.local.array((nmax, 3), float64)
        V = cuda.local.array((nmax, 3), float64)
        XJ = cuda.local.array((nmax, 3), float64)
        VJ = cuda.local.array((nmax, 3), float64)
        XS = cuda.local.array((nmax, 3), float64)
        VS = cuda.local.array((nmax, 3), float64)
        A = cuda.local.array((nmax, 3), float64)
        AJ = cuda.local.array((nmax, 3), float64)
        M = cuda.local.array(nmax, float64)
        E = cuda.local.array(nmax, float64)
        MS = cuda.local.array(nmax, int64)
        for i in range(n):
            M[i] = m[lo + i]
            for c in range(3):
                X[i, c] = x[lo + i, c]
                V[i, c] = v[lo + i, c]
                XJ[i, c] = xj[lo + i, c]
                VJ[i, c] = vj[lo + i, c]
        for b in range(nm):
            MS[b] = b if exact else massive[mlo + b]
        status[k] = member(X[:n], V[:n], M[:n], E[:n], XJ[:n], VJ[:n], XS[:n], VS[:n], A[:n],
                           AJ[:n], MS[:nm], G[k], soft2[k], h[k], mode[k], nsteps[k], rem[k])
        for i in range(n):
            for c in range(3):
                x[lo + i, c] = X[i, c]
                v[lo + i, c] = V[i, c]
                xj[lo + i, c] = XJ[i, c]
                vj[lo + i, c] = VJ[i, c]

    _BUILT[key] = ensemble_whfast_resident
    return ensemble_whfast_resident
