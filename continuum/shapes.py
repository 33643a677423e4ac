"""Initial shapes of a colony: the shape specification and the outline of each shape.

One specification for both engines (``colony continuum --shape``, ``colony particles --shape``,
``continuum.Config.shape``, ``cases.shapes.initial_particles``):

==========================  ========================================================================
``circle``                  disc of the default radius (``Config.initial_radius``, R0 = sqrt(b/pi))
``circle:R``                disc of radius R
``ellipse:A,B``             x^2/A^2 + y^2/B^2 <= 1
``rectangle:W,H[,ROUND]``   W x H rectangle centred at the origin, corners rounded with radius
                            ROUND (default 0, sharp; 0 <= ROUND <= min(W, H)/2)
``star:K,EPS[,R]``          polar curve r(theta) = R (1 + EPS cos K theta), K >= 2 an integer,
                            0 <= EPS < 1, R default the default radius
``polygon:FILE.csv``        closed polygon of a CSV file with columns x,y, last row = first (to
                            round-off, 1e-12 of the largest coordinate), at most MAX_VERTICES
``line:N``                  N cells end to end (particles only: no outline, no area)
==========================  ========================================================================

:func:`parse` reads a specification into a :class:`Shape` (a one-line ValueError for every
malformed one; every size within SIZES, K at most MAX_VERTICES / 32), :func:`outline` gives
the dense counter-clockwise polygon (K, 2) of a shape with an area, one function per shape
(:func:`circle`, :func:`ellipse`, :func:`rectangle`, :func:`star`, :func:`polygon_csv`).
Exact areas, for checking: pi R^2, pi A B, W H - (4 - pi) ROUND^2, pi R^2 (1 + EPS^2 / 2).

The spec is parsed here, once, for both engines: ``particles`` may not import ``continuum``,
so the cases layer (cases.shapes) joins this outline with the particle fill
(particles.packings.fill_outline); ``line:N`` needs no outline and is parsed here too, so that
one grammar serves both.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from continuum.mesh import PolygonError, check_polygon, circle_polygon, ellipse_polygon
from continuum.radial import R0

__all__ = ["KINDS", "Shape", "parse", "outline", "circle", "ellipse", "rectangle", "star",
           "polygon_csv"]

#: Shape kinds and the arguments each takes (what the error messages quote).
KINDS = {
    "circle": "circle or circle:R",
    "ellipse": "ellipse:A,B",
    "rectangle": "rectangle:W,H[,ROUND]",
    "star": "star:K,EPS[,R]",
    "polygon": "polygon:FILE.csv",
    "line": "line:N",
}

#: Vertices of the outline of a circle or an ellipse (and the least of the other smooth shapes).
N_VERTICES = 256
#: Most vertices of an outline (a polygon file's, a star's 32 K): the check that no two edges
#: cross compares every pair of edges (continuum.mesh.check_polygon), 20 s at 10,000 vertices
#: (and ~8 GiB of index pairs at 1e5).
MAX_VERTICES = 10_000
#: The sizes a shape may have (R, A, B, W, H, ROUND > 0, |x|, |y| of a polygon), in model units
#: (a cell is b = 1/2 wide): a million cells across is beyond either engine's memory, and the
#: areas and perimeters of the sizes outside stay finite and non-zero in floating point.
SIZES = (1e-6, 1e6)


@dataclass(frozen=True)
class Shape:
    """A parsed shape specification.

    Attributes
    ----------
    kind : str
        One of :data:`KINDS`.
    values : tuple of float
        The numbers of the specification, in its order (empty for ``circle`` and ``polygon``;
        the optional ones filled in: ROUND = 0, R = None for the default radius).
    path : str or None
        The file of ``polygon:FILE.csv``.
    spec : str
        The specification as given (stripped).
    """

    kind: str
    values: tuple = ()
    path: str | None = None
    spec: str = ""

    @property
    def has_area(self) -> bool:
        """False for ``line:N`` (a line of particles), True for every other kind."""
        return self.kind != "line"


def _numbers(spec: str, kind: str, args: str, counts: tuple[int, ...]) -> list[float]:
    """The comma-separated finite numbers of ``args``; their count must be one of ``counts``."""
    parts = [p.strip() for p in args.split(",")] if args.strip() else []
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise ValueError(f"shape {spec!r}: expected numbers in {KINDS[kind]}") from None
    if len(values) not in counts:
        plural = "s" if max(counts) > 1 else ""
        raise ValueError(f"shape {spec!r}: {kind} takes {' or '.join(map(str, counts))} "
                         f"number{plural} ({KINDS[kind]}), got {len(values)}")
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"shape {spec!r}: the numbers must be finite")
    return values


def _positive(spec: str, what: str, value: float) -> None:
    """A size: positive and within SIZES."""
    if not value > 0:
        raise ValueError(f"shape {spec!r}: {what} must be positive, got {value:g}")
    if not SIZES[0] <= value <= SIZES[1]:
        raise ValueError(f"shape {spec!r}: {what} must be in [{SIZES[0]:g}, {SIZES[1]:g}] "
                         f"(model units, a cell is 1/2 wide), got {value:g}")


def _integer(spec: str, what: str, value: float, low: int) -> int:
    if value != int(value) or value < low:
        raise ValueError(f"shape {spec!r}: {what} must be an integer >= {low}, got {value:g}")
    return int(value)


def _corner(spec: str, rnd: float, w: float, h: float) -> float:
    """The corner radius ROUND of a W x H rectangle: 0, or a size up to min(W, H) / 2."""
    if not 0 <= rnd <= min(w, h) / 2:
        raise ValueError(f"shape {spec!r}: the corner radius ROUND must be in "
                         f"[0, min(W, H)/2 = {min(w, h) / 2:g}], got {rnd:g}")
    if rnd > 0:
        _positive(spec, "the corner radius ROUND", rnd)
    return rnd


def _mode(spec: str, k: float) -> int:
    """The mode K of a star: an integer >= 2, its outline's 32 K vertices MAX_VERTICES at most."""
    k = _integer(spec, "the mode K", k, 2)
    if 32 * k > MAX_VERTICES:
        raise ValueError(f"shape {spec!r}: the mode K must be at most {MAX_VERTICES // 32} "
                         f"(its outline has 32 K = {32 * k:,} vertices, at most "
                         f"{MAX_VERTICES:,})")
    return k


