"""Offline positions of the Sun, Moon and planets for perturbations and mission design.

Source, in order of preference:

1. **JPL DE421** through ``jplephem`` (the ``ephem`` extra: ``pip install visviva[ephem]``),
   whose ``de421`` package tabulates 1899-12-04 to 2200-02-01 (TDB; times outside are
   refused). DE421 agrees with the current DE440 to about 0.3 km for the Earth and Mars and
   a few metres for the Moon over 1950-2050 (Folkner et al. 2009, 2021).
2. Otherwise astropy's built-in ephemeris (ERFA ``epv00`` for the Earth and Sun, ``moon98`` for
   the Moon, ``plan94`` for the planets): a few km for the Sun, ~10-30 km for the Moon and
   arcsecond-level directions for the planets; enough for perturbations, not for navigation.

All vectors are in the ICRF axes (the GCRS axes for geocentric vectors), km and km/s, at the
TDB instant of the given astropy ``Time``. Which backend is in use: :func:`backend`.
"""

from __future__ import annotations

import functools

import numpy as np

from .._units import advance_epoch, to_quantity
from ..constants import DAY_S
from ..errors import InvalidInputError

__all__ = [
    "backend",
    "position_velocity",
    "sun_position",
    "moon_position",
    "planet_heliocentric",
    "KNOWN_BODIES",
]

#: Names :func:`position_velocity` knows (planets are system barycentres, as in DE421).
KNOWN_BODIES = (
    "sun",
    "mercury",
    "venus",
    "earth",
    "moon",
    "earth-moon-barycenter",
    "mars",
    "jupiter",
    "saturn",
    "uranus",
    "neptune",
    "pluto",
)


@functools.lru_cache(maxsize=1)
def _de421():
    try:
        import de421
        from jplephem.ephem import Ephemeris
    except ImportError:
        return None
    return Ephemeris(de421)


def backend() -> str:
    """``"de421"`` when jplephem + de421 are installed, else ``"astropy-builtin"``."""
    return "de421" if _de421() is not None else "astropy-builtin"


def _check_name(name: str) -> str:
    key = str(getattr(name, "name", name)).lower()
    if key == "emb":
        key = "earth-moon-barycenter"
    if key not in KNOWN_BODIES:
        raise InvalidInputError(
            f"unknown body {name!r} for the ephemeris; use one of {', '.join(KNOWN_BODIES)} "
            "(or vv.SUN, vv.MOON, vv.MARS, ...)."
        )
    return key


def _barycentric_de421(eph, key, jd1, jd2):
    """Barycentric r (km), v (km/s), shape (N, 3), from the old-style DE421 package."""

    def pv(name):
        p, v = eph.position_and_velocity(name, jd1, jd2)
        return np.asarray(p).T, np.asarray(v).T / DAY_S

    if key in ("earth", "moon", "earth-moon-barycenter"):
        emb_r, emb_v = pv("earthmoon")
        if key == "earth-moon-barycenter":
            return emb_r, emb_v
        moon_r, moon_v = pv("moon")  # geocentric Moon
        share = eph.earth_share  # 1 / (1 + EMRAT)
        earth_r = emb_r - share * moon_r
        earth_v = emb_v - share * moon_v
        if key == "earth":
            return earth_r, earth_v
        return earth_r + moon_r, earth_v + moon_v
    return pv(key)


def _barycentric_astropy(key, t):
    from astropy.coordinates import get_body_barycentric_posvel, solar_system_ephemeris

    name = "earth-moon-barycenter" if key == "earth-moon-barycenter" else key
    with solar_system_ephemeris.set("builtin"):
        p, v = get_body_barycentric_posvel(name, t)
    r = p.xyz.to_value("km").T
    vv = v.xyz.to_value("km/s").T
    return np.atleast_2d(r), np.atleast_2d(vv)


