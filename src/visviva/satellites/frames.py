"""Earth-centred frames for satellites: TEME, GCRS, ITRS and geodetic, through astropy.

Every rotation is astropy's own (``astropy.coordinates.TEME``, ``GCRS``, ``ITRS`` with a
``CartesianDifferential`` for the velocity), so visviva holds no copy of precession, nutation,
sidereal time or polar motion.

Earth-orientation data (UT1-UTC and polar motion) come **offline** from the files installed with
astropy (the ``astropy-iers-data`` package: IERS Bulletin A ``finals2000A.all`` with a year of
predictions, and EOP C04): inside these functions ``astropy.utils.iers.conf.auto_download`` is
``False``, so no call goes to the network. Observed values are good to ~0.1 ms in UT1 and
~0.1 mas in polar motion; predictions degrade to ~20 ms and ~0.08" after a year (Bulletin A's
error model). Beyond the table astropy warns (``iers_degraded_accuracy = "warn"``), holds UT1-UTC at its last
value and uses the 50-year mean pole: errors grow to up to 0.9 s in UT1 (~400 m along the
equator in ITRS).
GCRS is insensitive to these data (TEME and GCRS are both inertial). See docs/satellites.md.
"""

from __future__ import annotations

import contextlib

import numpy as np
from astropy import units as u

from .._units import to_quantity, to_vector
from ..errors import DomainError, InvalidInputError, ShapeError

__all__ = [
    "offline_iers",
    "teme_to_gcrs",
    "teme_to_itrs",
    "gcrs_to_itrs",
    "itrs_to_gcrs",
    "itrs_to_geodetic",
    "transform_matrices",
    "transform_batch",
    "WGS84_A_KM",
    "WGS84_F",
]

#: WGS-84 equatorial radius (km) and flattening (NIMA TR8350.2).
WGS84_A_KM = 6378.137
WGS84_F = 1.0 / 298.257223563


@contextlib.contextmanager
def offline_iers():
    """Use the Earth-orientation data installed with astropy; never download.

    Inside the block ``astropy.utils.iers.conf.auto_download`` is ``False``, the table's
    predictions are used however old the installed file is (``auto_max_age = None``), and
    times beyond the table warn instead of raising (``iers_degraded_accuracy = "warn"``).
    """
    from astropy.utils import iers

    with (
        iers.conf.set_temp("auto_download", False),
        # the installed table's predictions are used however old the file is (without this,
        # astropy refuses predictions from a file more than 30 days old: it expects to
        # download a newer one)
        iers.conf.set_temp("auto_max_age", None),
        iers.conf.set_temp("iers_degraded_accuracy", "warn"),
    ):
        yield


def _raw(value, kind, name):
    """Plain float64 array in canonical units from a Quantity or (already canonical) array."""
    if isinstance(value, u.Quantity):
        return to_vector(value, kind, name)
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise ShapeError(f"{name} must have shape (..., 3); got {arr.shape}.")
    return arr


def _transform(r, v, t, source, target):
    from astropy.coordinates import GCRS, ITRS, TEME, CartesianDifferential, CartesianRepresentation
    from astropy.time import Time

    frames = {"teme": TEME, "gcrs": GCRS, "itrs": ITRS}
    if not isinstance(t, Time):
        raise InvalidInputError(
            f"t must be an astropy Time for a {source.upper()} -> {target.upper()} conversion "
            f"(the rotation depends on the date); got {type(t).__name__}."
        )
    r_km = _raw(r, "length", "r")
    v_km_s = _raw(v, "speed", "v")
    try:
        shape = np.broadcast_shapes(r_km.shape[:-1], v_km_s.shape[:-1], t.shape)
    except ValueError as exc:
        raise ShapeError(
            f"r {r_km.shape}, v {v_km_s.shape} and t {t.shape} do not broadcast: {exc}"
        ) from exc
    r_km = np.broadcast_to(r_km, shape + (3,))
    v_km_s = np.broadcast_to(v_km_s, shape + (3,))
    if r_km.size == 0:  # empty in, empty out (astropy drops the differentials of empty data)
        return np.empty(shape + (3,)), np.empty(shape + (3,))
    rep = CartesianRepresentation(
        np.moveaxis(r_km, -1, 0) * u.km,
        differentials=CartesianDifferential(np.moveaxis(v_km_s, -1, 0) * (u.km / u.s)),
        copy=False,
    )
    with offline_iers():
        coord = frames[source](rep, obstime=t)
        out = coord.transform_to(frames[target](obstime=t))
        cart = out.cartesian
        r_out = np.moveaxis(cart.xyz.to_value(u.km), 0, -1)
        v_out = np.moveaxis(cart.differentials["s"].d_xyz.to_value(u.km / u.s), 0, -1)
    finite_in = np.isfinite(r_km).all(-1) & np.isfinite(v_km_s).all(-1)
    finite_out = np.isfinite(r_out).all(-1) & np.isfinite(v_out).all(-1)
    if (finite_in & ~finite_out).any():
        raise DomainError(
            f"the {source.upper()} -> {target.upper()} conversion gave a non-finite state "
            f"(astropy/ERFA) for {int((finite_in & ~finite_out).sum())} of {finite_out.size} "
            "finite inputs; use times within astropy's supported range (years -4712 to 9999)."
        )
    return np.ascontiguousarray(r_out), np.ascontiguousarray(v_out)


