"""Catalogue screening for close approaches (SGP4), single process or on Dask workers.

:func:`screen_conjunctions` runs the classic filter chain on whole arrays: apogee/perigee, then the
sampled relative motion (a sign change of the range rate brackets every local minimum of the
distance, a Hermite model estimates it), all in one compiled kernel
(:func:`visviva.core.screening.screen_rows`); then each surviving candidate is refined with SGP4
itself: the time of closest approach is the root of ``rho . rho_dot`` (Brent, 1e-5 s), and the
miss vector is expressed in the primary's RTN frame.

Blocks of primaries are independent, so the same function runs them on Dask process workers
(``client=``): each worker propagates the catalogue once and screens its rows.
"""

from __future__ import annotations

import math
import threading

import numpy as np

from .._units import require_usable_time, to_array
from ..constants import DAY_S, GM_EARTH_KM3_S2
from ..errors import InvalidInputError
from ..satellites.tle_checks import warn_stale_sets
from ..satellites.utc_days import time_to_utc_days, utc_days_to_time

__all__ = ["screen_conjunctions", "screen_block", "SCREEN_COLUMNS"]

#: output columns and their meaning
SCREEN_COLUMNS = {
    "object1": "name of the primary",
    "object2": "name of the secondary",
    "tca": "time of closest approach (UTC), within 1 ms",
    "miss_distance": "distance at TCA, km (within 1 m of SGP4)",
    "relative_speed": "|v2 - v1| at TCA, km/s",
    "radial": "R component of r2 - r1 in the primary's RTN frame, km",
    "in_track": "T component, km",
    "cross_track": "N component, km",
    "index1": "index of the primary in its catalogue",
    "index2": "index of the secondary in its catalogue",
    "satnum1": "catalogue number of the primary (masked for ephemerides)",
    "satnum2": "catalogue number of the secondary (masked for ephemerides)",
}

#: distance added to the apogee/perigee and sampling filters (km): covers the difference between
#: SGP4's mean-element perigee/apogee and its osculating radius (short-period J2, ~10 km in LEO)
FILTER_MARGIN_KM = 60.0
#: distance added to the Hermite minimum (km) at a 60 s step: the cubic Hermite model of the
#: relative motion errs by ~1e-3 km there (its error grows as step^4)
HERMITE_MARGIN_KM = 2.0


#: half-step (s) of the central difference of SGP4 positions that gives the relative velocity in
#: the TCA refinement: its error, ~ jerk h^2 / 6, is below 1e-6 km/s in LEO
_FD_HALF_STEP_S = 0.5


def _refine(src1, i, src2, j, t_lo, t_hi, window, step_s):
    """TCA near [t_lo, t_hi] (s from t0): the root of ``rho . rho_dot`` by Brent (1e-5 s).

    For SGP4 objects ``rho_dot`` is the central difference of SGP4's positions, not SGP4's
    velocities: those leave out the rates of some periodic terms (the deep-space ones most), so
    their root is not the minimum of the distance (seconds off for an eccentric deep-space
    orbit, and a miss distance up to hundreds of metres larger). Its root may then lie just
    outside the sampled bracket: the bracket widens by one step on the side it points to.
    Ephemerides use their interpolant's own derivative.
    """
    from scipy.optimize import brentq

    from .sources import SgpSource

    exact_rate = not (isinstance(src1, SgpSource) and isinstance(src2, SgpSource))
    h = _FD_HALF_STEP_S

    def rel(ts):
        r1, v1 = src1.state(i, ts)
        r2, v2 = src2.state(j, ts)
        if r1 is None or r2 is None:
            return None, None
        return r2 - r1, v2 - v1

    def f(ts):
        if exact_rate:
            rho, rho_dot = rel(ts)
            if rho is None:
                return math.nan
        else:  # SGP4 positions at ts - h, ts, ts + h: one call per object
            three = np.array([ts - h, ts, ts + h])
            p1 = src1.positions(i, three)
            p2 = src2.positions(j, three)
            if p1 is None or p2 is None:
                return math.nan
            d = p2 - p1
            rho, rho_dot = d[1], (d[2] - d[0]) / (2.0 * h)
        return float(np.dot(rho, rho_dot))

    lo, hi = max(t_lo, 0.0), min(t_hi, window)
    fa, fb = f(lo), f(hi)
    for _ in range(2):  # the positions' root just outside the velocities' bracket
        if fa < 0.0 and fb < 0.0 and hi < window:
            lo, fa = hi, fb
            hi = min(hi + step_s, window)
            fb = f(hi)
        elif fa > 0.0 and fb > 0.0 and lo > 0.0:
            hi, fb = lo, fa
            lo = max(lo - step_s, 0.0)
            fa = f(lo)
    if not (math.isfinite(fa) and math.isfinite(fb)):
        return None
    if fa >= 0.0:
        tca = lo  # receding at the start of the window
    elif fb <= 0.0:
        tca = hi  # approaching at the end
    else:
        tca = brentq(f, lo, hi, xtol=1e-5, rtol=4 * np.finfo(float).eps, maxiter=200)
    return tca


