"""CCSDS epochs, time systems, reference frames and centres, mapped to astropy and visviva.

* Epochs: ``YYYY-MM-DDThh:mm:ss.d...`` or ``YYYY-DDDThh:mm:ss`` (day of year) in the message's
  ``TIME_SYSTEM``; UTC, TAI, TT, TDB, TCB, TCG and UT1 are astropy time scales, GPS is TAI - 19 s.
  MET (mission elapsed time) and MRT (mission relative time) count from a mission epoch agreed
  outside the message (CCSDS 502.0-B-3 annex: "time since launch" / "time since a
  mission-defined reference"): they are read and written when the user gives that epoch
  (``mission_epoch=Time(...)``), with each epoch written ``YYYY-DDDThh:mm:ss.f`` meaning
  YYYY Julian years + DDD days + the clock time elapsed (Orekit's reading). SCLK, GMST and the
  rest cannot be interpreted without a clock correlation or a rotation model: they are refused
  with a message saying what to do.
* Frames: ``ICRF`` and ``GCRF`` are the GCRS axes; ``EME2000`` (mean equator and equinox of
  J2000) differs from them by the constant frame bias :data:`FRAME_BIAS` (23 mas: 0.8 m in LEO,
  4.7 m at GEO), which the readers and writers apply (:func:`to_gcrs_axes`,
  :func:`from_gcrs_axes`); visviva maps all three to ``"gcrs"``. ``TEME`` is
  ``"teme"``, ``ITRF``/``ITRF2000``/``ITRF-93``/``ITRF-97``/``ITRF2008``/``ITRF2014``/``ITRF2020``
  are ``"itrs"``. Other CCSDS frames (``TOD``, ``RTN``, ...) are read and written, but have no
  visviva frame (None).
* Centres: ``EARTH``, ``MOON``, ``SUN`` and the planets give their :class:`~visviva.bodies.Body`
  (its GM is that of the states).
"""

from __future__ import annotations

import re
import warnings

import numpy as np

from ..errors import InvalidInputError
from .grammar import CCSDSFormatError, impossible_date

__all__ = ["FRAME_BIAS", "has_frame_bias", "to_gcrs_axes", "from_gcrs_axes", "TIME_SCALES",
           "RELATIVE_TIME_SYSTEMS", "epochs_to_time", "time_to_epochs",
           "visviva_frame", "earth_fixed", "center_body", "center_of", "FrameCenterMetadata",
           "ref_frame_of", "refuse_unused_mission_epoch"]

#: CCSDS TIME_SYSTEM -> astropy scale (GPS is handled as TAI - 19 s)
TIME_SCALES = {"UTC": "utc", "TAI": "tai", "TT": "tt", "TDB": "tdb", "TCB": "tcb", "TCG": "tcg",
               "UT1": "ut1", "GPS": "tai"}
_GPS_MINUS_TAI_S = -19.0
#: time systems counted from a mission epoch the user supplies: name -> what the epoch is
RELATIVE_TIME_SYSTEMS = {"MET": "the launch epoch", "MRT": "the mission's reference epoch"}
_JULIAN_YEAR_S = 365.25 * 86400.0
_ELAPSED = re.compile(r"^(\d{4})-(\d{3})T(\d{2}):(\d{2}):(\d{2}(?:\.\d*)?)Z?$", re.ASCII)

_FRAMES = {"EME2000": "gcrs", "ICRF": "gcrs", "GCRF": "gcrs", "GCRS": "gcrs", "TEME": "teme",
           "ITRF": "itrs", "ITRS": "itrs", "ITRF2000": "itrs", "ITRF-93": "itrs", "ITRF-97": "itrs",
           "ITRF93": "itrs", "ITRF97": "itrs", "ITRF2005": "itrs", "ITRF2008": "itrs",
           "ITRF2014": "itrs", "ITRF2020": "itrs"}


def _frame_bias() -> np.ndarray:
    import erfa  # (installed with astropy)

    # ERFA bp06's rb: the IAU 2006 frame bias, dα0 = -14.6 mas, ξ0 = -16.617 mas,
    # η0 = -6.819 mas; constant (the same at every date)
    rb = np.array(erfa.bp06(2451545.0, 0.0)[0], dtype=np.float64)
    rb.setflags(write=False)
    return rb


