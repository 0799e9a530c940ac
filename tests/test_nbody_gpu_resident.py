"""The resident GPU ensemble kernels (:mod:`visviva.core.cuda.resident`: each member's state in
its thread's local arrays for a whole call) against the CPU ensemble and the global-memory
kernels, under numba's CUDA simulator in a subprocess (``tests/gpu/check_resident.py``); the
same script on a real GPU with ``-m gpu``."""

from __future__ import annotations

import os

import pytest

from test_nbody_gpu import _has_gpu, _run

SCRIPT = os.path.join(os.path.dirname(__file__), "gpu", "check_resident.py")
INTEGRATORS = ("leapfrog", "whfast")


def _check(out, tolerance, bits):
    for integrator in INTEGRATORS:
        # ragged members of 3 to 8 particles (test particles among them) through the start
        # time, off the grid, on it, backwards and forwards again: the bucket of 8; packs of
        # 3 and of 8 bodies, all massive: the kernels for exactly 3 and 8 (their loops
        # unrolled); of 4 with test particles: the bucket of 4; of 9, all massive: the bucket
        # of 16; a member of 32 particles: the bucket of 32; one of 33: no resident kernel
        # (the global-memory one runs it); everywhere the same numbers
        launched = {"": "8, False", "_exact3": "3, True", "_n4": "4, False",
                    "_exact8": "8, True", "_n9": "16, False", "_n32": "32, False"}
        for suffix, kernel in launched.items():
            assert out[f"{integrator}{suffix}_launched"] == f"[('{integrator}', {kernel})]"
        assert out[f"{integrator}_n33_launched"] == "[]"
        for key in [integrator + suffix for suffix in (*launched, "_n33")]:
            assert out[f"{key}_packed"] == "True", key
            for what in ("pos", "vel"):
                assert float(out[f"{key}_{what}"]) <= tolerance, (key, what, out[f"{key}_{what}"])
            assert out[f"{key}_steps_equal"] == "True", key
            assert float(out[f"{key}_t_diff"]) <= (0.0 if bits else 1e-12), key
            # the same device functions in the same order as the global-memory kernel: its
            # bits, on any device
            assert out[f"{key}_bits_vs_global"] == "True", key
            if bits:
                assert out[f"{key}_bits_vs_cpu"] == "True", key
        # saved on the GPU and continued on the CPU, saved on the CPU and continued on the GPU
        for what in ("to_cpu_pos", "to_gpu_pos", "continued_pos"):
            key = f"{integrator}_restart_{what}"
            assert float(out[key]) <= tolerance, (key, out[key])
        if bits:
            assert out[f"{integrator}_restart_bits"] == "True"


@pytest.mark.slow
def test_resident_kernels_on_the_cuda_simulator_give_the_cpu_ensembles_bits():
    _check(_run({"NUMBA_ENABLE_CUDASIM": "1"}, SCRIPT), 0.0, True)


@pytest.mark.gpu
@pytest.mark.skipif(not _has_gpu(), reason="needs an NVIDIA GPU and numba-cuda")
def test_resident_kernels_on_a_real_gpu_match_the_cpu_ensemble():
    # the device's fused multiply-adds, sqrt and the Kepler drift's sin/cos: round-off
    _check(_run({"NUMBA_ENABLE_CUDASIM": "0"}, SCRIPT), 1e-12, False)


def test_buckets_and_the_switch(monkeypatch):
    from visviva.core.cuda import resident as R

    # the smallest bucket holding the largest member; above the largest: None (global kernel)
    assert R.EXACT_MAX <= R.BUCKETS[-1]
    assert [R.bucket(n) for n in (1, 3, 4, 5, 8, 9, 16, 17, 32, 33, 1000)] == [
        4, 4, 4, 8, 8, 16, 16, 32, 32, None, None]
    # unset: on, under the simulator and on a real GPU (checked on an H200, 2026-11-27)
    monkeypatch.delenv(R.RESIDENT, raising=False)
    for sim in ("1", "0"):
        monkeypatch.setenv("NUMBA_ENABLE_CUDASIM", sim)
        assert R.enabled()
    monkeypatch.setenv(R.RESIDENT, "1")
    assert R.enabled()
    for off in ("0", "off", "False", " no "):
        monkeypatch.setenv(R.RESIDENT, off)
        monkeypatch.setenv("NUMBA_ENABLE_CUDASIM", "1")
        assert not R.enabled()
