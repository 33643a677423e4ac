"""Time stepping of the particle colony: configuration, one step, runs with checkpoints.

One step of length dt from state (x, theta, l) (model.md, "Discrete model"):

1. candidate pairs by cell lists, contacts with gap phi_k <= ``contact_margin`` (geometry.py);
2. the convex problem E(gamma) solved by the selected solver (contact_solver.py), warm-started
   from the previous step's forces matched by contact identity (particle ids + endpoint code);
3. update x += dt F / l, theta += dt 12 T / l^3 (F, T = D gamma, l at the start of the step),
   l <- l exp(dt exp(-lam sigma)), sigma = G gamma;
4. re-detect contacts on the new configuration; while the real overlap max(b - d) exceeds
   ``tol``, solve the overlap-removal problem (the same E without growth, Phi = the new gaps,
   mobility at the new lengths) and move by dt M D gamma'; those forces act over the same step and
   are added to the loads sigma.  At most ``max_passes`` passes, each of at most
   max(PASS_ITERATION_FLOOR, iterations of step 2) iterations, else OverlapError or
   ContactSolveError, upon which the step is redone from the same state as two steps of dt/2
   (``robust_step``, nested up to dt/16);
5. divide particles with l >= 2 (growth.py; the daughters record parent and generation).

With ``adaptive_dt`` the next step's length follows the cost of this step's passes
(:func:`next_dt`); ``dt`` is then the first and the largest step.

The history row of a step records the real overlap after step 4, the solver iterations of
steps 2 and 4 together (``iterations``), those of step 4 alone (``pass_iterations``), the
iterations of attempts that failed and were redone as half steps (``failed_iterations``), and
the loads sigma.
"""

from __future__ import annotations

import errno
import json
import math
import os
import shutil
import signal
import sys
import threading
import time as _time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numba
import numpy as np
from tqdm import tqdm

from . import output
from .apgd import solve_contacts_apgd
from .contact_solver import ContactSolveError, solve_contacts
from .geometry import Contacts, find_contacts, generalised_forces, loads
from .growth import divide, grow
from .neighbours import candidate_pairs
from .state import B, ParticleState, colony_radius, hull_radius
from .twolevel import solve_contacts_twolevel

SOLVERS = {
    "bbpgd": solve_contacts,
    "apgd": solve_contacts_apgd,
    "twolevel": solve_contacts_twolevel,
}
"""Contact solvers by name: callables (contacts, length, dt, lam, gamma0, tol, maxiter, growth)
-> (gamma, residual history)."""


class OverlapError(RuntimeError):
    """The re-solve passes could not bring the real overlap within tolerance."""


class ParticleLimitError(RuntimeError):
    """The colony exceeded ``max_particles``."""


