"""Kepler's equation and the anomalies of every conic: the units-aware public layer.

Array in, array out: every function broadcasts its arguments against each other and makes one
call of a compiled kernel (:mod:`visviva.core.kepler`) over all the items.

Angles are plain numbers in radians or astropy Quantities of any angle unit. The result has the
broadcast shape of the inputs; it is an astropy ``Quantity`` in ``rad`` when the angle argument was
a Quantity, else a plain ``ndarray`` (a NumPy float for scalar input). Eccentricities are plain
numbers (or dimensionless Quantities).

Mean-anomaly conventions (M = n t, t the time since periapsis; see ``docs/anomalies.md``):

==========  =======================  ===========================  =========================
regime      anomaly                  mean anomaly                 mean motion n
==========  =======================  ===========================  =========================
0 <= e < 1  eccentric E              M = E - e sin E              sqrt(mu / a^3)
e = 1       D = tan(nu / 2)          M = D + D^3 / 3 (Barker)     2 sqrt(mu / p^3)
e > 1       hyperbolic F             M = e sinh F - F             sqrt(mu / (-a)^3)
==========  =======================  ===========================  =========================

The first call of each function compiles its kernel (or loads it from numba's cache).
"""

from __future__ import annotations

import numba
import numpy as np

from . import _units
from .core import kepler_arrays as _ka
from .core import tier
from .core.status import OK, OVERFLOW
from .errors import ShapeError, raise_for_status

__all__ = [
    "solve_kepler",
    "solve_kepler_hyperbolic",
    "solve_barker",
    "mean_to_true",
    "true_to_mean",
    "eccentric_to_true",
    "true_to_eccentric",
    "hyperbolic_to_true",
    "true_to_hyperbolic",
    "parabolic_to_true",
    "true_to_parabolic",
    "eccentric_to_mean",
    "hyperbolic_to_mean",
]

#: below this many items the kernels run on the calling thread only
_PARALLEL_MIN_ITEMS = 4096


def _run(kernel, context, angle, angle_name, ecc=None):
    """Convert, broadcast, call ``kernel(angle, [ecc,] out, status)`` once, raise, wrap."""
    was_quantity = _units.is_quantity(angle) or (
        isinstance(angle, list | tuple) and _units._holds_quantity(angle)
    )
    # NaN and inf are caught by the kernels (status NON_FINITE), so no separate pass here
    x = _units.to_array(angle, "angle", angle_name, finite=False)
    inputs = {angle_name: x}
    if ecc is None:
        shape = x.shape
        args = (np.ascontiguousarray(x).ravel(),)
    else:
        e = _units.to_array(ecc, "dimensionless", "ecc", finite=False)
        try:
            shape = np.broadcast_shapes(x.shape, e.shape)
        except ValueError as exc:
            raise ShapeError(
                f"{angle_name} with shape {np.shape(x)} and ecc with shape {np.shape(e)} do not "
                "broadcast against each other; give arrays of the same shape, or a scalar."
            ) from exc
        # writable contiguous copies where broadcasting repeats items (to_array's arrays are
        # our own; broadcast_arrays views would make numba warn about their writeable flag)
        x, e = (a if a.shape == shape else np.ascontiguousarray(np.broadcast_to(a, shape))
                for a in (x, e))
        inputs["ecc"] = e
        args = (np.ascontiguousarray(x).ravel(), np.ascontiguousarray(e).ravel())
    n = args[0].shape[0]
    out = np.empty(n, dtype=np.float64)
    status = np.empty(n, dtype=np.int8)
    if n < _PARALLEL_MIN_ITEMS:
        # waking numba's worker threads costs ~0.1-5 ms (far more on a busy machine) while a
        # few thousand solves take microseconds: run small batches on the calling thread
        threads = numba.get_num_threads()
        numba.set_num_threads(1)
        try:  # a small call on a fresh install runs interpreted (core/tier.py)
            tier.call(kernel, *args, out, status, small=n <= tier.SMALL_ITEMS)
        finally:
            numba.set_num_threads(threads)
    else:
        kernel(*args, out, status)
    status = status.reshape(shape)
    raise_for_status(status, context, **inputs)
    out = out.reshape(shape)
    if not np.all(np.isfinite(out)):
        # a kernel reported OK but its value is not finite: never hand out NaN/inf silently
        raise_for_status(np.where(np.isfinite(out), OK, OVERFLOW), context, **inputs)
    if was_quantity:
        return _units.to_quantity(out, "angle")
    return out if shape else out[()]


