"""``visviva convert``: between TLE, OMM and OEM (an OEM from a TLE or OMM by SGP4 sampling).

Input kinds are recognised from the content (``CCSDS_OMM_VERS`` / ``<omm>``, ``CCSDS_OEM_VERS``
/ ``<oem>``, else element sets of any kind :func:`visviva.read_catalog_file` reads: TLE lines,
CelesTrak's GP data as OMM JSON, CSV or an XML ``<ndm>`` of many ``<omm>``); the output kind
from ``--to`` or the output's suffix (``.tle``, ``.txt``, ``.omm``, ``.oem``); KVN or XML from
``--format`` or a ``.xml`` suffix. A catalogue (several element sets) becomes a TLE file of
them all, or an XML ``<ndm>`` of one ``<omm>`` per element set (KVN holds one OMM: refused);
an OEM is sampled from one element set (``--satnum``).
"""

from __future__ import annotations

from ..errors import InvalidInputError

_KINDS = ("tle", "omm", "oem")
_SUFFIX = {".tle": "tle", ".txt": "tle", ".3le": "tle", ".omm": "omm", ".oem": "oem"}


def add_parser(sub) -> None:
    """Add the ``convert`` sub-command to an argparse sub-parser group.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The group.
    """
    p = sub.add_parser(
        "convert", help="convert between TLE, CCSDS OMM and CCSDS OEM (KVN or XML)",
        description="Convert orbit data: TLE <-> OMM (exact SGP4 mean elements), TLE or OMM -> "
        "OEM (SGP4 sampled every --step seconds for --hours from --start), OEM/OMM KVN <-> XML.")
    p.add_argument("input", help="TLE file (2 or 3 lines per satellite), CelesTrak GP data "
                   "(OMM JSON, CSV or XML), CCSDS OMM or OEM (KVN/XML)")
    p.add_argument("output", help="file to write ('-' for standard output)")
    p.add_argument("--to", choices=_KINDS, default=None,
                   help="output kind (default: from the output's suffix)")
    p.add_argument("--format", choices=("kvn", "xml"), default=None,
                   help="CCSDS encoding (default: xml for a .xml output, else kvn)")
    p.add_argument("--satnum", type="satnum", default=None,
                   help="catalogue number to take from a file with several satellites "
                        "(default: all of them, for a TLE or XML OMM output)")
    p.add_argument("--start", default=None, metavar="ISO",
                   help="OEM start, UTC (default: the element set's epoch)")
    p.add_argument("--hours", type="hours", default=None, help="OEM span in hours (default 24)")
    p.add_argument("--step", type="seconds", default=None, help="OEM step in seconds (default 60)")
    p.add_argument("--frame", choices=("GCRF", "EME2000", "TEME", "ITRF"), default=None,
                   help="OEM reference frame (default GCRF; EME2000 is written from the GCRS "
                        "states turned by the 23 mas frame bias)")
    p.add_argument("--mission-epoch", default=None, metavar="ISO",
                   help="UTC epoch that an OEM in TIME_SYSTEM MET (launch) or MRT counts from")
    p.add_argument("--originator", default="VISVIVA",
                   help="ORIGINATOR of a new OMM or OEM (default VISVIVA)")
    from ..cli_window import add_overwrite_argument

    add_overwrite_argument(p)


def _kind_of_text(text: str) -> str:
    head = text.lstrip()[:2000]
    first = head.split("\n", 1)[0]
    if head.startswith(("{", "[")) or ("," in first and "=" not in first):
        return "tle"  # (GP data in JSON or CSV, whose records may hold CCSDS_OMM_VERS)
    for kind in ("omm", "oem"):
        if f"CCSDS_{kind.upper()}_VERS" in head or f"<{kind}" in head:
            return kind
    if "CCSDS_OPM_VERS" in head or "<opm" in head:
        raise InvalidInputError("OPM input is not converted (it holds one state); "
                                "read it with visviva.read_opm")
    return "tle"


def _output_kind(args) -> str:
    import os

    if args.to:
        return args.to
    suffix = os.path.splitext(args.output)[1].lower()
    if suffix in _SUFFIX:
        return _SUFFIX[suffix]
    raise InvalidInputError(f"cannot tell the output kind from {args.output!r}; "
                            "pass --to tle, omm or oem")


def _format(args) -> str:
    if args.format:
        return args.format
    return "xml" if args.output.lower().endswith(".xml") else "kvn"


def _satellites(args, path, text: str, kind: str) -> list:
    """The element sets of the input (those of ``--satnum`` when given), in the file's order."""
    from ..satellites import Satellite
    from ..satellites.catalog import read_catalog_file
    from .omm import read_omm

    if kind == "omm" and not _is_ndm(text) and _one_omm(text):
        sats = [Satellite.from_omm(read_omm(path))]
    else:
        sats = list(read_catalog_file(path))
    if args.satnum is not None:  # (a one-OMM file too: never another object than asked for)
        held = sorted({s.satnum for s in sats})
        sats = [s for s in sats if s.satnum == args.satnum]
        if not sats:
            shown = ", ".join(str(n) for n in held[:10]) + (", ..." if len(held) > 10 else "")
            raise InvalidInputError(f"no satellite {args.satnum} in {args.input} (it holds "
                                    f"{shown})")
    return sats


