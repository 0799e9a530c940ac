"""Many independent simulations advanced together: :class:`Ensemble`.

Stability maps, Monte Carlo over uncertain masses and orbits, and clone studies run thousands of
small systems. ``vv.Ensemble.from_simulations(sims)`` takes any number of
:class:`~visviva.Simulation` objects with the same integrator (any N per member: the members are
packed one after another, ragged) and :meth:`Ensemble.integrate` advances all of them to the same
absolute time in ONE compiled call, in parallel over the members
(:func:`visviva.core.nbody_ensemble.ensemble_run`). Each member runs the very kernel a lone
:class:`~visviva.Simulation` runs, on the same numbers, so its result equals running it alone
bit for bit. With ``client=`` the members are cut into blocks that run on Dask workers (processes),
with identical results.

A member that meets an event (collision, encounter, escape) is handled as
:meth:`visviva.Simulation.integrate` handles it: mergers and bounces are resolved and the member
continues; ``"halt"``, encounters and escapes stop that member at the event while the others
finish, and the first such exception is raised afterwards with the member's index in
``exc.member`` (the indices of every member that stopped in ``exc.members``, and in its notes).
"""

from __future__ import annotations

import functools
import math
import operator

import numpy as np

from ..core import nbody_common as _nc
from ..errors import InvalidInputError, InvalidStateError, ShapeError
from . import step_check as _step_check
from . import tier as _tier
from .chaos import extra_slots, refuse_packed
from .ensemble_file import load_ensemble, save_ensemble
from .ensemble_pack import Pack, ensemble_kernel, finish_member
from .forces import force_key
from .gpu import check_backend, check_ensemble
from .simulation import Simulation

__all__ = ["Ensemble", "advance_members"]



