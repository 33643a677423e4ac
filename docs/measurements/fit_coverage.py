"""Coverage of ``colony fit``'s 95 % interval on the project's own colonies (issue 54).

Fits R(t) of colonies of known lam with :func:`cases.fit.fit_colony` under several choices of
what the fit models (:data:`METHODS`) and counts how often the 95 % interval covers the true lam.
Writes ``coverage.csv`` (one row per fit), ``summary.csv`` (one row per method and source),
``speeds.csv`` (:func:`speed_ratios`) and ``example_colony.csv`` (the worked example of
docs/tutorial.md) into OUT_DIR and prints the speed ratios and the summary as markdown tables.

    python docs/measurements/fit_coverage.py [--runs DIR] [--out OUT_DIR] [--methods a,b]

The colonies (``source``):

- ``particles``: particle runs in ``--runs`` (default /work/fitcov), folders ``lam*_s*`` made by
  ``colony particles --lam LAM --radius 60 --seed S --threads 1 --quiet --out DIR/lamLAM_sS``;
  each history is fitted up to the radii 25, 40 and 60 (the same colony cut there).
- ``continuum``: continuum runs in ``--runs``, folders ``cont_lam*`` made by
  ``colony continuum --lam LAM --radius 60 --quiet --out DIR/cont_lamLAM``; cut likewise.
- ``paper``: the committed particle colonies of radius 150 and 260 (every ``history.csv`` under
  ``cases/data`` of a particle run, ``stopped`` runs left out), cut at 25, 40, 60 and their
  final radius (colony_260's seed-0 lam = 1e-3 colony only at 260: below 150 it is the
  particles_paper colony, step for step).
- ``paper_continuum``: the committed continuum colony of radius 260, at 260 only (below 60 it
  is the ``continuum`` run of lam = 1e-3, to the digits printed).

Units: the histories are in cell lengths and growth times; they are fitted as a user's data with
the fixed pair tau = 54 min, l0 = 1 um (``--tau-minutes 54 --cell-length-um 1``, times
t * 54 min, radii R * 1 um), thinned to one row per 0.1 growth time (a frame every 5.4 min, the
first row at or after each multiple of 0.1), so that every source has the same sampling.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy import stats

from cases import fit
from cases.rundir import replace_file

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "cases" / "data"
TAU_MINUTES = 54.0
CELL_LENGTH_UM = 1.0
FRAME = 0.1  # growth times between the rows fitted
CUTS = (25.0, 40.0, 60.0)

#: The fits compared: name -> keyword arguments of :func:`cases.fit.fit_colony` (``neff``:
#: the independent-noise interval widened by the lag-1 effective sample size, computed here).
METHODS = {
    "before": {"min_radius": 0.0, "tolerance": 0.0, "noise": "independent"},
    "R>=10": {"min_radius": 10.0, "tolerance": 0.0, "noise": "independent"},
    "R>=10 + n_eff": {"min_radius": 10.0, "tolerance": 0.0, "noise": "independent",
                     "neff": True},
    "R>=10 + AR(1)": {"min_radius": 10.0, "tolerance": 0.0, "noise": "ar1"},
    "AR(1) + tau +-10 %": {"min_radius": 0.0, "tolerance": 0.1, "noise": "ar1"},
    "R>=10 + AR(1) + tau +-5 %": {"min_radius": 10.0, "tolerance": 0.05, "noise": "ar1"},
    "after": {},  # the defaults of cases.fit: R >= 10, AR(1), tau +-10 %
}

COLUMNS = ("method", "source", "lam_true", "radius", "seed", "n", "lam_hat", "lo", "hi",
           "covered", "lag1", "rho", "status")


def _history(folder: Path) -> tuple[np.ndarray, np.ndarray]:
    """(t, radius) of a run's history.csv, thinned to one row per :data:`FRAME`."""
    t, R, _ = fit.read_series(folder / "history.csv", "t", "radius")
    keep, nxt = [], 0.0
    for i, ti in enumerate(t):
        if ti >= nxt - 1e-9:
            keep.append(i)
            nxt = (math.floor(ti / FRAME + 1e-9) + 1) * FRAME
    return t[keep], R[keep]


