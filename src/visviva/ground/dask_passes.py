"""Pass tables for large catalogues x station networks on a ``dask.distributed`` cluster.

:func:`find_passes_dask` splits the catalogue into chunks of satellites; each task runs
:func:`visviva.find_passes` on one chunk against **all** stations (so the SGP4 work stays shared
by the stations), and the tables are stacked and sorted as the in-memory call sorts them. The
result equals ``find_passes`` row for row. Satellites and stations pickle (satellites as their
element sets), so process workers and remote clusters work as well as threads.

Requires the ``scale`` extra (``pip install visviva[scale]``: dask[array,distributed]).
"""

from __future__ import annotations

import numpy as np
from astropy import units as u

from ..errors import InvalidInputError
from .mask import station_thresholds
from .passes import describe_elevations, passes_of
from .search import as_catalog, check_window, warn_stale_element_sets
from .station import as_stations

__all__ = ["find_passes_dask"]


def _table_to_wire(table) -> tuple:
    """A pass table as plain arrays that pickle between processes (astropy's table columns
    keep a weak reference to their table, and its masked Time and Quantity columns do not
    unpickle): per column ``(name, kind, data, mask, extra)``, and the table's ``meta``."""
    from astropy.time import Time

    cols = []
    for name in table.colnames:
        col = table[name]
        mask = np.array(getattr(col, "mask", False), dtype=bool)
        if isinstance(col, Time):
            plain = col.unmasked if hasattr(col, "unmasked") else col
            cols.append((name, "time", (np.array(plain.jd1), np.array(plain.jd2)), mask,
                         (plain.scale, plain.format, plain.precision)))
        elif isinstance(col, u.Quantity):
            plain = col.unmasked if hasattr(col, "unmasked") else col
            cols.append((name, "quantity", np.array(plain.value), mask, plain.unit.to_string()))
        else:
            cols.append((name, "column", np.array(col), mask, None))
    return cols, dict(table.meta)


def _table_from_wire(wire):
    """The QTable that :func:`_table_to_wire` took apart (the same values and masks)."""
    from astropy.table import QTable
    from astropy.time import Time
    from astropy.utils.masked import Masked

    cols, meta = wire
    table = QTable(meta=meta)
    for name, kind, data, mask, extra in cols:
        if kind == "time":
            scale, fmt, precision = extra  # (as find_passes shows them: ISO, to the ms)
            col = Time(data[0], data[1], format="jd", scale=scale, precision=precision)
            col.format = fmt
            if mask.any():
                col = col.copy()
                col[mask] = np.ma.masked
        elif kind == "quantity":
            col = data * u.Unit(extra)
            if mask.any():
                col = Masked(col, mask=mask)
        else:
            col = np.ma.MaskedArray(data, mask=mask) if mask.any() else data
        table[name] = col
    return table


def _chunk_passes(chunk, stations, t0, t1, min_elevation, standard_magnitude, refraction):
    from .._dask import NUMBA_LOCK

    # numba's workqueue threading layer must not be entered from two threads at once
    with NUMBA_LOCK:
        # stale element sets were warned about once, on the client (a warning raised on a
        # process worker never reaches the caller; on threads it came once per chunk)
        table = passes_of(chunk, stations, t0, t1, min_elevation, standard_magnitude,
                          refraction, warn_stale=False)
    return _table_to_wire(table)


def find_passes_dask(satellites, stations, t0, t1, min_elevation=0.0 * u.deg, *,
                     chunk_size: int = 500, client=None, standard_magnitude=None,
                     refraction=False):
    """:func:`visviva.find_passes` chunked over the satellites on a Dask cluster.

    Parameters
    ----------
    satellites : Satellite, Catalog or list of Satellite
    stations : GroundStation or list of GroundStation
    t0, t1 : astropy Time
        The window (scalars, ``t1 > t0``).
    min_elevation : Quantity (angle), ElevationMask, or list of them
        In [-90, 90] deg (default 0 deg); or elevation masks, as in
        :func:`visviva.find_passes`.
    chunk_size : int
        Satellites per task (default 500), each against all stations.
    client : dask.distributed.Client, optional
        Default: the current client, else a LocalCluster started once
        (:func:`visviva.satellites.dask_batch.get_client`).
    standard_magnitude : float or array_like (mag), optional
        As in :func:`visviva.find_passes` (one value, or one per satellite).
    refraction : bool, {"optical", "radio"} or dict
        As in :func:`visviva.find_passes`: rise and set on the apparent horizon.

    Returns
    -------
    astropy.table.QTable
        The same rows as :func:`visviva.find_passes`, sorted by the pass's start (rise time,
        or ``t0`` for a pass under way at ``t0``).
    """
    from astropy.table import vstack

    from ..satellites.catalog import Catalog
    from ..satellites.dask_batch import get_client

    cat = as_catalog(satellites)
    sts = as_stations(stations)
    t0, t1 = check_window(t0, t1)
    from .horizon import Horizon

    # bad input refused here, not on the workers
    horizon = Horizon(sts, station_thresholds(min_elevation, len(sts))[0], refraction)
    if not (isinstance(chunk_size, (int, np.integer)) and chunk_size > 0):
        raise InvalidInputError(f"chunk_size must be a positive integer, got {chunk_size!r}.")
    mags = None
    if standard_magnitude is not None:
        from .visibility import standard_magnitudes

        mags = standard_magnitudes(standard_magnitude, len(cat))
    warn_stale_element_sets(cat, t0, t1)
    client = client if client is not None else get_client()
    starts = range(0, len(cat), int(chunk_size))
    futures = [
        client.submit(_chunk_passes, Catalog(cat.satellites[a:a + chunk_size]), sts, t0, t1,
                      min_elevation, None if mags is None else mags[a:a + chunk_size].copy(),
                      refraction, pure=False)
        for a in starts
    ]
    tables = [_table_from_wire(w) for w in client.gather(futures)]
    out = vstack(tables, metadata_conflicts="silent")
    if len(out):
        rise = out["rise_time"]
        jd = np.ma.getdata(np.asarray(rise.utc.unmasked.jd, dtype=np.float64))
        begin = np.where(np.asarray(rise.mask, dtype=bool), t0.utc.jd, jd)
        out = out[np.argsort(begin, kind="stable")]
    out.meta.update({"t0": t0.utc.isot, "t1": t1.utc.isot})
    describe_elevations(out, horizon.label)
    return out
