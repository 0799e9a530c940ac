"""Catalogue scale: many satellites at many times in one call.

* :func:`read_tle_file` reads a file of two- or three-line element sets into a :class:`Catalog`
  (a bad line raises :class:`~visviva.satellites.tle.TLEFormatError` naming its line number);
  :func:`read_omm_file` reads CelesTrak's GP data (JSON, CSV, XML); the parsing is in
  :mod:`visviva.satellites.catalog_files`.
* :func:`propagate_sgp4_batch`: N satellites at T times in one call of sgp4's ``SatrecArray``
  (C++), ``(N, T, 3)`` positions and velocities in the arrays sgp4 writes (no copy), bit for
  bit :meth:`visviva.Satellite.teme` at the same times.
* :func:`propagate_kepler_batch`: two-body states (:func:`visviva.core.universal.propagate_many`).
* :func:`propagate_j2_batch`: SGP4 mean elements with the secular J2 drift of the node, perigee
  and mean anomaly (:mod:`visviva.satellites.secular`), one compiled loop over the N x T pairs
  (:mod:`visviva.satellites.secular_batch`).

Their result, :class:`BatchStates`, and the checks of their shared arguments are in
:mod:`visviva.satellites.batch_states` (imported here: ``visviva.satellites.catalog.BatchStates``).
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
from astropy.time import Time

from .._units import to_array, to_quantity, to_vector
from ..errors import InvalidInputError, ShapeError, raise_for_status
from .batch_states import BatchStates, absolute_times, check_on_error, offsets_s
from .catalog_files import (
    catalog_file_satellites,
    omm_file_satellites,
    tle_file_satellites,
    tle_text_satellites,
)
from .decay import warn_after_decay
from .satellite_states import require_kepler_frame
from .secular_batch import secular_grid, secular_setup
from .tle import Satellite
from .tle_checks import (
    MINUTES_PER_DAY,
    SGP4Error,
    check_tsince,
    flag_beyond_earth_orbit,
    raise_for_sgp4_status,
    sgp4_times,
    warn_stale_sets,
)
from .utc_days import utc_days_to_time

__all__ = [
    "Catalog",
    "BatchStates",
    "read_tle_file",
    "read_omm_file",
    "read_catalog_file",
    "parse_tle_text",
    "propagate_sgp4_batch",
    "propagate_kepler_batch",
    "propagate_j2_batch",
]


class Catalog:
    """A sequence of :class:`~visviva.Satellite` propagated together (fixed once built).

    Parameters
    ----------
    satellites : iterable of Satellite
        The objects, in order.

    Examples
    --------
    >>> cat = read_tle_file("active.txt")                       # doctest: +SKIP
    >>> states = cat.propagate(Time("2024-01-01") + np.arange(1440) * u.min)  # doctest: +SKIP
    >>> states.r.shape                                          # doctest: +SKIP
    (9000, 1440, 3)
    """

    def __init__(self, satellites):
        sats = tuple(satellites)
        for s in sats:
            if not isinstance(s, Satellite):
                raise InvalidInputError(
                    f"a Catalog holds vv.Satellite objects, got {type(s).__name__}; build them "
                    "with vv.Satellite.from_tle or from_omm."
                )
        self._satellites = sats

    @property
    def satellites(self) -> tuple:
        """The satellites, in order (a tuple).

        A catalogue does not change once built: its SGP4 arrays, epochs and search setups are
        computed once and kept, so a list changed in place (``cat.satellites[0] = other`` was
        accepted) went on propagating the old element sets under the new names. Build a new
        one instead: ``Catalog([*cat, sat])``, ``cat[1:]``, ``cat.latest()``.
        """
        return self._satellites

    def __reduce__(self):
        # sgp4's SatrecArray does not pickle, and rebuilding thousands of Satellites costs
        # ~0.2 ms each: a catalogue travels as one bytes payload with a content token, and a
        # process that has seen the token reuses its catalogue (and SatrecArray) instead
        return (_catalog_from_payload, self._payload)

    @cached_property
    def _payload(self) -> tuple:
        import hashlib
        import pickle

        data = pickle.dumps(self.satellites, protocol=pickle.HIGHEST_PROTOCOL)
        return hashlib.blake2b(data, digest_size=16).hexdigest(), data

    @classmethod
    def from_omm(cls, records):
        """A catalogue from OMM records (e.g. ``json.load`` of CelesTrak GP data)."""
        return cls(Satellite.from_omm(f) for f in records)

    def __len__(self):
        return len(self.satellites)

    def __iter__(self):
        return iter(self.satellites)

    def __getitem__(self, index):
        """``cat[k]``: the satellite at position ``k`` (an int, negative from the end);
        ``cat[a:b]``: a :class:`Catalog`; ``cat["NAME"]``: the one satellite of that name.

        Raises
        ------
        KeyError
            No satellite has the name.
        InvalidInputError
            Several satellites have the name (debris of one breakup shares a name; an
            element-set history repeats one object): the first was returned before, silently,
            which could be the oldest set or another object. Or ``index`` is of another type.
        """
        if isinstance(index, slice):
            return Catalog(self.satellites[index])
        if isinstance(index, str):
            where = [k for k, s in enumerate(self.satellites) if s.name == index]
            if len(where) == 1:
                return self.satellites[where[0]]
            if not where:
                raise KeyError(index)
            raise InvalidInputError(self._ambiguous_name(index, where))
        if isinstance(index, (bool, np.bool_)) or not isinstance(index, (int, np.integer)):
            raise InvalidInputError(
                f"a Catalog is indexed by position (int), slice or name (str), got "
                f"{type(index).__name__}; for several positions build Catalog([cat[k] for k "
                "in ks])."
            )
        return self.satellites[index]

    def _ambiguous_name(self, name: str, where: list) -> str:
        """The message of ``cat[name]`` when ``name`` names the satellites at ``where``."""
        numbers = sorted({self.satellites[k].satnum for k in where})
        shown = ", ".join(str(k) for k in where[:5]) + (", ..." if len(where) > 5 else "")
        if len(numbers) == 1:
            todo = (f"they are element sets of one object ({numbers[0]}): cat.latest()[{name!r}] "
                    "picks the newest, or index by position")
        else:
            nums = ", ".join(str(x) for x in numbers[:5]) + (", ..." if len(numbers) > 5 else "")
            todo = (f"they are {len(numbers)} objects (catalogue numbers {nums}): index by "
                    "position, e.g. cat[int(np.flatnonzero(cat.satnums == NUMBER)[-1])] for "
                    "the last set of one number")
        return (f"{len(where)} satellites of this catalogue are named {name!r} (positions "
                f"{shown}); {todo}.")

    def __repr__(self):
        return f"Catalog({len(self)} satellites)"

    @property
    def names(self) -> list[str]:
        return [s.name for s in self.satellites]

    @property
    def satnums(self) -> np.ndarray:
        """Catalogue numbers (int64, shape (N,); up to nine digits)."""
        return np.array([s.satnum for s in self.satellites], dtype=np.int64)

    def latest(self) -> Catalog:
        """One satellite per catalogue number: the element set with the latest epoch.

        A file may hold an object more than once (an element-set history, or two downloads
        joined): screening such a catalogue pairs the object with itself, and passes are
        listed once per element set. This keeps, for each catalogue number, the set with the
        latest epoch (the later in the file on a tie), in the order of first appearance;
        satellites numbered 0 (unknown) are all kept.

        Returns
        -------
        Catalog
        """
        jd, fr = self.epoch_days
        chosen: dict = {}  # number -> index (a dict keeps each number's first place)
        for k, number in enumerate(self.satnums.tolist()):
            key = ("unknown", k) if number == 0 else number
            j = chosen.get(key)
            if j is None or (jd[k] - jd[j]) + (fr[k] - fr[j]) >= 0:
                chosen[key] = k
        return Catalog(self.satellites[k] for k in chosen.values())

    @cached_property
    def satrec_array(self):
        """sgp4's ``SatrecArray`` over the catalogue (built once)."""
        from sgp4.api import SatrecArray

        return SatrecArray([s.satrec for s in self.satellites])

    @cached_property
    def epoch_days(self) -> tuple:
        """Element-set epochs as sgp4 keeps them: ``(jd, fraction)`` arrays (N,) of UTC Julian
        dates of 86,400-s days (:mod:`visviva.satellites.utc_days`)."""
        return (np.array([s.satrec.jdsatepoch for s in self.satellites]),
                np.array([s.satrec.jdsatepochF for s in self.satellites]))

    @cached_property
    def epochs(self) -> Time:
        """Element-set epochs, UTC (shape (N,))."""
        return utc_days_to_time(*self.epoch_days)

    def propagate(self, t, method: str = "sgp4", frame: str = "teme", on_error: str = "raise"):
        """Propagate every satellite to the times ``t``.

        Parameters
        ----------
        t : astropy Time, shape (T,) or scalar
            Absolute times. Element sets used more than 30 days from their epochs warn
            (:class:`~visviva.StaleElementSetWarning`, once per call, naming the stalest),
            whatever the method: the J2 and Kepler methods start from SGP4 at each epoch.
        method : {"sgp4", "j2", "kepler"}
            SGP4 (sgp4's SatrecArray); secular J2 drift of the SGP4 mean elements; two-body
            motion of the osculating TEME state at each epoch.
        frame : {"teme", "gcrs", "itrs"}
            Output frame (GCRS and ITRS through astropy).
        on_error : {"raise", "nan"}
            Raise the typed error of the first failure, or leave NaN and report ``status``.

        Returns
        -------
        BatchStates
            ``r`` (km) and ``v`` (km/s) of shape (N, T, 3).
        """
        funcs = {"sgp4": propagate_sgp4_batch, "j2": propagate_j2_batch,
                 "kepler": propagate_kepler_batch}
        if method not in funcs:
            raise InvalidInputError(f"method must be one of {sorted(funcs)}, got {method!r}.")
        out = funcs[method](self, t, on_error=on_error)
        return out.to_frame(frame)