def solve_kepler(M, ecc):
    """Eccentric anomaly E from the mean anomaly M of an ellipse (Kepler's equation).

    Parameters
    ----------
    M : float, array_like or Quantity (angle)
        Mean anomaly, any real value (rad if plain). Whole revolutions are kept:
        ``solve_kepler(M + 2 pi k, e) = solve_kepler(M, e) + 2 pi k``.
    ecc : float or array_like
        Eccentricity, 0 <= e < 1. Broadcasts against ``M``.

    Returns
    -------
    E : ndarray, float or Quantity (rad)
        Eccentric anomaly, with ``E - e sin E = M`` to within ``2e-15 max(1, |M|)``.

    Raises
    ------
    DomainError
        If some e < 0 or e >= 1 (use :func:`solve_kepler_hyperbolic` or :func:`mean_to_true`).
    InvalidInputError
        NaN or infinite input.

    Notes
    -----
    Solves M = E - e sin E. Markley's (1995) cubic starter with one fifth-order correction;
    where ``1 - e cos E < 0.3`` (e -> 1, small M), Newton iterations on the residual
    ``(1 - e) E + e (E - sin E) - M`` with ``E - sin E`` from its series, so that E has full
    relative precision also there (Farnocchia et al. 2013).

    References: F. L. Markley, Celest. Mech. Dyn. Astron. 63, 101 (1995); D. Farnocchia,
    D. Bracali Cioci, A. Milani, Celest. Mech. Dyn. Astron. 116, 21 (2013); Vallado,
    Fundamentals of Astrodynamics and Applications, 4th ed., Algorithm 2.

    Examples
    --------
    >>> import visviva as vv
    >>> print(f"{vv.solve_kepler(0.5, 0.1):.12f}")
    0.552479986907
    """
    return _run(_ka.solve_kepler_array, "solve_kepler (elliptic, 0 <= e < 1)", M, "M", ecc)


def solve_kepler_hyperbolic(M, ecc):
    """Hyperbolic anomaly F from the hyperbolic mean anomaly M = e sinh F - F (e > 1).

    Parameters
    ----------
    M : float, array_like or Quantity (angle)
        Hyperbolic mean anomaly (rad if plain), any real value.
    ecc : float or array_like
        Eccentricity, e > 1.

    Returns
    -------
    F : ndarray, float or Quantity (rad)
        Hyperbolic anomaly (same sign as M).

    Raises
    ------
    DomainError
        If some e <= 1 (use :func:`solve_kepler`, or :func:`mean_to_true` for any e).

    Notes
    -----
    Newton iterations on ``(e - 1) F + e (sinh F - F) - M`` (series for ``sinh F - F`` when
    ``|F| < 2``) from an upper bound (the root of ``(e - 1) F + e F^3 / 6 = M``, improved by
    ``F <- asinh((M + F) / e)``), so they decrease monotonically; for F > 20 the equation
    ``F = log((M + F) / e) + log 2`` is solved instead (no overflow up to M ~ 1e308).
    Reference: Vallado (2013), Algorithm 4; Farnocchia et al. (2013).
    """
    return _run(_ka.solve_kepler_hyperbolic_array, "solve_kepler_hyperbolic (e > 1)", M, "M", ecc)


def solve_barker(M):
    """Parabolic anomaly D = tan(nu / 2) from the parabolic mean anomaly M = D + D^3 / 3.

    Parameters
    ----------
    M : float, array_like or Quantity (angle)
        Parabolic mean anomaly M = 2 sqrt(mu / p^3) t (rad if plain).

    Returns
    -------
    D : ndarray or float
        tan(nu / 2) (dimensionless; a plain array also for Quantity input).

    Notes
    -----
    Barker's equation, solved in closed form (Cardano, written without cancellation).
    Reference: Vallado (2013), Algorithm 3.
    """
    D = _run(_ka.parabolic_anomaly_array, "solve_barker (e = 1)", M, "M")
    return D.value if _units.is_quantity(D) else D


