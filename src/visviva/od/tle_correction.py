"""The differential correction of :func:`visviva.od.tle_fit.fit_tle`, and the states it leaves out.

:func:`correct` is the Levenberg-Marquardt iteration on SGP4 mean elements with forward-
difference partials of SGP4 itself (Vallado & Crawford 2008, AIAA 2008-6770).
:func:`robust_correct` runs it again without the few states a converged fit misses by far more
than the rest (:func:`far_states`), and keeps them out while they stay far.

SGP4 is not continuous in time or in its elements: SDP4 applies its lunisolar periodics to the
inclination, node and perigee directly while the perturbed inclination is at least 0.2 rad and
in Lyddane's form below it (Hoots & Roehrich 1980, Spacetrack Report 3; the "Lyddane choice" of
Vallado et al. 2006, AIAA 2006-6753), and the two forms differ by the periodics' second-order
terms. The SGP4-VER set 20413 (e = 0.786, i = 12.35 deg, a 5.8-day orbit) crosses 0.2 rad
between minutes 1843 and 1844 after its epoch, near apogee, and its position jumps 1,655 km
there. An element set that crosses elsewhere misses every state between the two crossings by
about that jump; moving its crossing moves the misfit of a whole state at once, which no
finite-difference partial sees, so the correction settled 351 km RMS off with two states
1,500 km off, inside the 1 %-of-the-radius check (audit33). Refitted without them, it recovers
the set to 1e-8 km and both states with it.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

__all__ = ["correct", "far_states", "robust_correct", "staged_correct", "warn_far_states"]

#: the smallest change of the states (km) a finite-difference step of B* must make, and the
#: largest step it may take (1/earth radii) to make it: below, B* is not seen (held)
BSTAR_EFFECT_KM = 1e-6
BSTAR_STEP_MAX = 1e-2

#: a column of the normal matrix under this fraction of the largest is an element the states
#: do not see (held for that iteration)
DEAD_COLUMN = 1e-24

#: a fit with no downhill step left ends converged when Gauss-Newton's step promised to lower
#: the sum of squares by less than this fraction of it (else ConvergenceError)
STALLED_GAIN = 1e-3

#: a state whose position residual exceeds FAR_FACTOR times the median one and FAR_KM is far:
#: left out and refitted when they are at most FAR_SHARE of the states
FAR_FACTOR = 10.0
FAR_KM = 1.0
FAR_SHARE = 0.2
#: refits without the far states at most this many times
FAR_ROUNDS = 3

#: relative finite-difference steps of the element vector (n, 4 equinoctial, mean longitude, B*).
#: Those of the six elements were 10 times larger: over 2 days of the 24-hour resonant SGP4-VER
#: set 14128 the columns they gave missed SDP4's resonance terms' curvature and the fit crept
#: 1 cm off for 400 iterations (ConvergenceError); with these it takes 4 (tlefit2)
_STEPS = np.array([1e-10, 1e-8, 1e-8, 1e-8, 1e-8, 1e-8, 1e-6])

#: the first window of :func:`staged_correct` (s either side of the epoch), doubled per stage
FIRST_WINDOW_S = 43200.0


class Correction:
    """Where :func:`correct` ended: elements ``p``, residuals ``z``, their ``cost`` (the
    weighted sum of squares), per-iteration ``history``, ``converged`` / ``stalled`` (no step
    lowered the misfit while the linear model promised ``gain`` of it), the last Jacobian
    ``J`` and its ``live`` columns (those the states see)."""

    def __init__(self, **kw):
        self.__dict__.update(kw)


def _rms(z, n):
    return float(np.sqrt(np.mean(np.sum(z.reshape(n, 6)[:, :3] ** 2, axis=1))))


def _column(resid, p, z, j):
    """Forward-difference column j of the Jacobian of ``resid`` at p (zeros if SGP4 fails on
    both sides) and the step taken."""
    h = _STEPS[j] * (max(abs(p[j]), 1e-3) if j in (0, 6) else 1.0)
    while True:
        pp = p.copy()
        pp[j] += h
        zp = resid(pp)
        if zp is None:  # e.g. e < 0 or i > pi on this side: step the other way
            pp[j] -= 2 * h
            zp = resid(pp)
            h = -h
        # B* of a high orbit moves the states by less than SGP4's rounding over the step: its
        # column was noise, which the fit followed (a deep-space B* of 0 came back -6e-4
        # after 48 creeping iterations; audit31). Widen the step until it moves them by
        # BSTAR_EFFECT_KM (drag is about linear in B*)
        if (j != 6 or zp is None or abs(h) >= BSTAR_STEP_MAX
                or np.max(np.abs(zp - z)) >= BSTAR_EFFECT_KM):
            break
        h = 100.0 * abs(h)
    return 0.0 if zp is None else (zp - z) / h


def correct(p, z, resid, free, n, max_iterations, tol):
    """Levenberg-Marquardt on the element vector ``p`` (residuals ``z = resid(p)``, None where
    SGP4 fails) over the ``free`` elements of ``n`` states; a :class:`Correction`."""
    cost = float(z @ z)
    lam = 1e-3
    history = []
    converged = stalled = False
    gain = 0.0
    for it in range(1, max_iterations + 1):
        J = np.empty((z.size, free.size))
        for c, j in enumerate(free):
            J[:, c] = _column(resid, p, z, j)
        g = J.T @ z
        N = J.T @ J
        d = np.diag(N)
        # an element the states do not see at all (B* of a high orbit over a short arc: its
        # column is zero to rounding) stays where it is; the solve with it was singular at
        # every damping, which ended the fit at its first guess as if converged (audit31)
        live = d > DEAD_COLUMN * max(float(d.max()), 1e-300)
        Nl, gl = N[np.ix_(live, live)], g[live]
        try:
            gain = float(-gl @ np.linalg.lstsq(Nl, -gl, rcond=None)[0])  # Gauss-Newton's promise
        except np.linalg.LinAlgError:
            gain = math.inf
        improved = False
        while lam < 1e12:
            dp = np.zeros(free.size)
            try:
                dp[live] = np.linalg.solve(Nl + lam * np.diag(d[live]), -gl)
            except np.linalg.LinAlgError:
                lam *= 10
                continue
            trial = p.copy()
            trial[free] += dp
            zt = resid(trial)
            if zt is not None and float(zt @ zt) <= cost:
                improved = True
                break
            lam *= 10
        rms_pos = _rms(z, n)
        history.append({"iteration": it, "rms_position_km": rms_pos, "damping": lam})
        if not improved:
            # no downhill step left: the minimum to rounding, unless the linear model still
            # promises a real drop (a Jacobian the step cannot follow: not a converged fit)
            converged = gain <= STALLED_GAIN * cost or rms_pos < 1e-7
            stalled = not converged
            break
        new_cost = float(zt @ zt)
        rel = (cost - new_cost) / max(cost, 1e-300)
        p, z, cost = trial, zt, new_cost
        lam = max(lam / 10, 1e-9)
        if rel < tol or _rms(z, n) < 1e-7:
            converged = True
            break
    return Correction(p=p, z=z, cost=cost, history=history, converged=converged,
                      stalled=stalled, gain=gain, J=J, live=live)


def _joined(first, then):
    """Two corrections' histories as one, numbered on."""
    return first + [{**h, "iteration": len(first) + h["iteration"]} for h in then]


