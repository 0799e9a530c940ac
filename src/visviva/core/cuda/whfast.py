"""The GPU kernels of WHFast ensembles: one thread per member, the CPU kernel's own functions.

:func:`build` returns :func:`ensemble_whfast`, the plain case: for every member of a packed
ensemble, what the fast path of :func:`visviva.core.nbody_whfast.whfast_run_plain` runs between
two outputs (Jacobi coordinates, no symplectic corrector, no additional force, no events):
build the internal state ``P`` when it is not valid (``_first_half``: inertial -> Jacobi, Kepler
drift ``h/2``, kick ``h``), ``nsteps`` fused steps ``P <- Kick(h) Kepler(h) P``, a synchronised
copy (Kepler ``h/2`` and back to inertial coordinates) and, for an output time between grid
points, one shortened drift-kick-drift step of the copy. The host plans the steps with the CPU
kernel's expressions (:mod:`visviva.nbody.gpu_ensemble_whfast`). The per-member body is the
device function :func:`plain_member`: the kernel calls it on slices of the packed global arrays,
:mod:`.resident` on each thread's local copies of its member's rows.

:func:`build_general` returns :func:`ensemble_whfast_general`, every other case (additional
forces included): each thread runs the CPU kernel's run body itself,
:func:`visviva.core.nbody_whfast._whfast`, compiled for the device with the member's whole
state (``fstate``, ``istate``, ``buf``), so democratic heliocentric coordinates (transforms,
jump, interaction kick), the symplectic correctors (applied when the internal state is built
and when a synchronised copy is made) and the event path (synchronised steps, then
:func:`visviva.core.nbody_common.check_events`; a member whose check fires stops there with the
CPU's state, clock, status and ``istate[I_EVENT_A/B]``) are the CPU kernel's own code, its
bookkeeping included. Only the gravity dispatch is swapped (``gravity.gravity`` and
``nbody_common.accelerations`` become the plain few-body rows, the bits of the CPU's few-body
kernels) and the additional force is the members' force compiled for the device (built once
per set of force functions by :func:`visviva.nbody.gpu_forces.kernel_for`: the run body calls
it through the CPU's first-class force argument, on each member's parameters
``params[qoff[k]:qoff[k + 1]]``; the no-op force for gravity only). The universal-variable
Kepler solver is kept out of line (:func:`.twins.never_inlined`): one copy called from the run
body's 23 drift sites (the corrector's maps and the solver's retry in power-of-two units each
go through one call site), 1.4 MB of PTX instead of 6.4 MB inlined; the first launch in a
process compiles for about 50 s on an H200 (NVVM 28 s, ptxas 22 s; once per set of force
functions; the plain kernel: 2 MB, 10 s). Its members' positions and velocities come flat
(see :func:`build_general`: sliced as (P, 3) arrays they gave wrong numbers for democratic
heliocentric members on an H200).

Every piece of arithmetic is a CPU kernel compiled for the device from its own source
(:func:`.twins.device_twin`): the Jacobi transforms, the Kepler drift (the universal-variable
solver), the interaction kick and the few-body gravity sum :func:`visviva.core.gravity._plain_rows`
(each pull summed in the order of ``massive``, the bits of the CPU's few-body kernel). Under
numba's CUDA simulator the results equal the CPU ensemble's bit for bit (the CPU kernel adds
the same numbers in the same order).
"""

from __future__ import annotations

from numba import cuda

__all__ = ["build", "build_general", "general_swaps", "plain_member"]

#: Values of the ``mode`` argument: nothing to do (an output at the current time of a member
#: without an internal state), continue the internal state, or build it first.
SKIP, CONTINUE, RESTART = 0, 1, 2


_PARTS: list = []


