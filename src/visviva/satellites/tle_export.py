"""Write a satellite's SGP4 mean elements as TLE lines and as CCSDS OMM fields.

The TLE columns follow the format of Hoots & Roehrich (Spacetrack Report No. 3, 1980) and
CelesTrak's "NORAD Two-Line Element Set Format"; catalogue numbers above 99999 are written in
the alpha-5 scheme (:mod:`visviva.satellites.catalog_numbers`; up to 339999 -> Z9999, larger
numbers only in OMMs). The OMM fields are the keys that ``sgp4.exporter.export_omm`` gives, with the
same values, so the OMM reproduces the sgp4 record.
"""

from __future__ import annotations

import math
import re

from ..errors import InvalidInputError
from .catalog_numbers import tle_number
from .tle_checks import tle_checksum  # the one checksum rule (read and write)

#: A COSPAR international designator as OMM's OBJECT_ID writes it: launch year, launch number
#: of the year, piece (one to three letters)
_COSPAR_ID = re.compile(r"(\d{4})-(\d{3})([A-Z]{1,3})")
#: The same designator in a TLE's columns 10-17: two-digit year, launch number, piece
_TLE_DESIGNATOR = re.compile(r"\d{5}[A-Z]{1,3}")

__all__ = ["to_tle", "to_omm", "tle_checksum", "format_exponent", "epoch_text"]

_XPDOTP = 1440.0 / (2.0 * math.pi)  # rad/min -> rev/day


def format_exponent(value: float, what: str, zero_sign: str = "+") -> str:
    """The TLE's 8-column 'assumed decimal point' notation: ``-0.11606e-4`` -> ``-11606-4``.

    Parameters
    ----------
    value : float
        The number (B* in 1/earth radii, or the second derivative of mean motion).
    what : str
        Its name, for the error message.
    zero_sign : str
        Sign of a zero exponent: TLEs write ``00000-0`` for the second derivative and
        ``00000+0`` for B* (as sgp4's exporter does).

    Returns
    -------
    str
        Sign (blank or '-'), five mantissa digits, exponent sign and digit.
    """
    if not math.isfinite(value):
        raise InvalidInputError(f"{what} = {value} cannot be written in a TLE")
    if value == 0.0:
        return f" 00000{zero_sign}0"
    exponent = math.floor(math.log10(abs(value))) + 1
    if exponent < -10:  # below 0.00001e-9: rounds to zero in five digits
        return f" 00000{zero_sign}0"
    mantissa = round(abs(value) * 10.0 ** (5 - exponent))
    if mantissa >= 100000:
        mantissa //= 10
        exponent += 1
    if mantissa == 0 or exponent < -9:
        return f" 00000{zero_sign}0"
    if exponent > 9:
        raise InvalidInputError(f"{what} = {value} is too large for a TLE field; use to_omm()")
    sign = "-" if value < 0 else " "
    exp_sign = "-" if exponent < 0 else "+" if exponent > 0 else zero_sign
    return f"{sign}{mantissa:05d}{exp_sign}{abs(exponent)}"


def _fit_column(value: float, decimals: int, largest: float) -> float:
    """``value``, or ``largest`` (with its sign) where rounding to ``decimals`` decimals would
    carry into a column the field lacks: a mean motion of 99.999999996 rev/day would be written
    ``100.00000000``, 12 characters in an 11-column field. The written number stays within one
    unit of its last decimal of ``value``."""
    return value if abs(round(value, decimals)) <= largest else math.copysign(largest, value)


def _angle(rad: float) -> str:
    deg = math.degrees(rad) % 360.0
    text = f"{deg:8.4f}"
    return "  0.0000" if text == "360.0000" else text


def _epoch_year(satrec) -> int:
    """Full year of the record's epoch (from its Julian date, UTC)."""
    from datetime import datetime, timedelta

    days = (satrec.jdsatepoch - 2433281.5) + satrec.jdsatepochF  # since 1949-12-31 00:00
    return (datetime(1949, 12, 31) + timedelta(days=days)).year


