"""What the screening kernel reads: sampled states of a set of objects, from SGP4 or ephemerides.

:func:`~visviva.conjunctions.screen_conjunctions` screens either SGP4 element sets (a
:class:`~visviva.Catalog`, TEME) or ephemerides: a :class:`~visviva.satellites.CowellResult` (one
or N states), a :class:`~visviva.StateVectors` history with absolute epochs, or a list of them
(positions in their own inertial frame, e.g. GCRS). Both are wrapped here behind the same four
operations: sample every object on the screening grid, the radial shells of the apogee/perigee
filter, one object's state at any time (for the TCA refinement) and the names.

Ephemerides are interpolated with the Hermite polynomial of degree 7 through the positions and
velocities of the four samples around each time (:data:`HERMITE_NODES`): its error grows as
``h^8``. On a two-body LEO orbit it is 0.1 mm at 120 s, 3.7 cm at 300 s and 8.6 m at 600 s (the
cubic Hermite of the two samples around each time, used before the twentieth session: 5.6 m,
220 m and 3.5 km), so an OEM or Cowell run with 300 s outputs is screened to the centimetre.
Where the velocities are not the positions' derivatives (SGP4 histories) the cubic one may be
better, and is chosen per ephemeris (:func:`interpolation_choice`) from an estimate of each one's
error made from the samples themselves (leave-one-out, :func:`_estimate_km`).
"""

from __future__ import annotations

import math

import numpy as np

from ..constants import DAY_S
from ..core.interpolation import hermite, hermite_windows, windows
from ..errors import InvalidInputError
from ..satellites.tle_checks import flag_beyond_earth_orbit

__all__ = ["SgpSource", "SampledSource", "as_source"]


class SgpSource:
    """SGP4 element sets (a Catalog) as a screening source; states in TEME, km and km/s."""

    frame = "SGP4 objects (TEME)"

    def __init__(self, catalog, jd0, fr0):
        self.catalog = catalog
        self.jd0 = jd0
        self.fr0 = fr0

    def __len__(self):
        return len(self.catalog)

    @property
    def names(self):
        return self.catalog.names

    def sample(self, ts):
        """Positions and velocities ``(N, T, 3)`` at ``ts`` (s from t0); NaN where SGP4 fails
        (an error code, or a position beyond any Earth orbit as :meth:`visviva.Satellite.teme`
        refuses)."""
        jd = np.full(ts.size, self.jd0)
        e, r, v = self.catalog.satrec_array.sgp4(jd, self.fr0 + ts / DAY_S)
        flag_beyond_earth_orbit(e, r)  # no Earth orbit (SGP4 far outside its span): failed
        bad = e != 0
        if bad.any():
            r[bad] = np.nan
            v[bad] = np.nan
        return np.ascontiguousarray(r), np.ascontiguousarray(v)

    def shells(self):
        """Perigee and apogee radii (km) of SGP4's mean elements."""
        sat = [s.satrec for s in self.catalog]
        re = np.array([s.radiusearthkm for s in sat])
        q = (1.0 + np.array([s.altp for s in sat])) * re
        big_q = (1.0 + np.array([s.alta for s in sat])) * re
        return q, big_q

    def path_elements(self):
        """Mean elements at t0 and secular rates for the orbit-path filter, ``(N, 7)``
        (:data:`visviva.core.orbit_path.PATH_ELEMENTS`; km, rad, rad/s)."""
        out = np.empty((len(self.catalog), 7))
        t0 = self.jd0 + self.fr0
        for n, sat in enumerate(self.catalog):
            s = sat.satrec
            dt_min = (t0 - (s.jdsatepoch + s.jdsatepochF)) * 1440.0
            e = min(s.ecco, 0.999)
            out[n] = (s.a * s.radiusearthkm * (1.0 - e * e), e, s.inclo,
                      s.nodeo + s.nodedot * dt_min, s.argpo + s.argpdot * dt_min,
                      s.nodedot / 60.0, s.argpdot / 60.0)
        return out

    def state(self, i, ts):
        """State of object ``i`` at ``ts`` (s from t0), or ``(None, None)`` if SGP4 fails."""
        e, r, v = self.catalog[i].satrec.sgp4(self.jd0, self.fr0 + ts / DAY_S)
        if e:
            return None, None
        return np.array(r), np.array(v)

    def positions(self, i, ts):
        """Positions of object ``i`` at the times ``ts`` (s from t0, array), km, shape
        ``(len(ts), 3)``, in one SGP4 call; None if SGP4 fails at one of them."""
        ts = np.asarray(ts, dtype=np.float64)
        e, r, _ = self.catalog[i].satrec.sgp4_array(np.full(ts.size, self.jd0),
                                                    self.fr0 + ts / DAY_S)
        return None if np.any(e) else r

    def keys(self):
        """One hashable identity per object: its element set (catalogue number, epoch, mean
        elements, drag terms and gravity model). Two equal element sets propagate to the same
        states, so they are one object (see :meth:`same`)."""
        if getattr(self, "_keys", None) is None:
            self._keys = [_element_key(sat.satrec) for sat in self.catalog]
        return self._keys

    def same(self, i, other, j):
        """Whether object ``i`` here and ``j`` of ``other`` are one object (equal keys)."""
        return other is self and i == j or self.keys()[i] == other.keys()[j]


