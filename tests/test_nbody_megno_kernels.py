"""The MEGNO kernels ``<integrator>_run_megno``: what a MEGNO run takes (the few-body kernel
without the paths MEGNO refuses, the first-use compile cut; docs/performance.md), and the same
bits as the general few-body kernel ``<integrator>_run_few``."""

from __future__ import annotations

import numpy as np
import pytest

import visviva as vv

CASES = [("whfast", 0.013), ("leapfrog", 0.005), ("ias15", None)]


def _system(integrator, dt, a2=1.25, **kw):
    sim = vv.Simulation(integrator=integrator, G=1.0, dt=dt, **kw)
    sim.add(1.0)
    sim.add(1e-3, a=1.0, primary=0)
    sim.add(1e-3, a=a2, e=0.05, primary=0)  # a2 = 1.25: chaotic, the tangent vector grows
    sim.move_to_com()
    return sim


def _variant(sim) -> str:
    st = sim._state
    return sim.integrator_info.variant(True, st.istate, st.fstate)


@pytest.mark.parametrize(("integrator", "dt"), CASES)
def test_a_megno_run_takes_the_megno_kernel_and_gets_the_few_body_kernels_bits(
        integrator, dt, monkeypatch):
    def run():
        sim = _system(integrator, dt)
        sim.init_megno(seed=3)
        kernel = _variant(sim)
        sim.integrate(np.linspace(0.3, 30.3, 5))  # output times between steps: copies
        sim.integrate(12.0)  # backwards
        return sim, kernel

    megno, kernel = run()
    assert kernel == f"{integrator}_run_megno"
    monkeypatch.setattr(megno.integrator_info.core, "is_megno", lambda istate, fstate: False)
    few, kernel = run()
    assert kernel == f"{integrator}_run_few"
    assert np.array_equal(megno.positions, few.positions)
    assert np.array_equal(megno.velocities, few.velocities)
    assert np.array_equal(megno.tangent_vector, few.tangent_vector)
    assert megno.steps_done == few.steps_done
    assert megno.megno() == few.megno() and megno.lyapunov() == few.lyapunov()
    assert megno.megno() != 0.0 and np.isfinite(megno.megno())


@pytest.mark.parametrize(("integrator", "dt"), CASES)
def test_runs_the_megno_kernel_does_not_cover_take_the_others(integrator, dt):
    plain = _system(integrator, dt)
    assert _variant(plain) == (f"{integrator}_run_plain" if integrator == "whfast"
                               else f"{integrator}_run_few")
    if integrator == "whfast":
        return  # init_megno refuses events with WHFast
    events = _system(integrator, dt, collision="halt")
    events.init_megno(seed=1)
    assert _variant(events) == f"{integrator}_run_few"  # event checks: the general kernel
    events.integrate(3.0)
    alone = _system(integrator, dt)
    alone.init_megno(seed=1)
    alone.integrate(3.0)
    assert events.megno() == alone.megno()  # no collision: the same run


def test_a_packed_megno_ensemble_runs_the_megno_kernel_with_the_lone_runs_bits():
    # was: a packed CPU ensemble ran the general few-body kernel (whfast_run_few, 41 s of CPU
    # to compile) although its members' lone runs and `visviva warmup` use the MEGNO kernel
    from visviva.nbody.ensemble_pack import Pack

    def members(megno=True):
        out = []
        for a2 in (1.25, 1.6):
            s = _system("whfast", 0.013, a2)
            if megno:
                s.init_megno(seed=2)
            out.append(s)
        return out

    info = members()[0].integrator_info

    def rows(sims):
        arrays = [s.state_arrays() for s in sims]
        return (np.stack([a["istate"] for a in arrays]), np.stack([a["fstate"] for a in arrays]))

    assert info.pack_variant(True, *rows(members())) == "whfast_run_megno"
    assert info.pack_variant(True, *rows(members(False))) == "whfast_run_few"
    assert info.pack_variant(False, *rows(members())) == "whfast_run"
    packed, lone = members(), members()
    pack = Pack.build(packed)
    assert pack is not None and pack.advance(20.0) == []
    for s in lone:
        s.integrate(20.0)
    for p, q in zip(packed, lone, strict=True):
        assert p.megno() == q.megno() and np.array_equal(p.tangent_vector, q.tangent_vector)
