"""What one BBPGD iteration costs against the machine's memory bandwidth, and in single precision.

Issue 33 (goal 2) asks whether the contact solver's iteration is limited by memory traffic and
whether single precision pays where the tolerance allows.  From a particle run's checkpoint
(``--checkpoint``) the script poses the main contact problem of the run's next step, as the
engine would (``cases.bench.warm_start.main_problem``), and measures:

- **stream**: the machine's sustained bandwidth, a STREAM triad ``a = b + s c`` in Numba on
  arrays of ``--stream-mb`` MB each (3 x 8 bytes moved per element), best of 5;
- **bytes**: the bytes one iteration moves (:func:`bytes_per_iteration`: every contact array
  an iteration reads or writes, counted from the kernels of particles/solvers/bbpgd.py, plus
  the particle rows), hence the bandwidth an iteration reaches, against stream;
- **precision**: the same solver kernels (``bbpgd._bbpgd``, compiled for the arrays' types)
  with the contact geometry (normals, arms, load factors, gaps, a_kk) in float32 and the
  particle indices in int32, the forces, gradients and sums staying in float64 (and each
  change alone: VARIANTS).  Rounding the
  geometry to float32 moves each gap by about 6e-8 of its terms (dt a gamma <= 10 at paper
  scale: < 1e-6, against the tolerance 1e-3), so the solve is the same problem within the
  tolerance.  Reported: iterations to the run's tolerance from the engine's warm start, the
  float32 solution's residual in the float64 problem (it must be <= the tolerance, up to the
  rounding), and seconds per iteration over
  ``--iterations`` iterations (tolerance 0), alternating the variants ``--repeats``
  times in one process.

Seconds are medians over the repeats; compare only within one run of the script, and run it on
an otherwise idle machine (pause other runs with SIGSTOP).

    python -m cases.bench.iteration_cost --checkpoint RUN.partial/checkpoint.npz
           [--threads 1] [--iterations 300] [--repeats 5] [--stream-mb 256]
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np
from numba import njit, prange

from particles.simulation import Simulation
from particles.solvers import bbpgd
from particles.solvers.problem import incidence, linearised_gap, prepare

from .warm_start import main_problem

STREAM_REPEATS = 5


@njit(cache=True, parallel=True)
def _triad(a, b, c, s):
    for k in prange(a.shape[0]):
        a[k] = b[k] + s * c[k]


def stream_bandwidth(megabytes: float) -> float:
    """Sustained memory bandwidth in GB/s: best of 5 STREAM triads a = b + s c (24 B/element)."""
    n = int(megabytes * 2**20 / 8)
    a, b, c = np.zeros(n), np.ones(n), np.full(n, 2.0)
    _triad(a, b, c, 3.0)
    best = np.inf
    for _ in range(STREAM_REPEATS):
        t0 = time.perf_counter()
        _triad(a, b, c, 3.0)
        best = min(best, time.perf_counter() - t0)
    return 24 * n / best / 1e9


VARIANTS = {"float64": (False, False), "float32": (True, True),
            "float64, int32 ids": (True, False), "float32, int64 ids": (False, True)}
"""Array types measured: (indices in int32, geometry in float32).  "float32" is both."""


def kernel_arrays(problem, gamma0, small_ids: bool, single: bool):
    """The arguments of ``bbpgd._bbpgd`` for ``problem``: int32 ids, float32 geometry if asked.

    Returns (gamma, args after gamma up to ``tol``), the arrays in the kernels' order.
    """
    c, length, dt, lam, _ = problem
    length, gam, (mt, mr, ti, tj, akk), law = prepare(c, length, dt, lam, gamma0)
    start, idx, coef = incidence(c, ti, tj, length.shape[0])
    ids = [c.i, c.j]
    geometry = [c.nx, c.ny, ti, tj, c.gi, c.gj, c.gap, akk]
    if small_ids:
        ids = [np.ascontiguousarray(a, dtype=np.int32) for a in ids]
    if single:
        geometry = [np.ascontiguousarray(a, dtype=np.float32) for a in geometry]
    return gam, (start, idx, coef, *ids, *geometry[:7], mt, mr, length, float(dt), law, True,
                 geometry[7])


def bytes_per_iteration(m: int, n: int, small_ids: bool, single: bool) -> int:
    """Bytes one BBPGD iteration moves on one thread (the scatter path of problem.py).

    Per contact: the projected step reads gamma and its gradient and writes the step (3 x 8);
    the force scatter reads the step, i, j and six geometry numbers (n, t_i, t_j, G_i, G_j);
    the gap pass reads i, j, the six, Phi, a_kk, the step, gamma and the old gradient and
    writes the new gradient.  Per particle: the (N, 4) sums written twice (zeroed, summed) and
    read twice (moves, gaps), and mt, mr, l read once.  Indices 8 or 4 bytes, geometry 8 or 4.
    """
    ind, geo = 4 if small_ids else 8, 4 if single else 8
    step = 3 * 8
    scatter = 8 + 2 * ind + 6 * geo
    gaps = 2 * ind + 6 * geo + 2 * geo + 3 * 8 + 8
    return m * (step + scatter + gaps) + n * (4 * 32 + 3 * 8)


def _solve(gam, args, tol, maxiter):
    hist = np.full(maxiter + 1, np.nan)
    g = gam.copy()
    t0 = time.perf_counter()
    it = bbpgd._bbpgd(g, *args, float(tol), int(maxiter), hist)
    return g, it, time.perf_counter() - t0


def measure(problem, gamma0, iterations: int, repeats: int) -> dict:
    """Iterations to tolerance and seconds per iteration of each of VARIANTS, alternated.

    Also the float32 solution's residual in the float64 problem.
    """
    c, length, dt, lam, tol = problem
    out = {"contacts": len(c), "particles": int(length.shape[0])}
    runs = {p: kernel_arrays(problem, gamma0, *VARIANTS[p]) for p in VARIANTS}
    for p, (gam, args) in runs.items():
        g, out[f"{p} iterations"], _ = _solve(gam, args, tol, 10**6)
        if p == "float32":
            q = linearised_gap(c, length, dt, lam, g)
            akk = runs["float64"][1][-1]
            out["float32 residual in float64"] = float(np.max(np.abs(np.minimum(akk * g, q))))
    seconds = {p: [] for p in runs}
    for _ in range(repeats):
        for p, (gam, args) in runs.items():
            seconds[p].append(_solve(gam, args, 0.0, iterations)[2] / iterations)
    for p in runs:
        out[f"{p} s/iteration"] = float(np.median(seconds[p]))
        out[f"{p} bytes/iteration"] = bytes_per_iteration(len(c), out["particles"], *VARIANTS[p])
    return out


def main(argv: list[str] | None = None) -> dict:
    """Run the measurements of the module docstring; returns them as a dict."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--checkpoint", required=True, help="a particle run's checkpoint.npz")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--iterations", type=int, default=300)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--stream-mb", type=float, default=256.0)
    args = ap.parse_args(argv)
    for name in ("threads", "iterations", "repeats"):
        if getattr(args, name) < 1:
            ap.error(f"--{name} must be >= 1, got {getattr(args, name)}")
    if not 0 < args.stream_mb <= 4096:
        ap.error(f"--stream-mb must be in (0, 4096], got {args.stream_mb}")
    numba.set_num_threads(args.threads)
    problem, matched, _ = main_problem(Simulation.load(args.checkpoint))
    out = measure(problem, matched, args.iterations, args.repeats)
    out["stream GB/s"] = stream_bandwidth(args.stream_mb)
    print(f"N = {out['particles']}, contacts {out['contacts']}, {args.threads} thread(s); "
          f"stream triad {out['stream GB/s']:.1f} GB/s")
    print("| arrays | iterations to tol | s/iteration (median) | bytes/iteration | GB/s | "
          "share of stream |")
    print("|---|---|---|---|---|---|")
    for p in VARIANTS:
        s, b = out[f"{p} s/iteration"], out[f"{p} bytes/iteration"]
        print(f"| {p} | {out[f'{p} iterations']} | {s * 1e3:.3f} ms | {b / 1e6:.1f} MB | "
              f"{b / s / 1e9:.1f} | {b / s / 1e9 / out['stream GB/s']:.2f} |")
    print(f"float32 / float64 seconds per iteration: "
          f"{out['float32 s/iteration'] / out['float64 s/iteration']:.3f}; the float32 "
          f"solution's residual in float64 {out['float32 residual in float64']:.3e} "
          f"(tolerance {problem[4]:g})")
    return out


if __name__ == "__main__":
    main()
