"""Observations for orbit determination: one row per measurement, validated once.

>>> import visviva as vv
>>> from astropy import units as u
>>> from astropy.time import Time
>>> t = Time("2024-01-01T00:00:00", scale="utc") + [0, 60, 120] * u.s
>>> obs = vv.Observations(time=t, kind="position",
...                       value=[[7000, 0, 0], [6990, 450, 0], [6960, 900, 0]] * u.km,
...                       sigma=0.01 * u.km)
>>> len(obs), str(obs.kinds[0])
(3, 'position')
"""

from __future__ import annotations

import numpy as np

from .._units import is_quantity, require_usable_time, to_array
from ..errors import DomainError, InvalidInputError, ShapeError

__all__ = ["Observations", "KINDS", "sigma_value"]

#: kind -> (number of components, physical kind of value and sigma, needs a station)
KINDS = {
    "position": (3, "length", False),
    "range": (1, "length", True),
    "range_rate": (1, "speed", True),
    "azel": (2, "angle", True),
    "radec": (2, "angle", True),
}

_UNITS_TEXT = {"length": "km", "speed": "km/s", "angle": "rad"}

#: rows with the estimate more than this below their ground station's horizon are warned about,
#: deg (refraction lifts the apparent horizon by at most 0.6 deg)
BELOW_HORIZON_DEG = 1.0


def _row_value(value, kind, i):
    dim, phys, _ = KINDS[kind]
    arr = to_array(value, phys, f"value[{i}]", allow_plain=True)
    if arr.size != dim or (dim > 1 and arr.shape != (dim,)):
        raise ShapeError(
            f"observation {i} of kind {kind!r} needs a value of {dim} component(s) "
            f"({_UNITS_TEXT[phys]}); got shape {arr.shape}."
        )
    arr = arr.reshape(dim)
    if kind == "range" and arr[0] < 0:
        raise DomainError(
            f"observation {i}: a range is a distance, >= 0; got {float(arr[0]):g} km. Check the sign "
            "and the unit (plain numbers are km)."
        )
    if phys == "angle" and abs(arr[1]) > np.pi / 2:
        name = "elevation" if kind == "azel" else "declination"
        raise DomainError(
            f"observation {i} ({kind}): the {name} {float(arr[1]):g} rad is outside [-pi/2, pi/2]. "
            "Plain numbers are radians: pass degrees as a Quantity, e.g. [200, 30] * u.deg."
        )
    if phys == "angle" and not abs(arr[0]) <= 2 * np.pi:  # audit24: [200, 1] rad accepted
        name = "azimuth" if kind == "azel" else "right ascension"
        raise DomainError(
            f"observation {i} ({kind}): the {name} {float(arr[0]):g} rad is outside "
            "[-2 pi, 2 pi]. Plain numbers are radians: pass degrees as a Quantity, e.g. "
            "[200, 30] * u.deg."
        )
    return arr


def sigma_value(s, kind: str, name: str) -> float:
    """One measurement standard deviation of ``kind``, canonical (km, km/s, rad), checked.

    ``s`` is a Quantity in the kind's units or a plain number in canonical units; ``name``
    names it in the error (``"sigma[3]"``, ``"sigma['range']"``).
    """
    val = to_array(s, KINDS[kind][1], name, allow_plain=True, finite=False)
    if val.size != 1 or not np.isfinite(val).all() or not float(val.ravel()[0]) > 0:
        raise InvalidInputError(
            f"{name} must be one finite number > 0 ({_UNITS_TEXT[KINDS[kind][1]]}); "
            f"got {s!r}. A sigma is the measurement's standard deviation."
        )
    return float(val.ravel()[0])


