"""Animations of orbits and N-body simulations with matplotlib (``FuncAnimation``).

:func:`animate_orbit` moves a body along its orbit: two-body motion of ``StateVectors`` or
``KeplerianElements`` (universal variables), or SGP4 for a ``Satellite``; :func:`animate_simulation`
integrates a :class:`~visviva.Simulation` to the frame times and replays every particle with a
fading trail. Both compute every frame's positions in one call first (never a propagation per
frame), then return a ``matplotlib.animation.FuncAnimation`` on a pyplot figure: it plays in a
window (``plt.show()``) or in a notebook (``HTML(anim.to_jshtml())``), and
:func:`save_animation` writes a GIF with pillow, or an MP4 when ffmpeg is installed.

The view is 2-D: by default the plane of the orbit (``plane="orbit"``: x along the first
position, z along the angular momentum, so any inclination looks like the true ellipse), or
the frame's x-y plane (``plane="xy"``).
"""

from __future__ import annotations

import weakref

import numpy as np

from .errors import InvalidInputError

__all__ = ["animate_orbit", "animate_simulation", "save_animation"]

#: frames drawn per second when played or saved (40 ms per frame)
_INTERVAL_MS = 40
#: the frame interval (ms) of each animation made here, for save_animation's default fps
#: (kept beside the object, not written into matplotlib's FuncAnimation)
_INTERVALS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _orbit_positions(target, t, frame: str):
    """(T, 3) positions (km), the times' labels (min from the first) and the central radius."""
    from astropy import units as u

    from .constants import R_EARTH_KM
    from .elements import KeplerianElements
    from .satellites.tle import Satellite, SatelliteStates
    from .states import StateVectors

    if isinstance(target, Satellite):
        from .satellites.frames import frame_name

        # (a name read as an attribute: "epoch" or "to_omm" were called, "GCRS" AttributeError)
        states = getattr(target, frame_name(frame))(t)
        r = states.r.to_value(u.km).reshape(-1, 3)
        minutes = (states.t - states.t.ravel()[0]).to_value(u.min).ravel()
        return r, minutes, R_EARTH_KM, target.name
    if isinstance(target, KeplerianElements):
        target = target.to_state()
    if isinstance(target, SatelliteStates):
        target = target.to_state_vectors()
    if not isinstance(target, StateVectors):
        raise InvalidInputError(
            f"animate_orbit needs a StateVectors, KeplerianElements or Satellite; got "
            f"{type(target).__name__}. For a Simulation use vv.animate_simulation(sim, t_end)."
        )
    if target.shape != ():
        raise InvalidInputError(
            f"animate_orbit animates one orbit; got states of shape {target.shape}. Pick one, "
            "e.g. states[0]."
        )
    from ._units import to_array

    dt_s = to_array(t, "time", "t").ravel()
    r = target.propagate(dt_s * u.s).r.to_value(u.km).reshape(-1, 3)
    gm = float(target.gm.to_value(u.km**3 / u.s**2))
    radius = R_EARTH_KM if abs(gm / 398600.4418 - 1) < 1e-3 else 0.0
    return r, (dt_s - dt_s[0]) / 60.0, radius, "body"


def _plane_basis(r: np.ndarray, plane: str) -> np.ndarray:
    """3 x 2 matrix projecting 3-D positions to the drawing plane."""
    if plane == "xy":
        return np.eye(3)[:, :2]
    if plane != "orbit":
        raise InvalidInputError(f"plane must be 'orbit' or 'xy'; got {plane!r}.")
    finite = r[np.isfinite(r).all(-1)]
    x = finite[0] / np.linalg.norm(finite[0])
    h = np.zeros(3)
    for other in finite[1:]:
        h = np.cross(finite[0], other)
        if np.linalg.norm(h) > 1e-9 * np.linalg.norm(finite[0]) * np.linalg.norm(other):
            break
    if not np.linalg.norm(h) > 0:  # radial or single-point motion: any plane holding it
        h = np.cross(x, [0.0, 0.0, 1.0] if abs(x[2]) < 0.9 else [1.0, 0.0, 0.0])
    z = h / np.linalg.norm(h)
    return np.stack([x, np.cross(z, x)], axis=1)


def _square_limits(ax, xy: np.ndarray, radius: float = 0.0) -> None:
    finite = xy[np.isfinite(xy).all(-1)]
    span = max(float(np.abs(finite).max()) if finite.size else 1.0, radius) * 1.1
    ax.set_xlim(-span, span)
    ax.set_ylim(-span, span)
    ax.set_aspect("equal")


