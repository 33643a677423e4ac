"""Initial configurations of a colony, and dense packings to test the contact solvers on.

- :func:`single_cell`: one particle of length 1 at the origin (model.md's initial condition);
- :func:`from_csv`: the particles of a CSV file with columns x,y,theta,length (``Config.init``);
- :func:`fill_outline`: rods filling a given outline (a polygon) at the model's packing, lengths
  drawn from :func:`sample_lengths` (by default the stable distribution Psi ~ l^-2 on [1, 2]);
  :func:`fill_estimate` its rods and seconds beforehand (a fill beyond MAX_FILL_SECONDS or a
  given number of rods is refused);
- :func:`line`: N cells of length 1 end to end on the x axis;
- :func:`ring_packing`: a dense, jammed, non-overlapping disc of rods on concentric rings: the
  synthetic states of docs/measurements/contact_solvers.py and of the solver tests, where
  growth along each ring pushes on the next ring out (a 2D-coupled, pressure-like load path);
"""

from __future__ import annotations

import math
import os

import numpy as np
from numba import njit

from .config import FILL_LENGTHS, FILL_ORIENTATIONS
from .geometry import B, segments_cross
from .output import read_init
from .state import ParticleState

__all__ = ["FILL_LENGTHS", "FILL_ORIENTATIONS", "fill_estimate", "fill_outline", "from_csv", "line",
           "packing_fractions", "ring_packing", "sample_lengths", "single_cell"]

#: Lengths waiting for a place in :func:`fill_outline` (the oldest that fits is placed).
FILL_WINDOW = 8
#: Advance along a guide of :func:`fill_outline` after a rejected place.
FILL_STEP = 0.02
#: Rows at this many angles (multiples of pi / HOLE_ANGLES) fill the holes the "tangent"
#: layers leave (:func:`fill_outline`).
HOLE_ANGLES = 6
#: Largest inward move of a rod of a "tangent" layer, in units of b (:func:`fill_outline`).
LAYER_SHIFT = 0.5
#: Seconds of :func:`fill_outline` ("tangent") per (A + P / 2) P and per P of an outline of
#: area A and perimeter P: the points of its layers (4 per unit of 2 A + P of guides, the
#: first layer a copy of the outline) are compared with every edge (4 P), ~3e-8 s a pair, and
#: its guides are walked 0.02 at a time. Fitted on a 2-core machine to circle:80, circle:150
#: (101,068 rods in 87 s), rectangle:750,2 (28 s), 1500,2, 750,20 and 3000,2 (115 s): within
#: a third.
FILL_SECONDS = (9.2e-7, 0.017)
#: Longest fill :func:`fill_outline` starts (its estimate, :func:`fill_estimate`).
MAX_FILL_SECONDS = 3600.0
#: Largest |x|, |y| of a rod's centre and largest rod length in an init file (:func:`from_csv`):
#: the neighbour search's grid covers the rods' bounding box in cells of about a rod length
#: (neighbours.py), 3e6 cells for centres within +-1000; a colony of the default max_particles
#: (500,000) has a radius of about 420. A rod divides at length 2 (division.py): one of length
#: 1000 becomes 512 cells on a line in its first 9 steps.
INIT_SIZE = 1e3


def single_cell() -> ParticleState:
    """One particle of length l0 = 1 at the origin, angle 0 (t = 0).

    Returns
    -------
    ParticleState
        The one-cell colony, the default initial state of a run.
    """
    return ParticleState.from_arrays([0.0], [0.0], [0.0], [1.0])


def from_csv(path: str | os.PathLike) -> ParticleState:
    """The particles of a CSV file with a header and columns x,y,theta,length (t = 0).

    Parameters
    ----------
    path : str or path-like
        The CSV file (``Config.init``): one row per particle, centre (x, y), angle theta and
        tip-to-tip length l.

    Returns
    -------
    ParticleState
        The particles at t = 0.

    Raises
    ------
    ValueError
        With one line naming the file, when it is missing, not text, lacks a column, holds a
        non-numeric or non-finite value, a length <= b or above INIT_SIZE, a centre beyond
        +-INIT_SIZE, or more rods about one place than fit there (:func:`_check_crowding`:
        before the overlap check, which would compare every pair of them).
    """
    try:
        arrays = read_init(path)
    except UnicodeDecodeError:
        raise ValueError(f"init file {path} is not a text CSV file") from None
    try:
        state = ParticleState.from_arrays(*arrays)
        _check_sizes(state.x, state.y, state.length)
        _check_crowding(state.x, state.y, state.length)
    except ValueError as err:
        raise ValueError(f"init file {path}: {err}") from None
    return state


