"""The rings of a colony: peaks of the radial mean-length profile, contours of the growth phase.

- particle colonies (noisy profiles): :func:`ring_peaks` / :func:`ring_wavelength`, the distance
  between the last two peaks of the radial mean-length profile (Fig 4B, C), after Gaussian
  local-linear smoothing (:func:`smooth_profile`) and with a noise threshold from the annulus
  standard errors (:func:`profile_wavelength`); :func:`ring_coherence`: whether a colony has
  rings at all (the same radial pattern in every angular sector, significance ``RING_Z``);
- continuum (smooth growth phase G): the rings are the contours G = k ln 2, where
  lbar = 2^frac(G / ln 2) jumps from 2 to 1 and so peaks (:mod:`continuum.rings`):
  :func:`contour_wavelength` of a ring table, :func:`profile_ring_radii` of a radial profile
  of G;
- the 1D radial reference (:func:`continuum.radial.ring_radii`) at a colony's radius:
  :func:`exact_wavelength`, the difference of its two outermost ring radii (Fig 4C, the
  cross-check), and :func:`exact_rings`, its radius of each ring k of a ring table.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from scipy.signal import find_peaks

from continuum import radial
from continuum import rings as _rings
from continuum.growth import LN2

__all__ = [
    "smooth_profile",
    "ring_peaks",
    "ring_wavelength",
    "profile_wavelength",
    "RING_Z",
    "ring_coherence",
    "profile_ring_radii",
    "contour_wavelength",
    "exact_wavelength",
    "exact_rings",
]


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


def profile_ring_radii(r: np.ndarray, G: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rings of a radial profile of the growth phase: where G(r) crosses k ln 2.

    Radii where the (annulus-mean) G(r) crosses k ln 2, by linear interpolation between samples
    (k >= 1; nan samples dropped).

    Returns (radii, k) in increasing r. A cheap stand-in for the contours of the 2D field
    (:func:`cases.analysis.continuum_runs.frame_rings`) when only ``profile.csv`` is at hand.
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


def contour_wavelength(table: Mapping[str, np.ndarray]) -> float:
    """Ring wavelength of a ring table: the two largest mean ring radii's difference.

    nan if fewer than two rings (:func:`continuum.rings.ring_wavelength`).
    """
    return _rings.ring_wavelength(table)


def exact_wavelength(lam: float, radius: float) -> float:
    """Wavelength of the 1D radial reference at colony radius R.

    It is the difference of its two outermost ring radii, G(r) = k ln 2
    (continuum.radial.ring_radii, ``|G - k ln 2| <= 1e-11``); nan with fewer than two rings
    (lam = 0 has none).
    """
    if lam <= 0:
        return math.nan
    r = radial.ring_radii(lam, radius=radius)
    return float(r[-1] - r[-2]) if r.size >= 2 else math.nan


def exact_rings(table: dict[str, np.ndarray], lam: float, radius: float) -> np.ndarray:
    """The 1D reference's radius of each ring k of ``table`` at colony radius R (nan if absent)."""
    if lam <= 0:
        return np.full(len(table["k"]), math.nan)
    r, k = radial.ring_radii(lam, radius=radius, with_index=True)
    by_k = dict(zip(k.tolist(), r.tolist(), strict=True))
    return np.array([by_k.get(int(kk), math.nan) for kk in table["k"]], dtype=float)
