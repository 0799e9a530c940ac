"""State and state-transition matrix of Cowell's force model, by the variational equations.

The state y = (r, v) and its state-transition matrix Phi(t, t0) = d y(t) / d y(t0) are
integrated together (42 components):

    y' = f(t, y),    Phi' = F(t, y) Phi,    Phi(t0) = I,

with F = [[0, I], [da/dr, da/dv]] the Jacobian of the right-hand side
:func:`visviva.core.perturbations.cowell_rhs`, evaluated analytically
(:func:`acceleration_partials`; Montenbruck & Gill 2000, sec. 7.2, eqs. 7.42-7.45;
Vallado 2013, sec. 10.4). The force model is the same flat parameter block that
:func:`visviva.core.cowell.integrate_cowell` reads (see :mod:`visviva.core.perturbations`), so
the trajectory is the one ``propagate_cowell`` computes, to the integration tolerance.

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
  saltation matrix (:func:`_boundary_jump`).

Integration is DOP853 (the tableau of :mod:`visviva.core.cowell`) with the step-size control
on the six state components only; each step is shortened to land on the next output time, so
the STM at every output is that of the integrated trajectory. With SRP and a shadow model the
steps also end at the shadow's boundaries, as in :func:`visviva.core.cowell.integrate_cowell`
(:mod:`visviva.core.cowell_events`, "Shadow boundaries"; the boundaries are found on the dense
output of the state, from three extra stages of the state alone), so both integrators follow
the same trajectory to their tolerances; runs without a shadow take the same steps, with the
same bits, as before this handling.
"""

from __future__ import annotations

import math

import numpy as np

from . import force_block as fb
from . import status as st
from ._jit import kernel
from .cowell import dense_coefficients, rk_combine
from .cowell_events import (
    BOUNDARY_RTOL,
    boundary_gradient,
    boundary_plan,
    lock_shadow,
    penumbra_step,
    shadow_crossing,
    shadow_sides,
    srp_shadow_model,
)
from .drag_bands import altitude_gradient, band_crossing, bands_on, hold_band, start_band
from .perturbations import (
    band_density,
    cowell_rhs,
    cunningham_vw,
    exponential_band,
    geodetic_altitude,
    grid_density_at,
    hermite_position,
    shadow_fraction,
)

__all__ = ["acceleration_partials", "variational_rhs", "integrate_variational", "N_VAR"]