def screen_block(src1, src2, self_mode, step_s, n_steps, threshold_km, rows, cache=None):
    """Screen the primaries ``rows`` of ``src1`` against ``src2``: the unit of parallel work.

    Parameters
    ----------
    src1, src2 : SgpSource or SampledSource
        Primaries and secondaries (the same object when ``self_mode``), see
        :mod:`visviva.conjunctions.sources`.
    self_mode : bool
        Screen the catalogue against itself (pairs ``j > i``).
    step_s : float
        Sampling step, s.
    n_steps : int
        Number of samples (window ``(n_steps - 1) step_s``).
    threshold_km : float
        Reporting distance, km.
    rows : array_like of int
        Primary indices.
    cache : dict, optional
        Holds the sampled ephemerides between calls (per process).

    Returns
    -------
    list of tuple
        ``(i, j, tca_s, miss_km, speed_km_s, radial, in_track, cross_track)`` per conjunction.
    """
    from ..core.screening import screen_rows

    entry = _sampled(src1, src2, self_mode, step_s, n_steps, {} if cache is None else cache)
    r1, v1, q1, Q1, r2, v2, q2, Q2 = entry["eph"]
    el1, g1, el2, g2 = entry["path"]
    speed_bound = entry["speed"]
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    cap = 64
    while True:
        out_j = np.empty((rows.size, cap), dtype=np.int64)
        out_k = np.empty((rows.size, cap), dtype=np.int64)
        out_d = np.empty((rows.size, cap))
        counts = np.zeros(rows.size, dtype=np.int64)
        fine = HERMITE_MARGIN_KM * max(1.0, (step_s / 60.0) ** 4)
        screen_rows(r1, v1, q1, Q1, rows, r2, v2, q2, Q2, bool(self_mode), float(step_s),
                    float(threshold_km), FILTER_MARGIN_KM, fine, speed_bound, out_j, out_k, out_d,
                    counts, el1, g1, el2, g2)
        if counts.max(initial=0) <= cap:
            break
        cap = int(counts.max()) + 16
    window = (n_steps - 1) * step_s
    found = []
    for a, i in enumerate(rows):
        for c in range(int(counts[a])):
            j, k = int(out_j[a, c]), int(out_k[a, c])
            if src1.same(int(i), src2, j):
                continue  # the same object in both lists
            if k < 0:
                lo, hi = 0.0, step_s
            elif k >= n_steps - 1:
                lo, hi = window - step_s, window
            else:
                lo, hi = k * step_s, (k + 1) * step_s
            tca = _refine(src1, int(i), src2, j, lo, hi, window, step_s)
            if tca is None or any(f[0] == i and f[1] == j and abs(f[2] - tca) < 1e-3
                                  for f in found[-4:]):
                continue  # (two brackets that widened onto one minimum: once)
            ra, va = src1.state(int(i), tca)
            rb, vb = src2.state(j, tca)
            d = rb - ra
            miss = float(np.linalg.norm(d))
            if miss >= threshold_km:
                continue
            h = np.cross(ra, va)
            R = ra / np.linalg.norm(ra)
            N = h / np.linalg.norm(h)
            T = np.cross(N, R)
            found.append((int(i), j, tca, miss, float(np.linalg.norm(vb - va)),
                          float(d @ R), float(d @ T), float(d @ N)))
    return found


