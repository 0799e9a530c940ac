"""Satellite plots with matplotlib: ground track, 3-D orbit, altitude and eclipse timeline.

Each function draws into ``ax`` when given one; otherwise it makes a new figure through
``matplotlib.pyplot`` and returns it, so the figure behaves as every matplotlib user expects:
it shows itself in a notebook, ``fig.show()`` / ``plt.show()`` open a window in a script with an
interactive backend, and ``fig.savefig("track.png")`` works anywhere (on a server without a
display pyplot picks the Agg backend by itself). Close figures you no longer need with
``plt.close(fig)``. Each function takes a :class:`~visviva.Satellite` or a
:class:`~visviva.Catalog` (one line per satellite, labelled with its name; the times must then be
an absolute astropy ``Time``). The map is a plain longitude-latitude (equirectangular) grid: no
coastlines are bundled.
"""

from __future__ import annotations

import numpy as np
from astropy import units as u

from ..constants import R_EARTH_KM
from .groundtrack import eclipse_fraction, eclipse_intervals, ground_track, is_catalog

__all__ = ["plot_ground_track", "plot_orbit_3d", "plot_altitude_eclipse", "new_figure"]


def new_figure(projection=None, figsize=(8, 4.5)):
    """A new pyplot-managed figure with one axes (``projection="3d"`` for 3-D).

    Parameters
    ----------
    projection : str, optional
        Passed to ``fig.add_subplot``.
    figsize : (float, float)
        Width and height, inches.

    Returns
    -------
    (matplotlib.figure.Figure, matplotlib.axes.Axes)
    """
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=figsize)
    ax = fig.add_subplot(1, 1, 1, projection=projection)
    return fig, ax


def _members(sat):
    """The satellites to draw: a catalogue's, or the one."""
    return list(sat) if is_catalog(sat) else [sat]


def _tracks_on_axes(sat, t, ax):
    """``(figure, axes, list of ground tracks)``: ``ax`` or a new figure's, one track a member."""
    fig, ax = (ax.figure, ax) if ax is not None else new_figure()
    tracks = ground_track(sat, t)
    return fig, ax, tracks if isinstance(tracks, list) else [tracks]


