"""The CCSDS Tracking Data Message (TDM, CCSDS 503.0-B-1 2007 and 503.0-B-2 2020): reading.

A TDM carries tracking measurements -- range, Doppler, angles, frequencies, media and clock
data -- between agencies (Orekit, GMAT, ODTK, ESA and the NASA DSN exchange it). It is a
header followed by segments, each a metadata block (``META_START`` ... ``META_STOP``: time
system, participants, signal path, units, corrections) and a data block (``DATA_START`` ...
``DATA_STOP``) of lines ``KEYWORD = epoch value``. In XML each data line is an
``<observation>`` with an ``<EPOCH>`` and one measurement element.

:func:`read_tdm` reads KVN and XML (detected) into a :class:`TDM`: ``.header``, ``.segments``
(each a :class:`TDMSegment` with ``.metadata``, ``.keywords``, ``.epochs``, ``.values``,
``.times``), every line kept -- keywords visviva does not model included. Turning the
measurements into a :class:`~visviva.Observations` table is ``to_observations`` of the
subclass that ``vv.read_tdm`` returns (:mod:`visviva.od.tracking_data`: orbit determination
sits above the file formats); writing is
:func:`~visviva.ccsds.tdm_write.write_tdm`. The KVN lexer, the keyword tables and the XML tree
are those of the other CCSDS messages (:mod:`visviva.ccsds.layout`): every malformed line is a
:class:`~visviva.ccsds.grammar.CCSDSFormatError` naming the line.
"""

from __future__ import annotations

import re
import warnings

import numpy as np

from .grammar import EPOCH_PATTERN, CCSDSFormatError, Record, Section, parse_float, version_keyword
from .grammar import Keyword as K
from .kvn import KVNCursor, KVNLine
from .layout import (
    check_mandatory,
    read_kvn_header,
    read_kvn_metadata_block,
    read_text,
    read_xml_section,
    with_version,
)
from .ndmxml import looks_like_xml, message_root, parse

__all__ = ["TDM", "TDMSegment", "read_tdm", "check_data", "HEADER", "METADATA",
           "DATA_KEYWORDS"]

_EPOCH_RE = re.compile(f"^{EPOCH_PATTERN}$")
_EPOCHS_RE = re.compile(f"(?:{EPOCH_PATTERN}\n)*{EPOCH_PATTERN}")  # one per line, one scan
_PARTICIPANTS = range(1, 6)  # PARTICIPANT_1 .. PARTICIPANT_5 (503.0-B-2, 3.3.2)
_PATH_RE = re.compile(r"^[1-5](?:\s*,\s*[1-5])+$")
#: keywords in RANGE_UNITS (km, s or RU): a unit written with them must be that one
_IN_RANGE_UNITS = ("CORRECTION_RANGE", "RANGE_MODULUS")

HEADER = Section("header", (
    version_keyword("TDM"), K("CREATION_DATE", "epoch", None, True),
    K("ORIGINATOR", "text", None, True), K("MESSAGE_ID")), "header")