@dataclass
class ParticleConfig:
    """Configuration of a particle run (all quantities in model units, b = 1/2).

    Parameters
    ----------
    lam : float
        Stress sensitivity lambda >= 0 of the growth law dl/dt = l exp(-lam sigma).
    radius, time : float or None
        Stop when the colony radius reaches ``radius`` or when t reaches ``time`` (exactly one).
    dt : float
        Time step (the last step of a ``time`` run is shortened to land on it); with
        ``adaptive_dt`` the first and largest step.
        Default 0.01, measured: lam = 1e-2 to radius 40 (about 6600 particles) took 58 s,
        53 s and 44 s of wall time at dt = 0.005, 0.01, 0.02 with 0.39, 0.56 and 0.98 re-solve
        passes per step, reaching radius 40 at t = 10.52, 10.48, 10.52.
    adaptive_dt : bool
        Adapt the step to the cost of the re-solve passes (:func:`next_dt`); default False
        (fixed dt).
    tol : float
        Largest admitted real overlap b - d after each step (default b/500).
    seed : int
        Seed of the division-angle perturbations.
    division_noise : float
        Amplitude eps (radians): daughters' angles are theta + eps * U(-1, 1).
    init : str or None
        CSV file with columns x,y,theta,length; None: one particle of length 1 at the origin.
    solver : str
        Contact solver name, a key of SOLVERS.
    output_every : int
        Trajectory frame every this many steps (and the final state).
    checkpoint_seconds : float
        Wall time between checkpoints when writing to a folder (like ``threads`` an execution
        setting: a run may resume with another value).
    max_particles : int
        Guard: a run whose colony exceeds this raises ParticleLimitError.
    solver_tol : float or None
        Residual tolerance of each solve (a gap, see contact_solver); default tol / 2.
    contact_margin : float
        Pairs with gap <= margin enter the solve.
    max_passes : int
        Re-detection and re-solve passes allowed per step.
    max_iterations : int
        Iteration cap of one solve (ContactSolveError beyond).
    threads : int
        Numba threads of the contact solver (its loops over particles and contacts).  The
        iterates do not depend on it (sums by fixed blocks, contact_solver.BLOCK), so a run
        may resume with another value and give the same result.
    """

    lam: float
    radius: float | None = None
    time: float | None = None
    dt: float = 0.01
    tol: float = B / 500
    seed: int = 0
    division_noise: float = 0.02
    init: str | None = None
    solver: str = "bbpgd"
    output_every: int = 10
    checkpoint_seconds: float = 300.0
    max_particles: int = 500_000
    solver_tol: float | None = None
    contact_margin: float = 0.1
    max_passes: int = 20
    max_iterations: int = 200_000
    adaptive_dt: bool = False
    threads: int = 1

    def validate(self) -> None:
        """Raise ValueError with a one-line message on an inconsistent configuration."""
        def finite(v):
            return isinstance(v, (int, float)) and math.isfinite(v)

        if not finite(self.lam) or self.lam < 0:
            raise ValueError(f"lam must be a finite number >= 0 for particles, got {self.lam}")
        if (self.radius is None) == (self.time is None):
            raise ValueError("give exactly one of radius and time")
        if self.radius is not None and (not finite(self.radius) or self.radius <= 0):
            raise ValueError(f"radius must be positive, got {self.radius}")
        if self.time is not None and (not finite(self.time) or self.time <= 0):
            raise ValueError(f"time must be positive, got {self.time}")
        if not finite(self.dt) or not 0 < self.dt <= 0.1:
            raise ValueError(f"dt must be in (0, 0.1], got {self.dt}")
        if not finite(self.tol) or not 0 < self.tol < B:
            raise ValueError(f"tol must be in (0, b = {B}), got {self.tol}")
        if self.solver_tol is not None and (not finite(self.solver_tol) or self.solver_tol <= 0):
            raise ValueError(f"solver_tol must be positive, got {self.solver_tol}")
        if not isinstance(self.seed, int) or self.seed < 0:
            raise ValueError(f"seed must be a non-negative integer, got {self.seed}")
        if not finite(self.division_noise) or not 0 <= self.division_noise <= 0.5:
            raise ValueError(f"division_noise must be in [0, 0.5] rad, got {self.division_noise}")
        if self.solver not in SOLVERS:
            raise ValueError(f"unknown solver {self.solver!r}; choose from {sorted(SOLVERS)}")
        if not isinstance(self.output_every, int) or self.output_every < 1:
            raise ValueError(f"output_every must be an integer >= 1, got {self.output_every}")
        if not finite(self.checkpoint_seconds) or self.checkpoint_seconds < 0:
            raise ValueError(f"checkpoint_seconds must be >= 0, got {self.checkpoint_seconds}")
        if not isinstance(self.max_particles, int) or self.max_particles < 1:
            raise ValueError(f"max_particles must be a positive integer, got {self.max_particles}")
        if not finite(self.contact_margin) or self.contact_margin < 0:
            raise ValueError(f"contact_margin must be >= 0, got {self.contact_margin}")
        if not isinstance(self.max_passes, int) or self.max_passes < 0:
            raise ValueError(f"max_passes must be an integer >= 0, got {self.max_passes}")
        if not isinstance(self.max_iterations, int) or self.max_iterations < 1:
            raise ValueError(
                f"max_iterations must be a positive integer, got {self.max_iterations}")
        if not isinstance(self.adaptive_dt, bool):
            raise ValueError(f"adaptive_dt must be true or false, got {self.adaptive_dt!r}")
        if (not isinstance(self.threads, int)
                or not 1 <= self.threads <= numba.config.NUMBA_NUM_THREADS):
            raise ValueError(f"threads must be an integer in [1, "
                             f"{numba.config.NUMBA_NUM_THREADS}], got {self.threads}")
        if self.init is not None and not Path(self.init).is_file():
            raise ValueError(f"init file not found: {self.init}")

    @property
    def effective_solver_tol(self) -> float:
        return self.tol / 2 if self.solver_tol is None else self.solver_tol


