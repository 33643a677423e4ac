"""Jacobi-scaled APGD contact solver (particles/apgd.py) against exact answers and BBPGD.

The exact chain answers are checked for both solvers in tests/particles/test_chain.py.
References here:
- dense packings (a small colony grown by the engine, concentric rings of
  particles.packings.ring_packing):
  KKT conditions of E to the tolerance and the unique quantities of the solution (stress
  sigma = G gamma for lam > 0, displacements dt M D gamma for every lam) equal to BBPGD's.
"""

import numba
import numpy as np
import pytest

import particles
from particles.geometry import detect_contacts, find_contacts, generalised_forces
from particles.packings import ring_packing
from particles.solvers.apgd import apgd_kernel, lipschitz_bound, solve_contacts_apgd
from particles.solvers.bbpgd import BLOCK, solve_contacts
from particles.solvers.problem import (
    ContactSolveError,
    incidence,
    law_rows,
    linearised_gap,
    problem_arrays,
)
from particles.stress import axial_stress
from tests.measurements import measurement


def diagonal(c, length, dt):
    return problem_arrays(c, np.asarray(length, dtype=float), dt)[4]


def assert_kkt(c, length, dt, lam, gamma, tol, growth=True):
    """KKT: gamma >= 0, q >= -tol, |min(a gamma, q)| <= tol (gamma_k > tol/a_kk => |q_k| <= tol)."""
    q = linearised_gap(c, length, dt, lam, gamma, growth)
    a = diagonal(c, length, dt)
    assert np.all(gamma >= 0)
    assert q.min() >= -tol
    assert np.max(np.abs(np.minimum(a * gamma, q))) <= tol
    loaded = a * gamma > tol
    assert np.all(np.abs(q[loaded]) <= tol)


@pytest.fixture(scope="module")
def grown():
    """A jammed colony grown by the engine (BBPGD, lam = 1e-2) to t = 5: ~150 particles."""
    col = particles.run(particles.Config(lam=1e-2, time=5.0, dt=0.01, seed=3)).state
    assert col.n > 100
    return col.x, col.y, col.theta, col.length


def displacement(c, gamma, length, dt):
    fx, fy, tz = generalised_forces(c, gamma, length.size)
    return np.concatenate([dt * fx / length, dt * fy / length, dt * 12 * tz / length**3])


@pytest.mark.parametrize("lam", [0.0, 1e-2, 1.0])
def test_grown_colony_kkt_and_agreement_with_bbpgd(grown, lam):
    x, y, th, length = grown
    c = detect_contacts(x, y, th, length, 0.1)
    dt = 0.005
    tol = 1e-9
    ga, _ = solve_contacts_apgd(c, length, dt, lam, tol=tol)
    gb, _ = solve_contacts(c, length, dt, lam, tol=tol)
    assert_kkt(c, length, dt, lam, ga, tol)
    assert np.count_nonzero(ga) > len(c) / 3  # a jammed colony: most contacts loaded
    # unique parts of the solution: displacements (every lam), stress (lam > 0)
    ua, ub = displacement(c, ga, length, dt), displacement(c, gb, length, dt)
    assert np.max(np.abs(ua - ub)) <= 1e-5 * np.max(np.abs(ub))
    if lam > 0:
        sa, sb = axial_stress(c, ga, x.size), axial_stress(c, gb, x.size)
        assert np.max(np.abs(sa - sb)) <= 1e-4 * np.max(sb)


@pytest.mark.parametrize("packing", ["grown", "rings"])
def test_warm_start_overlap_removal_and_exact_restart(grown, packing):
    x, y, th, length = grown if packing == "grown" else ring_packing(300, seed=5)
    dt, lam, tol = 0.005, 1e-2, 1e-6
    c = detect_contacts(x, y, th, length, 0.1)
    g, _ = solve_contacts(c, length, dt, lam, tol=tol / 10)
    warm_problem = measurement("contact_solvers").warm_problem
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
    c = detect_contacts(x, y, th, length, 0.1)
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
    est = lipschitz_bound(c, length, dt, law_rows(lam, 1.0, dt, len(length)), iters=200,
                          rtol=0.0)
    assert 0.99 * exact <= est <= exact * (1 + 1e-9)


