"""Velocity u = -grad p at the mesh nodes.

Interior nodes: superconvergent patch recovery (Zienkiewicz-Zhu, :func:`spr_weights`) of the
(constant) P1 element gradients. The plain area-weighted average over the patch of elements
around each node::

    (grad f)_n = sum_{T containing n} |T| (grad f_h)|_T / sum_{T containing n} |T|

is the linear operator ``GradientRecovery`` (two sparse N x N matrices) reused for the
gradient-corrected transfer of material fields at remeshing. The recovered velocity's observed
order on the exact disc solution is measured in tests/continuum/test_velocity.py: about 1 in the
RMS over the interior nodes of these smoothed Delaunay meshes (1.0 at lam = 0, 1.5 at
lam = 1e-2), its errors 4 to 10 times smaller than the patch average's.

Boundary nodes: since p = 0 on the boundary, grad p is normal there and u = -(dp/dn) n.
The normal derivative comes from the consistent residual flux: at a boundary node i the FE
residual r_i = sum_j K_ij p_j - b_i equals int_boundary (dp/dn) phi_i ds, so ::

    u_i = -(r_i / L_i) n_i,    L_i = (|e_{i-1}| + |e_i|) / 2,

L_i the lumped boundary length and n_i the unit normal of the two adjacent edges
(length-weighted). This flux converges at second order in h (tests), unlike the averaged
gradient at the boundary. The flux density q_i = r_i / L_i is smoothed by a five-point filter
(:func:`flux_filter`) that removes the node-to-node noise of the irregular first element layer
and changes a smooth mode of wavenumber k by (k h)^4 / 16 only; the filter acts on q, not on r:
on a boundary whose material nodes have drifted to an uneven spacing L_i, smoothing r = q L
by node index makes a spurious velocity -q (the smoothing of L)/L, the cause of the too fast
decay of boundary modes that docs/validation.md ("Shape stability") measures.

P2 pressure (``Config.element = "P2"``, continuum.fem): :func:`vertex_velocity`, the element
gradients of the P2 field (linear on each element) at each vertex, area-averaged over its
elements, inside and on the (isoparametric) boundary: boundary RMS order 2 and the decay rates
of boundary modes within 0.7 % up to K = 8 (docs/validation.md, docs/benchmarks.md).

continuum.darcy.darcy_flow puts the pieces together: at given node positions, the pressure
(Newton, continuum.pressure), u = -grad p (this module) and the growth rate g = exp(-lam p).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit

from continuum.pressure import P1Assembler

__all__ = [
    "GradientRecovery",
    "recovered_gradient",
    "spr_weights",
    "boundary_normals",
    "boundary_velocity",
    "flux_filter",
    "nodal_velocity",
    "vertex_velocity",
]


@njit(cache=True)
def _spr_weights(tris, points):  # pragma: no cover - compiled
    """The weights of :func:`spr_weights`, one pass over the elements for the moments A_n."""
    n, m = points.shape[0], tris.shape[0]
    A = np.zeros((n, 6))  # a00 (= patch size), a01, a02, a11, a12, a22
    d = np.empty((m, 3, 2))
    area = np.zeros(n)
    for t in range(m):
        cx = (points[tris[t, 0], 0] + points[tris[t, 1], 0] + points[tris[t, 2], 0]) / 3.0
        cy = (points[tris[t, 0], 1] + points[tris[t, 1], 1] + points[tris[t, 2], 1]) / 3.0
        x0, y0 = points[tris[t, 0], 0], points[tris[t, 0], 1]
        at = 0.5 * abs((points[tris[t, 1], 0] - x0) * (points[tris[t, 2], 1] - y0)
                       - (points[tris[t, 1], 1] - y0) * (points[tris[t, 2], 0] - x0))
        for k in range(3):
            i = tris[t, k]
            dx, dy = cx - points[i, 0], cy - points[i, 1]
            d[t, k, 0], d[t, k, 1] = dx, dy
            A[i, 0] += 1.0
            A[i, 1] += dx
            A[i, 2] += dy
            A[i, 3] += dx * dx
            A[i, 4] += dx * dy
            A[i, 5] += dy * dy
            area[i] += at
    row = np.empty((n, 3))
    ok = np.empty(n, dtype=np.bool_)
    for i in range(n):
        a, b, c, dd, e, f = A[i, 0], A[i, 1], A[i, 2], A[i, 3], A[i, 4], A[i, 5]
        c0, c1, c2 = dd * f - e * e, c * e - b * f, b * e - c * dd
        det = a * c0 + b * c1 + c * c2
        h2 = (dd + f) / max(a, 1.0)
        ok[i] = abs(det) > 1e-6 * a * h2 * h2
        if ok[i]:
            row[i, 0], row[i, 1], row[i, 2] = c0 / det, c1 / det, c2 / det
    w = np.empty(3 * m)
    for t in range(m):
        x0, y0 = points[tris[t, 0], 0], points[tris[t, 0], 1]
        at = 0.5 * abs((points[tris[t, 1], 0] - x0) * (points[tris[t, 2], 1] - y0)
                       - (points[tris[t, 1], 1] - y0) * (points[tris[t, 2], 0] - x0))
        for k in range(3):
            i = tris[t, k]
            if ok[i]:
                w[3 * t + k] = row[i, 0] + row[i, 1] * d[t, k, 0] + row[i, 2] * d[t, k, 1]
            else:
                w[3 * t + k] = at / area[i]
    return w


def spr_weights(tris: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Weights w_(n,T) of superconvergent patch recovery (Zienkiewicz-Zhu) at every node.

    At node n the linear polynomial a + b.(x - x_n) fitted by least squares to the element
    gradients at the centroids c_T of the patch {T containing n} has the value
    a = sum_T w_(n,T) (grad f_h)|_T with w_(n,T) = [A_n^{-1}]_0 . [1, c_T - x_n],
    A_n = sum_T [1, c_T - x_n]^T [1, c_T - x_n] (its first row of the inverse by cofactors).
    Returned in the order of ``tris.ravel()`` (entry 3 T + k pairs node tris[T, k] with
    element T). Patches with a singular fit (fewer than 3 non-collinear centroids:
    ``|det A_n| <= 1e-6 a00 (trace of the second moments / a00)^2``) fall back to the
    area-weighted average.
    """
    return _spr_weights(np.ascontiguousarray(tris, dtype=np.int64),
                        np.ascontiguousarray(points, dtype=float))


