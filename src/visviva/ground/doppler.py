"""Doppler shift of a radio signal from the range rate, for one-way links.

``delta_f = -f * range_rate / c`` (first order in ``beta = range_rate / c``; the second-order
terms, relativistic and light-time, are below ``beta^2 ~ 6e-10`` of ``f`` for a LEO satellite,
about 1 Hz at 2 GHz). A satellite approaching the station (``range_rate < 0``) is received high.
"""

from __future__ import annotations

import numpy as np
from astropy import units as u

from .._units import to_array
from ..errors import DomainError

__all__ = ["doppler_shift", "SPEED_OF_LIGHT_KM_S"]

#: speed of light in vacuum, km/s (exact, SI 2019)
SPEED_OF_LIGHT_KM_S = 299_792.458


def doppler_shift(frequency, range_rate):
    """Doppler shift of a one-way signal received at a station.

    Parameters
    ----------
    frequency : Quantity (frequency)
        Transmitted frequency (e.g. 437.8 MHz), > 0; any shape broadcasting with
        ``range_rate``.
    range_rate : Quantity (speed)
        Rate of change of the station-satellite distance (km/s; negative when approaching),
        e.g. ``look.range_rate``.

    Returns
    -------
    Quantity (Hz)
        ``received - transmitted`` frequency.

    Notes
    -----
    ``delta_f = -f rdot / c`` (e.g. Montenbruck & Gill 2000, sec. 6.3.2, to first order). For
    the two-way (up- and downlink) shift of a transponder double it.

    Examples
    --------
    >>> from astropy import units as u
    >>> from visviva.ground import doppler_shift
    >>> print(f"{doppler_shift(437.8 * u.MHz, -7.0 * u.km / u.s).to(u.kHz):.3f}")
    10.222 kHz
    """
    from .. import errors

    if not (hasattr(frequency, "unit") and frequency.unit.physical_type == "frequency"):
        raise errors.UnitsError(
            f"frequency must be a Quantity in Hz (e.g. 437.8 * u.MHz), got {frequency!r}.")
    f_hz = np.asarray(frequency.to_value(u.Hz), dtype=np.float64)
    if not np.all(f_hz > 0) or not np.all(np.isfinite(f_hz)):
        raise DomainError(f"frequency must be positive and finite, got {frequency!r}.")
    rr = to_array(range_rate, "speed", "range_rate")
    try:
        np.broadcast_shapes(f_hz.shape, rr.shape)
    except ValueError:
        from ..errors import ShapeError

        raise ShapeError(f"frequency of shape {f_hz.shape} and range_rate of shape {rr.shape} "
                         "do not broadcast; give one frequency, or one per range rate.") from None
    return (-f_hz * rr / SPEED_OF_LIGHT_KM_S) * u.Hz
