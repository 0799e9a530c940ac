"""The troposphere in the ground-station measurement models (``Observations(troposphere=...)``).

Radio signals from a satellite are slowed by the neutral atmosphere: a range measured by a
station reads longer than the geometric one by 2.3-2.6 m at the zenith and 10-25 m at 5-10 deg of
elevation, and a range rate changes with the delay as the elevation changes (cm/s near the
horizon in LEO). Light is bent upwards: an optical elevation reads higher than the geometric one
(34 arcmin at the horizon, 1 arcmin at 45 deg). With ``troposphere`` on, the models predict
what the station measures:

* ``range``: the geometric (or light-time) range plus the slant delay
  ``ZHD m(E) + ZWD m(E)``, the same up and down, so once in the two-way mean;
* ``range_rate``: plus the delay's rate ``d/dt [(ZHD + ZWD) m(E)]`` along the pass;
* ``azel``: the elevation plus the refraction of :func:`visviva.ground.refraction_deg` for the
  station's pressure and temperature;
* ``radec`` and ``position`` rows are left alone (astrometry reduced against catalogue stars has
  its refraction removed with the stars').

Model: Saastamoinen's zenith delays (hydrostatic ``ZHD = 0.0022768 P / (1 - 0.00266 cos 2 phi -
0.00028 h_km)`` m, Davis et al. 1985; wet ``ZWD = 0.002277 (1255 / T + 0.05) e`` m, P and e in
hPa, T in K), the mapping function of Black & Eisner (1984) ``m(E) = 1.001 / sqrt(0.002001 +
sin^2 E)`` (the RTCA DO-229 one; its slant delay differs from Niell's mapping functions at
45 deg latitude and sea level by 15 cm at 5 deg, 6 cm at 10 deg, 2 cm at 15 deg of elevation and
0.4 m at 3 deg), and the station's air
from the standard atmosphere at its height (``P = 1013.25 (1 - 2.2557e-5 h)^5.2568`` hPa,
``T = 15 - 0.0065 h`` deg C up to the tropopause at 11 km, isothermal above it; 50 % relative
humidity) unless given. The range partials carry the delay's slope with the elevation, the
elevation's partials the refraction's slope; the range rate's partials are the geometric ones
(the rate of the delay moves them by less than 1e-6).
"""

from __future__ import annotations

import numbers

import numpy as np

from ..constants import EARTH_ROTATION_RAD_S
from ..errors import InvalidInputError

__all__ = ["Weather", "standard_atmosphere", "weather_from", "zenith_delays_m", "mapping", "apply"]

#: Keys of a ``troposphere`` mapping and their checks (name -> (low, high, unit)).
_KEYS = {"pressure_hpa": (100.0, 1100.0, "hPa"), "temperature_c": (-90.0, 60.0, "deg C"),
         "relative_humidity": (0.0, 1.0, "(0..1)")}


class Weather:
    """The air at the stations: None for the standard atmosphere at each station's height, or
    the given ``pressure_hpa``, ``temperature_c``, ``relative_humidity`` for every station."""

    def __init__(self, given: dict | None):
        self.given = given

    def at(self, height_m):
        """Pressure (hPa), temperature (K) and water-vapour pressure (hPa) at ``height_m``."""
        g = self.given or {}
        p_std, t_std = standard_atmosphere(height_m)
        p = g.get("pressure_hpa", p_std)
        t_c = g.get("temperature_c", t_std)
        rh = g.get("relative_humidity", 0.5)
        # saturation vapour pressure over water (Magnus form), hPa
        e = rh * 6.1078 * np.exp(17.27 * t_c / (t_c + 237.3))
        return p, t_c + 273.15, e


#: Top of the standard atmosphere's troposphere (the tropopause), m, and its air there.
_TROPOPAUSE_M = 11_000.0
_P_TROPOPAUSE_HPA = 1013.25 * (1.0 - 2.2557e-5 * _TROPOPAUSE_M) ** 5.2568
_T_TROPOPAUSE_C = 15.0 - 0.0065 * _TROPOPAUSE_M
#: g0 M / (R T) of the isothermal layer above the tropopause (216.65 K), 1/m.
_ISOTHERMAL_SCALE_PER_M = 9.80665 * 0.0289644 / (8.31432 * 216.65)


def standard_atmosphere(height_m):
    """Pressure (hPa) and temperature (deg C) of the standard atmosphere (ICAO 1993) at
    ``height_m``: the 6.5 K/km lapse rate up to the tropopause at 11 km, isothermal
    (-56.5 deg C, pressure falling exponentially) above it. The lapse-rate formula alone turns
    negative (NaN or complex pressures) above 44 km and reached absolute zero at 44.3 km."""
    h = float(height_m)
    if h <= _TROPOPAUSE_M:
        return 1013.25 * (1.0 - 2.2557e-5 * h) ** 5.2568, 15.0 - 0.0065 * h
    return (_P_TROPOPAUSE_HPA * np.exp(-_ISOTHERMAL_SCALE_PER_M * (h - _TROPOPAUSE_M)),
            _T_TROPOPAUSE_C)


