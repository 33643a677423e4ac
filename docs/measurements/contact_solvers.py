"""Benchmark of the per-step contact solvers on the same saved states (issue 4).

For each state the growth step of model.md is solved at the same tolerance by every solver
(BBPGD and APGD):

- cold: from gamma0 = 0 on the state's contacts (gap <= margin);
- warm: after one step of the engine's update with the reference solution (move by
  dt M D gamma, grow l <- l exp(dt exp(-lam sigma))), contacts re-detected and the new solve
  warm-started from the previous forces matched by contact identity (particle ids + endpoint
  code), as the engine does.

States (``--sizes``, target particle numbers):

- ``synthetic`` (default): a dense disc of rods made by ``particles.packings.ring_packing``:
  concentric rings of tangential rods (random tip-to-tip lengths in [1, 1.9), seeded),
  end-to-end gaps and
  ring-to-ring clearances of 1e-3 b-units jittered by +-50%, so no two rods overlap and the
  colony is jammed under one growth step: growth along each ring pushes on the next ring out,
  a 2D-coupled, pressure-like load path;
- ``--grown FILE.npz`` (repeatable): saved engine states (arrays x, y, theta, length),
  e.g. from ``particles.run(particles.Config(lam=1e-2, radius=R))``, or ring
  packings grown by the engine for a short time (jammed, most contacts loaded).  States are
  grouped into families by the leading letters of their file names for the fitted exponents.

Candidate measured and rejected (prototype not kept; numbers from this machine, 2026-11-21):
augmented Lagrangian in particle space (growth linearised at the current loads, proximal
point on gamma with weight rho = s / median(a_kk), semismooth Newton on the 4N scaled
particle unknowns, Hessian I + rho S_A S_A^T, S = (dt M, c)^(1/2) [D; G], by CG with pyamg
smoothed aggregation, 4x4 blocks, near-null space translations/spin/growth).  On the grown
colony N = 1022 (tol 1e-3, cold): s = 1e4: 2 outer, 17 Newton, 3505 CG iterations, 45.6 s;
s = 1e2: 7 outer, 23 Newton, 765 CG, 21.4 s; BBPGD: 151 iterations, 0.05 s.  The AMG-PCG
alone on H at the converged active set (s = 1e4, rtol 1e-6) needs 285 iterations at 4N = 4088
and 286 at 4N = 50900 (N = 12725): flat in N but far too many; the network of active
frictionless contacts is close to isostatic (3022 active contacts for 3N = 3066 at N = 1022),
so its low modes are not smooth and aggregation does not capture them.  SuperLU (MMD) on the
same H at 4N = 50900 did not factor within 9 minutes.

Second candidate, ``twolevel``, measured by this script at commit d7ef4ce (removed since:
rejected; the code was particles/solvers/twolevel.py), no faster: BBPGD smoothing
(nu = 200, BB step kept across cycles) + one coarse Newton step on the smooth multiplicative
correction gamma <- max(0, gamma (1 + P c)), P the bilinear hats of a square grid of spacing h =
4 (601 nodes at N = 1e4, ~8000 at N = 1e5; sparse Galerkin H_c, SuperLU). Gradient evaluations
twolevel / BBPGD (cold, warm; measured 2026-11-22, load ~2, repeat 1): tol 1e-3: grownrings1000
1.00, 1.00; grownrings10000 0.97, 0.92; grownrings100000 0.85, 0.97; grown_R55 0.85, 1.00. tol
1e-4: grownrings1000 1.12, 0.90; grownrings10000 0.81, 1.19; grownrings100000 1.00, 0.97 (9611
and 5887 iterations, 56 s and 35 s; BBPGD 9582 and 6048, 48 s and 33 s in an earlier run at load
~3); grown_R55 0.83, 1.10. Seconds follow (the coarse step costs ~0.3 s at N = 1e5), and APGD
stays 2x ahead at tol 1e-4; fitted exponents of iterations over grownrings 1e3-1e5, cold: tol
1e-4 N^0.77 (BBPGD 0.80, APGD 0.58), tol 1e-3 N^0.54 (BBPGD 0.58, APGD 0.66). Why: the coarse
step does remove energy (N = 1e4, cold, E - E_ref after 200 smoothing iterations 110 with four
coarse steps vs 251 for plain BBPGD; a 2 x 2-node grid alone gives 135), but the stopping test
is a max-norm gap residual and what is left is not smooth: after 1500 BBPGD iterations at N =
1e4 the load error averaged over radial bands is -0.8 while its standard deviation is 10 (mean
load ~100), and the largest residuals sit on a few contacts; 32077 active contacts for 3N =
31926 rigid-body freedoms, so self-stress states (forces that open no gap) are held only by the
weak growth curvature l lam dt exp(r) ~ 5e-5 l. Variants no better: h = 8, nu = 400 (1400 vs
1425 iterations, N = 1e5, tol 1e-3); a 2 x 2-node grid, nu = 200 (3228 vs 3019, N = 1e4, tol
1e-4); resetting the BB step at each coarse step (nu = 50: 3485, nu = 20: 4239 vs 3019; keeping
it, nu = 50: 2904).

Third candidate, prototype not kept (runs/fastsolver/blockapgd_prototype.py, untracked): the
largest late residuals sit on pairs of rods touching twice (91% of the 100 largest at N = 1e4
after 1500 BBPGD iterations, vs 56% of all contacts), so APGD was run in the exact 2 x 2
block-Jacobi metric of dt D^T M D per such pair (blockwise exact projection onto gamma >= 0,
step from power iteration, gradient restart). Cold, tol 1e-4, iterations block / APGD:
grownrings 1e3, 1e4, 1e5: 258 / 329, 1409 / 1367, 4430 / 4182 (same growth in N); grown_R17 351
/ 433, grown_R55 1274 / 1936. A constant factor on engine-grown states at best, not an
N-independent cost; seconds were not better in the prototype.

Fourth candidate, prototype not kept (runs/fastsolver/pgs_exp.py, untracked; 2026-11-22, load
~3.5): projected Gauss-Seidel, i.e. exact coordinate descent on E contact by contact (Newton
step on gamma_k with curvature a_kk + the growth curvature, projected on >= 0; one sweep costs
about one gradient evaluation), alone and as the smoother of the two-level cycle above.  Cold,
tol 1e-4, sweeps on grownrings 1229 / 10642 particles: Gauss-Seidel 1110 / 11190 (N^0.98),
symmetric 1880 / 21710, SOR omega = 1.5 520 / 7380, Gauss-Seidel + coarse step (h = 4) every 50
sweeps 1000 / 10900, every 10 sweeps 920 / 11140; BBPGD 296 / 3282 iterations.  Gauss-Seidel
smooths the error, yet the coarse step still removes almost nothing, which is the diagnosis
above: the slow part of the error is not smooth.

The load error column compares sigma = G gamma with the reference solve (``--ref-solver`` at
tol / ``--ref-factor``); with a small factor, or with the reference computed by one of the
compared solvers, it is biased towards that solver: use BBPGD and a factor >= 100 for a fair
comparison (at tol 1e-3 both solvers' loads then differ from the reference by 20-40% at
N ~ 1e4: the gap tolerance does not pin the loads).

Prints a table of medians over ``--repeat`` runs (iterations, gradient evaluations, seconds,
final residual, max ``|sigma - sigma_ref|``) and the fitted exponents of iterations and seconds in
N, and writes the rows to ``--out`` (CSV).  Record ``uptime`` beside the timings: the machine
may be shared.

Command line (from the repository root, the package installed)::

    python docs/measurements/contact_solvers.py [--sizes 1000 10000] [--tol 1e-3 1e-4]
        [--solvers bbpgd apgd] [--grown FILE.npz ...] [--repeat 3] [--out CSV]
"""

