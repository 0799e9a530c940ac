"""A parsed copy of astropy's Earth-orientation table kept on disk between processes.

astropy reads its IERS table (``IERS_Auto``: the Bulletin A file ``finals2000A.all`` with the
EOP C04 values substituted, both from the ``astropy-iers-data`` package) with its general CDS
text reader the first time a process needs UT1-UTC or polar motion: about 0.5 s of CPU on
every fresh process, a third of the warm budget of ``Satellite.gcrs`` (issue 11). This module
stores the table astropy builds (a pickle of the ``IERS_Auto`` instance), with the EOP C04 rows
of 1962-1972 put before it (:func:`with_eop_c04_before`; astropy's own values from 1973), in a cache
directory keyed by the astropy version and the paths, sizes and modification times of the
files it was read from; later processes load it in ~10 ms. visviva hands it to astropy as
``earth_orientation_table`` inside its own calls only (:func:`visviva_table`), so every number
from 1973 on is astropy's own and none depends on which table astropy loaded first.

The directory is ``$VISVIVA_CACHE_DIR``, else ``$NUMBA_CACHE_DIR/visviva`` when numba's cache
is redirected (a fresh numba cache then means a fresh table too), else
``$XDG_CACHE_HOME/visviva`` (``~/.cache/visviva``). Nothing is cached when the directory is not
writable or when a ``finals2000A.all`` lies in the working directory (astropy then reads that
file, with a deprecation warning); a damaged or foreign cache file is ignored and rewritten.
Delete the directory to force a fresh parse.
"""

from __future__ import annotations

import hashlib
import os
import pickle
import tempfile
from pathlib import Path

__all__ = ["cache_dir", "visviva_table", "with_eop_c04_before"]

#: the layout of the cached table (2: EOP C04 rows from 1962 before the Bulletin A file;
#: 3: an EarthOrientationTable, which warns outside its range)
_TABLE_VERSION = "3"


def cache_dir() -> Path:
    """The directory of visviva's on-disk caches (see the module docstring)."""
    explicit = os.environ.get("VISVIVA_CACHE_DIR")
    if explicit:
        return Path(explicit)
    numba_dir = os.environ.get("NUMBA_CACHE_DIR")
    if numba_dir:
        return Path(numba_dir) / "visviva"
    xdg = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(xdg) / "visviva"


def _cache_file(iers) -> Path | None:
    """The cache file for the installed IERS files and astropy version (None: do not cache)."""
    import astropy

    parts = [astropy.__version__, str(pickle.HIGHEST_PROTOCOL), _TABLE_VERSION]
    for name in (iers.IERS_A_FILE, iers.IERS_A_README, iers.IERS_B_FILE, iers.IERS_B_README):
        try:
            st = os.stat(name)
        except OSError:
            return None
        parts += [os.fspath(name), str(st.st_size), str(st.st_mtime_ns)]
    key = hashlib.sha256("\n".join(parts).encode()).hexdigest()[:20]
    return cache_dir() / f"iers_auto-{key}.pickle"


def _load(path: Path, cls):
    try:
        with open(path, "rb") as fh:
            table = pickle.load(fh)
    except Exception:  # missing, truncated or written by another version: parse again
        return None
    return table if type(table) is cls else None


def _store(path: Path, table) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".iers-", suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as fh:
                pickle.dump(table, fh, protocol=pickle.HIGHEST_PROTOCOL)
            os.replace(tmp, path)  # atomic: a concurrent reader sees the old or the new file
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
    except (OSError, pickle.PicklingError):  # read-only home, full disk: just do not cache
        pass


#: the table visviva uses, once loaded in this process (:func:`visviva_table`)
_TABLE = None


def visviva_table():
    """visviva's Earth-orientation table, from the disk cache or parsed once per process.

    An :class:`~visviva._eop_table.EarthOrientationTable`: astropy's ``IERS_Auto``
    table (``IERS_Auto.read()``, what ``IERS_Auto.open()`` parses) with the EOP C04 rows of
    1962-1972 first, read from the cache file or parsed and written to it. It is visviva's
    own: whatever table astropy holds (``IERS_Auto.iers_table``, loaded by a user's
    ``Time(...).ut1`` before visviva's first call, or not) is neither used nor changed, so the
    numbers do not depend on the order of the calls. Call it with downloads off
    (:func:`visviva._offline_iers.offline_iers`, which hands it to astropy).

    Returns
    -------
    visviva._eop_table.EarthOrientationTable
    """
    global _TABLE
    if _TABLE is None:
        _TABLE = _load_or_parse()[0]
    return _TABLE


def _load_or_parse():
    """(table, True when it came from the cache file)."""
    from astropy.utils import iers

    from ._eop_table import EarthOrientationTable

    path = None if os.path.exists("finals2000A.all") else _cache_file(iers)
    table = None if path is None else _load(path, EarthOrientationTable)
    if table is not None:
        return table, True
    table = with_eop_c04_before(iers.IERS_Auto.read())
    if path is not None:
        _store(path, table)
    return table, False


def with_eop_c04_before(table):
    """The ``IERS_Auto`` table with the EOP C04 (IERS-B) rows that precede it put first.

    astropy's ``IERS_Auto`` starts with the Bulletin A file, on 1973-01-02; before that it
    held UT1 - UTC at that day's 0.808 s (true values 1962-1972: -0.09 .. +0.07 s, so up to
    0.9 s of Earth rotation, ~400 m at the equator, wrong without a warning) and used the
    mean pole. The EOP C04 file installed with it starts on 1962-01-01: its rows give
    UT1 - UTC and polar motion from then on, as astropy's ``IERS_B`` table does.

    Parameters
    ----------
    table : astropy.utils.iers.IERS_Auto
        As ``IERS_Auto.read()`` returns it.

    Returns
    -------
    visviva._eop_table.EarthOrientationTable
        The same rows after the C04 ones (``predictive_index`` moved along).
    """
    import warnings

    import numpy as np
    from astropy import units as u
    from astropy.table import MaskedColumn, QTable, vstack
    from astropy.utils import iers

    from ._eop_table import EarthOrientationTable

    b = iers.IERS_B.open()
    first = table["MJD"][0].to_value(u.d)
    early = b[np.asarray(b["MJD"].to_value(u.d)) < first]
    n = len(early)
    if n == 0:
        return EarthOrientationTable(table, meta=dict(table.meta))
    same = {"PM_X": "PM_x", "PM_Y": "PM_y"}  # the _B columns' names in IERS_B
    cols = {}
    for name in table.colnames:
        col = table[name]
        base = name[:-2] if name.endswith(("_A", "_B")) else name
        src = same.get(base, base)
        if name == "year":
            cols[name] = np.asarray(early["year"]) % 100  # two digits, as the A file
        elif name in ("month", "day"):
            cols[name] = np.asarray(early[name])
        elif col.dtype.kind == "U":  # flags: "B" (from Bulletin B / C04); none for the A file
            from_a = name.endswith("_A")
            cols[name] = MaskedColumn(np.full(n, "" if from_a else "B"), mask=np.full(n, from_a))
        elif name.endswith("_A") or src not in early.colnames:
            cols[name] = np.full(n, np.nan) * (col.unit or 1)
        else:
            cols[name] = early[src].to(col.unit)
    with warnings.catch_warnings():  # column descriptions differ between the two files
        warnings.simplefilter("ignore")
        joined = vstack([QTable(cols), QTable(table)], metadata_conflicts="silent")
    out = EarthOrientationTable(joined, meta=dict(table.meta))
    out.meta["predictive_index"] = table.meta["predictive_index"] + n
    return out
