"""The extended Kalman filter's forward pass, in square-root covariance form.

:func:`visviva.filter_orbit` (``method="ekf"``) walks the observation epochs with the state and
a square root L of its covariance (P = L L^T): between epochs it integrates the state and its
transition Phi with the fit's dynamics (through known burns, with estimated coefficients) and
predicts L from the prediction's transition and noise, at each epoch it updates (x, L) with the
rows kept by the editing, both by orthogonal triangularisation
(:mod:`visviva.od.square_root`), so that every covariance it reports is symmetric positive
semi-definite by construction, also when nanometre measurements meet a kilometre prior. The
prediction's noise N (process noise, the execution errors of burns, the coefficients'
Gauss-Markov noise) is that of the covariance prediction started from zero: the prediction is
affine in P, P- = Phi P Phi^T + N. Where the arc has a gap of days
(:data:`UNSCENTED_GAP_S`), the gaps between passes are predicted by sigma points instead
(:func:`unscented_gap`; with ``estimate=`` the points carry the coefficients too, each flying
its own, Gauss-Markov decay and noise included), Phi being then the prediction's statistical
linearisation, and an epoch whose measurements bend across the predicted covariance
(:data:`NONLINEAR_SHIFT`) is updated by the sigma points as well
(:func:`visviva.od.unscented.sigma_point_update`) instead of warning.
"""

from __future__ import annotations

import copy

import numpy as np

from ..errors import VisvivaError
from ..satellites.covariance import noise_substeps
from .coefficient_prediction import predict_coefficients, predict_covariance
from .light_time import model
from .measurements import residuals
from .square_root import covariance, noise_factor, predict_factor, psd_factor, update_factor

__all__ = ["ekf_pass", "initial_impulses", "curvature_shift", "unscented_gap", "NONLINEAR_SHIFT",
           "CURVATURE_GAP_S", "UNSCENTED_GAP_S"]

#: the extended filter warns (after a gap of days: updates by sigma points instead) when,
#: across its predicted covariance, the curvature of a measurement shifts the measurement's
#: mean by more than this many of its sigmas (what the linearised update leaves out; audit44:
#: range rates from a 10 km, 100 m/s prior, a shift of 19 sigmas at the first epoch, ended
#: 24 km off for a formal 0.8 km, silently; the docs' campaign from 3 km and 3 m/s shifts 1.7)
NONLINEAR_SHIFT = 3.0
#: ... checked at the first epoch and after each gap longer than this (s), where the predicted
#: covariance has grown (within a pass it shrinks; 2.5 ms per check doubled the filter's time
#: when made at every epoch)
CURVATURE_GAP_S = 300.0
#: when two epochs are more than this apart (s), the extended filter predicts the mean and
#: covariance over every gap longer than CURVATURE_GAP_S by the unscented transform instead
#: of the STM: across days the flow is nonlinear across the covariance (two 3-hour arcs 3
#: days apart from 100 m and 10 cm/s: its second-order term put the error 16 sigmas out along
#: the covariance's thinnest direction, NEES 7.5 -> 281 over the gap), and the semi-major
#: axis the second arc then fixes makes the smoother's linear maps across the first arc's
#: gaps between passes fail as well. With ``estimate=`` too (odgap: drag estimated across
#: those 3 days from a 422 km orbit, the STM's (x, B) NEES 1.3e4 to 9.6e5 or a divergence,
#: the sigma points' 8.1, the UKF's). In this mode an epoch that fails the curvature check is
#: updated by the sigma points instead of warning (Gauss-Markov drag left 9 km along track
#: after the gap: (x, B) NEES 262 -> 11.6 there). Tracking without such a gap keeps the STM's
#: prediction and the linearised update (and its results, bit for bit).
UNSCENTED_GAP_S = 6 * 3600.0


