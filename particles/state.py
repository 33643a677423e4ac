"""Particle state in flat arrays that grow with division.

Particle n: centre (x_n, y_n), angle theta_n (axis p_n = (cos, sin)), tip-to-tip length l_n,
axial load sigma_n (``stress``), a unique integer id (ids are never reused: they identify
contacts between steps for the solver's warm start) and its lineage: ``parent`` = the id of the
particle whose division made it (-1 for an initial particle) and ``generation`` = the number of
divisions between it and its initial ancestor (0 for an initial particle; growth.divide).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

B = 0.5
"""Particle diameter b (model.md units)."""


@dataclass
class ParticleState:
    """Flat arrays of the current particles (see module docstring).

    Attributes
    ----------
    x, y, theta, length, stress : float64 arrays (N,)
    ids : int64 array (N,)
        Unique ids; ``next_id`` is the next unused one.
    next_id : int
    parent : int64 array (N,)
        Id of the mother (the particle whose division made this one), -1 for an initial particle.
    generation : int64 array (N,)
        Divisions since the initial ancestor: 0 for an initial particle, the mother's + 1.

    ``parent`` and ``generation`` None (e.g. a state built from arrays saved before they
    existed) are set to -1 and 0 for every particle: the particles then present count as
    initial ones.
    """

    x: np.ndarray
    y: np.ndarray
    theta: np.ndarray
    length: np.ndarray
    stress: np.ndarray
    ids: np.ndarray
    next_id: int
    parent: np.ndarray | None = None
    generation: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = self.x.shape[0]
        if self.parent is None:
            self.parent = np.full(n, -1, dtype=np.int64)
        if self.generation is None:
            self.generation = np.zeros(n, dtype=np.int64)

    @classmethod
    def from_arrays(cls, x, y, theta, length) -> "ParticleState":
        """New state; ids 0..N-1, loads zero, parent -1, generation 0.

        Raises ValueError on inconsistent input.
        """
        arrs = [np.array(a, dtype=np.float64, ndmin=1) for a in (x, y, theta, length)]
        n = arrs[0].shape[0]
        if any(a.ndim != 1 or a.shape[0] != n for a in arrs):
            raise ValueError("x, y, theta and length must be 1D arrays of equal length")
        if n == 0:
            raise ValueError("a colony needs at least one particle")
        if not all(np.all(np.isfinite(a)) for a in arrs):
            raise ValueError("particle coordinates must be finite")
        if np.any(arrs[3] <= B):
            raise ValueError(f"every particle length must exceed the diameter b = {B}")
        return cls(*arrs, np.zeros(n), np.arange(n, dtype=np.int64), n)

    @property
    def n(self) -> int:
        return int(self.x.shape[0])

    def append(self, x, y, theta, length, ids, parent=None, generation=None) -> None:
        """Append particles (zero load; parent -1 and generation 0 unless given)."""
        m = len(x)
        parent = np.full(m, -1) if parent is None else parent
        generation = np.zeros(m) if generation is None else generation
        self.x = np.concatenate([self.x, x])
        self.y = np.concatenate([self.y, y])
        self.theta = np.concatenate([self.theta, theta])
        self.length = np.concatenate([self.length, length])
        self.stress = np.concatenate([self.stress, np.zeros(len(x))])
        self.ids = np.concatenate([self.ids, np.asarray(ids, dtype=np.int64)])
        self.parent = np.concatenate([self.parent, np.asarray(parent, dtype=np.int64)])
        self.generation = np.concatenate([self.generation,
                                          np.asarray(generation, dtype=np.int64)])

    def copy(self) -> "ParticleState":
        return ParticleState(self.x.copy(), self.y.copy(), self.theta.copy(), self.length.copy(),
                             self.stress.copy(), self.ids.copy(), self.next_id,
                             self.parent.copy(), self.generation.copy())

    def arrays(self) -> dict[str, np.ndarray]:
        """The per-particle arrays by attribute name (what a checkpoint saves)."""
        return {"x": self.x, "y": self.y, "theta": self.theta, "length": self.length,
                "stress": self.stress, "ids": self.ids, "parent": self.parent,
                "generation": self.generation}


def centroid(state: ParticleState) -> tuple[float, float]:
    """Area-weighted centroid of the particles (area_n = L_n b + pi b^2 / 4)."""
    w = (state.length - B) * B + np.pi * B * B / 4
    return float(np.sum(w * state.x) / w.sum()), float(np.sum(w * state.y) / w.sum())


def tips(state: ParticleState) -> tuple[np.ndarray, np.ndarray]:
    """Segment end points (2N, 2 coordinates)."""
    h = 0.5 * (state.length - B)
    c = np.cos(state.theta) * h
    s = np.sin(state.theta) * h
    return np.concatenate([state.x + c, state.x - c]), np.concatenate([state.y + s, state.y - s])


def colony_radius(state: ParticleState) -> float:
    """Radius of the smallest disc about the centroid holding every particle.

    max over segment ends e of |e - centroid| + b/2 (the farthest point of a sphero-cylinder
    from any point is on the cap of one of its ends).
    """
    cx, cy = centroid(state)
    ex, ey = tips(state)
    return float(np.max(np.hypot(ex - cx, ey - cy)) + B / 2)


def hull_radius(state: ParticleState) -> float:
    """sqrt(A / pi), A the area of the convex hull of the particles.

    The hull of the union of sphero-cylinders is the hull H of the segment ends dilated by b/2:
    A = |H| + perimeter(H) b/2 + pi b^2/4 (exact, Steiner formula).
    """
    ex, ey = tips(state)
    pts = np.column_stack([ex, ey])
    area, perim = _hull_area_perimeter(pts)
    return float(np.sqrt((area + perim * B / 2 + np.pi * B * B / 4) / np.pi))


def _hull_area_perimeter(pts: np.ndarray) -> tuple[float, float]:
    """Area and perimeter of the convex hull of points (monotone chain; degenerate -> 0, 2*len)."""
    p = np.unique(pts, axis=0)
    if p.shape[0] < 3:
        d = np.ptp(p, axis=0)
        return 0.0, 2.0 * float(np.hypot(*d))
    from scipy.spatial import ConvexHull, QhullError

    try:
        h = ConvexHull(p)
    except QhullError:  # collinear points
        d = p[np.argmax(p @ (p[-1] - p[0]))] - p[np.argmin(p @ (p[-1] - p[0]))]
        return 0.0, 2.0 * float(np.hypot(*d))
    return float(h.volume), float(h.area)