def recovered_gradient(
    tris: np.ndarray,
    area: np.ndarray,
    grads: np.ndarray,
    f: np.ndarray,
    points: np.ndarray | None = None,
) -> np.ndarray:
    """Recovered nodal gradient of the P1 field f, (N, 2).

    With ``points``: superconvergent patch recovery (``spr_weights``); without: the
    area-weighted patch average ``sum |T| grad f_h|_T / sum |T|``.

    Parameters
    ----------
    tris : ndarray, shape (M, 3)
        Triangles (node indices).
    area : ndarray, shape (M,)
        Element areas ``|T|``.
    grads : ndarray, shape (M, 3, 2)
        Gradients grad lambda_i of the barycentric coordinates per element.
    f : ndarray, shape (N,)
        Nodal values of the P1 field.
    points : ndarray, shape (N, 2), optional
        Node positions (for SPR).

    Returns
    -------
    ndarray, shape (N, 2)
        The recovered gradient (grad f)_n at every node.
    """
    n = int(f.shape[0])
    gT = np.einsum("mi,mid->md", f[tris], grads)
    idx = tris.ravel()
    if points is not None:
        w = spr_weights(tris, points)
        gx = np.bincount(idx, weights=w * np.repeat(gT[:, 0], 3), minlength=n)
        gy = np.bincount(idx, weights=w * np.repeat(gT[:, 1], 3), minlength=n)
        return np.column_stack([gx, gy])
    gT = gT * area[:, None]
    patch = np.bincount(idx, weights=np.repeat(area, 3), minlength=n)
    gx = np.bincount(idx, weights=np.repeat(gT[:, 0], 3), minlength=n)
    gy = np.bincount(idx, weights=np.repeat(gT[:, 1], 3), minlength=n)
    return np.column_stack([gx, gy]) / patch[:, None]


class GradientRecovery:
    """Sparse operators Dx, Dy with (Dx f, Dy f) the recovered nodal gradient of f.

    Parameters
    ----------
    assembler : P1Assembler
        Topology (pattern and scatter map are reused).
    points : array (N, 2)
        Node positions.
    """

    def __init__(self, assembler: P1Assembler, points: np.ndarray):
        A = assembler
        area, grads = A.geometry(points)
        patch = np.bincount(A.tris.ravel(), weights=np.repeat(area, 3), minlength=A.n)
        mats = []
        for d in range(2):
            # entry (n, j) for n, j in T: |T| grad lambda_j / patch_n
            w = area[:, None, None] * np.broadcast_to(grads[:, None, :, d], (len(area), 3, 3))
            data = np.bincount(A.scatter, weights=w.ravel(), minlength=A.nnz)
            M = A.matrix(data)
            mats.append(sp.diags(1.0 / patch) @ M)
        self.Dx, self.Dy = (m.tocsr() for m in mats)

    def __call__(self, f: np.ndarray) -> np.ndarray:
        """Recovered nodal gradient of the P1 field f, shape (N, 2) (or (N, 2, k) for f (N, k))."""
        return np.stack([self.Dx @ f, self.Dy @ f], axis=1)