def to_tle(satrec, satnum: int | None = None) -> tuple[str, str]:
    """The two TLE lines of an sgp4 record, with checksums and alpha-5 catalogue numbers.

    Parameters
    ----------
    satrec : sgp4.api.Satrec
        The record (from a TLE, an OMM or a fit).
    satnum : int, optional
        Catalogue number (default: the record's; :attr:`visviva.Satellite.satnum` passes
        numbers above 339,999, which the record cannot hold, and are refused here).

    Returns
    -------
    line1, line2 : str
        69 characters each.

    Raises
    ------
    InvalidInputError
        A value that the TLE's fixed columns cannot hold (eccentricity >= 1, mean motion >= 100
        rev/day, |mean motion derivative| >= 1 rev/day**2, a catalogue number above 339999).
    """
    num = tle_number(int(satrec.satnum) if satnum is None else satnum)
    cls = (getattr(satrec, "classification", "U") or "U").strip()[:1] or "U"
    intl = (getattr(satrec, "intldesg", "") or "").strip()[:8]
    ndot = satrec.ndot * _XPDOTP * 1440.0  # rev/day**2 (the TLE's n-dot/2)
    if not abs(ndot) < 1.0:
        raise InvalidInputError(f"mean motion derivative {ndot} rev/day**2 does not fit a TLE")
    ndot_text = f"{_fit_column(ndot, 8, 0.99999999): .8f}".replace("0.", ".", 1)
    nddot = satrec.nddot * _XPDOTP * 1440.0 * 1440.0  # rev/day**3 (n-ddot/6)
    year = _epoch_year(satrec)
    if not 1957 <= year <= 2056:
        raise InvalidInputError(f"epoch year {year} cannot be written in a TLE (its two digits "
                                "mean 1957 .. 2056); use to_omm()")
    epoch = _tle_epoch(year, satrec.epochdays)
    line1 = (f"1 {num}{cls} {intl:<8} {epoch} {ndot_text} "
             f"{format_exponent(nddot, 'MEAN_MOTION_DDOT', '-')} "
             f"{format_exponent(satrec.bstar, 'BSTAR')} {int(satrec.ephtype) % 10} "
             f"{int(satrec.elnum) % 10000:4d}")
    ecc = f"{satrec.ecco:.7f}"
    if not 0.0 <= satrec.ecco < 1.0 or not ecc.startswith("0."):
        raise InvalidInputError(f"eccentricity {satrec.ecco} does not fit a TLE (0 <= e < 1)")
    n = satrec.no_kozai * _XPDOTP
    if not 0.0 < n < 100.0 or float(f"{n:.8f}") == 0.0:
        raise InvalidInputError(f"mean motion {n} rev/day does not fit a TLE (0 < n < 100); "
                                "use to_omm()")
    incl = math.degrees(satrec.inclo)
    if not -1e-9 <= incl <= 180.0 + 1e-9:
        raise InvalidInputError(f"inclination {incl} deg is outside [0, 180]")
    line2 = (f"2 {num} {incl:8.4f} {_angle(satrec.nodeo)} {ecc[2:]} "
             f"{_angle(satrec.argpo)} {_angle(satrec.mo)} {_fit_column(n, 8, 99.99999999):11.8f}"
             f"{int(satrec.revnum) % 100000:5d}")
    return line1 + str(tle_checksum(line1)), line2 + str(tle_checksum(line2))


def _tle_epoch(year: int, days: float) -> str:
    """Columns 19-32 of line 1, ``YYDDD.DDDDDDDD``: the day of year rounded to 1e-8 day (0.86 ms).

    A time in the last 0.43 ms of a year rounds to day 1 of the next year (``%012.8f`` alone
    wrote day 366.00000000 of a common year, which no TLE reader accepts), or, where that year
    is 2057 (beyond the two-digit years), down to the year's last 1e-8 day.
    """
    text = f"{days:012.8f}"
    leap = year % 4 == 0 and (year % 100 != 0 or year % 400 == 0)
    if float(text) >= (367.0 if leap else 366.0):
        if year + 1 <= 2056:
            return f"{(year + 1) % 100:02d}001.00000000"
        text = f"{(366.0 if leap else 365.0) + 0.99999999:012.8f}"
    return f"{year % 100:02d}{text}"


def epoch_text(jd: float, fr: float) -> str:
    """``YYYY-mm-ddTHH:MM:SS.ffffff`` of a two-part UTC Julian date, rounded to the microsecond.

    (sgp4's own exporter truncates through ``datetime``; rounding halves the error to 0.5 us.)

    Parameters
    ----------
    jd, fr : float
        Whole and fractional parts of the Julian date (days, sgp4's UTC days of 86,400 s).

    Returns
    -------
    str
    """
    from datetime import datetime, timedelta

    split = jd - 2440587.5  # days since 1970-01-01
    whole = math.floor(split)
    us = whole * 86_400_000_000 + round(((split - whole) + fr) * 86_400_000_000)
    return (datetime(1970, 1, 1) + timedelta(microseconds=us)).strftime("%Y-%m-%dT%H:%M:%S.%f")


def _inverse(target: float, forward) -> float:
    """The float x nearest ``target`` / forward's factor with ``forward(x) == target`` exactly.

    sgp4's OMM reader converts each field once (degrees to radians, rev/day to rad/min); the
    plain inverse can be one unit in the last place off, so the neighbours are tried too.
    """
    guess = target / forward(1.0) if forward(1.0) != 0 else target
    candidates = [guess]
    up = down = guess
    for _ in range(4):
        up, down = math.nextafter(up, math.inf), math.nextafter(down, -math.inf)
        candidates += [up, down]
    for x in candidates:
        if forward(x) == target:
            return x
    return guess


