"""Jacobi-scaled APGD contact solver (particles/apgd.py) against exact answers and BBPGD.

References:
- straight chain of rods (all N - 1 end-to-end contacts active): lam = 0 is a tridiagonal
  linear system, lam > 0 a small nonlinear system (scipy), both independent of the engine;
  a long chain converges to the 1D continuum pressure at second order (p(x) of
  tests/test_particles_chain.py, re-derived in its module docstring);
- dense packings (a small colony grown by the engine, concentric rings of
  cases.bench_contact_solvers):
  KKT conditions of E to the tolerance and the unique quantities of the solution (loads
  sigma = G gamma for lam > 0, displacements dt M D gamma for every lam) equal to BBPGD's.
"""

import numpy as np
import pytest
from scipy.linalg import solve_banded
from scipy.optimize import brentq, root

from cases.bench_contact_solvers import contacts_of, ring_packing, warm_problem
from particles import simulation
from particles.apgd import apgd_kernel, lipschitz_bound, solve_contacts_apgd
from particles.contact_solver import (
    ContactSolveError,
    linearised_gap,
    problem_arrays,
    solve_contacts,
)
from particles.geometry import find_contacts, generalised_forces, loads
from particles.neighbours import candidate_pairs


def chain(lengths):
    lengths = np.asarray(lengths, dtype=float)
    right = np.cumsum(lengths)
    x = right - lengths / 2 - right[-1] / 2
    z = np.zeros_like(x)
    c = find_contacts(x, z, z, lengths, candidate_pairs(x, z, lengths, 0.05), 0.05)
    return x, c


def chain_conditions(gamma, lengths, dt, lam):
    """Optimality conditions of the chain with every contact active (gap Phi = 0)."""
    n = lengths.size
    g_full = np.concatenate([[0.0], gamma, [0.0]])
    sigma = 0.5 * (g_full[:-1] + g_full[1:])
    rate = lengths * np.expm1(dt * np.exp(-lam * sigma))
    a = dt * ((1 / lengths[:-1] + 1 / lengths[1:]) * gamma)
    a[1:] -= dt * gamma[:-1] / lengths[1 : n - 1]
    a[:-1] -= dt * gamma[1:] / lengths[1 : n - 1]
    return a - 0.5 * (rate[:-1] + rate[1:])


def diagonal(c, length, dt):
    return problem_arrays(c, np.asarray(length, dtype=float), dt)[4]


def assert_kkt(c, length, dt, lam, gamma, tol, growth=True):
    """gamma >= 0, q >= -tol, |min(a gamma, q)| <= tol (so gamma_k > tol/a_kk => |q_k| <= tol)."""
    q = linearised_gap(c, length, dt, lam, gamma, growth)
    a = diagonal(c, length, dt)
    assert np.all(gamma >= 0)
    assert q.min() >= -tol
    assert np.max(np.abs(np.minimum(a * gamma, q))) <= tol
    loaded = a * gamma > tol
    assert np.all(np.abs(q[loaded]) <= tol)


@pytest.mark.parametrize("n", [5, 30])
def test_chain_lam0_equals_tridiagonal_solution(n):
    rng = np.random.default_rng(n)
    lengths = rng.uniform(1.0, 2.0, n)
    dt = 0.01
    _, c = chain(lengths)
    tol = 1e-12
    gamma, hist = solve_contacts_apgd(c, lengths, dt, 0.0, tol=tol)
    diag = dt * (1 / lengths[:-1] + 1 / lengths[1:])
    off = -dt / lengths[1:-1]
    ab = np.zeros((3, n - 1))
    ab[0, 1:] = off
    ab[1] = diag
    ab[2, :-1] = off
    gref = solve_banded((1, 1), ab, 0.5 * (lengths[:-1] + lengths[1:]) * np.expm1(dt))
    a = np.diag(diag) + np.diag(off, 1) + np.diag(off, -1)
    bound = np.abs(np.linalg.inv(a)).sum(axis=1).max() * tol  # |gamma - gref| <= |A^-1| res
    assert np.max(np.abs(gamma - gref)) <= bound
    assert hist[-1] <= tol and len(hist) > 2
    assert_kkt(c, lengths, dt, 0.0, gamma, tol)


@pytest.mark.parametrize("lam", [0.05, 0.5])
def test_chain_lam_positive_equals_nonlinear_solution(lam):
    n = 15
    lengths = np.random.default_rng(7).uniform(1.0, 2.0, n)
    dt = 0.01
    _, c = chain(lengths)
    gamma, _ = solve_contacts_apgd(c, lengths, dt, lam, tol=1e-13)
    ref = root(chain_conditions, np.ones(n - 1), args=(lengths, dt, lam), tol=1e-12)
    assert np.max(np.abs(chain_conditions(ref.x, lengths, dt, lam))) < 1e-13
    np.testing.assert_allclose(gamma, ref.x, rtol=1e-8, atol=0)


