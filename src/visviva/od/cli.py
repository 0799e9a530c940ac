"""``visviva fit-tle EPHEMERIS``: fit SGP4 mean elements to a CCSDS OEM and print the TLE or OMM."""

from __future__ import annotations


def add_parser(sub) -> None:
    """Add the ``fit-tle`` sub-command to an argparse sub-parser group.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The group.
    """
    p = sub.add_parser(
        "fit-tle", help="fit a TLE (SGP4 mean elements and B*) to an OEM ephemeris",
        description="Fit SGP4 mean elements (and B*) by differential correction to every state "
        "of a CCSDS OEM (KVN or XML; GCRF/EME2000/ICRF, TEME or ITRF) and write the TLE lines "
        "or an OMM. The fit's RMS and largest position difference go to standard error.")
    p.add_argument("ephemeris", help="OEM file (KVN or XML)")
    p.add_argument("--satnum", type="satnum", default=99999,
                   help="catalogue number of the new element set, up to nine digits (default "
                   "99999, or the --initial set's)")
    p.add_argument("--initial", default=None, metavar="FILE",
                   help="an earlier element set of the object (TLE or OMM file; with several "
                   "objects, the one numbered --satnum): carries the revolution number forward "
                   "and gives the catalogue number and B*")
    p.add_argument("--name", default=None, help="object name (default: the OEM's OBJECT_NAME)")
    p.add_argument("--epoch", default=None, metavar="ISO",
                   help="epoch of the element set, UTC (default: the first state)")
    p.add_argument("--mission-epoch", default=None, metavar="ISO",
                   help="UTC epoch that an OEM in TIME_SYSTEM MET (launch) or MRT counts from")
    p.add_argument("--no-bstar", action="store_true", help="hold B* fixed instead of fitting it")
    p.add_argument("--bstar", type="per-earth-radius", default=None,
                   help="B* (1/earth radii): held value, or first guess (default: the --initial "
                   "set's, else 0)")
    p.add_argument("--to", choices=("tle", "omm"), default="tle",
                   help="output: TLE lines (default) or an OMM in KVN")
    p.add_argument("--output", "-o", default="-", help="file to write (default: standard output)")
    from ..cli_window import add_overwrite_argument

    add_overwrite_argument(p)


def run(args) -> int:
    """Run ``visviva fit-tle``; returns the exit code (0 on success, 1 on a failed fit, 2 for an
    ephemeris or ``--initial`` file that cannot be read or an output that cannot be written).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments of :func:`add_parser`.
    """
    import sys
    from pathlib import Path

    from ..ccsds.oem_io import read_oem
    from ..cli_window import check_inputs, check_outputs, time_from_arg, write_output
    from ..errors import VisvivaError
    from .tle_fit import fit_tle

    try:
        check_inputs([args.ephemeris])
        check_outputs([args.output], [args.ephemeris, args.initial], args.overwrite)
        mission = (time_from_arg("--mission-epoch", args.mission_epoch) if args.mission_epoch
                   else None)
        try:
            eph = read_oem(Path(args.ephemeris), mission_epoch=mission)
        except VisvivaError as exc:  # (a TLE or OMM given: say what fit-tle is for)
            print(f"visviva fit-tle: {exc}{_element_set_hint(args.ephemeris)}", file=sys.stderr)
            return 2
        epoch = time_from_arg("--epoch", args.epoch) if args.epoch else None
        near = epoch if epoch is not None else eph.segments[0].times[0]
        initial = _initial(args.initial, args.satnum, near) if args.initial else None
    except (VisvivaError, ValueError) as exc:  # the files, --mission-epoch or --epoch
        print(f"visviva fit-tle: {exc}", file=sys.stderr)
        return 2
    try:
        name = args.name
        if name is None:
            name = str(eph.segments[0].metadata.get("OBJECT_NAME", "")) or None
        object_id = str(eph.segments[0].metadata.get("OBJECT_ID", "")).strip()
        if object_id.upper() in ("", "UNKNOWN") or not object_id[:4].isdigit():
            object_id = None
        sat = fit_tle(eph, satnum=args.satnum, fit_bstar=not args.no_bstar, bstar=args.bstar,
                      epoch=epoch, name=name, object_id=object_id, initial=initial)
        if args.to == "tle":
            line1, line2 = sat.to_tle()
            text = (f"{name}\n" if name else "") + f"{line1}\n{line2}\n"
        else:
            from ..ccsds.omm import write_omm

            fields = sat.to_omm()
            fields["OBJECT_ID"] = fields["OBJECT_ID"] or "UNKNOWN"
            text = write_omm(fields, originator="VISVIVA")
    except (VisvivaError, OSError, ValueError) as exc:
        print(f"visviva fit-tle: {exc}", file=sys.stderr)
        return 1
    fit = sat.fit
    print(f"fitted {fit.n_states} states in {fit.iterations} iterations: position RMS "
          f"{fit.rms_position_km * 1e3:.3f} m, max {fit.max_position_km * 1e3:.3f} m, "
          f"B* {sat.satrec.bstar:.5e}"
          + (f" +- {fit.sigma_bstar:.1e}" if fit.sigma_bstar is not None else " (held)"),
          file=sys.stderr)
    return write_output("fit-tle", args.output, text)


def _initial(path: str, satnum: int, near):
    """The element set of ``--initial``: of the file's one object (a history of its sets,
    audit49: refused before without ``--satnum``) or the one numbered ``satnum``, the set whose
    epoch is nearest ``near`` (the new set's epoch; the newest before audit49)."""
    import warnings

    from ..errors import InvalidInputError
    from ..satellites.catalog import read_catalog_file

    with warnings.catch_warnings():  # (a history repeats its number: one set is taken)
        warnings.filterwarnings("ignore", ".*appears more than once", UserWarning)
        cat = read_catalog_file(path)
    match = [s for s in cat if s.satnum == satnum or len(set(cat.satnums)) == 1]
    if not match:
        numbers = ", ".join(str(n) for n in cat.satnums[:10])
        raise InvalidInputError(f"{path} holds {len(cat)} element sets ({numbers}"
                                f"{', ...' if len(cat) > 10 else ''}); pick the object with "
                                "--satnum")
    return min(match, key=lambda s: abs((s.epoch - near).jd))


def _element_set_hint(path) -> str:
    """What to do when the ephemeris file holds element sets (a TLE, an OMM, GP data) instead
    of an OEM (audit51: it said only "an OEM starts with CCSDS_OEM_VERS"); "" otherwise."""
    try:
        with open(path, "rb") as f:
            head = f.read(4000).decode("utf-8", "replace")
    except OSError:
        return ""
    if "CCSDS_OEM_VERS" in head or "<oem" in head:
        return ""
    lines = [line.strip() for line in head.splitlines()]
    tle = any(a.startswith("1 ") and b.startswith("2 ") for a, b in zip(lines[:-1], lines[1:], strict=True))
    omm = "CCSDS_OMM_VERS" in head or "<omm" in head or "MEAN_MOTION" in head
    if not (tle or omm):
        return ""
    return (f". {path} holds element sets ({'TLE' if tle else 'OMM'}), not an ephemeris: "
            "fit-tle fits element sets TO an OEM ephemeris; the element sets are ready to use "
            "as they are (to sample them into an OEM: visviva convert "
            f"{path} out.oem)")
