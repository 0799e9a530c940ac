"""``visviva warmup``: runs every task, names each, reports failures, silences the compile notice."""

import io

import pytest

from visviva import cli, warmup
from visviva.core import _jit


def test_warmup_reports_each_task_and_failures():
    seen = []

    def ok():
        seen.append(_jit.notices["enabled"])

    def broken():
        raise ValueError("no such kernel")

    stream = io.StringIO()
    results = warmup.warmup((("fine", ok), ("broken", broken)), progress=False, stream=stream)
    assert [r[0] for r in results] == ["fine", "broken"]
    assert results[0][2] is None and results[1][2] == "ValueError: no such kernel"
    assert seen == [False] and _jit.notices["enabled"] is True  # notice off only meanwhile
    lines = stream.getvalue().splitlines()
    assert lines[0].split()[0] == "fine" and "FAILED: ValueError: no such kernel" in lines[1]


def test_warmup_compiles_instead_of_interpreting(monkeypatch):
    # the interpreter tier (core/tier.py) is off while the tasks run: their small calls must
    # compile and fill the cache; it is back as it was afterwards
    from visviva.core import tier

    monkeypatch.setitem(tier.spent, "off", False)
    seen = []
    warmup.warmup((("task", lambda: seen.append(tier.spent["off"])),), progress=False,
                  stream=io.StringIO())
    assert seen == [True] and tier.spent["off"] is False


def test_warmup_progress_bar_names_the_running_task():
    stream = io.StringIO()
    warmup.warmup((("first task", lambda: None),), progress=True, stream=stream)
    assert "visviva warmup" in stream.getvalue() and "first task" in stream.getvalue()


def test_warmup_is_a_cli_command(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["warmup", "--help"])
    assert exc.value.code == 0
    assert "compile" in capsys.readouterr().out.lower()


@pytest.mark.slow
def test_warmup_compiles_every_task(capsys):
    assert cli.main(["warmup", "--quiet"]) == 0
    out = capsys.readouterr()
    assert f"{len(warmup.TASKS)} of {len(warmup.TASKS)} kernel families compiled" in out.out


def test_warmup_compiles_the_full_cowell_kernels(monkeypatch):
    # the warm-up ran only the two-body + J2 kernel: a later process compiled the full force
    # model (SRP, drag, third bodies, events, a finite burn's thrust) for ~19 s and the batch
    # kernel for ~10 s on its first call
    from visviva.satellites import cowell, cowell_batch

    seen = set()
    kind = cowell.rhs_kind

    def spy(which):
        def rhs_kind(force, *ev_kind):
            full = kind(force, *ev_kind)
            seen.add((which, full is not None))  # None: zonal only
            return full
        return rhs_kind

    monkeypatch.setattr(cowell, "rhs_kind", spy("one"))
    monkeypatch.setattr(cowell_batch, "rhs_kind", spy("many"))
    tasks = [(label, task) for label, task in warmup.TASKS if label.startswith("Cowell")]
    assert all(r[2] is None for r in warmup.warmup(tasks, progress=False, stream=io.StringIO()))
    assert {("one", False), ("one", True), ("many", False), ("many", True)} <= seen


def _nothing_compiles_after(tmp_path, labels, use, **env):
    """Run the warm-up tasks whose labels start with ``labels`` in a fresh process on an empty
    numba cache (``tmp_path``), then the script ``use`` in another: returns the names of the
    kernels ``use`` compiled (should be none). ``use`` must import ``gc`` and ``_Kernel``."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), **env}
    fill = ("from visviva import warmup\nfor label, task in warmup.TASKS:\n"
            f"    if label.startswith({tuple(labels)!r}):\n        task()\n")
    subprocess.run([sys.executable, "-c", fill], env=env, check=True)
    listing = ("\ncompiled = [k.py_func.__name__ for k in gc.get_objects() if isinstance(k, "
               "_Kernel)\n            and sum(k.stats.cache_misses.values())]\n"
               "print(sorted(compiled))\n")
    out = subprocess.run([sys.executable, "-c", use + listing], env=env, check=True,
                         capture_output=True, text=True).stdout
    return out.strip()


@pytest.mark.slow
def test_after_warmup_a_new_process_compiles_no_cowell_kernel(tmp_path):
    use = """
import gc
import numpy as np
from astropy import units as u
from astropy.time import Time
import visviva as vv
from visviva.core._jit import _Kernel
ep = Time("2024-03-01T00:00:00", scale="utc")
one = vv.StateVectors([7000.0, 0, 0] * u.km, [0, 7.5, 1.0] * u.km / u.s, vv.EARTH, epoch=ep)
many = vv.StateVectors([[7000.0, 0, 0]] * 3 * u.km, [[0, 7.5, 1.0]] * 3 * u.km / u.s, vv.EARTH,
                       epoch=ep)
