"""The continuum colony as a simulation: the stepping and a run (the engine contract).

Model (model.md): on Omega(t), u = -grad p, div u = g = exp(-lam p), p = 0 on the boundary,
the boundary moves with u; the growth phase G = int g dt and the size distribution Psi(x, l, t)
are carried by the material. Initial condition: a disc of radius R0 = sqrt(b/pi) (or the given
shape), G = 0, Psi0 = delta(l - 1) carried exactly by its position (``Config.initial_sizes``;
a smooth bump or a histogram on the l grid as options; continuum.sizes).

The contract, the particle engine's too (docs/DESIGN.md, "One contract for both engines";
tests/test_contract.py): ``Simulation(config, state=None, out=None)`` holds the
:class:`~continuum.state.State` (a copy of ``state``) and the pressure solver.
``Simulation.step(time=None)`` is one time step: remesh when due (continuum.remesh), then
Heun's RK2 for the nodes, G and Psi with two pressure solves (continuum.motion,
continuum.darcy.darcy_flow), dt = courant * h / u_edge (continuum.motion.stable_dt) shortened
so as not to pass ``time``; it returns a :class:`~continuum.state.StepRecord`.
``Simulation.done(radius=None, time=None)`` says whether a goal is reached (:func:`reached`) and
``Simulation.advance(radius=None, time=None)`` steps until the first of the goals is reached,
the last step shortened to land on it. :func:`run` is the loop of a run to ``config.radius`` or
``config.time`` that hands each step to the output writers (continuum.output), the
checkpointer (continuum.checkpoint) and the progress bar, and writes the final files.

Mesh size: boundary edge length h = min(h_max, h_N(area)) with h_N the size giving about
``n_nodes`` nodes on the current area (continuum.mesh.target_spacing): a fixed node count while
the colony is small, a capped spacing later. With ``interior_coarsening`` c > 1 the interior
size grows away from the edge up to c h (graded mesh, fewer nodes where nothing happens fast).

Determinism: a configuration gives the same bits in any process (history, fields, files).
The one random ingredient, pyamg's spectral-radius estimate in the AMG setup, runs with a
fixed seed (continuum.pressure.amg_hierarchy); Triangle's meshing is deterministic and
independent of earlier calls; BLAS runs on one thread (limit_blas_threads).

Checkpoints (``run(config, out)``): every ``checkpoint_seconds`` of wall time, after the last
step of a call (``max_steps``) and after the step during which SIGINT, SIGTERM or SIGHUP
arrived, history.csv and then ``out/checkpoint.npz`` are written (continuum.checkpoint: the
state, the AMG matrix, the frame times, the rows and checksum of history.csv; verified, the one
before kept as ``checkpoint.prev.npz``). ``run`` with the same configuration (up to
EXECUTION_FIELDS) on that folder resumes from it (from the previous one when it is damaged),
drops the history rows and removes the frames written after it, and ends bit-identical to an
uninterrupted run; writing checkpoints changes no state, so the result does not depend on when
they happen. ``Simulation.save`` / ``Simulation.load`` write and read the same format. Before
each frame and checkpoint the run checks for continuum.runfiles.RESERVE_BYTES of free space.
"""

from __future__ import annotations

import logging
import math
import time as _time
from pathlib import Path

import numpy as np

from continuum import checkpoint, mesh
from continuum.budget import check_memory
from continuum.config import Config  # noqa: F401 (older imports)
from continuum.darcy import darcy_flow
from continuum.initial import meshed_state
from continuum.motion import heun_step, radius_rate, stable_dt
from continuum.pressure import PressureDivergence, PressureSolver, limit_blas_threads
from continuum.remesh import remesh, remesh_reason
from continuum.runfiles import (
    CHECKPOINT,
    HISTORY,
    StopRequest,
    advance,
    check_goal,
    check_state_type,
    checkpoint_files,
    drive,
    goal_of,
    history_record,
    reached,
    require_goal,
)
from continuum.sizes import (
    CharacteristicSizes,
    DeltaSizes,
    LengthGrid,
)
from continuum.state import State, StepRecord
from continuum.strains import check_fractions, fractions_at, parse_layout, slope_scale

