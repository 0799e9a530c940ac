"""Collisions: 1-D elastic, inelastic (restitution), perfectly inelastic and explosive; 3-D impulse
along the line of centres.

Everything is written in the centre-of-mass frame, v' = v_cm +/- (reduced-mass share) * u', so
that momentum is conserved to rounding for any masses (the centre-of-mass velocity is computed
once and never changed) and the relative velocity obeys u' = -e u exactly.
"""

from __future__ import annotations

import numpy as np

from ..errors import DomainError, InvalidStateError
from ._inputs import Inputs

__all__ = [
    "elastic_collision_1d",
    "inelastic_collision_1d",
    "perfectly_inelastic_collision_1d",
    "explosive_separation_1d",
    "collision_impulse",
    "kinetic_energy",
]


def _restitution(restitution, explosive: bool, ins: Inputs):
    e = ins.get(restitution, "one", "restitution")
    if np.any(e < 0):
        raise DomainError(
            f"restitution must be >= 0; got {float(np.min(e))!r}. Use 0 for a perfectly "
            "inelastic collision, 1 for an elastic one."
        )
    if not explosive and np.any(e > 1):
        raise DomainError(
            f"restitution must lie in [0, 1]; got {float(np.max(e))!r}. A coefficient above 1 "
            "adds kinetic energy: pass explosive=True if that is intended."
        )
    return e


def _masses(m1, m2, ins: Inputs):
    m1 = ins.get(m1, "kg", "m1", positive=True)
    m2 = ins.get(m2, "kg", "m2", positive=True)
    return m1, m2


def inelastic_collision_1d(m1, v1, m2, v2, restitution, *, explosive: bool = False):
    """Velocities after a head-on collision with coefficient of restitution e.

    Parameters
    ----------
    m1, m2 : float, array_like or Quantity
        Masses [kg], > 0.
    v1, v2 : float, array_like or Quantity
        Velocities before [m/s]; everything broadcasts.
    restitution : float or array_like
        e in [0, 1]: 1 elastic, 0 perfectly inelastic; e > 1 only with ``explosive=True``.
    explosive : bool
        Allow e > 1 (kinetic energy added by the collision).

    Returns
    -------
    v1_after, v2_after : ndarray or Quantity
        Velocities after [m/s].

    Notes
    -----
    With M = m1 + m2, v_cm = (m1 v1 + m2 v2) / M and u = v1 - v2:
    v1' = v_cm - e m2 u / M,  v2' = v_cm + e m1 u / M, so that v1' - v2' = -e u and
    m1 v1' + m2 v2' = M v_cm. Kinetic energy lost: (1 - e^2) mu u^2 / 2 with mu = m1 m2 / M
    (Taylor, *Classical Mechanics*, 2005, sec. 14.x; Goldstein 3rd ed. sec. 3.10).
    No positions are given, so whether the bodies approach cannot be checked: the law is
    applied to any velocities (with body 1 on the left they meet only if v1 > v2). Use
    :func:`collision_impulse`, which takes the positions and leaves separating bodies alone,
    when that is not known.
    """
    ins = Inputs()
    m1, m2 = _masses(m1, m2, ins)
    v1 = ins.get(v1, "speed", "v1")
    v2 = ins.get(v2, "speed", "v2")
    e = _restitution(restitution, explosive, ins)
    ins.broadcast("inelastic_collision_1d", m1=m1, v1=v1, m2=m2, v2=v2, restitution=e)
    with np.errstate(over="ignore", invalid="ignore"):
        total = m1 + m2
        w1, w2 = m1 / total, m2 / total
        if not np.all(np.isfinite(total)):  # m1 + m2 overflowed
            w1 = 1.0 / (1.0 + m2 / m1)
            w2 = 1.0 / (1.0 + m1 / m2)
        # v1' = v_cm - e w2 (v1 - v2) = (w1 - e w2) v1 + (1 + e) w2 v2 (and symmetrically):
        # coefficients of size <= 2, so no intermediate overflow for |v| up to ~1e308
        v1_after = (w1 - e * w2) * v1 + ((1.0 + e) * w2) * v2
        v2_after = ((1.0 + e) * w1) * v1 + (w2 - e * w1) * v2
    return ins.out(ins.finite(v1_after, "inelastic_collision_1d"), "speed"), ins.out(
        ins.finite(v2_after, "inelastic_collision_1d"), "speed"
    )


