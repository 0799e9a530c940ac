"""Perturbation objects for :func:`visviva.propagate_cowell`.

Each object validates and stores its parameters in canonical units, declares the slots of the
kernel's parameter block it owns (:attr:`Perturbation.PARAMETERS`, names from
:mod:`visviva.core.force_block`) and writes them itself (:meth:`Perturbation.pack`);
``propagate_cowell`` assembles the block from the central body's slots plus every perturbation's
``pack`` and runs one compiled right-hand side with every perturbation in it. Adding a
perturbation is one class here (its slots, its ``pack``) plus its term in
:func:`visviva.core.perturbations.cowell_rhs`.

>>> import visviva as vv
>>> from astropy import units as u
>>> forces = [vv.Zonal(vv.EARTH, 4), vv.ThirdBody(vv.MOON),
...           vv.AtmosphericDrag(2.2 * 4.0 * u.m**2 / (500 * u.kg))]
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from astropy import units as u

from .. import constants as c
from .._units import require_positive, to_array
from ..bodies import BODIES, EARTH, Body
from ..core import force_block as fb
from ..core.perturbations import VALLADO_EXPONENTIAL_TABLE
from ..errors import InvalidInputError, fmt_number
from .icgem import read_gfc

__all__ = [
    "Perturbation",
    "J2",
    "Zonal",
    "AtmosphericDrag",
    "ThirdBody",
    "SolarRadiationPressure",
    "SphericalHarmonics",
    "SOLAR_PRESSURE_1AU_N_M2",
    "require_body",
]

#: Solar radiation pressure on an absorbing surface at 1 AU, N/m^2 (= W/m^2 / c with a solar
#: flux of 1367 W/m^2; Montenbruck & Gill 2000, sec. 3.4).
SOLAR_PRESSURE_1AU_N_M2 = 4.56e-6


def require_body(body, what: str) -> Body:
    """``body`` as a :class:`~visviva.bodies.Body` (a Body, or a known body's name), else a
    clear error naming ``what`` needs it."""
    if isinstance(body, Body):
        return body
    if isinstance(body, str) and body.lower() in BODIES:
        return BODIES[body.lower()]
    raise InvalidInputError(
        f"{what} needs a body such as vv.EARTH, vv.SUN or vv.MOON (or its name); got {body!r}. "
        f"Known names: {', '.join(BODIES)}."
    )


class Perturbation:
    """Base class of the perturbations :func:`visviva.propagate_cowell` accepts."""

    #: the body whose radius, rotation and flattening define altitude and shadow, if any
    central_body: Body | None = None
    #: names (:mod:`visviva.core.force_block`) of the parameter-block slots this class writes
    PARAMETERS: tuple = ()
    #: whether the force turns with the central body's pole (the force model then tabulates
    #: the Earth's pole over the run once, :func:`earth_pole_table`, shared by all of them)
    uses_pole: bool = False

    @classmethod
    def parameters(cls) -> list:
        """The slots this perturbation writes, as ``(name, first index, size, unit, meaning)``.

        Returns
        -------
        list of tuple
            Rows of :data:`visviva.core.force_block.LAYOUT`, in the order of ``PARAMETERS``.
        """
        rows = {row[0]: row for row in fb.LAYOUT}
        return [rows[name] for name in cls.PARAMETERS]

    def pack(self, model) -> None:
        """Write this perturbation's slots of ``model.force`` (and its tables) in place.

        Parameters
        ----------
        model : visviva.satellites.cowell.ForceModel
            The force model being assembled: ``force`` (the parameter block, float64), the
            tables ``zonal``, ``atm``, ``sh``, and the context ``gm_km3_s2`` (km^3/s^2),
            ``central_body``, ``epoch``.
        """


@dataclass(frozen=True, repr=False)
class Zonal(Perturbation):
    """Zonal harmonics J_2 .. J_degree of ``body``'s gravity field.

    Parameters
    ----------
    body : Body
        A body with zonal harmonics, e.g. ``vv.EARTH`` (J2-J6 from EGM2008).
    degree : int
        Highest degree, 2 <= degree <= 1 + len(body.zonal).

    Notes
    -----
    The acceleration is the gradient of U = -GM/r sum_n J_n (R/r)^n P_n(sin phi), evaluated with
    the Legendre recursions (Vallado 2013, sec. 8.6.1; Montenbruck & Gill 2000, sec. 3.2).
    """

    body: Body = EARTH
    degree: int = 2

    def __post_init__(self):
        body = require_body(self.body, "Zonal")
        object.__setattr__(self, "body", body)
        nmax = 1 + len(body.zonal)
        if not isinstance(self.degree, int | np.integer) or not 2 <= self.degree <= nmax:
            raise InvalidInputError(
                f"Zonal degree must be an integer in 2..{nmax} for {body.name} (J2..J{nmax} are "
                f"known); got {fmt_number(self.degree)}."
                if body.zonal
                else f"{body.name} has no zonal harmonics; build a Body with zonal=(J2, ...)."
            )

    @property
    def central_body(self) -> Body:
        return self.body

    PARAMETERS = ("ZONAL_DEGREE",)
    uses_pole = True  # about the Earth's pole (the force model's table), else the frame's z

    def pack(self, model) -> None:
        model.zonal = self.coefficients()
        model.force[fb.ZONAL_DEGREE] = self.degree

    def coefficients(self) -> np.ndarray:
        """J_n indexed by n (entries 0 and 1 are zero), dimensionless."""
        j = np.zeros(self.degree + 1)
        for n in range(2, self.degree + 1):
            j[n] = self.body.jn(n)
        return j

    def __repr__(self):
        return f"Zonal({self.body.name}, degree={self.degree})"


class J2(Zonal):
    """The J2 (oblateness) term of ``body`` alone: ``Zonal(body, 2)``."""

    def __init__(self, body: Body = EARTH):
        super().__init__(body, 2)

    def __repr__(self):
        return f"J2({self.body.name})"


@dataclass(frozen=True, repr=False)
class AtmosphericDrag(Perturbation):
    """Drag in an exponential atmosphere that co-rotates with the central body.

    Parameters
    ----------
    ballistic_coefficient : Quantity, m^2/kg
        Cd * A / m (e.g. 2.2 * 1 m^2 / 100 kg = 0.022 m^2/kg), m the spacecraft's mass at the
        state's epoch: burns of :func:`~visviva.propagate_cowell` that know the mass scale it
        by m(epoch) / m(t) (:mod:`visviva.satellites.burn_mass`).
    body : Body
        Central body (default Earth): its radius and flattening define the geodetic altitude,
        its rotation rate the co-rotating atmosphere (a body without a ``rotation_rate``: an
        atmosphere at rest in the frame).
    table : array_like (K, 3), optional
        Base altitude (km), density at the base (kg/m^3), scale height (km). Default, for the
        Earth only: Vallado (2013), Table 8-4 (0 to 1000+ km); another body needs its own.

    Notes
    -----
    a = -1/2 rho(h) (Cd A / m) |v_rel| v_rel, v_rel = v - omega x r,
    rho(h) = rho_0 exp(-(h - h_0)/H) (Vallado 2013, eqs. 8-29, 8-31, 8-33). For a GCRS state
    with an epoch the atmosphere rotates about the Earth's pole (the celestial intermediate
    pole of :func:`earth_pole_table`, 0.134 deg from the GCRS z axis in 2024, the table the
    zonal field shares), and h is the exact geodetic height above the WGS-84 ellipsoid about
    that pole (:func:`visviva.core.geodetic.geodetic`; polar motion, < 10 m on the ground, left
    out); without an epoch, or about another body, the frame's z axis. Neither density model
    depends on the Earth's rotation angle (the table on h alone, NRLMSIS on h, the geodetic
    latitude and the hour angle from the Sun, measured about the same pole).

    ``model="nrlmsis"`` uses NRLMSIS 2.1 (Emmert et al. 2021, via ``pymsis``) with the
    space-weather indices you give (``f107``: previous-day F10.7, ``f107a``: 81-day mean,
    ``ap``: daily Ap; never downloaded). The density is tabulated once at the state's epoch on a
    grid of geodetic altitude (0-1000 km, 10 km; from 80 km before audit42), geodetic latitude
    (5 deg) and hour angle from the Sun (15 deg), and interpolated in ln(rho) during the run by
    a tricubic B-spline (C2, periodic in hour angle, continued over the poles, linear in ln(rho)
    above 1000 km; within 0.4 % of direct NRLMSIS calls in 150-900 km, 8 % near the
    tropopause); the bulge
    follows the Sun, but the seasonal and space-weather variation over the run is ignored
    (valid for runs of days; split longer runs).
    """

    ballistic_coefficient: u.Quantity = None
    body: Body = EARTH
    table: np.ndarray = field(default=None)
    model: str = "exponential"
    f107: float | None = None
    f107a: float | None = None
    ap: float | None = None

    def __post_init__(self):
        if self.model not in ("exponential", "nrlmsis"):
            raise InvalidInputError(
                f"model must be 'exponential' or 'nrlmsis'; got {self.model!r}."
            )
        body = require_body(self.body, "AtmosphericDrag")
        object.__setattr__(self, "body", body)
        if body.name != "earth" and (self.model == "nrlmsis" or self.table is None):
            what = "NRLMSIS" if self.model == "nrlmsis" else "the default table (Vallado 2013, " \
                "Table 8-4)"
            raise InvalidInputError(
                f"{what} is the Earth's atmosphere, not {body.name}'s: give {body.name}'s own "
                "exponential table, AtmosphericDrag(bc, body=..., table=[[base altitude km, "
                "density kg/m^3, scale height km], ...]) (a body without an atmosphere has no "
                "drag)."
            )
        if self.model == "nrlmsis":
            if self.f107 is None or self.f107a is None or self.ap is None:
                raise InvalidInputError(
                    "the NRLMSIS model needs the space-weather indices (no download is made): "
                    "AtmosphericDrag(bc, model='nrlmsis', f107=150, f107a=150, ap=4)."
                )
            for name in ("f107", "f107a", "ap"):
                val = float(to_array(getattr(self, name), "dimensionless", name))
                if not (np.isfinite(val) and val >= 0):
                    raise InvalidInputError(f"{name} must be a finite number >= 0.")
                object.__setattr__(self, name, val)
            try:
                import pymsis  # noqa: F401
            except ImportError as exc:
                raise InvalidInputError(
                    "model='nrlmsis' needs pymsis: pip install visviva[ephem]."
                ) from exc
        if self.ballistic_coefficient is None:
            raise InvalidInputError(
                "AtmosphericDrag needs ballistic_coefficient = Cd*A/m, e.g. "
                "AtmosphericDrag(2.2 * 1.0 * u.m**2 / (100 * u.kg))."
            )
        bc = _area_per_mass(self.ballistic_coefficient, "ballistic_coefficient", "m / (Cd A)")
        if bc.ndim != 0:
            raise InvalidInputError("ballistic_coefficient must be a scalar Quantity (m^2/kg).")
        require_positive(bc, "ballistic_coefficient")
        table = VALLADO_EXPONENTIAL_TABLE if self.table is None else self.table
        table = np.ascontiguousarray(table, dtype=np.float64)
        if table.ndim != 2 or table.shape[1] != 3 or not np.all(np.isfinite(table)):
            raise InvalidInputError(
                "table must be a finite (K, 3) array: base altitude km, density kg/m^3, "
                "scale height km."
            )
        if np.any(np.diff(table[:, 0]) <= 0) or np.any(table[:, 1:] <= 0):
            raise InvalidInputError(
                "table base altitudes must increase and densities/scale heights be > 0."
            )
        object.__setattr__(self, "table", table)
        object.__setattr__(self, "_bc_m2_kg", float(bc))

    @property
    def central_body(self) -> Body:
        return self.body

    PARAMETERS = ("DRAG_ON", "BALLISTIC", "DENSITY_MODEL", "DENSITY_GRID", "DENSITY_GRID_SIZES",
                  "DENSITY_BAND")
    uses_pole = True  # the co-rotating atmosphere and the geodetic altitude

    #: the NRLMSIS model needs the Sun (its row in the ephemeris tables)
    @property
    def needs_sun(self) -> bool:
        return self.model == "nrlmsis"

    def pack(self, model) -> None:
        model.force[fb.DRAG_ON] = 1.0
        model.force[fb.BALLISTIC] = self.ballistic_coefficient_km2_kg
        model.force[fb.DENSITY_BAND] = 0.0  # the integrators hold a band per step
        model.atm = self.table
        if self.needs_sun:
            from .ephemeris import sun_position
            from .frames import gcrs_to_itrs
            from .msis_table import warn_long_run

            warn_long_run(model.span_s)

            sun0 = sun_position(model.epoch).to_value(u.km)
            s_itrs, _ = gcrs_to_itrs(sun0, np.zeros(3), model.epoch)
            table, meta = self.msis_grid(model.epoch, np.arctan2(s_itrs[1], s_itrs[0]))
            model.atm = table
            model.force[fb.DENSITY_MODEL] = 1.0
            model.force[fb.DENSITY_GRID:fb.DENSITY_GRID_SIZES + 3] = meta

    def msis_grid(self, epoch, sun_longitude_rad):
        """Tricubic B-spline coefficients of ln(rho) on the (hour angle, latitude, altitude)
        grid from NRLMSIS 2.1 at ``epoch``.

        Returns ``(table, meta)``: table ((n_h + 3) * (n_lat + 2), n_alt + 2), the coefficients
        with one node of margin on each side in the layout read by
        :func:`visviva.core.perturbations.grid_log_density`; meta the grid starts/steps and
        sizes for the slots ``DENSITY_GRID`` and ``DENSITY_GRID_SIZES`` of the force block.
        """
        from pymsis import msis

        from .msis_table import spline_coefficients

        alts = np.arange(0.0, 1000.0 + 1e-9, 10.0)  # from the ground (80 km before audit42)
        lats = np.arange(-90.0, 90.0 + 1e-9, 5.0)
        hours = np.arange(-180.0, 180.0 - 1e-9, 15.0)  # periodic: +180 is -180
        lons = np.mod(np.degrees(sun_longitude_rad) + hours + 180.0, 360.0) - 180.0
        # NRLMSIS takes a numpy datetime64 (no leap second): its UTC date and time, the
        # fraction of a second kept, a leap second (23:59:60.x) held at 23:59:59.999999
        from .frames import offline_iers

        with offline_iers():  # an epoch in UT1 needs the installed IERS table, no download
            iso = epoch.utc.copy(format="isot")
        iso.precision = 6
        text = str(iso.value)
        if text[17:19] == "60":
            text = text[:17] + "59.999999"
        date = np.array([np.datetime64(text, "us")])
        out = msis.run(date, lons, lats, alts, f107s=[self.f107], f107as=[self.f107a],
                       aps=[[self.ap] * 7], version=2.1)  # fmt: skip
        rho = np.asarray(out[0, ..., 0], dtype=np.float64)  # (hours, lats, alts)
        if not np.all(np.isfinite(rho)) or np.any(rho <= 0):
            raise InvalidInputError("NRLMSIS returned invalid densities for these indices.")
        table = spline_coefficients(np.log(rho))
        meta = np.array(
            [alts[0], 10.0, np.radians(lats[0]), np.radians(5.0), np.radians(hours[0]),
             np.radians(15.0), len(alts), len(lats), len(hours)]
        )  # fmt: skip
        return table, meta

    @property
    def ballistic_coefficient_m2_kg(self) -> float:
        """B = Cd A / m, m^2/kg (the drag parameter that orbit determination estimates)."""
        return self._bc_m2_kg

    @property
    def ballistic_coefficient_km2_kg(self) -> float:
        """Cd*A/m in km^2/kg."""
        return self._bc_m2_kg * 1e-6

    def density(self, altitude):
        """Density (Quantity, kg/m^3) of the model at geodetic ``altitude`` (Quantity)."""
        from ..core.perturbations import exponential_density

        h = to_array(altitude, "length", "altitude")
        rho = np.array([exponential_density(float(x), self.table) for x in h.ravel()])
        return rho.reshape(h.shape) * (u.kg / u.m**3)

    def __repr__(self):
        return f"AtmosphericDrag({self._bc_m2_kg:g} m2 / kg, {self.body.name}, {self.model})"


@dataclass(frozen=True, repr=False)
class ThirdBody(Perturbation):
    """The tidal attraction of a third body (Sun, Moon or a planet) from the offline ephemeris.

    Parameters
    ----------
    body : Body or str
        ``vv.SUN``, ``vv.MOON``, a planet, or ``vv.EARTH`` for a state about another body (a
        lunar orbiter feels the Earth's tide, ~1e-8 km/s^2 at 100 km above the Moon). Positions
        come from :mod:`visviva.satellites.ephemeris` (JPL DE421 when installed), relative to
        the central body; the central body itself is refused as a third body.

    Notes
    -----
    a = GM_b [(r_b - r)/|r_b - r|^3 - r_b/|r_b|^3] (Vallado 2013, eq. 8-35). The positions are
    tabulated every hour over the propagation span and interpolated by cubic Hermite polynomials
    (interpolation error below 1 cm for the Moon, 50 m out of 1 AU for the Sun).
    """

    body: Body = None

    def __post_init__(self):
        from .ephemeris import KNOWN_BODIES

        body = require_body(self.body, "ThirdBody")
        if body.name not in KNOWN_BODIES:
            raise InvalidInputError(
                f"ThirdBody({body.name}) is not available; use vv.SUN, vv.MOON, vv.EARTH (for a "
                "state about another body) or a planet."
            )
        object.__setattr__(self, "body", body)

    PARAMETERS = ("N_THIRD_BODIES",)

    def pack(self, model) -> None:
        # the body's row and GM are in the shared ephemeris tables (ForceModel): count it
        model.force[fb.N_THIRD_BODIES] += 1.0

    def __repr__(self):
        return f"ThirdBody({self.body.name})"


_SHADOWS = {None: 0, "none": 0, "cylindrical": 1, "conical": 2}


@dataclass(frozen=True, repr=False)
class SolarRadiationPressure(Perturbation):
    """Solar radiation pressure on a cannonball, with the central body's shadow.

    Parameters
    ----------
    area_to_mass : Quantity, m^2/kg
        Illuminated area over mass, A/m, m the mass at the state's epoch (burns that know
        the mass scale it by m(epoch) / m(t), as for :class:`AtmosphericDrag`).
    reflectivity : float
        Cr, 1 for a black body, up to 2 for a mirror (default 1.3).
    shadow : {"conical", "cylindrical", None}
        Shadow model: conical with penumbra (Montenbruck & Gill 2000, sec. 3.4.2), cylindrical
        (Vallado 2013, Algorithm 34), or none.
    body : Body
        The occulting central body (default Earth). For the Sun (a heliocentric orbit, a
        solar sail) the shadow is None whatever is given: no central body occults the Sun.

    Notes
    -----
    a = nu P_1AU Cr (A/m) (AU/d)^2 d_hat, with d = r - r_sun and nu the visible fraction of the
    solar disc (Montenbruck & Gill 2000, eq. 3.75), P_1AU = 4.56e-6 N/m^2.
    """

    area_to_mass: u.Quantity = None
    reflectivity: float = 1.3
    shadow: str | None = "conical"
    body: Body = EARTH

    def __post_init__(self):
        if self.area_to_mass is None:
            raise InvalidInputError(
                "SolarRadiationPressure needs area_to_mass, e.g. "
                "SolarRadiationPressure(0.02 * u.m**2 / u.kg)."
            )
        am = _area_per_mass(self.area_to_mass, "area_to_mass", "m / A")
        cr = to_array(self.reflectivity, "dimensionless", "reflectivity")
        if am.ndim != 0 or cr.ndim != 0:  # (float() of an array raised a bare TypeError)
            raise InvalidInputError(
                "area_to_mass and reflectivity must be scalars (one spacecraft), e.g. "
                "SolarRadiationPressure(0.02 * u.m**2 / u.kg, reflectivity=1.3); propagate "
                "spacecraft with other values in separate calls."
            )
        require_positive(am, "area_to_mass")
        if not 0.0 <= float(cr) <= 2.0:
            raise InvalidInputError(f"reflectivity Cr must lie in [0, 2]; got {float(cr)}.")
        if self.shadow not in _SHADOWS:
            raise InvalidInputError(
                f"shadow must be 'conical', 'cylindrical' or None; got {self.shadow!r}."
            )
        object.__setattr__(self, "body", require_body(self.body, "SolarRadiationPressure"))
        if self.body.name == "sun":  # nothing occults the Sun's light from the Sun's centre: a
            # shadow model there put every point in the umbra of the Sun itself (no SRP at all)
            object.__setattr__(self, "shadow", None)
        object.__setattr__(self, "_am_m2_kg", float(am))
        object.__setattr__(self, "_cr", float(cr))

    @property
    def central_body(self) -> Body:
        return self.body

    PARAMETERS = ("SRP_ON", "SRP_COEFFICIENT", "SHADOW_MODEL")
    needs_sun = True

    def pack(self, model) -> None:
        model.force[fb.SRP_ON] = 1.0
        model.force[fb.SRP_COEFFICIENT] = self.coefficient_km_s2
        model.force[fb.SHADOW_MODEL] = self.shadow_code

    @property
    def radiation_pressure_coefficient(self) -> float:
        """Cr as a float (``reflectivity`` as given, a number or a dimensionless Quantity):
        1 absorbing, 2 mirror-like; the SRP parameter that orbit determination estimates."""
        return self._cr

    @property
    def area_to_mass_m2_kg(self) -> float:
        """A / m of the illuminated area, m^2/kg."""
        return self._am_m2_kg

    @property
    def coefficient_km_s2(self) -> float:
        """P_1AU * Cr * A/m in km/s^2."""
        return SOLAR_PRESSURE_1AU_N_M2 * self._cr * self._am_m2_kg * 1e-3

    @property
    def shadow_code(self) -> int:
        return _SHADOWS[self.shadow]

    def __repr__(self):
        return (
            f"SolarRadiationPressure({self._am_m2_kg:g} m2 / kg, Cr={self._cr:g}, "
            f"shadow={self.shadow!r})"
        )


class SphericalHarmonics(Perturbation):
    """Full degree-and-order gravity field read from an ICGEM ``.gfc`` file.

    Parameters
    ----------
    path : str or Path
        An ICGEM gravity-field file (``gfc`` lines ``gfc n m C S [sigmaC sigmaS]`` after
        ``end_of_head``; header keys ``earth_gravity_constant`` (m^3/s^2), ``radius`` (m),
        ``norm`` (``fully_normalized`` or ``unnormalized``)), e.g. EGM2008 or EIGEN-6C4
        truncated to the degree you need.
    degree : int, optional
        Truncation degree N (default: the file's maximum), 2 <= N <= 80 (unnormalised
        recursion; higher degrees underflow).
    body : Body
        The central body (the Earth: the field rotates with the ITRS).

    Notes
    -----
    The acceleration is the gradient of
    U = GM/r sum_n sum_m (R/r)^n P_nm(sin phi) (C_nm cos m lambda + S_nm sin m lambda),
    evaluated with the V_nm/W_nm recursions of Cunningham (1970) as in Montenbruck & Gill (2000),
    sec. 3.2.4-3.2.5, in the body-fixed frame. The GCRS -> ITRS rotation (precession, nutation,
    Earth rotation, polar motion; astropy, offline IERS data) is computed at the state's epoch;
    during the run the Earth turns about its pole of date (the celestial intermediate pole of
    :func:`earth_pole_table`, which precession and nutation move by about 50" a year) at its
    the rate of the Earth rotation angle (IERS 2010, eq. 5.15; UT1 - TT's drift, the length
    of day, left out), and polar motion stays at the epoch's (it changes by ~0.1" a month;
    :func:`visviva.core.geodetic.body_fixed_matrix`). Until audit42 the frame was frozen at
    the epoch: its axis was 1.5" off the Earth's after 30 days, 22" after a year. Coefficients are
    rescaled to the state's GM and the body's radius, and degrees 0 and 1 are dropped.
    Do not combine with :class:`Zonal` (the zonal terms are included).
    """

    def __init__(self, path, degree: int | None = None, body: Body = EARTH):
        body = require_body(body, "SphericalHarmonics")
        if body.name != "earth":
            raise InvalidInputError("SphericalHarmonics is implemented for the Earth (ITRS) only.")
        self.body = body
        self.path = str(path)
        gm, radius, norm, rows = read_gfc(self.path)
        n_file = max(int(n) for n, _, _, _ in rows)
        n_max = n_file if degree is None else degree
        if not isinstance(n_max, int | np.integer) or not 2 <= n_max <= min(n_file, 80):
            given = (f"the file goes to degree {n_file}: give degree=N to truncate it" if
                     degree is None else f"got {fmt_number(degree)}")  # fmt: skip
            raise InvalidInputError(
                f"degree must be an integer in 2..{min(n_file, 80)} for {self.path}; {given}."
            )
        self.degree = int(n_max)
        self.gm_km3_s2 = gm * 1e-9
        self.radius_km = radius * 1e-3
        sh = np.zeros((2, n_max + 2, n_max + 2))
        from math import exp, lgamma, log

        for n, m, c_nm, s_nm in rows:
            n, m = int(n), int(m)
            if n > n_max or n < 2:
                continue
            if norm:
                # P_nm normalisation: sqrt((2 - delta_m0)(2n + 1)(n - m)!/(n + m)!)
                f = exp(
                    0.5
                    * (log((2.0 - (m == 0)) * (2 * n + 1)) + lgamma(n - m + 1) - lgamma(n + m + 1))
                )
            else:
                f = 1.0
            sh[0, n, m] = c_nm * f
            sh[1, n, m] = s_nm * f
        self.coefficients = sh

    @property
    def central_body(self) -> Body:
        return self.body

    PARAMETERS = ("HARMONICS_DEGREE", "FRAME_MATRIX")
    uses_pole = True  # the field's axis follows the Earth's pole of date (precession-nutation)

    def pack(self, model) -> None:
        if model.epoch is None:
            raise InvalidInputError(
                "SphericalHarmonics needs the state's epoch (to orient the Earth): build the "
                "state with epoch=Time(...)."
            )
        from ..core.geodetic import body_fixed_matrix
        from .frames import gcrs_to_itrs

        basis, _ = gcrs_to_itrs(np.eye(3) * 1e4, np.zeros((3, 3)), model.epoch)
        m0 = np.asarray(basis).T / 1e4  # columns: ITRS images of the GCRS axes
        # the kernel's frame is A R3(w t) C(p(t)) (the pole p of the model's table): A = M0 C0^T
        # makes it M0 at the epoch, and the precession-nutation of the pole moves it after
        probe = model.force.copy()
        probe[fb.FRAME_MATRIX:fb.FRAME_MATRIX + 9] = np.eye(3).ravel()
        c0 = np.empty((3, 3))
        body_fixed_matrix(0.0, probe, c0)
        model.force[fb.HARMONICS_DEGREE] = self.degree
        model.force[fb.FRAME_MATRIX:fb.FRAME_MATRIX + 9] = (m0 @ c0.T).ravel()
        model.sh = self.scaled(model.gm_km3_s2, model.central_body.radius_km)

    def scaled(self, gm_km3_s2: float, radius_km: float) -> np.ndarray:
        """Unnormalised (C, S) rescaled to another GM and reference radius."""
        n = np.arange(self.coefficients.shape[1])
        factor = (self.gm_km3_s2 / gm_km3_s2) * (self.radius_km / radius_km) ** n
        return np.ascontiguousarray(self.coefficients * factor[None, :, None])

    def __repr__(self):
        return f"SphericalHarmonics({self.path!r}, degree={self.degree})"


def _area_per_mass(value, name: str, inverse: str):
    """``to_array(value, "area_per_mass", name)``; a mass over an area (``inverse``, e.g. the
    ballistic coefficient m / (Cd A) of Vallado and of the US convention, in kg/m^2) is refused
    with the reciprocal to give (audit42: astropy's 'cannot be converted' said nothing of it)."""
    if isinstance(value, u.Quantity) and value.unit.is_equivalent(u.kg / u.m**2):
        inv = np.atleast_1d((1.0 / value).to_value(u.m**2 / u.kg))
        raise InvalidInputError(
            f"{name} is an area over a mass (m^2/kg); got {value}, a mass over an area "
            f"({inverse}): give its reciprocal, {name}={fmt_number(inv[0])} * u.m**2 / u.kg."
        )
    return to_array(value, "area_per_mass", name)


def earth_pole_table(epoch, t_start_s: float = 0.0, t_end_s: float = 0.0):
    """The Earth's pole in GCRS on knots at every 0h TT over a run: ``(t0, step, knots)``.

    The pole is the celestial intermediate pole (IAU 2006/2000A precession-nutation, ERFA
    ``xys06a``), the Earth's axis of rotation seen in the GCRS: 0.134 deg from the GCRS z axis
    in 2024 (precession since J2000), moving by about 0.05" a day. The knots are fixed in
    absolute time (whole TT days, one spare on each side of [t_start_s, t_end_s] s after
    ``epoch``), so that every run, whatever its epoch (restarted after a burn, from a fit's
    state, backwards), sees the same pole; between them it is linear (within 0.003" of the
    series). Polar motion (~0.3" between this axis and the ITRS z axis of EGM2008's
    coefficients, turning with the Earth) is left out. One table per run, built by the force
    model (:class:`visviva.satellites.cowell.ForceModel`) when a force or event turns with the
    pole (``uses_pole``: the zonal field, drag, the Lense-Thirring spin, altitude events).

    Returns
    -------
    t0 : float
        Time of the first knot, s (TT) after ``epoch``.
    step : float
        86400 s.
    knots : ndarray (K, 2)
        x and y of the pole's unit vector at the knots.
    """
    import erfa

    from .frames import offline_iers

    with offline_iers():  # a UT1 epoch needs the installed IERS table, never a download
        tt = epoch.tt
    jd1, jd2 = float(tt.jd1), float(tt.jd2)
    base = np.floor(jd1 - 0.5) + 0.5  # a 0h TT at or before the epoch, exact in float64
    frac = (jd1 - base) + jd2  # days from it to the epoch
    lo = int(np.floor(frac + min(t_start_s, t_end_s, 0.0) / c.DAY_S)) - 1
    hi = int(np.ceil(frac + max(t_start_s, t_end_s, 0.0) / c.DAY_S)) + 1
    days = np.arange(lo, hi + 1, dtype=np.float64)
    x, y, _ = erfa.xys06a(np.full(days.shape, base), days)
    return (lo - frac) * c.DAY_S, c.DAY_S, np.column_stack([x, y])


def flattening_of(body: Body) -> float:
    """Flattening used for geodetic altitude (WGS-84 for the Earth, 0 otherwise)."""
    return c.EARTH_FLATTENING if body.name == "earth" else 0.0


def ellipsoid_radius_of(body: Body) -> float:
    """Equatorial radius (km) of the ellipsoid of geodetic altitude: WGS-84's for the Earth
    (0.7 m longer than the gravity field's reference radius), the body's radius otherwise."""
    return c.EARTH_ELLIPSOID_RADIUS_KM if body.name == "earth" else body.radius_km