def animate_orbit(target, t, *, plane: str = "orbit", frame: str = "gcrs", trail: int = 30,
                  ax=None, interval: int = _INTERVAL_MS):
    """Animate a body moving along its orbit.

    Parameters
    ----------
    target : StateVectors, KeplerianElements or Satellite
        One orbit: two-body motion from the state or elements (universal variables), or SGP4
        for a satellite.
    t : Quantity (time) or astropy Time, 1-D
        The frame times: offsets from the state's epoch (e.g. ``np.linspace(0, 90, 120) *
        u.min``), or for a satellite absolute times as well.
    plane : {"orbit", "xy"}
        Draw in the orbit's plane (default) or in the frame's x-y plane.
    frame : {"gcrs", "teme", "itrs"}
        A satellite's frame (ignored for states and elements).
    trail : int
        Number of past frames drawn behind the body (0 for none).
    ax : matplotlib Axes, optional
        Draw here instead of in a new figure.
    interval : int
        Milliseconds between frames when played (the GIF frame rate of :func:`save_animation`).

    Returns
    -------
    matplotlib.animation.FuncAnimation
        One frame per time; ``anim.save("orbit.gif", writer="pillow")`` or
        :func:`save_animation`. Keep a reference while it plays.

    Examples
    --------
    >>> import numpy as np, visviva as vv
    >>> from astropy import units as u
    >>> el = vv.KeplerianElements.from_semi_major_axis(
    ...     12000 * u.km, 0.4, 30 * u.deg, 0 * u.deg, 0 * u.deg, 0 * u.deg, vv.EARTH)
    >>> anim = vv.animate_orbit(el, np.linspace(0, 217, 60) * u.min)   # doctest: +SKIP
    >>> vv.save_animation(anim, "orbit.gif")                            # doctest: +SKIP

    Notes
    -----
    The positions of every frame come from one propagation call before the animation starts
    (``StateVectors.propagate`` over the array of times, or one SGP4 array call), so playing
    and saving only draw.
    """
    n_t = getattr(t, "size", None)
    if n_t is not None and n_t < 2:  # checked first: an empty t failed with an IndexError
        raise InvalidInputError(f"t must hold at least 2 times to animate; got {n_t}.")
    r, minutes, radius, name = _orbit_positions(target, t, frame)
    if r.shape[0] < 2:
        raise InvalidInputError(f"t must hold at least 2 times to animate; got {r.shape[0]}.")
    xy = r @ _plane_basis(r, plane)
    unit = "km"
    where = "orbital plane" if plane == "orbit" else f"{frame.upper()} x-y plane"
    title = (f"two-body motion in the {where}" if name == "body"
             else f"{name} (SGP4) in the {where}")
    return _animate(ax, xy[:, None, :], [name], minutes, "min", radius, unit, trail, interval,
                    title)


def animate_simulation(sim, t_end, frames: int = 100, *, plane: str = "xy", trail: int = 40,
                       ax=None, interval: int = _INTERVAL_MS, labels=None):
    """Integrate a Simulation to ``t_end`` and animate its particles.

    Parameters
    ----------
    sim : Simulation
        The simulation; it is integrated (it ends at ``t_end``). Pass ``sim.copy()`` to keep
        the original.
    t_end : float or Quantity
        Absolute end time (simulation units, or a Quantity when the simulation has units).
    frames : int
        Number of frames, equally spaced from ``sim.t`` to ``t_end``.
    plane : {"xy", "orbit"}
        The frame's x-y plane (default), or the plane of the first particle pair's motion.
    trail : int
        Number of past frames drawn behind each particle (0 for none).
    ax : matplotlib Axes, optional
        Draw here instead of in a new figure.
    interval : int
        Milliseconds between frames.
    labels : list of str, optional
        Legend names of the particles (default "particle 0", ...).

    Returns
    -------
    matplotlib.animation.FuncAnimation

    Notes
    -----
    One ``sim.integrate`` call over the frame times (each reached exactly) computes every frame
    first; particles removed by a merger disappear from their frame on.
    """
    from ._units import is_quantity

    frames = int(frames)
    if frames < 2:
        raise InvalidInputError(f"frames must be >= 2; got {frames}.")
    units = getattr(sim, "units", None)
    t0 = sim.t
    if is_quantity(t_end):
        t_end = sim.time_value(t_end, "t_end")
    t_end = float(t_end)
    if not np.isfinite(t_end) or t_end == t0:
        raise InvalidInputError(
            f"t_end must be a finite time other than the simulation's time {t0}; got {t_end}."
        )
    times = np.linspace(t0, t_end, frames)
    start = sim.positions.copy()
    traj = sim.integrate(times[1:])
    pos = np.concatenate([start[None], traj.positions], axis=0)  # (F, N, 3)
    basis = _plane_basis(pos[:, 1] - pos[:, 0] if pos.shape[1] > 1 else pos[:, 0], plane)
    xy = pos @ basis
    n = pos.shape[1]
    names = list(labels) if labels is not None else [f"particle {k}" for k in range(n)]
    if len(names) != n:
        raise InvalidInputError(f"labels must name the {n} particles; got {len(names)}.")
    length = units.length if units is not None else "simulation units"
    time_unit = units.time if units is not None else ""
    return _animate(ax, xy, names, times, time_unit, 0.0, length, trail, interval,
                    f"{n} bodies, {sim.integrator}, t = {t0:g} to {t_end:g} {time_unit}".strip())


