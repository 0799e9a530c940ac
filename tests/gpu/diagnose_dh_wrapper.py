"""Where between the run body and the ensemble the democratic heliocentric (DH) WHFast ensemble
goes wrong on a real GPU (a diagnosis, not a test: ``python tests/gpu/diagnose_dh_wrapper.py
VARIANT``; without one, every variant, each in its own process).

On an NVIDIA H200 (2026-11-28) every DH piece of the general kernel and its whole run body, in a
one-thread kernel on the member's own arrays, agreed with the CPU to 7e-19
(``diagnose_dh_pieces.py``), while the ensemble kernel gave 0.4-67 % for a DH member alone
(2026-11-27, ``diagnose_whfast_general.py --alone``); the packed arrays equal the lone run's bit
for bit (checked under the simulator). Each variant runs member 1 of
``check_whfast_ensemble.member`` (DH, one step and a quarter: t = 0.0125) one way and prints
``VARIANT=largest relative difference`` from the CPU's lone run (``whfast_run_few``) over the
positions, velocities and ``buf``, with the status codes:

- ``ensemble``: ``vv.Ensemble.from_simulations([sim], backend="cuda")`` (the user's path);
- ``ensemble3``: members 0, 1, 2 in one GPU ensemble (the worst member);
- ``kernel128``: the ensemble's kernel (its x and v flat since 2026-11-28) (``kernel_for``/``build_general``) launched as
  ``run_general`` launches it (one block of 128 threads, ``device_array`` outputs);
- ``kernel1``: the same launched with one thread;
- ``kernel128z``: 128 threads, outputs zeroed first;
- ``body_pack``: the run body in a one-thread kernel (``diagnose_dh_pieces.k_body``) on the
  pack's arrays;
- ``whole``: a kernel calling the body on the pack's whole arrays (no slicing, rows of
  ``fstate``/``istate``), to tell the slicing from the rest.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
from numba import cuda

sys.path.insert(0, os.path.dirname(__file__))

T_END = 0.0125
VARIANTS = ("ensemble", "ensemble3", "kernel128", "kernel1", "kernel128z", "body_pack", "whole")


def rel(a, b):
    scale = np.max(np.abs(b)) or 1.0
    return float(np.max(np.abs(np.nan_to_num(a, nan=1e300) - b)) / scale)


def dh_member(k):
    from check_whfast_ensemble import member

    sim = member(k)
    sim.coordinates = "democratic_heliocentric"
    return sim


def cpu_lone(sim):
    """The lone CPU run of a copy of ``sim`` to T_END: x, v, buf (flat), status."""
    from visviva.core import gravity
    from visviva.core import nbody_whfast as W
    from visviva.core.gravity import GWORK_ROWS

    ref = sim.copy()
    t_out = np.array([T_END])
    ref.begin_run(t_out)
    _, params, massive = ref.kernel_inputs(parallel=False)
    a = {k: np.ascontiguousarray(v).copy() for k, v in ref.state_arrays().items()}
    n = len(a["m"])
    params = np.ascontiguousarray(params, dtype=float) if len(params) else np.zeros(1)
    st = W.whfast_run_few(a["x"], a["v"], a["m"], np.ascontiguousarray(massive, np.int64),
                          a["radius"], a["fstate"], a["istate"], a["buf"].reshape(W.N_BUF, n, 3),
                          np.zeros((GWORK_ROWS, n)), gravity.no_force, params, t_out,
                          np.zeros(1), np.zeros((1, n, 3)), np.zeros((1, n, 3)))
    return a["x"], a["v"], a["buf"].reshape(-1), int(st)


def pack_of(sim):
    """The pack ``run_general`` would launch for ``sim`` (a copy) and its target time."""
    from visviva.nbody.ensemble_pack import Pack
    from visviva.nbody.gpu import begin_gpu_run

    s = sim.copy()
    target, _ = begin_gpu_run(s, T_END, ensemble=True)
    return Pack([s], s.integrator_info.n_buf), target, s


def report(name, got, want):
    x, v, buf, st = got
    wx, wv, wbuf, wst = want
    d = [rel(x, wx), rel(v, wv), rel(buf, wbuf)]
    print(f"{name}={max(d)!r}", flush=True)
    print(f"{name}_detail=x {d[0]!r} v {d[1]!r} buf {d[2]!r} status {st}/{wst}", flush=True)


def launch_kernel(sim, threads, zero):
    from numba import cuda

    from visviva.core.cuda import whfast as CW
    from visviva.nbody.gpu_forces import kernel_for

    pack, target, s = pack_of(sim)
    kernel = kernel_for("whfast", s, CW.build_general)
    M, P = 1, len(pack.x)
    state = pack.to_device(("fstate", "istate", "buf"))
    flat = {k: cuda.to_device(getattr(pack, k).reshape(-1)) for k in ("x", "v")}  # as run_general
    d = {**pack.to_device(("m", "massive", "moff", "radius", "poff", "params", "qoff")),
         **state, **flat}
    if zero:
        status = cuda.to_device(np.zeros(M, dtype=np.int64))
        out = [cuda.to_device(np.zeros(3 * P)), cuda.to_device(np.zeros(3 * P))]
        out_t = cuda.to_device(np.zeros((M, 1)))
    else:
        status = cuda.device_array(M, dtype=np.int64)
        out = [cuda.device_array(3 * P), cuda.device_array(3 * P)]
        out_t = cuda.device_array((M, 1))
    kernel[1, threads](*(d[k] for k in ("x", "v", "m", "massive", "moff", "radius", "poff",
                                        "fstate", "istate", "buf", "params", "qoff")),
                       cuda.to_device(np.array([target])), out_t, *out, status)
    pack.from_device(state)
    for k, arr in flat.items():
        getattr(pack, k)[:] = arr.copy_to_host().reshape(-1, 3)
    return pack.x.copy(), pack.v.copy(), pack.buf.copy(), int(status.copy_to_host()[0])


def body_pack(sim):
    import diagnose_dh_pieces as P
    from numba import cuda

    pack, target, _ = pack_of(sim)
    n = len(pack.m)
    d = {k: cuda.to_device(np.ascontiguousarray(getattr(pack, k)))
         for k in ("x", "v", "m", "massive", "radius", "buf", "params")}
    d["fstate"] = cuda.to_device(pack.fstate[0].copy())
    d["istate"] = cuda.to_device(pack.istate[0].copy())
    st = cuda.to_device(np.zeros(1, dtype=np.int64))
    P.k_body[1, 1](d["x"], d["v"], d["m"], d["massive"], d["radius"], d["fstate"], d["istate"],
                   d["buf"], d["params"], cuda.to_device(np.array([target])),
                   cuda.to_device(np.zeros(1)), cuda.to_device(np.zeros(3 * n)),
                   cuda.to_device(np.zeros(3 * n)), st)
    return (d["x"].copy_to_host(), d["v"].copy_to_host(), d["buf"].copy_to_host(),
            int(st.copy_to_host()[0]))


def whole(sim):
    import diagnose_dh_pieces as P
    from numba import cuda

    from visviva.core import nbody_whfast as W

    body, force, NB = P.body, P.force, W.N_BUF

    @cuda.jit
    def k_whole(x, v, m, massive, radius, fstate, istate, buf, params, t_out, out_t, out_x,
                out_v, status):
        n = x.shape[0]
        T = t_out.shape[0]
        status[0] = body(x, v, m, massive, radius, fstate[0], istate[0],
                         buf.reshape((NB, n, 3)), x, force, params, t_out, out_t[0],
                         out_x.reshape((T, n, 3)), out_v.reshape((T, n, 3)), 0, True, None)

    pack, target, _ = pack_of(sim)
    n = len(pack.m)
    d = {k: cuda.to_device(np.ascontiguousarray(getattr(pack, k)))
         for k in ("x", "v", "m", "massive", "radius", "fstate", "istate", "buf", "params")}
    st = cuda.to_device(np.zeros(1, dtype=np.int64))
    k_whole[1, 1](d["x"], d["v"], d["m"], d["massive"], d["radius"], d["fstate"], d["istate"],
                  d["buf"], d["params"], cuda.to_device(np.array([target])),
                  cuda.to_device(np.zeros((1, 1))), cuda.to_device(np.zeros(3 * n)),
                  cuda.to_device(np.zeros(3 * n)), st)
    return (d["x"].copy_to_host(), d["v"].copy_to_host(), d["buf"].copy_to_host(),
            int(st.copy_to_host()[0]))


def run(variant):
    import visviva as vv

    if variant in ("ensemble", "ensemble3"):
        ks = (1,) if variant == "ensemble" else (0, 1, 2)
        sims = [dh_member(k) for k in ks]
        ens = vv.Ensemble.from_simulations(sims, backend="cuda")
        ens.integrate(T_END)
        for j, k in enumerate(ks):
            got = ens[j]
            want = cpu_lone(sims[j])
            n = sims[j].N
            st = got.state_arrays()
            tag = variant if len(ks) == 1 else f"{variant}_m{k}"
            report(tag, (got.positions, got.velocities, st["buf"].reshape(-1)[:21 * n], 0),
                   (want[0], want[1], want[2][:21 * n], want[3]))
        return
    if variant in SPLIT:
        run_split(variant)
        return
    sim = dh_member(1)
    want = cpu_lone(sim)
    if variant.startswith("kernel"):
        got = launch_kernel(sim, 1 if variant == "kernel1" else 128, variant.endswith("z"))
    elif variant == "body_pack":
        got = body_pack(sim)
    else:
        got = whole(sim)
    report(variant, got, want)


def main():
    if len(sys.argv) > 1:
        try:
            run(sys.argv[1])
        except Exception as exc:
            print(f"{sys.argv[1]}_error={type(exc).__name__}: {str(exc).splitlines()[0][:200]}")
        return
    chosen = VARIANTS
    if os.environ.get("DH_SPLIT"):
        chosen = tuple(os.environ["DH_SPLIT"].split(",")) if "," in os.environ["DH_SPLIT"] \
            else SPLIT + ("kernel1",)
    procs = [subprocess.Popen([sys.executable, __file__, v], stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True) for v in chosen]
    for v, p in zip(chosen, procs, strict=True):
        out, _ = p.communicate()
        lines = [ln for ln in out.splitlines() if "=" in ln and "Warning" not in ln]
        print("\n".join(lines) or f"{v}_error=no output: {out[-300:]}", flush=True)



# ---- the second round: ``whole`` right, the ensemble kernel wrong (H200, 2026-11-28) -------------
# Each kernel below is ``whole`` with one of the ensemble kernel's differences, or the ensemble
# kernel's code with the pieces' body: ``VARIANT`` names as in ``SPLIT``.

def split_kernel(variant):
    import diagnose_dh_pieces as P

    from visviva.core import nbody_whfast as W
    from visviva.core.cuda import whfast as CW
    from visviva.core.cuda.twins import device_twin
    from visviva.core.gravity import no_force

    NB = W.N_BUF
    force = P.force
    body = P.body
    if variant == "build_run":  # build_general's own twin of the body (as it builds it)
        assert device_twin(no_force) is force
        body = device_twin(W._whfast, CW.general_swaps(force))
    sx = variant in ("slice_x", "slice_all", "slice_xv", "flat_x")
    sxv = variant != "slice_mr"  # (only with sx) x and v sliced
    smr = variant != "slice_xv"  # (only with sx) m and radius sliced
    flat = variant == "flat_x"  # x and v flat (3P,), a 1-D slice reshaped (as buf)
    sm = variant in ("slice_massive", "slice_all")
    sb = variant in ("slice_buf", "slice_all")
    so = variant in ("slice_out", "slice_all")

    @cuda.jit
    def k(x, v, m, massive, moff, radius, poff, fstate, istate, buf, params, qoff, t_out, out_t,
          out_x, out_v, status):
        j = cuda.grid(1)
        if j >= fstate.shape[0]:
            return
        lo = poff[j]
        hi = poff[j + 1]
        n = hi - lo if sx else m.shape[0]
        T = t_out.shape[0]
        if flat:
            X = x[3 * lo:3 * hi].reshape((n, 3))
            V = v[3 * lo:3 * hi].reshape((n, 3))
        else:
            X = x[lo:hi] if sx and sxv else x
            V = v[lo:hi] if sx and sxv else v
        Mm = m[lo:hi] if sx and smr else m
        R = radius[lo:hi] if sx and smr else radius
        MS = massive[moff[j]:moff[j + 1]] if sm else massive
        B = (buf[3 * NB * lo:3 * NB * hi] if sb else buf).reshape((NB, n, 3))
        OX = (out_x[3 * T * lo:3 * T * hi] if so else out_x).reshape((T, n, 3))
        OV = (out_v[3 * T * lo:3 * T * hi] if so else out_v).reshape((T, n, 3))
        Q = params[qoff[j]:qoff[j + 1]] if so else params
        status[j] = body(X, V, Mm, MS, R, fstate[j], istate[j], B, X, force, Q, t_out,
                         out_t[j], OX, OV, 0, True, None)

    return k


SPLIT = ("build_run", "slice_x", "slice_massive", "slice_buf", "slice_out", "slice_all",
         "slice_xv", "slice_mr", "flat_x")


def run_split(variant):
    from numba import cuda

    sim = dh_member(1)
    want = cpu_lone(sim)
    pack, target, _ = pack_of(sim)
    P = len(pack.x)
    state = pack.to_device(("x", "v", "fstate", "istate", "buf"))
    d = {**pack.to_device(("m", "massive", "moff", "radius", "poff", "params", "qoff")),
         **state}
    if variant == "flat_x":
        state["x"] = d["x"] = cuda.to_device(pack.x.reshape(-1))
        state["v"] = d["v"] = cuda.to_device(pack.v.reshape(-1))
    status = cuda.to_device(np.zeros(1, dtype=np.int64))
    split_kernel(variant)[1, 1](
        *(d[k] for k in ("x", "v", "m", "massive", "moff", "radius", "poff", "fstate", "istate",
                         "buf", "params", "qoff")),
        cuda.to_device(np.array([target])), cuda.to_device(np.zeros((1, 1))),
        cuda.to_device(np.zeros(3 * P)), cuda.to_device(np.zeros(3 * P)), status)
    for k in ("x", "v"):
        getattr(pack, k)[:] = state.pop(k).copy_to_host().reshape(-1, 3)
    pack.from_device(state)
    report(variant, (pack.x, pack.v, pack.buf, int(status.copy_to_host()[0])), want)


if __name__ == "__main__":
    main()