def plot_ground_track(sat, t, ax=None, **line_kwargs):
    """Draw the ground track on a longitude-latitude map.

    Parameters
    ----------
    sat : Satellite or Catalog
        The satellite(s); a catalogue draws one track per satellite.
    t : astropy Time or Quantity (offsets from ``sat.epoch``), 1-D
        The times (absolute for a catalogue).
    ax : matplotlib Axes, optional
        Draw here instead of in a new figure.
    **line_kwargs
        Passed to ``ax.plot`` (e.g. ``color``, ``lw``, ``label``; the label defaults to the
        satellite's name).

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax, tracks = _tracks_on_axes(sat, t, ax)
    for n, track in enumerate(tracks):
        lon = track.longitude.to_value(u.deg)
        lat = track.latitude.to_value(u.deg)
        style = {"color": f"C{n % 10}", "lw": 1.2, "label": track.name}
        style.update(line_kwargs)
        label = style.pop("label")
        for k, seg in enumerate(track.segments()):
            ax.plot(lon[seg], lat[seg], label=label if k == 0 else None, **style)
        ax.plot(lon[0], lat[0], "o", color=style["color"], ms=5)
    ax.set_xlim(-180, 180)
    ax.set_ylim(-90, 90)
    ax.set_xticks(np.arange(-180, 181, 60))
    ax.set_yticks(np.arange(-90, 91, 30))
    ax.set_xlabel("geodetic longitude (deg)")
    ax.set_ylabel("geodetic latitude (deg)")
    ax.grid(True, lw=0.5, alpha=0.5)
    ax.set_aspect("equal")
    who = tracks[0].name if len(tracks) == 1 else f"{len(tracks)} satellites"
    ax.set_title(f"Ground track of {who} from {tracks[0].t[0].utc.isot[:19]} UTC (dot: start)")
    if len(tracks) > 1 or "label" in line_kwargs:
        ax.legend(loc="lower left", fontsize="small")
    return fig


def plot_orbit_3d(sat, t, ax=None, frame: str = "gcrs", **line_kwargs):
    """Draw the orbit in 3-D around a wireframe Earth.

    Parameters
    ----------
    sat : Satellite or Catalog
        The satellite(s); a catalogue draws one orbit per satellite.
    t : astropy Time or Quantity (offsets from ``sat.epoch``)
        The times (absolute for a catalogue).
    ax : mpl_toolkits.mplot3d Axes3D, optional
        Draw here instead of in a new figure.
    frame : {"gcrs", "teme", "itrs"}
        The frame of the coordinates drawn.
    **line_kwargs
        Passed to ``ax.plot`` (the label defaults to the satellite's name).

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = (ax.figure, ax) if ax is not None else new_figure("3d", figsize=(6, 6))
    if is_catalog(sat):
        from .batch_states import absolute_times

        states = sat.propagate(absolute_times(t, "plot_orbit_3d of a Catalog"), frame=frame)
        paths = list(zip(states.names, states.r.to_value(u.km), strict=True))
    else:
        paths = [(sat.name, getattr(sat, frame)(t).r.to_value(u.km).reshape(-1, 3))]
    lim = R_EARTH_KM
    for name, r in paths:
        style = {"label": name}
        style.update(line_kwargs)
        ax.plot(r[:, 0], r[:, 1], r[:, 2], **style)
        lim = max(lim, np.abs(r).max())
    uu, vv = np.mgrid[0 : 2 * np.pi : 25j, 0 : np.pi : 13j]
    ax.plot_wireframe(
        R_EARTH_KM * np.cos(uu) * np.sin(vv), R_EARTH_KM * np.sin(uu) * np.sin(vv),
        R_EARTH_KM * np.cos(vv), color="0.6", lw=0.4,
    )
    lim *= 1.05
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_zlim(-lim, lim)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel(f"x {frame.upper()} (km)")
    ax.set_ylabel(f"y {frame.upper()} (km)")
    ax.set_zlabel(f"z {frame.upper()} (km)")
    who = paths[0][0] if len(paths) == 1 else f"{len(paths)} satellites"
    ax.set_title(f"{who} ({frame.upper()})")
    ax.legend(loc="upper left", fontsize="small")
    return fig


def plot_altitude_eclipse(sat, t, ax=None):
    """Height above the WGS-84 ellipsoid against time, with eclipses shaded.

    Umbra (no Sun) is dark grey, penumbra light grey (conical shadow model; see
    :func:`visviva.satellites.groundtrack.eclipse_fraction`). A catalogue draws every
    satellite's height; the shading is then that of its first satellite.

    Parameters
    ----------
    sat : Satellite or Catalog
        The satellite(s).
    t : astropy Time or Quantity (offsets from ``sat.epoch``)
        The times (absolute for a catalogue).
    ax : matplotlib Axes, optional
        Draw here instead of in a new figure.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax, tracks = _tracks_on_axes(sat, t, ax)
    times = tracks[0].t
    hours = (times - times[0]).to_value(u.h)
    for n, track in enumerate(tracks):
        ax.plot(hours, track.height.to_value(u.km), color=f"C{n % 10}",
                label=f"height of {track.name}")
    first = _members(sat)[0]
    frac = eclipse_fraction(first, times)
    step = hours[1] - hours[0] if hours.size > 1 else 0.0
    for threshold, color, label in ((1.0, "0.85", "penumbra"), (1e-12, "0.55", "umbra")):
        for k, (a, b) in enumerate(eclipse_intervals(times, frac, threshold)):
            x0 = (a - times[0]).to_value(u.h)
            x1 = (b - times[0]).to_value(u.h) + step
            ax.axvspan(x0, x1, color=color, lw=0, label=label if k == 0 else None)
    ax.set_xlabel(f"hours from {times[0].utc.isot[:19]} UTC")
    ax.set_ylabel("height above WGS-84 (km)")
    who = tracks[0].name if len(tracks) == 1 else f"{len(tracks)} satellites"
    ax.set_title(f"{who}: height and eclipses")
    ax.legend(loc="best", fontsize="small")
    return fig
