"""Lagrange and Hermite interpolation of tabulated values, vectorised over the query times.

Both use the n + 1 tabulated points nearest to each query time (a window centred on it, clamped
to the ends; Orekit's reading of the CCSDS OEM):

* Lagrange: each component interpolated by the polynomial of degree n through the n + 1 points;
* Hermite: the osculating polynomial of degree 2n + 1 that matches values and first derivatives
  at the n + 1 points, and its derivative.

Every query is computed in one pass of NumPy over the whole array of times (no Python loop over
the queries); times are scaled to the window so the products stay near 1. Users: the OEM
(:mod:`visviva.ccsds.oem`, which names its method and degree) and the screening of ephemerides
(:mod:`visviva.conjunctions.sources`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["windows", "lagrange", "hermite", "hermite_windows"]


def windows(t_nodes: np.ndarray, t_query: np.ndarray, n_points: int) -> np.ndarray:
    """Indices (M, n_points) of the ``n_points`` nodes nearest each query (centred, clamped).

    Parameters
    ----------
    t_nodes : ndarray, shape (N,)
        Node times (s), strictly increasing.
    t_query : ndarray, shape (M,)
        Query times (s).
    n_points : int
        Points per window (at most N).

    Returns
    -------
    ndarray of int, shape (M, n_points)
    """
    n = t_nodes.size
    right = np.searchsorted(t_nodes, t_query, side="right")
    start = np.clip(right - (n_points + 1) // 2, 0, n - n_points)
    return start[:, None] + np.arange(n_points)[None, :]


def _basis(x_nodes: np.ndarray, x: np.ndarray):
    """Lagrange basis values L_j(x) and derivatives L_j'(x); x_nodes (M, K), x (M,)."""
    m, k = x_nodes.shape
    diff = x[:, None] - x_nodes  # (M, K)
    denom = x_nodes[:, :, None] - x_nodes[:, None, :]  # (M, K, K): x_j - x_k
    eye = np.eye(k, dtype=bool)
    denom = np.where(eye, 1.0, denom)
    ratio = np.where(eye, 1.0, diff[:, None, :] / denom)  # (x - x_k)/(x_j - x_k), 1 on k == j
    value = ratio.prod(axis=2)  # (M, K)
    # L_j'(x) = sum_{m != j} 1/(x_j - x_m) prod_{k != j, m} (x - x_k)/(x_j - x_k)
    deriv = np.zeros((m, k))
    for mm in range(k):
        drop = ratio.copy()
        drop[:, :, mm] = 1.0
        term = drop.prod(axis=2) / denom[:, :, mm]
        term[:, mm] = 0.0
        deriv += term
    return value, deriv


def _scaled(t_nodes, t_query, idx):
    x_nodes = t_nodes[idx]
    centre = x_nodes.mean(axis=1)
    scale = np.maximum(x_nodes[:, -1] - x_nodes[:, 0], 1e-300)
    return (x_nodes - centre[:, None]) / scale[:, None], (t_query - centre) / scale, scale


_CHUNK = 32768  # queries per pass: bounds the (M, K, K) work arrays to a few MB


def _chunked(fn, t_query, *args):
    """Run ``fn`` over blocks of the query times and join the results."""
    if t_query.size <= _CHUNK:
        return fn(t_query, *args)
    parts = [fn(t_query[i:i + _CHUNK], *args) for i in range(0, t_query.size, _CHUNK)]
    if isinstance(parts[0], tuple):
        return tuple(None if p[0] is None else np.concatenate(p) for p in zip(*parts,
                                                                             strict=True))
    return np.concatenate(parts)


