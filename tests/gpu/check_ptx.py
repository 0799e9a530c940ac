"""Compile every GPU kernel of the backend to PTX through NVVM (no GPU needed: numba-cuda's
``compile_ptx`` with the libraries of the nvidia-nvvm and nvidia-cuda-nvrtc wheels), for
compute capability 9.0; prints ``kernel=ok`` or ``kernel=<error>`` lines, or ``missing=...``.

The simulator runs the kernels as Python, so it cannot catch what numba-cuda does not compile
(an unsupported numpy function, a type it cannot lower); this can."""

from __future__ import annotations

import sys
import types


def main():
    from numba import cuda, float64, int32, int64

    try:
        from numba.cuda.cudadrv import nvrtc, nvvm

        nvvm.NVVM()
        nvrtc.get_supported_ccs()
    except Exception as exc:  # the libraries are not installed
        print(f"missing={type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}")
        return
    # device functions are compiled for the current device's compute capability: there is no
    # device here, so name one (numba-cuda's dispatcher asks get_current_device)
    dispatcher = sys.modules["numba.cuda.dispatcher"]
    dispatcher.get_current_device = lambda: types.SimpleNamespace(compute_capability=(9, 0))

    import visviva as vv
    from visviva.core.cuda import ias15 as I
    from visviva.core.cuda import kernels as K
    from visviva.core.cuda import resident as R
    from visviva.core.cuda import whfast as W
    from visviva.core.cuda.twins import device_twin
    from visviva.core.gravity import no_force
    from visviva.nbody.forces import J2Force, LinearDrag
    from visviva.nbody.gpu_forces import device_force

    # the ensembles' additional forces compiled for the device: J2 fused with a user's force
    # (the fused closure of visviva.nbody.forces.combine), and IAS15's velocity-dependent drag
    # (WHFast members take position-dependent forces only; compiling the drag in changes
    # nothing the kernel's code does with the fused force)
    sim = vv.Simulation("ias15")
    sim.add(1.0)
    sim.add_force(J2Force(0, 1e-3, 0.05))
    sim.add_force(_user_force(), params=[0.1])
    sim.add_force(LinearDrag(0.1))
    forces = device_force(sim)

    a2, f1, i1, i2 = float64[:, ::1], float64[::1], int64[::1], int64[:, ::1]
    leapfrog = (a2, a2, a2, a2, f1, f1, i1, i1, i1, f1, a2, i1, f1, f1, f1, a2, i2, f1, i1, i1,
                i1)
    ias15 = (a2, a2, f1, i1, i1, i1, f1, a2, i2, f1, f1, i1, a2, i2, float64, i1)
    cases = {
        "tight_pairs": (K.tight_pairs, (a2, i1, float64, int32[::1])),
        "accelerations": (K.accelerations, (a2, a2, f1, i1, float64, a2)),
        "accelerations_split": (K.accelerations_split, (a2, a2, f1, i1, float64, a2)),
        "accelerations_rsqrt": (K.accelerations_rsqrt, (a2, a2, f1, i1, float64, a2)),
        "drift": (K.drift, (a2, a2, float64)),
        "kick_drift": (K.kick_drift, (a2, a2, a2, float64, float64)),
        "ensemble_leapfrog": (K.leapfrog_kernel(device_twin(no_force)), leapfrog),
        "ensemble_leapfrog_forces": (K.leapfrog_kernel(forces), leapfrog),
        "propagate_many": (K._kepler_kernel(), (a2, a2, f1, f1, a2, a2, i1)),
        "ensemble_whfast": (W.build(), (a2, a2, f1) + (a2,) * 6 + (f1, i1, i1, i1, f1, f1, f1,
                                                                   i1, i1, f1, i1)),
        # (the gravity-only general kernel is this one with the no-op force: one ~1 min NVVM
        # compile is enough here)
        "ensemble_whfast_general_forces": (W.build_general(forces), (
            a2, a2, f1, i1, i1, f1, i1, a2, i2, f1, f1, i1, f1, a2, f1, f1, i1)),
        # the resident kernels (each member's rows in its thread's local arrays), the smallest
        # and the largest bucket
        **{f"resident_leapfrog_{b}": (R.leapfrog(b), (a2, a2, a2, a2, f1, f1, i1, i1, i1, f1,
                                                       i1, f1, f1)) for b in (4, 32)},
        **{f"resident_whfast_{b}": (R.whfast(b), (a2, a2, f1, a2, a2, i1, i1, i1, f1, f1, f1,
                                                   i1, i1, f1, i1)) for b in (4, 32)},
        # and the leapfrog's for exactly three massive bodies (its loops unrolled)
        "resident_leapfrog_exact3": (R.leapfrog(3, True), (a2, a2, a2, a2, f1, f1, i1, i1, i1,
                                                           f1, i1, f1, f1)),
        "ensemble_ias15": (I.build(device_twin(no_force)), ias15),
        "ensemble_ias15_forces": (I.build(forces), ias15),
    }
    sizes = {}
    for name, (kernel, sig) in cases.items():
        try:
            ptx, _ = cuda.compile_ptx(kernel.py_func, sig, cc=(9, 0))
            print(f"{name}={'ok' if '.entry' in ptx else 'no entry'}")
            sizes[name] = len(ptx)
            if name.startswith("resident"):  # local memory the resident kernels declare
                print(f"{name}_local_bytes={_local_bytes(ptx)!r}")
        except Exception as exc:
            print(f"{name}={type(exc).__name__}: {str(exc).splitlines()[0][:200]}")
    # the general WHFast kernel's PTX (its size is what its first launch compiles: with the
    # Kepler solver inlined at its 23 call sites 6.4 MB and minutes, out of line 1.4 MB)
    print(f"size_general_whfast_mb={sizes.get('ensemble_whfast_general_forces', 0) / 1e6!r}")


def _local_bytes(ptx):
    """The bytes of the ``.local`` arrays the kernel's PTX declares (its per-thread frame)."""
    import re

    return sum(int(n) for n in re.findall(r"\.local\s+\.align\s+\d+\s+\.b8\s+\w+\[(\d+)\]",
                                           ptx))


def _user_force():
    import numba

    @numba.njit
    def pull(t, x, v, m, params, acc):
        for i in range(x.shape[0]):
            acc[i, 2] -= params[0] * x[i, 2]

    return pull


if __name__ == "__main__":
    main()
