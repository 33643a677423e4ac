"""Shared analysis of both engines' outputs (model.md, "Analysis").

Everything here works on plain arrays, so the particle engine (samples = particles) and the
continuum solver (samples = mesh nodes, weighted by their lumped areas) are reduced the same way:

- :func:`equal_area_annuli` / :func:`radial_profile`: averages over annuli of equal area about the
  colony centre, with the standard deviation (Fig 3A, Fig 4A);
- :func:`ring_peaks` / :func:`ring_wavelength`: the ring wavelength, the distance between the
  last two peaks of the radial mean-length profile (Fig 4B, C; particle colonies);
  :func:`ring_coherence`: whether a particle colony has rings at all (the same radial pattern
  in every angular sector);
- continuum rings from the field, not from a binned profile: the contours G = k ln 2 of the
  smooth growth phase (:mod:`continuum.rings`), where lbar = 2^frac(G / ln 2) jumps from 2 to 1
  and so peaks: :func:`frame_rings`, :func:`continuum_rings` (a run's ``rings.csv`` or its last
  frame), :func:`contour_wavelength` (difference of the two outermost mean ring radii);
  continuum radial profiles average G and map the mean by 2^frac(. / ln 2)
  (``mean_length_phase``, :func:`field_profile`), sharp where the annulus mean of the
  discontinuous lbar is smeared;
- :func:`late_slope`: the late-time dR/dt by a linear fit (Fig 3D); :func:`max_value` (Fig 3C);
- :func:`power_law_fit`: exponent and prefactor of y = C x^a (Fig 3C, Fig 4C);
- :func:`ecoli_lambda`: the paper's estimate lam ~ 1.1e-3 for E. coli.

The closed-form radial solution (analytic curves of Fig 3) is :mod:`continuum.radial`.
"""

from __future__ import annotations

import gzip
import math
import os
import warnings
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np
from scipy.signal import find_peaks

from continuum import growth as _growth
from continuum import rings as _rings

__all__ = [
    "equal_area_annuli",
    "annuli_for_edge_width",
    "radial_profile",
    "smooth_profile",
    "ring_peaks",
    "ring_wavelength",
    "ring_coherence",
    "RING_Z",
    "late_slope",
    "max_value",
    "power_law_fit",
    "ecoli_lambda",
    "read_csv",
    "write_csv",
    "markdown_rows",
    "continuum_frames",
    "read_continuum_frame",
    "particle_frames",
    "field_profile",
    "particle_profile",
    "profile_wavelength",
    "thin_rows",
    "colony_radius",
    "wavelength_series",
    "final_continuum_profile",
    "final_particle_profile",
    "frame_rings",
    "continuum_rings",
    "contour_wavelength",
    "continuum_wavelength",
    "profile_ring_radii",
    "mean_length_from_phase",
]

LN2 = math.log(2.0)


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


RING_Z = 3.0
"""Significance of :func:`ring_coherence` (standard deviations of noise) from which a particle
colony counts as having rings, so that its wavelength enters a fitted exponent."""