#: catalogues unpickled in this process (e.g. a Dask worker), by content token, newest last
_UNPICKLED: dict = {}
_UNPICKLED_MAX = 32


def _catalog_from_payload(token: str, data: bytes) -> Catalog:
    """Unpickle a catalogue, or return the one with the same content unpickled before."""
    import pickle

    cat = _UNPICKLED.pop(token, None)
    if cat is None:
        cat = Catalog.__new__(Catalog)
        cat._satellites = tuple(pickle.loads(data))
        cat.__dict__["_payload"] = (token, data)
    _UNPICKLED[token] = cat
    while len(_UNPICKLED) > _UNPICKLED_MAX:
        _UNPICKLED.pop(next(iter(_UNPICKLED)))
    return cat


# --------------------------------------------------------------------------------------------
# Reading files (the parsing: visviva.satellites.catalog_files)
# --------------------------------------------------------------------------------------------
def parse_tle_text(text: str, *, source: str = "<text>", verify_checksum: bool = True) -> Catalog:
    """Parse two-line or three-line element sets (names on their own line, ``0 `` optional).

    Parameters
    ----------
    text : str
        The file's contents.
    source : str
        How to name the text in messages (a file name).
    verify_checksum : bool
        Check every line's checksum (default).

    Raises
    ------
    TLEFormatError
        Naming the line number (1-based) and ``source`` of the first bad line.
    """
    return Catalog(tle_text_satellites(text, source=source, verify_checksum=verify_checksum))