#: components of the augmented state: 6 (r, v) + 36 (Phi, row-major)
N_VAR = 42
_SAFETY = 0.9
_MIN_FACTOR = 0.2
_MAX_FACTOR = 10.0
_N_STAGES = 12
#: Step of the central differences of the gridded density (NRLMSIS), km.
_DENSITY_STEP_KM = 1e-3


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
def _add_zonal_gradient(x, y, z, gm, radius, zonal, n_max, G):
    """G += d a_zonal / d r for the zonal terms J_2 .. J_n_max (``zonal[n]`` = J_n).

    With s = z/r, c_n = J_n R^n, alpha_n = (n+1) P_n + s P_n', the acceleration of
    :func:`visviva.core.perturbations.accel_zonal` is a = GM [A r / r^3 - B z_hat / r^2] with
    A = sum c_n r^-n alpha_n(s), B = sum c_n r^-n P_n'(s). Its gradient is

        GM [r (f_r r_hat + f_s grad s)^T + f I - z_hat (g_r r_hat + g_s grad s)^T],

    f = A/r^3, g = B/r^2, grad s = (z_hat - s r_hat)/r, with the radial and s-derivatives
    from the Legendre recursions P_n'' = (n+1) P_{n-1}' + s P_{n-1}''.
    """
    r2 = x * x + y * y + z * z
    r = math.sqrt(r2)
    s = z / r
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
    for j in range(3):
        rhat_j = pos[j] / r
        grad_s_j = ((1.0 if j == 2 else 0.0) - s * rhat_j) / r
        df_j = f_r * rhat_j + f_s * grad_s_j
        dg_j = g_r * rhat_j + g_s * grad_s_j
        for i in range(3):
            G[i, j] += gm * pos[i] * df_j
        G[j, j] += gm * f
        G[2, j] -= gm * dg_j


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
    if int(force[fb.ZONAL_DEGREE]) >= 2:
        _add_zonal_gradient(x, yy, z, gm, force[fb.RADIUS], zonal, int(force[fb.ZONAL_DEGREE]), dadr)
    elif force[fb.HARMONICS_DEGREE] >= 2.0:
        _add_harmonics_gradient(t, x, yy, z, force, sh, dadr)
    sun = int(force[fb.SUN_ROW])
    sun_pos = np.empty(3)
    pos = np.empty(3)
    if sun >= 0:
        hermite_position(t, sun, force, eph_r, eph_v, sun_pos)
    if force[fb.DRAG_ON] != 0.0:
        omega = force[fb.ROTATION_RATE]
        bc = force[fb.BALLISTIC]
        wx = y[3] + omega * yy
        wy = y[4] - omega * x
        wz = y[5]
        w = math.sqrt(wx * wx + wy * wy + wz * wz)
        grad = np.empty(3)  # d ln(rho) / d r, 1/km
        if force[fb.DENSITY_MODEL] == 1.0 and sun >= 0:
            # the gridded ln(rho) is trilinear in (altitude, latitude, hour angle) in each
            # cell: central differences of 1 m give its gradient along all three (before:
            # the altitude slope alone, 0.2 % off in the covariance of a LEO day)
            rho = grid_density_at(x, yy, z, sun_pos, force, atm)
            for j in range(3):
                pos[0] = x
                pos[1] = yy
                pos[2] = z
                pos[j] += _DENSITY_STEP_KM
                up = grid_density_at(pos[0], pos[1], pos[2], sun_pos, force, atm)
                pos[j] -= 2.0 * _DENSITY_STEP_KM
                down = grid_density_at(pos[0], pos[1], pos[2], sun_pos, force, atm)
                grad[j] = (math.log(up) - math.log(down)) / (2.0 * _DENSITY_STEP_KM)
        else:
            h = geodetic_altitude(x, yy, z, force[fb.RADIUS], force[fb.FLATTENING])
            r = math.sqrt(x * x + yy * yy + z * z)
            k = int(force[fb.DENSITY_BAND]) - 1  # the band held in a step, as cowell_rhs
            if k < 0:
                k = exponential_band(h, atm)
            rho = band_density(h, atm, k)
            dlnrho_dh = -1.0 / atm[k, 2]
            # d h / d r = r_hat + R f d(s^2)/d r, s = z / r
            s = z / r
            fr = force[fb.RADIUS] * force[fb.FLATTENING]
            posv = (x, yy, z)
            for j in range(3):
                dh = posv[j] / r + fr * 2.0 * s * (-s * posv[j] / r) / r
                if j == 2:
                    dh += fr * 2.0 * s / r
                grad[j] = dlnrho_dh * dh
        rho_km = rho * 1e9
        c = -0.5 * rho_km * bc
        wv = (wx, wy, wz)
        for i in range(3):
            for j in range(3):
                dadv[i, j] += c * wv[i] * wv[j] / w
            dadv[i, i] += c * w
        # d w / d r = [[0, omega, 0], [-omega, 0, 0], [0, 0, 0]]
        for i in range(3):
            dadr[i, 0] += dadv[i, 1] * (-omega)
            dadr[i, 1] += dadv[i, 0] * omega
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
            k = nu * force[fb.SRP_COEFFICIENT] * force[fb.AU] * force[fb.AU]
            # a = k d / |d|^3 with d = r - r_sun: d a / d r = k (I/d^3 - 3 d d^T/d^5)
            _add_point_mass_gradient(from_sun_x, from_sun_y, from_sun_z, -k, dadr)
        if 0.0 < nu < 1.0 and int(force[fb.SHADOW_MODEL]) == 2:
            _add_penumbra_gradient(x, yy, z, from_sun_x, from_sun_y, from_sun_z, sun_pos,
                                   force, dadr)  # fmt: skip


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
    th = force[fb.ROTATION_RATE] * t
    c = math.cos(th)
    s = math.sin(th)
    m0 = force[fb.FRAME_MATRIX:fb.FRAME_MATRIX + 9]
    M = np.empty((3, 3))  # r_bf = M r, M = Rz(th) M0
    for j in range(3):
        M[0, j] = c * m0[j] + s * m0[3 + j]
        M[1, j] = -s * m0[j] + c * m0[3 + j]
        M[2, j] = m0[6 + j]
    bx = M[0, 0] * x + M[0, 1] * yy + M[0, 2] * z
    by = M[1, 0] * x + M[1, 1] * yy + M[1, 2] * z
    bz = M[2, 0] * x + M[2, 1] * yy + M[2, 2] * z
    n_max = int(force[fb.HARMONICS_DEGREE])
    radius = force[fb.RADIUS]
    V, W = cunningham_vw(bx, by, bz, radius, n_max + 3)
    k1 = np.empty(2, np.int64)
    c1 = np.empty(2)
    w1 = np.empty(2)
    k2 = np.empty(2, np.int64)
    c2 = np.empty(2)
    w2 = np.empty(2)
    H = np.zeros((3, 3))  # lower triangle, body frame
    for n in range(2, n_max + 1):
        for m in range(n + 1):
            C = sh[0, n, m]
            S = sh[1, n, m]
            if C == 0.0 and S == 0.0:
                continue
            for b in range(3):
                n1 = _derive(b, n, m, C, S, k1, c1, w1)
                for i in range(n1):
                    for a in range(b, 3):
                        n2 = _derive(a, n + 1, k1[i], c1[i], w1[i], k2, c2, w2)
                        for j in range(n2):
                            kk = k2[j]
                            H[a, b] += c2[j] * V[n + 2, kk] + w2[j] * W[n + 2, kk]
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