def boundary_normals(boundary: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit outward node normals n_i and lumped lengths L_i of a counter-clockwise polygon.

    n_i is the normalised sum of the outward edge normals times edge lengths of the edges
    (i-1, i) and (i, i+1); L_i is half the sum of their lengths.
    """
    e = np.roll(boundary, -1, axis=0) - boundary  # edge i: x_i -> x_{i+1}
    out = np.column_stack([e[:, 1], -e[:, 0]])  # |e| times outward normal (CCW)
    nsum = out + np.roll(out, 1, axis=0)
    n = nsum / np.linalg.norm(nsum, axis=1, keepdims=True)
    lens = np.linalg.norm(e, axis=1)
    L = 0.5 * (lens + np.roll(lens, 1))
    return n, L


def flux_filter(q: np.ndarray) -> np.ndarray:
    """Five-point periodic filter q_i <- (-q_{i-2} + 4 q_{i-1} + 10 q_i + 4 q_{i+1} - q_{i+2}) / 16.

    Its response to a mode e^{i k s} on a spacing h is H = (10 + 8 cos kh - 2 cos 2kh) / 16
    = 1 - (kh)^4 / 16 + O((kh)^6): zero at the node-to-node (Nyquist) mode kh = pi, 3/4 at
    four nodes per wavelength, and a smooth mode is changed at fourth order only (the three-point
    (1, 2, 1)/4 filter changes it by (kh)^2 / 4: -1.6 % of a K = 6 mode on a disc of radius 3
    at 148 boundary nodes, more than the flux's own error).
    """
    return (10.0 * q + 4.0 * (np.roll(q, 1) + np.roll(q, -1))
            - (np.roll(q, 2) + np.roll(q, -2))) / 16.0


def boundary_velocity(
    residual: np.ndarray, boundary: np.ndarray, filter: bool = True
) -> np.ndarray:
    """Boundary velocity u_i = -q_i n_i from the consistent residual flux r_i, q_i = r_i / L_i.

    With ``filter`` the flux density q is smoothed by :func:`flux_filter` and shifted by the
    constant c = (sum r_i - sum q_i L_i) / sum L_i, so that the outflow sum_i q_i L_i (the
    area growth rate) is still exactly sum_i r_i = int g_h. Filtering q (not r = q L, which on
    an unevenly spaced boundary turns the spacing's variation into a velocity) damps the
    node-to-node noise of the flux (measured on the disc: 2x smaller RMS error) and changes
    a smooth boundary mode by (k h)^4 / 16.
    """
    n, L = boundary_normals(boundary)
    k = len(boundary)
    r = residual[:k]
    q = r / L
    if filter:
        q = flux_filter(q)
        q = q + (np.sum(r) - np.sum(q * L)) / np.sum(L)
    return -q[:, None] * n


def nodal_velocity(
    assembler: P1Assembler,
    points: np.ndarray,
    p: np.ndarray,
    residual: np.ndarray,
    geometry: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """Velocity u = -grad p at every node: recovered inside, residual flux on the boundary, (N, 2).

    Parameters
    ----------
    assembler : topology; points : (N, 2) nodes; p : (N,) pressure;
    residual : (N,) FE residual K p - b (its boundary entries are the consistent flux).
    geometry : optional (areas, barycentric gradients) of this mesh, if already computed.
    """
    n_boundary = assembler.nb
    area, grads = assembler.geometry(points) if geometry is None else geometry
    u = -recovered_gradient(assembler.tris, area, grads, p, points)
    u[:n_boundary] = boundary_velocity(residual, points[:n_boundary])
    return u


def vertex_velocity(space, points: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Velocity u = -grad p_h at every vertex from the element gradients, (N, 2).

    The velocity of a P2 pressure (``PressureSolver(element="P2")``): grad p_h is linear on each
    element, its values at a vertex area-averaged over the elements around it
    (continuum.fem.LagrangeSpace.vertex_gradient) are O(h^2) accurate, inside and on the
    boundary (isoparametric boundary elements), one order better than the recovered P1
    gradient; no recovery or residual flux is needed.

    Parameters
    ----------
    space : continuum.fem.LagrangeSpace
        The pressure's space; points : (N, 2) vertices; p : (n,) all degrees of freedom.
    """
    return -space.vertex_gradient(points, p)
