"""Partial derivatives of Cowell's accelerations with respect to position and velocity.

:func:`acceleration_partials` gives da/dr and da/dv of
:func:`visviva.core.perturbations.cowell_rhs`, evaluated analytically (Montenbruck & Gill 2000,
sec. 7.2, eqs. 7.42-7.45; Vallado 2013, sec. 10.4), for the variational equations of
:mod:`visviva.core.variational`.

Partials included, each exact for its force term:

* two-body: da/dr = -GM/r^3 (I - 3 r r^T / r^2);
* zonal harmonics J_2 .. J_n: the Hessian of the zonal potential of any degree
  (:func:`_add_zonal_gradient`); a full spherical-harmonic field (tesseral terms, the body
  frame's orientation): the Hessian of its potential from Cunningham's recursions
  (:func:`_add_harmonics_gradient`; before, its zonal part alone, which left the covariance
  of a LEO day with a degree-4 field 1 % off);
* drag: da/dv = -rho B/2 (|w| I + w w^T/|w|), w = v - omega x r, and da/dr from the
  co-rotation and from the gradient of the density: d ln rho / dh = -1/H along the geodetic
  altitude (exponential table), or central differences of 1 m of the gridded ln rho along
  x, y, z (NRLMSIS grid: altitude, latitude and hour angle from the Sun);
* third bodies: da/dr = GM_b (3 d d^T / d^5 - I / d^3), d = r_b - r;
* SRP (cannonball): da/dr = k nu (I/d^3 - 3 d d^T/d^5), plus in the conical shadow's penumbra
  the change of the visible fraction nu of the Sun, k d grad(nu)^T / d^3
  (:func:`_add_penumbra_gradient`); the cylindrical shadow's jump enters at its boundary as a
  saltation matrix (:func:`_boundary_jump`);
* the post-Newtonian Schwarzschild and Lense-Thirring terms
  (:func:`visviva.core.relativity.add_relativity_partials`);
* a finite burn's thrust on a local frame's axes (RTN, TNW, VNB): a(t) d(M^T u)/d(r, v)
  (:func:`_add_thrust_gradient`); drag's and SRP's partials follow the falling mass as their
  accelerations do.
"""

from __future__ import annotations

import math

import numpy as np

from . import force_block as fb
from ._jit import inline_kernel, kernel
from .geodetic import body_fixed_matrix, body_pole, geodetic
from .local_frames import to_inertial_jacobian
from .perturbations import (
    accel_drag_rho,
    accel_srp,
    band_density,
    cunningham_vw,
    drag_density,
    exponential_band,
    grid_log_density_gradient_at,
    hermite_position,
    shadow_fraction,
    sun_and_mass_scale,
)
from .relativity import add_relativity_partials
from .zonal import pole_sine

__all__ = ["acceleration_partials", "parameter_accelerations", "N_PARAMETERS"]

#: solve-for parameters of the variational equations: d a / d force[BALLISTIC], then
#: d a / d force[SRP_COEFFICIENT] (:func:`parameter_accelerations`)
N_PARAMETERS = 2


@kernel
def _add_point_mass_gradient(dx, dy, dz, k, G):
    """G += k (3 d d^T / |d|^5 - I / |d|^3), which is -k times the gradient of d / |d|^3.

    The tidal (gravity-gradient) matrix of a point mass: with k = GM and d the vector from
    the mass, it is the gradient of the attraction -GM d / |d|^3.
    """
    d2 = dx * dx + dy * dy + dz * dz
    d = math.sqrt(d2)
    inv3 = 1.0 / (d2 * d)
    inv5 = 3.0 * inv3 / d2
    dv = (dx, dy, dz)
    for i in range(3):
        for j in range(3):
            G[i, j] += k * inv5 * dv[i] * dv[j]
        G[i, i] -= k * inv3


