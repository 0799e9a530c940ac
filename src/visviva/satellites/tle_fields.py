"""The element-set fields that SGP4 itself does not use: the first derivative of the mean motion
(the TLE's "ndot / 2") and the revolution number at epoch.

A published element set carries both (Hoots & Roehrich 1980, Spacetrack Report No. 3; CelesTrak's
"NORAD Two-Line Element Set Format"): ``MEAN_MOTION_DOT`` is half the first time derivative of
the mean motion in rev/day**2, the coefficient of t**2 in the mean anomaly
M(t) = M0 + n0 t + (ndot/2) t**2 + (nddot/6) t**3 of the older SGP model; ``REV_AT_EPOCH`` counts
the ascending-node crossings since launch. SGP4 models drag through B* and ignores both fields
(propagation is the same whatever they hold), but users, catalogues and other software read them.

* :func:`mean_motion_dot` gives an element set's ndot/2: the rate of change of SGP4's own mean
  motion at the epoch, halved. On the SGP4 verification TLEs (Vallado et al. 2006) it matches the
  published field for drag-dominated orbits to a few per cent (e.g. 2.2266e-7 against 2.30e-7,
  0.1618 against 0.1615, 7.71e-3 against 7.66e-3 rev/day**2; see docs/satellites.md).
* :func:`revolutions_between` counts the ascending-node crossings between the epochs of two
  element sets of one object, from the argument of latitude of SGP4's mean elements (secular
  and drag terms, no short-period terms; w + M unwrapped, plus the equation of centre at the
  ends), so that a new set can carry the revolution number forward.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from .tle_checks import MINUTES_PER_DAY, raise_for_sgp4_status

__all__ = ["mean_motion_dot", "revolutions_between", "NDOT_TLE_MAX"]

_REV_DAY2_PER_RAD_MIN2 = MINUTES_PER_DAY**2 / (2.0 * math.pi)  # rad/min**2 -> rev/day**2
#: the largest |ndot/2| the TLE's column can hold (rev/day**2): ``.99999999``
NDOT_TLE_MAX = 0.99999999
#: mean-argument-of-latitude samples per revolution of the epoch's mean motion when counting
#: node crossings, times 1.25 (the unwrap needs steps under half a revolution: five per
#: revolution leave room for a mean motion that grows 2.5-fold under drag)
_SAMPLES_PER_REV = 4
#: largest along-track disagreement (rad) of two element sets where they meet before the count
#: of revolutions between them is reported as uncertain
_MISMATCH_WARN_RAD = math.pi / 2
#: largest drag-driven along-track drift (rev; |ndot/2| t**2 over half the gap between the
#: epochs) before the count is reported as resting on SGP4's drag model
_DRIFT_WARN_REV = 0.5
#: largest relative difference of the two sets' SGP4 mean motions where they meet before the
#: count is reported as uncertain (one object's sets agree to ~1e-3 over months of drag)
_MEAN_MOTION_WARN = 0.01


def mean_motion_dot(satrec, step_min: float = 1.0) -> float:
    """Half the first derivative of the (Kozai) mean motion at the epoch, rev/day**2.

    Parameters
    ----------
    satrec : sgp4.api.Satrec
        The element set (its own ``ndot`` field is not used).
    step_min : float
        Half-width of the central difference, minutes.

    Returns
    -------
    float
        ndot/2 in rev/day**2 (the TLE's and the OMM's ``MEAN_MOTION_DOT``), limited to what a
        TLE column holds (+-0.99999999; objects past it re-enter within hours). 0.0 where SGP4
        cannot propagate the set a minute either side of its epoch.

    Notes
    -----
    SGP4 carries the mean motion n(t) = n0'' / (1 - C1 t - D2 t**2 - ...)**3 (Hoots &
    Roehrich 1980, eq. for a and n with drag; deep-space sets add resonance terms), exposed by
    sgp4 as ``Satrec.nm`` after each call. Its central difference at the epoch,
    dn/dt ~ (n(h) - n(-h)) / 2h, scaled from the un-Kozai'd to the Kozai mean motion the element
    set gives, and halved, is the TLE's "first derivative of mean motion divided by two".
    """
    nm = []
    for dt_min in (-step_min, 0.0, step_min):
        err, _, _ = satrec.sgp4_tsince(dt_min)
        if err:
            return 0.0
        nm.append(satrec.nm)
    rate = (nm[2] - nm[0]) / (2.0 * step_min)  # rad/min**2, un-Kozai'd mean motion
    rate *= satrec.no_kozai / nm[1]
    half = 0.5 * rate * _REV_DAY2_PER_RAD_MIN2
    return float(min(max(half, -NDOT_TLE_MAX), NDOT_TLE_MAX))


def _latitude_argument(sat, tsince_min) -> tuple[np.ndarray, float, float, float]:
    """SGP4's mean argument of latitude w + M (rad, unwrapped) of ``sat`` at the minutes
    ``tsince_min`` from its epoch (from 0 outward, spaced under half a revolution), the
    equation of centre nu - M of the mean elements at the first and last time, and SGP4's mean
    motion (rad/min) at the last time."""
    from ..core.kepler import mean_to_true_anomaly

    rec = sat.satrec
    out = np.empty(len(tsince_min))
    centre = []
    for k, t in enumerate(tsince_min):
        err, _, _ = rec.sgp4_tsince(float(t))
        if err:
            raise_for_sgp4_status(np.array([err]), [sat.name], np.array([t]))
        out[k] = rec.om + rec.mm
        if k in (0, len(tsince_min) - 1):
            mean = math.remainder(rec.mm, 2.0 * math.pi)
            nu, _ = mean_to_true_anomaly(mean, min(max(rec.em, 0.0), 0.999999))
            centre.append(nu - mean)
    return np.unwrap(out), centre[0], centre[-1], float(rec.nm)


def _grid(t0_min: float, t1_min: float, rev_per_min: float) -> np.ndarray:
    """Times from t0 to t1 (either order), spaced at most 1/_SAMPLES_PER_REV revolution."""
    count = int(math.ceil(abs(t1_min - t0_min) * rev_per_min * _SAMPLES_PER_REV)) + 1
    return np.linspace(t0_min, t1_min, max(count, 2))


def _warn_if_uncertain(mismatch: float, drift: float, dn: float, days: float) -> None:
    """Warn when a revolution count may be off: the sets disagree along track by ``mismatch``
    (rad) or in mean motion by the fraction ``dn`` where they meet, or drag moves the object
    ``drift`` revolutions over half the ``days`` between them."""
    if dn > _MEAN_MOTION_WARN:
        why = (f"their mean motions differ by {dn:.1%} half-way between their epochs (are they "
               "one object?)")
    elif abs(mismatch) > _MISMATCH_WARN_RAD:
        why = (f"they disagree by {abs(mismatch) / (2 * math.pi):.2f} revolution along track "
               "half-way between their epochs")
    elif drift > _DRIFT_WARN_REV:
        why = (f"drag moves the object {drift:.1f} revolutions along track over half the gap, "
               "and the count relies on SGP4's drag model over it")
    else:
        return
    warnings.warn(
        f"the revolution number carried between element sets {days:.1f} days apart may be "
        f"off: {why}. Carry it from an element set of the same object nearer in time (with no "
        "manoeuvre in between).", RuntimeWarning, stacklevel=3)


def revolutions_between(old, new) -> tuple[int, float]:
    """Ascending-node crossings between the epochs of two element sets of one object.

    Parameters
    ----------
    old, new : Satellite
        Element sets of the same object (``new`` may be before ``old``).

    Returns
    -------
    crossings : int
        Signed count of the ascending-node crossings from ``old.epoch`` to ``new.epoch``
        (negative when ``new`` is earlier): ``REV_AT_EPOCH`` of ``new`` is that of ``old`` plus
        this.
    mismatch_rad : float
        How far the two sets disagree along track (in the argument of latitude, rad) at the
        midpoint of their epochs, where the count passes from one to the other.

    Raises
    ------
    SGP4Error
        Either set cannot be propagated to the midpoint (it decays first).

    Warns
    -----
    RuntimeWarning
        The count may be off by one or more: at the midpoint the sets disagree by more than a
        quarter revolution along track (a manoeuvre between them, or epochs too far apart) or
        by more than 1 % in mean motion (another object?), or drag moves the object more than
        half a revolution along track over half the gap (|ndot/2| t**2), so the count rests on
        SGP4's drag model over it.

    Notes
    -----
    NORAD's revolution number goes up by one at each ascending-node crossing. The crossings are
    the multiples of 2 pi passed by the argument of latitude u = w + nu of SGP4's mean elements
    (secular and drag terms, deep-space resonance included, no short-period terms), not
    estimated from the period: the mean argument of latitude w + M is sampled five times per
    revolution and unwrapped, and the equation of centre nu - M of the mean elements is added
    at the ends (so that an eccentric orbit's count changes where the mean orbit crosses the
    equator, not half an orbit's eccentric lag away). ``old`` carries u from its epoch to the
    midpoint, ``new`` from the midpoint to its epoch, and where they meet the new set's u is
    taken on the branch nearest the old one's.
    """
    a, b = old.satrec, new.satrec
    gap_min = ((b.jdsatepoch - a.jdsatepoch) + (b.jdsatepochF - a.jdsatepochF)) * MINUTES_PER_DAY
    mid = 0.5 * gap_min
    rate_a = a.no_kozai / (2.0 * math.pi)  # rev/min
    rate_b = b.no_kozai / (2.0 * math.pi)
    lam, c0, c1, n_old = _latitude_argument(old, _grid(0.0, mid, 1.25 * rate_a))
    start = (lam[0] + c0) % (2.0 * math.pi)  # the old epoch's u = w + nu, in [0, 2 pi)
    at_mid = start + (lam[-1] + c1) - (lam[0] + c0)
    # (sampled from the epoch outward, as for old: sgp4's deep-space resonance integrator
    # restarts from the epoch whenever a call comes nearer to it than the last one)
    lam, c0, c1, n_new = _latitude_argument(new, _grid(0.0, mid - gap_min, 1.25 * rate_b))
    mismatch = math.remainder(lam[-1] + c1 - at_mid, 2.0 * math.pi)
    end = at_mid + mismatch + (lam[0] + c0) - (lam[-1] + c1)
    half_days = 0.5 * abs(gap_min) / MINUTES_PER_DAY
    drift = max(abs(mean_motion_dot(a)), abs(mean_motion_dot(b))) * half_days**2  # rev
    _warn_if_uncertain(mismatch, drift, abs(n_new - n_old) / n_new, 2.0 * half_days)
    return int(math.floor(end / (2.0 * math.pi))), float(mismatch)