def _warn_repeated_rows(offsets_s, kinds, vals, stations, times):
    """TrackingDataWarning when a row repeats an earlier one exactly (time, kind, station and
    value): real measurements differ by their noise, so such a copy is data read or appended
    twice, which the fits count twice (a covariance sqrt(2) too small)."""
    seen = {}
    repeats = []
    for i, (t, k, v, st) in enumerate(zip(offsets_s, kinds, vals, stations, strict=True)):
        key = (float(t), k, v.tobytes())
        if any(stations[j] is st or stations[j] == st for j in seen.get(key, ())):
            repeats.append(i)
        seen.setdefault(key, []).append(i)
    if not repeats:
        return
    import warnings

    from ..errors import TrackingDataWarning

    i = repeats[0]
    warnings.warn(
        f"{len(repeats)} observation row(s) repeat an earlier row exactly (the same time, kind, "
        f"station and value; first row {i}, {kinds[i]} at {times[i].utc.isot} UTC): the data "
        "were probably read or appended twice (the same TDM given twice?). Each copy counts as "
        "a measurement, so the fit's covariance comes out too small: drop the duplicates.",
        TrackingDataWarning, stacklevel=3)


def _warn_per_component_reading(sigmas, kinds, n):
    """TrackingDataWarning when N different sigmas for N rows of one kind with N components
    each (3 position rows with an x, y, z sigma; 2 azel rows with an azimuth and an elevation
    sigma) could be meant per component: they are read one per row (audit44's left item)."""
    dim = KINDS[kinds[0]][0]
    if n < 2 or dim != n or any(k != kinds[0] for k in kinds) or np.all(sigmas == sigmas[0]):
        return
    import warnings

    from ..errors import TrackingDataWarning

    warnings.warn(
        f"sigma has {n} different entries for {n} {kinds[0]} rows of {dim} components each: "
        "they are read as one sigma per row (each applying to every component of its row), "
        "not one per component (visviva takes no per-component sigmas). If they were meant "
        f"per component, give one value for all rows or split the kinds; to say 'per row' and "
        f"silence this, pass them with shape ({n}, 1).",
        TrackingDataWarning, stacklevel=4)


def _height_km(station):
    """A station's height above the ellipsoid in km (0 when it gives none)."""
    h = getattr(station, "height", None)
    return float(h.to_value("km")) if is_quantity(h) else 0.0