def elastic_collision_1d(m1, v1, m2, v2):
    """Velocities ``(v1', v2')`` after a 1-D elastic collision [m/s].

    Parameters
    ----------
    m1, m2 : float, array_like or Quantity
        Masses [kg], > 0.
    v1, v2 : float, array_like or Quantity
        Velocities before [m/s].

    Notes
    -----
    v1' = 2 v_cm - v1, v2' = 2 v_cm - v2 with v_cm the centre-of-mass velocity: each velocity is
    reflected in the centre-of-mass frame, conserving momentum and kinetic energy (Taylor 2005).

    Examples
    --------
    >>> v1, v2 = elastic_collision_1d(1.0, 1.0, 1.0, 0.0)   # equal masses swap velocities
    >>> print(f"{v1:.3f} {v2:.3f}")
    0.000 1.000
    """
    return inelastic_collision_1d(m1, v1, m2, v2, 1.0)


def perfectly_inelastic_collision_1d(m1, v1, m2, v2):
    """Common velocity after the bodies stick together, v_cm = (m1 v1 + m2 v2)/(m1 + m2) [m/s]."""
    return inelastic_collision_1d(m1, v1, m2, v2, 0.0)[0]


def explosive_separation_1d(m1, v1, m2, v2, energy_released):
    """Velocities after a 1-D collision (or explosion) that adds kinetic energy Q >= 0.

    Parameters
    ----------
    m1, m2 : masses [kg]; v1, v2 : velocities before [m/s];
    energy_released : float, array_like or Quantity
        Q [J], >= 0, added to the kinetic energy.

    Returns
    -------
    v1_after, v2_after : velocities after [m/s].

    Notes
    -----
    Momentum fixes v_cm; the relative speed after is abs(u') = sqrt(u^2 + 2 Q / mu). The bodies
    separate afterwards with body 2 on the + side: u' = v1' - v2' = -sqrt(u^2 + 2 Q / mu) (an
    approaching pair bounces back; a pair at rest relative to each other, as in an explosion,
    flies apart with body 2 moving in the + direction relative to body 1).
    """
    ins = Inputs()
    m1, m2 = _masses(m1, m2, ins)
    v1 = ins.get(v1, "speed", "v1")
    v2 = ins.get(v2, "speed", "v2")
    Q = ins.get(energy_released, "energy", "energy_released", nonnegative=True)
    ins.broadcast("explosive_separation_1d", m1=m1, v1=v1, m2=m2, v2=v2, energy_released=Q)
    total = m1 + m2
    mu = m1 * m2 / total
    v_cm = (m1 / total) * v1 + (m2 / total) * v2
    u = v1 - v2
    with np.errstate(over="ignore", invalid="ignore"):
        u_after = -np.sqrt(u * u + 2.0 * Q / mu)
        v1_after = v_cm + (m2 / total) * u_after
        v2_after = v_cm - (m1 / total) * u_after
    return ins.out(ins.finite(v1_after, "explosive_separation_1d"), "speed"), ins.out(
        ins.finite(v2_after, "explosive_separation_1d"), "speed"
    )


