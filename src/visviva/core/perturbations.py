"""Perturbing accelerations for Cowell's method, as compiled scalar kernels.

Every kernel works on plain float64 values in km, km/s, s and km^3/s^2, writes its acceleration
*into* an output 3-vector (adding to what is there), and never raises. The single right-hand side
:func:`cowell_rhs` sums the two-body term and every perturbation switched on in the ``force``
parameter array, in a fixed order, so that one compiled call gives the full derivative.

The ``force`` parameter array (float64, :data:`FORCE_SIZE` values, then the table of the
central body's pole when a force or event turns with it) is laid out in
:mod:`visviva.core.force_block`, which names every slot (``fb.GM``, ``fb.DRAG_ON``, ...): the
kernels below read it by those names only (the pole through :mod:`visviva.core.geodetic`), and
each perturbation class of :mod:`visviva.satellites.perturbations` writes its own slots.

With density model 1, ``atm`` has shape ((n_hour_angle + 3) * (n_latitude + 2),
n_altitude + 2) and holds the tricubic B-spline coefficients of ln(rho / (kg/m^3)) over (hour angle from the Sun,
geodetic latitude, geodetic altitude), read by :func:`grid_log_density`.

``sh``, shape (2, N+2, N+2): unnormalised C_nm and S_nm of the spherical-harmonic field
(Montenbruck & Gill 2000, eq. 3.13), used when ``force[fb.HARMONICS_DEGREE]`` is > 0.

``atm`` is the exponential atmosphere table, shape (K, 3): base altitude km, density at the
base kg/m^3, scale height km (Vallado 2013, Table 8-4).
``eph_r``/``eph_v``, shape (B, N, 3): positions (km) and velocities (km/s) of the tabulated
bodies relative to the central body on a uniform time grid; ``eph_gm`` their GM. Positions in
between come from cubic Hermite interpolation.
"""

from __future__ import annotations

import math

import numpy as np

from . import force_block as fb
from ._jit import inline_kernel, kernel
from .force_block import FORCE_SIZE
from .geodetic import body_fixed_matrix, body_pole, geodetic, geodetic_altitude
from .hermite import hermite_basis
from .local_frames import to_inertial
from .relativity import accel_relativity
from .zonal import accel_zonal

__all__ = [
    "FORCE_SIZE",
    "accel_two_body",
    "accel_zonal",
    "accel_harmonics",
    "accel_harmonics_inertial",
    "cunningham_vw",
    "grid_density_at",
    "grid_log_density_gradient_at",
    "grid_log_density",
    "grid_density",
    "accel_drag",
    "drag_density",
    "accel_third_body",
    "accel_srp",
    "shadow_fraction",
    "exponential_density",
    "exponential_band",
    "band_density",
    "geodetic_altitude",
    "hermite_position",
    "sun_and_mass_scale",
    "zonal_rhs",
    "body_pole",
    "cowell_rhs",
    "cowell_rhs_array",
]


#: Vallado (2013), Fundamentals of Astrodynamics and Applications, 4th ed., Table 8-4:
#: base altitude (km), nominal density (kg/m^3), scale height (km).
VALLADO_EXPONENTIAL_TABLE = np.array(
    [
        [0.0, 1.225, 7.249],
        [25.0, 3.899e-2, 6.349],
        [30.0, 1.774e-2, 6.682],
        [40.0, 3.972e-3, 7.554],
        [50.0, 1.057e-3, 8.382],
        [60.0, 3.206e-4, 7.714],
        [70.0, 8.770e-5, 6.549],
        [80.0, 1.905e-5, 5.799],
        [90.0, 3.396e-6, 5.382],
        [100.0, 5.297e-7, 5.877],
        [110.0, 9.661e-8, 7.263],
        [120.0, 2.438e-8, 9.473],
        [130.0, 8.484e-9, 12.636],
        [140.0, 3.845e-9, 16.149],
        [150.0, 2.070e-9, 22.523],
        [180.0, 5.464e-10, 29.740],
        [200.0, 2.789e-10, 37.105],
        [250.0, 7.248e-11, 45.546],
        [300.0, 2.418e-11, 53.628],
        [350.0, 9.518e-12, 53.298],
        [400.0, 3.725e-12, 58.515],
        [450.0, 1.585e-12, 60.828],
        [500.0, 6.967e-13, 63.822],
        [600.0, 1.454e-13, 71.835],
        [700.0, 3.614e-14, 88.667],
        [800.0, 1.170e-14, 124.64],
        [900.0, 5.245e-15, 181.05],
        [1000.0, 3.019e-15, 268.00],
    ]
)


