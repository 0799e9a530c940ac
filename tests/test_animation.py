"""vv.animate_orbit / vv.animate_simulation: every frame is the physics, and GIFs are written."""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib
import numpy as np
import pytest
from astropy import units as u

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.animation import FuncAnimation  # noqa: E402

import visviva as vv  # noqa: E402

DATA = Path(__file__).parent / "data" / "figure_eight.json"
ISS_1 = "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009"
ISS_2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340"


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def _drawn(anim):
    """The animation after its first draw, as a player would do (matplotlib warns about an
    animation deleted without having drawn anything)."""
    anim._init_draw()
    return anim


def _dot_xy(anim, i, k=0):
    """Draw frame i and return where particle k's dot is."""
    _drawn(anim)
    artists = anim._func(i)
    x, y = artists[k].get_data()
    return np.array([x[0], y[0]])


def test_orbit_frames_follow_kepler_and_a_gif_is_written(tmp_path):
    el = vv.KeplerianElements.from_semi_major_axis(
        12000 * u.km, 0.4, 30 * u.deg, 40 * u.deg, 10 * u.deg, 0 * u.deg, vv.EARTH)
    t = np.linspace(0, 60, 6) * u.min
    anim = vv.animate_orbit(el, t, plane="xy")
    assert isinstance(anim, FuncAnimation)
    r = el.to_state().propagate(t).r.to_value(u.km)
    for i in (0, 3, 5):
        np.testing.assert_allclose(_dot_xy(anim, i), r[i, :2], rtol=1e-12)
    # in the orbit's plane the distances from the focus are the radii |r|
    anim = vv.animate_orbit(el, t)
    for i in range(6):
        assert np.hypot(*_dot_xy(anim, i)) == pytest.approx(np.linalg.norm(r[i]), rel=1e-12)
    path = vv.save_animation(anim, tmp_path / "orbit.gif", dpi=30)
    from PIL import Image

    with Image.open(path) as gif:
        assert gif.format == "GIF" and gif.n_frames == 6


def test_satellite_animates_its_sgp4_track():
    sat = vv.Satellite.from_tle(ISS_1, ISS_2, name="ISS")
    t = np.linspace(0, 90, 4) * u.min
    anim = vv.animate_orbit(sat, t, plane="xy", frame="teme")
    r = sat.teme(t).r.to_value(u.km)
    np.testing.assert_allclose(_dot_xy(anim, 2), r[2, :2], rtol=1e-12)
    ax = anim._fig.axes[0]
    assert "ISS" in ax.get_title() and ax.get_xlabel() == "x (km)"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["Earth", "ISS"]
    # the frame is a frame name, any case (it was read as an attribute: "GCRS" raised
    # AttributeError, "epoch" or "to_omm" were called on t)
    anim = vv.animate_orbit(sat, t, plane="xy", frame="GCRS")
    np.testing.assert_allclose(_dot_xy(anim, 2), sat.gcrs(t).r.to_value(u.km)[2, :2], rtol=1e-12)
    for bad in ("epoch", "to_omm"):
        with pytest.raises(vv.InvalidInputError, match="'teme', 'gcrs', 'itrs'"):
            vv.animate_orbit(sat, t, frame=bad)


def test_simulation_animation_replays_the_integration(tmp_path):
    d = json.loads(DATA.read_text())
    sim = vv.Simulation("ias15", G=d["G"])
    for m, r, v in zip(d["masses"], d["positions"], d["velocities"], strict=True):
        sim.add(m, r, v)
    ref = sim.copy()
    start = sim.positions.copy()
    anim = vv.animate_simulation(sim, d["period"] / 2, frames=5, labels=["a", "b", "c"])
    assert sim.t == pytest.approx(d["period"] / 2)
    ref.integrate(d["period"] / 4)
    for k in range(3):
        np.testing.assert_allclose(_dot_xy(anim, 0, k), start[k, :2], rtol=0, atol=1e-15)
        np.testing.assert_allclose(_dot_xy(anim, 2, k), ref.positions[k, :2], atol=1e-12)
        np.testing.assert_allclose(_dot_xy(anim, 4, k), sim.positions[k, :2], atol=1e-15)
    path = vv.save_animation(anim, tmp_path / "three.gif", dpi=30)
    assert path.stat().st_size > 1000


def test_bad_animation_inputs_say_what_to_do(tmp_path):
    el = vv.KeplerianElements.from_semi_major_axis(
        12000 * u.km, 0.1, 0.5, 0.0, 0.0, 0.0, vv.EARTH)
    with pytest.raises(vv.InvalidInputError, match="at least 2 times"):
        vv.animate_orbit(el, [0.0] * u.s)
    with pytest.raises(vv.InvalidInputError, match="at least 2 times to animate; got 0"):
        vv.animate_orbit(el, [] * u.s)  # was IndexError
    with pytest.raises(vv.InvalidInputError, match="animate_simulation"):
        vv.animate_orbit(vv.Simulation(), np.arange(3) * u.s)
    with pytest.raises(vv.InvalidInputError, match="plane"):
        vv.animate_orbit(el, np.arange(3) * u.s, plane="yz")
    with pytest.raises(vv.InvalidInputError, match="frames must be >= 2"):
        vv.animate_simulation(vv.Simulation(), 1.0, frames=1)
    anim = _drawn(vv.animate_orbit(el, np.arange(3) * u.min))
    with pytest.raises(vv.InvalidInputError, match=".gif"):
        vv.save_animation(anim, tmp_path / "orbit.avi")
