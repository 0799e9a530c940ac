"""IAS15 with ``backend="cuda"``: the predictor-corrector's gravity evaluations on the GPU.

A step of IAS15 evaluates the forces at the step start and at the 7 Gauss-Radau substeps of
every predictor-corrector sweep: for one large simulation that is O(N N_massive) work each time,
while everything else (the predictor, the divided differences and the ``b``/``e`` updates, the
convergence test, the step-size control, the compensated update of the state) is O(N). This
driver runs the CPU kernel itself, :func:`visviva.core.nbody_ias15.ias15_run_few` (the compiled
kernel the CPU backend runs), and hands it the gravity through its additional-force argument:

* the kernel is called with no massive particle, so its own direct sum adds nothing (one O(N)
  pass), and with :func:`gpu_gravity_force` as the additional force;
* that compiled force calls back into Python (``numba.objmode``) once per evaluation, and the
  tiled direct sum on the GPU (:class:`visviva.nbody.gpu.DeviceGravity`) adds the accelerations:
  positions go to the device and accelerations come back, 48 bytes per particle against
  N_massive pair evaluations;
* with fewer than :data:`visviva.core.gravity.PAIR_MIN_N` massive particles the CPU kernel
  evaluates a step on IAS15's two-part positions ``x + xlo`` when a particle is close to a
  massive one far from the origin (see :mod:`visviva.core.nbody_ias15`); the force makes the
  same decision once per step (the test on the GPU, :func:`visviva.core.cuda.kernels.tight_pairs`)
  and rebuilds the same low parts from the kernel's ``buf`` (the compensated-summation terms at
  the step start, Knuth's two-sum at the substeps), then sums on the GPU with
  :data:`visviva.core.cuda.kernels.accelerations_split`.

The step grid, the step control, the output copies and the stored state are therefore the CPU
backend's own, operation for operation; only the gravity sums differ (added in another order:
round-off), so a run agrees with the CPU backend to round-off and can be saved, loaded and
continued on either backend. Gravity only, one output time per call, as the other GPU paths;
additional forces and event checks raise :class:`~visviva.errors.InvalidInputError` saying to use
``backend="cpu"`` (:func:`visviva.nbody.gpu.begin_gpu_run`).
"""

from __future__ import annotations

import itertools
import threading
import warnings

import numpy as np
from numba import objmode

from ..core._jit import kernel
from ..core.gravity import PAIR_MIN_N
from ..core.nbody_ias15 import SPLIT_RATIO

__all__ = ["integrate_ias15", "gpu_gravity_force", "IAS15_SLOTS"]

#: Slots of IAS15's ``buf`` the force reads (see :mod:`visviva.core.nbody_ias15`): the
#: compensated-summation terms of the positions, the predicted positions of a substep, the
#: position increments of a substep (``xl`` when the kernel's own split is off) and the internal
#: positions. Checked against the kernel's layout by ``tests/test_nbody_gpu.py``.
IAS15_SLOTS = {"csx": 35, "xp": 38, "xi": 41, "xl": 75}

_RUNS: dict = {}  # run key (params[0]) -> _Evaluator, for the runs in flight
_KEYS = itertools.count(1)
_LOCK = threading.Lock()
_READY: list = []  # [True] once gpu_gravity_force is compiled (see _compile_force)


class _Evaluator:
    """The gravity of one run: which call of the step this is, and the GPU sum."""

    def __init__(self, buf, gravity, n_massive: int):
        self.buf = buf
        self.gravity = gravity
        self.slots = {name: buf[k] for name, k in IAS15_SLOTS.items()}
        self.starts = buf[IAS15_SLOTS["xi"]].ctypes.data
        self.substeps = buf[IAS15_SLOTS["xp"]].ctypes.data
        # the CPU kernel's test for two-part positions applies below PAIR_MIN_N massive
        self.may_split = 0 < n_massive < PAIR_MIN_N
        self.split = False
        self.error: BaseException | None = None

    def __call__(self, x, acc) -> None:
        s = self.slots
        where = x.ctypes.data
        if where == self.starts:  # the step start, at the internal state: decide the split
            self.split = self.may_split and self.gravity.tight(x, SPLIT_RATIO)
            lo = -s["csx"] if self.split else None
        elif where == self.substeps:  # a substep: the kernel left x + dx in xp, dx in xl
            lo = None
            if self.split:  # the rounding error of xp = dx + x, exactly (Knuth's two-sum)
                xf, xp, dx = s["xi"], s["xp"], s["xl"]
                bb = xp - xf
                lo = (xf - (xp - bb)) + (dx - bb)
        else:
            raise RuntimeError(
                "the IAS15 kernel evaluated gravity at positions outside the slots the GPU "
                "driver knows (visviva.nbody.gpu_ias15.IAS15_SLOTS no longer matches "
                "visviva.core.nbody_ias15): use backend='cpu' and report this."
            )
        out = np.empty_like(acc)
        self.gravity.host(x, out, lo)
        acc += out


