"""Earth satellites from two-line element sets (TLE) and OMM records, propagated with SGP4.

SGP4 itself is the ``sgp4`` package (Vallado's C++ code, wrapped by Brandon Rhodes); visviva
never re-implements it. This module checks the element sets, converts times once, calls sgp4 once
per array of times, turns sgp4's error codes into typed exceptions that name the satellite and
the reason, and hands frame conversions to :mod:`visviva.satellites.frames` (astropy).

SGP4 works with *mean* elements (Brouwer/Kozai, WGS-72 constants, TEME frame): the numbers in a
TLE are not osculating elements, and only SGP4 turns them into positions consistently.
"""

from __future__ import annotations

import math
import re
import warnings
from datetime import datetime, timedelta
from functools import cached_property

import numpy as np
from astropy import units as u
from astropy.time import Time

from ..errors import (
    DecayedObjectWarning,
    InvalidElementsError,
    InvalidInputError,
    SubsurfacePerigeeWarning,
)
from .catalog_numbers import catalogue_number, sgp4_number
from .decay import warn_after_decay
from .satellite_states import SatelliteStates
from .tle_checks import (
    MINUTES_PER_DAY,
    OMM_KEYS,
    SGP4_ERROR_TYPES,
    TLE_COLUMNS,
    SatelliteDecayedError,
    SGP4EccentricityError,
    SGP4Error,
    SGP4MeanMotionError,
    SGP4SemiLatusRectumError,
    TLEFormatError,
    check_element_ranges,
    check_tle_epoch,
    check_tle_lines,
    check_tsince,
    flag_beyond_earth_orbit,
    raise_for_sgp4_status,
    sgp4_times,
    warn_decayed,
    warn_stale_tsince,
    warn_subsurface_perigee,
)
from .tle_export import tle_designator
from .utc_days import utc_days_to_time

#: names also importable from here (their modules: tle_checks, satellite_states)
__all__ = [
    "Satellite",
    "SatelliteStates",
    "TLEFormatError",
    "SGP4Error",
    "SGP4EccentricityError",
    "SGP4MeanMotionError",
    "SGP4SemiLatusRectumError",
    "SatelliteDecayedError",
    "SGP4_ERROR_TYPES",
    "check_tle_lines",
    "sgp4_times",
    "raise_for_sgp4_status",
]


# --------------------------------------------------------------------------------------------
# Satellite
# --------------------------------------------------------------------------------------------
_OMM_REQUIRED = (
    "EPOCH",
    "MEAN_MOTION",
    "ECCENTRICITY",
    "INCLINATION",
    "RA_OF_ASC_NODE",
    "ARG_OF_PERICENTER",
    "MEAN_ANOMALY",
    "NORAD_CAT_ID",
    "BSTAR",
)
#: the units of the OMM's numeric mean elements (CCSDS 502.0-B-3 table 4-3; sgp4's OMM)
_OMM_UNITS = {"MEAN_MOTION": "rev/day", "ECCENTRICITY": "dimensionless",
             "INCLINATION": "deg", "RA_OF_ASC_NODE": "deg", "ARG_OF_PERICENTER": "deg",
             "MEAN_ANOMALY": "deg", "BSTAR": "1/earth radii", "MEAN_MOTION_DOT": "rev/day^2",
             "MEAN_MOTION_DDOT": "rev/day^3"}
_OMM_DEFAULTS = {
    "CLASSIFICATION_TYPE": "U",
    "EPHEMERIS_TYPE": 0,
    "ELEMENT_SET_NO": 999,
    "REV_AT_EPOCH": 0,
    "MEAN_MOTION_DOT": 0.0,
    "MEAN_MOTION_DDOT": 0.0,
    "OBJECT_ID": "",
}


_OMM_EPOCH = re.compile(r"(\d{4})-(?:(\d{2})-(\d{2})|(\d{3}))[T ](\d{2}):(\d{2}):(\d{2})"
                        r"(\.\d*)?(Z|[+-]\d{2}(?::?\d{2})?)?", re.ASCII)


