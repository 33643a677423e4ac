"""The particle simulation: ``Simulation`` (state, ``step``, ``advance``, checkpoints) and ``run``.

In the manner of Dedalus's solver (``step``, ``evolve``) and JAX-MD's ``init_fn`` / ``apply_fn``:
one explicit mutable state (``state.ParticleState``), a ``step()`` that advances it by one
time step (stepping.robust_step: detect, solve, move and grow, re-solve, halving; then the
division rule and the spatial order, stepping.divide_in_order) and returns a typed
:class:`StepRecord` of what happened, and
:func:`run`, a short loop that hands each step to the output writers (output.RunOutput), the
checkpointer (checkpoint.py) and the progress bar.

>>> import particles
>>> sim = particles.Simulation(particles.Config(lam=1e-2, seed=1))
>>> record = sim.step()
>>> state = sim.advance(radius=6.0)
"""

from __future__ import annotations

import logging
import sys
import time as _time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from .checkpoint import (
    HISTORY,
    NO_FRAMES,
    StopRequest,
    checkpoint_config,
    checkpoint_files,
    history_record,
    load_checkpoint,
    resume_checkpoint,
    save_checkpoint,
)
from .config import STEP_POLICY_FIELDS, Config
from .output import RunOutput, write_config, write_history
from .packings import from_csv, single_cell
from .state import ParticleState
from .stepping import Detections, detect, divide_in_order, next_dt, robust_step

log = logging.getLogger(__name__)

__all__ = ["ParticleLimitError", "Simulation", "StepRecord", "check_initial", "initial_state",
           "run"]


class ParticleLimitError(RuntimeError):
    """The colony exceeded ``Config.max_particles``."""


@dataclass(frozen=True)
class StepRecord:
    """What one step did: the row of history.csv (output.HISTORY_COLUMNS).

    Attributes
    ----------
    step : int
        Steps since t = 0, this one included.
    t, dt : float
        Time after the step and the step's length.
    radius, hull_radius : float
        Enclosing and hull radius of the colony after the step (measures.py).
    n_particles : int
        N after the step's divisions.
    max_stress, mean_stress : float
        Largest and mean axial stress sigma.
    max_overlap : float
        Largest real overlap b - d after the re-solve passes (<= ``Config.tol``).
    iterations, pass_iterations, failed_iterations : int
        Solver iterations of the main solves and passes together, of the passes alone, and of
        attempts that failed and were redone as half steps.
    passes : int
        Re-solve passes.
    n_contacts : int
        Contacts of the (last) main solve.
    residual : float
        Largest final residual of the main solves.
    total_length : float
        sum_n l_n.
    divisions : int
        Particles that divided.
    substeps : int
        1, or the number of half steps the step was redone as.
    max_rotation, max_displacement : float
        Largest turn ``abs(delta theta)`` and displacement ``norm(delta x)`` of a particle in
        the step (in a sub-step when the step was halved).
    main_overlap : float
        Largest real overlap after the main solve's move, before the re-solve passes: the error
        of the step's linearised contacts.
    """

    step: int
    t: float
    dt: float
    radius: float
    hull_radius: float
    n_particles: int
    max_stress: float
    mean_stress: float
    max_overlap: float
    iterations: int
    pass_iterations: int
    failed_iterations: int
    passes: int
    n_contacts: int
    residual: float
    total_length: float
    divisions: int
    substeps: int
    max_rotation: float
    max_displacement: float
    main_overlap: float

    def row(self) -> dict:
        """The history row (a dict of the fields in their order, as checkpoints store it)."""
        return asdict(self)


def initial_state(config: Config) -> ParticleState:
    """Initial state of ``config``: packings.single_cell(), or packings.from_csv(config.init).

    Raises ValueError for a ``config.shape``: its state is built outside the engine
    (cases.shapes.initial_particles) and given to :class:`Simulation` or :func:`run`.
    """
    if config.shape is not None:
        raise ValueError(f"shape {config.shape!r}: give its initial state (state=..., built by "
                         "cases.shapes.initial_particles); the particle engine does not parse "
                         "shapes")
    return single_cell() if config.init is None else from_csv(config.init)


