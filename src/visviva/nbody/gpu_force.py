"""The CPU integrator kernels with their direct-sum gravity evaluated on the GPU.

For one large simulation an IAS15 or WHFast step (or a leapfrog step with additional forces or
event checks) costs O(N N_massive) for the gravity and O(N)
for everything else (IAS15's predictor-corrector and step control, WHFast's Kepler drifts,
coordinate transforms and correctors). :func:`run_with_gpu_gravity` therefore runs the CPU
backend's own compiled kernel (:mod:`visviva.core.nbody_ias15`, :mod:`visviva.core.nbody_whfast`)
and hands it the gravity through its additional-force argument:

* the kernel is called with no massive particle, so its own direct sum adds nothing (one O(N)
  pass), and with :func:`gpu_gravity_force` as the additional force;
* that compiled force calls back into Python (``numba.objmode``) once per force evaluation, and
  an evaluator (one per run, found through ``params[0]``) adds the accelerations from the tiled
  direct sum on the GPU (:class:`DeviceGravity`): positions go to the device
  and accelerations come back, 48 bytes per particle against N_massive pair evaluations.

The step grid, the step control, the output copies and the stored state are the CPU backend's
own, operation for operation: only the gravity sums differ (added in another order: round-off),
and a run can be saved, loaded and continued on either backend. The simulation's own additional
forces are fused after :func:`gpu_gravity_force` (added after the gravity, as the CPU kernel
adds them), and the collision, encounter and escape checks run in the kernel as on the CPU (a
merger or bounce rebuilds the GPU's arrays before the run goes on). The evaluators
(:mod:`visviva.nbody.gpu_ias15`, :mod:`visviva.nbody.gpu_whfast`) know which slot of the
integrator's ``buf`` a call concerns; tests check their slot numbers against the kernels'.
"""

from __future__ import annotations

import itertools
import threading
import warnings
import weakref

import numpy as np
from numba import objmode

from ..core import nbody_common as _nc
from ..core._jit import kernel

__all__ = ["DeviceGravity", "GravityEvaluator", "gpu_gravity_force", "run_with_gpu_gravity",
           "every_call"]

_RUNS: dict = {}  # run key (params[0]) -> GravityEvaluator, for the runs in flight
_KEYS = itertools.count(1)
_LOCK = threading.Lock()
_READY: list = []  # [True] once gpu_gravity_force is compiled (see _compile_force)
_FUSED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # user force -> with gravity


class DeviceGravity:
    """Direct-summation accelerations of one system on the GPU (the tiled kernel).

    Parameters
    ----------
    gm : ndarray, shape (N,)
        ``G m`` of every particle (length**3 / time**2).
    massive : ndarray of int64
        Indices of the massive particles.
    soft2 : float
        Plummer softening length squared (length**2).
    """

    def __init__(self, gm, massive, soft2: float):
        from numba import cuda

        from ..core.cuda import kernels

        self._kernels = kernels
        self.n = len(gm)
        self.gm = cuda.to_device(np.ascontiguousarray(gm, dtype=np.float64))
        self.massive = cuda.to_device(np.ascontiguousarray(massive, dtype=np.int64))
        self.soft2 = float(soft2)
        self.acc = cuda.device_array((self.n, 3))
        self._buffers: dict = {}  # host-path device buffers, allocated on first use
        self._out = None

    def __call__(self, x, xlo=None):
        """Launch the kernel on ``x`` (a device array, shape (N, 3)), on the two-part positions
        ``x + xlo`` when ``xlo`` is given; returns the device array of accelerations
        (length / time**2), overwritten by the next call."""
        K = self._kernels
        kernel = K.accelerations if xlo is None else K.accelerations_split
        kernel[K.blocks(self.n), K.THREADS](x, x if xlo is None else xlo, self.gm, self.massive,
                                            self.soft2, self.acc)
        return self.acc

    def _device(self, name, host):
        """``host`` (N, 3) copied into the device buffer ``name`` (allocated on first use)."""
        from numba import cuda

        buf = self._buffers.get(name)
        if buf is None:
            buf = self._buffers[name] = cuda.device_array(host.shape, dtype=host.dtype)
        buf.copy_to_device(np.ascontiguousarray(host))
        return buf

    def add(self, x, acc, xlo=None) -> None:
        """Add the accelerations at the host positions ``x`` (two-part ``x + xlo`` when ``xlo``
        is given) to the host array ``acc`` (N, 3); the device buffers are allocated once and
        reused."""
        d_lo = None if xlo is None else self._device("xlo", xlo)
        out = self(self._device("x", x), d_lo)
        if self._out is None:
            self._out = np.empty((self.n, 3))
        out.copy_to_host(self._out)
        acc += self._out

    def tight(self, x, ratio: float) -> bool:
        """True when a particle and a massive one are closer than ``1 / ratio`` of the larger
        of their distances from the origin (host positions ``x``, evaluated on the GPU)."""
        K = self._kernels
        flags = self._buffers.get("flags")
        if flags is None:
            from numba import cuda

            flags = self._buffers["flags"] = cuda.device_array(self.n, dtype=np.int32)
        K.tight_pairs[K.blocks(self.n), K.THREADS](self._device("x", x), self.massive,
                                                   ratio * ratio, flags)
        return bool(flags.copy_to_host().any())