def read_tle_file(path, *, verify_checksum: bool = True) -> Catalog:
    """Read a file of two- or three-line element sets (e.g. CelesTrak's ``active.txt``).

    Parameters
    ----------
    path : str, os.PathLike or text file object
        The file.
    verify_checksum : bool
        Check every line's checksum (default).

    Returns
    -------
    Catalog

    Raises
    ------
    TLEFormatError
        Naming the file and the line number of the first bad line.
    InvalidInputError
        The file is empty (nothing but white space): a failed download, not a catalogue.
    """
    return Catalog(tle_file_satellites(path, verify_checksum=verify_checksum))


def read_omm_file(path, *, format: str | None = None) -> Catalog:
    """Read OMM records (GP data of CelesTrak or Space-Track) from a JSON, CSV, XML or KVN file.

    Catalogue numbers may have up to nine digits (18 SDS publishes those above 339,999 in OMMs
    only). A KVN file holds one CCSDS OMM (what :func:`visviva.write_omm` writes by default) or
    many one after another (each from its ``CCSDS_OMM_VERS`` line), as Space-Track's KVN GP
    data does.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    format : {"json", "csv", "xml", "kvn"}, optional
        Taken from the file extension when not given; a file whose extension is none of these
        is read as KVN when it starts with ``CCSDS_OMM_VERS``.

    Returns
    -------
    Catalog
        One satellite per record, in file order (an object that appears twice is there twice:
        see :meth:`Catalog.latest`).

    Raises
    ------
    MissingFileError
        No such file (also a ``FileNotFoundError``).
    InvalidInputError
        Naming the file and the line (bytes that are not UTF-8, JSON or XML syntax, a CSV
        record) or the record number (1-based) of the first bad record.
    """
    return Catalog(omm_file_satellites(path, format=format))


