"""The radio ray through the exponential refractivity profile of ITU-R P.453/P.834: its
bending and its central angle (the bending integral of Bean & Dutton 1966, eq. 3.24; ITU-R
P.834-9 sec. 1), and the refraction table over the geometric elevation built from them.

Used by :mod:`visviva.ground.refraction` (the radio model) and
:mod:`visviva.ground.finite_range` (the offset of a target at a finite range); see
:func:`visviva.ground.refraction.refraction_deg`'s Notes for the integral.
"""

from __future__ import annotations

import functools

import numpy as np

__all__ = ["radio_bending_deg", "radio_ray_deg", "radio_table", "EARTH_RADIUS_KM", "DECAY_PER_KM",
           "TOP_KM", "TABLE_DEG"]

#: Earth radius of ITU-R P.834-9 (km) and the refractivity's decay rate of its reference
#: atmosphere (P.453-14 eq. 8, P.834-9 eq. 8: ``N(h) = 315 exp(-0.1361 h)``), 1/km.
EARTH_RADIUS_KM = 6370.0
DECAY_PER_KM = 0.1361
#: Panels of the quadrature in s (km from its lower end): the integrand decays over ~7 km of s
#: at the zenith and ~200 km at the horizon; 16 Gauss-Legendre nodes per panel.
_PANELS_KM = np.array([0.0, 1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024, 2048])
_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(16)
#: Top of the integration above the station (km): exp(-0.1361 * 120) = 8e-8 of N_s.
TOP_KM = 120.0
#: Apparent elevations of the table (deg): dense near the horizon, where the bending bends.
#: From -1 deg, whose geometric elevation -1 deg - R lies below the models' range.
TABLE_DEG = np.concatenate([np.linspace(-1.0, 12.0, 341)[:-1], np.linspace(12.0, 90.0, 160)])


def radio_bending_deg(theta_deg, n_s):
    """Total bending (deg) of a ray leaving the station at apparent elevations ``theta_deg``
    (deg, 1-d) through ``n = 1 + n_s 1e-6 exp(-0.1361 z)``: the integral of
    :func:`~visviva.ground.refraction.refraction_deg`'s Notes; a negative ``theta`` goes down to its tangent point below
    the station first and counts that leg twice."""
    return radio_ray_deg(theta_deg, n_s)[0]


def radio_ray_deg(theta_deg, n_s, top_km=TOP_KM):
    """Bending ``tau`` and central angle ``beta`` (deg) of rays leaving the station at apparent
    elevations ``theta_deg`` (deg, 1-d) up to ``top_km`` above it (a scalar, or one per ray
    for a target inside the profile): ``d tau/ds = -n' a / (n^2 r (n + r n'))`` and
    ``d beta/ds = a / (n r^2 (n + r n'))`` in the variable ``s`` of :func:`~visviva.ground.refraction.refraction_deg`'s
    Notes (``d beta = cot(phi) dr / r`` along the ray, ``a = n r cos(phi)``)."""
    theta = np.radians(np.asarray(theta_deg, dtype=np.float64))[:, None]
    eps = n_s * 1e-6
    n0, r0 = 1.0 + eps, EARTH_RADIUS_KM
    a = n0 * r0 * np.cos(theta)  # Snell's invariant n r cos(phi)
    s0 = n0 * r0 * np.sin(theta)
    top = np.reshape(np.asarray(top_km, dtype=np.float64), (-1, 1))
    r_top = r0 + top
    s_top = np.sqrt(((1.0 + eps * np.exp(-DECAY_PER_KM * top)) * r_top) ** 2 - a * a)

    def integral(lo, hi, a):
        total = np.zeros((2,) + lo.shape)
        for p0, p1 in zip(_PANELS_KM[:-1], _PANELS_KM[1:], strict=True):
            s_lo, s_hi = np.minimum(lo + p0, hi), np.minimum(lo + p1, hi)
            half = 0.5 * (s_hi - s_lo)
            s = 0.5 * (s_hi + s_lo) + half * _NODES
            m = np.sqrt(s * s + a * a)  # = n(r) r: solve for r by Newton's method
            r = m
            for _ in range(4):
                n = 1.0 + eps * np.exp(-DECAY_PER_KM * (r - r0))
                dn = -DECAY_PER_KM * (n - 1.0)
                r = r - (n * r - m) / (n + r * dn)
            n = 1.0 + eps * np.exp(-DECAY_PER_KM * (r - r0))
            dn = -DECAY_PER_KM * (n - 1.0)
            g = a / (n * r * r * (n + r * dn))  # d(beta)/ds
            f = -dn * g * r / n  # d(tau)/ds
            total[0] += (f * _WEIGHTS).sum(axis=-1, keepdims=True) * half
            total[1] += (g * _WEIGHTS).sum(axis=-1, keepdims=True) * half
        return total

    up = np.maximum(s0, 0.0)
    out = integral(up, s_top, a)
    down = s0[:, 0] < 0.0
    if down.any():  # the leg from the station down to the tangent point (s = 0) and back up
        out[:, down] += integral(np.zeros_like(s0[down]), -s0[down], a[down])
    return np.degrees(out[0, :, 0]), np.degrees(out[1, :, 0])


@functools.lru_cache(maxsize=64)
def radio_table(n_s: float):
    """The radio refraction (deg) over the geometric elevation (deg) for the surface
    refractivity ``n_s``: a cubic spline and the lowest geometric elevation it covers (below
    it the refraction stays at the spline's first value); None for no air."""
    from scipy.interpolate import CubicSpline

    if n_s <= 0.0:
        return None
    with np.errstate(all="ignore"):
        tau = radio_bending_deg(TABLE_DEG, n_s)
    geometric = TABLE_DEG - tau
    # rays aimed below the horizon pass under the station, where the profile grows; in dense
    # air they reach its ducting layer (no tangent point): keep the apparent elevations above
    ok = np.isfinite(geometric) & (tau >= 0.0)
    ok[:-1] &= np.diff(geometric) > 0.0
    first = TABLE_DEG.size - np.argmin(ok[::-1]) if not ok.all() else 0
    return CubicSpline(geometric[first:], tau[first:]), float(geometric[first])
