"""A synthetic LEO catalogue of SGP4 element sets, for tests, examples and benchmarks."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["synthetic_catalog"]

_MU_WGS72 = 398600.8  # km^3/s^2, the constant SGP4's WGS-72 mode uses
_RE_WGS72 = 6378.135  # km


def synthetic_catalog(n, *, seed=0, epoch="2024-01-01T00:00:00", crossing_pairs=0,
                      altitude=(400.0, 1200.0), bstar=1e-5):
    """``n`` random LEO objects plus ``crossing_pairs`` pairs built to pass within a few km.

    Parameters
    ----------
    n : int
        Number of random objects (near-circular, altitude uniform in ``altitude`` km,
        inclination 40-100 deg, all angles uniform).
    seed : int
        Random seed.
    epoch : str or astropy Time
        Element-set epoch (UTC).
    crossing_pairs : int
        Extra pairs sharing the node line and the mean anomaly to within ~0.02 deg at
        inclinations 53 and 97 deg: each pair meets near the equator every half revolution with
        misses of a few km.
    altitude : (float, float)
        Altitude range of the random objects, km.
    bstar : float
        B* drag term of every object (1 / earth radii).

    Returns
    -------
    Catalog
        Built from TLE lines (sgp4's exporter), so that it pickles; satellites named ``SYN<satnum>``, with satnums 10000+ (random) and 60000+ (pairs).
    """
    from astropy.time import Time
    from sgp4.api import WGS72, Satrec
    from sgp4.exporter import export_tle

    from ..satellites.catalog import Catalog
    from ..satellites.tle import Satellite
    from ..satellites.utc_days import time_to_utc_days

    t = Time(epoch, scale="utc")
    jd, fr = time_to_utc_days(t)  # sgp4's UTC days of 86,400 s
    days = float((jd - 2433281.5) + fr)  # days since 1949-12-31 00:00 UTC
    rng = np.random.default_rng(seed)

    def make(satnum, ecc, argp, inc, mo, alt, node):
        no_kozai = math.sqrt(_MU_WGS72 / (_RE_WGS72 + alt) ** 3) * 60.0  # rad/min
        s = Satrec()
        s.sgp4init(WGS72, "i", satnum, days, bstar, 0.0, 0.0, ecc, argp, inc, mo, no_kozai,
                   node)
        # through the TLE text, so that the satellites pickle (Dask workers rebuild them)
        line1, line2 = export_tle(s)
        return Satellite.from_tle(line1, line2, f"SYN{satnum}")

    sats = []
    for k in range(int(n)):
        sats.append(make(10000 + k, rng.uniform(0.0, 0.005), rng.uniform(0, 2 * math.pi),
                         math.radians(rng.uniform(40, 100)), rng.uniform(0, 2 * math.pi),
                         rng.uniform(*altitude), rng.uniform(0, 2 * math.pi)))
    for p in range(int(crossing_pairs)):
        alt = rng.uniform(500, 900)
        node = rng.uniform(0, 2 * math.pi)
        mo = rng.uniform(0, 2 * math.pi)
        sats.append(make(60000 + 2 * p, 0.0005, 0.0, math.radians(53), mo, alt, node))
        # (wrapped: sgp4's exporter refuses a mean anomaly outside [0, 2 pi), audit54)
        sats.append(make(60001 + 2 * p, 0.0005, 0.0, math.radians(97),
                         (mo + rng.uniform(-4e-4, 4e-4)) % (2 * math.pi), alt, node))
    return Catalog(sats)
