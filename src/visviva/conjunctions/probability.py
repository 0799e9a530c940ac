"""Collision probability of a conjunction: Foster, Chan, Alfano's maximum, 3-D, Monte Carlo.

All methods take the two objects' states at the time of closest approach (TCA) in one inertial
frame, their covariances and the combined hard-body radius (HBR). Positions, velocities and the
HBR may be Quantities; plain numbers are SI (m, m/s), like plain covariances (m^2, m^2/s, m^2/s^2,
the CCSDS CDM convention). Internally everything is in metres and seconds.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from .._covariance import not_psd
from .._units import is_quantity
from ..errors import InvalidInputError, ShapeError
from .accuracy import check_2d, check_chan, check_tca
from .accuracy import check_3d as _check_3d
from .covariance import (
    CLIP_FACTOR,
    as_covariance,
    encounter_plane,
    principal_axes,
    warn_km_as_metres,
)
from .pc2d import log_pc_2d

__all__ = [
    "collision_probability",
    "max_collision_probability",
    "monte_carlo_probability",
    "MonteCarloResult",
    "CovarianceRepairWarning",
    "METHODS",
    "log_pc_2d",
    "gm_m3_s2",
]

#: method name -> one-line description (the docs and tests iterate it)
METHODS = {
    "foster": "2-D encounter-plane integral over the hard-body circle (CARA PcCircle, 1e-10)",
    "chan": "Chan's series (equivalent-area Rician approximation; warns where it is more than "
            "10 % from the Foster integral)",
    "3d": "time integral of the probability flux through the hard-body cross-section along "
          "two-body relative motion, covariances propagated by the STM (mean relative "
          "velocity only; warns where it is more than 10 % from 'pc3d_hall', the validated "
          "3-D method, over the same time span)",
    "pc3d_hall": "Hall's (2021) 3D-Nc method (NASA CARA's Pc3D_Hall): the expected number of "
                 "collisions, two-body motion with equinoctial-element covariances linearised "
                 "about the peak overlap position, flux integrated over the hard-body sphere",
    "monte_carlo": "sampling of the relative position in the encounter plane",
}


class CovarianceRepairWarning(UserWarning):
    """A covariance was not positive semi-definite and was repaired by eigenvalue clipping."""


def si_value(value, unit: str, name: str, check_finite: bool = True) -> np.ndarray:
    """``value`` as a float64 array in ``unit`` (a Quantity is converted, a plain number is taken
    as ``unit``); a clear error naming ``name`` for wrong units or (``check_finite``) non-finite
    values."""
    if is_quantity(value):
        from astropy import units as u

        from ..errors import UnitsError

        try:
            arr = value.to_value(u.Unit(unit))
        except u.UnitConversionError as exc:
            raise UnitsError(f"{name} has unit '{value.unit}', which is not convertible to "
                             f"'{unit}'.") from exc
    else:
        arr = value
    try:
        arr = np.array(arr, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{name} must be numeric, got {value!r}.") from exc
    if check_finite and not np.all(np.isfinite(arr)):
        raise InvalidInputError(f"{name} contains NaN or infinite values: {arr}.")
    return arr


def refuse_local_axes(cov, name: str) -> None:
    """Refuse a covariance labelled as on local (RTN...) axes: the methods take it on the
    inertial axes of r and v (an RTN matrix taken for inertial gives a wrong Pc)."""
    from .._covariance import local_axes_of

    axes = local_axes_of(cov)
    if axes is not None:
        raise InvalidInputError(
            f"{name} is on the {axes} axes (propagate_covariance(..., output_frame={axes!r})), "
            "but the covariances go with r and v on inertial axes: propagate with "
            "output_frame='GCRS' (the default), or rotate it back.")


def encounter_inputs(r1, v1, cov1, r2, v2, cov2, hard_body_radius):
    """The checked inputs of the collision-probability methods in SI units (m, m/s, m^2...):
    ``(r1, v1, cov1, r2, v2, cov2, hbr)``; shared with :mod:`visviva.conjunctions.plots`."""
    vecs = []
    for val, unit, name in ((r1, "m", "r1"), (v1, "m/s", "v1"), (r2, "m", "r2"),
                            (v2, "m/s", "v2")):
        arr = si_value(val, unit, name)
        if arr.shape != (3,):
            raise ShapeError(f"{name} must be one 3-vector; got shape {arr.shape}.")
        vecs.append(arr)
    if not any(is_quantity(x) for x in (r1, v1, r2, v2)):
        warn_km_as_metres(*vecs)
    for c, name in ((cov1, "cov1"), (cov2, "cov2")):
        refuse_local_axes(c, name)
    # a km covariance returned by visviva (fit_orbit, propagate_covariance) is converted
    c1 = as_covariance(cov1, "cov1", convert_marked=True)
    c2 = as_covariance(cov2, "cov2", convert_marked=True)
    for c, name in ((c1, "cov1"), (c2, "cov2")):
        if c.ndim != 2:
            raise ShapeError(f"{name} must be a single 6x6 or 3x3 matrix; got {c.shape}.")
    if is_quantity(hard_body_radius):
        hbr = float(si_value(hard_body_radius, "m", "hard_body_radius"))
    else:
        try:
            hbr = float(hard_body_radius)
        except (TypeError, ValueError) as exc:
            raise InvalidInputError("hard_body_radius must be a length.") from exc
        if math.isnan(hbr):
            raise InvalidInputError("hard_body_radius is NaN.")
    if hbr < 0:
        raise InvalidInputError(f"hard_body_radius must be >= 0, got {hbr} m.")
    return vecs[0], vecs[1], c1, vecs[2], vecs[3], c2, hbr


def _warn_repair(what, stacklevel=3):
    warnings.warn(
        f"{what} is not positive semi-definite; repaired as NASA CARA does (eigenvalues of the "
        "encounter-plane covariance clipped to (1e-4 HBR)^2). Check the covariance source.",
        CovarianceRepairWarning, stacklevel=stacklevel)


def _repaired_plane(r1, v1, c1, r2, v2, c2, hbr):
    """The encounter plane with CARA's eigenvalue clip, warning when a covariance needed it."""
    npd_in = not_psd(c1) or not_psd(c2)
    plane = encounter_plane(r1, v1, c1, r2, v2, c2, hbr)
    warn_plane_repair(npd_in, plane, stacklevel=5)
    return plane


