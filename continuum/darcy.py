"""The Darcy problem of the colony: the pressure and the flow at given node positions.

On the colony Omega (model.md, "Continuum model")::

    u = -grad p,   div u = g = exp(-lam p)   in Omega,   p = 0 on the boundary,

i.e. -Laplace p = exp(-lam p) for the pressure, then the Darcy velocity u = -grad p and the
growth rate g. :func:`darcy_flow` is this solve, the one the stepping calls twice per time step
(continuum.motion.heun_step, continuum.simulation): p by Newton's method with AMG-preconditioned
CG (``continuum.pressure.PressureSolver``, P1 or P2 Lagrange elements), u = -grad p at the mesh
nodes (continuum.velocity: P1 patch recovery inside and the consistent residual flux on the
boundary, P2 element gradients at the vertices), g = exp(-lam p) (continuum.growth) as Newton
evaluated it at the solution.
"""

from __future__ import annotations

import numpy as np

from continuum.pressure import PressureSolver
from continuum.velocity import nodal_velocity, vertex_velocity

__all__ = ["darcy_flow"]


def darcy_flow(
    solver: PressureSolver, points: np.ndarray, p0: np.ndarray | None = None, where: str = ""
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pressure, velocity and growth rate of the colony whose nodes are at ``points``.

    Solves -Laplace p = exp(-lam p), p = 0 on the boundary (``solver``, topology set by its
    ``set_mesh``, warm start ``p0``), then u = -grad p (P1: continuum.velocity.nodal_velocity,
    P2: continuum.velocity.vertex_velocity); g = exp(-lam p) is the one Newton evaluated at the
    solution. p, u and g are at the mesh nodes (the vertices). The solve's diagnostics are in
    ``solver.stats``.

    Returns
    -------
    p : ndarray (N,); u : ndarray (N, 2); g : ndarray (N,)

    Raises
    ------
    PressureDivergence
        No pressure solution (see ``PressureSolver.solve``).
    """
    p = solver.solve(points, p0, where=where)
    last = solver.last
    if solver.element == "P2":
        u = vertex_velocity(solver.space, points, last["p"])
    else:
        u = nodal_velocity(solver.assembler, points, p, last["residual"],
                           (last["area"], last["grads"]))
    return p, u, last["g"][: len(p)]
