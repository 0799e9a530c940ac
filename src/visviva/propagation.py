"""Two-body (Kepler) propagation of state vectors with universal variables.

:func:`propagate_kepler` is the public function; it calls ``StateVectors.propagate(dt)``, which
hands its canonical arrays to :func:`propagate_canonical`: that checks units and shapes,
broadcasts the states against the times once, makes ONE call of the compiled kernel
:func:`visviva.core.universal.propagate_many` over the flattened items and raises through
:func:`visviva.errors.raise_for_status`. This module imports no container (the two-body layer
imports downward only: states -> propagation).
"""

from __future__ import annotations

import math

import numpy as np

from . import _units
from .errors import InvalidInputError, ShapeError, raise_for_result

__all__ = ["propagate_kepler", "propagate_canonical"]


def propagate_kepler(state, dt):
    """States after two-body (Kepler) motion for a time ``dt``, on every conic.

    Parameters
    ----------
    state : StateVectors
        Initial states, leading shape ``S`` (``()`` for one state), each with its central body's
        GM.
    dt : Quantity
        Time of flight (unit of time, e.g. ``u.s``, ``u.day``); negative values propagate
        backwards and ``0`` returns the input exactly. Plain numbers are refused: the unit is
        required. ``dt`` broadcasts against ``S`` with numpy's rules: for ``N`` states
        (``S = (N,)``) a ``dt`` of shape ``(N,)`` gives one time per state, ``(T, 1)`` gives every
        state at every time (result shape ``(T, N)``), and a scalar moves them all by the same
        time.

    Returns
    -------
    StateVectors
        Shape ``np.broadcast_shapes(S, dt.shape)``. Same GM; the epoch, when set, advances by
        ``dt`` counted in TT seconds and stays in its own scale (``(epoch.tt + dt).tdb`` for a
        TDB epoch: the offset ``t.tt - epoch.tt`` that ``propagate_cowell`` and the batches
        use; ``epoch + dt`` for utc, tai and tt epochs), broadcast to the result's shape when
        either is an array.

    Raises
    ------
    UnitsError
        ``dt`` without a unit of time.
    ShapeError
        ``dt`` does not broadcast against the states' shape.
    InvalidInputError
        NaN or infinite ``dt``; ``state`` is not a ``StateVectors``.
    InvalidStateError
        A radial orbit (``r x v = 0``) would reach the attractor (``r = 0``) within ``dt``.
    ConvergenceError
        The bounded iteration failed (never observed; report the quoted inputs).

    Notes
    -----
    Universal variables (Danby 1992 sec. 6.9; Vallado 2013 Algorithm 8; Battin 1999 ch. 4): with
    ``beta = 2 mu / r0 - v0^2`` and the Stumpff-Danby functions ``G_k(beta, s)`` the universal
    Kepler equation ``dt = r0 G1 + (r0 . v0) G2 + mu G3`` is solved for ``s`` by safeguarded
    Laguerre-Conway iteration, and Lagrange's coefficients give
    ``r = f r0 + g v0``, ``v = fdot r0 + gdot v0``. Elliptic ``dt`` is reduced modulo the period
    first (exact ``fmod``), so the error is the problem's own conditioning: the period carries
    the rounding of ``r0`` and ``v0``, and the position is off by ~ eps n |dt| relative (60-digit
    checks: 1.3e-12 after 1.7e3 LEO revolutions, 4e-9 after 5.7e6; GTO and e = 0.99 alike).
    Beyond ~1e13 revolutions the phase is rounding noise and the returned point, on the right
    conic, is anywhere along it: a :class:`~visviva.errors.PhaseRoundingWarning` is issued when
    eps n |dt| exceeds 1e-3 rad (~7e11 revolutions; measured 5.8 km off in LEO after 1e12).
    The first call compiles the kernel (or loads it from numba's
    cache).

    Examples
    --------
    >>> import visviva as vv
    >>> from astropy import units as u
    >>> s = vv.StateVectors([7000.0, 0, 0] * u.km, [0, 7.5, 0] * u.km / u.s, vv.EARTH)
    >>> later = propagate_kepler(s, [0, 10, 20] * u.min)
    >>> later.shape
    (3,)
    """
    propagate = getattr(state, "propagate", None)
    if not callable(propagate) or not hasattr(state, "to_elements"):
        raise InvalidInputError(
            f"state must be a visviva.StateVectors, got {type(state).__name__}. Build one with "
            "vv.StateVectors(r, v, gm) from Quantities r (km) and v (km/s)."
        )
    return propagate(dt)