@kernel
def _derive(axis, n, m, a, b, ks, cvs, cws):
    """d/d(axis) (x, y, z = 0, 1, 2) of a V_nm + b W_nm (m >= 0, lengths in units of R): terms
    (order ks[i], cvs[i] V + cws[i] W) of degree n + 1; returns how many (1 or 2)."""
    if axis == 2:
        g = -(n - m + 1.0)
        ks[0] = m
        cvs[0] = g * a
        cws[0] = g * b
        return 1
    f = (n - m + 2.0) * (n - m + 1.0)
    ks[0] = m + 1
    if axis == 0:
        cvs[0] = -0.5 * a
        cws[0] = -0.5 * b
        cv = 0.5 * f * a
        cw = 0.5 * f * b
    else:
        cvs[0] = 0.5 * b
        cws[0] = -0.5 * a
        cv = 0.5 * f * b
        cw = -0.5 * f * a
    if m >= 1:
        ks[1] = m - 1
        cvs[1] = cv
        cws[1] = cw
    else:  # order -1 of degree N = n + 1, folded into order 1
        fold = 1.0 / ((n + 1.0) * (n + 2.0))
        ks[1] = 1
        cvs[1] = -fold * cv
        cws[1] = fold * cw
    return 2


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


@kernel
def variational_rhs(t, y, force, zonal, atm, eph_r, eph_v, eph_gm, sh, dy, dadr, dadv):
    """Derivative of the augmented state (r, v, Phi): 42 components, Phi row-major."""
    cowell_rhs(t, y[:6], force, zonal, atm, eph_r, eph_v, eph_gm, sh, dy[:6])
    acceleration_partials(t, y[:6], force, zonal, atm, eph_r, eph_v, eph_gm, sh, dadr, dadv)
    # Phi' = F Phi with F = [[0, I], [dadr, dadv]]
    for j in range(6):
        for i in range(3):
            dy[6 + i * 6 + j] = y[6 + (i + 3) * 6 + j]
        for i in range(3):
            acc = 0.0
            for m in range(3):
                acc += dadr[i, m] * y[6 + m * 6 + j] + dadv[i, m] * y[6 + (m + 3) * 6 + j]
            dy[6 + (i + 3) * 6 + j] = acc