def parse(spec: str) -> Shape:
    """Read a shape specification (module docstring) and check its values.

    Parameters
    ----------
    spec : str
        ``KIND`` or ``KIND:ARGS``, e.g. ``"star:5,0.2,8"``.

    Returns
    -------
    Shape

    Raises
    ------
    ValueError
        One line naming the spec: unknown kind, wrong count of numbers, a non-number, a
        non-positive size, K not an integer >= 2, EPS outside [0, 1), ROUND outside
        [0, min(W, H)/2], N not an integer >= 1, a polygon without a file name.
    """
    if not isinstance(spec, str):
        raise ValueError(f"shape must be a string such as circle:2 or star:5,0.2,8, got {spec!r}")
    s = spec.strip()
    kind, sep, args = s.partition(":")
    kind = kind.strip()
    if kind not in KINDS:
        raise ValueError(f"unknown shape {s!r}; the shapes are {', '.join(KINDS.values())}")
    if kind == "polygon":
        path = args.strip()
        if not path:
            raise ValueError(f"shape {s!r}: give the file, polygon:FILE.csv")
        return Shape("polygon", (), path, s)
    if kind == "circle":
        if not sep:
            return Shape("circle", (), None, s)
        (r,) = _numbers(s, kind, args, (1,))
        _positive(s, "the radius R", r)
        return Shape("circle", (r,), None, s)
    if not sep:
        raise ValueError(f"shape {s!r}: {kind} needs its numbers, {KINDS[kind]}")
    if kind == "ellipse":
        a, b = _numbers(s, kind, args, (2,))
        _positive(s, "the semi-axis A", a)
        _positive(s, "the semi-axis B", b)
        return Shape("ellipse", (a, b), None, s)
    if kind == "rectangle":
        w, h, *rest = _numbers(s, kind, args, (2, 3))
        _positive(s, "the width W", w)
        _positive(s, "the height H", h)
        rnd = _corner(s, rest[0] if rest else 0.0, w, h)
        return Shape("rectangle", (w, h, rnd), None, s)
    if kind == "star":
        k, eps, *rest = _numbers(s, kind, args, (2, 3))
        k = _mode(s, k)
        if not 0 <= eps < 1:
            raise ValueError(f"shape {s!r}: the amplitude EPS must be in [0, 1), got {eps:g}")
        r = None
        if rest:
            r = rest[0]
            _positive(s, "the radius R", r)
        return Shape("star", (k, eps, r), None, s)
    (n,) = _numbers(s, kind, args, (1,))  # line
    return Shape("line", (_integer(s, "the number of cells N", n, 1),), None, s)


