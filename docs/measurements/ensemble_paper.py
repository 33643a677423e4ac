"""Seed bands at radius 150 from the recorded paper-scale colonies (issue 30, part 3).

A paper-scale particle colony takes about an hour, so its seeds are grown one by one
(``cases/data/ensemble_paper/README.md``) and only their records are kept
(``docs/measurements/records.py``: thinned history, final and pooled profiles). This script
reduces the records of every seed S of a lam, seed 0 being the figures' own colony (its pooled
profile ``cases/data/fig3_paper/profile_particles_lam=LAM.csv`` and history
``cases/data/particles_paper/lam=LAM/history.csv``), to the ensemble's files that the paper
figures draw as bands (:func:`cases.datasets.ensemble_data` finds them beside ``fig3_paper``):

- ``profile_lam=LAM.csv``: the seeds' pooled stress and mean-length profiles on the common
  equal-area annuli of radius 150, mean and spread (:func:`cases.analysis.seed_spread`);
- ``radius_lam=LAM.csv``: R(t) on a common time grid, and the continuum's R(t) of Fig 3B;
- ``seeds.csv``, ``summary.csv``: per seed and over the seeds, the time to reach radius 150,
  the late speed, the central stress by the largest annulus mean and by the fit
  p0 - c r^2 over r < R/2 (:func:`cases.analysis.profile_central_stress`), and the whole
  colony's mean stress over the continuum's mean pressure at the same radius, averaged over
  one division period (:func:`cases.studies.ensemble.mean_stress_ratio`): the stress offset
  of the particles over the continuum, with its 95 % t-interval over the seeds.

Run ``python docs/measurements/ensemble_paper.py`` (seconds); it prints the table of
docs/results.md. Only lam with at least two seeds are reduced.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from cases import analysis as A
from cases.studies import ensemble as E
from continuum import radial

__all__ = ["seed_records", "reduce", "markdown_table", "main"]

DATA = Path(__file__).resolve().parents[2] / "cases" / "data"
RADIUS = 150.0
#: Per-seed quantities of ``seeds.csv``, reduced over the seeds in ``summary.csv``.
QUANTITIES = ("t_at_radius", "t_final", "slope", "central_max", "central_fit", "rel_central_fit",
              "mean_stress_cycle")


def seed_records(data: Path = DATA) -> dict[float, dict[int, tuple[dict, dict]]]:
    """{lam: {seed: (pooled profile, history)}} of the recorded radius-150 colonies.

    Seed 0 from the figures' data (``fig3_paper``, ``particles_paper``), seeds S >= 1 from
    ``ensemble_paper/seed=S/lam=LAM`` (records with ``profile_pooled.csv``).
    """
    data = Path(data)
    found: dict[float, dict[int, tuple[dict, dict]]] = {}
    for folder in sorted((data / "ensemble_paper").glob("seed=*/lam=*")):
        if not (folder / "profile_pooled.csv").is_file():
            continue
        seed = int(folder.parent.name.split("=")[1])
        lam = float(json.loads((folder / "config.json").read_text())["lam"])
        found.setdefault(lam, {})[seed] = (A.read_csv(folder / "profile_pooled.csv"),
                                           A.read_csv(folder / "history.csv"))
    for lam, seeds in found.items():
        profile = data / "fig3_paper" / f"profile_particles_lam={lam:g}.csv"
        history = data / "particles_paper" / f"lam={lam:g}" / "history.csv"
        if profile.is_file() and history.is_file():
            seeds[0] = (A.read_csv(profile), A.read_csv(history))
    return {lam: dict(sorted(s.items())) for lam, s in sorted(found.items())}


def _seed_row(lam: float, profile: dict, hist: dict) -> dict[str, float]:
    """The quantities of one seed (module docstring)."""
    R_f = float(hist["radius"][-1])
    row = {"radius_final": R_f, "t_final": float(hist["t"][-1]),
           "t_at_radius": float(A.time_at_radius(hist["t"], hist["radius"],
                                                 np.array([RADIUS]))[0]),
           "slope": A.late_slope(hist["t"], hist["radius"], E.LATE_FRACTION)}
    row |= A.profile_central_stress(profile, R_f)
    row["rel_central_fit"] = row["central_fit"] / radial.max_pressure(R_f, lam) - 1.0
    row["mean_stress_cycle"] = float(E.mean_stress_ratio(hist, lam)["cycle"][-1])
    return row


def reduce(records: dict[float, dict[int, tuple[dict, dict]]], out: Path,
           data: Path = DATA) -> Path:
    """Write the ensemble files of every lam with two seeds or more into ``out``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    seeds_rows: dict[str, list] = {}
    summary: dict[str, list] = {}
    for lam, seeds in records.items():
        if len(seeds) < 2:
            continue
        rows = {s: _seed_row(lam, p, h) for s, (p, h) in seeds.items()}
        for s, row in rows.items():
            E._append(seeds_rows, {"lam": lam, "seed": s} | row)
        srow = {"lam": lam, "n_seeds": len(rows), "radius": RADIUS,
                "p0_exact": radial.max_pressure(RADIUS, lam)}
        for q in QUANTITIES:
            values = np.array([[rows[s][q]] for s in rows])
            srow |= {k: float(v[0]) for k, v in E._stats_columns(q, values).items()}
        E._append(summary, srow)
        E._write_profiles(out, lam, RADIUS, [p for p, _ in seeds.values()])
        continuum = A.read_csv(data / "fig3_paper" / f"radius_continuum_lam={lam:g}.csv")
        E._write_radius(out, lam, RADIUS, [h for _, h in seeds.values()], continuum)
    A.write_csv(out / "seeds.csv", seeds_rows)
    A.write_csv(out / "summary.csv", summary)
    return out


