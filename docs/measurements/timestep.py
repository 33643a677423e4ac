"""Benchmark of the particle time step: whole runs to a radius, per lam and step policy.

The main contact solve costs about the same in total whatever dt (its iterations scale with
dt), while the re-detection passes that remove the overlaps left by the linearised step grow
from a few percent of it to more than all of it once dt is too long for the colony's speeds,
which grow as lam falls.  For each lam of ``--lams`` and each policy of ``--policies``
(``CONTROL:DT[:TARGET]`` with CONTROL = fixed, overlap or cost, DT the largest step, TARGET
the overlap control's target in place of stepping.MAIN_OVERLAP; see particles.stepping.next_dt)
one colony is grown from one cell to ``--radius`` and the table reports CPU seconds, steps, the
solver iterations of the main solves, of the passes and of failed attempts (redone as half
steps), and t at the radius (the result, which the step must not change beyond its first-order
error).
``--uncapped`` lifts the cap on a pass's iterations (PASS_ITERATION_FLOOR = max_iterations),
which is how the engine ran before the cap, to measure what the cap saves.

``--checkpoint FILE`` measures the policies on a saved state instead (a run's checkpoint.npz,
e.g. a paper-scale colony): from it, each policy advances the colony by ``--duration`` time
units (divisions included, the run's other settings kept; an adaptive policy starts from the
run's last step) and the table reports the solver
iterations per unit time (main, passes, failed attempts), the halved steps and the rotation of
the particles in one step (largest and 99.9 % quantile: beyond ~0.1 rad the linearised contacts
no longer hold and the passes meet crossed rods).

Command line (from the repository root, the package installed)::

    python docs/measurements/timestep.py [--radius 40] [--lams 1e-2 1e-3 1e-4 0]
        [--policies fixed:0.005 fixed:0.01 fixed:0.02 overlap:0.01]
        [--uncapped] [--out runs/bench_timestep.csv]
    python docs/measurements/timestep.py --checkpoint RUN/checkpoint.npz [--duration 0.02]
        [--policies fixed:0.005 fixed:0.0025]
    python docs/measurements/timestep.py --history RUN [RUN ...] [--min-particles 6e4]
        [--sizes 1e4 2e4 4e4 6e4] [--logs LOG [LOG ...]]

``--history`` reads what whole runs did instead (no computation): per step-policy segment of
each run folder (config.json's ``step_policy_changes``), restricted to N >= ``--min-particles``,
the steps, dt range, halved steps and solver iterations per unit time, failed attempts
included; ``--sizes`` cuts each segment further into stretches of the colony's size (N below
the first size, between two, above the last), and ``--logs`` (a ``colony particles`` stderr
log per run, in the same order) adds each stretch's wall time and wall milliseconds per solver
iteration (``cases.analysis.progress_wall``).

CPU time (time.process_time) is reported because the engine is single-threaded and this
machine is often shared; wall time is in the CSV too.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import math
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

import particles.division as division
import particles.stepping as stepping
from cases import analysis as A
from particles import Config, run
from particles.checkpoint import load_checkpoint
from particles.config import SOLVERS, STEP_CONTROLS
from particles.neighbours import spatial_order

COLUMNS = ("lam", "policy", "uncapped", "cpu_s", "wall_s", "steps", "halved", "main_iterations",
           "pass_iterations", "failed_iterations", "t_at_radius", "n_particles")
CHECKPOINT_COLUMNS = ("checkpoint", "lam", "policy", "solver", "solver_tol", "threads", "reorder",
                      "duration", "cpu_s", "wall_s", "steps", "halved", "main_per_time",
                      "pass_per_time", "failed_per_time", "max_rotation", "rotation_q999",
                      "n_particles")


def parse_policy(text: str) -> tuple[str, float, float | None]:
    """'CONTROL:DT[:TARGET]' -> (CONTROL, DT, TARGET or None), CONTROL in STEP_CONTROLS.

    TARGET (control "overlap" only) replaces stepping.MAIN_OVERLAP for this policy.
    """
    kind, _, rest = text.partition(":")
    dt, *target = rest.split(":")
    message = (f"policy must be CONTROL:DT[:TARGET] with CONTROL in "
               f"{', '.join(STEP_CONTROLS)} (TARGET: overlap only)")
    if kind not in STEP_CONTROLS or len(target) > 1 or (target and kind != "overlap"):
        raise ValueError(f"{message}, got {text!r}")
    try:
        values = [float(v) for v in (dt, *target)]
    except ValueError:
        raise ValueError(f"{message}, got {text!r}") from None
    if not all(v > 0 for v in values):
        raise ValueError(f"{message}, positive numbers, got {text!r}")
    return kind, values[0], (values[1] if target else None)


@contextlib.contextmanager
def main_overlap(value: float | None):
    """stepping.MAIN_OVERLAP set to ``value`` (None: unchanged) inside the block."""
    saved = stepping.MAIN_OVERLAP
    if value is not None:
        stepping.MAIN_OVERLAP = value
    try:
        yield
    finally:
        stepping.MAIN_OVERLAP = saved


def measure(lam: float, radius: float, policy: str, uncapped: bool = False) -> dict:
    """One colony from one cell to ``radius`` under ``policy``; its costs and result."""
    control, dt, target = parse_policy(policy)
    config = Config(lam=lam, radius=radius, dt=dt, step_control=control)
    floor = stepping.PASS_ITERATION_FLOOR
    if uncapped:
        stepping.PASS_ITERATION_FLOOR = config.max_iterations
    try:
        w0, c0 = time.perf_counter(), time.process_time()
        with main_overlap(target):
            colony = run(config)
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    finally:
        stepping.PASS_ITERATION_FLOOR = floor
    h = colony.history

    def total(key):
        return int(sum(r[key] for r in h))

    return {"lam": lam, "policy": policy, "uncapped": uncapped, "cpu_s": cpu, "wall_s": wall,
            "steps": len(h), "halved": sum(r["substeps"] > 1 for r in h),
            "main_iterations": total("iterations") - total("pass_iterations"),
            "pass_iterations": total("pass_iterations"),
            "failed_iterations": total("failed_iterations"), "t_at_radius": colony.state.t,
            "n_particles": colony.state.n}


def measure_checkpoint(path: str | Path, policy: str, duration: float,  # noqa: PLR0913
                       threads: int | None = None, solver: str | None = None,
                       solver_tol: float | None = None, reorder: bool = False) -> dict:
    """Advance the state of checkpoint ``path`` by ``duration`` under ``policy``.

    See the module docstring; the run's configuration otherwise. Iterations are per unit time.
    An adaptive policy starts from the run's last step (at most DT), a fixed one with DT.
    ``threads``, ``solver``, ``solver_tol``: the contact solver's threads, name and residual
    tolerance (None: the run's).  ``reorder``: first put the particles in spatial order
    (particles.neighbours.spatial_order), as a run of this version holds them after its last
    division (a checkpoint written before 2026-12-02 holds them in the order of birth).
    """
    saved = load_checkpoint(Path(path))
    config, state, history = saved.config, saved.state, saved.history
    if reorder:
        state.permute(spatial_order(state.x, state.y))
    t0, rng, warm = state.t, state.rng, state.warm
    control, dt_max, target = parse_policy(policy)
    given = {"threads": threads, "solver": solver, "solver_tol": solver_tol}
    config = replace(config, dt=dt_max, step_control=control,
                     **{k: v for k, v in given.items() if v is not None})
    dt = dt_max if control == "fixed" or not history else min(dt_max, history[-1]["dt"])
    t, rows, turns = t0, [], []
    detections = stepping.Detections()  # as a run keeps them (particles.Simulation.step)
    w0, c0 = time.perf_counter(), time.process_time()
    with main_overlap(target):
        while t < t0 + duration * (1 - 1e-9):
            dt = min(dt, t0 + duration - t)
            theta = state.theta.copy()
            info, warm = stepping.robust_step(state, config, dt, warm, detections=detections)
            turns.append(np.abs(state.theta - theta))
            division.divide_in_order(state, rng, config.division_noise)
            rows.append(info)
            t += dt
            dt = stepping.next_dt(dt, info, dt_max, control)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    turns = np.concatenate(turns)

    def per_time(key):
        return sum(r[key] for r in rows) / (t - t0)

    return {"checkpoint": str(path), "lam": config.lam, "policy": policy,
            "solver": config.solver, "solver_tol": config.effective_solver_tol,
            "threads": config.threads, "reorder": reorder, "duration": t - t0,
            "cpu_s": cpu, "wall_s": wall, "steps": len(rows),
            "halved": sum(r["substeps"] > 1 for r in rows),
            "main_per_time": per_time("iterations") - per_time("pass_iterations"),
            "pass_per_time": per_time("pass_iterations"),
            "failed_per_time": per_time("failed_iterations"),
            "max_rotation": float(turns.max()), "rotation_q999": float(np.quantile(turns, 0.999)),
            "n_particles": state.n}


def _segments_table(rows: list[dict]) -> None:
    print(A.markdown_rows(
        ("run", "steps", "N", "t", "dt", "halved", "iterations per unit time", "failed share",
         "wall s", "ms per iteration"),
        ((r["run"], f"{r['first_step']}-{r['last_step']}", f"{r['n_first']}-{r['n_last']}",
          f"{r['t_first']:.2f}-{r['t_last']:.2f}", f"{r['dt_min']:.2g}-{r['dt_max']:.2g}",
          f"{r['halved']} of {r['steps']}", f"{r['per_time']:.3g}",
          f"{100 * r['failed_share']:.1f} %", f"{r.get('wall_s', math.nan):.0f}",
          f"{r.get('ms_per_iteration', math.nan):.2f}") for r in rows)), flush=True)


def _checkpoint_table(rows: list[dict]) -> None:
    print(A.markdown_rows(
        ("N", "lam", "policy", "steps", "halved", "main its / time", "pass its / time",
         "failed its / time", "CPU s", "max rotation", "99.9 % rotation"),
        ((r["n_particles"], f"{r['lam']:g}", r["policy"], r["steps"], r["halved"],
          f"{r['main_per_time']:.4g}", f"{r['pass_per_time']:.4g}", f"{r['failed_per_time']:.4g}",
          f"{r['cpu_s']:.1f}", f"{r['max_rotation']:.3g}", f"{r['rotation_q999']:.3g}")
         for r in rows)), flush=True)


def _write(rows: list[dict], columns: tuple[str, ...], out: Path) -> None:
    tmp = out.with_name(out.name + ".tmp")
    with open(tmp, "w", newline="") as f:  # rewritten after every run
        w = csv.DictWriter(f, columns)
        w.writeheader()
        w.writerows(rows)
    tmp.replace(out)


def _table(rows: list[dict]) -> None:
    print(A.markdown_rows(
        ("lam", "policy", "CPU s", "steps", "halved", "main its", "pass its", "failed its",
         "t at R", "N"),
        ((f"{r['lam']:g}", r["policy"] + (" uncapped" if r["uncapped"] else ""),
          f"{r['cpu_s']:.1f}", r["steps"], r["halved"], r["main_iterations"],
          r["pass_iterations"], r["failed_iterations"], f"{r['t_at_radius']:.3f}",
          r["n_particles"]) for r in rows)), flush=True)


def main(argv: list[str] | None = None) -> list[dict]:
    """Command line (module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--radius", type=float, default=40.0)
    ap.add_argument("--lams", type=float, nargs="+", default=[1e-2, 1e-3, 1e-4, 0.0])
    ap.add_argument("--policies", nargs="+",
                    default=["fixed:0.005", "fixed:0.01", "fixed:0.02", "overlap:0.01"])
    ap.add_argument("--uncapped", action="store_true",
                    help="also run each fixed policy without the pass iteration cap")
    ap.add_argument("--out", type=Path, default=Path("runs/bench_timestep.csv"))
    ap.add_argument("--checkpoint", type=Path,
                    help="measure the policies from this saved state (module docstring)")
    ap.add_argument("--duration", type=float, default=0.02,
                    help="with --checkpoint: time advanced per policy")
    ap.add_argument("--threads", type=int, default=None,
                    help="with --checkpoint: contact solver threads (default: the run's)")
    ap.add_argument("--solver", choices=sorted(SOLVERS), default=None,
                    help="with --checkpoint: contact solver (default: the run's)")
    ap.add_argument("--solver-tol", type=float, default=None,
                    help="with --checkpoint: the solver's residual tolerance (default: the run's)")
    ap.add_argument("--reorder", action="store_true",
                    help="with --checkpoint: the particles in spatial order first")
    ap.add_argument("--history", type=Path, nargs="+",
                    help="report the step-policy segments of these run folders (no runs)")
    ap.add_argument("--min-particles", type=float, default=0.0,
                    help="with --history: steps with at least this many particles")
    ap.add_argument("--sizes", type=float, nargs="+", default=[],
                    help="with --history: cut at these colony sizes N (stretches of size)")
    ap.add_argument("--logs", type=Path, nargs="+", default=None,
                    help="with --history: each run's colony particles log (wall per stretch)")
    a = ap.parse_args(argv)
    if a.history:
        missing = [str(r) for r in a.history if not (r / "history.csv").is_file()]
        if missing:
            ap.error(f"no history.csv in {', '.join(missing)}")
        if a.logs is not None and len(a.logs) != len(a.history):
            ap.error(f"--logs needs one log per --history run: {len(a.logs)} for "
                     f"{len(a.history)}")
        if a.logs is not None and (bad := [str(p) for p in a.logs if not p.is_file()]):
            ap.error(f"no log file {', '.join(bad)}")
        cuts = [a.min_particles, *sorted(n for n in a.sizes if n > a.min_particles), math.inf]
        logs = a.logs or [None] * len(a.history)
        rows = [row for r, log in zip(a.history, logs, strict=True)
                for lo, hi in zip(cuts[:-1], cuts[1:], strict=True)
                for row in A.history_segments(r, lo, hi, log and A.progress_wall(log))]
        _segments_table(rows)
        return rows
    try:
        for p in a.policies:
            parse_policy(p)
    except ValueError as e:
        ap.error(str(e))
    if a.checkpoint is not None and not a.checkpoint.is_file():
        ap.error(f"no checkpoint file {a.checkpoint}")
    if not a.duration > 0:
        ap.error(f"--duration must be positive, got {a.duration}")
    run(Config(lam=1e-2, radius=2.0))  # compile the kernels outside the timings
    a.out.parent.mkdir(parents=True, exist_ok=True)
    rows = []
    if a.checkpoint is not None:
        for policy in a.policies:
            rows.append(measure_checkpoint(a.checkpoint, policy, a.duration, a.threads,
                                           a.solver, a.solver_tol, a.reorder))
            _write(rows, CHECKPOINT_COLUMNS, a.out)
        _checkpoint_table(rows)
        return rows
    for lam in a.lams:
        for policy in a.policies:
            variants = [False] + ([True] if a.uncapped and policy.startswith("fixed") else [])
            for uncapped in variants:
                rows.append(measure(lam, a.radius, policy, uncapped))
                print(f"lam={lam:g} {policy}{' uncapped' if uncapped else ''}: "
                      f"{rows[-1]['cpu_s']:.1f} s CPU", flush=True)
                _write(rows, COLUMNS, a.out)
    _table(rows)
    return rows


if __name__ == "__main__":
    main()