def outline(spec: str | Shape, radius: float = R0) -> np.ndarray:
    """The dense counter-clockwise polygon (K, 2) of a shape with an area.

    Parameters
    ----------
    spec : str or Shape
        A shape specification (:func:`parse`).
    radius : float
        The default radius (of ``circle`` and of ``star:K,EPS``); default R0 = sqrt(b/pi),
        the area of one particle (continuum.radial.R0).

    Raises
    ------
    ValueError
        A malformed spec, ``line:N`` (no area), a default radius outside SIZES, or a bad
        polygon file (PolygonError).
    """
    shape = parse(spec) if isinstance(spec, str) else spec
    if shape.kind in ("circle", "star") and (not shape.values or shape.values[-1] is None):
        _positive(shape.spec, "the default radius (initial_radius)", radius)
    if shape.kind == "circle":
        return circle(shape.values[0] if shape.values else radius)
    if shape.kind == "ellipse":
        return ellipse(*shape.values)
    if shape.kind == "rectangle":
        return rectangle(*shape.values)
    if shape.kind == "star":
        k, eps, r = shape.values
        return star(k, eps, radius if r is None else r)
    if shape.kind == "polygon":
        return polygon_csv(shape.path)
    raise ValueError(f"shape {shape.spec!r} is a line of particles and has no outline; "
                     "the continuum needs a shape with an area")


def circle(r: float) -> np.ndarray:
    """The circle of radius r about the origin: N_VERTICES = 256 equally spaced vertices."""
    return circle_polygon(r, N_VERTICES)


def ellipse(a: float, b: float) -> np.ndarray:
    """The ellipse x^2/a^2 + y^2/b^2 = 1: 256 vertices about equally spaced in arc length."""
    return ellipse_polygon(a, b, N_VERTICES)


def rectangle(w: float, h: float, rnd: float = 0.0, spacing: float | None = None) -> np.ndarray:
    """The w x h rectangle about the origin, corners rounded with radius ``rnd``.

    Straight sides of length w - 2 rnd and h - 2 rnd joined by quarter circles of radius rnd
    (area w h - (4 - pi) rnd^2, perimeter 2 (w + h) - (8 - 2 pi) rnd). Vertices about
    ``spacing`` apart (default perimeter / 256), every corner (rnd = 0) or arc end a vertex.
    """
    perimeter = 2 * (w + h) - (8 - 2 * math.pi) * rnd
    ds = perimeter / N_VERTICES if spacing is None else spacing
    cx, cy = w / 2 - rnd, h / 2 - rnd
    pieces = []
    # counter-clockwise, side by side: the side ending at a corner, then the corner's arc;
    # (corner centre, outward radial direction where the arc starts, direction of the side)
    for (ox, oy), (rx, ry), (tx, ty) in (((cx, -cy), (0, -1), (1, 0)),
                                         ((cx, cy), (1, 0), (0, 1)),
                                         ((-cx, cy), (0, 1), (-1, 0)),
                                         ((-cx, -cy), (-1, 0), (0, -1))):
        side = 2 * (cx if tx else cy)
        if side > 0:
            m = max(1, math.ceil(side / ds))
            t = side * (np.arange(m) / m - 1)  # from the previous corner to this one
            pieces.append(np.column_stack([ox + rnd * rx + t * tx, oy + rnd * ry + t * ty]))
        if rnd > 0:
            m = max(2, math.ceil(0.5 * math.pi * rnd / ds))
            phi = math.atan2(ry, rx) + 0.5 * math.pi * np.arange(m) / m
            pieces.append(np.column_stack([ox + rnd * np.cos(phi), oy + rnd * np.sin(phi)]))
    return check_polygon(np.vstack(pieces), check_simple=False)