def propagate_canonical(r_km, v_km_s, gm_km3_s2, state_shape: tuple, dt):
    """Two-body propagation of canonical arrays: the work behind :func:`propagate_kepler`.

    Parameters
    ----------
    r_km, v_km_s : ndarray, shape ``state_shape + (3,)``
        Positions (km) and velocities (km/s).
    gm_km3_s2 : ndarray
        Gravitational parameters (km3/s2), scalar or of shape ``state_shape``.
    state_shape : tuple
        Leading shape of the states.
    dt : Quantity
        Times of flight (unit of time), broadcasting against ``state_shape``.

    Returns
    -------
    r_out, v_out : ndarray, shape ``shape + (3,)``
        Propagated positions (km) and velocities (km/s).
    gm_out : ndarray
        ``gm_km3_s2`` as given when scalar, else broadcast to ``shape``.
    dt_s : ndarray
        The times of flight in seconds, as given (not broadcast).
    shape : tuple
        ``np.broadcast_shapes(state_shape, dt.shape)``.

    Raises
    ------
    UnitsError, ShapeError, InvalidInputError, InvalidStateError, ConvergenceError, DomainError
        As listed for :func:`propagate_kepler`.
    """
    from .core import tier
    from .core.universal import propagate_many

    dt_s = _units.to_array(dt, "time", "dt")
    try:
        shape = np.broadcast_shapes(state_shape, dt_s.shape)
    except ValueError:
        raise ShapeError(
            f"dt of shape {dt_s.shape} does not broadcast against the states' shape "
            f"{state_shape}. For every state at every time give dt the shape (T, 1) with N "
            "states of shape (N,); for one time per state give dt the states' shape."
        ) from None

    n = int(np.prod(shape, dtype=np.int64))
    r0 = np.ascontiguousarray(np.broadcast_to(r_km, shape + (3,))).reshape(n, 3)
    v0 = np.ascontiguousarray(np.broadcast_to(v_km_s, shape + (3,))).reshape(n, 3)
    gm = np.ascontiguousarray(np.broadcast_to(gm_km3_s2, shape)).reshape(n)
    dt_flat = np.ascontiguousarray(np.broadcast_to(dt_s, shape)).reshape(n)
    r_out = np.empty((n, 3))
    v_out = np.empty((n, 3))
    status = np.empty(n, dtype=np.int64)
    tier.call(propagate_many, r0, v0, gm, dt_flat, r_out, v_out, status,
              small=n <= tier.SMALL_ITEMS)
    _explain_extreme_magnitudes(status, r0, v0, gm, dt_flat, shape)
    r_out = r_out.reshape(shape + (3,))
    v_out = v_out.reshape(shape + (3,))
    inputs = {
        "r_km": r0.reshape(shape + (3,)),
        "v_km_s": v0.reshape(shape + (3,)),
        "dt_s": dt_flat.reshape(shape),
    }
    raise_for_result("Kepler propagation", status, [r_out, v_out], shape, inputs)
    _warn_phase_rounding(r0, v0, gm, dt_flat, shape)
    gm_out = gm_km3_s2 if np.ndim(gm_km3_s2) == 0 else gm.reshape(shape)
    return r_out, v_out, gm_out, dt_s, shape


#: eps n |dt| (rad) beyond which the phase's rounding is worth a warning (~7e11 revolutions)
PHASE_ROUNDING_LIMIT_RAD = 1e-3
_EPS = float(np.finfo(np.float64).eps)