def _one(args, sats, why: str):
    """The one element set of ``sats``; several are refused (``why``: what needs one)."""
    if len(sats) != 1:
        numbers = ", ".join(str(s.satnum) for s in sats[:10])
        raise InvalidInputError(f"{args.input} holds {len(sats)} element sets "
                                f"({numbers}{', ...' if len(sats) > 10 else ''}); {why}: pick "
                                "one with --satnum")
    return sats[0]


def _one_omm(text: str) -> bool:
    """Whether a KVN input holds one OMM (many one after another, as Space-Track's KVN GP data,
    are read as a catalogue)."""
    return text.count("CCSDS_OMM_VERS") <= 1


def _kvn_message(text: str, satnum: int) -> str | None:
    """The one KVN OMM of ``satnum`` among several (Space-Track's KVN GP data), preceded by
    as many blank lines as come before it in the file (so errors name the file's lines); None
    when the file is XML, holds one message, or holds none or several of ``satnum``.

    Such a message read as a catalogue keeps only its SGP4 fields: its comments and
    ``USER_DEFINED_*`` parameters (Space-Track's object type, size, country) were dropped.
    """
    import re

    if text.lstrip().startswith("<"):
        return None
    starts = [m.start() for m in re.finditer(r"(?m)^[ \t]*CCSDS_OMM_VERS\b", text)]
    if len(starts) < 2:
        return None
    own = re.compile(rf"(?m)^[ \t]*NORAD_CAT_ID[ \t]*=[ \t]*0*{int(satnum)}[ \t]*$")
    hits = [(a, b) for a, b in zip(starts, [*starts[1:], len(text)], strict=True)
            if own.search(text, a, b)]
    if len(hits) != 1:
        return None
    a, b = hits[0]
    return "\n" * text.count("\n", 0, a) + text[a:b]


def _is_ndm(text: str) -> bool:
    """Whether an XML input is an ``<ndm>`` of several OMMs (CelesTrak's GP XML, read as a
    catalogue) rather than one ``<omm>``, bare or in an ``<ndm>`` (read as a message, so its
    comments, user-defined parameters, covariance ... are kept: they were dropped)."""
    import re

    return "<ndm" in text.lstrip()[:2000] and len(re.findall(r"<omm[\s>/]", text)) != 1


def _sample_oem(sat, args):
    import numpy as np
    from astropy import units as u
    from astropy.time import Time

    from ..cli_window import time_from_arg
    from .oem import Ephemeris, OEMSegment

    start = time_from_arg("--start", args.start) if args.start else sat.epoch.utc
    if not (args.hours > 0 and args.step > 0):
        raise InvalidInputError("--hours and --step must be positive")
    n = int(np.floor(args.hours * 3600.0 / args.step + 1e-9)) + 1
    if n < 2:
        raise InvalidInputError("--hours must span at least two --step")
    t = start + (np.arange(n) * args.step) * u.s
    states = {"GCRF": sat.gcrs, "EME2000": sat.gcrs, "TEME": sat.teme, "ITRF": sat.itrs}[
        args.frame](t)
    omm = sat.to_omm()
    seg = OEMSegment.from_states(  # (the states: EME2000 is written with the frame bias)
        states, object_name=sat.name,
        object_id=omm["OBJECT_ID"] or "UNKNOWN", frame=args.frame, interpolation="LAGRANGE",
        degree=min(7, n - 1))
    seg.data_comments.append(f"SGP4 states of NORAD {sat.satnum}, element set epoch "
                             f"{omm['EPOCH']} UTC, sampled every {args.step:g} s")
    header = {"CCSDS_OEM_VERS": "3.0", "CREATION_DATE": Time.now().utc.isot,
              "ORIGINATOR": args.originator}
    return Ephemeris([seg], header)


def run(args) -> int:
    """Run ``visviva convert`` with parsed arguments; return the exit code.

    Parameters
    ----------
    args : argparse.Namespace
        From :func:`add_parser`'s parser.

    Returns
    -------
    int
        0 on success, 2 for input that cannot be read or an output that cannot be written.
    """
    import sys
    from pathlib import Path

    from ..cli_window import check_inputs, check_outputs, write_output
    from ..errors import VisvivaError

    try:
        check_inputs([args.input])
        check_outputs([args.output], [args.input], args.overwrite)
        # (a Path: a file name holding '=' is still a file name, and errors name the file)
        text = _input_text(Path(args.input))
        source = _kind_of_text(text)
        target = _output_kind(args)
        _check_options(args, source, target)
        fmt = _format(args)
        out = _convert(args, Path(args.input), text, source, target, fmt)
    except VisvivaError as exc:
        print(f"visviva convert: {exc}", file=sys.stderr)
        return 2
    return write_output("convert", args.output, out)