def star(k: int, eps: float, r: float, n: int | None = None) -> np.ndarray:
    """The polar curve r(theta) = r (1 + eps cos k theta): n = max(256, 32 k) vertices.

    Equally spaced in theta (area pi r^2 (1 + eps^2 / 2); eps < 1 keeps r(theta) > 0, so the
    curve is simple and star-shaped about the origin).
    """
    n = max(N_VERTICES, 32 * k) if n is None else n
    theta = 2 * np.pi * np.arange(n) / n
    rho = r * (1 + eps * np.cos(k * theta))
    return np.column_stack([rho * np.cos(theta), rho * np.sin(theta)])


def polygon_csv(path) -> np.ndarray:
    """Read a closed boundary polygon from a CSV file with columns x,y (header line optional).

    The polygon must be explicitly closed: the last row repeats the first, to round-off (1e-12
    of the largest coordinate). Returns the checked, counter-clockwise vertices without the
    closing duplicate (continuum.mesh.check_polygon).

    Raises
    ------
    PolygonError
        One line naming the file: missing, not text, an unreadable line, more than
        MAX_VERTICES vertices, a coordinate beyond SIZES, an open polygon, fewer than 3
        vertices, or a polygon that is not simple or has no area.
    """
    path, name = Path(path), _name(path)
    if not _is_file(path):
        raise PolygonError(f"polygon file not found: {name}")
    xy = _read_xy(path)
    if len(xy) < 2 or not _closed(xy):
        raise PolygonError(
            f"polygon in {name} is not closed: the last vertex must repeat the first"
        )
    if len(xy) < 4:
        raise PolygonError(f"polygon in {name} has {len(xy) - 1} distinct vertices; a polygon "
                           "needs at least 3 (then the first repeated)")
    try:
        return check_polygon(xy[:-1])
    except PolygonError as err:
        raise PolygonError(f"polygon in {name}: {err}") from None


def _is_file(path: Path) -> bool:
    """Whether ``path`` is a file (False also for a name the system refuses: too long, NUL)."""
    try:
        return path.is_file()
    except (OSError, ValueError):
        return False


def _read_xy(path: Path) -> np.ndarray:
    """The x,y rows of a polygon file (K, 2): finite, within SIZES, at most MAX_VERTICES + 1."""
    rows, name = [], _name(path)
    try:
        with path.open(newline="") as fh:
            for row in csv.reader(fh):
                if not row or row[0].strip().lower() in ("x", "#"):
                    continue
                if len(rows) > MAX_VERTICES:
                    raise PolygonError(f"polygon in {name} has more than {MAX_VERTICES:,} "
                                       "vertices (the check that no two edges cross compares "
                                       "every pair); resample it")
                try:
                    rows.append([float(row[0]), float(row[1])])
                except (ValueError, IndexError):
                    raise PolygonError(f"{name}: cannot read x,y from the line "
                                       f"{','.join(row)[:60]!r}") from None
    except (UnicodeDecodeError, csv.Error) as err:
        raise PolygonError(f"{name} is not a text CSV file of x,y rows ({err})") from None
    xy = np.array(rows, dtype=float).reshape(-1, 2)
    if not np.all(np.abs(xy) <= SIZES[1]):  # also NaN
        raise PolygonError(f"polygon in {name}: the coordinates must be finite numbers within "
                           f"+-{SIZES[1]:g}")
    return xy


def _closed(xy: np.ndarray) -> bool:
    """Whether the last vertex repeats the first, to 1e-12 of the largest coordinate."""
    scale = float(np.max(np.abs(xy)))
    return bool(np.all(np.abs(xy[-1] - xy[0]) <= 1e-12 * scale))


def _name(path) -> str:
    """A file name for a one-line message: as it is, or quoted when it holds a line break."""
    text = str(path)
    return text if text.isprintable() else repr(text)