def _omm_epoch(text: str) -> str:
    """Normalise an OMM EPOCH to ``YYYY-mm-ddTHH:MM:SS.ffffff`` (what sgp4.omm parses).

    CCSDS 502.0 epochs: calendar (``2024-01-31T12:00:00.123``) or day-of-year
    (``2024-031T12:00:00``) dates, any number of decimals (rounded to the microsecond sgp4
    keeps), an optional ``Z`` or a UTC offset of zero (``+00:00``, ``-00:00``, ``+0000``,
    ``+00``: ISO 8601 writers such as Python's ``datetime.isoformat`` add one; refused before
    audit51). Another offset is refused: SGP4 epochs are UTC, and the offset would have to be
    subtracted.
    """
    raw = str(text).strip()
    m = _OMM_EPOCH.fullmatch(raw)
    offset = m.group(9) if m is not None else None
    if offset not in (None, "Z") and any(c not in "+-:0" for c in offset):
        raise InvalidInputError(
            f"OMM EPOCH {raw!r} carries the UTC offset {offset}; an OMM epoch is UTC (offset "
            "zero, 'Z' or '+00:00'): subtract the offset from the time and write it without "
            "one.")
    try:
        if m is None:
            raise ValueError(raw)
        year, month, day, doy, hh, mm, ss = (None if g is None else int(g) for g in m.groups()[:7])
        start = (datetime(year, month, day) if doy is None
                 else datetime(year, 1, 1) + timedelta(days=doy - 1))
        if doy is not None and (doy < 1 or start.year != year):  # day 366 of a common year
            raise ValueError(raw)
        micro = round(float("0" + (m.group(8) or ".0")) * 1e6)
        when = start + timedelta(hours=_clock(hh, 24), minutes=_clock(mm, 60),
                                 seconds=_clock(ss, 60), microseconds=micro)
    except ValueError:
        raise InvalidInputError(
            f"OMM EPOCH {raw!r} is not a UTC date-time like '2024-01-31T12:00:00.000000' or "
            "'2024-031T12:00:00' (day of year); a leap second (23:59:60) cannot be an SGP4 "
            "epoch."
        ) from None
    return when.strftime("%Y-%m-%dT%H:%M:%S.%f")


def _clock(value: int, limit: int) -> int:
    """An hour, minute or second field checked against its limit (ValueError past it)."""
    if not 0 <= value < limit:
        raise ValueError(value)
    return value



#: OMM metadata that SGP4 mean elements must carry when given: keyword -> accepted values
_SGP4_METADATA = {"TIME_SYSTEM": ("UTC",), "REF_FRAME": ("TEME",), "CENTER_NAME": ("EARTH",),
                  "MEAN_ELEMENT_THEORY": ("SGP4", "SGP/SGP4")}


def _check_sgp4_metadata(fields) -> None:
    """Refuse an OMM whose metadata says its elements are not SGP4's (UTC, TEME, Earth),
    naming every keyword that says so."""
    wrong = [f"{key} = {fields[key]}" for key, accepted in _SGP4_METADATA.items()
             if fields.get(key) not in (None, "")
             and str(fields[key]).strip().upper() not in accepted]
    if wrong:
        raise InvalidInputError(
            f"OMM record {fields.get('OBJECT_NAME', '')!r} has {', '.join(wrong)}; SGP4 mean "
            "elements are TIME_SYSTEM UTC, REF_FRAME TEME, CENTER_NAME EARTH, "
            "MEAN_ELEMENT_THEORY SGP4. Propagating these with SGP4 would be wrong: convert "
            "the record, or use the mean-element theory it was made for."
        )


