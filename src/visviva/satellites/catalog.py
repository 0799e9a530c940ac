"""Catalogue scale: many satellites at many times in one call.

* :class:`Catalog`: a list of :class:`~visviva.Satellite` propagated together
  (:meth:`Catalog.propagate`).
* :func:`read_tle_file` reads a file of two- or three-line element sets into a :class:`Catalog`
  (a bad line raises :class:`~visviva.satellites.tle.TLEFormatError` naming its line number);
  :func:`read_omm_file` reads CelesTrak's GP data (JSON, CSV, XML); the parsing is in
  :mod:`visviva.satellites.catalog_files`.
* :func:`propagate_sgp4_batch`, :func:`propagate_kepler_batch`, :func:`propagate_j2_batch` and
  their result :class:`BatchStates` live in :mod:`visviva.satellites.catalog_batch` and are
  imported here (their public path).
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
from astropy.time import Time

from ..errors import InvalidInputError
from .catalog_batch import (
    BatchStates,
    propagate_j2_batch,
    propagate_kepler_batch,
    propagate_sgp4_batch,
)
from .catalog_files import (
    catalog_file_satellites,
    omm_file_satellites,
    tle_file_satellites,
    tle_text_satellites,
)
from .tle import Satellite
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
    """A list of :class:`~visviva.Satellite` propagated together.

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
        self.satellites = list(satellites)
        for s in self.satellites:
            if not isinstance(s, Satellite):
                raise InvalidInputError(
                    f"a Catalog holds vv.Satellite objects, got {type(s).__name__}; build them "
                    "with vv.Satellite.from_tle or from_omm."
                )

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
        if isinstance(index, slice):
            return Catalog(self.satellites[index])
        if isinstance(index, str):
            for s in self.satellites:
                if s.name == index:
                    return s
            raise KeyError(index)
        return self.satellites[index]

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
            Absolute times.
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
        cat.satellites = pickle.loads(data)
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
