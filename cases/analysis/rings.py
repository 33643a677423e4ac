"""The rings of a colony: one measurement for both models, with significance and uncertainty.

A ring is a peak of the radial mean-length profile (particles) or a contour G = k ln 2 of the
growth phase, where lbar = 2^frac(G / ln 2) peaks (continuum, :mod:`continuum.rings`). Both
models' candidates go through one rule, :func:`count_rings`: a ring counts when it is
significant (z >= ``RING_SIGNIFICANCE``; a contour is exact, z = inf) and lies inside the
colony, not in the edge layer r > R - ``EDGE_LAYER``. A wavelength needs two counted rings;
otherwise it is nan and :class:`Rings` says why. Two wavelengths are reported (:class:`Rings`):

- ``outer_pair``: the distance of the two outermost rings (the paper's, Fig 4B, C);
- ``mean_spacing``: the mean spacing of the rings in the outer half r >= R/2, which other
  codes quote; the rings crowd as the colony grows, so the two differ.

- particle colonies (noisy profiles): :func:`peak_significance` (Gaussian local-linear
  smoothing, :func:`smooth_profile`, and each peak's prominence over its standard error),
  :func:`profile_rings` of a profile dict, :func:`ring_uncertainty` (the spread of both
  wavelengths under the annulus noise); :func:`ring_coherence`: the same radial pattern in
  every angular sector;
- continuum: :func:`contour_rings` of a ring table, :func:`profile_ring_radii` of a radial
  profile of G;
- the 1D radial reference (:func:`continuum.radial.ring_radii`) at a colony's radius:
  :func:`exact_ring_measure`, :func:`exact_wavelength` and :func:`exact_rings`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from scipy.signal import find_peaks

from continuum import radial
from continuum.growth import LN2

__all__ = [
    "RING_SIGNIFICANCE",
    "EDGE_LAYER",
    "Rings",
    "count_rings",
    "peak_significance",
    "profile_rings",
    "ring_uncertainty",
    "contour_rings",
    "exact_ring_measure",
    "ring_series",
    "final_wavelength",
    "smooth_profile",
    "ring_peaks",
    "RING_Z",
    "ring_coherence",
    "profile_ring_radii",
    "exact_wavelength",
    "exact_rings",
]


RING_SIGNIFICANCE = 5.0
"""Significance z from which a peak of a particle profile counts as a ring (prominence over its
standard error from the annulus noise, :func:`peak_significance`). Calibrated on profiles with
no rings (docs/validation.md, "Rings": colonies of lam = 0.1 at radius 20-40, their lengths
shuffled, the lam >= 0.03 colonies of radius 150): the false ring rate at this threshold is at
most 0.3 % there (5 % allowed)."""

EDGE_LAYER = 2.0
"""Width of the edge layer, in birth lengths: a ring within EDGE_LAYER of the colony radius R is
not counted. The edge is rough on the scale of a cell (lengths up to 2) and the smoother's
reach (4 x 0.5) is one-sided there."""


GAP_RATIO = 1.6
"""A spacing of rings larger than GAP_RATIO times the next outer one holds a missed ring: the
1D reference's consecutive spacings in the outer half differ by at most a factor 1.36 (lam
1e-4 to 0.1, radius 40 to 260), a missed ring makes it about 2."""


@dataclass(frozen=True, eq=False)
class Rings:
    """The rings of one colony at one time and its two wavelengths.

    ``radii``: the counted rings, increasing; ``significance``: their z (inf for an exact
    contour); ``radius``: the colony radius R; ``reason``: why ``outer_pair`` is nan ("" when
    it is measured).
    """

    radii: np.ndarray
    significance: np.ndarray
    radius: float
    reason: str = ""

    @property
    def count(self) -> int:
        """Number of counted rings."""
        return int(self.radii.size)

    @property
    def outer_pair(self) -> float:
        """Distance of the two outermost rings, r_n - r_(n-1) (the paper's wavelength)."""
        return float(self.radii[-1] - self.radii[-2]) if self.radii.size >= 2 else math.nan

    @property
    def mean_spacing(self) -> float:
        """Mean spacing of the rings in the outer half, (r_n - r_m) / (n - m).

        Over the outermost run of rings r_m < ... < r_n with r_m >= R/2 whose every spacing is
        at most ``GAP_RATIO`` times the next outer one (a larger spacing holds a ring the noise
        hid).
        """
        outer = self.radii[self.radii >= 0.5 * self.radius]
        if outer.size < 2:
            return math.nan
        d = np.diff(outer)
        m = d.size - 1
        while m > 0 and d[m - 1] <= GAP_RATIO * d[m]:
            m -= 1
        return float((outer[-1] - outer[m]) / (outer.size - 1 - m))


def count_rings(radii: np.ndarray, radius: float, significance: np.ndarray | None = None,
                z_min: float = RING_SIGNIFICANCE, edge: float = EDGE_LAYER) -> Rings:
    """The rule of both models: which candidate rings count, and why there is no wavelength.

    A candidate at r with significance z counts when z >= ``z_min`` and r <= R - ``edge``
    (``significance`` None: every candidate is exact, z = inf). ``reason`` names what is
    missing when fewer than two count.
    """
    r = np.asarray(radii, dtype=float).ravel()
    z = np.full(r.size, math.inf) if significance is None else np.asarray(significance, float)
    if z.shape != r.shape:
        raise ValueError(f"radii and significance differ in length: {r.size} != {z.size}")
    order = np.argsort(r)
    r, z = r[order], z[order]
    strong = z >= z_min
    inside = r <= radius - edge
    keep = strong & inside
    reason = ""
    if keep.sum() < 2:
        if r.size == 0:
            reason = "no ring peak"
        elif not strong.any():
            reason = f"no significant peak (largest z {z.max():.3g} < {z_min:g})"
        else:
            found = ", ".join(f"{x:.4g}" for x in r[keep])
            edge_note = (f"; {int((strong & ~inside).sum())} more in the edge layer"
                         if (strong & ~inside).any() else "")
            n = int(keep.sum())
            reason = (f"{n} ring{'' if n == 1 else 's'}" + (f" (r = {found})" if found else "")
                      + f"{edge_note}: a wavelength needs two")
    return Rings(r[keep], z[keep], float(radius), reason)


def ring_series(rows: list[tuple[float, float, Rings]]) -> dict[str, np.ndarray]:
    """The (t, R, :class:`Rings`) of a run's frames as columns.

    Columns t, radius, wavelength (outer pair), mean_spacing and rings (their number).
    """
    return {"t": np.array([t for t, _, _ in rows], dtype=float),
            "radius": np.array([R for _, R, _ in rows], dtype=float),
            "wavelength": np.array([x.outer_pair for _, _, x in rows], dtype=float),
            "mean_spacing": np.array([x.mean_spacing for _, _, x in rows], dtype=float),
            "rings": np.array([x.count for _, _, x in rows], dtype=float)}


def final_wavelength(series: Mapping[str, np.ndarray], window: float = LN2) -> dict[str, float]:
    """The final wavelengths of a :func:`ring_series` and their frame-to-frame spread.

    ``wavelength`` and ``mean_spacing`` of the last frame; ``*_sd`` the sample standard
    deviation of the measured (finite) values over the frames of the last ``window`` (default
    ln 2, a division period at the edge's unit growth rate; nan with fewer than two measured
    frames there), ``frames`` the number of frames in the window and ``rings`` the last frame's
    number of rings.
    """
    t = np.asarray(series["t"], dtype=float)
    last = t >= t[-1] - window
    out = {"frames": float(last.sum()), "rings": float(series["rings"][-1])}
    for key in ("wavelength", "mean_spacing"):
        v = np.asarray(series[key], dtype=float)
        w = v[last][np.isfinite(v[last])]
        out[key] = float(v[-1])
        out[f"{key}_sd"] = float(np.std(w, ddof=1)) if w.size >= 2 else math.nan
    return out


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


def _smoothed_peaks(
    r: np.ndarray, profile: np.ndarray, stderr: np.ndarray | None, smoothing: float,
    min_separation: float | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Interior maxima of the smoothed profile: (radii, prominence, standard error, median se).

    Steps (1)-(4) of :func:`ring_peaks` with no threshold; the standard error of each peak is
    that of the difference between the smoothed value at the peak and at its higher base.
    """
    empty = np.empty(0)
    if smoothing < 0:
        raise ValueError("smoothing must be >= 0")
    rr, f, se = _clean(r, profile, stderr)
    if rr.size < 3:
        return empty, empty, empty, np.zeros(1)
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
        return empty, empty, empty, np.zeros(1)
    spacing = float(np.median(np.diff(grid)))
    distance = max(1, int(round(sep / spacing))) if spacing > 0 else 1
    idx, props = find_peaks(fs, prominence=0.0, distance=distance)
    base = np.where(fs[props["left_bases"]] >= fs[props["right_bases"]],
                    props["left_bases"], props["right_bases"])
    peaks = grid[idx].astype(float)
    # parabolic refinement (exact for a parabola sampled on a uniform grid)
    for j, i in enumerate(idx):
        y0, y1, y2 = fs[i - 1], fs[i], fs[i + 1]
        den = y0 - 2.0 * y1 + y2
        hl, hr = grid[i] - grid[i - 1], grid[i + 1] - grid[i]
        if den < 0 and abs(hl - hr) <= 1e-9 * max(hl, hr):
            peaks[j] = grid[i] + 0.5 * hl * (y0 - y2) / den
    error = np.hypot(es[idx], es[base])
    return peaks, props["prominences"].astype(float), error, es


def peak_significance(
    r: np.ndarray,
    profile: np.ndarray,
    stderr: np.ndarray | None = None,
    smoothing: float = 0.5,
    min_prominence: float = 0.02,
    min_separation: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Every peak of a radial profile with its significance: (radii, z), radii increasing.

    The profile is smoothed as in :func:`ring_peaks` (width ``smoothing``); a peak of
    prominence P (its height over the higher of its two bases) has

        z = P / sqrt(se_peak^2 + se_base^2),

    se the standard error of the smoothed profile propagated from the samples' ``stderr``
    (annulus means: std / sqrt(count)). A peak below ``min_prominence`` (in length units: a
    change of the mean length under 2 % of a birth length is no ring) has z = 0; without
    ``stderr`` (noise-free data) every other peak has z = inf.
    """
    if min_prominence < 0:
        raise ValueError("min_prominence must be >= 0")
    peaks, prom, error, _ = _smoothed_peaks(r, profile, stderr, smoothing, min_separation)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(error > 0, prom / error, math.inf) if stderr is not None else \
            np.full(prom.shape, math.inf)
    return peaks, np.where(prom >= min_prominence, z, 0.0)


def ring_peaks(
    r: np.ndarray,
    profile: np.ndarray,
    stderr: np.ndarray | None = None,
    smoothing: float = 0.5,
    min_prominence: float = 0.02,
    noise_factor: float = 3.0,
    min_separation: float | None = None,
) -> np.ndarray:
    """Radii of the peaks of a radial mean-length profile above a fixed noise threshold.

    Method: (1) drop non-finite samples; (2) smooth by Gaussian local-linear regression of
    width s = `smoothing` (:func:`smooth_profile`; default 0.5 = b: features below the particle
    scale are noise) onto a uniform grid of spacing s/8; (3) keep the interior local maxima of
    the smoothed profile whose prominence (scipy.signal.find_peaks) is at least
    max(`min_prominence`, `noise_factor` x median standard error of the smoothed profile), the
    latter propagated from the samples' standard errors `stderr` (for annulus means:
    std / sqrt(count); omit for noise-free continuum data), and that are at least `min_separation`
    apart (default 2 s); (4) refine each by the vertex of the parabola through the grid maximum
    and its two neighbours. The profile's end points are never peaks. `smoothing=0` skips (2)
    and works on the samples themselves (sorted by r). The rings of a colony, with each peak's
    own significance and the edge layer, are :func:`profile_rings`.

    Returns
    -------
    Peak radii in increasing order (possibly empty).
    """
    if min_prominence < 0 or noise_factor < 0:
        raise ValueError("smoothing, min_prominence and noise_factor must be >= 0")
    peaks, prom, _, es = _smoothed_peaks(r, profile, stderr, smoothing, min_separation)
    return peaks[prom >= max(min_prominence, noise_factor * float(np.median(es)))]


def _profile_samples(profile: Mapping[str, np.ndarray], name: str, noisy: bool,
                     min_count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """(r, values, standard errors) of a profile dict.

    ``noisy``: the annuli with at least ``min_count`` particles and their std / sqrt(count);
    otherwise all samples and None.
    """
    r, f = np.asarray(profile["r"], float), np.asarray(profile[name], float)
    if not noisy:
        return r, f, None
    count = np.asarray(profile["count"], float)
    keep = count >= min_count
    se = np.asarray(profile[f"{name}_std"], float)[keep] / np.sqrt(count[keep])
    return r[keep], f[keep], se


def profile_rings(profile: Mapping[str, np.ndarray], radius: float | None = None,
                  name: str = "mean_length", noisy: bool = True, min_count: int = 10,
                  z_min: float = RING_SIGNIFICANCE, edge: float = EDGE_LAYER,
                  **kwargs) -> Rings:
    """The rings of a radial profile: :func:`peak_significance`, then :func:`count_rings`.

    The profile has columns r and ``name``, and for ``noisy`` data ``NAME_std`` and count.

    ``noisy`` (particle data): annuli with fewer than ``min_count`` particles are dropped
    (their standard deviation is no estimate of the noise) and the annulus means' standard
    errors std / sqrt(count) give each peak's z; False (noise-free continuum profiles): every
    peak above ``min_prominence`` is exact. ``radius``: the colony radius (default: the
    outermost annulus centre). ``kwargs`` go to :func:`peak_significance`.
    """
    r, f, se = _profile_samples(profile, name, noisy, min_count)
    R = float(np.nanmax(profile["r"])) if radius is None else float(radius)
    peaks, z = peak_significance(r, f, stderr=se, **kwargs)
    return count_rings(peaks, R, z, z_min=z_min, edge=edge)


def ring_uncertainty(profile: Mapping[str, np.ndarray], radius: float | None = None,
                     draws: int = 100, seed: int = 0, name: str = "mean_length",
                     min_count: int = 10, z_min: float = RING_SIGNIFICANCE,
                     edge: float = EDGE_LAYER, **kwargs) -> dict[str, float]:
    """Spread of both wavelengths of a noisy profile under its own annulus noise.

    Parametric bootstrap: each of ``draws`` copies adds to the smoothed profile
    (:func:`smooth_profile` at the annuli, the model of the data; re-noising the noisy means
    would keep their noise's maxima and understate the spread) a normal error of each annulus
    mean's standard error std / sqrt(count) and is measured again as :func:`profile_rings` does
    (``kwargs`` passed on to :func:`peak_significance`). Returns the spreads ``outer_pair_sd``
    and ``mean_spacing_sd``, 1.4826 x the median absolute deviation over the copies where the
    wavelength is measured (a standard deviation for normal errors, blind to the few copies
    where a marginal ring fell below the threshold and another pair was measured; nan when
    fewer than half are measured), and ``measured``, that fraction for the outer pair.
    Deterministic for a ``seed``.
    """
    if draws < 2:
        raise ValueError(f"draws must be >= 2, got {draws}")
    r, f, se = _clean(*_profile_samples(profile, name, True, min_count))
    R = float(np.nanmax(profile["r"])) if radius is None else float(radius)
    fit, _ = smooth_profile(r, f, kwargs.get("smoothing", 0.5), r)
    rng = np.random.default_rng(seed)
    pair, spacing = [], []
    for _ in range(draws):
        peaks, z = peak_significance(r, fit + se * rng.standard_normal(se.size), stderr=se,
                                     **kwargs)
        rings = count_rings(peaks, R, z, z_min=z_min, edge=edge)
        pair.append(rings.outer_pair)
        spacing.append(rings.mean_spacing)

    def sd(values: list[float]) -> float:  # robust: 1.4826 x the median absolute deviation
        v = np.asarray(values)
        v = v[np.isfinite(v)]
        if v.size < max(2, draws / 2):
            return math.nan
        return float(1.4826 * np.median(np.abs(v - np.median(v))))

    return {"outer_pair_sd": sd(pair), "mean_spacing_sd": sd(spacing),
            "measured": float(np.mean(np.isfinite(pair)))}


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


def contour_rings(table: Mapping[str, np.ndarray], radius: float) -> Rings:
    """The rings of a continuum ring table (:func:`continuum.rings.ring_table`) at colony radius R.

    Each contour G = k ln 2 is a ring at its mean radius, exact (z = inf); the edge layer as
    for the particles (:func:`count_rings`).
    """
    return count_rings(np.asarray(table["mean_radius"], dtype=float), radius)


def exact_ring_measure(lam: float, radius: float) -> Rings:
    """The rings of the 1D radial reference at colony radius R, by the rule of both models.

    Its ring radii G(r) = k ln 2 (continuum.radial.ring_radii, ``|G - k ln 2| <= 1e-11``),
    exact, through :func:`count_rings`; lam <= 0 has none.
    """
    r = radial.ring_radii(lam, radius=radius) if lam > 0 else np.empty(0)
    return count_rings(r, radius)


def exact_wavelength(lam: float, radius: float) -> float:
    """The 1D reference's wavelength (two outermost rings) at colony radius R, or nan."""
    return exact_ring_measure(lam, radius).outer_pair


def exact_rings(table: dict[str, np.ndarray], lam: float, radius: float) -> np.ndarray:
    """The 1D reference's radius of each ring k of ``table`` at colony radius R (nan if absent)."""
    if lam <= 0:
        return np.full(len(table["k"]), math.nan)
    r, k = radial.ring_radii(lam, radius=radius, with_index=True)
    by_k = dict(zip(k.tolist(), r.tolist(), strict=True))
    return np.array([by_k.get(int(kk), math.nan) for kk in table["k"]], dtype=float)
