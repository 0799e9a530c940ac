"""The only module that converts units.

Public functions take astropy ``Quantity`` objects; kernels take float64 arrays in the canonical
units below. Conversion happens here, once per array, never inside a loop.

Kinds and their canonical units:

- ``length``: km
- ``speed``: km / s
- ``time``: s
- ``angle``: rad (plain numbers are taken as radians)
- ``gm``: km3 / s2 (a :class:`visviva.bodies.Body` gives its ``gm``)
- ``accel``: km / s2
- ``mass``: kg
- ``force``: N (thrust)
- ``mass_flow``: kg / s
- ``area_per_mass``: m2 / kg (ballistic and radiation-pressure coefficients)
- ``spec_angmom``: km2 / s (specific angular momentum)
- ``spec_energy``: km2 / s2 (specific energy, potential per unit mass)
- ``accel_psd``: km2 / s3 (spectral density of a white-noise acceleration, process noise)
- ``dimensionless``: plain numbers or dimensionless Quantities

astropy.units is imported on first need, not with this module: it costs about 0.1 s, and a call
with plain numbers (``vv.solve_kepler(1.0, 0.5)``) never needs it. A value can only be a
Quantity if astropy is already imported, so :func:`is_quantity` asks ``sys.modules`` first.
"""

from __future__ import annotations

import functools
import sys

import numpy as np

from . import errors as _errors
from .errors import DomainError, InvalidInputError, ShapeError

__all__ = [
    "CANONICAL",  # noqa: F822 (module __getattr__)
    "is_quantity",
    "to_array",
    "to_vector",
    "to_quantity",
    "to_si",
    "require_finite",
    "require_positive",
    "require_flag",
    "advance_epoch",
    "seconds_since",
    "time_input_name",
]



def _astropy_units():
    """The ``astropy.units`` module, imported on first use."""
    from astropy import units

    return units


@functools.cache
def _canonical() -> dict:
    """The canonical unit of each kind (see the module docstring)."""
    u = _astropy_units()
    return {
        "length": u.km,
        "speed": u.km / u.s,
        "time": u.s,
        "angle": u.rad,
        "gm": u.km**3 / u.s**2,
        "accel": u.km / u.s**2,
        "mass": u.kg,
        "force": u.N,
        "mass_flow": u.kg / u.s,
        "area_per_mass": u.m**2 / u.kg,
        "spec_angmom": u.km**2 / u.s,
        "spec_energy": u.km**2 / u.s**2,
        "accel_psd": u.km**2 / u.s**3,
        "dimensionless": u.dimensionless_unscaled,
    }


def __getattr__(name):
    # PEP 562: CANONICAL (kind -> astropy unit) is built on first access
    if name == "CANONICAL":
        return _canonical()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def is_quantity(value) -> bool:
    """Whether ``value`` is an astropy ``Quantity``, without importing astropy.

    If astropy.units has not been imported, no Quantity can exist, so the answer is no.
    """
    units = sys.modules.get("astropy.units")
    return units is not None and isinstance(value, units.Quantity)

_EXAMPLE = {
    "length": "7000 * u.km",
    "speed": "7.5 * u.km / u.s",
    "time": "90 * u.min",
    "angle": "30 * u.deg (or a plain float in radians)",
    "gm": "vv.EARTH.gm or 398600.4418 * u.km**3 / u.s**2",
    "accel": "1e-6 * u.km / u.s**2",
    "mass": "1000 * u.kg",
    "force": "400 * u.N",
    "mass_flow": "0.1 * u.kg / u.s",
    "area_per_mass": "0.01 * u.m**2 / u.kg",
    "spec_angmom": "52000 * u.km**2 / u.s",
    "spec_energy": "-30 * u.km**2 / u.s**2",
    "accel_psd": "1e-12 * u.km**2 / u.s**3 (an acceleration noise density, (km/s^2)^2 s)",
    "dimensionless": "0.1",
}


