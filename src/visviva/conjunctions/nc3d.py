"""Hall's (2021) 3D-Nc collision probability: the expected number of collisions of a conjunction.

The method of NASA CARA's ``Pc3D_Hall``: both objects follow two-body motion from their states
at TCA; each object's state uncertainty is a Gaussian in equinoctial elements at TCA (the
Cartesian covariance mapped by the Jacobian at the mean), carried to every time ``t`` by
linearising the two-body map about the state that puts it at the *peak overlap position* of the
two position densities (found by iteration). The collision rate is the flux of the relative
position into the hard-body sphere, integrated over the sphere, and the probability its integral
over time (Hall, "Expected Collision Rates for Tracked Satellites", JSR 58 (2021) 715).

Everything here is in metres and seconds; the arrays carry a leading axis of time points. The
work per time point (the peak-overlap linearisation and the sphere rule) is done by the numba
kernels of :mod:`visviva.core.nc3d`.
"""

from __future__ import annotations

import functools
import math
import warnings

import numpy as np

from ..core.nc3d import (
    POP_OK,
    POP_SINGULAR,
    log_rates,
    mean_separations,
    pop_linearise,
    state_jacobian,
)
from ..errors import ConvergenceError, InvalidInputError, Pc3dWindowWarning

__all__ = ["log_pc3d_hall"]


# --- equinoctial elements (Broucke & Cefola 1972): n, af=k, ag=h, p, q, mean longitude --------

def _frame(p, q):
    s2 = 1.0 + p * p + q * q
    f = np.stack([1.0 - p * p + q * q, 2.0 * p * q, -2.0 * p], axis=-1) / s2[..., None]
    g = np.stack([2.0 * p * q, 1.0 + p * p - q * q, 2.0 * q], axis=-1) / s2[..., None]
    return f, g


def state_to_elements(x, gm):
    """Equinoctial elements ``(n, k, h, p, q, lam)`` of one prograde Cartesian state (m, m/s);
    the inverse of the state map of :func:`visviva.core.nc3d.state_jacobian`."""
    r, v = x[:3], x[3:]
    hv = np.cross(r, v)
    w = hv / np.linalg.norm(hv)
    if w[2] <= -1.0 + 1e-12:
        raise InvalidInputError("retrograde equatorial orbit: rotate the frame first.")
    p = w[0] / (1.0 + w[2])
    q = -w[1] / (1.0 + w[2])
    f, g = _frame(np.array(p), np.array(q))
    rn = float(np.linalg.norm(r))
    ecc = np.cross(v, hv) / gm - r / rn
    k, h = float(ecc @ f), float(ecc @ g)
    energy = 0.5 * float(v @ v) - gm / rn
    if not energy < 0:
        raise InvalidInputError("the 3D-Nc method needs bound (elliptic) orbits; "
                                f"an object has specific energy {energy:g} J/kg >= 0.")
    a = -gm / (2.0 * energy)
    n = math.sqrt(gm / a**3)
    x1, y1 = float(r @ f), float(r @ g)
    beta = 1.0 / (1.0 + math.sqrt(1.0 - h * h - k * k))
    root = a * math.sqrt(1.0 - h * h - k * k)
    cf = k + ((1.0 - k * k * beta) * x1 - h * k * beta * y1) / root
    sf = h + ((1.0 - h * h * beta) * y1 - h * k * beta * x1) / root
    big_f = math.atan2(sf, cf)
    lam = big_f + h * math.cos(big_f) - k * math.sin(big_f)
    return np.array([n, k, h, p, q, lam])


def _tca_jacobian(e0, gm):
    """``dX/dE`` (6, 6) at TCA of the equinoctial elements ``e0`` (analytic, in the kernel)."""
    x = np.empty(6)
    jac = np.empty((6, 6))
    state_jacobian(e0, 0.0, gm, x, jac)
    return jac


# --- the collision rate: flux into the hard-body sphere ----------------------------------------