@kernel
def _add_zonal_gradient(x, y, z, gm, radius, zonal, n_max, px, py, G):
    """G += d a_zonal / d r for the zonal terms J_2 .. J_n_max (``zonal[n]`` = J_n) about the
    pole p = (px, py, sqrt(1 - px^2 - py^2)) ((0, 0): the frame's z axis).

    With s = r_hat . p, c_n = J_n R^n, alpha_n = (n+1) P_n + s P_n', the acceleration of
    :func:`visviva.core.perturbations.accel_zonal` is a = GM [A r / r^3 - B p / r^2] with
    A = sum c_n r^-n alpha_n(s), B = sum c_n r^-n P_n'(s). Its gradient is

        GM [r (f_r r_hat + f_s grad s)^T + f I - p (g_r r_hat + g_s grad s)^T],

    f = A/r^3, g = B/r^2, grad s = (p - s r_hat)/r, with the radial and s-derivatives
    from the Legendre recursions P_n'' = (n+1) P_{n-1}' + s P_{n-1}''.
    """
    r2, r, pz, s = pole_sine(x, y, z, px, py)
    p_nm2 = 1.0
    p_nm1 = s
    dp_nm1 = 1.0
    ddp_nm1 = 0.0
    ratio = radius / r
    rn = ratio
    A = 0.0
    A_r = 0.0
    A_s = 0.0
    B = 0.0
    B_r = 0.0
    B_s = 0.0
    for n in range(2, n_max + 1):
        p_n = ((2 * n - 1) * s * p_nm1 - (n - 1) * p_nm2) / n
        dp_n = n * p_nm1 + s * dp_nm1
        ddp_n = (n + 1) * dp_nm1 + s * ddp_nm1
        rn *= ratio
        jn = zonal[n]
        if jn != 0.0:
            c = jn * rn  # J_n (R/r)^n
            alpha = (n + 1) * p_n + s * dp_n
            A += c * alpha
            A_r -= n * c * alpha / r
            A_s += c * ((n + 2) * dp_n + s * ddp_n)
            B += c * dp_n
            B_r -= n * c * dp_n / r
            B_s += c * ddp_n
        p_nm2, p_nm1 = p_nm1, p_n
        dp_nm1 = dp_n
        ddp_nm1 = ddp_n
    r3 = r2 * r
    f = A / r3
    f_r = A_r / r3 - 3.0 * A / (r3 * r)
    f_s = A_s / r3
    g_r = B_r / r2 - 2.0 * B / r3
    g_s = B_s / r2
    pos = (x, y, z)
    pole = (px, py, pz)
    for j in range(3):
        rhat_j = pos[j] / r
        grad_s_j = (pole[j] - s * rhat_j) / r
        df_j = f_r * rhat_j + f_s * grad_s_j
        dg_j = g_r * rhat_j + g_s * grad_s_j
        for i in range(3):
            G[i, j] += gm * pos[i] * df_j
        G[j, j] += gm * f
        for i in range(3):
            if pole[i] != 0.0:
                G[i, j] -= gm * pole[i] * dg_j


