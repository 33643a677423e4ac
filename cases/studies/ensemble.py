"""Seed ensembles of particle colonies: mean and spread of every Fig 3 / Fig 4 quantity.

(work in progress)
"""

from __future__ import annotations

from typing import Any

from cases.sweep import _engine_params, scale_config

#: Ensemble sizes. medium: the lam of the medium figure cases' curves (Fig 3A-B, 4A-B) at
#: radius 40, 8 seeds each, and the other two scaling lam of Fig 3C-D / 4C; "numerics": one run
#: per halved step setting (dt, tol) at the first seed of ``numerics_lam``.
ENSEMBLES: dict[str, dict[str, Any]] = {
    "smoke": {"scale": "smoke", "radius": 10.0, "lams": (0.1,), "seeds": 3,
              "numerics_lam": 0.1, "numerics": ({"dt": 0.005}, {"tol": 5e-4})},
    "medium": {"scale": "medium", "radius": 40.0, "lams": (0.0, 1e-3, 1e-2, 3e-2, 3e-3, 1e-1),
               "seeds": 8, "numerics_lam": 1e-3, "numerics": ({"dt": 0.005}, {"tol": 5e-4})},
}


def particle_params(lam: float, seed: int, scale: str, **settings: Any) -> dict[str, Any]:
    """Sweep parameters of one particle colony of the ensemble (seed 0: the figure cases' run)."""
    ens = ENSEMBLES[scale]
    params = _engine_params("particles", lam, scale_config(ens["scale"]))
    params["radius"] = ens["radius"]
    if seed:
        params["seed"] = int(seed)
    return params | settings
