"""The particle simulation: ``Simulation`` (state, ``step``, ``advance``, checkpoints) and ``run``.

In the manner of Dedalus's solver (``step``, ``evolve``) and JAX-MD's ``init_fn`` / ``apply_fn``:
one explicit mutable state (``state.ParticleState``), a ``step()`` that advances it by one
time step (stepping.robust_step: detect, solve, move and grow, re-solve, halving; then the
division rule and the spatial order, division.divide_in_order) and returns a typed
:class:`~particles.state.StepRecord` of what happened, and
:func:`run`, a short loop that hands each step to the output writers (output.RunOutput), the
checkpointer (checkpoint.py) and the progress bar, and writes the final files.

The contract, the continuum engine's too (docs/DESIGN.md, "One contract for both engines";
tests/test_contract.py): ``Simulation(config, state=None, out=None)`` (``state`` copied),
``step(time=None)`` (one step, not past ``time``), ``done(radius=None, time=None)`` and
``advance(radius=None, time=None)`` (the first goal reached stops, :func:`reached`; both None:
the configuration's), ``save(path=None)``, ``Simulation.load(path, config=None)``, and
``run(config, out=None, progress=False, state=None, max_steps=None)``.

>>> import particles
>>> sim = particles.Simulation(particles.Config(lam=1e-2, seed=1))
>>> record = sim.step()
>>> state = sim.advance(radius=6.0)
"""

from __future__ import annotations

import logging
from dataclasses import replace
from pathlib import Path

import numpy as np

