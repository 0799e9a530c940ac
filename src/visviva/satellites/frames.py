"""Earth-centred frames for satellites: TEME, GCRS, ITRS and geodetic, through astropy.

Every rotation is the one astropy's frame graph applies between ``astropy.coordinates.TEME``,
``GCRS`` and ``ITRS`` (GMST 1982 and polar motion; the IAU 2006/2000A CIO-based chain), built
from the same ERFA routines and IERS table (:mod:`visviva.satellites.earth_rotation`, which
spares the import of astropy.coordinates), so visviva holds no copy of precession, nutation,
sidereal time or polar motion. They are evaluated once per time (the costly precession-nutation
matrix on hourly nodes, interpolated) into 6 x 6 maps of (r, v) that every satellite shares
(:func:`transform_matrices`): a catalogue of 3 satellites x 1441 times goes to GCRS in ~0.03 s
instead of the 3-6 s of astropy's graph on the states; the results equal the graph's to
~1e-11 km and ~1e-11 km/s (tests/test_frames.py).

Earth-orientation data (UT1-UTC and polar motion) come **offline** from the files installed with
astropy (the ``astropy-iers-data`` package: IERS Bulletin A ``finals2000A.all`` with a year of
predictions, and EOP C04): inside these functions ``astropy.utils.iers.conf.auto_download`` is
``False``, so no call goes to the network. Observed values are good to ~0.1 ms in UT1 and
~0.1 mas in polar motion; predictions degrade to ~20 ms and ~0.08" after a year (Bulletin A's
error model). Beyond the table UT1-UTC is held at its last value and the pole is the 50-year
mean, with an :class:`~visviva.errors.EarthOrientationWarning` naming the date and the bound
of the error (up to ~1 s of UT1 per year past the table, 0.465 km per second along the
equator). Before the Bulletin A file (1973) the EOP C04 rows from 1962 are used
(:mod:`visviva._iers_cache`); the table is visviva's own, whatever astropy loaded first
(docs/conventions.md, "Earth orientation").
GCRS is insensitive to these data (TEME and GCRS are both inertial). See docs/satellites.md.
"""

from __future__ import annotations

import contextlib

import numpy as np
from astropy import units as u

from .._offline_iers import offline_iers
from .._units import require_usable_time, to_quantity, to_vector
from ..core.local_frames import EME2000_NOTE
from ..errors import DomainError, InvalidInputError, ShapeError
from .earth_rotation import cirs_to_itrs_mat, gcrs_to_cirs_mat, teme_to_itrs_mat

__all__ = [
    "offline_iers",
    "teme_to_gcrs",
    "teme_to_itrs",
    "gcrs_to_itrs",
    "itrs_to_gcrs",
    "itrs_to_geodetic",
    "geodetic_to_itrs_km",
    "altitude_km",
    "transform_matrices",
    "transform_batch",
    "frame_name",
    "FRAME_NAMES",
    "WGS84_A_KM",
    "WGS84_F",
]

#: WGS-84 equatorial radius (km) and flattening (NIMA TR8350.2).
WGS84_A_KM = 6378.137
WGS84_F = 1.0 / 298.257223563


#: visviva's Earth frames (lower case); :func:`frame_name` reads any case
FRAME_NAMES = ("teme", "gcrs", "itrs")
#: other names a user may write for them: the same frame (its realisation, same axes)
_SAME = {"gcrf": "gcrs", "itrf": "itrs"}
#: frames that are not one of visviva's, with what to do instead
_NOT_OURS = {
    "eme2000": EME2000_NOTE,  # (core.local_frames: burns and covariances refuse it too)
    "icrs": "the ICRS is barycentric; its axes about the Earth are the GCRS's: 'gcrs'",
    "icrf": "the ICRF is barycentric; its axes about the Earth are the GCRS's: 'gcrs'",
    "tod": "true-of-date axes have no visviva rotation; 'teme' differs from them by the "
           "equation of the equinoxes (up to ~17 arcsec of right ascension)",
}
_NOT_OURS["j2000"] = _NOT_OURS["eme2000"]


