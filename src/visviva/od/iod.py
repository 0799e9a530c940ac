"""Initial orbit determination from positions: Gibbs and Herrick-Gibbs (angles only:
:mod:`visviva.od.angles`; a first orbit from a table of observations:
:mod:`visviva.od.first_orbit`).

>>> import visviva as vv
>>> from astropy import units as u
>>> r1 = [-294.32, 4265.1, 5986.7] * u.km    # Curtis (2020), Example 5.1
>>> r2 = [-1365.5, 3637.6, 6346.8] * u.km
>>> r3 = [-2940.3, 2473.7, 6555.8] * u.km
>>> v2 = vv.gibbs(r1, r2, r3, 398600 * u.km**3 / u.s**2)
>>> print(v2.round(4))
[-6.2174 -4.0122  1.599 ] km / s
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from .._units import is_quantity, to_array, to_quantity, to_vector
from ..errors import DomainError, InvalidInputError, ShapeError

__all__ = ["gibbs", "herrick_gibbs", "gm_value"]

#: largest angle between r1 and the plane of r2, r3 that Gibbs accepts by default, rad
COPLANAR_TOL_RAD = math.radians(1.0)
#: smallest angle between successive positions below which Gibbs warns, rad: its velocity is a
#: difference of nearly equal vectors, and a position error dr moves it by about
#: |v| dr / (|r| theta^2) (1 m of noise at 7000 km: 2.2 m/s at 1 deg, 210 m/s at 0.1 deg,
#: 6.7 km/s at 0.01 deg; audit59), where Herrick-Gibbs is exact to 2e-5 m/s
GIBBS_MIN_ARC_RAD = math.radians(1.0)
#: largest angle between successive positions that Herrick-Gibbs accepts by default, rad
#: (its series is ~2e-5 of the speed off at 10 deg, 3e-3 at 36 deg)
HERRICK_GIBBS_MAX_ARC_RAD = math.radians(10.0)
#: farthest position from the Earth that Gibbs and Herrick-Gibbs take about the Earth's GM, km:
#: two thirds of the Earth's Hill radius, where the Sun's tide is no longer a perturbation
#: (audit44: Curtis's Example 5.1 in metres, read as km, gave an "orbit" 7.4 million km out)
EARTH_ORBIT_MAX_KM = 1.0e6


def gm_value(gm):
    """One gravitational parameter > 0 as a float in km^3/s^2 (refuses anything else)."""
    g = to_array(gm, "gm", "gm", allow_plain=True)
    if g.ndim != 0 or not g > 0:
        raise InvalidInputError(f"gm must be one number > 0 (e.g. vv.EARTH.gm); got {gm!r}.")
    return float(g)


def _positions(r1, r2, r3, gm):
    arrs = [to_vector(r, "length", f"r{k}", allow_plain=True) for k, r in enumerate((r1, r2, r3), 1)]
    try:
        shape = np.broadcast_shapes(*(a.shape for a in arrs))
    except ValueError as exc:
        raise ShapeError(f"r1, r2, r3 do not broadcast: {[a.shape for a in arrs]}.") from exc
    arrs = [np.broadcast_to(a, shape) for a in arrs]
    from ..constants import GM_EARTH_KM3_S2

    for k, a in enumerate(arrs, 1):
        norm = np.linalg.norm(a, axis=-1)
        if np.any(norm == 0):
            raise InvalidInputError(f"r{k} has zero length; give positions from the attractor.")
        if abs(gm / GM_EARTH_KM3_S2 - 1.0) < 1e-3 and np.any(norm > EARTH_ORBIT_MAX_KM):
            raise DomainError(
                f"r{k} is {float(np.max(norm)):.4g} km from the Earth, beyond any Earth orbit "
                f"({EARTH_ORBIT_MAX_KM:.0e} km, two thirds of its Hill radius). Plain numbers are "
                "km: positions in metres must be Quantities, e.g. r1=[...] * u.m.")
    return arrs, any(is_quantity(r) for r in (r1, r2, r3))


def _out(v_km_s, quantity):
    return to_quantity(v_km_s, "speed") if quantity else v_km_s


def _unit(a):
    return a / np.linalg.norm(a, axis=-1, keepdims=True)


def gibbs(r1, r2, r3, gm, *, coplanar_tol=COPLANAR_TOL_RAD):
    """Velocity at the middle of three position vectors on one two-body orbit (Gibbs).

    Parameters
    ----------
    r1, r2, r3 : Quantity (length) or array_like (km), shape (..., 3)
        Successive positions on one orbit, relative to the attractor, in time order.
    gm : Quantity (km^3/s^2), Body or float (km^3/s^2)
        Gravitational parameter of the attractor.
    coplanar_tol : Quantity (angle) or float (rad)
        Largest angle between r1 and the plane of r2 and r3 (default 1 deg).

    Returns
    -------
    v2 : Quantity (km/s) or ndarray (km/s), shape (..., 3)
        Velocity at ``r2`` (a Quantity when the positions are Quantities).

    Warns
    -----
    RuntimeWarning
        Successive positions less than ``GIBBS_MIN_ARC_RAD`` (1 deg) apart: the velocity is a
        difference of nearly equal vectors, and a position error dr moves it by about
        ``|v| dr / (|r| theta^2)`` (1 m at 7000 km: 2.2 m/s at 1 deg, 210 m/s at 0.1 deg, 6.7
        km/s at 0.01 deg); :func:`herrick_gibbs` is the method for such arcs.

    Raises
    ------
    DomainError
        The vectors are not coplanar within ``coplanar_tol``, or two are parallel; about the
        Earth's GM, a position beyond ``EARTH_ORBIT_MAX_KM`` (1e6 km: metres read as km).

    Notes
    -----
    With N = r1 (r2 x r3) + r2 (r3 x r1) + r3 (r1 x r2), D = r1 x r2 + r2 x r3 + r3 x r1 and
    S = r1 (r2 - r3) + r2 (r3 - r1) + r3 (r1 - r2) (magnitudes in the scalar factors),

        v2 = sqrt(GM / (N D)) (D x r2 / r2 + S)

    (Vallado 2013, Algorithm 54 and Example 7-3; Curtis 2020, Algorithm 5.1, Example 5.1).
    Exact for noise-free positions; best when the vectors are more than a few degrees apart
    (use :func:`herrick_gibbs` for short arcs).
    """
    g = gm_value(gm)
    coplanar_tol = _angle_limit(coplanar_tol, "coplanar_tol")
    (a, b, c), quantity = _positions(r1, r2, r3, g)
    v2 = _gibbs_core(a, b, c, g, coplanar_tol)
    _warn_short_arc(a, b, c, g)
    return _out(v2, quantity)


def _warn_short_arc(a, b, c, g):
    """Warn where successive positions are less than ``GIBBS_MIN_ARC_RAD`` apart."""
    arc = np.minimum(_angle_between(a, b), _angle_between(b, c))
    if not np.any(arc < GIBBS_MIN_ARC_RAD):
        return
    k = int(np.argmin(np.ravel(arc)))
    theta = float(np.ravel(arc)[k])
    r = float(np.ravel(np.linalg.norm(b, axis=-1))[k])
    v = math.sqrt(g / r)  # the speed's scale (v2 itself is what the noise may have spoiled)
    gain = v / (r * theta**2) if theta > 0 else math.inf  # km/s of velocity per km of position
    warnings.warn(
        f"Gibbs on positions only {math.degrees(theta):.3g} deg apart: its velocity is the "
        f"difference of nearly equal vectors, and an error in the positions moves it by about "
        f"{gain:.3g} m/s per metre (1 m of noise at 7000 km gives 2.2 m/s at 1 deg, 210 m/s "
        "at 0.1 deg). Use vv.herrick_gibbs with the "
        f"times for arcs under {math.degrees(GIBBS_MIN_ARC_RAD):g} deg (exact positions are "
        "fine: the warning is about their errors).",
        RuntimeWarning, stacklevel=3)  # fmt: skip


def gibbs_velocity(r1, r2, r3, gm_km3_s2, coplanar_tol):
    """Gibbs's v2 (ndarray, km/s) without the short-arc warning, for callers that judge their
    own arcs (double-r's trial orbits); the same checks and refusals as :func:`gibbs`."""
    (a, b, c), _ = _positions(r1, r2, r3, gm_km3_s2)
    return _gibbs_core(a, b, c, gm_km3_s2, coplanar_tol)


def _gibbs_core(a, b, c, g, coplanar_tol):
    """Gibbs's v2 (km/s) for checked positions (..., 3) in km and GM in km^3/s^2."""
    ra, rb, rc = (np.linalg.norm(x, axis=-1, keepdims=True) for x in (a, b, c))
    c12, c23, c31 = np.cross(a, b), np.cross(b, c), np.cross(c, a)
    _check_coplanar(a, c23, ra, coplanar_tol)
    for (i, j), x, y, cr in (((1, 2), a, b, c12), ((2, 3), b, c, c23), ((1, 3), a, c, c31)):
        same = (np.linalg.norm(cr, axis=-1) <= 1e-12 * np.linalg.norm(x, axis=-1)
                * np.linalg.norm(y, axis=-1)) & (np.sum(x * y, axis=-1) > 0)  # fmt: skip
        if np.any(same):
            raise DomainError(
                f"r{i} and r{j} point the same way from the attractor: no conic passes twice "
                "along one direction (and equal positions leave the orbit undetermined). Use "
                "positions some degrees apart."
            )
    N = ra * c23 + rb * c31 + rc * c12
    D = c12 + c23 + c31
    S = a * (rb - rc) + b * (rc - ra) + c * (ra - rb)
    nN = np.linalg.norm(N, axis=-1, keepdims=True)
    nD = np.linalg.norm(D, axis=-1, keepdims=True)
    if np.any(nN * nD == 0):
        raise DomainError("Gibbs: N or D vanishes (collinear positions); use other points.")
    if np.any(np.sum(N * D, axis=-1) <= 0):
        raise DomainError(
            "there is no two-body orbit through these three positions: the only conic with its "
            "focus at the attractor through them is the branch of a hyperbola that bends away "
            "from the attractor (N . D < 0). Check the data (order, frame, units)."
        )
    v2 = np.sqrt(g / (nN * nD)) * (np.cross(D, b) / rb + S)
    _check_hyperbolic_order(a, b, c, v2, g)
    return v2


def _angle_limit(value, name):
    """An angle limit (Quantity or float in rad) as one float > 0 in rad."""
    x = to_array(value, "angle", name, allow_plain=True)
    if x.ndim != 0 or not x > 0:
        raise InvalidInputError(f"{name} must be one angle > 0 (rad, or a Quantity); got {value!r}.")
    return float(x)


def _check_coplanar(r1, n23, r1_norm, tol):
    """Refuse r1 more than ``tol`` rad off the plane whose normal is ``n23`` = r2 x r3."""
    nn = np.linalg.norm(n23, axis=-1)
    if np.any(nn == 0):
        raise DomainError("r2 and r3 are parallel: their plane is undefined. Use other points.")
    tilt = np.arcsin(np.clip(np.abs(np.sum(r1 * n23, axis=-1)) / (r1_norm[..., 0] * nn), 0, 1))
    if np.any(tilt > tol):
        raise DomainError(
            f"the three positions are not coplanar: r1 lies {np.degrees(np.max(tilt)):.3f} deg "
            f"off the plane of r2 and r3 (tolerance {np.degrees(tol):.3f} deg). They "
            "cannot be on one two-body orbit; check the data or raise coplanar_tol."
        )


def _check_hyperbolic_order(r1, r2, r3, v2, gm):
    """On an open conic the true anomalies must increase r1 -> r2 -> r3 (no second pass)."""
    h = np.cross(r2, v2)
    e = np.cross(v2, h) / gm - r2 / np.linalg.norm(r2, axis=-1, keepdims=True)
    ecc = np.linalg.norm(e, axis=-1, keepdims=True)
    open_ = ecc[..., 0] >= 1.0
    if not np.any(open_):
        return
    p_hat = e / ecc
    q_hat = np.cross(h / np.linalg.norm(h, axis=-1, keepdims=True), p_hat)
    nu = [np.arctan2(np.sum(r * q_hat, axis=-1), np.sum(r * p_hat, axis=-1)) for r in (r1, r2, r3)]
    if np.any(open_ & ~((nu[0] < nu[1]) & (nu[1] < nu[2]))):
        raise DomainError(
            "there is no two-body orbit through these positions in this order: the conic "
            "through them is a hyperbola (escape orbit), which passes each point once, and not "
            "in the order r1, r2, r3. Check the order of the positions."
        )


def _offsets(t1, t2, t3):
    """Times as seconds: astropy Times (differences in TT) or time Quantities / plain seconds."""
    from astropy.time import Time

    ts = (t1, t2, t3)
    if all(isinstance(t, Time) for t in ts):
        if any(t.shape != () for t in ts):
            raise ShapeError(
                f"t1, t2, t3 must be scalars (one time per position); got Time shapes "
                f"{[t.shape for t in ts]}."
            )
        from ..satellites.frames import offline_iers

        with offline_iers():  # times in UT1 need the installed IERS table, never a download
            return [float((t.tt - t1.tt).sec) for t in ts]
    if any(isinstance(t, Time) for t in ts):
        raise InvalidInputError("give t1, t2, t3 all as astropy Times or all as time offsets.")
    out = [to_array(t, "time", f"t{k}", allow_plain=True) for k, t in enumerate(ts, 1)]
    if any(o.ndim for o in out):
        raise ShapeError("t1, t2, t3 must be scalars (one time per position).")
    return [float(o) for o in out]


def herrick_gibbs(r1, r2, r3, t1, t2, t3, gm, *, coplanar_tol=COPLANAR_TOL_RAD,
                  max_arc=HERRICK_GIBBS_MAX_ARC_RAD):  # fmt: skip
    """Velocity at the middle of three closely spaced positions (Herrick-Gibbs).

    Parameters
    ----------
    r1, r2, r3 : Quantity (length) or array_like (km), shape (3,) or (..., 3)
        Positions relative to the attractor at the three times.
    t1, t2, t3 : astropy Time, Quantity (time) or float (s)
        Times of the positions, strictly increasing.
    gm : Quantity (km^3/s^2), Body or float (km^3/s^2)
        Gravitational parameter.
    coplanar_tol : Quantity (angle) or float (rad)
        Largest angle between r1 and the plane of r2 and r3 (default 1 deg).
    max_arc : Quantity (angle) or float (rad)
        Largest angle between r1 and r2 or between r2 and r3 (default 10 deg, where the
        series is about 2e-5 of the speed off; use :func:`gibbs` for longer arcs).

    Returns
    -------
    v2 : Quantity (km/s) or ndarray (km/s)
        Velocity at ``r2``.

    Raises
    ------
    InvalidInputError
        Times not strictly increasing.
    DomainError
        The positions are not coplanar within ``coplanar_tol``, an arc is longer than
        ``max_arc``, or the times do not fit the positions: the acceleration their second
        difference implies is more than 100 times larger or smaller than the attractor's
        gravity at r2 (times in another unit, e.g. minutes passed as plain seconds); about
        the Earth's GM, a position beyond ``EARTH_ORBIT_MAX_KM`` (1e6 km).

    Notes
    -----
    A Taylor series of r(t) about t2 to fifth order with r'' = -GM r / r^3 (Herrick 1971;
    Vallado 2013, Algorithm 55, eq. 7-31, Example 7-4):

        v2 = -dt32 (1/(dt21 dt31) + GM/(12 r1^3)) r1
             + (dt32 - dt21) (1/(dt21 dt32) + GM/(12 r2^3)) r2
             + dt21 (1/(dt32 dt31) + GM/(12 r3^3)) r3.

    Accurate for arcs of a few degrees (where Gibbs loses precision); error grows like dt^4.
    """
    g = gm_value(gm)
    coplanar_tol = _angle_limit(coplanar_tol, "coplanar_tol")
    max_arc = _angle_limit(max_arc, "max_arc")
    (a, b, c), quantity = _positions(r1, r2, r3, g)
    s1, s2, s3 = _offsets(t1, t2, t3)
    d21, d31, d32 = s2 - s1, s3 - s1, s3 - s2
    if not (d21 > 0 and d32 > 0):
        raise InvalidInputError(
            f"the times must increase strictly (t1 < t2 < t3); got offsets {s1}, {s2}, {s3} s."
        )
    ra, rb, rc = (np.linalg.norm(x, axis=-1, keepdims=True) for x in (a, b, c))
    _check_coplanar(a, np.cross(b, c), ra, coplanar_tol)
    arc = np.maximum(_angle_between(a, b), _angle_between(b, c))
    if np.any(arc > max_arc):
        raise DomainError(
            f"the positions are {np.degrees(np.max(arc)):.2f} deg apart, beyond the "
            f"{np.degrees(max_arc):.2f} deg where Herrick-Gibbs's series holds (its error grows "
            "like the fourth power of the arc): use vv.gibbs for arcs this long, or raise "
            "max_arc."
        )
    _check_time_scale(a, b, c, d21, d32, rb, g)
    v2 = (
        -d32 * (1.0 / (d21 * d31) + g / (12.0 * ra**3)) * a
        + (d32 - d21) * (1.0 / (d21 * d32) + g / (12.0 * rb**3)) * b
        + d21 * (1.0 / (d32 * d31) + g / (12.0 * rc**3)) * c
    )
    return _out(v2, quantity)


#: largest factor between the acceleration the positions' second difference implies and the
#: attractor's gravity at r2 that Herrick-Gibbs accepts (noise-free arcs: 1 to a few %)
TIME_SCALE_FACTOR = 100.0


def _check_time_scale(r1, r2, r3, d21, d32, r2_norm, gm):
    """Refuse times that do not fit the positions: their bend is gravity's, a k^-2 off when the
    times are k times too long (minutes read as seconds: k = 1/60, a velocity 60 times too big)."""
    bend = 2.0 * ((r3 - r2) / d32 - (r2 - r1) / d21) / (d21 + d32)
    ratio = np.linalg.norm(bend, axis=-1) / (gm / r2_norm[..., 0] ** 2)
    bad = ~((ratio >= 1.0 / TIME_SCALE_FACTOR) & (ratio <= TIME_SCALE_FACTOR))
    if np.any(bad):
        k = float(np.ravel(ratio)[np.flatnonzero(np.ravel(bad))[0]])
        raise DomainError(
            f"the times do not fit the positions: over these intervals the three positions bend "
            f"as an acceleration {k:.3g} times the attractor's gravity at r2 (a two-body arc "
            "bends with gravity itself). The times are probably in another unit than the data's "
            "(plain numbers are seconds: a time k times too short makes the velocity k times "
            "too large), or the positions are in another unit than gm's (plain numbers are km), "
            "or belong to other times. Pass times as astropy Times or time Quantities."
        )


def _angle_between(a, b):
    """Angles (rad) between the vectors of two (..., 3) arrays."""
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1))
