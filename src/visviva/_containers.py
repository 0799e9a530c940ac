"""Helpers shared by the two-body containers (:mod:`visviva.states`, :mod:`visviva.elements`).

Shapes, the gravitational parameter, epochs and indexing: each check written once, raising the
typed exceptions of :mod:`visviva.errors` with a message that says what to do.
"""

from __future__ import annotations

import math
from functools import cached_property

import numpy as np

from . import _units
from .constants import C_KM_S as _C_KM_S
from .errors import InvalidElementsError, InvalidInputError, ShapeError, fmt_number

__all__ = ["TwoBodyContainer", "FOREIGN_FRAME_ATTRIBUTE", "PENDING_MANEUVERS_ATTRIBUTE", "MARKS",
           "carry_marks", "carry_frame_mark", "refuse_pending", "EARTH_FIXED_NAMES",
           "earth_fixed_name", "refuse_rotating", "broadcast_shape", "gm_positive", "validate_epoch", "flat", "normalise_key", "index_epoch",
           "canonical_arrays", "flat_elements", "warn_implausible_velocity", "warn_if_degrees",
           "check_element_scales"]


#: Earth-centred states read in a frame visviva cannot rotate (a CCSDS ``REF_FRAME = TOD``)
#: carry its name here, so that the GCRS-only functions refuse them
#: (:func:`visviva.satellites.satellite_states.require_gcrs`).
FOREIGN_FRAME_ATTRIBUTE = "_foreign_frame"
#: States read from an OPM with manoeuvres carry how many here (:attr:`visviva.ccsds.opm.OPM.state`),
#: so that what cannot apply them refuses them (:func:`refuse_pending`).
PENDING_MANEUVERS_ATTRIBUTE = "_pending_maneuvers"
#: The marks that say where states came from: kept by indexing and by every conversion between
#: states and elements (:func:`carry_marks`). Propagation refuses pending manoeuvres and keeps
#: the foreign frame (two-body motion stays in the frame it starts in: :func:`carry_frame_mark`).
MARKS = (FOREIGN_FRAME_ATTRIBUTE, PENDING_MANEUVERS_ATTRIBUTE)


def carry_marks(source, result):
    """``result`` (a container computed from ``source`` by indexing or conversion), with the
    :data:`MARKS` of ``source``.

    Parameters
    ----------
    source, result : TwoBodyContainer
        The container and what was computed from it.

    Returns
    -------
    TwoBodyContainer
        ``result``, marked in place.

    Notes
    -----
    A container built anew from a marked one's arrays (``vv.StateVectors(s.r, s.v, ...)``)
    carries no mark: nothing can tell where plain numbers came from.
    """
    for name in MARKS:
        value = getattr(source, name, None)
        if value is not None:
            setattr(result, name, value)
    return result


def carry_frame_mark(source, result):
    """``result`` (states propagated from ``source``), with the foreign frame of ``source``.

    Two-body motion from a state in a frame visviva cannot rotate (``REF_FRAME = TOD``) gives
    states in that frame, which the GCRS-only functions must refuse as they refuse ``source``.

    Parameters
    ----------
    source, result : TwoBodyContainer
        The initial states and the propagated ones.

    Returns
    -------
    TwoBodyContainer
        ``result``, marked in place.
    """
    value = getattr(source, FOREIGN_FRAME_ATTRIBUTE, None)
    if value is not None:
        setattr(result, FOREIGN_FRAME_ATTRIBUTE, value)
    return result


#: foreign frame names (a CCSDS ``REF_FRAME`` as written) of axes that turn with the Earth, besides
#: ``ITRF*`` (its realisations): SANA's GRC (Greenwich rotating) and TDR (true of date
#: rotating), GTOD, PEF, and the EFG / ECF / ECEF / ECR of other tools
EARTH_FIXED_NAMES = frozenset({"GRC", "TDR", "GTOD", "PEF", "EFG", "ECF", "ECEF", "ECR"})