def plain_member():
    """The device function ``member(X, V, M, E, XJ, VJ, XS, VS, A, AJ, ms, G, soft2, h, mode,
    nsteps, rem) -> status``: one member of :func:`ensemble_whfast` through one output time, on
    the member's own rows (any arrays of ``N`` rows: slices of the packed global arrays here,
    the thread's local arrays in :mod:`.resident`), in place; ``mode`` not ``SKIP``. Built once.
    """
    if _PARTS:
        return _PARTS[0]
    from .. import gravity, nbody_whfast
    from ..status import OK
    from .twins import device_twin

    to_jacobi = device_twin(nbody_whfast.to_jacobi)
    from_jacobi = device_twin(nbody_whfast.from_jacobi)
    kepler_drift = device_twin(nbody_whfast.kepler_drift)
    interaction_kick = device_twin(nbody_whfast.interaction_kick)
    gravity_rows = device_twin(gravity._plain_rows)

    @cuda.jit(device=True)
    def from_internal(xj, vj, m, eta, x, v):
        # nbody_whfast._from_internal for Jacobi coordinates
        from_jacobi(xj, m, eta, x)
        from_jacobi(vj, m, eta, v)

    @cuda.jit(device=True)
    def kick(xj, vj, x, m, eta, G, soft2, massive, acc, aj, h):
        # nbody_whfast._kick for Jacobi coordinates without an additional force
        from_jacobi(xj, m, eta, x)
        gravity_rows(x, m, G, soft2, massive, acc)
        to_jacobi(acc, m, eta, aj)
        interaction_kick(xj, vj, aj, eta, G, h)

    @cuda.jit(device=True)
    def first_half(x, v, m, eta, G, soft2, massive, h, xj, vj, acc, aj):
        # nbody_whfast._first_half without a corrector
        to_jacobi(x, m, eta, xj)  # nbody_whfast._to_internal for Jacobi coordinates
        to_jacobi(v, m, eta, vj)
        st = kepler_drift(xj, vj, eta, G, 0.5 * h, False)
        if st != OK:
            return st
        kick(xj, vj, x, m, eta, G, soft2, massive, acc, aj, h)
        return OK

    @cuda.jit(device=True)
    def member(X, V, M, E, XJ, VJ, XS, VS, A, AJ, ms, g, s2, step, mode, nsteps, r):
        total = 0.0
        for i in range(X.shape[0]):
            total += M[i]
            E[i] = total
        if mode == RESTART:
            st = first_half(X, V, M, E, g, s2, ms, step, XJ, VJ, A, AJ)
            if st != OK:
                return st
        for _ in range(nsteps):  # the fused step of the CPU kernel's loop
            st = kepler_drift(XJ, VJ, E, g, step, False)
            if st != OK:
                return st
            kick(XJ, VJ, X, M, E, g, s2, ms, A, AJ, step)
        # nbody_whfast._synchronise: a copy of P drifted by the last half step
        for i in range(X.shape[0]):
            for c in range(3):
                XS[i, c] = XJ[i, c]
                VS[i, c] = VJ[i, c]
        st = kepler_drift(XS, VS, E, g, 0.5 * step, False)
        if st != OK:
            return st
        from_internal(XS, VS, M, E, X, V)
        if r != 0.0:  # nbody_whfast._dkd_step of the copy, without a corrector
            st = first_half(X, V, M, E, g, s2, ms, r, XS, VS, A, AJ)
            if st == OK:
                st = kepler_drift(XS, VS, E, g, 0.5 * r, False)
            if st != OK:
                return st
            from_internal(XS, VS, M, E, X, V)
        return OK

    _PARTS.append(member)
    return member


def build():
    """Compile (lazily, on first launch) and return the kernel :func:`ensemble_whfast`."""
    from ..status import OK

    member = plain_member()

    @cuda.jit
    def ensemble_whfast(x, v, m, xj, vj, xs, vs, acc, aj, eta, massive, moff, poff, G, soft2,
                        h, mode, nsteps, rem, status):
        """Member ``k`` (one thread) through one output time; ``status[k]`` its status code.

        ``x, v`` (inertial, in and out), ``xj, vj`` (the internal state), ``xs, vs, acc, aj``
        (scratch), one row per particle, member after member (``poff``); ``eta`` (scratch,
        one per particle); ``massive`` local indices (``moff``); ``G, soft2, h, rem`` and
        ``mode, nsteps`` one per member (``rem`` 0: the output is on the grid).
        """
        k = cuda.grid(1)
        if k >= mode.shape[0]:
            return
        status[k] = OK
        if mode[k] == SKIP:
            return
        lo = poff[k]
        hi = poff[k + 1]
        status[k] = member(x[lo:hi], v[lo:hi], m[lo:hi], eta[lo:hi], xj[lo:hi], vj[lo:hi],
                           xs[lo:hi], vs[lo:hi], acc[lo:hi], aj[lo:hi],
                           massive[moff[k]:moff[k + 1]], G[k], soft2[k], h[k], mode[k],
                           nsteps[k], rem[k])

    return ensemble_whfast


