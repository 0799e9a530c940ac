"""Read and write the OEM in KVN and XML (CCSDS 502.0-B-3, sections 5 and 7; 505.0-B NDM/XML)."""

from __future__ import annotations

import re

import numpy as np

from .._xmltree import cyclic_gc_paused
from ..errors import InvalidInputError
from .covariance import (
    COVARIANCE_KEYWORDS,
    check_record_variances,
    check_variance,
    matrix_from_rows,
    matrix_from_values,
    values_from_matrix,
    warn_not_positive_definite,
)
from .grammar import EPOCH_PATTERN, CCSDSFormatError, Record, Section, format_float, parse_float
from .grammar import Keyword as K
from .kvn import KVNCursor, KVNWriter
from .layout import (
    read_kvn_header,
    read_kvn_metadata_block,
    read_kvn_section,
    read_text,
    read_xml_section,
    with_version,
    write_kvn_section,
    write_xml_section,
    xml_child,
)
from .ndmxml import looks_like_xml, message_root, new_root, parse, to_text
from .oem import (
    COVARIANCE_META,
    HEADER,
    INTERPOLATION_METHODS,
    METADATA,
    Ephemeris,
    OEMCovariance,
    OEMSegment,
)

__all__ = ["read_oem", "write_oem"]

_EPOCH_RE = re.compile(f"^{EPOCH_PATTERN}$")
_EPOCHS_RE = re.compile(f"(?:{EPOCH_PATTERN}\n)*{EPOCH_PATTERN}")  # many epochs, one per line, in one scan
_STATE_KEYS = ("X", "Y", "Z", "X_DOT", "Y_DOT", "Z_DOT", "X_DDOT", "Y_DDOT", "Z_DDOT")
_STATE_UNITS = ("km",) * 3 + ("km/s",) * 3 + ("km/s**2",) * 3
STATE_VECTOR = Section("state_vector", (K("EPOCH", "epoch", None, True),) + tuple(
    K(k, "float", unit, i < 6) for i, (k, unit) in enumerate(zip(_STATE_KEYS, _STATE_UNITS, strict=True))),
    "stateVector")
COVARIANCE_XML = Section("covariance", COVARIANCE_META.keywords + COVARIANCE_KEYWORDS,
                         "covarianceMatrix")


def read_oem(source, *, mission_epoch=None) -> Ephemeris:
    """Read a CCSDS Orbit Ephemeris Message (KVN or XML, detected).

    Parameters
    ----------
    source : str, os.PathLike or bytes
        A path, the message text, or its bytes (UTF-8).
    mission_epoch : astropy.time.Time, optional
        The epoch that ``TIME_SYSTEM = MET`` (launch) or ``MRT`` (the mission's reference)
        counts from; such messages cannot be read without it, and it is refused for a message
        with no MET/MRT segment.

    Returns
    -------
    Ephemeris
        ``.segments`` each with ``.times``, ``.states``, ``.frame``, ``.center``,
        ``.covariances``, ``.interpolate(t)``; ``.interpolate(t)`` across segments.

    Raises
    ------
    CCSDSFormatError
        Malformed input; the message names the line and what is wrong.

    Examples
    --------
    >>> import visviva as vv
    >>> oem = vv.read_oem('''CCSDS_OEM_VERS = 3.0
    ... CREATION_DATE = 2024-01-01T00:00:00
    ... ORIGINATOR = EXAMPLE
    ... META_START
    ... OBJECT_NAME = SAT
    ... OBJECT_ID = 2024-001A
    ... CENTER_NAME = EARTH
    ... REF_FRAME = EME2000
    ... TIME_SYSTEM = UTC
    ... START_TIME = 2024-01-01T00:00:00
    ... STOP_TIME = 2024-01-01T00:02:00
    ... META_STOP
    ... 2024-01-01T00:00:00 7000 0 0 0 7.5 0
    ... 2024-01-01T00:01:00 6996.1 449.8 0 -0.52 7.49 0
    ... 2024-01-01T00:02:00 6984.6 898.9 0 -1.03 7.46 0
    ... ''')
    >>> seg = oem.segments[0]
    >>> seg.frame, seg.center, len(seg)
    ('EME2000', 'EARTH', 3)
    """
    from .timeframes import refuse_unused_mission_epoch

    text, name = read_text(source)
    if looks_like_xml(text):
        with cyclic_gc_paused():  # (the element tree is freed on return, before the collector)
            eph = _read_xml(text, name, mission_epoch)
    else:
        eph = _read_kvn(text, name, mission_epoch)
    segs = eph.segments
    refuse_unused_mission_epoch(mission_epoch, [seg.time_system for seg in segs], name,
                                segs[0].metadata.line_of("TIME_SYSTEM") if segs else None)
    return eph