def ring_coherence(x: np.ndarray, y: np.ndarray, values: np.ndarray, sectors: int = 4,
                   width: float = 1.0, inner: float = 0.5) -> tuple[float, float]:
    """Azimuthal coherence of the radial pattern of ``values`` (particle lengths): rings or noise.

    About the centroid of the points, with R = max r: the disc is cut into S = ``sectors`` equal
    angular sectors; in each, ``values`` are averaged over annuli of ``width`` (default 1 = l0,
    the particle scale) covering inner R <= r <= R - width (annuli empty in some sector are
    dropped), and the least-squares quadratic in r is subtracted (the radial trend). Concentric
    rings make the S profiles alike, noise does not. Returns (C, z),

        C = (1/P) sum over the P = S (S - 1) / 2 sector pairs of the Pearson correlation of
            their profiles,   z = C sqrt(P n),

    n the number of annuli; (nan, nan) when a sector's profile is its trend to rounding (all
    lengths equal, as in the lam = 0 colonies). For independent noise each correlation has mean
    0 and variance about 1/n and the P correlations are uncorrelated, so z is about standard
    normal: z >= 3 says the colony has rings (tested on synthetic noise and rings).
    """
    x, y, v = (np.asarray(a, dtype=float).ravel() for a in (x, y, values))
    if not x.shape == y.shape == v.shape:
        raise ValueError("x, y and values differ in length")
    if sectors < 2 or not width > 0 or not 0 <= inner < 1:
        raise ValueError("need sectors >= 2, width > 0 and 0 <= inner < 1")
    dx, dy = x - x.mean(), y - y.mean()
    r = np.hypot(dx, dy)
    sector = np.minimum(np.floor((np.arctan2(dy, dx) + np.pi) / (2 * np.pi) * sectors), sectors - 1)
    R = r.max() if r.size else 0.0
    edges = np.arange(inner * R, R - width + 1e-12, width)
    if edges.size < 5:
        raise ValueError(f"colony of radius {R:.3g} too small for annuli of width {width:g}")
    profiles = []
    for s in range(sectors):
        m = sector == s
        count = np.histogram(r[m], edges)[0]
        total = np.histogram(r[m], edges, weights=v[m])[0]
        with np.errstate(invalid="ignore", divide="ignore"):
            profiles.append(total / count)
    prof = np.array(profiles)
    keep = np.all(np.isfinite(prof), axis=0)
    rc = 0.5 * (edges[1:] + edges[:-1])[keep]
    prof = prof[:, keep]
    n = rc.size
    prof = prof - np.array([np.polyval(np.polyfit(rc, p, 2), rc) for p in prof])
    if np.std(prof, axis=1).min() <= 1e-9 * max(np.abs(v).max(), 1e-300):
        return math.nan, math.nan  # no radial pattern beyond the trend (e.g. equal lengths)
    corr = np.corrcoef(prof)[np.triu_indices(sectors, 1)]
    C = float(np.mean(corr))
    return C, C * math.sqrt(corr.size * n)


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


# ----------------------------------------------------------------------------------------------
# run folders (docs/DESIGN.md, "Output contract") and small CSVs
# ----------------------------------------------------------------------------------------------


def read_csv(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Read a CSV (or gzipped ``.csv.gz``) with a header row into float columns {name: array};
    empty cells (a column that a run resumed from an older checkpoint lacks) read as NaN."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such CSV file: {path}")
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt") as f:
        header = f.readline().strip()
    names = [h.strip() for h in header.split(",")]
    with warnings.catch_warnings():  # a header-only file is an empty table, not a warning
        warnings.simplefilter("ignore", UserWarning)
        data = np.genfromtxt(path, delimiter=",", skip_header=1, ndmin=2, invalid_raise=True)
    if data.size == 0:
        return {n: np.empty(0) for n in names}
    if data.shape[1] != len(names):
        raise ValueError(f"{path}: {len(names)} header names but {data.shape[1]} columns")
    return {n: data[:, i] for i, n in enumerate(names)}


