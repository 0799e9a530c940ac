"""simulate_tracking with the atmosphere in its data (troposphere=, ionosphere=, frequency_hz=):
each value is simulate_observations' at its time, and the media move the data by their
physical size (troposphere: 2.3-2.6 m of zenith delay mapped to the slant; ionosphere: 40.3 TEC
/ f^2 at S band, 0.083 m per TECU at the zenith)."""

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv
from visviva.od import simulate_observations, simulate_tracking

EPOCH = Time("2024-03-01T00:00:00", scale="utc")
KMS = u.km / u.s
Y0 = np.array([6878.0, 0.0, 0.0, 0.0, 4.7, 5.9])  # 500 km, i = 51.5 deg
TRUTH = vv.StateVectors(Y0[:3] * u.km, Y0[3:] * KMS, vv.EARTH, epoch=EPOCH)
STATIONS = [vv.GroundStation(40 * u.deg, -10 * u.deg, 0.1 * u.km, name="A"),
            vv.GroundStation(-30 * u.deg, 120 * u.deg, 0.5 * u.km, name="B")]
GRID = EPOCH + np.arange(0, 12 * 3600, 30.0) * u.s
MEAS = {"range": 5 * u.m, "range_rate": 1 * u.mm / u.s, "azel": 20 * u.arcsec}
MEDIA = {
    "troposphere": {"troposphere": True},
    "ionosphere": {"ionosphere": {"vtec_tecu": 30.0}, "frequency_hz": 2.2 * u.GHz},
}


def _values(obs):
    return [obs.values[i, : obs.dims[i]] for i in range(len(obs))]


@pytest.fixture(scope="module")
def plain():
    return simulate_tracking(TRUTH, STATIONS, GRID, measurements=MEAS, seed=False)


@pytest.mark.parametrize("which", list(MEDIA))
def test_tracking_with_the_media_equals_simulate_observations(plain, which):
    media = MEDIA[which]
    obs = simulate_tracking(TRUTH, STATIONS, GRID, measurements=MEAS, seed=False, **media)
    assert len(obs) > 60
    same = simulate_observations(TRUTH, obs.times, list(obs.kinds), list(obs.sigmas),
                                 obs.stations, seed=False, **media)
    np.testing.assert_array_equal(obs.values, same.values)
    assert (obs.troposphere is not None) == (which == "troposphere")
    assert (obs.ionosphere is not None) == (which == "ionosphere")
    # the media in the data: range delays of the physical size at the rows both tables hold
    key = {(t, k, s.name): v for t, k, s, v in zip(plain.times.isot, plain.kinds,
                                                   plain.stations, plain.values[:, 0],
                                                   strict=True)}
    rng = [(v - key[(t, "range", s.name)]) * 1e3
           for t, k, s, v in zip(obs.times.isot, obs.kinds, obs.stations, obs.values[:, 0],
                                 strict=True) if k == "range" and (t, k, s.name) in key]
    rng = np.array(rng)
    assert rng.size > 20
    if which == "ionosphere":  # 30 TECU at 2.2 GHz: 2.50 m at the zenith, x1..3 at 10 deg
        zenith = 40.3 * 30e16 / 2.2e9**2
        assert zenith * 0.999 < rng.min() and rng.max() < 3.2 * zenith
    else:  # ~2.3-2.6 m at the zenith, under ~15 m at 10 deg
        assert 2.0 < rng.min() and rng.max() < 16.0


def test_the_mask_applies_to_the_apparent_elevation(plain):
    # refraction lifts a satellite near the 10 deg mask: the troposphere can only add rows
    obs = simulate_tracking(TRUTH, STATIONS, GRID, measurements=MEAS, seed=False,
                            troposphere=True)
    assert len(obs) >= len(plain)
    el = obs.values[obs.kinds == "azel", 1]
    assert el.min() > np.radians(10.0)


def test_an_ionosphere_without_a_frequency_is_refused():
    with pytest.raises(vv.InvalidInputError, match="frequency_hz"):
        simulate_tracking(TRUTH, STATIONS, GRID, measurements=MEAS, seed=False,
                          ionosphere={"vtec_tecu": 30.0})
