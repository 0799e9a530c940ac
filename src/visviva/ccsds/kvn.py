"""The KVN (keyword = value notation) lexer and writer shared by every CCSDS message.

A KVN message is a sequence of lines (CCSDS 502.0-B-3, section 7.4; 508.0-B-1 for the CDM):

* ``KEYWORD = value [unit]`` -- a keyword line; the unit in brackets is optional;
* ``COMMENT free text`` -- a comment line (kept, attached to the section that follows);
* ``META_START``, ``COVARIANCE_STOP``, ... -- a block marker (one upper-case word ending in
  ``_START`` or ``_STOP``);
* anything else that is not blank -- a data line of blank-separated tokens (an OEM state line:
  an epoch and six to nine numbers; a row of a covariance matrix).

:func:`tokenize` turns the text into :class:`KVNLine` objects that keep their 1-based line
number, and :class:`KVNCursor` walks them with the few verbs a message reader needs. Every
malformed line raises :class:`~visviva.ccsds.grammar.CCSDSFormatError` naming the line.
:class:`KVNWriter` writes lines in the same layout (keywords padded to one column, units in
brackets).
"""

from __future__ import annotations

import re
from typing import NamedTuple

from .grammar import CCSDSFormatError, format_float

__all__ = ["KVNLine", "tokenize", "KVNCursor", "KVNWriter", "format_float"]

# (a line is stripped before matching, so the value has no trailing blanks: no lazy '.*?\s*$',
# which takes quadratic time on a long run of blanks)
_KEYWORD_RE = re.compile(r"^([A-Z][A-Z0-9_]*)\s*=\s*(.*)$")
_DATA_START = frozenset("0123456789+-.")
_MARKER_RE = re.compile(r"^([A-Z][A-Z0-9_]*_(START|STOP))$")
#: characters no KVN line holds (CCSDS 502.0-B-3, 7.4: printable ASCII text and blanks; a tab
#: is read as a blank). Python's ``str.splitlines`` would also split at several of these
#: (form feed, U+2028, ...), so lines are split at CR/LF only and these refused.
_CONTROL_RE = re.compile("[\x00-\x08\x0b-\x0c\x0e-\x1f\x7f-\x9f\u2028\u2029]")
_NEWLINE_RE = re.compile(r"\r\n?|\n")
_KEY_ONLY_RE = re.compile(r"^[A-Z][A-Z0-9_]*$")


class KVNLine(NamedTuple):
    """One non-blank line of a KVN message.

    Attributes
    ----------
    kind : str
        ``"keyword"``, ``"comment"``, ``"start"``, ``"stop"`` or ``"data"``.
    line : int
        1-based line number in the source text.
    key : str
        The keyword (keyword lines), the block name without ``_START``/``_STOP`` (markers),
        ``"COMMENT"`` (comments), ``""`` (data lines).
    value : str
        The value text without its unit (keyword lines), the comment text (comments), the
        whole line (data lines).
    unit : str or None
        The unit written in brackets after a keyword's value, or None.
    """

    kind: str
    line: int
    key: str
    value: str
    unit: str | None = None

    @property
    def tokens(self) -> list[str]:
        """The blank-separated tokens of a data line."""
        return self.value.split()


def tokenize(text: str, source: str = "<text>") -> list[KVNLine]:
    """Split KVN text into :class:`KVNLine` objects (blank lines dropped, numbers kept).

    Parameters
    ----------
    text : str
        The whole message.
    source : str
        Name of the file, quoted in error messages.

    Returns
    -------
    list of KVNLine

    Raises
    ------
    CCSDSFormatError
        A keyword line without a value, a unit bracket left open, or a control character.
    """
    control = _CONTROL_RE.search(text)
    if control is not None:
        before = text[:control.start()]
        line = len(_NEWLINE_RE.findall(before)) + 1
        column = control.start() - max(before.rfind("\n"), before.rfind("\r"))
        raise CCSDSFormatError(
            f"control character U+{ord(control.group()):04X} in column {column}: a KVN message "
            "is printable text; remove it", line=line, source=source)
    out = []
    append = out.append
    for number, raw in enumerate(_NEWLINE_RE.split(text), start=1):
        stripped = raw.strip()
        if not stripped:
            continue
        if stripped[0] in _DATA_START:  # fast path: keywords and markers start with a letter
            append(KVNLine("data", number, "", stripped))
            continue
        if stripped == "COMMENT" or stripped.startswith(("COMMENT ", "COMMENT\t")):
            out.append(KVNLine("comment", number, "COMMENT", stripped[7:].strip()))
            continue
        marker = _MARKER_RE.match(stripped)
        if marker:
            name = marker.group(1)
            kind = "start" if name.endswith("_START") else "stop"
            out.append(KVNLine(kind, number, name.rsplit("_", 1)[0], stripped))
            continue
        if "=" in stripped:
            match = _KEYWORD_RE.match(stripped)
            if match is None:
                raise CCSDSFormatError(
                    f"'{stripped[:60]}' is not 'KEYWORD = value [unit]' (keywords are upper case "
                    "letters, digits and underscores)", line=number, source=source)
            key, value = match.group(1), match.group(2)
            unit = None
            if value.endswith("]"):
                bracket = value.rfind("[")
                unit = value[bracket + 1:-1]
                if bracket < 0 or "]" in unit:
                    raise CCSDSFormatError(f"the unit of {key} has an unbalanced bracket",
                                           line=number, source=source)
                value, unit = value[:bracket].rstrip(), unit.strip()
            elif "[" in value:
                raise CCSDSFormatError(f"the unit of {key} lacks its closing bracket ']'",
                                       line=number, source=source)
            if value == "":
                raise CCSDSFormatError(f"{key} has no value", line=number, source=source)
            out.append(KVNLine("keyword", number, key, value, unit))
            continue
        out.append(KVNLine("data", number, "", stripped))
    return out