def frame_name(frame, allowed=FRAME_NAMES, what: str = "frame") -> str:
    """visviva's name (``"teme"``, ``"gcrs"``, ``"itrs"``) of the frame the user wrote.

    Case does not matter, and ``"GCRF"`` and ``"ITRF"`` (the realisations of the GCRS and the
    ITRS, same axes) are read as ``"gcrs"`` and ``"itrs"``.

    Parameters
    ----------
    frame : str
        The name given.
    allowed : tuple of str
        The frames the caller handles (lower case).
    what : str
        The argument's name, for the message.

    Returns
    -------
    str

    Raises
    ------
    InvalidInputError
        Another frame (the message says what to pass: EME2000/J2000, ICRS, TOD ...).
    """
    key = frame.strip().lower() if isinstance(frame, str) else frame
    key = _SAME.get(key, key)
    if key in allowed:
        return key
    hint = _NOT_OURS.get(key)
    raise InvalidInputError(
        f"{what} must be one of {', '.join(repr(a) for a in allowed)} (any case); got "
        f"{frame!r}"
        + (f": {hint}." if hint else "."))


def _raw(value, kind, name):
    """Plain float64 array in canonical units from a Quantity or (already canonical) array."""
    if isinstance(value, u.Quantity):
        return to_vector(value, kind, name)
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise ShapeError(f"{name} must have shape (..., 3); got {arr.shape}.")
    return arr


#: Julian dates of -4712-01-01 12:00 and 9999-12-31 24:00, the range of astropy's calendar
_FIRST_JD, _LAST_JD = 0.0, 5373484.5


def _need_time(t, source, target):
    """Raise unless ``t`` is an astropy Time (a frame rotation depends on the date)."""
    from astropy.time import Time

    if not isinstance(t, Time):
        raise InvalidInputError(
            f"t must be an astropy Time for a {source.upper()} -> {target.upper()} conversion "
            f"(the rotation depends on the date); got {type(t).__name__}."
        )
    require_usable_time(t, "t")
    jd = np.asarray(t.jd1, dtype=np.float64) + np.asarray(t.jd2, dtype=np.float64)
    outside = (jd < _FIRST_JD) | (jd > _LAST_JD)
    if np.any(outside):
        first = t.ravel()[int(np.argmax(outside.ravel()))] if t.ndim else t
        raise DomainError(
            f"t = JD {float(first.jd1 + first.jd2):.1f} ({first.scale.upper()}) lies outside "
            f"years -4712 to 9999, the range of astropy's time scales: a {source.upper()} -> "
            f"{target.upper()} rotation there is not meaningful (ERFA raises, or evaluates its "
            "precession-nutation polynomials millennia beyond their fit); use times within "
            "that range.")


def _states_at(r, v, t, source, target):
    """Canonical ``r`` (km), ``v`` (km/s) checked against ``t`` and their broadcast shape."""
    _need_time(t, source, target)
    r_km = _raw(r, "length", "r")
    v_km_s = _raw(v, "speed", "v")
    try:
        shape = np.broadcast_shapes(r_km.shape[:-1], v_km_s.shape[:-1], t.shape)
    except ValueError as exc:
        raise ShapeError(
            f"r {r_km.shape}, v {v_km_s.shape} and t {t.shape} do not broadcast: {exc}"
        ) from exc
    return r_km, v_km_s, shape


def _transform(r, v, t, source, target):
    from astropy.coordinates import GCRS, ITRS, TEME, CartesianDifferential, CartesianRepresentation

    frames = {"teme": TEME, "gcrs": GCRS, "itrs": ITRS}
    r_km, v_km_s, shape = _states_at(r, v, t, source, target)
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


#: astropy's finite-difference step for velocities through its frame graph
#: (``FunctionTransformWithFiniteDifference``: 1 s, symmetric); the fast path uses the same.
_FD_STEP_S = 1.0


#: spacing (hours) of the nodes on which the GCRS -> CIRS matrix (the IAU 2006/2000A
#: precession-nutation series, by far the costliest part) is evaluated and interpolated
_NODE_H = 1.0


def _lagrange4(s):
    """Cubic Lagrange weights and their derivatives (per unit s) on the nodes -1, 0, 1, 2."""
    w = np.stack([-s * (s - 1) * (s - 2) / 6, (s + 1) * (s - 1) * (s - 2) / 2,
                  -(s + 1) * s * (s - 2) / 2, (s + 1) * s * (s - 1) / 6], axis=-1)
    dw = np.stack([-(3 * s * s - 6 * s + 2) / 6, (3 * s * s - 4 * s - 1) / 2,
                   -(3 * s * s - 2 * s - 2) / 2, (3 * s * s - 1) / 6], axis=-1)
    return w, dw


