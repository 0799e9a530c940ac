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
from datetime import datetime
from functools import cached_property

import numpy as np
from astropy import units as u
from astropy.time import Time

from .._units import to_array
from ..errors import (
    DomainError,
    InvalidElementsError,
    InvalidInputError,
    UnitsError,
    VisvivaError,
)
from ..states import StateVectors

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

MINUTES_PER_DAY = 1440.0
DAY_S = 86_400.0
#: Largest |t - epoch| SGP4 is asked for (days, ~270 years): sgp4's deep-space integrator steps
#: 720 min at a time from the epoch, so far larger offsets would run for hours.
MAX_TSINCE_DAYS = 100_000.0


# --------------------------------------------------------------------------------------------
# Errors
# --------------------------------------------------------------------------------------------
class TLEFormatError(InvalidInputError):
    """A TLE line is malformed: wrong length, bad checksum, a field in the wrong columns, or the
    two lines name different satellites. The message names the line (and its number in a file)."""


class SGP4Error(VisvivaError, ArithmeticError):
    """SGP4 could not propagate a satellite (one of sgp4's error codes 1-6).

    Attributes
    ----------
    code : int
        sgp4's error code.
    satellite : str
        Name (or catalogue number) of the satellite.
    reason : str
        sgp4's description of the code.
    tsince_min : float
        Minutes from the element-set epoch at which propagation failed.
    """

    def __init__(self, message, code=0, satellite="", reason="", tsince_min=float("nan")):
        super().__init__(message)
        self.code = code
        self.satellite = satellite
        self.reason = reason
        self.tsince_min = tsince_min


class SGP4EccentricityError(SGP4Error):
    """Mean (code 1) or perturbed (code 3) eccentricity left the range 0 <= e < 1."""


class SGP4MeanMotionError(SGP4Error):
    """The mean motion became negative (code 2)."""


class SGP4SemiLatusRectumError(SGP4Error):
    """The semi-latus rectum became negative (code 4)."""


class SatelliteDecayedError(SGP4Error):
    """The orbit decayed: the mean radius fell below one Earth radius (code 6, or the retired
    code 5, 'below the surface')."""


#: sgp4 error code -> (exception class, reason, what to do)
SGP4_ERROR_TYPES: dict[int, tuple[type[SGP4Error], str, str]] = {
    1: (
        SGP4EccentricityError,
        "mean eccentricity is outside the range 0 <= e < 1",
        "check the element set (the eccentricity field, or drag terms that drive it out of range)",
    ),
    2: (
        SGP4MeanMotionError,
        "mean motion fell to zero or below (it must stay > 0)",
        "the element set's drag terms (ndot, B*) drive the mean motion to zero by this time: "
        "propagate to times nearer the element-set epoch or use a newer element set",
    ),
    3: (
        SGP4EccentricityError,
        "perturbed eccentricity is outside the range 0 <= e <= 1",
        "propagate to times nearer the element-set epoch or use a newer element set",
    ),
    4: (
        SGP4SemiLatusRectumError,
        "semi-latus rectum is less than zero",
        "propagate to times nearer the element-set epoch or use a newer element set",
    ),
    5: (
        SatelliteDecayedError,
        "the satellite is below the Earth's surface",
        "the object has re-entered; use a newer element set",
    ),
    6: (
        SatelliteDecayedError,
        "mean radius is less than one Earth radius: the satellite has decayed",
        "the object has re-entered by this time; propagate to earlier times or use a newer "
        "element set",
    ),
}