class KVNCursor:
    """Walks the lines of a KVN message; what a message reader pulls its sections from.

    Parameters
    ----------
    text : str
        The message.
    source : str
        Name quoted in error messages.
    """

    def __init__(self, text: str, source: str = "<text>"):
        self.lines = tokenize(text, source)
        self.source = source
        self.pos = 0

    def error(self, message: str, line: int | None = None) -> CCSDSFormatError:
        """A :class:`CCSDSFormatError` at ``line`` (default: the current line; the last at EOF)."""
        if line is None:
            current = self.peek()
            line = current.line if current else (self.lines[-1].line if self.lines else 0)
        return CCSDSFormatError(message, line=line, source=self.source)

    def peek(self) -> KVNLine | None:
        """The current line, or None at the end."""
        return self.lines[self.pos] if self.pos < len(self.lines) else None

    def next(self) -> KVNLine:
        """Return the current line and advance; raise at the end of the message."""
        line = self.peek()
        if line is None:
            raise self.error("the message ends too early")
        self.pos += 1
        return line

    def at_end(self) -> bool:
        """True after the last line."""
        return self.pos >= len(self.lines)

    def take_comments(self) -> list[str]:
        """Consume the COMMENT lines at the cursor and return their texts."""
        out = []
        while (line := self.peek()) is not None and line.kind == "comment":
            out.append(line.value)
            self.pos += 1
        return out

    def at_block(self, name: str, kind: str = "start") -> bool:
        """True when the current line is the marker ``NAME_START`` (or ``_STOP``)."""
        line = self.peek()
        return line is not None and line.kind == kind and line.key == name

    def expect_block(self, name: str, kind: str = "start") -> KVNLine:
        """Consume the marker ``NAME_START`` (or ``NAME_STOP``) or raise saying what came instead."""
        line = self.peek()
        if line is None or line.kind != kind or line.key != name:
            got = "the end of the message" if line is None else f"'{line.value[:60]}'"
            raise self.error(f"expected {name}_{kind.upper()} here, found {got}")
        self.pos += 1
        return line

    def data_lines(self) -> list[KVNLine]:
        """Consume the data lines at the cursor (comments between them are skipped)."""
        return self.data_lines_with_comments()[0]

    def data_lines_with_comments(self) -> tuple[list[KVNLine], dict[int, list[str]]]:
        """Consume the data lines at the cursor and the comments among and right after them.

        Returns
        -------
        rows : list of KVNLine
            The data lines.
        comments : dict
            COMMENT texts keyed by the number of data lines before them (so ``k`` means
            "between line k-1 and line k", and ``len(rows)`` "after the last one").
        """
        rows: list[KVNLine] = []
        comments: dict[int, list[str]] = {}
        while (line := self.peek()) is not None and line.kind in ("data", "comment"):
            if line.kind == "data":
                rows.append(line)
            else:
                comments.setdefault(len(rows), []).append(line.value)
            self.pos += 1
        return rows, comments


class KVNWriter:
    """Builds KVN text line by line (keywords padded to one column, units in brackets)."""

    def __init__(self, width: int = 20):
        self.out: list[str] = []
        self.width = width

    def comment(self, texts) -> None:
        """Write one ``COMMENT`` line per text (a text of several lines, as XML may hold, on
        as many ``COMMENT`` lines)."""
        for text in texts:
            for part in _NEWLINE_RE.split(str(text)) if text else [""]:
                if _CONTROL_RE.search(part):
                    raise CCSDSFormatError(
                        f"the comment {part[:60]!r} holds a control character, which KVN "
                        "cannot hold: remove it, or write the message as XML")
                self.out.append(f"COMMENT {part}".rstrip())

    def keyword(self, key: str, value: str, unit: str | None = None) -> None:
        """Write ``KEY = value [unit]``.

        Raises
        ------
        CCSDSFormatError
            A key or a value that KVN cannot hold, so that the text would not read back (a
            value read from XML may hold a bracket or a line break): write XML instead.
        """
        value = str(value)
        if not _KEY_ONLY_RE.match(key):
            raise CCSDSFormatError(
                f"{key!r} cannot be a KVN keyword (upper case letters, digits and underscores "
                "only): rename it, or write the message as XML")
        if ("[" in value or "]" in value or not value.strip() or _NEWLINE_RE.search(value)
                or _CONTROL_RE.search(value)):
            raise CCSDSFormatError(
                f"{key} = {value!r} cannot be written as KVN (a KVN value is one line of "
                "printable text without brackets, which would read as a unit): change the "
                "value, or write the message as XML")
        suffix = f" [{unit}]" if unit else ""
        self.out.append(f"{key:<{self.width}} = {value}{suffix}")

    def marker(self, text: str) -> None:
        """Write a block marker such as ``META_START``."""
        self.out.append(text)

    def data(self, text: str) -> None:
        """Write a data line."""
        self.out.append(text)

    def blank(self) -> None:
        """Write an empty line between sections."""
        self.out.append("")

    def text(self) -> str:
        """The message so far, ending with a newline."""
        return "\n".join(self.out).rstrip("\n") + "\n"
