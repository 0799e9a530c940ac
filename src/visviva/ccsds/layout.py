"""Read and write the sections of a message, in KVN or XML, from its declarative description.

A message reader describes its sections (:class:`~visviva.ccsds.grammar.Section`) and calls
:func:`read_message` (flat messages such as the OPM and OMM, whose KVN is one run of keywords) or
the per-section functions (messages with blocks, such as the OEM's segments). Writers call
:func:`write_kvn_section` / :func:`write_xml_section` with the same sections, so the keyword
order, units and XML element names come from one table.
"""

from __future__ import annotations

from .._text import file_bytes, utf8_text
from .grammar import CCSDSFormatError, Record, Section, format_value, parse_value
from .kvn import KVNCursor, KVNWriter
from .ndmxml import XMLNode, add_text, looks_like_xml, message_root, new_root, parse, to_text

__all__ = [
    "read_kvn_section", "read_xml_section", "check_mandatory", "read_message",
    "write_kvn_section", "write_xml_section", "write_message", "xml_child", "read_text",
    "with_version", "read_kvn_header", "read_kvn_metadata_block", "article_of",
    "check_xml_elements", "message_element",
]


def read_text(source) -> tuple[str, str]:
    """The text of a message given as a path, a ``pathlib.Path``, the text itself or its bytes.

    Parameters
    ----------
    source : str, os.PathLike or bytes
        A file name, the message text (anything containing a newline or ``=``, starting
        with ``<``, or empty), or the bytes of a message (UTF-8, as a file holds them).

    Returns
    -------
    text : str
    name : str
        The file name, or ``"<text>"``.
    """
    import os

    if isinstance(source, (bytes, bytearray, memoryview)):
        return _decode(bytes(source), "<text>"), "<text>"
    if isinstance(source, os.PathLike) or (isinstance(source, str) and _is_path(source)):
        path = os.fspath(source)
        # (one owner for opening a user's file: a missing one raises MissingFileError, also a
        # FileNotFoundError, as the catalogue readers do)
        data = file_bytes(path, "a CCSDS message", "check the name, or pass the message text "
                          "itself (a string with its newlines, or bytes).",
                          lambda message: CCSDSFormatError(message.removeprefix(repr(path) + " "),
                                                           source=repr(path)))
        return _decode(data, path), path
    if not isinstance(source, str):
        raise CCSDSFormatError(f"expected a path or the message text, got {type(source).__name__}")
    return source.removeprefix("\ufeff"), "<text>"


def _is_path(text: str) -> bool:
    """Whether a string is a file name rather than a message: one line, not XML, and no
    ``KEYWORD =`` line, unless it names a file that exists (``data/run=1/iss.oem``) or holds a
    folder separator before any ``=``."""
    import os
    import re

    if not text.strip() or "\n" in text or "\r" in text or text.lstrip().startswith("<"):
        return False
    if "=" not in text or os.path.exists(text):
        return True
    return (re.match(r"\s*[A-Z][A-Z0-9_]*\s*=", text) is None
            and any(sep in text.partition("=")[0] for sep in "/\\"))


def _decode(data: bytes, name: str) -> str:
    """The UTF-8 text of a file's bytes, or an error naming the line of the first bad byte."""
    return utf8_text(data, lambda line, byte: CCSDSFormatError(
        f"byte 0x{byte:02x} is not UTF-8 text (CCSDS messages are ASCII): remove the character "
        "or save the file as UTF-8", line=line, source=name))


def check_mandatory(record: Record, section: Section, source: str) -> None:
    """Raise if a mandatory keyword of ``section`` is missing from ``record``.

    Parameters
    ----------
    record : Record
        The section as read.
    section : Section
        Its description.
    source : str
        File name, for the error message.
    """
    missing = [k.name for k in section.keywords if k.mandatory and k.name not in record.values]
    if missing:
        raise CCSDSFormatError(
            f"the {section.name.replace('_', ' ')} section lacks the mandatory keyword"
            f"{'s' if len(missing) > 1 else ''} {', '.join(missing)}",
            line=record.line, source=source)


