"""Look angles: azimuth, elevation, range, their rates, and topocentric RA/Dec from a station.

The geometry is done in the Earth-fixed frame (ITRS), where the station and its local axes are
at rest: the satellite's ITRS state comes from astropy's frame rotation (one 6 x 6 map per time,
:func:`visviva.satellites.frames.transform_matrices`, shared by every satellite), and range,
azimuth, elevation and their rates follow from the site-to-satellite vector by Vallado's RAZEL
(:func:`visviva.core.topocentric.razel_many`). Topocentric right ascension and declination use
the same vector rotated to GCRS axes. Geometric by default: no refraction, no light time.
"""

from __future__ import annotations

import numpy as np
from astropy import units as u
from astropy.time import Time

from .._units import time_input_name
from ..constants import GM_EARTH_KM3_S2
from ..core import topocentric as _topo
from ..errors import DomainError, InvalidInputError
from .doppler import SPEED_OF_LIGHT_KM_S, doppler_shift, light_time_rate
from .earthfixed import GMST_RATE_RAD_S
from .refraction import bend, refraction_deg, refraction_slope, station_air

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
                f"t must be an astropy Time for a satellite target, got {time_input_name(t)}; "
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
        from ..satellites.satellite_states import FRAMES, frame_of

        source = frame_of(target) or "gcrs"  # (plain states may carry one: TEME, TOD ...)
        if source not in FRAMES:
            raise InvalidInputError(
                f"these states are in REF_FRAME = {source}, which visviva cannot rotate to the "
                "ITRS: pass GCRS or TEME states (sat.gcrs(t)).")
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


def _retarded(rho, r_i, v_i, site_km):
    """The site-to-satellite vector from the satellite at emission ``t - tau`` to the site at
    reception ``t``, and its rate in the Earth-fixed frame (ITRS axes at ``t``, km and km/s).

    With ``V = v + omega x r`` and ``A = -GM r / |r|^3`` the satellite's inertial velocity and
    acceleration: ``rho_lt = rho - V tau`` (``tau = |rho| / c``, first order) and
    ``d rho_lt / dt = (V - A tau)(1 - tau_dot) - omega x (site + rho_lt)`` with
    ``tau_dot = u . (V - A tau - omega x site) / (c + u . (V - A tau))``, ``u`` along
    ``rho_lt``: the range rate is then ``d(c tau)/dt``, whose ``-f / c`` multiple is the
    classical one-way Doppler shift. (Before this, the satellite's velocity at ``t`` was
    projected on ``rho_lt``: 14-22 mm/s off for the ISS.)
    """
    omega = np.array([0.0, 0.0, GMST_RATE_RAD_S])
    vel = v_i + np.cross(omega, r_i)  # inertial velocity, ITRS axes
    tau = np.linalg.norm(rho, axis=-1, keepdims=True) / SPEED_OF_LIGHT_KM_S
    rho = rho - vel * tau
    r_norm = np.linalg.norm(r_i, axis=-1, keepdims=True)
    v_emit = vel + GM_EARTH_KM3_S2 * r_i / r_norm**3 * tau  # V(t - tau) = V - A tau
    unit = rho / np.linalg.norm(rho, axis=-1, keepdims=True)
    v_site = np.cross(omega, site_km)
    tau_dot = light_time_rate(unit, v_emit, v_site)[..., None]
    rate = v_emit * (1.0 - tau_dot) - v_site - np.cross(omega, rho)
    return rho, rate