def markdown_rows(header: Sequence[str], rows: Iterable[Sequence]) -> str:
    """A markdown table: the header, the ``|---|`` rule, one line per row of formatted cells."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join(lines + ["| " + " | ".join(map(str, r)) + " |" for r in rows])


def write_csv(path: str | os.PathLike, columns: Mapping[str, np.ndarray], fmt: str = "%.8g"):
    """Write equal-length 1D columns as a CSV with a header row (parent folder created).

    A path ending in ``.gz`` is gzip-compressed with no time stamp, so equal data give equal
    bytes.
    """
    path = Path(path)
    names = list(columns)
    cols = [np.asarray(columns[n], dtype=float).ravel() for n in names]
    if len({c.size for c in cols}) > 1:
        raise ValueError(f"{path.name}: columns differ in length")
    path.parent.mkdir(parents=True, exist_ok=True)
    data = np.column_stack(cols) if cols else np.empty((0, 0))
    if path.suffix == ".gz":
        with open(path, "wb") as raw, gzip.GzipFile(fileobj=raw, mode="wb", mtime=0) as f:
            np.savetxt(f, data, delimiter=",", header=",".join(names), comments="", fmt=fmt)
    else:
        np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt=fmt)
    return path


def continuum_frames(folder: str | os.PathLike) -> list[tuple[float, Path]]:
    """(t, vtu path) of every output step of a continuum run, from its ``fields.pvd`` index."""
    import xml.etree.ElementTree as ET

    folder = Path(folder)
    pvd = folder / "fields.pvd"
    if not pvd.is_file():
        raise FileNotFoundError(f"no fields.pvd in {folder}")
    frames = [(float(ds.get("timestep")), folder / ds.get("file"))
              for ds in ET.parse(pvd).getroot().iter("DataSet")]
    return sorted(frames, key=lambda f: f[0])


def read_continuum_frame(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray, dict]:
    """(points (n, 2), triangles (m, 3), point data {name: array}) of one VTU output step."""
    import meshio

    mesh = meshio.read(path)
    tri = [c.data for c in mesh.cells if c.type == "triangle"]
    if not tri:
        raise ValueError(f"{path}: no triangles")
    data = {k: np.asarray(v) for k, v in mesh.point_data.items()}
    return np.asarray(mesh.points[:, :2], dtype=float), np.concatenate(tri), data


def particle_frames(folder: str | os.PathLike, last_only: bool = False):
    """Iterate (t, {x, y, theta, length, stress}) over the frames of a particle run's trajectory
    (``last_only``: its last frame alone, the others not read).

    Positions and angles come from the HOOMD schema (theta = 2 atan2(q_z, q_w)); length and stress
    from ``log/particles/length`` and ``log/particles/stress``; t from history.csv's row of the
    frame's step (the step's index times the first dt when history has no ``step`` column).
    """
    import gsd.hoomd

    folder = Path(folder)
    hist = read_csv(folder / "history.csv")
    if "step" in hist:
        t_of_step = dict(zip(hist["step"].astype(int).tolist(), hist["t"].tolist(), strict=True))
    else:
        t_of_step = {}
    with gsd.hoomd.open(str(folder / "trajectory.gsd"), mode="r") as traj:
        for frame in (traj[-1:] if last_only else traj):
            step = int(frame.configuration.step)
            t = t_of_step.get(step, 0.0 if step == 0 else float("nan"))
            pos = np.asarray(frame.particles.position, dtype=float)
            q = np.asarray(frame.particles.orientation, dtype=float)
            yield t, {
                "x": pos[:, 0],
                "y": pos[:, 1],
                "theta": 2.0 * np.arctan2(q[:, 3], q[:, 0]),
                "length": np.asarray(frame.log["particles/length"], dtype=float),
                "stress": np.asarray(frame.log["particles/stress"], dtype=float),
            }


def _vogel_points(center: np.ndarray, radius: float, n: int) -> np.ndarray:
    """n points uniform in area in the disc: r_k = R sqrt((k + 1/2)/n), angle k pi (3 - sqrt 5)."""
    k = np.arange(n)
    r = radius * np.sqrt((k + 0.5) / n)
    a = k * math.pi * (3.0 - math.sqrt(5.0))
    return np.column_stack([center[0] + r * np.cos(a), center[1] + r * np.sin(a)])


def field_profile(
    points: np.ndarray,
    triangles: np.ndarray,
    values: Mapping[str, np.ndarray],
    edge_width: float = 0.05,
    samples_per_annulus: int = 64,
) -> dict[str, np.ndarray]:
    """Equal-area radial profile of P1 fields on a triangle mesh (continuum output).

    The centre is the domain's area centroid; the disc about it reaching the farthest node is cut
    into equal-area annuli (outermost at most `edge_width` wide) and sampled at
    `samples_per_annulus` area-uniform points per annulus (Vogel spiral); the fields are
    interpolated linearly in the mesh's triangles and samples outside the domain are dropped, so
    each annulus averages over its intersection with the colony.

    When `values` has the growth phase ``G``, the column ``mean_length_phase`` =
    2^frac(<G> / ln 2) of the annulus mean <G> is added: G is smooth, so <G> = G(r) + O(w^2)
    (w the annulus width) and the mapped profile keeps the rings' jumps sharp (at the annulus
    resolution), where the annulus mean of the discontinuous lbar = 2^frac(G / ln 2) (column
    ``mean_length``) smears each jump over the annulus and so shifts its apparent peak.
    """
    from matplotlib.tri import LinearTriInterpolator, Triangulation

    points = np.asarray(points, dtype=float)
    triangles = np.asarray(triangles, dtype=np.int64)
    a, b, c = (points[triangles[:, i]] for i in range(3))
    area = 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                  - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    center = (np.abs(area)[:, None] * (a + b + c) / 3.0).sum(0) / np.abs(area).sum()
    radius = float(np.max(np.hypot(*(points - center).T)))
    n_annuli = annuli_for_edge_width(radius, edge_width)
    xy = _vogel_points(center, radius, n_annuli * samples_per_annulus)
    tri = Triangulation(points[:, 0], points[:, 1], triangles)
    sampled = {}
    inside = np.ones(len(xy), dtype=bool)
    for name, v in values.items():
        s = LinearTriInterpolator(tri, np.asarray(v, dtype=float))(xy[:, 0], xy[:, 1])
        s = np.ma.filled(s.astype(float), np.nan)
        inside &= np.isfinite(s)
        sampled[name] = s
    sampled = {k: v[inside] for k, v in sampled.items()}
    out = radial_profile(xy[inside], sampled, center=center, radius=radius, n_annuli=n_annuli)
    if "G" in values:
        count = out.pop("count")
        out["mean_length_phase"] = mean_length_from_phase(out["G"])
        out["count"] = count
    return out


def mean_length_from_phase(G: np.ndarray) -> np.ndarray:
    """lbar = 2^frac(G / ln 2): the mean length after growth phase G for Psi0 = delta(l - 1)
    (nan stays nan; :func:`continuum.growth.mean_length`)."""
    return _growth.mean_length(G)


def profile_ring_radii(r: np.ndarray, G: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rings of a radial profile of the growth phase: radii where the (annulus-mean) G(r) crosses
    k ln 2, by linear interpolation between samples (k >= 1; nan samples dropped).

    Returns (radii, k) in increasing r. A cheap stand-in for the contours of the 2D field
    (:func:`frame_rings`) when only ``profile.csv`` is at hand.
    """
    r = np.asarray(r, dtype=float)
    G = np.asarray(G, dtype=float)
    ok = np.isfinite(r) & np.isfinite(G)
    r, G = r[ok], G[ok]
    radii, ks = [], []
    for i in range(r.size - 1):
        lo, hi = sorted((G[i], G[i + 1]))
        for k in range(max(1, math.floor(lo / LN2) + 1), math.floor(hi / LN2) + 1):
            if G[i + 1] == G[i]:
                continue
            radii.append(r[i] + (k * LN2 - G[i]) / (G[i + 1] - G[i]) * (r[i + 1] - r[i]))
            ks.append(k)
    order = np.argsort(radii)
    return np.asarray(radii, dtype=float)[order], np.asarray(ks, dtype=int)[order]


