"""Measures of a colony of sphero-cylinders: centroid, enclosing radius, hull radius.

Particle n: centre (x_n, y_n), angle theta_n, tip-to-tip length l_n, inner segment of length
L_n = l_n - b, area a_n = L_n b + pi b^2 / 4.  Two radii of the colony (model.md, "Initial
condition"):

- :func:`enclosing_radius`: the radius of the smallest disc about the centroid holding every
  particle, the colony radius R of the runs (``Config.radius``, history ``radius``);
- :func:`hull_radius`: sqrt(A / pi), A the area of the convex hull of the particles (history
  ``hull_radius``), <= the enclosing radius.

Functions of arrays, so they apply to a ``ParticleState`` as to a trajectory frame.
"""

from __future__ import annotations

import numpy as np

from .geometry import B


def centroid(x: np.ndarray, y: np.ndarray, length: np.ndarray) -> tuple[float, float]:
    """Area-weighted centroid c = sum_n a_n x_n / sum_n a_n, a_n = L_n b + pi b^2 / 4."""
    w = (length - B) * B + np.pi * B * B / 4
    return float(np.sum(w * x) / w.sum()), float(np.sum(w * y) / w.sum())


def tips(x: np.ndarray, y: np.ndarray, theta: np.ndarray,
         length: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Segment end points x_n +- (L_n / 2) p_n, as (2N,) arrays of x and of y coordinates."""
    h = 0.5 * (length - B)
    c = np.cos(theta) * h
    s = np.sin(theta) * h
    return np.concatenate([x + c, x - c]), np.concatenate([y + s, y - s])


def enclosing_radius(x: np.ndarray, y: np.ndarray, theta: np.ndarray,
                     length: np.ndarray) -> float:
    """Radius of the smallest disc about the centroid c holding every particle.

    ``R = max over segment ends e of |e - c| + b/2`` (the farthest point of a sphero-cylinder
    from any point is on the cap of one of its ends); c is the area-weighted centroid
    (:func:`centroid`).

    Parameters
    ----------
    x, y, theta, length : arrays (N,)
        Centres x_n, orientations theta_n and tip-to-tip lengths l_n of the particles.

    Returns
    -------
    R : float
        The enclosing radius.
    """
    cx, cy = centroid(x, y, length)
    ex, ey = tips(x, y, theta, length)
    return float(np.max(np.hypot(ex - cx, ey - cy)) + B / 2)


def hull_radius(x: np.ndarray, y: np.ndarray, theta: np.ndarray, length: np.ndarray) -> float:
    """Hull radius R = sqrt(A / pi), A the area of the convex hull of the particles.

    The hull of the union of sphero-cylinders is the hull H of the segment ends dilated by b/2:
    ``A = |H| + perimeter(H) b/2 + pi b^2/4`` (exact, Steiner formula).

    Parameters
    ----------
    x, y, theta, length : arrays (N,)
        Centres x_n, orientations theta_n and tip-to-tip lengths l_n of the particles.

    Returns
    -------
    R : float
        The radius of the disc with the hull's area.
    """
    ex, ey = tips(x, y, theta, length)
    area, perim = _hull_area_perimeter(np.column_stack([ex, ey]))
    return float(np.sqrt((area + perim * B / 2 + np.pi * B * B / 4) / np.pi))


def _hull_area_perimeter(pts: np.ndarray) -> tuple[float, float]:
    """Area and perimeter of the convex hull of points (monotone chain; degenerate -> 0, 2*len)."""
    p = pts[np.lexsort((pts[:, 1], pts[:, 0]))]  # np.unique(pts, axis=0), 2.6x faster
    p = p[np.concatenate([[True], np.any(p[1:] != p[:-1], axis=1)])]
    if p.shape[0] < 3:
        d = np.ptp(p, axis=0)
        return 0.0, 2.0 * float(np.hypot(*d))
    from scipy.spatial import ConvexHull, QhullError

    try:
        h = ConvexHull(p)
    except QhullError:  # collinear points
        d = p[np.argmax(p @ (p[-1] - p[0]))] - p[np.argmin(p @ (p[-1] - p[0]))]
        return 0.0, 2.0 * float(np.hypot(*d))
    return float(h.volume), float(h.area)
