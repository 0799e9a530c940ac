"""Reference satellite data: SGP4/SDP4 through the ``sgp4`` package, TEME -> GCRS through astropy.

Three TLEs cover the near-Earth SGP4 branch (the ISS) and the deep-space SDP4 branch (a Molniya
orbit, 12 h resonance, and a geostationary orbit, 24 h resonance). The Molniya and GEO element
sets are built with ``Satrec.sgp4init`` and written out with ``sgp4.exporter.export_tle``, so their
lines are exactly what sgp4 parses. For each TLE the file holds TEME position and velocity at
offsets from the epoch and the same states rotated to GCRS by astropy (``TEME`` -> ``GCRS``).

Run ``python reference/generate_sgp4_astropy.py`` to rewrite
``reference/data/sgp4_astropy.json``. Skyfield's own GCRS states of the same TLEs (its
TEME -> GCRS chain, independent of astropy) are stored beside astropy's.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _provenance  # noqa: E402

NAME = "sgp4_astropy.json"
OFFSETS_MIN = (0.0, 10.0, 95.0, 360.0, 1440.0, 4320.0)

ISS = ("1 25544U 98067A   19343.69339541  .00001764  00000-0  38792-4 0  9991",
       "2 25544  51.6439 211.2001 0007417  17.6667  85.6398 15.50103472202482")


def _built_tles() -> dict[str, tuple[str, str]]:
    """Molniya and GEO element sets written by sgp4's own exporter."""
    from sgp4.api import WGS72, Satrec
    from sgp4.exporter import export_tle

    epoch_days = 26000.5  # days since 1949 December 31 00:00 UT (2021-03-08 12:00 UT)
    out = {}
    # name: (satnum, bstar, ecco, argpo deg, inclo deg, mo deg, no_kozai rev/day, nodeo deg)
    specs = {
        "molniya": (90001, 1.0e-4, 0.72, 270.0, 63.4, 10.0, 2.00563, 120.0),
        "geo": (90002, 0.0, 0.0002, 90.0, 0.05, 200.0, 1.00273791, 75.0),
    }
    for name, (satnum, bstar, ecco, argpo, inclo, mo, n_rev_day, nodeo) in specs.items():
        sat = Satrec()
        sat.sgp4init(WGS72, "i", satnum, epoch_days, bstar, 0.0, 0.0, ecco, np.radians(argpo),
                     np.radians(inclo), np.radians(mo), n_rev_day * 2 * np.pi / 1440.0,
                     np.radians(nodeo))
        out[name] = export_tle(sat)
    return out


def _skyfield_gcrs(line1: str, line2: str, t):
    """Skyfield's GCRS position and velocity of the same TLE at the same UTC instants."""
    from skyfield.api import EarthSatellite, load

    ts = load.timescale(builtin=True)
    sat = EarthSatellite(line1, line2, ts=ts)
    utc = t.utc
    tt = ts.tt_jd(utc.tt.jd1, utc.tt.jd2)
    at = sat.at(tt)
    return at.position.km.T, at.velocity.km_per_s.T


def generate() -> dict:
    """Build the whole data set (no file written)."""
    from astropy import units as u
    from astropy.coordinates import GCRS, TEME, CartesianDifferential, CartesianRepresentation
    from astropy.time import Time
    from sgp4.api import Satrec

    tles = {"iss": ISS, **_built_tles()}
    cases = []
    for name, (line1, line2) in tles.items():
        sat = Satrec.twoline2rv(line1, line2)
        epoch = Time(sat.jdsatepoch, sat.jdsatepochF, format="jd", scale="utc")
        offsets = np.array(OFFSETS_MIN)
        t = epoch + offsets * u.min
        err, r, v = sat.sgp4_array(t.jd1, t.jd2)
        rep = CartesianRepresentation(r.T * u.km,
                                      differentials=CartesianDifferential(v.T * u.km / u.s))
        gcrs = TEME(rep, obstime=t).transform_to(GCRS(obstime=t))
        cart = gcrs.cartesian
        sky_r, sky_v = _skyfield_gcrs(line1, line2, t)
        cases.append({
            "name": name,
            "line1": line1,
            "line2": line2,
            "epoch_jd_utc": [float(sat.jdsatepoch), float(sat.jdsatepochF)],
            "offsets_min": offsets,
            "sgp4_error": err,
            "teme_r_km": r,
            "teme_v_km_s": v,
            "gcrs_r_km": cart.xyz.to_value(u.km).T,
            "gcrs_v_km_s": cart.differentials["s"].d_xyz.to_value(u.km / u.s).T,
            "skyfield_gcrs_r_km": sky_r,
            "skyfield_gcrs_v_km_s": sky_v,
        })
    settings = {"gravity_model": "WGS72 (sgp4 default for twoline2rv)",
                "opsmode": "i", "offsets_min": OFFSETS_MIN,
                "time_scale": "epoch and offsets in UTC; offsets are in minutes from the TLE epoch",
                "astropy": "TEME(obstime=t) -> GCRS(obstime=t), astropy's default IERS handling",
                "skyfield": "EarthSatellite(line1, line2).at(t): GCRS, builtin timescale"}
    return _provenance.document(
        __file__, ("sgp4", "astropy", "skyfield"), settings,
        "SGP4/SDP4 states in TEME for a LEO, a Molniya and a GEO TLE, and the same states in "
        "GCRS through astropy and through Skyfield.",
        {"teme_r_km": "km", "teme_v_km_s": "km/s", "gcrs_r_km": "km", "gcrs_v_km_s": "km/s",
         "offsets_min": "min"}, cases)


if __name__ == "__main__":
    _provenance.main(NAME, generate)