def _bounds(src, step_s=None, r=None):
    """The apogee/perigee shells and the orbit-path elements of one side, widened by what its
    samples ``r`` (positions every ``step_s``) show: ``(q, Q, elements, extra)``.

    The shells of SGP4's mean elements at epoch miss what the secular drift leaves out: SGP4
    lowers a dragged orbit (B* 0.01 at 400 km: 112 km in 15 days, within the staleness limit),
    and a close approach below the epoch's perigee was dropped by both filters without a word.
    So the shells also come within half of :data:`FILTER_MARGIN_KM` (each side's share, for its
    short-period terms) of every sampled radius, and ``extra`` (km, per object) is how far the
    samples stray from the drifting mean path beyond that share
    (:func:`~visviva.core.orbit_path.sampled_path_bounds`): ordinary orbits keep their filters.
    Without samples, the mean-element values (``extra`` None).
    """
    from ..core.orbit_path import sampled_path_bounds

    q, big = src.shells()
    elements = src.path_elements()
    if r is None or elements.shape[0] == 0:
        return q, big, elements, None
    out = np.zeros((len(src), 3))
    sampled_path_bounds(elements, float(step_s), r, out)
    share = 0.5 * FILTER_MARGIN_KM
    extra = np.maximum(out[:, 0] - share, 0.0)
    return np.minimum(q, out[:, 1] + share), np.maximum(big, out[:, 2] - share), elements, extra


def _path(b1, b2, self_mode, span_s):
    """The orbit-path filter's arrays for both sides (same drift chunks) from :func:`_bounds`:
    perigee and apogee radii and the drift displacement widened by each object's ``extra``."""
    from ..core.orbit_path import path_geometry, path_rate

    rate = path_rate(b1[2], b2[2])
    out = []
    for _q, _big, elements, extra in (b1,) if self_mode else (b1, b2):
        el, g = path_geometry(elements, span_s, rate)
        if extra is not None and el.shape[0]:
            el[:, 2] -= extra
            el[:, 3] += extra
            el[:, 4] += extra
        out.append((el, g))
    (el1, g1), (el2, g2) = (out[0], out[0]) if self_mode else out
    return el1, g1, el2, g2


def filter_statistics(src1, src2, span_s, threshold_km, step_s=60.0):
    """Pairs passing the apogee/perigee filter and also the orbit-path filter (two ints).

    Parameters
    ----------
    src1, src2 : SgpSource or SampledSource
        Primaries and secondaries (the same object: a self-screen).
    span_s : float
        Window length, s.
    threshold_km : float
        Screening distance, km.
    step_s : float or None
        Sampling step, s (default 60 s, the screen's default; as there, shortened so that
        whole steps fill the window). The objects are sampled over the window and both filters
        widened per object from the samples exactly as :func:`screen_conjunctions` widens them
        (:func:`_bounds`), so the counts are the pairs the screen's filters keep. ``None``:
        the filters of the mean elements at epoch alone, unwidened and without sampling; they
        keep fewer pairs where SGP4 strays from the drifting mean path (a dragged orbit sunk
        below its epoch's perigee: the pair the screen finds is counted as pruned).

    Returns
    -------
    tuple of int
        ``(after apogee/perigee, after orbit path)``.
    """
    from ..core.orbit_path import count_filter_survivors

    self_mode = src1 is src2
    if step_s is None:
        b1 = _bounds(src1)
        b2 = b1 if self_mode else _bounds(src2)
    else:
        if not float(step_s) > 0:
            raise InvalidInputError(f"step_s must be > 0 s (or None); got {step_s!r}.")
        n_steps = int(math.ceil(span_s / float(step_s))) + 1
        step = span_s / (n_steps - 1)
        ts = np.arange(n_steps) * step
        r1, _ = src1.sample(ts)
        b1 = _bounds(src1, step, r1)
        b2 = b1 if self_mode else _bounds(src2, step, src2.sample(ts)[0])
    q1, Q1, q2, Q2 = b1[0], b1[1], b2[0], b2[1]
    el1, g1, el2, g2 = _path(b1, b2, self_mode, span_s)
    out = np.zeros((len(src1), 2), dtype=np.int64)
    count_filter_survivors(q1, Q1, q2, Q2, el1, g1, el2, g2, self_mode,
                           float(threshold_km) + FILTER_MARGIN_KM, out)
    return int(out[:, 0].sum()), int(out[:, 1].sum())


