"""Simulated tracking: observations of a known orbit with Gaussian noise (for tests, docs, study).

>>> import numpy as np, visviva as vv
>>> from astropy import units as u
>>> from astropy.time import Time
>>> epoch = Time("2024-01-01T00:00:00", scale="utc")
>>> truth = vv.StateVectors([7000, 0, 0] * u.km, [0, 5.3, 5.3] * u.km / u.s, vv.EARTH,
...                         epoch=epoch)
>>> obs = vv.od.simulate_observations(truth, epoch + np.arange(10) * 60 * u.s, "position",
...                                   0.01 * u.km, seed=1)
>>> len(obs)
10
"""

from __future__ import annotations

import numpy as np

from ..errors import DomainError, InvalidInputError
from .light_time import model
from .observations import KINDS, Observations

__all__ = ["simulate_observations", "simulate_tracking"]

#: default tracking: range 10 m (0.010 km), range rate 1 cm/s (1e-5 km/s), azimuth/elevation 0.01 deg
DEFAULT_TRACKING = (("range", 0.010), ("range_rate", 1e-5), ("azel", np.radians(0.01)))
#: default elevation mask, rad (10 deg)
MIN_ELEVATION_RAD = np.radians(10.0)


def simulate_observations(state, times, kind, sigma, station=None, perturbations=None, *,
                          maneuvers=None, seed=None, light_time=True,
                          radec_reference="gcrs", troposphere=False, ionosphere=None,
                          frequency_hz=None):  # fmt: skip
    """Observations of the orbit through ``state``, with Gaussian noise of standard deviation sigma.

    Parameters
    ----------
    state : StateVectors
        The true GCRS state, with an epoch.
    times : astropy Time (N,)
        Observation times (non-decreasing).
    kind : str or sequence of str
        Measurement kind per row (see :class:`~visviva.Observations`).
    sigma : Quantity or float or sequence
        Noise standard deviation per row (km, km/s, rad).
    station : GroundStation or sequence, optional
        Station per row (needed by every kind but ``"position"``).
    perturbations : list of Perturbation or None
        Dynamics of the truth (None: two-body).
    maneuvers : list of ImpulsiveBurn / FiniteBurn, optional
        Burns the truth flies (as :func:`~visviva.propagate_cowell`'s ``maneuvers=``; needed
        for a state from an OPM with manoeuvres, ``[]`` to leave them out).
    seed : int, numpy Generator or False, optional
        Random seed or generator of the noise; ``False`` gives the exact values (the sigmas
        are still recorded).
    light_time : bool
        Include the signal's flight time (default; see :class:`~visviva.Observations`).
    radec_reference : {"gcrs", "stars"}
        What RA/Dec rows are (see :class:`~visviva.Observations`).
    troposphere : bool or dict
        Put the neutral atmosphere in the data (see :class:`~visviva.Observations`).
    ionosphere : dict, optional
        Put the ionosphere's delay in the data (``{"vtec_tecu": 20.0}`` or ``{"klobuchar":
        (alpha, beta)}``; see :class:`~visviva.Observations`); needs ``frequency_hz``.
    frequency_hz : float or Quantity, or one per row, optional
        The signal's frequency, Hz (a two-way link's:
        :func:`visviva.od.ionosphere.two_way_frequency_hz`).

    Returns
    -------
    Observations
        The noisy table (angles wrapped into range: an elevation or declination that the
        noise carries past +-90 deg is read over the pole, at the opposite azimuth or right
        ascension), with the same ``light_time``,
        ``radec_reference``, ``troposphere``, ``ionosphere`` and ``frequency_hz``.

    Raises
    ------
    SurfaceImpact
        With perturbations, the truth below its central body's surface at some of the times
        (a decaying orbit; ``exc.t`` the first such time from the state's epoch).

    Notes
    -----
    The truth is integrated with the same variational integrator as the fit
    (:class:`visviva.od.dynamics.Dynamics`), so a fit with the same dynamics has no model error.
    """
    from .dynamics import Dynamics

    flags = {"light_time": light_time, "radec_reference": radec_reference,
             "troposphere": troposphere, "ionosphere": ionosphere, "frequency_hz": frequency_hz}
    exact = Observations(time=times, kind=kind, value=_placeholder(kind, len(times)),
                         sigma=sigma, station=station, **flags)  # fmt: skip
    from ..satellites.burn_segments import burn_schedule
    from .initial_state import check_initial

    x, gm, epoch = check_initial(state, maneuvers)
    offsets = exact.offsets_s(epoch)
    dyn = Dynamics(gm, perturbations, epoch, (offsets.min(), offsets.max()), 1e-13, 1e-13,
                   schedule=burn_schedule([] if maneuvers is None else maneuvers, state, epoch))
    y, _ = dyn.propagate(x, offsets)
    _check_above_surface(y, gm, dyn.perturbations, x, exact.times, offsets)
    h, _ = model(exact, y, gm)
    if seed is False:
        noise = np.zeros_like(h)
    else:
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        noise = rng.standard_normal(h.shape) * exact.sigmas[:, None]
    values = h + noise
    ang = np.isin(exact.kinds, ["azel", "radec"])
    # noise that carries an elevation or declination past +-90 deg reads as the direction it
    # is: over the pole, at the opposite azimuth / right ascension (was an error near the
    # zenith, or a DomainError of the table for a declination; audit20)
    over = ang & (np.abs(values[:, 1]) > np.pi / 2)
    values[over, 1] = np.copysign(np.pi, values[over, 1]) - values[over, 1]
    values[over, 0] += np.pi
    values[ang, 0] = np.mod(values[ang, 0], 2 * np.pi)
    rows = [values[i, : exact.dims[i]] for i in range(len(exact))]
    return Observations(time=exact.times, kind=list(exact.kinds), value=rows,
                        sigma=list(exact.sigmas), station=exact.stations, **flags)  # fmt: skip


