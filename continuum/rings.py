"""Rings of the continuum colony: level sets of the growth phase G (model.md, "Continuum model").

For the model's initial Psi0 = delta(l - 1) the mean cell length is lbar = 2^frac(G / ln 2), G the
growth phase int g dt of each material element: lbar jumps from 2 to 1 wherever G crosses
k ln 2. Ring k is therefore the curve G = k ln 2 (k = 1, 2, ...). G is smooth, so its level sets
are found accurately from the P1 field of the solver, while any average of the discontinuous
lbar (an annulus mean, a binned profile) smears the jump over the averaging width.

Marching triangles. On a triangle with nodal values G_0, G_1, G_2 the P1 interpolant is linear;
with the node classes s_i = [G_i >= c], a triangle whose classes differ is cut by the level
c along a straight segment joining the two points of its edges (i, j) with s_i != s_j::

    x = x_i + t (x_j - x_i),   t = (c - G_i) / (G_j - G_i)   in [0, 1).

Points are computed once per mesh edge, so the segments of neighbouring triangles share their
end points and chain into polylines (closed, or ending on the boundary); the number of chained
pieces is reported. For a ring with segments S and the centre x_c (by default the colony's
area centroid ``sum_T |T| x_T / sum_T |T|``)::

    length       L = sum_S |S|,
    mean radius  rbar = (1/L) sum_S int_S |x - x_c| ds       (3-point Gauss-Legendre per segment),
    min radius   min over the contour of |x - x_c| (exact per segment: the closest point),
    max radius   max over the contour of |x - x_c| (at a segment end).

Accuracy: the P1 interpolant of a smooth G differs from it by O(h^2), so the contour moves
by ``O(h^2) / |grad G|`` and rbar, L are O(h^2) accurate (measured in
tests/continuum/test_rings.py: orders about 2 for a manufactured radial field).
:func:`ring_table` returns one row per level with a crossing; ``continuum.output.write_rings``
writes them to ``rings.csv``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from continuum.growth import LN2
from continuum.mesh import triangle_areas

__all__ = ["LN2", "COLUMNS", "area_centroid", "contour_segments", "level_curve", "ring_levels",
           "ring_table", "ring_wavelength"]


COLUMNS = ("k", "level", "mean_radius", "min_radius", "max_radius", "length", "cx", "cy",
           "n_pieces")
"""Columns of a ring table (and rings.csv): ring index k, level k ln 2, the radii about the
centre (cx, cy), contour length, and the number of chained pieces of the contour."""

# Gauss-Legendre nodes and weights on [0, 1]
_GL_T = 0.5 + 0.5 * np.array([-math.sqrt(0.6), 0.0, math.sqrt(0.6)])
_GL_W = np.array([5.0, 8.0, 5.0]) / 18.0


def _check_mesh(points: ArrayLike, triangles: ArrayLike, G: ArrayLike
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    points = np.asarray(points, dtype=float)
    if points.ndim != 2 or points.shape[1] < 2:
        raise ValueError(f"points must have shape (n, 2), got {points.shape}")
    points = points[:, :2]
    tris = np.asarray(triangles, dtype=np.int64)
    if tris.ndim != 2 or tris.shape[1] != 3:
        raise ValueError(f"triangles must have shape (m, 3), got {tris.shape}")
    if tris.size and (tris.min() < 0 or tris.max() >= len(points)):
        raise ValueError("triangle node index out of range")
    G = np.asarray(G, dtype=float).ravel()
    if G.shape != (len(points),):
        raise ValueError(f"G must have one value per node ({len(points)}), got {G.shape}")
    if not (np.all(np.isfinite(points)) and np.all(np.isfinite(G))):
        raise ValueError("points and G must be finite")
    return points, tris, G


def area_centroid(points: ArrayLike, triangles: ArrayLike) -> np.ndarray:
    """Area centroid ``sum_T |T| (x_a + x_b + x_c)/3 / sum_T |T|`` of a triangle mesh."""
    points = np.asarray(points, dtype=float)[:, :2]
    tris = np.asarray(triangles, dtype=np.int64)
    a, b, c = (points[tris[:, i]] for i in range(3))
    area = np.abs(triangle_areas(points, tris))
    if area.sum() <= 0:
        raise ValueError("mesh has zero area")
    return (area[:, None] * (a + b + c) / 3.0).sum(0) / area.sum()


def contour_segments(points: ArrayLike, triangles: ArrayLike, G: ArrayLike, level: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Segments of the level set {G_h = level} of the P1 field G_h (marching triangles).

    Returns
    -------
    segments : (S, 2, 2) end points of the segments, one per cut triangle;
    edge_ids : (S, 2) int, the mesh edge (an id unique per edge) carrying each end point, so
        segments sharing an id are joined there.
    """
    points, tris, G = _check_mesh(points, triangles, G)
    above = G >= level
    cls = above[tris]
    cut = cls.any(axis=1) & ~cls.all(axis=1)
    t3 = tris[cut]
    if t3.size == 0:
        return np.empty((0, 2, 2)), np.empty((0, 2), dtype=np.int64)
    ends, ids = [], []
    n = len(points)
    for i, j in ((0, 1), (1, 2), (2, 0)):
        a, b = t3[:, i], t3[:, j]
        crosses = above[a] != above[b]
        ga, gb = G[a], G[b]
        with np.errstate(invalid="ignore", divide="ignore"):
            t = np.where(crosses, (level - ga) / (gb - ga), np.nan)
        ends.append(points[a] + t[:, None] * (points[b] - points[a]))
        ids.append(np.where(crosses, np.minimum(a, b) * n + np.maximum(a, b), -1))
    ends = np.stack(ends, axis=1)  # (S, 3, 2), nan on the uncut edge
    ids = np.stack(ids, axis=1)  # (S, 3)
    keep = ids >= 0  # exactly two per cut triangle
    segments = ends[keep].reshape(-1, 2, 2)
    return segments, ids[keep].reshape(-1, 2)


