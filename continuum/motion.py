"""Lagrangian motion of the mesh nodes, remeshing criteria and transfer of material fields.

Motion. Nodes are material points, dx/dt = u(x, t), integrated by Heun's method (RK2):

    x* = x^n + dt u(x^n),   x^{n+1} = x^n + dt/2 (u(x^n) + u(x*)),

with the growth phase advanced by the trapezoidal rule along the same paths,
G^{n+1} = G^n + dt/2 (g(x^n) + g(x*)). Explicit node motion is stable only for
dt <~ h / u_edge (short boundary wiggles grow, elements invert), so

    dt = courant * h_boundary / max |u_boundary|     (``stable_dt``),

h_boundary the shortest boundary edge.

Remeshing (``remesh_reason``) happens when any of these holds:
  - quality: the worst triangle quality q = 4 sqrt(3)|T| / sum |e|^2 drops below ``q_min``;
  - boundary resolution: a boundary edge exceeds ``stretch`` * h_target or falls below
    h_target / ``stretch`` (material near the edge is stretched by up to exp(t));
  - size: the mean element size sqrt(4 |T|_mean / sqrt(3)) differs from the mean target
    by more than a factor ``stretch`` (the mesh size follows the domain).
A remesh resamples the boundary by a periodic cubic spline (O(h^4) displacement, no area
loss) and meshes the interior anew (continuum.mesh.triangulate).

Transfer. A material field f known at the old nodes x_j is evaluated at a new node x in the
old triangle T by the gradient-corrected interpolation

    f(x) = sum_{j in T} lambda_j(x) [ f_j + (1/2) (x - x_j) . (grad f)_j ],

lambda_j the barycentric coordinates and (grad f)_j the recovered nodal gradient. It is exact
for quadratic f with exact gradients (the averaged linear interpolant's O(h^2) error,
(1/2) sum_j lambda_j (x_j - x)^T H (x_j - x), cancels against the tangent-plane one), so
repeated remeshing does not bias the phase G (the linear interpolant biases ring radii).
It is a linear map, a sparse matrix W (n_new x n_old) applied to G and to Psi alike; the plain
linear (barycentric) matrix is also available. New nodes slightly outside the old polygon
(spline boundary) are extrapolated from the nearest old triangle.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from continuum.mesh import boundary_spacing, triangle_areas, triangle_quality
from continuum.pressure import P1Assembler
from continuum.velocity import GradientRecovery

__all__ = [
    "Locator",
    "interpolation_matrix",
    "gradient_corrected_matrix",
    "remesh_reason",
    "stable_dt",
]


class Locator:
    """Point location in a triangle mesh: containing triangle and barycentric coordinates.

    Candidates are the ``k`` triangles with the nearest centroids (KD-tree); the chosen one
    maximises the smallest barycentric coordinate, which is >= 0 for a containing triangle
    (points outside the mesh get their nearest triangle and some negative coordinates).
    """

    def __init__(self, points: np.ndarray, tris: np.ndarray, k: int = 12):
        self.points = np.asarray(points, dtype=float)
        self.tris = np.asarray(tris, dtype=np.int64)
        self.k = min(k, len(self.tris))
        self.tree = cKDTree(self.points[self.tris].mean(axis=1))

    def barycentric(self, xy: np.ndarray, cand: np.ndarray) -> np.ndarray:
        """Barycentric coordinates of points xy (P, 2) in triangles cand (P, k) -> (P, k, 3)."""
        x = self.points[self.tris[cand]]  # (P, k, 3, 2)
        a, b, c = x[..., 0, :], x[..., 1, :], x[..., 2, :]
        v0, v1 = b - a, c - a
        v2 = xy[:, None, :] - a
        det = v0[..., 0] * v1[..., 1] - v0[..., 1] * v1[..., 0]
        l1 = (v2[..., 0] * v1[..., 1] - v2[..., 1] * v1[..., 0]) / det
        l2 = (v0[..., 0] * v2[..., 1] - v0[..., 1] * v2[..., 0]) / det
        return np.stack([1.0 - l1 - l2, l1, l2], axis=-1)

    def locate(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Triangle index (P,), barycentric coordinates (P, 3) and an inside flag (P,).

        ``inside`` is True when the point lies in the mesh (all coordinates >= -1e-10).
        """
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        _, cand = self.tree.query(xy, k=self.k)
        cand = cand.reshape(len(xy), -1)
        lam = self.barycentric(xy, cand)
        score = lam.min(axis=-1)
        best = np.argmax(score, axis=1)
        rows = np.arange(len(xy))
        tri = cand[rows, best]
        bary = lam[rows, best]
        inside = score[rows, best] >= -1e-10
        miss = ~inside
        if np.any(miss) and self.k < len(self.tris):
            # wider search for points the nearest centroids did not cover
            _, c2 = self.tree.query(xy[miss], k=min(8 * self.k, len(self.tris)))
            l2 = self.barycentric(xy[miss], c2)
            s2 = l2.min(axis=-1)
            b2 = np.argmax(s2, axis=1)
            r2 = np.arange(len(c2))
            better = s2[r2, b2] > score[miss, best[miss]]
            idx = np.flatnonzero(miss)[better]
            tri[idx] = c2[r2, b2][better]
            bary[idx] = l2[r2, b2][better]
            inside[idx] = s2[r2, b2][better] >= -1e-10
        return tri, bary, inside

    def interpolate(self, f: np.ndarray, xy: np.ndarray, outside=np.nan) -> np.ndarray:
        """P1 interpolation of nodal values f (N,) or (N, k) at points xy; ``outside`` elsewhere."""
        tri, bary, inside = self.locate(xy)
        nodes = self.tris[tri]
        out = np.einsum("pi,pi...->p...", bary, f[nodes])
        out[~inside] = outside
        return out