def read_catalog_file(path) -> Catalog:
    """Read a file of element sets of any kind visviva knows, told apart by its content.

    Two- or three-line element sets (names in UTF-8 or Latin-1); OMM records as CelesTrak's GP
    data in JSON (a list of records or one record), CSV or XML (``<ndm>`` of ``<omm>``, or one
    CCSDS OMM XML as :func:`visviva.write_omm` writes it); a CCSDS KVN OMM (one satellite).
    The suffix of the file name plays no part. ``visviva passes`` and ``visviva screen`` read
    their file with this.

    Parameters
    ----------
    path : str, os.PathLike or text file object
        The file (a text file object is read as TLE text).

    Returns
    -------
    Catalog

    Raises
    ------
    TLEFormatError
        A file that is not OMM, naming its first bad TLE line.
    InvalidInputError
        An OMM file naming the line or record (as :func:`read_omm_file`), another CCSDS
        message (an OEM, an OPM) or XML document, or an empty file (nothing but white space).
    """
    return Catalog(catalog_file_satellites(path))


# --------------------------------------------------------------------------------------------
# Batch propagation
# --------------------------------------------------------------------------------------------
def as_catalog(satellites) -> Catalog:
    """The batch functions' input as a :class:`Catalog` (a Catalog is returned as it is).

    Parameters
    ----------
    satellites : Catalog, Satellite or sequence of Satellite
        What to propagate.

    Returns
    -------
    Catalog
    """
    if isinstance(satellites, Catalog):
        return satellites
    if isinstance(satellites, Satellite):
        return Catalog([satellites])
    return Catalog(satellites)



