"""The 1D radial reference with nutrient limitation (model.md, "Nutrient limitation").

A disc colony of radius R fed at its edge (c = 1 on r = R) or through the agar of a dish
(c = 1 on r = R_dish, the same diffusivity in colony and agar) stays a disc. In the colony
-Laplace p = g and Laplace c = g / ell^2 with g = exp(-lam p) f(c) (f: growth.uptake), so
q = p + ell^2 c is harmonic, and with p(R) = 0 and q regular at the centre it is constant::

    p = ell^2 (c_R - c),      c_R = c(R)  (1 with supply at the edge).

c alone then solves the boundary-value problem ::

    ell^2 (c'' + c'/r) = exp(-lam ell^2 (c_R - c)) f(c),      c'(0) = 0,

with c(R) = 1 at the edge, or in a dish c'(R) = (1 - c_R) / (R ln(R_dish / R)): outside the
colony c = c_R + (1 - c_R) ln(r/R) / ln(R_dish/R), and the flux is continuous. The edge moves at
U(R) = u(R) = -p'(R) = ell^2 c'(R), so the area grows at dA/dt = 2 pi ell^2 R c'(R), in a dish
exactly the supply through the agar, 2 pi ell^2 (1 - c_R) / ln(R_dish / R).

Since the state depends on R alone, t(R) = int_{R0}^{R} dR' / U(R') (:func:`time_to_radius`,
Gauss-Legendre panels in ln R, where R / U is smooth and 2 at small R).

Numerics (:func:`solve`): shooting from the centre in w = ln c, which keeps the relative accuracy
of c where it is tiny (a starved core, c ~ 1 / I0(R/ell)), ::

    w'' = exp(-lam ell^2 (c_R - c)) f(c) / (ell^2 c) - w'/r - w'^2,

started on the series w = w0 + k r^2 / 4 and integrated to rtol 1e-11 (DOP853) with its
sensitivities to w0 and c_R; the centre value w0 (and in a dish ln c_R) found by Newton's
method, from the previous radius in :func:`time_to_radius`. Should Newton fail, bracketing:
at the edge w0 <= ln c_R (c is subharmonic) and w0 >= ln c_R - ln I0(kappa R),
kappa^2 = (1 + K) / (K ell^2), by comparison with the linear problem.

Exact, for lam = 0, K = inf, supply at the edge (:func:`bessel`): c = I0(r/ell) / I0(R/ell),
u = ell I1(r/ell) / I0(R/ell), U = ell I1(R/ell) / I0(R/ell), and, since
d/dx ln(x I1(x)) = I0(x) / I1(x), ::

    t(R) = ln( R I1(R/ell) / (R0 I1(R0/ell)) ),

exponential growth R = R0 exp(t/2) while R << ell, linear at speed ell once R >> ell.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.special import i0e, i1e

from continuum.growth import uptake
from continuum.radial import R0

__all__ = ["RadialNutrientState", "bessel", "bessel_time_to_radius", "solve", "radius_rate",
           "time_to_radius", "radius"]

RTOL = 1e-11
"""Relative tolerance of the shooting integration."""


@dataclass(frozen=True)
class RadialNutrientState:
    """The radial state of a disc of radius ``R``: c(r), p(r), u(r) and the edge's speed.

    ``r`` the integration's radii (0 .. R), ``c``, ``p`` = ell^2 (c_R - c), ``u`` = -p' =
    ell^2 c' on them; ``c_edge`` = c(R); ``speed`` = U(R) = dR/dt.
    """

    R: float
    r: NDArray
    c: NDArray
    p: NDArray
    u: NDArray
    c_edge: float
    speed: float

    def growth(self, lam: float, K: float) -> NDArray:
        """The growth rate g = exp(-lam p) f(c) on ``r``."""
        return np.exp(-lam * self.p) * uptake(self.c, K)


# ----------------------------------------------------------------------------- exact (lam = 0)


def bessel(r: ArrayLike, R: float, ell: float) -> tuple[NDArray, NDArray, float]:
    """(c(r), u(r), U(R)) of lam = 0, K = inf, supply at the edge: the modified Bessel solution.

    c = I0(r/ell) / I0(R/ell), u = ell I1(r/ell) / I0(R/ell), U = ell I1(R/ell) / I0(R/ell),
    in the exponentially scaled Bessel functions (no overflow at R >> ell).
    """
    x, X = np.asarray(r, dtype=float) / ell, R / ell
    scale = np.exp(x - X)
    return (i0e(x) / i0e(X) * scale, ell * i1e(x) / i0e(X) * scale,
            float(ell * i1e(X) / i0e(X)))


def bessel_time_to_radius(R: ArrayLike, ell: float, R0: float = R0) -> NDArray | float:
    """t(R) = ln(R I1(R/ell) / (R0 I1(R0/ell))) of :func:`bessel` (module docstring)."""
    R = np.asarray(R, dtype=float)

    def log_x_i1(x):  # ln(x I1(x)) = ln x + ln i1e(x) + x
        return np.log(x) + np.log(i1e(x)) + x

    t = log_x_i1(R / ell) - log_x_i1(R0 / ell)
    return float(t) if t.ndim == 0 else t


# ----------------------------------------------------------------------------- shooting


def _check(R: float, lam: float, ell: float, K: float, R_dish: float | None) -> None:
    if not (math.isfinite(ell) and ell > 0):
        raise ValueError(f"ell must be a positive number, got {ell}")
    if not (math.isfinite(lam) and lam >= 0):
        raise ValueError(f"lam must be >= 0 and finite, got {lam}")
    if not (K > 0):
        raise ValueError(f"K must be > 0 (inf: first order), got {K}")
    if not (math.isfinite(R) and R > 0):
        raise ValueError(f"R must be a positive number, got {R}")
    if R_dish is not None and not (math.isfinite(R_dish) and R_dish > R):
        raise ValueError(f"the dish radius {R_dish} must exceed the colony radius {R}")


def _shoot(w0: float, c_edge: float, R: float, lam: float, ell: float, K: float,
           dense: bool = False):
    """Integrate w = ln c from the centre (w(0) = w0) to R, with its two sensitivities.

    y = [w, w', z, z', y, y'], z = dw/dw0 and y = dw/dc_R (variational equations of the ODE of
    the module docstring), so that Newton's method has exact derivatives. The solve_ivp result.
    """
    a = lam * ell**2

    def source(w):  # k = exp(-a (c_R - c)) f(c) / (ell^2 c), f(c)/c = (1 + K)/(K + c); dk/dw
        c = math.exp(w)
        ratio = 1.0 if math.isinf(K) else (1.0 + K) / (K + c)
        k = math.exp(-a * (c_edge - c)) * ratio / ell**2
        dlog_ratio = 0.0 if math.isinf(K) else -c / (K + c)
        return k, k * (a * c + dlog_ratio)

    def rhs(r, v):
        w, dw, z, dz, y, dy = v
        k, kw = source(w)
        return [dw, k - dw / r - dw * dw,
                dz, kw * z - dz / r - 2.0 * dw * dz,
                dy, kw * y - a * k - dy / r - 2.0 * dw * dy]

    k0, kw0 = source(w0)
    r0 = min(1e-4 * R, 1e-3 * ell)  # the series w = w0 + k r^2 / 4 (and its derivatives)
    v0 = [w0 + k0 * r0**2 / 4.0, k0 * r0 / 2.0, 1.0 + kw0 * r0**2 / 4.0, kw0 * r0 / 2.0,
          -a * k0 * r0**2 / 4.0, -a * k0 * r0 / 2.0]
    return solve_ivp(rhs, (r0, R), v0, method="DOP853", rtol=RTOL, atol=1e-14,
                     dense_output=dense)


def _log_i0(x: float) -> float:
    return math.log(i0e(x)) + x


NEWTON_TOL = 1e-12
"""Newton's method stops when every equation misses by less than this."""