@kernel
def acceleration_partials(t, y, force, zonal, atm, eph_r, eph_v, eph_gm, sh, dadr, dadv):
    """Write the partial derivatives of the Cowell acceleration into ``dadr``, ``dadv`` (3, 3).

    Parameters
    ----------
    t : float
        Time from the epoch, s.
    y : ndarray (6,)
        Position (km) and velocity (km/s).
    force, zonal, atm, eph_r, eph_v, eph_gm, sh : ndarray
        The force model of :mod:`visviva.core.perturbations`.
    dadr : ndarray (3, 3)
        Output: d a / d r, 1/s^2.
    dadv : ndarray (3, 3)
        Output: d a / d v, 1/s.
    """
    x = y[0]
    yy = y[1]
    z = y[2]
    for i in range(3):
        for j in range(3):
            dadr[i, j] = 0.0
            dadv[i, j] = 0.0
    gm = force[fb.GM]
    # two-body: the gradient of -gm r / r^3 is gm (3 r r^T / r^5 - I / r^3)
    _add_point_mass_gradient(x, yy, z, gm, dadr)
    px, py = body_pole(t, force)  # the body's pole: zonal field, atmosphere, spin
    pz = math.sqrt(1.0 - px * px - py * py)
    if int(force[fb.ZONAL_DEGREE]) >= 2:
        _add_zonal_gradient(x, yy, z, gm, force[fb.RADIUS], zonal, int(force[fb.ZONAL_DEGREE]),
                            px, py, dadr)
    elif force[fb.HARMONICS_DEGREE] >= 2.0:
        _add_harmonics_gradient(t, x, yy, z, force, sh, dadr)
    sun_pos = np.empty(3)
    pos = np.empty(3)
    # drag's and SRP's area-to-mass follow the mass during a finite burn (as cowell_rhs)
    sun, mass_scale = sun_and_mass_scale(t, force, eph_r, eph_v, sun_pos)
    if force[fb.DRAG_ON] != 0.0:
        omega = force[fb.ROTATION_RATE]
        bc = force[fb.BALLISTIC] * mass_scale
        # v_rel = v - omega p x r
        wx = y[3] - omega * (py * z - pz * yy)
        wy = y[4] - omega * (pz * x - px * z)
        wz = y[5] - omega * (px * yy - py * x)
        w = math.sqrt(wx * wx + wy * wy + wz * wz)
        grad = np.empty(3)  # d ln(rho) / d r, 1/km
        if force[fb.DENSITY_MODEL] == 1.0 and sun >= 0:
            # the gridded ln(rho) is a tricubic B-spline: its analytic gradient along all three
            # of altitude, latitude and hour angle
            rho = math.exp(grid_log_density_gradient_at(t, x, yy, z, sun_pos, force, atm,
                                                        grad))  # fmt: skip
        else:
            h, s, cl, zp, rh, _ = geodetic(x, yy, z, force[fb.ELLIPSOID_RADIUS], force[fb.FLATTENING],
                                           px, py)  # fmt: skip
            k = int(force[fb.DENSITY_BAND]) - 1  # the band held in a step, as cowell_rhs
            if k < 0:
                k = exponential_band(h, atm)
            rho = band_density(h, atm, k)
            dlnrho_dh = -1.0 / atm[k, 2]
            # d h / d r: the ellipsoid's normal cos(lat) rho_hat + sin(lat) p
            posv = (x, yy, z)
            pole = (px, py, pz)
            for j in range(3):
                rj = (posv[j] - zp * pole[j]) / rh if rh > 0.0 else 0.0
                grad[j] = dlnrho_dh * (cl * rj + s * pole[j])
        rho_km = rho * 1e9
        c = -0.5 * rho_km * bc
        wv = (wx, wy, wz)
        for i in range(3):
            for j in range(3):
                dadv[i, j] += c * wv[i] * wv[j] / w
            dadv[i, i] += c * w
        # d w / d r = -omega [p]x = omega [[0, pz, -py], [-pz, 0, px], [py, -px, 0]]
        for i in range(3):
            dadr[i, 0] += omega * (-pz * dadv[i, 1] + py * dadv[i, 2])
            dadr[i, 1] += omega * (pz * dadv[i, 0] - px * dadv[i, 2])
            dadr[i, 2] += omega * (-py * dadv[i, 0] + px * dadv[i, 1])
        for j in range(3):
            for i in range(3):
                dadr[i, j] += c * w * wv[i] * grad[j]
    n_third = int(force[fb.N_THIRD_BODIES])
    for b in range(n_third):
        if b == sun:
            bx, by, bz = sun_pos[0], sun_pos[1], sun_pos[2]
        else:
            hermite_position(t, b, force, eph_r, eph_v, pos)
            bx, by, bz = pos[0], pos[1], pos[2]
        # a = gm_b (d / |d|^3 - ...), d = r_b - r: d a / d r = -gm_b grad_d (d / |d|^3)
        # = gm_b (3 d d^T / d^5 - I / d^3)
        _add_point_mass_gradient(bx - x, by - yy, bz - z, eph_gm[b], dadr)
    if force[fb.SRP_ON] != 0.0 and sun >= 0:
        from_sun_x = x - sun_pos[0]
        from_sun_y = yy - sun_pos[1]
        from_sun_z = z - sun_pos[2]
        # the shadow fraction of this point, held fixed
        nu = shadow_fraction(
            x, yy, z, sun_pos[0], sun_pos[1], sun_pos[2], force[fb.RADIUS], force[fb.SUN_RADIUS], int(force[fb.SHADOW_MODEL])
        )
        if nu > 0.0:
            k = nu * force[fb.SRP_COEFFICIENT] * mass_scale * force[fb.AU] * force[fb.AU]
            # a = k d / |d|^3 with d = r - r_sun: d a / d r = k (I/d^3 - 3 d d^T/d^5)
            _add_point_mass_gradient(from_sun_x, from_sun_y, from_sun_z, -k, dadr)
        if 0.0 < nu < 1.0 and int(force[fb.SHADOW_MODEL]) == 2:
            _add_penumbra_gradient(x, yy, z, from_sun_x, from_sun_y, from_sun_z, sun_pos,
                                   force, dadr)  # fmt: skip
    if force[fb.THRUST_ON] != 0.0 and int(force[fb.THRUST_FRAME]) != 0:
        _add_thrust_gradient(t, y, force, dadr, dadv)
    if force[fb.RELATIVITY_ON] != 0.0:
        add_relativity_partials(x, yy, z, y[3], y[4], y[5], gm, force[fb.LENSE_THIRRING_J], px, py,
                                dadr, dadv)


