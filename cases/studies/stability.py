"""Shape stability of a circular colony: measured mode rates of the continuum against linear theory.

A disc of radius R perturbed to r = R (1 + eps cos K theta) (a dense polygon passed to the
continuum as ``polygon:FILE.csv``) is grown from t = 0 to ``t_end``; at ``samples`` equally
spaced times the relative amplitude of mode K of the boundary radius about the area centroid
(:func:`mode_amplitude`) is measured, and the measured rate is the least-squares slope of
ln amplitude against t. The theory (continuum.stability) gives ln eps(t) / eps(0) =
int sigma(K, lam, R(s)) ds along the disc radius R(s) (continuum.radial); the same slope fitted
to it at the same times is the theoretical rate (lam = 0: -K/2 exactly). Each (K, lam) is run at
the node counts of the scale, so the table shows the convergence of the rate error with the
boundary spacing h and its observed order.

Rates depend on lam through lam R^2 only at a fixed number of nodes per radius, so the study
grows discs of radius R = 10 (lam R^2 = 0.1 and 1 for lam = 1e-3, 1e-2: rates 1.5 % and 13 %
away from -K/2) on meshes sized by node count (h_max large: the mesh scales with R).

Scales: "smoke" (K = 3; lam = 0, 1e-2; 300 and 600 nodes; t_end = 0.4: seconds), "medium"
(K = 2..8; lam = 0, 1e-3, 1e-2; 1000, 2000, 4000 nodes; t_end = 1: minutes) and "paper"
(2000, 8000, 32000 nodes: an hour). Output: ``out/data/rates.csv`` (K, lam, measured, theory,
relative error, h, nodes), ``out/data/orders.csv`` (observed order of the rate error per K,
lam) and, from ``plot``, ``stability.png`` / ``.pdf`` and ``results.md``.

Particle colonies (when ``"particles"`` is in ``engines``; :func:`particle_stage`). A colony
filled into ``star:K,EPS,R`` (cases.shapes.initial_particles; lengths "stable", the
asynchronous length distribution, so that no synchronous division burst falls in the window, as
a "birth" fill would at t = ln 2) grows over [0, t_end] for several seeds (one seed drives both
the fill's lengths and the division noise). Per trajectory frame the outline is the alpha shape
of the rods (cases.handoff.particle_outline) and its mode-K amplitude about the area centroid is
:func:`mode_amplitude`; the rate per seed is the least-squares slope of ln amplitude against t
(all frames; ``measured_late``: the frames of the second half of the window). A particle
boundary is rough at the rod scale, so EPS is large (0.15-0.2) and nonlinear terms O(EPS) are
not negligible: the continuum is run from the same EPS for comparison (``continuum_same_eps``).
The noise floor of a frame is the median amplitude of the modes 2..16 that are not multiples of
K; a mode counts as measurable at the end when its amplitude is above 3 floors. Output:
``out/data/particle_rates.csv`` (one row per K, lam, seed), ``particle_amplitudes.csv`` (the
time series), ``particle_modes.csv`` (mean and seed spread per K, lam against the theory and the
continuum) and, from ``plot``, ``particle_modes.png`` / ``.pdf``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline

from cases import analysis as A
from continuum import stability
from continuum.mesh import boundary_spacing, polygon_area
from continuum.simulation import Config, Simulation
from particles.output import read_trajectory
from particles.packings import FILL_ORIENTATIONS

__all__ = [
    "SCALES",
    "star_polygon",
    "area_centroid",
    "mode_amplitude",
    "measure_rate",
    "theory_rate",
    "observed_orders",
    "PARTICLE_SCALES",
    "noise_floor",
    "particle_mode_series",
    "particle_stage",
    "compute",
    "plot",
]

SCALES = {
    "smoke": dict(modes=(3,), lams=(0.0, 1e-2), n_nodes=(300, 600), t_end=0.4, samples=5),
    "medium": dict(modes=tuple(range(2, 9)), lams=(0.0, 1e-3, 1e-2), n_nodes=(1000, 2000, 4000),
                   t_end=1.0, samples=11),
    "paper": dict(modes=tuple(range(2, 9)), lams=(0.0, 1e-3, 1e-2),
                  n_nodes=(2000, 8000, 32000), t_end=1.0, samples=11),
}
PARTICLE_SCALES = {
    "smoke": dict(modes=(3,), lams=(0.0,), seeds=(1, 2), radius=5.0, eps=0.2, t_end=0.5,
                  output_every=0.2, continuum_nodes=300, orientations=("tangent",)),
    "medium": dict(modes=(2, 3, 4, 5, 6, 8), lams=(0.0, 1e-2), seeds=(1, 2, 3), radius=8.0,
                   eps=0.15, t_end=1.0, output_every=0.2, continuum_nodes=600,
                   orientations=("tangent", "rows")),
    "paper": dict(modes=tuple(range(2, 9)), lams=(0.0, 1e-3, 1e-2), seeds=tuple(range(1, 9)),
                  radius=10.0, eps=0.15, t_end=1.0, output_every=0.2, continuum_nodes=2000,
                  orientations=("tangent", "rows")),
}
"""The particle stage per scale: modes K, lams, seeds, the star's R and EPS, t_end, frames every
``output_every`` of time, the node count of the continuum run from the same star, and the rods'
orientations of the fill (particles.packings.FILL_ORIENTATIONS; in the CSVs the column
``orientation`` is the index in it: 0 tangent, 1 rows)."""
RADIUS = 10.0
"""Initial disc radius of the study."""
EPS = 0.01
"""Initial relative amplitude of the mode."""


def star_polygon(K: int, eps: float, R: float, n: int = 2048) -> np.ndarray:
    """The n vertices of r = R (1 + eps cos K theta) at theta_j = 2 pi j / n (counter-clockwise)."""
    th = 2.0 * np.pi * np.arange(n) / n
    r = R * (1.0 + eps * np.cos(K * th))
    return np.column_stack([r * np.cos(th), r * np.sin(th)])


def area_centroid(xy: np.ndarray) -> np.ndarray:
    """Area centroid of a polygon.

    c = (1 / 6A) sum_k (x_k + x_{k+1}) (x_k y_{k+1} - x_{k+1} y_k), and likewise in y.
    """
    x, y = xy[:, 0], xy[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    six_a = 6.0 * polygon_area(xy)
    return np.array([np.sum((x + xn) * cross), np.sum((y + yn) * cross)]) / six_a


def mode_amplitude(boundary: np.ndarray, K: int, n_samples: int = 4096) -> float:
    """Relative amplitude abs(r_K) / r_0 of mode K of the boundary radius about the centroid.

    r(theta) is the periodic cubic spline through the boundary nodes in polar angle about the
    area centroid (the outline must be star-shaped about it), sampled at ``n_samples`` equal
    angles; r_k are its Fourier coefficients, r(theta) = r_0 + sum_k (r_k e^{i k theta} + c.c.),
    so that r = R (1 + eps cos K theta) gives eps (up to O(eps^2)).
    """
    d = boundary - area_centroid(boundary)
    th = np.mod(np.arctan2(d[:, 1], d[:, 0]), 2.0 * np.pi)
    order = np.argsort(th)
    th, r = th[order], np.hypot(d[order, 0], d[order, 1])
    if np.any(np.diff(th) <= 0):
        raise ValueError("boundary is not star-shaped about its centroid")
    spline = CubicSpline(np.append(th, th[0] + 2 * np.pi), np.append(r, r[0]),
                         bc_type="periodic")
    c = np.fft.rfft(spline(th[0] + 2 * np.pi * np.arange(n_samples) / n_samples)) / n_samples
    return float(2.0 * abs(c[K]) / abs(c[0]))


def _slope(t: np.ndarray, y: np.ndarray) -> float:
    return float(np.polyfit(t, y, 1)[0])


def measure_rate(K: int, lam: float, n_nodes: int, t_end: float, samples: int,  # noqa: PLR0913
                 folder: Path, R: float = RADIUS, eps: float = EPS, remesh: bool = False,
                 **config) -> dict:
    """Grow the perturbed disc and fit its mode-K rate; a row of rates.csv (without theory).

    The initial polygon is written to ``folder/star_K.csv``; ``config`` overrides fields of
    the continuum Config (default: node count ``n_nodes``, h_max = 1e3 so that the mesh is
    sized by the node count alone, no fields written). ``remesh``: rebuild the mesh after every
    sample (boundary resampled to equal spacing; a controlled experiment of
    docs/measurements/boundary_modes.py).

    Returns
    -------
    dict
        K, lam, measured (the slope of ln amplitude), h (boundary spacing at t = 0),
        n_boundary, nodes (at t = 0), t (sample times), log_amplitude, spacing_spread
        (std / mean of the boundary edge lengths at t_end).
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    poly = star_polygon(K, eps, R)
    csv = folder / f"star_{K}.csv"
    np.savetxt(csv, np.vstack([poly, poly[:1]]), delimiter=",", header="x,y", comments="",
               fmt="%.17g")
    cfg = dict(lam=lam, shape=f"polygon:{csv}", n_nodes=int(n_nodes), h_max=1e3,
               write_fields=False) | config
    sim = Simulation(Config(**cfg))
    s = sim.state
    h, nb, nodes = s.h_mesh, s.n_boundary, len(s.points)
    times = np.linspace(0.0, t_end, samples)
    amp = [mode_amplitude(s.boundary, K)]
    for t in times[1:]:
        amp.append(mode_amplitude(sim.advance(time=float(t)).boundary, K))
        if remesh:
            sim.remesh()
    log_amp = np.log(amp)
    edges = boundary_spacing(sim.state.boundary)
    return dict(K=K, lam=lam, measured=_slope(times, log_amp), h=h, n_boundary=nb, nodes=nodes,
                t=times, log_amplitude=log_amp, spacing_spread=float(edges.std() / edges.mean()))


