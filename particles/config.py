"""Configuration of a particle simulation: ``Config`` (a dataclass) and its validation.

One configuration object per run (model parameter ``lam``, the stop of a run, the step policy,
the solver and its tolerances, outputs, execution settings); ``output.write_config`` writes it
to config.json next to the results.  Which fields a checkpoint may resume under other values:
``EXECUTION_FIELDS`` (always) and ``STEP_POLICY_FIELDS`` (when asked).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numba

from .geometry import B
from .runfiles import check_nutrient, check_types, type_mismatch
from .strains import LAM_CAP_WHY, MAX_LAM, as_strains

__all__ = ["Config", "EXECUTION_FIELDS", "FILL_LENGTHS", "FILL_ORIENTATIONS", "REMOVED_SOLVERS",
           "SOLVERS", "STEP_CONTROLS", "STEP_POLICY_FIELDS"]

#: Names of the contact solvers (``Config.solver``; the solvers by name: ``solvers.BY_NAME``).
SOLVERS = ("bbpgd", "apgd", "bbpgd-cuda")
#: Solvers that were measured and removed (issue 43), with why: a configuration or checkpoint
#: that names one is refused with this note (the code is in git history, docs/benchmarks.md).
REMOVED_SOLVERS = {"twolevel": "measured, no gain over bbpgd; docs/benchmarks.md"}
#: Step controls of ``stepping.next_dt`` (``Config.step_control``).
STEP_CONTROLS = ("fixed", "overlap", "cost")
#: Orientations of ``packings.fill_outline`` (``Config.fill_orientation``; the first is the
#: default).
FILL_ORIENTATIONS = ("tangent", "rows")
#: Length distributions of ``packings.sample_lengths`` (``Config.fill_lengths``; the first is
#: the default).
FILL_LENGTHS = ("stable", "uniform", "birth")

#: Most time steps a run may take (at least): ``Config.check_budget`` refuses more. A step of the
#: smallest colony, one cell, costs ~2.5 ms (issue 28: 120,451 steps in 5 min at dt = 1e-300),
#: so 1e6 steps are 40 min at the very least, days for a colony of thousands of cells; the
#: paper's colonies took 1,300-2,900 steps (docs/benchmarks.md).
MAX_STEPS = 1_000_000
#: Particles per unit area of a grown colony, the sparsest measured: lam = 0 at radius 150,
#: 65,536 cells = 0.93 pi R^2 (lam = 1e-2: 99,195 = 1.40 pi R^2; docs/benchmarks.md).
PARTICLES_PER_AREA = 0.9
#: Resident bytes per particle of a run, measured: 666 MB peak at 99,281 particles (lam = 1e-2,
#: radius 150; docs/benchmarks.md), rounded up.
BYTES_PER_PARTICLE = 7_000
#: Enclosing radius of the default initial state, one cell of length 1 (packings.single_cell).
SINGLE_CELL_RADIUS = 0.5


@dataclass(frozen=True)
class Config:
    """Configuration of a particle run (all quantities in model units, b = 1/2).

    Validated when made (:meth:`validate`; ValueError); frozen (``dataclasses.replace`` makes
    a changed copy).

    Parameters
    ----------
    lam : float
        Stress sensitivity lambda of the growth law dl/dt = l exp(-lam sigma), in
        [0, strains.MAX_LAM]; required.
    radius, time : float or None
        The goal of a run: the colony radius (the enclosing radius,
        measures.enclosing_radius) or the time t to reach.  At most one; :func:`particles.run`
        needs one, a ``Simulation`` stepped by hand none (``advance()`` without arguments goes
        to this goal).
    dt : float
        Time step (the last step of a ``time`` run is shortened to land on it); with an
        adaptive ``step_control`` the first and largest step.
        Default 0.02 with the "overlap" control, measured to radius 40 against the former
        default (a fixed 0.01): 0.77x, 0.87x and 0.94x the CPU time at lam = 1e-2, 1e-3 and 0,
        no halved step, t at radius 40 within 0.3 % (docs/benchmarks.md, "Step control").
    step_control : str
        "overlap" (default): steps as long as ``dt`` while the overlap a step's linearised
        move leaves is below stepping.MAIN_OVERLAP, shorter where the colony's motion demands
        it; "fixed": every step ``dt``; "cost": adapt to the cost of the re-solve passes
        (stepping.next_dt).
    tol : float
        Largest admitted real overlap b - d after each step (default b/500).
    seed : int
        Seed of the division-angle perturbations.
    division_noise : float
        Amplitude eps (radians): daughters' angles are theta + eps * U(-1, 1).
    init : str or None
        CSV file with columns x,y,theta,length; None: one particle of length 1 at the origin
        (or the state of ``shape``).
    shape : str or None
        Initial shape (continuum.shapes: ``circle:R``, ``ellipse:A,B``, ``rectangle:W,H[,ROUND]``,
        ``star:K,EPS[,R]``, ``polygon:FILE.csv``, ``line:N``), filled with rods by
        packings.fill_outline (``line:N``: packings.line), the lengths seeded by ``seed``.
        ``particles`` does not import ``continuum``, so the engine does not parse it: the
        state is built by ``cases.shapes.initial_particles`` (``colony particles --shape``) and
        given as ``Simulation(config, state=...)`` / ``run(config, state=...)``; the field
        records it (config.json, run.json: ``colony info``) and a resume checks it. Not with
        ``init``.
    fill_orientation : str
        Orientation of the rods of ``shape``: "tangent" (layers along the outline, default) or
        "rows" (parallel to x) (packings.fill_outline).
    fill_lengths : str
        Lengths of the rods of ``shape``: "stable" (density ~ l^-2 on [1, 2], default),
        "uniform" on [1, 2] or "birth" (all 1) (packings.sample_lengths).
    solver : str
        Contact solver name, one of SOLVERS: "bbpgd" (the default), "apgd", or "bbpgd-cuda"
        (BBPGD on a CUDA GPU: the ``gpu`` extra; the same iterates as "bbpgd" to round-off).
    output_every : float
        Time between trajectory frames, in growth times, as in the continuum engine: a frame
        after each step that crosses a multiple of it (output.frame_count), the first and the
        final state always; 0: those two only.  Default 0.2 (10 steps of the largest dt).
        Until issue 43 a step count: older configurations' integers are read as that many
        steps of their ``dt`` (:func:`upgrade`).
    checkpoint_seconds : float
        Wall time between checkpoints when writing to a folder (like ``threads`` an execution
        setting: a run may resume with another value).
    max_hours : float or None
        Wall-clock limit of one ``run`` call: before it passes, the run writes a checkpoint and
        pauses (``Simulation.paused``; runfiles.WallLimit); the same call resumes it. An
        execution setting like ``checkpoint_seconds`` (each leg of a chain may give its own).
        None (the default): no limit.
    max_particles : int
        Guard: a run whose colony exceeds this raises ParticleLimitError.
    solver_tol : float or None
        Residual tolerance of each solve (a gap, see solvers.problem), in (0, tol]; None (the
        default): ``solver_tol_factor`` times tol.
    solver_tol_factor : float
        The solver's residual tolerance in units of tol when ``solver_tol`` is None, in
        (0, 1] (a looser solve leaves overlaps the re-solve passes do not remove): 1 since
        issue 18, 1/2 before (the value of older runs' configurations, LEGACY_CONFIG).  The
        passes hold the real overlap within tol either way.  Measured: at paper scale (lam = 0,
        32,768 particles) 1 takes 0.64x the solver iterations of 1/2; at radius 40 it moves
        the results by 0.6-1.2 seed spreads (docs/validation.md, "Particles";
        docs/benchmarks.md, "Step control at paper scale").
    contact_margin : float
        Pairs with gap <= margin enter the solve.
    max_passes : int
        Re-detection and re-solve passes allowed per step.
    max_iterations : int
        Iteration cap of one solve (ContactSolveError beyond).
    threads : int or "auto"
        Numba threads of the contact solver (its loops over particles and contacts); "auto"
        (the default): one thread below stepping.THREADS_MIN_PARTICLES particles, every usable
        core from there on (stepping.solver_threads).  Give 1 when several runs share the
        cores.  The iterates do not depend on it (sums by fixed blocks,
        solvers.bbpgd.BLOCK), so a run may resume with another value and give the same
        result.
    strains : tuple of (lam, growth) pairs
        The strains i = 0..S-1 of the colony (particles.strains): cell n of strain s_n grows
        at a_s l exp(-lam_s sigma); given as (lam, growth) pairs or {"lam", "growth"} tables,
        stored as a tuple of float pairs. Empty (the default): one strain (``lam``, 1), the
        model and the bits as before; with strains ``lam`` is not used by the model. The
        cells' strains come with the initial state (``ParticleState.strain``, or
        ``Simulation(config, state, layout=...)``); one cell from the configuration is of
        strain 0.
    layout : str or None
        A record of the layout the cells' strains were drawn from at the start, like
        ``shape`` a record of a state built outside the engine: cases.shapes.initial_state
        draws them (continuum.strains.parse_layout, particles.strains.draw_strains). The
        engine refuses it without the cells' strains (a state with strains or ``layout=``).
    nutrient_length : float or None
        ell, the nutrient's penetration length in cell lengths (model.md, "Nutrient
        limitation"): each cell grows at l exp(-lam sigma) f(c(x_n)), the nutrient solved on a
        grid each step with c = 1 outside the colony (particles.nutrients). None (the default):
        no nutrient limitation, the model as before, bit for bit.
    monod_k : float or None
        K > 0 of f(c) = (1 + K) c / (K + c); None (or inf, stored as None): f(c) = c.
    nutrient_grid : float or None
        The nutrient grid's spacing h in cell lengths; None: min(0.5, ell / 8) (the error is
        first order in h: the colony's edge is resolved to a node; particles.nutrients).
    dish_radius : float or None
        R_dish, the nutrient supplied through the agar of a dish: c = 1 on the circle of this
        radius about the origin (the colony's starting point), Laplace c = 0 in the agar
        between it and the colony, the same diffusivity in both (particles.nutrients). Only
        with ``nutrient_length``; larger than the initial colony's radius about the origin. A
        colony that reaches the wall (a cell's centre within nutrients.WALL_MARGIN grid
        spacings of it, or a cell touching it) stops the run with simulation.DishWallError.
        None (the default): supply at the colony's edge.
    """

    lam: float
    radius: float | None = None
    time: float | None = None
    dt: float = 0.02
    tol: float = B / 500
    seed: int = 0
    division_noise: float = 0.02
    init: str | None = None
    shape: str | None = None
    fill_orientation: str = "tangent"
    fill_lengths: str = "stable"
    solver: str = "bbpgd"
    output_every: float = 0.2
    checkpoint_seconds: float = 300.0
    max_hours: float | None = None
    max_particles: int = 500_000
    solver_tol: float | None = None
    solver_tol_factor: float = 1.0
    contact_margin: float = 0.1
    max_passes: int = 20
    max_iterations: int = 200_000
    step_control: str = "overlap"
    threads: int | str = "auto"
    strains: tuple = ()
    layout: str | None = None
    nutrient_length: float | None = None
    monod_k: float | None = None
    nutrient_grid: float | None = None
    dish_radius: float | None = None

    def __post_init__(self) -> None:
        if isinstance(self.strains, (tuple, list)):  # other types: validate names the field
            object.__setattr__(self, "strains", as_strains(self.strains))
        if isinstance(self.monod_k, float) and math.isinf(self.monod_k) and self.monod_k > 0:
            object.__setattr__(self, "monod_k", None)  # first order, one spelling
        self.validate()
        # a time: saved as a float, never as the integer step count of older configurations
        object.__setattr__(self, "output_every", float(self.output_every))

    def validate(self) -> None:
        """Raise ValueError with a one-line message on an inconsistent configuration.

        Called when the configuration is made.  Every field's type first (``type_mismatch``),
        then the goal (at most one of ``radius`` and ``time``), then the fields in the order of
        ``_RULES``.  Whether this machine can do the
        run is :meth:`check_budget`'s question.
        """
        check_types(self)
        if self.lam < 0:
            raise ValueError(f"lam must be a finite number >= 0 for particles, got {self.lam}")
        if self.lam > MAX_LAM:
            raise ValueError(f"lam must be in [0, {MAX_LAM:g}], got {self.lam:g} ({LAM_CAP_WHY})")
        if self.radius is not None and self.time is not None:
            raise ValueError("give at most one of radius and time, not both")
        if self.init is not None and self.shape is not None:
            raise ValueError("give at most one initial state: init (a CSV file) or shape")
        if self.layout is not None and len(self.strains) < 2:
            raise ValueError(f"layout {self.layout!r} needs two or more strains")
        for name, ok, message in _RULES:
            v = getattr(self, name)
            if not ok(v):
                raise ValueError(message(v))
        self._check_nutrient()
        if self.solver_tol is not None and self.solver_tol > self.tol:
            raise ValueError(f"solver_tol must be in (0, tol = {self.tol:g}], got "
                             f"{self.solver_tol:g}: {_LOOSE_SOLVE}")

    def _check_nutrient(self) -> None:
        """The nutrient's fields (one line each): ell, h and R_dish > 0 and finite, K > 0.

        A dish no larger than one cell's radius, the initial colony of a run with neither
        ``init`` nor ``shape``, is refused here; another initial colony's when the run starts
        (simulation.check_dish: its radius about the origin, the dish's centre).
        """
        ell, h, dish = self.nutrient_length, self.nutrient_grid, self.dish_radius
        check_nutrient(ell, self.monod_k, (("nutrient_grid", h), ("dish_radius", dish)))
        if ell is None:
            return
        if h is not None and not (math.isfinite(h) and 0.05 <= h <= ell):
            raise ValueError(f"nutrient_grid must be in [0.05, nutrient_length = {ell:g}] cell "
                             f"lengths, got {h!r}")
        if dish is not None and not (math.isfinite(dish) and dish > 0):
            raise ValueError(f"dish_radius must be a positive finite number (cell lengths), "
                             f"got {dish!r}; leave it unset for supply at the colony's edge")
        if dish is not None and self.init is None and self.shape is None:
            check_dish_fits(dish, SINGLE_CELL_RADIUS, "one cell of length 1 at the origin")

    @property
    def nutrient(self) -> tuple[float, float, float] | None:
        """(ell, K, h) of the nutrient (K = inf: first order), or None without nutrients."""
        if self.nutrient_length is None:
            return None
        ell = self.nutrient_length
        return (ell, math.inf if self.monod_k is None else self.monod_k,
                min(0.5, ell / 8.0) if self.nutrient_grid is None else self.nutrient_grid)

    def check_budget(self, initial_radius: float | None = None) -> None:
        """Raise ValueError (one line, with the estimate) for a run this machine cannot do.

        Refused: a radius goal whose colony (``least_particles``) exceeds ``max_particles`` or,
        at BYTES_PER_PARTICLE per particle, the physical memory; more than MAX_STEPS steps
        (``least_steps``: a bound from dt and the goal, for a radius goal from the initial
        colony's enclosing radius ``initial_radius``; None: the one cell's, SINGLE_CELL_RADIUS,
        when neither ``init`` nor ``shape`` is given, else unknown and the steps unchecked).
        A valid configuration (:meth:`validate`) is assumed.
        """
        if initial_radius is None and self.init is None and self.shape is None:
            initial_radius = SINGLE_CELL_RADIUS
        n = least_particles(self)
        need, memory = n * BYTES_PER_PARTICLE, _physical_memory()
        if n > self.max_particles or need > memory:
            limit = (f"more than max_particles = {self.max_particles}"
                     if n > self.max_particles else f"~{need / 2**30:.3g} GiB, more than the "
                     f"{memory / 2**30:.3g} GiB of this machine's memory")
            raise ValueError(f"radius {self.radius:g} takes {_at_least(n)} particles "
                             f"({PARTICLES_PER_AREA:g} pi R^2, the sparsest colony measured), "
                             f"{limit}")
        steps = least_steps(self, initial_radius)
        if steps > MAX_STEPS:
            goal = (f"time {self.time:g}" if self.time is not None else
                    f"radius {self.radius:g} from the initial radius {initial_radius:.3g} "
                    "(the radius grows at most e-fold per unit time)")
            raise ValueError(f"dt = {self.dt:g} takes {_at_least(steps)} steps to {goal}, "
                             f"more than the {MAX_STEPS:,} a run may take (days of computing); "
                             "give a larger dt or a nearer goal")

    @classmethod
    def type_mismatch(cls, name: str, value) -> str | None:
        """What field ``name`` takes (e.g. "a number") when ``value`` is not of its type, else None.

        The type is the field's annotation (runfiles.type_mismatch); ``monod_k`` also takes
        inf (first order, stored as None).
        """
        if name == "monod_k" and value == math.inf and not isinstance(value, bool):
            return None
        return type_mismatch(cls.__dataclass_fields__[name].type, value)

    @property
    def effective_solver_tol(self) -> float:
        """Residual tolerance of each solve: ``solver_tol``, or solver_tol_factor tol if None."""
        return self.solver_tol_factor * self.tol if self.solver_tol is None else self.solver_tol



def _is_file(path: str) -> bool:
    """Whether ``path`` is a file (False also for a name the system refuses: too long, NUL)."""
    try:
        return Path(path).is_file()
    except (OSError, ValueError):
        return False


MAX_CONTACT_MARGIN = 10.0
"""Largest contact margin (gap, in birth lengths) of the pairs a solve takes: 20 particle
diameters, far beyond any pair a step can bring into contact (the default is 0.1)."""

MIN_OUTPUT_EVERY = 1e-6
"""Shortest time between frames (far below any step; t / output_every stays a finite float)."""

_LOOSE_SOLVE = ("a solve looser than tol leaves overlaps above tol that re-solves as loose do "
                "not remove (measured: 2 tol stops a run at its second cell)")
"""Why a solve's tolerance may not exceed tol (``solver_tol``, ``solver_tol_factor``)."""

_RULES = [  # (field, test, message of a failed test), checked in order by Config.validate
    # after the types (Config.type_mismatch): a test may compare its number
    ("radius", lambda v: v is None or v > 0,
     lambda v: f"radius must be positive, got {v}"),
    ("time", lambda v: v is None or v > 0,
     lambda v: f"time must be positive, got {v}"),
    ("dt", lambda v: 0 < v <= 0.1,
     lambda v: f"dt must be in (0, 0.1], got {v}"),
    ("tol", lambda v: 0 < v < B,
     lambda v: f"tol must be in (0, b = {B}), got {v}"),
    ("solver_tol", lambda v: v is None or v > 0,
     lambda v: f"solver_tol must be positive, got {v}"),
    ("solver_tol_factor", lambda v: 0 < v <= 1,
     lambda v: f"solver_tol_factor must be positive and at most 1, got {v:g}: {_LOOSE_SOLVE}"),
    ("seed", lambda v: v >= 0,
     lambda v: f"seed must be a non-negative integer, got {v}"),
    ("division_noise", lambda v: 0 <= v <= 0.5,
     lambda v: f"division_noise must be in [0, 0.5] rad, got {v}"),
    ("solver", lambda v: v in SOLVERS,
     lambda v: f"unknown solver {v!r}; choose from {sorted(SOLVERS)}"
               + (f" ({v} was removed: {REMOVED_SOLVERS[v]})" if v in REMOVED_SOLVERS else "")),
    ("output_every", lambda v: v == 0 or v >= MIN_OUTPUT_EVERY,
     lambda v: f"output_every must be a time >= {MIN_OUTPUT_EVERY:g}, or 0 (the first and "
               f"last frames only), got {v}"),
    ("checkpoint_seconds", lambda v: v >= 0,
     lambda v: f"checkpoint_seconds must be >= 0, got {v}"),
    ("max_hours", lambda v: v is None or 0 < v < math.inf,
     lambda v: f"max_hours must be positive and finite, or None, got {v}"),
    ("max_particles", lambda v: v >= 1,
     lambda v: f"max_particles must be a positive integer, got {v}"),
    ("contact_margin", lambda v: 0 <= v <= MAX_CONTACT_MARGIN,
     lambda v: f"contact_margin must be in [0, {MAX_CONTACT_MARGIN:g}], got {v}"),
    ("max_passes", lambda v: v >= 0,
     lambda v: f"max_passes must be an integer >= 0, got {v}"),
    ("max_iterations", lambda v: v >= 1,
     lambda v: f"max_iterations must be a positive integer, got {v}"),
    ("step_control", lambda v: v in STEP_CONTROLS,
     lambda v: f"step_control must be one of {', '.join(STEP_CONTROLS)}, got {v!r}"),
    ("threads", lambda v: v == "auto" or (isinstance(v, int)
                                          and 1 <= v <= numba.config.NUMBA_NUM_THREADS),
     lambda v: f"threads must be auto or an integer in [1, {numba.config.NUMBA_NUM_THREADS}], "
               f"got {v!r}"),
    ("init", lambda v: v is None or _is_file(v),
     lambda v: f"init file not found: {v if v.isprintable() else repr(v)}"),
    ("shape", lambda v: v is None or v.strip() != "",
     lambda v: f"shape must be a shape specification such as star:5,0.2,8, got {v!r}"),
    ("fill_orientation", lambda v: v in FILL_ORIENTATIONS,
     lambda v: f"fill_orientation must be one of {', '.join(FILL_ORIENTATIONS)}, got {v!r}"),
    ("fill_lengths", lambda v: v in FILL_LENGTHS,
     lambda v: f"fill_lengths must be one of {', '.join(FILL_LENGTHS)}, got {v!r}"),
]


def least_steps(config: Config, initial_radius: float | None) -> float:
    """A lower bound of the steps of a run: time / dt, or ln(radius / initial_radius) / dt.

    Every step is at most dt long, and the colony's radius grows at most e-fold per unit time:
    every cell grows at the rate exp(-lam sigma) <= 1, and the cells of a line, whose tips move
    fastest, push them out at R per unit time. ``initial_radius`` None (not known yet): no
    bound for a radius goal.
    """
    if config.time is not None:
        return config.time / config.dt
    if config.radius is None or initial_radius is None:
        return 0.0
    return max(math.log(config.radius) - math.log(initial_radius), 0.0) / config.dt


def least_particles(config: Config) -> float:
    """About how many particles the colony holds at its radius goal: PARTICLES_PER_AREA pi R^2."""
    if config.radius is None:
        return 0.0
    return PARTICLES_PER_AREA * math.pi * config.radius * config.radius


def _at_least(x: float) -> str:
    """``at least 1.39e+06``, or ``more than 1e+300`` for what overflows a float."""
    return f"at least {x:.3g}" if x < 1e300 else "more than 1e+300"


def check_dish_fits(dish: float, radius: float, what: str) -> None:
    """ValueError (one line) unless the dish's radius exceeds the initial colony's ``radius``.

    ``what``: the initial colony, in words.
    """
    if not dish > radius:
        raise ValueError(f"dish_radius {dish:g} is not larger than the initial colony's radius "
                         f"{radius:.6g} ({what}): the colony must start inside the dish")


def _physical_memory() -> float:
    """Bytes of physical memory (inf where the system does not say)."""
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, ValueError, OSError):
        return math.inf


LEGACY_CONFIG = {"step_control": "fixed", "shape": None, "fill_orientation": "tangent",
                 "fill_lengths": "stable", "solver_tol_factor": 0.5, "strains": [],
                 "layout": None, "nutrient_length": None, "monod_k": None,
                 "nutrient_grid": None, "dish_radius": None}
"""Values of the configuration fields added after a checkpoint was written, as it ran."""

RENAMED = {"adaptive_dt": ("step_control", {True: "cost", False: "fixed"})}
"""Fields of older configurations: old name -> (new name, old value -> new value)."""


def upgrade(saved: dict) -> dict:
    """An older run's configuration fields in today's names (RENAMED) and defaults (LEGACY).

    An integer ``output_every`` is the step count of a configuration from before issue 43:
    N steps become the time N dt (the frames of a run at fixed steps; with an adaptive step
    control the frames came at least that far apart).
    """
    out = dict(LEGACY_CONFIG)
    for k, v in saved.items():
        name, values = RENAMED.get(k, (k, None))
        out[name] = v if values is None else values[v]
    every = out.get("output_every")
    if isinstance(every, int) and not isinstance(every, bool):
        out["output_every"] = every * out.get("dt", Config.dt)
    return out

EXECUTION_FIELDS = ("threads", "checkpoint_seconds", "max_hours")
"""Configuration fields that do not change the result: a checkpoint resumes whatever they are."""

STEP_POLICY_FIELDS = ("dt", "step_control")
"""Configuration fields that change only the step lengths after the checkpoint (the result
within the time-stepping error): a checkpoint resumes with other values only when asked
(``run(..., change_step_policy=True)``); the history's dt column records every step as it ran
and config.json the changes (``output.write_config``).  Where it pays: paper-scale colonies at
small lam, whose rods turn so fast under stress ~1/lam that a step fixed at the start becomes
too long (README, "Time step"; lam = 1e-4, N >= 6e4: at dt = 0.005 60 % of the solver work
went into failed attempts)."""
