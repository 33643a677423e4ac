"""How a particle colony's cost grows with its radius, and what a larger colony would cost.

Issue 33 (goal 3) asks how the cost of a colony grows with R from 40 to 150 to 260, against the
largest published run of the model (a C++/PETSc code: 24 h on 112 cores, wall time growing as
R^5). From recorded runs (folders of ``docs/measurements/records.py``: ``progress.log``,
``time.txt``, ``config.json``) the script reads the once-a-minute progress lines
(:func:`cases.analysis.progress_lines`: radius, particles, wall seconds, a resumed run's clock
continued) and gives, per run:

- the wall seconds at each of ``--radii`` (linear in R between the progress lines and the end:
  the history's last radius at the ``time -v`` reports' wall, when that is later than the last
  line; blank below the first line, written after a minute);
- the exponent a of W ~ R^a, least squares of log W on log R over the progress lines with R in
  ``--fit`` (and b of N ~ R^b likewise);
- the projection to ``--target``: W(R_t) = W(R_last) (R_t / R_last)^a, N(R_t) the same with b,
  the cores' hours W(R_t) u with u = user CPU / wall of the run's ``time -v`` reports (the
  threads it kept busy), and the peak memory scaled by N(R_t) / N(R_last).

A projection is not a measurement: the exponent is fitted where the run was measured and
assumed to hold beyond it.  Runs on a shared machine (the ensemble seeds beside other jobs) run
slower and their exponents carry the load of the other jobs; compare the runs grown alone.

    python docs/measurements/cost_growth.py --runs cases/data/particles_paper/lam=*
           [--radii 50 75 100 150] [--fit 75 150] [--target 260]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from cases import analysis as A

if str(Path(__file__).parent) not in sys.path:  # the sibling scripts, also when imported
    sys.path.insert(0, str(Path(__file__).parent))
from records import summary  # noqa: E402

#: The largest published run of the model (issue 33): wall hours, cores, wall exponent in R.
PUBLISHED = {"radius": 260, "wall_h": 24.0, "cores": 112, "exponent": 5.0}


def growth(run: str | Path, radii: list[float], fit: tuple[float, float],
           target: float) -> dict:
    """The row of the module docstring for the recorded run folder ``run``."""
    run = Path(run)
    lines = A.progress_lines(run / "progress.log")
    R, W, N = lines["radius"], lines["wall"], lines["particles"]
    fitted = (R >= fit[0]) & (R <= fit[1])
    if fitted.sum() < 3:
        raise ValueError(f"{run}: {fitted.sum()} progress lines with R in [{fit[0]}, {fit[1]}], "
                         "need 3 to fit")
    a, b = A.power_law_fit(R[fitted], W[fitted])[0], A.power_law_fit(R[fitted], N[fitted])[0]
    row = summary(run)
    end = float(A.read_csv(run / "history.csv")["radius"][-1])
    if row["wall_s"] > W[-1] and end > R[-1]:  # the run's end, after its last progress line
        R, W = np.append(R, end), np.append(W, row["wall_s"])
    busy = row["user_s"] / row["wall_s"] if row["wall_s"] > 0 else math.nan
    scale, n_scale = target / R[-1], (target / lines["radius"][-1])**b
    row |= {"run": str(run), "seed": json.loads((run / "config.json").read_text())["seed"],
            "wall_exponent": a, "particle_exponent": b, "busy_threads": busy,
            "target_radius": target, "target_wall_h": W[-1] * scale**a / 3600,
            "target_particles": N[-1] * n_scale,
            "target_peak_mb": row["peak_mb"] * n_scale}
    row["target_core_h"] = row["target_wall_h"] * busy
    for r in radii:
        row[f"wall_s at R={r:g}"] = float(np.interp(r, R, W)) if R[0] <= r <= R[-1] else math.nan
    return row


def table(rows: list[dict], radii: list[float]) -> str:
    """Markdown table of :func:`growth` rows, and the published run's line."""
    head = (["run", "lam", "seed"] + [f"wall at R = {r:g}" for r in radii]
            + ["a (W ~ R^a)", "b (N ~ R^b)", "busy threads", "peak MB",
               f"R = {rows[0]['target_radius']:g}: N", "wall", "core hours", "peak MB"])
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        walls = ["" if math.isnan(r[f"wall_s at R={x:g}"]) else f"{r[f'wall_s at R={x:g}']:.0f} s"
                 for x in radii]
        out.append("| " + " | ".join(
            [r["run"], f"{r['lam']:g}", str(r["seed"])] + walls
            + [f"{r['wall_exponent']:.2f}", f"{r['particle_exponent']:.2f}",
               f"{r['busy_threads']:.2f}", f"{r['peak_mb']:.0f}",
               f"{r['target_particles']:.3g}", f"{r['target_wall_h']:.1f} h",
               f"{r['target_core_h']:.0f}", f"{r['target_peak_mb']:.0f}"]) + " |")
    p = PUBLISHED
    out.append(f"\nPublished (issue 33): R = {p['radius']}, {p['wall_h']:g} h on {p['cores']} "
               f"cores = {p['wall_h'] * p['cores']:.0f} core hours, W ~ R^{p['exponent']:g}.")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> list[dict]:
    """Print the table of the module docstring; returns its rows."""
    ap = argparse.ArgumentParser(prog="python docs/measurements/cost_growth.py",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", nargs="+", required=True, help="recorded run folders")
    ap.add_argument("--radii", nargs="+", type=float, default=[50.0, 75.0, 100.0, 150.0])
    ap.add_argument("--fit", nargs=2, type=float, default=[75.0, 150.0])
    ap.add_argument("--target", type=float, default=260.0)
    args = ap.parse_args(argv)
    if not 0 < args.fit[0] < args.fit[1]:
        ap.error(f"--fit needs 0 < R1 < R2, got {args.fit[0]:g} {args.fit[1]:g}")
    if args.target <= 0:
        ap.error(f"--target must be > 0, got {args.target:g}")
    for run in args.runs:
        if not (Path(run) / "progress.log").is_file():
            ap.error(f"{run}: no progress.log (not a run recorded with records.py)")
    try:
        rows = [growth(r, args.radii, tuple(args.fit), args.target) for r in args.runs]
    except ValueError as e:
        ap.error(str(e))
    print(table(rows, args.radii))
    return rows


if __name__ == "__main__":
    main()
