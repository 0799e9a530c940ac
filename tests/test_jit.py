"""The numba decorators of core/_jit.py: one compilation per kernel, inlining, the compile notice."""

import time

import numba
import numpy as np
import pytest

from visviva.core import _jit

pytestmark = pytest.mark.skipif(numba.config.DISABLE_JIT, reason="needs numba's compiler")

_NO_CACHE = {**_jit._FLAGS, "cache": False}


@_jit._njit(**_NO_CACHE)
def _scaled(x, k, flag):
    return x * k if flag else -x * k


@_jit._njit(**_NO_CACHE)
def _caller(x):
    # constants typed Literal[int](2), Literal[bool](True/False), then plain int64 / bool
    n = int(x)
    return _scaled(x, 2, True) + _scaled(x, 3, False) + _scaled(x, n, x > 0.0)


def test_literal_arguments_compile_once():
    assert _caller(1.5) == pytest.approx(1.5 * 2 - 1.5 * 3 + 1.5 * 1)
    # a plain numba dispatcher compiles _scaled three times here (two literal variants)
    assert len(_scaled.signatures) == 1
    assert all(not isinstance(t, numba.types.Literal) for t in _scaled.signatures[0])


def test_inline_kernel_is_llvm_alwaysinline():
    helper = _jit._njit(forceinline=True, **_NO_CACHE)(lambda a, b: a * b + 1.0)
    assert helper(2.0, 3.0) == 7.0
    (llvm,) = helper.inspect_llvm().values()
    assert "alwaysinline" in llvm


def test_kernels_use_the_unliteral_dispatcher():
    from visviva.core import nbody_whfast, universal

    for fn in (universal.propagate_many, universal.stumpff_all, nbody_whfast.whfast_run):
        assert isinstance(fn, _jit._Kernel)


def test_compile_notice_says_once_what_compiles(monkeypatch, capsys):
    monkeypatch.setattr(_jit, "COMPILE_NOTICE_S", 0.01)
    monkeypatch.setitem(_jit.notices, "said", set())
    for name in ("slow_kernel", "slow_kernel", "another_kernel"):
        with _jit.compile_notice(name):
            time.sleep(0.3)
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "compiling slow_kernel" in err and "once" in err and "visviva warmup" in err


def test_a_long_first_use_compilation_is_never_silent_for_long(monkeypatch, capsys):
    # was: one line at 2 s, then silence: a cold find_passes compiled six kernels one after
    # another for 25 s (secular_grid 11 s, scan_passes 7 s, ...) with nothing after that line
    monkeypatch.setattr(_jit, "COMPILE_NOTICE_S", 0.01)
    monkeypatch.setattr(_jit, "STILL_COMPILING_S", 0.25, raising=False)
    monkeypatch.setitem(_jit.notices, "said", set())
    monkeypatch.setitem(_jit.notices, "compiling_s", 0.0)
    with _jit.compile_notice("slow_kernel"):
        time.sleep(0.4)
    with _jit.compile_notice("next_kernel"):
        time.sleep(0.9)
    lines = capsys.readouterr().err.splitlines()
    assert lines[0].startswith("visviva: compiling slow_kernel") and len(lines) >= 3, lines
    assert all(ln.startswith("visviva: still compiling (") for ln in lines[1:]), lines
    assert any("next_kernel" in ln for ln in lines[1:]), lines
    # the total counts the process's compiling: the last line says more than 1 s
    assert float(lines[-1].split("; ")[1].split(" s ")[0]) >= 1.0, lines[-1]


def test_compile_notice_silent_when_fast_or_disabled(monkeypatch, capsys):
    monkeypatch.setitem(_jit.notices, "said", set())
    with _jit.compile_notice("fast_kernel"):
        np.zeros(3)
    monkeypatch.setattr(_jit, "COMPILE_NOTICE_S", 0.01)
    monkeypatch.setitem(_jit.notices, "enabled", False)
    with _jit.compile_notice("quiet_kernel"):
        time.sleep(0.2)
    assert capsys.readouterr().err == ""


def test_gravity_paths_share_one_compiled_pair_item():
    from visviva.core import gravity

    rng = np.random.default_rng(3)
    n = 40
    x = rng.normal(size=(n, 3))
    m = np.full(n, 1.0 / n)
    massive = np.arange(n)
    acc_serial = np.zeros((n, 3))
    acc_parallel = np.zeros((n, 3))
    gravity._gravity_pairs_serial(x, m, 1.0, 1e-4, massive, acc_serial)
    gravity._gravity_pairs_parallel(x, m, 1.0, 1e-4, massive, acc_parallel)
    np.testing.assert_array_equal(acc_serial, acc_parallel)  # same items, same order, same bits
    # with an empty cache each helper is compiled for exactly one signature; with numba's cache
    # warm the callers load their machine code and the helpers are not compiled at all (0)
    for fn in (gravity._pair_item, gravity._pair_reduce, gravity._test_rows):
        assert len(fn.signatures) <= 1, (fn, fn.signatures)


# ---- the few-body kernels: what a small N-body run compiles (issue 11, cold start) -----------