_WORKER_CACHE: dict = {}
_CACHE_LOCK = threading.Lock()


def _sampled(src1, src2, self_mode, step_s, n_steps, cache):
    """The sampled ephemerides, their bounds, path filters and speed bound of one screening,
    as one dict kept in ``cache["entry"]`` and reused while the sources and grid are the same.

    A Dask worker runs blocks in several threads that share its cache: the entry is built under
    a lock and replaced whole (never cleared in place), and each block keeps the entry it got,
    so no block reads another screening's samples (a block had read the cache while another
    thread cleared it: KeyError, twentieth session).
    """
    from .sources import speed_bound

    key = (id(src1), id(src2), step_s, n_steps)
    with _CACHE_LOCK:
        entry = cache.get("entry")
        if entry is None or entry["key"] != key:
            ts = np.arange(n_steps) * step_s
            r1, v1 = src1.sample(ts)
            r2, v2 = (r1, v1) if self_mode else src2.sample(ts)
            b1 = _bounds(src1, step_s, r1)
            b2 = b1 if self_mode else _bounds(src2, step_s, r2)
            entry = {"key": key, "eph": (r1, v1, b1[0], b1[1], r2, v2, b2[0], b2[1]),
                     "path": _path(b1, b2, self_mode, (n_steps - 1) * step_s),
                     "speed": speed_bound(v1, v2)}
            cache["entry"] = entry
    return entry


def _worker_block(src1, src2, self_mode, step_s, n_steps, threshold_km, rows):
    entry = _sampled(src1, src2, self_mode, step_s, n_steps, _WORKER_CACHE)
    found = screen_block(src1, src2, self_mode, step_s, n_steps, threshold_km, rows,
                         cache={"entry": entry})
    return found, _first_failures(entry, self_mode)


def _first_failures(entry, self_mode):
    """Per object of each side, the first sample where it failed to propagate (SGP4 error:
    NaN states), -1 where none did; from the sampled ephemerides of ``entry``
    (:func:`_sampled`)."""
    out = []
    eph = entry["eph"]
    for r in (eph[0], eph[0] if self_mode else eph[4]):
        bad = ~np.isfinite(r[..., 0])
        out.append(np.where(bad.any(axis=1), bad.argmax(axis=1), -1))
    return out


def _warn_failures(first1, first2, names1, names2, self_mode, t0, step_s) -> None:
    """One RuntimeWarning naming the objects whose SGP4 failed inside the window: the
    screening of each stops at its last sample before the failure (nothing after it is
    screened, not even a minimum between that sample and the failure, so a close approach there
    would be missing from the table without it; the time named was the failed sample's, one
    step late, before audit39)."""
    from astropy import units as u

    sides = [(first1, names1)] if self_mode else [(first1, names1), (first2, names2)]
    items = [(names[i], int(first[i])) for first, names in sides
             for i in np.flatnonzero(first >= 0)]
    if not items:
        return
    import warnings

    where = ", ".join(f"{name!r} from {(t0 + max(k - 1, 0) * step_s * u.s).utc.isot[:19]}"
                      for name, k in items[:5])
    warnings.warn(
        f"SGP4 failed inside the window for {len(items)} object(s) ({where}"
        f"{', ...' if len(items) > 5 else ''}): decayed or invalid element sets, or sets run "
        "so far from their epochs that SGP4 left every Earth orbit; they are not screened "
        "from there on (close approaches after that time are not in the table).",
        RuntimeWarning, stacklevel=3)


