"""What a pass search is given: the satellites as a catalogue, the window, the minimum
elevation, and what it says when given states or an ephemeris instead of element sets.

Passes are searched on SGP4 element sets (:mod:`visviva.ground.search`); the refusals of
:func:`as_catalog` and ``GroundStation.find_events`` share the advice of
:func:`ephemeris_hint`. (Split from :mod:`visviva.ground.search` by audit50; that module
re-exports these names.)
"""

from __future__ import annotations

import math

from astropy import units as u
from astropy.time import Time

from .._units import is_quantity, require_usable_time, time_input_name, to_array
from ..errors import DomainError, InvalidInputError, fmt_first
from ..satellites.tle_checks import warn_stale_window

__all__ = ["as_catalog", "check_window", "ephemeris_hint", "min_elevation_rad",
           "warn_stale_element_sets"]


def ephemeris_hint(obj) -> str:
    """What to do where states or an ephemeris (``.r`` and ``.v``, or ``.segments``) are given
    to a pass search, which runs on SGP4 element sets; "" for anything else (audit46)."""
    if not (hasattr(obj, "segments") or (hasattr(obj, "r") and hasattr(obj, "v"))):
        return ""
    return (" Passes are searched on SGP4 element sets: fit one to the states with "
            "vv.fit_tle(states) (an OEM: vv.fit_tle(vv.read_oem(path)), or visviva fit-tle "
            "FILE), or sample station.look(states) for their look angles.")


def as_catalog(satellites):
    """The satellites as a non-empty Catalog (a Satellite, a Catalog or a list of Satellite)."""
    from ..satellites.catalog import Catalog
    from ..satellites.tle import Satellite

    if isinstance(satellites, Satellite):
        return Catalog([satellites])
    if isinstance(satellites, Catalog):
        cat = satellites
    else:
        try:
            items = list(satellites)
        except TypeError:
            raise InvalidInputError(
                f"satellites must be a Satellite, a Catalog or a list of Satellite, got "
                f"{type(satellites).__name__}.{ephemeris_hint(satellites)}"
            ) from None
        for k, s in enumerate(items):
            if not isinstance(s, Satellite):
                raise InvalidInputError(f"satellites[{k}] is a {type(s).__name__}, not a "
                                        f"Satellite.{ephemeris_hint(s)}")
        _warn_repeated(items)
        cat = Catalog(items)
    if len(cat) == 0:
        raise InvalidInputError("the catalogue is empty; pass at least one Satellite.")
    return cat


def _warn_repeated(items) -> None:
    """Warn (``UserWarning``) when a list of satellites holds one element set more than once
    (the same object, or the same catalogue number and epoch): each of its passes would be
    listed once per copy. (Files get :func:`visviva.satellites.catalog_files.warn_duplicates`,
    which also counts older sets of one object.)"""
    seen: dict = {}
    repeated = []
    for k, s in enumerate(items):
        key = (s.satnum, s.satrec.jdsatepoch, s.satrec.jdsatepochF)
        if key in seen:
            repeated.append(f"satellites[{k}] repeats satellites[{seen[key]}] ({s.name!r}, "
                            f"catalogue number {s.satnum})")
        else:
            seen[key] = k
    if repeated:
        import warnings

        from .._callsite import outside_stacklevel

        warnings.warn(
            f"{fmt_first(repeated, 3, '; ')}: the same element set is given more than once, so "
            "each of its passes is listed once per copy. Pass each satellite once.",
            UserWarning, stacklevel=outside_stacklevel())


def check_window(t0, t1):
    """Validate the window: scalar astropy Times with ``t1 > t0``; returns them in TAI.

    The conversion uses the IERS table installed with astropy (a window given in UT1 needs
    it), never a download.
    """
    for name, t in (("t0", t0), ("t1", t1)):
        if not isinstance(t, Time):
            raise InvalidInputError(
                f"{name} must be an astropy Time, got {time_input_name(t)}; for example "
                "Time('2024-05-01T18:00:00', scale='utc')."
            )
        if not t.isscalar:
            raise InvalidInputError(f"{name} must be a scalar Time, got shape {t.shape}.")
        require_usable_time(t, name)
    from ..satellites.frames import offline_iers

    with offline_iers():
        t0, t1 = t0.tai, t1.tai
    span = (t1 - t0).to_value(u.s)
    if not span > 0:
        raise InvalidInputError(
            f"t1 must be later than t0 (got t1 - t0 = {span:.6g} s); swap them or widen the "
            "window."
        )
    return t0, t1


def warn_stale_element_sets(cat, t0, t1) -> None:
    """Warn (:class:`~visviva.errors.StaleElementSetWarning`) when element sets of ``cat`` lie
    more than :data:`STALE_DAYS` before ``t0`` or after ``t1``: SGP4's along-track error grows
    by kilometres a day in low orbit, so rise and set times drift by minutes and passes appear
    or vanish (audit24: the ISS's 2024 TLE gave 0 passes for a 2026 window, without a word).
    The warning points at the user's line
    (:func:`~visviva.satellites.tle_checks.warn_stale_window`)."""
    warn_stale_window(cat, t0, t1, "these passes can be minutes off, or missing")


def min_elevation_rad(value) -> float:
    """The minimum elevation as float radians; a Quantity in [-90, 90] deg."""
    from .. import errors

    if not is_quantity(value):
        raise errors.UnitsError(
            f"min_elevation must be an angle Quantity such as 10 * u.deg, got a plain "
            f"{type(value).__name__}."
        )
    el = to_array(value, "angle", "min_elevation")
    if el.ndim != 0:
        raise InvalidInputError(f"min_elevation must be a scalar, got shape {el.shape}.")
    if abs(float(el)) > math.pi / 2:
        raise DomainError(
            f"min_elevation = {math.degrees(float(el)):.6g} deg is outside [-90, 90] deg."
        )
    return float(el)
