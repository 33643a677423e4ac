"""Semi-smooth Newton with sparse direct solves on a run's own contact problem (rejected).

Issue 33 (goal 2) asks for iterations per unit time against the methods the literature
reports for dense rigid contact, among them interior-point and semi-smooth Newton methods,
whose iteration counts hardly grow with N but whose every iteration is a sparse linear solve.
This script measures that trade on the main problem of a paper-scale run's next step
(``--checkpoint``, posed as the engine would: ``cases.bench.warm_start.main_problem``).

The problem (particles/solvers/problem.py) is min E(gamma) over gamma >= 0 with gradient
q(gamma) = Phi + A gamma - G^T dl(G gamma), A = dt D^T M D, and Hessian ::

    H(gamma) = A + G^T diag(w) G,   w_n = l_n lam a dt e^{-lam sigma_n} exp(a dt e^{-lam sigma_n}),

assembled here as scipy sparse matrices (:func:`contact_matrices`, checked against the
engine's kernels in the tests).  The method is the primal-dual active-set iteration (a
semi-smooth Newton method on min(a_kk gamma, q) = 0, Hintermueller, Ito, Kunisch 2002): with
the active set A = {k : q_k <= a_kk gamma_k} (contacts to close) and I its complement (forces
released), ::

    gamma_I <- 0,   (H_AA + eps mean(diag H_AA) I) delta_A = -q_A + H_AI gamma_I,
    gamma_A <- max(0, gamma_A + delta_A),

each step one sparse LU factorisation of the active block (``--factorisation``: scipy's
SuperLU with COLAMD, or MKL PARDISO through pypardiso, the ``pardiso`` extra, not a core
dependency).  eps (``--regularisation``) is needed: the active contact network is nearly
isostatic and often hyperstatic (more active contacts than rigid-body freedoms), so H_AA is
singular.  An interior-point iteration factorises H + diag(gamma / s) over all contacts, a
larger matrix of the same pattern: the time of one factorisation of the whole H is reported as
its lower bound per iteration.  BBPGD (the engine's solver, one thread) solves the same problem
from the same warm start for comparison, and again from the last Newton iterate (does a start
with the network's slow modes solved save BBPGD iterations?).

    python -m cases.bench.newton --checkpoint RUN.partial/checkpoint.npz
           [--regularisation 1e-1] [--newton 20] [--factorisation superlu|pardiso]
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from particles.simulation import Simulation
from particles.solvers import BY_NAME
from particles.solvers.problem import law_rows, linearised_gap, problem_arrays

from .warm_start import main_problem


def contact_matrices(problem):
    """(A, G, w) of ``problem``: A = dt D^T M D (m x m), G (N x m) and w(sigma) (module doc).

    D (3N x m) has the columns (-n, -t_i) on particle i and (n, t_j) on particle j, M =
    diag(1/l, 1/l, 12/l^3) per particle; w maps the loads sigma = G gamma to the growth term's
    curvature (zero where lam = 0).
    """
    c, length, dt, lam, _ = problem
    n, m = length.shape[0], len(c)
    mt, mr, ti, tj, _ = problem_arrays(c, length, dt)
    k = np.arange(m)
    rows = np.concatenate([3 * c.i, 3 * c.i + 1, 3 * c.i + 2, 3 * c.j, 3 * c.j + 1, 3 * c.j + 2])
    vals = np.concatenate([-c.nx, -c.ny, -ti, c.nx, c.ny, tj])
    d = sp.csr_matrix((vals, (rows, np.tile(k, 6))), shape=(3 * n, m))
    mobility = sp.diags(np.stack([mt, mt, mr], axis=1).ravel())
    a = (dt * (d.T @ mobility @ d)).tocsr()
    g = sp.csr_matrix((np.concatenate([c.gi, c.gj]), (np.concatenate([c.i, c.j]),
                                                       np.concatenate([k, k]))), shape=(n, m))
    law = law_rows(lam, 1.0, dt, n)
    lam_n, adt = law[:, 0], law[:, 1]

    def w(sigma):
        e = adt * np.exp(-lam_n * sigma)
        return length * lam_n * e * np.exp(e)

    return a, g, w


def hessian(a, g, w, gamma) -> sp.csr_matrix:
    """H(gamma) = A + G^T diag(w(G gamma)) G."""
    return (a + g.T @ sp.diags(w(g @ gamma)) @ g).tocsr()


def residual(akk, gamma, q) -> float:
    """The engine's residual ``max_k |min(a_kk gamma_k, q_k)|``."""
    return float(np.max(np.abs(np.minimum(akk * gamma, q))))


def factor_solve(matrix, rhs, method: str):
    """(solution of matrix x = rhs, seconds, fill of the factors) by SuperLU or MKL PARDISO.

    ``method``: "superlu" (scipy, COLAMD ordering) or "pardiso" (pypardiso, not a dependency of
    the project: ``pip install pypardiso``; fill not reported, NaN).
    """
    matrix = matrix.tocsc() if method == "superlu" else matrix.tocsr()
    t0 = time.perf_counter()
    if method == "superlu":
        lu = sla.splu(matrix)
        x = lu.solve(rhs)
        fill = (lu.L.nnz + lu.U.nnz) / matrix.nnz
    else:
        import pypardiso

        x, fill = pypardiso.PyPardisoSolver().solve(matrix, rhs), float("nan")
    return x, time.perf_counter() - t0, fill


