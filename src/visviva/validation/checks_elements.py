"""State vectors <-> orbital elements, checked live against Skyfield and by round trips.

* Classical elements of 10^4 random non-degenerate states (0.01 < e < 0.99 or 1.01 < e < 10,
  sin i > 0.01) against Skyfield's ``elementslib.OsculatingElements``: lengths relative, angles
  absolute (rad, modulo 2 pi).
* Elements -> state against Skyfield's ``keplerlib.ele_to_vec`` on the same orbits.
* state -> elements -> state round trips on the degenerate matrix (circular, equatorial
  prograde and retrograde, polar, exact parabola, near-parabolic, hyperbolic, signed zeros),
  where Skyfield and most libraries lose the orbit, and through the modified equinoctial
  elements with both retrograde factors.
* Vallado Example 2-5 against its full-precision values.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from .base import Check

__all__ = ["checks"]

REL_SKYFIELD = 1e-10  # relative, lengths
ANG_SKYFIELD = 1e-10  # rad
REL_ROUND_TRIP = 1e-12
MU = 398600.4418


def _skyfield_ref() -> str:
    import skyfield

    return f"skyfield {skyfield.__version__}"


def _ang_diff(a, b):
    return np.abs(np.mod(np.asarray(a) - np.asarray(b) + math.pi, 2 * math.pi) - math.pi)


def _random_states(n: int, seed: int):
    from astropy import units as u

    import visviva as vv

    rng = np.random.default_rng(seed)
    r = rng.normal(size=(4 * n, 3)) * 10000.0
    v = rng.normal(size=(4 * n, 3)) * 4.0
    s = vv.StateVectors(r * u.km, v * u.km / u.s, MU * u.km**3 / u.s**2)
    el = s.to_elements()
    e = el.eccentricity
    i = el.inclination.value
    ok = (((e > 0.01) & (e < 0.99)) | ((e > 1.01) & (e < 10))) & (np.sin(i) > 0.01)
    ok &= el.semi_latus_rectum.value / s.radius.value > 0.01
    idx = np.flatnonzero(ok)[:n]
    return r[idx], v[idx]


def _vs_skyfield(n: int) -> list[Check]:
    from astropy import units as u
    from skyfield.elementslib import OsculatingElements
    from skyfield.keplerlib import ele_to_vec
    from skyfield.units import Distance, Velocity

    import visviva as vv

    r, v = _random_states(n, seed=2024)
    sky = OsculatingElements(Distance(km=r.T), Velocity(km_per_s=v.T), None, MU)
    el = vv.StateVectors(r * u.km, v * u.km / u.s, MU * u.km**3 / u.s**2).to_elements()
    ref = _skyfield_ref() + " elementslib.OsculatingElements"
    details = {"n_states": int(len(r))}
    lengths = max(
        float(np.max(np.abs(el.semi_latus_rectum.value / sky.semi_latus_rectum.km - 1))),
        float(np.max(np.abs(el.semi_major_axis.value / sky.semi_major_axis.km - 1))),
        float(np.max(np.abs(el.periapsis_distance.value / sky.periapsis_distance.km - 1))),
    )
    ecc = float(np.max(np.abs(el.eccentricity / sky.eccentricity - 1)))
    out = [
        Check("elements vs skyfield: p, a, q", "max relative difference", lengths,
              REL_SKYFIELD, ref, details),
        Check("elements vs skyfield: eccentricity", "max relative difference", ecc,
              REL_SKYFIELD, ref, details),
    ]
    for label, ours, theirs in [
        ("inclination", el.inclination, sky.inclination),
        ("raan", el.longitude_of_ascending_node, sky.longitude_of_ascending_node),
        ("argument of periapsis", el.argument_of_periapsis, sky.argument_of_periapsis),
        ("true anomaly", el.true_anomaly, sky.true_anomaly),
        # Skyfield wraps the hyperbolic mean anomaly e sinh F - F (not an angle) differently:
        # compare M on the ellipses only
        ("mean anomaly (ellipses)", el.mean_anomaly, sky.mean_anomaly),
    ]:
        keep = el.eccentricity < 1 if label.startswith("mean") else slice(None)
        diff = float(_ang_diff(ours.to_value(u.rad)[keep], theirs.radians[keep]).max())
        out.append(Check(f"elements vs skyfield: {label}", "max |difference| (rad)", diff,
                         ANG_SKYFIELD, ref, details))
    R, V = ele_to_vec(el.semi_latus_rectum.value, el.eccentricity, el.inclination.value,
                      el.longitude_of_ascending_node.value, el.argument_of_periapsis.value,
                      el.true_anomaly.value, MU)
    s = el.to_state()
    dr = np.linalg.norm(s.r.value - R.T, axis=-1) / np.linalg.norm(r, axis=-1)
    dv = np.linalg.norm(s.v.value - V.T, axis=-1) / np.linalg.norm(v, axis=-1)
    out.append(Check("elements -> state vs skyfield ele_to_vec", "max relative |dr|, |dv|",
                     float(max(dr.max(), dv.max())), REL_SKYFIELD,
                     _skyfield_ref() + " keplerlib.ele_to_vec", details))
    return out


def _degenerate_matrix():
    """(label, r, v) triples of the exactly degenerate geometries, with signed zeros."""
    vc = math.sqrt(MU / 7000.0)
    vp = math.sqrt(2 * MU / 7000.0)
    cases = []
    for z in (0.0, -0.0):
        zs = "-0" if math.copysign(1, z) < 0 else "+0"
        for sgn, sense in ((1.0, "prograde"), (-1.0, "retrograde")):
            cases += [
                (f"circular equatorial {sense} ({zs})", [7000.0, z, z], [z, sgn * vc, z]),
                (f"parabola equatorial {sense} ({zs})", [7000.0, z, z], [z, sgn * vp, z]),
                (f"ellipse equatorial {sense} ({zs})", [-5000.0, 3000.0, z],
                 [-sgn * 3.0, -sgn * 6.0, z]),
                (f"hyperbola equatorial {sense} ({zs})", [7000.0, z, z], [z, sgn * 12.0, z]),
                (f"circular polar {sense} ({zs})", [z, 7000.0, z], [z, z, sgn * vc]),
            ]
    return cases


def _skyfield_round_trip(rs, vs) -> float | str:
    """For the report: Skyfield's own state -> elements -> state error on the same states."""
    try:
        from skyfield.elementslib import OsculatingElements
        from skyfield.keplerlib import ele_to_vec
        from skyfield.units import Distance, Velocity
    except ImportError:  # pragma: no cover
        return "skyfield not installed"
    worst = 0.0
    for r, v in zip(rs, vs, strict=True):
        r, v = np.array(r), np.array(v)
        try:
            el = OsculatingElements(Distance(km=r), Velocity(km_per_s=v), None, MU)
            R, V = ele_to_vec(el.semi_latus_rectum.km, el.eccentricity, el.inclination.radians,
                              el.longitude_of_ascending_node.radians,
                              el.argument_of_periapsis.radians, el.true_anomaly.radians, MU)
            err = max(np.linalg.norm(R - r) / np.linalg.norm(r),
                      np.linalg.norm(V - v) / np.linalg.norm(v))
        except Exception:  # noqa: BLE001 - report any failure as an infinite error
            err = math.inf
        worst = max(worst, float(err) if np.isfinite(err) else math.inf)
    return worst


