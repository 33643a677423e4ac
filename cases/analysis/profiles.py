"""Radial profiles in annuli of equal area about the colony centre (model.md, "Analysis").

Both engines are reduced the same way, on plain arrays: the particle engine's samples are the
particles (binned by their centres about the colony centroid of :mod:`particles.measures`), the
continuum's are area-uniform points of the domain where the P1 fields are interpolated.

- :func:`equal_area_annuli`, :func:`annuli_for_edge_width`: the weighted mean and standard
  deviation over N annuli of area pi R^2 / N (Fig 3A, Fig 4A);
- :func:`radial_profile`: several fields at once, about a given centre or the samples' centroid;
- :func:`field_profile`: P1 fields on a triangle mesh (continuum), with the transported Psi's
  mean length and spread of lengths per annulus (``mean_length_psi``, ``length_std_psi``) and
  the growth phase's closed form 2^frac(<G> / ln 2) (``mean_length_phase``) beside it;
- :func:`particle_profile`: particle length and stress.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from continuum.growth import mean_length
from continuum.mesh import triangle_areas
from particles.measures import centroid, enclosing_radius

__all__ = [
    "PSI_FIELDS",
    "annuli_for_edge_width",
    "equal_area_annuli",
    "radial_profile",
    "field_profile",
    "particle_profile",
]


PSI_FIELDS = ("number", "mean_length_psi", "length_std_psi")
"""The nodal moments of the transported Psi (continuum.state.State.fields) that
:func:`field_profile` turns into the annulus' length distribution."""


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
    samples' distances ``r_i = |x_i - centre|`` are binned by :func:`equal_area_annuli`.

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


def _vogel_points(center: np.ndarray, radius: float, n: int) -> np.ndarray:
    """Points uniform in area in the disc: r_k = R sqrt((k + 1/2)/n), angle k pi (3 - sqrt 5)."""
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
    each annulus averages over its intersection with the colony. Every field gets the columns
    "<name>" and "<name>_std" (:func:`radial_profile`), with two exceptions.

    The transported size distribution. When `values` has the moments of Psi, ``number`` N (per
    area), ``mean_length_psi`` m and ``length_std_psi`` s (``PSI_FIELDS``), the lengths of all
    the cells of an annulus make one distribution: the densities N, L = N m and Q = N (s^2 + m^2)
    (number, length and squared length per area, linear in Psi, so interpolated linearly) are
    averaged over the annulus, and the columns are its mean length and standard deviation::

        mean_length_psi = <L> / <N>,   length_std_psi = sqrt(<Q> / <N> - mean_length_psi^2),

    the spread within each material element and between them together (law of total variance):
    the continuum's counterpart of the particles' mean_length +- mean_length_std. ``number``
    keeps its plain columns.

    The closed form. When `values` has the growth phase ``G``, the column ``mean_length_phase`` =
    2^frac(<G> / ln 2) of the annulus mean <G> is added: G is smooth, so <G> = G(r) + O(w^2)
    (w the annulus width) and the mapped profile keeps the rings' jumps sharp (at the annulus
    resolution), where the annulus mean of the discontinuous lbar = 2^frac(G / ln 2) (column
    ``mean_length``) smears each jump over the annulus and so shifts its apparent peak. It is
    the mean length for the model's Psi0 = delta(l - 1), the check beside ``mean_length_psi``.
    """
    from matplotlib.tri import LinearTriInterpolator, Triangulation

    points = np.asarray(points, dtype=float)
    triangles = np.asarray(triangles, dtype=np.int64)
    values = dict(values)
    psi = all(name in values for name in PSI_FIELDS)
    if psi:
        N = np.asarray(values["number"], dtype=float)
        m = np.asarray(values.pop("mean_length_psi"), dtype=float)
        sd = np.asarray(values.pop("length_std_psi"), dtype=float)
        moments = {"L": N * m, "Q": N * (sd * sd + m * m)}
    area = np.abs(triangle_areas(points, triangles))
    center = (area[:, None] * points[triangles].mean(axis=1)).sum(0) / area.sum()
    radius = float(np.max(np.hypot(*(points - center).T)))
    n_annuli = annuli_for_edge_width(radius, edge_width)
    xy = _vogel_points(center, radius, n_annuli * samples_per_annulus)
    tri = Triangulation(points[:, 0], points[:, 1], triangles)
    sampled = {}
    inside = np.ones(len(xy), dtype=bool)
    for name, v in {**values, **(moments if psi else {})}.items():
        s = LinearTriInterpolator(tri, np.asarray(v, dtype=float))(xy[:, 0], xy[:, 1])
        s = np.ma.filled(s.astype(float), np.nan)
        inside &= np.isfinite(s)
        sampled[name] = s
    sampled = {k: v[inside] for k, v in sampled.items()}
    prof = radial_profile(xy[inside], sampled, center=center, radius=radius, n_annuli=n_annuli)
    count = prof.pop("count")
    if psi:
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = prof.pop("L") / prof["number"]
            square = prof.pop("Q") / prof["number"]
        del prof["L_std"], prof["Q_std"]
        prof["mean_length_psi"] = mean
        prof["length_std_psi"] = np.sqrt(np.maximum(square - mean * mean, 0.0))
    if "G" in values:
        prof["mean_length_phase"] = mean_length(prof["G"])
    prof["count"] = count
    return prof


def particle_profile(
    x: np.ndarray, y: np.ndarray, theta: np.ndarray, length: np.ndarray, stress: np.ndarray,
    edge_width: float = 0.5, radius: float | None = None,
) -> dict[str, np.ndarray]:
    """Equal-area radial profile of particle length and stress about the colony centroid.

    The centre is the area-weighted centroid c of the particles and the outer radius the colony
    radius R, the smallest disc about c holding every particle (or `radius`), both of
    :mod:`particles.measures` (:func:`particles.enclosing_radius`); particles are binned by their
    centres, all within R - b/2. Columns r, mean_length(_std), stress(_std), count.
    """
    x, y, theta, length = (np.asarray(a, float) for a in (x, y, theta, length))
    center = np.array(centroid(x, y, length))
    if radius is None:
        radius = enclosing_radius(x, y, theta, length)
    return radial_profile(np.column_stack([x, y]),
                          {"mean_length": length, "stress": np.asarray(stress, float)},
                          center=center, radius=radius, edge_width=edge_width)
