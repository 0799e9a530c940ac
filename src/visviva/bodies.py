"""Solar-system bodies: GM, radius and (for the Earth) zonal harmonics, each with its source."""

from __future__ import annotations

from dataclasses import dataclass, field

from astropy import units as u

from . import constants as c

__all__ = [
    "Body",
    "SUN",
    "MERCURY",
    "VENUS",
    "EARTH",
    "MOON",
    "MARS",
    "JUPITER",
    "SATURN",
    "URANUS",
    "NEPTUNE",
    "PLUTO",
    "BODIES",
]

_GM_SOURCE = "JPL DE440 (NAIF gm_de440.tpc)"
_R_SOURCE = "IAU WGCCRE 2015 (Archinal et al. 2018)"


@dataclass(frozen=True)
class Body:
    """A gravitating body.

    Attributes
    ----------
    name : str
        Lower-case name, e.g. ``"earth"``.
    gm : Quantity
        Gravitational parameter, km3 / s2.
    radius : Quantity
        Equatorial radius, km (the reference radius of the harmonics, where given).
    zonal : tuple of float
        Unnormalised zonal harmonics ``(J2, J3, ...)``, dimensionless; empty when not given.
    rotation_rate : Quantity or None
        Sidereal rotation rate, rad / s.
    source : str
        Where the numbers come from.
    """

    name: str
    gm: u.Quantity
    radius: u.Quantity
    zonal: tuple = field(default=())
    rotation_rate: u.Quantity | None = None
    source: str = f"GM: {_GM_SOURCE}; radius: {_R_SOURCE}"

    @property
    def j2(self) -> float:
        """Second zonal harmonic J2 (dimensionless); raises if the body has none."""
        return self.jn(2)

    def jn(self, n: int) -> float:
        """Unnormalised zonal harmonic J_n, for 2 <= n <= 1 + len(zonal)."""
        if not 2 <= n <= 1 + len(self.zonal):
            raise AttributeError(
                f"{self.name} has zonal harmonics J2..J{1 + len(self.zonal)} only"
                if self.zonal
                else f"no zonal harmonics are given for {self.name}; build a Body with zonal=(J2, ...)"
            )
        return self.zonal[n - 2]

    @property
    def gm_km3_s2(self) -> float:
        """GM as a float in km3 / s2."""
        return float(self.gm.to_value(u.km**3 / u.s**2))

    @property
    def radius_km(self) -> float:
        """Equatorial radius as a float in km."""
        return float(self.radius.to_value(u.km))

    def __repr__(self) -> str:
        return f"Body({self.name!r}, gm={self.gm:.10g}, radius={self.radius:g})"


_GM = u.km**3 / u.s**2


def _body(name, gm, radius, **kw):
    return Body(name, gm * _GM, radius * u.km, **kw)


SUN = _body("sun", c.GM_SUN_KM3_S2, c.R_SUN_KM)
MERCURY = _body("mercury", c.GM_MERCURY_KM3_S2, c.R_MERCURY_KM)
VENUS = _body("venus", c.GM_VENUS_KM3_S2, c.R_VENUS_KM)
EARTH = _body(
    "earth",
    c.GM_EARTH_KM3_S2,
    c.R_EARTH_KM,
    zonal=(c.EARTH_J2, c.EARTH_J3, c.EARTH_J4, c.EARTH_J5, c.EARTH_J6),
    rotation_rate=c.EARTH_ROTATION_RAD_S * u.rad / u.s,
    source=f"GM: {_GM_SOURCE}; radius and J2-J6: EGM2008 (Pavlis et al. 2012)",
)
MOON = _body("moon", c.GM_MOON_KM3_S2, c.R_MOON_KM)
MARS = _body("mars", c.GM_MARS_KM3_S2, c.R_MARS_KM)
JUPITER = _body("jupiter", c.GM_JUPITER_KM3_S2, c.R_JUPITER_KM)
SATURN = _body("saturn", c.GM_SATURN_KM3_S2, c.R_SATURN_KM)
URANUS = _body("uranus", c.GM_URANUS_KM3_S2, c.R_URANUS_KM)
NEPTUNE = _body("neptune", c.GM_NEPTUNE_KM3_S2, c.R_NEPTUNE_KM)
PLUTO = _body("pluto", c.GM_PLUTO_KM3_S2, c.R_PLUTO_KM)

#: Every body above by lower-case name.
BODIES = {
    b.name: b
    for b in (SUN, MERCURY, VENUS, EARTH, MOON, MARS, JUPITER, SATURN, URANUS, NEPTUNE, PLUTO)
}
