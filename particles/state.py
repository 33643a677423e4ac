"""The state of a particle simulation and the record of one step (``StepRecord``).

The state is one mutable object, what a checkpoint saves; a step's record is one row of
history.csv.

Particle n: centre (x_n, y_n), angle theta_n (axis p_n = (cos, sin)), tip-to-tip length l_n,
axial stress sigma_n = (G gamma)_n (``stress``, stress.axial_stress; the load of the growth
law), a unique integer id (ids are never reused: they identify contacts between steps for the
solver's warm start) and its lineage: ``parent`` = the id of the particle whose division made
it (-1 for an initial particle) and ``generation`` = the number of divisions between it and its
initial ancestor (0 for an initial particle; division.divide), and with strains
(particles.strains, ``Config.strains``) its strain s_n (``strain``; inherited at division;
None for a one-strain colony, whose state is as before strains existed).

Beyond the particles the state holds what the next step depends on: the time t, the step
count, the random generator of the division noise, the previous step's contact forces by
contact identity (the warm start) and the length of the next step (adaptive dt).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from .geometry import B
from .measures import enclosing_radius, hull_radius

__all__ = ["B", "ParticleState", "StepRecord"]

#: Per-particle arrays of a state, by attribute name (what checkpoints and copies hold).
PARTICLE_ARRAYS = ("x", "y", "theta", "length", "stress", "ids", "parent", "generation",
                   "strain")
OPTIONAL_ARRAYS = ("strain",)
"""Per-particle arrays a state may lack (None): the strain of a one-strain colony."""


def _no_contacts() -> np.ndarray:
    return np.zeros(0, dtype=np.int64)


@dataclass
class ParticleState:
    """The particles and the time-stepping state of a simulation (see module docstring).

    Attributes
    ----------
    x, y, theta, length, stress : float64 arrays (N,)
        Centres, angles, tip-to-tip lengths l_n and axial stress sigma_n.
    ids : int64 array (N,)
        Unique ids; ``next_id`` is the next unused one.
    next_id : int
    parent : int64 array (N,)
        Id of the mother (the particle whose division made this one), -1 for an initial particle.
    generation : int64 array (N,)
        Divisions since the initial ancestor: 0 for an initial particle, the mother's + 1.
    strain : int64 array (N,) or None
        Each particle's strain s_n, an index into ``Config.strains`` (particles.strains);
        None: one strain.
    t : float
        Time.
    step : int
        Steps taken since t = 0.
    rng : numpy.random.Generator or None
        Generator of the division noise (``Simulation`` seeds it with ``Config.seed``).
    warm_keys, warm_gamma : arrays
        Contact identities (geometry.Contacts.keys) and forces gamma of the last step's main
        solve: the next solve's warm start.
    dt_next : float or None
        Length of the next step (None: ``Config.dt``).

    ``parent`` and ``generation`` None (e.g. a state built from arrays saved before they
    existed) are set to -1 and 0 for every particle: the particles then present count as
    initial ones.
    """

    x: np.ndarray
    y: np.ndarray
    theta: np.ndarray
    length: np.ndarray
    stress: np.ndarray
    ids: np.ndarray
    next_id: int
    parent: np.ndarray | None = None
    generation: np.ndarray | None = None
    strain: np.ndarray | None = None
    t: float = 0.0
    step: int = 0
    rng: np.random.Generator | None = None
    warm_keys: np.ndarray = field(default_factory=_no_contacts)
    warm_gamma: np.ndarray = field(default_factory=lambda: np.zeros(0))
    dt_next: float | None = None

    def __post_init__(self) -> None:
        n = self.x.shape[0]
        if self.parent is None:
            self.parent = np.full(n, -1, dtype=np.int64)
        if self.generation is None:
            self.generation = np.zeros(n, dtype=np.int64)

    @classmethod
    def from_arrays(cls, x, y, theta, length) -> ParticleState:
        """New state at t = 0; ids 0..N-1, stress zero, parent -1, generation 0.

        Raises ValueError on inconsistent input.
        """
        arrs = [np.array(a, dtype=np.float64, ndmin=1) for a in (x, y, theta, length)]
        n = arrs[0].shape[0]
        if any(a.ndim != 1 or a.shape[0] != n for a in arrs):
            raise ValueError("x, y, theta and length must be 1D arrays of equal length")
        if n == 0:
            raise ValueError("a colony needs at least one particle")
        if not all(np.all(np.isfinite(a)) for a in arrs):
            raise ValueError("particle coordinates must be finite")
        if np.any(arrs[3] <= B):
            raise ValueError(f"every particle length must exceed the diameter b = {B}")
        return cls(*arrs, np.zeros(n), np.arange(n, dtype=np.int64), n)

    @property
    def n(self) -> int:
        """Number of particles N."""
        return int(self.x.shape[0])

    @property
    def warm(self) -> tuple[np.ndarray, np.ndarray]:
        """(warm_keys, warm_gamma): the warm start of the next solve."""
        return self.warm_keys, self.warm_gamma

    @warm.setter
    def warm(self, value: tuple[np.ndarray, np.ndarray]) -> None:
        self.warm_keys, self.warm_gamma = value

    def enclosing_radius(self) -> float:
        """Radius of the smallest disc about the centroid holding every particle.

        The colony radius (measures.enclosing_radius).
        """
        return enclosing_radius(self.x, self.y, self.theta, self.length)

    def hull_radius(self) -> float:
        """Hull radius sqrt(convex hull area / pi) (measures.hull_radius)."""
        return hull_radius(self.x, self.y, self.theta, self.length)

    def append(self, x, y, theta, length, ids, parent=None, generation=None,
               strain=None) -> None:
        """Append particles: zero stress, parent -1 and generation 0 unless given.

        ``strain``: the new cells' strains, needed when the state has strains.
        """
        m = len(x)
        parent = np.full(m, -1) if parent is None else parent
        generation = np.zeros(m) if generation is None else generation
        self.x = np.concatenate([self.x, x])
        self.y = np.concatenate([self.y, y])
        self.theta = np.concatenate([self.theta, theta])
        self.length = np.concatenate([self.length, length])
        self.stress = np.concatenate([self.stress, np.zeros(len(x))])
        self.ids = np.concatenate([self.ids, np.asarray(ids, dtype=np.int64)])
        self.parent = np.concatenate([self.parent, np.asarray(parent, dtype=np.int64)])
        self.generation = np.concatenate([self.generation,
                                          np.asarray(generation, dtype=np.int64)])
        if self.strain is not None:
            self.strain = np.concatenate([self.strain, np.asarray(strain, dtype=np.int64)])

    def permute(self, order: np.ndarray) -> None:
        """Reorder the particles: particle k becomes the former particle ``order[k]``.

        Every per-particle array moves; ids, lineage and the warm start (keyed by ids) are
        unchanged.
        """
        for k, a in self.arrays().items():
            setattr(self, k, a[order])

    def copy(self) -> ParticleState:
        """An independent copy (arrays copied; the generator copied with its state)."""
        rng = None
        if self.rng is not None:
            rng = np.random.default_rng()
            rng.bit_generator.state = self.rng.bit_generator.state
        return ParticleState(**{k: a.copy() for k, a in self.arrays().items()},
                             next_id=self.next_id, t=self.t, step=self.step, rng=rng,
                             warm_keys=self.warm_keys.copy(), warm_gamma=self.warm_gamma.copy(),
                             dt_next=self.dt_next)

    def arrays(self) -> dict[str, np.ndarray]:
        """The per-particle arrays by attribute name (what a checkpoint saves; no None ones)."""
        return {k: getattr(self, k) for k in PARTICLE_ARRAYS if getattr(self, k) is not None}


@dataclass(frozen=True)
class StepRecord:
    """What one step did: the row of history.csv (output.HISTORY_COLUMNS).

    The first four attributes (step, t, dt, radius) are the continuum engine's
    ``StepRecord``'s too.

    Attributes
    ----------
    step : int
        Steps since t = 0, this one included.
    t, dt : float
        Time after the step and the step's length.
    radius : float
        Enclosing radius of the colony after the step (measures.enclosing_radius; what a
        radius goal compares).
    hull_radius : float
        Hull radius sqrt(convex hull area / pi) after the step (measures.hull_radius).
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

    @property
    def size(self) -> str:
        """The colony's size in the progress lines: "N particles"."""
        return f"{self.n_particles} particles"

    def row(self) -> dict:
        """The history row (a dict of the fields in their order, as checkpoints store it)."""
        return asdict(self)