def curvature_shift(observations, x, L, rows, gm):
    """The largest shift of the mean of the measurements ``rows`` (in their sigmas) that their
    curvature causes across the covariance L L^T of the state ``x`` (the first 6 of n):
    0.5 tr(Hess h P), from the points x +- sqrt(n) L_j (the unscented transform's); 0 where
    the model cannot be evaluated."""
    n = L.shape[1]
    cols = np.sqrt(n) * L[:6].T  # (n, 6)
    pts = np.concatenate([x[None, :6] + cols, x[None, :6] - cols])  # (2n, 6)
    m = rows.size
    try:
        with np.errstate(all="ignore"):
            h0, _ = model(observations, np.repeat(x[None, :6], m, axis=0), gm, rows,
                          partials=False)
            h, _ = model(observations, np.repeat(pts, m, axis=0), gm, np.tile(rows, 2 * n),
                         partials=False)
            kinds = observations.kinds[np.tile(rows, 2 * n)]
            d = residuals(kinds, h, np.tile(h0, (2 * n, 1))).reshape(2, n, m, 3)
            shift = 0.5 * (d[0] + d[1]).sum(axis=0) / n  # (m, 3)
            used = np.arange(3)[None, :] < observations.dims[rows][:, None]
            ratio = np.where(used, np.abs(shift) / observations.sigmas[rows][:, None], 0.0)
    except VisvivaError:
        return 0.0
    return float(np.nanmax(ratio)) if np.isfinite(ratio).any() else 0.0


def _propagate(dyn, x, t_from, t_to):
    """States and STMs Phi(t, t_from) at the points of a grid ``t_to`` (s from the epoch)."""
    if t_from == 0.0:
        return dyn.propagate(x, t_to)
    return dyn.at_origin(t_from).propagate(x, np.asarray(t_to) - t_from)


def _predict(dyn, schedule, x, P, t_from, grid, q, code, apply_at_start=False):
    """The state, covariance and Phi(t_from + grid[-1], t_from) predicted from (x, P) at
    ``t_from`` (s from the epoch) over the sub-steps ``grid`` (s from t_from), through the
    burns of ``schedule`` (:func:`visviva.satellites.burn_partials.propagate_through`)."""
    if not schedule:
        y, phi = _propagate(dyn, x, t_from, t_from + grid)
        return y[-1].copy(), predict_covariance(x, grid, y, phi, P, q, code), phi[-1]
    t_end = t_from + float(grid[-1])
    if not any(t_from < edge <= t_end or (apply_at_start and edge == t_from)
               for a, b, _ in schedule.items for edge in (a, b)):
        # no burn starts or ends here: one segment (a finite burn's thrust on over it, drag
        # and SRP scaled to the mass), as the walk would integrate it
        shifted = copy.copy(dyn)
        shifted.model = schedule.segment_model(dyn.model, t_from, t_end)
        y, phi = shifted.propagate(x, grid)
        return y[-1].copy(), predict_covariance(x, grid, y, phi, P, q, code), phi[-1]
    from ..satellites.burn_partials import propagate_through
    from ..satellites.covariance import burn_noise

    y, phi, sens = propagate_through(dyn, schedule, x, t_from + grid, start=t_from,
                                     apply_at_start=apply_at_start)
    if grid.size == 1 and grid[0] == 0.0:  # impulses at the epoch itself
        jumps = burn_noise(schedule, grid + t_from, sens, t_from, apply_at_start)
        return y[-1].copy(), phi[-1] @ P @ phi[-1].T + sum(jumps.values(), 0.0 * P), phi[-1]
    sens = np.concatenate([np.zeros((1,) + sens.shape[1:]), sens])
    jumps = burn_noise(schedule, t_from + np.r_[0.0, grid], sens, t_from, apply_at_start)
    return y[-1].copy(), predict_covariance(x, grid, y, phi, P, q, code, jumps), phi[-1]