def raise_for_sgp4_status(status, names, tsince_min, times=None) -> None:
    """Raise the typed :class:`SGP4Error` for the first non-zero sgp4 error code.

    Parameters
    ----------
    status : ndarray of uint8, shape (N, T) or (T,)
        sgp4's error codes (0 = OK).
    names : sequence of str
        Satellite names, one per row (N) or a single name.
    tsince_min : ndarray, broadcastable to ``status``
        Minutes since each element-set epoch.
    times : astropy Time, optional
        The requested times (length T), quoted in the message.
    """
    status = np.asarray(status)
    if not status.any():
        return
    flat = np.flatnonzero(status.ravel())
    first = int(flat[0])
    index = np.unravel_index(first, status.shape)
    code = int(status[index])
    name = names[index[0]] if status.ndim == 2 else names[0]
    tsince = float(np.broadcast_to(tsince_min, status.shape)[index])
    exc, reason, todo = SGP4_ERROR_TYPES.get(
        code, (SGP4Error, f"unknown sgp4 error code {code}", "report this as a bug")
    )
    when = f"{tsince:.6f} min from its epoch"
    if times is not None:
        try:
            with warnings.catch_warnings():  # far-future dates: ERFA's "dubious year"
                warnings.simplefilter("ignore")
                when = f"{times.ravel()[index[-1]].utc.isot} UTC, {when}"
        except (IndexError, ValueError):
            pass
    more = f" ({flat.size} of {status.size} propagations failed)" if status.size > 1 else ""
    raise exc(
        f"SGP4 error {code} for satellite {name!r} at {when}: {reason}{more}. To fix: {todo}.",
        code=code,
        satellite=name,
        reason=reason,
        tsince_min=tsince,
    )


# --------------------------------------------------------------------------------------------
# TLE line checks
# --------------------------------------------------------------------------------------------
_SATNUM = r"[0-9A-HJ-NP-Z ][0-9 ]{4}"
#: (first column, last column (1-based, inclusive), field name, regular expression)
_LINE1_FIELDS = (
    (1, 1, "line number", r"1"),
    (3, 7, "catalogue number", _SATNUM),
    (8, 8, "classification", r"[ A-Z]"),
    (19, 32, "epoch (YYDDD.DDDDDDDD)", r"[ 0-9]{5}\.[ 0-9]{8}"),
    (34, 43, "first derivative of mean motion", r"[ +-]\.[ 0-9]{8}"),
    (45, 52, "second derivative of mean motion", r"[ +-][ 0-9]{5}[ +-][ 0-9]"),
    (54, 61, "BSTAR drag term", r"[ +-][ 0-9]{5}[ +-][ 0-9]"),
    (63, 63, "ephemeris type", r"[ 0-9]"),
    (65, 68, "element set number", r"[ 0-9]{4}"),
    (69, 69, "checksum", r"[0-9]"),
)
_LINE2_FIELDS = (
    (1, 1, "line number", r"2"),
    (3, 7, "catalogue number", _SATNUM),
    (9, 16, "inclination (deg)", r"[ 0-9]{3}\.[ 0-9]{4}"),
    (18, 25, "right ascension of the ascending node (deg)", r"[ 0-9]{3}\.[ 0-9]{4}"),
    (27, 33, "eccentricity (decimal point assumed)", r"[ 0-9]{7}"),
    (35, 42, "argument of perigee (deg)", r"[ 0-9]{3}\.[ 0-9]{4}"),
    (44, 51, "mean anomaly (deg)", r"[ 0-9]{3}\.[ 0-9]{4}"),
    (53, 63, "mean motion (rev/day)", r"[ 0-9]{2}\.[ 0-9 ]{8}"),
    (64, 68, "revolution number at epoch", r"[ 0-9]{5}"),
    (69, 69, "checksum", r"[0-9]"),
)
_BLANKS = {1: (2, 9, 18, 33, 44, 53, 62, 64), 2: (2, 8, 17, 26, 34, 43, 52)}
_COMPILED = {
    1: [(a, b, n, re.compile(p)) for a, b, n, p in _LINE1_FIELDS],
    2: [(a, b, n, re.compile(p)) for a, b, n, p in _LINE2_FIELDS],
}


def _tle_checksum(line: str) -> int:
    """Modulo-10 sum of the digits of the first 68 columns, minus signs counting 1."""
    return sum(int(c) if c.isdigit() else c == "-" for c in line[:68]) % 10


