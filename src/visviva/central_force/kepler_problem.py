"""Kepler-problem formulas: vis-viva, speeds, period, mean motion, apsides, energy, areal velocity.

astropy Quantities in, Quantities out, broadcasting over any shape (see :mod:`visviva.central_force`).
"""

from __future__ import annotations

import numpy as np
from astropy import units as u

from .._units import (
    broadcast_or_raise,
    to_array,
    to_quantity,
    to_vector,
)
from ..errors import DomainError, InvalidInputError
from ._inputs import (
    _finite_result,
    _gm_broadcast,
    _positive_array,
)


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
        shape_factor = 2.0 - r / a  # r v^2 / gm, dimensionless (r / inf = 0 on the parabola)
    if np.any(shape_factor < 0):
        raise DomainError(
            "r lies beyond the apoapsis 2a of this ellipse (2/r < 1/a), where the orbit never "
            "goes; check that r <= a (1 + e) <= 2a."
        )
    with np.errstate(over="ignore", invalid="ignore"):
        # sqrt(gm) / sqrt(r): gm / r alone underflows (gm = 1e-300, r = 1e300 km gave 0 km/s
        # for 1e-300) or overflows (r = 1e-320 km) where the speed itself is representable
        v = np.sqrt(gm) / np.sqrt(r) * np.sqrt(shape_factor)
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
        v = np.sqrt(gm) / np.sqrt(r)  # gm / r alone may under/overflow (see vis_viva)
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
        v = np.sqrt(2.0 * gm) / np.sqrt(r)  # gm / r alone may under/overflow (see vis_viva)
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
    broadcast_or_raise("apsides", a=a, ecc=ecc)
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
    broadcast_or_raise("specific_angular_momentum", r=r[..., 0], v=v[..., 0])
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