@kernel
def parameter_accelerations(t, y, force, atm, eph_r, eph_v, out):
    """Write the partials of the Cowell acceleration on the force block's drag and SRP
    coefficients into ``out`` (at least (2, 3)).

    ``out[0]`` = d a / d ``force[BALLISTIC]`` (Cd A / m, km^2/kg), the drag acceleration of a
    unit ballistic coefficient, 1/s^2 x kg/km; ``out[1]`` = d a / d ``force[SRP_COEFFICIENT]``
    (P(1 AU) Cr A / m, km/s^2), the SRP acceleration of a unit coefficient (dimensionless).
    Both accelerations are linear in their coefficient, so these are exact, also where the
    coefficient is zero; each is zero when its force is off. The density, the held band, the
    shadow and the mass scale of a finite burn are those of
    :func:`visviva.core.perturbations.cowell_rhs`.
    """
    x = y[0]
    yy = y[1]
    z = y[2]
    for i in range(3):
        out[0, i] = 0.0
        out[1, i] = 0.0
    sun_pos = np.zeros(3)
    sun, mass_scale = sun_and_mass_scale(t, force, eph_r, eph_v, sun_pos)
    if force[fb.DRAG_ON] != 0.0:
        px, py = body_pole(t, force)
        rho = drag_density(t, x, yy, z, px, py, sun, sun_pos, force, atm)
        accel_drag_rho(x, yy, z, y[3], y[4], y[5], rho, mass_scale, force[fb.ROTATION_RATE], px, py,
                       out[0])  # fmt: skip
    if force[fb.SRP_ON] != 0.0 and sun >= 0:
        nu = shadow_fraction(x, yy, z, sun_pos[0], sun_pos[1], sun_pos[2], force[fb.RADIUS],
                             force[fb.SUN_RADIUS], int(force[fb.SHADOW_MODEL]))  # fmt: skip
        accel_srp(x, yy, z, sun_pos[0], sun_pos[1], sun_pos[2], mass_scale, force[fb.AU], nu,
                  out[1])  # fmt: skip


