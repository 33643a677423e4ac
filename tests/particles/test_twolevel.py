"""Two-level contact solver (particles/twolevel.py) against exact answers.

Its pieces against exact answers, and the whole solve against the KKT conditions, BBPGD's
stress and the exact straight chain.
"""

import numpy as np
import pytest
from scipy.linalg import solve_banded
from scipy.optimize import root

from particles.geometry import B, detect_contacts
from particles.packings import ring_packing
from particles.solvers.bbpgd import solve_contacts
from particles.solvers.problem import (
    ContactSolveError,
    law_rows,
    linearised_gap,
    problem_arrays,
)
from particles.solvers.twolevel import (
    coarse_correction,
    contact_operators,
    contact_points,
    hat_prolongation,
    solve_contacts_twolevel,
)
from particles.stress import axial_stress

DT = 0.005


@pytest.fixture(scope="module")
def packing():
    x, y, th, length = ring_packing(300, seed=2)
    return x, y, th, length, detect_contacts(x, y, th, length, 0.1)


def kkt_residual(c, length, lam, gamma):
    *_, akk = problem_arrays(c, length, DT)
    q = linearised_gap(c, length, DT, lam, gamma)
    return np.max(np.abs(np.minimum(akk * gamma, q))), q


def test_contact_points_rebuilt_exactly(packing):
    x, y, _, _, c = packing
    zx, zy, main = contact_points(c, x.shape[0])
    tx = x[c.i] + c.rix + 0.5 * (c.gap + B) * c.nx
    ty = y[c.i] + c.riy + 0.5 * (c.gap + B) * c.ny
    # exact up to one translation of the (single, jammed) component
    assert main.all()
    for d in (tx - zx, ty - zy):
        assert np.ptp(d) < 1e-12


def test_hat_prolongation_reproduces_linear_fields(packing):
    x, _, _, _, c = packing
    zx, zy, main = contact_points(c, x.shape[0])
    main[::7] = False
    p = hat_prolongation(zx, zy, main, 2.5)
    np.testing.assert_allclose(p.sum(axis=1).A1[main], 1.0, atol=1e-13)
    assert p[~main].nnz == 0
    # nodal values of f = 2 + 3x - y interpolate f exactly (bilinear hats hold linears)
    nodes = np.linalg.lstsq(p[main].toarray(), 2 + 3 * zx[main] - zy[main], rcond=None)[0]
    np.testing.assert_allclose(p[main] @ nodes, 2 + 3 * zx[main] - zy[main], atol=1e-9)
    with pytest.raises(ValueError):
        hat_prolongation(zx, zy, main, 0.0)


@pytest.mark.parametrize("lam", [0.0, 0.05])
def test_operators_are_the_hessian(packing, lam):
    """q(gamma + e v) - q(gamma) = e (S^T S + G^T C G) v + O(e^2): observed order 2."""
    _, _, _, length, c = packing
    rng = np.random.default_rng(0)
    gam = rng.uniform(0, 50, len(c))
    v = rng.normal(size=len(c))
    s, g = contact_operators(c, length, DT)
    r = DT * np.exp(-lam * (g @ gam))
    hv = s.T @ (s @ v) + g.T @ (length * lam * r * np.exp(r) * (g @ v))
    q0 = linearised_gap(c, length, DT, lam, gam)
    eps = np.array([1e-1, 5e-2, 2.5e-2, 1.25e-2]) * 100
    errs = [np.abs((linearised_gap(c, length, DT, lam, gam + e * v) - q0) - e * hv).max()
            for e in eps]
    if lam == 0:
        assert max(errs) < 1e-10 * np.abs(hv).max() * eps.max()
    else:
        assert abs(np.polyfit(np.log(eps), np.log(errs), 1)[0] - 2) < 0.1, errs


