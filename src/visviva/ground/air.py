"""The air at a ground station: the standard atmosphere at its height, measured weather, and
its radio refractivity.

One place for what the pass tables (``look(refraction=...)``, :mod:`visviva.ground.look`) and
the orbit determination's measurement models (``Observations(troposphere=...)``,
:mod:`visviva.od.troposphere`) share: the keys of a weather dict and their checks, the ICAO
standard atmosphere that fills what the dict leaves out, the saturation vapour pressure that
turns a relative humidity into a water-vapour pressure, and the Smith-Weintraub refractivity.
The same dict works in both places::

    air = {"pressure_hpa": 1002.0, "temperature_c": 18.0, "relative_humidity": 0.7,
           "refraction": "radio"}
    station.look(sat, t, refraction=air)
    vv.Observations(..., troposphere=air)
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from ..errors import InvalidInputError

__all__ = ["AIR_KEYS", "REFRACTION_MODELS", "Weather", "check_air", "radio_refractivity",
           "saturation_vapour_hpa", "standard_atmosphere"]

#: Keys of a weather dict and their ranges (name -> (low, high, unit)).
AIR_KEYS = {"pressure_hpa": (100.0, 1100.0, "hPa"), "temperature_c": (-90.0, 60.0, "deg C"),
            "relative_humidity": (0.0, 1.0, "(a fraction, 0..1)")}
#: Values of a weather dict's ``"refraction"`` key: Saemundsson's optical formula, or the
#: radio bending of :mod:`visviva.ground.refraction`.
REFRACTION_MODELS = ("optical", "radio")
#: Relative humidity of the standard air (a fraction).
STANDARD_HUMIDITY = 0.5

#: Lowest height of the standard atmosphere's tables, m (ISO 2533 starts at -2 km): below
#: it the air of a station must be given (audit50: at -11 km the extrapolation gave
#: 3249 hPa and 86.5 deg C, refused as a weather value the user never gave, and the
#: troposphere's zenith delay of Observations took it silently).
STANDARD_LOWEST_M = -2000.0
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


def saturation_vapour_hpa(temperature_c):
    """Saturation water-vapour pressure over water (hPa) at ``temperature_c`` (deg C): the
    Magnus form ``6.1078 exp(17.27 t / (t + 237.3))`` (Murray 1967); 6.11 hPa at 0 deg C,
    17.0 hPa at 15 deg C."""
    return 6.1078 * np.exp(17.27 * temperature_c / (temperature_c + 237.3))


def radio_refractivity(pressure_hpa, temperature_k, vapour_hpa):
    """Radio refractivity ``N = (n - 1) 1e6`` of moist air (Smith & Weintraub 1953; ITU-R
    P.453-14 eq. 6): ``N = (77.6 / T) (P + 4810 e / T)``, i.e. ``77.6 P / T + 3.73e5 e / T^2``,
    with the total pressure ``P`` and the water-vapour pressure ``e`` in hPa, ``T`` in K.
    273 at 1013.25 hPa, 15 deg C in dry air, 311 with 50 % humidity: the vapour adds 10-20 %
    at temperate and tropical sites, where the optical refractivity hardly changes."""
    return 77.6 / temperature_k * (pressure_hpa + 4810.0 * vapour_hpa / temperature_k)


#: the unit each weather key's Quantity is converted to (astropy unit names), and its kind
_AIR_UNITS = {"pressure_hpa": ("hPa", "pressure (hPa, Pa, bar)"),
              "temperature_c": ("deg_C", "temperature (deg_C, K)"),
              "relative_humidity": ("", "fraction (dimensionless or percent)")}


def _air_value(key, value, name):
    """A weather value as a plain number in its key's unit: a Quantity (``1000 * u.hPa``,
    ``288 * u.K``, ``50 * u.percent``) converted once; plain numbers pass as they are."""
    from .._units import is_quantity

    if not is_quantity(value):
        return value
    from astropy import units as u

    from ..errors import UnitsError

    if value.size != 1:
        raise InvalidInputError(f"{name} {key} must be one value; got shape {value.shape}.")
    unit, kind = _AIR_UNITS[key]
    try:
        return float(value.to_value(u.Unit(unit), equivalencies=u.temperature()))
    except u.UnitConversionError as exc:
        raise UnitsError(
            f"{name} {key} has unit '{value.unit}', which is not a {kind}; pass a Quantity "
            f"of that kind or a plain number in {AIR_KEYS[key][2]}.") from exc


def check_air(air, name: str):
    """A weather dict checked: ``(given, model)`` with ``given`` the numbers among
    ``pressure_hpa``, ``temperature_c``, ``relative_humidity`` as floats (absent keys are
    absent) and ``model`` its ``"refraction"`` (``"optical"`` when absent)."""
    allowed = (*AIR_KEYS, "refraction")
    unknown = set(air) - set(allowed)
    if unknown:
        raise InvalidInputError(
            f"{name} has unknown keys {sorted(unknown)}; use {', '.join(allowed)}.")
    given = {}
    for key, value in air.items():
        if key == "refraction":
            continue
        lo, hi, unit = AIR_KEYS[key]
        value = _air_value(key, value, name)
        # a number (numpy scalars too), not a bool (True would read as 1)
        bad = isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real) \
            or not lo <= float(value) <= hi
        if bad:
            hint = ""
            if key == "relative_humidity" and isinstance(value, numbers.Real) \
                    and not isinstance(value, bool | np.bool_) and 1.0 < float(value) <= 100.0:
                hint = f" ({value!r} looks like a percentage: pass {float(value) / 100:g})"
            raise InvalidInputError(
                f"{name} {key} must be a number in [{lo:g}, {hi:g}] {unit}; got {value!r}"
                f"{hint}.")
        given[key] = float(value)
    model = air.get("refraction", "optical")
    if model not in REFRACTION_MODELS:
        label = name if name == "refraction" else f"{name} refraction"  # not "refraction" twice
        raise InvalidInputError(
            f"{label} must be 'optical' (light: Saemundsson's formula) or 'radio' "
            f"(antennas: the bending of the radio refractivity); got {model!r}.")
    return given, model


def check_humidity(relative_humidity) -> float:
    """A relative humidity argument as a float fraction in [0, 1]; a percentage is refused."""
    try:
        rh = float(relative_humidity)
    except (TypeError, ValueError):
        rh = math.nan
    if isinstance(relative_humidity, bool | np.bool_) or not 0.0 <= rh <= 1.0:
        hint = (f" ({relative_humidity!r} looks like a percentage: pass {rh / 100:g})"
                if 1.0 < rh <= 100.0 else "")
        raise InvalidInputError(
            f"relative_humidity must be a fraction in [0, 1]; got {relative_humidity!r}{hint}.")
    return rh


def _standard_top_km() -> float:
    """The height (km) where the standard air's pressure falls to the water vapour of the
    standard humidity (the isothermal layer's saturation pressure): the air's end."""
    e = STANDARD_HUMIDITY * saturation_vapour_hpa(_T_TROPOPAUSE_C)
    return (_TROPOPAUSE_M + math.log(_P_TROPOPAUSE_HPA / e) / _ISOTHERMAL_SCALE_PER_M) / 1000.0


class Weather:
    """The air at the stations: the standard atmosphere at each station's height (50 %
    relative humidity) where ``given`` (a checked weather dict, or None) says nothing, and
    the refraction model (``"optical"`` or ``"radio"``) of elevations."""

    def __init__(self, given: dict | None, refraction: str = "optical"):
        self.given = given
        self.refraction = refraction

    def conditions(self, height_m):
        """Pressure (hPa), temperature (deg C) and relative humidity (0..1) at ``height_m``.

        Raises
        ------
        InvalidInputError
            Radio refraction at a station above the atmosphere (the standard air's pressure
            there below its water vapour's: above ~73 km at 50 % humidity), where no pressure
            and humidity were given.
        """
        g = self.given or {}
        if height_m < STANDARD_LOWEST_M and not {"pressure_hpa", "temperature_c"} <= set(g):
            p_x, t_x = standard_atmosphere(height_m)
            raise InvalidInputError(
                f"the station is {-height_m / 1000:.3g} km below the ellipsoid, below the "
                f"standard atmosphere's lowest level ({STANDARD_LOWEST_M / 1000:g} km, ISO "
                "2533; the lowest dry land, the Dead Sea's shore, is at -0.43 km): a site "
                "there is under water or rock, and the standard air extrapolated to it "
                f"({p_x:.0f} hPa, {t_x:.0f} deg C) is no air to see a satellite through. "
                "Give the site's pressure_hpa and temperature_c in a weather dict, leave "
                "refraction off (refraction=False in look() and pass searches, "
                "troposphere=False in Observations), or check the height's sign and unit.")
        p_std, t_std = standard_atmosphere(height_m)
        p, t_c = g.get("pressure_hpa", p_std), g.get("temperature_c", t_std)
        rh = g.get("relative_humidity", STANDARD_HUMIDITY)
        if self.refraction == "radio" and "pressure_hpa" not in g \
                and rh * saturation_vapour_hpa(t_c) > p:
            raise InvalidInputError(
                f"the station is {height_m / 1000:.1f} km up, above the atmosphere: the "
                f"standard air's pressure there ({p:.3g} hPa) is below the water vapour of "
                f"{rh:.0%} humidity (the standard air ends near {_TOP_KM:.0f} km), and the "
                "refraction of a station in space means nothing. Leave refraction off for "
                "this observer (refraction=False in look() and pass searches, "
                "troposphere=False in Observations; an observer in orbit is no station), "
                "or check the station's height (m, not km?).")
        return p, t_c, rh

    def at(self, height_m):
        """Pressure (hPa), temperature (K) and water-vapour pressure (hPa) at ``height_m``."""
        p, t_c, rh = self.conditions(height_m)
        return p, t_c + 273.15, rh * saturation_vapour_hpa(t_c)


#: where the standard air ends (km): its pressure equals the 50 % humidity's vapour
_TOP_KM = _standard_top_km()
