"""Batch propagation: N satellites (or states) at T times in one call, and their result.

* :class:`BatchStates`: the (N, T, 3) positions and velocities with a status per state.
* :func:`propagate_sgp4_batch`: N satellites at T times in one call of sgp4's ``SatrecArray``
  (C++), ``(N, T, 3)`` positions and velocities in the arrays sgp4 writes (no copy), bit for
  bit :meth:`visviva.Satellite.teme` at the same times.
* :func:`propagate_kepler_batch`: two-body states (:func:`visviva.core.universal.propagate_many`).
* :func:`propagate_j2_batch`: SGP4 mean elements with the secular J2 drift of the node, perigee
  and mean anomaly (:mod:`visviva.satellites.secular`), one compiled loop over the N x T pairs
  (:mod:`visviva.satellites.secular_batch`).

The catalogue they take is :class:`visviva.satellites.catalog.Catalog`, which imports and
re-exports every public name here (``visviva.satellites.catalog.propagate_sgp4_batch``).
"""

from __future__ import annotations

import numpy as np
from astropy import units as u
from astropy.time import Time

from .._units import to_array, to_quantity, to_vector
from ..constants import DAY_S
from ..errors import InvalidInputError, ShapeError, UnitsError, raise_for_status
from .satellite_states import require_kepler_frame
from .secular_batch import secular_grid, secular_setup
from .tle import Satellite
from .tle_checks import (
    MINUTES_PER_DAY,
    SGP4Error,
    check_tsince,
    raise_for_sgp4_status,
    sgp4_times,
    warn_stale_sets,
)

__all__ = [
    "BatchStates",
    "propagate_sgp4_batch",
    "propagate_kepler_batch",
    "propagate_j2_batch",
    "absolute_times",
    "check_on_error",
]

class BatchStates:
    """States of N objects at T times.

    Attributes
    ----------
    r : Quantity, shape (N, T, 3)
        Positions, km (NaN where ``status`` is non-zero and errors were not raised).
    v : Quantity, shape (N, T, 3)
        Velocities, km/s.
    t : astropy Time, shape (T,)
        The times.
    status : ndarray of uint8, shape (N, T)
        0 where the propagation succeeded; otherwise sgp4's error code (1-6) for SGP4 or a
        :mod:`visviva.core.status` code for the Kepler and J2 propagators.
    names : list of str
        The N object names.
    frame : str
        ``"teme"``, ``"gcrs"`` or ``"itrs"``.
    """

    __slots__ = ("r", "v", "t", "status", "names", "frame")

    def __init__(self, r, v, t, status, names, frame):
        self.r, self.v, self.t, self.status, self.names, self.frame = r, v, t, status, names, frame

    @property
    def shape(self):
        """(N, T): objects and times."""
        return self.r.shape[:-1]

    @property
    def altitude(self):
        """Height above the WGS-84 ellipsoid (Quantity, km, shape (N, T)).

        From one rotation to ITRS per time shared by all objects (see :meth:`to_frame`), then
        astropy's geodetic conversion; NaN where a state is NaN (``status`` non-zero).
        """
        from .frames import altitude_km

        r = self.r.to_value(u.km)
        v = self.v.to_value(u.km / u.s)
        good = np.isfinite(r).all(-1) & np.isfinite(v).all(-1)
        out = np.full(self.shape, np.nan)
        if good.all():
            out[...] = altitude_km(r, v, self.t, self.frame)
        elif good.any():
            rr, vv = np.where(good[..., None], r, 7000.0), np.where(good[..., None], v, 0.0)
            out[good] = altitude_km(rr, vv, self.t, self.frame)[good]
        return out << u.km

    def to_frame(self, frame: str) -> BatchStates:
        """The same states in ``"teme"``, ``"gcrs"`` or ``"itrs"``, with astropy's frames.

        One 6 x 6 map per time from astropy's rotation matrices, shared by the N objects
        (:func:`visviva.satellites.frames.transform_batch`), equal to transforming every state
        with astropy's frame graph to ~1e-11 km and ~1e-10 km/s.
        """
        from .frames import transform_batch

        if frame == self.frame:
            return self
        known = ("teme", "gcrs", "itrs")
        if frame not in known or frame == "teme":
            raise InvalidInputError(
                f"cannot convert {self.frame} to {frame!r}; choose 'gcrs' or 'itrs'."
            )
        r, v = transform_batch(self.r.to_value("km"), self.v.to_value("km/s"), self.t,
                               self.frame, frame)
        return BatchStates(to_quantity(r, "length"), to_quantity(v, "speed"), self.t,
                           self.status, self.names, frame)

    def __repr__(self):
        return f"BatchStates(frame={self.frame!r}, shape={self.shape})"



