"""A state's covariance carried through Cowell's full force model.

:func:`propagate_covariance` integrates the state with its state-transition matrix
Phi(t, t0) = d y(t) / d y(t0) (the variational equations of :mod:`visviva.core.variational`,
driven by :class:`visviva.satellites.variational.Dynamics`, the driver orbit determination
uses) and maps the covariance linearly, P(t) = Phi P0 Phi^T, with every force of
:func:`visviva.propagate_cowell`: zonal harmonics, drag, third bodies, solar radiation pressure
with the saltation of a cylindrical shadow's jump. Optional process noise (state noise
compensation) adds the growth of a white-noise acceleration between steps.

>>> import numpy as np
>>> import visviva as vv
>>> from astropy import units as u
>>> from astropy.time import Time
>>> state = vv.StateVectors([7000.0, 0, 0] * u.km, [0, 5.0, 5.8] * u.km / u.s, vv.EARTH,
...                         epoch=Time("2024-01-01T00:00:00", scale="utc"))
>>> P0 = np.diag([1e-3, 1e-3, 1e-3, 1e-9, 1e-9, 1e-9])  # 30 m and 3 cm/s (km, km/s)
>>> out = vv.propagate_covariance(state, P0, [0, 1, 2] * u.h, [vv.J2(vv.EARTH)], frame="RTN")
>>> out.covariance.shape, out.stm.shape
((3, 6, 6), (3, 6, 6))
>>> bool(out.position_sigma[2, 1] > out.position_sigma[0, 1])  # along-track grows
True
"""

from __future__ import annotations

import numpy as np
from astropy import units as u

from .._covariance import (
    as_covariance,
    check_shape,
    frame_code,
    from_local,
    km_covariance,
    local_axes_of,
    require_psd,
    to_local,
)
from .._units import require_finite, to_array, to_quantity, to_vector
from ..errors import InvalidInputError, ShapeError, StepSizeError, SurfaceImpact
from .cowell import CowellResult, output_offsets_s, perturbation_list
from .dop853 import integration_tolerances
from .satellite_states import require_gcrs
from .surface import altitude_km, watched_body

__all__ = ["propagate_covariance", "CovarianceResult", "DEFAULT_NOISE_STEP_S"]

#: Longest interval (s) over which the process noise is taken as in a straight line (SNC).
DEFAULT_NOISE_STEP_S = 60.0


class CovarianceResult(CowellResult):
    """States with their covariance and state-transition matrix (:func:`propagate_covariance`).

    Attributes
    ----------
    t, r, v, epoch
        As in :class:`~visviva.satellites.CowellResult`: output times from the epoch (s),
        positions (km) and velocities (km/s), shape (T, 3) ((3,) for a scalar time).
    covariance : ndarray (T, 6, 6)
        The covariance at each output time, km^2, km^2/s, km^2/s^2, on the axes of ``frame``
        ((6, 6) for a scalar time).
    stm : ndarray (T, 6, 6)
        Phi(t, t0) = d y(t) / d y(t0), inertial (GCRS) axes, s and 1/s^2 in its off-diagonal
        blocks (independent of the length unit).
    frame : str
        The frame of ``covariance``: ``"GCRS"`` or a local frame of the state at each time.
    process_noise : ndarray (3,) or None
        The acceleration noise density used, km^2/s^3 per axis of ``process_noise_frame``.
    process_noise_frame : str or None
        ``"RTN"``, ``"GCRS"``, ... (None without process noise).
    impulses : list of ImpulsiveBurn
        The impulsive burns flown (``maneuvers=``), by epoch.
    delta_v_partials : ndarray (T, 6, 3 n)
        d y(t) / d Δv of each of the ``impulses`` (s in the position rows, dimensionless in
        the velocity rows; Δv on each burn's own axes, the state on inertial axes; zero
        before a burn).
    """

    def __init__(self, base, covariance, stm, frame, process_noise, noise_frame):
        self.__dict__.update(base.__dict__)
        self.covariance = km_covariance(covariance, frame)  # (marked with its local axes)
        self.stm = stm
        self.frame = frame
        self.process_noise = process_noise
        self.process_noise_frame = noise_frame

    @property
    def position_sigma(self):
        """1-sigma of the three position components on the axes of ``frame`` (Quantity, km)."""
        return np.sqrt(np.diagonal(self.covariance, axis1=-2, axis2=-1)[..., :3]) * u.km

    @property
    def velocity_sigma(self):
        """1-sigma of the three velocity components on the axes of ``frame`` (Quantity, km/s)."""
        return np.sqrt(np.diagonal(self.covariance, axis1=-2, axis2=-1)[..., 3:]) * u.km / u.s

    def __repr__(self):
        return f"CovarianceResult({len(self)} times, frame={self.frame!r})"


