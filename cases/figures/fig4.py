"""Fig 4 of the paper: dynamics of size inhomogeneity (the rings).

(A) radially averaged particle length <l_n> in equal-area annuli at the final time, with a
    one-standard-deviation band, for the three lam of Fig 2; continuum dashed: the mean length
    of the transported Psi over the annulus, column mean_length_psi, its band the standard
    deviation of the lengths of all the annulus' cells, length_std_psi
    (cases.analysis.continuum_profile), and beside it, dotted, the closed form
    2^frac(<G>/ln 2) of the annulus mean of the growth phase (mean_length_phase) as the check.
    Data made before the Psi columns existed: the closed form with the band lbar s_G (the
    azimuthal spread s_G of G carried by d lbar / dG = lbar); older still: the annulus mean of
    lbar and its spread;
(B) ring wavelength against time, continuum (lines): difference of the two outermost rings,
    the contours G = k ln 2 of the growth phase (cases.analysis.continuum_wavelength_series,
    continuum.rings), where lbar = 2^frac(G/ln 2) peaks; particles (open circles): distance
    between the last two peaks of the radial mean-length profile (cases.analysis.ring_wavelength);
(C) final wavelength against lam for both models and the converged 1D radial reference
    (difference of the two outermost ring radii G(r) = k ln 2 of continuum.radial.ring_radii at
    the continuum's final radius, the same definition as the continuum's;
    cases.analysis.exact_wavelength), with the lam^(-1/2)
    law and fitted exponents; a particle colony without rings (ring coherence
    z < cases.analysis.RING_Z) is drawn apart and left out of the particle fit (its
    "wavelength" is peak-finder noise).

``rings_continuum_lam=*.csv``: the final ring table of each continuum run (columns of
continuum.rings.COLUMNS) with ``radius_exact``, the 1D reference's radius of the same ring k at
the continuum's final radius (nan where the reference has no such ring;
cases.analysis.exact_rings).

Scale: "smoke" (radius 15, lam in {0.03, 0.1, 0.3}; about a minute on 2 cores, runs shared with
the other cases through a common ``runs`` folder) or "paper" (radius 150, lam in
{1e-4, 1e-3, 1e-2} and the scaling values of cases.sweep.SCALES; hours). ``compute`` writes the
CSVs behind every curve to ``out/data``; ``plot`` draws from those CSVs only.

Engines and committed data as for every figure case (``cases.sweep.case_runs``, docs/DESIGN.md):
``engines=("continuum",)`` draws the continuum alone, ``--engines finished`` reuses finished
particle runs only; data in cases/data/fig4 (radius 40) and fig4_paper (radius 150).
"""

from __future__ import annotations

import math
from functools import partial
from pathlib import Path

import numpy as np

from cases import analysis as A
from cases.analysis.rings import exact_rings, exact_wavelength
from cases.datasets import ensemble_data
from cases.sweep import ENGINES, compute_case, engine_pairs, scale_config

__all__ = ["compute", "reduce", "plot", "runs_needed"]


def runs_needed(scale: str, engines: tuple[str, ...] = ENGINES
                ) -> tuple[list[float], list[tuple[str, float]]]:
    """(lam values, (engine, lam) runs) at ``scale``."""
    cfg = scale_config(scale)
    lams = sorted({*cfg["lams"], *cfg["scaling_lams"]})
    return lams, engine_pairs(lams, engines)


def compute(scale: str = "smoke", out: str | Path | None = None, **options) -> Path:
    """Run (or reuse) Fig 4's engine runs and reduce them to ``out/data``.

    :func:`cases.sweep.compute_case` with ``options`` as there; the profiles and wavelength
    series are written for the lam of Fig 2.
    """
    profile_lams = list(scale_config(scale)["lams"])
    return compute_case("fig4", runs_needed, partial(reduce, profile_lams=profile_lams), scale,
                        out, **options)


