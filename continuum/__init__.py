"""The continuum colony: moving-boundary Darcy growth with size-distribution transport.

On the colony Omega(t): u = -grad p, div u = g = exp(-lam p), p = 0 on the boundary, the
boundary moving with u; the growth phase G = int g dt and the cell-size distribution Psi(x, l, t)
carried by the material (docs/model.md). A short use::

    import continuum
    sim = continuum.Simulation(continuum.Config(lam=1e-2))
    record = sim.step()                  # a StepRecord: step, t, dt, radius, remesh, ...
    state = sim.advance(radius=5.0)      # the State: mesh, fields, Psi, t, counters
    print(state.t, state.fields["G"].max(), len(state.points))
    sim.save("colony.npz")               # Simulation.load("colony.npz") continues bit for bit
    sim = continuum.run(continuum.Config(lam=1e-2, radius=12), out=folder)  # a run folder

The same contract as ``particles`` (``Config``, ``Simulation(config, state=None, out=None)``
with ``step``, ``done``, ``advance``, ``save``, ``load``; ``run``; docs/DESIGN.md).

Modules, one concept each:

- ``growth``: the growth law g = exp(-lam p) and the mean length lbar = 2^frac(G / ln 2);
- ``shapes``: the initial shape's specification (circle, ellipse, rectangle, star, polygon) and
  its outline;
- ``mesh``: boundary polygons, Triangle meshes of the colony, point location;
- ``fem``: the pressure's P1 / P2 Lagrange space and its assembly through scikit-fem;
- ``pressure``: Newton + AMG-preconditioned CG for -Laplace p = exp(-lam p), p = 0 on the edge;
- ``darcy``: the Darcy problem, ``darcy_flow``: (p, u, g) at given node positions (the pressure
  solve, then u = -grad p);
- ``velocity``: u = -grad p (patch recovery inside, residual flux on the boundary);
- ``motion``: Heun's step of the material nodes, G and Psi; the stable dt;
- ``remesh``: when to remesh, the new mesh, the transfer of G, Psi and p;
- ``sizes``: Psi(x, l, t) in s = log2 l, transport with the division condition;
- ``state``: the ``State`` of a colony and the ``StepRecord`` of a step;
- ``config``: ``Config``, the configuration of a run (validated when made, frozen);
- ``simulation``: ``Simulation``, ``run``;
- ``initial``: the state at t = 0 from any polygon and Psi0 (``state_from``; e.g. a particle
  colony handed over by cases.handoff), grown by ``Simulation(config, state=state)``;
- ``checkpoint``: checkpoint files (``save_checkpoint``, ``load_checkpoint``), SIGINT /
  SIGTERM / SIGHUP deferred to the end of a step (``StopRequest``);
- ``output``: the run folder's files (history, boundary, rings, VTU frames);
- ``strains``: strains of a colony (stress sensitivity, growth factor), their fractions phi
  carried by the material, the mixture's source, initial layouts and interfaces
  (``Config.strains``, ``Simulation(config, layout=...)``);
- ``radial``: the exact 1D reference of a disc colony (R(t), p, u, characteristics, rings);
- ``radial_strains``: the exact 1D reference of concentric strains (core and shells);
- ``ellipse``: the exact lam = 0 ellipse (semi-axes in time; a polygon's moment axes);
- ``stability``: the linear rate of a mode-K boundary perturbation of a disc colony;
- ``rings``: the rings G = k ln 2 of a 2D field (contours and their radii);
- ``budget``: the size of a run's mesh and memory, estimated before meshing.
"""

from __future__ import annotations

from importlib import metadata as _metadata

from continuum.budget import BudgetError
from continuum.config import Config
from continuum.growth import growth_rate, mean_length
from continuum.initial import state_from
from continuum.mesh import PolygonError
from continuum.pressure import PressureDivergence
from continuum.radial import R0, NoRadialSolution, ring_radii
from continuum.radial import radius as radial_radius
from continuum.rings import ring_table
from continuum.simulation import Simulation, run
from continuum.state import State, StepRecord

try:
    __version__ = _metadata.version("colony-mechanics")
except _metadata.PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0+unknown"

__all__ = [
    "__version__",
    "Config",
    "Simulation",
    "State",
    "StepRecord",
    "run",
    "state_from",
    "growth_rate",
    "mean_length",
    "radial_radius",
    "ring_radii",
    "ring_table",
    "R0",
    "PressureDivergence",
    "BudgetError",
    "PolygonError",
    "NoRadialSolution",
]
