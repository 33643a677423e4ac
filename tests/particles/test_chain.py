"""Straight chains of rods growing end to end: exact discrete answers and the 1D continuum.

A chain of N rods on the x axis (theta = 0), touching end to end (gaps 0), has N - 1 contacts
with G = 1/2 on both rods and no torques.  The step's optimality conditions (all contacts
active) are the N - 1 equations

    dt (D^T M D gamma)_k = (1/2) [l_k (exp(dt g_k) - 1) + l_{k+1} (exp(dt g_{k+1}) - 1)],
    g_n = exp(-lam sigma_n),  sigma_n = (gamma_{n-1} + gamma_n) / 2,  gamma_0 = gamma_N = 0,

with D^T M D tridiagonal: diagonal 1/l_k + 1/l_{k+1}, off-diagonal -1/l_{k+1}.  lam = 0 is a
tridiagonal linear system (scipy.linalg.solve_banded); lam > 0 a small nonlinear system
(scipy.optimize.root), both independent of the engine's solver.

1D continuum: per unit length friction 1 and growth g, so u = -p', u' = g: -p'' = exp(-lam p),
p(+-R) = 0 with p the compressive force along the chain.  Exact solution (lam > 0):
p(x) = (2/lam) ln(cos(k x) / cos(k R)) with k = sqrt(lam/2) cos(k R); lam = 0: (R^2 - x^2)/2.
The discrete equations above (dt -> 0) are its second-order finite differences at the contact
points with the rod-averaged load, so max |sigma_n - p(x_n)| / p(0) = O(N^-2) at fixed lam R^2.
"""

import numpy as np
import pytest
from scipy.linalg import solve_banded
from scipy.optimize import brentq, root

from particles.solvers.apgd import solve_contacts_apgd
from particles.solvers.bbpgd import solve_contacts
from particles.solvers.problem import linearised_gap
from particles.stress import axial_stress


def residual_reference(gamma, lengths, dt, lam):
    """Optimality conditions of the chain (module docstring), independent of the engine."""
    n = lengths.size
    g_full = np.concatenate([[0.0], gamma, [0.0]])
    sigma = 0.5 * (g_full[:-1] + g_full[1:])
    rate = lengths * np.expm1(dt * np.exp(-lam * sigma))
    a = dt * ((1 / lengths[:-1] + 1 / lengths[1:]) * gamma)
    a[1:] -= dt * gamma[:-1] / lengths[1 : n - 1]
    a[:-1] -= dt * gamma[1:] / lengths[1 : n - 1]
    return a - 0.5 * (rate[:-1] + rate[1:])


def test_chain_contacts_are_end_to_end(chain):
    rng = np.random.default_rng(1)
    lengths = rng.uniform(1.0, 2.0, 12)
    _, c = chain(lengths)
    assert len(c) == 11
    np.testing.assert_array_equal(c.j - c.i, 1)
    np.testing.assert_allclose(c.gap, 0.0, atol=1e-14)
    np.testing.assert_allclose(c.gi, 0.5, atol=1e-14)
    np.testing.assert_allclose(c.gj, 0.5, atol=1e-14)


#: Both contact solvers must reproduce the exact chain answers.
SOLVERS = pytest.mark.parametrize(
    "solve", [solve_contacts, solve_contacts_apgd], ids=["bbpgd", "apgd"])