class Ensemble:
    """Many independent N-body simulations with the same integrator, advanced together.

    Build one with :meth:`from_simulations`. The ensemble owns copies of the simulations it was
    given; ``ens[i]`` and :meth:`to_simulations` return copies again.

    Parameters
    ----------
    members : list of Simulation
        The members (taken over, not copied: use :meth:`from_simulations`).
    backend : str
        ``"cpu"`` (numba threads over the members) or ``"cuda"`` (one GPU thread per member;
        leapfrog, IAS15, and WHFast in any coordinates, with or without a corrector, event
        checks and additional forces; see :mod:`visviva.nbody.gpu`).

    Examples
    --------
    >>> import visviva as vv
    >>> sims = []
    >>> for a in (1.0, 1.5, 2.0):
    ...     sim = vv.Simulation("whfast", dt=0.01)
    ...     indices = [sim.add(1.0), sim.add(1e-3, a=a, primary=0)]
    ...     sims.append(sim)
    >>> ens = vv.Ensemble.from_simulations(sims)
    >>> ens.integrate(10.0)
    >>> len(ens), ens.t.tolist()
    (3, [10.0, 10.0, 10.0])
    >>> alone = sims[1].copy()
    >>> alone.integrate(10.0)
    >>> bool((ens[1].positions == alone.positions).all())
    True
    """

    def __init__(self, members, backend: str = "cpu"):
        self._members = list(members)
        self.backend = backend
        self._pack = None  # the members' arrays packed (ensemble_pack.Pack), once integrated

    @classmethod
    def from_simulations(cls, sims, backend: str = "cpu") -> Ensemble:
        """An ensemble of copies of ``sims``.

        Parameters
        ----------
        sims : sequence of Simulation
            At least one; all with the same integrator; any number of particles each.
        backend : str
            ``"cpu"`` (default) or ``"cuda"`` (leapfrog, IAS15 or WHFast members; see
            :mod:`visviva.nbody.gpu`); ``"cuda"`` raises
            :class:`visviva.errors.BackendUnavailableError` saying what is missing when there is
            no usable GPU or numba-cuda is not installed, and
            :class:`visviva.errors.InvalidInputError` (naming the member) for settings the GPU
            does not run.

        Returns
        -------
        Ensemble
        """
        if isinstance(sims, Simulation):
            raise InvalidInputError(
                "sims is one Simulation; an Ensemble is built from a list of them: pass [sim] "
                "(or [sim.copy() for _ in range(n)] for n copies).")
        try:
            sims = list(sims)
        except TypeError:
            raise InvalidInputError(
                f"sims must be a list of visviva.Simulation objects; got a "
                f"{type(sims).__name__}.") from None
        if not sims:
            raise InvalidInputError("an Ensemble needs at least one Simulation.")
        for k, sim in enumerate(sims):
            if not isinstance(sim, Simulation):
                raise InvalidInputError(
                    f"member {k} is a {type(sim).__name__}, not a visviva.Simulation."
                )
            if sim.N == 0:
                raise InvalidInputError(f"member {k} has no particles: add some first.")
        names = sorted({s.integrator for s in sims})
        if len(names) > 1:
            raise InvalidInputError(
                f"the members use different integrators {names}: an ensemble advances members "
                "of one integrator; make one ensemble per integrator."
            )
        backend = check_backend(backend, names[0], ensemble=True)
        if backend == "cuda":
            check_ensemble(sims)
        return cls([s.copy() for s in sims], backend)

    # ---- members ---------------------------------------------------------------------------------
    def __len__(self) -> int:
        return len(self._members)

    def __getitem__(self, index):
        if isinstance(index, slice):
            return Ensemble([s.copy() for s in self._members[index]], self.backend)
        try:
            k = operator.index(index)  # int(0.7) picked member 0 without a word
        except TypeError:
            raise InvalidInputError(
                f"an ensemble is indexed by an integer (or a slice); got {index!r}.") from None
        if not -len(self) <= k < len(self):
            raise IndexError(f"member {k} is out of range: the ensemble has {len(self)} members.")
        return self._members[k].copy()

    def __iter__(self):
        for k in range(len(self)):
            yield self[k]

    def to_simulations(self) -> list:
        """Copies of the members as :class:`~visviva.Simulation` objects, in order."""
        return [s.copy() for s in self._members]

    def __repr__(self) -> str:
        n = self.n_particles
        return (f"<Ensemble {len(self)} x {self.integrator} N={n.min()}..{n.max()} "
                f"backend={self.backend}>")

    @property
    def integrator(self) -> str:
        """The members' integrator."""
        return self._members[0].integrator

    @property
    def t(self) -> np.ndarray:
        """Time of each member, shape (M,) (simulation units)."""
        if self._pack is not None:
            return self._pack.fstate[:, _nc.F_T].copy()
        return np.array([s.t for s in self._members])

    @property
    def n_particles(self) -> np.ndarray:
        """Number of particles of each member, shape (M,)."""
        return np.array([s.N for s in self._members], dtype=np.int64)

    def _padded(self, name, width):
        if self._pack is not None:
            return self._pack.padded(getattr(self._pack, {"positions": "x", "velocities": "v",
                                                          "masses": "m"}[name]))
        n = self.n_particles
        out = np.full((len(self), int(n.max())) + width, np.nan)
        for k, s in enumerate(self._members):
            out[k, : n[k]] = getattr(s, name)
        return out

    @property
    def positions(self) -> np.ndarray:
        """Positions, shape (M, N_max, 3) (simulation units); rows past a member's N are NaN."""
        return self._padded("positions", (3,))

    @property
    def velocities(self) -> np.ndarray:
        """Velocities, shape (M, N_max, 3) (simulation units); rows past a member's N are NaN."""
        return self._padded("velocities", (3,))

    @property
    def masses(self) -> np.ndarray:
        """Masses, shape (M, N_max) (simulation units); entries past a member's N are NaN."""
        return self._padded("masses", ())

    def megno(self) -> np.ndarray:
        """MEGNO of each member, shape (M,) (:meth:`visviva.Simulation.megno`; switch it on
        with each member's ``init_megno`` before integrating; CPU backend only; each member's
        result equals its lone run bit for bit)."""
        self._refuse_megno_off("megno")
        return np.array([s.megno() for s in self._members])

    def _refuse_megno_off(self, what: str) -> None:
        """Name the members without MEGNO (each lone Simulation's error named none)."""
        off = [k for k, s in enumerate(self._members) if not extra_slots(s)]
        if off:
            shown = ", ".join(map(str, off[:10])) + (", ..." if len(off) > 10 else "")
            raise InvalidStateError(
                f"Ensemble.{what}: MEGNO is off for member(s) {shown} ({len(off)} of "
                f"{len(self._members)}); call init_megno() on each Simulation before "
                "Ensemble.from_simulations (and before integrating).")

    def lyapunov(self) -> np.ndarray:
        """The maximal Lyapunov exponent of each member, shape (M,) (per unit of the members'
        time; :meth:`visviva.Simulation.lyapunov`)."""
        self._refuse_megno_off("lyapunov")
        return np.array([s.lyapunov() for s in self._members])

    def energy(self, include_offset: bool = True) -> np.ndarray:
        """Total energy of each member, shape (M,) (simulation units; see
        :meth:`visviva.Simulation.energy`)."""
        return np.array([s.energy(include_offset) for s in self._members])

    # ---- integration -----------------------------------------------------------------------------
    def integrate(self, t, client=None) -> None:
        """Integrate every member to the absolute time ``t``.

        Parameters
        ----------
        t : float or Quantity
            Absolute time (simulation units, or a Quantity for members with units).
        client : dask.distributed.Client, str or True, optional
            Spread blocks of members over Dask workers: a client, a scheduler address
            (``"tcp://host:8786"``), or ``True``/``"local"`` for a ``LocalCluster`` of two
            process workers (started once and reused). Each worker advances its block as an
            ensemble with as many numba threads as the worker has threads. The results are
            identical to ``client=None`` (this process, numba threads over the members).

        Raises
        ------
        Collision, Encounter, Escape, StepSizeError, InvalidStateError
            As :meth:`visviva.Simulation.integrate`, for the first member that met one (its index
            in ``exc.member``); the other members have reached ``t``.
        """
        if np.ndim(t) != 0:
            raise ShapeError(
                f"Ensemble.integrate takes one time for every member; got shape {np.shape(t)}. "
                "For snapshots, call it once per output time."
            )
        if self._pack is None:  # a pack holds members of one set of units (Pack.build)
            _check_one_time_unit(self._members, t)
        # WHFast steps too long for the orbits: one warning naming the members, not one each
        with _step_check.members_checked():
            if client is not None:
                from .ensemble_dask import integrate_on_dask

                _step_check.check_members(  # here: the workers say nothing
                    self, self._members, t=_time(self._members[0], t))
                advance = functools.partial(_advance_block, backend=self.backend)
                self._pack = None  # the members come back as new objects
                errors = integrate_on_dask(self._members, t, client, advance)
            else:
                errors, self._pack = advance_members(self._members, t, self.backend, self._pack,
                                                     owner=self)
            # the states they reached: a close encounter met on the way (step_check.py)
            _step_check.check_members_run(self, self._members, self._pack)
        _raise_first(errors)

    # ---- files -----------------------------------------------------------------------------------
    def save(self, path) -> None:
        """Write every member's complete state atomically to ``path`` (an ``.npz`` file).

        :meth:`load` returns an ensemble whose members continue bit for bit. Format
        ``visviva.nbody.ensemble`` version 2: the members' arrays packed one after another
        (:mod:`visviva.nbody.ensemble_file`).
        """
        save_ensemble(self._members, self.backend, path)

    @classmethod
    def load(cls, path, forces=None, backend: str | None = None) -> Ensemble:
        """Read an ensemble written by :meth:`save` (format version 1 or 2).

        Parameters
        ----------
        path : str or path-like
            The file.
        forces : sequence, optional
            As in :meth:`visviva.Simulation.load`, for every member.
        backend : str, optional
            Override the saved backend (``"cpu"`` or ``"cuda"``).

        Returns
        -------
        Ensemble
        """
        members, saved_backend = load_ensemble(Simulation, path, forces)
        backend = check_backend(backend or saved_backend, members[0].integrator, ensemble=True)
        if backend == "cuda":
            check_ensemble(members)
        return cls(members, backend)