def theory_rate(K: int, lam: float, t_end: float, samples: int, R: float = RADIUS) -> float:
    """The theoretical rate: the slope of ln eps(t) fitted at the sample times of measure_rate.

    ln eps(t) / eps(0) from continuum.stability.amplitude_ratio along the disc's R(t)
    (lam = 0: -K/2).
    """
    times = np.linspace(0.0, t_end, samples)
    return _slope(times, stability.amplitude_ratio(K, lam, R, times))


def observed_orders(rates: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Observed order of the absolute relative error in h per (K, lam): slope of ln err vs ln h."""
    out: dict[str, list] = {"K": [], "lam": [], "order": [], "error_finest": []}
    keys = sorted({(int(k), float(lam)) for k, lam in zip(rates["K"], rates["lam"], strict=True)})
    for k, lam in keys:
        sel = (rates["K"] == k) & (rates["lam"] == lam)
        h, err = rates["h"][sel], np.abs(rates["relative_error"][sel])
        order = _slope(np.log(h), np.log(err)) if len(h) > 1 and np.all(err > 0) else math.nan
        out["K"].append(k)
        out["lam"].append(lam)
        out["order"].append(order)
        out["error_finest"].append(float(rates["relative_error"][sel][np.argmin(h)]))
    return {k: np.asarray(v, dtype=float) for k, v in out.items()}


FLOOR_MODES = 16
"""Highest mode of the noise floor (:func:`noise_floor`)."""


def noise_floor(boundary: np.ndarray, K: int, k_max: int = FLOOR_MODES) -> float:
    """Median relative amplitude of the modes k = 2..k_max that are not multiples of K.

    A circle's outline of rods has amplitudes of order (roughness / R) / sqrt(boundary rods) in
    every mode; the multiples of K are left out as the mode's nonlinear harmonics.
    """
    ks = [k for k in range(2, k_max + 1) if k % K]
    return float(np.median([mode_amplitude(boundary, k) for k in ks]))


def particle_mode_series(folder: Path, K: int) -> dict[str, np.ndarray]:
    """t, the mode-K amplitude, its noise floor and N per frame of a particle run's trajectory.

    The outline of a frame is cases.handoff.particle_outline of its rods.
    """
    from cases.handoff import particle_outline

    cols: dict[str, list] = {"t": [], "amplitude": [], "floor": [], "particles": []}
    for fr in read_trajectory(Path(folder) / "trajectory.gsd"):
        outline = particle_outline(fr.x, fr.y, fr.theta, fr.length)
        cols["t"].append(fr.t)
        cols["amplitude"].append(mode_amplitude(outline, K))
        cols["floor"].append(noise_floor(outline, K))
        cols["particles"].append(len(fr.x))
    return {k: np.asarray(v, dtype=float) for k, v in cols.items()}


def _seed_summary(rates: dict[str, np.ndarray], sel: np.ndarray) -> dict:
    """Seed count, mean and sample standard deviation of the rates of the rows ``sel``.

    Also the fraction of seeds whose end amplitude is above 3 noise floors (``measurable``).
    """
    m, ml = rates["measured"][sel], rates["measured_late"][sel]
    ok = rates["amplitude_end"][sel] > 3.0 * rates["floor_end"][sel]
    return dict(seeds=int(sel.sum()), mean=m.mean(),
                std=m.std(ddof=1) if m.size > 1 else math.nan, mean_late=ml.mean(),
                std_late=ml.std(ddof=1) if ml.size > 1 else math.nan, measurable=ok.mean())


def particle_stage(scale: str, out: Path, runs: Path, scheduler: str | None = None,
                   n_workers: int = 2) -> Path:
    """The particle colonies of PARTICLE_SCALES[scale]: particle_rates.csv, particle_modes.csv.

    The runs (cases.sweep.run_engine, one folder per K, lam, seed under ``runs/particles``,
    reused when finished) go through cases.sweep.sweep; the continuum from the same star
    (``continuum_nodes`` nodes) runs here. Returns the data folder ``out/data``.
    """
    from cases.sweep import run_engine, sweep

    cfg = PARTICLE_SCALES[scale]
    R, eps, t_end = cfg["radius"], cfg["eps"], cfg["t_end"]
    params = [dict(engine="particles", lam=float(lam), time=t_end, seed=int(seed),
                   shape=f"star:{K},{eps:g},{R:g}", fill_lengths="stable",
                   fill_orientation=orientation, output_every=cfg["output_every"])
              for orientation in cfg["orientations"] for lam in cfg["lams"]
              for K in cfg["modes"] for seed in cfg["seeds"]]
    folders = sweep(run_engine, params, runs / "particles", scheduler=scheduler,
                    n_workers=n_workers, progress=False)
    rate_cols = ("orientation", "K", "lam", "seed", "radius", "eps", "measured", "measured_late",
                 "amplitude_start", "amplitude_end", "floor_end", "particles_start",
                 "particles_end")
    rates: dict[str, list] = {k: [] for k in rate_cols}
    series: dict[str, list] = {k: [] for k in ("orientation", "K", "lam", "seed", "t",
                                                "amplitude", "floor", "particles")}
    for p, folder in zip(params, folders, strict=True):
        K = int(p["shape"].split(":")[1].split(",")[0])
        s = particle_mode_series(folder, K)
        log_amp = np.log(s["amplitude"])
        late = s["t"] >= 0.5 * t_end
        code = FILL_ORIENTATIONS.index(p["fill_orientation"])
        row = dict(orientation=code, K=K, lam=p["lam"], seed=p["seed"], radius=R, eps=eps,
                   measured=_slope(s["t"], log_amp),
                   measured_late=_slope(s["t"][late], log_amp[late]),
                   amplitude_start=s["amplitude"][0], amplitude_end=s["amplitude"][-1],
                   floor_end=s["floor"][-1], particles_start=s["particles"][0],
                   particles_end=s["particles"][-1])
        for k in rate_cols:
            rates[k].append(row[k])
        n = len(s["t"])
        for k, v in (("orientation", code), ("K", K), ("lam", p["lam"]), ("seed", p["seed"])):
            series[k].extend([v] * n)
        for k in ("t", "amplitude", "floor", "particles"):
            series[k].extend(s[k])
    data = out / "data"
    rates_arr = {k: np.asarray(v, dtype=float) for k, v in rates.items()}
    A.write_csv(data / "particle_rates.csv", rates_arr)
    A.write_csv(data / "particle_amplitudes.csv",
                {k: np.asarray(v, dtype=float) for k, v in series.items()})
    summary: dict[str, list] = {k: [] for k in (
        "orientation", "K", "lam", "seeds", "mean", "std", "mean_late", "std_late", "theory",
        "continuum_same_eps", "measurable")}
    continuum = {(K, lam): measure_rate(K, lam, cfg["continuum_nodes"], t_end, 11,
                                        runs / "continuum-same-eps", R=R, eps=eps)["measured"]
                 for lam in cfg["lams"] for K in cfg["modes"]}
    for orientation in cfg["orientations"]:
        code = FILL_ORIENTATIONS.index(orientation)
        for lam in cfg["lams"]:
            for K in cfg["modes"]:
                sel = ((rates_arr["orientation"] == code) & (rates_arr["K"] == K)
                       & (rates_arr["lam"] == lam))
                row = _seed_summary(rates_arr, sel)
                row |= dict(orientation=code, K=K, lam=lam,
                            theory=theory_rate(K, lam, t_end, 11, R=R),
                            continuum_same_eps=continuum[K, lam])
                for k in summary:
                    summary[k].append(row[k])
    A.write_csv(data / "particle_modes.csv",
                {k: np.asarray(v, dtype=float) for k, v in summary.items()})
    return data


def compute(scale: str = "smoke", out: str | Path = "runs/case-stability-smoke",
            scheduler: str | None = None, n_workers: int = 2, runs: str | Path | None = None,
            engines: tuple[str, ...] = ("continuum",), finished_only: tuple[str, ...] = ()
            ) -> Path:
    """Measure every (K, lam, node count) of ``scale`` and write out/data/rates.csv, orders.csv.

    With "continuum" in ``engines``: the continuum runs, short, one after another in this
    process. With "particles": the particle stage (:func:`particle_stage`, its runs through
    ``scheduler`` / ``n_workers``). ``runs``: the folder of the initial polygons and the
    particle runs, default out/runs. ``finished_only`` is accepted for the case interface and
    not used (the particle runs here are short).
    """
    if scale not in SCALES:
        raise ValueError(f"scale must be one of {', '.join(SCALES)}, got {scale!r}")
    bad = [e for e in engines if e not in ("continuum", "particles")]
    if bad or not engines:
        raise ValueError(f"engines must be a non-empty subset of ('continuum', 'particles'), "
                         f"got {tuple(engines)!r}")
    cfg = SCALES[scale]
    out = Path(out)
    folder = Path(runs) if runs is not None else out / "runs"
    data = out / "data"
    if "particles" in engines:
        particle_stage(scale, out, folder, scheduler=scheduler, n_workers=n_workers)
    if "continuum" not in engines:
        return data
    cols: dict[str, list] = {k: [] for k in ("K", "lam", "measured", "theory", "relative_error",
                                             "h", "h_over_R", "n_boundary", "nodes")}
    for lam in cfg["lams"]:
        for K in cfg["modes"]:
            theory = theory_rate(K, lam, cfg["t_end"], cfg["samples"])
            for n in cfg["n_nodes"]:
                row = measure_rate(K, lam, n, cfg["t_end"], cfg["samples"], folder)
                row |= dict(theory=theory, relative_error=row["measured"] / theory - 1.0,
                            h_over_R=row["h"] / RADIUS)
                for k in cols:
                    cols[k].append(row[k])
    rates = {k: np.asarray(v, dtype=float) for k, v in cols.items()}
    A.write_csv(data / "rates.csv", rates)
    A.write_csv(data / "orders.csv", observed_orders(rates))
    return data


def markdown_table(data: str | Path) -> str:
    """rates.csv and orders.csv as markdown tables (the docs' table)."""
    rates = A.read_csv(Path(data) / "rates.csv")
    orders = A.read_csv(Path(data) / "orders.csv")
    rows = [(int(k), f"{lam:g}", int(nodes), f"{h:.4f}", f"{m:.4f}", f"{t:.4f}", f"{100 * e:+.2f}")
            for k, lam, nodes, h, m, t, e in zip(rates["K"], rates["lam"], rates["nodes"],
                                                   rates["h_over_R"], rates["measured"],
                                                   rates["theory"], rates["relative_error"],
                                                   strict=True)]
    head = ("K", "lam", "nodes", "h/R", "measured", "theory", "error %")
    orow = [(int(k), f"{lam:g}", f"{o:.2f}", f"{100 * e:+.2f}")
            for k, lam, o, e in zip(orders["K"], orders["lam"], orders["order"],
                                    orders["error_finest"], strict=True)]
    return (A.markdown_rows(head, rows) + "\n\n"
            + A.markdown_rows(("K", "lam", "observed order", "error % (finest)"), orow) + "\n")


def particle_table(data: str | Path) -> str:
    """particle_modes.csv as a markdown table (the docs' table)."""
    m = A.read_csv(Path(data) / "particle_modes.csv")
    rows = [(FILL_ORIENTATIONS[int(o)], int(k), f"{lam:g}", int(n), f"{mu:.3f} ± {sd:.3f}",
             f"{ml:.3f} ± {sl:.3f}", f"{t:.3f}", f"{c:.3f}", f"{ok:.2f}")
            for o, k, lam, n, mu, sd, ml, sl, t, c, ok in zip(
                m["orientation"], m["K"], m["lam"], m["seeds"], m["mean"], m["std"],
                m["mean_late"], m["std_late"], m["theory"], m["continuum_same_eps"],
                m["measurable"], strict=True)]
    head = ("fill", "K", "lam", "seeds", "particles [0, t_end]", "particles late half", "theory",
            "continuum same eps", "measurable")
    return A.markdown_rows(head, rows) + "\n"


def plot_particles(data: str | Path, out: str | Path) -> list[Path]:
    """The particle figure particle_modes.png / .pdf.

    (A) rates vs K: seed mean and spread per fill orientation and lam, theory, continuum from
    the same star; (B) the amplitude against t of every seed at the first lam (solid: the
    first orientation, dashed: the second), with the noise floor of the first (dotted).
    """
    import matplotlib.pyplot as plt

    from cases.figures.draw import save_figure

    data, out = Path(data), Path(out)
    m = A.read_csv(data / "particle_modes.csv")
    amp = A.read_csv(data / "particle_amplitudes.csv")
    rates = A.read_csv(data / "particle_rates.csv")
    fig, (ax, ts) = plt.subplots(1, 2, figsize=(11, 4.2))
    lams = sorted(set(m["lam"]))
    codes = sorted(set(m["orientation"]))
    for i, lam in enumerate(lams):
        c = plt.cm.viridis(i / max(1, len(lams)))
        sel = (m["lam"] == lam) & (m["orientation"] == codes[0])
        ax.plot(m["K"][sel], m["theory"][sel], "-_", ms=14, color=c,
                label=rf"theory $\lambda$ = {lam:g}")
        ax.plot(m["K"][sel], m["continuum_same_eps"][sel], "s", color=c, mfc="none",
                label="continuum, same star")
        for j, code in enumerate(codes):
            sel = (m["lam"] == lam) & (m["orientation"] == code)
            ax.errorbar(m["K"][sel] + 0.1 * (2 * i + j - 1), m["mean"][sel], yerr=m["std"][sel],
                        fmt="oD"[j % 2], color=c, capsize=3, mfc=c if j == 0 else "none",
                        label=f"particles, {FILL_ORIENTATIONS[int(code)]} fill")
    modes = sorted(set(amp["K"]))
    for n, k in enumerate(modes):
        c = plt.cm.plasma(n / max(1, len(modes)))
        for j, code in enumerate(codes):
            for seed in sorted(set(amp["seed"])):
                s = ((amp["K"] == k) & (amp["lam"] == lams[0]) & (amp["seed"] == seed)
                     & (amp["orientation"] == code))
                first = seed == amp["seed"].min() and j == 0
                ts.semilogy(amp["t"][s], amp["amplitude"][s], "-" if j == 0 else "--", color=c,
                            lw=1, label=f"K = {k:g}" if first else None)
                if j == 0:
                    ts.semilogy(amp["t"][s], amp["floor"][s], ":", color=c, lw=0.7)
    R, eps = rates["radius"][0], rates["eps"][0]
    ax.set(xlabel="mode K", ylabel=r"rate $d\,\ln\epsilon/dt$",
           title=rf"(A) particle colonies from star R = {R:g}, $\epsilon$ = {eps:g}")
    ts.set(xlabel="t", ylabel=r"mode amplitude $\epsilon_K$",
           title=rf"(B) every seed, $\lambda$ = {lams[0]:g} (dotted: noise floor)")
    ax.legend(fontsize=6)
    ts.legend(fontsize=7, ncol=2)
    return save_figure(fig, out / "particle_modes")


def plot(data: str | Path, out: str | Path) -> list[Path]:
    """Write results.md and the figures from the CSVs in ``data`` (those present).

    stability.png, .pdf (from rates.csv): (A) rates vs K, measured (finest mesh) and theory,
    per lam; (B) the absolute relative error vs h/R per K and lam, with an h^2 guide.
    particle_modes.png, .pdf (from particle_modes.csv): :func:`plot_particles`.
    """
    data, out = Path(data), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    has_continuum = (data / "rates.csv").is_file()
    has_particles = (data / "particle_modes.csv").is_file()
    if not (has_continuum or has_particles):
        raise FileNotFoundError(f"no rates.csv or particle_modes.csv in {data}")
    md = markdown_table(data) if has_continuum else ""
    paths = plot_particles(data, out) if has_particles else []
    if has_particles:
        md += ("\n" if md else "") + particle_table(data)
    (out / "results.md").write_text(md)
    if has_continuum:
        paths = plot_continuum(data, out) + paths
    return paths


def plot_continuum(data: Path, out: Path) -> list[Path]:
    """stability.png / .pdf from rates.csv (see :func:`plot`)."""
    import matplotlib.pyplot as plt

    from cases.figures.draw import save_figure

    rates = A.read_csv(data / "rates.csv")
    fig, (ax, conv) = plt.subplots(1, 2, figsize=(11, 4.2))
    lams = sorted(set(rates["lam"]))
    modes = sorted(set(rates["K"]))
    for i, lam in enumerate(lams):
        c = plt.cm.viridis(i / max(1, len(lams)))
        sel = rates["lam"] == lam
        fine = sel & (rates["h"] == np.array([rates["h"][sel & (rates["K"] == k)].min()
                                               for k in rates["K"]]))
        ax.plot(rates["K"][fine], rates["theory"][fine], "-", color=c,
                label=rf"theory $\lambda$ = {lam:g}")
        ax.plot(rates["K"][fine], rates["measured"][fine], "o", color=c, mfc="none",
                label="measured (finest)")
        for j, k in enumerate(modes):
            s = sel & (rates["K"] == k)
            conv.loglog(rates["h_over_R"][s], np.abs(rates["relative_error"][s]),
                        "o-" if i == 0 else "s--", color=plt.cm.plasma(j / len(modes)),
                        label=f"K = {k:g}" if i == 0 else None)
    hh = np.array([rates["h_over_R"].min(), rates["h_over_R"].max()])
    err_max = np.abs(rates["relative_error"]).max()
    conv.loglog(hh, err_max * (hh / hh[-1]) ** 2, "k:", label=r"$h^2$")
    ax.set(xlabel="mode K", ylabel=r"rate $d\,\ln\epsilon/dt$",
           title=f"(A) mode rates, disc R = {RADIUS:g}")
    conv.set(xlabel="boundary spacing h / R", ylabel="|relative rate error|",
             title=r"(B) convergence (circles $\lambda$ = 0, squares $\lambda$ > 0)")
    ax.legend(fontsize=7)
    conv.legend(fontsize=7, ncol=2)
    return save_figure(fig, out / "stability")
