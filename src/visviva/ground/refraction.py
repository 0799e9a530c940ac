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

Both are the bending of a ray from a target far outside the atmosphere (a star; GEO sees 0.995
of it); a nearer target is offset less by the bent ray's lever arm over the range: a satellite
500 km up sees 0.93 of the bending at the horizon, 0.97 at 5 deg, 0.98 at 10 deg (a ray trace
of the radio profile). Both are zero below -1 deg of geometric elevation.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from ..errors import InvalidInputError
from .air import Weather, check_air, check_humidity, radio_refractivity, saturation_vapour_hpa

__all__ = ["refraction_deg", "refraction_slope", "station_air", "bend"]

#: Earth radius of ITU-R P.834-9 (km) and the refractivity's decay rate of its reference
#: atmosphere (P.453-14 eq. 8, P.834-9 eq. 8: ``N(h) = 315 exp(-0.1361 h)``), 1/km.
_EARTH_RADIUS_KM = 6370.0
_DECAY_PER_KM = 0.1361
#: Above this surface refractivity an exponential profile with the P.453 decay traps rays
#: (ducting: dN/dz < -157 per km) and the model stops meaning anything.
_MAX_RADIO_N = 1000.0
#: Lowest geometric elevation the models cover (deg); the refraction is 0 below.
_LOWEST_DEG = -1.0


