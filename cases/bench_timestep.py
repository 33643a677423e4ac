"""Benchmark of the particle time step: whole runs to a radius, per lam and step policy.

The main contact solve costs about the same in total whatever dt (its iterations scale with
dt), while the re-detection passes that remove the overlaps left by the linearised step grow
from a few percent of it to more than all of it once dt is too long for the colony's speeds,
which grow as lam falls.  For each lam of ``--lams`` and each policy of ``--policies``
(``fixed:DT`` or ``adaptive:DT_MAX``, see particles.simulation.next_dt) one colony is grown from
one cell to ``--radius`` and the table reports CPU seconds, steps, the solver iterations of
the main solves, of the passes and of failed attempts (redone as half steps), and t at the
radius (the result, which the step must not change beyond its first-order error).
``--uncapped`` lifts the cap on a pass's iterations (PASS_ITERATION_FLOOR = max_iterations),
which is how the engine ran before the cap, to measure what the cap saves.

    python -m cases.bench_timestep [--radius 40] [--lams 1e-2 1e-3 1e-4 0]
                                   [--policies fixed:0.005 fixed:0.01 fixed:0.02 adaptive:0.04]
                                   [--uncapped] [--out runs/bench_timestep.csv]

CPU time (time.process_time) is reported because the engine is single-threaded and this
machine is often shared; wall time is in the CSV too.
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import particles.simulation as simulation
from particles.simulation import ParticleConfig, run

COLUMNS = ("lam", "policy", "uncapped", "cpu_s", "wall_s", "steps", "halved", "main_iterations",
           "pass_iterations", "failed_iterations", "t_at_radius", "n_particles")


def parse_policy(text: str) -> tuple[bool, float]:
    """'fixed:DT' -> (False, DT); 'adaptive:DT_MAX' -> (True, DT_MAX)."""
    kind, _, value = text.partition(":")
    if kind not in ("fixed", "adaptive"):
        raise ValueError(f"policy must be fixed:DT or adaptive:DT_MAX, got {text!r}")
    try:
        dt = float(value)
    except ValueError:
        raise ValueError(f"policy must be fixed:DT or adaptive:DT_MAX, got {text!r}") from None
    return kind == "adaptive", dt


def measure(lam: float, radius: float, policy: str, uncapped: bool = False) -> dict:
    """One colony from one cell to ``radius`` under ``policy``; its costs and result."""
    adaptive, dt = parse_policy(policy)
    config = ParticleConfig(lam=lam, radius=radius, dt=dt, adaptive_dt=adaptive)
    config.validate()
    floor = simulation.PASS_ITERATION_FLOOR
    if uncapped:
        simulation.PASS_ITERATION_FLOOR = config.max_iterations
    try:
        w0, c0 = time.perf_counter(), time.process_time()
        colony = run(config)
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    finally:
        simulation.PASS_ITERATION_FLOOR = floor
    h = colony.history

    def total(key):
        return int(sum(r[key] for r in h))

    return {"lam": lam, "policy": policy, "uncapped": uncapped, "cpu_s": cpu, "wall_s": wall,
            "steps": len(h), "halved": sum(r["substeps"] > 1 for r in h),
            "main_iterations": total("iterations") - total("pass_iterations"),
            "pass_iterations": total("pass_iterations"),
            "failed_iterations": total("failed_iterations"), "t_at_radius": colony.t,
            "n_particles": colony.n}


def _table(rows: list[dict]) -> None:
    print("| lam | policy | CPU s | steps | halved | main its | pass its | failed its "
          "| t at R | N |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        policy = r["policy"] + (" uncapped" if r["uncapped"] else "")
        print(f"| {r['lam']:g} | {policy} | {r['cpu_s']:.1f} | {r['steps']} | {r['halved']} "
              f"| {r['main_iterations']} | {r['pass_iterations']} | {r['failed_iterations']} "
              f"| {r['t_at_radius']:.3f} | {r['n_particles']} |", flush=True)


def main(argv: list[str] | None = None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--radius", type=float, default=40.0)
    ap.add_argument("--lams", type=float, nargs="+", default=[1e-2, 1e-3, 1e-4, 0.0])
    ap.add_argument("--policies", nargs="+",
                    default=["fixed:0.005", "fixed:0.01", "fixed:0.02", "adaptive:0.04"])
    ap.add_argument("--uncapped", action="store_true",
                    help="also run each fixed policy without the pass iteration cap")
    ap.add_argument("--out", type=Path, default=Path("runs/bench_timestep.csv"))
    a = ap.parse_args(argv)
    try:
        for p in a.policies:
            parse_policy(p)
    except ValueError as e:
        ap.error(str(e))
    run(ParticleConfig(lam=1e-2, radius=2.0))  # compile the kernels outside the timings
    a.out.parent.mkdir(parents=True, exist_ok=True)
    rows = []
    for lam in a.lams:
        for policy in a.policies:
            variants = [False] + ([True] if a.uncapped and policy.startswith("fixed") else [])
            for uncapped in variants:
                rows.append(measure(lam, a.radius, policy, uncapped))
                print(f"lam={lam:g} {policy}{' uncapped' if uncapped else ''}: "
                      f"{rows[-1]['cpu_s']:.1f} s CPU", flush=True)
                tmp = a.out.with_name(a.out.name + ".tmp")
                with open(tmp, "w", newline="") as f:  # rewritten after every run
                    w = csv.DictWriter(f, COLUMNS)
                    w.writeheader()
                    w.writerows(rows)
                tmp.replace(a.out)
    _table(rows)
    return rows


if __name__ == "__main__":
    main()
