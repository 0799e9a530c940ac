"""Reading satellite catalogues from files: TLE text (two- or three-line element sets), OMM
records (CelesTrak's GP data as JSON, CSV or XML) and a CCSDS KVN OMM (one satellite), for the
public readers of :mod:`visviva.satellites.catalog`, which wrap the satellites in a ``Catalog``.
:func:`catalog_file_satellites` tells the kind of a file from its content.

Every malformed input raises a typed error naming the file and the line (or the record):
:class:`~visviva.satellites.tle.TLEFormatError` for TLE lines,
:class:`~visviva.errors.InvalidInputError` for OMM files.
"""

from __future__ import annotations

import io
import os
import warnings

from .._text import file_bytes, utf8_text
from ..errors import DecayedObjectWarning, InvalidInputError, fmt_first
from .tle import Satellite, TLEFormatError
from .tle_checks import warn_decayed

__all__ = ["tle_text_satellites", "tle_file_satellites", "omm_file_satellites",
           "catalog_file_satellites", "decode_tle_bytes", "warn_duplicates"]


def tle_text_satellites(text: str, *, source: str = "<text>", verify_checksum: bool = True) -> list:
    """The satellites of :func:`visviva.satellites.catalog.parse_tle_text` (which see), as a list."""
    # lines end at CR/LF only: str.splitlines would also split at a form feed or a NEL (a
    # Latin-1 byte 0x85 in a name), and every later line number would be off
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    sats = []
    name = None
    i = 0
    n = len(lines)
    while i < n:
        # element lines indented (pasted from a web page or an e-mail: audit51) are read
        # without their leading blanks; their columns and checksums are checked as usual
        line = lines[i].strip()
        if not line:
            i += 1
            continue
        nxt = lines[i + 1].strip() if i + 1 < n else ""
        if line.startswith("1 ") and nxt.startswith("2 "):
            where = (f"line {i + 1} of {source}", f"line {i + 2} of {source}")
            sats.append(
                Satellite.from_tle(line, nxt, name, verify_checksum=verify_checksum, where=where)
            )
            name = None
            i += 2
            continue
        if line.startswith("1 "):
            raise TLEFormatError(
                f"line {i + 2} of {source} should be line 2 of the element set that starts on "
                f"line {i + 1} (it must start with '2 '), got {nxt!r}."
            )
        if line.startswith("2 "):
            raise TLEFormatError(
                f"line {i + 1} of {source} is a TLE line 2 without its line 1: {line!r}."
            )
        if name is not None:
            raise TLEFormatError(
                f"line {i + 1} of {source}: expected TLE line 1 after the name line {name!r}, "
                f"got {line!r}."
            )
        name = line[2:].strip() if line.startswith("0 ") else line.strip()
        i += 1
    if name is not None:
        raise TLEFormatError(f"{source} ends with the name line {name!r} and no element set.")
    warn_duplicates(sats, source)
    return sats


def warn_duplicates(sats, source: str) -> None:
    """Warn (``UserWarning``) when catalogue numbers other than 0 appear more than once among
    the satellites read from ``source``, naming them and what to do."""
    import warnings
    from collections import Counter

    counts = Counter(s.satnum for s in sats if s.satnum != 0)
    twice = [(n, c) for n, c in counts.items() if c > 1]
    if not twice:
        return
    listed = fmt_first([f"{n} ({c} element sets)" for n, c in twice])
    warnings.warn(
        f"{source}: catalogue number {listed} appears more than once. The catalogue "
        "keeps every element set, so screening pairs such an object with itself and passes are "
        "listed once per set: keep the newest set of each object (catalog.latest()), or remove "
        "the older sets from the file.",
        UserWarning, stacklevel=2)


def tle_file_satellites(path, *, verify_checksum: bool = True) -> list:
    """The satellites of :func:`visviva.satellites.catalog.read_tle_file` (which see), as a list."""
    if isinstance(path, io.TextIOBase) or hasattr(path, "read"):
        text = path.read()
        source = getattr(path, "name", "<file>")
    else:
        text = decode_tle_bytes(_file_bytes(path, "element sets"))
        source = os.fspath(path)
    return tle_text_satellites(text, source=str(source), verify_checksum=verify_checksum)


