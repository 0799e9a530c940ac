"""Checks of a fixed step: too short for the run (refused), too long for WHFast's orbits (warned).

WHFast solves each Kepler drift exactly, so the step only has to resolve the interaction between
the bodies; but with a step beyond a fraction of the shortest orbital timescale the map stops
following the interaction. Measured (a star with planets of 1e-3 at a = 1 and 1.6, e = 0.1 and
0.05, 100 time units, against IAS15): largest position error 8e-4, 3e-3, 1.5e-2 at
``dt = P/40, P/20, P/10`` of the inner period ``P``, then 0.26 at ``P/5``, 0.5 at ``P/3`` and
``P/2`` and 2.3 at ``0.9 P`` (the orbits' size: the planets are elsewhere), while the relative
energy error stays at 1e-3 .. 1.5e-2 and looks acceptable. An eccentric orbit needs its
pericentre passage resolved (Wisdom 2015): a test particle falling radially onto the star from
r = 1 beside a planet (dt = 0.01, 1/200 of its period) came out of the pericentre unbound
(specific energy -1 -> +0.78 with WHFast, +8.4 with leapfrog), while the total energy, which a
test particle does not enter, showed nothing; IAS15 raises StepSizeError there.

So the timescale of each orbit is that of a circular orbit at its pericentre distance ``q``,
``2 pi sqrt(q**3 / GM)`` (the period ``P`` times ``(1 - e)**1.5`` for an ellipse; hyperbolic
orbits too), for the osculating two-body orbits of the splitting: in Jacobi coordinates each
body about the centre of mass of the bodies before it (the mass inside it plus its own); in
democratic heliocentric coordinates each body about particle 0. The integrator goes on (a user
may want it), with a :class:`~visviva.errors.StepSizeWarning` (a ``UserWarning``) once the
step exceeds :data:`MAX_STEP_FRACTION` of the shortest timescale (an open orbit receding from its pericentre along the run is timed at its
present distance: the pericentre is behind it). Jacobi WHFast integrates two bodies exactly at any step, so it is checked
from three particles on. The state at the start of a call is checked, and the run's later states
by :func:`check_run` (the output snapshots, or the final state, every
:data:`RUN_CHECK_STEPS` steps or more): an orbit that turns eccentric or a close encounter met
during the run is warned about once, naming the time; one that begins and ends between two
checked snapshots is seen in Jacobi WHFast by the peak of the bodies' interaction acceleration
the kernel keeps at every step (``fstate[F_WATCH_*]``, :func:`_watched_encounter`). Reference: Wisdom & Holman (1991); Rein & Tamayo (2015),
MNRAS 452, 376; Wisdom (2015), AJ 150, 127 (resolving the pericentre).

Two bodies other than particle 0 within :data:`ENCOUNTER_HILL` mutual Hill radii (a moon, a
binary, a close encounter) move about each other through the interaction kick, as in a
leapfrog, in both splittings: a step beyond :data:`ENCOUNTER_STEP_FRACTION` of their own
pericentre timescale is warned about too (two Jupiters 0.05 apart ran silently to |dE/E| = 3.5;
Chambers 1999, MNRAS 304, 793, switches such pairs to another integrator at a few Hill radii).
"""

from __future__ import annotations

import contextlib
import contextvars
import math
import warnings
import weakref

import numpy as np

from ..core import nbody_common as _nc
from ..errors import InvalidInputError, StepSizeWarning, fmt_number

__all__ = ["MAX_STEP_FRACTION", "MIN_STEP_REL", "shortest_timescale", "check_step",
           "check_members", "members_checked", "initial_dt", "ENCOUNTER_HILL",
           "ENCOUNTER_STEP_FRACTION", "check_run", "RUN_CHECK_STEPS"]

