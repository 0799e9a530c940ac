"""Central-force tools: vis-viva, energy, apsides, Kepler's laws, effective potential and Binet.

Two kinds of functions live here:

* **Kepler-problem formulas** (``vis_viva``, ``circular_speed``, ``escape_speed``,
  ``orbital_period``, ``mean_motion``, ``semi_major_axis_from_period``, ``apsides``,
  ``specific_energy``, ``specific_angular_momentum``, ``areal_velocity``): astropy Quantities in,
  Quantities out, broadcasting over any shape.
* **Any central force** (``effective_potential``, ``turning_points``, ``orbit_equation``): the
  potential V(r) or the force F(r) per unit mass is a Python callable. They work either with
  Quantities (then the callable receives and returns Quantities for ``effective_potential`` and
  ``turning_points``, and plain floats in km and km/s2 inside the ODE of ``orbit_equation``) or
  with plain numbers in any consistent units (e.g. G = M = 1 for teaching).

References
----------
.. [1] H. Goldstein, C. Poole, J. Safko, *Classical Mechanics*, 3rd ed., ch. 3 (the equivalent
   one-body problem, effective potential, Binet's equation, Bertrand's theorem).
.. [2] D. A. Vallado, *Fundamentals of Astrodynamics and Applications*, 4th ed., sec. 1.3 and 2.3.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from astropy import units as u

from ._units import (
    broadcast_or_raise,
    require_finite_result,
    to_array,
    to_quantity,
    to_vector,
)
from .errors import DomainError, InvalidInputError, ShapeError, UnitsError, fmt_number

__all__ = [
    "vis_viva",
    "circular_speed",
    "escape_speed",
    "orbital_period",
    "mean_motion",
    "semi_major_axis_from_period",
    "apsides",
    "specific_energy",
    "specific_angular_momentum",
    "areal_velocity",
    "kepler_potential",
    "power_law_force",
    "effective_potential",
    "turning_points",
    "orbit_equation",
    "BinetOrbit",
    "bertrand_apsidal_angle",
]


def _positive(arr, name):
    if np.any(arr <= 0):
        raise InvalidInputError(f"{name} must be > 0; got {fmt_number(np.min(arr))}.")
    return arr


def _positive_array(value, kind, name):
    """``value`` converted by :func:`visviva._units.to_array` (unit ``kind``) and checked > 0."""
    return _positive(to_array(value, kind, name), name)


def _gm(gm):
    return _positive_array(gm, "gm", "gm")


_broadcast = broadcast_or_raise  # ShapeError unless the arguments broadcast together


def _gm_broadcast(context, gm, **arrays):
    """The gravitational parameter (km3 / s2, > 0), checked to broadcast against ``arrays``.

    Parameters
    ----------
    context : str
        The calling function, named in the ShapeError.
    gm : Quantity (km3 / s2) or Body
        Gravitational parameter.
    **arrays : ndarray
        The other converted arguments, in the order of the call's signature.

    Returns
    -------
    ndarray
        gm in km3 / s2.
    """
    gm = _gm(gm)
    _broadcast(context, **arrays, gm=gm)
    return gm


def _finite_result(arr, context):
    """Raise DomainError if a result overflowed (or underflowed into a division by zero)."""
    return require_finite_result(arr, context, remedy="Rescale them (other units, or G = M = 1).")


def _real(value, name):
    """A finite Python float from a plain number (for callables built from parameters)."""
    try:
        x = float(value)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name} must be a real number; got {fmt_number(value)}.") from exc
    if not math.isfinite(x):
        raise InvalidInputError(f"{name} must be finite; got {fmt_number(x)}.")
    return x


def _callable(fn, name):
    if not callable(fn):
        raise InvalidInputError(
            f"{name} must be a callable, e.g. kepler_potential(gm) or lambda r: -1.0 / r; got "
            f"{type(fn).__name__}."
        )


# --------------------------------------------------------------------------------------------
# The Kepler problem


def vis_viva(r, a, gm):
    """Speed on a Keplerian orbit at distance ``r``: the vis-viva equation.

    Parameters
    ----------
    r : Quantity, length
        Distance from the attractor's centre (> 0).
    a : Quantity, length
        Semi-major axis: positive for ellipses, ``inf`` for the parabola, negative for hyperbolas.
    gm : Quantity (km3 / s2) or Body
        Gravitational parameter of the attractor.

    Returns
    -------
    Quantity, km / s
        Speed, broadcast over ``r``, ``a`` and ``gm``.

    Raises
    ------
    DomainError
        If ``r`` lies beyond the apoapsis (``2/r < 1/a``), where no Keplerian orbit reaches.

    Notes
    -----
    .. math:: v^2 = \\mu \\left(\\frac{2}{r} - \\frac{1}{a}\\right)

    which is the energy integral :math:`v^2/2 - \\mu/r = -\\mu/(2a)` (Vallado, eq. 1-31).

    Examples
    --------
    >>> import astropy.units as u, visviva as vv
    >>> print(f"{vv.vis_viva(6778 * u.km, 6778 * u.km, vv.EARTH):.4f}")
    7.6686 km / s
    """
    r = _positive_array(r, "length", "r")
    a = to_array(a, "length", "a", finite=False)
    if np.any(np.isnan(a)):
        raise InvalidInputError("a contains NaN; give inf for a parabola, not NaN.")
    if np.any(a == 0):
        raise InvalidInputError("a = 0 is not an orbit; a is inf for a parabola, < 0 for hyperbolas.")
    gm = _gm_broadcast("vis_viva", gm, r=r, a=a)
    with np.errstate(over="ignore", divide="ignore"):
        v2_over_gm = 2.0 / r - 1.0 / a
    if np.any(v2_over_gm < 0):
        raise DomainError(
            "r lies beyond the apoapsis 2a of this ellipse (2/r < 1/a), where the orbit never "
            "goes; check that r <= a (1 + e) <= 2a."
        )
    with np.errstate(over="ignore", invalid="ignore"):
        v = np.sqrt(gm * v2_over_gm)
    return to_quantity(_finite_result(v, "vis_viva"), "speed")


def circular_speed(r, gm):
    """Speed of a circular orbit of radius ``r``: :math:`v_c = \\sqrt{\\mu / r}` (km / s).

    Parameters
    ----------
    r : Quantity, length
        Orbit radius (> 0).
    gm : Quantity (km3 / s2) or Body
        Gravitational parameter.
    """
    r = _positive_array(r, "length", "r")
    gm = _gm_broadcast("circular_speed", gm, r=r)
    with np.errstate(over="ignore"):
        v = np.sqrt(gm / r)
    return to_quantity(_finite_result(v, "circular_speed"), "speed")


def escape_speed(r, gm):
    """Escape speed at distance ``r``: :math:`v_e = \\sqrt{2 \\mu / r}` (km / s), the parabolic speed.

    Parameters
    ----------
    r : Quantity, length
        Distance from the attractor's centre (> 0).
    gm : Quantity (km3 / s2) or Body
        Gravitational parameter.

    Examples
    --------
    >>> import astropy.units as u, visviva as vv
    >>> from visviva.central_force import escape_speed
    >>> print(f"{escape_speed(vv.EARTH.radius, vv.EARTH):.3f}")
    11.180 km / s
    """
    r = _positive_array(r, "length", "r")
    gm = _gm_broadcast("escape_speed", gm, r=r)
    with np.errstate(over="ignore"):
        v = np.sqrt(2.0 * gm / r)
    return to_quantity(_finite_result(v, "escape_speed"), "speed")


def orbital_period(a, gm):
    """Period of an elliptic orbit, Kepler's third law :math:`T = 2\\pi\\sqrt{a^3/\\mu}` (s).

    Parameters
    ----------
    a : Quantity, length
        Semi-major axis (> 0; open orbits have no period).
    gm : Quantity (km3 / s2) or Body
        Gravitational parameter (of the two bodies together, :math:`G(m_1 + m_2)`).

    Examples
    --------
    >>> import astropy.units as u, visviva as vv
    >>> from visviva.central_force import orbital_period
    >>> print(f"{orbital_period(1 * u.au, vv.SUN).to(u.day):.3f}")
    365.257 d
    """
    a = to_array(a, "length", "a")
    if np.any(a <= 0):
        raise DomainError(
            "orbital_period needs a > 0: parabolic and hyperbolic orbits (a = inf or a < 0) are "
            "open and have no period."
        )
    gm = _gm_broadcast("orbital_period", gm, a=a)
    with np.errstate(over="ignore"):
        period = 2.0 * np.pi * a * np.sqrt(a / gm)  # a sqrt(a): no overflow of a**3
    return to_quantity(_finite_result(period, "orbital_period"), "time")


def mean_motion(a, gm):
    """Mean motion :math:`n = \\sqrt{\\mu/|a|^3}` (rad / s) of an elliptic or hyperbolic orbit.

    Parameters
    ----------
    a : Quantity, length
        Semi-major axis, positive (ellipse) or negative (hyperbola); not infinite (for the
        parabola use ``KeplerianElements.mean_motion``, which is :math:`2\\sqrt{\\mu/p^3}`).
    gm : Quantity (km3 / s2) or Body
        Gravitational parameter.
    """
    a = to_array(a, "length", "a")
    if np.any(a == 0):
        raise InvalidInputError("a must be non-zero.")
    gm = _gm_broadcast("mean_motion", gm, a=a)
    with np.errstate(over="ignore", divide="ignore", under="ignore"):
        n = np.sqrt(gm / np.abs(a)) / np.abs(a)  # no overflow/underflow of |a|**3
    return _finite_result(n, "mean_motion") * (u.rad / u.s)


def semi_major_axis_from_period(period, gm):
    """Semi-major axis of the ellipse with the given period, :math:`a = (\\mu T^2/4\\pi^2)^{1/3}` (km).

    Parameters
    ----------
    period : Quantity, time
        Orbital period (> 0).
    gm : Quantity (km3 / s2) or Body
        Gravitational parameter.

    Examples
    --------
    >>> import astropy.units as u, visviva as vv
    >>> from visviva.central_force import semi_major_axis_from_period
    >>> print(f"{semi_major_axis_from_period(1 * u.sday, vv.EARTH):.1f}")  # geostationary
    42164.2 km
    """
    period = _positive_array(period, "time", "period")
    gm = _gm_broadcast("semi_major_axis_from_period", gm, period=period)
    with np.errstate(over="ignore"):
        # cbrt(gm) cbrt(T/2pi)^2: no overflow of gm T^2 for large T
        a = np.cbrt(gm) * np.cbrt(period / (2.0 * np.pi)) ** 2
    return to_quantity(_finite_result(a, "semi_major_axis_from_period"), "length")


def apsides(a, ecc):
    """Periapsis and apoapsis distances :math:`r_p = a(1-e)`, :math:`r_a = a(1+e)` (km).

    Parameters
    ----------
    a : Quantity, length
        Semi-major axis (> 0 for ellipses, < 0 for hyperbolas).
    ecc : float or array_like
        Eccentricity (>= 0, != 1: for the parabola use ``r_p = p / 2``).

    Returns
    -------
    r_p, r_a : Quantity, km
        ``r_a`` is ``inf`` for hyperbolas (the body never turns back).
    """
    a = to_array(a, "length", "a")
    ecc = to_array(ecc, "dimensionless", "ecc")
    _broadcast("apsides", a=a, ecc=ecc)
    if np.any(ecc < 0):
        raise InvalidInputError("ecc must be >= 0.")
    if np.any(ecc == 1):
        raise DomainError("a is infinite on the parabola: give p and use r_p = p / 2.")
    if np.any((ecc < 1) != (a > 0)):
        raise InvalidInputError("a must be > 0 for e < 1 and < 0 for e > 1.")
    with np.errstate(over="ignore"):
        r_p = a * (1.0 - ecc)
        r_a_ellipse = a * (1.0 + ecc)
    _finite_result(r_p, "apsides")
    _finite_result(np.where(ecc < 1, r_a_ellipse, 0.0), "apsides")
    r_a = np.where(ecc < 1, r_a_ellipse, np.inf)  # documented: inf for hyperbolas
    return to_quantity(r_p, "length"), to_quantity(r_a, "length")


def specific_energy(r, v, gm):
    """Specific orbital energy :math:`\\varepsilon = v^2/2 - \\mu/r` (km2 / s2).

    Parameters
    ----------
    r : Quantity, length
        Distance from the attractor (> 0): a magnitude, not a vector.
    v : Quantity, speed
        Speed: a magnitude.
    gm : Quantity (km3 / s2) or Body
        Gravitational parameter.
    """
    r = _positive_array(r, "length", "r")
    v = to_array(v, "speed", "v")
    gm = _gm_broadcast("specific_energy", gm, r=r, v=v)
    with np.errstate(over="ignore", invalid="ignore"):
        energy = 0.5 * v * v - gm / r
    return to_quantity(_finite_result(energy, "specific_energy"), "spec_energy")


def specific_angular_momentum(r, v):
    """Specific angular momentum vector :math:`\\mathbf h = \\mathbf r \\times \\mathbf v` (km2 / s).

    Parameters
    ----------
    r : Quantity, length, shape (..., 3)
        Position vectors.
    v : Quantity, speed, shape (..., 3)
        Velocity vectors.
    """
    r = to_vector(r, "length", "r")
    v = to_vector(v, "speed", "v")
    _broadcast("specific_angular_momentum", r=r[..., 0], v=v[..., 0])
    with np.errstate(over="ignore", invalid="ignore"):
        h = np.cross(r, v)
    return to_quantity(_finite_result(h, "specific_angular_momentum"), "spec_angmom")


def areal_velocity(r, v):
    """Rate at which the radius vector sweeps area, :math:`dA/dt = |\\mathbf r \\times \\mathbf v|/2`.

    Kepler's second law: constant along any central-force orbit (km2 / s).

    Parameters
    ----------
    r : Quantity, length, shape (..., 3)
        Position vectors.
    v : Quantity, speed, shape (..., 3)
        Velocity vectors.
    """
    h = specific_angular_momentum(r, v)
    with np.errstate(over="ignore"):
        rate = 0.5 * np.linalg.norm(h.value, axis=-1)
    return _finite_result(rate, "areal_velocity") * h.unit


# --------------------------------------------------------------------------------------------
# Any central force


def kepler_potential(gm):
    """The Newtonian potential per unit mass :math:`V(r) = -\\mu / r` as a callable.

    Parameters
    ----------
    gm : Quantity (km3 / s2), Body, or float
        With a Quantity or Body the callable takes Quantity ``r``; with a float it takes floats
        in the same consistent units.
    """
    if isinstance(gm, u.Quantity) or hasattr(gm, "gm"):
        gm_q = to_quantity(_gm(gm), "gm")
        return lambda r: -gm_q / r
    gm = _real(gm, "gm")
    if not gm > 0:
        raise InvalidInputError("gm must be > 0.")
    return lambda r: -gm / r


def power_law_force(k, n):
    """The attractive power-law force per unit mass :math:`F(r) = -k r^n` as a callable.

    ``n = -2`` is gravity, ``n = 1`` the isotropic harmonic oscillator (Hooke): the two forces
    whose bound orbits are all closed (Bertrand's theorem). Plain numbers, consistent units.

    Parameters
    ----------
    k : float
        Strength (> 0 for attraction).
    n : float
        Exponent.
    """
    k, n = _real(k, "k"), _real(n, "n")
    return lambda r: -k * r**n


def _split_units(r, h):
    """Decide the unit mode of a (r, h) pair: both Quantities or both plain."""
    r_is_q, h_is_q = isinstance(r, u.Quantity), isinstance(h, u.Quantity)
    if r_is_q != h_is_q:
        raise UnitsError(
            "give r and h both as Quantities (e.g. r in km, h in km2 / s) or both as plain "
            "numbers in one consistent unit system."
        )
    return r_is_q


def effective_potential(r, h, potential):
    """Effective potential of radial motion :math:`V_{eff}(r) = h^2/(2r^2) + V(r)` per unit mass.

    Parameters
    ----------
    r : Quantity (length) or array_like
        Radii (> 0).
    h : Quantity (km2 / s) or float
        Specific angular momentum.
    potential : callable
        ``V(r)`` per unit mass, vectorised: called once with the whole ``r`` array (as a Quantity
        when ``r`` is one, and then returning a Quantity of specific energy).

    Returns
    -------
    Quantity (km2 / s2) or ndarray
        The effective potential at each radius.

    Notes
    -----
    The radial equation of a particle in a central potential is
    :math:`\\ddot r = -dV_{eff}/dr`; the orbit is bounded between the turning points where
    :math:`V_{eff}(r) = \\varepsilon` (Goldstein sec. 3.3).

    Examples
    --------
    >>> from visviva.central_force import effective_potential, kepler_potential
    >>> print(effective_potential(1.0, 1.0, kepler_potential(1.0)))  # minimum of V_eff at r = h^2/mu
    -0.5
    """
    _callable(potential, "potential")
    if _split_units(r, h):
        r_km = _positive_array(r, "length", "r")
        h_c = to_array(h, "spec_angmom", "h")
        V = to_array(potential(to_quantity(r_km, "length")), "spec_energy", "potential(r)")
        _broadcast("effective_potential", r=r_km, h=h_c, V=V)
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            out = h_c**2 / (2.0 * r_km**2) + V
        return to_quantity(_finite_result(out, "effective_potential"), "spec_energy")
    r = _positive(to_array(r, "length", "r", allow_plain=True), "r")
    h = to_array(h, "length", "h", allow_plain=True)
    V = to_array(potential(r), "length", "potential(r)", allow_plain=True)
    _broadcast("effective_potential", r=r, h=h, V=V)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        out = h**2 / (2.0 * r**2) + V
    _finite_result(out, "effective_potential")
    return out if out.ndim else float(out)


def turning_points(energy, h, potential, r_min, r_max, n_grid=4000):
    """Radii where :math:`V_{eff}(r) = \\varepsilon`: the apsides of the orbit (ascending).

    Parameters
    ----------
    energy : Quantity (km2 / s2) or float
        Specific energy of the orbit.
    h : Quantity (km2 / s) or float
        Specific angular momentum.
    potential : callable
        ``V(r)`` per unit mass (see :func:`effective_potential`).
    r_min, r_max : Quantity (length) or float
        The interval searched, ``0 < r_min < r_max``.
    n_grid : int
        Points of the logarithmic scan that brackets the roots before Brent's method refines them
        to machine precision. Roots closer together than the grid spacing can be missed.

    Returns
    -------
    Quantity (km) or ndarray
        The turning points found, ascending; empty when the energy is everywhere below or above
        the effective potential in the interval.
    """
    from scipy.optimize import brentq, minimize_scalar

    _callable(potential, "potential")
    if isinstance(n_grid, bool) or not isinstance(n_grid, int | np.integer) or n_grid < 2:
        raise InvalidInputError(f"n_grid must be an integer >= 2; got {fmt_number(n_grid)}.")
    quantity = isinstance(energy, u.Quantity)
    if quantity:
        E = float(to_array(energy, "spec_energy", "energy"))
        lo, hi = float(to_array(r_min, "length", "r_min")), float(to_array(r_max, "length", "r_max"))
        h_q = to_quantity(to_array(h, "spec_angmom", "h"), "spec_angmom")

        def f(r):
            r = to_quantity(np.asarray(r, dtype=float), "length")
            return to_array(effective_potential(r, h_q, potential), "spec_energy", "V_eff") - E
    else:
        E = _real(energy, "energy")
        lo, hi = float(to_array(r_min, "length", "r_min", allow_plain=True, finite=False)), float(
            to_array(r_max, "length", "r_max", allow_plain=True, finite=False)
        )

        def f(r):
            return np.asarray(effective_potential(np.asarray(r, dtype=float), h, potential)) - E

    if not (0 < lo < hi and math.isfinite(hi)):
        raise InvalidInputError("need 0 < r_min < r_max < inf for the search interval.")
    grid = np.geomspace(lo, hi, int(n_grid))
    values = f(grid)
    roots = [float(r) for r, v in zip(grid, values, strict=True) if v == 0.0]
    brackets = [
        (grid[i], grid[i + 1])
        for i in np.flatnonzero(np.signbit(values[:-1]) != np.signbit(values[1:]))
        if values[i] != 0.0 and values[i + 1] != 0.0
    ]
    # two roots closer than the grid spacing (a nearly circular orbit) hide in a local minimum of
    # V_eff - E that stays positive on the grid: find the minimum and split the bracket there
    interior = np.flatnonzero((values[1:-1] > 0) & (values[1:-1] <= values[:-2])
                              & (values[1:-1] <= values[2:])) + 1
    for i in interior:
        best = minimize_scalar(lambda x: float(f(np.array([x]))[0]), bounds=(grid[i - 1], grid[i + 1]),
                               method="bounded", options={"xatol": 1e-14 * grid[i]})
        if best.fun < 0:
            brackets += [(grid[i - 1], best.x), (best.x, grid[i + 1])]
        elif best.fun == 0:
            roots.append(float(best.x))  # a double root: the circular orbit
    for lo_b, hi_b in brackets:
        roots.append(brentq(lambda x: float(f(np.array([x]))[0]), lo_b, hi_b,
                            xtol=1e-15 * lo_b, rtol=4 * np.finfo(float).eps, maxiter=200))
    roots = np.array(sorted(roots))
    return to_quantity(roots, "length") if quantity else roots


def bertrand_apsidal_angle(n):
    """Apsidal angle of a nearly circular orbit under the power-law force :math:`F \\propto -r^n`.

    :math:`\\Delta\\theta = \\pi / \\sqrt{n + 3}` (rad), for ``n > -3``. It is a rational multiple
    of :math:`\\pi` that stays so for all amplitudes only for ``n = -2`` (gravity: ``pi``) and
    ``n = 1`` (Hooke: ``pi/2``): Bertrand's theorem (Goldstein sec. 3.6 and appendix A).

    Parameters
    ----------
    n : float
        Exponent of the force law.
    """
    n = to_array(n, "dimensionless", "n")
    if np.any(n <= -3):
        raise DomainError("circular orbits are unstable for n <= -3: there is no apsidal angle.")
    return np.pi / np.sqrt(n + 3.0)


@dataclass(frozen=True)
class BinetOrbit:
    """A planar orbit under a central force, from the Binet equation.

    Attributes
    ----------
    theta : ndarray
        Polar angle samples (rad), from 0 to ``theta_max``.
    r : ndarray
        Radius at each sample (the units of the inputs: km when Quantities were given).
    apsis_theta : ndarray
        Polar angles of the apsides found (where dr/dtheta = 0), ascending (rad).
    apsis_r : ndarray
        Radii at those apsides.
    h : float
        Specific angular momentum used.
    """

    theta: np.ndarray
    r: np.ndarray
    apsis_theta: np.ndarray
    apsis_r: np.ndarray
    h: float

    @cached_property
    def apsidal_angle(self) -> float:
        """Mean polar angle between successive apsides (periapsis to apoapsis), rad."""
        if self.apsis_theta.size < 2:
            raise DomainError(
                "fewer than two apsides were found: integrate further (larger theta_max), or the "
                "orbit is circular to the integration tolerance (r constant: apsides undefined; "
                "for the apsidal angle of nearly circular orbits use bertrand_apsidal_angle) or "
                "unbound."
            )
        return float(np.mean(np.diff(self.apsis_theta)))

    @cached_property
    def precession_per_orbit(self) -> float:
        """Advance of the periapsis per radial period, :math:`2\\Delta\\theta - 2\\pi` (rad)."""
        return 2.0 * self.apsidal_angle - 2.0 * np.pi

    def is_closed(self, max_turns: int = 12, tol: float = 1e-6) -> bool:
        """Whether the apsidal angle is (to ``tol`` rad) a rational multiple p/q of 2 pi, q <= max_turns."""
        ratio = self.apsidal_angle / (2.0 * np.pi)
        return any(
            abs(ratio * q - round(ratio * q)) * 2.0 * np.pi < tol for q in range(1, 2 * max_turns + 1)
        )

    @cached_property
    def xy(self) -> np.ndarray:
        """Cartesian positions in the orbital plane, shape (n, 2)."""
        return np.stack([self.r * np.cos(self.theta), self.r * np.sin(self.theta)], axis=-1)


def orbit_equation(force, r0, h, dr_dtheta0=0.0, theta_max=4.0 * np.pi, n_points=2000, rtol=1e-12):
    """Integrate the orbit equation (Binet) :math:`u'' + u = -F(1/u) / (h^2 u^2)`, u = 1/r.

    Parameters
    ----------
    force : callable
        Radial force per unit mass ``F(r)`` (negative = attractive), called with a float ``r``
        (in km when the other inputs are Quantities), returning a float (km / s2).
    r0 : Quantity (length) or float
        Radius at theta = 0 (> 0).
    h : Quantity (km2 / s) or float
        Specific angular momentum (> 0).
    dr_dtheta0 : Quantity (length) or float
        :math:`dr/d\\theta` at theta = 0; zero starts at an apsis.
    theta_max : float
        Polar angle to integrate to (rad).
    n_points : int
        Number of output samples of ``r(theta)``.
    rtol : float
        Relative tolerance of scipy's DOP853 (the absolute tolerance is scaled to ``1/r0``).

    Returns
    -------
    BinetOrbit
        Samples, the apsides found (by root finding on :math:`du/d\\theta = 0` in the dense output)
        and the apsidal angle and precession derived from them.

    Notes
    -----
    With :math:`r^2\\dot\\theta = h` and u = 1/r the radial equation of motion becomes
    :math:`d^2u/d\\theta^2 + u = -F(1/u)/(h^2u^2)` (Goldstein eq. 3.34). For gravity,
    :math:`F = -\\mu u^2` and the solution is the conic :math:`u = (\\mu/h^2)(1 + e\\cos\\theta)`.

    Examples
    --------
    >>> from visviva.central_force import orbit_equation, power_law_force
    >>> orbit = orbit_equation(power_law_force(1.0, -2), r0=1.0, h=0.9)
    >>> print(f"{orbit.apsidal_angle / 3.141592653589793:.9f}")  # Kepler: closed, pi
    1.000000000
    """
    from scipy.integrate import solve_ivp

    _callable(force, "force")
    quantity = _split_units(r0, h)

    def scalar(value, kind, name, allow_plain):
        arr = to_array(value, kind, name, allow_plain=allow_plain)
        if arr.ndim != 0:
            raise ShapeError(
                f"orbit_equation integrates one orbit: {name} must be a scalar; got shape "
                f"{arr.shape}. Call it once per orbit."
            )
        return float(arr)

    if quantity:
        r0 = scalar(r0, "length", "r0", False)
        h = scalar(h, "spec_angmom", "h", False)
        plain_zero = not isinstance(dr_dtheta0, u.Quantity) and np.all(np.asarray(dr_dtheta0) == 0)
        dr_dtheta0 = scalar(dr_dtheta0, "length", "dr_dtheta0", plain_zero)
    else:
        r0 = scalar(r0, "length", "r0", True)
        h = scalar(h, "length", "h", True)
        dr_dtheta0 = scalar(dr_dtheta0, "length", "dr_dtheta0", True)
    for name, val in (("r0", r0), ("h", h)):
        if not val > 0:
            raise InvalidInputError(f"{name} must be finite and > 0; got {fmt_number(val)}.")
    theta_max = float(to_array(theta_max, "angle", "theta_max", finite=False))
    if not (math.isfinite(theta_max) and theta_max > 0):
        raise InvalidInputError("theta_max must be finite and > 0 (rad).")
    if isinstance(n_points, bool) or not isinstance(n_points, int | np.integer) or n_points < 2:
        raise InvalidInputError(f"n_points must be an integer >= 2; got {fmt_number(n_points)}.")
    if not (isinstance(rtol, float | int) and math.isfinite(rtol) and 0 < rtol < 1):
        raise InvalidInputError(f"rtol must be a float in (0, 1); got {fmt_number(rtol)}.")
    h2 = h * h

    def rhs(_theta, y):
        uu, du = y
        if uu <= 0:
            return [du, 0.0]
        F = force(1.0 / uu)
        try:
            F = float(F)
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(
                "force(r) must return one float (the radial force per unit mass, in km/s2 when "
                f"the inputs are Quantities); got {F!r}."
            ) from exc
        if not math.isfinite(F):
            raise InvalidInputError(
                f"force(r) returned {fmt_number(F)} at r = {fmt_number(1.0 / uu)}: the force must be finite along "
                "the orbit. Check the force law (and its units)."
            )
        return [du, -uu - F / (h2 * uu * uu)]

    def apsis(_theta, y):
        return y[1]

    def escaped(_theta, y):
        return y[0]

    escaped.terminal = True
    u0 = 1.0 / r0
    du0 = -dr_dtheta0 / r0**2
    theta = np.linspace(0.0, theta_max, int(n_points))
    sol = solve_ivp(rhs, (0.0, theta_max), [u0, du0], method="DOP853", t_eval=theta,
                    events=(apsis, escaped), rtol=rtol, atol=rtol * u0 * 1e-3, dense_output=True)
    if not sol.success:
        raise InvalidInputError(f"the orbit equation could not be integrated: {sol.message}")
    u_s = sol.y[0]
    if sol.t_events[1].size or np.any(u_s <= 0) or not np.all(np.isfinite(u_s)):
        raise DomainError(
            "the orbit reaches r = infinity (u = 0) within theta_max: it is unbound; use a smaller "
            "theta_max or more angular momentum/less energy for a bound orbit."
        )
    apsis_theta = sol.t_events[0]
    # an apsis exactly at theta = 0 (dr/dtheta0 = 0) is not reported as an event: add it
    if du0 == 0.0:
        apsis_theta = np.concatenate([[0.0], apsis_theta[apsis_theta > 0]])
    # a circular orbit (r constant to the integration tolerance) has no apsides: the events
    # found are zero crossings of rounding noise in du/dtheta, at meaningless angles
    if np.ptp(u_s) <= 1e3 * rtol * np.max(u_s):
        apsis_theta = np.empty(0)
    apsis_r = 1.0 / sol.sol(apsis_theta)[0] if apsis_theta.size else np.empty(0)
    return BinetOrbit(theta=sol.t, r=1.0 / u_s, apsis_theta=apsis_theta, apsis_r=apsis_r, h=h)
