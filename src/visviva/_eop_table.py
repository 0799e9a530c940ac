"""visviva's Earth-orientation table: astropy's ``IERS_Auto`` rows that say when they run out.

:class:`EarthOrientationTable` is astropy's ``IERS_Auto`` table (with the EOP C04 rows of
1962-1972 put first, :func:`visviva._iers_cache.with_eop_c04_before`) whose
interpolation behaves exactly as astropy's, number for number, except that a time outside the
table issues an :class:`~visviva.errors.EarthOrientationWarning` naming the date and how wrong
UT1 may be there. astropy holds UT1 - UTC at the table's last (or first) value there and says
nothing about it (it warns only about polar motion, and only in the frame transformations).

visviva hands this table to astropy as ``astropy.utils.iers.earth_orientation_table`` inside
:func:`visviva._offline_iers.offline_iers` only, so whatever table astropy itself loaded
before (a user's ``Time(...).ut1``) changes nothing in visviva's numbers, and visviva changes
nothing in astropy's outside its calls.

Bounds quoted in the warning (docs/conventions.md, "Earth orientation"): past the table the
Earth's rotation angle drifts away from the held UT1 - UTC by the accumulated excess length of
day, 0.1-0.3 s per year lately and up to ~1 s per year in the 1970s-1990s (the leap-second
era's rate); 1 s of UT1 is 15" of rotation, 0.465 km along the equator. Before 1962 the table
holds UT1 - UTC at 0.033 s while the true Delta T falls away from the UTC of ERFA (which before
1960 is TAI, Delta T = 32.184 s): ~1 s wrong in 1955, ~35 s in 1900.
"""

from __future__ import annotations

import contextvars
import warnings

import numpy as np
from astropy.utils import iers

from ._callsite import outside_stacklevel
from .errors import EarthOrientationWarning

__all__ = ["EarthOrientationTable", "warning_scope", "insensitive", "check_carried_ut1",
           "is_insensitive", "issue_once"]

#: a UT1 - UTC carried by a Time that differs from the table's by more than this (s) warns
CARRIED_TOL_S = 0.1

#: drift of UT1 against a held UT1 - UTC, s per year (the upper end: the 1970s-1990s rate)
DRIFT_S_PER_YEAR = 1.0
#: the equator's speed due to the Earth's rotation, km per second of UT1
EQUATOR_KM_PER_S = 0.465

#: keys of the warnings already issued in the current visviva call (None: outside any call)
_ISSUED: contextvars.ContextVar[set | None] = contextvars.ContextVar("_eop_issued", default=None)
#: True while computing a result that does not depend on UT1 (TEME <-> GCRS rotations)
_QUIET: contextvars.ContextVar[bool] = contextvars.ContextVar("_eop_quiet", default=False)


class warning_scope:
    """Within one (outermost) block each kind of warning is issued once (re-entrant)."""

    def __enter__(self):
        self._token = _ISSUED.set(set()) if _ISSUED.get() is None else None
        return self

    def __exit__(self, *exc):
        if self._token is not None:
            _ISSUED.reset(self._token)
        return False


class insensitive:
    """No warning inside: the result does not depend on UT1 or the pole (TEME <-> GCRS, where
    GMST and the Earth rotation angle cancel to ~1e-11 rad per second of UT1 error)."""

    def __enter__(self):
        self._token = _QUIET.set(True)
        return self

    def __exit__(self, *exc):
        _QUIET.reset(self._token)
        return False


def is_insensitive() -> bool:
    """True inside :class:`insensitive` (the result does not depend on UT1 or the pole)."""
    return _QUIET.get()


def _isot(mjd: float) -> str:
    from astropy.time import Time

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # ERFA's "dubious year" far from the leap-second table
        return Time(mjd, format="mjd", scale="utc").isot[:10]


def _issue(key: str, message: str, category=EarthOrientationWarning) -> None:
    if _QUIET.get():
        return
    issued = _ISSUED.get()
    if issued is not None:
        if key in issued:
            return
        issued.add(key)
    warnings.warn(message, category, stacklevel=outside_stacklevel())


def issue_once(key: str, message: str, category) -> None:
    """Warn ``message`` (``category``) once per visviva call (:class:`warning_scope`), and not
    at all inside :class:`insensitive`; outside any call, every time."""
    _issue(key, message, category)