@kernel
def _boundary_jump(model, which, t, y, a_old, a_new, force, eph_r, eph_v, s, grad):
    """Apply the saltation matrix of a jump of the acceleration from ``a_old`` to ``a_new``
    (km/s^2) at shadow boundary ``which`` (crossed at t, y) to the STM in ``y[6:]``.

    A trajectory started at x0 + dx0 reaches the boundary g = 0 at t + dt, dt = -grad g . dx /
    g_dot, and spends dt longer (or shorter) under the old force: after the boundary its
    deviation is dx + (f_new - f_old) grad g . dx / g_dot. So Phi+ = (I + (f_new - f_old)
    grad g^T / g_dot) Phi- (the saltation matrix; Hiskens & Pai 2000), with g the boundary
    function (:func:`visviva.core.cowell_events.boundary_gradient`, position only) and f the
    derivative of the state, which jumps in its acceleration only."""
    rate = boundary_gradient(model, which, t, y, force, eph_r, eph_v, s, grad)
    _saltation(y, a_old, a_new, grad, rate)


@kernel
def _saltation(y, a_old, a_new, grad, rate):
    """Phi+ = (I + (f_new - f_old) grad g^T / g_dot) Phi- on the STM in ``y[6:]``: the jump of
    the acceleration from ``a_old`` to ``a_new`` at a boundary g = 0 of position gradient
    ``grad`` crossed at the rate ``rate`` (:func:`_boundary_jump`)."""
    if rate == 0.0:
        return
    for j in range(6):
        w = (grad[0] * y[6 + j] + grad[1] * y[12 + j] + grad[2] * y[18 + j]) / rate
        for i in range(3):
            y[6 + (3 + i) * 6 + j] += (a_new[i] - a_old[i]) * w


