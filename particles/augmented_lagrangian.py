"""Per-step contact problem by an augmented Lagrangian in particle space, AMG-preconditioned.

The problem is the one of contact_solver.py (model.md, "Discrete model"): minimise over
gamma >= 0

    E(gamma) = gamma . Phi + (dt/2) gamma . (D^T M D) gamma + sum_n l_n h(sigma_n),  sigma = G gamma,

with gradient the linearised gap

    q_k(gamma) = Phi_k + dt (D^T M D gamma)_k - (G^T dl(sigma))_k,
    dl_n(sigma) = l_n (exp(dt exp(-lam sigma_n)) - 1),

and the same stopping test: the projected residual res = max_k |min(a_kk gamma_k, q_k)| <= tol,
a_kk = dt (D^T M D)_kk, a length.

Method.  Three nested loops, each with a short justification.

1. Growth linearised at the current loads sigma_bar = G gamma:
   dl(sigma) ~ dl(sigma_bar) - c (sigma - sigma_bar),
   c_n = -dl_n'(sigma_bar) = l_n lam dt exp(-lam sigma_bar_n) exp(dt exp(-lam sigma_bar_n)) >= 0,
   which turns E into the quadratic model  gamma . Phi~ + (1/2) |S gamma|^2  with
   S = W^(1/2) B (4N x K), B = [D; G] the particle-space Jacobian (x, y, theta, l per particle),
   W = diag(dt M, c) and Phi~ = Phi - G^T (dl(sigma_bar) + c sigma_bar).  Its Hessian in
   gamma is exactly the Hessian of E at sigma_bar, so re-linearising every outer iteration is a
   Newton iteration for the growth coupling.
2. Proximal point on that model (= augmented Lagrangian on its particle-space primal
   min 1/2 |z|^2 s.t. Phi~ + S^T z >= 0):
   gamma+ = argmin_{gamma >= 0} model(gamma) + |gamma - gamma_bar|^2 / (2 rho), computed as
   gamma+ = max(0, gamma_bar - rho (Phi~ + S^T z)) with z the minimiser of
   L(z) = 1/2 |z|^2 + 1/(2 rho) |max(0, gamma_bar - rho (Phi~ + S^T z))|^2   (4N unknowns).
   rho = rho_scale / median(a_kk): the proximal term then perturbs the model by ~1/rho_scale of
   its stiffness, so few outer iterations are needed whatever N.
3. L is convex, C^1 and piecewise quadratic: semismooth Newton, Hessian
   H = I + rho S_A S_A^T (A = contacts with a positive candidate force), which is SPD and, on
   the translational dofs, a weighted graph Laplacian of the contact network plus the identity.
   H d = -grad L is solved by conjugate gradients preconditioned with smoothed-aggregation AMG
   (pyamg, 4x4 particle blocks, near-null space = rigid motions in the scaled variables and the
   growth dof), with Armijo backtracking on L.  The AMG hierarchy is rebuilt only when CG needs
   more than ``amg_rebuild_iterations`` iterations (the active set changes little between
   Newton steps, so a slightly stale hierarchy is still a good preconditioner).

Every outer iteration evaluates the exact residual of E (not of the model).  If ``max_outer``
outer iterations do not reach tol, BBPGD (contact_solver.solve_contacts) is run from the
current gamma as a polisher, with the remaining iteration budget.

The residual history returned has one entry per outer iteration (first: initial guess),
followed by the polisher's entries if it ran; ``stats`` (optional dict) receives the counts of
outer, Newton, CG iterations, AMG set-ups and polisher iterations.
"""

from __future__ import annotations

import numpy as np
import pyamg
import scipy.sparse as sp
from scipy.sparse.linalg import LinearOperator, cg

from .contact_solver import ContactSolveError, linearised_gap, solve_contacts
from .geometry import Contacts, loads

NAME = "alm"
"""Name under which the engine may register this solver (ParticleConfig.solver)."""


def _growth_increment(length: np.ndarray, sigma: np.ndarray, dt: float, lam: float):
    """dl_n(sigma) = l_n (exp(dt exp(-lam sigma_n)) - 1) and c_n = -d dl_n / d sigma_n."""
    rate = dt * np.exp(-lam * sigma)
    dl = length * np.expm1(rate)
    c = length * lam * rate * np.exp(rate)
    return dl, c