# Config lives in continuum.config; imported here for older imports
# (``from continuum.simulation import Config``), documented there.
__all__ = ["Simulation", "run"]

log = logging.getLogger(__name__)

def initial_state(config: Config) -> State:
    """The colony at t = 0.

    The initial shape meshed at h = min(h_max, h_N(area)), G = 0, Psi0 of ``initial_sizes``
    (:func:`initial_sizes`), p = 0 (u, g zero until the first pressure solve).
    """
    if config.initial_sizes == "histogram":
        raise ValueError("initial_sizes 'histogram' is a Psi0 given with the state "
                         "(continuum.state_from, e.g. colony continuum --from-particles); "
                         "without one use 'delta' or 'bump'")
    return meshed_state(config, config.initial_boundary(),
                        lambda points: initial_sizes(config, len(points)))


def initial_sizes(config: Config, n: int
                  ) -> DeltaSizes | CharacteristicSizes:
    """Psi0 on n nodes (``initial_sizes``).

    "delta": delta(l - 1) carried by its position (DeltaSizes); "bump": the bump of
    ``bump_width`` along the characteristics (``psi_transport``).
    """
    if config.initial_sizes == "delta":
        return DeltaSizes.delta(n)
    grid = LengthGrid(config.n_length_cells)
    return CharacteristicSizes.bump(grid, n, width=config.bump_width)


def _solver(config: Config) -> PressureSolver:
    """The pressure solver of ``config``: its element, its strains or its nutrient.

    With strains its lam is the largest lam_i (continuum.strains.slope_scale; ``lam`` is the
    one strain's).
    """
    if not config.strains:
        return PressureSolver(config.lam, config.element, nutrient=config.nutrient)
    return PressureSolver(slope_scale(config.strains), config.element, strains=config.strains)


def initial_fractions(config: Config, state: State, layout=None) -> None:
    """Set the strain fractions phi and phases G_i = 0 of a state at t = 0 (in place).

    ``layout`` (``Simulation``; else ``config.layout`` parsed): the fractions as a callable
    phi0(x, y) or nodal values, checked
    (continuum.strains.fractions_at); None keeps the state's phi, or sets all 1 for a single
    strain. Without ``config.strains`` the state stays as it is (no fractions allowed).

    Raises
    ------
    ValueError
        Fractions without strains, none for S >= 2 strains, or bad ones (one line).
    """
    n_strains = len(config.strains)
    if layout is None and config.layout is not None:
        layout = parse_layout(config.layout, n_strains)
    if n_strains == 0:
        if layout is not None or state.phi is not None:
            raise ValueError("strain fractions need strains in the Config (Config.strains)")
        return
    n = len(state.points)
    if layout is not None:
        state.phi = fractions_at(layout, state.points, n_strains)
        absent = [i for i in range(n_strains) if not np.any(state.phi[:, i] > 0)]
        if absent:
            log.warning("strain(s) %s absent from the initial colony: the layout %s places "
                        "them outside it", ", ".join(map(str, absent)),
                        config.layout or "given")
    elif state.phi is not None:
        state.phi = check_fractions(state.phi, n, n_strains)
    elif n_strains == 1:
        state.phi = np.ones((n, 1))
    else:
        raise ValueError(f"give the initial fractions of the {n_strains} strains "
                         "(layout=phi0, e.g. continuum.strains.core(r1))")
    if state.G_strains is None or state.G_strains.shape != (n, n_strains):
        state.G_strains = np.zeros((n, n_strains))


def _target_spacing(config: Config, area: float) -> float:
    """Boundary mesh spacing min(h_max, h_N(area)) of this configuration."""
    return mesh.target_spacing(area, config.h_max, config.n_nodes)


