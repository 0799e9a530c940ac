"""Look angles: azimuth, elevation, range, their rates, and topocentric RA/Dec from a station.

The geometry is done in the Earth-fixed frame (ITRS), where the station and its local axes are
at rest: the satellite's ITRS state comes from astropy's frame rotation (one 6 x 6 map per time,
:func:`visviva.satellites.frames.transform_matrices`, shared by every satellite), and range,
azimuth, elevation and their rates follow from the site-to-satellite vector by Vallado's RAZEL
(:func:`visviva.core.topocentric.razel_many`). Topocentric right ascension and declination use
the same vector rotated to GCRS axes. Geometric by default: no refraction, no light time.
"""

from __future__ import annotations

import math

import numpy as np
from astropy import units as u
from astropy.time import Time

from ..core import topocentric as _topo
from ..errors import InvalidInputError
from .doppler import SPEED_OF_LIGHT_KM_S, doppler_shift
from .earthfixed import GMST_RATE_RAD_S

__all__ = ["LookAngles", "look", "refraction_deg", "refraction_slope"]


class LookAngles:
    """Where to point: the result of :meth:`visviva.GroundStation.look`.

    Attributes
    ----------
    azimuth : Quantity (deg)
        In [0, 360), from north through east.
    elevation : Quantity (deg)
        Above the horizon plane (the ellipsoid's tangent plane); apparent (refracted) when
        asked for.
    range : Quantity (km)
    range_rate : Quantity (km/s)
        Positive when receding.
    azimuth_rate, elevation_rate : Quantity (deg/s)
    ra, dec : Quantity (deg)
        Topocentric right ascension and declination, GCRS axes.
    t : astropy Time
        The times.
    doppler : Quantity (Hz) or None
        Received minus transmitted frequency when a ``frequency`` was given.

    Every array has the shape of ``t``, with a leading satellite axis for a catalogue.
    """

    __slots__ = ("azimuth", "elevation", "range", "range_rate", "azimuth_rate",
                 "elevation_rate", "ra", "dec", "t", "doppler")

    def __init__(self, **fields):
        for name in self.__slots__:
            setattr(self, name, fields.get(name))

    @property
    def shape(self) -> tuple:
        return self.azimuth.shape

    def __repr__(self):
        if self.azimuth.size == 1:
            return (f"LookAngles(azimuth={self.azimuth.ravel()[0]:.4f}, "
                    f"elevation={self.elevation.ravel()[0]:.4f}, "
                    f"range={self.range.ravel()[0]:.3f})")
        return f"LookAngles(shape={self.shape})"


def refraction_deg(elevation_deg, pressure_hpa=1010.0, temperature_c=10.0):
    """Atmospheric refraction to add to a geometric elevation (deg).

    Parameters
    ----------
    elevation_deg : float, array_like or Quantity (angle)
        Geometric elevation: plain numbers in degrees, or an angle Quantity (converted).
    pressure_hpa : float
        Air pressure at the site, hPa (>= 0; default 1010).
    temperature_c : float
        Air temperature at the site, deg C (above -273; default 10).

    Returns
    -------
    ndarray (deg), or Quantity (deg) for a Quantity ``elevation_deg``

    Notes
    -----
    Sæmundsson's formula (Meeus 1998, *Astronomical Algorithms*, eq. 16.4) with Meeus' zenith
    term: ``R = 1.02' / tan(h + 10.3 / (h + 5.11)) + 0.0019279'`` (0 at ``h`` = 90 deg) with
    ``h`` the geometric elevation in degrees, scaled by ``(P / 1010 hPa) (283 K / T)``; zero
    below -1 deg (the formula's range). Consistent with Bennett's inverse formula to 0.07'.
    """
    from astropy import units as u

    from .._units import is_quantity, to_array

    quantity = is_quantity(elevation_deg)
    if quantity:
        h = np.degrees(to_array(elevation_deg, "angle", "elevation_deg"))
    else:
        h = np.asarray(elevation_deg, dtype=np.float64)
    r_arcmin = _saemundsson_arcmin(h)[0] * _conditions(pressure_hpa, temperature_c)
    out = np.where(h >= -1.0, r_arcmin / 60.0, 0.0)
    return out * u.deg if quantity else out


