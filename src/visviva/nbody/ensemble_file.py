"""An ensemble as a file: the versioned ``.npz`` format behind :meth:`visviva.Ensemble.save`
and :meth:`visviva.Ensemble.load`.

Format ``visviva.nbody.ensemble`` version 2 (an uncompressed numpy ``.npz`` archive): the
members' arrays packed one after another, so that a file of 10^5 members holds a dozen arrays
rather than 10^6 (version 1, one set of arrays per member, still loads).

==================  ========================================================================
key                 content
==================  ========================================================================
``format``          the string ``"visviva.nbody.ensemble"``
``format_version``  integer, 2
``count``           number of members M
``backend``         JSON string: the ensemble's backend
``poff``            (M + 1,) int64: member k's particles are rows ``poff[k]:poff[k+1]``
``x``, ``v``        (P, 3) float64: positions and velocities of every member's particles
``m``, ``radius``   (P,) float64: masses and collision radii
``fstate``          (M, N_FSTATE) float64: each member's scalar state (time, dt, G, ...)
``istate``          (M, N_ISTATE) int64: each member's integer state
``buf``             (sum of K_k N_k 3,) float64: each member's internal arrays, flattened
``boff``            (M + 1,) int64: member k's ``buf`` is ``buf[boff[k]:boff[k+1]]``, of shape
                    (K_k, N_k, 3) (empty: never integrated)
``meta``            (U,) JSON strings: the members' distinct settings (integrator, units,
                    collision mode, forces, ...; :func:`visviva.nbody.snapshot.state_dict`)
``meta_index``      (M,) int64: member k's settings are ``meta[meta_index[k]]``
==================  ========================================================================

Every bit of every member's state is stored: a loaded ensemble continues exactly. The file is
written atomically (:func:`visviva.nbody.snapshot.atomic_savez`).
"""

from __future__ import annotations

import json
import os

import numpy as np

from ..errors import InvalidInputError
from .snapshot import (
    atomic_savez,
    build_simulation,
    check_format,
    open_npz,
    read_arrays,
    state_dict,
)

__all__ = ["save_ensemble", "load_ensemble", "ENSEMBLE_FORMAT", "ENSEMBLE_VERSION"]

ENSEMBLE_FORMAT = "visviva.nbody.ensemble"
ENSEMBLE_VERSION = 2
_PACKED = ("x", "v", "m", "radius")


def save_ensemble(members: list, backend: str, path) -> None:
    """Write the simulations ``members`` and ``backend`` to ``path`` (format above)."""
    metas: dict = {}
    index = np.empty(len(members), dtype=np.int64)
    parts: dict = {key: [] for key in (*_PACKED, "fstate", "istate", "buf")}
    for k, sim in enumerate(members):
        d = state_dict(sim)
        index[k] = metas.setdefault(str(d["meta"]), len(metas))
        for key in parts:
            parts[key].append(d["buf"].reshape(-1) if key == "buf" and "buf" in d
                              else np.zeros(0) if key == "buf" else d[key])
    n = [len(p) for p in parts["m"]]
    arrays = {
        "format": np.array(ENSEMBLE_FORMAT),
        "format_version": np.array(ENSEMBLE_VERSION),
        "count": np.array(len(members)),
        "backend": np.array(json.dumps(backend)),
        "poff": np.concatenate([[0], np.cumsum(n)]).astype(np.int64),
        "boff": np.concatenate([[0], np.cumsum([len(b) for b in parts["buf"]])]).astype(np.int64),
        "fstate": np.stack(parts["fstate"]),
        "istate": np.stack(parts["istate"]),
        "buf": np.concatenate(parts["buf"]),
        "meta": np.array(list(metas)),
        "meta_index": index,
    }
    for key in _PACKED:
        arrays[key] = np.concatenate(parts[key])
    atomic_savez(path, arrays)


