"""Units and time scales: the same physics whatever units and time scales the inputs carry.

visviva converts every Quantity once, in :mod:`visviva._units`, to km, km/s, s, rad, km3/s2.
These checks feed the same physical inputs expressed in other units (au, m, day, min, deg, m3/s2)
and in other astropy time scales (UTC, TAI, TT, TDB) and compare the results, with astropy's own
unit and time-scale conversions as the reference.

A check whose capability is not in visviva yet is reported as skipped with the reason.
"""

from __future__ import annotations

import math

import numpy as np

from .base import ONE_MM_KM, Check

__all__ = ["checks"]

#: relative tolerance for the same value through two unit paths (a few ulp of float64)
REL_ROUNDING = 1e-14
ONE_UM_PER_S_KM_S = 1e-9  # km/s


def _reference() -> str:
    import astropy

    return f"astropy {astropy.__version__} units/time"


def _skip(name: str, metric: str, tolerance: float, reason: str) -> Check:
    return Check(name, metric, math.nan, tolerance, _reference(), {"skipped": reason})


def _public(*names: str):
    """The public objects ``names`` of visviva, or raise LookupError saying which is missing."""
    import visviva as vv

    out = []
    for name in names:
        try:
            out.append(getattr(vv, name))
        except (AttributeError, ImportError) as exc:
            raise LookupError(f"visviva.{name} is not available yet ({exc})") from exc
    return out


def _guarded(name: str, metric: str, tolerance: float, fn, why: str = "") -> Check:
    """Run ``fn() -> (measured, details)``; a missing capability becomes a skip."""
    try:
        measured, details = fn()
    except LookupError as exc:
        return _skip(name, metric, tolerance, str(exc))
    if why:
        details["why"] = why
    return Check(name, metric, float(measured), tolerance, _reference(), details)


WHY_ROUNDING = ("the same number reached through two unit conversions differs only by float64 "
                "round-off (a few 1e-16 relative per operation)")
WHY_MM = ("positions of Earth orbits (~1e4 km) computed from inputs that differ only by unit "
          "round-off agree to ~1e-9 km; 1 mm leaves room for the conditioning of Kepler's "
          "equation")


def _rel(a, b) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    scale = np.maximum(np.abs(b), np.finfo(float).tiny)
    return np.abs(a - b) / scale


def _rng(seed: int = 20261121):
    return np.random.default_rng(seed)


# --------------------------------------------------------------------------------------------
# the one conversion module


def _canonical_conversion(n: int):
    from astropy import units as u

    from visviva import _units

    rng = _rng(1)
    cases = [
        ("length", rng.uniform(0.1, 40.0, n) * u.au),
        ("length", rng.uniform(1e5, 1e9, n) * u.m),
        ("speed", rng.uniform(0.1, 50.0, n) * u.au / u.day),
        ("speed", rng.uniform(1.0, 3e4, n) * u.m / u.s),
        ("time", rng.uniform(-400.0, 400.0, n) * u.day),
        ("time", rng.uniform(0.0, 100.0, n) * u.yr),
        ("time", rng.uniform(-3000.0, 3000.0, n) * u.min),
        ("angle", rng.uniform(-720.0, 720.0, n) * u.deg),
        ("angle", rng.uniform(-1e6, 1e6, n) * u.arcsec),
        ("gm", rng.uniform(1e13, 1e21, n) * u.m**3 / u.s**2),
        ("gm", rng.uniform(1e-10, 1e-3, n) * u.au**3 / u.day**2),
    ]
    worst = 0.0
    per_case = {}
    for kind, q in cases:
        got = _units.to_array(q, kind, "x")
        want = q.to_value(_units.CANONICAL[kind])
        err = float(np.max(_rel(got, want)))
        per_case[f"{kind} from {q.unit}"] = err
        worst = max(worst, err)
    return worst, {"samples_per_case": n, "max_rel_error_per_case": per_case}


# --------------------------------------------------------------------------------------------
# central force formulas in other units


