"""The solar system as an N-body simulation: Sun, planets (system barycentres), optionally Pluto.

At J2000 (the default) the states come from ``visviva/data/solar_system_j2000.json`` (JPL DE421
evaluated with jplephem; GM from DE440), barycentric ICRF. For another epoch, the states are read
from DE421 with jplephem when the ``de421`` and ``jplephem`` packages are installed (the ``ephem``
extra); the positions then carry DE421's accuracy (sub-km for the planets over 1900-2050), and
otherwise astropy's built-in ephemeris is used, with a warning: its planets (ERFA plan94) are off
by up to 4e-4 in position and 4e-3 in velocity (relative; Saturn, Uranus, Neptune, 1950-2050).
"""

from __future__ import annotations

import json
from importlib import resources

import numpy as np

from .._offline_iers import offline_iers
from .._units import require_usable_time
from ..constants import AU_KM, DAY_S, J2000_JD, JULIAN_YEAR_S
from ..errors import InvalidInputError, fmt_number

__all__ = ["solar_system", "PLANETS"]

#: Bodies in the order they are added (keys of the data file and their GM keys).
PLANETS = (
    ("sun", "sun"),
    ("mercury", "mercury_sys"),
    ("venus", "venus_sys"),
    ("earthmoon", "earth_moon_bary"),
    ("mars", "mars_sys"),
    ("jupiter", "jupiter_sys"),
    ("saturn", "saturn_sys"),
    ("uranus", "uranus_sys"),
    ("neptune", "neptune_sys"),
    ("pluto", "pluto_sys"),
)


def _load():
    text = resources.files("visviva.data").joinpath("solar_system_j2000.json").read_text()
    return json.loads(text)


def _states_at(epoch, names):
    """Barycentric states (km, km/s) of ``names`` at an astropy Time other than J2000.

    DE421 through jplephem when installed (sub-km for the planets), else astropy's built-in
    ephemeris, with a warning (:func:`_builtin_states`).
    """
    _jd(epoch)  # checked
    # two-part TDB Julian date: one float64 JD is only good to ~20 us (~0.6 m of the Earth's
    # motion); a Time keeps both parts
    with offline_iers():  # a UT1 epoch needs the installed IERS table, never a download
        jd, jd2 = (float(epoch.tdb.jd1), float(epoch.tdb.jd2)) if hasattr(epoch, "tdb") else (
            float(epoch), 0.0)
    try:
        import de421
        from jplephem import DateError, Ephemeris
    except ImportError:
        return _builtin_states(epoch, names, jd + jd2)
    eph = Ephemeris(de421)
    out = {}
    for name in names:
        try:
            r, v = eph.position_and_velocity(name, jd, jd2)
        except DateError as exc:
            raise InvalidInputError(
                f"solar_system: the epoch (TDB JD {jd + jd2:.1f}) is outside DE421 "
                f"({exc}); give an epoch between 1900 and 2199.") from None
        out[name] = (np.asarray(r).ravel(), np.asarray(v).ravel() / DAY_S)
    return out


#: ERFA's plan94 (astropy's built-in planets) covers J2000 +- this many days (1000-3000 AD)
PLAN94_SPAN_DAYS = 365250.0


def _builtin_states(epoch, names, jd_tdb: float):
    """The states from astropy's built-in ephemeris, with a warning saying how far off they are.

    Its planets come from ERFA's plan94: largest relative errors against DE421 over 25 epochs
    1950-2050, position / velocity: Mars 6.9e-5 / 1.4e-4, Jupiter 1.6e-4 / 1.1e-3, Saturn
    3.2e-4 / 3.6e-3, Uranus 4.2e-4 / 3.9e-3, Neptune 5.2e-5 / 3.9e-3 (the Sun and the inner
    planets 1e-5 to 7e-5); a velocity 4e-3 off makes the period about 1 % off."""
    import warnings

    from astropy.coordinates import get_body_barycentric_posvel

    if "pluto" in names:
        raise InvalidInputError(
            "solar_system(pluto=True) at an epoch other than J2000 needs DE421: pip install "
            "de421 jplephem (the 'ephem' extra); astropy's built-in ephemeris has no Pluto.")
    if not abs(jd_tdb - J2000_JD) <= PLAN94_SPAN_DAYS:
        raise InvalidInputError(
            f"solar_system: the epoch (TDB JD {jd_tdb:.1f}) is outside astropy's built-in "
            "ephemeris (ERFA plan94: the years 1000 to 3000, where DE421 is not installed); "
            "give an epoch in that range, or install DE421 (pip install de421 jplephem) for "
            "1900 to 2199.")
    warnings.warn(
        "solar_system: DE421 is not installed (pip install de421 jplephem, the 'ephem' extra), "
        "so the states come from astropy's built-in ephemeris (ERFA plan94), off by up to "
        "4e-4 in position and 4e-3 in velocity (Saturn, Uranus, Neptune; periods ~1 % off; "
        "measured 1950-2050).",
        UserWarning, stacklevel=4)
    astro = {"earthmoon": "earth-moon-barycenter"}
    out = {}
    for name in names:
        pos, vel = get_body_barycentric_posvel(astro.get(name, name), epoch, ephemeris="builtin")
        out[name] = (pos.xyz.to_value("km"), vel.xyz.to_value("km/s"))
    return out