def _element_key(s):
    return (str(getattr(s, "satnum_str", s.satnum)).strip(), s.jdsatepoch, s.jdsatepochF,
            s.no_kozai, s.ecco, s.inclo, s.nodeo, s.argpo, s.mo, s.bstar, s.ndot, s.nddot,
            s.radiusearthkm, s.mu)


class SampledSource:
    """Ephemerides (sample times, positions, velocities per object) as a screening source.

    Parameters
    ----------
    times : list of ndarray (T_i,)
        Sample times of each object, s from the screening start, increasing.
    r, v : list of ndarray (T_i, 3)
        Positions (km) and velocities (km/s) at those times.
    names : list of str
        Object names.
    frame : str
        The frame of the positions.
    nodes : list of int, optional
        Samples per interpolation window of each object (4: degree 7, 2: cubic; see
        :func:`interpolation_choice`); default :data:`HERMITE_NODES` for all.
    """

    frame = "GCRS ephemerides"

    def __init__(self, times, r, v, names, frame="GCRS", nodes=None):
        self.frame = f"{frame} ephemerides"
        self.times = times
        self.r = r
        self.v = v
        self._names = list(names)
        self.nodes = [HERMITE_NODES] * len(times) if nodes is None else list(nodes)

    def __len__(self):
        return len(self.times)

    @property
    def names(self):
        return self._names

    def _interp(self, i, ts):
        tau, p, m = self.times[i], self.r[i], self.v[i]
        ts = np.atleast_1d(np.asarray(ts, dtype=np.float64))
        r, v = hermite(tau, p, m, ts, min(self.nodes[i], tau.size) - 1)
        out = (ts < tau[0] - 1e-9) | (ts > tau[-1] + 1e-9)
        r[out] = np.nan
        v[out] = np.nan
        return r, v

    def sample(self, ts):
        """Hermite-interpolated positions and velocities ``(N, T, 3)``; NaN outside an ephemeris."""
        r = np.empty((len(self), ts.size, 3))
        v = np.empty_like(r)
        for i in range(len(self)):
            r[i], v[i] = self._interp(i, ts)
        return r, v

    def shells(self):
        """Smallest and largest sampled radius of each object (km); the filter's margin covers
        the radius between samples."""
        rad = [np.linalg.norm(x, axis=-1) for x in self.r]
        return np.array([x.min() for x in rad]), np.array([x.max() for x in rad])

    def path_elements(self):
        """No mean elements: the orbit-path filter is off for ephemerides (the sampled filters
        see every approach)."""
        return np.empty((0, 7))

    def state(self, i, ts):
        r, v = self._interp(i, ts)
        if not np.all(np.isfinite(r)):
            return None, None
        return r[0], v[0]

    def keys(self):
        """One hashable identity per object: its ephemeris (sample times, positions and
        velocities, bit for bit); two equal ephemerides are one object (see :meth:`same`)."""
        if getattr(self, "_keys", None) is None:
            self._keys = [(np.asarray(t, np.float64).tobytes(), np.asarray(r, np.float64).tobytes(),
                           np.asarray(v, np.float64).tobytes())
                          for t, r, v in zip(self.times, self.r, self.v, strict=True)]
        return self._keys

    def same(self, i, other, j):
        """Whether object ``i`` here and ``j`` of ``other`` are one object (equal keys)."""
        return other is self and i == j or self.keys()[i] == other.keys()[j]