def reduce(folders: dict[tuple[str, float], Path], data: Path,
           profile_lams: list[float]) -> Path:
    """Reduce run folders {(engine, lam): folder} to the CSVs of the figure in ``data``.

    The continuum runs are required; a lam without its particle run gets nan in the particle
    columns of ``summary.csv`` and no particle CSVs (continuum-only scales).
    """
    data = Path(data)
    lams = sorted({lam for _, lam in folders})
    rows = {k: [] for k in ("lam", "radius_continuum", "radius_particles",
                            "wavelength_continuum", "wavelength_particles", "wavelength_exact",
                            "ring_z_particles")}
    for lam in lams:
        for engine in ENGINES:
            if (engine, lam) not in folders:
                rows[f"radius_{engine}"].append(math.nan)
                rows[f"wavelength_{engine}"].append(math.nan)
                continue
            w = WAVELENGTH_SERIES[engine](folders[engine, lam])
            rows[f"radius_{engine}"].append(float(w["radius"][-1]))
            rows[f"wavelength_{engine}"].append(float(w["wavelength"][-1]))
            if lam in profile_lams:
                A.write_csv(data / f"wavelength_{engine}_lam={lam:g}.csv", A.thin_rows(w))
                A.write_csv(data / f"profile_{engine}_lam={lam:g}.csv",
                            _final_profile(folders[engine, lam], engine))
            if engine == "continuum":
                rings = A.continuum_rings(folders[engine, lam])
                rings["radius_exact"] = exact_rings(rings, lam, float(w["radius"][-1]))
                A.write_csv(data / f"rings_continuum_lam={lam:g}.csv", rings, fmt="%.10g")
        rows["ring_z_particles"].append(A.final_ring_coherence(folders["particles", lam])[1]
                                        if ("particles", lam) in folders else math.nan)
        rows["lam"].append(lam)
        rows["wavelength_exact"].append(exact_wavelength(lam, rows["radius_continuum"][-1]))
    A.write_csv(data / "summary.csv", rows)
    return data


#: Ring wavelength at every frame of a run, per engine.
WAVELENGTH_SERIES = {"continuum": A.continuum_wavelength_series,
                     "particles": A.particle_wavelength_series}


def _final_profile(folder: Path, engine: str) -> dict[str, np.ndarray]:
    """Final radial mean-length profile: the last frame only (no pooling: rings move)."""
    if engine == "continuum":
        return A.final_continuum_profile(folder)
    return A.final_particle_profile(folder, growth_window=0.0)


def _lams(data: Path, prefix: str) -> list[float]:
    return sorted(float(p.stem.split("lam=")[1]) for p in data.glob(f"{prefix}_lam=*.csv"))


def _seed_band(ax, ens: Path | None, lam: float, color) -> None:
    """The ensemble's 2.5-97.5 % seed band of the final mean-length profile (dash-dot)."""
    if ens is None or not (path := ens / f"profile_lam={lam:g}.csv").exists():
        return
    pe = A.read_csv(path)
    for q in ("mean_length_q025", "mean_length_q975"):
        ax.plot(pe["r"], pe[q], "-.", color=color, lw=0.8)


def _seed_bars(ax, ens: Path) -> None:
    """The ensemble's 2.5-97.5 % seed range of the final wavelength (lam with rings)."""
    e = A.read_csv(ens / "summary.csv")
    if "wavelength_q025" not in e:  # an ensemble of records without frames (ensemble_paper)
        return
    pos = (e["lam"] > 0) & (e["ring_z_mean"] >= A.RING_Z)
    n = int(np.max(e["n_seeds"]))
    ax.vlines(e["lam"][pos], e["wavelength_q025"][pos], e["wavelength_q975"][pos],
              color="0.4", lw=3, alpha=0.5, label=f"particles, {n} seeds: 2.5-97.5 %")


