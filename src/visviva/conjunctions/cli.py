"""``visviva screen``: screen an element-set file against itself for close approaches.

The file is read by :func:`visviva.read_catalog_file`: TLE, OMM JSON/CSV/XML or a CCSDS OMM.
"""

from __future__ import annotations


def add_parser(sub) -> None:
    """Add the ``screen`` sub-command to ``sub`` (an argparse sub-parsers object)."""
    p = sub.add_parser(
        "screen", help="screen a catalogue (TLE or OMM) against itself for close approaches (SGP4)",
        description="Find every close approach below --threshold between the objects of an "
        "element-set file over a window, with TCA within 1 ms and the miss vector in the "
        "primary's RTN frame.")
    from ..cli_window import add_catalog_argument

    add_catalog_argument(p)
    p.add_argument("--threshold", type="km", default=5.0, metavar="KM",
                   help="reporting distance in km (default 5)")
    p.add_argument("--start", required=True, metavar="ISO", help="start of the window (UTC)")
    p.add_argument("--hours", type="hours", required=True, metavar="H", help="window length")
    p.add_argument("--step", type="seconds", default=60.0, metavar="S",
                   help="sampling step of the filters in seconds (default 60; at most 1/8 of "
                        "the shortest orbital period)")
    p.add_argument("--primary", default=None, metavar="NAME|NUMBER",
                   help="screen only this object (its name, or its catalogue number) "
                        "against the rest")
    p.add_argument("--csv", default=None, metavar="PATH", help="also write the table as CSV")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    from ..cli_window import add_overwrite_argument

    add_overwrite_argument(p)


def run(args) -> int:
    """Run ``visviva screen``; returns the exit code (0, or 2 for bad input)."""
    import io
    import sys

    from astropy import units as u

    from .._text import replace_text_file
    from ..cli_window import check_outputs, window_from_args
    from ..errors import VisvivaError
    from ..satellites.catalog import read_catalog_file
    from .screening import screen_conjunctions

    try:
        check_outputs([args.csv], [args.tle_file], args.overwrite)
        cat = read_catalog_file(args.tle_file)
        t0, t1 = window_from_args(args.start, args.hours)
        if args.primary is not None:
            prim = _primary(cat, args.primary, args.tle_file)
            # against the whole file (never paired with itself), so that index2 is the
            # secondary's position in the file (it counted the file without the primary)
            tab = screen_conjunctions(prim, cat, t0, t1, args.threshold * u.km,
                                      step=args.step * u.s, progress=not args.quiet)
        else:
            tab = screen_conjunctions(cat, None, t0, t1, args.threshold * u.km,
                                      step=args.step * u.s, progress=not args.quiet)
    except (VisvivaError, KeyError, ValueError, OSError) as exc:
        reason = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"visviva screen: {reason}", file=sys.stderr)
        return 2
    print(f"{len(tab)} close approaches below {args.threshold:g} km between {t0.isot} and "
          f"{t1.isot} ({len(cat)} objects)")
    for row in tab:
        print(f"{row['tca'].isot}  {row['object1']:>24s} {row['satnum1']:>9d}  "
              f"{row['object2']:>24s} {row['satnum2']:>9d}  "
              f"miss {row['miss_distance'].to_value(u.km):9.3f} km  "
              f"v_rel {row['relative_speed'].to_value(u.km / u.s):7.3f} km/s  "
              f"RTN ({row['radial'].to_value(u.km):8.3f}, {row['in_track'].to_value(u.km):8.3f}, "
              f"{row['cross_track'].to_value(u.km):8.3f}) km")
    if args.csv:
        try:
            text = io.StringIO()
            tab.write(text, format="ascii.csv")
            replace_text_file(args.csv, text.getvalue())  # whole or not at all
        except OSError as exc:
            print(f"visviva screen: cannot write {args.csv}: {exc}", file=sys.stderr)
            return 2
    return 0


def _primary(cat, which, path):
    """The ``--primary`` object: by name, or by catalogue number where no object has that name
    (names repeat: "FENGYUN 1C DEB"; before audit46 a repeated name could not be screened)."""
    import numpy as np

    from ..errors import fmt_first

    if which in cat.names and cat.names.count(which) == 1:
        return cat[which]
    text = which.strip()
    if text.isdigit():
        rows = np.flatnonzero(cat.satnums == int(text))
        if rows.size == 1:
            return cat[int(rows[0])]
        if rows.size > 1:
            raise KeyError(f"{path} holds {rows.size} element sets numbered {text}: keep one "
                           "set per object in the file")
    if which in cat.names:
        numbers = ", ".join(str(s.satnum) for s in cat if s.name == which)
        raise KeyError(f"{cat.names.count(which)} objects of {path} are named {which!r} "
                       f"(catalogue numbers {numbers}): give --primary the catalogue number")
    raise KeyError(f"no object named {which!r} in {path}, nor numbered so (it has "
                   f"{fmt_first([repr(n) for n in cat.names], 10)})")