def propagate_sgp4_batch(satellites, t, *, on_error: str = "raise", out=None) -> BatchStates:
    """SGP4 for N satellites at T times in one call of sgp4's ``SatrecArray``.

    Parameters
    ----------
    satellites : Catalog or sequence of Satellite
        The N objects.
    t : astropy Time, shape (T,) or scalar
        Absolute times (any scale; converted to UTC Julian dates once). Element sets used more
        than 30 days from their epochs warn (:class:`~visviva.StaleElementSetWarning`, once
        per call, naming the stalest).
    on_error : {"raise", "nan"}
        Raise the typed :class:`~visviva.satellites.tle.SGP4Error` of the first failure
        (default), or return NaN in ``r`` and ``v`` wherever ``status`` is not 0: sgp4's code
        (1-6; sgp4 itself returns a state below the surface for a decayed object, code 6),
        or :data:`~visviva.satellites.tle_checks.SGP4_BEYOND_EARTH_ORBIT` (100) where sgp4
        returned, without a code, a position more than 1e6 km from the geocentre (no Earth
        orbit: SGP4 far outside its span), the rule of :meth:`visviva.Satellite.teme`.
    out : (status, r, v), optional
        C-contiguous arrays of shapes (N, T) uint8, (N, T, 3) and (N, T, 3) float64 that sgp4
        writes into (e.g. slices of a larger result); the returned states wrap them.

    Returns
    -------
    BatchStates
        TEME ``r`` (km) and ``v`` (km/s), shape (N, T, 3); identical bit for bit to
        ``Satellite.teme(t)`` of each satellite.
    """
    check_on_error(on_error)
    return sgp4_grid(as_catalog(satellites), absolute_times(t, "propagate_sgp4_batch"),
                     on_error, out)


def warn_stale_times(cat: Catalog, jd, fr) -> None:
    """Warn (:class:`~visviva.StaleElementSetWarning`, once, naming the stalest) when element
    sets of ``cat`` are used more than 30 days from their epochs at the times ``jd + fr``
    (UTC days, :func:`~visviva.satellites.tle_checks.sgp4_times`): the warning of
    :func:`propagate_sgp4_batch`, also given once by ``propagate_dask`` before its blocks run."""
    day = np.asarray(jd, dtype=np.float64) + np.asarray(fr, dtype=np.float64)
    if day.size == 0:
        return
    ep_jd, ep_fr = cat.epoch_days
    epoch = ep_jd + ep_fr  # (days: rounding far below the 30-day threshold)
    away = np.maximum(np.abs(day.min() - epoch), np.abs(day.max() - epoch))
    warn_stale_sets(lambda k: cat.satellites[k].name or cat.satellites[k].satnum, away,
                    "the requested times", "these positions can be far off")
    warn_after_decay(cat.satellites, float(day.max()))  # (re-entered objects: audit51)


def sgp4_grid(cat: Catalog, t: Time, on_error: str, out=None,
              warn_stale: bool = True) -> BatchStates:
    """:func:`propagate_sgp4_batch` on a :class:`Catalog` and 1-D times already checked;
    ``warn_stale=False`` for a block of a batch whose caller warned once, whole (Dask)."""
    jd, fr, _, _ = sgp4_times(t, 0.0, 0.0)
    ep_jd, ep_fr = cat.epoch_days
    tsince = ((jd[None, :] - ep_jd[:, None]) + (fr[None, :] - ep_fr[:, None])) * MINUTES_PER_DAY
    check_tsince(tsince, cat.names)
    if warn_stale:
        warn_stale_times(cat, jd, fr)
    if out is None:
        e, r, v = cat.satrec_array.sgp4(jd, fr)
    else:
        e, r, v = out
        shapes = ((len(cat), len(t)), (len(cat), len(t), 3), (len(cat), len(t), 3))
        dtypes = (np.uint8, np.float64, np.float64)
        if any(a.shape != sh or a.dtype != d or not a.flags.c_contiguous
               for a, sh, d in zip(out, shapes, dtypes, strict=True)):
            raise ShapeError(f"out arrays must be C-contiguous {shapes} of uint8, float64, "
                             f"float64; got {[(a.shape, str(a.dtype)) for a in out]}.")
        cat.satrec_array._sgp4(jd, fr, e, r, v)
    if flag_beyond_earth_orbit(e, r) or e.any():  # (the far rule of Satellite.teme too)
        if on_error == "raise":
            raise_for_sgp4_status(e, cat.names, tsince, t, r)
        # sgp4 fills some failed states with numbers (code 6, decayed: a point below the
        # surface) and others with NaN: no failed state leaves with numbers in it
        failed = e != 0
        r[failed] = np.nan
        v[failed] = np.nan
    # fast path: one summation each (NaN and inf propagate); the full mask only when it fails
    clean = np.isfinite(np.add.reduce(r, axis=None)) and np.isfinite(np.add.reduce(v, axis=None))
    bad = None if clean else ~(np.isfinite(r).all(-1) & np.isfinite(v).all(-1)) & (e == 0)
    if bad is not None and bad.any():  # never seen from sgp4, but no NaN leaves without a reason
        i, j = np.unravel_index(int(np.flatnonzero(bad)[0]), bad.shape)
        raise SGP4Error(
            f"SGP4 returned a non-finite state without an error code for satellite "
            f"{cat.names[i]!r} at {tsince[i, j]:.6f} min from its epoch. To fix: propagate to "
            "times nearer the element-set epoch or check the element set.",
            satellite=cat.names[i], reason="non-finite state", tsince_min=float(tsince[i, j]),
        )
    return BatchStates(to_quantity(r, "length"), to_quantity(v, "speed"), t, e, cat.names, "teme")


