"""Analytic secular J2 theory: node and perigee drift, sun-synchronous and frozen orbits.

The first-order secular rates of a J2 field (Vallado 2013, eqs. 9-41; Brouwer 1959), for mean
elements a, e, i with n = sqrt(mu/a^3), p = a (1 - e^2):

    dRAAN/dt = -3/2 n J2 (R/p)^2 cos i
    dargp/dt =  3/4 n J2 (R/p)^2 (5 cos^2 i - 1)
    dM/dt    =  n [1 + 3/4 J2 (R/p)^2 sqrt(1 - e^2) (3 cos^2 i - 1)]

>>> import visviva as vv
>>> from astropy import units as u
>>> inc = vv.satellites.sun_synchronous_inclination(7078.137 * u.km)
>>> print(f"{inc.to_value(u.deg):.3f}")
98.188
"""

from __future__ import annotations

import numpy as np
from astropy import units as u

from .. import constants as c
from .._units import advance_epoch, broadcast_or_raise, to_array, to_quantity
from ..bodies import EARTH
from ..errors import DomainError, InvalidInputError

__all__ = [
    "j2_secular_rates",
    "propagate_j2_secular",
    "sun_synchronous_inclination",
    "sun_synchronous_semi_major_axis",
    "frozen_eccentricity",
    "repeat_ground_track_semi_major_axis",
    "CRITICAL_INCLINATION",
    "SUN_SYNCHRONOUS_RATE",
]

#: Mean motion of the Sun in right ascension: 360 deg per tropical year (365.2421897 d).
SUN_SYNCHRONOUS_RATE = (2 * np.pi / (365.2421897 * c.DAY_S)) * u.rad / u.s
#: The inclination where the perigee does not drift under J2: arccos(1/sqrt(5)).
CRITICAL_INCLINATION = np.arccos(1 / np.sqrt(5)) * u.rad


def _body_consts(body):
    try:
        j2 = body.j2
    except AttributeError as exc:
        raise InvalidInputError(f"{body!r} has no J2; use a body with zonal harmonics.") from exc
    return body.gm_km3_s2, body.radius_km, j2


def _check_ecc(e):
    if np.any((e < 0) | (e >= 1)):
        raise DomainError(
            "secular J2 theory needs a closed orbit, 0 <= e < 1; parabolic and hyperbolic orbits "
            "have no secular drift (propagate them with vv.propagate_cowell)."
        )


def _check_inc(i):
    if np.any((i < 0) | (i > np.pi)):
        raise DomainError("inc must lie in [0, pi] rad (0 to 180 deg); got values outside.")


def _check_above_surface(periapsis_km, body, radius_km, what):
    if np.any(periapsis_km < radius_km):
        raise DomainError(
            f"{what}: the periapsis a (1 - e) lies below the surface of "
            f"{getattr(body, 'name', 'the body')} (radius {radius_km} km); no such orbit exists."
        )


def j2_secular_rates(a, ecc, inc, body=EARTH):
    """Secular rates of RAAN, argument of periapsis and mean anomaly under J2.

    Parameters
    ----------
    a : Quantity, length
        Mean semi-major axis (> 0; elliptic orbits, 0 <= e < 1), with the periapsis
        a (1 - e) at or above the body's radius (DomainError otherwise: the zonal expansion
        describes the field outside the body only).
    ecc : float or array_like
        Mean eccentricity.
    inc : Quantity or float
        Mean inclination (rad for plain floats).
    body : Body
        Central body with J2 (default Earth).

    Returns
    -------
    raan_rate, argp_rate, mean_anomaly_rate : Quantity, rad/s
        Broadcast over the inputs.

    Notes
    -----
    Vallado (2013), eqs. 9-41 (first-order secular J2 theory; Brouwer 1959, Kozai 1959).
    """
    a_km = to_array(a, "length", "a")
    e = to_array(ecc, "dimensionless", "ecc")
    i = to_array(inc, "angle", "inc")
    if np.any(~np.isfinite(a_km)) or np.any(~np.isfinite(e)) or np.any(~np.isfinite(i)):
        raise InvalidInputError("a, ecc and inc must be finite (no NaN or inf).")
    if np.any(a_km <= 0):
        raise InvalidInputError("a must be > 0 (elliptic orbits).")
    _check_ecc(e)
    _check_inc(i)
    broadcast_or_raise("j2_secular_rates", a=a_km, ecc=e, inc=i)
    gm, R, j2 = _body_consts(body)
    _check_above_surface(a_km * (1 - e), body, R, f"give a with a (1 - e) >= {R} km")
    n = np.sqrt(gm / a_km**3)
    p = a_km * (1 - e**2)
    k = n * j2 * (R / p) ** 2
    ci = np.cos(i)
    raan_rate = -1.5 * k * ci
    argp_rate = 0.75 * k * (5 * ci**2 - 1)
    m_rate = n + 0.75 * k * np.sqrt(1 - e**2) * (3 * ci**2 - 1)
    q = u.rad / u.s
    return raan_rate * q, argp_rate * q, m_rate * q


