"""A first orbit from a table of observations, for :func:`~visviva.fit_orbit` without a guess."""

from __future__ import annotations

import math

import numpy as np

from ..constants import C_KM_S
from ..errors import InvalidInputError
from .angles import gauss_angles, state_at
from .iod import gibbs, gm_value, herrick_gibbs

__all__ = ["initial_orbit"]


def _first_group(idx, secs, gap_s=300.0):
    """The leading run of ``idx`` whose successive times are at most ``gap_s`` apart."""
    end = 1
    while end < len(idx) and secs[idx[end]] - secs[idx[end - 1]] <= gap_s:
        end += 1
    return idx[:end]


def initial_orbit(observations, gm):
    """A first state from a table of observations, for :func:`~visviva.fit_orbit`.

    Parameters
    ----------
    observations : Observations
        Positions, or az/el or RA/Dec rows with a range row of the same station at the same
        time (together a position), or at least three RA/Dec or az/el rows in one pass.
    gm : Quantity (km^3/s^2), Body or float (km^3/s^2)
        Gravitational parameter.

    Returns
    -------
    StateVectors
        The GCRS state at the middle of the three observations used, with that epoch.

    Raises
    ------
    InvalidInputError
        The table has neither three positions (or angle + range pairs) nor three RA/Dec rows
        within one pass, or its first three fixes are not one short arc.

    Notes
    -----
    Three position fixes from the first pass (fixes at most 5 min apart) and at most an eighth
    of the circular period at the first fix's radius from its first fix: first, middle and
    last. Gibbs when they span more than 5 deg of arc, Herrick-Gibbs otherwise; the orbit must
    reach the first and last fix at their times (two-body, within a tenth of their distance),
    else :class:`~visviva.InvalidInputError` (fixes a revolution apart). With only angles,
    Gauss's method on the first, middle and last RA/Dec or az/el (turned to GCRS RA/Dec) of
    the first pass.
    """
    g = gm_value(gm)
    kinds = observations.kinds
    vals = observations.values
    secs = observations.offsets_s(observations.times[0])
    site_r, _, enu = observations.sites()
    fixes = {}
    delays = {}  # s: how long before its time tag a fix's light left the satellite (audit59)
    for i in np.flatnonzero(kinds == "position"):
        fixes.setdefault(i, vals[i, :3])
    ranges = {(round(secs[i], 6), id(observations.stations[i])): vals[i, 0]
              for i in np.flatnonzero(kinds == "range")}  # fmt: skip
    for i in np.flatnonzero((kinds == "azel") | (kinds == "radec")):
        rho = ranges.get((round(secs[i], 6), id(observations.stations[i])))
        if rho is None:
            continue
        a, b = vals[i, 0], vals[i, 1]
        if kinds[i] == "azel":
            los = enu[i].T @ np.array([np.cos(b) * np.sin(a), np.cos(b) * np.cos(a), np.sin(b)])
        else:
            los = np.array([np.cos(b) * np.cos(a), np.cos(b) * np.sin(a), np.sin(b)])
        fixes.setdefault(i, site_r[i] + rho * los)
        if observations.light_time:  # the direction (and range) of light that left rho/c ago
            delays[i] = rho / C_KM_S
    order = np.array(sorted(fixes, key=lambda i: secs[i]), dtype=np.int64)
    if order.size >= 3:
        group = _first_group(order, secs)
        if group.size < 3:
            group = order
        # a short arc: Gibbs knows no times, and fixes a revolution or more apart (a day of
        # GNSS fixes) gave an orbit flown backwards, 15 km/s off (audit20)
        r0 = float(np.linalg.norm(fixes[group[0]]))
        limit = 2.0 * math.pi * math.sqrt(r0**3 / g) / SHORT_ARC_PERIODS
        within = group[secs[group] - secs[group[0]] <= limit]
        if within.size < 3:
            within = group[:3]
        i1, i2, i3 = within[0], within[len(within) // 2], within[-1]
        t1, t2, t3 = (secs[i] - delays.get(i, 0.0) for i in (i1, i2, i3))
        if t1 < t2 < t3:
            r1, r2, r3 = fixes[i1], fixes[i2], fixes[i3]
            arc = max(_angle(r1, r2), _angle(r2, r3))
            if arc > math.radians(5.0):
                v2 = gibbs(r1, r2, r3, g, coplanar_tol=math.radians(5.0))
            else:
                v2 = herrick_gibbs(r1, r2, r3, t1, t2, t3, g)
            v2 = np.asarray(v2)
            _check_on_time(r1, r2, r3, v2, t1 - t2, t3 - t2, g, observations.times[[i1, i3]])
            if secs[i2] != t2:  # from the middle fix's emission time to its time tag
                from ..core.universal import propagate_scalar

                out = propagate_scalar(*(float(x) for x in r2), *(float(x) for x in v2), g,
                                       float(secs[i2] - t2))
                if out[0] == 0:
                    r2, v2 = np.array(out[1:4]), np.array(out[4:7])
            return state_at(r2, v2, g, observations.times[i2])
    sights = np.flatnonzero((kinds == "radec") | (kinds == "azel"))
    if sights.size >= 3:
        group = _first_group(sights, secs)
        if group.size >= 3:
            pick = [group[0], group[len(group) // 2], group[-1]]
            ra, dec = _gcrs_angles(kinds[pick], vals[pick], enu[pick])
            return gauss_angles(ra, dec, observations.times[pick], site_r[pick], g,
                                light_time=observations.light_time)
    raise InvalidInputError(
        "cannot find a first orbit in these observations: give three positions, az/el or RA/Dec "
        "rows each with a range from the same station at the same time, or three RA/Dec or "
        "az/el rows within one pass; or pass initial=vv.StateVectors(...) yourself."
    )


def _gcrs_angles(kinds, vals, enu):
    """GCRS right ascension and declination (rad) of RA/Dec and az/el rows (an az/el's
    direction turned from the station's east-north-up axes; refraction, which a first orbit
    can ignore, left in; the light time is gauss_angles's)."""
    a, b = vals[:, 0], vals[:, 1]
    up = np.stack([np.cos(b) * np.sin(a), np.cos(b) * np.cos(a), np.sin(b)], axis=-1)
    los = np.einsum("nji,nj->ni", enu, up)  # ENU -> GCRS: the rows' transpose
    azel = kinds == "azel"
    ra = np.where(azel, np.mod(np.arctan2(los[:, 1], los[:, 0]), 2 * np.pi), a)
    dec = np.where(azel, np.arcsin(np.clip(los[:, 2], -1.0, 1.0)), b)
    return ra, dec


#: the first orbit's fixes span at most this fraction of the circular period at the first
#: fix's radius (1/8: 11.6 min in LEO, 3 h in GEO)
SHORT_ARC_PERIODS = 8.0
#: largest miss of r1 or r3 by the first orbit flown over the fixes' times, as a fraction of
#: the chord |r3 - r1| (noise and the perturbations over a short arc stay far below it)
ON_TIME_FRACTION = 0.1


def _check_on_time(r1, r2, r3, v2, dt1, dt3, gm, ends):
    """Refuse a first orbit that does not reach r1 and r3 at their times (two-body)."""
    from ..core.universal import propagate_scalar

    chord = float(np.linalg.norm(r3 - r1))
    miss = 0.0
    for r, dt in ((r1, dt1), (r3, dt3)):
        out = propagate_scalar(*(float(x) for x in r2), *(float(x) for x in v2), gm, float(dt))
        miss = max(miss, math.inf if out[0] != 0 else float(np.linalg.norm(np.array(out[1:4]) - r)))
    if not miss <= ON_TIME_FRACTION * chord:
        raise InvalidInputError(
            f"cannot find a first orbit: the three fixes used ({ends[0].utc.isot} to "
            f"{ends[1].utc.isot} UTC) are not one short two-body arc (the orbit through them "
            f"misses them by {miss:.4g} km at their times: they are likely a revolution or "
            "more apart, or not of one object). Give fixes minutes apart in the first pass, "
            "or pass initial=vv.StateVectors(...) yourself."
        )


def _angle(a, b):
    c = float(a @ b) / (float(np.linalg.norm(a)) * float(np.linalg.norm(b)))
    return math.acos(max(-1.0, min(1.0, c)))
