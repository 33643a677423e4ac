"""Shared analysis of both engines' outputs (model.md, "Analysis").

Everything here works on plain arrays, so the particle engine (samples = particles) and the
continuum solver (samples = mesh nodes, weighted by their lumped areas) are reduced the same way:

- :func:`equal_area_annuli` / :func:`radial_profile`: averages over annuli of equal area about the
  colony centre, with the standard deviation (Fig 3A, Fig 4A);
- :func:`ring_peaks` / :func:`ring_wavelength`: the ring wavelength, the distance between the
  last two peaks of the radial mean-length profile (Fig 4B, C);
- :func:`late_slope`: the late-time dR/dt by a linear fit (Fig 3D); :func:`max_value` (Fig 3C);
- :func:`power_law_fit`: exponent and prefactor of y = C x^a (Fig 3C, Fig 4C);
- :func:`ecoli_lambda`: the paper's estimate lam ~ 1.1e-3 for E. coli;
- :func:`radial_pressure`, :func:`radial_max_pressure`, :func:`radial_speed`: the closed-form
  radial solution of model.md, used as the analytic curves of Fig 3.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from scipy.signal import find_peaks

__all__ = [
    "equal_area_annuli",
    "annuli_for_edge_width",
    "radial_profile",
    "smooth_profile",
    "ring_peaks",
    "ring_wavelength",
    "late_slope",
    "max_value",
    "power_law_fit",
    "ecoli_lambda",
    "radial_c",
    "radial_pressure",
    "radial_max_pressure",
    "radial_speed",
]


# ----------------------------------------------------------------------------------------------
# equal-area annuli
# ----------------------------------------------------------------------------------------------


def annuli_for_edge_width(radius: float, edge_width: float) -> int:
    """Smallest number N of equal-area annuli whose outermost annulus is at most `edge_width` wide.

    With edges r_k = R sqrt(k/N) the outermost width is R (1 - sqrt(1 - 1/N)), decreasing in N;
    it is <= w iff N >= 1 / (1 - (1 - w/R)^2).
    """
    if not (math.isfinite(radius) and radius > 0):
        raise ValueError(f"radius must be finite and > 0, got {radius}")
    if not (math.isfinite(edge_width) and edge_width > 0):
        raise ValueError(f"edge_width must be finite and > 0, got {edge_width}")
    if edge_width >= radius:
        return 1
    n = max(1, math.ceil(1.0 / (1.0 - (1.0 - edge_width / radius) ** 2)))
    # guard the ceil against round-off in both directions
    while n > 1 and radius * (1.0 - math.sqrt(1.0 - 1.0 / (n - 1))) <= edge_width:
        n -= 1
    while radius * (1.0 - math.sqrt(1.0 - 1.0 / n)) > edge_width:
        n += 1
    return n


def equal_area_annuli(
    r: np.ndarray,
    values: np.ndarray,
    weights: np.ndarray | None = None,
    radius: float | None = None,
    n_annuli: int | None = None,
    edge_width: float | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Weighted mean and standard deviation of `values` over N annuli of equal area.

    The annuli are r_{k} <= r < r_{k+1} with edges r_k = R sqrt(k / N), k = 0..N, so each has area
    pi R^2 / N. A sample at distance r falls in annulus k = floor(N r^2 / R^2) (r = R goes to the
    last one; samples with r > R are ignored). In annulus k, with weights w_i (1 by default;
    the lumped nodal areas for mesh data),

        mean_k = sum w_i v_i / sum w_i,   std_k = sqrt(sum w_i (v_i - mean_k)^2 / sum w_i),

    and r_mid_k = R sqrt((k + 1/2) / N) is the radius halving the annulus' area.

    Parameters
    ----------
    r : distances of the samples from the centre, shape (n,).
    values : sample values, shape (n,).
    weights : non-negative sample weights, shape (n,), or None for equal weights.
    radius : outer radius R; default max(r).
    n_annuli : number N of annuli. Exactly one of `n_annuli`, `edge_width` must be given.
    edge_width : largest allowed width of the outermost annulus; N is the smallest number
        meeting it (:func:`annuli_for_edge_width`).

    Returns
    -------
    r_mid, mean, std, count : arrays of shape (N,); `count` is the number of samples (int);
        mean and std are nan in empty annuli.
    """
    r = np.asarray(r, dtype=float).ravel()
    v = np.asarray(values, dtype=float).ravel()
    if r.shape != v.shape:
        raise ValueError(f"r and values differ in length: {r.size} != {v.size}")
    if r.size == 0:
        raise ValueError("no samples")
    if not (np.all(np.isfinite(r)) and np.all(r >= 0)):
        raise ValueError("r must be finite and >= 0")
    w = np.ones_like(r) if weights is None else np.asarray(weights, dtype=float).ravel()
    if w.shape != r.shape:
        raise ValueError(f"weights and r differ in length: {w.size} != {r.size}")
    if not (np.all(np.isfinite(w)) and np.all(w >= 0)):
        raise ValueError("weights must be finite and >= 0")
    R = float(np.max(r)) if radius is None else float(radius)
    if not (math.isfinite(R) and R > 0):
        raise ValueError(f"radius must be finite and > 0, got {R}")
    if (n_annuli is None) == (edge_width is None):
        raise ValueError("give exactly one of n_annuli and edge_width")
    N = annuli_for_edge_width(R, edge_width) if n_annuli is None else int(n_annuli)
    if N < 1:
        raise ValueError(f"n_annuli must be >= 1, got {n_annuli}")

    inside = (r <= R) & np.isfinite(v)
    k = np.minimum(np.floor(N * (r[inside] / R) ** 2).astype(np.int64), N - 1)
    vi, wi = v[inside], w[inside]
    count = np.bincount(k, minlength=N)
    sw = np.bincount(k, weights=wi, minlength=N)
    swv = np.bincount(k, weights=wi * vi, minlength=N)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(sw > 0, swv / sw, np.nan)
        dev = vi - mean[k]
        var = np.bincount(k, weights=wi * dev * dev, minlength=N)
        std = np.where(sw > 0, np.sqrt(var / sw), np.nan)
    r_mid = R * np.sqrt((np.arange(N) + 0.5) / N)
    return r_mid, mean, std, count