def _file_bytes(path, what: str) -> bytes:
    """The bytes of a catalogue file (:func:`visviva._text.file_bytes`: a missing file raises a
    :class:`~visviva.errors.MissingFileError`, also a ``FileNotFoundError``, naming the path
    and saying what to do). An empty file (nothing but white space) raises an
    :class:`~visviva.errors.InvalidInputError` naming it: it is a failed download or save far
    more often than an empty catalogue, and an empty catalogue would pass on as 0 passes or 0
    conjunctions without a word."""
    if isinstance(path, str) and "\n" in path.strip():  # (audit51: was "no such file")
        raise InvalidInputError(
            f"got a text of {path.strip().count(chr(10)) + 1} lines where the path of a file "
            f"of {what} is expected: pass the file's path, or read TLE text with "
            "visviva.satellites.catalog.parse_tle_text(text) (an OMM text: save it to a file "
            "first).")
    raw = file_bytes(
        path, what, f"check the name, or download the {what} first (e.g. CelesTrak's GP data, "
        "https://celestrak.org/NORAD/elements/, in TLE, JSON, CSV or XML); visviva never "
        "downloads them itself.")
    if not raw.lstrip(b"\xef\xbb\xbf").strip():
        raise InvalidInputError(
            f"{os.fspath(path)}: the file is empty (no {what}); download or save it again, or "
            "check the name.")
    return raw


def decode_tle_bytes(raw: bytes) -> str:
    """The text of a TLE file's bytes: UTF-8 (a byte-order mark dropped), else Latin-1.

    Element lines are ASCII; names may not be, and Latin-1 decodes any byte (names were
    replaced by '?' marks before). ``visviva convert`` reads TLE files through this too.
    """
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        return raw.decode("latin-1")


def omm_file_satellites(path, *, format: str | None = None) -> list:
    """The satellites of :func:`visviva.satellites.catalog.read_omm_file` (which see), as a list."""
    path = os.fspath(path)
    raw = _file_bytes(path, "OMM records")
    fmt = (format or os.path.splitext(path)[1].lstrip(".")).lower()
    if fmt not in ("json", "csv", "xml", "kvn"):
        if format is not None or _ccsds_kind(raw.lstrip(b"\xef\xbb\xbf")[:4096]) != "OMM":
            raise InvalidInputError(
                f"cannot tell the OMM format of {path!r}; pass format='json', 'csv', 'xml' or "
                "'kvn'."
            )
        fmt = "kvn"  # (CCSDS_OMM_VERS first: what vv.write_omm and Space-Track's KVN write)
    return _omm_text_satellites(_decode_utf8(raw, path), path, fmt)


def _decode_utf8(raw: bytes, path: str) -> str:
    """The UTF-8 text of an OMM file, or an error naming the line of the first bad byte."""
    return utf8_text(raw, lambda line, byte: InvalidInputError(
        f"{path}, line {line}: byte 0x{byte:02x} is not UTF-8 text; save the file as UTF-8 "
        "(CelesTrak's GP data is)."))


def _omm_text_satellites(text: str, path: str, fmt: str) -> list:
    """The satellites of the OMM records of ``text`` in the format ``fmt`` (json, csv, xml or
    kvn), errors naming ``path`` and the line or record."""
    import csv
    import json

    from sgp4 import omm

    where = []  # the line of each record, where the format tells it (CSV, KVN, XML)
    key_lines = None  # KVN: the line of each keyword of each record
    try:
        if fmt == "json":
            records = json.loads(text)
            if isinstance(records, dict):
                records = [records]
            if not isinstance(records, list):
                raise InvalidInputError(
                    f"{path}: the JSON top level is {type(records).__name__}, not a list of OMM "
                    "records (objects of keyword: value); is it CelesTrak's GP JSON?"
                )
        elif fmt == "csv":
            reader = omm.parse_csv(io.StringIO(text, newline=""))
            records = []
            for rec in reader:
                records.append(rec)
                where.append(reader.line_num)
            if not reader.fieldnames:
                raise InvalidInputError(
                    f"{path}: no header line; the file is empty." if not text.strip() else
                    f"{path}, line 1: empty; a CSV of OMM records starts with its header line.")
            if not records and "EPOCH" not in reader.fieldnames:
                raise InvalidInputError(
                    f"{path}, line 1: {','.join(reader.fieldnames)[:60]!r} is not a CSV of OMM "
                    "records (its header has no EPOCH column); is it CelesTrak's GP CSV?"
                )
        elif fmt == "kvn":
            records, where, key_lines = _kvn_omm_records(text, path)
        else:
            records, where = _omm_xml_records(text, path)
    except json.JSONDecodeError as exc:
        raise InvalidInputError(
            f"{path}, line {exc.lineno}, column {exc.colno}: not valid JSON ({exc.msg}); the "
            "file is truncated or is not CelesTrak's GP JSON."
        ) from exc
    except csv.Error as exc:
        raise InvalidInputError(
            f"{path}, line {reader.line_num}: not valid CSV ({exc})."
        ) from exc
    sats = []
    for k, rec in enumerate(records, start=1):
        try:
            with warnings.catch_warnings():  # (one warning for the file, below)
                warnings.simplefilter("ignore", DecayedObjectWarning)
                sats.append(Satellite.from_omm(rec))
        except InvalidInputError as exc:
            line = f", line {where[k - 1]}" if where else ""
            if key_lines is not None:
                line = _keyword_line(str(exc), key_lines[k - 1], where[k - 1])
            raise type(exc)(f"record {k} of {path}{line}: {exc}") from exc
    warn_decayed([(s.name or str(s.satnum), str(r.get("DECAY_DATE")).strip())
                  for s, r in zip(sats, records, strict=True)
                  if str(r.get("DECAY_DATE") or "").strip()], str(path))
    warn_duplicates(sats, path)
    return sats


