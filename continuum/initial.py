"""A colony's state at t = 0 from a given outline and a given size distribution.

The model's own start is a disc (or the configured shape) with Psi0 = delta(l - 1), or the
smooth bump on the l grid (``Config.initial_sizes``; ``continuum.simulation.initial_state``).
:func:`state_from` starts from anything else, e.g. a particle colony handed to the continuum
(cases.handoff): the boundary polygon is meshed as the configured one would be, and Psi0(x, s)
is evaluated at the mesh nodes, on the l grid (``initial_sizes = "histogram"`` says so in the
configuration; the given Psi0 is used whatever ``initial_sizes`` says).

Growth phase. G is the growth integrated along a material path, so it starts at G0 = 0 here
too: the transported Psi carries the sizes (shifted by G / ln 2 along each path, exactly), and
G only labels how far each element has grown since the start. The closed form
lbar = 2^frac(G / ln 2) (``mean_length``, continuum.growth) is then not the mean length of
these cells (it holds for Psi0 = delta(l - 1) only); ``mean_length_psi`` and
``length_std_psi`` are (continuum.state), and the contours G = k ln 2 (rings.csv) are the
places that have doubled k times since the start, not rings of equal length.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from continuum import mesh
from continuum.sizes import (
    CharacteristicSizes,
    LengthGrid,
)
from continuum.state import State

__all__ = ["state_from", "sizes_from"]


def sizes_from(config, points: NDArray,
               psi0: Callable[[NDArray], ArrayLike] | ArrayLike
               ) -> CharacteristicSizes:
    """Psi0 at the nodes ``points``, carried along the characteristics (``psi_transport``).

    Parameters
    ----------
    config : continuum.Config
        Its ``n_length_cells`` (the grid in s = log2 l).
    points : ndarray (n, 2)
        Node positions.
    psi0 : callable or array_like
        xy (n, 2) -> (n, n_length_cells): the cell averages of n(x, s) = Psi dl/ds, cells
        per unit area per unit s, on the grid's cells [i ds, (i + 1) ds) (phase 0); or one such
        row (n_length_cells,) for every node.

    Raises
    ------
    ValueError
        Wrong shape, negative or non-finite values, or a node with no cells.
    """
    grid = LengthGrid(config.n_length_cells)
    n_nodes = len(points)
    values = psi0(np.asarray(points, dtype=float)) if callable(psi0) else psi0
    values = np.array(values, dtype=float)
    if values.shape == (grid.n_cells,):
        values = np.tile(values, (n_nodes, 1))
    if values.shape != (n_nodes, grid.n_cells):
        raise ValueError(f"Psi0 must have shape ({n_nodes}, {grid.n_cells}) or "
                         f"({grid.n_cells},), got {values.shape}")
    if not np.all(np.isfinite(values)) or np.any(values < 0):
        raise ValueError("Psi0 must be finite and >= 0")
    if np.any(values.sum(axis=1) <= 0):
        raise ValueError("Psi0 has no cells at some node")
    return CharacteristicSizes(grid, values)


def state_from(config, boundary: ArrayLike,
               psi0: Callable[[NDArray], ArrayLike] | ArrayLike) -> State:
    """The colony at t = 0 bounded by ``boundary`` with the size distribution ``psi0``.

    The polygon (checked, made counter-clockwise: continuum.mesh.check_polygon) is resampled
    at h = min(h_max, h_N(area)) and meshed as ``initial_state`` meshes the configured shape;
    G = 0 (module docstring), Psi0 from :func:`sizes_from`, p = 0 (u, g zero until the first
    pressure solve). ``continuum.Simulation(config, state=state)`` grows it.

    Raises
    ------
    PolygonError, ValueError
        A polygon that is not simple, or a bad Psi0.
    """
    return meshed_state(config, mesh.check_polygon(boundary),
                        lambda points: sizes_from(config, points, psi0))


def meshed_state(config, dense: NDArray, sizes: Callable) -> State:
    """The colony at t = 0 inside the dense polygon ``dense``, with Psi0 = sizes(points).

    The polygon is resampled at h = min(h_max, h_N(area)) (mesh.target_spacing) and meshed
    (mesh.colony_mesh); G = 0, p = 0 (u, g zero until the first pressure solve).
    """
    h = mesh.target_spacing(abs(mesh.polygon_area(dense)), config.h_max, config.n_nodes)
    outline = mesh.resample_polygon(dense, spacing=h, min_points=16)
    t0 = time.perf_counter()
    points, tris = mesh.colony_mesh(outline, h, config.interior_coarsening, config.grading)
    n = len(points)
    state = State(points=points, triangles=tris, n_boundary=len(outline), p=np.zeros(n),
                  u=np.zeros((n, 2)), g=np.zeros(n), G=np.zeros(n), sizes=sizes(points))
    state.set_mesh(points, tris, len(outline), h)
    state.timings["meshing"] += time.perf_counter() - t0
    return state