def load_ensemble(cls, path, forces=None) -> tuple:
    """The members (``cls`` objects, built through ``cls.from_state``) and the saved backend of
    an ensemble file of version 1 or 2; ``forces`` replace the saved ones of every member."""
    name = os.fspath(path)
    with open_npz(path) as data:
        arrays = read_arrays(data, path)
    check_format(arrays, ENSEMBLE_FORMAT, ENSEMBLE_VERSION, name)
    backend = _json_text(arrays.get("backend"), "backend", name)
    if int(arrays["format_version"]) == 1:
        return _load_version_1(cls, arrays, forces, name), backend
    missing = [k for k in (*_PACKED, "poff", "boff", "fstate", "istate", "buf", "meta",
                           "meta_index", "count") if k not in arrays]
    if missing:
        raise InvalidInputError(
            f"{name!r} is not a complete visviva.nbody.ensemble file: the array(s) "
            f"{missing} are missing. Save the ensemble again with Ensemble.save.")
    count = _count(arrays["count"], name)
    poff, boff = arrays["poff"], arrays["boff"]
    meta, meta_index = arrays["meta"], arrays["meta_index"]
    fstate, istate, buf = arrays["fstate"], arrays["istate"], arrays["buf"]
    if poff.ndim != 1 or len(poff) != count + 1:
        raise InvalidInputError(
            f"{name!r} is not a consistent visviva.nbody.ensemble file: {count} members but "
            f"offsets for {len(poff) - 1 if poff.ndim == 1 else 'none'}. Save the ensemble "
            "again with Ensemble.save.")
    consistent = (
        _offsets(poff, count, len(arrays["m"]) if arrays["m"].ndim else -1)
        and _offsets(boff, count, buf.size)
        and buf.ndim == 1 and meta.ndim == 1 and meta_index.shape == (count,)
        and meta_index.dtype.kind in "iu" and (meta_index >= 0).all()
        and (meta_index < len(meta)).all()
        and fstate.ndim == 2 and len(fstate) == count and istate.ndim == 2
        and len(istate) == count
        and all(arrays[key].ndim >= 1 and len(arrays[key]) == poff[-1] for key in _PACKED))
    if not consistent:
        raise InvalidInputError(
            f"{name!r} is not a consistent visviva.nbody.ensemble file: {count} members, but "
            "the offsets, settings indices or packed arrays do not fit that count. Save the "
            "ensemble again with Ensemble.save.")
    members = []
    for k in range(count):
        lo, hi = poff[k], poff[k + 1]
        b = buf[boff[k]:boff[k + 1]]
        if b.size % (3 * max(hi - lo, 1)) or (hi == lo and b.size):
            raise InvalidInputError(
                f"{name!r}: member {k}'s integrator array has {b.size} values, not a multiple "
                f"of 3 x {hi - lo} particles. Save the ensemble again with Ensemble.save.")
        one = {key: arrays[key][lo:hi].copy() for key in _PACKED}
        one.update(fstate=fstate[k].copy(), istate=istate[k].copy(),
                   meta=meta[meta_index[k]],
                   buf=b.reshape(-1, hi - lo, 3).copy() if b.size else None)
        members.append(build_simulation(cls, one.get, forces, f"{name} (member {k})"))
    return members, backend


def _json_text(raw, key: str, name: str):
    """A JSON value stored as a 0-d string array, or a typed error."""
    try:
        if raw is None or np.ndim(raw) != 0:
            raise ValueError
        return json.loads(str(raw))
    except ValueError:
        raise InvalidInputError(f"{name!r}: the entry {key!r} is missing or not JSON; save "
                                "the ensemble again with Ensemble.save.") from None


def _count(raw, name: str) -> int:
    if np.ndim(raw) != 0 or np.asarray(raw).dtype.kind not in "iu" or raw < 0:
        raise InvalidInputError(f"{name!r}: the member count is not a whole number >= 0; save "
                                "the ensemble again with Ensemble.save.")
    return int(raw)


def _offsets(off, count: int, total: int) -> bool:
    """Whether ``off`` is ``count + 1`` non-decreasing integers from 0 to ``total``."""
    return (off.shape == (count + 1,) and off.dtype.kind in "iu" and off[0] == 0
            and off[-1] == total and bool((np.diff(off) >= 0).all()))


def _load_version_1(cls, data: dict, forces, name: str) -> list:
    """Members stored one set of arrays each under the keys ``e<k>_<key>``."""
    by_member: dict = {}
    for key in data:
        head, _, rest = key.partition("_")
        if head[:1] == "e" and head[1:].isdigit() and rest:
            by_member.setdefault(int(head[1:]), {})[rest] = data[key]
    return [build_simulation(cls, by_member.get(k, {}).get, forces, f"{name} (member {k})")
            for k in range(_count(data.get("count"), name))]