def colonies(runs: Path) -> list[dict]:
    """Every (source, folder, lam_true, seed, cuts) to fit (module docstring)."""
    out = []
    for folder in sorted(runs.glob("lam*_s*")):
        if (folder / "history.csv").exists() and not folder.name.endswith(".partial"):
            cfg = json.loads((folder / "config.json").read_text())
            out.append({"source": "particles", "folder": folder, "lam": float(cfg["lam"]),
                        "seed": int(cfg["seed"]), "cuts": CUTS})
    for folder in sorted(runs.glob("cont_lam*")):
        if (folder / "history.csv").exists() and not folder.name.endswith(".partial"):
            cfg = json.loads((folder / "config.json").read_text())
            out.append({"source": "continuum", "folder": folder, "lam": float(cfg["lam"]),
                        "seed": -1, "cuts": CUTS})
    for path in sorted(DATA.rglob("history.csv")):
        folder = path.parent
        if "stopped" in folder.parts:
            continue
        cfg = json.loads((folder / "config.json").read_text())
        continuum = "n_nodes" in cfg
        top = float(fit.read_series(path, "t", "radius")[1].max())
        cuts = (*CUTS, top)
        if folder.parent.name == "colony_260":  # below 150 / 60: particles_paper / cont_lam
            cuts = (top,)
        out.append({"source": "paper_continuum" if continuum else "paper", "folder": folder,
                    "lam": float(cfg["lam"]), "seed": -1 if continuum else int(cfg["seed"]),
                    "cuts": cuts})
    return out


def _neff_interval(res: fit.ColonyFit) -> tuple[float, float]:
    """The independent-noise interval widened for lag-1 correlated residuals.

    n_eff = n (1 - r) / (1 + r), r the residuals' lag-1 autocorrelation (clipped at 0): the
    deviance threshold becomes c(n_eff) (1 + r) / (1 - r), c(m) = m ln(1 + F_{1,m-p}/(m-p)),
    the variance of lam_hat being (1 + r)/(1 - r) times the independent one. No interval (a
    refusal) when n_eff <= p + 1.
    """
    r = max(res.lag1, 0.0)
    p = 2
    n_eff = res.n * (1.0 - r) / (1.0 + r)
    if n_eff <= p + 1:
        raise ValueError(f"n_eff = {n_eff:.2f} <= p + 1: no interval")
    dof = n_eff - p
    c = n_eff * math.log1p(float(stats.f.ppf(res.level, 1, dof)) / dof) * (1 + r) / (1 - r)
    pb = res._prof.pb
    return fit._interval(res._prof, res.lam, res.q_min, fit._grid(pb.y, pb.dt / pb.T), c)


def fit_one(t: np.ndarray, R: np.ndarray, options: dict) -> dict:
    """One fit in the units of the module docstring: lam_hat, lo, hi, lag1, rho (or a refusal)."""
    options = dict(options)
    neff = options.pop("neff", False)
    try:
        res = fit.fit_colony(t * TAU_MINUTES, R * CELL_LENGTH_UM, tau_minutes=TAU_MINUTES,
                             cell_length_um=CELL_LENGTH_UM, **options)
        lo, hi = _neff_interval(res) if neff else (res.lo, res.hi)
    except ValueError as err:
        return {"n": "", "lam_hat": "", "lo": "", "hi": "", "lag1": "", "rho": "",
                "status": "refused: " + str(err)[:120]}
    return {"n": res.n, "lam_hat": res.lam, "lo": lo, "hi": hi, "lag1": res.lag1,
            "rho": res.rho, "status": "ok"}


def coverage(runs: Path, methods: list[str], sources: set[str] | None = None) -> list[dict]:
    """One row per method, colony and cut (:data:`COLUMNS`), of ``sources`` (default all)."""
    rows = []
    for col in colonies(runs):
        if sources is not None and col["source"] not in sources:
            continue
        t, R = _history(col["folder"])
        for cut in col["cuts"]:
            keep = R <= cut + 1e-9
            for name in methods:
                start = time.perf_counter()
                got = fit_one(t[keep], R[keep], METHODS[name])
                ok = got["status"] == "ok"
                row = {"method": name, "source": col["source"], "lam_true": col["lam"],
                       "radius": round(float(R[keep].max()), 1), "seed": col["seed"], **got,
                       "covered": (got["lo"] <= col["lam"] <= got["hi"]) if ok else ""}
                rows.append(row)
                print(f"{name:24s} {col['source']:15s} lam={col['lam']:<7g} R={cut:<6g} "
                      f"seed={col['seed']:<3d} {got['status'][:60]:60s} "
                      + (f"{got['lam_hat']:.4g} [{got['lo']:.4g}, {got['hi']:.4g}] "
                         f"{'covers' if row['covered'] else 'MISSES'}" if ok else "")
                      + f" ({time.perf_counter() - start:.1f} s)", file=sys.stderr)
    return rows