def absolute_times(t, what: str) -> Time:
    """``t`` checked as the absolute times of a batch: a scalar or 1-D astropy Time, as 1-D.

    Parameters
    ----------
    t : astropy Time, scalar or shape (T,)
        The times, shared by every object of the batch.
    what : str
        The caller, for the message.

    Returns
    -------
    astropy Time, shape (T,)

    Raises
    ------
    UnitsError
        If ``t`` is not a Time (offsets need an epoch: ``epoch + dt``).
    ShapeError
        If ``t`` has more than one dimension.
    """
    if not isinstance(t, Time):
        raise UnitsError(
            f"{what} needs absolute times (an astropy Time), shared by every satellite; got "
            f"{type(t).__name__}. For offsets from one epoch use epoch + dt, e.g. "
            "Time('2024-01-01') + np.arange(0, 1440, 10) * u.min."
        )
    if t.ndim > 1:
        raise ShapeError(f"t must be a scalar or 1-D Time of T times; got shape {t.shape}.")
    return t.reshape(-1) if t.ndim == 0 else t


def check_on_error(on_error) -> None:
    """Refuse an ``on_error`` other than ``"raise"`` or ``"nan"`` (InvalidInputError).

    Parameters
    ----------
    on_error : str
        The batch functions' ``on_error`` argument.
    """
    if on_error not in ("raise", "nan"):
        raise InvalidInputError(f"on_error must be 'raise' or 'nan', got {on_error!r}.")


def propagate_sgp4_batch(satellites, t, *, on_error: str = "raise", out=None) -> BatchStates:
    """SGP4 for N satellites at T times in one call of sgp4's ``SatrecArray``.

    Parameters
    ----------
    satellites : Catalog or sequence of Satellite
        The N objects.
    t : astropy Time, shape (T,) or scalar
        Absolute times (any scale; converted to UTC Julian dates once). Element sets used more
        than 30 days from their epochs warn (:class:`~visviva.StaleElementSetWarning`, once
        per call, naming the stalest).
    on_error : {"raise", "nan"}
        Raise the typed :class:`~visviva.satellites.tle.SGP4Error` of the first failure
        (default), or return NaN in ``r`` and ``v`` wherever ``status`` (sgp4's code) is not
        0 (sgp4 itself returns a state below the surface for a decayed object, code 6).
    out : (status, r, v), optional
        C-contiguous arrays of shapes (N, T) uint8, (N, T, 3) and (N, T, 3) float64 that sgp4
        writes into (e.g. slices of a larger result); the returned states wrap them.

    Returns
    -------
    BatchStates
        TEME ``r`` (km) and ``v`` (km/s), shape (N, T, 3); identical bit for bit to
        ``Satellite.teme(t)`` of each satellite.
    """
    check_on_error(on_error)
    from .catalog import as_catalog  # (the catalogue module imports this one)

    cat = as_catalog(satellites)
    t = absolute_times(t, "propagate_sgp4_batch")
    jd, fr, _, _ = sgp4_times(t, 0.0, 0.0)
    ep_jd, ep_fr = cat.epoch_days
    tsince = ((jd[None, :] - ep_jd[:, None]) + (fr[None, :] - ep_fr[:, None])) * MINUTES_PER_DAY
    check_tsince(tsince, cat.names)
    warn_stale_sets(lambda k: cat.satellites[k].name or cat.satellites[k].satnum,
                    np.abs(tsince).max(axis=1, initial=0.0) / MINUTES_PER_DAY,
                    "the requested times", "these positions can be far off", stacklevel=2)
    if out is None:
        e, r, v = cat.satrec_array.sgp4(jd, fr)
    else:
        e, r, v = out
        shapes = ((len(cat), len(t)), (len(cat), len(t), 3), (len(cat), len(t), 3))
        dtypes = (np.uint8, np.float64, np.float64)
        if any(a.shape != sh or a.dtype != d or not a.flags.c_contiguous
               for a, sh, d in zip(out, shapes, dtypes, strict=True)):
            raise ShapeError(f"out arrays must be C-contiguous {shapes} of uint8, float64, "
                             f"float64; got {[(a.shape, str(a.dtype)) for a in out]}.")
        cat.satrec_array._sgp4(jd, fr, e, r, v)
    if e.any():
        if on_error == "raise":
            raise_for_sgp4_status(e, cat.names, tsince, t)
        # sgp4 fills some failed states with numbers (code 6, decayed: a point below the
        # surface) and others with NaN: no failed state leaves with numbers in it
        failed = e != 0
        r[failed] = np.nan
        v[failed] = np.nan
    # fast path: one summation each (NaN and inf propagate); the full mask only when it fails
    clean = np.isfinite(np.add.reduce(r, axis=None)) and np.isfinite(np.add.reduce(v, axis=None))
    bad = None if clean else ~(np.isfinite(r).all(-1) & np.isfinite(v).all(-1)) & (e == 0)
    if bad is not None and bad.any():  # never seen from sgp4, but no NaN leaves without a reason
        i, j = np.unravel_index(int(np.flatnonzero(bad)[0]), bad.shape)
        raise SGP4Error(
            f"SGP4 returned a non-finite state without an error code for satellite "
            f"{cat.names[i]!r} at {tsince[i, j]:.6f} min from its epoch. To fix: propagate to "
            "times nearer the element-set epoch or check the element set.",
            satellite=cat.names[i], reason="non-finite state", tsince_min=float(tsince[i, j]),
        )
    return BatchStates(to_quantity(r, "length"), to_quantity(v, "speed"), t, e, cat.names, "teme")