#: the unit CCSDS 502.0 fixes for each OMM keyword with one (visviva.ccsds.omm holds the same
#: table for the full reader, which this layer may not import; tests/test_catalog.py compares)
OMM_UNITS = {"SEMI_MAJOR_AXIS": "km", "MEAN_MOTION": "rev/day", "INCLINATION": "deg",
             "RA_OF_ASC_NODE": "deg", "ARG_OF_PERICENTER": "deg", "MEAN_ANOMALY": "deg",
             "GM": "km**3/s**2", "MASS": "kg", "SOLAR_RAD_AREA": "m**2", "DRAG_AREA": "m**2",
             "BSTAR": "1/ER", "BTERM": "m**2/kg",
             "MEAN_MOTION_DOT": "rev/day**2", "MEAN_MOTION_DDOT": "rev/day**3",
             "AGOM": "m**2/kg"}


def check_omm_unit(key: str, unit, where: str) -> None:
    """Refuse a unit written with an OMM keyword (KVN ``[unit]``, XML ``units=``) other than
    the one the standard fixes: the value is read in the standard's unit, so
    ``INCLINATION = 0.9 [rad]`` would be read as 0.9 deg (as :func:`visviva.read_omm` does,
    case and blanks ignored, ``^`` for ``**``; keywords without a fixed unit pass)."""
    if unit is None or unit.strip() in ("", "n/a") or key not in OMM_UNITS:
        return
    def norm(text):
        return text.replace(" ", "").replace("^", "**").lower()

    if norm(unit) != norm(OMM_UNITS[key]):
        raise InvalidInputError(
            f"{where}: {key} must be in [{OMM_UNITS[key]}], not [{unit}]; the value would be "
            f"read as {OMM_UNITS[key]}. Convert the value (and its unit) first."
        )


def _kvn_omm_records(text: str, path: str) -> tuple[list, list]:
    """The ``KEYWORD = value`` pairs (units in brackets dropped) of each CCSDS KVN OMM in
    ``text`` (one message, or many one after another as Space-Track's and CelesTrak's KVN GP
    data hold them: each ``CCSDS_OMM_VERS`` starts the next), and the line each starts on.

    The layers keep :mod:`visviva.satellites` below :mod:`visviva.ccsds`, so a catalogue file
    is read here; :func:`visviva.read_omm` is the full CCSDS reader (every section checked),
    and both give the same satellite (tests/test_ccsds_convert.py). Also returns the line of
    each keyword of each record (a bad value is reported at its own line)."""
    records, starts, lines = [], [], []
    fields = None
    for number, line in enumerate(text.replace("\r\n", "\n").split("\n"), start=1):
        stripped = line.strip()
        if not stripped or stripped == "COMMENT" or stripped.startswith(("COMMENT ", "COMMENT\t")):
            continue
        key, eq, value = stripped.partition("=")
        key = key.strip()
        if not eq or not key.replace("_", "").isalnum():
            raise InvalidInputError(
                f"{path}, line {number}: expected 'KEYWORD = value' of a KVN OMM, got "
                f"{stripped[:60]!r}."
            )
        if fields is None or key == "CCSDS_OMM_VERS":
            fields = {}
            records.append(fields)
            starts.append(number)
            lines.append({})
        elif key in fields:
            raise InvalidInputError(
                f"{path}, line {number}: {key} appears twice in the OMM that starts on line "
                f"{starts[-1]}; each OMM (from its CCSDS_OMM_VERS line on) holds one satellite."
            )
        value = value.strip()
        if value.endswith("]") and "[" in value:
            value, unit = value[:value.rindex("[")].strip(), value[value.rindex("[") + 1:-1]
            check_omm_unit(key, unit, f"{path}, line {number}")
        fields[key] = value
        lines[-1][key] = number
    if not records:
        raise InvalidInputError(f"{path}: no 'KEYWORD = value' lines; the file is empty.")
    return records, starts, lines


