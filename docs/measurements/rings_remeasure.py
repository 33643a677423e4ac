"""The paper-scale ring columns measured again from committed final profiles (issue 57).

The paper-scale particle colonies' run folders are gone; their final radial profiles are
committed (``cases/data/particles_paper/lam=*/profile.csv``, seed 0, and
``cases/data/ensemble_paper/seed=S/lam=*/profile.csv``), as are the continuum's final ring
tables (``rings_continuum_lam=*.csv``). This script measures every ring column of Fig 4's
``summary.csv`` (cases/data/fig4_paper) and the wavelength columns of the cross-check's
``table.csv`` and its ``exponents.csv`` (cases/data/crosscheck_paper) from them by the rule of
both models (cases.analysis.rings):

- particles: :func:`cases.analysis.profile_rings` of seed 0's final profile at its radius, the
  spread under its annulus noise (``*_noise_sd_particles``, :func:`cases.figures.fig4.noise_spread`)
  and, where other seeds' profiles exist, the standard deviation over the seeds whose
  wavelength is measured (``*_seed_sd_particles``, ``seeds_particles`` colonies measured of
  ``colonies_particles``); the frame-to-frame spread (``*_sd_particles``) needs the frames and is
  nan here;
- continuum: :func:`cases.analysis.contour_rings` of the final ring table at its radius (the
  frame spread nan likewise);
- the 1D reference: :func:`cases.analysis.exact_ring_measure` at the continuum's radius;

and the final rings of the radius-260 colonies (``cases/data/colony_260/rings_final.csv``: per
model its rings, both wavelengths and, for the particles, their spreads under the annulus noise).

    python docs/measurements/rings_remeasure.py

Each table is rewritten (its other columns kept) through a temporary file.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from cases import analysis as A
from cases.figures import fig4

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "cases" / "data"


def particle_profiles(lam: float) -> list[Path]:
    """Seed 0's final profile first, then the ensemble's seeds (those committed)."""
    first = DATA / "particles_paper" / f"lam={lam:g}" / "profile.csv"
    seeds = sorted((DATA / "ensemble_paper").glob(f"seed=*/lam={lam:g}/profile.csv"))
    return ([first] if first.is_file() else []) + seeds


def measure(data: Path) -> dict[str, list]:
    """Fig 4's summary columns of ``data`` measured again (module docstring)."""
    old = A.read_csv(data / "summary.csv")
    names = [*fig4.summary_names(), "wavelength_seed_sd_particles", "spacing_seed_sd_particles",
             "seeds_particles", "colonies_particles"]
    rows: dict[str, list] = {k: [] for k in names}
    for i, lam in enumerate(old["lam"]):
        row = dict.fromkeys(names, math.nan) | {"lam": float(lam)}
        R_c, R_p = float(old["radius_continuum"][i]), float(old["radius_particles"][i])
        row["radius_continuum"], row["radius_particles"] = R_c, R_p
        table = data / f"rings_continuum_lam={lam:g}.csv"
        if table.is_file():
            rings = A.contour_rings(A.read_csv(table), R_c)
            row |= {"wavelength_continuum": rings.outer_pair,
                    "spacing_continuum": rings.mean_spacing, "rings_continuum": rings.count}
        paths = particle_profiles(float(lam))
        if paths and math.isfinite(R_p):
            first = A.read_csv(paths[0])
            rings = A.profile_rings(first, R_p)
            row |= {"wavelength_particles": rings.outer_pair,
                    "spacing_particles": rings.mean_spacing, "rings_particles": rings.count}
            row |= fig4.noise_spread(first, R_p)
            seeds = [A.profile_rings(A.read_csv(p), R_p) for p in paths]
            for key, col in (("outer_pair", "wavelength"), ("mean_spacing", "spacing")):
                v = np.array([getattr(s, key) for s in seeds])
                v = v[np.isfinite(v)]
                row[f"{col}_seed_sd_particles"] = float(np.std(v, ddof=1)) if v.size >= 2 \
                    else math.nan
            row["seeds_particles"] = int(np.isfinite([s.outer_pair for s in seeds]).sum())
            row["colonies_particles"] = len(seeds)
        if "ring_z_particles" in old:
            row["ring_z_particles"] = float(old["ring_z_particles"][i])
        exact = A.exact_ring_measure(float(lam), R_c)
        row["wavelength_exact"], row["spacing_exact"] = exact.outer_pair, exact.mean_spacing
        for k in names:
            rows[k].append(row[k])
    return rows