def _check_frame_epoch(clean, fields) -> None:
    """Refuse a ``REF_FRAME_EPOCH`` more than 1 s from ``EPOCH``: the elements would be on the
    TEME axes of that epoch, and SGP4's are those of ``EPOCH`` (TEME of date), which turn by
    precession and nutation (~0.14 arcsec a day: 27 m at GEO after a day)."""
    ref = clean.get("REF_FRAME_EPOCH")
    if ref is None:
        return
    try:
        at = _omm_epoch(ref)
    except InvalidInputError as exc:  # (its message says EPOCH)
        raise InvalidInputError(str(exc).replace("OMM EPOCH", "OMM REF_FRAME_EPOCH", 1)) from None
    gap = (datetime.fromisoformat(at) - datetime.fromisoformat(clean["EPOCH"])).total_seconds()
    if abs(gap) > 1.0:
        raise InvalidInputError(
            f"OMM record {fields.get('OBJECT_NAME', '')!r} has REF_FRAME_EPOCH = {ref} "
            f"({gap / 86400.0:.6g} days from EPOCH = {fields['EPOCH']}): its elements are on "
            "the TEME axes of that epoch, but SGP4 elements are on those of EPOCH (TEME of "
            "date). Propagating these with SGP4 would be wrong: drop REF_FRAME_EPOCH if the "
            "elements are SGP4's, or ask for the object's SGP4 element set.")


#: ephemeris types of element sets that are not SGP4's: 4 is SGP4-XP at Space-Track (SGP8 in
#: Spacetrack Report #3, as 1 is SGP and 5 SDP8); 0 (today's), 2 and 3 (SGP4, SDP4) are SGP4's
_NOT_SGP4_TYPES = {1: "SGP", 4: "SGP4-XP (SGP8 in Spacetrack Report #3)", 5: "SDP8"}


def not_sgp4_ephemeris_type(value) -> str:
    """Why an element set's ephemeris type says it is not for SGP4 (``""`` when it is).

    Parameters
    ----------
    value : int or str
        The TLE's column 63, or an OMM's ``EPHEMERIS_TYPE``.

    Returns
    -------
    str
    """
    try:
        kind = int(value)
    except (TypeError, ValueError):
        return ""  # (a malformed value is the readers' to refuse)
    if kind not in _NOT_SGP4_TYPES:
        return ""
    return (f"ephemeris type {kind} marks {_NOT_SGP4_TYPES[kind]} elements, which SGP4 "
            "does not propagate correctly: propagate them with the theory they were "
            "fitted for, or use an SGP4 element set of the object (ephemeris type 0)")


