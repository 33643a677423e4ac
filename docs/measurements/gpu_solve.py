"""The contact solve on a GPU against the CPU, at a checkpoint's colony (issue 44, part 3).

A measurement for a machine with a CUDA GPU (and numba-cuda with CUDA's compiler, the ``gpu``
extra), not part of the package.  From a run's checkpoint it takes the problem of the next
step exactly as the engine poses it (``second_order.Problem``, beside this file) and times:

- one solve of it by the engine's BBPGD on the CPU, at each ``--threads`` (Numba threads);
- the same solve by ``--solver bbpgd-cuda`` (particles/solvers/bbpgd_cuda.py), after one
  solve that compiles the kernels;
- ``--steps`` whole engine steps from the checkpoint with each solver (division, detection and
  growth stay on the CPU), at the largest ``--threads``.

For each solve: median seconds of ``--repeats``, iterations, seconds per iteration, and the
bytes one iteration moves by the kernels' count (:func:`iteration_bytes`) over its time, to set
against the card's bandwidth (an H200: about 4.3 TB/s device to device) and one core's
(about 16 GB/s here).  The two solvers must reach the same tolerance in about the same number
of iterations (the same iteration to round-off); the table says how far their gammas are.

Run (from the repository root, the package installed, on the GPU machine)::

    NUMBA_ENABLE_CUDASIM=0 python docs/measurements/gpu_solve.py \
        runs/state_104993/checkpoint.npz --threads 1 2 16 --steps 3

Prints progress lines on stderr and a markdown table on stdout.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

import numba
import numpy as np

if str(Path(__file__).parent) not in sys.path:  # the sibling scripts, also when imported
    sys.path.insert(0, str(Path(__file__).parent))
from second_order import Problem, log  # noqa: E402

from particles import Simulation  # noqa: E402


def iteration_bytes(m: int, n: int) -> int:
    """Bytes one bbpgd-cuda iteration reads and writes, by its kernels' arrays (8-byte words).

    project: x0, g0 read, x1 written (3 m); moves: the incidence lists (idx, 4 coefficients) and
    the gathered gamma of 2 m entries (12 m), start, mobilities, lengths (4 n), pw written
    (4 n); gradient: i, j, the seven contact arrays, a_kk, x1, x0, g0 (14 m), two rows of pw
    (8 m), g1 written (1 m).  Scattered reads counted once (a lower bound of the traffic).
    """
    return 8 * (3 * m + 12 * m + 8 * n + 14 * m + 8 * m + m)


def timed(fn, repeats: int):
    """(median seconds, last result) of ``repeats`` calls of fn()."""
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def steps(path: Path, solver: str, threads: int, k: int) -> tuple[float, list[int]]:
    """Median seconds of k engine steps from the checkpoint with ``solver``, and iterations."""
    sim = Simulation.load(path)
    sim.config = replace(sim.config, solver=solver, threads=threads)
    times, its = [], []
    for _ in range(k):
        t0 = time.perf_counter()
        rec = sim.step()
        times.append(time.perf_counter() - t0)
        its.append(int(rec.iterations))
    return statistics.median(times), its


def main(argv: list[str] | None = None) -> list[tuple]:
    """Run the measurement (module docstring); the rows of the solve table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("checkpoint", type=Path)
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--steps", type=int, default=0, help="whole engine steps per solver")
    args = ap.parse_args(argv)
    from particles.solvers.bbpgd_cuda import solve_contacts_cuda

    pb = Problem(args.checkpoint)
    per_it = iteration_bytes(pb.m, pb.n)
    log(f"{pb.n} cells, {pb.m} contacts, dt {pb.dt:.4g}, tol {pb.tol:.3g}; "
        f"{per_it / 1e6:.1f} MB per GPU iteration")
    rows, ref = [], None
    for t in args.threads:
        numba.set_num_threads(t)
        pb.bbpgd(pb.gamma0)  # compiled and warm
        sec, (gam, hist) = timed(lambda: pb.bbpgd(pb.gamma0), args.repeats)
        ref = gam if ref is None else ref
        rows.append(("bbpgd", t, sec, len(hist) - 1, 0.0))
        log(f"bbpgd, {t} threads: {sec:.3f} s, {len(hist) - 1} iterations")

    def gpu():
        return solve_contacts_cuda(pb.c, pb.length_in, pb.dt, pb.lam, pb.gamma0, pb.tol,
                                   pb.maxiter, True, rate=pb.rate)

    gpu()  # compiles the kernels
    sec, (gam, hist) = timed(gpu, args.repeats)
    rows.append(("bbpgd-cuda", "GPU", sec, len(hist) - 1,
                 float(np.max(np.abs(gam - ref)) / max(np.max(ref), 1e-300))))
    log(f"bbpgd-cuda: {sec:.4f} s, {len(hist) - 1} iterations")
    base = next((r[2] for r in rows if r[1] == 2), rows[0][2])
    print(f"\n{pb.n} cells, {pb.m} contacts ({args.checkpoint}); one solve, median of "
          f"{args.repeats}\n")
    print("| solver | threads | s per solve | iterations | ms per iteration | GB/s (bytes by "
          "count) | vs 2 threads | max abs gamma difference / max gamma |")
    print("|---|---|---|---|---|---|---|---|")
    for name, t, sec, its, diff in rows:
        ms = 1e3 * sec / max(its, 1)
        print(f"| {name} | {t} | {sec:.4g} | {its} | {ms:.4g} | "
              f"{per_it * max(its, 1) / sec / 1e9:.3g} | {base / sec:.3g}x | {diff:.2g} |")
    if args.steps:
        t = max(args.threads)
        print(f"\nWhole engine steps from the checkpoint ({args.steps}, {t} CPU threads):\n")
        print("| solver | median s per step | iterations per step |")
        print("|---|---|---|")
        for solver in ("bbpgd", "bbpgd-cuda"):
            sec, its = steps(args.checkpoint, solver, t, args.steps)
            print(f"| {solver} | {sec:.4g} | {', '.join(map(str, its))} |")
    return rows


if __name__ == "__main__":
    main()