def _check_sizes(x: np.ndarray, y: np.ndarray, length: np.ndarray) -> None:
    """ValueError naming the first row with a length or a centre beyond INIT_SIZE."""
    long = np.flatnonzero(length > INIT_SIZE)
    if long.size:
        k = int(long[0])
        raise ValueError(f"row {k + 1} has a rod of length {length[k]:g}; lengths must be in "
                         f"(b = {B}, {INIT_SIZE:g}] (a rod divides at length 2, one of "
                         f"{INIT_SIZE:g} into 512 cells in its first 9 steps)")
    far = np.flatnonzero(np.maximum(np.abs(x), np.abs(y)) > INIT_SIZE)
    if far.size:
        k = int(far[0])
        raise ValueError(f"row {k + 1} has a rod centred at ({x[k]:g}, {y[k]:g}); centres must "
                         f"lie within +-{INIT_SIZE:g} of the origin (the neighbour search's "
                         "grid covers the rods' bounding box, a cell per rod length)")


def _check_crowding(x: np.ndarray, y: np.ndarray, length: np.ndarray) -> None:
    """ValueError when the rods centred in some unit square must overlap.

    A rod centred in the square [i, i + 1) x [j, j + 1) lies within the square widened by
    lmax / 2 on every side (lmax the longest of them): when their areas b (l - b) + pi b^2 / 4
    add up to more than (1 + lmax)^2, they overlap. O(N log N): 1e5 rods in a unit square
    are refused at once instead of filling the memory with their N^2 / 2 contacts.
    """
    cells, which = np.unique(np.floor(np.column_stack([x, y])), axis=0, return_inverse=True)
    which = which.ravel()
    area = np.bincount(which, B * (length - B) + 0.25 * math.pi * B * B)
    longest = np.zeros(len(cells))
    np.maximum.at(longest, which, length)
    room = (1.0 + longest) ** 2
    k = int(np.argmax(area / room))
    if area[k] > room[k]:
        count = int(np.sum(which == k))
        raise ValueError(f"{count} rods centred in the unit square at ({cells[k, 0]:g}, "
                         f"{cells[k, 1]:g}) cover {area[k]:.3g}, more than the "
                         f"{room[k]:.3g} they can reach: they overlap")


def ring_packing(n_target: int, seed: int = 0, gap: float = 1e-3, lmin: float = 1.0,
                 lmax: float = 1.9, r0: float = 3.0) -> tuple[np.ndarray, ...]:
    """Dense non-overlapping disc of rods on concentric rings (module docstring).

    Ring m has radius r_m (rod centre lines are chords of it); rods of segment length
    L = l - b subtend 2 asin(L / (2 r)); consecutive rods are separated along the ring so
    that their facing endpoints are b + g apart (g = gap * U(0.5, 1.5)); the leftover angle
    of each ring is spread over its end gaps.  The next ring lies at
    r_{m+1} = r_m + b + g + Lmax^2 / (8 r_m) (chord sagitta), so rods of adjacent rings
    never overlap.  Rings are added until n_target rods are placed.

    Parameters
    ----------
    n_target : int
        Least number of rods; the last ring is filled, so there may be more.
    seed : int
        Seed of the random lengths, gaps and ring phases (numpy.random.default_rng).
    gap : float
        Mean gap g between facing rod ends (g = gap * U(0.5, 1.5)).
    lmin, lmax : float
        Range of the tip-to-tip lengths l, drawn uniformly.
    r0 : float
        Radius of the first ring tried (a ring that holds fewer than three rods is skipped).

    Returns
    -------
    x, y, theta, length : arrays
        Centres, angles and tip-to-tip lengths of the rods.
    """
    rng = np.random.default_rng(seed)
    xs, ys, ts, ls = [], [], [], []
    r = r0
    count = 0
    while count < n_target:
        lengths, angles = [], []
        used = 0.0
        while True:
            ln = rng.uniform(lmin, lmax)
            seg = 2.0 * np.arcsin(min(1.0, (ln - B) / (2.0 * r)))
            sep = 2.0 * np.arcsin(min(1.0, (B + gap * rng.uniform(0.5, 1.5)) / (2.0 * r)))
            if used + seg + sep > 2.0 * np.pi:
                break
            lengths.append(ln)
            angles.append((seg, sep))
            used += seg + sep
        if len(lengths) < 3:
            r += B + gap + (lmax - B) ** 2 / (8.0 * r)
            continue
        extra = (2.0 * np.pi - used) / len(lengths)
        phi = rng.uniform(0.0, 2.0 * np.pi)
        for ln, (seg, sep) in zip(lengths, angles, strict=True):
            mid = phi + 0.5 * seg
            rc = r * np.cos(0.5 * seg)
            xs.append(rc * np.cos(mid))
            ys.append(rc * np.sin(mid))
            ts.append(mid + 0.5 * np.pi)
            ls.append(ln)
            phi += seg + sep + extra
        count += len(lengths)
        r += B + gap * rng.uniform(0.5, 1.5) + (lmax - B) ** 2 / (8.0 * r)
    return np.array(xs), np.array(ys), np.array(ts), np.array(ls)


# ---------------------------------------------------------------------------- shapes


