"""Snapshots of an N-body run (:class:`Trajectory`) and the coincident-particle check.

A :class:`Trajectory` is what :meth:`visviva.Simulation.integrate` returns for an array of output
times: ``(T, N, 3)`` positions and velocities, with the energy of every snapshot on demand.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core import gravity as _gravity
from ..errors import InvalidStateError, fmt_number

__all__ = ["Trajectory", "coincident_pairs"]


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
    masses : ndarray, shape (N,)
        Masses at the start of the run.
    """

    t: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    masses: np.ndarray
    G: float = 1.0
    softening: float = 0.0

    def energy(self) -> np.ndarray:
        """Total energy at each snapshot, shape (T,) (simulation units).

        Raises
        ------
        InvalidStateError
            A snapshot where the energy is not finite: two massive particles at the same
            position without softening, or a particle removed by a merger.
        """
        out = np.empty(len(self.t))
        _gravity.energy_history(
            np.ascontiguousarray(self.positions),
            np.ascontiguousarray(self.velocities),
            self.masses,
            float(self.G),
            float(self.softening) ** 2,
            out,
        )
        bad = np.flatnonzero(~np.isfinite(out))
        if bad.size:
            k = int(bad[0])
            context = f"Trajectory.energy: at snapshot {k} (t = {fmt_number(self.t[k])})"
            removed = np.flatnonzero(np.isnan(self.positions[k]).any(axis=1))
            if removed.size:
                raise InvalidStateError(
                    f"{context} particle(s) {removed.tolist()} had been removed by a merger, so "
                    "the total energy of the snapshot is undefined. Use Simulation.energy(), "
                    "which tracks the energy lost in mergers (energy_offset), or sample the "
                    "trajectory before the merger."
                )
            pairs = coincident_pairs(self.positions[k], self.masses, float(self.softening) ** 2)
            where = f"particles {pairs[0]} share a position" if pairs else "the energy overflows"
            raise InvalidStateError(
                f"{context} {where}, so the potential energy is not finite ({bad.size} "
                "snapshot(s) in all). To fix: run with softening > 0, or give the particles "
                "radii with collision='merge'."
            )
        return out
