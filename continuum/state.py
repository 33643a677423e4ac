"""The state of a continuum colony and the record of one time step.

:class:`State` holds everything the following steps depend on (the mesh, the fields and
Psi, the time, the counters, the warm start of the pressure solve): it is what a checkpoint
saves and loads (continuum.checkpoint), together with the matrix of the pressure solver's AMG
hierarchy. :class:`StepRecord` is what ``Simulation.step`` returns: one row of history.csv.

Fields (:attr:`State.fields`), nodal values:

- p, u = -grad p, G = int g dt (the growth phase of each material element);
- mean_length = 2^frac(G / ln 2): the exact mean length for the model's initial
  Psi0 = delta(l - 1) (continuum.growth.mean_length), what the figures show;
- mean_length_psi, length_std_psi, number, total_length: moments of the transported size
  distribution Psi (its mean length, the standard deviation of its lengths; number and total
  length per current area, i.e. per material element divided by its area stretch exp(G)).
  From the default Psi0 = delta(l - 1) (``Config.initial_sizes = "delta"``,
  continuum.sizes.DeltaSizes) the delta is carried exactly: mean_length_psi equals
  2^frac(G / ln 2) (= mean_length) to round-off at every node, across rings and remeshes, and
  length_std_psi is 0. From the smooth bump of ``bump_width`` ("bump"): along characteristics
  the bump is shifted exactly between remeshes, and by labels (``psi_transport``) also
  across them, so mean_length_psi follows the closed form 2^frac(G / ln 2 + w) of the bump's
  centre w to round-off; length_std_psi is the bump's width away from the rings and, across a
  ring, where part of the bump has divided, the spread of a bimodal distribution (up to ~0.5).

Strains (continuum.strains; only when the state has strain fractions ``phi``, S of them):
phi_i, the fraction of strain i, G_i = int g_i dt, its growth phase, and
mean_length_i = 2^frac(G_i / ln 2), its mean length from a delta Psi0, for i = 0..S-1.
G stays the phase of the mixture's growth rate g = sum_i phi_i g_i (the area stretch exp(G),
which Psi is transported with).

``sizes`` is a continuum.sizes.DeltaSizes (the delta's undivided number and position) or a
continuum.sizes.CharacteristicSizes (values and phase offsets), as ``Config.initial_sizes``
says.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np

from continuum import mesh
from continuum.growth import mean_length, nutrient_level
from continuum.sizes import CharacteristicSizes, DeltaSizes
from continuum.strains import phase_areas

__all__ = ["State", "StepRecord", "HISTORY_COLUMNS", "REMESH_CODES", "TIMING_STAGES"]

TIMING_STAGES = ("meshing", "assembly", "amg_setup", "krylov", "remeshing", "transport")
"""Stages of the accumulated wall-clock seconds in ``State.timings``."""

REMESH_CODES = {None: 0, "quality": 1, "boundary": 2, "size": 3}
"""The remesh reason as written in history.csv's column ``remesh``."""