from .checkpoint import (
    NO_FRAMES,
    Checkpoint,
    load_checkpoint,
    resume_checkpoint,
    save_checkpoint,
)
from .config import STEP_POLICY_FIELDS, Config, check_dish_fits
from .division import divide_in_order
from .nutrients import WALL_MARGIN, extent, reaches_wall
from .output import RunOutput, strain_columns, write_config, write_history
from .packings import from_csv, single_cell
from .runfiles import (
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
from .solvers import check_device
from .state import ParticleState, StepRecord
from .stepping import Detections, detect, next_dt, robust_step
from .strains import STRAIN_SEED, draw_strains

log = logging.getLogger(__name__)

# StepRecord lives in particles.state; imported here for older imports
# (``from particles.simulation import StepRecord``), documented there.
__all__ = ["DishWallError", "ParticleLimitError", "Simulation", "check_dish", "check_initial",
           "initial_state", "run"]

class ParticleLimitError(RuntimeError):
    """The colony exceeded ``Config.max_particles``."""


class DishWallError(ValueError):
    """The colony reached the wall of its dish (``Config.dish_radius``; nutrients.reaches_wall).

    Raised by :meth:`Simulation.step` after the step that brings a cell's centre within
    nutrients.WALL_MARGIN grid spacings of the wall or a cell to the wall, and before any work
    for an initial colony already there (:func:`check_dish`). A ValueError: the settings do
    not fit (the dish's radius and the run's goal).
    """


def check_wall(config: Config, state: ParticleState) -> None:
    """DishWallError (one line) when the colony of ``state`` reaches the dish's wall.

    nutrients.reaches_wall; nothing without a dish.
    """
    dish = config.dish_radius
    if dish is None:
        return
    h = config.nutrient[2]
    if reaches_wall(state.x, state.y, state.theta, state.length, dish, h):
        far = float(np.max(np.hypot(state.x, state.y)))
        limit = dish - WALL_MARGIN * h
        raise DishWallError(
            f"the colony reached the dish's wall (dish_radius {dish:g}) at t = {state.t:.6g}: "
            f"cell centres up to {far:.4g} from the origin (the limit: {limit:.4g}, "
            f"{WALL_MARGIN:g} grid spacings inside), cells up to "
            f"{extent(state.x, state.y, state.theta, state.length):.4g}; give a larger "
            "dish_radius or a nearer goal")


def check_dish(config: Config, state: ParticleState) -> None:
    """ValueError (one line) for an initial colony that does not fit in the dish.

    Its radius about the origin (nutrients.extent) must be below ``Config.dish_radius``, and
    no cell may reach the wall (:func:`check_wall`: DishWallError). Nothing without a dish.
    """
    if config.dish_radius is None:
        return
    check_dish_fits(config.dish_radius, extent(state.x, state.y, state.theta, state.length),
                    "about the origin")
    check_wall(config, state)


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


def _check_state_type(state) -> None:
    """TypeError unless ``state`` is a ParticleState or None (runfiles.check_state_type)."""
    check_state_type(state, ParticleState, "particles.ParticleState (or None: config.init or "
                     "one cell)")


def check_initial(config: Config, require_stop: bool = True,
                  state: ParticleState | None = None) -> ParticleState:
    """The initial state of ``config``, checked before any step.

    Checks a goal (with ``require_stop``), what this machine can do (``Config.check_budget``:
    the steps and the colony, first before reading any state, then the steps of a radius goal
    from the initial colony's radius), no overlap beyond ``config.tol`` (every gap
    phi_k >= -tol), and a ``radius`` goal larger than the initial colony radius (the
    configuration itself was checked when it was made).

    Parameters
    ----------
    config : Config
        The configuration; its ``init`` file (or one cell) gives the state when ``state`` is
        None.
    require_stop : bool
        Require one of ``radius`` and ``time`` (as :func:`run` does).
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
    TypeError
        ``state`` is not a ParticleState (:func:`_check_state_type`).
    """
    _check_state_type(state)
    if require_stop:
        require_goal(config)
    check_device(config.solver)  # a GPU solver on a machine without one
    config.check_budget()  # before any work: a time goal, a radius goal from one cell
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
    config.check_budget(r0)  # a radius goal from this colony (init file, shape)
    check_dish(config, state)
    return state


def initial_strains(config: Config, state: ParticleState, layout=None) -> None:
    """Set the cells' strains of a starting state (in place; particles.strains).

    ``layout``: the fractions phi0(x, y) -> (N, S) that each cell draws its strain from
    (particles.strains.draw_strains, generator seeded (Config.seed, STRAIN_SEED)), or the
    strains as integers; None keeps the state's, or puts every cell in strain 0.

    Raises
    ------
    ValueError
        Strains without ``Config.strains``, or a cell's strain not one of them (one line).
    """
    n_strains = len(config.strains)
    if n_strains == 0:
        if layout is not None or state.strain is not None:
            raise ValueError("cell strains need strains in the Config (Config.strains)")
        return
    if config.layout is not None and layout is None and state.strain is None:
        raise ValueError(f"layout {config.layout!r} is drawn outside the engine "
                         "(cases.shapes.initial_state): give the cells' strains, layout=")
    if layout is not None:
        rng = np.random.default_rng((config.seed, STRAIN_SEED))
        state.strain = draw_strains(layout, state.x, state.y, n_strains, rng)
        absent = sorted(set(range(n_strains)) - set(state.strain.tolist()))
        if absent:
            log.warning("strain(s) %s absent from the initial colony: the layout %s places "
                        "no cell in them", ", ".join(map(str, absent)), config.layout or "given")
    elif state.strain is None:
        state.strain = np.zeros(state.n, dtype=np.int64)
    s = np.asarray(state.strain)
    if s.shape != (state.n,) or s.dtype.kind not in "iu" or np.any(s < 0) or np.any(s >= n_strains):
        raise ValueError(f"every cell's strain must be an integer in [0, {n_strains}) "
                         f"(Config.strains has {n_strains})")


class Simulation:
    """A growing, dividing colony stepped in time.

    The engine contract (the continuum engine's ``Simulation`` has the same methods with the
    same meaning; docs/DESIGN.md, tests/test_contract.py).

    Parameters
    ----------
    config : Config
        ``radius`` and ``time`` may both be None (they are the stop of :func:`run` and the
        default goal of :meth:`advance` and :meth:`done`).
    state : ParticleState, optional
        Initial state (default: ``config.init`` or one cell, checked by :func:`check_initial`;
        required for a ``config.shape``, e.g. from cases.shapes.initial_particles).  A copy
        is grown (the given object is not changed); its ``rng`` seeded with ``config.seed``
        when None.  A checkpoint in ``out`` takes precedence.
    out : path, optional
        Existing run folder.  When given, the simulation resumes from ``out/checkpoint.npz``
        if there is one (same configuration up to ``EXECUTION_FIELDS``, and
        ``STEP_POLICY_FIELDS`` with ``change_step_policy``; ``checkpoint.prev.npz`` when that
        one is damaged: checkpoint.resume_checkpoint), else writes config.json and the
        trajectory's first frame; :meth:`step` then writes a frame every
        ``config.output_every`` of time and :meth:`save` defaults to ``out/checkpoint.npz``.
        The final files (history.csv, particles.csv, the last frame) are :func:`run`'s.
    change_step_policy : bool
        See ``out``; config.json then records the change (output.write_config).  (Particles
        only: the continuum has no step policy.)
    layout : callable or int array, optional
        The cells' strains of ``config.strains`` (:func:`initial_strains`): fractions
        phi0(x, y) -> (N, S) to draw them from (the continuum's layouts, e.g.
        continuum.strains.core(r1)), or integers (N,). None: the state's, else strain 0. Not
        allowed without strains; a checkpoint in ``out`` takes precedence.

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
        False when :func:`run` stopped before its goal (``max_steps``, a signal, or paused).
    paused : bool
        True when :func:`run` paused at ``config.max_hours`` (the same call resumes it).
    """

    def __init__(self, config: Config, state: ParticleState | None = None,
                 out: str | Path | None = None, *, change_step_policy: bool = False,
                 layout=None):
        check_device(config.solver)
        _check_state_type(state)
        self.config = config
        self.history: list[dict] = []
        self.finished, self.paused = True, False
        self._frames = list(NO_FRAMES)
        self._detections = Detections()  # the last step's final contacts, for the next step
        self.output = None
        if out is not None:
            out = Path(out)
            if not out.is_dir():
                raise ValueError(f"output folder does not exist: {out}")
            self.output = RunOutput(out, config.output_every)
        if out is not None and checkpoint_files(out):
            path, saved = resume_checkpoint(out, config, change_step_policy=change_step_policy)
            self.state, self.history = saved.state, saved.history
            self.output.resume(saved.frames, self.state.t)
            log.info("resuming from %s at t = %.6g (step %d, %d particles)", path,
                     self.state.t, self.state.step, self.state.n)
            if change_step_policy:
                write_config(out, config, step=self.state.step, policy=STEP_POLICY_FIELDS)
            return
        if state is None:
            self.state = check_initial(config, require_stop=False)
        else:
            config.check_budget(state.enclosing_radius())  # before any work, as check_initial
            check_dish(config, state)
            self.state = state.copy()
        initial_strains(config, self.state, layout)
        if self.state.rng is None:
            self.state.rng = np.random.default_rng(config.seed)
        if self.state.dt_next is None:
            self.state.dt_next = config.dt
        if self.output is not None:
            self.output.start(config, self.state)

    @classmethod
    def load(cls, path: str | Path, config: Config | None = None, *,
             change_step_policy: bool = False) -> Simulation:
        """The simulation saved at ``path`` (:meth:`save`, or a run's checkpoint.npz).

        ``config``: the configuration to continue with, equal to the saved one up to
        ``EXECUTION_FIELDS`` (and ``STEP_POLICY_FIELDS`` with ``change_step_policy``;
        ValueError otherwise); None: the saved one.  Older checkpoints load (checkpoint.py).
        The result writes no output (``output`` None); stepping it gives the bits the saved
        simulation would have.
        """
        saved = load_checkpoint(Path(path), config, change_step_policy=change_step_policy)
        sim = cls(saved.config, state=saved.state)
        sim.history, sim._frames = saved.history, saved.frames
        return sim

    def save(self, path: str | Path | None = None) -> Path:
        """Write a checkpoint (checkpoint.py; atomic) to ``path``, default out/checkpoint.npz.

        :meth:`load` (and :func:`run` on its folder) continues from it bit-identically.  The
        run folder's checkpoint: history.csv first, which the checkpoint refers to (its size
        stays that of the colony), and the checkpoint it replaces kept as
        checkpoint.prev.npz, after output.ensure_space.  Elsewhere the checkpoint holds the
        history rows.
        """
        if path is None:
            if self.output is None:
                raise ValueError("give a path: this simulation has no output folder")
            path = self.output.checkpoint
        path = Path(path)
        frames = self._frames if self.output is None else self.output.frames
        history = self.history
        if self.output is not None and path == self.output.checkpoint:
            self.output.ensure_space(self.state)
            write_history(self.output.out, self.history)
            history = history_record(self.output.out / HISTORY, len(self.history))
        save_checkpoint(path, Checkpoint(self.config, self.state, history, frames))
        return path

    def done(self, radius: float | None = None, time: float | None = None) -> bool:
        """Whether the first of the goals is reached (both None: the configuration's goal).

        The enclosing radius >= ``radius`` (1 - RADIUS_RTOL), or
        t >= ``time`` - TIME_TOL max(1, ``time``) (:func:`reached`).

        Raises
        ------
        ValueError
            No goal given and none in the configuration, or a goal not a positive number.
        """
        return self._reached(*goal_of(self.config, radius, time))

    def _reached(self, radius: float | None, time: float | None) -> bool:
        """:func:`reached` of the current state (False without a goal)."""
        return reached(self.state.enclosing_radius, self.state.t, radius, time)

    def step_toward(self, radius: float | None, time: float | None) -> StepRecord:
        """One step of :meth:`advance` and :func:`run`: :meth:`step`, not past ``time``.

        (A radius goal is reached at or after the step that reaches it: the step is not
        shortened for it.)
        """
        return self.step(time)

    @property
    def label(self) -> str:
        """The progress bar's label."""
        return f"particles lam={self.config.lam:g}"

    def finish(self) -> None:
        """The final files of :func:`run`: history.csv and particles.csv.

        When finished also the last frame and a checkpoint (a stop wrote its own already).
        """
        self.output.ensure_space(self.state)
        if self.finished:
            self.output.last_frame(self.state)
            self.save()
        self.output.results(self.state, self.history)

    def check_budget(self, radius: float | None, time: float | None) -> None:
        """Config.check_budget of the way from the state to a goal of :meth:`advance`.

        The same one-line refusal as :func:`run`'s (e.g. dt = 1e-300), before any step.
        """
        if self._reached(radius, time):
            return
        goals = [{"radius": radius, "time": None}] if radius is not None else []
        goals += [{"radius": None, "time": time - self.state.t}] if time is not None else []
        refusals = []
        for goal in goals:  # the first goal reached stops: one within the budget will do
            try:
                replace(self.config, **goal).check_budget(self.state.enclosing_radius())
                return
            except ValueError as err:
                refusals.append(err)
        raise refusals[0]

    def step(self, time: float | None = None) -> StepRecord:
        """Advance the state by one step, not past ``time``, divisions included; its record.

        The step has length ``state.dt_next`` (``Config.dt``, or adapted by
        ``Config.step_control``: stepping.next_dt), shortened to land on ``time`` when that is
        nearer.  With an output folder, a trajectory frame every ``Config.output_every``
        of time (output.frame_count).

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
        ParticleLimitError
            After the step, when N > ``Config.max_particles``.
        DishWallError
            After the step, when the colony reaches the dish's wall (``Config.dish_radius``).
        OverlapError, ContactSolveError
            When a step fails even as 16 sub-steps.
        """
        check_goal(None, time)
        if self._reached(None, time):
            raise ValueError(f"time {time:g} is reached already (t = {self.state.t:.17g})")
        config, st = self.config, self.state
        dt = st.dt_next
        if time is not None and time - st.t < dt * (1 + 1e-9):
            dt = time - st.t
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
        self.history.append(record.row() | strain_columns(st, len(config.strains)))
        if record.substeps > 1:
            log.debug("step %d at t = %.6g taken as %d sub-steps", st.step, st.t, record.substeps)
        if st.n > config.max_particles:
            raise ParticleLimitError(
                f"colony has {st.n} particles > max_particles {config.max_particles}")
        check_wall(config, st)
        if self.output is not None:
            self.output.after_step(st)
        return record

    def advance(self, radius: float | None = None, time: float | None = None,
                progress: bool = False) -> ParticleState:
        """Step until the enclosing radius reaches ``radius`` or t ``time``, whichever first.

        Both None: the configuration's goal.  The last step is shortened to land on ``time``;
        ``advance`` of a new simulation gives the bits of ``run`` to the same goal.  No step
        when the goal is reached already.  With an output folder the frames are written as
        :meth:`step` writes them; the final files are :func:`run`'s (or :meth:`save`'s
        history.csv).

        Parameters
        ----------
        radius : float, optional
            Goal for the enclosing radius R (measures.enclosing_radius).
        time : float, optional
            Goal for t.
        progress : bool
            A tqdm progress bar when stderr is a terminal, else a log line every
            runfiles.PROGRESS_SECONDS.

        Returns
        -------
        ParticleState
            ``state``, advanced in place.

        Raises
        ------
        ValueError
            No goal (:meth:`done`).
        """
        return advance(self, radius, time, progress)


def kernels_cached() -> bool:
    """Whether the contact solver's kernels are in Numba's cache (else the first step compiles).

    Numba's documented cache layout (Numba's notes on caching): a cached function's index
    ``<module>.<function>-<line>.py<version>.nbi`` in ``__pycache__`` beside its source, or in
    a tree under ``NUMBA_CACHE_DIR`` when that is set. True when neither place exists (a
    read-only install caches in a user folder: then no message is better than a wrong one).
    """
    from numba import config

    from .solvers import bbpgd

    source = Path(bbpgd.__file__)
    index = f"{source.stem}.{bbpgd._bbpgd.__name__}-*.nbi"
    places = [source.parent / "__pycache__"]
    if config.CACHE_DIR:
        places.append(Path(config.CACHE_DIR))
    places = [p for p in places if p.is_dir()]
    return not places or any(next(p.rglob(index), None) is not None for p in places)


def run(config: Config, out: str | Path | None = None, progress: bool = False,  # noqa: PLR0913
        state: ParticleState | None = None, max_steps: int | None = None, *,
        change_step_policy: bool = False, layout=None, started: float | None = None
        ) -> Simulation:
    """Grow a colony until ``config.radius`` or ``config.time``.

    The run loop both engines share (runfiles.drive) over the steps of a :class:`Simulation`:
    each step's frames, the checkpoints and the progress bar, and the final files.  SIGINT
    (Ctrl-C), SIGTERM (e.g. a batch system's time limit) or SIGHUP (a closed terminal) in the
    main thread ends the run after the current step, with a checkpoint of that step written
    (then KeyboardInterrupt, or SystemExit(128 + signal) for SIGTERM and SIGHUP); a second
    signal interrupts at once (runfiles.StopRequest).  Before ``config.max_hours`` of wall have
    passed, the run writes a checkpoint and returns paused (``.paused``; runfiles.WallLimit).

    Parameters
    ----------
    config : Config
        With one of ``radius`` and ``time``.
    out : Path, optional
        Existing folder for config.json, history.csv, particles.csv, trajectory.gsd and
        checkpoint.npz.  If it holds a checkpoint of the same configuration the run resumes from
        it, with the same result as an uninterrupted run.
    progress : bool
        A tqdm progress bar when stderr is a terminal, else a log line every
        runfiles.PROGRESS_SECONDS.
    state : ParticleState, optional
        Initial state of a new run (default: ``config.init`` or one cell; needed for a
        ``config.shape``; copied); unused when ``out`` holds a checkpoint.
    max_steps : int, optional
        Stop after this many steps of this call, writing a checkpoint (as if interrupted);
        the returned simulation has ``finished = False``.
    change_step_policy : bool
        Resume from a checkpoint written with other STEP_POLICY_FIELDS values (config.json then
        holds the new values and, under ``step_policy_changes``, the step and the old and new
        values of each change; the result differs from an uninterrupted run's within the
        time-stepping error).  Particles only.
    layout : callable or int array, optional
        The cells' strains of ``config.strains`` (:class:`Simulation`).
    started : float, optional
        The time.monotonic() reading ``config.max_hours`` counts from (the command line gives
        its process's start); default: this call's.

    Returns
    -------
    Simulation
        ``.state`` the final state, ``.history`` one row per step, ``.finished``, ``.paused``
        (stopped by ``config.max_hours``: the same call resumes it).

    Raises
    ------
    ValueError
        No goal in ``config``, a run this machine cannot do (``Config.check_budget``, before
        any work), or a mismatched checkpoint.
    OverlapError, ParticleLimitError, DishWallError, ContactSolveError
        A step failed or the colony reached the dish's wall (see their docstrings).
    """
    require_goal(config)
    if progress and not kernels_cached():
        log.info("compiling the engine's kernels (first run only, about a minute; Numba caches "
                 "them for later runs)")
    with StopRequest() as stop:
        sim = Simulation(config, state, out, change_step_policy=change_step_policy,
                         layout=layout)
        drive(sim, stop, max_steps, started, progress)
    stop.reraise()
    return sim
