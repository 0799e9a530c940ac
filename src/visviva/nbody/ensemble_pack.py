"""An ensemble's members packed one after another: :class:`Pack`, the fast path of its calls.

:meth:`visviva.Ensemble.integrate` used to prepare each member as a lone run does
(:meth:`~visviva.Simulation.begin_run`, :meth:`~visviva.Simulation.kernel_inputs`,
:meth:`~visviva.Simulation.after_kernel`), concatenate the members' arrays for the compiled call
and copy the results back: about 40-80 us of Python per member and call. For small systems
(a three-body system's 100 leapfrog steps are about 5 us of arithmetic) that was nearly all of
the time, on the CPU and on the GPU alike (measured: ``docs/performance.md``).

A :class:`Pack` holds the members' arrays once, one after another (positions, velocities,
masses, radii, the integrator's internal arrays; ``fstate``/``istate`` as rows of 2-D arrays),
and each member's :class:`~visviva.nbody.state.SimulationState` then holds *views* into them
(:meth:`~visviva.nbody.state.SimulationState.adopt`). A call checks what ``begin_run`` checks on
the whole pack at once and hands the packed arrays to the same compiled ensemble kernel, with
the same layout, so the results are the bits the per-member path gives. Whatever the pack's
checks do not clear (a member without a time step, particles at the same position without
softening, a status other than OK, additional forces) goes the per-member way, which also
raises the exceptions; the ensemble then drops the pack and builds it again at its next call.

The members are the ensemble's own (users get copies), so nothing else changes their arrays.

What depends on the layout alone (the particle and massive-particle offsets, ``n_buf``) is fixed
for a pack's life: a call that may change a member's size or arrays (a merger, a member
finished alone) marks the pack :attr:`~Pack.stale` and the ensemble builds a new one. So a pack
derives the indices of its internal slots once (:meth:`Pack.read_slot`), and when every member
has the same number of particles (:attr:`Pack.same_n`, the usual ensemble) reads and writes its
arrays as (members, N, ...) views instead of gathering them by index: the same numbers, without
the per-call index arithmetic. Values (positions, masses, settings in ``fstate``) are never
cached: every call reads them afresh.
"""

from __future__ import annotations

import numpy as np

from ..core import nbody_common as _nc
from ..core import status as _st
from ..core.gravity import GWORK_ROWS, PAIR_MIN_N, massive_indices
from .chaos import check_run, extra_slots, refuse_packed
from .step_check import MIN_STEP_REL

__all__ = ["Pack", "ensemble_kernel", "finish_member"]

#: Members of up to this many particles are checked for shared coordinates pair by pair
#: (:meth:`Pack._maybe_coincident`), larger ones by sorting each member's row.
_PAIRWISE_MAX = 8


def ensemble_kernel():
    """The compiled ensemble kernel (:func:`visviva.core.nbody_ensemble.ensemble_run`)."""
    from ..core.nbody_ensemble import ENSEMBLE_SIGNATURE
    from .integrators import compiled_kernel

    return compiled_kernel("visviva.core.nbody_ensemble", "ensemble_run", ENSEMBLE_SIGNATURE)


def finish_member(sim, code: int, t, errors: list, k: int) -> bool:
    """Act on member ``k``'s kernel status as a lone run does (:meth:`Simulation.after_kernel`;
    a resolved merger or bounce, or a pause, finishes the member alone); an exception goes to
    ``errors``. Returns True when the member's arrays may have been replaced."""
    try:
        if not sim.after_kernel(int(code)):
            sim.integrate(t)
            return True
    except Exception as exc:
        errors.append((k, exc))
    return code != _st.OK


