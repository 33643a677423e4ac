"""The particle-continuum offset of the central stress: estimator, numerics, seeds, model.

The figures' "max stress" of a particle colony is the largest annulus mean of a noisy profile
(per-annulus standard deviation up to ~80 % of the mean at lam = 0: force chains), which is
biased upwards. This module compares it with the fit p0 - c r^2 over r < R/2
(:func:`cases.analysis.central_value`) on committed particle profiles and estimates the bias of
the largest annulus mean from each profile itself: profiles drawn as the fit plus Gaussian
annulus noise of the fit's relative residual scatter (``bias_sim``, a parametric bootstrap of
``draws`` profiles).

The paper-scale colonies as they grow (:func:`paper_growth`): the whole colony's mean stress
against the continuum's mean pressure at the same radius and the time to reach each radius,
from the committed histories (radius 10 to 150).

Run ``python docs/measurements/stress_offset.py`` (seconds): it reads cases/data/fig3 (radius 40),
cases/data/fig3_paper and cases/data/particles_paper (radius 150), writes ``estimators.csv`` and
``growth_paper.csv`` into cases/data/ensemble (``--out`` to change) and prints the markdown
tables of docs/results.md. (``cases.studies.stress_offset`` until issue 43 moved it here.)
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from cases import analysis as A

__all__ = ["profile_estimators", "estimator_table", "growth_histories", "paper_growth",
           "main"]

DATA = Path(__file__).resolve().parents[2] / "cases" / "data"


def profile_estimators(profile: dict[str, np.ndarray], radius: float, p0_exact: float,
                       draws: int = 2000, seed: int = 0) -> dict[str, float]:
    """Both central-stress estimators of one particle profile, and the largest mean's bias.

    Returns central_max, central_fit, central_fit_se, their ratios to ``p0_exact`` minus one
    (rel_max, rel_fit), the relative residual scatter of the annulus means about the fit over
    r < R/2 (noise_rel) and bias_sim_rel: E[largest annulus mean] - p0 of profiles
    fit(r) (1 + noise_rel z_k), z_k independent standard normal, relative to p0 of the fit.
    """
    est = A.profile_central_stress(profile, radius)
    p0, _, c = A.central_value(profile["r"], profile["stress"], radius, profile["count"])
    r = profile["r"]
    ok = np.isfinite(profile["stress"]) & (profile["count"] > 0)
    fit = p0 - c * r[ok] ** 2
    inner = r[ok] < A.CENTRAL_FRACTION * radius
    noise = float(np.std(profile["stress"][ok][inner] / fit[inner] - 1.0, ddof=2))
    rng = np.random.default_rng(seed)
    largest = (fit[None, :] * (1.0 + noise * rng.standard_normal((draws, fit.size)))).max(1)
    return est | {"p0_exact": p0_exact, "rel_max": est["central_max"] / p0_exact - 1,
                  "rel_fit": est["central_fit"] / p0_exact - 1, "noise_rel": noise,
                  "bias_sim_rel": float(largest.mean() / p0 - 1)}


def estimator_table(fig3_data: Path) -> dict[str, np.ndarray]:
    """:func:`profile_estimators` of every particle profile of a Fig 3 data folder."""
    summary = A.read_csv(fig3_data / "summary.csv")
    rows: dict[str, list] = {}
    for i, lam in enumerate(summary["lam"]):
        path = fig3_data / f"profile_particles_lam={lam:g}.csv"
        if not path.exists():
            continue
        radius = float(summary["radius_particles"][i])
        row = {"lam": lam, "radius": radius}
        row |= profile_estimators(A.read_csv(path), radius, float(summary["p0_exact"][i]))
        for k, v in row.items():
            rows.setdefault(k, []).append(v)
    return {k: np.asarray(v, dtype=float) for k, v in rows.items()}


#: Radii at which the committed paper-scale colonies are compared with the continuum.
PAPER_RADII = np.geomspace(10.0, 150.0, 9)


def _stride(history: dict[str, np.ndarray]) -> int:
    """1 for a history of every step, else the typical step between its rows (a thinned one)."""
    return int(np.median(np.diff(history["step"])))


def growth_histories(particles: Path = DATA / "particles_paper",
                     seeds: Path = DATA / "ensemble_paper") -> list[tuple[float, int, dict]]:
    """(lam, seed, history) of the paper colonies the growth table reads, by lam and seed.

    Seed 0 of every lam (``particles/lam=LAM``) and every other seed whose record holds every
    step (``seeds/seed=S/lam=LAM``, recorded since 2026-12-05).
    """
    folders = [(f, 0) for f in particles.glob("lam=*")]
    folders += [(f, int(f.parent.name[5:])) for f in seeds.glob("seed=*/lam=*")]
    out = [(float(f.name[4:]), seed, A.read_csv(f / "history.csv")) for f, seed in folders]
    return sorted((x for x in out if x[1] == 0 or _stride(x[2]) == 1), key=lambda x: x[:2])


def paper_growth(particles: Path = DATA / "particles_paper", fig3: Path = DATA / "fig3_paper",
                 fig4: Path = DATA / "fig4_paper", radii: np.ndarray = PAPER_RADII,
                 seeds: Path = DATA / "ensemble_paper") -> dict[str, np.ndarray]:
    """The paper-scale colonies against the continuum as they grow (radius 10 to 150).

    From each colony's history (:func:`growth_histories`) and the continuum's R(t)
    (``fig3_paper/radius_continuum_lam=*.csv``):
    :func:`cases.studies.ensemble.history_growth` at ``radii`` (mean stress over the
    continuum's mean pressure - 1, cycle-averaged; time to reach the radius - 1);
    ``stride``: the steps between the history's rows (1: every step; records before
    2026-12-05 kept every k-th, which aliases the division waves by up to 7.5 points),
    ``thinning_error``: for a history of every step, what thinning it as those records were
    (``cases.analysis.thin_rows``: for a record made whole by ``records.py --make-whole``, its
    old rows exactly) does to the mean stress (nan for a thinned one); for seed 0 of the
    lam of Fig 4, the ring wavelength at every frame of both models
    (``fig4_paper/wavelength_*_lam=*.csv``) compared at the same radius (each interpolated
    linearly in R between its frames with two rings; nan elsewhere). No particle profiles at
    intermediate radii are committed, so no central value or ring radius there.
    """
    from cases.studies.ensemble import history_growth

    rows: dict[str, list] = {}
    for lam, seed, history in growth_histories(particles, seeds):
        cont = fig3 / f"radius_continuum_lam={lam:g}.csv"
        if not cont.exists():
            continue
        hc = A.read_csv(cont)
        g = history_growth(history, hc["t"], hc["radius"], lam, radii)
        stride = _stride(history)
        error = (history_growth(A.thin_rows(history), hc["t"], hc["radius"], lam,
                                radii)["mean_stress"] - g["mean_stress"]
                 if stride == 1 else np.full(radii.shape, np.nan))
        w = _wavelength_at(fig4, lam, radii) if seed == 0 else np.full(radii.shape, np.nan)
        for i, R in enumerate(radii):
            for k, v in (("lam", lam), ("seed", seed), ("radius", R),
                         ("rel_mean_stress", g["mean_stress"][i]), ("rel_t", g["t"][i]),
                         ("rel_wavelength", w[i]), ("stride", stride),
                         ("thinning_error", error[i])):
                rows.setdefault(k, []).append(v)
    return {k: np.asarray(v, dtype=float) for k, v in rows.items()}


def _wavelength_at(fig4: Path, lam: float, radii: np.ndarray) -> np.ndarray:
    """Particle wavelength / continuum wavelength - 1 at ``radii`` (nan without both)."""
    out = {}
    for engine in ("particles", "continuum"):
        path = fig4 / f"wavelength_{engine}_lam={lam:g}.csv"
        if not path.exists():
            return np.full(radii.shape, np.nan)
        w = A.read_csv(path)
        ok = np.isfinite(w["wavelength"])
        if ok.sum() < 2:
            return np.full(radii.shape, np.nan)
        out[engine] = np.interp(radii, w["radius"][ok], w["wavelength"][ok], left=np.nan,
                                right=np.nan)
    return out["particles"] / out["continuum"] - 1.0


def _markdown(table: dict[str, np.ndarray]) -> str:
    def pct(x: float) -> str:
        return "-" if not math.isfinite(x) else f"{100 * x:+.1f} %"

    rows = [(f"{R:.0f}", f"{lam:g}", f"{m:.4g} ({pct(rm)})",
             f"{f:.4g} +- {se:.2g} ({pct(rf)})", f"{p0:.4g}", f"{100 * n:.0f} %", pct(b))
            for R, lam, m, rm, f, se, rf, p0, n, b in zip(
                table["radius"], table["lam"], table["central_max"], table["rel_max"],
                table["central_fit"], table["central_fit_se"], table["rel_fit"],
                table["p0_exact"], table["noise_rel"], table["bias_sim_rel"], strict=True)]
    return A.markdown_rows(("R", "lam", "largest annulus mean (vs p(0))",
                            "fit p0 - c r^2, r < R/2 (vs p(0))", "p(0)",
                            "annulus noise / mean", "bias of the largest mean (simulated)"),
                           rows)


def main(argv: list[str] | None = None) -> int:
    """Write estimators.csv for the committed medium and paper Fig 3 profiles; print the table."""
    p = argparse.ArgumentParser(prog="python docs/measurements/stress_offset.py",
                                description=__doc__.split("\n")[0])
    p.add_argument("--out", default=str(DATA / "ensemble"), help="folder of estimators.csv")
    args = p.parse_args(argv)
    tables = [estimator_table(DATA / name) for name in ("fig3", "fig3_paper")]
    table = {k: np.concatenate([t[k] for t in tables]) for k in tables[0]}
    A.write_csv(Path(args.out) / "estimators.csv", table)
    print(_markdown(table))
    growth = paper_growth()
    A.write_csv(Path(args.out) / "growth_paper.csv", growth)
    print()
    print(_growth_markdown(growth))
    return 0


def _growth_markdown(g: dict[str, np.ndarray]) -> str:
    """Rows (lam, seed), columns radii: mean stress / continuum - 1 and t / continuum - 1 (%).

    A colony's history of every step adds a row of its thinning error (points); a thinned
    history is marked with its stride.
    """
    from cases.studies.ensemble import trailing_rate

    radii = np.unique(g["radius"])
    rows = []
    for lam, seed in dict.fromkeys(zip(g["lam"], g["seed"], strict=True)):
        sel = (g["lam"] == lam) & (g["seed"] == seed)
        stride = int(g["stride"][sel][0])
        label = f"{lam:g}" + (f", seed {seed:.0f}" if seed else "") + (
            f" (1 step in {stride})" if stride > 1 else "")
        cells = [f"{100 * m:+.1f} / {100 * t:+.1f}" if math.isfinite(m) else
                 f"- / {100 * t:+.1f}" for m, t in zip(g["rel_mean_stress"][sel],
                                                       g["rel_t"][sel], strict=True)]
        a_m, a_t = (trailing_rate(radii, g[k][sel]) for k in ("rel_mean_stress", "rel_t"))
        rows.append([label, *cells, f"{a_m:.2f} / {a_t:.2f}".replace("nan", "-")])
        if stride == 1:
            rows.append([f"{label}: thinned - whole", *[f"{100 * x:+.1f}" for x in
                                                          g["thinning_error"][sel]], "-"])
        wl = g["rel_wavelength"][sel]
        if np.isfinite(wl).any():
            rows.append([f"{lam:g} wavelength", *[f"{100 * x:+.0f}" if math.isfinite(x) else "-"
                                                  for x in wl],
                         f"{trailing_rate(radii, wl):.2f}".replace("nan", "-")])
    return A.markdown_rows(["lam", *[f"R = {R:.3g}" for R in radii],
                            "a of abs(diff) ~ R^a (trailing same-sign radii)"], rows)


if __name__ == "__main__":
    import sys

    sys.exit(main())
