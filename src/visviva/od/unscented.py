"""The unscented Kalman filter of :func:`visviva.filter_orbit` (``method="ukf"``).

Instead of the state-transition matrix and the measurement partials, the unscented filter
carries 2n + 1 = 13 sigma points of the 6-state through the dynamics and the measurement models
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
  2 pi give the right mean and spread. S = P_zz + R, K = P_xz S^-1, x+ = x- + K z,
  P+ = P- - K S K^T. Editing, NIS and divergence are the extended filter's rules on this S.
* Smoother: Saerkkae's unscented Rauch-Tung-Striebel smoother (Saerkkae 2008, IEEE TAC 53(3),
  845-849), whose gain uses the cross-covariance D_k+1 = cov(x_k, x_k+1^-) of the prediction's
  sigma points, stored during the forward pass (over several sub-steps chained through the
  statistical linearisation of each).
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError, VisvivaError
from ..satellites.covariance import noise_substeps, step_noise
from .light_time import model
from .measurements import residuals

__all__ = ["unscented_pass", "unscented_weights", "sigma_points", "DEFAULT_SIGMA_POINTS"]

#: (alpha, beta, kappa): points sqrt(6) sigma out, mean weights 0 (centre) and 1/12 (none
#: negative), beta = 2 optimal for a Gaussian prior (Wan & van der Merwe 2000).
DEFAULT_SIGMA_POINTS = (1.0, 2.0, 0.0)
N_STATE = 6


def unscented_weights(parameters=None):
    """The scaled unscented transform's spread and weights (Wan & van der Merwe 2000).

    Parameters
    ----------
    parameters : tuple of float or None
        (alpha, beta, kappa); None: :data:`DEFAULT_SIGMA_POINTS`. alpha > 0, kappa > -6.

    Returns
    -------
    scale : float
        sqrt(n + lambda), lambda = alpha^2 (n + kappa) - n: how many standard deviations out the
        points lie (n = 6).
    wm, wc : ndarray (13,)
        Mean and covariance weights: W_0^m = lambda / (n + lambda), W_0^c = W_0^m + 1 -
        alpha^2 + beta, W_i = 1 / (2 (n + lambda)).

    Raises
    ------
    InvalidInputError
        Not three finite numbers, alpha <= 0 or kappa <= -6.
    """
    if parameters is None:
        parameters = DEFAULT_SIGMA_POINTS
    try:
        alpha, beta, kappa = (float(v) for v in parameters)
    except (TypeError, ValueError):
        raise InvalidInputError(
            f"sigma_points must be three numbers (alpha, beta, kappa); got {parameters!r}."
        ) from None
    if not (np.isfinite([alpha, beta, kappa]).all() and alpha > 0 and N_STATE + kappa > 0):
        raise InvalidInputError(
            f"sigma_points (alpha, beta, kappa) = {parameters!r} needs finite values with "
            f"alpha > 0 and kappa > -{N_STATE} (the points lie sqrt(alpha^2 (6 + kappa)) "
            "sigma out); the default is (1, 2, 0)."
        )
    c = alpha**2 * (N_STATE + kappa)  # n + lambda
    wm = np.full(2 * N_STATE + 1, 0.5 / c)
    wm[0] = 1.0 - N_STATE / c
    wc = wm.copy()
    wc[0] += 1.0 - alpha**2 + beta
    return np.sqrt(c), wm, wc


def _square_root(P):
    """L with L L^T = P: Cholesky of P scaled to unit diagonal (position and velocity variances
    differ by 1e6 and more), or the symmetric root from the eigenvalues (negative round-off
    ones set to 0) for a singular P."""
    d = np.sqrt(np.diag(P))
    if np.all(d > 0):
        try:
            return d[:, None] * np.linalg.cholesky(P / np.outer(d, d))
        except np.linalg.LinAlgError:
            pass
    w, V = np.linalg.eigh(P)
    return V * np.sqrt(np.clip(w, 0.0, None))


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
    L = scale * _square_root(P)
    return np.concatenate([x[None], x + L.T, x - L.T])


def _solve_scaled(P, B):
    """P^-1 B for a covariance P, through its unit-diagonal scaling."""
    d = 1.0 / np.sqrt(np.diag(P))
    return d[:, None] * np.linalg.solve(P * np.outer(d, d), d[:, None] * B)


def _predict(dyn, x, P, t_from, dt, weights, q, code):
    """Mean, covariance (with the SNC noise of the step) and cov(x(t_from + dt), x(t_from)) of
    the sigma points of (x, P) carried over ``dt`` s."""
    scale, wm, wc = weights
    X = sigma_points(x, P, scale)
    # on the calling thread: 13 arcs take 0.2 ms (60 s) to 0.9 ms (90 min), waking numba's
    # workers 8 ms on the shared 2-core machine
    Y = dyn.at_origin(t_from).propagate_many(X, np.array([dt]), threads=False)[:, 0]
    m = Y[0] + wm @ (Y - Y[0])
    dY = Y - m
    Pn = (wc * dY.T) @ dY
    if q is not None:
        Pn = Pn + step_noise(x, m, dt, q, code)
    return m, 0.5 * (Pn + Pn.T), (wc * dY.T) @ (X - x)


def _update(observations, x, P, rows, k, screen, gm, weights):
    """The measurement update with the rows at epoch ``k``: (x+, P+)."""
    scale, wm, wc = weights
    X = sigma_points(x, P, scale)
    m, n_pts = rows.size, X.shape[0]
    kinds = observations.kinds[rows]
    h, _ = model(observations, np.repeat(X, m, axis=0), gm, np.tile(rows, n_pts), partials=False)
    h = h.reshape(n_pts, m, 3)
    # each point's prediction minus the central one's, angles wrapped: a mean of angles
    dev = residuals(np.tile(kinds, n_pts), h.reshape(-1, 3), np.tile(h[0], (n_pts, 1)))
    dev = dev.reshape(n_pts, m, 3)
    shift = np.tensordot(wm, dev, axes=1)
    z = residuals(kinds, observations.values[rows], h[0] + shift)
    comp, zc, Rd = screen.prefit(rows, z)
    dZ = (dev - shift)[:, comp]  # (13, components in use)
    S = (wc * dZ.T) @ dZ + np.diag(Rd)
    Pxz = (wc * (X - x).T) @ dZ
    use = screen.check(k, rows, zc, S)
    if use.any():
        Su = S[np.ix_(use, use)]
        K = np.linalg.solve(Su, Pxz[:, use].T).T  # P_xz S^-1 (S symmetric)
        x = x + K @ zc[use]
        P = P - K @ Su @ K.T
        P = 0.5 * (P + P.T)
    screen.finite(k, x, P)
    return x, P


def unscented_pass(dyn, observations, x, P, epochs, screen, q, code, step_s, parameters):
    """The unscented Kalman filter forward over ``epochs``: filtered and predicted states and
    covariances, and the cross-covariances cov(x_k^-, x_k-1^+) (the smoother's)."""
    weights = unscented_weights(parameters)
    n_t = len(epochs)
    xs = np.empty((n_t, 6))
    Ps = np.empty((n_t, 6, 6))
    xp = np.empty((n_t, 6))
    Pp = np.empty((n_t, 6, 6))
    cross = np.empty((n_t, 6, 6))
    xs[0] = xp[0] = x
    Ps[0] = Pp[0] = cross[0] = P
    for k in range(n_t):
        if k:
            before = 0.0
            C = None
            for after in noise_substeps(epochs[k] - epochs[k - 1], q, step_s):
                try:
                    xn, Pn, D = _predict(dyn, x, P, epochs[k - 1] + before, after - before,
                                         weights, q, code)  # fmt: skip
                except VisvivaError as exc:
                    raise screen.diverged(
                        k, f"the sigma points cannot be integrated ({exc})") from exc
                # cov(x_after, x_k-1) through the statistical linearisation D P^-1 of the step
                C = D if C is None else D @ _solve_scaled(P, C)
                x, P, before = xn, Pn, after
            xp[k], Pp[k], cross[k] = x, P, C
        rows = screen.rows(k)
        if rows.size:
            x, P = _update(observations, x, P, rows, k, screen, dyn.gm, weights)
        xs[k], Ps[k] = x, P
    return xs, Ps, xp, Pp, cross
