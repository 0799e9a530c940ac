"""Lagrange and Hermite interpolation of tabulated states, vectorised over the query times.

The OEM names its interpolation (``INTERPOLATION = LAGRANGE`` or ``HERMITE``) and a degree n.
Following Orekit's reading of the OEM (a common convention among CCSDS users), both use the
n + 1 tabulated points nearest to each query time (a window centred on it, clamped to the ends):

* Lagrange: each component of position and of velocity is interpolated by the polynomial of
  degree n through the n + 1 points;
* Hermite: the position by the osculating polynomial of degree 2n + 1 that matches positions and
  velocities at the n + 1 points; the velocity by its derivative, or, when the file gives
  accelerations, by the Hermite polynomial through velocities and accelerations.

The arithmetic lives in :mod:`visviva.core.interpolation` (the screening of ephemerides uses it
too); this module adds the OEM's names and the check of its method and degree.
"""

from __future__ import annotations

from ..core.interpolation import hermite, lagrange, windows
from ..errors import InvalidInputError

__all__ = ["windows", "lagrange", "hermite", "METHODS", "check_degree"]

METHODS = ("LAGRANGE", "HERMITE", "LINEAR")


def check_degree(method: str, degree: int, n_nodes: int, where: str) -> None:
    """Raise unless the method is known and the segment has enough states for the degree.

    Parameters
    ----------
    method : str
        ``"LAGRANGE"`` or ``"HERMITE"``.
    degree : int
        The interpolation degree.
    n_nodes : int
        Number of states in the segment.
    where : str
        Which segment, for the message.
    """
    if method not in METHODS:
        raise InvalidInputError(
            f"{where}: INTERPOLATION = {method} is not supported; visviva interpolates with "
            f"{' or '.join(METHODS)}.")
    if degree < 1:
        raise InvalidInputError(
            f"{where}: INTERPOLATION_DEGREE = {degree}: the degree of an interpolating polynomial "
            "is at least 1.")
    if n_nodes < 2:
        raise InvalidInputError(
            f"{where} holds one state, which no polynomial interpolates: use that state "
            "(seg.states[0]), or an OEM with at least two states per segment.")
    if degree + 1 > n_nodes:
        raise InvalidInputError(
            f"{where}: INTERPOLATION_DEGREE = {degree} needs {degree + 1} states, the segment "
            f"has {n_nodes}; use a degree between 1 and {n_nodes - 1}.")
