"""Visibility for visual observers: the satellite in sunlight, the observer in darkness, and an
estimated visual magnitude.

* **Sunlight.** The fraction of the Sun's disc seen from the satellite, conical shadow of a
  spherical Earth (Montenbruck & Gill 2000, sec. 3.4.2): the same function
  (:func:`visviva.core.perturbations.shadow_fraction`, model 2) as
  :func:`visviva.satellites.groundtrack.eclipse_fraction` and the conical
  :class:`~visviva.satellites.Eclipse` events, so ``fraction == 0`` is the umbra and
  ``0 < fraction < 1`` the penumbra. A satellite counts as *sunlit* when ``fraction > 0``.
* **Twilight.** The Sun's geometric elevation at the station: civil twilight ends at -6 deg,
  nautical at -12 deg, astronomical at -18 deg; ``station_dark`` means below -6 deg.
* **Magnitude.** ``m = m_std + 5 log10(range / 1000 km) - 2.5 log10(F(phi))`` with the phase
  law of a diffusely reflecting (Lambertian) sphere ``F(phi) = sin(phi) + (pi - phi) cos(phi)``,
  normalised to ``F(90 deg) = 1``, and ``phi`` the Sun-satellite-observer angle; ``m_std`` is
  the standard magnitude at 1000 km and 90 deg phase (McCants' convention, used by
  Heavens-Above). An estimate: real satellites glint, tumble and are not spheres.
"""

from __future__ import annotations

import numpy as np

from ..constants import R_EARTH_KM, R_SUN_KM

__all__ = ["DARK_SUN_ELEVATION_DEG", "sun_fraction", "sun_itrs_km", "sun_elevation_rad",
           "visual_magnitude", "twilight", "standard_magnitudes"]

#: Sun elevation below which the station counts as dark (end of civil twilight), deg
DARK_SUN_ELEVATION_DEG = -6.0


def sun_itrs_km(t_ref, t_s, earth) -> np.ndarray:
    """Geocentric Sun position in the Earth-fixed frame (km, shape ``t_s.shape + (3,)``).

    The Sun moves ~1 deg per day in GCRS: its position is tabulated every 10 min over the
    times (one ephemeris call), interpolated linearly (error < 1e-7 of the distance) and
    rotated to ITRS with ``earth`` (:class:`~visviva.ground.earthfixed.EarthFixedMap`).
    """
    from astropy import units as u

    from ..satellites.ephemeris import sun_position

    t_s = np.asarray(t_s, dtype=np.float64)
    if t_s.size == 0:
        return np.empty(t_s.shape + (3,))
    lo, hi = float(t_s.min()), float(t_s.max())
    grid = lo + np.arange(int(np.ceil((hi - lo) / 600.0)) + 2) * 600.0
    s = np.atleast_2d(sun_position(t_ref + grid * u.s).to_value("km"))
    sg = np.stack([np.interp(t_s, grid, s[:, c]) for c in range(3)], axis=-1)
    return earth.gcrs_positions_to_itrs(sg, t_s)


def sun_fraction(r_km, sun_km) -> np.ndarray:
    """Fraction of the solar disc seen from ``r_km`` (1 sunlit, 0 umbra); any common frame."""
    from ..satellites.groundtrack import shadow_fraction_many

    r = np.ascontiguousarray(np.reshape(r_km, (-1, 3)), dtype=np.float64)
    s = np.ascontiguousarray(np.reshape(sun_km, (-1, 3)), dtype=np.float64)
    out = np.empty(r.shape[0])
    shadow_fraction_many(r, s, R_EARTH_KM, R_SUN_KM, out)
    return out.reshape(np.shape(r_km)[:-1])


def sun_elevation_rad(site_km, up, sun_km) -> np.ndarray:
    """Geometric elevation of the Sun seen from sites (Earth-fixed positions and up vectors)."""
    d = np.asarray(sun_km) - np.asarray(site_km)
    return np.arcsin(np.clip(np.sum(d * up, axis=-1) / np.linalg.norm(d, axis=-1), -1.0, 1.0))


