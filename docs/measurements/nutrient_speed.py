"""What the nutrient costs: the same colony grown with and without it, side by side (issue 56).

For each engine, runs without the nutrient and with it fed at the edge (``--ell``, K = inf)
alternate, ``--repeats`` pairs each, in this process (one solver thread, no output files);
the table gives the median wall and CPU seconds of each, their ratio (nutrient / none) and
the final times. The issue's goal: at most 1.5x for the continuum to radius 150
and 1.2x for particles to radius 100.

Command line (from the repository root, the package installed)::

    python docs/measurements/nutrient_speed.py [--lam 1e-2] [--ell 10]
        [--continuum-radius 150] [--particles-radius 100] [--repeats 3]
        [--particle-repeats 1] [--engines continuum particles] [--out runs/nutrient_speed.csv]

A particle run first compiles the engine's kernels (or reads Numba's cache): one tiny run of
each setting comes first and is not timed.
"""

from __future__ import annotations

import argparse
import csv
import statistics
import time
from pathlib import Path


def grow(engine: str, lam: float, radius: float, ell: float | None) -> dict[str, float]:
    """One colony to ``radius``, no output: wall and CPU seconds, final time."""
    if engine == "continuum":
        import continuum as E

        config = E.Config(lam=lam, radius=radius, nutrient_length=ell)
    else:
        import particles as E

        config = E.Config(lam=lam, radius=radius, nutrient_length=ell, threads=1)
    wall, cpu = time.perf_counter(), time.process_time()
    sim = E.run(config)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    return {"wall": wall, "cpu": cpu, "t": float(sim.state.t)}


def main(argv: list[str] | None = None) -> list[dict]:
    """Measure, print the Markdown table, write the CSV of every run."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lam", type=float, default=1e-2)
    ap.add_argument("--ell", type=float, default=10.0)
    ap.add_argument("--continuum-radius", type=float, default=150.0)
    ap.add_argument("--particles-radius", type=float, default=100.0)
    ap.add_argument("--repeats", type=int, default=3, help="pairs per engine (continuum)")
    ap.add_argument("--particle-repeats", type=int, default=1)
    ap.add_argument("--engines", nargs="+", default=["continuum", "particles"],
                    choices=["continuum", "particles"])
    ap.add_argument("--out", type=Path, default=Path("runs/nutrient_speed.csv"))
    args = ap.parse_args(argv)
    rows = []
    for engine in args.engines:
        radius = args.continuum_radius if engine == "continuum" else args.particles_radius
        repeats = args.repeats if engine == "continuum" else args.particle_repeats
        for ell in (None, args.ell):  # compile / warm up, untimed
            grow(engine, args.lam, 3.0, ell)
        for k in range(repeats):
            for ell in (None, args.ell) if k % 2 == 0 else (args.ell, None):
                r = grow(engine, args.lam, radius, ell)
                rows.append({"engine": engine, "radius": radius, "ell": ell or "none",
                             "repeat": k, **r})
                print(f"{engine} R={radius:g} ell={ell}: {r['wall']:.1f} s wall, "
                      f"{r['cpu']:.1f} s CPU, t = {r['t']:.4f}", flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with args.out.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print("\n| engine | radius | runs | none: wall / CPU (median) | ell = "
          f"{args.ell:g}: wall / CPU | ratio wall / CPU | t at the radius: none / ell |")
    print("|---|---|---|---|---|---|---|")
    for engine in args.engines:
        sel = {e: [r for r in rows if r["engine"] == engine and (r["ell"] == "none") == (e == 0)]
               for e in (0, 1)}
        med = {e: {q: statistics.median(r[q] for r in sel[e]) for q in ("wall", "cpu", "t")}
               for e in (0, 1)}
        print(f"| {engine} | {sel[0][0]['radius']:g} | {len(sel[0])} + {len(sel[1])} | "
              f"{med[0]['wall']:.1f} / {med[0]['cpu']:.1f} | {med[1]['wall']:.1f} / "
              f"{med[1]['cpu']:.1f} | {med[1]['wall'] / med[0]['wall']:.2f} / "
              f"{med[1]['cpu'] / med[0]['cpu']:.2f} | {med[0]['t']:.3f} / {med[1]['t']:.3f} |")
    return rows


if __name__ == "__main__":
    main()
