"""Linear stability of a circular colony: the rate of a mode-K perturbation of the boundary.

A disc of radius R perturbed to r = R (1 + eps cos K theta) (eps << 1). Each instant is
-Laplace p = g(p) = exp(-lam p) inside, p = 0 on the boundary, and the boundary moves with the
normal velocity V = -dp/dn. Write p = p0(r) + eps p1(r) cos K theta, p0 the radial solution
(continuum.radial: u0 = -p0', u0(R) = dR/dt).

Pressure perturbation. -Laplace (p0 + eps p1 cos K theta) = g(p0) + eps g'(p0) p1 cos K theta,
with g'(p) = -lam g(p), gives the linear ODE ::

    p1'' + p1'/r - K^2 p1 / r^2 + g'(p0(r)) p1 = 0,      p1 ~ r^K at r = 0 (regular),

and p = 0 on r = R (1 + eps cos K theta) to first order, p0(R) + eps R p0'(R) + eps p1(R) = 0,
gives p1(R) = R u0(R).

Rate. The boundary radius R + eps R cos K theta moves with V = -dp/dr at the perturbed
boundary: dR/dt = u0(R) and d(eps R)/dt = -eps (R p0''(R) + p1'(R)). With p0'' = -g(0) - p0'/r
= -1 + u0/R at r = R, the relative amplitude eps obeys d eps / dt = sigma eps ::

    sigma(K, lam, R) = 1 - 2 u0(R)/R - p1'(R)/R.

Write p1 = R u0(R) (r/R)^K y(r) / y(R): y is regular, y'' + (2K + 1) y'/r + g'(p0) y = 0,
y(0) = 1, y'(0) = 0, and p1'(R)/R = u0(R) (K/R + y'(R)/y(R)), so ::

    sigma = 1 - 2 u0/R - u0 (K/R + y'(R)/y(R)).

lam = 0: g' = 0, y = 1, u0 = R/2: sigma = -K/2 exactly (relative amplitude; the absolute
amplitude eps R has the rate (1 - K)/2). K = 2 is the small-aspect limit of the exact ellipse
(model.md: q = ln(a/b) obeys dq/dt = -tanh q, and eps = (a - b)/(a + b) + O(eps^2) ~ q/2).
K = 1 is a translation for every lam: p1 = R u0(r) solves the ODE, and sigma = -u0(R)/R.
Small lam: y = 1 + lam r^2 / (4 (K + 1)) + ... (g' = -lam + O(lam^2)) and u0 = (R/2)(1 - lam
R^2/8) give sigma = -K/2 + lam R^2 [1/8 + K/16 - 1/(4 (K + 1))] + O(lam^2) (tests).

Numerics (:func:`shape_function`). The regular solution y is integrated by DOP853 from a
three-term series at r = r_s = 1e-3 R to R, at a relative tolerance ``rtol``; the convergence
check repeats the integration at rtol / 100 and raises if the two y'(R)/y(R) differ by more than
10 rtol (1 + abs(y'/y)). tests/continuum/test_stability.py compares it with an independent
collocation solve of the p1 problem (scipy.integrate.solve_bvp) and with the closed forms.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp

from continuum import radial

__all__ = [
    "mode_rate",
    "shape_function",
    "amplitude_ratio",
    "small_lam_rate",
]


def _check_mode(K: int) -> int:
    if int(K) != K or K < 1:
        raise ValueError(f"mode number K must be an integer >= 1, got {K!r}")
    return int(K)


def small_lam_rate(K: int, lam: float, R: float) -> float:
    """First order in lam: sigma = -K/2 + lam R^2 [1/8 + K/16 - 1/(4 (K + 1))] (module doc)."""
    K = _check_mode(K)
    return -0.5 * K + lam * R * R * (0.125 + K / 16.0 - 0.25 / (K + 1.0))


def _rhs(K: int, lam: float, R: float):
    """Right-hand side of y'' = -(2K + 1) y'/r - g'(p0) y, g'(p0) = -lam / D(r)^2.

    D(r) = 1 + lam c (R^2 - r^2), c = c(R) (continuum.radial: g(p0(r)) = 1 / D^2).
    """
    lc = lam * float(radial.c_of_R(R, lam))

    def f(r: float, z: NDArray) -> NDArray:
        D = 1.0 + lc * (R * R - r * r)
        return np.array([z[1], -(2 * K + 1) * z[1] / r + lam * z[0] / (D * D)])

    return f


def shape_function(K: int, lam: float, R: float, rtol: float = 1e-10) -> float:
    """The boundary log-derivative y'(R)/y(R) of the regular solution of the y equation.

    y'' + (2K + 1) y'/r + g'(p0(r)) y = 0, y(0) = 1, y'(0) = 0, g'(p0) = -lam exp(-lam p0)
    (module docstring). Started at r_s = 1e-3 R from the series y = 1 + a r^2,
    a = lam g(0) / (4 (K + 1)), integrated by DOP853 at ``rtol``; checked against a second
    integration at rtol / 100 (ValueError if they differ by more than 10 rtol (1 + abs(y'/y))).

    Returns
    -------
    float
        y'(R) / y(R) (0 at lam = 0).
    """
    K = _check_mode(K)
    lam, R = float(lam), float(R)
    if not (math.isfinite(R) and R > 0):
        raise ValueError(f"colony radius R must be positive and finite, got {R!r}")
    if lam == 0.0:
        return 0.0

    def once(tol: float) -> float:
        a = lam * float(radial.growth_rate(0.0, R, lam)) / (4.0 * (K + 1))
        rs = 1e-3 * R
        z0 = [1.0 + a * rs * rs, 2.0 * a * rs]
        sol = solve_ivp(_rhs(K, lam, R), (rs, R), z0, method="DOP853", rtol=tol,
                        atol=tol * 1e-6)
        if not sol.success:  # pragma: no cover - DOP853 on this smooth regular problem
            raise RuntimeError(f"mode-{K} shape function: {sol.message}")
        y, dy = sol.y[:, -1]
        return dy / y

    v, v_fine = once(rtol), once(rtol / 100.0)
    if abs(v - v_fine) > 10 * rtol * (1.0 + abs(v_fine)):
        raise ValueError(f"mode-{K} shape function not converged: {v} vs {v_fine} at rtol {rtol}")
    return v_fine


def mode_rate(K: int, lam: float, R: float, rtol: float = 1e-10) -> float:
    """Linear rate sigma = d ln(eps)/dt of the relative amplitude of r = R (1 + eps cos K theta).

    sigma = 1 - 2 u0(R)/R - u0(R) (K/R + y'(R)/y(R)) (module docstring; y from
    :func:`shape_function`, u0(R) = dR/dt of the disc, continuum.radial.radius_rate).
    lam = 0: -K/2; K = 1: -u0(R)/R.

    Parameters
    ----------
    K : int
        Mode number (>= 1).
    lam : float
        Stress sensitivity of g = exp(-lam p) (any lam with a radial solution at R).
    R : float
        Disc radius.
    rtol : float
        Tolerance of the shooting integration.
    """
    K = _check_mode(K)
    u0 = float(radial.radius_rate(R, lam))
    return 1.0 - 2.0 * u0 / R - u0 * (K / R + shape_function(K, lam, R, rtol))


def amplitude_ratio(K: int, lam: float, R_start: float, times: ArrayLike,
                    rtol: float = 1e-10) -> NDArray:
    """ln(eps(t) / eps(0)) = int_0^t sigma(K, lam, R(s)) ds along the disc's radius R(s).

    R(s) from R(0) = R_start (continuum.radial.radius); the integral by Gauss-Legendre
    quadrature (16 points) on each interval between consecutive ``times`` (sorted, >= 0).
    """
    K = _check_mode(K)
    times = np.asarray(times, dtype=float)
    if np.any(np.diff(times) < 0) or np.any(times < 0):
        raise ValueError("times must be sorted and >= 0")
    x, w = np.polynomial.legendre.leggauss(16)
    edges = np.concatenate([[0.0], times])
    out = np.zeros(len(times))
    acc = 0.0
    for i in range(len(times)):
        a, b = edges[i], edges[i + 1]
        if b > a:
            s = 0.5 * (a + b) + 0.5 * (b - a) * x
            R = radial.radius(s, lam, R0=R_start)
            acc += 0.5 * (b - a) * sum(wk * mode_rate(K, lam, float(Rk), rtol)
                                       for wk, Rk in zip(w, R, strict=True))
        out[i] = acc
    return out
