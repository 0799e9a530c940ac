"""The interpreter tier of single calls (core/tier.py): elements, two-body propagation, Cowell.

A small call on a fresh install runs the kernel's Python source instead of compiling it; it must
give the bits the machine code gives, for every input the kernels take, and the machine code
must take over where Python raises or a step cap is reached.
"""

from __future__ import annotations

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva.core import tier

KM, KMS = u.km, u.km / u.s
EPOCH = Time("2024-03-20T12:00:00", scale="utc")


def _both(force_tier, fn, clean=True):
    # ``clean``: the interpreted run must not have raised (degenerate inputs may: Python raises
    # where the machine code returns inf and a status; the machine code then runs the call)
    out = []
    for mode in ("interpreted", "compiled"):
        force_tier(mode)
        out.append(fn())
        if mode == "interpreted":
            assert tier.spent["cpu_s"] > 0  # it ran interpreted
            assert not (clean and tier.spent["off"])
    return out


_finite = st.floats(-5e4, 5e4, allow_nan=False)
_states = st.tuples(st.lists(st.tuples(_finite, _finite, _finite), min_size=1, max_size=6),
                    st.lists(st.tuples(*(st.floats(-12.0, 12.0),) * 3), min_size=1, max_size=6))


@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(states=_states, dt=st.floats(-2e5, 2e5))
def test_elements_and_propagation_are_bit_identical_across_tiers(force_tier, states, dt):
    # any conic (ellipses, hyperbolas, near-parabolic and near-circular orbits, equatorial
    # ones), either direction in time; degenerate inputs raise the same error in both tiers
    rs, vs = states
    n = min(len(rs), len(vs))
    r, v = np.array(rs[:n]), np.array(vs[:n])
    if np.any(np.linalg.norm(r, axis=1) < 100.0):
        r = r + 7000.0

    def run():
        s = vv.StateVectors(r * KM, v * KMS, vv.EARTH)
        results = []
        for f in (lambda: s.to_elements(), lambda: s.propagate(dt * u.s)):
            try:
                results.append(f())
            except vv.errors.VisvivaError as exc:
                results.append(type(exc).__name__)
        el, moved = results
        el = el if isinstance(el, str) else np.stack([np.asarray(q) for q in el.stored_arrays()])
        moved = moved if isinstance(moved, str) else np.concatenate(
            [moved.r.value.ravel(), moved.v.value.ravel()])
        return el, moved

    (e1, m1), (e2, m2) = _both(force_tier, run, clean=False)
    for a, b in ((e1, e2), (m1, m2)):
        if isinstance(a, str):
            assert a == b
        else:
            np.testing.assert_array_equal(a, b)


def _cowell(perturbations, events=(), days=0.3):
    state = vv.StateVectors([7000.0, 0.0, 0.0] * KM, [0.0, 5.3, 5.3] * KMS, vv.EARTH,
                            epoch=EPOCH)
    out = vv.propagate_cowell(state, np.linspace(0, days, 7) * u.day,
                              perturbations=list(perturbations), events=list(events))
    return np.concatenate([out.r.value.ravel(), out.v.value.ravel(), [out.n_steps]])


@pytest.mark.parametrize("perturbations", [
    [],
    [vv.J2(vv.EARTH)],
    [vv.Zonal(vv.EARTH, 4), vv.AtmosphericDrag(0.01 * u.m**2 / u.kg), vv.ThirdBody(vv.SUN),
     vv.ThirdBody(vv.MOON), vv.SolarRadiationPressure(0.02 * u.m**2 / u.kg, shadow="conical")],
    [vv.J2(vv.EARTH), vv.SolarRadiationPressure(0.02 * u.m**2 / u.kg, shadow="cylindrical")],
], ids=["two-body", "J2", "full", "cylindrical-shadow"])
def test_cowell_is_bit_identical_across_tiers(force_tier, perturbations):
    a, b = _both(force_tier, lambda: _cowell(perturbations))
    np.testing.assert_array_equal(a, b)


