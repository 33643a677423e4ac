"""Controlled experiments on the decay of boundary modes (docs/validation.md, "Shape stability").

A disc of radius 3 with a 1 % mode K (r = 3 (1 + 0.01 cos K theta)) grows at lam = 0 over
t in [0, 1]; the measured rate of the mode's relative amplitude (cases.studies.stability,
least-squares slope of ln amplitude at 11 times) is compared with the exact -K/2. Each row
switches one ingredient of the continuum solver:

- ``flux``: the filter of the boundary flux (continuum.velocity.boundary_velocity):
  ``q5`` the default (five-point filter of the flux density q = r/L), ``r3`` the filter before
  the fix (r <- (r_{i-1} + 2 r_i + r_{i+1})/4 of the integrated flux r, then u = -(r/L) n),
  ``q3`` the same three-point filter applied to q, ``none`` no filter;
- ``remesh``: rebuild the mesh (boundary resampled to equal spacing) after every sample;
- ``recovery``: interior velocity by patch recovery (SPR, default) or the plain patch average;
- ``courant``: the time step's Courant number (default 0.6);
- ``nodes``: the node count (default 2000).

The variants of the flux and of the recovery replace the module functions of continuum.velocity
for the duration of a run (:func:`solver_variant`); the solver itself has only the default.

Command line (from the repository root, the package installed)::

    python docs/measurements/boundary_modes.py [--modes 6 8]
"""

from __future__ import annotations

import argparse
import contextlib
import tempfile
from collections.abc import Iterator

import numpy as np

import continuum.velocity as V
from cases.analysis import markdown_rows
from cases.studies.stability import measure_rate

__all__ = ["FLUX_FILTERS", "solver_variant", "experiment", "main"]


def _three_point(x: np.ndarray) -> np.ndarray:
    return 0.25 * (np.roll(x, 1) + 2.0 * x + np.roll(x, -1))


def _flux(kind: str):
    """Boundary velocity u = -q n with the flux filter ``kind`` (module docstring)."""

    def boundary_velocity(residual, boundary, filter=True):
        n, L = V.boundary_normals(boundary)
        r = residual[: len(boundary)]
        if kind == "r3":
            q = _three_point(r) / L
        elif kind == "q3":
            q = _three_point(r / L)
            q = q + (np.sum(r) - np.sum(q * L)) / np.sum(L)
        else:
            q = r / L
        return -q[:, None] * n

    return boundary_velocity


FLUX_FILTERS = ("q5", "r3", "q3", "none")
"""Flux filters of the experiment; q5 is the solver's own (continuum.velocity.flux_filter)."""


@contextlib.contextmanager
def solver_variant(flux: str = "q5", recovery: str = "spr") -> Iterator[None]:
    """Run with another boundary flux filter and / or interior recovery, restoring them after."""
    if flux not in FLUX_FILTERS or recovery not in ("spr", "average"):
        raise ValueError(f"unknown variant flux={flux!r} recovery={recovery!r}")
    saved = V.boundary_velocity, V.recovered_gradient
    try:
        if flux != "q5":
            V.boundary_velocity = _flux(flux)
        if recovery == "average":
            rg = saved[1]
            V.recovered_gradient = lambda tris, area, grads, f, points=None: rg(
                tris, area, grads, f, None)
        yield
    finally:
        V.boundary_velocity, V.recovered_gradient = saved


EXPERIMENTS = [  # (flux, recovery, remesh, courant, nodes)
    ("q5", "spr", False, 0.6, 2000),
    ("r3", "spr", False, 0.6, 2000),
    ("r3", "spr", True, 0.6, 2000),
    ("q3", "spr", False, 0.6, 2000),
    ("none", "spr", False, 0.6, 2000),
    ("q5", "spr", True, 0.6, 2000),
    ("q5", "average", False, 0.6, 2000),
    ("q5", "spr", False, 0.15, 2000),
    ("r3", "spr", False, 0.6, 8000),
    ("q5", "spr", False, 0.6, 8000),
]


def experiment(K: int, flux: str, recovery: str, remesh: bool, courant: float, nodes: int,
               folder: str) -> dict:
    """One run of the table: the measured rate, its relative error and the spacing spread."""
    with solver_variant(flux, recovery):
        row = measure_rate(K, 0.0, nodes, 1.0, 11, folder, R=3.0, eps=0.01, remesh=remesh,
                           courant=courant)
    return dict(row, error=row["measured"] / (-K / 2) - 1.0)


def main(argv: list[str] | None = None) -> None:
    """Run the experiments of ``--modes`` and print the table (markdown)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--modes", type=int, nargs="+", default=[6, 8])
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for K in args.modes:
            for flux, recovery, remesh, courant, nodes in EXPERIMENTS:
                r = experiment(K, flux, recovery, remesh, courant, nodes, folder)
                rows.append((K, flux, recovery, "every 0.1" if remesh else "none", courant,
                             r["nodes"], f"{r['measured']:.4f}", f"{100 * r['error']:+.2f}",
                             f"{r['spacing_spread']:.4f}"))
                print(*rows[-1], flush=True)
    print(markdown_rows(("K", "flux filter", "recovery", "remesh", "courant", "nodes",
                         "rate", "error %", "spacing std/mean at t = 1"), rows))


if __name__ == "__main__":
    main()