def lagrange(t_nodes, y_nodes, t_query, degree: int):
    """Lagrange interpolation of degree ``degree`` (values only).

    Parameters
    ----------
    t_nodes : ndarray, shape (N,)
        Node times (s), strictly increasing.
    y_nodes : ndarray, shape (N, D)
        Values at the nodes (any unit).
    t_query : ndarray, shape (M,)
        Query times (s).
    degree : int
        Polynomial degree n >= 1 (n + 1 nodes per query; at most N - 1).

    Returns
    -------
    ndarray, shape (M, D)

    Notes
    -----
    :math:`p(t) = \\sum_j y_j \\prod_{k \\ne j} (t - t_k)/(t_j - t_k)` over the n + 1 nodes nearest
    ``t`` (Press et al., Numerical Recipes, 3rd ed., sec. 3.2).
    """
    def block(tq):
        idx = windows(t_nodes, tq, degree + 1)
        x_nodes, x, _ = _scaled(t_nodes, tq, idx)
        value, _ = _basis(x_nodes, x)
        return np.einsum("mk,mkd->md", value, y_nodes[idx])

    return _chunked(block, np.asarray(t_query, dtype=np.float64))


def hermite(t_nodes, y_nodes, dy_nodes, t_query, degree: int, want_derivative: bool = True):
    """Hermite interpolation through values and first derivatives at n + 1 nodes.

    Parameters
    ----------
    t_nodes : ndarray, shape (N,)
        Node times (s), strictly increasing.
    y_nodes : ndarray, shape (N, D)
        Values at the nodes (e.g. km).
    dy_nodes : ndarray, shape (N, D)
        Their time derivatives (e.g. km/s).
    t_query : ndarray, shape (M,)
        Query times (s).
    degree : int
        n: the window has n + 1 nodes, the polynomial degree 2n + 1.
    want_derivative : bool
        Also return the derivative of the interpolant (units of ``dy_nodes``).

    Returns
    -------
    y : ndarray, shape (M, D)
    dy : ndarray, shape (M, D) or None

    Notes
    -----
    :math:`H(t) = \\sum_j [y_j (1 - 2 L_j'(t_j)(t - t_j)) + y'_j (t - t_j)] L_j(t)^2` with
    :math:`L_j` the Lagrange basis (Burden & Faires, Numerical Analysis, sec. 3.4).
    """
    return _chunked(_hermite_block, np.asarray(t_query, dtype=np.float64), t_nodes, y_nodes,
                    dy_nodes, degree, want_derivative)


def _hermite_block(t_query, t_nodes, y_nodes, dy_nodes, degree, want_derivative):
    return hermite_windows(windows(t_nodes, t_query, degree + 1), t_nodes, y_nodes, dy_nodes,
                           t_query, want_derivative)


def hermite_windows(idx, t_nodes, y_nodes, dy_nodes, t_query, want_derivative: bool = True):
    """:func:`hermite` through given windows of nodes: ``idx`` (M, K) indices into the nodes,
    one window per query time (e.g. a window that leaves out the node at the query, to test
    the interpolation against it). Same units and returns as :func:`hermite`."""
    x_nodes, x, scale = _scaled(t_nodes, t_query, idx)
    value, deriv = _basis(x_nodes, x)
    # L_j'(x_j) = sum_{k != j} 1 / (x_j - x_k)
    d = x_nodes[:, :, None] - x_nodes[:, None, :]
    eye = np.eye(x_nodes.shape[1], dtype=bool)
    lp_at_node = np.where(eye, 0.0, 1.0 / np.where(eye, 1.0, d)).sum(axis=2)  # (M, K)
    dx = x[:, None] - x_nodes  # (M, K)
    y = y_nodes[idx]  # (M, K, D)
    dy = dy_nodes[idx] * scale[:, None, None]  # derivative with respect to scaled time
    a = 1.0 - 2.0 * lp_at_node * dx  # (M, K)
    l2 = value * value
    out = np.einsum("mk,mkd->md", a * l2, y) + np.einsum("mk,mkd->md", dx * l2, dy)
    if not want_derivative:
        return out, None
    dl2 = 2.0 * value * deriv
    da = -2.0 * lp_at_node
    ddt = (np.einsum("mk,mkd->md", da * l2 + a * dl2, y)
           + np.einsum("mk,mkd->md", l2 + dx * dl2, dy))
    return out, ddt / scale[:, None]
