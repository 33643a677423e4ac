"""Run outputs: config.json, history.csv, particles.csv, trajectory.gsd; the run's writer.

:class:`RunOutput` is what ``particles.run`` hands each step to: a trajectory frame every
``output_every`` of time (:func:`frame_count`), the history and the particles at the end, the
free-space checks.

trajectory.gsd follows the HOOMD schema (gsd.hoomd) and is laid out so that OVITO (3.x, File >
Load File or ``ovito.io.import_file``) draws every particle as the sphero-cylinder it is, with no
pipeline set up by hand.  Per frame:

- ``configuration.step`` = the step; ``log/Time`` = t (OVITO: global attributes ``Timestep`` and
  ``Time``); ``configuration.dimensions`` = 2.
- ``configuration.box``: a square of edge 2 (X + BOX_MARGIN) centred at the origin, X the
  largest ``|x|`` or ``|y|`` reached by any particle (segment end + b/2).  HOOMD boxes are
  periodic and OVITO's GSD reader always marks the cell periodic (checked:
  ``cell.pbc == (True, True, True)``); with this edge every periodic image lies at least
  2 BOX_MARGIN away from the colony, so images never touch it.  ``cases.viewer.ovito_pipeline``
  also turns periodicity off.
- ``particles.position`` (x, y, 0), ``particles.diameter`` = b (OVITO: ``Radius`` = b/2), one type
  "rod" whose ``type_shapes`` entry is a ConvexPolyhedron of two vertices on the local z axis
  with rounding radius b/2 (OVITO makes this type a ``Spherocylinder``).
- ``particles.orientation``: the unit quaternion (w, x, y, z) = (cos(theta/2), -sin(theta/2),
  cos(theta/2), sin(theta/2)) / sqrt(2), the rotation R_z(theta) R_y(pi/2), which turns the local
  z axis (OVITO's sphero-cylinder axis) into the particle axis p = (cos theta, sin theta, 0).
  theta = 2 atan2(q_z, q_w), as with the plain turn about z written before (older files).
- ``log/particles/Aspherical Shape`` = (b/2, b/2, l - b) per particle: OVITO loads it as its
  standard ``Aspherical Shape`` property, which for a Spherocylinder is (radius, -, length of the
  cylindrical part), so each rod gets its own tip-to-tip length l.
- ``log/particles/Particle Identifier`` = the particle's id (OVITO's standard identifier, so
  OVITO tracks particles across frames); ``log/particles/parent`` and
  ``log/particles/generation`` when the state carries ``parent`` and ``generation`` arrays.
- ``log/particles/length`` (l) and ``log/particles/stress`` (axial load sigma): OVITO
  user properties ``length`` and ``stress`` (colour with Color coding, range [1, 2] for l).

``read_trajectory`` reads the frames back (gsd and numpy only); ``cases.viewer.ovito_pipeline``
opens the file in OVITO's Python module (optional dependency ``ovito``) and
``cases.viewer.render_ovito`` renders a frame.
"""

from __future__ import annotations

import csv
import json
import math
import os
from collections.abc import Iterable, Iterator
from dataclasses import asdict, dataclass
from pathlib import Path

import gsd.hoomd
import numpy as np

from . import runfiles
from .state import B, ParticleState

HISTORY_COLUMNS = ("step", "t", "dt", "radius", "hull_radius", "n_particles", "max_stress",
                   "mean_stress", "max_overlap", "iterations", "passes", "n_contacts",
                   "residual", "total_length", "divisions", "substeps", "pass_iterations",
                   "failed_iterations", "max_rotation", "max_displacement", "main_overlap")


#: Config fields of the model's extensions, written to config.json only when set.
OPTIONAL_FIELDS = ("strains", "layout", "nutrient_length", "monod_k", "nutrient_grid",
                   "dish_radius")


