"""Atmospheric refraction of elevations: optical (light) and radio (antennas).

A ray from a target reaches a station bent down towards the denser air below, so the target
appears higher than its geometric elevation ``E`` by the refraction ``R(E)``. Two models:

* ``"optical"`` (light, the default): Sæmundsson's formula (Meeus 1998, eq. 16.4) scaled by
  Meeus' factor ``(P / 1010 hPa) (283 K / T)``; water vapour hardly bends light.
* ``"radio"`` (antennas): the bending integral (Bean & Dutton 1966, eq. 3.24; ITU-R P.834-9
  sec. 1) through the exponential refractivity profile of ITU-R P.453-14 and P.834-9
  (``n(z) = 1 + N_s 1e-6 exp(-0.1361 z / km)`` above the station), with the station's surface
  refractivity ``N_s`` from its pressure, temperature and humidity (Smith-Weintraub,
  :func:`visviva.ground.air.radio_refractivity`): water vapour adds 10-20 % to a radio
  refractivity, so an antenna at sea level sees 0.58 deg of bending at the horizon in the
  ITU-R reference atmosphere (0.577 deg in the standard air with 50 % humidity) where the
  optical formula gives 0.48 deg.

Both are the bending of a ray from a target far outside the atmosphere (a star); a satellite at
a finite range is offset less, by the bent ray's lever arm over the range (``range_km=``,
:mod:`visviva.ground.finite_range`: 500 km up 0.947 of the bending at the horizon, 0.968 at
5 deg, 0.977 at 10 deg; GEO 0.997). Both are zero below their lower end: -1 deg of geometric
elevation for the optical formula; for the radio model the geometric elevation seen at -1 deg
apparent (-2.37 deg at sea level in the standard air, -3.0 deg in tropical air), so that the
bending of hot, humid air (1.0 deg at -1 deg geometric for 31 deg C, 80 %) is never cut off
above the horizon.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InvalidInputError
from .air import (
    AIR_KEYS,
    Weather,
    check_air,
    check_humidity,
    radio_refractivity,
    saturation_vapour_hpa,
)
from .radioray import radio_bending_deg, radio_table  # noqa: F401 (radio_bending_deg: re-export)

__all__ = ["refraction_deg", "refraction_slope", "station_air", "bend", "lowest_geometric_deg"]

#: Above this surface refractivity an exponential profile with the P.453 decay traps rays
#: (ducting: dN/dz < -157 per km) and the model stops meaning anything.
_MAX_RADIO_N = 1000.0
#: Highest pressure refraction_deg takes (hPa): above the densest real air (1085 hPa), room
#: for a synthetic air (the ITU-R reference N_s = 315 dry is 1170 hPa at 15 deg C); a value in
#: Pa (1e4 and up) is refused.
_MAX_HPA = 1500.0
#: Lowest geometric elevation the models cover (deg); the refraction is 0 below.
_LOWEST_DEG = -1.0


def refraction_deg(elevation_deg, pressure_hpa=1010.0, temperature_c=10.0, *,
                   relative_humidity=0.5, model: str = "optical", range_km=None):
    """Atmospheric refraction to add to a geometric elevation (deg).

    Parameters
    ----------
    elevation_deg : float, array_like or Quantity (angle)
        Geometric elevation in [-90, 90] deg: plain numbers in degrees, or an angle Quantity
        (converted). NaN or infinite values are refused.
    pressure_hpa : float
        Air pressure at the site, hPa, in [0, 1500] (default 1010; 0: no air). A plain number:
        a value in Pa is refused.
    temperature_c : float
        Air temperature at the site, deg C, in [-90, 60] (default 10; a value in K is
        refused).
    relative_humidity : float
        Relative humidity at the site, a fraction in [0, 1] (default 0.5; a percentage such as
        70 is refused). Used by the radio model only.
    model : {"optical", "radio"}
        ``"optical"`` (default): Sæmundsson's formula for light. ``"radio"``: the bending of a
        radio ray through the exponential refractivity profile of ITU-R P.453/P.834 with the
        site's surface refractivity (antennas; humid air bends radio waves 10-20 % more).
    range_km : float, array_like or Quantity (length), optional
        The target's range (km, broadcast with ``elevation_deg``; > 0): the offset of a
        satellite at that range, less than a star's by the bent ray's lever arm
        (:mod:`visviva.ground.finite_range`: 0.95 of it at the horizon 500 km up, 0.97 at
        5 deg). Default: a target at infinity (a star). A target less than 1 km above the
        station is refused.

    Returns
    -------
    ndarray (deg), or Quantity (deg) for a Quantity ``elevation_deg``
        ``>= 0``, decreasing with the elevation, 0 below the model's lower end (optical:
        -1 deg; radio: the geometric elevation seen at -1 deg apparent).

    Notes
    -----
    Optical: Sæmundsson's formula (Meeus 1998, *Astronomical Algorithms*, eq. 16.4) with
    Meeus' zenith term: ``R = 1.02' / tan(h + 10.3 / (h + 5.11)) + 0.0019279'`` (0 at ``h`` =
    90 deg) with ``h`` the geometric elevation in degrees, scaled by ``(P / 1010 hPa)
    (283 K / T)``. Consistent with Bennett's inverse formula to 0.07'.

    Radio: the total bending of a ray leaving the station at the apparent elevation
    ``theta`` (Bean & Dutton 1966, *Radio Meteorology*, eq. 3.24; ITU-R P.834-9 sec. 1),
    ``tau(theta) = -int n'(r) / n(r) cot(phi) dr`` from the station up, with Snell's law
    ``n r cos(phi) = n_s r_s cos(theta)``, through ``n = 1 + N_s 1e-6 exp(-0.1361 z/km)``
    (z above the station; the ITU-R reference atmosphere's profile, P.453-14 eq. 8, scaled to
    the station's surface refractivity ``N_s = 77.6 / T (P + 4810 e / T)``, P.453-14 eq. 6,
    ``e`` the vapour pressure at the given humidity), integrated by Gauss-Legendre
    quadrature in ``s = sqrt(n^2 r^2 - n_s^2 r_s^2 cos^2 theta)`` (which removes the
    horizon's square-root singularity) to 1e-10 relative, and turned into a function of the
    geometric elevation ``E = theta - tau`` by a cubic spline over 500 apparent elevations
    (within 1e-7 deg of the integral; one table per air, 9 ms, cached). For the ITU-R
    reference atmosphere (``N_s = 315`` at sea level) it gives 0.583 deg at ``E = 0`` where
    P.834-9's fit in the geometric elevation (eq. 14) gives 0.579 deg; that fit stays within
    5 % of the integral from 0 to 5 deg for stations up to 4 km and is meant for low
    elevations only: above 10 deg the integral follows the textbook ``(n_s - 1) cot(theta)``
    (0.018 deg at 45 deg for ``N_s = 315``; eq. 14 gives 0.011 deg there).

    Examples
    --------
    >>> from visviva.ground import refraction_deg
    >>> print(f"{float(refraction_deg(0.0)):.3f} deg")
    0.483 deg
    >>> radio = refraction_deg(0.0, 1013.25, 15.0, relative_humidity=0.5, model="radio")
    >>> print(f"{float(radio):.3f} deg")
    0.577 deg
    """
    from astropy import units as u

    h, quantity = _elevations_deg(elevation_deg)
    out = bend(h, model, pressure_hpa, temperature_c, relative_humidity,
               _check_range(range_km))[0]
    return out * u.deg if quantity else out


def refraction_slope(elevation_deg, pressure_hpa=1010.0, temperature_c=10.0, *,
                     relative_humidity=0.5, model: str = "optical", range_km=None):
    """dR/dE of :func:`refraction_deg` (deg of refraction per deg of geometric elevation,
    negative: optical -0.02 at 5 deg, -0.04 at 2.5 deg), 0 below the model's lower end where
    the refraction is 0.

    Parameters
    ----------
    elevation_deg : float, array_like or Quantity (angle)
        Geometric elevation in [-90, 90] deg: plain degrees or an angle Quantity (converted;
        NaN refused).
    pressure_hpa, temperature_c, relative_humidity, model, range_km
        The site's air, the model and the target's range, as :func:`refraction_deg` (the
        slope at a fixed range).

    Returns
    -------
    ndarray
        The slope; ``1 + slope`` maps a change of geometric elevation (or its rate) to the
        apparent one.
    """
    h = _elevations_deg(elevation_deg)[0]
    return bend(h, model, pressure_hpa, temperature_c, relative_humidity,
                _check_range(range_km))[1]


def _check_range(range_km):
    """``range_km`` as float km (None stays None): a length Quantity converted; finite and
    positive."""
    if range_km is None:
        return None
    from .._units import is_quantity, to_array

    rng = (to_array(range_km, "length", "range_km") if is_quantity(range_km)
           else np.asarray(range_km, dtype=np.float64))
    if not np.all(np.isfinite(rng) & (rng > 0.0)):
        raise InvalidInputError("range_km must be finite and positive (km); omit it for a "
                                "target at infinity (a star).")
    return rng


def bend(elevation_deg, model, pressure_hpa, temperature_c, relative_humidity,
         range_km=None, range_slope=False, exact_slope=True):
    """Refraction (deg) and its slope dR/dE at geometric elevations ``elevation_deg`` (deg,
    ndarray), for the checked air; NaN elevations stay NaN (look() on NaN geometry). With
    ``range_km`` (km, broadcast): the offset of a target at that range
    (:mod:`visviva.ground.finite_range`), and its slope at a fixed range; ``range_slope``
    adds a third output, dR/d range (deg per km; zeros without ``range_km``). ``exact_slope``
    False (a Newton step's slope): at a range, the star's slope times the range's share
    (without the share's own change: 5x cheaper)."""
    h = np.asarray(elevation_deg, dtype=np.float64)
    if model == "optical":
        scale = _meeus_factor(pressure_hpa, temperature_c)
        check_humidity(relative_humidity)
        r, slope = _saemundsson_arcmin(h)
        r, slope = r * scale / 60.0, slope * scale / 60.0
        low = _LOWEST_DEG
    elif model == "radio":
        table = radio_table(_surface_refractivity(pressure_hpa, temperature_c,
                                                   relative_humidity))
        if table is None:  # no air
            r = slope = np.zeros_like(h)
            low = _LOWEST_DEG
        else:
            spline, low = table  # down to the apparent elevation of -1 deg
            hh = np.clip(h, low, 90.0)
            r, slope = spline(hh), np.where(h < low, 0.0, spline(hh, 1))
    else:
        raise InvalidInputError(
            f"model must be 'optical' (light: Saemundsson's formula) or 'radio' (antennas); "
            f"got {model!r}.")
    below = h < low
    nan = np.isnan(h)
    # >= 0: the fits reach the zenith within 1e-9 deg, on either side
    r = np.where(below, 0.0, np.maximum(r, 0.0))
    slope = np.where(below, 0.0, slope)
    d_range = np.zeros_like(r)
    if range_km is not None:
        r, slope, d_range = _at_range(h, r, slope, range_km, model, pressure_hpa,
                                      temperature_c, relative_humidity,
                                      exact_slope or range_slope, low)
        nan = np.broadcast_to(nan, r.shape)
    out = np.where(nan, np.nan, r), np.where(nan, np.nan, slope)
    return (*out, np.where(nan, np.nan, d_range)) if range_slope else out


def _at_range(h, r, slope, range_km, model, pressure_hpa, temperature_c, relative_humidity,
              slopes=True, low=-1.0):
    """``r`` and ``slope`` (of a target at infinity) for targets at ``range_km``: times the
    share ``k`` of :func:`visviva.ground.finite_range.range_factor`, traced through the
    station's radio refractivity, or the dry one for light."""
    from .finite_range import range_factor

    h, rng = np.broadcast_arrays(h, np.asarray(range_km, dtype=np.float64))
    r, slope = np.broadcast_to(r, h.shape).copy(), np.broadcast_to(slope, h.shape).copy()
    d_range = np.zeros(h.shape)
    if model == "radio":
        n_ray = _surface_refractivity(pressure_hpa, temperature_c, relative_humidity)
    else:
        p, t = _check_pt(pressure_hpa, temperature_c)
        n_ray = float(radio_refractivity(p, t + 273.15, 0.0))
    table = radio_table(n_ray)
    on = np.isfinite(h) & (h >= low)
    if table is None or not on.any():
        return r, slope, d_range
    k, dk, dk_range = range_factor(h[on], rng[on], n_ray, table[0], slopes)
    slope[on] = slope[on] * k + r[on] * dk
    d_range[on] = r[on] * dk_range
    r[on] = r[on] * k
    return r, slope, d_range


def station_air(refraction, height_m):
    """look()'s ``refraction`` argument at a station ``height_m`` above the ellipsoid: None
    (geometric) or ``(model, pressure_hpa, temperature_c, relative_humidity)``, the standard
    atmosphere at the height filling what a weather dict leaves out."""
    if refraction is None or refraction is False or refraction is np.False_:
        return None
    if refraction is True or refraction is np.True_:
        spec = {}
    elif isinstance(refraction, str):
        spec = {"refraction": refraction}
    elif isinstance(refraction, dict):
        spec = refraction
    else:
        raise InvalidInputError(
            "refraction must be False (geometric), True or 'optical' (light, the standard air "
            "at the station's height), 'radio' (antennas) or a weather dict of pressure_hpa, "
            "temperature_c, relative_humidity and refraction ('optical' or 'radio'), as "
            f"Observations(troposphere=...) takes; got {refraction!r}.")
    given, model = check_air(spec, "refraction")
    return (model, *Weather(given, model).conditions(height_m))


def lowest_geometric_deg(model, pressure_hpa, temperature_c, relative_humidity) -> float:
    """The lower end of a model's refraction (deg of geometric elevation; 0 refraction below):
    -1 deg for the optical formula, the geometric elevation seen at -1 deg apparent for the
    radio table (-1 deg without air)."""
    if model != "radio":
        return _LOWEST_DEG
    table = radio_table(_surface_refractivity(pressure_hpa, temperature_c, relative_humidity))
    return _LOWEST_DEG if table is None else float(table[1])


def _elevations_deg(elevation_deg):
    """``elevation_deg`` as float degrees (an angle Quantity converted: 0.1 rad is 5.73 deg,
    not 0.1 deg) and whether it was a Quantity; checked."""
    from .._units import is_quantity, to_array

    quantity = is_quantity(elevation_deg)
    if quantity:
        h = np.degrees(to_array(elevation_deg, "angle", "elevation_deg"))
    else:
        h = np.asarray(elevation_deg, dtype=np.float64)
    _check_elevations(h)
    return h, quantity


def _check_elevations(h) -> None:
    if not np.all(np.isfinite(h)):
        raise InvalidInputError(
            "elevation_deg has NaN or infinite values; pass finite geometric elevations in "
            "[-90, 90] deg.")
    if np.any(np.abs(h) > 90.0 + 1e-9):
        raise InvalidInputError(
            f"elevation_deg must be in [-90, 90] deg, got up to {float(np.max(np.abs(h))):.6g}: "
            "an elevation in degrees, not a zenith distance.")


def _check_pt(pressure_hpa, temperature_c) -> tuple[float, float]:
    """The site's pressure (hPa) and temperature (deg C) as floats: plain scalars in the ranges
    of a weather dict (:data:`visviva.ground.air.AIR_KEYS`; a pressure of 0 is no air). A
    pressure in Pa or a temperature in K is refused with a hint, not turned into a refraction
    100 times or 10 times off (the optical formula scales with P / T)."""
    return (_check_weather_value(pressure_hpa, "pressure_hpa", (0.0, _MAX_HPA)),
            _check_weather_value(temperature_c, "temperature_c"))


def _check_weather_value(value, key: str, bounds=None) -> float:
    from .._units import is_quantity

    lo, hi, unit = AIR_KEYS[key]
    lo, hi = (lo, hi) if bounds is None else bounds
    if is_quantity(value):
        raise InvalidInputError(
            f"{key} takes a plain number in {unit}, got the Quantity {value!r}; pass e.g. "
            f"value.to_value(u.{'hPa' if key == 'pressure_hpa' else 'deg_C'}"
            f"{'' if key == 'pressure_hpa' else ', equivalencies=u.temperature()'}).")
    if isinstance(value, bool | np.bool_) or np.ndim(value) != 0:
        raise InvalidInputError(f"{key} must be one number in {unit} (the site's air), got "
                                f"{value!r}.")
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    if not lo <= x <= hi:
        hint = ""
        if key == "pressure_hpa" and 1e4 <= x <= 1.1e5:
            hint = f" ({value!r} looks like Pa: pass {x / 100:g} hPa)"
        elif key == "temperature_c" and 173.15 <= x <= 333.15:
            hint = f" ({value!r} looks like kelvin: pass {x - 273.15:g} deg C)"
        raise InvalidInputError(
            f"{key} must be a finite number in [{lo:g}, {hi:g}] {unit}; got {value!r}{hint}.")
    return x


def _meeus_factor(pressure_hpa, temperature_c) -> float:
    """Meeus' factor ``(P / 1010 hPa) (283 K / T)`` for the site's air; checked."""
    p, t = _check_pt(pressure_hpa, temperature_c)
    return (p / 1010.0) * (283.0 / (273.0 + t))


def _surface_refractivity(pressure_hpa, temperature_c, relative_humidity) -> float:
    """The radio refractivity N of the site's air (checked)."""
    p, t = _check_pt(pressure_hpa, temperature_c)
    rh = check_humidity(relative_humidity)
    e = rh * float(saturation_vapour_hpa(t))
    if e > p:
        raise InvalidInputError(
            f"the water-vapour pressure ({e:.4g} hPa at {t:g} deg C and {rh:g} humidity) "
            f"exceeds the air pressure ({p:.4g} hPa): not air; check pressure_hpa and "
            "temperature_c (a pressure this low is above the atmosphere, where refraction "
            "means nothing: leave refraction off there, or pass relative_humidity=0).")
    n_s = float(radio_refractivity(p, t + 273.15, e))
    if n_s > _MAX_RADIO_N:
        raise InvalidInputError(
            f"the air's radio refractivity N = {n_s:.4g} ({p:.4g} hPa, {t:g} deg C) exceeds "
            f"{_MAX_RADIO_N:g}: an exponential profile that dense traps radio rays (ducting); "
            "check pressure_hpa (hPa, not Pa).")
    return n_s


def _saemundsson_arcmin(h):
    """Sæmundsson's refraction (arcmin, standard air) and its slope dR/dh (arcmin per deg) at
    geometric elevations ``h`` (deg); finite (not meaningful) below -1 deg."""
    with np.errstate(divide="ignore", invalid="ignore"):
        hh = np.where(h >= _LOWEST_DEG, h, 0.0)  # the formula's pole at -5.11 deg lies outside
        x = np.radians(hh + 10.3 / (hh + 5.11))
        r = 1.02 / np.tan(x) + 0.0019279
        slope = -1.02 / np.sin(x) ** 2 * (np.pi / 180.0) * (1.0 - 10.3 / (hh + 5.11) ** 2)
    return r, slope