@dataclass(eq=False)
class State:
    """Mesh, fields and counters of a continuum colony at time t (mutable, changed by each step).

    Attributes
    ----------
    points : ndarray (N, 2)
        Node positions (material points); nodes 0..n_boundary-1 are the boundary, in order.
    triangles : ndarray (M, 3)
        Counter-clockwise triangles (int64).
    n_boundary : int
        Number K of boundary nodes.
    p, g : ndarray (N,)
        Pressure and growth rate g = exp(-lam p) at the nodes.
    u : ndarray (N, 2)
        Velocity u = -grad p at the nodes.
    G : ndarray (N,)
        Growth phase int g dt of each material element.
    sizes : DeltaSizes or CharacteristicSizes
        Psi per material element (one row per node).
    t : float
        Time.
    step : int
        Number of time steps taken.
    n_remesh : int
        Number of remeshes.
    newton, krylov : int
        Newton and Krylov (CG) iterations of all pressure solves so far.
    h_mesh, h_mean_mesh : float
        Boundary spacing and mean element size of the mesh when it was built (the remeshing
        criteria compare the moved mesh with them).
    p_prev : ndarray (N,) or None
        Pressure of the previous step (None after a remesh): the warm start extrapolates in time.
    dt_prev : float
        The previous step.
    timings : dict
        Accumulated wall-clock seconds per stage (``TIMING_STAGES``).
    phi : ndarray (N, S) or None
        Strain fractions of each material element (continuum.strains): in [0, 1], rows summing
        to 1, changed along the characteristics only by the strains' different growth
        (continuum.strains.grown_fractions; pure regions keep theirs). None: one strain
        (``Config.strains`` empty).
    G_strains : ndarray (N, S) or None
        Growth phase G_i = int g_i dt of each strain, g_i = a_i exp(-lam_i p) (None with phi).
    nutrient_length : float or None
        ell of ``Config.nutrient_length`` (set by the simulation): the nodal nutrient
        c = 1 - p / ell^2 is a field (continuum.growth.nutrient_level). None: no nutrient.
    """

    points: np.ndarray
    triangles: np.ndarray
    n_boundary: int
    p: np.ndarray
    u: np.ndarray
    g: np.ndarray
    G: np.ndarray
    sizes: DeltaSizes | CharacteristicSizes
    t: float = 0.0
    step: int = 0
    n_remesh: int = 0
    newton: int = 0
    krylov: int = 0
    h_mesh: float = math.nan
    h_mean_mesh: float = math.nan
    p_prev: np.ndarray | None = None
    dt_prev: float = 1.0
    timings: dict = field(default_factory=lambda: dict.fromkeys(TIMING_STAGES, 0.0))
    phi: np.ndarray | None = None
    G_strains: np.ndarray | None = None
    nutrient_length: float | None = None

    def set_mesh(self, points: np.ndarray, triangles: np.ndarray, n_boundary: int,
                 h: float) -> None:
        """Take a new mesh built at boundary spacing h (the fields are set by the caller)."""
        self.points, self.triangles, self.n_boundary = points, triangles, n_boundary
        self.h_mesh = h
        self.h_mean_mesh = mesh.mean_element_size(points, triangles)

    @property
    def boundary(self) -> np.ndarray:
        """The boundary polygon, nodes 0..K-1 (a view)."""
        return self.points[: self.n_boundary]

    @property
    def area(self) -> float:
        """Colony area A (shoelace formula over the boundary)."""
        return mesh.polygon_area(self.boundary)

    @property
    def radius(self) -> float:
        """Colony radius sqrt(A / pi) (continuum.mesh.colony_radius)."""
        return mesh.colony_radius(self.boundary)

    def where(self) -> str:
        """Time and area, for error messages."""
        return f"t={self.t:.6g}, area={self.area:.6g}"

    @property
    def strain_areas(self) -> np.ndarray | None:
        """Area of each strain, int phi_i dA (continuum.strains.phase_areas); None: one strain."""
        if self.phi is None:
            return None
        return phase_areas(self.points, self.triangles, self.phi)

    @property
    def fields(self) -> dict[str, np.ndarray]:
        """Nodal fields (new arrays): p, u, G, mean_length and the moments of Psi (and c).

        mean_length_psi, length_std_psi, number, total_length: see the module docstring;
        number and total length are per current area (Psi moments times exp(-G)). With strains,
        phi_i, G_i and mean_length_i of every strain i (module docstring).
        """
        stretch = np.exp(-self.G)
        number = self.sizes.number()
        total = self.sizes.total_length()
        out = {
            "p": self.p.copy(),
            "u": self.u.copy(),
            "G": self.G.copy(),
            "mean_length": mean_length(self.G),
            "mean_length_psi": total / number,
            "length_std_psi": self.sizes.length_std(),
            "number": number * stretch,
            "total_length": total * stretch,
        }
        if self.nutrient_length is not None:
            out["c"] = nutrient_level(self.p, self.nutrient_length)
        if self.phi is not None:
            for i in range(self.phi.shape[1]):
                out[f"phi_{i}"] = self.phi[:, i].copy()
                out[f"G_{i}"] = self.G_strains[:, i].copy()
                out[f"mean_length_{i}"] = mean_length(self.G_strains[:, i])
        return out

    def sample(self, xy: np.ndarray) -> dict[str, np.ndarray]:
        """P1 interpolation of every field at the points xy (P, 2); NaN outside the domain."""
        return sample_fields(self.points, self.triangles, self.fields, xy)

    def copy(self) -> State:
        """A deep copy (later steps of a simulation do not change it)."""
        return copy.deepcopy(self)