def initial_impulses(dyn, schedule, x, P, q, code):
    """The state and covariance just after the impulses of ``schedule`` at the epoch (the
    initial state is before them)."""
    x, N, phi = _predict(dyn, schedule, x, np.zeros_like(P), 0.0, np.zeros(1), q, code,
                         apply_at_start=True)  # fmt: skip
    return x, covariance(predict_factor(psd_factor(P), phi, noise_factor(N)))


def ekf_pass(dyn, schedule, observations, x, P, epochs, screen, q, code, step_s, est=(),
             gauss=None):
    """The extended Kalman filter forward over ``epochs`` (through the burns of ``schedule``):
    filtered and predicted states and covariances, the STMs Phi(t_k, t_k-1), and the filtered
    and predicted square roots and the predictions' noise square roots (None: none) that the
    smoother takes;
    with ``est`` the state carries those coefficients too (6 + k), with ``gauss``
    (:class:`visviva.od.gauss_markov.GaussMarkov`) as Gauss-Markov processes. With a gap of
    over :data:`UNSCENTED_GAP_S` the gaps between passes are flown by sigma points
    (:func:`unscented_gap`) and the epochs whose curvature check fails are updated by them."""
    n_t = len(epochs)
    n = 6 + len(est)
    xs = np.empty((n_t, n))
    Ps = np.empty((n_t, n, n))
    xp = np.empty((n_t, n))
    Pp = np.empty((n_t, n, n))
    phis = np.empty((n_t, n, n))
    Ls = np.empty((n_t, n, n))
    Lp = np.empty((n_t, n, n))
    noises = [None] * n_t
    xs[0] = xp[0] = x
    Ps[0] = Pp[0] = P
    phis[0] = np.eye(n)
    L = Lp[0] = psd_factor(P)
    gm = dyn.gm
    if gauss is not None:
        step_s = gauss.longest_step_s(q, step_s)
    zero = np.zeros((n, n))
    curved = []  # (shift in sigmas, epoch index) where the linearisation fails
    # with a gap of days every gap between passes is flown by sigma points (UNSCENTED_GAP_S)
    unscented_after = CURVATURE_GAP_S if np.any(np.diff(epochs) > UNSCENTED_GAP_S) else np.inf
    for k in range(n_t):
        if k and epochs[k] - epochs[k - 1] > unscented_after:
            try:
                x, phis[k], noises[k], L = unscented_gap(dyn, schedule, x, L, epochs[k - 1],
                                                         epochs[k], q, code, step_s, est,
                                                         gauss)  # fmt: skip
            except VisvivaError as exc:
                raise screen.diverged(k, f"the sigma points cannot be integrated ({exc})") from exc
            Lp[k] = L
            xp[k], Pp[k] = x, covariance(L)
        elif k:
            grid = noise_substeps(epochs[k] - epochs[k - 1], q, step_s, gauss is not None)
            try:  # the prediction from P = 0 is its noise N
                if est:  # the coefficients, constants or Gauss-Markov, through the burns
                    x, N, phis[k] = predict_coefficients(dyn, schedule, x, zero, epochs[k - 1],
                                                         grid, q, code, est, gauss)
                else:
                    x, N, phis[k] = _predict(dyn, schedule, x, zero, epochs[k - 1], grid, q,
                                             code)  # fmt: skip
            except VisvivaError as exc:
                raise screen.diverged(k, f"the estimate cannot be integrated ({exc})") from exc
            noises[k] = noise_factor(N)
            L = Lp[k] = predict_factor(L, phis[k], noises[k])
            xp[k], Pp[k] = x, covariance(L)
        rows = screen.rows(k)
        if rows.size:
            bent = 0.0
            if k == 0 or epochs[k] - epochs[k - 1] > CURVATURE_GAP_S:  # after the growth
                bent = curvature_shift(observations, x, L, rows, gm)
            if bent > NONLINEAR_SHIFT and np.isfinite(unscented_after):
                x, L = _sigma_point_update(observations, x, L, rows, k, screen, gm)
            else:
                if bent > NONLINEAR_SHIFT:
                    curved.append((bent, k))
                x, L = _update(observations, x, L, rows, k, screen, gm)
        xs[k], Ps[k], Ls[k] = x, covariance(L), L
    if curved:
        _warn_curved(curved, observations, screen)
    return xs, Ps, xp, Pp, phis, (Ls, Lp, noises)


