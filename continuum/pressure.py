"""Pressure: Newton's method for -Laplace p = exp(-lam p) in Omega, p = 0 on the boundary.

Discretisation: Lagrange finite elements, P1 or P2 (``element``; P1 assembled by hand in
compiled element loops, ``P1Assembler``, P2 by scikit-fem, continuum.fem.LagrangeSpace, which
also assembles P1 as the hand-written assembly's reference, ``SKFEM_P1``), ::

    F_i(p) = sum_j K_ij p_j - b_i(g(p)) = 0   for interior degrees of freedom i,
    p_i = 0 on the boundary,

with K_ij = int grad phi_i . grad phi_j the stiffness matrix, g = exp(-lam p) at the degrees
of freedom (the growth law, :func:`continuum.growth.growth_rate`) and b(g) = M g,
M_ij = int phi_i phi_j, the consistent load of the interpolant of g (for P1 element-wise
``|T|/12 (g_i + sum_{j in T} g_j)``).

Newton step: J delta = -F with the symmetric part of the Jacobian K + lam M diag(g),
J_ij = K_ij + lam M_ij (g_i + g_j) / 2 (positive definite for lam >= 0 on these meshes; CG
reports it otherwise); the difference lam M_ij (g_j - g_i) / 2 is O(lam h grad g) M_ij, so
the residual contracts by about 1e-4 per iteration (7e-4 with the lumped approximation
K + lam diag(M g) used before); from a time step's warm start (continuum.motion) and with
``NEWTON_RTOL`` one iteration per solve suffices (1.02 on average at radius 150). K and M are
assembled once per node position (a solve): every Newton iteration is then matrix-vector
products and an update of J's data on the same pattern. Each linear system is solved by
conjugate gradients preconditioned with a V-cycle of a pyamg smoothed-aggregation hierarchy
(``VCycle``). The hierarchy is reused across Newton iterations and time steps
while the mesh topology is unchanged and CG converges quickly, and Newton is warm-started from
the previous nodal pressure (nodes move with the material, so the previous p is a good guess;
P2 edge values from their vertices, continuum.fem.LagrangeSpace.extend).

Assembly reuses the sparsity pattern and the element-to-CSR scatter map of a mesh topology
(``LagrangeSpace``; ``P1Assembler`` by hand for P1): only the geometric factors are recomputed
when nodes move. ``P1Assembler`` also serves the vertex mesh's geometry to the velocity recovery
and the remesh transfer (continuum.velocity, continuum.remesh).

Strains (continuum.strains; ``strains`` and the nodal fractions phi given by ``set_mesh``): the
source is the mixture's g = sum_i phi_i a_i exp(-lam_i p) at the degrees of freedom (phi at a P2
edge node the mean of its vertices'), and the Jacobian's part lam g becomes the nodal slope
-dg/dp = lam v, v = sum_i phi_i (lam_i / lam) a_i exp(-lam_i p) >= 0 with lam = max_i lam_i
(continuum.strains.mixed_growth): J_ij = K_ij + lam M_ij (v_i + v_j) / 2. One strain is
v = g; a node of a single strain whose lam_i is the largest has v = g bit for bit, so a
colony of identical strains in a layout of pure regions computes the one-strain run's bits.

Nutrients (``nutrient`` = (ell, K); model.md, "Nutrient limitation"): fed at the colony's edge,
the nutrient is c = 1 - p / ell^2 exactly (p + ell^2 c is harmonic and ell^2 on the edge; on the
mesh too, since both fields share this discretisation), so the coupled pair -Laplace p = g,
ell^2 Laplace c = g is the one scalar problem -Laplace p = exp(-lam p) f(1 - p / ell^2)
(continuum.growth.nutrient_factor), solved by the same Newton iteration: the source is still
monotone in p, and its slope -dg/dp = lam g + exp(-lam p) f'(c) / ell^2 enters the Jacobian as
``slope`` v, ``slope`` = lam + 1 / ell^2.

Non-convergence (lam < 0 beyond the critical size, where ``-Laplace p = |lam|^{-1} ...`` has no
solution, or non-finite values) raises ``PressureDivergence``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pyamg
import scipy.sparse as sp
from numba import njit

from continuum.fem import LagrangeSpace, Pattern, check_element
from continuum.growth import growth_rate, nutrient_factor
from continuum.strains import mixed_growth, slope_scale

__all__ = [
    "PressureDivergence",
    "P1Assembler",
    "PressureSolver",
    "SKFEM_P1",
    "NewtonStats",
    "NEWTON_RTOL",
    "pcg",
    "VCycle",
    "SMOOTHING",
    "limit_blas_threads",
    "amg_hierarchy",
]


def limit_blas_threads(n: int = 1) -> int:
    """Set the thread count of the OpenBLAS libraries bundled with numpy and scipy.

    The solver's BLAS work is small (level-1 products, small dense eigenproblems in the AMG
    setup); multi-threaded OpenBLAS spins on such calls and was measured 10-100x slower on a
    loaded 2-core machine. Called by ``continuum.simulation.run``. Returns how many libraries
    were set (0 when none is found: then this is a no-op).
    """
    import ctypes
    import glob
    import os

    import scipy

    count = 0
    for pkg in (np, scipy):
        base = os.path.dirname(os.path.dirname(pkg.__file__))
        libs = glob.glob(os.path.join(base, f"{pkg.__name__}.libs", "lib*openblas*.so*"))
        for path in libs:
            try:
                lib = ctypes.CDLL(path)
            except OSError:
                continue
            for sym in (
                "scipy_openblas_set_num_threads64_",
                "scipy_openblas_set_num_threads",
                "openblas_set_num_threads64_",
                "openblas_set_num_threads",
            ):
                fn = getattr(lib, sym, None)
                if fn is not None:
                    fn(ctypes.c_int(n))
                    count += 1
                    break
    return count


AMG_SEED = 20240611
"""Seed of numpy's global generator during an AMG setup (see ``amg_hierarchy``)."""