def _require_one_axis(r, v, gm, epoch) -> None:
    """ShapeError unless the states lie on one axis of N, with gm and epoch scalar or (N,).

    (2, 3) states were flattened, their epochs and gm not: a raw numpy ValueError."""
    n = r.shape[:-1]
    if r.shape != v.shape or len(n) > 1 or any(np.shape(x) not in ((), n) for x in (gm, epoch)):
        raise ShapeError(
            f"propagate_kepler_batch takes N states on one axis: r, v of shape (N, 3) with gm "
            f"and epoch scalar or (N,); got r {r.shape}, v {v.shape}, gm {np.shape(gm)}, epoch "
            f"{np.shape(epoch)}. Flatten the states first (states[i] for each, or build them "
            "from r.reshape(-1, 3), v.reshape(-1, 3) and epochs of shape (N,))."
        )


def propagate_kepler_batch(states, t, *, on_error: str = "raise",
                           backend: str = "cpu") -> BatchStates:
    """Two-body motion of N states to T times (universal variables, every conic).

    Parameters
    ----------
    states : Catalog, sequence of Satellite, or StateVectors-like of shape (N,)
        For satellites the osculating TEME state at each element-set epoch (from SGP4) with
        sgp4's WGS-72 GM; otherwise any object with ``.r``, ``.v`` Quantities (N, 3), ``.gm`` and
        ``.epoch`` (astropy Time, scalar or (N,)).
    t : astropy Time, shape (T,) or scalar
        Absolute times. Element sets used more than 30 days from their epochs warn
        (:class:`~visviva.StaleElementSetWarning`, once per call, as
        :func:`propagate_sgp4_batch`): the two-body motion starts from SGP4's state at each
        epoch, whose error grows from there (state vectors do not warn).
    on_error : {"raise", "nan"}
        As in :func:`propagate_sgp4_batch`; with ``"nan"`` a satellite whose SGP4 fails at its
        own epoch (it has no osculating state there) gives NaN and status
        :data:`~visviva.core.status.NON_FINITE` at every time instead of the SGP4 error.
    backend : {"cpu", "cuda"}
        ``"cuda"``: the same solver compiled for an NVIDIA GPU from the same source
        (:mod:`visviva.core.cuda.twins`; extra ``visviva[gpu]``), one thread per pair; raises
        :class:`visviva.errors.BackendUnavailableError` saying what is missing without one.

    Returns
    -------
    BatchStates
        ``r`` (km), ``v`` (km/s), shape (N, T, 3), in the frame of the input states.

    Notes
    -----
    Calls :func:`visviva.core.universal.propagate_many` once over the N*T pairs (Danby 1992,
    sec. 6.9; Vallado 2013, Algorithm 8).
    """
    from .._backends import check_backend

    check_on_error(on_error)
    check_backend(backend)  # a missing GPU is said before anything about the inputs
    return kepler_grid(states, absolute_times(t, "propagate_kepler_batch"), on_error, backend)


