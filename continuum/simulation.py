"""The continuum colony: moving-boundary Darcy growth with size-distribution transport.

Model (model.md): on Omega(t), u = -grad p, div u = g = exp(-lam p), p = 0 on the boundary,
the boundary moves with u; the growth phase G = int g dt and the size distribution Psi(x, l, t)
are carried by the material. Initial condition: a disc of radius R0 = sqrt(b/pi) (or the given
shape), G = 0, Psi0 a narrow smooth bump standing in for delta(l - 1) (continuum.sizes).

One time step (continuum.motion): Heun's RK2 for the node positions and G, the trapezoidal
growth rate for Psi, two pressure solves (continuum.pressure) per step, dt from the explicit
stability limit courant * h / u_edge, remeshing when the mesh degrades or must follow the
domain's size.

Mesh size: boundary edge length h = min(h_max, h_N(area)) with h_N the size giving about
``n_nodes`` nodes on the current area (continuum.mesh.h_for_nodes): a fixed node count while
the colony is small, a capped spacing later. With ``interior_coarsening`` c > 1 the interior
size grows away from the edge up to c h (graded mesh, fewer nodes where nothing happens fast).

Psi is stored per material element (per node, continuum.sizes); at a remesh the density per
current area, Psi exp(-G) (the area stretch of a material element is exp(G) since
div u = g), is interpolated and multiplied back by exp(G_new).

Determinism: a configuration gives the same bits in any process (history, fields, files).
The one random ingredient, pyamg's spectral-radius estimate in the AMG setup, runs with a
fixed seed (continuum.pressure.amg_hierarchy); Triangle's meshing is deterministic and
independent of earlier calls; BLAS runs on one thread (limit_blas_threads).

Checkpoints (``run(config, out)``): every ``checkpoint_seconds`` of wall time, after the last
step of a call (``max_steps_this_call``) and after the step during which SIGINT or SIGTERM
arrived, ``out/checkpoint.npz`` is written atomically. It holds everything the following
steps depend on (``_Colony.snapshot``: mesh, p, u, g, G, Psi, the warm start p_prev and
dt_prev, the counters and the matrix the pressure solver's AMG hierarchy was built from,
which the resumed solver rebuilds identically) and the run's bookkeeping (history, the VTU
frame list, the next frame time, the configuration). ``run`` with the same configuration (up
to EXECUTION_FIELDS) on that folder resumes from it, removes the frames written after it,
and ends bit-identical to an uninterrupted run; writing checkpoints changes no state, so the
result does not depend on when they happen.
"""

from __future__ import annotations

import json
import logging
import math
import os
import signal
import sys
import threading
import time as _time
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

import numpy as np

from continuum import mesh as M
from continuum.budget import check_memory
from continuum.motion import Locator, gradient_corrected_matrix, remesh_reason, stable_dt
from continuum.pressure import PressureDivergence, PressureSolver, limit_blas_threads
from continuum.radial import R0
from continuum.sizes import LengthGrid, SizeDistribution
from continuum.velocity import nodal_velocity

__all__ = ["ContinuumConfig", "ContinuumState", "run", "initial_boundary"]

LN2 = math.log(2.0)
log = logging.getLogger(__name__)


