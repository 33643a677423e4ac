"""The radius-260 particle colony against its continuum twin and its own cost (issue 42).

Reads committed data only (``cases/data/colony_260``) and prints four markdown tables:

1. **Cost.** The wall seconds to each radius from the legs' progress lines (one a minute; a
   resumed leg's clock continued, :func:`cases.analysis.progress_lines`), the cells there, and
   the exponent a of W ~ R^a fitted between neighbouring radii (:func:`cases.analysis.
   power_law_fit` over the lines in that range); then the wall, CPU and peak memory of every
   session of the run (its ``run.json``, written by the run itself), against the published
   C++/PETSc run (24 h on 112 cores, W ~ R^5).
2. **Growth.** The time to reach each radius and the whole colony's mean stress over the
   continuum's mean pressure at that radius, averaged over one division period, each relative
   to the continuum colony (:func:`cases.studies.ensemble.history_growth`).
3. **Rings.** The ring wavelength (the two outermost mean-length peaks' distance) of the
   trajectory frames nearest each radius (``--rings``, columns of
   :func:`cases.analysis.particle_growth_series`), against the continuum's final one (its
   ``rings.csv``: the two outermost contour rings) and the 1D radial reference at the particle
   frame's radius (:func:`cases.analysis.exact_wavelength`).
4. **Stress profile** (when the record has ``profile_pooled.csv``): the central stress p0 of the
   fit p0 - c r^2 over r < R/2 (:func:`central_stress`) of both models, and the particle stress
   over the continuum pressure in bands of r / R (annuli pooled by their counts; the continuum
   interpolated at the particle annuli's radii).

    python docs/measurements/colony_260.py [--particles cases/data/colony_260/particles_lam=0.001]
        [--history H] [--rings CSV] [--progress LOG] [--run RUN_JSON] [--continuum DIR]

The record's files are the defaults: ``history.csv`` (the run's whole history, every step),
``rings.csv``, ``progress.log`` and ``run.json``. ``--history`` takes a stage's
``history.csv`` while a colony still grows (then no profile); ``--run`` defaults to the
``run.json`` beside the history.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from cases import analysis as A
from cases.studies.ensemble import history_growth

if str(Path(__file__).parent) not in sys.path:  # the sibling scripts, also when imported
    sys.path.insert(0, str(Path(__file__).parent))
from cost_growth import PUBLISHED  # noqa: E402

DATA = Path(__file__).resolve().parents[2] / "cases" / "data" / "colony_260"
LAM = 1e-3
RADII = (40.0, 50.0, 75.0, 100.0, 150.0, 200.0, 235.0, 260.0)
#: How far (in radius) a trajectory frame may be from a table's radius to stand for it.
NEAR = 2.5
#: Bands of r / R in which the stress profiles are compared.
BANDS = ((0.0, 0.25), (0.25, 0.5), (0.5, 0.75), (0.75, 0.9))


def cost_rows(progress: dict[str, np.ndarray], radii=RADII) -> list[list[str]]:
    """Per radius: wall seconds, cells, and a of W ~ R^a since the previous radius.

    Wall and cells are linear between the progress lines (blank outside them); a is fitted on
    the lines between the previous radius and this one.
    """
    R, W, N = progress["radius"], progress["wall"], progress["particles"]
    rows, previous = [], None
    for r in radii:
        inside = R[0] <= r <= R[-1]
        wall = f"{np.interp(r, R, W):,.0f}" if inside else ""
        cells = f"{np.interp(r, R, N):,.0f}" if inside else ""
        a = ""
        if previous is not None and inside:
            sel = (R >= previous) & (R <= r)
            if sel.sum() >= 3:
                a = f"{A.power_law_fit(R[sel], W[sel])[0]:.2f}"
        rows.append([f"{r:g}", wall, cells, a])
        previous = r
    return rows


def session_totals(record: dict) -> dict[str, float]:
    """Sessions, summed wall and CPU seconds and largest peak memory (MB) of a ``run.json``."""
    sessions = record["sessions"]
    return {"sessions": len(sessions),
            "wall_s": sum(s.get("wall_seconds") or 0.0 for s in sessions),
            "cpu_s": sum(s.get("cpu_seconds") or 0.0 for s in sessions),
            "peak_mb": max((s.get("peak_memory_mb") or 0.0 for s in sessions), default=0.0)}


def growth_rows(history: dict, continuum: dict, radii=RADII) -> list[list[str]]:
    """Per radius: t of both models, t_p / t_c - 1 and the mean stress ratio - 1 (percent)."""
    grid = np.asarray(radii, dtype=float)
    g = history_growth(history, continuum["t"], continuum["radius"], LAM, grid)
    t_p = A.time_at_radius(history["t"], history["radius"], grid)
    t_c = A.time_at_radius(continuum["t"], continuum["radius"], grid)
    return [[f"{r:g}", f"{tp:.3f}", f"{tc:.3f}", f"{100 * dt:+.2f} %", f"{100 * ds:+.1f} %"]
            for r, tp, tc, dt, ds in zip(grid, t_p, t_c, g["t"], g["mean_stress"], strict=True)
            if np.isfinite(tp) and np.isfinite(tc)]


def ring_rows(rings: dict, radii=RADII) -> list[list[str]]:
    """The frame nearest each radius with a wavelength: its radius, wavelength, 1D reference.

    Radii with no such frame within ``NEAR`` are left out.
    """
    ok = np.isfinite(rings["wavelength"])
    R, w = rings["radius"][ok], rings["wavelength"][ok]
    rows = []
    for r in radii:
        i = int(np.argmin(np.abs(R - r))) if R.size else -1
        if i < 0 or abs(R[i] - r) > NEAR:
            continue
        rows.append([f"{r:g}", f"{R[i]:.1f}", f"{w[i]:.2f}",
                     f"{A.exact_wavelength(LAM, float(R[i])):.2f}"])
    return rows


def profile_rows(profile: dict, continuum: dict, radius: float) -> list[list[str]]:
    """Particle stress over continuum pressure, pooled in the bands of r / R."""
    p_c = np.interp(profile["r"], continuum["r"], continuum["pressure"])
    rows = []
    for lo, hi in BANDS:
        sel = (profile["r"] >= lo * radius) & (profile["r"] < hi * radius)
        w = profile["count"][sel]
        ratio = np.sum(w * profile["stress"][sel]) / np.sum(w * p_c[sel])
        rows.append([f"{lo:g}-{hi:g}", f"{int(w.sum()):,}", f"{100 * (ratio - 1):+.1f} %"])
    return rows


def central_stress(profile: dict, continuum: dict, radius: float) -> dict[str, float]:
    """p0 of the fit p0 - c r^2 over r < R/2 of the particle profile and of the continuum's.

    The same estimator on both (:func:`cases.analysis.profile_central_stress`; the continuum's
    annuli weighted alike), so that its bias (the neglected r^4 term) cancels in the ratio.
    """
    p = A.profile_central_stress(profile, radius)
    c = A.profile_central_stress({"r": continuum["r"], "stress": continuum["pressure"],
                                  "count": np.ones(continuum["r"].size)}, radius)
    return {"particles": p["central_fit"], "particles_se": p["central_fit_se"],
            "continuum": c["central_fit"]}


def main(argv: list[str] | None = None) -> str:
    """Print the tables of the module docstring; returns them."""
    ap = argparse.ArgumentParser(prog="python docs/measurements/colony_260.py",
                                 description=__doc__.split("\n")[0])
    ap.add_argument("--particles", type=Path, default=DATA / "particles_lam=0.001")
    ap.add_argument("--history", type=Path, default=None)
    ap.add_argument("--rings", type=Path, default=None)
    ap.add_argument("--progress", type=Path, default=None)
    ap.add_argument("--run", type=Path, default=None)
    ap.add_argument("--continuum", type=Path, default=DATA / "continuum_lam=0.001")
    args = ap.parse_args(argv)
    history_path = args.history or args.particles / "history.csv"
    rings_path = args.rings or args.particles / "rings.csv"
    progress_path = args.progress or args.particles / "progress.log"
    run_path = args.run or history_path.parent / "run.json"
    for path in (history_path, rings_path, progress_path, run_path,
                 args.continuum / "history.csv", args.continuum / "profile.csv",
                 args.continuum / "rings.csv"):
        if not path.is_file():
            ap.error(f"no file {path}")
    history, continuum = A.read_csv(history_path), A.read_csv(args.continuum / "history.csv")
    totals = session_totals(json.loads(run_path.read_text()))
    radius = float(history["radius"][-1])
    out = [f"Particle colony: radius {radius:.2f}, {int(history['n_particles'][-1]):,} cells, "
           f"t = {history['t'][-1]:.4f}, step {int(history['step'][-1])}.", "",
           A.markdown_rows(["R", "wall s", "cells", "a (W ~ R^a) since the previous R"],
                           cost_rows(A.progress_lines(progress_path))), "",
           f"{totals['sessions']} sessions: {totals['wall_s'] / 3600:.2f} h wall, "
           f"{totals['cpu_s'] / 3600:.2f} CPU h, peak {totals['peak_mb']:.0f} MB. Published: "
           f"R = {PUBLISHED['radius']}, {PUBLISHED['wall_h']:g} h on {PUBLISHED['cores']} cores "
           f"= {PUBLISHED['wall_h'] * PUBLISHED['cores']:.0f} core hours, "
           f"W ~ R^{PUBLISHED['exponent']:g}.", "",
           A.markdown_rows(["R", "t particles", "t continuum", "t_p / t_c - 1",
                            "mean stress / mean pressure - 1"], growth_rows(history, continuum)),
           ""]
    rings = A.read_csv(args.continuum / "rings.csv")["mean_radius"]
    out += [A.markdown_rows(["R", "frame radius", "wavelength", "1D reference"],
                            ring_rows(A.read_csv(rings_path))), "",
            f"Continuum at radius {continuum['radius'][-1]:.1f}: wavelength "
            f"{rings[-1] - rings[-2]:.3f}.", ""]
    pooled = args.particles / "profile_pooled.csv"
    if args.history is None and pooled.is_file():
        profile, cprof = A.read_csv(pooled), A.read_csv(args.continuum / "profile.csv")
        c = central_stress(profile, cprof, radius)
        out += [f"Central stress p0 (fit p0 - c r^2 over r < R/2): particles {c['particles']:.1f}"
                f" +- {c['particles_se']:.1f}, continuum {c['continuum']:.1f} by the same fit "
                f"(its largest pressure {continuum['max_pressure'][-1]:.1f}): "
                f"{100 * (c['particles'] / c['continuum'] - 1):+.1f} %.", "",
                A.markdown_rows(["r / R", "rods", "stress / pressure - 1"],
                                profile_rows(profile, cprof, radius)), ""]
    text = "\n".join(out)
    print(text)
    return text


if __name__ == "__main__":
    main()