def _offsets_s(epochs: Time, t: Time) -> np.ndarray:
    """(N, T) seconds from each epoch to each time (TAI differences: leap seconds counted)."""
    from .frames import offline_iers

    with offline_iers():  # a time in UT1 needs the installed IERS table, never a download
        e = epochs.tai
        tt = t.tai
    return ((tt.jd1[None, :] - e.jd1[:, None]) + (tt.jd2[None, :] - e.jd2[:, None])) * DAY_S


def _require_one_axis(r, v, gm, epoch) -> None:
    """ShapeError unless the states lie on one axis of N, with gm and epoch scalar or (N,).

    (2, 3) states were flattened, their epochs and gm not: a raw numpy ValueError."""
    n = r.shape[:-1]
    if r.shape != v.shape or len(n) > 1 or any(np.shape(x) not in ((), n) for x in (gm, epoch)):
        raise ShapeError(
            f"propagate_kepler_batch takes N states on one axis: r, v of shape (N, 3) with gm "
            f"and epoch scalar or (N,); got r {r.shape}, v {v.shape}, gm {np.shape(gm)}, epoch "
            f"{np.shape(epoch)}. Flatten the states first (states[i] for each, or build them "
            "from r.reshape(-1, 3), v.reshape(-1, 3) and epochs of shape (N,))."
        )


def propagate_kepler_batch(states, t, *, on_error: str = "raise",
                           backend: str = "cpu") -> BatchStates:
    """Two-body motion of N states to T times (universal variables, every conic).

    Parameters
    ----------
    states : Catalog, sequence of Satellite, or StateVectors-like of shape (N,)
        For satellites the osculating TEME state at each element-set epoch (from SGP4) with
        sgp4's WGS-72 GM; otherwise any object with ``.r``, ``.v`` Quantities (N, 3), ``.gm`` and
        ``.epoch`` (astropy Time, scalar or (N,)).
    t : astropy Time, shape (T,) or scalar
        Absolute times.
    on_error : {"raise", "nan"}
        As in :func:`propagate_sgp4_batch`.
    backend : {"cpu", "cuda"}
        ``"cuda"``: the same solver compiled for an NVIDIA GPU from the same source
        (:mod:`visviva.core.cuda.twins`; extra ``visviva[gpu]``), one thread per pair; raises
        :class:`visviva.errors.BackendUnavailableError` saying what is missing without one.

    Returns
    -------
    BatchStates
        ``r`` (km), ``v`` (km/s), shape (N, T, 3), in the frame of the input states.

    Notes
    -----
    Calls :func:`visviva.core.universal.propagate_many` once over the N*T pairs (Danby 1992,
    sec. 6.9; Vallado 2013, Algorithm 8).
    """
    from .._backends import check_backend

    if check_backend(backend) == "cuda":
        from ..core.cuda.kernels import propagate_many
    else:
        from ..core.universal import propagate_many
    check_on_error(on_error)
    t = absolute_times(t, "propagate_kepler_batch")
    from .catalog import Catalog, as_catalog

    if isinstance(states, (Catalog, Satellite, list, tuple)):
        cat = as_catalog(states)
        ep = cat.epochs
        # each satellite at its own epoch (one sgp4 call per element set, not per step)
        out = [s.satrec.sgp4(s.satrec.jdsatepoch, s.satrec.jdsatepochF) for s in cat]
        e = np.array([o[0] for o in out], dtype=np.uint8)
        r0 = np.array([o[1] for o in out], dtype=np.float64).reshape(-1, 3)
        v0 = np.array([o[2] for o in out], dtype=np.float64).reshape(-1, 3)
        raise_for_sgp4_status(e[:, None], cat.names, 0.0)
        gm = np.array([s.satrec.mu for s in cat.satellites])
        names, frame = cat.names, "teme"
    else:
        r0 = to_vector(states.r, "length", "states.r")
        v0 = to_vector(states.v, "speed", "states.v")
        gm = to_array(states.gm, "gm", "states.gm")
        ep = getattr(states, "epoch", None)
        if not isinstance(ep, Time):
            raise InvalidInputError("states needs an .epoch (astropy Time) for absolute times t.")
        _require_one_axis(r0, v0, gm, ep)
        r0, v0 = r0.reshape(-1, 3), v0.reshape(-1, 3)
        gm = np.broadcast_to(gm, (r0.shape[0],))
        ep = ep.reshape(-1) if ep.ndim == 0 else ep
        names = [str(i) for i in range(r0.shape[0])]
        frame = require_kepler_frame(states, "propagate_kepler_batch")
    n, m = r0.shape[0], len(t)
    dt = _offsets_s(ep, t)
    dt = np.ascontiguousarray(np.broadcast_to(dt, (n, m))).reshape(-1)
    r0f = np.ascontiguousarray(np.broadcast_to(r0[:, None, :], (n, m, 3))).reshape(-1, 3)
    v0f = np.ascontiguousarray(np.broadcast_to(v0[:, None, :], (n, m, 3))).reshape(-1, 3)
    gmf = np.ascontiguousarray(np.broadcast_to(np.asarray(gm, float)[:, None], (n, m))).reshape(-1)
    r = np.empty((n * m, 3))
    v = np.empty((n * m, 3))
    status = np.empty(n * m, dtype=np.int64)
    propagate_many(r0f, v0f, gmf, dt, r, v, status)
    status = status.reshape(n, m)
    if on_error == "raise":
        raise_for_status(status, "Kepler batch propagation", dt_s=dt.reshape(n, m))
    return BatchStates(
        to_quantity(r.reshape(n, m, 3), "length"), to_quantity(v.reshape(n, m, 3), "speed"), t,
        status.astype(np.uint8), names, frame,
    )


