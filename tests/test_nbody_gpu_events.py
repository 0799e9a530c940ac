"""Collision, encounter and escape checks, and additional forces, in leapfrog and IAS15 GPU
ensembles, against the CPU ensemble, under numba's CUDA simulator (``tests/gpu/check_ensemble_events.py`` in a subprocess;
see :mod:`test_nbody_gpu`). Real-GPU runs: ``-m gpu`` on a machine with an NVIDIA GPU."""

from __future__ import annotations

import os

import pytest

from test_nbody_gpu import _has_gpu, _run

SCRIPT = os.path.join(os.path.dirname(__file__), "gpu", "check_ensemble_events.py")


def _check(out, tolerance, messages_equal):
    for prefix in ("lf", "ias15"):
        # seven members: 1 launches a test particle past its exit distance (Escape), 2 merges
        # two planets and runs on, 3 meets an encounter, 5 halts at a collision, 0, 4 and 6 run
        # on (4 with collision checks that never fire); three calls, the later ones after the
        # events. Every member's state, time, step count and particle count is the CPU
        # ensemble's, and the ensemble raises the CPU's exception (type, message, members)
        # (then saved on the GPU and continued on the CPU, and saved on the CPU and continued
        # on the GPU)
        # the states compared at the same time (``*_same_t``: the CPU's carried to the GPU's
        # time, x + v dt, v + a dt): on a GPU an IAS15 member that stops at an event ends a
        # few 1e-12 of the time away from the CPU's (its step sizes follow a coefficient at
        # the level of round-off through libdevice's pow); under the simulator all 0
        for key in ("pos_same_t", "vel_same_t", "restart_pos_same_t", "restart_vel_same_t",
                    "to_gpu_pos_same_t", "to_gpu_vel_same_t"):
            assert float(out[f"{prefix}_{key}"]) <= tolerance, (prefix, key, out[f"{prefix}_{key}"])
        fixed_steps = prefix == "lf" or messages_equal
        for key in ("pos", "vel", "t", "restart_pos", "restart_vel", "restart_t", "to_gpu_pos",
                    "to_gpu_vel", "to_gpu_t"):
            limit = tolerance if fixed_steps or not key.endswith("t") else 1e-10
            if fixed_steps or key.endswith("t"):
                assert float(out[f"{prefix}_{key}"]) <= limit, (prefix, key, out[f"{prefix}_{key}"])
        for key in ("raised_kind_equal", "steps_equal", "n_equal", "restart_raised_kind_equal",
                    "restart_steps_equal", "restart_n_equal", "to_gpu_raised_kind_equal",
                    "to_gpu_steps_equal", "to_gpu_n_equal"):
            assert out[f"{prefix}_{key}"] == "True", (prefix, key)
        if messages_equal:  # the messages name the event's time: the same digits
            assert out[f"{prefix}_raised_equal"] == out[f"{prefix}_restart_raised_equal"] == "True"
        assert out[f"{prefix}_raised"] == "Escape"  # member 1's, the first that stopped
        assert out[f"{prefix}_stopped"] == "1,3,5"
        assert out[f"{prefix}_n"] == "3,4,4,5,3,5,3"  # member 2 merged (N 5 -> 4)
        assert out[f"{prefix}_n0"] == "3,4,5,5,3,5,3"
        assert out[f"{prefix}_on_time"] == "0,2,4,6"  # the others reached the time
        assert int(out[f"{prefix}_steps"]) >= 5
    for prefix in ("lf_force", "ias15_force"):
        # seven members: no force, J2Force of the star (two J2 values; IAS15's second with the
        # velocity-dependent GeneralRelativity too), a user's numba.njit force (position- and
        # time-dependent; two parameter sets), both fused, J2 with a merger; two calls, then saved and continued on the CPU. Each member adds the force's
        # device twin on its own parameters: the CPU ensemble's numbers
        for key in ("pos", "vel", "t", "restart_pos", "restart_vel", "restart_t"):
            assert float(out[f"{prefix}_{key}"]) <= tolerance, (prefix, key, out[f"{prefix}_{key}"])
        for key in ("steps_equal", "n_equal", "restart_steps_equal", "restart_n_equal"):
            assert out[f"{prefix}_{key}"] == "True", (prefix, key)
        assert out[f"{prefix}_n"] == "3,3,3,3,4,3,3"  # member 4 merged (N 5 -> 4)
        assert int(out[f"{prefix}_steps"]) >= 10


def test_events_and_forces_in_gpu_ensembles_under_the_simulator_match_the_cpu_ensemble():
    # the simulator runs the host's arithmetic in the CPU kernels' order: bit for bit there
    _check(_run({"NUMBA_ENABLE_CUDASIM": "1"}, SCRIPT), 0.0, True)


@pytest.mark.gpu
@pytest.mark.skipif(not _has_gpu(), reason="needs an NVIDIA GPU and numba-cuda")
def test_events_and_forces_in_gpu_ensembles_on_a_real_gpu_match_the_cpu_ensemble():
    # fused multiply-adds and libdevice's pow (IAS15's step control): round-off, so the event
    # times in the messages may differ in the last digit
    _check(_run({"NUMBA_ENABLE_CUDASIM": "0"}, SCRIPT), 1e-12, False)


def test_a_force_the_device_cannot_compile_is_refused_with_what_to_do():
    # numba-cuda's typing error on launch becomes the library's InvalidInputError naming the
    # force (the simulator runs forces as Python, so the error is raised here by a stand-in)
    from numba.core.errors import TypingError

    import visviva as vv
    from visviva.errors import InvalidInputError
    from visviva.nbody import J2Force
    from visviva.nbody.gpu_forces import force_key, launch

    class Refusing:
        def __getitem__(self, launch_config):
            def call(*args):
                raise TypingError("Use of unsupported NumPy function 'numpy.linalg.svd'")
            return call

    sim = vv.Simulation("leapfrog", dt=0.01)
    sim.add(1.0)
    sim.add(1e-3, a=1.0, primary=0)
    with pytest.raises(TypingError):  # no force: the error is the kernel's own, passed on
        launch(Refusing(), sim, 1, 1)
    sim.add_force(J2Force(0, 1e-3, 0.01))
    with pytest.raises(InvalidInputError, match=r"J2 do not compile for the GPU.*svd.*'cpu'"):
        launch(Refusing(), sim, 1, 1)
    # members with the same force functions and parameter lengths share a kernel
    other = sim.copy()
    other.forces[0].j2 = 2e-3
    assert force_key(other) == force_key(sim) != force_key(vv.Simulation("leapfrog", dt=0.01))