def collision_impulse(m1, m2, r1, r2, v1, v2, restitution, *, explosive: bool = False):
    """3-D collision of two smooth spheres: impulse along the line of centres.

    Parameters
    ----------
    m1, m2 : float, array_like or Quantity
        Masses [kg], > 0, shape (...).
    r1, r2 : array_like or Quantity, shape (..., 3)
        Centres at contact [m]; only the direction n = (r2 - r1)/‖r2 - r1‖ matters.
    v1, v2 : array_like or Quantity, shape (..., 3)
        Velocities before [m/s].
    restitution : float or array_like
        e in [0, 1] (e > 1 only with ``explosive=True``).
    explosive : bool
        Allow e > 1.

    Returns
    -------
    J : ndarray or Quantity, shape (..., 3)
        Impulse received by body 2 [N s] (body 1 receives -J). Zero when the bodies are already
        separating, (v1 - v2).n <= 0: then no collision takes place.
    v1_after, v2_after : ndarray or Quantity, shape (..., 3)
        Velocities after [m/s]: v1' = v1 - J/m1, v2' = v2 + J/m2.

    Raises
    ------
    InvalidStateError
        Coincident centres (no line of centres).
    DomainError
        Non-positive mass or restitution outside [0, 1].

    Notes
    -----
    Frictionless spheres exchange an impulse J = j n with j = (1 + e) mu (v1 - v2).n and
    mu = m1 m2/(m1 + m2); tangential velocities are unchanged, the normal relative velocity
    becomes -e times its old value, momentum is conserved exactly and the kinetic energy drops
    by (1 - e^2) mu ((v1 - v2).n)^2 / 2 (Goldstein 3rd ed. sec. 3.10; Taylor 2005).
    """
    ins = Inputs()
    m1, m2 = _masses(m1, m2, ins)
    r1 = ins.vector(r1, "m", "r1")
    r2 = ins.vector(r2, "m", "r2")
    v1 = ins.vector(v1, "speed", "v1")
    v2 = ins.vector(v2, "speed", "v2")
    e = _restitution(restitution, explosive, ins)
    ins.broadcast(
        "collision_impulse", m1=m1, m2=m2, r1=r1[..., 0], r2=r2[..., 0], v1=v1[..., 0],
        v2=v2[..., 0], restitution=e,
    )
    d = r2 - r1
    # scale before the norm: |d| ~ 1e-300 must not underflow to "coincident"
    scale = np.max(np.abs(d), axis=-1, keepdims=True)
    if np.any(scale == 0):
        raise InvalidStateError(
            "collision_impulse: r1 and r2 coincide, so the line of centres is undefined. Pass "
            "the centres at the moment of contact (|r2 - r1| = sum of radii)."
        )
    d = d / scale
    n = d / np.linalg.norm(d, axis=-1, keepdims=True)
    m1 = np.asarray(m1)[..., None]
    m2 = np.asarray(m2)[..., None]
    e = np.asarray(e)[..., None]
    mu = m1 * m2 / (m1 + m2)
    approach = np.sum((v1 - v2) * n, axis=-1, keepdims=True)
    j = np.where(approach > 0, (1.0 + e) * mu * approach, 0.0)
    J = j * n
    v1_after, v2_after = v1 - J / m1, v2 + J / m2
    for arr in (J, v1_after, v2_after):
        ins.finite(arr, "collision_impulse")
    return ins.out(J, "impulse"), ins.out(v1_after, "speed"), ins.out(v2_after, "speed")


def kinetic_energy(m, v):
    """Kinetic energy m ‖v‖^2 / 2 [J].

    ``v`` has the shape of ``m`` (1-D velocities) or more axes, the last holding the vector
    components (summed): one mass m with velocities (N, 3) gives N energies, m of shape (N,)
    with v of shape (N, 3) one energy per particle.
    """
    ins = Inputs()
    m = ins.get(m, "kg", "m", nonnegative=True)
    v = ins.get(v, "speed", "v")
    # a scalar mass with (N, 3) velocities is N vectors, not 3 N speeds (it gave [[9, 16, 0], ...]
    # for m = 2, v = [[3, 4, 0], ...] instead of [25, ...])
    if v.ndim > m.ndim:
        v2 = np.sum(v * v, axis=-1)
    else:
        v2 = v * v
    ins.broadcast("kinetic_energy", m=m, v2=v2)
    return ins.out(0.5 * m * v2, "energy")