#: Position sigma, as a fraction of |r|, above which a linear map means nothing (warned).
HUGE_SIGMA_FRACTION = 0.01


def _warn_if_huge(P0, r0):
    """Warn when the position sigma is a sizable fraction of the orbit (a matrix in m^2 read as
    km^2 gives this: a CDM's covariance is in m, m/s)."""
    sigma = float(np.sqrt(np.max(np.diag(P0)[:3])))
    if sigma > HUGE_SIGMA_FRACTION * float(np.linalg.norm(r0)):
        import warnings

        warnings.warn(
            f"the covariance's largest position sigma is {sigma:.6g} km, "
            f"{sigma / np.linalg.norm(r0):.2g} of |r|: a linear propagation means little at "
            "that size. Plain numbers are km^2, km^2/s, km^2/s^2; a matrix in m^2 (a CDM's) "
            "must be passed as a Quantity (cov * u.m**2).", UserWarning, stacklevel=3)


def noise_density(q):
    """The process-noise density as three values, km^2/s^3, or None (also for
    :func:`visviva.filter_orbit`)."""
    if q is None:
        return None
    arr = np.atleast_1d(to_array(q, "accel_psd", "process_noise", allow_plain=True))
    if arr.shape == (1,):
        arr = np.repeat(arr, 3)
    if arr.shape != (3,):
        raise ShapeError(
            f"process_noise must be one density or three (one per axis), km^2/s^3; got shape "
            f"{arr.shape}."
        )
    if np.any(arr < 0):
        raise InvalidInputError(
            f"process_noise must be >= 0 (a spectral density, km^2/s^3); got {arr}."
        )
    return arr


def noise_step_s(noise_step):
    """The longest interval of the process noise, s: a time Quantity or plain seconds, one
    finite value > 0; None gives :data:`DEFAULT_NOISE_STEP_S` (also for
    :func:`visviva.filter_orbit`)."""
    if noise_step is None:
        return DEFAULT_NOISE_STEP_S
    step = np.ravel(to_array(noise_step, "time", "noise_step", allow_plain=True))
    if step.size != 1:
        raise ShapeError(f"noise_step must be one interval (s); got {step.size} values.")
    require_finite(step, "noise_step")
    if not step[0] > 0:
        raise InvalidInputError(f"noise_step must be > 0; got {step[0]} s.")
    return float(step[0])


def _noise_grid(offsets, step):
    """The output times with points every ``step`` s between them and the epoch (both sides)."""
    pts = [offsets, [0.0]]
    for side in (offsets[offsets < 0], offsets[offsets > 0]):
        if side.size:
            far = float(np.max(np.abs(side)))
            n = int(np.ceil(far / step))
            pts.append(np.sign(side[0]) * np.linspace(0.0, far, n + 1))
    return np.unique(np.concatenate(pts))