def plot(data: str | Path, out: str | Path) -> list[Path]:
    """Draw Fig 4 (PNG and PDF in ``out``) from the CSVs in ``data`` only.

    With the seed ensemble's data beside ``data`` (as for Fig 3) panel A adds its 2.5-97.5 %
    seed band of the mean length (dash-dot) and panel C its seed range of the wavelength (lam
    whose mean ring coherence is at least RING_Z).
    """
    import matplotlib.pyplot as plt

    from cases.figures.draw import note_missing_engines, plain_log_ticks, save_figure

    data, out = Path(data), Path(out)
    ens = ensemble_data(data, float(A.read_csv(data / "summary.csv")["radius_continuum"][0]))
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.5))
    lams = sorted({*_lams(data, "profile_particles"), *_lams(data, "profile_continuum")})
    colors = {lam: plt.cm.viridis(i / max(1, len(lams))) for i, lam in enumerate(lams)}

    a = ax[0]
    for lam in lams:
        label = rf"$\lambda$ = {lam:g}"
        for engine, style in (("particles", "-"), ("continuum", "--")):
            if not (path := data / f"profile_{engine}_lam={lam:g}.csv").exists():
                continue
            p = A.read_csv(path)
            ok = p["count"] > 0
            r, m, s = p["r"][ok], p["mean_length"][ok], p["mean_length_std"][ok]
            if "mean_length_psi" in p:  # continuum: the transported Psi, the closed form beside
                m, s = p["mean_length_psi"][ok], p["length_std_psi"][ok]
                a.plot(r, p["mean_length_phase"][ok], ":", color=colors[lam], lw=0.8)
            elif "mean_length_phase" in p:  # older data: 2^frac(<G>/ln 2), spread lbar s_G
                m = p["mean_length_phase"][ok]
                s = m * p["G_std"][ok]
            a.plot(r, m, style, color=colors[lam], lw=1, label=label)
            label = None
            a.fill_between(r, m - s, m + s, color=colors[lam], alpha=0.2, lw=0)
        _seed_band(a, ens, lam, colors[lam])
    a.set(xlabel="r", ylabel=r"$\langle \ell_n \rangle$ $\pm$ 1 s.d.",
          title="(A) final time: particles solid, continuum dashed\n"
                r"(dotted: $2^{\mathrm{frac}(\langle G\rangle/\ln 2)}$)"
                + ("\ndash-dot: 2.5-97.5 % of the ensemble's seeds" if ens else ""))
    a.legend(fontsize=8)

    a = ax[1]
    for lam in _lams(data, "wavelength_continuum"):
        c = colors.get(lam, "k")
        wc = A.read_csv(data / f"wavelength_continuum_lam={lam:g}.csv")
        a.plot(wc["t"], wc["wavelength"], "-", color=c, label=rf"$\lambda$ = {lam:g}")
        wp_path = data / f"wavelength_particles_lam={lam:g}.csv"
        if wp_path.exists():
            wp = A.read_csv(wp_path)
            a.plot(wp["t"], wp["wavelength"], "o", color=c, mfc="none", ms=3)
    a.set(xlabel="t", ylabel="wavelength", yscale="log",
          title="(B) continuum lines, particles circles")
    a.legend(fontsize=8)

    a = ax[2]
    s = A.read_csv(data / "summary.csv")
    rings = s.get("ring_z_particles", np.full(s["lam"].shape, np.inf)) >= A.RING_Z
    if np.isfinite(s["wavelength_particles"][~rings]).any():
        a.plot(s["lam"][~rings], s["wavelength_particles"][~rings], "x", color="0.6",
               label=f"particles, no rings (z < {A.RING_Z:g})")
    for key, style, label in (("wavelength_particles", "o", "particles"),
                              ("wavelength_continuum", "s", "continuum"),
                              ("wavelength_exact", "k.", "radial reference")):
        lam, w = s["lam"], s[key]
        if key == "wavelength_particles":
            lam, w = lam[rings], w[rings]
        if not np.isfinite(w).any():
            continue
        try:
            expo, _ = A.power_law_fit(lam, w)
            label = f"{label} (slope {expo:.2f})"
        except ValueError:
            pass
        a.plot(lam, w, style, mfc="none", label=label)
    if ens is not None:
        _seed_bars(a, ens)
    ok = np.isfinite(s["wavelength_exact"]) & (s["wavelength_exact"] > 0)
    if ok.any():
        C = np.exp(np.mean(np.log(s["wavelength_exact"][ok] * np.sqrt(s["lam"][ok]))))
        lg = np.logspace(np.log10(s["lam"].min()), np.log10(s["lam"].max()), 50)
        a.plot(lg, C / np.sqrt(lg), "k--", lw=0.8, label=r"$\propto\lambda^{-1/2}$")
    a.set(xscale="log", yscale="log", xlabel=r"$\lambda$", ylabel="final wavelength",
          title="(C)")
    a.legend(fontsize=8)
    plain_log_ticks(fig)
    fig.tight_layout()
    note_missing_engines(fig, {e for e in ENGINES if np.isfinite(s[f"radius_{e}"]).any()})
    return save_figure(fig, out / "fig4")