def _check_one_time_unit(members, t) -> None:
    """A plain number ``t`` is a time in each member's own units: refuse it when members have
    different time units (it would send them to different times, some backwards), and say to
    pass a Quantity."""
    if hasattr(t, "unit") or type(t).__name__ == "TimeDelta":
        return
    scales = {s.units.time: s.units.time_s for s in members if s.units is not None}
    if len(set(scales.values())) > 1:
        raise InvalidInputError(
            f"t = {t!r} is a plain number, but the members have different time units "
            f"{sorted(scales)}, so it would mean a different time for each; pass a Quantity "
            "(e.g. t * astropy.units.yr).")


def _raise_first(errors) -> None:
    if not errors:
        return
    k, exc = errors[0]
    others = [j for j, _ in errors]
    try:
        exc.member = k
        exc.members = others
    except AttributeError:  # pragma: no cover - exceptions without a __dict__
        pass
    exc.add_note(
        f"in ensemble member {k}; {len(others)} member(s) stopped early: {others[:20]}"
        + (" ..." if len(others) > 20 else "")
        + ". The other members reached the requested time."
    )
    raise exc


def _advance_block(members, t, backend):
    """Dask worker side: advance a block of members as an ensemble; returns them and the errors
    (the client checked their steps: :func:`~visviva.nbody.step_check.check_members`)."""
    with _step_check.members_checked():
        return members, advance_members(members, t, backend)[0]


