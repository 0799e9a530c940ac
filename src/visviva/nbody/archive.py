"""Archiving N-body simulations: many snapshots in one file (atomic writes).

An :class:`Archive` (format ``visviva.nbody.archive`` version 1) holds many snapshots in one
file under the keys ``s<k>_<key>``, plus ``times``; indexing it returns a :class:`Simulation`
that continues bit for bit from that snapshot. Each snapshot holds the keys of one simulation
file (format ``visviva.nbody.simulation``, described in :mod:`visviva.nbody.snapshot`).
"""

from __future__ import annotations

import math
import os
import warnings

import numpy as np

from ..errors import InvalidInputError, fmt_number
from .simulation import Simulation
from .snapshot import (
    FORMAT,
    FORMAT_VERSION,
    atomic_savez,
    build_simulation,
    check_format,
    load_simulation,
    open_npz,
    read_arrays,
    save_simulation,
    state_dict,
)

__all__ = ["save_simulation", "load_simulation", "Archive", "FORMAT", "FORMAT_VERSION"]

ARCHIVE_FORMAT = "visviva.nbody.archive"
ARCHIVE_VERSION = 1
#: Most snapshots :meth:`Archive.record` takes in one call (an interval mistyped by a few powers
#: of ten would otherwise fill the memory, or never end: 1e-300 of a span is 1e300 snapshots).
MAX_SNAPSHOTS = 10**6


