"""The continuum colony as a simulation: its configuration, the stepping, and a run.

Model (model.md): on Omega(t), u = -grad p, div u = g = exp(-lam p), p = 0 on the boundary,
the boundary moves with u; the growth phase G = int g dt and the size distribution Psi(x, l, t)
are carried by the material. Initial condition: a disc of radius R0 = sqrt(b/pi) (or the given
shape), G = 0, Psi0 a narrow smooth bump standing in for delta(l - 1) (continuum.sizes).

:class:`Simulation` holds the :class:`~continuum.state.State` and the pressure solver.
``Simulation.step`` is one time step: remesh when due (continuum.remesh), then Heun's RK2 for
the nodes, G and Psi with two pressure solves (continuum.motion, continuum.velocity.darcy_flow),
dt = courant * h / u_edge (continuum.motion.stable_dt) shortened so as to land on a goal;
it returns a :class:`~continuum.state.StepRecord`. ``Simulation.advance`` steps to a radius or
a time. :func:`run` is the loop of a run to ``config.radius`` or ``config.time`` that hands
each step to the output writers (continuum.output), the checkpointer (continuum.checkpoint)
and the progress bar.

Mesh size: boundary edge length h = min(h_max, h_N(area)) with h_N the size giving about
``n_nodes`` nodes on the current area (continuum.mesh.target_spacing): a fixed node count while
the colony is small, a capped spacing later. With ``interior_coarsening`` c > 1 the interior
size grows away from the edge up to c h (graded mesh, fewer nodes where nothing happens fast).

Determinism: a configuration gives the same bits in any process (history, fields, files).
The one random ingredient, pyamg's spectral-radius estimate in the AMG setup, runs with a
fixed seed (continuum.pressure.amg_hierarchy); Triangle's meshing is deterministic and
independent of earlier calls; BLAS runs on one thread (limit_blas_threads).

Checkpoints (``run(config, out)``): every ``checkpoint_seconds`` of wall time, after the last
step of a call (``max_steps_this_call``) and after the step during which SIGINT or SIGTERM
arrived, history.csv and then ``out/checkpoint.npz`` are written (continuum.checkpoint: the
state, the AMG matrix, the frame times, the rows and checksum of history.csv; verified, the one
before kept as ``checkpoint.prev.npz``). ``run`` with the same configuration (up to
EXECUTION_FIELDS) on that folder resumes from it (from the previous one when it is damaged),
drops the history rows and removes the frames written after it, and ends bit-identical to an
uninterrupted run; writing checkpoints changes no state, so the result does not depend on when
they happen. ``Simulation.save`` / ``Simulation.load`` write and read the same format. Before
each frame and checkpoint the run checks for continuum.output.RESERVE_BYTES of free space.
"""

from __future__ import annotations

import logging
import math
import sys
import time as _time
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from continuum import checkpoint, mesh, shapes
from continuum.budget import check_memory
from continuum.fem import ELEMENTS
from continuum.initial import meshed_state
from continuum.motion import heun_step, radius_rate, stable_dt
from continuum.pressure import PressureDivergence, PressureSolver, limit_blas_threads
from continuum.radial import R0
from continuum.remesh import remesh, remesh_reason
from continuum.sizes import (
    TRANSPORT_REMAP,
    TRANSPORTS,
    CharacteristicSizes,
    LengthGrid,
    SizeDistribution,
)
from continuum.state import State, StepRecord
from continuum.velocity import darcy_flow

__all__ = ["Config", "Simulation", "run", "config_fields"]

log = logging.getLogger(__name__)


