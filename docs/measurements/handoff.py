"""Accuracy of the particle-to-continuum hand-off (cases.handoff) against its two parameters.

Outline: the alpha shape of rods packed in a known outline, for several alpha: a disc of
concentric rings (particles.ring_packing; reference the disc reaching the farthest rod outline,
aspect 1) and a W x H = 12 x 6 rectangle of rows of rods 1.5 long (reference its area less the
rounded rod ends, (1 - pi/4) b^2 / 2 per row end, aspect 2). Reported: the area's relative
error and the aspect ratio.

Size distribution: Psi0 on the continuum mesh of a 30 x 30 lattice of rods (rows b apart,
columns 1.5 apart), for several bandwidths h: with lengths 1.2 + 0.02 x, the largest error of
the mean length against 1.2 + 0.02 x at the nodes 4 h inside the edge (the kernel's bias; a
Gaussian kernel on a symmetric lattice has none for a linear field) and the median spread of
the lengths there (that of the field under the kernel, 0.02 h); with a step, lengths 1.8 for
x < 15 and 1.2 beyond (a ring), the 10-90 % width of the mean length's drop along the middle
row (2.56 h for a Gaussian).

Command line (from the repository root, the package installed)::

    python docs/measurements/handoff.py [--alphas 0.5 1 2] [--bandwidths 1 2 3]
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from cases.analysis import markdown_rows
from cases.handoff import (
    ALPHA,
    BANDWIDTH,
    particle_outline,
    polygon_moments,
    rod_outline_points,
    size_distribution,
)
from continuum import Config
from continuum.initial import state_from
from continuum.sizes import LengthGrid
from particles import B, ring_packing

__all__ = ["rod_lattice", "outline_errors", "psi0_errors", "main"]


def rod_lattice(n_cols: int, n_rows: int, length) -> tuple[np.ndarray, ...]:
    """Horizontal rods on a lattice, columns 1.5 apart, rows b apart: (x, y, theta, length).

    The outline is the n_cols 1.5 x n_rows b rectangle with its corner x >= 0, y >= 0 (rods
    1.5 long touch end to end); ``length`` a number or a function of x.
    """
    i, j = np.meshgrid(np.arange(n_cols), np.arange(n_rows))
    x, y = (1.5 * i + 0.75).ravel(), (B * j + 0.5 * B).ravel()
    lengths = np.asarray(length(x) if callable(length) else length, dtype=float)
    return x, y, np.zeros(x.size), np.broadcast_to(lengths, x.shape).copy()


def outline_errors(alpha: float) -> list[dict]:
    """Area error and aspect ratio of the alpha shapes of the reference packings."""
    rows = []
    for n in (400, 1600):
        x, y, th, ln = ring_packing(n, seed=1)
        R = np.hypot(*rod_outline_points(x, y, th, ln).T).max()
        area, aspect = polygon_moments(particle_outline(x, y, th, ln, alpha))
        rows.append({"packing": f"disc, {len(x)} rods, R = {R:.1f}", "alpha": alpha,
                     "area_error": area / (math.pi * R**2) - 1, "aspect": aspect,
                     "aspect_exact": 1.0})
    x, y, th, ln = rod_lattice(8, 12, 1.5)
    exact = 12 * 6 - 2 * 12 * (1 - math.pi / 4) * B**2 / 2
    area, aspect = polygon_moments(particle_outline(x, y, th, ln, alpha))
    rows.append({"packing": "rectangle 12 x 6, 96 rods", "alpha": alpha,
                 "area_error": area / exact - 1, "aspect": aspect, "aspect_exact": 2.0})
    return rows


def psi0_errors(bandwidth: float, n_nodes: int = 1500) -> dict:
    """Bias and spread of Psi0 for a linear length field, the width of a step (docstring)."""
    config = Config(lam=0.01, n_nodes=n_nodes)
    grid = LengthGrid(config.n_length_cells)
    out = {"bandwidth": bandwidth}
    for name, field in (("linear", lambda x: 1.2 + 0.02 * x),
                        ("step", lambda x: np.where(x < 15.0, 1.8, 1.2))):
        x, y, th, ln = rod_lattice(20, 60, field)
        psi0 = size_distribution(x, y, ln, grid, bandwidth)
        state = state_from(config, particle_outline(x, y, th, ln, ALPHA), psi0)
        p, f = state.points, state.fields
        if name == "linear":
            inner = np.all((p > 4 * bandwidth) & (p < 30 - 4 * bandwidth), axis=1)
            err = np.abs(f["mean_length_psi"] - field(p[:, 0]))[inner]
            out["inner_nodes"] = int(inner.sum())
            out["max_mean_error"] = float(err.max()) if err.size else math.nan
            out["median_spread"] = float(np.median(f["length_std_psi"][inner]))
            out["spread_exact"] = 0.02 * bandwidth
        else:
            xs = np.linspace(1.0, 29.0, 561)
            row = np.column_stack([xs, np.full_like(xs, 15.0)])
            m = psi0(row) @ (grid.length_integrals)  # length per area ...
            m = m / (psi0(row).sum(axis=1) * grid.ds)  # ... over number per area
            hi, lo = 1.8 - 0.1 * 0.6, 1.2 + 0.1 * 0.6
            out["step_width_10_90"] = float(xs[np.argmax(m < lo)] - xs[np.argmax(m < hi)])
            out["step_width_exact"] = 2 * 1.2816 * bandwidth
    return out


def main(argv: list[str] | None = None) -> tuple[list[dict], list[dict]]:
    """Command line: print the two markdown tables."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--alphas", type=float, nargs="+", default=[0.5, ALPHA, 2.0])
    parser.add_argument("--bandwidths", type=float, nargs="+", default=[1.0, BANDWIDTH, 3.0])
    args = parser.parse_args(argv)
    outline = [row for alpha in args.alphas for row in outline_errors(alpha)]
    psi0 = [psi0_errors(h) for h in args.bandwidths]
    for rows in (outline, psi0):
        columns = list(rows[0])
        print(markdown_rows(columns, [[f"{r[c]:.3g}" if isinstance(r[c], float) else r[c]
                                       for c in columns] for r in rows]))
        print()
    return outline, psi0


if __name__ == "__main__":
    main()