@dataclass
class Colony:
    """Result of a run: current particles, time and per-step history.

    Attributes
    ----------
    x, y, theta, length, stress, ids : arrays (N,)
    t : float
    history : list of dict
        One row per step, keys output.HISTORY_COLUMNS.
    finished : bool
        False when the run stopped early (``stop_after``) and can be resumed.
    parent, generation : int64 arrays (N,)
        Lineage (state.ParticleState): the mother's id (-1 for an initial particle) and the
        number of divisions since the initial ancestor; None: -1 and 0.
    """

    x: np.ndarray
    y: np.ndarray
    theta: np.ndarray
    length: np.ndarray
    stress: np.ndarray
    ids: np.ndarray
    t: float
    history: list = field(default_factory=list)
    finished: bool = True
    parent: np.ndarray | None = None
    generation: np.ndarray | None = None

    @property
    def state(self) -> ParticleState:
        return ParticleState(self.x, self.y, self.theta, self.length, self.stress, self.ids,
                             int(self.ids.max()) + 1, self.parent, self.generation)

    @property
    def n(self) -> int:
        return int(self.x.shape[0])

    def radius(self) -> float:
        """Radius of the smallest disc about the centroid holding every particle."""
        return colony_radius(self.state)

    def hull_radius(self) -> float:
        """sqrt(convex hull area / pi)."""
        return hull_radius(self.state)


def _warm_start(keys: np.ndarray, prev_keys: np.ndarray, prev_gamma: np.ndarray) -> np.ndarray:
    """Previous forces of the contacts whose identity persists, 0 for new contacts."""
    g0 = np.zeros(keys.shape[0])
    if prev_keys.size == 0 or keys.size == 0:
        return g0
    order = np.argsort(prev_keys)
    sk = prev_keys[order]
    pos = np.clip(np.searchsorted(sk, keys), 0, sk.size - 1)
    hit = sk[pos] == keys
    g0[hit] = prev_gamma[order[pos[hit]]]
    return g0


def detect(state: ParticleState, margin: float, timers: dict | None = None) -> Contacts:
    """Contacts of the current configuration with gap <= margin.

    ``timers`` (optional) accumulates wall seconds under "neighbours" and "geometry".
    """
    t0 = _time.perf_counter()
    pairs = candidate_pairs(state.x, state.y, state.length, margin)
    t1 = _time.perf_counter()
    c = find_contacts(state.x, state.y, state.theta, state.length, pairs, margin)
    if timers is not None:
        timers["neighbours"] = timers.get("neighbours", 0.0) + t1 - t0
        timers["geometry"] = timers.get("geometry", 0.0) + _time.perf_counter() - t1
    return c


def _tick(timers: dict | None, key: str, t0: float) -> float:
    t1 = _time.perf_counter()
    if timers is not None:
        timers[key] = timers.get(key, 0.0) + t1 - t0
    return t1


