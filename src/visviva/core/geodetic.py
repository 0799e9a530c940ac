"""The central body's pole in the propagation frame and geodetic coordinates about it.

The Earth's axis is not the z axis of the GCRS: the celestial intermediate pole is 0.134 deg
from it in 2024 (precession since J2000, growing by 0.014 deg a year). Every force and event
that depends on the axis reads it here: the zonal field (:mod:`visviva.core.zonal`), the
co-rotating atmosphere and the geodetic altitude of drag and of altitude events, the
Lense-Thirring spin (:mod:`visviva.core.relativity`), and the body-fixed frame of a full
gravity field (:func:`body_fixed_matrix`, since audit42; frozen at the epoch before).

The pole is tabulated once per run (``POLE`` slots of the force block,
:mod:`visviva.core.force_block`): knots of its x, y components fixed in absolute time after the
block's :data:`~visviva.core.force_block.FORCE_SIZE` values, interpolated linearly
(:func:`body_pole`); without a table (no epoch, another body) the frame's z axis.

Geodetic coordinates are exact to round-off in practice (:func:`geodetic`): the normal of the
ellipsoid of revolution about the pole through the point by Bowring's (1976) formula, the
parametric latitude beta (tan beta = R z_p / (b rho)) giving tan phi = (z_p + e'^2 b sin^3 beta)
/ (rho - e^2 R cos^3 beta), and the height h = rho cos phi + z_p sin phi -
R sqrt(1 - e^2 sin^2 phi) (stable on the axis; stationary in phi, so its error is second order
in phi's): within 1e-8 rad of astropy's WGS-84 latitude and 3e-8 m of its height at -5 to
100000 km (Vallado 2013, sec. 3.3; B. R. Bowring, Survey Review 23, 1976).
"""

from __future__ import annotations

import math

from . import force_block as fb
from ._jit import inline_kernel, kernel

__all__ = ["body_fixed_matrix", "body_pole", "geodetic", "geodetic_altitude", "geodetic_altitudes",
           "pole_altitude"]


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
def body_fixed_matrix(t, force, M):
    """The rotation M (3, 3) from the propagation frame to the central body's body-fixed frame
    at ``t`` s, written into ``M``: r_bf = M r.

    M = A R3(w t) C(p(t)), with C(p) the rotation that takes the pole p(t) of
    :func:`body_pole` (unit vector (X, Y, Z)) to the z axis without turning about it, the
    GCRS -> CIRS matrix of IERS Conventions 2010, eq. 5.10 with s = 0,
    C = [[1 - a X^2, -a X Y, -X], [-a X Y, 1 - a Y^2, -Y], [X, Y, 1 - a (X^2 + Y^2)]],
    a = 1 / (1 + Z); R3(w t) the body's rotation about its pole at the block's
    ``ROTATION_RATE``; A the block's ``FRAME_MATRIX`` (the rest of the rotation at t = 0:
    the Earth rotation angle and polar motion, held). Without a pole table C = I.
    """
    px, py = body_pole(t, force)
    pz = math.sqrt(1.0 - px * px - py * py)
    a = 1.0 / (1.0 + pz)
    c0x, c0y, c0z = 1.0 - a * px * px, -a * px * py, -px
    c1x, c1y, c1z = -a * px * py, 1.0 - a * py * py, -py
    c2x, c2y, c2z = px, py, 1.0 - a * (px * px + py * py)
    th = force[fb.ROTATION_RATE] * t
    c = math.cos(th)
    s = math.sin(th)
    r0x, r0y, r0z = c * c0x + s * c1x, c * c0y + s * c1y, c * c0z + s * c1z  # R3(th) C
    r1x, r1y, r1z = -s * c0x + c * c1x, -s * c0y + c * c1y, -s * c0z + c * c1z
    k = fb.FRAME_MATRIX
    for i in range(3):
        a0 = force[k + 3 * i]
        a1 = force[k + 3 * i + 1]
        a2 = force[k + 3 * i + 2]
        M[i, 0] = a0 * r0x + a1 * r1x + a2 * c2x
        M[i, 1] = a0 * r0y + a1 * r1y + a2 * c2y
        M[i, 2] = a0 * r0z + a1 * r1z + a2 * c2z


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
    b = radius * (1.0 - flattening)
    sb = radius * zp  # the parametric latitude beta: (sin, cos) along (R z_p, b rho)
    cb = b * rho
    d = math.sqrt(sb * sb + cb * cb)
    if d == 0.0:  # the centre: no normal
        return -radius, 0.0, 1.0, zp, rho, pz
    sb /= d
    cb /= d
    sn = zp + e2 / (1.0 - e2) * b * sb * sb * sb
    cs = rho - e2 * radius * cb * cb * cb
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


@kernel
def geodetic_altitudes(r, radius, flattening, px, py, out):
    """:func:`geodetic_altitude` of each row of ``r`` (N, 3), km, into ``out`` (N,)."""
    for i in range(r.shape[0]):
        out[i] = geodetic(r[i, 0], r[i, 1], r[i, 2], radius, flattening, px, py)[0]