def check_initial(config: Config, require_stop: bool = True,
                  state: ParticleState | None = None) -> ParticleState:
    """The initial state of ``config``, checked before any step.

    Checks a valid configuration (``Config.validate(require_stop)``), no overlap beyond
    ``config.tol`` (every gap phi_k >= -tol), and a ``radius`` goal larger than the initial
    colony radius.

    Parameters
    ----------
    config : Config
        The configuration; its ``init`` file (or one cell) gives the state when ``state`` is
        None.
    require_stop : bool
        Require exactly one of ``radius`` and ``time`` (as :func:`run` does).
    state : ParticleState, optional
        The initial state to check (e.g. of ``config.shape``).

    Returns
    -------
    ParticleState
        The initial state (``state``, or :func:`initial_state`).

    Raises
    ------
    ValueError
        With a one-line message, when a check fails.
    """
    config.validate(require_stop)
    state = initial_state(config) if state is None else state
    c = detect(state, 0.0)
    if c.gap.size and c.gap.min() < -config.tol:
        k = int(np.argmin(c.gap))
        source = (f"init file {config.init}" if config.init is not None else
                  f"shape {config.shape}" if config.shape is not None else "initial state")
        raise ValueError(
            f"{source}: particles {c.i[k]} and {c.j[k]} overlap by "
            f"{-c.gap[k]:.3g} (tolerance tol = {config.tol:.3g})")
    r0 = state.enclosing_radius()
    if config.radius is not None and config.radius <= r0:
        raise ValueError(f"radius {config.radius:g} is not larger than the initial colony "
                         f"radius {r0:.6g}: nothing to grow")
    return state