#: samples per interpolation window of an ephemeris: the Hermite polynomial through their
#: positions and velocities has degree 7 (:func:`visviva.core.interpolation.hermite`, the
#: window centred on the query time, clamped at the ends; fewer for shorter ephemerides)
HERMITE_NODES = 4

#: Estimated interpolation error (km) above which an ephemeris is too coarse for screening
INTERPOLATION_WARN_KM = 0.01


#: The estimate evaluates the interpolation (and its node polynomial) at 1/4, 1/2 and 3/4 of
#: every sample gap (7 points per gap read the same within 10 %, at twice the cost)
_GAP_POINTS = 4
#: Safety factor on the velocities' part of the estimate: the velocity mismatch is taken as
#: constant over each held-out window, which reads it up to ~20 % low where it varies within
#: the window (SGP4 LEO and Molniya histories every 300 s)
_VELOCITY_MARGIN = 1.5


def _estimate_km(tau, r, v, span, m):
    """Estimated largest error (km) over ``[0, span]`` of the Hermite interpolation with ``m``
    samples per window, from the samples themselves; None when there are too few samples.

    Each sample ``k`` is interpolated from its ``m`` neighbours (``m / 2`` on each side) with
    the same interpolant (leave-one-out). The error has two parts:

    * truncation: ``f^(2m)(xi) / (2m)! prod (t - t_j)^2`` (Burden & Faires, Numerical
      Analysis, Thm. 3.9); the position residual divided by the held-out node polynomial
      ``prod (t_k - t_j)^2`` estimates ``|f^(2m)| / (2m)!`` at ``k``, which times the largest
      node polynomial of the screen's own windows over each gap (``0.316 h^8`` in the middle
      of degree 7's, against ``16 h^8`` held out) gives the gap's truncation error;
    * velocities that are not the positions' derivatives (SGP4's leave out the rates of some
      periodic terms): the velocity residual at ``k`` is ``delta_k (1 - w)`` for a mismatch
      ``delta`` constant over the window, ``w`` the derivative at ``t_k`` of the held-out
      interpolant of zero positions and unit velocities; the mismatch so estimated, carried
      through the screen's interpolant of zero positions (:data:`_VELOCITY_MARGIN` times),
      gives its part.

    The two are added, plus a rounding floor of ``1e-14 max|r|``.
    """
    n = tau.size
    half = m // 2
    if n < m + 1:
        return None
    # samples whose windows touch [0, span]
    lo = max(int(np.searchsorted(tau, 0.0, side="right")) - 1 - m, 0)
    hi = min(int(np.searchsorted(tau, span, side="left")) + 1 + m, n)
    tau, r, v = tau[lo:hi], r[lo:hi], v[lo:hi]
    n = tau.size
    if n < m + 1:
        return None
    offsets = np.r_[np.arange(-half, 0), np.arange(1, half + 1)]
    k = np.arange(half, n - half)
    idx = k[:, None] + offsets[None, :]
    # one pass: the samples, and (4th column) zero positions with unit velocities for w
    held, dheld = hermite_windows(idx, tau, np.c_[r, np.zeros(n)], np.c_[v, np.ones(n)], tau[k])
    residual = np.linalg.norm(r[k] - held[:, :3], axis=-1)
    delta = np.empty_like(v)
    delta[k] = (v[k] - dheld[:, :3]) / (1.0 - dheld[:, 3:])
    delta[:half] = delta[half]
    delta[n - half:] = delta[n - half - 1]
    # the screen's windows at points inside every gap
    frac = np.arange(1, _GAP_POINTS) / _GAP_POINTS
    tq = (tau[:-1, None] + np.diff(tau)[:, None] * frac[None, :]).ravel()
    node_poly = np.prod((tq[:, None] - tau[windows(tau, tq, m)]) ** 2, axis=1)
    node_poly = node_poly.reshape(n - 1, frac.size).max(axis=1)
    f_2m = residual / np.prod((tau[k][:, None] - tau[idx]) ** 2, axis=1)
    gap = np.arange(n - 1)
    f_gap = np.zeros(n - 1)
    for d in range(-1, 3):  # the held-out samples of the gap's own window
        f_gap = np.maximum(f_gap, f_2m[np.clip(gap + d, half, n - half - 1) - half])
    inside = (tau[1:] > 0.0) & (tau[:-1] < span)
    if not inside.any():
        inside[:] = True
    truncation = float(np.max((node_poly * f_gap)[inside]))
    carried, _ = hermite(tau, np.zeros_like(r), delta, tq, m - 1, want_derivative=False)
    mismatch = np.linalg.norm(carried, axis=-1).reshape(n - 1, frac.size).max(axis=1)
    velocities = _VELOCITY_MARGIN * float(np.max(mismatch[inside]))
    return truncation + velocities + 1e-14 * float(np.max(np.abs(r)))


