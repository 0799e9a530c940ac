"""Covariance matrices: the checks every reader of one applies, and rotations to local frames.

One owner for what the satellites layer (:func:`visviva.propagate_covariance`) and the layers
above it (conjunctions, CCSDS messages, orbit determination) all need: a covariance given as an
array or an area Quantity, checked for shape, finiteness and symmetry
(:func:`as_covariance`), optionally for positive semi-definiteness (:func:`require_psd`), and
rotated between an inertial frame and a local orbital frame of the state (RTN, TNW, VNB: the
axes of :mod:`visviva.core.local_frames`) by :func:`to_local` / :func:`from_local`.
"""

from __future__ import annotations

import numpy as np

from .errors import InvalidInputError, ShapeError

__all__ = ["as_covariance", "require_psd", "not_psd", "npd_position", "block_rotation", "to_local",
           "from_local", "frame_code", "KilometreCovariance", "km_covariance", "local_axes_of",
           "in_frame"]


class KilometreCovariance(np.ndarray):
    """A covariance array in km and km/s (km^2, km^2/s, km^2/s^2) that remembers its unit.

    It is a plain ndarray in every use, except that :func:`as_covariance` (with
    ``convert_marked``, where the unit matters) reads it in km: a
    covariance from :func:`visviva.fit_orbit`, :func:`visviva.propagate_covariance` or
    :func:`visviva.filter_orbit` passed as it is to a function that reads plain arrays in m^2
    (:func:`visviva.collision_probability`, the CDM builder) is converted, not read as m^2
    (which would shrink it 10^6 times). Indexing and slicing keep the mark; any arithmetic
    (``P * 1e6``, ``R @ P @ R.T``) gives a plain array, read by the documented convention of
    the function it is passed to.
    """

    covariance_length_unit = "km"
    #: the local orbital frame whose axes the matrices are on (``"RTN"``, ``"TNW"`` ... from
    #: ``propagate_covariance(..., output_frame=...)``), None on the inertial axes of the state;
    #: kept by indexing, so that a CCSDS writer never takes an RTN matrix for an inertial one
    covariance_axes = None

    def __array_finalize__(self, obj):
        self.covariance_axes = getattr(obj, "covariance_axes", None)

    def __array_wrap__(self, array, context=None, return_scalar=False):
        plain = np.asarray(array).view(np.ndarray)
        return plain[()] if return_scalar else plain

    def __repr__(self):
        return repr(self.view(np.ndarray))

    def __str__(self):
        return str(self.view(np.ndarray))


def km_covariance(arr, axes: str | None = None) -> KilometreCovariance:
    """``arr`` (km, km/s) marked as a :class:`KilometreCovariance` (on the axes of the local
    frame ``axes``, ``"RTN"`` ..., or None: the state's inertial axes, ``"GCRS"``)."""
    out = np.asarray(arr, dtype=np.float64).view(KilometreCovariance)
    out.covariance_axes = None if axes is None or str(axes).upper() == "GCRS" else str(axes)
    return out


def local_axes_of(cov, covariance_frame=None, where: str = "") -> str | None:
    """The local frame a covariance from visviva is on (``"RTN"`` ...), None when inertial or
    not marked (:class:`KilometreCovariance`); a ``covariance_frame`` that names another frame
    is refused (``where``: the function, for the message), as the matrix is not on its axes."""
    axes = getattr(cov, "covariance_axes", None)
    if axes is not None and covariance_frame is not None \
            and str(covariance_frame).strip().upper() != axes.upper():
        raise InvalidInputError(
            f"{where}: this covariance is on the {axes} axes (propagate_covariance(..., "
            f"output_frame={axes!r}) or fit.propagate(..., output_frame={axes!r})), but "
            f"covariance_frame = {covariance_frame!r}; pass covariance_frame={axes!r} (it is "
            f"written as COV_REF_FRAME = {axes}), or propagate with output_frame="
            f"{str(covariance_frame).upper()!r}.")
    return axes