#: the options that shape an OEM sampled from a TLE or OMM, and their defaults
_SAMPLING = (("--start", "start", None), ("--hours", "hours", 24.0), ("--step", "step", 60.0),
             ("--frame", "frame", "GCRF"))


def _check_options(args, source: str, target: str) -> None:
    """Refuse options this conversion would not read, then fill in the sampling defaults.

    ``--frame ITRF`` on an OEM -> OEM re-encoding, or ``--hours 48`` on a TLE -> OMM, was
    ignored in silence (exit 0, the input's frame and span written)."""
    samples = target == "oem" and source != "oem"
    unused = [] if samples else [o for o, name, _ in _SAMPLING if getattr(args, name) is not None]
    if unused:
        why = ("an OEM is re-encoded with its own frame and times (rotate one in Python with "
               "vv.read_oem(path).segments[k].states_in(frame))" if source == "oem" else
               f"{'a' if target == 'tle' else 'an'} {target.upper()} output holds the mean "
               "elements, not sampled states")
        named = ", ".join(unused[:-1]) + " and " + unused[-1] if len(unused) > 1 else unused[0]
        raise InvalidInputError(f"{named} shape{'s' if len(unused) == 1 else ''} "
                                f"an OEM sampled from a TLE or OMM; {why}. Leave "
                                f"{'it' if len(unused) == 1 else 'them'} out.")
    if args.mission_epoch is not None and source != "oem":
        raise InvalidInputError("--mission-epoch reads an OEM input in TIME_SYSTEM MET or MRT; "
                                f"this input is a {source.upper()}. Leave it out.")
    for _, name, default in _SAMPLING:
        if getattr(args, name) is None:
            setattr(args, name, default)


def _input_text(path) -> str:
    """The text of the input: a CCSDS message strictly UTF-8 (a bad byte is refused naming its
    line), a TLE file as :func:`visviva.read_tle_file` reads it (names in UTF-8, else
    Latin-1)."""
    from ..satellites.catalog_files import decode_tle_bytes
    from .grammar import CCSDSFormatError
    from .layout import read_text

    try:
        return read_text(path)[0]
    except CCSDSFormatError as exc:
        try:
            text = decode_tle_bytes(path.read_bytes())
        except OSError:  # (no such file, a directory, no permission: read_text's message)
            raise exc from None
        head = text.lstrip()[:2000]
        if head.startswith("<") or "CCSDS_" in head:  # (a CCSDS message: stay strict)
            raise
        return text


def _convert(args, path, text, source, target, fmt) -> str:
    from .oem_io import read_oem, write_oem
    from .omm import read_omm, write_omm

    if source == "oem":
        if target != "oem":
            raise InvalidInputError("an OEM becomes a TLE or OMM only by a fit; use "
                                    "visviva.fit_tle on the ephemeris")
        from astropy.time import Time

        try:
            mission = Time(args.mission_epoch, scale="utc") if args.mission_epoch else None
        except ValueError:
            raise InvalidInputError(f"--mission-epoch {args.mission_epoch!r} is not an ISO "
                                    "date-time like 2024-01-31T12:00:00") from None
        return write_oem(read_oem(path, mission_epoch=mission), format=fmt)
    if source == "omm" and target == "omm" and not _is_ndm(text) and _one_omm(text):
        return write_omm(read_omm(path), format=fmt, originator=args.originator)
    if source == "omm" and target == "omm" and args.satnum is not None:
        message = _kvn_message(text, args.satnum)
        if message is not None:  # the whole message, not only what SGP4 takes
            from .grammar import CCSDSFormatError

            try:
                omm = read_omm(message)
            except CCSDSFormatError as exc:  # (named by the file, not "<text>")
                raise CCSDSFormatError(str(exc).split(": ", 1)[1], exc.line,
                                       str(path)) from None
            return write_omm(omm, format=fmt, originator=args.originator)
    sats = _satellites(args, path, text, source)
    if target == "tle":  # every element set, one after another
        return "".join(f"{sat.name}\n{line1}\n{line2}\n" for sat in sats
                       for line1, line2 in [sat.to_tle()])
    if target == "omm":
        records = [_omm_fields(sat) for sat in sats]
        if len(records) == 1:
            return write_omm(records[0], format=fmt, originator=args.originator)
        if fmt == "kvn":
            raise InvalidInputError(
                f"{args.input} holds {len(records)} element sets and a KVN OMM holds one (OMMs "
                "one after another are not a CCSDS file): write them all as an XML <ndm> of "
                "OMMs (--format xml or an output ending in .xml, as CelesTrak's GP data), or "
                "pick one with --satnum")
        from .omm import write_omm_ndm

        return write_omm_ndm(records, originator=args.originator)
    sat = _one(args, sats, "an OEM is sampled from one")
    return write_oem(_sample_oem(sat, args), format=fmt)


def _omm_fields(sat) -> dict:
    """The OMM keywords of an element set (an unknown international designator written as
    UNKNOWN, as the OMM requires one)."""
    fields = sat.to_omm()
    if not fields["OBJECT_ID"]:
        fields["OBJECT_ID"] = "UNKNOWN"
    return fields
