"""SANA's orbit-relative reference frames: the axes a ``COV_REF_FRAME`` names, and their rates.

CCSDS 502.0-B-3 (ODM) takes ``COV_REF_FRAME`` from the SANA registry "Orbit-Relative Reference
Frames" (sanaregistry.org/r/orbit_relative_reference_frames). Each frame below is three
orthonormal axes (the rows of ``Q``) built from the state ``(r, v)``, ``h = r x v``; with
``R = r/|r|``, ``W = h/|h|``, ``S = W x R``, ``T = v/|v|``:

==============  =====================  =====================  =====================
frame           X                      Y                      Z
==============  =====================  =====================  =====================
RSW (RTN, RIC)  R (zenith)             S = W x R              W (orbit normal)
LVLH (SANA)     S                      -W                     -R (nadir)
TNW             T (velocity)           W x T (inward)         W
NTW             T x W (outward)        T                      W
VNC (VNB)       T                      W                      T x W (outward)
NSW             -R (nadir)             Sun, normal to X       X x Y
PQW             P = e / |e| (periapsis)  W x P                W
EQW             f (equinoctial)        g = W x f              W
==============  =====================  =====================  =====================

Sources (read for the facts): the SANA registry (RSW; TNW "N completing the right handed
system", inward on a circular orbit; LVLH "Z ... opposite sign of the ... satellite position,
Y ... opposite sign of the orbital kinetic momentum, X = Y x Z"), Orekit's ``OrbitRelativeFrame``
and ``LOFType`` (NTW: Y along velocity, Z along momentum, so X = Y x Z points outward; VNC;
``LVLH_CCSDS``), Vallado, *Fundamentals of Astrodynamics and Applications* (2013), sec. 3.3
(RSW, NTW, PQW, EQW) and Broucke & Cefola, Celestial Mechanics 5, 303 (1972) (the
equinoctial ``f, g, w`` of a direct orbit: ``f`` is the node direction turned back by the
right ascension of the node about ``w``, so it is the X axis at zero inclination). SANA's
LVLH is *not* Orekit's ``LOFType.LVLH`` nor STK's LVLH (both the RSW axes), and Orekit's
``LOFType.EQW`` puts X on the ascending node (the equinoctial ``f`` turned by Omega).

``*_INERTIAL`` is the quasi-inertial form (``J = blockdiag(Q, Q)``, the velocity block rotated
like the position block); ``*_ROTATING`` the velocity seen from the turning axes,
``J = [[Q, 0], [dQ/dt, Q]]``, with ``dQ/dt`` the exact derivative of the axes along two-body
motion (acceleration ``-GM r / |r|**3``): ``h/|r|**2`` about W for the RSW/LVLH axes,
``GM |h| / (|r|**3 |v|**2)`` for TNW/NTW/VNC (Orekit uses ``h/|r|**2`` for every frame:
exact for RSW only). PQW and EQW are fixed in two-body motion: SANA lists them inertial only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InvalidInputError

__all__ = ["FrameSpec", "frame_spec", "READ_NAMES", "axes", "jacobian", "inverse_jacobian"]


@dataclass(frozen=True)
class FrameSpec:
    """One orbit-relative frame: its axes (``kind``), the velocity block (``rotating``), and
    what building it needs (``needs_gm``: the central body's GM; ``needs_sun``: the Sun)."""

    kind: str
    rotating: bool

    @property
    def needs_gm(self) -> bool:
        return self.kind == "PQW" or (self.rotating and self.kind in _V_BASED + ("NSW",))

    @property
    def needs_sun(self) -> bool:
        return self.kind == "NSW"


_R_BASED = ("RSW", "LVLH")
_V_BASED = ("TNW", "NTW", "VNC")
#: rows of Q as (index, sign) over the (e1, e2, e3) of the frame's two defining vectors
_ROWS = {"RSW": ((0, 1), (1, 1), (2, 1)), "LVLH": ((1, 1), (2, -1), (0, -1)),
         "TNW": ((0, 1), (1, 1), (2, 1)), "NTW": ((1, -1), (0, 1), (2, 1)),
         "VNC": ((0, 1), (2, 1), (1, -1)), "NSW": ((0, 1), (1, 1), (2, 1)),
         "PQW": ((0, 1), (1, 1), (2, 1))}
#: SANA names with both forms; PQW and EQW are inertial only
_SANA = {f"{k}_{form}": FrameSpec(k, form == "ROTATING")
         for k in ("RSW", "TNW", "NTW", "LVLH", "VNC", "NSW") for form in ("INERTIAL", "ROTATING")}
_SANA.update({"PQW_INERTIAL": FrameSpec("PQW", False), "EQW_INERTIAL": FrameSpec("EQW", False)})
#: plain names, read quasi-inertial as the CDM reads RTN (docs/design.md, "RTN / TNW covariances")
_PLAIN = {"RTN": "RSW", "RSW": "RSW", "RIC": "RSW", "QSW": "RSW", "TNW": "TNW", "NTW": "NTW",
          "VNB": "VNC", "VNC": "VNC"}
#: every name visviva reads
READ_NAMES = tuple(sorted(_PLAIN) + sorted(_SANA))
#: names refused with a reason (a guess would give a wrong covariance in silence)
_REFUSED = {
    "LVLH": "plain LVLH is ambiguous: SANA's LVLH has Z to nadir and Y against the orbit "
            "normal, Orekit's LOFType.LVLH and STK's LVLH are the RSW axes; write "
            "LVLH_INERTIAL / LVLH_ROTATING (SANA) or RSW_INERTIAL",
    "SEZ_INERTIAL": "visviva does not build the South-East-Zenith axes (they need the central "
                    "body's pole, which the state does not give)",
    "SEZ_ROTATING": "visviva does not build the South-East-Zenith axes (they need the central "
                    "body's pole, which the state does not give)",
}
#: below this eccentricity the periapsis direction P is not fixed by a state good to 1e-10
PQW_MIN_ECCENTRICITY = 1e-6
#: below this sine of the inclination, a retrograde orbit has no equinoctial f axis
EQW_MIN_SINE = 1e-6
#: below this sine of the Sun's angle from the vertical the NSW axes are not fixed: the Sun
#: seen from the spacecraft or from the centre differ by up to 2.8e-4 rad at GEO
NSW_MIN_SINE = 1e-4


def frame_spec(name) -> FrameSpec | None:
    """The :class:`FrameSpec` of a ``COV_REF_FRAME`` name (case-insensitive), or None.

    Raises
    ------
    InvalidInputError
        A name whose axes are ambiguous or not built (plain ``LVLH``, ``SEZ_*``).
    """
    key = str(name).strip().upper()
    if key in _REFUSED:
        raise InvalidInputError(f"COV_REF_FRAME = {key}: {_REFUSED[key]}.")
    if key in _SANA:
        return _SANA[key]
    if key in _PLAIN:
        return FrameSpec(_PLAIN[key], False)
    return None


def _unit_and_rate(x, xdot):
    """``x/|x|`` and its time derivative ``(I - u u^T) xdot / |x|``."""
    n = np.linalg.norm(x)
    u = x / n
    return u, (xdot - u * (u @ xdot)) / n


def _triad(a, adot, b, bdot):
    """e1 = a/|a|, e3 = (a x b)/|a x b|, e2 = e3 x e1 and their time derivatives."""
    e1, d1 = _unit_and_rate(a, adot)
    e3, d3 = _unit_and_rate(np.cross(a, b), np.cross(adot, b) + np.cross(a, bdot))
    return (e1, np.cross(e3, e1), e3), (d1, np.cross(d3, e1) + np.cross(e3, d1), d3)


def _refuse_degenerate(r, v):
    h = np.cross(r, v)
    if not np.linalg.norm(h) > 1e-12 * np.linalg.norm(r) * np.linalg.norm(v):
        raise InvalidInputError(
            f"r = {r} km and v = {v} km/s are parallel (or zero): the state has no orbit "
            "plane, so no orbit-relative axes; give the covariance on the state's axes.")


def _eccentricity_vector(r, v, gm):
    return ((v @ v - gm / np.linalg.norm(r)) * r - (r @ v) * v) / gm


def _equinoctial(r, v):
    """Rows f, g, w of the direct equinoctial frame (Broucke & Cefola 1972, retrograde factor
    +1): with p = tan(i/2) sin(raan) = w_x/(1 + w_z), q = tan(i/2) cos(raan) = -w_y/(1 + w_z),
    f = (1 - p^2 + q^2, 2pq, -2p)/s, g = (2pq, 1 + p^2 - q^2, 2q)/s, s = 1 + p^2 + q^2."""
    w = np.cross(r, v)
    w = w / np.linalg.norm(w)
    sin_i2 = w[0] ** 2 + w[1] ** 2
    if w[2] < 0 and sin_i2 < EQW_MIN_SINE**2:
        inc = np.degrees(np.arctan2(np.sqrt(sin_i2), w[2]))
        raise InvalidInputError(
            f"EQW_INERTIAL: the orbit is retrograde equatorial (inclination {inc:.10g} deg), "
            "where the equinoctial axes of a direct orbit are undefined (f turns with the "
            "node); write the covariance in RSW_INERTIAL or on the state's axes.")
    one_plus_cos = sin_i2 / (1.0 - w[2]) if w[2] < 0 else 1.0 + w[2]  # no cancellation
    p, q = w[0] / one_plus_cos, -w[1] / one_plus_cos
    s = 1.0 + p * p + q * q
    f = np.array([1.0 - p * p + q * q, 2.0 * p * q, -2.0 * p]) / s
    g = np.array([2.0 * p * q, 1.0 + p * p - q * q, 2.0 * q]) / s
    return np.stack([f, g, np.cross(f, g)]), np.zeros((3, 3))


def _axes_and_rate(spec: FrameSpec, r, v, gm, sun):
    """(Q, dQ/dt) of ``spec`` at (r, v), dQ/dt along two-body motion (zeros unless needed)."""
    _refuse_degenerate(r, v)
    if spec.kind == "EQW":
        return _equinoctial(r, v)
    acc = -gm * r / np.linalg.norm(r) ** 3 if gm is not None else np.zeros(3)
    if spec.kind in _R_BASED:
        e, d = _triad(r, v, v, acc)
    elif spec.kind in _V_BASED:
        e, d = _triad(v, acc, -r, -v)
    elif spec.kind == "NSW":
        s, s_dot = sun
        e, d = _triad(-r, -v, s - r, s_dot - v)
        sine = np.linalg.norm(np.cross(e[0], s - r)) / np.linalg.norm(s - r)
        if sine < NSW_MIN_SINE:
            raise InvalidInputError(
                f"NSW: the Sun is {np.degrees(np.arcsin(sine)):.3g} deg from the local "
                "vertical, so the Sun axis (normal to the nadir) turns with the ephemeris "
                "and with where the Sun is seen from; write the covariance in RSW or on the "
                "state's axes.")
    else:  # PQW
        ecc = _eccentricity_vector(r, v, gm)
        if np.linalg.norm(ecc) < PQW_MIN_ECCENTRICITY:
            raise InvalidInputError(
                f"PQW_INERTIAL: the orbit is circular to e = {np.linalg.norm(ecc):.3g} (GM "
                f"{gm:.10g} km^3/s^2), so its periapsis direction P is not defined (below "
                f"e = {PQW_MIN_ECCENTRICITY:g}); write the covariance in RSW_INERTIAL or on "
                "the state's axes.")
        h = np.cross(r, v)
        e, d = _triad(ecc, np.zeros(3), np.cross(h, ecc), np.zeros(3))
    rows = _ROWS[spec.kind]
    q = np.stack([sign * e[i] for i, sign in rows])
    qdot = np.stack([sign * d[i] for i, sign in rows])
    return q, qdot


def axes(spec: FrameSpec, r_km, v_km_s, gm_km3_s2=None, sun=None) -> np.ndarray:
    """The frame's axes as the rows of ``Q`` (``Q @ x_inertial`` gives local components).

    Parameters
    ----------
    spec : FrameSpec
        From :func:`frame_spec`.
    r_km, v_km_s : array_like (3,)
        The state, km and km/s.
    gm_km3_s2 : float, optional
        Central body's GM, km^3/s^2 (PQW's eccentricity vector; the rotating rates).
    sun : tuple of ndarray (3,), optional
        The Sun's position (km) and velocity (km/s) from the central body, on the state's
        axes (NSW).

    Returns
    -------
    ndarray (3, 3)
    """
    r, v = np.asarray(r_km, dtype=np.float64), np.asarray(v_km_s, dtype=np.float64)
    return _axes_and_rate(spec, r, v, gm_km3_s2, sun)[0]


def jacobian(spec: FrameSpec, r_km, v_km_s, gm_km3_s2=None, sun=None) -> np.ndarray:
    """``d(local state) / d(inertial state)``, 6 x 6, at the state (r, v).

    Quasi-inertial: ``blockdiag(Q, Q)``. Rotating: ``[[Q, 0], [dQ/dt, Q]]`` (the local
    velocity of a neighbour is ``Q dv + dQ/dt dr``, ``dQ/dt = -Q [omega]x``), ``dQ/dt`` the
    exact derivative of the axes along two-body motion (needs ``gm_km3_s2`` for the
    velocity-based and Sun-based frames; the Sun's velocity for NSW).

    Parameters
    ----------
    spec, r_km, v_km_s, gm_km3_s2, sun
        As for :func:`axes`.

    Returns
    -------
    ndarray (6, 6)

    References
    ----------
    Vallado, "Covariance transformations for satellite flight dynamics operations",
    AAS 03-526 (2003); CCSDS 502.0-B-3 and the SANA orbit-relative reference frames registry.
    """
    r, v = np.asarray(r_km, dtype=np.float64), np.asarray(v_km_s, dtype=np.float64)
    if spec.needs_gm and gm_km3_s2 is None:
        raise InvalidInputError(f"the {spec.kind} axes need the central body's GM")
    q, qdot = _axes_and_rate(spec, r, v, gm_km3_s2, sun)
    jac = np.zeros((6, 6))
    jac[:3, :3] = jac[3:, 3:] = q
    if spec.rotating:
        jac[3:, :3] = qdot
    return jac


def inverse_jacobian(jac: np.ndarray) -> np.ndarray:
    """The inverse of ``[[Q, 0], [B, Q]]`` (``Q`` orthonormal): ``[[Q^T, 0], [-Q^T B Q^T,
    Q^T]]``."""
    qt = jac[:3, :3].T
    out = np.zeros((6, 6))
    out[:3, :3] = out[3:, 3:] = qt
    out[3:, :3] = -qt @ jac[3:, :3] @ qt
    return out