def radial_profile(
    xy: np.ndarray,
    values: Mapping[str, np.ndarray],
    center: np.ndarray | None = None,
    weights: np.ndarray | None = None,
    radius: float | None = None,
    n_annuli: int | None = None,
    edge_width: float | None = None,
) -> dict[str, np.ndarray]:
    """Radial profiles of several fields in equal-area annuli about the colony centre.

    The centre is `center` or the weighted centroid sum w_i x_i / sum w_i of the samples; the
    samples' distances r_i = |x_i - centre| are binned by :func:`equal_area_annuli`.

    Parameters
    ----------
    xy : sample positions, shape (n, 2) (particle centres, or mesh nodes).
    values : name -> sample values (n,), e.g. {"mean_length": l, "stress": sigma}.
    center, weights, radius, n_annuli, edge_width : see :func:`equal_area_annuli`.

    Returns
    -------
    dict of columns ready for CSV: "r", then "<name>" and "<name>_std" per field, then "count".
    """
    xy = np.asarray(xy, dtype=float)
    if xy.ndim != 2 or xy.shape[1] != 2:
        raise ValueError(f"xy must have shape (n, 2), got {xy.shape}")
    if not values:
        raise ValueError("values must name at least one field")
    if center is None:
        w = np.ones(len(xy)) if weights is None else np.asarray(weights, dtype=float)
        if w.sum() <= 0:
            raise ValueError("weights sum to zero")
        center = (w[:, None] * xy).sum(axis=0) / w.sum()
    r = np.hypot(xy[:, 0] - center[0], xy[:, 1] - center[1])
    out: dict[str, np.ndarray] = {}
    count = None
    for name, v in values.items():
        r_mid, mean, std, count = equal_area_annuli(
            r, v, weights=weights, radius=radius, n_annuli=n_annuli, edge_width=edge_width
        )
        out.setdefault("r", r_mid)
        out[name] = mean
        out[f"{name}_std"] = std
    out["count"] = count
    return out


# ----------------------------------------------------------------------------------------------
# ring peaks and wavelength
# ----------------------------------------------------------------------------------------------


