"""The element vector of the SGP4 fit (:func:`visviva.od.tle_fit.fit_tle`): equinoctial mean
elements to and from the classical ones, the first guess from an osculating state, SGP4 states
of an element vector, and the OMM fields of the result.
"""

from __future__ import annotations

import math
import re
import warnings

import numpy as np

from ..errors import InvalidInputError
from ..satellites.catalog_numbers import sgp4_number
from ..satellites.tle_checks import flag_beyond_earth_orbit

__all__ = ["classical", "ephemeris_identity", "elements_to_fields", "epoch_days", "sgp4_states", "initial_elements",
           "initial_identity", "is_retrograde", "naive_fields", "propagable_start",
           "warn_other_object"]

#: beyond these the fitted set and ``initial=`` are taken for different objects (a warning):
#: inclination (deg; an uncontrolled geostationary orbit drifts about 0.9 deg a year) and
#: relative mean motion (a year of drag moves a low orbit's by a few per cent)
OTHER_OBJECT_INC_DEG = 5.0
OTHER_OBJECT_MEAN_MOTION = 0.2

#: WGS-72 GM (km^3/s^2), the constant SGP4 uses
GM_WGS72 = 398600.8

#: the largest eccentricity of a first guess (an osculating e above SGP4's 0.99 starts here)
ECC_START_MAX = 0.975


def classical(p, retrograde=False):
    """Classical SGP4 elements (n rad/min, e, argp, i, node, M, B*; angles in rad) of the
    element vector p of the fit.

    p = (n, e cos(w + s W), e sin(w + s W), t cos W, t sin W, M + w + s W, B*), the equinoctial
    elements (Broucke & Cefola 1972) with t = tan(i / 2) and s = +1, or for a retrograde orbit
    t = tan((pi - i) / 2) and s = -1: non-singular at e = 0 and at i = 0 (or 180 deg), where
    the classical node and argument of perigee are undefined (a fit in i and the node ran out
    of iterations 23 m off a geostationary set 0.015 deg inclined that SGP4 itself made;
    audit31).
    """
    n, ex, ey, q1, q2, lam, bstar = p
    s = -1.0 if retrograde else 1.0
    ecc = math.hypot(ex, ey)
    node = math.atan2(q2, q1) if (q1 or q2) else 0.0
    half = math.atan(math.hypot(q1, q2))
    inc = math.pi - 2.0 * half if retrograde else 2.0 * half
    varpi = math.atan2(ey, ex) if ecc > 0 else 0.0  # w + s W
    return n, ecc, varpi - s * node, inc, node, lam - varpi, bstar


def elements_to_fields(p, epoch_str, satnum, name, object_id="UNKNOWN", retrograde=False):
    n_rad_min, ecc, argp, inc, raan, mean, bstar = classical(p, retrograde)
    deg = 180.0 / math.pi
    return {
        "OBJECT_NAME": name or f"FIT {satnum}",
        "OBJECT_ID": object_id,
        "EPOCH": epoch_str,
        "MEAN_MOTION": n_rad_min * 720.0 / math.pi,
        "ECCENTRICITY": ecc,
        "INCLINATION": inc * deg,
        "RA_OF_ASC_NODE": (raan * deg) % 360.0,
        "ARG_OF_PERICENTER": (argp * deg) % 360.0,
        "MEAN_ANOMALY": (mean * deg) % 360.0,
        "EPHEMERIS_TYPE": 0,
        "CLASSIFICATION_TYPE": "U",
        "NORAD_CAT_ID": int(satnum),
        "ELEMENT_SET_NO": 999,
        "REV_AT_EPOCH": 0,
        "BSTAR": bstar,
        "MEAN_MOTION_DOT": 0.0,
        "MEAN_MOTION_DDOT": 0.0,
    }


def epoch_days(epoch_str):
    """Days since 1949-12-31 00:00 UTC of an OMM epoch string, as sgp4's OMM reader computes."""
    from datetime import datetime

    from sgp4.omm import _epoch0

    when = datetime.strptime(epoch_str, "%Y-%m-%dT%H:%M:%S.%f")
    return (when - _epoch0).total_seconds() / 86400.0


