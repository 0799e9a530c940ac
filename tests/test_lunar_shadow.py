"""The Earth's shadow over Moon-centred runs: warned about, since only the central body's
shadow is modelled (audit56)."""

import warnings

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv
from visviva._units import advance_epoch
from visviva.satellites import Eclipse
from visviva.satellites.lunar_shadow import earth_shadow_windows

# NASA's eclipse catalogue (Espenak): penumbral contacts P1 and P4 of 2025's lunar eclipses
CONTACTS = [("2025-03-14T03:57:28", "2025-03-14T10:00:09"),
            ("2025-09-07T15:28:21", "2025-09-07T20:55:10")]


def test_windows_enclose_published_lunar_eclipses():
    epoch = Time("2025-03-01T00:00:00", scale="utc")
    windows = earth_shadow_windows(epoch, (0.0, 200 * 86400.0), vv.MOON.radius_km)
    assert len(windows) == 2  # the two eclipses, nothing else in 200 days
    for (a, b), (p1, p4) in zip(windows, CONTACTS, strict=True):
        early = (Time(p1, scale="utc") - advance_epoch(epoch, a)).to_value(u.min)
        late = (advance_epoch(epoch, b) - Time(p4, scale="utc")).to_value(u.min)
        assert 0.0 < early < 35.0 and 0.0 < late < 35.0, (early, late)


def _lunar_orbiter(epoch):
    return vv.KeplerianElements.from_semi_major_axis(
        (vv.MOON.radius_km + 50) * u.km, 0.0, 90 * u.deg, 0.5, 0.0, 0.3, vv.MOON, epoch=epoch
    ).to_state()


def test_moon_centred_srp_run_through_a_lunar_eclipse_warns():
    state = _lunar_orbiter(Time("2025-03-14T04:00:00", scale="utc"))
    srp = vv.SolarRadiationPressure(0.02 * u.m**2 / u.kg, body=vv.MOON)
    with pytest.warns(UserWarning, match="Earth's shadow.*2025-03-14T04:00 to 2025-03-14T10:00"):
        vv.propagate_cowell(state, 6 * u.hour, [srp])
    with pytest.warns(UserWarning, match="Eclipse events do not report it"):
        vv.propagate_cowell(state, 6 * u.hour, [], events=[Eclipse()])


def test_no_warning_away_from_eclipses_or_without_srp():
    quiet = _lunar_orbiter(Time("2025-04-14T04:00:00", scale="utc"))  # full Moon, no eclipse
    srp = vv.SolarRadiationPressure(0.02 * u.m**2 / u.kg, body=vv.MOON)
    in_eclipse = _lunar_orbiter(Time("2025-03-14T04:00:00", scale="utc"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = vv.propagate_cowell(quiet, 6 * u.hour, [srp])
        vv.propagate_cowell(in_eclipse, 6 * u.hour, [vv.ThirdBody(vv.EARTH)])  # no SRP
    assert np.all(np.isfinite(out.r.value))
