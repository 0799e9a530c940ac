"""The 6 x 6 position-velocity covariance as CCSDS writes it: 21 lower-triangle keywords.

Keyword ``C<row>_<column>`` over (X, Y, Z, X_DOT, Y_DOT, Z_DOT), e.g. ``CX_X``, ``CY_DOT_X``,
``CZ_DOT_Z_DOT``; units km**2 (position-position), km**2/s (velocity-position), km**2/s**2
(velocity-velocity). The OEM's KVN writes the same lower triangle as six rows of 1..6 numbers.
"""

from __future__ import annotations

import warnings

import numpy as np

from .._covariance import _symmetric, not_psd
from ..errors import InvalidInputError
from .grammar import CCSDSFormatError, Keyword
from .orbit_frames import READ_NAMES, FrameSpec, frame_spec, inverse_jacobian, jacobian

__all__ = ["AXES", "COVARIANCE_KEYWORDS", "matrix_from_values", "values_from_matrix",
           "matrix_from_rows", "check_variance", "check_record_variances", "warn_not_positive_definite",
           "on_state_axes",
           "ORBIT_RELATIVE_FRAMES", "local_frame", "from_state_axes", "sun_from"]

AXES = ("X", "Y", "Z", "X_DOT", "Y_DOT", "Z_DOT")


#: SANA's orbit-relative reference frames (the ``COV_REF_FRAME`` values of CCSDS 502.0-B-3)
#: visviva reads: name -> (axes, rotating). ``*_INERTIAL`` is the quasi-inertial form (the
#: velocity block rotated like the position block), ``*_ROTATING`` takes the frame's rotation
#: into the velocity block (:func:`visviva.ccsds.orbit_frames.jacobian`). The plain names
#: RTN/RSW/RIC/QSW, TNW, NTW, VNB/VNC are read quasi-inertial, as the CDM defines RTN
#: (docs/design.md, "RTN / TNW covariances"). Axes: :mod:`visviva.ccsds.orbit_frames`.
ORBIT_RELATIVE_FRAMES = {name: (spec.kind, spec.rotating) for name, spec in
                         ((n, frame_spec(n)) for n in READ_NAMES) if "_" in name}


def local_frame(name) -> FrameSpec | None:
    """The :class:`~visviva.ccsds.orbit_frames.FrameSpec` of a local orbital frame named in a
    message, None for another name.

    Parameters
    ----------
    name : str
        ``COV_REF_FRAME`` as written: a SANA name (``RSW_ROTATING``, ``LVLH_INERTIAL``,
        ``PQW_INERTIAL`` ...) or a plain one (``RTN``, ``RSW``, ``RIC``, ``QSW``, ``TNW``,
        ``NTW``, ``VNB``, ``VNC``: quasi-inertial).

    Returns
    -------
    FrameSpec or None

    Raises
    ------
    InvalidInputError
        A name whose axes are ambiguous or not built (plain ``LVLH``, ``SEZ_*``).
    """
    return frame_spec(name)


def _local_names() -> str:
    return ", ".join(READ_NAMES)


def _rotation(spec, r, v, gm, sun) -> np.ndarray:
    """The 6 x 6 Jacobian of ``spec`` at (r, v), fetching the GM and the Sun only when needed
    (``gm`` and ``sun`` may be callables)."""
    gm_value = (gm() if callable(gm) else gm) if spec.needs_gm else None
    sun_value = None
    if spec.needs_sun:
        if sun is None:
            raise InvalidInputError("the NSW axes need the Sun's position at the epoch: give "
                                    "sun=(position km, velocity km/s) from the central body.")
        sun_value = sun() if callable(sun) else sun
    return jacobian(spec, np.asarray(r, dtype=np.float64), np.asarray(v, dtype=np.float64),
                    gm_value, sun_value)


def _unit(i: int, j: int) -> str:
    return ("km**2", "km**2/s", "km**2/s**2")[(i >= 3) + (j >= 3)]


#: the 21 keywords in CCSDS order (row by row of the lower triangle)
COVARIANCE_KEYWORDS = tuple(
    Keyword(f"C{AXES[i]}_{AXES[j]}", "float", _unit(i, j), True)
    for i in range(6) for j in range(i + 1))
_INDEX = tuple((i, j) for i in range(6) for j in range(i + 1))


def matrix_from_values(values) -> np.ndarray:
    """The symmetric 6 x 6 matrix from a mapping of the 21 keywords.

    Parameters
    ----------
    values : mapping
        ``CX_X`` ... ``CZ_DOT_Z_DOT`` -> float (km, km/s based units).

    Returns
    -------
    ndarray, shape (6, 6)
    """
    return matrix_from_rows([values[k.name] for k in COVARIANCE_KEYWORDS])


def matrix_from_rows(lower) -> np.ndarray:
    """The symmetric 6 x 6 matrix from the 21 lower-triangle numbers, row by row.

    Parameters
    ----------
    lower : sequence of float
        21 numbers.

    Returns
    -------
    ndarray, shape (6, 6)
    """
    m = np.zeros((6, 6))
    for (i, j), value in zip(_INDEX, lower, strict=True):
        m[i, j] = m[j, i] = value
    return m