#: A WHFast step longer than this fraction of the shortest pericentre timescale is warned about.
MAX_STEP_FRACTION = 0.2
#: Two bodies (neither particle 0) closer than this many mutual Hill radii are checked as a
#: close encounter, by the pericentre of their own two-body orbit.
ENCOUNTER_HILL = 3.0
#: ... when their masses are below this fraction of particle 0's (the Hill radius assumes a
#: dominant central body; a hierarchical triple is what Jacobi coordinates are made for).
ENCOUNTER_MASS_RATIO = 0.01
#: A WHFast step longer than this fraction of such a pair's pericentre timescale is warned
#: about (the pair is integrated as by a leapfrog: a moon's error after 90 orbits, 0.77 %, 7 %
#: and 75 % of its orbit at dt = 1e-3, 3e-3 and 1e-2 of its period).
ENCOUNTER_STEP_FRACTION = 0.002
#: Pairs (massive x all) of one system beyond which its close encounters are not checked (a
#: one-off ~0.05 s at this size; ensembles are checked in chunks of this many pair evaluations).
ENCOUNTER_MAX_PAIRS = 100_000
#: A Jacobi WHFast run whose bodies' interaction acceleration reached this times
#: ``(m_max / m_0)^(1/3)`` of the central one's (``3^(2/3) / ENCOUNTER_HILL^2``: the perturber
#: within ENCOUNTER_HILL mutual Hill radii) between two checked states is judged by
#: :func:`check_run` as a close pair (the kernel keeps the peak at every step).
WATCH_RHO = 3.0 ** (2.0 / 3.0) / ENCOUNTER_HILL**2
#: Steps of a run between two checks of its state by :func:`check_run` (a check of one state
#: costs about as much as a 1-step call, 0.1-0.3 ms: a loop of short calls is checked once per
#: this many steps, a long call at its end).
RUN_CHECK_STEPS = 1000
#: Steps between two snapshots of one call that :func:`check_run` checks (at most
#: :data:`RUN_MAX_SNAPSHOTS` of them, ~5 us each).
RUN_SNAPSHOT_STEPS = 10
RUN_MAX_SNAPSHOTS = 512
#: A fixed step below this fraction of a run's time scale is refused (IAS15's relative floor,
#: :data:`visviva.core.nbody_ias15.DT_FLOOR_REL`).
MIN_STEP_REL = 1e-15


def shortest_timescale(x, v, m, G: float, jacobi: bool = True, radius=None,
                       direction: float = 0.0) -> float:
    """The shortest pericentre timescale ``2 pi sqrt(q**3 / GM)`` of the splitting's osculating
    two-body orbits (``inf`` when there is none: no mass inside any orbit).

    Parameters
    ----------
    x, v : ndarray, shape (N, 3)
        Positions and velocities (simulation units).
    m : ndarray, shape (N,)
        Masses; particle 0 is the central body.
    G : float
        Gravitational constant.
    jacobi : bool
        Jacobi (each body about the bodies before it) or heliocentric (each about particle 0).
    radius : ndarray, shape (N,), optional
        Collision radii, when collisions are detected: an orbit whose pericentre lies within
        the radii of its body and of particle 0 ends in a collision and is skipped.
    direction : float
        The sign of the run (+1 forward, -1 backward in time, 0 unknown): an open orbit
        (e >= 1) that recedes in that direction has its pericentre behind it, so its timescale
        is that of its present distance r >= q (a flyby leaving the star is not warned about
        the pericentre it has passed).
    """
    collide = None if radius is None else np.ones(1, dtype=bool)
    return float(_timescales(x[None], v[None], m[None], np.array([G]), jacobi,
                             None if radius is None else radius[None], collide,
                             np.array([direction], dtype=float))[0])


