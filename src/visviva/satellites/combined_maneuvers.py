"""A Hohmann transfer combined with a change of inclination, split between its two burns.

Turning the plane at the slow far apsis is cheap, and a little of it at the first burn is
cheaper still: the burns add vectors, and a small rotation of a large Δv costs almost nothing.
:func:`hohmann_plane_change_delta_v` finds the split of Δi that minimises |Δv1| + |Δv2|;
:meth:`visviva.satellites.Maneuver.hohmann` flies it (``delta_inc=``).

>>> import visviva as vv
>>> from astropy import units as u
>>> from visviva.satellites import hohmann_plane_change_delta_v
>>> dv1, dv2, di1, di2, tof = hohmann_plane_change_delta_v(6678 * u.km, 42164 * u.km,
...                                                        28.5 * u.deg, vv.EARTH)
>>> print(f"{(dv1 + dv2).to_value(u.km / u.s):.4f} km/s, {di1.to_value(u.deg):.3f} deg first")
4.2314 km/s, 2.200 deg first
"""

from __future__ import annotations

import numpy as np
from astropy import units as u

from .._units import broadcast_or_raise, to_array, to_quantity
from ..errors import InvalidInputError
from .maneuver_checks import inclination_change, refuse_below_surface

__all__ = ["hohmann_plane_change_delta_v"]

#: Points of the search grid over the split (refined by bisection around the best one)
_GRID = 129


def _burn(va, vb, angle):
    """|va - vb| for speeds va, vb whose directions differ by ``angle`` (rad), without the
    cancellation of the law of cosines: (va - vb)^2 + 4 va vb sin^2(angle/2)."""
    s = np.sin(0.5 * angle)
    return np.sqrt((va - vb) ** 2 + 4.0 * va * vb * s * s)


def _slope(alpha, total, v1, vt1, vt2, v2):
    """d(|Δv1| + |Δv2|)/d(alpha) with alpha turned at the first burn, total - alpha at the
    second."""
    d1 = _burn(v1, vt1, alpha)
    d2 = _burn(vt2, v2, total - alpha)
    with np.errstate(invalid="ignore", divide="ignore"):
        return v1 * vt1 * np.sin(alpha) / d1 - vt2 * v2 * np.sin(total - alpha) / d2