def values_from_matrix(matrix) -> dict:
    """The 21 keywords of a 6 x 6 matrix (its lower triangle).

    Parameters
    ----------
    matrix : array_like, shape (6, 6)
        Covariance in km and km/s.

    Returns
    -------
    dict
    """
    m = np.asarray(matrix, dtype=np.float64)
    return {k.name: float(m[i, j]) for k, (i, j) in zip(COVARIANCE_KEYWORDS, _INDEX, strict=True)}


def check_variance(value: float, axis: int, line, source: str) -> None:
    """Raise unless a diagonal element (a variance) is >= 0.

    Parameters
    ----------
    value : float
        The variance as read (km**2 or km**2/s**2).
    axis : int
        0..5 over (X, Y, Z, X_DOT, Y_DOT, Z_DOT).
    line : int or None
        Line it was read from, for the message.
    source : str
        File name, for the message.
    """
    if value < 0:
        name = f"C{AXES[axis]}_{AXES[axis]}"
        raise CCSDSFormatError(
            f"{name} = {value!r} is a variance (the square of a standard deviation) and cannot be "
            "negative; the covariance is corrupted (check the sign and the row order)",
            line=line, source=source)


def check_record_variances(record, source: str) -> None:
    """:func:`check_variance` on the six diagonal keywords of a section as read.

    Parameters
    ----------
    record : Record
        The covariance section (``CX_X`` ... ``CZ_DOT_Z_DOT``), with its lines.
    source : str
        File name, for the message.
    """
    for axis, a in enumerate(AXES):
        key = f"C{a}_{a}"
        if key in record:
            check_variance(record[key], axis, record.line_of(key), source)


def warn_not_positive_definite(blocks, source: str, stacklevel: int = 4) -> None:
    """Warn (once) when a covariance as read is not positive semi-definite; keep it as written.

    The test (:func:`visviva._covariance.not_psd`) is the one
    :func:`visviva.conjunctions.collision_probability` applies before
    repairing a covariance (the position block's eigenvalues down to -1e-10 of the largest, the
    correlation matrix's down to -1e-3), so rounding-level negatives of tabulated values stay
    silent, and a matrix that ``propagate_covariance`` would refuse, or the Pc code repair, is
    flagged when the file is read.

    Parameters
    ----------
    blocks : iterable of (ndarray (6, 6), int or None)
        Each covariance (km, km/s based units) with the line its block starts on.
    source : str
        File name, for the message.
    stacklevel : int
        Passed to :func:`warnings.warn` (the default points at the caller of ``read_oem``).
    """
    bad = [(m, line) for m, line in blocks if not_psd(m, full=True)]
    if not bad:
        return
    m, line = bad[0]
    d = np.sqrt(np.abs(np.diag(m)))
    d = np.where(d > 0, d, 1.0)
    corr = m / np.outer(d, d)
    off = np.abs(corr - np.diag(np.diag(corr)))
    i, j = sorted(np.unravel_index(int(np.argmax(off)), off.shape), reverse=True)
    where = f"line {line}" if line is not None else "a block"
    more = f" ({len(bad) - 1} more such block{'s' if len(bad) > 2 else ''} in the file)" \
        if len(bad) > 1 else ""
    warnings.warn(
        f"{source}: the covariance at {where} is not positive semi-definite{more}: its "
        f"correlation matrix has smallest eigenvalue {np.linalg.eigvalsh(corr)[0]:.3g} and "
        f"largest correlation |C{AXES[i]}_{AXES[j]}| / (sigma sigma) = {off[i, j]:.3g} (a "
        "correlation lies in [-1, 1]). Kept as written; propagate_covariance refuses it and "
        "collision_probability repairs it: check the covariance source (a wrong row order or "
        "unit?).", UserWarning, stacklevel=stacklevel)


