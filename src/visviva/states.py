"""Two-body state vectors: position and velocity relative to a central body.

:class:`StateVectors` holds canonical float64 arrays (km, km/s, km3/s2) and wraps them in astropy
Quantities only when asked. Every conversion calls one compiled kernel over the whole array
(:mod:`visviva.core.elements`); the first call compiles it (or loads numba's on-disk cache).
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from . import _units
from ._containers import (
    TwoBodyContainer,
    broadcast_shape,
    carry_frame_mark,
    carry_marks,
    flat,
    gm_positive,
    index_epoch,
    normalise_key,
    refuse_pending,
    refuse_rotating,
    validate_epoch,
    warn_implausible_velocity,
)
from .errors import (
    InvalidStateError,
    raise_for_result,
    require_finite_result,
)

__all__ = ["StateVectors"]



def _norm(x: np.ndarray) -> np.ndarray:
    """Euclidean norm over the last axis, scaled so that squares cannot overflow."""
    scale = np.max(np.abs(x), axis=-1)
    safe = np.where(scale > 0, scale, 1.0)
    return scale * np.sqrt(np.einsum("...i,...i->...", x / safe[..., None], x / safe[..., None]))


def _fmt_vec(arr: np.ndarray) -> str:
    return np.array2string(arr, precision=9, separator=", ", max_line_width=200)


# ----------------------------------------------------------------------------------------------


class StateVectors(TwoBodyContainer):
    """Position and velocity of one or many bodies relative to a central body.

    Parameters
    ----------
    r : Quantity, shape (..., 3)
        Position relative to the central body, unit of length (e.g. km).
    v : Quantity, shape (..., 3)
        Velocity, unit of speed (e.g. km/s). Broadcasts against ``r`` over the leading axes.
    gm : Quantity or Body
        Gravitational parameter of the central body (km3/s2), > 0, scalar or broadcasting
        against the leading shape; a :class:`visviva.bodies.Body` gives its ``gm``.
    epoch : astropy.time.Time, optional
        Epoch of the states; carried along, never used in the two-body conversions.

    Attributes
    ----------
    r, v : Quantity
        Position (km) and velocity (km/s), shape ``shape + (3,)``.
    gm : Quantity
        Gravitational parameter (km3/s2), broadcast to ``shape``.
    shape : tuple
        Leading shape (one item per state).

    Raises
    ------
    UnitsError
        A missing or wrong unit.
    ShapeError
        xyz not on the last axis, or leading shapes that do not broadcast.
    InvalidInputError
        NaN/inf values, or gm <= 0.
    InvalidStateError
        A zero position vector (the body sits on the attractor).

    Warns
    -----
    ImplausibleVelocityWarning
        A speed above 100 km/s and ten times the escape speed at its radius (velocities in m/s
        given as km/s?); the states are kept.

    Notes
    -----
    The arrays are stored in canonical units (km, km/s, km3/s2) as float64; the Quantities and
    the derived properties are computed on first access and cached. The two-body relations are
    those of Vallado (2013), Ch. 2: specific energy v^2/2 - mu/r, h = r x v, eccentricity vector
    e = ((v^2 - mu/r) r - (r . v) v)/mu.

    Examples
    --------
    >>> import visviva as vv
    >>> from astropy import units as u
    >>> s = vv.StateVectors([7000.0, 0, 0] * u.km, [0, 7.5, 0] * u.km / u.s, vv.EARTH)
    >>> print(f"{s.to_elements().eccentricity:.6f}")
    0.012169
    """

    _ITEM = "state"

    def __init__(self, r, v, gm, epoch=None):
        from .core import tier
        from .core.elements import scan_states
        from .core.status import NON_FINITE

        epoch = validate_epoch(epoch)
        # finiteness is checked below in the same pass as the zero-position test
        r_km = _units.to_vector(r, "length", "r", finite=False)
        v_kms = _units.to_vector(v, "speed", "v", finite=False)
        gm_arr = _units.to_array(gm, "gm", "gm")
        gm_positive(gm_arr)
        shape = broadcast_shape(
            {"r": r_km.shape[:-1], "v": v_kms.shape[:-1], "gm": gm_arr.shape}, "StateVectors"
        )
        epoch = validate_epoch(epoch, shape, "the states")
        r_km = np.ascontiguousarray(np.broadcast_to(r_km, shape + (3,)))
        v_kms = np.ascontiguousarray(np.broadcast_to(v_kms, shape + (3,)))
        first, code = tier.call(scan_states, r_km.reshape(-1, 3), v_kms.reshape(-1, 3),
                                small=r_km.size <= 3 * tier.SMALL_ITEMS)
        if first >= 0:
            if code == NON_FINITE:
                _units.require_finite(r_km, "r")
                _units.require_finite(v_kms, "v")
            where = tuple(int(i) for i in np.unravel_index(first, shape)) if shape else ()
            raise InvalidStateError(
                f"r has zero length at index {where}: "
                "the body would sit on the attractor, where the two-body problem is singular. "
                "Give a non-zero position relative to the central body."
            )
        warn_implausible_velocity(r_km, v_kms, gm_arr, "StateVectors")
        self._init_canonical(r_km, v_kms, gm_arr, epoch, shape)

    def _init_canonical(self, r_km, v_kms, gm_km3_s2, epoch, shape):
        self._r = r_km
        self._v = v_kms
        self._gm = np.asarray(gm_km3_s2, dtype=np.float64)
        self._epoch = epoch
        self._shape = tuple(shape)

    @classmethod
    def _from_canonical(cls, r_km, v_kms, gm_km3_s2, epoch=None):
        """Wrap canonical float64 arrays without validation (for visviva's own results).

        ``r_km``, ``v_kms`` have shape ``shape + (3,)``; ``gm_km3_s2`` broadcasts to ``shape``.
        """
        obj = cls.__new__(cls)
        shape = np.shape(r_km)[:-1]
        obj._init_canonical(
            np.asarray(r_km, dtype=np.float64),
            np.asarray(v_kms, dtype=np.float64),
            gm_km3_s2,
            epoch,
            shape,
        )
        return obj

    # --- stored values -------------------------------------------------------------------------
    @cached_property
    def r(self):
        """Position (Quantity, km), shape ``shape + (3,)``."""
        return _units.to_quantity(self._r, "length")

    @cached_property
    def v(self):
        """Velocity (Quantity, km/s), shape ``shape + (3,)``."""
        return _units.to_quantity(self._v, "speed")

    def __getitem__(self, key):
        key = normalise_key(key, self._shape, "StateVectors")
        r = self._r[key + (slice(None),)]
        v = self._v[key + (slice(None),)]
        gm = np.broadcast_to(self._gm, self._shape)[key]
        out = StateVectors._from_canonical(
            r, v, np.array(gm), index_epoch(self._epoch, key, self._shape)
        )
        return carry_marks(self, out)

    def __repr__(self) -> str:
        if self.size == 0:
            return f"<StateVectors shape={self._shape}: no states>"
        gm = np.unique(self._gm)
        gm_txt = f"{gm[0]:.10g} km3 / s2" if gm.size == 1 else f"{gm.size} values (km3 / s2)"
        epoch = "" if self._epoch is None else f", epoch={self._epoch}"
        if self.size <= 2:
            return (
                f"StateVectors(r={_fmt_vec(self._r)} km, v={_fmt_vec(self._v)} km / s, "
                f"gm={gm_txt}{epoch})"
            )
        return (
            f"<StateVectors shape={self._shape}: {self.size} states, gm={gm_txt}{epoch}; "
            f"first r={_fmt_vec(self._r.reshape(-1, 3)[0])} km, "
            f"v={_fmt_vec(self._v.reshape(-1, 3)[0])} km / s>"
        )

    # --- derived quantities (lazy, cached) ------------------------------------------------------
    @cached_property
    def radius(self):
        """Distance from the central body \\|r\\| (Quantity, km), shape ``shape``."""
        return _units.to_quantity(_norm(self._r), "length")

    @cached_property
    def speed(self):
        """Speed \\|v\\| (Quantity, km/s), shape ``shape``."""
        return _units.to_quantity(_norm(self._v), "speed")

    @cached_property
    def specific_energy(self):
        """Specific orbital energy v^2/2 - mu/r (Quantity, km2/s2); < 0 bound, 0 parabolic."""
        r = _norm(self._r)
        v2 = np.einsum("...i,...i->...", self._v, self._v)
        with np.errstate(over="ignore", invalid="ignore"):
            eps = 0.5 * v2 - self._gm / r
        self._check_finite("specific energy", eps)
        return _units.to_quantity(eps, "spec_energy")

    @cached_property
    def specific_angular_momentum(self):
        """Specific angular momentum vector h = r x v (Quantity, km2/s), shape ``shape + (3,)``."""
        with np.errstate(over="ignore", invalid="ignore"):
            h = np.cross(self._r, self._v)
        self._check_finite("specific angular momentum", h)
        return _units.to_quantity(h, "spec_angmom")

    @cached_property
    def eccentricity_vector(self):
        """Eccentricity vector (dimensionless ndarray, shape ``shape + (3,)``).

        It points to periapsis and its length is the eccentricity. Evaluated as
        e = (p/r - 1) r_hat - (h (r . v)/(mu r)) theta_hat with theta_hat = h_hat x r_hat, which
        equals ((v^2 - mu/r) r - (r . v) v)/mu (Vallado 2013, eq. 2-78) without that formula's
        cancellation far out on open orbits; radial states (h = 0) use eq. 2-78.
        """
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            e_vec = self._eccentricity_vector()
        self._check_finite("eccentricity vector", e_vec)
        return e_vec

    def _check_finite(self, what: str, *outputs) -> None:
        require_finite_result(f"StateVectors.{what}", outputs, self._shape, r=self._r, v=self._v)

    def _eccentricity_vector(self):
        r = self._r
        v = self._v
        gm = np.broadcast_to(self._gm, self._shape)[..., None]
        rm = np.linalg.norm(r, axis=-1)[..., None]
        h = np.cross(r, v)
        hm = np.linalg.norm(h, axis=-1)[..., None]
        rv = np.einsum("...i,...i->...", r, v)[..., None]
        radial = hm == 0.0
        safe_hm = np.where(radial, 1.0, hm)
        ec = (hm * hm / gm - rm) / rm
        es = hm * rv / (gm * rm)
        theta_hat = np.cross(h, r) / (safe_hm * rm)
        e_vec = ec * r / rm - es * theta_hat
        if np.any(radial):
            v2 = np.einsum("...i,...i->...", v, v)[..., None]
            classic = ((v2 - gm / rm) * r - rv * v) / gm
            e_vec = np.where(radial, classic, e_vec)
        return e_vec

    # --- conversions ----------------------------------------------------------------------------
    def _flat_inputs(self):
        return self._r.reshape(-1, 3), self._v.reshape(-1, 3), flat(self._gm, self._shape)

    def _checked_results(self, outputs, status, context, result_context=None):
        """The flat kernel ``outputs`` reshaped to ``shape``, after :func:`raise_for_result`."""
        outputs = [x.reshape(self._shape) for x in outputs]
        raise_for_result(
            context,
            status,
            outputs,
            self._shape,
            {"r": self._r, "v": self._v},
            result_context=result_context,
        )
        return outputs

    def to_elements(self):
        """Classical (Keplerian) elements of every state.

        Returns
        -------
        KeplerianElements
            Same shape, gm and epoch. Undefined angles follow docs/conventions.md (equatorial:
            raan = 0; circular: argp = 0 and nu = argument of latitude / true longitude).

        Raises
        ------
        InvalidStateError
            Radial motion (r x v = 0): the orbital plane is undefined.
        DomainError
            |r|^2, |v|^2 or |r x v|^2 / gm beyond float64 (|r| or |v| above ~1.3e154 in the
            given units): the message says to scale r, v and gm to other units.

        Notes
        -----
        One call of :func:`visviva.core.elements.rv_to_coe_array`; Vallado (2013) Algorithm 9
        rewritten with atan2 only (no arccos), see :mod:`visviva.core.elements`.
        """
        from .core import tier
        from .core.elements import empty_elements, rv_to_coe_array
        from .elements import KeplerianElements

        refuse_rotating(self, "state vectors -> elements")
        *elements, status = out = empty_elements(self.size)
        tier.call(rv_to_coe_array, *self._flat_inputs(), *out, small=self.size <= tier.SMALL_ITEMS)
        elements = self._checked_results(
            elements,
            status,
            "state vectors -> elements",
            "state vectors -> elements (scale r, v and gm to other units)",
        )
        return carry_marks(self, KeplerianElements._from_canonical(*elements, self._gm,
                                                                   self._epoch))

    def to_equinoctial(self, retrograde: bool = False):
        """Modified equinoctial elements (Walker, Ireland & Owens 1985) of every state.

        Parameters
        ----------
        retrograde : bool
            Use the retrograde factor I = -1 (singular only at i = 0) instead of I = +1
            (singular only at i = pi). Choose True for orbits at or near i = pi.

        Returns
        -------
        ModifiedEquinoctialElements

        Raises
        ------
        DomainError
            The orbit is exactly at the singularity of the chosen set, or the magnitudes
            overflow float64 (as in :meth:`to_elements`).
        InvalidStateError
            Radial motion.
        """
        from .core.elements import empty_elements, rv_to_mee_array
        from .equinoctial import ModifiedEquinoctialElements

        retrograde = _units.require_flag(retrograde, "retrograde")
        refuse_rotating(self, "state vectors -> equinoctial elements")
        retro = -1.0 if retrograde else 1.0
        *elements, status = out = empty_elements(self.size)
        rv_to_mee_array(*self._flat_inputs(), retro, *out)
        elements = self._checked_results(
            elements,
            status,
            "state vectors -> equinoctial elements",
            "state vectors -> equinoctial elements (scale r, v and gm to other units)",
        )
        return carry_marks(self, ModifiedEquinoctialElements._from_canonical(
            *elements, self._gm, self._epoch, bool(retrograde)
        ))

    def propagate(self, dt):
        """States after two-body (Kepler) motion for a time ``dt``.

        Parameters
        ----------
        dt : Quantity
            Time of flight (unit of time), broadcasting against the states; negative values
            propagate backwards. Every conic is handled.

        Returns
        -------
        StateVectors

        Notes
        -----
        Universal variables: :func:`visviva.propagation.propagate_canonical` does the work
        (:func:`visviva.propagation.propagate_kepler` is the same as a function).
        """
        from .propagation import propagate_canonical

        refuse_pending(self, "two-body propagation")
        refuse_rotating(self, "two-body propagation")
        r, v, gm, dt_s, shape = propagate_canonical(self._r, self._v, self._gm, self._shape, dt)
        epoch = self.epoch
        if epoch is not None:
            epoch = _units.advance_epoch(epoch, dt_s)
            if epoch.shape not in ((), shape):
                epoch = np.broadcast_to(epoch, shape, subok=True)
        return carry_frame_mark(self, StateVectors._from_canonical(r, v, gm, epoch))


def states_from_kernel(elements, r, v, status, context, inputs, result_inputs=None):
    """Check one elements -> state kernel call and wrap its flat ``r``, ``v`` (km, km/s).

    Raises through :func:`visviva.errors.raise_for_result` (``inputs`` and ``result_inputs``
    are quoted in its messages) and returns a :class:`StateVectors` with the gm and epoch of
    ``elements``.
    """
    shape = elements.shape
    r = r.reshape(shape + (3,))
    v = v.reshape(shape + (3,))
    raise_for_result(context, status, [r, v], shape, inputs, result_inputs=result_inputs)
    return carry_marks(elements, StateVectors._from_canonical(r, v, elements.gm_km3_s2,
                                                              elements.epoch))
