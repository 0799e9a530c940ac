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
  station's air: optical (Saemundsson's formula) by default, the radio bending of the
  station's refractivity with ``troposphere={"refraction": "radio", ...}`` for antenna angles
  (0.1 deg more at the horizon, ~1 arcmin more at 5 deg in humid air);
* ``radec`` and ``position`` rows are left alone (astrometry reduced against catalogue stars has
  its refraction removed with the stars').

Model: Saastamoinen's zenith delays (hydrostatic ``ZHD = 0.0022768 P / (1 - 0.00266 cos 2 phi -
0.00028 h_km)`` m, Davis et al. 1985; wet ``ZWD = 0.002277 (1255 / T + 0.05) e`` m, P and e in
hPa, T in K), the mapping function of Black & Eisner (1984) ``m(E) = 1.001 / sqrt(0.002001 +
sin^2 E)`` (the RTCA DO-229 one; its slant delay differs from Niell's mapping functions at
45 deg latitude and sea level by 15 cm at 5 deg, 6 cm at 10 deg, 2 cm at 15 deg of elevation and
0.4 m at 3 deg), and the station's air from the standard atmosphere at its height
(:func:`visviva.ground.air.standard_atmosphere`: ``P = 1013.25 (1 - 2.2557e-5 h)^5.2568`` hPa,
``T = 15 - 0.0065 h`` deg C up to the tropopause at 11 km, isothermal above it; 50 % relative
humidity) unless given: the same air and the same dict keys as ``look(refraction=...)``
(:mod:`visviva.ground.air`). The range partials carry the delay's slope with the elevation, the
elevation's partials the refraction's slope; the range rate's partials are the geometric ones
(the rate of the delay moves them by less than 1e-6).
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError
from ..ground.air import Weather, check_air, standard_atmosphere
from .slant import line_of_sight

__all__ = ["Weather", "standard_atmosphere", "weather_from", "zenith_delays_m", "mapping", "apply"]


def weather_from(troposphere):
    """The ``troposphere`` argument checked: None (off) or a :class:`Weather`."""
    if troposphere is None or troposphere is False:
        return None
    if troposphere is True:
        return Weather(None)
    if isinstance(troposphere, dict):
        given, model = check_air(troposphere, "troposphere")
        return Weather(given, model)
    raise InvalidInputError(
        "troposphere must be False (no model), True (the standard atmosphere at each station) "
        "or a dict of pressure_hpa, temperature_c, relative_humidity and refraction ('optical' "
        f"or 'radio' for az/el rows); got {troposphere!r}.")


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
    """Per station object: (zenith delay km, pressure hPa, temperature deg C, humidity)."""
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
        out[id(s)] = ((zhd + zwd) / 1000.0, *weather.conditions(height))
    return out


def apply(observations, kinds, y, site_r, site_v, enu, h, H, rows):
    """Add the troposphere to the predicted values ``h`` (and the range partials ``H``) of the
    rows ``rows`` of ``observations``, in place; ``enu`` holds each row's east-north-up axes."""
    from ..ground.refraction import bend

    weather = observations.troposphere
    stations = [observations.stations[i] for i in rows]
    air = _station_air(stations, weather)
    zenith = np.array([air[id(s)][0] if s is not None else 0.0 for s in stations])
    sight = line_of_sight(y, site_r, site_v, enu)
    rng = sight.rng
    sin_el, cos_el = np.sin(sight.el), np.cos(sight.el)
    m, dm = mapping(sin_el)
    ranged = kinds == "range"
    if ranged.any():
        h[ranged, 0] += zenith[ranged] * m[ranged]
        if H is not None:
            ds = cos_el[ranged, None] * sight.d_dr[ranged, 1]  # d sin E / d r
            H[ranged, 0, :3] += (zenith[ranged] * dm[ranged])[:, None] * ds
    rated = kinds == "range_rate"
    if rated.any():
        # d sin E / dt with the station's axes turning with the Earth
        dsin = cos_el[rated] * sight.rate[rated, 1]
        h[rated, 0] += zenith[rated] * dm[rated] * dsin
    pointed = kinds == "azel"
    if pointed.any():
        owner = np.array([id(s) for s in stations])  # once, not per station
        for key, (_, p, t_c, rh) in air.items():
            idx = np.flatnonzero(pointed & (owner == key))
            if idx.size:
                # a satellite at its range: 0.95 of a star's refraction at the horizon 500 km
                # up (visviva.ground.finite_range)
                r_deg, slope, d_range = bend(np.degrees(h[idx, 1]), weather.refraction, p, t_c,
                                             rh, range_km=rng[idx], range_slope=True)
                h[idx, 1] += np.radians(r_deg)
                if H is not None:
                    # d(E + R(E, rho)) = (1 + dR/dE) dE + dR/drho drho, in the models' range
                    # (optical above -1 deg geometric, radio above -1 deg apparent); optical -0.04 at 2.5 deg, -0.02 at 5 deg; the range's
                    # share ~5e-5 of the elevation's
                    H[idx, 1, :] *= (1.0 + slope)[:, None]
                    H[idx, 1, :3] += (np.radians(d_range) / rng[idx])[:, None] * sight.rho[idx]
