"""The unscented Kalman filter of :func:`visviva.filter_orbit` (``method="ukf"``).

Instead of the state-transition matrix and the measurement partials, the unscented filter
carries 2n + 1 = 13 sigma points of the 6-state (2n + 1 of the 6 + k-state with k estimated
coefficients) through the dynamics and the measurement models
and takes their weighted mean and covariance (the scaled unscented transform: Julier & Uhlmann
2004, Proc. IEEE 92(3), 401-422; Wan & van der Merwe 2000, IEEE AS-SPCC, 153-158). It keeps
the second-order terms of a mean that the extended filter drops, which matters when the a
priori covariance is large enough for the dynamics or the measurements to be nonlinear across
it (an IOD state with km-level uncertainty): there the extended filter's covariance is
overconfident.

* Sigma points: X_0 = x, X_i = x +- sqrt(n + lambda) L_i (L_i the columns of a square root of
  P, L L^T = P), lambda = alpha^2 (n + kappa) - n; weights W_0^m = lambda / (n + lambda),
  W_0^c = W_0^m + 1 - alpha^2 + beta, W_i = 1 / (2 (n + lambda)).
* Prediction: the 13 points in one compiled call of the fit's force model and integrator
  (:meth:`visviva.od.dynamics.Dynamics.propagate_many`, no STM); with process noise the
  interval is cut into the extended filter's sub-steps (<= ``noise_step``) and each sub-step
  adds the same state noise compensation Q (:func:`visviva.satellites.covariance.step_noise`),
  fresh sigma points being drawn from the (mean, covariance) at the start of each.
* Update: the points of the predicted (mean, covariance) through the measurement model of the
  epoch's rows (:func:`visviva.od.light_time.model`, one call for all 13 x rows); azimuth and
  right ascension are averaged as angles (each point's value minus the central point's,
  wrapped into (-pi, pi], then averaged and added back), so that points on both sides of 0 /
  2 pi give the right mean and spread. S = P_zz + R, K = P_xz S^-1, x+ = x- + K z, P+ = P- -
  K S K^T, computed in square-root form (van der Merwe & Wan 2001, ICASSP): the filter carries
  L (P = L L^T), draws the points from it, and both the prediction (QR of the weighted
  deviations and the noise's square root, :func:`_linearised`) and the update
  (:func:`array_update`, the extended filter's array form with the statistically linearised
  H L) are orthogonal triangularisations, positive semi-definite by construction at any
  conditioning (1 nm positions against a 1 km prior). Editing, NIS and divergence are the
  extended filter's rules on this S.
* Burns (``maneuvers=``): every burn start and end inside an interval cuts it (fresh sigma
  points on each piece); a piece flies the force model of its segment
  (:meth:`visviva.satellites.burn_segments.Schedule.segment_model`: a finite burn's thrust,
  in each point's own local frame, and the mass ratio of drag and SRP), and the impulses at
  its end are applied to every point on the point's own local axes
  (:func:`through_impulses`), which adds the execution error C as sum_i W_i^m G_i C G_i^T
  (G_i = [[0], [M_i^T]]): the exact second moment of an error independent of the state.
* Coefficients (``estimate=``): the state is (x, p), n = 6 + k, 2 n + 1 points; the force
  block holds unit coefficients and each point scales them by its own p in the same compiled
  call (:meth:`visviva.od.dynamics.Dynamics.propagate_many`, ``per_state``); p is constant
  over a step and enters the measurements through x only. With Gauss-Markov coefficients
  (:mod:`visviva.od.gauss_markov`) the steps are at most tau / 50, and at each step's end every
  point's p decays towards p0 and the noise sigma^2 (1 - m^2) is added to the p block.
* Smoother: Saerkkae's unscented Rauch-Tung-Striebel smoother (Saerkkae 2008, IEEE TAC 53(3),
  845-849), whose gain uses the cross-covariance D_k+1 = cov(x_k, x_k+1^-) of the prediction's
  sigma points, stored during the forward pass (over several sub-steps chained through the
  statistical linearisation of each, as the square root of the joint covariance of (x_k,
  x_k+1^-)); its covariance in square-root Joseph form from that joint factor
  (:func:`visviva.od.square_root.smooth_factor_from_joint`).
"""

