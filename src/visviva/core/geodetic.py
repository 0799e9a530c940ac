"""The central body's pole in the propagation frame and geodetic coordinates about it.

The Earth's axis is not the z axis of the GCRS: the celestial intermediate pole is 0.134 deg
from it in 2024 (precession since J2000, growing by 0.014 deg a year). Every force and event
that depends on the axis reads it here: the zonal field (:mod:`visviva.core.zonal`), the
co-rotating atmosphere and the geodetic altitude of drag and of altitude events, the
Lense-Thirring spin (:mod:`visviva.core.relativity`).

The pole is tabulated once per run (``POLE`` slots of the force block,
:mod:`visviva.core.force_block`): knots of its x, y components fixed in absolute time after the
block's :data:`~visviva.core.force_block.FORCE_SIZE` values, interpolated linearly
(:func:`body_pole`); without a table (no epoch, another body) the frame's z axis.

Geodetic coordinates are exact (:func:`geodetic`): the normal of the ellipsoid of revolution
about the pole through the point, found by a fixed-point iteration on the latitude
(tan phi = (z_p + e^2 N sin phi) / rho; three passes, below 1e-9 rad and 1e-6 m in
0-40000 km altitude), h = rho cos phi + z_p sin phi - R sqrt(1 - e^2 sin^2 phi) (Vallado 2013,
sec. 3.3; the height formula of Bowring 1985, stable on the axis).
"""

from __future__ import annotations

import math

from . import force_block as fb
from ._jit import inline_kernel

__all__ = ["body_pole", "geodetic", "geodetic_altitude", "pole_altitude"]


@inline_kernel
def body_pole(t, force):
    """x and y of the central body's pole (unit vector; z = sqrt(1 - x^2 - y^2)) in the
    propagation frame at ``t`` s: linear interpolation in the table of the block's ``POLE``
    slots (continued linearly past its ends); (0, 0), the frame's z axis, without a table."""
    k = fb.POLE
    n = int(force[k + 2])
    if n < 2:
        return 0.0, 0.0
    u = (t - force[k]) / force[k + 1]
    i = int(math.floor(u))  # plain comparisons, not min/max: numba compiles its min/max
    i = 0 if i < 0 else (n - 2 if i > n - 2 else i)  # overloads anew in every process
    w = u - i
    j = int(force[k + 3]) + 2 * i
    return (force[j] + w * (force[j + 2] - force[j]),
            force[j + 1] + w * (force[j + 3] - force[j + 1]))


@inline_kernel
def geodetic(x, y, z, radius, flattening, px, py):
    """Geodetic coordinates of (x, y, z) (km) about the pole p = (px, py, pz) of an ellipsoid of
    equatorial ``radius`` (km) and ``flattening``.

    Returns ``(h, s, c, zp, rho, pz)``: the height above the ellipsoid along its normal (km),
    sine and cosine of the geodetic latitude, the distance along the pole z_p = r . p (km),
    the distance from the axis rho = |r x p| (km) and pz. The gradient of h is the normal
    c rho_hat + s p; that of the latitude (-s rho_hat + c p) / (M + h), M the meridian radius
    of curvature R (1 - e^2) / (1 - e^2 s^2)^1.5; that of the longitude (p x r) / rho^2.
    """
    pz = math.sqrt(1.0 - px * px - py * py)
    zp = x * px + y * py + z * pz
    cx = y * pz - z * py
    cy = z * px - x * pz
    cz = x * py - y * px
    rho = math.sqrt(cx * cx + cy * cy + cz * cz)  # |r x p|: exact near the axis too
    e2 = flattening * (2.0 - flattening)
    sn = zp
    cs = rho * (1.0 - e2)
    for _ in range(3):
        d = math.sqrt(sn * sn + cs * cs)
        if d == 0.0:  # the centre: no normal
            return -radius, 0.0, 1.0, zp, rho, pz
        s = sn / d
        sn = zp + e2 * radius * s / math.sqrt(1.0 - e2 * s * s)
        cs = rho
    d = math.sqrt(sn * sn + cs * cs)
    s = sn / d
    c = cs / d
    h = rho * c + zp * s - radius * math.sqrt(1.0 - e2 * s * s)
    return h, s, c, zp, rho, pz


@inline_kernel
def geodetic_altitude(x, y, z, radius, flattening, px, py):
    """Height (km) of (x, y, z) above the ellipsoid about the pole (px, py): :func:`geodetic`."""
    return geodetic(x, y, z, radius, flattening, px, py)[0]


@inline_kernel
def pole_altitude(t, x, y, z, force):
    """The geodetic altitude (km) of (x, y, z) at ``t`` s about the block's pole, with its
    central body's radius and flattening: the altitude of drag and of altitude events."""
    px, py = body_pole(t, force)
    return geodetic(x, y, z, force[fb.ELLIPSOID_RADIUS], force[fb.FLATTENING], px, py)[0]