_FEW_GRAVITY = """
import numpy as np
from visviva.core import gravity, gravity_split
x = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0]])
m = np.array([1.0, 1e-3, 1e-3])
acc = np.zeros((3, 3))
work = np.zeros((gravity.GWORK_ROWS, 3))
massive = np.arange(3)
gravity.gravity(x, m, 1.0, 0.0, massive, acc, work, gravity.FEW)
gravity_split.gravity_split(x, 0.0 * x, m, 1.0, 0.0, massive, acc, work, gravity.FEW)
compiled = [f.__name__ for f in (gravity.gravity_parallel, gravity._gravity_pairs_parallel,
            gravity._gravity_pairs_serial, gravity.gravity_serial,
            gravity_split._gravity_split_parallel) if f.signatures]
print(repr(compiled), len(gravity.gravity_few.signatures))
"""


def _fresh_process(code, cache_dir):
    import os
    import subprocess
    import sys

    # what compiles is the question: the interpreter tier would run these small first calls
    # without compiling anything (visviva.core.tier)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir), VISVIVA_INTERPRET="0")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env, timeout=900, check=True)
    return proc.stdout.strip().splitlines()[-1]


def test_few_body_gravity_compiles_no_parallel_or_large_n_kernel(tmp_path):
    # FEW (None) is a type: numba drops the other branches when it types the dispatch, so with
    # an empty cache no prange region and no large-N kernel is compiled (the structure that
    # keeps a small N-body run's first call short)
    assert _fresh_process(_FEW_GRAVITY, tmp_path) == "[] 1"


_FEW_RUNS = """
import visviva as vv
from visviva.core import gravity, gravity_split, nbody_ias15, nbody_whfast
for integrator, kw in (("whfast", {"dt": 0.01}), ("ias15", {})):
    sim = vv.Simulation(integrator=integrator, G=1.0, **kw)
    sim.add(1.0, [0, 0, 0], [0, 0, 0])
    sim.add(1e-3, [1, 0, 0], [0, 1, 0])
    sim.add(1e-3, [2, 0, 0], [0, 0.7, 0])
    sim.integrate(1.0)
w = nbody_whfast
fns = (gravity.gravity_parallel, gravity._gravity_pairs_parallel, gravity._gravity_pairs_serial,
       gravity_split._gravity_split_parallel, w.whfast_run, nbody_ias15.ias15_run,
       w.whfast_run_few, w._corrector, w._phase_kick, w._dh_step)
print(repr([f.__name__ for f in fns if f.signatures]),
      len(w.whfast_run_plain.signatures), len(nbody_ias15.ias15_run_few.signatures))
"""


@pytest.mark.slow
def test_three_body_runs_compile_only_the_few_body_kernels(tmp_path):
    # a 3-body WHFast and IAS15 run with an empty cache: the few-body kernels only (one
    # signature each), no parallel gravity, no large-N kernel, not the every-path kernels;
    # WHFast's default case (Jacobi, no corrector, no events) compiles neither the corrector
    # nor the democratic heliocentric step
    assert _fresh_process(_FEW_RUNS, tmp_path) == "[] 1 1"


@pytest.mark.parametrize("kw, plain", [
    ({}, True),
    ({"exact_finish_time": False}, True),
    ({"corrector": 5}, False),
    ({"coordinates": "democratic_heliocentric"}, False),
])
def test_plain_whfast_kernel_gives_the_general_kernels_bits(monkeypatch, kw, plain):
    # the default-case kernel (whfast_run_plain) and the general few-body kernel agree to the
    # bit, at output times off the step grid (shortened steps) and through a resumed run
    import visviva as vv
    from visviva.core import nbody_whfast

    def run():
        sim = vv.Simulation(integrator="whfast", G=1.0, dt=0.013, **kw)
        sim.add(1.0, [0, 0, 0], [0, 0, 0])
        sim.add(1e-3, [1, 0, 0], [0, 1, 0])
        sim.add(1e-3, [2, 0, 0.1], [0, 0.7, 0])
        kernels.append(nbody_whfast.is_plain(sim._state.istate, sim._state.fstate))
        first = sim.integrate(np.linspace(0.0, 3.0, 7))
        second = sim.integrate(np.array([3.5, 4.0001]))
        return np.concatenate([first.positions, second.positions]), np.concatenate(
            [first.velocities, second.velocities])

    kernels = []
    x1, v1 = run()
    monkeypatch.setattr(nbody_whfast, "is_plain", lambda istate, fstate: False)
    x2, v2 = run()
    assert kernels == [plain, False]
    np.testing.assert_array_equal(x1, x2)
    np.testing.assert_array_equal(v1, v2)