def _keyword_line(message: str, key_lines: dict, start: int) -> str:
    """", line N" of the keyword of a KVN OMM that ``message`` (a record's error) names first,
    with the line its OMM starts on; ", line {start}" when it names none of them."""
    import re

    found = [(m.start(), key) for key in key_lines
             if (m := re.search(rf"(?<![A-Z0-9_]){re.escape(key)}(?![A-Z0-9_])", message))]
    if not found:
        return f", line {start}"
    key = min(found)[1]
    return f", line {key_lines[key]} ({key}; the OMM starts on line {start})"


#: column names of which one in a comma-separated first line makes it an OMM CSV header
#: (CelesTrak's GP CSV), whatever else it lacks
_CSV_HEADER_KEYS = (b"NORAD_CAT_ID", b"MEAN_MOTION", b"ECCENTRICITY", b"INCLINATION",
                    b"OBJECT_NAME", b"EPOCH")


def catalog_file_satellites(path) -> list:
    """The satellites of :func:`visviva.satellites.catalog.read_catalog_file` (which see)."""
    if isinstance(path, io.TextIOBase) or hasattr(path, "read"):
        return tle_file_satellites(path)
    path = os.fspath(path)
    raw = _file_bytes(path, "element sets")
    head = raw.lstrip(b"\xef\xbb\xbf \t\r\n")[:4096]
    first = head.split(b"\n", 1)[0].upper()
    lines = [line for line in head.split(b"\n", 4)[:4] if line.strip()]
    if any(line.startswith(b"1 ") for line in lines[:2]):  # (a name such as '[+] X' or '<X>')
        return tle_text_satellites(decode_tle_bytes(raw), source=path)
    if head[:1] in (b"{", b"["):
        fmt = "json"
    elif head[:1] == b"<":
        fmt = "xml"
        if b"<omm" not in head.lower() and b"<ndm" not in head.lower():
            raise InvalidInputError(
                f"{path}, line 1: an XML file without <omm> or <ndm>; visviva reads element "
                "sets from OMM XML (CelesTrak's or CCSDS), not other messages."
            )
    elif b"," in first and any(key in first for key in _CSV_HEADER_KEYS):
        fmt = "csv"  # a header missing NORAD_CAT_ID is still CSV: its reader names the gap
    else:
        kind = _ccsds_kind(head)
        if kind is None:
            return tle_text_satellites(decode_tle_bytes(raw), source=path)
        if kind != "OMM":
            raise InvalidInputError(
                f"{path}: a CCSDS {kind}, not element sets; visviva reads TLE, OMM JSON, CSV "
                "or XML, and CCSDS OMM files."
                + (f" For an ephemeris fit an element set first: visviva fit-tle {path} "
                   "--output set.tle (vv.fit_tle(vv.read_oem(path)))." if kind == "OEM" else "")
            )
        fmt = "kvn"
    return _omm_text_satellites(_decode_utf8(raw, path), path, fmt)


def _ccsds_kind(head: bytes) -> str | None:
    """``"OMM"``, ``"OEM"``... when the first line that is not blank or a comment is a CCSDS
    ``CCSDS_xxx_VERS`` keyword, else None."""
    for line in head.split(b"\n"):
        stripped = line.strip().upper()
        if not stripped or stripped.startswith(b"COMMENT"):
            continue
        if stripped.startswith(b"CCSDS_") and b"_VERS" in stripped[:16]:
            return stripped[6:9].decode("ascii", "replace")
        return None
    return None


def _omm_xml_records(text: str, path: str) -> tuple[list, list]:
    """The keyword: text records of every OMM ``<segment>`` of an XML file (one ``<omm>`` or an
    ``<ndm>`` of many, as CelesTrak writes), and the line of each ``<segment>``.

    As sgp4's ``omm.parse_xml``, but the decoded text is parsed as UTF-8 whatever encoding its
    declaration names (a declared 'latin-1' re-decoded it, an unknown name raised LookupError),
    external entities are refused (:mod:`visviva._xmltree`), a segment without some of its
    sections gives a record lacking those keywords (which :meth:`Satellite.from_omm` names)
    instead of an AttributeError, and elements holding elements are left out."""
    from .._xmltree import parse_xml

    root = parse_xml(text, lambda line, message: InvalidInputError(
        f"{path}, line {line}: {message}; the file is truncated or is not an OMM XML file."))
    records, lines = [], []
    for segment in root.iter("segment"):
        fields = {}
        for section in ("metadata", "data/meanElements", "data/tleParameters"):
            for element in segment.path(section):
                for c in element.children:
                    if c.tag != "COMMENT" and not c.children:
                        check_omm_unit(c.tag, c.attrib.get("units"), f"{path}, line {c.line}")
                        fields[c.tag] = c.text
        records.append(fields)
        lines.append(segment.line)
    if not records:
        raise InvalidInputError(f"{path}: no OMM <segment> in the XML; is it an OMM XML file?")
    return records, lines