def _move(state: ParticleState, c: Contacts, gamma: np.ndarray, dt: float,
          length: np.ndarray) -> None:
    fx, fy, tz = generalised_forces(c, gamma, state.n)
    state.x += dt * fx / length
    state.y += dt * fy / length
    state.theta += dt * 12.0 * tz / length**3


PASS_ITERATION_FLOOR = 1000
"""A re-solve pass may take max(PASS_ITERATION_FLOOR, the step's main-solve iterations)
iterations; beyond, the step is redone as half steps.  Measured (lam = 1e-3 and 1e-4 to radius
40, dt = 0.0025-0.01, 2,600 passes): a pass that converges takes at most 0.3 of the main solve's
iterations in 99 % of cases and never more than 190 iterations where the step size is right;
at dt = 0.01 and lam = 1e-3 a few passes took 22,000 to 200,000 (the cap) before the step was
halved anyway."""


def _solve(solver, spent: list, *args):
    """solver(*args), adding its iterations to spent[0] whether or not it converges."""
    try:
        gamma, hist = solver(*args)
    except ContactSolveError as e:
        spent[0] += len(e.residuals) - 1
        raise
    spent[0] += len(hist) - 1
    return gamma, hist


def step(state: ParticleState, config: ParticleConfig, dt: float,
         warm: tuple[np.ndarray, np.ndarray], timers: dict | None = None,
         spent: list | None = None) -> tuple[dict, tuple[np.ndarray, np.ndarray]]:
    """Advance the state by one step in place (module docstring, items 1-4; no division).

    Returns the step's diagnostics (iterations, pass_iterations, passes, n_contacts, residual,
    max_overlap, and the contacts and forces of the main solve) and the (keys, gamma) of the
    solve for the next warm start.  ``timers`` (optional dict) accumulates wall seconds per
    phase: neighbours, geometry, solver, update; ``spent`` (optional one-element list)
    accumulates the solver iterations, also of a step that raises.
    """
    solver = SOLVERS[config.solver]
    numba.set_num_threads(config.threads)
    stol = config.effective_solver_tol
    margin = config.contact_margin
    spent = [0] if spent is None else spent
    n = state.n
    c = detect(state, margin, timers)
    t0 = _time.perf_counter()
    keys = c.keys(state.ids)
    gamma0 = _warm_start(keys, *warm)
    t0 = _tick(timers, "update", t0)
    gamma, hist = _solve(solver, spent, c, state.length, dt, config.lam, gamma0, stol,
                         config.max_iterations, True)
    t0 = _tick(timers, "solver", t0)
    main_iterations = len(hist) - 1
    pass_cap = min(config.max_iterations, max(PASS_ITERATION_FLOOR, main_iterations))
    sigma = loads(c, gamma, n)
    l0 = state.length
    _move(state, c, gamma, dt, l0)
    state.length = grow(l0, sigma, config.lam, dt)
    _tick(timers, "update", t0)
    passes = 0
    pass_iterations = 0
    while True:
        c2 = detect(state, margin, timers)
        overlap = max(0.0, -float(c2.gap.min())) if len(c2) else 0.0
        if overlap <= config.tol:
            break
        if passes >= config.max_passes:
            raise OverlapError(
                f"overlap {overlap:.3g} > tol {config.tol:g} after {passes} re-solve passes "
                f"(N={n}, dt={dt:g}); decrease dt")
        t0 = _time.perf_counter()
        g2, h2 = _solve(solver, spent, c2, state.length, dt, config.lam, None, stol, pass_cap,
                        False)
        t0 = _tick(timers, "solver", t0)
        pass_iterations += len(h2) - 1
        _move(state, c2, g2, dt, state.length)
        sigma = sigma + loads(c2, g2, n)
        _tick(timers, "update", t0)
        passes += 1
    state.stress = sigma
    info = {"iterations": main_iterations + pass_iterations, "pass_iterations": pass_iterations,
            "failed_iterations": 0, "passes": passes, "n_contacts": len(c),
            "residual": float(hist[-1]), "max_overlap": overlap, "contacts": c, "gamma": gamma}
    return info, (keys, gamma)


