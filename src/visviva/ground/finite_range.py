"""Refraction of a target inside reach: the offset of a satellite's apparent direction.

:func:`~visviva.ground.refraction.refraction_deg` is the bending ``R(E)`` of a ray from a
target outside the atmosphere and far away (a star). A satellite at a finite range ``rho`` is
offset less: its apparent direction is the ray's first tangent, its geometric direction the
chord from the station to it, and the chord leaves the ray's bent part behind by the lever arm
``rho``. For a ray leaving at the apparent elevation ``theta`` the bending ``psi(s)`` accrued
over the path ``s`` gives the offset ``delta = theta - E = (1/rho) int_0^rho psi ds`` (to
first order): each bit of bending counts with the weight ``1 - s/rho``, and the bending beyond
the target not at all. At 500 km up the offset is 0.947 of ``R`` at the horizon, 0.968 at
5 deg, 0.977 at 10 deg; at GEO 0.997.

The offset is found by tracing the ray through the radio profile of
:func:`~visviva.ground.radioray.radio_ray_deg` (Snell's law on a sphere; the "elevation
angle error" of a radar target at a finite height in Bean & Dutton 1966, ch. 3): up to the
profile's top (120 km) the bending ``tau`` and the central angle ``beta`` of the ray come from
one table per air (cubic splines over 500 apparent elevations, cached); beyond, the ray is a
straight line to the target's radius ``r_t``, found from the geometric elevation and range
(``r_t^2 = r_0^2 + rho^2 + 2 r_0 rho sin E``); a target inside the profile takes the integral
to its own height. The apparent elevation ``theta`` of a target seen at ``(E, rho)`` solves
``E_ray(theta, r_t) = E`` by Newton's method (3-5 steps to 1e-12 rad), from the flat-Earth
share ``1 - (H_s / H)(1 - exp(-H / H_s))`` of ``R(E)``. The offset's share of
``R(E)``, ``k = delta / R``, multiplies either model's refraction: for the optical one the
ray is traced through the dry (optical) refractivity ``77.6 P / T`` of the same air. The
share depends on the profile's decay (7.35 km) more than on its size: a real atmosphere's
~8 km scale height moves ``1 - k`` by ~10 % of itself (0.005 of ``R`` at a LEO horizon).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from ..errors import InvalidInputError
from .radioray import DECAY_PER_KM, EARTH_RADIUS_KM, TABLE_DEG, TOP_KM, radio_ray_deg

__all__ = ["range_factor", "height_above_station_km", "refracts"]

#: Below this height above the station (km) a target is not refracted by the models.
_LOWEST_TARGET_KM = 1.0
#: Central-difference steps of the factor's slopes: in the elevation (deg), and in the range
#: (a fraction of it).
_STEP_DEG = 1e-3
_RANGE_STEP = 1e-3
#: Most Newton steps of the apparent elevation (3-4 reach 1e-12 rad).
_NEWTON = 8


def height_above_station_km(el_deg, range_km):
    """Height (km) of a target at the geometric elevation ``el_deg`` (deg) and the range
    ``range_km`` (km) above the station's sphere (radius 6370 km)."""
    r0 = EARTH_RADIUS_KM
    return (np.sqrt(r0 * r0 + range_km * range_km
                    + 2.0 * r0 * range_km * np.sin(np.radians(el_deg))) - r0)


def refracts(el_deg, range_km):
    """Whether the models refract a target at ``(el_deg, range_km)``: at least 1 km above the
    station (elsewhere :func:`range_factor` refuses it)."""
    return height_above_station_km(el_deg, range_km) >= _LOWEST_TARGET_KM


@functools.lru_cache(maxsize=64)
def _exit_table(n_s: float):
    """Splines of the bending and the central angle (deg) at the profile's top over the
    apparent elevation (deg), and the lowest apparent elevation they cover."""
    from scipy.interpolate import CubicSpline

    with np.errstate(all="ignore"):
        tau, beta = radio_ray_deg(TABLE_DEG, n_s)
    ok = np.isfinite(tau) & np.isfinite(beta) & (tau >= 0.0)
    geometric = TABLE_DEG - tau
    ok[:-1] &= np.diff(geometric) > 0.0
    first = TABLE_DEG.size - np.argmin(ok[::-1]) if not ok.all() else 0
    theta = TABLE_DEG[first:]
    return CubicSpline(theta, tau[first:]), CubicSpline(theta, beta[first:]), float(theta[0])


def _ray_elevation_rad(theta_deg, r_t, n_s):
    """Geometric elevation (rad) from the station of the point at radius ``r_t`` (km) on the
    ray that leaves it at the apparent elevation ``theta_deg`` (deg)."""
    r0 = EARTH_RADIUS_KM
    eps = n_s * 1e-6
    tau_s, beta_s, lowest = _exit_table(n_s)
    theta = np.clip(theta_deg, lowest, 90.0)
    x = np.empty_like(theta)
    y = np.empty_like(theta)
    above = r_t - r0 >= TOP_KM
    if above.any():  # a straight line from the ray's exit at the top
        th = np.radians(theta[above])
        beta = np.radians(beta_s(theta[above]))
        r_top = r0 + TOP_KM
        n_top = 1.0 + eps * math.exp(-DECAY_PER_KM * TOP_KM)
        cos_phi = np.clip((1.0 + eps) * r0 * np.cos(th) / (n_top * r_top), -1.0, 1.0)
        sin_phi = np.sqrt(1.0 - cos_phi * cos_phi)  # going up at the exit
        rt = r_t[above]
        t = -r_top * sin_phi + np.sqrt((r_top * sin_phi) ** 2 + rt * rt - r_top * r_top)
        sb, cb = np.sin(beta), np.cos(beta)
        # exit point r_top (sin b, cos b); direction cos(phi) (cos b, -sin b) + sin(phi) (sin b,
        # cos b)
        x[above] = r_top * sb + t * (cos_phi * cb + sin_phi * sb)
        y[above] = r_top * cb + t * (-cos_phi * sb + sin_phi * cb)
    inside = ~above
    if inside.any():  # a target inside the profile: the integral to its height
        _, beta = radio_ray_deg(theta[inside], n_s, r_t[inside] - r0)
        x[inside] = r_t[inside] * np.sin(np.radians(beta))
        y[inside] = r_t[inside] * np.cos(np.radians(beta))
    return np.arctan2(y - r0, x)