def particle_profile(
    x: np.ndarray, y: np.ndarray, length: np.ndarray, stress: np.ndarray,
    edge_width: float = 0.5, radius: float | None = None,
) -> dict[str, np.ndarray]:
    """Equal-area radial profile of particle length and stress about the particles' centroid.

    The outer radius is the colony radius R = max_n (|x_n - centroid| + l_n/2) (or `radius`);
    particles are binned by their centres. Columns r, mean_length(_std), stress(_std), count.
    """
    xy = np.column_stack([np.asarray(x, float), np.asarray(y, float)])
    length = np.asarray(length, float)
    center = xy.mean(0)
    if radius is None:
        radius = float(np.max(np.hypot(*(xy - center).T) + 0.5 * length))
    return radial_profile(xy, {"mean_length": length, "stress": np.asarray(stress, float)},
                          center=center, radius=radius, edge_width=edge_width)


def profile_wavelength(profile: Mapping[str, np.ndarray], name: str = "mean_length",
                       noisy: bool = True, min_count: int = 10, **kwargs) -> float:
    """Ring wavelength of a profile dict (:func:`ring_wavelength`).

    `noisy` (particle data): annuli with fewer than `min_count` particles are dropped (their
    standard deviation is no estimate of the noise) and the annulus means' standard errors
    std/sqrt(count) set the noise threshold; False (continuum): no noise threshold beyond
    `min_prominence`.
    """
    r, f = np.asarray(profile["r"], float), np.asarray(profile[name], float)
    if not noisy:
        return ring_wavelength(r, f, **kwargs)
    count = np.asarray(profile["count"], float)
    keep = count >= min_count
    se = np.asarray(profile[f"{name}_std"], float)[keep] / np.sqrt(count[keep])
    return ring_wavelength(r[keep], f[keep], stderr=se, **kwargs)