def check_tle_lines(
    line1: str, line2: str, *, verify_checksum: bool = True, where: tuple[str, str] | None = None
) -> tuple[str, str]:
    """Check the format of a TLE pair and return the two 69-column lines.

    Parameters
    ----------
    line1, line2 : str
        The two lines (a trailing newline or trailing blanks are ignored).
    verify_checksum : bool
        Check column 69 against the modulo-10 checksum (default).
    where : (str, str), optional
        How to name the lines in messages, e.g. ``("line 7 of cat.txt", "line 8 of cat.txt")``.

    Raises
    ------
    TLEFormatError
        The message names the line, the columns and the field that are wrong.
    """
    where = where or ("TLE line 1", "TLE line 2")
    lines = []
    for number, line, name in ((1, line1, where[0]), (2, line2, where[1])):
        if not isinstance(line, str):
            raise TLEFormatError(f"{name} must be a str, got {type(line).__name__}.")
        line = line.rstrip("\r\n ")
        if len(line) != 69:
            raise TLEFormatError(
                f"{name} has {len(line)} characters; a TLE line has exactly 69: {line!r}. "
                "Check that the line was not wrapped, truncated or padded."
            )
        if line[0] != str(number):
            raise TLEFormatError(
                f"{name} must start with '{number}', got {line[0]!r}: {line!r}. "
                "Pass the two lines in order (line 1, then line 2)."
            )
        for col in _BLANKS[number]:
            if line[col - 1] != " ":
                raise TLEFormatError(
                    f"{name}: column {col} must be blank, got {line[col - 1]!r}: {line!r}. "
                    "The fields of a TLE sit in fixed columns; check for shifted fields."
                )
        for a, b, field, pattern in _COMPILED[number]:
            text = line[a - 1 : b]
            if not pattern.fullmatch(text):
                raise TLEFormatError(
                    f"{name}: columns {a}-{b} ({field}) hold {text!r}, which is not a valid "
                    f"value: {line!r}."
                )
        if verify_checksum:
            expected = _tle_checksum(line)
            if int(line[68]) != expected:
                raise TLEFormatError(
                    f"{name}: checksum mismatch, column 69 says {line[68]} but the line sums to "
                    f"{expected}: {line!r}. The line is corrupted (or pass "
                    "verify_checksum=False for hand-made element sets)."
                )
        lines.append(line)
    if lines[0][2:7] != lines[1][2:7]:
        raise TLEFormatError(
            f"{where[0]} and {where[1]} name different satellites "
            f"({lines[0][2:7]!r} and {lines[1][2:7]!r}); pass the two lines of one element set."
        )
    return lines[0], lines[1]


# --------------------------------------------------------------------------------------------
# Ranges of the mean elements (TLE and OMM)
# --------------------------------------------------------------------------------------------
#: field -> (low, high, high inclusive, unit) for the SGP4 mean elements
_ELEMENT_RANGES = {
    "mean motion": (0.0, math.inf, False, "rev/day"),
    "eccentricity": (0.0, 1.0, False, ""),
    "inclination": (0.0, 180.0, True, "deg"),
    "right ascension of the ascending node": (0.0, 360.0, True, "deg"),
    "argument of perigee": (0.0, 360.0, True, "deg"),
    "mean anomaly": (0.0, 360.0, True, "deg"),
}
_TLE_COLUMNS = {
    "mean motion": "columns 53-63",
    "eccentricity": "columns 27-33",
    "inclination": "columns 9-16",
    "right ascension of the ascending node": "columns 18-25",
    "argument of perigee": "columns 35-42",
    "mean anomaly": "columns 44-51",
}
_OMM_KEYS = {
    "mean motion": "MEAN_MOTION",
    "eccentricity": "ECCENTRICITY",
    "inclination": "INCLINATION",
    "right ascension of the ascending node": "RA_OF_ASC_NODE",
    "argument of perigee": "ARG_OF_PERICENTER",
    "mean anomaly": "MEAN_ANOMALY",
}
_ANGLE_TOL_DEG = 1e-9  # degrees -> radians -> degrees round trip of sgp4's parser


def _check_element_ranges(
    values: dict, where: str, exc: type[InvalidInputError], labels: dict
) -> None:
    """Raise ``exc`` naming the first mean element outside its range.

    ``values`` maps the names of :data:`_ELEMENT_RANGES` to floats (rev/day, deg); ``labels``
    maps the same names to where the value sits (TLE columns, OMM keyword).
    """
    for field, value in values.items():
        lo, hi, hi_inclusive, unit = _ELEMENT_RANGES[field]
        tol = _ANGLE_TOL_DEG if unit == "deg" else 0.0
        ok = math.isfinite(value) and lo - tol <= value and (
            value <= hi + tol if hi_inclusive else value < hi
        )
        if field == "mean motion":
            ok = math.isfinite(value) and value > 0.0
        if not ok:
            interval = (
                "> 0" if field == "mean motion"
                else f"in [{lo:g}, {hi:g}{']' if hi_inclusive else ')'}"
            )
            raise exc(
                f"{where}: {field} ({labels[field]}) is {value:.10g}{' ' + unit if unit else ''}; it must be "
                f"{interval}. Check the element set (a corrupted or hand-made record)."
            )