def refraction_slope(elevation_deg, pressure_hpa=1010.0, temperature_c=10.0):
    """dR/dE of :func:`refraction_deg` (deg of refraction per deg of geometric elevation,
    negative: -0.02 at 5 deg, -0.04 at 2.5 deg), 0 below -1 deg where the refraction is 0.

    Parameters
    ----------
    elevation_deg : float or array_like
        Geometric elevation, deg.
    pressure_hpa, temperature_c : float
        The site's air, as :func:`refraction_deg`.

    Returns
    -------
    ndarray
        The slope; ``1 + slope`` maps a change of geometric elevation (or its rate) to the
        apparent one.
    """
    h = np.asarray(elevation_deg, dtype=np.float64)
    slope = _saemundsson_arcmin(h)[1] * _conditions(pressure_hpa, temperature_c) / 60.0
    return np.where(h >= -1.0, slope, 0.0)


def _conditions(pressure_hpa, temperature_c) -> float:
    """Meeus' factor ``(P / 1010 hPa) (283 K / T)`` for the site's air; checked."""
    p = float(pressure_hpa)
    t = float(temperature_c)
    if not (math.isfinite(p) and p >= 0.0):
        raise InvalidInputError(f"pressure_hpa must be >= 0 hPa and finite, got {p!r}.")
    if not (math.isfinite(t) and t > -273.0):
        raise InvalidInputError(f"temperature_c must be above -273 deg C (the formula's 0 K), "
                                f"got {t!r}.")
    return (p / 1010.0) * (283.0 / (273.0 + t))


def _saemundsson_arcmin(h):
    """Sæmundsson's refraction (arcmin, standard air) and its slope dR/dh (arcmin per deg) at
    geometric elevations ``h`` (deg); finite (not meaningful) below -1 deg."""
    with np.errstate(divide="ignore", invalid="ignore"):
        hh = np.where(h >= -1.0, h, 0.0)  # the formula's pole at -5.11 deg lies outside
        x = np.radians(hh + 10.3 / (hh + 5.11))
        r = 1.02 / np.tan(x) + 0.0019279
        slope = -1.02 / np.sin(x) ** 2 * (np.pi / 180.0) * (1.0 - 10.3 / (hh + 5.11) ** 2)
    return r, slope


#: Largest distance from the geocentre to a station (km): a margin for the light time bound.
_STATION_REACH_KM = 6400.0


def _check_states_time(states, t) -> None:
    """Refuse a ``t`` farther from the states' own epoch than light can travel between them and
    a station: look() rotates the states to the Earth-fixed frame at ``t``, so a later ``t``
    would silently give another place in the sky. A difference up to the light time (states
    at emission, ``t`` at reception) is the documented use."""
    epoch = states.epoch
    if epoch is None or t is None:
        return
    try:
        dt = np.abs(np.asarray((t - epoch).to_value(u.s), dtype=float))
        dist = np.linalg.norm(states.r.to_value(u.km), axis=-1)
        limit = (np.broadcast_to(dist, np.broadcast_shapes(dist.shape, dt.shape))
                 + _STATION_REACH_KM) / SPEED_OF_LIGHT_KM_S + 1e-3
        bad = dt > limit
    except ValueError:  # shapes that do not broadcast are reported by the caller
        return
    if np.any(bad):
        worst = float(np.max(dt))
        raise InvalidInputError(
            f"t differs from the states' epoch by up to {worst:.6g} s, more than the light time "
            "between them and a station: look() evaluates the states at t, so this would be "
            "another place in the sky. Pass states at t (e.g. sat.gcrs(t)), or omit t to use "
            "their epoch; a difference up to the light time (states at emission, t at "
            "reception) is accepted."
        )