class Pack:
    """The members' arrays, packed; the members' states view them (see the module notes).

    Build one with :meth:`build`, which returns None for members the pack does not take
    (additional forces, different units).
    """

    def __init__(self, members, n_buf: int):
        # the integrator's arrays allocated (a fresh start if they were not); the additional
        # forces' parameters as each lone run passes them, ``qoff`` their offsets
        if any(s.integrator_info.n_buf + extra_slots(s) != n_buf for s in members):
            refuse_packed(members)  # (a pack of members with and without MEGNO, or the GPU's)
        params = [s.kernel_inputs(parallel=False)[1] for s in members]
        self.params = np.ascontiguousarray(np.concatenate(params))
        self.qoff = np.concatenate([[0], np.cumsum([len(p) for p in params])]).astype(np.int64)
        states = [s.state_arrays() for s in members]
        self.members = members
        self.n_buf = n_buf
        self.stale = False
        n = np.array([len(st["m"]) for st in states], dtype=np.int64)
        #: the members' common number of particles, or 0 when they differ (ragged)
        self.same_n = int(n[0]) if bool(np.all(n == n[0])) else 0
        self._slot_at: dict = {}  # slot -> its indices into buf (ragged packs; read_slot)
        self.poff = np.concatenate([[0], np.cumsum(n)]).astype(np.int64)
        self.member_of = np.repeat(np.arange(len(members)), n)
        self.x = np.concatenate([st["x"] for st in states])
        self.v = np.concatenate([st["v"] for st in states])
        self.m = np.concatenate([st["m"] for st in states])
        self.radius = np.concatenate([st["radius"] for st in states])
        self.fstate = np.stack([st["fstate"] for st in states])
        self.istate = np.stack([st["istate"] for st in states])
        self.buf = np.concatenate([st["buf"].reshape(-1) for st in states])
        local = [massive_indices(st["m"]) for st in states]
        self.massive = np.ascontiguousarray(np.concatenate(local), dtype=np.int64)
        self.moff = np.concatenate([[0], np.cumsum([len(i) for i in local])]).astype(np.int64)
        step = 3 * n_buf
        for j, s in enumerate(members):
            lo, hi = self.poff[j], self.poff[j + 1]
            s.adopt_arrays({"x": self.x[lo:hi], "v": self.v[lo:hi], "m": self.m[lo:hi],
                            "radius": self.radius[lo:hi], "fstate": self.fstate[j],
                            "istate": self.istate[j],
                            "buf": self.buf[step * lo:step * hi].reshape(n_buf, hi - lo, 3)},
                           local[j])

    @classmethod
    def build(cls, members) -> Pack | None:
        """A pack of ``members`` (Simulations of one integrator), or None when some member has
        additional forces, the members' units differ or MEGNO is on in some members only (the
        per-member path runs those). With MEGNO on in every member, each member's ``buf`` holds
        the tangent slots too (:mod:`visviva.core.nbody_variational`)."""
        first = members[0]
        if any(s.forces or s.units != first.units or extra_slots(s) != extra_slots(first)
               for s in members):  # (MEGNO on in some members only: the per-member path)
            return None
        pack = cls(members, first.integrator_info.n_buf + extra_slots(first))
        pack.collision_off = all(s.collision == "none" for s in members)
        return pack

    def slot(self, s: int) -> np.ndarray:
        """Indices into the packed ``buf`` of slot ``s`` of every particle, shape (P, 3)
        (member j's internal arrays are ``buf`` of shape (n_buf, N_j, 3), one after another)."""
        lo = self.poff[self.member_of]
        n = np.diff(self.poff)[self.member_of]
        base = 3 * self.n_buf * lo + 3 * s * n + 3 * (np.arange(len(self.x)) - lo)
        return base[:, None] + np.arange(3)

    def _slots(self) -> np.ndarray | None:
        """``buf`` as (members, n_buf, N, 3), a view, when every member has N particles."""
        if not self.same_n:
            return None
        return self.buf.reshape(len(self.members), self.n_buf, self.same_n, 3)

    def by_member(self, packed: np.ndarray) -> np.ndarray:
        """A view of ``packed`` (one row per particle) as (members, N, ...), for a pack whose
        members all have N particles (:attr:`same_n`)."""
        return packed.reshape((len(self.members), self.same_n) + packed.shape[1:])

    def read_slot(self, s: int) -> np.ndarray:
        """Slot ``s`` of every particle's internal arrays, a new contiguous (P, 3) array (the
        rows of :meth:`slot`, read as a strided view when the members are all of one size)."""
        slots = self._slots()
        if slots is not None:
            return np.ascontiguousarray(slots[:, s]).reshape(len(self.x), 3)
        if s not in self._slot_at:
            self._slot_at[s] = self.slot(s)
        return self.buf[self._slot_at[s]]

    def write_slot(self, s: int, values: np.ndarray, members=None) -> None:
        """Set slot ``s`` of every particle to ``values`` (P, 3), or, with ``members`` (a
        boolean mask over the members), of those members' particles only."""
        slots = self._slots()
        if slots is not None:
            rows = self.by_member(values)
            if members is None:
                slots[:, s] = rows
            else:
                slots[members, s] = rows[members]
            return
        if s not in self._slot_at:
            self._slot_at[s] = self.slot(s)
        at = self._slot_at[s]
        if members is None:
            self.buf[at] = values
        else:
            rows = members[self.member_of]
            self.buf[at[rows]] = values[rows]

    def per_particle(self, column: np.ndarray) -> np.ndarray:
        """A per-member ``column`` (M,) repeated for each member's particles, (P,)."""
        if self.same_n:
            return np.repeat(column, self.same_n)
        return column[self.member_of]

    def all_finite(self) -> np.ndarray:
        """Per member: True when its positions and velocities are all finite."""
        # a finite sum means every term is finite (an infinity or NaN anywhere makes it inf or
        # NaN); only when it is not (or it overflowed) is each member looked at
        with np.errstate(over="ignore", invalid="ignore"):
            total = np.add.reduce(self.x, axis=None) + np.add.reduce(self.v, axis=None)
        if np.isfinite(total):
            return np.ones(len(self.members), dtype=bool)
        finite = np.isfinite(self.x).all(axis=1) & np.isfinite(self.v).all(axis=1)
        return np.logical_and.reduceat(finite, self.poff[:-1])

    def to_device(self, names) -> dict:
        """The packed arrays ``names`` (``"x"``, ``"fstate"``, ...) copied to the GPU, by name
        (numba device arrays; for the GPU ensemble kernels)."""
        from numba import cuda

        return {name: cuda.to_device(np.ascontiguousarray(getattr(self, name)))
                for name in names}

    def from_device(self, arrays: dict) -> None:
        """Copy the device arrays of :meth:`to_device` back into the packed arrays, in place
        (the members' states view them)."""
        for name, arr in arrays.items():
            getattr(self, name)[:] = arr.copy_to_host()

    # ---- reading ---------------------------------------------------------------------------------
    def padded(self, packed: np.ndarray) -> np.ndarray:
        """``packed`` (one row per particle) as (members, N_max, ...) with NaN past each N."""
        n = np.diff(self.poff)
        out = np.full((len(n), int(n.max())) + packed.shape[1:], np.nan)
        out[self.member_of, np.arange(len(packed)) - self.poff[self.member_of]] = packed
        return out

    # ---- the fast path ---------------------------------------------------------------------------
    def target(self, t) -> float | None:
        """The output time in simulation units when every member can start a run to it as
        :meth:`visviva.Simulation.begin_run` would let it, else None (nothing changed then)."""
        first = self.members[0]
        try:
            target = float(first.begin_run(t)[0])  # converts t and checks member 0
        except Exception:
            return None  # the per-member path raises it, for the right member
        if extra_slots(first):
            # MEGNO's settings are each member's own (WHFast's coordinates, corrector, events):
            # a member whose tangent map is missing must raise, not run without it
            try:
                for s in self.members[1:]:
                    check_run(s)
            except Exception:
                return None
        info = first.integrator_info
        dt = self.fstate[:, _nc.F_DT]
        if (info.needs_dt or info.adaptive) and not np.all(dt != 0.0):
            return None
        t0 = self.fstate[:, _nc.F_T]
        scale = np.maximum(np.maximum(np.abs(t0), abs(target)), np.abs(target - t0))
        if info.needs_dt and np.any(np.abs(dt) < MIN_STEP_REL * scale):
            return None  # a step too short to finish (step_check): the member is named there
        if info.name == "whfast" and not np.all(self.m[self.poff[:-1]] > 0.0):
            return None
        if self._maybe_coincident():
            return None
        self.istate[:, _nc.I_NOUT] = 0
        self.istate[:, _nc.I_PARALLEL] = 0
        self.istate[:, _nc.I_VELOCITY_DEPENDENT] = 0
        return target

    def _maybe_coincident(self) -> bool:
        """True when two particles of one unsoftened member share their first coordinate (the
        per-member check then decides: :func:`visviva.nbody.events.check_not_coincident`)."""
        hard_member = self.fstate[:, _nc.F_SOFT2] <= 0.0
        if not hard_member.any():
            return False
        if self.same_n:  # every pair of each member's particles compared, or its sorted row
            x0 = self.by_member(self.x)[:, :, 0]
            if not hard_member.all():
                x0 = x0[hard_member]
            N = self.same_n
            if N <= _PAIRWISE_MAX:
                return any(bool(np.any(x0[:, i] == x0[:, j]))
                           for i in range(N) for j in range(i + 1, N))
            row = np.sort(x0, axis=1)
            return bool(np.any(row[:, 1:] == row[:, :-1]))
        hard = hard_member[self.member_of]
        owner, x0 = self.member_of[hard], self.x[hard, 0]
        order = np.lexsort((x0, owner))
        owner, x0 = owner[order], x0[order]
        return bool(np.any((owner[1:] == owner[:-1]) & (x0[1:] == x0[:-1])))

    def advance(self, t) -> list | None:
        """Advance every member to ``t`` on the CPU in one compiled call; returns
        ``[(index, exception), ...]``, or None when the per-member path must run this call.
        :attr:`stale` is True afterwards when some member's arrays may have been replaced."""
        self.stale = False
        target = self.target(t)
        if target is None:
            return None
        first = self.members[0]
        fn, _, _ = first.kernel_inputs(parallel=False)
        M, P = len(self.members), len(self.x)
        times = np.array([target])
        out_t = np.zeros((M, 1))
        out_x = np.zeros(P * 3)
        out_v = np.zeros(P * 3)
        status = np.zeros(M, dtype=np.int64)
        # no additional forces: one unused parameter per member, as each lone run passes
        params = np.zeros(M)
        qoff = np.arange(M + 1, dtype=np.int64)
        # members with few massive bodies run the few-body kernel a lone run takes (the same
        # bits; visviva.nbody.integrators.few_bodies; with MEGNO, the MEGNO kernel when it
        # covers them all), the others the every-path kernel
        few = int(np.diff(self.moff).max()) < PAIR_MIN_N
        run = first.integrator_info.pack_kernel(few, self.istate, self.fstate)
        ensemble_kernel()(
            run, self.n_buf, self.x, self.v, self.m, self.massive, self.moff, self.radius,
            self.fstate, self.istate, self.buf,
            np.zeros(GWORK_ROWS * P), fn, params, qoff, times, out_t, out_x, out_v, self.poff,
            status,
        )
        return self.finish(status, t)

    def finish(self, status: np.ndarray, t) -> list:
        """After a packed call: members with status OK and finite numbers are done; the others
        are finished (or raise) one by one as a lone run would."""
        good = self.all_finite() & (status == _st.OK)
        errors: list = []
        for k in np.flatnonzero(~good).tolist():
            self.stale |= finish_member(self.members[k], int(status[k]), t, errors, k)
        return errors
