"""The declarative description of CCSDS messages: keywords, sections, records.

Each message is described once, as data: a :class:`Section` is a tuple of :class:`Keyword`
(name, type, unit, mandatory flag) plus where the section sits in the XML layout; a message is a
tuple of sections. The readers in :mod:`visviva.ccsds.layout` fill one :class:`Record` per
section from either KVN or XML, checking the types, the units and the mandatory keywords, and
the writers write the records back.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

from ..errors import InvalidInputError

__all__ = [
    "CCSDSFormatError", "Keyword", "Section", "Record", "parse_value", "parse_float",
    "impossible_date", "VERSIONS", "version_keyword",
    "format_value", "format_float", "normalise_unit",
]


class CCSDSFormatError(InvalidInputError):
    """A CCSDS message (OEM, OPM, OMM, CDM) is malformed; the message names the line.

    Attributes
    ----------
    line : int or None
        1-based line number in the source (None when the error concerns the whole message).
    source : str
        File name or ``"<text>"``.
    """

    def __init__(self, message: str, line: int | None = None, source: str = "<text>"):
        where = f"{source}, line {line}: " if line is not None else f"{source}: "
        super().__init__(where + message)
        self.line = line
        self.source = source


# ASCII digits only ([0-9], not \d, which also takes '１２' and '١٢'), and no two ways to match
# the same digits (a long run of them that fails must fail in linear time)
_NUMBER_RE = re.compile(r"^[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eEdD][+-]?[0-9]+)?$")
_INT_RE = re.compile(r"^[+-]?[0-9]+$")
#: CCSDS epoch: calendar (YYYY-MM-DD) or ordinal (YYYY-DDD) date, 'T', time, optional 'Z'
EPOCH_PATTERN = r"[0-9]{4}-(?:[0-9]{2}-[0-9]{2}|[0-9]{3})T[0-9]{2}:[0-9]{2}:[0-9]{2}(?:\.[0-9]*)?Z?"
_EPOCH_RE = re.compile(f"^{EPOCH_PATTERN}$")
#: an epoch followed by an ISO 8601 UTC offset (``+00:00``, ``-0000``, ``+01``): CCSDS has none
_OFFSET_RE = re.compile(r"^(.*[0-9])([+-][0-9]{2}(?::?[0-9]{2})?)$")

#: value types a keyword may have
TYPES = ("text", "float", "int", "epoch")


@dataclass(frozen=True)
class Keyword:
    """One keyword of a CCSDS message.

    Parameters
    ----------
    name : str
        The keyword as written in KVN and as the XML element name (``"SEMI_MAJOR_AXIS"``).
    type : str
        ``"text"``, ``"float"``, ``"int"`` or ``"epoch"`` (a CCSDS date-time, kept as text).
    unit : str or None
        The CCSDS unit (``"km"``, ``"km/s"``, ``"km**2"``, ``"deg"``, ``"rev/day"``), or None for
        dimensionless keywords. A unit written in the message must match it.
    mandatory : bool
        Whether the section is incomplete without it.
    values : tuple of str
        The only texts a text keyword may hold (empty: any).
    """

    name: str
    type: str = "text"
    unit: str | None = None
    mandatory: bool = False
    values: tuple = ()

    def __post_init__(self):
        if self.type not in TYPES:
            raise ValueError(f"Keyword {self.name}: type must be one of {TYPES}")


#: the format versions each reader knows (CCSDS 502.0-B-1..B-3 for the ODMs; 508.0-B-1 for the
#: CDM, and 2.0 of its update 508.0-P-1.1, whose keywords shared with 1.0 keep their meaning:
#: the reader takes those and refuses its new ones as unknown keywords, naming the line)
VERSIONS = {"OEM": ("1.0", "2.0", "3.0"), "OPM": ("1.0", "2.0", "3.0"),
            "OMM": ("2.0", "3.0"), "CDM": ("1.0", "2.0"), "TDM": ("1.0", "2.0")}


def version_keyword(kind: str) -> Keyword:
    """The mandatory ``CCSDS_<KIND>_VERS`` keyword, taking the versions of :data:`VERSIONS`.

    Parameters
    ----------
    kind : str
        ``"OEM"``, ``"OPM"``, ``"OMM"`` or ``"CDM"``.

    Returns
    -------
    Keyword
    """
    return Keyword(f"CCSDS_{kind}_VERS", "text", None, True, VERSIONS[kind])


@dataclass(frozen=True)
class Section:
    """A group of keywords read together (a header, a metadata block, a state vector, ...).

    Parameters
    ----------
    name : str
        Name of the section in the parsed message (``"state_vector"``).
    keywords : tuple of Keyword
        The keywords, in the order writers write them.
    xml_path : str
        Path of the section's element below the root element, e.g.
        ``"body/segment/data/stateVector"``.
    optional : bool
        Whether the whole section may be absent. Its mandatory keywords are then mandatory only
        when the section is present.
    repeat : bool
        Whether the section may occur several times (manoeuvres); then its first keyword starts
        each occurrence and the parsed message holds a list of records.
    user_defined : bool
        ``USER_DEFINED_x = value`` lines in KVN, ``<USER_DEFINED parameter="x">`` in XML; the
        record maps each ``x`` to its text.
    """

    name: str
    keywords: tuple
    xml_path: str
    optional: bool = False
    repeat: bool = False
    user_defined: bool = False
    by_name: dict = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "by_name", {k.name: k for k in self.keywords})

    def owns(self, key: str) -> bool:
        """Whether a KVN keyword belongs to this section."""
        if self.user_defined:
            return key.startswith("USER_DEFINED_")
        return key in self.by_name


@dataclass
class Record:
    """The keywords of one section as read: values, units, comments and line numbers.

    Attributes
    ----------
    values : dict
        Keyword -> value (``str`` for text and epochs, ``float``, ``int``), in reading order.
    comments : list of str
        The COMMENT lines at the start of the section.
    lines : dict
        Keyword -> 1-based line number where it was read (absent for records built in code).
    line : int or None
        Line where the section starts.
    units : dict
        Parameter -> unit of the user-defined parameters written with one
        (``USER_DEFINED_X = 1.5 [km]``, ``<USER_DEFINED parameter="X" units="km">``), which
        have no table to take it from; written back with them.
    attributes : dict
        Keyword -> ``{name: value}``: the XML attributes of the keyword's element that the
        NDM/XML schema does not define (``<CREATION_DATE zone="UTC">``), written back on the
        same element by the XML writers (a KVN write has no place for them and warns).
    """

    values: dict = field(default_factory=dict)
    comments: list = field(default_factory=list)
    lines: dict = field(default_factory=dict)
    line: int | None = None
    units: dict = field(default_factory=dict)
    attributes: dict = field(default_factory=dict)

    def __getitem__(self, key):
        return self.values[key]

    def __contains__(self, key) -> bool:
        return key in self.values

    def get(self, key, default=None):
        """The value of ``key``, or ``default`` when absent."""
        return self.values.get(key, default)

    def line_of(self, key) -> int | None:
        """Line where ``key`` was read (the section's first line when it is absent)."""
        return self.lines.get(key, self.line)


def normalise_unit(unit: str) -> str:
    """A unit in one canonical spelling: lower case, no blanks, ``^`` written ``**``.

    Parameters
    ----------
    unit : str
        A CCSDS unit, e.g. ``"KM**2/S"``.

    Returns
    -------
    str
    """
    return unit.replace(" ", "").replace("^", "**").lower()


def parse_value(keyword: Keyword, text: str, unit: str | None, line, source: str):
    """Convert the text of one keyword to its type, checking its unit.

    Parameters
    ----------
    keyword : Keyword
        What the value should be.
    text : str
        The value as written (no unit).
    unit : str or None
        The unit as written (KVN brackets, XML ``units`` attribute), or None.
    line : int or None
        Line number, for the error message.
    source : str
        File name, for the error message.

    Returns
    -------
    str, float or int

    Raises
    ------
    CCSDSFormatError
        Wrong unit, a number that does not parse or is not finite, a malformed epoch.
    """
    if unit is not None and unit.strip() not in ("", "n/a"):
        expected = keyword.unit
        if expected is None:
            raise CCSDSFormatError(f"{keyword.name} takes no unit, but has [{unit}]",
                                   line=line, source=source)
        if normalise_unit(unit) != normalise_unit(expected):
            raise CCSDSFormatError(
                f"{keyword.name} must be in [{expected}], not [{unit}]; convert the value",
                line=line, source=source)
    text = text.strip()
    if keyword.type == "text":
        if not text:  # (an XML attribute or element of blanks; KVN refuses it in the lexer)
            raise CCSDSFormatError(f"{keyword.name} has no value", line=line, source=source)
        if keyword.values and text not in keyword.values:
            raise CCSDSFormatError(
                f"{keyword.name} = {text!r}: this reader knows {', '.join(keyword.values)}",
                line=line, source=source)
        return text
    if keyword.type == "epoch":
        offset = _OFFSET_RE.match(text)
        if offset and _EPOCH_RE.match(offset.group(1)):
            # an ISO 8601 UTC offset (written by datetime.isoformat and many web services:
            # audit51): zero is the CCSDS 'Z' and reads as such; another would shift the time
            if offset.group(2).strip("+-:0"):
                raise CCSDSFormatError(
                    f"{keyword.name} = {text!r} carries the UTC offset {offset.group(2)}; a "
                    "CCSDS epoch has none (it is a time in the message's TIME_SYSTEM): "
                    "subtract the offset from the time and write it without one",
                    line=line, source=source)
            text = offset.group(1) + "Z"
        if not _EPOCH_RE.match(text):
            raise CCSDSFormatError(
                f"{keyword.name} = {text!r} is not a CCSDS epoch like 2024-01-31T12:00:00.000 "
                "or 2024-031T12:00:00", line=line, source=source)
        why = impossible_date(text)
        if why:
            raise CCSDSFormatError(f"{keyword.name} = {text!r} is not a date that exists "
                                   f"({why})", line=line, source=source)
        return text
    if keyword.type == "int":
        if not _INT_RE.match(text):
            raise CCSDSFormatError(f"{keyword.name} = {text!r} is not an integer",
                                   line=line, source=source)
        return int(text)
    return parse_float(text, keyword.name, line, source)


def impossible_date(text: str) -> str:
    """Why a text that matches :data:`EPOCH_PATTERN` is no calendar date-time (month 13,
    February 30, day 366 of a common year, hour 24, minute 60, second 61 or more), or ``""``.
    A leap second (``23:59:60``) passes here: the time system decides (astropy, for UTC); so
    does an ordinal date in year 0000 (the elapsed days of a MET or MRT time)."""
    import calendar

    date, _, clock = text.rstrip("Z").partition("T")
    parts = date.split("-")
    year = int(parts[0])
    if len(parts) == 3:
        month, day = int(parts[1]), int(parts[2])
        if not 1 <= month <= 12:
            return f"month {month}"
        last = calendar.monthrange(year, month)[1]
        if not 1 <= day <= last:
            return f"day {day} of a month of {last} days"
    elif year >= 1000:  # (year 0000: an elapsed time of a MET/MRT message, day 000 and on)
        day = int(parts[1])
        last = 366 if calendar.isleap(year) else 365
        if not 1 <= day <= last:
            return f"day {day} of a year of {last} days"
    hh, mm, ss = clock.split(":")
    if int(hh) > 23 or int(mm) > 59 or float(ss) >= 61.0:
        return f"time {clock}"
    return ""


def parse_float(text: str, what: str, line, source: str) -> float:
    """Parse a CCSDS real number (``1.5``, ``-2.E-3``, ``.5``; no NaN or infinity).

    Parameters
    ----------
    text : str
        The number as written.
    what : str
        Name of the value, quoted in the error message.
    line : int or None
        Line number, for the error message.
    source : str
        File name, for the error message.

    Returns
    -------
    float
    """
    if not _NUMBER_RE.match(text):
        raise CCSDSFormatError(f"{what} = {text!r} is not a number", line=line, source=source)
    value = float(text.replace("d", "e").replace("D", "e"))
    if not math.isfinite(value):
        raise CCSDSFormatError(f"{what} = {text!r} overflows float64", line=line, source=source)
    return value


def format_value(keyword: Keyword, value) -> str:
    """The text a writer puts for a value (floats shortest round-trip, in E notation).

    Parameters
    ----------
    keyword : Keyword
        What the value is.
    value : str, float or int
        The value.

    Returns
    -------
    str
    """
    if keyword.type == "float":
        return format_float(value)
    if keyword.type == "int":
        return str(int(value))
    text = str(value).strip()
    if not text or "\n" in text or "\r" in text:
        raise InvalidInputError(
            f"{keyword.name} = {value!r}: a value is one line of text, not empty (a reader "
            "refuses anything else); give e.g. UNKNOWN.")
    return text


def format_float(value: float) -> str:
    """Shortest text that reads back to the same float64 (Python's ``repr``), in E notation.

    Parameters
    ----------
    value : float
        Any finite number.

    Returns
    -------
    str
    """
    text = repr(float(value))
    return text.replace("e", "E") if "e" in text else text