def _newton(w0: float, log_c_edge: float, R, lam, ell, K, R_dish) -> tuple[float, float] | None:
    """(w0, ln c_R) by Newton's method from a guess; None when it does not converge.

    Edge: w(R) = 0. Dish: w(R) = ln c_R and c_R w'(R) R L = 1 - c_R, L = ln(R_dish / R).
    """
    for _ in range(30):
        c_edge = math.exp(log_c_edge)
        sol = _shoot(w0, c_edge, R, lam, ell, K)
        if sol.status != 0:
            return None
        w, dw, z, dz, y, dy = sol.y[:, -1]
        if R_dish is None:
            miss = w
            if abs(miss) < NEWTON_TOL:
                return w0, 0.0
            w0 -= max(-2.0, min(2.0, miss / z))
            continue
        L = math.log(R_dish / R)
        misses = np.array([w - log_c_edge, c_edge * dw * R * L - (1.0 - c_edge)])
        if np.max(np.abs(misses)) < NEWTON_TOL:
            return w0, log_c_edge
        jac = np.array([[z, y * c_edge - 1.0],
                        [c_edge * dz * R * L, c_edge * (dw + c_edge * dy) * R * L + c_edge]])
        step = np.linalg.solve(jac, misses)
        step *= min(1.0, 2.0 / max(np.max(np.abs(step)), 1e-300))  # at most 2 in ln units
        w0, log_c_edge = w0 - step[0], log_c_edge - step[1]
    return None


