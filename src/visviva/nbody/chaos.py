"""Chaos indicators of a :class:`visviva.Simulation`: MEGNO and the maximal Lyapunov exponent.

REBOUND's ``sim.init_megno()``, ``sim.megno()`` and ``sim.lyapunov()``, as methods of
:class:`ChaosIndicators` (a base class of :class:`~visviva.Simulation`): a tangent vector is
integrated with the particles by the first-order variational equations and MEGNO is accumulated
step by step (the kernels and the definitions: :mod:`visviva.core.nbody_variational`).

Supported integrators: :data:`MEGNO_INTEGRATORS` (IAS15, leapfrog, WHFast in Jacobi
coordinates without corrector or event checks; :mod:`visviva.core.nbody_wh_tangent`). The
physical trajectory is bit for bit that of a run without MEGNO: the tangent vector follows each
step the integrator takes and never steers it (IAS15's step-size control sees the particles
alone).
"""

from __future__ import annotations

import numpy as np

from ..core import nbody_common as _nc
from ..core import nbody_variational as _nv
from ..errors import InvalidInputError, InvalidStateError, ShapeError

__all__ = ["ChaosIndicators", "MEGNO_INTEGRATORS", "extra_slots", "check_run", "refuse_packed"]

#: Integrators that integrate the tangent vector (the others refuse ``init_megno``).
MEGNO_INTEGRATORS = ("ias15", "leapfrog", "whfast")

_F_SLOTS = (_nc.F_MG_YS, _nc.F_MG_YSS, _nc.F_MG_N, _nc.F_MG_MEAN_T, _nc.F_MG_MEAN_Y,
            _nc.F_MG_COV, _nc.F_MG_VAR, _nc.F_MG_TAU, _nc.F_MG_DT_PREV, _nc.F_MG_LN,
            _nc.F_MG_ILN, _nc.F_MG_LN_SHIFT)


def _state_code(sim) -> int:
    return int(sim.state_arrays()["istate"][_nc.I_MEGNO])


def extra_slots(sim) -> int:
    """The ``buf`` slots the tangent vector adds to the integrator's own (0 when MEGNO is off)."""
    return _nv.N_TANGENT_SLOTS if _state_code(sim) == 1 else 0


def _check_supported(sim, what: str) -> None:
    if sim.integrator not in MEGNO_INTEGRATORS:
        raise InvalidInputError(
            f"{what}: MEGNO needs the tangent map of the integrator, which visviva has for "
            f"{', '.join(repr(k) for k in MEGNO_INTEGRATORS)} only, not "
            f"{sim.integrator!r}; set sim.integrator = 'whfast' (or 'ias15') first.")
    if sim.integrator == "whfast":
        _check_whfast(sim, what)
    if sim.forces:
        names = ", ".join(f.name for f in sim.forces)
        raise InvalidInputError(
            f"{what}: the additional force(s) {names} have no Jacobian, so the tangent vector "
            "would miss their part and MEGNO would be wrong; MEGNO supports Newtonian gravity "
            "alone (sim.clear_forces() to remove them).")
    if sim.collision in ("merge", "bounce"):
        raise InvalidInputError(
            f"{what}: collision={sim.collision!r} changes the particles (or their velocities "
            "by a jump) in a way the tangent vector cannot follow; use collision='none' or "
            "'halt' with MEGNO.")
    if sim.backend != "cpu":
        raise InvalidInputError(
            f"{what}: MEGNO runs on the CPU backend only; create the simulation with "
            "backend='cpu'.")


