"""The radio link's frequencies from a TDM segment, for the ionosphere's delay of its range and
Doppler rows (``TDM.to_observations(ionosphere=...)``).

CCSDS 503.0-B-2 (sections 3.3.2 and 3.5.2) writes a link's frequencies as data lines:

* ``TRANSMIT_FREQ_n``: the frequency (Hz) that participant n transmits, as written;
* ``RECEIVE_FREQ_n`` (and the unindexed ``RECEIVE_FREQ``): the frequency received by
  participant n, in Hz **after adding the metadata's** ``FREQ_OFFSET`` (default 0), which "must
  be added to every RECEIVE_FREQ to reconstruct it" (a Doppler shift sent in place of the
  received frequency, for instance);
* ``TURNAROUND_NUMERATOR`` / ``TURNAROUND_DENOMINATOR``: the transponder's ratio, downlink =
  uplink * numerator / denominator (240/221 in S band, 880/749 in X band).

For a two-way path ``s, c, s`` (station s, spacecraft c) the uplink is ``TRANSMIT_FREQ_s`` or
``RECEIVE_FREQ_c``, the downlink ``RECEIVE_FREQ_s``, ``RECEIVE_FREQ`` or ``TRANSMIT_FREQ_c``.
Each range or Doppler row takes, on each leg, **the last frequency line at or before its
epoch** (its epoch as written, before any re-tagging), or the leg's first line when the row
comes before all of them. A transmitted frequency is ramped: ``TRANSMIT_FREQ_RATE_n`` (Hz/s)
is the linear rate of change of ``TRANSMIT_FREQ_n`` from its epoch to the next rate line
(503.0-B-2, 3.5.2), so the row's frequency is the line's plus the rates integrated from the
line's epoch to the row's (no rate before the first rate line). A leg without lines is the other leg through the turnaround ratio,
or, without a ratio, the other leg's frequency (a link at one frequency). The row's frequency
is the two-way one, :func:`visviva.od.ionosphere.two_way_frequency_hz` of the two legs (each
leg delayed by its own ``40.3 TEC / f^2``). A segment without frequency lines takes the
``frequency_hz`` given. Refused, naming the line: a frequency below 30 MHz (not a carrier the
ionosphere passes: often a Doppler shift without its ``FREQ_OFFSET``), one turnaround keyword
without the other, and a ``frequency_hz`` given that differs by more than 1 % from both the
row's downlink and its two-way frequency (the TDM and the argument disagree: one is wrong).
"""

from __future__ import annotations

import numpy as np

from ..ccsds.grammar import CCSDSFormatError
from .ionosphere import two_way_frequency_hz

__all__ = ["link_frequencies", "MIN_CARRIER_HZ", "AGREEMENT"]

#: the lowest frequency read as a carrier, Hz (the ionosphere reflects below ~10-30 MHz)
MIN_CARRIER_HZ = 30e6
#: the relative difference between a given frequency_hz and the TDM's that is refused
AGREEMENT = 0.01


def _leg(seg, names, offset, src):
    """(seconds from the segment's first epoch, Hz, line, keyword) of a leg's frequency lines,
    sorted by time, or None."""
    keys = np.array(seg.keywords)
    idx = np.flatnonzero(np.isin(keys, names))
    if idx.size == 0:
        return None
    receive = np.char.startswith(keys[idx].astype(str), "RECEIVE_FREQ")
    hz = seg.values[idx] + np.where(receive, offset, 0.0)
    low = np.flatnonzero(~(hz >= MIN_CARRIER_HZ))
    if low.size:
        i = idx[low[0]]
        extra = f" + FREQ_OFFSET {offset!r}" if receive[low[0]] else ""
        raise CCSDSFormatError(
            f"{keys[i]} = {float(seg.values[i])!r} Hz{extra} is not a carrier frequency (below "
            f"{MIN_CARRIER_HZ / 1e6:g} MHz): the ionosphere's delay needs the link's frequency; "
            "a Doppler shift needs FREQ_OFFSET (the frequency it is added to)",
            line=seg.lines[i], source=src)
    sec = (seg.times[idx] - seg.times[0]).sec
    order = np.argsort(sec, kind="stable")
    idx = idx[order]
    return sec[order], hz[order], [seg.lines[i] for i in idx], keys[idx]


def _ramp(seg, key, t0, t1, ignore):
    """The integral (Hz) of ``TRANSMIT_FREQ_RATE_n`` from ``t0`` to ``t1`` (seconds from the
    segment's first epoch, arrays) for the frequency line ``key`` (``TRANSMIT_FREQ_n``), and
    whether rate lines were read. A rate holds from its epoch to the next rate line (0 before
    the first): 503.0-B-2, 3.5.2."""
    rate_key = key.replace("TRANSMIT_FREQ_", "TRANSMIT_FREQ_RATE_", 1)
    keys = np.array(seg.keywords)
    idx = np.flatnonzero(keys == rate_key)
    if not key.startswith("TRANSMIT_FREQ_") or idx.size == 0 or rate_key in ignore:
        return 0.0, False
    sec = (seg.times[idx] - seg.times[0]).sec
    order = np.argsort(sec, kind="stable")
    sec, rate = sec[order], seg.values[idx][order]
    # integral from sec[0] to each rate epoch, then to any t
    knots = np.concatenate([[0.0], np.cumsum(rate[:-1] * np.diff(sec))])

    def integral(t):
        j = np.searchsorted(sec, t, side="right") - 1
        inside = j >= 0
        jj = np.maximum(j, 0)
        return np.where(inside, knots[jj] + rate[jj] * (t - sec[jj]), 0.0)

    return integral(np.asarray(t1, float)) - integral(np.asarray(t0, float)), True