#: sigmas kept on either side of the density's centre by the adapted sphere rule
_K_SIGMA = 9.0
_N_U = 40  # Gauss-Legendre nodes across the band in u = cos(theta)
_N_PHI = 40  # Gauss-Legendre nodes along each half ring


@functools.cache
def _legendre(n):
    x, w = np.polynomial.legendre.leggauss(n)
    return np.ascontiguousarray(np.stack([x, w]))


def _relative(t, el, gm):
    """Relative mode state and 6x6 covariance at the times ``t``, linearised about the peak
    overlap position (Hall 2021, section III), and which time points converged.

    Far from the encounter the two densities do not overlap and the iteration can leave the
    elliptic domain (e >= 1, a NaN state) or make a position covariance singular; such a time
    point keeps the linearisation about the mean elements ``E0`` and is reported as not
    converged (the caller refuses the result only where the collision rate matters).
    """
    xu = np.empty((t.size, 2, 6))
    p = np.empty((t.size, 2, 6, 6))
    status = np.empty(t.size, dtype=np.int64)
    pop_linearise(np.ascontiguousarray(t, dtype=float), *el, gm, xu, p, status)
    if np.any(status == POP_SINGULAR):
        raise ConvergenceError(
            "the 3D-Nc method found a singular position covariance at the mean elements; "
            "check the covariances (positive definite, in m^2, m^2/s, m^2/s^2) or use "
            "method='foster'.")
    return xu[:, 1, :3] - xu[:, 0, :3], xu[:, 1, 3:] - xu[:, 0, 3:], p[:, 0] + p[:, 1], \
        status == POP_OK


def _rates(t, el, hbr, clip, gm, n_u=_N_U, n_phi=_N_PHI):
    """ln collision rate at the times ``t`` and which time points' linearisation converged.

    The sphere rule (:func:`visviva.core.nc3d.log_rates`) works in the eigenframe of the
    relative position covariance (axes a, b, c, sigmas increasing), where the density is a
    product of three 1-D Gaussians. The pole is the minor axis a: the rule covers the band
    ``u = x_a / R`` within ``_K_SIGMA`` sigmas of the centre and, on each ring of the band, the
    arcs (one per half ring ``x_c >= 0`` and ``x_c <= 0``) where ``x_b`` is within ``_K_SIGMA``
    sigmas; Gauss-Legendre in ``u`` and in ``phi`` on each. Outside, the density is below
    ``exp(-_K_SIGMA^2 / 2)`` of its peak. Whatever the sigmas are relative to the HBR (thin
    slabs and needles included) the nodes sit where the integrand is.
    """
    ru, vu, ps, ok = _relative(t, el, gm)
    w, vecs = np.linalg.eigh(ps[:, :3, :3])
    out = np.empty(t.size)
    log_rates(ru, vu, ps, np.maximum(w, clip), vecs, hbr, _K_SIGMA, _legendre(n_u),
              _legendre(n_phi), out)
    return out, ok


def _support(t, lr, floor):
    """Intervals of the sorted grid ``t`` where the ln rate ``lr`` is above ``floor`` (padded by
    one cell on either side)."""
    keep = lr > floor
    cells = keep[:-1] | keep[1:]
    cells = cells | np.r_[cells[1:], False] | np.r_[False, cells[:-1]]
    out = []
    i = 0
    while i < cells.size:
        if cells[i]:
            j = i
            while j + 1 < cells.size and cells[j + 1]:
                j += 1
            out.append((t[i], t[j + 1]))
            i = j + 1
        else:
            i += 1
    return out


def _encounter(t, lr, tc, margin=60.0):
    """The stretch of the sorted grid ``t`` holding the encounter at ``tc``: uphill from the grid
    point nearest ``tc`` to the rate's local peak, then out on both sides while the rate stays
    within ``e^-margin`` of that peak (one more cell each side). Returns ``(t_lo, t_hi, peak)``
    (``peak``: the local ln rate; -inf when the rate is nil there)."""
    i = int(np.argmin(np.abs(t - tc)))
    while True:
        j = i
        if i + 1 < t.size and lr[i + 1] > lr[j]:
            j = i + 1
        if i > 0 and lr[i - 1] > lr[j]:
            j = i - 1
        if j == i:
            break
        i = j
    peak = float(lr[i])
    lo = hi = i
    while lo > 0 and lr[lo - 1] > peak - margin:
        lo -= 1
    while hi < t.size - 1 and lr[hi + 1] > peak - margin:
        hi += 1
    return float(t[max(lo - 1, 0)]), float(t[min(hi + 1, t.size - 1)]), peak


