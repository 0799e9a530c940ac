"""IAS15 on close encounters and very eccentric binaries, against the installed REBOUND.

The energy error of a tight, eccentric pair far from the origin is set by the round-off of the
absolute positions the forces are evaluated at (``eps |x|`` instead of ``eps |d|``). visviva's
IAS15 evaluates gravity on its compensated two-part positions for such steps
(:func:`visviva.core.gravity_split.gravity_split`); REBOUND's IAS15 (gravity "basic") does not.
See docs/nbody.md, "IAS15 on close encounters".
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

import visviva as vv
from visviva.core import gravity as g
from visviva.core import gravity_split as gs
from visviva.core import nbody_ias15 as ias

rebound = pytest.importorskip("rebound")

PYTHAGOREAN = ([3.0, 4.0, 5.0], [[1.0, 3.0, 0.0], [-2.0, -1.0, 0.0], [1.0, -1.0, 0.0]])


def _pair(e, offset, a=0.1, m1=5.0, m2=4.0):
    """A two-body orbit at pericentre, its centre of mass at ``offset`` (N-body units)."""
    mu = m1 + m2
    rp = a * (1 - e)
    vp = np.sqrt(mu * (1 + e) / rp)
    off = np.asarray(offset, dtype=float)
    x = [off + [-m2 / mu * rp, 0, 0], off + [m1 / mu * rp, 0, 0]]
    v = [np.array([0.0, -m2 / mu * vp, 0]), np.array([0.0, m1 / mu * vp, 0])]
    period = 2 * np.pi * np.sqrt(a**3 / mu)
    return [m1, m2], x, v, period


def _both(masses, xs, vs=None):
    vs = vs if vs is not None else [np.zeros(3)] * len(masses)
    sim = vv.Simulation("ias15")
    r = rebound.Simulation()
    r.integrator = "ias15"
    for m, x, v in zip(masses, xs, vs, strict=True):
        sim.add(m, r=x, v=v)
        r.add(m=m, x=x[0], y=x[1], z=x[2], vx=v[0], vy=v[1], vz=v[2])
    return sim, r


def test_pythagorean_problem_to_t100_beats_rebound():
    # Burrau's problem: close triple encounters, then (t > 70) a binary with e ~ 0.99 that
    # drifts away from the origin. Default settings both, integrated to 20 and then 100.
    sim, r = _both(*PYTHAGOREAN)
    E0, Er0 = sim.energy(), r.energy()
    for t in (20.0, 100.0):
        sim.integrate(t)
        r.integrate(t)
    err = abs(sim.energy() / E0 - 1)
    err_rb = abs(r.energy() / Er0 - 1)
    # measured: 8.0e-15 against REBOUND 5.2's 4.5e-12 (the code before: 1.0e-10)
    assert err < 1e-12
    assert err < err_rb
    # the same physics: the 4-5 pair ends as the bound binary in both runs
    d = np.linalg.norm(sim.positions[1] - sim.positions[2])
    dr = np.linalg.norm(np.array(r.particles[1].xyz) - np.array(r.particles[2].xyz))
    assert d < 1.0 and dr < 1.0


@pytest.mark.parametrize("e", [0.99, 0.999])
def test_eccentric_binary_far_from_the_origin_beats_rebound(e):
    masses, xs, vs, period = _pair(e, offset=[1.3, -0.7, 0.0])
    sim, r = _both(masses, xs, vs)
    # measure at apocentre (the energy of a pericentre state carries the round-off of |x| too)
    for s in (sim, r):
        s.integrate(period / 2)
    E0, Er0 = sim.energy(), r.energy()
    t_end = period * 50.5
    sim.integrate(t_end)
    r.integrate(t_end)
    err = abs(sim.energy() / E0 - 1)
    err_rb = abs(r.energy() / Er0 - 1)
    # measured over 8 starting steps x 200 orbits: median 4e-14 (e = 0.99) and 6e-13
    # (e = 0.999) against REBOUND's 5e-11 and 2e-9
    assert err < err_rb / 10
    assert err < {0.99: 1e-12, 0.999: 1e-10}[e]


def test_eccentric_binary_is_as_accurate_far_from_the_origin_as_at_it():
    errs = []
    for offset in ([0.0, 0.0, 0.0], [40.0, -25.0, 10.0]):
        masses, xs, vs, period = _pair(0.99, offset=offset)
        sim = vv.Simulation("ias15")
        for m, x, v in zip(masses, xs, vs, strict=True):
            sim.add(m, r=x, v=v)
        sim.integrate(period / 2)
        E0 = sim.energy()
        sim.integrate(period * 20.5)
        errs.append(abs(sim.energy() / E0 - 1))
    assert errs[1] < 1e-12
    assert errs[1] < 30 * max(errs[0], 1e-15)


def _exact_acc(x, m):
    """Accelerations in exact rational arithmetic, rounded once (G = 1)."""
    n = len(m)
    out = np.zeros((n, 3))
    for i in range(n):
        acc = [Fraction(0)] * 3
        for j in range(n):
            if j == i:
                continue
            d = [x[j][c] - x[i][c] for c in range(3)]
            r2 = sum(dc * dc for dc in d)
            r3 = Fraction(float(r2) ** 1.5)  # the cube of the distance to double precision
            acc = [acc[c] + Fraction(m[j]) * d[c] / r3 for c in range(3)]
        out[i] = [float(a) for a in acc]
    return out


def test_gravity_split_keeps_the_separation_of_a_tight_pair_far_away():
    # a pair 1e-6 apart at 1e3 from the origin: rounded positions lose 9 of 16 digits of the
    # separation; the two-part positions keep them
    rng = np.random.default_rng(3)
    centre = np.array([1e3, -7e2, 3e2])
    exact = [centre + rng.normal(size=3) * 1e-6 for _ in range(2)] + [np.array([0.3, 0.1, 0.2])]
    hi = np.array(exact)
    lo = rng.normal(size=(3, 3)) * 1e-14  # the part below the doubles
    xq = [[Fraction(hi[i, c]) + Fraction(lo[i, c]) for c in range(3)] for i in range(3)]
    m = np.array([1.0, 0.5, 2.0])
    ref = _exact_acc(xq, m)
    massive = g.massive_indices(m)
    a_split = np.empty((3, 3))
    a_plain = np.empty((3, 3))
    gs.gravity_split(hi, lo, m, 1.0, 0.0, massive, a_split, np.empty((g.GWORK_ROWS, 3)), False)
    g.gravity(hi, m, 1.0, 0.0, massive, a_plain, np.empty((g.GWORK_ROWS, 3)), False)
    rel_split = np.abs(a_split[:2] - ref[:2]).max() / np.abs(ref[:2]).max()
    rel_plain = np.abs(a_plain[:2] - ref[:2]).max() / np.abs(ref[:2]).max()
    assert rel_split < 1e-14
    assert rel_plain > 1e-10  # what the rounded positions give
    # lo = 0: the same accelerations as gravity (to the last bits of the reordered sums)
    gs.gravity_split(hi, np.zeros((3, 3)), m, 1.0, 0.0, massive, a_split, np.empty((g.GWORK_ROWS, 3)), False)
    np.testing.assert_allclose(a_split, a_plain, rtol=1e-15, atol=0)


def test_gravity_split_serial_and_parallel_give_identical_bits():
    rng = np.random.default_rng(5)
    n = 600
    x = rng.normal(size=(n, 3))
    lo = rng.normal(size=(n, 3)) * 1e-17
    m = np.where(rng.uniform(size=n) < 0.1, 1.0 / n, 0.0)  # few massive, many test particles
    massive = g.massive_indices(m)
    a1 = np.empty((n, 3))
    a2 = np.empty((n, 3))
    gs.gravity_split(x, lo, m, 1.0, 1e-6, massive, a1, np.empty((g.GWORK_ROWS, n)), False)
    gs.gravity_split(x, lo, m, 1.0, 1e-6, massive, a2, np.empty((g.GWORK_ROWS, n)), True)
    assert np.array_equal(a1, a2)


def test_split_positions_only_for_tight_pairs_far_from_the_origin():
    sim = vv.solar_system(integrator="ias15")
    massive = g.massive_indices(sim.masses)
    # the planets: no pair closer than 1/8 of its distance from the origin (the steps keep
    # the plain gravity kernel, bit for bit the code before)
    assert not ias._tight_pair(sim.positions, massive)
    masses, xs, _, _ = _pair(0.99, offset=[1.3, -0.7, 0.0])
    assert ias._tight_pair(np.array(xs), g.massive_indices(np.array(masses)))
    assert not ias._tight_pair(np.array(xs) - np.mean(xs, axis=0), np.array([0, 1]))


def test_state_saved_before_the_low_part_slot_continues_bit_for_bit():
    # files written before slot 75 existed hold 75 IAS15 slots; they continue unchanged
    a = vv.solar_system(integrator="ias15")
    a.integrate(3.0)
    b = a.copy()
    b._state.buf = np.ascontiguousarray(b._state.buf[:75])
    a.integrate(6.0)
    b.integrate(6.0)
    assert np.array_equal(a.positions, b.positions)
    assert np.array_equal(a.velocities, b.velocities)


def test_gravity_split_few_and_packed_paths_agree_bit_for_bit():
    # below SPLIT_FEW_N massive particles a plain pair loop, above it the packed rows: both sum
    # each acceleration in the order of j, so they give the same bits (serial and parallel too)
    rng = np.random.default_rng(11)
    n = 5
    x = rng.normal(size=(n, 3)) * 3.0
    lo = rng.normal(size=(n, 3)) * 1e-16
    m = rng.uniform(0.5, 2.0, n)
    m[4] = 0.0  # a test particle
    massive = g.massive_indices(m)
    assert len(massive) < gs.SPLIT_FEW_N
    a_few = np.empty((n, 3))
    a_packed = np.empty((n, 3))
    a_parallel = np.empty((n, 3))
    gs.gravity_split(x, lo, m, 1.0, 0.0, massive, a_few, np.empty((g.GWORK_ROWS, n)), False)
    gs._gravity_split_serial(x, lo, m, 1.0, 0.0, massive, a_packed, np.empty((g.GWORK_ROWS, n)))
    gs._gravity_split_parallel(x, lo, m, 1.0, 0.0, massive, a_parallel,
                               np.empty((g.GWORK_ROWS, n)))
    np.testing.assert_array_equal(a_few, a_packed)
    np.testing.assert_array_equal(a_few, a_parallel)


@pytest.mark.parametrize("nm", [3, gs.SPLIT_FEW_N - 1, gs.SPLIT_FEW_N, gs.SPLIT_FEW_N + 1, 40])
def test_gravity_split_is_the_strict_sum_over_j(nm):
    # every few-body path sums each acceleration over j in ascending order, left to right: the
    # same bits on every CPU (any vector width) and in the interpreter tier
    rng = np.random.default_rng(nm)
    n = nm + 3
    x = rng.normal(size=(n, 3)) * 3.0
    lo = rng.normal(size=(n, 3)) * 1e-16
    m = np.zeros(n)
    m[rng.permutation(n)[:nm]] = rng.uniform(0.5, 2.0, nm)
    massive = g.massive_indices(m)
    ref = np.zeros((n, 3))
    for j in massive:
        d = (x[j] - x) + (lo[j] - lo)
        r2 = (d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2] + 1e-6
        s = (1.3 * m[j]) / (r2 * np.sqrt(r2))
        ref += d * s[:, None]
    for parallel in (None, False, True):
        a = np.empty((n, 3))
        gs.gravity_split(x, lo, m, 1.3, 1e-6, massive, a, np.empty((g.GWORK_ROWS, n)), parallel)
        np.testing.assert_array_equal(a, ref)