def _ramped(seg, leg, j, sec, ignore):
    """The leg's frequency (Hz) at each time ``sec`` from its lines ``j``: the line's value
    plus the uplink ramp (``TRANSMIT_FREQ_RATE_n``) since the line's epoch; and the rate
    keywords read."""
    f = leg[1][j].astype(np.float64)
    used = []
    for key in dict.fromkeys(leg[3][j]):
        m = leg[3][j] == key
        df, read = _ramp(seg, str(key), leg[0][j][m], sec[m], ignore)
        f[m] += df
        if read:
            used.append(str(key).replace("TRANSMIT_FREQ_", "TRANSMIT_FREQ_RATE_", 1))
    return f, used


def _at(leg, sec):
    """Index in ``leg`` of the line used at each time ``sec``: the last at or before it, else
    the first."""
    j = np.searchsorted(leg[0], sec, side="right") - 1
    return np.maximum(j, 0)


def link_frequencies(seg, station, spacecraft, rows, frequency_hz, src, ignore=()):
    """The two-way frequency (Hz) of the segment's data lines ``rows`` (range and Doppler)
    from its frequency lines, and the keywords read; (None, ()) when it has none.

    Parameters
    ----------
    seg : TDMSegment
    station, spacecraft : int
        The participant numbers of the ground station and the spacecraft (path ``s, c, s``).
    rows : ndarray of int
        Indices of the segment's data lines that need a frequency.
    frequency_hz : float or None
        The frequency given to ``to_observations`` (checked against the TDM's).
    src : str
        The file's name, for messages.
    ignore : collection of str
        Keywords not to read (``to_observations(ignore=...)``).
    """
    meta = seg.metadata
    offset = float(meta.get("FREQ_OFFSET", 0.0) or 0.0)
    up_names = [k for k in (f"TRANSMIT_FREQ_{station}", f"RECEIVE_FREQ_{spacecraft}")
                if k not in ignore]
    down_names = [k for k in (f"RECEIVE_FREQ_{station}", "RECEIVE_FREQ",
                              f"TRANSMIT_FREQ_{spacecraft}") if k not in ignore]
    up = _leg(seg, up_names, offset, src)
    down = _leg(seg, down_names, offset, src)
    if up is None and down is None:
        return None, ()
    num, den = meta.get("TURNAROUND_NUMERATOR"), meta.get("TURNAROUND_DENOMINATOR")
    if (num is None) != (den is None) or (num is not None and (num <= 0 or den <= 0)):
        key = "TURNAROUND_NUMERATOR" if num is not None else "TURNAROUND_DENOMINATOR"
        raise CCSDSFormatError(
            "TURNAROUND_NUMERATOR and TURNAROUND_DENOMINATOR go together, both > 0 (downlink = "
            f"uplink * numerator / denominator); got {num!r} / {den!r}",
            line=meta.line_of(key), source=src)
    ratio = 1.0 if num is None else num / den
    sec = (seg.times[rows] - seg.times[0]).sec
    ramps = []
    if up is not None:
        ju = _at(up, sec)
        f_up, r = _ramped(seg, up, ju, sec, ignore)
        ramps += r
    if down is not None:
        jd = _at(down, sec)
        f_down, r = _ramped(seg, down, jd, sec, ignore)
        ramps += r
    if up is None:
        f_up = f_down / ratio
    if down is None:
        f_down = f_up * ratio
    f = two_way_frequency_hz(f_up, f_down)
    if frequency_hz is not None:
        off = np.minimum(np.abs(f_down / frequency_hz - 1.0), np.abs(f / frequency_hz - 1.0))
        bad = np.flatnonzero(off > AGREEMENT)
        if bad.size:
            k = int(bad[0])
            leg, j = (down, jd[k]) if down is not None else (up, ju[k])
            raise CCSDSFormatError(
                f"{leg[3][j]} gives a downlink of {f_down[k]:.6g} Hz (two-way {f[k]:.6g} Hz) at "
                f"{seg.epochs[rows[k]]}, but frequency_hz = {frequency_hz:.6g} Hz differs by "
                f"more than {AGREEMENT:.0%}: one of them is wrong. Leave frequency_hz out to "
                "use the TDM's frequencies, or correct the one that is wrong",
                line=leg[2][j], source=src)
    used = tuple(k for k in up_names + down_names if k in seg.keywords) + tuple(ramps)
    return f, used
