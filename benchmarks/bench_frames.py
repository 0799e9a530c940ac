"""Catalogue frame changes: TEME -> GCRS / ITRS for N satellites x T times.

visviva builds one 6 x 6 map per time from astropy's own rotation matrices (the precession-
nutation matrix interpolated between hourly nodes) and applies it to every satellite; the
reference is astropy's frame graph (``TEME(...).transform_to(GCRS(...))``) on the same states in
one call, which is what the catalogue did before (3 satellites x 1441 times: 3.4 s).
"""

from __future__ import annotations

import numpy as np

try:  # as part of the package (python -m benchmarks) or as a script
    from .common import compile_time, quick_from_env, result, time_call
except ImportError:  # pragma: no cover
    from common import compile_time, quick_from_env, result, time_call

ISS = ("1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
       "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340")


def run(quick: bool = False) -> list[dict]:
    from astropy import units as u
    from astropy.time import Time

    import visviva as vv
    from visviva.satellites.frames import _transform

    quick = quick or quick_from_env()
    sat = vv.Satellite.from_tle(*ISS, name="ISS")
    cat = vv.Catalog([sat] * 3)
    t = Time("2024-01-01T12:00:00", scale="utc") + np.arange(1441) * u.min
    teme = cat.propagate(t)
    r, v = teme.r.to_value(u.km), teme.v.to_value(u.km / u.s)
    rows = []
    for frame in ("gcrs", "itrs"):
        first = compile_time(cat.propagate, t, frame=frame)
        ours = time_call(cat.propagate, t, frame=frame, repeat=3 if quick else 7)
        ref = time_call(_transform, r, v, t[None, :], "teme", frame, repeat=1 if quick else 3,
                        number=1, warmup=0)
        rows.append(result(
            f"catalogue TEME -> {frame.upper()}, 3 satellites x 1441 times (with SGP4)",
            ours.median, "astropy frame graph on the same states, one call", ref.median,
            target=0.1 if frame == "gcrs" else 1.0, compile_s=first,
            notes="one 6x6 map per time from astropy's rotation matrices, shared by all "
            "satellites" + ("" if frame == "gcrs" else "; astropy's TEME -> ITRS was never slow "
                            "(no precession-nutation series)"),
        ))
    return rows


if __name__ == "__main__":  # pragma: no cover
    import sys

    for row in run(quick="--quick" in sys.argv):
        print(row)
