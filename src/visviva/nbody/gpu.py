"""The ``backend="cuda"`` runs of :class:`visviva.Simulation` and :class:`visviva.Ensemble`.

What runs on the GPU today:

* the leapfrog integrator (drift-kick-drift) with direct-summation gravity, for one large
  simulation (one thread per particle per kernel, the gravity tiled through shared memory, the
  state kept on the device between steps) and for ensembles (one thread per member,
  :mod:`visviva.core.cuda.kernels`, :mod:`visviva.nbody.gpu_ensemble_leapfrog`);
* IAS15 and WHFast for one large simulation (:mod:`visviva.nbody.gpu_force`): the CPU backend's
  own compiled kernel runs every step (IAS15's predictor-corrector and step control; WHFast's
  Kepler drifts, coordinate transforms and correctors, in Jacobi or democratic heliocentric
  coordinates) and every gravity evaluation is the tiled direct sum on the GPU, handed to the
  kernel through its additional-force argument (:mod:`visviva.nbody.gpu_ias15`, with IAS15's
  two-part positions for tight pairs; :mod:`visviva.nbody.gpu_whfast`).
* WHFast ensembles (Jacobi or democratic heliocentric coordinates, symplectic correctors,
  collision, encounter and escape checks, position-dependent additional forces): one thread per
  member runs the CPU kernel's own functions compiled for the device
  (:mod:`visviva.core.cuda.whfast`; in the plain case without forces planned on the host,
  otherwise the CPU's whole run body on the member's state,
  :mod:`visviva.nbody.gpu_ensemble_whfast`);
* IAS15 ensembles: one thread per member runs IAS15's own step (predictor-corrector, step control, compensated
  summation, two-part positions for tight pairs, the shortened copy to an output time) compiled
  for the device from the CPU source (:mod:`visviva.core.cuda.ias15`,
  :mod:`visviva.nbody.gpu_ensemble_ias15`); the members' whole state goes to the device and back.
  A member with ``PAIR_MIN_N`` (256) massive particles or more runs as its own GPU simulation
  (its gravity tiled over the GPU, as above), with its lone run's result.
* collision, encounter and escape checks in leapfrog and IAS15 ensembles: after every step the
  member's thread runs the CPU kernel's own check (:func:`visviva.core.nbody_common.check_events`
  compiled for the device); a member whose check fires stops as the CPU kernel stops and is
  finished by :meth:`visviva.nbody.ensemble_pack.Pack.finish` as on the CPU (a merger or bounce
  resolved and the member continued alone; a halt, encounter or escape raised for it), the
  others run on (WHFast: the CPU's run body on the device); and additional forces in leapfrog,
  IAS15 and WHFast ensembles, each force function
  compiled for the device from its own source (:mod:`visviva.nbody.gpu_forces`), one kernel
  call per set of force functions, each member on its own parameters.

The step grid, the time origin and the shortened last step to an output time are the CPU
kernels' (the plans are computed with their expressions, :mod:`visviva.nbody.gpu_plan`), and
the state (``buf`` included) is stored as the CPU backend stores it, so a run can be saved,
loaded and continued on either backend. Results agree with the CPU backend to round-off (the
gravity sums are added in another order): under numba's CUDA simulator 1e-17 to 3e-16 relative
after several steps (``tests/test_nbody_gpu.py``; the WHFast and IAS15 ensembles, which add
the same numbers in the same order, bit for bit there); that is all the simulator shows, it says nothing
of speed.

A simulation integrates through an array of output times as on the CPU and returns the same
:class:`~visviva.nbody.trajectory.Trajectory` (:func:`integrate_simulation`; the snapshots are
gathered by the CPU path's :class:`~visviva.nbody.trajectory.Recording`): IAS15 and WHFast hand
the times to their CPU kernel, the leapfrog runs to one output time after the other (the same
steps and bits as one CPU call through all of them).

IAS15 and WHFast take additional forces (evaluated on the CPU, after the GPU gravity, as the CPU
kernel adds them) and the collision, encounter and escape checks (on the CPU after each step;
mergers and bounces rebuild the GPU arrays); so does a leapfrog simulation, which then runs its
CPU kernel with the gravity on the GPU (:func:`visviva.nbody.gpu_force.every_call`). Not on the
GPU (yet): arrays of output times for ensembles (:class:`visviva.errors.ShapeError`, as on the
CPU: an ensemble integrates to one time per call).
"""

