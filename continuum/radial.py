"""The 1D radial reference of the continuum model (model.md, "Exact solutions to validate against").

A disc colony of radius R stays a disc. With g = exp(-lam p) the instantaneous problem
-p'' - p'/r = exp(-lam p), p(R) = 0, p'(0) = 0 has the closed-form solution ::

    p(r) = (2/lam) ln D(r),   D(r) = 1 + lam c (R^2 - r^2),   c(R) = 1 / (4 (w + 1)),
    w(R) = sqrt(1 + lam R^2 / 2),

(equal to model.md's p = (2/lam) ln(1/(8c) - c lam r^2), since 1/(8c) - c lam R^2 = 1), so that ::

    u(r) = -p'(r) = 4 c r / D(r),   g(r) = exp(-lam p) = 1 / D(r)^2,   dR/dt = u(R) = 4 c R.

lam = 0 is the continuous limit: c = 1/8, p = (R^2 - r^2)/4, u = r/2. lam < 0 is allowed while
1 + lam R^2/2 >= 0, i.e. ``R <= R_crit = sqrt(2/|lam|)`` (the Bratu critical size); beyond it
there is no solution and the functions raise :class:`NoRadialSolution`.

Radius. Separating dt = (w + 1) dR / R and using d/dR [w - ln(1 + w)] = w' w/(1 + w) gives ::

    t(R) = F(R) - F(R0),   F(R) = 2 ln R + w(R) - ln(1 + w(R)),

exactly (lam = 0: R = R0 exp(t/2); lam > 0: R ~ sqrt(2/lam) t at late times). :func:`radius`
inverts it by safeguarded Newton in x = ln R (dF/dx = 1 + w).

Characteristics. A material point moves with dr/dt = u(r, R(t)) and its growth phase is
G = int g dt along the path (G(0) = 0). With the boundary radius as clock, sigma = ln R, and the
relative position rho = r/R (D = 1 + k (1 - rho^2), k = lam c R^2 = (w - 1)/2)::

    d rho / d sigma = rho (1/D - 1),      d G / d sigma = (1 + w) / D^2,

integrated to rtol 1e-10 (DOP853). Paths are integrated backward from their final radii, so the
reference is exactly as fine as asked where it is needed (near the edge, where the rings form);
the mean length of an initial delta(l - 1) is lbar = 2^frac(G / ln 2) and a ring (a jump of lbar
from 2 to 1) sits where G = k ln 2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline

from continuum.growth import LN2, mean_length

__all__ = [
    "R0",
    "NoRadialSolution",
    "Characteristics",
    "c_of_R",
    "pressure",
    "velocity",
    "growth_rate",
    "radius_rate",
    "max_pressure",
    "radius",
    "time_to_radius",
    "critical_radius",
    "critical_time",
    "characteristics",
    "growth_phase",
    "mean_length_profile",
    "ring_radii",
    "mean_length_from_phase",
]

B = 0.5
"""Particle diameter b (units: birth length l0 = 1; model.md)."""

R0 = math.sqrt(B / math.pi)
"""Initial colony radius sqrt(b/pi): the disc with the area of one particle (b = 1/2)."""


class NoRadialSolution(ValueError):  # noqa: N818 - the public name
    """lam < 0 and the disc is larger than the critical radius ``sqrt(2/|lam|)``: no solution."""


# ----------------------------------------------------------------------------- closed forms


def critical_radius(lam: float) -> float:
    """Largest radius with a solution: ``sqrt(2/|lam|)`` for lam < 0, infinity for lam >= 0."""
    lam = _check_lam(lam)
    return math.inf if lam >= 0 else math.sqrt(2.0 / -lam)


def _check_lam(lam: float) -> float:
    lam = float(lam)
    if not math.isfinite(lam):
        raise ValueError(f"lam must be finite, got {lam}")
    return lam


def _w(R: NDArray, lam: float) -> NDArray:
    """The root w = sqrt(1 + lam R^2 / 2), raising NoRadialSolution when the root is imaginary."""
    arg = 1.0 + 0.5 * lam * R * R
    if np.any(arg < 0):
        raise NoRadialSolution(
            f"lam = {lam} < 0: no radial solution for R > sqrt(2/|lam|) = {critical_radius(lam):g}"
        )
    return np.sqrt(arg)


def _radius_array(R: ArrayLike) -> NDArray:
    R = np.asarray(R, dtype=float)
    if np.any(~np.isfinite(R)) or np.any(R <= 0):
        raise ValueError("colony radius R must be finite and positive")
    return R


def c_of_R(R: ArrayLike, lam: float) -> NDArray | float:  # noqa: N802 - the model's c(R)
    """Constant c(R) = 1 / (4 (sqrt(1 + lam R^2/2) + 1)) of the radial solution (lam = 0: 1/8).

    This is the cancellation-free form of c = [sqrt(1 + lam R^2/2) - 1] / (2 lam R^2).
    """
    lam = _check_lam(lam)
    R = _radius_array(R)
    c = 1.0 / (4.0 * (_w(R, lam) + 1.0))
    return c if c.ndim else float(c)


def _D(r: NDArray, R: NDArray, lam: float) -> tuple[NDArray, NDArray]:  # noqa: N802 - D(r)
    """Return (D, c) with D = 1 + lam c (R^2 - r^2) > 0, after checking 0 <= r <= R."""
    if np.any(r < 0) or np.any(r > R * (1 + 1e-12)):
        raise ValueError("radial positions must satisfy 0 <= r <= R")
    c = 1.0 / (4.0 * (_w(R, lam) + 1.0))
    return 1.0 + lam * c * (R * R - r * r), c


def _log1p_ratio(z: NDArray) -> NDArray:
    """ln(1 + z) / z, continuous at z = 0 (where it is 1)."""
    z = np.asarray(z, dtype=float)
    small = np.abs(z) < 1e-6
    zs = np.where(small, 1.0, z)
    return np.where(small, 1.0 - z / 2.0 + z * z / 3.0, np.log1p(zs) / zs)


def pressure(r: ArrayLike, R: ArrayLike, lam: float) -> NDArray | float:
    """Radial pressure p(r) = (2/lam) ln(1 + lam c (R^2 - r^2)) for 0 <= r <= R.

    Evaluated as 2 c (R^2 - r^2) ln(1 + z)/z with z = lam c (R^2 - r^2), so lam = 0 gives
    (R^2 - r^2)/4 exactly and small lam has no cancellation.
    """
    lam = _check_lam(lam)
    r = np.asarray(r, dtype=float)
    R = _radius_array(R)
    D, c = _D(r, R, lam)
    q = np.maximum(R * R - r * r, 0.0)
    p = 2.0 * c * q * _log1p_ratio(lam * c * q)
    return p if p.ndim else float(p)


def velocity(r: ArrayLike, R: ArrayLike, lam: float) -> NDArray | float:
    """Radial Darcy velocity u(r) = -dp/dr = 4 c r / (1 + lam c (R^2 - r^2)) (lam = 0: r/2)."""
    lam = _check_lam(lam)
    r = np.asarray(r, dtype=float)
    R = _radius_array(R)
    D, c = _D(r, R, lam)
    u = 4.0 * c * r / D
    return u if u.ndim else float(u)


def growth_rate(r: ArrayLike, R: ArrayLike, lam: float) -> NDArray | float:
    """Growth rate g(r) = exp(-lam p(r)) = 1 / (1 + lam c (R^2 - r^2))^2."""
    lam = _check_lam(lam)
    r = np.asarray(r, dtype=float)
    R = _radius_array(R)
    D, _ = _D(r, R, lam)
    g = 1.0 / (D * D)
    return g if g.ndim else float(g)


def radius_rate(R: ArrayLike, lam: float) -> NDArray | float:
    """Boundary speed dR/dt = u(R) = 4 c(R) R = R / (sqrt(1 + lam R^2/2) + 1)."""
    lam = _check_lam(lam)
    R = _radius_array(R)
    v = R / (_w(R, lam) + 1.0)
    return v if v.ndim else float(v)


def max_pressure(R: ArrayLike, lam: float) -> NDArray | float:
    """Maximum (centre) pressure p(0) = (2/lam) ln(1/(8c)) (lam = 0: R^2/4)."""
    return pressure(0.0 * np.asarray(R, dtype=float), R, lam)


# ----------------------------------------------------------------------------- R(t)


def _F(x: NDArray, lam: float) -> NDArray:  # noqa: N802 - the model's F(R)
    """F(R) = 2 ln R + w - ln(1 + w) in x = ln R; t(R) = F(R) - F(R0)."""
    w = _w(np.exp(x), lam)
    return 2.0 * x + w - np.log1p(w)


def time_to_radius(R: ArrayLike, lam: float, R0: float = R0) -> NDArray | float:
    """Time at which the disc reaches radius R: t = F(R) - F(R0), F = 2 ln R + w - ln(1 + w)."""
    lam = _check_lam(lam)
    R = _radius_array(R)
    _radius_array(R0)
    t = _F(np.log(R), lam) - _F(np.log(np.asarray(float(R0))), lam)
    return t if t.ndim else float(t)


def critical_time(lam: float, R0: float = R0) -> float:
    """Time at which the disc from R0 < R_crit reaches the critical radius: F(R_crit) - F(R0).

    w(R_crit) = 0, so F(R_crit) = 2 ln R_crit. Infinity for lam >= 0 (no critical radius).
    """
    lam = _check_lam(lam)
    if lam >= 0:
        return math.inf
    _radius_array(R0)
    return 2.0 * math.log(critical_radius(lam)) - float(_F(np.asarray(math.log(R0)), lam))


def radius(t: ArrayLike, lam: float, R0: float = R0) -> NDArray | float:
    """Disc radius R(t) from R(0) = R0, the exact inverse of :func:`time_to_radius`.

    lam = 0: R = R0 exp(t/2). Otherwise F(ln R) = F(ln R0) + t is solved by Newton in x = ln R
    (dF/dx = 1 + w in [1, inf)), safeguarded by the bracket x0 + t/2 >= x >= x0 + t/(1 + w_max)
    (lam > 0: x <= ln(R0 + t / sqrt(lam/2)) as well), to machine precision.

    Parameters
    ----------
    t : array_like
        Times t >= 0.
    lam : float
        Stress sensitivity lambda of the growth law g = exp(-lam p).
    R0 : float
        Radius at t = 0.

    Returns
    -------
    ndarray or float
        R(t), of the shape of ``t`` (a float for a scalar ``t``).

    Raises
    ------
    NoRadialSolution
        lam < 0 and the disc reaches the critical radius ``sqrt(2/|lam|)`` by time t.
    """
    lam = _check_lam(lam)
    _radius_array(R0)
    t = np.asarray(t, dtype=float)
    if np.any(~np.isfinite(t)) or np.any(t < 0):
        raise ValueError("times must be finite and >= 0")
    x0 = math.log(R0)
    if lam == 0.0:
        R = R0 * np.exp(t / 2.0)
        return R if R.ndim else float(R)
    F0 = float(_F(np.asarray(x0), lam))
    target = F0 + t
    if lam > 0:
        lo = np.full_like(t, x0)
        hi = np.minimum(x0 + t / 2.0, np.log(R0 + t / math.sqrt(lam / 2.0)))
    else:
        xc = math.log(critical_radius(lam))
        tc = float(_F(np.asarray(xc), lam)) - F0
        if np.any(t > tc):
            raise NoRadialSolution(
                f"lam = {lam} < 0: the disc reaches the critical radius at t = {tc:g}"
            )
        lo = x0 + t / 2.0
        hi = np.minimum(x0 + t, xc)
    x = hi.copy()
    for _ in range(200):
        Fx = _F(x, lam) - target
        lo = np.where(Fx < 0, x, lo)
        hi = np.where(Fx > 0, x, hi)
        step = Fx / (1.0 + _w(np.exp(x), lam))
        xn = x - step
        bad = (xn <= lo) | (xn >= hi)
        xn = np.where(bad, 0.5 * (lo + hi), xn)
        done = np.abs(xn - x) <= 4e-16 * np.maximum(1.0, np.abs(x))
        x = xn
        if np.all(done):
            break
    R = np.exp(x)
    return R if R.ndim else float(R)


# ----------------------------------------------------------------------------- characteristics


@dataclass(frozen=True)
class Characteristics:
    """Material paths of the radial colony, from t = 0 to t = t_end (radius R = radius_end).

    Attributes
    ----------
    lam : float
        Stress sensitivity.
    t_end, radius_end : float
        Final time and disc radius.
    r0 : ndarray
        Material labels: radii at t = 0, in [0, R0].
    r : ndarray
        Radii of the same material points at t_end, in [0, radius_end], increasing.
    G : ndarray
        Growth phase G = int_0^t_end g dt along each path.
    """

    lam: float
    t_end: float
    radius_end: float
    r0: NDArray
    r: NDArray
    G: NDArray

    @property
    def mean_length(self) -> NDArray:
        """Mean length lbar = 2^frac(G / ln 2) at the path ends for Psi0 = delta(l - 1)."""
        return mean_length_from_phase(self.G)


def mean_length_from_phase(G: ArrayLike, phase0: float = 0.0) -> NDArray:
    """Mean length of an initial delta(l - 2^phase0) after growth phase G.

    lbar = 2^frac(G / ln 2 + phase0); phase0 = 0 is Psi0 = delta(l - 1)
    (:func:`continuum.growth.mean_length`).
    """
    return mean_length(G, phase0)


def _end_state(lam: float, t: float | None, radius_end: float | None, R0: float) -> tuple:
    if (t is None) == (radius_end is None):
        raise ValueError("give exactly one of t and radius")
    if t is not None:
        t = float(t)
        return t, float(radius(t, lam, R0))
    radius_end = float(radius_end)
    if radius_end < R0:
        raise ValueError(f"radius {radius_end} is smaller than the initial radius {R0}")
    return float(time_to_radius(radius_end, lam, R0)), radius_end


def _rhs(lam: float):
    """Right-hand side in sigma = ln R of y = (rho_1..rho_n, G_1..G_n)."""

    def f(sigma: float, y: NDArray) -> NDArray:
        n = y.size // 2
        rho = y[:n]
        R = math.exp(sigma)
        w = math.sqrt(1.0 + 0.5 * lam * R * R)
        k = 0.5 * (0.5 * lam * R * R) / (w + 1.0)  # (w - 1)/2 without cancellation
        D = 1.0 + k * (1.0 - rho * rho)
        return np.concatenate((rho * (1.0 / D - 1.0), (1.0 + w) / (D * D)))

    return f


def _integrate(lam: float, rho_start: NDArray, s_from: float, s_to: float, rtol: float) -> tuple:
    """Integrate (rho, G) from sigma = s_from to s_to; returns (rho_end, |G gained|)."""
    if s_to == s_from:
        return rho_start.copy(), np.zeros_like(rho_start)
    y0 = np.concatenate((rho_start, np.zeros_like(rho_start)))
    sol = solve_ivp(_rhs(lam), (s_from, s_to), y0, method="DOP853", rtol=rtol, atol=rtol * 1e-3)
    if not sol.success:  # pragma: no cover - DOP853 on this smooth system does not fail
        raise RuntimeError(f"radial characteristics: {sol.message}")
    n = rho_start.size
    return sol.y[:n, -1], np.abs(sol.y[n:, -1])


def characteristics(
    lam: float,
    t_end: float | None = None,
    radius_end: float | None = None,
    n_paths: int = 1001,
    *,
    r0: ArrayLike | None = None,
    r_final: ArrayLike | None = None,
    R0: float = R0,
    rtol: float = 1e-10,
) -> Characteristics:
    """Material paths dr/dt = u(r, R(t)) with growth phase dG/dt = exp(-lam p(r, R(t))), G(0) = 0.

    Give exactly one of ``t_end`` and ``radius_end``. The paths are, in order of precedence:
    forward from the labels ``r0`` (radii at t = 0); backward from the final radii ``r_final``;
    by default backward from ``n_paths`` final radii equally spaced in [0, radius_end] (uniform
    resolution at the end time, where the rings are). The system integrated (in sigma = ln R,
    rho = r/R) is stated in the module docstring; ``rtol`` is DOP853's relative tolerance.
    """
    lam = _check_lam(lam)
    t_end, R_end = _end_state(lam, t_end, radius_end, R0)
    s0, s1 = math.log(R0), math.log(R_end)
    if r0 is not None:
        r0 = np.sort(np.asarray(r0, dtype=float).ravel())
        if np.any(r0 < 0) or np.any(r0 > R0):
            raise ValueError("labels r0 must lie in [0, R0]")
        rho, G = _integrate(lam, r0 / R0, s0, s1, rtol)
        return Characteristics(lam, t_end, R_end, r0, rho * R_end, G)
    if r_final is None:
        if int(n_paths) < 2:
            raise ValueError("n_paths must be >= 2")
        r_final = np.linspace(0.0, R_end, int(n_paths))
    r_final = np.asarray(r_final, dtype=float).ravel()
    if np.any(r_final < 0) or np.any(r_final > R_end * (1 + 1e-12)):
        raise ValueError(f"final radii must lie in [0, R = {R_end:g}]")
    order = np.argsort(r_final)
    rf = r_final[order]
    rho, G = _integrate(lam, np.minimum(rf / R_end, 1.0), s1, s0, rtol)
    return Characteristics(lam, t_end, R_end, rho * R0, rf, G)


def growth_phase(
    lam: float,
    r_eval: ArrayLike,
    t: float | None = None,
    radius: float | None = None,
    *,
    R0: float = R0,
    rtol: float = 1e-10,
) -> NDArray:
    """Growth phase G(r, t) = int_0^t g dt along the material path ending at radius r at time t.

    Each point is integrated backward along its own characteristic (no interpolation); the
    result has the shape of ``r_eval``. Give exactly one of ``t`` and ``radius``.
    """
    r_eval = np.asarray(r_eval, dtype=float)
    ch = characteristics(lam, t, radius, r_final=r_eval.ravel(), R0=R0, rtol=rtol)
    G = np.empty(r_eval.size)
    G[np.argsort(r_eval.ravel())] = ch.G
    return G.reshape(r_eval.shape)


def mean_length_profile(
    lam: float,
    r_eval: ArrayLike,
    t: float | None = None,
    radius: float | None = None,
    *,
    R0: float = R0,
    rtol: float = 1e-10,
    phase0: float = 0.0,
) -> NDArray:
    """Mean length lbar(r, t) = 2^frac(G(r, t) / ln 2 + phase0) at radii r_eval.

    phase0 = 0: initial delta(l - 1); phase0 = log2 l_init for delta(l - l_init) (e.g. the centre
    ``width`` of :func:`continuum.sizes.bump_profile`). G (smooth in r) is computed
    exactly along each point's characteristic; lbar (discontinuous at the rings) only afterwards.
    """
    G = growth_phase(lam, r_eval, t, radius, R0=R0, rtol=rtol)
    return mean_length_from_phase(G, phase0)


def ring_radii(
    lam: float,
    t: float | None = None,
    radius: float | None = None,
    *,
    n_grid: int = 2001,
    R0: float = R0,
    rtol: float = 1e-10,
    with_index: bool = False,
    phase0: float = 0.0,
) -> NDArray | tuple[NDArray, NDArray]:
    """Radii of the rings at time t (or disc radius ``radius``): where G(r, t) = k ln 2, k integer.

    More generally where G / ln 2 + phase0 = k (initial delta(l - 2^phase0), see
    :func:`mean_length_profile`).

    There lbar = 2^frac(G/ln 2) jumps between 2 and 1. G is tabulated backward along ``n_grid``
    characteristics equally spaced in final radius, the crossings of a cubic spline of G(r) give
    first guesses, and each is refined by Newton steps on the exactly integrated G (spline
    derivative) until ``|G - k ln 2| <= 1e-11``. lam = 0 gives G = t uniformly: no rings (empty
    array).

    Parameters
    ----------
    lam : float
        Stress sensitivity lambda of the growth law g = exp(-lam p).
    t : float, optional
        Time of the rings.
    radius : float, optional
        Disc radius R of the rings instead of t (exactly one of ``t`` and ``radius``).
    n_grid : int
        Number of characteristics on which G is tabulated.
    R0 : float
        Disc radius at t = 0.
    rtol : float
        Relative tolerance of the integration of the characteristics.
    with_index : bool
        Return the integers k as well.
    phase0 : float
        Initial phase: the rings are where G / ln 2 + phase0 is an integer k.

    Returns
    -------
    radii : ndarray
        The ring radii r_k, in increasing order.
    k : ndarray of int
        With ``with_index`` only: the integer k of each ring.
    """
    lam = _check_lam(lam)
    t_end, R_end = _end_state(lam, t, radius, R0)
    ch = characteristics(lam, t_end, None, n_grid, R0=R0, rtol=rtol)
    empty = (np.empty(0), np.empty(0, dtype=int))
    if np.ptp(ch.G) < 1e-12 * max(1.0, np.max(np.abs(ch.G))):
        return empty if with_index else empty[0]
    spline = CubicSpline(ch.r, ch.G)
    off = float(phase0) * LN2
    ks = np.arange(math.ceil((ch.G.min() + off) / LN2), math.floor((ch.G.max() + off) / LN2) + 1)
    roots, kk = [], []
    for k in ks:
        rts = spline.solve(k * LN2 - off, extrapolate=False)
        rts = rts[(rts > 0) & (rts < R_end)]
        roots.extend(rts)
        kk.extend([k] * rts.size)
    r = np.asarray(roots, dtype=float)
    k = np.asarray(kk, dtype=int)
    if r.size == 0:
        return empty if with_index else empty[0]
    dG = spline(r, 1)
    for _ in range(20):
        res = growth_phase(lam, r, t_end, R0=R0, rtol=rtol) + off - k * LN2
        if np.all(np.abs(res) <= 1e-11):
            break
        r = np.clip(r - res / dG, 0.0, R_end)
    order = np.argsort(r)
    return (r[order], k[order]) if with_index else r[order]
