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

``--phases`` (with ``--state CHECKPOINT.npz``, a run's checkpoint) instead times ``--steps``
whole steps of the run (``Simulation.step``: divisions, record and all) on ONE thread and
splits each step's CPU seconds into exclusive phases (:func:`phases`): the parallel kernels, the
serial work around them (NumPy, serial Numba) and the Python between them; it prints medians,
the Amdahl serial fraction s and the predicted speed-up 1 / (s + (1 - s) / P).  ``--gather``
takes the code paths of two or more threads while still on one (the solver's incidence lists,
problem.incidence; geometry.generalised_forces): the work of the parallel algorithm.

    NUMBA_NUM_THREADS=1 python -m cases.bench.particles --phases --state CHECKPOINT.npz
                                                        [--steps 3] [--gather]
"""

from __future__ import annotations

import argparse
import functools
import inspect
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


PARALLEL = ("BBPGD kernel", "neighbour kernel", "contact kernel", "keys, warm start: kernels",
            "solve: incidence lists: kernels",
            "forces D gamma: kernels")
"""Phases of :func:`phases` that run in parallel (Numba prange) on more than one thread; the
rest is serial there (NumPy is single-threaded, the serial Numba kernels, the Python)."""


CLOCK = time.process_time
"""The clock of :func:`phases`: the process's CPU seconds, which a shared machine's other jobs do
not inflate (run it with NUMBA_NUM_THREADS=1: no idle worker threads)."""


class _Phases:
    """Exclusive CPU seconds (CLOCK) of nested timed calls, by label (a stack of open calls)."""

    def __init__(self):
        self.seconds: dict[str, float] = {}
        self.stack: list[list[float]] = []
        self.undo: list = []

    def wrap(self, owner, name: str, label: str) -> None:
        """Time ``owner.name`` (a module's function, a class's method) under ``label``."""
        fn = getattr(owner, name)

        def timed(*args, **kwargs):
            self.stack.append([CLOCK(), 0.0])
            try:
                return fn(*args, **kwargs)
            finally:
                t0, inner = self.stack.pop()
                wall = CLOCK() - t0
                self.seconds[label] = self.seconds.get(label, 0.0) + wall - inner
                if self.stack:
                    self.stack[-1][1] += wall

        self.undo.append((owner, name, fn))
        setattr(owner, name, timed)

    def restore(self) -> None:
        for owner, name, fn in reversed(self.undo):
            setattr(owner, name, fn)
        self.undo.clear()


def _instrument(ph: _Phases, gather: bool) -> None:
    """Every phase of a step timed (monkeypatched in this process only)."""
    import particles.division as division
    import particles.geometry as geometry
    import particles.neighbours as neighbours
    import particles.simulation as simulation
    import particles.solvers as solvers
    import particles.solvers.bbpgd as bbpgd
    import particles.solvers.problem as problem
    import particles.stepping as stepping

    if gather:  # the code paths of two or more threads, on one
        ph.undo.append((bbpgd, "incidence", bbpgd.incidence))
        bbpgd.incidence = lambda c, ti, tj, n, threads=None: problem.incidence(c, ti, tj, n, 2)
        if "threads" in inspect.signature(geometry.generalised_forces).parameters:
            ph.undo.append((stepping, "generalised_forces", stepping.generalised_forces))
            stepping.generalised_forces = functools.partial(geometry.generalised_forces,
                                                            threads=2)
    for owner, name, label in (
            (simulation.Simulation, "step", "Python between kernels"),
            (simulation, "robust_step", "Python between kernels"),
            (stepping, "step", "Python between kernels"),
            (stepping, "detect", "Python between kernels"),
            (simulation, "next_dt", "Python between kernels"),
            (division, "divide", "division"),
            (division, "spatial_order", "spatial order (argsort)"),
            (simulation.ParticleState, "permute", "permute arrays"),
            (simulation.ParticleState, "enclosing_radius", "enclosing radius (record)"),
            (simulation.ParticleState, "hull_radius", "hull radius (record)"),
            (simulation, "strain_columns", "Python between kernels"),
            (stepping.Detections, "get", "detection cache"),
            (stepping.Detections, "put", "detection cache"),
            (stepping, "candidate_pairs", "neighbour checks (NumPy)"),
            (neighbours, "_cell_pairs", "neighbour kernel"),
            (stepping, "find_contacts", "contact checks (NumPy)"),
            (geometry, "_contacts_kernel", "contact kernel"),
            (geometry.Contacts, "keys", "keys, warm start (NumPy)"),
            (stepping, "warm_start", "keys, warm start (NumPy)"),
            (stepping, "growth_law", "Python between kernels"),
            (stepping, "axial_stress", "stress, move, grow (NumPy)"),
            (stepping, "generalised_forces", "forces D gamma (NumPy)"),
            (geometry, "by_particle", "forces D gamma: kernels"),
            (geometry, "_forces", "forces D gamma: kernels"),
            (stepping, "grow", "stress, move, grow (NumPy)"),
            (stepping, "motion", "stress, move, grow (NumPy)"),
            (bbpgd, "prepare", "solve: prepare (NumPy)"),
            (bbpgd, "incidence", "solve: incidence lists: kernels"),
            (bbpgd, "_bbpgd", "BBPGD kernel"),
            (bbpgd, "finish", "solve: prepare (NumPy)"),
            (geometry, "_canonical_keys_of", "keys, warm start: kernels"),
            (stepping, "_lookup", "keys, warm start: kernels"),
            (geometry, "_short_in_pairs", "contact kernel")):
        if hasattr(owner, name):  # the kernels of issue 44 (absent before it)
            ph.wrap(owner, name, label)
    ph.wrap(_DictSlot(solvers.BY_NAME, "bbpgd"), "value", "Python between kernels")


class _DictSlot:
    """One entry of a dict as the attribute ``value`` (for :meth:`_Phases.wrap`)."""

    def __init__(self, d: dict, key: str):
        self.d, self.key = d, key

    @property
    def value(self):
        return self.d[self.key]

    @value.setter
    def value(self, v) -> None:
        self.d[self.key] = v


def _cell_sort_seconds(state: ParticleState, margin: float) -> float:
    """CPU seconds of the neighbour search's serial part (neighbours._cell_sort), alone."""
    from particles.neighbours import _cell_sort

    h = float(state.length.max()) + margin
    _cell_sort(state.x, state.y, h)
    t0 = CLOCK()
    _cell_sort(state.x, state.y, h)
    return CLOCK() - t0


def phases(path: Path, steps: int, gather: bool) -> dict:
    """Medians over ``steps`` steps (one thread) of each phase's exclusive CPU seconds per step.

    From the run's checkpoint ``path`` (Simulation.load; no output folder: a run's frame every
    ``output_every`` steps and checkpoint every ``checkpoint_seconds`` are not in it).
    Phases in PARALLEL run in parallel on more threads; the others are serial there.
    """
    import numba

    from particles.simulation import Simulation

    sim = Simulation.load(path)
    sim.config = replace(sim.config, threads=1)
    numba.set_num_threads(1)
    n0 = sim.state.n
    sim.step()  # compile, warm the caches (not counted)
    rows = []
    ph = _Phases()
    _instrument(ph, gather)
    try:
        for _ in range(steps):
            ph.seconds = {}
            t0, c0 = time.perf_counter(), CLOCK()
            rec = sim.step()
            wall, cpu = time.perf_counter() - t0, CLOCK() - c0
            rows.append({"wall": wall, "cpu": cpu, "iterations": rec.iterations,
                         "contacts": rec.n_contacts, **ph.seconds})
            print(f"N={rec.n_particles} wall {wall:.3f} s, CPU {cpu:.3f} s, {rec.iterations} "
                  "iterations", flush=True)
    finally:
        ph.restore()
    labels = sorted({k for r in rows for k in r} - {"wall", "cpu", "iterations", "contacts"})
    med = {k: float(np.median([r.get(k, 0.0) for r in rows])) for k in
           ["wall", "cpu", "iterations", "contacts", *labels]}
    med["cell sort (serial part of neighbour kernel, once)"] = _cell_sort_seconds(
        sim.state, sim.config.contact_margin)
    med["N"] = n0
    return med


def _phase_table(med: dict, gather: bool) -> None:
    labels = [k for k in med if k not in ("wall", "cpu", "iterations", "contacts", "N")
              and not k.startswith("cell sort")]
    total = sum(med[k] for k in labels)
    labels.sort(key=lambda k: -med[k])
    print(f"\nN={med['N']}, {med['iterations']:.0f} iterations, {med['contacts']:.0f} contacts,"
          f" one thread, {'gather' if gather else 'scatter'} path; medians per step of CPU "
          f"seconds, sum of phases {total:.3f} s (step CPU {med['cpu']:.3f} s, wall "
          f"{med['wall']:.3f} s)")
    print(A.markdown_rows(("phase", "on P threads", "s/step", "share"),
                          ((k, "parallel" if k in PARALLEL else "serial", f"{med[k]:.4f}",
                            f"{100 * med[k] / total:.2f}%") for k in labels)))
    serial = sum(med[k] for k in labels if k not in PARALLEL)
    s = serial / total
    print(f"serial fraction s = {100 * s:.2f}% (the neighbour kernel's serial cell sort, "
          f"{med['cell sort (serial part of neighbour kernel, once)']:.4f} s per detection, "
          "counted parallel)")
    print("predicted S(P) = 1/(s + (1-s)/P): " + ", ".join(
        f"P={p}: {1 / (s + (1 - s) / p):.2f}" for p in (2, 4, 8, 16, 32)))


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
    ap.add_argument("--phases", action="store_true",
                    help="split whole steps from each --state checkpoint into phases, one "
                         "thread (module docstring)")
    ap.add_argument("--gather", action="store_true",
                    help="with --phases: the solver's multi-thread path (incidence lists)")
    a = ap.parse_args(argv)
    for path in a.state:
        if not path.is_file():
            ap.error(f"state file not found: {path}")
    if a.phases:
        out = {}
        for path in a.state:
            med = phases(path, a.steps, a.gather)
            _phase_table(med, a.gather)
            out[str(path)] = [med]
        return out
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