def _check_tle_epoch(line1: str, epochyr: int, epochdays: float, where: str) -> None:
    """Day of year of a TLE epoch in [1, 366) (or [1, 367) in leap years)."""
    year = epochyr + (1900 if epochyr >= 57 else 2000)
    leap = year % 4 == 0 and (year % 100 != 0 or year % 400 == 0)
    end = 367.0 if leap else 366.0
    if not (1.0 <= epochdays < end):
        raise TLEFormatError(
            f"{where}: columns 21-32 (epoch day of year) hold {line1[20:32]!r} = {epochdays!r}; "
            f"the day of year of {year} must be in [1, {end:g}) (1.0 = 1 January 00:00 UTC): "
            f"{line1!r}."
        )


# --------------------------------------------------------------------------------------------
# Time conversion (one array operation per call)
# --------------------------------------------------------------------------------------------
def check_tsince(tsince_min, names) -> None:
    """Raise DomainError when a time is more than :data:`MAX_TSINCE_DAYS` from its epoch."""
    tsince_min = np.asarray(tsince_min, dtype=np.float64)
    far = ~(np.abs(tsince_min) <= MAX_TSINCE_DAYS * MINUTES_PER_DAY)
    if far.any():
        index = np.unravel_index(int(np.flatnonzero(far.ravel())[0]), far.shape)
        name = names[index[0]] if far.ndim == 2 else names[0]
        raise DomainError(
            f"satellite {name!r}: a requested time is {tsince_min[index] / MINUTES_PER_DAY:.6g} "
            f"days from the element-set epoch; SGP4 is meaningful for days to weeks around it "
            f"and visviva refuses offsets beyond {MAX_TSINCE_DAYS:g} days. Use times near the "
            "epoch (or a newer element set)."
        )


def sgp4_times(t, jd_epoch: float, fr_epoch: float):
    """Convert a time argument to the (jd, fr) pair of UTC Julian dates sgp4 takes.

    Parameters
    ----------
    t : astropy Time or Quantity (time)
        Absolute times, or offsets from the epoch ``jd_epoch + fr_epoch``.
    jd_epoch, fr_epoch : float
        Whole and fractional parts of the epoch's UTC Julian date (days).

    Returns
    -------
    jd, fr : ndarray of float64, flat
        Parts of the UTC Julian dates (days).
    shape : tuple
        Shape of ``t``.
    times : Time or None
        ``t`` as a Time when it was given as one.
    """
    if isinstance(t, Time):
        from erfa import ErfaError

        try:
            tu = t.utc
        except (ErfaError, ValueError) as exc:
            raise DomainError(
                f"t cannot be converted to UTC ({exc}); use dates within astropy's supported "
                "range, near the element-set epoch."
            ) from exc
        jd = np.ascontiguousarray(tu.jd1, dtype=np.float64).ravel()
        fr = np.ascontiguousarray(tu.jd2, dtype=np.float64).ravel()
        return jd, fr, t.shape, t
    if isinstance(t, u.Quantity):
        dt_s = to_array(t, "time", "t")
        jd = np.full(dt_s.size, jd_epoch)
        fr = fr_epoch + dt_s.ravel() / DAY_S
        return jd, fr, dt_s.shape, None
    raise UnitsError(
        f"t must be an astropy Time (absolute UTC/TT/... times) or a time Quantity (offset from "
        f"the element-set epoch, e.g. np.arange(0, 90, 10) * u.min); got {type(t).__name__}."
    )