def sgp4_states(p, days, satnum, jd, fr, retrograde=False):
    """TEME r, v (N, 3) of the element vector p (see :func:`classical`), or None if SGP4
    fails: one of sgp4's error codes, a non-finite state, or a position more than 1e6 km from
    the geocentre (:func:`~visviva.satellites.tle_checks.flag_beyond_earth_orbit`, the rule of
    ``Satellite.teme`` and the SGP4 batch: SGP4 run far outside its span, no Earth orbit a fit
    may settle on)."""
    from sgp4.api import WGS72, Satrec

    n, ecc, argp, inc, node, mean, bstar = classical(p, retrograde)
    if not (0.0 <= ecc < 0.99 and n > 0 and math.isfinite(inc)):
        return None
    sat = Satrec()
    sat.sgp4init(WGS72, "i", sgp4_number(satnum), days, bstar, 0.0, 0.0, ecc,
                 argp % (2 * math.pi), inc, mean % (2 * math.pi), n,
                 node % (2 * math.pi))  # fmt: skip
    e, r, v = sat.sgp4_array(jd, fr)
    if e.any() or not np.isfinite(r).all() or flag_beyond_earth_orbit(e, r):
        return None
    return r, v


def initial_elements(r, v, bstar, retrograde=False):
    """Element vector p (see :func:`classical`) from an osculating TEME state (the naive
    TLE)."""
    gm = GM_WGS72
    h = np.cross(r, v)
    rn = np.linalg.norm(r)
    e_vec = np.cross(v, h) / gm - r / rn
    ecc = float(np.linalg.norm(e_vec))
    energy = float(v @ v) / 2 - gm / rn
    if energy >= 0 or ecc >= 1:
        raise InvalidInputError("the states are not on a bound orbit (e >= 1); SGP4 needs e < 1.")
    a = -gm / (2 * energy)
    inc = math.acos(max(-1.0, min(1.0, h[2] / np.linalg.norm(h))))
    node = np.array([-h[1], h[0], 0.0])
    nn = np.linalg.norm(node)
    raan = math.atan2(node[1], node[0]) if nn > 1e-12 else 0.0
    n_hat = node / nn if nn > 1e-12 else np.array([1.0, 0.0, 0.0])
    h_hat = h / np.linalg.norm(h)
    m_hat = np.cross(h_hat, n_hat)
    # argument of latitude u and argument of perigee w, measured from the node
    u_lat = math.atan2(float(r @ m_hat), float(r @ n_hat))
    w = math.atan2(float(e_vec @ m_hat), float(e_vec @ n_hat)) if ecc > 1e-12 else 0.0
    nu = u_lat - w
    E = 2 * math.atan2(math.sqrt(1 - ecc) * math.sin(nu / 2), math.sqrt(1 + ecc) * math.cos(nu / 2))
    M = E - ecc * math.sin(E)
    n_rad_min = math.sqrt(gm / a**3) * 60.0
    s = -1.0 if retrograde else 1.0
    t = math.tan(0.5 * (math.pi - inc if retrograde else inc))
    varpi = w + s * raan
    # SGP4 takes mean e < 0.99 only; an osculating e past it (near perigee of SGP4-VER 23333,
    # mean e 0.973: 0.9905) was no first guess at all (InvalidInputError). Start inside
    ecc = min(ecc, ECC_START_MAX)
    return np.array([n_rad_min, ecc * math.cos(varpi), ecc * math.sin(varpi), t * math.cos(raan),
                     t * math.sin(raan), varpi + M, bstar])  # fmt: skip


#: the eccentricities at which a first guess SGP4 cannot propagate is tried again, in turn
ECC_RETRY = (0.95, 0.9, 0.8, 0.6)


def propagable_start(p, resid):
    """The first guess ``p`` and its residuals ``resid(p)``, or, where SGP4 cannot propagate
    it (``resid`` gives None), the first of ``p`` with its eccentricity lowered to
    :data:`ECC_RETRY` (the other elements kept) that SGP4 can; ``(p, None)`` when none can.

    Over half a day of SGP4-VER 23333 (mean e = 0.973, a = 241,600 km, perigee 187 km up) the
    start at e = 0.975 (0.96 too) stopped the fit: SDP4's lunisolar periodics in e, of order
    1e-2, move the perigee by a * de, thousands of km, and SGP4 reported the start decayed
    (error 6) at the state nearest perigee. From e = 0.95 the fit recovers the set to 4e-8 km
    in 42 iterations.
    """
    z = resid(p)
    e = math.hypot(p[1], p[2])
    for e_try in ECC_RETRY:
        if z is not None:
            break
        if e_try < e:
            q = p.copy()
            q[1:3] *= e_try / e
            zq = resid(q)
            if zq is not None:
                return q, zq
    return p, z


def is_retrograde(r, v):
    """Whether the orbit through the TEME state (r, v) is retrograde (i > 90 deg)."""
    return bool(np.cross(r, v)[2] < 0)