def propagate_j2_batch(satellites, t, *, on_error: str = "raise") -> BatchStates:
    """Secular J2 propagation of SGP4 mean elements for N satellites at T times.

    The node, perigee and mean anomaly drift at the first-order secular J2 rates of
    :func:`visviva.satellites.secular.j2_secular_rates` (Brouwer 1959; Vallado 2013, eqs. 9-41)
    with SGP4's WGS-72 constants; a, e, i stay at their mean values (no drag, no periodic
    terms) and each state comes from Kepler's equation, in one compiled loop over the N x T
    pairs. A fast screening propagator (a few to tens of km from SGP4 over a day in LEO, since
    mean elements are used as if osculating), not a replacement for SGP4.

    Parameters
    ----------
    satellites : Catalog or sequence of Satellite
    t : astropy Time, shape (T,) or scalar
        Absolute times.
    on_error : {"raise", "nan"}

    Returns
    -------
    BatchStates
        TEME ``r`` (km), ``v`` (km/s), shape (N, T, 3).
    """
    check_on_error(on_error)
    from .catalog import as_catalog  # (the catalogue module imports this one)

    cat = as_catalog(satellites)
    t = absolute_times(t, "propagate_j2_batch")
    setup = cat.__dict__.get("_j2_setup")  # per-catalogue: elements, rates, epochs (TAI)
    if setup is None:
        setup = secular_setup([s.satrec for s in cat.satellites], cat.names, cat.epochs.tai)
        cat.__dict__["_j2_setup"] = setup
    (a, ecc, inc, raan, argp, M), (raan_dot, argp_dot, M_dot), gm, ep1, ep2 = setup
    from .frames import offline_iers

    with offline_iers():  # a time in UT1 needs the installed IERS table, never a download
        tt = t.tai
    n, m = len(cat), len(t)
    r = np.empty((n, m, 3))
    v = np.empty((n, m, 3))
    status = np.empty((n, m), dtype=np.int64)
    secular_grid(a, ecc, inc, raan, argp, M, raan_dot, argp_dot, M_dot, ep1, ep2,
                  np.ascontiguousarray(tt.jd1, dtype=np.float64),
                  np.ascontiguousarray(tt.jd2, dtype=np.float64), gm, r, v, status)
    if on_error == "raise" and status.any():
        raise_for_status(status, "secular J2 batch propagation", dt_s=_offsets_s(cat.epochs, t))
    return BatchStates(
        to_quantity(r, "length"), to_quantity(v, "speed"), t, status.astype(np.uint8),
        cat.names, "teme",
    )

