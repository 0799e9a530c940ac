"""Classical (Keplerian) orbital elements.

:class:`KeplerianElements` stores the semi-latus rectum ``p`` (not ``a``), so that the exact
parabola is representable, plus e, i, raan, argp, nu and GM; every other element is a lazy,
cached, long-named property. The non-singular set is
:class:`visviva.equinoctial.ModifiedEquinoctialElements`. Symbols and the convention for
undefined angles: ``docs/conventions.md``.
"""

from __future__ import annotations

import math
from functools import cached_property

import numpy as np

from . import _units
from ._containers import (
    _INC_SLACK,
    _TWO_PI,
    TwoBodyContainer,
    _deg,
    _first_bad,
    _index_elements,
    _require_positive_p,
    _scalar_or_array,
    _wrap_2pi,
    _wrap_pi,
    broadcast_shape,
    canonical_arrays,
    carry_marks,
    check_element_scales,
    flat,
    flat_elements,
    gm_positive,
    validate_epoch,
    warn_if_degrees,
)
from .errors import InvalidElementsError, InvalidInputError, fmt_number, raise_for_result
from .states import states_from_kernel

__all__ = ["KeplerianElements"]

_TINY_NORMAL = float(np.finfo(np.float64).tiny)

class KeplerianElements(TwoBodyContainer):
    """Classical orbital elements of one or many two-body orbits.

    Parameters
    ----------
    p : Quantity
        Semi-latus rectum (unit of length, e.g. km), > 0. Stored instead of ``a`` so that the
        parabola (e = 1, a infinite) is exact; use :meth:`from_semi_major_axis` to give ``a``.
    ecc : float or array_like
        Eccentricity (dimensionless), >= 0: 0 circle, < 1 ellipse, exactly 1 parabola, > 1
        hyperbola.
    inc : Quantity or float
        Inclination in [0, pi] (angle; plain floats are radians).
    raan : Quantity or float
        Longitude of the ascending node (rad).
    argp : Quantity or float
        Argument of periapsis (rad).
    nu : Quantity or float
        True anomaly (rad); for e >= 1 it must satisfy 1 + e cos(nu) > 0 (inside the asymptotes).
    gm : Quantity or Body
        Gravitational parameter of the central body (km3/s2), > 0.
    epoch : astropy.time.Time, optional
        Epoch of the elements (carried along).

    Raises
    ------
    UnitsError, ShapeError
        Missing/wrong units or shapes that do not broadcast.
    InvalidElementsError
        p <= 0, e < 0, inclination outside [0, pi], or a true anomaly on/beyond the asymptote.
    InvalidInputError
        NaN/inf values or gm <= 0.

    Notes
    -----
    Orientation R = Rz(raan) Rx(inc) Rz(argp); r = p/(1 + e cos nu). Undefined angles (raan of an
    equatorial orbit, argp of a circular one) follow docs/conventions.md, so that
    state -> elements -> state is exact to rounding. Vallado (2013), Sec. 2.5-2.6.

    Examples
    --------
    >>> import visviva as vv
    >>> from astropy import units as u
    >>> el = vv.KeplerianElements(7000 * u.km, 0.0, 0.0, 0.0, 0.0, 0.0, vv.EARTH)
    >>> print(el.to_state().r)
    [7000.    0.    0.] km
    """

    _ITEM = "set of elements"

    def __init__(self, p, ecc, inc, raan, argp, nu, gm, epoch=None):
        from .core import tier
        from .core.elements import scan_coe

        raan_in, argp_in, nu_in = raan, argp, nu
        # finite=False: one compiled pass below checks finiteness and every range at once;
        # the numpy checks after it only run to word the error message.
        p_km = _units.to_array(p, "length", "p", finite=False)
        ecc = _units.to_array(ecc, "dimensionless", "ecc", finite=False)
        inc = _units.to_array(inc, "angle", "inc", finite=False)
        raan = _units.to_array(raan, "angle", "raan", finite=False)
        argp = _units.to_array(argp, "angle", "argp", finite=False)
        nu = _units.to_array(nu, "angle", "nu", finite=False)
        gm = _units.to_array(gm, "gm", "gm", finite=False)
        shape = broadcast_shape(
            {
                "p": p_km.shape,
                "ecc": ecc.shape,
                "inc": inc.shape,
                "raan": raan.shape,
                "argp": argp.shape,
                "nu": nu.shape,
                "gm": gm.shape,
            },
            "KeplerianElements",
        )
        epoch = validate_epoch(epoch, shape, "the elements")
        first, _ = tier.call(
            scan_coe, *(flat(x, shape) for x in (p_km, ecc, inc, raan, argp, nu, gm)), _INC_SLACK,
            small=math.prod(shape) <= tier.SMALL_ITEMS)
        if first >= 0:
            self._raise_invalid(p_km, ecc, inc, raan, argp, nu, gm, shape)
        check_element_scales(p_km, ecc, gm, shape)
        if np.any(inc > math.pi):  # rounding above pi (e.g. 180 deg -> rad): exactly pi
            inc = np.minimum(inc, math.pi)
        inc = inc + 0.0  # -0.0 (e.g. -0.0 deg) stored as +0.0: no negative-zero inclination
        # docs/conventions.md: raan, argp in [0, 2 pi), nu in (-pi, pi], from any input
        for value, arr, name in ((raan_in, raan, "raan"), (argp_in, argp, "argp"), (nu_in, nu, "nu")):
            warn_if_degrees(value, arr, name)
        raan, argp, nu = _wrap_2pi(raan), _wrap_2pi(argp), _wrap_pi(nu)
        self._init_canonical(p_km, ecc, inc, raan, argp, nu, gm, epoch, shape)

    @staticmethod
    def _raise_invalid(p_km, ecc, inc, raan, argp, nu, gm, shape):
        """Word the error for the first invalid input (slow path, only on failure)."""
        for name, arr in (
            ("p", p_km),
            ("ecc", ecc),
            ("inc", inc),
            ("raan", raan),
            ("argp", argp),
            ("nu", nu),
            ("gm", gm),
        ):
            _units.require_finite(arr, name)
        gm_positive(gm)
        _require_positive_p(
            p_km,
            " A radial orbit (p = 0) has no classical elements; for a given semi-major axis use "
            "KeplerianElements.from_semi_major_axis.",
        )
        if np.any(ecc < 0):
            raise InvalidElementsError(
                f"ecc (eccentricity) must be >= 0{_first_bad(ecc < 0)}; got "
                f"{fmt_number(ecc[ecc < 0].ravel()[0])}. Flip the sign and add pi to argp if you meant the "
                "opposite periapsis direction."
            )
        bad_inc = (inc < 0) | (inc > math.pi + _INC_SLACK)
        if np.any(bad_inc):
            raise InvalidElementsError(
                f"inc (inclination) must lie in [0, pi] rad = [0, 180] deg{_first_bad(bad_inc)}; "
                f"got {fmt_number(inc[bad_inc].ravel()[0])} rad. Retrograde orbits have inc > pi/2; a "
                "negative inclination is the same orbit with inc -> -inc and raan -> raan + pi."
            )
        unreachable = np.zeros(shape, dtype=bool)
        if np.any(ecc >= 1.0):  # only open orbits have an asymptote: test those alone
            e_b, nu_b = np.broadcast_to(ecc, shape), np.broadcast_to(nu, shape)
            is_open = e_b >= 1.0
            unreachable[is_open] = 1.0 + e_b[is_open] * np.cos(nu_b[is_open]) <= 0
        if np.any(unreachable):
            e_b = np.broadcast_to(ecc, shape)[unreachable].ravel()[0]
            nu_b = np.broadcast_to(nu, shape)[unreachable].ravel()[0]
            limit = math.degrees(math.acos(-1.0 / e_b))
            raise InvalidElementsError(
                f"nu = {math.degrees(nu_b):.6f} deg lies on or beyond the asymptote of the open "
                f"orbit with e = {fmt_number(e_b)}{_first_bad(unreachable)}: no body reaches it. Choose "
                f"|nu| < arccos(-1/e) = {limit:.6f} deg."
            )
        raise InvalidElementsError("invalid elements (no specific check matched); report this")

    def _init_canonical(self, p, ecc, inc, raan, argp, nu, gm, epoch, shape):
        self._shape = tuple(shape)
        self._p, self._ecc, self._inc, self._raan, self._argp, self._nu = canonical_arrays(
            self._shape, p, ecc, inc, raan, argp, nu
        )
        self._gm = np.asarray(gm, dtype=np.float64)
        self._epoch = epoch

    @classmethod
    def _from_canonical(cls, p, ecc, inc, raan, argp, nu, gm, epoch=None):
        """Wrap canonical float64 arrays (km, rad, km3/s2) without validation."""
        obj = cls.__new__(cls)
        shape = np.broadcast_shapes(*(np.shape(x) for x in (p, ecc, inc, raan, argp, nu, gm)))
        obj._init_canonical(p, ecc, inc, raan, argp, nu, gm, epoch, shape)
        return obj

    @classmethod
    def from_semi_major_axis(cls, a, ecc, inc, raan, argp, nu, gm, epoch=None):
        """Elements from the semi-major axis instead of the semi-latus rectum.

        Parameters
        ----------
        a : Quantity
            Semi-major axis (length): > 0 for an ellipse (0 <= e < 1), < 0 for a hyperbola
            (e > 1). A parabola (e = 1) has no finite a: give ``p`` to the constructor instead.
        ecc, inc, raan, argp, nu, gm, epoch
            As for :class:`KeplerianElements`.

        Notes
        -----
        p = a (1 - e)(1 + e) (the product avoids the cancellation in 1 - e^2 near e = 1).
        """
        a_km = _units.to_array(a, "length", "a", finite=False)
        e = _units.to_array(ecc, "dimensionless", "ecc")
        if np.any(np.isnan(a_km)):
            raise InvalidInputError("a contains NaN values. Remove or fill them before calling.")
        if np.any(e == 1.0):
            raise InvalidElementsError(
                "a parabola (ecc = 1) has an infinite semi-major axis, so a cannot define it: "
                "use KeplerianElements(p, 1.0, ...) with the semi-latus rectum p "
                "(p = 2 q, twice the periapsis distance)."
            )
        shape = broadcast_shape({"a": a_km.shape, "ecc": e.shape}, "from_semi_major_axis")
        a_b, e_b = np.broadcast_to(a_km, shape), np.broadcast_to(e, shape)
        bad_ell = (e_b < 1) & ~(a_b > 0)
        if np.any(bad_ell):
            raise InvalidElementsError(
                f"a must be > 0 for an ellipse (ecc < 1){_first_bad(bad_ell)}; got "
                f"{fmt_number(a_b[bad_ell].ravel()[0])} km with ecc = {fmt_number(e_b[bad_ell].ravel()[0])}."
            )
        bad_hyp = (e_b > 1) & ~(a_b < 0)
        if np.any(bad_hyp):
            raise InvalidElementsError(
                f"a must be < 0 for a hyperbola (ecc > 1){_first_bad(bad_hyp)}; got "
                f"{fmt_number(a_b[bad_hyp].ravel()[0])} km with ecc = {fmt_number(e_b[bad_hyp].ravel()[0])}. "
                "Pass a = -|a|."
            )
        if np.any(~np.isfinite(a_b)):
            raise InvalidInputError("a must be finite for ecc != 1.")
        p = a_b * (1.0 - e_b) * (1.0 + e_b)
        return cls(_units.to_quantity(p, "length"), e, inc, raan, argp, nu, gm, epoch)

    # --- container protocol --------------------------------------------------------------------
    def __getitem__(self, key):
        parts, gm, epoch = _index_elements(self, key, "KeplerianElements")
        return carry_marks(self, KeplerianElements._from_canonical(*parts, gm, epoch))

    def stored_arrays(self) -> tuple:
        """The six stored elements as canonical float64 arrays (p km, ecc, inc, raan, argp, nu rad), each broadcasting to
        :attr:`shape`: what the compiled kernels take."""
        return (self._p, self._ecc, self._inc, self._raan, self._argp, self._nu)

    def __repr__(self) -> str:
        gm = np.unique(self._gm)
        gm_txt = f"{gm[0]:.10g} km3 / s2" if gm.size == 1 else f"{gm.size} values"
        epoch = "" if self._epoch is None else f", epoch={self._epoch}"
        if self.size == 1:
            p, e, i, o, w, n = (float(x.reshape(-1)[0]) for x in self.stored_arrays())
            return (
                f"KeplerianElements(p={p:.9g} km, ecc={e:.12g}, inc={_deg(i)}, "
                f"raan={_deg(o)}, argp={_deg(w)}, nu={_deg(n)}, gm={gm_txt}{epoch})"
            )
        if self.size == 0:
            return f"<KeplerianElements shape={self._shape}: no orbits>"
        return (
            f"<KeplerianElements shape={self._shape}: {self.size} orbits, gm={gm_txt}{epoch}; "
            f"ecc in [{self._ecc.min():.6g}, {self._ecc.max():.6g}], "
            f"p in [{self._p.min():.6g}, {self._p.max():.6g}] km>"
        )

    # --- stored elements as Quantities ----------------------------------------------------------
    @cached_property
    def semi_latus_rectum(self):
        """Semi-latus rectum p = h^2/mu (Quantity, km)."""
        return _units.to_quantity(self._p, "length")

    @cached_property
    def eccentricity(self):
        """Eccentricity e (dimensionless float or ndarray)."""
        return _scalar_or_array(np.array(self._ecc))

    @cached_property
    def inclination(self):
        """Inclination i in [0, pi] (Quantity, rad)."""
        return _units.to_quantity(self._inc, "angle")

    @cached_property
    def longitude_of_ascending_node(self):
        """Longitude of the ascending node raan (Quantity, rad); 0 for equatorial orbits."""
        return _units.to_quantity(self._raan, "angle")

    @cached_property
    def argument_of_periapsis(self):
        """Argument of periapsis argp (Quantity, rad); 0 for circular orbits."""
        return _units.to_quantity(self._argp, "angle")

    @cached_property
    def true_anomaly(self):
        """True anomaly nu (Quantity, rad)."""
        return _units.to_quantity(self._nu, "angle")

    # --- derived elements (lazy) ----------------------------------------------------------------
    @cached_property
    def _one_minus_e2(self):
        return (1.0 - self._ecc) * (1.0 + self._ecc)

    @cached_property
    def _a_km(self):
        with np.errstate(divide="ignore"):
            return np.where(self._ecc == 1.0, np.inf, self._p / self._one_minus_e2)

    @cached_property
    def semi_major_axis(self):
        """Semi-major axis a = p/(1 - e^2) (Quantity, km): inf for e = 1, < 0 for e > 1."""
        return _units.to_quantity(self._a_km, "length")

    @cached_property
    def mean_anomaly(self):
        """Mean anomaly M (Quantity, rad).

        Ellipse E - e sin E, hyperbola e sinh F - F, parabola D + D^3/3 with D = tan(nu/2)
        (Barker), each with the sign of nu; M = n (t - t_periapsis) with n = mean_motion.
        Computed by :func:`visviva.core.kepler_arrays.true_to_mean_array`.
        """
        from .core.kepler_arrays import true_to_mean_array

        nu = np.ascontiguousarray(self._nu).reshape(-1)
        ecc = np.ascontiguousarray(self._ecc).reshape(-1)
        M = np.empty(nu.shape[0])
        status = np.empty(nu.shape[0], dtype=np.int8)
        true_to_mean_array(nu, ecc, M, status)
        M = M.reshape(self._shape)
        raise_for_result(
            "true -> mean anomaly",
            status,
            [M],
            self._shape,
            {"nu": self._nu, "ecc": self._ecc},
            result_inputs={"nu": self._nu},
        )
        return _units.to_quantity(M, "angle")

    @cached_property
    def argument_of_latitude(self):
        """Argument of latitude u = argp + nu in [0, 2 pi) (Quantity, rad)."""
        return _units.to_quantity(_wrap_2pi(self._argp + self._nu), "angle")

    @cached_property
    def true_longitude(self):
        """True longitude l = raan + argp + nu in [0, 2 pi) (Quantity, rad).

        For i = pi it is measured from x in the direction of motion (clockwise seen from +z).
        """
        return _units.to_quantity(_wrap_2pi(self._raan + self._argp + self._nu), "angle")

    @cached_property
    def longitude_of_periapsis(self):
        """Longitude of periapsis varpi = raan + argp in [0, 2 pi) (Quantity, rad)."""
        return _units.to_quantity(_wrap_2pi(self._raan + self._argp), "angle")

    @cached_property
    def periapsis_distance(self):
        """Periapsis distance q = p/(1 + e) (Quantity, km)."""
        return _units.to_quantity(self._p / (1.0 + self._ecc), "length")

    @cached_property
    def apoapsis_distance(self):
        """Apoapsis distance p/(1 - e) (Quantity, km); inf for e >= 1."""
        with np.errstate(divide="ignore"):
            Q = np.where(self._ecc < 1.0, self._p / (1.0 - self._ecc), np.inf)
        return _units.to_quantity(Q, "length")

    @cached_property
    def _n_rad_s(self):
        gm = np.broadcast_to(self._gm, self._shape)
        with np.errstate(all="ignore"):  # the branch np.where discards may overflow
            a = np.abs(self._a_km)
            p = self._p
            n = np.where(self._ecc == 1.0, 2.0 * (np.sqrt(gm / p) / p), np.sqrt(gm / a) / a)
        bad = ~(n >= _TINY_NORMAL)  # underflow to 0 (or a subnormal): period inf
        if np.any(bad):
            from .errors import DomainError

            i = int(np.flatnonzero(bad.ravel())[0])
            a_i = float(np.broadcast_to(np.where(self._ecc == 1.0, p, a), self._shape).ravel()[i])
            g_i = float(gm.ravel()[i])
            log_n = 0.5 * (math.log10(g_i) - 3.0 * math.log10(a_i))
            raise DomainError(
                f"mean motion{_first_bad(bad)}: sqrt(gm/|a|^3) ~ 1e{log_n:.1f} rad/s (|a| = "
                f"{a_i:.6g} km, gm = {g_i:.6g} km3/s2) underflows float64, so the mean motion "
                f"would read 0 and the period (~1e{math.log10(_TWO_PI) - log_n:.1f} s) inf. Such "
                "an orbit does not move in any representable time; check the units of p and gm."
            )
        return n

    @cached_property
    def mean_motion(self):
        """Mean motion n (Quantity, rad/s): sqrt(mu/|a|^3); 2 sqrt(mu/p^3) for the parabola."""
        from astropy import units as u

        return u.Quantity(self._n_rad_s, u.rad / u.s, copy=False)

    @cached_property
    def period(self):
        """Orbital period 2 pi/n (Quantity, s); inf for e >= 1."""
        with np.errstate(divide="ignore"):
            T = np.where(self._ecc < 1.0, _TWO_PI / self._n_rad_s, np.inf)
        return _units.to_quantity(T, "time")

    @cached_property
    def specific_energy(self):
        """Specific orbital energy -mu (1 - e^2)/(2 p) (Quantity, km2/s2); 0 for the parabola."""
        gm = np.broadcast_to(self._gm, self._shape)
        return _units.to_quantity(-0.5 * gm * self._one_minus_e2 / self._p, "spec_energy")

    @cached_property
    def specific_angular_momentum(self):
        """Magnitude of the specific angular momentum sqrt(mu p) (Quantity, km2/s)."""
        gm = np.broadcast_to(self._gm, self._shape)
        return _units.to_quantity(np.sqrt(gm * self._p), "spec_angmom")

    # --- conversions ----------------------------------------------------------------------------
    def to_state(self):
        """State vectors of every orbit at its true anomaly.

        Returns
        -------
        StateVectors

        Notes
        -----
        One call of :func:`visviva.core.elements.coe_to_rv_array` (Vallado 2013, Algorithm 10).
        """
        from .core import tier
        from .core.elements import coe_to_rv_array, empty_states

        r, v, status = out = empty_states(self.size)
        tier.call(coe_to_rv_array, *flat_elements(self), *out, small=self.size <= tier.SMALL_ITEMS)
        inputs = {"p": self._p, "ecc": self._ecc, "nu": self._nu}
        return states_from_kernel(self, r, v, status, "elements -> state vectors", inputs)

    def to_equinoctial(self, retrograde: bool = False):
        """Modified equinoctial elements (through the state vectors)."""
        return self.to_state().to_equinoctial(retrograde=retrograde)
