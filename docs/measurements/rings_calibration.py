"""Calibration of the ring significance on profiles with no rings (issue 57).

A peak of a particle profile counts as a ring when its significance z (prominence over its
standard error from the annulus noise, :func:`cases.analysis.peak_significance`) reaches
:data:`cases.analysis.RING_SIGNIFICANCE` and it lies outside the edge layer. Measured here: on
profiles that have no rings, the largest z of any peak inside the colony, and the false ring
rate, the fraction of those profiles with at least one peak counted as a ring at the threshold
(and the fraction given a wavelength, two or more).

The ring-free profiles (``source``):

- ``lam=0.1``, ``lam=0.03``: every frame of radius >= 20 of particle colonies of lam = 0.1 and
  0.03 grown to radius 40 (``colony particles --lam LAM --radius 40 --seed S --threads 1
  --output-every 0.2 --quiet --out RUNS/lamLAM/sS``), whose rings (continuum spacing 2-4) the
  particles do not form (ring coherence z about 0-1 at every radius); their lengths are
  spread (a colony of lam = 1e-4 of this radius has no ring either, but its lengths are nearly
  equal: no peak reaches the 0.02 prominence floor, a test that cannot fail);
- ``shuffled``: the same frames with the lengths permuted among the particles (white noise with
  the colony's own length distribution);
- ``lam>=0.03``: the final profiles of the committed paper colonies of lam = 0.03, 0.05, 0.1
  (radius 150), whose rings the particles do not resolve (ring coherence z < 1.2);
- and, with one ring, never a wavelength: the lam = 1e-4 colonies of radius 150 (seed 0 and the
  ensemble's seeds 1 and 2) and the continuum at lam = 1e-4.

Writes ``OUT/ringfree.csv`` (one row per profile: source, seed, t, radius, largest z inside,
peaks) and ``OUT/summary.csv`` (per source: profiles, the 95th percentile of the largest z,
the false ring and false wavelength rates at the threshold), and prints the summary.

    python docs/measurements/rings_calibration.py --runs RUNS [--out OUT]
    python docs/measurements/rings_calibration.py --from-data [--out OUT]   # summary only
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from cases import analysis as A
from cases.analysis.io import particle_frames
from cases.analysis.profiles import particle_profile
from particles.measures import enclosing_radius

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "cases" / "data"
MIN_RADIUS = 20.0


def _profile_z(profile: dict, radius: float) -> tuple[float, float, int]:
    """Largest and second largest z of a peak inside the colony, and the number of peaks.

    Inside: outside the edge layer.
    """
    r, f, se = A.rings._profile_samples(profile, "mean_length", True, 10)
    r, z = A.peak_significance(r, f, stderr=se)
    z = np.sort(z[r <= radius - A.EDGE_LAYER])[::-1]
    return float(z[0]) if z.size else 0.0, float(z[1]) if z.size > 1 else 0.0, int(r.size)


def ringfree_rows(runs: Path) -> list[dict]:
    """One row per frame of radius >= MIN_RADIUS of every run in ``runs`` (and its shuffle)."""
    rows = []
    folders = [f for f in runs.glob("lam*/s*") if f.name[1:].isdigit()
               and (f / "run.json").is_file()]
    for folder in sorted(folders, key=lambda f: (f.parent.name, int(f.name[1:]))):
        seed = int(folder.name[1:])
        rng = np.random.default_rng(seed)
        for t, fr in particle_frames(folder):
            R = enclosing_radius(fr["x"], fr["y"], fr["theta"], fr["length"])
            if R < MIN_RADIUS:
                continue
            for source, length in ((folder.parent.name.replace("lam", "lam="), fr["length"]),
                                   ("shuffled", rng.permutation(fr["length"]))):
                prof = particle_profile(fr["x"], fr["y"], fr["theta"], length, fr["stress"],
                                        edge_width=0.5, radius=R)
                z, z2, n = _profile_z(prof, R)
                rows.append({"source": source, "seed": seed, "t": t, "radius": R,
                             "largest_z": z, "second_z": z2, "peaks": n})
    for lam in (0.03, 0.05, 0.1):
        prof = A.read_csv(DATA / "particles_paper" / f"lam={lam:g}" / "profile.csv")
        R = float(prof["r"].max())
        z, z2, n = _profile_z(prof, R)
        rows.append({"source": "lam>=0.03", "seed": 0, "t": math.nan, "radius": R,
                     "largest_z": z, "second_z": z2, "peaks": n})
    return rows


def one_ring_rows() -> list[dict]:
    """The lam = 1e-4 colonies of radius 150, which have one ring: their rings and reason."""
    paths = [DATA / "particles_paper" / "lam=0.0001" / "profile.csv",
             *sorted((DATA / "ensemble_paper").glob("seed=*/lam=0.0001/profile.csv"))]
    rows = []
    for path in paths:
        prof = A.read_csv(path)
        rings = A.profile_rings(prof)
        rows.append({"profile": str(path.relative_to(ROOT)), "rings": rings.count,
                     "wavelength": rings.outer_pair, "reason": rings.reason})
    cont = A.read_csv(DATA / "fig4_paper" / "rings_continuum_lam=0.0001.csv")
    rings = A.contour_rings(cont, 150.0)
    rows.append({"profile": "cases/data/fig4_paper/rings_continuum_lam=0.0001.csv",
                 "rings": rings.count, "wavelength": rings.outer_pair, "reason": rings.reason})
    return rows


def summary(rows: dict[str, np.ndarray], z_min: float = A.RING_SIGNIFICANCE) -> list[dict]:
    """Per source: profiles, 95th percentile of the largest z, false ring rate at ``z_min``."""
    out = []
    for source in dict.fromkeys(rows["source"]):
        mine = np.asarray(rows["source"]) == source
        z = np.asarray(rows["largest_z"], float)[mine]
        z2 = np.asarray(rows["second_z"], float)[mine]
        out.append({"source": source, "profiles": z.size,
                    "largest_z_q95": float(np.quantile(z, 0.95)),
                    "largest_z_max": float(z.max()),
                    "false_ring_rate": float(np.mean(z >= z_min)),
                    "false_wavelength_rate": float(np.mean(z2 >= z_min))})
    return out


def _write(path: Path, rows: list[dict]) -> None:
    import csv

    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        for row in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in row.items()})


def _read(path: Path) -> dict[str, np.ndarray]:
    import csv

    with path.open() as fh:
        rows = list(csv.DictReader(fh))
    return {k: np.array([r[k] for r in rows]) for k in rows[0]}


def main(argv: list[str] | None = None) -> int:
    """Measure (--runs) or summarise (--from-data) and print the table."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=Path, help="folder of the runs lamLAM/sS")
    p.add_argument("--from-data", action="store_true", help="summarise OUT/ringfree.csv")
    p.add_argument("--out", type=Path, default=DATA / "rings_calibration")
    args = p.parse_args(argv)
    if not args.from_data and args.runs is None:
        p.error("give --runs RUNS or --from-data")
    args.out.mkdir(parents=True, exist_ok=True)
    if not args.from_data:
        _write(args.out / "ringfree.csv", ringfree_rows(args.runs))
        _write(args.out / "one_ring.csv", one_ring_rows())
    rows = _read(args.out / "ringfree.csv")
    table = summary(rows)
    _write(args.out / "summary.csv", table)
    print(f"| source | profiles | largest z, 95th pct | largest z | rings at z >= "
          f"{A.RING_SIGNIFICANCE:g} | wavelengths |\n|---|---|---|---|---|---|")
    for r in table:
        print(f"| {r['source']} | {r['profiles']} | {r['largest_z_q95']:.2f} | "
              f"{r['largest_z_max']:.2f} | {100 * r['false_ring_rate']:.1f} % | "
              f"{100 * r['false_wavelength_rate']:.1f} % |")
    for r in _read(args.out / "one_ring.csv")["reason"]:
        print("one ring:", r)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
