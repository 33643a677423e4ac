"""Strains: inherited growth traits carried by the material (issue 32).

A colony of S strains i = 0..S-1. Strain i grows at ::

    g_i(p) = a_i exp(-lam_i p)          (:class:`Strain`: a_i ``growth``, lam_i ``lam``),

and a daughter inherits its mother's strain. In the continuum each material point carries the
strain fractions phi_i(x, t) >= 0, sum_i phi_i = 1 (the share of the material's volume). The
material does not mix between points, but within a point each strain's volume grows at its own
rate, so along the characteristics dx/dt = u ::

    d phi_i / dt = phi_i (g_i - g),   whence   phi_i = phi_i(0) exp(G_i) / sum_j phi_j(0) exp(G_j)

(:func:`grown_fractions`; a pure region, phi 0 or 1, keeps its fractions exactly: an
interface is a material line), and the Darcy source is the mixture's growth rate ::

    g(p, phi) = sum_i phi_i a_i exp(-lam_i p),     -dg/dp = sum_i phi_i lam_i a_i exp(-lam_i p) >= 0

(:func:`mixed_growth`; -Laplace p = g stays monotone in p, continuum.pressure). Each strain has
its own growth phase G_i = int g_i dt along the material path (meaningful where phi_i > 0), whence
its mean length 2^frac(G_i / ln 2) and its rings G_i = k ln 2, as G gives them for one strain.

The strains are data: ``Config.strains`` holds them (a tuple of :class:`Strain`; empty = one
strain, ``lam`` and growth 1, today's code path), the initial layout phi0 is given to the engine
(``continuum.Simulation(config, layout=phi0)``) as a callable phi0(x, y) -> (n, S) or as an
(n_nodes, S) array. The layouts here return such callables: :func:`core` (concentric strains,
the layered colony of continuum.radial_strains), :func:`sector` (a wedge), :func:`mixture`
(the same fractions everywhere) and :func:`polygon` (a strain per polygon). A third strain,
or a trait other than (lam, growth), is a new entry or a new field of :class:`Strain` and of
:func:`strain_rates`; the engine carries phi and G_i for any S.

Accuracy. The fractions live on the material nodes and the source is the P1 interpolant of
the nodal g, so an element cut by an interface grows at a mean of the two rates with a fixed
share of each strain. With strain 0 a core of nodal fractions 1, its discrete area
A_h = sum_{j in core} m_j (m_j = sum_k M_jk) grows as ::

    dA_h/dt = g_core A_h - (g_core - g_shell) sum_{j in core, k in shell} M_jk,

and the cross mass is the interface length times O(h): an O(h) defect per unit time. The
interface radius, R(t) and p are therefore first order in h (measured in
tests/continuum/test_strains.py against continuum.radial_strains: orders 0.8-1.0, errors
systematic, about 0.4-0.6 h for the interface), against the one-strain colony's second order.
Second order would need the interface inside the elements (a cut-cell source from a transported
smooth label), not nodal fractions. Identical strains are exact: they give the one-strain run
bit for bit (:func:`mixed_growth`).

The interfaces between strains are the contours phi_i = 1/2 (:func:`interface_table`, written
to interfaces.csv by continuum.output.write_interfaces).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["Strain", "as_strains", "strain_rates", "grown_fractions", "mixed_growth", "slope_scale",
           "check_fractions", "fractions_at", "phase_areas", "core", "sector", "mixture",
           "polygon", "inside_polygon", "parse_layout", "LAYOUTS", "interface_table",
           "INTERFACE_COLUMNS", "FRACTION_ATOL"]

FRACTION_ATOL = 1e-9
"""Tolerance of the fractions' checks: 0 - atol <= phi_i <= 1 + atol and
abs(sum_i phi_i - 1) <= atol."""


MAX_GROWTH = 100.0
"""Largest growth factor a of a strain: a cell of it doubles in ln 2 / a, and the time step
follows the fastest strain (the particle engine's twin constant is the same)."""

MAX_STRAINS = 64
"""Most strains of a colony: each carries its own fields (75 bytes per node and strain)."""

MAX_LAM = 1e4
"""Largest stress sensitivity lam (``Config.lam``, a strain's lam): beyond it growth all but
stops. A disc's edge moves at dR/dt = R / (1 + sqrt(1 + lam R^2 / 2)) < sqrt(2 / lam)
(continuum.radial), 0.014 at 1e4: a cell length in 70 doubling times; the paper's lam are 0 to
0.1 (the particle engine's twin constant is the same)."""

LAM_CAP_WHY = (f"beyond {MAX_LAM:g} growth all but stops: a colony's edge moves at most "
               "sqrt(2/lam) per unit time, a cell length in 70 doubling times")
"""Why lam is capped at MAX_LAM, as the refusals say it."""


@dataclass(frozen=True)
class Strain:
    """An inherited trait: growth rate g(p) = a exp(-lam p) (a: ``growth``, lam: ``lam``).

    Validated when made: lam in [0, MAX_LAM], growth in (0, MAX_GROWTH] (one-line ValueError).
    """

    lam: float
    growth: float = 1.0

    def __post_init__(self):
        for name in ("lam", "growth"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, numbers.Real):
                raise ValueError(f"a strain's {name} must be a number, got {v!r}")
            object.__setattr__(self, name, float(v))
        if not (math.isfinite(self.lam) and self.lam >= 0):
            raise ValueError(f"a strain's lam must be finite and >= 0, got {self.lam!r}")
        if self.lam > MAX_LAM:
            raise ValueError(f"a strain's lam must be in [0, {MAX_LAM:g}], got {self.lam!r} "
                             f"({LAM_CAP_WHY})")
        if not (math.isfinite(self.growth) and 0 < self.growth <= MAX_GROWTH):
            raise ValueError(f"a strain's growth must be in (0, {MAX_GROWTH:g}], got "
                             f"{self.growth!r}")

    def rate(self, p):
        """g(p) = a exp(-lam p)."""
        return self.growth * np.exp(-self.lam * p)


def as_strains(value) -> tuple[Strain, ...]:
    """A tuple of :class:`Strain` from strains, (lam, growth) pairs or {"lam", "growth"} dicts.

    The forms a Config, a TOML file or a checkpoint's JSON give; ValueError (one line) otherwise.
    """
    if isinstance(value, (str, bytes)) or not isinstance(value, (tuple, list)):
        raise ValueError(f"strains must be a sequence of (lam, growth) pairs, got {value!r}")
    if len(value) > MAX_STRAINS:
        raise ValueError(f"strains: {len(value)} given, at most {MAX_STRAINS}")
    out = []
    for entry in value:
        try:
            if isinstance(entry, Strain):
                out.append(entry)
            elif isinstance(entry, dict) and set(entry) <= {"lam", "growth"} and "lam" in entry:
                out.append(Strain(**entry))
            elif isinstance(entry, (tuple, list)) and len(entry) in (1, 2):
                out.append(Strain(*entry))
            else:
                raise ValueError(f"a strain must be (lam, growth), got {entry!r}")
        except ValueError as err:  # named by the field, as Config's other errors are
            raise ValueError(f"strains must be valid strains: {err}") from None
    return tuple(out)


def strain_rates(p: ArrayLike, strains) -> NDArray:
    """Every strain's growth rate at the pressure p: g_i = a_i exp(-lam_i p), shape (n, S)."""
    p = np.asarray(p, dtype=float)
    return np.stack([s.growth * np.exp(-s.lam * p) for s in strains], axis=-1)


def slope_scale(strains) -> float:
    """lam* = max_i lam_i, the scale of the source's slope (:func:`mixed_growth`)."""
    return max(s.lam for s in strains)


def mixed_growth(p: ArrayLike, phi: NDArray, strains) -> tuple[NDArray, NDArray]:
    """The source of the mixture and its scaled slope: (g, v), each (n,).

    g = sum_i phi_i g_i and v = sum_i phi_i (lam_i / lam*) g_i, g_i = a_i exp(-lam_i p),
    lam* = max_i lam_i (:func:`slope_scale`; v = 0 when every lam_i = 0), so that
    -dg/dp = lam* v (the Newton Jacobian's weight, continuum.pressure). ``phi`` (n, S) the
    fractions, rows summing to 1, so g is evaluated relative to strain 0 as ::

        g = g_0 + sum_{i >= 1} phi_i (g_i - g_0)      (v likewise):

    strains equal to strain 0 add exact zeros, so identical strains in any layout give
    g = v = exp(-lam p), the one-strain solver's values, bit for bit.
    """
    rates = strain_rates(p, strains)
    top = slope_scale(strains)
    scaled = rates * np.array([s.lam / top if top > 0 else 0.0 for s in strains])

    def mix(f):
        return f[:, 0] + np.einsum("ni,ni->n", phi[:, 1:], f[:, 1:] - f[:, :1])

    return mix(rates), mix(scaled)


def grown_fractions(phi: NDArray, dG: NDArray) -> NDArray:
    """The fractions after each strain's volume in a material element grew by exp(dG_i).

    phi_i' = phi_i exp(dG_i) / sum_j phi_j exp(dG_j) (each row shifted by its largest dG): the
    exact solution of d phi_i/dt = phi_i (g_i - g) over a step in which strain i's phase grew
    by dG_i = int g_i dt. Rows of one strain (phi 0 or 1) are returned exactly.
    """
    w = phi * np.exp(dG - dG.max(axis=1, keepdims=True))
    return w / w.sum(axis=1, keepdims=True)


def check_fractions(phi: ArrayLike, n: int, n_strains: int) -> NDArray:
    """The fractions as a float array (n, S), checked: finite, in [0, 1], rows summing to 1.

    Within ``FRACTION_ATOL``; ValueError (one line) otherwise.
    """
    phi = np.array(phi, dtype=float)
    if phi.shape != (n, n_strains):
        raise ValueError(f"the strain fractions must have shape ({n}, {n_strains}) (nodes, "
                         f"strains), got {phi.shape}")
    if not np.all(np.isfinite(phi)):
        raise ValueError("the strain fractions must be finite")
    if np.any(phi < -FRACTION_ATOL) or np.any(phi > 1 + FRACTION_ATOL):
        raise ValueError(f"the strain fractions must lie in [0, 1], got values in "
                         f"[{phi.min():.6g}, {phi.max():.6g}]")
    worst = float(np.max(np.abs(phi.sum(axis=1) - 1.0))) if n else 0.0
    if worst > FRACTION_ATOL:
        raise ValueError(f"the strain fractions must sum to 1 at every node (off by up to "
                         f"{worst:.3g})")
    return phi


def fractions_at(phi0: Callable | ArrayLike, points: NDArray, n_strains: int) -> NDArray:
    """The fractions phi0 at the nodes ``points`` (n, 2), checked (:func:`check_fractions`).

    ``phi0``: a callable phi0(x, y) -> (n, S) (x, y the node coordinates, arrays (n,)), or an
    (n, S) array of nodal values.
    """
    points = np.asarray(points, dtype=float)
    values = phi0(points[:, 0], points[:, 1]) if callable(phi0) else phi0
    return check_fractions(values, len(points), n_strains)


def phase_areas(points: NDArray, triangles: NDArray, phi: NDArray) -> NDArray:
    """The area of each strain, A_i = int phi_i dA of the P1 fractions, shape (S,).

    Element by element area(T) (phi_a + phi_b + phi_c) / 3; they sum to the mesh's area.
    """
    a, b, c = (points[triangles[:, k]] for k in range(3))
    area = 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                  - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    mean = (phi[triangles[:, 0]] + phi[triangles[:, 1]] + phi[triangles[:, 2]]) / 3.0
    return area @ mean


# ------------------------------------------------------------------ initial layouts


def _one_hot(index: NDArray, n_strains: int) -> NDArray:
    out = np.zeros((len(index), n_strains))
    out[np.arange(len(index)), index] = 1.0
    return out


def core(*radii: float, center: ArrayLike = (0.0, 0.0)) -> Callable[[NDArray, NDArray], NDArray]:
    """Concentric strains: strain i in r_{i-1} <= dist(x, center) < r_i, the last one outside.

    ``core(r1)``: strain 0 in the disc of radius r1, strain 1 around it (S = len(radii) + 1;
    the layered colony of continuum.radial_strains, radii inner to outer). Returns phi0(x, y).
    """
    r = np.array(radii, dtype=float)
    if r.ndim != 1 or len(r) == 0 or not (np.all(np.isfinite(r)) and r[0] > 0
                                          and np.all(np.diff(r) > 0)):
        raise ValueError(f"core radii must be positive, finite and increasing, got {radii!r}")
    cx, cy = (float(v) for v in center)

    def phi0(x, y):
        dist = np.hypot(np.asarray(x, dtype=float) - cx, np.asarray(y, dtype=float) - cy)
        return _one_hot(np.searchsorted(r, dist, side="right"), len(r) + 1)

    return phi0


def sector(theta: float, direction: float = 0.0, center: ArrayLike = (0.0, 0.0)
           ) -> Callable[[NDArray, NDArray], NDArray]:
    """A wedge of strain 1 in strain 0: the angle about ``center`` within theta/2 of ``direction``.

    theta in (0, 2 pi) radians, the opening of the wedge (a sector reaching the colony's edge).
    Returns phi0(x, y) with S = 2.
    """
    if not (math.isfinite(theta) and 0 < theta < 2 * math.pi):
        raise ValueError(f"sector angle theta must lie in (0, 2 pi), got {theta!r}")
    cx, cy = (float(v) for v in center)

    def phi0(x, y):
        angle = np.arctan2(np.asarray(y, dtype=float) - cy, np.asarray(x, dtype=float) - cx)
        off = np.abs((angle - direction + math.pi) % (2 * math.pi) - math.pi)
        return _one_hot((off < theta / 2).astype(int), 2)

    return phi0


def mixture(*fractions: float) -> Callable[[NDArray, NDArray], NDArray]:
    """The same fractions (phi_0, phi_1, ...) at every point (summing to 1). Returns phi0(x, y)."""
    f = check_fractions(np.array(fractions, dtype=float)[None, :], 1, len(fractions))[0]

    def phi0(x, y):
        return np.tile(f, (np.shape(x)[0], 1))

    return phi0


def inside_polygon(x: NDArray, y: NDArray, vertices: ArrayLike) -> NDArray:
    """Whether each point (x, y) lies inside the closed polygon ``vertices`` (m, 2): even-odd rule.

    A ray from the point towards +x crosses the polygon's edges an odd number of times exactly
    when the point is inside (points on an edge count either way).
    """
    v = np.asarray(vertices, dtype=float)
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    inside = np.zeros(np.shape(x), dtype=bool)
    for (ax, ay), (bx, by) in zip(v, np.roll(v, -1, axis=0), strict=True):
        straddles = (ay > y) != (by > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            cross = ax + (y - ay) * (bx - ax) / (by - ay)
        inside ^= straddles & (x < cross)
    return inside


def polygon(*outlines: ArrayLike) -> Callable[[NDArray, NDArray], NDArray]:
    """A strain per polygon: strain i + 1 inside ``outlines[i]``, strain 0 elsewhere.

    Each outline closed, (m, 2) vertices; a point inside several takes the last. Returns
    phi0(x, y) with S = len(outlines) + 1.
    """
    shapes = [np.asarray(o, dtype=float) for o in outlines]
    if not shapes or any(v.ndim != 2 or v.shape[1] != 2 or len(v) < 3
                         or not np.all(np.isfinite(v)) for v in shapes):
        raise ValueError("each polygon must be at least 3 finite vertices (x, y)")

    def phi0(x, y):
        index = np.zeros(np.shape(x), dtype=int)
        for i, v in enumerate(shapes):
            index[inside_polygon(x, y, v)] = i + 1
        return _one_hot(index, len(shapes) + 1)

    return phi0


LAYOUTS = {"core": "core:R1[,R2,...]", "sector": "sector:THETA[,DIRECTION]",
           "mixture": "mixture:F0,F1[,...]", "polygon": "polygon:FILE.csv[,FILE2.csv,...]"}
"""The layout specifications of :func:`parse_layout` (angles in radians, files with columns x,y)."""


def parse_layout(spec: str, n_strains: int | None = None) -> Callable[[NDArray, NDArray], NDArray]:
    """The fractions phi0(x, y) of a layout specification (``LAYOUTS``), checked.

    ``core:R1,R2`` :func:`core`; ``sector:THETA[,DIRECTION]`` :func:`sector`;
    ``mixture:F0,F1,...`` :func:`mixture`; ``polygon:A.csv,B.csv`` :func:`polygon` of the
    polygons in those files (continuum.shapes.polygon_csv). With ``n_strains`` the layout must
    have that many strains. ValueError (one line naming the spec) otherwise.
    """
    if not isinstance(spec, str):
        raise ValueError(f"layout must be a string such as sector:0.785, got {spec!r}")
    kind, sep, args = spec.strip().partition(":")
    kind = kind.strip()
    if kind not in LAYOUTS or not sep or not args.strip():
        raise ValueError(f"layout {spec!r}: use one of {', '.join(LAYOUTS.values())}")
    try:
        phi0, count = _layout(kind, [a.strip() for a in args.split(",")])
    except (OSError, ValueError) as err:
        raise ValueError(f"layout {spec!r}: {err}") from None
    if n_strains is not None and count != n_strains:
        raise ValueError(f"layout {spec!r} has {count} strains, the colony {n_strains}")
    return phi0


def _layout(kind: str, items: list[str]):
    """(phi0, number of strains) of a layout's kind and arguments (:func:`parse_layout`)."""
    if kind == "polygon":
        from continuum.shapes import polygon_csv

        return polygon(*(polygon_csv(path) for path in items)), len(items) + 1
    try:
        numbers = [float(a) for a in items]
    except ValueError:
        raise ValueError(f"{LAYOUTS[kind]} takes numbers") from None
    if not all(math.isfinite(x) for x in numbers):
        raise ValueError(f"{LAYOUTS[kind]} takes finite numbers, got {','.join(items)}")
    if kind == "core":
        return core(*numbers), len(numbers) + 1
    if kind == "sector":
        if len(numbers) > 2:
            raise ValueError(f"give {LAYOUTS[kind]}")
        return sector(*numbers), 2
    return mixture(*numbers), len(numbers)


# ------------------------------------------------------------------ interfaces

INTERFACE_COLUMNS = ("strain", "level", "area", "mean_radius", "min_radius", "max_radius",
                     "length", "cx", "cy", "n_pieces")
"""Columns of an interface table (and interfaces.csv): the strain i, the level 1/2 of its
contour, its area int phi_i dA, then the contour's radii, length, centre and pieces as in a ring
table (continuum.rings.COLUMNS)."""


def interface_table(points: NDArray, triangles: NDArray, phi: NDArray,
                    center: ArrayLike | None = None) -> dict[str, NDArray]:
    """The interfaces of the strains: the contours phi_i = 1/2 of the P1 fractions.

    One row per strain whose fraction crosses 1/2 (``INTERFACE_COLUMNS``); radii about the
    colony's area centroid (or ``center``), measured as continuum.rings measures a ring. For a
    core of strain 0 the contour's mean radius is the interface radius; sqrt(area / pi) is
    another measure of it (the equal-area radius).
    """
    from continuum.rings import area_centroid, level_curve

    phi = np.asarray(phi, dtype=float)
    c = area_centroid(points, triangles) if center is None else np.asarray(center, dtype=float)
    areas = phase_areas(np.asarray(points, dtype=float), np.asarray(triangles), phi)
    rows: dict[str, list] = {name: [] for name in INTERFACE_COLUMNS}
    for i in range(phi.shape[1]):
        curve = level_curve(points, triangles, phi[:, i], 0.5, c)
        if curve is None:
            continue
        values = (i, 0.5, areas[i], *curve[:4], c[0], c[1], curve[4])
        for name, v in zip(INTERFACE_COLUMNS, values, strict=True):
            rows[name].append(v)
    out = {name: np.asarray(v, dtype=float) for name, v in rows.items()}
    out["strain"] = out["strain"].astype(int)
    out["n_pieces"] = out["n_pieces"].astype(int)
    return out