SMOOTHING = (("gauss_seidel", {"sweep": "forward"}), ("gauss_seidel", {"sweep": "backward"}))
"""Pre- and post-smoother of the V-cycle: one forward, then one backward Gauss-Seidel sweep.

The cycle is then symmetric (a valid CG preconditioner) with half the sweeps of pyamg's default
symmetric Gauss-Seidel before and after (docs/benchmarks.md, "Continuum solver")."""


def amg_hierarchy(A: sp.csr_matrix):
    """The pyamg smoothed-aggregation hierarchy of the SPD matrix A, the same on every call.

    Smoothers ``SMOOTHING``. pyamg estimates the spectral radius rho(D^-1 S) of the
    prolongation smoother (``approximate_spectral_radius``, Lanczos/Arnoldi) from a random
    start vector drawn from numpy's *global* generator, so two setups of one matrix differ in
    the last digits of P and thus of every CG iterate. Here the global generator is seeded
    with ``AMG_SEED`` for the setup and its previous state is put back afterwards (callers'
    random streams are not disturbed). Not thread-safe with respect to other users of the
    global generator.
    """
    # pyamg draws from the legacy global generator: seeded here on purpose (docstring)
    saved = np.random.get_state()  # noqa: NPY002
    np.random.seed(AMG_SEED)  # noqa: NPY002
    try:
        return pyamg.smoothed_aggregation_solver(A, symmetry="hermitian", max_coarse=200,
                                                 presmoother=SMOOTHING[0],
                                                 postsmoother=SMOOTHING[1])
    finally:
        np.random.set_state(saved)  # noqa: NPY002


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    """Inner product without BLAS (multi-threaded BLAS level-1 calls thrash on busy machines)."""
    return float(np.einsum("i,i->", a, b))


