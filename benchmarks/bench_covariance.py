"""Covariance propagation through the full force model, timed side by side.

Rows (ratio = visviva time / reference time; below 1 visviva is faster):

* ``propagate_covariance, LEO day, full forces``: :func:`visviva.propagate_covariance`
  (J4, exponential drag, Sun, Moon, SRP with a conical shadow; 25 outputs over a day) vs the
  same run of :func:`visviva.propagate_cowell` without a covariance: the price of the 36
  extra components and the analytic partials. Target: ratio <= 6.
* ``... vs central differences``: the same against the obvious alternative, an STM from
  central differences of ``propagate_cowell`` (12 displaced states in its parallel batch mode,
  plus the nominal). Target: ratio <= 1.
* ``propagate_covariance, LEO day, two-body``: the same call with ``[]`` vs
  :func:`visviva.conjunctions.propagate_covariance` (two-body, fixed-step RK4) at the 25
  outputs. No target (the two-body tool has no force model).
* ``propagate_covariance, LEO day, degree-40 field``: a full spherical-harmonic field of degree
  and order 40 (coefficients drawn at random with a Kaula-like fall-off, written to a temporary
  ``.gfc``) vs the same run of ``propagate_cowell``: the price of the field's analytic Hessian
  at every stage. No target.

Run: ``python -m benchmarks --only covariance`` or ``python -m benchmarks.bench_covariance``.
"""

from __future__ import annotations

import numpy as np

try:  # as part of the package (python -m benchmarks) or as a script
    from .common import interleaved_medians, quick_from_env, result
except ImportError:  # pragma: no cover
    from common import interleaved_medians, quick_from_env, result


def _case():
    from astropy import units as u
    from astropy.time import Time

    import visviva as vv

    epoch = Time("2024-03-01T00:00:00", scale="utc")
    state = vv.KeplerianElements.from_semi_major_axis(
        7000 * u.km, 0.001, 51.6 * u.deg, 0.3, 0.2, 0.1, vv.EARTH, epoch=epoch).to_state()
    am = 0.05 * u.m**2 / u.kg
    forces = [vv.Zonal(vv.EARTH, 4), vv.AtmosphericDrag(am), vv.ThirdBody(vv.SUN),
              vv.ThirdBody(vv.MOON), vv.SolarRadiationPressure(am, 1.3, shadow="conical")]
    P0 = np.diag([1e-3] * 3 + [1e-9] * 3)
    return state, forces, P0


def _field_40(directory):
    """A degree-40 ICGEM field with random fully normalised coefficients (~1e-6 / n^2)."""
    import os

    from visviva._text import replace_text_file
    from visviva.satellites.perturbations import SphericalHarmonics

    rng = np.random.default_rng(1)
    lines = ["product_type gravity_field", "modelname random_degree_40",
             "earth_gravity_constant 3.986004415E+14", "radius 6378136.3", "max_degree 40",
             "norm fully_normalized", "tide_system tide_free", "key n m C S sigmaC sigmaS",
             "end_of_head", "gfc 0 0 1.0 0.0 0 0", "gfc 2 0 -4.84165e-4 0 0 0"]
    for n in range(2, 41):
        for m in range(n + 1):
            if (n, m) != (2, 0):
                c = rng.normal() * 1e-6 / n**2
                s = 0.0 if m == 0 else rng.normal() * 1e-6 / n**2
                lines.append(f"gfc {n} {m} {c:.15e} {s:.15e} 0 0")
    path = os.path.join(directory, "random40.gfc")
    replace_text_file(path, "\n".join(lines) + "\n")
    return [SphericalHarmonics(path, 40)]


def run(quick: bool = False) -> list[dict]:
    import time

    from astropy import units as u

    import visviva as vv
    from visviva.conjunctions import propagate_covariance as two_body

    quick = quick or quick_from_env()
    rounds = 3 if quick else 7
    state, forces, P0 = _case()
    t = np.linspace(0.0, 1.0, 25) * u.day
    t0 = time.perf_counter()
    vv.propagate_covariance(state, P0, t, forces)
    first = time.perf_counter() - t0
    vv.propagate_cowell(state, t, forces)

    def ours():
        return vv.propagate_covariance(state, P0, t, forces)

    def plain():
        return vv.propagate_cowell(state, t, forces)

    y = np.r_[state.r.to_value(u.km), state.v.to_value(u.km / u.s)]
    d = np.r_[[1e-3] * 3, [1e-6] * 3]
    y0 = np.concatenate([y[None], y + np.diag(d), y - np.diag(d)])
    batch = vv.StateVectors(y0[:, :3] * u.km, y0[:, 3:] * u.km / u.s, vv.EARTH,
                            epoch=state.epoch)

    def differences():
        res = vv.propagate_cowell(batch, t, forces)
        yt = np.concatenate([res.r.to_value(u.km), res.v.to_value(u.km / u.s)], axis=-1)
        phi = np.transpose((yt[1:7] - yt[7:]) / (2 * d[:, None, None]), (1, 2, 0))
        return phi @ P0 @ np.swapaxes(phi, -1, -2)

    differences()
    a, b = interleaved_medians(ours, plain, rounds)
    rows = [result("propagate_covariance, LEO day, full forces (25 outputs)", a,
                   "propagate_cowell, same run without covariance", b, target=6.0,
                   compile_s=first, notes="J4, drag, Sun, Moon, SRP conical; rtol 1e-12")]
    a, c = interleaved_medians(ours, differences, rounds)
    rows.append(result("propagate_covariance vs a central-difference STM, LEO day", a,
                       "propagate_cowell batch of 13 states (central differences)", c,
                       target=1.0, notes="same forces and outputs; batch on all threads"))
    dt = t.to_value(u.s)

    def ours_kepler():
        return vv.propagate_covariance(state, P0, t, [])

    def reference_kepler():
        return [two_body(P0, state.r, state.v, s * u.s, vv.EARTH) for s in dt]

    a, k = interleaved_medians(ours_kepler, reference_kepler, rounds)
    rows.append(result("propagate_covariance, LEO day, two-body (25 outputs)", a,
                       "conjunctions.propagate_covariance (two-body RK4), 25 calls", k,
                       notes="agree to 3e-10 relative after a day"))
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        field = _field_40(tmp)
        vv.propagate_covariance(state, P0, t, field)
        vv.propagate_cowell(state, t, field)
        a, g = interleaved_medians(lambda: vv.propagate_covariance(state, P0, t, field),
                                   lambda: vv.propagate_cowell(state, t, field), rounds)
    rows.append(result("propagate_covariance, LEO day, degree-40 field (25 outputs)", a,
                       "propagate_cowell, same run without covariance", g,
                       notes="random coefficients; the field's Hessian at every stage"))
    return rows


if __name__ == "__main__":  # pragma: no cover
    import sys

    for row in run(quick="--quick" in sys.argv):
        print(row)
