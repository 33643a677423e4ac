"""The nutrient of a particle colony fed at its edge or through the agar of a dish (model.md).

Each cell n grows at dl_n/dt = l_n exp(-lam sigma_n) f(c(x_n)), f(c) = (1 + K) c / (K + c)
(:func:`uptake`; K = inf: f(c) = c), and takes up nutrient in proportion to its rate of area
growth: with diffusion much faster than growth, ::

    ell^2 Laplace c = s  in the colony,   c = 1 outside it (a well-mixed reservoir at the edge),
    s(x) = sum_n b l_n exp(-lam sigma_n) f(c_n) delta(x - x_n)   (area growth per unit area),

or, in a dish of radius R_dish about the origin (the colony's starting point; ``dish``), with
the same diffusivity in colony and agar, ::

    ell^2 Laplace c = s  for |x| < R_dish  (s = 0 in the agar between colony and wall),
    c = 1  on |x| = R_dish.

Discretisation (:func:`nutrient_at_cells`): a square grid of spacing h over the colony; each
cell's area b l_n is spread onto the four nodes about its centre with bilinear weights (cloud in
cell), which also interpolate c back to the cells (the matrix P, cells x nodes), so that the
source is P^T D f(P c) / h^2, D = diag(b l_n exp(-lam sigma_n)). A node belongs to the colony
where the cells' area per unit area (the occupancy P^T (b l) / h^2, box-averaged over a cell
length: NutrientGrid.occupancy) is at least OCCUPIED; the other nodes hold c = 1. The 5-point
Laplacian then gives ::

    F(c) = ell^2 L c - P^T D f(P c) / h^2 = 0   on the colony's nodes,

monotone in c (f' > 0), solved by Newton's method (one iteration is exact for K = inf, where F
is linear). For a finite K Newton starts from the solution of the linear problem with the
uptake's largest slope, f(c) <= f'(0) c = (1 + K) c / K (f is concave): a subsolution, from
which Newton's iterates rise monotonically to the positive solution; from c = 1 they could
overshoot to c < 0 and converge there, a root of the discrete equations that is not the
nutrient (a packed disc of radius 40, ell = 10, K = 0.5: min c -2.8 against 0.013, in 15
iterations against 5). Each linear system (J symmetric negative definite) is solved directly
up to DIRECT_NODES unknowns and above by conjugate gradients preconditioned with classical
algebraic multigrid (pyamg's Ruge-Stuben, no random start: the same bits every time), to a
relative residual of AMG_TOL (:func:`linear_solve`; 0.6 s against 1.6 s for a packed disc of
radius 100 on h = 0.5, 125,065 unknowns). The error is first order in h: the colony's edge is
resolved to a node (on a packed disc against the Bessel solution, ell = 3: 0.062, 0.032, 0.014
at h = 1, 0.5, 0.25 away from the edge; tests/particles/test_nutrients.py).

In a dish (``dish``: R_dish) the grid covers the dish's disc, with a node at the origin; every
node at a distance >= R_dish from the origin holds c = 1 and every node inside the dish is an
unknown of the same equations, the source P^T D f(P c) / h^2 (zero in the agar, where no cell
deposits) and no occupancy: the colony is where its cells are. The wall is a staircase of
nodes, first order in h, with a coefficient that depends on how the circle falls between the
nodes (a packed disc of radius 6 in a dish of 10, ell = 3, against
continuum.radial_nutrients: max error 5.6e-3, 2.9e-3, 9.1e-4 at h = 0.5, 0.25, 0.125, error
/ h from 0.007 to 0.017 at ten h in [0.1, 1]; tests/particles/test_nutrients.py). The grid
has about (2 R_dish / h)^2 nodes whatever the colony's size (one sparse solve: 5 ms at
R_dish = 8, 40 ms at 20, 0.5 s at 50, h = 0.375; Newton takes several for a finite K). A
cell's centre within WALL_MARGIN h of the wall, or a cell touching it, is the colony reaching
it (:func:`reaches_wall`; the run stops, simulation.DishWallError).

The cells' stress is the last contact solve's, so c is a function of the state at the start of
a step: the step's growth factor f(c_n) needs no state of its own, and a resumed run computes
the same c.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
from scipy.ndimage import uniform_filter
from scipy.sparse.linalg import spsolve

from .geometry import B
from .measures import tips

__all__ = ["uptake", "uptake_slope", "NutrientGrid", "nutrient_at_cells", "nutrient_field",
           "extent", "reaches_wall", "OCCUPIED", "WALL_MARGIN"]

DIRECT_NODES = 40_000
"""Unknowns up to which :func:`linear_solve` is a sparse direct solve (above: AMG-CG; the
measured crossover lies between 20,000 and 45,000 nodes: 0.12 s against 0.11 s at 19,833)."""
AMG_TOL = 1e-13
"""Relative residual of :func:`linear_solve`'s conjugate gradients (the direct solve's
round-off level: the two agree to 2e-13 on a packed disc)."""
OCCUPIED = 0.5
"""A grid node is inside the colony where the cells' area per unit area is at least this."""
SMOOTHING = 1.0
"""Half-width, in cell lengths, of the box average of the occupancy (NutrientGrid.occupancy)."""
NEWTON_TOL = 1e-10
"""Newton's method stops when the update is below this (c is O(1))."""
WALL_MARGIN = 2.0
"""A colony reaches the dish's wall when a cell's centre is within this many grid spacings h of
it (or beyond): its nodes would touch the staircase of nodes held at c = 1."""


