"""Particle boundary modes against the colony radius: does the particles' rate tend to theory.

At R = 8 (rods about 1/8 of the radius) particle colonies filled into ``star:K,EPS,R`` decay
at 39-81 % of the linear theory's rate (rods tangent to the edge) or 30-167 % (rods in rows),
while the continuum from the same star is within 0.8-3.7 % (cases.studies.stability, the
particle stage). :func:`radius_study` repeats that measurement at several radii R: per fill
orientation, mode K, radius and seed a particle colony filled into ``star:K,EPS,R`` (lengths
"stable") grows over [0, t_end] at ``lam`` (default 0, where the theory is -K/2 at every R; at
lam > 0 it depends on lam R^2 and comes from continuum.stability at the star's R), and its
mode rate is measured exactly as in the particle stage (cases.studies.stability: the alpha-shape
outline per trajectory frame, the mode-K amplitude about the area centroid, the least-squares
slope of its log over all frames; ``measured_late`` over t >= t_end / 2).

The reduction (:func:`reduce_ratios`, :func:`fit_ratios`): ratio = measured / theory per run;
per (fill, K, R) the seed mean, sample std and standard error; per (fill, K) two fits of the
seed means against R, each weighted by the standard errors (unweighted when one is 0):

- a power law abs(ratio - 1) = c R^a (only when every mean lies on the same side of 1), and
- a line in 1/R, ratio = r_inf + b / R, whose r_inf (with its standard error) is the ratio an
  infinitely large colony would have if the 1/R trend held;

and from each the radius from which on the fitted ratio stays within 10 % of 1 (``R10_power``,
``R10_linear``: inf when it never does, the smallest radius sampled when it already is).

Scales (:data:`RADIUS_SCALES`): "smoke" (R = 4, 5; K = 3; EPS = 0.2; one seed; tangent;
t_end = 0.5: seconds) and "medium" (R = 8, 16, 32; K = 2, 4, 6; seeds 1, 2, 3; both fills;
EPS = 0.15; t_end = 1). Output in ``out/data``: ``radius_rates.csv`` (one row per run),
``radius_ratios.csv`` (per fill, K, R), ``radius_fit.csv`` (per fill, K) and, from
:func:`plot`, ``radius_study.png``.

    python docs/measurements/stability_radius.py --scale medium --out runs/stability-radius \
        --workers 1
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from cases import analysis as A
from cases.studies.stability import _slope, theory_rate
from particles.packings import FILL_ORIENTATIONS

__all__ = ["RADIUS_SCALES", "boundary_rods", "outline", "mode_series", "radius_study",
           "reduce_ratios", "fit_ratios", "plot", "main"]

RADIUS_SCALES = {
    "smoke": dict(radii=(4.0, 5.0), ks=(3,), seeds=(1,), fills=("tangent",), eps=0.2,
                  t_end=0.5, output_every=0.1),
    "medium": dict(radii=(8.0, 16.0, 32.0), ks=(2, 4, 6), seeds=(1, 2, 3),
                   fills=("tangent", "rows"), eps=0.15, t_end=1.0, output_every=0.2),
    "R64": dict(radii=(64.0,), ks=(2, 4, 6), seeds=(1, 2, 3), fills=("tangent",), eps=0.15,
                t_end=1.0, output_every=0.05),
}
"""Radii, modes K, seeds, fill orientations, the star's EPS, t_end and frames every
``output_every`` of time of :func:`radius_study` per scale (lam = 0). "R64" (issue 42): the
next radius, tangent fill only, about 25 min a run on one core (18,700 rods at the start, the
step near 0.002 from the first steps); frames every 0.05, 21 of which MAX_FRAMES are outlined,
as at R = 32 (where 10 steps were 0.02-0.04)."""
WITHIN = 0.1
"""The fitted ratio is "within" theory when abs(ratio - 1) <= WITHIN."""

RATE_COLS = ("orientation", "K", "radius", "seed", "lam", "eps", "measured", "measured_late",
             "theory", "ratio", "ratio_late", "amplitude_start", "amplitude_end", "floor_end",
             "particles_start", "particles_end", "frames")


MAX_FRAMES = 13
"""At most this many trajectory frames (equally spaced in frame index, first and last kept) are
outlined per run: a radius-32 colony writes about 26 frames over [0, 1] and its alpha shape
takes seconds per frame; at R = 8 (about 11 frames) every frame is used, as in the particle
stage."""
MARGIN = 6.0
"""Rods whose centre lies deeper than MARGIN below the outermost centre of its angular sector
(and of the two neighbouring sectors) are left out of the outline (:func:`outline`)."""
SERIES = "mode_series_K{K}.csv"


def boundary_rods(x: np.ndarray, y: np.ndarray, margin: float = MARGIN,
                  sectors: int = 256) -> np.ndarray:
    """Mask of the rods within ``margin`` of the colony's edge.

    By angular sectors about the centroid of the centres: a rod is kept unless its radius is
    below the smallest of the largest radii of its sector and the two neighbouring ones minus
    ``margin``.

    The outer loop of an alpha shape depends only on the points within a few alpha of it
    (Delaunay triangles of circumradius < alpha whose circles hold no dropped point are kept,
    and no new triangle of circumradius < alpha forms farther than 2 alpha from a dropped
    point), so with a margin of several rod lengths plus 2 alpha the outline is unchanged
    (tested against the full one).
    """
    dx, dy = x - x.mean(), y - y.mean()
    r = np.hypot(dx, dy)
    k = np.floor((np.arctan2(dy, dx) + np.pi) / (2 * np.pi) * sectors).astype(int) % sectors
    rmax = np.full(sectors, -np.inf)
    np.maximum.at(rmax, k, r)
    rmax[~np.isfinite(rmax)] = np.inf  # an empty sector keeps its neighbours' rods
    low = np.minimum(np.minimum(rmax, np.roll(rmax, 1)), np.roll(rmax, -1))
    return r >= low[k] - margin


def outline(x, y, theta, length, margin: float | None = MARGIN) -> np.ndarray:
    """cases.handoff.particle_outline of the rods near the edge.

    The rods of :func:`boundary_rods` (all rods when ``margin`` is None).
    """
    from cases.handoff import particle_outline

    x, y, theta, length = (np.asarray(v, dtype=float) for v in (x, y, theta, length))
    if margin is not None:
        keep = boundary_rods(x, y, margin)
        x, y, theta, length = x[keep], y[keep], theta[keep], length[keep]
    return particle_outline(x, y, theta, length)


def mode_series(folder: str | Path, K: int, max_frames: int = MAX_FRAMES) -> dict[str, np.ndarray]:
    """t, the mode-K amplitude, its noise floor and N at up to ``max_frames`` frames of a run.

    As cases.studies.stability.particle_mode_series; cached in the run folder as
    ``mode_series_K{K}.csv``.
    """
    from cases.studies.stability import mode_amplitude, noise_floor
    from particles.output import read_trajectory

    cache = Path(folder) / SERIES.format(K=K)
    if cache.is_file():
        return A.read_csv(cache)
    frames = list(read_trajectory(Path(folder) / "trajectory.gsd"))
    idx = np.unique(np.round(np.linspace(0, len(frames) - 1, min(max_frames, len(frames))))
                    .astype(int))
    cols: dict[str, list] = {"t": [], "amplitude": [], "floor": [], "particles": []}
    for i in idx:
        fr = frames[i]
        o = outline(fr.x, fr.y, fr.theta, fr.length)
        cols["t"].append(fr.t)
        cols["amplitude"].append(mode_amplitude(o, K))
        cols["floor"].append(noise_floor(o, K))
        cols["particles"].append(len(fr.x))
    series = {k: np.asarray(v, dtype=float) for k, v in cols.items()}
    A.write_csv(cache, series)
    return series


def radius_study(  # noqa: PLR0913
    radii: Sequence[float], ks: Sequence[int], seeds: Sequence[int],
                 fills: Sequence[str], out: str | Path, runs: str | Path | None = None,
                 eps: float = 0.15, lam: float = 0.0, t_end: float = 1.0,
                 output_every: float = 0.2, scheduler: str | None = None,
                 n_workers: int = 1, finished_only: bool = False) -> Path:
    """Grow and measure every (fill, K, R, seed); the CSVs in ``out/data``, returned.

    radius_rates.csv, radius_ratios.csv and radius_fit.csv (module docstring).

    The particle runs (cases.sweep.run_engine through cases.sweep.sweep, one folder each under
    ``runs``, default ``out/runs``; finished runs are reused) are those of the particle stage of
    cases.studies.stability with the star's R varied; each run's mode series
    (:func:`mode_series`) is measured here, one run after the other, and cached in its folder
    (a script's own function cannot be sent to the sweep's worker processes). Runs are
    submitted smallest radius first and seed by seed within a radius; ``finished_only`` reduces
    the runs already finished and runs nothing (a stopped sweep's data).
    """
    from cases.sweep import is_done, run_engine, run_name, sweep

    bad = [f for f in fills if f not in FILL_ORIENTATIONS]
    if bad:
        raise ValueError(f"fills must be among {FILL_ORIENTATIONS}, got {bad}")
    out = Path(out)
    runs = Path(runs) if runs is not None else out / "runs"
    params = [dict(engine="particles", lam=float(lam), time=float(t_end), seed=int(seed),
                   shape=f"star:{int(K)},{eps:g},{float(R):g}", fill_lengths="stable",
                   fill_orientation=fill, output_every=float(output_every))
              for R in sorted(radii) for seed in seeds for fill in fills for K in ks]
    if finished_only:
        params = [p for p in params if is_done(runs / run_name(p), p)]
        folders = [runs / run_name(p) for p in params]
    else:
        folders = sweep(run_engine, params, runs, scheduler=scheduler,
                        n_workers=n_workers, progress=False)
    rows: dict[str, list] = {k: [] for k in RATE_COLS}
    theory: dict[tuple[int, float], float] = {}
    for p, folder in zip(params, folders, strict=True):
        K, _, R = (float(v) for v in p["shape"].split(":")[1].split(","))
        K = int(K)
        if (K, R) not in theory:
            theory[K, R] = theory_rate(K, lam, t_end, 11, R=R)
        s = mode_series(folder, K)
        log_amp = np.log(s["amplitude"])
        late = s["t"] >= 0.5 * t_end
        m, ml = _slope(s["t"], log_amp), _slope(s["t"][late], log_amp[late])
        row = dict(orientation=FILL_ORIENTATIONS.index(p["fill_orientation"]), K=K, radius=R,
                   seed=p["seed"], lam=lam, eps=eps, measured=m, measured_late=ml,
                   theory=theory[K, R], ratio=m / theory[K, R], ratio_late=ml / theory[K, R],
                   amplitude_start=s["amplitude"][0], amplitude_end=s["amplitude"][-1],
                   floor_end=s["floor"][-1], particles_start=s["particles"][0],
                   particles_end=s["particles"][-1], frames=len(s["t"]))
        for k in RATE_COLS:
            rows[k].append(row[k])
    data = out / "data"
    rates = {k: np.asarray(v, dtype=float) for k, v in rows.items()}
    order = np.lexsort((rates["seed"], rates["radius"], rates["K"], rates["orientation"]))
    rates = {k: v[order] for k, v in rates.items()}
    A.write_csv(data / "radius_rates.csv", rates)
    ratios = reduce_ratios(rates)
    A.write_csv(data / "radius_ratios.csv", ratios)
    A.write_csv(data / "radius_fit.csv", fit_ratios(ratios))
    return data


def reduce_ratios(rates: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Per (orientation, K, radius): the seed statistics of the ratio.

    Seeds, mean, std (sample), sem of ratio and of ratio_late, the theory, and ``measurable``
    (fraction of seeds whose end amplitude is above 3 floors).
    """
    cols = ("orientation", "K", "radius", "seeds", "theory", "mean", "std", "sem", "mean_late",
            "std_late", "sem_late", "measurable")
    out: dict[str, list] = {k: [] for k in cols}
    keys = sorted({(o, k, r) for o, k, r in zip(rates["orientation"], rates["K"],
                                                  rates["radius"], strict=True)})
    for o, k, r in keys:
        sel = (rates["orientation"] == o) & (rates["K"] == k) & (rates["radius"] == r)
        x, xl = rates["ratio"][sel], rates["ratio_late"][sel]
        n = int(sel.sum())
        sd = x.std(ddof=1) if n > 1 else math.nan
        sdl = xl.std(ddof=1) if n > 1 else math.nan
        ok = rates["amplitude_end"][sel] > 3.0 * rates["floor_end"][sel]
        for key, v in (("orientation", o), ("K", k), ("radius", r), ("seeds", n),
                       ("theory", rates["theory"][sel][0]), ("mean", x.mean()), ("std", sd),
                       ("sem", sd / math.sqrt(n) if n > 1 else math.nan),
                       ("mean_late", xl.mean()),
                       ("std_late", sdl), ("sem_late", sdl / math.sqrt(n) if n > 1 else math.nan),
                       ("measurable", ok.mean())):
            out[key].append(v)
    return {k: np.asarray(v, dtype=float) for k, v in out.items()}


def _wls(x: np.ndarray, y: np.ndarray, sigma: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Weighted least squares line y = p[0] x + p[1]; returns p and the standard errors.

    With ``sigma`` (all finite and > 0) the errors are those of the known sigmas, otherwise
    those of the residual scatter (nan with only two points).
    """
    X = np.column_stack([x, np.ones_like(x)])
    known = sigma is not None and np.all(np.isfinite(sigma)) and np.all(sigma > 0)
    w = 1.0 / sigma if known else np.ones_like(x)
    p, *_ = np.linalg.lstsq(X * w[:, None], y * w, rcond=None)
    cov = np.linalg.inv((X * w[:, None]).T @ (X * w[:, None]))
    if not known:
        dof = x.size - 2
        res = y - X @ p
        cov = cov * (res @ res / dof) if dof > 0 else cov * math.nan
    return p, np.sqrt(np.diag(cov))


def _r_within(r_inf: float, b: float, r_min: float) -> float:
    """Smallest R0 >= r_min with abs(r_inf + b / R - 1) <= WITHIN for every R >= R0 (or inf)."""
    d = r_inf - 1.0
    if abs(d) > WITHIN:
        return math.inf
    if abs(d + b / r_min) <= WITHIN:
        return r_min
    # |d| < WITHIN: the line enters the band at the edge on b's side
    edge = WITHIN if b > 0 else -WITHIN
    return float(b / (edge - d))


def fit_ratios(ratios: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Per (orientation, K): the power law and the 1/R line of the seed-mean ratio against R.

    One row per window: 0 the rates over [0, t_end] (``mean``, ``sem``), 1 the late half
    (``mean_late``, ``sem_late``). Columns: orientation, K, window, radii (how many), exponent
    a and its standard error, prefactor c (abs(ratio - 1) = c R^a; nan when the means straddle
    1), r_inf, its standard error and b (ratio = r_inf + b / R), R10_power, R10_linear (see the
    module docstring).
    """
    cols = ("orientation", "K", "window", "radii", "exponent", "exponent_se", "prefactor", "r_inf",
            "r_inf_se", "slope_inv_R", "R10_power", "R10_linear")
    out: dict[str, list] = {k: [] for k in cols}
    keys = sorted({(o, k, w) for o, k in zip(ratios["orientation"], ratios["K"], strict=True)
                   for w in (0, 1)})
    for o, k, window in keys:
        sel = (ratios["orientation"] == o) & (ratios["K"] == k)
        mcol, scol = ("mean", "sem") if window == 0 else ("mean_late", "sem_late")
        R, m, se = ratios["radius"][sel], ratios[mcol][sel], ratios[scol][sel]
        idx = np.argsort(R)
        R, m, se = R[idx], m[idx], se[idx]
        d = m - 1.0
        if R.size >= 2 and (np.all(d > 0) or np.all(d < 0)):
            (a, lnc), (a_se, _) = _wls(np.log(R), np.log(np.abs(d)), se / np.abs(d))
            c = math.exp(lnc)
            r10p = (float(R[0]) if c * R[0] ** a <= WITHIN
                    else (WITHIN / c) ** (1.0 / a) if a < 0 else math.inf)
        else:
            a = a_se = c = r10p = math.nan
        if R.size >= 2:
            (b, r_inf), (_, r_inf_se) = _wls(1.0 / R, m, se)
            r10l = _r_within(float(r_inf), float(b), float(R[0]))
        else:
            b = r_inf = r_inf_se = r10l = math.nan
        for key, v in (("orientation", o), ("K", k), ("window", window), ("radii", R.size),
                       ("exponent", a),
                       ("exponent_se", a_se), ("prefactor", c), ("r_inf", r_inf),
                       ("r_inf_se", r_inf_se), ("slope_inv_R", b), ("R10_power", r10p),
                       ("R10_linear", r10l)):
            out[key].append(v)
    return {k: np.asarray(v, dtype=float) for k, v in out.items()}


def markdown(data: str | Path) -> str:
    """The tables of radius_ratios.csv (ratio mean ± std per fill, K, R) and radius_fit.csv."""
    data = Path(data)
    q = A.read_csv(data / "radius_ratios.csv")
    f = A.read_csv(data / "radius_fit.csv")
    rows = [(FILL_ORIENTATIONS[int(o)], int(k), f"{r:g}", int(n), f"{t:.2f}",
             f"{m:.3f} ± {s:.3f}", f"{ml:.3f} ± {sl:.3f}", f"{ok:.2f}")
            for o, k, r, n, t, m, s, ml, sl, ok in zip(
                q["orientation"], q["K"], q["radius"], q["seeds"], q["theory"], q["mean"],
                q["std"], q["mean_late"], q["std_late"], q["measurable"], strict=True)]
    head = ("fill", "K", "R", "seeds", "theory", "ratio [0, t_end]", "ratio late half",
            "measurable")
    frows = [(FILL_ORIENTATIONS[int(o)], int(k), ("[0, t_end]", "late half")[int(w)],
              f"{a:+.2f} ± {ase:.2f}", f"{ri:.3f} ± {rse:.3f}", f"{r10p:.3g}", f"{r10l:.3g}")
             for o, k, w, a, ase, ri, rse, r10p, r10l in zip(
                 f["orientation"], f["K"], f["window"], f["exponent"], f["exponent_se"],
                 f["r_inf"], f["r_inf_se"], f["R10_power"], f["R10_linear"], strict=True)]
    fhead = ("fill", "K", "window", "exponent a (abs(ratio - 1) ~ R^a)",
             "r_inf (ratio = r_inf + b/R)", "R10 power law", "R10 1/R line")
    return A.markdown_rows(head, rows) + "\n\n" + A.markdown_rows(fhead, frows) + "\n"


def plot(data: str | Path, out: str | Path) -> list[Path]:
    """radius_study.png: ratio measured / theory against R per K (colour) and fill (panel).

    Seed mean ± std (a white centre: most seeds' mode below 3 noise floors at t_end), with the
    1/R line fit (dashed) and the band within 10 % of 1.
    """
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    from cases.figures.draw import save_figure

    data, out = Path(data), Path(out)
    q = A.read_csv(data / "radius_ratios.csv")
    f = A.read_csv(data / "radius_fit.csv")
    codes = sorted(set(q["orientation"]))
    modes = sorted(set(q["K"]))
    fig, axes = plt.subplots(1, len(codes), figsize=(4.6 * len(codes), 3.6), squeeze=False,
                             sharey=True)
    for ax, code in zip(axes[0], codes, strict=True):
        ax.axhspan(1 - WITHIN, 1 + WITHIN, color="0.9", label="within 10 % of theory")
        ax.axhline(1.0, color="k", lw=0.8)
        for j, k in enumerate(modes):
            c = plt.cm.viridis(j / max(1, len(modes)))
            s = (q["orientation"] == code) & (q["K"] == k)
            x = q["radius"][s] * (1 + 0.03 * (j - 1))
            ax.errorbar(x, q["mean"][s], yerr=q["std"][s], fmt="o", color=c, capsize=3,
                        label=f"K = {k:g}")
            low = q["measurable"][s] < 0.5  # most seeds at the noise floor by t_end: open
            ax.plot(x[low], q["mean"][s][low], "o", color="w", ms=3, zorder=5)
            fs = (f["orientation"] == code) & (f["K"] == k) & (f["window"] == 0)
            if fs.any() and np.isfinite(f["r_inf"][fs][0]):
                rr = np.geomspace(q["radius"][s].min(), 4 * q["radius"][s].max(), 50)
                ax.plot(rr, f["r_inf"][fs][0] + f["slope_inv_R"][fs][0] / rr, "--", color=c,
                        lw=0.8)
        ax.set(xscale="log", xlabel="initial radius R",
               title=f"{FILL_ORIENTATIONS[int(code)]} fill")
        ax.set_xticks(sorted(set(q["radius"])), [f"{r:g}" for r in sorted(set(q["radius"]))])
        ax.xaxis.set_minor_formatter(NullFormatter())
    axes[0][0].set_ylabel("rate / theory (-K/2)")
    axes[0][0].legend(fontsize=7)
    return save_figure(fig, out / "radius_study", formats=("png",), dpi=110)


def main(argv: Sequence[str] | None = None) -> Path:
    """Command line: run a scale of :data:`RADIUS_SCALES`, or redraw from ``--from-data``."""
    ap = argparse.ArgumentParser(prog="python docs/measurements/stability_radius.py",
                                 description=__doc__.split("\n")[0])
    ap.add_argument("--scale", choices=sorted(RADIUS_SCALES), default="smoke")
    ap.add_argument("--out", default="runs/stability-radius")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--from-data", default=None, help="redraw from this data folder only")
    ap.add_argument("--runs", default=None, help="folder of the runs (default OUT/runs)")
    ap.add_argument("--finished-only", action="store_true",
                    help="reduce the finished runs of the scale, run nothing")
    args = ap.parse_args(argv)
    out = Path(args.out)
    if args.from_data is None:
        data = radius_study(out=out, runs=args.runs, n_workers=args.workers,
                            finished_only=args.finished_only, **RADIUS_SCALES[args.scale])
    else:
        data = Path(args.from_data)
    plot(data, out)
    (out / "radius_results.md").write_text(markdown(data))
    print((out / "radius_results.md").read_text())
    return data


if __name__ == "__main__":
    main()