from __future__ import annotations

import copy

import numpy as np

from ..errors import InvalidInputError, VisvivaError
from ..satellites.burn_segments import DRIFT_S
from ..satellites.covariance import noise_substeps, step_noise
from .light_time import model
from .measurements import residuals
from .square_root import covariance, noise_factor, psd_factor, stacked_factor, update_rows

__all__ = ["unscented_pass", "unscented_weights", "sigma_points", "through_impulses",
           "array_update", "predict_interval", "sigma_point_update", "DEFAULT_SIGMA_POINTS"]

#: (alpha, beta, kappa): points sqrt(6) sigma out, mean weights 0 (centre) and 1/12 (none
#: negative), beta = 2 optimal for a Gaussian prior (Wan & van der Merwe 2000).
DEFAULT_SIGMA_POINTS = (1.0, 2.0, 0.0)
N_STATE = 6


def unscented_weights(parameters=None, n=N_STATE):
    """The scaled unscented transform's spread and weights (Wan & van der Merwe 2000).

    Parameters
    ----------
    parameters : tuple of float or None
        (alpha, beta, kappa); None: :data:`DEFAULT_SIGMA_POINTS`. alpha > 0, kappa > -n.
    n : int
        Dimension of the state (6; 6 + k with k estimated coefficients).

    Returns
    -------
    scale : float
        sqrt(n + lambda), lambda = alpha^2 (n + kappa) - n: how many standard deviations out the
        points lie.
    wm, wc : ndarray (2 n + 1,)
        Mean and covariance weights: W_0^m = lambda / (n + lambda), W_0^c = W_0^m + 1 -
        alpha^2 + beta, W_i = 1 / (2 (n + lambda)).

    Raises
    ------
    InvalidInputError
        Not three finite numbers, alpha <= 0 or kappa <= -n.
    """
    if parameters is None:
        parameters = DEFAULT_SIGMA_POINTS
    try:
        alpha, beta, kappa = (float(v) for v in parameters)
    except (TypeError, ValueError):
        raise InvalidInputError(
            f"sigma_points must be three numbers (alpha, beta, kappa); got {parameters!r}."
        ) from None
    if not (np.isfinite([alpha, beta, kappa]).all() and alpha > 0 and n + kappa > 0):
        raise InvalidInputError(
            f"sigma_points (alpha, beta, kappa) = {parameters!r} needs finite values with "
            f"alpha > 0 and kappa > -{n} (the points lie sqrt(alpha^2 ({n} + kappa)) "
            "sigma out); the default is (1, 2, 0)."
        )
    c = alpha**2 * (n + kappa)  # n + lambda
    wm = np.full(2 * n + 1, 0.5 / c)
    wm[0] = 1.0 - n / c
    wc = wm.copy()
    wc[0] += 1.0 - alpha**2 + beta
    return np.sqrt(c), wm, wc


def _square_root(P):
    """L with L L^T = P: Cholesky of P scaled to unit diagonal (position and velocity variances
    differ by 1e6 and more), or :func:`visviva.od.square_root.psd_factor` for a singular P."""
    d = np.sqrt(np.diag(P))
    if np.all(d > 0):
        try:
            return d[:, None] * np.linalg.cholesky(P / np.outer(d, d))
        except np.linalg.LinAlgError:
            pass
    return psd_factor(P)


def _points(x, L, scale):
    """The 2n + 1 sigma points of the mean x and the square root L of its covariance."""
    L = scale * L
    return np.concatenate([x[None], x + L.T, x - L.T])


def sigma_points(x, P, scale):
    """The 2n + 1 sigma points of a mean and covariance.

    Parameters
    ----------
    x : ndarray (6,)
        Mean state, km and km/s.
    P : ndarray (6, 6)
        Its covariance, km^2, km^2/s, km^2/s^2 (positive semi-definite).
    scale : float
        sqrt(n + lambda) from :func:`unscented_weights`.

    Returns
    -------
    ndarray (13, 6)
        x, then x + scale L_i (i = 1..6), then x - scale L_i, L L^T = P.
    """
    return _points(x, _square_root(P), scale)