def read_kvn_section(cursor: KVNCursor, section: Section, check: bool = True) -> Record | None:
    """Read the keywords of one section at the cursor (with the comments before them).

    Reading stops at the first line that is not a keyword of the section, or, for a repeated
    section, where its first keyword comes again. A keyword given twice is an error.

    Parameters
    ----------
    cursor : KVNCursor
        Positioned at the section's first line (comments included).
    section : Section
        What to read.
    check : bool
        Check the mandatory keywords (else the caller calls :func:`check_mandatory`).

    Returns
    -------
    Record or None
        None when the section is absent (the cursor is then left where it was).
    """
    start = cursor.pos
    record = Record()
    first = section.keywords[0].name if section.keywords else None
    while True:
        line = _next_keyword(cursor, section, record)
        if line is None:
            break
        if section.user_defined:
            key = line.key[len("USER_DEFINED_"):]
            value = line.value
            if key in record.values:
                raise cursor.error(f"{line.key} is given twice (first on line "
                                   f"{record.lines[key]})")
            if line.unit:  # (no table gives its unit: kept as written)
                record.units[key] = line.unit
        else:
            key = line.key
            if key in record.values:
                if section.repeat and key == first:
                    break
                raise cursor.error(f"{key} is given twice in the {section.name.replace('_', ' ')} "
                                   f"section (first on line {record.lines[key]})")
            value = parse_value(section.by_name[key], line.value, line.unit, line.line,
                                cursor.source)
        if record.line is None:
            record.line = line.line
        record.values[key] = value
        record.lines[key] = line.line
        cursor.pos += 1
    if not record.values:
        cursor.pos = start
        return None
    if check:
        check_mandatory(record, section, cursor.source)
    return record


def read_kvn_header(cursor: KVNCursor, header: Section, kind: str) -> Record:
    """Read the header of a KVN message with segments (OEM, TDM), which starts with its
    version keyword (the first keyword of ``header``).

    Parameters
    ----------
    cursor : KVNCursor
        At the start of the message.
    header : Section
        The header's description; its first keyword is ``CCSDS_<KIND>_VERS``.
    kind : str
        ``"OEM"``, ``"TDM"``, for the error messages.

    Returns
    -------
    Record
    """
    version_key = header.keywords[0].name
    first = cursor.peek()
    if first is None:
        raise CCSDSFormatError("the message is empty", source=cursor.source)
    if first.kind != "keyword" or first.key != version_key:
        raise cursor.error(f"{article_of(kind)} {kind} starts with {version_key} = <version>")
    return read_kvn_section(cursor, header)


def read_kvn_metadata_block(cursor: KVNCursor, metadata: Section, kind: str, first: bool,
                            empty: str, check: bool = True):  # fmt: skip
    """Read ``META_START``, a segment's metadata keywords and ``META_STOP`` (with the comments
    before the block, which join the record's), or return None at the end of the message.

    Parameters
    ----------
    cursor : KVNCursor
        Where the next segment may start.
    metadata : Section
        The metadata's description.
    kind : str
        ``"OEM"``, ``"TDM"``, for the error messages.
    first : bool
        Whether no segment was read yet (a stray keyword is then no header keyword).
    empty : str
        The error message for a block without keywords (naming the mandatory ones).
    check : bool
        Check the mandatory keywords before ``META_STOP``.

    Returns
    -------
    (Record, KVNLine) or None
        The metadata and the ``META_START`` line.
    """
    comments = cursor.take_comments()
    if cursor.at_end():
        return None
    if not cursor.at_block("META"):
        line = cursor.peek()
        what = line.key if line.kind == "keyword" else f"'{line.value[:40]}'"
        raise cursor.error(f"expected META_START (a new segment), found {what}"
                           + (f": not {article_of(kind)} {kind} header keyword" if first else ""))
    start = cursor.next()
    meta = read_kvn_section(cursor, metadata, check=False)
    if meta is None:
        raise cursor.error(empty)
    meta.comments = comments + meta.comments
    line = cursor.peek()
    if line is not None and line.kind == "keyword":
        raise cursor.error(f"{line.key} is not {article_of(kind)} {kind} metadata keyword (or "
                           "is given twice)")
    if check:
        check_mandatory(meta, metadata, cursor.source)
    cursor.expect_block("META", "stop")
    return meta, start


