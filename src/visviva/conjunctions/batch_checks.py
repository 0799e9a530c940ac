"""Which rows of a batch of conjunctions need the scalar accuracy checks (whole arrays at once).

:func:`~visviva.conjunctions.collision_probabilities` gives, row for row, the warnings of
:func:`~visviva.conjunctions.collision_probability`. The scalar checks cost ~0.3 ms a row in
numpy calls on 3-vectors and 3x3 matrices (:func:`~.accuracy.check_2d`'s Coppola bounds and
velocity spread, :func:`~.accuracy.check_tca`, :func:`~.covariance.warn_km_as_metres`,
:func:`~.accuracy.check_chan`'s Foster integral), while
almost every row passes them silently. The functions here compute the same quantities on the
stacked arrays and keep the rows that are not clearly silent: those (and only those) run the
scalar check itself, so the warnings are those of the scalar function, decided by its own
arithmetic. "Clearly" means a relative margin of :data:`GATE_MARGIN` beside each cutoff (the
stacked arithmetic may differ from the scalar one in the last bits), and every row with a
non-finite or degenerate value goes to the scalar check.
"""

from __future__ import annotations

import math

import numpy as np

from .accuracy import EXTENDED_LIMIT, OFFSET_LIMIT, SPREAD_LIMIT
from .covariance import CLIP_FACTOR

__all__ = ["short_encounter_rows", "off_tca_rows", "km_as_metres_rows", "chan_rows", "GATE_MARGIN"]

#: relative margin beside each cutoff within which a row goes to the scalar check
GATE_MARGIN = 1e-6

#: Coppola's precision factor (as :func:`~.accuracy.linear_encounter_bounds`)
_GAMMA = 1e-16


def short_encounter_rows(r1, v1, c1, r2, v2, c2, hbr, gm_m, points=25):
    """Rows where :func:`~.accuracy.check_2d` may warn (its gate is not clearly passed).

    Parameters
    ----------
    r1, v1, r2, v2 : ndarray, shape (K, 3)
        States at TCA, m and m/s.
    c1, c2 : ndarray, shape (K, 6, 6) or (K, 3, 3)
        Covariances, m^2 ...
    hbr : ndarray, shape (K,)
        Combined hard-body radii, m (finite, > 0).
    gm_m : float
        Gravitational parameter, m^3/s^2.
    points : int
        Samples of the velocity spread (as :func:`~.accuracy.velocity_spread`).

    Returns
    -------
    ndarray of bool, shape (K,)
        True where the scalar check must run: CARA's indicators ``extended`` or ``offset``
        (:func:`~.accuracy.linear_encounter_bounds`) or the velocity spread
        (:func:`~.accuracy.velocity_spread`) not clearly below their cutoffs, or a degenerate
        row. False where the scalar check returns before computing 3D-Nc.
    """
    from scipy.special import erfcinv

    k = r1.shape[0]
    if k == 0:
        return np.zeros(0, dtype=bool)
    keep = 1.0 - GATE_MARGIN
    floor = np.maximum((CLIP_FACTOR * hbr) ** 2, 1e-300)
    a = c1[:, :3, :3] + c2[:, :3, :3]
    w, vec = np.linalg.eigh(0.5 * (a + np.swapaxes(a, 1, 2)))
    w = np.maximum(w, floor[:, None])
    ainv = (vec / w[:, None, :]) @ np.swapaxes(vec, 1, 2)
    r, u = r2 - r1, v2 - v1
    with np.errstate(all="ignore"):
        uau = np.einsum("ki,kij,kj->k", u, ainv, u)
        t_m = -np.einsum("ki,kij,kj->k", r, ainv, u) / uau
        dtau = math.sqrt(2.0) * float(erfcinv(_GAMMA)) / np.sqrt(uau)
        inv_a = [2.0 / np.linalg.norm(rr, axis=1) - np.sum(vv * vv, axis=1) / gm_m
                 for rr, vv in ((r1, v1), (r2, v2))]
        periods = [np.where(x > 0, 2.0 * math.pi * np.sqrt(x ** -3 / gm_m), np.inf)
                   for x in inv_a]
        p = np.minimum(*periods)
        t_a, t_b = t_m - dtau, t_m + dtau
        extended = 2.0 * dtau / p
        offset = np.maximum(np.abs(t_a), np.abs(t_b)) / p
    relative = ~(np.any(r1 != 0, axis=1) & np.any(r2 != 0, axis=1))  # scalar: no check
    suspect = ~(uau > 0) | ~np.isfinite(p)  # degenerate: let the scalar check decide
    suspect |= ~(extended < EXTENDED_LIMIT * keep) | ~(offset < OFFSET_LIMIT * keep)
    rest = np.nonzero(~suspect & ~relative)[0]
    if rest.size and c1.shape[1:] == (6, 6) and c2.shape[1:] == (6, 6):
        drop, scale = _spread(r[rest], u[rest], (c1 + c2)[rest], floor[rest], t_a[rest],
                              t_b[rest], points)
        suspect[rest] |= ~(drop < SPREAD_LIMIT - GATE_MARGIN * (1.0 + scale))
    return suspect & ~relative


