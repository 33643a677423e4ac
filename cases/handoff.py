"""A particle colony handed to the continuum: its outline, its size distribution, its start.

``colony continuum --from-particles RUN_DIR`` (from Python :func:`simulation_from_particles`,
or :func:`continuum_start` and ``continuum.run(config, out, state=state)``) starts
the continuum from the final state of a particle run, the last frame of its trajectory.gsd
(particles.read_trajectory), so that both models grow the same colony: the particle run
continued (e.g. ``colony particles --init`` of that frame) and the continuum from here.

Outline (:func:`particle_outline`). The colony is the union of its sphero-cylinders (width b,
tip-to-tip length l). Each rod's outline is sampled (its two straight sides and its two
half-disc caps, at most ``b / 4`` apart), and the alpha shape of all these points is taken:
the Delaunay triangles whose circumradius is below ``alpha`` (default ``ALPHA`` = 2 b = one
unit of length: gaps and bays narrower than about 2 alpha are filled, wider ones carved), and
the boundary of their union traced counter-clockwise. Holes are filled (the outer loop only),
pinches split (the loop of largest area is kept), so the result is a simple counter-clockwise
polygon (continuum.mesh.check_polygon); its vertices lie on rod outlines, so the area is that
of the colony with its inner gaps filled.

Size distribution (:func:`size_distribution`). At a point x, the lengths of the nearby
particles, weighted by a Gaussian kernel of their centres' distance d to x,
K(x - x_p) = exp(-d^2 / (2 h^2)) (bandwidth h, default ``BANDWIDTH`` = 2: four rod widths,
about 1.3 mean cell lengths; cut at 4 h), give the normalised histogram (the Nadaraya-Watson
estimate) on the continuum's grid in s = log2 l::

    p(x, i) = sum_p K(x - x_p) w_pi / sum_p K(x - x_p),

w_pi the share of particle p in cell i: the particle is split between the two cells whose mean
lengths bracket its length l_p so that both its number and its length are kept. So the mean
length of Psi0 at x is the kernel-weighted mean of the particle lengths, exactly, except for
particles shorter than the first cell's mean length (1.0087 for 40 cells) or longer than the
last one's (1.9828), which go wholly to that cell: their lengths move by at most 0.0087 and
0.0172 (one value per cell cannot hold a length outside the cells' means). The number per
unit area is the packing of the model, one rod width of cell length per unit area:
rho(x) = 1 / (b lbar(x)), so Psi0 = n(x, s_i) = rho(x) p(x, i) / ds (the flow does not
depend on this normalisation; the fields number and total_length do).

Growth phase: G0 = 0 (continuum.initial): the transported Psi carries the sizes from here on
(the transport along characteristics shifts each element's distribution exactly), G only
measures the growth since the hand-off; the closed form 2^frac(G / ln 2) of ``mean_length``
does not apply to this start (it is that of Psi0 = delta(l - 1)).

The run folder gets ``handoff.json`` (where the state came from and the two parameters) and
``outline.csv`` (the alpha shape, before the continuum resamples it at its mesh spacing).
:func:`compare_runs` reads a particle run and a continuum run and tabulates area, aspect ratio
and mean length over time.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from scipy.spatial import Delaunay, cKDTree

from cases import rundir
from cases.analysis.io import DamagedFileError, check_trajectory, read_particle_frames
from continuum.mesh import PolygonError, check_polygon, polygon_area, triangle_areas
from continuum.sizes import LengthGrid
from particles import B

__all__ = [
    "ALPHA",
    "BANDWIDTH",
    "HANDOFF",
    "OUTLINE",
    "rod_outline_points",
    "alpha_shape",
    "particle_outline",
    "length_shares",
    "size_distribution",
    "check_bandwidth",
    "final_particles",
    "particle_lam",
    "continuum_start",
    "simulation_from_particles",
    "check_resume",
    "read_handoff",
    "write_handoff",
    "region_moments",
    "outline_moments",
    "polygon_moments",
    "compare_runs",
]

ALPHA = 2.0 * B
"""Default alpha (largest circumradius of a kept Delaunay triangle): two rod widths."""

BANDWIDTH = 4.0 * B
"""Default kernel bandwidth h of Psi0: four rod widths (length 2)."""

MAX_BANDWIDTH = 10.0
"""Largest kernel bandwidth h of Psi0 (20 rod widths, 5 times the default): the kernel reaches
4 h, so each mesh node weighs about 0.9 pi (4 h)^2 particles, 4,500 at 10 (180 at the default),
and a wider kernel smooths away the radial profile of the lengths the hand-off carries."""

HANDOFF = "handoff.json"
OUTLINE = "outline.csv"


# ---------------------------------------------------------------------------- outline


def rod_outline_points(x, y, theta, length, spacing: float = B / 4) -> np.ndarray:
    """Points on the outline of every sphero-cylinder (width b), at most ``spacing`` apart.

    Rod n: segment centre (x_n, y_n), axis (cos theta_n, sin theta_n), half segment
    a_n = (l_n - b) / 2; its outline is the two sides at +-b/2 from the segment and the two
    half circles of radius b/2 about its ends.
    """
    x, y, theta, length = (np.asarray(v, dtype=float) for v in (x, y, theta, length))
    r = 0.5 * B
    out = []
    n_cap = max(4, math.ceil(math.pi * r / spacing))
    cap = np.linspace(-0.5 * math.pi, 0.5 * math.pi, n_cap + 1)
    a_all = np.maximum(0.5 * (length - B), 0.0)
    n_side = np.maximum(1, np.ceil(2 * a_all / spacing).astype(int))
    for k in np.unique(n_side):
        sel = n_side == k
        a, c, s = a_all[sel, None], np.cos(theta[sel])[:, None], np.sin(theta[sel])[:, None]
        t = np.linspace(-1.0, 1.0, k + 1)[None, :] * a  # along the axis
        # local (u along the axis, v across): sides v = +-r, caps at u = +-a
        u = np.concatenate([t, t, a + r * np.cos(cap)[None, :], -a - r * np.cos(cap)[None, :]],
                           axis=1)
        v = np.concatenate([np.full_like(t, r), np.full_like(t, -r),
                            np.broadcast_to(r * np.sin(cap), (sel.sum(), cap.size)),
                            np.broadcast_to(r * np.sin(cap), (sel.sum(), cap.size))], axis=1)
        px = x[sel, None] + u * c - v * s
        py = y[sel, None] + u * s + v * c
        out.append(np.column_stack([px.ravel(), py.ravel()]))
    return np.concatenate(out)


def _circumradii(pts: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Circumradius abc / (4 ``|T|``) of each triangle (inf for a degenerate one)."""
    a, b, c = pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]
    la, lb, lc = (np.linalg.norm(p - q, axis=1) for p, q in ((b, c), (c, a), (a, b)))
    area = 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                        - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    with np.errstate(divide="ignore"):
        return np.where(area > 0, la * lb * lc / (4.0 * np.maximum(area, 1e-300)), np.inf)


