"""Terrain and elevation masks: a station's local horizon as a minimum elevation per azimuth.

An :class:`ElevationMask` is a table of (azimuth, minimum elevation) points, interpolated
linearly in azimuth and wrapped around north (the last point joins the first through
360 -> 0 deg), as Orekit's ``ElevationMask`` / ``GroundMaskElevationDetector`` (the limit
between two points is linear in azimuth-elevation, not a great circle) and STK's AzElMask
take it. Passes over a masked station rise and set where the satellite crosses the mask
(:mod:`visviva.ground.masked_search`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from astropy import units as u

from .._units import is_quantity, to_array
from ..errors import DomainError, InvalidInputError, ShapeError

__all__ = ["ElevationMask", "station_thresholds"]

_TWO_PI = 2.0 * math.pi


class ElevationMask:
    """A station's local horizon: the minimum elevation as a function of azimuth.

    Parameters
    ----------
    azimuth : Quantity (angle), shape (K,)
        Azimuths of the mask's points, from north through east, in [0, 360] deg (360 is
        north, as 0). Any order: the points are sorted by azimuth (the order of two points
        at one azimuth is kept: see Notes).
    elevation : Quantity (angle), shape (K,)
        The minimum elevation at each azimuth, in [-90, 90] deg (negative for a site above
        its surroundings: a mountain top, an aircraft).

    Attributes
    ----------
    azimuth, elevation : Quantity (deg)
        The points, sorted by azimuth.
    lowest, highest : Quantity (deg)
        The lowest and highest elevation of the mask.
    is_flat : bool
        All points at one elevation (then the search is exactly the scalar threshold's).

    Notes
    -----
    Between two neighbouring points ``(A1, E1)``, ``(A2, E2)`` the mask is
    ``E(A) = E1 + (E2 - E1) (A - A1) / (A2 - A1)``; past the last point it runs to the first
    one plus 360 deg (wrap-around). One point is a flat mask. Two points at the same azimuth
    make a vertical step there (a building's edge): the first given is the value on the
    lower-azimuth side, the second on the higher side, and the mask at that azimuth is the
    higher of the two. 0 and 360 deg are the same azimuth: a point at 360 deg is the value
    on the lower-azimuth side of north. More than two points at one azimuth are refused.

    Examples
    --------
    >>> import visviva as vv
    >>> from astropy import units as u
    >>> hill = vv.ElevationMask([0, 90, 180, 270] * u.deg, [5, 20, 5, 0] * u.deg)
    >>> hill([45, 315] * u.deg)
    <Quantity [12.5,  2.5] deg>
    """

    __slots__ = ("_az", "_el", "_xp", "_yp", "_max_slope", "_steps")

    def __init__(self, azimuth, elevation):
        az = _angles(azimuth, "azimuth")
        el = _angles(elevation, "elevation")
        if az.shape != el.shape:
            raise ShapeError(f"azimuth and elevation must have the same length, got {az.size} "
                             f"and {el.size} points.")
        self._setup(az, el, lambda k: f"point {k} (azimuth[{k}], elevation[{k}])")

    def _setup(self, az, el, where) -> None:
        if az.size == 0:
            raise InvalidInputError("an elevation mask needs at least one point (one point is "
                                    "a flat mask).")
        for k in range(az.size):
            a, e = math.degrees(az[k]), math.degrees(el[k])
            if not (math.isfinite(a) and math.isfinite(e)):
                raise InvalidInputError(f"{where(k)}: azimuth {a} deg, elevation {e} deg is not "
                                        "finite; give numbers.")
            if not 0.0 <= a <= 360.0 * (1 + 1e-15):
                raise DomainError(f"{where(k)}: azimuth {a:.6g} deg is outside [0, 360] deg "
                                  "(from north through east); wrap it into [0, 360].")
            if abs(e) > 90.0 * (1 + 1e-15):
                raise DomainError(f"{where(k)}: elevation {e:.6g} deg is outside [-90, 90] "
                                  "deg; check the column order (azimuth, elevation) and "
                                  "the unit.")
        order = np.argsort(az, kind="stable")
        az, el = np.minimum(az[order], _TWO_PI), np.clip(el[order], -math.pi / 2, math.pi / 2)
        key = np.where(az >= _TWO_PI, 0.0, az)  # 360 deg is north
        values, counts = np.unique(key, return_counts=True)
        if (counts > 2).any():
            bad = float(np.degrees(values[counts > 2][0]))
            lines = [where(int(order[k])) for k in np.flatnonzero(key == values[counts > 2][0])]
            raise InvalidInputError(
                f"more than two points at azimuth {bad:.6g} deg ({'; '.join(lines)}): one "
                "point gives the mask there, two a vertical step (lower side first); drop the "
                "others.")
        self._az, self._el = az, el
        # the table with its wrap-around: the last point 360 deg back, the first one ahead
        self._xp = np.concatenate([[az[-1] - _TWO_PI], az, [az[0] + _TWO_PI]])
        self._yp = np.concatenate([[el[-1]], el, [el[0]]])
        dx, dy = np.diff(self._xp), np.diff(self._yp)
        step = (dx == 0.0) & (dy != 0.0)
        run = dx > 0.0
        self._max_slope = float(np.abs(dy[run] / dx[run]).max()) if run.any() else 0.0
        self._steps = np.unique(np.mod(self._xp[1:][step], _TWO_PI))

    @classmethod
    def from_file(cls, path) -> ElevationMask:
        """Read a mask from a text file of two columns: azimuth (deg), elevation (deg).

        Parameters
        ----------
        path : str or path-like
            A plain text file: one point per line, the two numbers separated by spaces, tabs
            or a comma; ``#`` starts a comment; blank lines are skipped.

        Returns
        -------
        ElevationMask

        Raises
        ------
        InvalidInputError
            A line that is not two numbers, a value out of range or not finite, or a file
            with no points: the message names the file and the line.
        """
        p = Path(path)
        if not p.is_file():
            from ..errors import MissingFileError

            raise MissingFileError(p, "check the path of the elevation mask file (two "
                                      "columns: azimuth deg, elevation deg).")
        az, el, line_no = [], [], []
        with p.open(encoding="utf-8-sig") as fh:  # (a byte-order mark, as Notepad saves)
            for n, raw in enumerate(fh, start=1):
                text = raw.split("#", 1)[0].replace(",", " ").split()
                if not text:
                    continue
                if len(text) != 2:
                    raise InvalidInputError(
                        f"{p}, line {n}: expected two numbers (azimuth deg, elevation deg), got "
                        f"{len(text)} field(s): {raw.strip()!r}.")
                try:
                    a, e = float(text[0]), float(text[1])
                except ValueError:
                    raise InvalidInputError(
                        f"{p}, line {n}: {raw.strip()!r} is not two numbers (azimuth deg, "
                        "elevation deg); start a header or note with '#'.") from None
                az.append(a)
                el.append(e)
                line_no.append(n)
        if not az:
            raise InvalidInputError(f"{p} holds no points: expected lines of 'azimuth "
                                    "elevation' in degrees.")
        self = cls.__new__(cls)
        self._setup(np.radians(az), np.radians(el), lambda k: f"{p}, line {line_no[k]}")
        return self

    # attributes -----------------------------------------------------------------------------
    @property
    def azimuth(self):
        """Azimuths of the points, sorted (deg)."""
        return np.degrees(self._az) * u.deg

    @property
    def elevation(self):
        """Minimum elevations at :attr:`azimuth` (deg)."""
        return np.degrees(self._el) * u.deg

    @property
    def lowest(self):
        """The lowest elevation of the mask (deg)."""
        return math.degrees(self.lowest_rad) * u.deg

    @property
    def highest(self):
        """The highest elevation of the mask (deg)."""
        return math.degrees(float(self._el.max())) * u.deg

    @property
    def lowest_rad(self) -> float:
        """The lowest elevation of the mask, rad."""
        return float(self._el.min())

    @property
    def max_slope(self) -> float:
        """The steepest side of the mask, d(elevation)/d(azimuth) (rad/rad; its vertical
        steps left out: :attr:`step_azimuths_rad`)."""
        return self._max_slope

    @property
    def step_azimuths_rad(self) -> np.ndarray:
        """Azimuths of the mask's vertical steps, rad in [0, 2 pi)."""
        return self._steps

    @property
    def is_flat(self) -> bool:
        """All points at one elevation."""
        return bool((self._el == self._el[0]).all())

    # evaluation -----------------------------------------------------------------------------
    def elevation_rad(self, az_rad) -> np.ndarray:
        """The mask at azimuths ``az_rad`` (rad, any real value, wrapped), rad; vectorised.

        Linear between the neighbouring points; at a vertical step the higher side."""
        az = np.mod(np.asarray(az_rad, dtype=np.float64), _TWO_PI)
        xp, yp = self._xp, self._yp
        last = xp.size - 1
        i = np.clip(np.searchsorted(xp, az, side="right") - 1, 0, last - 1)  # xp[i] <= az
        j = np.clip(np.searchsorted(xp, az, side="left"), 1, last)  # xp[j] >= az
        out = np.maximum(_lerp(xp, yp, i, i + 1, az), _lerp(xp, yp, j - 1, j, az))
        return out

    def __call__(self, azimuth):
        """The minimum elevation at ``azimuth`` (an angle Quantity, any shape), deg."""
        if not is_quantity(azimuth):
            from .. import errors

            raise errors.UnitsError(f"azimuth must be an angle Quantity such as 45 * u.deg, got "
                                    f"a plain {type(azimuth).__name__}.")
        return np.degrees(self.elevation_rad(to_array(azimuth, "angle", "azimuth"))) * u.deg

    # protocol -------------------------------------------------------------------------------
    def __repr__(self):
        pts = ", ".join(f"({a:.6g}, {e:.6g})" for a, e in
                        zip(np.degrees(self._az[:4]), np.degrees(self._el[:4]), strict=True))
        more = f", ... {self._az.size} points" if self._az.size > 4 else ""
        return f"ElevationMask([{pts}{more}] deg)"

    def __eq__(self, other):
        if not isinstance(other, ElevationMask):
            return NotImplemented
        return (np.array_equal(self._az, other._az) and np.array_equal(self._el, other._el))

    def __hash__(self):
        return hash((self._az.tobytes(), self._el.tobytes()))

    def __getstate__(self):
        return (self._az, self._el)

    def __setstate__(self, state):
        self._setup(state[0], state[1], lambda k: f"point {k}")


def _lerp(xp, yp, a, b, x):
    """Linear interpolation between points ``a`` and ``b`` (equal abscissae: ``yp[b]``)."""
    dx = xp[b] - xp[a]
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where(dx > 0.0, (x - xp[a]) / dx, 1.0)
    return yp[a] + (yp[b] - yp[a]) * np.clip(w, 0.0, 1.0)


def _angles(value, name: str) -> np.ndarray:
    """A 1-D angle Quantity -> float rad (plain numbers refused: degrees or radians?)."""
    if not is_quantity(value):
        from .. import errors

        raise errors.UnitsError(
            f"{name} must be an angle Quantity such as [0, 90, 180, 270] * u.deg, got a plain "
            f"{type(value).__name__}: degrees and radians are too easy to confuse.")
    arr = np.atleast_1d(to_array(value, "angle", name, finite=False))
    if arr.ndim != 1:
        raise ShapeError(f"{name} must be one-dimensional, got shape {arr.shape}.")
    return arr


def station_thresholds(min_elevation, n_stations: int):
    """``min_elevation`` of the pass search -> ``(flat_rad, masks)``.

    ``min_elevation`` is a scalar angle Quantity (``masks`` is None: the scalar search,
    unchanged), an :class:`ElevationMask` for every station, or a list with one entry (a
    Quantity or a mask) per station (or a 1-D angle Quantity, one value per station). ``flat_rad`` is the scalar threshold of the first search:
    the threshold itself, or the lowest elevation of all the masks (every mask crossing lies
    inside a pass above it); ``masks`` one :class:`ElevationMask` per station.
    """
    from .search import min_elevation_rad

    if isinstance(min_elevation, ElevationMask):
        if min_elevation.is_flat:  # the scalar search, bit for bit
            return float(min_elevation._el[0]), None
        return min_elevation.lowest_rad, [min_elevation] * n_stations
    if is_quantity(min_elevation) and np.ndim(min_elevation) == 1 and n_stations > 1:
        min_elevation = list(min_elevation)  # one per station, checked below
    if is_quantity(min_elevation) or not isinstance(min_elevation, (list, tuple)):
        return min_elevation_rad(min_elevation), None
    if len(min_elevation) != n_stations:
        raise ShapeError(f"min_elevation has {len(min_elevation)} entries for {n_stations} "
                         "station(s): give one threshold (a Quantity or an ElevationMask) per "
                         "station, in the stations' order, or one for all.")
    masks = []
    for k, m in enumerate(min_elevation):
        if isinstance(m, ElevationMask):
            masks.append(m)
            continue
        try:
            el = min_elevation_rad(m)
        except InvalidInputError as exc:
            raise type(exc)(f"min_elevation[{k}]: {exc}") from None
        masks.append(ElevationMask([0.0] * u.rad, [el] * u.rad))
    flats = {float(m._el[0]) for m in masks if m.is_flat}
    if all(m.is_flat for m in masks) and len(flats) == 1:
        return flats.pop(), None
    return min(m.lowest_rad for m in masks), masks