# --------------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------------
class SatelliteStates(StateVectors):
    """Positions and velocities of a satellite in one frame at an array of times.

    A :class:`visviva.StateVectors` about the Earth (``gm`` = ``vv.EARTH.gm``) that also knows
    its frame, so ``.to_elements()`` gives osculating elements in that frame (meaningful in the
    quasi-inertial TEME and GCRS, not in the rotating ITRS).

    Attributes
    ----------
    r : Quantity, shape (..., 3)
        Position, km.
    v : Quantity, shape (..., 3)
        Velocity, km/s (relative to the rotating Earth in ITRS).
    t : astropy Time, shape (...)
        The times (same as ``epoch``).
    frame : str
        ``"teme"``, ``"gcrs"`` or ``"itrs"``.
    """

    frame = "teme"

    @classmethod
    def _wrap(cls, r_km, v_km_s, times, frame):
        from ..constants import GM_EARTH_KM3_S2

        obj = cls._from_canonical(r_km, v_km_s, np.float64(GM_EARTH_KM3_S2), times)
        obj.frame = frame
        return obj

    @property
    def t(self):
        """The times of the states (astropy Time)."""
        return self.epoch

    @property
    def altitude(self):
        """Height above the WGS-84 ellipsoid (Quantity, km; shape of the states).

        The geodetic height of :func:`visviva.satellites.frames.itrs_to_geodetic`, after a
        rotation to ITRS at :attr:`t` (astropy's matrices) when the states are in TEME or GCRS.
        """
        from .frames import altitude_km

        return altitude_km(self._r, self._v, self.epoch, self.frame) << u.km

    def to_state_vectors(self) -> StateVectors:
        """These states as a plain :class:`visviva.StateVectors` (TEME or GCRS only)."""
        if self.frame == "itrs":
            raise InvalidInputError(
                "ITRS rotates with the Earth, so its velocities are not inertial; convert "
                "sat.gcrs(t) or sat.teme(t) instead."
            )
        return StateVectors._from_canonical(self._r, self._v, self._gm, self.epoch)

    def __repr__(self):
        return f"<SatelliteStates frame={self.frame!r} shape={self.shape}>"


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
_OMM_DEFAULTS = {
    "CLASSIFICATION_TYPE": "U",
    "EPHEMERIS_TYPE": 0,
    "ELEMENT_SET_NO": 999,
    "REV_AT_EPOCH": 0,
    "MEAN_MOTION_DOT": 0.0,
    "MEAN_MOTION_DDOT": 0.0,
    "OBJECT_ID": "",
}


