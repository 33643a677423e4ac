"""How far the transported mean length is from the model's closed form, per initial Psi0.

For each Psi0 of ``--initial`` (``continuum.Config.initial_sizes``: the model's delta carried by
its position, or the smooth bump of ``bump_width`` on the l grid) one colony at ``--lam`` is
grown from the initial disc to ``--radius`` with the default configuration otherwise, and the
mean length of the transported Psi, ``mean_length_psi``, is compared with the closed form for
Psi0 = delta(l - 1), lbar = 2^frac(G / ln 2) (continuum.growth.mean_length):

- at every node: the median and largest ``abs(mean_length_psi - lbar)`` over all nodes and away from
  the ring jumps (nodes with frac(G / ln 2) in [0.1, 0.9]);
- in the radial profile the figures draw (profile.csv, cases.analysis.continuum_profile): the
  median and largest ``abs(mean_length_psi - mean_length_phase)`` over the annuli.

The two runs have the same mesh, pressure and G bit for bit (Psi does not act on the flow).

Command line (from the repository root, the package installed)::

    python docs/measurements/initial_sizes.py [--radius 40] [--lam 1e-2] [--initial bump delta]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from cases.analysis import markdown_rows
from cases.analysis.continuum_runs import continuum_profile
from continuum import Config, Simulation
from continuum.growth import LN2, mean_length
from continuum.sizes import INITIAL_SIZES

__all__ = ["mean_length_errors", "main"]


def mean_length_errors(radius: float, lam: float, initial: str) -> dict:
    """One run to ``radius`` from the Psi0 ``initial``; its mean length against 2^frac(G/ln 2)."""
    config = Config(lam=lam, radius=radius, initial_sizes=initial)
    cpu = time.process_time()
    state = Simulation(config).advance()
    cpu = time.process_time() - cpu
    fields = state.fields
    G = fields["G"]
    error = np.abs(fields["mean_length_psi"] - mean_length(G))
    phase = np.mod(G / LN2, 1.0)
    away = error[(phase >= 0.1) & (phase <= 0.9)]
    prof = continuum_profile(state.points, state.triangles, fields)
    ok = np.isfinite(prof["mean_length_psi"]) & np.isfinite(prof["mean_length_phase"])
    dprof = np.abs(prof["mean_length_psi"][ok] - prof["mean_length_phase"][ok])
    return {"initial_sizes": initial, "radius": radius, "nodes": len(G),
            "remeshes": state.n_remesh, "median_all": float(np.median(error)),
            "max_all": float(error.max()), "median_away": float(np.median(away)),
            "max_away": float(away.max()), "profile_median": float(np.median(dprof)),
            "profile_max": float(dprof.max()), "std_median": float(np.median(
                fields["length_std_psi"])), "cpu_s": cpu,
            "transport_s": state.timings["transport"]}


def main(argv: list[str] | None = None) -> list[dict]:
    """Command line: print a markdown table of :func:`mean_length_errors` per Psi0."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--radius", type=float, default=40.0)
    parser.add_argument("--lam", type=float, default=1e-2)
    parser.add_argument("--initial", nargs="+", default=["bump", "delta"],
                        choices=[s for s in INITIAL_SIZES if s != "histogram"])
    args = parser.parse_args(argv)
    rows = [mean_length_errors(args.radius, args.lam, s) for s in args.initial]
    columns = list(rows[0])
    print(markdown_rows(columns, [[f"{r[c]:.3g}" if isinstance(r[c], float) else r[c]
                                   for c in columns] for r in rows]))
    return rows


if __name__ == "__main__":
    main()