from __future__ import annotations

import argparse
import csv
import os
import re
import time
from pathlib import Path

import numpy as np

from particles.geometry import detect_contacts, generalised_forces
from particles.growth import grow
from particles.packings import ring_packing
from particles.solvers.apgd import solve_contacts_apgd
from particles.solvers.bbpgd import solve_contacts
from particles.solvers.problem import linearised_gap
from particles.stepping import warm_start
from particles.stress import axial_stress


def warm_problem(x, y, theta, length, c, gamma, dt, lam, margin):  # noqa: PLR0913
    """The warm-started problem of the next step: a contact solver's test problem.

    One engine update with forces gamma (x += dt F / l, theta += dt 12 T / l^3, (F, T) =
    D gamma; l <- l exp(dt exp(-lam sigma)), sigma = G gamma), the contacts of the new
    configuration with gap <= margin, and their warm start (the forces gamma of the contacts
    whose identity persists, 0 for new ones: stepping.warm_start), as the engine does
    (stepping.step).

    Returns
    -------
    (x2, y2, theta2, length2), contacts2, gamma0
    """
    n = x.shape[0]
    ids = np.arange(n, dtype=np.int64)
    fx, fy, tz = generalised_forces(c, gamma, n)
    stress = axial_stress(c, gamma, n)
    x2 = x + dt * fx / length
    y2 = y + dt * fy / length
    th2 = theta + dt * 12.0 * tz / length**3
    l2 = grow(length, stress, lam, dt)
    c2 = detect_contacts(x2, y2, th2, l2, margin)
    return (x2, y2, th2, l2), c2, warm_start(c2.keys(ids), c.keys(ids), gamma)