def _central_force(n: int):
    from astropy import units as u

    (vis_viva,) = _public("vis_viva")
    import visviva as vv

    rng = _rng(2)
    r_km = rng.uniform(6600.0, 4e5, n)
    a_km = r_km * rng.uniform(0.6, 5.0, n)
    a_km = np.where(a_km < r_km / 2, r_km, a_km)  # bound: r <= 2a
    gm = vv.EARTH.gm
    base = vis_viva(r_km * u.km, a_km * u.km, gm).to_value(u.km / u.s)
    variants = {
        "au": vis_viva((r_km * u.km).to(u.au), (a_km * u.km).to(u.au), gm),
        "m": vis_viva((r_km * u.km).to(u.m), (a_km * u.km).to(u.m), gm.to(u.m**3 / u.s**2)),
        "au3/day2": vis_viva(r_km * u.km, a_km * u.km, gm.to(u.au**3 / u.day**2)),
    }
    ref = np.sqrt(gm * (2.0 / (r_km * u.km) - 1.0 / (a_km * u.km))).to_value(u.km / u.s)
    errors = {"astropy formula": float(np.max(_rel(base, ref)))}
    for label, value in variants.items():
        errors[label] = float(np.max(_rel(value.to_value(u.km / u.s), base)))
    rel_err = np.concatenate([_rel(v.to_value(u.km / u.s), base) for v in variants.values()])
    return max(errors.values()), {"samples": n, "max_rel_error_by_units": errors,
                                  "rel_error_units": rel_err}


def _elements_units(n: int):
    from astropy import units as u

    (StateVectors,) = _public("StateVectors")
    import visviva as vv

    rng = _rng(3)
    r = rng.normal(0.0, 1.0, (n, 3))
    r = r / np.linalg.norm(r, axis=-1, keepdims=True) * rng.uniform(6700.0, 42000.0, (n, 1))
    v_circ = np.sqrt(vv.EARTH.gm.to_value(u.km**3 / u.s**2) / np.linalg.norm(r, axis=-1))
    v = rng.normal(0.0, 1.0, (n, 3)) * (0.6 * v_circ[:, None])
    base = StateVectors(r * u.km, v * u.km / u.s, vv.EARTH).to_elements()
    alt = StateVectors((r * u.km).to(u.au), (v * u.km / u.s).to(u.au / u.day),
                       vv.EARTH.gm.to(u.au**3 / u.day**2)).to_elements()
    alt_m = StateVectors((r * u.km).to(u.m), (v * u.km / u.s).to(u.m / u.s),
                         vv.EARTH.gm.to(u.m**3 / u.s**2)).to_elements()
    errs = {}
    for label, other in (("au, au/day", alt), ("m, m/s", alt_m)):
        errs[f"p ({label})"] = float(np.max(_rel(other.semi_latus_rectum.to_value(u.km),
                                                 base.semi_latus_rectum.to_value(u.km))))
        errs[f"ecc ({label})"] = float(np.max(np.abs(np.asarray(other.eccentricity, float)
                                                     - np.asarray(base.eccentricity, float))))
        for attr in ("inclination", "longitude_of_ascending_node", "argument_of_periapsis",
                     "true_anomaly"):
            d = (getattr(other, attr) - getattr(base, attr)).to_value(u.rad)
            d = np.abs((d + np.pi) % (2 * np.pi) - np.pi)
            errs[f"{attr} ({label})"] = float(np.max(d))
    return max(errs.values()), {"samples": n, "max_error_by_element": errs}


