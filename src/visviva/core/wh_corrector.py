"""The coefficients of WHFast's symplectic correctors (used by :mod:`visviva.core.nbody_whfast`).

A corrector of order k removes the O(eps h^k) terms of the Wisdom-Holman map's error by
conjugation with m pairs of drift-kick-drift maps (Wisdom, Holman & Touma 1996; Rein & Tamayo
2015); the drift fractions and kick weights are computed here once, at import.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["CORRECTOR_PAIRS", "CORRECTOR_A", "CORRECTOR_B", "corrector_table"]

#: Bernoulli numbers B_2 .. B_12.
_BERNOULLI = (1.0 / 6.0, -1.0 / 30.0, 1.0 / 42.0, -1.0 / 30.0, 5.0 / 66.0, -691.0 / 2730.0)


def corrector_table(m):
    """Drift fractions a_j = j/m and kick weights b_j of an m-pair symplectic corrector.

    To first order in the interaction, the drift-kick-drift map differs from the exact flow by
    the factor ``x / sin x`` (``x = omega h / 2``) on each Fourier mode of the interaction along
    the Kepler flow; the conjugating corrector ``C`` has the generator
    ``chi_k = (h / 2i) (1/sin x - 1/x)``. A pair of kicks ``b h`` at Kepler phases ``+-a h``
    contributes ``2 i h b sin(2 a x)``, so the weights solve
    ``sum_j b_j sin(2 a_j x) = -(1/4) (1/sin x - 1/x)`` order by order in ``x`` (the first m odd
    powers), with ``1/sin x - 1/x = sum_n (-1)^(n+1) 2 (2^(2n-1) - 1) B_2n x^(2n-1) / (2n)!``.
    The first equation, ``2 sum a_j b_j = -1/24``, is Wisdom, Holman & Touma's (1996) condition.
    """
    a = np.array([(j + 1) / m for j in range(m)])
    A = np.zeros((m, m))
    rhs = np.zeros(m)
    for n in range(m):
        k = n + 1
        coeff = (-1.0) ** (k + 1) * 2.0 * (2.0 ** (2 * k - 1) - 1.0) * _BERNOULLI[k - 1]
        rhs[n] = -0.25 * coeff / math.factorial(2 * k)
        for j in range(m):
            A[n, j] = (-1.0) ** n * (2.0 * a[j]) ** (2 * n + 1) / math.factorial(2 * n + 1)
    return a, np.linalg.solve(A, rhs)


#: Supported corrector orders -> number of kick pairs (orders of the removed O(eps h^k) terms).
CORRECTOR_PAIRS = {3: 1, 5: 2, 7: 3}
#: Rows: corrector order; columns: a_j (drift fractions) and b_j (kick weights), zero-padded.
CORRECTOR_A = np.zeros((8, 3))
CORRECTOR_B = np.zeros((8, 3))
for _order, _m in CORRECTOR_PAIRS.items():
    _a, _b = corrector_table(_m)
    CORRECTOR_A[_order, :_m] = _a
    CORRECTOR_B[_order, :_m] = _b
