"""Non-radial colonies in both models: the same initial shapes grown by both engines.

``colony case shapes [--scale smoke|medium|paper]`` (issue 16, "Cross-check and stability
cases"). For each shape of the scale, at one lam (``LAM`` = 1e-2), both engines start from the
same outline and grow for the same time ``t_end``:

- ``ellipse`` 2:1 (``ellipse:A,A/2``), ``rectangle`` 4:1 (``rectangle:2A,A/2,A/8``, corners
  rounded), ``star3`` and ``star5`` (``star:K,0.2,A``): the continuum from
  continuum.shapes.outline, the particles from its fill (cases.shapes.initial_particles) with
  ``fill_lengths = "birth"`` (every rod at l = 1: like for like with the continuum's narrow bump
  of Psi0 at l = 1, so both start synchronised);
- ``line``: the particles ``line:N`` (N cells of length 1 end to end, width b); the continuum
  cannot take a polygon of width b at its mesh spacing, so it starts from the rounded rectangle
  ``rectangle:N,2b,b/2`` of the same length and twice the width (area 2 N b, twice the line's;
  its aspect ratio N / 2b against the line's about N / b): the closest outline the mesh holds;
- ``handoff``: a particle colony grown from one cell to the enclosing radius ``handoff_radius``
  (lam the same), then continued from its last frame in both models: the continuum by the
  hand-off of cases.handoff (alpha-shape outline, kernel-smoothed Psi0; ``colony continuum
  --from-particles``), the particles by their own run started from that frame (its
  x, y, theta, length as the ``init`` CSV: ``colony particles --init``); both at t = 0 there.

All runs go through :func:`cases.sweep.sweep` (``run_shape``, which is
:func:`cases.sweep.run_engine` for the plain runs), so ``--runs DIR`` reuses finished ones.

Reductions, per frame of each run (continuum: the boundary of the VTU frame's mesh, traced from
its triangles; particles: the alpha shape of the rods, cases.handoff.particle_outline): the area
and the aspect ratio of the region (cases.handoff.polygon_moments: sqrt of the ratio of the
principal second moments of area), and the relative amplitudes ``abs(r_K) / r_0`` of modes
K = 2..6 of the boundary radius about the area centroid
(:func:`radius_modes`, cases.studies.stability.mode_amplitude with r(theta) interpolated
linearly, of :func:`radial_outline`: the notches where a particle
outline turns back by a few hundredths of a radian are dropped; nan where it turns back by more
than ``BACK_STEP`` = 0.05 rad in total, e.g. a buckled line, whose r(theta) is not a function).
Rings: the contours G = k ln 2 of the continuum's last frame
(their count and mean radii, continuum.rings via cases.analysis.continuum_rings); the particles'
length pattern is left out (at these radii, a few cell lengths, a radial length profile has too
few cells per annulus to show a ring).

Outputs in ``out/data``: ``shape_NAME.csv`` (engine 0 continuum / 1 particles, t, area, aspect,
mode2..mode6), ``outlines_NAME.csv`` (engine, t, x, y: both outlines at the first, middle and
last matched frame), ``rings_NAME.csv`` (the continuum's final ring table),
``differences.csv`` (shape, t, both areas, relative area difference, aspect ratios and their
difference, the mode differences; particles minus continuum at the continuum's frame times, the
particle series interpolated linearly in t) and, from :func:`plot`, ``results.md`` and
``shapes.png`` / ``.pdf``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from cases import analysis as A
from cases.handoff import (
    _boundary_loops,
    continuum_start,
    final_particles,
    particle_outline,
    polygon_moments,
)
from cases.studies.stability import area_centroid
from cases.sweep import is_done, local_cluster, run_engine, run_name, sweep
from continuum.mesh import polygon_area
from particles import B

__all__ = ["SCALES", "LAM", "MODES", "shape_specs", "run_shape", "mesh_boundary",
           "radial_outline", "radius_modes", "outline_measures", "reduce_pair", "differences",
           "compute", "markdown_table", "plot"]

LAM = 1e-2
"""Stress sensitivity of every run of the case."""
MODES = (2, 3, 4, 5, 6)
"""Fourier modes of the boundary radius that are measured."""

#: size: A of the ellipse (semi-axes A, A/2; 2A x A/2 the rectangle, R = A the stars);
#: line_cells: N of the line; handoff_radius: the particle colony handed over; t_end: the time
#: both engines grow from the initial shape; frames: output interval in t.
SCALES = {
    "smoke": dict(size=3.0, line_cells=4, handoff_radius=2.0, t_end=0.4, frame_dt=0.2,
                  n_nodes=200),
    "medium": dict(size=7.0, line_cells=12, handoff_radius=6.0, t_end=2.5, frame_dt=0.25,
                   n_nodes=1500),
    "paper": dict(size=8.0, line_cells=16, handoff_radius=8.0, t_end=4.0, frame_dt=0.25,
                  n_nodes=3000),
}
DT = 0.01
"""Particle time step, the largest one (the default "overlap" control may shorten steps): a
particle frame every frame_dt; the reductions interpolate the
particle series at the continuum's frame times.  The committed data were made with it."""


