"""Numbers of a run's time series and of a sweep: late slope, maxima, power laws, the E. coli lam.

- :func:`late_slope`: the late-time dR/dt by a linear fit (Fig 3D); :func:`max_value` (Fig 3C);
- :func:`power_law_fit`: exponent and prefactor of y = C x^a (Fig 3C, Fig 4C);
- :func:`central_value`: the centre value p(0) of a noisy radial profile by a least-squares fit
  (without the upward bias of the largest annulus mean);
- :func:`seed_spread`: mean, standard deviation and 95 % intervals over the seeds of an ensemble;
- :func:`time_at_radius`: the time a colony first reaches each of several radii;
- :func:`ecoli_lambda`: the paper's estimate lam ~ 1.1e-3 for E. coli from its late speed.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

__all__ = ["late_slope", "max_value", "power_law_fit", "power_law_interval", "ecoli_lambda",
           "central_value",
           "CENTRAL_FRACTION", "seed_spread", "time_at_radius"]


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
    x, y, keep = _positive_pairs(x, y)
    a, logC = np.polyfit(np.log(x[keep]), np.log(y[keep]), 1)
    return float(a), float(np.exp(logC))


def _positive_pairs(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, y, keep) as float arrays, keep the positive, finite pairs (at least two distinct x)."""
    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    if x.shape != y.shape:
        raise ValueError(f"x and y differ in length: {x.size} != {y.size}")
    keep = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    if keep.sum() < 2 or np.unique(x[keep]).size < 2:
        raise ValueError("need at least two positive pairs with distinct x")
    return x, y, keep


def power_law_interval(x: np.ndarray, y: np.ndarray, sd: np.ndarray | None = None,
                       level: float = 0.95) -> tuple[float, float, float, float]:
    """Exponent a of y = C x^a with its ``level`` interval: (a, lo, hi, C).

    Weighted least squares on (log x, log y) over the positive, finite pairs, each weighted by
    1 / s_i^2, s_i = sd_i / y_i the standard error of log y_i. With every ``sd`` given, the
    standard error of a is sqrt([(X^T W X)^-1]_aa), times sqrt(chi^2 / (n - 2)) where that
    exceeds 1 (the scatter says more than the errors), and the interval a -+ z se (normal
    quantile; at least the nominal coverage). Without them (``sd`` None or any nan) the pairs
    are weighted alike, se from the scatter, chi^2 / (n - 2), and the interval a -+ t_{n-2} se
    (nan for n = 2).
    """
    from scipy import stats

    x, y, keep = _positive_pairs(x, y)
    s = np.full(x.shape, math.nan) if sd is None else np.asarray(sd, dtype=float).ravel()
    if s.shape != x.shape:
        raise ValueError(f"sd and x differ in length: {s.size} != {x.size}")
    lx, ly, ls = np.log(x[keep]), np.log(y[keep]), s[keep] / y[keep]
    known = np.isfinite(ls) & (ls > 0)
    w = 1.0 / ls**2 if known.all() else np.ones(lx.size)
    X = np.stack([np.ones_like(lx), lx], axis=1)
    cov = np.linalg.inv(X.T @ (X * w[:, None]))
    logC, a = cov @ (X.T @ (w * ly))
    n = lx.size
    chi2 = float(np.sum(w * (ly - logC - a * lx) ** 2))
    if known.all():  # the errors set the width, widened where the scatter exceeds them
        scale = max(1.0, chi2 / (n - 2)) if n > 2 else 1.0
        q = stats.norm.ppf(0.5 + level / 2)
    else:  # the scatter alone
        scale = chi2 / (n - 2) if n > 2 else math.nan
        q = stats.t.ppf(0.5 + level / 2, n - 2) if n > 2 else math.nan
    half = q * math.sqrt(cov[1, 1] * scale)
    return float(a), float(a - half), float(a + half), float(math.exp(logC))


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



#: Outer end of the central region fitted by :func:`central_value`, as a fraction of the radius.
#: The neglected quartic term of the radial pressure biases the fitted p(0) of the exact profile
#: by less than 1 % for every lam of the figures (docs/results.md, "The stress offset").
CENTRAL_FRACTION = 0.5


