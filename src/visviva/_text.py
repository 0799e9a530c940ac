"""Decoding the bytes of a text file: the one place that finds the line of a byte that is not
UTF-8, for every reader (CCSDS messages, OMM catalogues)."""

from __future__ import annotations

__all__ = ["utf8_text"]


def utf8_text(raw: bytes, error):
    """The UTF-8 text of a file's bytes (a byte-order mark dropped), else raise ``error(line,
    byte)``: the exception the caller builds from the 1-based line and the value of the first
    byte that is not UTF-8.

    Parameters
    ----------
    raw : bytes
        The file's contents.
    error : callable
        ``error(line: int, byte: int) -> Exception``, naming the file and saying what to do.

    Returns
    -------
    str
    """
    # utf-8-sig: a byte-order mark (Windows editors write one) is not part of the text; left in,
    # it made JSON fail and hid the first CSV column
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise error(raw[:exc.start].count(b"\n") + 1, raw[exc.start]) from None