class VCycle:
    """One V-cycle of a pyamg hierarchy from x = 0, as a preconditioner ``M(b)``.

    Level by level: a forward Gauss-Seidel sweep, the residual restricted (R = P^T), the
    coarser level's cycle prolonged and added, a backward sweep (``SMOOTHING``); the coarsest
    level is solved by the hierarchy's coarse solver. Equal to pyamg's
    ``ml.solve(b, maxiter=1)`` to round-off, with every level's A, P and R in CSR (pyamg keeps
    the coarse levels of smoothed aggregation in BSR with 1 x 1 blocks, slower per nonzero in
    its Gauss-Seidel and products) and its compiled sweep called without the wrapper's checks.
    """

    def __init__(self, ml):
        # the CSR copies and the coarse solver only: pyamg's BSR levels are not kept
        self.levels = [(sp.csr_matrix(lv.A), sp.csr_matrix(lv.P), sp.csr_matrix(lv.R))
                       for lv in ml.levels[:-1]]
        self.coarse = ml.levels[-1].A
        self.coarse_solver = ml.coarse_solver

    def __call__(self, b: np.ndarray) -> np.ndarray:
        """The cycle's approximation of A^-1 b."""
        return self._cycle(0, b)

    def _cycle(self, lvl: int, b: np.ndarray) -> np.ndarray:
        if lvl == len(self.levels):
            return self.coarse_solver(self.coarse, b)
        A, P, R = self.levels[lvl]
        n = len(b)
        x = np.zeros_like(b)
        pyamg.amg_core.gauss_seidel(A.indptr, A.indices, A.data, x, b, 0, n, 1)
        x += P @ self._cycle(lvl + 1, R @ (b - A @ x))
        pyamg.amg_core.gauss_seidel(A.indptr, A.indices, A.data, x, b, n - 1, -1, -1)
        return x


def pcg(
    A: sp.csr_matrix, b: np.ndarray, M, rtol: float, maxiter: int = 200
) -> tuple[np.ndarray, int, bool]:
    """Preconditioned conjugate gradients for A x = b from x = 0.

    Stops when ``||r||_2 <= rtol ||b||_2``. Returns (x, iterations, converged); breaks off
    (converged False) if a search direction has p.A p <= 0 (A not positive definite).
    """
    x = np.zeros_like(b)
    r = b.copy()
    bnorm = np.sqrt(_dot(b, b))
    if bnorm == 0.0:
        return x, 0, True
    z = M(r)
    p = z.copy()
    rz = _dot(r, z)
    for it in range(1, maxiter + 1):
        Ap = A @ p
        pAp = _dot(p, Ap)
        if not pAp > 0.0:
            return x, it, False
        alpha = rz / pAp
        x += alpha * p
        r -= alpha * Ap
        if np.sqrt(_dot(r, r)) <= rtol * bnorm:
            return x, it, True
        z = M(r)
        rz_new = _dot(r, z)
        p *= rz_new / rz
        p += z
        rz = rz_new
    return x, maxiter, False


class PressureDivergence(RuntimeError):  # noqa: N818 - the public name
    """Newton's method for the pressure did not converge (no solution, or non-finite values)."""


@njit(cache=True)
def _geometry(points, tris, area, grads):  # pragma: no cover - compiled
    """In place: ``area[T] = |T|``, ``grads[T, i] = rot(x_k - x_j) / (2 |T|)``, (i, j, k) cyclic."""
    for t in range(tris.shape[0]):
        for i in range(3):
            j, k = tris[t, (i + 1) % 3], tris[t, (i + 2) % 3]
            grads[t, i, 0] = -(points[k, 1] - points[j, 1])
            grads[t, i, 1] = points[k, 0] - points[j, 0]
        # |T| = (x_1 - x_0) x (x_2 - x_0) / 2 = e_2 x (-e_1) / 2
        a = 0.5 * (grads[t, 2, 1] * grads[t, 1, 0] - grads[t, 2, 0] * grads[t, 1, 1])
        area[t] = a
        for i in range(3):
            grads[t, i, 0] /= 2.0 * a
            grads[t, i, 1] /= 2.0 * a


@njit(cache=True)
def _stiffness_mass(area, grads, scatter, nnz):  # pragma: no cover - compiled
    """CSR data of K and M, element by element.

    Entry (i, j) of element T, |T| grad lambda_i . grad lambda_j and |T| (1 + delta_ij) / 12,
    is added at ``scatter[9 T + 3 i + j]``.
    """
    K = np.zeros(nnz)
    M = np.zeros(nnz)
    for t in range(area.shape[0]):
        for i in range(3):
            for j in range(3):
                k = scatter[9 * t + 3 * i + j]
                K[k] += area[t] * (grads[t, i, 0] * grads[t, j, 0]
                                   + grads[t, i, 1] * grads[t, j, 1])
                M[k] += area[t] * (2.0 if i == j else 1.0) / 12.0
    return K, M