#: The frame-bias matrix B: GCRS (ICRF, GCRF) axes -> mean equator and equinox of J2000
#: (EME2000) axes, ``r_eme2000 = B @ r_gcrs``. References: IERS Conventions (2010), TN 36,
#: eq. 5.21 and 5.33; ERFA ``bp06`` (``rb``). Orekit, STK (J2000 vs ICRF) and GMAT
#: (EarthMJ2000Eq vs EarthICRF) apply it: 0.8 m in LEO, 4.7 m at GEO.
FRAME_BIAS = _frame_bias()
#: the CCSDS frames on the mean J2000 axes (about any centre)
_BIASED_FRAMES = ("EME2000",)


def _bias(name):
    return FRAME_BIAS if str(name).strip().upper() in _BIASED_FRAMES else None


def has_frame_bias(name) -> bool:
    """Whether the CCSDS frame ``name`` is on the mean J2000 axes (EME2000), which
    :func:`to_gcrs_axes` turns by :data:`FRAME_BIAS`."""
    return _bias(name) is not None


def to_gcrs_axes(name, *arrays):
    """Vectors (``(..., 3)``) or covariances (``(..., 6, 6)``, km and km/s blocks) on the axes of
    the CCSDS frame ``name``, rotated to the GCRS/ICRF axes (EME2000: ``B.T``
    :data:`FRAME_BIAS`; other frames: unchanged).

    Parameters
    ----------
    name : str
        The CCSDS ``REF_FRAME``.
    *arrays : array_like
        Vectors (last axis 3) or 6x6 covariances (last two axes 6).

    Returns
    -------
    tuple of ndarray
        The arrays on the GCRS axes, in the order given.
    """
    b = _bias(name)
    return tuple(_rotate(a, None if b is None else b.T) for a in arrays)


def from_gcrs_axes(name, *arrays):
    """The inverse of :func:`to_gcrs_axes`: GCRS/ICRF axes to those of ``name`` (EME2000: ``B``);
    the same parameters, and the arrays on ``name``'s axes in the order given."""
    return tuple(_rotate(a, _bias(name)) for a in arrays)


def _rotate(a, m):
    if m is None:
        return a
    a = np.asarray(a, dtype=np.float64)
    if a.shape[-2:] == (6, 6):
        m6 = np.zeros((6, 6))
        m6[:3, :3] = m6[3:, 3:] = m
        return m6 @ a @ m6.T
    return a @ m.T


#: visviva frame -> the CCSDS name writers use
CCSDS_FRAME = {"gcrs": "GCRF", "teme": "TEME", "itrs": "ITRF"}

_ORDINAL = re.compile(r"^(\d{4})-(\d{3})T(.*?)Z?$", re.ASCII)


def _scale(time_system: str, line, source, mission_epoch=None):
    """The astropy scale of a CCSDS time system; None for MET/MRT given a mission epoch."""
    name = time_system.upper()
    if name in RELATIVE_TIME_SYSTEMS:
        if mission_epoch is None:
            raise CCSDSFormatError(
                f"TIME_SYSTEM {name} counts time from {RELATIVE_TIME_SYSTEMS[name]}, which the "
                f"message does not carry: pass mission_epoch=Time(...) (that epoch, as agreed "
                f"for the mission) to the reader or writer (--mission-epoch ISO on the command "
                f"line)", line=line, source=source)
        _check_mission_epoch(mission_epoch)
        return None
    scale = TIME_SCALES.get(name)
    if scale is None:
        raise CCSDSFormatError(
            f"TIME_SYSTEM {time_system!r} is not supported (visviva reads "
            f"{', '.join(TIME_SCALES)}, and MET/MRT given mission_epoch=); convert the epochs "
            "to one of these", line=line, source=source)
    return scale


def _check_mission_epoch(mission_epoch):
    from astropy.time import Time

    if not isinstance(mission_epoch, Time) or not mission_epoch.isscalar:
        raise InvalidInputError(
            f"mission_epoch must be one astropy Time (the epoch MET/MRT count from); got "
            f"{type(mission_epoch).__name__}")


