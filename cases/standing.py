"""Where an unfinished run stands, and the wall it will take to its goal (``colony info``).

A run's cost grows as a power of its radius (docs/benchmarks.md, "Cost growth": a particle
colony's wall as R^3.5-3.9). The projection takes that law from the run's own history:

- the work of each step, w = iterations x contacts of the contact solve (particles; the solve is
  most of a step) or the mesh nodes (continuum), summed into C(x) over the steps, x the goal's
  variable (radius or t);
- the exponent a of C ~ x^a, least squares on the steps with x >= x_now / 2
  (:func:`cases.analysis.power_law_fit`, as ``docs/measurements/cost_growth.py`` fits the wall);
- the wall to the goal: W_spent (C(x_goal) / C(x_now) - 1), C(x_goal) = C(x_now)
  (x_goal / x_now)^a: the wall spent per unit of work so far, at the work still to do.

A projection, not a measurement: the law is assumed to hold beyond where it was fitted, and a
leg on another machine or with other threads runs at another wall per unit of work.
"""

from __future__ import annotations

import math
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

#: Fewest steps of a fit (fewer: no projection).
MIN_STEPS = 10


def step_work(history: dict[str, np.ndarray]) -> np.ndarray:
    """The work w of each step of a history.csv (module docstring)."""
    if "n_contacts" in history:  # particles
        return (np.nan_to_num(history["iterations"]) + 1) * (history["n_contacts"] + 1)
    return np.asarray(history["n_nodes"], dtype=float)


def projected_wall(history: dict[str, np.ndarray], variable: str, goal: float,
                   wall: float) -> tuple[float, float] | None:
    """(seconds of wall to the goal, exponent a) of the module docstring; None: too few steps."""
    from cases.analysis import power_law_fit

    x = np.asarray(history[variable], dtype=float)
    cost = np.cumsum(step_work(history))
    late = x >= x[-1] / 2
    if late.sum() < MIN_STEPS or x[-1] <= 0 or wall <= 0:
        return None
    try:
        a = power_law_fit(x[late], cost[late])[0]
    except ValueError:
        return None
    return wall * max((goal / x[-1]) ** a - 1.0, 0.0), a


def _count(n: int, noun: str) -> str:
    """``n noun`` with the noun in the plural unless n is 1 ("1 session", "2,048 cells")."""
    return f"{n:,} {noun}{'' if n == 1 else 's'}"


def duration(seconds: float) -> str:
    """A wall time as people read it: "40 s", "12.5 min", "3.21 h" (never "0.00 h")."""
    if seconds < 60:
        return f"{seconds:.0f} s"
    if seconds < 3600:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.2f} h"


def wall_spent(run: dict, until: datetime) -> float:
    """Wall seconds of a run's sessions; a session still running counts until ``until``."""
    total = 0.0
    for s in run.get("sessions", []):
        if isinstance(s.get("wall_seconds"), (int, float)):
            total += s["wall_seconds"]
        elif s.get("status") == "running" and s.get("start"):
            try:
                total += (until - datetime.fromisoformat(s["start"])).total_seconds()
            except (TypeError, ValueError):
                pass
    return total


def standing(folder: Path, run: dict) -> list[str]:
    """Lines of ``colony info`` for a run not finished: goal, cells, wall spent and projected."""
    from cases.analysis import read_csv

    if run.get("status") == "finished" or not (Path(folder) / "history.csv").is_file():
        return []
    try:
        history = read_csv(Path(folder) / "history.csv")
    except (OSError, ValueError):
        return []
    config = run.get("config", {})
    variable = "radius" if config.get("radius") is not None else "t"
    goal = config.get(variable if variable == "radius" else "time")
    if not history or variable not in history or not len(history[variable]) or goal is None:
        return []
    now = float(history[variable][-1])
    cells = (f", {_count(int(history['n_particles'][-1]), 'cell')}" if "n_particles" in history
             else "")
    written = (Path(folder) / "history.csv").stat().st_mtime  # the history's last step
    wall = wall_spent(run, datetime.fromtimestamp(written, UTC))
    lines = [f"stands at       {variable} {now:.4g} of {goal:g}{cells}, t = "
             f"{float(history['t'][-1]):.4g}, step {len(history[variable])}; wall spent "
             f"{duration(wall)} in {_count(len(run.get('sessions', [])), 'session')}"]
    projection = projected_wall(history, variable, float(goal), wall)
    if projection is not None and math.isfinite(projection[0]):
        lines.append(f"projected       {duration(projection[0])} more wall to {variable} "
                     f"{goal:g} (work ~ {variable}^{projection[1]:.2f} fitted on this run's "
                     "steps, at its wall per unit of work so far; cases/standing.py)")
    return lines