def advance_members(members: list, t, backend: str = "cpu", pack=None, owner=None) -> tuple:
    """Advance the simulations ``members`` (in place) to ``t`` in this process, as one ensemble.

    The worker side of :meth:`Ensemble.integrate` and its in-process path (numba threads over
    the members on ``backend="cpu"``, one GPU thread per member on ``"cuda"``). The members are
    packed (:class:`~visviva.nbody.ensemble_pack.Pack`, or ``pack``, the one a previous call
    returned for the same members) and advanced in one call; what the pack does not clear runs
    member by member, with the same results. With ``owner`` (the ensemble), the members' WHFast
    steps are checked on the packed arrays first
    (:func:`~visviva.nbody.step_check.check_members`; call it inside
    :func:`~visviva.nbody.step_check.members_checked`, so that the members do not warn again).

    Returns
    -------
    errors : list
        ``[(index, exception), ...]`` of the members that stopped early.
    pack : Pack or None
        The pack to pass to the next call for these members (None: build it again).
    """
    if backend != "cpu":
        refuse_packed(members)  # the GPU kernels do not carry tangent vectors
    elif _tier.ensemble_would_compile(members, _time(members[0], t)):
        if owner is not None:
            _step_check.check_members(owner, members, stacklevel=4, t=_time(members[0], t))
        return _advance_alone(members, t), None  # a fresh install's first small ensemble
    if pack is None:
        pack = Pack.build(members)
    if owner is not None:
        _step_check.check_members(owner, members, pack, stacklevel=4, t=_time(members[0], t))
    errors = None
    if pack is not None:
        if backend == "cuda":
            from .gpu import integrate_pack

            errors = integrate_pack(pack, t)
        else:
            errors = pack.advance(t)
        if errors is None or pack.stale:
            pack = None
    if errors is None:
        errors = _advance_each(members, t, backend)
    return errors, pack


