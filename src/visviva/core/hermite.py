"""The cubic Hermite basis, one copy for every kernel that interpolates tabulated states.

On a segment [t_k, t_k + h] with s = (t - t_k) / h in [0, 1], values p0, p1 and derivatives
(with respect to t) m0, m1 at its ends,

    x(s) = h00(s) p0 + h h10(s) m0 + h01(s) p1 + h h11(s) m1,

h00 = 2 s^3 - 3 s^2 + 1, h10 = s^3 - 2 s^2 + s, h01 = -2 s^3 + 3 s^2, h11 = s^3 - s^2
(e.g. Burden & Faires, *Numerical Analysis*, sec. 3.4). Users: the ephemeris tables of the
Cowell force model (:func:`visviva.core.perturbations.hermite_position`), the pass search
(:mod:`visviva.core.topocentric`) and the conjunction screen (:mod:`visviva.core.screening`).
"""

from __future__ import annotations

from ._jit import inline_kernel

__all__ = ["hermite_basis", "hermite_basis_rate"]


@inline_kernel
def hermite_basis(s):
    """(h00, h10, h01, h11) at s (dimensionless, in [0, 1] on the segment)."""
    s2 = s * s
    s3 = s2 * s
    return (2.0 * s3 - 3.0 * s2 + 1.0, s3 - 2.0 * s2 + s, -2.0 * s3 + 3.0 * s2, s3 - s2)


@inline_kernel
def hermite_basis_rate(s):
    """d/ds of (h00, h10, h01, h11) at s: divide the first and third by h for d/dt."""
    s2 = s * s
    return (6.0 * s2 - 6.0 * s, 3.0 * s2 - 4.0 * s + 1.0, -6.0 * s2 + 6.0 * s, 3.0 * s2 - 2.0 * s)