def mean_to_true(M, ecc):
    """True anomaly nu from the mean anomaly M, for every eccentricity e >= 0.

    Parameters
    ----------
    M : float, array_like or Quantity (angle)
        Mean anomaly in the convention of the regime (module docstring): elliptic
        ``E - e sin E`` (any real; revolutions kept), parabolic ``D + D^3 / 3``, hyperbolic
        ``e sinh F - F``.
    ecc : float or array_like
        Eccentricity, e >= 0 (exactly 1 is the parabola).

    Returns
    -------
    nu : ndarray, float or Quantity (rad)
        True anomaly; for e >= 1, |nu| < arccos(-1 / e).

    Notes
    -----
    Continuous through e = 1 at fixed time since periapsis: ``mean_to_true(n(e) t, e)`` tends to
    the parabolic value as e -> 1 from either side (n from the module docstring), and stays
    accurate in the near-parabolic band (see :func:`solve_kepler`).

    Examples
    --------
    >>> import visviva as vv
    >>> print(f"{vv.mean_to_true(0.0, 0.7):.1f}")
    0.0
    """
    return _run(_ka.mean_to_true_array, "mean_to_true", M, "M", ecc)


def true_to_mean(nu, ecc):
    """Mean anomaly M from the true anomaly nu, for every eccentricity e >= 0.

    Parameters
    ----------
    nu : float, array_like or Quantity (angle)
        True anomaly. For e < 1 any real (revolutions kept); for e >= 1 it must satisfy
        |nu| < arccos(-1 / e) (the asymptote), else :class:`InvalidElementsError`.
    ecc : float or array_like
        Eccentricity, e >= 0.

    Returns
    -------
    M : ndarray, float or Quantity (rad)
        Mean anomaly in the convention of the regime (module docstring).

    Notes
    -----
    E (or F, or D = tan(nu/2)) from nu, then ``M = (1 - e) E + e (E - sin E)`` (or
    ``(e - 1) F + e (sinh F - F)``, or ``D + D^3 / 3``) with the series of ``E - sin E`` and
    ``sinh F - F`` for small arguments, so M keeps full relative precision near e = 1.
    """
    return _run(_ka.true_to_mean_array, "true_to_mean", nu, "nu", ecc)


def eccentric_to_true(E, ecc):
    """True anomaly nu from the eccentric anomaly E of an ellipse.

    Parameters
    ----------
    E : float, array_like or Quantity (angle)
        Eccentric anomaly (rad if plain), any real value; whole revolutions are kept.
    ecc : float or array_like
        Eccentricity, 0 <= e < 1.

    Returns
    -------
    nu : ndarray, float or Quantity (rad)

    Notes
    -----
    tan(nu / 2) = sqrt((1 + e) / (1 - e)) tan(E / 2), evaluated as
    nu = 2 atan2(sqrt(1 + e) sin(E / 2), sqrt(1 - e) cos(E / 2)), exact at E = +-pi
    (Vallado 2013, Sec. 2.2).
    """
    return _run(_ka.true_from_eccentric_array, "eccentric_to_true (0 <= e < 1)", E, "E", ecc)


def true_to_eccentric(nu, ecc):
    """Eccentric anomaly E from the true anomaly nu of an ellipse.

    Parameters
    ----------
    nu : float, array_like or Quantity (angle)
        True anomaly (rad if plain), any real value; whole revolutions are kept.
    ecc : float or array_like
        Eccentricity, 0 <= e < 1.

    Returns
    -------
    E : ndarray, float or Quantity (rad)

    Notes
    -----
    tan(E / 2) = sqrt((1 - e) / (1 + e)) tan(nu / 2), evaluated with atan2 (Vallado 2013,
    Sec. 2.2).
    """
    return _run(_ka.eccentric_from_true_array, "true_to_eccentric (0 <= e < 1)", nu, "nu", ecc)


