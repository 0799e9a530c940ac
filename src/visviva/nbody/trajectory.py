"""Snapshots of an N-body run (:class:`Trajectory`), their collection during the run
(:class:`Recording`) and the coincident-particle check.

A :class:`Trajectory` is what :meth:`visviva.Simulation.integrate` returns for an array of output
times: ``(T, N, 3)`` positions and velocities, with the energy of every snapshot on demand. A
:class:`Recording` gathers them while the run goes on, on either backend: the rows a kernel call
wrote, the particles a merger removed, the progress bar.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core import gravity as _gravity
from ..core import nbody_common as _nc
from ..errors import InvalidInputError, InvalidStateError, fmt_number
from . import step_check as _step_check

__all__ = ["Trajectory", "Recording", "coincident_pairs"]

#: Steps between two pauses of a kernel call when a progress bar is shown.
_PROGRESS_STEPS = 2000


def coincident_pairs(x, m, soft2, limit: int = 3) -> list:
    """Pairs ``(i, j)`` of particles at exactly the same position where at least one is massive
    and there is no softening (the point-mass force is infinite there); at most ``limit``."""
    if soft2 > 0 or x.shape[0] < 2:
        return []
    if np.unique(x[:, 0]).size == x.shape[0]:
        return []  # distinct first coordinates: no two coincide (the common case, ~10x faster)
    _, first, inverse = np.unique(x, axis=0, return_index=True, return_inverse=True)
    inverse = np.asarray(inverse).reshape(-1)
    pairs = []
    if len(first) == x.shape[0]:
        return pairs
    for g in np.flatnonzero(np.bincount(inverse) > 1):
        idx = np.flatnonzero(inverse == g)
        if np.count_nonzero(m[idx]) == 0:
            continue  # test particles only: they do not attract each other
        pairs.append((int(idx[0]), int(idx[1])))
        if len(pairs) >= limit:
            break
    return pairs


@dataclass
class Trajectory:
    """Snapshots returned by :meth:`Simulation.integrate` for an array of output times.

    Attributes
    ----------
    t : ndarray, shape (T,)
        Output times (simulation units).
    positions, velocities : ndarray, shape (T, N, 3)
        Snapshots (simulation units). Particles removed by a merger are NaN afterwards.
    masses : ndarray, shape (T, N)
        The mass of each particle at each snapshot (simulation units): after a merger the
        survivor's column holds the merged mass and the removed particle's column is NaN.
        Constructed from a shape (N,) array (masses that do not change), it is repeated for
        every snapshot.
    G : float
        Gravitational constant (simulation units).
    softening : float
        Plummer softening length (simulation units).
    energy_offset : ndarray, shape (T,)
        The simulation's ``energy_offset`` at each snapshot: the energy removed by mergers and
        inelastic bounces so far (simulation units); a scalar is repeated for every snapshot.
    """

    t: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    masses: np.ndarray
    G: float = 1.0
    softening: float = 0.0
    energy_offset: np.ndarray | float = 0.0

    def __post_init__(self):
        T, n = np.shape(self.positions)[:2]
        m = np.asarray(self.masses, dtype=float)
        if m.shape == (n,):
            m = np.repeat(m[None, :], T, axis=0)
        if m.shape != (T, n):
            raise InvalidInputError(
                f"Trajectory: masses has shape {m.shape}; it must be (T, N) = ({T}, {n}), one "
                f"mass per particle and snapshot, or (N,) = ({n},) for masses that do not change.")
        self.masses = m
        off = np.asarray(self.energy_offset, dtype=float)
        if off.shape not in ((), (T,)):
            raise InvalidInputError(
                f"Trajectory: energy_offset has shape {off.shape}; give a number or one value "
                f"per snapshot, shape ({T},).")
        self.energy_offset = np.array(np.broadcast_to(off, (T,)))

    def _present(self) -> np.ndarray:
        """Which particles exist at each snapshot, shape (T, N) (a removed one's mass is NaN)."""
        return ~np.isnan(self.masses)

    def energy(self, include_offset: bool = False) -> np.ndarray:
        """Total energy (kinetic plus potential) of the particles present at each snapshot,
        shape (T,) (simulation units).

        After a merger this is the energy of the merged system, as
        ``Simulation.energy(include_offset=False)`` gives it at that time. With
        ``include_offset`` the energy removed by mergers and inelastic bounces up to each
        snapshot (:attr:`energy_offset`) is added back, as :meth:`Simulation.energy` does by
        default, so that the sum stays constant through a merger.

        Raises
        ------
        InvalidStateError
            A snapshot where the energy is not finite: two massive particles at the same
            position without softening, or a particle with a mass but NaN coordinates.
        """
        out = self._each_mass_set(lambda x, v, m, res: _gravity.energy_history(
            x, v, m, float(self.G), float(self.softening) ** 2, res))
        bad = np.flatnonzero(~np.isfinite(out))
        if bad.size:
            k = int(bad[0])
            context = f"Trajectory.energy: at snapshot {k} (t = {fmt_number(self.t[k])})"
            present = self._present()[k]
            lost = present & ~(np.isfinite(self.positions[k]).all(axis=1)
                               & np.isfinite(self.velocities[k]).all(axis=1))
            if lost.any():
                raise InvalidStateError(
                    f"{context} particle(s) {np.flatnonzero(lost).tolist()} have a mass but NaN "
                    "or infinite coordinates, so the total energy is undefined. A particle "
                    "removed by a merger must have a NaN mass at that snapshot (masses of "
                    "shape (T, N), as Simulation.integrate returns them).")
            m = np.where(present, self.masses[k], 0.0)
            pairs = coincident_pairs(self.positions[k], m, float(self.softening) ** 2)
            where = f"particles {pairs[0]} share a position" if pairs else "the energy overflows"
            raise InvalidStateError(
                f"{context} {where}, so the potential energy is not finite ({bad.size} "
                "snapshot(s) in all). To fix: run with softening > 0, or give the particles "
                "radii with collision='merge'."
            )
        return out + self.energy_offset if include_offset else out

    def momentum(self) -> np.ndarray:
        """Total linear momentum ``sum m v`` of the particles present at each snapshot, shape
        (T, 3) (simulation units)."""
        m = self.masses[..., None]
        return np.where(self._present()[..., None], m * self.velocities, 0.0).sum(axis=1)

    def angular_momentum(self) -> np.ndarray:
        """Total angular momentum ``sum m r x v`` about the origin of the particles present at
        each snapshot, shape (T, 3) (simulation units)."""
        L = self.masses[..., None] * np.cross(self.positions, self.velocities)
        return np.where(self._present()[..., None], L, 0.0).sum(axis=1)

    def _each_mass_set(self, kernel) -> np.ndarray:
        """``kernel(x, v, m, out)`` over each run of snapshots with the same masses (between two
        mergers), on the particles present there; the results, shape (T,)."""
        present = self._present()
        key = np.where(present, self.masses, -1.0)  # masses are >= 0: -1 marks a removed one
        T = len(self.t)
        starts = np.flatnonzero(np.r_[True, (key[1:] != key[:-1]).any(axis=1)]) if T else []
        out = np.empty(T)
        for a, b in zip(starts, [*starts[1:], T], strict=True):
            cols = np.flatnonzero(present[a])
            res = np.empty(b - a)
            kernel(np.ascontiguousarray(self.positions[a:b][:, cols]),
                   np.ascontiguousarray(self.velocities[a:b][:, cols]),
                   np.ascontiguousarray(self.masses[a, cols]), res)
            out[a:b] = res
        return out


class Recording:
    """The snapshots of one run through the output times ``times``, gathered as it goes (one
    per :meth:`visviva.Simulation.integrate` call, on the CPU and GPU backends alike).

    A kernel call writes its snapshots into ``out_t``, ``chunk_x`` and ``chunk_v`` (rows ``k``
    for the outputs it reached, over the particles it had); :meth:`after_call` copies them to
    the particles' original columns and acts on the call's status. Used as a context manager:
    the progress bar is closed and the kernel's pause request cleared on exit.

    Parameters
    ----------
    sim : Simulation
        The simulation about to run (after :meth:`visviva.Simulation.begin_run`).
    times : ndarray, shape (T,)
        The output times (simulation units).
    progress : bool
        Show a tqdm progress bar, updated when a kernel call pauses or returns.
    """

    def __init__(self, sim, times, progress: bool = False):
        self.sim = sim
        self.times = times
        self.out_t = times.copy()
        T, n = len(times), sim.N
        self.out_x = np.full((T, n, 3), np.nan)
        self.out_v = np.full((T, n, 3), np.nan)
        self.out_m = np.full((T, n), np.nan)  # masses per snapshot: NaN once removed
        self.out_offset = np.full(T, np.nan)  # the simulation's energy_offset per snapshot
        self.alive = np.arange(n)  # original index of each current particle
        self._chunks(n)
        self.bar = None
        self.t_start = sim.t
        if progress:
            from tqdm.auto import tqdm

            self.bar = tqdm(total=abs(times[-1] - sim.t), unit="t", desc=sim.integrator)

    def _chunks(self, n: int) -> None:
        T = len(self.times)
        self.chunk_x = np.empty((T, n, 3))
        self.chunk_v = np.empty((T, n, 3))

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.sim.state_arrays()["istate"][_nc.I_STOP_AT_STEP] = 0
        if self.bar is not None:
            self.bar.close()
        return False

    def before_call(self) -> int:
        """Ask the next kernel call to pause after a slice of steps when a bar is shown; returns
        the number of outputs done so far (for :meth:`after_call`)."""
        istate = self.sim.state_arrays()["istate"]
        steps = int(istate[_nc.I_STEPS])
        istate[_nc.I_STOP_AT_STEP] = steps + _PROGRESS_STEPS if self.bar is not None else 0
        return int(istate[_nc.I_NOUT])

    def after_call(self, status: int, done0: int) -> bool:
        """Copy the snapshots the call wrote (outputs ``done0`` on), check their states
        (:func:`visviva.nbody.step_check.check_run`), update the bar, and act on the status
        (:meth:`visviva.Simulation.after_kernel`): True when the run is done, False to call
        the kernel again; events raise."""
        sim = self.sim
        done = int(sim.state_arrays()["istate"][_nc.I_NOUT])
        if done > done0:
            self.out_x[done0:done, self.alive] = self.chunk_x[done0:done]
            self.out_v[done0:done, self.alive] = self.chunk_v[done0:done]
            # the masses and offset of the call: a merger changes them only between calls
            self.out_m[done0:done, self.alive] = sim.masses
            self.out_offset[done0:done] = sim.energy_offset
            # the states the run reached: a close encounter met on the way (step_check.py)
            _step_check.check_run(sim, self.t_start, self.out_t[done0:done],
                                  self.chunk_x[done0:done], self.chunk_v[done0:done])
        if self.bar is not None:
            self.bar.n = abs(sim.t - self.t_start)
            self.bar.refresh()
        return sim.after_kernel(status, removed=self._removed)

    def _removed(self, index: int) -> None:
        """A merger removed particle ``index``: the columns of the particles left."""
        self.alive = np.delete(self.alive, index)
        self._chunks(self.sim.N)

    def trajectory(self) -> Trajectory:
        """The snapshots as a :class:`Trajectory`."""
        return Trajectory(self.out_t, self.out_x, self.out_v, self.out_m, self.sim.G,
                          self.sim.softening, self.out_offset)
