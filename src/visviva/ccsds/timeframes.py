"""CCSDS epochs, time systems, reference frames and centres, mapped to astropy and visviva.

* Epochs: ``YYYY-MM-DDThh:mm:ss.d...`` or ``YYYY-DDDThh:mm:ss`` (day of year) in the message's
  ``TIME_SYSTEM``; UTC, TAI, TT, TDB, TCB, TCG and UT1 are astropy time scales, GPS is TAI - 19 s.
  Other systems (MET, MRT, SCLK, ...) need a reference the message does not carry, so they are
  refused with a message saying so.
* Frames: ``EME2000``, ``ICRF``, ``GCRF`` are inertial frames that differ from the GCRS by at
  most the 23 mas frame bias (~1 m at GEO); visviva maps all three to ``"gcrs"``. ``TEME`` is
  ``"teme"``, ``ITRF``/``ITRF2000``/``ITRF-93``/``ITRF-97``/``ITRF2008``/``ITRF2014``/``ITRF2020``
  are ``"itrs"``. Other CCSDS frames (``TOD``, ``RTN``, ...) are read and written, but have no
  visviva frame (None).
* Centres: ``EARTH``, ``MOON``, ``SUN`` and the planets give their :class:`~visviva.bodies.Body`
  (its GM is that of the states).
"""

from __future__ import annotations

import re

import numpy as np

from .grammar import CCSDSFormatError

__all__ = ["TIME_SCALES", "epochs_to_time", "time_to_epochs", "visviva_frame", "center_body",
           "FrameCenterMetadata"]

#: CCSDS TIME_SYSTEM -> astropy scale (GPS is handled as TAI - 19 s)
TIME_SCALES = {"UTC": "utc", "TAI": "tai", "TT": "tt", "TDB": "tdb", "TCB": "tcb", "TCG": "tcg",
               "UT1": "ut1", "GPS": "tai"}
_GPS_MINUS_TAI_S = -19.0

_FRAMES = {"EME2000": "gcrs", "ICRF": "gcrs", "GCRF": "gcrs", "TEME": "teme",
           "ITRF": "itrs", "ITRF2000": "itrs", "ITRF-93": "itrs", "ITRF-97": "itrs",
           "ITRF93": "itrs", "ITRF97": "itrs", "ITRF2005": "itrs", "ITRF2008": "itrs",
           "ITRF2014": "itrs", "ITRF2020": "itrs"}
#: visviva frame -> the CCSDS name writers use
CCSDS_FRAME = {"gcrs": "GCRF", "teme": "TEME", "itrs": "ITRF"}

_ORDINAL = re.compile(r"^(\d{4})-(\d{3})T(.*?)Z?$")


def _scale(time_system: str, line, source):
    scale = TIME_SCALES.get(time_system.upper())
    if scale is None:
        raise CCSDSFormatError(
            f"TIME_SYSTEM {time_system!r} is not supported (visviva reads "
            f"{', '.join(TIME_SCALES)}); convert the epochs to one of these",
            line=line, source=source)
    return scale


def _iso(text: str) -> str:
    text = text.rstrip("Z")
    ordinal = _ORDINAL.match(text)
    if ordinal:  # astropy's 'yday' format: YYYY:DDD:hh:mm:ss
        return f"{ordinal.group(1)}:{ordinal.group(2)}:{ordinal.group(3)}"
    return text


def epochs_to_time(texts, time_system: str, line=None, source: str = "<text>"):
    """Convert CCSDS epoch strings to an astropy ``Time`` in the given time system.

    Parameters
    ----------
    texts : str or list of str
        Epochs as written in the message (already checked by the grammar).
    time_system : str
        The message's ``TIME_SYSTEM`` (``"UTC"``, ``"TDB"``, ``"GPS"``, ...).
    line : int or None
        Line of the first epoch, for error messages.
    source : str
        File name, for error messages.

    Returns
    -------
    astropy.time.Time
        Scalar for one string, else one-dimensional.
    """
    from astropy import units as u
    from astropy.time import Time

    scale = _scale(time_system, line, source)
    scalar = isinstance(texts, str)
    items = [texts] if scalar else list(texts)
    iso = [_iso(t) for t in items]
    kinds = {":" in t[4:5] for t in iso}
    try:
        if kinds == {True}:
            t = Time(iso, format="yday", scale=scale, precision=9)
        elif kinds == {False}:
            t = Time(iso, format="isot", scale=scale, precision=9)
        else:
            t = Time([Time(s, format="yday" if s[4] == ":" else "isot", scale=scale) for s in iso],
                     precision=9)
    except ValueError as exc:
        raise CCSDSFormatError(f"an epoch is not a valid date-time: {exc}", line=line,
                               source=source) from None
    if time_system.upper() == "GPS":
        t = t - _GPS_MINUS_TAI_S * u.s
    return t[0] if scalar else t


def time_to_epochs(t, time_system: str) -> list[str]:
    """Format times as CCSDS epochs (``YYYY-MM-DDThh:mm:ss.fffffffff``) in a time system.

    Parameters
    ----------
    t : astropy.time.Time
        Times (any scale; converted).
    time_system : str
        The CCSDS time system to write in.

    Returns
    -------
    list of str
        One epoch per time, nanosecond resolution.
    """
    from astropy import units as u

    _scale(time_system, None, "<output>")
    flat = t.reshape(-1) if t.ndim else t.reshape(1)
    if time_system.upper() == "GPS":
        flat = flat.tai + _GPS_MINUS_TAI_S * u.s
        out = flat.tai
    else:
        out = getattr(flat, TIME_SCALES[time_system.upper()])
    out = out.copy(format="isot")
    out.precision = 9
    return list(np.atleast_1d(out.value))


def visviva_frame(name: str) -> str | None:
    """The visviva frame (``"gcrs"``, ``"teme"``, ``"itrs"``) of a CCSDS ``REF_FRAME``.

    Parameters
    ----------
    name : str
        The CCSDS frame name, e.g. ``"EME2000"``.

    Returns
    -------
    str or None
        None for frames visviva has no transformation for.
    """
    return _FRAMES.get(name.strip().upper())


class FrameCenterMetadata:
    """Mixin for a message part with a ``metadata`` record: its frame and its centre.

    The class that uses it sets ``self.metadata`` (a :class:`~visviva.ccsds.grammar.Record` or
    a dict with ``REF_FRAME`` and ``CENTER_NAME``), as :class:`~visviva.ccsds.oem.OEMSegment`
    and :class:`~visviva.ccsds.opm.OPM` do.
    """

    @property
    def frame(self) -> str:
        """``REF_FRAME`` as written (``"EME2000"``, ``"GCRF"``, ``"TEME"``, ``"ITRF"`` ...)."""
        return self.metadata["REF_FRAME"]

    @property
    def visviva_frame(self) -> str | None:
        """The visviva frame of ``REF_FRAME`` (``"gcrs"``, ``"teme"``, ``"itrs"``) or None."""
        return visviva_frame(self.frame)

    @property
    def center(self) -> str:
        """``CENTER_NAME`` as written."""
        return self.metadata["CENTER_NAME"]


def center_body(name: str):
    """The :class:`~visviva.bodies.Body` named by a CCSDS ``CENTER_NAME``, or None.

    Parameters
    ----------
    name : str
        E.g. ``"EARTH"``, ``"MOON"``, ``"MARS"``, ``"MARS BARYCENTER"``.

    Returns
    -------
    visviva.bodies.Body or None
    """
    from .. import bodies

    key = name.strip().upper().replace(" BARYCENTER", "")
    body = getattr(bodies, key, None)
    return body if isinstance(body, bodies.Body) else None