def hyperbolic_to_true(F, ecc):
    """True anomaly nu from the hyperbolic anomaly F of a hyperbola.

    Parameters
    ----------
    F : float, array_like or Quantity (angle)
        Hyperbolic anomaly (rad if plain).
    ecc : float or array_like
        Eccentricity, e > 1.

    Returns
    -------
    nu : ndarray, float or Quantity (rad)
        |nu| < arccos(-1 / e).

    Notes
    -----
    tan(nu / 2) = sqrt((e + 1) / (e - 1)) tanh(F / 2) (Vallado 2013, Sec. 2.2).
    """
    return _run(_ka.true_from_hyperbolic_array, "hyperbolic_to_true (e > 1)", F, "F", ecc)


def true_to_hyperbolic(nu, ecc):
    """Hyperbolic anomaly F from the true anomaly nu of a hyperbola.

    Parameters
    ----------
    nu : float, array_like or Quantity (angle)
        True anomaly (rad if plain), |nu| < arccos(-1 / e).
    ecc : float or array_like
        Eccentricity, e > 1.

    Returns
    -------
    F : ndarray, float or Quantity (rad)

    Raises
    ------
    InvalidElementsError
        For |nu| >= arccos(-1 / e) (on or beyond the asymptote).

    Notes
    -----
    tanh(F / 2) = sqrt((e - 1) / (e + 1)) tan(nu / 2) (Vallado 2013, Sec. 2.2).
    """
    return _run(_ka.hyperbolic_from_true_array, "true_to_hyperbolic (e > 1)", nu, "nu", ecc)


def parabolic_to_true(D):
    """True anomaly nu = 2 arctan(D) from the parabolic anomaly D = tan(nu / 2).

    Parameters
    ----------
    D : float or array_like
        Parabolic anomaly (dimensionless).

    Returns
    -------
    nu : ndarray or float
        True anomaly (rad), |nu| < pi.
    """
    D = _units.to_array(D, "dimensionless", "D", finite=False)
    return _run(_ka.true_from_parabolic_array, "parabolic_to_true", D, "D")


def true_to_parabolic(nu):
    """Parabolic anomaly D = tan(nu / 2) from the true anomaly nu of a parabola.

    Parameters
    ----------
    nu : float, array_like or Quantity (angle)
        True anomaly (rad if plain), |nu| < pi.

    Returns
    -------
    D : ndarray or float
        Dimensionless (a plain array also for Quantity input).
    """
    D = _run(_ka.parabolic_from_true_array, "true_to_parabolic (e = 1)", nu, "nu")
    return D.value if _units.is_quantity(D) else D


def eccentric_to_mean(E, ecc):
    """Mean anomaly M = E - e sin E from the eccentric anomaly E (Kepler's equation).

    Parameters
    ----------
    E : float, array_like or Quantity (angle)
        Eccentric anomaly (rad if plain), any real value.
    ecc : float or array_like
        Eccentricity, 0 <= e < 1.

    Returns
    -------
    M : ndarray, float or Quantity (rad)

    Notes
    -----
    Evaluated as (1 - e) E + e (E - sin E) with the series of E - sin E for e > 0.5 and
    |E| < 2, so M has full relative precision near e = 1 (Farnocchia et al. 2013).
    """
    return _run(_ka.mean_from_eccentric_array, "eccentric_to_mean (0 <= e < 1)", E, "E", ecc)


def hyperbolic_to_mean(F, ecc):
    """Hyperbolic mean anomaly M = e sinh F - F from the hyperbolic anomaly F.

    Parameters
    ----------
    F : float, array_like or Quantity (angle)
        Hyperbolic anomaly (rad if plain).
    ecc : float or array_like
        Eccentricity, e > 1.

    Returns
    -------
    M : ndarray, float or Quantity (rad)

    Notes
    -----
    Evaluated as (e - 1) F + e (sinh F - F) with the series of sinh F - F for e < 2 and |F| < 2
    (Farnocchia et al. 2013).
    """
    return _run(_ka.mean_from_hyperbolic_array, "hyperbolic_to_mean (e > 1)", F, "F", ecc)
