"""Sky plot: the azimuth-elevation track of a pass on a polar chart (zenith at the centre).

Like :mod:`visviva.satellites.plots`, it draws into ``ax`` when given one (a polar Axes);
otherwise it makes a new ``matplotlib.figure.Figure`` with an Agg canvas (no pyplot, no
display) and returns it.
"""

from __future__ import annotations

import numpy as np
from astropy import units as u

from ..errors import InvalidInputError

__all__ = ["plot_sky_track"]


def plot_sky_track(station, satellite, t0, t1, ax=None, step=10 * u.s, min_elevation=0 * u.deg,
                   **line_kwargs):
    """Draw a satellite's track across the sky of a station between two times.

    North is up, east to the right (azimuth clockwise, as on a sky chart seen from below);
    the radius is the zenith distance ``90 - elevation``. Only the part above
    ``min_elevation`` is drawn, rise and set are marked.

    Parameters
    ----------
    station : GroundStation
    satellite : Satellite
    t0, t1 : astropy Time
        Usually a pass's ``rise_time`` and ``set_time`` from :func:`visviva.find_passes`.
    ax : matplotlib polar Axes, optional
    step : Quantity (time)
        Sampling step (default 10 s).
    min_elevation : Quantity (angle)
        Lowest elevation drawn (default 0 deg).
    **line_kwargs
        Passed to ``ax.plot``.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from .search import check_window, min_elevation_rad

    t0, t1 = check_window(t0, t1)
    el_min = np.degrees(min_elevation_rad(min_elevation))
    dt = step.to_value(u.s) if hasattr(step, "unit") else None
    if dt is None or not dt > 0:
        raise InvalidInputError(f"step must be a positive time Quantity, got {step!r}.")
    span = (t1 - t0).to_value(u.s)
    times = t0 + np.append(np.arange(0.0, span, dt), span) * u.s
    look = station.look(satellite, times)
    az = look.azimuth.to_value(u.rad)
    el = look.elevation.to_value(u.deg)
    if ax is None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        fig = Figure(figsize=(5.5, 5.5))
        FigureCanvasAgg(fig)
        ax = fig.add_subplot(1, 1, 1, projection="polar")
    fig = ax.figure
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    ax.set_rlim(0, 90)
    ax.set_rticks([15, 30, 45, 60, 75, 90])
    ax.set_yticklabels(["75", "60", "45", "30", "15", "0"])
    style = {"color": "C0", "lw": 1.5, "label": getattr(satellite, "name", None)}
    style.update(line_kwargs)
    up = el >= el_min - 1e-9
    r = 90.0 - el
    track = np.where(up, r, np.nan)
    ax.plot(az, track, **style)
    if up.any():
        first, last = np.flatnonzero(up)[[0, -1]]
        ax.plot(az[first], r[first], "o", color=style["color"], ms=5)
        ax.plot(az[last], r[last], "s", color=style["color"], ms=5)
    ax.set_title(f"{getattr(station, 'name', '')}: sky track (o rise, \u25a1 set)", fontsize=10)
    ax.grid(True, lw=0.5, alpha=0.5)
    return fig