def earth_fixed_name(name) -> bool:
    """Whether a frame name (``ITRF``, ``ITRF2014``, ``ITRS``, ``GTOD``, ``ECEF`` ...) is of axes
    that turn with the Earth, on which a velocity is not the inertial velocity.

    Parameters
    ----------
    name : str
        The name as written (any case).

    Returns
    -------
    bool
    """
    key = str(name).strip().upper()
    return key.startswith(("ITRF", "ITRS")) or key in EARTH_FIXED_NAMES


def refuse_rotating(state, what: str) -> None:
    """Refuse states marked with a foreign frame that turns with the Earth (an OEM's or OPM's
    ``REF_FRAME = GTOD``, ``PEF``, ``GRC`` ...) where ``what`` takes their axes as inertial.

    Parameters
    ----------
    state : TwoBodyContainer
        The states.
    what : str
        The function that needs inertial axes, for the message.

    Raises
    ------
    InvalidInputError
        When the states say so.
    """
    foreign = getattr(state, FOREIGN_FRAME_ATTRIBUTE, None)
    if foreign is not None and earth_fixed_name(foreign):
        raise InvalidInputError(
            f"{what}: these states are in REF_FRAME = {foreign}, whose axes turn with the Earth "
            "(the velocity is relative to them), so Kepler motion does not hold in it and "
            "osculating elements mean nothing; rotate them to an inertial frame (GCRF, EME2000, "
            "TEME) first.")


def refuse_pending(state, what: str, remedy: str = "Propagate it with opm.propagate(t, "
                   "perturbations), which applies them.") -> None:
    """Refuse a state read from an OPM with manoeuvres where ``what`` would ignore them.

    Parameters
    ----------
    state : TwoBodyContainer
        The state (an OPM's :attr:`~visviva.ccsds.opm.OPM.state`, or what was indexed or
        converted from it, says how many manoeuvres its message has).
    what : str
        The function that cannot apply manoeuvres, for the message.
    remedy : str
        What to do instead.

    Raises
    ------
    InvalidInputError
        When the state carries manoeuvres.
    """
    pending = getattr(state, PENDING_MANEUVERS_ATTRIBUTE, None)
    if pending:
        raise InvalidInputError(
            f"this state comes from an OPM with {pending} manoeuvre(s), which {what} would "
            f"ignore. {remedy}"
        )


class TwoBodyContainer:
    """What every two-body container has: shape, size, length, epoch and central body's GM.

    The base of :class:`~visviva.StateVectors`, :class:`~visviva.KeplerianElements` and
    :class:`~visviva.ModifiedEquinoctialElements`; each stores ``_shape`` (tuple), ``_epoch``
    (astropy Time or None) and ``_gm`` (float64 km3/s2, broadcasting to ``_shape``).
    """

    #: what one item is called in messages ("a single state has no len()")
    _ITEM = "item"

    @property
    def shape(self) -> tuple:
        """Leading shape: one item (state or orbit) per index."""
        return self._shape

    @property
    def ndim(self) -> int:
        """Number of leading dimensions, ``len(shape)``."""
        return len(self._shape)

    @property
    def size(self) -> int:
        """Number of items, the product of :attr:`shape` (1 for a single item)."""
        return int(np.prod(self._shape, dtype=np.int64))

    @property
    def epoch(self):
        """Epoch (astropy Time, as given, or None)."""
        return self._epoch

    @property
    def gm_km3_s2(self):
        """Gravitational parameter in km3/s2 as stored (float64, broadcasting to :attr:`shape`)."""
        return self._gm

    @cached_property
    def gm(self):
        """Gravitational parameter of the central body (Quantity, km3/s2), shape :attr:`shape`."""
        return _units.to_quantity(np.broadcast_to(self._gm, self._shape), "gm")

    def __len__(self) -> int:
        if not self._shape:
            raise TypeError(f"a single {self._ITEM} (shape ()) has no len(); see .shape")
        return self._shape[0]


