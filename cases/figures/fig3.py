"""Fig 3 of the paper: mechanics of growth, particles against continuum.

(A) radially averaged particle stress <sigma_n> (solid; pooled over the last frames, during which
    the colony grows by less than one particle length) and continuum pressure p (dashed), for
    lam = 0 and the three lam of Fig 2;
(B) colony radius R(t) of both models (particles solid, continuum dashed);
(C) maximum stress vs lam: particles (max of the averaged stress profile), continuum (max p),
    and the analytic p(0) = (2/lam) ln(1/(8c)) of a disc of the final radius, with fitted
    power-law exponents;
(D) final growth rate dR/dt (linear fit of the last 20 % of the run) vs lam with the asymptote
    sqrt(2/lam) and the exact disc speed 4 c R at the final radius.

Scale: "smoke" (radius 15, lam in {0.03, 0.1, 0.3} and 0; about a minute on 2 cores) or
"paper" (radius 150, lam in {0, 1e-4, 1e-3, 1e-2} and the seven scaling values of
cases.sweep.SCALES; hours per particle run). ``compute`` runs (or reuses) the engine runs and
writes the small CSVs behind every curve to ``out/data``; ``plot`` draws the figure from those
CSVs only (``colony case fig3 --from-data`` redraws from cases/data/fig3).

Engines and committed data as for every figure case (``cases.sweep.case_runs``, docs/DESIGN.md):
``engines=("continuum",)`` draws the continuum alone, ``--engines finished`` reuses finished
particle runs only; data in cases/data/fig3 (radius 40) and fig3_paper (radius 150).
"""

from __future__ import annotations

import math
from functools import partial
from pathlib import Path

import numpy as np

from cases import analysis as A
from cases.datasets import ensemble_data
from cases.sweep import ENGINES, compute_case, engine_pairs, scale_config
from continuum import radial

__all__ = ["compute", "reduce", "plot", "runs_needed"]

LATE_FRACTION = 0.2


def runs_needed(scale: str, engines: tuple[str, ...] = ENGINES
                ) -> tuple[list[float], list[tuple[str, float]]]:
    """(lam values of the figure, (engine, lam) runs) at ``scale``."""
    cfg = scale_config(scale)
    lams = sorted({0.0, *cfg["lams"], *cfg["scaling_lams"]})
    return lams, engine_pairs(lams, engines)


def compute(scale: str = "smoke", out: str | Path | None = None, **options) -> Path:
    """Run (or reuse) Fig 3's engine runs and reduce them to ``out/data``.

    :func:`cases.sweep.compute_case` with ``options`` as there; the profiles are written for
    lam = 0 and the lam of Fig 2.
    """
    profile_lams = sorted({0.0, *scale_config(scale)["lams"]})
    return compute_case("fig3", runs_needed, partial(reduce, profile_lams=profile_lams), scale,
                        out, **options)


def reduce(folders: dict[tuple[str, float], Path], data: Path,
           profile_lams: list[float]) -> Path:
    """Reduce run folders {(engine, lam): folder} to the CSVs of the figure in ``data``.

    The continuum runs are required; a lam without its particle run gets nan in the particle
    columns of ``summary.csv`` and no particle CSVs (continuum-only scales).
    """
    data = Path(data)
    lams = sorted({lam for _, lam in folders})
    rows: dict[str, list] = {k: [] for k in SUMMARY}
    for lam in lams:
        row = _continuum_row(folders["continuum", lam], lam, data, lam in profile_lams)
        fp = folders.get(("particles", lam))
        row |= (_particle_row(fp, lam, data, lam in profile_lams) if fp is not None
                else dict.fromkeys(PARTICLE_COLUMNS, math.nan))
        for k in SUMMARY:
            rows[k].append(row[k])
    A.write_csv(data / "summary.csv", rows)
    return data


PARTICLE_COLUMNS = ("radius_particles", "max_stress_particles", "slope_particles")
SUMMARY = ("lam", "radius_continuum", "radius_particles", "max_stress_particles",
           "max_pressure_continuum", "p0_exact", "slope_particles", "slope_continuum",
           "slope_exact", "slope_asymptotic")


