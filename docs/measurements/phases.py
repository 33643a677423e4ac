"""The serial fraction of a particle step: its CPU seconds split into phases (issue 44, part 2).

From a run's checkpoint (``--state CHECKPOINT.npz``) this times ``--steps`` whole steps of the run
(``Simulation.step``: divisions, record and all) on ONE thread and splits each step's CPU seconds
into exclusive phases (:func:`phases`): the parallel kernels, the serial work around them (NumPy,
serial Numba) and the Python between them; it prints medians, the Amdahl serial fraction s and
the predicted speed-up 1 / (s + (1 - s) / P).  ``--gather`` takes the code paths of two or more
threads while still on one (the solver's incidence lists, problem.incidence;
geometry.generalised_forces): the work of the parallel algorithm.

    NUMBA_NUM_THREADS=1 python docs/measurements/phases.py --state CHECKPOINT.npz [--steps 3]
                                                          [--gather]

Lived in ``cases.bench.particles`` (``--phases``) until issue 43 moved it here; the tables it
made are in docs/benchmarks.md ("Where a step's time goes").
"""

from __future__ import annotations

import argparse
import functools
import inspect
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from cases import analysis as A
from particles.state import ParticleState

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


def main(argv: list[str] | None = None) -> dict[str, dict]:
    """Command line (module docstring): the medians of each checkpoint, by its path."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--state", type=Path, action="append", required=True,
                    help="a run's checkpoint.npz (repeatable)")
    ap.add_argument("--steps", type=int, default=3)
    ap.add_argument("--gather", action="store_true",
                    help="the solver's multi-thread path (incidence lists), on one thread")
    a = ap.parse_args(argv)
    for path in a.state:
        if not path.is_file():
            ap.error(f"checkpoint not found: {path}")
    out = {}
    for path in a.state:
        med = phases(path, a.steps, a.gather)
        _phase_table(med, a.gather)
        out[str(path)] = med
    return out


if __name__ == "__main__":
    main()
