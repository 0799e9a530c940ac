"""A priori information in the batch fit: whitened pseudo-observations of a prior estimate.

Batch least squares with a priori (Tapley, Schutz & Born 2004, sec. 4.6) minimises

    J(p) = (y - h(p))^T R^-1 (y - h(p)) + (p_bar - p)^T P_bar^-1 (p_bar - p),

with p_bar the a priori value of (part of) the unknowns p, fixed through the iterations, and
P_bar its covariance. With W^T W = P_bar^-1 the second term is the sum of squares of the rows
W (p_bar - p): appended to the whitened design matrix as rows W (columns of those unknowns) and
to the whitened residuals as W (p_bar - p_k) at the current iterate p_k, they make each
Gauss-Newton step minimise the linearised J, and (A^T A)^-1 of the stacked system is
(H^T R^-1 H + P_bar^-1)^-1, the covariance of the combination. The deviation is measured from
p_bar, never from the current iterate (which would reset the prior at each step).

:func:`visviva.fit_orbit` uses it for the epoch state (``apriori_covariance=``, the covariance
of ``initial``) and for the planned Δv of an estimated burn with an execution covariance; the
force-model coefficients' a priori sigmas (``parameter_sigma=``) are the one-column case
(:func:`visviva.od.parameters.prior_rows`).
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError

__all__ = ["whitening", "state_covariance", "state_prior", "maneuver_priors", "with_priors"]

#: directions of a covariance with a variance below this fraction of the largest (after
#: scaling) are held by a variance of that size instead of an infinite weight
FLOOR = 1e-12


def whitening(c, scale=None):
    """W with W^T W = C^-1: the rows that whiten a deviation of covariance C.

    Parameters
    ----------
    c : ndarray (n, n)
        Symmetric positive semi-definite covariance.
    scale : ndarray (n,), optional
        Per-component scales (e.g. the standard deviations) by which C is divided before its
        eigen-decomposition, so that components in different units (km and km/s) weigh alike;
        none: C is decomposed as it is (components in one unit).

    Returns
    -------
    ndarray (n, n)
        W = diag(1/scale) applied after Lambda^-1/2 V^T of the scaled C = V Lambda V^T, the
        eigenvalues below ``FLOOR`` of the largest raised to that size (a direction of zero
        variance is held by a variance 1e-12 of the largest rather than refused).
    """
    s = np.ones(c.shape[0]) if scale is None else np.asarray(scale, dtype=np.float64)
    lam, vec = np.linalg.eigh(c / np.outer(s, s))
    lam = np.maximum(lam, FLOOR * lam[-1])
    return (vec.T / np.sqrt(lam)[:, None]) / s[None, :]


def state_covariance(covariance, name="covariance"):
    """A 6 x 6 position-velocity covariance read as the filter and the fit read it: km-based
    plain numbers (km^2, km^2/s, km^2/s^2; a covariance visviva returned as it is) or an area
    Quantity (the whole matrix in that length unit and seconds); symmetric, positive
    semi-definite."""
    from .._covariance import as_covariance, check_shape, require_psd

    P = as_covariance(covariance, name, length_unit="km", sizes=(6,))
    check_shape(P, name)
    require_psd(P, name)
    return P


def state_prior(covariance):
    """The a priori of the epoch state (``fit_orbit(apriori_covariance=)``): (P_bar, W), P_bar
    km-based and W its whitening (scaled by the standard deviations, so that a correlation of
    +-1 between components, a singular P_bar, is held rather than refused)."""
    P = state_covariance(covariance, "apriori_covariance")
    d = np.diag(P)
    if np.any(d == 0):
        k = int(np.flatnonzero(d == 0)[0])
        comp = ("x", "y", "z", "vx", "vy", "vz")[k]
        raise InvalidInputError(
            f"apriori_covariance[{k}, {k}] is zero: it says that {comp} of the initial state is "
            "known exactly, which a least-squares fit cannot weigh. Give that component its "
            "(small) variance, or leave apriori_covariance out to fit the data alone.")
    return P, whitening(P, np.sqrt(d))


def maneuver_priors(burns, chosen):
    """(first column, W, Δv_plan) for each estimated burn with an execution covariance C: W (3, 3)
    with W^T W = C^-1 (eigen-directions of C below 1e-12 of its largest variance given that
    much); the burn's Δv columns follow the 6 of the state, 3 per estimated burn."""
    out = []
    for j, (burn, i) in enumerate(zip(burns, chosen, strict=True)):
        c = burn.execution_covariance
        if c is None:
            continue
        if not np.linalg.eigvalsh(c)[-1] > 0:
            raise InvalidInputError(
                f"maneuvers[{i}] ({burn!r}) has a zero execution covariance: its Δv is known, so "
                "leave it out of estimate_maneuvers (or give its uncertainty).")
        out.append((6 + 3 * j, whitening(c), burn.delta_v_km_s))
    return out


def with_priors(A, b, priors, p, n_par):
    """The whitened system (A, b) with the rows W (p_bar - p) of each a priori
    (first column, W, p_bar) appended; ``p`` the current iterate of all ``n_par`` unknowns."""
    rows_a, rows_b = [A], [b]
    for col, w, value in priors:
        k = w.shape[1]
        extra = np.zeros((w.shape[0], n_par))
        extra[:, col:col + k] = w
        rows_a.append(extra)
        rows_b.append(w @ (value - p[col:col + k]))
    return np.vstack(rows_a), np.concatenate(rows_b)