def _check_state_type(state) -> None:
    """TypeError (one line) unless ``state`` is a State or None (runfiles.check_state_type)."""
    check_state_type(state, State, "continuum.State (e.g. of continuum.state_from; or None: "
                     "the configured shape)")


class Simulation:
    """A growing continuum colony that a script steps, inspects and saves.

    The engine contract (the particle engine's ``Simulation`` has the same methods with the
    same meaning; docs/DESIGN.md, tests/test_contract.py).

    Parameters
    ----------
    config : Config
        ``radius`` and ``time`` may both be None (they are the stop of :func:`run` and the
        default goal of :meth:`advance` and :meth:`done`).
    state : State, optional
        The state at t = 0 instead of the configured shape and bump; a copy is grown (the
        given object is not changed). continuum.initial.state_from builds one from a polygon
        and a Psi0. A checkpoint in ``out`` takes precedence.
    out : path, optional
        Existing run folder. When given, the simulation resumes from ``out/checkpoint.npz`` if
        there is one (same configuration up to ``checkpoint.EXECUTION_FIELDS``), else writes
        config.json and the first VTU frame; :meth:`step` then writes a frame every
        ``config.output_every`` of time (not at a goal of :meth:`advance`), and :meth:`save`
        defaults to ``out/checkpoint.npz``. The final files (history.csv, boundary.csv, the
        last frame) are :func:`run`'s.
    layout : callable or ndarray, optional
        The initial strain fractions phi0 of ``config.strains`` (continuum.strains): a callable
        phi0(x, y) -> (n, S) evaluated at the nodes (e.g. continuum.strains.core(r1)), or the
        (n_nodes, S) values at the nodes of ``state``; rows in [0, 1] summing to 1. Needed for
        S >= 2 strains unless ``state`` carries them (``State.phi``); one strain: all 1. Not
        allowed without strains. A checkpoint in ``out`` takes precedence.

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
        False when :func:`run` stopped before its goal (``max_steps``, a signal, or paused).
    paused : bool
        True when :func:`run` paused at ``config.max_hours`` (the same call resumes it).

    Raises
    ------
    ValueError, BudgetError
        Bad checkpoint, or a mesh too large for the memory (continuum.budget).
    TypeError
        ``state`` is not a State.
    PressureDivergence
        No pressure solution on the initial shape.

    Examples
    --------
    >>> import continuum
    >>> sim = continuum.Simulation(continuum.Config(lam=1e-2))
    >>> record = sim.step()
    >>> state = sim.advance(radius=5.0)
    """

    def __init__(self, config: Config, state: State | None = None,
                 out: Path | str | None = None, *, layout=None):
        limit_blas_threads(1)
        _check_state_type(state)
        self.config = config
        self.finished, self.paused = True, False
        resume = out is not None and Path(out).is_dir() and checkpoint_files(Path(out))
        if not resume:  # before any file: the fields/ folder of the outputs included
            check_memory(config, start=None if state is None else (state.boundary, state.t))
        self.output = None if out is None else _Outputs(config, Path(out))
        if resume:
            path, saved = checkpoint.resume_checkpoint(self.output.out, config)
            self._restore(saved.state, saved.amg, saved.history)
            self.output.resume(saved.frames, saved.next_frame)
            log.info("resuming from %s at t = %.6g (step %d)", path, saved.state.t,
                     saved.state.step)
            return
        self.solver = _solver(config)
        self.state = initial_state(config) if state is None else state.copy()
        self.state.nutrient_length = config.nutrient_length
        initial_fractions(config, self.state, layout)
        self._set_mesh()
        self._solve_flow()
        self.history = [StepRecord.of(self.state, 0.0, None).row()]
        if self.output is not None:
            self.output.start(self)

    def _restore(self, state: State, amg: np.ndarray | None, history: list) -> None:
        """Continue from a loaded state: the solver's topology and AMG hierarchy rebuilt."""
        self.solver = _solver(self.config)
        self.state, self.history = state, history
        self.state.nutrient_length = self.config.nutrient_length
        self._set_mesh()
        self.solver.restore_amg(amg)

    # ------------------------------------------------------------------ the physics
    def _set_mesh(self) -> None:
        """The solver on the state's mesh (and strain fractions)."""
        s = self.state
        self.solver.set_mesh(s.triangles, len(s.points), s.n_boundary, s.phi)

    def _flow(self, points: np.ndarray, p0: np.ndarray, fractions: np.ndarray | None = None):
        """Darcy flow (p, u, g) at these node positions; counts iterations and times stages.

        ``fractions``: the strain fractions to solve with (strains; the solver keeps them).
        """
        if fractions is not None:
            self.solver.set_fractions(fractions)
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
        self._set_mesh()
        self._solve_flow()

    def remesh(self) -> None:
        """Rebuild the mesh now, at the target spacing of the current area.

        continuum.remesh: G, Psi and p transferred; p, u, g solved on the new mesh.
        """
        self._remesh(_target_spacing(self.config, self.state.area))

    def _dt(self, radius: float | None, time: float | None) -> float:
        """The stable dt (continuum.motion.stable_dt), shortened to land on the first goal.

        Radius: dt = (R_goal - R) / (dR/dt) when R + dt dR/dt >= R_goal; time: T - t when
        t + dt >= T (1 - 1e-12).
        """
        s = self.state
        dt = stable_dt(s.boundary, s.u[: s.n_boundary], self.config.courant)
        if radius is not None:
            R, Rdot = s.radius, radius_rate(s.boundary, s.u[: s.n_boundary])
            if R + dt * Rdot >= radius:
                dt = max((radius - R) / max(Rdot, 1e-300), 1e-14)
        if time is not None and s.t + dt >= time * (1 - 1e-12):
            return time - s.t
        return dt

    # ------------------------------------------------------------------ stepping
    def step(self, time: float | None = None) -> StepRecord:
        """One time step, not past ``time``; returns its record (also appended to ``history``).

        Remesh when due (continuum.remesh), then a Heun step (continuum.motion.heun_step) of
        the stable dt, shortened to land on ``time`` when given. With an output folder, a VTU
        frame when one is due, and history.csv if the step fails.

        Parameters
        ----------
        time : float, optional
            Time t not to pass (ValueError when it is reached already).

        Returns
        -------
        StepRecord
            What the step did (one row of history.csv).

        Raises
        ------
        PressureDivergence
            No pressure solution, or elements invert even for tiny steps.
        """
        check_goal(None, time)
        if self._reached(None, time):
            raise ValueError(f"time {time:g} is reached already (t = {self.state.t:.17g})")
        return self._step(None, time)

    def _step(self, radius: float | None, time: float | None) -> StepRecord:
        """:meth:`step`, shortened also so as not to pass the colony radius ``radius``.

        The frame due at the end of the step is not written when the step reaches its goal
        (:func:`run` writes the last frame).
        """
        try:
            reason = self._remesh_if_due()
            dt = heun_step(self.state, self._flow, self._dt(radius, time), self.solver.lam,
                           self.solver.strains)
        except PressureDivergence:
            if self.output is not None:  # keep the history up to the failure for diagnosis
                self.output.write_history(self)
            raise
        record = StepRecord.of(self.state, dt, reason)
        self.history.append(record.row())
        if self.output is not None:
            self.output.after_step(self, self._reached(radius, time))
        return record

    def done(self, radius: float | None = None, time: float | None = None) -> bool:
        """Whether the first of the goals is reached (both None: the configuration's goal).

        The colony radius R = sqrt(A/pi) >= ``radius`` (1 - RADIUS_RTOL), or
        t >= ``time`` - TIME_TOL max(1, ``time``) (:func:`reached`).

        Raises
        ------
        ValueError
            No goal given and none in the configuration, or a goal not a positive number.
        """
        return self._reached(*goal_of(self.config, radius, time))

    def _reached(self, radius: float | None, time: float | None) -> bool:
        """:func:`reached` of the current state (False without a goal)."""
        return reached(lambda: self.state.radius, self.state.t, radius, time)

    def step_toward(self, radius: float | None, time: float | None) -> StepRecord:
        """One step of :meth:`advance` and :func:`run`: not past ``radius`` nor ``time``.

        RuntimeError beyond ``config.step_limit`` steps.
        """
        if len(self.history) > self.config.step_limit:
            raise RuntimeError(
                f"step_limit={self.config.step_limit} reached at {self.state.where()}")
        return self._step(radius, time)

    def check_budget(self, radius: float | None, time: float | None) -> None:
        """A goal whose mesh would not fit in memory refused before any step (BudgetError).

        continuum.budget.check_memory from the current state; nothing when it is reached.
        """
        if not self._reached(radius, time):
            check_memory(self.config, start=(self.state.boundary, self.state.t),
                         goal=(radius, time))

    @property
    def label(self) -> str:
        """The progress bar's label."""
        return f"continuum lam={self.config.lam:g}"

    def finish(self) -> None:
        """The final files of :func:`run` at its goal (nothing when it stopped before)."""
        if self.done():
            self.output.finish(self)

    def advance(self, radius: float | None = None, time: float | None = None,
                progress: bool = False) -> State:
        """Step until the colony reaches ``radius`` or ``time``, whichever comes first.

        Both None: the configuration's goal. The steps are those of :func:`run` to the same
        goal, the last one shortened to land on it: ``advance(radius=R)`` of a new simulation
        gives the bits of ``run(Config(..., radius=R))``. No step when the goal is reached
        already. With an output folder the frames are written as :meth:`step` writes them; the
        final files are :func:`run`'s (or :meth:`save`'s history.csv).

        Parameters
        ----------
        radius : float, optional
            Goal for the colony radius R = sqrt(A/pi).
        time : float, optional
            Goal for t.
        progress : bool
            A tqdm progress bar when stderr is a terminal, else a log line every
            runfiles.PROGRESS_SECONDS.

        Returns
        -------
        State
            ``state``, the live object (``State.copy`` keeps it as it is now).

        Raises
        ------
        ValueError
            No goal (:meth:`done`).
        BudgetError
            The mesh at the goal would not fit in memory (continuum.budget.check_memory from
            the current state), before any step.
        RuntimeError
            ``config.step_limit`` steps taken.
        PressureDivergence
            No pressure solution (e.g. lam < 0 beyond the critical size).
        """
        return advance(self, radius, time, progress)

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
            history = history_record(self.output.out / HISTORY, len(self.history))
        checkpoint.save_checkpoint(path, checkpoint.Checkpoint(
            self.config, self.state, history, frame_times, self.solver.amg_state(), next_frame,
            self._reached(self.config.radius, self.config.time)))
        return path

    @classmethod
    def load(cls, path: Path | str, config: Config | None = None) -> Simulation:
        """The simulation saved at ``path`` (:meth:`save`, or a run's checkpoint.npz).

        ``config``: the configuration to continue with, equal to the saved one up to
        ``checkpoint.EXECUTION_FIELDS`` (ValueError otherwise); None: the saved one. The
        result writes no output; stepping it gives the bits the saved simulation would have.
        """
        saved = checkpoint.load_checkpoint(Path(path), config)
        sim = cls.__new__(cls)
        sim.config = saved.config
        sim.finished, sim.output = True, None
        limit_blas_threads(1)
        sim._restore(saved.state, saved.amg, saved.history)
        return sim


