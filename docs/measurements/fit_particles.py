"""The fits of the particle colonies' R(t): ``cases/data/fit`` (``colony fit`` on known lam).

Each committed particle colony of ``cases/data/particles_paper`` is fitted by
:func:`cases.fit.fit_colony` in model units, with three choices of the radius column and the
smallest radius kept (:data:`PARTICLE_FITS`); the table says whether the 95 % interval covers
the true lam. Writes ``particles.csv`` and ``particles_lam=0.01.png`` and prints the markdown
table of cases/data/fit/README.md.

    python docs/measurements/fit_particles.py [OUT_DIR]     # default cases/data/fit

Lived in ``cases.fit`` (``python -m cases.fit``) until issue 43 moved it here.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import sys
from pathlib import Path

from cases.fit import _out_folder, fit_colony, fit_file, plot_fit, read_series
from cases.rundir import replace_file

DATA = Path(__file__).resolve().parents[2] / "cases" / "data"


#: The fits of :func:`particle_table`: (radius column, smallest radius kept).
PARTICLE_FITS = (("radius", 0.0), ("radius", 10.0), ("hull_radius", 0.0))


def particle_table(root: str | os.PathLike | None = None,
                   fits: tuple = PARTICLE_FITS) -> list[dict]:
    """Fits of the particle colonies' R(t) (``cases/data/particles_paper/lam=*/history.csv``).

    Model units (tau = 1, l0 = 1), the time column t. One row per colony and fit
    (``fits``: the radius column, ``radius`` = smallest disc about the centroid holding every
    particle, or ``hull_radius`` = sqrt(hull area / pi), and the smallest radius kept):
    the true lam (config.json), lam_fit and its 95 % profile-likelihood interval, whether it
    covers the truth, fit / true, sigma, the time origin t0 (the particle colony is one cell
    at t = 0) and the residuals' lag-1 autocorrelation.
    """
    root = Path(root) if root is not None else DATA / "particles_paper"
    rows = []
    for folder in sorted(root.glob("lam=*"), key=lambda p: float(p.name[4:])):
        lam_true = float(json.loads((folder / "config.json").read_text())["lam"])
        for column, min_radius in fits:
            t, R, _ = read_series(folder / "history.csv", "t", column)
            keep = R >= min_radius
            res = fit_colony(t[keep], R[keep], tau_minutes=1.0, cell_length_um=1.0)
            rows.append({"lam_true": lam_true, "column": column, "min_radius": min_radius,
                         "n": res.n, "lam_fit": res.lam, "lo": res.lo, "hi": res.hi,
                         "covers": bool(res.lo <= lam_true <= res.hi),
                         "ratio": res.lam / lam_true if lam_true > 0 else math.nan,
                         "sigma": res.sigma, "t0": res.t0, "lag1": res.lag1})
    return rows


def _write_table(rows: list[dict], path: Path) -> None:
    cols = list(rows[0])

    text = io.StringIO(newline="")
    w = csv.writer(text, lineterminator="\n")
    w.writerow(cols)
    for r in rows:
        w.writerow([f"{r[c]:.6g}" if isinstance(r[c], float) else r[c] for c in cols])
    replace_file(path.parent, path.name, lambda fh: fh.write(text.getvalue().encode("utf-8")))


def _markdown(rows: list[dict]) -> str:
    """The table of :func:`particle_table`, one line per colony, one column group per fit."""
    fits = list(dict.fromkeys((r["column"], r["min_radius"]) for r in rows))
    head = ["lam true"] + [f"{c}{f', R >= {m:g}' if m else ''}: lam fit [95 %], fit/true"
                           for c, m in fits] + ["t0 (radius)", "lag-1 (radius)"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for lam in dict.fromkeys(r["lam_true"] for r in rows):
        mine = {(r["column"], r["min_radius"]): r for r in rows if r["lam_true"] == lam}
        cells = [f"{lam:g}"]
        for key in fits:
            r = mine[key]
            ratio = "" if math.isnan(r["ratio"]) else f", {r['ratio']:.3g}"
            mark = "" if r["covers"] else " (misses)"
            cells.append(f"{r['lam_fit']:.3g} [{r['lo']:.3g}, {r['hi']:.3g}]{mark}{ratio}")
        first = mine[fits[0]]
        cells += [f"{first['t0']:.3f}", f"{first['lag1']:.3f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    """Command line (module docstring)."""
    argv = sys.argv[1:] if argv is None else argv
    out = _out_folder(Path(argv[0]) if argv else DATA / "fit")
    table = particle_table()
    _write_table(table, out / "particles.csv")
    one = fit_file(DATA / "particles_paper" / "lam=0.01" / "history.csv", time_column="t",
                   radius_column="radius", tau_minutes=1.0, cell_length_um=1.0)
    replace_file(out, "particles_lam=0.01.png", lambda fh: plot_fit(one, fh))
    print(_markdown(table))


if __name__ == "__main__":
    main()
