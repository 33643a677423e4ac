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
(B) ring wavelength against time, continuum (lines): the two outermost rings' distance, the
    contours G = k ln 2 of the growth phase (continuum.rings), where lbar = 2^frac(G/ln 2)
    peaks; particles (open circles): the two outermost significant peaks of the radial
    mean-length profile; both by one rule (cases.analysis.rings: a wavelength only with two
    rings inside the colony, outside the edge layer; particle peaks of significance z >=
    RING_SIGNIFICANCE); filled: the final value with its error bar (:func:`error_bar`);
(C) final wavelength against lam for both models and the converged 1D radial reference
    (continuum.radial.ring_radii at the continuum's final radius, the same rule;
    cases.analysis.exact_ring_measure), with the lam^(-1/2) law and each model's fitted
    exponent with its 95 % interval on its measured wavelengths only
    (cases.analysis.power_law_interval, weighted by the error bars).

``summary.csv`` has both wavelengths of every engine (``wavelength_*``: the two outermost
rings, the paper's; ``spacing_*``: the mean spacing of the rings in the outer half), their
spreads (RING_COLUMNS, NOISE_COLUMNS; ``*_seed_sd_particles`` where seeds were measured) and
the particles' ring coherence ``ring_z_particles`` (information only).

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
from cases.analysis.rings import exact_rings
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


#: The ring columns of ``summary.csv`` per engine (cases.analysis.rings): the wavelength of
#: the two outermost rings and the mean spacing in the outer half, each with its
#: frame-to-frame spread over the last division period (``_sd``), and the number of rings;
#: the particles add the spread under their annulus noise (``_noise_sd``).
RING_COLUMNS = ("wavelength", "wavelength_sd", "spacing", "spacing_sd", "rings")
NOISE_COLUMNS = ("wavelength_noise_sd", "spacing_noise_sd")


def summary_names() -> list[str]:
    """The columns of ``summary.csv``."""
    return ["lam", *(f"{c}_{e}" for e in ENGINES for c in ("radius", *RING_COLUMNS)),
            *(f"{c}_particles" for c in NOISE_COLUMNS), "wavelength_exact", "spacing_exact",
            "ring_z_particles"]


def reduce(folders: dict[tuple[str, float], Path], data: Path,
           profile_lams: list[float]) -> Path:
    """Reduce run folders {(engine, lam): folder} to the CSVs of the figure in ``data``.

    The continuum runs are required; a lam without its particle run gets nan in the particle
    columns of ``summary.csv`` and no particle CSVs (continuum-only scales).
    """
    data = Path(data)
    lams = sorted({lam for _, lam in folders})
    names = summary_names()
    rows: dict[str, list] = {k: [] for k in names}
    for lam in lams:
        row = dict.fromkeys(names, math.nan) | {"lam": lam}
        for engine in ENGINES:
            if (engine, lam) not in folders:
                continue
            w = WAVELENGTH_SERIES[engine](folders[engine, lam])
            final = A.final_wavelength(w)
            row[f"radius_{engine}"] = float(w["radius"][-1])
            for key, col in (("wavelength", "wavelength"), ("mean_spacing", "spacing")):
                row[f"{col}_{engine}"] = final[key]
                row[f"{col}_sd_{engine}"] = final[f"{key}_sd"]
            row[f"rings_{engine}"] = final["rings"]
            if lam in profile_lams:
                A.write_csv(data / f"wavelength_{engine}_lam={lam:g}.csv", A.thin_rows(w))
            # the final profile: written for the lam of Fig 4A, the particles' noise spread
            profile = (_final_profile(folders[engine, lam], engine)
                       if lam in profile_lams or engine == "particles" else None)
            if lam in profile_lams:
                A.write_csv(data / f"profile_{engine}_lam={lam:g}.csv", profile)
            if engine == "continuum":
                rings = A.continuum_rings(folders[engine, lam])
                rings["radius_exact"] = exact_rings(rings, lam, float(w["radius"][-1]))
                A.write_csv(data / f"rings_continuum_lam={lam:g}.csv", rings, fmt="%.10g")
            else:
                row |= noise_spread(profile, row["radius_particles"])
                row["ring_z_particles"] = A.final_ring_coherence(folders[engine, lam])[1]
        exact = A.exact_ring_measure(lam, row["radius_continuum"])
        row["wavelength_exact"], row["spacing_exact"] = exact.outer_pair, exact.mean_spacing
        for k in names:
            rows[k].append(row[k])
    A.write_csv(data / "summary.csv", rows)
    return data


def noise_spread(profile: dict[str, np.ndarray], radius: float) -> dict[str, float]:
    """The particle columns NOISE_COLUMNS: :func:`cases.analysis.ring_uncertainty`."""
    spread = A.ring_uncertainty(profile, radius)
    return {"wavelength_noise_sd_particles": spread["outer_pair_sd"],
            "spacing_noise_sd_particles": spread["mean_spacing_sd"]}


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


def error_bar(summary: dict[str, np.ndarray], engine: str) -> np.ndarray:
    """The error bar of a final wavelength: the largest of its spreads present.

    Over the last division period's frames, under the annulus noise and over seeds (0 if none).
    """
    cols = [f"wavelength_{k}_{engine}" for k in ("sd", "noise_sd", "seed_sd")]
    spreads = [np.asarray(summary[c], float) for c in cols if c in summary]
    if not spreads:
        return np.zeros(np.shape(summary["lam"]))
    return np.nan_to_num(np.fmax.reduce(spreads))


def with_seed_spread(summary: dict[str, np.ndarray], ens: Path | None) -> dict[str, np.ndarray]:
    """``summary`` with ``wavelength_seed_sd_particles`` from the seed ensemble beside it.

    The ensemble's standard deviation over its seeds of the particle wavelength at each lam it
    has (``wavelength_std``; nan elsewhere); ``summary`` unchanged if it has the column already
    (data remeasured with their seeds) or no ensemble lies beside it.
    """
    if ens is None or "wavelength_seed_sd_particles" in summary:
        return summary
    e = A.read_csv(ens / "summary.csv")
    sd = dict(zip(e["lam"].tolist(), e["wavelength_std"].tolist(), strict=True))
    return summary | {"wavelength_seed_sd_particles":
                      np.array([sd.get(lam, math.nan) for lam in summary["lam"].tolist()])}


def slope_label(name: str, lam: np.ndarray, w: np.ndarray, err: np.ndarray | None) -> str:
    """``name (slope a [lo, hi])`` of the measured wavelengths (A.power_law_interval)."""
    try:
        a, lo, hi, _ = A.power_law_interval(lam, w, None if err is None else
                                            np.where(err > 0, err, np.nan))
    except ValueError:  # fewer than two measured wavelengths
        return name
    if not np.isfinite(lo):
        return f"{name} (slope {a:.2f})"
    return f"{name} (slope {a:.2f} [{lo:.2f}, {hi:.2f}])"


def plot(data: str | Path, out: str | Path) -> list[Path]:
    """Draw Fig 4 (PNG and PDF in ``out``) from the CSVs in ``data`` only.

    With the seed ensemble's data beside ``data`` (as for Fig 3) panel A adds its 2.5-97.5 %
    seed band of the mean length (dash-dot). Panels B and C draw measured wavelengths only
    (two rings or more, cases.analysis.count_rings) with their error bars (:func:`error_bar`);
    a particle series written before the rule (no ``rings`` column) is not drawn. The
    particles' error bars take the ensemble's seed spread where it has the lam
    (:func:`with_seed_spread`).
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

    s = with_seed_spread(A.read_csv(data / "summary.csv"), ens)
    a = ax[1]
    for lam in _lams(data, "wavelength_continuum"):
        c = colors.get(lam, "k")
        wc = A.read_csv(data / f"wavelength_continuum_lam={lam:g}.csv")
        a.plot(wc["t"], wc["wavelength"], "-", color=c, label=rf"$\lambda$ = {lam:g}")
        t_end = {"continuum": wc["t"][-1], "particles": wc["t"][-1]}
        wp_path = data / f"wavelength_particles_lam={lam:g}.csv"
        if wp_path.exists():
            wp = A.read_csv(wp_path)
            t_end["particles"] = wp["t"][-1]
            if "rings" in wp:
                a.plot(wp["t"], wp["wavelength"], "o", color=c, mfc="none", ms=3)
        i = np.flatnonzero(s["lam"] == lam)
        for engine, style in (("continuum", "s"), ("particles", "o")):
            if i.size and np.isfinite(s[f"wavelength_{engine}"][i[0]]):
                a.errorbar(t_end[engine], s[f"wavelength_{engine}"][i[0]],
                           yerr=error_bar(s, engine)[i[0]], fmt=style, color=c, ms=5,
                           capsize=3)
    a.set(xlabel="t", ylabel="wavelength", yscale="log",
          title="(B) continuum lines, particles circles\n"
                "filled: the final wavelength with its error bar")
    a.legend(fontsize=8)

    a = ax[2]
    for engine, style in (("particles", "o"), ("continuum", "s")):
        lam, w, err = s["lam"], s[f"wavelength_{engine}"], error_bar(s, engine)
        if not np.isfinite(w).any():
            continue
        a.errorbar(lam, w, yerr=err, fmt=style, mfc="none", capsize=3,
                   label=slope_label(engine, lam, w, err))
    a.plot(s["lam"], s["wavelength_exact"], "k.",
           label=slope_label("radial reference", s["lam"], s["wavelength_exact"], None))
    ok = np.isfinite(s["wavelength_exact"]) & (s["wavelength_exact"] > 0)
    if ok.any():
        C = np.exp(np.mean(np.log(s["wavelength_exact"][ok] * np.sqrt(s["lam"][ok]))))
        lg = np.logspace(np.log10(s["lam"].min()), np.log10(s["lam"].max()), 50)
        a.plot(lg, C / np.sqrt(lg), "k--", lw=0.8, label=r"$\propto\lambda^{-1/2}$")
    a.set(xscale="log", yscale="log", xlabel=r"$\lambda$", ylabel="final wavelength",
          title="(C) two outermost rings, measured only (>= 2 rings);\n"
                "slopes with their 95 % intervals")
    a.legend(fontsize=8)
    plain_log_ticks(fig)
    fig.tight_layout()
    note_missing_engines(fig, {e for e in ENGINES if np.isfinite(s[f"radius_{e}"]).any()})
    return save_figure(fig, out / "fig4")