@dataclass
class ContinuumConfig:
    """Configuration of one continuum run (exactly one of ``radius`` and ``time``).

    Attributes
    ----------
    lam : float
        Stress sensitivity lambda (finite).
    radius : float or None
        Stop when the colony radius sqrt(area/pi) reaches this value.
    time : float or None
        Stop at this time.
    shape : str
        "circle" (radius ``initial_radius``), "ellipse:A,B" (semi-axes A, B) or
        "polygon:FILE.csv" (closed polygon, columns x,y).
    initial_radius : float
        Radius of the initial circle (default R0 = sqrt(b/pi), one particle's area).
    n_nodes : int
        Target node count while the colony is small (h = h_N(area)).
    h_max : float
        Cap on the boundary mesh spacing h.
    interior_coarsening : float
        Interior mesh size up to this multiple of h (1 = uniform mesh).
    grading : float
        Growth of the interior mesh size with the distance d to the edge: min(c h, h + grading d).
    courant : float
        dt = courant * h_boundary / max u_boundary.
    q_min : float
        Remesh when a triangle's quality drops below this.
    stretch : float
        Remesh when boundary edges or the mean element size leave [h/stretch, stretch h].
    n_length_cells : int
        Cells of the log2-length grid of Psi.
    bump_width : float
        Half-width in s = log2 l of the initial bump standing in for delta(l - 1).
    output_every : float
        Time between field frames (VTU); 0 writes only the first and last.
    write_fields : bool
        Write the VTU series (history, boundary and config are always written).
    max_steps : int
        Safety limit on the number of time steps.
    checkpoint_seconds : float
        Wall time between checkpoints when writing to a folder (an execution setting,
        ``EXECUTION_FIELDS``: a checkpoint resumes under another value, with the same result).
    """

    lam: float = 0.0
    radius: float | None = None
    time: float | None = None
    shape: str = "circle"
    initial_radius: float = R0
    n_nodes: int = 2000
    h_max: float = 0.55
    interior_coarsening: float = 2.5
    grading: float = 0.05
    courant: float = 0.6
    q_min: float = 0.35
    stretch: float = 1.5
    n_length_cells: int = 40
    bump_width: float = 0.08
    output_every: float = 1.0
    write_fields: bool = True
    max_steps: int = 200_000
    checkpoint_seconds: float = 300.0

    def validate(self) -> ContinuumConfig:
        """Check the values; raises ValueError with a one-line message. Returns self."""

        def positive(name):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive finite number, got {v!r}")

        if not (isinstance(self.lam, (int, float)) and math.isfinite(self.lam)):
            raise ValueError(f"lam must be a finite number, got {self.lam!r}")
        if (self.radius is None) == (self.time is None):
            raise ValueError("give exactly one of radius and time")
        for name in ("initial_radius", "h_max", "courant", "bump_width", "grading"):
            positive(name)
        if self.radius is not None:
            positive("radius")
        if self.time is not None:
            positive("time")
        if not (isinstance(self.n_nodes, int) and self.n_nodes >= 50):
            raise ValueError(f"n_nodes must be an integer >= 50, got {self.n_nodes!r}")
        if not (math.isfinite(self.interior_coarsening) and self.interior_coarsening >= 1):
            raise ValueError(f"interior_coarsening must be >= 1, got {self.interior_coarsening!r}")
        if not 0 < self.courant <= 1.0:
            raise ValueError(f"courant must be in (0, 1], got {self.courant!r}")
        if not 0 < self.q_min < 0.9:
            raise ValueError(f"q_min must be in (0, 0.9), got {self.q_min!r}")
        if not (math.isfinite(self.stretch) and self.stretch > 1.1):
            raise ValueError(f"stretch must be > 1.1, got {self.stretch!r}")
        if not (isinstance(self.n_length_cells, int) and self.n_length_cells >= 8):
            raise ValueError(f"n_length_cells must be an integer >= 8, got {self.n_length_cells!r}")
        if not (math.isfinite(self.output_every) and self.output_every >= 0):
            raise ValueError(f"output_every must be >= 0, got {self.output_every!r}")
        if not (isinstance(self.max_steps, int) and self.max_steps > 0):
            raise ValueError(f"max_steps must be a positive integer, got {self.max_steps!r}")
        if not (math.isfinite(self.checkpoint_seconds) and self.checkpoint_seconds >= 0):
            raise ValueError(f"checkpoint_seconds must be >= 0, got {self.checkpoint_seconds!r}")
        self._shape_polygon()  # parses and checks the shape
        if self.radius is not None:
            r_init = math.sqrt(abs(M.polygon_area(self._shape_polygon())) / math.pi)
            if self.radius < r_init:
                raise ValueError(
                    f"radius {self.radius} is smaller than the initial radius {r_init:.6g}"
                )
        return self

    def _shape_polygon(self) -> np.ndarray:
        """A dense polygon of the initial shape (checked, counter-clockwise)."""
        s = str(self.shape).strip()
        if s == "circle":
            return M.circle_polygon(self.initial_radius, 256)
        if s.startswith("ellipse:"):
            try:
                a, b = (float(v) for v in s[len("ellipse:") :].split(","))
            except ValueError:
                raise ValueError(
                    f"shape must be ellipse:A,B with numbers A, B, got {s!r}"
                ) from None
            if not (math.isfinite(a) and math.isfinite(b) and a > 0 and b > 0):
                raise ValueError(f"ellipse semi-axes must be positive and finite, got {s!r}")
            return M.ellipse_polygon(a, b, 256)
        if s.startswith("polygon:"):
            return M.load_polygon_csv(s[len("polygon:") :])
        raise ValueError(f"shape must be circle, ellipse:A,B or polygon:FILE.csv, got {s!r}")


