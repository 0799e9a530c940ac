"""Square-root covariance forms of the extended Kalman filter's updates and of its smoother.

The filter carries a square root L of its covariance, P = L L^T, and never P itself: every
update is an orthogonal triangularisation (Householder QR) of a stacked "pre-array" whose
Gram matrix is the new covariance, so that the new factor exists whatever the round-off and
P = L L^T is symmetric positive semi-definite by construction (Bierman 1977, ch. V; Tapley,
Schutz & Born 2004, sec. 5.4; Carpenter & D'Souza 2018, NASA/TM-2018-219822, sec. 3.3). The
covariance form, even the Joseph form, subtracts: once a 1 nm measurement meets a 1 km prior
(a condition number ~1e24) P+ loses its smallest eigenvalues to round-off and comes out with
negative variances. The factor's condition number is the square root of P's, and Householder
QR is backward stable column by column, i.e. per state component, whatever the components'
units (km next to km/s).

* Time update, P- = Phi P Phi^T + N: the R factor of [(Phi L)^T; N^(1/2)T] (2n x n) is U with
  U^T U = P-, and L- = U^T.
* Measurement update (Carlson's array form): the R factor of

      A = [[R^(1/2),  0  ],          U = [[U11, U12],     U^T U = A^T A gives
           [(H L)^T, L^T]]                [  0, U22]]     S = U11^T U11, P H^T = U12^T U11,

  so K = U12^T U11^-T, x+ = x + U12^T (U11^-T z) and L+ = U22^T: P+ = P - K S K^T, the
  optimal update, without the subtraction.
* Smoother: the Rauch-Tung-Striebel covariance P^s_k = P_k + C (P^s_k+1 - P-_k+1) C^T in its
  Joseph form (I - C Phi) P_k (I - C Phi)^T + C N C^T + C P^s_k+1 C^T (equal for the smoother
  gain C = P_k Phi^T (P-_k+1)^-1, and the covariance of x^s_k for any C), as the R factor of
  the three factors stacked.

The input covariance and the process noise N are factored once by an eigen-decomposition of
their correlation matrix (:func:`psd_factor`), which holds semi-definite matrices (an exactly
known component, a rank-3 noise) that a Cholesky factorisation refuses.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import lapack

__all__ = ["psd_factor", "predict_factor", "update_factor", "update_rows", "noise_factor",
           "stacked_factor", "smoother_gain", "smooth_factor",
           "smooth_factor_from_joint", "covariance"]


def psd_factor(P):
    """A square root L (n, n) of a symmetric positive semi-definite P: L L^T = P.

    The correlation matrix D^-1/2 P D^-1/2 of the components of nonzero variance (D the
    diagonal) is decomposed as V Lambda V^T and L = D^1/2 V Lambda^1/2, the eigenvalues below
    zero (round-off of a semi-definite P; callers check larger ones beforehand, e.g.
    :func:`visviva._covariance.require_psd`) taken as zero; a component of zero variance (whose
    row must be zero) gets an exact zero row, which the updates keep.
    """
    d = np.sqrt(np.diag(P))
    on = np.flatnonzero(d > 0)
    lam, vec = np.linalg.eigh(P[np.ix_(on, on)] / np.outer(d[on], d[on]))
    L = np.zeros(P.shape)
    L[on[:, None], np.arange(on.size)[None, :]] = d[on, None] * vec * np.sqrt(np.maximum(lam, 0.0))
    return L


def covariance(L):
    """P = L L^T, symmetrised (the product is symmetric only to round-off)."""
    P = L @ L.T
    return 0.5 * (P + P.T)


# LAPACK's dgeqrf called directly: scipy.linalg.qr's checks and workspace query cost 3-5 times
# the factorisation of these 6-9 column matrices
_GEQRF = lapack.get_lapack_funcs("geqrf", (np.zeros(1),))


def _r_factor(pre):
    """The upper-triangular R (columns x columns) of the QR factorisation of ``pre``
    (Householder; rows >= columns)."""
    n = pre.shape[1]
    qr, _, _, info = _GEQRF(pre, lwork=64 * n)
    if info:
        raise np.linalg.LinAlgError(f"LAPACK dgeqrf failed (info {info})")
    return np.triu(qr[:n])


def _triangular(pre, n):
    """The n x n upper-triangular R factor of the stacked ``pre`` (rows >= n) as a lower L."""
    return _r_factor(pre)[:n, :n].T


def stacked_factor(rows):
    """The lower-triangular L (n, n) with L L^T = rows^T rows (``rows`` (>= n, n)): the
    unscented filter's predicted factor from its weighted sigma-point deviations and noise
    factor (van der Merwe & Wan 2001, eq. 20)."""
    return _r_factor(rows).T


def predict_factor(L, phi, noise=None):
    """The square root of P- = Phi P Phi^T + N from L (P = L L^T), ``phi`` (n, n) and the
    square root ``noise`` of N (None: no noise)."""
    pre = (phi @ L).T if noise is None else np.vstack([(phi @ L).T, noise.T])
    return _triangular(pre, L.shape[0])


def update_factor(x, L, H, r, z):
    """The measurement update in array form: (x+, L+) from the state x (n,), the square root
    L of its covariance, the partials H (m, n), the measurement variances r (m,) (> 0,
    uncorrelated) and the pre-fit residuals z (m,)."""
    return update_rows(x, L, H @ L, np.diag(np.sqrt(r)), z)


def update_rows(x, L, HL, noise_rows, z):
    """:func:`update_factor` from the measurement's image ``HL`` (m, n) of the factor L and
    ``noise_rows`` (k >= m, m) whose Gram matrix is the measurement noise R (rows^T rows = R;
    the unscented filter's holds its linearisation error as well)."""
    k, m = noise_rows.shape
    n = L.shape[0]
    pre = np.zeros((k + n, m + n))
    pre[:k, :m] = noise_rows
    pre[k:, :m] = HL.T
    pre[k:, m:] = L.T
    U = _r_factor(pre)
    w = np.linalg.solve(U[:m, :m].T, z)  # U11^-T z (numpy's LU: LAPACK's trtrs through scipy
    # took milliseconds a call with a loaded machine's OpenBLAS threads)
    return x + U[:m, m:].T @ w, U[m:, m:].T


def noise_factor(N):
    """The square root of a prediction's noise N, None for none (Cholesky when N is definite,
    as it is over two sub-steps of process noise; else the semi-definite factor)."""
    if not np.any(N):
        return None
    try:
        return np.linalg.cholesky(N)
    except np.linalg.LinAlgError:
        return psd_factor(N)


def smoother_gain(L, phi, L_pred, image=None):
    """The Rauch-Tung-Striebel gain C = P Phi^T (P-)^-1 from the filtered square root L, the
    transition ``phi`` and the lower-triangular square root ``L_pred`` of P- (two solves with
    the square root, on its condition number rather than P-'s); ``image``: Phi L given (the
    unscented smoother's L21 of the joint factor, ``phi`` unused); a singular P- (a
    component of zero predicted variance): :class:`numpy.linalg.LinAlgError`."""
    if not np.all(np.diag(L_pred)):
        raise np.linalg.LinAlgError("the predicted covariance is singular")
    W = np.linalg.solve(L_pred, phi @ L if image is None else image)
    return np.linalg.solve(L_pred.T, W @ L.T).T


def smooth_factor(L, phi, noise, C, L_next):
    """The square root of the smoothed covariance (I - C Phi) P (I - C Phi)^T + C N C^T +
    C P^s C^T from the filtered factor L, the transition ``phi`` to the next epoch, the
    square root ``noise`` of the prediction's noise (None: none), the smoother gain C and the
    next epoch's smoothed factor ``L_next``."""
    n = L.shape[0]
    blocks = [((np.eye(n) - C @ phi) @ L).T, (C @ L_next).T]
    if noise is not None:
        blocks.append((C @ noise).T)
    return _triangular(np.vstack(blocks), n)


def smooth_factor_from_joint(T, C, L_next):
    """:func:`smooth_factor` for the unscented smoother: from the lower-triangular square root
    T = [[L11, 0], [L21, L22]] of the joint covariance [[P, cross^T], [cross, P-]] of (x_k,
    x_k+1^-) (cross = L21 L11^T), the gain C and the next epoch's smoothed factor ``L_next``.

    L21 L11^T = cross, and L22 L22^T is the Schur complement P- - cross P^-1 cross^T, the
    effective noise N of the statistically linearised transition A = cross P^-1 (A L11 =
    L21), so that the Joseph form's (I - C A) L and C N^1/2 are L11 - C L21 and C L22 (no
    inverse of P, which may be singular).
    """
    n = T.shape[0] // 2
    L11, L21, L22 = T[:n, :n], T[n:, :n], T[n:, n:]
    return _triangular(np.vstack([(L11 - C @ L21).T, (C @ L22).T, (C @ L_next).T]), n)