def article_of(kind: str) -> str:
    """``"an"`` before OEM, OPM, OMM; ``"a"`` before TDM, CDM."""
    return "an" if kind[:1] in "AEIOU" else "a"


def _next_keyword(cursor: KVNCursor, section: Section, record: Record):
    """The next keyword line of the section, taking the comments before it into the record.

    Comments followed by a line of another section are left for that section.
    """
    ahead = cursor.pos
    while ahead < len(cursor.lines) and cursor.lines[ahead].kind == "comment":
        ahead += 1
    if ahead >= len(cursor.lines):
        return None
    line = cursor.lines[ahead]
    if line.kind != "keyword" or not section.owns(line.key):
        return None
    if (section.repeat and line.key in record.values
            and line.key == section.keywords[0].name):
        return None
    record.comments.extend(c.value for c in cursor.lines[cursor.pos:ahead])
    cursor.pos = ahead
    return line


def read_xml_section(node: XMLNode, section: Section, source: str) -> Record:
    """Read the keyword elements of one XML section element.

    Parameters
    ----------
    node : XMLNode
        The section's element (``<stateVector>``).
    section : Section
        What it holds.
    source : str
        File name, for error messages.

    Returns
    -------
    Record
    """
    record = Record(line=node.line)
    for child in node.children:
        if child.children:  # (expat would join the text around them into one value)
            raise CCSDSFormatError(f"<{child.tag}> holds the element <{child.children[0].tag}>; "
                                   "a keyword element holds only its value",
                                   line=child.children[0].line, source=source)
        if child.tag == "COMMENT":
            record.comments.append(child.text)
            continue
        if section.user_defined and child.tag == "USER_DEFINED":
            key = child.attrib.get("parameter")
            if not key:
                raise CCSDSFormatError("<USER_DEFINED> needs a 'parameter' attribute",
                                       line=child.line, source=source)
            if key in record.values:
                raise CCSDSFormatError(f"<USER_DEFINED parameter=\"{key}\"> is given twice",
                                       line=child.line, source=source)
            record.values[key] = child.text
            record.lines[key] = child.line
            if child.attrib.get("units"):
                record.units[key] = child.attrib["units"]
            _keep_attributes(record, key, child, ("parameter", "units"))
            continue
        keyword = section.by_name.get(child.tag)
        if keyword is None:
            raise CCSDSFormatError(f"<{child.tag}> does not belong in <{node.tag}>",
                                   line=child.line, source=source)
        if child.tag in record.values:
            raise CCSDSFormatError(f"<{child.tag}> is given twice in <{node.tag}>",
                                   line=child.line, source=source)
        if child.text == "":
            raise CCSDSFormatError(f"<{child.tag}> is empty", line=child.line, source=source)
        record.values[child.tag] = parse_value(keyword, child.text, child.attrib.get("units"),
                                               child.line, source)
        record.lines[child.tag] = child.line
        _keep_attributes(record, child.tag, child, ("units",))
    check_mandatory(record, section, source)
    return record


def _keep_attributes(record: Record, key: str, child: XMLNode, schema: tuple) -> None:
    """Keep the attributes of a keyword element that the schema does not define (warned about
    by :func:`visviva.ccsds.ndmxml.check_attributes`), to write them back on the same element."""
    extra = {k: v for k, v in child.attrib.items() if k not in schema}
    if extra:
        record.attributes[key] = extra