def _pieces(edge_ids: np.ndarray) -> int:
    """Number of connected polylines formed by segments joined at shared edge points."""
    if edge_ids.size == 0:
        return 0
    _, inv = np.unique(edge_ids.ravel(), return_inverse=True)
    inv = inv.reshape(-1, 2)
    m = int(inv.max()) + 1
    graph = coo_matrix((np.ones(len(inv)), (inv[:, 0], inv[:, 1])), shape=(m, m))
    return int(connected_components(graph, directed=False)[0])


def _segment_radii(seg: np.ndarray, center: np.ndarray) -> tuple[float, float, float, float]:
    """``(length, int |x - c| ds, min |x - c|, max |x - c|)`` over segments (S, 2, 2)."""
    p, q = seg[:, 0] - center, seg[:, 1] - center
    d = q - p
    length = np.hypot(d[:, 0], d[:, 1])
    x = p[:, None, :] + _GL_T[None, :, None] * d[:, None, :]
    integral = float((length * (np.hypot(x[..., 0], x[..., 1]) @ _GL_W)).sum())
    dd = np.maximum((d * d).sum(1), 1e-300)
    s = np.clip(-(p * d).sum(1) / dd, 0.0, 1.0)
    closest = p + s[:, None] * d
    r_min = float(np.hypot(closest[:, 0], closest[:, 1]).min())
    r_max = float(np.maximum(np.hypot(p[:, 0], p[:, 1]), np.hypot(q[:, 0], q[:, 1])).max())
    return float(length.sum()), integral, r_min, r_max


def level_curve(points: ArrayLike, triangles: ArrayLike, f: ArrayLike, level: float,
                center: ArrayLike) -> tuple[float, float, float, float, int] | None:
    """The contour {f_h = level} of a P1 field f measured about ``center``; None when not crossed.

    (mean radius rbar, min radius, max radius, length L, chained pieces), as in the module
    docstring (a ring of :func:`ring_table`, a strain interface of continuum.strains).
    """
    seg, ids = contour_segments(points, triangles, f, level)
    if len(seg) == 0:
        return None
    length, integral, r_min, r_max = _segment_radii(seg, np.asarray(center, dtype=float))
    return integral / max(length, 1e-300), r_min, r_max, length, _pieces(ids)


def ring_levels(G: ArrayLike, period: float = LN2, first: int = 1) -> np.ndarray:
    """Integers k >= ``first`` with min G < k period <= max G: the rings present in G."""
    G = np.asarray(G, dtype=float)
    if G.size == 0:
        return np.empty(0, dtype=int)
    lo = max(first, math.floor(G.min() / period) + 1)
    hi = math.floor(G.max() / period)
    return np.arange(lo, hi + 1, dtype=int)


def ring_table(points: ArrayLike, triangles: ArrayLike, G: ArrayLike,
               center: ArrayLike | None = None, period: float = LN2
               ) -> dict[str, np.ndarray]:
    """The rings G = k ln 2 of a P1 field G on a triangle mesh, one row per level crossed.

    Parameters
    ----------
    points : array_like, shape (n, 2)
        Node positions.
    triangles : array_like, shape (m, 3)
        Node indices of the triangles.
    G : array_like, shape (n,)
        Growth phase ``G = int g dt`` at the nodes.
    center : array_like, shape (2,), optional
        The centre x_c of the radii; default the mesh's area centroid (the colony centroid).
    period : float, optional
        Level spacing (ln 2 for the rings of ``lbar = 2^frac(G / ln 2)``).

    Returns
    -------
    dict of str to ndarray
        The columns :data:`COLUMNS`, one entry per ring k = 1, 2, ... crossed by G, in
        increasing k: k, ``level = k period``, ``mean_radius = (1/L) int |x - x_c| ds``,
        min_radius, max_radius, length L, cx, cy (the centre x_c), n_pieces (chained polylines of
        the contour; 1 for a ring closed inside the colony).
    """
    points, tris, G = _check_mesh(points, triangles, G)
    c = area_centroid(points, tris) if center is None else np.asarray(center, dtype=float)
    rows: dict[str, list] = {name: [] for name in COLUMNS}
    for k in ring_levels(G, period):
        level = k * period
        curve = level_curve(points, tris, G, level, c)
        if curve is None:
            continue
        for name, v in zip(COLUMNS, (k, level, *curve[:4], c[0], c[1], curve[4]), strict=True):
            rows[name].append(v)
    out = {name: np.asarray(v, dtype=float) for name, v in rows.items()}
    out["k"] = out["k"].astype(int)
    out["n_pieces"] = out["n_pieces"].astype(int)
    return out


def ring_wavelength(table: dict[str, np.ndarray]) -> float:
    """Ring wavelength: difference of the two largest mean ring radii of a ring table.

    lbar = 2^frac(G / ln 2) peaks (value 2) exactly at a ring, so this is model.md's "distance
    between the last two peaks of the radial mean-length profile" measured on the contours.
    nan with fewer than two rings.
    """
    r = np.sort(np.asarray(table["mean_radius"], dtype=float))
    r = r[np.isfinite(r)]
    return float(r[-1] - r[-2]) if r.size >= 2 else math.nan
