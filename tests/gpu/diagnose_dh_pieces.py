"""Each democratic heliocentric piece of the general WHFast GPU kernel, alone, on the device and
on the CPU (a diagnosis for the next lent GPU, not a test: ``python tests/gpu/diagnose_dh_pieces.py``).

On an NVIDIA H200 (2026-11-26) :func:`visviva.core.cuda.whfast.build_general`'s kernel was wrong
for democratic heliocentric (DH) members (1.3 relative in positions) and right for Jacobi
members with correctors (1e-16). The lone ``Simulation(backend="cuda")`` runs that were checked
right on that GPU run the CPU kernel with the GPU's gravity, so the device twins of the DH
pieces (the coordinate transforms, the jump, the DH interaction kick, the Kepler drift about the
central body, the gravity over ``massive[1:]``, the zeroing ``aj[:, :] = 0.0``) had never run
on a GPU. This script builds each piece's twin exactly as ``build_general`` builds the tree
(the same swaps, the same ``buf`` slicing and reshaping, the strided ``eta`` view), runs it in
a one-thread kernel on one member and prints ``piece=largest relative difference`` from the
CPU kernel's own function on the same arrays (0 expected; a Jacobi kick as the control).
Under numba's CUDA simulator every line prints 0.0.

On the H200 (2026-11-27) all twelve agreed to 7e-19, while the whole kernel run for one DH
member alone (one thread) was 0.4-67% off after one step (``diagnose_whfast_general.py
--alone``), the same without NVVM's optimisations and with a 64 kB stack. Those twelve take
``dh`` (and the corrector ``order``) as the literal constants ``True`` (and 0), so numba prunes
the Jacobi branches; the kernel computes them at run time from ``istate``, as
``_whfast`` does. The ``rt_*`` pieces take them at run time the same way, the ``lit_*`` ones as
literals (the transforms, the drift with its jumps and the synchronised step, which the twelve
do not cover): the first ``rt_*`` piece that differs while its ``lit_*`` twin agrees names the
fault. ``body`` runs the kernel's whole run body (``_whfast``'s twin, built as the kernel builds
it) for one member and one output time in a one-thread kernel, on the member's own arrays
(not through the ensemble's packing): wrong here, the fault is inside the body; right here, in
what the ensemble kernel passes it. Every piece runs for the members 1 (a star, three planets, a
test particle), 0 (a star, two planets) and 2 (a star, four planets) of
``check_whfast_ensemble.member``: ``name``, ``name_m0``, ``name_m2`` lines. Arguments: only the
pieces whose names start so (``rt_ lit_ body``).
"""

from __future__ import annotations

import os
import sys

import numpy as np
from numba import cuda

sys.path.insert(0, os.path.dirname(__file__))
from check_whfast_ensemble import member  # noqa: E402

from visviva.core import gravity  # noqa: E402
from visviva.core import nbody_whfast as W  # noqa: E402
from visviva.core.cuda.twins import device_twin  # noqa: E402
from visviva.core.cuda.whfast import general_swaps  # noqa: E402
from visviva.core.gravity import FEW, GWORK_ROWS  # noqa: E402
from visviva.core.nbody_common import F_G, F_SOFT2, I_CORRECTOR, I_WH_COORDINATES  # noqa: E402

NB, XJ, VJ, ACC, AJ, ETA, XS, VS = W.N_BUF, W._XJ, W._VJ, W._ACC, W._AJ, W._ETA, W._XS, W._VS
H = 0.01

force = device_twin(gravity.no_force)
REPLACE = general_swaps(force)  # as build_general swaps them (the solver never inlined)
gravity_few = REPLACE[gravity.gravity]


def twin(fn):
    return device_twin(fn, REPLACE)


to_dh = twin(W.to_democratic_heliocentric)
from_dh = twin(W.from_democratic_heliocentric)
jump = twin(W._jump)
dh_kick = twin(W._dh_interaction_kick)
drift = twin(W._kepler_drift)
dh_step = twin(W._dh_step)
kick = twin(W._kick)
first_half = twin(W._first_half)
synchronise = twin(W._synchronise)
to_internal = twin(W._to_internal)
from_internal = twin(W._from_internal)
drift_jumps = twin(W._drift)
dkd_step = twin(W._dkd_step)
body = twin(W._whfast)