def interpolation_choice(tau, r, v, span):
    """Samples per interpolation window of one ephemeris (4 or 2), and the estimated largest
    position error (km) of that interpolation over the window ``[0, span]`` (s from t0).

    Both interpolations are estimated from the samples (:func:`_estimate_km`) and the better
    one is kept: the degree-7 one wins by orders of magnitude on ephemerides whose velocities
    are the derivatives of their positions (numerical propagation, most OEMs), while the cubic
    one suffers less from velocities that are not (SGP4's leave out the rates of some
    periodic terms: a Molniya history from ``sat.teme(t)`` every 60 s is off by 10 m cubic,
    14 m degree 7). Against the truth (dense Kepler or SGP4 propagation between the samples)
    on LEO, Molniya and GEO orbits every 60, 300 and 600 s the estimate of the kept
    interpolation is 1.1 to 3 times the true largest error, 4.2 times on a Molniya SGP4
    history every 600 s (2.5 km for 0.6 km); never below it. (Before leftfix7 it was
    extrapolated from held-out samples at twice and four times the spacing: 450 m for 8.6 m
    on a two-body LEO every 600 s, and 0.4 m for 4.6 m on an SGP4 LEO history every 300 s.)
    ``(m, None)`` when there are too few samples to compare.
    """
    best = None
    for m in (HERMITE_NODES, 2):
        est = _estimate_km(tau, r, v, span, m)
        if est is not None and (best is None or est < best[1]):
            best = (m, est)
    if best is None:
        return min(HERMITE_NODES, tau.size), None
    return best


def interpolation_error_km(tau, r, v, span):
    """The estimated largest position error (km) of the interpolation the screening uses for
    one ephemeris over ``[0, span]`` (:func:`interpolation_choice`), or None."""
    return interpolation_choice(tau, r, v, span)[1]


def _warn_coarse(coarse, name):
    """One warning naming the ephemerides whose interpolation error exceeds
    :data:`INTERPOLATION_WARN_KM` (``coarse``: (index, error km, spacing s, samples per
    window))."""
    import warnings

    worst = max(coarse, key=lambda c: c[1])
    n, err, h, m = worst
    finer = h * (1e-3 / err) ** (1.0 / (2 * m))
    warnings.warn(
        f"{len(coarse)} of the {name}' ephemerides are sampled too coarsely for the Hermite "
        f"interpolation of the screening (degree {2 * m - 1}): {name}[{n}] "
        f"(samples every {h:.4g} s) is off "
        f"by about {err * 1e3:.3g} m between its samples (estimated from the samples "
        "themselves), so its close approaches, TCAs and miss distances are that far off. Give "
        f"samples every {finer:.3g} s or less for ~1 m (an OEM's own interpolation: "
        "oem.segments[0].interpolate(times) on such a grid).",
        UserWarning, stacklevel=5)


