"""The signal's flight time in the ground-station measurement models (``light_time=True``),
and :func:`model`, the measurement model of an :class:`~visviva.Observations` table.

A station's measurement is tagged with the time ``t_r`` the signal is *received*. With
light time on (the default of :class:`~visviva.Observations`, what real tracking data are):

* **az/el and RA/Dec** are one-way (downlink): the direction at ``t_r`` from the station
  R(t_r) to where the satellite was when the light left it, r(t_b) with
  ``c (t_r - t_b) = |r(t_b) - R(t_r)|``.
* **range** is two-way (round trip, as radar, SLR and turn-around ranging measure it): the
  signal left the station at ``t_t``, was reflected or turned around at ``t_b`` and came back at
  ``t_r``; the value is half the path, ``c (t_r - t_t) / 2``, with
  ``c (t_b - t_t) = |r(t_b) - R(t_t)|``.
* **range rate** is the time derivative of that two-way range with respect to ``t_r``
  (two-way Doppler divided by twice the frequency, times -c):
  ``(c / 2) (dtau_d/dt_r + dtau_u/dt_b (1 - dtau_d/dt_r))`` with
  ``dtau_d/dt_r = u_d.(v_b - V_r) / (c + u_d.v_b)`` and
  ``dtau_u/dt_b = u_u.(v_b - V_t) / (c - u_u.V_t)`` (u_d, u_u: unit vectors from the station
  to the satellite on the down and up legs).

Everything is computed in the GCRS (a geocentric, locally inertial frame), as Orekit's
``signalTimeOfFlight`` and GMAT's ``UseLightTime`` do. The flight times are found by
fixed-point iteration (each step gains a factor v/c ~ 3e-5, three steps reach double
precision); the satellite's state at ``t_b`` is a third-order two-body Taylor step back from
the integrated state at ``t_r`` (a perturbing acceleration ``a_p`` adds ``a_p tau^2 / 2``:
under 1 nm for J2 in LEO, about 0.1 mm at GEO), and the station's position at ``t_t`` a
second-order step along the Earth's rotation. The partials are those of the down-leg geometry
mapped through ``d y(t_b) / d y(t_r) = I - tau F`` (F the two-body Jacobian), good to O(v/c).

**RA/Dec and aberration.** ``radec_reference="gcrs"`` (default) models the *natural*
direction of the incoming light in the GCRS, with no aberration, as Orekit's ``AngularRaDec``
does without its ``AberrationModifier``. Optical astrometry reduced against catalogue stars
instead measures the direction in the barycentric frame (the stars' aberration, which the
satellite shares, is calibrated away, but the satellite's light time there includes the Earth's
motion): the model for ``radec_reference="stars"`` subtracts the Earth's barycentric velocity
times the flight time, ``rho - V_E tau``, a shift of up to V_E / c = 20.5 arcsec. Diurnal
aberration (the station's own 0.46 km/s, <= 0.32 arcsec) is removed by the same reduction and
is not modelled in either case. Atmospheric refraction and the media's path delays are added
after the light time, by :mod:`visviva.od.troposphere` and :mod:`visviva.od.ionosphere`.
"""

from __future__ import annotations

import numpy as np

from ..constants import C_KM_S, EARTH_ROTATION_RAD_S
from ..ground.doppler import light_time_rate
from . import ionosphere, troposphere
from .measurements import angles, predict

__all__ = ["predict_light_time", "model"]

#: fixed-point iterations of each flight time (each multiplies the error by ~v/c)
ITERATIONS = 3


def _shift_back(y, gm, tau, jacobian=True):
    """Two-body Taylor step of states y (N, 6) back by tau (N,) s, and d y(t-tau) / d y(t)
    (None with ``jacobian=False``: the flight time's fixed-point steps need the state only)."""
    r, v = y[:, :3], y[:, 3:]
    rn = np.linalg.norm(r, axis=-1)[:, None]
    rv = np.sum(r * v, axis=-1)[:, None]
    acc = -gm * r / rn**3
    jerk = -gm * (v / rn**3 - 3.0 * r * rv / rn**5)
    t = tau[:, None]
    out = np.empty_like(y)
    out[:, :3] = r - v * t + 0.5 * acc * t * t - jerk * t**3 / 6.0
    out[:, 3:] = v - acc * t + 0.5 * jerk * t * t
    if not jacobian:
        return out, None
    n = y.shape[0]
    gradient = gm * (3.0 * np.einsum("ni,nj->nij", r, r) / rn[:, :, None] ** 5
                     - np.eye(3)[None] / rn[:, :, None] ** 3)  # fmt: skip
    jac = np.broadcast_to(np.eye(6), (n, 6, 6)).copy()
    jac[:, :3, 3:] -= tau[:, None, None] * np.eye(3)[None]
    jac[:, 3:, :3] -= tau[:, None, None] * gradient
    return out, jac


def _site_back(site_r, site_v, tau):
    """Station GCRS position and velocity tau (N,) s earlier: a step along the Earth's spin."""
    w2 = EARTH_ROTATION_RAD_S**2
    acc = np.zeros_like(site_r)
    acc[:, :2] = -w2 * site_r[:, :2]
    t = tau[:, None]
    return site_r - site_v * t + 0.5 * acc * t * t, site_v - acc * t