# --- the default window: the conjunction segment about TCA ---------------------------------------

_SEG_POINTS = 257  # scan of the mean separation over +-half the shorter period
_SEG_ZOOM = 4  # rounds of a 65-point scan about each separation maximum (to ~1e-7 of the scan)
#: a separation maximum must stand this far (m) above the separations between it and TCA; a
#: separation flatter than that (orbits flown in formation) bounds nothing
_SEG_PROMINENCE = 1e-3
#: the rate at an end of the default window within e^-_CUT of its peak: the encounter is cut
_CUT = 12.0


def _separation(t, e1, e2, gm):
    out = np.empty(t.size)
    mean_separations(np.ascontiguousarray(t, dtype=float), e1, e2, gm, out)
    return np.sqrt(out)


def _segment(e1, e2, gm, tc, half):
    """The conjunction segment about TCA: from the last maximum of the distance between the two
    mean (two-body) positions before TCA to the first one after it (Hall 2021's conjunction
    segment; CARA's ``Pc3D_Hall`` bounds its default search the same way), within ``+-half``
    (half the shorter period: nearly equal orbits meet again half an orbit later, another
    conjunction). A side with no maximum (or only maxima within ``_SEG_PROMINENCE`` of the
    separations between them and TCA) is bounded by ``half``. ``tc``: the linear closest
    approach (s), which the segment holds too. Returns ``(t_a, t_b)`` in s from TCA."""
    tc = min(max(tc, -half), half)
    t = np.linspace(-half, half, _SEG_POINTS)
    d = _separation(t, e1, e2, gm)
    ia = int(np.searchsorted(t, min(0.0, tc)))
    ib = int(np.searchsorted(t, max(0.0, tc)))
    peaks = np.flatnonzero((d[1:-1] >= d[:-2]) & (d[1:-1] > d[2:])) + 1

    def bound(candidates, inner):
        for i in candidates:
            j0, j1 = sorted((i, inner))
            if d[i] - float(np.min(d[j0:j1 + 1])) > _SEG_PROMINENCE:
                lo, hi = t[i - 1], t[i + 1]
                for _ in range(_SEG_ZOOM):
                    tz = np.linspace(lo, hi, 65)
                    k = int(np.argmax(_separation(tz, e1, e2, gm)))
                    lo, hi = tz[max(k - 1, 0)], tz[min(k + 1, 64)]
                return 0.5 * (lo + hi)
        return None

    ta = bound(peaks[t[peaks] < min(0.0, tc)][::-1], ia)
    tb = bound(peaks[t[peaks] > max(0.0, tc)], ib)
    return -half if ta is None else ta, half if tb is None else tb


def _conjunction(t, lr, tc, margin=60.0):
    """The stretches of the grid ``t`` (the conjunction segment) that count by default: the
    encounter at TCA (:func:`_encounter`) and every other stretch where the rate is within
    ``e^-margin`` of that encounter's peak and which lies inside the segment (one that reaches an
    end belongs to the neighbouring conjunction). Returns ``(edges, peak, cut)``: the intervals,
    the largest ln rate in them, and the end (s) where the encounter at TCA is cut (its rate
    still within ``e^-_CUT`` of the peak there), else None; ``edges`` is None when the rate is
    nil about TCA."""
    lo, hi, local = _encounter(t, lr, tc, margin)
    if not np.isfinite(local):
        return None, local, None
    edges = [iv for iv in _support(t, lr, local - margin)
             if (iv[1] >= lo and iv[0] <= hi) or (iv[0] > t[0] and iv[1] < t[-1])]
    inside = np.zeros(t.size, dtype=bool)
    for a, b in edges:
        inside |= (t >= a) & (t <= b)
    peak = float(np.max(lr[inside]))
    cut = None
    if lo <= t[0] and lr[0] > peak - _CUT:
        cut = float(t[0])
    elif hi >= t[-1] and lr[-1] > peak - _CUT:
        cut = float(t[-1])
    return edges, peak, cut