def _history(obj, t0, name):
    """(times from t0 in s, r km, v km/s) of one object's ephemeris; a list for N objects."""
    from astropy import units as u
    from astropy.time import Time

    from ..satellites.cowell import CowellResult
    from ..satellites.frames import offline_iers
    from ..states import StateVectors

    if isinstance(obj, CowellResult):
        if obj.epoch is None:
            raise InvalidInputError(f"{name}: the CowellResult has no epoch (give the initial "
                                    "StateVectors an epoch to screen its ephemeris).")
        with offline_iers():  # an epoch in UT1 needs the installed IERS table, no download
            tau = (obj.epoch.tai - t0.tai).to_value(u.s) + obj.t.to_value(u.s)
        r = obj.r.to_value(u.km)
        v = obj.v.to_value(u.km / u.s)
        if r.ndim == 2:
            return [(np.atleast_1d(tau), r, v)]
        return [(np.atleast_1d(tau), r[n], v[n]) for n in range(r.shape[0])]
    if isinstance(obj, StateVectors):
        if not isinstance(obj.epoch, Time) or obj.epoch.ndim != 1 or obj.r.ndim != 2:
            raise InvalidInputError(f"{name}: a StateVectors history needs r of shape (T, 3) "
                                    "and one absolute epoch per state (a 1-D Time).")
        with offline_iers():  # epochs in UT1 need the installed IERS table, no download
            tau = (obj.epoch.tai - t0.tai).to_value(u.s)
        return [(tau, obj.r.to_value(u.km), obj.v.to_value(u.km / u.s))]
    raise InvalidInputError(
        f"{name} must be a Satellite, a Catalog, a CowellResult, a StateVectors history, an "
        f"OEM or a list of them; got {type(obj).__name__}.")


def _sampled(objs, t0, t1, name):
    from astropy import units as u

    items = objs if isinstance(objs, (list, tuple)) else [objs]
    times, rs, vs, names, nodes = [], [], [], [], []
    span = float((t1 - t0).to_value(u.s))
    frames = set()
    coarse = []  # (index, estimated interpolation error km, spacing s)
    for n, obj in enumerate(items):
        _check_useable(obj, t0, span, f"{name}[{n}]")
        obj = _oem_states(obj, f"{name}[{n}]")
        frames.add(_frame(obj, f"{name}[{n}]"))
        for tau, r, v in _history(obj, t0, f"{name}[{n}]"):
            tau = np.asarray(tau, dtype=np.float64)
            if tau.size < 2 or np.any(np.diff(tau) <= 0):
                raise InvalidInputError(f"{name}[{n}]: an ephemeris needs at least two samples "
                                        "at increasing times.")
            if tau[0] > 1e-6 or tau[-1] < span - 1e-6:
                raise InvalidInputError(
                    f"{name}[{n}]: the ephemeris spans {tau[0]:.3f} to {tau[-1]:.3f} s from t0, "
                    f"which does not cover the screening window (0 to {span:.3f} s); propagate "
                    "over the whole window.")
            if not (np.all(np.isfinite(r)) and np.all(np.isfinite(v))):
                raise InvalidInputError(f"{name}[{n}]: the ephemeris contains NaN.")
            times.append(tau)
            rs.append(np.ascontiguousarray(r, dtype=np.float64))
            vs.append(np.ascontiguousarray(v, dtype=np.float64))
            n_nodes, err = interpolation_choice(tau, rs[-1], vs[-1], span)
            nodes.append(n_nodes)
            if err is not None and err > INTERPOLATION_WARN_KM:
                coarse.append((len(names), err, float(np.median(np.diff(tau))), n_nodes))
            names.append(f"{name}[{len(names)}]")
    if coarse:
        _warn_coarse(coarse, name)
    if len(frames) > 1:
        raise InvalidInputError(
            f"{name}: ephemerides in {' and '.join(sorted(frames))} are mixed, and positions in "
            "different frames cannot be compared; give every history in one frame (e.g. "
            "sat.gcrs(t)).")
    return SampledSource(times, rs, vs, names, frames.pop() if frames else "GCRS", nodes)


def _oem_states(obj, name):
    """The states of a one-segment Earth-centred OEM (they know their frame); other objects
    unchanged."""
    if not hasattr(obj, "segments"):
        return obj
    if len(obj.segments) != 1:
        raise InvalidInputError(
            f"{name}: the OEM has {len(obj.segments)} segments (a manoeuvre between them breaks "
            "the interpolation): screen each segment's span with oem.segments[k].states.")
    seg = obj.segments[0]
    if str(seg.center).strip().upper() != "EARTH" or seg.visviva_frame is None:
        raise InvalidInputError(
            f"{name}: the OEM has CENTER_NAME = {seg.center}, REF_FRAME = {seg.frame}; "
            "screening needs geocentric states in GCRF/EME2000/ICRF or TEME.")
    return seg.states


