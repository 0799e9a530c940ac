"""Simulation units: G from a choice of length, time and mass units.

An N-body simulation works in one consistent set of units chosen by the user. Either ``G`` is
given directly (``G = 1`` by default: N-body units, all values plain floats), or
``units=("au", "yr", "Msun")`` (any astropy length, time and mass units) sets

    G = 6.67430e-20 km**3 / (kg s**2)   expressed in  length**3 / (mass time**2)

and lets :meth:`visviva.Simulation.add` take astropy Quantities, which are converted through
:mod:`visviva._units` to km, km/s, kg and then scaled to the simulation's units.
"""

from __future__ import annotations

from dataclasses import dataclass

from astropy import units as u

from .. import _units
from ..constants import G_KM3_KG_S2
from ..errors import InvalidInputError

__all__ = ["SimulationUnits"]

#: The Gaussian gravitational constant k (rad/day; IAU 1938, 2012 B2): a year of 2 pi / k days.
GAUSSIAN_K = 0.01720209895
#: REBOUND's unit names (``rebound.units``) that astropy does not know, as astropy units.
REBOUND_SPELLINGS = {"msun": "Msun", "solarmass": "Msun", "sunmass": "Msun", "msolar": "Msun",
                     "mearth": "Mearth", "mjupiter": "Mjup", "gyr": "Gyr", "days": "day",
                     "years": "yr", "yrs": "yr", "jyr": "yr", "aus": "au",
                     "yr2pi": u.Unit(u.day / GAUSSIAN_K)}  # 1/k days: G = 1 (Gauss)
#: Names REBOUND and astropy read differently: refused rather than guessed.
AMBIGUOUS = {"myr": "a megayear in REBOUND but a milliyear in astropy (G would be 1e18 times "
                    "REBOUND's); write 'Myr' for the megayear"}


@dataclass(frozen=True)
class SimulationUnits:
    """Length, time and mass units of a simulation and the scale factors to canonical units.

    Attributes
    ----------
    length, time, mass : str
        The unit names (astropy syntax, e.g. ``"au"``, ``"yr"``, ``"Msun"``).
    length_km, time_s, mass_kg : float
        One simulation unit of length in km, of time in s, of mass in kg.
    """

    length: str
    time: str
    mass: str
    length_km: float
    time_s: float
    mass_kg: float

    @classmethod
    def parse(cls, units) -> SimulationUnits:
        """Build from a tuple ``(length, time, mass)`` of unit names (astropy's, or REBOUND's:
        ``"msun"``, ``"mjupiter"``, ``"yr2pi"``, ... see :data:`REBOUND_SPELLINGS`; ``"myr"``,
        a megayear in REBOUND and a milliyear in astropy, is refused) or astropy units."""
        if isinstance(units, SimulationUnits):
            return units
        try:
            length, time, mass = units
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(
                f"units must be (length, time, mass), e.g. ('au', 'yr', 'Msun'); got {units!r}."
            ) from exc
        scales = []
        for value, kind, canon in ((length, "length", u.km), (time, "time", u.s),
                                   (mass, "mass", u.kg)):
            if isinstance(value, str) and value in AMBIGUOUS:
                raise InvalidInputError(f"units: {value!r} is {AMBIGUOUS[value]}.")
            try:
                unit = u.Unit(REBOUND_SPELLINGS.get(value, value) if isinstance(value, str)
                              else value)
                scales.append(float((1.0 * unit).to_value(canon)))
            except (ValueError, u.UnitConversionError) as exc:
                raise InvalidInputError(
                    f"units: {value!r} is not a unit of {kind} (e.g. 'au', 'yr', 'Msun')."
                ) from exc
        return cls(str(length), str(time), str(mass), *scales)

    @property
    def G(self) -> float:
        """The gravitational constant in length**3 / (mass time**2) of these units."""
        return G_KM3_KG_S2 * self.mass_kg * self.time_s**2 / self.length_km**3

    # -- conversion of user input (Quantities go through visviva._units) -------------------------
    def length_value(self, value, name):
        return _units.to_array(value, "length", name) / self.length_km

    def speed_value(self, value, name):
        return _units.to_array(value, "speed", name) / (self.length_km / self.time_s)

    def time_value(self, value, name):
        return _units.to_array(value, "time", name) / self.time_s

    def mass_value(self, value, name):
        return _units.to_array(value, "mass", name) / self.mass_kg

    def as_tuple(self):
        return (self.length, self.time, self.mass)
