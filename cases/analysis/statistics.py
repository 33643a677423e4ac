"""Numbers of a run's time series and of a sweep: late slope, maxima, power laws, the E. coli lam.

- :func:`late_slope`: the late-time dR/dt by a linear fit (Fig 3D); :func:`max_value` (Fig 3C);
- :func:`power_law_fit`: exponent and prefactor of y = C x^a (Fig 3C, Fig 4C);
- :func:`ecoli_lambda`: the paper's estimate lam ~ 1.1e-3 for E. coli from its late speed.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["late_slope", "max_value", "power_law_fit", "ecoli_lambda"]


def late_slope(t: np.ndarray, R: np.ndarray, fraction: float = 0.2) -> float:
    """Late-time growth rate dR/dt: least-squares slope of R(t) over the last part of the run.

    The fit uses the samples with t >= t_end - fraction (t_end - t_start) (at least the last two).
    """
    t = np.asarray(t, dtype=float).ravel()
    R = np.asarray(R, dtype=float).ravel()
    if t.shape != R.shape:
        raise ValueError(f"t and R differ in length: {t.size} != {R.size}")
    if not 0 < fraction <= 1:
        raise ValueError(f"fraction must be in (0, 1], got {fraction}")
    keep = np.isfinite(t) & np.isfinite(R)
    t, R = t[keep], R[keep]
    if t.size < 2:
        raise ValueError("need at least two finite samples")
    order = np.argsort(t)
    t, R = t[order], R[order]
    late = t >= t[-1] - fraction * (t[-1] - t[0])
    if late.sum() < 2:
        late[-2:] = True
    return float(np.polyfit(t[late], R[late], 1)[0])


def max_value(values: np.ndarray) -> float:
    """Largest finite value (e.g. max stress, max pressure); ValueError if there is none."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        raise ValueError("no finite values")
    return float(v.max())


def power_law_fit(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Fit y = C x^a by least squares on (log x, log y); returns (a, C).

    Only positive, finite pairs are used; at least two are needed.
    """
    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    if x.shape != y.shape:
        raise ValueError(f"x and y differ in length: {x.size} != {y.size}")
    keep = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    if keep.sum() < 2 or np.unique(x[keep]).size < 2:
        raise ValueError("need at least two positive pairs with distinct x")
    a, logC = np.polyfit(np.log(x[keep]), np.log(y[keep]), 1)
    return float(a), float(np.exp(logC))


def ecoli_lambda(
    tau_min: float = 54.0, l0_um: float = 1.0, dRdt_um_per_s: float = 1.3e-2
) -> float:
    """Dimensionless stress sensitivity from a colony's late radial speed (paper, last paragraph).

    Late growth is linear, dR/dt ~ sqrt(2/lam) in units l0/tau, so with the dimensionless speed
    v = (dR/dt) tau / l0 the estimate is lam ~ 2 / v^2. E. coli (tau = 54 min, l0 = 1 um,
    dR/dt = 1.3e-2 um/s): v = 42.1, lam = 1.13e-3 (the paper's 1.1e-3).
    """
    for name, val in (("tau_min", tau_min), ("l0_um", l0_um), ("dRdt_um_per_s", dRdt_um_per_s)):
        if not (math.isfinite(val) and val > 0):
            raise ValueError(f"{name} must be finite and > 0, got {val}")
    v = dRdt_um_per_s * tau_min * 60.0 / l0_um
    return 2.0 / v**2

