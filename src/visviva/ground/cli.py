"""``visviva passes``: the passes of every satellite in an element-set file over one site.

The file is read by :func:`visviva.read_catalog_file`: TLE (two or three lines per satellite),
OMM JSON, CSV or XML (CelesTrak's GP data) or a CCSDS OMM (KVN or XML), told by content.

Example::

    visviva passes stations.tle --lat 52.2 --lon 0.12 --start 2024-05-01T18:00 --hours 12 \\
        --min-elevation 10 --csv passes.csv

prints one line per pass (rise, culmination, set in UTC, maximum elevation, azimuths, sunlit,
station dark) sorted by rise time; ``--mask FILE`` takes the site's horizon from a file of
azimuth/elevation pairs (:meth:`visviva.ElevationMask.from_file`) instead of one
``--min-elevation``; ``--csv`` / ``--ecsv`` also write the full table.
"""

from __future__ import annotations

import sys


def add_parser(sub) -> None:
    p = sub.add_parser(
        "passes", help="passes of the satellites of an element-set file over a ground site",
        description="Rise, culmination and set of every satellite of an element-set file over "
        "one site, with maximum elevation, azimuths and visibility (sunlit satellite, dark "
        "site).")
    from ..cli_window import add_catalog_argument

    add_catalog_argument(p)
    p.add_argument("--lat", type="degrees", required=True, metavar="DEG",
                   help="geodetic latitude, degrees north")
    p.add_argument("--lon", type="degrees", required=True, metavar="DEG",
                   help="longitude, degrees east")
    p.add_argument("--height", type="metres", default=0.0, metavar="M",
                   help="height above the WGS-84 ellipsoid, metres (default 0)")
    p.add_argument("--start", required=True, metavar="ISO",
                   help="start of the window, ISO time in UTC (e.g. 2024-05-01T18:00)")
    p.add_argument("--hours", type="hours", default=24.0, metavar="H",
                   help="length of the window, hours (default 24)")
    p.add_argument("--min-elevation", type="degrees", default=0.0, metavar="DEG",
                   help="minimum elevation, degrees (default 0)")
    p.add_argument("--mask", default=None, metavar="FILE",
                   help="the site's terrain / elevation mask: a text file of 'azimuth "
                   "elevation' lines in degrees ('#' comments), linear in azimuth, wrapping "
                   "360 -> 0; replaces --min-elevation")
    p.add_argument("--refraction", choices=("optical", "radio"), default=None,
                   help="rise and set on the apparent (refracted) horizon, the standard air at "
                   "the site's height: 'optical' (light) or 'radio' (antennas); default: "
                   "geometric elevations")
    p.add_argument("--visible", action="store_true",
                   help="only passes with the satellite sunlit and the site dark")
    p.add_argument("--csv", default=None, metavar="PATH", help="also write the table as CSV")
    p.add_argument("--ecsv", default=None, metavar="PATH",
                   help="also write the table as ECSV (keeps units and masks)")
    from ..cli_window import add_overwrite_argument

    add_overwrite_argument(p)


def _fmt_time(t) -> str:
    """UTC to the nearest second (``strftime`` cut the fraction: up to 1 s early)."""
    if getattr(t, "mask", False):
        return "--"
    shown = t.utc.copy(format="iso")
    shown.precision = 0
    return str(shown.value)


def format_table(table) -> str:
    """The pass table as aligned text lines (a header and one line per pass); the catalogue
    number beside the name, as names repeat (audit46)."""
    import numpy as np

    head = (f"{'satellite':<24} {'number':>9} {'rise (UTC)':<19} {'culmination':<19} {'set':<19} "
            f"{'max el':>7} {'az rise':>7} {'az set':>7} {'sunlit':>6} {'dark':>5}")
    lines = [head, "-" * len(head)]
    for row in table:
        az_r = row["rise_azimuth"]
        az_s = row["set_azimuth"]
        lines.append(
            f"{str(row['satellite'])[:24]:<24} {int(row['satnum']):>9d} "
            f"{_fmt_time(row['rise_time']):<19} "
            f"{_fmt_time(row['culmination_time']):<19} {_fmt_time(row['set_time']):<19} "
            f"{row['max_elevation'].to_value('deg'):7.1f} "
            f"{'--' if np.ma.is_masked(az_r.value) else format(az_r.to_value('deg'), '.1f'):>7} "
            f"{'--' if np.ma.is_masked(az_s.value) else format(az_s.to_value('deg'), '.1f'):>7} "
            f"{'yes' if row['sunlit'] else 'no':>6} {'yes' if row['station_dark'] else 'no':>5}")
    return "\n".join(lines)


def run(args) -> int:
    from astropy import units as u

    from ..cli_window import check_outputs, window_from_args
    from ..errors import InvalidInputError, VisvivaError
    from ..satellites.catalog import read_catalog_file
    from .mask import ElevationMask
    from .passes import find_passes, write_passes
    from .station import GroundStation

    try:
        check_outputs([args.csv, args.ecsv], [args.tle_file], args.overwrite)
        t0, t1 = window_from_args(args.start, args.hours)
        cat = read_catalog_file(args.tle_file)
        site = GroundStation(args.lat * u.deg, args.lon * u.deg, args.height * u.m,
                             name=f"{args.lat:g}, {args.lon:g}")
        if args.mask is not None and args.min_elevation != 0.0:
            raise InvalidInputError("give --mask or --min-elevation, not both: the mask is "
                                    "the minimum elevation at each azimuth.")
        threshold = (args.min_elevation * u.deg if args.mask is None
                     else ElevationMask.from_file(args.mask))
        table = find_passes(cat, site, t0, t1, threshold, refraction=args.refraction or False)
    except (VisvivaError, OSError) as exc:  # bad arguments: the file, the site, the window
        print(f"visviva passes: {exc}", file=sys.stderr)
        return 2
    if args.visible:
        table = table[table["visible"]]
    print(format_table(table))
    above = (f"{args.min_elevation:g} deg" if args.mask is None
             else f"the mask of {args.mask} ({threshold.lowest.to_value(u.deg):g} to "
             f"{threshold.highest.to_value(u.deg):g} deg)")
    print(f"{len(table)} pass(es) of {len(cat)} satellite(s) above {above} "
          f"({table.meta['elevation']}) between {t0.isot} and {t1.isot} UTC")
    for path, fmt in ((args.csv, "csv"), (args.ecsv, "ecsv")):
        if path:
            try:
                write_passes(table, path, format=fmt)
            except (VisvivaError, OSError) as exc:
                print(f"visviva passes: cannot write {path}: {exc}", file=sys.stderr)
                return 2
    return 0

