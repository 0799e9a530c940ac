"""Earth-rotation matrices from ERFA and astropy's IERS table, without astropy.coordinates.

The three rotations that astropy's ``TEME``, ``CIRS``/``GCRS`` and ``ITRS`` frames apply,
built from the same ERFA routines with the same time scales and Earth-orientation data, so the
matrices are identical to astropy's (tests/test_frames.py compares them element by element).
Importing ``astropy.coordinates`` (its frame graph, representations and every built-in frame)
costs about 0.2-0.4 s of CPU in a fresh process; :mod:`erfa`, :mod:`astropy.time` and
:mod:`astropy.utils.iers` are all these need (issue 11: the warm ``Satellite.gcrs`` budget).

The matrices (IERS Conventions 2010, ch. 5; Vallado et al. 2006, AIAA 2006-6753, for TEME):

* TEME -> ITRS: ``W(xp, yp, 0) R3(GMST82(UT1))`` (ERFA ``gmst82``, ``pom00``, ``c2tcio``;
  no TIO locator s', as in Vallado et al.).
* GCRS -> CIRS: ``C(X, Y, s)`` of the IAU 2006/2000A precession-nutation (ERFA ``c2i06a``,
  TT), without the IERS celestial-pole offsets dX, dY (as astropy).
* CIRS -> ITRS: ``W(xp, yp, s') R3(ERA(UT1))`` (ERFA ``era00``, ``sp00``, ``pom00``).

Polar motion (xp, yp) is interpolated in the IERS table that astropy's ``Time`` uses for
UT1 - UTC (``earth_orientation_table``); outside the table it falls back to the 50-year mean
pole with a warning, as astropy does.
"""

from __future__ import annotations

import warnings

import erfa
import numpy as np

__all__ = ["teme_to_itrs_mat", "gcrs_to_cirs_mat", "cirs_to_itrs_mat", "polar_motion_rad"]

#: the mean pole (arcsec) used outside the IERS table: astropy's default, the 50-year mean
MEAN_POLE_ARCSEC = (0.035, 0.29)


def _jd12(t, scale: str):
    """Two-part Julian date of the astropy Time ``t`` in ``scale`` ("ut1" or "tt").

    Where UT1 - UTC is unavailable (astropy raises ``IERSRangeError`` when its
    ``iers_degraded_accuracy`` setting is "error") UT1 = UTC is assumed with a warning, as
    astropy's frames do.
    """
    from astropy.utils import iers
    from astropy.utils.exceptions import AstropyWarning

    if t.scale == scale:
        return t.jd1, t.jd2
    if scale == "ut1":
        from .._eop_table import check_carried_ut1

        check_carried_ut1(t)
    try:
        other = getattr(t, scale)
    except iers.IERSRangeError as exc:
        warnings.warn(f"{exc.args[0]} Assuming UT1-UTC=0 for coordinate transformations.",
                      AstropyWarning, stacklevel=3)
        other = t
    return other.jd1, other.jd2


def polar_motion_rad(t):
    """Polar motion (xp, yp), radians, at the astropy Time ``t`` from astropy's IERS table.

    Outside the table: the mean pole :data:`MEAN_POLE_ARCSEC`, with an ``AstropyWarning``.
    """
    from astropy import units as u
    from astropy.utils import iers
    from astropy.utils.exceptions import AstropyWarning

    from .._eop_table import issue_once

    xp, yp, status = iers.earth_orientation_table.get().pm_xy(t, return_status=True)
    for code, when in ((iers.TIME_BEFORE_IERS_RANGE, "before"),
                       (iers.TIME_BEYOND_IERS_RANGE, "after")):
        outside = status == code
        if np.any(outside):
            xp[outside] = MEAN_POLE_ARCSEC[0] * u.arcsec
            yp[outside] = MEAN_POLE_ARCSEC[1] * u.arcsec
            # once per visviva call (a rotation with its velocity evaluates the pole at t and
            # t +- 0.5 s: three identical warnings before); none for TEME <-> GCRS, where the
            # pole cancels
            issue_once(
                f"pole-{when}",
                f"Tried to get polar motions for times {when} IERS data is valid. Defaulting "
                "to polar motion from the 50-yr mean for those. This may affect precision at "
                "the arcsec level.", AstropyWarning)
    return xp.to_value(u.rad), yp.to_value(u.rad)


def teme_to_itrs_mat(t) -> np.ndarray:
    """Rotation matrices TEME -> ITRS at the astropy Time ``t`` (shape t.shape + (3, 3)).

    Parameters
    ----------
    t : astropy Time
        The times (any scale).

    Returns
    -------
    ndarray, shape t.shape + (3, 3)
        ``r_itrs = M @ r_teme``.

    Notes
    -----
    Greenwich mean sidereal time (IAU 1982) of UT1, then polar motion without the TIO locator
    (Vallado et al. 2006): ERFA ``c2tcio(I, gmst82(UT1), pom00(xp, yp, 0))``.
    """
    gmst = erfa.gmst82(*_jd12(t, "ut1"))
    xp, yp = polar_motion_rad(t)
    return erfa.c2tcio(np.eye(3), gmst, erfa.pom00(xp, yp, 0))


def gcrs_to_cirs_mat(t) -> np.ndarray:
    """Celestial-to-intermediate matrices GCRS -> CIRS (IAU 2006/2000A) at ``t`` (TT).

    Parameters and result as in :func:`teme_to_itrs_mat` (``r_cirs = M @ r_gcrs``).

    Notes
    -----
    ERFA ``c2i06a`` (IAU 2006 precession, IAU 2000A nutation, CIO locator s), ~70 us a time.
    """
    return erfa.c2i06a(*_jd12(t, "tt"))


def cirs_to_itrs_mat(t) -> np.ndarray:
    """Rotation matrices CIRS -> ITRS at the astropy Time ``t`` (shape t.shape + (3, 3)).

    Parameters and result as in :func:`teme_to_itrs_mat` (``r_itrs = M @ r_cirs``).

    Notes
    -----
    Earth rotation angle of UT1 and polar motion with the TIO locator s' (of TT):
    ERFA ``c2tcio(I, era00(UT1), pom00(xp, yp, sp00(TT)))``.
    """
    xp, yp = polar_motion_rad(t)
    sp = erfa.sp00(*_jd12(t, "tt"))
    era = erfa.era00(*_jd12(t, "ut1"))
    return erfa.c2tcio(np.eye(3), era, erfa.pom00(xp, yp, sp))