def warn_plane_repair(npd_in, plane, stacklevel):
    """The CovarianceRepairWarning of the 2-D methods, where an input covariance (``npd_in``)
    or the projected one (``plane``) was not positive semi-definite."""
    if npd_in or plane.non_positive_definite:
        _warn_repair("the combined covariance" if not npd_in else "an input covariance",
                     stacklevel=stacklevel)


def collision_probability(r1, v1, cov1, r2, v2, cov2, hard_body_radius, method="foster", *,
                          samples=1_000_000, seed=None, gm=None, window=None, log=False):
    """Probability that two objects come within ``hard_body_radius`` of each other.

    Parameters
    ----------
    r1, r2 : Quantity, shape (3,)
        Positions at TCA in one inertial frame (plain numbers: m). The 2-D methods
        (``"foster"``, ``"chan"``) take the miss distance as ``|r1 - r2|``, as NASA CARA's
        ``PcCircle`` does: states off TCA count their offset along the relative velocity in
        the miss (3 ms at 15 km/s: a 45 m offset, added in quadrature). Give states at TCA
        (a CDM's are), or use ``"3d"`` / ``"pc3d_hall"``, which integrate the encounter in
        time.
    v1, v2 : Quantity, shape (3,)
        Velocities at TCA (plain numbers: m/s).
    cov1, cov2 : array_like, shape (6, 6) or (3, 3)
        Position-velocity (or position) covariances in that frame; plain arrays in m^2, m^2/s,
        m^2/s^2, or an area Quantity (see :func:`~visviva.conjunctions.covariance.as_covariance`).
    hard_body_radius : Quantity or float
        Radius of the sphere enclosing both objects (plain numbers: m); 0 gives 0, ``inf`` 1.
    method : {"foster", "chan", "3d", "pc3d_hall", "monte_carlo"}
        See :data:`METHODS`.
    samples : int
        Number of Monte Carlo samples (``method="monte_carlo"``).
    seed : int, optional
        Seed of the Monte Carlo generator.
    gm : Quantity or Body, optional
        Attractor for ``method="3d"`` and ``"pc3d_hall"``, and for the orbital periods and
        3D-Nc of the 2-D methods' check (default: the Earth).
    window : tuple of Quantity or float, optional
        ``(t_a, t_b)``, the time span relative to TCA (plain numbers: s) over which
        ``method="pc3d_hall"`` integrates the collision rate; every encounter in it counts.
        Default: this conjunction, bounded as CARA's ``Pc3D_Hall`` bounds its default search:
        the segment between the maxima of the mean two-body separation before and after TCA
        (at most half the shorter orbital period either side: nearly equal orbits meet again
        half an orbit later, another conjunction), with the encounter at TCA and every other
        encounter wholly inside it.
    log : bool
        Return the natural logarithm of Pc instead (represents values below 1e-308).

    Returns
    -------
    float
        Pc (dimensionless), or ``ln Pc``.

    Warns
    -----
    CovarianceRepairWarning
        A covariance (or the combined one on the encounter plane) is not positive semi-definite
        and was repaired by eigenvalue clipping.
    ChanAccuracyWarning
        ``method="chan"`` only: Chan's value is more than 10 % from Foster's exact integral of
        the same encounter plane (large aspect ratio or HBR beside the minor sigma); the
        message gives both.
    Pc2dAccuracyWarning
        ``method="foster"``, ``"chan"`` or ``"monte_carlo"``: the states are not at TCA
        (``r1 - r2`` has a component along the relative velocity) and that moves Pc by more
        than 10 % from its value with the miss at the straight-line TCA (0.1 s off at 10.6 km/s
        gave 7.7e-16 for 1.09e-3); the message gives both. Or the encounter is not short (NASA CARA's
        usage-violation indicators, Coppola's straight-line encounter lasting more than 1 % of
        the shorter orbital period or lying that far from TCA: slow GEO pairs, formation
        flight) and the value is more than 10 % from Hall's 3D-Nc (``"pc3d_hall"``) of this
        conjunction (Alfano's (2009) cases 1, 2, 4, 10: 0.40x to 0.80x); the message gives
        both. Only such flagged encounters pay for the 3D-Nc check (0.1-1 s).
    UserWarning
        ``method="monte_carlo"`` with fewer than 10 hits: the message gives the Clopper-Pearson
        interval (0 hits: an upper bound, not Pc = 0).
    Pc3dAccuracyWarning
        ``method="3d"`` only: the flux integral is more than 10 % from Hall's 3D-Nc
        (``"pc3d_hall"``) over the same time span (a slow, curved encounter: Alfano's case 11
        gives 0.14 for 2.4e-3); the message gives both and the window.
    Pc3dWindowWarning
        ``method="pc3d_hall"`` with the default window only: the encounter at TCA does not end
        within it (orbits flown in formation; the expected number of collisions grows with the
        time span, Alfano's cases 11 and 12); the message gives the window used; pass
        ``window=``.

    Raises
    ------
    InvalidInputError
        NaN input, negative HBR, zero relative velocity (for the 2-D methods), unknown method;
        for ``"pc3d_hall"`` an HBR above 1 % of the smaller distance from the attractor (a
        sphere not small beside the orbit: 1,000 km in LEO gave Pc 1.007, 10,000 km inf).

    Notes
    -----
    ``"foster"``: the combined covariance ``C1 + C2`` is projected on the plane normal to the
    relative velocity and the 2-D Gaussian integrated over the HBR circle (Foster & Estes 1992;
    Alfano 2005),
    ``Pc = (1 / (2 pi sx sz)) \\iint_{x^2 + z^2 < R^2} exp(-(x - xm)^2/(2 sx^2) - (z - zm)^2/(2 sz^2))``,
    as a 1-D integral along the major axis with the normal CDF across it, adaptively to 1e-13
    relative in log space (no underflow: Pc = 1e-300 keeps all its digits). Conventions of NASA
    CARA's ``PcCircle``: ``r = r1 - r2``, the full miss distance on the encounter-frame ``x`` axis,
    eigenvalues clipped at ``(1e-4 HBR)^2``.
    ``"chan"``: Chan (2008) eq. 5.40 summed to convergence.
    ``"3d"``: ``Pc = \\int |u(t)| p_y(0; t) P_2D(t) dt`` over the encounter, where both mean states
    follow two-body motion, the covariances follow ``Phi C Phi^T`` (position and velocity
    uncertainty), ``p_y`` is the density of the relative position along the relative velocity
    ``u`` at the hard-body cross-section, and ``P_2D`` the Foster integral of the conditional
    in-plane Gaussian (Coppola 2012; the idea of Hall's 3D-Nc, 2021). For rectilinear motion it
    equals ``"foster"``. A relative position covariance that is not positive semi-definite at
    some time of the encounter has its eigenvalues clipped in 3-D at ``(1e-4 HBR)^2`` there, as
    CARA's ``Pc3D_Hall`` does (the 2-D methods clip the projected 2x2, as ``PcCircle`` does);
    the warning says at how many times and by how much. Every value is checked against
    ``"pc3d_hall"`` over the same time span (it costs less than the flux integral).
    ``"pc3d_hall"``: Hall's 3D-Nc method (D. Hall, "Expected Collision Rates for Tracked
    Satellites", J. Spacecr. Rockets 58 (2021) 715; NASA CARA's ``Pc3D_Hall``):
    ``Nc = \\int dt R^2 \\oint d^2n N(R n; r_u, A) E[(-n . v)^+ | R n]`` over the HBR sphere, where
    each object's state pdf is a Gaussian in equinoctial elements at TCA carried by two-body
    motion and linearised about the peak overlap position of the two position pdfs (iterated
    at every time), and the relative velocity is conditioned on the relative position. It needs
    no short-encounter assumption, handles slow, curved and long encounters (zero relative
    velocity at TCA included) and equals Pc for an isolated conjunction (an upper bound for
    repeating ones). The sphere rule adapts to the density (thin covariances included) and the
    time integral is adaptive (1e-6 relative); Alfano's (2009) twelve cases match CARA's values
    to 1e-3 (see ``docs/conjunctions.md``).
    ``"monte_carlo"``: the estimate of :func:`monte_carlo_probability`.
    The 2-D methods (and ``"monte_carlo"``) take the miss as ``|r1 - r2|``, CARA's convention
    for states at TCA; states off TCA are checked against the miss at the straight-line TCA
    (the component of ``r1 - r2`` normal to the relative velocity).
    """
    if method not in METHODS:
        raise InvalidInputError(f"method must be one of {sorted(METHODS)}, got {method!r}.")
    r1, v1, c1, r2, v2, c2, hbr = encounter_inputs(r1, v1, cov1, r2, v2, cov2, hard_body_radius)
    if method == "monte_carlo":
        res = _monte_carlo(r1, v1, c1, r2, v2, c2, hbr, samples, seed, 0.95)
        if hbr > 0:  # HBR 0: Pc = 0 exactly
            _warn_few_hits(res)
        if 0 < hbr < math.inf:  # the sampled plane's exact value, against 3D-Nc
            plane = encounter_plane(r1, v1, c1, r2, v2, c2, hbr)
            check_2d(log_pc_2d(*plane.principal_miss, *plane.sigma, hbr, "foster"), method,
                     r1, v1, c1, r2, v2, c2, hbr, gm_m3_s2(gm))
        return math.log(res.pc) if log and res.pc > 0 else (-math.inf if log else res.pc)
    if method == "3d":
        lp, half, gm_km = _log_pc_3d(r1, v1, c1, r2, v2, c2, hbr, gm)
        _check_3d(lp, r1, v1, c1, r2, v2, c2, hbr, gm_km, half)
        return lp if log else math.exp(lp)
    if method == "pc3d_hall":
        lp = _log_pc3d_hall(r1, v1, c1, r2, v2, c2, hbr, gm, window)
        return lp if log else math.exp(lp)
    if hbr == 0:
        return -math.inf if log else 0.0
    if math.isinf(hbr):
        encounter_plane(r1, v1, c1, r2, v2, c2, hbr)  # its input checks
        return 0.0 if log else 1.0
    plane = _repaired_plane(r1, v1, c1, r2, v2, c2, hbr)
    xm, zm = plane.principal_miss
    sx, sz = plane.sigma
    lp = log_pc_2d(xm, zm, sx, sz, hbr, method)
    if method == "chan":
        check_chan(lp, xm, zm, sx, sz, hbr)
    check_tca(method, r1, v1, r2, v2, plane, hbr)
    check_2d(lp, method, r1, v1, c1, r2, v2, c2, hbr, gm_m3_s2(gm))
    return lp if log else math.exp(lp)