def to_array(value, kind: str, name: str, *, allow_plain: bool = False, finite: bool = True):
    """Convert ``value`` to a float64 ndarray in the canonical unit of ``kind``.

    Parameters
    ----------
    value : Quantity, Body, float or array_like
        The input. Plain numbers are accepted for ``angle`` (radians) and ``dimensionless``, and
        for any kind when ``allow_plain`` is true (then taken to be in the canonical unit already).
    kind : str
        One of the keys of :data:`CANONICAL`.
    name : str
        The argument's name, quoted in error messages.
    allow_plain : bool
        Accept plain numbers as canonical-unit values.
    finite : bool
        Reject NaN and infinity (default).

    Returns
    -------
    ndarray of float64
        A new array (never a view of the caller's data).

    Raises
    ------
    UnitsError
        Missing unit where one is required, or a unit of the wrong physical type.
    InvalidInputError
        NaN or infinite entries when ``finite`` is true.
    """
    value = _unmasked(value, name)
    quantity = is_quantity(value)
    if not quantity and isinstance(value, (list, tuple)) and _holds_quantity(value):
        value = _list_to_quantity(value, kind, name)
        quantity = True
    if kind == "gm" and hasattr(value, "gm") and not quantity:
        value = value.gm
        quantity = is_quantity(value)
    if kind == "time" and type(value).__name__ == "TimeDelta":  # astropy.time.TimeDelta
        value = value.to(_astropy_units().s)
        quantity = True
    if np.iscomplexobj(getattr(value, "value", value)):
        raise InvalidInputError(
            f"{name} is complex; visviva works with real numbers. Pass the real part explicitly "
            f"(np.real) if that is what you mean."
        )
    if quantity:
        unit = _canonical()[kind]
        try:
            arr = value.to_value(unit)
        except _astropy_units().UnitConversionError as exc:
            raise _errors.UnitsError(
                f"{name} has unit '{value.unit}', which cannot be converted to {kind} "
                f"('{unit}'). Pass e.g. {name}={_EXAMPLE[kind]}."
            ) from exc
        arr = np.array(arr, dtype=np.float64, copy=True)
    else:
        if not (allow_plain or kind in ("angle", "dimensionless")):
            raise _errors.UnitsError(
                f"{name} must be an astropy Quantity with a unit of {kind} ('{_canonical()[kind]}'), "
                f"got a plain {type(value).__name__}. Pass e.g. {name}={_EXAMPLE[kind]} "
                "(with `from astropy import units as u`)."
            )
        try:
            arr = np.array(value, dtype=np.float64, copy=True)
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(f"{name} must be numeric, got {value!r}.") from exc
    if finite:
        require_finite(arr, name)
    return arr


def _unmasked(value, name: str):
    """``value`` without its mask; InvalidInputError when any entry is masked.

    A masked entry (a MaskedQuantity from a QTable column with missing values, e.g. a pass
    table's ``duration``; a ``numpy.ma`` array) keeps a value under its mask, and every
    function computed with it silently: a state at the hidden time, a speed at the hidden
    radius. As for masked Times (:func:`require_usable_time`), they are refused.
    """
    mask = getattr(value, "mask", None)
    if mask is None or mask is np.ma.nomask or type(value).__name__ in ("Time", "TimeDelta"):
        return value
    mask = np.asarray(mask, dtype=bool)
    if mask.any():
        first = tuple(int(i) for i in np.argwhere(mask)[0]) if mask.ndim else ()
        raise InvalidInputError(
            f"{name} has {int(mask.sum())} masked (missing) value(s), the first at index "
            f"{first}; a masked entry has no value to compute with (the one hidden under the "
            f"mask would be used). Drop or fill them first, e.g. {name}[~{name}.mask] or "
            f"{name}.filled(...)."
        )
    return value.unmasked if hasattr(value, "unmasked") else np.ma.getdata(value)


def _holds_quantity(seq) -> bool:
    """Whether a (nested) list or tuple holds a Quantity anywhere."""
    return any(
        is_quantity(v) or (isinstance(v, (list, tuple)) and _holds_quantity(v)) for v in seq
    )


def _list_to_quantity(seq, kind: str, name: str):
    """One Quantity from a list of Quantities (``[7000 * u.km, 0 * u.km, 0 * u.km]``)."""
    units = _astropy_units()
    try:
        return units.Quantity(seq)
    except (units.UnitsError, TypeError, ValueError) as exc:
        why = "it mixes Quantities and plain numbers" if isinstance(exc, TypeError) else str(exc)
        raise _errors.UnitsError(
            f"{name} is a list whose entries do not share one unit of {kind} ({why}). Give every "
            f"entry a unit of {kind}, or pass one Quantity, e.g. {name}={_EXAMPLE[kind]}."
        ) from exc


def to_vector(value, kind: str, name: str, **kwargs):
    """Like :func:`to_array`, and check that the last axis holds x, y, z (length 3)."""
    arr = to_array(value, kind, name, **kwargs)
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise ShapeError(
            f"{name} must have x, y, z on its last axis, shape (..., 3); got shape {arr.shape}. "
            "For N vectors pass an (N, 3) array."
        )
    return arr


def to_quantity(arr, kind: str):
    """Wrap a canonical-unit float array as a Quantity (no copy when ``arr`` is an ndarray)."""
    return np.asarray(arr, dtype=np.float64) << _canonical()[kind]