def hohmann_plane_change_delta_v(r1, r2, delta_inc, gm):
    """The cheapest split of an inclination change between the two burns of a Hohmann transfer.

    The first burn (at r1, on the line of nodes) turns the plane by Δi1 while raising the far
    apsis to r2; the second (at r2, on the same line) turns it by the rest, Δi2 = Δi - Δi1,
    while circularising. Each burn is the vector difference of the speeds before and after:
    |Δv1|^2 = v1^2 + vt1^2 - 2 v1 vt1 cos Δi1, |Δv2|^2 = vt2^2 + v2^2 - 2 vt2 v2 cos Δi2, with
    v1, v2 the circular speeds and vt1, vt2 the transfer ellipse's at r1 and r2. Δi1 minimises
    |Δv1| + |Δv2| (a grid over [0, Δi], then bisection of the derivative around the best
    point; the ends, the whole turn at one burn, included): Vallado (2013), Fundamentals of
    Astrodynamics and Applications, 4th ed., ch. 6, "minimum combined plane change";
    Curtis (2014), ch. 6 (plane change maneuvers).

    Parameters
    ----------
    r1, r2 : Quantity, length
        Radii of the initial and final circular orbits (> 0; from the centre, not altitudes).
    delta_inc : Quantity or float
        Change of inclination Δi (angle; rad for plain floats, |Δi| <= pi). Its sign is
        carried by ``di1`` and ``di2`` (negative lowers the inclination).
    gm : Quantity (km^3/s^2) or Body
        Gravitational parameter of the attractor (> 0).

    Returns
    -------
    dv1, dv2 : Quantity, km/s
        Magnitudes of the two burns (>= 0).
    di1, di2 : Quantity, deg
        The turn of the plane at each burn (di1 + di2 = delta_inc, same sign).
    tof : Quantity, s
        Time between the burns (half the transfer ellipse's period).

    Raises
    ------
    InvalidInputError
        Non-positive radii or gm, radii inside a known attractor, |Δi| > pi (a plain number
        above pi is degrees without their unit).

    Notes
    -----
    LEO (6678 km) to GEO (42164 km) with 28.5 deg about the Earth: Δi1 = 2.200 deg, 4.2314 km/s
    in all, against 4.2560 km/s with the whole turn at the apogee burn (the classic result:
    about 2 deg at the first burn saves ~25 m/s) and 6.4561 km/s with all of it at the first.
    """
    a = to_array(r1, "length", "r1")
    b = to_array(r2, "length", "r2")
    mu = to_array(gm, "gm", "gm")
    di = inclination_change(delta_inc)
    if np.any(a <= 0) or np.any(b <= 0) or np.any(mu <= 0):
        raise InvalidInputError("r1, r2 and gm must be > 0.")
    if np.any(np.abs(di) > np.pi):
        raise InvalidInputError(
            f"|delta_inc| must be <= 180 deg; got {np.rad2deg(np.max(np.abs(di))):.6g} deg.")
    shape = broadcast_or_raise("hohmann_plane_change_delta_v", r1=a, r2=b, delta_inc=di, gm=mu)
    refuse_below_surface(gm, mu, r1=a, r2=b)
    a, b, di, mu = (np.broadcast_to(x, shape).astype(np.float64) for x in (a, b, di, mu))
    total = np.abs(di)
    v1 = np.sqrt(mu / a)
    v2 = np.sqrt(mu / b)
    vt1 = v1 * np.sqrt(2.0 * b / (a + b))
    vt2 = v2 * np.sqrt(2.0 * a / (a + b))
    frac = np.linspace(0.0, 1.0, _GRID)
    alphas = total[..., None] * frac  # (..., G)
    cost = (_burn(v1[..., None], vt1[..., None], alphas)
            + _burn(vt2[..., None], v2[..., None], total[..., None] - alphas))
    k = np.argmin(cost, axis=-1)
    best = np.take_along_axis(alphas, k[..., None], axis=-1)[..., 0]
    lo = np.take_along_axis(alphas, np.maximum(k - 1, 0)[..., None], axis=-1)[..., 0]
    hi = np.take_along_axis(alphas, np.minimum(k + 1, _GRID - 1)[..., None], axis=-1)[..., 0]
    args = (total, v1, vt1, vt2, v2)
    s_lo, s_hi = _slope(lo, *args), _slope(hi, *args)
    inner = (s_lo < 0) & (s_hi > 0)  # a minimum between the neighbours of the best point
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        up = _slope(mid, *args) > 0
        hi = np.where(inner & up, mid, hi)
        lo = np.where(inner & ~up, mid, lo)
    refined = np.where(inner, 0.5 * (lo + hi), best)
    # the refined point only where it is no worse than the grid's (the ends included)
    f_ref = _burn(v1, vt1, refined) + _burn(vt2, v2, total - refined)
    f_best = _burn(v1, vt1, best) + _burn(vt2, v2, total - best)
    alpha = np.where(f_ref <= f_best, refined, best)
    sign = np.where(di < 0, -1.0, 1.0)
    dv1 = _burn(v1, vt1, alpha)
    dv2 = _burn(vt2, v2, total - alpha)
    tof = np.pi * np.sqrt((a + b) ** 3 / (8.0 * mu))
    return (to_quantity(dv1, "speed"), to_quantity(dv2, "speed"),
            np.rad2deg(sign * alpha) * u.deg, np.rad2deg(sign * (total - alpha)) * u.deg,
            to_quantity(tof, "time"))