@dataclass(frozen=True)
class MonteCarloResult:
    """A Monte Carlo estimate of Pc with its confidence interval.

    Attributes
    ----------
    pc : float
        ``hits / samples``.
    low, high : float
        Clopper-Pearson interval at ``confidence``.
    hits, samples : int
        Counts.
    confidence : float
        Confidence level of the interval (e.g. 0.95).
    """

    pc: float
    low: float
    high: float
    hits: int
    samples: int
    confidence: float


def monte_carlo_probability(r1, v1, cov1, r2, v2, cov2, hard_body_radius, *,
                            samples=1_000_000, seed=None, confidence=0.95) -> MonteCarloResult:
    """Monte Carlo Pc in the encounter plane, with a Clopper-Pearson confidence interval.

    Parameters
    ----------
    r1, r2 : Quantity, shape (3,)
        Positions at TCA (plain numbers: m).
    v1, v2 : Quantity, shape (3,)
        Velocities at TCA (plain numbers: m/s).
    cov1, cov2 : array_like, shape (6, 6) or (3, 3)
        Covariances (m^2 ...).
    hard_body_radius : Quantity or float
        Combined radius (plain: m).
    samples : int
        Number of samples (drawn in blocks of 1e6).
    seed : int, optional
        Generator seed (numpy's PCG64).
    confidence : float
        Level of the interval.

    Returns
    -------
    MonteCarloResult

    Notes
    -----
    Draws the relative position on the encounter plane from ``N(miss, A_2D)`` (the repaired
    projection used by ``"foster"``) and counts the draws inside the HBR circle; the interval is
    the exact binomial (Clopper-Pearson) one.
    """
    r1, v1, c1, r2, v2, c2, hbr = encounter_inputs(r1, v1, cov1, r2, v2, cov2, hard_body_radius)
    return _monte_carlo(r1, v1, c1, r2, v2, c2, hbr, samples, seed, confidence)