def _round_trip_units(n: int):
    """state (au, au/day) -> elements -> state, compared in km: a histogram of relative errors."""
    from astropy import units as u

    (StateVectors,) = _public("StateVectors")
    import visviva as vv

    rng = _rng(7)
    r = rng.normal(0.0, 1.0, (n, 3))
    r = r / np.linalg.norm(r, axis=-1, keepdims=True) * rng.uniform(6700.0, 1e5, (n, 1))
    v_esc = np.sqrt(2 * vv.EARTH.gm.to_value(u.km**3 / u.s**2) / np.linalg.norm(r, axis=-1))
    v = rng.normal(0.0, 1.0, (n, 3))
    v = v / np.linalg.norm(v, axis=-1, keepdims=True) * (v_esc * rng.uniform(0.2, 1.8, n))[:, None]
    state = StateVectors((r * u.km).to(u.au), (v * u.km / u.s).to(u.au / u.day),
                         vv.EARTH.gm.to(u.au**3 / u.day**2))
    back = state.to_elements().to_state()
    dr_rel = (np.linalg.norm((back.r - state.r).to_value(u.km), axis=-1)
              / np.linalg.norm(r, axis=-1))
    dv_rel = (np.linalg.norm((back.v - state.v).to_value(u.km / u.s), axis=-1)
              / np.linalg.norm(v, axis=-1))
    return float(max(dr_rel.max(), dv_rel.max())), {
        "samples": n, "conics": "elliptic and hyperbolic, 0.2 to 1.8 times escape speed",
        "plot": {"kind": "hist", "y": ["dr_rel_error", "dv_rel_error"],
                 "labels": ["|dr| / |r|", "|dv| / |v|"],
                 "title": "round trip state -> elements -> state in au, au/day"},
        "dr_rel_error": dr_rel, "dv_rel_error": dv_rel}


def _propagation_units(n: int):
    from astropy import units as u

    (StateVectors,) = _public("StateVectors")
    import visviva as vv

    rng = _rng(4)
    r = np.column_stack([rng.uniform(6800.0, 9000.0, n), np.zeros(n), np.zeros(n)])
    speed = np.sqrt(vv.EARTH.gm.to_value(u.km**3 / u.s**2) / r[:, 0]) * rng.uniform(0.9, 1.1, n)
    v = np.column_stack([np.zeros(n), speed * np.cos(0.5), speed * np.sin(0.5)])
    state = StateVectors(r * u.km, v * u.km / u.s, vv.EARTH)
    dt_min = rng.uniform(-300.0, 300.0, n)
    base = state.propagate(dt_min * 60.0 * u.s)
    worst = 0.0
    per = {}
    for q in (dt_min * u.min, (dt_min * u.min).to(u.day), (dt_min * u.min).to(u.h)):
        other = state.propagate(q)
        dr = float(np.max(np.linalg.norm((other.r - base.r).to_value(u.km), axis=-1)))
        per[str(q.unit)] = dr
        worst = max(worst, dr)
    return worst, {"samples": n, "max_dr_km_by_time_unit": per}


def _elements_to_state_units(n: int):
    from astropy import units as u

    (KeplerianElements,) = _public("KeplerianElements")
    import visviva as vv

    rng = _rng(5)
    a_km = rng.uniform(7000.0, 1e5, n)
    ecc = rng.uniform(0.0, 0.9, n)
    inc, raan, argp, nu = (rng.uniform(0.1, 3.0, n) for _ in range(4))
    base = KeplerianElements.from_semi_major_axis(a_km * u.km, ecc, inc * u.rad, raan * u.rad,
                                                  argp * u.rad, nu * u.rad, vv.EARTH).to_state()
    other = KeplerianElements.from_semi_major_axis(
        (a_km * u.km).to(u.au), ecc, (inc * u.rad).to(u.deg), (raan * u.rad).to(u.deg),
        (argp * u.rad).to(u.arcmin), nu, vv.EARTH.gm.to(u.m**3 / u.s**2)).to_state()
    dr = np.linalg.norm((other.r - base.r).to_value(u.km), axis=-1)
    dv = np.linalg.norm((other.v - base.v).to_value(u.km / u.s), axis=-1)
    return float(np.max(dr)), {"samples": n, "max_dv_km_s": float(np.max(dv)), "dr_km": dr}


def _simulation_units(years: float):
    """Sun, Jupiter, Earth set up with Quantities, integrated in three unit systems."""
    from astropy import units as u

    (Simulation,) = _public("Simulation")

    def final_positions_km(units):
        sim = Simulation("ias15", units=units)
        sim.add(1 * u.Msun, [0, 0, 0] * u.km, [0, 0, 0] * u.km / u.s)
        sim.add(1 * u.Mjup, [5.2, 0, 0] * u.au, [0, 13.07, 0.3] * u.km / u.s)
        sim.add(1 * u.Mearth, [0, 1.0, 0.01] * u.au, [-29.78, 0, 0] * u.km / u.s)
        sim.integrate(years * u.yr)
        return sim.positions * sim.units.length_km

    base = final_positions_km(("au", "yr", "Msun"))
    scale = float(np.abs(base).max())
    per = {}
    for units in (("km", "s", "kg"), ("m", "day", "Mearth")):
        per[", ".join(units)] = float(np.abs(final_positions_km(units) - base).max() / scale)
    return max(per.values()), {"years": years, "bodies": "Sun, Jupiter, Earth",
                               "max_rel_dr_vs_au_yr_Msun": per}


