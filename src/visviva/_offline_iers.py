"""Earth-orientation data for every time conversion: offline, and the same table in every call.

:func:`offline_iers` is the one place visviva switches astropy to its own Earth-orientation
table (:mod:`visviva._iers_cache`, :mod:`visviva._eop_table`) with downloads off: every
conversion of a Time to or from UT1, and every Earth-fixed rotation, runs inside it. It lives
outside :mod:`visviva.satellites` so that :mod:`visviva.nbody` (a UT1 epoch for
``solar_system``) uses the same policy; ``visviva.satellites.frames.offline_iers`` is this.
"""

from __future__ import annotations

import contextlib
import threading

__all__ = ["offline_iers"]


@contextlib.contextmanager
def offline_iers():
    """Use visviva's Earth-orientation table, from the files installed with astropy; never download.

    Inside the block ``astropy.utils.iers.earth_orientation_table`` is visviva's table
    (:func:`visviva._iers_cache.visviva_table`: astropy's ``IERS_Auto`` table from the
    installed files with the EOP C04 rows from 1962 first, the same whatever table astropy
    loaded before), unless the user set one with ``earth_orientation_table.set(...)``: that
    one is used as given. ``astropy.utils.iers.conf.auto_download`` is ``False``, the table's
    predictions are used however old the installed file is (``auto_max_age = None``), and
    times beyond the table warn instead of raising (``iers_degraded_accuracy = "warn"``): an
    :class:`~visviva.errors.EarthOrientationWarning` naming the date and the possible error,
    once per kind per call. The parsed table is kept on disk between processes
    (:mod:`visviva._iers_cache`), so a fresh process loads it in ~10 ms. Re-entrant and
    thread-safe: threads inside such blocks share one activation (astropy's settings are
    process-wide), undone when the last block ends.
    """
    from ._eop_table import warning_scope

    _enter()
    try:
        with warning_scope():
            yield
    finally:
        _exit()


#: the settings are process-wide (astropy's configuration and science state are global), so
#: threads share one activation: the first block to enter applies them, the last to leave
#: restores them (a thread leaving while another still converts would otherwise hand the
#: other astropy's own table and downloads mid-call: 0.36 km of ITRS in 1968, seen)
_LOCK = threading.RLock()
_DEPTH = 0
_ACTIVE: contextlib.ExitStack | None = None


def _enter() -> None:
    global _DEPTH, _ACTIVE
    with _LOCK:
        if _DEPTH == 0:
            _ACTIVE = _apply()
        _DEPTH += 1


def _exit() -> None:
    global _DEPTH, _ACTIVE
    with _LOCK:
        _DEPTH -= 1
        if _DEPTH == 0:
            active, _ACTIVE = _ACTIVE, None
            active.close()


def _apply() -> contextlib.ExitStack:
    from astropy.utils import iers

    from ._iers_cache import visviva_table

    stack = contextlib.ExitStack()
    try:
        stack.enter_context(iers.conf.set_temp("auto_download", False))
        # the installed table's predictions are used however old the file is (without this,
        # astropy refuses predictions from a file more than 30 days old: it expects to
        # download a newer one)
        stack.enter_context(iers.conf.set_temp("auto_max_age", None))
        stack.enter_context(iers.conf.set_temp("iers_degraded_accuracy", "warn"))
        if getattr(iers.earth_orientation_table, "_value", None) is None:  # else the user's
            stack.enter_context(iers.earth_orientation_table.set(visviva_table()))
    except BaseException:
        stack.close()
        raise
    return stack
