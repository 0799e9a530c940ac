"""Ground tracks and eclipse fractions (visviva.satellites.groundtrack) against Skyfield and astropy."""

from __future__ import annotations

import os

import numpy as np
import pytest
from astropy import units as u

import visviva as vv
from visviva.errors import InvalidInputError, UnitsError
from visviva.satellites import eclipse_fraction, ground_track
from visviva.satellites.groundtrack import eclipse_intervals

# the ISS element set of the other tests, moved to epoch 2015-03-01 12:00 UTC so that Skyfield's
# DE430 excerpt (2015-02-26 .. 03-06) covers a day of it
L1 = "1 25544U 98067A   15060.50000000  .00016717  00000-0  10270-3 0  9005"
L2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391 44001"


@pytest.fixture(scope="module")
def iss():
    return vv.Satellite.from_tle(L1, L2, verify_checksum=False)


def test_ground_track_agrees_with_skyfield_subpoint_and_astropy(iss, skyfield_ts):
    from astropy.coordinates import ITRS, TEME, CartesianRepresentation, EarthLocation
    from skyfield.api import EarthSatellite, wgs84

    t = iss.epoch + np.linspace(0, 1, 200) * u.day
    track = ground_track(iss, t)
    at = EarthSatellite(L1, L2, "ISS", skyfield_ts).at(skyfield_ts.from_astropy(t))
    sub = wgs84.subpoint_of(at)
    # with the same polar motion table: 1e-5 deg is 1 m on the ground
    assert np.abs(track.latitude.to_value(u.deg) - sub.latitude.degrees).max() < 1e-5
    dlon = (track.longitude.to_value(u.deg) - sub.longitude.degrees + 180) % 360 - 180
    assert np.abs(dlon).max() < 1e-5
    assert np.abs(track.height.to_value(u.km) - wgs84.height_of(at).km).max() < 1e-3
    # the same TEME states through astropy's frames and EarthLocation: to rounding
    teme = iss.teme(t)
    itrs = TEME(CartesianRepresentation(teme.r.T), obstime=t).transform_to(ITRS(obstime=t))
    loc = EarthLocation.from_geocentric(*itrs.cartesian.xyz)
    assert np.abs(track.latitude.to_value(u.deg) - loc.lat.deg).max() < 1e-9
    assert np.abs((track.longitude.to_value(u.deg) - loc.lon.deg + 180) % 360 - 180).max() < 1e-9
    assert np.abs(track.height.to_value(u.km) - loc.height.to_value(u.km)).max() < 1e-9
    lon = track.longitude.to_value(u.deg)
    assert np.all((-180 <= lon) & (lon < 180))
    # 16 orbits a day: the track crosses the antimeridian about 16 times
    assert 14 <= len(track.segments()) <= 18


def test_eclipse_fraction_agrees_with_skyfield_is_sunlit(iss, skyfield_ts):
    import skyfield
    from skyfield.api import EarthSatellite
    from skyfield.jpllib import SpiceKernel

    path = os.path.join(os.path.dirname(skyfield.__file__), "tests", "data", "de430-2015-03-02.bsp")
    if not os.path.exists(path):
        pytest.skip("skyfield's DE430 test excerpt is not installed")
    t = iss.epoch + np.arange(0, 86400, 10.0) * u.s
    frac = eclipse_fraction(iss, t)
    lit = EarthSatellite(L1, L2, "ISS", skyfield_ts).at(skyfield_ts.from_astropy(t))
    lit = lit.is_sunlit(SpiceKernel(path))
    # Skyfield asks whether the line to the Sun's centre misses the Earth: lit where the whole
    # disc is visible, dark in the umbra, and mostly the side of the half-visible disc between
    assert np.all(lit[frac > 0.9]) and not np.any(lit[frac < 0.1])
    assert 0.25 < 1 - frac.mean() < 0.4  # the ISS spends up to ~40 % of its orbit in shadow
    spans = eclipse_intervals(t, frac)
    assert 15 <= len(spans) <= 17


def test_ground_track_refuses_plain_numbers_and_non_satellites(iss):
    # plain numbers were added to the epoch as days by astropy ([1.0, 2.0] -> one and two days)
    with pytest.raises(UnitsError, match="Quantity"):
        ground_track(iss, [1.0, 2.0])
    with pytest.raises(UnitsError, match="Quantity"):
        eclipse_fraction(iss, 30.0)
    # anything but a Satellite or Catalog gave AttributeError/TypeError from inside
    with pytest.raises(InvalidInputError, match="Satellite"):
        ground_track("ISS", [1.0] * u.min)
    state = vv.StateVectors([7000, 0, 0] * u.km, [0, 7.5, 0] * u.km / u.s, vv.EARTH)
    with pytest.raises(InvalidInputError, match="Satellite"):
        eclipse_fraction(state, [1.0] * u.min)


def test_ground_track_at_one_time_and_mismatched_eclipse_intervals(iss):
    one = ground_track(iss, 3 * u.min)
    assert one.latitude.shape == ()
    assert one.segments() == [slice(0, 1)]  # numpy's "diff requires 1-D input" before
    t = iss.epoch + np.arange(5) * u.min
    with pytest.raises(InvalidInputError, match="same length"):
        eclipse_intervals(t[:3], np.ones(5))


def test_a_polar_track_is_split_over_each_pole_and_at_the_antimeridian():
    """audit38: a 90 deg orbit sampled each minute turns its longitude by 179.75 deg over a
    pole, below the 180 deg of an antimeridian wrap, so segments() joined the two sides by a
    line across the map (3 pieces in 200 min instead of 7 or 8)."""
    from astropy.time import Time

    from visviva.satellites.groundtrack import GroundTrack

    t = Time("2024-01-01", scale="utc") + np.arange(0, 200.0) * u.min
    u_arg = np.deg2rad(np.arange(200.0) * 360.0 / 94.7)  # argument of latitude, i = 90 deg
    lat = np.rad2deg(np.arcsin(np.sin(u_arg)))
    lon_i = np.where(np.cos(u_arg) >= 0, 0.0, 180.0) - 0.25 * np.arange(200.0)
    lon = (lon_i + 180.0) % 360.0 - 180.0
    track = GroundTrack(t, lat * u.deg, lon * u.deg, np.full(200, 500.0) * u.km)
    pieces = track.segments()
    # within each piece the longitude moves smoothly
    for seg in pieces:
        assert np.all(np.abs(np.diff(lon[seg])) < 2.0)
    # every pole passage (cos u changes sign) starts a new piece
    poles = np.flatnonzero(np.diff(np.sign(np.cos(u_arg))) != 0) + 1
    starts = {seg.start for seg in pieces}
    assert set(poles.tolist()) <= starts
    assert len(pieces) >= len(poles) + 1