def propagate_j2_secular(elements, dt, body=EARTH):
    """Advance mean Keplerian elements by ``dt`` with the secular J2 rates.

    Parameters
    ----------
    elements : KeplerianElements
        Mean elements (elliptic), any shape.
    dt : Quantity, time
        Broadcasts against the elements' shape.
    body : Body
        Central body with J2.

    Returns
    -------
    KeplerianElements
        a, e, i unchanged; RAAN, argp and mean anomaly advanced linearly, true anomaly from the
        new mean anomaly (Kepler's equation); in the frame of the input when it has one
        (elements or states of a satellite, e.g. ``sat.teme(t).to_elements()``).

    Notes
    -----
    The rates turn the orbit about the Earth's pole. Elements about the Earth with an epoch,
    GCRS or plain (taken as GCRS), are drifted in the equator of the epoch's celestial
    intermediate pole (0.134 deg from the GCRS z axis in 2024) and turned back; TEME elements
    (true equator) and elements without an epoch, about their frame's z axis.
    """
    from ..anomalies import mean_to_true
    from ..elements import KeplerianElements
    from .satellite_states import with_frame

    if not isinstance(elements, KeplerianElements):
        if hasattr(elements, "to_elements"):
            elements = elements.to_elements()
        else:
            raise InvalidInputError(
                f"propagate_j2_secular takes vv.KeplerianElements (or vv.StateVectors, converted "
                f"with .to_elements()); got {type(elements).__name__}."
            )
        if not isinstance(elements, KeplerianElements):
            raise InvalidInputError(
                "propagate_j2_secular takes vv.KeplerianElements; convert with .to_elements()."
            )
    dt_s = to_array(dt, "time", "dt")
    frame = getattr(elements, "frame", None)
    to_equator = _equator_rotation(elements, body)
    if to_equator is not None:  # GCRS elements: the theory's angles are about the Earth's pole
        elements = _rotated_elements(elements, to_equator)
    e = np.asarray(elements.eccentricity, dtype=float)
    if np.any(~(e < 1)):
        raise DomainError(
            "secular J2 propagation needs a closed orbit (e < 1); parabolic and hyperbolic "
            f"orbits (here e = {np.max(e)}) have no secular drift: use vv.propagate_cowell."
        )
    a = elements.semi_major_axis
    inc = elements.inclination
    broadcast_or_raise("propagate_j2_secular", elements=e, dt=dt_s)
    raan_rate, argp_rate, m_rate = j2_secular_rates(a, e, inc, body)
    raan = elements.longitude_of_ascending_node.to_value(u.rad) + raan_rate.value * dt_s
    argp = elements.argument_of_periapsis.to_value(u.rad) + argp_rate.value * dt_s
    M = elements.mean_anomaly.to_value(u.rad) + m_rate.value * dt_s
    M = np.mod(M + np.pi, 2 * np.pi) - np.pi
    nu = mean_to_true(M, np.broadcast_to(e, np.shape(M)))
    nu = nu.to_value(u.rad) if hasattr(nu, "unit") else np.asarray(nu)
    shape = np.shape(M)
    drifted = KeplerianElements.from_semi_major_axis(
        np.broadcast_to(a.to_value(u.km), shape) * u.km,
        np.broadcast_to(e, shape),
        np.broadcast_to(inc.to_value(u.rad), shape),
        np.mod(raan, 2 * np.pi),
        np.mod(argp, 2 * np.pi),
        nu,
        elements.gm,
        epoch=None if elements.epoch is None else advance_epoch(elements.epoch, dt_s),
    )
    if to_equator is not None:  # back to the GCRS
        drifted = _rotated_elements(drifted, np.swapaxes(to_equator, -1, -2))
    return drifted if frame is None else with_frame(drifted, frame)


def _equator_rotation(elements, body):
    """Matrices (..., 3, 3) from GCRS to the Earth's equator and pole of the elements' epoch, or
    None where the elements' angles are already about that pole (TEME, a true-of-date frame
    such as an OPM's TOD), about another body, or without an epoch.

    The pole is the celestial intermediate pole (IAU 2006/2000A, ERFA ``xys06a``/``c2ixys``),
    0.134 deg from the GCRS z axis in 2024: secular rates about the GCRS z axis put a LEO
    orbit 2.2 km off after a day. It is held at the epoch (it moves by 0.05" a day).
    """
    from .satellite_states import frame_of

    if body.name != "earth" or elements.epoch is None:
        return None
    if frame_of(elements) not in (None, "gcrs"):
        return None
    if abs(float(np.max(elements.gm.to_value(u.km**3 / u.s**2))) / body.gm_km3_s2 - 1) > 1e-6:
        return None  # elements about another body
    import erfa

    from .frames import offline_iers

    with offline_iers():  # a UT1 epoch needs the installed IERS table, never a download
        tt = elements.epoch.tt
    x, y, s = erfa.xys06a(tt.jd1, tt.jd2)
    return erfa.c2ixys(x, y, s)


