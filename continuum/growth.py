"""The growth law and what it implies for the cell lengths (model.md, "Continuum model").

Growth law. Cells grow at the rate set by the local pressure,

    g = exp(-lam p),

so the Darcy problem div u = g, u = -grad p is the nonlinear elliptic problem
-Laplace p = exp(-lam p) (continuum.pressure solves it with :func:`growth_rate`).

Growth phase and mean length. A material element accumulates the growth phase
G = int g dt along its path (its area stretch is exp(G), since div u = g). A cell born with
length 1 doubles at G = ln 2 and divides into two of length 1, so for Psi0 = delta(l - 1)
every cell of the element has the length

    lbar = 2^frac(G / ln 2)                                      (:func:`mean_length`),

which jumps from 2 to 1 wherever G crosses k ln 2: the rings of the colony (continuum.rings).
:func:`ring_index` counts the divisions, floor(G / ln 2).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["LN2", "growth_rate", "mean_length", "ring_index", "uptake", "uptake_slope",
           "nutrient_level", "nutrient_factor"]

LN2 = math.log(2.0)
"""ln 2: the growth phase of one cell cycle (length 1 to 2)."""


def growth_rate(p: ArrayLike, lam: float) -> NDArray:
    """Growth rate g = exp(-lam p) at the pressure p.

    Parameters
    ----------
    p : array_like
        Pressure (nodal values).
    lam : float
        Stress sensitivity lambda.

    Returns
    -------
    ndarray
        g, the shape of ``p``.
    """
    return np.exp(-lam * p)


def uptake(c: ArrayLike, K: float) -> NDArray:
    """The nutrient factor of growth, f(c) = (1 + K) c / (K + c) (model.md, "Nutrient limitation").

    Monod uptake normalised so that f(1) = 1 (growth at the reservoir's level is the model
    without nutrients); K > 0 the half-saturation level over the reservoir's; K = inf gives
    f(c) = c (first order). The growth rate with nutrients is g = exp(-lam p) f(c).
    """
    c = np.asarray(c, dtype=float)
    if math.isinf(K):
        return c.copy()
    return (1.0 + K) * c / (K + c)


def uptake_slope(c: ArrayLike, K: float) -> NDArray:
    """f'(c) = (1 + K) K / (K + c)^2 of :func:`uptake` (1 for K = inf)."""
    c = np.asarray(c, dtype=float)
    if math.isinf(K):
        return np.ones_like(c)
    return (1.0 + K) * K / (K + c) ** 2


def nutrient_level(p: ArrayLike, ell: float) -> NDArray:
    """The nutrient c = 1 - p / ell^2 of a colony fed at its edge, at least 0.

    With supply at the edge, p + ell^2 c is harmonic in the colony (-Laplace p = g,
    ell^2 Laplace c = g) and ell^2 on its edge, so p = ell^2 (1 - c) for every lam, K and shape
    (model.md, "Exact solutions with nutrients", 2); on a mesh too, the two fields sharing one
    discretisation. c >= 0 where the solution is (p <= ell^2); the bound keeps Newton's iterates
    in the model's range.
    """
    return np.maximum(1.0 - np.asarray(p, dtype=float) / (ell * ell), 0.0)


def nutrient_factor(p: ArrayLike, ell: float, K: float) -> tuple[NDArray, NDArray]:
    """(f(c), -d f(c) / dp) at c = :func:`nutrient_level` (p): the nutrient's factor of g.

    g = exp(-lam p) f(c) with c = 1 - p / ell^2, so -df/dp = f'(c) / ell^2 >= 0 (0 where c is
    bounded at 0): the source stays monotone in p, and Newton's Jacobian has its slope
    (continuum.pressure).
    """
    c = nutrient_level(p, ell)
    slope = np.where(c > 0.0, uptake_slope(c, K) / (ell * ell), 0.0)
    return uptake(c, K), slope


def mean_length(G: ArrayLike, phase0: float = 0.0) -> NDArray:
    """Mean cell length lbar = 2^frac(G / ln 2 + phase0) after the growth phase G.

    phase0 = 0 is the model's initial Psi0 = delta(l - 1); phase0 = log2 l_init for an initial
    delta(l - l_init).

    Parameters
    ----------
    G : array_like
        Growth phase int g dt of each material element.
    phase0 : float
        log2 of the initial length.

    Returns
    -------
    ndarray
        lbar in [1, 2), the shape of ``G``.
    """
    q = np.asarray(G, dtype=float) / LN2
    if phase0:
        q = q + float(phase0)
    return 2.0 ** (q - np.floor(q))


def ring_index(G: ArrayLike) -> NDArray:
    """Number of divisions floor(G / ln 2) (int32).

    Piecewise constant, it jumps by one across each ring G = k ln 2.
    """
    return np.floor(np.asarray(G, dtype=float) / LN2).astype(np.int32)