@inline_kernel
def accel_two_body(x, y, z, gm, out):
    """Add the Keplerian acceleration -GM r / |r|^3 to ``out``."""
    r2 = x * x + y * y + z * z
    r = math.sqrt(r2)
    k = -gm / (r2 * r)
    out[0] += k * x
    out[1] += k * y
    out[2] += k * z


@kernel
def cunningham_vw(x, y, z, radius, n_rows):
    """The V_nm, W_nm of Cunningham's recursions for degrees and orders 0 .. ``n_rows`` - 1.

    Body-fixed (x, y, z) and the field's reference radius, km; Montenbruck & Gill (2000),
    eqs. 3.29-3.31. Returns (V, W), each (n_rows, n_rows), zero above the diagonal m > n.
    """
    r2 = x * x + y * y + z * z
    rr = radius * radius / r2
    x0 = radius * x / r2
    y0 = radius * y / r2
    z0 = radius * z / r2
    N = n_rows
    V = np.zeros((N, N))
    W = np.zeros((N, N))
    V[0, 0] = radius / math.sqrt(r2)
    W[0, 0] = 0.0
    for m in range(N):
        if m > 0:
            V[m, m] = (2 * m - 1) * (x0 * V[m - 1, m - 1] - y0 * W[m - 1, m - 1])
            W[m, m] = (2 * m - 1) * (x0 * W[m - 1, m - 1] + y0 * V[m - 1, m - 1])
        if m + 1 < N:
            V[m + 1, m] = (2 * m + 1) * z0 * V[m, m]
            W[m + 1, m] = (2 * m + 1) * z0 * W[m, m]
    # the columns m and m + 1 in one loop: two independent chains of divisions interleaved
    # (each chain is bound by the division's latency); the same operations, the same bits
    for m in range(0, N, 2):
        for n in range(m + 2, N):
            V[n, m] = ((2 * n - 1) * z0 * V[n - 1, m] - (n + m - 1) * rr * V[n - 2, m]) / (n - m)
            W[n, m] = ((2 * n - 1) * z0 * W[n - 1, m] - (n + m - 1) * rr * W[n - 2, m]) / (n - m)
            k = m + 1
            if n >= k + 2:
                V[n, k] = ((2 * n - 1) * z0 * V[n - 1, k] - (n + k - 1) * rr * V[n - 2, k]) / (n - k)
                W[n, k] = ((2 * n - 1) * z0 * W[n - 1, k] - (n + k - 1) * rr * W[n - 2, k]) / (n - k)
    return V, W