def test_too_long_step_is_recovered_by_halving(grown):
    x, y, th, length = grown
    c = detect_contacts(x, y, th, length, 0.1)
    dt, lam, tol = 0.005, 1e-2, 1e-7
    mt, mr, ti, tj, akk = problem_arrays(c, length, dt)
    law = law_rows(lam, 1.0, dt, len(length))
    lip = lipschitz_bound(c, length, dt, law)
    gam = np.zeros(len(c))
    hist = np.full(200_001, np.nan)
    it = apgd_kernel(gam, *incidence(c, ti, tj, len(length)), c.i, c.j, c.nx, c.ny, ti, tj,
                     c.gi, c.gj, c.gap, mt, mr, length, dt, law, True, akk, 8.0 / lip, tol,
                     200_000, hist)
    assert it > 0
    assert np.nanmax(hist) > 1e3 * np.nanmin(hist[: it + 1])  # it did blow up first
    assert_kkt(c, length, dt, lam, gam, tol)


def test_failure_raises_contact_solve_error_with_history(grown):
    x, y, th, length = grown
    c = detect_contacts(x, y, th, length, 0.1)
    with pytest.raises(ContactSolveError) as err:
        solve_contacts_apgd(c, length, 0.005, 1e-2, tol=1e-14, maxiter=5)
    e = err.value
    assert e.n_particles == x.size and e.n_contacts == len(c)
    assert e.residuals.shape == (6,) and np.all(np.isfinite(e.residuals))
    assert f"N={x.size}" in str(e)


def test_bad_input_raises_value_error(chain):
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
    assert particles.solvers.BY_NAME["apgd"] is solve_contacts_apgd
    cfg = dict(lam=1e-2, time=3.0, dt=0.01, division_noise=0.02, seed=1)
    a = particles.run(particles.Config(solver="apgd", **cfg))
    ca, cb = a.state, particles.run(particles.Config(solver="bbpgd", **cfg)).state
    tol = particles.Config(**cfg).tol
    assert max(r["max_overlap"] for r in a.history) <= tol
    assert ca.n >= 16
    # same law: total length and number agree to the tolerance-driven scatter
    assert abs(ca.length.sum() / cb.length.sum() - 1) < 0.02
    assert abs(ca.n - cb.n) <= 0.1 * cb.n


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two Numba threads")
@pytest.mark.parametrize("name", sorted(set(particles.solvers.BY_NAME) - {"bbpgd-cuda"}))
def test_solvers_give_the_same_iterates_on_any_number_of_threads(name):
    """More contacts than solvers.bbpgd.BLOCK, so the blocked sums have several blocks.

    The CPU solvers (bbpgd-cuda's threads are the card's: test_cuda_solver.py, same bits on
    every solve).
    """
    x, y, th, length = ring_packing(2500, seed=7)
    c = detect_contacts(x, y, th, length, 0.1)
    assert len(c) > 2 * BLOCK
    solve = particles.solvers.BY_NAME[name]
    out = []
    for threads in (1, 2):
        numba.set_num_threads(threads)
        try:
            out.append(solve(c, length, 0.005, 1e-2, None, 1e-4))
        finally:
            numba.set_num_threads(1)
    (g1, h1), (g2, h2) = out
    assert len(h1) > 50
    np.testing.assert_array_equal(g1, g2)
    np.testing.assert_array_equal(h1, h2)


def test_incidence_lists_every_contact_of_every_particle_in_order():
    x, y, th, length = ring_packing(300, seed=5)
    c = detect_contacts(x, y, th, length, 0.1)
    n = length.size
    _, _, ti, tj, _ = problem_arrays(c, length, 0.01)
    start, idx, coef = incidence(c, ti, tj, n, threads=2)
    dense = np.zeros((4 * n, len(c)))  # rows: fx, fy, torque, load of every particle
    for col, (ai, aj) in enumerate(((-c.nx, c.nx), (-c.ny, c.ny), (-ti, tj), (c.gi, c.gj))):
        dense[col * n + c.i, np.arange(len(c))] += ai
        dense[col * n + c.j, np.arange(len(c))] += aj
    for p in range(n):
        want = np.flatnonzero((c.i == p) | (c.j == p))
        np.testing.assert_array_equal(idx[start[p]:start[p + 1]], want)
        for col in range(4):
            np.testing.assert_array_equal(coef[start[p]:start[p + 1], col],
                                          dense[col * n + p, want])
    assert incidence(c, ti, tj, n, threads=1)[1].size == 0  # serial kernels scatter instead