def _monte_carlo(r1, v1, c1, r2, v2, c2, hbr, samples, seed, confidence):
    """:func:`monte_carlo_probability` of checked SI inputs (:func:`encounter_inputs`), for it
    and for ``collision_probability(method="monte_carlo")``."""
    from scipy import stats

    if not (isinstance(samples, (int, np.integer, float, np.floating))
            and math.isfinite(samples) and samples == int(samples) and samples >= 1):
        raise InvalidInputError(f"samples must be a whole number >= 1, got {samples!r}.")
    samples = int(samples)
    if not (isinstance(confidence, (int, float, np.integer, np.floating))
            and 0.0 < confidence < 1.0):
        raise InvalidInputError(f"confidence must be a level in (0, 1) such as 0.95, got "
                                f"{confidence!r}.")
    plane = _repaired_plane(r1, v1, c1, r2, v2, c2, hbr)
    check_tca("monte_carlo", r1, v1, r2, v2, plane, hbr, stacklevel=4)
    sx, sz = plane.sigma
    xm, zm = plane.principal_miss
    rng = np.random.default_rng(seed)
    hits = 0
    left = samples
    r2lim = hbr * hbr
    while left > 0:
        n = min(left, 1_000_000)
        x = rng.standard_normal(n) * sx + xm
        z = rng.standard_normal(n) * sz + zm
        hits += int(np.count_nonzero(x * x + z * z < r2lim))
        left -= n
    alpha = 1.0 - confidence
    low = 0.0 if hits == 0 else float(stats.beta.ppf(alpha / 2, hits, samples - hits + 1))
    high = 1.0 if hits == samples else float(stats.beta.ppf(1 - alpha / 2, hits + 1,
                                                             samples - hits))
    return MonteCarloResult(hits / samples, low, high, hits, samples, confidence)