# ----------------------------------------------------------------------------------------------
# reductions of whole runs (used by the figure cases)
# ----------------------------------------------------------------------------------------------


def thin_rows(columns: Mapping[str, np.ndarray], max_rows: int = 400) -> dict[str, np.ndarray]:
    """Every k-th row (k the smallest giving <= max_rows) plus the last: small CSVs for figures."""
    n = len(next(iter(columns.values())))
    if n <= max_rows:
        return {k: np.asarray(v) for k, v in columns.items()}
    k = math.ceil(n / (max_rows - 1))
    idx = np.unique(np.append(np.arange(0, n, k), n - 1))
    return {name: np.asarray(v)[idx] for name, v in columns.items()}


def colony_radius(x: np.ndarray, y: np.ndarray, length: np.ndarray) -> float:
    """Radius of the smallest disc about the centroid holding every particle: max |x_n - c| + l_n/2.

    (The tip of a rod of length l is l/2 from its centre; the rod's half-width b/2 <= l/2 is
    inside that.)
    """
    x, y, length = (np.asarray(a, dtype=float) for a in (x, y, length))
    return float(np.max(np.hypot(x - x.mean(), y - y.mean()) + 0.5 * length))


def wavelength_series(folder: str | os.PathLike, engine: str,
                      edge_width: float | None = None, **kwargs) -> dict[str, np.ndarray]:
    """Ring wavelength at every output frame of a run.

    Continuum: every VTU frame, the contours G = k ln 2 of the growth phase (:func:`frame_rings`),
    wavelength = difference of the two outermost mean ring radii (:func:`contour_wavelength`;
    lbar peaks exactly at a ring, so this is the distance between the last two peaks of lbar);
    a frame without G (runs older than the G output) falls back to the peaks of the
    :func:`field_profile` of lbar (edge width 0.05, no noise threshold).
    Particles: every trajectory frame, :func:`particle_profile` (edge width 0.5), noise threshold
    from the annulus standard errors, peaks of the mean-length profile.
    Returns columns t, radius, wavelength (nan: < 2 rings).
    """
    ts, Rs, ws = [], [], []
    if engine == "continuum":
        ew = 0.05 if edge_width is None else edge_width
        for t, path in continuum_frames(folder):
            pts, tri, data = read_continuum_frame(path)
            ts.append(t)
            Rs.append(math.sqrt(_mesh_area(pts, tri) / math.pi))
            if "G" in data:
                ws.append(contour_wavelength(_rings.ring_table(pts, tri, data["G"])))
                continue
            prof = field_profile(pts, tri, {"mean_length": data["mean_length"]}, edge_width=ew)
            ws.append(profile_wavelength(prof, noisy=False, **kwargs))
    elif engine == "particles":
        ew = 0.5 if edge_width is None else edge_width
        for t, fr in particle_frames(folder):
            ts.append(t)
            Rs.append(colony_radius(fr["x"], fr["y"], fr["length"]))
            if fr["x"].size < 3:
                ws.append(float("nan"))
                continue
            prof = particle_profile(fr["x"], fr["y"], fr["length"], fr["stress"], edge_width=ew)
            ws.append(profile_wavelength(prof, noisy=True, **kwargs))
    else:
        raise ValueError(f"engine must be 'continuum' or 'particles', got {engine!r}")
    return {"t": np.array(ts), "radius": np.array(Rs), "wavelength": np.array(ws)}


def _mesh_area(points: np.ndarray, triangles: np.ndarray) -> float:
    a, b, c = (points[triangles[:, i]] for i in range(3))
    return float(np.abs(0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                               - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))).sum())


def final_continuum_profile(folder: str | os.PathLike, edge_width: float = 0.05
                            ) -> dict[str, np.ndarray]:
    """Radial profile of the last VTU frame of a continuum run: mean_length, pressure and, when
    the frame has it, G with mean_length_phase = 2^frac(<G> / ln 2) (:func:`field_profile`)."""
    t, path = continuum_frames(folder)[-1]
    pts, tri, data = read_continuum_frame(path)
    values = {"mean_length": data["mean_length"], "pressure": data["p"]}
    if "G" in data:
        values["G"] = data["G"]
    return field_profile(pts, tri, values, edge_width=edge_width)