def _warn_attributes_dropped(record: Record) -> None:
    """A KVN write of a record holding XML attributes: KVN has no place for them."""
    import warnings

    shown = "; ".join(f"{k}: " + ", ".join(f'{n}="{v}"' for n, v in a.items())
                      for k, a in record.attributes.items())
    warnings.warn(f"KVN has no place for XML attributes; writing as KVN leaves out {shown} "
                  "(an XML write keeps them)", UserWarning, stacklevel=4)


def _as_record(record) -> Record:
    return record if isinstance(record, Record) else Record(values=dict(record))


def write_kvn_section(writer: KVNWriter, section: Section, record) -> None:
    """Write one section as KVN, keywords in the order of the section's table.

    Parameters
    ----------
    writer : KVNWriter
        Where to write.
    section : Section
        The description.
    record : Record or dict
        The values (a dict is taken as keyword -> value without comments).
    """
    record = _as_record(record)
    if record.attributes:
        _warn_attributes_dropped(record)
    keywords = section.keywords
    if keywords and keywords[0].name.endswith("_VERS") and keywords[0].name in record.values:
        # a header: the version line comes first, its comments after it (502.0-B-3, 7.8.5)
        writer.keyword(keywords[0].name, str(record.values[keywords[0].name]))
        keywords = keywords[1:]
    writer.comment(record.comments)
    if section.user_defined:
        for key, value in record.values.items():
            writer.keyword(f"USER_DEFINED_{key}", str(value), record.units.get(key))
        return
    for keyword in keywords:
        if keyword.name in record.values:
            writer.keyword(keyword.name, format_value(keyword, record.values[keyword.name]),
                           keyword.unit)


def xml_child(parent, tag: str):
    """The first child element of ``parent`` with this tag, created when absent.

    Parameters
    ----------
    parent : xml.etree.ElementTree.Element
        The parent element.
    tag : str
        The child's tag.

    Returns
    -------
    xml.etree.ElementTree.Element
    """
    import xml.etree.ElementTree as ET

    found = parent.find(tag)
    return found if found is not None else ET.SubElement(parent, tag)


def write_xml_section(parent, section: Section, record, skip=()):
    """Append one section as an XML element (its tag is the last part of ``xml_path``).

    Parameters
    ----------
    parent : xml.etree.ElementTree.Element
        The element that holds the section.
    section : Section
        The description.
    record : Record or dict
        The values.
    skip : iterable of str
        Keywords not to write (the version keyword, which XML puts on the root).

    Returns
    -------
    xml.etree.ElementTree.Element
    """
    import xml.etree.ElementTree as ET

    record = _as_record(record)
    element = ET.SubElement(parent, section.xml_path.rsplit("/", 1)[-1])
    for text in record.comments:
        add_text(element, "COMMENT", text)
    if section.user_defined:
        for key, value in record.values.items():
            unit = record.units.get(key)
            ET.SubElement(element, "USER_DEFINED",
                          {"parameter": key, **({"units": unit} if unit else {}),
                           **record.attributes.get(key, {})}).text = str(value)
        return element
    for keyword in section.keywords:
        if keyword.name in record.values and keyword.name not in skip:
            child = add_text(element, keyword.name,
                             format_value(keyword, record.values[keyword.name]), keyword.unit)
            child.attrib.update(record.attributes.get(keyword.name, {}))
    return element