METADATA = Section("metadata", (
    K("TRACK_ID"), K("DATA_TYPES"), K("TIME_SYSTEM", "text", None, True),
    K("START_TIME", "epoch"), K("STOP_TIME", "epoch"),
    *(K(f"PARTICIPANT_{n}", "text", None, n == 1) for n in _PARTICIPANTS),
    K("MODE", "text", None, False, ("SEQUENTIAL", "SINGLE_DIFF")),
    K("PATH"), K("PATH_1"), K("PATH_2"),
    *(K(f"EPHEMERIS_NAME_{n}") for n in _PARTICIPANTS),
    K("TRANSMIT_BAND"), K("RECEIVE_BAND"),
    K("TURNAROUND_NUMERATOR", "int"), K("TURNAROUND_DENOMINATOR", "int"),
    K("TIMETAG_REF", "text", None, False, ("TRANSMIT", "RECEIVE")),
    K("INTEGRATION_INTERVAL", "float", "s"),
    K("INTEGRATION_REF", "text", None, False, ("START", "MIDDLE", "END")),
    K("FREQ_OFFSET", "float", "Hz"),
    K("RANGE_MODE", "text", None, False, ("COHERENT", "CONSTANT", "ONE_WAY")),
    K("RANGE_MODULUS", "float"), K("RANGE_UNITS", "text", None, False, ("km", "s", "RU")),
    K("ANGLE_TYPE", "text", None, False, ("AZEL", "RADEC", "XEYN", "XSYE")),
    K("REFERENCE_FRAME"), K("INTERPOLATION"), K("INTERPOLATION_DEGREE", "int"),
    K("DOPPLER_COUNT_BIAS", "float", "Hz"), K("DOPPLER_COUNT_SCALE", "float"),
    K("DOPPLER_COUNT_ROLLOVER", "text", None, False, ("YES", "NO")),
    *(K(f"TRANSMIT_DELAY_{n}", "float", "s") for n in _PARTICIPANTS),
    *(K(f"RECEIVE_DELAY_{n}", "float", "s") for n in _PARTICIPANTS),
    K("DATA_QUALITY", "text", None, False, ("RAW", "VALIDATED", "DEGRADED")),
    K("CORRECTION_ANGLE_1", "float", "deg"), K("CORRECTION_ANGLE_2", "float", "deg"),
    K("CORRECTION_DOPPLER", "float", "km/s"), K("CORRECTION_MAG", "float"),
    K("CORRECTION_RANGE", "float"), K("CORRECTION_RCS", "float", "m**2"),
    K("CORRECTION_RECEIVE", "float", "Hz"), K("CORRECTION_TRANSMIT", "float", "Hz"),
    K("CORRECTION_ABERRATION_YEARLY", "float", "deg"),
    K("CORRECTION_ABERRATION_DIURNAL", "float", "deg"),
    K("CORRECTIONS_APPLIED", "text", None, False, ("YES", "NO")),
), "body/segment/metadata")


def _indexed(name, unit):
    return {f"{name}_{n}": unit for n in _PARTICIPANTS}


#: every data keyword of 503.0-B-2 (section 3.5) -> its unit (None: dimensionless or per
#: the metadata, as RANGE in RANGE_UNITS)
DATA_KEYWORDS = {
    "ANGLE_1": "deg", "ANGLE_2": "deg", "CARRIER_POWER": "dBW", "CLOCK_BIAS": "s",
    "CLOCK_DRIFT": "s/s", "DOPPLER_COUNT": None, "DOPPLER_INSTANTANEOUS": "km/s",
    "DOPPLER_INTEGRATED": "km/s", "DOR": "s", "MAG": None, "PC_N0": "dBHz", "PR_N0": "dBHz",
    "PRESSURE": "hPa", "RANGE": None, "RCS": "m**2", "RECEIVE_FREQ": "Hz",
    **_indexed("RECEIVE_FREQ", "Hz"), **_indexed("RECEIVE_PHASE_CT", None),
    "RHUMIDITY": "%", "STEC": "TECU", "TEMPERATURE": "K",
    **_indexed("TRANSMIT_FREQ", "Hz"), **_indexed("TRANSMIT_FREQ_RATE", "Hz/s"),
    **_indexed("TRANSMIT_PHASE_CT", None),
    "TROPO_DRY": "m", "TROPO_WET": "m", "VLBI_DELAY": "s",
}


