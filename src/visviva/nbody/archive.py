"""Saving, loading and archiving N-body simulations (versioned ``.npz`` files, atomic writes).

Format ``visviva.nbody.simulation`` version 1 (an uncompressed numpy ``.npz`` archive)
------------------------------------------------------------------------------------------
=================  =========================================================================
key                content
=================  =========================================================================
``format``         the string ``"visviva.nbody.simulation"``
``format_version`` integer, 1
``meta``           JSON: integrator, units, collision mode, restitution, parallel flag,
                   energy offset (as a float hex string), forces (how to rebuild them), names
``x``, ``v``       positions and velocities, (N, 3) float64
``m``, ``radius``  masses and collision radii, (N,)
``fstate``         float64 scalar state (time, dt, last dt, epsilon, G, ...); see
                   :mod:`visviva.core.nbody_common`
``istate``         int64 scalar state (step counters, flags)
``buf``            the integrator's internal arrays (IAS15's b, e and compensated-summation
                   terms, WHFast's Jacobi state), (K, N, 3); absent if never integrated
=================  =========================================================================

Every bit of state is stored, so a loaded simulation continues exactly as if it had never
stopped. Files are written to a temporary file in the same directory and moved into place with
:func:`os.replace`, so a crash never leaves a half-written file.

An :class:`Archive` (format ``visviva.nbody.archive`` version 1) holds many such snapshots in one
file under the keys ``s<k>_<key>``, plus ``times``; indexing it returns a :class:`Simulation`
that continues bit for bit from that snapshot.
"""

from __future__ import annotations

import json
import os
import tempfile
import warnings

import numpy as np

from ..errors import InvalidInputError, fmt_number

__all__ = ["save_simulation", "load_simulation", "Archive", "FORMAT", "FORMAT_VERSION"]

FORMAT = "visviva.nbody.simulation"
FORMAT_VERSION = 1
ARCHIVE_FORMAT = "visviva.nbody.archive"
ARCHIVE_VERSION = 1


def _state(sim) -> dict:
    meta = {
        "integrator": sim.integrator,
        "units": None if sim.units is None else list(sim.units.as_tuple()),
        "collision": sim.collision,
        "restitution": sim.restitution,
        "parallel": sim.parallel,
        "energy_offset": float(sim.energy_offset).hex(),
        "forces": [f.spec() for f in sim.forces],
        "names": getattr(sim, "names", None),
    }
    out = {
        "meta": np.array(json.dumps(meta)),
        "x": sim._x,
        "v": sim._v,
        "m": sim._m,
        "radius": sim._radius,
        "fstate": sim._fstate,
        "istate": sim._istate,
    }
    if sim._buf is not None:
        out["buf"] = sim._buf
    return out


def _atomic_savez(path, arrays: dict) -> None:
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".npz", dir=directory)
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, **arrays)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def save_simulation(sim, path) -> None:
    """Write ``sim`` to ``path`` atomically (format above)."""
    arrays = {"format": np.array(FORMAT), "format_version": np.array(FORMAT_VERSION)}
    arrays.update(_state(sim))
    _atomic_savez(path, arrays)


def _build(cls, get, forces=None):
    from .forces import Force
    from .units import SimulationUnits

    meta = json.loads(str(get("meta")))
    sim = cls.__new__(cls)
    cls.__init__(sim, meta["integrator"])
    sim.units = None if meta["units"] is None else SimulationUnits.parse(meta["units"])
    sim._x = np.ascontiguousarray(get("x"))
    sim._v = np.ascontiguousarray(get("v"))
    sim._m = np.ascontiguousarray(get("m"))
    sim._radius = np.ascontiguousarray(get("radius"))
    sim._fstate = np.ascontiguousarray(get("fstate"))
    sim._istate = np.ascontiguousarray(get("istate"))
    buf = get("buf")
    sim._buf = None if buf is None else np.ascontiguousarray(buf)
    sim._collision = meta["collision"]
    sim._restitution = meta["restitution"]
    sim.parallel = meta["parallel"]
    sim.energy_offset = float.fromhex(meta["energy_offset"])
    if meta.get("names") is not None:
        sim.names = meta["names"]
    if forces is not None:
        sim._forces = [f if isinstance(f, Force) else Force(f) for f in forces]
    else:
        sim._forces = []
        for spec in meta["forces"]:
            try:
                sim._forces.append(Force.from_spec(spec))
            except (ImportError, AttributeError, KeyError, TypeError) as exc:
                raise InvalidInputError(
                    f"the saved simulation used the force {spec['fn']!r}, which cannot be "
                    "re-imported (defined in __main__ or a closure): pass it again with "
                    "Simulation.load(path, forces=[...])."
                ) from exc
    sim._fused = None
    return sim