def write_config(out: Path, config, step: int | None = None,
                 policy: tuple[str, ...] = ()) -> None:
    """config.json: the run's ``Config`` fields (OPTIONAL_FIELDS only when given).

    ``step`` given (a run resumed there with a changed step policy): the ``policy`` fields that
    differ from the config.json in ``out`` are appended to its ``step_policy_changes``, a list of
    {"step": step, field: [old, new], ...}, kept with the new fields.
    """
    fields = asdict(config)
    for name in OPTIONAL_FIELDS:  # without the extension: the file as before it existed
        if name in fields and fields[name] in ((), [], None):
            del fields[name]
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
    """history.csv, one row per step (HISTORY_COLUMNS, then a run's strain columns), atomically.

    With strains (particles.strains) each row also holds n_strain_i and total_length_i, the
    particles and their summed length l of every strain i (:func:`strain_columns`).
    """
    columns = HISTORY_COLUMNS + tuple(k for k in (history[-1] if history else {})
                                      if k.startswith(STRAIN_COLUMN_PREFIXES))
    tmp = out / "history.csv.tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(columns)
        for row in history:
            values = [row.get(c, "") for c in columns]  # "": not recorded then
            w.writerow([repr(v) if isinstance(v, float) else v for v in values])
    os.replace(tmp, out / "history.csv")


STRAIN_COLUMN_PREFIXES = ("n_strain_", "total_length_")
"""Prefixes of history.csv's columns per strain (:func:`strain_columns`)."""


def strain_columns(state: ParticleState, n_strains: int) -> dict[str, float]:
    """History values of each strain i: n_strain_i (particles) and total_length_i (sum of l).

    Empty for a one-strain colony (``state.strain`` None).
    """
    if state.strain is None:
        return {}
    counts = np.bincount(state.strain, minlength=n_strains)
    lengths = np.bincount(state.strain, weights=state.length, minlength=n_strains)
    return ({f"n_strain_{i}": int(counts[i]) for i in range(n_strains)}
            | {f"total_length_{i}": float(lengths[i]) for i in range(n_strains)})


def ensure_space(out: Path, n_particles: int, checkpoint: Path | None = None) -> None:
    """OSError(ENOSPC) unless ``out`` keeps its reserve after the next writes (runfiles).

    The next writes: a frame and a checkpoint of ``n_particles``, at most the last checkpoint's
    size twice.
    """
    runfiles.ensure_space(Path(out), 200 * n_particles, ((checkpoint, 2),))


def write_particles(out: Path, state: ParticleState) -> None:
    """particles.csv: x,y,theta,length,stress (and strain, with strains) of the particles.

    Full precision (the strain an integer).
    """
    columns = [state.x, state.y, state.theta, state.length, state.stress]
    header = "x,y,theta,length,stress"
    if state.strain is not None:
        columns.append(state.strain)
        header += ",strain"
    tmp = out / "particles.csv.tmp"
    np.savetxt(tmp, np.column_stack(columns), delimiter=",", header=header, comments="",
               fmt="%.17g")
    os.replace(tmp, out / "particles.csv")


def read_init(path: str | os.PathLike) -> tuple[np.ndarray, ...]:
    """Read an initial condition CSV with columns x,y,theta,length (header required).

    ValueError (one line naming the file) for a missing file or header, a row shorter than the
    header (its row number and line) or a non-numeric value.
    """
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"init file not found: {p}")
    with open(p, newline="") as f:
        reader = csv.DictReader(f)
        rows, lines = [], []
        for r in reader:
            rows.append(r)
            lines.append(reader.line_num)
    need = ("x", "y", "theta", "length")
    if not rows or any(c not in rows[0] for c in need):
        raise ValueError(f"init file {p} needs a header with columns x,y,theta,length")
    for k, r in enumerate(rows):
        missing = [c for c in need if r[c] is None]  # DictReader's None: the row ended before
        if missing:
            raise ValueError(f"init file {p}: row {k + 1} (line {lines[k]}) is shorter than the "
                             f"header, no value for {','.join(missing)}")
    try:
        return tuple(np.array([float(r[c]) for r in rows]) for c in need)
    except ValueError as e:
        raise ValueError(f"init file {p}: non-numeric value ({e})") from None


BOX_MARGIN = 2.0
"""Gap (model length units) between the colony and the box edge; images are 2 BOX_MARGIN apart."""

ROD_TYPE = "rod"


def strain_type(i: int) -> str:
    """The particle type of strain i in trajectory.gsd: ``strain_i`` (a rod like ROD_TYPE)."""
    return f"strain_{i}"
_NOMINAL_CYLINDER = 1.0  # the type's default cylinder length; every particle overrides it


