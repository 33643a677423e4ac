"""Benchmark of the particle engine's threads: wall time per step on one and two threads.

The contact solver's loops are Numba ``prange`` loops, and the iterates are the same on any
number of threads (docs/DESIGN.md), so the threads are an execution setting only.  Whether a
second thread pays depends on the colony's size (the per-iteration work against the cost of
starting a parallel region) and on whether the second core is free.

From each saved state of ``--checkpoint`` (a run's checkpoint.npz), the same ``--steps`` steps
are taken ``--repeats`` times on each thread count of ``--threads``, alternating, and the
table reports the median wall seconds per step and the ratio to one thread.  With ``--busy``
a second process keeps the other core busy (a second run beside this one), which is the
situation of two runs side by side.

Command line::

    python -m cases.bench.threads --checkpoint CK.npz [CK.npz ...] [--steps 5] [--repeats 3]
                                  [--threads 1 2] [--busy] [--out runs/bench_threads.csv]
"""

from __future__ import annotations

import argparse
import csv
import multiprocessing as mp
import statistics
import time
from pathlib import Path

import numba

from cases import analysis as A
from particles import Simulation
from particles.checkpoint import checkpoint_config, load_checkpoint

COLUMNS = ("checkpoint", "n_particles", "threads", "busy", "steps", "seconds_per_step",
           "ratio_to_one_thread")


def _spin(stop) -> None:
    """Keep one core busy until ``stop`` is set."""
    x = 0
    while not stop.is_set():
        for _ in range(100_000):
            x += 1


def time_steps(path: Path, threads: int, steps: int) -> float:
    """Wall seconds per step of ``steps`` steps from the state saved at ``path``."""
    config = checkpoint_config(path)
    config.threads = threads
    state, history, _ = load_checkpoint(path, config)
    sim = Simulation(config, state=state)
    t0 = time.perf_counter()
    for _ in range(steps):
        sim.step()
    return (time.perf_counter() - t0) / steps


def measure(path: Path, thread_counts: list[int], steps: int, repeats: int,
            busy: bool) -> list[dict]:
    """Median seconds per step per thread count (alternating repeats) and ratios."""
    seconds = {k: [] for k in thread_counts}
    for _ in range(repeats):
        for k in thread_counts:
            seconds[k].append(time_steps(path, k, steps))
    n = load_checkpoint(path, checkpoint_config(path))[0].n
    base = statistics.median(seconds[thread_counts[0]])
    return [{"checkpoint": str(path), "n_particles": n, "threads": k, "busy": busy,
             "steps": steps, "seconds_per_step": statistics.median(seconds[k]),
             "ratio_to_one_thread": statistics.median(seconds[k]) / base}
            for k in thread_counts]


def main(argv: list[str] | None = None) -> list[dict]:
    """Command line (module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--checkpoint", type=Path, nargs="+", required=True)
    ap.add_argument("--steps", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--busy", action="store_true", help="keep the other core busy")
    ap.add_argument("--out", type=Path, default=Path("runs/bench_threads.csv"))
    a = ap.parse_args(argv)
    missing = [str(p) for p in a.checkpoint if not p.is_file()]
    if missing:
        ap.error(f"no checkpoint file {', '.join(missing)}")
    if a.steps < 1 or a.repeats < 1:
        ap.error("--steps and --repeats must be >= 1")
    bad = [k for k in a.threads if not 1 <= k <= numba.config.NUMBA_NUM_THREADS]
    if bad:
        ap.error(f"--threads must be in [1, {numba.config.NUMBA_NUM_THREADS}], got {bad}")
    stop = mp.Event()
    spinner = mp.Process(target=_spin, args=(stop,), daemon=True) if a.busy else None
    if spinner is not None:
        spinner.start()
    try:
        for k in a.threads:  # compile the kernels (serial and parallel) outside the timings
            time_steps(a.checkpoint[0], k, 1)
        rows = [r for p in a.checkpoint for r in measure(p, a.threads, a.steps, a.repeats,
                                                         a.busy)]
    finally:
        if spinner is not None:
            stop.set()
            spinner.join()
    a.out.parent.mkdir(parents=True, exist_ok=True)
    with open(a.out, "w", newline="") as f:
        w = csv.DictWriter(f, COLUMNS)
        w.writeheader()
        w.writerows(rows)
    print(A.markdown_rows(
        ("N", "threads", "other core busy", "s per step", "ratio to 1 thread"),
        ((r["n_particles"], r["threads"], "yes" if r["busy"] else "no",
          f"{r['seconds_per_step']:.3g}", f"{r['ratio_to_one_thread']:.2f}") for r in rows)))
    return rows


if __name__ == "__main__":
    main()
