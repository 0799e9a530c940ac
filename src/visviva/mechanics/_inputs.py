"""Inputs of :mod:`visviva.mechanics`: plain numbers in consistent units, or Quantities.

Every dimensional argument goes through :func:`visviva._units.to_si` (the one module that
converts units): a Quantity is converted to SI, a plain number is taken as it is. When any input of
a call was a Quantity, the outputs are returned as SI Quantities; otherwise as plain arrays.
"""

from __future__ import annotations

import numpy as np

from .._units import broadcast_or_raise, require_finite_result, to_si
from ..errors import ConvergenceError, DomainError, InvalidInputError, ShapeError

__all__ = ["Inputs", "SI", "callable_result", "finite_rhs", "si_array", "si_value",
           "require_symmetric"]


class _SIUnits:
    """SI units, resolved lazily so that importing this module does not import astropy."""

    _names = {
        "m": "m",
        "kg": "kg",
        "s": "s",
        "rad": "rad",
        "speed": "m / s",
        "accel": "m / s2",
        "rate": "1 / s",
        "angular_rate": "1 / s",
        "force": "N",
        "charge": "C",
        "impulse": "N s",
        "energy": "J",
        "energy_length": "J m",
        "momentum": "kg m / s",
        "inertia": "kg m2",
        "angmom": "kg m2 / s",
        "torque": "N m",
        "stiffness": "N / m",
        "drag_linear": "kg / s",
        "drag_quadratic": "kg / m",
        "per_m": "1 / m",
        "one": "",
    }

    def __getattr__(self, key):
        from astropy import units as u

        if key not in self._names:
            raise AttributeError(key)
        return u.Unit(self._names[key]) if self._names[key] else u.dimensionless_unscaled


SI = _SIUnits()


class Inputs:
    """Collects converted arguments of one call and remembers whether any was a Quantity.

    Examples
    --------
    >>> ins = Inputs()
    >>> m = ins.get(2.0, "kg", "m1", positive=True)
    >>> float(m), ins.any_quantity
    (2.0, False)
    """

    def __init__(self):
        self.any_quantity = False

    def get(
        self,
        value,
        unit: str,
        name: str,
        *,
        positive: bool = False,
        nonnegative: bool = False,
        finite: bool = True,
    ) -> np.ndarray:
        """Convert ``value`` (Quantity -> SI ``unit`` from :data:`SI`; plain number as is).

        ``unit="angular_rate"`` (an angular frequency or angular velocity, rad/s) refuses
        Quantities in hertz: astropy converts 1 Hz to 1 rad/s, not 2 pi rad/s, so a frequency
        in Hz would silently be 2 pi too slow.
        """
        if value is None:
            raise InvalidInputError(f"{name} is required; pass a number or a Quantity.")
        if unit == "angular_rate" and "Hz" in str(getattr(value, "unit", "")):
            from ..errors import UnitsError

            raise UnitsError(
                f"{name} is an angular frequency (rad/s) but was given in '{value.unit}': "
                "astropy converts 1 Hz to 1 rad/s, not 2 pi rad/s. Pass rad/s (or 1/s), or "
                "2 * np.pi * f for a frequency f in Hz (u.cycle / u.s also converts correctly)."
            )
        arr, was_q = to_si(value, getattr(SI, unit), name, finite=finite)
        self.any_quantity |= was_q
        if positive and np.any(~(arr > 0)):
            bad = arr[~(arr > 0)].ravel()[0] if arr.ndim else arr
            raise DomainError(f"{name} must be > 0; got {float(bad)!r}. Pass a positive value.")
        if nonnegative and np.any(~(arr >= 0)):
            bad = arr[~(arr >= 0)].ravel()[0] if arr.ndim else arr
            raise DomainError(f"{name} must be >= 0; got {float(bad)!r}. Pass a value >= 0.")
        return arr

    def vector(self, value, unit: str, name: str, *, dim: int | None = 3) -> np.ndarray:
        """Like :meth:`get`, and check that the last axis has length ``dim`` (any if None)."""
        arr = self.get(value, unit, name)
        if arr.ndim == 0 or (dim is not None and arr.shape[-1] != dim):
            want = f"({dim},) or (N, {dim})" if dim else "(d,) or (N, d)"
            raise ShapeError(
                f"{name} must have its components on the last axis, shape {want}; "
                f"got shape {arr.shape}."
            )
        return arr

    def broadcast(self, context: str, **arrays) -> tuple:
        """The common shape of ``arrays``; :class:`ShapeError` if they do not broadcast."""
        return broadcast_or_raise(context, **arrays)

    def finite(self, arr, context: str):
        """Return ``arr``; :class:`DomainError` if the computation overflowed to inf/NaN."""
        return require_finite_result(arr, context)

    def out(self, arr, unit: str):
        """Return ``arr`` as an SI Quantity if any input was a Quantity, else as an ndarray/float."""
        arr = np.asarray(arr, dtype=np.float64)
        if self.any_quantity:
            from astropy import units as u

            return u.Quantity(arr, getattr(SI, unit), copy=False)
        return arr[()] if arr.ndim == 0 else arr