def _timescales(x, v, m, G, jacobi: bool, radius=None, collide=None,
                direction=None) -> np.ndarray:
    """:func:`shortest_timescale` of B systems of N particles at once: ``x, v`` (B, N, 3),
    ``m`` and ``radius`` (B, N), ``G``, ``collide`` (whether a system detects collisions) and
    ``direction`` (the sign of each run, 0 unknown) (B,); returns (B,)."""
    if jacobi:
        mass = np.cumsum(m, axis=1)  # mass[:, i - 1]: inside body i
        mx = np.cumsum(m[..., None] * x, axis=1)
        mv = np.cumsum(m[..., None] * v, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            inner_x, inner_v = mx[:, :-1] / mass[:, :-1, None], mv[:, :-1] / mass[:, :-1, None]
        r, w, gm = x[:, 1:] - inner_x, v[:, 1:] - inner_v, G[:, None] * mass[:, 1:]
    else:
        r, w = x[:, 1:] - x[:, :1], v[:, 1:] - v[:, :1]
        gm = G[:, None] * (m[:, :1] + m[:, 1:])
    tau, closest = _pericentre_timescale(r, w, gm, direction)
    ok = np.isfinite(tau) & (gm > 0)
    if radius is not None:  # (a receding orbit's distance only grows: it will not collide)
        ok &= ~(collide[:, None] & (closest <= radius[:, 1:] + radius[:, :1]))
    return np.where(ok, tau, math.inf).min(axis=1)


def _pericentre_timescale(r, w, gm, direction):
    """``2 pi sqrt(q^3 / GM)`` and ``q`` of the two-body orbits of relative positions ``r`` and
    velocities ``w`` (B, K, 3) with ``gm`` (B, K); an open orbit receding along the run
    (``direction`` (B,) or (B, K), or None) is timed at its present distance."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        dist = np.sqrt(np.einsum("bij,bij->bi", r, r))
        energy = 0.5 * np.einsum("bij,bij->bi", w, w) - gm / dist
        # |r x w|^2 by components (np.cross costs ~5x more on these small arrays)
        h2 = ((r[..., 1] * w[..., 2] - r[..., 2] * w[..., 1]) ** 2
              + (r[..., 2] * w[..., 0] - r[..., 0] * w[..., 2]) ** 2
              + (r[..., 0] * w[..., 1] - r[..., 1] * w[..., 0]) ** 2)
        p = h2 / gm  # semi-latus rectum
        e = np.sqrt(np.maximum(1.0 + 2.0 * energy * p / gm, 0.0))
        q = p / (1.0 + e)  # pericentre distance, also of open orbits
        closest = q
        if direction is not None:  # an open orbit receding along the run: q is behind it
            sign = direction[:, None] if direction.ndim == 1 else direction  # (B,) or (B, K)
            receding = (e >= 1.0) & (sign * np.einsum("bij,bij->bi", r, w) > 0)
            closest = np.where(receding, dist, q)
        return 2.0 * math.pi * np.sqrt(closest**3 / gm), closest


def _encounter_timescales(x, v, m, G, radius=None, collide=None, direction=None):
    """The shortest pericentre timescale ``2 pi sqrt(q^3 / G (m_i + m_j))`` of the pairs of
    bodies other than particle 0 (at least one massive) closer than :data:`ENCOUNTER_HILL`
    mutual Hill radii ``((m_i + m_j) / 3 m_0)^(1/3) (r_i + r_j) / 2``: a moon, a binary or a
    close encounter, whose motion about each other the splitting leaves to its interaction
    kick. Returns (B,) timescales (``inf`` without such a pair, and when a system's pairs exceed
    :data:`ENCOUNTER_MAX_PAIRS`: not checked) and (B, 2) the pair of each."""
    b, n = m.shape
    out, pair = np.full(b, math.inf), np.zeros((b, 2), dtype=np.int64)
    massive = np.flatnonzero((m[:, 1:] > 0).any(axis=0)) + 1
    size = len(massive) * (n - 1)
    if n < 3 or size == 0 or size > ENCOUNTER_MAX_PAIRS:
        return out, pair
    chunk = max(1, ENCOUNTER_MAX_PAIRS // size)  # members at a time: bounded memory
    if b > chunk:
        for k in range(0, b, chunk):
            part = slice(k, k + chunk)
            out[part], pair[part] = _encounter_timescales(
                x[part], v[part], m[part], G[part], None if radius is None else radius[part],
                None if collide is None else collide[part],
                None if direction is None else direction[part])
        return out, pair
    i, j = (a.ravel() for a in np.meshgrid(massive, np.arange(1, n), indexing="ij"))
    i, j = i[i != j], j[i != j]  # both orders of a massive pair: the same timescale
    r = x[:, j] - x[:, i]
    d, mij = np.sqrt(np.einsum("bij,bij->bi", r, r)), m[:, i] + m[:, j]
    helio = np.linalg.norm(x - x[:, :1], axis=-1)  # (B, N): each body's distance to particle 0
    with np.errstate(divide="ignore", invalid="ignore"):
        hill = ENCOUNTER_HILL * np.cbrt(mij / (3.0 * m[:, :1])) * 0.5 * (helio[:, i] + helio[:, j])
        near = (d < hill) & (mij > 0) & (mij < ENCOUNTER_MASS_RATIO * m[:, :1])
    bb, kk = np.nonzero(near)  # the few pairs close enough: the rest is computed for them only
    if len(bb) == 0:
        return out, pair
    ii, jj = i[kk], j[kk]
    w, gm = v[bb, jj] - v[bb, ii], G[bb] * mij[bb, kk]
    tau, closest = _pericentre_timescale(r[bb, kk][None], w[None], gm[None],
                                         None if direction is None else direction[bb][None])
    tau, closest = tau[0], closest[0]
    with np.errstate(invalid="ignore"):  # bound to each other, or coming within the radius
        bound = 0.5 * np.einsum("ij,ij->i", w, w) < gm / d[bb, kk]
        ok = np.isfinite(tau) & (bound | (closest < hill[bb, kk]))
    if radius is not None:
        ok &= ~(collide[bb] & (closest <= radius[bb, ii] + radius[bb, jj]))
    order = np.argsort(np.where(ok, tau, math.inf))[::-1]  # the shortest last: it wins below
    out[bb[order]] = np.where(ok, tau, math.inf)[order]
    pair[bb[order]] = np.stack([ii, jj], axis=1)[order]
    return out, pair


def _criteria(x, v, m, G, jacobi, leapfrog: bool, radius=None, collide=None, direction=None):
    """The timescales the step is checked against, for B states (arguments as
    :func:`_timescales`'s): the orbits' (B,) (against :data:`MAX_STEP_FRACTION`; a leapfrog's
    close pairs included), the close pairs' (B,) (against :data:`ENCOUNTER_STEP_FRACTION`;
    ``inf`` for a leapfrog) and the pair of each (B, 2)."""
    tau = _timescales(x, v, m, G, jacobi, radius, collide, direction)
    close, pair = _encounter_timescales(x, v, m, G, radius, collide, direction)
    if leapfrog:  # a close pair is one more orbit of the kicks
        tau, close = np.minimum(tau, close), np.full(len(tau), math.inf)
    return tau, close, pair


def _too_close(dt: float, tau: float, pair) -> str:
    """What is wrong with a WHFast step ``dt`` for a pair within a few Hill radii."""
    i, j = (int(k) for k in sorted(pair))
    return (f"particles {i} and {j} are within {ENCOUNTER_HILL:g} mutual Hill radii (a moon, a "
            "binary or a close encounter), whose motion about each other WHFast leaves to its "
            "interaction kick, i.e. integrates as a leapfrog would, at dt = "
            f"{fmt_number(dt)}, {abs(dt) / tau:.2g} of their timescale 2 pi sqrt(q^3 / G (m_i + "
            f"m_j)) = {fmt_number(tau)} (q: their pericentre): its error grows like (dt / "
            "timescale)^2 per orbit (a moon at dt = 1/100 of its period was 75 % of its orbit "
            "off after 90 orbits; two planets in a close encounter came out with energy errors "
            "of 0.03 to 1e3 at any step). Use IAS15, or dt below "
            f"{ENCOUNTER_STEP_FRACTION:g} of that timescale for a moon")


def _too_long(dt: float, tau: float, coordinates: str) -> str:
    """What is wrong with a WHFast (or, ``coordinates="leapfrog"``, leapfrog) step ``dt``
    against the shortest timescale ``tau``."""
    ratio = abs(dt) / tau if tau > 0 else math.inf  # tau = 0: a radial plunge
    whose = ("the leapfrog step" if coordinates == "leapfrog" else "WHFast's step")
    orbits = ("the two-body orbits about particle 0 and of bodies within "
              f"{ENCOUNTER_HILL:g} mutual Hill radii" if coordinates == "leapfrog"
              else f"{coordinates} coordinates")
    return (f"{whose} dt = {fmt_number(dt)} is {ratio:.2g} of the shortest orbital "
            f"timescale, 2 pi sqrt(q^3 / GM) = {fmt_number(tau)} at a pericentre q "
            f"({orbits}; the period for a circular orbit; for an open orbit "
            "receding along the run, q is its present distance)")


_ADVICE = (f"beyond {MAX_STEP_FRACTION:g} of it the positions are wrong by up to the orbits' "
           "size (a plunging orbit comes out of its pericentre unbound) while the energy error "
           "can stay small. Use dt of about 1/20 of that timescale (leapfrog: 1/100 or less; "
           "its phase error grows like (dt / timescale)^2 per orbit), or IAS15.")


# the (dt, N, coordinates) each simulation was last checked with; this module owns it (weak
# keys: a simulation leaves it when it is freed; a copy is checked afresh)
_CHECKED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
# True while an ensemble advances members that check_members has checked (per thread/task)
_MEMBERS_CHECKED: contextvars.ContextVar = contextvars.ContextVar("members_checked",
                                                                  default=False)
# per ensemble: the (N, dt, coordinates) of each member at its last check
_CHECKED_ENSEMBLES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()



def initial_dt(sim) -> float:
    """A first guess for IAS15's step when no dt was given: 1e-3 of the shortest two-body time
    ``sqrt(d^3 / G (m_i + m_j))`` over a sample of the pairs (0 without a massive particle)."""
    arrays = sim.state_arrays()
    x, m = arrays["x"], arrays["m"]
    mi = np.flatnonzero(m)
    if len(mi) == 0:
        return 0.0
    d = np.linalg.norm(x[:300, None, :] - x[None, mi[:300], :], axis=-1)  # a sample: cheap
    msum = m[:300, None] + m[None, mi[:300]]
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = np.sqrt(d**3 / (sim.G * msum))
    tau = tau[np.isfinite(tau) & (tau > 0)]
    return 1e-3 * float(tau.min()) if tau.size else 0.0


def check_step(sim, times) -> None:
    """Check the fixed step of ``sim`` (a leapfrog or WHFast :class:`~visviva.Simulation`) for a
    run through ``times``: refuse one shorter than :data:`MIN_STEP_REL` of the larger of the
    run's time span and its largest |t| (the run would take over 10^15 steps: a typo such as
    ``integrate(1e300)`` hung without end in one uninterruptible compiled call), and warn when
    a WHFast step exceeds :data:`MAX_STEP_FRACTION` of the shortest pericentre timescale (or
    :data:`ENCOUNTER_STEP_FRACTION` of a close pair's). A leapfrog step (every orbit in its
    kicks) is checked against both timescales with :data:`MAX_STEP_FRACTION`, the orbits taken
    about particle 0; a softened leapfrog (no point-mass orbits) is not checked."""
    t0 = sim.t
    t1 = float(times[-1]) if len(times) else t0  # times run monotonically from t0 to here
    scale = max(abs(t0), abs(t1), abs(t1 - t0))
    if abs(sim.dt) < MIN_STEP_REL * scale:
        raise InvalidInputError(
            f"the {sim.integrator} step dt = {fmt_number(sim.dt)} is below 1e-15 of this run's "
            f"time scale ({fmt_number(scale)}: from t = {fmt_number(t0)} to "
            f"{fmt_number(times[-1])}), so it would take over 10^15 steps and never finish; "
            "check the output times (and their units) or use a longer dt.")
    leapfrog = sim.integrator == "leapfrog"  # every orbit in its kicks: no Kepler part
    if (sim.integrator not in ("whfast", "leapfrog") or _MEMBERS_CHECKED.get()
            or (leapfrog and sim.softening > 0)):  # softened: not point-mass orbits
        return
    jacobi = sim.coordinates == "jacobi" and not leapfrog
    direction = float(np.sign(t1 - t0))
    key = (sim.dt, sim.N, jacobi, direction)  # checked again when these or the particles change
    if sim.state_arrays()["istate"][_nc.I_FRESH] == 0 and _CHECKED.get(sim) == key:
        return
    _CHECKED[sim] = key
    _RUNS[sim] = [_run_key(sim), t0, False]  # check_run: from here, not warned yet
    if sim.N < (3 if jacobi else 2):
        return
    radius = None if sim.collision == "none" else sim.radii
    tau, close, pair = _criteria(
        sim.positions[None], sim.velocities[None], sim.masses[None], np.array([sim.G]), jacobi,
        leapfrog, None if radius is None else radius[None], np.array([radius is not None]),
        np.array([direction]))
    label = "leapfrog" if leapfrog else sim.coordinates
    if abs(sim.dt) > MAX_STEP_FRACTION * tau[0]:
        _RUNS[sim][2] = True
        warnings.warn(f"{_too_long(sim.dt, float(tau[0]), label)}: {_ADVICE}", StepSizeWarning,
                      stacklevel=4)
    if abs(sim.dt) > ENCOUNTER_STEP_FRACTION * close[0]:
        _RUNS[sim][2] = True
        warnings.warn(_too_close(sim.dt, float(close[0]), pair[0]) + ".", StepSizeWarning,
                      stacklevel=4)


def _run_key(sim) -> tuple:
    """What a run's check depends on beside the particles: its step, size and splitting."""
    return (sim.dt, sim.N, sim.coordinates, sim.integrator)