def require_finite(arr, name: str) -> None:
    """Raise :class:`InvalidInputError` if ``arr`` holds NaN or infinity."""
    arr = np.asarray(arr)
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))
        where = tuple(int(i) for i in bad[0]) if arr.ndim else ()
        raise InvalidInputError(
            f"{name} contains NaN or infinite values (first at index {where}, "
            f"{len(bad) if arr.ndim else 1} in all). Remove or fill them before calling."
        )


def seconds_since(t, epoch):
    """TT seconds from ``epoch`` to ``t`` (astropy Times of any scales), float64 ndarray.

    SI seconds whatever the scales (a TDB difference drifts ~1.7 ms a year from TT's): the
    elapsed time of every propagation, the inverse of :func:`advance_epoch`.
    """
    from ._offline_iers import offline_iers

    with offline_iers():  # UT1 needs the installed IERS table, never a download
        return np.asarray((t.tt - epoch.tt).to_value(_astropy_units().s), dtype=np.float64)


def advance_epoch(epoch, dt_s):
    """``epoch`` moved by ``dt_s`` SI seconds of TT, returned in ``epoch``'s own scale and format.

    Elapsed times in visviva are TT (= TAI) differences whatever the scales: Cowell's output
    offsets are ``(t.tt - epoch.tt)`` and the batches' TAI Julian-date differences. astropy's
    ``epoch + dt`` adds ``dt`` in the epoch's scale (TDB, TCB, TCG or UT1 seconds; TAI for a
    UTC epoch), so a state propagated by ``dt`` from a TDB epoch was labelled with a time
    whose TT offset is not ``dt`` (up to 2.7 ms after 180 days: 74 m along a heliocentric
    orbit against ``propagate_cowell`` or the Kepler batch at that label). This is the one
    owner of the inverse of those offsets.

    Parameters
    ----------
    epoch : astropy.time.Time
        The epoch (any scale but ``local``, any shape).
    dt_s : float or ndarray
        Seconds of TT to add, broadcasting against ``epoch``.

    Returns
    -------
    astropy.time.Time
        In ``epoch.scale``; for utc, tai and tt epochs (or ``dt_s`` all zero) exactly
        ``epoch + dt_s * u.s``.
    """
    dt = to_quantity(dt_s, "time")
    if epoch.scale in ("utc", "tai", "tt") or not np.any(dt.value):
        # (no offset keeps the epoch's bits: through TT and back, UT1 moved by one ulp)
        return epoch + dt  # astropy adds these in TAI seconds already
    from ._offline_iers import offline_iers

    with offline_iers():  # a UT1 epoch needs the installed IERS table, never a download
        return getattr(epoch.tt + dt, epoch.scale)


def time_input_name(t) -> str:
    """How a refusal names a value given where an astropy ``Time`` is expected: its type, and
    for the times of other libraries the conversion (audit51: a Skyfield ``Time`` was refused
    as "must be an astropy Time, got Time").

    Parameters
    ----------
    t : object
        The value given.

    Returns
    -------
    str
        E.g. ``"skyfield.timelib.Time (a Skyfield time: pass t.to_astropy())"``.
    """
    kind = type(t)
    module = kind.__module__ or ""
    if module.startswith("skyfield"):
        return f"{module}.{kind.__qualname__} (a Skyfield time: pass t.to_astropy())"
    if module == "datetime" and kind.__name__ == "datetime":
        zone = ("aware: it is converted to UTC" if t.tzinfo is not None and
                t.utcoffset() is not None else "naive: it is taken as UTC")
        return f"datetime.datetime (pass astropy's Time(dt); {zone})"
    if module.startswith(("numpy", "pandas")) and "datetime64" in str(getattr(t, "dtype", kind)):
        return f"{module}.{kind.__qualname__} of datetime64 (pass astropy's Time(values))"
    if isinstance(t, str):
        return f"str {t!r} (pass astropy's Time({t!r}, scale='utc'))"
    return kind.__name__


def require_usable_time(t, name: str) -> None:
    """Raise :class:`InvalidInputError` for an astropy Time no date can be computed from.

    A masked Time (``Time(np.ma.masked_array(...))``, a masked table column) keeps a value
    under each mask, and every conversion (``t.utc.jd1``, ``t.tt - epoch``) silently used it:
    a state at the hidden date instead of none. A Time in the ``local`` scale (a free-running
    clock) has no relation to UTC or TT.

    Parameters
    ----------
    t : astropy.time.Time
        The times (any shape).
    name : str
        The argument's name, for the message.
    """
    if getattr(t, "scale", None) == "local":
        raise InvalidInputError(
            f"{name} is in the 'local' time scale, which has no relation to UTC, TT or TDB; "
            "give times in utc, tai, tt, tdb, tcg, tcb or ut1 (e.g. Time(..., scale='utc')).")
    if getattr(t, "masked", False):
        mask = np.asarray(t.mask)
        if mask.any():
            first = tuple(int(i) for i in np.argwhere(mask)[0]) if mask.ndim else ()
            raise InvalidInputError(
                f"{name} has {int(mask.sum())} masked (missing) time(s), the first at index "
                f"{first}; a masked time has no date to compute at. Drop them first, e.g. "
                f"t[~t.mask].")