def _continuum_row(folder: Path, lam: float, data: Path, profile: bool) -> dict[str, float]:
    """Write R(t) (and the final profile) of a continuum run; its columns of the summary."""
    hc = A.read_csv(folder / "history.csv")
    A.write_csv(data / f"radius_continuum_lam={lam:g}.csv",
                A.thin_rows({"t": hc["t"], "radius": hc["radius"],
                             "max_pressure": hc["max_pressure"]}))
    if profile:
        A.write_csv(data / f"profile_continuum_lam={lam:g}.csv", A.final_continuum_profile(folder))
    R_c = float(hc["radius"][-1])
    return {"lam": lam, "radius_continuum": R_c,
            "max_pressure_continuum": float(hc["max_pressure"][-1]),
            "p0_exact": radial.max_pressure(R_c, lam),
            "slope_continuum": A.late_slope(hc["t"], hc["radius"], LATE_FRACTION),
            "slope_exact": radial.radius_rate(R_c, lam),
            "slope_asymptotic": math.sqrt(2.0 / lam) if lam > 0 else math.nan}


def _particle_row(folder: Path, lam: float, data: Path, profile: bool) -> dict[str, float]:
    """Write R(t) (and the pooled final profile) of a particle run; its summary columns."""
    hp = A.read_csv(folder / "history.csv")
    A.write_csv(data / f"radius_particles_lam={lam:g}.csv",
                A.thin_rows({"t": hp["t"], "radius": hp["radius"],
                             "max_stress": hp["max_stress"]}))
    pp = A.final_particle_profile(folder, growth_window=1.0)
    if profile:
        A.write_csv(data / f"profile_particles_lam={lam:g}.csv", pp)
    return {"radius_particles": float(hp["radius"][-1]),
            "max_stress_particles": A.max_value(pp["stress"]),
            "slope_particles": A.late_slope(hp["t"], hp["radius"], LATE_FRACTION)}


def _lam_files(data: Path, prefix: str) -> dict[float, Path]:
    out = {}
    for p in data.glob(f"{prefix}_lam=*.csv"):
        out[float(p.stem.split("lam=")[1])] = p
    return dict(sorted(out.items()))


def _seeds(ens: Path) -> str:
    """How many seeds the ensemble's lam have: "4", or the range "2-4" when they differ."""
    n = A.read_csv(ens / "summary.csv")["n_seeds"].astype(int)
    return f"{n.min()}" if n.min() == n.max() else f"{n.min()}-{n.max()}"


def _band_lams(ens: Path) -> str:
    """The lam of the ensemble (every lam of the figure, or the few grown at radius 150)."""
    lams = A.read_csv(ens / "summary.csv")["lam"]
    return "lam " + ", ".join(f"{lam:g}" for lam in lams) if lams.size < 4 else "every lam"


def _seed_bars(ax, ens: Path, key: str, lams: np.ndarray) -> None:
    """The ensemble's 2.5-97.5 % seed range of ``key`` at each lam > 0 of ``lams`` (grey bars).

    Only the lam the figure draws: the ensemble may hold others (radius 40: lam = 1e-4).
    """
    s = A.read_csv(ens / "summary.csv")
    pos = (s["lam"] > 0) & np.isin(s["lam"], lams)
    lo, hi = s[f"{key}_q025"][pos], s[f"{key}_q975"][pos]
    ax.vlines(s["lam"][pos], lo, hi, color="0.4", lw=3, alpha=0.5,
              label=f"particles, {_seeds(ens)} seeds: 2.5-97.5 %")


def _asymptote(a, lam: np.ndarray) -> None:
    """The late growth speed (2/lam)^(1/2) over the range of ``lam`` (none when empty)."""
    if lam.size:
        lg = np.logspace(np.log10(lam.min()), np.log10(lam.max()), 50)
        a.plot(lg, np.sqrt(2 / lg), "k--", label=r"$(2/\lambda)^{1/2}$")


def _blank_without_lam(axes, lam: np.ndarray) -> None:
    """Blank the panels against lam when the data have no lam > 0 (``--lams 0``)."""
    if lam.size:
        return
    for a in axes:
        a.clear()
        a.set_axis_off()
        a.text(0.5, 0.5, r"no $\lambda > 0$ in these data", ha="center", va="center",
               transform=a.transAxes)


