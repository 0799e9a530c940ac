"""The defects a new user hit (issue 11): each one reproduced, each now fixed.

Plots and animations use pyplot with the Agg backend (set below before pyplot is imported).
"""

from __future__ import annotations

import math
import warnings

import matplotlib
import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

import visviva as vv  # noqa: E402
from visviva.errors import fmt_number  # noqa: E402

ISS_1 = "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009"
ISS_2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340"
# NOAA 19 (sun-synchronous, 870 km), a 2024 element set
NOAA_1 = "1 33591U 09005A   24001.52324513  .00000198  00000-0  13232-3 0  9997"
NOAA_2 = "2 33591  99.1367  42.4315 0014176 107.2588 253.0149 14.12875420768520"


@pytest.fixture(scope="module")
def iss():
    return vv.Satellite.from_tle(ISS_1, ISS_2, name="ISS")


@pytest.fixture(scope="module")
def catalog(iss):
    noaa = vv.Satellite.from_tle(NOAA_1, NOAA_2, name="NOAA 19", verify_checksum=False)
    return vv.Catalog([iss, noaa])


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


# -- units and messages -----------------------------------------------------------------------
def test_a_list_of_quantities_is_one_quantity():
    r = [7000 * u.km, 0 * u.km, 0 * u.km]
    v = [0 * u.km / u.s, 7.546 * u.km / u.s, 1 * u.m / u.s]
    s = vv.StateVectors(r, v, vv.EARTH)
    np.testing.assert_array_equal(s.r.to_value(u.km), [7000.0, 0.0, 0.0])
    np.testing.assert_allclose(s.v.to_value(u.km / u.s), [0.0, 7.546, 0.001], rtol=1e-15)
    # the same orbit as the one-Quantity spelling
    ref = vv.StateVectors([7000, 0, 0] * u.km, [0, 7.546, 0.001] * u.km / u.s, vv.EARTH)
    assert s.to_elements().semi_major_axis == ref.to_elements().semi_major_axis


@pytest.mark.parametrize("r, why", [([7000 * u.km, 0, 0], "mixes Quantities and plain numbers"),
                                    ([7000 * u.km, 0 * u.s, 0 * u.km], "not convertible")])
def test_a_bad_list_of_quantities_says_what_is_wrong(r, why):
    with pytest.raises(vv.UnitsError, match=why) as info:
        vv.StateVectors(r, [0, 7.5, 0] * u.km / u.s, vv.EARTH)
    assert "r=7000 * u.km" in str(info.value)


@pytest.mark.parametrize("value, text", [(np.float64(-0.1), "-0.1"), (np.int64(3), "3"),
                                         (np.float32(0.5), "0.5"), (np.array(2.5), "2.5"),
                                         (np.array([1.0, 2.0]), "[1.0, 2.0]"), ("abc", "'abc'"),
                                         (float("nan"), "nan")])
def test_fmt_number_writes_numbers_as_numbers(value, text):
    assert fmt_number(value) == text


@pytest.mark.parametrize("make", [
    lambda: vv.KeplerianElements(7000 * u.km, np.float64(-0.1), 0.5, 0, 0, 0, vv.EARTH),
    lambda: vv.KeplerianElements(7000 * u.km, 0.1, np.float64(4.0), 0, 0, 0, vv.EARTH),
    lambda: vv.KeplerianElements(-7000 * u.km, 0.1, 0.5, 0, 0, 0, vv.EARTH),
    lambda: vv.KeplerianElements.from_semi_major_axis(-7000 * u.km, 0.1, 0.5, 0, 0, 0, vv.EARTH),
    lambda: vv.StateVectors([7000, 0, 0] * u.km, [0, 7.5, 0] * u.km / u.s,
                            np.float64(-1.0) * u.km**3 / u.s**2),
    lambda: vv.Simulation(G=np.float64(-1.0)),
    lambda: vv.orbit_equation(np.float64(-1.0) * u.km, 0.1, 0.0),
])
def test_messages_show_numbers_not_numpy_reprs(make):
    with pytest.raises(vv.VisvivaError) as info:
        make()
    assert "np.float" not in str(info.value) and "np.int" not in str(info.value)
    assert "array(" not in str(info.value)


# -- angles wrapped on construction (docs/conventions.md) -------------------------------------
def test_plain_number_angles_are_radians_wrapped_as_documented():
    with pytest.warns(UserWarning, match="raan = 7.0 is a plain number"):  # > 2 pi: degrees?
        el = vv.KeplerianElements(7000 * u.km, 0.1, 0.5, 7.0, -1.0, 4.0, vv.EARTH)
    assert el.longitude_of_ascending_node.to_value(u.rad) == pytest.approx(7.0 - 2 * math.pi)
    assert el.argument_of_periapsis.to_value(u.rad) == pytest.approx(2 * math.pi - 1.0)
    assert el.true_anomaly.to_value(u.rad) == pytest.approx(4.0 - 2 * math.pi)  # (-pi, pi]
    deg = vv.KeplerianElements(7000 * u.km, 0.1, 0.5, 400 * u.deg, -10 * u.deg, 190 * u.deg,
                               vv.EARTH)
    assert deg.longitude_of_ascending_node.to_value(u.deg) == pytest.approx(40.0)
    assert deg.argument_of_periapsis.to_value(u.deg) == pytest.approx(350.0)
    assert deg.true_anomaly.to_value(u.deg) == pytest.approx(-170.0)
    # wrapping moves no body: the state is the same as from the unwrapped angles' cos/sin
    same = vv.KeplerianElements(7000 * u.km, 0.1, 0.5, 40 * u.deg, 350 * u.deg, -170 * u.deg,
                                vv.EARTH)
    np.testing.assert_allclose(deg.to_state().r.value, same.to_state().r.value, atol=1e-9)
    # pi stays pi, -pi becomes pi; no negative zero
    edge = vv.KeplerianElements(7000 * u.km, 0.1, 0.5, -0.0, 2 * math.pi, [math.pi, -math.pi],
                                vv.EARTH)
    assert list(edge.true_anomaly.to_value(u.rad)) == [math.pi, math.pi]
    assert math.copysign(1, float(edge.longitude_of_ascending_node[0].value)) == 1.0
    assert float(edge.argument_of_periapsis[0].value) == 0.0


