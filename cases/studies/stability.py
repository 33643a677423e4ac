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

__all__ = [
    "SCALES",
    "star_polygon",
    "area_centroid",
    "mode_amplitude",
    "measure_rate",
    "theory_rate",
    "observed_orders",
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
    cases.bench.boundary_modes).

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


def compute(scale: str = "smoke", out: str | Path = "runs/case-stability-smoke",
            scheduler: str | None = None, n_workers: int = 2, runs: str | Path | None = None,
            engines: tuple[str, ...] = ("continuum",), finished_only: tuple[str, ...] = ()
            ) -> Path:
    """Measure every (K, lam, node count) of ``scale`` and write out/data/rates.csv, orders.csv.

    The runs are short and run one after another in this process (``scheduler``,
    ``n_workers``, ``engines`` and ``finished_only`` are accepted for the case interface and
    not used: the study is continuum only; ``runs`` is the folder of the initial polygons,
    default out/runs).
    """
    if scale not in SCALES:
        raise ValueError(f"scale must be one of {', '.join(SCALES)}, got {scale!r}")
    cfg = SCALES[scale]
    out = Path(out)
    folder = Path(runs) if runs is not None else out / "runs"
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
    data = out / "data"
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


def plot(data: str | Path, out: str | Path) -> list[Path]:
    """Write results.md and the figure (stability.png, .pdf) from the CSVs in ``data``.

    (A) rates vs K, measured (finest mesh) and theory, per lam; (B) the absolute relative
    error vs h/R per K and lam, with an h^2 guide.
    """
    import matplotlib.pyplot as plt

    from cases.figures.draw import save_figure

    data, out = Path(data), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "results.md").write_text(markdown_table(data))
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
