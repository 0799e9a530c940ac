"""Helpers of the validation checks: Skyfield times and the brute-force crossing search."""

from __future__ import annotations

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

pytest.importorskip("skyfield")

from visviva.validation._skyfield import sky_time, timescale  # noqa: E402
from visviva.validation.checks_ground import _crossings  # noqa: E402


def _offset_s(st, t):
    """Skyfield time minus astropy time, s, with both parts of each Julian date."""
    tt = t.tt
    return ((st.whole - tt.jd1) + (st.tt_fraction - tt.jd2)) * 86400.0


def test_sky_time_keeps_both_parts_of_the_julian_date():
    ts = timescale()
    t = Time("2024-01-01T12:00:00", scale="utc") + np.linspace(0.0, 1.0, 97) * u.s / 7.0
    assert np.abs(_offset_s(sky_time(ts, t), t)).max() < 1e-9  # s
    # ts.from_astropy sums the two parts into one float: ~20 us in 2024
    assert np.abs(_offset_s(ts.from_astropy(t), t)).max() > 1e-6


def test_timescale_carries_astropy_polar_motion():
    ts = timescale()
    st = sky_time(ts, Time("2024-01-01T00:00:00", scale="utc"))
    # the builtin timescale has none; 2024-01-01: x_p ~ 0.10", y_p ~ 0.23" (IERS)
    assert 0.05 < np.hypot(*st.polar_motion_angles()[:2]) < 0.5


def test_crossings_bisect_rises_sets_and_a_jump():
    def f(x):  # a sine, with a drop of 1 over 5.3 < x < 7 (a mask's vertical edges)
        return np.sin(x / 4.0) - 0.2 - np.where((x > 5.3) & (x < 7.0), 1.0, 0.0)

    tx, sense = _crossings(f, [(0.0, 20.0)], 1e-4)
    a = 4.0 * np.arcsin(0.2)
    np.testing.assert_allclose(tx, [a, 5.3, 7.0, 4.0 * np.pi - a], atol=1e-4)
    np.testing.assert_array_equal(sense, [1, -1, 1, -1])
    # two windows: nothing is bracketed across the gap between them
    tx, sense = _crossings(f, [(0.0, 3.0), (6.0, 20.0)], 1e-4)
    np.testing.assert_allclose(tx, [a, 7.0, 4.0 * np.pi - a], atol=1e-4)