burn = vv.FiniteBurn(60 * u.s, 100 * u.s, [1, 0, 0], "RTN", thrust=1 * u.N, mass=100 * u.kg)
srp = vv.SolarRadiationPressure(0.02 * u.m**2 / u.kg, shadow="conical")
vv.propagate_cowell(one, 3600 * u.s, [srp], events=[vv.satellites.Eclipse()], maneuvers=[burn])
vv.propagate_cowell(many, 3600 * u.s, [vv.J2(vv.EARTH)], maneuvers=[burn])
"""
    assert _nothing_compiles_after(tmp_path, ["Cowell"], use) == "[]"


def test_warmup_covers_the_pass_search_and_screening_kernels():
    # was: `visviva warmup` ("compile every numba kernel") left out the pass search and the
    # catalogue screening: after it, a first find_passes still compiled for 10 s (25 s on an
    # empty cache) and a first screen_conjunctions for 7 s (audit14)
    from visviva.core import screening, topocentric
    from visviva.satellites import groundtrack, secular_batch

    tasks = dict(warmup.TASKS)
    chosen = [(label, fn) for label, fn in warmup.TASKS
              if label.startswith(("ground stations", "conjunctions: catalogue"))]
    assert len(chosen) == 2, sorted(tasks)
    results = warmup.warmup(tuple(chosen), progress=False, stream=io.StringIO())
    assert [r[2] for r in results] == [None, None]
    for kernel in (secular_batch.secular_grid, topocentric.scan_passes, topocentric.razel_many,
                   topocentric.elevation_rate_many, groundtrack.shadow_fraction_many,
                   screening.screen_rows):
        assert kernel.signatures, kernel.py_func.__name__


def test_warmup_covers_the_default_window_of_pc3d_hall():
    # the default window of method="pc3d_hall" scans the mean separation with its own kernel;
    # the warm-up ran an explicit window only, so a first default call still compiled it
    import warnings

    from visviva.core import nc3d

    chosen = [(label, fn) for label, fn in warmup.TASKS if label.startswith("conjunctions: Foster")]
    assert len(chosen) == 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        results = warmup.warmup(tuple(chosen), progress=False, stream=io.StringIO())
    assert [r[2] for r in results] == [None]
    for kernel in (nc3d.mean_separations, nc3d.pop_linearise, nc3d.log_rates):
        assert kernel.signatures, kernel.py_func.__name__


def test_warmup_covers_lambert_universal_the_stm_foster_many_and_the_path_filter():
    # was: `visviva warmup` left out lambert(method="universal") (universal_many), the two-body
    # STM of state_transition_matrix / propagate_covariance / collision_probability("3d")
    # (two_body_stm), the Foster kernel over arrays (log_pc_many) and the screening filters'
    # pair counts (count_filter_survivors): after it, their first calls still compiled
    # (cold, 2 cores: log_pc_many 19 s, count_filter_survivors 20 s, two_body_stm 4.6 s)
    from visviva.core import collision, lambert, orbit_path, stm

    chosen = [(label, fn) for label, fn in warmup.TASKS
              if label.startswith(("Lambert", "conjunctions: two-body", "conjunctions: catalogue"))]
    assert len(chosen) == 3, sorted(dict(warmup.TASKS))
    results = warmup.warmup(tuple(chosen), progress=False, stream=io.StringIO())
    assert [r[2] for r in results] == [None, None, None]
    for kernel in (lambert.izzo_many, lambert.universal_many, stm.two_body_stm,
                   collision.log_pc_many, collision.log_pc_chan_many,
                   orbit_path.count_filter_survivors):
        assert kernel.signatures, kernel.py_func.__name__


def test_dense_output_is_compiled_inside_the_warmed_integrators():
    # dense_coefficients (DOP853's dense output) is an inline kernel: it has no machine code of
    # its own but is compiled into integrate_cowell and integrate_variational, which the Cowell
    # and covariance tasks warm (a first call from Python would compile it alone, for nothing)
    import inspect

    from visviva.core import cowell, variational

    assert cowell.dense_coefficients.targetoptions.get("forceinline")
    for caller in (cowell.integrate_cowell, variational.integrate_variational):
        assert "dense_coefficients(" in inspect.getsource(caller.py_func)
    labels = [label for label, _ in warmup.TASKS]
    assert "Cowell propagation" in labels
    assert "covariance propagation and orbit fits (STM)" in labels


@pytest.mark.slow
def test_after_warmup_a_new_process_compiles_none_of_the_added_entry_points(tmp_path):
    use = """