def _fly(dyn, schedule, est, X, a, b, dt):
    """The sigma points X (N, 6 + k) at ``a`` carried to ``b`` = a + ``dt`` (s from the epoch;
    no burn starts or ends between them): one compiled call, each point flying its own
    coefficients (columns 6 on, on a block holding unit coefficients) and the thrust of a finite
    burn on over the interval in its own local frame; the coefficients are constants."""
    Y = X.copy()
    if dt < DRIFT_S:  # burn edges less than a nanosecond apart (burn_segments.DRIFT_S)
        Y[:, :3] += X[:, 3:6] * dt
        return Y
    if schedule:
        schedule.check_state(a, b, X[:, :6])
        d = copy.copy(dyn)
        d.model = schedule.segment_model(dyn.model, a, b)
    else:
        d = dyn.at_origin(a)
    per_state = {c.slot: X[:, 6 + j] for j, c in enumerate(est)}
    # on the calling thread: 13 arcs take 0.2 ms (60 s) to 0.9 ms (90 min), waking numba's
    # workers 8 ms on the shared 2-core machine
    Y[:, :6] = d.propagate_many(X[:, :6], np.array([dt]), threads=False,
                                per_state=per_state)[:, 0]
    return Y


def through_impulses(schedule, t, Y, wm):
    """The impulses of ``schedule`` at ``t`` applied to every sigma point (rows of ``Y``), each
    Δv on the point's own local axes, in the schedule's order; with the noise of their
    execution errors, sum_i W_i^m G_i C G_i^T (G_i = d y+ / d Δv = [[0], [M_i^T]] at point i;
    zero without an ``execution_covariance``): the exact second moment of the error's
    contribution y+ = y- + M(y-)^T (Δv + e), e ~ (0, C) independent of the state."""
    from ..satellites.burn_partials import impulse_jacobians

    Y = Y.copy()
    noise = np.zeros((Y.shape[1], Y.shape[1]))
    for burn in schedule.impulses_at(t) if schedule else []:
        c = burn.execution_covariance
        if c is not None:
            for w, y in zip(wm, Y, strict=True):
                g = impulse_jacobians(burn, y[:6])[1]
                noise[:6, :6] += w * (g @ c @ g.T)
        Y[:, 3:6] += burn.delta_v_inertial(Y[:, :3], Y[:, 3:6])
    return Y, noise


def _moments(Y, wm):
    """Weighted mean of the points Y and their deviations from it."""
    m = Y[0] + wm @ (Y - Y[0])
    return m, Y - m