MAX_HALVINGS = 4
"""A step that fails (OverlapError or ContactSolveError) is retried as two half steps, up to
this many times nested (dt / 16), before the error is raised."""


def robust_step(state: ParticleState, config: ParticleConfig, dt: float,
                warm: tuple[np.ndarray, np.ndarray], timers: dict | None = None,
                depth: int = 0) -> tuple[dict, tuple[np.ndarray, np.ndarray]]:
    """:func:`step`, retried from the same state as two steps of dt/2 when it fails.

    The returned info sums the iteration counts and passes over the sub-steps (the failed
    attempts' iterations under ``failed_iterations``), reports the largest overlap and residual,
    and counts the sub-steps (``substeps``).  Deterministic.
    """
    backup = state.copy()
    spent = [0]
    try:
        info, warm2 = step(state, config, dt, warm, timers, spent)
        info["substeps"] = 1
        return info, warm2
    except (OverlapError, ContactSolveError):
        if depth >= MAX_HALVINGS:
            raise
    for name, value in backup.arrays().items():
        setattr(state, name, value)
    a, warm = robust_step(state, config, dt / 2, warm, timers, depth + 1)
    b, warm = robust_step(state, config, dt / 2, warm, timers, depth + 1)
    info = dict(b)
    for k in ("iterations", "pass_iterations", "failed_iterations", "passes", "substeps"):
        info[k] = a[k] + b[k]
    info["failed_iterations"] += spent[0]
    info["max_overlap"] = max(a["max_overlap"], b["max_overlap"])
    info["residual"] = max(a["residual"], b["residual"])
    return info, warm


DT_GROWTH, DT_SHRINK = 1.02, 0.7
"""Factors of :func:`next_dt`."""


def next_dt(dt: float, info: dict, dt_max: float) -> float:
    """Length of the next step after a step of length dt with diagnostics ``info``.

    The main solve's work is nearly independent of dt (its iterations scale with dt), while
    the re-solve passes grow from a few percent of it to more than all of it, with failed
    attempts, once dt is too long for the colony's speeds (measured, lam = 1e-3 to radius 40:
    187,000 main iterations at dt = 0.005 and at 0.01; pass iterations 15,000 and 395,000).
    So, with r = pass_iterations / (main iterations):

        halved step (substeps > 1)  ->  dt / 2,
        r > 1/2                     ->  DT_SHRINK dt,
        r < 1/4                     ->  min(DT_GROWTH dt, dt_max),
        otherwise                   ->  dt,

    never below dt_max / 2^(MAX_HALVINGS + 2).
    """
    main = info["iterations"] - info["pass_iterations"]
    r = info["pass_iterations"] / max(main, 1)
    if info["substeps"] > 1:
        new = dt / 2
    elif r > 0.5:
        new = DT_SHRINK * dt
    elif r < 0.25:
        new = min(DT_GROWTH * dt, dt_max)
    else:
        new = dt
    return max(new, dt_max / 2 ** (MAX_HALVINGS + 2))


def initial_state(config: ParticleConfig) -> ParticleState:
    """One particle of length 1 at the origin, or the particles of ``config.init``."""
    if config.init is None:
        return ParticleState.from_arrays([0.0], [0.0], [0.0], [1.0])
    try:
        arrays = output.read_init(config.init)
    except UnicodeDecodeError:
        raise ValueError(f"init file {config.init} is not a text CSV file") from None
    try:
        return ParticleState.from_arrays(*arrays)
    except ValueError as err:
        raise ValueError(f"init file {config.init}: {err}") from None


