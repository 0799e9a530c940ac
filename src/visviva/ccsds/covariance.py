"""The 6 x 6 position-velocity covariance as CCSDS writes it: 21 lower-triangle keywords.

Keyword ``C<row>_<column>`` over (X, Y, Z, X_DOT, Y_DOT, Z_DOT), e.g. ``CX_X``, ``CY_DOT_X``,
``CZ_DOT_Z_DOT``; units km**2 (position-position), km**2/s (velocity-position), km**2/s**2
(velocity-velocity). The OEM's KVN writes the same lower triangle as six rows of 1..6 numbers.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError
from .grammar import CCSDSFormatError, Keyword

__all__ = ["AXES", "COVARIANCE_KEYWORDS", "matrix_from_values", "values_from_matrix",
           "matrix_from_rows", "check_variance", "check_record_variances", "on_state_axes",
           "ORBIT_RELATIVE_FRAMES", "local_frame", "from_state_axes"]

AXES = ("X", "Y", "Z", "X_DOT", "Y_DOT", "Z_DOT")


#: SANA's orbit-relative reference frames (the ``COV_REF_FRAME`` values of CCSDS 502.0-B-3)
#: visviva reads: name -> (axes, rotating). ``*_INERTIAL`` is the quasi-inertial form (the
#: velocity block rotated like the position block), ``*_ROTATING`` takes the frame's rotation
#: ``omega = (r x v)/|r|**2`` into the velocity block (:func:`visviva._covariance.local_jacobian`).
#: The plain names RTN/RSW/RIC/QSW, TNW, VNB are read quasi-inertial, as the CDM defines RTN
#: (docs/design.md, "RTN / TNW covariances").
ORBIT_RELATIVE_FRAMES = {"RSW_INERTIAL": ("RTN", False), "RSW_ROTATING": ("RTN", True),
                         "TNW_INERTIAL": ("TNW", False), "TNW_ROTATING": ("TNW", True)}


def local_frame(name) -> tuple[int, bool] | None:
    """``(code, rotating)`` of a local orbital frame named in a message, None for another name.

    Parameters
    ----------
    name : str
        ``COV_REF_FRAME`` as written: a SANA name (``RSW_ROTATING``, ``TNW_INERTIAL`` ...) or
        a plain one (``RTN``, ``RSW``, ``RIC``, ``QSW``, ``TNW``, ``VNB``: quasi-inertial).

    Returns
    -------
    tuple of (int, bool) or None
        The :mod:`visviva.core.local_frames` code and whether the frame rotates.
    """
    from ..core.local_frames import FRAME_CODES

    key = str(name).strip().upper()
    if key in ORBIT_RELATIVE_FRAMES:
        axes, rotating = ORBIT_RELATIVE_FRAMES[key]
        return FRAME_CODES[axes], rotating
    if key in FRAME_CODES:
        return FRAME_CODES[key], False
    return None


def _local_names() -> str:
    from ..core.local_frames import FRAME_CODES

    return ", ".join(sorted(FRAME_CODES) + sorted(ORBIT_RELATIVE_FRAMES))


def _unit(i: int, j: int) -> str:
    return ("km**2", "km**2/s", "km**2/s**2")[(i >= 3) + (j >= 3)]


#: the 21 keywords in CCSDS order (row by row of the lower triangle)
COVARIANCE_KEYWORDS = tuple(
    Keyword(f"C{AXES[i]}_{AXES[j]}", "float", _unit(i, j), True)
    for i in range(6) for j in range(i + 1))
_INDEX = tuple((i, j) for i in range(6) for j in range(i + 1))


def matrix_from_values(values) -> np.ndarray:
    """The symmetric 6 x 6 matrix from a mapping of the 21 keywords.

    Parameters
    ----------
    values : mapping
        ``CX_X`` ... ``CZ_DOT_Z_DOT`` -> float (km, km/s based units).

    Returns
    -------
    ndarray, shape (6, 6)
    """
    return matrix_from_rows([values[k.name] for k in COVARIANCE_KEYWORDS])


def matrix_from_rows(lower) -> np.ndarray:
    """The symmetric 6 x 6 matrix from the 21 lower-triangle numbers, row by row.

    Parameters
    ----------
    lower : sequence of float
        21 numbers.

    Returns
    -------
    ndarray, shape (6, 6)
    """
    m = np.zeros((6, 6))
    for (i, j), value in zip(_INDEX, lower, strict=True):
        m[i, j] = m[j, i] = value
    return m


def values_from_matrix(matrix) -> dict:
    """The 21 keywords of a 6 x 6 matrix (its lower triangle).

    Parameters
    ----------
    matrix : array_like, shape (6, 6)
        Covariance in km and km/s.

    Returns
    -------
    dict
    """
    m = np.asarray(matrix, dtype=np.float64)
    return {k.name: float(m[i, j]) for k, (i, j) in zip(COVARIANCE_KEYWORDS, _INDEX, strict=True)}


def check_variance(value: float, axis: int, line, source: str) -> None:
    """Raise unless a diagonal element (a variance) is >= 0.

    Parameters
    ----------
    value : float
        The variance as read (km**2 or km**2/s**2).
    axis : int
        0..5 over (X, Y, Z, X_DOT, Y_DOT, Z_DOT).
    line : int or None
        Line it was read from, for the message.
    source : str
        File name, for the message.
    """
    if value < 0:
        name = f"C{AXES[axis]}_{AXES[axis]}"
        raise CCSDSFormatError(
            f"{name} = {value!r} is a variance (the square of a standard deviation) and cannot be "
            "negative; the covariance is corrupted (check the sign and the row order)",
            line=line, source=source)


def check_record_variances(record, source: str) -> None:
    """:func:`check_variance` on the six diagonal keywords of a section as read.

    Parameters
    ----------
    record : Record
        The covariance section (``CX_X`` ... ``CZ_DOT_Z_DOT``), with its lines.
    source : str
        File name, for the message.
    """
    for axis, a in enumerate(AXES):
        key = f"C{a}_{a}"
        if key in record:
            check_variance(record[key], axis, record.line_of(key), source)


def on_state_axes(matrix, cov_frame, ref_frame, state_frame, r, v, where, raw):
    """A covariance written in ``COV_REF_FRAME = cov_frame`` on the axes of its state.

    A local orbital frame of the state (``RTN``/``RSW``/``RIC``/``QSW``, ``TNW``, ``VNB``,
    SANA's ``RSW_INERTIAL``, ``TNW_INERTIAL``) is rotated to the state's axes (the velocity
    block as the position block, the CCSDS convention); ``RSW_ROTATING`` / ``TNW_ROTATING``
    add the frame's rotation to the velocity block (:func:`visviva._covariance.local_jacobian`);
    ``REF_FRAME`` itself, or another name of the same axes, is kept.

    Parameters
    ----------
    matrix : ndarray (6, 6)
        The covariance as written (km, km/s).
    cov_frame : str or None
        ``COV_REF_FRAME`` (None: ``REF_FRAME``).
    ref_frame : str
        The message's ``REF_FRAME``.
    state_frame : str or None
        visviva's name of ``REF_FRAME`` (``"itrs"`` for Earth-fixed axes).
    r, v : ndarray (3,)
        The state the local frame belongs to (km, km/s).
    where : str
        Where the keyword is, for messages (source, line, keyword).
    raw : str
        How the user reaches the matrix as written, for messages.

    Returns
    -------
    ndarray (6, 6)

    Raises
    ------
    InvalidInputError
        Another frame than ``REF_FRAME`` and no local frame, or a local frame of a state on
        Earth-fixed axes (ITRF, GRC, TDR, GTOD ...: its velocity does not give the orbital
        axes).
    """
    if cov_frame is None or str(cov_frame).strip().upper() == str(ref_frame).strip().upper():
        return matrix
    from .._covariance import from_local
    from .timeframes import earth_fixed, visviva_frame

    key = str(cov_frame).strip().upper()
    local = local_frame(key)
    if local is None:
        if visviva_frame(key) is not None and visviva_frame(key) == state_frame:
            return matrix  # (EME2000 / GCRF / ICRF: one set of axes within 23 mas)
        raise InvalidInputError(
            f"{where} is neither REF_FRAME = {ref_frame} nor a local orbital frame "
            f"({_local_names()}); rotate {raw} to the state's axes yourself.")
    if state_frame == "itrs" or earth_fixed(ref_frame):  # (GRC, TDR, GTOD: Earth-fixed too)
        raise InvalidInputError(
            f"{where} of a state on Earth-fixed axes ({ref_frame}): its Earth-fixed velocity "
            f"does not give the orbital axes; rotate the state and {raw} to an inertial frame "
            "first.")
    return from_local(matrix, np.asarray(r, dtype=np.float64), np.asarray(v, dtype=np.float64),
                      *local)


def from_state_axes(matrix, cov_frame, r, v) -> np.ndarray:
    """A covariance on the axes of its state written in local frame ``cov_frame`` (the inverse
    of :func:`on_state_axes`, for writing ``COV_REF_FRAME = cov_frame``).

    Parameters
    ----------
    matrix : ndarray (6, 6)
        Covariance on the state's (inertial) axes, km and km/s.
    cov_frame : str
        A local orbital frame (:func:`local_frame`): ``RTN``, ``TNW``, ``RSW_ROTATING`` ...
    r, v : ndarray (3,)
        The state (km, km/s).

    Returns
    -------
    ndarray (6, 6)

    Raises
    ------
    InvalidInputError
        ``cov_frame`` names no local orbital frame.
    """
    from .._covariance import to_local

    local = local_frame(cov_frame)
    if local is None:
        raise InvalidInputError(f"covariance_frame = {cov_frame!r} is not a local orbital "
                                f"frame; use one of {_local_names()} (or None: the state's "
                                "axes).")
    return to_local(np.asarray(matrix, dtype=np.float64), np.asarray(r, dtype=np.float64),
                    np.asarray(v, dtype=np.float64), *local)

