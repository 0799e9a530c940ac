"""The batch fit's steps: the Gauss-Newton solve and its Levenberg-Marquardt damping.

A Gauss-Newton step from a first guess far from the data (tens of km) can overshoot: the
linearisation holds only near the estimate, and the next iterate fits worse, or cannot be
integrated at all. Levenberg (1944) and Marquardt (1963) shorten such a step by solving
(A^T A + lambda D) dx = A^T b instead of (A^T A) dx = A^T b, with Marquardt's scaling
D = diag(A^T A), which makes the damping independent of the units of the unknowns (km next
to km/s next to m^2/kg): lambda -> 0 is the Gauss-Newton step, lambda -> infinity a short
step down the gradient, each unknown scaled by its own information.

The damping is reactive (Madsen, Nielsen & Tingleff 2004, "Methods for non-linear least
squares problems", sec. 3.2; Tapley, Schutz & Born 2004, sec. 4.3 on the divergence of the
linearised batch): lambda starts at 0, so a fit whose RMS keeps falling takes exactly its
Gauss-Newton steps (the same iterates and the same bits as without damping). When an iterate
fits worse than the last accepted one by more than the convergence tolerance, both on the rows
outlier editing kept and on all of them (:meth:`Marquardt.rejects`), (or cannot be
evaluated: the trajectory cannot be integrated, or leaves the measurement model's domain),
that iterate is rejected, lambda is raised (to ``LAMBDA_START``, then tenfold) and a shorter
step is taken from the accepted one; each accepted step lowers it tenfold (``LAMBDA_DOWN``), back to 0
below ``LAMBDA_OFF``. The covariance is always the undamped (A^T A)^-1 at the solution.

Damping alone does not reach the data's minimum from a guess hundreds of km off a long arc:
the along-track error grows over the arc (a 200 km error in the radius is one of ~400 km in the
semi-major axis, ~0.5 rad of drift per LEO revolution), so the late passes are measured where
the guess's satellite is on another part of its orbit; their residuals are not linear in the
state, a Gauss-Newton step fits them worse than the guess (rejected), damped steps creep, and
outlier editing keeps whichever late rows the wrong orbit happens to match (a local minimum
at an RMS of thousands). Hence arc continuation (:class:`Window`; the "fit a shorter arc
first" of Tapley, Schutz & Born 2004, sec. 4.3, automated): when a damped step is rejected
too, after a Gauss-Newton step of over ``WINDOW_STEP`` of its own sigmas, the fit restarts
from the accepted iterate on the rows nearest the epoch (the nearest 1/``WINDOW_FRACTION`` of
them), where the linearisation holds; each time that fit settles (a correction under
``WINDOW_SETTLE`` of its own sigmas, or an RMS that stopped changing) the window doubles its
span (on past gaps, and past the rows the estimate already fits, ``WINDOW_FIT``), until it
holds every row and the fit goes on as before. A fit without a rejected step never opens one
(the same bits as ``damping=None``).
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError

__all__ = ["DAMPINGS", "WINDOW_FIT", "WINDOW_SETTLE", "Marquardt", "Window", "solve"]

#: the values of ``fit_orbit(damping=...)``
DAMPINGS = ("auto", None)
#: lambda after the first rejected step (of the column-scaled normal matrix, whose diagonal is 1)
LAMBDA_START = 1e-3
#: lambda below which an accepted step returns to Gauss-Newton (lambda = 0)
LAMBDA_OFF = 1e-6
#: lambda's divisor after an accepted step (as fast as its rise)
LAMBDA_DOWN = 10.0
#: lambda above which the fit gives up: no step shorter than this lowers the RMS
LAMBDA_MAX = 1e12
#: a rejected step longer than this many of its own sigmas opens the window (a step of a few
#: sigmas, rejected near the minimum by outliers, does not restart the fit)
WINDOW_STEP = 100.0
#: the first window holds the 1/WINDOW_FRACTION of the rows nearest the epoch, and at least
#: twice as many components as unknowns (from 200 km off, 20 random directions, 1/4 reached
#: the data's minimum 15 times, 1/8 19 times, 1/16 20 times; docs/performance.md)
WINDOW_FRACTION = 16
#: the window's fit has settled (the window widens) when a correction is under this many of its
#: own sigmas: the wider window's fit goes on from there, so the last few sigmas of the narrow
#: one are not worth an iteration each (3 cost one to two iterations per widening)
WINDOW_SETTLE = 10.0
#: a row beyond the window fits (the window widens past it without an iteration) when its
#: normalised residuals are under WINDOW_FIT x max(1, the window's RMS): rows that far off are
#: still in the linear regime (a far guess's late rows are off by 10^3-10^7 sigmas), and the
#: next Gauss-Newton step fits them (4 cost two iterations per pass of a one-station arc)
WINDOW_FIT = 100.0
#: no window when its first one reaches past WINDOW_NEAR of the farthest row's distance from the
#: epoch: the rows nearest the epoch are then no nearer than the rest, and their fit is as far
#: from linear as the whole arc's (one station whose first pass comes 4.5 h into a 6 h arc:
#: az/el from 100 km off, 13 of 20 within 60 iterations against 8 with the window)
WINDOW_NEAR = 0.5


def solve(A, b, lam=0.0):
    """Step and covariance of the whitened system A dx = b (SVD of the column-scaled A).

    With ``lam`` > 0 the step is Marquardt's damped one, (A^T A + lam diag(A^T A))^-1 A^T b;
    the covariance is the undamped (A^T A)^-1 either way.
    """
    scale = np.linalg.norm(A, axis=0)
    if np.any(scale == 0):
        raise InvalidInputError(
            "the observations carry no information on some state component; add observations "
            "of other kinds, from other stations or over a longer arc."
        )
    As = A / scale
    U, s, Vt = np.linalg.svd(As, full_matrices=False)
    if s[-1] <= s[0] * 1e-13:
        raise InvalidInputError(
            f"the observations do not determine the orbit (condition number "
            f"{s[0] / max(s[-1], 1e-300):.2e}): add observations of other kinds, from other "
            "stations or over a longer arc."
        )
    if lam > 0:  # diag(As^T As) = 1: the damped solve is a filter on the singular values
        dx = (Vt.T @ ((U.T @ b) * (s / (s * s + lam)))) / scale
    else:
        dx = (Vt.T @ ((U.T @ b) / s)) / scale
    Vs = Vt.T / s
    P = (Vs @ Vs.T) / np.outer(scale, scale)
    return dx, P


class Marquardt:
    """The damping of one fit: lambda, and the last accepted iterate to step back to.

    Parameters
    ----------
    damping : {"auto", None}
        ``"auto"``: damp after an RMS increase; None: plain Gauss-Newton.
    tol : float
        The fit's relative RMS tolerance: an increase within it is not a rejection.
    """

    def __init__(self, damping, tol):
        if not (damping is None or (isinstance(damping, str) and damping in DAMPINGS)):
            raise InvalidInputError(
                f"damping must be 'auto' (Levenberg-Marquardt after a step that fits worse) or "
                f"None (plain Gauss-Newton steps); got {damping!r}.")
        self.on = damping == "auto"
        self.tol = tol
        self.lam = 0.0  # lambda of the next step
        self.used = 0.0  # lambda of the step that led to the current iterate
        self.base = None  # (A, b, unknowns) of the last accepted iterate
        self.rows = None  # (normalised residuals, rows used, a priori rows' residuals) there
        self.predicted = self.gain = None  # chi^2 drop Gauss-Newton promised; got / promised
        self.gains = []  # the gain of each accepted iterate since the rows changed (None: first)

    @property
    def armed(self):
        """True when a worse iterate can be rejected (damping on, an iterate accepted)."""
        return self.on and self.base is not None

    def rejects(self, zn, every, prior):
        """Whether an iterate is rejected: the RMS of its normalised residuals ``zn`` (N, 3)
        with its a priori rows ``prior`` exceeds the accepted iterate's by more than ``tol``
        (or is not finite) both on the rows that iterate kept and on ``every`` measured
        component. Outlier editing changes the rows between iterates: on the kept rows alone
        a far guess's editing keeps the rows its wrong orbit fits, and a step towards the data
        reads as a worse fit there (the 24 h LEO benchmark campaign, from 1.5 km off, was
        damped to a standstill that way); on every row alone the true outliers move the
        minimum away from the edited fit's, and its converging steps read as worse."""
        self.gain = None
        if not self.armed:
            return False
        zn0, kept0, prior0 = self.rows
        then = np.sum(zn0[kept0] ** 2) + np.sum(prior0 ** 2)  # chi^2 there, on its rows
        with np.errstate(over="ignore", invalid="ignore"):
            self.gain = (then - np.sum(zn[kept0] ** 2) - np.sum(prior ** 2)) / self.predicted

        def grew(rows):
            now = np.sqrt(np.mean(np.r_[zn[rows], prior] ** 2))
            then = np.sqrt(np.mean(np.r_[zn0[rows], prior0] ** 2))
            return not now <= then * (1.0 + self.tol)

        return grew(kept0) and grew(every)

    def accept(self, A, b, unknowns, zn, kept, n_meas):
        """Record an accepted iterate (its whitened system, its residuals ``zn`` and the rows
        ``kept`` by editing; the rows of ``b`` past ``n_meas`` are the a priori ones) and lower
        lambda."""
        if self.on:
            self.gains.append(self.gain)
            self.base = (A, b, unknowns)
            self.rows = (zn, kept, b[n_meas:])
            self.lam = self.lam / LAMBDA_DOWN if self.lam / LAMBDA_DOWN >= LAMBDA_OFF else 0.0

    def step(self, A, b, dx):
        """The step to take from the accepted iterate: ``dx`` (Gauss-Newton) or damped."""
        self.used = self.lam
        self.predicted = float(np.sum((A @ dx) ** 2))  # Gauss-Newton's chi^2 drop, n step^2
        return dx if self.lam == 0.0 else solve(A, b, self.lam)[0]

    def reset(self):
        """Forget the accepted iterate and return to Gauss-Newton (the rows changed: the next
        iterate is accepted and compared with from then on)."""
        self.lam = self.used = 0.0
        self.base = self.rows = None
        self.gains = []

    def retreat(self):
        """The unknowns after a rejected iterate: a shorter step from the accepted one; None
        when lambda has grown past ``LAMBDA_MAX`` (no step lowers the RMS)."""
        self.lam = LAMBDA_START if self.lam == 0.0 else 10.0 * self.lam
        if self.lam > LAMBDA_MAX:
            return None
        A, b, unknowns = self.base
        self.used = self.lam
        return unknowns + solve(A, b, self.lam)[0]