def _evaluate(params, x, acc) -> None:
    """Called from compiled code: the GPU gravity of run ``params[0]`` added to ``acc``. An
    exception cannot cross the compiled kernel: it is kept for the driver, and NaN makes the
    kernel stop at once (its non-finite check)."""
    run = _RUNS.get(int(params[0]))
    if run is None:
        return  # key 0: the compile-time call of _compile_force
    try:
        run(x, acc)
    except BaseException as exc:  # noqa: BLE001 - re-raised by integrate_ias15
        if run.error is None:
            run.error = exc
        acc[:] = np.nan


@kernel
def gpu_gravity_force(t, x, v, m, params, acc):
    """The additional force that adds the direct-sum gravity computed on the GPU.

    Parameters
    ----------
    t : float
        Time (simulation units; not used).
    x, v : ndarray, shape (N, 3)
        Positions and velocities (simulation units) as the IAS15 kernel passes them.
    m : ndarray, shape (N,)
        Masses (not used: the GPU holds ``G m``).
    params : ndarray, shape (>= 1,)
        ``params[0]``: the key of the run in flight (:func:`integrate_ias15`).
    acc : ndarray, shape (N, 3)
        Accelerations (length / time**2), added to in place.

    Notes
    -----
    A compiled function with the integrators' force signature
    (:data:`visviva.core.nbody_common.FORCE_SIGNATURE`) whose body calls back into the
    interpreter (``numba.objmode``) for the GPU launch; numba caches it like any kernel.
    """
    with objmode():
        _evaluate(params, x, acc)


def _compile_force() -> None:
    """Compile (or load from the cache) :func:`gpu_gravity_force` and the interpreter block in
    it (compiled at its first call), without numba's warning that this block holds the GIL (it
    must: it launches the GPU kernels from Python; the kernel around it releases the GIL as
    usual)."""
    if _READY:
        return
    from numba.core.errors import NumbaWarning

    from ..core.nbody_common import FORCE_SIGNATURE

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NumbaWarning)
        gpu_gravity_force.compile(FORCE_SIGNATURE)
        z = np.zeros((1, 3))
        gpu_gravity_force(0.0, z, z, np.zeros(1), np.zeros(1), z)  # key 0: no run, no-op
    _READY.append(True)


def integrate_ias15(sim, target: float, massive, gravity) -> None:
    """Integrate ``sim`` (IAS15, ``backend="cuda"``) to the absolute time ``target``.

    Parameters
    ----------
    sim : Simulation
        An IAS15 simulation, gravity only, prepared by :func:`visviva.nbody.gpu.begin_gpu_run`.
    target : float
        Absolute time (simulation units).
    massive : ndarray of int64
        Indices of its massive particles.
    gravity : DeviceGravity
        The GPU direct sum of its particles.

    Raises
    ------
    StepSizeError, InvalidStateError
        As on the CPU (the kernel's status is handled by :meth:`visviva.Simulation.after_kernel`).
    """
    state = sim.state_arrays()
    x, v, m, buf = state["x"], state["v"], state["m"], state["buf"]
    fstate, istate = state["fstate"], state["istate"]
    n = x.shape[0]
    with _LOCK:
        key = next(_KEYS)
    run = _RUNS[key] = _Evaluator(buf, gravity, len(massive))
    params = np.array([float(key), 0.0])
    times = np.array([target])
    out_x, out_v = np.empty((1, n, 3)), np.empty((1, n, 3))
    # the few-body kernel (its gravity is a pass over no massive particle); I_PARALLEL is 0
    run_kernel = sim.integrator_info.kernel(few=True)
    _compile_force()
    try:
        while True:
            status = int(run_kernel(x, v, m, np.empty(0, np.int64), state["radius"], fstate,
                                    istate, buf, np.zeros((7, 1)), gpu_gravity_force, params,
                                    times, times.copy(), out_x, out_v))
            if run.error is not None:
                raise run.error
            if sim.after_kernel(status):
                return
    finally:
        del _RUNS[key]
