"""Ground tracks and eclipses of a satellite: the numbers behind :mod:`visviva.satellites.plots`.

* :func:`ground_track`: geodetic latitude, longitude (WGS-84) and height along the orbit, with
  the track split where it crosses the antimeridian (for drawing).

Both take a :class:`~visviva.Satellite` or a :class:`~visviva.Catalog` (one propagation and one
frame change for all its satellites; the times must then be absolute, an astropy ``Time``).
* :func:`eclipse_fraction`: the fraction of the solar disc visible from the satellite (1 in
  sunlight, 0 in the umbra), conical shadow model of Montenbruck & Gill (2000), sec. 3.4.2,
  through the ``shadow_fraction`` kernel of :mod:`visviva.core.perturbations`, with the Sun from
  :mod:`visviva.satellites.ephemeris`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from astropy import units as u
from astropy.time import Time

from ..constants import R_EARTH_KM, R_SUN_KM
from ..core._jit import parallel_kernel, prange
from ..core.perturbations import shadow_fraction

__all__ = ["GroundTrack", "ground_track", "eclipse_fraction", "eclipse_intervals"]


@dataclass
class GroundTrack:
    """Sub-satellite points.

    Attributes
    ----------
    t : astropy Time, shape (T,)
    latitude, longitude : Quantity, deg, shape (T,)
        Geodetic (WGS-84); longitude in [-180, 180).
    height : Quantity, km, shape (T,)
        Height above the WGS-84 ellipsoid.
    name : str
        The satellite's name.
    """

    t: Time
    latitude: u.Quantity
    longitude: u.Quantity
    height: u.Quantity
    name: str = ""

    def segments(self):
        """Index slices of the pieces between antimeridian crossings and passages over a pole
        (for line plots).

        A step whose longitude wraps (|Δλ| > 180 deg) crosses the antimeridian; one whose
        longitude, unwrapped, still jumps by more than 90 deg passes over (or next to) a pole,
        where the longitude turns by about 180 deg at once: a polar orbit's track was joined
        there by a line across the whole map when the jump fell just below 180 deg (179.75 deg
        for a 90 deg orbit sampled each minute).
        """
        lon = np.atleast_1d(self.longitude.to_value(u.deg))
        step = np.diff(lon)
        unwrapped = (step + 180.0) % 360.0 - 180.0
        breaks = np.flatnonzero((np.abs(step) > 180.0) | (np.abs(unwrapped) > 90.0)) + 1
        edges = np.concatenate([[0], breaks, [lon.size]])
        return [slice(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:], strict=True)]


def _times(sat, t) -> Time:
    """``t`` as absolute times: a Time as it is, a time Quantity as offsets from the epoch."""
    from .._units import to_array
    from ..errors import InvalidInputError, UnitsError
    from .tle import Satellite

    if not isinstance(sat, Satellite):
        raise InvalidInputError(
            f"give a vv.Satellite (from_tle / from_omm) or a vv.Catalog; got "
            f"{type(sat).__name__}. For states or elements, propagate them and convert with "
            "vv.satellites.gcrs_to_itrs and itrs_to_geodetic."
        )
    if isinstance(t, Time):
        return t
    if not isinstance(t, u.Quantity):
        raise UnitsError(
            f"t must be an astropy Time (absolute times) or a time Quantity (offsets from the "
            f"element-set epoch, e.g. np.arange(0, 90, 10) * u.min); got {type(t).__name__}."
        )
    return sat.epoch + to_array(t, "time", "t") * u.s


def is_catalog(obj) -> bool:
    """Whether ``obj`` is a :class:`~visviva.satellites.catalog.Catalog` (without importing it
    for a single satellite's plot)."""
    from .catalog import Catalog

    return isinstance(obj, Catalog)


def ground_track(sat, t):
    """Geodetic sub-satellite track.

    Parameters
    ----------
    sat : Satellite or Catalog
        One satellite, or a catalogue (all propagated in one call).
    t : astropy Time or Quantity (time offsets from ``sat.epoch``), 1-D
        The times; absolute (an astropy Time) for a catalogue.

    Returns
    -------
    GroundTrack, or list of GroundTrack (one per satellite of a catalogue)
    """
    from .frames import itrs_to_geodetic

    if is_catalog(sat):
        from .batch_states import absolute_times

        times = absolute_times(t, "ground_track of a Catalog")
        states = sat.propagate(times, frame="itrs")
        lat, lon, h = itrs_to_geodetic(states.r)
        return [GroundTrack(times, lat[k], lon[k], h[k], name)
                for k, name in enumerate(states.names)]
    times = _times(sat, t)
    lat, lon, h = sat.geodetic(times)
    return GroundTrack(times, lat, lon, h, sat.name)


@parallel_kernel
def shadow_fraction_many(r, s, radius, sun_radius, out):
    """Visible fraction of the Sun's disc (conical shadow) for N positions, in place.

    ``r``, ``s`` (N, 3) satellite and Sun positions (km) from the body's centre, ``radius`` and
    ``sun_radius`` (km); writes ``out`` (N,) with
    :func:`visviva.core.perturbations.shadow_fraction`.
    """
    for i in prange(r.shape[0]):
        out[i] = shadow_fraction(
            r[i, 0], r[i, 1], r[i, 2], s[i, 0], s[i, 1], s[i, 2], radius, sun_radius, 2
        )


def eclipse_fraction(sat, t) -> np.ndarray:
    """Fraction of the Sun's disc visible from the satellite.

    Parameters
    ----------
    sat : Satellite or Catalog
        One satellite, or a catalogue of N (propagated together).
    t : astropy Time or Quantity (offsets from ``sat.epoch``)
        The times; absolute (an astropy Time, 1-D) for a catalogue.

    Returns
    -------
    ndarray, shape of ``t`` (a Catalog: (N, T))
        1 in full sunlight, 0 in the umbra, in between in the penumbra.

    Notes
    -----
    Conical shadow of a spherical Earth (radius ``R_EARTH_KM``) and Sun (Montenbruck & Gill
    2000, eqs. 3.85-3.87), GCRS positions of the satellite (SGP4 -> astropy) and the Sun.
    """
    from .ephemeris import sun_position

    if is_catalog(sat):
        from .batch_states import absolute_times

        times = absolute_times(t, "eclipse_fraction of a Catalog")
        r = sat.propagate(times, frame="gcrs").r.to_value(u.km)  # (N, T, 3)
        s = np.broadcast_to(sun_position(times).to_value(u.km), r.shape)
        shape = r.shape[:-1]
    else:
        times = _times(sat, t)
        r = sat.gcrs(times).r.to_value(u.km)
        s = sun_position(times.ravel()).to_value(u.km)
        shape = times.shape
    r = np.ascontiguousarray(r.reshape(-1, 3))
    s = np.ascontiguousarray(s.reshape(-1, 3))
    out = np.empty(r.shape[0])
    shadow_fraction_many(r, s, R_EARTH_KM, R_SUN_KM, out)
    return out.reshape(shape)


def eclipse_intervals(t: Time, fraction: np.ndarray, threshold: float = 1.0):
    """(start, end) Time pairs of the runs where ``fraction < threshold`` (sampled, no root
    finding: the edges are good to one sample step; use the Cowell ``Eclipse`` event for exact
    times)."""
    if len(t) != np.shape(fraction)[0] or np.ndim(fraction) != 1:
        from ..errors import InvalidInputError

        raise InvalidInputError(
            f"t and fraction must be 1-D and of the same length; got {len(t)} times and "
            f"fraction of shape {np.shape(fraction)} (for a Catalog pass one row at a time)."
        )
    shaded = np.asarray(fraction) < threshold
    edges = np.diff(np.concatenate([[0], shaded.astype(np.int8), [0]]))
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1) - 1
    return [(t[a], t[b]) for a, b in zip(starts, ends, strict=True)]