#: fewer hits than this make ``method="monte_carlo"`` warn (relative standard error above 30 %)
_FEW_HITS = 10


def _warn_few_hits(res: MonteCarloResult) -> None:
    """Warn where ``collision_probability(method="monte_carlo")`` returns an estimate from fewer
    than :data:`_FEW_HITS` hits: 0 hits returned Pc = 0 for a conjunction whose Foster value is
    2.2e-14 (audit48); the bare number hides the interval that :func:`monte_carlo_probability`
    gives."""
    if res.hits >= _FEW_HITS:
        return
    level = f"{100 * res.confidence:g} %"
    if res.hits == 0:
        what = (f"none of the {res.samples} samples hit the hard-body circle: Pc = 0 is not an "
                f"estimate, only a bound, Pc < {res.high:.3g} ({level} Clopper-Pearson)")
    else:
        what = (f"only {res.hits} of the {res.samples} samples hit the hard-body circle: Pc = "
                f"{res.pc:.3g} is uncertain by a factor {res.high / res.low:.3g} (between "
                f"{res.low:.3g} and {res.high:.3g}, {level} Clopper-Pearson)")
    warnings.warn(
        f"method='monte_carlo': {what}. Use method='foster' (the exact integral of the plane "
        f"sampled), or about {max(100.0 / max(res.high, 1e-300), 1.0):.3g} samples for 100 hits; "
        "vv.monte_carlo_probability gives the interval.", UserWarning, stacklevel=3)


