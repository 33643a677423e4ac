"""Neighbour search: cell lists in O(N) and a brute-force reference.

A pair (i, j) of sphero-cylinders is a *candidate* when their centres satisfy ::

    |x_i - x_j| <= (l_i + l_j) / 2 + margin,

which holds whenever the segment distance is at most b + margin (each segment lies within
L_n / 2 = (l_n - b) / 2 of its centre).  Cells are squares of side h >= max_n l_n + margin, so
every candidate pair lies in the same or in adjacent cells.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(cache=True)
def _cell_sort(x, y, h):
    n = x.shape[0]
    xmin = x.min()
    ymin = y.min()
    nx = int((x.max() - xmin) / h) + 1
    ny = int((y.max() - ymin) / h) + 1
    cell = np.empty(n, dtype=np.int64)
    for i in range(n):
        cx = int((x[i] - xmin) / h)
        cy = int((y[i] - ymin) / h)
        cell[i] = cy * nx + cx
    start = np.zeros(nx * ny + 1, dtype=np.int64)
    for i in range(n):
        start[cell[i] + 1] += 1
    for c in range(nx * ny):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    order = np.empty(n, dtype=np.int64)
    for i in range(n):
        order[fill[cell[i]]] = i
        fill[cell[i]] += 1
    return cell, start, order, nx, ny


@njit(cache=True)
def _neighbours_of(i, cell, start, order, nx, ny, x, y, length, margin, out, offset):
    """Candidates j > i of particle i in its and the adjacent cells, in cell order.

    Written to out[offset:] when ``out`` is not empty; returns how many.
    """
    c = cell[i]
    cx = c % nx
    cy = c // nx
    m = 0
    for dy in range(-1, 2):
        yy = cy + dy
        if yy < 0 or yy >= ny:
            continue
        for dx in range(-1, 2):
            xx = cx + dx
            if xx < 0 or xx >= nx:
                continue
            cc = yy * nx + xx
            for q in range(start[cc], start[cc + 1]):
                j = order[q]
                if j <= i:
                    continue
                rx = x[j] - x[i]
                ry = y[j] - y[i]
                cut = 0.5 * (length[i] + length[j]) + margin
                if rx * rx + ry * ry <= cut * cut:
                    if out.shape[0] > 0:
                        out[offset + m] = j
                    m += 1
    return m


@njit(cache=True, parallel=True)
def _cell_pairs(x, y, length, margin, h):
    """Every candidate pair (i, j), i < j, sorted lexicographically: particles in parallel.

    Each particle counts, then writes and sorts (insertion sort of its few j) its own slice,
    so the result does not depend on the number of threads.
    """
    cell, start, order, nx, ny = _cell_sort(x, y, h)
    n = x.shape[0]
    none = np.zeros(0, dtype=np.int64)
    count = np.zeros(n + 1, dtype=np.int64)
    for i in prange(n):
        count[i + 1] = _neighbours_of(i, cell, start, order, nx, ny, x, y, length, margin,
                                      none, 0)
    for i in range(n):
        count[i + 1] += count[i]
    out_i = np.empty(count[n], dtype=np.int64)
    out_j = np.empty(count[n], dtype=np.int64)
    for i in prange(n):
        a = count[i]
        _neighbours_of(i, cell, start, order, nx, ny, x, y, length, margin, out_j, a)
        for p in range(a, count[i + 1]):
            out_i[p] = i
            v = out_j[p]
            q = p - 1
            while q >= a and out_j[q] > v:
                out_j[q + 1] = out_j[q]
                q -= 1
            out_j[q + 1] = v
    return out_i, out_j


def candidate_pairs(
    x: np.ndarray, y: np.ndarray, length: np.ndarray, margin: float
) -> tuple[np.ndarray, np.ndarray]:
    """Candidate contact pairs by cell lists, O(N).

    Parameters
    ----------
    x, y, length : arrays of shape (N,)
        Centres and tip-to-tip lengths l_n.
    margin : float
        Extra reach beyond touching (gap phi <= margin can be a contact).

    Returns
    -------
    i, j : int64 arrays, i < j, sorted lexicographically
        All pairs with ``|x_i - x_j| <= (l_i + l_j)/2 + margin``.
    """
    x = np.ascontiguousarray(x, dtype=np.float64)
    y = np.ascontiguousarray(y, dtype=np.float64)
    length = np.ascontiguousarray(length, dtype=np.float64)
    if not (x.shape == y.shape == length.shape) or x.ndim != 1:
        raise ValueError("x, y and length must be 1D arrays of equal length")
    if margin < 0:
        raise ValueError(f"margin must be >= 0, got {margin}")
    if x.size < 2:
        e = np.zeros(0, dtype=np.int64)
        return e, e.copy()
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ValueError("particle positions must be finite")
    return _cell_pairs(x, y, length, margin, float(length.max()) + margin)


ORDER_CELL = 1.0
"""Side of the grid cells of :func:`spatial_order` (about one particle length)."""


def _spread_bits(v: np.ndarray) -> np.ndarray:
    """The bits of 32-bit integers v spread to the even bit positions of 64-bit ones."""
    v = v & np.uint64(0xFFFFFFFF)
    for shift, mask in ((16, 0x0000FFFF0000FFFF), (8, 0x00FF00FF00FF00FF),
                        (4, 0x0F0F0F0F0F0F0F0F), (2, 0x3333333333333333),
                        (1, 0x5555555555555555)):
        v = (v | (v << np.uint64(shift))) & np.uint64(mask)
    return v


def spatial_order(x: np.ndarray, y: np.ndarray, h: float = ORDER_CELL) -> np.ndarray:
    """The permutation that puts the particles in Morton (Z-curve) order of their centres.

    Centres are binned on a grid of side ``h`` from the lower left corner; the cells are
    ordered by interleaving the bits of their column and row (ix, iy), ties in the present
    order (stable sort).  Neighbours in space then lie near each other in memory, which is
    what the contact solver's per-contact reads of both particles need (measured: 1.65x fewer
    seconds per solver iteration at 32,768 particles, docs/benchmarks.md).
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if x.size == 0:
        return np.zeros(0, dtype=np.int64)
    ix = np.floor((x - x.min()) / h).astype(np.uint64)
    iy = np.floor((y - y.min()) / h).astype(np.uint64)
    key = _spread_bits(ix) | (_spread_bits(iy) << np.uint64(1))
    return np.argsort(key, kind="stable")
