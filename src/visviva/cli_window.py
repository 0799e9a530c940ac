"""The time window that the command-line tools take (``--start ISO --hours H``), and the output
file they write.

One owner for parsing the window, so that ``visviva passes`` and ``visviva screen`` refuse a bad
window with the same short message instead of astropy's list of every time format it tried; one
for writing the output, so that ``visviva convert`` and ``visviva fit-tle`` report a file they
cannot write in one line with exit code 2 instead of a traceback; one for the element-set file
argument of ``visviva passes`` and ``visviva screen`` (read by :func:`visviva.read_catalog_file`);
and one check of the output paths of every command (:func:`check_outputs`): no output may be an
input file, no file is written twice, and an existing file is replaced only with
``--overwrite``.
"""

from __future__ import annotations

import math

__all__ = ["window_from_args", "time_from_arg", "write_output", "add_catalog_argument",
           "add_overwrite_argument", "check_outputs", "check_inputs"]


def add_catalog_argument(parser) -> None:
    """Add the positional element-set file argument (``args.tle_file``) to ``parser``.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        A sub-command's parser; its ``run`` reads the file with
        :func:`visviva.read_catalog_file`, which tells the kind by content.
    """
    parser.add_argument(
        "tle_file", metavar="FILE",
        help="element sets: TLE (2 or 3 lines each), OMM JSON/CSV/XML (CelesTrak GP data) or a "
             "CCSDS OMM (KVN or XML); the kind is told by content")


def window_from_args(start: str, hours: float):
    """The window ``(t0, t1)`` (astropy Times, UTC) from ``--start`` and ``--hours``.

    Parameters
    ----------
    start : str
        Start of the window, an ISO 8601 time in UTC (e.g. ``2024-05-01T18:00``), or with a
        UTC offset (``2024-05-01T20:00+02:00``: the same instant).
    hours : float
        Length of the window, hours; positive and finite.

    Returns
    -------
    t0, t1 : astropy.time.Time
        Start and end of the window.

    Raises
    ------
    visviva.errors.InvalidInputError
        ``start`` is not an ISO time (the message gives astropy's ISO reason only, and an
        example), or ``hours`` is not a positive finite number.
    """
    from astropy import units as u

    from .errors import InvalidInputError

    if not (math.isfinite(hours) and hours > 0):
        raise InvalidInputError(f"--hours must be a positive finite number, got {hours}.")
    t0 = time_from_arg("--start", start)
    return t0, t0 + hours * u.hour


def time_from_arg(option: str, value: str):
    """An ISO 8601 time in UTC (or with a UTC offset) given as ``option`` -> astropy Time.

    Raises :class:`visviva.errors.InvalidInputError` with astropy's ISO reason only, and an
    example, for anything else.
    """
    from astropy.time import Time

    from .errors import InvalidInputError

    try:
        t = _with_utc_offset(value)
        if t is None:
            t = Time(value, scale="utc")
    except ValueError as exc:
        # astropy lists why every format failed; the ISO one is the reason that matters here
        lines = str(exc).splitlines()
        why = next((ln.split(":", 1)[1].strip() for ln in lines if "'isot'" in ln), lines[0])
        raise InvalidInputError(
            f"{option} {value!r} is not an ISO time ({why}); use e.g. 2024-05-01T18:00:00"
        ) from None
    return t


def _with_utc_offset(start: str):
    """The Time of an ISO string that ends in a UTC offset (``+02:00``, ``-0500``), else None.

    astropy refuses such strings; read through ``datetime`` they are converted to UTC, never
    taken for UTC clock readings.
    """
    import re
    from datetime import datetime

    from astropy.time import Time

    if not re.search(r"[T ].*[+-]\d{2}:?\d{2}$", start.strip()):
        return None
    return Time(datetime.fromisoformat(start.strip()), scale="utc")


def write_output(command: str, path: str, text: str) -> int:
    """Write ``text`` to ``path`` (``"-"``: standard output); the exit code.

    Parameters
    ----------
    command : str
        The command's name, quoted in the message (``"convert"``).
    path : str
        The output file, or ``"-"``.
    text : str
        What to write.

    Returns
    -------
    int
        0, or 2 after a one-line message on standard error when the file cannot be written (a
        folder, a missing folder, no permission). The file is replaced in one step
        (:func:`visviva._text.replace_text_file`): a failed or interrupted write leaves an
        existing file as it was.
    """
    import sys

    if path == "-":
        sys.stdout.write(text)
        return 0
    from ._text import replace_text_file

    try:
        replace_text_file(path, text)  # whole or not at all: never a half-written file
    except OSError as exc:
        print(f"visviva {command}: cannot write {path}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    return 0


def add_overwrite_argument(parser) -> None:
    """Add ``--overwrite`` (``args.overwrite``): replace output files that exist."""
    parser.add_argument("--overwrite", action="store_true",
                        help="replace output files that exist (an input file is never replaced)")


def _same_file(a, b) -> bool:
    import os

    try:
        return os.path.samefile(a, b)
    except OSError:  # one does not exist (yet): compare the absolute paths
        return os.path.abspath(a) == os.path.abspath(b)


def check_outputs(outputs, inputs, overwrite: bool) -> None:
    """Refuse output paths that would destroy data, before any work is done.

    Parameters
    ----------
    outputs : list of str or None
        The output paths given (``None`` or ``"-"``, standard output: not checked).
    inputs : list of str or None
        The files the command reads.
    overwrite : bool
        ``--overwrite``: an existing output file may be replaced.

    Raises
    ------
    visviva.errors.InvalidInputError
        An output is one of the input files (refused even with ``--overwrite``), the same file
        is given as two outputs, an output is a folder or in a folder that does not exist
        (refused before hours of work, not after), or an output file exists and ``overwrite``
        is false.
    """
    import os

    from .errors import InvalidInputError

    seen = []
    for out in outputs:
        if out is None or out == "-":
            continue
        for source in inputs:
            if source is not None and _same_file(out, source):
                raise InvalidInputError(
                    f"the output {out} is the input file {source}: writing it would destroy "
                    "the input; choose another output path.")
        for earlier in seen:
            if _same_file(out, earlier):
                raise InvalidInputError(f"{out} is given as two outputs; name two files.")
        if os.path.isdir(out):
            raise InvalidInputError(f"cannot write {out}: it is a folder; name a file to write.")
        folder = os.path.dirname(os.path.abspath(out))
        if not os.path.isdir(folder):
            raise InvalidInputError(
                f"cannot write {out}: the folder {folder} does not exist; create it first.")
        if os.path.isfile(out) and not overwrite:
            raise InvalidInputError(
                f"{out} exists; pass --overwrite to replace it, or choose another path.")
        seen.append(out)


def check_inputs(inputs) -> None:
    """Refuse an input file that does not exist, with advice for the shell.

    The CCSDS readers take a path or the message text itself, and say so when a path does not
    exist ("or pass the message text itself"), which a command-line user cannot do.

    Parameters
    ----------
    inputs : list of str or None
        The files the command reads (``None``: not given).

    Raises
    ------
    visviva.errors.MissingFileError
        Naming the first missing file (relative to the working folder when relative).
    """
    import os

    from .errors import MissingFileError

    for path in inputs:
        if path is not None and not os.path.exists(path):
            raise MissingFileError(path, "check the name.")