@cuda.jit(device=True)
def layout(flat, m):
    """``buf`` and ``eta`` as the general kernel makes them (eta filled as ``_whfast`` does)."""
    n = m.shape[0]
    buf = flat.reshape((NB, n, 3))
    eta = buf[ETA, :, 0]
    s = 0.0
    for i in range(n):
        s += m[i]
        eta[i] = s
    return buf, eta


@cuda.jit
def k_to_dh(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    to_dh(x, m, eta, buf[XJ], False)
    to_dh(v, m, eta, buf[VJ], True)


@cuda.jit
def k_from_dh(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    from_dh(buf[XJ], m, eta, x, False)
    from_dh(buf[VJ], m, eta, v, True)


@cuda.jit
def k_jump(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    jump(buf[XJ], buf[VJ], m, 0.5 * H)


@cuda.jit
def k_dh_kick(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    dh_kick(buf[VJ], buf[ACC], buf[AJ], m, eta, H)


@cuda.jit
def k_drift_dh(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    st[0] = drift(buf[XJ], buf[VJ], eta, fstate[F_G], H, True)


@cuda.jit
def k_gravity_rest(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    gravity_few(x, m, fstate[F_G], fstate[F_SOFT2], massive[1:], buf[ACC], x, 0)


@cuda.jit
def k_zero_slice(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    aj = buf[AJ]
    aj[:, :] = 0.0


@cuda.jit
def k_dh_step(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    st[0] = dh_step(0.5 * H, buf[XJ], buf[VJ], m, eta, fstate[F_G], H, x, v, massive, fstate,
                    istate, x, force, params, buf[ACC], buf[AJ], 0)


@cuda.jit
def k_kick_dh(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    kick(0.0, buf[XJ], buf[VJ], m, eta, fstate[F_G], H, x, v, massive, fstate, istate, x,
         force, params, buf[ACC], buf[AJ], True, 0)


@cuda.jit
def k_kick_jacobi(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    kick(0.0, buf[XJ], buf[VJ], m, eta, fstate[F_G], H, x, v, massive, fstate, istate, x,
         force, params, buf[ACC], buf[AJ], False, 0)


@cuda.jit
def k_first_half_dh(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    st[0] = first_half(x, v, m, eta, fstate[F_G], H, 0.0, buf[XJ], buf[VJ], massive, fstate,
                       istate, x, force, params, buf[ACC], buf[AJ], 0, True, 0)


@cuda.jit
def k_synchronise_dh(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    st[0] = synchronise(buf[XJ], buf[VJ], buf[XS], buf[VS], m, eta, fstate[F_G], 0.5 * H, x, v,
                        0, 0.0, massive, fstate, istate, x, force, params, buf[ACC], buf[AJ],
                        True, 0)


@cuda.jit(device=True)
def flags(istate):
    """``dh`` and the corrector order at run time, as ``_whfast`` computes them."""
    dh = istate[I_WH_COORDINATES] == W.DEMOCRATIC_HELIOCENTRIC
    order = 0 if dh else istate[I_CORRECTOR]
    return dh, order


@cuda.jit
def k_rt_to_internal(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    dh, order = flags(istate)
    to_internal(x, v, m, eta, buf[XJ], buf[VJ], dh)


@cuda.jit
def k_lit_to_internal(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    to_internal(x, v, m, eta, buf[XJ], buf[VJ], True)


@cuda.jit
def k_rt_from_internal(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    dh, order = flags(istate)
    from_internal(buf[XJ], buf[VJ], m, eta, x, v, dh)


@cuda.jit
def k_lit_from_internal(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    from_internal(buf[XJ], buf[VJ], m, eta, x, v, True)


@cuda.jit
def k_rt_kepler_drift(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    dh, order = flags(istate)
    st[0] = drift(buf[XJ], buf[VJ], eta, fstate[F_G], H, dh)


@cuda.jit
def k_rt_drift_jumps(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    dh, order = flags(istate)
    st[0] = drift_jumps(buf[XJ], buf[VJ], m, eta, fstate[F_G], H, 0.5 * H, 0.5 * H, dh)


@cuda.jit
def k_lit_drift_jumps(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    st[0] = drift_jumps(buf[XJ], buf[VJ], m, eta, fstate[F_G], H, 0.5 * H, 0.5 * H, True)


@cuda.jit
def k_rt_kick(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    dh, order = flags(istate)
    kick(0.0, buf[XJ], buf[VJ], m, eta, fstate[F_G], H, x, v, massive, fstate, istate, x,
         force, params, buf[ACC], buf[AJ], dh, 0)


@cuda.jit
def k_rt_first_half(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    dh, order = flags(istate)
    st[0] = first_half(x, v, m, eta, fstate[F_G], H, 0.0, buf[XJ], buf[VJ], massive, fstate,
                       istate, x, force, params, buf[ACC], buf[AJ], order, dh, 0)


@cuda.jit
def k_rt_synchronise(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    dh, order = flags(istate)
    st[0] = synchronise(buf[XJ], buf[VJ], buf[XS], buf[VS], m, eta, fstate[F_G], 0.5 * H, x, v,
                        order, 0.0, massive, fstate, istate, x, force, params, buf[ACC],
                        buf[AJ], dh, 0)


@cuda.jit
def k_rt_dkd_step(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    dh, order = flags(istate)
    st[0] = dkd_step(x, v, m, eta, fstate[F_G], H, 0.0, buf[XJ], buf[VJ], massive, fstate,
                     istate, x, force, params, buf[ACC], buf[AJ], order, dh, 0)


@cuda.jit
def k_lit_dkd_step(flat, x, v, m, massive, fstate, istate, params, st):
    buf, eta = layout(flat, m)
    st[0] = dkd_step(x, v, m, eta, fstate[F_G], H, 0.0, buf[XJ], buf[VJ], massive, fstate,
                     istate, x, force, params, buf[ACC], buf[AJ], 0, True, 0)


@cuda.jit
def k_body(x, v, m, massive, radius, fstate, istate, flat, params, t_out, out_t, out_x, out_v,
           st):
    """The run body for one member through ``t_out``, as the ensemble kernel calls it."""
    n = x.shape[0]
    T = t_out.shape[0]
    st[0] = body(x, v, m, massive, radius, fstate, istate, flat.reshape((NB, n, 3)), x, force,
                 params, t_out, out_t, out_x.reshape((T, n, 3)), out_v.reshape((T, n, 3)), 0,
                 True, None)


def run_body(sim, coordinates="democratic_heliocentric", t_end=0.0125):
    """``body`` on the device and the CPU's run body (``whfast_run_few``) on copies of ``sim``'s
    arrays (in ``coordinates``), one output time ``t_end`` (about one step): the largest
    relative difference of positions, velocities and the internal state, and both statuses."""
    sim = sim.copy()
    sim.coordinates = coordinates
    t_out = np.array([t_end])
    sim.begin_run(t_out)
    fn, params, massive = sim.kernel_inputs(parallel=False)
    arrays = sim.state_arrays()
    names = ("x", "v", "m", "radius", "fstate", "istate", "buf")
    cpu = {k: np.ascontiguousarray(arrays[k]).copy() for k in names}
    gpu = {k: a.copy() for k, a in cpu.items()}
    n = len(cpu["m"])
    massive = np.ascontiguousarray(massive, dtype=np.int64)
    params = np.ascontiguousarray(params, dtype=float) if len(params) else np.zeros(1)
    out = [np.zeros(1), np.zeros((1, n, 3)), np.zeros((1, n, 3))]
    want = W.whfast_run_few(cpu["x"], cpu["v"], cpu["m"], massive, cpu["radius"], cpu["fstate"],
                            cpu["istate"], cpu["buf"].reshape(NB, n, 3),
                            np.zeros((GWORK_ROWS, n)), gravity.no_force, params, t_out, *out)
    d = {k: cuda.to_device(gpu[k].reshape(-1) if k == "buf" else gpu[k]) for k in names}
    st = cuda.to_device(np.zeros(1, dtype=np.int64))
    k_body[1, 1](d["x"], d["v"], d["m"], cuda.to_device(massive), d["radius"], d["fstate"],
                 d["istate"], d["buf"], cuda.to_device(params), cuda.to_device(t_out),
                 cuda.to_device(np.zeros(1)), cuda.to_device(np.zeros(3 * n)),
                 cuda.to_device(np.zeros(3 * n)), st)
    got = {k: d[k].copy_to_host() for k in ("x", "v", "buf")}
    diffs = [rel(got["x"], cpu["x"]), rel(got["v"], cpu["v"]),
             rel(got["buf"], cpu["buf"].reshape(-1))]
    return diffs, int(st.copy_to_host()[0]), int(want)


def cpu_layout(flat, m):
    n = m.shape[0]
    buf = flat.reshape((NB, n, 3))
    eta = buf[ETA, :, 0]
    eta[:] = np.cumsum(m)  # the same sums, in the same order, as the loop
    return buf, eta


def cpu_piece(name, flat, x, v, m, massive, fstate, istate, params):
    """The CPU kernel's own function for piece ``name``: returns its status code (0: none)."""
    buf, eta = cpu_layout(flat, m)
    G = fstate[F_G]
    gwork = np.zeros((GWORK_ROWS, m.shape[0]))
    rest = (massive, fstate, istate, gwork, gravity.no_force, params, buf[ACC], buf[AJ])
    if name == "to_dh":
        W.to_democratic_heliocentric(x, m, eta, buf[XJ], False)
        W.to_democratic_heliocentric(v, m, eta, buf[VJ], True)
    elif name == "from_dh":
        W.from_democratic_heliocentric(buf[XJ], m, eta, x, False)
        W.from_democratic_heliocentric(buf[VJ], m, eta, v, True)
    elif name == "jump":
        W._jump(buf[XJ], buf[VJ], m, 0.5 * H)
    elif name == "dh_kick":
        W._dh_interaction_kick(buf[VJ], buf[ACC], buf[AJ], m, eta, H)
    elif name == "drift_dh":
        return W._kepler_drift(buf[XJ], buf[VJ], eta, G, H, True)
    elif name == "gravity_rest":
        gravity.gravity(x, m, G, fstate[F_SOFT2], massive[1:], buf[ACC], gwork, FEW)
    elif name == "zero_slice":
        buf[AJ][:, :] = 0.0
    elif name == "dh_step":
        return W._dh_step(0.5 * H, buf[XJ], buf[VJ], m, eta, G, H, x, v, *rest, FEW)
    elif name == "kick_dh":
        W._kick(0.0, buf[XJ], buf[VJ], m, eta, G, H, x, v, *rest, True, FEW)
    elif name == "kick_jacobi":
        W._kick(0.0, buf[XJ], buf[VJ], m, eta, G, H, x, v, *rest, False, FEW)
    elif name.endswith("to_internal"):
        W._to_internal(x, v, m, eta, buf[XJ], buf[VJ], True)
    elif name.endswith("from_internal"):
        W._from_internal(buf[XJ], buf[VJ], m, eta, x, v, True)
    elif name == "rt_kepler_drift":
        return W._kepler_drift(buf[XJ], buf[VJ], eta, G, H, True)
    elif name.endswith("drift_jumps"):
        return W._drift(buf[XJ], buf[VJ], m, eta, G, H, 0.5 * H, 0.5 * H, True)
    elif name == "rt_kick":
        W._kick(0.0, buf[XJ], buf[VJ], m, eta, G, H, x, v, *rest, True, FEW)
    elif name == "rt_first_half":
        return W._first_half(x, v, m, eta, G, H, 0.0, buf[XJ], buf[VJ], *rest, 0, True, FEW)
    elif name == "rt_synchronise":
        return W._synchronise(buf[XJ], buf[VJ], buf[XS], buf[VS], m, eta, G, 0.5 * H, x, v, 0,
                              0.0, massive, fstate, istate, gwork, gravity.no_force, params,
                              buf[ACC], buf[AJ], True, FEW)
    elif name.endswith("dkd_step"):
        return W._dkd_step(x, v, m, eta, G, H, 0.0, buf[XJ], buf[VJ], *rest, 0, True, FEW)
    elif name == "first_half_dh":
        return W._first_half(x, v, m, eta, G, H, 0.0, buf[XJ], buf[VJ], *rest, 0, True, FEW)
    elif name == "synchronise_dh":
        return W._synchronise(buf[XJ], buf[VJ], buf[XS], buf[VS], m, eta, G, 0.5 * H, x, v, 0,
                              0.0, massive, fstate, istate, gwork, gravity.no_force, params,
                              buf[ACC], buf[AJ], True, FEW)
    return 0


PIECES = {"to_dh": k_to_dh, "from_dh": k_from_dh, "jump": k_jump, "dh_kick": k_dh_kick,
          "drift_dh": k_drift_dh, "gravity_rest": k_gravity_rest, "zero_slice": k_zero_slice,
          "dh_step": k_dh_step, "kick_dh": k_kick_dh, "kick_jacobi": k_kick_jacobi,
          "first_half_dh": k_first_half_dh, "synchronise_dh": k_synchronise_dh,
          # the same with ``dh`` and ``order`` computed at run time, as the kernel does, and
          # literal controls for the pieces not above
          "rt_to_internal": k_rt_to_internal, "lit_to_internal": k_lit_to_internal,
          "rt_from_internal": k_rt_from_internal, "lit_from_internal": k_lit_from_internal,
          "rt_kepler_drift": k_rt_kepler_drift, "rt_drift_jumps": k_rt_drift_jumps,
          "lit_drift_jumps": k_lit_drift_jumps, "rt_kick": k_rt_kick,
          "rt_first_half": k_rt_first_half, "rt_synchronise": k_rt_synchronise,
          "rt_dkd_step": k_rt_dkd_step, "lit_dkd_step": k_lit_dkd_step}


def inputs(k=1):
    """Member ``k`` (1: a star, three planets, a test particle) with a filled ``buf``: its DH
    coordinates in the XJ/VJ slots and made-up numbers of the right size in ACC/AJ/XS/VS."""
    sim = member(k)
    x = np.ascontiguousarray(sim.positions, dtype=float)
    v = np.ascontiguousarray(sim.velocities, dtype=float)
    m = np.ascontiguousarray(sim.masses, dtype=float)
    n = len(m)
    massive = np.flatnonzero(m > 0.0).astype(np.int64)
    fstate = sim.state_arrays()["fstate"].copy()
    fstate[F_G] = sim.G
    fstate[F_SOFT2] = 0.0
    istate = sim.state_arrays()["istate"].copy()
    istate[I_WH_COORDINATES] = W.DEMOCRATIC_HELIOCENTRIC  # the rt_* pieces read it
    flat = np.zeros(NB * n * 3)
    buf, eta = cpu_layout(flat, m)
    W.to_democratic_heliocentric(x, m, eta, buf[XJ], False)
    W.to_democratic_heliocentric(v, m, eta, buf[VJ], True)
    rng = np.random.default_rng(7)
    for slot in (ACC, AJ, XS, VS):
        buf[slot] = rng.normal(size=(n, 3))
    return flat, x, v, m, massive, fstate, istate, np.zeros(1)


def rel(a, b):
    scale = np.max(np.abs(b)) or 1.0
    return float(np.max(np.abs(np.nan_to_num(a, nan=1e300) - b)) / scale)


def wanted(name):
    """True when ``name`` is among the pieces the command line asks for (all without one)."""
    return not sys.argv[1:] or name.startswith(tuple(sys.argv[1:]))


def main():
    for k in (1, 0, 2):
        tag = "" if k == 1 else f"_m{k}"
        base = inputs(k)
        for name, kernel in PIECES.items():
            if not wanted(name):
                continue
            flat, x, v, m, massive, fstate, istate, params = (a.copy() for a in base)
            try:
                d = [cuda.to_device(a) for a in (flat, x, v, m, massive, fstate, istate,
                                                  params)]
                st = cuda.to_device(np.zeros(1, dtype=np.int64))
                kernel[1, 1](*d, st)
                got = [d[0].copy_to_host(), d[1].copy_to_host(), d[2].copy_to_host()]
                got_st = int(st.copy_to_host()[0])
            except Exception as exc:  # print and go on to the next piece
                print(f"{name}{tag}_error={type(exc).__name__}: "
                      f"{str(exc).splitlines()[0][:150]}")
                continue
            want_st = cpu_piece(name, flat, x, v, m, massive, fstate, istate, params)
            diffs = [rel(g, w) for g, w in zip(got, (flat, x, v), strict=True)]
            print(f"{name}{tag}={max(diffs)!r}", flush=True)
            if max(diffs) != 0.0 or got_st != want_st:
                print(f"{name}{tag}_detail=buf {diffs[0]!r} x {diffs[1]!r} v {diffs[2]!r} "
                      f"status {got_st}/{want_st}")
        for coordinates in ("democratic_heliocentric", "jacobi"):
            name = "body" if coordinates != "jacobi" else "body_jacobi"
            if not wanted(name):
                continue
            try:
                diffs, got_st, want_st = run_body(member(k), coordinates)
            except Exception as exc:
                print(f"{name}{tag}_error={type(exc).__name__}: "
                      f"{str(exc).splitlines()[0][:150]}")
                continue
            print(f"{name}{tag}={max(diffs)!r}", flush=True)
            print(f"{name}{tag}_detail=x {diffs[0]!r} v {diffs[1]!r} buf {diffs[2]!r} "
                  f"status {got_st}/{want_st}")


if __name__ == "__main__":
    main()