def test_plain_angles_that_look_like_degrees_warn():
    with pytest.warns(UserWarning, match=r"raan = 247.46 .* radians.*247.46 \* u.deg"):
        vv.KeplerianElements(7000 * u.km, 0.1, 0.5, 247.46, 0.0, 0.0, vv.EARTH)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        vv.KeplerianElements(7000 * u.km, 0.1, 0.5, 247.46 * u.deg, 6.0, -3.0, vv.EARTH)


# -- altitude ----------------------------------------------------------------------------------
def test_altitude_of_satellite_states_agrees_with_skyfield(iss):
    from skyfield.api import EarthSatellite, load, wgs84

    ts = load.timescale(builtin=True)
    t = iss.epoch + np.linspace(0, 95, 20) * u.min
    ref = wgs84.height_of(EarthSatellite(ISS_1, ISS_2, "ISS", ts).at(ts.from_astropy(t))).km
    for frame in ("teme", "gcrs", "itrs"):
        alt = getattr(iss, frame)(t).altitude
        assert alt.unit == u.km and alt.shape == (20,)
        assert np.abs(alt.to_value(u.km) - ref).max() < 0.01  # 10 m (Skyfield's own frames)
        np.testing.assert_allclose(alt.to_value(u.km), iss.geodetic(t)[2].to_value(u.km),
                                   rtol=0, atol=1e-8)


def test_altitude_of_batch_states(catalog):
    t = catalog[0].epoch + np.arange(0, 120, 15) * u.min
    batch = catalog.propagate(t)
    alt = batch.altitude
    assert alt.shape == (2, 8) and alt.unit == u.km
    for k, sat in enumerate(catalog):
        np.testing.assert_allclose(alt[k].value, sat.geodetic(t)[2].to_value(u.km), atol=1e-8)
    np.testing.assert_allclose(batch.to_frame("gcrs").altitude.value, alt.value, atol=1e-8)
    assert 380 < alt[0].value.min() and alt[0].value.max() < 440  # the ISS
    assert 830 < alt[1].value.min() and alt[1].value.max() < 890  # NOAA 19


# -- catalogues in ground tracks, eclipses and plots -------------------------------------------
def test_ground_track_and_eclipse_of_a_catalog_equal_each_satellite(catalog):
    from visviva.satellites import eclipse_fraction, ground_track

    t = Time("2024-01-01T12:00:00", scale="utc") + np.linspace(0, 200, 60) * u.min
    tracks = ground_track(catalog, t)
    frac = eclipse_fraction(catalog, t)
    assert [g.name for g in tracks] == ["ISS", "NOAA 19"] and frac.shape == (2, 60)
    for k, sat in enumerate(catalog):
        one = ground_track(sat, t)
        np.testing.assert_allclose(tracks[k].latitude.value, one.latitude.value, atol=1e-9)
        np.testing.assert_allclose(tracks[k].height.value, one.height.value, atol=1e-8)
        np.testing.assert_allclose(frac[k], eclipse_fraction(sat, t), atol=1e-9)
    with pytest.raises(vv.UnitsError, match="absolute times"):
        ground_track(catalog, np.arange(3) * u.min)


def test_plots_take_a_catalog_a_label_and_show(iss, catalog, tmp_path):
    from visviva.satellites import plot_altitude_eclipse, plot_ground_track, plot_orbit_3d

    t = Time("2024-01-01T12:00:00", scale="utc") + np.linspace(0, 100, 80) * u.min
    fig = plot_ground_track(iss, t, label="ISS (ZARYA)", color="C3")
    labels = [ln.get_label() for ln in fig.axes[0].lines]
    assert "ISS (ZARYA)" in labels
    assert fig.axes[0].get_legend() is not None
    for plot in (plot_ground_track, plot_orbit_3d, plot_altitude_eclipse):
        fig = plot(catalog, t)
        names = {ln.get_label() for ln in fig.axes[0].lines}
        assert {"ISS", "NOAA 19"} <= names or {"height of ISS", "height of NOAA 19"} <= names
        # a pyplot figure: it shows itself in notebooks, and show() works (Agg: a warning only)
        assert fig.canvas.manager is not None and plt.fignum_exists(fig.number)
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", "FigureCanvasAgg is non-interactive")
            warnings.filterwarnings("ignore", ".*cannot be shown")
            fig.show()
        fig.savefig(tmp_path / f"{plot.__name__}.png")
        assert (tmp_path / f"{plot.__name__}.png").stat().st_size > 10_000