class GravityEvaluator:
    """The gravity of one run on the GPU, called by :func:`gpu_gravity_force`.

    Parameters
    ----------
    buf : ndarray, shape (K, N, 3)
        The integrator's own arrays (read and, by some evaluators, written).
    gravity : DeviceGravity
        The GPU direct sum of the run's particles.

    Notes
    -----
    Subclasses define ``__call__(x, acc)``: add the gravity at the positions ``x`` (N, 3) to
    ``acc`` (N, 3), both arrays over the kernel's own memory (``x.ctypes.data`` tells which slot
    of ``buf`` they are). An exception is kept in :attr:`error` and re-raised by
    :func:`run_with_gpu_gravity` (it cannot cross the compiled kernel).
    """

    def __init__(self, buf, gravity):
        self.buf = buf
        self.gravity = gravity
        self.error: BaseException | None = None

    def address(self, slot: int) -> int:
        """Where slot ``slot`` of ``buf`` starts in memory."""
        return self.buf[slot].ctypes.data

    def unexpected(self, what: str) -> RuntimeError:
        """The error for a call the evaluator does not recognise (the kernel's buf layout
        changed under it)."""
        return RuntimeError(
            f"the integrator kernel asked for gravity {what} outside the slots the GPU driver "
            f"knows ({type(self).__module__}): use backend='cpu' and report this."
        )


class _EveryCall(GravityEvaluator):
    """For a kernel whose every force call is one whole acceleration evaluation at ``x`` (the
    leapfrog: :func:`visviva.core.nbody_common.accelerations`, once per step)."""

    def __call__(self, x, acc) -> None:
        self.gravity.add(x, acc)


def every_call(sim, massive) -> GravityEvaluator:
    """The GPU gravity of one leapfrog run of ``sim`` with additional forces or event checks
    (``massive``: the indices of its massive particles), for :func:`run_with_gpu_gravity`."""
    state = sim.state_arrays()
    gravity = DeviceGravity(sim.G * state["m"], massive, state["fstate"][_nc.F_SOFT2])
    return _EveryCall(state["buf"], gravity)


def _evaluate(params, x, acc) -> None:
    """Called from compiled code: the GPU gravity of run ``params[0]`` added to ``acc``. An
    exception cannot cross the compiled kernel: it is kept for the driver, and NaN makes the
    kernel stop at once (its non-finite checks)."""
    run = _RUNS.get(int(params[0]))
    if run is None:
        return  # key 0: the compile-time call of _compile_force
    try:
        run(x, acc)
    except BaseException as exc:  # noqa: BLE001 - re-raised by run_with_gpu_gravity
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
        Positions and velocities (simulation units) as the integrator kernel passes them.
    m : ndarray, shape (N,)
        Masses (not used: the GPU holds ``G m``).
    params : ndarray, shape (>= 1,)
        ``params[0]``: the key of the run in flight (:func:`run_with_gpu_gravity`).
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


def _fused_with(fn):
    """:func:`gpu_gravity_force` followed by the simulation's own (fused) force ``fn``: the GPU
    gravity first, then the forces, added in the CPU kernel's order."""
    fused = _FUSED.get(fn)
    if fused is None:
        from numba.core.errors import NumbaWarning

        from ..core.nbody_common import FORCE_SIGNATURE
        from .forces import combine

        fused = combine([gpu_gravity_force, fn], [1, 0])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NumbaWarning)
            fused.compile(FORCE_SIGNATURE)
        _FUSED[fn] = fused
    return fused


def run_with_gpu_gravity(sim, rec, evaluator) -> None:
    """Integrate ``sim`` (IAS15, WHFast, or the leapfrog with forces or events) through the output times of ``rec`` with its CPU
    kernel, every gravity evaluation on the GPU.

    Parameters
    ----------
    sim : Simulation
        Prepared by :meth:`visviva.Simulation.begin_run`. Its additional forces are added
        after the gravity, and its collision, encounter and escape checks run, as on the CPU; a
        merger or bounce rebuilds the GPU's arrays before the run goes on.
    rec : visviva.nbody.trajectory.Recording
        The output times (simulation units, monotonic) and the arrays the kernel writes its
        snapshots into, as :meth:`visviva.Simulation.integrate` passes them on the CPU.
    evaluator : callable
        ``evaluator(sim, massive)``: the :class:`GravityEvaluator` of one kernel call over the
        current arrays of ``sim`` (``massive``: the indices of its massive particles), e.g.
        :func:`visviva.nbody.gpu_ias15.evaluator`.

    Raises
    ------
    Collision, Encounter, Escape, StepSizeError, InvalidStateError
        As on the CPU (the kernel's status goes through :meth:`visviva.Simulation.after_kernel`).
    Exception
        Whatever the GPU call raised; the state is then the last one the kernel completed.
    """
    from ..core.gravity import GWORK_ROWS, no_force

    _compile_force()
    with _LOCK:
        key = next(_KEYS)
    try:
        while True:
            # (again after a merger or bounce: N, the masses and buf may have changed)
            fn, params, massive = sim.kernel_inputs(parallel=False)
            state = sim.state_arrays()
            x, v, fstate, istate = state["x"], state["v"], state["fstate"], state["istate"]
            run = _RUNS[key] = evaluator(sim, massive)
            force = gpu_gravity_force if fn is no_force else _fused_with(fn)
            n = x.shape[0]
            done0 = rec.before_call()
            # the few-body kernel: its own gravity is a pass over no massive particle (with
            # its scratch of the full size: the rows of the particles i are used all the same)
            status = int(sim.integrator_info.kernel(True, istate, fstate)(
                x, v, state["m"], np.empty(0, np.int64), state["radius"], fstate, istate,
                state["buf"], np.zeros((GWORK_ROWS, n)), force,
                np.concatenate([[float(key)], params]), rec.times, rec.out_t, rec.chunk_x,
                rec.chunk_v))
            if run.error is not None:
                raise run.error
            if rec.after_call(status, done0):
                return
    finally:
        _RUNS.pop(key, None)