@kernel
def integrate_variational(y0, t_out, rtol, atol, h_max, max_steps, force, zonal, atm, eph_r,
                          eph_v, eph_gm, sh, A, B, C, E3, E5, D, y_out, phi_out, info):  # fmt: skip
    """Integrate the state and its STM from t = 0 to each of the output times ``t_out``.

    Parameters
    ----------
    y0 : ndarray (6,)
        State at t = 0: position (km), velocity (km/s).
    t_out : ndarray (T,)
        Output times, s, monotonic (all >= 0 increasing, or all <= 0 decreasing).
    rtol, atol : float
        Tolerances of the state's local error (atol in km and km/s).
    h_max : float
        Largest step, s.
    max_steps : int
        Step budget; beyond it the status is ``STEP_TOO_SMALL``.
    force, zonal, atm, eph_r, eph_v, eph_gm, sh : ndarray
        The force model (:mod:`visviva.core.perturbations`).
    A, B, C, E3, E5, D : ndarray
        The DOP853 tableau (``D``: the dense output, used with a shadow only).
    y_out : ndarray (T, 6)
        Output: states at ``t_out``.
    phi_out : ndarray (T, 6, 6)
        Output: Phi(t_out, 0).
    info : ndarray (3,)
        Output: [outputs written, steps (with a shadow, also those redone up to a boundary),
        right-hand-side evaluations].

    Returns
    -------
    int
        ``OK`` or ``STEP_TOO_SMALL``.
    """
    n = N_VAR
    n_out = t_out.shape[0]
    y = np.zeros(n)
    for j in range(6):
        y[j] = y0[j]
        y[6 + j * 6 + j] = 1.0
    K = np.zeros((16, n))
    y_new = np.empty(n)
    y_tmp = np.empty(n)
    f = np.empty(n)
    dadr = np.empty((3, 3))
    dadv = np.empty((3, 3))
    direction = 1.0
    for k in range(n_out):
        if t_out[k] < 0.0:
            direction = -1.0
    t = 0.0
    written = 0
    n_steps = 0
    nfev = 0
    status = st.OK
    # SRP with a shadow: steps end at the shadow boundaries, as in integrate_cowell (see
    # visviva.core.cowell_events, "Shadow boundaries"); side0/side1 +1 outside, -1 inside
    rforce = force
    sh_model = 0
    n_sh = 0
    side0 = 1.0
    side1 = 1.0
    F = np.zeros((7, 6))
    # rows: the dense state, two sample rows, the Sun, a_old, grad, two rows of altitudes
    scr = np.zeros((8, 6))
    if srp_shadow_model(force) > 0:
        sh_model = srp_shadow_model(force)
        n_sh = 1 if sh_model == 1 else 2
        side0, side1 = shadow_sides(sh_model, t, y, force, eph_r, eph_v, scr[3])
        rforce = force.copy()
        lock_shadow(rforce, sh_model, side0)
    # drag in the exponential table: steps end at its band edges (visviva.core.drag_bands)
    band = -1
    if bands_on(force):
        if n_sh == 0:
            rforce = force.copy()
        band = start_band(rforce, y, atm)
    bnd_pending = False
    t_bnd = 0.0
    bnd_which = -1
    h_keep = 0.0
    pen_cap = math.inf
    n_here = 0
    variational_rhs(t, y, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, f, dadr, dadv)
    nfev += 1
    # a first step of 1/200 of the orbital period-ish: |r|/|v| / 20
    rr = math.sqrt(y[0] ** 2 + y[1] ** 2 + y[2] ** 2)
    vv = math.sqrt(y[3] ** 2 + y[4] ** 2 + y[5] ** 2)
    h_abs = min(h_max, 0.05 * rr / max(vv, 1e-12))
    while written < n_out:
        target = t_out[written]
        if direction * (target - t) <= 0.0:
            for j in range(6):
                y_out[written, j] = y[j]
                for m in range(6):
                    phi_out[written, j, m] = y[6 + j * 6 + m]
            written += 1
            continue
        if n_steps >= max_steps:
            status = st.STEP_TOO_SMALL
            break
        min_step = 10.0 * abs(math.nextafter(t, direction * math.inf) - t)
        if n_sh > 0 and side0 < 0.0 and side1 > 0.0 and h_abs > pen_cap > 100.0 * min_step:
            h_abs = pen_cap  # in the penumbra (conical shadow)
        accepted = False
        rejected = False
        h = 0.0
        landing = False
        at_bnd = False
        while not accepted:
            if h_abs < 1e-14 * max(1.0, abs(t)):
                break
            h = min(h_abs, h_max) * direction
            landing = direction * (t + h - target) >= 0.0
            if landing:
                h = target - t
            at_bnd = False
            if bnd_pending and direction * (t + h - t_bnd) > -BOUNDARY_RTOL * abs(h):
                h = t_bnd - t
                at_bnd = True
                landing = t_bnd == target
            for j in range(n):
                K[0, j] = f[j]
            for s in range(1, _N_STAGES):
                rk_combine(n, y, K, A[s], s, h, y_tmp)
                variational_rhs(t + C[s] * h, y_tmp, rforce, zonal, atm, eph_r, eph_v, eph_gm,
                                sh, K[s], dadr, dadv)  # fmt: skip
            rk_combine(n, y, K, B, _N_STAGES, h, y_new)
            variational_rhs(t + h, y_new, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh,
                            K[_N_STAGES], dadr, dadv)  # fmt: skip
            nfev += _N_STAGES
            e5 = 0.0
            e3 = 0.0
            for j in range(6):
                scale = atol + max(abs(y[j]), abs(y_new[j])) * rtol
                a5 = 0.0
                a3 = 0.0
                for m in range(_N_STAGES + 1):
                    a5 += E5[m] * K[m, j]
                    a3 += E3[m] * K[m, j]
                e5 += (a5 / scale) ** 2
                e3 += (a3 / scale) ** 2
            if e5 == 0.0 and e3 == 0.0:
                err = 0.0
            else:
                err = abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * 6)
            if err < 1.0:
                factor = _MAX_FACTOR if err == 0.0 else min(_MAX_FACTOR,
                                                            _SAFETY * err ** (-1.0 / 8.0))
                if rejected:
                    factor = min(1.0, factor)
                if not (landing or at_bnd) or factor < 1.0:
                    h_abs = abs(h) * factor
                accepted = True
            else:
                h_abs = abs(h) * max(_MIN_FACTOR, _SAFETY * err ** (-1.0 / 8.0))
                rejected = True
        if not accepted:
            status = st.STEP_TOO_SMALL
            break
        n_steps += 1
        flip = -1
        resync = False
        if n_sh > 0 or band >= 0:
            bnd_pending = False
            if at_bnd:
                flip = bnd_which
            elif n_here > 2 * n_sh + (2 if band >= 0 else 0):
                resync = True
            else:
                # the state's dense output (its own three extra stages, state only)
                for s in range(_N_STAGES + 1, 16):
                    rk_combine(6, y, K, A[s], s, h, y_tmp)
                    cowell_rhs(t + C[s] * h, y_tmp[:6], rforce, zonal, atm, eph_r, eph_v,
                               eph_gm, sh, K[s, :6])  # fmt: skip
                nfev += 3
                dense_coefficients(6, h, y, y_new, K, D, F)
                ta_b = t
                tb_b = t
                which_b = -1
                if n_sh > 0:
                    ta_b, tb_b, which_b = shadow_crossing(sh_model, n_sh, side0, side1, t, h,
                                                          y[:6], y_new[:6], F, scr[0], scr[1],
                                                          scr[2], scr[3], force, eph_r, eph_v)  # fmt: skip
                if band >= 0:
                    ta_3, tb_3, which_3 = band_crossing(band, atm, t, h, y[:6], y_new[:6], F,
                                                        scr[0], scr[6], scr[7], force, eph_r,
                                                        eph_v)  # fmt: skip
                    if which_3 >= 0 and (which_b < 0 or (tb_3 - tb_b) * h < 0.0):
                        ta_b = ta_3
                        tb_b = tb_3
                        which_b = which_3 + 4  # 4, 5: the band's lower, upper edge
                if which_b >= 0:
                    side_before = side0
                    if which_b >= 4:
                        at_t, _, _, t_bnd, h_keep, h_abs = boundary_plan(
                            ta_b, tb_b, 0, t, h, h_abs, min_step, 1.0, 1.0)
                    else:
                        at_t, side0, side1, t_bnd, h_keep, h_abs = boundary_plan(
                            ta_b, tb_b, which_b, t, h, h_abs, min_step, side0, side1)
                    if at_t:
                        # the boundary is at t: crossed here
                        if which_b >= 4:
                            band += 2 * which_b - 9
                            _cross_band(band, t, y, f, rforce, zonal, atm, eph_r, eph_v, eph_gm,
                                        sh, dadr, dadv, scr)  # fmt: skip
                        else:
                            _cross(sh_model, which_b, t, y, f, rforce, zonal, atm, eph_r, eph_v,
                                   eph_gm, sh, side_before, dadr, dadv, scr)  # fmt: skip
                        nfev += 2
                        n_here += 1
                    else:
                        bnd_pending = True
                        bnd_which = which_b
                    continue
        t_old = t
        if landing:
            t = target
        elif at_bnd:
            t = t_bnd
        else:
            t = t + h
        for j in range(n):
            y[j] = y_new[j]
            f[j] = K[_N_STAGES, j]
        if band >= 0 and (flip >= 4 or resync):
            if flip >= 4:
                band += 2 * flip - 9  # 4: one band down, 5: one up
                _cross_band(band, t, y, f, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, dadr,
                            dadv, scr)  # fmt: skip
                nfev += 2
                if h_keep > h_abs:
                    h_abs = h_keep
            else:
                band = start_band(rforce, y, atm)
                variational_rhs(t, y, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, f, dadr,
                                dadv)  # fmt: skip
                nfev += 1
            if flip >= 4:
                flip = -2  # done: not a shadow boundary
            n_here = 0
        if n_sh > 0:
            if 0 <= flip < 4 or resync:
                if flip >= 0 and sh_model == 2:
                    pen_cap = penumbra_step(scr[1, 0] * side0, scr[2, 0] * side1, flip,
                                            t - t_old, force[fb.SRP_COEFFICIENT],
                                            atol + rtol * math.sqrt(y[3] ** 2 + y[4] ** 2
                                                                    + y[5] ** 2))  # fmt: skip
                if flip >= 0:
                    if sh_model == 1:
                        _cross(sh_model, flip, t, y, f, rforce, zonal, atm, eph_r, eph_v,
                               eph_gm, sh, side0, dadr, dadv, scr)  # fmt: skip
                        nfev += 2
                    if flip == 0:
                        side0 = -side0
                    else:
                        side1 = -side1
                    if h_keep > h_abs:
                        h_abs = h_keep
                else:
                    side0, side1 = shadow_sides(sh_model, t, y, force, eph_r, eph_v, scr[3])
                    if sh_model == 1:
                        lock_shadow(rforce, sh_model, side0)
                        variational_rhs(t, y, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, f,
                                        dadr, dadv)  # fmt: skip
                        nfev += 1
        n_here = 0  # a step was taken
    info[0] = written
    info[1] = n_steps
    info[2] = nfev
    return status


