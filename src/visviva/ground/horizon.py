"""The horizon the event search finds crossings of: geometric, or apparent (refracted).

With ``refraction`` the rise and the set of a pass are where the APPARENT elevation
``E + R(E)`` (:func:`visviva.ground.refraction.bend`, the station's air as in
:func:`visviva.ground.look.look`) crosses ``min_elevation``, as Skyfield's
``find_events(altitude_degrees=...)`` on refracted altitudes and STK's apparent access do.
``E + R(E)`` grows with the geometric elevation ``E`` from the model's lower end up (optical:
-1 deg; radio: the geometric elevation seen at -1 deg apparent),
so the apparent threshold is a geometric one per station, ``E_s + R(E_s) = min_elevation``
(the root of a monotonic function, by bisection): the coarse scan looks for crossings of
``E_s``, and the final Newton steps on SGP4 solve ``sin(E + R(E)) = sin(min_elevation)``
itself. The culmination (the highest point) is the geometric one: ``E + R(E)`` is monotonic.
"""

from __future__ import annotations

import math

import numpy as np

from ..core import topocentric as _topo
from ..errors import InvalidInputError
from .refraction import bend, lowest_geometric_deg, station_air

__all__ = ["Horizon"]


class Horizon:
    """``f = sin(el) - sin(min_elevation)`` and ``df/dt`` for the search, ``el`` geometric or
    apparent per station.

    Parameters
    ----------
    stations : list of GroundStation
    min_el_rad : float
        The threshold, rad (checked).
    refraction : bool, str or dict
        As :func:`visviva.ground.look.look`'s ``refraction`` (False: geometric).
    """

    def __init__(self, stations, min_el_rad: float, refraction=False):
        from astropy import units as u

        self.min_el_rad = float(min_el_rad)
        self.sin_min = math.sin(self.min_el_rad)
        airs = [station_air(refraction, s.height.to_value(u.m)) for s in stations]
        self.refracted = airs[0] is not None
        self.sin_geo = np.full(len(stations), self.sin_min)  # the scan's threshold per station
        self.model = airs[0][0] if self.refracted else None
        self._groups = []  # (air, station indices) for each distinct air
        if not self.refracted:
            return
        for air in dict.fromkeys(airs):
            members = np.array([k for k, a in enumerate(airs) if a == air], dtype=np.int64)
            self._groups.append((air, members))
            el_geo = _geometric_threshold_deg(math.degrees(self.min_el_rad), air,
                                              [stations[k].name for k in members])
            self.sin_geo[members] = math.sin(math.radians(el_geo))

    @property
    def label(self) -> str:
        """What the elevations of the events are: ``"geometric"`` or ``"apparent (optical
        refraction)"`` / ``"apparent (radio refraction)"``."""
        return f"apparent ({self.model} refraction)" if self.refracted else "geometric"

    @property
    def lowest_geometric_rad(self) -> float:
        """The lowest geometric threshold of any station, rad."""
        if not self.refracted:
            return self.min_el_rad
        return float(np.arcsin(np.min(self.sin_geo)))

    def f(self, r, v, sites, ups, site_index, geometric=None) -> np.ndarray:
        """``(f, df/dt)`` (M, 2) at Earth-fixed states ``r, v`` (M, 3) seen from
        ``sites[site_index]``; ``f = sin(el) - sin(min_elevation)``, ``el`` apparent when
        refracted (``d sin(el_app)/dt = cos(el_app) (1 + R') d el/dt``; the range's change is
        left out of the rate, a Newton slope), except in the rows where ``geometric`` (M,
        bool) is set: the culminations are the geometric maxima, found on ``f`` as without
        refraction."""
        fd = np.empty((len(r), 2))
        idx = np.ascontiguousarray(site_index, dtype=np.int64)
        if not self.refracted:
            _topo.elevation_rate_many(r, v, sites, ups, idx, self.sin_min, fd)
            return fd
        if geometric is not None and geometric.any():
            fd[~geometric] = self.f(r[~geometric], v[~geometric], sites, ups, idx[~geometric])
            plain = np.empty((int(geometric.sum()), 2))
            _topo.elevation_rate_many(np.ascontiguousarray(r[geometric]),
                                      np.ascontiguousarray(v[geometric]), sites, ups,
                                      idx[geometric], self.sin_min, plain)
            fd[geometric] = plain
            return fd
        _topo.elevation_rate_many(r, v, sites, ups, idx, 0.0, fd)
        s = np.clip(fd[:, 0], -1.0, 1.0)
        el = np.arcsin(s)
        rng = np.linalg.norm(r - sites[idx], axis=-1)
        r_deg, slope = self.bend(np.degrees(el), idx, rng, exact_slope=False)
        app = el + np.radians(r_deg)
        cos_el = np.cos(el)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(cos_el > 1e-12, np.cos(app) / cos_el, 1.0)
        fd[:, 1] = fd[:, 1] * ratio * (1.0 + slope)
        fd[:, 0] = np.sin(app) - self.sin_min
        return fd

    def bend(self, el_deg, site_index, range_km, exact_slope=True):
        """Refraction (deg) and its slope at geometric elevations ``el_deg`` (deg) of targets
        at ``range_km`` (km) seen from stations ``site_index``: each station's air."""
        from .finite_range import refracts

        r_deg = np.zeros_like(el_deg)
        slope = np.zeros_like(el_deg)
        # a "target" less than 1 km above the station is an SGP4 failure (decayed, inside the
        # Earth): left geometric, never refused in the middle of a catalogue's search
        ok = np.isfinite(el_deg) & np.isfinite(range_km)
        ok[ok] = refracts(el_deg[ok], range_km[ok])
        for air, members in self._groups:
            m = np.isin(site_index, members) & ok
            if m.any():
                r_deg[m], slope[m] = bend(el_deg[m], *air, range_km=range_km[m],
                                          exact_slope=exact_slope)
        return r_deg, slope

    def apparent_rad(self, el_rad, site_index, range_km) -> np.ndarray:
        """The elevations ``el_rad`` (geometric, rad) of targets at ``range_km`` as the events
        report them: apparent when refracted, else unchanged (the same array)."""
        if not self.refracted:
            return el_rad
        return el_rad + np.radians(self.bend(np.degrees(el_rad), site_index, range_km,
                                             exact_slope=False)[0])


def _geometric_threshold_deg(min_el_deg: float, air, names) -> float:
    """The geometric elevation ``E`` (deg) with ``E + R(E) = min_el_deg`` in the air ``air``;
    refuses a threshold below the apparent elevation of the model's lower end (optical: -1 deg
    geometric; radio: -1 deg apparent)."""
    lo, hi = lowest_geometric_deg(*air), min_el_deg
    lowest = lo + float(bend(np.array(lo), *air)[0])
    if min_el_deg < lowest:
        raise InvalidInputError(
            f"min_elevation = {min_el_deg:.6g} deg is below the lowest apparent elevation the "
            f"refraction models cover at station(s) {', '.join(map(str, names))} "
            f"({lowest:.4g} deg, the apparent elevation of {lo:.4g} deg geometric, the lower "
            f"end of {air[0]} refraction): raise min_elevation, or pass refraction=False for a "
            "geometric threshold.")
    if min_el_deg >= 90.0:
        return 90.0
    for _ in range(200):  # bisection on E + R(E), increasing: to the last bit
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if mid + float(bend(np.array(mid), *air)[0]) < min_el_deg:
            lo = mid
        else:
            hi = mid
    return hi
