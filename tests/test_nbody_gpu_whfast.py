"""WHFast GPU ensembles beyond the plain case (democratic heliocentric coordinates, symplectic
correctors, collision/encounter/escape checks) against the CPU ensemble, under numba's CUDA
simulator in a subprocess (``tests/gpu/check_whfast_general.py``); the same script on a real
GPU with ``-m gpu``."""

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


def test_whfast_members_with_forces_are_refused_with_a_clear_error(monkeypatch):
    # the check backend="cuda" makes for every member (no GPU needed: the simulator's switch
    # makes the backend available to it, nothing is compiled or launched)
    pytest.importorskip("numba_cuda")
    monkeypatch.setenv("NUMBA_ENABLE_CUDASIM", "1")
    from visviva.nbody import J2Force
    from visviva.nbody.gpu import check_ensemble

    sim = vv.Simulation("whfast", dt=0.01, coordinates="democratic_heliocentric")
    sim.add(1.0)
    sim.add(1e-3, a=1.0, primary=0)
    sim.exit_max_distance = 10.0
    sim.corrector = 0
    events = sim.copy()
    events.collision = "merge"
    check_ensemble([sim, events])  # any coordinates, corrector, events: accepted
    sim.add_force(J2Force(0, 1e-3, 0.01))
    with pytest.raises(InvalidInputError, match="member 1: .*additional forces run on "
                                                "backend='cpu'"):
        check_ensemble([events, sim])