@kernel
def _cross(model, which, t, y, f, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, side0, dadr,
           dadv, scr):  # fmt: skip
    """Cross boundary ``which`` of SRP shadow ``model`` at (t, y) (the state with its STM; the
    side of boundary 0 before the crossing ``side0``): the cylindrical shadow's force jumps, so
    the shadow is locked on the new side, the STM takes the saltation matrix of the jump
    (:func:`_boundary_jump`) and ``f`` the derivative after it. The conical shadow's force is
    continuous: nothing changes (the caller flips the side)."""
    if model != 1:
        return
    for i in range(3):
        scr[4, i] = f[3 + i]
    lock_shadow(rforce, model, -side0)
    variational_rhs(t, y, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, f, dadr, dadv)
    _boundary_jump(model, which, t, y, scr[4, :3], f[3:6], rforce, eph_r, eph_v, scr[3], scr[5])
    variational_rhs(t, y, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, f, dadr, dadv)


@kernel
def _cross_band(band, t, y, f, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, dadr, dadv, scr):
    """Cross into band ``band`` of the exponential atmosphere at (t, y) (the state with its
    STM): the band is held, the density jumps, so the STM takes the saltation matrix of the
    jump across the altitude boundary (:func:`_saltation`, with the altitude's gradient,
    :func:`visviva.core.drag_bands.altitude_gradient`) and ``f`` the derivative after it."""
    for i in range(3):
        scr[4, i] = f[3 + i]
    hold_band(rforce, band)
    variational_rhs(t, y, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, f, dadr, dadv)
    rate = altitude_gradient(y, rforce, scr[5])
    _saltation(y, scr[4, :3], f[3:6], scr[5, :3], rate)
    variational_rhs(t, y, rforce, zonal, atm, eph_r, eph_v, eph_gm, sh, f, dadr, dadv)