def shape_specs(cfg: dict) -> dict[str, tuple[str, str | None]]:
    """{name: (continuum shape, particle shape)} of a scale; ``handoff`` has no spec (None)."""
    a = cfg["size"]
    n = cfg["line_cells"]
    rect = f"rectangle:{2 * a:g},{a / 2:g},{a / 8:g}"
    return {
        "ellipse": (f"ellipse:{a:g},{a / 2:g}",) * 2,
        "rectangle": (rect, rect),
        "star3": (f"star:3,0.2,{a:g}",) * 2,
        "star5": (f"star:5,0.2,{a:g}",) * 2,
        "line": (f"rectangle:{n:g},{2 * B:g},{B / 2:g}", f"line:{n:d}"),
        "handoff": (None, None),
    }


def _continuum(cfg: dict, **extra) -> dict:
    return {"engine": "continuum", "lam": LAM, "time": cfg["t_end"],
            "output_every": cfg["frame_dt"], "n_nodes": cfg["n_nodes"], **extra}


def _particles(cfg: dict, **extra) -> dict:
    return {"engine": "particles", "lam": LAM, "time": cfg["t_end"],
            "output_every": cfg["frame_dt"], "dt": DT, **extra}


def run_params(cfg: dict) -> tuple[dict[str, tuple[dict, dict]], dict]:
    """({shape: (continuum params, particle params)}, params of the hand-off's particle seed).

    The hand-off pair names its source run by ``from_run`` (its folder name under the root).
    """
    pairs = {}
    for name, (cspec, pspec) in shape_specs(cfg).items():
        if name == "handoff":
            continue
        extra = {"fill_lengths": "birth"} if not pspec.startswith("line") else {}
        pairs[name] = (_continuum(cfg, shape=cspec), _particles(cfg, shape=pspec, **extra))
    seed = {"engine": "particles", "lam": LAM, "radius": cfg["handoff_radius"],
            "output_every": cfg["frame_dt"], "dt": DT}
    source = run_name(seed)
    pairs["handoff"] = (_continuum(cfg, from_run=source), _particles(cfg, from_run=source))
    return pairs, seed


def run_shape(params: dict, folder: Path) -> None:
    """Sweep ``run_fn`` of the case: :func:`cases.sweep.run_engine`, or a continued hand-off.

    ``from_run`` NAME (a finished particle run in the same root as ``folder``): the continuum
    starts from its last frame by cases.handoff.continuum_start (handoff.json and outline.csv
    written into the run), the particles from the same frame as their ``init`` CSV
    (``NAME.init.csv`` beside the run folder). Every run is the command line's (cases.runs).
    """
    from cases import runs

    params = dict(params)
    source = params.pop("from_run", None)
    if source is None:
        run_engine(params, folder)
        return
    folder = Path(folder)
    src = folder.parent / source
    engine = params.pop("engine")
    if engine == "continuum":
        from continuum import Config

        config = Config(**params, initial_sizes="histogram")  # Psi0: the particles' histogram
        runs.run_continuum(config, folder, progress=False, start=continuum_start(src, config))
        return
    frame = final_particles(src)
    init = folder.with_name(folder.name + ".init.csv")
    np.savetxt(init, np.column_stack([frame.x, frame.y, frame.theta, frame.length]),
               delimiter=",", header="x,y,theta,length", comments="", fmt="%.17g")
    run_engine({"engine": engine, **params, "init": str(init.resolve())}, folder)


run_shape.stages_itself = True