def frame_rings(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Ring table (:func:`continuum.rings.ring_table`) of the G field of one VTU frame."""
    pts, tri, data = read_continuum_frame(path)
    if "G" not in data:
        raise ValueError(f"{path}: no growth phase G in the frame")
    return _rings.ring_table(pts, tri, data["G"])


def continuum_rings(folder: str | os.PathLike) -> dict[str, np.ndarray]:
    """Final ring table of a continuum run: its ``rings.csv`` (written by the run) if present,
    else computed from the G of its last VTU frame (the same numbers)."""
    folder = Path(folder)
    if (folder / "rings.csv").is_file():
        table = read_csv(folder / "rings.csv")
        for key in ("k", "n_pieces"):
            if key in table:
                table[key] = table[key].astype(int)
        return table
    return frame_rings(continuum_frames(folder)[-1][1])


def continuum_wavelength(folder: str | os.PathLike, edge_width: float = 0.05, **kwargs) -> float:
    """Final ring wavelength of a continuum run: :func:`contour_wavelength` of
    :func:`continuum_rings`; a run without G in its frames falls back to the peaks of the last
    frame's lbar profile (as :func:`wavelength_series`)."""
    folder = Path(folder)
    if (folder / "rings.csv").is_file():
        return contour_wavelength(continuum_rings(folder))
    pts, tri, data = read_continuum_frame(continuum_frames(folder)[-1][1])
    if "G" in data:
        return contour_wavelength(_rings.ring_table(pts, tri, data["G"]))
    prof = field_profile(pts, tri, {"mean_length": data["mean_length"]}, edge_width=edge_width)
    return profile_wavelength(prof, noisy=False, **kwargs)


def contour_wavelength(table: Mapping[str, np.ndarray]) -> float:
    """Ring wavelength of a ring table: the two largest mean ring radii's difference (nan if
    fewer than two rings; :func:`continuum.rings.ring_wavelength`)."""
    return _rings.ring_wavelength(table)


def final_particle_profile(folder: str | os.PathLike, growth_window: float = 1.0,
                           edge_width: float = 0.5) -> dict[str, np.ndarray]:
    """Radial profile (mean_length, stress) of a particle run, pooled over its last frames.

    To reduce noise (paper, Fig 3A) the particles of every frame whose colony radius is within
    `growth_window` of the final radius R_f (the colony grew by less than that) are pooled, each
    frame about its own centroid, and binned in equal-area annuli of the final disc; with
    `growth_window` = 0 only the final frame is used. The pooled frames are correlated, so
    `count` overstates the number of independent samples.
    """
    if growth_window < 0:
        raise ValueError(f"growth_window must be >= 0, got {growth_window}")
    radii = [colony_radius(fr["x"], fr["y"], fr["length"]) for _, fr in particle_frames(folder)]
    if not radii:
        raise ValueError(f"no frames in {folder}")
    R_f = radii[-1]
    keep = {i for i, R in enumerate(radii) if R >= R_f - growth_window} | {len(radii) - 1}
    r, length, stress = [], [], []
    for i, (_, fr) in enumerate(particle_frames(folder)):
        if i in keep:
            r.append(np.hypot(fr["x"] - fr["x"].mean(), fr["y"] - fr["y"].mean()))
            length.append(fr["length"])
            stress.append(fr["stress"])
    r, length, stress = (np.concatenate(a) for a in (r, length, stress))
    out: dict[str, np.ndarray] = {}
    for name, v in (("mean_length", length), ("stress", stress)):
        r_mid, mean, std, count = equal_area_annuli(r, v, radius=max(R_f, r.max()),
                                                    edge_width=edge_width)
        out["r"], out[name], out[f"{name}_std"], out["count"] = r_mid, mean, std, count
    out["count"] = out.pop("count")
    return out


def final_ring_coherence(folder: str | os.PathLike, width: float = 1.0) -> tuple[float, float]:
    """:func:`ring_coherence` (C, z) of the lengths in the last frame of a particle run; (nan,
    nan) for a colony too small for five annuli of ``width`` over its outer half."""
    ((_, last),) = particle_frames(folder, last_only=True)
    r = np.hypot(last["x"] - last["x"].mean(), last["y"] - last["y"].mean())
    if r.size == 0 or 0.5 * r.max() < 5 * width:
        return math.nan, math.nan
    return ring_coherence(last["x"], last["y"], last["length"], width=width)
