"""Measurement models and their partial derivatives with respect to the satellite's state.

Every model maps the GCRS state y = (r, v) of the satellite at the observation time, and the
GCRS position R and velocity V of the station, to the predicted value, with the row of
partials H = d h / d y (Montenbruck & Gill 2000, sec. 7.3; Vallado 2013, sec. 10.3).
With rho = r - R and rho_dot = v - V:

===========  ==================================  =============================================
kind         h(y)                                d h / d r  (d h / d v)
===========  ==================================  =============================================
position     r                                   I (0)
range        |rho|                               rho_hat (0)
range_rate   rho . rho_dot / |rho|               (rho_dot - rr rho_hat) / |rho| (rho_hat)
radec        atan2(rho_y, rho_x),                (-y, x, 0) / (x^2 + y^2);
             asin(rho_z / |rho|)                 (-x z, -y z, x^2 + y^2) / (rho^2 sqrt(x^2+y^2))
azel         atan2(e, n), asin(u / |rho|),       as radec in the local (e, n, u) axes, times
             (e, n, u) = E(t) rho                the GCRS -> east-north-up rotation E(t)
===========  ==================================  =============================================

These are the geometric values at one instant (``Observations(light_time=False)``);
:func:`visviva.od.light_time.model` dispatches to
:func:`visviva.od.light_time.predict_light_time` for the default ``light_time=True``, which adds
the signal's flight (for LEO the satellite moves ~25 m per
1000 km of range meanwhile).
"""

from __future__ import annotations

import numpy as np

__all__ = ["predict", "residuals", "angles"]


def angles(vec):
    """Longitude-like and latitude-like angles of vectors, and their partials.

    Parameters
    ----------
    vec : ndarray (N, 3)
        Vectors (any length unit).

    Returns
    -------
    lon : ndarray (N,)
        atan2(y, x) in [0, 2 pi), rad.
    lat : ndarray (N,)
        asin(z / |vec|), rad.
    d : ndarray (N, 2, 3)
        d(lon, lat) / d vec, rad per length unit.
    """
    x, y, z = vec[:, 0], vec[:, 1], vec[:, 2]
    rho2 = x * x + y * y + z * z
    q2 = x * x + y * y
    q = np.sqrt(q2)
    lon = np.mod(np.arctan2(y, x), 2 * np.pi)
    lat = np.arcsin(np.clip(z / np.sqrt(rho2), -1.0, 1.0))
    d = np.zeros((vec.shape[0], 2, 3))
    d[:, 0, 0] = -y / q2
    d[:, 0, 1] = x / q2
    d[:, 1, 0] = -x * z / (rho2 * q)
    d[:, 1, 1] = -y * z / (rho2 * q)
    d[:, 1, 2] = q2 / (rho2 * q)
    return lon, lat, d


def predict(kinds, y, site_r, site_v, enu):
    """Predicted values (N, 3) and partials d h / d y (N, 3, 6), padded with zeros.

    Parameters
    ----------
    kinds : ndarray of str (N,)
        The measurement kind of each row.
    y : ndarray (N, 6)
        Satellite GCRS position (km) and velocity (km/s) at each observation time.
    site_r, site_v : ndarray (N, 3)
        Station GCRS position (km) and velocity (km/s) (ignored for position rows).
    enu : ndarray (N, 3, 3)
        Rows of the east, north and up unit vectors in GCRS axes (used by azel rows).

    Returns
    -------
    h : ndarray (N, 3)
        Predicted values in km, km/s, rad (azimuth and right ascension in [0, 2 pi)).
    H : ndarray (N, 3, 6)
        Partials with respect to the state at the observation time.
    """
    n = y.shape[0]
    h = np.zeros((n, 3))
    H = np.zeros((n, 3, 6))
    r = y[:, :3]
    v = y[:, 3:]
    rho = r - site_r
    rhod = v - site_v
    rng = np.linalg.norm(rho, axis=-1)
    m = kinds == "position"
    if m.any():
        h[m] = r[m]
        H[m, :, :3] = np.eye(3)
    m = kinds == "range"
    if m.any():
        h[m, 0] = rng[m]
        H[m, 0, :3] = rho[m] / rng[m, None]
    m = kinds == "range_rate"
    if m.any():
        u_hat = rho[m] / rng[m, None]
        rr = np.sum(u_hat * rhod[m], axis=-1)
        h[m, 0] = rr
        H[m, 0, :3] = (rhod[m] - rr[:, None] * u_hat) / rng[m, None]
        H[m, 0, 3:] = u_hat
    m = kinds == "radec"
    if m.any():
        lon, lat, d = angles(rho[m])
        h[m, 0] = lon
        h[m, 1] = lat
        H[m, :2, :3] = d
    m = kinds == "azel"
    if m.any():
        local = np.einsum("nij,nj->ni", enu[m], rho[m])  # (e, n, u)
        # azimuth from north through east: atan2(e, n) = the longitude of (n, e, u)
        swapped = local[:, [1, 0, 2]]
        az, el, d = angles(swapped)
        d_local = d[:, :, [1, 0, 2]]  # back to (e, n, u) order
        h[m, 0] = az
        h[m, 1] = el
        H[m, :2, :3] = np.einsum("nij,njk->nik", d_local, enu[m])
    return h, H


def residuals(kinds, observed, computed):
    """Observed minus computed (N, 3), with angle differences wrapped into (-pi, pi]."""
    z = observed - computed
    ang = (kinds == "radec") | (kinds == "azel")
    if ang.any():
        z[ang, 0] = np.mod(z[ang, 0] + np.pi, 2 * np.pi) - np.pi
    return z

