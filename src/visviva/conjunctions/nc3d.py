"""Hall's (2021) 3D-Nc collision probability: the expected number of collisions of a conjunction.

The method of NASA CARA's ``Pc3D_Hall``: both objects follow two-body motion from their states
at TCA; each object's state uncertainty is a Gaussian in equinoctial elements at TCA (the
Cartesian covariance mapped by the Jacobian at the mean), carried to every time ``t`` by
linearising the two-body map about the state that puts it at the *peak overlap position* of the
two position densities (found by iteration). The collision rate is the flux of the relative
position into the hard-body sphere, integrated over the sphere, and the probability its integral
over time (Hall, "Expected Collision Rates for Tracked Satellites", JSR 58 (2021) 715).

Everything here is in metres and seconds; the arrays carry a leading axis of time points.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ConvergenceError, InvalidInputError

__all__ = ["log_pc3d_hall"]

_STEP = 1e-30  # complex-step size: derivatives exact to rounding
_POP_ITERATIONS = 60
_POP_TOL = 1e-4  # change of the expansion centre, in sigmas of each element
_LOG_TINY = -745.0  # exp() of this is the smallest double


# --- equinoctial elements (Broucke & Cefola 1972): n, af=k, ag=h, p, q, mean longitude --------

def _kepler_f(lam, h, k):
    """Eccentric longitude F from ``lam = F + h cos F - k sin F`` (complex-step safe)."""
    f = lam.real.copy() if np.iscomplexobj(lam) else lam.copy()
    f = f + 0.0 * lam  # complex when lam is
    for _ in range(50):
        c, s = np.cos(f), np.sin(f)
        g = f + h * c - k * s - lam
        dg = 1.0 - h * s - k * c
        step = g / dg
        f = f - step
        if np.all(np.abs(step.real) < 1e-15):
            break
    # one more Newton step carries the complex part to full accuracy
    c, s = np.cos(f), np.sin(f)
    return f - (f + h * c - k * s - lam) / (1.0 - h * s - k * c)


def _frame(p, q):
    s2 = 1.0 + p * p + q * q
    f = np.stack([1.0 - p * p + q * q, 2.0 * p * q, -2.0 * p], axis=-1) / s2[..., None]
    g = np.stack([2.0 * p * q, 1.0 + p * p - q * q, 2.0 * q], axis=-1) / s2[..., None]
    return f, g


def elements_to_state(e, gm):
    """Cartesian states ``(..., 6)`` (m, m/s) of equinoctial elements ``(..., 6)``.

    ``e = (n, k, h, p, q, lam)``: mean motion (rad/s), ``k = e cos(w + W)``, ``h = e sin(w + W)``,
    ``p = tan(i/2) sin W``, ``q = tan(i/2) cos W``, mean longitude (rad). Works on complex input
    (for complex-step derivatives).
    """
    n, k, h, p, q, lam = (e[..., j] for j in range(6))
    a = (gm / (n * n)) ** (1.0 / 3.0)
    big_f = _kepler_f(lam, h, k)
    c, s = np.cos(big_f), np.sin(big_f)
    beta = 1.0 / (1.0 + np.sqrt(1.0 - h * h - k * k))
    x1 = a * ((1.0 - h * h * beta) * c + h * k * beta * s - k)
    y1 = a * ((1.0 - k * k * beta) * s + h * k * beta * c - h)
    rad = a * (1.0 - k * c - h * s)
    fac = n * a * a / rad
    xd = fac * (h * k * beta * c - (1.0 - h * h * beta) * s)
    yd = fac * ((1.0 - k * k * beta) * c - h * k * beta * s)
    f, g = _frame(p, q)
    r = x1[..., None] * f + y1[..., None] * g
    v = xd[..., None] * f + yd[..., None] * g
    return np.concatenate([r, v], axis=-1)


def state_to_elements(x, gm):
    """Equinoctial elements of one prograde Cartesian state (m, m/s); see elements_to_state."""
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


def _state_and_jacobian(e0, t, gm):
    """State at ``t`` (from TCA) of elements ``e0`` at TCA, and ``dX(t)/dE0`` by complex step.

    ``e0``: ``(N, 6)``, ``t``: ``(N,)``. Returns ``(N, 6)`` and ``(N, 6, 6)``.
    """
    pert = np.broadcast_to(e0[:, None, :], (e0.shape[0], 7, 6)).astype(np.complex128)
    idx = np.arange(6)
    pert[:, idx + 1, idx] += 1j * _STEP
    et = pert.copy()
    et[..., 5] = pert[..., 5] + pert[..., 0] * t[:, None]
    x = elements_to_state(et, gm)
    return x[:, 0].real, np.swapaxes(x[:, 1:].imag / _STEP, 1, 2)


# --- the peak overlap position -----------------------------------------------------------------

def _solve3(a, b):
    return np.linalg.solve(a, b[..., None])[..., 0]


def _usable(centres):
    """Rows of equinoctial elements ``(N, 6)`` inside the elliptic domain (n > 0, e < 1)."""
    return (np.all(np.isfinite(centres), axis=1) & (centres[:, 0] > 0)
            & (centres[:, 1] ** 2 + centres[:, 2] ** 2 < 1.0))


def _positive_definite(a):
    """Rows of ``(N, 3, 3)`` symmetric matrices that are finite and positive definite."""
    ok = np.all(np.isfinite(a), axis=(1, 2))
    w = np.linalg.eigvalsh(np.where(ok[:, None, None], a, np.eye(3)))
    return ok & (w[:, 0] > 0)


def _peak_overlap(t, e1, q1, e2, q2, gm):
    """Expansion centres of both objects at the times ``t`` (Hall 2021, section III).

    Linearised about centre ``Es``, the state at ``t`` is Gaussian with mean
    ``xu = X(Es) + J (E0 - Es)`` and covariance ``J Q J^T``. The peak overlap position ``r*``
    maximises the product of the two position densities; each new centre is the most probable
    element set (under ``N(E0, Q)``) whose linearised position at ``t`` is ``r*``.

    Far from the encounter the two densities do not overlap and the iteration can leave the
    elliptic domain (e >= 1, a NaN state) or make a position covariance singular; such a time
    point keeps the linearisation about the mean elements ``E0`` and is reported as not
    converged (the caller refuses the result only where the collision rate matters).
    """
    nt = t.size
    centres = [np.tile(e1, (nt, 1)), np.tile(e2, (nt, 1))]
    scales = [np.sqrt(np.diag(q1)), np.sqrt(np.diag(q2))]
    done = np.zeros(nt, dtype=bool)
    failed = np.zeros(nt, dtype=bool)
    about_mean = None
    # a time point that leaves the domain computes inf/NaN on its way; it is found and set
    # aside below (the warnings of its arithmetic would only repeat that)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        for _ in range(_POP_ITERATIONS):
            lin = []
            for es, e0, q in zip(centres, (e1, e2), (q1, q2), strict=True):
                xs, jac = _state_and_jacobian(es, t, gm)
                xu = xs + np.einsum("nij,nj->ni", jac, e0[None, :] - es)
                p = jac @ q @ np.swapaxes(jac, 1, 2)
                lin.append((xu, p, jac))
            if about_mean is None:  # the first pass linearises about E0 itself
                about_mean = lin
            for xu, p, jac in lin:
                failed |= ~(np.all(np.isfinite(xu), axis=1) & np.all(np.isfinite(jac), axis=(1, 2))
                            & _positive_definite(p[:, :3, :3]))
            lin = _about_mean_where(failed, lin, about_mean)
            for j, e0 in enumerate((e1, e2)):
                centres[j] = np.where(failed[:, None], e0[None, :], centres[j])
            a1, a2 = lin[0][1][:, :3, :3], lin[1][1][:, :3, :3]
            if not np.all(_positive_definite(a1) & _positive_definite(a2)):
                raise ConvergenceError(
                    "the 3D-Nc method found a singular position covariance at the mean elements; "
                    "check the covariances (positive definite, in m^2, m^2/s, m^2/s^2) or use "
                    "method='foster'.")
            i1, i2 = np.linalg.inv(a1), np.linalg.inv(a2)
            rstar = _solve3(i1 + i2, np.einsum("nij,nj->ni", i1, lin[0][0][:, :3])
                            + np.einsum("nij,nj->ni", i2, lin[1][0][:, :3]))
            moved = np.zeros(nt)
            for j, ((xu, p, jac), e0, q, sc) in enumerate(
                    zip(lin, (e1, e2), (q1, q2), scales, strict=True)):
                jr = jac[:, :3, :]
                gain = q @ np.swapaxes(jr, 1, 2)  # Q Jr^T, (N, 6, 3)
                new = e0[None, :] + np.einsum("nij,nj->ni", gain,
                                              _solve3(p[:, :3, :3], rstar - xu[:, :3]))
                failed |= ~_usable(new)
                moved = np.maximum(moved, np.max(np.abs(new - centres[j]) / sc, axis=1))
                centres[j] = np.where((done | failed)[:, None], centres[j], new)
            done |= (moved < _POP_TOL) | failed
            if np.all(done):
                break
    return _about_mean_where(failed, lin, about_mean), done & ~failed


def _about_mean_where(failed, lin, about_mean):
    """The linearisations ``lin`` with the rows of ``failed`` time points taken about E0."""
    if not np.any(failed):
        return lin
    return [tuple(np.where(failed.reshape((-1,) + (1,) * (x.ndim - 1)), x0, x)
                  for x, x0 in zip(now, mean, strict=True))
            for now, mean in zip(lin, about_mean, strict=True)]


# --- the collision rate: flux into the hard-body sphere ----------------------------------------

#: sigmas kept on either side of the density's centre by the adapted sphere rule
_K_SIGMA = 9.0
_N_U = 40  # Gauss-Legendre nodes across the band in u = cos(theta)
_N_PHI = 40  # Gauss-Legendre nodes along each half ring


def _sphere_nodes(ru, w, vecs, hbr, n_u, n_phi):
    """Directions ``(N, K, 3)`` and weights ``(N, K)`` of a sphere rule adapted to the density.

    In the eigenframe of the position covariance (axes a, b, c, sigmas increasing) the density is
    a product of three 1-D Gaussians. The pole is the minor axis a: the rule covers the band
    ``u = x_a / R`` within ``_K_SIGMA`` sigmas of the centre and, on each ring of the band, the
    arcs (one per half ring ``x_c >= 0`` and ``x_c <= 0``) where ``x_b`` is within ``_K_SIGMA``
    sigmas; Gauss-Legendre in ``u`` and in ``phi`` on each. Outside, the density is below
    ``exp(-_K_SIGMA^2 / 2)`` of its peak. Whatever the sigmas are relative to the HBR (thin
    slabs and needles included) the nodes sit where the integrand is.
    """
    nt = ru.shape[0]
    m = np.einsum("nji,nj->ni", vecs, ru)  # centre in the eigenframe
    sig = np.sqrt(w)
    xu, wu = np.polynomial.legendre.leggauss(n_u)
    xp, wp = np.polynomial.legendre.leggauss(n_phi)
    u_lo = np.clip((m[:, 0] - _K_SIGMA * sig[:, 0]) / hbr, -1.0, 1.0)
    u_hi = np.clip((m[:, 0] + _K_SIGMA * sig[:, 0]) / hbr, -1.0, 1.0)
    half = 0.5 * (u_hi - u_lo)
    u = (0.5 * (u_hi + u_lo))[:, None] + half[:, None] * xu[None, :]  # (N, NU)
    wu_n = half[:, None] * wu[None, :]
    ring = hbr * np.sqrt(np.maximum(1.0 - u * u, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        c_hi = np.where(ring > 0, (m[:, 1:2] + _K_SIGMA * sig[:, 1:2]) / ring, 1.0)
        c_lo = np.where(ring > 0, (m[:, 1:2] - _K_SIGMA * sig[:, 1:2]) / ring, -1.0)
    p_lo = np.arccos(np.clip(c_hi, -1.0, 1.0))  # phi in [0, pi]: x_b = ring cos(phi)
    p_hi = np.arccos(np.clip(c_lo, -1.0, 1.0))
    ph = 0.5 * (p_hi - p_lo)
    phi = (0.5 * (p_hi + p_lo))[..., None] + ph[..., None] * xp  # (N, NU, NP)
    wphi = ph[..., None] * wp
    phi = np.concatenate([phi, -phi], axis=2)
    wphi = np.concatenate([wphi, wphi], axis=2)
    st = np.sqrt(np.maximum(1.0 - u * u, 0.0))[..., None]
    local = np.stack([np.broadcast_to(u[..., None], phi.shape), st * np.cos(phi),
                      st * np.sin(phi)], axis=-1).reshape(nt, -1, 3)
    dirs = np.einsum("nij,nkj->nki", vecs, local)
    weights = (wu_n[..., None] * wphi).reshape(nt, -1)
    return dirs, weights


def _log_rate(ru, vu, ps, hbr, clip, n_u=_N_U, n_phi=_N_PHI):
    r"""ln of the collision rate (1/s) at each time point: ``R^2 \oint N(R n) E[(-n.v)^+ | R n]``.

    ``ru``, ``vu``: relative mode position and velocity (N, 3); ``ps``: relative 6x6 covariance.
    The velocity is the conditional Gaussian given the position (Hall 2021 eq. 36 ff.).
    """
    from scipy.special import log_ndtr

    a = ps[:, :3, :3]
    b = ps[:, 3:, :3]
    c = ps[:, 3:, 3:]
    w, vecs = np.linalg.eigh(a)
    w = np.maximum(w, clip)
    ainv = vecs @ (vecs / w[:, None, :]).swapaxes(1, 2)
    logdet = np.sum(np.log(w), axis=1)
    bs = b @ ainv
    cp = c - bs @ np.swapaxes(b, 1, 2)
    n, weights = _sphere_nodes(ru, w, vecs, hbr, n_u, n_phi)
    d = hbr * n - ru[:, None, :]
    md2 = np.einsum("nki,nij,nkj->nk", d, ainv, d)
    log_dens = -0.5 * md2 - 0.5 * logdet[:, None] - 1.5 * math.log(2.0 * math.pi)
    vmean = vu[:, None, :] + np.einsum("nij,nkj->nki", bs, d)
    mu = -np.einsum("nki,nki->nk", n, vmean)
    var = np.einsum("nki,nij,nkj->nk", n, cp, n)
    sd = np.sqrt(np.maximum(var, 0.0))
    # E[w+] for w ~ N(mu, sd^2): mu Phi(mu/sd) + sd phi(mu/sd); far tail sd phi(z) / z^2
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        z = mu / sd
        ez = np.where(sd > 0, mu * np.exp(log_ndtr(z)) + sd * np.exp(-0.5 * z * z)
                      / math.sqrt(2 * math.pi), np.maximum(mu, 0.0))
        tail = np.log(sd) - 0.5 * z * z - 0.5 * math.log(2 * math.pi) - 2.0 * np.log(-z)
        log_e = np.where((z < -30.0) & (sd > 0), tail, np.log(np.maximum(ez, 1e-320)))
        terms = log_dens + log_e + np.log(weights)
    terms = np.where(weights > 0, terms, -np.inf)
    top = np.max(terms, axis=1)
    safe = np.where(np.isfinite(top), top, 0.0)
    s = np.sum(np.exp(terms - safe[:, None]), axis=1)
    with np.errstate(divide="ignore"):
        return np.where(np.isfinite(top), safe + np.log(s), -np.inf) + 2.0 * math.log(hbr)


def _relative(t, el, gm):
    """Relative mode state and 6x6 covariance at the times ``t`` (POP in chunks)."""
    ru = np.empty((t.size, 3))
    vu = np.empty((t.size, 3))
    ps = np.empty((t.size, 6, 6))
    ok = np.empty(t.size, dtype=bool)
    for lo in range(0, t.size, 4096):
        sl = slice(lo, lo + 4096)
        lin, ok[sl] = _peak_overlap(t[sl], *el, gm)
        (xu1, p1, _), (xu2, p2, _) = lin
        ru[sl] = xu2[:, :3] - xu1[:, :3]
        vu[sl] = xu2[:, 3:] - xu1[:, 3:]
        ps[sl] = p1 + p2
    return ru, vu, ps, ok


def _rates(t, el, hbr, clip, gm, n_u=_N_U, n_phi=_N_PHI):
    """ln collision rate at the times ``t`` (chunks of time points keep the arrays small)."""
    ru, vu, ps, ok = _relative(t, el, gm)
    out = np.empty(t.size)
    chunk = max(1, 400_000 // (2 * n_u * n_phi))
    for lo in range(0, t.size, chunk):
        sl = slice(lo, lo + chunk)
        out[sl] = _log_rate(ru[sl], vu[sl], ps[sl], hbr, clip, n_u, n_phi)
    return out, ok


def _logsumexp(x):
    top = float(np.max(x))
    if not np.isfinite(top):
        return -math.inf
    return top + math.log(float(np.sum(np.exp(x - top))))


def _support(t, lr, margin=60.0):
    """Intervals of the sorted grid ``t`` where the rate is within ``e^-margin`` of its peak
    (padded by one cell on either side)."""
    keep = lr > float(np.max(lr)) - margin
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

    ``window``: ``(ta, tb)`` in s relative to TCA bounding the time integral, or ``None`` for
    half the shorter orbital period on either side. Returns ``ln Pc``.
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
        _, jac = _state_and_jacobian(e0[None, :], np.zeros(1), gm)
        kinv = np.linalg.inv(jac[0])
        q = kinv @ c @ kinv.T
        el += [e0, 0.5 * (q + q.T)]
        periods.append(2.0 * math.pi / e0[0])
    if window is None:
        ta, tb = -0.5 * min(periods), 0.5 * min(periods)
    else:
        ta, tb = float(window[0]), float(window[1])
        if not tb > ta:
            raise InvalidInputError(f"window must be (ta, tb) with ta < tb, got {window}.")
    clip = (1e-4 * hbr) ** 2
    # where the rate lives: a coarse scan of the window on a uniform grid and, around the
    # linear-motion closest approach, on its time scale (short for fast encounters)
    rel = x2 - x1
    arel = k1[:3, :3] + k2[:3, :3]
    grid = [np.linspace(ta, tb, 2049)]
    vel = rel[3:]
    if float(np.linalg.norm(vel)) > 0:
        ainv = np.linalg.inv(arel + clip * np.eye(3))
        curv = float(vel @ ainv @ vel)
        tc = -float(vel @ ainv @ rel[:3]) / curv
        st = 1.0 / math.sqrt(curv) + hbr / float(np.linalg.norm(vel))
        grid.append(np.clip(tc + st * np.linspace(-40.0, 40.0, 513), ta, tb))
    t = np.unique(np.concatenate(grid))
    lr, conv = _rates(t, el, hbr, clip, gm, 16, 16)
    peak = float(np.max(lr))
    if not np.isfinite(peak):
        return -math.inf
    if np.any(~conv & (lr > peak - 30.0)):
        _pop_failed()

    def log_rate(tt):
        return _rates(tt, el, hbr, clip, gm)

    lp, worst = _adaptive(_support(t, lr), log_rate, rtol)
    if worst > peak - 30.0:
        _pop_failed()
    return lp


def _pop_failed():
    raise ConvergenceError(
        "the peak overlap position of the 3D-Nc method did not converge at a time where the "
        "collision rate matters (CARA's Pc3D_Hall returns NaN here); use method='foster' or "
        "'monte_carlo', or report this case.")