def _check_geocentric(states) -> None:
    """Refuse states whose GM is (to 0.1 %) another known body's: look() takes them as
    geocentric GCRS, so a lunar or heliocentric state would give a place in the sky silently."""
    from ..satellites.cowell import central_body

    gm = float(np.asarray(states.gm.to_value(u.km**3 / u.s**2)).ravel()[0])
    body = central_body(gm, ())
    if body.name != "earth":
        raise InvalidInputError(
            f"the states' gm = {gm:.10g} km3/s2 is {body.name}'s: look() needs geocentric "
            "states with GCRS axes (gm=vv.EARTH), e.g. sat.gcrs(t)."
        )


def _target_states(target, t):
    """Earth-fixed (ITRS) r, v (km, km/s) of shape lead + t.shape + (3,), the times, and the
    ITRS -> GCRS rotations (T, 3, 3) of the flat times."""
    from ..satellites.catalog import Catalog, propagate_sgp4_batch
    from ..satellites.frames import transform_matrices
    from ..satellites.tle import Satellite, SatelliteStates
    from ..states import StateVectors

    if isinstance(target, (Satellite, Catalog)):
        if not isinstance(target, Satellite) and len(target) == 0:
            raise InvalidInputError("the catalogue is empty; pass at least one Satellite.")
        if not isinstance(t, Time):
            raise InvalidInputError(
                f"t must be an astropy Time for a satellite target, got {type(t).__name__}; "
                "pass e.g. Time('2024-05-01T20:00:00') + np.arange(60) * u.s."
            )
        flat = t.ravel()
        if isinstance(target, Satellite):
            st = target.teme(flat)
            r = st.r.to_value(u.km)[None]
            v = st.v.to_value(u.km / u.s)[None]
            lead = ()
        else:
            b = propagate_sgp4_batch(target, flat)
            r, v = b.r.to_value(u.km), b.v.to_value(u.km / u.s)
            lead = (len(target),)
        source = "teme"
    elif isinstance(target, StateVectors):
        if t is None:
            t = target.epoch
        if not isinstance(t, Time):
            raise InvalidInputError(
                "look() needs the states' times: give the StateVectors an epoch or pass t "
                "(astropy Time)."
            )
        _check_geocentric(target)
        source = getattr(target, "frame", "gcrs")
        if source == "itrs":
            raise InvalidInputError("pass GCRS or TEME states (sat.gcrs(t)), not ITRS ones.")
        try:
            shape = np.broadcast_shapes(target.shape, t.shape)
        except ValueError as exc:
            raise InvalidInputError(
                f"states of shape {target.shape} and t of shape {t.shape} do not broadcast."
            ) from exc
        _check_states_time(target, t)
        t = t if t.shape == shape else Time(np.broadcast_to(t.jd1, shape),
                                              np.broadcast_to(t.jd2, shape),
                                              format="jd", scale=t.scale)
        flat = t.ravel()
        r = np.broadcast_to(target.r.to_value(u.km), shape + (3,)).reshape(1, -1, 3)
        v = np.broadcast_to(target.v.to_value(u.km / u.s), shape + (3,)).reshape(1, -1, 3)
        lead = ()
    else:
        raise InvalidInputError(
            f"target must be a Satellite, a Catalog or StateVectors (GCRS), got "
            f"{type(target).__name__}."
        )
    if isinstance(target, SatelliteStates) and target.frame == "teme":
        source = "teme"
    m = transform_matrices(flat, source, "itrs")  # (T, 6, 6)
    y = np.concatenate([r, v], axis=-1)  # (N, T, 6)
    out = np.einsum("tij,ntj->nti", m, y)
    r_i, v_i = out[..., :3], out[..., 3:]
    rot_ig = np.swapaxes(transform_matrices(flat, "gcrs", "itrs")[:, :3, :3], -1, -2)
    return r_i, v_i, t, lead, rot_ig