def check_initial(config: ParticleConfig) -> ParticleState:
    """The initial state, checked: no overlap beyond ``config.tol``, and a ``radius`` goal
    larger than the initial colony radius. Raises ValueError (one line) before any step."""
    config.validate()
    state = initial_state(config)
    c = detect(state, 0.0)
    if c.gap.size and c.gap.min() < -config.tol:
        k = int(np.argmin(c.gap))
        raise ValueError(
            f"init file {config.init}: particles {c.i[k]} and {c.j[k]} overlap by "
            f"{-c.gap[k]:.3g} (tolerance tol = {config.tol:.3g})")
    r0 = colony_radius(state)
    if config.radius is not None and config.radius <= r0:
        raise ValueError(f"radius {config.radius:g} is not larger than the initial colony "
                         f"radius {r0:.6g}: nothing to grow")
    return state


def _done(config: ParticleConfig, state: ParticleState, t: float) -> bool:
    if config.time is not None:
        return t >= config.time - 1e-12
    return colony_radius(state) >= config.radius


LEGACY_CONFIG = {"adaptive_dt": False}
"""Values of the configuration fields added after a checkpoint was written, as it ran."""

EXECUTION_FIELDS = ("threads", "checkpoint_seconds")
"""Configuration fields that do not change the result: a checkpoint resumes whatever they are."""

STEP_POLICY_FIELDS = ("dt", "adaptive_dt")
"""Configuration fields that change only the step lengths after the checkpoint (the result
within the time-stepping error): a checkpoint resumes with other values only when asked
(``run(..., change_step_policy=True)``); the history's dt column records every step as it ran
and config.json the changes (``output.write_config``).  Where it pays: paper-scale colonies at
small lam, whose rods turn so fast under loads ~1/lam that a step fixed at the start becomes
too long (README, "Time step"; lam = 1e-4, N >= 6e4: at dt = 0.005 60 % of the solver work
went into failed attempts)."""


#: Free space a run keeps on its output's file system: it stops with ENOSPC before a write
#: could fill it (a trajectory write into a full tmpfs can end the process with SIGBUS).
RESERVE_BYTES = 4 * 2**20


def ensure_space(out: Path, n_particles: int, checkpoint: Path | None = None) -> None:
    """Raise OSError(ENOSPC) unless ``out`` has RESERVE_BYTES free beyond the next writes
    (a frame and a checkpoint of ``n_particles``, at most the last checkpoint's size twice)."""
    need = RESERVE_BYTES + 200 * n_particles
    if checkpoint is not None and checkpoint.exists():
        need += 2 * checkpoint.stat().st_size
    free = shutil.disk_usage(out).free
    if free < need:
        raise OSError(errno.ENOSPC, f"no space left on {out} ({free / 2**20:.1f} MB free, "
                      f"{need / 2**20:.1f} MB needed for the next output)")


def _save_checkpoint(path: Path, config, state, t, nstep, rng, warm, history, frames,
                     dt_next) -> None:
    meta = {"config": asdict(config), "t": t, "step": nstep, "next_id": state.next_id,
            "rng": rng.bit_generator.state, "history": history, "frames": frames,
            "dt_next": dt_next}
    tmp = path.with_name(path.name + ".tmp.npz")
    try:
        np.savez(tmp, meta=np.array(json.dumps(meta)), warm_keys=warm[0], warm_gamma=warm[1],
                 **state.arrays())
        os.replace(tmp, path)
    finally:  # a failed write (e.g. a full disk) leaves the previous checkpoint as it was
        tmp.unlink(missing_ok=True)


def _saved_config(meta: dict) -> dict:
    """The configuration fields a checkpoint's metadata holds (LEGACY_CONFIG where missing)."""
    return {**LEGACY_CONFIG, **meta["config"]}


def checkpoint_config(path: Path) -> ParticleConfig:
    """The configuration the checkpoint at ``path`` was written with."""
    with np.load(path) as z:
        return ParticleConfig(**_saved_config(json.loads(str(z["meta"]))))