def _check_useable(obj, t0, span, name):
    """Refuse an OEM whose useable span (``USEABLE_START_TIME`` .. ``USEABLE_STOP_TIME``)
    does not cover the window: the states outside it are there for the interpolation at the
    span's ends only (CCSDS 502.0-B-3, 5.2.3), not to be used as the ephemeris."""
    segs = getattr(obj, "segments", None)
    if not segs or len(segs) != 1:
        return  # not an OEM (or refused with its reason by _oem_states)
    seg = segs[0]
    meta = seg.metadata
    if "USEABLE_START_TIME" not in meta and "USEABLE_STOP_TIME" not in meta:
        return
    from ..satellites.frames import offline_iers

    with offline_iers():  # a UT1 file needs the installed IERS table, never a download
        lo = float((seg.start.tai - t0.tai).to_value("s"))
        hi = float((seg.stop.tai - t0.tai).to_value("s"))
    if lo > 1e-6 or hi < span - 1e-6:
        raise InvalidInputError(
            f"{name}: the OEM is useable from {meta.get('USEABLE_START_TIME', seg.start)} to "
            f"{meta.get('USEABLE_STOP_TIME', seg.stop)} ({lo:.3f} to {hi:.3f} s from t0), which "
            f"does not cover the screening window (0 to {span:.3f} s): its states outside the "
            "useable span serve the interpolation only. Screen a window inside the useable "
            "span.")


def _frame(obj, name):
    """The frame of one ephemeris: satellite states say theirs (TEME, GCRS); the rest are
    taken as GCRS. The rotating ITRS is refused (its velocities would tilt the RTN axes), and
    so are states marked with a frame visviva cannot rotate (an OEM's ``TOD`` states)."""
    from ..satellites.satellite_states import FRAMES, frame_of

    own = frame_of(obj)  # (plain states may carry a mark: TEME, or a REF_FRAME such as TOD)
    if own is not None and own not in FRAMES:
        raise InvalidInputError(
            f"{name} is in REF_FRAME = {own}, which visviva cannot rotate: screen states in "
            "GCRF/EME2000/ICRF or TEME (their positions could not be compared with others').")
    frame = str(own or "gcrs").upper()
    if frame == "ITRS":
        raise InvalidInputError(
            f"{name} is in the ITRS, which rotates with the Earth (its velocities would tilt the "
            "RTN axes): screen sat.gcrs(t) or sat.teme(t) states instead.")
    return frame


def _is_sgp4(obj):
    from ..satellites.catalog import Catalog
    from ..satellites.tle import Satellite

    if isinstance(obj, (Catalog, Satellite)):
        return True
    return isinstance(obj, (list, tuple)) and len(obj) > 0 and all(
        isinstance(o, Satellite) for o in obj)


def as_source(objs, t0, t1, name, jd0, fr0):
    """The screening source of ``objs`` (SGP4 objects or ephemerides)."""
    if _is_sgp4(objs):
        from ..satellites.catalog import as_catalog

        return SgpSource(as_catalog(objs), jd0, fr0)
    return _sampled(objs, t0, t1, name)


def check_same_kind(src1, src2):
    """Refuse two sides in different frames, saying how to screen SGP4 objects against
    ephemerides (an operator's OEM against a TLE catalogue): sample them in the
    ephemerides' frame (the message named no way before audit54)."""
    if src1.frame != src2.frame:
        how = ""
        kinds = {type(src1).__name__, type(src2).__name__}
        if kinds == {"SgpSource", "SampledSource"}:
            eph = src1 if isinstance(src1, SampledSource) else src2
            frame = eph.frame.split()[0].lower()
            if frame in ("gcrs", "teme"):
                side = "secondaries" if eph is src1 else "primaries"
                how = (f" To screen SGP4 objects against ephemerides, sample them in the "
                       f"ephemerides' frame over the window and pass those states as the {side}: "
                       f"t = t0 + np.arange(0, window_s + 1, 30) * u.s; "
                       f"[sat.{frame}(t) for sat in catalog].")
        raise InvalidInputError(
            f"the primaries are {src1.frame}, the secondaries {src2.frame}: give both as SGP4 "
            "objects (TEME) or both as ephemerides in one inertial frame; positions in different "
            f"frames cannot be compared.{how}")


def speed_bound(v1, v2):
    """An upper bound of every relative speed (km/s)."""
    speeds = [np.nanmax(np.linalg.norm(v, axis=-1), initial=0.0) for v in (v1, v2)]
    return 1.01 * (speeds[0] + speeds[1]) + 1e-3 if math.isfinite(sum(speeds)) else math.inf