# per simulation: [its _run_key, the time of its last checked state, whether it was warned]
_RUNS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def check_run(sim, t0: float, t, x, v, stacklevel: int = 4) -> None:
    """Check the states a lone leapfrog or WHFast run reached (``x, v`` (K, N, 3) at the times
    ``t`` (K,), the snapshots one kernel call wrote, the last its final state; ``t0``: where
    the run began) by the criteria of :func:`check_step`, which sees the start of a call only:
    warn once, naming the time and the pair, when a close encounter or an orbit that turned
    eccentric makes the step too long (two Jupiters on crossing orbits, WHFast at dt = P/40:
    |dE/E| 4e-8 -> 0.054 at their encounters, in silence).

    The cost stays small: a state is checked only when :data:`RUN_CHECK_STEPS` steps have passed
    since the last checked one (over calls), the snapshots between at most every
    :data:`RUN_SNAPSHOT_STEPS` steps (:data:`RUN_MAX_SNAPSHOTS` per call). Once warned, a
    simulation is not checked again until its step, particles or splitting change (as
    :func:`check_step` decides)."""
    leapfrog = sim.integrator == "leapfrog"
    if (sim.integrator not in ("whfast", "leapfrog") or _MEMBERS_CHECKED.get() or len(t) == 0
            or (leapfrog and sim.softening > 0) or sim.dt == 0.0):
        return
    jacobi = sim.coordinates == "jacobi" and not leapfrog
    key, memo = _run_key(sim), _RUNS.get(sim)
    if memo is None or memo[0] != key:  # a merger changed N: counted from the call's start
        memo = _RUNS[sim] = [key, float(t0), False]
    watch = _watched_encounter(sim, jacobi)  # read at every call: it sees every step
    if memo[2] or sim.N < (3 if jacobi else 2):
        return
    found = _check_snapshots(sim, memo, t0, t, x, v, leapfrog, jacobi)
    if found is None and watch is not None:  # a snapshot names the pair: preferred
        found = (f"near t = {watch[0]}", watch[1])
    if found is not None:
        memo[2] = True
        warnings.warn(
            f"during the run, {found[0]} (the start of the call, t = {fmt_number(float(t0))}, "
            f"was fine; the states after it are not to be trusted): {found[1]}",
            StepSizeWarning, stacklevel=stacklevel)