def si_array(value, name: str, *, finite: bool = False) -> np.ndarray:
    """``value`` as a float64 array, a Quantity converted to its SI form.

    NaN/inf pass through unless ``finite`` (then :class:`~visviva.errors.InvalidInputError`).

    For arguments whose physical type is not fixed (generalised coordinates q0 in m or deg, their
    rates, momenta, times, parameters of a sympy model): ``30 * u.deg`` becomes 0.5236 (rad),
    ``1 * u.min`` 60 (s), ``1 * u.km`` 1000 (m). ``np.asarray`` would strip the unit and keep
    30, 1, 1: a silently wrong number. Plain numbers are taken as they are (consistent units).
    """
    return to_si(value, None, name, finite=finite)[0]


def si_value(value, name: str):
    """A model parameter: a Quantity converted to its SI form (a float), anything else as is."""
    if hasattr(value, "unit"):
        arr = si_array(value, name)
        if arr.size != 1:
            raise ShapeError(f"parameter {name} must be a scalar; got shape {arr.shape}.")
        return float(arr.reshape(()))
    return value


def model_parameters(expr, parameters, what: str) -> dict:
    """``{symbol: value}`` for a sympy model, keys matched by name to the symbols of ``expr``.

    A key given as a string (``{"m": 1.0}``), or as a Symbol whose assumptions differ from the
    model's (``Symbol("m")`` for ``Symbol("m", positive=True)``), is not equal to the model's
    symbol, so sympy's ``subs`` skipped it and the model said "symbols without values: m".
    Each key is replaced by the model's symbol of the same name; a string naming no symbol of
    the model is an InvalidInputError (a typo would otherwise be ignored).
    """
    by_name = {}
    for symbol in expr.free_symbols:
        by_name.setdefault(str(symbol), []).append(symbol)
    out = {}
    for key, value in dict(parameters or {}).items():
        if key in expr.free_symbols:
            out[key] = si_value(value, str(key))
            continue
        matches = by_name.get(str(key), [])
        if not matches and not isinstance(key, str):
            out[key] = si_value(value, str(key))  # a symbol the model does not use: unused
            continue
        if len(matches) != 1:
            known = ", ".join(sorted(by_name))
            raise InvalidInputError(
                f"parameter {str(key)!r} is not a symbol of {what}"
                + (" (several symbols have that name)" if matches else "")
                + f"; its symbols are: {known}."
            )
        out[matches[0]] = si_value(value, str(key))
    return out


def require_symmetric(I, name: str) -> None:
    """InvalidInputError unless the (3, 3) tensor I is symmetric to rounding (1e-12 relative)."""
    asym = np.max(np.abs(I - I.T))
    if asym > 1e-12 * max(np.max(np.abs(I)), 1e-300):
        raise InvalidInputError(
            f"{name} must be symmetric (an inertia tensor is); |{name} - {name}.T| reaches "
            f"{asym:.3g}. Pass (I + I.T) / 2 if this is rounding, or check the off-diagonal "
            "products of inertia."
        )


def require_physical_inertia(moments, name: str, context: str) -> None:
    """DomainError unless principal moments (ascending, last axis) are those of a real body.

    A body's principal moments are >= 0 and obey the triangle inequality I3 <= I1 + I2
    (equality for a plane lamina, zero moments for a rod or a point), both to 1e-12 of the
    largest moment (Goldstein 3rd ed. sec. 5.3; Landau & Lifshitz, *Mechanics*, sec. 32).
    """
    moments = np.asarray(moments, dtype=float)
    tol = 1e-12 * np.abs(moments[..., 2])
    if np.any(moments[..., 0] < -tol):
        raise DomainError(
            f"{context}: {name} has a negative principal moment ({moments[..., 0].min():.6g}); "
            "every moment of inertia sum m (r^2 - (r.n)^2) is >= 0. Check the signs of the "
            "products of inertia (I_xy = -sum m x y) and of the moments."
        )
    excess = moments[..., 2] - moments[..., 0] - moments[..., 1]
    if np.any(excess > tol):
        raise DomainError(
            f"{context}: the principal moments {moments} of {name} violate the triangle "
            "inequality I3 <= I1 + I2 that every real body satisfies (equality for a flat "
            "plate); check the inertia tensor."
        )