def test_chain_error_is_first_order_in_the_tolerance():
    """|gamma - gamma_exact| <= |A^-1|_inf res: the error follows the tolerance, order 1."""
    n = 40
    lengths = np.random.default_rng(3).uniform(1.0, 2.0, n)
    dt = 0.01
    _, c = chain(lengths)
    ref = root(chain_conditions, np.ones(n - 1), args=(lengths, dt, 0.2), tol=1e-13).x
    tols = np.array([1e-5, 1e-6, 1e-7, 1e-8, 1e-9])
    errs = []
    for tol in tols:
        gamma, hist = solve_contacts_apgd(c, lengths, dt, 0.2, tol=tol)
        errs.append(np.max(np.abs(gamma - ref)) / np.max(ref))
    rate = np.polyfit(np.log(tols), np.log(errs), 1)[0]
    assert 0.7 < rate < 1.3, (errs, rate)


def continuum_1d(x, radius, lam):
    """p(x) of -p'' = exp(-lam p), p(+-R) = 0 (tests/test_particles_chain.py)."""
    if lam == 0:
        return (radius**2 - x**2) / 2
    s = np.sqrt(lam / 2)
    k = brentq(lambda k: k - s * np.cos(k * radius), 0.0, np.pi / (2 * radius))
    return (2 / lam) * np.log(np.cos(k * x) / np.cos(k * radius))


@pytest.mark.parametrize("lam_r2", [0.0, 2.0])
def test_long_chain_loads_converge_to_1d_continuum_at_second_order(lam_r2):
    ns = np.array([16, 32, 64, 128])
    errs = []
    for n in ns:
        lengths = np.ones(n)
        radius = n / 2
        lam = lam_r2 / radius**2
        x, c = chain(lengths)
        dt = 1e-7
        gamma, _ = solve_contacts_apgd(c, lengths, dt, lam, tol=1e-16 * radius**2)
        p = continuum_1d(x, radius, lam)
        errs.append(np.max(np.abs(loads(c, gamma, n) - p)) / p.max())
    rate = np.polyfit(np.log(ns), np.log(errs), 1)[0]
    assert errs[-1] < 1e-3
    assert abs(rate + 2) < 0.1, (errs, rate)


@pytest.fixture(scope="module")
def grown():
    """A jammed colony grown by the engine (BBPGD, lam = 1e-2) to t = 5: ~150 particles."""
    col = simulation.run(simulation.ParticleConfig(lam=1e-2, time=5.0, dt=0.01, seed=3))
    assert col.n > 100
    return col.x, col.y, col.theta, col.length


def displacement(c, gamma, length, dt):
    fx, fy, tz = generalised_forces(c, gamma, length.size)
    return np.concatenate([dt * fx / length, dt * fy / length, dt * 12 * tz / length**3])


@pytest.mark.parametrize("lam", [0.0, 1e-2, 1.0])
def test_grown_colony_kkt_and_agreement_with_bbpgd(grown, lam):
    x, y, th, length = grown
    c = contacts_of(x, y, th, length, 0.1)
    dt = 0.005
    tol = 1e-9
    ga, _ = solve_contacts_apgd(c, length, dt, lam, tol=tol)
    gb, _ = solve_contacts(c, length, dt, lam, tol=tol)
    assert_kkt(c, length, dt, lam, ga, tol)
    assert np.count_nonzero(ga) > len(c) / 3  # a jammed colony: most contacts loaded
    # unique parts of the solution: displacements (every lam), loads (lam > 0)
    ua, ub = displacement(c, ga, length, dt), displacement(c, gb, length, dt)
    assert np.max(np.abs(ua - ub)) <= 1e-5 * np.max(np.abs(ub))
    if lam > 0:
        sa, sb = loads(c, ga, x.size), loads(c, gb, x.size)
        assert np.max(np.abs(sa - sb)) <= 1e-4 * np.max(sb)


@pytest.mark.parametrize("packing", ["grown", "rings"])
def test_warm_start_overlap_removal_and_exact_restart(grown, packing):
    x, y, th, length = grown if packing == "grown" else ring_packing(300, seed=5)
    dt, lam, tol = 0.005, 1e-2, 1e-6
    c = contacts_of(x, y, th, length, 0.1)
    g, _ = solve_contacts(c, length, dt, lam, tol=tol / 10)
    (x2, y2, th2, l2), c2, g0 = warm_problem(x, y, th, length, c, g, dt, lam, 0.1)
    gw, hw = solve_contacts_apgd(c2, l2, dt, lam, g0, tol)
    assert_kkt(c2, l2, dt, lam, gw, tol)
    # restarting from an accepted solution costs no iteration
    _, h0 = solve_contacts_apgd(c2, l2, dt, lam, gw, tol)
    assert len(h0) == 1
    # the overlap-removal problem (no growth) of the re-solve passes
    gn, _ = solve_contacts_apgd(c2, l2, dt, lam, None, tol, growth=False)
    assert_kkt(c2, l2, dt, lam, gn, tol, growth=False)