_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)


def _adaptive(edges, log_rate, rtol):
    """ln of the time integral of ``exp(log_rate)`` over panels, adaptively (Gauss-Legendre on
    each panel against the sum over its halves; all active panels evaluated together)."""
    a = np.array([e[0] for e in edges])
    b = np.array([e[1] for e in edges])

    def panel(lo, hi):
        t = (0.5 * (lo + hi))[:, None] + (0.5 * (hi - lo))[:, None] * _GL_X
        lr, conv = log_rate(t.ravel())
        lr = lr.reshape(t.shape)
        failed.append(float(np.max(lr.ravel()[~conv], initial=-np.inf)))
        return lr + np.log(0.5 * (hi - lo))[:, None] + np.log(_GL_W)

    failed = []
    whole = panel(a, b)
    ref = float(np.max(whole))
    if not np.isfinite(ref):
        return -math.inf, max(failed)
    val = np.sum(np.exp(whole - ref), axis=1)
    done = []
    total = float(np.sum(val))
    for _ in range(60):
        mid = 0.5 * (a + b)
        left = panel(a, mid)
        right = panel(mid, b)
        lv = np.sum(np.exp(left - ref), axis=1)
        rv = np.sum(np.exp(right - ref), axis=1)
        err = np.abs(lv + rv - val)
        total = float(np.sum(done)) + float(np.sum(lv + rv))
        width = float(np.sum(b - a))
        good = err <= rtol * total * np.maximum((b - a) / width, 1e-3)
        done.extend((lv + rv)[good])
        bad = ~good
        if not np.any(bad):
            return ref + math.log(float(np.sum(done))), max(failed)
        a = np.concatenate([a[bad], mid[bad]])
        b = np.concatenate([mid[bad], b[bad]])
        val = np.concatenate([lv[bad], rv[bad]])
    raise ConvergenceError("the 3D-Nc time integral did not converge; report this case.")


def _orient(states, covs):
    """Rotate the frame so that neither orbit is retrograde (equinoctial elements are singular
    at i = 180 deg); the probability does not depend on the frame."""
    h = [np.cross(s[:3], s[3:]) for s in states]
    h = [x / np.linalg.norm(x) for x in h]
    z = h[0] + h[1]
    if np.linalg.norm(z) < 0.5:
        z = np.cross(h[0], np.eye(3)[int(np.argmin(np.abs(h[0])))])
    z = z / np.linalg.norm(z)
    x = np.cross(np.eye(3)[int(np.argmin(np.abs(z)))], z)
    x /= np.linalg.norm(x)
    rot = np.stack([x, np.cross(z, x), z])
    big = np.zeros((6, 6))
    big[:3, :3] = rot
    big[3:, 3:] = rot
    return [big @ s for s in states], [big @ c @ big.T for c in covs]


