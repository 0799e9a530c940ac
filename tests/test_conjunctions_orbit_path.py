"""The orbit-path filter (Hoots et al. 1984) never drops a pair that comes close."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from visviva.core.orbit_path import (
    orbit_paths_close,
    path_geometry,
    path_rate,
    path_schedule,
)

RE = 6378.135


def _ellipse_points(p, e, inc, node, argp, n=12_000):
    nu = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    r = p / (1 + e * np.cos(nu))
    u = nu + argp
    cn, sn, ci, si = math.cos(node), math.sin(node), math.cos(inc), math.sin(inc)
    x = r * (cn * np.cos(u) - sn * np.sin(u) * ci)
    y = r * (sn * np.cos(u) + cn * np.sin(u) * ci)
    z = r * (np.sin(u) * si)
    return np.stack([x, y, z], axis=1)


orbit = st.tuples(
    st.floats(6700.0, 30000.0),  # semi-major axis, km
    st.floats(0.0, 0.6),  # eccentricity
    st.floats(0.0, math.pi),  # inclination
    st.floats(0.0, 2 * math.pi),  # node
    st.floats(0.0, 2 * math.pi),  # argument of perigee
)


@settings(max_examples=60, deadline=None)
@given(orbit, orbit, st.floats(1.0, 200.0), st.booleans())
def test_never_drops_orbits_closer_than_the_distance(o1, o2, dist, near):
    # fixed ellipses: the filter drops a pair only if their minimum distance (brute force over
    # 12,000 points per orbit, a few km apart) exceeds the distance less the spacing
    if near:  # make the second orbit pass close to the first: same node, perigee radius near
        o2 = (o2[0], o2[1], o2[2], o1[3], o1[4])
    el = np.array([[a * (1 - e * e), e, i, n, w, 0.0, 0.0] for a, e, i, n, w in (o1, o2)])
    keep = _close(el, dist)
    if not keep:
        pts = [_ellipse_points(*el[k, :5]) for k in range(2)]
        moid, _ = cKDTree(pts[1]).query(pts[0], k=1)
        spacing = max(np.max(np.linalg.norm(np.diff(x, axis=0), axis=1)) for x in pts)
        assert moid.min() > dist - spacing


def test_equatorial_orbit_found_by_hypothesis():
    # an equatorial eccentric orbit (no node line of its own) against an inclined circle
    el = np.array([[12823.0 * (1 - 0.5625**2), 0.5625, 0.0, 3.796875, 0.546875, 0.0, 0.0],
                   [17241.0, 0.0, 1.0, 1.703125, 0.0, 0.0, 0.0]])
    assert _close(el, 63.0)  # the orbits come within 52 km


def test_it_prunes_and_keeps_what_it_should():
    # two circular orbits 100 km apart in radius, crossing planes: dropped at 50 km, kept at 150
    el = np.array([[7000.0, 0.0, 0.9, 0.0, 0.0, 0.0, 0.0],
                   [7100.0, 0.0, 1.2, 1.0, 0.0, 0.0, 0.0]])
    assert not _close(el, 50.0)
    assert _close(el, 150.0)
    # an eccentric orbit with its perigee on the mutual node line at the other's radius: kept
    el[1] = [7000.0 * 1.1, 0.1, 1.2, 1.0, 0.0, 0.0, 0.0]
    el[0, 3] = 1.0  # same node: the mutual node line is the line of nodes, perigee on it
    assert _close(el, 5.0)
    # coplanar: always kept
    el[1] = [7100.0, 0.0, 0.9, 1.0, 0.0, 0.0, 0.0]
    assert _close(el, 5.0)


def test_drift_chunks_bound_the_displacement():
    el = np.array([[7000.0, 0.001, 1.0, 0.0, 0.0, -1.1e-6, 1.3e-6]])
    t_mid, length = path_schedule(path_rate(el), 86400.0)
    assert t_mid.size * length == pytest.approx(86400.0)
    const, geom = path_geometry(el, 86400.0, path_rate(el))
    assert geom.shape == (1, t_mid.size, 6)
    assert const[0, 4] <= 20.0 + 1e-9  # displacement over half a chunk (default 20 km)
    assert np.allclose(np.linalg.norm(geom[0, :, :3], axis=1), 1.0)
    assert path_schedule(0.0, 3600.0) == (np.array([1800.0]), 3600.0)


@settings(max_examples=20, deadline=None)
@given(st.floats(0.0, 0.25), st.floats(0.0, 0.25), st.floats(0.3, 2.8), st.floats(0.3, 2.8),
       st.floats(0.0, 2 * math.pi), st.floats(-0.003, 0.003), st.floats(300.0, 1500.0))
def test_sgp4_pairs_found_by_one_second_sampling_pass_the_filter(e1, e2, i1, i2, node, dm,
                                                                 alt):
    # SGP4 pairs built to meet: both at perigee on the same ascending node at t0 (mean anomalies
    # dm apart, up to ~20 km), any eccentricities and inclinations; whenever one-second
    # sampling over 3 h sees them within 30 km (nearly always), the filter keeps the pair
    from astropy.time import Time
    from sgp4.api import WGS72, Satrec
    from sgp4.exporter import export_tle

    from visviva.conjunctions.sources import SgpSource
    from visviva.satellites import Catalog, Satellite

    t0 = Time("2024-01-01T00:00:00", scale="utc")
    days = float((t0.utc.jd1 - 2433281.5) + t0.utc.jd2)
    sats = []
    for k, (e, inc, mo) in enumerate(((e1, i1, 0.0), (e2, i2, dm % (2 * math.pi)))):
        a = (RE + alt) / (1 - e)  # same perigee radius
        s = Satrec()
        s.sgp4init(WGS72, "i", 70000 + k, days, 1e-5, 0.0, 0.0, e, 0.0, inc, mo,
                   math.sqrt(398600.8 / a**3) * 60.0, node)
        line1, line2 = export_tle(s)
        sats.append(Satellite.from_tle(line1, line2, f"P{k}"))
    cat = Catalog(sats)
    src = SgpSource(cat, float(t0.utc.jd1), float(t0.utc.jd2))
    ts = np.arange(0.0, 3 * 3600.0 + 1)
    r, _ = src.sample(ts)
    dmin = float(np.nanmin(np.linalg.norm(r[1] - r[0], axis=-1)))
    keep = _close(src.path_elements(), 30.0 + 60.0, ts[-1])
    if dmin < 30.0:
        assert keep


def _close(el7, dist, span=0.0):
    el7 = np.asarray(el7, dtype=np.float64)
    el, g = path_geometry(el7, max(span, 1.0), path_rate(el7))
    return orbit_paths_close(el, g, 0, el, g, 1, dist)