@pytest.mark.parametrize("integrator, kw", [
    ("whfast", {"dt": 0.01, "corrector": 5}),
    ("whfast", {"dt": 0.01, "coordinates": "democratic_heliocentric"}),
    ("ias15", {}),
    ("leapfrog", {"dt": 0.01}),
])
def test_few_body_and_every_path_kernels_give_the_same_bits(integrator, kw):
    import visviva as vv
    from visviva.nbody.integrators import few_bodies

    runs = []
    for parallel in (None, True):  # 3 bodies: the few-body kernel; parallel: every-path one
        sim = vv.Simulation(integrator=integrator, G=1.0, parallel=parallel, **kw)
        sim.add(1.0, [0, 0, 0], [0, 0, 0])
        sim.add(1e-3, [1, 0, 0], [0, 1, 0])
        sim.add(1e-3, [2, 0, 0.1], [0, 0.7, 0])
        runs.append(sim.integrate(np.linspace(0.0, 3.0, 7)))
        st = sim._state
        assert few_bodies(st.istate, st.massive) == (parallel is None)
    np.testing.assert_array_equal(runs[0].positions, runs[1].positions)
    np.testing.assert_array_equal(runs[0].velocities, runs[1].velocities)


_ZONAL_ONLY_COWELL = """
import sys
import numpy as np
from astropy import units as u
from numba.core import event
import visviva as vv
from visviva.core import cowell, perturbations
compiled = []
class Names(event.Listener):
    def on_start(self, e):
        compiled.append(e.data["dispatcher"].py_func.__qualname__)
    def on_end(self, e):
        pass
event.register("numba:compile", Names())
s = vv.StateVectors([7000.0, 0.0, 0.0] * u.km, [0.0, 7.5, 1.0] * u.km / u.s, vv.EARTH)
vv.propagate_cowell(s, np.linspace(0, 3600, 5) * u.s, perturbations=[vv.J2(vv.EARTH)])
fns = (perturbations.cowell_rhs, perturbations.accel_drag, perturbations.accel_srp,
       perturbations.accel_harmonics, perturbations.shadow_fraction, cowell.event_function)
builtins = sorted({n.split(".")[0] for n in compiled if n.split(".")[0] in (
    "ol_np_empty", "ol_np_zeros", "ol_min", "ol_max")})
print(repr([f.__name__ for f in fns if f.signatures]), len(perturbations.zonal_rhs.signatures),
      repr(builtins), "scipy.integrate" in sys.modules)
"""


@pytest.mark.slow
def test_j2_cowell_compiles_only_the_zonal_right_hand_side(tmp_path):
    # and no numba np.empty/np.zeros/min/max overload (compiled anew in every process), and
    # the DOP853 tableau is read without importing scipy.integrate (0.2 s)
    assert _fresh_process(_ZONAL_ONLY_COWELL, tmp_path) == "[] 1 [] False"


_SERIAL_LINKING_PARALLEL = """
import sys
import numpy as np
from visviva.core import gravity as g
n = 300
rng = np.random.default_rng(1)
x = rng.normal(size=(n, 3))
m = rng.uniform(0.1, 1, n)
acc = np.zeros((n, 3))
work = np.zeros((g.GWORK_ROWS, n))
if sys.argv[1] == "parallel":
    g.gravity_parallel(x, m, 1.0, 0.0, np.arange(n), acc, work)
else:
    g.gravity_serial(x, m, 1.0, 0.0, np.arange(n), acc, work)
    g.gravity(x, m, 1.0, 0.0, np.arange(n), acc, work, False)
print(acc[0, 0].hex())
"""


def test_serial_kernel_linking_a_parallel_one_loads_from_the_cache(tmp_path):
    # gravity (serial) links gravity_parallel: loaded from numba's cache in a process whose
    # threading layer was not started, it called address 0 (a segfault in the third process
    # of this sequence); every kernel now starts the layer before it is compiled or loaded
    import os
    import subprocess
    import sys

    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    out = [subprocess.run([sys.executable, "-c", _SERIAL_LINKING_PARALLEL, which], env=env,
                          capture_output=True, text=True, timeout=900, check=True).stdout
           for which in ("parallel", "serial", "serial")]
    assert out[0] == out[1] == out[2] != ""


_STAMP_RUN = """
import sys
sys.path.insert(0, {folder!r})
from visviva.core import _jit
if {stamp!r}:
    _jit.core_sources_stamp = lambda: {stamp!r}  # as after an edit to a file of visviva.core
import stamped_kernel
print(stamped_kernel.twice(2.0), sum(stamped_kernel.twice.stats.cache_hits.values()))
"""


def test_an_edit_anywhere_in_core_invalidates_cached_kernels(tmp_path):
    # numba keys a cached kernel by its own file: a kernel whose callee lives in another file of
    # visviva.core (integrate_cowell calling core/cowell_events.py) was loaded stale from the
    # cache after the callee's file changed. The key now holds a stamp of every core source.
    folder = tmp_path / "mod"
    folder.mkdir()
    (folder / "stamped_kernel.py").write_text(
        "from visviva.core._jit import kernel\n\n@kernel\ndef twice(x):\n    return 2.0 * x\n")
    runs = [_fresh_process(_STAMP_RUN.format(folder=str(folder), stamp=stamp), tmp_path / "c")
            for stamp in ("", "", "edited", "edited", "")]
    hits = [int(line.split()[-1]) for line in runs]
    assert [line.split()[0] for line in runs] == ["4.0"] * 5
    # compiled, loaded, recompiled after the "edit", loaded, recompiled after the "revert"
    assert hits == [0, 1, 0, 1, 0]