class TDMSegment:
    """One segment of a TDM: its metadata and its data lines, as read (nothing dropped).

    Parameters
    ----------
    metadata : Record
        The metadata keywords (``.values``, ``.comments``, ``.lines``).
    keywords, epochs : list of str
        The data keyword and the epoch text of each data line.
    values : ndarray (N,)
        The value of each data line, as written (units of :data:`DATA_KEYWORDS`; RANGE in
        ``RANGE_UNITS``).
    lines : list of int
        1-based line of each data line (None for data built in code).
    data_comments : list of str
        The COMMENT lines of the data block (in KVN also those between ``META_STOP`` and
        ``DATA_START``, and, for the last segment, those after its ``DATA_STOP``).
    source : str
        File name, for error messages.
    mission_epoch : astropy.time.Time, optional
        The epoch of a MET/MRT time system.

    Attributes
    ----------
    metadata, keywords, epochs, values, lines, data_comments
        As given.
    """

    def __init__(self, metadata, keywords, epochs, values, lines=None, data_comments=(),
                 source="<text>", mission_epoch=None):  # fmt: skip
        self.metadata = metadata
        self.keywords = list(keywords)
        self.epochs = list(epochs)
        self.values = np.asarray(values, dtype=np.float64).reshape(-1)
        self.lines = list(lines) if lines is not None else [None] * len(self.keywords)
        self.data_comments = list(data_comments)
        self.source = source
        self._mission_epoch = mission_epoch
        self._times = None

    def __len__(self):
        return len(self.keywords)

    def __repr__(self):
        kinds = sorted(set(self.keywords))
        return (f"TDMSegment({len(self)} lines, participants {self.participants}, "
                f"{', '.join(kinds)})")

    @property
    def participants(self) -> dict:
        """``{n: name}`` of the ``PARTICIPANT_n`` keywords."""
        return {n: self.metadata[f"PARTICIPANT_{n}"] for n in _PARTICIPANTS
                if f"PARTICIPANT_{n}" in self.metadata}

    @property
    def path(self) -> tuple | None:
        """``PATH`` as a tuple of participant numbers (``(1, 2, 1)``), or None."""
        text = self.metadata.get("PATH")
        return None if text is None else tuple(int(p) for p in text.split(","))

    @property
    def time_system(self) -> str:
        """``TIME_SYSTEM`` as written."""
        return self.metadata["TIME_SYSTEM"]

    @property
    def data_quality(self) -> str | None:
        """``DATA_QUALITY`` (``RAW``, ``VALIDATED``, ``DEGRADED``) or None."""
        return self.metadata.get("DATA_QUALITY")

    @property
    def times(self):
        """The epochs as an astropy ``Time`` (N,), in the segment's time system (cached)."""
        if self._times is None:
            from .timeframes import epochs_to_time

            self._times = epochs_to_time(
                self.epochs, self.time_system, self.lines, self.source, self._mission_epoch,
                system_line=self.metadata.line_of("TIME_SYSTEM"))
        return self._times

    def select(self, keyword: str):
        """Times (astropy ``Time``) and values (ndarray) of the lines of one data keyword.

        Parameters
        ----------
        keyword : str
            E.g. ``"RANGE"``.

        Returns
        -------
        times : astropy.time.Time (M,)
        values : ndarray (M,)
        """
        idx = [i for i, k in enumerate(self.keywords) if k == keyword]
        return self.times[idx], self.values[idx]


class TDM:
    """A CCSDS Tracking Data Message: a header and segments of tracking data.

    Parameters
    ----------
    header : Record or dict
        ``CCSDS_TDM_VERS``, ``CREATION_DATE``, ``ORIGINATOR``, optional ``MESSAGE_ID``.
    segments : list of TDMSegment
        The segments.
    fmt : {"kvn", "xml"}
        The format read.

    Attributes
    ----------
    header : Record
    segments : list of TDMSegment
    fmt : str
    """

    def __init__(self, header, segments, fmt="kvn"):
        self.header = header if isinstance(header, Record) else Record(values=dict(header))
        self.segments = list(segments)
        self.fmt = fmt

    def __len__(self):
        return sum(len(s) for s in self.segments)

    def __repr__(self):
        return f"TDM({len(self.segments)} segments, {len(self)} data lines)"

    @property
    def version(self) -> str:
        """``CCSDS_TDM_VERS``."""
        return self.header["CCSDS_TDM_VERS"]

    def keyword_counts(self) -> dict:
        """Number of data lines of each data keyword over all segments."""
        out: dict = {}
        for seg in self.segments:
            for k in seg.keywords:
                out[k] = out.get(k, 0) + 1
        return out


