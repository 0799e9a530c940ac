"""The zonal harmonics of a central body as a compiled kernel, about the body's pole.

The zonal field J_2 .. J_n is symmetric about the body's axis, which need not be the z axis of
the propagation frame: the Earth's pole is 0.13 deg from the GCRS z axis in 2024 (precession
since J2000). The pole at a time is :func:`visviva.core.geodetic.body_pole` (the force block's
``POLE`` table, shared with drag, altitude events and relativity); without one the frame's z
axis.
"""

from __future__ import annotations

import math

from ._jit import inline_kernel, kernel

__all__ = ["accel_zonal", "pole_sine"]


@inline_kernel
def pole_sine(x, y, z, px, py):
    """|r|^2, |r|, the pole's z component pz = sqrt(1 - px^2 - py^2) and s = r_hat . p (the
    sine of the latitude of (x, y, z) above the equator of the pole p = (px, py, pz)): the
    variables of the zonal field (:func:`accel_zonal`) and of its gradient
    (``force_partials``)."""
    r2 = x * x + y * y + z * z
    r = math.sqrt(r2)
    pz = math.sqrt(1.0 - px * px - py * py)
    return r2, r, pz, (x * px + y * py + z * pz) / r


@kernel
def accel_zonal(x, y, z, gm, radius, zonal, n_max, px, py, out):
    """Add the acceleration of the zonal harmonics J_2 .. J_n_max to ``out``.

    ``(px, py, pz)``, pz = sqrt(1 - px^2 - py^2), is the unit vector of the body's pole (the
    axis of symmetry of the zonal field) in the frame of (x, y, z); (0, 0) is the frame's z axis.

    Notes
    -----
    With s = r_hat . p (the sine of the latitude above the body's equator) and the potential
    U = -GM/r * sum_n J_n (R/r)^n P_n(s), the gradient is (Vallado 2013, eq. 8-19, generalised
    to any degree and any pole p)

        a = GM J_n R^n / r^(n+2) * [((n+1) P_n(s) + s P_n'(s)) r_hat - P_n'(s) p],

    with the Legendre recursions n P_n = (2n-1) s P_{n-1} - (n-1) P_{n-2} and
    P_n' = n P_{n-1} + s P_{n-1}'. For n = 2 and p = z_hat this is the familiar J2 acceleration
    a_x = -3/2 J2 GM R^2 x / r^5 (1 - 5 z^2/r^2), a_z = -3/2 J2 GM R^2 z / r^5 (3 - 5 z^2/r^2).
    """
    r2, r, pz, s = pole_sine(x, y, z, px, py)
    # P_0, P_1 and derivatives
    p_nm2 = 1.0
    p_nm1 = s
    dp_nm1 = 1.0
    ratio = radius / r
    rn = ratio  # (R/r)^1
    radial = 0.0
    axial = 0.0
    for n in range(2, n_max + 1):
        p_n = ((2 * n - 1) * s * p_nm1 - (n - 1) * p_nm2) / n
        dp_n = n * p_nm1 + s * dp_nm1
        rn *= ratio
        jn = zonal[n]
        if jn != 0.0:
            c = jn * rn
            radial += c * ((n + 1) * p_n + s * dp_n)
            axial += c * dp_n
        p_nm2, p_nm1 = p_nm1, p_n
        dp_nm1 = dp_n
    k = gm / r2
    if px == 0.0 and py == 0.0:  # the frame's z axis (the bits of the z-axis formula)
        out[0] += k * radial * x / r
        out[1] += k * radial * y / r
        out[2] += k * (radial * s - axial)
    else:
        out[0] += k * (radial * x / r - axial * px)
        out[1] += k * (radial * y / r - axial * py)
        out[2] += k * (radial * z / r - axial * pz)