def _time(sim, t) -> float:
    """``t`` in ``sim``'s simulation units (NaN when it is not a valid time: the run says so)."""
    from .settings import convert

    try:
        return float(convert(sim, t, "time", "t"))
    except Exception:
        return math.nan


def _advance_alone(members: list, t) -> list:
    """Each member integrated as a lone simulation (the same bits as the ensemble kernel)."""
    errors = []
    for k, sim in enumerate(members):
        try:
            sim.integrate(t)
        except Exception as exc:
            errors.append((k, exc))
    return errors


def _advance_each(members: list, t, backend: str) -> list:
    """The per-member path of :func:`advance_members` (each member prepared and finished as a
    lone run; one compiled call per group of members with the same forces)."""
    if backend == "cuda":
        from .gpu import integrate_ensemble

        return integrate_ensemble(members, t)
    errors = []
    groups: dict = {}
    for k, sim in enumerate(members):
        try:
            times = sim.begin_run(t)
        except Exception as exc:
            errors.append((k, exc))
            continue
        groups.setdefault((force_key(sim), times.tobytes(), extra_slots(sim)), []).append(k)
    for (_, times_bytes, _), ks in groups.items():
        times = np.frombuffer(times_bytes, dtype=np.float64).copy()
        status = _run_group([members[k] for k in ks], times)
        for k, code in zip(ks, status.tolist(), strict=True):
            finish_member(members[k], code, t, errors, k)
    return sorted(errors, key=lambda e: e[0])


def _run_group(members, times) -> np.ndarray:
    """One compiled call over ``members`` (same forces, same output times); their status codes."""
    from ..core.gravity import GWORK_ROWS

    info = members[0].integrator_info
    n_buf = info.n_buf + extra_slots(members[0])  # the same for every member of the group
    inputs = [s.kernel_inputs(parallel=False) for s in members]
    arrays = [s.state_arrays() for s in members]
    n = np.array([s.N for s in members], dtype=np.int64)
    poff = np.concatenate([[0], np.cumsum(n)]).astype(np.int64)
    moff = np.concatenate([[0], np.cumsum([len(i[2]) for i in inputs])]).astype(np.int64)
    qoff = np.concatenate([[0], np.cumsum([len(i[1]) for i in inputs])]).astype(np.int64)

    def cat(key):
        return np.ascontiguousarray(np.concatenate([a[key] for a in arrays]))

    x, v, m, radius = cat("x"), cat("v"), cat("m"), cat("radius")
    fstate = np.ascontiguousarray(np.stack([a["fstate"] for a in arrays]))
    istate = np.ascontiguousarray(np.stack([a["istate"] for a in arrays]))
    buf = np.concatenate([a["buf"].reshape(-1) for a in arrays])
    massive = np.ascontiguousarray(np.concatenate([i[2] for i in inputs]), dtype=np.int64)
    params = np.ascontiguousarray(np.concatenate([i[1] for i in inputs]))
    T = len(times)
    total = int(poff[-1])
    gwork = np.zeros(GWORK_ROWS * total)
    out_t = np.zeros((len(members), T))
    out_x = np.zeros(T * total * 3)
    out_v = np.zeros(T * total * 3)
    status = np.zeros(len(members), dtype=np.int64)
    ensemble_kernel()(
        info.kernel(), n_buf, x, v, m, massive, moff, radius, fstate, istate, buf, gwork,
        inputs[0][0], params, qoff, times, out_t, out_x, out_v, poff, status,
    )
    for j, a in enumerate(arrays):
        lo, hi = poff[j], poff[j + 1]
        a["x"][:] = x[lo:hi]
        a["v"][:] = v[lo:hi]
        a["fstate"][:] = fstate[j]
        a["istate"][:] = istate[j]
        a["buf"][:] = buf[n_buf * lo * 3:n_buf * hi * 3].reshape(a["buf"].shape)
    return status
