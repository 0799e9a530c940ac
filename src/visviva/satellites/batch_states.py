"""The result of the batch propagators and the checks of their arguments.

:class:`BatchStates` holds N objects at T times (``(N, T, 3)`` positions and velocities, a
status per state); :func:`absolute_times` and :func:`check_on_error` check the arguments every
batch function shares; :func:`offsets_s` gives the (N, T) seconds from N epochs to T times.
The propagators themselves (:func:`~visviva.satellites.catalog.propagate_sgp4_batch`,
``propagate_kepler_batch``, ``propagate_j2_batch``) live with the
:class:`~visviva.satellites.catalog.Catalog` they take, in :mod:`visviva.satellites.catalog`,
which imports :class:`BatchStates` (its public path ``visviva.satellites.catalog.BatchStates``).
"""

from __future__ import annotations

import numpy as np
from astropy import units as u
from astropy.time import Time

from .._units import time_input_name, to_quantity
from ..constants import DAY_S
from ..errors import InvalidInputError, ShapeError, UnitsError

__all__ = ["BatchStates", "absolute_times", "check_on_error", "offsets_s"]

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
        0 where the propagation succeeded; otherwise, for SGP4, sgp4's error code (1-6) or
        visviva's :data:`~visviva.satellites.tle_checks.SGP4_BEYOND_EARTH_ORBIT` (100: a
        position more than 1e6 km from the geocentre, returned by sgp4 without a code), and
        for the Kepler and J2 propagators a :mod:`visviva.core.status` code (0-16).
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
        """The same states in ``"teme"``, ``"gcrs"`` or ``"itrs"`` (any case), with astropy's
        frames.

        One 6 x 6 map per time from astropy's rotation matrices, shared by the N objects
        (:func:`visviva.satellites.frames.transform_batch`), equal to transforming every state
        with astropy's frame graph to ~1e-11 km and ~1e-10 km/s.
        """
        from .frames import frame_name, transform_batch

        frame = frame_name(frame)
        if frame == self.frame:
            return self
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
            f"{time_input_name(t)}. For offsets from one epoch use epoch + dt, e.g. "
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


def offsets_s(epochs: Time, t: Time) -> np.ndarray:
    """(N, T) seconds from each epoch to each time (TAI differences: leap seconds counted)."""
    from .frames import offline_iers

    with offline_iers():  # a time in UT1 needs the installed IERS table, never a download
        e = epochs.tai
        tt = t.tai
    return ((tt.jd1[None, :] - e.jd1[:, None]) + (tt.jd2[None, :] - e.jd2[:, None])) * DAY_S