def _round_trips() -> list[Check]:
    from astropy import units as u

    import visviva as vv
    from visviva.core.elements import coe_to_rv_array, empty_states

    gm = MU * u.km**3 / u.s**2
    out = []
    labels, rs, vs = zip(*_degenerate_matrix(), strict=True)
    s = vv.StateVectors(np.array(rs) * u.km, np.array(vs) * u.km / u.s, gm)
    for name, conv in [
        ("state -> Keplerian -> state", lambda s: s.to_elements().to_state()),
        ("state -> equinoctial (I=+1 or -1) -> state", None),
    ]:
        if conv is None:
            # the I = +1 set is singular at i = pi: use I = -1 for retrograde states
            retro = s.specific_angular_momentum.value[:, 2] < 0
            b1 = s[~retro].to_equinoctial().to_state()
            b2 = s[retro].to_equinoctial(retrograde=True).to_state()
            r_back = np.empty_like(s.r.value)
            v_back = np.empty_like(s.v.value)
            r_back[~retro], v_back[~retro] = b1.r.value, b1.v.value
            r_back[retro], v_back[retro] = b2.r.value, b2.v.value
        else:
            back = conv(s)
            r_back, v_back = back.r.value, back.v.value
        er = np.linalg.norm(r_back - s.r.value, axis=-1) / s.radius.value
        ev = np.linalg.norm(v_back - s.v.value, axis=-1) / s.speed.value
        worst = int(np.argmax(np.maximum(er, ev)))
        details = {"cases": list(labels), "worst": labels[worst]}
        if conv is not None:
            details["skyfield_round_trip_max_rel_error"] = _skyfield_round_trip(rs, vs)
        out.append(Check(f"degenerate matrix: {name}", "max relative |dr|, |dv|",
                         float(max(er.max(), ev.max())), REL_ROUND_TRIP,
                         "exact: the input state", details))

    # near-degenerate sweep: e and i close to the singular values, each orbit around its conic
    ecc = np.array([0.0, 1e-15, 1e-12, 1e-8, 0.5, 1 - 1e-10, 1.0, 1 + 1e-10, 3.0, 10.0])
    inc = np.array([0.0, 1e-12, 0.5 * math.pi, math.pi - 1e-12, math.pi])
    nu = np.linspace(-3.0, 3.0, 13)
    E, I, N = (x.ravel() for x in np.meshgrid(ecc, inc, nu, indexing="ij"))
    keep = 1 + E * np.cos(N) >= 1e-3  # where (p, e, nu) is well conditioned (docs/elements.md)
    E, I, N = E[keep], I[keep], N[keep]
    n = E.size
    r, v, status = states = empty_states(n)
    coe_to_rv_array(np.full(n, 9000.0), E, I, np.full(n, 0.7), np.full(n, 1.3), N,
                    np.full(n, MU), *states)
    s = vv.StateVectors(r * u.km, v * u.km / u.s, gm)
    back = s.to_elements().to_state()
    er = np.linalg.norm(back.r.value - r, axis=-1) / np.linalg.norm(r, axis=-1)
    ev = np.linalg.norm(back.v.value - v, axis=-1) / np.linalg.norm(v, axis=-1)
    out.append(Check("regime sweep (e 0..10, i 0..pi incl. 1e-12 off): state round trip",
                     "max relative |dr|, |dv|", float(max(er.max(), ev.max())), REL_ROUND_TRIP,
                     "exact: the input state", {"n_orbits": int(n)}))
    return out