def remeasure_crosscheck(data: Path) -> dict[str, list]:
    """The cross-check table with its wavelength columns measured again (the rest kept)."""
    table = {k: list(v) for k, v in A.read_csv(data / "table.csv").items()}
    for i, lam in enumerate(table["lam"]):
        R = float(table["radius_final"][i])
        rings = data / ".." / "fig4_paper" / f"rings_continuum_lam={lam:g}.csv"
        table["wavelength_continuum"][i] = (A.contour_rings(A.read_csv(rings), R).outer_pair
                                            if rings.is_file() else math.nan)
        table["wavelength_exact"][i] = A.exact_wavelength(float(lam), R)
        paths = particle_profiles(float(lam))
        table["wavelength_particles"][i] = (
            A.profile_rings(A.read_csv(paths[0]), R).outer_pair if paths else math.nan)
    return table


def colony_260_rings(folder: Path) -> dict[str, list]:
    """Final rings of the radius-260 colonies: particles, continuum and the 1D reference."""
    prof = A.read_csv(folder / "particles_lam=0.001" / "profile.csv")
    R_p = float(prof["r"].max())
    R_c = float(A.read_csv(folder / "continuum_lam=0.001" / "history.csv")["radius"][-1])
    spread = A.ring_uncertainty(prof, R_p)
    models = {
        "particles": (A.profile_rings(prof, R_p), spread),
        "continuum": (A.contour_rings(A.read_csv(folder / "continuum_lam=0.001" / "rings.csv"),
                                      R_c), {}),
        "exact": (A.exact_ring_measure(1e-3, R_c), {}),
    }
    out: dict[str, list] = {k: [] for k in ("model", "radius", "rings", "outer_pair",
                                           "outer_pair_noise_sd", "mean_spacing",
                                           "mean_spacing_noise_sd", "radii")}
    for name, (rings, sd) in models.items():
        row = {"model": name, "radius": rings.radius, "rings": rings.count,
               "outer_pair": rings.outer_pair,
               "outer_pair_noise_sd": sd.get("outer_pair_sd", math.nan),
               "mean_spacing": rings.mean_spacing,
               "mean_spacing_noise_sd": sd.get("mean_spacing_sd", math.nan),
               "radii": " ".join(f"{r:.2f}" for r in rings.radii)}
        for k in out:
            out[k].append(row[k])
    return out


def _replace(path: Path, columns: dict[str, list]) -> None:
    tmp = path.with_name(path.name + ".partial")
    A.write_csv(tmp, columns)
    tmp.replace(path)


def main(argv: list[str] | None = None) -> int:
    """Rewrite both tables and print the Fig 4 table and slopes."""
    from cases.figures import crosscheck

    data = DATA / "fig4_paper"
    rows = measure(data)
    _replace(data / "summary.csv", rows)
    cross = DATA / "crosscheck_paper"
    table = remeasure_crosscheck(cross)
    _replace(cross / "table.csv", table)
    _replace(cross / "exponents.csv", crosscheck.exponents(table))
    final = colony_260_rings(DATA / "colony_260")
    path = DATA / "colony_260" / "rings_final.csv"
    with path.with_name(path.name + ".partial").open("w") as fh:
        fh.write(",".join(final) + "\n")
        for i in range(len(final["model"])):
            fh.write(",".join(v if isinstance(v, str) else f"{v:.6g}"
                              for v in (final[k][i] for k in final)) + "\n")
    path.with_name(path.name + ".partial").replace(path)
    print(path.read_text())
    print("| lam | particles: outer pair (noise sd, seed sd; seeds) | mean spacing | continuum "
          "| reference |\n|---|---|---|---|---|")
    for i, lam in enumerate(rows["lam"]):
        print(f"| {lam:g} | {rows['wavelength_particles'][i]:.3g} "
              f"({rows['wavelength_noise_sd_particles'][i]:.2g}, "
              f"{rows['wavelength_seed_sd_particles'][i]:.2g}; "
              f"{rows['seeds_particles'][i]}/{rows['colonies_particles'][i]}) | "
              f"{rows['spacing_particles'][i]:.3g} | {rows['wavelength_continuum'][i]:.4g} "
              f"/ {rows['spacing_continuum'][i]:.4g} | {rows['wavelength_exact'][i]:.4g} / "
              f"{rows['spacing_exact'][i]:.4g} |")
    s = A.read_csv(data / "summary.csv")
    for engine in ("particles", "continuum", "exact"):
        err = fig4.error_bar(s, engine) if engine != "exact" else None
        print(fig4.slope_label(engine, s["lam"], s[f"wavelength_{engine}"], err))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
