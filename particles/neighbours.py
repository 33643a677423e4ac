"""Neighbour search: cell lists in O(N) and a brute-force reference.

A pair (i, j) of sphero-cylinders is a *candidate* when their centres satisfy ::

    |x_i - x_j| <= (l_i + l_j) / 2 + margin,

which holds whenever the segment distance is at most b + margin (each segment lies within
L_n / 2 = (l_n - b) / 2 of its centre).  Cells are squares of side h >= max_n l_n + margin, so
every candidate pair lies in the same or in adjacent cells.
"""

from __future__ import annotations

import numpy as np
from numba import njit


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
def _cell_pairs(x, y, length, margin, h, count_only, out_i, out_j):
    cell, start, order, nx, ny = _cell_sort(x, y, h)
    n = x.shape[0]
    m = 0
    for i in range(n):
        c = cell[i]
        cx = c % nx
        cy = c // nx
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
                        if not count_only:
                            out_i[m] = i
                            out_j[m] = j
                        m += 1
    return m


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
    h = float(length.max()) + margin
    dummy = np.zeros(0, dtype=np.int64)
    m = _cell_pairs(x, y, length, margin, h, True, dummy, dummy)
    out_i = np.empty(m, dtype=np.int64)
    out_j = np.empty(m, dtype=np.int64)
    _cell_pairs(x, y, length, margin, h, False, out_i, out_j)
    key = np.lexsort((out_j, out_i))
    return out_i[key], out_j[key]


def brute_force_pairs(
    x: np.ndarray, y: np.ndarray, length: np.ndarray, margin: float
) -> tuple[np.ndarray, np.ndarray]:
    """Reference O(N^2) version of :func:`candidate_pairs` (same criterion, same order)."""
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    length = np.asarray(length, dtype=np.float64)
    d2 = (x[:, None] - x[None, :]) ** 2 + (y[:, None] - y[None, :]) ** 2
    cut = 0.5 * (length[:, None] + length[None, :]) + margin
    i, j = np.nonzero(np.triu(d2 <= cut * cut, k=1))
    return i.astype(np.int64), j.astype(np.int64)
