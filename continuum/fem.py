"""The pressure's finite-element space through scikit-fem: Lagrange P1 or P2 on the colony mesh.

The colony mesh (continuum.mesh: vertices 0..K-1 on the boundary, in order) carries the
Lagrange space of ``element`` (the pressure solver, continuum.pressure, uses it for P2; its P1
is the reference of the hand-written P1 assembly, equal to round-off and about 2x slower per
solve, docs/benchmarks.md):

- "P1": one degree of freedom per vertex (``skfem.ElementTriP1``, affine elements);
- "P2": one per vertex and one per edge (``skfem.ElementTriP2``), numbered as scikit-fem's
  ``Dofs``: the N vertices first, then N + f for edge (facet) f. The elements are
  isoparametric (``skfem.MeshTri2``): the midpoint of a boundary edge is put on the smooth
  boundary through the vertices, the periodic cubic spline in the chordal arc length (the curve
  that remeshing resamples, continuum.mesh.resample_polygon; a polygon with corners keeps its
  straight edges), so that P2 keeps its orders (3 in L2, 2 in H1) on a curved domain; with
  straight boundary edges the domain error O(h^2) would cap them at 2 and 1.5. Interior edge
  midpoints are the midpoints of the straight edges.

On these spaces the pressure solver (continuum.pressure) needs, at given vertex positions, the
stiffness and mass matrices ::

    K_ij = int grad phi_i . grad phi_j,   M_ij = int phi_i phi_j,

assembled by scikit-fem (``BilinearForm`` on a ``CellBasis``; quadrature of degree 2 for P1,
4 for P2: exact on affine elements). The
load of the growth rate is b = M g, g = exp(-lam p) at the degrees of freedom (the consistent
load of the interpolant of g; for P1 exactly the hand-written assembly's).

Reuse while only the points move (``LagrangeSpace``): the topology-dependent parts are built
once per mesh topology: scikit-fem's ``Dofs``, the sorted connectivity, the CSR pattern of the
element-dof graph and the scatter map from scikit-fem's elemental (COO) data to the CSR data
positions (one ``np.bincount`` per matrix), the boundary degrees of freedom and the Dirichlet
masks. A new node position costs a new ``MeshTri`` on the stored connectivity (no re-sorting,
the stored ``Dofs`` handed over), one ``CellBasis`` and two elemental assemblies.

Velocity (:meth:`LagrangeSpace.vertex_gradient`): grad p_h of a P2 field is linear on each
element; its values at a vertex, area-weighted over the elements around it, give grad p at the
vertex to O(h^2) (one order better than the P1 gradient), on the boundary too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import skfem
from scipy.interpolate import CubicSpline

from continuum.growth import growth_rate
from continuum.mesh import boundary_spacing, turning_angles

__all__ = ["ELEMENTS", "LagrangeSpace", "Operators", "boundary_midpoints", "check_element"]

ELEMENTS = ("P1", "P2")
"""The Lagrange elements of the pressure."""

_SKFEM = {"P1": skfem.ElementTriP1, "P2": skfem.ElementTriP2}
_INTORDER = {"P1": 2, "P2": 4}
CORNER_ANGLE = 0.6
"""A boundary turning by more than this (radians) at a vertex is a polygon: straight edges."""


def check_element(element) -> str:
    """``element`` if it is one of ELEMENTS, else ValueError with a one-line message."""
    if element not in ELEMENTS:
        raise ValueError(f"element must be {' or '.join(map(repr, ELEMENTS))}, got {element!r}")
    return element


@skfem.BilinearForm
def _stiffness(u, v, _):
    """The stiffness form: the integrand grad u . grad v (two products: faster than an einsum)."""
    return u.grad[0] * v.grad[0] + u.grad[1] * v.grad[1]


@skfem.BilinearForm
def _mass(u, v, _):
    """The mass form: the integrand u v."""
    return u * v


def boundary_midpoints(boundary: np.ndarray) -> np.ndarray:
    """Midpoints of the boundary edges (i, i+1) on the smooth curve through the vertices, (K, 2).

    The periodic cubic spline x(s) in the chordal arc length s (as continuum.mesh.
    resample_polygon) at ``s_i + |e_i| / 2``; a polygon turning by more than ``CORNER_ANGLE``
    at a vertex keeps its straight midpoints (a spline through a corner overshoots).
    """
    nxt = np.roll(boundary, -1, axis=0)
    if len(boundary) < 4 or np.max(turning_angles(boundary)) > CORNER_ANGLE:
        return 0.5 * (boundary + nxt)
    lens = boundary_spacing(boundary)
    s = np.concatenate([[0.0], np.cumsum(lens)])
    spline = CubicSpline(s, np.vstack([boundary, boundary[:1]]), bc_type="periodic")
    return spline(s[:-1] + 0.5 * lens)


@dataclass
class Operators:
    """The matrices of one mesh position (``LagrangeSpace.assemble``).

    Attributes
    ----------
    K_data, M_data : ndarray (nnz,)
        CSR data of the stiffness and mass matrices on the space's pattern (no boundary rows).
    basis : skfem.CellBasis
        The basis of this position (for gradients).
    """

    K_data: np.ndarray
    M_data: np.ndarray
    space: LagrangeSpace
    basis: skfem.CellBasis

    def load(self, g: np.ndarray) -> np.ndarray:
        """Consistent load b = M g of the interpolant of g."""
        return self.space.matrix(self.M_data) @ g


class Pattern:
    """The CSR pattern of an assembled operator on ``n`` dofs, and its Dirichlet rows.

    :meth:`set_pattern` takes the (row, column) of every entry of every element matrix, in the
    element layout of the assembly, and the boundary dofs (a mask); then ``indptr``,
    ``indices``, ``rows`` (the row of each stored entry), ``nnz``, ``diag`` (the positions of
    the diagonal) and ``scatter`` (entry -> position: the CSR data of a sum of element
    matrices is ``np.bincount(scatter, entries, minlength=nnz)``).
    """

    n: int

    def set_pattern(self, rows: np.ndarray, cols: np.ndarray, boundary: np.ndarray) -> None:
        """The pattern of the entries (``rows``, ``cols``) with the dofs ``boundary`` Dirichlet."""
        uniq, self.scatter = np.unique(rows * self.n + cols, return_inverse=True)
        r, c = np.divmod(uniq, self.n)
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(r, minlength=self.n))])
        self.indices = c
        self.rows = r
        self.nnz = len(uniq)
        bnd_entry = boundary[r] | boundary[c]
        self.zero_mask = bnd_entry & (r != c)
        self.bnd_diag = np.flatnonzero(bnd_entry & (r == c))
        self.diag = np.flatnonzero(r == c)

    def matrix(self, data: np.ndarray) -> sp.csr_matrix:
        """CSR matrix with this pattern and the given data."""
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))

    def dirichlet(self, data: np.ndarray) -> np.ndarray:
        """Copy of the CSR data with boundary rows and columns replaced by identity."""
        d = data.copy()
        d[self.zero_mask] = 0.0
        d[self.bnd_diag] = 1.0
        return d


class LagrangeSpace(Pattern):
    """P1 or P2 Lagrange space on a fixed triangle topology, reassembled as the vertices move.

    Parameters
    ----------
    element : str
        "P1" or "P2".
    tris : array (M, 3)
        Triangles of the colony mesh.
    n_nodes : int
        Number of vertices N.
    n_boundary : int
        Vertices 0..n_boundary-1 are the boundary, in order (edge i joins i and i+1 mod K).

    Attributes
    ----------
    n : int
        Number of degrees of freedom (N for P1, N + number of edges for P2).
    boundary_dofs : ndarray
        Degrees of freedom on the boundary (p = 0 there), ascending.
    indices, indptr, rows, nnz, diag : the CSR pattern of the element-dof graph (``rows``: the
        row of each entry) and its diagonal.
    """

    def __init__(self, element: str, tris: np.ndarray, n_nodes: int, n_boundary: int):
        self.element = check_element(element)
        self.n_nodes, self.nb = int(n_nodes), int(n_boundary)
        self.t = np.ascontiguousarray(np.sort(np.asarray(tris).T, axis=0), dtype=np.int32)
        self.elem = _SKFEM[element]()
        self.intorder = _INTORDER[element]
        topo = skfem.MeshTri(np.zeros((2, self.n_nodes)), self.t, sort_t=False)
        self.dofs = skfem.assembly.Dofs(topo, self.elem)
        self.n = int(self.dofs.N)
        bnd = list(range(self.nb))
        if element == "P2":
            bf = topo.boundary_facets()
            a, b = topo.facets[:, bf]  # sorted vertex pairs
            # boundary edge i joins i and i+1 (mod K): the pair (0, K-1) is edge K-1
            self.boundary_edge = np.where(b - a == 1, a, b)
            self.boundary_facet_dofs = self.dofs.facet_dofs[0, bf]
            self.edge_vertices = topo.facets  # (2, F)
            bnd = np.concatenate([bnd, self.boundary_facet_dofs])
        self.boundary_dofs = np.sort(np.asarray(bnd, dtype=np.int64))
        self._pattern()

    def _pattern(self) -> None:
        """CSR pattern and scatter map of scikit-fem's elemental COO layout.

        ``BilinearForm.elemental`` stores entry (i, j) of element e at position
        (nb j + i) M + e with row ``element_dofs[i, e]`` and column ``element_dofs[j, e]``
        (nb local basis functions, M elements); checked against the first assembly.
        """
        ed = self.dofs.element_dofs.astype(np.int64)  # (nb, M)
        nbf = ed.shape[0]
        self._rows = np.concatenate([ed[i] for j in range(nbf) for i in range(nbf)])
        self._cols = np.concatenate([ed[j] for j in range(nbf) for i in range(nbf)])
        isb = np.zeros(self.n, dtype=bool)
        isb[self.boundary_dofs] = True
        self.set_pattern(self._rows, self._cols, isb)
        self._checked = False

    # ------------------------------------------------------------------ geometry
    def dof_points(self, points: np.ndarray) -> np.ndarray:
        """Locations of the degrees of freedom, (n, 2): the vertices, then (P2) edge midpoints.

        Boundary edge midpoints on the smooth boundary (:func:`boundary_midpoints`).
        """
        if self.element == "P1":
            return points
        a, b = self.edge_vertices
        mid = 0.5 * (points[a] + points[b])
        mid[self.boundary_facet_dofs - self.n_nodes] = boundary_midpoints(points[: self.nb])[
            self.boundary_edge
        ]
        return np.vstack([points, mid])

    def mesh(self, points: np.ndarray) -> skfem.Mesh:
        """scikit-fem mesh at these vertex positions on the stored topology.

        P1: an affine ``MeshTri``; P2: the isoparametric ``MeshTri2`` on ``dof_points``. The
        stored ``Dofs`` are handed to the P2 mesh (its mapping would otherwise rebuild the
        edges of the topology at every position).
        """
        if self.element == "P1":
            return skfem.MeshTri(np.ascontiguousarray(points.T), self.t, sort_t=False)
        m = skfem.MeshTri2(np.ascontiguousarray(self.dof_points(points).T), self.t, sort_t=False)
        m._dofs = self.dofs  # same topology, same element: scikit-fem's own cache attribute
        return m

    def basis(self, points: np.ndarray, quadrature=None) -> skfem.CellBasis:
        """``CellBasis`` of the space at these vertex positions (stored ``Dofs``)."""
        kw = {"intorder": self.intorder} if quadrature is None else {"quadrature": quadrature}
        return skfem.CellBasis(self.mesh(points), self.elem, dofs=self.dofs,
                               disable_doflocs=True, **kw)

    # ------------------------------------------------------------------ assembly
    def _csr_data(self, coo) -> np.ndarray:
        if not self._checked:
            if not (np.array_equal(coo.indices[0], self._rows)
                    and np.array_equal(coo.indices[1], self._cols)):
                raise RuntimeError("scikit-fem's elemental COO layout is not the expected one")
            self._checked = True
        return np.bincount(self.scatter, weights=coo.data, minlength=self.nnz)

    def assemble(self, points: np.ndarray) -> Operators:
        """Stiffness K and mass M at these vertex positions (module docstring)."""
        basis = self.basis(points)
        K = self._csr_data(_stiffness.elemental(basis))
        M = self._csr_data(_mass.elemental(basis))
        return Operators(K, M, self, basis)

    # ------------------------------------------------------------------ fields
    def extend(self, p_nodes: np.ndarray, points: np.ndarray, lam: float) -> np.ndarray:
        """Degrees of freedom of the pressure from its values at the vertices (a warm start).

        P1: the values themselves. P2: the value at the midpoint of edge e = (a, b) of a
        quadratic p is (p_a + p_b)/2 - e.H e / 8, H the Hessian; with its isotropic part from
        the equation, -Laplace p = g (H ~ -(g/2) I), ::

            p_e = (p_a + p_b)/2 + |e|^2 (g_a + g_b) / 32,   g = exp(-lam p),

        exact for the disc at lam = 0; the rest is O(h^2) times the anisotropic part of H.
        A full vector of degrees of freedom is returned as it is.
        """
        if self.element == "P1" or len(p_nodes) == self.n:
            return np.array(p_nodes, dtype=float)
        a, b = self.edge_vertices
        g = growth_rate(p_nodes, lam)
        e2 = np.sum((points[b] - points[a]) ** 2, axis=1)
        return np.concatenate([p_nodes, 0.5 * (p_nodes[a] + p_nodes[b]) + e2 * (g[a] + g[b]) / 32])

    def vertex_gradient(self, points: np.ndarray, p: np.ndarray) -> np.ndarray:
        """The gradient of p_h at every vertex, (N, 2): element values area-weighted over the patch.

        Each element's gradient is evaluated at its own vertices (a ``CellBasis`` whose
        quadrature points are the reference vertices) and averaged with weights ``|T|`` over the
        elements around each vertex. O(h) for P1 (a patch average), O(h^2) for P2.
        """
        X = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # reference vertices, local 0, 1, 2
        basis = self.basis(points, quadrature=(X, np.full(3, 1.0 / 6.0)))
        gv = basis.interpolate(p).grad  # (2, M, 3)
        area = basis.dx.sum(axis=1)  # |T| (the weights sum to 1/2, |det DF| = 2 |T|)
        w = np.repeat(area, 3)
        idx = self.t.T.ravel()  # element e, local vertex k -> t[k, e]
        den = np.bincount(idx, weights=w, minlength=self.n_nodes)
        out = np.empty((self.n_nodes, 2))
        for d in range(2):
            out[:, d] = np.bincount(idx, weights=w * gv[d].ravel(), minlength=self.n_nodes)
        return out / den[:, None]