def _linearised(dY, weights, noise=None):
    """The statistical linearisation of a transform of the sigma points of (x, L L^T).

    Returns the image F = (dY_j+ - dY_j-) / (2 scale) of the factor (column j; the points are
    x +- scale L_j) and rows whose Gram matrix is the second-order residue sum_i W_i^c e_i
    e_i^T (e_0 = dY_0, e_j+- = (dY_j+ + dY_j-) / 2) plus the ``noise`` N (its square root's
    rows): sum_i W_i^c dY_i dY_i^T + N = F F^T + rows^T rows, the transform's covariance (van
    der Merwe & Wan 2001, eq. 20) as factors. With W_0^c >= 0 the rows are the weighted e_i
    themselves. With W_0^c < 0 (alpha = 0.5, kappa = 0) the centre's term is not downdated (van
    der Merwe & Wan's Cholesky downdate of the factor by sqrt(-W_0^c) dY_0 failed at 1 nm,
    and on a deterministic prediction's joint factor, where that term is round-off): since
    the points are symmetric, sum_j s_j = W_0^m sum_j delta_j (s_j = e_j+-, delta_j their
    curvature terms, dY_0 = -sum_j delta_j / c, c = n + lambda), and the residue is exactly
    (1/c) sum_j (s_j - s_bar)(s_j - s_bar)^T + gamma dY_0 dY_0^T with s_bar the mean of the
    s_j and gamma = c (W_0^m)^2 / n + W_0^c (beta for kappa = 0): rows again, positive
    semi-definite by construction when gamma >= 0, which :func:`unscented_pass` requires
    (gamma = beta + alpha^2 kappa / n; below 0 the unscented covariance itself is not positive
    by construction).
    """
    scale, wm, wc = weights
    n = (dY.shape[0] - 1) // 2
    F = ((dY[1:n + 1] - dY[n + 1:]) / (2.0 * scale)).T
    E = np.sqrt(2.0 * wc[1]) * 0.5 * (dY[1:n + 1] + dY[n + 1:])  # sqrt(1/c) s_j
    if wc[0] >= 0:
        rows = [E, np.sqrt(wc[0]) * dY[:1]]
    else:  # sqrt(1/c) (s_j - s_bar), and gamma = c (W_0^m)^2 / n + W_0^c
        rows = [E - E.mean(axis=0), np.sqrt(max(_gamma(weights, n), 0.0)) * dY[:1]]
    root = None if noise is None else noise_factor(noise)
    if root is not None:
        rows.append(root.T)
    return F, np.vstack(rows)


def _gamma(weights, n):
    """c (W_0^m)^2 / n + W_0^c (= beta + alpha^2 kappa / n): the weight of the centre's term
    in the residue's positive form (:func:`_linearised`)."""
    scale, wm, wc = weights
    return scale**2 * wm[0] ** 2 / n + wc[0]


def _factor(F, rows):
    """The lower-triangular square root of F F^T + rows^T rows."""
    return stacked_factor(np.vstack([F.T, rows]))


def _predict(dyn, schedule, est, x, L, step, weights, q, code, gm=None):
    """The mean of the sigma points of (x, L L^T) carried over the sub-step ``step`` = (a, b,
    b - a) (s from the epoch), through the impulses at b, and the statistical linearisation
    of the step (:func:`_linearised`) with the SNC noise of the step and the execution errors
    of the impulses at its end."""
    scale, wm, wc = weights
    a, b, dt = step
    X = _points(x, L, scale)
    Y = _fly(dyn, schedule, est, X, a, b, dt)
    Y, noise = through_impulses(schedule, b, Y, wm)
    if gm is not None:  # each point's coefficients decay, the Gauss-Markov noise is added
        Y, extra = gm.apply_points(Y, dt)
        noise = noise + extra
    m, dY = _moments(Y, wm)
    if q is not None:
        noise[:6, :6] += step_noise(x[:6], m[:6], dt, q, code)
    return (m,) + _linearised(dY, weights, noise)


def _chain(T, L, F, rows):
    """The joint square root of (x_k, x_b) from T, (x_k, x_a)'s, and a step x_a -> x_b
    linearised as x_b = A x_a + e (A L = F, e of the Gram matrix ``rows``^T ``rows``), L the
    factor the step's points were drawn from; T None: x_a = x_k, L its
    factor. Lower-triangular [[L11, 0], [L21, L22]], L11 a factor of P_k."""
    n = F.shape[0]
    if T is None:
        top, image = L, F
    else:  # A [T21, T22] = F L^-1 [T21, T22]
        try:
            q = np.linalg.solve(L, T[n:])
        except np.linalg.LinAlgError:  # a component known exactly: [T21, T22] = L Q still
            q = np.linalg.lstsq(L, T[n:], rcond=None)[0]
        top, image = T[:n], F @ q
    pre = np.zeros((top.shape[1] + rows.shape[0], 2 * n))
    pre[:top.shape[1], :n] = top.T
    pre[:top.shape[1], n:] = image.T
    pre[top.shape[1]:, n:] = rows
    return stacked_factor(pre)