# ---- KVN ---------------------------------------------------------------------------------
def _read_kvn(text: str, name: str, mission_epoch=None) -> Ephemeris:
    cursor = KVNCursor(text, name)
    header = read_kvn_header(cursor, HEADER, "OEM")
    segments, cov_lines = [], []
    while not cursor.at_end():
        block = read_kvn_metadata_block(
            cursor, METADATA, "OEM", not segments,
            "the segment's metadata is empty (OBJECT_NAME, OBJECT_ID, CENTER_NAME, REF_FRAME, "
            "TIME_SYSTEM, START_TIME, STOP_TIME)")
        if block is None:
            break
        meta, start = block
        data_comments = cursor.take_comments()
        rows, state_comments = cursor.data_lines_with_comments()
        if not rows:
            raise cursor.error("the segment has no state lines after META_STOP")
        epochs, numbers = _state_lines(rows, name)
        covariances = []
        if cursor.at_block("COVARIANCE"):
            covariances = _kvn_covariances(cursor, cov_lines)
            if not cursor.at_end() and all(line.kind == "comment"
                                           for line in cursor.lines[cursor.pos:]):
                # comments after the last block of the file: kept with the segment's last
                # state (they were dropped), and written back after it
                state_comments.setdefault(len(rows), []).extend(cursor.take_comments())
        seg = OEMSegment(meta, epochs, numbers[:, 0:3], numbers[:, 3:6],
                         numbers[:, 6:9] if numbers.shape[1] == 9 else None, covariances,
                         data_comments, state_comments, mission_epoch)
        _check_segment(seg, [r.line for r in rows], start.line, name)
        segments.append(seg)
    if not segments:
        raise cursor.error("the OEM has no segment (META_START ... META_STOP and state lines)")
    warn_not_positive_definite(
        zip([c.matrix for seg in segments for c in seg.covariances], cov_lines, strict=True),
        name)
    return Ephemeris(segments, header)


def _state_lines(rows, name):
    """Epochs and numbers of a segment's state lines: one split, one regex, one conversion.

    Anything unusual (a wrong count, a bad epoch or number) falls back to the line-by-line
    check, which names the line.
    """
    n = len(rows)
    width = len(rows[0].value.split())
    blob = " ".join([r.value for r in rows])
    fast = _table(blob.split(), n, width)
    if fast is not None:
        return fast
    return _state_lines_checked(rows, name)


def _table(parts: list, n: int, width: int):
    """(epochs, numbers) from n rows of ``width`` tokens, or None when anything is off."""
    if width not in (7, 10) or len(parts) != n * width:
        return None
    # float() would also take '1_000', '１２' and 'nan': the first two are refused here, the
    # third below (the grammar's checks then say which token is wrong, on which line)
    joined = "".join(parts)
    if "_" in joined or not joined.isascii():
        return None
    table = np.array(parts, dtype=object).reshape(n, width)
    epochs = table[:, 0].tolist()
    if not _EPOCHS_RE.fullmatch("\n".join(epochs)):
        return None
    try:
        numbers = table[:, 1:].astype(np.float64)
    except ValueError:
        return None
    return (epochs, numbers) if np.isfinite(numbers).all() else None


def _state_lines_checked(rows, name):
    tokens = [r.tokens for r in rows]
    width = len(tokens[0])
    for row, tok in zip(rows, tokens, strict=True):
        if len(tok) not in (7, 10) or len(tok) != width:
            raise CCSDSFormatError(
                f"a state line has an epoch and 6 numbers (x y z vx vy vz, km and km/s) or 9 "
                f"(with ax ay az, km/s**2), the same in the whole segment; this one has "
                f"{len(tok) - 1}", line=row.line, source=name)
        if not _EPOCH_RE.match(tok[0]):
            raise CCSDSFormatError(f"{tok[0]!r} is not a CCSDS epoch like "
                                   "2024-01-31T12:00:00.000", line=row.line, source=name)
    epochs = [tok[0] for tok in tokens]
    numbers = np.array([[parse_float(x, "a state value", row.line, name) for x in tok[1:]]
                        for row, tok in zip(rows, tokens, strict=True)])
    return epochs, numbers


