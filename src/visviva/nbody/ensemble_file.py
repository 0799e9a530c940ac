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
from .snapshot import atomic_savez, build_simulation, check_format, open_npz, state_dict

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
    with open_npz(path) as data:
        check_format(data, ENSEMBLE_FORMAT, ENSEMBLE_VERSION, os.fspath(path))
        backend = json.loads(str(data["backend"]))
        if int(data["format_version"]) == 1:
            return _load_version_1(cls, data, forces), backend
        arrays = {key: data[key] for key in data.files}
    missing = [k for k in (*_PACKED, "poff", "boff", "fstate", "istate", "buf", "meta",
                           "meta_index", "count") if k not in arrays]
    if missing:
        raise InvalidInputError(
            f"{os.fspath(path)!r} is not a complete visviva.nbody.ensemble file: the array(s) "
            f"{missing} are missing. Save the ensemble again with Ensemble.save.")
    poff, boff = arrays["poff"], arrays["boff"]
    count = int(arrays["count"])
    if len(poff) != count + 1 or len(boff) != count + 1 or len(arrays["meta_index"]) != count:
        raise InvalidInputError(
            f"{os.fspath(path)!r} is not a consistent visviva.nbody.ensemble file: {count} "
            f"members but offsets for {len(poff) - 1}. Save the ensemble again with "
            "Ensemble.save.")
    meta, meta_index = arrays["meta"], arrays["meta_index"]
    members = []
    for k in range(count):
        lo, hi = poff[k], poff[k + 1]
        b = arrays["buf"][boff[k]:boff[k + 1]]
        one = {key: arrays[key][lo:hi] for key in _PACKED}
        one.update(fstate=arrays["fstate"][k], istate=arrays["istate"][k],
                   meta=meta[meta_index[k]],
                   buf=b.reshape(-1, hi - lo, 3).copy() if b.size else None)
        for key in _PACKED:
            one[key] = one[key].copy()
        one["fstate"] = one["fstate"].copy()
        one["istate"] = one["istate"].copy()
        members.append(build_simulation(cls, one.get, forces))
    return members, backend


def _load_version_1(cls, data, forces) -> list:
    """Members stored one set of arrays each under the keys ``e<k>_<key>``."""
    by_member: dict = {}
    for key in data.files:
        if key.startswith("e") and "_" in key:
            head, name = key.split("_", 1)
            by_member.setdefault(int(head[1:]), {})[name] = data[key]
    return [build_simulation(cls, by_member.get(k, {}).get, forces)
            for k in range(int(data["count"]))]