def _substeps(t_from, t_to, q, step_s, schedule, cut=False):
    """The sub-steps (a, b, b - a) (s from the epoch) of a prediction from ``t_from`` to
    ``t_to``: the noise steps, cut at every burn start and end inside the interval (the sigma
    points are redrawn there, after an impulse's execution error is added). The ends are the
    burns' and epochs' own numbers (an impulse is found at b by equality)."""
    grid = noise_substeps(t_to - t_from, q, step_s, cut)
    if not schedule:
        before = np.r_[0.0, grid[:-1]]
        return [(t_from + p, t_from + n, n - p) for p, n in zip(before, grid, strict=True)]
    cuts = [e for a, b, _ in schedule.items for e in (a, b) if t_from < e < t_to]
    ts = np.unique(np.r_[t_from, t_from + grid[:-1], cuts, t_to])
    return [(float(p), float(n), float(n - p)) for p, n in zip(ts[:-1], ts[1:], strict=True)]


def predict_interval(dyn, schedule, est, x, L, t_from, t_to, q, code, step_s, weights,
                     gm=None):
    """The unscented prediction of (x, L L^T) from ``t_from`` to ``t_to`` (s from the epoch),
    on the noise sub-steps cut at the burns (:func:`_substeps`), fresh sigma points on each
    (weights from :func:`unscented_weights`): the mean, its square root and the joint square
    root of (x(t_from), x(t_to)) (:func:`_chain`, the smoother's); the extended filter's over
    gaps of days too (:func:`visviva.od.extended.unscented_gap`)."""
    T = None
    for step in _substeps(t_from, t_to, q, step_s, schedule, gm is not None):
        xn, F, rows = _predict(dyn, schedule, est, x, L, step, weights, q, code, gm)
        T = _chain(T, L, F, rows)  # the joint factor of (x(t_from), x_b)
        x, L = xn, _factor(F, rows)
    return x, L, T


def sigma_point_update(observations, x, L, rows, k, screen, gm, weights):
    """The measurement update of (x, L L^T) with the rows at epoch ``k`` by the sigma points
    (the pre-fit residuals, editing and NIS through ``screen``): (x+, L+); the extended
    filter's too where its linearisation fails after a gap of days
    (:func:`visviva.od.extended.ekf_pass`)."""
    scale, wm, wc = weights
    X = _points(x, L, scale)
    m, n_pts = rows.size, X.shape[0]
    kinds = observations.kinds[rows]
    h, _ = model(observations, np.repeat(X[:, :6], m, axis=0), gm, np.tile(rows, n_pts),
                 partials=False)
    h = h.reshape(n_pts, m, 3)
    # each point's prediction minus the central one's, angles wrapped: a mean of angles
    dev = residuals(np.tile(kinds, n_pts), h.reshape(-1, 3), np.tile(h[0], (n_pts, 1)))
    dev = dev.reshape(n_pts, m, 3)
    shift = np.tensordot(wm, dev, axes=1)
    z = residuals(kinds, observations.values[rows], h[0] + shift)
    comp, zc, Rd = screen.prefit(rows, z)
    dZ = (dev - shift)[:, comp]  # (13, components in use)
    use = screen.check(k, rows, zc, (wc * dZ.T) @ dZ + np.diag(Rd))
    if use.any():
        x, L = array_update(x, L, dZ[:, use], weights, Rd[use], zc[use])
    screen.finite(k, x, L)
    return x, L