def kepler_grid(states, t: Time, on_error: str, backend: str = "cpu",
                warn_stale: bool = True) -> BatchStates:
    """:func:`propagate_kepler_batch` on times already checked; ``warn_stale=False`` for a
    caller that warned about stale element sets once itself (a Dask block)."""
    from .._backends import check_backend

    if check_backend(backend) == "cuda":
        from ..core.cuda.kernels import propagate_many
    else:
        from ..core.universal import propagate_many
    if isinstance(states, (Catalog, Satellite, list, tuple)):
        cat = as_catalog(states)
        if warn_stale:  # the states start from SGP4 at each epoch: its errors grow from there
            warn_stale_times(cat, *sgp4_times(t, 0.0, 0.0)[:2])
        ep = cat.epochs
        # each satellite at its own epoch (one sgp4 call per element set, not per step)
        out = [s.satrec.sgp4(s.satrec.jdsatepoch, s.satrec.jdsatepochF) for s in cat]
        e = np.array([o[0] for o in out], dtype=np.uint8)
        r0 = np.array([o[1] for o in out], dtype=np.float64).reshape(-1, 3)
        v0 = np.array([o[2] for o in out], dtype=np.float64).reshape(-1, 3)
        if on_error == "raise":
            raise_for_sgp4_status(e[:, None], cat.names, 0.0)
        r0[e != 0] = np.nan  # no state at its epoch: NON_FINITE (4) at every time, NaN
        v0[e != 0] = np.nan
        gm = np.array([s.satrec.mu for s in cat.satellites])
        names, frame = cat.names, "teme"
    else:
        r0 = to_vector(states.r, "length", "states.r")
        v0 = to_vector(states.v, "speed", "states.v")
        gm = to_array(states.gm, "gm", "states.gm")
        ep = getattr(states, "epoch", None)
        if not isinstance(ep, Time):
            raise InvalidInputError("states needs an .epoch (astropy Time) for absolute times t.")
        _require_one_axis(r0, v0, gm, ep)
        r0, v0 = r0.reshape(-1, 3), v0.reshape(-1, 3)
        gm = np.broadcast_to(gm, (r0.shape[0],))
        ep = ep.reshape(-1) if ep.ndim == 0 else ep
        names = [str(i) for i in range(r0.shape[0])]
        frame = require_kepler_frame(states, "propagate_kepler_batch")
    n, m = r0.shape[0], len(t)
    dt = offsets_s(ep, t)
    dt = np.ascontiguousarray(np.broadcast_to(dt, (n, m))).reshape(-1)
    r0f = np.ascontiguousarray(np.broadcast_to(r0[:, None, :], (n, m, 3))).reshape(-1, 3)
    v0f = np.ascontiguousarray(np.broadcast_to(v0[:, None, :], (n, m, 3))).reshape(-1, 3)
    gmf = np.ascontiguousarray(np.broadcast_to(np.asarray(gm, float)[:, None], (n, m))).reshape(-1)
    r = np.empty((n * m, 3))
    v = np.empty((n * m, 3))
    status = np.empty(n * m, dtype=np.int64)
    propagate_many(r0f, v0f, gmf, dt, r, v, status)
    status = status.reshape(n, m)
    if on_error == "raise":
        raise_for_status(status, "Kepler batch propagation", dt_s=dt.reshape(n, m))
    return BatchStates(
        to_quantity(r.reshape(n, m, 3), "length"), to_quantity(v.reshape(n, m, 3), "speed"), t,
        status.astype(np.uint8), names, frame,
    )