def _boundary_loops(pts: np.ndarray, tri: np.ndarray) -> list[list[int]]:
    """Closed loops of the boundary edges of a union of triangles, interior on the left.

    Triangles are made counter-clockwise; an edge of exactly one triangle is a boundary edge,
    directed as in that triangle. At a vertex with several outgoing edges (a pinch) the walk
    takes the one bounding the same sector of the interior: the first met turning clockwise
    from the edge it came along, so every loop visits a vertex at most once per sector.
    """
    a, b, c = pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]
    cw = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]) < 0
    tri = tri.copy()
    tri[cw] = tri[cw][:, ::-1]
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    key = np.sort(edges, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    directed = edges[counts[inverse.ravel()] == 1]
    out: dict[int, list[int]] = {}
    for u, v in directed.tolist():
        out.setdefault(u, []).append(v)
    loops = []
    while out:
        start = next(iter(out))
        loop, prev, cur = [start], None, start
        while True:
            nexts = out[cur]
            nxt = nexts[0]
            if prev is not None and len(nexts) > 1:
                back = pts[prev] - pts[cur]
                turn = [(math.atan2(back[1], back[0])
                         - math.atan2(pts[w][1] - pts[cur][1], pts[w][0] - pts[cur][0]))
                        % (2 * math.pi) for w in nexts]
                nxt = nexts[int(np.argmin(turn))]
            nexts.remove(nxt)
            if not nexts:
                del out[cur]
            if nxt == start:
                break
            loop.append(nxt)
            prev, cur = cur, nxt
        loops.append(loop)
    return loops


def _split_repeats(loop: list[int], pts: np.ndarray) -> list[int]:
    """The largest simple part of a loop that visits a vertex twice (split there)."""
    while True:
        seen: dict[int, int] = {}
        for j, v in enumerate(loop):
            if v in seen:
                i = seen[v]
                inner, outer = loop[i:j], loop[:i] + loop[j:]
                loop = max((inner, outer), key=lambda q: polygon_area(pts[q]))
                break
            seen[v] = j
        else:
            return loop


def alpha_shape(points: np.ndarray, alpha: float) -> np.ndarray:
    """Outer boundary of the alpha shape of ``points``: a simple counter-clockwise polygon.

    Delaunay triangles of circumradius < ``alpha`` are kept; the boundary loops of their union
    (:func:`_boundary_loops`) are split at repeated vertices, and the loop of largest area is
    returned (holes and smaller pieces dropped).

    Raises
    ------
    ValueError
        Fewer than three points, or no triangle kept (``alpha`` too small for the spacing).
    """
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3:
        raise ValueError("the alpha shape needs at least three points (n, 2)")
    if not (math.isfinite(alpha) and alpha > 0):
        raise ValueError(f"alpha must be a positive number, got {alpha!r}")
    pts = np.unique(pts, axis=0)
    tri = Delaunay(pts).simplices
    tri = tri[_circumradii(pts, tri) < alpha]
    if len(tri) == 0:
        raise ValueError(f"alpha = {alpha:g} keeps no triangle: choose a larger alpha")
    loops = [_split_repeats(loop, pts) for loop in _boundary_loops(pts, tri)]
    best = max(loops, key=lambda q: polygon_area(pts[q]))
    return check_polygon(pts[best])


def particle_outline(x, y, theta, length, alpha: float = ALPHA) -> np.ndarray:
    """Outline of a particle colony: the alpha shape of its rods' outlines (module docstring).

    Returns a simple counter-clockwise polygon (K, 2).
    """
    return alpha_shape(rod_outline_points(x, y, theta, length), alpha)


# ---------------------------------------------------------------------------- Psi0


def length_shares(length: np.ndarray, grid: LengthGrid) -> tuple[np.ndarray, np.ndarray]:
    """Each particle's shares of two cells of ``grid``: (cell k, weight w of k; 1 - w of k + 1).

    The cell mean lengths q_i = (2^(s_(i+1)) - 2^(s_i)) / (ln 2 ds) bracket l: q_k <= l < q_(k+1),
    weight (q_(k+1) - l) / (q_(k+1) - q_k), so the number (1) and the length (l) of the
    particle are kept. l below q_0 (above q_(N-1)) goes wholly to cell 0 (N - 1).
    """
    q = grid.length_integrals / grid.ds
    lengths = np.asarray(length, dtype=float)
    k = np.clip(np.searchsorted(q, lengths, side="right") - 1, 0, grid.n_cells - 2)
    w = np.clip((q[k + 1] - lengths) / (q[k + 1] - q[k]), 0.0, 1.0)
    return k, w


def check_bandwidth(bandwidth: float) -> None:
    """ValueError (one line, with the valid range) unless 0 < ``bandwidth`` <= MAX_BANDWIDTH."""
    if not (math.isfinite(bandwidth) and 0 < bandwidth <= MAX_BANDWIDTH):
        raise ValueError(f"bandwidth must be a positive number at most {MAX_BANDWIDTH:g}, got "
                         f"{bandwidth:g} (the kernel of Psi0 reaches 4 bandwidths: about 4,500 "
                         f"particles a mesh node at {MAX_BANDWIDTH:g}, 180 at the default "
                         f"{BANDWIDTH:g})")


def size_distribution(x, y, length, grid: LengthGrid, bandwidth: float = BANDWIDTH):
    """Psi0 of a particle colony: a function of the nodes xy (n, 2) -> (n, grid.n_cells).

    n(x, s_i) = rho(x) p(x, i) / ds with the kernel-weighted histogram p and rho = 1 / (b lbar)
    (module docstring). Raises ValueError at a node with no particle within 4 ``bandwidth``.
    """
    check_bandwidth(bandwidth)
    centres = np.column_stack([np.asarray(x, float), np.asarray(y, float)])
    k, w = length_shares(length, grid)
    n_particles = len(centres)
    shares = sp.csr_matrix((np.concatenate([w, 1.0 - w]),
                            (np.tile(np.arange(n_particles), 2), np.concatenate([k, k + 1]))),
                           shape=(n_particles, grid.n_cells))
    tree = cKDTree(centres)

    def psi0(xy: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy, dtype=float)
        near = tree.query_ball_point(xy, 4.0 * bandwidth, return_sorted=True)
        counts = np.fromiter(map(len, near), dtype=np.int64, count=len(near))
        if np.any(counts == 0):
            raise ValueError(f"a node has no particle within {4 * bandwidth:g} "
                             "(4 bandwidths): the outline and the particles do not match")
        cols = np.concatenate(near).astype(np.int64)
        rows = np.repeat(np.arange(len(xy)), counts)
        d2 = np.sum((xy[rows] - centres[cols]) ** 2, axis=1)
        kernel = sp.csr_matrix((np.exp(-0.5 * d2 / bandwidth**2), (rows, cols)),
                               shape=(len(xy), n_particles))
        p = np.asarray((kernel @ shares).todense()) / np.asarray(kernel.sum(axis=1))
        lbar = p @ (grid.length_integrals / grid.ds)
        return p / (B * lbar[:, None] * grid.ds)

    return psi0


# ---------------------------------------------------------------------------- the hand-off


def final_particles(run_dir: str | os.PathLike):
    """The last trajectory frame of a particle run folder (particles.TrajectoryFrame).

    The trajectory and the frame are checked before use (cases.analysis.io.check_trajectory,
    check_particle_frame): a damaged last frame is refused, never handed over.

    Raises
    ------
    ValueError
        Not a folder, no trajectory.gsd, a damaged one (DamagedFileError), no frame, or fewer
        than 3 particles (one line).
    """
    folder = Path(run_dir)
    if not folder.is_dir():
        raise ValueError(f"particle run folder not found: {folder}")
    rundir.check_source(folder)
    path = folder / "trajectory.gsd"
    if not path.is_file():
        raise ValueError(f"{folder} is not a particle run folder (no trajectory.gsd)")
    n = check_trajectory(path)
    if n == 0:
        raise ValueError(f"{path} has no frame")
    (frame,) = read_particle_frames(path, [n - 1])
    if frame.n < 3:
        raise ValueError(f"{path}: the last frame has {frame.n} particles, the hand-off "
                         "needs at least 3")
    return frame


def particle_lam(run_dir: str | os.PathLike) -> float | None:
    """The stress sensitivity lam of a particle run (config.json), or None without one."""
    try:
        return float(json.loads((Path(run_dir) / "config.json").read_text())["lam"])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def continuum_start(run_dir: str | os.PathLike, config, alpha: float = ALPHA,
                    bandwidth: float = BANDWIDTH):
    """The continuum state at t = 0 from a particle run's final frame, and its record.

    Parameters
    ----------
    run_dir : path
        Particle run folder (trajectory.gsd).
    config : continuum.Config
        Mesh and Psi grid of the continuum run; its ``initial_sizes`` must be "histogram"
        (Psi0 is the particles' size histogram, and the run's config.json says so).
    alpha, bandwidth : float
        Of the outline and of Psi0 (module docstring).

    Returns
    -------
    state : continuum.State
        For ``continuum.Simulation(config, state=state)`` / ``continuum.run``.
    record : dict
        What ``handoff.json`` holds (source, frame, parameters, outline area) and the outline
        under "outline" (not written to the JSON).

    Raises
    ------
    ValueError
        A bad run folder or parameters, a configuration whose ``initial_sizes`` is not
        "histogram", or an outline the mesh cannot take.
    """
    from continuum.initial import state_from

    if config.initial_sizes != "histogram":
        raise ValueError(f"a hand-off starts from the particles' size histogram: give "
                         f"initial_sizes='histogram' (got {config.initial_sizes!r})")
    check_bandwidth(bandwidth)  # before the particle run is read
    frame = final_particles(run_dir)
    if not (math.isfinite(alpha) and alpha > 0):
        raise ValueError(f"alpha must be a positive number, got {alpha!r}")
    try:
        outline = particle_outline(frame.x, frame.y, frame.theta, frame.length, alpha)
    except PolygonError as err:
        raise ValueError(f"the outline of the particles is not a simple polygon: {err}") from None
    psi0 = size_distribution(frame.x, frame.y, frame.length, LengthGrid(config.n_length_cells),
                             bandwidth)
    state = state_from(config, outline, psi0)
    area = polygon_area(outline)
    record = {
        "particle_run": str(Path(run_dir).resolve()), "step": frame.step, "t": frame.t,
        "n_particles": frame.n, "particle_lam": particle_lam(run_dir), "alpha": alpha,
        "bandwidth": bandwidth, "outline_area": area,
        "outline_radius": math.sqrt(area / math.pi),
        "particle_mean_length": float(frame.length.mean()),
        "G0": 0.0,
    }
    return state, {**record, "outline": outline}


def simulation_from_particles(run_dir: str | os.PathLike, config, alpha: float = ALPHA,
                              bandwidth: float = BANDWIDTH):
    """(continuum.Simulation, record) started from a particle run's final state (no output).

    The Python form of ``colony continuum --from-particles``: :func:`continuum_start`, then
    ``continuum.Simulation(config, state=state)``::

        sim, record = simulation_from_particles(
            "runs/particles", continuum.Config(lam=0.01, initial_sizes="histogram"))
        sim.advance(radius=20.0)
    """
    from continuum import Simulation

    state, record = continuum_start(run_dir, config, alpha, bandwidth)
    return Simulation(config, state=state), record


#: What identifies a hand-off's start: a stopped run resumes only from the same.
START_KEYS = ("particle_run", "step", "alpha", "bandwidth")


def check_resume(stage: Path, record: dict | None) -> None:
    """Refuse to resume a stopped continuum run in ``stage`` from another start.

    A checkpoint in ``stage`` continues the run it came from: a hand-off from the same
    particle state and parameters (``START_KEYS`` of its handoff.json), or a run without
    hand-off when ``record`` is None. Raises ValueError (one line) otherwise.
    """
    stage = Path(stage)
    if not (stage / "checkpoint.npz").is_file():
        return
    saved = read_handoff(stage) if (stage / HANDOFF).is_file() else None
    same = (saved is None and record is None) or (
        saved is not None and record is not None
        and all(saved.get(k) == record.get(k) for k in START_KEYS))
    if not same:
        what = "a run without --from-particles" if saved is None else \
            f"a hand-off from {saved.get('particle_run')} (step {saved.get('step')})"
        raise ValueError(f"{stage} holds a stopped continuum run of {what}; give its command "
                         "to resume it, or --overwrite to start afresh (removes it)")


def read_handoff(folder: Path) -> dict:
    """The ``handoff.json`` of ``folder``: a JSON object (DamagedFileError naming it otherwise)."""
    path = Path(folder) / HANDOFF
    try:
        record = json.loads(path.read_text())
    except UnicodeDecodeError:
        raise DamagedFileError(f"{path} is damaged: not text") from None
    except ValueError as err:
        raise DamagedFileError(f"{path} is damaged: {err}") from None
    if not isinstance(record, dict):
        raise DamagedFileError(f"{path} is damaged: not a JSON object")
    return record


def write_handoff(folder: Path, record: dict) -> None:
    """``handoff.json`` (the record without the outline) and ``outline.csv`` (x,y)."""
    folder = Path(folder)
    body = {k: v for k, v in record.items() if k != "outline"}
    (folder / HANDOFF).write_text(json.dumps(body, indent=2) + "\n")
    np.savetxt(folder / OUTLINE, record["outline"], delimiter=",", header="x,y", comments="",
               fmt="%.17g")


# ---------------------------------------------------------------------------- comparison


def region_moments(corners: np.ndarray, area: np.ndarray) -> tuple[float, float]:
    """(area, aspect ratio) of a region given as triangles (corners (M, 3, 2), areas (M,)).

    Aspect ratio sqrt(mu_1 / mu_2), mu_1 >= mu_2 the eigenvalues of the second moment of area
    about the centroid c, int (x - c)(x - c)^T dA, exact per triangle:
    ``|T|`` / 12 (sum_i d_i d_i^T + (sum_i d_i)(sum_i d_i)^T), d_i its corners about c. 1 for a
    disc, A / B for an ellipse of semi-axes A >= B, W / H for a W x H rectangle. Signed areas
    (a polygon's fan of triangles about one vertex) give the polygon's moments.
    """
    A = float(area.sum())
    c = (area[:, None] * corners.mean(axis=1)).sum(axis=0) / A
    d = corners - c
    s = d.sum(axis=1)
    M = (np.einsum("m,mki,mkj->ij", area, d, d) + np.einsum("m,mi,mj->ij", area, s, s)) / 12.0
    mu = np.linalg.eigvalsh(M / A)
    return abs(A), math.sqrt(mu[1] / mu[0])


def outline_moments(points: np.ndarray, triangles: np.ndarray) -> tuple[float, float]:
    """(area, aspect ratio) of a triangulated region (:func:`region_moments`)."""
    pts, tri = np.asarray(points, dtype=float), np.asarray(triangles, dtype=np.int64)
    return region_moments(pts[tri], np.abs(triangle_areas(pts, tri)))


def polygon_moments(polygon: np.ndarray) -> tuple[float, float]:
    """(area, aspect ratio) of a simple polygon: the fan of signed triangles from vertex 0."""
    pts = np.asarray(polygon, dtype=float)
    n = len(pts)
    tri = np.column_stack([np.zeros(n - 2, int), np.arange(1, n - 1), np.arange(2, n)])
    a, b, c = pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]
    area = 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                  - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    return region_moments(pts[tri], area)