def rod_quaternion(theta: np.ndarray) -> np.ndarray:
    """Unit quaternions (w, x, y, z) turning the local z axis into p = (cos theta, sin theta, 0).

    q = q_z(theta) q_y(pi/2) = (cos(theta/2), -sin(theta/2), cos(theta/2), sin(theta/2)) / sqrt(2):
    first a quarter turn about y (z -> x), then a turn by theta about z (x -> p).
    """
    h = 0.5 * np.asarray(theta, dtype=float)
    c, s = np.cos(h), np.sin(h)
    return np.column_stack([c, -s, c, s]) / np.sqrt(2.0)


def box_edge(state: ParticleState) -> float:
    """Edge 2 (X + BOX_MARGIN) of the square box; X = max ``|coordinate|`` of any particle point."""
    h = 0.5 * (state.length - B)
    ex = np.abs(state.x) + np.abs(np.cos(state.theta)) * h
    ey = np.abs(state.y) + np.abs(np.sin(state.theta)) * h
    return 2.0 * (float(max(ex.max(), ey.max())) + B / 2 + BOX_MARGIN)


def make_frame(state: ParticleState, step: int, t: float | None = None) -> gsd.hoomd.Frame:
    """One HOOMD frame of the colony at step ``step`` and time ``t`` (see module docstring).

    ``t`` None: no ``log/Time`` (the time is then read from history.csv).
    """
    f = gsd.hoomd.Frame()
    n = state.n
    f.configuration.step = int(step)
    f.configuration.dimensions = 2
    ext = box_edge(state)
    f.configuration.box = [ext, ext, 0.0, 0.0, 0.0, 0.0]
    f.particles.N = n
    shape = {"type": "ConvexPolyhedron", "rounding_radius": B / 2,
             "vertices": [[0.0, 0.0, -_NOMINAL_CYLINDER / 2], [0.0, 0.0, _NOMINAL_CYLINDER / 2]]}
    if state.strain is None:
        f.particles.types = [ROD_TYPE]
        f.particles.typeid = np.zeros(n, dtype=np.uint32)
    else:  # one type per strain, all rods: OVITO colours the particles by strain
        f.particles.types = [strain_type(i) for i in range(int(state.strain.max()) + 1)]
        f.particles.typeid = np.asarray(state.strain, dtype=np.uint32)
    f.particles.type_shapes = [shape] * len(f.particles.types)
    f.particles.position = np.column_stack([state.x, state.y, np.zeros(n)]).astype(np.float32)
    f.particles.orientation = rod_quaternion(state.theta).astype(np.float32)
    f.particles.diameter = np.full(n, B, dtype=np.float32)
    shape = np.empty((n, 3), dtype=np.float32)
    shape[:, :2] = B / 2
    shape[:, 2] = state.length - B
    f.log["particles/Aspherical Shape"] = shape
    f.log["particles/Particle Identifier"] = np.asarray(state.ids, dtype=np.int64)
    for name in ("parent", "generation"):
        values = getattr(state, name, None)
        if values is not None:
            f.log[f"particles/{name}"] = np.asarray(values, dtype=np.int64)
    f.log["particles/length"] = state.length.astype(np.float32)
    f.log["particles/stress"] = state.stress.astype(np.float32)
    if t is not None:
        f.log["Time"] = np.array([float(t)], dtype=np.float64)
    return f


def append_frame(path: Path, state: ParticleState, step: int, t: float | None = None) -> None:
    """Append a frame to trajectory.gsd (created when missing)."""
    _append(path, make_frame(state, step, t))


def _append(path: Path, frame: gsd.hoomd.Frame) -> None:
    """Append ``frame`` to the gsd file ``path`` in an open of its own (created when missing).

    gsd lays out its index by the opens that wrote a file, so one open per frame, here and in
    :func:`truncate_trajectory`, gives a file the same bytes however its frames were written.
    A file gsd creates is 0640 whatever the umask: it gets the umask's mode, as every other
    file of a run folder does.
    """
    created = not path.exists()
    with gsd.hoomd.open(str(path), mode="a") as traj:
        traj.append(frame)
    if created:
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(path, 0o666 & ~mask)


