"""One simulation as a file: the versioned ``.npz`` format behind :meth:`Simulation.save` and
:meth:`Simulation.load`, atomic writes (also used by :class:`~visviva.nbody.archive.Archive` and
:meth:`Ensemble.save`).

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

This module works on a simulation's state, settings and forces and builds the object through
the class it is given (``cls.from_state``): it imports neither the simulation nor the archive.
"""

from __future__ import annotations

import json
import os
import tempfile
import zipfile

import numpy as np

from ..errors import InvalidInputError

__all__ = [
    "save_simulation", "load_simulation", "FORMAT", "FORMAT_VERSION",
    # the friend functions of the archive and the ensembles (docs/design.md)
    "state_dict", "atomic_savez", "check_format", "open_npz", "build_simulation",
]

FORMAT = "visviva.nbody.simulation"
FORMAT_VERSION = 1


def state_dict(sim) -> dict:
    """Everything a file stores of ``sim``: ``meta`` (JSON settings) and its state arrays."""
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
    out = {"meta": np.array(json.dumps(meta))}
    out.update(sim.state_arrays())
    return out


def atomic_savez(path, arrays: dict) -> None:
    """``np.savez`` of ``arrays`` to a temporary file in the same folder, then renamed to
    ``path``: a reader never sees half a file."""
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):  # else the error names the temporary file
        raise FileNotFoundError(f"cannot write {path!r}: the folder {directory!r} does not exist")
    if os.path.isdir(path):
        raise IsADirectoryError(
            f"cannot write {path!r}: it is a folder; give a file name in it, e.g. "
            f"{os.path.join(path, 'simulation.npz')!r}"
        )
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
    arrays.update(state_dict(sim))
    atomic_savez(path, arrays)


def build_simulation(cls, get, forces=None):
    """A ``cls`` (through its friend constructor ``from_state``) from ``get(key)`` (a stored
    array or None) as written by :func:`state_dict`; ``forces`` replace the saved ones."""
    from .forces import Force
    from .state import SimulationState
    from .units import SimulationUnits

    meta = json.loads(str(get("meta")))
    state = SimulationState.from_arrays(
        get,
        collision=meta["collision"],
        restitution=meta["restitution"],
        energy_offset=float.fromhex(meta["energy_offset"]),
    )
    units = None if meta["units"] is None else SimulationUnits.parse(meta["units"])
    if forces is not None:
        forces = [f if isinstance(f, Force) else Force(f) for f in forces]
    else:
        forces = []
        for spec in meta["forces"]:
            try:
                forces.append(Force.from_spec(spec))
            except (ImportError, AttributeError, KeyError, TypeError) as exc:
                raise InvalidInputError(
                    f"the saved simulation used the force {spec['fn']!r}, which cannot be "
                    "re-imported (defined in __main__ or a closure): pass it again with "
                    "Simulation.load(path, forces=[...])."
                ) from exc
    sim = cls.from_state(state, meta["integrator"], units=units, parallel=meta["parallel"],
                         forces=forces)
    if meta.get("names") is not None:
        sim.names = meta["names"]
    return sim


def check_format(data, fmt, version, path):
    """Raise :class:`~visviva.errors.InvalidInputError` unless ``data`` is a ``fmt`` file of a
    version this visviva reads."""
    if "format" not in data or str(data["format"]) != fmt:
        raise InvalidInputError(f"{path!r} is not a {fmt} file.")
    v = int(data["format_version"])
    if v > version:
        raise InvalidInputError(
            f"{path!r} has format version {v}; this visviva reads up to {version}: upgrade visviva."
        )


def load_simulation(cls, path, forces=None):
    """Read a simulation written by :func:`save_simulation`."""
    data = open_npz(path)
    with data:
        check_format(data, FORMAT, FORMAT_VERSION, path)
        return build_simulation(cls, lambda k: data[k] if k in data else None, forces)


def open_npz(path):
    """``np.load`` of an archive, with a typed error for a file that is not one."""
    try:
        data = np.load(os.fspath(path), allow_pickle=False)
    except FileNotFoundError:
        raise
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        if isinstance(exc, zipfile.BadZipFile):
            why = f"a truncated or corrupted zip archive ({exc})"
        elif "pickle" in str(exc):  # numpy's fallback for unknown content; never unpickle
            why = "not a numpy file at all"
        else:
            why = str(exc)
        raise InvalidInputError(
            f"{path!r} is not a visviva simulation file (numpy .npz written by Simulation.save or "
            f"Archive.record): {why}. Pass the path of such a file."
        ) from exc
    if not hasattr(data, "files"):
        raise InvalidInputError(
            f"{path!r} is a single numpy array, not a visviva simulation file (.npz written by "
            "Simulation.save or Archive.record)."
        )
    return data