def initial_boundary(config: ContinuumConfig) -> np.ndarray:
    """The initial boundary polygon of the configured shape (dense, counter-clockwise)."""
    return config._shape_polygon()


@dataclass
class ContinuumState:
    """State of a continuum colony at time t.

    Attributes
    ----------
    points : (N, 2) node positions; triangles : (M, 3) counter-clockwise triangles.
    fields : dict of nodal fields p (N,), u (N, 2), G (N,) (growth phase),
        mean_length = 2^frac(G/ln 2) (N,): the exact mean length for the model's initial
        Psi0 = delta(l - 1) (model.md), what the figures show;
        mean_length_psi, number, total_length (N,): moments of the transported size
        distribution Psi (started from the smooth bump of ``sizes.SizeDistribution.bump``;
        number and total length per current area). The bump smears over many divisions
        (finite volumes in l), so mean_length_psi is the smoother of the two.
    t : time; boundary : (K, 2) boundary polygon (the nodes 0..K-1); history : per-step rows.
    timings : accumulated seconds per stage.
    finished : False when the run stopped early (``max_steps_this_call``) and can be resumed.
    """

    points: np.ndarray
    triangles: np.ndarray
    fields: dict
    t: float
    boundary: np.ndarray
    history: list = field(default_factory=list)
    timings: dict = field(default_factory=dict)
    finished: bool = True

    def sample(self, xy: np.ndarray) -> dict:
        """P1 interpolation of every field at the points xy (P, 2); NaN outside the domain."""
        loc = Locator(self.points, self.triangles)
        tri, bary, inside = loc.locate(np.asarray(xy, dtype=float))
        nodes = self.triangles[tri]
        out = {}
        for name, f in self.fields.items():
            v = np.einsum("pi,pi...->p...", bary, np.asarray(f)[nodes])
            v[~inside] = np.nan
            out[name] = v
        return out