def on_state_axes(matrix, cov_frame, ref_frame, state_frame, r, v, where, raw, gm=None,
                  sun=None):
    """A covariance written in ``COV_REF_FRAME = cov_frame`` on the axes of its state.

    An orbit-relative frame of the state (:mod:`visviva.ccsds.orbit_frames`: the plain
    ``RTN``/``RSW``/``RIC``/``QSW``, ``TNW``, ``NTW``, ``VNB``/``VNC`` and SANA's ``*_INERTIAL``
    quasi-inertial, SANA's ``*_ROTATING`` with the frame's rotation in the velocity block) is
    rotated to the state's axes; ``REF_FRAME`` itself, or another name of the same axes, is
    kept.

    Parameters
    ----------
    matrix : ndarray (6, 6)
        The covariance as written (km, km/s).
    cov_frame : str or None
        ``COV_REF_FRAME`` (None: ``REF_FRAME``).
    ref_frame : str
        The message's ``REF_FRAME``.
    state_frame : str or None
        visviva's name of ``REF_FRAME`` (``"itrs"`` for Earth-fixed axes).
    r, v : ndarray (3,)
        The state the local frame belongs to (km, km/s).
    where : str
        Where the keyword is, for messages (source, line, keyword).
    raw : str
        How the user reaches the matrix as written, for messages.
    gm : float or callable, optional
        The central body's GM (km^3/s^2), or a function giving it; asked for only by the
        frames that need it (``PQW_INERTIAL``, ``TNW/NTW/VNC/NSW_ROTATING``).
    sun : tuple or callable, optional
        The Sun's position (km) and velocity (km/s) from the central body on the state's axes,
        or a function giving them (:func:`sun_from`); ``NSW_*`` only.

    Returns
    -------
    ndarray (6, 6)

    Raises
    ------
    InvalidInputError
        Another frame than ``REF_FRAME`` and no local frame, a local frame of a state on
        Earth-fixed axes (ITRF, GRC, TDR, GTOD ...: its velocity does not give the orbital
        axes), an ambiguous name (plain ``LVLH``), or axes the state does not define
        (``PQW_INERTIAL`` of a circular orbit, ``EQW_INERTIAL`` of a retrograde equatorial one).
    """
    if cov_frame is None or str(cov_frame).strip().upper() == str(ref_frame).strip().upper():
        return matrix
    from .timeframes import earth_fixed, visviva_frame

    key = str(cov_frame).strip().upper()
    try:
        local = local_frame(key)
    except InvalidInputError as exc:
        raise InvalidInputError(f"{where}: {exc}") from None
    if local is None:
        if visviva_frame(key) is not None and visviva_frame(key) == state_frame:
            from .timeframes import from_gcrs_axes, to_gcrs_axes

            # (EME2000 / GCRF / ICRF: the GCRS axes up to the frame bias, applied here)
            return from_gcrs_axes(ref_frame, *to_gcrs_axes(key, matrix))[0]
        raise InvalidInputError(
            f"{where} is neither REF_FRAME = {ref_frame} nor a local orbital frame "
            f"({_local_names()}); rotate {raw} to the state's axes yourself.")
    if state_frame == "itrs" or earth_fixed(ref_frame):  # (GRC, TDR, GTOD: Earth-fixed too)
        raise InvalidInputError(
            f"{where} of a state on Earth-fixed axes ({ref_frame}): its Earth-fixed velocity "
            f"does not give the orbital axes; rotate the state and {raw} to an inertial frame "
            "first.")
    try:
        m = inverse_jacobian(_rotation(local, r, v, gm, sun))
    except InvalidInputError as exc:
        raise InvalidInputError(f"{where}: {exc}") from None
    return _symmetric(m @ np.asarray(matrix, dtype=np.float64) @ m.T)


def from_state_axes(matrix, cov_frame, r, v, gm=None, sun=None) -> np.ndarray:
    """A covariance on the axes of its state written in local frame ``cov_frame`` (the inverse
    of :func:`on_state_axes`, for writing ``COV_REF_FRAME = cov_frame``).

    Parameters
    ----------
    matrix : ndarray (6, 6)
        Covariance on the state's (inertial) axes, km and km/s.
    cov_frame : str
        A local orbital frame (:func:`local_frame`): ``RTN``, ``TNW``, ``RSW_ROTATING``,
        ``LVLH_INERTIAL``, ``PQW_INERTIAL`` ...
    r, v : ndarray (3,)
        The state (km, km/s).
    gm, sun : optional
        As for :func:`on_state_axes`.

    Returns
    -------
    ndarray (6, 6)

    Raises
    ------
    InvalidInputError
        ``cov_frame`` names no local orbital frame, or one the state does not define.
    """
    local = local_frame(cov_frame)
    if local is None:
        raise InvalidInputError(f"covariance_frame = {cov_frame!r} is not a local orbital "
                                f"frame; use one of {_local_names()} (or None: the state's "
                                "axes).")
    m = _rotation(local, r, v, gm, sun)
    return _symmetric(m @ np.asarray(matrix, dtype=np.float64) @ m.T)


def sun_from(epoch, center, ref_frame):
    """A function giving the Sun's position (km) and velocity (km/s) from ``center`` at
    ``epoch`` on the axes of ``ref_frame`` (the NSW axes' Sun), refusing frames whose axes are
    not the ICRF's (EME2000, GCRF, ICRF: the same within 23 mas).

    Parameters
    ----------
    epoch : astropy.time.Time or callable
        The covariance's epoch (or a function giving it).
    center : str
        ``CENTER_NAME``.
    ref_frame : str
        ``REF_FRAME`` of the state.

    Returns
    -------
    callable
    """
    def get():
        from astropy import units as u

        from ..satellites.ephemeris import position_velocity
        from .timeframes import center_body, visviva_frame

        if visviva_frame(ref_frame) != "gcrs":
            raise InvalidInputError(
                f"the NSW axes need the Sun on the state's axes; visviva has it on ICRF axes "
                f"(EME2000, GCRF, ICRF), not on REF_FRAME = {ref_frame}")
        body = center_body(center)
        if body is None:
            raise InvalidInputError(f"the NSW axes need the Sun seen from CENTER_NAME = "
                                    f"{center}, a body visviva does not know")
        t = epoch() if callable(epoch) else epoch
        p, vel = position_velocity("sun", t, body)
        return p.to_value(u.km), vel.to_value(u.km / u.s)

    return get