class Observations:
    """A table of observations of one object: times, kinds, values, sigmas and stations.

    Parameters
    ----------
    time : astropy Time, shape (N,)
        Observation times (non-decreasing).
    kind : str or sequence of str
        One per row (or one for all): ``"position"`` (GCRS, 3 components, km), ``"range"``
        (km), ``"range_rate"`` (km/s), ``"azel"`` (azimuth from north through east and
        elevation, rad or angle Quantity), ``"radec"`` (topocentric right ascension and
        declination in GCRS axes, rad or angle Quantity).
    value : Quantity or array_like or sequence
        One value per row: a Quantity array (N, k) when every row has the same kind, or a list
        of per-row values (Quantities or numbers in km, km/s, rad).
    sigma : Quantity or float or sequence
        One standard deviation per row (or one for all), in the value's units; > 0. It applies
        to each component of the row (both angles of an azel row, each axis of a position).
        There are no per-component sigmas: N different sigmas for N rows of N components each
        (two azel rows, three position rows) are read one per row with a
        ``TrackingDataWarning``, as they may have been meant per component; shape (N, 1)
        says "per row" without it.
    station : GroundStation or sequence, optional
        The observing station of each row (one for all, or a list with None for position rows);
        needs ``gcrs_position_velocity(t)`` and, for azel, ``enu_matrix`` (ITRS).
    light_time : bool
        True (default, what real tracking measures): the models include the signal's flight
        time: range and range rate two-way (round trip from the station), az/el and RA/Dec
        one-way (where the satellite was when the light left it), times tagged at reception
        (:mod:`visviva.od.light_time`). False: geometric values at the tag time (the station
        and the satellite at the same instant), e.g. for data made that way.
    radec_reference : {"gcrs", "stars"}
        What RA/Dec rows are: ``"gcrs"`` (default) the natural direction of the incoming light
        in the GCRS; ``"stars"`` optical astrometry reduced against catalogue stars (the
        barycentric direction: differs by up to 20.5 arcsec, the Earth's velocity times the
        flight time). ``"stars"`` needs ``light_time=True``.
    troposphere : bool or dict
        False (default): geometric signal paths, for data already corrected. True: the models
        add the neutral atmosphere as the station measures it (range delay, its rate in range
        rates, refraction of azel elevations; :mod:`visviva.od.troposphere`) with the
        standard atmosphere at each station's height; a dict of ``pressure_hpa``,
        ``temperature_c``, ``relative_humidity`` (0..1) gives the air at every station (the
        keys left out from the standard air), and its ``refraction`` the model of azel
        elevations: ``"optical"`` (default, Saemundsson's formula) or ``"radio"`` (antenna
        angles, :func:`visviva.ground.refraction_deg`); ``look(refraction=...)`` takes the
        same dict.
    ionosphere : dict, optional
        None (default): no ionosphere (data corrected for it, or optical). ``{"vtec_tecu": V,
        "shell_km": 350.0}``: a vertical electron content V (TEC units) on a thin shell;
        ``{"klobuchar": (alpha, beta)}``: the GPS broadcast model's 4 + 4 coefficients; an
        optional ``"doppler"`` key, ``"group"`` (default) or ``"phase"`` (carrier Doppler),
        gives the sign of the delay's rate in range rates. Range rows get the group delay
        ``40.3 TEC / f^2``, range rates its rate; angles are left alone
        (:mod:`visviva.od.ionosphere`). Needs ``frequency_hz``.
    frequency_hz : float or Quantity, or a sequence of them, optional
        The signal's frequency (Hz, > 0), e.g. 2.2e9 for S band: required by ``ionosphere``.
        One for every row, or one per row (NaN allowed on rows the ionosphere leaves alone);
        a two-way link with different uplink and downlink frequencies takes
        :func:`visviva.od.ionosphere.two_way_frequency_hz` of the two.

    Attributes
    ----------
    times : astropy Time (N,)
    kinds : ndarray of str (N,)
    values : ndarray (N, 3)
        Canonical values (km, km/s, rad), padded with zeros after the row's components.
    dims : ndarray of int (N,)
        Components per row.
    sigmas : ndarray (N,)
        Canonical sigmas.
    stations : list
        Station of each row (None for positions).
    light_time : bool
    radec_reference : str
    troposphere : visviva.od.troposphere.Weather or None
        The stations' air (None: no troposphere in the models).
    ionosphere : visviva.od.ionosphere.Ionosphere or None
        The checked ionosphere model with its frequency (None: none in the models).

    Raises
    ------
    InvalidInputError
        No observations, an unknown kind, an unknown ``radec_reference``, a non-positive or non-finite sigma, a row needing a
        station without one, times that go backwards, a time that is not an astropy Time, or
        ``troposphere`` or ``ionosphere`` with an observer that is not a ground station, an
        ionosphere without a frequency or with bad numbers.
    ShapeError
        A value with the wrong number of components.
    DomainError
        An impossible value: a negative range, an elevation or declination outside
        [-90, 90] deg, or an azimuth or right ascension outside [-360, 360] deg (often degrees
        passed as plain numbers, which are read as radians).

    Warns
    -----
    TrackingDataWarning
        A row that repeats an earlier one exactly (time, kind, station and value): data read
        or appended twice, which a fit would count twice.
    """

    def __init__(self, time, kind, value, sigma, station=None, *, light_time=True,
                 radec_reference="gcrs", troposphere=False, ionosphere=None,
                 frequency_hz=None):  # fmt: skip
        from astropy.time import Time

        from .ionosphere import ionosphere_from
        from .troposphere import weather_from

        weather = weather_from(troposphere)

        if not isinstance(light_time, bool | np.bool_):
            raise InvalidInputError(
                f"light_time must be True (model the signal's flight time) or False; got "
                f"{light_time!r}."
            )
        if radec_reference not in ("gcrs", "stars"):
            raise InvalidInputError(
                f"radec_reference must be 'gcrs' (natural GCRS direction) or 'stars' (reduced "
                f"against catalogue stars); got {radec_reference!r}."
            )
        if radec_reference == "stars" and not light_time:
            raise InvalidInputError(
                "radec_reference='stars' models the light's flight in the barycentric frame: "
                "it needs light_time=True."
            )

        if not isinstance(time, Time):
            raise InvalidInputError(
                f"time must be an astropy Time array (stations and the force model need dates); "
                f"got {type(time).__name__}."
            )
        require_usable_time(time, "time")
        times = time.reshape(-1) if time.ndim else time.reshape(1)
        n = len(times)
        if n == 0:
            raise InvalidInputError("there are no observations: give at least one row.")
        kinds = [kind] * n if isinstance(kind, str) else list(kind)
        if len(kinds) != n:
            raise ShapeError(f"kind has {len(kinds)} entries for {n} times; give one per row.")
        for i, k in enumerate(kinds):
            if k not in KINDS:
                raise InvalidInputError(
                    f"observation {i} has unknown kind {k!r}; use one of {', '.join(KINDS)}."
                )
        from ..satellites.frames import offline_iers

        with offline_iers():  # times in UT1 need the installed IERS table, never a download
            tt = times.tt
        dt = np.diff((tt - tt[0]).sec) if n > 1 else np.zeros(0)
        if np.any(dt < 0):
            i = int(np.flatnonzero(dt < 0)[0]) + 1
            raise InvalidInputError(
                f"observation times must not go backwards: row {i} ({times[i].isot}) comes before "
                f"row {i - 1} ({times[i - 1].isot}). Sort the observations by time."
            )
        if isinstance(value, list | tuple):
            rows = list(value)
        elif (is_quantity(value) or isinstance(value, np.ndarray)) and np.ndim(value) >= 1 and (
            len(value) == n and (np.ndim(value) > 1 or all(KINDS[k][0] == 1 for k in kinds))
        ):
            rows = [value[i] for i in range(n)]
        elif n == 1:
            rows = [value]
        else:
            raise ShapeError(
                f"value has shape {np.shape(value)} for {n} rows; give an (N, k) array or a list "
                "with one value per row."
            )
        if len(rows) != n:
            raise ShapeError(f"value has {len(rows)} rows for {n} times; give one per row.")
        vals = np.zeros((n, 3))
        dims = np.zeros(n, dtype=np.int64)
        for i, (k, v) in enumerate(zip(kinds, rows, strict=True)):
            arr = _row_value(v, k, i)
            vals[i, : arr.size] = arr
            dims[i] = arr.size
        iono = ionosphere_from(ionosphere, frequency_hz, kinds)
        sig = self._sigmas(sigma, kinds, n)
        stations = self._stations(station, kinds, n)
        for name, on in (("troposphere", weather), ("ionosphere", iono)):
            if on is None:  # audit20: an AttributeError from deep inside before
                continue
            for i, st in enumerate(stations):
                if st is not None and not hasattr(st, "enu_matrix"):
                    raise InvalidInputError(
                        f"observation {i} ({kinds[i]}): {name} models the air above "
                        f"a ground station, and its observer {type(st).__name__} has no "
                        "horizon (no enu_matrix): give it a vv.GroundStation, or keep the "
                        f"rows of other observers in a table without {name}.")
        _warn_repeated_rows((tt - tt[0]).sec, kinds, vals, stations, times)
        self.times = times
        self.kinds = np.array(kinds)
        self.values = vals
        self.dims = dims
        self.sigmas = sig
        self.stations = stations
        self.light_time = bool(light_time)
        self.radec_reference = radec_reference
        self.troposphere = weather
        self.ionosphere = iono
        self._cache = {}

    @staticmethod
    def _sigmas(sigma, kinds, n):
        if (is_quantity(sigma) or isinstance(sigma, np.ndarray)) and np.ndim(sigma) == 0 or (
            np.isscalar(sigma)
        ):
            items = [sigma] * n
            explicit = True
        else:
            # an (N, 1) array says "one per row" explicitly (no ambiguity warning below)
            explicit = isinstance(sigma, np.ndarray) and sigma.ndim == 2 and sigma.shape[1] == 1
            items = [row[0] for row in sigma] if explicit else list(sigma)
        if len(items) != n:
            raise ShapeError(f"sigma has {len(items)} entries for {n} rows; give one per row.")
        out = np.empty(n)
        for i, (k, s) in enumerate(zip(kinds, items, strict=True)):
            out[i] = sigma_value(s, k, f"sigma[{i}]")
        if not explicit:
            _warn_per_component_reading(out, kinds, n)
        return out

    @staticmethod
    def _stations(station, kinds, n):
        if station is None or not isinstance(station, list | tuple | np.ndarray):
            stations = [station] * n
        else:
            stations = list(station)
        if len(stations) != n:
            raise ShapeError(f"station has {len(stations)} entries for {n} rows.")
        for i, (k, s) in enumerate(zip(kinds, stations, strict=True)):
            if KINDS[k][2] and (s is None or not hasattr(s, "gcrs_position_velocity")):
                raise InvalidInputError(
                    f"observation {i} ({k}) needs the observing station: pass "
                    "station=vv.GroundStation(lat, lon, height) (one, or one per row)."
                )
            if k == "azel" and not hasattr(s, "enu_matrix"):
                raise InvalidInputError(
                    f"observation {i} (azel) needs a station with an enu_matrix (a GroundStation)."
                )
            if not KINDS[k][2]:
                stations[i] = None
        return stations

    def __len__(self):
        return len(self.times)

    def __repr__(self):
        counts = {k: int(np.sum(self.kinds == k)) for k in KINDS if np.any(self.kinds == k)}
        span = self.offsets_s(self.times[0])[-1] if len(self) else 0.0
        return f"Observations({len(self)} rows {counts}, span {span:.1f} s)"

    def without_media(self):
        """The same rows without the troposphere and the ionosphere in their models.

        The times, kinds, values, sigmas, stations, ``light_time`` and ``radec_reference`` are
        shared (arrays not copied: the table is not modified in place); only ``troposphere``
        and ``ionosphere`` become None. For fitting the same data with geometric models only,
        e.g. to see what the media move.

        Returns
        -------
        Observations

        Examples
        --------
        >>> import numpy as np
        >>> from astropy import units as u
        >>> from astropy.time import Time
        >>> import visviva as vv
        >>> site = vv.GroundStation(40 * u.deg, -4 * u.deg, 0.8 * u.km)
        >>> obs = vv.Observations(time=Time("2024-01-01") + [0, 60] * u.s, kind="range",
        ...                       value=[1000.0, 1010.0] * u.km, sigma=0.01, station=site,
        ...                       troposphere=True)
        >>> plain = obs.without_media()
        >>> plain.troposphere is None, obs.troposphere is not None, len(plain)
        (True, True, 2)
        """
        import copy

        out = copy.copy(self)
        out.troposphere = None
        out.ionosphere = None
        out._cache = {}  # the sites' ENU rows depend on the media
        return out

    def offsets_s(self, epoch):
        """Times as seconds from ``epoch`` (differences in TT)."""
        from ..satellites.frames import offline_iers

        with offline_iers():  # times in UT1 need the installed IERS table, never a download
            return np.asarray((self.times.tt - epoch.tt).sec, dtype=np.float64)

    def sites(self):
        """GCRS site position (km), velocity (km/s) and GCRS->ENU rows, each (N, 3[, 3]).

        Rows without a station get zeros. Computed once per table and cached.
        """
        if "sites" in self._cache:
            return self._cache["sites"]
        n = len(self)
        r = np.zeros((n, 3))
        v = np.zeros((n, 3))
        enu = np.zeros((n, 3, 3))
        groups = {}
        for i, s in enumerate(self.stations):
            if s is not None:
                groups.setdefault(id(s), (s, []))[1].append(i)
        for s, idx in groups.values():
            idx = np.asarray(idx)
            ri, vi = s.gcrs_position_velocity(self.times[idx])
            r[idx] = ri
            v[idx] = vi
            media = self.troposphere is not None or self.ionosphere is not None
            if media or np.any(self.kinds[idx] == "azel"):
                from ..satellites.frames import transform_matrices

                m = transform_matrices(self.times[idx], "gcrs", "itrs")[:, :3, :3]
                enu[idx] = np.asarray(s.enu_matrix) @ m
        self._cache["sites"] = (r, v, enu)
        return r, v, enu

    def elevations(self, r_sat):
        """Geometric elevation (rad) of the satellite at ``r_sat`` (N, 3; GCRS, km) above each
        row's ground station (NaN for rows without one, or a station without a horizon)."""
        out = np.full(len(self), np.nan)
        site_r, _, _ = self.sites()
        if "up" not in self._cache:
            up = np.full((len(self), 3), np.nan)
            groups = {}
            for i, s in enumerate(self.stations):
                if s is not None and hasattr(s, "enu_matrix"):
                    groups.setdefault(id(s), (s, []))[1].append(i)
            if groups:
                from ..satellites.frames import transform_matrices

            for s, idx in groups.values():
                m = transform_matrices(self.times[idx], "gcrs", "itrs")[:, :3, :3]
                up[idx] = np.asarray(s.enu_matrix)[2] @ m  # the ITRS up in GCRS axes
            self._cache["up"] = up
        up = self._cache["up"]
        d = np.asarray(r_sat, dtype=np.float64) - site_r
        ok = np.isfinite(up[:, 0])
        out[ok] = np.arcsin(np.clip(np.sum(d[ok] * up[ok], axis=1)
                                    / np.linalg.norm(d[ok], axis=1), -1.0, 1.0))
        return out

    def warn_below_horizon(self, r_sat, used, what):
        """Warn (TrackingDataWarning) when rows ``used`` come from ground stations that cannot
        see the satellite at ``r_sat``: more than 1 deg below their horizon (refraction lifts
        at most 0.6 deg) and the horizon's dip from their height. ``what`` names the estimate
        ("the fitted orbit")."""
        el = self.elevations(r_sat)
        # a station above the ellipsoid sees below its horizontal plane by the horizon's dip,
        # acos(R / (R + h)): 2 deg from 4 km, 10 deg from 100 km
        h_km = np.array([_height_km(s) for s in self.stations])
        dip = np.arccos(6371.0 / (6371.0 + np.maximum(h_km, 0.0)))
        low = np.flatnonzero(used & (el < -np.radians(BELOW_HORIZON_DEG) - dip))
        if low.size == 0:
            return
        import warnings

        from ..errors import TrackingDataWarning

        i = int(low[np.argmin(el[low])])
        name = getattr(self.stations[i], "name", None) or "its station"
        warnings.warn(
            f"{low.size} row(s) used come from ground stations that cannot see {what}: it is "
            f"below their horizon (lowest {np.degrees(el[i]):.1f} deg, row {i} ({self.kinds[i]}, "
            f"{name}, {self.times[i].utc.isot} UTC)). A station does not track through the Earth: "
            "check the stations' coordinates (east longitude, geodetic latitude), the station "
            "of each row and the time tags; drop rows that are not real.",
            TrackingDataWarning, stacklevel=3)

    def earth_velocity(self):
        """The Earth's barycentric velocity at each time, km/s in ICRS (= GCRS) axes (N, 3).

        Used by RA/Dec rows referred to catalogue stars; from astropy's built-in ephemeris
        (no download), cached.
        """
        if "earth_velocity" not in self._cache:
            from astropy.coordinates import get_body_barycentric_posvel

            _, vel = get_body_barycentric_posvel("earth", self.times)
            self._cache["earth_velocity"] = np.asarray(
                vel.xyz.to_value("km/s"), dtype=np.float64).T.reshape(len(self), 3)  # fmt: skip
        return self._cache["earth_velocity"]

    def gps_seconds(self):
        """Each row's time as seconds of the GPS time scale since 1980-01-06 (N,), float64:
        the clock of the Klobuchar ionosphere (:mod:`visviva.od.ionosphere`); cached, with
        astropy's bundled IERS data (no download)."""
        if "gps_seconds" not in self._cache:
            from ..satellites.frames import offline_iers

            with offline_iers():
                self._cache["gps_seconds"] = np.asarray(self.times.gps,
                                                        dtype=np.float64).reshape(-1)
        return self._cache["gps_seconds"]
