"""Kepler's equation and the anomalies: residuals, agreement with kepler.py, mpmath, textbooks.

Each check runs live: random inputs are drawn (seeded), visviva solves them in one kernel call,
and the result is compared with the equation itself, with the independent C++ solver of the
kepler.py package (Foreman-Mackey; Raposo-Pulido & Pelaez 2017, Brandt et al. 2021), with
mpmath at 50 digits in the near-parabolic corner, and with Vallado's worked examples.
"""

from __future__ import annotations

import math

import numpy as np

from .base import Check

__all__ = ["checks"]

EPS = float(np.finfo(float).eps)


def _version(dist: str) -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return f"{dist} {version(dist)}"
    except PackageNotFoundError:
        return f"{dist} (not installed)"


def _elliptic_sample(n: int, rng):
    """Uniform M in [-pi, pi] and e in [0, 1), plus quarters with large |M|, e -> 1, tiny M."""
    M = rng.uniform(-np.pi, np.pi, n)
    M[: n // 4] = rng.uniform(-1e4, 1e4, n // 4)
    M[n // 4 : n // 2] *= 10.0 ** rng.uniform(-12, 0, n // 4)
    ecc = rng.uniform(0.0, 1.0, n)
    ecc[n // 2 : 3 * n // 4] = 1.0 - 10.0 ** rng.uniform(-16, -1, n // 4)
    return M, ecc


def _check_elliptic_residual(n: int, rng) -> Check:
    import visviva as vv

    M, ecc = _elliptic_sample(n, rng)
    E = vv.solve_kepler(M, ecc)
    rel = np.abs(E - ecc * np.sin(E) - M) / np.maximum(1.0, np.abs(M))
    return Check(
        f"kepler elliptic: residual over {n:.0e} random (M, e)",
        "max |E - e sin E - M| / max(1, |M|)",
        float(rel.max()),
        2e-15,
        "Kepler's equation itself",
        {"n": n, "median": float(np.median(rel)), "p99.9": float(np.quantile(rel, 0.999)),
         "sample": "uniform M in [-pi, pi], e in [0,1); quarters with |M| <= 1e4, "
                   "M * 10^U(-12,0), 1 - e = 10^U(-16,-1)"},
    )  # fmt: skip


def _check_against_kepler_py(n: int, rng) -> Check:
    import visviva as vv

    try:
        import kepler
    except ImportError as exc:
        return Check("kepler elliptic vs kepler.py", "max |dE| (rad)", math.nan, 1e-12,
                     "kepler.py", {"skipped": f"kepler.py not installed ({exc})"})  # fmt: skip
    M = rng.uniform(0.0, 2.0 * np.pi, n)
    ecc = rng.uniform(0.0, 1.0, n)
    E = vv.solve_kepler(M, ecc)
    E_ref = kepler.solve(M, ecc)
    diff = np.abs(E - E_ref)
    res_ref = np.abs(E_ref - ecc * np.sin(E_ref) - M)
    return Check(
        f"kepler elliptic vs kepler.py: E over {n:.0e} random (M, e)",
        "max |E_visviva - E_kepler.py| (rad)",
        float(diff.max()),
        1e-12,
        _version("kepler.py") + " kepler.solve",
        {"n": n, "median |dE|": float(np.median(diff)),
         "kepler.py max residual": float(res_ref.max()),
         "why": "two independent algorithms (Markley 1995 vs Raposo-Pulido & Pelaez 2017)"},
    )  # fmt: skip


def _check_hyperbolic_residual(n: int, rng) -> Check:
    import visviva as vv

    M = rng.uniform(-60.0, 60.0, n)
    M[: n // 4] = np.sign(M[: n // 4]) * 10.0 ** rng.uniform(-300, 300, n // 4)
    M[n // 4 : n // 2] *= 10.0 ** rng.uniform(-12, 0, n // 4)
    ecc = 1.0 + 10.0 ** rng.uniform(-15, 1, n)
    F = vv.solve_kepler_hyperbolic(M, ecc)
    with np.errstate(over="ignore", invalid="ignore"):
        slope = np.abs(ecc * np.cosh(F) - 1.0)
        res = np.abs(ecc * np.sinh(F) - F - M)
        # the scale: max(1, |M|), plus what one rounding of F itself moves the residual by
        scaled = res / (np.maximum(1.0, np.abs(M)) + np.abs(F) * slope)
    ok = np.isfinite(scaled)
    return Check(
        f"kepler hyperbolic: residual over {n:.0e} random (M, e)",
        "max |e sinh F - F - M| / (max(1, |M|) + |F| (e cosh F - 1))",
        float(scaled[ok].max()),
        2e-15,
        "the hyperbolic Kepler equation itself",
        {"n": n, "evaluated": int(ok.sum()), "median": float(np.median(scaled[ok]))},
    )


def _check_parabolic_residual(n: int, rng) -> Check:
    import visviva as vv

    M = np.sign(rng.uniform(-1, 1, n)) * 10.0 ** rng.uniform(-300, 300, n)
    D = vv.solve_barker(M)
    rel = np.abs(D * (1.0 + (D / 3.0) * D) - M) / np.abs(M)
    return Check(
        f"kepler parabolic (Barker): residual over {n:.0e} random M",
        "max |D + D^3/3 - M| / |M|",
        float(rel.max()),
        4 * EPS,
        "Barker's equation itself",
        {"n": n, "sample": "|M| = 10^U(-300, 300)"},
    )


def _check_near_parabolic_mpmath(n: int, rng) -> Check:
    from visviva.core import kepler as core

    try:
        import mpmath
    except ImportError as exc:
        return Check("kepler near-parabolic vs mpmath", "max relative error", math.nan, 4 * EPS,
                     "mpmath", {"skipped": str(exc)})  # fmt: skip
    mpmath.mp.dps = 50
    worst = 0.0
    for _ in range(n):
        d = 10.0 ** rng.uniform(-16, -2)
        M = 10.0 ** rng.uniform(-20, 0.5)
        for ecc, fn, g in (
            (1.0 - d, core.eccentric_anomaly, lambda x, e, M: x - e * mpmath.sin(x) - M),
            (1.0 + d, core.hyperbolic_anomaly, lambda x, e, M: e * mpmath.sinh(x) - x - M),
        ):
            x, status = fn(M, ecc)
            if status != 0:
                return Check("kepler near-parabolic vs mpmath", "max relative error", math.inf,
                             4 * EPS, "mpmath", {"failed at": (M, ecc, int(status))})  # fmt: skip
            e_mp = mpmath.mpf(ecc)
            ref = mpmath.findroot(lambda y, e_mp=e_mp, M=M, g=g: g(y, e_mp, M), mpmath.mpf(x))
            worst = max(worst, float(abs(mpmath.mpf(x) - ref) / abs(ref)))
    return Check(
        f"kepler near-parabolic (|1 - e| = 10^U(-16,-2)) vs mpmath, {2 * n} solves",
        "max relative error of E or F",
        worst,
        4 * EPS,
        _version("mpmath") + " findroot at 50 digits",
        {"why": "the regime where E - e sin E cancels (Farnocchia et al. 2013)"},
    )


def _check_round_trip_near_parabolic(n: int, rng) -> Check:
    import visviva as vv

    d = 10.0 ** rng.uniform(-15, -1, n)
    ecc = np.where(rng.uniform(size=n) < 0.5, 1.0 - d, 1.0 + d)
    ecc[: n // 10] = 1.0
    limit = np.where(ecc < 1, np.pi, np.arccos(-1.0 / np.maximum(ecc, 1.0)))
    nu = rng.uniform(-0.9, 0.9, n) * limit
    M = vv.true_to_mean(nu, ecc)
    nu2 = vv.mean_to_true(M, ecc)
    err = float(np.max(np.abs(nu2 - nu) / np.maximum(1.0, np.abs(nu))))
    return Check(
        f"anomalies: true -> mean -> true round trip, {n:.0e} near-parabolic",
        "max |nu' - nu| / max(1, |nu|)",
        err,
        1e-13,
        "identity",
        {"sample": "|1 - e| = 10^U(-15,-1) on both sides and e = 1; |nu| < 0.9 of the limit"},
    )


def _check_textbook() -> Check:
    import visviva as vv

    E_deg = math.degrees(float(vv.solve_kepler(math.radians(235.4), 0.4)))
    F = float(vv.solve_kepler_hyperbolic(math.radians(235.4), 2.4))
    err = max(math.radians(abs(E_deg - 220.512074767522)), abs(F - 1.601376144))
    return Check(
        "anomalies: Vallado examples 2-1 (E = 220.512074767522 deg) and 2-3 (H = 1.601376144)",
        "max |difference| from the published values (rad)",
        err,
        1e-8,  # Vallado's algorithms iterate to a tolerance of 1e-8
        "Vallado (2013), Fundamentals of Astrodynamics and Applications, 4th ed., Ex. 2-1, 2-3",
        {"E (deg)": E_deg, "H": F},
    )


def checks(full: bool = False) -> list[Check]:
    """Run the anomaly checks (about 5 s, plus compilation on a cold cache)."""
    rng = np.random.default_rng(20130101)
    n = 1_000_000
    return [
        _check_elliptic_residual(n, rng),
        _check_against_kepler_py(n, rng),
        _check_hyperbolic_residual(n if full else 200_000, rng),
        _check_parabolic_residual(n if full else 200_000, rng),
        _check_near_parabolic_mpmath(200 if full else 20, rng),
        _check_round_trip_near_parabolic(n if full else 100_000, rng),
        _check_textbook(),
    ]