def read_tdm(source, *, mission_epoch=None, cls=None) -> TDM:
    """Read a CCSDS Tracking Data Message (KVN or XML, detected).

    Parameters
    ----------
    source : str, os.PathLike or bytes
        A path, the message text, or its bytes (UTF-8).
    mission_epoch : astropy.time.Time, optional
        The epoch that ``TIME_SYSTEM = MET`` or ``MRT`` counts from.
    cls : type, optional
        The class of the result (a subclass of :class:`TDM`; ``vv.read_tdm`` gives
        :class:`visviva.od.tracking_data.TDM`, which adds ``to_observations``).

    Returns
    -------
    TDM
        ``.header``, ``.segments`` (each with ``.metadata``, ``.keywords``, ``.epochs``,
        ``.values``, ``.times``); ``.to_observations(stations, sigma)`` for
        :func:`~visviva.fit_orbit`.

    Raises
    ------
    CCSDSFormatError
        Malformed input (a keyword that is no TDM keyword, a bad epoch or number, a block left
        open, a missing mandatory keyword, a second 60 that is no leap second); the message
        names the line.

    Examples
    --------
    >>> import visviva as vv
    >>> tdm = vv.read_tdm('''CCSDS_TDM_VERS = 2.0
    ... CREATION_DATE = 2024-01-01T00:00:00
    ... ORIGINATOR = EXAMPLE
    ... META_START
    ... TIME_SYSTEM = UTC
    ... PARTICIPANT_1 = STATION-A
    ... PARTICIPANT_2 = SAT
    ... MODE = SEQUENTIAL
    ... PATH = 1,2,1
    ... RANGE_UNITS = km
    ... META_STOP
    ... DATA_START
    ... RANGE = 2024-01-01T00:00:00 1234.5678
    ... RANGE = 2024-01-01T00:00:10 1230.0012
    ... DATA_STOP
    ... ''')
    >>> seg = tdm.segments[0]
    >>> seg.participants, seg.path, seg.values.tolist()
    ({1: 'STATION-A', 2: 'SAT'}, (1, 2, 1), [1234.5678, 1230.0012])
    """
    text, name = read_text(source)
    read = _read_xml if looks_like_xml(text) else _read_kvn
    tdm = read(text, name, mission_epoch)
    from .timeframes import refuse_unused_mission_epoch

    segs = tdm.segments
    refuse_unused_mission_epoch(mission_epoch, [seg.time_system for seg in segs], name,
                                segs[0].metadata.line_of("TIME_SYSTEM") if segs else None)
    _warn_duplicates(segs, name)
    return tdm if cls is None else cls(tdm.header, tdm.segments, tdm.fmt)


def _warn_duplicates(segs, name: str) -> None:
    """Warn (once per file) when two data lines give the same keyword at the same epoch (to
    1 ns) for the same metadata (participants, path, bands ...; START/STOP_TIME aside): a
    second RANGE 25 km from the first is two observations to a fit, one of them wrong."""
    if not any(len(seg) for seg in segs):
        return
    t0 = next(seg.times[0] for seg in segs if len(seg))
    seen, identical, conflicting = {}, [], []
    for n, seg in enumerate(segs):
        if not len(seg):
            continue
        meta = tuple(sorted((k, str(v)) for k, v in seg.metadata.values.items()
                            if k not in ("START_TIME", "STOP_TIME")))
        ns = np.round((seg.times - t0).to_value("s") * 1e9).astype(np.int64)
        for k, (key, t, value, line) in enumerate(zip(seg.keywords, ns.tolist(),
                                                      seg.values.tolist(), seg.lines,
                                                      strict=True)):
            first = seen.setdefault((meta, key, t), (value, line, (n, k)))
            if first[2] != (n, k):
                (identical if first[0] == value else conflicting).append(
                    (key, first[:2], value, line))
    if not identical and not conflicting:
        return
    parts = []
    for kind, found in (("conflicting", conflicting), ("identical", identical)):
        if found:
            key, (v1, l1), v2, l2 = found[0]
            parts.append(f"{len(found)} {kind} (first: {key} = {v1!r} at line {l1} and "
                         f"{key} = {v2!r} at line {l2}, same epoch and participants)")
    warnings.warn(
        f"{name}: {' and '.join(parts)} duplicate observation line(s); each line is kept and would count as its own observation in a fit: remove the wrong "
        "or repeated lines.", UserWarning, stacklevel=3)