def broadcast_shape(named_shapes: dict[str, tuple], what: str) -> tuple:
    """Common leading shape of the arguments, or a ShapeError naming them."""
    try:
        return np.broadcast_shapes(*named_shapes.values())
    except ValueError:
        listing = ", ".join(f"{k} {v}" for k, v in named_shapes.items())
        raise ShapeError(
            f"{what}: the leading shapes do not broadcast ({listing}). Give every argument the "
            "same leading shape, e.g. (N,) per orbit and (N, 3) per vector, or use scalars "
            "for values shared by all items."
        ) from None


def gm_positive(gm: np.ndarray) -> None:
    if not np.all(gm > 0):
        bad = np.asarray(gm)[~(np.asarray(gm) > 0)].ravel()[0]
        raise InvalidInputError(
            f"gm must be > 0 (the gravitational parameter of the central body); got {fmt_number(bad)} "
            "km3/s2. Pass e.g. gm=vv.EARTH.gm or gm=398600.4418 * u.km**3 / u.s**2."
        )


#: a speed above both of these (km/s; times the escape speed) is taken for m/s read as km/s
IMPLAUSIBLE_SPEED_KM_S = 100.0
IMPLAUSIBLE_ESCAPE_FACTOR = 10.0
_SPEED_COMPONENT_KM_S = IMPLAUSIBLE_SPEED_KM_S / math.sqrt(3.0)


def warn_implausible_velocity(r_km, v_kms, gm_km3_s2, what: str = "the state",
                              stacklevel: int = 3) -> bool:
    """Warn once when a speed is far above the escape speed at its radius (m/s read as km/s?).

    Parameters
    ----------
    r_km : ndarray, shape (..., 3)
        Positions (km).
    v_kms : ndarray, shape (..., 3)
        Velocities (km/s), broadcasting against ``r_km``.
    gm_km3_s2 : float or ndarray
        Gravitational parameter (km3/s2), broadcasting against the leading shape.
    what : str
        What the states are, for the message.
    stacklevel : int
        Passed to :func:`warnings.warn` (3: the caller of the function that calls this one).

    Returns
    -------
    bool
        Whether a warning was given.

    Notes
    -----
    A state is flagged when ``v > 100 km/s`` and ``v > 10 sqrt(2 gm / r)``: no bound orbit, and
    no natural flyby of the Earth (< 73 km/s), comes near; a velocity in m/s taken as km/s is
    1000 times its true value. A first numpy pass looks for a velocity component above
    100/sqrt(3) km/s (without one, v < 100 km/s), so that ordinary states cost one
    comparison. NaN and inf are left to the caller's own checks. The state is kept
    (:class:`~visviva.errors.ImplausibleVelocityWarning`).
    """
    v = np.asarray(v_kms, dtype=np.float64)
    # fast path, no overflow possible: v > 100 km/s needs a component above 100/sqrt(3) km/s
    if not (np.abs(v) > _SPEED_COMPONENT_KM_S).any():
        return False
    with np.errstate(over="ignore", invalid="ignore"):
        v2 = np.einsum("...i,...i->...", v, v)
        r = np.asarray(r_km, dtype=np.float64)
        rn = np.sqrt(np.einsum("...i,...i->...", r, r))
        bad = (v2 > IMPLAUSIBLE_SPEED_KM_S**2) & (
            v2 * rn > 2.0 * IMPLAUSIBLE_ESCAPE_FACTOR**2 * np.asarray(gm_km3_s2))
    if not np.any(bad):
        return False
    import warnings

    from .errors import ImplausibleVelocityWarning

    gm = np.broadcast_to(np.asarray(gm_km3_s2, dtype=np.float64), bad.shape).ravel()
    first = int(np.flatnonzero(bad.ravel())[0])
    where = tuple(int(i) for i in np.unravel_index(first, bad.shape)) if bad.ndim else ()
    # math.hypot does not overflow where v2 did
    speed = math.hypot(*np.broadcast_to(v, bad.shape + (3,)).reshape(-1, 3)[first])
    radius = math.hypot(*np.broadcast_to(r, bad.shape + (3,)).reshape(-1, 3)[first])
    g = gm[first]
    v_esc = math.sqrt(2.0 * g / radius)
    count = int(np.count_nonzero(bad))
    more = f" ({count} states in all)" if count > 1 else ""
    warnings.warn(
        f"{what}{' at index ' + str(where) if where else ''}: velocity {speed:.6g} km/s is far "
        f"above escape speed ({v_esc:.4g} km/s) at this radius ({radius:.6g} km){more}; were "
        "m/s given as km/s? Velocities are read in km/s when plain, and "
        "[7500, ...] * u.km / u.s means 7500 km/s; write [7.5, ...] * u.km / u.s or "
        "[7500, ...] * u.m / u.s. (Kept as given: a fast hyperbolic state is legitimate.)",
        ImplausibleVelocityWarning, stacklevel=stacklevel,
    )
    return True