def _kvn_covariances(cursor: KVNCursor, lines: list) -> list:
    """The segment's covariances; appends the line each starts on (its EPOCH) to ``lines``."""
    cursor.expect_block("COVARIANCE")
    out = []
    while not cursor.at_block("COVARIANCE", "stop"):
        if cursor.at_end():
            raise cursor.error("COVARIANCE_START has no matching COVARIANCE_STOP")
        meta = read_kvn_section(cursor, COVARIANCE_META)
        if meta is None:
            line = cursor.peek()
            what = line.key if line.kind == "keyword" else f"'{line.value[:40]}'"
            raise cursor.error(f"expected EPOCH = ... to start a covariance matrix, found {what}")
        lines.append(meta.line_of("EPOCH"))
        lower = []
        for i in range(6):
            line = cursor.peek()
            if line is None or line.kind != "data":
                raise cursor.error(f"a covariance matrix has 6 rows of 1..6 numbers; row {i + 1} "
                                   "is missing")
            cursor.pos += 1
            if len(line.tokens) != i + 1:
                raise cursor.error(
                    f"row {i + 1} of the covariance (lower triangle) holds {i + 1} "
                    f"number{'s' if i else ''}, but this line has {len(line.tokens)} "
                    f"({line.value[:60]!r}"
                    + ("; a covariance row has no units" if "[" in line.value else "") + ")",
                    line=line.line)
            lower += [parse_float(x, "a covariance value", line.line, cursor.source)
                      for x in line.tokens]
            check_variance(lower[-1], i, line.line, cursor.source)
        out.append(OEMCovariance(meta["EPOCH"], matrix_from_rows(lower),
                                 meta.get("COV_REF_FRAME"), meta.comments))
    cursor.expect_block("COVARIANCE", "stop")
    return out


def _check_segment(seg: OEMSegment, lines, meta_line, name):
    """Times increase and lie within START_TIME .. STOP_TIME; errors name the state line."""
    from .timeframes import epochs_to_time

    meta = seg.metadata
    # (errors and warnings name the state line of the epoch; an unsupported system, its line)
    t = seg._times = epochs_to_time(seg.epochs, seg.time_system, list(lines), name,
                                    seg.mission_epoch, system_line=meta.line_of("TIME_SYSTEM"))
    sec = (t - t[0]).to_value("s")
    steps = np.diff(sec)
    if (steps <= 0).any():
        k = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise CCSDSFormatError(f"the epochs must increase: {seg.epochs[k]} follows "
                               f"{seg.epochs[k - 1]}", line=lines[k], source=name)
    _check_accelerations(seg, sec, lines, name)
    problem = seg.span_problem(name)
    if problem is not None:
        where, message = problem
        line = meta.line_of(where) if isinstance(where, str) else lines[where]
        raise CCSDSFormatError(message, line=line, source=name)
    method = meta.get("INTERPOLATION")
    if method is not None and method.upper() not in INTERPOLATION_METHODS:
        raise CCSDSFormatError(f"INTERPOLATION = {method}: visviva reads LAGRANGE, HERMITE or "
                               "LINEAR", line=meta.line_of("INTERPOLATION"), source=name)
    degree = meta.get("INTERPOLATION_DEGREE")
    if degree is not None and degree < 1:
        raise CCSDSFormatError(f"INTERPOLATION_DEGREE = {degree}: the degree of an interpolating "
                               "polynomial is at least 1", line=meta.line_of("INTERPOLATION_DEGREE"),
                               source=name)