#: The longest filter step, as a fraction of the shortest orbital period among the objects.
MAX_STEP_FRACTION = 1.0 / 8.0


def _check_step(step_s: float, asked_s: float, *sources) -> None:
    """Refuse a sampling step too long to bracket every minimum of the distance.

    Between two samples the range rate ``rho . rho_dot`` must change sign at most once; the
    distance between two orbiting objects has about two minima per orbit, so the step is held
    to :data:`MAX_STEP_FRACTION` of the shortest period, taken as that of a circular orbit at
    the lowest perigee radius (where the motion is fastest). Before, an hour's step over a LEO
    pair silently dropped an approach that a 60 s step found.
    """
    lowest = min(float(np.nanmin(src.shells()[0])) for src in sources)
    if not math.isfinite(lowest) or lowest <= 0:
        return
    period = 2.0 * math.pi * math.sqrt(lowest ** 3 / GM_EARTH_KM3_S2)
    longest = MAX_STEP_FRACTION * period
    if step_s > longest:
        raise InvalidInputError(
            f"step = {asked_s:g} s is longer than 1/8 of the shortest orbital period among the "
            f"objects ({period / 60.0:.1f} min, perigee radius {lowest:.0f} km): two close "
            "approaches could fall between two samples and one would be missed. Use a step of "
            f"at most {math.floor(longest):d} s (the default, 60 s, suits every Earth orbit).")