class EarthOrientationTable(iers.IERS_Auto):
    """astropy's ``IERS_Auto`` table that warns for times outside it (module docstring)."""

    def _interpolate(self, jd1, jd2, columns, source=None):
        out = super()._interpolate(jd1, jd2, columns, source)
        mjd, frac = self.mjd_utc(jd1, jd2)
        if "UT1_UTC" in columns:
            out = self._across_utc_steps(out, columns, source, jd1, jd2, mjd, frac)
        days = np.asarray(mjd, dtype=np.float64) + np.asarray(frac, dtype=np.float64)
        days = days[np.isfinite(days)]
        if days.size:
            first, last = self._mjd_range()
            if days.max() > last:
                self._warn_after(float(days.max()), last)
            if days.min() < first:
                self._warn_before(float(days.min()), first)
        return out

    def _across_utc_steps(self, out, columns, source, jd1, jd2, mjd, frac):
        """UT1 - UTC before 1972 interpolated as UT1 - TAI, in the form ERFA's ``utcut1`` takes.

        Before 1972 UTC stepped by fractions of a second (0.1 s on 1963-11-01, 1964-04-01,
        1964-09-01, 1965-01-01, 1965-03-01, 1965-07-01, 1965-09-01, -0.1 s on 1968-02-01 and
        0.107758 s on 1972-01-01) and drifted from TAI by 1.296 ms (1962-1965) or 2.592 ms
        (1966-1971) a day. astropy interpolates UT1 - UTC linearly between the daily rows and
        removes only whole-second jumps (leap seconds), and ERFA's ``utcut1`` (UTC -> UT1)
        applies the value as UT1 = TAI + (UT1 - UTC) - (TAI - UTC at 0h of the day). So, with
        astropy's value: over the day before each step UT1 ran up to 0.1 s wrong and jumped back
        at 00:00 (~46 m along the equator, ~51 m in a LEO's ITRS position); an instant at 00:00
        that astropy holds as the end of the previous day (``t0 + dt``) got that day's 0h
        TAI - UTC (0.1 s off after a step, a day of drift otherwise); and each day UT1 drifted
        by up to 2.6 ms before it jumped back at 00:00.

        UT1 - TAI is smooth: it is interpolated between the rows, and TAI - UTC at 0h of the
        day ERFA places (``jd1``, ``jd2``) in is added back, so that ``utcut1`` gives UT1 = TAI
        + (UT1 - TAI) exactly. The reverse conversion (a Time given in UT1, ERFA ``ut1utc``,
        UTC = UT1 - value) is then off by the drift since 0h, at most 2.6 ms (it was exact on
        days without a step). From 1972 on astropy's own value is kept, number for number.
        """
        import erfa

        mjd = np.atleast_1d(np.asarray(mjd, dtype=np.float64))
        if not np.any(mjd <= _LAST_FRACTIONAL_STEP_MJD):  # (also for an empty array)
            return out  # all from 1972-01-02 on: astropy's values
        if hasattr(jd1, "utc"):  # a Time (as astropy's mjd_utc accepts)
            jd1, jd2 = jd1.utc.jd1, jd1.utc.jd2
        frac = np.atleast_1d(np.asarray(frac, dtype=np.float64))
        jd1, jd2 = (np.broadcast_to(np.asarray(x, dtype=np.float64), mjd.shape)
                    for x in (jd1, jd2))
        table_mjd = np.asarray(self["MJD"].to_value("d"), dtype=np.float64)
        i = np.searchsorted(table_mjd, mjd, side="right")
        i1 = np.clip(i, 1, len(table_mjd) - 1)
        early = (table_mjd[i1] <= _LAST_FRACTIONAL_STEP_MJD) | (mjd <= _LAST_FRACTIONAL_STEP_MJD)
        fix = (i > 0) & (i < len(table_mjd)) & early & np.isfinite(jd1 + jd2)
        if not fix.any():
            return out
        i0, i1 = i1[fix] - 1, i1[fix]
        mjd0, mjd1 = table_mjd[i0], table_mjd[i1]
        dut = np.asarray(self["UT1_UTC"].to_value("s"), dtype=np.float64)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", erfa.ErfaWarning)
            ut1_tai0 = dut[i0] - _tai_minus_utc_0h(2400000.5, mjd0)
            ut1_tai1 = dut[i1] - _tai_minus_utc_0h(2400000.5, mjd1)
            at_0h = _tai_minus_utc_0h(jd1[fix], jd2[fix])  # of ERFA's day, as utcut1 takes
        f = (mjd[fix] - mjd0 + frac[fix]) / (mjd1 - mjd0)
        k = columns.index("UT1_UTC")
        many = source is not None or len(columns) > 1
        old = out[k] if many else out
        shape = np.shape(old)
        val = np.array(np.broadcast_to(old.to_value("s"), mjd.shape), dtype=np.float64)
        val[fix] = ut1_tai0 + f * (ut1_tai1 - ut1_tai0) + at_0h
        new = (val.reshape(shape) if shape else val.reshape(-1)[0]) * old.unit
        if many:
            out = list(out)
            out[k] = new
            return out
        return new

    def _mjd_range(self) -> tuple[float, float]:
        """(first, last) MJD of the table, computed once."""
        rng = self.__dict__.get("_visviva_mjd_range")
        if rng is None:
            mjd = self["MJD"]
            rng = (float(mjd[0].to_value("d")), float(mjd[-1].to_value("d")))
            self.__dict__["_visviva_mjd_range"] = rng
        return rng

    def _warn_after(self, mjd: float, last: float) -> None:
        years = (mjd - last) / 365.25
        held = float(self["UT1_UTC"][-1].to_value("s"))
        err_s = max(years * DRIFT_S_PER_YEAR, 0.05)
        _issue("after", (
            f"Earth orientation for {_isot(mjd)} is {years:.1f} years past the end of the IERS "
            f"table (predictions end {_isot(last)}; astropy-iers-data installed with astropy): "
            f"UT1-UTC is held at its last value, {held:+.4f} s, and the pole at the 50-year "
            f"mean. UT1 drifts from a held value by 0.1-1 s a year, so Earth-fixed (ITRS) "
            f"positions, look angles and sidereal times there may be off by up to ~{err_s:.1f} s "
            f"of rotation (~{err_s * EQUATOR_KM_PER_S:.1f} km along the equator), and times "
            "given in UT1 by as many seconds of time. Install a "
            "newer astropy-iers-data (pip install -U astropy-iers-data) or set "
            "astropy.utils.iers.earth_orientation_table to a current IERS-A table."))

    def _warn_before(self, mjd: float, first: float) -> None:
        years = (first - mjd) / 365.25
        held = float(self["UT1_UTC"][0].to_value("s"))
        _issue("before", (
            f"Earth orientation for {_isot(mjd)} is {years:.1f} years before the IERS table "
            f"(EOP C04 from {_isot(first)}): UT1-UTC is held at its first value, {held:+.4f} s, "
            "and the pole at the 50-year mean. Before 1960 UTC is undefined (ERFA treats it "
            "as TAI), so UT1 there is off by Delta T - 32.2 s: ~1 s in 1955 (~0.5 km along "
            "the equator), ~35 s in 1900; Earth-fixed (ITRS) positions, look angles and "
            "sidereal times are that far off. Set astropy.utils.iers.earth_orientation_table, "
            "or give the times' delta_ut1_utc, from a long-term Delta T model."))


