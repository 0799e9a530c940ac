"""The compiled loop of the secular J2 batch (:func:`visviva.satellites.catalog.propagate_j2_batch`).

SGP4's mean elements of a catalogue, the first-order secular J2 rates of their node, perigee and
mean anomaly with SGP4's WGS-72 constants (:func:`visviva.satellites.secular.j2_secular_rates`),
and one compiled pass over the N x T (satellite, time) pairs that solves Kepler's equation and
builds each state directly from the eccentric anomaly. Works on arrays and element sets only:
the catalogue and its results stay in :mod:`visviva.satellites.catalog`.
"""

from __future__ import annotations

import math

import numpy as np
from astropy import units as u

from ..constants import DAY_S
from ..core._jit import kernel, parallel_kernel, prange
from ..core.kepler import eccentric_anomaly
from ..core.status import BAD_ECCENTRICITY, HITS_ATTRACTOR

__all__ = ["secular_setup", "secular_grid"]


def secular_setup(satrecs, names, epochs_tai):
    """Everything the grid needs that depends on the catalogue only (computed once per catalogue).

    Parameters
    ----------
    satrecs : sequence of sgp4.api.Satrec
        The element sets, N of them.
    names : sequence of str
        Their names, for the error message.
    epochs_tai : astropy.time.Time, shape (N,)
        Their epochs on the TAI scale.

    Returns
    -------
    tuple
        ``((a, e, i, raan, argp, M), (raan_dot, argp_dot, M_dot), gm, ep1, ep2, refused)``: mean
        elements (km, rad), secular rates (rad/s), WGS-72 GM (km3/s2), the two-part TAI Julian
        epochs and ``refused``, a dict ``{index: (status code, message)}`` of the satellites the
        theory cannot take: an unbound mean orbit (a <= 0 or e outside [0, 1),
        :data:`~visviva.core.status.BAD_ECCENTRICITY`) or a mean perigee below the Earth's
        radius (decayed, :data:`~visviva.core.status.HITS_ATTRACTOR`). Their elements are
        replaced by a harmless circular orbit so the grid runs; the caller NaNs their rows.
    """
    from .secular import j2_secular_rates

    a, ecc, inc, raan, argp, M = _mean_elements(satrecs)
    body = _wgs72_body(satrecs[0])
    refused = {}
    bad = (a <= 0) | ~((ecc >= 0) & (ecc < 1))
    for k in np.flatnonzero(bad):
        refused[int(k)] = (BAD_ECCENTRICITY, (
            f"satellite {names[k]!r} has mean a = {a[k]:.6g} km, e = {ecc[k]:.6g}: the "
            "secular J2 theory needs a bound orbit (a > 0, 0 <= e < 1); use method='sgp4'."
        ))
    with np.errstate(invalid="ignore"):
        under = ~bad & (a * (1 - ecc) < body.radius_km)
    for k in np.flatnonzero(under):
        refused[int(k)] = (HITS_ATTRACTOR, (
            f"satellite {names[k]!r} has its mean perigee a (1 - e) = {a[k] * (1 - ecc[k]):.6g} "
            f"km below the Earth's radius ({body.radius_km} km): it has decayed; drop it from the "
            "catalog, use on_error='nan' (NaN states, status 9 for it), or use method='sgp4', "
            "which flags decayed satellites per time."
        ))
    if refused:
        k = np.array(sorted(refused))
        a, ecc = a.copy(), ecc.copy()
        a[k] = 2.0 * body.radius_km
        ecc[k] = 0.0
    rates = tuple(
        q.to_value(u.rad / u.s) for q in j2_secular_rates(a * u.km, ecc, inc, body)
    )
    return ((a, ecc, inc, raan, argp, M), rates, body.gm_km3_s2,
            np.ascontiguousarray(epochs_tai.jd1, dtype=np.float64),
            np.ascontiguousarray(epochs_tai.jd2, dtype=np.float64), refused)


def _mean_elements(satrecs):
    """SGP4 mean elements at epoch as (N,) float arrays: a (km), e, i, raan, argp, M (rad)."""
    s = list(satrecs)
    a = np.array([x.a * x.radiusearthkm for x in s])
    ecc = np.array([x.ecco for x in s])
    inc = np.array([x.inclo for x in s])
    raan = np.array([x.nodeo for x in s])
    argp = np.array([x.argpo for x in s])
    M = np.array([x.mo for x in s])
    return a, ecc, inc, raan, argp, M