def _gcrs_to_cirs(t):
    """The GCRS -> CIRS matrix G (:func:`.earth_rotation.gcrs_to_cirs_mat`) and dG/dt (1/s) at t.

    G is evaluated on an hourly grid of TT nodes and interpolated by cubic Lagrange
    polynomials: its fastest terms (nutation, periods of days and longer) change by ~1e-7 rad
    per hour, so the interpolation error is below 1e-15 rad (~1e-11 km at GEO). When the times
    are sparse (more nodes than times) G comes straight from ERFA at t +- 0.5 s instead.
    """
    from astropy.time import Time, TimeDelta

    tt = t.tt
    ref = np.floor(np.min(tt.jd1))
    hours = ((tt.jd1 - ref) + tt.jd2) * (24.0 / _NODE_H)
    k = np.floor(hours)
    nodes = k[..., None] + np.arange(-1, 3)
    uniq, inverse = np.unique(nodes, return_inverse=True)
    if uniq.size > 2 * t.size:
        half = TimeDelta(_FD_STEP_S / 2.0, format="sec")
        g = gcrs_to_cirs_mat(t)
        rate = (gcrs_to_cirs_mat(t + half) - gcrs_to_cirs_mat(t - half)) / _FD_STEP_S
        return g, rate
    g_nodes = gcrs_to_cirs_mat(Time(ref, uniq * (_NODE_H / 24.0), format="jd", scale="tt"))
    g4 = g_nodes[inverse.reshape(nodes.shape)]  # t.shape + (4, 3, 3)
    w, dw = _lagrange4(hours - k)
    g = np.einsum("...k,...kij->...ij", w, g4)
    rate = np.einsum("...k,...kij->...ij", dw, g4) / (_NODE_H * 3600.0)
    return g, rate


def _rotation_to_itrs(t, frame: str, g) -> np.ndarray:
    """3 x 3 matrices (shape t.shape + (3, 3)) rotating ``frame`` vectors to ITRS at ``t``.

    The rotations astropy's frame graph applies (TEME -> ITRS: GMST 1982 and polar motion,
    Vallado et al. 2006; GCRS -> CIRS -> ITRS: IAU 2006/2000A CIO-based), from
    :mod:`visviva.satellites.earth_rotation`, with the GCRS -> CIRS matrix ``g`` given (see
    :func:`_gcrs_to_cirs`).
    """
    if frame == "itrs":
        return np.broadcast_to(np.eye(3), t.shape + (3, 3))
    if frame == "teme":
        return teme_to_itrs_mat(t)
    return np.matmul(cirs_to_itrs_mat(t), g)


def _map_at(t, source: str, target: str, g) -> np.ndarray:
    """Position map ``target <- source`` (shape t.shape + (3, 3)) at the times ``t``."""
    to_itrs = _rotation_to_itrs(t, source, g)
    from_itrs = np.swapaxes(_rotation_to_itrs(t, target, g), -1, -2)
    return np.matmul(from_itrs, to_itrs)


def _matrices_fast(t, source: str, target: str) -> np.ndarray:
    """(..., 6, 6) maps from the rotation matrices of :mod:`.earth_rotation`.

    The position rotates by M(t); the velocity as astropy's frame graph does it, by a symmetric
    finite difference in obstime, v' = M v + (M+ - M-)/h r with M+- = M(t +- h/2) and
    h = 1 s, for the Earth-rotation parts, plus the (tiny) precession-nutation rate from
    :func:`_gcrs_to_cirs`. The result equals the frame graph's to ~1e-11 km and ~1e-10 km/s.
    """
    from astropy.time import TimeDelta

    from .._eop_table import insensitive

    half = TimeDelta(_FD_STEP_S / 2.0, format="sec")
    quiet = insensitive() if "itrs" not in (source, target) else contextlib.nullcontext()
    with offline_iers(), quiet:
        g, g_rate = _gcrs_to_cirs(t) if "gcrs" in (source, target) else (None, None)
        m0 = _map_at(t, source, target, g)
        rate = (_map_at(t + half, source, target, g) - _map_at(t - half, source, target, g))
        rate /= _FD_STEP_S
        if source == "gcrs":  # M = from_itrs(target) C G: add from_itrs C dG/dt
            c = cirs_to_itrs_mat(t)
            from_itrs = np.swapaxes(_rotation_to_itrs(t, target, g), -1, -2)
            rate += from_itrs @ c @ g_rate
        elif target == "gcrs":  # M = G^T C^T to_itrs(source): add dG^T/dt C^T to_itrs
            c = cirs_to_itrs_mat(t)
            rate += np.swapaxes(g_rate, -1, -2) @ np.swapaxes(c, -1, -2) @ _rotation_to_itrs(
                t, source, g)
    out = np.zeros(t.shape + (6, 6))
    out[..., :3, :3] = m0
    out[..., 3:, 3:] = m0
    out[..., 3:, :3] = rate
    return out