def compare_runs(particle_dir: str | os.PathLike, continuum_dir: str | os.PathLike,
                 t_start: float | None = None, alpha: float = ALPHA) -> dict[str, np.ndarray]:
    """Area, aspect ratio and mean length over time of a particle and a continuum run.

    Rows (columns engine, t, area, aspect, mean_length; engine 0 continuum, 1 particles):

    - continuum, every VTU frame: the mesh's area and aspect ratio (:func:`outline_moments`),
      the mean cell length int L dA / int N dA from the transported Psi (fields total_length,
      number per area; lumped P1 integrals);
    - particles, every trajectory frame at t >= ``t_start``: the alpha shape's area and aspect
      ratio (:func:`particle_outline`), the mean particle length; t shifted by ``t_start``.

    ``t_start`` None: the hand-off time in the continuum run's handoff.json when it came from
    ``particle_dir``, else 0 (a particle run continued from the handed-off frame starts at t = 0
    too).
    """
    from cases.analysis import continuum_frames, particle_frames, read_continuum_frame

    continuum_dir, particle_dir = Path(continuum_dir), Path(particle_dir)
    if t_start is None:
        t_start = 0.0
        if (continuum_dir / HANDOFF).is_file():
            rec = read_handoff(continuum_dir)
            if Path(str(rec.get("particle_run", ""))) == particle_dir.resolve():
                t_start = float(rec["t"])
    rows = {k: [] for k in ("engine", "t", "area", "aspect", "mean_length")}

    def add(engine, t, area, aspect, mean):
        for key, v in zip(rows, (engine, t, area, aspect, mean), strict=True):
            rows[key].append(v)

    for t, path in continuum_frames(continuum_dir):
        pts, tri, data = read_continuum_frame(path)
        area, aspect = outline_moments(pts, tri)
        lumped = np.zeros(len(pts))
        np.add.at(lumped, tri.ravel(), np.repeat(np.abs(triangle_areas(pts, tri)) / 3.0, 3))
        mean = float(lumped @ data["total_length"] / (lumped @ data["number"]))
        add(0, t, area, aspect, mean)
    for t, fr in particle_frames(particle_dir):
        if t < t_start - 1e-12 or fr["x"].size < 3:
            continue
        area, aspect = polygon_moments(particle_outline(fr["x"], fr["y"], fr["theta"],
                                                         fr["length"], alpha))
        add(1, t - t_start, area, aspect, float(fr["length"].mean()))
    return {k: np.array(v, dtype=float) for k, v in rows.items()}
