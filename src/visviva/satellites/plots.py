"""Satellite plots with matplotlib: ground track, 3-D orbit, altitude and eclipse timeline.

Each function draws into ``ax`` when given one; otherwise it makes a new
``matplotlib.figure.Figure`` with an Agg canvas (no pyplot, no display, safe on servers) and
returns it, so ``fig.savefig("track.png")`` works anywhere. The map is a plain
longitude-latitude (equirectangular) grid: no coastlines are bundled.
"""

from __future__ import annotations

import numpy as np
from astropy import units as u

from ..constants import R_EARTH_KM
from .groundtrack import eclipse_fraction, eclipse_intervals, ground_track

__all__ = ["plot_ground_track", "plot_orbit_3d", "plot_altitude_eclipse"]


def _new_axes(projection=None, figsize=(8, 4.5)):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1, projection=projection)
    return fig, ax


def plot_ground_track(sat, t, ax=None, **line_kwargs):
    """Draw the ground track on a longitude-latitude map.

    Parameters
    ----------
    sat : Satellite
    t : astropy Time or Quantity (offsets from ``sat.epoch``), 1-D
    ax : matplotlib Axes, optional
    **line_kwargs
        Passed to ``ax.plot``.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = (ax.figure, ax) if ax is not None else _new_axes()
    track = ground_track(sat, t)
    lon = track.longitude.to_value(u.deg)
    lat = track.latitude.to_value(u.deg)
    style = {"color": "C0", "lw": 1.2}
    style.update(line_kwargs)
    for k, seg in enumerate(track.segments()):
        ax.plot(lon[seg], lat[seg], label=sat.name if k == 0 else None, **style)
    ax.plot(lon[0], lat[0], "o", color=style["color"], ms=5)
    ax.set_xlim(-180, 180)
    ax.set_ylim(-90, 90)
    ax.set_xticks(np.arange(-180, 181, 60))
    ax.set_yticks(np.arange(-90, 91, 30))
    ax.set_xlabel("geodetic longitude (deg)")
    ax.set_ylabel("geodetic latitude (deg)")
    ax.grid(True, lw=0.5, alpha=0.5)
    ax.set_aspect("equal")
    ax.set_title(f"Ground track of {sat.name} from {track.t[0].utc.isot[:19]} UTC")
    return fig


def plot_orbit_3d(sat, t, ax=None, frame: str = "gcrs", **line_kwargs):
    """Draw the orbit in 3-D around a wireframe Earth.

    Parameters
    ----------
    sat : Satellite
    t : astropy Time or Quantity (offsets from ``sat.epoch``)
    ax : mpl_toolkits.mplot3d Axes3D, optional
    frame : {"gcrs", "teme", "itrs"}
    """
    fig, ax = (ax.figure, ax) if ax is not None else _new_axes("3d", figsize=(6, 6))
    states = getattr(sat, frame)(t)
    r = states.r.to_value(u.km).reshape(-1, 3)
    ax.plot(r[:, 0], r[:, 1], r[:, 2], label=sat.name, **line_kwargs)
    uu, vv = np.mgrid[0 : 2 * np.pi : 25j, 0 : np.pi : 13j]
    ax.plot_wireframe(
        R_EARTH_KM * np.cos(uu) * np.sin(vv), R_EARTH_KM * np.sin(uu) * np.sin(vv),
        R_EARTH_KM * np.cos(vv), color="0.6", lw=0.4,
    )
    lim = max(np.abs(r).max(), R_EARTH_KM) * 1.05
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_zlim(-lim, lim)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel(f"x {frame.upper()} (km)")
    ax.set_ylabel(f"y {frame.upper()} (km)")
    ax.set_zlabel(f"z {frame.upper()} (km)")
    ax.set_title(f"{sat.name} ({frame.upper()})")
    return fig


def plot_altitude_eclipse(sat, t, ax=None):
    """Height above the WGS-84 ellipsoid against time, with eclipses shaded.

    Umbra (no Sun) is dark grey, penumbra light grey (conical shadow model; see
    :func:`visviva.satellites.groundtrack.eclipse_fraction`).
    """
    fig, ax = (ax.figure, ax) if ax is not None else _new_axes()
    track = ground_track(sat, t)
    hours = (track.t - track.t[0]).to_value(u.h)
    ax.plot(hours, track.height.to_value(u.km), color="C0", label="height")
    frac = eclipse_fraction(sat, track.t)
    step = hours[1] - hours[0] if hours.size > 1 else 0.0
    for threshold, color, label in ((1.0, "0.85", "penumbra"), (1e-12, "0.55", "umbra")):
        for k, (a, b) in enumerate(eclipse_intervals(track.t, frac, threshold)):
            x0 = (a - track.t[0]).to_value(u.h)
            x1 = (b - track.t[0]).to_value(u.h) + step
            ax.axvspan(x0, x1, color=color, lw=0, label=label if k == 0 else None)
    ax.set_xlabel(f"hours from {track.t[0].utc.isot[:19]} UTC")
    ax.set_ylabel("height above WGS-84 (km)")
    ax.set_title(f"{sat.name}: height and eclipses")
    ax.legend(loc="best", fontsize="small")
    return fig
