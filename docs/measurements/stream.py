"""Memory bandwidth on 1..P threads: the STREAM triad a = b + s c in Numba (issue 44, part 2).

The contact solve at 1e5 cells is bound by memory bandwidth (docs/benchmarks.md, "Memory
bandwidth, not Amdahl"), so its speed-up on P threads is at most B(P), the triad's bandwidth on
P threads over one thread's. This measures B(P) with the same compiler and threading layer as
the engine: three float64 arrays of ``--mb`` MB each (far beyond the caches), the triad in a
``prange`` loop, the best of ``--repeats`` passes per thread count (as STREAM reports), and the
bytes counted as STREAM counts them (24 per element: two reads, one write).

    python docs/measurements/stream.py --threads 1 2 [16] [--mb 400] [--repeats 20]

Prints one markdown row per thread count: GB/s and B(P).
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np
from numba import njit, prange


@njit(parallel=True)  # no cache: the tests load this file under another module name
def triad(a, b, c, s):
    """The triad a = b + s c, element by element, in parallel."""
    for i in prange(a.shape[0]):
        a[i] = b[i] + s * c[i]


def bandwidth(n: int, threads: int, repeats: int) -> float:
    """The best triad bandwidth (bytes/s) of ``repeats`` passes on ``threads`` threads."""
    numba.set_num_threads(threads)
    a, b, c = np.zeros(n), np.ones(n), np.full(n, 2.0)
    triad(a, b, c, 3.0)  # compile and touch every page
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        triad(a, b, c, 3.0)
        best = min(best, time.perf_counter() - t0)
    return 24 * n / best


def main(argv: list[str] | None = None) -> list[tuple[int, float]]:
    """Command line: the triad's bandwidth per thread count, as a markdown table."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--threads", type=int, nargs="+", default=[1, numba.config.NUMBA_NUM_THREADS])
    ap.add_argument("--mb", type=float, default=400.0, help="MB per array (default 400)")
    ap.add_argument("--repeats", type=int, default=20)
    args = ap.parse_args(argv)
    n = int(args.mb * 1e6 / 8)
    rows = [(p, bandwidth(n, p, args.repeats)) for p in args.threads]
    print("| threads | triad GB/s | B(P) |\n|---|---|---|")
    for p, bw in rows:
        print(f"| {p} | {bw / 1e9:.1f} | {bw / rows[0][1]:.2f} |")
    return rows


if __name__ == "__main__":
    main()
