"""The one owner of a :class:`visviva.Simulation`'s state: :class:`SimulationState`.

Every number a simulation integrates or saves lives here: the particle arrays, the scalar state
the compiled kernels read and write (``fstate``/``istate``, slots named in
:mod:`visviva.core.nbody_common`), the integrator's internal arrays (``buf``), and the few Python
settings the kernels never see (collision mode, restitution, the energy lost in mergers). The
:class:`~visviva.Simulation`, the archive, collision handling, REBOUND interop and ensembles read
and change it only through the methods below, so that adding a piece of state is one field here.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core import nbody_common as _nc

__all__ = ["SimulationState", "ARRAY_KEYS"]

#: The arrays of a state, in the order (and under the keys) the archive format stores them.
ARRAY_KEYS = ("x", "v", "m", "radius", "fstate", "istate")


@dataclass(eq=False)
class SimulationState:
    """Arrays and settings of one N-body simulation (simulation units throughout).

    Attributes
    ----------
    x, v : ndarray, shape (N, 3)
        Positions and velocities (C-contiguous float64; the kernels update them in place).
    m, radius : ndarray, shape (N,)
        Masses (0: test particle) and collision radii.
    fstate : ndarray of float64, shape (N_FSTATE,)
        Scalar state (time, step, G, softening, ...), slots ``F_*`` of
        :mod:`visviva.core.nbody_common`.
    istate : ndarray of int64, shape (N_ISTATE,)
        Integer state (counters, flags), slots ``I_*``.
    buf : ndarray, shape (K, N, 3), or None
        The integrator's internal arrays; None until the first integration.
    collision : str
        Collision mode (see :data:`visviva.nbody.COLLISION_MODES`).
    restitution : float
        Coefficient of restitution of a bounce.
    energy_offset : float
        Energy removed by mergers and inelastic bounces (added back by ``energy()``).
    """

    x: np.ndarray
    v: np.ndarray
    m: np.ndarray
    radius: np.ndarray
    fstate: np.ndarray
    istate: np.ndarray
    buf: np.ndarray | None = None
    collision: str = "none"
    restitution: float = 1.0
    energy_offset: float = 0.0
    # scratch of the kernels: rebuilt on demand, never saved
    massive: np.ndarray | None = field(default=None, repr=False)
    gwork: np.ndarray | None = field(default=None, repr=False)

    @classmethod
    def empty(cls) -> SimulationState:
        """A state with no particles and a fresh integrator."""
        istate = np.zeros(_nc.N_ISTATE, dtype=np.int64)
        istate[_nc.I_FRESH] = 1
        return cls(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros(0),
                   np.zeros(_nc.N_FSTATE), istate)

    @property
    def N(self) -> int:
        """Number of particles."""
        return int(self.m.shape[0])

    # ---- changes ---------------------------------------------------------------------------------
    def mark_fresh(self) -> None:
        """Make the integrator rebuild its internal state from ``x, v`` at the next step."""
        self.istate[_nc.I_FRESH] = 1

    def particles_changed(self) -> None:
        """Particles were added or removed: drop the integrator's arrays (and with them a
        tangent vector: MEGNO is marked dropped, ``istate[I_MEGNO] = -1``, so that asking for it
        raises instead of answering with a stale value)."""
        self.buf = None
        if self.istate[_nc.I_MEGNO] == 1:
            self.istate[_nc.I_MEGNO] = -1
        self.mark_fresh()

    def append(self, r, v, m: float, radius: float) -> None:
        """Add one particle (position ``r`` and velocity ``v`` of shape (3,))."""
        self.x = np.ascontiguousarray(np.vstack([self.x, r]))
        self.v = np.ascontiguousarray(np.vstack([self.v, v]))
        self.m = np.append(self.m, m)
        self.radius = np.append(self.radius, radius)
        self.particles_changed()

    def remove(self, index: int) -> None:
        """Remove particle ``index`` (later indices shift down by one)."""
        keep = np.ones(self.N, bool)
        keep[int(index)] = False
        self.x = np.ascontiguousarray(self.x[keep])
        self.v = np.ascontiguousarray(self.v[keep])
        self.m = self.m[keep].copy()
        self.radius = self.radius[keep].copy()
        self.particles_changed()

    def replace(self, key: str, arr: np.ndarray) -> None:
        """Replace the array ``key`` (``"x"`` or ``"v"``) by ``arr`` of the same shape."""
        setattr(self, key, np.ascontiguousarray(arr, dtype=np.float64))
        self.mark_fresh()

    def set_particle(self, i: int, *, m=None, r=None, v=None, radius=None) -> None:
        """Change the given quantities of particle ``i`` in place (the integrator restarts)."""
        if m is not None:
            self.m[i] = m
        if r is not None:
            self.x[i] = r
        if v is not None:
            self.v[i] = v
        if radius is not None:
            self.radius[i] = radius
        self.mark_fresh()

    def adopt(self, x, v, m, radius, fstate, istate, buf, massive) -> None:
        """Hold the given arrays, which already hold this state's values (views into an
        ensemble's packed arrays, :mod:`visviva.nbody.ensemble_pack`), as this state's arrays:
        a packed call then updates the member in place."""
        self.x, self.v, self.m, self.radius = x, v, m, radius
        self.fstate, self.istate, self.buf, self.massive = fstate, istate, buf, massive

    # ---- kernel scratch --------------------------------------------------------------------------
    def ensure_buf(self, n_buf: int) -> None:
        """Allocate the integrator's arrays when missing or of another shape (restart then)."""
        if (self.buf is not None and n_buf == 76 and self.buf.shape == (75, self.N, 3)):
            # an IAS15 state saved before its scratch slot for the low parts of positions (slot
            # 75) was added: the slots in use are the same, so the run continues bit for bit
            self.buf = np.concatenate([self.buf, np.zeros((1, self.N, 3))])
        if self.buf is None or self.buf.shape != (n_buf, self.N, 3):
            self.buf = np.zeros((n_buf, self.N, 3))
            self.mark_fresh()

    def work(self) -> np.ndarray:
        """The gravity kernels' scratch, shape (GWORK_ROWS, N) (:mod:`visviva.core.gravity`)."""
        from ..core.gravity import GWORK_ROWS

        if self.gwork is None or self.gwork.shape != (GWORK_ROWS, self.N):
            self.gwork = np.zeros((GWORK_ROWS, self.N))
        return self.gwork

    # ---- copies and files ------------------------------------------------------------------------
    def __getstate__(self):
        # pickles (Dask workers, multiprocessing) leave the kernels' scratch behind: rebuilt on
        # demand, and two of nine arrays less per simulation to pickle
        return {**self.__dict__, "massive": None, "gwork": None}

    def copy(self) -> SimulationState:
        """A deep copy (the scratch is not shared)."""
        return SimulationState(
            *(getattr(self, k).copy() for k in ARRAY_KEYS),
            buf=None if self.buf is None else self.buf.copy(),
            collision=self.collision,
            restitution=self.restitution,
            energy_offset=self.energy_offset,
        )

    def restore(self, saved: SimulationState) -> None:
        """Take back the values of ``saved`` (a :meth:`copy` of this state): in place where the
        shapes still match (views into an ensemble's packed arrays stay views), else by
        replacing the arrays (a merger removed particles since)."""
        for key in ARRAY_KEYS + ("buf",):
            old, new = getattr(self, key), getattr(saved, key)
            if old is not None and new is not None and old.shape == new.shape:
                old[...] = new
            else:
                setattr(self, key, None if new is None else new.copy())
        self.energy_offset = saved.energy_offset
        self.massive = None
        self.gwork = None

    def arrays(self) -> dict:
        """The arrays under their archive keys (``buf`` only when allocated); not copies."""
        out = {k: getattr(self, k) for k in ARRAY_KEYS}
        if self.buf is not None:
            out["buf"] = self.buf
        return out

    @classmethod
    def from_arrays(cls, get, *, collision: str = "none", restitution: float = 1.0,
                    energy_offset: float = 0.0) -> SimulationState:
        """A state from ``get(key)`` (the stored array or None), as written by :meth:`arrays`."""
        arrays = [np.ascontiguousarray(get(k)) for k in ARRAY_KEYS]
        buf = get("buf")
        return cls(*arrays, buf=None if buf is None else np.ascontiguousarray(buf),
                   collision=collision, restitution=restitution, energy_offset=energy_offset)
