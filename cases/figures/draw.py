"""Pictures of colonies: particles as sphero-cylinders and the continuum mean-length field.

Both are coloured by length with the limits [l0, 2 l0] = [1, 2] of the paper's Fig 2, so particle
and continuum panels share one colour scale. Uses matplotlib's Agg backend (no display needed).

A sphero-cylinder (x, y, theta, l) is every point within b/2 of the segment of length L = l - b
centred at (x, y) along p = (cos theta, sin theta); it is drawn as one polygon (two half-circle
caps of `n_cap` + 1 points each) built for all particles at once with numpy and handed to a
single PolyCollection, which stays fast at 1e5 particles and is exact in data units whatever the
figure size or format.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

__all__ = ["LENGTH_LIMITS", "DEFAULT_CMAP", "spherocylinder_polygons", "draw_particles",
           "draw_field", "mean_length_image", "draw_mean_length", "continuum_picture",
           "particles_picture", "save_figure", "colorbar", "note_missing_engines",
           "plain_log_ticks"]

LENGTH_LIMITS = (1.0, 2.0)
DEFAULT_CMAP = "viridis"


def _new_axes(ax: Axes | None) -> Axes:
    if ax is None:
        _, ax = plt.subplots(figsize=(5, 5))
    return ax


def spherocylinder_polygons(
    x: np.ndarray, y: np.ndarray, theta: np.ndarray, length: np.ndarray, b: float = 0.5,
    n_cap: int = 6,
) -> np.ndarray:
    """Outline polygons of sphero-cylinders, shape (n, 2 (n_cap + 1), 2).

    Vertex j of the cap at end s = +-1 is c + s (L/2) p + (b/2) (cos a_j, sin a_j), with the angles
    a_j sweeping the half circle facing outward from that end (theta - pi/2 .. theta + pi/2 for
    s = +1), L = l - b.
    """
    x, y, theta, length = (np.asarray(a, dtype=float).ravel() for a in (x, y, theta, length))
    n = x.size
    if not (y.size == theta.size == length.size == n):
        raise ValueError("x, y, theta and length must have the same length")
    if b <= 0 or n_cap < 1:
        raise ValueError("b must be > 0 and n_cap >= 1")
    if n and np.any(length < b):
        raise ValueError(f"every length must be >= b = {b}")
    half = 0.5 * (length - b)
    px, py = np.cos(theta), np.sin(theta)
    a = np.linspace(-0.5 * np.pi, 0.5 * np.pi, n_cap + 1)
    ang = theta[:, None] + np.concatenate([a, a + np.pi])[None, :]  # (n, 2(n_cap+1))
    sgn = np.concatenate([np.ones(n_cap + 1), -np.ones(n_cap + 1)])
    vx = x[:, None] + sgn * half[:, None] * px[:, None] + 0.5 * b * np.cos(ang)
    vy = y[:, None] + sgn * half[:, None] * py[:, None] + 0.5 * b * np.sin(ang)
    return np.stack([vx, vy], axis=-1)


def draw_particles(  # noqa: PLR0913 (drawing options, all keywords with defaults)
    x: np.ndarray,
    y: np.ndarray,
    theta: np.ndarray,
    length: np.ndarray,
    ax: Axes | None = None,
    color_by: np.ndarray | None = None,
    cmap: str = DEFAULT_CMAP,
    b: float = 0.5,
    clim: tuple[float, float] = LENGTH_LIMITS,
    n_cap: int = 6,
    rasterized: bool | None = None,
) -> PolyCollection:
    """Draw particles as sphero-cylinders of diameter b coloured by `color_by` (default: length).

    Colour limits `clim` = [1, 2] (birth and division length) as in the paper's Fig 2.
    The axes get equal aspect and limits that hold every particle. `rasterized` (default: when
    there are more than 2000 particles) keeps vector outputs (PDF) small.

    Returns
    -------
    The PolyCollection (a ScalarMappable, usable for a colorbar).
    """
    ax = _new_axes(ax)
    verts = spherocylinder_polygons(x, y, theta, length, b=b, n_cap=n_cap)
    c = np.asarray(length if color_by is None else color_by, dtype=float).ravel()
    if c.size != verts.shape[0]:
        raise ValueError("color_by must have one value per particle")
    coll = PolyCollection(verts, array=c, cmap=cmap, edgecolors="none", linewidths=0,
                          antialiaseds=False)
    coll.set_clim(*clim)
    coll.set_rasterized(verts.shape[0] > 2000 if rasterized is None else rasterized)
    ax.add_collection(coll)
    if verts.shape[0]:
        lo, hi = verts.reshape(-1, 2).min(0), verts.reshape(-1, 2).max(0)
        pad = 0.02 * float(max(hi - lo)) + b
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    return coll


def draw_field(
    points: np.ndarray,
    triangles: np.ndarray,
    values: np.ndarray,
    ax: Axes | None = None,
    cmap: str = DEFAULT_CMAP,
    clim: tuple[float, float] = LENGTH_LIMITS,
    rasterized: bool = True,
):
    """Draw a nodal (P1) field on a triangle mesh, Gouraud-shaded (e.g. the mean length lbar).

    Parameters
    ----------
    points : node coordinates, shape (n, 2).
    triangles : node indices of the triangles, shape (m, 3).
    values : nodal values, shape (n,).

    Returns
    -------
    The TriMesh/PolyCollection of `tripcolor` (usable for a colorbar).
    """
    ax = _new_axes(ax)
    points = np.asarray(points, dtype=float)
    triangles = np.asarray(triangles, dtype=np.int64)
    values = np.asarray(values, dtype=float).ravel()
    if points.ndim != 2 or points.shape[1] != 2:
        raise ValueError(f"points must have shape (n, 2), got {points.shape}")
    if triangles.ndim != 2 or triangles.shape[1] != 3:
        raise ValueError(f"triangles must have shape (m, 3), got {triangles.shape}")
    if values.size != points.shape[0]:
        raise ValueError("values must have one value per point")
    if triangles.size and (triangles.min() < 0 or triangles.max() >= points.shape[0]):
        raise ValueError("triangles index points out of range")
    coll = ax.tripcolor(points[:, 0], points[:, 1], triangles, values, shading="gouraud",
                        cmap=cmap, vmin=clim[0], vmax=clim[1], rasterized=rasterized)
    ax.set_aspect("equal")
    return coll


def mean_length_image(points, triangles, G, pixels: int = 900):
    """Pixel image of lbar = 2^frac(G / ln 2) on the mesh's bounding box (NaN outside).

    The growth phase G is smooth, lbar is a sawtooth: interpolating G linearly at each pixel
    and applying the sawtooth there keeps the rings sharp, where shading the nodal lbar would
    smear every jump over a triangle. Returns (image, extent) for ``imshow``.
    """
    from matplotlib.tri import LinearTriInterpolator, Triangulation

    lo, hi = points.min(axis=0), points.max(axis=0)
    x = np.linspace(lo[0], hi[0], pixels)
    y = np.linspace(lo[1], hi[1], pixels)
    X, Y = np.meshgrid(x, y)
    tri = Triangulation(points[:, 0], points[:, 1], triangles)
    g = LinearTriInterpolator(tri, G)(X, Y)
    from continuum.growth import mean_length

    return mean_length(np.ma.filled(g.astype(float), np.nan)), (lo[0], hi[0], lo[1], hi[1])


def draw_mean_length(points, triangles, G, ax: Axes, pixels: int = 900):
    """Draw :func:`mean_length_image` on ``ax`` on the colour scale LENGTH_LIMITS; its image."""
    image, extent = mean_length_image(points, triangles, G, pixels=pixels)
    return ax.imshow(image, origin="lower", extent=extent, cmap=DEFAULT_CMAP,
                     vmin=LENGTH_LIMITS[0], vmax=LENGTH_LIMITS[1], interpolation="nearest")


def continuum_picture(state, stem: Path, lam: float, transported: bool = False) -> None:
    """``stem.png``: lbar of a continuum state (points, triangles, fields, t), colour bar.

    The closed form 2^frac(G / ln 2) per pixel (:func:`draw_mean_length`, sharp rings), or with
    ``transported`` the transported Psi's nodal mean length ``mean_length_psi``, Gouraud-shaded
    (a start other than the model's narrow bump, e.g. a particle colony handed over).
    """
    fig, ax = plt.subplots(figsize=(6.6, 6))
    if transported:
        mappable = draw_field(state.points, state.triangles, state.fields["mean_length_psi"],
                              ax=ax)
    else:
        mappable = draw_mean_length(state.points, state.triangles, state.fields["G"], ax)
    ax.set_aspect("equal")
    colorbar(fig, mappable, ax, label=r"mean length $\bar\ell$")
    ax.set_title(f"continuum, lam = {lam:g}, t = {state.t:.3g}")
    save_figure(fig, stem, formats=("png",))


def particles_picture(colony, stem: Path, lam: float) -> None:
    """``stem.png``: a particle colony (x, y, theta, length, t) coloured by length, colour bar."""
    fig, ax = plt.subplots(figsize=(6.6, 6))
    mappable = draw_particles(colony.x, colony.y, colony.theta, colony.length, ax=ax)
    colorbar(fig, mappable, ax)
    ax.set_title(f"particles, lam = {lam:g}, N = {len(colony.x)}, t = {colony.t:.3g}")
    save_figure(fig, stem, formats=("png",))


def colorbar(fig: Figure, mappable, ax, label: str = r"length $\ell$"):
    """A colour bar for a particle or field panel (one call, shared styling)."""
    cb = fig.colorbar(mappable, ax=ax, shrink=0.8)
    cb.set_label(label)
    return cb


def note_missing_engines(fig: Figure, present: set[str],
                         engines: Sequence[str] = ("continuum", "particles")) -> list[str]:
    """Write at the foot of `fig` which of `engines` are absent from its data; returns them."""
    missing = [e for e in engines if e not in present]
    if missing:
        fig.text(0.5, -0.01, f"{' and '.join(missing)}: not computed at this scale; "
                 "their panels and curves are omitted", ha="center", va="top", fontsize=9,
                 style="italic")
    return missing


def save_figure(
    fig: Figure, path_without_suffix: str | Path, formats: Sequence[str] = ("png", "pdf"),
    dpi: int = 150, close: bool = True,
) -> list[Path]:
    """Save `fig` once per format as `path_without_suffix.<format>`; returns the paths.

    The parent folder is created. The figure is closed afterwards unless `close` is False.
    """
    base = Path(path_without_suffix)
    if not formats:
        raise ValueError("formats must name at least one format")
    base.parent.mkdir(parents=True, exist_ok=True)
    paths = []
    for fmt in formats:
        p = base.with_name(f"{base.name}.{fmt}")
        fig.savefig(p, dpi=dpi, bbox_inches="tight")
        paths.append(p)
    if close:
        plt.close(fig)
    return paths


def plain_log_ticks(fig: Figure) -> None:
    """No minor tick labels on the logarithmic x axes of ``fig`` (they crowd the decades)."""
    from matplotlib.ticker import NullFormatter

    for ax in fig.axes:
        if ax.get_xscale() == "log":
            ax.xaxis.set_minor_formatter(NullFormatter())