class _Colony:
    """Mutable solver state: mesh, fields and the pressure solver (one run).

    ``snapshot`` returns everything that determines the following steps, and
    ``_Colony(config, snapshot)`` continues from it exactly as this object would.
    """

    SCALARS = ("t", "nb", "n_remesh", "newton", "krylov", "h_mesh", "hmean_mesh", "dt_prev")
    ARRAYS = ("points", "tris", "G", "p", "u", "g")

    def __init__(self, config: ContinuumConfig, snapshot: tuple[dict, dict] | None = None):
        self.cfg = config
        self.solver = PressureSolver(config.lam)
        self.grid = LengthGrid(config.n_length_cells)
        if snapshot is not None:
            self._restore(*snapshot)
            return
        self.t = 0.0
        self.n_remesh = 0
        self.timings = dict.fromkeys(
            ("meshing", "assembly", "amg_setup", "krylov", "remeshing", "transport"), 0.0
        )
        self.newton = 0
        self.krylov = 0
        dense = initial_boundary(config)
        h = self.h_target(abs(M.polygon_area(dense)))
        bnd = M.resample_polygon(dense, spacing=h, min_points=16)
        self._mesh(bnd, h)
        n = len(self.points)
        self.G = np.zeros(n)
        self.sizes = SizeDistribution.bump(self.grid, n, width=config.bump_width)
        self.p = np.zeros(n)
        self.p_prev, self.dt_prev = None, 1.0
        self.solve_here()

    # ------------------------------------------------------------------ checkpoints
    def snapshot(self) -> tuple[dict, dict]:
        """(scalars, arrays) of the state: mesh, fields, Psi, warm start, AMG matrix, counters.

        ``timings`` (wall seconds) is included so that a resumed run keeps accumulating.
        """
        scalars = {name: getattr(self, name) for name in self.SCALARS}
        scalars["timings"] = dict(self.timings)
        arrays = {name: getattr(self, name) for name in self.ARRAYS}
        arrays["psi"] = self.sizes.n
        if self.p_prev is not None:
            arrays["p_prev"] = self.p_prev
        amg = self.solver.amg_state()
        if amg is not None:
            arrays["amg"] = amg
        return scalars, arrays

    def _restore(self, scalars: dict, arrays: dict) -> None:
        """Set the state from ``snapshot()`` output (the pressure solver's AMG rebuilt)."""
        for name in self.SCALARS:
            setattr(self, name, scalars[name])
        self.timings = dict(scalars["timings"])
        for name in self.ARRAYS:
            setattr(self, name, np.array(arrays[name]))
        self.sizes = SizeDistribution(self.grid, arrays["psi"])
        self.p_prev = np.array(arrays["p_prev"]) if "p_prev" in arrays else None
        self.solver.set_mesh(self.tris, len(self.points), self.nb)
        self.solver.restore_amg(arrays.get("amg"))

    # ------------------------------------------------------------------ helpers
    def h_target(self, area: float) -> float:
        """Boundary mesh size min(h_max, h_N(area))."""
        return min(self.cfg.h_max, M.h_for_nodes(area, self.cfg.n_nodes))

    @property
    def area(self) -> float:
        return M.polygon_area(self.points[: self.nb])

    def where(self) -> str:
        return f"t={self.t:.6g}, area={self.area:.6g}"

    def _mesh(self, bnd: np.ndarray, h: float) -> None:
        t0 = _time.perf_counter()
        c = self.cfg.interior_coarsening
        self.points, self.tris = M.triangulate(
            bnd, h, h_interior=c * h if c > 1 else None, grading=self.cfg.grading
        )
        self.nb = len(bnd)
        self.solver.set_mesh(self.tris, len(self.points), self.nb)
        self.h_mesh = h
        self.hmean_mesh = float(
            np.sqrt(4.0 * np.mean(M.triangle_areas(self.points, self.tris)) / np.sqrt(3.0))
        )
        self.timings["meshing"] += _time.perf_counter() - t0

    def _solve(self, points: np.ndarray, p0: np.ndarray):
        """Pressure, velocity and growth rate at these node positions."""
        p = self.solver.solve(points, p0, where=self.where())
        st = self.solver.stats
        self.timings["assembly"] += st.time_assembly
        self.timings["amg_setup"] += st.time_amg
        self.timings["krylov"] += st.time_krylov
        self.newton += st.newton_iterations
        self.krylov += st.krylov_iterations
        t0 = _time.perf_counter()
        last = self.solver.last
        u = nodal_velocity(
            self.solver.assembler, points, p, last["residual"], (last["area"], last["grads"])
        )
        self.timings["assembly"] += _time.perf_counter() - t0
        return p, u, last["g"]

    def solve_here(self) -> None:
        self.p, self.u, self.g = self._solve(self.points, self.p)

    # ------------------------------------------------------------------ remeshing
    def maybe_remesh(self) -> str | None:
        h = self.h_target(self.area)
        reason = remesh_reason(
            self.points,
            self.tris,
            self.nb,
            h,
            self.cfg.q_min,
            self.cfg.stretch,
            mean_h_target=self.hmean_mesh * h / self.h_mesh,
        )
        if reason is not None:
            self.remesh(h)
        return reason

    def remesh(self, h: float) -> None:
        """New mesh of the current domain; G, Psi and p transferred (gradient-corrected)."""
        old_points, old_assembler = self.points, self.solver.assembler
        bnd = M.resample_polygon(old_points[: self.nb], spacing=h, min_points=16)
        self._mesh(bnd, h)
        t0 = _time.perf_counter()
        W = gradient_corrected_matrix(
            Locator(old_points, old_assembler.tris), old_assembler, self.points
        )
        G_old = self.G
        self.G = W @ G_old
        dens = self.sizes.transfer(W.multiply(np.exp(-G_old)[None, :]).tocsr())
        dens.n *= np.exp(self.G)[:, None]
        np.maximum(dens.n, 0.0, out=dens.n)
        self.sizes = dens
        p0 = W @ self.p
        self.timings["remeshing"] += _time.perf_counter() - t0
        self.n_remesh += 1
        self.p, self.p_prev = p0, None
        self.solve_here()

    # ------------------------------------------------------------------ stepping
    def radius_rate(self) -> float:
        """dR/dt with R = sqrt(A/pi): dA/dt = sum over boundary of u.n L (exact flux sum)."""
        from continuum.velocity import boundary_normals

        n, L = boundary_normals(self.points[: self.nb])
        dA = float(np.sum(np.sum(self.u[: self.nb] * n, axis=1) * L))
        R = math.sqrt(self.area / math.pi)
        return dA / (2 * math.pi * R)

    def step(self, dt: float) -> float:
        """One Heun step of size dt (halved while elements invert); returns the dt taken.

        The predictor's pressure solve is warm-started from the linear extrapolation in time of
        the nodal pressure, p^n + (p^n - p^{n-1}) dt / dt_prev (same topology only).
        """
        for _ in range(6):
            x1 = self.points + dt * self.u
            guess = self.p
            if self.p_prev is not None:
                guess = self.p + (self.p - self.p_prev) * (dt / self.dt_prev)
            if np.all(M.triangle_areas(x1, self.tris) > 0):
                try:
                    p1, u1, g1 = self._solve(x1, guess)
                except PressureDivergence:
                    if self.cfg.lam < 0:
                        raise
                    dt *= 0.5
                    continue
                x2 = self.points + 0.5 * dt * (self.u + u1)
                if np.all(M.triangle_areas(x2, self.tris) > 0):
                    break
            dt *= 0.5
        else:
            raise PressureDivergence(f"mesh elements invert even for tiny steps at {self.where()}")
        t0 = _time.perf_counter()
        g_avg = 0.5 * (self.g + g1)
        self.points = x2
        self.G = self.G + dt * g_avg
        self.sizes.advance(g_avg, dt)
        self.timings["transport"] += _time.perf_counter() - t0
        self.t += dt
        self.p_prev, self.dt_prev = self.p, dt
        self.p = p1
        self.solve_here()
        return dt

    # ------------------------------------------------------------------ output
    def state_fields(self) -> dict:
        stretch = np.exp(-self.G)
        number = self.sizes.number()
        total = self.sizes.total_length()
        q = self.G / LN2
        return {
            "p": self.p.copy(),
            "u": self.u.copy(),
            "G": self.G.copy(),
            "mean_length": 2.0 ** (q - np.floor(q)),
            "mean_length_psi": total / number,
            "number": number * stretch,
            "total_length": total * stretch,
        }

    def history_row(self, dt: float, reason: str | None) -> dict:
        area = self.area
        return {
            "t": self.t,
            "radius": math.sqrt(area / math.pi),
            "area": area,
            "max_pressure": float(self.p.max()),
            "n_nodes": len(self.points),
            "n_boundary": self.nb,
            "n_remesh": self.n_remesh,
            "dt": dt,
            "h": self.h_mesh,
            "min_quality": float(M.triangle_quality(self.points, self.tris).min()),
            "newton_iterations": self.newton,
            "krylov_iterations": self.krylov,
            "remesh": {None: 0, "quality": 1, "boundary": 2, "size": 3}[reason],
        }

    def state(self, history: list, finished: bool = True) -> ContinuumState:
        return ContinuumState(
            points=self.points.copy(),
            triangles=self.tris.copy(),
            fields=self.state_fields(),
            t=self.t,
            boundary=self.points[: self.nb].copy(),
            history=list(history),
            timings=dict(self.timings),
            finished=finished,
        )