def _load_checkpoint(path: Path, config, change_step_policy: bool = False):
    """(state, t, step, rng, warm, history, frames, dt_next) saved by :func:`_save_checkpoint`.

    A checkpoint written before the lineage was tracked has no ``parent`` and ``generation``
    arrays: the particles then present are loaded as initial ones (parent -1, generation 0),
    and their daughters count generations from them.
    """
    with np.load(path) as z:
        meta = json.loads(str(z["meta"]))
        saved = _saved_config(meta)
        now = json.loads(json.dumps(asdict(config)))
        free = EXECUTION_FIELDS + (STEP_POLICY_FIELDS if change_step_policy else ())
        for k in free:
            saved.pop(k, None)
            now.pop(k)
        if saved != now:
            wrong = sorted(k for k in {*saved, *now} if saved.get(k) != now.get(k))
            hint = ("; a changed step policy resumes with change_step_policy=True "
                    "(colony particles --change-step-policy)"
                    if set(wrong) <= set(STEP_POLICY_FIELDS) else "")
            raise ValueError(f"checkpoint {path} belongs to a different configuration "
                             f"(differs in {', '.join(wrong)}){hint}")
        lineage = {k: z[k] for k in ("parent", "generation") if k in z.files}
        st = ParticleState(z["x"], z["y"], z["theta"], z["length"], z["stress"], z["ids"],
                           int(meta["next_id"]), **lineage)
        warm = (z["warm_keys"], z["warm_gamma"])
    rng = np.random.default_rng(config.seed)
    rng.bit_generator.state = meta["rng"]
    return (st, meta["t"], meta["step"], rng, warm, meta["history"], meta["frames"],
            meta.get("dt_next", config.dt))


class _StopRequest:
    """SIGINT / SIGTERM deferred to the end of the current step (main thread only).

    ``install`` replaces the handlers; the first signal sets ``signum`` and puts the previous
    handlers back, so the run can write a checkpoint of a whole step before stopping, while a
    second signal acts at once. ``restore`` puts them back when no signal came.
    """

    def __init__(self):
        self.signum = None
        self._previous = {}

    def install(self) -> "_StopRequest":
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def _handle(self, signum, frame):
        self.signum = signum
        self.restore()

    def restore(self) -> None:
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        self._previous = {}