def twilight(sun_elevation_deg) -> np.ndarray:
    """``"day"``, ``"civil"``, ``"nautical"``, ``"astronomical"`` or ``"night"`` per value.

    ``sun_elevation_deg``: plain numbers in degrees, or an angle Quantity (converted). NaN
    is refused (``InvalidInputError``): it was labelled ``"day"`` (audit50).
    """
    from .._units import is_quantity, to_array
    from ..errors import InvalidInputError

    if is_quantity(sun_elevation_deg):
        e = np.degrees(to_array(sun_elevation_deg, "angle", "sun_elevation_deg",
                                finite=False))
    else:
        e = np.asarray(sun_elevation_deg, dtype=np.float64)
    if np.isnan(e).any():
        raise InvalidInputError(
            f"sun_elevation_deg has {int(np.isnan(e).sum())} NaN value(s), which have no "
            "twilight (NaN was labelled 'day'); remove or fill them before calling.")
    labels = np.array(["night", "astronomical", "nautical", "civil", "day"])
    return labels[np.digitize(e, [-18.0, -12.0, -6.0, -0.833])]


def standard_magnitudes(value, n: int) -> np.ndarray:
    """``standard_magnitude`` of :func:`visviva.find_passes` -> float64 array of ``n`` (mag).

    One number for every satellite or one per satellite, finite; a Quantity must be in mag.
    Anything else raises :class:`~visviva.errors.InvalidInputError` naming what is wrong.
    """
    from astropy import units as u

    from ..errors import InvalidInputError

    if isinstance(value, u.Quantity):
        if value.unit != u.mag and value.unit != u.dimensionless_unscaled:
            raise InvalidInputError(
                f"standard_magnitude has unit '{value.unit}'; give magnitudes (plain numbers "
                "or u.mag)."
            )
        value = value.value
    try:
        m = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidInputError(
            f"standard_magnitude must be a number or one number per satellite, got {value!r}."
        ) from None
    if m.ndim > 1 or (m.ndim == 1 and m.size != n):
        raise InvalidInputError(
            f"standard_magnitude must be one number, or one per satellite ({n}); got shape "
            f"{m.shape}."
        )
    flat = np.atleast_1d(m)
    if not np.all(np.isfinite(flat)):
        bad = int(np.flatnonzero(~np.isfinite(flat))[0])
        where = f"[{bad}]" if m.ndim else ""
        raise InvalidInputError(
            f"standard_magnitude{where} is {flat[bad]}, not a finite magnitude; give one for "
            "every satellite (a magnitude estimate needs it)."
        )
    return np.ascontiguousarray(np.broadcast_to(m, (n,)))


def visual_magnitude(standard_magnitude, range_km, phase_angle_rad,
                     sun_fraction=1.0) -> np.ndarray:
    """Estimated visual magnitude from a standard magnitude (1000 km, 90 deg phase).

    Parameters
    ----------
    standard_magnitude : float or ndarray
        Magnitude at 1000 km range and 90 deg phase angle (mag).
    range_km : ndarray or Quantity
        Observer-satellite distance: plain numbers in km, or a length Quantity (converted).
    phase_angle_rad : ndarray or Quantity
        Sun-satellite-observer angle: plain numbers in rad, or an angle Quantity (converted);
        0: fully lit as seen.
    sun_fraction : float or ndarray
        Fraction of the solar disc seen from the satellite, in [0, 1] (default 1: sunlit;
        :func:`sun_fraction`): in the penumbra the sunlight, and the satellite's brightness,
        falls with it, ``-2.5 log10(fraction)`` mag (a uniform disc; 2.5 mag at a tenth).

    Returns
    -------
    ndarray
        Magnitude (larger is fainter); ``inf`` at phase 180 deg (unlit side) and in the
        umbra (``sun_fraction`` 0).
    """
    from .._units import is_quantity, to_array

    phi = to_array(phase_angle_rad, "angle", "phase_angle_rad", finite=False)
    rng = to_array(range_km, "length", "range_km", allow_plain=True, finite=False)
    if is_quantity(standard_magnitude):
        standard_magnitude = standard_magnitude.value  # (mag)
    lit = np.asarray(sun_fraction, dtype=np.float64)
    if not np.all((lit >= 0.0) & (lit <= 1.0)):
        from ..errors import InvalidInputError

        raise InvalidInputError(
            f"sun_fraction must be in [0, 1] (the part of the solar disc seen), got {lit!r}.")
    f = np.sin(phi) + (np.pi - phi) * np.cos(phi)
    with np.errstate(divide="ignore"):
        return (np.asarray(standard_magnitude, dtype=np.float64)
                + 5.0 * np.log10(rng / 1000.0)
                - 2.5 * np.log10(np.where(f > 1e-12, f, 0.0))
                - 2.5 * np.log10(lit))