from __future__ import annotations

import numpy as np

from .._backends import check_backend as _check
from ..core import nbody_common as _nc
from ..core import status as _st
from ..errors import InvalidInputError, InvalidStateError, ShapeError
from .gpu_force import DeviceGravity
from .gpu_plan import plan

__all__ = [
    "check_backend", "integrate_simulation", "integrate_ensemble", "integrate_pack",
    "DeviceGravity", "begin_gpu_run", "check_ensemble",
]

#: Integrators with a GPU implementation: of one simulation, of an ensemble.
GPU_INTEGRATORS = ("leapfrog", "whfast", "ias15")
GPU_ENSEMBLE_INTEGRATORS = ("leapfrog", "whfast", "ias15")
# slots of the leapfrog's buf (see visviva.core.nbody_leapfrog)
_XI, _VI = 1, 2


def check_backend(backend: str, integrator: str | None = None, ensemble: bool = False) -> str:
    """The canonical backend name (:func:`visviva._backends.check_backend`), and for ``"cuda"``
    an :class:`~visviva.errors.InvalidInputError` when ``integrator`` has no GPU version (for
    an ensemble when ``ensemble``)."""
    name = _check(backend)
    able = GPU_ENSEMBLE_INTEGRATORS if ensemble else GPU_INTEGRATORS
    if name == "cuda" and integrator is not None and integrator not in able:
        what = "ensembles of the" if ensemble else "the"
        raise InvalidInputError(
            f"backend='cuda' runs {what} {able} integrator(s) so far, not {integrator!r}; use "
            "backend='cpu' (or integrator='leapfrog')."
        )
    return name


#: Integrators whose GPU run is their CPU kernel with the gravity on the GPU
#: (:mod:`visviva.nbody.gpu_force`): additional forces and event checks run as on the CPU.
CPU_KERNEL_INTEGRATORS = ("ias15", "whfast")


def _extras(sim) -> bool:
    """True when ``sim`` has additional forces or collision, encounter or escape checks."""
    return bool(sim.forces or sim.collision != "none" or sim.encounter_distance
                or sim.exit_max_distance)


#: Integrators whose GPU ensembles run additional forces and the collision, encounter and
#: escape checks.
EVENT_ENSEMBLE_INTEGRATORS = ("leapfrog", "whfast", "ias15")


def _check_supported(sim, ensemble: bool) -> None:
    if ensemble and _extras(sim) and sim.integrator not in EVENT_ENSEMBLE_INTEGRATORS:
        raise InvalidInputError(
            "backend='cuda' integrates ensembles with additional forces or collision, "
            f"encounter or escape checks for the {EVENT_ENSEMBLE_INTEGRATORS} integrators "
            "only: use backend='cpu' for this ensemble (or, for one simulation, on the GPU: "
            "Simulation(..., backend='cuda'))."
        )
    check_backend("cuda", sim.integrator, ensemble)


def check_ensemble(members) -> None:
    """Raise :class:`~visviva.errors.InvalidInputError` (naming the member) when a member of a
    ``backend="cuda"`` ensemble uses what the GPU ensemble kernels do not run."""
    for k, sim in enumerate(members):
        try:
            _check_supported(sim, ensemble=True)
        except InvalidInputError as exc:
            raise InvalidInputError(f"ensemble member {k}: {exc}") from None