def validate_epoch(epoch, shape=None, what="the container"):
    """``epoch`` checked to be a Time (or None) whose shape broadcasts to ``shape``.

    A scalar epoch, or one of exactly ``shape``, is returned as it is; one that broadcasts (e.g.
    ``(N,)`` times for ``(T, N)`` states) is broadcast to ``shape``, so that indexing the
    container indexes its epoch.
    """
    if epoch is None:
        return None
    from astropy.time import Time

    if not isinstance(epoch, Time):
        raise InvalidInputError(
            f"epoch must be an astropy.time.Time or None; got {_units.time_input_name(epoch)} "
            f"{epoch!r}. Pass e.g. epoch=Time('2024-01-01T12:00:00', scale='utc')."
        )
    _units.require_usable_time(epoch, "epoch")
    if shape is None or epoch.shape in ((), shape):
        return epoch
    try:
        if np.broadcast_shapes(epoch.shape, shape) == shape:
            return np.broadcast_to(epoch, shape, subok=True)
    except ValueError:
        pass
    raise ShapeError(
        f"epoch of shape {epoch.shape} does not match {what} of shape {shape}: give one Time "
        "for all, or one Time per item (an array of the same shape)."
    )


def flat(arr: np.ndarray, shape: tuple) -> np.ndarray:
    """``arr`` broadcast to ``shape`` and flattened to 1-D (a view where numpy allows)."""
    return np.broadcast_to(arr, shape).reshape(-1)


def normalise_key(key, shape: tuple, cls_name: str) -> tuple:
    if shape == ():
        raise TypeError(f"a scalar {cls_name} cannot be indexed (its shape is ())")
    if not isinstance(key, tuple):
        key = (key,)
    n_index = sum(1 for k in key if k is not None and k is not Ellipsis)
    if n_index > len(shape):
        raise IndexError(
            f"too many indices for {cls_name} of shape {shape}: index the leading axes only "
            "(the xyz axis of r and v is not indexable here; use .r[..., 0] for x)"
        )
    return key


def index_epoch(epoch, key, shape):
    if epoch is None:
        return None
    if np.shape(epoch) == shape and shape != ():
        return epoch[key]
    return epoch


# ----------------------------------------------------------------------------------------------
# element sets (visviva.elements, visviva.equinoctial)

_TWO_PI = 2.0 * math.pi
#: inclinations up to this far above pi are rounding (e.g. 180 deg converted to rad) -> pi
_INC_SLACK = 8.0 * np.finfo(float).eps


def _wrap_2pi(x: np.ndarray) -> np.ndarray:
    y = np.mod(x, _TWO_PI)
    y = np.where(y >= _TWO_PI, y - _TWO_PI, y)
    return y + 0.0


def _wrap_pi(x: np.ndarray) -> np.ndarray:
    """Wrap into (-pi, pi] (pi stays pi, -pi becomes pi; no negative zero).

    Angles already inside are returned unchanged: wrapping them through [0, 2 pi) would round
    small ones to multiples of ulp(2 pi) (-1e-15 -> -8.9e-16).
    """
    x = np.asarray(x, dtype=np.float64)
    inside = (x > -math.pi) & (x <= math.pi)
    return np.where(inside, x, math.pi - _wrap_2pi(math.pi - x)) + 0.0