EXECUTION_FIELDS = ("checkpoint_seconds",)
"""Configuration fields that do not change the result: a checkpoint resumes whatever they are."""

CHECKPOINT = "checkpoint.npz"
"""File name of the checkpoint in the run folder."""


def _step_dt(col: _Colony, config: ContinuumConfig) -> tuple[float, bool]:
    """dt of the next step, the stable one (``stable_dt``) shortened to land on the goal.

    Returns (dt, last): ``last`` is True when the step is meant to reach the goal (radius R:
    R + dt dR/dt >= R_goal; time: t + dt >= T).
    """
    dt = stable_dt(col.points[: col.nb], col.u[: col.nb], config.courant)
    if config.radius is not None:
        R, Rdot = math.sqrt(col.area / math.pi), col.radius_rate()
        if R + dt * Rdot >= config.radius:
            return max((config.radius - R) / max(Rdot, 1e-300), 1e-14), True
    elif col.t + dt >= config.time * (1 - 1e-12):
        return config.time - col.t, True
    return dt, False


def _advance(col: _Colony, config: ContinuumConfig) -> tuple[dict, bool]:
    """One step of a run: remesh if due, then a Heun step; returns (history row, goal reached)."""
    reason = col.maybe_remesh()
    if reason is not None:
        log.debug("remeshed at t = %.6g (%s): %d nodes", col.t, reason, len(col.points))
    dt, last = _step_dt(col, config)
    dt = col.step(dt)
    row = col.history_row(dt, reason)
    if config.radius is not None:
        return row, row["radius"] >= config.radius * (1 - 1e-7)
    return row, last and col.t >= config.time * (1 - 1e-12)