def _as_time(t):
    from astropy.time import Time

    if not isinstance(t, Time):
        raise InvalidInputError(
            f"the ephemeris needs an astropy Time, got {type(t).__name__}; pass e.g. "
            "Time('2024-03-20T12:00:00', scale='utc')."
        )
    return t


def position_velocity(name, t, center="earth"):
    """Position and velocity of body ``name`` relative to ``center`` at times ``t``.

    Parameters
    ----------
    name, center : str or Body
        Names from :data:`KNOWN_BODIES` (a :class:`visviva.bodies.Body` gives its name).
    t : astropy.time.Time
        Instants, any shape (any scale; converted to TDB).

    Returns
    -------
    r : Quantity (..., 3), km
    v : Quantity (..., 3), km/s
        ICRF axes; shape ``t.shape + (3,)``: (3,) for a scalar ``t``, (N, 3) for N times.
    """
    t = _as_time(t)
    key = _check_name(name)
    ckey = _check_name(center)
    from .frames import offline_iers

    with offline_iers():  # a time in UT1 needs the installed IERS table, never a download
        tt = (t.reshape(1) if t.isscalar else t.ravel()).tdb
    eph = _de421()
    if eph is not None:
        tdb = tt
        jd1 = np.asarray(tdb.jd1, dtype=float)
        jd2 = np.asarray(tdb.jd2, dtype=float)
        lo, hi = eph.jalpha, eph.jomega  # the package's span: 1899-12-04 to 2200-02-01 TDB
        if np.any(jd1 + jd2 < lo) or np.any(jd1 + jd2 > hi):
            raise InvalidInputError(
                "the DE421 tables cover 1899-12-04 to 2200-02-01 (TDB); the requested times "
                "fall outside. Uninstall the ephem extra to use astropy's built-in "
                "(lower-accuracy) ephemeris."
            )
        r, v = _barycentric_de421(eph, key, jd1, jd2)
        if ckey != "ssb":
            rc, vc = _barycentric_de421(eph, ckey, jd1, jd2)
            r, v = r - rc, v - vc
    else:
        r, v = _barycentric_astropy(key, tt)
        rc, vc = _barycentric_astropy(ckey, tt)
        r, v = r - rc, v - vc
    r = r.reshape(t.shape + (3,))
    v = v.reshape(t.shape + (3,))
    return to_quantity(np.ascontiguousarray(r), "length"), to_quantity(
        np.ascontiguousarray(v), "speed"
    )


def sun_position(t):
    """Geocentric position of the Sun (GCRS axes), Quantity (..., 3) km."""
    return position_velocity("sun", t, "earth")[0]


def moon_position(t):
    """Geocentric position of the Moon (GCRS axes), Quantity (..., 3) km."""
    return position_velocity("moon", t, "earth")[0]


def planet_heliocentric(name, t):
    """Heliocentric position and velocity (ICRF axes) of a planet (system barycentre)."""
    return position_velocity(name, t, "sun")


def tabulate(names, epoch, t_start_s, t_end_s, step_s, center="earth"):
    """Positions and velocities of ``names`` on a uniform grid, for the compiled Hermite tables.

    Returns
    -------
    t0_s, step_s : float
        Grid start (s from ``epoch``) and step (s).
    r, v : ndarray (B, N, 3)
        Positions (km) and velocities (km/s) relative to ``center``.
    """
    from astropy import units as u

    n = max(2, int(np.ceil((t_end_s - t_start_s) / step_s)) + 3)
    t0 = t_start_s - step_s
    grid = t0 + step_s * np.arange(n)
    times = advance_epoch(epoch, grid)  # Cowell's offsets are TT seconds from the epoch
    r = np.empty((len(names), n, 3))
    v = np.empty((len(names), n, 3))
    for i, name in enumerate(names):
        rq, vq = position_velocity(name, times, center)
        r[i] = rq.to_value(u.km)
        v[i] = vq.to_value(u.km / u.s)
    return t0, step_s, r, v