def _rotated_elements(elements, matrices):
    """The Keplerian elements of the states of ``elements`` turned by ``matrices``."""
    from ..states import StateVectors

    st = elements.to_state()
    r = np.einsum("...ij,...j->...i", matrices, st.r.to_value(u.km))
    v = np.einsum("...ij,...j->...i", matrices, st.v.to_value(u.km / u.s))
    return StateVectors(r * u.km, v * u.km / u.s, elements.gm, epoch=elements.epoch).to_elements()


def sun_synchronous_inclination(a, ecc=0.0, body=EARTH):
    """Inclination that makes the node precess at the Sun's mean rate (360 deg / year).

    cos i = -2 Omega_dot_sun a^(7/2) (1 - e^2)^2 / (3 J2 R^2 sqrt(mu)) (Vallado 2013,
    eq. 11-11). Raises DomainError when |cos i| > 1 (a above ~12 350 km for the Earth).
    """
    a_km = to_array(a, "length", "a")
    e = to_array(ecc, "dimensionless", "ecc")
    if np.any(a_km <= 0):
        raise InvalidInputError("a must be > 0.")
    _check_ecc(e)
    broadcast_or_raise("sun_synchronous_inclination", a=a_km, ecc=e)
    gm, R, j2 = _body_consts(body)
    _check_above_surface(a_km * (1 - e), body, R, f"give a with a (1 - e) >= {R} km")
    rate = SUN_SYNCHRONOUS_RATE.to_value(u.rad / u.s)
    cos_i = -2 * rate * a_km**3.5 * (1 - e**2) ** 2 / (3 * j2 * R**2 * np.sqrt(gm))
    if np.any(np.abs(cos_i) > 1):
        raise DomainError(
            "no sun-synchronous inclination exists for this a and e (|cos i| > 1): the orbit is "
            "too high for J2 to turn the node fast enough; choose a lower orbit."
        )
    return to_quantity(np.arccos(cos_i), "angle")


def sun_synchronous_semi_major_axis(inc, ecc=0.0, body=EARTH):
    """Semi-major axis at which an orbit of inclination ``inc`` (> 90 deg) is sun-synchronous.

    Parameters
    ----------
    inc : Quantity or float
        Inclination, 90 deg < inc <= 180 deg (rad for plain floats).
    ecc : float or array_like
        Eccentricity, 0 <= e < 1; broadcasts against ``inc``.
    body : Body
        Central body with J2 (default Earth).

    Returns
    -------
    Quantity, km
        a from Vallado (2013), eq. 11-11 solved for a. Raises DomainError when the periapsis
        a (1 - e) would lie below the surface (inc just above 90 deg).
    """
    i = to_array(inc, "angle", "inc")
    e = to_array(ecc, "dimensionless", "ecc")
    _check_ecc(e)
    _check_inc(i)
    if np.any(np.cos(i) >= 0):
        raise DomainError("sun-synchronous orbits are retrograde: give inc > 90 deg.")
    broadcast_or_raise("sun_synchronous_semi_major_axis", inc=i, ecc=e)
    gm, R, j2 = _body_consts(body)
    rate = SUN_SYNCHRONOUS_RATE.to_value(u.rad / u.s)
    a = (-3 * j2 * R**2 * np.sqrt(gm) * np.cos(i) / (2 * rate * (1 - e**2) ** 2)) ** (2 / 7)
    _check_above_surface(
        a * (1 - e), body, R, "the sun-synchronous orbit at this inclination and eccentricity"
    )
    return to_quantity(a, "length")


def frozen_eccentricity(a, inc, body=EARTH):
    """Eccentricity of the frozen orbit (argument of periapsis 90 deg) under J2 and J3.

    e_f = -(J3 / (2 J2)) (R / a) sin i, with argp = 90 deg: the J3 long-period drift of e and
    argp vanishes to first order (Vallado 2013, sec. 11.4.3; Cook 1966). About 0.001 for
    the Earth in LEO.

    Parameters
    ----------
    a : Quantity, length
        Mean semi-major axis (at or above the body's surface).
    inc : Quantity or float
        Inclination in [0, 180 deg] (rad for plain floats); broadcasts against ``a``.
    body : Body
        Central body with J2 and J3 (default Earth).

    Returns
    -------
    float or ndarray
        The frozen eccentricity (dimensionless).
    """
    a_km = to_array(a, "length", "a")
    i = to_array(inc, "angle", "inc")
    if np.any(a_km <= 0):
        raise InvalidInputError("a must be > 0.")
    _check_inc(i)
    broadcast_or_raise("frozen_eccentricity", a=a_km, inc=i)
    try:
        j2 = body.jn(2)
        j3 = body.jn(3)
    except AttributeError as exc:
        raise InvalidInputError(
            f"frozen_eccentricity needs J2 and J3 of {getattr(body, 'name', body)!r}: {exc}."
        ) from exc
    _check_above_surface(a_km, body, body.radius_km, "frozen_eccentricity")
    return -(j3 / (2 * j2)) * (body.radius_km / a_km) * np.sin(i)