def _check_whfast(sim, what: str) -> None:
    """WHFast's tangent map covers Jacobi coordinates without a corrector and without events."""
    if sim.coordinates != "jacobi":
        raise InvalidInputError(
            f"{what}: WHFast's tangent map is implemented for Jacobi coordinates only, not "
            f"{sim.coordinates!r}; set sim.coordinates = 'jacobi' for MEGNO.")
    if sim.corrector != 0:
        raise InvalidInputError(
            f"{what}: WHFast's symplectic corrector (corrector={sim.corrector}) has no tangent "
            "map here, so MEGNO would follow a different map than the particles; set "
            "sim.corrector = 0 for MEGNO.")
    st = sim.state_arrays()
    if (st["istate"][_nc.I_COLLISIONS] != 0 or st["fstate"][_nc.F_ENCOUNTER] > 0.0
            or st["fstate"][_nc.F_EXIT] > 0.0):
        raise InvalidInputError(
            f"{what}: WHFast checks collisions, encounters and escapes on synchronised steps, "
            "which do not carry the tangent vector; with MEGNO use collision='none', "
            "encounter_distance=None and exit_max_distance=None (or integrator='ias15').")


def check_run(sim) -> None:
    """Raise when a run to start cannot carry the simulation's MEGNO state (called by
    :meth:`Simulation.begin_run`)."""
    if _state_code(sim) == 1:
        _check_supported(sim, "integrate")


def refuse_packed(members) -> None:
    """Raise when one of ``members`` (simulations to integrate together in a packed kernel whose
    ``buf`` has no tangent slots: the GPU's, or a CPU pack of members with and without MEGNO)
    has MEGNO switched on."""
    for k, s in enumerate(members):
        if _state_code(s) == 1:
            raise InvalidInputError(
                f"member {k} of the ensemble has MEGNO switched on (init_megno), which the "
                "GPU ensemble kernels do not integrate; use the ensemble's CPU backend "
                "(backend='cpu') or integrate the member with sim.integrate(t).")


