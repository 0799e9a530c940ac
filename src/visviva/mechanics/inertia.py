"""Inertia tensors: point masses, uniform solids, the parallel-axis theorem, principal axes.

All functions take plain numbers in consistent units or astropy Quantities (converted to SI);
with any Quantity input, results come back as SI Quantities.
"""

from __future__ import annotations

import numpy as np

from ..errors import ShapeError
from ._inputs import Inputs, require_physical_inertia, require_symmetric

__all__ = [
    "inertia_tensor",
    "inertia_solid_sphere",
    "inertia_spherical_shell",
    "inertia_solid_cylinder",
    "inertia_thin_rod",
    "inertia_box",
    "parallel_axis",
    "principal_axes",
]


# --------------------------------------------------------------------------- inertia tensors
# The solids (sphere, shell, cylinder, rod, box) broadcast over arrays of bodies: arrays of
# masses or sizes give one (3, 3) tensor per body, shape (..., 3, 3).
def inertia_tensor(masses, positions, origin=None):
    """Inertia tensor of point masses about ``origin``.

    Parameters
    ----------
    masses : (N,) array_like or Quantity
        Masses [kg], >= 0 (a scalar for a single particle).
    positions : (N, 3) array_like or Quantity
        Positions [m] ((3,) for a single particle).
    origin : (3,) array_like or Quantity, optional
        Reference point [m]; the coordinate origin by default. Pass the centre of mass for the
        central inertia tensor.

    Returns
    -------
    I : (3, 3) ndarray or Quantity
        I_jk = sum_i m_i (‖r_i‖^2 delta_jk - r_ij r_ik) [kg m^2], symmetric.

    Raises
    ------
    ShapeError
        positions not (N, 3), or masses not (N,).
    DomainError
        Negative masses.

    Notes
    -----
    Goldstein, Poole & Safko, *Classical Mechanics*, 3rd ed. (2002), eq. 5.7.

    Examples
    --------
    >>> I = inertia_tensor([1.0, 1.0], [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    >>> print(I.diagonal())
    [0. 2. 2.]
    """
    ins = Inputs()
    m = ins.get(masses, "kg", "masses", nonnegative=True)
    r = ins.vector(positions, "m", "positions")
    if r.ndim == 1:
        r = r[None, :]
    if r.ndim != 2:
        raise ShapeError(f"positions must have shape (N, 3); got {r.shape}.")
    m = np.broadcast_to(m, (r.shape[0],)) if m.ndim == 0 else m
    if m.shape != (r.shape[0],):
        raise ShapeError(
            f"masses must have shape (N,) = ({r.shape[0]},) to match positions; got {m.shape}."
        )
    if origin is not None:
        o = ins.vector(origin, "m", "origin")
        if o.shape != (3,):
            raise ShapeError(f"origin must be one point, shape (3,); got {o.shape}.")
        r = r - o
    with np.errstate(over="ignore", invalid="ignore"):
        r2 = np.einsum("i,ij,ij->", m, r, r)
        I = r2 * np.eye(3) - np.einsum("i,ij,ik->jk", m, r, r)
    return ins.out(ins.finite(0.5 * (I + I.T), "inertia_tensor"), "inertia")


def _solid(values, names, ins, context):
    arrays = [
        ins.get(v, unit, n, nonnegative=True) for v, (n, unit) in zip(values, names, strict=True)
    ]
    ins.broadcast(context, **{n: a for (n, _), a in zip(names, arrays, strict=True)})
    return arrays


def _diagonal_tensor(ins, context, **moments):
    """(..., 3, 3) tensors diag(Ixx, Iyy, Izz) broadcast over the bodies, as SI output.

    ``np.diag`` and ``m * np.eye(3)`` took a batch of bodies for the axes of one tensor: three
    spheres of masses 1, 2, 3 gave the single tensor diag(0.4, 0.8, 1.2).
    """
    shape = ins.broadcast(context, **moments)
    diagonal = np.stack([np.broadcast_to(m, shape) for m in moments.values()], axis=-1)
    return ins.out(diagonal[..., None] * np.eye(3), "inertia")


def inertia_solid_sphere(mass, radius):
    """Central inertia tensor of a uniform solid sphere: (2/5) m R^2 on the diagonal [kg m^2]."""
    ins = Inputs()
    m, R = _solid((mass, radius), (("mass", "kg"), ("radius", "m")), ins, "inertia_solid_sphere")
    a = 0.4 * m * R**2
    return _diagonal_tensor(ins, "inertia_solid_sphere", Ixx=a, Iyy=a, Izz=a)