def _finish(sim, state, n, h, t_final) -> None:
    """Clock and counters after a GPU run, as the CPU kernel leaves them."""
    fstate, istate = state["fstate"], state["istate"]
    istate[_nc.I_K] += n if h > 0.0 else -n
    istate[_nc.I_STEPS] += n
    if n:
        fstate[_nc.F_DT_LAST] = h
    fstate[_nc.F_T] = t_final
    istate[_nc.I_NOUT] = 1
    if not (np.all(np.isfinite(state["x"])) and np.all(np.isfinite(state["v"]))):
        istate[_nc.I_INT_VALID] = 0
        raise _non_finite(t_final)


def _non_finite(t_final) -> InvalidStateError:
    return InvalidStateError(
        f"the GPU leapfrog produced NaN or infinite positions or velocities by t = "
        f"{float(t_final)!r}: use a smaller dt or softening > 0."
    )


def begin_gpu_run(sim, t, ensemble: bool = False):
    """Check that ``sim`` (an ensemble's member) can run on the GPU to the one time ``t`` and
    prepare it (:meth:`visviva.Simulation.begin_run`, :meth:`~visviva.Simulation.kernel_inputs`);
    returns the target time (simulation units) and the indices of the massive particles."""
    if np.ndim(t) != 0:
        raise ShapeError("backend='cuda' integrates to one time per call; got an array of "
                         "times (call integrate once per output time).")
    _check_supported(sim, ensemble)
    target = float(sim.begin_run(t)[0])
    _, _, massive = sim.kernel_inputs(parallel=False)
    return target, massive


def integrate_simulation(sim, t, progress: bool = False):
    """Integrate one simulation to the time(s) ``t`` on the GPU, as
    :meth:`visviva.Simulation.integrate` does on the CPU (same arguments, same result: None for
    one time, a :class:`~visviva.nbody.trajectory.Trajectory` for an array of times).

    Leapfrog: the state stays on the device between steps (N threads per kernel), one run per
    output time (:func:`_leapfrog_to`), each landing on the time as the CPU kernel does; WHFast
    and IAS15: the CPU kernel through all the output times, its gravity on the GPU
    (:mod:`visviva.nbody.gpu_force`)."""
    from .trajectory import Recording

    _check_supported(sim, ensemble=False)
    scalar = np.ndim(t) == 0
    times = sim.begin_run(t)
    with Recording(sim, times, progress) as rec:
        if sim.integrator in CPU_KERNEL_INTEGRATORS or _extras(sim):
            from .gpu_force import run_with_gpu_gravity

            if sim.integrator == "ias15":
                from .gpu_ias15 import evaluator
            elif sim.integrator == "whfast":
                from .gpu_whfast import evaluator
            else:  # the leapfrog with forces or event checks: its CPU kernel
                from .gpu_force import every_call as evaluator
            run_with_gpu_gravity(sim, rec, evaluator)
        else:
            _, _, massive = sim.kernel_inputs(parallel=False)
            state = sim.state_arrays()
            for k, target in enumerate(times):
                done0 = rec.before_call()
                _leapfrog_to(sim, state, massive, float(target))
                state["istate"][_nc.I_NOUT] = k + 1
                rec.out_t[k] = sim.t
                rec.chunk_x[k] = state["x"]
                rec.chunk_v[k] = state["v"]
                rec.after_call(_st.OK, done0)
    return None if scalar else rec.trajectory()