def _check_snapshots(sim, memo, t0, t, x, v, leapfrog: bool, jacobi: bool):
    """:func:`check_run`'s check of the snapshots (when their turn has come): ``(where,
    message)`` of the first wrong one, or None."""
    steps = np.abs(np.asarray(t, dtype=float) - memo[1]) / abs(sim.dt)
    if not steps[-1] >= RUN_CHECK_STEPS:
        return None
    bins = np.floor(steps / RUN_SNAPSHOT_STEPS)  # the last snapshot of each bin, the final one
    pick = np.flatnonzero(np.r_[bins[1:] != bins[:-1], True])
    if len(pick) > RUN_MAX_SNAPSHOTS:
        pick = pick[np.linspace(0, len(pick) - 1, RUN_MAX_SNAPSHOTS).round().astype(np.int64)]
    memo[1] = float(t[-1])
    b = len(pick)
    radius = None if sim.collision == "none" else np.repeat(sim.radii[None], b, axis=0)
    tau, close, pair = _criteria(
        x[pick], v[pick], np.repeat(sim.masses[None], b, axis=0), np.full(b, sim.G), jacobi,
        leapfrog, radius, np.full(b, radius is not None),
        np.full(b, float(np.sign(t[-1] - t0))))
    dt = abs(sim.dt)
    with np.errstate(invalid="ignore"):
        bad = (dt > MAX_STEP_FRACTION * tau) | (dt > ENCOUNTER_STEP_FRACTION * close)
    if not bad.any():
        return None
    k = int(np.flatnonzero(bad)[0])
    label = "leapfrog" if leapfrog else sim.coordinates
    what = (_too_close(sim.dt, float(close[k]), pair[k]) + "."
            if dt > ENCOUNTER_STEP_FRACTION * close[k]
            else f"{_too_long(sim.dt, float(tau[k]), label)}: {_ADVICE}")
    return f"at t = {fmt_number(float(t[pick[k]]))}", what