def warn_if_degrees(value, arr: np.ndarray, name: str) -> None:
    """Warn once per call when a plain-number angle looks like degrees (|x| > 2 pi)."""
    if _units.is_quantity(value) or not np.any(np.abs(arr) > _TWO_PI):
        return
    import warnings

    big = float(arr[np.abs(arr) > _TWO_PI].ravel()[0])
    warnings.warn(
        f"{name} = {fmt_number(big)} is a plain number, so it is taken in radians "
        f"(= {fmt_number(math.degrees(big) % 360.0)} deg after wrapping). If you meant "
        f"degrees pass {name}={fmt_number(big)} * u.deg.",
        UserWarning, stacklevel=3,
    )


def _scalar_or_array(arr: np.ndarray):
    """A 0-d array becomes a numpy scalar, anything else stays an array."""
    return arr[()] if arr.ndim == 0 else arr


def _first_bad(mask: np.ndarray) -> str:
    mask = np.asarray(mask)
    if mask.ndim == 0:
        return ""
    return f" at index {tuple(int(i) for i in np.argwhere(mask)[0])}"


def _deg(x) -> str:
    return f"{math.degrees(float(x)):.6f} deg"


def _require_positive_p(p_km: np.ndarray, advice: str = "") -> None:
    """Raise InvalidElementsError unless every semi-latus rectum is > 0 (and not NaN).

    Parameters
    ----------
    p_km : ndarray
        Semi-latus rectum (km).
    advice : str
        Appended to the message (starting with a space), e.g. what to give instead.
    """
    bad = ~(p_km > 0)
    if np.any(bad):
        raise InvalidElementsError(
            f"p (semi-latus rectum) must be > 0{_first_bad(bad)}; got "
            f"{fmt_number(p_km[bad].ravel()[0])} km.{advice}"
        )


def _index_elements(elements, key, cls_name: str):
    """The stored arrays, gm and epoch of an element set indexed by ``key``.

    Parameters
    ----------
    elements : KeplerianElements or ModifiedEquinoctialElements
        The element set (its ``stored_arrays()`` arrays have its leading shape).
    key : index
        Any numpy index of the leading axes.
    cls_name : str
        Class name for the messages of :func:`visviva._containers.normalise_key`.

    Returns
    -------
    parts : list of ndarray
        The stored elements, indexed (canonical units).
    gm : ndarray
        gm (km3/s2), indexed.
    epoch : astropy.time.Time or None
        The epoch, indexed where it has the leading shape.
    """
    shape = elements.shape
    key = normalise_key(key, shape, cls_name)
    parts = [np.array(x[key]) for x in elements.stored_arrays()]
    gm = np.array(np.broadcast_to(elements.gm_km3_s2, shape)[key])
    return parts, gm, index_epoch(elements.epoch, key, shape)


def canonical_arrays(shape: tuple, *arrays) -> tuple:
    """Each of ``arrays`` as float64, broadcast to ``shape`` (read-only views where numpy allows).

    Parameters
    ----------
    shape : tuple
        The element set's leading shape.
    *arrays : array_like
        Stored elements in canonical units (km, rad, dimensionless).

    Returns
    -------
    tuple of ndarray
    """
    return tuple(np.broadcast_to(np.asarray(x, dtype=np.float64), shape) for x in arrays)


def flat_elements(elements) -> list:
    """The stored elements and gm of an element set, each broadcast and flattened (the kernel's
    arguments).

    Parameters
    ----------
    elements : KeplerianElements or ModifiedEquinoctialElements
        The element set (its ``stored_arrays()`` arrays and ``gm_km3_s2``).

    Returns
    -------
    list of ndarray
        The six elements then gm (km3/s2), each of shape ``(elements.size,)``.
    """
    shape = elements.shape
    return [flat(x, shape) for x in (*elements.stored_arrays(), elements.gm_km3_s2)]