class ChaosIndicators:
    """MEGNO and the Lyapunov exponent: the methods :class:`~visviva.Simulation` inherits."""

    def init_megno(self, seed=None, delta=None) -> None:
        """Start MEGNO: a tangent vector is integrated with the particles from now on.

        Parameters
        ----------
        seed : int, optional
            Seed of the random initial tangent vector (normal components, scaled to unit
            length): the same seed gives the same vector. None: a fresh random vector.
        delta : array_like, shape (N, 6), optional
            The initial tangent vector ``(dx, dy, dz, dvx, dvy, dvz)`` per particle (simulation
            units), e.g. the one REBOUND's variational particles hold; not all zero. Overrides
            ``seed``.

        Notes
        -----
        Supported by IAS15, leapfrog and WHFast (:data:`MEGNO_INTEGRATORS`; WHFast in Jacobi
        coordinates, without corrector, collision checks, encounter distance or escape radius);
        additional forces (no Jacobian), ``collision="merge"``/``"bounce"`` and the CUDA
        backend raise. MEGNO counts time from this call, as the sum of the steps taken
        (assigning ``sim.t`` later moves nothing; REBOUND counts from ``t = 0``, the same for
        a simulation started at 0 that keeps its clock). The integrator's internal state
        restarts here from the current positions and velocities (as after any change of them);
        from then on the physical trajectory is bit for bit that of a run without MEGNO: the
        tangent vector follows each accepted step and never steers one (IAS15's step-size
        control sees the particles alone, as REBOUND's does). The tangent vector is advanced on
        the integrator's own steps: :meth:`megno` is the value at the last of them, not at an
        output time reached by a copy between steps. ``save``/``load``, ``copy`` and pickles
        carry the MEGNO state; adding or removing particles or changing the integrator drops
        it (:meth:`megno` then raises).

        Costs one more O(N**2) Jacobian-vector product per force evaluation (IAS15: a second
        predictor-corrector loop on the linear tangent equations; WHFast: also two Kepler
        tangent drifts per body and step; see docs/performance.md).
        """
        _check_supported(self, "init_megno")
        n = self.N
        if n == 0:
            raise InvalidInputError("init_megno: the simulation has no particles; add them first.")
        if delta is None:
            if seed is not None and (isinstance(seed, (bool, np.bool_))
                                     or not isinstance(seed, (int, np.integer)) or seed < 0):
                raise InvalidInputError(
                    f"init_megno: seed must be an integer >= 0 (or None for a fresh random "
                    f"tangent vector), got {seed!r}; give delta=(N, 6) array for a given one.")
            d = np.random.default_rng(seed).standard_normal((n, 6))
        else:
            d = np.array(delta, dtype=np.float64)
            if d.shape != (n, 6):
                raise ShapeError(f"delta must have shape ({n}, 6) (one row (dx, dy, dz, dvx, "
                                 f"dvy, dvz) per particle); got {d.shape}.")
            if not np.all(np.isfinite(d)):
                raise InvalidInputError("delta contains NaN or infinite values.")
        norm = float(np.sqrt(np.sum(d * d)))
        if norm == 0.0:
            raise InvalidInputError("delta is all zeros: a tangent vector needs a direction.")
        st = self._state
        st.istate[_nc.I_MEGNO] = 1
        st.ensure_buf(self._integrator.n_buf + _nv.N_TANGENT_SLOTS)
        base = self._integrator.n_buf
        st.buf[base:] = 0.0
        st.buf[base + _nv.DX] = d[:, :3] / norm
        st.buf[base + _nv.DV] = d[:, 3:] / norm
        st.fstate[list(_F_SLOTS)] = 0.0
        st.fstate[_nc.F_MG_T0] = self.t
        st.mark_fresh()

    def _megno_state(self, what: str):
        code = _state_code(self)
        if code == 0:
            raise InvalidStateError(f"{what}: MEGNO is off; call sim.init_megno() before "
                                    "integrating.")
        if code == -1:
            raise InvalidStateError(
                f"{what}: the MEGNO state was dropped when particles were added or removed or "
                "the integrator changed; call sim.init_megno() again.")
        return self._state.fstate

    def megno(self) -> float:
        """MEGNO ``<Y>`` since :meth:`init_megno` (REBOUND's ``sim.megno()``): about 2 for a
        quasi-periodic orbit, growing like ``lambda tau / 2`` for a chaotic one; 0 before the
        first step. Raises :class:`~visviva.errors.InvalidStateError` when MEGNO is off."""
        f = self._megno_state("megno")
        tau = f[_nc.F_MG_TAU]
        return float(f[_nc.F_MG_YSS] / tau) if tau != 0.0 else 0.0

    def lyapunov(self) -> float:
        """The maximal Lyapunov exponent, per unit of the simulation's time: twice the slope of a
        least-squares line through MEGNO ``<Y>`` against time over the steps since
        :meth:`init_megno` (``<Y> ~ lambda tau / 2``; Cincotta & Simo 2000, eq. 24). About 0
        for a regular orbit; 0 before two steps. Time runs from :meth:`init_megno` as the sum of
        the steps taken (assigning ``sim.t`` changes nothing; backwards runs count ``|t|``).

        REBOUND's ``sim.lyapunov()`` returns the slope itself, half of this (compare with
        ``2 * rsim.lyapunov()``; docs/nbody.md). Like any such fit it lags behind the growth
        rate ``ln|delta(t)/delta(0)| / t`` while ``<Y>`` leaves 2, and approaches it as the run
        lengthens. The Lyapunov time is ``1 / sim.lyapunov()``.
        """
        f = self._megno_state("lyapunov")
        var = f[_nc.F_MG_VAR]
        # against |tau|: a run backwards in time grows like one forwards
        sign = -1.0 if f[_nc.F_MG_TAU] < 0.0 else 1.0
        return float(2.0 * sign * f[_nc.F_MG_COV] / var) if var > 0.0 else 0.0

    @property
    def tangent_vector(self) -> np.ndarray:
        """The tangent vector, shape (N, 6) ``(dx, dy, dz, dvx, dvy, dvz)`` (a copy), at the
        integrator's last step: ``sim.t`` with ``exact_finish_time=False`` or on the leapfrog's
        or WHFast's step grid (synchronised: comparable with REBOUND's variational particles),
        up to one step before it when an output time was reached by a copy (as :meth:`megno`).
        Multiplied by 1e-100 whenever ``|delta|^2`` passes 1e200 (MEGNO is scale-free)."""
        self._megno_state("tangent_vector")
        base = self._integrator.n_buf
        buf = self._state.buf
        return np.concatenate([buf[base + _nv.DX], buf[base + _nv.DV]], axis=1)