@kernel
def secular_grid(a, ecc, inc, raan0, argp0, M0, raan_dot, argp_dot, M_dot, ep1, ep2, t1, t2,
                 gm, r_out, v_out, status):
    """States (km, km/s) of N mean-element sets at T two-part TAI Julian dates, in place.

    Mean elements a, e, i, raan, argp, M (km, rad) and their secular rates (rad/s) as (N,)
    arrays, epochs ``ep1 + ep2`` (N,), times ``t1 + t2`` (T,), ``gm`` (km3/s2); writes
    ``r_out``, ``v_out`` (N, T, 3) and the solver's ``status`` (N, T) (see ``_secular_pairs``).
    """
    n = a.shape[0]
    sq = np.empty(n)
    kv = np.empty(n)
    si = np.empty(n)
    ci = np.empty(n)
    for i in range(n):  # per-satellite constants, once
        sq[i] = math.sqrt(1.0 - ecc[i] * ecc[i])
        kv[i] = math.sqrt(gm * a[i])
        si[i] = math.sin(inc[i])
        ci[i] = math.cos(inc[i])
    _secular_pairs(a, ecc, sq, kv, si, ci, raan0, argp0, M0, raan_dot, argp_dot, M_dot,
                   ep1, ep2, t1, t2, r_out, v_out, status)


@parallel_kernel
def _secular_pairs(a, ecc, sq, kv, si, ci, raan0, argp0, M0, raan_dot, argp_dot, M_dot,
                   ep1, ep2, t1, t2, r_out, v_out, status):
    """States of N mean-element sets at N x T offsets dt (s) with linear secular drift.

    Per pair: M = M0 + Mdot dt, E from Kepler's equation (the core solver), then the state
    straight from E in the perifocal frame,
        x = a (cos E - e),  y = b sin E,  xdot = -sqrt(mu a) sin E / r,
        ydot = sqrt(mu a) sqrt(1 - e^2) cos E / r,  r = a (1 - e cos E),
    rotated by R3(-raan) R1(-inc) R3(-argp) (Montenbruck & Gill 2000, eqs. 2.43 and 2.46).
    Going through E rather than the true anomaly saves an atan2 and two sin/cos per state.
    ``prange`` over the satellites (per-satellite constants stay in registers); each item is
    independent, so any chunking gives the same bits. dt = ((t1 - ep1) + (t2 - ep2)) * 86400 s
    from two-part TAI Julian dates, as ``batch_states.offsets_s`` computes them.
    """
    n = a.shape[0]
    m = t1.shape[0]
    for i in prange(n):
        e = ecc[i]
        ai = a[i]
        sqi = sq[i]
        kvi = kv[i]
        sii = si[i]
        cii = ci[i]
        for j in range(m):
            d = ((t1[j] - ep1[i]) + (t2[j] - ep2[i])) * DAY_S
            E, st = eccentric_anomaly(M0[i] + M_dot[i] * d, e)
            sE = math.sin(E)
            cE = math.cos(E)
            x = ai * (cE - e)
            y = ai * sqi * sE
            k_v = kvi / (ai * (1.0 - e * cE))
            xd = -k_v * sE
            yd = k_v * sqi * cE
            raan = raan0[i] + raan_dot[i] * d
            argp = argp0[i] + argp_dot[i] * d
            sO = math.sin(raan)
            cO = math.cos(raan)
            sw = math.sin(argp)
            cw = math.cos(argp)
            px = cO * cw - sO * sw * cii
            py = sO * cw + cO * sw * cii
            pz = sw * sii
            qx = -cO * sw - sO * cw * cii
            qy = -sO * sw + cO * cw * cii
            qz = cw * sii
            r_out[i, j, 0] = x * px + y * qx
            r_out[i, j, 1] = x * py + y * qy
            r_out[i, j, 2] = x * pz + y * qz
            v_out[i, j, 0] = xd * px + yd * qx
            v_out[i, j, 1] = xd * py + yd * qy
            v_out[i, j, 2] = xd * pz + yd * qz
            status[i, j] = st


def _wgs72_body(satrec):
    """The Earth as SGP4 sees it (WGS-72 GM, radius, J2), for consistent secular rates."""
    from ..bodies import Body

    return Body(
        "earth (WGS-72)", satrec.mu * u.km**3 / u.s**2, satrec.radiusearthkm * u.km,
        zonal=(satrec.j2,),
    )
