"""Collision probability of many conjunctions at once (Foster or Chan, one kernel call).

:func:`collision_probabilities` is :func:`~visviva.conjunctions.collision_probability` over
stacked inputs (thousands of CDMs, Monte Carlo draws of a screening): units are converted once
per array, each row's encounter plane and checks are those of the scalar function (the same
helpers, so the same projection, CARA clip, repair rule and accuracy checks), and the 2-D
integrals of all rows run in one parallel kernel call. Warnings are gathered: one per kind,
naming how many rows and which.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from .._covariance import as_covariance, npd_position
from .._units import is_quantity
from ..errors import ConvergenceError, InvalidInputError, ShapeError
from .accuracy import check_2d, check_chan, check_tca
from .covariance import (
    ZERO_SPEED,
    encounter_frames,
    plane_of_frame,
    warn_km_as_metres,
)
from .pc2d import FOSTER_RTOL, check_plane
from .probability import gm_m3_s2, refuse_local_axes, si_value, warn_plane_repair

__all__ = ["collision_probabilities", "BATCH_METHODS"]

#: the methods of :func:`collision_probabilities` (the others integrate each encounter in time
#: or sample it: loop over :func:`~visviva.conjunctions.collision_probability`)
BATCH_METHODS = ("foster", "chan")

#: rows named in an error or a gathered warning before "..."
_SHOWN = 5


def _rows(idx) -> str:
    idx = [int(i) for i in idx]
    shown = ", ".join(str(i) for i in idx[:_SHOWN])
    return f"row{'s' if len(idx) > 1 else ''} {shown}{', ...' if len(idx) > _SHOWN else ''}"


def _bad_rows(name, arr, what, fix):
    """Refuse ``arr`` where a row (leading axis) holds a bad value, naming the rows."""
    bad = np.nonzero(what(arr.reshape(arr.shape[0], -1)).any(axis=1))[0] if arr.ndim else (
        [0] if what(arr) else [])
    if len(bad):
        raise InvalidInputError(f"{name}: {_rows(bad)} {fix}.")


def _not_finite(a):
    return ~np.isfinite(a)


def _states(value, unit, name):
    arr = si_value(value, unit, name, check_finite=False)
    if arr.shape == (3,):
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ShapeError(f"{name} must be stacked 3-vectors, shape (K, 3) (or one (3,) for all "
                         f"rows); got shape {arr.shape}.")
    _bad_rows(name, arr, _not_finite, "hold NaN or infinite values; drop or fill them")
    return arr


def _covariances(value, name):
    refuse_local_axes(value, name)
    try:
        raw = np.asarray(value.value if is_quantity(value) else value, dtype=np.float64)
    except (TypeError, ValueError):
        raw = None  # as_covariance says what is wrong
    if raw is not None and raw.ndim == 3:
        _bad_rows(name, raw, _not_finite, "hold NaN or infinite entries; fill them first")
    c = as_covariance(value, name, convert_marked=True)
    if c.ndim == 2:
        c = c[None]
    if c.ndim != 3:
        raise ShapeError(f"{name} must be stacked 6x6 or 3x3 matrices, shape (K, 6, 6) or "
                         f"(K, 3, 3) (or one matrix for all rows); got {c.shape}.")
    return c


def _radii(value):
    hbr = si_value(value, "m", "hard_body_radius", check_finite=False)
    if hbr.ndim > 1:
        raise ShapeError(f"hard_body_radius must be one radius or one per row, shape (K,); got "
                         f"{hbr.shape}.")
    hbr = np.atleast_1d(hbr)
    _bad_rows("hard_body_radius", hbr, np.isnan, "are NaN")
    _bad_rows("hard_body_radius", hbr, lambda a: a < 0, "are negative (a radius is >= 0 m)")
    return hbr


def _common_length(arrays):
    sizes = {name: len(a) for name, a in arrays.items() if len(a) != 1}
    if len(set(sizes.values())) > 1:
        raise ShapeError(f"the inputs must have one length K (or 1, broadcast over K); got "
                         f"{sizes}.")
    return next(iter(sizes.values()), 1)


def _row(a, i):
    return a[0] if len(a) == 1 else a[i]


def _gather(records, rows, k):
    """Issue one warning per kind (category) for the ``records`` caught row by row."""
    kinds = {}
    for rec, i in zip(records, rows, strict=True):
        kinds.setdefault(rec.category, []).append((i, rec))
    for category, hits in kinds.items():
        idx = sorted({i for i, _ in hits})
        first_row, first = hits[0]
        warnings.warn(
            f"{len(idx)} of {k} conjunctions ({_rows(idx)}) gave a {category.__name__}; "
            f"row {first_row}: {first.message}", category, stacklevel=3)


def collision_probabilities(r1, v1, cov1, r2, v2, cov2, hard_body_radius, *, method="foster",
                            log=False, gm=None):
    """Collision probabilities of K conjunctions, one value per row.

    Parameters
    ----------
    r1, r2 : Quantity or array_like, shape (K, 3) or (3,)
        Positions at TCA in one inertial frame (plain numbers: m); one (3,) vector is used for
        every row.
    v1, v2 : Quantity or array_like, shape (K, 3) or (3,)
        Velocities at TCA (plain numbers: m/s).
    cov1, cov2 : array_like, shape (K, 6, 6), (K, 3, 3), (6, 6) or (3, 3)
        Covariances in that frame (plain: m^2, m^2/s, m^2/s^2; or area Quantities), one per row
        or one for all rows.
    hard_body_radius : Quantity or float or array_like, shape (K,)
        Combined radius (plain: m), one per row or one for all; 0 gives 0, ``inf`` 1.
    method : {"foster", "chan"}
        As in :func:`~visviva.conjunctions.collision_probability` (see :data:`BATCH_METHODS`).
    log : bool
        Return ``ln Pc`` (keeps values below 1e-308).
    gm : Quantity or Body, optional
        Attractor for the short-encounter check (default: the Earth).

    Returns
    -------
    ndarray, shape (K,)
        Pc per row (dimensionless), or ``ln Pc``: bit for bit what ``collision_probability``
        gives for that row.

    Warns
    -----
    CovarianceRepairWarning, ChanAccuracyWarning, Pc2dAccuracyWarning, UserWarning
        The warnings of :func:`~visviva.conjunctions.collision_probability`, gathered: one per
        kind, saying how many rows and which (the first few) and giving the first row's message.

    Raises
    ------
    InvalidInputError
        A method other than ``"foster"`` or ``"chan"`` (loop over ``collision_probability``);
        rows with NaN or infinite states or covariances, a NaN or negative HBR, or a zero
        relative velocity: the message names the rows.
    ShapeError
        Inputs that are not (K, 3) / (K, 6, 6) / (K, 3, 3) / (K,) or do not share one K.
    ConvergenceError
        A Foster integral did not reach its accuracy (the rows are named).

    Notes
    -----
    Each row goes through the scalar function's helpers (``encounter_plane`` with NASA CARA's
    clip at ``(1e-4 HBR)^2``, its non-PSD check, ``check_chan``, ``check_tca``, ``check_2d``);
    only the integrals are batched, in one ``prange`` kernel call
    (:func:`visviva.core.collision.log_pc_many`, :func:`~visviva.core.collision.log_pc_chan_many`)
    that runs the scalar kernel per row, so the values are identical. ``"3d"``,
    ``"pc3d_hall"`` and ``"monte_carlo"`` integrate or sample each encounter on its own
    (0.1-1 s each): they are refused, with the loop to write instead. The first call compiles the
    kernels (``visviva warmup`` does it once).

    Examples
    --------
    >>> import numpy as np
    >>> from visviva.conjunctions import collision_probabilities
    >>> r1 = [[7.0e6, 0.0, 0.0], [7.0e6, 0.0, 0.0]]
    >>> v1 = [0.0, 7.5e3, 0.0]
    >>> r2 = [[7.0e6 + 100.0, 0.0, 0.0], [7.0e6 + 900.0, 0.0, 0.0]]
    >>> v2 = [0.0, 0.0, 7.5e3]
    >>> cov = np.diag([200.0, 200.0, 200.0]) ** 2
    >>> pc = collision_probabilities(r1, v1, cov, r2, v2, cov, 20.0)
    >>> [f"{p:.4g}" for p in pc]
    ['0.002346', '1.59e-05']
    """
    if method not in BATCH_METHODS:
        raise InvalidInputError(
            f"collision_probabilities computes method 'foster' or 'chan', got {method!r}: the "
            "other methods integrate or sample each encounter on its own; loop over "
            "vv.collision_probability(..., method=...) row by row.")
    r1q, v1q, r2q, v2q = r1, v1, r2, v2
    r1, v1, r2, v2 = (_states(x, unit, name) for x, unit, name in (
        (r1, "m", "r1"), (v1, "m/s", "v1"), (r2, "m", "r2"), (v2, "m/s", "v2")))
    c1, c2 = _covariances(cov1, "cov1"), _covariances(cov2, "cov2")
    hbr = _radii(hard_body_radius)
    k = _common_length({"r1": r1, "v1": v1, "r2": r2, "v2": v2, "cov1": c1, "cov2": c2,
                        "hard_body_radius": hbr})
    plain = not any(is_quantity(x) for x in (r1q, v1q, r2q, v2q))
    gm_m = gm_m3_s2(gm)
    hbr = np.broadcast_to(hbr, (k,))
    lp = np.full(k, -math.inf)  # HBR 0: Pc = 0 (the scalar function computes no plane)
    lp[np.isinf(hbr)] = 0.0
    live = np.nonzero(hbr > 0)[0]
    todo = np.nonzero((hbr > 0) & np.isfinite(hbr))[0]
    r, v = np.broadcast_to(r1 - r2, (k, 3))[live], np.broadcast_to(v1 - v2, (k, 3))[live]
    a = np.broadcast_to(c1[:, :3, :3] + c2[:, :3, :3], (k, 3, 3))[live]
    basis, cp, rm, vn = encounter_frames(r, v, a)
    if not np.all(vn > 0):
        raise InvalidInputError(f"{_rows(live[~(vn > 0)])}: {ZERO_SPEED}")
    npd_in = np.broadcast_to(npd_position(c1) | npd_position(c2), (k,))
    planes = {}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rows = []
        for j, i in enumerate(live):  # each row's plane and CARA clip, as the scalar function's
            start = len(caught)
            try:
                planes[i] = plane_of_frame(basis[j], cp[j], float(rm[j]), float(vn[j]), hbr[i])
            except InvalidInputError as exc:
                raise InvalidInputError(f"row {i}: {exc}") from exc
            if math.isfinite(hbr[i]):
                warn_plane_repair(bool(npd_in[i]), planes[i], stacklevel=2)
            rows += [i] * (len(caught) - start)
        xm, zm, sx, sz = (np.array([planes[i].principal_miss[0] for i in todo]),
                          np.array([planes[i].principal_miss[1] for i in todo]),
                          np.array([planes[i].sigma[0] for i in todo]),
                          np.array([planes[i].sigma[1] for i in todo]))
        for j, i in enumerate(todo):
            check_plane(xm[j], zm[j], sx[j], sz[j], hbr[i], method)
        lp[todo] = _integrals(xm, zm, sx, sz, np.ascontiguousarray(hbr[todo]), method, todo)
        units, tca, short = _suspects(r1, v1, c1, r2, v2, c2, hbr, gm_m, k, todo, planes,
                                      plain)
        chan = np.zeros(k, dtype=bool)
        if method == "chan" and len(todo):
            from .batch_checks import chan_rows

            chan[todo] = chan_rows(lp[todo], xm, zm, sx, sz, np.ascontiguousarray(hbr[todo]))
        for i in np.nonzero(units | tca | short | chan)[0]:  # the scalar path's checks
            start = len(caught)
            args = (_row(r1, i), _row(v1, i), _row(c1, i), _row(r2, i), _row(v2, i),
                    _row(c2, i), float(hbr[i]))
            if units[i]:
                warn_km_as_metres(args[0], args[1], args[3], args[4])
            if i in planes and math.isfinite(hbr[i]):
                if chan[i]:
                    check_chan(float(lp[i]), *planes[i].principal_miss, *planes[i].sigma,
                               args[6])
                if tca[i]:
                    check_tca(method, args[0], args[1], args[3], args[4], planes[i], args[6])
                if short[i]:
                    check_2d(float(lp[i]), method, *args, gm_m)
            rows += [i] * (len(caught) - start)
    _gather(caught, rows, k)
    # math.exp, as the scalar function (numpy's SIMD exp may differ in the last bit)
    return lp if log else np.array([math.exp(x) for x in lp])


def _suspects(r1, v1, c1, r2, v2, c2, hbr, gm_m, k, todo, planes, plain):
    """Per row (K bools each): may the scalar function's unit warning, its TCA check, its
    short-encounter check warn? Computed on the stacked arrays (:mod:`.batch_checks`); only
    those rows run the scalar checks (~0.3 ms a row), which decide by their own arithmetic.
    Every row ran them before (3.8 s at K = 10,000; audit54)."""
    from .batch_checks import km_as_metres_rows, off_tca_rows, short_encounter_rows

    def full(a, shape):
        return np.ascontiguousarray(np.broadcast_to(a, (k, *shape)))

    s1, s2 = (full(x, (3,)) for x in (r1, r2))
    u1, u2 = (full(x, (3,)) for x in (v1, v2))
    units = km_as_metres_rows(s1, u1, s2, u2) if plain else np.zeros(k, dtype=bool)
    tca = np.zeros(k, dtype=bool)
    short = np.zeros(k, dtype=bool)
    if len(todo):
        by = np.array([planes[i].basis[1] for i in todo])
        sz = np.array([planes[i].sigma[1] for i in todo])
        tca[todo] = off_tca_rows(s1[todo], u1[todo], s2[todo], u2[todo], by, sz, hbr[todo])
        short[todo] = short_encounter_rows(
            s1[todo], u1[todo], full(c1, c1.shape[1:])[todo], s2[todo], u2[todo],
            full(c2, c2.shape[1:])[todo], np.asarray(hbr[todo], dtype=np.float64), gm_m)
    return units, tca, short


def _integrals(xm, zm, sx, sz, hbr, method, rows):
    """``ln Pc`` of the planes, one kernel call; clipped at 0 as :func:`log_pc_2d` clips."""
    from ..core import collision as kern

    out = np.empty(len(xm))
    if method == "chan":
        kern.log_pc_chan_many(xm, zm, sx, sz, hbr, out)
    else:
        status = np.zeros(len(xm), dtype=np.int64)
        kern.log_pc_many(xm, zm, sx, sz, hbr, kern.GAUSS_LO, kern.GAUSS_HI, FOSTER_RTOL, out,
                         status)
        if status.any():
            raise ConvergenceError(
                f"the Foster integral did not reach {FOSTER_RTOL:g} relative accuracy for "
                f"{_rows(rows[status != 0])}; report these cases (or compute them one by one "
                "with collision_probability).")
    return np.minimum(out, 0.0)