def test_coarse_step_is_galerkin_exact_for_lam0(packing):
    """With lam = 0, E is quadratic: after the step P^T (gamma q(gamma_new)) = 0 (no clipping)."""
    x, _, _, length, c = packing
    gam, _ = solve_contacts(c, length, DT, 0.0, tol=1e-4)
    assert np.count_nonzero(gam) > 50
    zx, zy, main = contact_points(c, x.shape[0])
    gam = gam * (1 + 0.3 * np.sin(zx / 3))  # a smooth error the coarse space holds
    p = hat_prolongation(zx, zy, main, 3.0)
    s, g = contact_operators(c, length, DT)
    q = linearised_gap(c, length, DT, 0.0, gam)
    new = coarse_correction(gam, q, p, s, g, length, law_rows(0.0, 1.0, DT, len(length)),
                            True)
    assert np.all(new >= 0) and np.all(new[gam == 0] == 0)
    assert np.all(new[gam > 0] > 0)  # no clipping: the step is the exact coarse minimiser
    qn = linearised_gap(c, length, DT, 0.0, new)
    gc0 = np.abs(p.T @ (gam * q)).max()
    assert np.abs(p.T @ (gam * qn)).max() < 1e-8 * gc0


@pytest.mark.parametrize("lam", [0.0, 1e-2])
def test_kkt_and_bbpgd_agreement(packing, lam):
    _, _, _, length, c = packing
    tol = 1e-4
    gam, hist = solve_contacts_twolevel(c, length, DT, lam, tol=tol, smoothing=10, coarse_h=2.0)
    res, q = kkt_residual(c, length, lam, gam)
    assert np.all(gam >= 0) and res <= tol and q.min() >= -tol
    assert hist[-1] == pytest.approx(res) and len(hist) > 12  # coarse steps did happen
    # tight solves of the same strictly convex problem agree with BBPGD
    g2, _ = solve_contacts_twolevel(c, length, DT, lam, tol=1e-9, smoothing=10, coarse_h=2.0)
    g1, _ = solve_contacts(c, length, DT, lam, tol=1e-9)
    n = length.shape[0]
    s1, s2 = axial_stress(c, g1, n), axial_stress(c, g2, n)
    assert np.abs(s1 - s2).max() < 1e-3 * s1.max()
    # warm start from the solution: no iteration
    g3, h3 = solve_contacts_twolevel(c, length, DT, lam, g2, tol=1e-9)
    assert len(h3) == 1 and np.array_equal(g3, g2)


def test_chain_exact_lam0_and_lam_positive(chain):
    n = 30
    lengths = np.random.default_rng(5).uniform(1.0, 2.0, n)
    dt = 0.01
    _, c = chain(lengths)
    # lam = 0: tridiagonal system (tests/particles/test_chain.py)
    diag = dt * (1 / lengths[:-1] + 1 / lengths[1:])
    off = -dt / lengths[1:-1]
    ab = np.zeros((3, n - 1))
    ab[0, 1:], ab[1], ab[2, :-1] = off, diag, off
    gref = solve_banded((1, 1), ab, 0.5 * (lengths[:-1] + lengths[1:]) * np.expm1(dt))
    gam, _ = solve_contacts_twolevel(c, lengths, dt, 0.0, tol=1e-12, smoothing=5, coarse_h=3.0)
    a = np.diag(diag) + np.diag(off, 1) + np.diag(off, -1)
    bound = np.abs(np.linalg.inv(a)).sum(axis=1).max() * 1e-12
    assert np.max(np.abs(gam - gref)) <= bound

    def reference(g, lam):
        gf = np.concatenate([[0.0], g, [0.0]])
        rate = lengths * np.expm1(dt * np.exp(-lam * 0.5 * (gf[:-1] + gf[1:])))
        return a @ g - 0.5 * (rate[:-1] + rate[1:])

    ref = root(reference, gref, args=(0.3,), tol=1e-12).x
    gam, _ = solve_contacts_twolevel(c, lengths, dt, 0.3, tol=1e-13, smoothing=5, coarse_h=3.0)
    np.testing.assert_allclose(gam, ref, rtol=1e-8)


def test_bad_input_and_failure(packing):
    _, _, _, length, c = packing
    with pytest.raises(ValueError):
        solve_contacts_twolevel(c, length, DT, 1e-2, smoothing=0)
    with pytest.raises(ValueError):
        solve_contacts_twolevel(c, length, -1.0, 1e-2)
    with pytest.raises(ContactSolveError) as err:
        solve_contacts_twolevel(c, length, DT, 1e-2, tol=1e-12, maxiter=15, smoothing=5)
    assert err.value.n_contacts == len(c) and err.value.residuals[-1] > 1e-12
