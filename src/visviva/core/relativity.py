"""The post-Newtonian (general-relativistic) correction to a satellite's acceleration and its
partials, as compiled scalar kernels.

The IERS Conventions (2010), chapter 10, eq. 10.12, with the PPN parameters beta = gamma = 1
(general relativity), in the geocentric frame:

* **Schwarzschild** (the central mass):
  ``a_S = GM / (c^2 r^3) [(4 GM / r - v^2) r + 4 (r . v) v]``. It turns perigee forwards by
  ``6 pi GM / (c^2 a (1 - e^2))`` per revolution (the textbook perihelion advance); about
  1.7e-8 m/s^2 in LEO.
* **Lense-Thirring** (the central body's rotation, frame dragging):
  ``a_LT = 2 GM / (c^2 r^3) [3 / r^2 (r x v)(r . J) + v x J]`` with ``J`` the body's angular
  momentum per unit mass (the Earth: 9.8e8 m^2/s along its pole, the celestial intermediate
  pole of the run's table, not the frame's z axis); about 2e-10 m/s^2 in LEO.

The de Sitter (geodesic) term, the Earth's orbit about the Sun, is left out: about 5e-11 m/s^2
in LEO, below the other two.

Units: km, km/s, km^3/s^2, and ``spin`` in km^2/s. References: G. Petit and B. Luzum (eds.), IERS
Conventions (2010), IERS Technical Note 36, sec. 10.3; Montenbruck & Gill (2000), Satellite
Orbits, sec. 3.7.3.
"""

from __future__ import annotations

import math

from ._jit import inline_kernel, kernel

__all__ = ["C_KM_S", "schwarzschild", "accel_relativity", "add_relativity_partials"]

#: Speed of light, km/s (exact, SI; the same value as :data:`visviva.constants.C_KM_S`, which
#: this layer may not import).
C_KM_S = 299_792.458


@inline_kernel
def schwarzschild(dx, dy, dz, dvx, dvy, dvz, mu, c2):
    """The Schwarzschild (1PN, single-body) acceleration ``(ax, ay, az)`` at ``d`` moving at
    ``dv`` relative to a mass of gravitational parameter ``mu``, with ``c2`` = c^2 in the same
    units: ``mu / (c2 r^3) [(4 mu / r - v^2) d + 4 (d . dv) dv]`` (also the N-body
    :class:`visviva.nbody.forces.GeneralRelativity`'s pair term)."""
    r2 = dx * dx + dy * dy + dz * dz
    r = math.sqrt(r2)
    v2 = dvx * dvx + dvy * dvy + dvz * dvz
    rv = dx * dvx + dy * dvy + dz * dvz
    k = mu / (c2 * r2 * r)
    fr = 4.0 * mu / r - v2
    return (k * (fr * dx + 4.0 * rv * dvx), k * (fr * dy + 4.0 * rv * dvy),
            k * (fr * dz + 4.0 * rv * dvz))


@kernel
def accel_relativity(x, y, z, vx, vy, vz, gm, spin, px, py, out):
    """Add the Schwarzschild term and, for ``spin != 0``, the Lense-Thirring term to ``out``.

    Parameters
    ----------
    x, y, z : float
        Position from the central body, km.
    vx, vy, vz : float
        Velocity, km/s.
    gm : float
        GM of the central body, km^3/s^2.
    spin : float
        The central body's angular momentum per unit mass, km^2/s (0: no Lense-Thirring term).
    px, py : float
        x and y of the unit vector of the body's pole (its spin axis; z = sqrt(1 - px^2 -
        py^2)): J = spin p (:func:`visviva.core.geodetic.body_pole`; (0, 0): the frame's z axis).
    out : ndarray (3,)
        Acceleration, km/s^2, added to in place.
    """
    ax, ay, az = schwarzschild(x, y, z, vx, vy, vz, gm, C_KM_S * C_KM_S)
    out[0] += ax
    out[1] += ay
    out[2] += az
    if spin != 0.0:
        jx = spin * px
        jy = spin * py
        jz = spin * math.sqrt(1.0 - px * px - py * py)
        r2 = x * x + y * y + z * z
        g = 2.0 * gm / (C_KM_S * C_KM_S * r2 * math.sqrt(r2))
        q = 3.0 * (x * jx + y * jy + z * jz) / r2  # 3 (r . J) / r^2
        # (r x v) q + v x J
        out[0] += g * ((y * vz - z * vy) * q + vy * jz - vz * jy)
        out[1] += g * ((z * vx - x * vz) * q + vz * jx - vx * jz)
        out[2] += g * ((x * vy - y * vx) * q + vx * jy - vy * jx)