def _leapfrog_to(sim, state, massive, target: float) -> None:
    """The leapfrog on the GPU to the one time ``target`` (simulation units): the internal state
    on the device for the steps of :func:`plan`, then the output copy."""
    from numba import cuda

    from ..core.cuda import kernels as K

    gravity = DeviceGravity(sim.G * state["m"], massive, state["fstate"][_nc.F_SOFT2])
    n, h, rem, t_final = plan(state, target)
    grid = K.blocks(sim.N)

    def dkd(x, v, step):
        K.drift[grid, K.THREADS](x, v, 0.5 * step)
        acc = gravity(x)
        K.kick_drift[grid, K.THREADS](x, v, acc, step, 0.5 * step)

    xi = cuda.to_device(np.ascontiguousarray(state["buf"][_XI]))
    vi = cuda.to_device(np.ascontiguousarray(state["buf"][_VI]))
    for _ in range(n):
        dkd(xi, vi, h)
    state["buf"][_XI] = xi.copy_to_host()
    state["buf"][_VI] = vi.copy_to_host()
    state["x"][:] = state["buf"][_XI]
    state["v"][:] = state["buf"][_VI]
    if rem != 0.0:
        dkd(xi, vi, rem)  # the output copy (the internal state is already saved)
        state["x"][:] = xi.copy_to_host()
        state["v"][:] = vi.copy_to_host()
    _finish(sim, state, n, h, t_final)


def integrate_ensemble(members, t) -> list:
    """Advance the simulations ``members`` (in place) to ``t`` on the GPU, one thread per member;
    returns ``[(index, exception), ...]`` as the CPU path does (the member-by-member path of
    :func:`visviva.nbody.ensemble.advance_members`: each member checked as a lone run, then
    the members that may run packed together)."""
    return _packed_each(members, t)


def _packed_each(members, t) -> list:
    """:func:`integrate_ensemble`: each member checked as a lone run, then the members that may
    run packed together (one pack per output time in simulation units and set of additional
    force functions); an IAS15 member with ``PAIR_MIN_N`` massive particles or more runs as
    its own GPU simulation (:func:`integrate_simulation`, the same as its lone run)."""
    from .ensemble_pack import Pack
    from .forces import force_key
    from .gpu_ensemble_ias15 import runs_alone

    run = _pack_runner(members[0].integrator)
    errors, groups = [], {}
    for k, sim in enumerate(members):
        try:
            if sim.integrator == "ias15" and runs_alone(sim):
                integrate_simulation(sim, t)  # a large member: its lone GPU run
                continue
            target, _ = begin_gpu_run(sim, t, ensemble=True)
        except Exception as exc:
            errors.append((k, exc))
            continue
        groups.setdefault((target, force_key(sim)), []).append(k)
    for (target, _), ks in groups.items():
        pack = Pack([members[k] for k in ks], members[ks[0]].integrator_info.n_buf)
        errors += [(ks[j], exc) for j, exc in run(pack, target, t)]
    return sorted(errors, key=lambda e: e[0])


def _pack_runner(integrator: str):
    """The ``run(pack, target, t)`` of the GPU ensemble kernel of ``integrator``."""
    if integrator == "ias15":
        from .gpu_ensemble_ias15 import run
    elif integrator == "leapfrog":
        from .gpu_ensemble_leapfrog import run
    else:
        from .gpu_ensemble_whfast import run
    return run


def integrate_pack(pack, t):
    """Advance an ensemble's packed members (:class:`visviva.nbody.ensemble_pack.Pack`) to ``t``
    on the GPU, one thread per member, the plan and bookkeeping done on whole arrays; returns
    the errors, or None when the per-member path must run this call (it then raises what the
    GPU cannot run)."""
    pack.stale = False
    fs = pack.fstate
    integrator = pack.members[0].integrator
    if integrator not in GPU_ENSEMBLE_INTEGRATORS:
        return None
    if integrator not in EVENT_ENSEMBLE_INTEGRATORS and (
            not pack.collision_off or np.any(fs[:, _nc.F_ENCOUNTER] != 0.0)
            or np.any(fs[:, _nc.F_EXIT] != 0.0)):
        return None
    if integrator == "ias15":
        from .gpu_ensemble_ias15 import any_alone

        if any_alone(pack.moff):  # a large member runs alone: the per-member path
            return None
    target = pack.target(t)
    if target is None:
        return None
    return _pack_runner(integrator)(pack, target, t)