def _number(v) -> bool:
    """A finite int or float (a bool is no number here)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return False
    try:
        return math.isfinite(v)
    except OverflowError:  # an int beyond the range of floats
        return False


#: The types of the fields' annotations: (test of a value, what the value must be).
_TYPES = {
    "float": (_number, "a number"),
    "int": (lambda v: isinstance(v, int) and not isinstance(v, bool), "an integer"),
    "str": (lambda v: isinstance(v, str), "a string"),
    "bool": (lambda v: isinstance(v, bool), "true or false"),
    "None": (lambda v: v is None, "None"),
}

_RULES = [  # (field, test, what the value must be), checked by Config.validate after the types
    ("n_nodes", lambda v: v >= 50, "an integer >= 50"),
    ("interior_coarsening", lambda v: v >= 1, ">= 1"),
    ("courant", lambda v: 0 < v <= 1.0, "in (0, 1]"),
    ("q_min", lambda v: 0 < v < 0.9, "in (0, 0.9)"),
    ("stretch", lambda v: v > 1.1, "> 1.1"),
    ("n_length_cells", lambda v: v >= 8, "an integer >= 8"),
    ("psi_transport", lambda v: v in TRANSPORTS, " or ".join(map(repr, TRANSPORTS))),
    ("element", lambda v: v in ELEMENTS, " or ".join(map(repr, ELEMENTS))),
    ("output_every", lambda v: v >= 0, ">= 0"),
    ("max_steps", lambda v: v > 0, "a positive integer"),
    ("checkpoint_seconds", lambda v: v >= 0, ">= 0"),
]


@dataclass
class Config:
    """Configuration of a continuum colony: the model, the numerics and the stop of ``run``.

    Attributes
    ----------
    lam : float
        Stress sensitivity lambda (finite).
    radius : float or None
        ``run`` stops when the colony radius sqrt(area/pi) reaches this value.
    time : float or None
        ``run`` stops at this time. ``run`` needs exactly one of ``radius`` and ``time``;
        a :class:`Simulation` at most one (the default goal of ``advance``).
    shape : str
        Initial shape (continuum.shapes): "circle" (radius ``initial_radius``), "circle:R",
        "ellipse:A,B", "rectangle:W,H[,ROUND]", "star:K,EPS[,R]" (R default
        ``initial_radius``) or "polygon:FILE.csv" (closed polygon, columns x,y).
    initial_radius : float
        Radius of the initial ``circle`` and of ``star:K,EPS`` (default R0 = sqrt(b/pi), one
        particle's area); the other shapes give their own sizes.
    n_nodes : int
        Target node count while the colony is small (h = h_N(area)).
    h_max : float
        Cap on the boundary mesh spacing h.
    interior_coarsening : float
        Interior mesh size up to this multiple of h (1 = uniform mesh).
    grading : float
        Growth of the interior mesh size with the distance d to the edge: min(c h, h + grading d).
    courant : float
        dt = courant * h_boundary / max u_boundary.
    q_min : float
        Remesh when a triangle's quality drops below this.
    stretch : float
        Remesh when boundary edges or the mean element size leave [h/stretch, stretch h].
    n_length_cells : int
        Cells of the log2-length grid of Psi.
    bump_width : float
        Half-width in s = log2 l of the initial bump standing in for delta(l - 1).
    psi_transport : str
        Transport of Psi in l: "characteristics-labels" (default: exact shift of per-node
        windows in s = log2 l, continuum.sizes.CharacteristicSizes; a remesh interpolates the
        rows by label, continuum.remesh: from a uniform Psi0 exact to round-off at radius 150),
        "characteristics" (the same transport; a remesh remaps the cells conservatively in s,
        which smears across rings: median error of the mean length 0.030 at radius 150) or
        "finite-volume" (flux-limited Lax-Wendroff, continuum.sizes.SizeDistribution).
    element : str
        Lagrange element of the pressure: "P1" (default: hand-written assembly, equal to
        scikit-fem's to round-off and faster; velocity by patch recovery and residual flux,
        continuum.velocity) or "P2" (scikit-fem, continuum.fem; isoparametric at the boundary;
        velocity from the element gradients at the vertices, one order more accurate; 6-12x
        the cost per solve on the same mesh, docs/benchmarks.md).
    output_every : float
        Time between field frames (VTU); 0 writes only the first and last.
    write_fields : bool
        Write the VTU series (history, boundary and config are always written).
    max_steps : int
        Safety limit on the number of time steps.
    checkpoint_seconds : float
        Wall time between checkpoints when writing to a folder (an execution setting,
        ``EXECUTION_FIELDS``: a checkpoint resumes under another value, with the same result).
    """

    lam: float = 0.0
    radius: float | None = None
    time: float | None = None
    shape: str = "circle"
    initial_radius: float = R0
    n_nodes: int = 2000
    h_max: float = 0.55
    interior_coarsening: float = 2.5
    grading: float = 0.05
    courant: float = 0.6
    q_min: float = 0.35
    stretch: float = 1.5
    n_length_cells: int = 40
    bump_width: float = 0.08
    psi_transport: str = "characteristics-labels"
    element: str = "P1"
    output_every: float = 1.0
    write_fields: bool = True
    max_steps: int = 200_000
    checkpoint_seconds: float = 300.0

    def validate(self, require_stop: bool = True) -> Config:
        """Check the values; raises ValueError with a one-line message. Returns self.

        ``require_stop``: exactly one of ``radius`` and ``time`` is required (else at most one).
        Every field's type first (``type_mismatch``), then the goal, the values and the shape.
        """
        for field in fields(self):
            value = getattr(self, field.name)
            what = self.type_mismatch(field.name, value)
            if what is not None:
                raise ValueError(f"{field.name} must be {what}, got {value!r}")
        if self.radius is not None and self.time is not None:
            raise ValueError("give exactly one of radius and time, not both")
        if require_stop and self.radius is None and self.time is None:
            raise ValueError("give exactly one of radius and time")
        positive = ["initial_radius", "h_max", "courant", "bump_width", "grading"]
        positive += [name for name in ("radius", "time") if getattr(self, name) is not None]
        rules = [(name, lambda v: v > 0, "a positive number") for name in positive]
        for name, ok, what in rules + _RULES:
            v = getattr(self, name)
            if not ok(v):
                raise ValueError(f"{name} must be {what}, got {v!r}")
        polygon = self.initial_boundary()  # parses and checks the shape
        if self.radius is not None:
            r_init = mesh.colony_radius(polygon)
            if self.radius < r_init:
                raise ValueError(
                    f"radius {self.radius} is smaller than the initial radius {r_init:.6g}"
                )
        return self

    @classmethod
    def type_mismatch(cls, name: str, value) -> str | None:
        """What field ``name`` takes (e.g. "a number") when ``value`` is not of its type, else None.

        The type is the field's annotation (``float | None``): float a finite int or float, never
        a bool; int an int, not a bool; str a string; bool True or False only; None.
        """
        kinds = [kind.strip() for kind in cls.__dataclass_fields__[name].type.split("|")]
        if any(_TYPES[kind][0](value) for kind in kinds):
            return None
        if "float" in kinds and isinstance(value, float):
            return "a finite number"
        return " or ".join(_TYPES[kind][1] for kind in kinds if kind != "None")

    def initial_boundary(self) -> np.ndarray:
        """A dense polygon of the initial shape (checked, counter-clockwise).

        continuum.shapes.outline of ``shape`` (``circle`` of radius ``initial_radius``, and the
        default R of ``star:K,EPS``); 256 vertices for a circle or an ellipse, the file's for
        a polygon. ``line:N`` (particles only) is refused.
        """
        return shapes.outline(self.shape, radius=self.initial_radius)


def initial_state(config: Config) -> State:
    """The colony at t = 0.

    The initial shape meshed at h = min(h_max, h_N(area)), G = 0, Psi the bump of
    ``bump_width``, p = 0 (u, g zero until the first pressure solve).
    """
    return meshed_state(config, config.initial_boundary(),
                        lambda points: initial_sizes(config, len(points)))


def initial_sizes(config: Config, n: int) -> SizeDistribution | CharacteristicSizes:
    """Psi0 on n nodes: the bump of ``bump_width`` in the class of ``psi_transport``."""
    grid = LengthGrid(config.n_length_cells)
    if config.psi_transport == "finite-volume":
        return SizeDistribution.bump(grid, n, width=config.bump_width)
    return CharacteristicSizes.bump(grid, n, width=config.bump_width,
                                    remap=TRANSPORT_REMAP[config.psi_transport])


def _target_spacing(config: Config, area: float) -> float:
    """Boundary mesh spacing min(h_max, h_N(area)) of this configuration."""
    return mesh.target_spacing(area, config.h_max, config.n_nodes)


class Simulation:
    """A growing continuum colony that a script steps, inspects and saves.

    Parameters
    ----------
    config : Config
        ``radius`` and ``time`` may both be None (they are the stop of :func:`run` and the
        default goal of :meth:`advance`).
    out : path, optional
        Existing run folder. When given, the simulation resumes from ``out/checkpoint.npz`` if
        there is one (same configuration up to ``checkpoint.EXECUTION_FIELDS``), else writes
        config.json and the first VTU frame; :meth:`step` then writes a frame every
        ``config.output_every`` of time, :meth:`advance` the final files at its goal
        (history.csv, boundary.csv, the last frame), and :meth:`save` defaults to
        ``out/checkpoint.npz``.
    initial : State, optional
        The state at t = 0 instead of the configured shape and bump (a copy is grown;
        continuum.initial.state_from builds one from a polygon and a Psi0). A checkpoint in
        ``out`` takes precedence.

    Attributes
    ----------
    config : Config
    state : State
        The one mutable state; :meth:`step` changes it in place.
    history : list of dict
        The history.csv rows: the initial state, then one per step (``StepRecord.row``).
    solver : PressureSolver
        The pressure solver (its AMG hierarchy is reused from step to step; a checkpoint
        saves its matrix).
    finished : bool
        False when :func:`run` stopped before its goal (``max_steps_this_call`` or a signal).

    Raises
    ------
    ValueError, BudgetError
        Bad configuration or checkpoint, or a mesh too large for the memory (continuum.budget).
    PressureDivergence
        No pressure solution on the initial shape.

    Examples
    --------
    >>> import continuum
    >>> sim = continuum.Simulation(continuum.Config(lam=1e-2))
    >>> record = sim.step()
    >>> state = sim.advance(radius=5.0)
    """

    def __init__(self, config: Config, out: Path | str | None = None,
                 initial: State | None = None):
        config.validate(require_stop=False)
        limit_blas_threads(1)
        self.config = config
        self.finished = True
        self.output = None if out is None else _Outputs(config, Path(out))
        if self.output is not None and checkpoint.checkpoint_files(self.output.out):
            path, (_, state, amg, history, frame_times, next_frame, _) = checkpoint.resume(
                self.output.out, config)
            self._restore(state, amg, history)
            self.output.resume(frame_times, next_frame)
            log.info("resuming from %s at t = %.6g (step %d)", path, state.t, state.step)
            return
        check_memory(config)
        self.solver = PressureSolver(config.lam, config.element)
        self.state = initial_state(config) if initial is None else initial.copy()
        self.solver.set_mesh(self.state.triangles, len(self.state.points), self.state.n_boundary)
        self._solve_flow()
        self.history = [StepRecord.of(self.state, 0.0, None).row()]
        if self.output is not None:
            self.output.start(self)

    def _restore(self, state: State, amg: np.ndarray | None, history: list) -> None:
        """Continue from a loaded state: the solver's topology and AMG hierarchy rebuilt."""
        self.solver = PressureSolver(self.config.lam, self.config.element)
        self.solver.set_mesh(state.triangles, len(state.points), state.n_boundary)
        self.solver.restore_amg(amg)
        self.state, self.history = state, history

    # ------------------------------------------------------------------ the physics
    def _flow(self, points: np.ndarray, p0: np.ndarray):
        """Darcy flow (p, u, g) at these node positions; counts iterations and times stages."""
        t0 = _time.perf_counter()
        p, u, g = darcy_flow(self.solver, points, p0, where=self.state.where())
        st, timings = self.solver.stats, self.state.timings
        timings["amg_setup"] += st.time_amg
        timings["krylov"] += st.time_krylov
        timings["assembly"] += _time.perf_counter() - t0 - st.time_amg - st.time_krylov
        self.state.newton += st.newton_iterations
        self.state.krylov += st.krylov_iterations
        return p, u, g

    def _solve_flow(self) -> None:
        """p, u, g of the current node positions (warm start: the current p)."""
        s = self.state
        s.p, s.u, s.g = self._flow(s.points, s.p)

    def _remesh_if_due(self) -> str | None:
        """Remesh when a criterion of continuum.remesh.remesh_reason holds; the reason or None."""
        s, cfg = self.state, self.config
        h = _target_spacing(cfg, s.area)
        reason = remesh_reason(s.points, s.triangles, s.n_boundary, h, cfg.q_min, cfg.stretch,
                               mean_h_target=s.h_mean_mesh * h / s.h_mesh)
        if reason is not None:
            self._remesh(h)
            log.debug("remeshed at t = %.6g (%s): %d nodes", s.t, reason, len(s.points))
        return reason

    def _remesh(self, h: float) -> None:
        s, cfg = self.state, self.config
        remesh(s, self.solver.assembler, h, cfg.interior_coarsening, cfg.grading)
        self.solver.set_mesh(s.triangles, len(s.points), s.n_boundary)
        self._solve_flow()

    def remesh(self) -> None:
        """Rebuild the mesh now, at the target spacing of the current area.

        continuum.remesh: G, Psi and p transferred; p, u, g solved on the new mesh.
        """
        self._remesh(_target_spacing(self.config, self.state.area))

    def _dt(self, radius: float | None, time: float | None) -> float:
        """The stable dt (continuum.motion.stable_dt), shortened to land on the goal.

        Radius: dt = (R_goal - R) / (dR/dt) when R + dt dR/dt >= R_goal; time: T - t when
        t + dt >= T.
        """
        s = self.state
        dt = stable_dt(s.boundary, s.u[: s.n_boundary], self.config.courant)
        if radius is not None:
            R, Rdot = s.radius, radius_rate(s.boundary, s.u[: s.n_boundary])
            if R + dt * Rdot >= radius:
                return max((radius - R) / max(Rdot, 1e-300), 1e-14)
        elif time is not None and s.t + dt >= time * (1 - 1e-12):
            return time - s.t
        return dt

    # ------------------------------------------------------------------ stepping
    def step(self, radius: float | None = None, time: float | None = None) -> StepRecord:
        """One time step; returns its record (also appended to ``history``).

        Remesh when due (continuum.remesh), then a Heun step (continuum.motion.heun_step) of
        the stable dt, shortened so as not to pass ``radius`` or ``time`` when given. With an
        output folder, a VTU frame when one is due (not at the goal: :meth:`advance` and
        :func:`run` write the last frame), and history.csv if the step fails.

        Parameters
        ----------
        radius : float, optional
            Colony radius R = sqrt(A/pi) not to pass (at most one of ``radius`` and ``time``).
        time : float, optional
            Time t not to pass.

        Returns
        -------
        StepRecord
            What the step did (one row of history.csv).

        Raises
        ------
        PressureDivergence
            No pressure solution, or elements invert even for tiny steps.
        """
        if radius is not None and time is not None:
            raise ValueError("give at most one of radius and time")
        try:
            reason = self._remesh_if_due()
            dt = heun_step(self.state, self._flow, self._dt(radius, time), self.config.lam)
        except PressureDivergence:
            if self.output is not None:  # keep the history up to the failure for diagnosis
                self.output.write_history(self)
            raise
        record = StepRecord.of(self.state, dt, reason)
        self.history.append(record.row())
        if self.output is not None:
            self.output.after_step(self, self.done(radius, time))
        return record

    def done(self, radius: float | None = None, time: float | None = None) -> bool:
        """Whether the colony has reached the goal.

        True once the colony radius >= ``radius`` (to 1e-7 relative) or t >= ``time`` (to
        1e-12 relative); False when both are None.
        """
        if radius is not None:
            return self.state.radius >= radius * (1 - 1e-7)
        return time is not None and self.state.t >= time * (1 - 1e-12)

    def _goal(self, radius: float | None, time: float | None) -> tuple[float | None, float | None]:
        """The goal of :meth:`advance`: the given one, else the configuration's (checked)."""
        if radius is None and time is None:
            radius, time = self.config.radius, self.config.time
            if radius is None and time is None:
                raise ValueError("give radius or time (or set one in the Config)")
        if radius is not None and time is not None:
            raise ValueError("give at most one of radius and time")
        for name, v in (("radius", radius), ("time", time)):
            if v is not None and not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive finite number, got {v!r}")
        return radius, time

    def _check_max_steps(self) -> None:
        if len(self.history) > self.config.max_steps:
            raise RuntimeError(
                f"max_steps={self.config.max_steps} reached at {self.state.where()}")

    def advance(self, radius: float | None = None, time: float | None = None,
                progress: bool = False) -> State:
        """Step until the colony reaches ``radius`` or ``time`` (both None: the config's goal).

        The steps are those of :func:`run` to the same goal, the last one shortened to land on
        it: ``advance(radius=R)`` of a new simulation gives the bits of
        ``run(Config(..., radius=R))``. With an output folder, the final files are written at
        the goal (history.csv, boundary.csv, the last frame).

        Parameters
        ----------
        radius : float, optional
            Goal for the colony radius R = sqrt(A/pi).
        time : float, optional
            Goal for t (at most one of ``radius`` and ``time``; both None: ``Config.radius`` /
            ``Config.time``).
        progress : bool
            tqdm progress bar (only when stderr is a terminal).

        Returns
        -------
        State
            ``state``, the live object (``State.copy`` keeps it as it is now).

        Raises
        ------
        RuntimeError
            ``config.max_steps`` steps taken.
        PressureDivergence
            No pressure solution (e.g. lam < 0 beyond the critical size).
        """
        radius, time = self._goal(radius, time)
        steps = 0
        with _ProgressBar(self, radius, time, progress) as bar:
            while not self.done(radius, time):
                self._check_max_steps()
                bar.show(self.step(radius, time))
                steps += 1
        if self.output is not None and steps:
            self.output.finish(self)
        return self.state

    @property
    def fields(self) -> dict[str, np.ndarray]:
        """The nodal fields of the current state (``State.fields``)."""
        return self.state.fields

    # ------------------------------------------------------------------ checkpoints
    def save(self, path: Path | str | None = None) -> Path:
        """Write a checkpoint (continuum.checkpoint; atomic) to ``path``; returns the path.

        Default out/checkpoint.npz. :meth:`load` (and :func:`run` on its folder) continues
        from it bit-identically. The run folder's checkpoint: history.csv first, which the
        checkpoint refers to (its size stays that of the mesh), and the checkpoint it replaces
        kept as checkpoint.prev.npz; elsewhere the checkpoint holds the history rows.
        """
        if path is None:
            if self.output is None:
                raise ValueError("give a path: this simulation has no output folder")
            path = self.output.checkpoint
        path = Path(path)
        frame_times, next_frame, history = [], math.inf, self.history
        if self.output is not None:
            frame_times, next_frame = self.output.frame_times(), self.output.next_frame
        elif self.config.output_every > 0:
            every = self.config.output_every
            next_frame = every * (math.floor(self.state.t / every) + 1)
        if self.output is not None and path == self.output.checkpoint:
            self.output.ensure_space(self)
            self.output.write_history(self)
            history = checkpoint.history_record(self.output.out / checkpoint.HISTORY,
                                                len(self.history))
        checkpoint.save(path, self.config, self.state, self.solver.amg_state(), history,
                        frame_times, next_frame, self.done(self.config.radius, self.config.time))
        return path

    @classmethod
    def load(cls, path: Path | str, config: Config | None = None) -> Simulation:
        """The simulation saved at ``path`` (:meth:`save`, or a run's checkpoint.npz).

        ``config``: the configuration to continue with, equal to the saved one up to
        ``checkpoint.EXECUTION_FIELDS`` (ValueError otherwise); None: the saved one. The
        result writes no output.
        """
        saved, state, amg, history, *_ = checkpoint.load(Path(path), config)
        sim = cls.__new__(cls)
        if config is None:
            config = checkpoint.checked(Path(path), lambda: Config(**saved))
        sim.config = config.validate(require_stop=False)
        sim.finished, sim.output = True, None
        limit_blas_threads(1)
        sim._restore(state, amg, history)
        return sim


class _ProgressBar:
    """tqdm bar of the radius or time reached (only when asked and stderr is a terminal)."""

    def __init__(self, sim: Simulation, radius: float | None, time: float | None,
                 progress: bool):
        from tqdm import tqdm

        self.by_radius = radius is not None
        self.start = sim.history[0]["radius"] if self.by_radius else 0.0
        goal = radius if self.by_radius else time
        self.bar = tqdm(total=round(goal - self.start, 6),
                        disable=not (progress and sys.stderr.isatty()),
                        unit="R" if self.by_radius else "t", leave=False)

    def show(self, record: StepRecord) -> None:
        now = record.radius if self.by_radius else record.t
        self.bar.update(round(now - self.start, 6) - self.bar.n)

    def __enter__(self) -> _ProgressBar:
        return self

    def __exit__(self, *exc) -> None:
        self.bar.close()


class _Outputs:
    """The files of a simulation in its run folder (continuum.output).

    config.json, VTU frames every ``output_every``, history.csv, boundary.csv, the checkpoint.
    """

    def __init__(self, config: Config, out: Path):
        from continuum import output

        if not out.is_dir():
            raise ValueError(f"output folder does not exist: {out}")
        self.output, self.config, self.out = output, config, out
        self.checkpoint = out / checkpoint.CHECKPOINT
        self.fields = output.FieldWriter(out) if config.write_fields else None
        self.next_frame = config.output_every if config.output_every > 0 else math.inf

    def start(self, sim: Simulation) -> None:
        """config.json and the first frame of a new run."""
        self.output.write_config(self.out, self.config)
        self.frame(sim)

    def resume(self, frame_times: list, next_frame: float) -> None:
        """Continue the frames of a checkpoint (those written after it removed)."""
        self.next_frame = next_frame
        if self.fields is not None:
            self.fields.resume(frame_times)

    def frame_times(self) -> list:
        """The times of the frames written."""
        return [] if self.fields is None else self.fields.times

    def ensure_space(self, sim: Simulation) -> None:
        """continuum.output.ensure_space before the next frame or checkpoint of ``sim``."""
        self.output.ensure_space(self.out, len(sim.state.points), self.checkpoint)

    def frame(self, sim: Simulation) -> None:
        if self.fields is not None:
            s = sim.state
            self.ensure_space(sim)
            self.fields.write(s.t, s.points, s.triangles, s.fields)

    def after_step(self, sim: Simulation, done: bool) -> None:
        """A frame when one is due, except at the goal (:meth:`finish` writes it)."""
        if self.fields is not None and sim.state.t >= self.next_frame and not done:
            self.frame(sim)
            self.next_frame += self.config.output_every

    def write_history(self, sim: Simulation) -> None:
        self.output.write_history(self.out, sim.history)

    def finish(self, sim: Simulation) -> None:
        """history.csv, boundary.csv and the last frame, at the goal."""
        self.ensure_space(sim)
        self.write_history(sim)
        self.output.write_boundary(self.out, sim.state.boundary)
        self.frame(sim)


# ---------------------------------------------------------------------------- run


def run(
    config: Config,
    out: Path | str | None = None,
    progress: bool = False,
    max_steps_this_call: int | None = None,
    initial: State | None = None,
) -> Simulation:
    """Grow the colony until ``config.radius`` or ``config.time``; optionally write ``out``.

    The loop over :meth:`Simulation.step` that hands each step to the run folder's writers,
    the checkpointer and the progress bar.

    Parameters
    ----------
    config : Config
        With exactly one of ``radius`` and ``time``.
    out : Path, optional
        Existing folder: config.json, history.csv, boundary.csv, fields.pvd + fields/, and
        checkpoint.npz every ``config.checkpoint_seconds``. If it holds a checkpoint of the
        same configuration (up to EXECUTION_FIELDS) the run resumes from it, with a result
        bit-identical to an uninterrupted run's (files and arrays). The caller removes
        checkpoint.npz after a finished run.
    progress : bool
        Show a tqdm progress bar (only when stderr is a terminal).
    max_steps_this_call : int, optional
        Stop after this many steps of this call, writing a checkpoint (as if interrupted);
        the returned simulation has ``finished = False``.
    initial : State, optional
        The state at t = 0 (:class:`Simulation`).

    Returns
    -------
    Simulation
        ``.state`` the final state (``.state.fields``, ``.state.points``, ...), ``.history``
        one row per step, ``.finished``.

    SIGINT, SIGTERM or SIGHUP in the main thread ends the run after the current step (remeshing
    and output included) with a checkpoint of that step, then raises KeyboardInterrupt (SIGINT)
    or SystemExit(128 + signum) (SIGTERM, SIGHUP); a second signal acts at once.

    Raises
    ------
    ValueError
        Bad configuration, or a checkpoint of another configuration in ``out``.
    BudgetError
        The mesh would not fit in memory.
    PressureDivergence
        No pressure solution (e.g. lam < 0 beyond the critical size).
    """
    config.validate()
    stop = checkpoint.StopRequest().install()
    try:
        sim = Simulation(config, out, initial)
        _steps(sim, progress, max_steps_this_call, stop)
    finally:
        stop.restore()
    stop.act()
    return sim


def _steps(sim: Simulation, progress: bool, max_steps_this_call: int | None,
           stop: checkpoint.StopRequest) -> None:
    """The loop of ``run``.

    Step until the goal, a stop request or ``max_steps_this_call`` steps; history.csv and a
    checkpoint every ``checkpoint_seconds`` and when stopping; the final files at the goal.
    """
    config = sim.config
    goal = {"radius": config.radius, "time": config.time}
    last_checkpoint = _time.monotonic()
    steps_here = 0
    with _ProgressBar(sim, progress=progress, **goal) as bar:
        while not sim.done(**goal):
            sim._check_max_steps()
            bar.show(sim.step(**goal))
            steps_here += 1
            done = sim.done(**goal)
            pause = not done and max_steps_this_call is not None
            pause = pause and steps_here >= max_steps_this_call
            due = not done and _time.monotonic() - last_checkpoint >= config.checkpoint_seconds
            if sim.output is not None and (stop.signum is not None or pause or due):
                sim.save()  # history.csv, then the checkpoint
                last_checkpoint = _time.monotonic()
            if stop.signum is not None or pause:
                sim.finished = done
                break
    if sim.output is not None and sim.done(**goal):
        sim.output.finish(sim)


def config_fields() -> list[str]:
    """Names of the Config fields (for the command line)."""
    return [f.name for f in fields(Config)]