class Archive:
    """Snapshots of a simulation at regular intervals, in one file, indexable like a sequence.

    Record with :meth:`record` (or :meth:`append` snapshot by snapshot); read with
    ``Archive(path)``: ``len(archive)``, ``archive.times``, ``archive[k]`` (a
    :class:`visviva.Simulation` that continues bit for bit) and iteration.

    Examples
    --------
    >>> import visviva as vv, tempfile, os
    >>> sim = vv.Simulation("leapfrog", dt=0.01)
    >>> sim.add(1.0); sim.add(1e-3, r=[1, 0, 0], v=[0, 1, 0])
    0
    1
    >>> path = os.path.join(tempfile.mkdtemp(), "run.npz")
    >>> archive = vv.nbody.Archive.record(sim, path, interval=1.0, t_end=5.0)
    >>> len(archive), float(archive.times[-1])
    (6, 5.0)
    """

    def __init__(self, path):
        self.path = os.fspath(path)
        self._snapshots: list[dict] = []
        self._times: list[float] = []
        if os.path.exists(self.path):
            with open_npz(self.path) as data:
                arrays = read_arrays(data, self.path)
            check_format(arrays, ARCHIVE_FORMAT, ARCHIVE_VERSION, self.path)
            n, times = arrays.get("count"), arrays.get("times")
            if (n is None or np.ndim(n) != 0 or np.asarray(n).dtype.kind not in "iu"
                    or times is None or times.shape != (int(n),)
                    or times.dtype.kind != "f" or not np.isfinite(times).all()):
                raise InvalidInputError(
                    f"{self.path!r} is not a consistent visviva archive: its snapshot count and "
                    "times do not agree. Record the run again.")
            keys = [k for k in arrays if k.startswith("s")]
            for k in range(int(n)):
                prefix = f"s{k}_"
                self._snapshots.append(
                    {key[len(prefix):]: arrays[key] for key in keys if key.startswith(prefix)}
                )
            self._times = [float(t) for t in times]

    # -- writing ----------------------------------------------------------------------------------
    def append(self, sim, flush: bool = True) -> None:
        """Add a snapshot of ``sim`` (and rewrite the file atomically when ``flush``).

        Its time must continue the archive's (the same time as the last snapshot, or beyond it
        in the direction the times go); a time that goes back raises
        :class:`~visviva.errors.InvalidInputError`, as :meth:`record` does."""
        last = self._times[-1] if self._times else None
        before = next((t for t in reversed(self._times) if t != last), None)
        if before is not None:  # the times' direction, from the last earlier time
            self._check_continues(sim.t, math.copysign(1.0, last - before))
        self._snapshots.append({k: np.array(v, copy=True) for k, v in state_dict(sim).items()})
        self._times.append(sim.t)
        if flush:
            self.flush()

    def flush(self) -> None:
        arrays = {
            "format": np.array(ARCHIVE_FORMAT),
            "format_version": np.array(ARCHIVE_VERSION),
            "count": np.array(len(self._snapshots)),
            "times": np.array(self._times, dtype=float),
        }
        for k, snap in enumerate(self._snapshots):
            for key, value in snap.items():
                arrays[f"s{k}_{key}"] = value
        atomic_savez(self.path, arrays)

    @classmethod
    def record(cls, sim, path, interval, t_end, *, progress: bool = False,
               flush_every: int = 100) -> Archive:
        """Integrate ``sim`` to ``t_end``, storing a snapshot every ``interval`` (and at start).

        One compiled call per interval; the file is rewritten atomically every ``flush_every``
        snapshots and at the end. When ``path`` already holds an archive, the run continues
        it: ``sim`` must start at its last snapshot's time or beyond it in the direction of
        the recording (that snapshot is not stored twice); anything else raises
        :class:`~visviva.errors.InvalidInputError` rather than mixing two runs in one file.
        When the integration raises (a :class:`visviva.Collision`, ``Escape``, ...), the
        snapshots taken so far are written before the exception propagates.
        """
        interval = sim.time_value(interval, "interval")
        t_end = sim.time_value(t_end, "t_end")
        if not interval > 0:
            raise InvalidInputError(f"interval must be > 0; got {fmt_number(interval)}.")
        archive = cls(path)
        t0 = sim.t
        sign = 1.0 if t_end >= t0 else -1.0
        count = math.floor(abs(t_end - t0) / interval + 1e-9)
        if count > MAX_SNAPSHOTS:
            raise InvalidInputError(
                f"interval = {fmt_number(interval)} from t = {fmt_number(t0)} to t_end = "
                f"{fmt_number(t_end)} makes {count:.3g} snapshots (more than "
                f"{MAX_SNAPSHOTS:,}, each held in memory and rewritten into one file): give a "
                "larger interval, or record a shorter span per archive.")
        n = int(count)
        times = [t0 + sign * k * interval for k in range(1, n + 1)]
        # the grid up to t_end: a time past it (the floor's slack of 1e-9 intervals let one
        # through, and t_end was appended after it: the run went back) is dropped, and a last
        # one within 1e-12 intervals of it IS t_end (the run ended at 0.30000000000000004)
        while times and (times[-1] - t_end) * sign > 1e-12 * interval:
            times.pop()
        if times and abs(times[-1] - t_end) <= 1e-12 * interval:
            times[-1] = t_end
        elif t_end != t0:
            times.append(t_end)
        if archive._times:
            archive._check_continues(t0, sign)
        if not archive._times or archive._times[-1] != t0:
            archive.append(sim, flush=False)
        iterator = times
        if progress:
            from tqdm.auto import tqdm

            iterator = tqdm(times, desc="archive")
        try:
            for k, t in enumerate(iterator):
                if (t - sim.t) * sign > 0:  # exact_finish_time=False may have passed t: a
                    sim.integrate(t)  # call would go back (the snapshot repeats, as there)
                archive.append(sim, flush=(k + 1) % flush_every == 0)
        except BaseException as exc:
            archive.flush()  # never lose the snapshots taken before the event
            exc.add_note(f"{archive.path!r} holds the {len(archive)} snapshot(s) recorded up to "
                         f"t = {archive._times[-1]!r}; the simulation stopped at t = {sim.t!r}.")
            raise
        archive.flush()
        return archive

    def _check_continues(self, t0: float, sign: float) -> None:
        """Raise unless a recording starting at ``t0`` in the direction ``sign`` continues this
        archive (its times keep going the same way)."""
        last = self._times[-1]
        previous = self._times[-2] if len(self._times) > 1 else last
        backwards = (t0 - last) * sign < 0 or (last - previous) * sign < 0
        if backwards:
            raise InvalidInputError(
                f"{self.path!r} already holds an archive of {len(self)} snapshot(s) ending at "
                f"t = {fmt_number(last)}; recording from t = {fmt_number(t0)} to t_end in that "
                "direction would not continue it (its times would go back and forth). Record to "
                "another path, delete the file first, or continue from its last snapshot: "
                "sim = Archive(path)[-1].")

    # -- reading ----------------------------------------------------------------------------------
    @property
    def times(self) -> np.ndarray:
        return np.array(self._times)

    def __len__(self) -> int:
        return len(self._snapshots)

    def __getitem__(self, k):
        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(len(self)))]
        # a copy: the simulation's arrays are its live state (audit58: integrating archive[3]
        # changed what archive[3] returned afterwards, t = 15 -> 40, in silence)
        snap = {key: np.array(value, copy=True) for key, value in self._snapshots[k].items()}
        with warnings.catch_warnings():
            return build_simulation(Simulation, snap.get, path=f"{self.path} (snapshot {k})")

    def __iter__(self):
        for k in range(len(self)):
            yield self[k]

    def __repr__(self) -> str:
        return f"<Archive {self.path!r}: {len(self)} snapshots>"