def transform_matrices(t, source: str, target: str) -> np.ndarray:
    """6 x 6 matrices taking (r, v) in ``source`` to (r, v) in ``target`` at each time.

    The frame changes between TEME, GCRS and ITRS are linear in (r, v) at a fixed time
    (rotations, plus the rotation rate times r in the velocity; all three are geocentric).
    The rotations are those astropy's frame graph applies, from the same ERFA routines and IERS
    table (:mod:`visviva.satellites.earth_rotation`), evaluated once per time and at t +- 0.5 s
    for the velocity term, as astropy's graph does by finite differences; applying them to N
    objects costs one small matrix product per state instead of an astropy transformation per
    state.

    Parameters
    ----------
    t : astropy Time, any shape
        The times.
    source, target : {"teme", "gcrs", "itrs"}
        The frames (any case; "GCRF", "ITRF" read as "gcrs", "itrs": :func:`frame_name`).

    Returns
    -------
    ndarray, shape t.shape + (6, 6)
        ``y_target = M @ y_source`` with ``y = (x, y, z, vx, vy, vz)`` in km and km/s.
    """
    source = frame_name(source, what="source frame")
    target = frame_name(target, what="target frame")
    _need_time(t, source, target)
    if t.size == 0:
        return np.zeros(t.shape + (6, 6))
    if source == target:
        return np.broadcast_to(np.eye(6), t.shape + (6, 6)).copy()
    m = _matrices_fast(t, source, target)
    if not np.isfinite(m).all():
        raise DomainError(
            f"the {source.upper()} -> {target.upper()} rotation is not finite (astropy/ERFA) "
            "at some times; use times within astropy's supported range (years -4712 to 9999)."
        )
    return m


def apply_matrices(m, r_km, v_km_s):
    """Apply (..., 6, 6) maps to positions (km) and velocities (km/s) of shape (..., 3).

    Returns contiguous ``r`` and ``v`` arrays of the broadcast shape.
    """
    y = np.concatenate(np.broadcast_arrays(r_km, v_km_s), axis=-1)[..., None]
    out = np.matmul(m, y)[..., 0]
    return np.ascontiguousarray(out[..., :3]), np.ascontiguousarray(out[..., 3:])


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


def teme_of_epoch_to_teme(r_km, v_km_s, t0, t):
    """States on the TEME axes of one epoch ``t0`` (CCSDS ``REF_FRAME = TEME`` with
    ``REF_FRAME_EPOCH``) rotated to the TEME of their own dates ``t`` (SGP4's, visviva's).

    Parameters
    ----------
    r_km, v_km_s : ndarray (..., 3)
        Positions (km) and velocities (km/s) on the axes of TEME at ``t0``.
    t0 : astropy Time
        The frame's epoch (scalar).
    t : astropy Time
        The states' times, shape ``r_km.shape[:-1]``.

    Returns
    -------
    r, v : ndarray (..., 3)

    Notes
    -----
    The axes of epoch do not turn: ``(r, v)_GCRS = (R0 r, R0 v)`` with ``R0`` the TEME -> GCRS
    rotation at ``t0``; then GCRS -> TEME of date by :func:`transform_matrices` at ``t`` (whose
    axes turn by precession and nutation, ~1e-11 rad/s: metres a day in LEO, tens at GEO).
    """
    r0 = transform_matrices(t0, "teme", "gcrs")[..., :3, :3]
    r_g = np.einsum("ij,...j->...i", r0, r_km)
    v_g = np.einsum("ij,...j->...i", r0, v_km_s)
    return apply_matrices(transform_matrices(t, "gcrs", "teme"), r_g, v_g)