def solar_system(epoch=None, *, integrator="whfast", dt=None, pluto=False, units=("au", "yr", "Msun")):
    """A :class:`visviva.Simulation` of the Sun and the planets (system barycentres).

    Parameters
    ----------
    epoch : astropy Time, optional
        Epoch of the states; J2000 (TDB) by default, from the bundled DE421 table.
    integrator : str
        Integrator of the new simulation (``"whfast"`` by default).
    dt : float, optional
        Step in years; default 4.4 days (1/20 of Mercury's period) for the fixed-step ones.
    pluto : bool
        Add Pluto (system barycentre) as a tenth body.
    units : tuple
        ``("au", "yr", "Msun")``; G is set to ``GM_sun`` in these units (DE440), and each mass
        to ``GM / GM_sun``, so the gravitational parameters are exactly DE440's.

    Returns
    -------
    Simulation
        Barycentric ICRF positions (au) and velocities (au/yr), t = 0 at ``epoch``.
    """
    from .simulation import Simulation

    if tuple(units) != ("au", "yr", "Msun"):
        raise InvalidInputError("solar_system() builds the system in units ('au', 'yr', 'Msun').")
    data = _load()
    gms = data["gm_km3_s2_system_barycentres"]
    bodies = [b for b in PLANETS if pluto or b[0] != "pluto"]
    if epoch is None or abs(_jd(epoch) - J2000_JD) < 1e-9:
        states = {name: (np.array(data["states_km_km_s"][name]["r"]),
                         np.array(data["states_km_km_s"][name]["v"])) for name, _ in bodies}
    else:
        states = _states_at(epoch, [name for name, _ in bodies])
    gm_sun = gms["sun"]
    G = gm_sun * JULIAN_YEAR_S**2 / AU_KM**3
    if dt is None and integrator != "ias15":
        dt = 4.4 / 365.25
    sim = Simulation(integrator, G=G, dt=dt)
    # the unit system (au, yr, Msun) for Quantities and the speed of light; G stays DE440's
    # GM_sun in these units rather than CODATA G times the IAU solar mass (5e-6 apart)
    from .units import SimulationUnits

    sim.units = SimulationUnits.parse(units)
    speed = AU_KM / JULIAN_YEAR_S
    for name, gm_key in bodies:
        r, v = states[name]
        sim.add(gms[gm_key] / gm_sun, np.asarray(r) / AU_KM, np.asarray(v) / speed)
    sim.names = [name for name, _ in bodies]
    return sim


def _jd(epoch):
    from astropy.time import Time, TimeDelta

    if isinstance(epoch, TimeDelta):
        raise InvalidInputError(
            "epoch must be an absolute date (an astropy Time or a TDB Julian date), not a "
            "TimeDelta; e.g. Time('2025-01-01', scale='tdb').")
    if isinstance(epoch, Time):
        require_usable_time(epoch, "epoch")
    try:
        with offline_iers():  # a UT1 epoch needs the installed IERS table, never a download
            jd = float(epoch.tdb.jd) if hasattr(epoch, "tdb") else float(epoch)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(
            f"epoch must be an astropy Time (e.g. Time('2025-01-01', scale='tdb')) or a TDB "
            f"Julian date; got {fmt_number(epoch)}."
        ) from exc
    if not np.isfinite(jd):
        raise InvalidInputError(f"epoch must be a finite Julian date; got {fmt_number(epoch)}.")
    return jd