def refuse_unused_mission_epoch(mission_epoch, time_systems, source, line=None) -> None:
    """Raise InvalidInputError when a reader was given ``mission_epoch`` and no
    ``TIME_SYSTEM`` of the message is MET or MRT: the epoch would be ignored in silence (a
    user who believed the file counted from launch would read its UTC epochs unchanged).

    ``time_systems``: the message's TIME_SYSTEM values (one per OEM segment); ``line``: the
    first one's line, quoted in the message."""
    if mission_epoch is None:
        return
    names = [str(ts).strip().upper() for ts in time_systems]
    if any(n in RELATIVE_TIME_SYSTEMS for n in names):
        return
    where = f"{source}" + (f", line {line}" if line is not None else "")
    raise InvalidInputError(
        f"{where}: mission_epoch was given, but the message's TIME_SYSTEM is "
        f"{', '.join(dict.fromkeys(names))}, not MET or MRT, so no epoch counts from it; omit "
        "mission_epoch (--mission-epoch on the command line), or check that this is the file "
        "you meant.")


def _line_at(line, k):
    """Line of item ``k``: ``line`` is one line number, a sequence of them, or None."""
    return line[k] if isinstance(line, list | tuple) else line


def _elapsed(texts, time_system, line, source):
    """Elapsed time of MET/MRT epochs as (whole days, seconds of the day), each (N,)."""
    days = np.empty(len(texts))
    secs = np.empty(len(texts))
    for i, text in enumerate(texts):
        m = _ELAPSED.match(text.strip())
        if m is None:
            raise CCSDSFormatError(
                f"in TIME_SYSTEM {time_system} an epoch is elapsed time written "
                f"YYYY-DDDThh:mm:ss (years, days and clock time since the mission epoch); "
                f"got {text!r}", line=_line_at(line, i), source=source)
        years, dd, hh, mm = (int(g) for g in m.groups()[:4])
        days[i] = years * 365.25 + dd  # a multiple of 1/4: exact
        secs[i] = hh * 3600.0 + mm * 60.0 + float(m.group(5))
    return days, secs