class Window:
    """Arc continuation of one fit: the rows within ``span`` seconds of the epoch.

    Parameters
    ----------
    offsets : ndarray (N,)
        The rows' times from the epoch (s).
    dims : ndarray of int (N,)
        The rows' measurement components.
    n_unknowns : int
        The fit's unknowns: the first window holds at least twice as many components.
    """

    def __init__(self, offsets, dims, n_unknowns):
        self.dist = np.abs(np.asarray(offsets, dtype=float))
        self.span = np.inf  # every row: no window open
        self.opened = False  # a fit opens it once
        order = np.argsort(self.dist, kind="stable")
        enough = np.cumsum(dims[order]) >= 2 * n_unknowns
        first = max(len(order) // WINDOW_FRACTION,
                    int(np.argmax(enough)) if enough[-1] else len(order) - 1)
        self.first = float(self.dist[order[min(first, len(order) - 1)]])

    @property
    def active(self):
        """True while the fit sees only part of the arc."""
        return self.span < np.inf

    @property
    def seconds(self):
        """The span (s) while open, else None (history's ``window``)."""
        return self.span if self.active else None

    def rows(self):
        """(N,) mask of the rows inside the window."""
        return self.dist <= self.span

    def open(self, step):
        """Open the window after a rejected damped step (the Gauss-Newton step from the accepted
        iterate was ``step`` of its sigmas), once per fit, when that step was long
        (``WINDOW_STEP``) and the first window leaves rows out and stays near the epoch
        (``WINDOW_NEAR``); True if opened."""
        if (self.opened or not step > WINDOW_STEP or self.first >= self.dist.max()
                or self.first > WINDOW_NEAR * self.dist.max()):
            return False
        self.opened, self.span = True, max(self.first, 1e-9)
        return True

    def widen(self, fits=None):
        """Double the span, past any gap without rows, and on while every row it adds fits
        (``fits``, (N,) bool: the estimate already explains them); every row once it reaches
        the farthest."""
        while self.active:
            before = self.rows()
            beyond = self.dist[~before]
            self.span = max(2.0 * self.span, float(beyond.min()))
            if self.span >= self.dist.max():
                self.span = np.inf
            if fits is None or not np.all(fits[self.rows() & ~before]):
                return