def _watched_encounter(sim, jacobi: bool):
    """The close encounter a Jacobi WHFast kernel saw between two checked states, from the peak
    it kept of a body's interaction acceleration ``A`` relative to its Kepler one, ``rho = A r^2
    / G eta`` (``fstate[F_WATCH_*]``, cleared here): ``(time, message)``, or None.

    From the perturber alone (mass ``m_j <= m_max``, the largest but particle 0's), ``A ~ G m_j /
    d^2`` at a distance ``d``: ``rho`` beyond :data:`WATCH_RHO` ``(m_max / m_0)^(1/3)`` puts it
    within :data:`ENCOUNTER_HILL` mutual Hill radii, and the pair's timescale ``2 pi sqrt(d^3 /
    G (m_i + m_j))`` is at most ``2 pi (2 G m_max)^(1/4) / A^(3/4)``: a step beyond
    :data:`ENCOUNTER_STEP_FRACTION` of that is beyond it of theirs (the criterion of
    :func:`check_step`, from below). Systems with a body of :data:`ENCOUNTER_MASS_RATIO` of
    particle 0 or more are not judged (as there)."""
    arrays = sim.state_arrays()
    fstate = arrays["fstate"]
    peak = float(fstate[_nc.F_WATCH_RHO2])
    if not peak > 0.0:
        return None
    a2, when = float(fstate[_nc.F_WATCH_A2]), float(fstate[_nc.F_WATCH_T])
    body = int(fstate[_nc.F_WATCH_BODY])
    # all four cleared: the state after a call does not depend on how it was cut into kernel
    # calls (the interpreter tier's chunks)
    fstate[_nc.F_WATCH_RHO2] = fstate[_nc.F_WATCH_A2] = 0.0
    fstate[_nc.F_WATCH_T] = fstate[_nc.F_WATCH_BODY] = 0.0
    m = arrays["m"]
    if not (jacobi and sim.integrator == "whfast" and len(m) >= 3):
        return None
    m_max = float(m[1:].max())
    if not 0.0 < m_max < ENCOUNTER_MASS_RATIO * m[0]:
        return None
    rho = math.sqrt(peak)
    if not rho > WATCH_RHO * math.cbrt(m_max / m[0]):
        return None
    tau = 2.0 * math.pi * (2.0 * sim.G * m_max) ** 0.25 / math.sqrt(a2) ** 0.75
    if not abs(sim.dt) > ENCOUNTER_STEP_FRACTION * tau:
        return None
    return fmt_number(when), (
        f"particle {body} passed within {ENCOUNTER_HILL:g} mutual Hill radii of another body "
        f"(its acceleration by the others reached {rho:.2g} of the central one's) between two "
        "checked states, a close encounter that WHFast integrates as a leapfrog would: dt = "
        f"{fmt_number(sim.dt)} is at least {abs(sim.dt) / tau:.2g} of the pair's timescale 2 pi "
        "sqrt(d^3 / G (m_i + m_j)) there (a flyby 0.12 Hill radii apart at dt = P/40 "
        "changed the energy by 7.6 %). Use IAS15, or outputs often enough to see the encounter")