@kernel
def accel_harmonics(x, y, z, gm, radius, sh, n_max, out):
    """Add the acceleration of a spherical-harmonic field of degree and order ``n_max``.

    Body-fixed coordinates in, body-fixed acceleration added to ``out``. Terms of degree 0 and
    1 are skipped (the central term is the two-body one).

    Notes
    -----
    The V_nm, W_nm recursions and the acceleration sums of Montenbruck & Gill (2000),
    eqs. 3.29-3.33, with unnormalised C_nm = sh[0, n, m], S_nm = sh[1, n, m]
    (Cunningham 1970).
    """
    V, W = cunningham_vw(x, y, z, radius, n_max + 2)
    ax = 0.0
    ay = 0.0
    az = 0.0
    for m in range(n_max + 1):
        for n in range(max(m, 2), n_max + 1):
            C = sh[0, n, m]
            S = sh[1, n, m]
            if m == 0:
                ax -= C * V[n + 1, 1]
                ay -= C * W[n + 1, 1]
                az -= (n + 1) * C * V[n + 1, 0]
            else:
                fac = 1.0
                for k in range(n - m + 1, n - m + 3):
                    fac *= k  # (n-m+2)! / (n-m)!
                ax += 0.5 * ((-C * V[n + 1, m + 1] - S * W[n + 1, m + 1])
                             + fac * (C * V[n + 1, m - 1] + S * W[n + 1, m - 1]))  # fmt: skip
                ay += 0.5 * ((-C * W[n + 1, m + 1] + S * V[n + 1, m + 1])
                             + fac * (-C * W[n + 1, m - 1] + S * V[n + 1, m - 1]))  # fmt: skip
                az += (n - m + 1) * (-C * V[n + 1, m] - S * W[n + 1, m])
    k = gm / (radius * radius)
    out[0] += k * ax
    out[1] += k * ay
    out[2] += k * az


@kernel
def accel_harmonics_inertial(t, x, y, z, force, sh, out):
    """Rotate r to the body frame at time t (:func:`~visviva.core.geodetic.body_fixed_matrix`),
    add the harmonic acceleration rotated back, a_in = M^T a_bf."""
    M = np.empty((3, 3))
    body_fixed_matrix(t, force, M)
    bx = M[0, 0] * x + M[0, 1] * y + M[0, 2] * z
    by = M[1, 0] * x + M[1, 1] * y + M[1, 2] * z
    bz = M[2, 0] * x + M[2, 1] * y + M[2, 2] * z
    a = np.zeros(3)
    accel_harmonics(bx, by, bz, force[fb.GM], force[fb.RADIUS], sh, int(force[fb.HARMONICS_DEGREE]), a)
    out[0] += M[0, 0] * a[0] + M[1, 0] * a[1] + M[2, 0] * a[2]
    out[1] += M[0, 1] * a[0] + M[1, 1] * a[1] + M[2, 1] * a[2]
    out[2] += M[0, 2] * a[0] + M[1, 2] * a[1] + M[2, 2] * a[2]


@kernel
def exponential_band(h, atm):
    """The row (band) of an exponential table (K, 3) for altitude ``h`` (km): the one whose base
    altitude is the largest one <= h (the first row below the first base altitude)."""
    k = 0
    n = atm.shape[0]
    while k + 1 < n and h >= atm[k + 1, 0]:
        k += 1
    return k


@kernel
def band_density(h, atm, k):
    """Density in kg/m^3 at altitude ``h`` (km) from row ``k`` of an exponential table (K, 3),
    rho = rho_0 exp(-(h - h_0)/H), also outside the row's band (the integrators hold a band
    for a whole step: :mod:`visviva.core.drag_bands`)."""
    return atm[k, 1] * math.exp(-(h - atm[k, 0]) / atm[k, 2])


@kernel
def exponential_density(h, atm):
    """Density in kg/m^3 at altitude ``h`` (km) from an exponential table (K, 3).

    rho = rho_0 exp(-(h - h_0)/H) with the row whose base altitude h_0 is the largest one <= h
    (Vallado 2013, eq. 8-33 and Table 8-4). Below the first base altitude the first row is used.
    The published table is piecewise: its densities at the band edges jump (by the rounding of
    rho_0 to four digits, up to 0.14 % at 25 km) and its slope d ln rho / dh = -1/H jumps there
    (by up to 18 %, at 300 km); the integrators end their steps at the band edges
    (:mod:`visviva.core.drag_bands`).
    """
    return band_density(h, atm, exponential_band(h, atm))


@kernel
def grid_density_at(t, x, y, z, sun_pos, force, atm):
    """Density (kg/m^3) of the gridded model at (x, y, z) (km, inertial) at ``t`` s, the Sun at
    ``sun_pos``: geodetic altitude and latitude (NRLMSIS's) about the body's pole, hour angle
    from the Sun about it (:func:`_pole_hour_angle`), :func:`grid_density`."""
    px, py = body_pole(t, force)
    h, s, c, _, _, pz = geodetic(x, y, z, force[fb.ELLIPSOID_RADIUS], force[fb.FLATTENING], px, py)
    ha = _pole_hour_angle(x, y, z, sun_pos, px, py, pz)
    return grid_density(h, math.atan2(s, c), ha, force, atm)