SOLVERS = {"bbpgd": (solve_contacts, 1), "apgd": (solve_contacts_apgd, 1)}
"""name -> (solver, gradient evaluations per iteration)."""


def residual(c, length, dt, lam, gamma) -> float:
    """Projected residual ``max_k |min(a_kk gamma_k, q_k)|`` (contact_solver's definition)."""
    ti = c.rix * c.ny - c.riy * c.nx
    tj = c.rjx * c.ny - c.rjy * c.nx
    akk = dt * (1 / length[c.i] + 1 / length[c.j] + 12 / length[c.i] ** 3 * ti**2
                + 12 / length[c.j] ** 3 * tj**2)
    q = linearised_gap(c, length, dt, lam, gamma)
    return float(np.max(np.abs(np.minimum(akk * gamma, q))))


def measure(name, c, length, dt, lam, gamma0, tol, repeat):
    """Median seconds and the (deterministic) iteration count of one solver."""
    solver, per_it = SOLVERS[name]
    secs = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        gamma, hist = solver(c, length, dt, lam, gamma0, tol, 1_000_000, True)
        secs.append(time.perf_counter() - t0)
    return gamma, len(hist) - 1, per_it * (len(hist) - 1), float(np.median(secs))


def states(args):
    """The states to measure: (label, (x, y, theta, length), seconds to make it) each."""
    for n in args.sizes:
        t0 = time.perf_counter()
        st = ring_packing(n, seed=args.seed)
        yield f"rings{n}", st, time.perf_counter() - t0
    for f in args.grown or []:
        z = np.load(f)
        yield Path(f).stem, (z["x"], z["y"], z["theta"], z["length"]), 0.0