def _offset_deg(el_deg, r_t, n_s, r_inf, slope_inf):
    """``theta - E`` (deg) of targets at geometric elevations ``el_deg`` and radii ``r_t``."""
    # first guess: the flat-Earth lever arm of an exponential profile of scale height H_s,
    # k = 1 - (H_s / H) (1 - exp(-H / H_s)) for a target H above the station
    hs = 1.0 / DECAY_PER_KM
    height = np.maximum(r_t - EARTH_RADIUS_KM, _LOWEST_TARGET_KM)
    share = 1.0 - hs / height * (1.0 - np.exp(-height / hs))
    theta = el_deg + share * r_inf
    el = np.radians(el_deg)
    for _ in range(_NEWTON):
        # Newton: d E_ray / d theta ~ 1 / (1 + k R'(E)), k the offset's share so far
        miss = el - _ray_elevation_rad(theta, r_t, n_s)
        theta = theta + np.degrees(miss) * (1.0 + share * slope_inf)
        if np.all(np.abs(miss) < 1e-12):
            break
        with np.errstate(divide="ignore", invalid="ignore"):
            share = np.clip(np.where(r_inf > 1e-12, (theta - el_deg) / r_inf, 1.0), 0.0, 1.0)
    return theta - el_deg


def range_factor(el_deg, range_km, n_s, spline, slopes: bool = True):
    """The share ``k`` of the refraction ``R(E)`` that offsets a target at the range
    ``range_km`` (km), and ``dk/dE`` (per deg), at geometric elevations ``el_deg`` (deg, in the
    models' range: from -1 deg, or the radio table's end).

    Parameters
    ----------
    el_deg : ndarray
        Geometric elevations, deg (>= -1).
    range_km : ndarray
        The targets' ranges, km (broadcast with ``el_deg``; finite, > 0).
    n_s : float
        Surface refractivity of the traced ray's air (> 0).
    spline : callable
        ``R(E)`` of that air for a target at infinity (the radio table's spline), deg.
    slopes : bool
        Compute ``dk/dE`` and ``dk/d range`` (four more ray solutions); else zeros.

    Returns
    -------
    k, dk, dk_range : ndarray
        ``k`` in (0, 1] (1 at the zenith), ``dk/dE`` (per deg) and ``dk/d range`` (per km).
    """
    el_deg, rng = np.broadcast_arrays(np.asarray(el_deg, dtype=np.float64),
                                      np.asarray(range_km, dtype=np.float64))
    if not np.all(np.isfinite(rng) & (rng > 0.0)):
        raise InvalidInputError("range_km must be finite and positive (km) to refract a target "
                                "at a finite range.")
    r0 = EARTH_RADIUS_KM
    out_k = np.ones(el_deg.shape)
    out_dk = np.zeros(el_deg.shape)
    out_dr = np.zeros(el_deg.shape)
    top = el_deg < 90.0 - 2 * _STEP_DEG  # at the zenith the refraction is 0: k = 1
    if not top.any():
        return out_k, out_dk, out_dr
    e = el_deg[top]
    rho = rng[top]
    low = ~refracts(e, rho)
    if low.any():
        raise InvalidInputError(
            f"a target {float(rho[low][0]):.6g} km away at {float(e[low][0]):.4g} deg of "
            f"elevation is less than {_LOWEST_TARGET_KM:g} km above the station: the refraction "
            "models are for satellites above the air; pass refraction=False.")
    ks = []
    d_rho = _RANGE_STEP * rho
    steps = ((0.0, 0.0), (-_STEP_DEG, 0.0), (_STEP_DEG, 0.0), (0.0, -1.0), (0.0, 1.0))
    for de, dr in steps if slopes else steps[:1]:
        ee = e + de
        rr = rho + dr * d_rho
        r_t = np.sqrt(r0 * r0 + rr * rr + 2.0 * r0 * rr * np.sin(np.radians(ee)))
        r_inf = spline(ee)
        slope = spline(ee, 1)
        delta = _offset_deg(ee, r_t, n_s, r_inf, slope)
        with np.errstate(divide="ignore", invalid="ignore"):
            ks.append(np.where(r_inf > 1e-12, delta / r_inf, 1.0))
    out_k[top] = ks[0]
    if slopes:
        out_dk[top] = (ks[2] - ks[1]) / (2.0 * _STEP_DEG)
        out_dr[top] = (ks[4] - ks[3]) / (2.0 * d_rho)
    return out_k, out_dk, out_dr