def look(station, target, t=None, *, refraction=False, light_time: bool = False,
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
    refraction : bool, {"optical", "radio"} or dict
        Add atmospheric refraction (:func:`refraction_deg`) to the elevation and its rate to
        ``elevation_rate``. False (default): geometric. True or ``"optical"``: light
        (Sæmundsson's formula) in the standard atmosphere at the station's height (ICAO:
        1013.25 hPa, 15 deg C at sea level; about 0.48 deg at the horizon, 0.30 deg from
        4200 m). ``"radio"``: an antenna's angles, the radio bending of the same air with 50 %
        humidity (about 0.57 deg at the horizon at sea level). A dict gives the station's
        weather with the keys of ``Observations(troposphere=...)``: ``pressure_hpa``,
        ``temperature_c``, ``relative_humidity`` (0..1) and ``refraction`` (``"optical"``,
        the default, or ``"radio"``); the standard air fills the keys left out. The offset is
        the satellite's at its range, less than a star's bending by the bent ray's lever arm
        (0.947 of it at the horizon 500 km up; :mod:`visviva.ground.finite_range`), and
        ``elevation_rate`` carries the range's change too. A target less than 1 km above the
        station is refused.
    light_time : bool
        Use the satellite's position when the light received at ``t`` left it
        (``r(t - range/c)``, to first order: under 30 m in LEO), and as ``range_rate`` the
        rate of that range, ``d(c tau)/dt`` (the one-way Doppler's; it differs from the
        instantaneous range rate by about ``-v^2 / c``, -0.19 m/s for the ISS). The angle
        rates are those of the retarded direction. Default: off (geometric, instantaneous).
    frequency : Quantity (frequency), optional
        A transmitted frequency: the result's ``doppler`` holds the received shift
        (:func:`visviva.ground.doppler_shift`). For a catalogue, one per satellite (shape
        ``(N,)``) applies to each satellite's row; other shapes broadcast with the result's
        (one per time: ``t.shape``, or ``(N,) + t.shape``).

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

    air = station_air(refraction, station.height.to_value(u.m))
    with offline_iers():  # one block: an Earth-orientation warning once per call
        r_i, v_i, t, lead, rot_ig = _target_states(target, t)
    rho = r_i - station.itrs_km
    _refuse_at_station(rho, station)
    if light_time:
        rho, v_i = _retarded(rho, r_i, v_i, station.itrs_km)
    flat_rho = np.ascontiguousarray(rho.reshape(-1, 3))
    flat_v = np.ascontiguousarray(v_i.reshape(-1, 3))
    res = np.empty((flat_rho.shape[0], 6))
    _topo.razel_many(flat_rho, flat_v, station.enu_matrix[None], np.zeros(len(flat_rho),
                                                                         dtype=np.int64), res)
    shape = lead + t.shape
    res = res.reshape(shape + (6,))
    el_deg = np.degrees(res[..., 2])
    el_rate = np.degrees(res[..., 5])
    if air is not None:  # the apparent elevation, and its rate d(el + R(el, range))/dt
        r_deg, slope, d_range = bend(el_deg, *air, range_km=res[..., 0], range_slope=True)
        el_rate = el_rate * (1.0 + slope) + d_range * res[..., 3]
        el_deg = el_deg + r_deg
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
        doppler=None if frequency is None else doppler_shift(
            _per_satellite(frequency, lead, t.shape), range_rate),
    )


#: closest target look() takes, km: nearer, the direction is round-off (at range 0 the angles
#: are undefined; a target at the station's own place gave az 255 deg, el -29 deg, audit51)
MIN_RANGE_KM = 1e-3


def _refuse_at_station(rho, station) -> None:
    """Refuse (:class:`~visviva.errors.DomainError`) targets within :data:`MIN_RANGE_KM` of
    the station: their azimuth and elevation are undefined (NaN at range 0, round-off just
    above it)."""
    rng = np.linalg.norm(rho, axis=-1)
    near = rng < MIN_RANGE_KM
    if near.any():
        k = int(np.flatnonzero(near.ravel())[0])
        raise DomainError(
            f"the target is {rng.ravel()[k] * 1e3:.3g} m from the station {station.name!r} "
            f"(at {int(near.sum())} of {near.size} times; the first is element {k} of the "
            "flattened times): azimuth and elevation are undefined at the station itself. "
            "Check that the target is not the station's own position (e.g. "
            "station.gcrs_position_velocity) and that its positions are in km.")


def _per_satellite(frequency, lead, t_shape):
    """A catalogue's frequencies, one per satellite (shape ``(N,)``), set on its leading
    axis: numpy's broadcasting would lay them along the times, and with as many times as
    satellites each satellite took the others' frequencies silently (audit50: 6.6 kHz off
    at 437.8 MHz). Anything else is left to :func:`doppler_shift`'s broadcasting."""
    shape = getattr(frequency, "shape", ())
    if lead and len(t_shape) and shape == lead:
        return frequency.reshape(lead + (1,) * len(t_shape))
    return frequency