@kernel
def _add_thrust_gradient(t, y, force, dadr, dadv):
    """dadr, dadv += the partials of a finite burn's thrust held on a local frame's axes:
    a(t) d(M^T u) / d(r, v) (:func:`visviva.core.local_frames.to_inertial_jacobian`); its
    magnitude a(t) = F / m(t) depends on time alone."""
    a = force[fb.THRUST_ACCEL] / (1.0 - force[fb.THRUST_MASS_RATE] * t)
    d = fb.THRUST_DIRECTION
    jac = np.empty((3, 6))
    to_inertial_jacobian(int(force[fb.THRUST_FRAME]), y, a * force[d], a * force[d + 1],
                         a * force[d + 2], jac)
    for i in range(3):
        for j in range(3):
            dadr[i, j] += jac[i, j]
            dadv[i, j] += jac[i, 3 + j]


@kernel
def _add_harmonics_gradient(t, x, yy, z, force, sh, G):
    """G += d a_field / d r of a full spherical-harmonic field (every degree and order, in its
    body frame at time t): the Hessian of its potential, analytically from Cunningham's V_nm,
    W_nm to degree n_max + 2, rotated to the inertial axes, H_in = M^T H_bf M.

    The acceleration sums of :func:`visviva.core.perturbations.accel_harmonics` are the
    derivative rules d/dz (a V_nm + b W_nm) = -(n - m + 1) (a V_n+1,m + b W_n+1,m) and, with
    f = (n - m + 2)(n - m + 1), d/dx = 1/2 [-(a V + b W)_n+1,m+1 + f (a V + b W)_n+1,m-1],
    d/dy = 1/2 [(b V - a W)_n+1,m+1 + f (b V - a W)_n+1,m-1] (lengths in units of R;
    Montenbruck & Gill 2000, eqs. 3.33, 7.40); applied twice they give the Hessian. An order
    -1 is folded into order 1: V_N,-1 = -V_N,1 / (N (N + 1)), W_N,-1 = W_N,1 / (N (N + 1)).
    """
    M = np.empty((3, 3))  # r_bf = M r
    body_fixed_matrix(t, force, M)
    bx = M[0, 0] * x + M[0, 1] * yy + M[0, 2] * z
    by = M[1, 0] * x + M[1, 1] * yy + M[1, 2] * z
    bz = M[2, 0] * x + M[2, 1] * yy + M[2, 2] * z
    n_max = int(force[fb.HARMONICS_DEGREE])
    radius = force[fb.RADIUS]
    V, W = cunningham_vw(bx, by, bz, radius, n_max + 3)
    H = np.zeros((3, 3))  # lower triangle, body frame
    for n in range(2, n_max + 1):
        for m in range(n + 1):
            C = sh[0, n, m]
            S = sh[1, n, m]
            if C == 0.0 and S == 0.0:
                continue
            # column b: d/db gives two terms of degree n + 1 (one for z), each differentiated
            # again along a >= b (the same additions into H[a, b], in the same order, as term
            # by term); unrolled so that every axis is a constant in the inlined helpers
            _, ka, ca, wa, kb, cb, wb = _derive(0, n, m, C, S)
            _add_derivative(0, n + 1, ka, ca, wa, V, W, H, 0)
            _add_derivative(1, n + 1, ka, ca, wa, V, W, H, 0)
            _add_derivative(2, n + 1, ka, ca, wa, V, W, H, 0)
            _add_derivative(0, n + 1, kb, cb, wb, V, W, H, 0)
            _add_derivative(1, n + 1, kb, cb, wb, V, W, H, 0)
            _add_derivative(2, n + 1, kb, cb, wb, V, W, H, 0)
            _, ka, ca, wa, kb, cb, wb = _derive(1, n, m, C, S)
            _add_derivative(1, n + 1, ka, ca, wa, V, W, H, 1)
            _add_derivative(2, n + 1, ka, ca, wa, V, W, H, 1)
            _add_derivative(1, n + 1, kb, cb, wb, V, W, H, 1)
            _add_derivative(2, n + 1, kb, cb, wb, V, W, H, 1)
            _, ka, ca, wa, _, _, _ = _derive(2, n, m, C, S)
            _add_derivative(2, n + 1, ka, ca, wa, V, W, H, 2)
    k = force[fb.GM] / (radius * radius * radius)
    for a in range(3):
        for b in range(a):
            H[b, a] = H[a, b]
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for p in range(3):
                for q in range(3):
                    acc += M[p, i] * H[p, q] * M[q, j]
            G[i, j] += k * acc