def far_states(z, n):
    """Indices of the states whose position residual (of the residual vector ``z`` of ``n``
    states) exceeds ``FAR_FACTOR`` times the median one and ``FAR_KM``."""
    miss = np.linalg.norm(z.reshape(n, 6)[:, :3], axis=1)
    limit = max(FAR_FACTOR * float(np.median(miss)), FAR_KM)
    return np.flatnonzero(miss > limit)


def robust_correct(p, z, resid, free, n, need, max_iterations, tol):
    """:func:`correct`, then again without the far states (:func:`far_states`) while they are
    at most ``FAR_SHARE`` of the ``n`` and leave ``need``, kept when it fits the others better;
    when every state fits that set, once more with them all.

    Returns
    -------
    Correction
        The fit kept; its ``z`` holds the residuals of every state.
    left_out : ndarray of int
        The states it was fitted without (each still far).
    far : ndarray of int
        The far states of the fit kept (none when they are more than ``FAR_SHARE``: not a few
        states but the model, which the fit's RMS check judges).
    """
    fit = correct(p, z, resid, free, n, max_iterations, tol)
    out = np.array([], dtype=int)
    for _ in range(FAR_ROUNDS):
        far = far_states(fit.z, n)
        if far.size == 0 or np.array_equal(far, out) or far.size > FAR_SHARE * n or (
                n - far.size < need):
            break
        keep = np.ones((n, 6))
        keep[far] = 0.0
        keep = keep.ravel()

        def kept(pp, keep=keep):
            zz = resid(pp)
            return None if zz is None else zz * keep

        again = correct(fit.p, fit.z * keep, kept, free, n, max_iterations, tol)
        z_all = resid(again.p)
        if z_all is None or again.cost >= float((fit.z * keep) @ (fit.z * keep)):
            break
        again.history = _joined(fit.history, again.history)
        again.z = z_all
        fit, out = again, far
    if out.size and far_states(fit.z, n).size == 0:  # they fit it too: polish on them all
        polished = correct(fit.p, fit.z, resid, free, n, max_iterations, tol)
        polished.history = _joined(fit.history, polished.history)
        fit, out = polished, out[:0]
    far = far_states(fit.z, n)
    if far.size > FAR_SHARE * n:
        far = far[:0]
    return fit, np.intersect1d(out, far), far