def _update(observations, x, L, rows, k, screen, gm):
    """The linearised update of (x, L L^T) with the rows at epoch ``k``: (x+, L+)."""
    h, H = model(observations, np.repeat(x[None, :6], rows.size, axis=0), gm, rows)
    z = residuals(observations.kinds[rows], observations.values[rows], h)
    comp, zc, Rd = screen.prefit(rows, z)
    Hc = H[comp]  # (m, 6) components in use, row-major
    if x.size > 6:  # the coefficients enter the measurements through the state only
        Hc = np.concatenate([Hc, np.zeros((Hc.shape[0], x.size - 6))], axis=1)
    HL = Hc @ L
    use = screen.check(k, rows, zc, HL @ HL.T + np.diag(Rd))
    if use.any():
        x, L = update_factor(x, L, Hc[use], Rd[use], zc[use])
    screen.finite(k, x, L)
    return x, L


def _sigma_point_update(observations, x, L, rows, k, screen, gm):
    """The update by sigma points (:func:`visviva.od.unscented.sigma_point_update`)."""
    from .unscented import sigma_point_update, unscented_weights

    return sigma_point_update(observations, x, L, rows, k, screen, gm,
                              unscented_weights(None, x.size))


def unscented_gap(dyn, schedule, x, L, t_from, t_to, q, code, step_s, est=(), gauss=None):
    """The prediction over a long gap by the unscented transform (:mod:`visviva.od.unscented`):
    the sigma points of (x, L L^T) at ``t_from`` flown to ``t_to`` (s from the epoch), on the
    sub-steps and through the burns the unscented filter takes; with ``est`` the state is
    (x, p) (6 + k) and each point flies its own coefficients p, which with ``gauss``
    (:class:`visviva.od.gauss_markov.GaussMarkov`) decay and take their noise at each
    sub-step's end. Returns the predicted mean, the statistical linearisation A of the flow
    (in place of the STM), the square root of the residue (cov(x-) = A P A^T + residue; the
    smoother's noise) and the predicted square root.
    """
    from .unscented import predict_interval, unscented_weights

    n = x.size
    for c in est:  # the block flies unit coefficients, each point scaling them by its own p
        c.write(dyn, 1.0)  # (the STM's predictions write the estimate again before each flight)
    x, L, T = predict_interval(dyn, schedule, est, x, L, t_from, t_to, q, code, step_s,
                               unscented_weights(None, n), gauss)
    L11, L21 = T[:n, :n], T[n:, :n]
    try:  # A = L21 L11^-1
        A = np.linalg.solve(L11.T, L21.T).T
    except np.linalg.LinAlgError:  # a component known exactly
        A = np.linalg.lstsq(L11.T, L21.T, rcond=None)[0].T
    return x, A, T[n:, n:].copy(), L


def _warn_curved(curved, observations, screen):
    import warnings

    worst, k = max(curved)
    first = observations.times[int(screen.rows(curved[0][1])[0])]
    warnings.warn(
        f"the extended Kalman filter's linearisation fails at {len(curved)} epoch(s) (the first "
        f"at {first.utc.isot} UTC): across its predicted covariance the curvature of the "
        f"measurements shifts their mean by up to {worst:.3g} of their sigmas (epoch {k}), "
        "which the linearised update leaves out, so the estimate can drift by many of its "
        "formal sigmas (range rates from a 10 km, 100 m/s prior ended 24 km off for a formal "
        "0.8 km). Use method='ukf', or start from a tighter prior (a batch fit of the first "
        "pass).", RuntimeWarning, stacklevel=4)