def line(n: int, length: float = 1.0) -> ParticleState:
    """N cells of the same length end to end on the x axis, centred at the origin (t = 0).

    Cell k (0 <= k < n) has centre ((k - (n - 1)/2) l, 0), angle 0 and length l: the tips of
    neighbours touch (gap phi = 0, no overlap). Like :func:`single_cell` every cell starts at
    the birth length 1 by default, so the cells divide together until the division noise
    (``Config.division_noise``) desynchronises them and buckles the line.

    Raises
    ------
    ValueError
        n not an integer >= 1, or length <= b.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"a line needs an integer number of cells >= 1, got {n!r}")
    if not (math.isfinite(length) and length > B):
        raise ValueError(f"line cells need a length > b = {B}, got {length!r}")
    x = (np.arange(n) - 0.5 * (n - 1)) * length
    return ParticleState.from_arrays(x, np.zeros(n), np.zeros(n), np.full(n, float(length)))


def sample_lengths(n: int, rng: np.random.Generator, lengths: str = "stable",
                   lmin: float = 1.0, lmax: float = 2.0) -> np.ndarray:
    """Draw n tip-to-tip lengths from a distribution on [lmin, lmax] (inverse-CDF sampling).

    - ``"stable"`` (default): density proportional to l^-2, the stable size distribution of an
      exponentially growing population whose cells grow at rate dl/dt = g l and divide at
      lmax = 2 lmin (the continuum's Psi in steady growth: (l Psi)' = -Psi gives Psi ~ l^-2,
      which meets the division condition (l Psi)(1) = 2 (l Psi)(2)). CDF
      F(l) = (1/lmin - 1/l) / (1/lmin - 1/lmax), so l = 1 / (1/lmin - u (1/lmin - 1/lmax)),
      u ~ U[0, 1); mean lmin lmax ln(lmax/lmin) / (lmax - lmin) = 2 ln 2 on [1, 2];
    - ``"uniform"``: l = lmin + u (lmax - lmin);
    - ``"birth"``: every length lmin (the particles' analogue of the continuum's
      Psi0 = delta(l - 1)); no random number is drawn.
    """
    if lengths not in FILL_LENGTHS:
        raise ValueError(f"unknown length distribution {lengths!r}; choose from "
                         f"{', '.join(FILL_LENGTHS)}")
    if not (B < lmin <= lmax and math.isfinite(lmax)):
        raise ValueError(f"lengths need b = {B} < lmin <= lmax < inf, got [{lmin}, {lmax}]")
    if lengths == "birth":
        return np.full(n, float(lmin))
    u = rng.random(n)
    if lengths == "uniform":
        return lmin + u * (lmax - lmin)
    return 1.0 / (1.0 / lmin - u * (1.0 / lmin - 1.0 / lmax))


def packing_fractions(length: np.ndarray, area: float) -> tuple[float, float]:
    """(length packing, area fraction) of rods of these lengths in a region of this area.

    Length packing b sum_n l_n / A: 1 at the model's packing, the continuum's total length per
    area [l] = 1/b (its initial disc, of area b, holds one cell of length 1). Area fraction
    sum_n (b (l_n - b) + pi b^2 / 4) / A: the area the rods cover.
    """
    length = np.asarray(length, dtype=float)
    rods = B * (length - B) + 0.25 * math.pi * B * B
    return float(B * length.sum() / area), float(rods.sum() / area)


def fill_estimate(outline, lengths: str = "stable", lmin: float = 1.0,
                  lmax: float = 2.0) -> tuple[float, float]:
    """(rods, seconds) of :func:`fill_outline` of this outline, estimated before any work.

    Rods: the model's packing, b sum l = A, at the mean of the ``lengths`` distribution
    (measured: 0.93 of it for circle:20, 0.98 for circle:80). Seconds: FILL_SECONDS times
    ((A + P / 2) P, P) of the outline (area A, perimeter P). inf where a size overflows.
    """
    poly = _checked_outline(outline)
    area = _signed_area(poly)
    perimeter = float(np.linalg.norm(np.roll(poly, -1, axis=0) - poly, axis=1).sum())
    if lengths == "birth" or lmax == lmin:
        mean = lmin
    elif lengths == "uniform":
        mean = 0.5 * (lmin + lmax)
    else:  # "stable": density ~ l^-2 (sample_lengths)
        mean = lmin * lmax * math.log(lmax / lmin) / (lmax - lmin)
    seconds = (FILL_SECONDS[0] * (area + perimeter / 2) + FILL_SECONDS[1]) * perimeter
    return area / (B * mean), seconds


def fill_outline(outline, seed: int = 0, orientation: str = "tangent",  # noqa: PLR0913
                 lengths: str = "stable", gap: float = 1e-3, angle: float = 0.0,
                 lmin: float = 1.0, lmax: float = 2.0,
                 max_rods: int | None = None) -> ParticleState:
    """Rods filling the polygon ``outline`` at the model's packing, none overlapping (t = 0).

    Lengths: the sequence l_1, l_2, ... of :func:`sample_lengths` (``lengths``, seeded by
    ``seed``). The FILL_WINDOW = 8 oldest lengths not yet placed wait for a place; at each
    position they are tried oldest first, and the first that fits is placed. No length is
    skipped: the rods are the first M draws but for at most 8 left waiting when the outline
    is full (those are biased long, a bias of at most 8 / N in the distribution function).

    Placement, greedy along guide curves: a rod's segment (length l - b) is laid along a
    guide from arc position s; it is kept when its segment lies inside the outline at
    distance >= b/2 + gap/2 from it and at distance >= b + gap/2 from every rod placed (gap
    >= gap/2 between the capsules); then s moves on by l + gap (the next tip gap apart), else
    by FILL_STEP = 0.02. Guides:

    - ``"tangent"`` (default): layers parallel to the outline, the first at depth b/2 + gap,
      each next one b + gap inside the previous one plus the sagitta of a mean rod on the
      layer's curvature (vertices moved along the inward normal; those nearer to the outline or
      to the previous layer than intended are dropped, which removes the swallow-tails of the
      convex parts; ``_layer_guides``). A rod that does not fit where its layer puts it may
      move inwards by up to LAYER_SHIFT b (0.01 at a time), making way for the chords of the
      layer outside that bulge more. The rods follow the outline's tangent as the cells at a
      colony's edge do, and the fill keeps the outline's symmetry. Then rows at HOLE_ANGLES = 6
      angles (multiples of 30 degrees from ``angle``) fill what the layers left;
    - ``"rows"``: straight parallel rows at ``angle`` (radians from the x axis), b + gap apart.

    Parameters
    ----------
    outline : array (K, 2)
        A simple closed polygon (either orientation; no repeated closing vertex needed).
    seed : int
        Seed of the lengths (numpy.random.default_rng).
    orientation, lengths : str
        One of FILL_ORIENTATIONS, FILL_LENGTHS.
    gap : float
        Tip-to-tip gap of rods along a guide and spacing surplus of the layers (> 0).
    angle : float
        Direction of the rows.
    lmin, lmax : float
        Range of the lengths.
    max_rods : int, optional
        Refuse an outline whose fill (:func:`fill_estimate`) takes more rods (the particle
        engine's ``max_particles``).

    Returns
    -------
    ParticleState
        The rods at t = 0 (:func:`packing_fractions` gives how densely they fill the outline:
        measured in docs/tutorial.md, "Shapes").

    Raises
    ------
    ValueError
        A bad outline or option, an outline that holds no rod, or, before any work, a fill
        estimated (:func:`fill_estimate`) beyond ``max_rods`` rods or MAX_FILL_SECONDS.
    """
    if orientation not in FILL_ORIENTATIONS:
        raise ValueError(f"unknown orientation {orientation!r}; choose from "
                         f"{', '.join(FILL_ORIENTATIONS)}")
    if not (isinstance(gap, (int, float)) and math.isfinite(gap) and 0 < gap < B):
        raise ValueError(f"gap must be a number in (0, b = {B}), got {gap!r}")
    poly = _checked_outline(outline)
    area = _signed_area(poly)
    _check_fill(poly, lengths, lmin, lmax, max_rods)
    rng = np.random.default_rng(seed)
    rod_min = B * (lmin - B) + 0.25 * math.pi * B * B
    draws = sample_lengths(int(area / rod_min) + 16, rng, lengths, lmin, lmax)
    edges = _subdivide(poly, 0.25)
    guides = []
    if orientation == "tangent":
        shifts = int(math.ceil(LAYER_SHIFT * B / (0.5 * FILL_STEP)))
        layers = _layer_guides(edges, B / 2 + gap, B + gap, float(np.mean(draws)) - B)
        guides += [(g, c, shifts) for g, c in layers]
    angles = [angle]
    if orientation == "tangent":
        angles = angle + np.pi * np.arange(HOLE_ANGLES) / HOLE_ANGLES
    for a in angles:
        guides += [(g, c, 0) for g, c in _row_guides(edges, a, B / 2 + gap, B + gap)]
    pts = np.vstack([g for g, _, _ in guides]) if guides else np.zeros((0, 2))
    starts = np.cumsum([0] + [len(g) for g, _, _ in guides]).astype(np.int64)
    closed = np.array([c for _, c, _ in guides], dtype=np.bool_)
    n_shift = np.array([k for _, _, k in guides], dtype=np.int64)
    seg, placed, count = _place(pts, starts, closed, n_shift, draws - B, edges, B, gap, lmax,
                                FILL_STEP, FILL_WINDOW)
    if count == 0:
        raise ValueError(f"the outline (area {area:.3g}) is too small to hold a rod of "
                         f"length {draws[0]:.3g}")
    a, b = seg[:count, :2], seg[:count, 2:]
    centre, d = 0.5 * (a + b), b - a
    return ParticleState.from_arrays(centre[:, 0], centre[:, 1], np.arctan2(d[:, 1], d[:, 0]),
                                     placed[:count])


def _check_fill(poly: np.ndarray, lengths: str, lmin: float, lmax: float,
                max_rods: int | None) -> None:
    """ValueError when the fill of ``poly`` takes more than ``max_rods`` rods or seconds.

    The estimate of :func:`fill_estimate` against ``max_rods`` and MAX_FILL_SECONDS.
    """
    rods, seconds = fill_estimate(poly, lengths, lmin, lmax)
    area = _signed_area(poly)
    if max_rods is not None and not rods <= max_rods:
        raise ValueError(f"the outline (area {area:.3g}) takes about {rods:.3g} rods, more "
                         f"than max_particles = {max_rods}")
    if not seconds <= MAX_FILL_SECONDS:
        raise ValueError(f"the fill of the outline (area {area:.3g}, about {rods:.3g} rods) "
                         f"takes about {seconds / 3600:.3g} h, more than the "
                         f"{MAX_FILL_SECONDS / 3600:g} h a fill may take")


def _signed_area(xy: np.ndarray) -> float:
    """Shoelace area, positive for counter-clockwise vertices."""
    x, y = xy[:, 0], xy[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _checked_outline(outline) -> np.ndarray:
    """The outline as a counter-clockwise float array (K, 2) without a closing duplicate."""
    poly = np.asarray(outline, dtype=float)
    if poly.ndim != 2 or poly.shape[1] != 2 or len(poly) < 3:
        raise ValueError(f"an outline is an array of at least 3 vertices (K, 2), got shape "
                         f"{poly.shape}")
    if not np.all(np.isfinite(poly)):
        raise ValueError("the outline has non-finite vertices")
    if np.array_equal(poly[0], poly[-1]):
        poly = poly[:-1]
    area = _signed_area(poly)
    if not abs(area) > 0:
        raise ValueError("the outline has no area")
    return poly if area > 0 else poly[::-1].copy()


def _subdivide(poly: np.ndarray, max_edge: float) -> np.ndarray:
    """The same closed polygon with every edge cut into pieces no longer than ``max_edge``."""
    nxt = np.roll(poly, -1, axis=0)
    m = np.maximum(1, np.ceil(np.linalg.norm(nxt - poly, axis=1) / max_edge)).astype(int)
    t = np.concatenate([np.arange(k) / k for k in m])
    i = np.repeat(np.arange(len(poly)), m)
    return poly[i] + t[:, None] * (nxt[i] - poly[i])


def _layer_guides(poly: np.ndarray, first: float, spacing: float, chord: float) -> list:
    """Layers parallel to the outline, from the outside in: a list of (points, closed).

    Layer 0 is the outline moved inwards by ``first``; layer k + 1 is layer k moved inwards by
    spacing + chord^2 |kappa| / 8 at each vertex, kappa the layer's curvature averaged over a
    chord (the sagitta of a chord of that length, by which the rods of layer k bulge off it;
    ``fill_outline`` takes the mean segment length l - b of its lengths: measured, the longest
    one, 1.5, packs a star:5,0.2,8 at 0.775 instead of 0.844, and the rods that bulge further
    are moved inwards one by one).
    Vertices are moved along the inward bisector normal; a moved vertex is dropped when it
    lies outside the outline, nearer to the outline than the layer's least depth (less 1 %),
    or nearer to the layer it came from than its move (less 1 %): that removes the
    swallow-tails where a convex part folds over itself. The runs of kept vertices are the
    next layer's guides (closed when a closed layer keeps every vertex).
    """
    guides = []
    layer = [(poly, True)]
    depth = 0.0
    step = np.full(len(poly), first)  # the first move: no chord bulges off the outline itself
    while layer:
        depth += first if not guides else spacing
        pieces, parent = [], np.vstack([p for p, _ in layer])
        for k, (pts, closed) in enumerate(layer):
            move = step if k == 0 and not guides else spacing + chord**2 * np.abs(
                _curvature(pts, closed, chord)) / 8
            new = pts - move[:, None] * _normals(pts, closed)
            keep = (_inside(new, poly) & (_distance_to_polygon(new, poly) >= 0.99 * depth)
                    & (_distance_to_points(new, parent) >= 0.99 * move))
            pieces += _runs(new, keep, closed)
        guides += pieces
        layer = pieces
    return guides


def _normals(pts: np.ndarray, closed: bool) -> np.ndarray:
    """Unit outward normals (right of the direction of travel) at the vertices of a polyline."""
    e = np.roll(pts, -1, axis=0) - pts if closed else np.diff(pts, axis=0)
    n_edge = np.column_stack([e[:, 1], -e[:, 0]]) / np.linalg.norm(e, axis=1)[:, None]
    if closed:
        normal = n_edge + np.roll(n_edge, 1, axis=0)
    else:
        normal = np.vstack([n_edge[:1], n_edge[1:] + n_edge[:-1], n_edge[-1:]])
    return normal / np.maximum(np.linalg.norm(normal, axis=1), 1e-300)[:, None]


def _curvature(pts: np.ndarray, closed: bool, width: float) -> np.ndarray:
    """Curvature at the vertices of a polyline, the turning per length over +-width/2.

    (Theta(s + w/2) - Theta(s - w/2)) / w, Theta the cumulative turning angle at arc length s
    (a closed polyline is continued periodically, an open one is clipped at its ends).
    """
    if not width > 0:
        return np.zeros(len(pts))
    e = np.roll(pts, -1, axis=0) - pts if closed else np.diff(pts, axis=0)
    ang = np.arctan2(e[:, 1], e[:, 0])
    turn = np.angle(np.exp(1j * (np.roll(ang, -1) - ang)))  # at the end of each edge
    length = np.linalg.norm(e, axis=1)
    if closed:
        total = length.sum()
        s = np.concatenate([[0.0], np.cumsum(length)])[:-1]  # arc position of each vertex
        s_end = np.cumsum(length)  # where each turn happens (vertex k + 1)
        reps = np.arange(-1, 2)
        sx = (s_end[None, :] + total * reps[:, None]).ravel()
        theta = np.cumsum(np.tile(turn, 3))
        lo = np.interp(s - width / 2, sx, theta)
        hi = np.interp(s + width / 2, sx, theta)
        return (hi - lo) / width
    if len(pts) < 3:
        return np.zeros(len(pts))
    s = np.concatenate([[0.0], np.cumsum(length)])
    theta = np.concatenate([[0.0], np.cumsum(turn[:-1])])  # turning reached at vertex k
    theta = np.append(theta, theta[-1])  # the last vertex does not turn
    a = np.clip(s - width / 2, 0, s[-1])
    b = np.clip(s + width / 2, 0, s[-1])
    span = np.maximum(b - a, 1e-300)
    return (np.interp(b, s, theta) - np.interp(a, s, theta)) / span


def _runs(pts: np.ndarray, keep: np.ndarray, closed: bool) -> list:
    """The runs of kept vertices as polylines (points, closed), runs of one vertex dropped."""
    if keep.all():
        return [(pts, closed)] if len(pts) >= 2 else []
    if closed:  # start after a dropped vertex, so that no run wraps around
        shift = int(np.argmin(keep))
        keep, pts = np.roll(keep, -shift), np.roll(pts, -shift, axis=0)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], keep.astype(int), [0]])))
    return [(pts[a:b], False) for a, b in zip(edges[::2], edges[1::2], strict=True) if b - a >= 2]


def _row_guides(poly: np.ndarray, angle: float, first: float, spacing: float) -> list:
    """The intervals inside the outline of the lines at ``angle``, spacing apart: (points, False).

    Lines v = v_min + first + k spacing in the frame (u, v) turned by ``angle``; each crossing
    with an edge is found by the half-open rule, and the crossings' sorted pairs are the
    interior intervals (even-odd).
    """
    c, s = math.cos(angle), math.sin(angle)
    u = poly @ np.array([c, s])
    v = poly @ np.array([-s, c])
    u2, v2 = np.roll(u, -1), np.roll(v, -1)
    guides = []
    for level in np.arange(v.min() + first, v.max(), spacing):
        hit = (v <= level) != (v2 <= level)
        t = (level - v[hit]) / (v2[hit] - v[hit])
        cross = np.sort(u[hit] + t * (u2[hit] - u[hit]))
        for a, b in zip(cross[::2], cross[1::2], strict=True):
            ends = np.array([[a, level], [b, level]])
            guides.append((ends @ np.array([[c, s], [-s, c]]), False))
    return guides


@njit(cache=True)
def _point_edge(px, py, ax, ay, bx, by):
    """Distance from the point p to the segment [a, b]."""
    dx, dy = bx - ax, by - ay
    ll = dx * dx + dy * dy
    t = 0.0 if ll == 0.0 else ((px - ax) * dx + (py - ay) * dy) / ll
    t = min(1.0, max(0.0, t))
    return math.hypot(px - ax - t * dx, py - ay - t * dy)


@njit(cache=True)
def _segment_distance(ax, ay, bx, by, cx, cy, dx, dy):
    """Distance between the segments [a, b] and [c, d] (0 when they cross)."""
    if segments_cross(ax, ay, bx, by, cx, cy, dx, dy):
        return 0.0
    return min(_point_edge(ax, ay, cx, cy, dx, dy), _point_edge(bx, by, cx, cy, dx, dy),
               _point_edge(cx, cy, ax, ay, bx, by), _point_edge(dx, dy, ax, ay, bx, by))


@njit(cache=True)
def _distance_to_polygon(pts, poly):
    """Distance from each point to the closed polygon (brute force over its edges)."""
    n, k = pts.shape[0], poly.shape[0]
    out = np.empty(n)
    for p in range(n):
        best = 1e300
        for e in range(k):
            f = (e + 1) % k
            d = _point_edge(pts[p, 0], pts[p, 1], poly[e, 0], poly[e, 1], poly[f, 0], poly[f, 1])
            best = min(best, d)
        out[p] = best
    return out


@njit(cache=True)
def _distance_to_points(pts, polyline):
    """Distance from each point to the nearest vertex of ``polyline`` (brute force)."""
    out = np.empty(pts.shape[0])
    for p in range(pts.shape[0]):
        best = 1e300
        for q in range(polyline.shape[0]):
            best = min(best, math.hypot(pts[p, 0] - polyline[q, 0], pts[p, 1] - polyline[q, 1]))
        out[p] = best
    return out


@njit(cache=True)
def _inside_one(px, py, poly):
    """Even-odd point-in-polygon test."""
    k = poly.shape[0]
    inside = False
    for e in range(k):
        f = (e + 1) % k
        ya, yb = poly[e, 1], poly[f, 1]
        if (ya <= py) != (yb <= py):
            x = poly[e, 0] + (py - ya) / (yb - ya) * (poly[f, 0] - poly[e, 0])
            if x > px:
                inside = not inside
    return inside


@njit(cache=True)
def _inside(pts, poly):
    out = np.empty(pts.shape[0], dtype=np.bool_)
    for p in range(pts.shape[0]):
        out[p] = _inside_one(pts[p, 0], pts[p, 1], poly)
    return out


@njit(cache=True)
def _cell(x, y, x0, y0, cs, nx, ny):
    i = min(nx - 1, max(0, int((x - x0) / cs)))
    j = min(ny - 1, max(0, int((y - y0) / cs)))
    return j * nx + i


@njit(cache=True)
def _at(pts, cum, a, b, s):
    """The point at arc position s of the polyline pts[a:b] (cumulative lengths cum[a:b])."""
    k = a + np.searchsorted(cum[a:b], s, side="right") - 1
    k = min(max(k, a), b - 2)
    seg = cum[k + 1] - cum[k]
    t = 0.0 if seg == 0.0 else (s - cum[k]) / seg
    return pts[k, 0] + t * (pts[k + 1, 0] - pts[k, 0]), pts[k, 1] + t * (pts[k + 1, 1] - pts[k, 1])


@njit(cache=True)
def _clear(p, ci, cj, nx, ny, poly, ehead, enext, seg, rhead, rnext, wall, apart):  # noqa: PLR0913
    """Whether the segment p = (ax, ay, bx, by) in cell (ci, cj) keeps its clearances.

    Distance >= wall to the outline's edges and >= apart to the placed segments, over the 3 x 3
    cells about (ci, cj).
    """
    k = poly.shape[0]
    for j2 in range(max(cj - 1, 0), min(cj + 2, ny)):
        for i2 in range(max(ci - 1, 0), min(ci + 2, nx)):
            e = ehead[j2 * nx + i2]
            while e >= 0:
                f = (e + 1) % k
                if _segment_distance(p[0], p[1], p[2], p[3], poly[e, 0], poly[e, 1], poly[f, 0],
                                     poly[f, 1]) < wall:
                    return False
                e = enext[e]
            r = rhead[j2 * nx + i2]
            while r >= 0:
                if _segment_distance(p[0], p[1], p[2], p[3], seg[r, 0], seg[r, 1], seg[r, 2],
                                     seg[r, 3]) < apart:
                    return False
                r = rnext[r]
    return True


@njit(cache=True)
def _fit(ax, ay, ex, ey, L, n_shift, shift, grid, poly, ehead, enext, seg, rhead,  # noqa: PLR0913
         rnext, wall, apart):
    """The segment of length L from a towards e, moved left by j shift, j = 0..n_shift.

    Returns (1 or 0 for found or not, px, py, bx, by, cell i, cell j) of the first position
    that keeps the clearances (:func:`_clear`) with its midpoint inside the outline.
    """
    x0, y0, cs, nx, ny = grid[0], grid[1], grid[2], int(grid[3]), int(grid[4])
    out = np.zeros(7)
    dist = math.hypot(ex - ax, ey - ay)
    if dist <= 1e-9:
        return out
    tx, ty = (ex - ax) / dist, (ey - ay) / dist
    for j in range(n_shift + 1):
        px, py = ax - j * shift * ty, ay + j * shift * tx
        bx, by = px + L * tx, py + L * ty
        mx, my = 0.5 * (px + bx), 0.5 * (py + by)
        ci = min(nx - 1, max(0, int((mx - x0) / cs)))
        cj = min(ny - 1, max(0, int((my - y0) / cs)))
        if _clear(np.array([px, py, bx, by]), ci, cj, nx, ny, poly, ehead, enext, seg, rhead,
                  rnext, wall, apart) and _inside_one(mx, my, poly):
            out[0], out[1], out[2], out[3], out[4], out[5], out[6] = 1.0, px, py, bx, by, ci, cj
            return out
    return out


@njit(cache=True)
def _place(guide_pts, starts, closed, n_shift, seglen, poly, b, gap, lmax, step,  # noqa: PLR0913
           window):
    """Greedy placement of the segments seglen[0], seglen[1], ... along the guides.

    At each arc position the ``window`` oldest unplaced segments are tried in their order, and
    the first that fits is placed (the next one drawn joins the window).

    At each arc position the chord is tried as it lies, then moved to its left (into the
    outline, for a counter-clockwise guide) by FILL_STEP / 2 at a time, up to n_shift[g] times:
    a layer's chords bulge inwards by their sagitta l^2 / (8 rho), and the next layer makes way.

    Returns (segments (N, 4) as ax, ay, bx, by, their tip-to-tip lengths, count N). Cell
    lists of size lmax + gap hold the outline's edges (subdivided, <= 0.25 long) and the
    placed segments, so the 3 x 3 cells about a candidate's midpoint hold every edge and
    segment within the clearances.
    """
    n_max = seglen.shape[0]
    seg = np.zeros((n_max, 4))
    cs = lmax + gap
    x0, y0 = poly[:, 0].min() - cs, poly[:, 1].min() - cs
    nx = int((poly[:, 0].max() + cs - x0) / cs) + 1
    ny = int((poly[:, 1].max() + cs - y0) / cs) + 1
    k = poly.shape[0]
    ehead = -np.ones(nx * ny, dtype=np.int64)
    enext = -np.ones(k, dtype=np.int64)
    for e in range(k):
        f = (e + 1) % k
        c = _cell(0.5 * (poly[e, 0] + poly[f, 0]), 0.5 * (poly[e, 1] + poly[f, 1]), x0, y0, cs,
                  nx, ny)
        enext[e] = ehead[c]
        ehead[c] = e
    rhead = -np.ones(nx * ny, dtype=np.int64)
    rnext = -np.ones(n_max, dtype=np.int64)
    grid = np.array([x0, y0, cs, nx, ny])
    shift = 0.5 * step
    wall = 0.5 * b + 0.5 * gap
    apart = b + 0.5 * gap
    count = 0
    placed = np.zeros(n_max)
    n_window = min(window, n_max)
    queue = np.arange(n_window)  # the draws waiting for a place, oldest first
    drawn = n_window
    for g in range(starts.shape[0] - 1):
        a, z = starts[g], starts[g + 1]
        if closed[g]:  # the loop once more, so that rods may cross the start
            idx = np.concatenate((np.arange(a, z), np.arange(a, z), np.arange(a, a + 1)))
        else:
            idx = np.arange(a, z)
        pts = guide_pts[idx]
        m = pts.shape[0]
        cum = np.zeros(m)
        for q in range(1, m):
            cum[q] = cum[q - 1] + math.hypot(pts[q, 0] - pts[q - 1, 0], pts[q, 1] - pts[q - 1, 1])
        total = cum[m - 1]
        end = 0.5 * total if closed[g] else total
        s = 0.0
        while n_window > 0 and s < end:
            shortest = seglen[queue[:n_window]].min()
            if s + shortest > total:
                break
            ok = False
            if n_shift[g] == 0:  # every candidate starts at the same point: is it free?
                ax, ay = _at(pts, cum, 0, m, s)
                ci = min(nx - 1, max(0, int((ax - x0) / cs)))
                cj = min(ny - 1, max(0, int((ay - y0) / cs)))
                if not _clear(np.array([ax, ay, ax, ay]), ci, cj, nx, ny, poly, ehead, enext,
                              seg, rhead, rnext, wall, apart):
                    s += step
                    continue
            for w in range(n_window):
                L = seglen[queue[w]]
                if s + L > total:
                    continue
                ax, ay = _at(pts, cum, 0, m, s)
                ex, ey = _at(pts, cum, 0, m, s + L)
                p = _fit(ax, ay, ex, ey, L, n_shift[g], shift, grid, poly, ehead, enext, seg,
                         rhead, rnext, wall, apart)
                ok = p[0] == 1.0
                px, py, bx, by, ci, cj = p[1], p[2], p[3], p[4], int(p[5]), int(p[6])
                if ok:
                    seg[count, 0], seg[count, 1], seg[count, 2], seg[count, 3] = px, py, bx, by
                    placed[count] = L + b
                    c = ci + nx * cj
                    rnext[count] = rhead[c]
                    rhead[c] = count
                    count += 1
                    queue[w:n_window - 1] = queue[w + 1:n_window].copy()
                    if drawn < n_max:
                        queue[n_window - 1] = drawn
                        drawn += 1
                    else:
                        n_window -= 1
                    s += L + b + gap
                    break
            if not ok:
                s += step
    return seg, placed, count

