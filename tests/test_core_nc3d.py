"""Kernels of Hall's 3D-Nc method (visviva.core.nc3d): the state and Jacobian in equinoctial
elements, against visviva's two-body propagation and finite differences; and the values of the
pc3d_hall method pinned to those of the former numpy implementation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from astropy import units as u
from hypothesis import given, settings
from hypothesis import strategies as st

import visviva as vv
from visviva.conjunctions import collision_probability
from visviva.conjunctions.nc3d import state_to_elements
from visviva.core.nc3d import state_jacobian

GM = 3.986004418e14  # m^3/s^2

STATES = [
    (np.array([7000e3, 0.0, 0.0]), np.array([0.0, 7500.0, 1000.0])),  # LEO, e ~ 0.1
    (np.array([-837964.597, -817188.717, 7094136.015]),
     np.array([-2670.646534, 6931.563469, 482.778663])),  # CARA's Omitron case, near circular
    (np.array([9000e3, 2000e3, -3000e3]), np.array([-1500.0, 8200.0, 2500.0])),  # HEO, e ~ 0.6
]


def _state(e, t):
    x, jac = np.empty(6), np.empty((6, 6))
    state_jacobian(e, t, GM, x, jac)
    return x, jac


@pytest.mark.parametrize("k", range(len(STATES)))
def test_state_matches_two_body_propagation(k):
    r, v = STATES[k]
    e = state_to_elements(np.concatenate([r, v]), GM)
    x0, _ = _state(e, 0.0)
    np.testing.assert_allclose(x0, np.concatenate([r, v]), rtol=0, atol=1e-6)  # m, m/s
    sv = vv.StateVectors(r / 1e3 * u.km, v / 1e3 * u.km / u.s, GM / 1e9 * u.km**3 / u.s**2)
    for t in (-3000.0, 1234.5, 5000.0):
        x, _ = _state(e, t)
        ref = sv.propagate(t * u.s)
        np.testing.assert_allclose(x[:3], ref.r.to_value(u.m), rtol=0, atol=1e-4)
        np.testing.assert_allclose(x[3:], ref.v.to_value(u.m / u.s), rtol=0, atol=1e-7)


@pytest.mark.parametrize("k", range(len(STATES)))
def test_jacobian_matches_central_differences(k):
    r, v = STATES[k]
    e = state_to_elements(np.concatenate([r, v]), GM)
    t = 1800.0
    _, jac = _state(e, t)
    steps = 1e-6 * np.maximum(np.abs(e), 1e-3)
    steps[0] = 1e-7 * e[0]
    for j in range(6):
        de = np.zeros(6)
        de[j] = steps[j]
        fd = (_state(e + de, t)[0] - _state(e - de, t)[0]) / (2 * steps[j])
        np.testing.assert_allclose(jac[:, j], fd, rtol=2e-6,
                                   atol=2e-6 * float(np.max(np.abs(jac[:, j]))))


# ln Pc of the numpy implementation this kernel replaced (visviva before session 8), to full
# precision; the kernels agree to 2e-8 on every case of tests/test_conjunctions_alfano.py
# (2e-7 on a case whose far time points leave the elliptic domain)
@pytest.mark.parametrize("case, old", [(5, -3.112430031057701), (8, -3.345283138723048)])
def test_pc3d_hall_keeps_the_values_of_the_numpy_implementation(case, old):
    from test_conjunctions_alfano import CASES, _args

    c = CASES[case]
    lp = collision_probability(*_args(c), method="pc3d_hall", window=(-c["window"], c["window"]),
                               gm=3.986004418e5, log=True)
    assert math.exp(lp - old) - 1 == pytest.approx(0.0, abs=1e-7)


@settings(max_examples=25, deadline=None)
@given(n=st.floats(6e-4, 1.2e-3), ecc=st.floats(0.0, 0.7), w=st.floats(-3.0, 3.0),
       tani=st.floats(0.0, 3.0), node=st.floats(-3.0, 3.0), lam=st.floats(-3.0, 3.0),
       t=st.floats(-5000.0, 5000.0))
def test_jacobian_matches_central_differences_everywhere(n, ecc, w, tani, node, lam, t):
    e = np.array([n, ecc * math.cos(w), ecc * math.sin(w), tani * math.sin(node),
                  tani * math.cos(node), lam])
    _, jac = _state(e, t)
    for j in range(6):
        step = 1e-7 * e[0] if j == 0 else 1e-6
        de = np.zeros(6)
        de[j] = step
        fd = (_state(e + de, t)[0] - _state(e - de, t)[0]) / (2 * step)
        np.testing.assert_allclose(jac[:, j], fd, rtol=1e-4,
                                   atol=1e-4 * float(np.max(np.abs(jac[:, j]))) + 1e-9)


def _brute_force_log_rate(ru, vu, ps, hbr, n_theta=300, n_phi=600):
    """The flux into the sphere on a dense Gauss-Legendre x uniform grid over the whole sphere."""
    from scipy.special import ndtr

    x, wx = np.polynomial.legendre.leggauss(n_theta)  # u = cos(theta)
    phi = (np.arange(n_phi) + 0.5) * 2 * np.pi / n_phi
    u, ph = np.meshgrid(x, phi, indexing="ij")
    s = np.sqrt(1 - u * u)
    nv = np.stack([s * np.cos(ph), s * np.sin(ph), u], axis=-1).reshape(-1, 3)
    wts = (wx[:, None] * np.full(n_phi, 2 * np.pi / n_phi)[None, :]).ravel()
    a, b, c = ps[:3, :3], ps[3:, :3], ps[3:, 3:]
    ainv = np.linalg.inv(a)
    d = hbr * nv - ru
    dens = np.exp(-0.5 * np.einsum("ki,ij,kj->k", d, ainv, d)) / math.sqrt(
        (2 * math.pi) ** 3 * np.linalg.det(a))
    bs = b @ ainv
    mu = -np.einsum("ki,ki->k", nv, vu + d @ bs.T)
    sd = np.sqrt(np.einsum("ki,ij,kj->k", nv, c - bs @ b.T, nv))
    ez = mu * ndtr(mu / sd) + sd * np.exp(-0.5 * (mu / sd) ** 2) / math.sqrt(2 * math.pi)
    return math.log(hbr * hbr * float(np.sum(wts * dens * ez)))


@pytest.mark.parametrize("seed", range(4))
def test_sphere_rule_matches_a_dense_grid_over_the_whole_sphere(seed):
    from visviva.conjunctions.nc3d import _K_SIGMA, _N_PHI, _N_U, _legendre
    from visviva.core.nc3d import log_rates

    rng = np.random.default_rng(seed)
    hbr = 20.0
    m = rng.normal(size=(6, 6)) * np.r_[15.0, 25.0, 40.0, 0.5, 0.5, 0.5][:, None]
    ps = m @ m.T + np.diag([4.0, 4.0, 4.0, 1e-3, 1e-3, 1e-3])
    ru = rng.normal(size=3) * 15.0
    vu = rng.normal(size=3) * 3.0 + np.array([0.0, 0.0, 2.0])
    w, vecs = np.linalg.eigh(ps[:3, :3])
    out = np.empty(1)
    log_rates(ru[None], vu[None], ps[None], w[None], vecs[None], hbr, _K_SIGMA,
              _legendre(_N_U), _legendre(_N_PHI), out)
    assert out[0] == pytest.approx(_brute_force_log_rate(ru, vu, ps, hbr), abs=1e-6)


def test_singular_position_covariance_is_refused_with_a_reason():
    # no position uncertainty at all: the relative position density at TCA is a point mass; the
    # peak-overlap kernel reports POP_SINGULAR and the method says what to check
    from visviva.errors import ConvergenceError

    r1, v1 = np.array([7000.0, 0.0, 0.0]), np.array([0.0, 7.5, 0.0])
    c = np.diag([0.0, 0.0, 0.0, 1e-6, 1e-6, 1e-6])
    with pytest.raises(ConvergenceError, match="singular position covariance"):
        collision_probability(r1, v1, c, r1 + np.array([0.1, 0.05, 0.0]),
                              np.array([0.0, 5.0, 5.6]), c, 0.02, method="pc3d_hall",
                              window=(-60.0, 60.0))