def _convert(r, v, t, source, target):
    """Frame change of states broadcast against ``t`` through :func:`transform_matrices`."""
    r_km, v_km_s, shape = _states_at(r, v, t, source, target)
    if int(np.prod(shape)) == 0:
        return np.empty(shape + (3,)), np.empty(shape + (3,))
    m = transform_matrices(t, source, target)
    return apply_matrices(m, r_km, v_km_s)


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
    (IAU 1982) -> ITRS by polar motion -> GCRS by the IAU 2006/2000A CIO-based chain, all with
    astropy/ERFA's matrices (:func:`transform_matrices`); the velocity term of the rotating
    frames by astropy's symmetric finite difference in obstime (1 s).
    """
    ro, vo = _convert(r, v, t, "teme", "gcrs")
    return _wrap(ro, vo, r)


def teme_to_itrs(r, v, t):
    """Rotate TEME positions and velocities to ITRS (Earth-fixed) with astropy.

    Parameters and returns as in :func:`teme_to_gcrs`; the ITRS velocity is relative to the
    rotating Earth.
    """
    ro, vo = _convert(r, v, t, "teme", "itrs")
    return _wrap(ro, vo, r)


def gcrs_to_itrs(r, v, t):
    """Rotate GCRS positions and velocities to ITRS with astropy (see :func:`teme_to_gcrs`)."""
    ro, vo = _convert(r, v, t, "gcrs", "itrs")
    return _wrap(ro, vo, r)


def itrs_to_gcrs(r, v, t):
    """Rotate ITRS positions and velocities to GCRS with astropy (see :func:`teme_to_gcrs`)."""
    ro, vo = _convert(r, v, t, "itrs", "gcrs")
    return _wrap(ro, vo, r)


def altitude_km(r_km, v_km_s, t, frame: str) -> np.ndarray:
    """Height (km) above the WGS-84 ellipsoid of states in ``frame`` at the times ``t``.

    Parameters
    ----------
    r_km, v_km_s : ndarray, shape (..., 3)
        Positions (km) and velocities (km/s).
    t : astropy Time, broadcastable to ``r_km.shape[:-1]``
        The times (unused for ITRS states).
    frame : {"teme", "gcrs", "itrs"}
        The frame of the states.

    Returns
    -------
    ndarray, shape ``r_km.shape[:-1]``
    """
    if frame != "itrs":
        r_km, _ = _convert(r_km, v_km_s, t, frame, "itrs")
    return itrs_to_geodetic(r_km)[2].to_value(u.km)


def itrs_to_geodetic(r):
    """Geodetic latitude, longitude and height above the WGS-84 ellipsoid.

    Parameters
    ----------
    r : Quantity (length) or ndarray (km), shape (..., 3)
        ITRS position.

    Returns
    -------
    latitude, longitude, height : Quantity
        Degrees, degrees in [-180, 180), km; shape ``r.shape[:-1]``. NaN for a position
        with a NaN or infinite coordinate (e.g. the failed rows of a batch propagated with
        ``on_error="nan"``).

    Notes
    -----
    ERFA ``gc2gde`` (Fukushima's method), the routine behind astropy's
    ``EarthLocation.to_geodetic("WGS84")``, called directly (no astropy.coordinates import);
    equal to astropy's to ~1e-10 km and ~1e-13 degrees. A round trip through
    :func:`geodetic_to_itrs_km` returns the position to ~1e-9 km in low orbit and ~1e-6 km
    (1 mm) at GEO distance and beyond: the accuracy of ERFA's closed-form method.
    """
    import erfa

    r_km = _raw(r, "length", "r")
    with np.errstate(invalid="ignore"):
        lon_rad, lat_rad, height_km = erfa.gc2gde(WGS84_A_KM, WGS84_F, r_km)
    # ERFA answers a NaN coordinate with the pole (90 deg, 0 deg, -6356.75 km) and an infinite
    # one with longitude 0: no position, no coordinates (NaN rows of a batch, on_error="nan")
    bad = ~np.isfinite(r_km).all(axis=-1)
    lon_deg = np.where(bad, np.nan, np.rad2deg(lon_rad))
    lon_deg = np.where(lon_deg >= 180.0, lon_deg - 360.0, lon_deg)  # [-180, 180)
    return (np.where(bad, np.nan, np.rad2deg(lat_rad)) << u.deg, lon_deg << u.deg,
            np.where(bad, np.nan, np.asarray(height_km, dtype=np.float64)) << u.km)


def geodetic_to_itrs_km(lat_rad, lon_rad, height_km) -> np.ndarray:
    """Earth-fixed (ITRS) position (km) of WGS-84 geodetic coordinates.

    Parameters
    ----------
    lat_rad, lon_rad : float or ndarray
        Geodetic latitude and longitude, radians.
    height_km : float or ndarray
        Height above the WGS-84 ellipsoid, km.

    Returns
    -------
    ndarray, shape (broadcast shape) + (3,)

    Notes
    -----
    ERFA ``gd2gce``, the routine behind astropy's ``EarthLocation.from_geodetic``, called
    directly (no astropy.coordinates import); equal to astropy's to ~1e-12 km.
    """
    import erfa

    return np.asarray(erfa.gd2gce(WGS84_A_KM, WGS84_F, lon_rad, lat_rad, height_km),
                      dtype=np.float64)