def max_collision_probability(r1, v1, r2, v2, hard_body_radius, cov1=None, cov2=None, *,
                              log=False):
    """Alfano's maximum Pc over an unknown covariance size.

    Parameters
    ----------
    r1, r2 : Quantity, shape (3,)
        Positions at TCA (plain: m).
    v1, v2 : Quantity, shape (3,)
        Velocities at TCA (plain: m/s).
    hard_body_radius : Quantity or float
        Combined radius (plain: m).
    cov1, cov2 : array_like, optional
        Covariances giving the shape (orientation and aspect ratio) of the combined covariance;
        their size is the unknown. One alone gives the shape by itself; without them the
        encounter-plane covariance is taken circular.
    log : bool
        Return ``ln Pc_max``.

    Returns
    -------
    float
        ``max_k Pc(k^2 A)`` over the scale ``k > 0`` of the combined covariance ``A``.

    Notes
    -----
    Alfano, "Relating position uncertainty to maximum conjunction probability", J. Astronaut.
    Sci. 53 (2005) 193. For a circular covariance and a small HBR the maximum is
    ``R^2 / (e d^2)`` at ``sigma^2 = d^2 / 2``; here the exact Foster integral is maximised over
    ``log k`` (bounded Brent search), which also holds when ``R`` is not small.
    """
    from scipy.optimize import minimize_scalar

    # one covariance alone gives the shape: the other adds nothing (it added 1 m^2, whose
    # weight beside the given one depended on its units: 7.5e-4 for 1.3e-5; audit48)
    zero, eye = np.zeros((3, 3)), np.eye(3)
    c1 = (eye if cov2 is None else zero) if cov1 is None else cov1
    c2 = (zero if cov1 is not None else eye) if cov2 is None else cov2
    r1, v1, c1, r2, v2, c2, hbr = encounter_inputs(r1, v1, c1, r2, v2, c2, hard_body_radius)
    if hbr == 0:
        return -math.inf if log else 0.0
    # the size is the unknown: scale the shape to the miss before CARA's clip at (1e-4 HBR)^2,
    # which rounded a small covariance (sigmas 1e-5 m, 1e-3 m) to a circle (audit48)
    trace = float(np.trace(c1[:3, :3] + c2[:3, :3]))
    if trace > 0:
        scale = max(float(np.linalg.norm(r1 - r2)), hbr) ** 2 / trace
        c1, c2 = c1 * scale, c2 * scale
    plane = (encounter_plane(r1, v1, c1, r2, v2, c2, hbr) if cov1 is None and cov2 is None
             else _repaired_plane(r1, v1, c1, r2, v2, c2, hbr))
    if cov1 is None and cov2 is None:
        s0 = np.array([1.0, 1.0])
        pm = np.array([float(np.hypot(*plane.principal_miss)), 0.0])
    else:
        s0 = plane.sigma
        pm = plane.principal_miss
    d = max(float(np.hypot(*pm)), hbr)

    def neg(logk):
        k = math.exp(logk)
        return -log_pc_2d(pm[0], pm[1], k * s0[0], k * s0[1], hbr, "foster")

    # the optimum scale puts the sigmas near the miss distance: bracket generously around it
    centre = math.log(d / math.sqrt(s0[0] * s0[1]))
    res = minimize_scalar(neg, bounds=(centre - 12.0, centre + 12.0), method="bounded",
                          options={"xatol": 1e-10})
    lp = -float(res.fun)
    return lp if log else math.exp(lp)


def _period(r, v, gm):
    """Orbital period (s) of the state ``r`` (km), ``v`` (km/s) about ``gm`` (km^3/s^2); inf
    for an open (parabolic or hyperbolic) orbit."""
    inv_a = 2.0 / float(np.linalg.norm(r)) - float(np.dot(v, v)) / gm
    if not inv_a > 0:
        return math.inf
    return 2 * math.pi * math.sqrt(inv_a ** -3 / gm)