# --------------------------------------------------------------------------------------------
# time scales


_TLE_ISS = ("1 25544U 98067A   19343.69339541  .00001764  00000-0  38792-4 0  9991",
            "2 25544  51.6439 211.2001 0007417  17.6667  85.6398 15.50103472202482")


def _satellite_time_scales(n: int):
    from astropy import units as u
    from astropy.time import Time

    (Satellite,) = _public("Satellite")
    sat = Satellite.from_tle(*_TLE_ISS)
    offsets = np.linspace(0.0, 2.0, n) * u.day
    t_utc = Time(sat.epoch.utc.jd1, sat.epoch.utc.jd2, format="jd", scale="utc") + offsets
    base = sat.teme(t_utc)
    per = {}
    worst = 0.0
    for label, t in (("tai", t_utc.tai), ("tt", t_utc.tt), ("tdb", t_utc.tdb),
                     ("offset from epoch (Quantity)", offsets)):
        other = sat.teme(t)
        dr = float(np.max(np.linalg.norm((other.r - base.r).to_value(u.km), axis=-1)))
        per[label] = dr
        worst = max(worst, dr)
    return worst, {"samples": n, "max_dr_km_by_time_scale": per}


def _lambert_units(n: int):
    from astropy import units as u

    (lambert,) = _public("lambert")
    import visviva as vv

    rng = _rng(6)
    r1 = rng.normal(0.0, 1.0, (n, 3))
    r1 = r1 / np.linalg.norm(r1, axis=-1, keepdims=True) * rng.uniform(7000.0, 42000.0, (n, 1))
    r2 = rng.normal(0.0, 1.0, (n, 3))
    r2 = r2 / np.linalg.norm(r2, axis=-1, keepdims=True) * rng.uniform(7000.0, 42000.0, (n, 1))
    tof_s = rng.uniform(1800.0, 86400.0, n)
    v1, v2 = lambert(r1 * u.km, r2 * u.km, tof_s * u.s, vv.EARTH)
    base = np.concatenate([v1.to_value(u.km / u.s), v2.to_value(u.km / u.s)], axis=-1)
    per = {}
    for label, args in (
        ("au, day", ((r1 * u.km).to(u.au), (r2 * u.km).to(u.au), (tof_s * u.s).to(u.day),
                     vv.EARTH)),
        ("m, min, m3/s2", ((r1 * u.km).to(u.m), (r2 * u.km).to(u.m), (tof_s * u.s).to(u.min),
                           vv.EARTH.gm.to(u.m**3 / u.s**2))),
    ):
        w1, w2 = lambert(*args)
        other = np.concatenate([w1.to_value(u.km / u.s), w2.to_value(u.km / u.s)], axis=-1)
        per[label] = float(np.max(np.abs(other - base)))
    return max(per.values()), {"samples": n, "max_dv_km_s_by_units": per}


