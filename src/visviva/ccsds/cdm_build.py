"""A Conjunction Data Message built from the two states and covariances at TCA.

What a screening and a probability computation give (the states of both objects at the time of
closest approach in one inertial frame, their 6x6 covariances in that frame) becomes the CDM's
mandatory content (CCSDS 508.0-B-1): TCA, miss distance, relative speed and the relative state
in object 1's RTN frame, each object's state (km, km/s) and its covariance rotated to the RTN
frame of its own state (m, m/s; :func:`visviva.conjunctions.inertial_to_rtn`, the convention
:attr:`~visviva.ccsds.cdm.CDMObject.covariance` reverses).
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError

__all__ = ["cdm_sections"]

#: CDM frames that are inertial (collision probability needs one)
INERTIAL_FRAMES = ("GCRF", "EME2000")


def _text(value, name):
    text = str(value).strip()
    if not text or "\n" in text:
        raise InvalidInputError(f"{name} must be a non-empty one-line text; got {value!r}.")
    return text


def cdm_sections(tca, r1, v1, cov1, r2, v2, cov2, *, names, designators, frame, originator,
                 message_id, collision_probability, collision_probability_method, cov_keywords):
    """The sections of the CDM (see :meth:`ConjunctionDataMessage.from_states`);
    ``cov_keywords`` lists ``(keyword, i, j)`` of the RTN covariance's lower triangle."""
    from astropy.time import Time

    from ..conjunctions.covariance import inertial_to_rtn, rtn_basis
    from ..conjunctions.probability import encounter_inputs
    from .timeframes import time_to_epochs

    if not isinstance(tca, Time) or not tca.isscalar:
        raise InvalidInputError(f"tca must be one astropy Time; got {tca!r:.80}.")
    frame = _text(frame, "frame").upper()
    if frame not in INERTIAL_FRAMES:
        raise InvalidInputError(
            f"frame = {frame!r}: the states and covariances of a CDM built here are inertial; "
            f"use one of {', '.join(INERTIAL_FRAMES)} (rotate Earth-fixed states first)."
        )
    r1, v1, c1, r2, v2, c2, _ = encounter_inputs(r1, v1, cov1, r2, v2, cov2, 0.0)
    for c, name in ((c1, "cov1"), (c2, "cov2")):
        if c.shape != (6, 6):
            raise InvalidInputError(f"{name} is {c.shape[0]}x{c.shape[1]}: a CDM carries the "
                                    "6x6 position-velocity covariance (m, m/s).")
    names = [_text(n, "names") for n in names]
    designators = [_text(d, "designators") for d in designators]
    if len(names) != 2 or len(designators) != 2:
        raise InvalidInputError("names and designators each need two entries (object 1, 2).")
    if collision_probability is not None:
        pc = float(collision_probability)
        if not 0.0 <= pc <= 1.0:
            raise InvalidInputError(f"collision_probability must lie in [0, 1]; got {pc}.")
    epoch = time_to_epochs(tca, "UTC")[0]
    q = rtn_basis(r1 / 1e3, v1 / 1e3)  # object 1's RTN axes (rows)
    dr, dv = q @ (r2 - r1), q @ (v2 - v1)
    relative = {"TCA": epoch, "MISS_DISTANCE": float(np.linalg.norm(r2 - r1)),
                "RELATIVE_SPEED": float(np.linalg.norm(v2 - v1))}
    for k, axis in enumerate("RTN"):
        relative[f"RELATIVE_POSITION_{axis}"] = float(dr[k])
    for k, axis in enumerate("RTN"):
        relative[f"RELATIVE_VELOCITY_{axis}"] = float(dv[k])
    if collision_probability is not None:
        relative["COLLISION_PROBABILITY"] = pc
        if collision_probability_method is not None:
            relative["COLLISION_PROBABILITY_METHOD"] = _text(collision_probability_method,
                                                             "collision_probability_method")
    objects = {}
    for k, (r, v, c) in enumerate(((r1, v1, c1), (r2, v2, c2))):
        rtn = inertial_to_rtn(c, r / 1e3, v / 1e3)
        state = dict(zip(("X", "Y", "Z", "X_DOT", "Y_DOT", "Z_DOT"),
                         map(float, np.concatenate([r, v]) / 1e3), strict=True))
        objects[f"object{k + 1}"] = {
            "metadata": {"OBJECT": f"OBJECT{k + 1}", "OBJECT_DESIGNATOR": designators[k],
                         "CATALOG_NAME": "SATCAT", "OBJECT_NAME": names[k],
                         "INTERNATIONAL_DESIGNATOR": "UNKNOWN", "EPHEMERIS_NAME": "NONE",
                         "COVARIANCE_METHOD": "CALCULATED", "MANEUVERABLE": "N/A",
                         "REF_FRAME": frame},
            "state_vector": state,
            "covariance": {name: float(rtn[i, j]) for name, i, j in cov_keywords},
        }
    header = {"CCSDS_CDM_VERS": "1.0", "CREATION_DATE": Time.now().utc.isot,
              "ORIGINATOR": _text(originator, "originator"),
              "MESSAGE_ID": _text(message_id if message_id is not None
                                  else f"{names[0]}-{names[1]}-{epoch}", "message_id")}
    return {"header": header, "relative": relative, **objects}