def _check_accelerations(seg: OEMSegment, sec, lines, name):
    """Warn when a segment's accelerations do not give the change of its velocities: over each
    step the mean of the two accelerations (trapezoid; its error is ~ (n dt)^2 / 12 of an orbit
    of mean motion n) against (v[k+1] - v[k]) / dt, off by more than half of it in the median
    step. Zeros written for want of accelerations, m/s**2 for km/s**2, or the wrong sign, which
    HERMITE uses for the velocities (zeros: 5.5 m/s off in LEO, 60 s steps)."""
    a = seg.a_km_s2
    if a is None or len(sec) < 2:
        return
    mean = np.diff(seg.v_km_s, axis=0) / np.diff(sec)[:, None]
    scale = np.linalg.norm(mean, axis=1)
    off = float(np.median(np.linalg.norm(0.5 * (a[1:] + a[:-1]) - mean, axis=1)
                          / np.where(scale > 0, scale, np.inf)))
    if off > 0.5:
        import warnings

        warnings.warn(
            f"{name}, line {lines[0]}: the accelerations of this segment do not give the change "
            f"of its velocities (off by {off:.0%} of it between states, in the median step): "
            "zeros in place of accelerations, another unit than km/s**2, or the wrong sign? "
            "INTERPOLATION = HERMITE interpolates the velocities with them; set "
            "seg.a_km_s2 = None to interpolate from the positions and velocities alone.",
            UserWarning, stacklevel=5)


# ---- XML ---------------------------------------------------------------------------------
def _read_xml(text: str, name: str, mission_epoch=None) -> Ephemeris:
    root = message_root(parse(text, name), "oem", name, ("body", "segment"),
                        ("stateVector", "covarianceMatrix"))
    header_node = root.find("header")
    if header_node is None or not root.attrib.get("version"):
        raise CCSDSFormatError("<oem> needs a version attribute and a <header>",
                               line=root.line, source=name)
    header = read_xml_section(with_version(header_node, "CCSDS_OEM_VERS", root), HEADER, name)
    segments, cov_lines = [], []
    for node in root.path("body/segment"):
        meta_node, data_node = node.find("metadata"), node.find("data")
        if meta_node is None or data_node is None:
            raise CCSDSFormatError("a <segment> needs <metadata> and <data>", line=node.line,
                                   source=name)
        meta = read_xml_section(meta_node, METADATA, name)
        comments, state_nodes, covariances, among = [], [], [], {}
        for child in data_node.children:
            if child.tag == "COMMENT" and (state_nodes or covariances):
                among.setdefault(len(state_nodes), []).append(child.text)
            elif child.tag == "COMMENT":
                comments.append(child.text)
            elif child.tag == "stateVector":
                inner = [c.text for c in child.children if c.tag == "COMMENT"]
                if inner:  # (not in the schema; kept where the same comment before it goes)
                    if state_nodes or covariances:
                        among.setdefault(len(state_nodes), []).extend(inner)
                    else:
                        comments.extend(inner)
                    child.children = [c for c in child.children if c.tag != "COMMENT"]
                state_nodes.append(child)
            elif child.tag == "covarianceMatrix":
                rec = read_xml_section(child, COVARIANCE_XML, name)
                check_record_variances(rec, name)
                cov_lines.append(child.line)
                covariances.append(OEMCovariance(rec["EPOCH"], matrix_from_values(rec.values),
                                                 rec.get("COV_REF_FRAME"), rec.comments))
            else:
                raise CCSDSFormatError(f"<{child.tag}> does not belong in an OEM <data>",
                                       line=child.line, source=name)
        if not state_nodes:
            raise CCSDSFormatError("the segment's <data> has no <stateVector>",
                                   line=data_node.line, source=name)
        epochs, numbers = _xml_states(state_nodes, name)
        acc = numbers.shape[1] == 9
        seg = OEMSegment(meta, epochs, numbers[:, 0:3], numbers[:, 3:6],
                         numbers[:, 6:9] if acc else None, covariances, comments, among,
                         mission_epoch)
        _check_segment(seg, [_epoch_line(n) for n in state_nodes], meta_node.line,
                       name)  # fmt: skip
        segments.append(seg)
    if not segments:
        raise CCSDSFormatError("the OEM has no <segment>", line=root.line, source=name)
    warn_not_positive_definite(
        zip([c.matrix for seg in segments for c in seg.covariances], cov_lines, strict=True),
        name)
    return Ephemeris(segments, header)