def sample_fields(points: np.ndarray, triangles: np.ndarray, fields: dict,
                  xy: np.ndarray) -> dict[str, np.ndarray]:
    """P1 interpolation of nodal ``fields`` at the points xy (P, 2); NaN outside the mesh."""
    loc = mesh.Locator(points, triangles)
    tri, bary, inside = loc.locate(np.asarray(xy, dtype=float))
    nodes = triangles[tri]
    out = {}
    for name, f in fields.items():
        v = np.einsum("pi,pi...->p...", bary, np.asarray(f)[nodes])
        v[~inside] = np.nan
        out[name] = v
    return out


HISTORY_COLUMNS = ("t", "radius", "area", "max_pressure", "n_nodes", "n_boundary", "n_remesh",
                   "dt", "h", "min_quality", "newton_iterations", "krylov_iterations", "remesh")
"""The columns of history.csv, in their order (``StepRecord.row``)."""


@dataclass(frozen=True)
class StepRecord:
    """What one time step did and where it left the colony: one row of history.csv.

    The first four attributes (step, t, dt, radius) are the particle engine's
    ``StepRecord``'s too.

    Attributes
    ----------
    step : int
        Steps taken so far, this one included (not in history.csv).
    t : float
        Time after the step.
    dt : float
        The step taken (halved from the planned one while elements invert; 0 for the initial
        record).
    radius : float
        Colony radius sqrt(A/pi) after the step (what a radius goal compares).
    area : float
        Colony area A.
    max_pressure : float
        Largest nodal pressure.
    n_nodes, n_boundary : int
        Mesh nodes, boundary nodes.
    n_remesh : int
        Remeshes so far.
    h : float
        Boundary spacing of the current mesh when it was built.
    min_quality : float
        Worst triangle quality ``4 sqrt(3) |T| / sum |e|^2``.
    newton_iterations, krylov_iterations : int
        Newton and Krylov iterations of all pressure solves so far (cumulative).
    remesh : str or None
        Why the mesh was rebuilt before this step ("quality", "boundary", "size"), or None.
    strain_areas : tuple of float
        With S >= 2 strains the area of each, int phi_i dA (history.csv's columns area_0,
        area_1, ... after HISTORY_COLUMNS); empty for one strain.
    """

    step: int
    t: float
    dt: float
    radius: float
    area: float
    max_pressure: float
    n_nodes: int
    n_boundary: int
    n_remesh: int
    h: float
    min_quality: float
    newton_iterations: int
    krylov_iterations: int
    remesh: str | None
    strain_areas: tuple = ()

    @property
    def size(self) -> str:
        """The colony's size in the progress lines: "N nodes"."""
        return f"{self.n_nodes} nodes"

    @classmethod
    def of(cls, state: State, dt: float, remesh: str | None) -> StepRecord:
        """The record of ``state`` after a step of size dt (remeshed first for ``remesh``)."""
        area = state.area
        strains = state.phi is not None and state.phi.shape[1] > 1
        return cls(
            step=state.step,
            t=state.t,
            dt=dt,
            radius=math.sqrt(area / math.pi),
            area=area,
            max_pressure=float(state.p.max()),
            n_nodes=len(state.points),
            n_boundary=state.n_boundary,
            n_remesh=state.n_remesh,
            h=state.h_mesh,
            min_quality=float(mesh.triangle_quality(state.points, state.triangles).min()),
            newton_iterations=state.newton,
            krylov_iterations=state.krylov,
            remesh=remesh,
            strain_areas=tuple(float(a) for a in state.strain_areas) if strains else (),
        )

    def row(self) -> dict:
        """The history.csv row: every attribute but ``step``, in the order of HISTORY_COLUMNS.

        ``remesh`` as its code (``REMESH_CODES``: 0 none, 1 quality, 2 boundary, 3 size); then
        the strain areas as area_0, area_1, ... (only with S >= 2 strains).
        """
        row = {name: getattr(self, name) for name in HISTORY_COLUMNS}
        row["remesh"] = REMESH_CODES[self.remesh]
        row |= {f"area_{i}": a for i, a in enumerate(self.strain_areas)}
        return row