def predict_light_time(kinds, y, site_r, site_v, enu, gm, earth_velocity=None, partials=True):
    """Predicted values (N, 3) and partials (N, 3, 6) with the signal's flight time.

    Parameters
    ----------
    kinds, y, site_r, site_v, enu : ndarray
        As for :func:`visviva.od.measurements.predict` (kinds (N,), satellite state (N, 6)
        in km and km/s, station position and velocity (N, 3) in km and km/s, GCRS -> ENU
        rows (N, 3, 3)), with the satellite and the station at the reception times.
    gm : float
        GM of the central body, km^3/s^2 (the Taylor step back along the orbit).
    earth_velocity : ndarray (N, 3), optional
        The Earth's barycentric velocity (km/s) for RA/Dec referred to catalogue stars; None
        models the natural GCRS direction.
    partials : bool
        False: skip the chain rule through the flight time (H is then None; an unscented
        filter's sigma points need the values only).

    Returns
    -------
    h : ndarray (N, 3)
        Predicted values (km, km/s, rad).
    H : ndarray (N, 3, 6) or None
        Partials with respect to the state at the reception time.
    """
    station = kinds != "position"
    yb = y.copy()
    jac = np.broadcast_to(np.eye(6), (len(kinds), 6, 6)).copy() if partials else None
    if not station.any():
        return predict(kinds, y, site_r, site_v, enu)
    ys, R, V = y[station], site_r[station], site_v[station]
    tau_d = np.linalg.norm(ys[:, :3] - R, axis=-1) / C_KM_S
    for _ in range(ITERATIONS):
        ysb, _ = _shift_back(ys, gm, tau_d, jacobian=False)
        tau_d = np.linalg.norm(ysb[:, :3] - R, axis=-1) / C_KM_S
    ysb, jac_s = _shift_back(ys, gm, tau_d, jacobian=partials)
    yb[station] = ysb
    if partials:
        jac[station] = jac_s
    h, H = predict(kinds, yb, site_r, site_v, enu)
    two_way = (kinds == "range") | (kinds == "range_rate")
    if two_way.any():
        sel = two_way[station]
        rb, vb = ysb[sel, :3], ysb[sel, 3:]
        Rr, Vr, td = R[sel], V[sel], tau_d[sel]
        tau_u = td.copy()
        for _ in range(ITERATIONS):
            Rt, Vt = _site_back(Rr, Vr, td + tau_u)
            tau_u = np.linalg.norm(rb - Rt, axis=-1) / C_KM_S
        Rt, Vt = _site_back(Rr, Vr, td + tau_u)
        u_d = (rb - Rr) / np.linalg.norm(rb - Rr, axis=-1)[:, None]
        u_u = (rb - Rt) / np.linalg.norm(rb - Rt, axis=-1)[:, None]
        dtd = light_time_rate(u_d, vb, Vr)  # down: satellite at t_b -> station at t_r
        dtu = light_time_rate(-u_u, Vt, vb)  # up: station at t_t -> satellite at t_b
        rows = np.flatnonzero(two_way)
        k = kinds[rows]
        rng = 0.5 * C_KM_S * (td + tau_u)
        rate = 0.5 * C_KM_S * (dtd + dtu * (1.0 - dtd))
        h[rows, 0] = np.where(k == "range", rng, rate)
    if earth_velocity is not None:
        m = kinds == "radec"
        if m.any():
            rho = yb[m, :3] - site_r[m]
            tau = np.linalg.norm(rho, axis=-1)[:, None] / C_KM_S
            lon, lat, _ = angles(rho - earth_velocity[m] * tau)
            h[m, 0] = lon
            h[m, 1] = lat
    return h, np.einsum("nij,njk->nik", H, jac) if partials else None


def model(observations, y, gm, rows=None, partials=True):
    """Predicted values and partials of a whole :class:`~visviva.Observations` table.

    Parameters
    ----------
    observations : Observations
        The table; its ``light_time`` and ``radec_reference`` choose the model.
    y : ndarray (N, 6)
        The satellite's GCRS states at the observation (reception) times, km and km/s (one per
        row of ``rows`` when given).
    gm : float
        GM of the central body, km^3/s^2.
    rows : ndarray of int, optional
        Only these rows of the table (a sequential filter's rows at one epoch); None: all.
    partials : bool
        False: H may be None (light time on), when only the values are needed.

    Returns
    -------
    h : ndarray (N, 3)
        Predicted values (km, km/s, rad).
    H : ndarray (N, 3, 6)
        Partials with respect to the states ``y``.
    """
    site_r, site_v, enu = observations.sites()
    kinds = observations.kinds
    pick = slice(None) if rows is None else rows
    site_r, site_v, enu, kinds = site_r[pick], site_v[pick], enu[pick], kinds[pick]
    if not observations.light_time:
        h, H = predict(kinds, y, site_r, site_v, enu)
    else:
        ev = (observations.earth_velocity()[pick] if observations.radec_reference == "stars"
              else None)
        h, H = predict_light_time(kinds, y, site_r, site_v, enu, gm, ev, partials)
    if observations.troposphere is not None:
        rows_idx = np.arange(len(observations))[pick]
        troposphere.apply(observations, kinds, y, site_r, site_v, enu, h, H, rows_idx)
    if observations.ionosphere is not None:
        rows_idx = np.arange(len(observations))[pick]
        ionosphere.apply(observations, kinds, y, site_r, site_v, enu, h, H, rows_idx)
    return h, H