@kernel
def add_relativity_partials(x, y, z, vx, vy, vz, gm, spin, px, py, dadr, dadv):
    """Add the partial derivatives of :func:`accel_relativity` to ``dadr`` (1/s^2) and
    ``dadv`` (1/s), (3, 3) each, row = acceleration component, column = coordinate.

    With ``f = GM / (c^2 r^3)``, ``s = 4 GM / r - v^2``, ``p = r . v``:
    ``da_S/dr = f [s (I - 3 r r^T / r^2) - 4 GM r r^T / r^3 - 12 p v r^T / r^2 + 4 v v^T]`` and
    ``da_S/dv = f [4 p I + 4 v r^T - 2 r v^T]``; with ``g = 2 f``, ``w = r x v``,
    ``q = 3 (r . J) / r^2``:
    ``da_LT/dr = -3 a_LT r^T / r^2 + g [w (3 J / r^2 - 2 q r / r^2)^T - q [v]x]`` and
    ``da_LT/dv = g (q [r]x - [J]x)``, where ``[u]x`` is the cross-product matrix
    (``[u]x b = u x b``), and ``J = spin p`` (``px``, ``py`` as for :func:`accel_relativity`).
    """
    r2 = x * x + y * y + z * z
    r = math.sqrt(r2)
    v2 = vx * vx + vy * vy + vz * vz
    p = x * vx + y * vy + z * vz
    f = gm / (C_KM_S * C_KM_S * r2 * r)
    s = 4.0 * gm / r - v2
    rr = (x, y, z)
    vv = (vx, vy, vz)
    for i in range(3):
        for j in range(3):
            dadr[i, j] += f * (-3.0 * s * rr[i] * rr[j] / r2 - 4.0 * gm * rr[i] * rr[j] / (r2 * r)
                               - 12.0 * p * vv[i] * rr[j] / r2 + 4.0 * vv[i] * vv[j])
            dadv[i, j] += f * (4.0 * vv[i] * rr[j] - 2.0 * rr[i] * vv[j])
        dadr[i, i] += f * s
        dadv[i, i] += f * 4.0 * p
    if spin == 0.0:
        return
    jv = (spin * px, spin * py, spin * math.sqrt(1.0 - px * px - py * py))
    g = 2.0 * f
    q = 3.0 * (x * jv[0] + y * jv[1] + z * jv[2]) / r2
    w = (y * vz - z * vy, z * vx - x * vz, x * vy - y * vx)
    vxj = (vy * jv[2] - vz * jv[1], vz * jv[0] - vx * jv[2], vx * jv[1] - vy * jv[0])
    a = (g * (w[0] * q + vxj[0]), g * (w[1] * q + vxj[1]), g * (w[2] * q + vxj[2]))
    dq = (3.0 * jv[0] / r2 - 2.0 * q * x / r2, 3.0 * jv[1] / r2 - 2.0 * q * y / r2,
          3.0 * jv[2] / r2 - 2.0 * q * z / r2)
    for i in range(3):
        for k in range(3):
            dadr[i, k] += -3.0 * a[i] * rr[k] / r2 + g * w[i] * dq[k]
    # - g q [v]x: d (r x v) / d r = -[v]x
    dadr[0, 1] += g * q * vz
    dadr[0, 2] -= g * q * vy
    dadr[1, 0] -= g * q * vz
    dadr[1, 2] += g * q * vx
    dadr[2, 0] += g * q * vy
    dadr[2, 1] -= g * q * vx
    # g q [r]x - g [J]x
    dadv[0, 1] += g * (-q * z + jv[2])
    dadv[0, 2] += g * (q * y - jv[1])
    dadv[1, 0] += g * (q * z - jv[2])
    dadv[1, 2] += g * (-q * x + jv[0])
    dadv[2, 0] += g * (-q * y + jv[1])
    dadv[2, 1] += g * (q * x - jv[0])