def propagate_j2_batch(satellites, t, *, on_error: str = "raise") -> BatchStates:
    """Secular J2 propagation of SGP4 mean elements for N satellites at T times.

    The node, perigee and mean anomaly drift at the first-order secular J2 rates of
    :func:`visviva.satellites.secular.j2_secular_rates` (Brouwer 1959; Vallado 2013, eqs. 9-41)
    with SGP4's WGS-72 constants; a, e, i stay at their mean values (no drag, no periodic
    terms) and each state comes from Kepler's equation, in one compiled loop over the N x T
    pairs. A fast screening propagator (a few to tens of km from SGP4 over a day in LEO, since
    mean elements are used as if osculating), not a replacement for SGP4.

    Parameters
    ----------
    satellites : Catalog or sequence of Satellite
    t : astropy Time, shape (T,) or scalar
        Absolute times. Element sets used more than 30 days from their epochs warn
        (:class:`~visviva.StaleElementSetWarning`, once per call, as
        :func:`propagate_sgp4_batch`): the mean elements are SGP4's at each epoch.
    on_error : {"raise", "nan"}
        ``"raise"``: InvalidInputError naming the first satellite whose mean orbit is unbound
        or whose mean perigee is below the Earth's radius (decayed), before any propagation.
        ``"nan"``: NaN rows for those satellites, with status
        :data:`~visviva.core.status.BAD_ECCENTRICITY` (2, unbound) or
        :data:`~visviva.core.status.HITS_ATTRACTOR` (9, decayed); the others propagate.

    Returns
    -------
    BatchStates
        TEME ``r`` (km), ``v`` (km/s), shape (N, T, 3).
    """
    check_on_error(on_error)
    return j2_grid(as_catalog(satellites), absolute_times(t, "propagate_j2_batch"), on_error)


def j2_grid(cat: Catalog, t: Time, on_error: str, warn_stale: bool = True) -> BatchStates:
    """:func:`propagate_j2_batch` on a :class:`Catalog` and times already checked;
    ``warn_stale=False`` for a caller that warned about stale element sets once itself (a pass
    search over its window, a Dask block)."""
    if warn_stale:  # the mean elements are SGP4's at each epoch: its errors grow from there
        warn_stale_times(cat, *sgp4_times(t, 0.0, 0.0)[:2])
    if len(cat) == 0:  # as the SGP4 and Kepler batches (the setup reads a first element set)
        return BatchStates(to_quantity(np.empty((0, len(t), 3)), "length"),
                           to_quantity(np.empty((0, len(t), 3)), "speed"), t,
                           np.empty((0, len(t)), dtype=np.uint8), [], "teme")
    setup = cat.__dict__.get("_j2_setup")  # per-catalogue: elements, rates, epochs (TAI)
    if setup is None:
        setup = secular_setup([s.satrec for s in cat.satellites], cat.names, cat.epochs.tai)
        cat.__dict__["_j2_setup"] = setup
    (a, ecc, inc, raan, argp, M), (raan_dot, argp_dot, M_dot), gm, ep1, ep2, refused = setup
    if refused and on_error == "raise":  # an unbound or decayed mean orbit: named before any work
        raise InvalidInputError(refused[min(refused)][1])
    from .frames import offline_iers

    with offline_iers():  # a time in UT1 needs the installed IERS table, never a download
        tt = t.tai
    n, m = len(cat), len(t)
    r = np.empty((n, m, 3))
    v = np.empty((n, m, 3))
    status = np.empty((n, m), dtype=np.int64)
    secular_grid(a, ecc, inc, raan, argp, M, raan_dot, argp_dot, M_dot, ep1, ep2,
                  np.ascontiguousarray(tt.jd1, dtype=np.float64),
                  np.ascontiguousarray(tt.jd2, dtype=np.float64), gm, r, v, status)
    for k, (code, _) in refused.items():  # on_error="nan": those satellites' rows NaN, coded
        r[k] = v[k] = np.nan
        status[k] = code
    if on_error == "raise" and status.any():
        raise_for_status(status, "secular J2 batch propagation", dt_s=offsets_s(cat.epochs, t))
    return BatchStates(
        to_quantity(r, "length"), to_quantity(v, "speed"), t, status.astype(np.uint8),
        cat.names, "teme",
    )

