"""The NDM/XML side of the grammar: a small element tree that keeps line numbers, and a writer.

CCSDS 505.0-B (NDM/XML) lays each message out as ``<oem id="CCSDS_OEM_VERS" version="3.0">``
holding ``<header>`` and ``<body>``; the body holds one or more ``<segment>`` with
``<metadata>`` and ``<data>``; every keyword is an element of the same name with an optional
``units`` attribute (``<X units="km">6655.99</X>``), comments are ``<COMMENT>`` elements.

:func:`parse` reads the text into :class:`XMLNode` objects (:mod:`visviva._xmltree`: expat, every
element remembers its line), so errors name the line as in KVN.
:func:`new_root` and :func:`to_text` write with :mod:`xml.etree.ElementTree`.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

from .._xmltree import XMLNode, parse_xml
from ..errors import fmt_first
from .grammar import CCSDSFormatError

__all__ = ["XMLNode", "parse", "message_root", "check_attributes", "hoist_comments", "looks_like_xml", "new_root", "new_ndm", "add_text",
           "to_text"]

_XSI = "http://www.w3.org/2001/XMLSchema-instance"
_SCHEMA = "https://sanaregistry.org/r/ndmxml_unqualified/ndmxml-3.0.0-master-3.0.xsd"


def looks_like_xml(text: str) -> bool:
    """Whether a message is XML (its first non-blank character is ``<``).

    Parameters
    ----------
    text : str
        The message.

    Returns
    -------
    bool
    """
    return text.lstrip().startswith("<")


def parse(text: str, source: str = "<text>") -> XMLNode:
    """Parse an NDM/XML message into :class:`XMLNode` objects; the root node is returned.

    Parameters
    ----------
    text : str
        The XML document.
    source : str
        Name of the file, quoted in error messages.

    Returns
    -------
    XMLNode

    Raises
    ------
    CCSDSFormatError
        The XML is not well formed (the message names the line and column).
    """
    return parse_xml(text, lambda line, message: CCSDSFormatError(message, line=line,
                                                                   source=source))


def message_root(root: XMLNode, tag: str, source: str, containers=(),
                 data_lines=()) -> XMLNode:
    """The ``<tag>`` message element: the root itself, or the one inside an ``<ndm>`` wrapper.

    Parameters
    ----------
    root : XMLNode
        The document's root element.
    tag : str
        ``"oem"``, ``"opm"``, ``"omm"``, ``"cdm"``.
    source : str
        File name, for error messages.
    containers : iterable of str
        Tags of the elements that hold sections rather than keywords (``"body"``,
        ``"segment"``, an OPM's ``"data"``): their ``<COMMENT>`` elements move into the
        element after them (:func:`hoist_comments`).
    data_lines : iterable of str
        Tags of the elements whose keyword elements are data lines the message keeps as
        numbers, not records (an OEM's ``stateVector``/``covarianceMatrix``, a TDM's
        ``observation``): attributes there are not kept (:func:`check_attributes`).

    Returns
    -------
    XMLNode

    Raises
    ------
    CCSDSFormatError
        No such message, or its ``id`` names another type (:func:`check_attributes`, which
        also warns about attributes the readers do not keep).
    """
    if root.tag == "ndm":  # a combined instantiation (505.0-B, 3.4), e.g. CelesTrak's OMM XML
        inner = root.findall(tag)
        if len(inner) != 1:
            raise CCSDSFormatError(
                f"the <ndm> holds {len(inner)} <{tag}> messages; this reader takes one (for many "
                "OMMs use vv.read_omm_file)", line=root.line, source=source)
        message = inner[0]
        others = [c for c in root.children if c is not message]
        if others:  # (the combined instantiation may hold other messages, a MESSAGE_ID, ...)
            import warnings

            shown = fmt_first([f"<{c.tag}> (line {c.line})" for c in others])
            warnings.warn(
                f"{source}: the <ndm> also holds {shown}, which this reader does not "
                f"keep: it reads the <{tag}> only (read another message with its own reader, "
                "e.g. vv.read_oem, after taking it out of the <ndm>)", UserWarning,
                stacklevel=3)
    elif root.tag != tag:
        raise CCSDSFormatError(f"the root element is <{root.tag}>, expected <{tag}>",
                               line=root.line, source=source)
    else:
        message = root
    check_attributes(root, message, source, data_lines)
    hoist_comments(message, {tag, *containers}, source)
    return message


def hoist_comments(node: XMLNode, containers: set, source: str) -> None:
    """Move the ``<COMMENT>`` elements of container elements into the element after them.

    NDM/XML lets ``<COMMENT>`` open an OPM's, OMM's or CDM's ``<data>`` (505.0-B), before any
    section; a comment describes what follows it (as in KVN, where such a comment opens the
    first data section), so it joins the first section after it, where the readers keep it and
    the writers write it back. The readers took comments from section elements only, and those
    of ``<data>``, ``<segment>``, ``<body>`` or the message element were dropped without a
    word. Works from the top down, so a comment in ``<body>`` reaches the first ``<metadata>``.

    Parameters
    ----------
    node : XMLNode
        The message element (changed in place: the parse tree is the reader's own).
    containers : set of str
        Tags of the elements whose comments move (the message's own tag among them).
    source : str
        File name, for error messages.

    Raises
    ------
    CCSDSFormatError
        A comment after the last element of a container: it describes nothing, and no
        section would keep it (the same rule as for KVN).
    """
    if node.tag not in containers or not node.children:
        return
    pending, children = [], []
    for child in node.children:
        if child.tag == "COMMENT":
            pending.append(child)
            continue
        if pending:
            child.children[:0] = pending
            pending = []
        children.append(child)
    if pending:
        raise CCSDSFormatError(
            f"a <COMMENT> after the last element of <{node.tag}> belongs to no section (a "
            "comment comes before what it describes): move it or remove it",
            line=pending[0].line, source=source)
    node.children = children
    for child in children:
        hoist_comments(child, containers, source)


_SCHEMA_ATTRIBUTES = frozenset({"noNamespaceSchemaLocation", "schemaLocation"})
_ROOT_ATTRIBUTES = _SCHEMA_ATTRIBUTES | {"id", "version"}
_UNITS = frozenset({"units"})  # compared with an attribute dict's keys


def check_attributes(root: XMLNode, message: XMLNode, source: str, data_lines=()) -> None:
    """Refuse a wrong ``id`` on the message and warn about attributes NDM/XML does not define.

    The NDM/XML schemas (505.0-B) define ``id`` and ``version`` on the message element,
    ``units`` on a value's element, ``parameter`` on ``<USER_DEFINED>`` and the schema location
    (``xsi:noNamespaceSchemaLocation``); the readers keep those. Another attribute on a
    keyword element of a section (``<CREATION_DATE zone="UTC">``) is kept with its keyword
    (``Record.attributes``) and written back on the same element by an XML write (a KVN write
    warns that it leaves it out). Any other attribute -- on a structure element (``<segment
    foo="1">``, ``<body>``, a section element), a ``<COMMENT>``, or a data line of
    ``data_lines`` (an OEM state or covariance, a TDM observation, which are kept as numbers)
    -- has no place in the message objects and is dropped on write: a :class:`UserWarning`
    names each one with its line and says so, so none is dropped silently.

    Parameters
    ----------
    root : XMLNode
        The document's root element (the message, or the ``<ndm>`` around it).
    message : XMLNode
        The ``<oem>``/``<opm>``/... element.
    source : str
        File name, for the messages.
    data_lines : iterable of str
        Tags whose keyword elements are data lines (not kept: see above).

    Raises
    ------
    CCSDSFormatError
        The message's ``id`` names another message type (``<opm id="CCSDS_OEM_VERS">``), or
        an element that holds elements holds text too (``<data>stray<stateVector>``: it
        would be dropped).
    """
    key = f"CCSDS_{message.tag.upper()}_VERS"
    given = message.attrib.get("id")
    if given is not None and given.strip() != key:
        raise CCSDSFormatError(
            f"<{message.tag}> has id=\"{given}\"; the id of an <{message.tag}> message is "
            f"\"{key}\" (is the file another message type?)", line=message.line, source=source)
    dropped = []
    stack = [(root, None)]
    while stack:
        node, parent = stack.pop()
        if (node.tag[:1].isupper() and not node.children and node.tag != "COMMENT"
                and parent is not None and parent.tag not in data_lines):
            continue  # a keyword element: its attributes are kept (Record.attributes)
        if node is message:
            allowed = _ROOT_ATTRIBUTES
        elif node is root:  # the <ndm> wrapper
            allowed = _SCHEMA_ATTRIBUTES
        elif node.tag == "USER_DEFINED":
            allowed = {"parameter", "units"}
        else:
            allowed = {"units"} if not node.children or node.tag[:1].isupper() else set()
        dropped.extend(f'{name}="{value}" on <{node.tag}> (line {node.line})'
                       for name, value in node.attrib.items() if name not in allowed)
        # (structure elements are lower camel case; an upper-case keyword element holding an
        # element is refused by the section reader, naming that element)
        if node.children and node.text and node.tag[:1].islower():
            raise CCSDSFormatError(
                f"<{node.tag}> holds the text {node.text[:40]!r} beside its elements; text "
                "belongs in a keyword element (or a <COMMENT>)", line=node.line, source=source)
        # (the other children of an <ndm> are named by message_root's warning)
        wrapper = node is root and root is not message
        if wrapper:
            stack.append((message, node))
        else:  # (a leaf with no attribute but units has nothing to check: not stacked)
            stack.extend([(c, node) for c in reversed(node.children)
                          if c.children or (c.attrib and c.attrib.keys() != _UNITS)])
    if dropped:
        import warnings

        shown = fmt_first(dropped, 5, "; ")
        warnings.warn(f"{source}: XML attributes that CCSDS NDM/XML does not define are not kept "
                      f"and are dropped on write (writing this message back, as XML or KVN, "
                      f"leaves them out): {shown}. Only the schema's attributes have a place "
                      "in the message objects; keep the original file where these matter.",
                      UserWarning, stacklevel=4)


def new_root(tag: str, version_key: str, version: str) -> ET.Element:
    """The root element of an NDM/XML message, e.g. ``<opm id="CCSDS_OPM_VERS" version="3.0">``.

    Parameters
    ----------
    tag : str
        ``"oem"``, ``"opm"``, ``"omm"``, ``"cdm"``.
    version_key : str
        ``"CCSDS_OPM_VERS"`` and the like.
    version : str
        The version number as text.

    Returns
    -------
    xml.etree.ElementTree.Element
    """
    return ET.Element(tag, {"xmlns:xsi": _XSI, "xsi:noNamespaceSchemaLocation": _SCHEMA,
                            "id": version_key, "version": str(version)})


def new_ndm(messages) -> ET.Element:
    """An ``<ndm>`` combined instrument holding the message elements ``messages`` (each as
    :func:`new_root` made it; the schema attributes move to the ``<ndm>``), as CelesTrak writes
    its GP data: ``<ndm><omm id="CCSDS_OMM_VERS" version="3.0">...</omm><omm>...</ndm>``.

    Parameters
    ----------
    messages : iterable of xml.etree.ElementTree.Element
        The message elements.

    Returns
    -------
    xml.etree.ElementTree.Element
    """
    root = ET.Element("ndm", {"xmlns:xsi": _XSI, "xsi:noNamespaceSchemaLocation": _SCHEMA})
    for message in messages:
        message.attrib.pop("xmlns:xsi", None)
        message.attrib.pop("xsi:noNamespaceSchemaLocation", None)
        root.append(message)
    return root


def add_text(parent: ET.Element, tag: str, text: str, units: str | None = None) -> ET.Element:
    """Append ``<tag units="...">text</tag>`` to ``parent``.

    Parameters
    ----------
    parent : xml.etree.ElementTree.Element
        Where to append.
    tag : str
        Element name.
    text : str
        Its text.
    units : str or None
        The ``units`` attribute, if any.

    Returns
    -------
    xml.etree.ElementTree.Element
    """
    element = ET.SubElement(parent, tag, {"units": units} if units else {})
    element.text = text
    return element


def to_text(root: ET.Element) -> str:
    """Serialise an element tree with an XML declaration and two-space indentation.

    Parameters
    ----------
    root : xml.etree.ElementTree.Element
        The root element.

    Returns
    -------
    str
    """
    ET.indent(root, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"