def mesh_boundary(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """The outer boundary of a triangulated region, counter-clockwise (the loop of largest area)."""
    loops = _boundary_loops(points, triangles)
    return points[max(loops, key=lambda q: abs(polygon_area(points[q])))]


BACK_STEP = 0.05
"""Largest total back-step (radians) of an outline's polar angle for its modes to be measured."""


def radial_outline(outline: np.ndarray, back_step: float = BACK_STEP) -> np.ndarray | None:
    """The vertices of an outline along which the polar angle about its centroid increases.

    Walking the counter-clockwise outline from its farthest vertex, a vertex is kept when the
    angle turned so far (unwrapped, below 2 pi) exceeds that of the last kept one; the dropped
    vertices are the small notches where the boundary turns back (the rods' caps of a particle
    outline). None when the angles turned back by more than ``back_step`` in total (a bay, a
    buckled line): the radius r(theta) of the outline is then not a function.
    """
    d = outline - area_centroid(outline)
    th = np.arctan2(d[:, 1], d[:, 0])
    step = (np.diff(np.append(th, th[0])) + np.pi) % (2 * np.pi) - np.pi
    if -step[step < 0].sum() > back_step:
        return None
    start = int(np.argmax(np.hypot(d[:, 0], d[:, 1])))
    order = np.roll(np.arange(len(outline)), -start)
    turned = np.concatenate([[0.0], np.cumsum(np.roll(step, -start)[:-1])])  # unwrapped angle
    keep = [0]
    for i in range(1, len(order)):
        if turned[keep[-1]] < turned[i] < 2 * np.pi:
            keep.append(i)
    return outline[order[keep]]


def radius_modes(outline: np.ndarray, modes=MODES, n_samples: int = 4096) -> list[float]:
    """Relative amplitudes abs(r_K) / r_0 of the boundary radius about the area centroid.

    The definition of cases.studies.stability.mode_amplitude, with r(theta) interpolated
    linearly (periodic) between the vertices instead of by a cubic spline: a particle outline
    has pieces where r changes steeply with theta (the sides of rods pointing outwards), where a
    spline overshoots. For a smooth, finely sampled outline both agree to O(h^2).
    """
    d = outline - area_centroid(outline)
    th = np.mod(np.arctan2(d[:, 1], d[:, 0]), 2.0 * np.pi)
    order = np.argsort(th)
    r = np.hypot(d[order, 0], d[order, 1])
    grid = 2 * np.pi * np.arange(n_samples) / n_samples
    c = np.fft.rfft(np.interp(grid, th[order], r, period=2 * np.pi)) / n_samples
    return [float(2.0 * abs(c[k]) / abs(c[0])) for k in modes]


def outline_measures(outline: np.ndarray) -> dict[str, float]:
    """area, aspect (cases.handoff.polygon_moments) and modeK (mode_amplitude) of an outline.

    The modes are :func:`radius_modes` of :func:`radial_outline` (nan where it is None).
    """
    area, aspect = polygon_moments(outline)
    row = {"area": area, "aspect": aspect}
    radial = radial_outline(outline)
    amps = radius_modes(radial) if radial is not None else [math.nan] * len(MODES)
    return row | {f"mode{k}": a for k, a in zip(MODES, amps, strict=True)}


def _continuum_series(folder: Path):
    for t, path in A.continuum_frames(folder):
        pts, tri, _ = A.read_continuum_frame(path)
        yield t, mesh_boundary(pts, tri)


def _particle_series(folder: Path):
    for t, fr in A.particle_frames(folder):
        yield t, particle_outline(fr["x"], fr["y"], fr["theta"], fr["length"])


COLUMNS = ("engine", "t", "area", "aspect", *(f"mode{k}" for k in MODES))


def reduce_pair(continuum_dir: Path, particle_dir: Path, data: Path, name: str) -> None:
    """shape_NAME.csv, outlines_NAME.csv and rings_NAME.csv of one shape's two runs."""
    rows = {k: [] for k in COLUMNS}
    outlines = {k: [] for k in ("engine", "t", "x", "y")}
    for engine, series in ((0, _continuum_series(continuum_dir)),
                           (1, _particle_series(particle_dir))):
        frames = list(series)
        ts = [t for t, _ in frames]
        keep = {0, len(frames) // 2, len(frames) - 1}
        for i, (t, outline) in enumerate(frames):
            row = {"engine": engine, "t": t, **outline_measures(outline)}
            for k in COLUMNS:
                rows[k].append(row[k])
            if i in keep:
                for key, v in (("engine", engine), ("t", ts[i])):
                    outlines[key].extend([v] * len(outline))
                outlines["x"].extend(outline[:, 0])
                outlines["y"].extend(outline[:, 1])
    A.write_csv(data / f"shape_{name}.csv", {k: np.asarray(v, float) for k, v in rows.items()})
    A.write_csv(data / f"outlines_{name}.csv",
                {k: np.asarray(v, float) for k, v in outlines.items()}, fmt="%.5g")
    rings = A.continuum_rings(continuum_dir)
    A.write_csv(data / f"rings_{name}.csv", {k: np.asarray(v, float) for k, v in rings.items()})


def differences(data: Path, names: list[str]) -> dict[str, np.ndarray]:
    """Particles minus continuum of every shape at the continuum's frame times (module doc)."""
    out: dict[str, list] = {k: [] for k in (
        "shape", "t", "area_continuum", "area_particles", "area_rel", "aspect_continuum",
        "aspect_particles", "aspect", *(f"mode{k}" for k in MODES))}
    for i, name in enumerate(names):
        s = A.read_csv(data / f"shape_{name}.csv")
        c, p = s["engine"] == 0, s["engine"] == 1
        tc = s["t"][c]
        ok = tc <= s["t"][p].max() + 1e-9
        tc = tc[ok]

        def at(col, tc=tc, s=s, p=p):
            return np.interp(tc, s["t"][p], s[col][p])

        out["shape"].extend([i] * len(tc))
        out["t"].extend(tc)
        ac, ap = s["area"][c][ok], at("area")
        out["area_continuum"].extend(ac)
        out["area_particles"].extend(ap)
        out["area_rel"].extend(ap / ac - 1.0)
        out["aspect_continuum"].extend(s["aspect"][c][ok])
        out["aspect_particles"].extend(at("aspect"))
        out["aspect"].extend(at("aspect") - s["aspect"][c][ok])
        for k in MODES:
            out[f"mode{k}"].extend(at(f"mode{k}") - s[f"mode{k}"][c][ok])
    return {k: np.asarray(v, float) for k, v in out.items()}


def compute(scale: str = "smoke", out: str | Path = "runs/case-shapes-smoke",
            scheduler: str | None = None, n_workers: int = 2, runs: str | Path | None = None,
            engines: tuple[str, ...] = ("continuum", "particles"),
            finished_only: tuple[str, ...] = ()) -> Path:
    """Run (or reuse under ``runs``, default out/runs) every pair of ``scale`` and reduce them.

    Two sweeps: the plain pairs with the hand-off's particle seed, then the hand-off pair.
    Both engines are needed (``engines`` must hold both; ``finished_only`` is not used).
    """
    if scale not in SCALES:
        raise ValueError(f"scale must be one of {', '.join(SCALES)}, got {scale!r}")
    if set(engines) != {"continuum", "particles"}:
        raise ValueError("the shapes case compares both engines: --engines both")
    cfg = SCALES[scale]
    out = Path(out)
    root = Path(runs) if runs is not None else out / "runs"
    pairs, seed = run_params(cfg)
    plain = [p for name, pair in pairs.items() if name != "handoff" for p in pair]
    cluster = None
    if scheduler is None and not all(is_done(root / run_name(p), p)
                                     for p in [*plain, seed, *pairs["handoff"]]):
        cluster = local_cluster(n_workers)  # one cluster for both sweeps
        scheduler = cluster.scheduler_address
    try:
        folders = sweep(run_shape, [*plain, seed], root, scheduler=scheduler,
                        n_workers=n_workers)
        folders += sweep(run_shape, list(pairs["handoff"]), root, scheduler=scheduler,
                         n_workers=n_workers)
    finally:
        if cluster is not None:
            cluster.close()
    data = out / "data"
    data.mkdir(parents=True, exist_ok=True)
    names = list(pairs)
    plain_names = [n for n in names if n != "handoff"]
    for i, name in enumerate(plain_names):
        reduce_pair(folders[2 * i], folders[2 * i + 1], data, name)
    reduce_pair(folders[-2], folders[-1], data, "handoff")
    A.write_csv(data / "differences.csv", differences(data, names))
    (data / "shapes.json").write_text(json.dumps(
        {"scale": scale, "lam": LAM, "names": names,
         "specs": {n: list(s) for n, s in shape_specs(cfg).items()}, **cfg}, indent=2) + "\n")
    return data


#: The shapes whose own mode is drawn and tabulated beside the aspect ratio.
OWN_MODE = {"star3": "mode3", "star5": "mode5"}


def own_mode_rows(data: Path, names: list[str]) -> list[tuple]:
    """(shape, K, t_end, mode K at t = 0 and t_end of the continuum, of the particles)."""
    rows = []
    for name in names:
        if name not in OWN_MODE:
            continue
        col = OWN_MODE[name]
        s = A.read_csv(data / f"shape_{name}.csv")
        c, p = s["engine"] == 0, s["engine"] == 1
        rows.append((name, col[4:], f"{s['t'][c][-1]:.2f}",
                     *(f"{v:.4f}" for v in (s[col][c][0], s[col][c][-1], s[col][p][0],
                                            s[col][p][-1]))))
    return rows


def markdown_table(data: str | Path) -> str:
    """The differences at the first and last matched time of each shape, as a markdown table."""
    data = Path(data)
    meta = json.loads((data / "shapes.json").read_text())
    d = A.read_csv(data / "differences.csv")
    rows = []
    for i, name in enumerate(meta["names"]):
        sel = np.flatnonzero(d["shape"] == i)
        for j in (sel[0], sel[-1]):
            rows.append((name, f"{d['t'][j]:.2f}", f"{d['area_continuum'][j]:.1f}",
                         f"{100 * d['area_rel'][j]:+.1f}", f"{d['aspect_continuum'][j]:.2f}",
                         f"{d['aspect_particles'][j]:.2f}",
                         *(f"{d[f'mode{k}'][j]:+.3f}" for k in MODES)))
    head = ("shape", "t", "area (continuum)", "area diff %", "aspect (continuum)",
            "aspect (particles)", *(f"d mode {k}" for k in MODES))
    own = A.markdown_rows(("shape", "K", "t_end", "continuum t = 0", "continuum t_end",
                           "particles t = 0", "particles t_end"),
                          own_mode_rows(data, meta["names"]))
    return (f"lam = {meta['lam']:g}, scale {meta['scale']}; differences particles - continuum "
            "(area relative, modes absolute in relative amplitude abs(r_K)/r_0)\n\n"
            + A.markdown_rows(head, rows) + "\n\nThe stars' own mode abs(r_K)/r_0:\n\n"
            + own + "\n")


def plot(data: str | Path, out: str | Path) -> list[Path]:
    """results.md and shapes.png / .pdf from the CSVs of ``data``.

    One column per shape: the outlines of both models at the first, middle and last kept frame
    (continuum solid, particles dashed; darker = later), and below the aspect ratio against t
    (for the stars the amplitude of their own mode K instead).
    """
    import matplotlib.pyplot as plt

    from cases.figures.draw import save_figure

    data, out = Path(data), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "results.md").write_text(markdown_table(data))
    names = json.loads((data / "shapes.json").read_text())["names"]
    fig, axes = plt.subplots(2, len(names), figsize=(2.6 * len(names), 5.6),
                             gridspec_kw={"height_ratios": [1.3, 1]})
    for col, name in enumerate(names):
        ax, asp = axes[0, col], axes[1, col]
        o = A.read_csv(data / f"outlines_{name}.csv")
        for engine, style in ((0, "-"), (1, "--")):
            ts = np.unique(o["t"][o["engine"] == engine])
            for j, t in enumerate(ts):
                sel = (o["engine"] == engine) & (o["t"] == t)
                x, y = (np.append(o[k][sel], o[k][sel][0]) for k in ("x", "y"))
                c = plt.cm.viridis(0.8 * (1 - j / max(1, len(ts) - 1)))
                ax.plot(x, y, style, color=c, lw=1.0,
                        label=(("continuum" if engine == 0 else "particles") + f" t={t:.2g}"))
        ax.set_aspect("equal")
        ax.set_title(name, fontsize=9)
        ax.tick_params(labelsize=6)
        s = A.read_csv(data / f"shape_{name}.csv")
        column = OWN_MODE.get(name, "aspect")
        for engine, style, label in ((0, "-", "continuum"), (1, "--", "particles")):
            sel = s["engine"] == engine
            asp.plot(s["t"][sel], s[column][sel], style, label=label)
        asp.set_xlabel("t", fontsize=8)
        asp.set_ylabel("aspect ratio" if column == "aspect" else
                       rf"mode {column[4:]} $|r_K|/r_0$", fontsize=8)
        asp.tick_params(labelsize=6)
        if col == 0:
            asp.legend(fontsize=6)
            ax.legend(fontsize=5)
    fig.suptitle(rf"Shapes in both models, $\lambda$ = {LAM:g}: outlines (continuum solid, "
                 "particles dashed), aspect ratio or the star's own mode", fontsize=9)
    fig.tight_layout()
    return save_figure(fig, out / "shapes", dpi=100)
