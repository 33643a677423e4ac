"""The nutrient of a particle colony fed at its edge (model.md, "Nutrient limitation").

Each cell n grows at dl_n/dt = l_n exp(-lam sigma_n) f(c(x_n)), f(c) = (1 + K) c / (K + c)
(:func:`uptake`; K = inf: f(c) = c), and takes up nutrient in proportion to its rate of area
growth: with diffusion much faster than growth, ::

    ell^2 Laplace c = s  in the colony,   c = 1 outside it (a well-mixed reservoir at the edge),
    s(x) = sum_n b l_n exp(-lam sigma_n) f(c_n) delta(x - x_n)   (area growth per unit area).

Discretisation (:func:`nutrient_at_cells`): a square grid of spacing h over the colony; each
cell's area b l_n is spread onto the four nodes about its centre with bilinear weights (cloud in
cell), which also interpolate c back to the cells (the matrix P, cells x nodes), so that the
source is P^T D f(P c) / h^2, D = diag(b l_n exp(-lam sigma_n)). A node belongs to the colony
where the cells' area per unit area (the occupancy P^T (b l) / h^2, box-averaged over a cell
length: NutrientGrid.occupancy) is at least OCCUPIED; the other nodes hold c = 1. The 5-point
Laplacian then gives ::

    F(c) = ell^2 L c - P^T D f(P c) / h^2 = 0   on the colony's nodes,

monotone in c (f' > 0), solved by Newton's method with a sparse direct solver (one iteration is
exact for K = inf, where F is linear). The error is first order in h: the colony's edge is
resolved to a node (on a packed disc against the Bessel solution, ell = 3: 0.062, 0.032, 0.014
at h = 1, 0.5, 0.25 away from the edge; tests/particles/test_nutrients.py). The cells' stress
is the last contact solve's, so c is a function of the state at the start of a step: the step's
growth factor f(c_n) needs no state of its own, and a resumed run computes the same c.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
from scipy.ndimage import uniform_filter
from scipy.sparse.linalg import spsolve

from .geometry import B

__all__ = ["uptake", "uptake_slope", "NutrientGrid", "nutrient_at_cells", "OCCUPIED"]

OCCUPIED = 0.5
"""A grid node is inside the colony where the cells' area per unit area is at least this."""
SMOOTHING = 1.0
"""Half-width, in cell lengths, of the box average of the occupancy (NutrientGrid.occupancy)."""
NEWTON_TOL = 1e-10
"""Newton's method stops when the update is below this (c is O(1))."""


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

    ``P`` (N cells x M nodes, CSR) the bilinear weights of each cell's centre; ``shape`` the
    grid's (rows, columns); ``origin`` its lower-left node.
    """

    def __init__(self, x: np.ndarray, y: np.ndarray, h: float):
        self.h = float(h)
        lo = np.array([x.min(), y.min()]) - 2.0 * h
        hi = np.array([x.max(), y.max()]) + 2.0 * h
        self.origin = lo
        nx, ny = (np.ceil((hi - lo) / h).astype(int) + 1)
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

    def laplacian(self, inside: np.ndarray) -> tuple[sp.csr_matrix, np.ndarray]:
        """(L_II, L_IO 1): the 5-point Laplacian on the nodes ``inside``, and its coupling.

        The coupling to the other nodes, held at c = 1, as a vector on the inside nodes' rows.
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
            outside_sum += ~inner  # a neighbour outside the colony (or the grid) holds c = 1
        L = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                          shape=(len(nodes), len(nodes))) / self.h**2
        return L, outside_sum / self.h**2


def nutrient_at_cells(x: np.ndarray, y: np.ndarray, length: np.ndarray, growth: np.ndarray,
                      ell: float, K: float, h: float) -> np.ndarray:
    """The nutrient c at each cell's centre (module docstring); c = 1 off the colony's nodes.

    ``growth``: each cell's exp(-lam sigma_n) (times its strain's factor); ``h`` the grid's
    spacing. Newton's method from c = 1.
    """
    grid = NutrientGrid(x, y, h)
    area = B * np.asarray(length, dtype=float)
    inside = grid.occupancy(area) >= OCCUPIED
    if not inside.any():
        return np.ones(len(x))
    L, outside = grid.laplacian(inside)
    nodes = np.flatnonzero(inside)
    P_in = grid.P[:, nodes]
    P_out_ones = np.asarray(grid.P[:, ~inside].sum(axis=1)).ravel()  # c = 1 off the colony
    weight = area * np.asarray(growth, dtype=float) / h**2  # D / h^2
    c = np.ones(len(nodes))
    for _ in range(30):
        cells = P_in @ c + P_out_ones
        F = ell**2 * (L @ c + outside) - P_in.T @ (weight * uptake(cells, K))
        J = ell**2 * L - P_in.T @ sp.diags(weight * uptake_slope(cells, K)) @ P_in
        dc = spsolve(J.tocsc(), -F)
        c += dc
        if math.isinf(K) or np.max(np.abs(dc)) < NEWTON_TOL:  # K = inf: F linear, one step
            break
    return np.clip(P_in @ c + P_out_ones, 0.0, 1.0)