def active_set_newton(problem, gamma0, eps: float, steps: int, method: str = "superlu"):
    """The module's iteration from max(0, gamma0): one row per step (residual, factorisation)."""
    c, length, dt, lam, tol = problem
    a, g, w = contact_matrices(problem)
    akk = problem_arrays(c, length, dt)[4]
    gamma = np.maximum(gamma0, 0.0)
    rows = []
    for _ in range(steps + 1):
        q = linearised_gap(c, length, dt, lam, gamma)
        active = q <= akk * gamma
        row = {"residual": residual(akk, gamma, q), "active": int(active.sum())}
        rows.append(row)
        if row["residual"] <= tol or len(rows) > steps:
            break
        h = hessian(a, g, w, gamma)
        on, off = np.flatnonzero(active), np.flatnonzero(~active)
        haa = h[on][:, on]
        rhs = -q[on] + h[on][:, off] @ gamma[off]
        regular = haa + eps * haa.diagonal().mean() * sp.identity(on.size)
        delta, row["seconds"], row["fill"] = factor_solve(regular, rhs, method)
        gamma[off] = 0.0
        gamma[on] = np.maximum(0.0, gamma[on] + delta)
    return gamma, rows


def full_factorisation_seconds(problem, gamma, eps: float, method: str = "superlu") -> float:
    """Seconds of one factorisation and solve of H(gamma) + eps mean(diag) I, all contacts."""
    a, g, w = contact_matrices(problem)
    h = hessian(a, g, w, gamma)
    regular = h + eps * h.diagonal().mean() * sp.identity(h.shape[0])
    return factor_solve(regular, np.ones(h.shape[0]), method)[1]


def main(argv: list[str] | None = None) -> dict:
    """Run the comparison of the module docstring; returns its numbers."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--checkpoint", required=True, help="a particle run's checkpoint.npz")
    ap.add_argument("--regularisation", type=float, default=1e-1,
                    help="eps: the active block is factorised as H_AA + eps mean(diag) I")
    ap.add_argument("--newton", type=int, default=20, help="at most this many Newton steps")
    ap.add_argument("--factorisation", choices=("superlu", "pardiso"), default="superlu",
                    help="sparse LU: scipy's SuperLU, or MKL PARDISO (pip install pypardiso)")
    args = ap.parse_args(argv)
    if not args.regularisation > 0:
        ap.error(f"--regularisation must be > 0, got {args.regularisation}")
    if args.newton < 1:
        ap.error(f"--newton must be >= 1, got {args.newton}")
    if args.factorisation == "pardiso":
        try:
            import pypardiso  # noqa: F401
        except ImportError:
            ap.error("--factorisation pardiso needs pypardiso (pip install '.[pardiso]')")
    numba.set_num_threads(1)
    problem, matched, _ = main_problem(Simulation.load(args.checkpoint))
    c, length, dt, lam, tol = problem
    solver = BY_NAME["bbpgd"]
    solver(c, length, dt, lam, matched, tol, 10**6, True)  # compiled before timing
    t0 = time.perf_counter()
    gamma_bb, hist = solver(c, length, dt, lam, matched, tol, 10**6, True)
    out = {"particles": int(length.shape[0]), "contacts": len(c), "tolerance": tol,
           "bbpgd iterations": len(hist) - 1, "bbpgd seconds": time.perf_counter() - t0}
    gamma_newton, rows = active_set_newton(problem, matched, args.regularisation, args.newton,
                                           args.factorisation)
    out["newton"] = rows
    out["bbpgd after newton"] = len(solver(c, length, dt, lam, gamma_newton, tol, 10**6,
                                           True)[1]) - 1
    out["full factorisation seconds"] = full_factorisation_seconds(
        problem, gamma_bb, args.regularisation, args.factorisation)
    out["loaded contacts"], out["freedoms"] = int((gamma_bb > 0).sum()), 3 * out["particles"]
    print(f"N = {out['particles']}, contacts {out['contacts']}, tolerance {tol:g}: BBPGD "
          f"{out['bbpgd iterations']} iterations in {out['bbpgd seconds']:.2f} s; one "
          f"factorisation of the whole H {out['full factorisation seconds']:.2f} s "
          f"({args.factorisation}); loaded contacts at the solution {out['loaded contacts']} "
          f"against 3N = {out['freedoms']} rigid-body freedoms")
    print("| Newton step | residual | active contacts | factorisation + solve [s] | fill |")
    print("|---|---|---|---|---|")
    for k, r in enumerate(rows):
        print(f"| {k} | {r['residual']:.3g} | {r['active']} | {r.get('seconds', 0.0):.2f} | "
              f"{r.get('fill', 0.0):.1f} |")
    spent = sum(r.get("seconds", 0.0) for r in rows)
    print(f"Newton: residual {rows[-1]['residual']:.3g} after {len(rows) - 1} steps, "
          f"{spent:.2f} s in factorisations = {spent / out['bbpgd seconds']:.2f} BBPGD solves; "
          f"BBPGD from there {out['bbpgd after newton']} iterations")
    return out


if __name__ == "__main__":
    main()