def _omm_epoch(text: str) -> str:
    """Normalise an OMM EPOCH to ``YYYY-mm-ddTHH:MM:SS.ffffff`` (what sgp4.omm parses)."""
    text = str(text).strip().rstrip("Z")
    for fmt in ("%Y-%m-%dT%H:%M:%S.%f", "%Y-%m-%dT%H:%M:%S", "%Y-%m-%d %H:%M:%S.%f",
                "%Y-%m-%d %H:%M:%S"):
        try:
            return datetime.strptime(text, fmt).strftime("%Y-%m-%dT%H:%M:%S.%f")
        except ValueError:
            continue
    raise InvalidInputError(
        f"OMM EPOCH {text!r} is not an ISO date-time like '2024-01-31T12:00:00.000000'."
    )


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
    """

    def __init__(self, satrec, name=None, source=None):
        self.satrec = satrec
        self.name = str(name).strip() if name else satrec.satnum_str.strip()
        self._source = source

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
            Check each line's modulo-10 checksum (default).
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
        _check_tle_epoch(line1, int(satrec.epochyr), float(satrec.epochdays), where[0])
        deg = 180.0 / math.pi
        _check_element_ranges(
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
            _TLE_COLUMNS,
        )
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
            ``ELEMENT_SET_NO``, ``REV_AT_EPOCH``.

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
                f"fields must be a dict of OMM keywords, got {type(fields).__name__}."
            )
        missing = [k for k in _OMM_REQUIRED if k not in fields or fields[k] in (None, "")]
        if missing:
            raise InvalidInputError(
                f"OMM record {fields.get('OBJECT_NAME', '')!r} lacks {', '.join(missing)}; "
                "pass every mean element (CelesTrak's GP data in JSON or CSV has them)."
            )
        clean = dict(_OMM_DEFAULTS)
        clean.update({k: v for k, v in fields.items() if v not in (None, "")})
        clean["EPOCH"] = _omm_epoch(clean["EPOCH"])
        try:
            satnum = clean["NORAD_CAT_ID"]
            if isinstance(satnum, str) and satnum.strip()[:1].isalpha():
                from sgp4.alpha5 import from_alpha5

                clean["NORAD_CAT_ID"] = from_alpha5(satnum.strip())
            clean["NORAD_CAT_ID"] = int(clean["NORAD_CAT_ID"])
            for k in ("MEAN_MOTION", "ECCENTRICITY", "INCLINATION", "RA_OF_ASC_NODE",
                      "ARG_OF_PERICENTER", "MEAN_ANOMALY", "BSTAR", "MEAN_MOTION_DOT",
                      "MEAN_MOTION_DDOT"):
                clean[k] = float(clean[k])
                if not math.isfinite(clean[k]):
                    raise ValueError(f"{k} is not finite")
            satrec = Satrec()
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(
                f"OMM record {fields.get('OBJECT_NAME', '')!r} has a bad value: {exc}."
            ) from exc
        _check_element_ranges(
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
            _OMM_KEYS,
        )
        try:
            omm.initialize(satrec, clean, WGS72)
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(
                f"OMM record {fields.get('OBJECT_NAME', '')!r} has a bad value: {exc}."
            ) from exc
        return cls(satrec, fields.get("OBJECT_NAME"), ("omm", clean))

    # -- attributes --------------------------------------------------------------------------
    @property
    def satnum(self) -> int:
        """NORAD catalogue number (alpha-5 numbers decoded, e.g. ``A0001`` -> 100001)."""
        return int(self.satrec.satnum)

    @cached_property
    def epoch(self) -> Time:
        """Epoch of the element set (astropy Time, UTC)."""
        return Time(self.satrec.jdsatepoch, self.satrec.jdsatepochF, format="jd", scale="utc")

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
            A value that does not fit the TLE's columns (use :meth:`to_omm` instead).
        """
        from .tle_export import to_tle

        return to_tle(self.satrec)

    def to_omm(self) -> dict:
        """The CCSDS OMM fields (the keys of ``sgp4.exporter.export_omm``), full precision.

        Returns
        -------
        dict
            For :meth:`from_omm` or :func:`visviva.write_omm` (with ``originator=``).
        """
        from .tle_export import to_omm

        return to_omm(self.satrec, self.name)

    # -- propagation -------------------------------------------------------------------------
    def _sgp4(self, t):
        """One sgp4 array call: TEME r (km), v (km/s) of shape t.shape + (3,), and times."""
        s = self.satrec
        jd, fr, shape, times = sgp4_times(t, s.jdsatepoch, s.jdsatepochF)
        check_tsince(((jd - s.jdsatepoch) + (fr - s.jdsatepochF)) * MINUTES_PER_DAY, [self.name])
        e, r, v = s.sgp4_array(jd, fr)
        if e.any():
            tsince = ((jd - s.jdsatepoch) + (fr - s.jdsatepochF)) * MINUTES_PER_DAY
            when = times if times is not None else Time(jd, fr, format="jd", scale="utc")
            raise_for_sgp4_status(e, [self.name], tsince, when)
        if not (np.isfinite(r).all() and np.isfinite(v).all()):
            tsince = ((jd - s.jdsatepoch) + (fr - s.jdsatepochF)) * MINUTES_PER_DAY
            k = int(np.flatnonzero(~(np.isfinite(r).all(-1) & np.isfinite(v).all(-1)))[0])
            raise SGP4Error(
                f"SGP4 returned a non-finite state for satellite {self.name!r} at "
                f"{tsince[k]:.6f} min from its epoch without an error code. To fix: propagate "
                "to times nearer the element-set epoch or check the element set.",
                satellite=self.name, reason="non-finite state", tsince_min=float(tsince[k]),
            )
        if times is None:
            times = Time(jd, fr, format="jd", scale="utc").reshape(shape)
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
    return Satellite.from_tle(line1, line2, name, verify_checksum=False)


def _rebuild_omm(fields, name):
    sat = Satellite.from_omm(fields)
    sat.name = name
    return sat
