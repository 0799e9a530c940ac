"""Lambert's problem: velocities that carry a body from r1 to r2 in a given time.

>>> import visviva as vv
>>> from astropy import units as u
>>> # Curtis (2014), Example 5.2: r1, r2 in km, 1 hour, Earth mu = 398600 km^3/s^2
>>> v1, v2 = vv.lambert([5000.0, 10000.0, 2100.0] * u.km, [-14600.0, 2500.0, 7000.0] * u.km,
...                    3600 * u.s, 398600 * u.km**3 / u.s**2)
>>> print(", ".join(f"{x:.4f}" for x in v1.to_value(u.km / u.s)))
-5.9925, 1.9254, 3.2456
"""

from __future__ import annotations

import numpy as np

from .._units import to_array, to_quantity, to_vector
from ..core import status as st
from ..core.lambert import izzo_many, universal_many
from ..errors import DomainError, InvalidInputError, raise_for_status

__all__ = ["lambert", "LAMBERT_METHODS"]

#: The solvers and what they handle (every conic; M >= 0 revolutions; both branches).
LAMBERT_METHODS = {
    "izzo": {"kernel": izzo_many, "conics": ("ellipse", "parabola", "hyperbola"), "multirev": True},
    "universal": {
        "kernel": universal_many,
        "conics": ("ellipse", "parabola", "hyperbola"),
        "multirev": True,
    },
}


def lambert(
    r1, r2, tof, gm, revolutions: int = 0, prograde: bool = True, *, branch="left", method="izzo"
):
    """Solve Lambert's problem: the velocities at r1 and r2 of the conic from r1 to r2 in ``tof``.

    Parameters
    ----------
    r1, r2 : Quantity (..., 3), length
        Initial and final positions relative to the attractor.
    tof : Quantity (...), time
        Time of flight, > 0. Broadcasts against r1 and r2.
    gm : Quantity or Body
        Gravitational parameter of the attractor.
    revolutions : int
        Number of complete revolutions M >= 0 before arriving.
    prograde : bool
        True (default): the transfer orbit turns counter-clockwise about +z (angular momentum
        h_z > 0), which picks the short way when r1 x r2 points to +z and the long way
        otherwise; False gives the other way. When (r1 x r2)_z = 0 exactly (a transfer plane
        containing the z axis) True gives the short way.
    branch : {"left", "right"}
        For ``revolutions >= 1`` there are two solutions (or none if ``tof`` is below the
        minimum time for M revolutions): Izzo's left branch (x < x_Tmin) and right branch
        (x > x_Tmin). The left branch has the smaller semi-major axis (shorter period), the
        right branch the larger one (checked over random geometries in the tests). Ignored for
        M = 0.
    method : {"izzo", "universal"}
        Izzo (2015), Householder iterations (default); or the universal-variable method of
        Bate, Mueller & White / Vallado Algorithm 58 with bisection (independent check; it
        loses a few digits within ~0.01 deg of a 180 deg transfer, where g -> 0).

    Returns
    -------
    v1, v2 : Quantity (..., 3), km/s
        Velocities at departure and arrival.

    Raises
    ------
    DomainError
        r1 and r2 collinear (transfer plane undefined), tof <= 0, or no M-revolution solution
        in that time.

    Notes
    -----
    Izzo, D. (2015), Revisiting Lambert's problem, Celest. Mech. Dyn. Astron. 121, 1-15:
    with c = |r2 - r1|, s = (|r1| + |r2| + c)/2, lambda^2 = 1 - c/s and T = sqrt(2 mu/s^3) tof,
    solve T(x) = T for x (eqs. 18-22), then
    v = gamma [(lambda y - x) - rho (lambda y + x)]/r1 r1_hat + gamma sigma (y + lambda x)/r1 t1_hat
    (eq. 23). Verified against Curtis (2014), Example 5.2 and the second method.
    """
    R1 = to_vector(r1, "length", "r1")
    R2 = to_vector(r2, "length", "r2")
    T = to_array(tof, "time", "tof")
    mu = to_array(gm, "gm", "gm")
    if not isinstance(revolutions, int | np.integer) or revolutions < 0:
        raise InvalidInputError(f"revolutions must be an integer >= 0; got {revolutions!r}.")
    if branch not in ("left", "right"):
        raise InvalidInputError(f"branch must be 'left' or 'right'; got {branch!r}.")
    if method not in LAMBERT_METHODS:
        raise InvalidInputError(f"method must be one of {sorted(LAMBERT_METHODS)}; got {method!r}.")
    if np.any(T <= 0):
        raise DomainError("tof must be > 0; for a backward arc swap r1 and r2.")
    if np.any(mu <= 0):
        raise InvalidInputError("gm must be > 0 (e.g. vv.SUN.gm).")
    shape = np.broadcast_shapes(R1.shape[:-1], R2.shape[:-1], T.shape, mu.shape)
    n = int(np.prod(shape))
    r1f = np.ascontiguousarray(np.broadcast_to(R1, shape + (3,)).reshape(n, 3))
    r2f = np.ascontiguousarray(np.broadcast_to(R2, shape + (3,)).reshape(n, 3))
    tf = np.ascontiguousarray(np.broadcast_to(T, shape).reshape(n))
    mf = np.ascontiguousarray(np.broadcast_to(mu, shape).reshape(n))
    v1 = np.empty((n, 3))
    v2 = np.empty((n, 3))
    status = np.zeros(n, dtype=np.int64)
    LAMBERT_METHODS[method]["kernel"](
        r1f, r2f, tf, mf, int(revolutions), bool(prograde), branch == "right", v1, v2, status
    )
    if np.any(status == st.DOMAIN):
        k = int(np.flatnonzero(status == st.DOMAIN)[0])
        cross = np.linalg.norm(np.cross(r1f[k], r2f[k]))
        if cross <= 1e-12 * np.linalg.norm(r1f[k]) * np.linalg.norm(r2f[k]):
            raise DomainError(
                f"r1 and r2 are collinear (transfer angle 0 or 180 deg) at index {k}: the "
                "transfer plane is undefined. Offset one position slightly out of the line."
            )
        raise DomainError(
            f"no {revolutions}-revolution transfer exists in tof = {tf[k]} s at index {k}: the "
            "time of flight is below the minimum for that many revolutions. Use fewer "
            "revolutions or a longer tof."
        )
    raise_for_status(status.reshape(shape), "Lambert", tof=tf.reshape(shape))
    return (
        to_quantity(v1.reshape(shape + (3,)), "speed"),
        to_quantity(v2.reshape(shape + (3,)), "speed"),
    )