class Satellite:
    """An Earth satellite described by SGP4 mean elements (from a TLE or an OMM record).

    Build one with :meth:`from_tle` or :meth:`from_omm`. Positions come from the ``sgp4``
    package, one call per array of times; frames other than TEME go through astropy.

    Attributes
    ----------
    name : str
        Object name (the catalogue number when none was given).
    satrec : sgp4.api.Satrec
        The sgp4 record (WGS-72 constants, improved mode, as in the SGP4 verification set).
        For a catalogue number above 339,999 its ``satnum`` is the placeholder 0 (sgp4 cannot
        hold the number); :attr:`satnum` is the real one.
    """

    def __init__(self, satrec, name=None, source=None, *, satnum=None):
        self.satrec = satrec
        # a catalogue number above sgp4's alpha-5 limit lives here (sgp4 holds a placeholder:
        # visviva.satellites.catalog_numbers); None: the record's own
        self._satnum = None if satnum is None or satnum == satrec.satnum else int(satnum)
        if name:
            self.name = str(name).strip()
        else:
            self.name = satrec.satnum_str.strip() if self._satnum is None else str(self._satnum)
        self._source = source
        # the DECAY_DATE of an OMM record, as written: propagation past it warns once
        # (visviva.satellites.decay, audit51)
        self._decay_date = None

    # -- constructors ------------------------------------------------------------------------
    @classmethod
    def from_tle(cls, line1: str, line2: str, name: str | None = None, *,
                 verify_checksum: bool = True, where: tuple[str, str] | None = None):
        """Build a satellite from the two lines of a TLE.

        Parameters
        ----------
        line1, line2 : str
            The two 69-column lines; alpha-5 catalogue numbers (``A0001`` = 100001) are
            accepted.
        name : str, optional
            Object name (e.g. line 0 of a three-line element set).
        verify_checksum : bool
            Check each line's modulo-10 checksum (default); False also reads lines of 68
            columns, without the checksum (refused before audit49).
        where : tuple of str, optional
            How error messages name the two lines (default ``("TLE line 1", "TLE line 2")``;
            a catalogue reader passes the file and line numbers).

        Raises
        ------
        TLEFormatError
            A line is malformed, or a field is out of range (epoch day of year outside
            [1, 366) or [1, 367) in leap years, mean motion <= 0, inclination > 180 deg, an
            angle > 360 deg); the message names the line and the field.

        Notes
        -----
        The elements are SGP4 mean elements (Hoots & Roehrich 1980, Spacetrack Report #3;
        Vallado et al. 2006, AIAA 2006-6753), initialised with WGS-72 constants. Element sets
        that sgp4 cannot initialise (e.g. eccentricity out of range) are accepted here;
        propagating them raises the typed :class:`SGP4Error`.
        """
        from sgp4.api import WGS72, Satrec

        line1, line2 = check_tle_lines(line1, line2, verify_checksum=verify_checksum, where=where)
        satrec = Satrec.twoline2rv(line1, line2, WGS72)
        where = where or ("TLE line 1", "TLE line 2")
        why = not_sgp4_ephemeris_type(line1[62])
        if why:
            raise TLEFormatError(f"{where[0]}, column 63: {why}.")
        check_tle_epoch(line1, int(satrec.epochyr), float(satrec.epochdays), where[0])
        deg = 180.0 / math.pi
        check_element_ranges(
            {
                "mean motion": satrec.no_kozai * MINUTES_PER_DAY / (2 * math.pi),
                "eccentricity": float(satrec.ecco),
                "inclination": satrec.inclo * deg,
                "right ascension of the ascending node": satrec.nodeo * deg,
                "argument of perigee": satrec.argpo * deg,
                "mean anomaly": satrec.mo * deg,
            },
            where[1],
            TLEFormatError,
            TLE_COLUMNS,
        )
        warn_subsurface_perigee(satrec, where[1], "the eccentricity (columns 27-33) and the "
                                "mean motion (columns 53-63)")
        return cls(satrec, name, ("tle", line1, line2))

    @classmethod
    def from_omm(cls, fields: dict):
        """Build a satellite from an Orbit Mean-Elements Message (OMM) record.

        Parameters
        ----------
        fields : dict
            OMM keywords as in CelesTrak's JSON, CSV or XML (values may be numbers or strings):
            ``EPOCH``, ``MEAN_MOTION`` (rev/day), ``ECCENTRICITY``, ``INCLINATION``,
            ``RA_OF_ASC_NODE``, ``ARG_OF_PERICENTER``, ``MEAN_ANOMALY`` (deg), ``NORAD_CAT_ID``,
            ``BSTAR`` (1/earth radii), optionally ``MEAN_MOTION_DOT``, ``MEAN_MOTION_DDOT``,
            ``OBJECT_NAME``, ``OBJECT_ID``, ``CLASSIFICATION_TYPE``, ``EPHEMERIS_TYPE``,
            ``ELEMENT_SET_NO``, ``REV_AT_EPOCH``; a ``DECAY_DATE`` (Space-Track) warns.

        Raises
        ------
        InvalidInputError
            A required keyword is missing or a value is not a number.
        InvalidElementsError
            A mean element is out of range (mean motion <= 0, eccentricity outside [0, 1),
            inclination outside [0, 180] deg, an angle outside [0, 360] deg).
        """
        from sgp4 import omm
        from sgp4.api import WGS72, Satrec

        if not hasattr(fields, "keys"):
            raise InvalidInputError(
                f"fields must be a dict of OMM keywords, got {type(fields).__name__} (for a "
                "file or a message text, pass vv.read_omm(path))."
            )
        missing = [k for k in _OMM_REQUIRED if k not in fields or fields[k] in (None, "")]
        if "MEAN_MOTION" in missing and fields.get("SEMI_MAJOR_AXIS") not in (None, ""):
            raise InvalidInputError(
                f"OMM record {fields.get('OBJECT_NAME', '')!r} gives SEMI_MAJOR_AXIS, not "
                "MEAN_MOTION: SGP4 elements are a Kozai mean motion (rev/day), which a mean "
                "semi-major axis does not fix uniquely; ask for the SGP4 element set (with "
                "MEAN_MOTION) of the object.")
        if missing:
            raise InvalidInputError(
                f"OMM record {fields.get('OBJECT_NAME', '')!r} lacks {', '.join(missing)}; "
                "pass every mean element (CelesTrak's GP data in JSON or CSV has them)."
            )
        _check_sgp4_metadata(fields)
        why = not_sgp4_ephemeris_type(fields.get("EPHEMERIS_TYPE"))
        if why:
            raise InvalidInputError(f"OMM record {fields.get('OBJECT_NAME', '')!r}: "
                                    f"EPHEMERIS_TYPE = {fields['EPHEMERIS_TYPE']}: {why}.")
        clean = dict(_OMM_DEFAULTS)
        clean.update({k: v for k, v in fields.items() if v not in (None, "")})
        clean["EPOCH"] = _omm_epoch(clean["EPOCH"])
        _check_frame_epoch(clean, fields)
        try:
            clean["NORAD_CAT_ID"] = catalogue_number(clean["NORAD_CAT_ID"])
            for k in ("MEAN_MOTION", "ECCENTRICITY", "INCLINATION", "RA_OF_ASC_NODE",
                      "ARG_OF_PERICENTER", "MEAN_ANOMALY", "BSTAR", "MEAN_MOTION_DOT",
                      "MEAN_MOTION_DDOT"):
                if hasattr(clean[k], "unit"):  # a Quantity: which unit the OMM means is fixed
                    raise ValueError(f"{k} = {clean[k]!r} is a Quantity; OMM fields are plain "
                                     f"numbers in the OMM's units: give {k} in "
                                     f"{_OMM_UNITS.get(k, '')}")
                try:
                    clean[k] = float(clean[k])
                except (TypeError, ValueError):
                    raise ValueError(f"{k} = {clean[k]!r} is not a number") from None
                if not math.isfinite(clean[k]):
                    raise ValueError(f"{k} is not finite")
            satrec = Satrec()
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(
                f"OMM record {fields.get('OBJECT_NAME', '')!r} has a bad value: {exc}."
            ) from exc
        check_element_ranges(
            {
                "mean motion": clean["MEAN_MOTION"],
                "eccentricity": clean["ECCENTRICITY"],
                "inclination": clean["INCLINATION"],
                "right ascension of the ascending node": clean["RA_OF_ASC_NODE"],
                "argument of perigee": clean["ARG_OF_PERICENTER"],
                "mean anomaly": clean["MEAN_ANOMALY"],
            },
            f"OMM record {fields.get('OBJECT_NAME', '')!r}",
            InvalidElementsError,
            OMM_KEYS,
        )
        number = clean["NORAD_CAT_ID"]
        try:
            omm.initialize(satrec, {**clean, "NORAD_CAT_ID": sgp4_number(number)}, WGS72)
        except (TypeError, ValueError, OverflowError) as exc:  # (an int field of 1e999, say)
            raise InvalidInputError(
                f"OMM record {fields.get('OBJECT_NAME', '')!r} has a bad value: {exc}."
            ) from exc
        satrec.intldesg = tle_designator(clean.get("OBJECT_ID"))  # not sgp4's OBJECT_ID[2:]
        warn_subsurface_perigee(satrec, f"OMM record {fields.get('OBJECT_NAME', '')!r}",
                                "ECCENTRICITY and MEAN_MOTION")
        if str(clean.get("DECAY_DATE", "")).strip():  # (Space-Track's GP data: audit49)
            warn_decayed([(fields.get("OBJECT_NAME") or str(number),
                           str(clean["DECAY_DATE"]).strip())], "OMM record")
        sat = cls(satrec, fields.get("OBJECT_NAME"), ("omm", clean), satnum=number)
        sat._decay_date = str(clean.get("DECAY_DATE", "")).strip() or None
        return sat

    # -- attributes --------------------------------------------------------------------------
    @property
    def satnum(self) -> int:
        """NORAD catalogue number (alpha-5 numbers decoded, e.g. ``A0001`` -> 100001).

        Up to nine digits: an OMM's number above 339,999 (which sgp4's record cannot hold; it
        carries the placeholder 0 there) is kept here.
        """
        return int(self.satrec.satnum) if self._satnum is None else self._satnum

    @cached_property
    def epoch(self) -> Time:
        """Epoch of the element set (astropy Time, UTC)."""
        return utc_days_to_time(self.satrec.jdsatepoch, self.satrec.jdsatepochF)

    @property
    def decay_date(self) -> str | None:
        """The ``DECAY_DATE`` of the OMM record the satellite was read from (``YYYY-MM-DD``, as
        written; Space-Track's GP data has it for objects that re-entered), else None.
        Positions asked for after 00:00 UTC of that date warn
        (:class:`~visviva.errors.DecayedObjectWarning`, once per satellite; audit51)."""
        return self._decay_date

    @property
    def inclination(self):
        """Mean inclination at epoch (Quantity, deg)."""
        return (self.satrec.inclo * u.rad).to(u.deg)

    @property
    def eccentricity(self) -> float:
        """Mean eccentricity at epoch."""
        return float(self.satrec.ecco)

    @property
    def mean_motion(self):
        """Kozai mean motion at epoch as given in the TLE (Quantity, rev/day)."""
        return self.satrec.no_kozai * MINUTES_PER_DAY / (2 * math.pi) * u.Unit("1/day")

    @property
    def bstar(self):
        """Drag term B* (Quantity, 1 / earth radii)."""
        return self.satrec.bstar / u.Unit("earthRad")

    def __repr__(self):
        return f"Satellite({self.name!r}, satnum={self.satnum}, epoch={self.epoch.utc.isot})"

    # -- export ------------------------------------------------------------------------------
    def to_tle(self) -> tuple[str, str]:
        """The two TLE lines (checksums; alpha-5 catalogue numbers above 99999).

        Returns
        -------
        line1, line2 : str
            69 characters each; :meth:`from_tle` on them gives back this satellite's record
            (to the TLE's column precision for a record that did not come from a TLE).

        Raises
        ------
        InvalidInputError
            A value that does not fit the TLE's columns (use :meth:`to_omm` instead), such as
            a catalogue number above 339,999 (alpha-5 ``Z9999``): those exist only in OMMs.
        """
        from .tle_export import to_tle

        return to_tle(self.satrec, self.satnum)

    def to_omm(self) -> dict:
        """The CCSDS OMM fields (the keys of ``sgp4.exporter.export_omm``), full precision.

        Returns
        -------
        dict
            For :meth:`from_omm` or :func:`visviva.write_omm` (with ``originator=``).
            ``OBJECT_ID`` is the COSPAR designator of the record (``""`` when a TLE has
            none), or, for a satellite read from an OMM whose ``OBJECT_ID`` no TLE designator
            holds (``UNKNOWN``, a name), that text as given, so that OMM -> satellite -> OMM
            keeps it.
        """
        from .tle_export import to_omm

        fields = to_omm(self.satrec, self.name, self.satnum)
        if not fields["OBJECT_ID"] and self._source and self._source[0] == "omm":
            fields["OBJECT_ID"] = str(self._source[1].get("OBJECT_ID") or "").strip()
        return fields

    # -- propagation -------------------------------------------------------------------------
    def _sgp4(self, t):
        """One sgp4 array call: TEME r (km), v (km/s) of shape t.shape + (3,), and times."""
        s = self.satrec
        jd, fr, shape, times = sgp4_times(t, s.jdsatepoch, s.jdsatepochF)
        tsince = ((jd - s.jdsatepoch) + (fr - s.jdsatepochF)) * MINUTES_PER_DAY
        check_tsince(tsince, [self.name])
        warn_stale_tsince(tsince, self.name)  # (pointing at the user's line)
        if self._decay_date is not None and np.size(jd):
            warn_after_decay([self], float(np.max(jd + fr)))
        e, r, v = s.sgp4_array(jd, fr)
        if flag_beyond_earth_orbit(e, r) or e.any():
            when = times if times is not None else utc_days_to_time(jd, fr)
            raise_for_sgp4_status(e, [self.name], tsince, when, r)
        if not (np.isfinite(r).all() and np.isfinite(v).all()):
            k = int(np.flatnonzero(~(np.isfinite(r).all(-1) & np.isfinite(v).all(-1)))[0])
            raise SGP4Error(
                f"SGP4 returned a non-finite state for satellite {self.name!r} at "
                f"{tsince[k]:.6f} min from its epoch without an error code. To fix: propagate "
                "to times nearer the element-set epoch or check the element set.",
                satellite=self.name, reason="non-finite state", tsince_min=float(tsince[k]),
            )
        if times is None:
            times = utc_days_to_time(jd, fr).reshape(shape)
        return r.reshape(shape + (3,)), v.reshape(shape + (3,)), times

    def teme(self, t) -> SatelliteStates:
        """Position and velocity in TEME (the frame of SGP4), straight from sgp4.

        Parameters
        ----------
        t : astropy Time or Quantity (time)
            Absolute times, or offsets from :attr:`epoch` (e.g. ``np.arange(0, 90) * u.min``);
            scalar or any shape.

        Returns
        -------
        SatelliteStates
            ``.r`` (km) and ``.v`` (km/s) of shape ``t.shape + (3,)``, ``.t`` the times.

        Raises
        ------
        SGP4Error
            A subclass per sgp4 error code (e.g. :class:`SatelliteDecayedError`), naming the
            satellite, the time and the reason.
        """
        r, v, times = self._sgp4(t)
        return SatelliteStates._wrap(r, v, times, "teme")

    def gcrs(self, t) -> SatelliteStates:
        """Position and velocity in GCRS (geocentric, ICRS-aligned axes), via astropy.

        Parameters
        ----------
        t : astropy Time or Quantity (time)
            As in :meth:`teme`.

        Notes
        -----
        TEME -> GCRS goes through astropy's TEME, ITRS and GCRS frames (IAU 2006/2000A) with
        the Earth-orientation data installed with astropy (see :mod:`visviva.satellites.frames`).
        """
        from .frames import teme_to_gcrs

        r, v, times = self._sgp4(t)
        rg, vg = teme_to_gcrs(r, v, times)
        return SatelliteStates._wrap(rg, vg, times, "gcrs")

    def itrs(self, t) -> SatelliteStates:
        """Position and velocity in ITRS (Earth-fixed; velocity relative to the rotating Earth).

        Parameters
        ----------
        t : astropy Time or Quantity (time)
            As in :meth:`teme`.
        """
        from .frames import teme_to_itrs

        r, v, times = self._sgp4(t)
        ri, vi = teme_to_itrs(r, v, times)
        return SatelliteStates._wrap(ri, vi, times, "itrs")

    def geodetic(self, t):
        """Geodetic latitude, longitude and height above the WGS-84 ellipsoid.

        Parameters
        ----------
        t : astropy Time or Quantity (time)
            As in :meth:`teme`.

        Returns
        -------
        latitude, longitude, height : Quantity
            Degrees (longitude in [-180, 180)), degrees, km; shape of ``t``.
        """
        from .frames import itrs_to_geodetic, teme_to_itrs

        r, v, times = self._sgp4(t)
        ri, _ = teme_to_itrs(r, v, times)
        return itrs_to_geodetic(ri)

    # -- for batches and dask ----------------------------------------------------------------
    def __reduce__(self):
        # sgp4's Satrec does not pickle; rebuild it from the element set (Dask workers).
        kind = self._source[0] if self._source else None
        if kind == "tle":
            return (_rebuild_tle, (self._source[1], self._source[2], self.name))
        if kind == "omm":
            return (_rebuild_omm, (self._source[1], self.name))
        raise TypeError("this Satellite was built from a bare Satrec and cannot be pickled")


def _rebuild_tle(line1, line2, name):
    with warnings.catch_warnings():  # warned when it was first built
        warnings.simplefilter("ignore", SubsurfacePerigeeWarning)
        return Satellite.from_tle(line1, line2, name, verify_checksum=False)


def _rebuild_omm(fields, name):
    with warnings.catch_warnings():  # warned when it was first built
        warnings.simplefilter("ignore", SubsurfacePerigeeWarning)
        warnings.simplefilter("ignore", DecayedObjectWarning)
        sat = Satellite.from_omm(fields)
    sat.name = name
    return sat