def as_covariance(cov, name: str = "cov", *, length_unit: str = "m",
                  convert_marked: bool = False, sizes: tuple = (6, 3)) -> np.ndarray:
    """A covariance as a float64 array ``(..., 6, 6)`` or ``(..., 3, 3)``, checked.

    Parameters
    ----------
    cov : array_like or Quantity
        Plain numbers are taken as given (in ``length_unit`` and seconds: m^2, m^2/s, m^2/s^2
        by the CCSDS convention); a :class:`KilometreCovariance` (what visviva's orbit
        determination and covariance propagation return) is converted from km where
        ``convert_marked``. A Quantity must have an area unit; it is converted to
        ``length_unit`` squared (for a 6 x 6 array the whole matrix is scaled by the same
        factor, i.e. it is read in the length unit of the Quantity and seconds).
    name : str
        The argument's name for messages.
    length_unit : str
        The length unit of the result (``"m"`` or ``"km"``).
    convert_marked : bool
        True where the numbers' unit matters (a collision probability against a hard-body
        radius, a CDM's m^2 fields): a :class:`KilometreCovariance` is converted from km.
        False (default) where it does not (rotations, linear propagation): the numbers are
        taken as they are, so the result keeps the unit the caller gave.
    sizes : tuple of int
        The matrix sizes the caller takes (default 6 and 3); others are refused, naming these.

    Returns
    -------
    ndarray
        The symmetrised matrix ``(C + C^T) / 2``.

    Raises
    ------
    ShapeError
        Not a square 3 x 3 or 6 x 6 matrix on the last two axes.
    InvalidInputError
        NaN or infinite entries, or a matrix that is not symmetric (to 1e-8 of its largest entry).
    """
    from ._units import is_quantity

    plain = f"{length_unit}^2, {length_unit}^2/s, {length_unit}^2/s^2"
    marked = getattr(cov, "covariance_length_unit", None) if convert_marked else None
    if marked is not None and marked != length_unit:
        # a covariance visviva returned in km (fit_orbit, propagate_covariance, filter_orbit)
        factor = {"km": 1e3, "m": 1.0}[marked] / {"km": 1e3, "m": 1.0}[length_unit]
        cov = np.asarray(cov).view(np.ndarray) * factor**2
    if is_quantity(cov):
        from astropy import units as u

        from .errors import UnitsError

        try:
            arr = np.array(cov.to_value(u.Unit(length_unit) ** 2), dtype=np.float64)
        except u.UnitConversionError as exc:
            raise UnitsError(
                f"{name} has unit '{cov.unit}'; a covariance Quantity needs an area unit "
                f"(e.g. {length_unit}**2), or pass a plain array in {plain}."
            ) from exc
    else:
        try:
            arr = np.array(cov, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(
                f"{name} must be a numeric {' or '.join(f'{k}x{k}' for k in sizes)} array "
                f"(in {plain})."
            ) from exc
    if arr.ndim < 2 or arr.shape[-1] != arr.shape[-2] or arr.shape[-1] not in sizes:
        # the sizes the caller takes (a state's a priori: 6x6 only; audit20)
        allowed = " or ".join(f"{k}x{k}" for k in sizes)
        raise ShapeError(f"{name} must be {allowed} on its last two axes; got {arr.shape}.")
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(f"{name} contains NaN or infinite entries; fill them first.")
    scale = np.max(np.abs(arr)) if arr.size else 0.0
    if scale > 0 and np.max(np.abs(arr - np.swapaxes(arr, -1, -2))) > 1e-8 * scale:
        raise InvalidInputError(
            f"{name} is not symmetric; a covariance must equal its transpose "
            "(symmetrise it with (C + C.T) / 2 if the asymmetry is round-off)."
        )
    return 0.5 * (arr + np.swapaxes(arr, -1, -2))


def npd_position(c):
    """Whether the position block of each covariance ``c`` (..., n, n) is not positive
    semi-definite beyond round-off (its smallest eigenvalue below -1e-10 of its largest)."""
    w = np.linalg.eigvalsh(c[..., :3, :3])
    return w[..., 0] < -1e-10 * np.maximum(np.abs(w[..., -1]), 1e-300)


def not_psd(c, full=False) -> bool:
    """True when ``c`` is not positive semi-definite: its position block, or (``full``, for
    the methods that use the velocities too) also the whole matrix, tested on its correlation
    matrix so that m^2 beside m^2/s^2 hides no negative eigenvalue, down to -1e-3: the
    rounding of tabulated covariances leaves a few 1e-5 (CARA's Alfano case 6, symmetrised),
    a CDM's four or five digits up to ~1e-3, and the flux integrals clip at each time anyway."""
    if npd_position(c):
        return True
    if full and c.shape[-1] == 6:
        d = np.sqrt(np.abs(np.diag(c)))
        d = np.where(d > 0, d, 1.0)
        return bool(np.linalg.eigvalsh(c / np.outer(d, d))[0] < -1e-3)
    return False


def require_psd(cov: np.ndarray, name: str = "cov", tol: float = 1e-10) -> None:
    """Refuse a covariance (square, symmetric) that is not positive semi-definite.

    The test is on the correlation matrix ``D^-1/2 C D^-1/2`` (``D`` the diagonal), so that
    position variances in km^2 next to velocity variances in km^2/s^2 do not hide a negative
    eigenvalue: its smallest eigenvalue must be >= ``-tol``. A zero variance needs a zero row.

    Parameters
    ----------
    cov : ndarray, shape (n, n)
        The matrix (any consistent units).
    name : str
        The argument's name for messages.
    tol : float
        Round-off allowed on the correlation matrix's eigenvalues.

    Raises
    ------
    InvalidInputError
        A negative variance, a correlation above 1, or a negative eigenvalue.
    """
    d = np.diag(cov).copy()
    if np.any(d < 0):
        k = int(np.argmin(d))
        raise InvalidInputError(
            f"{name}[{k}, {k}] = {d[k]:.6g} is a negative variance; a covariance has variances "
            ">= 0 on its diagonal (check the units and the order x, y, z, vx, vy, vz)."
        )
    zero = d == 0
    if np.any(np.abs(cov[zero]) > 0):
        k = int(np.flatnonzero(zero)[0])
        raise InvalidInputError(
            f"{name}[{k}, {k}] is 0 but its row is not: a component without uncertainty cannot "
            "be correlated with another; the matrix is not positive semi-definite."
        )
    s = np.where(zero, 1.0, np.sqrt(d))
    corr = cov / np.outer(s, s)
    lam = float(np.linalg.eigvalsh(corr)[0])
    if lam < -tol:
        raise InvalidInputError(
            f"{name} is not positive semi-definite (the smallest eigenvalue of its correlation "
            f"matrix is {lam:.3g}); a covariance must have eigenvalues >= 0. Check its "
            "correlations, or repair it (e.g. clip negative eigenvalues) before propagating."
        )


def frame_code(frame: str, name: str = "frame") -> int:
    """The local-frame code of :mod:`visviva.core.local_frames` for ``frame`` (0: inertial).

    Parameters
    ----------
    frame : str
        ``"GCRS"`` (also ``"GCRF"``, ``"ICRF"``, ``"INERTIAL"``: the inertial frame of the
        states) or a local frame: ``"RTN"`` (``"RSW"``, ``"RIC"``, ``"QSW"``), ``"TNW"``,
        ``"VNB"``; case-insensitive. ``"EME2000"`` (``"J2000"``) is refused: its axes differ
        from the GCRS by the 23 mas frame bias, which is applied where CCSDS messages are read
        (``opm.covariance``, ``seg.covariance(k)``) or by
        ``visviva.ccsds.timeframes.to_gcrs_axes("EME2000", cov)``.
    name : str
        The argument's name for messages.

    Returns
    -------
    int
    """
    from .core.local_frames import FRAME_CODES, INERTIAL

    key = str(frame).strip().upper()
    if key in ("GCRS", "GCRF", "ICRF", "INERTIAL"):
        return INERTIAL
    if key in ("EME2000", "J2000"):  # (the bias is not a local frame: the caller turns it)
        from .core.local_frames import EME2000_NOTE

        raise InvalidInputError(f"{name} = {frame!r}: {EME2000_NOTE}, and give 'GCRS'.")
    if key not in FRAME_CODES:
        raise InvalidInputError(
            f"{name} = {frame!r}: use 'GCRS' (inertial, the states' frame) or a local frame "
            f"of the state: {', '.join(sorted(FRAME_CODES))}."
        )
    return FRAME_CODES[key]


def block_rotation(m: np.ndarray, n: int) -> np.ndarray:
    """``m`` (..., 3, 3) for a 3 x 3 covariance, ``blockdiag(m, m)`` (..., 6, 6) for a 6 x 6."""
    if n == 3:
        return m
    out = np.zeros(m.shape[:-2] + (6, 6))
    out[..., :3, :3] = m
    out[..., 3:, 3:] = m
    return out


def to_local(cov, r_km, v_km_s, code: int) -> np.ndarray:
    """``M C M^T``: an inertial covariance (..., n, n) on the axes of local frame ``code``.

    ``M = blockdiag(Q, Q)`` with ``Q`` the frame's axes as rows
    (:func:`visviva.core.local_frames.local_axes`); the velocity block is rotated like the
    position block, ignoring the frame's rotation (the convention of the CCSDS CDM and of NASA
    CARA); the result is symmetrised. (The rotating frames of a CCSDS ``COV_REF_FRAME``,
    ``*_ROTATING``, are :func:`visviva.ccsds.orbit_frames.jacobian`.) Code 0 (inertial)
    returns ``cov`` unchanged.
    """
    if code == 0:
        return cov
    from .core.local_frames import local_axes

    m = block_rotation(local_axes(r_km, v_km_s, code), cov.shape[-1])
    return _symmetric(m @ cov @ np.swapaxes(m, -1, -2))


def from_local(cov, r_km, v_km_s, code: int) -> np.ndarray:
    """``M^T C M``: a covariance on the axes of local frame ``code`` back to inertial axes
    (the inverse of :func:`to_local`)."""
    if code == 0:
        return cov
    from .core.local_frames import local_axes

    m = np.swapaxes(block_rotation(local_axes(r_km, v_km_s, code), cov.shape[-1]), -1, -2)
    return _symmetric(m @ cov @ np.swapaxes(m, -1, -2))


def _symmetric(c):
    """``(C + C^T) / 2``: a rotated covariance, symmetric to the bit."""
    return 0.5 * (c + np.swapaxes(c, -1, -2))


def check_shape(cov: np.ndarray, name: str) -> None:
    """Refuse anything but one 6 x 6 matrix."""
    if cov.shape != (6, 6):
        raise ShapeError(
            f"{name} must be one 6x6 position-velocity covariance (x, y, z, vx, vy, vz); got "
            f"shape {cov.shape}."
        )


def in_frame(out, p, out_name):
    """``out`` (a GCRS :class:`~visviva.satellites.covariance.CovarianceResult`) with its
    covariance set to the GCRS covariances ``p`` (T, 6, 6) rotated to ``out_name``'s axes."""
    code = frame_code(out_name, "output_frame")
    r = np.atleast_2d(out.r.to_value("km"))
    v = np.atleast_2d(out.v.to_value("km/s"))
    out.frame = "GCRS" if code == 0 else str(out_name).upper()
    out.covariance = km_covariance(to_local(np.reshape(p, (-1, 6, 6)), r, v, code)
                                   .reshape(p.shape), out.frame)
    return out