def snc_covariance(dt, qc):
    """Process noise of a white-noise acceleration over ``dt`` s of straight-line motion.

    Parameters
    ----------
    dt : float
        Interval, s (negative for a backward step).
    qc : ndarray (3, 3)
        Spectral density of the acceleration in inertial axes, km^2/s^3.

    Returns
    -------
    ndarray (6, 6)
        Q = [[|dt|^3/3 Qc, dt |dt|/2 Qc], [dt |dt|/2 Qc, |dt| Qc]], km^2, km^2/s, km^2/s^2:
        the covariance a constant-velocity random walk accumulates (Tapley, Schutz & Born
        2004, sec. 4.9, state noise compensation).
    """
    a = abs(dt)
    out = np.empty((6, 6))
    out[:3, :3] = a**3 / 3.0 * qc
    out[:3, 3:] = out[3:, :3] = dt * a / 2.0 * qc
    out[3:, 3:] = a * qc
    return out


def with_process_noise(grid, y, phi, P0, q, noise_code, jumps=None):
    """Covariances at the ``grid`` times (sorted, holding 0) with process noise, by the
    recursion P_k+1 = Phi_k+1,k P_k Phi_k+1,k^T + Q_k outward from the epoch.

    ``y`` (states) and ``phi`` (Phi(t, 0)) are at the grid times, ``P0`` at 0, ``q`` the three
    densities (km^2/s^3) on the axes of ``noise_code`` (:func:`visviva._covariance.frame_code`;
    0 inertial). Also the prediction step of :func:`visviva.filter_orbit`. ``jumps`` (optional,
    {grid index: (6, 6)}) adds a covariance on arrival at that index (a burn's execution error
    mapped there, :func:`burn_noise`).
    """
    P = np.empty((grid.size, 6, 6))
    k0 = int(np.flatnonzero(grid == 0.0)[0])
    jumps = jumps or {}
    P[k0] = P0
    if k0 in jumps or not np.array_equal(phi[k0], np.eye(6)):  # after an impulse at 0
        p0 = phi[k0] @ P0 @ phi[k0].T + jumps.get(k0, 0.0)
        P[k0] = 0.5 * (p0 + p0.T)
    for direction in (1, -1):
        k = k0
        # backwards from the state given, before any impulse at 0 (Phi(t, 0-) on that side)
        p_k, phi_k = (P[k0], phi[k0]) if direction > 0 else (P0, np.eye(6))
        while 0 <= k + direction < grid.size:
            j = k + direction
            step = np.linalg.solve(phi_k.T, phi[j].T).T  # Phi(t_j, t_k) = Phi_j Phi_k^-1
            pj = step @ p_k @ step.T + step_noise(y[k], y[j], grid[j] - grid[k], q, noise_code)
            if j in jumps:
                pj = pj + jumps[j]
            P[j] = 0.5 * (pj + pj.T)
            k, p_k, phi_k = j, P[j], phi[j]
    return P


def noise_substeps(dt, q, step_s, cut=False):
    """The sub-steps (s from the interval's start) of a filter's prediction over ``dt`` s: the
    interval itself without process noise (``q`` None) unless ``cut`` (Gauss-Markov
    coefficients), else equal steps of at most ``step_s`` (which may be infinite)."""
    if (q is None and not cut) or dt <= step_s:
        return np.array([dt])
    return np.linspace(0.0, dt, int(np.ceil(dt / step_s)) + 1)[1:]


def step_noise(y_from, y_to, dt, q, noise_code):
    """The state noise compensation Q (6, 6) of one step of ``dt`` s between the states
    ``y_from`` and ``y_to`` (km, km/s): :func:`snc_covariance` with the density ``q`` (three
    values, km^2/s^3) on the axes of ``noise_code`` (0 inertial), a local frame's density
    averaged over the step's ends. The noise of :func:`with_process_noise` and of the unscented
    filter's prediction (:mod:`visviva.od.unscented`)."""
    from ..core.local_frames import local_axes

    diag = np.diag(q)
    if noise_code:  # the local axes' density, averaged over the interval's ends
        mk = local_axes(y_from[:3], y_from[3:], noise_code)
        mj = local_axes(y_to[:3], y_to[3:], noise_code)
        qc = 0.5 * (mk.T @ diag @ mk + mj.T @ diag @ mj)
    else:
        qc = diag
    return snc_covariance(dt, qc)