def staged_correct(p, z, resid, free, n, need, max_iterations, tol, from_epoch_s, bad):
    """:func:`robust_correct`, and when its fit is ``bad`` (a predicate on the Correction) again
    from the elements fitted to the states within ``FIRST_WINDOW_S`` of the epoch, the window
    doubled until it holds them all; the better of the two fits (by its sum of squares).

    Over a long arc of a high-eccentricity deep-space orbit the osculating first guess is too
    far off in mean motion for the correction: 2 days of the SGP4-VER sets 11801, 28623 and
    16925 (e = 0.56-0.73) ended 15-315 km off while half a day of each comes back to 1e-10 km;
    each wider window starts within reach of its minimum (tlefit2).

    Returns
    -------
    The three values of :func:`robust_correct`.
    """
    first = robust_correct(p, z, resid, free, n, need, max_iterations, tol)
    if not bad(first[0]):
        return first
    span = float(np.max(np.abs(from_epoch_s)))
    window = FIRST_WINDOW_S
    q, staged = p, first[0].history
    while window < span:
        keep = np.repeat(np.abs(from_epoch_s) <= window, 6).astype(float)
        if keep.sum() < 6 * need:
            window *= 2.0
            continue

        def kept(pp, keep=keep):
            zz = resid(pp)
            return None if zz is None else zz * keep

        zq = kept(q)
        if zq is None:
            break
        stage = correct(q, zq, kept, free, n, max_iterations, tol)
        q, staged = stage.p, _joined(staged, stage.history)
        window *= 2.0
    zq = resid(q)
    if zq is None or q is p:
        return first
    second = robust_correct(q, zq, resid, free, n, need, max_iterations, tol)
    second[0].history = _joined(staged, second[0].history)
    return second if second[0].cost < first[0].cost else first


def warn_far_states(z, n, far, left_out, minutes, stacklevel=4):
    """RuntimeWarning naming the far states of a fit (indices ``far``, of which ``left_out``
    were left out of it; ``minutes`` after the first state) and what to do about them."""
    miss = np.linalg.norm(z.reshape(n, 6)[:, :3], axis=1)
    order = far[np.argsort(-miss[far])][:5]
    worst = ", ".join(f"state {i} (minute {minutes[i]:.6g}, {miss[i]:.4g} km)" for i in order)
    more = f" and {far.size - order.size} more" if far.size > order.size else ""
    rest = np.delete(miss, far)
    how = ("Left out of the fit (fit.excluded; fit.rms_position_km counts them)"
           if left_out.size == far.size else
           f"{left_out.size} of them left out of the fit (fit.excluded)" if left_out.size
           else "Kept in the fit (a refit without them fitted the others no better)")
    warnings.warn(
        f"{far.size} of the {n} states {'is' if far.size == 1 else 'are'} far off the fitted "
        "SGP4 element set, which fits the "
        f"others to {float(np.sqrt(np.mean(rest**2))):.4g} km RMS (median "
        f"{float(np.median(rest)):.4g} km): {worst}{more}. {how}. SGP4 itself jumps where a "
        "deep-space orbit's perturbed inclination crosses 0.2 rad (its lunisolar periodics in "
        "Lyddane's form below it), and a manoeuvre or a bad state jumps too: drop those "
        "states, or split the arc there.", RuntimeWarning, stacklevel=stacklevel)