def smooth_profile(
    r: np.ndarray,
    profile: np.ndarray,
    width: float,
    grid: np.ndarray,
    stderr: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Gaussian local-linear smoothing of scattered samples (r_i, f_i), evaluated on `grid`.

    At each grid point x the value is a_0 of the weighted least-squares line
    f ~ a_0 + a_1 (r - x) with weights w_i = exp(-(r_i - x)^2 / (2 s^2)), s = `width`, i.e.
    a_0 = sum_i l_i f_i with l_i = w_i (S2 - S1 d_i) / (S0 S2 - S1^2), d_i = r_i - x,
    S_m = sum_i w_i d_i^m. Unlike a plain kernel average it has no bias from the non-uniform
    spacing of equal-area annuli (denser at large r): its bias is (s^2/2) f'', which does not
    move the extrema of a sinusoid. Where the line is undetermined (a single sample in reach) the
    kernel average is used.

    Returns
    -------
    smoothed values on `grid`, and their standard error sqrt(sum_i l_i^2 se_i^2) when the samples'
    standard errors `stderr` are given (zeros otherwise).
    """
    r = np.asarray(r, dtype=float)
    f = np.asarray(profile, dtype=float)
    se2 = None if stderr is None else np.asarray(stderr, dtype=float) ** 2
    grid = np.asarray(grid, dtype=float)
    out = np.empty_like(grid)
    err = np.zeros_like(grid)
    block = max(1, int(4e6 // max(r.size, 1)))
    for start in range(0, grid.size, block):
        x = grid[start : start + block, None]
        d = r[None, :] - x
        w = np.exp(-0.5 * (d / width) ** 2)
        S0, S1, S2 = w.sum(1), (w * d).sum(1), (w * d * d).sum(1)
        det = S0 * S2 - S1 * S1
        ok = det > 1e-10 * np.maximum(S0 * S2, 1e-300)
        with np.errstate(invalid="ignore", divide="ignore"):
            lin = w * (S2[:, None] - S1[:, None] * d) / det[:, None]
            avg = w / S0[:, None]
        weights = np.where(ok[:, None], lin, avg)
        out[start : start + block] = weights @ f
        if se2 is not None:
            err[start : start + block] = np.sqrt((weights * weights) @ se2)
    return out, err


def _clean(
    r: np.ndarray, profile: np.ndarray, stderr: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Finite samples sorted by r (stderr: non-finite treated as 0)."""
    r = np.asarray(r, dtype=float).ravel()
    f = np.asarray(profile, dtype=float).ravel()
    if r.shape != f.shape:
        raise ValueError(f"r and profile differ in length: {r.size} != {f.size}")
    keep = np.isfinite(r) & np.isfinite(f)
    order = np.argsort(r[keep])
    se = None
    if stderr is not None:
        se = np.asarray(stderr, dtype=float).ravel()
        if se.shape != r.shape:
            raise ValueError(f"stderr and r differ in length: {se.size} != {r.size}")
        se = np.nan_to_num(se[keep][order], nan=0.0, posinf=0.0)
    return r[keep][order], f[keep][order], se


def ring_peaks(
    r: np.ndarray,
    profile: np.ndarray,
    stderr: np.ndarray | None = None,
    smoothing: float = 0.5,
    min_prominence: float = 0.02,
    noise_factor: float = 3.0,
    min_separation: float | None = None,
) -> np.ndarray:
    """Radii of the peaks (rings) of a radial mean-length profile, robust to particle noise.

    Method: (1) drop non-finite samples; (2) smooth by Gaussian local-linear regression of
    width s = `smoothing` (:func:`smooth_profile`; default 0.5 = b: features below the particle
    scale are noise) onto a uniform grid of spacing s/8; (3) keep the interior local maxima of
    the smoothed profile whose prominence (scipy.signal.find_peaks) is at least
    max(`min_prominence`, `noise_factor` x median standard error of the smoothed profile), the
    latter propagated from the samples' standard errors `stderr` (for annulus means:
    std / sqrt(count); omit for noise-free continuum data), and that are at least `min_separation`
    apart (default 2 s); (4) refine each by the vertex of the parabola through the grid maximum
    and its two neighbours. The profile's end points are never peaks. `smoothing=0` skips (2)
    and works on the samples themselves (sorted by r).

    Returns
    -------
    Peak radii in increasing order (possibly empty).
    """
    if smoothing < 0 or min_prominence < 0 or noise_factor < 0:
        raise ValueError("smoothing, min_prominence and noise_factor must be >= 0")
    rr, f, se = _clean(r, profile, stderr)
    if rr.size < 3:
        return np.empty(0)
    if smoothing > 0:
        h = smoothing / 8.0
        grid = np.arange(rr[0], rr[-1] + 0.5 * h, h)
        fs, es = smooth_profile(rr, f, smoothing, grid, stderr=se)
        sep = 2.0 * smoothing if min_separation is None else min_separation
    else:
        grid, fs = rr, f
        es = np.zeros_like(f) if se is None else se
        sep = 0.0 if min_separation is None else min_separation
    if grid.size < 3:
        return np.empty(0)
    prominence = max(min_prominence, noise_factor * float(np.median(es)))
    spacing = float(np.median(np.diff(grid)))
    distance = max(1, int(round(sep / spacing))) if spacing > 0 else 1
    idx, _ = find_peaks(fs, prominence=prominence, distance=distance)
    peaks = grid[idx].astype(float)
    # parabolic refinement (exact for a parabola sampled on a uniform grid)
    for j, i in enumerate(idx):
        y0, y1, y2 = fs[i - 1], fs[i], fs[i + 1]
        den = y0 - 2.0 * y1 + y2
        hl, hr = grid[i] - grid[i - 1], grid[i + 1] - grid[i]
        if den < 0 and abs(hl - hr) <= 1e-9 * max(hl, hr):
            peaks[j] = grid[i] + 0.5 * hl * (y0 - y2) / den
    return peaks


def ring_wavelength(r: np.ndarray, profile: np.ndarray, **kwargs) -> float:
    """Ring wavelength: distance between the last two peaks of the radial mean-length profile.

    Peaks as in :func:`ring_peaks` (keyword arguments passed on). Returns nan when fewer than two
    peaks are found.
    """
    peaks = ring_peaks(r, profile, **kwargs)
    if peaks.size < 2:
        return float("nan")
    return float(peaks[-1] - peaks[-2])


# ----------------------------------------------------------------------------------------------
# time series
# ----------------------------------------------------------------------------------------------


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


# ----------------------------------------------------------------------------------------------
# E. coli estimate and the radial solution
# ----------------------------------------------------------------------------------------------


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


def radial_c(lam: float, R: float) -> float:
    """c(R) = [sqrt(1 + lam R^2/2) - 1] / (2 lam R^2) = 1 / (4 (sqrt(1 + lam R^2/2) + 1)).

    The stable second form is used; lam = 0 gives 1/8.
    """
    if lam < 0:
        raise ValueError(f"lam must be >= 0, got {lam}")
    return 1.0 / (4.0 * (math.sqrt(1.0 + 0.5 * lam * R * R) + 1.0))


def radial_pressure(r: np.ndarray, lam: float, R: float) -> np.ndarray:
    """Pressure of the radial colony of radius R (model.md).

    lam > 0: p(r) = (2/lam) ln(1/(8c) - c lam r^2); lam = 0: p = (R^2 - r^2)/4.
    """
    r = np.asarray(r, dtype=float)
    if lam == 0:
        return 0.25 * (R * R - r * r)
    c = radial_c(lam, R)
    return (2.0 / lam) * np.log(1.0 / (8.0 * c) - c * lam * r * r)


def radial_max_pressure(lam: float, R: float) -> float:
    """p(0) = (2/lam) ln(1/(8c)) (lam > 0), R^2/4 (lam = 0): the analytic curve of Fig 3C."""
    return float(radial_pressure(np.zeros(1), lam, R)[0])


def radial_speed(lam: float, R: float) -> float:
    """Boundary speed dR/dt = u(R) = 4 c R; tends to sqrt(2/lam) as lam^(1/2) R -> infinity."""
    return 4.0 * radial_c(lam, R) * R