def inertia_spherical_shell(mass, radius):
    """Central inertia tensor of a thin uniform spherical shell: (2/3) m R^2 [kg m^2]."""
    ins = Inputs()
    m, R = _solid((mass, radius), (("mass", "kg"), ("radius", "m")), ins,
                  "inertia_spherical_shell")
    a = (2.0 / 3.0) * m * R**2
    return _diagonal_tensor(ins, "inertia_spherical_shell", Ixx=a, Iyy=a, Izz=a)


def inertia_solid_cylinder(mass, radius, height):
    """Central inertia tensor of a uniform solid cylinder with its axis along z [kg m^2].

    I_xx = I_yy = m (3 R^2 + h^2) / 12, I_zz = m R^2 / 2.
    """
    ins = Inputs()
    m, R, h = _solid(
        (mass, radius, height), (("mass", "kg"), ("radius", "m"), ("height", "m")), ins,
        "inertia_solid_cylinder",
    )
    a = m * (3 * R**2 + h**2) / 12.0
    return _diagonal_tensor(ins, "inertia_solid_cylinder", Ixx=a, Iyy=a, Izz=0.5 * m * R**2)


def inertia_thin_rod(mass, length):
    """Central inertia tensor of a thin uniform rod along z: diag(m L^2/12, m L^2/12, 0)."""
    ins = Inputs()
    m, L = _solid((mass, length), (("mass", "kg"), ("length", "m")), ins, "inertia_thin_rod")
    a = m * L**2 / 12.0
    return _diagonal_tensor(ins, "inertia_thin_rod", Ixx=a, Iyy=a, Izz=0.0 * a)


def inertia_box(mass, a, b, c):
    """Central inertia tensor of a uniform box with edges a, b, c along x, y, z [kg m^2].

    diag(m (b^2 + c^2), m (a^2 + c^2), m (a^2 + b^2)) / 12.
    """
    ins = Inputs()
    m, a, b, c = _solid((mass, a, b, c), (("mass", "kg"), ("a", "m"), ("b", "m"), ("c", "m")), ins,
                        "inertia_box")
    return _diagonal_tensor(ins, "inertia_box", Ixx=m * (b**2 + c**2) / 12.0,
                            Iyy=m * (a**2 + c**2) / 12.0, Izz=m * (a**2 + b**2) / 12.0)


def parallel_axis(I_cm, mass, displacement):
    """Parallel-axis (Steiner) theorem: inertia about a point displaced by d from the centre of mass.

    Parameters
    ----------
    I_cm : (3, 3) array_like or Quantity
        Inertia tensor about the centre of mass [kg m^2].
    mass : float or Quantity
        Total mass [kg].
    displacement : (3,) array_like or Quantity
        d = (centre of mass) - (new reference point) [m] (only d d^T enters, so the sign is
        immaterial).

    Returns
    -------
    (3, 3) ndarray or Quantity
        I = I_cm + m (‖d‖^2 1 - d d^T) [kg m^2] (Goldstein 3rd ed. eq. 5.17).
    """
    ins = Inputs()
    I = ins.get(I_cm, "inertia", "I_cm")
    if I.shape != (3, 3):
        raise ShapeError(f"I_cm must have shape (3, 3); got {I.shape}.")
    require_symmetric(I, "I_cm")
    require_physical_inertia(np.linalg.eigvalsh(0.5 * (I + I.T)), "I_cm", "parallel_axis")
    m = ins.get(mass, "kg", "mass", nonnegative=True)
    d = ins.vector(displacement, "m", "displacement")
    if d.shape != (3,) or m.ndim:
        raise ShapeError(
            "parallel_axis shifts one inertia tensor: displacement must have shape (3,) and mass "
            f"be a scalar; got shapes {d.shape} and {m.shape}. Call it once per reference point."
        )
    return ins.out(I + m * (np.dot(d, d) * np.eye(3) - np.outer(d, d)), "inertia")


def principal_axes(I):
    """Principal moments (ascending) and principal axes of an inertia tensor.

    Parameters
    ----------
    I : (3, 3) array_like or Quantity
        Symmetric inertia tensor [kg m^2].

    Returns
    -------
    moments : (3,) ndarray or Quantity
        Principal moments I1 <= I2 <= I3 [kg m^2].
    axes : (3, 3) ndarray
        Orthonormal principal axes as columns, right-handed (det = +1), so ``axes`` is the
        rotation matrix from the principal (body) frame to the frame of ``I``:
        ``axes.T @ I @ axes = diag(moments)``.
    """
    ins = Inputs()
    I = ins.get(I, "inertia", "I")
    if I.shape != (3, 3):
        raise ShapeError(f"I must have shape (3, 3); got {I.shape}.")
    require_symmetric(I, "I")
    moments, axes = np.linalg.eigh(0.5 * (I + I.T))
    require_physical_inertia(moments, "I", "principal_axes")
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    return ins.out(moments, "inertia"), axes