def _warn_phase_rounding(r0, v0, gm, dt_s, shape) -> None:
    """Warn when rounding alone moves an elliptic orbit's body by > 1e-3 rad of phase.

    With x = r/a = 2 - r v^2/mu > 0 and n = sqrt(mu/r^3) x^1.5, the estimated along-track
    error is eps n |dt| a (measured against 60 digits: 5.8 km after 1e12 LEO revolutions,
    the estimate 10 km). Hyperbolic and parabolic items (x <= 0) are exempt: their
    position error stays ~eps relative however long dt. One numpy pass over the items.
    """
    if dt_s.size == 0:
        return
    with np.errstate(all="ignore"):
        r2 = np.einsum("ij,ij->i", r0, r0)
        r2_min = float(np.min(r2))
        if r2_min > 0.0:  # fast exit: any ellipse has n <= sqrt(8 mu / r^3) (beta <= 2 mu / r)
            n_bound = math.sqrt(8.0 * float(np.max(gm))) / r2_min**0.75
            if not _EPS * float(np.max(np.abs(dt_s))) * n_bound > PHASE_ROUNDING_LIMIT_RAD:
                return
            rn = np.sqrt(r2)
        else:  # |r|^2 underflows (tiny units): hypot does not
            rn = np.hypot(np.hypot(r0[:, 0], r0[:, 1]), r0[:, 2])
        vn = np.hypot(np.hypot(v0[:, 0], v0[:, 1]), v0[:, 2])
        x = 2.0 - (rn / gm) * vn * vn  # r / a, dimensionless: > 0 for an ellipse
        n = np.sqrt(gm / rn) / rn * x * np.sqrt(x)  # sqrt(mu / a^3), scaled to avoid underflow
        phase_err = _EPS * np.abs(dt_s) * n  # eps n |dt|
        bad = (x > 0) & (phase_err > PHASE_ROUNDING_LIMIT_RAD)
    if not bad.any():
        return
    import warnings

    from .errors import PhaseRoundingWarning

    i = int(np.flatnonzero(bad)[0])
    where = tuple(int(j) for j in np.unravel_index(i, shape)) if shape else ()
    a = float(rn[i] / x[i])
    revs = float(np.abs(dt_s[i]) * n[i]) / (2.0 * np.pi)
    count = int(np.count_nonzero(bad))
    more = f" ({count} items in all)" if count > 1 else ""
    warnings.warn(
        f"Kepler propagation{' at index ' + str(where) if where else ''}: dt = {dt_s[i]:.6g} s "
        f"is {revs:.3g} revolutions{more}; float64 rounding of dt and of the period alone "
        f"moves the body ~{phase_err[i]:.2g} rad along its orbit (~{phase_err[i] * a:.3g} km "
        f"with a = {a:.6g} km), growing linearly with dt. The result is on the right conic but "
        "its phase is that uncertain; propagate a shorter span (e.g. from a nearer epoch).",
        PhaseRoundingWarning, stacklevel=4,
    )


def _explain_extreme_magnitudes(status, r0, v0, gm, dt_s, shape) -> None:
    """A DomainError naming the magnitudes when the solver failed even in rescaled units.

    The kernel retries a failed item in units where |r0| and the larger of |v0| and the
    circular speed are ~1 (exact powers of two); a failure after that (or a position whose
    squared length underflows) means the problem does not fit float64 at all.
    """
    from .core.status import HITS_ATTRACTOR, NO_CONVERGENCE, ZERO_POSITION
    from .errors import DomainError

    bad = (status == NO_CONVERGENCE) | (status == ZERO_POSITION)
    hit = status == HITS_ATTRACTOR
    if hit.any():
        # a "collision" of a state that is not radial comes from |r x v| overflowing
        with np.errstate(all="ignore"):
            r_hat = r0 / np.max(np.abs(r0), axis=-1, keepdims=True)
            v_hat = v0 / np.maximum(np.max(np.abs(v0), axis=-1, keepdims=True), 1e-300)
            h_hat = np.linalg.norm(np.cross(r_hat, v_hat), axis=-1)
            scale = np.linalg.norm(r_hat, axis=-1) * np.linalg.norm(v_hat, axis=-1)
            # radial to float64 means p = |r x v|^2 / gm below the rounding of |r| (as in
            # core.elements); p / |r| = |r| |v|^2 sin^2(angle) / gm, taken in logarithms
            rm_all = np.max(np.abs(r0), axis=-1)
            vm_all = np.max(np.abs(v0), axis=-1)
            log_p_over_r = (np.log(rm_all) + 2 * np.log(vm_all)
                            + 2 * np.log(h_hat / scale) - np.log(gm))
        not_radial = (h_hat > 1e-12 * scale) & (log_p_over_r > np.log(16 * np.finfo(float).eps))
        bad |= hit & not_radial
    if not bad.any():
        return
    i = int(np.flatnonzero(bad)[0])
    where = tuple(int(j) for j in np.unravel_index(i, shape)) if shape else ()
    rm = float(np.max(np.abs(r0[i])))
    vm = float(np.max(np.abs(v0[i])))
    raise DomainError(
        f"Kepler propagation at index {where}: the magnitudes are out of float64's range for "
        f"two-body propagation (|r0| ~ {rm:.3g} km, |v0| ~ {vm:.3g} km/s, gm = {gm[i]:.3g} "
        f"km3/s2, dt = {dt_s[i]:.3g} s): even in rescaled units the speed ratio "
        "|v0| / sqrt(gm / |r0|) or the flight time in dynamical units exceeds ~1e150. "
        "To fix: check the units of r, v, gm and dt; choose values whose ratios are physical."
    )