def test_cowell_events_are_bit_identical_across_tiers(force_tier):
    def run():
        state = vv.StateVectors([7000.0, 0.0, 0.0] * KM, [0.0, 5.3, 5.3] * KMS, vv.EARTH,
                                epoch=EPOCH)
        out = vv.propagate_cowell(state, [0.0, 0.2] * u.day, perturbations=[vv.J2(vv.EARTH)],
                                  events=[vv.satellites.Eclipse(), vv.satellites.Apsides()])
        return np.array([[e.t.to_value(u.s), *e.r.to_value(KM), *e.v.to_value(KMS)]
                         for e in out.events])

    a, b = _both(force_tier, run)
    assert a.shape[0] >= 2  # eclipse entries/exits and apsides were found
    np.testing.assert_array_equal(a, b)


def test_cowell_beyond_the_interpreter_step_cap_is_run_by_the_machine_code(force_tier,
                                                                          monkeypatch):
    # a budget of 0.05 s affords about 50 interpreted steps: the 2-day run (about 1500 steps)
    # reaches the cap, is dropped with its arrays restored, and runs compiled: the same result
    force_tier("interpreted", budget=0.05)
    monkeypatch.setattr("visviva.satellites.cowell._INTERPRETED_STEP_S", {"s": 1e-3})
    a = _cowell([vv.J2(vv.EARTH)], days=2.0)
    assert tier.spent["cpu_s"] > 0
    force_tier("compiled")
    b = _cowell([vv.J2(vv.EARTH)], days=2.0)
    np.testing.assert_array_equal(a, b)


def test_python_raising_restores_the_arrays_and_switches_the_tier_off(force_tier):
    force_tier("interpreted")
    x = np.array([1.0, 2.0])

    def kernel_like(a):
        a[0] = 99.0
        return 1.0 / 0.0  # Python raises where the machine code gives inf

    ok, result = tier.run_guarded(kernel_like, (x,))
    assert not ok and result is None
    assert tier.spent["off"]
    np.testing.assert_array_equal(x, [1.0, 2.0])


def test_large_calls_compile(force_tier):
    force_tier("interpreted")
    n = tier.SMALL_ITEMS + 1
    r = np.tile([7000.0, 0.0, 0.0], (n, 1)) * KM
    v = np.tile([0.0, 7.5, 1.0], (n, 1)) * KMS
    vv.StateVectors(r, v, vv.EARTH).propagate(60 * u.s)
    assert tier.spent["cpu_s"] == 0.0


_COLD = """
import sys
import numpy as np
from astropy import units as u
import visviva as vv
s = vv.StateVectors([[7000.0, 0.0, 0.0], [0.0, 42164.0, 0.0]] * u.km,
                    [[0.0, 7.5, 1.0], [-3.07, 0.0, 0.0]] * u.km / u.s, vv.EARTH)
el = s.to_elements()
moved = s.propagate(3600 * u.s)
c = vv.propagate_cowell(s[0], np.linspace(0, 86400, 145) * u.s, perturbations=[vv.J2(vv.EARTH)])
out = np.concatenate([np.ravel(el.eccentricity), moved.r.value.ravel(), c.r.value.ravel()])
print(len(compiled), out.tobytes().hex())
"""


def test_cold_first_calls_compile_nothing_and_match_the_warm_bits(cold_and_warm):
    # a fresh install (empty numba cache): elements, two-body propagation and a one-day Cowell
    # run with J2 compile no kernel, and give the bits of the compiled kernels
    cold, warm = cold_and_warm(_COLD)
    assert cold[0] == "0"
    assert cold[1] == warm[1]


def _value_or_error(f):
    try:
        out = f()
    except vv.errors.VisvivaError as exc:
        return type(exc).__name__
    return np.asarray(getattr(out, "value", out))


def _same(a, b):
    if isinstance(a, str) or isinstance(b, str):
        assert a == b
    else:
        np.testing.assert_array_equal(a, b)


@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(M=st.lists(st.floats(-50.0, 50.0), min_size=1, max_size=5),
       ecc=st.floats(0.0, 5.0) | st.sampled_from([0.0, 0.999999, 1.0, 1.000001]))