def refraction_deg(elevation_deg, pressure_hpa=1010.0, temperature_c=10.0, *,
                   relative_humidity=0.5, model: str = "optical"):
    """Atmospheric refraction to add to a geometric elevation (deg).

    Parameters
    ----------
    elevation_deg : float, array_like or Quantity (angle)
        Geometric elevation in [-90, 90] deg: plain numbers in degrees, or an angle Quantity
        (converted). NaN or infinite values are refused.
    pressure_hpa : float
        Air pressure at the site, hPa (>= 0; default 1010).
    temperature_c : float
        Air temperature at the site, deg C (above -273; default 10).
    relative_humidity : float
        Relative humidity at the site, a fraction in [0, 1] (default 0.5; a percentage such as
        70 is refused). Used by the radio model only.
    model : {"optical", "radio"}
        ``"optical"`` (default): Sæmundsson's formula for light. ``"radio"``: the bending of a
        radio ray through the exponential refractivity profile of ITU-R P.453/P.834 with the
        site's surface refractivity (antennas; humid air bends radio waves 10-20 % more).

    Returns
    -------
    ndarray (deg), or Quantity (deg) for a Quantity ``elevation_deg``
        ``>= 0``, decreasing with the elevation, 0 below -1 deg.

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

    from .._units import is_quantity, to_array

    quantity = is_quantity(elevation_deg)
    if quantity:
        h = np.degrees(to_array(elevation_deg, "angle", "elevation_deg"))
    else:
        h = np.asarray(elevation_deg, dtype=np.float64)
    _check_elevations(h)
    out = bend(h, model, pressure_hpa, temperature_c, relative_humidity)[0]
    return out * u.deg if quantity else out


def refraction_slope(elevation_deg, pressure_hpa=1010.0, temperature_c=10.0, *,
                     relative_humidity=0.5, model: str = "optical"):
    """dR/dE of :func:`refraction_deg` (deg of refraction per deg of geometric elevation,
    negative: optical -0.02 at 5 deg, -0.04 at 2.5 deg), 0 below -1 deg where the refraction
    is 0.

    Parameters
    ----------
    elevation_deg : float or array_like
        Geometric elevation, deg, in [-90, 90] (NaN refused).
    pressure_hpa, temperature_c, relative_humidity, model
        The site's air and the model, as :func:`refraction_deg`.

    Returns
    -------
    ndarray
        The slope; ``1 + slope`` maps a change of geometric elevation (or its rate) to the
        apparent one.
    """
    h = np.asarray(elevation_deg, dtype=np.float64)
    _check_elevations(h)
    return bend(h, model, pressure_hpa, temperature_c, relative_humidity)[1]


def bend(elevation_deg, model, pressure_hpa, temperature_c, relative_humidity):
    """Refraction (deg) and its slope dR/dE at geometric elevations ``elevation_deg`` (deg,
    ndarray), for the checked air; NaN elevations stay NaN (look() on NaN geometry)."""
    h = np.asarray(elevation_deg, dtype=np.float64)
    if model == "optical":
        scale = _meeus_factor(pressure_hpa, temperature_c)
        check_humidity(relative_humidity)
        r, slope = _saemundsson_arcmin(h)
        r, slope = r * scale / 60.0, slope * scale / 60.0
    elif model == "radio":
        table = _radio_table(_surface_refractivity(pressure_hpa, temperature_c,
                                                   relative_humidity))
        if table is None:  # no air
            r = slope = np.zeros_like(h)
        else:
            spline, lowest = table
            hh = np.clip(h, lowest, 90.0)
            r, slope = spline(hh), np.where(h < lowest, 0.0, spline(hh, 1))
    else:
        raise InvalidInputError(
            f"model must be 'optical' (light: Saemundsson's formula) or 'radio' (antennas); "
            f"got {model!r}.")
    below = h < _LOWEST_DEG
    nan = np.isnan(h)
    # >= 0: the fits reach the zenith within 1e-9 deg, on either side
    r = np.where(below, 0.0, np.maximum(r, 0.0))
    slope = np.where(below, 0.0, slope)
    return np.where(nan, np.nan, r), np.where(nan, np.nan, slope)


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
    p = float(pressure_hpa)
    t = float(temperature_c)
    if not (math.isfinite(p) and p >= 0.0):
        raise InvalidInputError(f"pressure_hpa must be >= 0 hPa and finite, got {p!r}.")
    if not (math.isfinite(t) and t > -273.0):
        raise InvalidInputError(f"temperature_c must be above -273 deg C (the formula's 0 K), "
                                f"got {t!r}.")
    return p, t


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
            "temperature_c.")
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


# radio -----------------------------------------------------------------------------------
#: Panels of the quadrature in s (km from its lower end): the integrand decays over ~7 km of s
#: at the zenith and ~200 km at the horizon; 16 Gauss-Legendre nodes per panel.
_PANELS_KM = np.array([0.0, 1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024, 2048])
_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(16)
#: Top of the integration above the station (km): exp(-0.1361 * 120) = 8e-8 of N_s.
_TOP_KM = 120.0
#: Apparent elevations of the table (deg): dense near the horizon, where the bending bends.
#: From -1 deg, whose geometric elevation -1 deg - R lies below the models' range.
_TABLE_DEG = np.concatenate([np.linspace(-1.0, 12.0, 341)[:-1], np.linspace(12.0, 90.0, 160)])


def radio_bending_deg(theta_deg, n_s):
    """Total bending (deg) of a ray leaving the station at apparent elevations ``theta_deg``
    (deg, 1-d) through ``n = 1 + n_s 1e-6 exp(-0.1361 z)``: the integral of
    :func:`refraction_deg`'s Notes; a negative ``theta`` goes down to its tangent point below
    the station first and counts that leg twice."""
    theta = np.radians(np.asarray(theta_deg, dtype=np.float64))[:, None]
    eps = n_s * 1e-6
    n0, r0 = 1.0 + eps, _EARTH_RADIUS_KM
    a = n0 * r0 * np.cos(theta)  # Snell's invariant n r cos(phi)
    s0 = n0 * r0 * np.sin(theta)
    r_top = r0 + _TOP_KM
    s_top = np.sqrt(((1.0 + eps * math.exp(-_DECAY_PER_KM * _TOP_KM)) * r_top) ** 2 - a * a)

    def integral(lo, hi, a):
        total = np.zeros(lo.shape)
        for p0, p1 in zip(_PANELS_KM[:-1], _PANELS_KM[1:], strict=True):
            s_lo, s_hi = np.minimum(lo + p0, hi), np.minimum(lo + p1, hi)
            half = 0.5 * (s_hi - s_lo)
            s = 0.5 * (s_hi + s_lo) + half * _NODES
            m = np.sqrt(s * s + a * a)  # = n(r) r: solve for r by Newton's method
            r = m
            for _ in range(4):
                n = 1.0 + eps * np.exp(-_DECAY_PER_KM * (r - r0))
                dn = -_DECAY_PER_KM * (n - 1.0)
                r = r - (n * r - m) / (n + r * dn)
            n = 1.0 + eps * np.exp(-_DECAY_PER_KM * (r - r0))
            dn = -_DECAY_PER_KM * (n - 1.0)
            f = -dn * a / (n * n * r * (n + r * dn))  # d(tau)/ds
            total += (f * _WEIGHTS).sum(axis=-1, keepdims=True) * half
        return total

    up = np.maximum(s0, 0.0)
    tau = integral(up, s_top, a)
    down = s0[:, 0] < 0.0
    if down.any():  # the leg from the station down to the tangent point (s = 0) and back up
        tau[down] += integral(np.zeros_like(s0[down]), -s0[down], a[down])
    return np.degrees(tau[:, 0])


@functools.lru_cache(maxsize=64)
def _radio_table(n_s: float):
    """The radio refraction (deg) over the geometric elevation (deg) for the surface
    refractivity ``n_s``: a cubic spline and the lowest geometric elevation it covers (below
    it the refraction stays at the spline's first value); None for no air."""
    from scipy.interpolate import CubicSpline

    if n_s <= 0.0:
        return None
    with np.errstate(all="ignore"):
        tau = radio_bending_deg(_TABLE_DEG, n_s)
    geometric = _TABLE_DEG - tau
    # rays aimed below the horizon pass under the station, where the profile grows; in dense
    # air they reach its ducting layer (no tangent point): keep the apparent elevations above
    ok = np.isfinite(geometric) & (tau >= 0.0)
    ok[:-1] &= np.diff(geometric) > 0.0
    first = _TABLE_DEG.size - np.argmin(ok[::-1]) if not ok.all() else 0
    return CubicSpline(geometric[first:], tau[first:]), float(geometric[first])
