"""particles: growing, dividing sphero-cylinders with hard contacts (model.md, "Discrete model").

A Numba engine as a library: a configuration (:class:`Config`), a simulation object that steps
one explicit state (:class:`Simulation`, :class:`ParticleState`, :class:`StepRecord`), a run
loop with outputs, checkpoints and signals (:func:`run`), initial configurations and the
colony measures.

>>> import particles
>>> sim = particles.Simulation(particles.Config(lam=1e-2, seed=1))
>>> record = sim.step()
>>> state = sim.advance(radius=6.0)
>>> print(state.n, state.t, state.stress.max())  # doctest: +SKIP

The same contract as ``continuum`` (``Config``, ``Simulation(config, state=None, out=None)``
with ``step``, ``done``, ``advance``, ``save``, ``load``; ``run``; docs/DESIGN.md).

Modules by concept: ``config`` (Config, the options' names), ``state`` (ParticleState,
StepRecord), ``neighbours`` (cell lists), ``geometry`` (contacts, D gamma), ``stress`` (the
axial stress sigma = G gamma), ``growth`` (the growth law exp(-lam sigma)), ``strains``
(inherited traits: each cell's lam and growth factor), ``division`` (the division rule),
``solvers`` (the per-step convex problem: ``solvers.problem``, and one file per solver,
``solvers.bbpgd``, ``solvers.apgd``), ``stepping`` (one step, halving, adaptive dt),
``simulation`` (Simulation, run), ``checkpoint`` (save_checkpoint, load_checkpoint,
StopRequest), ``output`` (files), ``packings`` (initial configurations), ``measures`` (colony
radii).
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

from .config import Config
from .division import divide
from .geometry import B
from .growth import grow
from .measures import enclosing_radius, hull_radius
from .output import read_trajectory
from .packings import fill_outline, from_csv, line, ring_packing, single_cell
from .simulation import DishWallError, ParticleLimitError, Simulation, run
from .solvers import ContactSolveError
from .state import ParticleState, StepRecord
from .stepping import OverlapError
from .stress import axial_stress

try:
    __version__ = version("colony-mechanics")
except PackageNotFoundError:  # not installed (a source tree on sys.path)
    __version__ = "0+unknown"

__all__ = [
    "B",
    "Config",
    "ContactSolveError",
    "DishWallError",
    "OverlapError",
    "ParticleLimitError",
    "ParticleState",
    "Simulation",
    "StepRecord",
    "__version__",
    "axial_stress",
    "divide",
    "enclosing_radius",
    "fill_outline",
    "from_csv",
    "grow",
    "hull_radius",
    "line",
    "read_trajectory",
    "ring_packing",
    "run",
    "single_cell",
]
