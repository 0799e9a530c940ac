"""A small XML element tree that keeps the line of every element, for the file readers.

:func:`parse_xml` reads the text with :mod:`xml.parsers.expat` (the standard library's parser)
into :class:`XMLNode` objects that remember their line, so a reader's errors name the line of
the element at fault (ElementTree keeps no line numbers). External entities are refused, not
fetched, and the encoding an XML declaration names is ignored (the text is already Unicode).
The CCSDS NDM/XML reader (:mod:`visviva.ccsds.ndmxml`) and the OMM XML catalogue reader
(:mod:`visviva.satellites.catalog_files`) use it.
"""

from __future__ import annotations

import gc
from contextlib import contextmanager
from dataclasses import dataclass, field
from xml.parsers import expat

__all__ = ["XMLNode", "parse_xml", "cyclic_gc_paused"]


def _local(name: str) -> str:
    return name.rsplit(":", 1)[-1].rsplit("}", 1)[-1]


@dataclass(slots=True)
class XMLNode:
    """One XML element: tag, attributes, stripped text, children and its 1-based line.

    Attributes
    ----------
    tag : str
        Element name with any namespace prefix removed.
    attrib : dict
        Attributes (names without prefixes; namespace declarations ``xmlns``/``xmlns:*`` are
        left out).
    text : str
        The element's own character data, stripped.
    children : list of XMLNode
        Child elements in document order.
    line : int
        Line of the start tag.
    """

    tag: str
    attrib: dict
    line: int
    text: str = ""
    children: list = field(default_factory=list)

    def find(self, tag: str) -> XMLNode | None:
        """First child with this tag, or None."""
        for child in self.children:
            if child.tag == tag:
                return child
        return None

    def findall(self, tag: str) -> list[XMLNode]:
        """Every child with this tag."""
        return [c for c in self.children if c.tag == tag]

    def iter(self, tag: str):
        """This element and every descendant with this tag, in document order."""
        stack = [self]
        while stack:
            node = stack.pop()
            if node.tag == tag:
                yield node
            stack.extend(reversed(node.children))

    def path(self, path: str) -> list[XMLNode]:
        """Every descendant along a slash-separated path of tags (``"body/segment"``)."""
        nodes = [self]
        for tag in path.split("/"):
            nodes = [c for n in nodes for c in n.findall(tag)]
        return nodes


@contextmanager
def cyclic_gc_paused():
    """Pause Python's cyclic garbage collector (reference counting goes on) while a tree of
    :class:`XMLNode` objects is built and read: the tree holds no reference cycles, and the
    collector, triggered again and again by the allocations, would walk the whole growing tree
    each time (~1e6 nodes for 1e5 OEM states: seconds). Restored as it was on exit."""
    collecting = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if collecting:
            gc.enable()


def parse_xml(text: str, error) -> XMLNode:
    """Parse XML text into :class:`XMLNode` objects; the root node is returned.

    Parameters
    ----------
    text : str
        The XML document.
    error : callable
        ``error(line: int, message: str) -> Exception``: the exception the caller raises when
        the XML is not well formed (``message`` names the fault and the column).

    Returns
    -------
    XMLNode
    """
    parser = expat.ParserCreate()
    parser.buffer_text = True
    parser.buffer_size = 1 << 16  # fewer splits of long text (joined by buffer_text anyway)
    top = XMLNode("", {}, 0, "", [])  # holds the root element
    stack: list[XMLNode] = []  # the ancestors of ``current``
    current = top
    names: dict[str, str] = {}
    plain: set[str] = set()  # attribute names kept as they are (no prefix, no xmlns)

    def attributes(attrs):
        # namespace declarations (xmlns, xmlns:xsi) are not attributes of the element
        return {_local(k): v for k, v in attrs.items()
                if k != "xmlns" and not k.startswith("xmlns:")}

    def start(name, attrs):
        nonlocal current
        tag = names.get(name)
        if tag is None:
            tag = names[name] = _local(name)
        if attrs and not plain.issuperset(attrs):
            kept = attributes(attrs)
            if kept.keys() == attrs.keys():
                plain.update(attrs)
            attrs = kept
        # (expat gives each element a dict of its own: it is the node's)
        node = XMLNode(tag, attrs, parser.CurrentLineNumber, "", [])
        current.children.append(node)
        stack.append(current)
        current = node

    def end(name):
        nonlocal current
        current.text = current.text.strip()
        current = stack.pop()

    def chars(data):
        current.text += data

    def external(context, base, system_id, public_id):
        return 0  # not fetched: expat then stops with "error in processing external entity"

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = chars
    # an entity declared SYSTEM "file-or-url" and used in the text is refused, not fetched,
    # nor silently left out of the value it stands in (an external DTD is not read either)
    parser.ExternalEntityRefHandler = external
    with cyclic_gc_paused():
        _run(parser, text, error)
    return top.children[0]


def _run(parser, text, error):
    try:
        # text, not bytes: expat then reads it as the Unicode it is and ignores the encoding an
        # XML declaration names (a declared 'latin-1' or an unknown name would otherwise
        # re-decode it or raise LookupError)
        parser.Parse(text, True)
    except expat.ExpatError as exc:
        raise error(exc.lineno, f"the XML is not well formed: {expat.ErrorString(exc.code)} "
                                f"(column {exc.offset + 1})") from None
