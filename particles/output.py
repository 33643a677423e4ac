"""Run outputs: config.json, history.csv, particles.csv, trajectory.gsd.

trajectory.gsd follows the HOOMD schema (gsd.hoomd): per frame, particles at z = 0 with
orientation quaternion (cos(theta/2), 0, 0, sin(theta/2)) about z, typeid 0 (type "rod"),
diameter b, and per-particle tip-to-tip length and axial load under
``log/particles/length`` and ``log/particles/stress``.  OVITO opens it directly (File > Load
File; the log quantities appear as particle properties "length" and "stress"); ParaView reads
it through OVITO export or the gsd Python package.
"""

from __future__ import annotations

import csv
import json
import os
from dataclasses import asdict
from pathlib import Path

import gsd.hoomd
import numpy as np

from .state import B, ParticleState

HISTORY_COLUMNS = ("step", "t", "dt", "radius", "hull_radius", "n_particles", "max_stress",
                   "mean_stress", "max_overlap", "iterations", "passes", "n_contacts",
                   "residual", "total_length", "divisions", "substeps", "pass_iterations",
                   "failed_iterations")


def write_config(out: Path, config, step: int | None = None,
                 policy: tuple[str, ...] = ()) -> None:
    """config.json: the run's ParticleConfig fields.

    ``step`` given (a run resumed there with a changed step policy): the ``policy`` fields that
    differ from the config.json in ``out`` are appended to its ``step_policy_changes``, a list of
    {"step": step, field: [old, new], ...}, kept with the new fields.
    """
    fields = asdict(config)
    path = out / "config.json"
    if step is not None and path.is_file():
        old = json.loads(path.read_text())
        changes = old.pop("step_policy_changes", [])
        diff = {k: [old[k], fields[k]] for k in policy if k in old and old[k] != fields[k]}
        if diff:
            changes.append({"step": step, **diff})
        if changes:
            fields["step_policy_changes"] = changes
    path.write_text(json.dumps(fields, indent=2) + "\n")


def write_history(out: Path, history: list[dict]) -> None:
    """history.csv, one row per step (HISTORY_COLUMNS), written atomically."""
    tmp = out / "history.csv.tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(HISTORY_COLUMNS)
        for row in history:
            values = [row.get(c, "") for c in HISTORY_COLUMNS]  # "": not recorded then
            w.writerow([repr(v) if isinstance(v, float) else v for v in values])
    os.replace(tmp, out / "history.csv")


def write_particles(out: Path, state: ParticleState) -> None:
    """particles.csv: x,y,theta,length,stress of the current particles (full precision)."""
    data = np.column_stack([state.x, state.y, state.theta, state.length, state.stress])
    tmp = out / "particles.csv.tmp"
    np.savetxt(tmp, data, delimiter=",", header="x,y,theta,length,stress", comments="",
               fmt="%.17g")
    os.replace(tmp, out / "particles.csv")


def read_init(path: str | os.PathLike) -> tuple[np.ndarray, ...]:
    """Read an initial condition CSV with columns x,y,theta,length (header required)."""
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"init file not found: {p}")
    with open(p, newline="") as f:
        rows = list(csv.DictReader(f))
    need = ("x", "y", "theta", "length")
    if not rows or any(c not in rows[0] for c in need):
        raise ValueError(f"init file {p} needs a header with columns x,y,theta,length")
    try:
        return tuple(np.array([float(r[c]) for r in rows]) for c in need)
    except ValueError as e:
        raise ValueError(f"init file {p}: non-numeric value ({e})") from None


def make_frame(state: ParticleState, step: int) -> gsd.hoomd.Frame:
    """One HOOMD frame of the colony (see module docstring)."""
    f = gsd.hoomd.Frame()
    n = state.n
    f.configuration.step = int(step)
    f.configuration.dimensions = 2
    ext = 2.0 * (float(np.max(np.abs(np.concatenate([state.x, state.y])))) + 2.0)
    f.configuration.box = [ext, ext, 0.0, 0.0, 0.0, 0.0]
    f.particles.N = n
    f.particles.types = ["rod"]
    f.particles.typeid = np.zeros(n, dtype=np.uint32)
    f.particles.position = np.column_stack([state.x, state.y, np.zeros(n)]).astype(np.float32)
    q = np.zeros((n, 4), dtype=np.float32)
    q[:, 0] = np.cos(state.theta / 2)
    q[:, 3] = np.sin(state.theta / 2)
    f.particles.orientation = q
    f.particles.diameter = np.full(n, B, dtype=np.float32)
    f.log["particles/length"] = state.length.astype(np.float32)
    f.log["particles/stress"] = state.stress.astype(np.float32)
    return f


def append_frame(path: Path, state: ParticleState, step: int) -> None:
    """Append a frame to trajectory.gsd (created when missing)."""
    with gsd.hoomd.open(str(path), mode="a") as t:
        t.append(make_frame(state, step))


def truncate_trajectory(path: Path, n_frames: int) -> None:
    """Keep the first n_frames frames of a trajectory (used when resuming from a checkpoint)."""
    if not path.exists():
        return
    with gsd.hoomd.open(str(path), mode="r") as t:
        if len(t) <= n_frames:
            return
        frames = [t[i] for i in range(n_frames)]
    tmp = path.with_suffix(".gsd.tmp")
    with gsd.hoomd.open(str(tmp), mode="w") as t:
        for fr in frames:
            t.append(fr)
    os.replace(tmp, path)
