"""Modified equinoctial elements (Walker, Ireland & Owens 1985), non-singular for circular and
equatorial orbits (and, with the retrograde factor, for i = pi).

Symbols: ``docs/conventions.md``.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from . import _units
from ._containers import (
    TwoBodyContainer,
    _deg,
    _first_bad,
    _index_elements,
    _require_positive_p,
    _scalar_or_array,
    broadcast_shape,
    canonical_arrays,
    carry_marks,
    flat_elements,
    gm_positive,
    validate_epoch,
    warn_if_degrees,
)
from .errors import InvalidElementsError
from .states import states_from_kernel

__all__ = ["ModifiedEquinoctialElements"]


class ModifiedEquinoctialElements(TwoBodyContainer):
    """Modified equinoctial elements (Walker, Ireland & Owens 1985) of one or many orbits.

    Parameters
    ----------
    p : Quantity
        Semi-latus rectum (length), > 0.
    f, g : float or array_like
        e cos(argp + I raan), e sin(argp + I raan) (dimensionless).
    h, k : float or array_like
        tan^I(i/2) cos(raan), tan^I(i/2) sin(raan) (dimensionless).
    L : Quantity or float
        True longitude argp + I raan + nu (rad).
    gm : Quantity or Body
        Gravitational parameter (km3/s2), > 0.
    epoch : astropy.time.Time, optional
    retrograde : bool
        The retrograde factor: False for I = +1 (standard; singular only at i = pi exactly),
        True for I = -1 (singular only at i = 0). Use True for orbits at or near i = pi.

    Notes
    -----
    Non-singular for circular and equatorial orbits and valid for every conic (e = f^2 + g^2
    may be >= 1). r = p/(1 + f cos L + g sin L); the frame vectors and the velocity follow
    Walker et al. (1985), eqs. 2-4, with the retrograde factor of Broucke & Cefola (1972).
    """

    _ITEM = "set of elements"

    def __init__(self, p, f, g, h, k, L, gm, epoch=None, retrograde=False):
        retrograde = _units.require_flag(retrograde, "retrograde")
        p_km = _units.to_array(p, "length", "p")
        f = _units.to_array(f, "dimensionless", "f")
        g = _units.to_array(g, "dimensionless", "g")
        h = _units.to_array(h, "dimensionless", "h")
        k = _units.to_array(k, "dimensionless", "k")
        L_in, L = L, _units.to_array(L, "angle", "L")
        warn_if_degrees(L_in, L, "L")  # as KeplerianElements does for its angles
        gm = _units.to_array(gm, "gm", "gm")
        gm_positive(gm)
        shape = broadcast_shape(
            {
                "p": p_km.shape,
                "f": f.shape,
                "g": g.shape,
                "h": h.shape,
                "k": k.shape,
                "L": L.shape,
                "gm": gm.shape,
            },
            "ModifiedEquinoctialElements",
        )
        epoch = validate_epoch(epoch, shape, "the elements")
        _require_positive_p(p_km)
        w = np.broadcast_to(1.0 + f * np.cos(L) + g * np.sin(L), shape)
        if np.any(w <= 0):
            raise InvalidElementsError(
                f"1 + f cos L + g sin L <= 0{_first_bad(w <= 0)}: the true longitude lies on or "
                "beyond the asymptote of the open orbit. Choose L with "
                "|L - atan2(g, f)| < arccos(-1/e), e = hypot(f, g)."
            )
        self._init_canonical(p_km, f, g, h, k, L, gm, epoch, retrograde, shape)

    def _init_canonical(self, p, f, g, h, k, L, gm, epoch, retrograde, shape):
        self._shape = tuple(shape)
        self._p, self._f, self._g, self._h, self._k, self._L = canonical_arrays(
            self._shape, p, f, g, h, k, L
        )
        self._gm = np.asarray(gm, dtype=np.float64)
        self._epoch = epoch
        self._retrograde = bool(retrograde)

    @classmethod
    def _from_canonical(cls, p, f, g, h, k, L, gm, epoch=None, retrograde=False):
        obj = cls.__new__(cls)
        shape = np.broadcast_shapes(*(np.shape(x) for x in (p, f, g, h, k, L, gm)))
        obj._init_canonical(p, f, g, h, k, L, gm, epoch, retrograde, shape)
        return obj

    @property
    def retrograde(self) -> bool:
        """True when the retrograde factor I = -1 is used."""
        return self._retrograde

    @cached_property
    def semi_latus_rectum(self):
        """p (Quantity, km)."""
        return _units.to_quantity(self._p, "length")

    @property
    def p(self):
        """Alias of :attr:`semi_latus_rectum`."""
        return self.semi_latus_rectum

    @cached_property
    def f(self):
        """f = e cos(argp + I raan) (dimensionless)."""
        return _scalar_or_array(np.array(self._f))

    @cached_property
    def g(self):
        """g = e sin(argp + I raan) (dimensionless)."""
        return _scalar_or_array(np.array(self._g))

    @cached_property
    def h(self):
        """h = tan^I(i/2) cos(raan) (dimensionless)."""
        return _scalar_or_array(np.array(self._h))

    @cached_property
    def k(self):
        """k = tan^I(i/2) sin(raan) (dimensionless)."""
        return _scalar_or_array(np.array(self._k))

    @cached_property
    def true_longitude(self):
        """L = argp + I raan + nu (Quantity, rad)."""
        return _units.to_quantity(self._L, "angle")

    @property
    def L(self):
        """Alias of :attr:`true_longitude`."""
        return self.true_longitude

    def __getitem__(self, key):
        parts, gm, epoch = _index_elements(self, key, "ModifiedEquinoctialElements")
        return carry_marks(self, ModifiedEquinoctialElements._from_canonical(
            *parts, gm, epoch, self._retrograde))

    def stored_arrays(self) -> tuple:
        """The six stored elements as canonical float64 arrays (p km, f, g, h, k, L rad), each broadcasting to
        :attr:`shape`: what the compiled kernels take."""
        return (self._p, self._f, self._g, self._h, self._k, self._L)

    def __repr__(self) -> str:
        I = -1 if self._retrograde else 1  # noqa: E741
        if int(np.prod(self._shape)) == 1:
            vals = [float(x.reshape(-1)[0]) for x in self.stored_arrays()]
            return (
                f"ModifiedEquinoctialElements(p={vals[0]:.9g} km, f={vals[1]:.12g}, "
                f"g={vals[2]:.12g}, h={vals[3]:.12g}, k={vals[4]:.12g}, L={_deg(vals[5])}, I={I})"
            )
        return f"<ModifiedEquinoctialElements shape={self._shape}, I={I}>"

    def to_state(self):
        """State vectors (Walker et al. 1985, eqs. 3-4). Returns :class:`StateVectors`."""
        from .core.elements import empty_states, mee_to_rv_array

        retro = -1.0 if self._retrograde else 1.0
        r, v, status = out = empty_states(self.size)
        mee_to_rv_array(*flat_elements(self), retro, *out)
        return states_from_kernel(
            self,
            r,
            v,
            status,
            "equinoctial elements -> state vectors",
            {"p": self._p, "f": self._f, "g": self._g, "L": self._L},
            result_inputs={"p": self._p, "h": self._h, "k": self._k},
        )

    def to_keplerian(self):
        """Classical elements (through the state vectors). Returns :class:`KeplerianElements`."""
        return self.to_state().to_elements()