@kernel
def grid_density(h, lat, hour_angle, force, atm):
    """Density (kg/m^3) at geodetic altitude ``h`` (km), geodetic latitude and hour angle
    from the Sun (rad): the exponential of :func:`grid_log_density`."""
    return math.exp(grid_log_density(h, lat, hour_angle, force, atm)[0])


@kernel
def grid_log_density_gradient_at(t, x, y, z, sun_pos, force, atm, grad):
    """ln(rho / (kg/m^3)) of the gridded model at (x, y, z) (km, inertial) at ``t`` s, and its
    gradient d ln(rho) / d r (1/km) written into ``grad`` (3,), the Sun held at ``sun_pos``.

    The chain rule through the exact geodetic coordinates about the pole p
    (:func:`visviva.core.geodetic.geodetic`): d h / d r the ellipsoid's normal
    c rho_hat + s p, d lat / d r = (-s rho_hat + c p) / (M + h), d ha / d r = (p x r) / rho^2,
    with the spline's analytic partials.
    """
    px, py = body_pole(t, force)
    radius = force[fb.ELLIPSOID_RADIUS]
    h, s, c, zp, rho, pz = geodetic(x, y, z, radius, force[fb.FLATTENING], px, py)
    ha = _pole_hour_angle(x, y, z, sun_pos, px, py, pz)
    val, dh, dlat, dha = grid_log_density(h, math.atan2(s, c), ha, force, atm)
    e2 = force[fb.FLATTENING] * (2.0 - force[fb.FLATTENING])
    m_curv = radius * (1.0 - e2) / (1.0 - e2 * s * s) ** 1.5
    pos = (float(x), float(y), float(z))
    pole = (px, py, pz)
    cross = (py * z - pz * y, pz * x - px * z, px * y - py * x)  # p x r
    for j in range(3):
        rh = (pos[j] - zp * pole[j]) / rho if rho > 0.0 else 0.0
        grad[j] = dh * (c * rh + s * pole[j]) + dlat * (-s * rh + c * pole[j]) / (m_curv + h)
        if rho > 0.0:
            grad[j] += dha * cross[j] / (rho * rho)
    return val


@inline_kernel
def _pole_hour_angle(x, y, z, sun_pos, px, py, pz):
    """Hour angle of (x, y, z) from the Sun about the pole p, rad in [-pi, pi]: the angle from
    the Sun's meridian to the point's, atan2(p . (s x r), s . r - (s . p)(r . p))."""
    sx, sy, sz = sun_pos[0], sun_pos[1], sun_pos[2]
    triple = px * (sy * z - sz * y) + py * (sz * x - sx * z) + pz * (sx * y - sy * x)
    dot = sx * x + sy * y + sz * z - (sx * px + sy * py + sz * pz) * (x * px + y * py + z * pz)
    return math.atan2(triple, dot)


