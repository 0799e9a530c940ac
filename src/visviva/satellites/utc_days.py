"""UTC Julian dates with 86,400-second days: the clock SGP4 and TLE/OMM epochs count in.

The ``sgp4`` package (``jday``, ``Satrec.jdsatepoch``, ``sgp4_array(jd, fr)``) and skyfield's
``EarthSatellite`` count UTC in Julian days of exactly 86,400 s: ``jd = JD(calendar date) +
(3600 h + 60 m + s) / 86400``. astropy's ``Time(..., scale="utc").jd1/.jd2`` are ERFA's
*quasi* Julian dates instead, whose day on a leap-second day (e.g. 2016-12-31) lasts 86,401 s:
the two differ by up to 1 s on such a day (0.5 s at noon, ~7.5 km along a LEO track). Every
conversion between an astropy ``Time`` and sgp4's Julian dates goes through this module.

During a leap second (23:59:60.x UTC) these Julian dates run on past midnight (continuous
with the seconds before it, ``TAI - JD`` unchanged) and step back 1 s at 00:00:00: sgp4 has no
way to name that second, so two instants 1 s apart give the same date there.
"""

from __future__ import annotations

import numpy as np

__all__ = ["time_to_utc_days", "utc_days_to_time"]

DAY_S = 86400.0


def time_to_utc_days(t):
    """Julian dates (UTC, days of 86,400 s) of an astropy Time, as sgp4 takes them.

    Parameters
    ----------
    t : astropy.time.Time
        Any scale, any shape.

    Returns
    -------
    jd, fr : ndarray of float64
        Whole (midnight, ``x.5``) and fractional parts (days) of the UTC Julian dates, shape
        ``t.shape``; ``jd + fr`` is the date sgp4's ``jday`` gives for the UTC calendar
        date and time of ``t``.

    Raises
    ------
    erfa.ErfaError, ValueError
        ``t`` cannot be expressed in UTC (astropy's message).
    """
    import erfa

    from .._units import require_usable_time
    from .frames import offline_iers

    require_usable_time(t, "t")
    with offline_iers():  # a UT1 time needs the installed IERS table, never a download
        tu = t.utc
    # the UTC calendar day and the (quasi-JD) fraction of it elapsed
    iy, im, iday, frac = erfa.jd2cal(np.asarray(tu.jd1, dtype=np.float64),
                                     np.asarray(tu.jd2, dtype=np.float64))
    midnight, day_s = _midnight_and_length(iy, im, iday)
    # seconds since that midnight are the fraction times the day's length in SI seconds
    return midnight, np.asarray(frac * (day_s / DAY_S), dtype=np.float64)


def utc_days_to_time(jd, fr):
    """An astropy UTC Time from sgp4's Julian dates (UTC, days of 86,400 s).

    Parameters
    ----------
    jd, fr : array_like of float
        Whole and fractional parts of the UTC Julian dates (days), e.g. a ``Satrec``'s
        ``jdsatepoch`` and ``jdsatepochF``; broadcast together.

    Returns
    -------
    astropy.time.Time
        The same UTC calendar date and time (scale ``"utc"``, format ``"jd"``).
    """
    import erfa
    from astropy.time import Time

    jd, fr = np.broadcast_arrays(np.asarray(jd, dtype=np.float64),
                                 np.asarray(fr, dtype=np.float64))
    iy, im, iday, frac = erfa.jd2cal(jd, fr)  # a pure calendar: days of 86,400 s
    midnight, day_s = _midnight_and_length(iy, im, iday)
    # back to ERFA's quasi-JD fraction of that UTC day (which may last 86,401 s)
    return Time(midnight, frac * (DAY_S / day_s), format="jd", scale="utc")


def _midnight_and_length(iy, im, iday):
    """Julian date of 00:00 UTC of each calendar day and the day's length in SI seconds.

    The length is ERFA's (``eraDtf2d``): 86,400 s plus the leap second at the day's end, the
    drift of 1960-1971 UTC excluded; outside the leap-second table (before 1960, or years
    past the table's end) ERFA's "dubious year" status is ignored (astropy's UTC conversion
    already warned) and the day lasts 86,400 s.
    """
    import warnings

    import erfa

    d1, d2 = erfa.cal2jd(iy, im, iday)
    ny, nm, nd, _ = erfa.jd2cal(d1, d2 + 1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", erfa.ErfaWarning)
        dat0 = erfa.dat(iy, im, iday, 0.0)
        dat12 = erfa.dat(iy, im, iday, 0.5)
        dat24 = erfa.dat(ny, nm, nd, 0.0)
    leap = dat24 - (2.0 * dat12 - dat0)
    return np.asarray(d1 + d2, dtype=np.float64), DAY_S + leap