def summary(rows: list[dict]) -> list[dict]:
    """Per method and source group: fits, refused, covered, coverage of the intervals given.

    The groups are of lam > 0, but ``lam=0``: the committed lam = 0 particle colonies.
    """
    every = ("particles", "paper", "continuum", "paper_continuum")
    groups = {"particles": ("particles",), "paper": ("paper",),
              "continuum": ("continuum", "paper_continuum"), "all": every, "lam=0": every}
    out = []
    for method in dict.fromkeys(r["method"] for r in rows):
        for group, sources in groups.items():
            mine = [r for r in rows if r["method"] == method and r["source"] in sources
                    and (r["lam_true"] == 0) == (group == "lam=0")]
            if not mine:
                continue
            ok = [r for r in mine if r["status"] == "ok"]
            covered = sum(bool(r["covered"]) for r in ok)
            ratio = [float(r["lam_hat"]) / r["lam_true"] for r in ok if r["lam_true"] > 0]
            width = [(float(r["hi"]) - float(r["lo"])) / r["lam_true"] for r in ok
                     if r["lam_true"] > 0]
            out.append({"method": method, "sources": group, "fits": len(mine),
                        "refused": len(mine) - len(ok), "covered": covered,
                        "coverage": covered / len(ok) if ok else math.nan,
                        "coverage_all": covered / len(mine),
                        "median_ratio": float(np.median(ratio)) if ratio else math.nan,
                        "median_width": float(np.median(width)) if width else math.nan})
    return out


def _read(path: Path) -> list[dict]:
    """Rows of a coverage.csv, with lam_true a float and covered a bool (or "")."""
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        r["lam_true"] = float(r["lam_true"])
        r["covered"] = {"True": True, "False": False}.get(r["covered"], "")
    return rows


def _write(rows: list[dict], path: Path) -> None:
    text = io.StringIO(newline="")
    w = csv.writer(text, lineterminator="\n")
    w.writerow(list(rows[0]))
    for r in rows:
        w.writerow([f"{v:.6g}" if isinstance(v, float) else v for v in r.values()])
    replace_file(path.parent, path.name, lambda fh: fh.write(text.getvalue().encode("utf-8")))


def markdown(table: list[dict]) -> str:
    """The summary as a markdown table."""
    lines = ["| method | sources | fits | refused | covered | coverage (of intervals given) |"
             " coverage (refusals count as misses) | median lam_hat / lam | median (hi - lo) "
             "/ lam |", "|---|---|---|---|---|---|---|---|---|"]
    for r in table:
        lines.append(f"| {r['method']} | {r['sources']} | {r['fits']} | {r['refused']} | "
                     f"{r['covered']} | {r['coverage']:.2f} | {r['coverage_all']:.2f} | "
                     + " | ".join("-" if math.isnan(r[k]) else f"{r[k]:.3g}"
                                  for k in ("median_ratio", "median_width")) + " |")
    return "\n".join(lines)


BANDS = ((2, 5), (5, 10), (10, 15), (15, 20), (20, 25), (25, 30), (35, 45), (55, 65),
         (90, 110), (130, 150))
"""Radius bands of :func:`speed_ratios` (cell lengths)."""