def run(config: ParticleConfig, out: Path | None = None, progress: bool = False,
        stop_after: int | None = None, change_step_policy: bool = False) -> Colony:
    """Grow a colony until ``config.radius`` or ``config.time``.

    Parameters
    ----------
    config : ParticleConfig
    out : Path, optional
        Existing folder for config.json, history.csv, particles.csv, trajectory.gsd and
        checkpoint.npz.  If it holds a checkpoint of the same configuration the run resumes from
        it, with the same result as an uninterrupted run.
    progress : bool
        tqdm progress bar (only when stderr is a terminal).
    stop_after : int, optional
        Stop after this many steps of this call, writing a checkpoint (as if interrupted);
        the returned Colony has ``finished = False``.
    change_step_policy : bool
        Resume from a checkpoint written with other STEP_POLICY_FIELDS values (config.json then
        holds the new values and, under ``step_policy_changes``, the step and the old and new
        values of each change; the result differs from an uninterrupted run's within the
        time-stepping error).

    SIGINT (Ctrl-C) or SIGTERM (e.g. a batch system's time limit) in the main thread ends the
    run after the current step, with a checkpoint of that step written (then KeyboardInterrupt,
    or SystemExit(128 + signal) for SIGTERM); a second signal interrupts at once.

    Raises
    ------
    ValueError
        Bad configuration or mismatched checkpoint.
    OverlapError, ParticleLimitError, ContactSolveError
        A step failed (see their docstrings).
    """
    config.validate()
    if out is not None:
        out = Path(out)
        if not out.is_dir():
            raise ValueError(f"output folder does not exist: {out}")
    ckpt = None if out is None else out / "checkpoint.npz"
    traj = None if out is None else out / "trajectory.gsd"
    if ckpt is not None and ckpt.exists():
        state, t, nstep, rng, warm, history, frames, dt_next = _load_checkpoint(
            ckpt, config, change_step_policy)
        output.truncate_trajectory(traj, frames[0])
        if change_step_policy:
            dt_next = min(dt_next, config.dt) if config.adaptive_dt else config.dt
            output.write_config(out, config, step=nstep, policy=STEP_POLICY_FIELDS)
    else:
        state = check_initial(config)
        t, nstep, history = 0.0, 0, []
        rng = np.random.default_rng(config.seed)
        warm = (np.zeros(0, dtype=np.int64), np.zeros(0))
        frames = [0, -1]  # [frames written, step of the last frame]
        dt_next = config.dt
        if out is not None:
            output.write_config(out, config)
            if traj.exists():
                traj.unlink()
            output.append_frame(traj, state, 0, t=t)
            frames = [1, 0]
    total = config.time if config.time is not None else config.radius
    bar = tqdm(total=total, disable=not (progress and sys.stderr.isatty()), unit="",
               desc=f"particles lam={config.lam:g}", leave=False)
    last_ckpt = _time.monotonic()
    steps_here = 0
    finished = True
    stop = _StopRequest().install()
    try:
        while not _done(config, state, t):
            dt = dt_next
            if config.time is not None and config.time - t < dt * (1 + 1e-9):
                dt = config.time - t
            info, warm = robust_step(state, config, dt, warm)
            dt_next = next_dt(dt, info, config.dt) if config.adaptive_dt else config.dt
            ndiv = divide(state, rng, config.division_noise)
            t += dt
            nstep += 1
            steps_here += 1
            r = colony_radius(state)
            row = {"step": nstep, "t": t, "dt": dt, "radius": r,
                   "hull_radius": hull_radius(state), "n_particles": state.n,
                   "max_stress": float(state.stress.max()),
                   "mean_stress": float(state.stress.mean()),
                   "max_overlap": info["max_overlap"], "iterations": int(info["iterations"]),
                   "pass_iterations": int(info["pass_iterations"]),
                   "failed_iterations": int(info["failed_iterations"]),
                   "passes": int(info["passes"]), "n_contacts": int(info["n_contacts"]),
                   "residual": info["residual"], "total_length": float(state.length.sum()),
                   "divisions": int(ndiv), "substeps": int(info["substeps"])}
            history.append(row)
            bar.n = min(total, t if config.time is not None else r)
            bar.refresh()
            if state.n > config.max_particles:
                raise ParticleLimitError(
                    f"colony has {state.n} particles > max_particles {config.max_particles}")
            if out is not None:
                if nstep % config.output_every == 0:
                    ensure_space(out, state.n, ckpt)
                    output.append_frame(traj, state, nstep, t=t)
                    frames = [frames[0] + 1, nstep]
                now = _time.monotonic()
                if now - last_ckpt >= config.checkpoint_seconds:
                    ensure_space(out, state.n, ckpt)
                    _save_checkpoint(ckpt, config, state, t, nstep, rng, warm, history, frames,
                                     dt_next)
                    output.write_history(out, history)
                    last_ckpt = now
            if stop.signum is not None and not _done(config, state, t):
                finished = False
                break
            if stop_after is not None and steps_here >= stop_after and not _done(config, state, t):
                finished = False
                break
    finally:
        stop.restore()
        bar.close()
    if out is not None:
        ensure_space(out, state.n, ckpt)
        if finished and frames[1] != nstep:
            output.append_frame(traj, state, nstep, t=t)
            frames = [frames[0] + 1, nstep]
        _save_checkpoint(ckpt, config, state, t, nstep, rng, warm, history, frames, dt_next)
        output.write_history(out, history)
        output.write_particles(out, state)
    if stop.signum == signal.SIGINT:
        raise KeyboardInterrupt  # after the checkpoint of the last whole step
    if stop.signum is not None:
        raise SystemExit(128 + stop.signum)
    return Colony(state.x, state.y, state.theta, state.length, state.stress, state.ids, t,
                  history, finished, state.parent, state.generation)