def screen_conjunctions(primaries, secondaries=None, t0=None, t1=None, threshold=None, *,
                        step=None, client=None, blocks=None, progress=False):
    """Find every close approach below ``threshold`` between ``t0`` and ``t1`` (SGP4).

    Parameters
    ----------
    primaries : Satellite, Catalog, CowellResult, StateVectors or list
        The objects to protect: SGP4 objects (TEME), or ephemerides (a
        :class:`~visviva.satellites.CowellResult` of one or N states with an epoch, a
        :class:`~visviva.StateVectors` history with one absolute epoch per state, a one-segment
        geocentric OEM (:func:`~visviva.read_oem`), or a list of them; positions in their
        inertial frame, covering the window; histories that say their frame, as
        ``sat.teme(t)`` does, are only screened against histories in the same one), see
        :mod:`visviva.conjunctions.sources`.
    secondaries : same kinds, optional
        The objects screened against them (of the same kind as ``primaries``); ``None`` screens
        ``primaries`` against itself. An object in both lists is never paired with itself, and
        a pair of objects that are both in both lists is reported once, from the side of the
        one that comes first among the primaries: ``screen_conjunctions(cat, cat)`` returns
        the rows of ``screen_conjunctions(cat, None)``. One object means equal element sets
        (catalogue number, epoch, mean elements, drag terms, gravity model), or for
        ephemerides equal sample times, positions and velocities; not merely the same
        catalogue number (two element sets of one object are screened, with a warning).
    t0, t1 : astropy Time
        The window.
    threshold : Quantity
        Reporting distance (default 5 km).
    step : Quantity
        Sampling step of the filter stage (default 60 s); every local minimum is bracketed
        whatever the step up to :data:`MAX_STEP_FRACTION` (1/8) of the shortest orbital period
        among the objects (that of a circular orbit at the lowest perigee), which only sets the
        cost balance. A longer step is refused: two minima of the distance could then fall
        between two samples, and one would be missed without a word.
    client : dask.distributed.Client, optional
        Screen blocks of primaries on its workers (process workers propagate the catalogue once
        each); ``None`` runs in this process.
    blocks : int, optional
        Number of blocks of primaries (default: 4 per worker, or 32 in process).
    progress : bool
        Show a tqdm progress bar over the blocks.

    Returns
    -------
    astropy.table.QTable
        One row per close approach, sorted by TCA; columns in :data:`SCREEN_COLUMNS`.

    Raises
    ------
    InvalidInputError
        ``t1 <= t0``, non-positive threshold or step, or a step longer than 1/8 of the shortest
        orbital period.

    Warns
    -----
    StaleElementSetWarning
        Element sets more than 30 days from the window (as :func:`visviva.find_passes`).
    RuntimeWarning
        Objects whose SGP4 fails inside the window (not screened from there on).

    Notes
    -----
    Filters (Hoots, Crawford & Roehrich, Celest. Mech. 33 (1984) 143; Alarcon-Rodriguez et al.,
    Adv. Space Res. 34 (2004) 1120): apogee/perigee shells widened by ``threshold`` + 60 km, then
    the sampled range rate ``rho . rho_dot`` (SGP4 positions and velocities every ``step``): a
    change of sign from - to + brackets each local minimum of the distance, so none is skipped,
    and a cubic Hermite model of the relative motion (error ~1 m at 60 s; margin 2 km, growing
    as ``step^4``) rejects those above the threshold. Survivors are refined on SGP4 itself: TCA by Brent's method on
    ``rho . rho_dot`` to 1e-5 s, ``rho_dot`` from SGP4's positions (see :func:`_refine`). Positions are TEME; the RTN components of ``r2 - r1`` use the
    primary's TEME position and velocity. Minima at the edges of the window are reported at the
    edge.
    """
    from astropy import units as u
    from astropy.table import QTable
    from astropy.time import Time

    from .sources import SgpSource, as_source, check_same_kind

    if not isinstance(t0, Time) or not isinstance(t1, Time):
        raise InvalidInputError("t0 and t1 must be astropy Time objects (the window).")
    if not (t0.isscalar and t1.isscalar):
        raise InvalidInputError(
            f"t0 and t1 must be single times (the window's ends); got shapes {t0.shape} and "
            f"{t1.shape}. Screen one window per call (and stack the tables).")
    require_usable_time(t0, "t0")
    require_usable_time(t1, "t1")
    from ..satellites.frames import offline_iers

    with offline_iers():  # a window in UT1 needs the installed IERS table, never a download
        t0, t1 = t0.tai, t1.tai
    thr = 5.0 if threshold is None else _scalar(to_array(threshold, "length", "threshold"),
                                                 "threshold", "km")
    step_s = 60.0 if step is None else _scalar(to_array(step, "time", "step"), "step", "s")
    for name, value, unit in (("threshold", thr, "km"), ("step", step_s, "s")):
        if not value > 0:  # (one message for both, naming neither, before audit54)
            raise InvalidInputError(
                f"{name} must be positive; got {value:g} {unit}. E.g. threshold=5 * u.km (the "
                "reporting distance), step=60 * u.s (the sampling step of the filters).")
    span = float((t1 - t0).to_value(u.s))
    if not span > 0:
        raise InvalidInputError(f"t1 must be after t0; got a window of {span} s.")
    asked_s = step_s
    n_steps = int(math.ceil(span / step_s)) + 1
    step_s = span / (n_steps - 1)
    jd0, fr0 = (float(x) for x in time_to_utc_days(t0))  # sgp4's UTC days of 86,400 s
    cat1 = as_source(primaries, t0, t1, "primaries", jd0, fr0)
    self_mode = secondaries is None
    cat2 = cat1 if self_mode else as_source(secondaries, t0, t1, "secondaries", jd0, fr0)
    for which, src in (("primaries", cat1), ("secondaries", cat2)):
        if len(src) == 0:  # (before the kinds: an empty list is no kind at all)
            raise InvalidInputError(f"the {which} hold no object: nothing to screen (an empty "
                                    "catalogue or TLE file?); pass at least one object.")
    check_same_kind(cat1, cat2)
    if not self_mode and cat1.keys() == cat2.keys():
        self_mode, cat2 = True, cat1  # the same objects twice: all against all, pairs once
    for src in (cat1,) if self_mode else (cat1, cat2):
        if isinstance(src, SgpSource):  # (a pass search warns the same way)
            _warn_stale(src.catalog, t0, t1)
    _check_step(step_s, asked_s, cat1, cat2)
    n1 = len(cat1)
    _check_memory(n1 + (0 if self_mode else len(cat2)), n_steps, step_s)
    if blocks is None:
        blocks = 32 if client is None else 4 * max(1, len(client.scheduler_info()["workers"]))
    blocks = max(1, min(int(blocks), n1))
    # interleaved rows balance the triangular work of a self-screen
    row_sets = [np.arange(b, n1, blocks) for b in range(blocks)]
    found = []
    if client is None:
        cache: dict = {}
        it = row_sets
        if progress:
            from tqdm.auto import tqdm

            it = tqdm(row_sets, desc="screening", unit="block")
        for rows in it:
            found.extend(screen_block(cat1, cat2, self_mode, step_s, n_steps, thr, rows,
                                      cache=cache))
        first1, first2 = _first_failures(cache["entry"], self_mode)
    else:
        c1 = client.scatter(cat1, broadcast=True)
        c2 = c1 if self_mode else client.scatter(cat2, broadcast=True)
        futures = [client.submit(_worker_block, c1, c2, self_mode, step_s, n_steps, thr, rows,
                                 pure=False) for rows in row_sets]
        if progress:
            from dask.distributed import progress as dask_progress

            dask_progress(futures)
        first1 = first2 = None
        for part, (f1, f2) in client.gather(futures):
            found.extend(part)
            first1, first2 = f1, f2  # every worker samples every object
    if not self_mode:
        found = _once_per_pair(found, cat1.keys(), cat2.keys())
    found.sort(key=lambda row: (row[2], row[0], row[1]))
    arr = np.array([f[2:] for f in found], dtype=np.float64).reshape(-1, 6)
    names1, names2 = cat1.names, cat2.names
    tab = QTable()
    tab["object1"] = [names1[f[0]] for f in found]
    tab["object2"] = [names2[f[1]] for f in found]
    if isinstance(cat1, SgpSource):  # seconds on sgp4's UTC clock (days of 86,400 s)
        tca = utc_days_to_time(np.full(len(found), jd0), fr0 + arr[:, 0] / DAY_S)
    else:  # ephemerides count SI seconds from t0 (leap seconds included)
        tca = (t0 + arr[:, 0] * u.s).utc
    tca.format = "isot"
    tab["tca"] = tca
    tab["miss_distance"] = arr[:, 1] * u.km
    tab["relative_speed"] = arr[:, 2] * u.km / u.s
    tab["radial"] = arr[:, 3] * u.km
    tab["in_track"] = arr[:, 4] * u.km
    tab["cross_track"] = arr[:, 5] * u.km
    tab["index1"] = np.array([f[0] for f in found], dtype=np.int64)
    tab["index2"] = np.array([f[1] for f in found], dtype=np.int64)
    tab["satnum1"] = _satnums(cat1, tab["index1"])
    tab["satnum2"] = _satnums(cat2, tab["index2"])
    _warn_same_object(cat1, cat2, tab)
    _warn_failures(first1, first2, names1, names2, self_mode, t0, step_s)
    return tab