def _check_format(data, fmt, version, path):
    if "format" not in data or str(data["format"]) != fmt:
        raise InvalidInputError(f"{path!r} is not a {fmt} file.")
    v = int(data["format_version"])
    if v > version:
        raise InvalidInputError(
            f"{path!r} has format version {v}; this visviva reads up to {version}: upgrade visviva."
        )


def load_simulation(cls, path, forces=None):
    """Read a simulation written by :func:`save_simulation`."""
    data = _open_npz(path)
    with data:
        _check_format(data, FORMAT, FORMAT_VERSION, path)
        return _build(cls, lambda k: data[k] if k in data else None, forces)


def _open_npz(path):
    """``np.load`` of an archive, with a typed error for a file that is not one."""
    try:
        data = np.load(os.fspath(path), allow_pickle=False)
    except FileNotFoundError:
        raise
    except (ValueError, OSError, EOFError) as exc:
        raise InvalidInputError(
            f"{path!r} is not a visviva simulation file (numpy .npz written by Simulation.save or "
            f"Archive.record): {exc}. Pass the path of such a file."
        ) from exc
    if not hasattr(data, "files"):
        raise InvalidInputError(
            f"{path!r} is a single numpy array, not a visviva simulation file (.npz written by "
            "Simulation.save or Archive.record)."
        )
    return data


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
            with _open_npz(self.path) as data:
                _check_format(data, ARCHIVE_FORMAT, ARCHIVE_VERSION, self.path)
                n = int(data["count"])
                keys = [k for k in data.files if k.startswith("s")]
                for k in range(n):
                    prefix = f"s{k}_"
                    self._snapshots.append(
                        {key[len(prefix):]: data[key] for key in keys if key.startswith(prefix)}
                    )
                self._times = list(np.asarray(data["times"], dtype=float))

    # -- writing ----------------------------------------------------------------------------------
    def append(self, sim, flush: bool = True) -> None:
        """Add a snapshot of ``sim`` (and rewrite the file atomically when ``flush``)."""
        self._snapshots.append({k: np.array(v, copy=True) for k, v in _state(sim).items()})
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
        _atomic_savez(self.path, arrays)

    @classmethod
    def record(cls, sim, path, interval, t_end, *, progress: bool = False,
               flush_every: int = 100) -> Archive:
        """Integrate ``sim`` to ``t_end``, storing a snapshot every ``interval`` (and at start).

        One compiled call per interval; the file is rewritten atomically every ``flush_every``
        snapshots and at the end.
        """
        interval = float(sim._time(interval, "interval"))
        t_end = float(sim._time(t_end, "t_end"))
        if not interval > 0:
            raise InvalidInputError(f"interval must be > 0; got {fmt_number(interval)}.")
        archive = cls(path)
        t0 = sim.t
        sign = 1.0 if t_end >= t0 else -1.0
        n = int(np.floor(abs(t_end - t0) / interval + 1e-9))
        times = [t0 + sign * k * interval for k in range(1, n + 1)]
        if not times or times[-1] != t_end and abs(times[-1] - t_end) > 1e-12 * interval:
            times.append(t_end)
        archive.append(sim, flush=False)
        iterator = times
        if progress:
            from tqdm.auto import tqdm

            iterator = tqdm(times, desc="archive")
        for k, t in enumerate(iterator):
            sim.integrate(t)
            archive.append(sim, flush=(k + 1) % flush_every == 0)
        archive.flush()
        return archive

    # -- reading ----------------------------------------------------------------------------------
    @property
    def times(self) -> np.ndarray:
        return np.array(self._times)

    def __len__(self) -> int:
        return len(self._snapshots)

    def __getitem__(self, k):
        from .simulation import Simulation

        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(len(self)))]
        snap = self._snapshots[k]
        with warnings.catch_warnings():
            return _build(Simulation, lambda key: snap.get(key))

    def __iter__(self):
        for k in range(len(self)):
            yield self[k]

    def __repr__(self) -> str:
        return f"<Archive {self.path!r}: {len(self)} snapshots>"