def markdown_table(out: Path) -> str:
    """The seeds' numbers at radius 150: mean +- 95 % t-interval, and the seed range."""
    s = A.read_csv(Path(out) / "summary.csv")
    lines = ["| lam | seeds | t(R = 150) | central stress fit / p(0) - 1 | mean stress / "
             "continuum mean pressure - 1 (over a division period) |", "|---|---|---|---|---|"]
    def cell(i, q, scale=1.0, digits=3, unit=""):
        m, ci = s[f"{q}_mean"][i] * scale, s[f"{q}_ci95"][i] * scale
        lo, hi = s[f"{q}_q025"][i] * scale, s[f"{q}_q975"][i] * scale
        return (f"{m:.{digits}f} +- {ci:.{digits}f}{unit} (seeds {lo:.{digits}f} to "
                f"{hi:.{digits}f}{unit})")

    for i, lam in enumerate(s["lam"]):
        ratio = {k: s[f"mean_stress_cycle_{k}"][i] - (1.0 if k != "ci95" else 0.0)
                 for k in ("mean", "ci95", "q025", "q975")}
        rs = (f"{100 * ratio['mean']:+.1f} +- {100 * ratio['ci95']:.1f} % (seeds "
              f"{100 * ratio['q025']:+.1f} to {100 * ratio['q975']:+.1f} %)")
        lines.append(f"| {lam:g} | {int(s['n_seeds'][i])} | {cell(i, 't_at_radius')} | "
                     f"{cell(i, 'rel_central_fit', 100.0, 1, ' %')} | {rs} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    """``python docs/measurements/ensemble_paper.py [--data D] [--out O]``: reduce, print."""
    p = argparse.ArgumentParser(prog="python docs/measurements/ensemble_paper.py",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, default=DATA, help="cases/data (default: the checkout's)")
    p.add_argument("--out", type=Path, default=None,
                   help="folder of the ensemble files (default DATA/ensemble_paper)")
    args = p.parse_args(argv)
    out = reduce(seed_records(args.data), args.out or args.data / "ensemble_paper", args.data)
    print(markdown_table(out), end="")
    return 0


if __name__ == "__main__":
    import sys

    sys.exit(main())