def _format_elapsed(delta) -> list[str]:
    """MET/MRT text of TimeDelta(s) from the mission epoch, without losing the nanoseconds."""
    jd1 = np.atleast_1d(delta.jd1)
    jd2 = np.atleast_1d(delta.jd2)
    whole = np.floor(jd1) + np.floor(jd2)
    frac = (jd1 - np.floor(jd1)) + (jd2 - np.floor(jd2))  # [0, 2) days
    out = []
    for w, f in zip(whole, frac, strict=True):
        if w + f < 0:
            raise InvalidInputError(
                f"a time {(w + f) * 86400.0:.3f} s before the mission epoch cannot be written in "
                "MET/MRT (elapsed time is not negative); choose an earlier mission_epoch or "
                "another time system")
        years = int((w + f) // 365.25)
        rest = w - years * 365.25  # exact (quarter days)
        days = int(np.floor(rest + f))
        sec = round((rest - days) * 86400.0 + f * 86400.0, 9)
        while sec < 0.0:  # rest + f rounded up across a day boundary
            days, sec = days - 1, sec + 86400.0
        while sec >= 86400.0:
            days, sec = days + 1, sec - 86400.0
        hh = int(sec // 3600.0)
        mm = int((sec - hh * 3600.0) // 60.0)
        ss = sec - hh * 3600.0 - mm * 60.0
        out.append(f"{years:04d}-{days:03d}T{hh:02d}:{mm:02d}:{ss:012.9f}")
    return out


def _iso(text: str) -> str:
    text = text.rstrip("Z")
    ordinal = _ORDINAL.match(text)
    if ordinal:  # astropy's 'yday' format: YYYY:DDD:hh:mm:ss
        return f"{ordinal.group(1)}:{ordinal.group(2)}:{ordinal.group(3)}"
    return text


def epochs_to_time(texts, time_system: str, line=None, source: str = "<text>",
                   mission_epoch=None, *, system_line=None):  # fmt: skip
    """Convert CCSDS epoch strings to an astropy ``Time`` in the given time system.

    Parameters
    ----------
    texts : str or list of str
        Epochs as written in the message (already checked by the grammar).
    time_system : str
        The message's ``TIME_SYSTEM`` (``"UTC"``, ``"TDB"``, ``"GPS"``, ...).
    line : int, list of int or None
        Line of the epoch (or of each epoch), for error messages.
    source : str
        File name, for error messages.
    mission_epoch : astropy.time.Time, optional
        The epoch MET/MRT count from (needed for those systems only).
    system_line : int or None
        Line of ``TIME_SYSTEM``, for an unsupported time system (default: ``line``).

    Returns
    -------
    astropy.time.Time
        Scalar for one string, else one-dimensional (for MET/MRT: in the scale of
        ``mission_epoch``, elapsed SI seconds added).
    """
    from astropy import units as u
    if system_line is None and not isinstance(line, list | tuple):
        system_line = line
    scale = _scale(time_system, system_line, source, mission_epoch)
    scalar = isinstance(texts, str)
    items = [texts] if scalar else list(texts)
    if scale is None:
        from astropy.time import TimeDelta

        days, secs = _elapsed(items, time_system.upper(), line, source)
        t = mission_epoch + TimeDelta(days, secs / 86400.0, format="jd", scale="tai")
        return t[0] if scalar else t
    _warn_zulu(items, time_system, line, source)
    iso = [_iso(t) for t in items]
    with warnings.catch_warnings():  # a second 60 that is no leap second: refused below
        warnings.filterwarnings("ignore", message=".*after end of day")
        t = _parse(iso, items, scale, line, source)
    _check_leap_seconds(iso, items, t, scale, time_system, line, source)
    if time_system.upper() == "GPS":
        t = t - _GPS_MINUS_TAI_S * u.s
    return t[0] if scalar else t


def _warn_zulu(items, time_system, line, source):
    """Warn, naming the first such epoch's line, when epochs end with ``Z`` (or carried a zero
    UTC offset, which the grammar reads as ``Z``) in a message whose ``TIME_SYSTEM`` is not UTC.

    CCSDS 502.0-B-3 (7.5.10) makes ``Z`` an optional terminator of the epoch, which is in the
    ``TIME_SYSTEM``, so the epochs are read in it; but ``Z`` (ISO 8601) and ``+00:00`` say UTC
    to most writers, and a UTC time read as TT is 69.184 s late, as GPS 18 s early.
    """
    if time_system.strip().upper() == "UTC":
        return
    k = next((k for k, text in enumerate(items) if text.rstrip().endswith("Z")), None)
    if k is None:
        return
    where = f"{source}" + (f", line {_line_at(line, k)}" if _line_at(line, k) is not None else "")
    warnings.warn(
        f"{where}: the epoch {items[k]!r} ends with 'Z' (or a zero UTC offset), which ISO 8601 "
        f"reads as UTC, but TIME_SYSTEM = {time_system.strip()}; it is read in "
        f"{time_system.strip()} (CCSDS 502.0-B-3: 'Z' only ends the epoch). If the epochs are "
        "UTC, write TIME_SYSTEM = UTC; if they are in the TIME_SYSTEM, drop the 'Z'.",
        UserWarning, stacklevel=3)


def _parse(iso, items, scale, line, source):
    """astropy Time of ISO or ``yday`` texts (one format each), nanosecond precision."""
    from astropy.time import Time

    kinds = {":" in t[4:5] for t in iso}
    try:
        if kinds == {True}:
            t = Time(iso, format="yday", scale=scale, precision=9)
        elif kinds == {False}:
            t = Time(iso, format="isot", scale=scale, precision=9)
        else:
            t = Time([Time(s, format="yday" if s[4] == ":" else "isot", scale=scale) for s in iso],
                     precision=9)
    except ValueError:
        raise _bad_epoch(iso, items, scale, line, source) from None
    if True in kinds:  # astropy reads day 366 of a common year as January 1 of the next
        for k, text in enumerate(iso):
            if text[4:5] != ":" or text[5:8] < "366":  # (fast path: every other day exists)
                continue
            why = impossible_date(items[k])
            if why:
                raise CCSDSFormatError(f"the epoch {items[k]!r} is not a date that exists "
                                       f"({why})", line=_line_at(line, k), source=source)
    return t


def _check_leap_seconds(iso, items, t, scale, time_system, line, source):
    """Refuse a second 60 that is no leap second (astropy reads ``23:59:60.5`` of any day, in
    any scale, as 00:00:00.5 of the next day).

    CCSDS 502.0 allows ``23:59:60.x`` in UTC at the end of a day that ends with a leap second
    (e.g. 2016-12-31); TAI, TT, TDB, GPS and the other uniform scales have no such second.
    """
    for k, text in enumerate(iso):
        if float(text.rpartition(":")[2]) < 60.0:
            continue
        if scale == "utc":
            one = t if t.isscalar else t[k]
            written = one.utc.copy(format="isot").value
            if written[11:19] == "23:59:60":  # astropy names it a leap second: it is one
                continue
            why = (f"UTC has no such second on {items[k].partition('T')[0]} (a leap second is "
                   "23:59:60.x at the end of a day that has one, e.g. 2016-12-31T23:59:60.5)")
        else:
            why = f"{time_system.upper()} is a uniform time scale without leap seconds"
        raise CCSDSFormatError(
            f"the epoch {items[k]!r} has second 60 or more, but {why}; write the next minute "
            "(hh:mm+1:ss-60) instead", line=_line_at(line, k), source=source)


def _bad_epoch(iso, items, scale, line, source):
    """The error for the first epoch that astropy cannot read, naming its line."""
    from astropy.time import Time

    for k, text in enumerate(iso):
        try:
            Time(text, format="yday" if text[4:5] == ":" else "isot", scale=scale)
        except ValueError as exc:
            reason = str(exc).strip().splitlines()[-1].rsplit(" of ", 1)[-1].strip('"')
            return CCSDSFormatError(f"the epoch {items[k]!r} is not a valid date-time ({reason})",
                                    line=_line_at(line, k), source=source)
    return CCSDSFormatError("the epochs are not valid date-times", line=_line_at(line, 0),
                            source=source)


def time_to_epochs(t, time_system: str, mission_epoch=None) -> list[str]:
    """Format times as CCSDS epochs (``YYYY-MM-DDThh:mm:ss.fffffffff``) in a time system.

    Parameters
    ----------
    t : astropy.time.Time
        Times (any scale; converted).
    time_system : str
        The CCSDS time system to write in.
    mission_epoch : astropy.time.Time, optional
        The epoch MET/MRT count from (needed for those systems only).

    Returns
    -------
    list of str
        One epoch per time, nanosecond resolution.
    """
    from astropy import units as u

    from ..satellites.frames import offline_iers

    scale = _scale(time_system, None, "<output>", mission_epoch)
    flat = t.reshape(-1) if t.ndim else t.reshape(1)
    with offline_iers():  # UT1 needs the installed IERS table, never a download
        if scale is None:
            return _format_elapsed(flat.tai - mission_epoch.tai)
        if time_system.upper() == "GPS":
            flat = flat.tai + _GPS_MINUS_TAI_S * u.s
            out = flat.tai
        else:
            out = getattr(flat, TIME_SCALES[time_system.upper()])
    out = out.copy(format="isot")
    out.precision = 9
    return list(np.atleast_1d(out.value))


def earth_fixed(name: str) -> bool:
    """Whether a CCSDS ``REF_FRAME`` rotates with the Earth (ITRF and its realisations, ITRS, GRC,
    TDR, GTOD, PEF, EFG, ECF, ECEF, ECR: :data:`visviva._containers.EARTH_FIXED_NAMES`): a
    velocity on its axes is not the inertial velocity.

    Parameters
    ----------
    name : str
        The CCSDS frame name.

    Returns
    -------
    bool
    """
    from .._containers import earth_fixed_name

    return visviva_frame(str(name)) == "itrs" or earth_fixed_name(name)


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


#: the CCSDS REF_FRAME written for states that know their visviva frame
_CCSDS_NAME = {"teme": "TEME", "gcrs": "GCRF", "itrs": "ITRF"}


def ref_frame_of(states, frame: str | None, center: str = "EARTH") -> str:
    """The ``REF_FRAME`` to write for ``states``: ``frame``, or their own when they know it
    (``sat.teme(t)``: ``"TEME"``; a message's ``TOD`` states: ``"TOD"``), else ``"GCRF"`` about
    the Earth and ``"ICRF"`` about another
    centre (the GCRF is geocentric); a ``frame`` that contradicts theirs is refused.

    Parameters
    ----------
    states : StateVectors
        The states to write (satellite states carry ``.frame``).
    frame : str or None
        The CCSDS frame asked for.
    center : str
        The ``CENTER_NAME`` written with them.

    Returns
    -------
    str
    """
    from ..satellites.satellite_states import frame_of

    # (their visviva frame, or the REF_FRAME they were read in when visviva has no rotation for
    # it, "TOD": such states were written GCRF, 0.33 deg of precession away in 2024)
    own = frame_of(states)
    foreign = own is not None and own not in _CCSDS_NAME
    if frame is None:
        if foreign:
            return own
        earth = str(center).strip().upper() == "EARTH"
        return _CCSDS_NAME.get(own, "GCRF" if earth else "ICRF")
    if foreign and str(frame).strip().upper() != own.strip().upper():
        raise InvalidInputError(
            f"the states were read in REF_FRAME = {own} (they say so) but frame={frame!r} was "
            f"asked for: visviva cannot rotate {own}; leave frame out to write {own}, or pass "
            f"states in {frame}.")
    if own is not None and not foreign and visviva_frame(str(frame)) != own:
        raise InvalidInputError(
            f"the states are in {str(own).upper()} (they say so) but frame={frame!r} was asked "
            f"for: leave frame out to write {_CCSDS_NAME.get(own, own)}, or pass states in "
            f"{frame}.")
    return frame


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

    def visviva_axes(self, r_km, v_km_s, times):
        """Numbers on the axes of ``REF_FRAME`` turned to those of its visviva frame: EME2000
        by the frame bias (:func:`to_gcrs_axes`), TEME of ``REF_FRAME_EPOCH`` to the TEME of
        each state's date (``times``); others unchanged. Returns ``(r_km, v_km_s)``."""
        r_km, v_km_s = to_gcrs_axes(self.frame, r_km, v_km_s)
        meta = self.metadata
        if self.visviva_frame != "teme" or meta.get("REF_FRAME_EPOCH") in (None, ""):
            return r_km, v_km_s
        from ..satellites.frames import teme_of_epoch_to_teme

        line = meta.line_of("REF_FRAME_EPOCH") if hasattr(meta, "line_of") else None
        t0 = epochs_to_time(meta["REF_FRAME_EPOCH"], meta["TIME_SYSTEM"], line,
                            getattr(self, "source", "<text>"), getattr(self, "mission_epoch", None))
        return teme_of_epoch_to_teme(r_km, v_km_s, t0, times)

    def wrap_states(self, r_km, v_km_s, gm_km3_s2, times):
        """States of this message, labelled with their visviva frame when Earth-centred (so
        that TEME or ITRF data are not taken for GCRS downstream); EME2000 numbers (about any
        centre) are rotated to the GCRS/ICRF axes by the frame bias (:func:`to_gcrs_axes`),
        TEME ones with a ``REF_FRAME_EPOCH`` (TEME of that epoch) to the TEME of their dates.

        Parameters
        ----------
        r_km, v_km_s : ndarray (..., 3)
            Positions (km) and velocities (km/s) in ``REF_FRAME``.
        gm_km3_s2 : float
            Central GM, km^3/s^2.
        times : astropy.time.Time
            Their times.

        Returns
        -------
        StateVectors
            A :class:`~visviva.satellites.SatelliteStates` with ``.frame`` for Earth-centred
            GCRS/TEME/ITRS data, else plain (Earth-centred data in another frame remember its
            name, so that :func:`~visviva.satellites.satellite_states.require_gcrs` refuses
            them).
        """
        from ..satellites.satellite_states import framed_states

        earth = str(self.center).strip().upper() == "EARTH"
        r_km, v_km_s = self.visviva_axes(r_km, v_km_s, times)
        return framed_states(r_km, v_km_s, gm_km3_s2, times,
                             self.visviva_frame if earth else None,
                             foreign=self.frame if earth else None)


#: the centres a state's GM names when the writer is not told (the bodies of :mod:`visviva.bodies`)
_CENTRES = ("EARTH", "MOON", "SUN", "MERCURY", "VENUS", "MARS", "JUPITER", "SATURN", "URANUS",
            "NEPTUNE", "PLUTO")
#: relative difference below which a state's GM is a body's (Earth models differ by 2e-8, a
#: planet and its system's barycentre by up to 2e-4; two bodies by a factor 1.2 at least)
_GM_RTOL = 1e-3


def center_of(states, center: str | None) -> str:
    """The ``CENTER_NAME`` to write for ``states``: ``center`` checked against their GM, else
    the body whose GM is theirs (``"EARTH"`` for bare arrays, which carry no GM).

    Parameters
    ----------
    states : StateVectors or None
        The states written (their ``gm``), or None for bare arrays.
    center : str or None
        The centre asked for.

    Returns
    -------
    str

    Raises
    ------
    InvalidInputError
        A ``center`` whose body has another GM than the states (a Moon-centred state written
        ``CENTER_NAME = EARTH`` would read back with the Earth's GM), or, with no ``center``, a
        GM that is no body's.
    """
    gm = getattr(states, "gm", None)
    if gm is None:
        return "EARTH" if center is None else center
    gm = np.atleast_1d(np.asarray(gm.to_value("km3 / s2"), dtype=np.float64))

    def same(body):
        ref = body.gm_km3_s2
        return bool(np.all(np.abs(gm - ref) <= _GM_RTOL * ref))

    if center is not None:
        body = center_body(str(center))
        if body is not None and not same(body):
            raise InvalidInputError(
                f"center = {center!r} has GM {body.gm_km3_s2:.10g} km3/s2, but the states' gm "
                f"is {gm[0]:.10g} km3/s2: the message would read back with the centre's GM. "
                "Pass the centre the states are about (leave center out to take it from their "
                "gm).")
        return center
    from .. import bodies

    for name in _CENTRES:
        if same(getattr(bodies, name)):
            return name
    raise InvalidInputError(
        f"the states' gm = {gm[0]:.10g} km3/s2 is no body's visviva knows, so CENTER_NAME "
        "cannot be told from it: pass center='...' (e.g. 'EARTH', 'MOON', 'MARS BARYCENTER').")


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

    key = name.strip().upper()
    if key.endswith(" BARYCENTER"):
        key = key.removesuffix(" BARYCENTER").strip()
        if key not in _BODY_AT_BARYCENTER:  # (the moons pull it away: no body sits there)
            return None
    body = getattr(bodies, key, None)
    return body if isinstance(body, bodies.Body) else None


#: the systems whose barycentre is the body's centre to better than a metre (no moons, or
#: Mars's two small ones); the Earth-Moon barycentre is 4,671 km from the geocentre, Pluto's
#: ~2,100 km from Pluto, Saturn's and Jupiter's hundreds of km from the planet, and the planet's
#: GM is not the system's: states about them are not states about the body
_BODY_AT_BARYCENTER = frozenset({"MERCURY", "VENUS", "MARS"})


def barycentre_note(name: str) -> str:
    """Why a ``CENTER_NAME`` that is a barycentre has no body (``""`` for other names).

    Parameters
    ----------
    name : str
        A ``CENTER_NAME``.

    Returns
    -------
    str
    """
    key = str(name).strip().upper()
    if not key.endswith(" BARYCENTER") or center_body(key) is not None:
        return ""
    system = key.removesuffix(" BARYCENTER").strip()
    where = ("the Earth-Moon barycentre, 4,671 km from the Earth's centre" if system == "EARTH"
             else f"the barycentre of the {system.title()} system, not the centre of a body")
    return (f" ({where}: a central-body GM there would propagate the states wrongly; "
            "transform them to the body's centre first)")