class Simulation:
    """A growing, dividing colony stepped in time.

    Parameters
    ----------
    config : Config
        ``radius`` and ``time`` may both be None (they are the stop of :func:`run` and the
        default stop of :meth:`advance`).
    out : path, optional
        Existing run folder.  When given, the simulation resumes from ``out/checkpoint.npz``
        if there is one (same configuration up to ``EXECUTION_FIELDS``, and
        ``STEP_POLICY_FIELDS`` with ``change_step_policy``; ``checkpoint.prev.npz`` when that
        one is damaged: checkpoint.resume_checkpoint), else writes config.json and the
        trajectory's first frame; :meth:`advance` then writes a frame every
        ``config.output_every`` steps and :meth:`save` defaults to ``out/checkpoint.npz``.
    state : ParticleState, optional
        Initial state (default: ``config.init`` or one cell, checked by :func:`check_initial`;
        required for a ``config.shape``, e.g. from cases.shapes.initial_particles).
        Its ``rng`` is seeded with ``config.seed`` when None.
    change_step_policy : bool
        See ``out``; config.json then records the change (output.write_config).

    Attributes
    ----------
    config : Config
    state : ParticleState
        The one mutable state; ``step`` changes it in place.
    history : list of dict
        One row per step (:meth:`StepRecord.row`).
    output : output.RunOutput or None
        The writers of ``out``.
    finished : bool
        False when :func:`run` stopped before its goal (``stop_after`` or a signal).
    """

    def __init__(self, config: Config, out: str | Path | None = None,
                 state: ParticleState | None = None, *, change_step_policy: bool = False):
        config.validate(require_stop=False)
        self.config = config
        self.history: list[dict] = []
        self.finished = True
        self._frames = list(NO_FRAMES)
        self._detections = Detections()  # the last step's final contacts, for the next step
        self.output = None
        if out is not None:
            out = Path(out)
            if not out.is_dir():
                raise ValueError(f"output folder does not exist: {out}")
            self.output = RunOutput(out, config.output_every)
        if out is not None and checkpoint_files(out):
            checkpoint, (self.state, self.history, frames) = resume_checkpoint(
                out, config, change_step_policy)
            self.output.resume(frames)
            log.info("resuming from %s at t = %.6g (step %d, %d particles)", checkpoint,
                     self.state.t, self.state.step, self.state.n)
            if change_step_policy:
                write_config(out, config, step=self.state.step, policy=STEP_POLICY_FIELDS)
            return
        self.state = check_initial(config, require_stop=False) if state is None else state
        if self.state.rng is None:
            self.state.rng = np.random.default_rng(config.seed)
        if self.state.dt_next is None:
            self.state.dt_next = config.dt
        if self.output is not None:
            self.output.start(config, self.state)

    @classmethod
    def load(cls, path: str | Path, config: Config | None = None,
             change_step_policy: bool = False) -> Simulation:
        """The simulation saved at ``path`` (:meth:`save`, or a run's checkpoint.npz).

        ``config`` None: the checkpoint's own configuration.  Older checkpoints load
        (checkpoint.py).  The result writes no output (``output`` None).
        """
        path = Path(path)
        if config is None:
            config = checkpoint_config(path)
        config.validate(require_stop=False)
        state, history, frames = load_checkpoint(path, config, change_step_policy)
        sim = cls(config, state=state)
        sim.history, sim._frames = history, frames
        return sim

    def save(self, path: str | Path | None = None) -> Path:
        """Write a checkpoint (checkpoint.py; atomic) to ``path``, default out/checkpoint.npz.

        The run folder's checkpoint: history.csv first, which the checkpoint refers to (its
        size stays that of the colony), and the checkpoint it replaces kept as
        checkpoint.prev.npz.  Elsewhere the checkpoint holds the history rows.
        """
        if path is None:
            if self.output is None:
                raise ValueError("give a path: this simulation has no output folder")
            path = self.output.checkpoint
        path = Path(path)
        frames = self._frames if self.output is None else self.output.frames
        history = self.history
        if self.output is not None and path == self.output.checkpoint:
            write_history(self.output.out, self.history)
            history = history_record(self.output.out / HISTORY, len(self.history))
        save_checkpoint(path, self.config, self.state, history, frames)
        return path

    def done(self, radius: float | None = None, time: float | None = None) -> bool:
        """Whether the goal is reached: t >= ``time`` (to 1e-12), else radius >= ``radius``.

        Without ``time``, the colony's enclosing radius is compared with ``radius``; False when
        both are None.
        """
        if time is not None:
            return self.state.t >= time - 1e-12
        if radius is not None:
            return self.state.enclosing_radius() >= radius
        return False

    def step(self, until: float | None = None) -> StepRecord:
        """Advance the state by one step, divisions included; return its record.

        The step has length ``state.dt_next`` (``Config.dt``, or adapted by
        ``Config.step_control``: stepping.next_dt), shortened to land on ``until`` when that is
        nearer.

        Parameters
        ----------
        until : float, optional
            A time to land on: the step is shortened to end at ``until`` when that is nearer.

        Returns
        -------
        StepRecord
            What the step did (one row of history.csv).

        Raises
        ------
        ParticleLimitError
            After the step, when N > ``Config.max_particles``.
        OverlapError, ContactSolveError
            When a step fails even as 16 sub-steps.
        """
        config, st = self.config, self.state
        dt = st.dt_next
        if until is not None and until - st.t < dt * (1 + 1e-9):
            dt = until - st.t
        info, st.warm = robust_step(st, config, dt, st.warm, detections=self._detections)
        st.dt_next = next_dt(dt, info, config.dt, config.step_control)
        divisions = divide_in_order(st, st.rng, config.division_noise)
        st.t += dt
        st.step += 1
        record = StepRecord(
            step=st.step, t=st.t, dt=dt, radius=st.enclosing_radius(),
            hull_radius=st.hull_radius(), n_particles=st.n,
            max_stress=float(st.stress.max()), mean_stress=float(st.stress.mean()),
            max_overlap=info["max_overlap"], iterations=int(info["iterations"]),
            pass_iterations=int(info["pass_iterations"]),
            failed_iterations=int(info["failed_iterations"]), passes=int(info["passes"]),
            n_contacts=int(info["n_contacts"]), residual=info["residual"],
            total_length=float(st.length.sum()), divisions=int(divisions),
            substeps=int(info["substeps"]), max_rotation=info["max_rotation"],
            max_displacement=info["max_displacement"], main_overlap=info["main_overlap"])
        self.history.append(record.row())
        if record.substeps > 1:
            log.debug("step %d at t = %.6g taken as %d sub-steps", st.step, st.t, record.substeps)
        if st.n > config.max_particles:
            raise ParticleLimitError(
                f"colony has {st.n} particles > max_particles {config.max_particles}")
        return record

    def advance(self, radius: float | None = None, time: float | None = None,
                progress: bool = False) -> ParticleState:
        """Step until the enclosing radius reaches ``radius`` or t reaches ``time``.

        The last step is shortened to land on ``time``.  With an output folder, a trajectory
        frame every ``Config.output_every`` steps (no checkpoint, history or final files:
        :func:`run` writes those).

        Parameters
        ----------
        radius : float, optional
            Goal for the enclosing radius R (measures.enclosing_radius).
        time : float, optional
            Goal for t; takes precedence over ``radius``.  Both None: ``Config.radius`` /
            ``Config.time``.
        progress : bool
            A tqdm progress bar when stderr is a terminal, else a log line every
            PROGRESS_SECONDS.

        Returns
        -------
        ParticleState
            ``state``, advanced in place.
        """
        if radius is None and time is None:
            radius, time = self.config.radius, self.config.time
        if radius is None and time is None:
            raise ValueError("give radius or time (or set one in the Config)")
        with _ProgressBar(self.config.lam, radius, time, progress) as bar:
            while not self.done(radius, time):
                bar.show(self.step(until=time))
                if self.output is not None:
                    self.output.after_step(self.state)
        return self.state


PROGRESS_SECONDS = 60.0
"""With ``progress`` and stderr not a terminal (a batch job's log), :func:`run` logs one line
of progress at most this often (wall seconds)."""