@example(M=[0.25], ecc=0.5)  # numpy's own np.cbrt differed from numba's (the C library's) here
@example(M=[1e305, -3e300], ecc=1.0)  # the parabolic branch's cbrt
def test_anomalies_are_bit_identical_across_tiers(force_tier, M, ecc):
    M = np.array(M)
    calls = [lambda: vv.mean_to_true(M, ecc), lambda: vv.true_to_mean(np.clip(M, -3.1, 3.1), ecc)]
    if ecc < 1.0:
        calls.append(lambda: vv.solve_kepler(M, ecc))
    elif ecc > 1.0:
        calls.append(lambda: vv.solve_kepler_hyperbolic(M, ecc))
    for call in calls:
        a, b = _both(force_tier, lambda call=call: _value_or_error(call), clean=False)
        _same(a, b)


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(r2=st.tuples(st.floats(-4e4, 4e4), st.floats(-4e4, 4e4), st.floats(-4e3, 4e3)),
       tof=st.floats(600.0, 2e5), revolutions=st.integers(0, 2), prograde=st.booleans(),
       branch=st.sampled_from(["left", "right"]), method=st.sampled_from(["izzo", "universal"]))
def test_lambert_is_bit_identical_across_tiers(force_tier, r2, tof, revolutions, prograde,
                                               branch, method):
    r1 = [7000.0, 0.0, 0.0] * KM

    def run():
        try:
            v1, v2 = vv.lambert(r1, np.array(r2) * KM, tof * u.s, vv.EARTH, revolutions,
                                prograde, branch=branch, method=method)
        except (vv.errors.VisvivaError, ValueError) as exc:
            return type(exc).__name__
        return np.concatenate([v1.value, v2.value])

    a, b = _both(force_tier, run, clean=False)
    _same(a, b)


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(a=st.floats(6600.0, 5e5), ecc=st.floats(0.0, 0.99), inc=st.floats(0.0, 3.14159),
       angles=st.tuples(*(st.floats(-10.0, 10.0),) * 3))
def test_elements_to_state_is_bit_identical_across_tiers(force_tier, a, ecc, inc, angles):
    def run():
        el = vv.KeplerianElements.from_semi_major_axis(
            a * KM, ecc, inc * u.rad, angles[0] * u.rad, angles[1] * u.rad, angles[2] * u.rad,
            vv.EARTH)
        s = el.to_state()
        return np.concatenate([s.r.value, s.v.value])

    x, y = _both(force_tier, run)
    _same(x, y)


# numpy functions whose scalar results may differ in the last place from the C library's, which
# numba compiles them to: a kernel must use math.* (or core._intrinsics.cbrt) instead, so that
# the interpreter tier gives the machine code's bits
_NUMPY_ROUNDING_DIFFERS = {"sin", "cos", "tan", "arcsin", "arccos", "arctan", "arctan2", "sinh",
                           "cosh", "tanh", "arcsinh", "arccosh", "arctanh", "exp", "exp2",
                           "expm1", "log", "log2", "log10", "log1p", "cbrt", "power", "hypot"}
_KERNEL_DECORATORS = {"kernel", "parallel_kernel", "inline_kernel", "simd_kernel", "step_kernel"}


def test_kernels_call_no_numpy_function_that_rounds_differently():
    import ast
    from pathlib import Path

    import visviva.core

    found = []
    for path in Path(visviva.core.__file__).parent.glob("*.py"):
        tree = ast.parse(path.read_text())
        for fn in ast.walk(tree):
            if not isinstance(fn, ast.FunctionDef):
                continue
            names = {getattr(d, "id", getattr(d, "attr", None)) for d in fn.decorator_list}
            if not names & _KERNEL_DECORATORS or fn.name == "cbrt":
                continue
            for node in ast.walk(fn):
                if (isinstance(node, ast.Attribute) and getattr(node.value, "id", None) == "np"
                        and node.attr in _NUMPY_ROUNDING_DIFFERS):
                    found.append(f"{path.name}:{node.lineno} {fn.name}: np.{node.attr}")
    assert not found, found