def _cowell_time_scales():
    from astropy import units as u
    from astropy.time import Time

    propagate_cowell, StateVectors, J2 = _public("propagate_cowell", "StateVectors", "J2")
    import visviva as vv

    epoch = Time("2024-03-20T12:00:00", scale="utc")
    state = StateVectors([7000.0, 0.0, 0.0] * u.km, [0.0, 5.0, 5.6] * u.km / u.s, vv.EARTH,
                         epoch=epoch)
    offsets_min = np.linspace(10.0, 600.0, 8)
    base = propagate_cowell(state, offsets_min * u.min, [J2(vv.EARTH)])
    per = {}
    for label, t in (("s", (offsets_min * u.min).to(u.s)), ("day", (offsets_min * u.min).to(u.day)),
                     ("Time utc", epoch + offsets_min * u.min),
                     ("Time tt", (epoch + offsets_min * u.min).tt),
                     ("Time tdb", (epoch + offsets_min * u.min).tdb)):
        other = propagate_cowell(state, t, [J2(vv.EARTH)])
        per[label] = float(np.max(np.linalg.norm((other.r - base.r).to_value(u.km), axis=-1)))
    details = {"outputs": len(offsets_min), "max_dr_km_by_time_input": per}
    if max(per.values()) > ONE_MM_KM:
        worst = max(per, key=per.get)
        details["hint"] = (
            f"worst with t as {worst}: the same instants give different states. A time "
            "difference taken in TDB (t - epoch with t in TDB) is in TDB seconds; TDB - TT "
            "swings by +-1.7 ms over a year, so TDB seconds differ from the SI seconds of "
            "geocentric motion by up to ~3e-10; subtract in TT instead: (t.tt - epoch.tt)")
    return max(per.values()), details


def checks(full: bool = False) -> list[Check]:
    """Units and time-scale invariance of visviva (cheap: well under a second when compiled)."""
    n = 20000 if full else 2000
    return [
        _guarded("units: _units.to_array vs astropy (au, m, day, yr, deg, m3/s2, ...)",
                 "max relative difference", REL_ROUNDING, lambda: _canonical_conversion(n),
                 WHY_ROUNDING),
        _guarded("units: vis_viva with r, a, gm in km / au / m / au3/day2",
                 "max relative speed difference", REL_ROUNDING, lambda: _central_force(n),
                 WHY_ROUNDING),
        _guarded("units: StateVectors.to_elements in km, m, au (au/day)",
                 "max difference (relative p; ecc; angles rad)", 1e-12,
                 lambda: _elements_units(min(n, 2000)),
                 "element conversion amplifies input round-off by the conditioning of the "
                 "angles (large near e -> 0 and i -> 0); 1e-12 is a hundred times the measured"),
        _guarded("units: round trip state -> elements -> state with r in au, v in au/day",
                 "max relative |dr|, |dv|", 1e-12, lambda: _round_trip_units(min(n, 5000)),
                 "a round trip repeats the conversion's round-off a few times; elements are "
                 "ill-conditioned only near e = 0 and i = 0, where angles trade off exactly"),
        _guarded("units: KeplerianElements.to_state with a in au, angles in deg/arcmin",
                 "max |dr| (km)", ONE_MM_KM, lambda: _elements_to_state_units(min(n, 2000)),
                 WHY_MM),
        _guarded("units: propagate with dt in s / min / h / day",
                 "max |dr| (km)", ONE_MM_KM, lambda: _propagation_units(min(n, 2000)),
                 WHY_MM),
        _guarded("time scales: Satellite.teme at the same instant in UTC/TAI/TT/TDB and as offset",
                 "max |dr| (km)", ONE_MM_KM, lambda: _satellite_time_scales(200 if full else 50),
                 "astropy converts the instant between scales to ~1 ns or better (a LEO moves "
                 "8 um in 1 ns); 1 mm is the budget for SGP4 evaluated at the same instant"),
        _guarded("units: Simulation (IAS15) in au/yr/Msun, km/s/kg, m/day/Mearth",
                 "max |dr| / max |r| (20 yr; 100 yr with --full)", 1e-11,
                 lambda: _simulation_units(100.0 if full else 20.0),
                 "IAS15's step control is dimensionless, so the three runs take the same steps "
                 "and differ by round-off growing over ~20 orbits (measured ~1e-13)"),
        _guarded("units: lambert with r in km / au / m, tof in s / day / min",
                 "max |dv| (km/s)", 1e-9, lambda: _lambert_units(200 if full else 50),
                 "the same geometry and time of flight up to unit round-off; the iteration "
                 "converges to ~1e-14 relative, so 1 um/s is a generous bound"),
        _guarded("time scales: propagate_cowell (J2) with t in min / s / day / Time utc, tt, tdb",
                 "max |dr| (km)", ONE_MM_KM, _cowell_time_scales,
                 "the same output instants expressed differently: the adaptive integrator takes "
                 "the same steps, so the results differ by round-off of the last step (<< 1 mm)"),
    ]
