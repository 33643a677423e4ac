"""Benchmark of the particle engine: cost per step against colony size, for each contact solver.

Grows one colony at lam = 1e-2 from one cell and saves its state (npz, not committed) when it
first reaches each target size N (default 1e3, 1e4; larger sizes continue from the largest
saved state instead of regrowing).  ``--state FILE.csv`` adds colonies written by ``colony
particles`` (``particles.csv``: x, y, theta, length), e.g. the ~1e5-particle colony of a radius-150
run, which is far cheaper to reuse than to regrow; such a state starts with zero loads and
no warm start, so its first step is a cold solve (the medians hide it).

From each state every solver of ``--solvers`` (default bbpgd and apgd: the same states, the same
tolerance) times ``--steps`` steps of ``particles.stepping.step`` and reports medians of
seconds per step, solver iterations per step (re-solve passes included), contacts, the split of
the time between neighbour search, geometry, solver and update, and the exponents fitted to them
(np.polyfit of log y against log N).  ``--threads 1 2`` repeats every measurement on each
number of Numba threads (``particles.Config.threads``; the iterates do not depend on it, so the
iteration counts must agree) and reports the speed-up.  ``--alternate K`` measures instead
each number of threads K times, alternating, every measurement in a fresh process, and reports
medians and ranges: on a shared virtual machine the speed-up of a second thread differs from
process to process (README, "Threads").

    python -m cases.bench.particles [--sizes 1000 10000] [--state particles.csv]
                                    [--solvers bbpgd apgd] [--steps 10] [--threads 1 2]
                                    [--alternate K]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from cases import analysis as A
from particles.config import SOLVERS, Config
from particles.division import divide
from particles.output import read_init
from particles.state import ParticleState
from particles.stepping import step

DEFAULT_FOLDER = Path("runs/bench_particles")


def _save(path: Path, state: ParticleState, t: float, warm, rng) -> None:
    np.savez(path, warm_keys=warm[0], warm_gamma=warm[1], t=t, next_id=state.next_id,
             rng=json.dumps(rng.bit_generator.state), **state.arrays())


def load_state(path: Path):
    """(state, t, warm, rng) of a saved state, a run's checkpoint or a ``particles.csv`` colony.

    Saved states are :func:`grow_states`'; a run's ``checkpoint.npz`` (e.g. a paper colony's,
    ``colony particles``) gives its state warm-started as the run would resume it.
    """
    if path.suffix == ".csv":
        state = ParticleState.from_arrays(*read_init(path))
        return state, 0.0, (np.zeros(0, dtype=np.int64), np.zeros(0)), np.random.default_rng(0)
    with np.load(path) as z:
        meta = json.loads(str(z["meta"])) if "meta" in z.files else {}  # a run's checkpoint
        st = ParticleState(z["x"], z["y"], z["theta"], z["length"], z["stress"], z["ids"],
                           int(meta["next_id"] if meta else z["next_id"]))
        warm = (z["warm_keys"], z["warm_gamma"])
        rng = np.random.default_rng()
        rng.bit_generator.state = meta["rng"] if meta else json.loads(str(z["rng"]))
        return st, float(meta["t"] if meta else z["t"]), warm, rng


FIXED_DT = 0.01
"""The step of these measurements (fixed; the engine's default before the "overlap" step
control), with which the tables of docs/benchmarks.md were measured."""


def grow_states(config: Config, sizes: list[int], folder: Path) -> list[Path]:
    """Saved states of one colony at the first step where N >= each size (reusing saved ones)."""
    folder.mkdir(parents=True, exist_ok=True)
    tag = f"lam{config.lam:g}_dt{config.dt:g}_seed{config.seed}"
    paths = [folder / f"state_{tag}_N{n}.npz" for n in sizes]
    have = [p.exists() for p in paths]
    if all(have):
        return paths
    start = max((k for k in range(len(sizes)) if have[k]), default=-1)
    if start >= 0:
        state, t, warm, rng = load_state(paths[start])
    else:
        state = ParticleState.from_arrays([0.0], [0.0], [0.0], [1.0])
        t, warm = 0.0, (np.zeros(0, dtype=np.int64), np.zeros(0))
        rng = np.random.default_rng(config.seed)
    t0 = time.perf_counter()
    for k in range(start + 1, len(sizes)):
        while state.n < sizes[k]:
            _, warm = step(state, config, config.dt, warm)
            divide(state, rng, config.division_noise)
            t += config.dt
        _save(paths[k], state, t, warm, rng)
        print(f"grown N={state.n} t={t:.2f} R={state.enclosing_radius():.1f} "
              f"({time.perf_counter() - t0:.0f} s so far)", flush=True)
    return paths


def measure(path: Path, config: Config, steps: int) -> dict:
    """Median cost per step over ``steps`` steps from a saved state."""
    state, t, warm, rng = load_state(path)
    n0 = state.n
    rows = []
    for _ in range(steps):
        timers: dict = {}
        t0 = time.perf_counter()
        info, warm = step(state, config, config.dt, warm, timers)
        wall = time.perf_counter() - t0
        divide(state, rng, config.division_noise)
        rows.append({"seconds": wall, "iterations": info["iterations"],
                     "contacts": info["n_contacts"], "passes": info["passes"], **timers})
    med = {k: float(np.median([r.get(k, 0.0) for r in rows]))
           for k in ("seconds", "iterations", "contacts", "passes", "neighbours", "geometry",
                     "solver", "update")}
    tot = sum(med[k] for k in ("neighbours", "geometry", "solver", "update"))
    for k in ("neighbours", "geometry", "solver", "update"):
        med[k + "_frac"] = med[k] / tot if tot > 0 else 0.0
    med["N"] = n0
    med["ns_per_contact_iteration"] = 1e9 * med["solver"] / max(1.0, med["contacts"]
                                                                 * max(1.0, med["iterations"]))
    return med


def fit_exponent(ns, ys) -> float:
    """Slope of log y against log N."""
    return float(np.polyfit(np.log(ns), np.log(ys), 1)[0])


def _table(res: list[dict]) -> None:
    print(A.markdown_rows(
        ("N", "contacts", "iterations/step", "s/step", "ns/(contact*it)", "neighbours",
         "geometry", "solver", "update"),
        ((r["N"], f"{r['contacts']:.0f}", f"{r['iterations']:.0f}", f"{r['seconds']:.4f}",
          f"{r['ns_per_contact_iteration']:.1f}", f"{100 * r['neighbours_frac']:.1f}%",
          f"{100 * r['geometry_frac']:.1f}%", f"{100 * r['solver_frac']:.1f}%",
          f"{100 * r['update_frac']:.1f}%") for r in res)))
    ns = [r["N"] for r in res]
    if len(set(ns)) >= 2:
        print("fitted exponents vs N: " + ", ".join(
            f"{k} {fit_exponent(ns, [max(r[k], 1e-12) for r in res]):.2f}"
            for k in ("contacts", "iterations", "seconds", "neighbours", "geometry")))


def alternate(argv: list[str], threads: list[int], repeats: int, folder: Path) -> dict:
    """{threads: {N: [seconds per step of each repetition]}} of the first solver.

    Each measurement is a fresh ``python -m cases.bench.particles ARGV --threads T`` process,
    the numbers of threads alternating.
    """
    secs: dict = {t: {} for t in threads}
    for rep in range(repeats):
        for t in threads:
            sub = folder / f"alternate_t{t}"
            sub.mkdir(parents=True, exist_ok=True)
            for f in folder.glob("state_*.npz"):  # the grown states, shared
                if not (sub / f.name).exists():
                    (sub / f.name).symlink_to(f.resolve())
            subprocess.run([sys.executable, "-m", "cases.bench.particles", *argv, "--threads",
                            str(t), "--folder", str(sub)], check=True, stdout=subprocess.DEVNULL)
            for r in json.loads(next(sub.glob("bench_*.json")).read_text()):
                secs[t].setdefault(r["N"], []).append(r["seconds"])
            print(f"repetition {rep + 1}, {t} thread(s): " + ", ".join(
                f"N={n}: {v[-1]:.4g} s" for n, v in secs[t].items()), flush=True)
    ref = threads[0]
    print(f"\n| N | {' | '.join(f'{t} thread(s)' for t in threads)} | speed-up |")
    print("|---|" + "---|" * (len(threads) + 1))
    for n in secs[ref]:
        med = [float(np.median(secs[t][n])) for t in threads]
        print(f"| {n} | " + " | ".join(
            f"{m:.4g} ({min(secs[t][n]):.4g}-{max(secs[t][n]):.4g})"
            for m, t in zip(med, threads, strict=True))
            + " | " + ", ".join(f"{med[0] / m:.2f}" for m in med[1:]) + " |")
    return secs


def main(argv: list[str] | None = None) -> dict[str, list[dict]]:
    """Command line (module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[1000, 10000])
    ap.add_argument("--state", type=Path, action="append", default=[],
                    help="a colony CSV (x, y, theta, length) to measure as well (repeatable)")
    ap.add_argument("--lam", type=float, default=1e-2)
    ap.add_argument("--dt", type=float, default=None)
    ap.add_argument("--solvers", nargs="+", default=["bbpgd", "apgd"], choices=sorted(SOLVERS))
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--threads", type=int, nargs="+", default=[1],
                    help="numbers of Numba threads to measure (default 1)")
    ap.add_argument("--alternate", type=int, default=0, metavar="K",
                    help="K alternating repetitions per number of threads, each a fresh process")
    ap.add_argument("--folder", type=Path, default=DEFAULT_FOLDER)
    a = ap.parse_args(argv)
    for path in a.state:
        if not path.is_file():
            ap.error(f"state file not found: {path}")
    base = Config(lam=a.lam, time=1e9, dt=FIXED_DT if a.dt is None else a.dt,
                  step_control="fixed")
    paths = grow_states(base, sorted(a.sizes), a.folder) + list(a.state)
    if a.alternate > 0:
        forward = ["--sizes", *map(str, a.sizes), "--lam", str(a.lam), "--solvers",
                   a.solvers[0], "--steps", str(a.steps)]
        forward += [x for p in a.state for x in ("--state", str(p))]
        forward += ["--dt", str(a.dt)] if a.dt is not None else []
        return alternate(forward, a.threads, a.alternate, a.folder)
    results = {}
    for solver in a.solvers:
        for threads in a.threads:
            cfg = replace(base, solver=solver, threads=threads)
            res = sorted((measure(p, cfg, a.steps) for p in paths), key=lambda r: r["N"])
            print(f"\nsolver={solver} threads={threads} lam={a.lam:g} dt={cfg.dt:g} "
                  f"tol={cfg.tol:g} (medians over {a.steps} steps)", flush=True)
            _table(res)
            key = solver if threads == a.threads[0] else f"{solver}@{threads}"
            results[key] = res
            out = a.folder / f"bench_{key}_lam{a.lam:g}.json"
            out.write_text(json.dumps(res, indent=1))
        for threads in a.threads[1:]:
            _ratios(f"{solver}: {threads} threads / {a.threads[0]} (same states)",
                    results[solver], results[f"{solver}@{threads}"])
    ref, *others = a.solvers
    for other in others:
        _ratios(f"{other} / {ref} (same states, same tolerance)", results[ref], results[other])
    return results


def _ratios(label: str, ref: list[dict], other: list[dict]) -> None:
    """Print iterations and seconds of ``other`` over ``ref``, state by state."""
    print(f"\n{label}: " + ", ".join(
        f"N={r['N']}: iterations {o['iterations'] / r['iterations']:.2f}, "
        f"seconds {o['seconds'] / r['seconds']:.2f}" for r, o in zip(ref, other, strict=True)))


if __name__ == "__main__":
    main()
