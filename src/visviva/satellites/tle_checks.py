"""TLE and OMM element sets: their checks, SGP4's times, and SGP4's errors as typed exceptions.

Every check of a two-line element set (columns, checksums, ranges, epoch) and of the times handed
to SGP4, and the one table from sgp4's error codes to the exceptions below, which name the
satellite and the reason. :mod:`visviva.satellites.tle` builds :class:`Satellite` on them.
"""

from __future__ import annotations

import math
import re
import warnings

import numpy as np
from astropy import units as u
from astropy.time import Time

from .._callsite import outside_stacklevel
from .._units import time_input_name, to_array
from ..constants import DAY_S
from ..errors import (
    DecayedObjectWarning,
    DomainError,
    InvalidInputError,
    StaleElementSetWarning,
    SubsurfacePerigeeWarning,
    UnitsError,
    VisvivaError,
    fmt_first,
)

__all__ = [
    "TLEFormatError",
    "SGP4Error",
    "SGP4EccentricityError",
    "SGP4MeanMotionError",
    "SGP4SemiLatusRectumError",
    "SatelliteDecayedError",
    "SGP4_ERROR_TYPES",
    "check_tle_lines",
    "check_tsince",
    "sgp4_times",
    "raise_for_sgp4_status",
    "warn_subsurface_perigee",
    "warn_decayed",
    "STALE_DAYS",
    "is_stale",
    "warn_stale_sets",
    "warn_stale_tsince",
    "warn_stale_window",
    "MAX_SGP4_RADIUS_KM",
    "SGP4_BEYOND_EARTH_ORBIT",
    "flag_beyond_earth_orbit",
]

MINUTES_PER_DAY = 1440.0
#: Largest |t - epoch| SGP4 is asked for (days, ~270 years): sgp4's deep-space integrator steps
#: 720 min at a time from the epoch, so far larger offsets would run for hours.
MAX_TSINCE_DAYS = 100_000.0
#: Element sets used further than this from their epoch warn (StaleElementSetWarning), days:
#: the one threshold of Satellite's propagation, find_passes and find_events
STALE_DAYS = 30.0
#: An SGP4 position further than this from the geocentre is no Earth orbit (km): two and a half
#: times the Moon's distance, two thirds of the Earth's Hill radius (~1.5e6 km)
MAX_SGP4_RADIUS_KM = 1.0e6
#: visviva's status code for an SGP4 state that sgp4 returned without an error code but more
#: than :data:`MAX_SGP4_RADIUS_KM` from the geocentre (:func:`flag_beyond_earth_orbit`): in
#: ``BatchStates.status`` beside sgp4's own codes 1-6, clear of :mod:`visviva.core.status`'s
SGP4_BEYOND_EARTH_ORBIT = 100
#: a warning about stale element sets names this many of them, the stalest first
STALE_NAMED = 5


# --------------------------------------------------------------------------------------------
# Errors
# --------------------------------------------------------------------------------------------
class TLEFormatError(InvalidInputError):
    """A TLE line is malformed: wrong length, bad checksum, a field in the wrong columns, or the
    two lines name different satellites. The message names the line (and its number in a file)."""