def _xml_states(nodes, name):
    """Epochs and numbers of the ``<stateVector>`` elements of a segment.

    The fast path takes the elements in the schema's order with the schema's units (or none);
    anything else goes through the grammar element by element, which names the line.
    """
    width = len(nodes[0].children)
    keys = ("EPOCH",) + _STATE_KEYS[:width - 1]
    units = (None,) + _STATE_UNITS[:width - 1]
    texts = []
    fast = width in (7, 10)
    if fast:
        for node in nodes:
            children = node.children
            if len(children) != width:
                fast = False
                break
            for child, key, unit in zip(children, keys, units, strict=True):
                if (child.tag != key or child.attrib.get("units", unit) != unit
                        or child.children):
                    fast = False
                    break
                texts.append(child.text)
            if not fast:
                break
    if fast:
        table = _table(texts, len(nodes), width)
        if table is not None:
            return table
    rows, lines = [], []
    for node in nodes:
        rec = read_xml_section(node, STATE_VECTOR, name)
        rows.append([rec["EPOCH"]] + [rec.get(k) for k in _STATE_KEYS])
        lines.append(node.line)
    for row, line in zip(rows, lines, strict=True):  # (X .. Z_DOT are mandatory keywords)
        missing = [k for k, v in zip(_STATE_KEYS[6:], row[7:], strict=True) if v is None]
        if 0 < len(missing) < 3:
            raise CCSDSFormatError(f"the <stateVector> has accelerations but lacks "
                                   f"<{'>, <'.join(missing)}>: give all three or none",
                                   line=line, source=name)
    has_acc = [r[7] is not None for r in rows]
    if any(has_acc) and not all(has_acc):
        k = has_acc.index(not has_acc[0])
        raise CCSDSFormatError("either every <stateVector> of a segment has accelerations "
                               "or none", line=lines[k], source=name)
    numbers = np.array([r[1:] if has_acc[0] else r[1:7] for r in rows], dtype=np.float64)
    return [r[0] for r in rows], numbers


# ---- writing -----------------------------------------------------------------------------
def write_oem(ephemeris, path=None, format: str | None = None) -> str:  # noqa: A002
    """Write an OEM (KVN or XML) with every field of the ephemeris.

    Parameters
    ----------
    ephemeris : Ephemeris or OEMSegment
        What to write (a segment alone is written as a one-segment OEM).
    path : str or os.PathLike, optional
        File to write; nothing is written when None (the text is returned either way).
    format : {"kvn", "xml"}, optional
        Default: ``"xml"`` for a path ending in ``.xml``, else ``"kvn"``.

    Returns
    -------
    str
        The message text.

    Notes
    -----
    Floats are written with the shortest text that reads back to the same float64, so
    ``read_oem(write_oem(e))`` reproduces every number bit for bit. The writer adds no keyword
    the ephemeris lacks, except ``CREATION_DATE`` for an ephemeris built in code.
    """
    import os

    if isinstance(ephemeris, OEMSegment):
        ephemeris = Ephemeris([ephemeris])
    if not isinstance(ephemeris, Ephemeris):
        raise InvalidInputError(
            f"write_oem needs an Ephemeris or an OEMSegment, got {type(ephemeris).__name__}: "
            "build one from computed states with visviva.ccsds.oem.OEMSegment.from_states("
            "times, r_km, v_km_s, object_name=...) (a CowellResult gives .times, .r, .v).")
    if format is None:
        format = "xml" if path is not None and os.fspath(path).lower().endswith(".xml") else "kvn"
    if format not in ("kvn", "xml"):
        raise CCSDSFormatError(f"format must be 'kvn' or 'xml', not {format!r}")
    for k, seg in enumerate(ephemeris.segments):
        seg.check(f"segment {k + 1}")
    header = ephemeris.header
    if "CREATION_DATE" not in header:  # the one keyword a writer may add (on a copy)
        from astropy.time import Time

        header = Record({**header.values, "CREATION_DATE": Time.now().utc.isot},
                        header.comments, header.lines, header.line,
                        header.units, header.attributes)
        ephemeris = Ephemeris(ephemeris.segments, header)
    missing = [k for k in ("CCSDS_OEM_VERS", "ORIGINATOR") if k not in header]
    if missing:
        raise CCSDSFormatError(f"the ephemeris header lacks {', '.join(missing)}")
    text = _write_kvn(ephemeris) if format == "kvn" else _write_xml(ephemeris)
    if path is not None:
        from .._text import replace_text_file

        replace_text_file(path, text)  # whole or not at all: a failed write keeps the old file
    return text


def _rows(seg: OEMSegment) -> np.ndarray:
    parts = [seg.r_km, seg.v_km_s] + ([seg.a_km_s2] if seg.a_km_s2 is not None else [])
    return np.hstack(parts)