def speed_ratios() -> list[dict]:
    """The particle colonies' edge speed over the radial solution's, per radius band.

    For every committed particle colony of lam 1e-3 and 1e-2 (``paper`` source) and the
    committed continuum colony: the slope of a straight line through R(t) over each band of
    :data:`BANDS` (every history row in it) over ``continuum.radial.radius_rate`` at the
    band's middle. What :data:`cases.fit.MIN_RADIUS` and :data:`cases.fit.MODEL_TOLERANCE`
    rest on.
    """
    from continuum import radial

    rows = []
    for col in colonies(Path("/nonexistent")):
        if col["lam"] not in (1e-3, 1e-2) or col["folder"].parent.name == "colony_260" and (
                col["source"] == "paper"):
            continue
        t, R, _ = fit.read_series(col["folder"] / "history.csv", "t", "radius")
        for a, b in BANDS:
            k = (R >= a) & (R <= b)
            if k.sum() < 3:
                continue
            v = float(np.polyfit(t[k], R[k], 1)[0])
            model = float(radial.radius_rate(0.5 * (a + b), col["lam"]))
            rows.append({"source": col["source"], "lam": col["lam"], "seed": col["seed"],
                         "band": f"{a}-{b}", "speed": v, "radial": model, "ratio": v / model})
    return rows


def _speed_markdown(rows: list[dict]) -> str:
    """Per band: the ratio's range over the particle colonies, and the continuum's."""
    lines = ["| radius band | particle colonies: speed / radial solution's (min .. max) | "
             "continuum colony |", "|---|---|---|"]
    for band in dict.fromkeys(r["band"] for r in rows):
        p = [r["ratio"] for r in rows if r["band"] == band and r["source"] == "paper"]
        c = [r["ratio"] for r in rows if r["band"] == band and r["source"] != "paper"]
        lines.append(f"| {band} | {min(p):.2f} .. {max(p):.2f} ({len(p)}) | "
                     + (f"{c[0]:.3f} |" if c else "- |"))
    return "\n".join(lines)


EXAMPLE = DATA / "ensemble_paper" / "seed=1" / "lam=0.01"
"""The colony of the worked example (docs/tutorial.md): lam = 0.01, seed 1, up to radius 60."""


def write_example(out: Path) -> Path:
    """``example_colony.csv``: :data:`EXAMPLE` up to R = 60 as a user's data (min, um)."""
    t, R = _history(EXAMPLE)
    keep = R <= 60.0
    text = ("# a particle colony of this project (cases/data/ensemble_paper/seed=1/lam=0.01) "
            "up to radius 60, as a time-lapse: time in min (tau = 54 min), radius in um "
            "(l0 = 1 um); docs/measurements/fit_coverage.py\ntime,radius\n") + "".join(
        f"{a * TAU_MINUTES:.2f},{b * CELL_LENGTH_UM:.3f}\n" for a, b in zip(t[keep], R[keep],
                                                                          strict=True))
    return replace_file(out, "example_colony.csv", lambda fh: fh.write(text.encode("utf-8")))


def main(argv: list[str] | None = None) -> None:
    """Command line (module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", default="/work/fitcov", help="folder of the run folders")
    ap.add_argument("--out", default=str(DATA / "fit_coverage"), help="folder of the CSVs")
    ap.add_argument("--methods", default=",".join(METHODS),
                    help=f"comma-separated, of: {', '.join(METHODS)}")
    ap.add_argument("--sources", help="comma-separated sources to fit again; the rows of the "
                    "others are kept from OUT_DIR/coverage.csv (default: fit every source)")
    ap.add_argument("--summary-only", action="store_true",
                    help="no fits: summary.csv again from OUT_DIR/coverage.csv")
    args = ap.parse_args(argv)
    methods = [m.strip() for m in args.methods.split(",")]
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        ap.error(f"unknown methods: {unknown}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_example(out)
    speeds = speed_ratios()
    _write(speeds, out / "speeds.csv")
    print(_speed_markdown(speeds) + "\n")
    if args.summary_only:
        table = summary(_read(out / "coverage.csv"))
        _write(table, out / "summary.csv")
        print(markdown(table))
        return
    sources = None if args.sources is None else set(args.sources.split(","))
    rows = coverage(Path(args.runs), methods, sources)
    if sources is not None and (out / "coverage.csv").exists():
        rows = [r for r in _read(out / "coverage.csv") if r["source"] not in sources] + rows
    _write([{c: r[c] for c in COLUMNS} for r in rows], out / "coverage.csv")
    table = summary(rows)
    _write(table, out / "summary.csv")
    print(markdown(table))


if __name__ == "__main__":
    main()