def uptake(c, K: float):
    """f(c) = (1 + K) c / (K + c), f(1) = 1; c for K = inf (the continuum's growth.uptake)."""
    c = np.asarray(c, dtype=float)
    return c.copy() if math.isinf(K) else (1.0 + K) * c / (K + c)


def uptake_slope(c, K: float):
    """f'(c) = (1 + K) K / (K + c)^2 (1 for K = inf)."""
    c = np.asarray(c, dtype=float)
    return np.ones_like(c) if math.isinf(K) else (1.0 + K) * K / (K + c) ** 2


class NutrientGrid:
    """The grid of spacing ``h`` over points x, y (a margin of two nodes) and its operators.

    ``dish`` (R_dish, optional): the grid covers the dish's disc about the origin too, with a
    node at the origin. ``P`` (N cells x M nodes, CSR) the bilinear weights of each cell's
    centre; ``shape`` the grid's (rows, columns); ``origin`` its lower-left node.
    """

    def __init__(self, x: np.ndarray, y: np.ndarray, h: float, dish: float | None = None):
        self.h = float(h)
        self.dish = dish
        if dish is None:
            lo = np.array([x.min(), y.min()]) - 2.0 * h
            hi = np.array([x.max(), y.max()]) + 2.0 * h
            nx, ny = (np.ceil((hi - lo) / h).astype(int) + 1)
        else:  # nodes (i h, j h), |i|, |j| <= m: the dish's disc, the cells, two nodes more
            reach = max(float(dish), float(np.max(np.abs(x), initial=0.0)),
                        float(np.max(np.abs(y), initial=0.0)))
            m = math.ceil(reach / h) + 2
            lo = np.array([-m * h, -m * h])
            nx = ny = 2 * m + 1
        self.origin = lo
        self.shape = (int(ny), int(nx))
        fx, fy = (x - lo[0]) / h, (y - lo[1]) / h
        i0, j0 = np.floor(fx).astype(int), np.floor(fy).astype(int)
        ax, ay = fx - i0, fy - j0
        n = len(x)
        cols = np.stack([j0 * nx + i0, j0 * nx + i0 + 1, (j0 + 1) * nx + i0,
                         (j0 + 1) * nx + i0 + 1], axis=1)
        weights = np.stack([(1 - ax) * (1 - ay), ax * (1 - ay), (1 - ax) * ay, ax * ay], axis=1)
        self.P = sp.csr_matrix((weights.ravel(), cols.ravel(), np.arange(0, 4 * n + 1, 4)),
                               shape=(n, nx * ny))
        self.P.sum_duplicates()

    def occupancy(self, area: np.ndarray) -> np.ndarray:
        """The cells' area per unit area at each node, averaged over a cell length.

        The cloud-in-cell deposit P^T area / h^2, box-averaged over the nodes within
        SMOOTHING cell lengths (at least one node) each way: on a grid finer than the cells'
        spacing the deposit alone leaves holes between the cells' centres.
        """
        deposit = (self.P.T @ area / self.h**2).reshape(self.shape)
        width = 2 * max(1, round(SMOOTHING / self.h)) + 1
        return uniform_filter(deposit, size=width, mode="constant").ravel()

    @property
    def size(self) -> int:
        """Number of grid nodes."""
        return self.shape[0] * self.shape[1]

    def in_dish(self) -> np.ndarray:
        """The nodes strictly inside the dish (distance < R_dish from the origin), a mask.

        In grid units about the origin's node, so that the staircase is symmetric.
        """
        ny, nx = self.shape
        i = np.arange(nx) - (nx - 1) // 2
        j = np.arange(ny) - (ny - 1) // 2
        I, J = np.meshgrid(i, j)
        return ((I * I + J * J) < (self.dish / self.h) ** 2).ravel()

    def laplacian(self, inside: np.ndarray) -> tuple[sp.csr_matrix, np.ndarray]:
        """(L_II, L_IO 1): the 5-point Laplacian on the nodes ``inside``, and its coupling.

        The coupling to the other nodes, held at c = 1, as a vector on the inside nodes' rows.
        ``inside``: the colony's nodes, or in a dish every node inside it.
        """
        ny, nx = self.shape
        index = -np.ones(self.size, dtype=np.int64)
        nodes = np.flatnonzero(inside)
        index[nodes] = np.arange(len(nodes))
        i, j = nodes % nx, nodes // nx
        rows, cols, vals = [np.arange(len(nodes))], [np.arange(len(nodes))], [
            np.full(len(nodes), -4.0)]
        outside_sum = np.zeros(len(nodes))
        for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            ii, jj = i + di, j + dj
            ok = (ii >= 0) & (ii < nx) & (jj >= 0) & (jj < ny)
            neighbour = np.where(ok, jj * nx + ii, 0)
            k = np.where(ok, index[neighbour], -1)
            inner = k >= 0
            rows.append(np.flatnonzero(inner))
            cols.append(k[inner])
            vals.append(np.ones(int(inner.sum())))
            outside_sum += ~inner  # a neighbour not inside (or off the grid) holds c = 1
        L = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                          shape=(len(nodes), len(nodes))) / self.h**2
        return L, outside_sum / self.h**2


