"""Orientational order of a particle colony: nematic order tensor, its director, its defects.

A rod of angle theta has the unit axis n = (cos theta, sin theta); rods are head-tail symmetric,
so the order of a group of rods is the 2D nematic order tensor ::

    Q = < 2 n n^T - I > = [[q_xx, q_xy], [q_xy, -q_xx]],
    q_xx = <cos 2 theta>,  q_xy = <sin 2 theta>,

(OVITO / freud's ``Nematic`` convention in 2D; averages by count, or with weights). Its largest
eigenvalue is the order S = sqrt(q_xx^2 + q_xy^2) in [0, 1] (1: all parallel; 0: no preferred
axis), its eigenvector the director, at angle psi = atan2(q_xy, q_xx) / 2. For n rods of
independent uniform angles (q_xx, q_xy) is asymptotically normal with variance 1/(2n) each, so
S is Rayleigh distributed with mean sqrt(pi / (4 n)) (:func:`isotropic_order`): the order of a
finite group is never 0, and S must be read against this floor.

Relative to the colony. About the centre c (the area-weighted centroid of the rods, as
particles.measures), a rod at polar angle phi makes the angle theta - phi with the radius; the
same tensor in the polar frame, q_r = <cos 2 (theta - phi)>, q_s = <sin 2 (theta - phi)>, has
q_r = +1 for rods all along the radius, -1 for rods all along circles (tangent), and its angle
psi_r = atan2(q_s, q_r) / 2 is the director's angle from the radial direction (0 radial, +-90
degrees azimuthal). Per annulus (:func:`annulus_order`) these give the colony's radial
alignment q_r(r), which is what a flow with e_rr > e_tt (continuum.strain_rate) would produce; the
local order S_local(r) is the mean order of the grid cells in the annulus, which a uniform
azimuthal or radial arrangement does not need.

Grid (:func:`orientation_grid`). Square cells of side ``cell``; in each, Q of its rods (by their
centres), optionally smoothed by a Gaussian of ``smooth`` cells (normalized convolution of
count Q and count); cells with fewer than ``min_count`` rods are empty.

Defects (:func:`plaquette_charges`). The director angle psi is sampled at the cell centres; around
each plaquette of four neighbouring filled cells (counter-clockwise) the charge is
sum(wrap(dpsi)) / (2 pi), every difference wrapped into [-pi/2, pi/2) (the nematic's head-tail
symmetry: psi and psi + pi are the same director). Each of the four steps is less than pi/2 in
size, so a plaquette's charge is -1/2, 0 or +1/2; the charges of the plaquettes inside a loop add
up to the winding of the director around it. A +1 defect (an aster or a vortex of rods, whose
director turns by 2 pi around it) is therefore always counted as TWO +1/2 defects, in two
plaquettes next to its core (the total, +1, is exact; tests/cases/test_orientation.py). The
defect density is the number of +1/2 (and of -1/2) defects per area of the plaquettes
examined.

Output (:func:`orientation_run`): ``orientation_annuli.csv`` (the final frame per annulus),
``orientation_series.csv`` (every frame: radius, mean order, radial alignment, defects),
``orientation_defects.csv``, and ``orientation_grid.vtu`` / ``orientation_defects.vtu`` for
ParaView: the grid's filled cells as quads with cell data count, q_xx, q_xy, S, director (a
3-vector: use the Glyph filter, glyph type Line, orientation "director", as the director has no
sign) and angle_to_radial (degrees), the defects as vertices with the point data ``charge``.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
from scipy.ndimage import gaussian_filter

from particles.measures import centroid, enclosing_radius

from .io import particle_frames, write_csv

__all__ = [
    "order_tensor",
    "order_parameter",
    "director_angle",
    "isotropic_order",
    "annulus_order",
    "orientation_grid",
    "plaquette_charges",
    "grid_defects",
    "frame_orientation",
    "orientation_series",
    "write_orientation_vtu",
    "orientation_run",
]

#: Default grid cell side (units of the birth length l0 = 1): about two rod lengths.
CELL = 2.0
#: Default Gaussian smoothing of the grid's Q, in cells (0: none).
SMOOTH = 1.0
#: Default least number of rods in a cell for it to carry a director.
MIN_COUNT = 3
#: Default annulus width.
WIDTH = 2.0


def order_tensor(theta, weights=None) -> tuple[float, float]:
    """(q_xx, q_xy) of Q = <2 n n^T - I>: the weighted means of cos 2 theta and sin 2 theta."""
    theta = np.asarray(theta, dtype=float)
    if theta.size == 0:
        return math.nan, math.nan
    w = np.ones_like(theta) if weights is None else np.asarray(weights, dtype=float)
    return (float(np.sum(w * np.cos(2 * theta)) / np.sum(w)),
            float(np.sum(w * np.sin(2 * theta)) / np.sum(w)))


def order_parameter(qxx, qxy):
    """S = sqrt(q_xx^2 + q_xy^2), the largest eigenvalue of Q."""
    return np.hypot(qxx, qxy)


def director_angle(qxx, qxy):
    """Director angle psi = atan2(q_xy, q_xx) / 2 in (-pi/2, pi/2]."""
    return 0.5 * np.arctan2(qxy, qxx)


def isotropic_order(n):
    """Mean S of n rods of independent uniform angles: sqrt(pi / (4 n)) (Rayleigh, large n)."""
    return np.sqrt(np.pi / (4.0 * np.asarray(n, dtype=float)))


def _polar(x, y, theta, center):
    d_phi = np.asarray(theta, dtype=float) - np.arctan2(np.asarray(y) - center[1],
                                                        np.asarray(x) - center[0])
    return np.cos(2 * d_phi), np.sin(2 * d_phi), np.hypot(np.asarray(x) - center[0],
                                                          np.asarray(y) - center[1])


def annulus_order(x, y, theta, center, radius, width: float = WIDTH,
                  grid: dict | None = None) -> dict[str, np.ndarray]:
    """Orientation per annulus: round(radius / width) equal-width annuli of [0, radius].

    Rods beyond ``radius`` count in the last annulus (so that colonies of a nominal radius
    share the annuli).

    Columns: r (mid radius), count; q_r = <cos 2 (theta - phi)>, q_s = <sin 2 (theta - phi)>;
    S_polar = hypot(q_r, q_s); angle = atan2(q_s, q_r) / 2 in degrees (the director's angle from
    the radius, 0 radial, +-90 azimuthal); mean_abs_angle = the mean of abs(theta - phi) folded into
    [0, 90] degrees (45 for isotropic rods); S_iso = isotropic_order(count); with ``grid``
    (:func:`orientation_grid`), S_local = the count-weighted mean S of the filled cells whose
    centre is in the annulus and S_local_iso its isotropic floor.
    """
    cos2, sin2, r = _polar(x, y, theta, center)
    n_ann = max(1, round(radius / width))
    edges = np.linspace(0.0, radius, n_ann + 1)
    k = np.clip(np.searchsorted(edges, r, side="right") - 1, 0, n_ann - 1)
    count = np.bincount(k, minlength=n_ann).astype(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        q_r = np.bincount(k, weights=cos2, minlength=n_ann) / count
        q_s = np.bincount(k, weights=sin2, minlength=n_ann) / count
        fold = np.arccos(np.sqrt(np.clip((1.0 + cos2) / 2.0, 0.0, 1.0)))  # in [0, pi/2]
        mean_abs = np.degrees(np.bincount(k, weights=fold, minlength=n_ann) / count)
    out = {"r": 0.5 * (edges[:-1] + edges[1:]), "count": count,
           "q_r": q_r, "q_s": q_s, "S_polar": np.hypot(q_r, q_s),
           "angle": np.degrees(0.5 * np.arctan2(q_s, q_r)), "mean_abs_angle": mean_abs,
           "S_iso": isotropic_order(np.maximum(count, 1))}
    if grid is not None:
        filled = grid["valid"]
        rc = np.hypot(grid["xc"] - center[0], grid["yc"] - center[1])[filled]
        kc = np.clip(np.searchsorted(edges, rc, side="right") - 1, 0, n_ann - 1)
        wc = grid["count"][filled]
        with np.errstate(invalid="ignore", divide="ignore"):
            wsum = np.bincount(kc, weights=wc, minlength=n_ann)
            out["S_local"] = np.bincount(kc, weights=wc * grid["S"][filled],
                                         minlength=n_ann) / wsum
            out["S_local_iso"] = np.bincount(
                kc, weights=wc * isotropic_order(grid["n_eff"][filled]), minlength=n_ann) / wsum
    return out


def orientation_grid(x, y, theta, cell: float = CELL, smooth: float = SMOOTH,
                     min_count: int = MIN_COUNT, center=None, weights=None) -> dict:
    """Q, S and the director on a square grid of side ``cell`` covering the rods (module doc).

    Returns a dict of (ny, nx) arrays: count (rods per cell), n_eff (the effective number of
    rods behind a smoothed cell: (sum w)^2 / sum w^2 of the Gaussian weights times counts),
    qxx, qxy, S, angle (director, radians), angle_to_radial (director minus the polar angle of
    the cell centre about ``center``, wrapped into (-pi/2, pi/2]), xc, yc (cell centres), valid
    (count >= min_count); and x0, y0, cell (the grid's lower-left corner and side).
    """
    x, y, theta = (np.asarray(a, dtype=float) for a in (x, y, theta))
    w = np.ones_like(x) if weights is None else np.asarray(weights, dtype=float)
    x0 = math.floor(x.min() / cell) * cell
    y0 = math.floor(y.min() / cell) * cell
    nx = int(math.floor((x.max() - x0) / cell)) + 1
    ny = int(math.floor((y.max() - y0) / cell)) + 1
    ix = np.clip(((x - x0) / cell).astype(int), 0, nx - 1)
    iy = np.clip(((y - y0) / cell).astype(int), 0, ny - 1)
    flat = iy * nx + ix

    def grid_sum(v):
        return np.bincount(flat, weights=v, minlength=nx * ny).reshape(ny, nx)

    count = grid_sum(np.ones_like(x))
    wsum, c2, s2 = grid_sum(w), grid_sum(w * np.cos(2 * theta)), grid_sum(w * np.sin(2 * theta))
    n_eff = count.copy()
    if smooth > 0:
        def blur(a):
            return gaussian_filter(a, smooth, mode="constant", truncate=3.0)
        wsum, c2, s2 = blur(wsum), blur(c2), blur(s2)
        # effective sample size of the Gaussian average of the rods around each cell
        n_eff = blur(count) ** 2 / np.maximum(gaussian_filter(count, smooth / math.sqrt(2),
                                                              mode="constant", truncate=3.0)
                                              / (4 * math.pi * smooth ** 2), 1e-300)
    valid = count >= min_count
    with np.errstate(invalid="ignore", divide="ignore"):
        qxx = np.where(valid, c2 / wsum, np.nan)
        qxy = np.where(valid, s2 / wsum, np.nan)
    xc = x0 + cell * (np.arange(nx) + 0.5)[None, :] * np.ones((ny, 1))
    yc = y0 + cell * (np.arange(ny) + 0.5)[:, None] * np.ones((1, nx))
    if center is None:
        center = centroid(x, y, np.ones_like(x)) if weights is None else centroid(x, y, w)
    psi = director_angle(qxx, qxy)
    rel = psi - np.arctan2(yc - center[1], xc - center[0])
    rel = (rel + np.pi / 2) % np.pi - np.pi / 2
    return {"count": count, "n_eff": n_eff, "qxx": qxx, "qxy": qxy,
            "S": order_parameter(qxx, qxy), "angle": psi, "angle_to_radial": rel,
            "xc": xc, "yc": yc, "valid": valid, "x0": x0, "y0": y0, "cell": float(cell)}


def _wrap(d):
    """Nematic angle difference wrapped into [-pi/2, pi/2)."""
    return (d + np.pi / 2) % np.pi - np.pi / 2


def plaquette_charges(angle, valid=None) -> np.ndarray:
    """Winding charge of the director around every plaquette of four neighbouring cells.

    ``angle`` (ny, nx) director angles at cell centres; the plaquette (i, j) has the corners
    (i, j), (i, j+1), (i+1, j+1), (i+1, j) (counter-clockwise with x along j, y along i).
    Returns (ny-1, nx-1) charges in {-1/2, 0, +1/2}, NaN where a corner is not ``valid``.
    """
    a = np.asarray(angle, dtype=float)
    ok = np.isfinite(a) if valid is None else (np.asarray(valid, bool) & np.isfinite(a))
    c00, c01, c11, c10 = a[:-1, :-1], a[:-1, 1:], a[1:, 1:], a[1:, :-1]
    total = _wrap(c01 - c00) + _wrap(c11 - c01) + _wrap(c10 - c11) + _wrap(c00 - c10)
    q = np.round(total / np.pi) / 2.0
    all_ok = ok[:-1, :-1] & ok[:-1, 1:] & ok[1:, 1:] & ok[1:, :-1]
    return np.where(all_ok, q, np.nan)


def grid_defects(grid: dict) -> dict[str, np.ndarray]:
    """The defects of a grid: x, y (plaquette centres), charge (+-1/2); and the area examined.

    ``area``: the total area of the plaquettes with four filled corners (cell^2 each), as a
    one-element array.
    """
    q = plaquette_charges(grid["angle"], grid["valid"])
    iy, ix = np.nonzero(np.nan_to_num(q) != 0)
    c = grid["cell"]
    return {"x": grid["x0"] + c * (ix + 1.0), "y": grid["y0"] + c * (iy + 1.0),
            "charge": q[iy, ix], "area": np.array([c * c * np.isfinite(q).sum()])}


def frame_orientation(frame: dict[str, np.ndarray], cell: float = CELL, smooth: float = SMOOTH,
                      min_count: int = MIN_COUNT, width: float = WIDTH) -> dict:
    """Everything of one particle frame ({x, y, theta, length}): annuli, grid, defects, scalars.

    Centre and radius: particles.measures.centroid (area-weighted) and enclosing_radius. The
    scalars: radius, n_particles, q_r (all rods), q_r_outer (rods beyond R/2), S_local (mean
    cell order, count-weighted), S_local_iso (its isotropic floor), n_plus, n_minus (defects),
    defect_area, density_plus, density_minus (per unit area).
    """
    x, y, th, ln = frame["x"], frame["y"], frame["theta"], frame["length"]
    c = centroid(x, y, ln)
    R = enclosing_radius(x, y, th, ln)
    grid = orientation_grid(x, y, th, cell=cell, smooth=smooth, min_count=min_count, center=c)
    ann = annulus_order(x, y, th, c, R, width=width, grid=grid)
    dfc = grid_defects(grid)
    cos2, _, r = _polar(x, y, th, c)
    v = grid["valid"]
    wc = grid["count"][v]
    area = float(dfc["area"][0])
    n_plus, n_minus = int(np.sum(dfc["charge"] > 0)), int(np.sum(dfc["charge"] < 0))
    scal = {"radius": R, "n_particles": x.size, "q_r": float(cos2.mean()),
            "q_r_outer": float(cos2[r > R / 2].mean()) if np.any(r > R / 2) else math.nan,
            "S_local": float(np.sum(wc * grid["S"][v]) / wc.sum()) if wc.size else math.nan,
            "S_local_iso": (float(np.sum(wc * isotropic_order(grid["n_eff"][v])) / wc.sum())
                            if wc.size else math.nan),
            "n_plus": n_plus, "n_minus": n_minus, "defect_area": area,
            "density_plus": n_plus / area if area else math.nan,
            "density_minus": n_minus / area if area else math.nan}
    return {"center": c, "annuli": ann, "grid": grid, "defects": dfc, "scalars": scal}


def orientation_series(folder: str | os.PathLike, every: int = 1, **kwargs
                       ) -> dict[str, np.ndarray]:
    """The scalars of :func:`frame_orientation` at every ``every``-th frame (and the last), with t.

    Frames of fewer than 10 rods are skipped.
    """
    frames = list(particle_frames(folder))
    picks = sorted(set(range(0, len(frames), max(1, every))) | {len(frames) - 1})
    cols: dict[str, list] = {}
    for i in picks:
        t, fr = frames[i]
        if fr["x"].size < 10:
            continue
        row = {"t": t} | frame_orientation(fr, **kwargs)["scalars"]
        for k, v in row.items():
            cols.setdefault(k, []).append(v)
    return {k: np.asarray(v, dtype=float) for k, v in cols.items()}


def write_orientation_vtu(path: str | os.PathLike, grid: dict,
                          defects: dict | None = None, t: float | None = None) -> list[Path]:
    """The grid's filled cells as a VTU of quads (and the defects as a second VTU of vertices).

    Cell data: count, qxx, qxy, S, director (cos psi, sin psi, 0), angle_to_radial (degrees).
    ``defects`` (:func:`grid_defects`) go to ``<path stem>_defects.vtu`` with point data charge.
    ``t``: written as FieldData TimeValue. Returns the paths written.
    """
    import meshio

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ny, nx = grid["count"].shape
    c, x0, y0 = grid["cell"], grid["x0"], grid["y0"]
    px, py = np.meshgrid(x0 + c * np.arange(nx + 1), y0 + c * np.arange(ny + 1))
    pts = np.column_stack([px.ravel(), py.ravel(), np.zeros(px.size)])
    iy, ix = np.nonzero(grid["valid"])
    n0 = iy * (nx + 1) + ix
    quads = np.column_stack([n0, n0 + 1, n0 + nx + 2, n0 + nx + 1])
    psi = grid["angle"][iy, ix]
    data = {"count": grid["count"][iy, ix], "qxx": grid["qxx"][iy, ix],
            "qxy": grid["qxy"][iy, ix], "S": grid["S"][iy, ix],
            "director": np.column_stack([np.cos(psi), np.sin(psi), np.zeros(psi.size)]),
            "angle_to_radial": np.degrees(grid["angle_to_radial"][iy, ix])}
    field = {} if t is None else {"TimeValue": np.array([float(t)])}
    meshio.write(path, meshio.Mesh(pts, [("quad", quads)],
                                   cell_data={k: [v] for k, v in data.items()},
                                   field_data=field), file_format="vtu")
    paths = [path]
    if defects is not None:
        dpath = path.with_name(path.stem + "_defects.vtu")
        n = defects["x"].size
        dpts = np.column_stack([defects["x"], defects["y"], np.zeros(n)])
        meshio.write(dpath, meshio.Mesh(dpts, [("vertex", np.arange(n)[:, None])],
                                        point_data={"charge": defects["charge"]},
                                        field_data=field), file_format="vtu")
        paths.append(dpath)
    return paths


def orientation_run(folder: str | os.PathLike, out: str | os.PathLike | None = None,
                    every: int = 1, **kwargs) -> dict:
    """Reduce a particle run folder: its orientation CSVs and VTUs in ``out`` (default: folder).

    Writes orientation_annuli.csv (last frame), orientation_series.csv (every ``every``-th
    frame), orientation_defects.csv (last frame: x, y, charge), orientation_grid.vtu and
    orientation_grid_defects.vtu (last frame). ``kwargs``: cell, smooth, min_count, width.
    Returns the last frame's :func:`frame_orientation` with ``series`` added.
    """
    folder = Path(folder)
    out = folder if out is None else Path(out)
    ((t, last),) = particle_frames(folder, last_only=True)
    res = frame_orientation(last, **kwargs)
    res["series"] = orientation_series(folder, every=every, **kwargs)
    write_csv(out / "orientation_annuli.csv", res["annuli"])
    write_csv(out / "orientation_series.csv", res["series"])
    d = res["defects"]
    write_csv(out / "orientation_defects.csv", {k: d[k] for k in ("x", "y", "charge")})
    write_orientation_vtu(out / "orientation_grid.vtu", res["grid"], d, t=t)
    return res