def _spread(r, u, c, floor, t_a, t_b, points):
    """:func:`~.accuracy.velocity_spread` of stacked rows (0 where ``C_rv``, ``C_vv`` are 0),
    and the size of the terms it subtracts (for the margin of its rounding)."""
    a = c[:, :3, :3]
    b = c[:, :3, 3:] + c[:, 3:, :3]
    d = c[:, 3:, 3:]
    frac = np.linspace(0.0, 1.0, points)
    t = t_a[:, None] + (t_b - t_a)[:, None] * frac[None, :]  # (K, points)
    x = r[:, None, :] + t[:, :, None] * u[:, None, :]
    a_t = np.concatenate([a[:, None], a[:, None] + t[:, :, None, None] * b[:, None]
                          + (t * t)[:, :, None, None] * d[:, None]], axis=1)
    w, vec = np.linalg.eigh(a_t)
    w = np.maximum(w, floor[:, None, None])
    with np.errstate(all="ignore"):
        y0 = np.einsum("kti,kij->ktj", x, vec[:, 0])
        y = np.einsum("ktji,ktj->kti", vec[:, 1:], x)
        fixed = np.sum(y0 * y0 / w[:, :1], axis=2)
        spread = (np.sum(y * y / w[:, 1:], axis=2)
                  + np.sum(np.log(w[:, 1:] / w[:, :1]), axis=2))
        low_fixed, low_spread = np.min(fixed, axis=1), np.min(spread, axis=1)
        drop = low_fixed - low_spread
        scale = np.abs(low_fixed) + np.abs(low_spread)
    zero = ~(np.any(b != 0, axis=(1, 2)) | np.any(d != 0, axis=(1, 2)))
    return np.where(zero, 0.0, drop), np.where(zero, 0.0, scale)


def off_tca_rows(r1, v1, r2, v2, basis_y, sigma_z, hbr):
    """Rows where :func:`~.accuracy.check_tca` may warn: ``r1 - r2`` has a component along the
    relative velocity that could move ``ln Pc`` by 0.01 or more (its own gate, with a margin).

    ``basis_y`` (K, 3) is each encounter plane's unit relative velocity, ``sigma_z`` (K,) its
    smaller principal sigma (m); the other arrays as in :func:`short_encounter_rows`.
    """
    r = r1 - r2
    with np.errstate(all="ignore"):
        rn = np.linalg.norm(r, axis=1)
        along = np.sum(r * basis_y, axis=1)
        perp = np.linalg.norm(r - along[:, None] * basis_y, axis=1)
        lhs = (rn - perp) * (rn + hbr)
        clear = lhs < 1e-2 * sigma_z ** 2 * (1.0 - GATE_MARGIN) - GATE_MARGIN * np.abs(lhs)
    return ~clear & (rn != 0)


def km_as_metres_rows(r1, v1, r2, v2):
    """Rows where :func:`~.covariance.warn_km_as_metres` may warn (radii 6,000 to 500,000 and
    speeds 0.5 to 12 in the plain numbers, with a margin)."""
    lo, hi = 1.0 - GATE_MARGIN, 1.0 + GATE_MARGIN
    out = np.ones(r1.shape[0], dtype=bool)
    for x, a, b in ((r1, 6e3, 5e5), (r2, 6e3, 5e5), (v1, 0.5, 12.0), (v2, 0.5, 12.0)):
        n = np.linalg.norm(x, axis=1)
        out &= ~((n < a * lo) | (n > b * hi))  # NaN stays True
    return out


def chan_rows(lp_chan, xm, zm, sx, sz, hbr):
    """Rows where :func:`~.accuracy.check_chan` may warn: Chan's ``ln Pc`` not clearly within
    a factor 1.1 of Foster's integral of the same plane (computed here for all rows in one
    kernel call, the one :func:`~.pc2d.log_pc_2d` runs per row), unless both are negligible.
    Rows whose integral did not converge go to the scalar check (it stays silent there)."""
    from ..core import collision as kern
    from .accuracy import CHAN_LOG_TOL, NEGLIGIBLE_LN_PC
    from .pc2d import FOSTER_RTOL

    lp_foster = np.empty(len(xm))
    status = np.zeros(len(xm), dtype=np.int64)
    kern.log_pc_many(xm, zm, sx, sz, hbr, kern.GAUSS_LO, kern.GAUSS_HI, FOSTER_RTOL,
                     lp_foster, status)
    lp_foster = np.minimum(lp_foster, 0.0)
    with np.errstate(invalid="ignore"):
        silent = ((lp_chan == lp_foster)
                  | (np.abs(lp_chan - lp_foster)
                     < CHAN_LOG_TOL - GATE_MARGIN * (1.0 + np.abs(lp_chan)))
                  | (np.maximum(lp_chan, lp_foster)
                     < NEGLIGIBLE_LN_PC * (1.0 + GATE_MARGIN)))
    return ~silent | (status != 0)