def _check_above_surface(y, gm, perturbations, x, times, offsets_s):
    """Refuse a truth that is below its central body's surface at some of ``times`` (states
    ``y`` (N, 6), ``offsets_s`` from the truth's epoch), as :func:`~visviva.propagate_cowell` does: the variational integrator the
    simulator shares with the fits does not stop there (audit44: a decaying LEO truth gave
    ranges from inside the Earth for the rest of the day, without a word)."""
    from ..satellites.surface import altitude_km, watched_body

    body = watched_body(gm, perturbations, x[:3])
    if body is None:
        return
    below = np.flatnonzero(altitude_km(y[:, :3], body) < 0.0)
    if below.size:
        from astropy import units as u

        from ..errors import SurfaceImpact

        first = times[int(below[0])]
        raise SurfaceImpact(
            f"the true orbit is below the surface of {body.name} at {below.size} of the "
            f"{len(times)} times, the first at {first.utc.isot} UTC: it decays or passes through "
            "the body, where the force model means nothing and no station tracks it. Simulate "
            "times before the impact (vv.propagate_cowell finds it), or check the state.",
            t=float(offsets_s[int(below[0])]) * u.s)


def _placeholder(kind, n):
    """Stand-in values, one per row, all different (rows at one time are no repeats: those
    warn) and in every kind's range (a range >= 0, an azimuth within 2 pi)."""
    kinds = [kind] * n if isinstance(kind, str) else list(kind)
    return [np.r_[(i % 10**6) * 1e-6, np.zeros(KINDS[k][0] - 1)] if k in KINDS else 0.0
            for i, k in enumerate(kinds)]

