"""WHFast GPU ensembles beyond the plain case (democratic heliocentric coordinates, symplectic
correctors, collision/encounter/escape checks, additional forces) against the CPU ensemble and
lone CPU runs, under numba's CUDA simulator in a subprocess (``tests/gpu/check_whfast_general.py``,
``tests/gpu/check_whfast_forces.py``); the same scripts on a real GPU with ``-m gpu``."""

from __future__ import annotations

import os

import numpy as np
import pytest

import visviva as vv
from test_nbody_gpu import _has_gpu, _run
from visviva.errors import InvalidInputError

SCRIPT = os.path.join(os.path.dirname(__file__), "gpu", "check_whfast_general.py")
SECTIONS = ("dh", "corr3", "corr7", "events")


def _check(out, tolerance, bits):
    # ragged members, off and on the step grid, backwards, one landing on grid points only:
    # the same steps, times, particle counts and exceptions as the CPU ensemble, the state to
    # round-off (under the simulator the device runs the CPU's arithmetic: 0.0, and the same
    # times; on a GPU the compiler's fused multiply-adds may move a time by an ulp)
    for key in SECTIONS + ("dh_restart", "dh_to_gpu", "events_restart"):
        for what in ("pos", "vel"):
            assert float(out[f"{key}_{what}"]) <= tolerance, (key, what, out[f"{key}_{what}"])
        assert out[f"{key}_steps_equal"] == "True", key
        assert out[f"{key}_raised_equal"] == "True", key
    for key in SECTIONS:
        assert out[f"{key}_n_equal"] == "True", key
        assert out[f"{key}_t_equal"] == "True" if bits else float(out[f"{key}_t_diff"]) < 1e-12
    for key in ("dh", "corr3", "corr7"):
        assert out[f"{key}_raised"] == "[]", key
    # through the pack (Ensemble.integrate's fast path), and member by member the same bits
    assert out["dh_packed"] == "True" and out["each_bits_vs_packed"] == "True"
    # member 1 escapes (raised at both calls, as by the CPU ensemble, which names member 7
    # too: its encounter), member 3 merges its two bodies into one and member 5 keeps its four,
    # the others reach the times; each member equals its lone CPU run (the escape and the
    # encounter raised there too)
    assert out["events_raised"] == "[('Escape', 1, [1, 7]), ('Escape', 1, [1, 7])]"
    assert out["events_n"] == "3,5,5,1,4,4,3,5"
    t = np.array([float(x) for x in out["events_t"].split(",")])
    assert t[1] < 0.1 and t[7] < 0.1 and t[5] == pytest.approx(0.36, rel=1e-12)  # grid only
    np.testing.assert_allclose(t[[0, 2, 3, 4, 6]], 0.35, rtol=1e-12)
    assert float(out["events_alone_pos"]) <= tolerance
    assert float(out["events_alone_t_diff"]) <= (0.0 if bits else 1e-12)
    assert out["events_alone_raised"] == "[(1, 'Escape'), (7, 'Encounter')]"


def test_whfast_ensembles_in_every_setting_on_the_cuda_simulator_match_the_cpu():
    _check(_run({"NUMBA_ENABLE_CUDASIM": "1"}, SCRIPT), 0.0, True)


@pytest.mark.gpu
@pytest.mark.skipif(not _has_gpu(), reason="needs an NVIDIA GPU and numba-cuda")
def test_whfast_ensembles_in_every_setting_on_a_real_gpu_match_the_cpu():
    # the device's sin, cos, sqrt and fused multiply-adds in the Kepler drifts: round-off
    _check(_run({"NUMBA_ENABLE_CUDASIM": "0"}, SCRIPT), 1e-12, False)


FORCES_SCRIPT = os.path.join(os.path.dirname(__file__), "gpu", "check_whfast_forces.py")


def _check_forces(out, tolerance, bits):
    # seven members: J2 of the star with two J2 values (one kernel call), a user's numba.njit
    # force fused with J2, democratic heliocentric coordinates with J2 and with both fused, the
    # GR potential with the 5th-order corrector, one member without forces; three
    # output times (off the grid, on it, backwards). Each member adds its force's device twin
    # on the parameters its lone run passes: the CPU ensemble's and the lone runs' numbers,
    # steps and times; then saved on the GPU and continued on the CPU, and the other way
    for key in ("force_pos", "force_vel", "force_t", "alone_pos", "alone_vel", "restart_pos",
                "restart_vel", "restart_t", "to_gpu_pos", "to_gpu_vel", "to_gpu_t"):
        assert float(out[key]) <= tolerance, (key, out[key])
    assert float(out["alone_t_diff"]) <= (0.0 if bits else 1e-12)
    for key in ("force_steps_equal", "force_n_equal", "alone_steps_equal",
                "restart_steps_equal", "to_gpu_steps_equal"):
        assert out[key] == "True", key
    assert out["force_t_equal"] == "True" or not bits
    assert int(out["force_steps"]) >= 10
    # one kernel per set of force functions (J2; J2 and the user's force; the GR potential),
    # whatever the members' coordinates or parameter values
    assert out["force_kernels"] == "3"
    # the forces do move the members (relative to the same members without them)
    # (member 4 has none: the same numbers, to the device's round-off: 6.6e-19 on an H200)
    assert float(out["effect_min"]) > 1e-8 and float(out["effect_none"]) <= tolerance
    # a velocity-dependent force: WHFast refuses it as on the CPU, saying what to use
    assert out["velocity_refused"].startswith("InvalidInputError: ")
    assert "integrator='ias15'" in out["velocity_refused"]


def test_whfast_ensembles_with_forces_on_the_cuda_simulator_match_the_cpu():
    _check_forces(_run({"NUMBA_ENABLE_CUDASIM": "1"}, FORCES_SCRIPT), 0.0, True)


