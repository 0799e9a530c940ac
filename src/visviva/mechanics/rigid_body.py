"""Rigid bodies: Euler angles (3-1-3), Euler's equations, tops (inertia tensors: inertia.py).

Conventions
-----------
* The attitude is the rotation matrix R that takes body-frame vectors to the reference (space)
  frame: v_space = R v_body. With 3-1-3 Euler angles R = Rz(phi) Rx(theta) Rz(psi), identical to
  ``scipy.spatial.transform.Rotation.from_euler('ZXZ', [phi, theta, psi]).as_matrix()``.
* Angular velocity omega and torque in Euler's equations are body-frame components.
* Quaternions are scipy's (x, y, z, w), scalar last.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..errors import DomainError, InvalidInputError, ShapeError, fmt_number
from ._inputs import (
    Inputs,
    callable_result,
    ivp_failure,
    ivp_method,
    require_physical_inertia,
    require_symmetric,
)

__all__ = [
    "rotation_matrix_313",
    "euler_angles_313",
    "euler_equations",
    "integrate_rigid_body",
    "RigidBodyTrajectory",
    "torque_free_precession_rate",
    "heavy_top_torque",
    "heavy_top_precession_rate",
]


# --------------------------------------------------------------------------- Euler angles
def rotation_matrix_313(phi, theta, psi):
    """Rotation matrix of 3-1-3 (z-x-z) Euler angles, body frame -> reference frame.

    Parameters
    ----------
    phi, theta, psi : float, array_like or Quantity
        Precession, nutation and spin angles [rad] (plain numbers are radians); broadcast.

    Returns
    -------
    R : (..., 3, 3) ndarray
        R = Rz(phi) Rx(theta) Rz(psi), orthogonal with det +1; v_ref = R v_body. Equal to
        ``scipy.spatial.transform.Rotation.from_euler('ZXZ', [phi, theta, psi]).as_matrix()``.

    Notes
    -----
    Goldstein, Poole & Safko (2002) sec. 4.4 write the passive matrix A = R^T (reference ->
    body). Written out (c = cos, s = sin)::

        [ c(phi)c(psi) - s(phi)c(theta)s(psi)  -c(phi)s(psi) - s(phi)c(theta)c(psi)   s(phi)s(theta)]
        [ s(phi)c(psi) + c(phi)c(theta)s(psi)  -s(phi)s(psi) + c(phi)c(theta)c(psi)  -c(phi)s(theta)]
        [ s(theta)s(psi)                        s(theta)c(psi)                         c(theta)     ]

    Examples
    --------
    >>> R = rotation_matrix_313(0.3, 0.2, 0.1)
    >>> print(f"{np.linalg.det(R):.12f}")
    1.000000000000
    """
    ins = Inputs()
    phi = ins.get(phi, "rad", "phi")
    theta = ins.get(theta, "rad", "theta")
    psi = ins.get(psi, "rad", "psi")
    ins.broadcast("rotation_matrix_313", phi=phi, theta=theta, psi=psi)
    phi, theta, psi = np.broadcast_arrays(phi, theta, psi)
    c1, s1 = np.cos(phi), np.sin(phi)
    c2, s2 = np.cos(theta), np.sin(theta)
    c3, s3 = np.cos(psi), np.sin(psi)
    R = np.empty(phi.shape + (3, 3))
    R[..., 0, 0] = c1 * c3 - s1 * c2 * s3
    R[..., 0, 1] = -c1 * s3 - s1 * c2 * c3
    R[..., 0, 2] = s1 * s2
    R[..., 1, 0] = s1 * c3 + c1 * c2 * s3
    R[..., 1, 1] = -s1 * s3 + c1 * c2 * c3
    R[..., 1, 2] = -c1 * s2
    R[..., 2, 0] = s2 * s3
    R[..., 2, 1] = s2 * c3
    R[..., 2, 2] = c2
    return R


def euler_angles_313(R):
    """3-1-3 Euler angles (phi, theta, psi) of a rotation matrix (inverse of rotation_matrix_313).

    Parameters
    ----------
    R : (..., 3, 3) array_like
        Rotation matrices (body -> reference), orthogonal with det +1.

    Returns
    -------
    phi, theta, psi : ndarray
        phi, psi in (-pi, pi], theta in [0, pi] [rad]. At gimbal lock (theta = 0 or pi, where
        only phi +/- psi is defined) psi = 0 is chosen. ``rotation_matrix_313(*euler_angles_313(R))``
        returns R to rounding for every rotation.

    Raises
    ------
    ShapeError
        Not (..., 3, 3).
    InvalidInputError
        R not a proper rotation (max abs(R^T R - 1) > 1e-9 or det < 0).

    Notes
    -----
    theta = atan2(sqrt(R20^2 + R21^2), R22) keeps full accuracy near 0 and pi, where arccos(R22)
    loses half the digits; phi = atan2(R02, -R12). psi comes from the upper 2x2 block:
    psi = (phi + psi) - phi with phi + psi = atan2(R10 - R01, R00 + R11) for theta <= pi/2, and
    psi = phi - (phi - psi) with phi - psi = atan2(R10 + R01, R00 - R11) beyond. Near gimbal lock
    phi carries an error of about eps / sin(theta) from a rounded R, but it moves the elements
    of size sin(theta) by only eps, and the block, which holds the sum (or difference), stays
    exact: the round trip keeps R to rounding at every theta (psi = atan2(R20, R21) alone would
    not: the block would then carry both angles' errors, up to 1e-8 at theta = 1e-8).
    """
    ins = Inputs()
    R = ins.get(R, "one", "R")
    if R.ndim < 2 or R.shape[-2:] != (3, 3):
        raise ShapeError(f"R must have shape (..., 3, 3); got {R.shape}.")
    err = np.abs(np.einsum("...ji,...jk->...ik", R, R) - np.eye(3)).max(initial=0.0)
    if err > 1e-9 or np.any(np.linalg.det(R) < 0):
        raise InvalidInputError(
            "R must be a proper rotation matrix (orthogonal, det +1); "
            f"|R^T R - 1| = {err:.3g}. Orthonormalise it first (e.g. via scipy Rotation)."
        )
    sin_theta = np.hypot(R[..., 2, 0], R[..., 2, 1])
    theta = np.arctan2(sin_theta, R[..., 2, 2])
    # R00 + R11 = (1 + cos theta) cos(phi + psi), R10 - R01 = (1 + cos theta) sin(phi + psi),
    # R00 - R11 = (1 - cos theta) cos(phi - psi), R10 + R01 = (1 - cos theta) sin(phi - psi):
    # phi + psi is well conditioned for theta <= pi/2, phi - psi for theta >= pi/2
    up = R[..., 2, 2] >= 0.0
    total = np.arctan2(R[..., 1, 0] - R[..., 0, 1], R[..., 0, 0] + R[..., 1, 1])
    diff = np.arctan2(R[..., 1, 0] + R[..., 0, 1], R[..., 0, 0] - R[..., 1, 1])
    locked = sin_theta == 0.0  # gimbal lock: only phi + psi (or phi - psi) exists; psi = 0
    phi = np.where(locked, np.where(up, total, diff), np.arctan2(R[..., 0, 2], -R[..., 1, 2]))
    psi = np.where(up, total - phi, phi - diff)
    psi = np.where(psi > np.pi, psi - 2.0 * np.pi, np.where(psi <= -np.pi, psi + 2.0 * np.pi, psi))
    return phi[()], theta[()], psi[()]


# --------------------------------------------------------------------------- Euler's equations
def euler_equations(I, omega, torque=None):
    """Body-frame angular acceleration from Euler's equations, I omega' = tau - omega x (I omega).

    Parameters
    ----------
    I : (3, 3) or (3,) array_like
        Inertia tensor in the body frame (or its principal moments) [kg m^2].
    omega : (..., 3) array_like
        Body-frame angular velocity [rad/s].
    torque : (..., 3) array_like, optional
        Body-frame torque [N m]; zero by default.

    Returns
    -------
    (..., 3) ndarray
        omega' [rad/s^2] (plain array in the units of the inputs).

    Notes
    -----
    Goldstein 3rd ed. eq. 5.39; for principal axes I1 w1' = (I2 - I3) w2 w3 + tau1 and cyclic.
    """
    ins = Inputs()
    I = _body_inertia(ins.get(I, "inertia", "I"))
    w = ins.vector(omega, "angular_rate", "omega")
    tau = np.zeros_like(w) if torque is None else ins.vector(torque, "torque", "torque")
    ins.broadcast("euler_equations", omega=w, torque=tau)
    Iw = w @ I.T
    return np.linalg.solve(I, (tau - np.cross(w, Iw))[..., None])[..., 0]


def _body_inertia(I):
    if I.shape == (3,):
        I = np.diag(I)
    if I.shape != (3, 3):
        raise ShapeError(f"I must be a (3, 3) tensor or 3 principal moments; got {I.shape}.")
    require_symmetric(I, "I")
    moments = np.linalg.eigvalsh(0.5 * (I + I.T))
    if moments[0] <= 0:
        raise DomainError(
            "the inertia tensor must be positive definite for Euler's equations (a rod or a "
            "point has a zero moment and no rotational dynamics about that axis); got principal "
            f"moments {moments}."
        )
    require_physical_inertia(moments, "I", "Euler's equations")
    return 0.5 * (I + I.T)


@dataclass(frozen=True)
class RigidBodyTrajectory:
    """Attitude and body-frame angular velocity of a rigid body at output times.

    Attributes
    ----------
    t : (n,) ndarray
        Times [s].
    quaternions : (n, 4) ndarray
        Unit quaternions (x, y, z, w) of the attitude, body -> reference (scipy convention).
    omega : (n, 3) ndarray
        Body-frame angular velocity [rad/s].
    inertia : (3, 3) ndarray
        Body-frame inertia tensor [kg m^2].
    """

    t: np.ndarray
    quaternions: np.ndarray
    omega: np.ndarray
    inertia: np.ndarray = field(repr=False)

    @cached_property
    def rotation(self):
        """The attitudes as one ``scipy.spatial.transform.Rotation`` (n rotations)."""
        from scipy.spatial.transform import Rotation

        return Rotation.from_quat(self.quaternions)

    @cached_property
    def rotation_matrices(self) -> np.ndarray:
        """(n, 3, 3) matrices R (body -> reference)."""
        return self.rotation.as_matrix()

    @cached_property
    def angular_momentum_body(self) -> np.ndarray:
        """(n, 3) body-frame angular momentum I omega [kg m^2/s]."""
        return self.omega @ self.inertia.T

    @cached_property
    def angular_momentum(self) -> np.ndarray:
        """(n, 3) reference-frame angular momentum R I omega [kg m^2/s] (constant when torque-free)."""
        return np.einsum("nij,nj->ni", self.rotation_matrices, self.angular_momentum_body)

    @cached_property
    def rotational_energy(self) -> np.ndarray:
        """(n,) kinetic energy omega . I omega / 2 [J]."""
        return 0.5 * np.einsum("ni,ni->n", self.omega, self.angular_momentum_body)

    @cached_property
    def euler_angles_313(self):
        """(phi, theta, psi) arrays, each (n,), with phi and psi unwrapped to be continuous."""
        phi, theta, psi = euler_angles_313(self.rotation_matrices)
        return np.unwrap(phi), theta, np.unwrap(psi)


def integrate_rigid_body(
    I,
    omega0,
    t,
    *,
    attitude0=None,
    torque=None,
    rtol: float = 1e-11,
    atol: float = 1e-12,
    method: str = "DOP853",
) -> RigidBodyTrajectory:
    """Integrate Euler's equations together with the attitude quaternion.

    Parameters
    ----------
    I : (3, 3) or (3,) array_like or Quantity
        Body-frame inertia tensor or principal moments [kg m^2] (about the centre of mass, or
        about the fixed point for a top).
    omega0 : (3,) array_like or Quantity
        Initial body-frame angular velocity [rad/s].
    t : (n,) array_like or Quantity
        Increasing output times [s]; the integration starts at ``t[0]``.
    attitude0 : scipy Rotation or (3, 3) array_like, optional
        Initial attitude (body -> reference); identity by default.
    torque : callable, optional
        ``torque(t, R, omega) -> (3,)`` body-frame torque [N m], with R the (3, 3) attitude
        matrix; torque-free if omitted. See :func:`heavy_top_torque`.
    rtol, atol : float
        Tolerances of :func:`scipy.integrate.solve_ivp`.
    method : str
        solve_ivp method (default ``"DOP853"``).

    Returns
    -------
    RigidBodyTrajectory

    Notes
    -----
    State (q, omega) with q' = q (x) (omega, 0) / 2 (quaternion product, body-frame rate) and
    I omega' = tau - omega x I omega (Goldstein 3rd ed. sec. 5.5; Markley & Crassidis,
    *Fundamentals of Spacecraft Attitude Determination and Control*, 2014, eq. 3.20). The
    quaternion is renormalised inside the right-hand side and at output, so its norm never drifts
    into the attitude; outputs are converted with :class:`scipy.spatial.transform.Rotation`.
    """
    from scipy.integrate import solve_ivp
    from scipy.spatial.transform import Rotation

    ins = Inputs()
    Ib = _body_inertia(ins.get(I, "inertia", "I"))
    w0 = ins.vector(omega0, "angular_rate", "omega0")
    if w0.shape != (3,):
        raise ShapeError(f"omega0 must have shape (3,); got {w0.shape}.")
    t = np.atleast_1d(ins.get(t, "s", "t"))
    if t.ndim != 1 or t.size < 1 or np.any(np.diff(t) <= 0):
        raise InvalidInputError("t must be a 1-D array of strictly increasing times.")
    if attitude0 is None:
        q0 = np.array([0.0, 0.0, 0.0, 1.0])
    elif isinstance(attitude0, Rotation):
        q0 = attitude0.as_quat()
    else:
        R0 = ins.get(attitude0, "one", "attitude0")
        if R0.shape != (3, 3):
            raise ShapeError(f"attitude0 must be a (3, 3) rotation matrix; got shape {R0.shape}.")
        if not (np.allclose(R0 @ R0.T, np.eye(3), atol=1e-9) and np.linalg.det(R0) > 0):
            raise InvalidInputError(
                "attitude0 must be a proper rotation matrix (R R^T = I, det R = +1 to 1e-9); "
                "build it with rotation_matrix_313(phi, theta, psi) or pass a scipy Rotation."
            )
        q0 = Rotation.from_matrix(R0).as_quat()
    method = ivp_method(method, "integrate_rigid_body")
    for name, tol in (("rtol", rtol), ("atol", atol)):
        if not (isinstance(tol, float | int) and np.isfinite(tol) and tol > 0):
            raise InvalidInputError(f"{name} must be a finite float > 0; got {fmt_number(tol)}.")
    I_inv = np.linalg.inv(Ib)

    def rhs(time, y):
        q = y[:4] / np.sqrt(y[:4] @ y[:4])
        w = y[4:]
        x, yq, z, s = q
        # q' = 1/2 q (x) (w, 0), scalar-last Hamilton product
        dq = 0.5 * np.array(
            [
                s * w[0] + yq * w[2] - z * w[1],
                s * w[1] + z * w[0] - x * w[2],
                s * w[2] + x * w[1] - yq * w[0],
                -(x * w[0] + yq * w[1] + z * w[2]),
            ]
        )
        tau = 0.0
        if torque is not None:
            # attitude matrix of the unit quaternion (x, y, z, w) = (x, yq, z, s)
            R = np.array(
                [
                    [1 - 2 * (yq * yq + z * z), 2 * (x * yq - z * s), 2 * (x * z + yq * s)],
                    [2 * (x * yq + z * s), 1 - 2 * (x * x + z * z), 2 * (yq * z - x * s)],
                    [2 * (x * z - yq * s), 2 * (yq * z + x * s), 1 - 2 * (x * x + yq * yq)],
                ]
            )
            tau = callable_result(torque(time, R, w), (3,), "torque(t, R, omega)", time,
                                  unit="torque")
        dw = I_inv @ (tau - np.cross(w, Ib @ w))
        return np.concatenate([dq, dw])

    y0 = np.concatenate([q0, w0])
    if t.size == 1:
        Y = y0[:, None]
    else:
        sol = solve_ivp(rhs, (t[0], t[-1]), y0, method=method, t_eval=t, rtol=rtol, atol=atol)
        if not sol.success:
            raise ivp_failure(sol, "integrate_rigid_body", t[-1])
        Y = sol.y
    quats = Y[:4].T / np.linalg.norm(Y[:4].T, axis=1, keepdims=True)
    return RigidBodyTrajectory(t=t, quaternions=quats, omega=Y[4:].T.copy(), inertia=Ib)


def torque_free_precession_rate(I1, I3, omega3):
    """Precession rates of a torque-free symmetric body (I1 = I2 != I3).

    Parameters
    ----------
    I1 : transverse moment [kg m^2]; I3 : symmetry-axis moment [kg m^2];
    omega3 : body-frame spin component along the symmetry axis [rad/s].

    Returns
    -------
    float or Quantity
        Omega_b = (I3 - I1) omega3 / I1 [rad/s]: in the body frame omega circles the symmetry
        axis, w1 + i w2 ~ exp(i Omega_b t).

    Notes
    -----
    Goldstein 3rd ed. sec. 5.6. In the reference frame the symmetry axis cones about the fixed
    angular momentum L at the rate ‖L‖ / I1.
    """
    ins = Inputs()
    I1 = ins.get(I1, "inertia", "I1", positive=True)
    I3 = ins.get(I3, "inertia", "I3", positive=True)
    w3 = ins.get(omega3, "angular_rate", "omega3")
    ins.broadcast("torque_free_precession_rate", I1=I1, I3=I3, omega3=w3)
    I1b, I3b = np.broadcast_arrays(I1, I3)
    require_physical_inertia(np.sort(np.stack([I1b, I1b, I3b], axis=-1), axis=-1),
                             "(I1, I1, I3)", "torque_free_precession_rate")
    return ins.out((I3 - I1) * w3 / I1, "rate")


def heavy_top_torque(mass, g, length):
    """Gravity torque on a top with its fixed point at the origin, for :func:`integrate_rigid_body`.

    Parameters
    ----------
    mass : total mass [kg]; g : gravitational acceleration [m/s^2] along -z of the reference
    frame; length : distance from the fixed point to the centre of mass along the body z axis
    [m].

    Returns
    -------
    callable
        ``torque(t, R, omega)`` giving the body-frame torque R^T (r_cm x m g) [N m].
    """
    ins = Inputs()
    m = float(ins.get(mass, "kg", "mass", positive=True))
    gg = float(ins.get(g, "accel", "g"))
    ell = float(ins.get(length, "m", "length"))
    weight = np.array([0.0, 0.0, -m * gg])
    arm = np.array([0.0, 0.0, ell])

    def torque(t, R, omega):
        return R.T @ np.cross(R @ arm, weight)

    return torque


def heavy_top_precession_rate(I1, I3, mass, g, length, omega3, theta, *, branch: str = "slow"):
    """Steady precession rate of a heavy symmetric top at fixed tilt theta.

    Parameters
    ----------
    I1 : moment about a transverse axis through the FIXED POINT [kg m^2].
    I3 : moment about the symmetry axis [kg m^2].
    mass, g, length : mass [kg], gravity [m/s^2], fixed point to centre of mass [m].
    omega3 : spin component along the symmetry axis, psi' + phi' cos(theta) [rad/s].
    theta : tilt of the symmetry axis from the upward vertical [rad].
    branch : ``"slow"`` (default) or ``"fast"``.

    Returns
    -------
    float or Quantity
        phi' [rad/s], a root of I1 cos(theta) phi'^2 - I3 omega3 phi' + m g l = 0.

    Raises
    ------
    DomainError
        No steady precession (discriminant < 0: the top spins too slowly), or the fast branch at
        theta = pi/2 (it does not exist).

    Notes
    -----
    Goldstein 3rd ed. sec. 5.7, eq. 5.77. The slow root is written 2 m g l / (I3 w3 + sqrt(D)),
    D = (I3 w3)^2 - 4 I1 cos(theta) m g l, which tends to m g l / (I3 w3) for a fast top and has
    no cancellation.
    """
    ins = Inputs()

    def scalar(value, unit, name, **rule):
        arr = ins.get(value, unit, name, **rule)
        if arr.size != 1:
            raise ShapeError(
                f"heavy_top_precession_rate takes one top: {name} must be a scalar; got shape "
                f"{arr.shape}. Call it once per value."
            )
        return float(arr.reshape(()))

    I1 = scalar(I1, "inertia", "I1", positive=True)
    I3 = scalar(I3, "inertia", "I3", positive=True)
    m = scalar(mass, "kg", "mass", positive=True)
    gg = scalar(g, "accel", "g")
    ell = scalar(length, "m", "length")
    w3 = scalar(omega3, "angular_rate", "omega3")
    th = scalar(theta, "rad", "theta")
    cos_th = np.cos(th)
    # theta within rounding of pi/2 (np.pi / 2 has cos = 6e-17, not 0) is the horizontal axis:
    # the fast branch I3 w3 / (I1 cos theta) would be ~1e18 rad/s instead of the error below
    a = 0.0 if abs(cos_th) <= 4.0 * np.finfo(float).eps else I1 * cos_th
    b = I3 * w3
    c = m * gg * ell
    disc = b * b - 4.0 * a * c
    if disc < 0:
        raise DomainError(
            f"heavy_top_precession_rate: no steady precession, (I3 w3)^2 < 4 I1 cos(theta) m g l "
            f"({b * b:.6g} < {4 * a * c:.6g}). Spin the top faster (larger omega3)."
        )
    root = np.sqrt(disc)
    q = b + np.copysign(root, b) if b != 0 else root
    if branch == "slow":
        if q == 0 and c != 0:  # a = b = 0: c = 0 has no root
            raise DomainError(
                "heavy_top_precession_rate: no steady precession for a top that does not spin "
                "(omega3 = 0) with its axis horizontal."
            )
        rate = 2.0 * c / q if q != 0 else 0.0
    elif branch == "fast":
        if a == 0:
            raise DomainError("the fast precession branch does not exist at theta = pi/2.")
        rate = q / (2.0 * a)
    else:
        raise InvalidInputError(f"branch must be 'slow' or 'fast'; got {branch!r}.")
    return ins.out(rate, "rate")
