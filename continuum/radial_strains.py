"""The 1D radial reference of a colony of concentric strains (issue 32: core and shells).

Strain i (i = 0 the core, then the shells outwards) occupies r_{i-1} < r < r_i (r_{-1} = 0,
the last radius the colony's edge R) and grows at g_i(p) = a_i exp(-lam_i p) (growth factor
a_i, stress sensitivity lam_i; ``Strain``, continuum.strains). Daughters inherit the strain and
the material does not mix, so the interfaces are material circles: the colony stays a set of
concentric rings. The instantaneous Darcy problem (model.md) ::

    -(1/r) (r p')' = g(p, r),   p'(0) = 0,   p(R) = 0,   g = g_i(p) on strain i,

with p and p' continuous at the interfaces, gives the velocity u = -p' and every radius moves
with the flow, dr_i/dt = u(r_i) = (1/r_i) int_0^{r_i} g s ds.

The pressure is found by shooting from the centre: p(0) = P solves p(R; P) = 0. For
lam_i >= 0, p(R; P) increases with P and 0 <= p <= max_i a_i (R^2 - r^2) / 4 (comparison with
the constant source max a_i), which brackets P. Each shot starts from the series
p(eps) = P - g_0(P) eps^2 / 4 and is integrated with DOP853 (rtol 1e-12) region by region, so
the source's jumps fall on the integration's end points. The radii are integrated in time with
DOP853 (rtol 1e-10), one shooting per right-hand side.

Exact checks (tests/continuum/test_radial_strains.py): identical strains are the one-strain
reference (continuum.radial: pressure and R(t)); with every lam_i = 0 the area of each ring
grows as exp(a_i t), so r_i(t)^2 = sum_{j <= i} (r_j(0)^2 - r_{j-1}(0)^2) exp(a_j t), and the
pressure is piecewise a_i r^2/4 plus logarithms, in closed form (:func:`pressure_lam0`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from continuum.strains import Strain

__all__ = ["Strain", "Layers", "layers", "pressure_lam0", "radii"]

EPS = 1e-6
"""Relative start of a shot, eps = EPS r_0 (the series there is exact to O(eps^4))."""


def _check(radii_now: ArrayLike, strains) -> tuple[NDArray, tuple[Strain, ...]]:
    r = np.asarray(radii_now, dtype=float)
    strains = tuple(strains)
    if r.ndim != 1 or len(r) != len(strains) or len(r) == 0:
        raise ValueError(f"give one radius per strain (inner to outer), got {len(r)} radii "
                         f"for {len(strains)} strains")
    if not (np.all(np.isfinite(r)) and r[0] > 0 and np.all(np.diff(r) > 0)):
        raise ValueError(f"the radii must be positive, finite and increasing, got {r.tolist()}")
    return r, strains


def _shoot(P: float, r: NDArray, strains: tuple[Strain, ...], dense: bool = False):
    """The edge values (p, p') of the shot with p(0) = P, and each region's solution."""
    eps = EPS * r[0]
    g0 = float(strains[0].rate(P))
    y = np.array([P - g0 * eps**2 / 4.0, -g0 * eps / 2.0])
    start, pieces = eps, []
    for ri, s in zip(r, strains, strict=True):
        def rhs(x, yy, s=s):
            return [yy[1], -yy[1] / x - s.rate(yy[0])]
        sol = solve_ivp(rhs, (start, ri), y, method="DOP853", rtol=1e-12, atol=1e-14 * (1 + P),
                        dense_output=dense)
        y = sol.y[:, -1]
        pieces.append(sol)
        start = ri
    return y, pieces


@dataclass
class Layers:
    """The pressure of a layered colony at one instant (:func:`layers`).

    Attributes
    ----------
    radii : ndarray
        Interface radii and the edge R (last).
    strains : tuple of Strain
    p0 : float
        p(0), the central pressure.
    velocity_at_radii : ndarray
        u(r_i) = -p'(r_i) at every radius: the rate of each interface and of the edge.
    """

    radii: NDArray
    strains: tuple
    p0: float
    velocity_at_radii: NDArray
    _pieces: list

    def pressure(self, r: ArrayLike) -> NDArray:
        """p(r) for 0 <= r <= R (the series inside eps)."""
        return self._eval(r, 0)

    def velocity(self, r: ArrayLike) -> NDArray:
        """u(r) = -p'(r) for 0 <= r <= R."""
        return -self._eval(r, 1)

    def _eval(self, r: ArrayLike, k: int) -> NDArray:
        r = np.atleast_1d(np.asarray(r, dtype=float))
        if np.any(r < 0) or np.any(r > self.radii[-1] * (1 + 1e-12)):
            raise ValueError("r outside the colony")
        out = np.empty_like(r)
        region = np.searchsorted(self.radii, r, side="left")
        region = np.minimum(region, len(self.radii) - 1)
        eps = EPS * self.radii[0]
        g0 = float(self.strains[0].rate(self.p0))
        for i, sol in enumerate(self._pieces):
            m = (region == i) & (r >= eps)
            if np.any(m):
                out[m] = sol.sol(r[m])[k]
        inner = r < eps
        out[inner] = (self.p0 - g0 * r[inner] ** 2 / 4.0) if k == 0 else -g0 * r[inner] / 2.0
        return out


def layers(radii_now: ArrayLike, strains) -> Layers:
    """Pressure and interface velocities of concentric strains with these radii (inner to outer).

    ``radii_now[i]`` is the outer radius of strain i (the last one the colony's edge R);
    ``strains[i]`` its :class:`Strain`. Raises ValueError on radii that are not positive and
    increasing or on a strain with lam < 0 (no bracket for the shooting).
    """
    r, strains = _check(radii_now, strains)
    top = max(s.growth for s in strains) * r[-1] ** 2 / 4.0
    P = brentq(lambda P: _shoot(P, r, strains)[0][0], 0.0, top * (1 + 1e-9) + 1e-300,
               xtol=1e-14 * max(top, 1e-300), rtol=4 * np.finfo(float).eps, maxiter=200)
    _, pieces = _shoot(P, r, strains, dense=True)
    u = np.array([-sol.y[1, -1] for sol in pieces])
    return Layers(r, strains, float(P), u, pieces)


def radii(t: ArrayLike, radii0: ArrayLike, strains, rtol: float = 1e-10) -> NDArray:
    """Every interface radius and the edge at the times t, (len(t), n): dr_i/dt = u(r_i).

    ``radii0``: the radii at t = 0 (inner to outer). Each right-hand side is one
    :func:`layers` solve.
    """
    r0, strains = _check(radii0, strains)
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if np.any(t < 0) or np.any(np.diff(t) < 0):
        raise ValueError("times must be >= 0 and increasing")
    if t[-1] == 0:
        return np.tile(r0, (len(t), 1))
    sol = solve_ivp(lambda _, y: layers(np.exp(y), strains).velocity_at_radii / np.exp(y),
                    (0.0, t[-1]), np.log(r0), method="DOP853", rtol=rtol, atol=rtol * 1e-2,
                    t_eval=t)
    return np.exp(sol.y.T)


def pressure_lam0(r: ArrayLike, radii_now: ArrayLike, growth: ArrayLike) -> NDArray:
    """Closed-form p(r) when every lam_i = 0: the source is a_i on ring i.

    On ring i, p = -a_i r^2 / 4 + B_i ln r + C_i; B_0 = 0 (regular centre), p and p' continuous
    at each interface (B_i = B_{i-1} + (a_i - a_{i-1}) r_{i-1}^2 / 2) and p(R) = 0.
    """
    rr, a = np.asarray(radii_now, dtype=float), np.asarray(growth, dtype=float)
    n = len(rr)
    B = np.zeros(n)
    for i in range(1, n):
        B[i] = B[i - 1] + (a[i] - a[i - 1]) * rr[i - 1] ** 2 / 2.0
    C = np.zeros(n)
    C[-1] = a[-1] * rr[-1] ** 2 / 4.0 - B[-1] * math.log(rr[-1])
    for i in range(n - 2, -1, -1):  # continuity of p at r_i, from outside in
        x = rr[i]
        outer = -a[i + 1] * x**2 / 4.0 + B[i + 1] * math.log(x) + C[i + 1]
        C[i] = outer + a[i] * x**2 / 4.0 - (B[i] * math.log(x) if B[i] else 0.0)
    r = np.atleast_1d(np.asarray(r, dtype=float))
    i = np.minimum(np.searchsorted(rr, r, side="left"), n - 1)
    logr = np.where(B[i] != 0, np.log(np.where(r > 0, r, 1.0)), 0.0)
    return -a[i] * r**2 / 4.0 + B[i] * logr + C[i]