def _satnums(source, index):
    """Catalogue numbers of the rows' objects: names alone are ambiguous (thousands of objects
    are called "FENGYUN 1C DEB"; audit46). Ephemerides carry none: masked."""
    from astropy.table import MaskedColumn

    from .sources import SgpSource

    index = np.asarray(index, dtype=np.int64)
    if isinstance(source, SgpSource):
        return np.asarray(source.catalog.satnums, dtype=np.int64)[index]
    return MaskedColumn(np.zeros(index.size, dtype=np.int64), mask=np.ones(index.size, bool))


def _scalar(value, name, unit) -> float:
    """One number from a converted Quantity, or a clear refusal (arrays raised numpy's
    "only 0-dimensional arrays can be converted" before audit39)."""
    if np.ndim(value) != 0:
        raise InvalidInputError(
            f"{name} must be one value; got an array of shape {np.shape(value)}. One "
            f"{name} per screening: e.g. {name}=5 * u.{unit}.")
    return float(value)


def _warn_stale(cat, t0, t1) -> None:
    """One StaleElementSetWarning for the element sets whose epochs lie more than 30 days from
    some time of the window: from its farther end, so that a long window starting at the epochs
    is not taken for a fresh one (a 60-day window from the epochs was screened without a word,
    its last weeks with SGP4 errors of kilometres; audit39)."""
    jd, fr = cat.epoch_days
    away = []
    for t in (t0, t1):
        tj, tf = time_to_utc_days(t)
        away.append(np.abs((float(tj) - jd) + (float(tf) - fr)))  # days
    sats = cat.satellites
    warn_stale_sets(lambda k: sats[k].name or sats[k].satnum, np.maximum(*away),
                    "the window", "these close approaches can be kilometres off, or missing")


