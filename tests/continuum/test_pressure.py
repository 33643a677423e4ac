"""Pressure Newton solver on a fixed disc against the exact radial solution (continuum.pressure)."""

import numpy as np
import pyamg
import pytest
import skfem
from skfem.models.poisson import laplace, mass

from continuum import mesh as M
from continuum import radial
from continuum.pressure import P1Assembler, PressureDivergence, PressureSolver

R = 10.0
HS = (2.0, 1.0, 0.5, 0.25)

# Dunavant degree-4 rule on the reference triangle (6 points): barycentric coordinates, weights
_A, _B = 0.445948490915965, 0.091576213509771
_W1, _W2 = 0.223381589678011, 0.109951743655322
QB = np.array(
    [
        [_A, _A, 1 - 2 * _A],
        [_A, 1 - 2 * _A, _A],
        [1 - 2 * _A, _A, _A],
        [_B, _B, 1 - 2 * _B],
        [_B, 1 - 2 * _B, _B],
        [1 - 2 * _B, _B, _B],
    ]
)
QW = np.array([_W1] * 3 + [_W2] * 3)


def disc(h):
    bnd = M.resample_polygon(M.circle_polygon(R, 4000), spacing=h)
    pts, tri = M.triangulate(bnd, h)
    return bnd, pts, tri


def errors(pts, tri, ph, lam):
    """L2 and H1-seminorm errors of the P1 field ph against the exact radial p (quadrature)."""
    A = P1Assembler(tri, len(pts), 0)
    area, grads = A.geometry(pts)
    xq = np.einsum("qi,mid->mqd", QB, pts[tri])
    rq = np.hypot(xq[..., 0], xq[..., 1])
    pe = radial.pressure(rq, R, lam)
    ue = radial.velocity(rq, R, lam)[..., None] * xq / rq[..., None]  # = -grad p
    phq = np.einsum("qi,mi->mq", QB, ph[tri])
    gh = np.einsum("mi,mid->md", ph[tri], grads)
    l2 = np.sqrt(np.sum(area[:, None] * QW * (phq - pe) ** 2))
    h1 = np.sqrt(np.sum(area[:, None] * QW * np.sum((-gh[:, None, :] - ue) ** 2, axis=-1)))
    return l2, h1


def test_assembly_matches_skfem():
    bnd, pts, tri = disc(1.0)
    A = P1Assembler(tri, len(pts), len(bnd))
    area, grads = A.geometry(pts)
    basis = skfem.Basis(skfem.MeshTri(pts.T, tri.T), skfem.ElementTriP1())
    K = A.matrix(A.stiffness_data(area, grads))
    assert abs(K - laplace.assemble(basis)).max() < 1e-12
    g = np.random.default_rng(0).random(len(pts))
    np.testing.assert_allclose(A.load(area, g), mass.assemble(basis) @ g, atol=1e-14)
    ops = A.assemble(pts)
    assert abs(A.matrix(ops.M_data) - mass.assemble(basis)).max() < 1e-14
    np.testing.assert_allclose(ops.M_data.sum(), area.sum())


@pytest.mark.parametrize("lam", [0.0, 1e-3, 1e-2])
def test_disc_convergence_orders(lam):
    l2s, h1s = [], []
    for h in HS:
        bnd, pts, tri = disc(h)
        S = PressureSolver(lam)
        S.set_mesh(tri, len(pts), len(bnd))
        ph = S.solve(pts)
        assert S.stats.residual < S.rtol
        l2, h1 = errors(pts, tri, ph, lam)
        l2s.append(l2)
        h1s.append(h1)
    o2 = np.polyfit(np.log(HS), np.log(l2s), 1)[0]
    o1 = np.polyfit(np.log(HS), np.log(h1s), 1)[0]
    assert abs(o2 - 2.0) < 0.2, (l2s, o2)
    assert abs(o1 - 1.0) < 0.15, (h1s, o1)
    # absolute size: relative L2 error at h = R/40 below 1e-3
    assert l2s[-1] / np.sqrt(np.pi * R**2) / radial.max_pressure(R, lam) < 1e-3