@inline_kernel
def _bspline_weights(t):
    """The four uniform cubic B-spline weights at t in [0, 1] and their derivatives d/dt."""
    u = 1.0 - t
    t2 = t * t
    t3 = t2 * t
    w = (u * u * u / 6.0, (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
         (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0, t3 / 6.0)  # fmt: skip
    d = (-0.5 * u * u, 1.5 * t2 - 2.0 * t, -1.5 * t2 + t + 0.5, 0.5 * t2)
    return w, d


@kernel
def grid_log_density(h, lat, hour_angle, force, atm):
    """ln(rho / (kg/m^3)) of the gridded model by a tricubic B-spline (C2), with its partials.

    Returns ``(ln_rho, d/dh (1/km), d/dlat (1/rad), d/dhour_angle (1/rad))``. ``atm`` holds
    the B-spline coefficients (prefiltered in
    :meth:`visviva.satellites.perturbations.AtmosphericDrag.msis_grid`), one node of margin on
    each side: rows (hour-angle node + 1) * (n_lat + 2) + latitude node + 1, hour-angle nodes
    -1 .. n_h + 1 (periodic), latitude nodes -1 .. n_lat (continued across the poles),
    columns altitude node + 1, nodes -1 .. n_alt. Beyond the altitude grid ln(rho) continues
    linearly with the slope at its end (exponential extrapolation).
    """
    na = int(force[fb.DENSITY_GRID_SIZES])
    nl = int(force[fb.DENSITY_GRID_SIZES + 1])
    nh = int(force[fb.DENSITY_GRID_SIZES + 2])
    step_a = force[fb.DENSITY_GRID + 1]
    step_l = force[fb.DENSITY_GRID + 3]
    step_h = force[fb.DENSITY_GRID + 5]
    fa = (h - force[fb.DENSITY_GRID]) / step_a
    fa_in = min(max(fa, 0.0), na - 1.0)
    fl = min(max((lat - force[fb.DENSITY_GRID + 2]) / step_l, 0.0), nl - 1.0)
    fh = min(max((hour_angle - force[fb.DENSITY_GRID + 4]) / step_h, 0.0), float(nh))
    ia = min(int(fa_in), na - 2)
    il = min(int(fl), nl - 2)
    ih = min(int(fh), nh - 1)
    wa, da = _bspline_weights(fa_in - ia)
    wl, dl = _bspline_weights(fl - il)
    wh, dh = _bspline_weights(fh - ih)
    val = 0.0
    ga = 0.0
    gl = 0.0
    gh = 0.0
    gal = 0.0  # d2 / (d alt d lat) and d2 / (d alt d hour angle), for the extrapolation
    gah = 0.0
    for p in range(4):
        for q in range(4):
            row = (ih + p) * (nl + 2) + il + q
            s = 0.0
            sa = 0.0
            for k in range(4):
                c = atm[row, ia + k]
                s += wa[k] * c
                sa += da[k] * c
            val += wh[p] * wl[q] * s
            ga += wh[p] * wl[q] * sa
            gl += wh[p] * dl[q] * s
            gh += dh[p] * wl[q] * s
            gal += wh[p] * dl[q] * sa
            gah += dh[p] * wl[q] * sa
    beyond = fa - fa_in  # cells beyond the altitude grid (0 inside)
    val += ga * beyond
    gl += gal * beyond
    gh += gah * beyond
    return val, ga / step_a, gl / step_l, gh / step_h


@kernel
def accel_drag_rho(x, y, z, vx, vy, vz, rho_kg_m3, bc_km2_kg, omega, px, py, out):
    """Add drag for a given density (kg/m^3): a = -1/2 rho (Cd A/m) |v_rel| v_rel, v_rel =
    v - omega p x r, the atmosphere turning at ``omega`` (rad/s) about the body's pole
    p = (px, py, sqrt(1 - px^2 - py^2)) (:func:`visviva.core.geodetic.body_pole`)."""
    rho = rho_kg_m3 * 1e9  # kg/km^3
    pz = math.sqrt(1.0 - px * px - py * py)
    wx = vx - omega * (py * z - pz * y)
    wy = vy - omega * (pz * x - px * z)
    wz = vz - omega * (px * y - py * x)
    w = math.sqrt(wx * wx + wy * wy + wz * wz)
    k = -0.5 * rho * bc_km2_kg * w
    out[0] += k * wx
    out[1] += k * wy
    out[2] += k * wz


@kernel
def accel_drag(x, y, z, vx, vy, vz, bc_km2_kg, omega, radius, flattening, atm, px, py, out):
    """Add atmospheric drag a = -1/2 rho (Cd A/m) |v_rel| v_rel to ``out``.

    v_rel = v - omega x r is the velocity relative to an atmosphere co-rotating with the body
    about its pole (px, py) (Vallado 2013, eq. 8-31), rho the exponential table's at the
    geodetic altitude about that pole. rho in kg/m^3 times Cd*A/m in km^2/kg is converted to
    1/km with the factor 1e9.
    """
    h = geodetic_altitude(x, y, z, radius, flattening, px, py)
    accel_drag_rho(x, y, z, vx, vy, vz, exponential_density(h, atm), bc_km2_kg, omega, px, py,
                   out)


@inline_kernel
def accel_third_body(x, y, z, bx, by, bz, gm_b, out):
    """Add the third-body acceleration GM_b [(r_b - r)/|r_b - r|^3 - r_b/|r_b|^3] to ``out``.

    (Vallado 2013, eq. 8-35; Montenbruck & Gill 2000, eq. 3.37.)
    """
    dx = bx - x
    dy = by - y
    dz = bz - z
    d2 = dx * dx + dy * dy + dz * dz
    d3 = d2 * math.sqrt(d2)
    b2 = bx * bx + by * by + bz * bz
    b3 = b2 * math.sqrt(b2)
    out[0] += gm_b * (dx / d3 - bx / b3)
    out[1] += gm_b * (dy / d3 - by / b3)
    out[2] += gm_b * (dz / d3 - bz / b3)


@kernel
def shadow_fraction(x, y, z, sx, sy, sz, radius, sun_radius, model):
    """Fraction of the solar disc seen from r (1: full Sun, 0: umbra).

    model 1, cylindrical: 0 when r is behind the body (r . s_hat < 0) within the cylinder of the
    body's radius, else 1. model 2, conical: the overlap of the apparent discs of Sun (radius a)
    and body (radius b) at apparent separation c (Montenbruck & Gill 2000, sec. 3.4.2,
    eqs. 3.85-3.87). model 0: always 1.
    """
    if model == 0:
        return 1.0
    if model == 1:
        s = math.sqrt(sx * sx + sy * sy + sz * sz)
        proj = (x * sx + y * sy + z * sz) / s
        if proj >= 0.0:
            return 1.0
        px = x - proj * sx / s
        py = y - proj * sy / s
        pz = z - proj * sz / s
        if math.sqrt(px * px + py * py + pz * pz) < radius:
            return 0.0
        return 1.0
    r = math.sqrt(x * x + y * y + z * z)
    dx = sx - x
    dy = sy - y
    dz = sz - z
    d = math.sqrt(dx * dx + dy * dy + dz * dz)
    a = math.asin(min(1.0, sun_radius / d))
    b = math.asin(min(1.0, radius / r))
    cosc = -(x * dx + y * dy + z * dz) / (r * d)
    c = math.acos(max(-1.0, min(1.0, cosc)))
    if c >= a + b:
        return 1.0
    if c <= b - a:
        return 0.0
    if c <= a - b:  # annular: the body's disc lies inside the Sun's
        return 1.0 - (b * b) / (a * a)
    xx = (c * c + a * a - b * b) / (2.0 * c)
    yy = math.sqrt(max(0.0, a * a - xx * xx))
    area = a * a * math.acos(max(-1.0, min(1.0, xx / a)))
    area += b * b * math.acos(max(-1.0, min(1.0, (c - xx) / b))) - c * yy
    return 1.0 - area / (math.pi * a * a)


@kernel
def accel_srp(x, y, z, sx, sy, sz, coef, au, nu, out):
    """Add solar radiation pressure a = nu P (AU/d)^2 Cr A/m (r - r_sun)/d to ``out``.

    ``coef`` = P(1 AU) Cr A/m in km/s^2, d = |r - r_sun|, nu the shadow fraction
    (cannonball model; Montenbruck & Gill 2000, eq. 3.75).
    """
    if nu <= 0.0:
        return
    dx = x - sx
    dy = y - sy
    dz = z - sz
    d2 = dx * dx + dy * dy + dz * dz
    d = math.sqrt(d2)
    k = nu * coef * au * au / (d2 * d)
    out[0] += k * dx
    out[1] += k * dy
    out[2] += k * dz


@kernel
def hermite_position(t, body, force, eph_r, eph_v, out):
    """Position of tabulated body ``body`` at time ``t`` by cubic Hermite interpolation.

    Uses positions and velocities at the two grid points around ``t`` (clamped to the grid).
    """
    t0 = force[fb.EPH_T0]
    dt = force[fb.EPH_STEP]
    n = int(force[fb.EPH_N])
    u = (t - t0) / dt
    k = int(math.floor(u))
    if k < 0:
        k = 0
    if k > n - 2:
        k = n - 2
    h00, h10, h01, h11 = hermite_basis(u - k)
    for i in range(3):
        out[i] = (
            h00 * eph_r[body, k, i]
            + h10 * dt * eph_v[body, k, i]
            + h01 * eph_r[body, k + 1, i]
            + h11 * dt * eph_v[body, k + 1, i]
        )


@kernel
def accel_thrust(t, y, force, out):
    """The thrust acceleration of a finite burn at time t (s from its start), km/s^2.

    a(t) = F / m(t) u with m(t) = m0 - mdot t, i.e. ``THRUST_ACCEL / (1 - THRUST_MASS_RATE t)``,
    along the unit direction ``THRUST_DIRECTION`` held fixed in the frame ``THRUST_FRAME``
    (inertial, or RTN / TNW / VNB turning with the state, :mod:`visviva.core.local_frames`).
    Writes ``out`` (3,).
    """
    a = force[fb.THRUST_ACCEL] / (1.0 - force[fb.THRUST_MASS_RATE] * t)
    d = fb.THRUST_DIRECTION
    to_inertial(int(force[fb.THRUST_FRAME]), y, a * force[d], a * force[d + 1],
                a * force[d + 2], out)


@kernel
def zonal_rhs(t, y, force, zonal, dy):
    """The derivative dy = (v, a) with the two-body and zonal-harmonic terms and, when switched
    on, the post-Newtonian correction (:mod:`visviva.core.relativity`) alone: the first terms
    of :func:`cowell_rhs`, same bits. Returns nothing; writes ``dy`` (not ``y``).

    The accelerations are summed in ``dy[3:]`` itself: no array is allocated, so neither this
    kernel nor the integrator above it compiles numba's ``np.zeros``/``np.empty`` (a cost paid
    in every process with an empty cache).
    """
    for i in range(3):
        dy[i] = y[3 + i]
        dy[3 + i] = 0.0
    acc = dy[3:]
    accel_two_body(y[0], y[1], y[2], force[fb.GM], acc)
    n_max = int(force[fb.ZONAL_DEGREE])
    if n_max >= 2 or force[fb.RELATIVITY_ON] != 0.0:
        px, py = body_pole(t, force)
        if n_max >= 2:
            accel_zonal(y[0], y[1], y[2], force[fb.GM], force[fb.RADIUS], zonal, n_max, px, py,
                        acc)  # fmt: skip
        if force[fb.RELATIVITY_ON] != 0.0:
            accel_relativity(y[0], y[1], y[2], y[3], y[4], y[5], force[fb.GM],
                             force[fb.LENSE_THIRRING_J], px, py, acc)


@inline_kernel
def sun_and_mass_scale(t, force, eph_r, eph_v, sun_pos):
    """The Sun's ephemeris row in ``force`` (-1 without one), its position at ``t`` s written to
    ``sun_pos`` (km), and the factor m(0) / m(t) by which drag's and SRP's area-to-mass follow
    the mass during a finite burn (1 without thrust): the preamble of the acceleration, of its
    partials and of the coefficients' accelerations."""
    sun = int(force[fb.SUN_ROW])
    if sun >= 0:
        hermite_position(t, sun, force, eph_r, eph_v, sun_pos)
    mass_scale = 1.0
    if force[fb.THRUST_ON] != 0.0:
        mass_scale = 1.0 / (1.0 - force[fb.THRUST_MASS_RATE] * t)
    return sun, mass_scale


@kernel
def drag_density(t, x, yy, z, px, py, sun, sun_pos, force, atm):
    """The density of the block's drag model at (x, yy, z) (km) at ``t`` s, the body's pole
    then (px, py) (:func:`body_pole`; the geodetic altitude about it), kg/m^3: the gridded model
    (NRLMSIS, the Sun at ``sun_pos``, its row ``sun``) or the exponential table, whose band
    is the one held by the integrator for a step (``DENSITY_BAND`` = band + 1), else (0) the
    one of the altitude."""
    if force[fb.DENSITY_MODEL] == 1.0 and sun >= 0:
        return grid_density_at(t, x, yy, z, sun_pos, force, atm)
    h = geodetic_altitude(x, yy, z, force[fb.ELLIPSOID_RADIUS], force[fb.FLATTENING], px, py)
    band = int(force[fb.DENSITY_BAND]) - 1
    if band < 0:
        band = exponential_band(h, atm)
    return band_density(h, atm, band)


@kernel
def cowell_rhs(t, y, force, zonal, atm, eph_r, eph_v, eph_gm, sh, dy):
    """The full derivative dy = (v, a) of the state y = (r, v) at time t (s from the epoch).

    Sums, in this fixed order: two-body, zonal harmonics and relativity (:func:`zonal_rhs`),
    full spherical harmonics, drag, third bodies, SRP, thrust. During a finite burn drag's and
    SRP's area-to-mass ratios follow the falling mass (divided by 1 - ``THRUST_MASS_RATE`` t);
    otherwise they are the block's (multiplied by exactly 1.0: the same bits).
    """
    x = y[0]
    yy = y[1]
    z = y[2]
    zonal_rhs(t, y, force, zonal, dy)
    acc = dy[3:]  # the sum goes on in dy itself (no array allocated per evaluation)
    if force[fb.HARMONICS_DEGREE] >= 2.0:
        accel_harmonics_inertial(t, x, yy, z, force, sh, acc)
    n_third = int(force[fb.N_THIRD_BODIES])
    pos = np.empty(3)
    sun_pos = np.empty(3)
    # drag's and SRP's area-to-mass follow the mass during a finite burn: m(0) / m(t)
    sun, mass_scale = sun_and_mass_scale(t, force, eph_r, eph_v, sun_pos)
    if force[fb.DRAG_ON] != 0.0:
        px, py = body_pole(t, force)
        rho = drag_density(t, x, yy, z, px, py, sun, sun_pos, force, atm)
        accel_drag_rho(x, yy, z, y[3], y[4], y[5], rho, force[fb.BALLISTIC] * mass_scale,
                       force[fb.ROTATION_RATE], px, py, acc)
    for b in range(n_third):
        if b == sun:
            accel_third_body(x, yy, z, sun_pos[0], sun_pos[1], sun_pos[2], eph_gm[b], acc)
        else:
            hermite_position(t, b, force, eph_r, eph_v, pos)
            accel_third_body(x, yy, z, pos[0], pos[1], pos[2], eph_gm[b], acc)
    if force[fb.SRP_ON] != 0.0 and sun >= 0:
        nu = shadow_fraction(
            x, yy, z, sun_pos[0], sun_pos[1], sun_pos[2], force[fb.RADIUS], force[fb.SUN_RADIUS], int(force[fb.SHADOW_MODEL])
        )
        accel_srp(x, yy, z, sun_pos[0], sun_pos[1], sun_pos[2], force[fb.SRP_COEFFICIENT] * mass_scale, force[fb.AU], nu, acc)
    if force[fb.THRUST_ON] != 0.0:
        accel_thrust(t, y, force, pos)
        for i in range(3):
            acc[i] += pos[i]


@kernel
def cowell_rhs_array(t, y, force, zonal, atm, eph_r, eph_v, eph_gm, sh):
    """Derivatives for many (t, y) pairs: t (N,), y (N, 6) -> (N, 6). For tests and plots."""
    out = np.empty_like(y)
    for i in range(y.shape[0]):
        cowell_rhs(t[i], y[i], force, zonal, atm, eph_r, eph_v, eph_gm, sh, out[i])
    return out