def burn_noise(schedule, grid, sens, start=0.0, apply_at_start=True):
    """The execution errors of the impulses of ``schedule``, each mapped to the first time of
    ``grid`` past its burn (away from ``start``): {grid index: S C S^T}, S = d y / d Δv there
    (``sens`` (T, 6, 3 n), :func:`visviva.satellites.burn_partials.propagate_through`), C the
    burn's ``execution_covariance``. Burns without one, or not crossed (one at ``start``
    without ``apply_at_start``), add nothing."""
    from .burn_partials import impulses_of

    out = {}
    times = {id(m): a for a, _, m in (schedule.items if schedule else [])}
    for k, burn in enumerate(impulses_of(schedule)):
        c = burn.execution_covariance
        if c is None:
            continue
        t_b = times[id(burn)]
        if t_b == start and not apply_at_start:
            continue
        if t_b >= start:
            idx = np.flatnonzero(grid >= t_b)
            j = int(idx[0]) if idx.size else None
        else:
            idx = np.flatnonzero(grid < t_b)
            j = int(idx[-1]) if idx.size else None
        if j is None:
            continue
        s_j = sens[j, :, 3 * k:3 * k + 3]
        out[j] = out.get(j, 0.0) + s_j @ c @ s_j.T
    return out


def propagate_covariance(state, covariance, t, perturbations=(), *, maneuvers=None,
                         frame: str = "GCRS",
                         output_frame: str | None = None, process_noise=None,
                         process_noise_frame: str = "RTN", noise_step=None, consider=None,
                         rtol: float = 1e-12, atol: float = 1e-12, max_steps: int = 200_000):
    """Propagate a state and its 6 x 6 covariance with Cowell's full force model.

    Parameters
    ----------
    state : StateVectors
        One GCRS state (``r``, ``v`` of shape (3,)) with its ``epoch`` where the force model
        needs one (third bodies, SRP, NRLMSIS, harmonics); e.g. ``fit.state`` of
        :func:`~visviva.fit_orbit` (or call ``fit.propagate(t)``).
    covariance : array_like or Quantity, shape (6, 6)
        The covariance of (x, y, z, vx, vy, vz) at the state's epoch: plain numbers in km^2,
        km^2/s, km^2/s^2 (what ``fit.covariance`` holds), or an area Quantity (the whole matrix
        read in its length unit and seconds, e.g. a CDM's covariance in m^2). Symmetric,
        positive semi-definite and finite, else refused; on the axes of ``frame`` (a matrix of
        an ``output_frame="RTN"`` result knows it is RTN: another ``frame`` is refused).
    t : Quantity or astropy Time
        Output times: offsets from the epoch (scalar or 1-D, strictly increasing, any sign:
        negative times give the covariance at earlier times) or absolute Times.
    perturbations : list of Perturbation or None
        As for :func:`~visviva.propagate_cowell`; ``[]`` or None is two-body motion.
    maneuvers : list of ImpulsiveBurn / FiniteBurn, optional
        Burns flown through (as :func:`~visviva.propagate_cowell`'s ``maneuvers=``, e.g. an
        OPM's ``opm.burns()``; ``[]`` for none): the STM crosses each impulse with its
        Jacobian, and an impulse's ``execution_covariance`` (its ``delta_v_covariance`` or
        ``magnitude_sigma``/``pointing_sigma``) is added at the burn. Finite burns are
        integrated with their thrust's partials. Either direction of time. None (default):
        no burns, and a state from an OPM with manoeuvres is refused.
    frame : str
        Axes of ``covariance``: ``"GCRS"`` (inertial) or a local frame of the state, ``"RTN"``
        (alias ``"RSW"``, ``"RIC"``), ``"TNW"``, ``"VNB"``.
    output_frame : str, optional
        Axes of the result's covariances (default: ``frame``); a local frame is that of the
        state at each output time.
    process_noise : float, array_like (3,) or Quantity, optional
        Spectral density q of a white-noise acceleration on each axis of
        ``process_noise_frame``, km^2/s^3 (= (km/s^2)^2 per Hz); None: no process noise.
    process_noise_frame : str
        ``"RTN"`` (default) or ``"GCRS"``: the axes ``process_noise`` is given on.
    noise_step : Quantity or float, optional
        Longest interval over which the noise is added in straight-line motion, s (default
        60 s).
    consider : dict, optional
        Uncertain force-model coefficients and their sigmas, ``{"drag": 0.004 * u.m**2 /
        u.kg}`` (the ballistic coefficient of the one :class:`~visviva.AtmosphericDrag`),
        ``{"srp": 0.2}`` (the reflectivity of the one :class:`~visviva.SolarRadiationPressure`):
        held at their values, their variance C mapped through the sensitivities S(t) = d y(t) /
        d p integrated with the STM and added, P(t) += S C S^T (uncorrelated with the state);
        ``.parameter_partials`` (T, 6, q) holds S (:mod:`visviva.satellites.force_parameters`).
    rtol, atol : float
        Integration tolerances of the state (atol in km and km/s); the defaults are
        :func:`~visviva.propagate_cowell`'s, so the states equal its states to ~1e-9 relative.
    max_steps : int
        Step budget of each direction of time (a LEO day takes ~2000 steps; a decaying orbit
        exhausts it, and is then reported as the :class:`~visviva.SurfaceImpact` it is).

    Returns
    -------
    CovarianceResult
        ``.t``, ``.r``, ``.v`` (as from :func:`~visviva.propagate_cowell`), ``.covariance``
        (T, 6, 6) in ``output_frame``, km-based units; ``.stm`` (T, 6, 6) inertial;
        ``.position_sigma``, ``.velocity_sigma``.

    Warns
    -----
    UserWarning
        A position sigma above 1 % of |r| (where a linear map means little; also what a matrix
        in m^2 passed as plain numbers looks like).

    Raises
    ------
    InvalidInputError
        A covariance that is not symmetric, not positive semi-definite, or not finite; a state
        from an OPM with manoeuvres without ``maneuvers=``; bad frames.
    ShapeError
        A covariance that is not 6 x 6, or a batch of states.
    SurfaceImpact
        An output state below the central body's surface (with perturbations).

    Notes
    -----
    The linear map of a covariance by the state-transition matrix (Tapley, Schutz & Born 2004,
    sec. 4.2; Montenbruck & Gill 2000, sec. 7.1)::

        P(t) = Phi(t, t0) P0 Phi(t, t0)^T,    Phi' = F(t, y) Phi,  Phi(t0) = I,

    F the Jacobian of the full force model (:mod:`visviva.core.variational`). In a local frame
    the covariance is rotated, C_local = M C M^T with M = blockdiag(Q, Q) and Q the frame's
    axes, the velocity block on the same axes as the position block (the CCSDS/CARA
    convention; :mod:`visviva.core.local_frames`).

    Process noise is the state noise compensation of Tapley, Schutz & Born (2004), sec. 4.9:
    a white acceleration of density Q_c = diag(q) (rotated from ``process_noise_frame``,
    averaged over the two ends of each interval) adds, over an interval dt taken in
    straight-line motion::

        Q(dt) = [[|dt|^3/3 Q_c, dt|dt|/2 Q_c], [dt|dt|/2 Q_c, |dt| Q_c]],

    and P_k+1 = Phi(t_k+1, t_k) P_k Phi(t_k+1, t_k)^T + Q(t_k+1 - t_k) on a grid of at most
    ``noise_step`` s. Over one LEO orbit with 60-s intervals this is within 0.2 % of the exact
    integral of Phi(t, tau) B Q_c B^T Phi(t, tau)^T over tau (tested by quadrature).

    The map is linear: it holds while the uncertainty stays small against the orbit's
    nonlinearity. A large along-track uncertainty after many revolutions bends along the orbit
    (a "banana"), which a Gaussian in Cartesian coordinates cannot describe; docs/cowell.md,
    "Covariance propagation", measures where this begins against a Monte Carlo.

    Through a burn (:mod:`visviva.satellites.burn_partials`): an impulse Δv held on a local
    frame's axes turns with the state, v+ = v- + M(r, v-)^T Δv, so its STM is not the identity
    but Phi_burn = I + [[0, 0], [d(M^T Δv)/dr, d(M^T Δv)/dv]] (analytic). Its execution error,
    a covariance C of the Δv on the burn's axes, adds S C S^T with S = Phi(t, t_b+)
    [[0], [M^T]]: at an output time t past the burn::

        P(t) = Phi(t, t0) P0 Phi(t, t0)^T + sum_k S_k(t) C_k S_k(t)^T.

    Backwards across a burn the maps are inverted (Phi_burn^-1, S = -Phi(t, t_b-)
    Phi_burn^-1 [[0], [M^T]]). A finite burn's thrust on a local frame enters the variational
    equations with its partials a(t) d(M^T u)/d(r, v); its execution error is not modelled
    (add process noise over it).
    """
    if not hasattr(state, "r") or not hasattr(state, "v") or not hasattr(state, "gm"):
        raise InvalidInputError(
            "state must be a vv.StateVectors (with .r, .v, .gm), e.g. fit.state of vv.fit_orbit."
        )
    require_gcrs(state, "propagate_covariance")
    if maneuvers is None:
        from .._containers import refuse_pending

        refuse_pending(state, "propagate_covariance", "Pass maneuvers=opm.burns() to fly them "
                       "(with their execution errors), or maneuvers=[] to propagate without.")
    r0 = to_vector(state.r, "length", "state.r")
    v0 = to_vector(state.v, "speed", "state.v")
    if r0.shape != (3,) or v0.shape != (3,):
        raise ShapeError(
            f"propagate_covariance takes one state (r and v of shape (3,)); got {r0.shape} and "
            f"{v0.shape}. Loop over the states (state[i]) with their own covariances."
        )
    if np.linalg.norm(np.cross(r0, v0)) == 0:
        raise InvalidInputError("r x v = 0: the state has no orbit plane (a radial or zero state).")
    gm = float(np.ravel(to_array(state.gm, "gm", "state.gm"))[0])
    if not gm > 0:
        raise InvalidInputError("the state's GM must be > 0 (e.g. vv.EARTH.gm).")
    epoch = getattr(state, "epoch", None)
    if epoch is not None and not epoch.isscalar:
        epoch = epoch.ravel()[0]
    in_code = frame_code(frame, "frame")
    marked = local_axes_of(covariance)  # (an RTN output fed back in: on RTN axes, not GCRS)
    if marked is not None and frame_code(marked) != in_code:
        raise InvalidInputError(
            f"covariance is on the {marked} axes (an output_frame={marked!r} result), but "
            f"frame = {frame!r}; pass frame={marked!r}.")
    P0 = as_covariance(covariance, "covariance", length_unit="km")
    check_shape(P0, "covariance")
    out_name = frame if output_frame is None else output_frame
    out_code = frame_code(out_name, "output_frame")
    P0 = from_local(P0, r0, v0, in_code)
    require_psd(P0, "covariance")
    _warn_if_huge(P0, r0)
    q = noise_density(process_noise)
    noise_code = frame_code(process_noise_frame, "process_noise_frame")
    step_s = noise_step_s(noise_step)
    offsets = output_offsets_s(t, epoch)
    scalar = offsets.ndim == 0
    offsets = np.atleast_1d(offsets)
    if offsets.ndim != 1 or offsets.size == 0:
        raise ShapeError(f"t must be a scalar or a non-empty 1-D array; got shape {offsets.shape}.")
    require_finite(offsets, "t")
    if np.any(np.diff(offsets) <= 0):
        raise InvalidInputError(
            "the output times must be strictly increasing; sort them (np.sort) and remove "
            "duplicates."
        )
    rtol, atol = integration_tolerances(rtol, atol)
    if isinstance(max_steps, bool) or not isinstance(max_steps, int | np.integer) or max_steps <= 0:
        raise InvalidInputError(f"max_steps must be an integer > 0; got {max_steps!r}.")
    perturbations = list(perturbation_list(perturbations, allow_none=True))
    body = watched_body(gm, perturbations, r0)
    from .burn_partials import impulses_of
    from .burn_segments import burn_schedule
    from .force_parameters import coefficients, partials
    from .variational import Dynamics

    _, con = coefficients(perturbations, None, None, consider)
    schedule = burn_schedule([] if maneuvers is None else maneuvers, state, epoch)
    grid = offsets if q is None else _noise_grid(offsets, step_s)
    dyn = Dynamics(gm, perturbations, epoch, (grid.min(), grid.max()), rtol, atol,
                   schedule=schedule)
    try:
        y, phi = dyn.propagate(np.concatenate([r0, v0]), grid, max_steps, parameters=bool(con))
    except (StepSizeError, InvalidInputError):
        if body is not None:  # through the surface? propagate_cowell finds where, and says so
            from .cowell import propagate_cowell

            propagate_cowell(state, grid * u.s, perturbations, rtol=rtol, atol=atol,
                             max_steps=max_steps, maneuvers=maneuvers or [])
        raise
    if q is None:
        P = phi @ P0 @ np.swapaxes(phi, -1, -2)
        for k, burn in enumerate(impulses_of(schedule)):
            if burn.execution_covariance is not None:
                s_k = dyn.sensitivity[:, :, 3 * k:3 * k + 3]
                P = P + s_k @ burn.execution_covariance @ np.swapaxes(s_k, -1, -2)
        P = 0.5 * (P + np.swapaxes(P, -1, -2))
    else:
        P = with_process_noise(grid, y, phi, P0, q, noise_code,
                               burn_noise(schedule, grid, dyn.sensitivity))
    keep = np.searchsorted(grid, offsets)
    if q is not None:
        y, phi, P = y[keep], phi[keep], P[keep]
    s_p = partials(dyn, con)[keep] if con else np.zeros((offsets.size, 6, 0))
    if con:  # the consider parameters, uncorrelated with the state and the noise
        c = np.diag([k.sigma ** 2 for k in con])
        P = P + s_p @ c @ np.swapaxes(s_p, -1, -2)
    P = to_local(P, y[:, :3], y[:, 3:], out_code)
    if body is not None:
        h = altitude_km(y[:, :3], body)
        if np.any(h < 0):
            k = int(np.flatnonzero(h < 0)[0])
            raise SurfaceImpact(
                f"the trajectory is below the surface of {body.name} at t = {offsets[k]:.6f} s "
                "from the epoch, where the force model means nothing; propagate to earlier "
                "times.", t=offsets[k] * u.s)
    base = CowellResult(
        to_quantity(offsets[0] if scalar else offsets, "time"),
        to_quantity(np.ascontiguousarray(y[0, :3] if scalar else y[:, :3]), "length"),
        to_quantity(np.ascontiguousarray(y[0, 3:] if scalar else y[:, 3:]), "speed"),
        gm, epoch, [], False,
        float(offsets[-1] if offsets[-1] >= 0 else offsets[0]) * u.s, dyn.n_steps,
        dyn.n_evaluations, scalar,
    )
    out_label = "GCRS" if out_code == 0 else str(out_name).upper()
    out = CovarianceResult(base, P[0] if scalar else P, phi[0] if scalar else phi, out_label,
                           q, None if q is None else str(process_noise_frame).upper())
    sens = dyn.sensitivity if q is None else dyn.sensitivity[keep]
    out.impulses = impulses_of(schedule)
    out.delta_v_partials = sens[0] if scalar else sens
    out.parameter_partials = s_p[0] if scalar else s_p
    return out
