"""Helpers shared by the two-body containers (:mod:`visviva.states`, :mod:`visviva.elements`).

Shapes, the gravitational parameter, epochs and indexing: each check written once, raising the
typed exceptions of :mod:`visviva.errors` with a message that says what to do.
"""

from __future__ import annotations

import numpy as np

from .errors import InvalidInputError, ShapeError, fmt_number

__all__ = ["broadcast_shape", "gm_positive", "validate_epoch", "flat", "normalise_key", "index_epoch"]


def broadcast_shape(named_shapes: dict[str, tuple], what: str) -> tuple:
    """Common leading shape of the arguments, or a ShapeError naming them."""
    try:
        return np.broadcast_shapes(*named_shapes.values())
    except ValueError:
        listing = ", ".join(f"{k} {v}" for k, v in named_shapes.items())
        raise ShapeError(
            f"{what}: the leading shapes do not broadcast ({listing}). Give every argument the "
            "same leading shape, e.g. (N,) per orbit and (N, 3) per vector, or use scalars "
            "for values shared by all items."
        ) from None


def gm_positive(gm: np.ndarray) -> None:
    if not np.all(gm > 0):
        bad = np.asarray(gm)[~(np.asarray(gm) > 0)].ravel()[0]
        raise InvalidInputError(
            f"gm must be > 0 (the gravitational parameter of the central body); got {fmt_number(bad)} "
            "km3/s2. Pass e.g. gm=vv.EARTH.gm or gm=398600.4418 * u.km**3 / u.s**2."
        )


def validate_epoch(epoch):
    if epoch is None:
        return None
    from astropy.time import Time

    if not isinstance(epoch, Time):
        raise InvalidInputError(
            f"epoch must be an astropy.time.Time or None; got {type(epoch).__name__} "
            f"{epoch!r}. Pass e.g. epoch=Time('2024-01-01T12:00:00', scale='utc')."
        )
    return epoch


def flat(arr: np.ndarray, shape: tuple) -> np.ndarray:
    """``arr`` broadcast to ``shape`` and flattened to 1-D (a view where numpy allows)."""
    return np.broadcast_to(arr, shape).reshape(-1)


def normalise_key(key, shape: tuple, cls_name: str) -> tuple:
    if shape == ():
        raise TypeError(f"a scalar {cls_name} cannot be indexed (its shape is ())")
    if not isinstance(key, tuple):
        key = (key,)
    n_index = sum(1 for k in key if k is not None and k is not Ellipsis)
    if n_index > len(shape):
        raise IndexError(
            f"too many indices for {cls_name} of shape {shape}: index the leading axes only "
            "(the xyz axis of r and v is not indexable here; use .r[..., 0] for x)"
        )
    return key


def index_epoch(epoch, key, shape):
    if epoch is None:
        return None
    if np.shape(epoch) == shape and shape != ():
        return epoch[key]
    return epoch
