"""Reading a user's file: the one place that opens it (a missing file raises
:class:`~visviva.errors.MissingFileError` naming the path) and the one place that finds the
line of a byte that is not UTF-8, for every reader (CCSDS messages, TLE and OMM catalogues);
and writing a text file whole or not at all (:func:`replace_text_file`), for the command-line
tools' outputs and the CCSDS writers."""

from __future__ import annotations

__all__ = ["utf8_text", "file_bytes", "replace_text_file", "replace_binary_file"]


def file_bytes(path, what: str, todo: str, error=None) -> bytes:
    """The bytes of the user's file ``path``.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    what : str
        What the file holds, for the messages ("element sets", "a CCSDS message").
    todo : str
        What to do when the file does not exist (the message of the
        :class:`~visviva.errors.MissingFileError` raised then, after the path).
    error : callable, optional
        ``error(message) -> Exception`` for a directory or a file that cannot be read (no
        permission, a device): the reader's own error class; default
        :class:`~visviva.errors.InvalidInputError`.

    Returns
    -------
    bytes
    """
    import os

    from .errors import InvalidInputError, MissingFileError

    error = InvalidInputError if error is None else error
    path = os.fspath(path)
    if os.path.isdir(path):
        raise error(f"{path!r} is a directory; pass the path of a file of {what}.")
    try:
        with open(path, "rb") as f:
            return f.read()
    except FileNotFoundError:
        raise MissingFileError(path, todo) from None
    except OSError as exc:  # (no permission, a device, ...)
        raise error(f"{path!r} cannot be read: {exc.strerror or exc}") from None


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


def replace_text_file(path, text: str) -> None:
    """Write ``text`` to ``path`` (UTF-8) whole or not at all.

    The text goes to a temporary file in the same folder, which then replaces ``path`` in one
    step (:func:`os.replace`): an interrupted or failed write (Ctrl-C, a full disk) leaves the
    earlier file, if any, as it was and no partial file; the temporary file is removed.

    Parameters
    ----------
    path : str or os.PathLike
        The file to write (replaced when it exists; its permission bits are kept; a symbolic
        link is followed: the file it points to is replaced, the link stays).
    text : str
        The whole content.

    Raises
    ------
    InvalidInputError
        The text holds a character UTF-8 cannot encode (a lone surrogate such as ``"\\ud800"``,
        left by a file decoded with ``errors="surrogateescape"``); nothing is written.
    OSError
        The folder does not exist or cannot be written, or ``path`` is a folder.
    """
    import os

    try:
        text.encode("utf-8")
    except UnicodeEncodeError as exc:
        from .errors import InvalidInputError

        line = text.count("\n", 0, exc.start) + 1
        raise InvalidInputError(
            f"cannot write {os.fspath(path)}: line {line} of the text holds "
            f"{text[exc.start]!r}, which UTF-8 cannot encode (a lone surrogate); remove or "
            "replace it. Nothing was written (an existing file is as it was).") from None
    _replace_file(path, text, "w")


def replace_binary_file(path, data: bytes) -> None:
    """Write ``data`` to ``path`` whole or not at all, as :func:`replace_text_file` does for
    text (a PNG plot, an archive).

    Raises
    ------
    OSError
        The folder does not exist or cannot be written, or ``path`` is a folder.
    """
    _replace_file(path, bytes(data), "wb")


def _replace_file(path, content, mode: str) -> None:
    """The temporary file and :func:`os.replace` of :func:`replace_text_file`."""
    import os
    import tempfile

    path = os.fspath(path)
    if os.path.islink(path):  # write where the link points, as open(path, "w") did
        path = os.path.realpath(path)
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".visviva-", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, mode, encoding=None if "b" in mode else "utf-8") as handle:
            handle.write(content)
        try:
            perm = os.stat(path).st_mode & 0o7777
        except OSError:  # a new file: the usual permissions (mkstemp's are 0o600)
            umask = os.umask(0)
            os.umask(umask)
            perm = 0o666 & ~umask
        os.chmod(tmp, perm)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