def transform_matrices(t, source: str, target: str) -> np.ndarray:
    """6 x 6 matrices taking (r, v) in ``source`` to (r, v) in ``target`` at each time.

    The frame changes between TEME, GCRS and ITRS are linear in (r, v) at a fixed time
    (rotations, plus the rotation rate times r in the velocity; all three are geocentric), so
    astropy's transformation of six basis states per time gives the whole map. Applying it to
    N objects costs one small matrix product instead of N astropy transformations per time.

    Parameters
    ----------
    t : astropy Time, shape (T,)
    source, target : {"teme", "gcrs", "itrs"}

    Returns
    -------
    ndarray, shape (T, 6, 6)
        ``y_target = M @ y_source`` with ``y = (x, y, z, vx, vy, vz)`` in km and km/s.
    """
    scale = 7000.0  # km: a basis of satellite-like size keeps astropy's finite differences sane
    T = t.shape[0]
    r = np.zeros((6, T, 3))
    v = np.zeros((6, T, 3))
    for k in range(3):
        r[k, :, k] = scale
        r[3 + k, :, 0] = scale
        v[3 + k, :, k] = 1.0
    ro, vo = _transform(r, v, t, source, target)
    out = np.concatenate([ro, vo], axis=-1)  # (6, T, 6)
    m = np.empty((T, 6, 6))
    for k in range(3):
        m[:, :, k] = out[k] / scale
        m[:, :, 3 + k] = out[3 + k] - out[0]
    return m


def transform_batch(r, v, t, source: str, target: str):
    """Frame change of (N, T, 3) states at T shared times through :func:`transform_matrices`.

    Parameters
    ----------
    r, v : ndarray (km, km/s), shape (N, T, 3)
    t : astropy Time, shape (T,)

    Returns
    -------
    r, v : ndarray, shape (N, T, 3)
    """
    m = transform_matrices(t, source, target)  # (T, 6, 6)
    y = np.concatenate([r, v], axis=-1).transpose(1, 0, 2)  # (T, N, 6)
    out = np.matmul(y, m.transpose(0, 2, 1)).transpose(1, 0, 2)  # (N, T, 6)
    return np.ascontiguousarray(out[..., :3]), np.ascontiguousarray(out[..., 3:])


def _wrap(r, v, like):
    if isinstance(like, u.Quantity):
        return to_quantity(r, "length"), to_quantity(v, "speed")
    return r, v


def teme_to_gcrs(r, v, t):
    """Rotate TEME positions and velocities to GCRS with astropy.

    Parameters
    ----------
    r : Quantity (length) or ndarray (km), shape (..., 3)
        TEME position.
    v : Quantity (speed) or ndarray (km/s), shape (..., 3)
        TEME velocity.
    t : astropy Time, broadcastable to ``r.shape[:-1]``
        Times of the states.

    Returns
    -------
    r, v : Quantity or ndarray (same kind as ``r``)
        GCRS position (km) and velocity (km/s).

    Notes
    -----
    TEME (true equator, mean equinox; Vallado et al. 2006, AIAA 2006-6753) -> PEF by GMST
    (IAU 1982) -> ITRS by polar motion -> GCRS by the IAU 2006/2000A CIO-based chain, all in
    astropy/ERFA; velocities are transformed with astropy's finite differences in obstime.
    """
    ro, vo = _transform(r, v, t, "teme", "gcrs")
    return _wrap(ro, vo, r)


def teme_to_itrs(r, v, t):
    """Rotate TEME positions and velocities to ITRS (Earth-fixed) with astropy.

    Parameters and returns as in :func:`teme_to_gcrs`; the ITRS velocity is relative to the
    rotating Earth.
    """
    ro, vo = _transform(r, v, t, "teme", "itrs")
    return _wrap(ro, vo, r)


def gcrs_to_itrs(r, v, t):
    """Rotate GCRS positions and velocities to ITRS with astropy (see :func:`teme_to_gcrs`)."""
    ro, vo = _transform(r, v, t, "gcrs", "itrs")
    return _wrap(ro, vo, r)


def itrs_to_gcrs(r, v, t):
    """Rotate ITRS positions and velocities to GCRS with astropy (see :func:`teme_to_gcrs`)."""
    ro, vo = _transform(r, v, t, "itrs", "gcrs")
    return _wrap(ro, vo, r)


def itrs_to_geodetic(r):
    """Geodetic latitude, longitude and height above the WGS-84 ellipsoid.

    Parameters
    ----------
    r : Quantity (length) or ndarray (km), shape (..., 3)
        ITRS position.

    Returns
    -------
    latitude, longitude, height : Quantity
        Degrees, degrees in [-180, 180), km; shape ``r.shape[:-1]``.

    Notes
    -----
    astropy's ``EarthLocation.to_geodetic("WGS84")`` (ERFA ``gc2gde``, Fukushima's method),
    exact to well below a millimetre.
    """
    from astropy.coordinates import EarthLocation

    r_km = _raw(r, "length", "r")
    loc = EarthLocation.from_geocentric(r_km[..., 0], r_km[..., 1], r_km[..., 2], unit=u.km)
    geo = loc.to_geodetic("WGS84")
    lat = u.Quantity(geo.lat, u.deg)
    lon = u.Quantity(geo.lon.wrap_at(180 * u.deg), u.deg)
    return lat, lon, geo.height.to(u.km)