@inline_kernel
def _derive(axis, n, m, a, b):
    """d/d(axis) (x, y, z = 0, 1, 2) of a V_nm + b W_nm (m >= 0, lengths in units of R): terms
    (order k, c V + w W) of degree n + 1, as (count, k0, c0, w0, k1, c1, w1) (count 1 or 2;
    the second term is zero when count is 1)."""
    if axis == 2:
        g = -(n - m + 1.0)
        return 1, m, g * a, g * b, 0, 0.0, 0.0
    f = (n - m + 2.0) * (n - m + 1.0)
    if axis == 0:
        c0 = -0.5 * a
        w0 = -0.5 * b
        cv = 0.5 * f * a
        cw = 0.5 * f * b
    else:
        c0 = 0.5 * b
        w0 = -0.5 * a
        cv = 0.5 * f * b
        cw = -0.5 * f * a
    if m >= 1:
        return 2, m + 1, c0, w0, m - 1, cv, cw
    # order -1 of degree N = n + 1, folded into order 1
    fold = 1.0 / ((n + 1.0) * (n + 2.0))
    return 2, m + 1, c0, w0, 1, -fold * cv, fold * cw


@inline_kernel
def _add_derivative(axis, n, m, a, b, V, W, H, col):
    """H[axis, col] += d/d(axis) (a V_nm + b W_nm), from V, W of degree n + 1."""
    count, k0, c0, w0, k1, c1, w1 = _derive(axis, n, m, a, b)
    H[axis, col] += c0 * V[n + 1, k0] + w0 * W[n + 1, k0]
    if count == 2:
        H[axis, col] += c1 * V[n + 1, k1] + w1 * W[n + 1, k1]


@kernel
def _add_penumbra_gradient(x, yy, z, dx, dy, dz, sun_pos, force, G):
    """G += (a_srp / nu) grad(nu)^T in the conical shadow's penumbra: the change of the visible
    fraction nu of the Sun with position (d = r - r_sun = (dx, dy, dz)), by central differences
    of 1e-3 km (nu changes over the penumbra's width, >= 20 km in low orbit; it varies like
    depth^1.5 near its edges, so the differences are good to ~1e-6 of the gradient there)."""
    d2 = dx * dx + dy * dy + dz * dz
    k = force[fb.SRP_COEFFICIENT] * force[fb.AU] * force[fb.AU] / (d2 * math.sqrt(d2))
    step = 1e-3
    radius = force[fb.RADIUS]
    sun_radius = force[fb.SUN_RADIUS]
    dv = (dx, dy, dz)
    for j in range(3):
        ex = step if j == 0 else 0.0
        ey = step if j == 1 else 0.0
        ez = step if j == 2 else 0.0
        up = shadow_fraction(x + ex, yy + ey, z + ez, sun_pos[0], sun_pos[1], sun_pos[2],
                             radius, sun_radius, 2)  # fmt: skip
        down = shadow_fraction(x - ex, yy - ey, z - ez, sun_pos[0], sun_pos[1], sun_pos[2],
                               radius, sun_radius, 2)  # fmt: skip
        dnu = (up - down) / (2.0 * step)
        for i in range(3):
            G[i, j] += k * dv[i] * dnu