#: MJD of 1972-01-01, the last step of UTC by a fraction of a second (0.107758 s); whole-second
#: leap seconds after it are removed by astropy's own interpolation
_LAST_FRACTIONAL_STEP_MJD = 41317.0


def _tai_minus_utc_0h(jd1, jd2):
    """TAI - UTC (s) at 0h of the calendar day ERFA places the UTC date ``jd1 + jd2`` in."""
    import erfa

    iy, im, iday, _ = erfa.jd2cal(jd1, jd2)
    return np.asarray(erfa.dat(iy, im, iday, 0.0), dtype=np.float64)


def check_carried_ut1(t) -> None:
    """Warn when ``t`` carries a UT1 - UTC far (> 0.1 s) from visviva's table.

    astropy keeps the UT1 it computed the first time (``t.ut1`` is cached on ``t``, with its
    UT1 - UTC), or the ``t.delta_ut1_utc`` the user set, and uses it from then on, whatever
    table is in force: a ``t.ut1`` computed before visviva's first call with astropy's own table (UT1 - UTC
    held at 0.808 s before 1973) would carry that value into visviva's rotations. The value
    the Time carries is used (it may be the user's own); the warning says so.
    """
    carried = getattr(t, "_delta_ut1_utc", None)  # set by the user
    if carried is None:  # or computed by an earlier t.ut1, which astropy caches whole
        cached = t.cache["scale"].get("ut1") if "scale" in t.cache else None
        carried = getattr(cached, "_delta_ut1_utc", None)
    table = iers.earth_orientation_table.get()
    if carried is None or not isinstance(table, EarthOrientationTable) or t.size == 0:
        return
    utc = t.utc
    ours = np.asarray(table.ut1_utc(utc.jd1, utc.jd2).to_value("s"))
    diff = np.abs(np.asarray(carried, dtype=np.float64) - ours)
    if not np.nanmax(diff, initial=0.0) > CARRIED_TOL_S:
        return
    k = int(np.nanargmax(np.broadcast_to(diff, np.shape(ours)).ravel())) if np.ndim(ours) else 0
    flat_c = np.broadcast_to(np.asarray(carried, dtype=np.float64), np.shape(ours)).ravel()
    when = utc.ravel()[k] if utc.ndim else utc
    _issue("carried", (
        f"the Time carries UT1-UTC = {float(flat_c[k]):+.4f} s at {when.isot[:19]} (set on it, "
        "or computed by an earlier .ut1 with another IERS table, e.g. astropy's own before "
        "visviva's first call); visviva's table gives "
        f"{float(np.ravel(ours)[k]):+.4f} s there. visviva uses the value the Time carries "
        f"({float(np.ravel(diff)[k]):.2f} s of Earth rotation, "
        f"~{float(np.ravel(diff)[k]) * EQUATOR_KM_PER_S:.2f} km along the equator, apart). To "
        "use the table, pass a fresh Time, e.g. Time(t.jd1, t.jd2, format='jd', "
        "scale=t.scale)."))