def square_matrix(value, name: str, ins: Inputs, unit: str) -> np.ndarray:
    """A finite square (n, n) matrix, symmetric to rounding, as float64."""
    arr = ins.get(value, unit, name)
    if arr.ndim == 0:
        arr = arr.reshape(1, 1)
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1] or arr.shape[0] == 0:
        raise ShapeError(
            f"{name} must be a square (n, n) matrix with n >= 1; got shape {arr.shape}."
        )
    scale = max(np.max(np.abs(arr)), np.finfo(float).tiny)
    if np.max(np.abs(arr - arr.T)) > 1e-10 * scale:
        raise InvalidInputError(
            f"{name} must be symmetric; |{name} - {name}.T| reaches "
            f"{np.max(np.abs(arr - arr.T)):.3g}. Pass (A + A.T) / 2 if the asymmetry is rounding."
        )
    return 0.5 * (arr + arr.T)


def callable_result(
    value, shape: tuple, what: str, time, at: str = "t", unit: str | None = None
) -> np.ndarray:
    """The float64 array a user callable returned, checked to have ``shape`` and be finite.

    Parameters
    ----------
    value : array_like
        What the callable returned.
    shape : tuple
        The shape it must have (same number of elements is accepted, then reshaped).
    what : str
        The callable as the user knows it, e.g. ``"force(t, r, v)"``, named in the errors.
    time : float
        The time [s] (or curve parameter) of the call, named in the errors.
    at : str
        The name of ``time`` in the errors (``"t"``, or ``"s"`` for a curve parameter).
    unit : str, optional
        The key in :data:`SI` of what the callable returns (``"force"``, ``"torque"``, ...): a
        Quantity result is converted to it (:class:`~visviva.errors.UnitsError` if it cannot
        be); without ``unit`` a Quantity is converted to its SI form. ``np.asarray`` would strip
        the unit: a force in kN was read as N.

    Returns
    -------
    ndarray
        ``value`` as float64 of ``shape``.
    """
    if hasattr(value, "unit"):
        target = None if unit is None else getattr(SI, unit)
        arr = to_si(value, target, what, finite=False)[0]
    else:
        arr = np.asarray(value, dtype=float)
    if arr.size != int(np.prod(shape)):
        raise ShapeError(
            f"{what.split('(')[0]} returned shape {arr.shape}; {what} must return shape {shape}."
        )
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(
            f"{what} returned NaN or inf at {at} = {float(time):.9g}: {arr.tolist()}. It must be finite "
            "all along the motion; check the formula (a division by zero, a square root of a "
            "negative number) and its units."
        )
    return arr.reshape(shape)


def ivp_failure(sol, context: str, t_end) -> ConvergenceError:
    """The ConvergenceError for a failed :func:`scipy.integrate.solve_ivp` run, naming where.

    scipy's own message ("Required step size is less than spacing between numbers") says
    neither when nor why; the step collapses where the motion becomes singular.
    """
    reached = float(sol.t[-1]) if np.size(sol.t) else float("nan")
    return ConvergenceError(
        f"{context}: the integrator failed after t = {reached:.9g} (the last output time reached; "
        f"the run was to t = {float(t_end):.9g}): {sol.message} The step size collapses where the "
        "equations of motion become singular: a collision (a distance falling to 0 under an "
        "attractive force, e.g. radial infall reaches r = 0 at the free-fall time "
        "pi/2 sqrt(r0^3 / 2 mu)), a force growing without bound, or a very stiff system (try "
        "method='Radau'). End the run before that time, or soften the force."
    )


IVP_METHODS = ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")


def ivp_method(method, context: str) -> str:
    """``method`` if it names a :func:`scipy.integrate.solve_ivp` method, else InvalidInputError."""
    if method not in IVP_METHODS:
        raise InvalidInputError(f"{context}: method must be one of {IVP_METHODS}; got {method!r}.")
    return method


def finite_rhs(rhs, context: str):
    """``rhs(t, y)`` for :func:`scipy.integrate.solve_ivp` that raises instead of returning NaN.

    solve_ivp does not stop on a NaN derivative: its step-size control shrinks the step for ever
    (the call hangs) or fails with an unrelated message. The wrapper raises
    :class:`~visviva.errors.DomainError` naming the time and the state instead.

    Parameters
    ----------
    rhs : callable
        ``rhs(t, y) -> dy/dt``.
    context : str
        The public function, named in the error.

    Returns
    -------
    callable
        The guarded right-hand side.
    """

    def fail(t, y, cause):
        raise DomainError(
            f"{context}: the equations of motion are not finite ({cause}) at t = "
            f"{float(t):.9g}, state {np.asarray(y).tolist()}: the motion reached a singular "
            "configuration (a collision, a singular mass matrix, a zero radius) or a callable "
            "returned NaN. Stop the integration before it, or check the model."
        )

    def guarded(t, y):
        try:
            dy = rhs(t, y)
        except (ZeroDivisionError, OverflowError) as exc:  # from math-module lambdified code
            fail(t, y, str(exc))
        except ValueError as exc:
            if str(exc) != "math domain error":
                raise
            fail(t, y, str(exc))
        if not np.all(np.isfinite(dy)):
            fail(t, y, "NaN or inf")
        return dy

    return guarded