_TINY = float(np.finfo(np.float64).tiny)


def check_element_scales(p_km, ecc, gm, shape, what: str = "KeplerianElements",
                         stacklevel: int = 3) -> None:
    """Refuse elements whose speeds leave float64; warn when the periapsis speed exceeds c.

    Parameters
    ----------
    p_km, ecc, gm : ndarray
        Semi-latus rectum (km), eccentricity and GM (km3/s2), already finite, p > 0, e >= 0,
        gm > 0, broadcasting to ``shape``.
    shape : tuple
        Broadcast shape of the elements.
    what : str
        Name used in the messages.
    stacklevel : int
        Passed to :func:`warnings.warn`.

    Raises
    ------
    InvalidElementsError
        ``gm``, ``gm/p`` (square of the circular speed at r = p, km2/s2) or ``gm p`` (h^2,
        km4/s2) is subnormal (below 2.2e-308: speeds underflow to 0) or overflows, or the
        periapsis speed ``sqrt(gm/p) (1 + e)`` overflows.

    Notes
    -----
    Every speed on the conic is ``sqrt(gm/p) |e sin nu|, sqrt(gm/p)(1 + e cos nu)`` and the
    largest is the periapsis speed, so the three checks bound every state these elements make.
    Legitimate extremes (p 1e-3 to 1e12 km, gm 1e-10 to 1e20 km3/s2) pass with hundreds of
    decades to spare. A periapsis speed above the speed of light (299,792.458 km/s) is kept
    with an :class:`~visviva.errors.ImplausibleVelocityWarning`: Newtonian two-body motion does
    not describe it, and the usual cause is a unit or eccentricity mistake.
    """
    with np.errstate(all="ignore"):
        g = np.broadcast_to(gm, shape)
        q = g / np.broadcast_to(p_km, shape)
        h2 = g * np.broadcast_to(p_km, shape)
        vp = np.sqrt(q) * (1.0 + np.broadcast_to(ecc, shape))
    bad = ~((g >= _TINY) & (q >= _TINY) & (h2 >= _TINY) & np.isfinite(q) & np.isfinite(h2)
            & np.isfinite(vp))
    if np.any(bad):
        i = int(np.flatnonzero(bad.ravel())[0])
        p0 = float(np.broadcast_to(p_km, shape).ravel()[i])
        e0 = float(np.broadcast_to(ecc, shape).ravel()[i])
        g0 = float(g.ravel()[i])
        raise InvalidElementsError(
            f"{what}{_first_bad(bad)}: p = {p0:.6g} km, ecc = {e0:.6g}, gm = {g0:.6g} km3/s2 "
            "give speeds outside float64's range (gm, gm/p and gm p must lie between 2.2e-308 "
            "and 1.8e308, and the periapsis speed sqrt(gm/p) (1 + e) must be finite): the "
            "velocities would underflow to exactly 0 or overflow. Check the units of p and gm "
            "(km and km3/s2) and the eccentricity."
        )
    fast = vp > _C_KM_S
    if np.any(fast):
        import warnings

        from .errors import ImplausibleVelocityWarning

        i = int(np.flatnonzero(fast.ravel())[0])
        warnings.warn(
            f"{what}{_first_bad(fast)}: the periapsis speed sqrt(gm/p) (1 + e) = "
            f"{float(vp.ravel()[i]):.6g} km/s exceeds the speed of light (299,792.458 km/s) "
            f"(p = {float(np.broadcast_to(p_km, shape).ravel()[i]):.6g} km, ecc = "
            f"{float(np.broadcast_to(ecc, shape).ravel()[i]):.6g}, gm = {float(g.ravel()[i]):.6g} "
            "km3/s2): Newtonian two-body motion does not describe this orbit. Check the units of "
            "p and gm and the eccentricity. (Kept as given.)",
            ImplausibleVelocityWarning, stacklevel=stacklevel,
        )
