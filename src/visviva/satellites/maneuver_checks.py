"""Checks the impulsive-manoeuvre planners share: an inclination change typed without its
unit, and circle radii inside the attractor (an altitude given for a radius).

Used by :mod:`visviva.satellites.maneuvers` and :mod:`visviva.satellites.combined_maneuvers`.
"""

from __future__ import annotations

import numpy as np
from astropy import units as u

from .._units import to_array
from ..errors import InvalidInputError

__all__ = ["inclination_change", "known_body", "refuse_below_surface", "arc_min_radius"]


def inclination_change(delta_inc, name="delta_inc", limit=np.pi):
    """``delta_inc`` in rad; a plain number beyond ``limit`` (60 for 60 deg) is refused.

    No change of inclination exceeds pi, so a plain number above it is degrees typed without
    their unit: taken in radians it gave another Δv without a word (60 -> 14.8 km/s at 7.5 km/s
    instead of 7.5 km/s). Quantities of any size are taken as given. (A phase angle: 2 pi.)
    """
    di = to_array(delta_inc, "angle", name)
    if not isinstance(delta_inc, u.Quantity) and np.any(np.abs(di) > limit):
        big = float(di[np.abs(di) > limit].ravel()[0])
        what = "pi, which no plane change exceeds" if limit == np.pi else f"{limit:.6g} rad"
        raise InvalidInputError(
            f"{name} = {big:g} is a plain number, so it would be taken in radians: more than "
            f"{what}. Pass {name}={big:g} * u.deg if you meant degrees (or a Quantity in rad)."
        )
    return di


def known_body(gm, mu):
    """The attractor when ``gm`` is a Body or, to 0.1 %, a known body's GM (a one-value
    ``mu``, km^3/s^2); else None."""
    from ..bodies import BODIES, Body

    if isinstance(gm, Body):
        return gm
    if np.ndim(mu) != 0:
        return None
    return next((b for b in BODIES.values() if abs(float(mu) / b.gm_km3_s2 - 1.0) <= 1e-3), None)


def refuse_below_surface(gm, mu, **radii_km):
    """Refuse circle radii inside the attractor (an altitude given for a radius, 500 km for
    6878 km), when it is a known body (:func:`_known_body`)."""
    body = known_body(gm, mu)
    if body is None:
        return
    for name, r in radii_km.items():
        if np.any(r < body.radius_km):
            low = float(np.min(r))
            raise InvalidInputError(
                f"{name} = {low:.6g} km is inside {body.name} (radius {body.radius_km:.6g} km): "
                "the radii of a transfer are from the body's centre, not altitudes. For an "
                f"altitude of {low:.6g} km give {body.radius_km + low:.6g} km "
                f"({body.name}'s radius + altitude)."
            )


def arc_min_radius(r1, v1, r2, v2, mu, revolutions) -> float:
    """The least distance from the centre (km) along the conic arc from (r1, v1) to r2.

    The arc passes the periapsis (radius p / (1 + e)) when it has whole revolutions or when the
    true anomaly at r1 plus the transfer angle, in the direction of motion, reaches 2 pi;
    otherwise its nearest point is an end. r km, v km/s, mu km^3/s^2 (plain arrays (3,)).
    """
    h = np.cross(r1, v1)
    hn = float(np.linalg.norm(h))
    n1, n2 = float(np.linalg.norm(r1)), float(np.linalg.norm(r2))
    e_vec = np.cross(v1, h) / mu - r1 / n1
    e = float(np.linalg.norm(e_vec))
    rp = hn * hn / mu / (1.0 + e)
    if revolutions >= 1:
        return min(rp, n1, n2)
    k = h / hn
    two_pi = 2.0 * np.pi
    nu1 = np.arctan2(np.dot(np.cross(e_vec, r1), k), np.dot(e_vec, r1)) % two_pi
    dnu = np.arctan2(np.dot(np.cross(r1, r2), k), np.dot(r1, r2)) % two_pi
    return min(rp, n1, n2) if nu1 + dnu >= two_pi else min(n1, n2)