@contextlib.contextmanager
def members_checked():
    """Within: :func:`check_step` leaves the WHFast step to :func:`check_members`, which has
    checked the ensemble's members and warned once for all of them (a short step is still
    refused)."""
    token = _MEMBERS_CHECKED.set(True)
    try:
        yield
    finally:
        _MEMBERS_CHECKED.reset(token)


def check_members(owner, members, pack=None, stacklevel: int = 3, t=None) -> None:
    """Warn once (one :class:`~visviva.errors.StepSizeWarning` naming the members) when the
    WHFast (or leapfrog) step of any of an ensemble's ``members`` exceeds
    :data:`MAX_STEP_FRACTION` of its shortest pericentre timescale, as :func:`check_step`
    does for a lone simulation; run it before advancing them inside :func:`members_checked`. ``owner`` (the ensemble) keeps each member's ``(N, dt,
    coordinates)``: a member is checked again when those change or its integrator restarts.
    Works on whole arrays (``pack``: the members' packed arrays, when there is one): a call
    whose members were all checked costs a few comparisons of length-M arrays. ``stacklevel``:
    as :func:`warnings.warn`'s, counted from the caller (the user's call, 3 levels up). ``t``:
    the time the members are advanced to (the direction of each run; None: unknown)."""
    leapfrog = members[0].integrator == "leapfrog"  # as in check_step
    if members[0].integrator not in ("whfast", "leapfrog"):
        return
    x, v, m, radius, fstate, istate, poff = _member_arrays(members, pack)
    n, dt = np.diff(poff), fstate[:, _nc.F_DT].copy()
    coords = istate[:, _nc.I_WH_COORDINATES].copy()
    direction = (np.zeros(len(n)) if t is None
                 else np.sign(float(t) - fstate[:, _nc.F_T]))
    todo = istate[:, _nc.I_FRESH] != 0
    last = _CHECKED_ENSEMBLES.get(owner)
    if last is None or len(last[0]) != len(n):
        todo[:] = True
    else:
        todo |= (n != last[0]) | (dt != last[1]) | (coords != last[2]) | (direction != last[3])
    _CHECKED_ENSEMBLES[owner] = (n, dt, coords, direction)
    run = _RUN_ENSEMBLES.get(owner)  # check_members_run counts from each member's check
    if run is None or len(run[0]) != len(n):
        run = _RUN_ENSEMBLES[owner] = [fstate[:, _nc.F_T].copy(), np.zeros(len(n), dtype=bool)]
    run[0][todo], run[1][todo] = fstate[todo, _nc.F_T], False
    jacobi = (coords == 0) & (not leapfrog)
    todo &= (n >= np.where(jacobi, 3, 2)) & (dt != 0.0) & (m[poff[:-1]] > 0.0)
    if leapfrog:
        todo &= fstate[:, _nc.F_SOFT2] == 0.0
    if not todo.any():
        return
    tau, close, pairs = _member_criteria(todo, leapfrog, jacobi, direction, x, v, m, radius,
                                         fstate, istate, poff)
    with np.errstate(invalid="ignore"):
        bad = np.flatnonzero(todo & (np.abs(dt) > MAX_STEP_FRACTION * tau))
        near = np.flatnonzero(todo & (np.abs(dt) > ENCOUNTER_STEP_FRACTION * close))
    run[1][bad], run[1][near] = True, True  # check_members_run: warned already
    if len(near):
        k = int(near[0])
        warnings.warn(
            f"WHFast: {len(near)} of the {len(n)} ensemble members have two bodies within "
            f"{ENCOUNTER_HILL:g} mutual Hill radii ({', '.join(map(str, near[:20].tolist()))}"
            f"{', ...' if len(near) > 20 else ''}); member {k}: "
            f"{_too_close(float(dt[k]), float(close[k]), pairs[k])}.",
            StepSizeWarning, stacklevel=stacklevel)
    if not len(bad):
        return
    with np.errstate(divide="ignore"):
        worst = int(bad[np.argmax(np.abs(dt[bad]) / tau[bad])])
    listed = ", ".join(map(str, bad[:20].tolist())) + (", ..." if len(bad) > 20 else "")
    name = "leapfrog" if leapfrog else "jacobi" if jacobi[worst] else "democratic_heliocentric"
    whose = "The leapfrog step" if leapfrog else "WHFast's step"
    warnings.warn(
        f"{whose} is too long for the orbits of {len(bad)} of the {len(n)} ensemble "
        f"members ({listed}); the worst, member {worst}: "
        f"{_too_long(float(dt[worst]), float(tau[worst]), name)}: {_ADVICE}",
        StepSizeWarning, stacklevel=stacklevel)