class _Outputs:
    """The files of a simulation in its run folder (continuum.output).

    config.json, VTU frames every ``output_every``, history.csv, boundary.csv, the checkpoint.
    """

    def __init__(self, config: Config, out: Path):
        from continuum import output

        if not out.is_dir():
            raise ValueError(f"output folder does not exist: {out}")
        self.output, self.config, self.out = output, config, out
        self.checkpoint = out / CHECKPOINT
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
        s = sim.state
        self.output.ensure_space(self.out, len(s.points), self.checkpoint,
                                 0 if s.phi is None else s.phi.shape[1])

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
        """history.csv, boundary.csv, the last frame, and with S >= 2 strains interfaces.csv."""
        self.ensure_space(sim)
        self.write_history(sim)
        s = sim.state
        self.output.write_boundary(self.out, s.boundary)
        if s.phi is not None and s.phi.shape[1] > 1:
            self.output.write_interfaces(self.out, s.points, s.triangles, s.phi)
        self.frame(sim)


# ---------------------------------------------------------------------------- run


def run(config: Config, out: Path | str | None = None, progress: bool = False,  # noqa: PLR0913
        state: State | None = None, max_steps: int | None = None, *,
        layout=None, started: float | None = None) -> Simulation:
    """Grow the colony until ``config.radius`` or ``config.time``; optionally write ``out``.

    The run loop both engines share (runfiles.drive) over the steps of a :class:`Simulation`:
    each step's frames, the checkpoints and the progress bar, and the final files at the goal.

    Parameters
    ----------
    config : Config
        With one of ``radius`` and ``time``.
    out : Path, optional
        Existing folder: config.json, history.csv, boundary.csv, fields.pvd + fields/, and
        checkpoint.npz every ``config.checkpoint_seconds``. If it holds a checkpoint of the
        same configuration (up to EXECUTION_FIELDS) the run resumes from it, with a result
        bit-identical to an uninterrupted run's (files and arrays). The caller removes
        checkpoint.npz after a finished run.
    progress : bool
        A tqdm progress bar when stderr is a terminal, else a log line (INFO, the logger
        ``continuum.runfiles``) every runfiles.PROGRESS_SECONDS.
    state : State, optional
        The state at t = 0 of a new run (:class:`Simulation`; copied); unused when ``out``
        holds a checkpoint.
    max_steps : int, optional
        Stop after this many steps of this call, writing a checkpoint (as if interrupted);
        the returned simulation has ``finished = False``. (``Config.step_limit`` is the most
        steps a run may take in all, an error beyond.)
    layout : callable or ndarray, optional
        The initial strain fractions of ``config.strains`` (:class:`Simulation`).
    started : float, optional
        The time.monotonic() reading ``config.max_hours`` counts from (the command line gives
        its process's start); default: this call's.

    Returns
    -------
    Simulation
        ``.state`` the final state (``.state.fields``, ``.state.points``, ...), ``.history``
        one row per step, ``.finished``, ``.paused`` (stopped by ``config.max_hours``: the
        same call resumes it).

    SIGINT, SIGTERM or SIGHUP in the main thread ends the run after the current step (remeshing
    and output included) with a checkpoint of that step, then raises KeyboardInterrupt (SIGINT)
    or SystemExit(128 + signum) (SIGTERM, SIGHUP); a second signal acts at once
    (runfiles.StopRequest). Before ``config.max_hours`` of wall have passed, the run writes a
    checkpoint and returns paused (``.paused``; runfiles.WallLimit).

    Raises
    ------
    ValueError
        No goal in ``config``, or a checkpoint of another configuration in ``out``.
    BudgetError
        The mesh would not fit in memory.
    PressureDivergence
        No pressure solution (e.g. lam < 0 beyond the critical size).
    """
    require_goal(config)
    with StopRequest() as stop:
        sim = Simulation(config, state, out, layout=layout)
        drive(sim, stop, max_steps, started, progress)
    stop.reraise()
    return sim