def plot(data: str | Path, out: str | Path) -> list[Path]:
    """Draw Fig 3 (PNG and PDF in ``out``) from the CSVs in ``data`` only.

    Where the seed ensemble's data lie beside ``data`` (cases.datasets.ensemble_data:
    cases/data/ensemble for cases/data/fig3, OUT/ensemble for OUT/data) at the same radius, the
    particle curves get its seed bands (2.5-97.5 % of the seeds) and panels C, D its seed ranges.
    """
    import matplotlib.pyplot as plt

    from cases.figures.draw import note_missing_engines, plain_log_ticks, save_figure

    data, out = Path(data), Path(out)
    summary = A.read_csv(data / "summary.csv")
    ens = ensemble_data(data, float(summary["radius_continuum"][0]))
    fig, ax = plt.subplots(2, 2, figsize=(10, 8))
    prof_lams = sorted(_lam_files(data, "profile_continuum"))
    colors = {lam: plt.cm.plasma(i / max(1, len(prof_lams))) for i, lam in enumerate(prof_lams)}

    a = ax[0, 0]
    for lam in prof_lams:
        pc = A.read_csv(data / f"profile_continuum_lam={lam:g}.csv")
        a.plot(pc["r"], pc["pressure"], "--", color=colors[lam], label=rf"$\lambda$ = {lam:g}")
        if (path := data / f"profile_particles_lam={lam:g}.csv").exists():
            pp = A.read_csv(path)
            a.plot(pp["r"], pp["stress"], "-", color=colors[lam])
        if ens is not None and (path := ens / f"profile_lam={lam:g}.csv").exists():
            pe = A.read_csv(path)
            a.fill_between(pe["r"], pe["stress_q025"], pe["stress_q975"], color=colors[lam],
                           alpha=0.2, lw=0)
    a.set(xlabel="r", ylabel=r"$\langle\sigma_n\rangle$ (solid), $p$ (dashed)",
          title="(A)" + (f" bands: {_seeds(ens)} seeds, 2.5-97.5 % ({_band_lams(ens)})"
                         if ens else ""))
    a.legend(fontsize=8)

    a = ax[0, 1]
    for lam in prof_lams:
        hc = A.read_csv(data / f"radius_continuum_lam={lam:g}.csv")
        a.plot(hc["t"], hc["radius"], "--", color=colors[lam], label=rf"$\lambda$ = {lam:g}")
        if (path := data / f"radius_particles_lam={lam:g}.csv").exists():
            hp = A.read_csv(path)
            a.plot(hp["t"], hp["radius"], "-", color=colors[lam])
        if ens is not None and (path := ens / f"radius_lam={lam:g}.csv").exists():
            he = A.read_csv(path)
            a.fill_between(he["t"], he["radius_q025"], he["radius_q975"], color=colors[lam],
                           alpha=0.25, lw=0)
    a.set(xlabel="t", ylabel="R(t)", yscale="log", title="(B) particles solid, continuum dashed")
    a.legend(fontsize=8)

    pos = summary["lam"] > 0
    lam = summary["lam"][pos]
    a = ax[1, 0]
    for key, style, label in (("max_stress_particles", "o", "particles"),
                              ("max_pressure_continuum", "s", "continuum"),
                              ("p0_exact", "k--", r"analytic $p(0)$")):
        y = summary[key][pos]
        if not np.isfinite(y).any():
            continue
        try:
            expo, _ = A.power_law_fit(lam, y)
            label = f"{label} (slope {expo:.2f})"
        except ValueError:
            pass
        a.plot(lam, y, style, mfc="none", label=label)
    if ens is not None:
        _seed_bars(a, ens, "central_max", lam)
    a.set(xscale="log", yscale="log", xlabel=r"$\lambda$", ylabel="max stress", title="(C)")
    if pos.any():  # lam = 0 alone leaves (C) empty
        a.legend(fontsize=8)

    a = ax[1, 1]
    for key, style, label in (("slope_particles", "o", "particles"),
                              ("slope_continuum", "s", "continuum")):
        if np.isfinite(summary[key][pos]).any():
            a.plot(lam, summary[key][pos], style, mfc="none", label=label)
    if ens is not None:
        _seed_bars(a, ens, "slope", lam)
    a.plot(lam, summary["slope_exact"][pos], "k:", label=r"disc $4cR$ at final $R$")
    _asymptote(a, lam)
    a.set(xscale="log", yscale="log", xlabel=r"$\lambda$", ylabel=r"$dR/dt$ at $t_f$",
          title="(D)")
    a.legend(fontsize=8)
    _blank_without_lam(ax[1], lam)
    plain_log_ticks(fig)
    fig.tight_layout()
    note_missing_engines(fig, {e for e in ENGINES if np.isfinite(summary[f"slope_{e}"]).any()})
    return save_figure(fig, out / "fig3")
