"""Remeshing: when the moving mesh must be rebuilt, the new mesh, and the transfer of the fields.

Criteria (:func:`remesh_reason`). The mesh is rebuilt when any of these holds:

- quality: the worst triangle quality ``q = 4 sqrt(3) |T| / sum |e|^2`` drops below ``q_min``;
- boundary resolution: a boundary edge exceeds ``stretch`` * h_target or falls below
  h_target / ``stretch`` (material near the edge is stretched by up to exp(t));
- size: the mean element size ``sqrt(4 |T|_mean / sqrt(3))`` differs from the mean target
  by more than a factor ``stretch`` (the mesh size follows the domain).

New mesh (:func:`remesh`). The boundary is resampled by a periodic cubic spline at the target
spacing h = min(h_max, h_N(A)) (O(h^4) displacement, no area loss) and the interior meshed anew
(continuum.mesh.colony_mesh).

Transfer. A material field f known at the old nodes x_j is evaluated at a new node x in the
old triangle T by the gradient-corrected interpolation

    f(x) = sum_{j in T} lambda_j(x) [ f_j + (1/2) (x - x_j) . (grad f)_j ],

lambda_j the barycentric coordinates and (grad f)_j the recovered nodal gradient. It is exact
for quadratic f with exact gradients (the averaged linear interpolant's O(h^2) error,
(1/2) sum_j lambda_j (x_j - x)^T H (x_j - x), cancels against the tangent-plane one), so
repeated remeshing does not bias the phase G (the linear interpolant biases ring radii).
It is a linear map, a sparse matrix W (n_new x n_old) applied to G and to p (the warm start
of the next pressure solve). New nodes slightly outside the old polygon (spline boundary) are
extrapolated from the nearest old triangle.

Strains (continuum.strains). Each strain's growth phase G_i is smooth (g_i(p) of the smooth p,
at every node) and is transferred as G is, with W. The strain fractions phi are transferred
with the convex weights C of :func:`convex_weights` (linear interpolation, its extrapolation cut
to a convex combination) and nothing else: C >= 0 with rows summing to 1, so every new row is a
convex combination of old rows and stays in [0, 1] with sum 1 (to round-off). A sharp interface
is smeared by about one element per remesh (linear interpolation of a ramp one element wide).

The model's delta Psi0 (``initial_sizes = "delta"``, continuum.sizes.DeltaSizes): the number per
material element with its divisions undone is interpolated with the convex weights below and the
delta put at the new node's growth phase G_new / ln 2, so its mean length stays
2^frac(G / ln 2) to round-off (``DeltaSizes.transfer_labels``). On the l grid:

Along characteristics (continuum.sizes.CharacteristicSizes), by labels: every row lives on its
own window in s = log2 l; the rows with their divisions undone, 2^-k n, are interpolated by cell
index and put on the window at the new node's phase G_new / ln 2 (no remap in s; the total
length per current area transfers exactly with the weights, the number follows the phase;
``CharacteristicSizes.transfer_labels``). From the model's uniform Psi0 this keeps Psi exact. The
weights are the linear ones with the extrapolation cut to a convex combination
(:func:`convex_weights` of ``interpolation_matrix``: W >= 0, rows summing to 1). Why not the
gradient-corrected W: its negative weights, applied to narrow distributions at neighbouring
phases, left negative cells in the cell remap this replaced, and cutting them raised the total
length per area by up to 15 % at radius 40 (lam = 1e-2; docs/validation.md).
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from continuum import mesh
from continuum.growth import LN2
from continuum.pressure import P1Assembler
from continuum.sizes import CharacteristicSizes, DeltaSizes
from continuum.state import State
from continuum.velocity import GradientRecovery

__all__ = [
    "interpolation_matrix",
    "gradient_corrected_matrix",
    "convex_weights",
    "remesh_reason",
    "transfer_sizes",
    "remesh",
]


def interpolation_matrix(locator: mesh.Locator, new_points: np.ndarray) -> sp.csr_matrix:
    """Linear interpolation W_ij = lambda_j(x_i) onto new nodes (extrapolating outside).

    :func:`convex_weights` makes it W >= 0 with rows summing to 1.
    """
    tri, bary, _ = locator.locate(new_points)
    n_new = len(new_points)
    rows = np.repeat(np.arange(n_new), 3)
    cols = locator.tris[tri].ravel()
    return sp.csr_matrix((bary.ravel(), (rows, cols)), shape=(n_new, len(locator.points)))


def convex_weights(L: sp.csr_matrix) -> sp.csr_matrix:
    """The linear interpolation matrix L with its entries cut at 0 and its rows renormalised.

    Only rows of nodes outside the old mesh change (their extrapolating barycentric
    coordinates become a convex combination of the same three nodes).
    """
    C = L.tocsr(copy=True)
    np.maximum(C.data, 0.0, out=C.data)
    return sp.diags(1.0 / np.asarray(C.sum(axis=1)).ravel()) @ C


def gradient_corrected_matrix(
    locator: mesh.Locator, assembler: P1Assembler, new_points: np.ndarray,
    linear: sp.csr_matrix | None = None,
) -> sp.csr_matrix:
    """Gradient-corrected interpolation W = L + (1/2) [(L o dX) Dx + (L o dY) Dy].

    L_ij = lambda_j(x_i) the linear interpolation, (dX)_ij, (dY)_ij the components of
    x_i - x_j, and Dx, Dy the gradient recovery operators of the old mesh: (W f)_i is
    sum_j lambda_j(x_i) [f_j + (1/2)(x_i - x_j) . (grad f)_j] (exact for quadratics).
    ``linear``: L when already computed (:func:`interpolation_matrix`).
    """
    L = (interpolation_matrix(locator, new_points) if linear is None else linear).tocoo()
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
    q = mesh.triangle_quality(points, tris)
    if q.min() < q_min:
        return "quality"
    e = mesh.boundary_spacing(points[:n_boundary])
    if e.max() > stretch * h_target or e.min() < h_target / stretch:
        return "boundary"
    h_mean = mesh.mean_element_size(points, tris)
    target = h_target if mean_h_target is None else mean_h_target
    if not (target / stretch < h_mean < stretch * target):
        return "size"
    return None


def transfer_sizes(sizes: CharacteristicSizes | DeltaSizes, W: sp.csr_matrix,
                   G_old: np.ndarray, G_new: np.ndarray) -> CharacteristicSizes | DeltaSizes:
    """Psi on the new nodes, by labels (module docstring).

    The undivided rows (a delta's undivided number) interpolated with W, placed at the new
    nodes' phases G_new / ln 2.
    """
    if isinstance(sizes, DeltaSizes):
        return sizes.transfer_labels(W, G_old, G_new)
    return sizes.transfer_labels(W, np.asarray(G_old) / LN2, np.asarray(G_new) / LN2)


def remesh(
    state: State,
    assembler: P1Assembler,
    h: float,
    interior_coarsening: float,
    grading: float,
) -> None:
    """New mesh of the current domain at boundary spacing h; G, Psi, p (and phi, G_i) transferred.

    In place: the mesh of ``state``, its fields G, Psi, the strains' phi and G_i, and p (p, the
    warm start of the next pressure solve, without the extrapolation in time: ``p_prev`` is
    dropped), ``n_remesh`` and the timings. ``assembler`` is the pressure solver's P1
    assembler of the old mesh (its gradient recovery gives W). The velocity and growth rate are
    left for the caller to solve on the new mesh.
    """
    old_points, old_tris = state.points, state.triangles
    boundary = mesh.resample_polygon(old_points[: state.n_boundary], spacing=h, min_points=16)
    t0 = time.perf_counter()
    points, tris = mesh.colony_mesh(boundary, h, interior_coarsening, grading)
    state.set_mesh(points, tris, len(boundary), h)
    state.timings["meshing"] += time.perf_counter() - t0
    t0 = time.perf_counter()
    locator = mesh.Locator(old_points, old_tris)
    L = interpolation_matrix(locator, state.points)
    W = gradient_corrected_matrix(locator, assembler, state.points, linear=L)
    convex = isinstance(state.sizes, (CharacteristicSizes, DeltaSizes))
    W_psi = convex_weights(L) if convex else W
    G_old = state.G
    state.G = W @ G_old
    state.sizes = transfer_sizes(state.sizes, W_psi, G_old, state.G)
    if state.phi is not None:
        state.phi = (W_psi if convex else convex_weights(L)) @ state.phi
        state.G_strains = W @ state.G_strains
    p0 = W @ state.p
    state.timings["remeshing"] += time.perf_counter() - t0
    state.n_remesh += 1
    state.p, state.p_prev = p0, None
