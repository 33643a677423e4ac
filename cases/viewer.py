"""Pictures and movies of a finished run, redrawn from its saved outputs (nothing is rerun).

``plot_run(DIR)`` (``colony plot DIR``) and ``movie_run(DIR, OUT.mp4)`` (``colony movie DIR``)
read a run folder of either engine (docs/DESIGN.md, output contract):

- continuum: config.json, history.csv, fields.pvd + ``fields/*.vtu`` (point data G);
- particles: config.json, history.csv, trajectory.gsd (particles.csv for the final picture).

Particles are sphero-cylinders coloured by their length l, the continuum is its mean length
lbar = 2^frac(G / ln 2) with the domain boundary (a run handed over from particles,
``handoff.json``: the transported Psi's nodal mean_length_psi, as 2^frac(G / ln 2) holds for the
model's start only); both on the colour scale [1, 2] of the paper's
Fig 2 (cases.figures.draw.LENGTH_LIMITS).  The final pictures are those
``colony continuum|particles`` draws (cases.figures.draw, reused); R(t) comes from
history.csv.  Movie frames share one colour scale and the axis limits of the largest (last)
frame; the MP4 is written by imageio-ffmpeg (H.264, yuv420p, playable everywhere).

Every file read is checked before use (cases.analysis.io: a damaged trajectory, VTU frame or
CSV is refused with one line naming it). The pictures and the movie are written as the runs
write (:func:`_writing_into`): the lock of the folder they go into is held
(cases.rundir.hold: a run still writing into it is refused with one line), each file is made
in a temporary folder inside it and then replaces its namesake with ``os.replace``, which
replaces a symbolic link rather than writing through it, so no file is ever half-written and
nothing outside the output is touched.

``ovito_pipeline`` and ``render_ovito`` open a particle trajectory in OVITO's Python module (an
optional dependency) and render it headless.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import sys
import tempfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from cases import rundir  # noqa: E402
from cases.analysis import (  # noqa: E402
    DamagedFileError,
    check_colony,
    check_trajectory,
    continuum_frames,
    read_continuum_frame,
    read_csv,
    read_particle_frames,
)
from cases.figures.draw import (  # noqa: E402
    DEFAULT_CMAP,
    LENGTH_LIMITS,
    continuum_picture,
    draw_field,
    draw_mean_length,
    draw_particles,
    particles_picture,
)

__all__ = ["run_kind", "plot_run", "movie_run", "boundary_edges", "ovito_pipeline",
           "render_ovito"]

#: Files that make a folder a run of each engine.
REQUIRED = {"continuum": ("config.json", "history.csv", "fields.pvd"),
            "particles": ("config.json", "history.csv", "trajectory.gsd")}

#: Movie frame size in pixels (multiples of 16, the H.264 macro block).
MOVIE_SIZE = (720, 640)
#: Frames per second a movie may have (ffmpeg writes the rate with two decimals).
MOVIE_FPS = (0.1, 1000.0)
#: Most frames a movie may have (``max_frames``): an hour at 25 frames per second.
MAX_MOVIE_FRAMES = 90_000
#: What a movie file's name ends with (ffmpeg's container is chosen by it).
MOVIE_SUFFIX = ".mp4"


def run_kind(run_dir: str | Path) -> str:
    """'continuum' or 'particles' from the files in ``run_dir``; ValueError (one line) otherwise."""
    d = Path(run_dir)
    if not d.is_dir():
        raise ValueError(f"{d}: not a folder")
    kind = ("continuum" if (d / "fields.pvd").exists() else
            "particles" if (d / "trajectory.gsd").exists() else None)
    if kind is None:
        raise ValueError(f"{d}: not a run folder (neither fields.pvd nor trajectory.gsd)")
    missing = [f for f in REQUIRED[kind] if not (d / f).is_file()]
    if missing:
        raise ValueError(f"{d}: {kind} run folder without {', '.join(missing)}")
    return kind


def _lam(d: Path) -> float:
    try:
        return float(json.loads((d / "config.json").read_text())["lam"])
    except (ValueError, KeyError, TypeError) as e:
        raise ValueError(f"{d}: config.json unreadable or without lam ({e})") from None


def _continuum_frames(d: Path) -> list[tuple[float, Path]]:
    """The (t, VTU) frames fields.pvd lists (cases.analysis.continuum_frames), all present."""
    frames = continuum_frames(d)
    missing = [p.name for _, p in frames if not p.is_file()]
    if not frames or missing:
        raise ValueError(f"{d}: fields.pvd lists no frames or missing files "
                         f"({', '.join(missing[:3])})")
    return frames


def _continuum_field(vtu: Path, data: dict, transported: bool) -> np.ndarray:
    """The field a continuum frame is drawn from: G, or mean_length_psi when ``transported``.

    It must be there and finite (DamagedFileError naming the VTU otherwise).
    """
    name = "mean_length_psi" if transported else "G"
    if name not in data:
        raise DamagedFileError(f"{vtu} is damaged: it has no point data {name}")
    if not np.all(np.isfinite(data[name])):
        raise DamagedFileError(f"{vtu} is damaged: its point data {name} are not finite")
    return data[name]


# --------------------------------------------------------------------------- writing


@contextmanager
def _writing_into(folder: Path) -> Iterator[Path]:
    """A temporary folder whose files replace their namesakes in ``folder`` when the body ends.

    ``folder`` (checked by the caller, :func:`cases.rundir.check_output`) is created when missing,
    with its missing parents, which are removed again when the body fails. Its lock is held
    meanwhile
    (cases.rundir.hold: a run still writing into it, or another ``colony plot|movie``, is
    refused with one line). The body writes into a fresh temporary folder inside ``folder``
    (``colony-*.tmp``, a name the run folders count as colony's); when the body ends normally
    every file of it replaces the entry of its name in ``folder`` with os.replace (a link is
    replaced, never followed; a folder of that name is refused first). The temporary folder
    is always removed.
    """
    created = [p for p in (folder, *folder.parents) if not p.exists()]
    folder.mkdir(parents=True, exist_ok=True)
    try:
        with rundir.hold(folder):
            staging = Path(tempfile.mkdtemp(prefix="colony-", suffix=".tmp", dir=folder))
            try:
                yield staging
                names = sorted(p.name for p in staging.iterdir())
                for name in names:
                    target = folder / name
                    if target.is_dir() and not target.is_symlink():
                        raise ValueError(f"{target} is a folder; move it away or give another "
                                         "output")
                for name in names:
                    os.replace(staging / name, folder / name)
            finally:
                shutil.rmtree(staging, ignore_errors=True)
    except BaseException:
        for made in created:  # the deepest first; each empty unless another process wrote
            if made.is_dir() and not any(made.iterdir()):
                made.rmdir()
        raise


# --------------------------------------------------------------------------- pictures


def plot_run(run_dir: str | Path, out: str | Path | None = None) -> list[Path]:
    """Redraw a run's pictures into ``out`` (default: the run folder); returns the PNG paths.

    Continuum: ``mean_length.png`` (the last VTU frame); particles: ``colony.png`` (particles.csv,
    else the trajectory's last frame); both: ``radius.png``, R(t) from history.csv, and
    ``profile.png``, the radial mean-length profile from profile.csv when present.
    """
    d = Path(run_dir)
    rundir.check_source(d)
    kind = run_kind(d)
    o = rundir.check_output(d if out is None else out, source=d)
    with _writing_into(o) as staging:
        lam = _lam(d)
        hist = _history(d)
        if kind == "continuum":
            t, vtu = _continuum_frames(d)[-1]
            points, triangles, data = read_continuum_frame(vtu)
            transported = _handed_over(d) and "mean_length_psi" in data
            _continuum_field(vtu, data, transported)
            state = SimpleNamespace(points=points, triangles=triangles, fields=data, t=t)
            continuum_picture(state, staging / "mean_length", lam, transported=transported)
            names = ["mean_length.png"]
        else:
            particles_picture(_final_particles(d, hist), staging / "colony", lam)
            names = ["colony.png"]
        names.append(_plot_radius(hist, kind, lam, staging / "radius.png").name)
        if (d / "profile.csv").is_file():
            names.append(_plot_profile(_profile(d), kind, lam, staging / "profile.png",
                                       closed_form=not _handed_over(d)).name)
    return [o / name for name in names]


def _columns(table: dict[str, np.ndarray], path: Path, names: Sequence[str]) -> None:
    """Refuse a CSV table without the columns ``names`` (DamagedFileError naming it)."""
    missing = [n for n in names if n not in table]
    if missing:
        raise DamagedFileError(f"{path} is damaged: no column {', '.join(missing)}")


def _history(d: Path) -> dict[str, np.ndarray]:
    """history.csv: columns t and radius, at least one row, every t and radius finite."""
    path = d / "history.csv"
    hist = read_csv(path)
    if "t" not in hist or "radius" not in hist or np.size(hist["t"]) == 0:
        raise ValueError(f"{d}: history.csv without rows or columns t, radius")
    hist = {k: np.atleast_1d(v) for k, v in hist.items()}
    bad = np.flatnonzero(~(np.isfinite(hist["t"]) & np.isfinite(hist["radius"])))
    if len(bad):
        raise DamagedFileError(f"{path} is damaged: row {bad[0] + 1} has no finite t and radius")
    return hist


def _profile(d: Path) -> dict[str, np.ndarray]:
    """profile.csv: r and mean_length, or r and the transported mean, its spread, the phase."""
    path = d / "profile.csv"
    profile = read_csv(path)
    psi = ("mean_length_psi", "length_std_psi", "mean_length_phase")
    _columns(profile, path, ("r", *(psi if "mean_length_psi" in profile else ("mean_length",))))
    return profile


def _final_particles(d: Path, hist: dict[str, np.ndarray]) -> SimpleNamespace:
    """The last colony: particles.csv (checked), else the trajectory's last frame (checked)."""
    t = float(hist["t"][-1])
    path = d / "particles.csv"
    if path.is_file():
        p = read_csv(path)
        _columns(p, path, ("x", "y", "theta", "length"))
        colony = SimpleNamespace(**{k: np.atleast_1d(p[k]) for k in ("x", "y", "theta", "length")},
                                 t=t)
        check_colony(f"{path} is damaged: it", colony.x, colony.y, colony.theta, colony.length)
        return colony
    gsd_path = d / "trajectory.gsd"
    (fr,) = read_particle_frames(gsd_path, [_last_frame(gsd_path)])
    return SimpleNamespace(x=fr.x, y=fr.y, theta=fr.theta, length=fr.length,
                           t=fr.t if math.isfinite(fr.t) else t)


def _last_frame(gsd_path: Path) -> int:
    """Index of the last frame of a (checked) trajectory; ValueError when it has none."""
    n = check_trajectory(gsd_path)
    if n == 0:
        raise ValueError(f"{gsd_path} has no frame")
    return n - 1


def _plot_radius(hist, kind: str, lam: float, path: Path) -> Path:
    fig, ax = plt.subplots(figsize=(5, 3.6))
    ax.plot(hist["t"], hist["radius"], lw=1.5)
    ax.set_xlabel("t")
    ax.set_ylabel("R(t)")
    ax.set_title(f"{kind}, lam = {lam:g}: colony radius")
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return path


def _handed_over(d: Path) -> bool:
    """Whether a continuum run started from a particle colony (cases.handoff: handoff.json)."""
    from cases.handoff import HANDOFF

    return (d / HANDOFF).is_file()


def _plot_profile(profile, kind: str, lam: float, path: Path, closed_form: bool = True) -> Path:
    """Mean length against r; a continuum's transported Psi with its band, closed form dotted.

    ``closed_form`` False (a run handed over from particles): without 2^frac(<G> / ln 2).
    """
    fig, ax = plt.subplots(figsize=(5, 3.6))
    if "mean_length_psi" in profile:
        r, m, s = profile["r"], profile["mean_length_psi"], profile["length_std_psi"]
        ax.plot(r, m, lw=1.2, label=r"transported $\Psi$, $\pm$ 1 s.d.")
        ax.fill_between(r, m - s, m + s, alpha=0.25, lw=0)
        if closed_form:
            ax.plot(r, profile["mean_length_phase"], ":", lw=1, color="k",
                    label=r"$2^{\mathrm{frac}(\langle G\rangle/\ln 2)}$")
        ax.legend(fontsize=8)
    else:
        ax.plot(profile["r"], profile["mean_length"], lw=1.2)
    ax.set_xlabel("r")
    ax.set_ylabel(r"mean length $\bar\ell$")
    ax.set_title(f"{kind}, lam = {lam:g}: final radial profile")
    ax.set_ylim(*LENGTH_LIMITS)
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return path


# --------------------------------------------------------------------------- movies


def boundary_edges(triangles: np.ndarray) -> np.ndarray:
    """Edges (k, 2) of a triangle mesh used by exactly one triangle: the domain boundary."""
    t = np.asarray(triangles, dtype=np.int64)
    e = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    uniq, count = np.unique(e, axis=0, return_counts=True)
    return uniq[count == 1]


def _pick(n: int, max_frames: int | None) -> list[int]:
    """At most ``max_frames`` frame indices, evenly spaced, first and last kept."""
    if max_frames is None or n <= max_frames:
        return list(range(n))
    if max_frames < 2:
        return [n - 1]
    return sorted(set(np.round(np.linspace(0, n - 1, max_frames)).astype(int).tolist()))


def check_movie_options(out_path: str | Path, fps: float, max_frames: int | None) -> Path:
    """The movie file ``out_path``, checked with the rate and frame count; ValueError otherwise.

    ``out_path`` ends in ``MOVIE_SUFFIX`` and is not a folder; fps lies in ``MOVIE_FPS``;
    ``max_frames`` is None (every frame) or 1 .. ``MAX_MOVIE_FRAMES``.
    """
    out_path = Path(out_path)
    if out_path.is_dir() and not out_path.is_symlink():
        raise ValueError(f"movie {out_path} is a folder; give the movie's file name, e.g. "
                         f"{out_path / ('movie' + MOVIE_SUFFIX)}")
    if out_path.suffix.lower() != MOVIE_SUFFIX:
        raise ValueError(f"movie {out_path}: the name must end in {MOVIE_SUFFIX} (an H.264 MP4 "
                         "is written)")
    low, high = MOVIE_FPS
    if not (isinstance(fps, int | float) and math.isfinite(fps) and low <= fps <= high):
        raise ValueError(f"--fps must be a number from {low:g} to {high:g} frames per second, "
                         f"got {fps}")
    if max_frames is not None and not 1 <= max_frames <= MAX_MOVIE_FRAMES:
        raise ValueError(f"--max-frames must be from 1 to {MAX_MOVIE_FRAMES}, got {max_frames}")
    return out_path


def movie_run(run_dir: str | Path, out_path: str | Path, fps: float = 12.0,
              max_frames: int | None = None, pixels: int = 640,
              progress: bool = True) -> Path:
    """Write an MP4 of a run's frames (every VTU / trajectory frame, or ``max_frames`` of them).

    Each movie frame is a matplotlib picture of ``MOVIE_SIZE`` pixels: particles as
    sphero-cylinders coloured by l, or the continuum's lbar on a ``pixels``-wide grid over the
    final domain with the frame's boundary; colour scale [1, 2] and axis limits (those of the
    last, largest frame) fixed.  A tqdm bar shows progress when ``progress``. The options are
    checked first (:func:`check_movie_options`), the frames as they are read; the movie
    appears under its name only once whole (:func:`_writing_into`).
    """
    out_path = check_movie_options(out_path, fps, max_frames)
    d = Path(run_dir)
    rundir.check_source(d)
    kind = run_kind(d)
    folder = rundir.check_output(out_path.parent, source=d)
    with _writing_into(folder) as staging:
        _write_movie(d, kind, staging / out_path.name, fps, max_frames, pixels, progress)
    return out_path


def _movie_limits(d: Path, kind: str, max_frames: int | None) -> tuple:
    """(frames picked, lower corner, upper corner): the frames and the last one's extent.

    The frames are (t, VTU path) of a continuum run, trajectory indices of a particle run.
    """
    if kind == "continuum":
        frames = _continuum_frames(d)
        pick = [frames[i] for i in _pick(len(frames), max_frames)]
        p_last, _, _ = read_continuum_frame(pick[-1][1])
        return pick, p_last.min(axis=0), p_last.max(axis=0)
    gsd_path = d / "trajectory.gsd"
    pick = _pick(_last_frame(gsd_path) + 1, max_frames)
    (last,) = read_particle_frames(gsd_path, [pick[-1]])
    h = 0.5 * last.length
    return (pick, np.array([np.min(last.x - h), np.min(last.y - h)]),
            np.array([np.max(last.x + h), np.max(last.y + h)]))


def _write_movie(d: Path, kind: str, out_path: Path, fps: float, max_frames: int | None,
                 pixels: int, progress: bool) -> None:
    """The MP4 of :func:`movie_run`, written to ``out_path`` (a file of a fresh folder)."""
    import imageio_ffmpeg
    from matplotlib.collections import LineCollection
    from tqdm import tqdm

    lam = _lam(d)
    handed_over = kind == "continuum" and _handed_over(d)
    pick, lo, hi = _movie_limits(d, kind, max_frames)
    pad = 0.03 * float(np.max(hi - lo)) + 0.5
    xlim, ylim = (lo[0] - pad, hi[0] + pad), (lo[1] - pad, hi[1] + pad)

    w, h = MOVIE_SIZE
    fig = plt.figure(figsize=(w / 100, h / 100), dpi=100)
    ax = fig.add_axes((0.06, 0.06, 0.74, 0.86))
    cax = fig.add_axes((0.84, 0.15, 0.03, 0.68))
    sm = plt.cm.ScalarMappable(cmap=DEFAULT_CMAP, norm=plt.Normalize(*LENGTH_LIMITS))
    cb = fig.colorbar(sm, cax=cax)  # a fixed axes: the picture does not move between frames
    cb.set_label(r"length $\ell$" if kind == "particles" else r"mean length $\bar\ell$")

    writer = imageio_ffmpeg.write_frames(str(out_path), (w, h), fps=fps, codec="libx264",
                                         pix_fmt_in="rgb24", pix_fmt_out="yuv420p",
                                         quality=None, macro_block_size=16,
                                         output_params=["-crf", "23"])
    writer.send(None)
    try:
        if kind == "continuum":
            items = iter(pick)
        else:
            items = ((None, fr) for fr in read_particle_frames(d / "trajectory.gsd", pick))
        bar = tqdm(items, total=len(pick), desc=f"movie {out_path.name}",
                   disable=not (progress and sys.stderr.isatty()))  # no bar in a log file
        for t, item in bar:
            ax.clear()
            if kind == "continuum":
                points, triangles, data = read_continuum_frame(item)
                size = float(np.max(points.max(axis=0) - points.min(axis=0)))
                px = max(32, int(pixels * size / float(np.max(hi - lo))))
                transported = handed_over and "mean_length_psi" in data
                field = _continuum_field(item, data, transported)
                if transported:
                    draw_field(points, triangles, field, ax=ax)
                else:
                    draw_mean_length(points, triangles, field, ax, pixels=px)
                edges = points[boundary_edges(triangles)]
                ax.add_collection(LineCollection(edges, colors="k", linewidths=0.8))
                ax.set_title(f"continuum, lam = {lam:g}, t = {t:.3g}")
            else:
                draw_particles(item.x, item.y, item.theta, item.length, ax=ax, rasterized=False)
                ax.set_title(f"particles, lam = {lam:g}, N = {item.n}, t = {item.t:.3g}")
            ax.set_xlim(*xlim)
            ax.set_ylim(*ylim)
            ax.set_aspect("equal")
            fig.canvas.draw()
            rgb = np.asarray(fig.canvas.buffer_rgba())[:, :, :3]
            writer.send(np.ascontiguousarray(rgb).tobytes())
    finally:
        writer.close()
        plt.close(fig)


# --------------------------------------------------------------------------- OVITO


def ovito_pipeline(path: str | Path, color_by: str = "length",
                   clim: Sequence[float] = LENGTH_LIMITS):
    """OVITO pipeline of a particle trajectory.gsd: rods coloured by ``color_by``, cell open.

    The file alone already gives OVITO sphero-cylinders of each particle's length along theta
    (particles/output.py); this adds the colour coding (viridis, limits ``clim``) and turns the
    cell's periodicity off (OVITO's GSD reader always marks HOOMD boxes periodic).
    """
    from ovito.io import import_file
    from ovito.modifiers import ColorCodingModifier

    p = Path(path)
    if not p.is_file():
        raise ValueError(f"trajectory not found: {p}")
    pipeline = import_file(str(p))

    def open_cell(frame, data):
        data.cell_.pbc = (False, False, False)
        data.cell_.vis.enabled = False

    pipeline.modifiers.append(open_cell)
    pipeline.modifiers.append(ColorCodingModifier(
        property=color_by, start_value=float(clim[0]), end_value=float(clim[1]),
        gradient=ColorCodingModifier.Viridis()))
    return pipeline


def render_ovito(path: str | Path, png: str | Path, frame: int = -1,
                 size: tuple[int, int] = (600, 600), renderer: str = "tachyon") -> Path:
    """Render one frame of a particle trajectory with OVITO headless (top view, white).

    ``renderer``: 'tachyon' (software ray tracer) or 'opengl'.  OVITO 3.17 renders through
    Vulkan: on a machine without a GPU it needs the Vulkan loader and Mesa's software driver
    (Debian: ``apt-get install libvulkan1 mesa-vulkan-drivers``).
    """
    from ovito.vis import OpenGLRenderer, TachyonRenderer, Viewport

    pipeline = ovito_pipeline(path)
    k = frame % pipeline.num_frames
    pos = pipeline.compute(k).particles.positions[:, :2]
    lo, hi = pos.min(axis=0) - 1.0, pos.max(axis=0) + 1.0  # + half a division length
    centre = 0.5 * (lo + hi)
    pipeline.add_to_scene()
    try:
        # orthographic top view: fov is half the height of the visible area (world units)
        half = 0.5 * float(max(hi[1] - lo[1], (hi[0] - lo[0]) * size[1] / size[0]))
        vp = Viewport(type=Viewport.Type.Top, camera_pos=(centre[0], centre[1], 0.0),
                      fov=1.02 * half)
        r = TachyonRenderer(ambient_occlusion=False) if renderer == "tachyon" else OpenGLRenderer()
        vp.render_image(filename=str(png), size=size, frame=k, background=(1.0, 1.0, 1.0),
                        renderer=r)
    finally:
        pipeline.remove_from_scene()
    return Path(png)

