"""Porkchop plots: launch energy and arrival speed over a grid of departure and arrival dates.

Planet states come from the offline ephemeris (:mod:`visviva.satellites.ephemeris`, DE421 when
installed); every grid point is one prograde Lambert problem about the Sun (zero revolutions unless
``revolutions=`` says otherwise), all solved in one vectorised call.

>>> import numpy as np
>>> from astropy import units as u
>>> from astropy.time import Time
>>> from visviva.satellites.porkchop_plot import porkchop
>>> dep = Time("2005-06-20", scale="tdb") + np.arange(0, 120, 10) * u.day
>>> arr = Time("2005-12-01", scale="tdb") + np.arange(0, 240, 10) * u.day
>>> pc = porkchop("earth", "mars", dep, arr)
>>> print(f"{pc.c3.to_value(u.km**2 / u.s**2)[np.isfinite(pc.c3)].min():.0f}")
16
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from astropy import units as u

from ..bodies import SUN
from ..errors import DomainError, InvalidInputError
from .ephemeris import planet_heliocentric

__all__ = ["porkchop", "Porkchop"]


@dataclass
class Porkchop:
    """Porkchop grid. Arrays have shape (N_departure, N_arrival); NaN where tof <= 0 or no
    solution.

    Attributes
    ----------
    departure, arrival : astropy Time (N,), (M,)
    tof : Quantity, days
    c3 : Quantity, km^2/s^2
        Launch energy |v1 - v_departure_planet|^2.
    v_inf_arrival : Quantity, km/s
        Hyperbolic excess speed at arrival |v2 - v_arrival_planet|.
    delta_v : Quantity, km/s
        v_inf departure + v_inf arrival (both patched-conic excess speeds).
    """

    departure: object
    arrival: object
    tof: u.Quantity
    c3: u.Quantity
    v_inf_arrival: u.Quantity
    delta_v: u.Quantity
    names: tuple

    def best(self):
        """(departure, arrival, delta_v) at the minimum total excess speed."""
        dv = self.delta_v.to_value(u.km / u.s)
        if not np.any(np.isfinite(dv)):
            raise DomainError("no transfer on this grid; widen the date ranges.")
        i, j = np.unravel_index(np.nanargmin(dv), dv.shape)
        return self.departure[i], self.arrival[j], self.delta_v[i, j]

    def plot(self, ax=None, levels=None, path=None):
        """Contour plot of C3 (filled) and the time of flight (lines); returns the Figure.

        Uses the Agg backend unless a figure already exists; ``path`` saves it to a file.
        Cells without a transfer (NaN) are left blank, not filled.

        Raises
        ------
        InvalidInputError
            A grid with fewer than 2 departure or arrival dates (no contour can be drawn:
            matplotlib's own error was about a "z" array).
        """
        if min(self.c3.shape) < 2:
            raise InvalidInputError(
                f"Porkchop.plot draws contours, which need at least 2 departure and 2 arrival "
                f"dates; this grid is {self.c3.shape[0]} x {self.c3.shape[1]}. Widen the axis "
                "with one date, or read the numbers (pc.c3, pc.delta_v, pc.best()) instead.")
        import matplotlib

        if ax is None:
            matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        if ax is None:
            fig, ax = plt.subplots(figsize=(7, 5.5))
        else:
            fig = ax.figure
        x = (self.departure - self.departure[0]).to_value(u.day)
        y = (self.arrival - self.arrival[0]).to_value(u.day)
        c3 = self.c3.to_value(u.km**2 / u.s**2).T
        if levels is None:
            finite = c3[np.isfinite(c3)]
            lo = np.nanmin(finite) if finite.size else 0.0
            levels = lo + np.array([0, 1, 2, 4, 8, 16, 32, 64])
        cs = ax.contourf(x, y, c3, levels=levels, cmap="viridis", extend="max")
        fig.colorbar(cs, ax=ax, label="C3 (km$^2$/s$^2$)")
        ct = ax.contour(x, y, self.tof.to_value(u.day).T, colors="white", linewidths=0.6)
        ax.clabel(ct, fmt="%d d", fontsize=7)
        ax.set_xlabel(f"departure, days after {self.departure[0].iso[:10]}")
        ax.set_ylabel(f"arrival, days after {self.arrival[0].iso[:10]}")
        ax.set_title(f"{self.names[0].title()} to {self.names[1].title()}")
        if path is not None:
            fig.savefig(path, dpi=100)
        return fig


def porkchop(departure_body, arrival_body, departure_times, arrival_times, revolutions=0,
             branch="left"):
    """Lambert transfers between two planets over a grid of dates.

    Parameters
    ----------
    departure_body, arrival_body : str or Body
        Planet names (``"earth"``, ``"mars"``, ...) or ``vv.MARS`` etc.
    departure_times, arrival_times : astropy Time, 1-D
        The grid axes.
    revolutions : int
        M >= 0 complete revolutions about the Sun before arriving (default 0). With M >= 1,
        grid points whose time of flight is below the minimum for M revolutions have no
        transfer and are NaN.
    branch : {"left", "right"}
        For M >= 1: Izzo's left branch (the smaller transfer orbit, default) or the right one
        (:func:`visviva.lambert`).

    Returns
    -------
    Porkchop
        C3, arrival v_inf, total excess speed and time of flight on the grid.

    Notes
    -----
    Patched conics: heliocentric zero-revolution prograde Lambert arcs (Izzo 2015) between
    the planets' positions; C3 = |v1 - v_p1|^2, v_inf = |v2 - v_p2| (Vallado 2013, sec. 12.6;
    Curtis 2014, sec. 8.10). The Sun and the Moon are refused: a heliocentric arc from the
    Earth to the Moon gave C3 = 0.0008 km^2/s^2 and 0.97 km/s, silently (audit38).
    """
    from astropy.time import Time

    from .lambert_solvers import lambert

    for name, t in (("departure_times", departure_times), ("arrival_times", arrival_times)):
        if not isinstance(t, Time) or t.ndim != 1:
            raise InvalidInputError(f"{name} must be a 1-D astropy Time array.")
    dname = str(getattr(departure_body, "name", departure_body)).lower()
    aname = str(getattr(arrival_body, "name", arrival_body)).lower()
    not_heliocentric = {"sun": "the attractor itself",
                        "moon": "it orbits the Earth, whose pull a heliocentric arc leaves out"}
    for name in (dname, aname):
        if name in not_heliocentric:
            raise InvalidInputError(
                f"porkchop solves Lambert's problem about the Sun between bodies that orbit it; "
                f"{name!r} does not ({not_heliocentric[name]}). For Earth-Moon transfers solve "
                "vv.lambert about the Earth (gm=vv.EARTH) with the Moon's geocentric position."
            )
    for name, t in (("departure_times", departure_times), ("arrival_times", arrival_times)):
        if len(t) == 0:
            raise InvalidInputError(f"{name} is empty: give at least one date per axis.")
    r1, v1p = planet_heliocentric(dname, departure_times)
    r2, v2p = planet_heliocentric(aname, arrival_times)
    tof = (arrival_times[None, :] - departure_times[:, None]).to(u.s)
    valid = tof.value > 0
    tof_safe = np.where(valid, tof.value, 1.0) * u.s
    R1 = np.broadcast_to(r1.to_value(u.km)[:, None, :], tof.shape + (3,))
    R2 = np.broadcast_to(r2.to_value(u.km)[None, :, :], tof.shape + (3,))
    # collinear geometries (transfer angle 180 deg) have no defined plane: nudge them
    cross = np.linalg.norm(np.cross(R1, R2), axis=-1)
    bad = cross <= 1e-9 * np.linalg.norm(R1, axis=-1) * np.linalg.norm(R2, axis=-1)
    R2 = np.where(bad[..., None], R2 + np.array([0.0, 0.0, 1.0]), R2)
    # one masked solve over the grid: a cell without a transfer is NaN, not an error for all
    v1, v2 = lambert(R1 * u.km, R2 * u.km, tof_safe, SUN.gm, revolutions, branch=branch,
                     on_failure="mask")
    failed = np.any(v1.mask, axis=-1)
    _warn_failed_cells(R1, R2, tof_safe, revolutions, branch, failed & valid,
                       int(np.count_nonzero(valid)))
    valid &= ~failed
    v1, v2 = v1.unmasked, v2.unmasked
    _refuse_empty_grid(valid, tof, revolutions)
    kms = u.km / u.s
    dv1 = np.linalg.norm(v1.to_value(kms) - v1p.to_value(kms)[:, None, :], axis=-1)
    dv2 = np.linalg.norm(v2.to_value(kms) - v2p.to_value(kms)[None, :, :], axis=-1)
    dv1[~valid] = np.nan
    dv2[~valid] = np.nan
    return Porkchop(
        departure_times,
        arrival_times,
        np.where(valid, tof.to_value(u.day), np.nan) * u.day,
        dv1**2 * kms**2,
        dv2 * kms,
        (dv1 + dv2) * kms,
        (dname, aname),
    )


def _warn_failed_cells(R1, R2, tof, revolutions, branch, failed, cells) -> None:
    """One warning for the grid cells with tof > 0 but no transfer, by cause (those below the
    M-revolution minimum tof are documented NaN and go unnamed), with the first one's reason:
    the failed cells alone solved again, for the causes their error names."""
    if not failed.any():
        return
    from .lambert_solvers import lambert

    where = np.argwhere(failed)
    try:
        lambert(R1[failed] * u.km, R2[failed] * u.km, tof[failed], SUN.gm, revolutions,
                branch=branch)
    except DomainError as exc:
        found = [(int(k[0]), exc.causes[k], exc.failures[k]) for k in sorted(exc.causes)]
    else:  # (cannot happen: the same transfers failed in the grid)
        return
    found = [f for f in found if f[1] != "no M-revolution solution in that time"]
    if not found:
        return
    import warnings

    counts = {}
    for _, cause, _ in found:
        counts[cause] = counts.get(cause, 0) + 1
    k, _, reason = found[0]
    cell = tuple(int(i) for i in where[k])
    causes = ", ".join(f"{n} {c}" for c, n in counts.items())
    warnings.warn(
        f"porkchop: {len(found)} of {cells} grid cells with tof > 0 have no transfer and are NaN "
        f"({causes}); the first, (departure, arrival) = {cell}: {reason}.", UserWarning,
        stacklevel=3)


def _refuse_empty_grid(valid, tof, revolutions) -> None:
    """A grid without a single transfer is a mistake in the axes, not a porkchop: refuse it.

    Each NaN point is documented (a time of flight <= 0, or below the M-revolution minimum);
    a grid of NaN alone came back silently (audit40: arrival and departure dates swapped).
    """
    if valid.any():
        return
    days = tof.to_value(u.day)
    if not (days > 0).any():
        raise InvalidInputError(
            "porkchop: every arrival time is at or before every departure time "
            f"(longest time of flight {days.max():.1f} d), so no grid point has a transfer; "
            "pass the departure dates first and the arrival dates second, with arrivals later.")
    if not revolutions:  # every cell failed for its own reasons (named by the warning before)
        raise DomainError(
            "porkchop: no grid point has a transfer (the warning above names the causes, e.g. "
            "times of flight too short for any speed below light's); widen the date axes.")
    raise DomainError(
        f"porkchop: no grid point has a transfer with revolutions={revolutions}: every time of "
        f"flight (at most {days.max():.1f} d) is below the minimum for {revolutions} complete "
        "revolution(s) about the Sun; lengthen the times of flight (later arrival dates) or "
        "lower revolutions.")
