"""Covariance tools for conjunction assessment: RTN frames, STM propagation, encounter plane.

Covariances are plain float64 arrays (``(..., 6, 6)`` position-velocity or ``(..., 3, 3)``
position only) in one consistent unit system; the CCSDS CDM and NASA CARA use m, m/s. The
rotations and the state-transition matrix do not depend on the length unit (``dr/dv`` is a time,
``dv/dr`` an inverse time squared), so a covariance in m^2 can be propagated along a state given in
km. States are astropy Quantities (or plain numbers, taken as km and km/s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._containers import warn_implausible_velocity
from .._covariance import as_covariance, block_rotation
from .._units import to_array, to_vector
from ..core.local_frames import RTN, local_axes
from ..errors import InvalidInputError, ShapeError, raise_for_status

__all__ = [
    "rtn_basis",
    "rtn_to_inertial",
    "inertial_to_rtn",
    "state_transition_matrix",
    "propagate_covariance",
    "combined_covariance",
    "EncounterPlane",
    "encounter_plane",
    "principal_axes",
    "as_covariance",
]


def _vec(value, kind, name):
    return to_vector(value, kind, name, allow_plain=True)


def rtn_basis(r, v) -> np.ndarray:
    """The radial / transverse / normal unit vectors as the rows of a rotation matrix.

    Parameters
    ----------
    r : Quantity, shape (..., 3)
        Position (km if plain numbers).
    v : Quantity, shape (..., 3)
        Velocity (km/s if plain numbers).

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``M`` with rows ``R = r/|r|``, ``T = N x R``, ``N = (r x v)/|r x v|``, so that
        ``M @ x_inertial`` gives the RTN components (CCSDS 508.0-B-1 sec. 3.5.2, "RTN"; the
        axes of :mod:`visviva.core.local_frames`).
    """
    r = _vec(r, "length", "r")
    v = _vec(v, "speed", "v")
    h = np.cross(r, v)
    rn = np.linalg.norm(r, axis=-1, keepdims=True)
    hn = np.linalg.norm(h, axis=-1, keepdims=True)
    if np.any(rn == 0) or np.any(hn == 0):
        raise InvalidInputError(
            "the RTN frame needs r != 0 and r not parallel to v (r x v = 0 here)."
        )
    return local_axes(r, v, RTN)


def rtn_to_inertial(cov_rtn, r, v) -> np.ndarray:
    """Rotate a covariance from the RTN frame of the state ``(r, v)`` to the inertial frame.

    Parameters
    ----------
    cov_rtn : array_like, shape (..., 6, 6) or (..., 3, 3)
        Covariance in RTN (any consistent units, e.g. m^2, m^2/s, m^2/s^2).
    r : Quantity, shape (..., 3)
        Position of the object (km if plain).
    v : Quantity, shape (..., 3)
        Velocity of the object (km/s if plain).

    Returns
    -------
    ndarray
        ``M^T C M`` with ``M = blockdiag(Q, Q)``, ``Q`` from :func:`rtn_basis`.

    Notes
    -----
    The velocity block is rotated like the position block, ignoring the frame's rotation rate
    (the convention of the CCSDS CDM and of NASA CARA's ``RIC2ECI``): the RTN velocity
    covariance describes inertial velocity errors expressed on RTN axes.
    """
    c = as_covariance(cov_rtn, "cov_rtn")
    m = block_rotation(rtn_basis(r, v), c.shape[-1])
    return np.swapaxes(m, -1, -2) @ c @ m


def inertial_to_rtn(cov, r, v) -> np.ndarray:
    """Rotate an inertial covariance to the RTN frame of ``(r, v)`` (inverse of
    :func:`rtn_to_inertial`).

    Parameters
    ----------
    cov : array_like, shape (..., 6, 6) or (..., 3, 3)
        Inertial covariance (consistent units).
    r : Quantity, shape (..., 3)
        Position (km if plain).
    v : Quantity, shape (..., 3)
        Velocity (km/s if plain).

    Returns
    -------
    ndarray
        ``M C M^T``.
    """
    c = as_covariance(cov, "cov")
    m = block_rotation(rtn_basis(r, v), c.shape[-1])
    return m @ c @ np.swapaxes(m, -1, -2)


def state_transition_matrix(r, v, dt, gm):
    """The two-body 6 x 6 state-transition matrix ``d(r, v)(t + dt) / d(r, v)(t)``.

    Parameters
    ----------
    r : Quantity, shape (3,)
        Position at the start (km if plain).
    v : Quantity, shape (3,)
        Velocity at the start (km/s if plain).
    dt : Quantity
        Time span (s if plain); negative goes backwards.
    gm : Quantity or Body
        Gravitational parameter (km^3/s^2 if plain).

    Returns
    -------
    phi : ndarray, shape (6, 6)
        The STM in seconds for the ``dr/dv`` block and 1/s^2 for ``dv/dr``; it is independent of
        the length unit.
    r1, v1 : ndarray, shape (3,)
        The propagated state in km and km/s.

    Notes
    -----
    Integrates the variational equations ``Phi' = A Phi``, ``A = [[0, I], [G, 0]]`` with the gravity
    gradient ``G = gm (3 r r^T - r^2 I) / r^5`` (Montenbruck & Gill, *Satellite Orbits*, sec.
    7.2) by fourth-order Runge-Kutta with steps of 1/300 of the local time scale
    r / sqrt(v^2 + 2 gm / r) (3265 per circular orbit, shorter near periapsis); relative accuracy
    against the exact two-body STM 3e-11 (LEO, a day) to 1e-8 (a parabolic periapsis passage),
    on every conic, periapsis passages included.
    """
    from ..core.stm import two_body_stm

    r0 = np.ascontiguousarray(_vec(r, "length", "r"), dtype=np.float64)
    v0 = np.ascontiguousarray(_vec(v, "speed", "v"), dtype=np.float64)
    if r0.shape != (3,) or v0.shape != (3,):
        raise ShapeError(f"r and v must be single 3-vectors; got {r0.shape} and {v0.shape}.")
    dt_s = float(to_array(dt, "time", "dt", allow_plain=True))
    gm_v = float(to_array(gm, "gm", "gm", allow_plain=True))
    if not gm_v > 0:
        raise InvalidInputError(f"gm must be > 0, got {gm_v}.")
    warn_implausible_velocity(r0, v0, gm_v, "state_transition_matrix")
    phi = np.empty((6, 6))
    r1, v1, status = two_body_stm(r0, v0, gm_v, dt_s, phi)
    if status == 1:
        raise InvalidInputError(
            f"state_transition_matrix: dt = {dt_s:.6g} s spans more than 10^8 integration steps "
            "(tens of thousands of revolutions), where a two-body covariance is meaningless and "
            "the integration would take a minute or more. To fix: propagate the covariance over a "
            "shorter span.")
    raise_for_status(status, "two-body STM")
    return phi, r1, v1


def propagate_covariance(cov, r, v, dt, gm) -> np.ndarray:
    """Propagate a 6 x 6 covariance along a two-body orbit: ``Phi C Phi^T``.

    Parameters
    ----------
    cov : array_like, shape (6, 6)
        Inertial position-velocity covariance (m and m/s, or any length unit with seconds).
    r : Quantity, shape (3,)
        Position at the covariance epoch (km if plain).
    v : Quantity, shape (3,)
        Velocity at the covariance epoch (km/s if plain).
    dt : Quantity
        Time span (s if plain).
    gm : Quantity or Body
        Gravitational parameter.

    Returns
    -------
    ndarray, shape (6, 6)
        The covariance at ``t + dt``, same units as ``cov``.
    """
    c = as_covariance(cov, "cov")
    if c.shape != (6, 6):
        raise ShapeError(f"cov must be 6x6 to be propagated; got {c.shape}.")
    phi, _, _ = state_transition_matrix(r, v, dt, gm)
    out = phi @ c @ phi.T
    return 0.5 * (out + out.T)


def combined_covariance(cov1, cov2) -> np.ndarray:
    """The relative-position covariance of two independent objects: ``C1[:3,:3] + C2[:3,:3]``.

    Parameters
    ----------
    cov1, cov2 : array_like, shape (..., 6, 6) or (..., 3, 3)
        Covariances of the two objects in one inertial frame and unit system.

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    c1 = as_covariance(cov1, "cov1")
    c2 = as_covariance(cov2, "cov2")
    return c1[..., :3, :3] + c2[..., :3, :3]


@dataclass(frozen=True)
class EncounterPlane:
    """The short-encounter geometry of a conjunction (NASA CARA's PcCircle convention).

    Attributes
    ----------
    basis : ndarray, shape (3, 3)
        Rows ``x, y, z``: ``y`` along the relative velocity ``v1 - v2``, ``z`` along
        ``(r1 - r2) x (v1 - v2)``, ``x = y x z``; the encounter plane is spanned by ``x, z``.
    miss : ndarray, shape (2,)
        The miss vector in the plane ``(x, z)`` (the full distance ``|r1 - r2|`` along ``x``,
        which assumes the states are at the time of closest approach).
    covariance : ndarray, shape (2, 2)
        The combined position covariance projected on the plane (``x, z`` order).
    sigma : ndarray, shape (2,)
        Square roots of the eigenvalues of ``covariance`` (major first) after the
        non-positive-definite repair.
    principal_miss : ndarray, shape (2,)
        The absolute miss components along the two principal axes (major first).
    angle : float
        Angle of the major axis from ``x`` towards ``z``, rad.
    relative_speed : float
        ``|v1 - v2|`` in the velocity unit of the input.
    repaired : bool
        Whether an eigenvalue was clipped (non-positive-definite repair).
    non_positive_definite : bool
        Whether the projected covariance had an eigenvalue <= 0 before the repair.
    """

    basis: np.ndarray
    miss: np.ndarray
    covariance: np.ndarray
    sigma: np.ndarray
    principal_miss: np.ndarray
    angle: float
    relative_speed: float
    repaired: bool
    non_positive_definite: bool


#: Eigenvalue clipping factor of the CARA repair: eigenvalues below (F * HBR)^2 are raised to it.
CLIP_FACTOR = 1e-4


def encounter_plane(r1, v1, cov1, r2, v2, cov2, hard_body_radius=0.0) -> EncounterPlane:
    """Project a conjunction on its encounter plane (the frame of Foster's 2-D integral).

    Parameters
    ----------
    r1, v1, r2, v2 : ndarray, shape (3,)
        States of the two objects at TCA, plain float64 in one unit system (e.g. m, m/s).
    cov1, cov2 : ndarray, shape (6, 6) or (3, 3)
        Covariances in the same frame and units (squared).
    hard_body_radius : float
        Combined radius in the same length unit; sets the eigenvalue clipping level
        ``(1e-4 HBR)^2`` of the CARA repair.

    Returns
    -------
    EncounterPlane

    Raises
    ------
    InvalidInputError
        Zero relative velocity (no encounter plane), or both eigenvalues non-positive.

    Notes
    -----
    Follows NASA CARA's ``PcCircle`` (Hall et al.): the combined covariance
    ``A = C1 + C2`` (position blocks) is rotated into the encounter frame and its ``x, z`` block
    taken; eigenvalues below ``(1e-4 HBR)^2`` are clipped to that value (Hall, Hejduk & Johnson,
    "Remediating non-positive-definite state covariances for collision probability estimation",
    AAS 17-567, 2017). When ``r1 - r2`` is zero or parallel to the relative velocity, any basis of
    the plane is used (the probability does not depend on it).
    """
    r = np.asarray(r1, dtype=np.float64) - np.asarray(r2, dtype=np.float64)
    v = np.asarray(v1, dtype=np.float64) - np.asarray(v2, dtype=np.float64)
    a = combined_covariance(cov1, cov2)
    basis, cp, rm, vn = encounter_frames(r[None], v[None], a[None])
    if not vn[0] > 0:
        raise InvalidInputError(ZERO_SPEED)
    return plane_of_frame(basis[0], cp[0], float(rm[0]), float(vn[0]), hard_body_radius)


#: the refusal of a conjunction without relative velocity (no encounter plane)
ZERO_SPEED = ("the relative velocity is zero: there is no encounter plane and the short-encounter "
              "probability is undefined; use method='pc3d_hall' (Hall's 3D-Nc, which follows the "
              "objects in time; it needs 6x6 position-velocity covariances).")


def plane_of_frame(basis, cp, rm, vn, hard_body_radius) -> EncounterPlane:
    """The :class:`EncounterPlane` of one row of :func:`encounter_frames` (``basis``, ``cp``,
    ``rm``, ``vn``), with the CARA clip of :func:`principal_axes` at ``(1e-4 HBR)^2``."""
    miss = np.array([rm, 0.0])
    sigma, principal, angle, repaired, npd = principal_axes(miss, cp, hard_body_radius)
    return EncounterPlane(basis=basis, miss=miss, covariance=cp,
                          sigma=sigma, principal_miss=principal, angle=angle,
                          relative_speed=vn, repaired=repaired, non_positive_definite=npd)


def encounter_frames(r, v, a):
    """The encounter frames of K conjunctions (the geometry of :func:`encounter_plane`).

    Parameters
    ----------
    r, v : ndarray, shape (K, 3)
        Relative positions ``r1 - r2`` and velocities ``v1 - v2`` (one unit system).
    a : ndarray, shape (K, 3, 3)
        Combined position covariances (that length unit, squared).

    Returns
    -------
    basis : ndarray, shape (K, 3, 3)
        Rows ``x, y, z`` per conjunction (see :class:`EncounterPlane`); NaN where ``|v| = 0``.
    covariance : ndarray, shape (K, 2, 2)
        ``a`` projected on the plane (``x, z``).
    miss : ndarray, shape (K,)
        ``|r|``.
    relative_speed : ndarray, shape (K,)
        ``|v|`` (the caller refuses 0: no encounter plane).
    """
    vn = np.sqrt(np.sum(v * v, axis=-1))
    rn = np.sqrt(np.sum(r * r, axis=-1))
    with np.errstate(invalid="ignore", divide="ignore"):
        y = v / vn[:, None]
        h = np.cross(r, v)
        hn = np.sqrt(np.sum(h * h, axis=-1))
        # r = 0 or r parallel to v: any unit vector normal to y
        flat = hn <= 1e-12 * np.maximum(rn, 1e-300) * vn
        if flat.any():
            trial = np.eye(3)[np.argmin(np.abs(np.nan_to_num(y[flat])), axis=-1)]
            h[flat] = np.cross(y[flat], trial)
            hn[flat] = np.sqrt(np.sum(h[flat] * h[flat], axis=-1))
        z = h / hn[:, None]
    x = np.cross(y, z)
    basis = np.stack([x, y, z], axis=1)
    full = basis @ a @ np.swapaxes(basis, -1, -2)
    cp = full[:, ::2, ::2].copy()
    return basis, cp, rn, vn


def principal_axes(miss, cov2, hard_body_radius):
    """Principal sigmas and miss components of a 2-D Gaussian, with the CARA eigenvalue clip.

    Parameters
    ----------
    miss : ndarray, shape (2,)
        Miss vector in the plane.
    cov2 : ndarray, shape (2, 2)
        Its covariance (same length unit, squared).
    hard_body_radius : float
        Sets the clipping level ``(1e-4 HBR)^2``.

    Returns
    -------
    sigma : ndarray, shape (2,)
        Major and minor standard deviations after clipping.
    principal_miss : ndarray, shape (2,)
        ``|miss|`` components along the major and minor axes.
    angle : float
        Major axis angle from the first axis, rad.
    repaired : bool
        An eigenvalue was clipped.
    non_positive_definite : bool
        The minor eigenvalue was <= 0 before clipping.
    """
    a11, a12, a22 = float(cov2[0, 0]), float(cov2[0, 1]), float(cov2[1, 1])
    tr = 0.5 * (a11 + a22)
    root = math.hypot(0.5 * (a11 - a22), a12)
    l1 = tr + root
    l2 = tr - root
    angle = 0.5 * math.atan2(2.0 * a12, a11 - a22)
    if not l1 > 0:
        raise InvalidInputError(
            "the combined covariance projected on the encounter plane has no positive "
            f"eigenvalue (eigenvalues {l1:.6g}, {l2:.6g}); check the covariances."
        )
    npd = not l2 > 0
    hbr = float(hard_body_radius)
    clip = (CLIP_FACTOR * hbr) ** 2 if math.isfinite(hbr) else 0.0
    repaired = False
    if l1 < clip:
        l1, repaired = clip, True
    if l2 < clip:
        l2, repaired = clip, True
    l2 = max(l2, 0.0)
    ca, sa = math.cos(angle), math.sin(angle)
    m0, m1 = float(miss[0]), float(miss[1])
    principal = np.array([abs(m0 * ca + m1 * sa), abs(-m0 * sa + m1 * ca)])
    return np.array([math.sqrt(l1), math.sqrt(l2)]), principal, angle, repaired, npd


def warn_km_as_metres(r1, v1, r2, v2):
    """Warn when plain states (read as m, m/s) look like an Earth orbit's km and km/s: both
    objects 6,000 to 500,000 "m" from the origin at 0.5 to 12 "m/s" (inside the Earth, at
    walking pace). Given in km, a LEO conjunction's Pc came out 0.0025 for 0.0019 silently."""
    import warnings

    radii = [float(np.linalg.norm(x)) for x in (r1, r2)]
    speeds = [float(np.linalg.norm(x)) for x in (v1, v2)]
    if all(6e3 <= r <= 5e5 for r in radii) and all(0.5 <= v <= 12.0 for v in speeds):
        warnings.warn(
            f"plain r1, r2, v1, v2 are read as m and m/s: |r1| = {radii[0]:.6g} m and |v1| = "
            f"{speeds[0]:.4g} m/s (and the same for object 2) look like km and km/s of an Earth "
            "orbit. If they are, pass Quantities (r1 * u.km, v1 * u.km / u.s) or multiply by "
            "1000; the covariance stays in m^2 when plain.", UserWarning, stacklevel=4)