def _animate(ax, xy, names, times, time_unit, radius, length_unit, trail, interval, title):
    """The FuncAnimation over positions ``xy`` of shape (F, N, 2)."""
    from matplotlib.animation import FuncAnimation
    from matplotlib.patches import Circle

    if ax is None:
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6, 6))
    else:
        fig = ax.figure
    own_figure = ax is not None and fig.axes == [ax]
    n_frames, n = xy.shape[:2]
    trail = max(int(trail), 0)
    for k in range(n):  # the whole path, faint
        ax.plot(xy[:, k, 0], xy[:, k, 1], lw=0.6, alpha=0.3, color=f"C{k % 10}")
    if radius > 0:
        ax.add_patch(Circle((0, 0), radius, color="tab:blue", alpha=0.25, label="Earth"))
    elif n == 1:
        ax.plot(0, 0, "k*", ms=9, label="central body")
    dots = [ax.plot([], [], "o", color=f"C{k % 10}", ms=7, label=names[k])[0] for k in range(n)]
    tails = [ax.plot([], [], "-", color=f"C{k % 10}", lw=1.8)[0] for k in range(n)]
    clock = ax.text(0.02, 0.97, "", transform=ax.transAxes, va="top", family="monospace")
    _square_limits(ax, xy.reshape(-1, 2), radius)
    ax.set_xlabel(f"x ({length_unit})")
    ax.set_ylabel(f"y ({length_unit})")
    ax.set_title(title, fontsize=10)
    ax.legend(loc="upper right", fontsize="small")
    ax.grid(True, lw=0.4, alpha=0.4)

    def draw(i):
        lo = max(0, i - trail)
        for k in range(n):
            dots[k].set_data(xy[i : i + 1, k, 0], xy[i : i + 1, k, 1])
            tails[k].set_data(xy[lo : i + 1, k, 0], xy[lo : i + 1, k, 1])
        clock.set_text(f"t = {times[i]:.4g} {time_unit}".rstrip())
        return (*dots, *tails, clock)

    if own_figure:
        fig.tight_layout()
    anim = FuncAnimation(fig, draw, frames=n_frames, interval=interval, blit=False)
    _INTERVALS[anim] = interval
    return anim


def save_animation(anim, path, *, fps: float | None = None, dpi: int = 80):
    """Save an animation: ``.gif`` with pillow, ``.mp4`` with ffmpeg (when installed).

    Parameters
    ----------
    anim : matplotlib.animation.FuncAnimation
        From :func:`animate_orbit` or :func:`animate_simulation`.
    path : str or os.PathLike
        The file; its extension picks the writer.
    fps : float, optional
        Frames per second (default: from the animation's interval, 25).
    dpi : int
        Resolution, dots per inch.

    Returns
    -------
    pathlib.Path
        The file written.
    """
    import os
    from pathlib import Path

    from matplotlib import animation

    path = Path(os.fspath(path))
    fps = fps or 1000.0 / _INTERVALS.get(anim, _INTERVAL_MS)
    ext = path.suffix.lower()
    if ext == ".gif":
        writer = animation.PillowWriter(fps=fps)
    elif ext in (".mp4", ".m4v", ".mov"):
        if not animation.writers.is_available("ffmpeg"):
            raise InvalidInputError(
                f"saving {path.name} needs ffmpeg, which is not installed (or not on PATH). "
                "Install it (e.g. apt install ffmpeg, conda install ffmpeg) or save a .gif."
            )
        writer = animation.FFMpegWriter(fps=fps)
    else:
        raise InvalidInputError(f"save a .gif (pillow) or an .mp4 (ffmpeg); got {path.name!r}.")
    anim.save(path, writer=writer, dpi=dpi)
    return path
