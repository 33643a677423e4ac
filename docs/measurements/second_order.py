"""Whether a second-order contact solver competes with BBPGD at 1e5 cells (issue 44, part 1).

A measurement, not part of the package (the designs it times were rejected; docs/benchmarks.md,
"Second-order solvers at 1e5 cells").  It rebuilds the contact problem of one engine
step from a run's checkpoint, exactly as ``particles.stepping.step`` poses it on resuming
(contacts of the checkpoint's configuration, lengths, dt = the saved ``dt_next``, lam and
growth factor, the warm start of the saved forces, tolerance ``effective_solver_tol``), and
times on it, on one thread:

- the engine's BBPGD (``particles.solvers.bbpgd.solve_contacts``) from the warm start and cold;
- the body-space matrix K = I + S R^-1 S^T (S: the 4N x m matrix whose column k is contact
  k's row of the Hessian factor, H = S^T S = dt D^T M D + G^T diag(h) G at the warm start,
  rows x, y, theta, length of each cell; R = diag(rho0 H_kk), rho0 = 0.1) for the contacts
  active at the warm start (gamma0 > 0), its assembly (scipy), and its factorisations:
  cholespy (CHOLMOD: analysis + factorisation, solve), qdldl (AMD + factorisation, numeric
  refactorisation of the same pattern, solve), SuperLU (scipy splu, COLAMD; once when slow),
  and cholespy's of K_A without the length rows (3N unknowns; a singular Newton matrix when
  more contacts are active than 3N, timed for its cost only);
- semismooth Newton from the warm start (``newton``): a cholespy factorisation of K_A with
  R = 1e-6 diag(H) per new active set, backtracking on the residual's 2-norm, the exact
  gradient; counts factorisations and solves, stopped at ``--limit``;
- a fixed-factor augmented Lagrangian: ADMM (OSQP's iteration, relaxation 1.6, rho0 = 0.1
  after Jacobi scaling, i.e. R above), its x-step one Newton step of the subproblem with the
  Hessian frozen at the warm start and the exact gradient (the growth term stays nonlinear),
  through Woodbury: (R + S^T S)^-1 = R^-1 - R^-1 S^T K^-1 S R^-1 with K over ALL contacts,
  factorised once (cholespy) per step; warm-started from gamma0 (dual -grad(gamma0)); it stops
  at the engine's residual max_k |min(a_kk gamma_k, grad_k)| <= tol, evaluated at the
  projected iterate z >= 0 with the exact gradient;
- off-the-shelf references on the QP of the growth term linearised at the warm start (one SQP
  step: E(gamma0) + grad(gamma0).(gamma - gamma0) + 1/2 |S (gamma - gamma0)|^2), written in
  the lifted form  min c.gamma + 1/2 |v|^2, v = S gamma, gamma >= 0  (sparser than S^T S):
  qpalm (proximal augmented Lagrangian, semismooth Newton with factorisation updates;
  warm-started) and piqp (interior point), both with eps_abs = the engine's tol.  Their answer
  is judged by the engine's residual on the true (nonlinear) problem.

Every timing is repeated ``--repeats`` times (median), except a method whose first run takes
more than ``--slow`` (10) times BBPGD's warm seconds: that one is timed once.  SuperLU, qpalm
and piqp run in a spawned child process (which rebuilds the problem, untimed) under an
address-space cap (``--memory-gb``, so a huge fill fails there, not in the machine) and a time
limit of ``--limit`` (10) times BBPGD's warm seconds (killed 120 s beyond: reported as
"> limit"; qpalm stops itself at the limit and reports where it got); the fixed-factor AL stops
at ``--admm-limit`` (30) times.  BBPGD (warm) is timed at the start and again at the end; the
ratios are to the median of all those runs (the machine's load drifts during a run).

Run (from the repository root, with the project's environment, one thread)::

    export NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
    python docs/measurements/second_order.py \
        [--checkpoint runs/state_104993/checkpoint.npz] [--repeats 3]

(the state after leg 1 of the radius-260 colony, restored from git history as
``cases/data/colony_260/README.md`` says)

Needs: the package's dependencies (numpy, scipy, numba) and ``pip install cholespy qdldl qpalm
piqp`` (a missing one is reported in its row and skipped).

Prints progress lines, then a markdown table: method, what was timed, median seconds, ratio to
BBPGD's warm seconds, iterations / solves, residual reached (the engine's residual, a length;
for a factorisation, the relative residual |K x - b| / |b| of one solve, and fill nnz(L) / nnz
of K's lower triangle where known).
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import resource
import sys
import time
from pathlib import Path

import numba
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

try:
    import cholespy
except ImportError:  # reported in the table's rows
    cholespy = None

from particles.checkpoint import load_checkpoint
from particles.solvers.bbpgd import solve_contacts
from particles.solvers.problem import _gradient, _residual, incidence, particle_sums, prepare
from particles.stepping import detect, warm_start
from particles.strains import growth_law

ROOT = Path(__file__).resolve().parents[2]
CHECKPOINT = ROOT / "runs/state_104993/checkpoint.npz"
RHO0 = 0.1
"""ADMM penalty after Jacobi scaling (OSQP's default rho); R = diag(RHO0 H_kk)."""
RELAX = 1.6
"""ADMM relaxation (OSQP's default alpha)."""
NEWTON_EPS = 1e-6
"""Semismooth Newton's regularisation: H_AA + NEWTON_EPS diag(H)_A (H_AA is near singular: more
active contacts than the 3N rigid-body freedoms, the growth rows' curvature small)."""


def log(msg: str) -> None:
    """A progress line (stderr)."""
    print(msg, file=sys.stderr, flush=True)


# ------------------------------------------------------------------------- the step's problem


class Problem:
    """The contact problem of the step after the checkpoint, as stepping.step poses it."""

    def __init__(self, path: Path):
        ck = load_checkpoint(path)
        cfg, st = ck.config, ck.state
        self.n, self.step = st.n, st.step
        self.c = c = detect(st, cfg.contact_margin)
        self.gamma0 = warm_start(c.keys(st.ids), *st.warm)
        self.lam, self.rate = growth_law(cfg.strains, cfg.lam, st.strain)
        self.dt = float(st.dt_next)
        self.tol = cfg.effective_solver_tol
        self.maxiter = cfg.max_iterations
        self.length_in = st.length
        (self.length, _, (self.mt, self.mr, self.ti, self.tj, self.akk),
         self.law) = prepare(c, st.length, self.dt, self.lam, self.gamma0, self.rate)
        self.inc = incidence(c, self.ti, self.tj, self.n)
        self.pw = np.empty((self.n, 4))
        self.m = len(c)

    def grad(self, gam: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """The engine's gradient (the linearised gap) at gam (problem._gradient)."""
        out = np.empty(self.m) if out is None else out
        c = self.c
        _gradient(gam, *self.inc, c.i, c.j, c.nx, c.ny, self.ti, self.tj, c.gi, c.gj, c.gap,
                  self.mt, self.mr, self.length, self.dt, self.law, True, self.pw, out)
        return out

    def residual(self, gam: np.ndarray, g: np.ndarray | None = None) -> float:
        """The engine's stopping residual max_k |min(a_kk gam_k, grad_k)|; inf if not finite.

        (The kernel's max skips NaN, so a non-finite iterate is caught here.)
        """
        g = self.grad(gam) if g is None else g
        if not (np.all(np.isfinite(gam)) and np.all(np.isfinite(g))):
            return float("inf")
        return float(_residual(gam, g, self.akk))

    def merit(self, gam: np.ndarray, g: np.ndarray) -> float:
        """|min(a_kk gam_k, grad_k)|_2, the Newton line search's merit (inf if not finite)."""
        v = np.minimum(self.akk * gam, g)
        with np.errstate(over="ignore"):
            return float(np.sqrt(v @ v)) if np.all(np.isfinite(v)) else float("inf")

    def bbpgd(self, gamma0):
        """The engine's solve of this problem from gamma0 (None: cold)."""
        return solve_contacts(self.c, self.length_in, self.dt, self.lam, gamma0, self.tol,
                              self.maxiter, True, rate=self.rate)

    def hessian_factor(self, gam: np.ndarray) -> sp.csc_matrix:
        """S (4N x m, CSC): H(gam) = S^T S, rows (x, y, theta, l) of each cell.

        Rows scaled by sqrt(dt / l), sqrt(dt / l), sqrt(12 dt / l^3) and sqrt(h), h the
        curvature of the growth term, l lam a dt e^(-lam s) exp(a dt e^(-lam s)), s = G gam.
        """
        c, n, m = self.c, self.n, self.m
        particle_sums(gam, *self.inc, c.i, c.j, c.nx, c.ny, self.ti, self.tj, c.gi, c.gj,
                      self.pw)
        sigma = self.pw[:, 3].copy()
        lam = np.broadcast_to(self.law[:, 0], (n,))
        dtg = np.broadcast_to(self.law[:, 1], (n,))
        x = dtg * np.exp(-lam * sigma)
        h = self.length * lam * x * np.exp(x)
        sx, sr, sh = np.sqrt(self.dt * self.mt), np.sqrt(self.dt * self.mr), np.sqrt(h)
        i, j = c.i, c.j
        rows = np.empty((m, 8), dtype=np.int64)
        vals = np.empty((m, 8))
        for q in range(4):
            rows[:, q], rows[:, 4 + q] = 4 * i + q, 4 * j + q
        vals[:, 0], vals[:, 1] = -c.nx * sx[i], -c.ny * sx[i]
        vals[:, 2], vals[:, 3] = -self.ti * sr[i], c.gi * sh[i]
        vals[:, 4], vals[:, 5] = c.nx * sx[j], c.ny * sx[j]
        vals[:, 6], vals[:, 7] = self.tj * sr[j], c.gj * sh[j]
        indptr = np.arange(0, 8 * m + 1, 8)
        s = sp.csc_matrix((vals.ravel(), rows.ravel(), indptr), shape=(4 * n, m))
        s.sort_indices()
        return s


def body_matrix(s: sp.csc_matrix, r: np.ndarray, cols: np.ndarray | None = None):
    """K = I + S_cols R^-1 S_cols^T (CSC, full), its lower triangle (CSC)."""
    sc = s if cols is None else s[:, cols]
    rr = r if cols is None else r[cols]
    c = sc @ sp.diags(1.0 / np.sqrt(rr))
    k = (sp.identity(s.shape[0], format="csc") + (c @ c.T)).tocsc()
    k.sort_indices()
    low = sp.tril(k, format="csc")
    low.sort_indices()
    return k, low


# -------------------------------------------------------------------------------- timing


def median_time(fn, repeats: int, slow: float | None):
    """(median seconds, runs, last result) of fn(); a first run over ``slow`` s is not repeated."""
    secs, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        secs.append(time.perf_counter() - t0)
        if slow is not None and secs[0] > slow:
            break
    return float(np.median(secs)), len(secs), out


def _worker(name: str, checkpoint: Path, limit_s: float, memory_gb: float, q) -> None:
    """Child process: rebuild the problem and S, cap the address space, run one method."""
    numba.set_num_threads(1)
    pb = Problem(checkpoint)
    s = pb.hessian_factor(pb.gamma0)
    cap = int(memory_gb * 2**30)
    resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    q.put(("ready", None))
    try:
        if name == "superlu":
            d = np.asarray(s.multiply(s).sum(axis=0)).ravel()
            k, _ = body_matrix(s, RHO0 * d, np.flatnonzero(pb.gamma0 > 0))
            t0 = time.perf_counter()
            lu = spla.splu(k, permc_spec="COLAMD")
            q.put(("ok", (time.perf_counter() - t0, (lu.L.nnz + lu.U.nnz) / k.nnz)))
        elif name == "qpalm":
            q.put(("ok", run_qpalm(pb, s, lifted_qp(pb, s), limit_s)))
        else:
            q.put(("ok", run_piqp(pb, s, lifted_qp(pb, s))))
    except BaseException as err:  # noqa: BLE001 - reported, not raised
        q.put(("error", f"{type(err).__name__}: {err}".splitlines()[0][:160]))


def in_child(name: str, checkpoint: Path, limit_s: float, memory_gb: float):
    """Method ``name`` (superlu, qpalm, piqp) in a fresh process, under an address-space cap.

    Spawned: the Numba threading layer (GNU OpenMP) forbids fork.  Returns ('ok', result),
    ('error', line) or ('killed', limit_s) when it runs past limit_s (its setup not counted).
    """
    ctx = mp.get_context("spawn")
    q = ctx.Queue()
    p = ctx.Process(target=_worker, args=(name, checkpoint, limit_s, memory_gb, q))
    p.start()
    t0 = time.perf_counter() + 600.0  # the child rebuilds the problem first (untimed)
    result = None
    while p.is_alive() or not q.empty():
        try:
            result = q.get(timeout=1.0)
        except Exception:  # noqa: BLE001 - queue.Empty
            if time.perf_counter() - t0 > limit_s + 120.0:  # qpalm stops itself at limit_s
                os.kill(p.pid, 9)
                break
            continue
        if result[0] != "ready":
            break
        result, t0 = None, time.perf_counter()
    p.join()
    if result is None and p.exitcode not in (None, -9):
        return ("error", f"child exited with code {p.exitcode}")
    return result or ("killed", limit_s)


# -------------------------------------------------------------------------------- methods


def admm(pb: Problem, s: sp.csc_matrix, r: np.ndarray, factor_solve, max_seconds: float,
         max_iterations: int = 20_000):
    """Fixed-factor ADMM (module docstring) from the warm start; (solves, residual, z)."""
    x = pb.gamma0.copy()
    z = x.copy()
    g = pb.grad(x)
    y = -g
    st = s.T.tocsr()
    kb = np.empty(s.shape[0])
    t0 = time.perf_counter()
    res = pb.residual(z, g)
    it = 0
    while res > pb.tol and it < max_iterations and time.perf_counter() - t0 < max_seconds:
        it += 1
        rhs = -(g + r * (x - z) + y)
        w = rhs / r
        factor_solve(np.ascontiguousarray(s @ w), kb)
        xt = x + (w - (st @ kb) / r)
        zh = RELAX * xt + (1 - RELAX) * z
        x = RELAX * xt + (1 - RELAX) * x
        znew = np.maximum(0.0, zh + y / r)
        y = y + r * (zh - znew)
        z = znew
        g = pb.grad(x)
        res = pb.residual(z)
        if it % 100 == 0:
            log(f"  ADMM: residual {res:.3g} after {it} solves")
    return it, res, z


def _woodbury(f, sa: sp.csc_matrix, ra: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """(S_A^T S_A + R_A)^-1 rhs = R_A^-1 (rhs - S_A^T K_A^-1 S_A R_A^-1 rhs), f: K_A's factor."""
    v = np.empty(sa.shape[0])
    f.solve(np.ascontiguousarray(sa @ (rhs / ra)), v)
    return (rhs - sa.T @ v) / ra


def newton(pb: Problem, s: sp.csc_matrix, d: np.ndarray, max_seconds: float,
           eps: float = NEWTON_EPS):
    """Semismooth Newton from the warm start, one cholespy factorisation per new active set.

    At gamma, A = {k : grad_k < a_kk gamma_k} (the contacts where the engine's residual reads
    the gap); the step sets gamma_I = 0 and solves (H_AA + eps diag(H)_A) dgamma_A =
    -grad_A + H_AI gamma_I with H = S^T S frozen at the warm start (Woodbury: K_A = I + S_A
    R_A^-1 S_A^T, one refinement solve), then backtracks (halving, from a full step) along the
    projected path max(0, gamma + alpha dgamma) until |min(a_kk gamma, grad)|_2 decreases
    (gradients only: the energy's growth term has no closed form); the exact gradient
    throughout.  Returns (factorisations, solves, residual, residual history).
    """
    t0 = time.perf_counter()
    gam = pb.gamma0.copy()
    g = pb.grad(gam)
    res = pb.residual(gam, g)
    hist = [res]
    r = eps * d
    facts = solves = 0
    prev = None
    f = sa = None
    while res > pb.tol and time.perf_counter() - t0 < max_seconds:
        act = g < pb.akk * gam
        if prev is None or not np.array_equal(act, prev):
            cols = np.flatnonzero(act)
            sa = s[:, cols]
            k, low = body_matrix(sa, r[cols])
            f = cholespy.CholeskySolverD(k.shape[0], low.indptr.astype(np.int32),
                                         low.indices.astype(np.int32), low.data,
                                         cholespy.MatrixType.CSC)
            facts += 1
            prev = act
        off = np.where(act, 0.0, gam)
        b = -g[act] + sa.T @ (s @ off)
        ra = r[act]

        step = _woodbury(f, sa, ra, b)
        step += _woodbury(f, sa, ra, b - (sa.T @ (sa @ step) + ra * step))
        solves += 2
        full = np.where(act, gam, 0.0)
        full[act] += step
        direction = full - gam
        m0, alpha = pb.merit(gam, g), 1.0
        while True:  # backtracking on the merit along the projected path (gradients only)
            trial = np.maximum(gam + alpha * direction, 0.0)
            gt = pb.grad(trial)
            if pb.merit(trial, gt) < m0 or alpha < 1e-6:
                break
            alpha *= 0.5
        gam, g = trial, gt
        res = pb.residual(gam, g)
        hist.append(res)
        log(f"  Newton: residual {res:.3g} after {facts} factorisations (|A| = {act.sum()}, "
            f"step {alpha:g})")
    return facts, solves, res, hist


def lifted_qp(pb: Problem, s: sp.csc_matrix):
    """The SQP step's QP at gamma0 in lifted form: (c, S) of min c.g + |v|^2/2, v = S g, g >= 0."""
    g0 = pb.grad(pb.gamma0)
    return g0 - s.T @ (s @ pb.gamma0)


def run_qpalm(pb: Problem, s: sp.csc_matrix, cvec: np.ndarray, time_limit: float):
    """Qpalm on the lifted QP: (seconds, iterations, engine residual, status)."""
    import qpalm

    m, nb = s.shape[1], s.shape[0]
    n = m + nb
    t0 = time.perf_counter()
    d = qpalm.Data(n, nb + m)
    d.Q = sp.block_diag([sp.csc_matrix((m, m)), sp.identity(nb)], format="csc")
    d.A = sp.bmat([[-s, sp.identity(nb)], [sp.identity(m), None]], format="csc")
    d.q = np.r_[cvec, np.zeros(nb)]
    d.bmin = np.zeros(nb + m)
    d.bmax = np.r_[np.zeros(nb), np.full(m, 1e20)]
    st = qpalm.Settings()
    st.verbose, st.eps_abs, st.time_limit = 0, pb.tol, time_limit
    solver = qpalm.Solver(d, st)
    solver.warm_start(np.r_[pb.gamma0, s @ pb.gamma0], None)
    solver.solve()
    secs = time.perf_counter() - t0
    gam = np.maximum(0.0, solver.solution.x[:m])
    return secs, f"{solver.info.iter} inner / {solver.info.iter_out} outer", \
        pb.residual(gam), str(solver.info.status)


def run_piqp(pb: Problem, s: sp.csc_matrix, cvec: np.ndarray):
    """Piqp on the lifted QP: (seconds, iterations, engine residual, status)."""
    import piqp

    m, nb = s.shape[1], s.shape[0]
    t0 = time.perf_counter()
    solver = piqp.SparseSolver()
    solver.settings.num_threads = 1
    solver.settings.eps_abs = pb.tol
    solver.settings.eps_duality_gap_abs = pb.tol
    solver.setup(sp.block_diag([sp.csc_matrix((m, m)), sp.identity(nb)], format="csc"),
                 np.r_[cvec, np.zeros(nb)], sp.hstack([-s, sp.identity(nb)], format="csc"),
                 np.zeros(nb), None, None, None, np.r_[np.zeros(m), np.full(nb, -np.inf)],
                 None)
    status = solver.solve()
    secs = time.perf_counter() - t0
    gam = np.maximum(0.0, solver.result.x[:m])
    return secs, f"{solver.result.info.iter} IP iterations", pb.residual(gam), str(status)


# ----------------------------------------------------------------------------------- main


def main(argv: list[str] | None = None) -> list[tuple]:  # noqa: C901 - one row per method
    """Command line (module docstring); returns the table's rows."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--checkpoint", type=Path, default=CHECKPOINT)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--slow", type=float, default=10.0,
                    help="time once a method whose first run exceeds this many BBPGD solves")
    ap.add_argument("--limit", type=float, default=10.0,
                    help="stop a method after this many BBPGD (warm) seconds")
    ap.add_argument("--admm-limit", type=float, default=30.0,
                    help="stop the fixed-factor AL after this many BBPGD (warm) seconds")
    ap.add_argument("--memory-gb", type=float, default=12.0)
    ap.add_argument("--skip", nargs="*", default=[],
                    help="methods to leave out: cholespy qdldl newton superlu admm qpalm piqp")
    a = ap.parse_args(argv)
    numba.set_num_threads(1)
    rows: list[tuple] = []

    pb = Problem(a.checkpoint)
    log(f"state: {pb.n} cells, step {pb.step}; step's problem: {pb.m} contacts, dt "
        f"{pb.dt:.6g}, lam {pb.lam}, tol {pb.tol:g}, warm start: {np.count_nonzero(pb.gamma0)}"
        f" nonzero, residual {pb.residual(pb.gamma0):.3g}")
    pb.bbpgd(pb.gamma0)  # compiled / loaded kernels before timing

    def bbpgd_warm():
        secs = []
        for _ in range(a.repeats):
            t0 = time.perf_counter()
            out = pb.bbpgd(pb.gamma0)
            secs.append(time.perf_counter() - t0)
        return secs, out

    first, (gam, hist) = bbpgd_warm()
    bb = ref = float(np.median(first))  # the reference of --slow and the limits
    runs = len(first)
    active = int(np.count_nonzero(gam))
    log(f"BBPGD warm: {len(hist) - 1} iterations, {bb:.3f} s, residual {hist[-1]:.3g}, "
        f"{active} active")
    rows.append(("BBPGD (engine)", "solve from warm start", bb, runs, len(hist) - 1,
                 f"{hist[-1]:.3g}"))
    sec, runs, (_, hc) = median_time(lambda: pb.bbpgd(None), a.repeats, None)
    log(f"BBPGD cold: {len(hc) - 1} iterations, {sec:.3f} s, residual {hc[-1]:.3g}")
    rows.append(("BBPGD (engine)", "solve from zero", sec, runs, len(hc) - 1, f"{hc[-1]:.3g}"))
    slow = a.slow * ref

    # The Hessian factor at the warm start, checked against the engine's gradient.
    s = pb.hessian_factor(pb.gamma0)
    d = np.asarray(s.multiply(s).sum(axis=0)).ravel()  # H_kk
    rng = np.random.default_rng(0)
    dg = rng.standard_normal(pb.m) * 1e-3 * max(1.0, float(pb.gamma0.max()))
    fd = pb.grad(pb.gamma0 + dg) - pb.grad(pb.gamma0 - dg)
    hd = 2 * (s.T @ (s @ dg))
    log(f"check: |(q(g+d) - q(g-d)) - 2 S^T S d| / |...| = "
        f"{np.linalg.norm(fd - hd) / np.linalg.norm(hd):.2e}; "
        f"growth share of H_kk: max {np.max((d - pb.akk) / d):.2e}")
    r = RHO0 * d
    cols = np.flatnonzero(pb.gamma0 > 0)
    sec, runs, (k, low) = median_time(lambda: body_matrix(s, r, cols), a.repeats, slow)
    log(f"K_A: {k.shape[0]} unknowns, {k.nnz} nonzeros ({low.nnz} in the lower triangle), "
        f"A = {cols.size} contacts active at the warm start; assembled in {sec:.3f} s")
    rows.append(("assembly (scipy)", f"K_A = I + S_A R^-1 S_A^T, {k.shape[0]} unknowns, "
                 f"{k.nnz / 1e6:.1f}e6 nonzeros", sec, runs, "", ""))
    b = rng.standard_normal(k.shape[0])

    def rel(x):
        return f"{np.linalg.norm(k @ x - b) / np.linalg.norm(b):.1e}"

    if "cholespy" not in a.skip:
        try:
            import cholespy

            ip, ix = low.indptr.astype(np.int32), low.indices.astype(np.int32)

            def chol():
                return cholespy.CholeskySolverD(k.shape[0], ip, ix, low.data,
                                                cholespy.MatrixType.CSC)

            sec, runs, f = median_time(chol, a.repeats, slow)
            log(f"cholespy analysis + factorisation {sec:.3f} s ({runs} runs)")
            rows.append(("cholespy (CHOLMOD)", "analysis + factorisation of K_A", sec, runs,
                         "", ""))
            x = np.empty_like(b)
            sec, runs, _ = median_time(lambda: f.solve(b, x), a.repeats, slow)
            rows.append(("cholespy (CHOLMOD)", "one solve", sec, runs, "", rel(x)))
            del f
        except ImportError as err:
            rows.append(("cholespy", f"not installed: {err}", np.nan, 0, "", ""))

    if "qdldl" not in a.skip:
        try:
            import qdldl

            sec, runs, f = median_time(lambda: qdldl.Solver(low.T.tocsc(), upper=True),
                                       a.repeats, slow)
            lnz = f.factors()[0].nnz if hasattr(f, "factors") else None
            fill = f"fill {lnz / low.nnz:.1f}" if lnz else ""
            log(f"qdldl factorisation {sec:.3f} s ({runs} runs) {fill}")
            rows.append(("qdldl (AMD)", "ordering + factorisation of K_A", sec, runs, "",
                         fill))
            up = low.T.tocsc()
            up.data = up.data * (1 + 1e-3 * rng.random(up.nnz))  # new values, same pattern
            sec, runs, _ = median_time(lambda: f.update(up, upper=True), a.repeats, slow)
            rows.append(("qdldl (AMD)", "numeric refactorisation (same pattern)", sec, runs,
                         "", ""))
            f.update(low.T.tocsc(), upper=True)
            sec, runs, x = median_time(lambda: f.solve(b), a.repeats, slow)
            rows.append(("qdldl (AMD)", "one solve", sec, runs, "", rel(x)))
            del f
        except ImportError as err:
            rows.append(("qdldl", f"not installed: {err}", np.nan, 0, "", ""))

    if "newton" not in a.skip:
        try:
            import cholespy  # noqa: F401 - newton() uses it

            rows3 = np.flatnonzero(np.arange(s.shape[0]) % 4 != 3)
            k3, low3 = body_matrix(s[rows3, :].tocsc(), r, cols)

            def chol3():
                return cholespy.CholeskySolverD(k3.shape[0], low3.indptr.astype(np.int32),
                                                low3.indices.astype(np.int32), low3.data,
                                                cholespy.MatrixType.CSC)

            sec, runs, _ = median_time(chol3, a.repeats, slow)
            log(f"cholespy 3N: {sec:.3f} s ({runs} runs)")
            rows.append(("cholespy (CHOLMOD)", f"analysis + factorisation of K_A without the "
                         f"length rows ({k3.shape[0]} unknowns, {k3.nnz / 1e6:.1f}e6 "
                         "nonzeros: H_AA singular with more active contacts than 3N)", sec,
                         runs, "", ""))
            del k3, low3
            t0 = time.perf_counter()
            facts, solves, res, nh = newton(pb, s, d, a.limit * ref)
            sec = time.perf_counter() - t0
            log(f"Newton: {sec:.3f} s, {facts} factorisations, residuals "
                f"{', '.join(f'{x:.3g}' for x in nh)}")
            rows.append(("semismooth Newton (cholespy)", "a factorisation of K_A (4N) per new "
                         "active set + 2 solves per step, from warm start", sec, 1,
                         f"{facts} factorisations, {solves} solves"
                         + (" (stopped at the time limit)" if res > pb.tol else ""),
                         f"{res:.3g}"))
        except ImportError as err:
            rows.append(("semismooth Newton", f"needs cholespy: {err}", np.nan, 0, "", ""))

    if "superlu" not in a.skip:
        secs, runs, fill = [], 0, None
        for _ in range(a.repeats):
            kind, out = in_child("superlu", a.checkpoint, a.limit * ref, a.memory_gb)
            runs += 1
            if kind != "ok":
                secs.append(np.nan if kind == "error" else -a.limit * ref)
                fill = "killed at the time limit" if kind == "killed" else out
                break
            secs.append(out[0])
            fill = f"fill {out[1]:.1f} (L+U over K)"
            if out[0] > slow:
                break
        sec = float(np.median(secs))
        log(f"SuperLU COLAMD {sec:.3f} s ({runs} runs) {fill}")
        rows.append(("SuperLU (COLAMD)", "factorisation of K_A (full)", sec, runs, "", fill))

    if "admm" not in a.skip:
        try:
            import cholespy

            def fixed_factor_al():
                t0 = time.perf_counter()
                kall, lall = body_matrix(s, r)
                f = cholespy.CholeskySolverD(kall.shape[0], lall.indptr.astype(np.int32),
                                             lall.indices.astype(np.int32), lall.data,
                                             cholespy.MatrixType.CSC)
                t1 = time.perf_counter()
                it, res, _ = admm(pb, s, r, f.solve, a.admm_limit * ref - (t1 - t0))
                return t1 - t0, it, res, kall.nnz

            sec, runs, (tf, it, res, nnz) = median_time(fixed_factor_al, a.repeats, slow)
            log(f"fixed-factor AL (ADMM): {sec:.3f} s, factor {tf:.3f} s, {it} solves, "
                f"residual {res:.3g}")
            rows.append(("fixed-factor AL (ADMM, cholespy)",
                         f"assembly + factorisation of K_all ({nnz / 1e6:.1f}e6 nonzeros, "
                         f"{tf:.2f} s) + solves to tol", sec, runs,
                         f"{it} solves" + (" (stopped at the time limit)" if res > pb.tol
                                           else ""),
                         f"{res:.3g}"))
        except ImportError as err:
            rows.append(("fixed-factor AL", f"needs cholespy: {err}", np.nan, 0, "", ""))

    for name in ("qpalm", "piqp"):
        if name in a.skip:
            continue
        secs, runs, info = [], 0, ("", "", "")
        for _ in range(a.repeats):
            kind, out = in_child(name, a.checkpoint, a.limit * ref, a.memory_gb)
            runs += 1
            if kind != "ok":
                secs.append(np.nan if kind == "error" else -a.limit * ref)
                info = ("", "killed at the time limit" if kind == "killed" else out, "-")
                break
            secs.append(out[0])
            info = out[1:]
            if out[0] > slow:
                break
        sec = float(np.median(secs))
        log(f"{name}: {sec:.3f} s ({runs} runs) {info}")
        what = ("proximal AL + semismooth Newton, warm start" if name == "qpalm"
                else "interior point, cold") + ", SQP-step QP (growth linearised at gamma0)"
        res = f"{info[1]:.3g}" if isinstance(info[1], float) else info[1]
        rows.append((name, f"{what}; status {info[2]}", sec, runs, info[0], res))

    # BBPGD warm again at the end: the machine's load drifts during the run, so the ratios
    # are taken to the median of the runs at the start and at the end.
    last, _ = bbpgd_warm()
    ref = float(np.median(first + last))
    log(f"BBPGD warm again: {np.median(last):.3f} s; reference {ref:.3f} s "
        f"(runs {', '.join(f'{x:.2f}' for x in first + last)})")
    rows[0] = ("BBPGD (engine)", f"solve from warm start (median of {len(first)} runs at the "
               f"start, {np.median(first):.3g} s, and {len(last)} at the end, "
               f"{np.median(last):.3g} s)", ref, len(first) + len(last), rows[0][4], rows[0][5])
    print(f"\nstep {pb.step + 1} of the checkpoint's run: {pb.n} cells, {pb.m} contacts, "
          f"{active} active at the solution, dt {pb.dt:.6g}, lam {pb.lam}, tol {pb.tol:g}, "
          f"one thread, medians of up to {a.repeats} runs\n")
    print("| method | timed | median s | / BBPGD (warm) | runs | iterations / solves "
          "| residual reached |")
    print("|---|---|---|---|---|---|---|")
    for name, what, sec, runs, its, res in rows:  # sec < 0: stopped at -sec
        over = "> " if sec < 0 else ""
        print(f"| {name} | {what} | {over}{abs(sec):.3g} | {over}{abs(sec) / ref:.2f} | {runs} "
              f"| {its} | {res} |")
    return rows


if __name__ == "__main__":
    main()
