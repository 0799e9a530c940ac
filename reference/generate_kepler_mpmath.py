"""Reference solutions of Kepler's equation in every regime, computed with mpmath at 60 digits.

For float64 inputs (M, e) taken exactly, the file holds the correctly rounded float64 values of

- elliptic (0 <= e < 1): E with E - e sin E = M, and the true anomaly nu (same revolution as E);
- hyperbolic (e > 1): F with e sinh F - F = M, and nu;
- parabolic (e = 1): D with D + D^3/3 = M (Barker), and nu = 2 atan D;

plus the condition number dnu/dM, which bounds how much an error of one rounding in M moves nu.
Regimes include e -> 1 from both sides, tiny and huge |M| and e = 0.

Run ``python reference/generate_kepler_mpmath.py`` to rewrite
``reference/data/kepler_mpmath.json``.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _provenance  # noqa: E402

NAME = "kepler_mpmath.json"
DPS = 60

ELLIPTIC_E = (0.0, 1e-8, 0.1, 0.5, 0.9, 0.99, 0.999999, 1.0 - 2.0**-40)
ELLIPTIC_M = (-20.0, -3.141592653589793, -1.0, -1e-3, 0.0, 1e-12, 1e-6, 1e-3, 0.1, 0.5, 1.0,
              2.0, 3.0, 3.141592653589793, 3.1415, 5.0, 1000.0)
HYPERBOLIC_E = (1.0 + 2.0**-40, 1.000001, 1.01, 1.5, 3.0, 10.0, 100.0)
HYPERBOLIC_M = (-1e4, -10.0, -1.0, -1e-4, 0.0, 1e-10, 1e-6, 1e-3, 0.1, 1.0, 10.0, 1e3, 1e6)
PARABOLIC_M = (-1e6, -100.0, -1.0, -1e-6, 0.0, 1e-12, 1e-3, 0.5, 1.0, 10.0, 1e4, 1e9)


def _solve(f, lo, hi):
    """Root of an increasing function f in [lo, hi] by bisection to the working precision."""
    import mpmath as mp

    flo = f(lo)
    if flo == 0:
        return lo
    for _ in range(4 * mp.mp.prec):
        mid = (lo + hi) / 2
        if mid == lo or mid == hi:
            break
        fm = f(mid)
        if fm == 0:
            return mid
        if (fm > 0) == (flo > 0):
            lo, flo = mid, fm
        else:
            hi = mid
    return (lo + hi) / 2


def _elliptic(M, e):
    import mpmath as mp

    Mm, em = mp.mpf(M), mp.mpf(e)
    E = _solve(lambda x: x - em * mp.sin(x) - Mm, Mm - em - 1, Mm + em + 1) if e > 0 else Mm
    # nu on the same revolution as E
    k = mp.floor((E + mp.pi) / (2 * mp.pi))
    Er = E - 2 * mp.pi * k
    nu = 2 * mp.atan(mp.sqrt((1 + em) / (1 - em)) * mp.tan(Er / 2)) + 2 * mp.pi * k
    # dnu/dM = (1 + e cos nu)^2 / (1 - e^2)^(3/2)
    cond = (1 + em * mp.cos(nu)) ** 2 / (1 - em**2) ** mp.mpf(1.5)
    return E, nu, cond


def _hyperbolic(M, e):
    import mpmath as mp

    Mm, em = mp.mpf(M), mp.mpf(e)
    if M == 0:
        F = mp.mpf(0)
    else:
        s = 1 if M > 0 else -1
        lo = mp.asinh(abs(Mm) / em)
        hi = mp.asinh(abs(Mm) / (em - 1)) + 1
        F = s * _solve(lambda x: em * mp.sinh(x) - x - abs(Mm), lo, hi)
    nu = 2 * mp.atan(mp.sqrt((em + 1) / (em - 1)) * mp.tanh(F / 2))
    cond = (1 + em * mp.cos(nu)) ** 2 / (em**2 - 1) ** mp.mpf(1.5)
    return F, nu, cond


def _parabolic(M):
    import mpmath as mp

    Mm = mp.mpf(M)
    # D + D^3/3 = M has one real root (Cardano)
    w = mp.cbrt(3 * Mm / 2 + mp.sqrt(1 + (3 * Mm / 2) ** 2))
    D = w - 1 / w
    D = _solve(lambda x: x + x**3 / 3 - Mm, D - abs(D) / 8 - 1, D + abs(D) / 8 + 1)
    nu = 2 * mp.atan(D)
    cond = (1 + mp.cos(nu)) ** 2 / 2  # dnu/dM with M = D + D^3/3
    return D, nu, cond


def generate() -> dict:
    """Build the whole data set (no file written)."""
    import mpmath as mp

    mp.mp.dps = DPS
    cases = []
    for e in ELLIPTIC_E:
        for M in ELLIPTIC_M:
            E, nu, cond = _elliptic(M, e)
            cases.append({"regime": "elliptic", "M": M, "ecc": e, "anomaly": float(E),
                          "nu": float(nu), "dnu_dM": float(cond)})
    for e in HYPERBOLIC_E:
        for M in HYPERBOLIC_M:
            F, nu, cond = _hyperbolic(M, e)
            cases.append({"regime": "hyperbolic", "M": M, "ecc": e, "anomaly": float(F),
                          "nu": float(nu), "dnu_dM": float(cond)})
    for M in PARABOLIC_M:
        D, nu, cond = _parabolic(M)
        cases.append({"regime": "parabolic", "M": M, "ecc": 1.0, "anomaly": float(D),
                      "nu": float(nu), "dnu_dM": float(cond)})
    settings = {"mpmath_dps": DPS, "root_finder": "bisection on a bracket to the working precision (4 x 200 bits)",
                "conventions": {"elliptic": "M = E - e sin E", "hyperbolic": "M = e sinh F - F",
                                "parabolic": "M = D + D^3/3, D = tan(nu/2)"},
                "rounding": "inputs are float64 values taken exactly; outputs rounded to float64"}
    return _provenance.document(
        __file__, ("mpmath",), settings,
        "Kepler's equation solved to 60 digits for elliptic, near-parabolic, parabolic and "
        "hyperbolic orbits: eccentric/hyperbolic/parabolic anomaly, true anomaly and dnu/dM.",
        {"M": "rad", "anomaly": "rad (E, F or D = tan(nu/2))", "nu": "rad", "dnu_dM": "1"}, cases)


if __name__ == "__main__":
    _provenance.main(NAME, generate)