def read_message(source, sections: tuple, root_tag: str, version_key: str):
    """Read a flat message (OPM, OMM): every section, KVN or XML (detected).

    Parameters
    ----------
    source : str or os.PathLike
        A path or the message text.
    sections : tuple of Section
        The message's sections in KVN order; the first is the header and holds ``version_key``.
    root_tag : str
        The XML root element (``"opm"``).
    version_key : str
        ``"CCSDS_OPM_VERS"``; XML gives it as the root's ``version`` attribute.

    Returns
    -------
    parsed : dict
        Section name -> Record (a list of Records for repeated sections; absent optional
        sections are missing).
    fmt : str
        ``"kvn"`` or ``"xml"``.
    name : str
        The file name or ``"<text>"``.
    """
    text, name = read_text(source)
    if looks_like_xml(text):
        inner = {t for sec in sections for t in sec.xml_path.split("/")[:-1]}
        root = message_root(parse(text, name), root_tag, name,
                            inner - {sec.xml_path.rsplit("/", 1)[-1] for sec in sections})
        check_xml_elements(root, sections, name)
        parsed = {}
        for section in sections:
            nodes = root.path(section.xml_path)
            if section is sections[0] and nodes:
                version = root.attrib.get("version")
                if not version:
                    raise CCSDSFormatError(f"<{root_tag}> lacks its version attribute",
                                           line=root.line, source=name)
                header = read_xml_section(
                    with_version(nodes[0], version_key, root), section, name)
                parsed[section.name] = header
                continue
            if not nodes:
                if not section.optional:
                    raise CCSDSFormatError(f"the <{section.xml_path}> element is missing",
                                           line=root.line, source=name)
                continue
            if len(nodes) > 1 and not section.repeat:
                raise CCSDSFormatError(f"<{section.xml_path}> is given twice",
                                       line=nodes[1].line, source=name)
            records = [read_xml_section(n, section, name) for n in nodes]
            parsed[section.name] = records if section.repeat else records[0]
        return parsed, "xml", name
    cursor = KVNCursor(text, name)
    if cursor.at_end():
        raise CCSDSFormatError("the message is empty", source=name)
    first = cursor.peek()
    if first.kind != "keyword" or first.key != version_key:
        raise cursor.error(f"a {root_tag.upper()} starts with {version_key} = <version>")
    parsed = {}
    for section in sections:
        records = []
        while (record := read_kvn_section(cursor, section)) is not None:
            records.append(record)
            if not section.repeat:
                break
        if records:
            parsed[section.name] = records if section.repeat else records[0]
        elif not section.optional:
            _unexpected(cursor, sections, root_tag)
            nxt = _after_comments(cursor)
            raise cursor.error(f"the {section.name.replace('_', ' ')} section is missing "
                               f"(expected {section.keywords[0].name} or another of its "
                               f"keywords, found {_describe(nxt)})",
                               line=None if nxt is None else nxt.line)
    if not cursor.at_end():
        nxt = _after_comments(cursor)
        if nxt is None:  # COMMENT lines after the last section: no section to keep them
            raise cursor.error("COMMENT lines after the last keyword belong to no section (a "
                               "comment comes before what it describes): move them or remove "
                               "them")
        if nxt.kind == "keyword" and nxt.key == version_key:  # messages one after another
            hint = (" (for many OMMs, as in Space-Track's KVN GP data, use vv.read_omm_file)"
                    if root_tag == "omm" else "")
            raise cursor.error(f"a second {root_tag.upper()} starts here; this reader takes "
                               f"one message{hint}", line=nxt.line)
        _unexpected(cursor, sections, root_tag)
        raise cursor.error(f"unexpected {_describe(nxt)} here: out of order (the "
                           "sections go header, metadata, data in the CCSDS order)",
                           line=nxt.line)
    return parsed, "kvn", name


def _after_comments(cursor: KVNCursor):
    """The first line at or after the cursor that is not a COMMENT (None at the end)."""
    ahead = cursor.pos
    while ahead < len(cursor.lines) and cursor.lines[ahead].kind == "comment":
        ahead += 1
    return cursor.lines[ahead] if ahead < len(cursor.lines) else None