def array_update(x, L, dZ, weights, R, z):
    """The unscented measurement update through the square root of the covariance.

    Parameters
    ----------
    x : ndarray (n,)
        Predicted state.
    L : ndarray (n, n)
        A square root of its covariance (L L^T = P-), whose columns drew the sigma points.
    dZ : ndarray (2 n + 1, m)
        The points' predicted measurements less their weighted mean.
    weights : tuple
        (scale, wm, wc) from :func:`unscented_weights`.
    R : ndarray (m,)
        Measurement variances.
    z : ndarray (m,)
        Pre-fit residuals.

    Returns
    -------
    x, L : ndarray (n,), (n, n)
        The updated state and the square root of its covariance.

    Notes
    -----
    The points are X_0 = x and x +- scale L_j, so the cross-covariance P_xz = sum_i W_i^c
    (X_i - x) dZ_i^T is L G^T with G = (dZ_j+ - dZ_j-) / (2 scale) column by column: G is
    the image H L of the factor under the statistically linearised measurement, and P_zz - G
    G^T = sum_i W_i^c e_i e_i^T (e_0 = dZ_0, e_j+- = (dZ_j+ + dZ_j-) / 2) its linearisation
    error, which joins R. The update is then the extended filter's array form
    (:func:`visviva.od.square_root.update_rows`): x + P_xz S^-1 z and the factor of P- -
    P_xz S^-1 P_xz^T (S = P_zz + R) from one QR, with no subtraction. This replaces van der
    Merwe & Wan's (2001, eq. 29) Cholesky downdates of the predicted factor by the columns of
    K S_y, which subtract (they fail where a 1 nm position meets a 1 km prior). A negative
    W_0^c (alpha < 1) enters through the residue's positive form (:func:`_linearised`).
    """
    HL, rows = _linearised(dZ, weights)
    return update_rows(x, L, HL, np.vstack([np.diag(np.sqrt(R)), rows]), z)


def unscented_pass(dyn, observations, x, P, epochs, screen, q, code, step_s, parameters,
                   schedule=None, est=(), apply_at_start=False, gm=None):
    """The unscented Kalman filter forward over ``epochs`` (through the burns of ``schedule``;
    the first state before the impulses at epochs[0] when ``apply_at_start``; with ``est`` the
    state carries those coefficients, 6 + k): filtered and predicted states and covariances, and
    the cross-covariances cov(x_k^-, x_k-1^+) (the smoother's); ``gm``: the coefficients'
    Gauss-Markov models (:class:`visviva.od.gauss_markov.GaussMarkov`), or None."""
    n = x.size
    weights = unscented_weights(parameters, n)
    if _gamma(weights, n) < -1e-12:
        raise InvalidInputError(
            f"sigma_points (alpha, beta, kappa) = {parameters!r} give a negative centre "
            f"covariance weight whose unscented covariance is not positive semi-definite by "
            f"construction (beta + alpha^2 kappa / {n} < 0); use beta >= 0 with kappa >= 0, "
            "e.g. the default (1, 2, 0).")
    if gm is not None:
        step_s = gm.longest_step_s(q, step_s)
    for c in est:  # the block flies unit coefficients, each point scaling them by its own
        c.write(dyn, 1.0)
    n_t = len(epochs)
    xs = np.empty((n_t, n))
    Ps = np.empty((n_t, n, n))
    xp = np.empty((n_t, n))
    Pp = np.empty((n_t, n, n))
    L = _square_root(P)
    if apply_at_start and schedule and schedule.impulses_at(epochs[0]):
        X = _points(x, L, weights[0])
        Y, noise = through_impulses(schedule, epochs[0], X, weights[1])
        x, dY = _moments(Y, weights[1])
        L = _factor(*_linearised(dY, weights, noise))
        P = covariance(L)
    xs[0] = xp[0] = x
    Ps[0] = Pp[0] = P
    Lf = np.empty((n_t, n, n))
    Lp = np.empty((n_t, n, n))
    joints = np.zeros((n_t, 2 * n, 2 * n))
    Lf[0] = Lp[0] = L
    for k in range(n_t):
        if k:
            try:
                x, L, T = predict_interval(dyn, schedule, est, x, L, epochs[k - 1], epochs[k],
                                           q, code, step_s, weights, gm)  # fmt: skip
            except VisvivaError as exc:
                raise screen.diverged(k, f"the sigma points cannot be integrated ({exc})") from exc
            xp[k], Pp[k], Lp[k], joints[k] = x, covariance(L), L, T
        rows = screen.rows(k)
        if rows.size:
            x, L = sigma_point_update(observations, x, L, rows, k, screen, dyn.gm, weights)
        xs[k], Ps[k], Lf[k] = x, covariance(L), L
    return xs, Ps, xp, Pp, (Lf, Lp, joints)