def repeat_ground_track_semi_major_axis(revolutions, days, inc, ecc=0.0, body=EARTH):
    """Mean semi-major axis of an orbit whose ground track repeats after ``revolutions`` nodal
    revolutions in ``days`` turns of the body relative to the orbit's node (J2 secular theory).

    The track repeats when R nodal periods equal D turns of the body under the node:
    D (dM/dt + domega/dt) = R (omega_body - dOmega/dt), with the rates of
    :func:`j2_secular_rates` (Vallado 2013, ch. 11, repeat-groundtrack orbits). Solved by
    bisection in a (the left side falls with a faster than the right).

    Parameters
    ----------
    revolutions, days : int or array_like of int
        R >= 1 revolutions in D >= 1 days (e.g. Landsat 8: 233 in 16, Sentinel-2: 143 in
        10); broadcast together and against ``inc`` and ``ecc``. R and D without a common factor
        give a cycle of exactly D days.
    inc : Quantity or float
        Mean inclination in [0, 180 deg] (rad for plain floats).
    ecc : float or array_like
        Mean eccentricity, 0 <= e < 1.
    body : Body
        Central body with J2 and a rotation rate (default Earth, 7.292115e-5 rad/s).

    Returns
    -------
    Quantity, km
        The mean semi-major axis.

    Raises
    ------
    DomainError
        No such orbit above the surface (too many revolutions per day: 16 a day is near the
        Earth's limit), or non-integer or non-positive R, D.

    Notes
    -----
    Landsat 8 (233 / 16, 98.2 deg): a = 7077.7 km, 699.6 km above the equatorial radius
    (published: "705 km", nominal), nodal period 98.88 min (published: 98.9 min; USGS, Landsat 8
    Data Users Handbook). Sentinel-2 (143 / 10, 98.62 deg): 786.2 km (published: 786 km).
    """
    rev = np.asarray(revolutions)
    day = np.asarray(days)
    for arr, name in ((rev, "revolutions"), (day, "days")):
        if arr.dtype.kind not in "iu" or np.any(arr < 1):
            raise DomainError(f"{name} must be integers >= 1; got {arr!r}.")
    i = to_array(inc, "angle", "inc")
    e = to_array(ecc, "dimensionless", "ecc")
    _check_ecc(e)
    _check_inc(i)
    shape = broadcast_or_raise("repeat_ground_track_semi_major_axis", revolutions=rev, days=day,
                               inc=i, ecc=e)
    gm, R, _ = _body_consts(body)
    spin = body.rotation_rate
    if spin is None:
        raise InvalidInputError(f"{body.name} has no rotation rate; a ground track needs one.")
    w = float(spin.to_value(u.rad / u.s))
    rev, day, i, e = (np.broadcast_to(x, shape).astype(np.float64) for x in (rev, day, i, e))

    def excess(a):  # D (Mdot + wdot) - R (w - Omegadot): > 0 below the root
        raan_rate, argp_rate, m_rate = (x.value for x in j2_secular_rates(a * u.km, e, i, body))
        return day * (m_rate + argp_rate) - rev * (w - raan_rate)

    lo = R / (1 - e)  # the periapsis at the surface
    if np.any(excess(lo) <= 0):
        k = np.argwhere(np.broadcast_to(excess(lo) <= 0, shape))[0] if shape else ()
        raise DomainError(
            f"no orbit above the surface of {body.name} repeats its ground track after "
            f"{rev[tuple(k)]:g} revolutions in {day[tuple(k)]:g} days: that is more revolutions "
            "per day than an orbit grazing the surface makes. Give fewer revolutions or more "
            "days.")
    hi = np.broadcast_to((gm / (rev * w / day) ** 2) ** (1 / 3) * 2.0, shape).copy()
    lo = np.broadcast_to(lo, shape).copy()
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        below = excess(mid) > 0
        lo = np.where(below, mid, lo)
        hi = np.where(below, hi, mid)
        if np.all(hi - lo <= 1e-12 * hi):
            break
    return to_quantity(0.5 * (lo + hi), "length")