def _save_checkpoint(
    path: Path, config: ContinuumConfig, col: _Colony, history: list, frames: list,
    next_frame: float, done: bool,
) -> None:
    """Write the run's state (``_Colony.snapshot``, history, VTU frame list, next frame time,
    configuration) to ``path`` atomically: a temporary file, then ``os.replace``."""
    scalars, arrays = col.snapshot()
    meta = {"config": asdict(config), "colony": scalars, "history": history,
            "frames": frames, "next_frame": next_frame, "done": done}
    tmp = path.with_name(path.name + ".tmp.npz")
    try:
        np.savez(tmp, meta=np.array(json.dumps(meta)), **arrays)
        os.replace(tmp, path)
    finally:  # a failed write (e.g. a full disk) leaves the previous checkpoint as it was
        tmp.unlink(missing_ok=True)
    log.debug("checkpoint at t = %.6g written to %s", col.t, path)


def _check_resumable(path: Path, saved: dict, config: ContinuumConfig) -> None:
    """ValueError unless the saved configuration equals ``config`` up to EXECUTION_FIELDS."""
    now = json.loads(json.dumps(asdict(config)))
    wrong = sorted(
        k for k in {*saved, *now} if k not in EXECUTION_FIELDS and saved.get(k) != now.get(k)
    )
    if wrong:
        raise ValueError(
            f"checkpoint {path} belongs to a different configuration (differs in "
            f"{', '.join(wrong)}); delete it, or use another output folder, to start afresh"
        )


def _load_checkpoint(path: Path, config: ContinuumConfig) -> tuple:
    """(colony, history, frames, next_frame, done) saved by ``_save_checkpoint`` at ``path``."""
    with np.load(path) as z:
        meta = json.loads(str(z["meta"]))
        _check_resumable(path, meta["config"], config)
        arrays = {k: z[k] for k in z.files if k != "meta"}
    col = _Colony(config, (meta["colony"], arrays))
    frames = [(t, name) for t, name in meta["frames"]]
    return col, meta["history"], frames, meta["next_frame"], meta["done"]


def _remove_later_frames(out: Path, frames: list) -> None:
    """Delete the VTU frames ``fields/frame_*.vtu`` that are not in ``frames``: those the run
    wrote after its checkpoint (a resumed run writes them again)."""
    keep = {name for _, name in frames}
    for path in sorted((out / "fields").glob("frame_*.vtu")):
        if f"fields/{path.name}" not in keep:
            path.unlink()


class _StopRequest:
    """SIGINT / SIGTERM deferred to the end of the current step (main thread only).

    ``install`` replaces the handlers; the first signal sets ``signum`` and puts the previous
    handlers back, so the run can finish its step and write a checkpoint, while a second signal
    acts at once. ``restore`` puts them back. (The twin of particles.simulation._StopRequest:
    the two engines do not import each other.)
    """

    def __init__(self):
        self.signum = None
        self._previous = {}

    def install(self) -> _StopRequest:
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def _handle(self, signum, frame):
        self.signum = signum
        self.restore()

    def restore(self) -> None:
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        self._previous = {}

    def act(self) -> None:
        """Raise for the signal received: KeyboardInterrupt (SIGINT), SystemExit(128 + signum)."""
        if self.signum == signal.SIGINT:
            raise KeyboardInterrupt
        if self.signum is not None:
            raise SystemExit(128 + self.signum)


def _start(config: ContinuumConfig, out: Path | None, writer) -> tuple:
    """(colony, history, next_frame, done): from ``out``'s checkpoint if there is one (the
    frames written after it removed, the writer's frame list restored), else afresh (writing
    config.json and the first frame)."""
    from continuum import output

    ckpt = None if out is None else out / CHECKPOINT
    if ckpt is not None and ckpt.exists():
        col, history, frames, next_frame, done = _load_checkpoint(ckpt, config)
        log.info("resuming from %s at t = %.6g (step %d)", ckpt, col.t, len(history) - 1)
        if writer is not None:
            writer.frames = frames
            _remove_later_frames(out, frames)
        return col, history, next_frame, done
    check_memory(config)
    if out is not None:
        output.write_config(out, config)
    col = _Colony(config)
    history = [col.history_row(0.0, None)]
    if writer is not None:
        writer.write(col.t, col.points, col.tris, col.state_fields())
    return col, history, config.output_every if config.output_every > 0 else math.inf, False


