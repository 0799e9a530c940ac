"""Input checks shared by the central-force functions (units, signs, callables)."""

from __future__ import annotations

import math

import numpy as np

from .._units import (
    broadcast_or_raise,
    require_finite_result,
    to_array,
)
from ..errors import InvalidInputError, fmt_number


def _positive(arr, name):
    if np.any(arr <= 0):
        raise InvalidInputError(f"{name} must be > 0; got {fmt_number(np.min(arr))}.")
    return arr


def _positive_array(value, kind, name):
    """``value`` converted by :func:`visviva._units.to_array` (unit ``kind``) and checked > 0."""
    return _positive(to_array(value, kind, name), name)


def _gm(gm):
    return _positive_array(gm, "gm", "gm")




def _gm_broadcast(context, gm, **arrays):
    """The gravitational parameter (km3 / s2, > 0), checked to broadcast against ``arrays``.

    Parameters
    ----------
    context : str
        The calling function, named in the ShapeError.
    gm : Quantity (km3 / s2) or Body
        Gravitational parameter.
    **arrays : ndarray
        The other converted arguments, in the order of the call's signature.

    Returns
    -------
    ndarray
        gm in km3 / s2.
    """
    gm = _gm(gm)
    broadcast_or_raise(context, **arrays, gm=gm)
    return gm


def _finite_result(arr, context):
    """Raise DomainError if a result overflowed (or underflowed into a division by zero)."""
    return require_finite_result(arr, context, remedy="Rescale them (other units, or G = M = 1).")


def _real(value, name):
    """A finite Python float from a plain number (for callables built from parameters)."""
    try:
        x = float(value)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name} must be a real number; got {fmt_number(value)}.") from exc
    if not math.isfinite(x):
        raise InvalidInputError(f"{name} must be finite; got {fmt_number(x)}.")
    return x


def _callable(fn, name):
    if not callable(fn):
        raise InvalidInputError(
            f"{name} must be a callable, e.g. kepler_potential(gm) or lambda r: -1.0 / r; got "
            f"{type(fn).__name__}."
        )


# --------------------------------------------------------------------------------------------
# The Kepler problem
