"""Times after an object's re-entry: the ``DECAY_DATE`` of an OMM record (Space-Track's GP
data) kept with the satellite, and the warning when positions are asked for after it.

SGP4 gives positions for any time, also after the object has burnt up: a satellite read from a
record with a ``DECAY_DATE`` warned when it was read (:func:`~.tle_checks.warn_decayed`), but
propagated past that date it went on silently (audit51). :meth:`visviva.Satellite.teme` (and
``gcrs``, ``itrs``, ``geodetic``) and the catalogue batches now warn
(:class:`~visviva.errors.DecayedObjectWarning`) once per satellite when a requested time lies
after 00:00 UTC of its decay date (:attr:`visviva.Satellite.decay_date`).
"""

from __future__ import annotations

import re
import warnings
import weakref

import numpy as np

from .._callsite import outside_stacklevel
from ..errors import DecayedObjectWarning, fmt_first

__all__ = ["decay_day", "warn_after_decay"]

#: the satellites already warned about (once each; a rebuilt copy, on a Dask worker, warns anew)
_WARNED: weakref.WeakSet = weakref.WeakSet()

_DATE = re.compile(r"\s*(\d{4})-(\d{2})-(\d{2})", re.ASCII)


def decay_day(text) -> float | None:
    """The UTC Julian date (sgp4's days of 86,400 s) of 00:00 UTC on a ``DECAY_DATE``.

    Parameters
    ----------
    text : str or None
        ``YYYY-MM-DD``, optionally followed by a time (which is ignored: the object may have
        re-entered at any time of that day).

    Returns
    -------
    float or None
        None when there is no date or it is not one (the record was warned about when read).
    """
    from sgp4.api import jday

    m = _DATE.match(str(text or ""))
    if m is None:
        return None
    year, month, day = (int(g) for g in m.groups())
    if not (1 <= month <= 12 and 1 <= day <= 31):
        return None
    jd, fr = jday(year, month, day, 0, 0, 0.0)
    return float(jd + fr)


def warn_after_decay(satellites, last_day: float) -> None:
    """Warn (:class:`~visviva.errors.DecayedObjectWarning`) once per satellite whose decay date
    (:attr:`~visviva.Satellite.decay_date`, from its OMM record's ``DECAY_DATE``) lies before
    ``last_day``.

    Parameters
    ----------
    satellites : iterable of Satellite
        Those asked for positions.
    last_day : float
        The latest requested time, UTC Julian date (sgp4's days).
    """
    if not np.isfinite(last_day):
        return
    late = []
    for s in satellites:
        if s.decay_date is None or s in _WARNED:
            continue
        start = decay_day(s.decay_date)
        if start is not None and last_day > start:
            late.append((s, start))
    if not late:
        return
    for s, _ in late:
        _WARNED.add(s)
    listed = fmt_first([f"{s.name!r} (DECAY_DATE {s.decay_date}, asked "
                        f"{last_day - start:.1f} days after its start)" for s, start in late])
    warnings.warn(
        f"positions asked for after the re-entry of {listed}: SGP4 still gives numbers "
        "there, of no object. Leave these satellites out, or ask only for times before their "
        "decay dates.", DecayedObjectWarning, stacklevel=outside_stacklevel())