@SOLVERS
@pytest.mark.parametrize("n", [5, 20])
def test_chain_lam0_tridiagonal(chain, n, solve):
    rng = np.random.default_rng(n)
    lengths = rng.uniform(1.0, 2.0, n)
    dt = 0.01
    _, c = chain(lengths)
    tol = 1e-12
    gamma, hist = solve(c, lengths, dt, 0.0, tol=tol)
    # tridiagonal reference
    diag = dt * (1 / lengths[:-1] + 1 / lengths[1:])
    off = -dt / lengths[1:-1]
    ab = np.zeros((3, n - 1))
    ab[0, 1:] = off
    ab[1] = diag
    ab[2, :-1] = off
    rhs = 0.5 * (lengths[:-1] + lengths[1:]) * np.expm1(dt)
    gref = solve_banded((1, 1), ab, rhs)
    a = np.diag(diag) + np.diag(off, 1) + np.diag(off, -1)
    bound = np.abs(np.linalg.inv(a)).sum(axis=1).max() * tol  # |gamma - gref| <= |A^-1| res
    assert np.max(np.abs(gamma - gref)) <= bound
    sig = axial_stress(c, gamma, n)
    gfull = np.concatenate([[0.0], gref, [0.0]])
    np.testing.assert_allclose(sig, 0.5 * (gfull[:-1] + gfull[1:]), atol=bound, rtol=0)
    assert hist[-1] <= tol and len(hist) > 2


@SOLVERS
@pytest.mark.parametrize("lam", [0.05, 0.5])
def test_chain_lam_positive_nonlinear(chain, lam, solve):
    n = 15
    rng = np.random.default_rng(7)
    lengths = rng.uniform(1.0, 2.0, n)
    dt = 0.01
    _, c = chain(lengths)
    gamma, _ = solve(c, lengths, dt, lam, tol=1e-13)
    ref = root(residual_reference, np.ones(n - 1), args=(lengths, dt, lam), tol=1e-12)
    assert np.max(np.abs(residual_reference(ref.x, lengths, dt, lam))) < 1e-13
    np.testing.assert_allclose(gamma, ref.x, rtol=1e-8, atol=0)
    # the engine's gradient is the reference's optimality condition
    np.testing.assert_allclose(linearised_gap(c, lengths, dt, lam, gamma),
                               residual_reference(gamma, lengths, dt, lam), atol=1e-14)
    # loads are inhibited compared with lam = 0
    g0, _ = solve_contacts(c, lengths, dt, 0.0, tol=1e-13)
    assert np.all(gamma < g0)


def continuum_1d(x, radius, lam):
    """p(x) of -p'' = exp(-lam p), p(+-R) = 0 (module docstring)."""
    if lam == 0:
        return (radius**2 - x**2) / 2
    s = np.sqrt(lam / 2)
    k = brentq(lambda k: k - s * np.cos(k * radius), 0.0, np.pi / (2 * radius))
    return (2 / lam) * np.log(np.cos(k * x) / np.cos(k * radius))


@SOLVERS
@pytest.mark.parametrize("lam_r2", [0.0, 2.0])
def test_long_chain_matches_1d_continuum_second_order(chain, lam_r2, solve):
    ns = np.array([16, 32, 64, 128])
    errs = []
    for n in ns:
        lengths = np.ones(n)
        radius = n / 2
        lam = lam_r2 / radius**2
        x, c = chain(lengths)
        dt = 1e-7
        gamma, _ = solve(c, lengths, dt, lam, tol=1e-16 * radius**2)
        sig = axial_stress(c, gamma, n)
        p = continuum_1d(x, radius, lam)
        errs.append(np.max(np.abs(sig - p)) / p.max())
    rate = np.polyfit(np.log(ns), np.log(errs), 1)[0]
    assert errs[-1] < 1e-3
    assert abs(rate + 2) < 0.1, (errs, rate)


@SOLVERS
def test_chain_error_is_first_order_in_the_tolerance(chain, solve):
    """|gamma - gamma_exact| <= |A^-1|_inf res: the error follows the tolerance, order 1."""
    n = 40
    lengths = np.random.default_rng(3).uniform(1.0, 2.0, n)
    dt = 0.01
    _, c = chain(lengths)
    ref = root(residual_reference, np.ones(n - 1), args=(lengths, dt, 0.2), tol=1e-13).x
    tols = np.array([1e-5, 1e-6, 1e-7, 1e-8, 1e-9])
    errs = [np.max(np.abs(solve(c, lengths, dt, 0.2, tol=tol)[0] - ref)) / np.max(ref)
            for tol in tols]
    rate = np.polyfit(np.log(tols), np.log(errs), 1)[0]
    assert 0.7 < rate < 1.3, (errs, rate)