def _vallado() -> Check:
    from astropy import units as u

    import visviva as vv

    path = Path(__file__).resolve().parents[3] / "tests" / "data" / "textbook_examples.json"
    if not path.exists():
        return Check("Vallado Example 2-5 (full precision)", "max relative difference",
                     math.nan, 1e-8, "Vallado (2013) Example 2-5",
                     {"skipped": "tests/data/textbook_examples.json not found"})
    ex = json.loads(path.read_text())["vallado_ex2_5_rv_to_elements"]
    s = vv.StateVectors(ex["inputs"]["r"] * u.km, ex["inputs"]["v"] * u.km / u.s,
                        ex["mu"] * u.km**3 / u.s**2)
    el = s.to_elements()
    c = ex["computed"]
    rel = max(abs(el.semi_latus_rectum.value / c["p"] - 1), abs(el.eccentricity / c["e"] - 1),
              abs(el.semi_major_axis.value / c["a"] - 1))
    ang = max(abs(el.inclination.to_value(u.deg) - c["i"]),
              abs(el.longitude_of_ascending_node.to_value(u.deg) - c["raan"]),
              abs(el.argument_of_periapsis.to_value(u.deg) - c["argp"]),
              abs(el.true_anomaly.to_value(u.deg) - c["nu"]))
    # the computed values are printed to 1e-7 deg and 10-11 digits: compare in units of tolerance
    measured = max(rel / ex["tol_computed"]["rel"], ang / ex["tol_computed"]["angles"])
    return Check("Vallado Example 2-5 (full-precision values)",
                 "max difference / tolerance (1e-8 rel, 1e-6 deg)", float(measured), 1.0,
                 ex["source"], {"rel": float(rel), "deg": float(ang)})


def checks(full: bool = False) -> list[Check]:
    """Run the element checks (about 2 s after compilation; ``full`` uses 10^5 states)."""
    out = []
    try:
        out += _vs_skyfield(100_000 if full else 10_000)
    except ImportError as exc:  # pragma: no cover - skyfield is in the reference extra
        out.append(Check("elements vs skyfield", "max difference", math.nan, REL_SKYFIELD,
                         "skyfield", {"skipped": f"skyfield not installed ({exc})"}))
    out += _round_trips()
    out.append(_vallado())
    return out