def truncate_trajectory(path: Path, n_frames: int, size: int | None = None) -> None:
    """Keep the first n_frames frames of a trajectory (used when resuming from a checkpoint).

    ``size``: the file's bytes when it held those frames (the checkpoint's bookkeeping); a file
    of that size is kept as it is, any other is rewritten with its first n_frames frames, one
    at a time (a run killed while appending a frame leaves the new frame's bytes after the last
    frame gsd indexes; the rewrite drops them).  None (older checkpoints): rewritten only when
    it holds more frames. The rewrite appends each frame in an open of its own, as the run
    wrote them (:func:`_append`), so the file's bytes are those of an uninterrupted run.
    """
    if not path.exists() or (size is not None and path.stat().st_size == size):
        return
    tmp = path.with_suffix(".gsd.tmp")
    with gsd.hoomd.open(str(path), mode="r") as t:
        if len(t) < n_frames or (size is None and len(t) == n_frames):
            return
        if tmp.exists():
            tmp.unlink()
        for i in range(n_frames):
            _append(tmp, t[i])
    os.replace(tmp, path)


FRAME_SLACK = 1e-9
"""Fraction of ``output_every`` by which t may fall short of a multiple and count as on it: t
summed over fixed steps (10 steps of 0.01 give 0.09999999999999999) lands on the multiples."""


def frame_count(t: float, output_every: float) -> int:
    """The multiples of ``output_every`` that t has reached: floor(t / output_every + slack).

    A frame is due after each step that raises it (:meth:`RunOutput.after_step`); it depends on
    t alone, so a resumed run writes the frames of an uninterrupted one.  0 when
    ``output_every`` is 0 (no frames between the first and the last).
    """
    if output_every <= 0:
        return 0
    return math.floor(t / output_every + FRAME_SLACK)


class RunOutput:
    """The writers of a run folder: trajectory frames, history.csv, particles.csv, config.json.

    ``frames`` = [frames written, step of the last frame, bytes of trajectory.gsd] (saved in
    checkpoints, so that a resumed run first truncates its trajectory to the frames of its
    checkpoint; checkpoints written before the bytes were kept have the first two).
    """

    def __init__(self, out: Path, output_every: float):
        self.out = Path(out)
        self.output_every = output_every
        self.trajectory = self.out / "trajectory.gsd"
        self.checkpoint = self.out / "checkpoint.npz"
        self.frames = [0, -1]
        self.reached = 0  # frame_count of the last step

    def start(self, config, state: ParticleState) -> None:
        """A new run: config.json, and the trajectory restarted with the frame of step 0."""
        write_config(self.out, config)
        if self.trajectory.exists():
            self.trajectory.unlink()
        self.reached = frame_count(state.t, self.output_every)
        self.frame(state)

    def resume(self, frames: list[int], t: float) -> None:
        """A run resumed from a checkpoint at time ``t``: the first ``frames[0]`` frames kept."""
        self.frames = list(frames)
        self.reached = frame_count(t, self.output_every)
        size = self.frames[2] if len(self.frames) > 2 else None  # older checkpoints: none
        truncate_trajectory(self.trajectory, self.frames[0], size)

    def frame(self, state: ParticleState) -> None:
        """Append the frame of ``state`` (step ``state.step``, time ``state.t``)."""
        append_frame(self.trajectory, state, state.step, t=state.t)
        self.frames = [self.frames[0] + 1, state.step, self.trajectory.stat().st_size]

    def ensure_space(self, state: ParticleState) -> None:
        """:func:`ensure_space` before the next write of ``state``."""
        ensure_space(self.out, state.n, self.checkpoint)

    def after_step(self, state: ParticleState) -> None:
        """A frame when the step crossed a multiple of ``output_every`` (:func:`frame_count`)."""
        reached = frame_count(state.t, self.output_every)
        if reached > self.reached:
            self.reached = reached
            self.ensure_space(state)
            self.frame(state)

    def last_frame(self, state: ParticleState) -> None:
        """The frame of the final state, unless written already."""
        if self.frames[1] != state.step:
            self.frame(state)

    def results(self, state: ParticleState, history: list[dict]) -> None:
        """history.csv and particles.csv of the current state."""
        write_history(self.out, history)
        write_particles(self.out, state)