def dense_problem(c, length, dt):
    """D^T M D (contacts x contacts) and G (particles x contacts), dense, from model.md."""
    n, m = length.size, len(c)
    _, _, ti, tj, _ = problem_arrays(c, length, dt)
    d = np.zeros((3 * n, m))
    g = np.zeros((n, m))
    k = np.arange(m)
    for col, (ai, aj) in enumerate(((-c.nx, c.nx), (-c.ny, c.ny), (-ti, tj))):
        np.add.at(d, (col * n + c.i, k), ai)
        np.add.at(d, (col * n + c.j, k), aj)
    np.add.at(g, (c.i, k), c.gi)
    np.add.at(g, (c.j, k), c.gj)
    mob = np.concatenate([1 / length, 1 / length, 12 / length**3])
    return d.T @ (mob[:, None] * d), g


@pytest.mark.parametrize("lam", [0.0, 1e-2])
@pytest.mark.parametrize("nu", [1, 2, 7, 8])
def test_bbpgd_iterates_are_textbook_bbpgd(grown, lam, nu):
    """bb_smooth's fused passes and swapped buffers against BBPGD written out in NumPy."""
    from particles.solvers.bbpgd import bb_smooth

    x, y, th, length = grown
    c = detect_contacts(x, y, th, length, 0.1)
    dt = 0.01
    a_mat, g_mat = dense_problem(c, length, dt)
    akk = diagonal(c, length, dt)

    def q(gam):
        growth = length * np.expm1(dt * np.exp(-lam * g_mat @ gam))
        return c.gap + dt * a_mat @ gam - g_mat.T @ growth

    rng = np.random.default_rng(1)
    gam0 = np.maximum(0.0, rng.normal(0.0, 0.1, len(c)))
    want, res = [gam0], [np.abs(np.minimum(akk * gam0, q(gam0))).max()]
    alpha = 1 / np.abs(gam0 - np.maximum(0.0, gam0 - q(gam0))).max()
    for it in range(nu):
        g0 = want[-1]
        g1 = np.maximum(0.0, g0 - alpha * q(g0))
        s, yv = g1 - g0, q(g1) - q(g0)
        alpha = (s @ yv) / (yv @ yv) if it % 2 == 0 else (s @ s) / (s @ yv)
        want.append(g1)
        res.append(np.abs(np.minimum(akk * g1, q(g1))).max())
    _, _, ti, tj, _ = problem_arrays(c, length, dt)
    gam, hist, qout = gam0.copy(), np.full(nu + 1, np.nan), np.empty(len(c))
    it, _, _ = bb_smooth(gam, *incidence(c, ti, tj, length.size), c.i, c.j, c.nx, c.ny, ti, tj,
                         c.gi, c.gj, c.gap, 1 / length, 12 / length**3, length, dt,
                         law_rows(lam, 1.0, dt, length.size), True, akk, 0.0, nu, 0.0, 0, hist,
                         qout)
    assert it == -1  # tol 0: every iteration taken
    np.testing.assert_allclose(gam, want[-1], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(qout, q(gam), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(hist, res, rtol=1e-9)


def test_gradient_at_lam_zero_is_the_general_formula_bit_for_bit(grown):
    """The lam = 0 shortcut l (exp(dt) - 1) gives the bits of l (exp(dt exp(-lam s)) - 1)."""
    x, y, th, length = grown
    c = detect_contacts(x, y, th, length, 0.1)
    gam = np.random.default_rng(2).uniform(0.0, 1.0, len(c))
    np.testing.assert_array_equal(linearised_gap(c, length, 0.01, 0.0, gam),
                                  linearised_gap(c, length, 0.01, 1e-300, gam))


@pytest.mark.parametrize("solve", [solve_contacts, solve_contacts_apgd])
def test_a_nan_gap_is_never_converged(grown, solve):
    """A NaN in the problem fails the solve (residual inf), never passes as converged.

    max(r, NaN) is r and a projection max(0, NaN) is 0, so without problem.residual_term a NaN
    gap left its contact out of the residual and the solve 'converged' around it.
    """
    x, y, th, length = grown
    c = detect_contacts(x, y, th, length, 0.1)
    c.gap[3] = np.nan
    with pytest.raises(ContactSolveError, match="last residual inf"):
        solve(c, length, 0.005, 1e-2, tol=1e-6, maxiter=50)