class SGP4Error(VisvivaError, ArithmeticError):
    """SGP4 could not propagate a satellite (one of sgp4's error codes 1-6, or visviva's
    :data:`SGP4_BEYOND_EARTH_ORBIT`: a position no Earth orbit reaches).

    Attributes
    ----------
    code : int
        sgp4's error code (or :data:`SGP4_BEYOND_EARTH_ORBIT`; 0 for a non-finite state).
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
    SGP4_BEYOND_EARTH_ORBIT: (
        SGP4Error,
        "position beyond any Earth orbit",
        "propagate to times near the element-set epoch (days to weeks) or use an element set "
        "from near these times",
    ),
}


def warn_subsurface_perigee(satrec, where: str, fields: str) -> None:
    """Warn (:class:`~visviva.errors.SubsurfacePerigeeWarning`) when the element set's mean
    perigee lies below the Earth's surface.

    Parameters
    ----------
    satrec : sgp4.api.Satrec
        The initialised element set (``altp``: its mean perigee height, Earth radii).
    where : str
        How the message names the element set (``"TLE line 2"``, a file's line, an OMM
        record).
    fields : str
        The fields to check (their columns or keywords).
    """
    height_km = float(satrec.altp) * float(satrec.radiusearthkm)
    if not height_km < 0.0:
        return
    n = float(satrec.no_kozai) * 1440.0 / (2.0 * math.pi)
    warnings.warn(
        f"{where}: the mean perigee a(1 - e) is {-height_km:.1f} km below the Earth's surface "
        f"(eccentricity {float(satrec.ecco):.7f}, mean motion {n:.8f} rev/day): SGP4 flags only "
        "the times below one Earth radius (error 6, decayed) and propagates the rest of the "
        f"orbit as if it flew. Check {fields} (a mistyped element set), or use a newer one if "
        "the object has re-entered.",
        SubsurfacePerigeeWarning, stacklevel=outside_stacklevel())  # the user's line


def warn_decayed(decayed, where: str) -> None:
    """Warn (:class:`~visviva.errors.DecayedObjectWarning`) once for the element sets of
    ``where`` whose objects have re-entered.

    Parameters
    ----------
    decayed : list of (str, str)
        Name (or catalogue number) and ``DECAY_DATE`` of each such set; nothing when empty.
    where : str
        The record or file, for the message.
    """
    if not decayed:
        return
    listed = fmt_first([f"{name} on {date}" for name, date in decayed])
    warnings.warn(
        f"{where}: {len(decayed)} element set(s) of objects that re-entered (DECAY_DATE): "
        f"{listed}. SGP4 still gives positions after that date, of no object: leave "
        "them out (on Space-Track, ask for DECAY_DATE/null-val).",
        DecayedObjectWarning, stacklevel=outside_stacklevel())


def raise_for_sgp4_status(status, names, tsince_min, times=None, r=None) -> None:
    """Raise the typed :class:`SGP4Error` for the first non-zero sgp4 error code (or
    :data:`SGP4_BEYOND_EARTH_ORBIT`, set by :func:`flag_beyond_earth_orbit`).

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
    r : ndarray, shape status.shape + (3,), optional
        The positions (km): the message of :data:`SGP4_BEYOND_EARTH_ORBIT` quotes the distance.
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
    head = f"SGP4 error {code} for satellite {name!r} at {when}: {reason}"
    if code == SGP4_BEYOND_EARTH_ORBIT:
        far = "" if r is None else f" {float(np.linalg.norm(np.asarray(r)[index])):.4g} km"
        head = (f"SGP4 returned a position{far} from the geocentre for satellite {name!r} at "
                f"{when}, without an error code: {reason} (more than {MAX_SGP4_RADIUS_KM:.0e} "
                f"km away, SGP4 run far outside its span; visviva status {code})")
    raise exc(
        f"{head}{more}. To fix: {todo}.",
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
    (19, 32, "epoch (YYDDD.DDDDDDDD)", r"[0-9]{2}[ 0-9]{3}\.[ 0-9]{8}"),
    (34, 43, "first derivative of mean motion", r"[ +-]\.[ 0-9]{8}"),
    (45, 52, "second derivative of mean motion", r"[ +-][ 0-9]{5}[ +-][ 0-9]"),
    (54, 61, "BSTAR drag term", r"[ +-][0-9]{5}[ +-][0-9]"),
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
#: the numbers of each line (first column, last column, name): right-justified, so a blank may
#: pad them on the left (or right) but never sit between two characters. sgp4's reader scans
#: blank-separated numbers, so '325. 288' in the mean anomaly read as 325 deg and a mean motion
#: of 288 rev/day. For the same reason the fields above take no blank where sgp4 would read the
#: next field's digits (epoch ' 6176.8' read as year 61, day 76.8) or NaN/inf (B* all blank or
#: without its exponent). The eccentricity and the second derivative's mantissa may hold
#: blanks: sgp4 reads them as zeros.
_NUMBERS = {
    1: ((21, 32, "epoch day of year"), (34, 43, "first derivative of mean motion")),
    2: ((9, 16, "inclination (deg)"), (18, 25, "right ascension of the ascending node (deg)"),
        (35, 42, "argument of perigee (deg)"), (44, 51, "mean anomaly (deg)"),
        (53, 63, "mean motion (rev/day)")),
}
_COMPILED = {
    1: [(a, b, n, re.compile(p)) for a, b, n, p in _LINE1_FIELDS],
    2: [(a, b, n, re.compile(p)) for a, b, n, p in _LINE2_FIELDS],
}


def tle_checksum(line: str) -> int:
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
        Check column 69 against the modulo-10 checksum (default); when False, a line of 68
        columns (no checksum) is read too (before audit49 it was refused as truncated).
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
        if "\n" in line or "\r" in line:  # (audit51: was "has 139 characters")
            raise TLEFormatError(
                f"{name} holds {line.count(chr(10)) + 1} lines: pass the two lines of the "
                "element set separately (vv.Satellite.from_tle(*text.splitlines()[-2:])), or "
                "a whole text to visviva.satellites.catalog.parse_tle_text(text).")
        indent = len(line) - len(line.lstrip(" \t"))
        if indent and line[indent:].startswith(f"{number} "):
            # pasted from a web page or an e-mail with an indent (audit51): the columns count
            # from the line's first character, so read it without the leading blanks; the
            # checks below (length, columns, checksum) still apply to what is left
            line = line[indent:]
        if len(line) == 68 and not verify_checksum:  # no checksum column (as sgp4 reads it)
            line += str(tle_checksum(line))
        if len(line) != 69:
            raise TLEFormatError(
                f"{name} has {len(line)} characters"
                + (f" (after its {indent} leading blanks)" if indent else "")
                + f"; a TLE line has exactly 69: {line!r}. "
                "Check that the line was not wrapped, truncated or padded"
                + (" (one without its checksum, column 69, is read with verify_checksum=False)."
                   if len(line) == 68 else "."))
        if not line.isascii():
            bad = next(ch for ch in line if not ch.isascii())
            raise TLEFormatError(
                f"{name} holds the non-ASCII character {bad!r} in column {line.index(bad) + 1}: "
                f"{line!r}. A TLE line is plain ASCII; the line is corrupted."
            )
        control = next((c for c in line if c < " " or c == "\x7f"), None)
        if control is not None:  # (sgp4 reads a tab in the designator as a field break)
            raise TLEFormatError(
                f"{name} holds the control character {control!r} in column "
                f"{line.index(control) + 1}: {line!r}. A TLE line is printable ASCII (blanks, "
                "no tabs); the line is corrupted."
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
        for a, b, field in _NUMBERS[number]:
            text = line[a - 1 : b].strip()
            if " " in text or not any(c.isdigit() for c in text):
                raise TLEFormatError(
                    f"{name}: columns {a}-{b} ({field}) hold {line[a - 1 : b]!r}, which is not "
                    f"one number (a TLE number is right-justified: blanks only on its left, "
                    f"none inside it, at least one digit): {line!r}."
                )
        if verify_checksum:
            expected = tle_checksum(line)
            if int(line[68]) != expected:
                raise TLEFormatError(
                    f"{name}: checksum mismatch, column 69 says {line[68]} but the line sums to "
                    f"{expected}: {line!r}. The line is corrupted: download the element set "
                    "again (a hand-made one is read by vv.Satellite.from_tle, "
                    "vv.read_tle_file or visviva.satellites.catalog.parse_tle_text with "
                    "verify_checksum=False)."
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
TLE_COLUMNS = {
    "mean motion": "columns 53-63",
    "eccentricity": "columns 27-33",
    "inclination": "columns 9-16",
    "right ascension of the ascending node": "columns 18-25",
    "argument of perigee": "columns 35-42",
    "mean anomaly": "columns 44-51",
}
OMM_KEYS = {
    "mean motion": "MEAN_MOTION",
    "eccentricity": "ECCENTRICITY",
    "inclination": "INCLINATION",
    "right ascension of the ascending node": "RA_OF_ASC_NODE",
    "argument of perigee": "ARG_OF_PERICENTER",
    "mean anomaly": "MEAN_ANOMALY",
}
_ANGLE_TOL_DEG = 1e-9  # degrees -> radians -> degrees round trip of sgp4's parser


def check_element_ranges(
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


def check_tle_epoch(line1: str, epochyr: int, epochdays: float, where: str) -> None:
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


def is_stale(away_days):
    """True where an element set is used more than :data:`STALE_DAYS` from its epoch.

    ``away_days``: how far (days, >= 0, before or after) the times lie from the epoch."""
    return np.asarray(away_days) > STALE_DAYS


def warn_stale_sets(label, away_days, where: str, consequence: str) -> None:
    """Warn (:class:`~visviva.errors.StaleElementSetWarning`) once when some of N element sets
    are used more than :data:`STALE_DAYS` from their epochs, naming the stalest
    (:data:`STALE_NAMED` at most): the one message of the catalogue-wide uses (pass and event
    searches, :func:`~visviva.satellites.catalog.propagate_sgp4_batch`).

    Parameters
    ----------
    label : callable
        ``label(k)``: a name for set ``k`` (its name or catalogue number), called only for the
        sets named.
    away_days : array_like, shape (N,)
        How far (days, >= 0) each set's epoch lies from the times it is used at.
    where, consequence : str
        What the times are ("the window") and what the user risks ("these passes can be
        minutes off, or missing").

    Notes
    -----
    The warning points at the user's line, the first frame outside visviva
    (:func:`visviva._callsite.outside_stacklevel`), whichever path led here.
    """
    away = np.asarray(away_days, dtype=np.float64)
    stale = np.flatnonzero(is_stale(away))
    if not stale.size:
        return
    worst = stale[np.argsort(-away[stale], kind="stable")]
    named = ", ".join(f"{label(k)} ({away[k]:.0f} d)" for k in worst[:STALE_NAMED])
    more = f" and {stale.size - STALE_NAMED} more" if stale.size > STALE_NAMED else ""
    warnings.warn(
        f"{stale.size} of {away.size} element set(s) lie more than {STALE_DAYS:g} days from "
        f"{where} (up to {away[stale].max():.0f} days: {named}{more}); SGP4's errors grow by "
        f"kilometres a day in low orbit, so {consequence}: use element sets from near "
        f"{where}.", StaleElementSetWarning, stacklevel=outside_stacklevel())


def warn_stale_window(cat, t0, t1, consequence: str) -> None:
    """Warn (:class:`~visviva.errors.StaleElementSetWarning`, :func:`warn_stale_sets`) when
    element sets of the catalogue ``cat`` lie more than :data:`STALE_DAYS` before ``t0`` or
    after ``t1``: the window of a pass search or a conjunction screening.

    Parameters
    ----------
    cat : Catalog
        The element sets (its ``epoch_days`` and ``satellites``).
    t0, t1 : astropy Time, scalar
        The window.
    consequence : str
        What the user risks ("these passes can be minutes off, or missing").
    """
    from .utc_days import time_to_utc_days

    jd, fr = cat.epoch_days
    days = []
    for t in (t0, t1):
        tj, tf = time_to_utc_days(t)
        days.append((float(tj) - jd) + (float(tf) - fr))  # window minus epoch, days
    away = np.maximum(np.maximum(days[0], -days[1]), 0.0)
    sats = cat.satellites
    warn_stale_sets(lambda k: sats[k].name or sats[k].satnum, away, "the window", consequence)
    from .decay import warn_after_decay  # (re-entered objects in the window: audit51)

    warn_after_decay(sats, float(np.add(*time_to_utc_days(t1))))


def warn_stale_tsince(tsince_min, name) -> None:
    """Warn (:class:`~visviva.errors.StaleElementSetWarning`) once when some of the times
    ``tsince_min`` (minutes from the element-set epoch) lie more than :data:`STALE_DAYS` from
    it: SGP4's along-track error grows by kilometres a day in low orbit (audit leftfix4: the
    ISS's 2024 TLE propagated to 1900 gave |r| = 3e8 km, with only ERFA's "dubious year").
    The warning points at the user's line, as :func:`warn_stale_sets`'s."""
    days = np.abs(np.asarray(tsince_min, dtype=np.float64)) / MINUTES_PER_DAY
    stale = is_stale(days)
    if not stale.any():
        return
    k = int(np.argmax(days))
    side = "after" if float(np.ravel(tsince_min)[k]) > 0 else "before"
    warnings.warn(
        f"satellite {name!r}: {int(stale.sum())} of {stale.size} time(s) lie more than "
        f"{STALE_DAYS:g} days from the element-set epoch (up to {days.ravel()[k]:.0f} days "
        f"{side} it); SGP4's errors grow by kilometres a day in low orbit, so these positions "
        "can be far off: use an element set from near these times.", StaleElementSetWarning,
        stacklevel=outside_stacklevel())


def flag_beyond_earth_orbit(status, r) -> bool:
    """Set :data:`SGP4_BEYOND_EARTH_ORBIT` in ``status`` (in place) wherever sgp4 reported no
    error (0) but returned a position more than :data:`MAX_SGP4_RADIUS_KM` from the geocentre:
    no Earth orbit, SGP4 run far outside its span (the ISS's 2024 TLE propagated to 1900 gave
    |r| = 3e8 km). The one rule of :meth:`visviva.Satellite.teme`, the SGP4 batch
    (:func:`~visviva.satellites.catalog.propagate_sgp4_batch`) and the pass search. A position
    below the surface is sgp4's own error 6.

    Parameters
    ----------
    status : ndarray of integers, shape S
        sgp4's error codes; changed in place.
    r : ndarray, shape S + (3,)
        The positions (km); NaN ones are left to the caller.

    Returns
    -------
    bool
        Whether any state was flagged.
    """
    r = np.asarray(r)
    if r.size == 0:
        return False
    # fast path, two reductions without temporaries (NaN ignored): every component within
    # MAX / sqrt(3) puts every |r| within MAX (a third of the cost of the norms)
    bound = MAX_SGP4_RADIUS_KM / math.sqrt(3.0)
    if np.fmax.reduce(r, axis=None) <= bound and np.fmin.reduce(r, axis=None) >= -bound:
        return False
    rr = np.einsum("...i,...i->...", r, r)
    far = (rr > MAX_SGP4_RADIUS_KM**2) & (status == 0)
    if not far.any():
        return False
    status[far] = SGP4_BEYOND_EARTH_ORBIT
    return True


def sgp4_times(t, jd_epoch: float, fr_epoch: float):
    """Convert a time argument to the (jd, fr) pair of UTC Julian dates sgp4 takes.

    Parameters
    ----------
    t : astropy Time, or Quantity (time) or TimeDelta
        Absolute times, or offsets from the epoch ``jd_epoch + fr_epoch`` (SGP4's minutes since
        epoch: days of 86,400 s on sgp4's UTC clock).
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

        from .utc_days import time_to_utc_days

        try:
            jd, fr = time_to_utc_days(t)  # sgp4's days of 86,400 s, not astropy's quasi-JD
        except InvalidInputError:
            raise  # masked or 'local' times: the message says what to do
        except (ErfaError, ValueError) as exc:
            raise DomainError(
                f"t cannot be converted to UTC ({exc}); use dates within astropy's supported "
                "range, near the element-set epoch."
            ) from exc
        jd = np.ascontiguousarray(jd, dtype=np.float64).ravel()
        fr = np.ascontiguousarray(fr, dtype=np.float64).ravel()
        return jd, fr, t.shape, t
    if isinstance(t, u.Quantity) or type(t).__name__ == "TimeDelta":  # offsets, as propagate
        dt_s = to_array(t, "time", "t")
        jd = np.full(dt_s.size, jd_epoch)
        fr = fr_epoch + dt_s.ravel() / DAY_S
        return jd, fr, dt_s.shape, None
    raise UnitsError(
        f"t must be an astropy Time (absolute UTC/TT/... times) or a time Quantity (offset from "
        f"the element-set epoch, e.g. np.arange(0, 90, 10) * u.min); got {time_input_name(t)}."
    )