def central_value(r: np.ndarray, mean: np.ndarray, radius: float,
                  count: np.ndarray | None = None, fraction: float = CENTRAL_FRACTION
                  ) -> tuple[float, float, float]:
    """Centre value p0 of a radial profile by a least-squares fit p(r) = p0 - c r^2.

    The annulus means ``mean`` at radii ``r`` with r < ``fraction`` x ``radius`` are fitted,
    weighted by their sample ``count`` (equal weights when None), by the straight line
    p0 - c r^2 in r^2. Unlike the largest annulus mean (:func:`max_value`), whose expectation
    exceeds the largest expected mean by about the noise of the annuli near the top, the fit is
    linear in the means, hence unbiased for a profile of that form (the radial pressure
    p = (R^2 - r^2)/4 at lam = 0; for lam > 0 the O(r^4) term is neglected). Its standard error
    is taken from the residuals e of the fit, sqrt(s^2 [(X^T W X)^-1]_00) with
    s^2 = sum w e^2 / (n - 2) (weights normalised to mean 1, n annuli), so it needs no noise
    model (neighbouring particles' loads are correlated along force chains, which makes
    std / sqrt(count) too small).

    Returns
    -------
    (p0, stderr, c); stderr is nan with fewer than three annuli in the region.

    Raises
    ------
    ValueError
        For fewer than two finite annuli in the central region or a bad ``fraction``/``radius``.
    """
    r = np.asarray(r, dtype=float).ravel()
    y = np.asarray(mean, dtype=float).ravel()
    if r.shape != y.shape:
        raise ValueError(f"r and mean differ in length: {r.size} != {y.size}")
    if not (math.isfinite(radius) and radius > 0):
        raise ValueError(f"radius must be finite and > 0, got {radius}")
    if not 0 < fraction <= 1:
        raise ValueError(f"fraction must be in (0, 1], got {fraction}")
    w = np.ones_like(r) if count is None else np.asarray(count, dtype=float).ravel()
    keep = np.isfinite(r) & np.isfinite(y) & (w > 0) & (r < fraction * radius)
    if keep.sum() < 2:
        raise ValueError("need at least two finite annuli in the central region")
    x, y, w = r[keep] ** 2, y[keep], w[keep] / w[keep].mean()
    X = np.column_stack([np.ones_like(x), -x])
    XtW = X.T * w
    cov = np.linalg.inv(XtW @ X)
    p0, c = cov @ (XtW @ y)
    n = x.size
    if n < 3:
        return float(p0), math.nan, float(c)
    e = y - X @ np.array([p0, c])
    s2 = float(np.sum(w * e * e)) / (n - 2)
    return float(p0), float(math.sqrt(s2 * cov[0, 0])), float(c)


def seed_spread(values: np.ndarray, axis: int = 0) -> dict[str, np.ndarray]:
    """Mean and spread of an ensemble's values over its seeds (along ``axis``; nan ignored).

    Returns
    -------
    dict of arrays: ``n`` (finite seeds), ``mean``, ``std`` (sample standard deviation, ddof 1),
    ``ci95`` (half width of the 95 % t-interval of the mean, t_{0.975, n-1} std / sqrt(n): where
    the ensemble mean lies), ``pi95`` (half width of the 95 % normal prediction interval of one
    more seed, t_{0.975, n-1} std sqrt(1 + 1/n): where one colony lies), ``q025`` and ``q975``
    (the 2.5 % and 97.5 % quantiles of the seeds themselves, linear interpolation; with 8 seeds
    nearly their minimum and maximum). Spreads are nan with fewer than two seeds.
    """
    from scipy.stats import t as student_t

    v = np.asarray(values, dtype=float)
    v = np.moveaxis(v, axis, 0)
    n = np.sum(np.isfinite(v), axis=0)
    with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-nan slices give nan
        mean = np.nanmean(v, axis=0)
        std = np.where(n >= 2, np.nanstd(v, axis=0, ddof=1), np.nan)
        tq = np.where(n >= 2, student_t.ppf(0.975, np.maximum(n - 1, 1)), np.nan)
        ci = tq * std / np.sqrt(n)
        pi = tq * std * np.sqrt(1.0 + 1.0 / n)
        q025 = np.nanquantile(v, 0.025, axis=0)
        q975 = np.nanquantile(v, 0.975, axis=0)
    return {"n": n, "mean": mean, "std": std, "ci95": ci, "pi95": pi, "q025": q025,
            "q975": q975}


def time_at_radius(t: np.ndarray, R: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """The first time the colony radius R(t) reaches each of ``radii`` (linear interpolation).

    R(t) of a particle colony is not monotone (divisions, rearrangements); the first crossing is
    that of its running maximum. nan for radii outside [R(t_0), max R].
    """
    t = np.asarray(t, dtype=float).ravel()
    R = np.asarray(R, dtype=float).ravel()
    if t.shape != R.shape:
        raise ValueError(f"t and R differ in length: {t.size} != {R.size}")
    keep = np.isfinite(t) & np.isfinite(R)
    t, R = t[keep], R[keep]
    if t.size < 2:
        raise ValueError("need at least two finite samples")
    order = np.argsort(t, kind="stable")
    t, Rmax = t[order], np.maximum.accumulate(R[order])
    radii = np.asarray(radii, dtype=float)
    out = np.full(radii.shape, np.nan)
    for i, target in np.ndenumerate(radii):
        if not (Rmax[0] <= target <= Rmax[-1]):
            continue
        j = int(np.searchsorted(Rmax, target, side="left"))
        if j == 0:
            out[i] = t[0]
            continue
        R0, R1 = Rmax[j - 1], Rmax[j]
        out[i] = t[j - 1] + (t[j] - t[j - 1]) * (target - R0) / (R1 - R0)
    return out