class _ProgressBar:
    """Progress of a run: a tqdm bar of the radius or the time on a terminal.

    When stderr is not a terminal (a log file): one INFO line every PROGRESS_SECONDS.
    """

    def __init__(self, lam: float, radius: float | None, time: float | None, progress: bool):
        self.by_time = time is not None
        self.total = time if self.by_time else radius
        self.bar = tqdm(total=self.total, disable=not (progress and sys.stderr.isatty()),
                        unit="", desc=f"particles lam={lam:g}", leave=False)
        self.log_lines = progress and self.bar.disable
        self.started = self.last = _time.monotonic()

    def show(self, record: StepRecord) -> None:
        """The time or the radius after the step of ``record``."""
        if self.log_lines:
            now = _time.monotonic()
            if now - self.last >= PROGRESS_SECONDS:
                self.last = now
                goal = (f"t = {record.t:.4f} of {self.total:g}, radius {record.radius:.2f}"
                        if self.by_time else
                        f"radius {record.radius:.2f} of {self.total:g}, t = {record.t:.4f}")
                log.info("%s, %d particles, step %d, dt %.3g, %.0f s", goal,
                         record.n_particles, record.step, record.dt, now - self.started)
        if self.bar.disable:
            return
        self.bar.n = min(self.total, record.t if self.by_time else record.radius)
        self.bar.refresh()

    def __enter__(self) -> _ProgressBar:
        return self

    def __exit__(self, *exc) -> None:
        self.bar.close()


class _Checkpointer:
    """A checkpoint (history.csv first) every ``Config.checkpoint_seconds`` of wall time."""

    def __init__(self, sim: Simulation):
        self.sim = sim
        self.last = _time.monotonic()

    def after_step(self) -> None:
        now = _time.monotonic()
        if now - self.last >= self.sim.config.checkpoint_seconds:
            self.sim.output.ensure_space(self.sim.state)
            self.sim.save()
            self.last = now


def run(config: Config, out: str | Path | None = None, progress: bool = False,
        stop_after: int | None = None, change_step_policy: bool = False,
        state: ParticleState | None = None) -> Simulation:
    """Grow a colony until ``config.radius`` or ``config.time``.

    SIGINT (Ctrl-C), SIGTERM (e.g. a batch system's time limit) or SIGHUP (a closed terminal)
    in the main thread ends the run after the current step, with a checkpoint of that step
    written (then KeyboardInterrupt, or SystemExit(128 + signal) for SIGTERM and SIGHUP); a
    second signal interrupts at once.

    Parameters
    ----------
    config : Config
        With exactly one of ``radius`` and ``time``.
    out : Path, optional
        Existing folder for config.json, history.csv, particles.csv, trajectory.gsd and
        checkpoint.npz.  If it holds a checkpoint of the same configuration the run resumes from
        it, with the same result as an uninterrupted run.
    progress : bool
        A tqdm progress bar when stderr is a terminal, else a log line every PROGRESS_SECONDS.
    stop_after : int, optional
        Stop after this many steps of this call, writing a checkpoint (as if interrupted);
        the returned simulation has ``finished = False``.
    change_step_policy : bool
        Resume from a checkpoint written with other STEP_POLICY_FIELDS values (config.json then
        holds the new values and, under ``step_policy_changes``, the step and the old and new
        values of each change; the result differs from an uninterrupted run's within the
        time-stepping error).
    state : ParticleState, optional
        Initial state of a new run (default: ``config.init`` or one cell; needed for a
        ``config.shape``); unused when ``out`` holds a checkpoint.

    Returns
    -------
    Simulation
        ``.state`` the final state, ``.history`` one row per step, ``.finished``.

    Raises
    ------
    ValueError
        Bad configuration or mismatched checkpoint.
    OverlapError, ParticleLimitError, ContactSolveError
        A step failed (see their docstrings).
    """
    config.validate()
    sim = Simulation(config, out, state=state, change_step_policy=change_step_policy)
    goal = {"radius": config.radius, "time": config.time}
    checkpointer = None if sim.output is None else _Checkpointer(sim)
    steps = 0
    with StopRequest() as stop, _ProgressBar(config.lam, progress=progress, **goal) as bar:
        while not sim.done(**goal):
            bar.show(sim.step(until=config.time))
            steps += 1
            if sim.output is not None:
                sim.output.after_step(sim.state)
                checkpointer.after_step()
            asked = stop.signum is not None or (stop_after is not None and steps >= stop_after)
            if asked and not sim.done(**goal):
                sim.finished = False
                break
    if sim.output is not None:
        sim.output.ensure_space(sim.state)
        if sim.finished:
            sim.output.last_frame(sim.state)
        sim.save()
        sim.output.results(sim.state, sim.history)
    stop.reraise()
    return sim