# per ensemble: [the time of each member's last checked state, whether it was warned]
_RUN_ENSEMBLES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _member_arrays(members, pack=None) -> tuple:
    """``x, v, m, radius, fstate, istate, poff`` of an ensemble's members: the pack's arrays,
    or their states concatenated."""
    if pack is not None:
        return (pack.x, pack.v, pack.m, pack.radius, pack.fstate, pack.istate, pack.poff)
    states = [s.state_arrays() for s in members]
    x, v, m, radius = (np.concatenate([st[k] for st in states])
                       for k in ("x", "v", "m", "radius"))
    fstate, istate = (np.stack([st[k] for st in states]) for k in ("fstate", "istate"))
    poff = np.concatenate([[0], np.cumsum([s.N for s in members])]).astype(np.int64)
    return x, v, m, radius, fstate, istate, poff


def _member_criteria(todo, leapfrog, jacobi, direction, x, v, m, radius, fstate, istate, poff):
    """:func:`_criteria` of the members ``todo`` (M,) (``inf`` for the others), grouped by
    size and splitting."""
    n, ks = np.diff(poff), np.flatnonzero(todo)
    tau, close = np.full(len(n), math.inf), np.full(len(n), math.inf)
    pairs = np.zeros((len(n), 2), dtype=np.int64)
    for size in np.unique(n[ks]).tolist():
        for jac in (True, False):
            group = ks[(n[ks] == size) & (jacobi[ks] == jac)]
            if len(group):
                idx = poff[group][:, None] + np.arange(size)
                tau[group], close[group], pairs[group] = _criteria(
                    x[idx], v[idx], m[idx], fstate[group, _nc.F_G], jac, leapfrog,
                    radius[idx], istate[group, _nc.I_COLLISIONS] != 0, direction[group])
    return tau, close, pairs


def check_members_run(owner, members, pack=None, stacklevel: int = 3) -> None:
    """:func:`check_run` for an ensemble's ``members`` after :meth:`Ensemble.integrate`
    advanced them (their final states; :func:`check_members` saw their start): one warning
    naming the members whose state is found wrong, each member warned once (until
    :func:`check_members` checks it afresh), and checked when :data:`RUN_CHECK_STEPS` of its
    steps have passed since its last checked state."""
    run = _RUN_ENSEMBLES.get(owner)
    leapfrog = members[0].integrator == "leapfrog"
    if run is None or members[0].integrator not in ("whfast", "leapfrog"):
        return
    x, v, m, radius, fstate, istate, poff = _member_arrays(members, pack)
    n, t_now, dt = np.diff(poff), fstate[:, _nc.F_T], fstate[:, _nc.F_DT]
    if len(run[0]) != len(n):
        return
    jacobi = (istate[:, _nc.I_WH_COORDINATES] == 0) & (not leapfrog)
    with np.errstate(invalid="ignore"):
        due = (~run[1] & (np.abs(t_now - run[0]) >= RUN_CHECK_STEPS * np.abs(dt))
               & (n >= np.where(jacobi, 3, 2)) & (dt != 0.0) & (m[poff[:-1]] > 0.0))
    if leapfrog:
        due &= fstate[:, _nc.F_SOFT2] == 0.0
    if not due.any():
        return
    tau, close, pairs = _member_criteria(due, leapfrog, jacobi, np.sign(t_now - run[0]), x, v,
                                         m, radius, fstate, istate, poff)
    run[0][due] = t_now[due]
    with np.errstate(invalid="ignore"):
        near = due & (np.abs(dt) > ENCOUNTER_STEP_FRACTION * close)
        bad = near | (due & (np.abs(dt) > MAX_STEP_FRACTION * tau))
    if not bad.any():
        return
    run[1][bad] = True
    listed = np.flatnonzero(bad)
    k = int(listed[0])
    name = "leapfrog" if leapfrog else "jacobi" if jacobi[k] else "democratic_heliocentric"
    what = (_too_close(float(dt[k]), float(close[k]), pairs[k]) + "." if near[k]
            else f"{_too_long(float(dt[k]), float(tau[k]), name)}: {_ADVICE}")
    warnings.warn(
        f"during the run: {len(listed)} of the {len(n)} ensemble members reached a state their "
        f"step is wrong for ({', '.join(map(str, listed[:20].tolist()))}"
        f"{', ...' if len(listed) > 20 else ''}; the start of the call was fine, the states "
        f"after are not to be trusted); member {k}, at t = {fmt_number(float(t_now[k]))}: "
        f"{what}", StepSizeWarning, stacklevel=stacklevel)
