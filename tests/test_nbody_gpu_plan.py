"""The host-side plans of the GPU's fixed-step runs against the CPU kernels (no GPU, no
simulator: the plans are numpy; the kernels they stand for are the CPU's)."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva.core import nbody_common as nc
from visviva.core.cuda.whfast import SKIP
from visviva.nbody import gpu_ensemble_whfast as gw

#: the state the CPU kernel leaves that the GPU run must leave too
FSTATE = {"t": nc.F_T, "t0": nc.F_T0, "dt_ref": nc.F_DT_REF, "dt_last": nc.F_DT_LAST,
          "wh_h": nc.F_WH_H}
ISTATE = {"k": nc.I_K, "steps": nc.I_STEPS, "wh_valid": nc.I_WH_VALID, "fresh": nc.I_FRESH,
          "nout": nc.I_NOUT}


def _binary(dt, exact):
    sim = vv.Simulation("whfast", dt=dt, exact_finish_time=exact)
    sim.add(1.0)
    sim.add(1e-3, a=1.0, e=0.1, primary=0)
    return sim


@settings(max_examples=40, deadline=None)
@given(dt=st.sampled_from([0.01, 0.0137, 0.1, 1.0 / 3.0]), exact=st.booleans(),
       moves=st.lists(st.one_of(st.floats(-1.5, 1.5), st.sampled_from([0.0, 0.3, -0.1])),
                      min_size=1, max_size=5),
       change_dt=st.booleans())
def test_whfast_plan_leaves_the_cpu_kernels_counters_clock_and_grid(dt, exact, moves,
                                                                    change_dt):
    # a sequence of runs forwards, backwards, to the current time and to grid points (0.3 is
    # one of dt = 0.01 and 0.1), with the step changed half way: the plan and its bookkeeping
    # applied to the state before each CPU run give the state after it, field by field
    sim = _binary(dt, exact)
    for j, move in enumerate(moves):
        if change_dt and j == len(moves) // 2:
            sim.dt = 0.75 * dt
        target = sim.t + move if move not in (0.3, -0.1) else move
        arrays = sim.state_arrays()
        fs, ist = arrays["fstate"].copy()[None], arrays["istate"].copy()[None]
        sim.integrate(target)
        mode, n, h, rem, t_final = gw.plan(fs, ist, float(target))
        gw.account(fs, ist, n, h, t_final)
        after = sim.state_arrays()
        for name, slot in FSTATE.items():
            assert fs[0, slot] == after["fstate"][slot], (name, j)
        for name, slot in ISTATE.items():
            assert ist[0, slot] == after["istate"][slot], (name, j)
        if mode[0] == SKIP:  # an output at the current time, no internal state: nothing runs
            assert n[0] == 0 and sim.t == fs[0, nc.F_T]
        # the output copy's shortened step: only with exact_finish_time, at most a step (back
        # from the first grid point when the target lies within the first step)
        assert rem[0] == 0.0 or (exact and abs(rem[0]) <= abs(fs[0, nc.F_DT]))
        assert mode[0] != SKIP or rem[0] == 0.0