@dataclass
class TrajectoryFrame:
    """One frame of trajectory.gsd as numpy arrays (float64, int64).

    ``ids`` None for files written before ids were stored; ``parent`` and ``generation`` None when
    the run did not record them; ``strain`` each particle's strain (its particle type
    ``strain_i``), None for a one-strain run.  ``t`` is NaN when neither ``log/Time`` nor a
    history.csv row of the frame's step gives it.
    """

    step: int
    t: float
    x: np.ndarray
    y: np.ndarray
    theta: np.ndarray
    length: np.ndarray
    stress: np.ndarray
    ids: np.ndarray | None = None
    parent: np.ndarray | None = None
    generation: np.ndarray | None = None
    strain: np.ndarray | None = None

    @property
    def n(self) -> int:
        """Number of particles N in the frame."""
        return int(self.x.shape[0])


def count_frames(path: str | os.PathLike) -> int:
    """Number of frames in a trajectory.gsd.  Raises ValueError when it is missing."""
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"trajectory not found: {p}")
    with gsd.hoomd.open(str(p), mode="r") as traj:
        return len(traj)


def _history_times(folder: Path) -> dict[int, float]:
    """Times by step, step -> t, from history.csv beside the trajectory ({} if absent/no step)."""
    path = folder / "history.csv"
    if not path.is_file():
        return {}
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows or "step" not in rows[0] or "t" not in rows[0]:
        return {}
    return {int(r["step"]): float(r["t"]) for r in rows}


def _strains_of(frame) -> np.ndarray | None:
    """Each particle's strain i from its type ``strain_i``; None for a one-strain file."""
    types = list(frame.particles.types)
    if not types or not all(t.startswith("strain_") for t in types):
        return None
    index = np.array([int(t.removeprefix("strain_")) for t in types], dtype=np.int64)
    return index[np.asarray(frame.particles.typeid, dtype=np.int64)]


def read_trajectory(path: str | os.PathLike,
                    frames: Iterable[int] | None = None) -> Iterator[TrajectoryFrame]:
    """Yield the frames (all, or the indices ``frames``) of a trajectory.gsd.

    theta = 2 atan2(q_z, q_w), right for this module's quaternions and for the plain turns about
    z of older files; l and sigma from ``log/particles/length`` and ``log/particles/stress``; t
    from ``log/Time``, else from the history.csv beside the file (row of the frame's step; 0 at
    step 0).

    Parameters
    ----------
    path : str or path-like
        The trajectory.gsd file.
    frames : iterable of int, optional
        Indices of the frames to read; default all, in order.

    Yields
    ------
    TrajectoryFrame
        Step, t, centres x_n, y_n, orientations theta_n, lengths l_n and axial stresses
        sigma_n of the frame (with ids and lineage where the file has them).

    Raises
    ------
    ValueError
        When the file is missing or lacks the per-particle logs.
    """
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"trajectory not found: {p}")
    t_of_step: dict[int, float] | None = None
    with gsd.hoomd.open(str(p), mode="r") as traj:
        for i in range(len(traj)) if frames is None else frames:
            fr = traj[int(i)]
            log = fr.log
            if "particles/length" not in log or "particles/stress" not in log:
                raise ValueError(f"{p}: frame {i} has no log/particles/length or stress")
            step = int(fr.configuration.step)
            if "Time" in log:
                t = float(np.asarray(log["Time"]).ravel()[0])
            else:
                if t_of_step is None:
                    t_of_step = _history_times(p.parent)
                t = t_of_step.get(step, 0.0 if step == 0 else float("nan"))
            pos = np.asarray(fr.particles.position, dtype=float)
            q = np.asarray(fr.particles.orientation, dtype=float)

            def opt(name, log=log):
                v = log.get(f"particles/{name}")
                return None if v is None else np.asarray(v, dtype=np.int64)

            yield TrajectoryFrame(
                step=step, t=t, x=pos[:, 0].copy(), y=pos[:, 1].copy(),
                theta=2.0 * np.arctan2(q[:, 3], q[:, 0]),
                length=np.asarray(log["particles/length"], dtype=float),
                stress=np.asarray(log["particles/stress"], dtype=float),
                ids=opt("Particle Identifier"), parent=opt("parent"),
                generation=opt("generation"), strain=_strains_of(fr))
