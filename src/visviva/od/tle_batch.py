"""Many TLE fits at once: in this process, or spread over a Dask cluster in chunks.

>>> import numpy as np, visviva as vv
>>> from astropy import units as u
>>> iss = vv.Satellite.from_tle(
...     "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9009",
...     "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340")
>>> days = [iss.gcrs(np.linspace(k, k + 1, 25) * u.day).to_state_vectors() for k in range(3)]
>>> sats = vv.od.fit_tle_batch(days, satnums=[25544] * 3)
>>> all(s.fit.max_position_km < 1e-3 for s in sats)   # SGP4 reproduced to < 1 m
True
"""

from __future__ import annotations

import warnings

import numpy as np

from ..errors import InvalidInputError

__all__ = ["fit_tle_batch"]


def _fit_recording(index, fit, *args, **kwargs):
    """History ``index``'s fit as a picklable result: (OMM fields, fit report, its warnings as
    (category, text)).

    The warnings are recorded, not shown, so that a fit on a Dask worker process (whose
    warnings would stay in the worker's log) reports them to the caller, who re-emits each one
    naming its history; an error carries the history's index as a note."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            sat = fit(*args, **kwargs)
        except Exception as exc:
            exc.add_note(f"(fitting histories[{index}] of fit_tle_batch)")
            raise
    said = [(w.category, str(w.message)) for w in caught]
    return sat.fit.fields, dict(sat.fit.__dict__), said


def _fit_chunk(items, kwargs, start=0):
    """Fit each (states, satnum, initial) of a chunk whose first is history ``start``; return
    picklable (OMM fields, fit report, warnings) triples."""
    from .tle_fit import fit_tle

    return [_fit_recording(start + k, fit_tle, states, satnum=satnum, initial=initial, **kwargs)
            for k, (states, satnum, initial) in enumerate(items)]


def _pack(items, frame, start=0):
    """A chunk of (history, satnum, initial) as a few flat arrays (one pickle frame each, not four per
    history: Dask's transfer cost is per frame), read here with fit_tle's own input reader."""
    from .tle_fit import states_and_times

    rs, vs, jd1, jd2, scales, frames, counts = [], [], [], [], [], [], []
    for states, _, _ in items:
        r, v, t, fr = states_and_times(states, None, frame)
        rs.append(r)
        vs.append(v)
        jd1.append(t.jd1)
        jd2.append(t.jd2)
        scales.append(t.scale)
        frames.append(fr)
        counts.append(len(r))
    return {"r": np.concatenate(rs), "v": np.concatenate(vs), "jd1": np.concatenate(jd1),
            "jd2": np.concatenate(jd2), "scale": scales, "frame": frames,
            "count": np.asarray(counts), "satnum": [s for _, s, _ in items], "start": start,
            "initial": [i for _, _, i in items]}  # fmt: skip


def _fit_packed(packed, kwargs):
    """Unpack a chunk (exact: the same jd1/jd2 in the same scales) and fit each history."""
    from astropy.time import Time

    from .tle_fit import fit_tle_arrays

    out = []
    ends = np.cumsum(packed["count"])
    for k, (stop, satnum) in enumerate(zip(ends, packed["satnum"], strict=True)):
        sl = slice(stop - packed["count"][k], stop)
        t = Time(packed["jd1"][sl], packed["jd2"][sl], format="jd", scale=packed["scale"][k])
        out.append(_fit_recording(packed["start"] + k, fit_tle_arrays, packed["r"][sl],
                                  packed["v"][sl], t, packed["frame"][k], satnum,
                                  initial=packed["initial"][k], **kwargs))  # fmt: skip
    return out


def fit_tle_batch(histories, satnums=None, *, initials=None, client=None, chunks=None,
                  **kwargs):  # fmt: skip
    """Fit one element set per state history, serially or on a Dask ``Client``.

    Parameters
    ----------
    histories : sequence
        State histories, each what :func:`~visviva.fit_tle` takes (a ``StateVectors`` with
        an epoch array, a ``CowellResult`` or an OEM ephemeris).
    satnums : sequence of int, optional
        Catalogue number of each new element set (default 99999 for all, or each initial
        set's number).
    initials : sequence of Satellite or None, optional
        An earlier element set of each object (``initial`` of :func:`~visviva.fit_tle`: the
        revolution number is carried forward), or None for a history without one.
    client : distributed.Client, optional
        Runs the fits on the cluster, ``chunks`` histories per task (worker processes give
        real parallelism: SGP4 holds the GIL); None fits here, one after another.
    chunks : int, optional
        Histories per task (default: spread evenly over 2 tasks per worker, few enough that
        Dask's per-task cost stays small against fits of a few ms each, two per worker to
        balance fits that take more iterations).
    **kwargs
        Passed to :func:`~visviva.fit_tle` (``fit_bstar``, ``bstar``, ``frame``, ...).

    Returns
    -------
    list of Satellite
        In the order of ``histories``, each with its ``fit`` report.

    Notes
    -----
    A fit of a day of states takes ~3 ms, so the cluster pays off from a few hundred fits
    on: each task costs Dask a scheduler round trip (ms), and a worker's statistical profiler
    (``distributed.worker.profile.enabled``, on by default) samples the running thread every
    10 ms, which costs short CPU-bound tasks 10-30 % more CPU; create the cluster with it off
    (``dask.config.set({"distributed.worker.profile.enabled": False})``) for the best
    throughput. The histories of a task travel packed into a few flat arrays (positions,
    velocities, the two-part Julian dates): sent as astropy objects, each history costs Dask
    four pickle frames and the client's scheduler thread ~0.3-0.5 ms, a serial cost that
    capped the speed-up below 1 (measured 10x less client CPU packed). Results come back as
    the element-set fields and the fit report, and the ``Satellite`` objects are rebuilt here
    (~0.05 ms each).

    Raises
    ------
    InvalidInputError
        ``satnums`` or ``initials`` of another length than ``histories``, a satnum that is
        not an integer; ``initial=`` (one
        set for every history) instead of ``initials=``.
    ConvergenceError, SGP4Error, ...
        As :func:`~visviva.fit_tle`, with a note naming the history (``histories[k]``).

    Warns
    -----
    RuntimeWarning, ...
        Each fit's warnings (a B* not determined, states left out, ...), shown here also for
        fits run on Dask worker processes, each prefixed with ``histories[k]:``.
    """
    from .tle_fit import TLEFit, satellite_from_fields

    histories = list(histories)
    satnums = [99999] * len(histories) if satnums is None else list(satnums)
    for k, s in enumerate(satnums):
        if isinstance(s, bool) or not isinstance(s, int | np.integer):
            # int(s) made 25544.7 catalogue number 25544 (audit20)
            raise InvalidInputError(
                f"satnums[{k}] = {s!r} is not a catalogue number: give integers (1..999999999).")
    if len(satnums) != len(histories):
        raise InvalidInputError(
            f"{len(satnums)} satnums for {len(histories)} histories; give one per history."
        )
    if "initial" in kwargs:
        raise InvalidInputError("fit_tle_batch takes initials=[...], one element set (or None) "
                                "per history, not initial=.")
    initials = [None] * len(histories) if initials is None else list(initials)
    if len(initials) != len(histories):
        raise InvalidInputError(
            f"{len(initials)} initials for {len(histories)} histories; give one per history "
            "(None where there is none).")
    items = list(zip(histories, satnums, initials, strict=True))
    if client is None:
        results = _fit_chunk(items, kwargs)
    else:
        n_workers = max(1, len(client.scheduler_info().get("workers", {})))
        size = chunks or max(1, -(-len(items) // (2 * n_workers)))
        frame = kwargs.pop("frame", None)
        if frame is not None:
            from ..satellites.frames import frame_name

            frame = frame_name(frame, ("gcrs", "teme"))
        parts = [_pack(items[i:i + size], frame, i) for i in range(0, len(items), size)]
        futures = client.map(_fit_packed, parts, [kwargs] * len(parts), pure=False)
        results = [r for part in client.gather(futures) for r in part]
    sats = []
    for k, (fields, report, said) in enumerate(results):
        for category, text in said:  # a Dask worker's warnings, shown here (leftfix: were lost)
            warnings.warn(f"histories[{k}]: {text}", category, stacklevel=2)
        sat = satellite_from_fields(fields)
        sat.fit = TLEFit(**report)
        sats.append(sat)
    return sats