def _check_metadata(meta: Record, name: str, units: dict) -> None:
    """Checks that need more than one keyword: the path, a participant it names, a unit
    written with a keyword in ``RANGE_UNITS`` (``units``: keyword -> unit as written)."""
    check_mandatory(meta, METADATA, name)
    range_units = meta.get("RANGE_UNITS", "km")
    for key, unit in units.items():
        if key in meta and unit != range_units:
            raise CCSDSFormatError(
                f"{key} is in RANGE_UNITS ({range_units}), not [{unit}]; convert the value",
                line=meta.line_of(key), source=name)
    present = {n for n in _PARTICIPANTS if f"PARTICIPANT_{n}" in meta}
    for key in ("PATH", "PATH_1", "PATH_2"):
        text = meta.get(key)
        if text is None:
            continue
        if not _PATH_RE.match(text):
            raise CCSDSFormatError(
                f"{key} = {text!r}: a path is participant numbers separated by commas, e.g. "
                "1,2,1 (two-way from participant 1) or 2,1 (one-way to participant 1)",
                line=meta.line_of(key), source=name)
        missing = sorted({int(p) for p in text.split(",")} - present)
        if missing:
            raise CCSDSFormatError(
                f"{key} = {text} names participant {missing[0]}, but PARTICIPANT_{missing[0]} "
                "is not given", line=meta.line_of(key), source=name)


def _data_line(key: str, text: str, line, name: str):
    """(epoch, value) of one data line ``KEY = epoch value``."""
    if key not in DATA_KEYWORDS:
        raise CCSDSFormatError(
            f"{key} is not a TDM data keyword (503.0-B-2, 3.5; check its spelling)",
            line=line, source=name)
    parts = text.split()
    if len(parts) != 2:
        raise CCSDSFormatError(
            f"a data line is '{key} = epoch value' (two items after '='); found {len(parts)}",
            line=line, source=name)
    epoch, value = parts
    if not _EPOCH_RE.match(epoch):
        raise CCSDSFormatError(f"{epoch!r} is not a CCSDS epoch like 2024-01-31T12:00:00.000",
                               line=line, source=name)
    return epoch, parse_float(value, key, line, name)


def _segment(meta, rows, data_comments, name, mission_epoch, units):
    """A segment from its metadata and (key, epoch text, value text or float, line) rows."""
    _check_metadata(meta, name, units)
    keywords, epochs, values, lines = (list(c) for c in zip(*rows, strict=True)) if rows else (
        [], [], [], [])
    seg = TDMSegment(meta, keywords, epochs, values, lines, data_comments, name, mission_epoch)
    seg.times  # noqa: B018 -- parse the epochs now, so a bad one is reported on reading
    _check_span(seg, name)
    return seg


def _check_span(seg: TDMSegment, name: str) -> None:
    """``START_TIME`` <= ``STOP_TIME``, and the data within them (when the metadata gives
    them: "the start/end of the total time span covered by the data", 503.0-B-2 table 3-3)."""
    from .timeframes import epochs_to_time

    meta = seg.metadata
    span = {}
    for key in ("START_TIME", "STOP_TIME"):
        if key in meta:
            span[key] = epochs_to_time(meta[key], seg.time_system, meta.line_of(key), name,
                                       seg._mission_epoch,
                                       system_line=meta.line_of("TIME_SYSTEM"))
    start, stop = span.get("START_TIME"), span.get("STOP_TIME")
    if start is not None and stop is not None and (stop - start).to_value("s") < 0:
        raise CCSDSFormatError(f"STOP_TIME = {meta['STOP_TIME']} is before START_TIME = "
                               f"{meta['START_TIME']}", line=meta.line_of("STOP_TIME"),
                               source=name)
    if not len(seg) or not span:
        return
    t = seg.times
    outside = np.zeros(len(seg), dtype=bool)
    if start is not None:
        outside |= (t - start).to_value("s") < -1e-6
    if stop is not None:
        outside |= (t - stop).to_value("s") > 1e-6
    if outside.any():
        k = int(np.flatnonzero(outside)[0])
        raise CCSDSFormatError(
            f"the epoch {seg.epochs[k]} lies outside START_TIME .. STOP_TIME "
            f"({meta.get('START_TIME', '...')} .. {meta.get('STOP_TIME', '...')}), the span the "
            "metadata says the data cover", line=seg.lines[k] if seg.lines else None, source=name)