def _edge_w0(R, lam, ell, K, c_edge: float = 1.0) -> float:
    """The centre value w0 = ln c(0) with c(R) = ``c_edge``, bracketed (module docstring)."""
    target = math.log(c_edge)

    def miss(w0):
        return float(_shoot(w0, c_edge, R, lam, ell, K).y[0, -1]) - target

    kappa = math.sqrt(1.0 / ell**2 if math.isinf(K) else (1.0 + K) / (K * ell**2))
    low = target - _log_i0(kappa * R) - 1.0
    return brentq(miss, low, target, xtol=1e-14, rtol=1e-15, maxiter=200)


def _unknowns_of(R, lam, ell, K, R_dish, guess) -> tuple[float, float]:
    """(w0, c_R): Newton from ``guess`` (or the linear problem's), else bracketing root finders.

    The fallback: the edge by :func:`_edge_w0`; the dish by brentq on c_R in (0, 1) of the
    flux balance, monotone (consumption rises with c_R, the agar's supply falls).
    """
    if guess is None:
        kappa = math.sqrt(1.0 / ell**2 if math.isinf(K) else (1.0 + K) / (K * ell**2))
        guess = (-_log_i0(kappa * R), 1.0 if R_dish is None else 0.5)
    found = _newton(guess[0], math.log(guess[1]), R, lam, ell, K, R_dish)
    if found is not None:
        return found[0], math.exp(found[1])
    if R_dish is None:
        return _edge_w0(R, lam, ell, K), 1.0
    L = math.log(R_dish / R)

    def flux_miss(c_edge):
        sol = _shoot(_edge_w0(R, lam, ell, K, c_edge), c_edge, R, lam, ell, K)
        return c_edge * sol.y[1, -1] * R * L - (1.0 - c_edge)

    c_edge = brentq(flux_miss, 1e-300, 1.0, xtol=1e-15, rtol=1e-15, maxiter=200)
    return _edge_w0(R, lam, ell, K, c_edge), c_edge


def solve(R: float, lam: float, ell: float, K: float = math.inf, R_dish: float | None = None,
          n: int = 201, guess=None) -> RadialNutrientState:
    """The radial state of a disc of radius ``R`` (module docstring), on ``n`` radii.

    ``R_dish`` None: supply at the edge; else the dish's radius (> R). ``guess``: the
    (w0, c_R) of a nearby radius, to start Newton's method from (:func:`time_to_radius`).
    """
    _check(R, lam, ell, K, R_dish)
    w0, c_edge = _unknowns_of(R, lam, ell, K, R_dish, guess)
    sol = _shoot(w0, c_edge, R, lam, ell, K, dense=True)
    r = np.linspace(0.0, R, n)
    w, dw = sol.sol(np.maximum(r, sol.t[0]))[:2]
    inner = r < sol.t[0]  # the series w = w0 + k r^2 / 4 inside the start radius
    k = 2.0 * sol.y[1, 0] / sol.t[0]
    w[inner], dw[inner] = w0 + k * r[inner] ** 2 / 4.0, k * r[inner] / 2.0
    c = np.exp(w)
    speed = ell**2 * c_edge * float(sol.y[1, -1])
    return RadialNutrientState(R=R, r=r, c=c, p=ell**2 * (c_edge - c), u=ell**2 * c * dw,
                               c_edge=c_edge, speed=speed)


