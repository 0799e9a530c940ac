"""The 6 x 6 position-velocity covariance as CCSDS writes it: 21 lower-triangle keywords.

Keyword ``C<row>_<column>`` over (X, Y, Z, X_DOT, Y_DOT, Z_DOT), e.g. ``CX_X``, ``CY_DOT_X``,
``CZ_DOT_Z_DOT``; units km**2 (position-position), km**2/s (velocity-position), km**2/s**2
(velocity-velocity). The OEM's KVN writes the same lower triangle as six rows of 1..6 numbers.
"""

from __future__ import annotations

import numpy as np

from .grammar import CCSDSFormatError, Keyword

__all__ = ["AXES", "COVARIANCE_KEYWORDS", "matrix_from_values", "values_from_matrix",
           "matrix_from_rows", "check_variance", "check_record_variances"]

AXES = ("X", "Y", "Z", "X_DOT", "Y_DOT", "Z_DOT")


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