def simulate_tracking(state, stations, times, perturbations=None, *, measurements=DEFAULT_TRACKING,
                      min_elevation=MIN_ELEVATION_RAD, seed=None, light_time=True,
                      maneuvers=None, troposphere=False, ionosphere=None,
                      frequency_hz=None, radec_reference="gcrs"):  # fmt: skip
    """A tracking campaign: every station measures whenever the satellite is high enough.

    Parameters
    ----------
    state : StateVectors
        The true GCRS state, with an epoch.
    stations : sequence of GroundStation
        The stations.
    times : astropy Time (T,)
        Candidate measurement times (increasing), e.g. every 30 s.
    perturbations : list of Perturbation or None
        Dynamics of the truth (None: two-body).
    measurements : dict or sequence of (kind, sigma)
        What each station measures at each visible time, with the noise standard deviation
        (a Quantity, or km, km/s, rad), e.g. ``{"range": 5 * u.m, "azel": 20 * u.arcsec}``
        (default: range 10 m, range rate 1 cm/s, az/el 0.01 deg).
    min_elevation : Quantity (angle) or float (rad)
        Elevation above which a station sees the satellite (default 10 deg).
    seed : int, numpy Generator or False, optional
        Noise seed (False: no noise).
    light_time : bool
        Include the signal's flight time (default; see :class:`~visviva.Observations`).
    maneuvers : list of ImpulsiveBurn / FiniteBurn, optional
        Burns the truth flies (see :func:`simulate_observations`).
    troposphere : bool or dict
        Put the neutral atmosphere in the data (see :class:`~visviva.Observations`); the
        elevation mask then applies to the refracted (apparent) elevation, as an antenna
        pointing at the satellite sees it.
    ionosphere : dict, optional
        Put the ionosphere's delay in the range and range-rate data (see
        :func:`simulate_observations`); needs ``frequency_hz``.
    frequency_hz : float or Quantity, optional
        The signal's frequency, Hz (one for every row).
    radec_reference : {"gcrs", "stars"}
        What RA/Dec rows are (see :class:`~visviva.Observations`): ``"stars"`` for optical
        astrometry reduced against catalogue stars.

    Returns
    -------
    Observations
        Rows sorted by time (at one time: stations in the given order, then ``measurements``
        in order), with ``troposphere``, ``ionosphere`` and ``frequency_hz``: each value is
        what :func:`simulate_observations` gives at its time with the same arguments.

    Raises
    ------
    InvalidInputError
        No station sees the satellite at any of the times.
    SurfaceImpact
        The truth is below the central body's surface at some of the times.
    DomainError
        A ``min_elevation`` beyond +-90 deg (degrees given as a plain number, read as radians).
    """
    from .._units import to_array

    el_min = float(to_array(min_elevation, "angle", "min_elevation"))
    if not abs(el_min) <= np.pi / 2:  # (audit44: 10 read as 573 deg, "no station sees it")
        raise DomainError(
            f"min_elevation = {el_min:g} rad is outside [-pi/2, pi/2]. Plain numbers are "
            "radians: pass degrees as a Quantity, e.g. min_elevation=10 * u.deg.")
    measurements = _measurement_pairs(measurements)
    # one set of media for the look (the mask) and the data: simulate_observations checks it
    media = {"troposphere": troposphere, "ionosphere": ionosphere, "frequency_hz": frequency_hz}
    rows = []
    for order, s in enumerate(stations):
        look = simulate_observations(state, times, "azel", 1e-9, s, perturbations, seed=False,
                                     maneuvers=maneuvers, **media)
        for i in np.flatnonzero(look.values[:, 1] > el_min):
            rows += [(i, order, k, sigma, s) for k, sigma in measurements]
    if not rows:
        raise InvalidInputError(
            "no station sees the satellite above min_elevation at any of the times; extend the "
            "times or lower min_elevation."
        )
    rows.sort(key=lambda row: (row[0], row[1]))
    idx, _, kinds, sigmas, sites = zip(*rows, strict=True)
    return simulate_observations(state, times[list(idx)], list(kinds), list(sigmas), list(sites),
                                 perturbations, seed=seed, light_time=light_time,
                                 maneuvers=maneuvers, radec_reference=radec_reference,
                                 **media)  # fmt: skip


def _measurement_pairs(measurements):
    """``measurements`` of :func:`simulate_tracking` as a list of (kind, sigma) pairs (a dict
    made a ValueError "too many values to unpack" deep inside; audit20)."""
    items = list(measurements.items()) if isinstance(measurements, dict) else list(measurements)
    for item in items:
        if not (isinstance(item, tuple | list) and len(item) == 2 and isinstance(item[0], str)):
            raise InvalidInputError(
                f"measurements must be {{kind: sigma}} or (kind, sigma) pairs, e.g. "
                f"{{'range': 5 * u.m, 'azel': 20 * u.arcsec}}; got the item {item!r}.")
        if item[0] not in KINDS:
            raise InvalidInputError(
                f"measurements: unknown kind {item[0]!r}; use one of {', '.join(KINDS)}.")
    if not items:
        raise InvalidInputError("measurements is empty: name at least one kind with its sigma.")
    return items
