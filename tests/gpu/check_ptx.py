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

    from visviva.core.cuda import ias15 as I
    from visviva.core.cuda import kernels as K
    from visviva.core.cuda import whfast as W

    a2, f1, i1, i2 = float64[:, ::1], float64[::1], int64[::1], int64[:, ::1]
    cases = {
        "tight_pairs": (K.tight_pairs, (a2, i1, float64, int32[::1])),
        "accelerations": (K.accelerations, (a2, a2, f1, i1, float64, a2)),
        "accelerations_split": (K.accelerations_split, (a2, a2, f1, i1, float64, a2)),
        "accelerations_rsqrt": (K.accelerations_rsqrt, (a2, a2, f1, i1, float64, a2)),
        "drift": (K.drift, (a2, a2, float64)),
        "kick_drift": (K.kick_drift, (a2, a2, a2, float64, float64)),
        "ensemble_leapfrog": (K.ensemble_leapfrog, (a2, a2, a2, a2, f1, i1, i1, i1, f1, a2, i1,
                                                    f1, f1)),
        "propagate_many": (K._kepler_kernel(), (a2, a2, f1, f1, a2, a2, i1)),
        "ensemble_whfast": (W.build(), (a2, a2, f1) + (a2,) * 6 + (f1, i1, i1, i1, f1, f1, f1,
                                                                   i1, i1, f1, i1)),
        "ensemble_ias15": (I.build(), (a2, a2, f1, i1, i1, i1, a2, i2, f1, a2, i2, float64,
                                       i1)),
    }
    for name, (kernel, sig) in cases.items():
        try:
            ptx, _ = cuda.compile_ptx(kernel.py_func, sig, cc=(9, 0))
            print(f"{name}={'ok' if '.entry' in ptx else 'no entry'}")
        except Exception as exc:
            print(f"{name}={type(exc).__name__}: {str(exc).splitlines()[0][:200]}")


if __name__ == "__main__":
    main()