def check_xml_elements(root: XMLNode, sections: tuple, source: str) -> None:
    """Raise on an element that no section of the message expects (naming its line)."""
    expected: dict[str, set] = {}
    for section in sections:
        parts = section.xml_path.split("/")
        for depth in range(len(parts)):
            expected.setdefault("/".join(parts[:depth]), set()).add(parts[depth])

    def walk(node: XMLNode, path: str) -> None:
        allowed = expected.get(path)
        if allowed is None:
            return  # a section element: its keywords are checked by read_xml_section
        for child in node.children:
            if child.tag not in allowed and child.tag != "COMMENT":
                where = f"<{node.tag}>"
                raise CCSDSFormatError(f"<{child.tag}> does not belong in {where} (expected "
                                       f"{', '.join(f'<{t}>' for t in sorted(allowed))})",
                                       line=child.line, source=source)
            walk(child, f"{path}/{child.tag}" if path else child.tag)

    walk(root, "")


def _describe(line) -> str:
    if line is None:
        return "the end of the message"
    return line.key if line.kind == "keyword" else f"'{line.value[:40]}'"


def _unexpected(cursor: KVNCursor, sections: tuple, root_tag: str) -> None:
    """Raise when the line at the cursor (after its comments) belongs to no section of the
    message, naming that line."""
    line = _after_comments(cursor)
    if line is None:
        return
    if line.kind != "keyword" or not any(s.owns(line.key) for s in sections):
        kind = root_tag.upper()
        raise cursor.error(f"unexpected {_describe(line)}: not a keyword of {article_of(kind)} "
                           f"{kind} message (check its spelling)", line=line.line)


def with_version(node: XMLNode, key: str, root: XMLNode) -> XMLNode:
    """A copy of an XML ``<header>`` with the root's version as its first keyword element.

    Parameters
    ----------
    node : XMLNode
        The header element.
    key : str
        The version keyword (``"CCSDS_OEM_VERS"``).
    root : XMLNode
        The message element, whose ``version`` attribute is the version (errors about it name
        the root's line, where it is written).

    Returns
    -------
    XMLNode
    """
    version_node = XMLNode(key, {}, root.line, root.attrib["version"])
    return XMLNode(node.tag, node.attrib, node.line, node.text, [version_node, *node.children])


def write_message(parsed: dict, sections: tuple, root_tag: str, version_key: str,
                  fmt: str = "kvn") -> str:
    """Write a flat message (OPM, OMM) from its section records.

    Parameters
    ----------
    parsed : dict
        Section name -> Record or dict (a list for repeated sections), as :func:`read_message`
        returns.
    sections : tuple of Section
        The message's sections.
    root_tag : str
        The XML root element.
    version_key : str
        The version keyword of the header.
    fmt : {"kvn", "xml"}
        Output format.

    Returns
    -------
    str
    """
    if fmt not in ("kvn", "xml"):
        raise CCSDSFormatError(f"format must be 'kvn' or 'xml', not {fmt!r}")
    if fmt == "kvn":
        writer = KVNWriter()
        for section in sections:
            for record in _records(parsed, section):
                write_kvn_section(writer, section, record)
                writer.blank()
        return writer.text()
    return to_text(message_element(parsed, sections, root_tag, version_key))


def message_element(parsed: dict, sections: tuple, root_tag: str, version_key: str):
    """The XML element of a flat message (:func:`write_message`'s XML, before serialising;
    an ``<ndm>`` of several messages holds these)."""
    header = _as_record(parsed[sections[0].name])
    root = new_root(root_tag, version_key, header.values[version_key])
    for section in sections:
        for record in _records(parsed, section):
            parent = root
            for tag in section.xml_path.split("/")[:-1]:
                parent = xml_child(parent, tag)
            write_xml_section(parent, section, record, skip=(version_key,))
    return root


def _records(parsed: dict, section: Section) -> list:
    value = parsed.get(section.name)
    if value is None:
        return []
    return list(value) if section.repeat else [value]