def look(station, target, t=None, *, refraction: bool = False, light_time: bool = False,
         frequency=None) -> LookAngles:
    """Azimuth, elevation, range, range rate, their rates and topocentric RA/Dec of a target.

    Parameters
    ----------
    station : GroundStation
    target : Satellite, Catalog or StateVectors
        A satellite (SGP4), a catalogue (adds a leading satellite axis), or states in the GCRS
        (``sat.gcrs(t)``, or any :class:`visviva.StateVectors` with GCRS axes).
    t : astropy Time, optional
        Times, scalar or any shape; for states it defaults to their epoch, and a given ``t``
        may differ from the epoch by at most the light time to a station (states at emission,
        ``t`` at reception); more raises :class:`~visviva.errors.InvalidInputError`.
    refraction : bool
        Add standard atmospheric refraction to the elevation (:func:`refraction_deg`:
        1010 hPa, 10 deg C; about 0.48 deg at the horizon) and its rate to ``elevation_rate``.
        Default: geometric.
    light_time : bool
        Use the satellite's position when the light received at ``t`` left it
        (``r(t - range/c)``, to first order: under 30 m in LEO). Default: off.
    frequency : Quantity (frequency), optional
        A transmitted frequency: the result's ``doppler`` holds the received shift
        (:func:`visviva.ground.doppler_shift`).

    Returns
    -------
    LookAngles

    Notes
    -----
    RAZEL (Vallado 2013, Algorithm 27): with ``rho`` = satellite - site in ITRS and its local
    components (east ``e``, north ``n``, up ``z``): ``el = atan2(z, sqrt(e^2 + n^2))``,
    ``az = atan2(e, n)``, ``rdot = rho . rho_dot / |rho|``,
    ``az_dot = (e_dot n - n_dot e) / (e^2 + n^2)``,
    ``el_dot = (z_dot - rdot z / |rho|) / sqrt(e^2 + n^2)``.
    """
    from ..satellites.frames import offline_iers

    with offline_iers():  # one block: an Earth-orientation warning once per call
        r_i, v_i, t, lead, rot_ig = _target_states(target, t)
    rho = r_i - station.itrs_km
    if light_time:
        omega = np.array([0.0, 0.0, GMST_RATE_RAD_S])
        tau = np.linalg.norm(rho, axis=-1, keepdims=True) / SPEED_OF_LIGHT_KM_S
        rho = rho - (v_i + np.cross(omega, r_i)) * tau
    flat_rho = np.ascontiguousarray(rho.reshape(-1, 3))
    flat_v = np.ascontiguousarray(v_i.reshape(-1, 3))
    res = np.empty((flat_rho.shape[0], 6))
    _topo.razel_many(flat_rho, flat_v, station.enu_matrix[None], np.zeros(len(flat_rho),
                                                                         dtype=np.int64), res)
    shape = lead + t.shape
    res = res.reshape(shape + (6,))
    el_deg = np.degrees(res[..., 2])
    el_rate = np.degrees(res[..., 5])
    if refraction:  # the apparent elevation, and its rate d(el + R(el))/dt
        el_rate = el_rate * (1.0 + refraction_slope(el_deg))
        el_deg = el_deg + refraction_deg(el_deg)
    rho_g = np.einsum("tij,ntj->nti", rot_ig, rho)
    ra = np.degrees(np.arctan2(rho_g[..., 1], rho_g[..., 0])) % 360.0
    dec = np.degrees(np.arcsin(np.clip(rho_g[..., 2] / np.linalg.norm(rho_g, axis=-1), -1, 1)))
    range_rate = res[..., 3] * (u.km / u.s)
    return LookAngles(
        azimuth=np.degrees(res[..., 1]) * u.deg,
        elevation=el_deg * u.deg,
        range=res[..., 0] * u.km,
        range_rate=range_rate,
        azimuth_rate=np.degrees(res[..., 4]) * (u.deg / u.s),
        elevation_rate=el_rate * (u.deg / u.s),
        ra=ra.reshape(shape) * u.deg,
        dec=dec.reshape(shape) * u.deg,
        t=t,
        doppler=None if frequency is None else doppler_shift(frequency, range_rate),
    )
