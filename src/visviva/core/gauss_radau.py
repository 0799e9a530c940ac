"""The Gauss-Radau constants of IAS15 (:mod:`visviva.core.nbody_ias15`): spacings and the maps
between the ``g`` and ``b`` coefficients of the acceleration's expansion (Everhart 1985).

The kernels read them as compile-time constants, and numba's cache checks only the stamp of the
defining file: after editing this module, touch :mod:`visviva.core.nbody_ias15`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["H", "CB", "BG", "RINV"]

#: Gauss-Radau spacings on [0, 1] (h0 = 0 and the 7 roots; Everhart 1985, table 1).
H = np.array(
    [
        0.0,
        0.0562625605369221464656521910318,
        0.180240691736892364987579942780,
        0.352624717113169637373907769648,
        0.547153626330555383001448554766,
        0.734210177215410531523210605558,
        0.885320946839095768090359771030,
        0.977520613561287501891174488626,
    ]
)


def _g_to_b():
    """CB[n, k]: coefficient of h**(k+1) in prod_{i<n} (h - H_i), n = 1..7 (row 0 unused)."""
    cb = np.zeros((8, 7))
    for n in range(1, 8):
        poly = np.array([1.0])  # ascending powers
        for i in range(n):
            poly = np.convolve(poly, np.array([-H[i], 1.0]))
        cb[n, : n] = poly[1 : n + 1]
    return cb


#: b_k = sum_n g_n CB[n, k]
CB = _g_to_b()
#: g_n = sum_k b_k BG[k, n]  (inverse of the triangular map above)
BG = np.zeros((7, 8))
BG[:, 1:] = np.linalg.inv(CB[1:, :])
#: divided-difference denominators 1 / (H_n - H_k)
RINV = np.zeros((8, 8))
for _n in range(8):
    for _k in range(_n):
        RINV[_n, _k] = 1.0 / (H[_n] - H[_k])