def _log_pc_3d(r1, v1, c1, r2, v2, c2, hbr, gm):
    """The 3-D flux integral (see collision_probability); inputs in m, m/s.

    Returns ``(ln Pc, half, gm)``: the integral runs over ``[-half, half]`` s about TCA, with
    ``gm`` in km^3/s^2.
    """
    from .._units import to_array
    from ..core.stm import two_body_stm
    from ..core.universal import propagate_one

    if gm is None:
        from ..bodies import EARTH

        gm = EARTH.gm
    gm_km = float(to_array(gm, "gm", "gm", allow_plain=True))
    if hbr == 0:
        return -math.inf, 0.0, gm_km
    if math.isinf(hbr):
        return 0.0, 0.0, gm_km
    # the flux integral propagates the velocity block too: test the whole 6x6
    npd_in = not_psd(c1, full=True) or not_psd(c2, full=True)
    clip = (CLIP_FACTOR * hbr) ** 2
    repairs = []  # (smallest eigenvalue, largest) of each non-PSD relative covariance
    a0 = c1[:3, :3] + c2[:3, :3]
    u0 = v1 - v2
    un = float(np.linalg.norm(u0))
    lam = float(np.max(np.linalg.eigvalsh(a0)))
    if un == 0:
        raise InvalidInputError("zero relative velocity at TCA: the 3-D flux method needs the "
                                "objects to move relative to each other; use "
                                "method='pc3d_hall', which handles it.")
    r1k, v1k, r2k, v2k = r1 / 1e3, v1 / 1e3, r2 / 1e3, v2 / 1e3
    # the window stays within a quarter of the shorter bound orbit's period (an open orbit,
    # hyperbolic or parabolic, sets no such bound)
    period = min(_period(r1k, v1k, gm_km), _period(r2k, v2k, gm_km))
    half = min(10.0 * (math.sqrt(lam) + hbr + float(np.linalg.norm(r1 - r2))) / un,
               0.25 * period)
    # the rate is a spike of width ~ sigma_t = (sigma along u) / |u| about the crossing of the
    # hard-body plane, t* = -(r . u) / |u|^2: for a covariance thin along u that is far narrower
    # than the window (which scales with the largest sigma), so it gets panels of its own
    y0 = u0 / un
    sigma_t = math.sqrt(max(float(y0 @ a0 @ y0), clip)) / un
    t_star = -float(np.dot(r1 - r2, y0)) / un
    half = min(max(half, abs(t_star) + 12.0 * sigma_t), 0.25 * period)

    def full6(c):
        if c.shape == (6, 6):
            return c
        out = np.zeros((6, 6))
        out[:3, :3] = c
        return out

    c1f, c2f = full6(c1), full6(c2)
    phi = np.empty((6, 6))
    rr = np.empty(3)
    vv = np.empty(3)

    def log_rate(t):
        states = []
        cov = np.zeros((3, 3))
        for r0, v0, cf in ((r1k, v1k, c1f), (r2k, v2k, c2f)):
            propagate_one(r0, v0, gm_km, t, rr, vv)
            two_body_stm(r0, v0, gm_km, t, phi)
            states.append((rr.copy() * 1e3, vv.copy() * 1e3))
            cov += (phi @ cf @ phi.T)[:3, :3]
        cov = _clip_3d(cov, clip, repairs)
        mu = states[0][0] - states[1][0]
        u = states[0][1] - states[1][1]
        speed = float(np.linalg.norm(u))
        y = u / speed
        trial = np.eye(3)[int(np.argmin(np.abs(y)))]
        x = np.cross(y, trial)
        x /= np.linalg.norm(x)
        z = np.cross(x, y)
        b = np.stack([x, y, z])
        m = b @ mu
        a = b @ cov @ b.T
        ayy = a[1, 1]
        if not ayy > 0:
            return -math.inf
        apy = np.array([a[0, 1], a[2, 1]])
        mean_p = np.array([m[0], m[2]]) - apy * (m[1] / ayy)
        cov_p = np.array([[a[0, 0], a[0, 2]], [a[2, 0], a[2, 2]]]) - np.outer(apy, apy) / ayy
        sigma, pm, _, _, _ = principal_axes(mean_p, cov_p, hbr)
        lp2 = log_pc_2d(pm[0], pm[1], sigma[0], sigma[1], hbr, "foster")
        log_py = -0.5 * m[1] ** 2 / ayy - 0.5 * math.log(2 * math.pi * ayy)
        return math.log(speed) + log_py + lp2

    # composite Gauss-Legendre over the window, in log space
    nodes, weights = np.polynomial.legendre.leggauss(8)
    panels = 96
    edges = np.linspace(-half, half, panels + 1)
    if 2.0 * half / panels > 2.0 * sigma_t:  # the spike is narrower than a panel
        fine = t_star + sigma_t * np.linspace(-12.0, 12.0, 49)
        edges = np.unique(np.concatenate([edges, fine[(fine > -half) & (fine < half)]]))
    logs = []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        for xk, wk in zip(nodes, weights, strict=True):
            t = 0.5 * (a + b) + 0.5 * (b - a) * xk
            logs.append(math.log(0.5 * (b - a) * wk) + log_rate(t))
    logs = np.array(logs)
    if npd_in or repairs:
        _warn_repair_3d(npd_in, repairs, len(logs), clip)
    top = float(np.max(logs))
    if top == -math.inf:
        return -math.inf, half, gm_km
    # a probability
    return min(top + math.log(float(np.sum(np.exp(logs - top)))), 0.0), half, gm_km