def _unknowns(state: RadialNutrientState) -> tuple[float, float]:
    return math.log(state.c[0]), state.c_edge


def radius_rate(R: ArrayLike, lam: float, ell: float, K: float = math.inf,
                R_dish: float | None = None) -> NDArray | float:
    """dR/dt = U(R) = ell^2 c'(R) of :func:`solve` at each radius."""
    Rs = np.atleast_1d(np.asarray(R, dtype=float))
    out = np.array([solve(float(x), lam, ell, K, R_dish, n=2).speed for x in Rs])
    return float(out[0]) if np.ndim(R) == 0 else out


#: Gauss-Legendre nodes and weights of each panel of :func:`time_to_radius` on [-1, 1].
_GL = np.polynomial.legendre.leggauss(10)
#: Panel width in ln R.
PANEL = 0.5


def time_to_radius(R: ArrayLike, lam: float, ell: float, K: float = math.inf,
                   R_dish: float | None = None, R0: float = R0) -> NDArray | float:
    """t(R) = int_{R0}^{R} dR'/U(R') = int R'/U(R') d ln R' (Gauss-Legendre panels in ln R).

    Each radius's state starts its root finder from the previous one's (continuation in R).
    """
    Rs = np.atleast_1d(np.asarray(R, dtype=float))
    if np.any(Rs < R0):
        raise ValueError(f"radii must be >= R0 = {R0}")
    order = np.argsort(Rs)
    out = np.empty_like(Rs)
    t, x, guess = 0.0, math.log(R0), None
    nodes, weights = _GL
    for i in order:
        x_end = math.log(Rs[i])
        while x < x_end - 1e-15:
            b = min(x + PANEL, x_end)
            half, mid = (b - x) / 2.0, (b + x) / 2.0
            for node, weight in zip(nodes, weights, strict=True):
                radius_here = math.exp(mid + half * node)
                state = solve(radius_here, lam, ell, K, R_dish, n=2, guess=guess)
                guess = _unknowns(state)
                t += half * weight * radius_here / state.speed
            x = b
        out[i] = t
    return float(out[0]) if np.ndim(R) == 0 else out


def radius(t: ArrayLike, lam: float, ell: float, K: float = math.inf,
           R_dish: float | None = None, R0: float = R0, R_max: float = 1e3) -> NDArray | float:
    """R(t), the inverse of :func:`time_to_radius`: a monotone cubic (PCHIP) of ln R in t.

    On a grid of 32 radii per e-fold of R from R0 to ``R_max`` (or the dish); for exact values
    at given radii use :func:`time_to_radius`.
    """
    from scipy.interpolate import PchipInterpolator

    ts = np.atleast_1d(np.asarray(t, dtype=float))
    top = R_max if R_dish is None else min(R_max, R_dish * (1 - 1e-6))
    R_grid = np.exp(np.linspace(math.log(R0), math.log(top), 1 + int(32 * math.log(top / R0))))
    t_grid = time_to_radius(R_grid, lam, ell, K, R_dish, R0)
    if ts.max() > t_grid[-1] or ts.min() < 0:
        raise ValueError(f"t must lie in [0, {t_grid[-1]:g}] (radius {top:g}), got {ts.max():g}")
    out = np.exp(PchipInterpolator(t_grid, np.log(R_grid))(ts))
    return float(out[0]) if np.ndim(t) == 0 else out