@pytest.mark.gpu
@pytest.mark.skipif(not _has_gpu(), reason="needs an NVIDIA GPU and numba-cuda")
def test_whfast_ensembles_with_forces_on_a_real_gpu_match_the_cpu():
    _check_forces(_run({"NUMBA_ENABLE_CUDASIM": "0"}, FORCES_SCRIPT), 1e-12, False)


def test_whfast_members_with_forces_are_accepted_and_velocity_forces_refused(monkeypatch):
    # the check backend="cuda" makes for every member (no GPU needed: the simulator's switch
    # makes the backend available to it, nothing is compiled or launched)
    pytest.importorskip("numba_cuda")
    monkeypatch.setenv("NUMBA_ENABLE_CUDASIM", "1")
    from visviva.nbody import GeneralRelativity, J2Force
    from visviva.nbody.gpu import check_ensemble

    sim = vv.Simulation("whfast", dt=0.01, coordinates="democratic_heliocentric")
    sim.add(1.0)
    sim.add(1e-3, a=1.0, primary=0)
    sim.exit_max_distance = 10.0
    sim.corrector = 0
    events = sim.copy()
    events.collision = "merge"
    sim.add_force(J2Force(0, 1e-3, 0.01))
    check_ensemble([sim, events])  # any coordinates, corrector, events, forces: accepted
    with pytest.raises(InvalidInputError, match="depends on velocities.*integrator='ias15'"):
        sim.add_force(GeneralRelativity(0, c=30.0))  # as on the CPU


def test_democratic_heliocentric_whfast_ensembles_run_on_a_real_gpu(monkeypatch):
    # refused on real GPUs from 2026-11-26 until the general kernel's fault was found on an
    # H200 (2026-11-28: it sliced the members' (P, 3) positions; now flat, right to 4e-17): an
    # ensemble with democratic heliocentric members is accepted when made and when it runs,
    # as if on a GPU, with the other settings of the general kernel
    pytest.importorskip("numba_cuda")
    from visviva.core import cuda as vcuda
    from visviva.nbody import J2Force
    from visviva.nbody.gpu import check_ensemble

    def member(**settings):
        sim = vv.Simulation("whfast", dt=0.01, **settings)
        sim.add(1.0)
        sim.add(1e-3, a=1.0, primary=0)
        return sim

    forced = member(coordinates="democratic_heliocentric")
    forced.add_force(J2Force(0, 1e-3, 0.01))
    dh = [member(coordinates="democratic_heliocentric"),
          member(coordinates="democratic_heliocentric", exit_max_distance=10.0), forced]
    monkeypatch.setattr(vcuda, "simulator", lambda: False)
    monkeypatch.setattr(vcuda, "missing", lambda: None)  # as if a GPU were there
    check_ensemble([member(), member(corrector=5)] + dh)
    assert vv.Ensemble.from_simulations(dh, backend="cuda").backend == "cuda"


PIECES_SCRIPT = os.path.join(os.path.dirname(__file__), "gpu", "diagnose_dh_pieces.py")


@pytest.mark.slow
def test_the_democratic_heliocentric_pieces_diagnosis_runs_and_agrees_on_the_simulator():
    # tests/gpu/diagnose_dh_pieces.py (run by benchmarks/on_gpu.sh on a lent GPU, where it
    # names the piece of the general WHFast kernel that goes wrong) must not rot: under the
    # simulator each piece's device twin, built as build_general builds it, equals the CPU
    # kernel's function bit for bit, and every piece runs
    out = _run({"NUMBA_ENABLE_CUDASIM": "1"}, PIECES_SCRIPT)
    pieces = ("to_dh", "from_dh", "jump", "dh_kick", "drift_dh", "gravity_rest", "zero_slice",
              "dh_step", "kick_dh", "kick_jacobi", "first_half_dh", "synchronise_dh",
              "rt_to_internal", "lit_to_internal", "rt_from_internal", "lit_from_internal",
              "rt_kepler_drift", "rt_drift_jumps", "lit_drift_jumps", "rt_kick",
              "rt_first_half", "rt_synchronise", "rt_dkd_step", "lit_dkd_step", "body",
              "body_jacobi")
    pieces += tuple(f"{k}_m{m}" for k in pieces for m in (0, 2))
    assert {k: out.get(k) for k in pieces} == {k: "0.0" for k in pieces}, out


WRAPPER_SCRIPT = os.path.join(os.path.dirname(__file__), "gpu", "diagnose_dh_wrapper.py")


@pytest.mark.slow
def test_the_democratic_heliocentric_wrapper_diagnosis_runs_and_agrees_on_the_simulator():
    # tests/gpu/diagnose_dh_wrapper.py found the general kernel's fault on an H200 (the
    # members' positions sliced as (P, 3) arrays: slice_x, slice_xv wrong there; flat_x and the
    # kernel as it is now right): under the simulator every variant equals the CPU's lone run
    variants = ("ensemble", "ensemble3_m0", "ensemble3_m1", "ensemble3_m2", "kernel128",
                "kernel1", "kernel128z", "body_pack", "whole")
    out = _run({"NUMBA_ENABLE_CUDASIM": "1"}, WRAPPER_SCRIPT)
    assert {k: out.get(k) for k in variants} == {k: "0.0" for k in variants}, out
    split = ("build_run", "slice_x", "slice_massive", "slice_buf", "slice_out", "slice_all",
             "slice_xv", "slice_mr", "flat_x")
    out = _run({"NUMBA_ENABLE_CUDASIM": "1", "DH_SPLIT": "1"}, WRAPPER_SCRIPT)
    assert {k: out.get(k) for k in split} == {k: "0.0" for k in split}, out
