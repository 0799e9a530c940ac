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
    "state_dict", "atomic_savez", "check_format", "open_npz", "read_arrays", "build_simulation",
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
    ``path``: a reader never sees half a file. An existing ``path`` is replaced only when it
    holds a file of the same format (``arrays["format"]``): see :func:`_check_replaceable`."""
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):  # else the error names the temporary file
        raise FileNotFoundError(f"cannot write {path!r}: the folder {directory!r} does not exist")
    if os.path.isdir(path):
        raise IsADirectoryError(
            f"cannot write {path!r}: it is a folder; give a file name in it, e.g. "
            f"{os.path.join(path, 'simulation.npz')!r}"
        )
    _check_replaceable(path, str(arrays["format"]))
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


def _check_replaceable(path: str, fmt: str) -> None:
    """Raise :class:`~visviva.errors.InvalidInputError` when ``path`` exists and is not a
    ``fmt`` file.

    Saving again over a file of the same kind (a checkpoint written by an earlier save) replaces
    it; anything else there (an archive of many snapshots, an ensemble, a user's own ``.npz`` or
    text file, an unreadable file) would be lost without a word, so it is refused."""
    if not os.path.lexists(path):
        return
    found = None
    try:
        with np.load(path, allow_pickle=False) as data:  # reads the format entry only
            if "format" in getattr(data, "files", ()) and np.ndim(data["format"]) == 0:
                found = str(data["format"])
    except Exception:  # noqa: BLE001 (not a readable .npz at all: found stays None)
        found = None
    if found == fmt:
        return
    what = f"a {found} file" if found and found.startswith("visviva.") else "not a visviva file"
    raise InvalidInputError(
        f"cannot write a {fmt} file to {path!r}: it exists and is {what}, which would be "
        "replaced and lost. Give another path, or delete that file first.")


def save_simulation(sim, path) -> None:
    """Write ``sim`` to ``path`` atomically (format above)."""
    arrays = {"format": np.array(FORMAT), "format_version": np.array(FORMAT_VERSION)}
    arrays.update(state_dict(sim))
    atomic_savez(path, arrays)


def build_simulation(cls, get, forces=None, path="the file"):
    """A ``cls`` (through its friend constructor ``from_state``) from ``get(key)`` (a stored
    array or None) as written by :func:`state_dict`; ``forces`` replace the saved ones.

    Everything read is checked first (:func:`_check_meta`, :func:`_check_state`): a file that
    was truncated, edited or written by something else raises
    :class:`~visviva.errors.InvalidInputError` naming ``path`` and what is wrong, never a bare
    exception, NaN state, or arrays whose sizes disagree (the kernels would write past them).
    """
    from .forces import Force
    from .state import SimulationState
    from .units import SimulationUnits

    meta = _check_meta(get("meta"), path)
    arrays = {key: get(key) for key in (*_ARRAY_KEYS, "buf")}
    _check_state(arrays, path)
    try:
        state = SimulationState.from_arrays(
            arrays.get,
            collision=meta["collision"],
            restitution=float(meta["restitution"]),
            energy_offset=float.fromhex(meta["energy_offset"]),
        )
        units = None if meta["units"] is None else SimulationUnits.parse(meta["units"])
    except (TypeError, ValueError) as exc:
        raise _inconsistent(path, f"a setting cannot be read ({exc})") from None
    if forces is not None:
        forces = [f if isinstance(f, Force) else Force(f) for f in forces]
    else:
        forces = []
        for spec in meta["forces"]:
            try:
                forces.append(Force.from_spec(spec))
            except InvalidInputError as exc:  # a built-in refusing the stored arguments
                raise InvalidInputError(
                    f"{path!r}: its force {spec.get('name')!r} cannot be rebuilt from the "
                    f"file ({exc})") from exc
            except (ImportError, AttributeError, KeyError, TypeError, ValueError) as exc:
                fn = spec.get("fn") if isinstance(spec, dict) else spec
                raise InvalidInputError(
                    f"the saved simulation used the force {fn!r}, which cannot be "
                    "re-imported (defined in __main__ or a closure): pass it again with "
                    "Simulation.load(path, forces=[...])."
                ) from exc
    sim = cls.from_state(state, meta["integrator"], units=units, parallel=meta["parallel"],
                         forces=forces)
    if meta.get("names") is not None:
        sim.names = meta["names"]
    return sim


_ARRAY_KEYS = ("x", "v", "m", "radius", "fstate", "istate")  # (state.ARRAY_KEYS, unimported)
#: meta key -> (types it may have, what it is)
_META_TYPES = {
    "integrator": (str, "the integrator's name"), "collision": (str, "the collision mode"),
    "restitution": ((int, float), "a number"), "parallel": ((bool, type(None)), "true/false"),
    "energy_offset": (str, "a float in hex"), "forces": (list, "a list"),
    "units": ((list, type(None)), "a list of 3 unit names or null"),
}


def _inconsistent(path, why: str) -> InvalidInputError:
    return InvalidInputError(
        f"{path!r} is not a valid visviva simulation file: {why}. The file was truncated, "
        "edited or written by another program; save the simulation again.")


def _check_meta(raw, path) -> dict:
    """The settings (``meta``) of a stored simulation, checked for every key and type."""
    if raw is None or np.ndim(raw) != 0:
        raise _inconsistent(path, "its settings ('meta') are missing")
    try:
        meta = json.loads(str(raw))
    except ValueError:
        meta = None
    if not isinstance(meta, dict):
        raise _inconsistent(path, "its settings ('meta') are not a JSON object")
    for key, (types, what) in _META_TYPES.items():
        if key not in meta or not isinstance(meta[key], types):
            raise _inconsistent(path, f"the setting {key!r} is missing or not {what}")
    names = meta.get("names")
    if names is not None and not (isinstance(names, list)
                                  and all(isinstance(n, str) for n in names)):
        raise _inconsistent(path, "the setting 'names' is not a list of names")
    return meta


def _check_state(arrays: dict, path) -> None:
    """Shapes, types, finiteness and the index and flag slots of a stored state."""
    from ..core import nbody_common as nc

    for key in _ARRAY_KEYS:
        if arrays[key] is None:
            raise _inconsistent(path, f"the array {key!r} is missing")
    x = arrays["x"]
    n = x.shape[0] if x.ndim == 2 else -1
    shapes = {"x": (n, 3), "v": (n, 3), "m": (n,), "radius": (n,),
              "fstate": (nc.N_FSTATE,), "istate": (nc.N_ISTATE,)}
    for key, shape in shapes.items():
        a = arrays[key]
        dtype = np.int64 if key == "istate" else np.float64
        if a.shape != shape or a.dtype != dtype:
            raise _inconsistent(path, f"the array {key!r} is {a.dtype} of shape {a.shape}, not "
                                      f"{np.dtype(dtype)} of shape {shape}")
    buf = arrays["buf"]
    if buf is not None and (buf.dtype != np.float64 or buf.ndim != 3 or buf.shape[1:] != (n, 3)):
        raise _inconsistent(path, f"the integrator's array 'buf' is {buf.dtype} of shape "
                                  f"{buf.shape}, not float64 of shape (K, {n}, 3)")
    for key in ("x", "v", "m", "radius", "fstate", "buf"):
        a = arrays[key]
        if a is not None and not np.isfinite(a).all():
            raise _inconsistent(path, f"the array {key!r} holds NaN or infinite values")
    if (arrays["m"] < 0).any() or (arrays["radius"] < 0).any():
        raise _inconsistent(path, "a mass or a radius is negative")
    ist = arrays["istate"]
    flags = (nc.I_PARALLEL, nc.I_COLLISIONS, nc.I_FRESH, nc.I_EXACT_FINISH, nc.I_WH_VALID,
             nc.I_VELOCITY_DEPENDENT, nc.I_INT_VALID, nc.I_ADAPTIVE_MODE, nc.I_WH_COORDINATES)
    counts = (nc.I_NOUT, nc.I_STEPS, nc.I_ITERATIONS, nc.I_REJECTED, nc.I_STOP_AT_STEP,
              nc.I_CORRECTOR)
    # (not the event's particles, I_EVENT_A/B: after an escape they may name a removed one)
    if any(ist[i] not in (0, 1) for i in flags) or any(ist[i] < 0 for i in counts):
        raise _inconsistent(path, "its integer state ('istate') holds impossible values")


def check_format(data, fmt, version, path):
    """Raise :class:`~visviva.errors.InvalidInputError` unless ``data`` is a ``fmt`` file of a
    version this visviva reads."""
    if "format" not in data or np.ndim(data["format"]) != 0 or str(data["format"]) != fmt:
        raise InvalidInputError(f"{path!r} is not a {fmt} file.")
    v = data["format_version"] if "format_version" in data else None
    if v is None or np.ndim(v) != 0 or np.asarray(v).dtype.kind not in "iu" or v < 1:
        raise InvalidInputError(f"{path!r} is a {fmt} file without a valid format_version; it "
                                "was edited or written by another program.")
    v = int(v)
    if v > version:
        raise InvalidInputError(
            f"{path!r} has format version {v}; this visviva reads up to {version}: upgrade visviva."
        )


def load_simulation(cls, path, forces=None):
    """Read a simulation written by :func:`save_simulation`."""
    with open_npz(path) as data:
        arrays = read_arrays(data, path)
    check_format(arrays, FORMAT, FORMAT_VERSION, path)
    return build_simulation(cls, arrays.get, forces, os.fspath(path))


def read_arrays(data, path) -> dict:
    """Every array of an open ``.npz`` (:func:`open_npz`), read now: a member whose bytes were
    damaged (a CRC error, a bad header, a truncated member) raises a typed error naming the
    file here, not later at first use."""
    try:
        return {key: data[key] for key in data.files}
    except Exception as exc:  # noqa: BLE001 (damaged bytes: BadZipFile, zlib.error, a header
        # numpy's parser chokes on (ValueError, SyntaxError, TokenError), a huge shape...)
        raise InvalidInputError(
            f"{os.fspath(path)!r} is corrupted and cannot be read ({type(exc).__name__}: "
            f"{exc}); use another copy or save the simulation again.") from exc


def open_npz(path):
    """``np.load`` of an archive, with a typed error for a file that is not one."""
    try:
        data = np.load(os.fspath(path), allow_pickle=False)
    except FileNotFoundError:
        raise
    except (ValueError, OSError, EOFError, zipfile.BadZipFile, NotImplementedError) as exc:
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
