"""The small continuum run of the API and restart tests, and the bytes that compare runs.

SMALL remeshes at steps 14, 17 and 20 of its 21 steps to radius 3 and writes frames, within a
fraction of a second. The subprocess scripts of test_restart.py import this module as
``tests.continuum.conftest``.
"""

from __future__ import annotations

import numpy as np

from continuum import Config

SMALL = dict(lam=1e-2, n_nodes=100, h_max=0.25, stretch=1.2, output_every=0.5)
"""The small configuration without its stop (a Simulation stepped by hand)."""

SMALL_RADIUS = 3.0
"""Where a run of SMALL stops."""


def small_config(**changes) -> Config:
    """SMALL to radius SMALL_RADIUS, with ``changes``."""
    return Config(**{**SMALL, "radius": SMALL_RADIUS, **changes})


def state_bytes(sim) -> dict:
    """The raw bytes of a simulation's history and state (mesh, boundary, fields, Psi, counters)."""
    s = sim.state
    out = {
        "history": np.array([[float(v) for v in row.values()] for row in sim.history]).tobytes(),
        "points": s.points.tobytes(),
        "triangles": s.triangles.tobytes(),
        "boundary": s.boundary.tobytes(),
        "psi": s.sizes.n.tobytes(),
        "scalars": np.array([s.t, s.step, s.n_remesh, s.newton, s.krylov, s.n_boundary]).tobytes(),
    }
    out.update({f"field {k}": np.ascontiguousarray(v).tobytes() for k, v in s.fields.items()})
    return out