def _solve(x, y, length, growth, ell: float, K: float, h: float, dish: float | None):
    """(grid, unknown nodes' mask, their c, P_in, P_out 1); None when there is no unknown.

    Newton's method, from c = 1 for K = inf and from the linear subsolution otherwise (module
    docstring).
    """
    grid = NutrientGrid(x, y, h, dish)
    area = B * np.asarray(length, dtype=float)
    inside = grid.occupancy(area) >= OCCUPIED if dish is None else grid.in_dish()
    if not inside.any():
        return None
    L, outside = grid.laplacian(inside)
    nodes = np.flatnonzero(inside)
    P_in = grid.P[:, nodes]
    P_out_ones = np.asarray(grid.P[:, ~inside].sum(axis=1)).ravel()  # c = 1 off the unknowns
    weight = area * np.asarray(growth, dtype=float) / h**2  # D / h^2
    c = np.ones(len(nodes))
    if not math.isinf(K):  # the subsolution of the uptake's largest slope (module docstring)
        slope = (1.0 + K) / K
        c = linear_solve(ell**2 * L - slope * (P_in.T @ sp.diags(weight) @ P_in),
                         slope * (P_in.T @ (weight * P_out_ones)) - ell**2 * outside)
    for _ in range(30):
        cells = P_in @ c + P_out_ones
        F = ell**2 * (L @ c + outside) - P_in.T @ (weight * uptake(cells, K))
        J = ell**2 * L - P_in.T @ sp.diags(weight * uptake_slope(cells, K)) @ P_in
        dc = linear_solve(J, -F)
        c += dc
        if math.isinf(K) or np.max(np.abs(dc)) < NEWTON_TOL:  # K = inf: F linear, one step
            break
    return grid, inside, c, P_in, P_out_ones


