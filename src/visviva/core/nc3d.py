"""Kernels of Hall's (2021) 3D-Nc collision probability (NASA CARA's ``Pc3D_Hall``).

The conjunction layer (:mod:`visviva.conjunctions.nc3d`) finds where the collision rate lives and
integrates it over time; these kernels do the work per time point, in metres and seconds:

* :func:`pop_linearise`: for each time ``t`` from TCA, the two-body state and its Jacobian with
  respect to the equinoctial elements at TCA (analytic, forward mode; it agrees with complex-step
  derivatives to 1e-14), iterated to the *peak overlap position* of the two position densities
  (Hall 2021, sec. III; a fixed-point iteration, accelerated by an Anderson step of depth one).
  A time point whose iteration leaves the elliptic domain or makes a position covariance
  singular keeps the linearisation about the mean elements and is flagged.
* :func:`mean_separations`: the squared distance between the two objects' mean (two-body)
  positions at each time, which bounds the conjunction segment.
* :func:`log_rates`: ln of the collision rate at each time point, the flux of the relative
  position into the hard-body sphere integrated over the sphere by a product Gauss-Legendre rule
  adapted to the position density (the caller passes the covariance's eigen-decomposition).

Reference: D. Hall, "Expected Collision Rates for Tracked Satellites", JSR 58 (2021) 715;
equinoctial elements: Broucke & Cefola, Celest. Mech. 5 (1972) 303.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import inline_kernel, kernel

__all__ = ["pop_linearise", "log_rates", "mean_separations", "state_jacobian", "POP_OK",
           "POP_FAILED", "POP_SINGULAR"]

#: status per time point: converged; kept about the mean (left the domain, or did not converge);
#: the position covariance at the mean elements is singular (the caller refuses the case)
POP_OK, POP_FAILED, POP_SINGULAR = 0, 1, 2
_ITERATE, _CONVERGED, _ABOUT_MEAN = 0, 1, 2  # what the next pass of the iteration does

_POP_ITERATIONS = 60
_POP_TOL = 1e-4  # change of the expansion centre, in sigmas of each element
_LOG_2PI = math.log(2.0 * math.pi)
_SQRT_2PI = math.sqrt(2.0 * math.pi)
_SQRT1_2 = math.sqrt(0.5)
#: a sphere node whose term is surely below e^-40 of the largest is skipped (all of them together
#: change the rate by < 3e-14 relative)
_NEGLIGIBLE = 40.0


@inline_kernel
def _kepler_real(lam, h, k):
    """Eccentric longitude F of ``lam = F + h cos F - k sin F`` (Newton from F = lam)."""
    f = lam
    for _ in range(50):
        c, s = math.cos(f), math.sin(f)
        step = (f + h * c - k * s - lam) / (1.0 - h * s - k * c)
        f = f - step
        if not abs(step) >= 1e-15:  # NaN stops too
            break
    return f


@kernel
def state_jacobian(es, t, gm, x, jac):
    """State ``x`` (6,) at ``t`` of the elements ``es`` at TCA and ``jac`` = dx/des (6, 6).

    ``es = (n, k, h, p, q, lam)``; the mean longitude at ``t`` is ``L = lam + n t``. The
    Jacobian is the chain rule of the map (forward mode, one tangent per element): ``a`` from
    ``n``; the eccentric longitude from ``L = F + h cos F - k sin F``, so
    ``dF = (dL - cos F dh + sin F dk) / D`` with ``D = 1 - h sin F - k cos F``; the in-plane
    position and velocity; the frame vectors ``f``, ``g`` from ``p``, ``q``.
    """
    n, k, h, p, q = es[0], es[1], es[2], es[3], es[4]
    big_l = es[5] + n * t
    big_f = _kepler_real(big_l, h, k)
    c, s = math.cos(big_f), math.sin(big_f)
    a = (gm / (n * n)) ** (1.0 / 3.0)
    root = math.sqrt(1.0 - h * h - k * k)
    beta = 1.0 / (1.0 + root)
    d = 1.0 - k * c - h * s
    fac = n * a / d
    ca = (1.0 - h * h * beta) * c + h * k * beta * s - k  # x1 / a
    cb = (1.0 - k * k * beta) * s + h * k * beta * c - h  # y1 / a
    cc = h * k * beta * c - (1.0 - h * h * beta) * s  # xd / fac
    ce = (1.0 - k * k * beta) * c - h * k * beta * s  # yd / fac
    x1, y1, xd, yd = a * ca, a * cb, fac * cc, fac * ce
    s2 = 1.0 + p * p + q * q
    f = ((1.0 - p * p + q * q) / s2, 2.0 * p * q / s2, -2.0 * p / s2)
    g = (2.0 * p * q / s2, (1.0 + p * p - q * q) / s2, 2.0 * q / s2)
    for i in range(3):
        x[i] = x1 * f[i] + y1 * g[i]
        x[3 + i] = xd * f[i] + yd * g[i]
    # the in-plane elements n, k, h, lam: tangents of a, F, beta and the four coordinates
    for col in (0, 1, 2, 5):
        dn = 1.0 if col == 0 else 0.0
        dk = 1.0 if col == 1 else 0.0
        dh = 1.0 if col == 2 else 0.0
        dl = t if col == 0 else (1.0 if col == 5 else 0.0)
        da = -2.0 * a / (3.0 * n) * dn
        dfl = (dl - c * dh + s * dk) / d
        dc, ds = -s * dfl, c * dfl
        db = beta * beta * (h * dh + k * dk) / root
        dhkb = k * beta * dh + h * beta * dk + h * k * db  # d(h k beta)
        dhhb = 2.0 * h * beta * dh + h * h * db  # d(h^2 beta)
        dkkb = 2.0 * k * beta * dk + k * k * db  # d(k^2 beta)
        hkb = h * k * beta
        dca = -dhhb * c + (1.0 - h * h * beta) * dc + dhkb * s + hkb * ds - dk
        dcb = -dkkb * s + (1.0 - k * k * beta) * ds + dhkb * c + hkb * dc - dh
        dcc = dhkb * c + hkb * dc + dhhb * s - (1.0 - h * h * beta) * ds
        dce = -dkkb * c + (1.0 - k * k * beta) * dc - dhkb * s - hkb * ds
        dd = -dk * c - k * dc - dh * s - h * ds
        dfac = fac * (dn / n + da / a - dd / d)
        dx1, dy1 = da * ca + a * dca, da * cb + a * dcb
        dxd, dyd = dfac * cc + fac * dcc, dfac * ce + fac * dce
        for i in range(3):
            jac[i, col] = dx1 * f[i] + dy1 * g[i]
            jac[3 + i, col] = dxd * f[i] + dyd * g[i]
    # the orientation p, q: d(f, g)/dp and d(f, g)/dq
    dfp = (-2.0 * p, 2.0 * q, -2.0)  # d(s2 f)/dp; d(s2 f)/dq = d(s2 g)/dp = (2q, 2p, 0)
    dpq = (2.0 * q, 2.0 * p, 0.0)
    dgq = (2.0 * p, -2.0 * q, 2.0)  # d(s2 g)/dq
    for i in range(3):
        fp, fq = (dfp[i] - 2.0 * p * f[i]) / s2, (dpq[i] - 2.0 * q * f[i]) / s2
        gp, gq = (dpq[i] - 2.0 * p * g[i]) / s2, (dgq[i] - 2.0 * q * g[i]) / s2
        jac[i, 3] = x1 * fp + y1 * gp
        jac[3 + i, 3] = xd * fp + yd * gp
        jac[i, 4] = x1 * fq + y1 * gq
        jac[3 + i, 4] = xd * fq + yd * gq


@kernel
def _cholesky3(a, low):
    """Lower Cholesky factor of the leading 3x3 block of the symmetric ``a`` into ``low``; False
    unless finite and positive definite."""
    for i in range(3):
        for j in range(i + 1):
            s = a[i, j]
            for m in range(j):
                s -= low[i, m] * low[j, m]
            if i == j:
                if not s > 0.0:
                    return False
                low[i, i] = math.sqrt(s)
            else:
                low[i, j] = s / low[j, j]
                if not math.isfinite(low[i, j]):
                    return False
    return True


@kernel
def _cho_solve3(low, b, out):
    """``out = A^-1 b`` from the Cholesky factor of A (``out`` may be ``b``)."""
    y0 = b[0] / low[0, 0]
    y1 = (b[1] - low[1, 0] * y0) / low[1, 1]
    y2 = (b[2] - low[2, 0] * y0 - low[2, 1] * y1) / low[2, 2]
    out[2] = y2 / low[2, 2]
    out[1] = (y1 - low[2, 1] * out[2]) / low[1, 1]
    out[0] = (y0 - low[1, 0] * out[1] - low[2, 0] * out[2]) / low[0, 0]


@kernel
def _linearise(es, e0, q, t, gm, xu, p, jac, x):
    """Mean ``xu`` (6,) and covariance ``p`` (6, 6) of the state at ``t`` linearised about the
    centre ``es`` (``jac``, ``x``: work arrays); False unless finite with a positive-definite
    position block."""
    state_jacobian(es, t, gm, x, jac)
    for i in range(6):
        s = x[i]
        for j in range(6):
            s += jac[i, j] * (e0[j] - es[j])
        xu[i] = s
    for i in range(6):
        for m in range(6):
            s = 0.0
            for r in range(6):
                s += jac[i, r] * q[r, m]
            x[m] = s  # row i of J Q (x is free again)
        for j in range(6):
            s = 0.0
            for m in range(6):
                s += x[m] * jac[j, m]
            p[i, j] = s
    for i in range(6):
        if not math.isfinite(xu[i]):
            return False
        for j in range(6):
            if not math.isfinite(p[i, j]):
                return False
    return _cholesky3(p, np.empty((3, 3)))


@inline_kernel
def _copy_rows(src, dst):
    for j in range(2):
        for m in range(6):
            dst[j, m] = src[j, m]


@kernel
def _pop_point(t, e1, q1, e2, q2, gm, cen, xu, p):
    """Peak-overlap linearisation of both objects at one time ``t``, iterated from the centres
    ``cen`` (2, 6) (overwritten); ``xu`` (2, 6), ``p`` (2, 6, 6) receive it. Returns a
    ``POP_*`` status: a point whose iteration leaves the elliptic domain, meets a singular
    covariance or does not converge is linearised about the mean elements instead
    (``POP_FAILED``; ``POP_SINGULAR`` where a position covariance is singular even there).

    One call site of :func:`_linearise` serves the iteration, the converged centres and the
    mean (numba compiles the callee tree into each call site: one keeps the compile short).
    """
    e0 = np.empty((2, 6))
    qs = np.empty((2, 6, 6))
    for m in range(6):  # element loops: an array assignment costs seconds of compile
        e0[0, m] = e1[m]
        e0[1, m] = e2[m]
        for i in range(6):
            qs[0, m, i] = q1[m, i]
            qs[1, m, i] = q2[m, i]
    jacs = np.empty((2, 6, 6))
    x = np.empty(6)
    low = np.empty((2, 3, 3))
    lsum = np.empty((3, 3))
    isum = np.empty((3, 3))
    rhs = np.empty(3)
    col = np.empty(3)
    d = np.empty(3)
    new = np.empty((2, 6))
    g = np.empty(6)
    res = np.empty((2, 6))  # the last residual (sigmas) and fixed-point image
    prev = np.empty((2, 6))
    have_prev = False
    last_moved = math.inf
    mode = _ITERATE
    iterations = 0
    while True:
        good = True
        for j in range(2):
            good &= _linearise(cen[j], e0[j], qs[j], t, gm, xu[j], p[j], jacs[j], x)
        if mode == _ABOUT_MEAN:
            return POP_FAILED if good else POP_SINGULAR
        if mode == _CONVERGED and good:
            return POP_OK
        mode = _ABOUT_MEAN  # unless this pass moves the centres on
        if not good or iterations == _POP_ITERATIONS:
            _copy_rows(e0, cen)
            continue
        iterations += 1
        # r* = (A1^-1 + A2^-1)^-1 (A1^-1 xu1 + A2^-1 xu2)
        for m in range(3):
            rhs[m] = 0.0
            for i in range(3):
                isum[m, i] = 0.0
        for j in range(2):
            _cholesky3(p[j], low[j])
            for m in range(3):
                for i in range(3):
                    col[i] = 1.0 if i == m else 0.0
                _cho_solve3(low[j], col, col)  # column m of A_j^-1
                for i in range(3):
                    isum[i, m] += col[i]
                    rhs[i] += col[i] * xu[j, m]
        if not _cholesky3(isum, lsum):
            _copy_rows(e0, cen)
            continue
        _cho_solve3(lsum, rhs, rhs)
        moved = 0.0
        usable = True
        for j in range(2):
            for i in range(3):
                d[i] = rhs[i] - xu[j, i]
            _cho_solve3(low[j], d, d)
            # the most probable elements whose linearised position is r*: E0 + Q Jr^T A^-1 (r* - xu)
            for i in range(6):
                g[i] = jacs[j, 0, i] * d[0] + jacs[j, 1, i] * d[1] + jacs[j, 2, i] * d[2]
            for m in range(6):
                s = 0.0
                for i in range(6):
                    s += qs[j, m, i] * g[i]
                new[j, m] = e0[j, m] + s
                moved = max(moved, abs(new[j, m] - cen[j, m]) / math.sqrt(qs[j, m, m]))
            usable &= new[j, 0] > 0.0 and new[j, 1] * new[j, 1] + new[j, 2] * new[j, 2] < 1.0
        if not usable:  # NaN lands here too
            _copy_rows(e0, cen)
            continue
        if moved < _POP_TOL:  # the next pass linearises about the converged centres
            _copy_rows(new, cen)
            mode = _CONVERGED
            continue
        mode = _ITERATE
        # the map converges linearly (slowly far from TCA): an Anderson step of depth one (a
        # secant step on the residual new - cen, in sigmas) where the residual shrinks
        num = 0.0
        den = 0.0
        for j in range(2):
            for m in range(6):
                r_now = (new[j, m] - cen[j, m]) / math.sqrt(qs[j, m, m])
                dr = r_now - res[j, m]
                num += r_now * dr
                den += dr * dr
                res[j, m] = r_now
        accelerate = have_prev and moved < last_moved and den > 0.0
        last_moved = moved
        have_prev = True
        for j in range(2):
            for m in range(6):
                step = new[j, m]
                if accelerate:
                    step -= num / den * (new[j, m] - prev[j, m])
                prev[j, m] = new[j, m]
                cen[j, m] = step
        for j in range(2):
            if not (cen[j, 0] > 0.0 and cen[j, 1] ** 2 + cen[j, 2] ** 2 < 1.0):
                _copy_rows(prev, cen)  # the secant step left the domain: the plain step


@kernel
def pop_linearise(t, e1, q1, e2, q2, gm, xu, p, status):
    """Peak-overlap linearisations at the times ``t`` (N,) (s from TCA).

    ``e1``, ``e2``: equinoctial elements (6,) at TCA (rad/s, -, -, -, -, rad); ``q1``, ``q2``:
    their covariances (6, 6); ``gm`` in m^3/s^2. Fills ``xu`` (N, 2, 6) (m, m/s), ``p``
    (N, 2, 6, 6) and ``status`` (N,) with a ``POP_*`` code. Every point's iteration starts from
    the mean elements (a start from a neighbouring point's centres can follow another branch of
    the peak overlap, a revolution away, along a whole grid).
    """
    cen = np.empty((2, 6))
    for i in range(t.size):
        for m in range(6):
            cen[0, m] = e1[m]
            cen[1, m] = e2[m]
        status[i] = _pop_point(t[i], e1, q1, e2, q2, gm, cen, xu[i], p[i])


@kernel
def mean_separations(t, e1, e2, gm, out):
    """Squared distance (m^2) between the mean positions of the elements ``e1`` and ``e2`` at TCA
    (equinoctial, as in :func:`state_jacobian`), carried by two-body motion to the times ``t``
    (N,) (s from TCA), into ``out`` (N,)."""
    x1 = np.empty(6)
    x2 = np.empty(6)
    jac = np.empty((6, 6))
    for i in range(t.size):
        state_jacobian(e1, t[i], gm, x1, jac)
        state_jacobian(e2, t[i], gm, x2, jac)
        out[i] = (x2[0] - x1[0]) ** 2 + (x2[1] - x1[1]) ** 2 + (x2[2] - x1[2]) ** 2


@kernel
def log_rates(ru, vu, ps, w, vecs, hbr, k_sigma, gu, gp, out):
    r"""ln of the collision rate (1/s) at each time point, ``R^2 \oint N(R n) E[(-n.v)^+ | R n]``.

    ``ru``, ``vu``: relative mode position and velocity (N, 3) (m, m/s); ``ps``: relative
    covariance (N, 6, 6); ``w``, ``vecs``: eigenvalues (clipped, m^2) and eigenvectors of its
    position block (N, 3) and (N, 3, 3); ``hbr`` (m); ``k_sigma``: sigmas kept either side of
    the density's centre; ``gu``, ``gp``: Gauss-Legendre nodes (row 0) and weights (row 1) in
    ``u = cos(theta)`` and along each half ring. The velocity is the conditional Gaussian given
    the position (Hall 2021 eq. 36 ff.).
    """
    n_u = gu.shape[1]
    n_p = gp.shape[1]
    for i in range(ru.shape[0]):
        out[i] = _log_rate_point(ru[i], vu[i], ps[i], w[i], vecs[i], hbr, k_sigma, gu, gp,
                                 n_u, n_p)


@inline_kernel
def _log_node(l0, l1, l2, vecs, ru, vu, ainv, bs, cp, hbr, log_bound, cut):
    """ln of ``exp(-md2 / 2) E[(-n.v)^+ | R n]`` at the sphere point of direction ``(l0, l1, l2)``
    in the eigenframe ``vecs``; ``md2`` is the squared Mahalanobis distance from ``ru``.

    ``-inf`` where a receding node (``z = mu / sd < 0``) is surely below ``cut``: there
    ``E[w+] = sd (phi(z) + z Phi(z)) <= sd phi(z) <= exp(log_bound - z^2 / 2)``, ``log_bound``
    bounding ``ln(|mu| + sd)`` over the sphere.
    """
    n0 = vecs[0, 0] * l0 + vecs[0, 1] * l1 + vecs[0, 2] * l2
    n1 = vecs[1, 0] * l0 + vecs[1, 1] * l1 + vecs[1, 2] * l2
    n2 = vecs[2, 0] * l0 + vecs[2, 1] * l1 + vecs[2, 2] * l2
    d0, d1, d2 = hbr * n0 - ru[0], hbr * n1 - ru[1], hbr * n2 - ru[2]
    md2 = (d0 * (ainv[0, 0] * d0 + ainv[0, 1] * d1 + ainv[0, 2] * d2)
           + d1 * (ainv[1, 0] * d0 + ainv[1, 1] * d1 + ainv[1, 2] * d2)
           + d2 * (ainv[2, 0] * d0 + ainv[2, 1] * d1 + ainv[2, 2] * d2))
    # the velocity given the position: mean vu + B A^-1 d, covariance cp; w = -n.v
    mu = -(n0 * (vu[0] + bs[0, 0] * d0 + bs[0, 1] * d1 + bs[0, 2] * d2)
           + n1 * (vu[1] + bs[1, 0] * d0 + bs[1, 1] * d1 + bs[1, 2] * d2)
           + n2 * (vu[2] + bs[2, 0] * d0 + bs[2, 1] * d1 + bs[2, 2] * d2))
    var = (n0 * (cp[0, 0] * n0 + cp[0, 1] * n1 + cp[0, 2] * n2)
           + n1 * (cp[1, 0] * n0 + cp[1, 1] * n1 + cp[1, 2] * n2)
           + n2 * (cp[2, 0] * n0 + cp[2, 1] * n1 + cp[2, 2] * n2))
    sd = math.sqrt(max(var, 0.0))
    # E[w+] for w ~ N(mu, sd^2): mu Phi(mu/sd) + sd phi(mu/sd); far tail sd phi(z)/z^2
    if sd > 0:
        z = mu / sd
        if z < 0.0 and log_bound - 0.5 * (z * z + md2) < cut:
            return -math.inf
        if z < -30.0:
            log_e = math.log(sd) - 0.5 * z * z - 0.5 * _LOG_2PI - 2.0 * math.log(-z)
        else:
            ez = (mu * 0.5 * math.erfc(-z * _SQRT1_2)
                  + sd * math.exp(-0.5 * z * z) / _SQRT_2PI)
            log_e = math.log(max(ez, 1e-320))
    else:
        log_e = math.log(max(mu, 1e-320))
    return log_e - 0.5 * md2


@kernel
def _log_rate_point(ru, vu, ps, w, vecs, hbr, k_sigma, gu, gp, n_u, n_p):
    ainv = np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            s = 0.0
            for m in range(3):
                s += vecs[a, m] * vecs[b, m] / w[m]
            ainv[a, b] = s
    logdet = math.log(w[0]) + math.log(w[1]) + math.log(w[2])
    bs = np.empty((3, 3))  # B A^-1, B = cov(v, r)
    for a in range(3):
        for b in range(3):
            bs[a, b] = (ps[3 + a, 0] * ainv[0, b] + ps[3 + a, 1] * ainv[1, b]
                        + ps[3 + a, 2] * ainv[2, b])
    cp = np.empty((3, 3))  # C - B A^-1 B^T: the velocity covariance given the position
    for a in range(3):
        for b in range(3):
            cp[a, b] = ps[3 + a, 3 + b] - (bs[a, 0] * ps[3 + b, 0] + bs[a, 1] * ps[3 + b, 1]
                                           + bs[a, 2] * ps[3 + b, 2])
    m_e = np.empty(3)  # the centre in the eigenframe
    for a in range(3):
        m_e[a] = vecs[0, a] * ru[0] + vecs[1, a] * ru[1] + vecs[2, a] * ru[2]
    sig0, sig1 = math.sqrt(w[0]), math.sqrt(w[1])
    u_lo = min(max((m_e[0] - k_sigma * sig0) / hbr, -1.0), 1.0)
    u_hi = min(max((m_e[0] + k_sigma * sig0) / hbr, -1.0), 1.0)
    half = 0.5 * (u_hi - u_lo)
    mid = 0.5 * (u_hi + u_lo)
    const = -0.5 * logdet - 1.5 * _LOG_2PI
    # |mu| + sd <= |vu| + |B A^-1|_F (R + |ru|) + sqrt(sum |cp_ij|) for every unit n
    vnorm = math.sqrt(vu[0] ** 2 + vu[1] ** 2 + vu[2] ** 2)
    rnorm = math.sqrt(ru[0] ** 2 + ru[1] ** 2 + ru[2] ** 2)
    bnorm = 0.0
    cabs = 0.0
    for a in range(3):
        for b in range(3):
            bnorm += bs[a, b] ** 2
            cabs += abs(cp[a, b])
    log_bound = math.log(max(vnorm + math.sqrt(bnorm) * (hbr + rnorm) + math.sqrt(cabs), 1e-300))
    top = -math.inf
    total = 0.0
    for iu in range(n_u):
        u = mid + half * gu[0, iu]
        wu = half * gu[1, iu]
        st = math.sqrt(max(1.0 - u * u, 0.0))
        ring = hbr * st
        if ring > 0:
            c_hi = (m_e[1] + k_sigma * sig1) / ring
            c_lo = (m_e[1] - k_sigma * sig1) / ring
        else:
            c_hi, c_lo = 1.0, -1.0
        p_lo = math.acos(min(max(c_hi, -1.0), 1.0))
        p_hi = math.acos(min(max(c_lo, -1.0), 1.0))
        ph = 0.5 * (p_hi - p_lo)
        pm = 0.5 * (p_hi + p_lo)
        for jp in range(n_p):
            weight = wu * ph * gp[1, jp]
            if not weight > 0:
                continue
            log_w = const + math.log(weight)
            angle = pm + ph * gp[0, jp]
            cphi, sphi = st * math.cos(angle), st * math.sin(angle)
            for half_ring in range(2):  # x_c >= 0 and x_c <= 0
                sign = 1.0 - 2.0 * half_ring
                term = log_w + _log_node(u, cphi, sign * sphi, vecs, ru, vu, ainv, bs, cp, hbr,
                                         log_bound, top - _NEGLIGIBLE - log_w)
                # running log-sum-exp
                if term > top:
                    total = total * math.exp(top - term) + 1.0 if top > -math.inf else 1.0
                    top = term
                elif term > -math.inf:
                    total += math.exp(term - top)
    if top == -math.inf:
        return -math.inf
    return top + math.log(total) + 2.0 * math.log(hbr)