def _clip_3d(cov, clip, repairs):
    """The relative position covariance ``cov`` (3x3, m^2) with its eigenvalues clipped at
    ``clip`` where one is below it, as NASA CARA's ``Pc3D_Hall`` repairs its relative position
    covariance at each time (``CovRemEigValClip``; Hall et al. 2017); a non-PSD one (beyond
    round-off) is recorded in ``repairs`` as (smallest eigenvalue, largest)."""
    w, vec = np.linalg.eigh(cov)
    if w[0] >= clip:
        return cov
    if w[0] < -1e-10 * max(abs(w[-1]), 1e-300):
        repairs.append((float(w[0]), float(w[-1])))
    return (vec * np.maximum(w, clip)) @ vec.T


def _warn_repair_3d(npd_in, repairs, n_times, clip, stacklevel=4):
    """The CovarianceRepairWarning of ``method="3d"``: which covariance was not PSD and by how
    much, and the repair (the 2-D methods clip the projected 2x2 instead)."""
    what = "an input covariance is not positive semi-definite"
    if repairs:
        low, high = min(repairs)
        what = (f"{what + ', and' if npd_in else 'the inputs are positive semi-definite, but'} the "
                f"relative position covariance is not at {len(repairs)} of the {n_times} "
                f"times of the encounter (smallest eigenvalue {low:.4g} m^2, "
                f"{abs(low) / high:.2g} of the largest)")
    warnings.warn(
        f"{what}; repaired as NASA CARA's Pc3D_Hall does: the eigenvalues of the 3x3 relative "
        f"position covariance clipped to (1e-4 HBR)^2 = {clip:.4g} m^2 at each time (the 2-D "
        "methods clip the 2x2 projected on the encounter plane). Check the covariance source.",
        CovarianceRepairWarning, stacklevel=stacklevel)


def gm_m3_s2(gm):
    """The attractor's ``gm`` (Quantity, Body or plain km^3/s^2; None: the Earth) in m^3/s^2."""
    from .._units import to_array

    if gm is None:  # the Earth's (vv.EARTH.gm), without a Quantity conversion per call
        from ..constants import GM_EARTH_KM3_S2

        return GM_EARTH_KM3_S2 * 1e9
    return float(to_array(gm, "gm", "gm", allow_plain=True)) * 1e9  # km^3/s^2 -> m^3/s^2


#: largest HBR of ``method="pc3d_hall"`` as a fraction of the smaller geocentric distance (70 km
#: in LEO, where a sphere holding the whole encounter gives Nc = 1 + 4e-5; 1 + 8e-6 at 30 km)
_HBR_ORBIT_FRACTION = 0.01


def _log_pc3d_hall(r1, v1, c1, r2, v2, c2, hbr, gm, window):
    """Units and checks for :func:`visviva.conjunctions.nc3d.log_pc3d_hall`."""
    from .nc3d import log_pc3d_hall

    gm_m = gm_m3_s2(gm)
    if c1.shape != (6, 6) or c2.shape != (6, 6):
        raise ShapeError("method='pc3d_hall' needs 6x6 position-velocity covariances.")
    radius = min(float(np.linalg.norm(r1)), float(np.linalg.norm(r2)))
    if 0 < hbr < math.inf and hbr > _HBR_ORBIT_FRACTION * radius:
        # a sphere not small beside the orbit: Nc came out 1.007 at HBR 1,000 km in LEO, a
        # ConvergenceError at 7,000 km and inf at 10,000 km (audit48)
        raise InvalidInputError(
            f"method='pc3d_hall' models a hard body small beside the orbits: HBR = {hbr:.6g} m "
            f"is more than {_HBR_ORBIT_FRACTION:g} of the smaller distance from the attractor "
            f"({radius:.6g} m). Check the HBR's unit (plain numbers are m); for the chance of "
            "coming within a large distance use method='foster'.")
    if not_psd(c1, full=True) or not_psd(c2, full=True):
        _warn_repair("an input covariance (position-velocity, 6x6)")
    if window is not None:
        try:
            ta, tb = window
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(f"window must be a pair (t_a, t_b), got {window!r}.") from exc
        window = (float(si_value(ta, "s", "window[0]")), float(si_value(tb, "s", "window[1]")))
    return log_pc3d_hall(r1, v1, c1, r2, v2, c2, hbr, gm_m, window)