def check_data(seg: TDMSegment) -> None:
    """Refuse data lines a reader would refuse (checked at once; for writers).

    Parameters
    ----------
    seg : TDMSegment
        The segment to write.

    Raises
    ------
    CCSDSFormatError
        An unknown data keyword, an epoch that is no CCSDS epoch, a NaN or infinite value, a
        ``STOP_TIME`` before ``START_TIME`` or data outside them.
    """
    unknown = set(seg.keywords) - set(DATA_KEYWORDS)
    if unknown:
        raise CCSDSFormatError(f"{sorted(unknown)[0]} is not a TDM data keyword")
    if seg.epochs and not _EPOCHS_RE.fullmatch("\n".join(seg.epochs)):
        bad = next(e for e in seg.epochs if not _EPOCH_RE.match(e))
        raise CCSDSFormatError(f"{bad!r} is not a CCSDS epoch like 2024-01-31T12:00:00.000")
    if not np.isfinite(seg.values).all():
        raise CCSDSFormatError("a TDM data value is NaN or infinite; remove that line")
    _check_span(seg, seg.source)


# ---- KVN ---------------------------------------------------------------------------------
def _read_kvn(text: str, name: str, mission_epoch) -> TDM:
    cursor = KVNCursor(text, name)
    header = read_kvn_header(cursor, HEADER, "TDM")
    segments = []
    while not cursor.at_end():
        if segments and all(line.kind == "comment" for line in cursor.lines[cursor.pos:]):
            # comments after the last DATA_STOP: kept with the last segment's data comments
            segments[-1].data_comments.extend(cursor.take_comments())
            break
        units = _take_range_units(cursor)
        block = read_kvn_metadata_block(
            cursor, METADATA, "TDM", not segments,
            "the segment's metadata is empty (TIME_SYSTEM, PARTICIPANT_1 ... are mandatory)",
            check=False)
        if block is None:
            break
        meta = block[0]
        between = cursor.take_comments()  # (before DATA_START: kept as data comments)
        cursor.expect_block("DATA", "start")
        data_comments, raw = between, []
        lines = cursor.lines
        while cursor.pos < len(lines) and lines[cursor.pos].kind in ("keyword", "comment"):
            line = lines[cursor.pos]
            cursor.pos += 1
            if line.kind == "comment":
                data_comments.append(line.value)
            else:
                raw.append(line)
        line = cursor.peek()
        rows = _data_rows(raw, name)
        if line is None or line.kind != "stop" or line.key != "DATA":
            got = "the end of the message" if line is None else f"'{line.value[:40]}'"
            raise cursor.error("expected a data line 'KEYWORD = epoch value' or DATA_STOP, "
                               f"found {got}")
        if not rows:
            raise cursor.error("the data block is empty: a TDM segment holds at least one "
                               "data line 'KEYWORD = epoch value'")
        cursor.next()
        segments.append(_segment(meta, rows, data_comments, name, mission_epoch, units))
    if not segments:
        raise cursor.error("the TDM has no segment (META_START ... META_STOP, DATA_START ... "
                           "DATA_STOP)")
    return TDM(header, segments, "kvn")


def _take_range_units(cursor) -> dict:
    """The units written with CORRECTION_RANGE and RANGE_MODULUS in the next metadata block
    (taken off their lines, which the grammar would refuse: their unit is RANGE_UNITS)."""
    units = {}
    lines = cursor.lines
    for k in range(cursor.pos, len(lines)):
        line = lines[k]
        if line.kind == "stop" and line.key == "META":
            break
        if line.kind == "keyword" and line.key in _IN_RANGE_UNITS and line.unit is not None:
            if line.unit not in ("km", "s", "RU"):
                raise CCSDSFormatError(f"{line.key} is in RANGE_UNITS (km, s or RU), not "
                                       f"[{line.unit}]", line=line.line, source=cursor.source)
            units[line.key] = line.unit
            lines[k] = KVNLine(line.kind, line.line, line.key, line.value, None)
    return units


def _data_rows(raw, name):
    """(keyword, epoch, value, line) of the data lines of a block: one split, one regex over
    the epochs, one numpy conversion; anything unusual falls back to the line-by-line checks,
    which name the line."""
    try:
        if any(r.unit is not None or r.key not in DATA_KEYWORDS for r in raw):
            raise ValueError
        parts = " ".join([r.value for r in raw]).split()
        if len(parts) != 2 * len(raw):
            raise ValueError
        epochs, texts = parts[0::2], parts[1::2]
        joined = "".join(texts)
        if "_" in joined or not joined.isascii() or not _EPOCHS_RE.fullmatch("\n".join(epochs)):
            raise ValueError
        values = np.array(texts, dtype=object).astype(np.float64)
        if not np.isfinite(values).all():
            raise ValueError
    except ValueError:
        return [_checked_row(r, name) for r in raw]
    return [(r.key, e, v, r.line) for r, e, v in zip(raw, epochs, values.tolist(), strict=True)]