def general_swaps(force):
    """The helpers :func:`build_general` swaps in the CPU kernel's run body (a ``replace``
    mapping of :func:`.twins.device_twin`, the Kepler solver's twin marked never inlined):
    ``gravity.gravity`` and ``nbody_common.accelerations`` become the plain few-body rows (the
    bits of the CPU's few-body kernels), the latter adding the device force ``force``; the
    MEGNO switch becomes a constant False and the tangent steps no-ops (the GPU backend refuses
    MEGNO, :mod:`visviva.nbody.chaos`: no tangent code is compiled for the device)."""
    from .. import gravity, nbody_common, nbody_variational, nbody_wh_tangent, universal
    from ..nbody_common import F_G, F_SOFT2
    from ..status import OK
    from .twins import device_twin, never_inlined

    rows = device_twin(gravity._plain_rows)

    @cuda.jit(device=True)
    def gravity_few(x, m, G, soft2, massive, acc, work, parallel):
        # gravity.gravity of the few-body kernels (FEW): the plain rows below PAIR_MIN_N
        rows(x, m, G, soft2, massive, acc)

    @cuda.jit(device=True)
    def accelerations(t, x, v, m, massive, fstate, gwork, unused, params, acc, parallel):
        # nbody_common.accelerations of the few-body kernel
        rows(x, m, fstate[F_G], fstate[F_SOFT2], massive, acc)
        force(t, x, v, m, params, acc)

    @cuda.jit(device=True)
    def megno_off(istate, buf, base):
        return False

    @cuda.jit(device=True)
    def no_tangent(xj, vj, x, m, massive, eta, fstate, buf, base, h):
        return OK

    @cuda.jit(device=True)
    def no_tangent_start(x, v, m, eta, buf, base):
        return

    replace = {gravity.gravity: gravity_few, nbody_common.accelerations: accelerations,
               nbody_variational.megno_on: megno_off,
               nbody_wh_tangent.whfast_tangent: no_tangent,
               nbody_wh_tangent.whfast_tangent_start: no_tangent_start}
    # one copy of the Kepler solver, called from the run body's 23 drift sites
    never_inlined(device_twin(universal.propagate_scalar, replace))
    return replace


def build_general(force):
    """Compile (lazily, on first launch) and return :func:`ensemble_whfast_general`: every
    member through the CPU kernel's own run body, :func:`visviva.core.nbody_whfast._whfast`,
    compiled for the device, its members adding the additional force ``force`` (a device
    function of the signature of :data:`visviva.core.nbody_common.FORCE_SIGNATURE`; the no-op
    force for gravity only; see the module notes and :func:`general_swaps`)."""
    from .. import nbody_whfast as W
    from .twins import device_twin

    run = device_twin(W._whfast, general_swaps(force))
    n_buf = W.N_BUF

    @cuda.jit
    def ensemble_whfast_general(x, v, m, massive, moff, radius, poff, fstate, istate, buf,
                                params, qoff, t_out, out_t, out_x, out_v, status):
        """Member ``k`` (one thread) through the output times ``t_out``; ``status[k]`` its code.

        The arrays of :func:`visviva.core.nbody_ensemble.ensemble_run` (``x``, ``v``, ``buf``
        and ``out_x``, ``out_v`` flat, member after member; ``out_t`` one row per member;
        ``params`` the force's parameters of every member, ``qoff`` their offsets). The
        positions and velocities come flat and each member's are a 1-D slice reshaped to
        (n, 3): with (P, 3) arrays sliced as ``x[lo:hi]`` this kernel gave wrong numbers for
        democratic heliocentric members on an NVIDIA H200 (0.67 relative in positions after
        one step, 2026-11-28, ``tests/gpu/diagnose_dh_wrapper.py``: the same body on the same
        member's arrays, unsliced or flat-sliced, agreed with the CPU to 4e-18), while Jacobi
        members were right either way.
        """
        k = cuda.grid(1)
        if k >= fstate.shape[0]:
            return
        lo = poff[k]
        hi = poff[k + 1]
        n = hi - lo
        T = t_out.shape[0]
        X = x[3 * lo:3 * hi].reshape((n, 3))
        status[k] = run(
            X, v[3 * lo:3 * hi].reshape((n, 3)), m[lo:hi], massive[moff[k]:moff[k + 1]], radius[lo:hi], fstate[k],
            istate[k], buf[3 * n_buf * lo:3 * n_buf * hi].reshape((n_buf, n, 3)), X, force,
            params[qoff[k]:qoff[k + 1]], t_out, out_t[k],
            out_x[3 * T * lo:3 * T * hi].reshape((T, n, 3)),
            out_v[3 * T * lo:3 * T * hi].reshape((T, n, 3)), 0, True, None)

    return ensemble_whfast_general