def linear_solve(J: sp.spmatrix, rhs: np.ndarray) -> np.ndarray:
    """The solution of J x = rhs, J symmetric negative definite (the nutrient's Jacobian).

    A sparse direct solve up to DIRECT_NODES unknowns; above, conjugate gradients on -J
    preconditioned by Ruge-Stuben AMG (pyamg), to the relative residual AMG_TOL.
    """
    if J.shape[0] <= DIRECT_NODES:
        return spsolve(J.tocsc(), rhs)
    import pyamg

    A = (-J).tocsr()
    return pyamg.ruge_stuben_solver(A).solve(-rhs, tol=AMG_TOL, accel="cg", maxiter=500)


def nutrient_at_cells(x: np.ndarray, y: np.ndarray, length: np.ndarray, growth: np.ndarray,
                      ell: float, K: float, h: float, dish: float | None = None) -> np.ndarray:
    """The nutrient c at each cell's centre (module docstring); c = 1 off the colony's nodes.

    ``growth``: each cell's exp(-lam sigma_n) (times its strain's factor); ``h`` the grid's
    spacing; ``dish``: R_dish, supply on the dish's wall (None: at the colony's edge). Newton's
    method (module docstring).
    """
    solved = _solve(x, y, length, growth, ell, K, h, dish)
    if solved is None:
        return np.ones(len(x))
    _, _, c, P_in, P_out_ones = solved
    return np.clip(P_in @ c + P_out_ones, 0.0, 1.0)


def nutrient_field(x: np.ndarray, y: np.ndarray, length: np.ndarray, growth: np.ndarray,
                   ell: float, K: float, h: float, dish: float | None = None
                   ) -> tuple[NutrientGrid, np.ndarray]:
    """(grid, c at its nodes) of :func:`nutrient_at_cells`'s solve, c = 1 on the fixed nodes.

    The nodes are row-major from ``grid.origin`` (``c.reshape(grid.shape)``).
    """
    solved = _solve(x, y, length, growth, ell, K, h, dish)
    if solved is None:
        grid = NutrientGrid(x, y, h, dish)
        return grid, np.ones(grid.size)
    grid, inside, c, _, _ = solved
    field = np.ones(grid.size)
    field[inside] = c
    return grid, field


def extent(x: np.ndarray, y: np.ndarray, theta: np.ndarray, length: np.ndarray) -> float:
    """The radius of the smallest disc about the origin holding every cell (0 for none).

    The largest distance ``|e|`` of a segment end e from the origin plus b/2, as
    measures.enclosing_radius is about the centroid.
    """
    if len(x) == 0:
        return 0.0
    ex, ey = tips(x, y, theta, length)
    return float(np.max(np.hypot(ex, ey)) + B / 2)


def reaches_wall(x: np.ndarray, y: np.ndarray, theta: np.ndarray, length: np.ndarray,
                 dish: float, h: float) -> bool:
    """Whether the colony reaches the dish's wall (radius ``dish``, grid spacing ``h``).

    A cell's centre within WALL_MARGIN h of it (its nodes would touch the nodes held at
    c = 1), or any cell touching it (:func:`extent` >= dish).
    """
    if len(x) == 0:
        return False
    near = float(np.max(np.hypot(x, y))) >= dish - WALL_MARGIN * h
    return near or extent(x, y, theta, length) >= dish