def log_pc3d_hall(r1, v1, c1, r2, v2, c2, hbr, gm, window=None, rtol=1e-6):
    """ln Pc by Hall's 3D-Nc method (inputs in m, m/s, m^2...; ``gm`` in m^3/s^2).

    ``window``: ``(ta, tb)`` in s relative to TCA bounding the time integral (every encounter
    in it counts), or ``None``: this conjunction, i.e. the conjunction segment about TCA
    (:func:`_segment`: between the maxima of the mean separation bracketing TCA, within half the
    shorter orbital period) and in it the encounter at TCA and every other encounter that lies
    wholly inside (:func:`_conjunction`). Where the encounter at TCA does not end within the
    segment (orbits flown in formation: the rate barely changes over an orbit, so the expected
    number of collisions grows with the time span) a :class:`~visviva.errors.Pc3dWindowWarning`
    says so and names ``window=``. Returns ``ln Pc``.
    """
    if hbr == 0:
        return -math.inf
    if math.isinf(hbr):
        return 0.0
    (x1, x2), (k1, k2) = _orient([np.concatenate([r1, v1]), np.concatenate([r2, v2])],
                                 [c1, c2])
    el = []
    periods = []
    for x, c in ((x1, k1), (x2, k2)):
        e0 = state_to_elements(x, gm)
        kinv = np.linalg.inv(_tca_jacobian(e0, gm))
        q = kinv @ c @ kinv.T
        el += [e0, 0.5 * (q + q.T)]
        periods.append(2.0 * math.pi / e0[0])
    clip = (1e-4 * hbr) ** 2
    # the linear-motion closest approach and its time scale (short for fast encounters)
    rel = x2 - x1
    arel = k1[:3, :3] + k2[:3, :3]
    vel = rel[3:]
    tc = 0.0
    st = None
    if float(np.linalg.norm(vel)) > 0:
        ainv = np.linalg.inv(arel + clip * np.eye(3))
        curv = float(vel @ ainv @ vel)
        tc = -float(vel @ ainv @ rel[:3]) / curv
        st = 1.0 / math.sqrt(curv) + hbr / float(np.linalg.norm(vel))
    if window is None:
        ta, tb = _segment(el[0], el[2], gm, tc, 0.5 * min(periods))
    else:
        ta, tb = float(window[0]), float(window[1])
        if not tb > ta:
            raise InvalidInputError(f"window must be (ta, tb) with ta < tb, got {window}.")
    # where the rate lives: a coarse scan of the window on a uniform grid and, around the
    # linear-motion closest approach, on its time scale
    grid = [np.linspace(ta, tb, 2049)]
    if st is not None:
        grid.append(np.clip(tc + st * np.linspace(-40.0, 40.0, 513), ta, tb))
    t = np.unique(np.concatenate(grid))
    lr, conv = _rates(t, el, hbr, clip, gm, 16, 16)
    peak = float(np.max(lr))
    if not np.isfinite(peak):
        return -math.inf
    edges = None
    cut = None
    if window is None:  # this conjunction, not the neighbouring ones
        found, local, cut = _conjunction(t, lr, tc)
        if found is not None:
            peak, edges = local, found
            inside = np.zeros(t.size, dtype=bool)
            for a, b in edges:
                inside |= (t >= a) & (t <= b)
            conv = conv | ~inside
    if np.any(~conv & (lr > peak - 30.0)):
        _pop_failed()

    def log_rate(tt):
        return _rates(tt, el, hbr, clip, gm)

    lp, worst = _adaptive(edges or _support(t, lr, peak - 60.0), log_rate, rtol)
    if worst > peak - 30.0:
        _pop_failed()
    if cut is not None:
        _warn_cut(cut, float(lr[0] if cut == t[0] else lr[-1]) - peak, ta, tb, lp)
    return lp


def _warn_cut(cut, drop, ta, tb, lp):
    warnings.warn(
        f"method='pc3d_hall': the collision rate at {cut:.6g} s from TCA, an end of the default "
        f"window ({ta:.6g}, {tb:.6g}) s (the conjunction segment: between the separation maxima "
        f"about TCA, at most half the shorter orbital period either side), is still "
        f"{math.exp(drop):.2g} of its peak: the encounter does not end there (orbits flown in "
        "formation or a slow drift), so the expected number of collisions grows with the time "
        f"span and Pc = {math.exp(lp):.4g} holds for this window only. Pass window=(t_a, t_b) "
        "(s from TCA) for the span you mean (CARA's Pc3D_Hall: Tmin_limit, Tmax_limit).",
        Pc3dWindowWarning, stacklevel=5)


def _pop_failed():
    raise ConvergenceError(
        "the peak overlap position of the 3D-Nc method did not converge at a time where the "
        "collision rate matters (CARA's Pc3D_Hall returns NaN here); use method='foster' or "
        "'monte_carlo', or report this case.")
