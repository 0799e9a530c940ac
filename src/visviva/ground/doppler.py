"""Doppler shift of a radio signal from the range rate, for one-way links, and the rate of a
link's light time.

``delta_f = -f * range_rate / c``. What it leaves out depends on which range rate is
passed. With the light-time range rate of ``look(light_time=True)`` (``d(c tau)/dt``,
:func:`light_time_rate`) it is the classical (Newtonian) one-way shift exactly, since
``f_r / f_e = 1 - d tau / d t_r``. The instantaneous (geometric) range rate differs from that
by the second-order light-time terms, about ``-v^2 / c``: -0.19 m/s for the ISS, 0.27 Hz at
437.8 MHz, 1.3 Hz at 2 GHz (docs/passes.md). Not modelled in either case: the relativistic
shifts, the transverse Doppler ``-v^2 / (2 c^2)`` and the gravitational ``Delta U / c^2``, each
below ``(v / c)^2 ~ 7e-10`` of ``f`` in LEO (under 0.3 Hz at 437.8 MHz). A satellite
approaching the station (``range_rate < 0``) is received high.
"""

from __future__ import annotations

import numpy as np
from astropy import units as u

from .._units import to_array
from ..errors import DomainError

__all__ = ["doppler_shift", "light_time_rate", "SPEED_OF_LIGHT_KM_S"]

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


def light_time_rate(unit, v_emitter, v_receiver):
    """Rate of a one-way link's light time with respect to the reception time, d tau / d t_r.

    Parameters
    ----------
    unit : ndarray (..., 3)
        Unit vector from the receiver at reception to the emitter at emission (inertial axes).
    v_emitter : ndarray (..., 3)
        The emitter's inertial velocity at the emission time ``t_r - tau``, km/s.
    v_receiver : ndarray (..., 3)
        The receiver's inertial velocity at the reception time ``t_r``, km/s.

    Returns
    -------
    ndarray (...)
        ``d tau / d t_r``, dimensionless (``c`` times it is the light-time range rate).

    Notes
    -----
    Differentiating ``c tau = |x_e(t_r - tau) - x_r(t_r)|``:
    ``d tau / d t_r = u . (v_e - v_r) / (c + u . v_e)`` (Montenbruck & Gill 2000, sec. 6.2.2,
    in any inertial frame, to first order in the Newtonian light path). The one-way Doppler
    ratio is ``f_r / f_e = 1 - d tau / d t_r``; a two-way link chains the up and down legs.
    """
    c = SPEED_OF_LIGHT_KM_S
    return (np.sum(unit * (v_emitter - v_receiver), axis=-1)
            / (c + np.sum(unit * v_emitter, axis=-1)))