def _jacobian(c: Contacts, length: np.ndarray, dt: float, cgrow: np.ndarray) -> sp.csr_matrix:
    """S = W^(1/2) B as a (4N x K) CSR matrix, rows (x, y, theta, l) of each particle.

    Column k: particle j gets sqrt(dt/l_j) (nx, ny), sqrt(12 dt / l_j^3) (r_j x n_k) and
    sqrt(c_j) G_jk; particle i the negated motion entries and sqrt(c_i) G_ik.
    """
    n = length.shape[0]
    m = len(c)
    st = np.sqrt(dt / length)
    sr = np.sqrt(12.0 * dt / length**3)
    sg = np.sqrt(cgrow)
    ti = c.rix * c.ny - c.riy * c.nx
    tj = c.rjx * c.ny - c.rjy * c.nx
    rows = np.concatenate([4 * c.j, 4 * c.j + 1, 4 * c.j + 2, 4 * c.j + 3,
                           4 * c.i, 4 * c.i + 1, 4 * c.i + 2, 4 * c.i + 3])
    vals = np.concatenate([st[c.j] * c.nx, st[c.j] * c.ny, sr[c.j] * tj, sg[c.j] * c.gj,
                           -st[c.i] * c.nx, -st[c.i] * c.ny, -sr[c.i] * ti, sg[c.i] * c.gi])
    cols = np.tile(np.arange(m), 8)
    return sp.csr_matrix((vals, (rows, cols)), shape=(4 * n, m))


def _near_null(length: np.ndarray, dt: float) -> np.ndarray:
    """Near-null space of H in the scaled variables z = W^(-1/2) v, per particle block.

    Translations (x, y), spin (theta) and growth (l): with aggregates of neighbouring
    particles, a rigid rotation is locally a translation plus a spin.
    """
    n = length.shape[0]
    bn = np.zeros((4 * n, 4))
    wt = np.sqrt(length / dt)
    bn[0::4, 0] = wt
    bn[1::4, 1] = wt
    bn[2::4, 2] = np.sqrt(length**3 / (12.0 * dt))
    bn[3::4, 3] = 1.0
    return bn


class _Newton:
    """Semismooth Newton for L(z) of the module docstring (one proximal subproblem)."""

    def __init__(self, S, phit, gbar, rho, bnull, cg_rtol, amg_rebuild_iterations, stats):
        self.S = S
        self.St = S.T.tocsr()
        self.phit = phit
        self.gbar = gbar
        self.rho = rho
        self.bnull = bnull
        self.cg_rtol = cg_rtol
        self.rebuild = amg_rebuild_iterations
        self.stats = stats

    def candidate(self, z):
        """w(z) = max(0, gamma_bar - rho (Phi~ + S^T z)): the candidate forces."""
        return np.maximum(0.0, self.gbar - self.rho * (self.phit + self.St @ z))

    def value(self, z, w):
        return 0.5 * z @ z + 0.5 / self.rho * (w @ w)

    def hessian(self, active):
        sa = self.S[:, active]
        return (sp.identity(self.S.shape[0], format="csr") + self.rho * (sa @ sa.T)).tocsr()

    def solve(self, z, ml, max_newton, gtol):
        """Newton steps from z until |grad L| <= gtol; returns z, w, ml (AMG, possibly new)."""
        w = self.candidate(z)
        f = self.value(z, w)
        for _ in range(max_newton):
            grad = z - self.S @ w
            gn = np.linalg.norm(grad)
            if gn <= gtol:
                break
            self.stats["newton"] += 1
            H = self.hessian(w > 0.0)
            if ml is None:
                ml = self._amg(H)
            d, its = self._cg(H, -grad, ml)
            if its > self.rebuild:
                ml = self._amg(H)
                d, its2 = self._cg(H, -grad, ml)
                its += its2
            self.stats["cg"] += its
            # Armijo backtracking on the convex C^1 function L
            slope = grad @ d
            t = 1.0
            while True:
                zt = z + t * d
                wt = self.candidate(zt)
                ft = self.value(zt, wt)
                if ft <= f + 1e-4 * t * slope or t < 1e-8:
                    break
                t *= 0.5
            z, w, f = zt, wt, ft
        return z, w, ml

    def _amg(self, H):
        self.stats["amg_setups"] += 1
        A = H.tobsr(blocksize=(4, 4))
        return pyamg.smoothed_aggregation_solver(A, B=self.bnull, symmetry="hermitian",
                                                 max_coarse=200)

    def _cg(self, H, rhs, ml):
        count = [0]

        def cb(_):
            count[0] += 1

        M = ml.aspreconditioner(cycle="V")
        d, _ = cg(H, rhs, rtol=self.cg_rtol, maxiter=200, M=M, callback=cb)
        return d, count[0]