import gc
import numpy as np
from astropy import units as u
import visviva as vv
from visviva.conjunctions import state_transition_matrix
from visviva.conjunctions.screening import filter_statistics
from visviva.conjunctions.sources import SgpSource
from visviva.core import collision as kern
from visviva.core._jit import _Kernel
x = np.array([12.0, 150.0]); out = np.empty(2); st = np.empty(2, dtype=np.int64)
kern.log_pc_many(x, x, np.array([120.0, 300.0]), np.array([40.0, 90.0]), np.array([3.0, 10.0]),
                 kern.GAUSS_LO, kern.GAUSS_HI, 1e-13, out, st)
vv.lambert([7100.0, 0, 0] * u.km, [0, 7900.0, 10.0] * u.km, 2800 * u.s, vv.EARTH,
           method="universal")
state_transition_matrix([7100.0, 0, 0] * u.km, [0, 7.4, 1.1] * u.km / u.s, 100 * u.s, vv.EARTH)
cat = vv.Catalog([vv.Satellite.from_tle(
    "1 25544U 98067A   19343.69339541  .00001764  00000-0  38792-4 0  9991",
    "2 25544  51.6439 211.2001 0007417  17.6667  85.6398 15.50103472202482"),
    vv.Satellite.from_tle(
    "1 25545U 98067A   19343.69339541  .00001764  00000-0  38792-4 0  9992",
    "2 25545  51.6439 211.2001 0007417  17.6667  86.1398 15.50103472202489")])
t0 = cat[0].epoch.utc
src = SgpSource(cat, float(t0.jd1), float(t0.jd2))
filter_statistics(src, src, 7200.0, 50.0)
"""
    labels = ["Lambert", "conjunctions: two-body", "conjunctions: catalogue"]
    assert _nothing_compiles_after(tmp_path, labels, use, VISVIVA_INTERPRET="0") == "[]"


def test_warmup_covers_the_ensemble_kernel_and_megno():
    # was: `visviva warmup` left out the ensemble kernel (ensemble_run: a first packed ensemble
    # after the warmup still compiled it, 2.9 s of CPU) and the scalar elements -> state
    # kernels of sim.add(a=..., primary=0); MEGNO's tangent maps live in the integrators' MEGNO
    # kernels (audit40: a first MEGNO run on an empty cache compiled for 11-44 s of CPU; 9-30 s
    # since the MEGNO kernels were split off the few-body ones, megnocold)
    from visviva.core import nbody_ensemble, nbody_ias15, nbody_leapfrog, nbody_whfast

    chosen = [(label, fn) for label, fn in warmup.TASKS
              if label.startswith(("N-body: MEGNO", "N-body: ensembles"))]
    assert len(chosen) == 2, sorted(dict(warmup.TASKS))
    results = warmup.warmup(tuple(chosen), progress=False, stream=io.StringIO())
    assert [r[2] for r in results] == [None, None]
    for kernel in (nbody_ensemble.ensemble_run, nbody_ias15.ias15_run_megno,
                   nbody_leapfrog.leapfrog_run_megno, nbody_whfast.whfast_run_megno):
        assert kernel.signatures, kernel.py_func.__name__


@pytest.mark.slow
def test_after_warmup_a_new_process_compiles_nothing_for_megno_and_ensembles(tmp_path):
    use = """
import gc
import visviva as vv
from visviva.core._jit import _Kernel
sims = []
for integrator, kw in (("ias15", {}), ("leapfrog", {"dt": 0.005}), ("whfast", {"dt": 0.02})):
    sim = vv.Simulation(integrator=integrator, **kw)
    sim.add(1.0); sim.add(1e-3, a=1.0, primary=0); sim.add(1e-3, a=1.25, primary=0)
    sim.move_to_com(); sim.init_megno(seed=3); sim.integrate(2.0); sim.megno(); sim.lyapunov()
    sims.append(sim)
ens = vv.Ensemble.from_simulations([sims[2], sims[2].copy()])
ens.integrate(3.0); ens.megno()
"""
    labels = ["N-body: MEGNO", "N-body: ensembles"]
    assert _nothing_compiles_after(tmp_path, labels, use, VISVIVA_INTERPRET="0") == "[]"


def test_warmup_covers_element_sets_built_from_numbers_and_single_states():
    # was: the warm-up never built a KeplerianElements from numbers (scan_coe, which checks
    # them, stayed cold) and converted batches only: a single state's arrays are C-contiguous
    # where a batch's broadcast GM is not, another signature, so a first Maneuver.phasing after
    # the warmup compiled coe_to_rv_array, scan_coe and propagate_many (5 s) once the
    # interpreter tier was off or spent (audit40)
    from visviva.core import elements

    chosen = [(label, fn) for label, fn in warmup.TASKS
              if label.startswith(("states <-> elements", "two-body propagation"))]
    assert len(chosen) == 2
    results = warmup.warmup(tuple(chosen), progress=False, stream=io.StringIO())
    assert [r[2] for r in results] == [None, None]
    assert elements.scan_coe.signatures
    assert len(elements.coe_to_rv_array.signatures) >= 2
