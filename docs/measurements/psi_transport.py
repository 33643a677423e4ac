"""Accuracy and cost of the transports of the size distribution Psi on a whole continuum run.

For each transport of ``--transports`` (``continuum.Config.psi_transport``) one colony at
``--lam`` from the bump Psi0 (``initial_sizes = "bump"``; the default delta is carried exactly
whatever the transport, docs/measurements/initial_sizes.py) is grown from the initial disc to
``--radius``, and the mean length of the transported
Psi, ``mean_length_psi``, is compared at every node with the exact answer: the initial bump
shifted by G / ln 2 along its characteristic (``CharacteristicSizes.bump`` advanced by the
node's G in one exact step). The error is reported away from the ring jumps (nodes whose phase
frac(G / ln 2 + w), w the bump's centre, is more than 2 w from a division), where a smeared Psi
shows as an error of order one, and over all nodes; with the spread of the total length per
area (constant for the exact solution) and the CPU seconds of the run and of its transport.
The table of docs/validation.md also has the two transports measured against it and removed
since (``continuum.sizes.REMOVED_TRANSPORTS``): that commit's checkout of this script measures
them.

Command line (from the repository root, the package installed)::

    python docs/measurements/psi_transport.py [--radius 40] [--lam 1e-2]
        [--transports characteristics-labels]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from cases.analysis import markdown_rows
from continuum import Config, Simulation
from continuum.growth import LN2
from continuum.sizes import TRANSPORTS, CharacteristicSizes, LengthGrid

__all__ = ["psi_errors", "main"]


def psi_errors(radius: float, lam: float, transport: str) -> dict:
    """One run to ``radius``; errors of its transported mean length against the exact shift."""
    config = Config(lam=lam, radius=radius, initial_sizes="bump", psi_transport=transport)
    cpu = time.process_time()
    sim = Simulation(config)
    state = sim.advance(radius=radius)
    cpu = time.process_time() - cpu
    G, w = state.G, config.bump_width
    exact = CharacteristicSizes.bump(LengthGrid(config.n_length_cells), len(G), width=w)
    exact.advance(G, 1.0)
    error = np.abs(state.fields["mean_length_psi"] - exact.mean_length())
    phase = np.mod(G / LN2 + w, 1.0)
    away = np.minimum(phase, 1.0 - phase) > 2 * w
    total = state.fields["total_length"]
    near = error[away] if away.any() else np.array([np.nan])  # small colonies: all near a jump
    return {"transport": transport, "radius": radius, "nodes": len(G),
            "remeshes": state.n_remesh, "median_away": float(np.median(near)),
            "max_away": float(near.max()), "median_all": float(np.median(error)),
            "max_all": float(error.max()),
            "total_length_spread": float(np.ptp(total) / np.mean(total)),
            "cpu_s": cpu, "transport_s": state.timings["transport"]}


def main(argv: list[str] | None = None) -> list[dict]:
    """Command line: print a markdown table of :func:`psi_errors` per transport."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--radius", type=float, default=40.0)
    parser.add_argument("--lam", type=float, default=1e-2)
    parser.add_argument("--transports", nargs="+", default=list(TRANSPORTS), choices=TRANSPORTS)
    args = parser.parse_args(argv)
    rows = [psi_errors(args.radius, args.lam, t) for t in args.transports]
    columns = list(rows[0])
    print(markdown_rows(columns, [[f"{r[c]:.3g}" if isinstance(r[c], float) else r[c]
                                   for c in columns] for r in rows]))
    return rows


if __name__ == "__main__":
    main()