def test_negative_lam_below_critical_matches_exact():
    lam = -0.01  # R_crit = sqrt(2/0.01) = 14.1 > R
    bnd, pts, tri = disc(0.5)
    S = PressureSolver(lam)
    S.set_mesh(tri, len(pts), len(bnd))
    ph = S.solve(pts)
    pe = radial.pressure(np.hypot(*pts.T), R, lam)
    assert np.max(np.abs(ph - pe)) < 5e-3 * pe.max()


def test_negative_lam_beyond_critical_raises():
    lam = -0.05  # R_crit = sqrt(2/0.05) = 6.3 < R: no solution
    bnd, pts, tri = disc(1.0)
    S = PressureSolver(lam)
    S.set_mesh(tri, len(pts), len(bnd))
    with pytest.raises(PressureDivergence, match="critical size") as err:
        S.solve(pts, where="t=1.0, area=314")
    assert "t=1.0" in str(err.value)


@pytest.mark.parametrize("lam", [np.nan, np.inf])
def test_bad_lam(lam):
    with pytest.raises(ValueError, match="finite"):
        PressureSolver(lam)


def test_warm_start_and_amg_reuse():
    """Moving the nodes slightly: the warm-started solve reuses the hierarchy.

    It contracts the residual by >= 100 per Newton step (the symmetric part of the Jacobian is
    O(lam h grad g) off; a tolerance below the default, so that the inexact CG, which solves
    just enough to meet it, does not set the contraction).
    """
    bnd, pts, tri = disc(0.5)
    S = PressureSolver(1e-2, rtol=1e-9)
    S.set_mesh(tri, len(pts), len(bnd))
    p = S.solve(pts)
    first = S.stats
    assert first.amg_setups == 1 and first.newton_iterations >= 3
    p2 = S.solve(pts * 1.01, p0=p)
    assert S.stats.amg_setups == 0
    assert S.stats.newton_iterations <= 3
    hist = np.array(S.stats.history)
    assert np.all(hist[1:] / hist[:-1] < 1e-2)
    assert np.max(np.abs(p2 - radial.pressure(np.hypot(*pts.T) * 1.01, 1.01 * R, 1e-2))) < 0.05


def test_inverted_element_raises():
    bnd, pts, tri = disc(2.0)
    S = PressureSolver(0.0)
    S.set_mesh(tri, len(pts), len(bnd))
    bad = pts.copy()
    bad[len(bnd)] = bad[0] * 3  # drag an interior node far outside
    with pytest.raises(PressureDivergence, match="inverted"):
        S.solve(bad)


def test_pcg_vcycle_match_direct_solve():
    import scipy.sparse.linalg as sla

    from continuum.pressure import VCycle, amg_hierarchy, pcg

    A = pyamg.gallery.poisson((40, 40), format="csr")
    ml = amg_hierarchy(A)
    assert len(ml.levels) >= 3  # a real multilevel cycle, coarse levels in BSR
    M = VCycle(ml)
    b = np.random.default_rng(1).random(A.shape[0])
    # the CSR cycle is pyamg's own V-cycle (forward then backward Gauss-Seidel)
    np.testing.assert_allclose(M(b), ml.solve(b, maxiter=1, cycle="V", tol=1e-300),
                               rtol=1e-12, atol=0)
    # symmetric: (M b, c) = (b, M c), as CG needs
    c = np.random.default_rng(2).random(A.shape[0])
    assert abs(M(b) @ c - b @ M(c)) < 1e-12 * abs(b @ M(c))
    x, its, ok = pcg(A, b, M, 1e-10)
    assert ok and its < 20
    np.testing.assert_allclose(x, sla.spsolve(A.tocsc(), b), rtol=1e-8)
    # a matrix that is not positive definite is reported, not silently "solved"
    _, _, ok = pcg(-A, b, lambda r: r, 1e-10)
    assert not ok