def weather_from(troposphere):
    """The ``troposphere`` argument checked: None (off) or a :class:`Weather`."""
    if troposphere is None or troposphere is False:
        return None
    if troposphere is True:
        return Weather(None)
    if isinstance(troposphere, dict):
        unknown = set(troposphere) - set(_KEYS)
        if unknown:
            raise InvalidInputError(
                f"troposphere has unknown keys {sorted(unknown)}; use {', '.join(_KEYS)}.")
        for key, value in troposphere.items():
            lo, hi, unit = _KEYS[key]
            # a number (numpy scalars too), not a bool (True would read as 1)
            if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real) \
                    or not lo <= float(value) <= hi:
                raise InvalidInputError(
                    f"troposphere {key} must be a number in [{lo}, {hi}] {unit}; got {value!r}.")
        return Weather({key: float(value) for key, value in troposphere.items()})
    raise InvalidInputError(
        "troposphere must be False (no model), True (the standard atmosphere at each station) "
        f"or a dict of pressure_hpa, temperature_c, relative_humidity; got {troposphere!r}.")


def zenith_delays_m(pressure_hpa, temperature_k, vapour_hpa, lat_rad, height_m):
    """Saastamoinen's hydrostatic and wet zenith delays, m (Davis et al. 1985)."""
    zhd = 0.0022768 * pressure_hpa / (
        1.0 - 0.00266 * np.cos(2.0 * lat_rad) - 0.00028 * height_m / 1000.0)
    zwd = 0.002277 * (1255.0 / temperature_k + 0.05) * vapour_hpa
    return zhd, zwd


def mapping(sin_el):
    """Black & Eisner's mapping function ``m`` and ``dm / d(sin E)`` at ``sin E``."""
    q = 0.002001 + sin_el * sin_el
    m = 1.001 / np.sqrt(q)
    return m, -m * sin_el / q


def _station_air(stations, weather):
    """Per station object: (zenith delay km, pressure hPa, temperature deg C)."""
    out = {}
    for s in stations:
        if s is None or id(s) in out:
            continue
        try:
            lat = float(np.radians(s.lat.to_value("deg")))
            height = float(s.height.to_value("m"))
        except AttributeError:
            raise InvalidInputError(
                f"troposphere needs each station's geodetic lat and height (a "
                f"vv.GroundStation); {s!r} has none.") from None
        p, t_k, e = weather.at(height)
        zhd, zwd = zenith_delays_m(p, t_k, e, lat, height)
        out[id(s)] = ((zhd + zwd) / 1000.0, p, t_k - 273.15)
    return out


def apply(observations, kinds, y, site_r, site_v, enu, h, H, rows):
    """Add the troposphere to the predicted values ``h`` (and the range partials ``H``) of the
    rows ``rows`` of ``observations``, in place; ``enu`` holds each row's east-north-up axes."""
    from ..ground.look import refraction_deg, refraction_slope

    weather = observations.troposphere
    stations = [observations.stations[i] for i in rows]
    air = _station_air(stations, weather)
    zenith = np.array([air[id(s)][0] if s is not None else 0.0 for s in stations])
    rho = y[:, :3] - site_r
    rhod = y[:, 3:] - site_v
    rng = np.linalg.norm(rho, axis=-1)
    up = enu[:, 2, :]
    sin_el = np.einsum("ni,ni->n", rho, up) / rng
    m, dm = mapping(sin_el)
    ranged = kinds == "range"
    if ranged.any():
        h[ranged, 0] += zenith[ranged] * m[ranged]
        # d sin E / d r = (up - sin E rho_hat) / |rho|
        ds = (up[ranged] - sin_el[ranged, None] * rho[ranged] / rng[ranged, None]) \
            / rng[ranged, None]
        if H is not None:
            H[ranged, 0, :3] += (zenith[ranged] * dm[ranged])[:, None] * ds
    rated = kinds == "range_rate"
    if rated.any():
        # d sin E / dt with the station's up turning with the Earth (omega x up)
        omega = np.array([0.0, 0.0, EARTH_ROTATION_RAD_S])
        dup = np.cross(omega, up[rated])
        r_, rd, s_ = rho[rated], rhod[rated], sin_el[rated]
        dsin = (np.einsum("ni,ni->n", rd, up[rated]) + np.einsum("ni,ni->n", r_, dup)) \
            / rng[rated] - s_ * np.einsum("ni,ni->n", r_, rd) / rng[rated] ** 2
        h[rated, 0] += zenith[rated] * dm[rated] * dsin
    pointed = kinds == "azel"
    if pointed.any():
        owner = np.array([id(s) for s in stations])  # once, not per station
        for key, (_, p, t_c) in air.items():
            idx = np.flatnonzero(pointed & (owner == key))
            if idx.size:
                el_deg = np.degrees(h[idx, 1])
                h[idx, 1] += np.radians(refraction_deg(el_deg, p, t_c))
                if H is not None:
                    # d(E + R(E)) = (1 + dR/dE) dE: R's slope (arcmin per deg) / 60, in the
                    # formula's range (above -1 deg); -0.04 at 2.5 deg, -0.02 at 5 deg
                    H[idx, 1, :] *= (1.0 + refraction_slope(el_deg, p, t_c))[:, None]