@njit(cache=True)
def _load(tris, area, g, n):  # pragma: no cover - compiled
    """``b_i = sum_T |T|/12 (g_i + sum_{j in T} g_j)``, node i in T."""
    b = np.zeros(n)
    for t in range(tris.shape[0]):
        s = g[tris[t, 0]] + g[tris[t, 1]] + g[tris[t, 2]]
        for i in range(3):
            b[tris[t, i]] += area[t] / 12.0 * (g[tris[t, i]] + s)
    return b


class P1Assembler(Pattern):
    """P1 stiffness, mass and consistent load on a fixed triangle topology.

    The CSR pattern of K and the scatter map from the 9 entries of each element matrix to
    CSR data positions are computed once per topology (:class:`continuum.fem.Pattern`);
    ``stiffness(points)`` then costs one vectorised pass over the elements and one
    ``np.bincount``.

    Parameters
    ----------
    tris : array (M, 3)
        Counter-clockwise triangles.
    n_nodes : int
        Number of nodes N.
    n_boundary : int
        Nodes 0..n_boundary-1 carry the Dirichlet condition p = 0.
    """

    def __init__(self, tris: np.ndarray, n_nodes: int, n_boundary: int):
        self.tris = np.ascontiguousarray(tris, dtype=np.int64)
        self.n = int(n_nodes)
        self.nb = int(n_boundary)
        rows = np.repeat(self.tris, 3, axis=1).ravel()
        cols = np.tile(self.tris, (1, 3)).ravel()
        self.set_pattern(rows, cols, np.arange(self.n) < self.nb)  # p = 0 on nodes < nb

    def geometry(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Element areas ``|T|`` and gradients of the barycentric coordinates, shape (M, 3, 2).

        ``grad lambda_i = rot(x_k - x_j) / (2 |T|)`` for (i, j, k) cyclic, rot(a, b) = (-b, a).
        """
        area = np.empty(len(self.tris))
        grads = np.empty((len(self.tris), 3, 2))
        _geometry(np.ascontiguousarray(points, dtype=float), self.tris, area, grads)
        return area, grads

    def stiffness_data(self, area: np.ndarray, grads: np.ndarray) -> np.ndarray:
        """CSR data of ``K_ij = sum_T |T| grad lambda_i . grad lambda_j`` (no boundary rows)."""
        return _stiffness_mass(area, grads, self.scatter, self.nnz)[0]

    def load(self, area: np.ndarray, g: np.ndarray) -> np.ndarray:
        """Consistent load ``b_i = int (sum_j g_j phi_j) phi_i = sum_T |T|/12 (g_i + sum_T g)``."""
        return _load(self.tris, area, np.asarray(g, dtype=float), self.n)

    @property
    def boundary_dofs(self) -> np.ndarray:
        """The Dirichlet nodes 0..n_boundary-1."""
        return np.arange(self.nb)

    def extend(self, p_nodes: np.ndarray, points=None, lam=None) -> np.ndarray:
        """Nodal values as they are (the interface of continuum.fem.LagrangeSpace)."""
        return np.array(p_nodes, dtype=float)

    def assemble(self, points: np.ndarray, geometry=None) -> HandOperators:
        """K, M and the load at these node positions, hand-written (P1).

        ``geometry``: (areas, barycentric gradients) of these positions, if already computed.
        """
        area, grads = self.geometry(points) if geometry is None else geometry
        return HandOperators(self, area, *_stiffness_mass(area, grads, self.scatter, self.nnz))


@dataclass
class HandOperators:
    """The hand-written P1 operators of one node position (``P1Assembler.assemble``)."""

    assembler: P1Assembler
    area: np.ndarray
    K_data: np.ndarray
    M_data: np.ndarray

    def load(self, g: np.ndarray) -> np.ndarray:
        """Consistent load b = M g, element by element."""
        return self.assembler.load(self.area, g)


@dataclass
class NewtonStats:
    """Diagnostics of one pressure solve."""

    newton_iterations: int = 0
    krylov_iterations: int = 0
    amg_setups: int = 0
    residual: float = np.inf
    time_assembly: float = 0.0
    time_amg: float = 0.0
    time_krylov: float = 0.0
    history: list = field(default_factory=list)


SKFEM_P1 = "P1-skfem"
"""P1 assembled by scikit-fem (continuum.fem.LagrangeSpace("P1")).

The same discrete problem as the hand-written "P1" to round-off (tests/continuum/
test_elements.py) but 1.9-2.2x its seconds per solve at 1.6e3-1.5e5 nodes and 2.1x its
whole run to radius 60 (docs/benchmarks.md, ``python docs/measurements/elements.py``): the
reference of the hand-written (Numba) assembly, not a ``Config.element``."""


NEWTON_RTOL = {"P1": 3e-7, "P2": 1e-8}
"""Newton's default relative residual tolerance per element.

The residual relative to the load bounds the relative error of the smooth part of p (to a
factor of a few), so the tolerance sits below the element's discretisation error on the finest
meshes validated: P1's max nodal error at 1.5e5 nodes is 7e-6 of max p (23x above 3e-7), P2's
7e-9 (docs/benchmarks.md, "Pressure elements"). From a time step's warm start P1 then takes one
Newton iteration per solve (1.02 at radius 150) where 1e-8 took 1.8 (docs/benchmarks.md,
"Continuum solver")."""


class PressureSolver:
    """Newton solver for -Laplace p = exp(-lam p), p = 0 on the boundary, on a moving mesh.

    Parameters
    ----------
    lam : float
        Stress sensitivity lambda (finite; negative values allowed but may have no solution).
    element : str
        "P1" (default): the hand-written P1 assembly (``P1Assembler``), measured faster than
        scikit-fem's and equal to it to round-off; "P2": the P2 space assembled by scikit-fem
        (continuum.fem.LagrangeSpace); ``SKFEM_P1``: P1 assembled by scikit-fem.
    rtol : float, optional
        Newton stops when ``||F(p)||_2 <= rtol ||b(g(p))||_2``; by default ``NEWTON_RTOL`` of
        the element.
    max_newton : int
        Iteration limit; exceeding it raises PressureDivergence.
    krylov_rtol : float
        Smallest relative tolerance of a CG solve. Inexact Newton: the step J delta = -F is
        solved to the relative tolerance ``max(krylov_rtol, min(0.1, 0.3 rtol ||b|| / ||F||))``,
        just enough for the next residual to meet ``rtol``.
    reuse_factor : int
        Rebuild the AMG hierarchy when CG needs more than this many iterations.
    strains : tuple of continuum.strains.Strain, optional
        The strains of a mixture (source sum_i phi_i a_i exp(-lam_i p); module docstring);
        their fractions are given with the mesh (``set_mesh``); ``lam`` must then be
        max_i lam_i, the scale of the slope. None: the one strain exp(-lam p).

    Attributes
    ----------
    assembler : P1Assembler
        The P1 topology of the mesh's vertices (geometry, velocity recovery, remesh transfer).
    space : LagrangeSpace or P1Assembler
        The degrees of freedom of the pressure and their assembly.
    """

    def __init__(
        self,
        lam: float,
        element: str = "P1",
        rtol: float | None = None,
        max_newton: int = 30,
        krylov_rtol: float = 1e-10,
        reuse_factor: int = 25,
        strains: tuple | None = None,
        nutrient: tuple[float, float] | None = None,
    ):
        if not np.isfinite(lam):
            raise ValueError(f"lam must be finite, got {lam}")
        if element != SKFEM_P1:
            check_element(element)
        self.lam = float(lam)
        self.element = element
        self.rtol = NEWTON_RTOL["P2" if element == "P2" else "P1"] if rtol is None else rtol
        self.max_newton = max_newton
        self.krylov_rtol = krylov_rtol
        self.reuse_factor = reuse_factor
        self.strains = tuple(strains) if strains else None
        if self.strains is not None and self.lam != slope_scale(self.strains):
            raise ValueError(f"with strains lam must be their largest lam_i, "
                             f"{slope_scale(self.strains)!r}, got {lam!r}")
        self.nutrient = None if nutrient is None else (float(nutrient[0]), float(nutrient[1]))
        #: The scale of the source's slope in Newton's Jacobian: lam, or with nutrients
        #: lam + 1 / ell^2 (positive also at lam = 0).
        self.slope = self.lam if nutrient is None else self.lam + 1.0 / self.nutrient[0] ** 2
        self.fractions: np.ndarray | None = None
        self.assembler: P1Assembler | None = None
        self.space = None
        self._amg = None
        self._amg_source: np.ndarray | None = None
        self.stats = NewtonStats()
        self.last: dict | None = None

    def set_mesh(self, tris: np.ndarray, n_nodes: int, n_boundary: int,
                 fractions: np.ndarray | None = None) -> None:
        """Change topology: new pattern and scatter map, and forget the AMG hierarchy.

        ``fractions``: the strain fractions phi (n_nodes, S) at the vertices, required with
        ``strains`` (:meth:`set_fractions`).
        """
        self.assembler = P1Assembler(tris, n_nodes, n_boundary)
        if self.element == "P1":
            self.space = self.assembler
        else:
            element = "P1" if self.element == SKFEM_P1 else self.element
            self.space = LagrangeSpace(element, tris, n_nodes, n_boundary)
        self._amg = None
        self.fractions = None
        if self.strains is None:
            if fractions is not None:
                raise ValueError("strain fractions given to a solver without strains")
            return
        self.set_fractions(fractions)

    def set_fractions(self, fractions: np.ndarray | None) -> None:
        """The strain fractions phi (n_nodes, S) at the vertices of the current mesh.

        They change with the material's composition (continuum.strains.grown_fractions), so the
        motion sets them before each solve; phi at a P2 edge node is the mean of its vertices'.
        """
        n = self.assembler.n
        phi = np.asarray(fractions if fractions is not None else np.empty((0, 0)), dtype=float)
        if phi.shape != (n, len(self.strains)):
            raise ValueError(f"the strain fractions must have shape ({n}, "
                             f"{len(self.strains)}), got {phi.shape}")
        if self.space.n > len(phi):  # P2: an edge node's fractions the mean of its vertices'
            a, b = self.space.edge_vertices
            phi = np.concatenate([phi, 0.5 * (phi[a] + phi[b])])
        self.fractions = phi

    def _growth(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The source g(p) at the degrees of freedom and its scaled slope v = -g'(p) / lam.

        One strain: g = v = exp(-lam p) (continuum.growth.growth_rate); strains: the
        mixture's (continuum.strains.mixed_growth). With nutrients (``nutrient`` = (ell, K)):
        g f(c) and its slope, v = (lam v0 f + g0 (-df/dp)) / ``slope``
        (continuum.growth.nutrient_factor).
        """
        if self.strains is None:
            g = growth_rate(p, self.lam)
            v = g
        else:
            g, v = mixed_growth(p, self.fractions, self.strains)
        if self.nutrient is None:
            return g, v
        f, df = nutrient_factor(p, *self.nutrient)
        return g * f, (self.lam * v * f + g * df) / self.slope

    def amg_state(self) -> np.ndarray | None:
        """CSR data (on the space's pattern) of the matrix the AMG hierarchy was built from.

        None when there is no hierarchy. Together with the topology this is all the state the
        solver carries from one solve to the next (the hierarchy is reused while CG converges
        quickly), so a solver given it by ``restore_amg`` makes the same decisions and computes
        the same iterates, bit for bit (``amg_hierarchy`` is deterministic).
        """
        return None if self._amg is None else self._amg_source

    def restore_amg(self, data: np.ndarray | None) -> None:
        """Rebuild the AMG hierarchy from ``amg_state()`` of a solver on the same topology."""
        if data is None:
            self._amg = None
            return
        data = np.array(data, dtype=float)
        if self.space is None or data.shape != (self.space.nnz,):
            raise ValueError("restore_amg: the matrix does not fit the current mesh topology")
        self._amg = VCycle(amg_hierarchy(self.space.matrix(data)))
        self._amg_source = data

    def _setup(self, A: sp.csr_matrix, st: NewtonStats) -> None:
        """Build the AMG hierarchy of A (``amg_hierarchy``), counted and timed in ``st``."""
        import time

        t0 = time.perf_counter()
        self._amg = VCycle(amg_hierarchy(A))
        self._amg_source = A.data.copy()
        st.amg_setups += 1
        st.time_amg += time.perf_counter() - t0

    def _krylov(self, A: sp.csr_matrix, rhs: np.ndarray, st: NewtonStats, tol: float) -> np.ndarray:
        import time

        if self._amg is None:
            self._setup(A, st)
        for attempt in range(2):
            t0 = time.perf_counter()
            x, its, ok = pcg(A, rhs, self._amg, tol)
            st.time_krylov += time.perf_counter() - t0
            st.krylov_iterations += its
            if ok and its <= self.reuse_factor:
                return x
            if ok or attempt == 1:
                # converged slowly: rebuild the hierarchy for the next solve
                self._amg = None
                if ok:
                    return x
                break
            self._setup(A, st)
        raise PressureDivergence(
            "the Newton linear system is not positive definite or CG failed to converge"
        )

    def residual(self, points: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """FE residual r = K p - b(g(p)) at every degree of freedom (no boundary condition), b.

        ``p`` holds the degrees of freedom (the nodal values for P1). At a boundary node
        r_i = int_boundary (dp/dn) phi_i ds is the consistent flux.
        """
        ops = self.space.assemble(points)
        b = ops.load(self._growth(p)[0])
        return self.space.matrix(ops.K_data) @ p - b, b

    def solve(
        self, points: np.ndarray, p0: np.ndarray | None = None, where: str = ""
    ) -> np.ndarray:
        """Solve for the pressure on the mesh with these node positions; its nodal values.

        Parameters
        ----------
        points : array (N, 2)
            Node coordinates (topology set by ``set_mesh``).
        p0 : array (N,) or (n,), optional
            Initial guess (warm start) at the nodes (P2: edge values from them,
            ``LagrangeSpace.extend``) or at every degree of freedom; boundary values set to 0.
        where : str
            Context for error messages (e.g. "t=3.2, area=40.1").

        Returns
        -------
        ndarray (N,)
            The pressure at the mesh nodes. All degrees of freedom, the residual, the operators
            and g are kept in ``last`` (keys "p", "residual", "area", "grads", "g", "ops").

        Raises
        ------
        PressureDivergence
            Newton did not converge within ``max_newton`` iterations, or produced non-finite
            values, or a linear system was not positive definite.
        """
        import time

        S = self.space
        if S is None:
            raise ValueError("PressureSolver.solve called before set_mesh")
        st = NewtonStats()
        t0 = time.perf_counter()
        area, grads = self.assembler.geometry(points)
        if np.any(area <= 0):
            raise PressureDivergence(f"inverted mesh element ({where})")
        ops = S.assemble(points, (area, grads)) if S is self.assembler else S.assemble(points)
        K = S.matrix(ops.K_data)
        st.time_assembly += time.perf_counter() - t0
        bnd = S.boundary_dofs
        lam = self.lam
        p = np.zeros(S.n) if p0 is None else S.extend(p0, points, lam)
        p[bnd] = 0.0
        cause = "lam < 0 beyond the critical size (no solution)" if lam < 0 else "no convergence"
        for it in range(self.max_newton + 1):
            g, v = self._growth(p)
            b = ops.load(g)
            r_full = K @ p - b
            F = r_full.copy()
            F[bnd] = 0.0
            b_in = b.copy()
            b_in[bnd] = 0.0
            res = float(np.sqrt(_dot(F, F)))
            scale = float(np.sqrt(_dot(b_in, b_in)))
            st.history.append(res / max(scale, 1e-300))
            if not np.isfinite(res):
                raise PressureDivergence(f"Newton produced non-finite values at {where}: {cause}")
            if res <= self.rtol * scale:
                st.residual = res / max(scale, 1e-300)
                st.newton_iterations = it
                self.stats = st
                # kept for the residual flux, the velocity recovery and g at this solution
                self.last = {"p": p, "residual": r_full, "area": area, "grads": grads, "g": g,
                             "ops": ops}
                return p[: self.assembler.n]
            if it == self.max_newton:
                break
            if it >= 3 and st.history[-1] > 0.9 * st.history[-2] and st.history[-1] > 1e-3:
                break  # stagnating far from the solution
            t0 = time.perf_counter()
            Jd = ops.K_data + (0.5 * self.slope) * ops.M_data * (v[S.rows] + v[S.indices])
            J = S.matrix(S.dirichlet(Jd))
            st.time_assembly += time.perf_counter() - t0
            try:
                tol = max(self.krylov_rtol, min(0.1, 0.3 * self.rtol * scale / res))
                dp = self._krylov(J, -F, st, tol)
            except PressureDivergence as err:
                raise PressureDivergence(f"Newton failed at {where}: {cause} ({err})") from None
            p += dp
        self.stats = st
        raise PressureDivergence(
            f"Newton diverged at {where}: {cause} (residual {st.history[-1]:.2e} after "
            f"{len(st.history) - 1} iterations)"
        )