def test_lipschitz_estimate_matches_dense_eigenvalue(grown):
    x, y, th, length = grown
    c = contacts_of(x, y, th, length, 0.1)
    dt, lam = 0.005, 0.5
    m = len(c)
    mt, mr, ti, tj, akk = problem_arrays(c, length, dt)
    # dense Hessian: columns are q(e_k) - q(0) of the quadratic model with curvature c_max
    n = length.size
    dmat = np.zeros((3 * n, m))
    k = np.arange(m)
    for s, p, t in ((1.0, c.j, tj), (-1.0, c.i, ti)):
        dmat[p, k] += s * c.nx
        dmat[n + p, k] += s * c.ny
        dmat[2 * n + p, k] += s * t
    gmat = np.zeros((n, m))
    gmat[c.i, k] += c.gi
    gmat[c.j, k] += c.gj
    mob = np.concatenate([mt, mt, mr])
    cmax = length * lam * dt * np.exp(dt)
    h = dt * dmat.T @ (mob[:, None] * dmat) + gmat.T @ (cmax[:, None] * gmat)
    np.testing.assert_allclose(np.diag(h) - np.diag(gmat.T @ (cmax[:, None] * gmat)), akk)
    s = 1 / np.sqrt(akk)
    exact = np.linalg.eigvalsh(s[:, None] * h * s[None, :]).max()
    est = lipschitz_bound(c, length, dt, lam, iters=200, rtol=0.0)
    assert 0.99 * exact <= est <= exact * (1 + 1e-9)


def test_too_long_step_is_recovered_by_halving(grown):
    x, y, th, length = grown
    c = contacts_of(x, y, th, length, 0.1)
    dt, lam, tol = 0.005, 1e-2, 1e-7
    mt, mr, ti, tj, akk = problem_arrays(c, length, dt)
    lip = lipschitz_bound(c, length, dt, lam)
    gam = np.zeros(len(c))
    hist = np.full(200_001, np.nan)
    it = apgd_kernel(gam, c.i, c.j, c.nx, c.ny, ti, tj, c.gi, c.gj, c.gap, mt, mr, length,
                     dt, lam, True, akk, 8.0 / lip, tol, 200_000, hist)
    assert it > 0
    assert np.nanmax(hist) > 1e3 * np.nanmin(hist[: it + 1])  # it did blow up first
    assert_kkt(c, length, dt, lam, gam, tol)


def test_failure_raises_contact_solve_error_with_history(grown):
    x, y, th, length = grown
    c = contacts_of(x, y, th, length, 0.1)
    with pytest.raises(ContactSolveError) as err:
        solve_contacts_apgd(c, length, 0.005, 1e-2, tol=1e-14, maxiter=5)
    e = err.value
    assert e.n_particles == x.size and e.n_contacts == len(c)
    assert e.residuals.shape == (6,) and np.all(np.isfinite(e.residuals))
    assert f"N={x.size}" in str(e)


def test_bad_input_raises_value_error():
    x, c = chain(np.ones(4))
    length = np.ones(4)
    with pytest.raises(ValueError, match="dt"):
        solve_contacts_apgd(c, length, 0.0, 0.0)
    with pytest.raises(ValueError, match="lam"):
        solve_contacts_apgd(c, length, 0.01, -1.0)
    with pytest.raises(ValueError, match="gamma0"):
        solve_contacts_apgd(c, length, 0.01, 0.0, np.zeros(2))
    g, h = solve_contacts_apgd(find_contacts(x, x, x, length, (np.zeros(0, int),) * 2, 0.1),
                               length, 0.01, 0.0)
    assert g.shape == (0,) and h.shape == (1,)


def test_engine_run_with_apgd_keeps_overlap_and_matches_bbpgd():
    """A small grown colony (lam = 1e-2) with APGD selected by name in the engine."""
    assert simulation.SOLVERS["apgd"] is solve_contacts_apgd
    cfg = dict(lam=1e-2, time=3.0, dt=0.01, division_noise=0.02, seed=1)
    ca = simulation.run(simulation.ParticleConfig(solver="apgd", **cfg))
    cb = simulation.run(simulation.ParticleConfig(solver="bbpgd", **cfg))
    tol = simulation.ParticleConfig(**cfg).tol
    assert max(r["max_overlap"] for r in ca.history) <= tol
    assert ca.n >= 16
    # same law: total length and number agree to the tolerance-driven scatter
    assert abs(ca.length.sum() / cb.length.sum() - 1) < 0.02
    assert abs(ca.n - cb.n) <= 0.1 * cb.n