def run(
    config: ContinuumConfig,
    out: Path | None = None,
    progress: bool = False,
    max_steps_this_call: int | None = None,
) -> ContinuumState:
    """Grow the colony until ``config.radius`` or ``config.time``; optionally write ``out``.

    Parameters
    ----------
    config : ContinuumConfig
    out : Path, optional
        Existing folder: config.json, history.csv, boundary.csv, fields.pvd + fields/, and
        checkpoint.npz every ``config.checkpoint_seconds``. If it holds a checkpoint of the
        same configuration (up to EXECUTION_FIELDS) the run resumes from it, with a result
        bit-identical to an uninterrupted run's (files and arrays). The caller removes
        checkpoint.npz after a finished run.
    progress : bool
        Show a tqdm progress bar (only when stderr is a terminal).
    max_steps_this_call : int, optional
        Stop after this many steps of this call, writing a checkpoint (as if interrupted);
        the returned state has ``finished = False``.

    SIGINT or SIGTERM in the main thread ends the run after the current step (remeshing and
    output included) with a checkpoint of that step, then raises KeyboardInterrupt (SIGINT) or
    SystemExit(128 + signum) (SIGTERM); a second signal acts at once.

    Raises
    ------
    ValueError
        Bad configuration, or a checkpoint of another configuration in ``out``.
    PressureDivergence
        No pressure solution (e.g. lam < 0 beyond the critical size).
    """
    from continuum import output

    config.validate()
    limit_blas_threads(1)
    writer = None
    if out is not None:
        out = Path(out)
        if not out.is_dir():
            raise ValueError(f"output folder does not exist: {out}")
        if config.write_fields:
            writer = output.FieldWriter(out)
    stop = _StopRequest().install()
    try:
        state = _steps(config, out, writer, progress, max_steps_this_call, stop)
    finally:
        stop.restore()
    stop.act()
    return state


def _steps(
    config: ContinuumConfig, out: Path | None, writer, progress: bool,
    max_steps_this_call: int | None, stop: _StopRequest,
) -> ContinuumState:
    """The body of ``run``: start or resume (``_start``), step until the goal, a stop request
    or ``max_steps_this_call`` steps, write checkpoints and, at the goal, the final outputs."""
    from tqdm import tqdm

    from continuum import output

    col, history, next_frame, done = _start(config, out, writer)
    by_radius = config.radius is not None
    goal = config.radius if by_radius else config.time
    start = history[0]["radius"] if by_radius else 0.0
    bar = tqdm(
        total=round(goal - start, 6),
        disable=not (progress and sys.stderr.isatty()),
        unit="R" if by_radius else "t",
        leave=False,
    )
    last_checkpoint = _time.monotonic()
    steps_here = 0
    try:
        while not done:
            if len(history) > config.max_steps:
                raise RuntimeError(f"max_steps={config.max_steps} reached at {col.where()}")
            try:
                row, done = _advance(col, config)
            except PressureDivergence:
                if out is not None:  # keep the history up to the failure for diagnosis
                    output.write_history(out, history)
                raise
            history.append(row)
            steps_here += 1
            bar.update(round((row["radius"] if by_radius else col.t) - start, 6) - bar.n)
            if writer is not None and (col.t >= next_frame) and not done:
                writer.write(col.t, col.points, col.tris, col.state_fields())
                next_frame += config.output_every
            pause = not done and max_steps_this_call is not None
            pause = pause and steps_here >= max_steps_this_call
            due = not done and _time.monotonic() - last_checkpoint >= config.checkpoint_seconds
            if out is not None and (stop.signum is not None or pause or due):
                frames = [] if writer is None else writer.frames
                _save_checkpoint(out / CHECKPOINT, config, col, history, frames, next_frame, done)
                output.write_history(out, history)
                last_checkpoint = _time.monotonic()
            if stop.signum is not None or pause:
                break
    finally:
        bar.close()
    state = col.state(history, finished=done)
    if out is not None and done:
        output.write_history(out, history)
        output.write_boundary(out, state.boundary)
        if writer is not None:
            writer.write(col.t, col.points, col.tris, state.fields)
    return state


def config_fields() -> list[str]:
    """Names of the ContinuumConfig fields (for the command line)."""
    return [f.name for f in fields(ContinuumConfig)]