def _write_kvn(eph: Ephemeris) -> str:
    w = KVNWriter()
    write_kvn_section(w, HEADER, eph.header)
    for seg in eph.segments:
        w.blank()
        w.marker("META_START")
        write_kvn_section(w, METADATA, seg.metadata)
        w.marker("META_STOP")
        w.blank()
        w.comment(seg.data_comments)
        fmt = format_float
        among = seg.state_comments
        for k, (epoch, row) in enumerate(zip(seg.epochs, _rows(seg).tolist(), strict=True)):
            if k in among:
                w.comment(among[k])
            w.data(epoch + " " + " ".join(map(fmt, row)))
        w.comment(among.get(len(seg), []))
        if seg.covariances:
            w.blank()
            w.marker("COVARIANCE_START")
            for cov in seg.covariances:
                w.comment(cov.comments)
                w.keyword("EPOCH", cov.epoch)
                if cov.frame is not None:
                    w.keyword("COV_REF_FRAME", cov.frame)
                m = np.asarray(cov.matrix, dtype=np.float64)
                for i in range(6):
                    w.data(" ".join(fmt(m[i, j]) for j in range(i + 1)))
            w.marker("COVARIANCE_STOP")
    return w.text()


def _write_xml(eph: Ephemeris) -> str:
    """NDM/XML: header and metadata through ElementTree, the (long) data blocks as text."""
    import xml.etree.ElementTree as ET

    header = eph.header
    root = new_root("oem", "CCSDS_OEM_VERS", header.values["CCSDS_OEM_VERS"])
    write_xml_section(root, HEADER, header, skip=("CCSDS_OEM_VERS",))
    body = xml_child(root, "body")
    blocks = []
    for k, seg in enumerate(eph.segments):
        segment = ET.SubElement(body, "segment")
        write_xml_section(segment, METADATA, seg.metadata)
        ET.SubElement(segment, "data").text = f"@@DATA{k}@@"
        blocks.append(_xml_data_block(seg))
    text = to_text(root)
    for k, block in enumerate(blocks):
        text = text.replace(f"<data>@@DATA{k}@@</data>", f"<data>\n{block}\n      </data>", 1)
    return text


def _xml_element(tag: str, text: str, units: str | None, indent: str) -> str:
    from xml.sax.saxutils import escape

    attr = f' units="{units}"' if units else ""
    return f"{indent}<{tag}{attr}>{escape(str(text))}</{tag}>"


def _xml_data_block(seg: OEMSegment) -> str:
    pad, pad2 = " " * 8, " " * 10
    lines = [_xml_element("COMMENT", c, None, pad) for c in seg.data_comments]
    width = 9 if seg.a_km_s2 is not None else 6
    template = "\n".join(
        [f"{pad}<stateVector>", f"{pad2}<EPOCH>{{}}</EPOCH>"]
        + [f'{pad2}<{k} units="{unit}">{{}}</{k}>'
           for k, unit in zip(_STATE_KEYS[:width], _STATE_UNITS[:width], strict=True)]
        + [f"{pad}</stateVector>"])
    fmt = format_float
    among = seg.state_comments
    for k, (epoch, row) in enumerate(zip(seg.epochs, _rows(seg).tolist(), strict=True)):
        lines += [_xml_element("COMMENT", c, None, pad) for c in among.get(k, ())]
        lines.append(template.format(epoch, *map(fmt, row)))
    lines += [_xml_element("COMMENT", c, None, pad) for c in among.get(len(seg), ())]
    for cov in seg.covariances:
        lines.append(f"{pad}<covarianceMatrix>")
        lines += [_xml_element("COMMENT", c, None, pad2) for c in cov.comments]
        lines.append(_xml_element("EPOCH", cov.epoch, None, pad2))
        if cov.frame is not None:
            lines.append(_xml_element("COV_REF_FRAME", cov.frame, None, pad2))
        for key, value in values_from_matrix(cov.matrix).items():
            unit = next(k.unit for k in COVARIANCE_KEYWORDS if k.name == key)
            lines.append(_xml_element(key, fmt(value), unit, pad2))
        lines.append(f"{pad}</covarianceMatrix>")
    return "\n".join(lines)


def _epoch_line(node):
    """Line of a ``<stateVector>``'s ``<EPOCH>`` (of the element itself when it has none)."""
    epoch = node.find("EPOCH")
    return node.line if epoch is None else epoch.line