def interpolation_matrix(locator: Locator, new_points: np.ndarray) -> sp.csr_matrix:
    """Linear interpolation W_ij = lambda_j(x_i) onto new nodes (extrapolating outside)."""
    tri, bary, _ = locator.locate(new_points)
    n_new = len(new_points)
    rows = np.repeat(np.arange(n_new), 3)
    cols = locator.tris[tri].ravel()
    return sp.csr_matrix((bary.ravel(), (rows, cols)), shape=(n_new, len(locator.points)))


def gradient_corrected_matrix(
    locator: Locator, assembler: P1Assembler, new_points: np.ndarray
) -> sp.csr_matrix:
    """Gradient-corrected interpolation W = L + (1/2) [(L o dX) Dx + (L o dY) Dy].

    L_ij = lambda_j(x_i) the linear interpolation, (dX)_ij, (dY)_ij the components of
    x_i - x_j, and Dx, Dy the gradient recovery operators of the old mesh: (W f)_i is
    sum_j lambda_j(x_i) [f_j + (1/2)(x_i - x_j) . (grad f)_j] (exact for quadratics).
    """
    L = interpolation_matrix(locator, new_points).tocoo()
    rec = GradientRecovery(assembler, locator.points)
    d = new_points[L.row] - locator.points[L.col]
    shape = L.shape
    Lx = sp.csr_matrix((0.5 * L.data * d[:, 0], (L.row, L.col)), shape=shape)
    Ly = sp.csr_matrix((0.5 * L.data * d[:, 1], (L.row, L.col)), shape=shape)
    return (L.tocsr() + Lx @ rec.Dx + Ly @ rec.Dy).tocsr()


def remesh_reason(
    points: np.ndarray,
    tris: np.ndarray,
    n_boundary: int,
    h_target: float,
    q_min: float = 0.35,
    stretch: float = 1.5,
    mean_h_target: float | None = None,
) -> str | None:
    """Why the mesh must be rebuilt ("quality", "boundary", "size"), or None.

    Parameters
    ----------
    points, tris : the current (moved) mesh; n_boundary : boundary nodes 0..K-1.
    h_target : target boundary edge length.
    q_min : smallest acceptable triangle quality.
    stretch : allowed factor between actual and target sizes.
    mean_h_target : target mean element size (defaults to h_target).
    """
    q = triangle_quality(points, tris)
    if q.min() < q_min:
        return "quality"
    e = boundary_spacing(points[:n_boundary])
    if e.max() > stretch * h_target or e.min() < h_target / stretch:
        return "boundary"
    mean_area = float(np.mean(triangle_areas(points, tris)))
    h_mean = np.sqrt(4.0 * mean_area / np.sqrt(3.0))
    target = h_target if mean_h_target is None else mean_h_target
    if not (target / stretch < h_mean < stretch * target):
        return "size"
    return None


def stable_dt(boundary: np.ndarray, u_boundary: np.ndarray, courant: float) -> float:
    """dt = courant * min boundary edge / max |u| on the boundary (explicit motion limit)."""
    umax = float(np.max(np.linalg.norm(u_boundary, axis=1)))
    return courant * float(boundary_spacing(boundary).min()) / max(umax, 1e-300)