def main(argv=None) -> None:
    """Command line (module docstring)."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sizes", type=int, nargs="*", default=[1000, 10000],
                   help="target particle numbers of synthetic ring packings")
    p.add_argument("--grown", action="append", help="saved grown state (npz), repeatable")
    p.add_argument("--tol", type=float, nargs="+", default=[1e-3, 1e-4])
    p.add_argument("--lam", type=float, default=1e-2)
    p.add_argument("--dt", type=float, default=0.005)
    p.add_argument("--margin", type=float, default=0.1)
    p.add_argument("--solvers", nargs="+", default=list(SOLVERS), choices=list(SOLVERS))
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--ref-factor", type=float, default=100.0,
                   help="reference loads: solved at tol / ref_factor")
    p.add_argument("--ref-solver", default="bbpgd", choices=list(SOLVERS),
                   help="solver of the reference loads and of the warm-start step")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=None)
    args = p.parse_args(argv)
    # compile every kernel once on a tiny state so no timing includes Numba compilation
    small = ring_packing(50, seed=1)
    cs = detect_contacts(*small, args.margin)
    for name in args.solvers:
        SOLVERS[name][0](cs, small[3], args.dt, args.lam, None, 1e-3)
    print(f"# load: {os.getloadavg()}")
    rows = []
    hdr = (f"{'state':>14} {'N':>7} {'K':>7} {'start':>5} {'tol':>7} {'solver':>6} {'iters':>7} "
           f"{'grads':>7} {'sec':>8} {'res':>9} {'dsig/sig':>9}")
    print(hdr)
    for label, st, _seconds in states(args):
        x, y, theta, length = st
        n = x.shape[0]
        c = detect_contacts(x, y, theta, length, args.margin)
        for tol in args.tol:
            # reference for the warm start and the load comparison, at tol / ref_factor
            rtol = tol / args.ref_factor
            ref_solve = SOLVERS[args.ref_solver][0]
            gref, _ = ref_solve(c, length, args.dt, args.lam, None, rtol, 10_000_000)
            (x2, y2, th2, l2), c2, g0 = warm_problem(x, y, theta, length, c, gref, args.dt,
                                                     args.lam, args.margin)
            gref2, _ = ref_solve(c2, l2, args.dt, args.lam, g0, rtol, 10_000_000)
            for start, cc, ll, gg, ref in (("cold", c, length, None, gref),
                                           ("warm", c2, l2, g0, gref2)):
                sref = axial_stress(cc, ref, n)
                for name in args.solvers:
                    gamma, its, grads, sec = measure(name, cc, ll, args.dt, args.lam, gg, tol,
                                                     args.repeat)
                    res = residual(cc, ll, args.dt, args.lam, gamma)
                    dsig = float(np.abs(axial_stress(cc, gamma, n) - sref).max() / sref.max())
                    row = dict(state=label, N=n, K=len(cc), start=start, tol=tol, solver=name,
                               iterations=its, gradients=grads, seconds=sec, residual=res,
                               rel_load_error=dsig, load=os.getloadavg()[0])
                    rows.append(row)
                    print(f"{label:>14} {n:>7} {len(cc):>7} {start:>5} {tol:>7.0e} {name:>6} "
                          f"{its:>7} {grads:>7} {sec:>8.3f} {res:>9.2e} {dsig:>9.2e}", flush=True)
    _summary(rows, args.solvers)
    if args.out is not None:
        with open(args.out, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)


def _family(label: str) -> str:
    """Family of a state label: its leading letters (rings1000 -> rings, grown_R17 -> grown)."""
    return re.match(r"[A-Za-z]*", label).group(0)


def _summary(rows, solvers) -> None:
    """Ratios to BBPGD and fitted exponents d log(iterations) / d log N per series."""
    print("# ratios (solver / bbpgd): gradient evaluations, seconds")
    keyf = lambda r: (r["state"], r["start"], r["tol"])  # noqa: E731
    by = {}
    for r in rows:
        by.setdefault(keyf(r), {})[r["solver"]] = r
    for k, d in by.items():
        if "bbpgd" in d:
            for s in solvers:
                if s != "bbpgd" and s in d:
                    rg = d[s]["gradients"] / max(1, d["bbpgd"]["gradients"])
                    rs = d[s]["seconds"] / d["bbpgd"]["seconds"]
                    print(f"#   {k}: {s} grads x{rg:.2f} seconds x{rs:.2f}")
    print("# exponents in N, per family of states: iterations ~ N^a, seconds ~ N^b")
    families = sorted({_family(r["state"]) for r in rows})
    for fam in families:
        for s in solvers:
            for start in ("cold", "warm"):
                for tol in sorted({r["tol"] for r in rows}):
                    sel = [r for r in rows if r["solver"] == s and r["start"] == start
                           and r["tol"] == tol and _family(r["state"]) == fam]
                    if len(sel) >= 2:
                        ln = np.log([r["N"] for r in sel])
                        a = np.polyfit(ln, np.log([max(1, r["iterations"]) for r in sel]), 1)[0]
                        b = np.polyfit(ln, np.log([r["seconds"] for r in sel]), 1)[0]
                        print(f"#   {fam} {s:>6} {start} tol={tol:g}: a={a:.2f} b={b:.2f}")


if __name__ == "__main__":
    main()