def solve_contacts_alm(
    contacts: Contacts,
    length: np.ndarray,
    dt: float,
    lam: float,
    gamma0: np.ndarray | None = None,
    tol: float = 1e-4,
    maxiter: int = 100_000,
    growth: bool = True,
    *,
    rho_scale: float = 1e4,
    max_outer: int = 30,
    max_newton: int = 30,
    cg_rtol: float = 1e-3,
    amg_rebuild_iterations: int = 25,
    stats: dict | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Minimise E(gamma) over gamma >= 0 by the particle-space augmented Lagrangian.

    Same problem, signature, residual and stopping test as
    :func:`particles.contact_solver.solve_contacts` (module docstring for the method).

    Parameters
    ----------
    contacts, length, dt, lam, gamma0, tol, growth
        As in solve_contacts: tol bounds the projected residual max_k |min(a_kk gamma_k, q_k)|.
    maxiter : int
        Iteration budget of the BBPGD polisher (used only when the outer loop stalls).
    rho_scale : float
        Proximal weight rho = rho_scale / median(a_kk).
    max_outer, max_newton : int
        Outer (linearisation + proximal) iterations and Newton steps per outer iteration.
    cg_rtol : float
        Relative tolerance of each preconditioned CG solve.
    amg_rebuild_iterations : int
        Rebuild the AMG hierarchy when a CG solve needs more iterations than this.
    stats : dict, optional
        Filled with counts: outer, newton, cg, amg_setups, polish.

    Returns
    -------
    gamma : array (K,)
    residuals : array
        Exact residual after each outer iteration (first: initial guess), then the polisher's.

    Raises
    ------
    ValueError
        Bad dt, lam, gamma0.
    ContactSolveError
        When neither the outer loop nor the polisher reach tol.
    """
    if dt <= 0 or not np.isfinite(dt):
        raise ValueError(f"dt must be positive and finite, got {dt}")
    if lam < 0 or not np.isfinite(lam):
        raise ValueError(f"lam must be >= 0 and finite in the particle engine, got {lam}")
    if rho_scale <= 0 or max_outer < 1 or max_newton < 1 or not 0 < cg_rtol < 1:
        raise ValueError("rho_scale, max_outer, max_newton must be positive, cg_rtol in (0, 1)")
    st = {"outer": 0, "newton": 0, "cg": 0, "amg_setups": 0, "polish": 0}
    if stats is not None:
        stats.update(st)
        st = stats
    length = np.ascontiguousarray(length, dtype=np.float64)
    n = length.shape[0]
    m = len(contacts)
    if m == 0:
        return np.zeros(0), np.zeros(1)
    gam = np.zeros(m) if gamma0 is None else np.array(gamma0, dtype=np.float64)
    if gam.shape != (m,):
        raise ValueError(f"gamma0 must have shape ({m},), got {gam.shape}")
    np.maximum(gam, 0.0, out=gam)
    c = contacts
    akk = _diagonal(c, length, dt)
    rho = rho_scale / float(np.median(akk))
    hist = [_residual(c, length, dt, lam, gam, growth, akk)]
    ml = None
    bnull = _near_null(length, dt)
    lam_eff = lam if growth else 0.0
    while hist[-1] > tol and st["outer"] < max_outer:
        st["outer"] += 1
        sigma = loads(c, gam, n)
        if growth:
            dl, cgrow = _growth_increment(length, sigma, dt, lam_eff)
            phit = c.gap - (c.gi * (dl + cgrow * sigma)[c.i] + c.gj * (dl + cgrow * sigma)[c.j])
        else:
            cgrow = np.zeros(n)
            phit = c.gap.copy()
        S = _jacobian(c, length, dt, cgrow)
        newton = _Newton(S, phit, gam, rho, bnull, cg_rtol, amg_rebuild_iterations, st)
        z = S @ gam
        gtol = 1e-3 * tol * np.sqrt(rho)
        z, w, ml = newton.solve(z, ml if not growth else ml, max_newton, gtol)
        gam = w
        hist.append(_residual(c, length, dt, lam, gam, growth, akk))
    if hist[-1] > tol:
        try:
            gam, h2 = solve_contacts(c, length, dt, lam, gam, tol, maxiter, growth)
        except ContactSolveError as err:
            raise ContactSolveError(
                f"augmented Lagrangian + BBPGD polisher did not reach residual {tol:g} "
                f"(N={n}, contacts={m}, last residual {err.residuals[-1]:.3g})",
                n, m, np.concatenate([hist, err.residuals]),
            ) from err
        st["polish"] = len(h2) - 1
        hist.extend(h2[1:])
    return gam, np.asarray(hist)


def _diagonal(c: Contacts, length: np.ndarray, dt: float) -> np.ndarray:
    """a_kk = dt (D^T M D)_kk, the gap opened by a unit force on contact k alone."""
    ti = c.rix * c.ny - c.riy * c.nx
    tj = c.rjx * c.ny - c.rjy * c.nx
    return dt * (1 / length[c.i] + 1 / length[c.j] + 12 / length[c.i] ** 3 * ti**2
                 + 12 / length[c.j] ** 3 * tj**2)


def _residual(c, length, dt, lam, gam, growth, akk) -> float:
    """res = max_k |min(a_kk gamma_k, q_k(gamma))| with q the exact linearised gap."""
    q = linearised_gap(c, length, dt, lam, gam, growth)
    return float(np.max(np.abs(np.minimum(akk * gam, q))))