def naive_fields(r_teme, v_teme, epoch_str, satnum=99999, bstar=0.0):
    """OMM fields made directly from an osculating TEME state: the naive TLE, for comparison."""
    r, v = np.asarray(r_teme), np.asarray(v_teme)
    retro = is_retrograde(r, v)
    p = initial_elements(r, v, bstar, retro)
    return elements_to_fields(p, epoch_str, satnum, None, retrograde=retro)


def ephemeris_identity(states, name, object_id, initial):
    """``name`` and ``object_id`` defaulting to an OEM's ``OBJECT_NAME`` and ``OBJECT_ID`` (an
    international designator ``YYYY-NNNP{PP}``; others, e.g. ``UNKNOWN``, are left out) where
    neither they nor ``initial`` give them (before audit46 the set fitted to an ISS OEM was
    named "FIT 99999" and had no designator; ``visviva fit-tle`` took the name only)."""
    segments = getattr(states, "segments", None)
    if not segments:
        return name, object_id
    meta = segments[0].metadata
    if name is None and (initial is None or not initial.name):
        name = str(meta.get("OBJECT_NAME", "") or "").strip() or None
    oid = str(meta.get("OBJECT_ID", "") or "").strip().upper()
    if not re.fullmatch(r"\d{4}-\d{3}[A-Z]{1,3}", oid):
        oid = ""
    if object_id is None and initial is None and oid:
        object_id = oid
    if initial is not None and oid:
        theirs = str(initial.to_omm()["OBJECT_ID"] or "").strip().upper()
        if theirs and theirs != oid:
            warnings.warn(
                f"the ephemeris is of OBJECT_ID {oid} but initial is {theirs} "
                f"({initial.name or 'unnamed'}, catalogue number {initial.satnum}): the new set "
                "takes initial's number, name, designator and B*. Pass that object's element set "
                "as initial (or none).", RuntimeWarning, stacklevel=3)
    return name, object_id


def initial_identity(initial, satnum, name, object_id, bstar):
    """``satnum``, ``name``, ``object_id`` and ``bstar`` with the defaults an initial element
    set gives: its catalogue number (for the default 99999), name, designator and B* (for
    ``bstar=None``; 0 without ``initial``). Before audit49 B* defaulted to 0 even with
    ``initial``, so ``fit_tle(..., initial=old, fit_bstar=False)`` held B* at 0, not at the old
    set's value: a day of ISS states propagated from its own set fitted to 1.3 km RMS instead
    of 3e-9 km, without a word."""
    if initial is None:
        return satnum, name, object_id, 0.0 if bstar is None else bstar
    from ..satellites.tle import Satellite

    if not isinstance(initial, Satellite):
        raise InvalidInputError(
            f"initial must be a vv.Satellite (an element set of the same object, e.g. "
            f"vv.Satellite.from_tle(...)); got {type(initial).__name__}.")
    if satnum == 99999:
        satnum = initial.satnum
    if object_id is None:
        object_id = initial.to_omm()["OBJECT_ID"] or None
    if bstar is None:
        bstar = float(initial.satrec.bstar)
    return satnum, name or initial.name, object_id, bstar


def warn_other_object(initial, sat) -> None:
    """Warn when the fitted set ``sat`` and ``initial`` look like different objects (their
    inclinations more than :data:`OTHER_OBJECT_INC_DEG` apart, or mean motions more than
    :data:`OTHER_OBJECT_MEAN_MOTION` relative): the new set took ``initial``'s catalogue number,
    name, designator and B*, which then belong to another object (before this check only the
    revolution number's disagreement was mentioned)."""
    if initial is None:
        return
    di = math.degrees(abs(sat.satrec.inclo - initial.satrec.inclo))
    n0, n1 = initial.satrec.no_kozai, sat.satrec.no_kozai
    dn = abs(n1 / n0 - 1.0) if n0 > 0.0 else math.inf
    if di <= OTHER_OBJECT_INC_DEG and dn <= OTHER_OBJECT_MEAN_MOTION:
        return
    per_day = 1440.0 / (2.0 * math.pi)
    warnings.warn(
        f"initial ({initial.name or 'unnamed'}, catalogue number {initial.satnum}) looks like "
        f"another object than these states: inclination {math.degrees(initial.satrec.inclo):.3f}"
        f" vs {math.degrees(sat.satrec.inclo):.3f} deg, mean motion {n0 * per_day:.5f} vs "
        f"{n1 * per_day:.5f} rev/day. The new set took its catalogue number, name, designator "
        "and B*: pass the same object's element set as initial, or none (and satnum=, name=).",
        RuntimeWarning, stacklevel=4)