def tle_designator(object_id) -> str:
    """The TLE's international designator field (``YYNNNPPP``) for an OMM ``OBJECT_ID``.

    A COSPAR identifier ``YYYY-NNNP{PP}`` (CCSDS 502.0-B-3, 3.2.3.3; e.g. ``1998-067A``) becomes
    ``98067A`` (kept as it is when already written so); anything else (``UNKNOWN``, a name, an
    empty field) becomes an empty field.
    sgp4's OMM reader keeps ``OBJECT_ID[2:]`` without its hyphens, which turns ``UNKNOWN`` into
    the designator ``KNOWN``: a TLE written from such a record would carry it.
    """
    text = str(object_id or "").strip().upper()
    if _TLE_DESIGNATOR.fullmatch(text):
        return text  # already the TLE's own form
    match = _COSPAR_ID.fullmatch(text)
    return "" if match is None else match[1][2:] + match[2] + match[3]


def to_omm(satrec, name: str, satnum: int | None = None) -> dict:
    """The CCSDS OMM fields of an sgp4 record (the keys of ``sgp4.exporter.export_omm``).

    Parameters
    ----------
    satrec : sgp4.api.Satrec
        The record.
    name : str
        ``OBJECT_NAME``.
    satnum : int, optional
        ``NORAD_CAT_ID`` (default: the record's; up to nine digits).

    Returns
    -------
    dict
        ``OBJECT_NAME``, ``OBJECT_ID``, ``CENTER_NAME``, ``REF_FRAME``, ``TIME_SYSTEM``,
        ``MEAN_ELEMENT_THEORY``, ``EPOCH``, ``MEAN_MOTION`` (rev/day), ``ECCENTRICITY``,
        ``INCLINATION``, ``RA_OF_ASC_NODE``, ``ARG_OF_PERICENTER``, ``MEAN_ANOMALY`` (deg),
        ``EPHEMERIS_TYPE``, ``CLASSIFICATION_TYPE``, ``NORAD_CAT_ID``, ``ELEMENT_SET_NO``,
        ``REV_AT_EPOCH``, ``BSTAR`` (1/earth radii), ``MEAN_MOTION_DOT`` (rev/day**2),
        ``MEAN_MOTION_DDOT`` (rev/day**3).

    Notes
    -----
    Each number is, where one exists, the float that sgp4's OMM reader (``sgp4.omm.initialize``,
    one multiplication per field) turns back into exactly the record's value; where none exists
    the reader lands one unit in the last place away. The epoch is rounded to the microsecond
    (sgp4's exporter truncates it).
    """
    intl = (getattr(satrec, "intldesg", "") or "").strip()
    object_id = ""
    if len(intl) >= 3 and intl[:2].isdigit():
        year = int(intl[:2])
        object_id = f"{year + (1900 if year >= 57 else 2000)}-{intl[2:]}"
    rad = math.pi / 180.0
    ndot_units = 1036800.0 / math.pi
    nddot_units = 2985984000.0 / 2.0 / math.pi
    return {
        "OBJECT_NAME": name,
        "OBJECT_ID": object_id,
        "CENTER_NAME": "EARTH",
        "REF_FRAME": "TEME",
        "TIME_SYSTEM": "UTC",
        "MEAN_ELEMENT_THEORY": "SGP4",
        "EPOCH": epoch_text(satrec.jdsatepoch, satrec.jdsatepochF),
        "MEAN_MOTION": _inverse(satrec.no_kozai, lambda x: x / 720.0 * math.pi),
        "ECCENTRICITY": satrec.ecco,
        "INCLINATION": _inverse(satrec.inclo, lambda x: x * rad),
        "RA_OF_ASC_NODE": _inverse(satrec.nodeo, lambda x: x * rad),
        "ARG_OF_PERICENTER": _inverse(satrec.argpo, lambda x: x * rad),
        "MEAN_ANOMALY": _inverse(satrec.mo, lambda x: x * rad),
        "EPHEMERIS_TYPE": int(satrec.ephtype),
        "CLASSIFICATION_TYPE": (getattr(satrec, "classification", "U") or "U"),
        "NORAD_CAT_ID": int(satrec.satnum) if satnum is None else int(satnum),
        "ELEMENT_SET_NO": int(satrec.elnum),
        "REV_AT_EPOCH": int(satrec.revnum),
        "BSTAR": satrec.bstar,
        "MEAN_MOTION_DOT": _inverse(satrec.ndot, lambda x: x / ndot_units),
        "MEAN_MOTION_DDOT": _inverse(satrec.nddot, lambda x: x / nddot_units),
    }