def _once_per_pair(found, keys1, keys2):
    """Drop the second report of a pair whose two objects are in both lists.

    Objects ``a`` and ``b`` that are both primaries and secondaries are screened twice: ``a``
    against ``b`` and ``b`` against ``a``. The row whose primary comes first among the
    primaries is kept (as the all-against-all screening keeps ``j > i``).
    """
    first1: dict = {}
    for i, k in enumerate(keys1):
        first1.setdefault(k, i)
    in2 = set(keys2)
    out = []
    for row in found:
        i, j = row[0], row[1]
        other = first1.get(keys2[j])  # the secondary's index among the primaries
        if other is not None and keys1[i] in in2 and other < i:
            continue  # reported from the other object's side
        out.append(row)
    return out


def _warn_same_object(cat1, cat2, tab) -> None:
    """Warn when rows pair two element sets with one catalogue number (not 0): one object
    twice, not a conjunction (kept, so that no close approach is ever dropped on a guess)."""
    from .sources import SgpSource

    if not (len(tab) and isinstance(cat1, SgpSource) and isinstance(cat2, SgpSource)):
        return
    n1 = cat1.catalog.satnums[tab["index1"]]
    n2 = cat2.catalog.satnums[tab["index2"]]
    same = (n1 == n2) & (n1 != 0)
    if same.any():
        import warnings

        numbers = ", ".join(str(n) for n in sorted(set(n1[same].tolist()))[:5])
        warnings.warn(
            f"{int(same.sum())} of the {len(tab)} close approaches pair an object with itself "
            f"(catalogue number {numbers}: two element sets of one object, not a conjunction). "
            "Screen catalog.latest() (one set per object), or drop the rows whose objects "
            "share a number.", UserWarning, stacklevel=3)


def _check_memory(n_objects: int, n_steps: int, step_s: float) -> None:
    """Refuse a screening whose sampled ephemerides (positions and velocities of every object at
    every step, 48 bytes each) would need more than half of this machine's memory."""
    import os

    need = 48.0 * n_objects * n_steps
    try:
        limit = 0.5 * os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        limit = 8.0 * 2**30
    if need > limit:
        raise InvalidInputError(
            f"screening {n_objects} objects at {n_steps} steps of {step_s:g} s samples their "
            f"ephemerides at once: {need / 2**30:.3g} GiB, more than half of this machine's "
            f"memory ({2 * limit / 2**30:.3g} GiB). Screen shorter windows one after the other "
            "(element sets are good for days, not years) and stack the tables "
            "(astropy.table.vstack), screen fewer objects per call, or use a larger step."
        )