def broadcast_or_raise(context: str, **arrays) -> tuple:
    """Return the common broadcast shape of ``arrays``; :class:`ShapeError` if there is none.

    Parameters
    ----------
    context : str
        Name of the calling function, put at the start of the error message.
    **arrays : array_like
        The arguments by name (for vectors pass their leading shape, e.g. ``r[..., 0]``).

    Returns
    -------
    tuple of int
        ``np.broadcast_shapes`` of the arrays' shapes.
    """
    try:
        return np.broadcast_shapes(*(np.shape(a) for a in arrays.values()))
    except ValueError:
        shapes = ", ".join(f"{k} {np.shape(a)}" for k, a in arrays.items())
        raise ShapeError(
            f"{context}: the arguments do not broadcast together ({shapes}). Give arrays of one "
            "shape, or scalars."
        ) from None


def require_finite_result(arr, context: str, *, remedy: str = "Rescale them (e.g. other units)."):
    """Return ``arr``; :class:`DomainError` if a computed result overflowed to inf or NaN.

    For results (not inputs: see :func:`require_finite`) that left float64 because the finite
    inputs were too extreme in magnitude.

    Parameters
    ----------
    arr : array_like
        The computed result.
    context : str
        Name of the calling function, put at the start of the error message.
    remedy : str, optional
        The sentence telling the user what to do, appended to the message.
    """
    if not np.all(np.isfinite(arr)):
        raise DomainError(
            f"{context}: the result overflows float64 (|x| > 1.8e308): the inputs are too "
            f"extreme in magnitude. {remedy}"
        )
    return arr


def require_positive(arr, name: str, *, strict: bool = True) -> None:
    """Raise :class:`InvalidInputError` unless every entry is > 0 (``>= 0`` if not strict)."""
    arr = np.asarray(arr)
    bad = ~(arr > 0) if strict else ~(arr >= 0)
    if np.any(bad):
        relation = "> 0" if strict else ">= 0"
        raise InvalidInputError(
            f"{name} must be {relation}; got {_errors.fmt_number(arr[bad].ravel()[0])}"
            f"{' (and more)' if np.count_nonzero(bad) > 1 else ''}."
        )


def require_flag(value, name: str) -> bool:
    """``value`` as a Python bool; raise :class:`InvalidInputError` unless it is True or False.

    A string such as ``"False"`` is truthy and an array has no single truth value: a switch
    that changes what numbers mean (the retrograde factor, the way round) takes only booleans.
    """
    if not isinstance(value, bool | np.bool_):
        raise InvalidInputError(f"{name} must be True or False; got {value!r}.")
    return bool(value)


def to_si(value, unit, name: str, *, finite: bool = True, angles_dimensionless: bool = True):
    """Convert ``value`` to a float64 ndarray in the SI unit ``unit``; plain numbers pass through.

    For APIs that accept plain numbers "in any consistent units" (``visviva.mechanics``) as well as
    Quantities. A Quantity is converted to ``unit`` (e.g. ``u.kg``, ``u.m / u.s``); a plain number
    is assumed to be in consistent units already and copied unchanged. With
    ``angles_dimensionless`` (default) radians count as dimensionless, so rad/s converts to 1/s.
    ``unit=None`` converts a Quantity to its SI form, whatever its physical type.

    Returns
    -------
    (ndarray, bool)
        The float64 array and whether ``value`` was a Quantity.

    Raises
    ------
    UnitsError
        A Quantity whose unit cannot be converted to ``unit``.
    InvalidInputError
        Non-numeric input, or NaN/inf when ``finite`` is true.
    """
    if is_quantity(value):
        u = _astropy_units()
        try:
            equiv = u.dimensionless_angles() if angles_dimensionless else []
            arr = value.si.value if unit is None else value.to_value(unit, equivalencies=equiv)
        except u.UnitConversionError as exc:
            raise _errors.UnitsError(
                f"{name} has unit '{value.unit}', which cannot be converted to '{unit}'. "
                f"Pass a Quantity in '{unit}' (or an equivalent unit), or a plain number in "
                "consistent units."
            ) from exc
        arr = np.array(arr, dtype=np.float64, copy=True)
        was_quantity = True
    else:
        try:
            arr = np.array(value, dtype=np.float64, copy=True)
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(f"{name} must be numeric, got {value!r}.") from exc
        was_quantity = False
    if finite:
        require_finite(arr, name)
    return arr, was_quantity