def _checked_row(line, name):
    if line.unit is not None:  # 'KEY = epoch value [unit]'
        raise CCSDSFormatError(f"a TDM data line carries no unit; remove [{line.unit}]",
                               line=line.line, source=name)
    epoch, value = _data_line(line.key, line.value, line.line, name)
    return line.key, epoch, value, line.line


# ---- XML ---------------------------------------------------------------------------------
def _read_xml(text: str, name: str, mission_epoch) -> TDM:
    root = message_root(parse(text, name), "tdm", name, ("body", "segment"), ("observation",))
    version = root.attrib.get("version")
    if not version:
        raise CCSDSFormatError("<tdm> lacks its version attribute", line=root.line, source=name)
    headers = root.findall("header")
    if len(headers) != 1:
        raise CCSDSFormatError("a <tdm> holds one <header>", line=root.line, source=name)
    header = read_xml_section(with_version(headers[0], "CCSDS_TDM_VERS", root), HEADER, name)
    for child in root.children:
        if child.tag not in ("header", "body", "COMMENT"):
            raise CCSDSFormatError(f"<{child.tag}> does not belong in <tdm>", line=child.line,
                                   source=name)
    bodies = root.findall("body")
    if len(bodies) != 1:
        raise CCSDSFormatError("a <tdm> holds one <body>", line=root.line, source=name)
    segments = []
    for node in bodies[0].children:
        if node.tag != "segment":
            raise CCSDSFormatError(f"<{node.tag}> does not belong in <body>", line=node.line,
                                   source=name)
        metas, datas = node.findall("metadata"), node.findall("data")
        extra = [c for c in node.children if c.tag not in ("metadata", "data")]
        if extra or len(metas) != 1 or len(datas) != 1:
            where = (extra[0].line if extra else datas[1].line if len(datas) > 1
                     else metas[1].line if len(metas) > 1 else node.line)
            raise CCSDSFormatError("a <segment> holds one <metadata> and one <data>",
                                   line=where, source=name)
        units = {}
        for child in metas[0].children:
            if child.tag in _IN_RANGE_UNITS and child.attrib.get("units"):
                units[child.tag] = child.attrib["units"]
                child.attrib = {k: v for k, v in child.attrib.items() if k != "units"}
        meta = read_xml_section(metas[0], METADATA, name)
        comments, rows = [], []
        for obs in datas[0].children:
            if obs.tag == "COMMENT":
                comments.append(obs.text)
                continue
            if obs.tag != "observation":
                raise CCSDSFormatError(f"<{obs.tag}> does not belong in <data> (expected "
                                       "<observation>)", line=obs.line, source=name)
            # a comment inside an <observation> (not in the schema) joins the data comments
            comments.extend(c.text for c in obs.children if c.tag == "COMMENT")
            rows.append(_xml_observation(obs, name))
        if not rows:
            raise CCSDSFormatError("the <data> is empty: a TDM segment holds at least one "
                                   "<observation>", line=datas[0].line, source=name)
        segments.append(_segment(meta, rows, comments, name, mission_epoch, units))
    if not segments:
        raise CCSDSFormatError("the TDM has no <segment>", line=bodies[0].line, source=name)
    return TDM(header, segments, "xml")


def _xml_observation(obs, name):
    items = [c for c in obs.children if c.tag != "COMMENT"]
    if len(items) != 2 or items[0].tag != "EPOCH":
        raise CCSDSFormatError("an <observation> holds <EPOCH> and one measurement element",
                               line=obs.line, source=name)
    epoch, item = items
    if item.children:
        raise CCSDSFormatError(f"<{item.tag}> holds only its value", line=item.line,
                               source=name)
    text = f"{epoch.text.strip()} {item.text.strip()}"
    got, value = _data_line(item.tag, text, item.line, name)
    return item.tag, got, value, item.line
