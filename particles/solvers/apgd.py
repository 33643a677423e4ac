"""Per-step contact problem by Jacobi-scaled APGD with adaptive restart, in Numba.

Same problem, residual and stopping test as bbpgd.py (BBPGD), so the two are
interchangeable (``Config.solver``).  One time step is the convex problem over the
contact forces gamma >= 0 (model.md, with the exact exponential length increment of
problem.py)::

    minimise  E(gamma),   grad E(gamma) = q(gamma) = Phi + dt D^T M D gamma - G^T dl(G gamma),
    dl_n(sigma) = l_n (exp(dt exp(-lam sigma_n)) - 1),

q the linearised gap at t + dt.  Stop when ::

    res = max_k |min(a_kk gamma_k, q_k)| <= tol,   a_kk = dt (D^T M D)_kk   (a length).

Method: accelerated projected gradient (APGD, Mazhar, Heyn, Negrut & Tasora, ACM TOG 2015;
Nesterov's scheme for a bound-constrained convex problem) in the Jacobi metric P = diag(1/a_kk)::

    x_{k+1} = max(0, y_k - t P q(y_k)),
    theta_{k+1} = theta_k (sqrt(theta_k^2 + 4) - theta_k) / 2,
    beta_k = theta_k (1 - theta_k) / (theta_k^2 + theta_{k+1}),
    y_{k+1} = x_{k+1} + beta_k (x_{k+1} - x_k),

with the gradient adaptive restart of O'Donoghue & Candes (2015): when
q(y_k) . (x_{k+1} - x_k) > 0 the momentum is dropped (theta = 1, y = x).  The diagonal metric
keeps the projection onto gamma >= 0 exact.

Step t = 1/L with L an upper bound of the largest eigenvalue of the scaled Hessian
P^(1/2) (dt D^T M D + G^T C G) P^(1/2), C = diag(c_max), c_max,n = l_n lam dt exp(dt) the
largest curvature of the growth term over sigma >= 0 (so L holds for every gamma >= 0): L is
estimated by power iteration and enlarged by ``lipschitz_margin``.  Safeguards against an
underestimate: every iteration compares the curvature of E between the last two points,
``(q(y_k) - q(y_{k-1})) . (y_k - y_{k-1}) / |y_k - y_{k-1}|^2_{P^-1}``, a lower bound of L, with
1/t; if it exceeds 1/t the step is shortened to 1 / (1.1 curvature) and the momentum dropped; a
residual 1e3 times its best value halves t and returns to the best iterate.

Accelerated methods need O(sqrt(kappa)) iterations where steepest descent needs O(kappa); with
kappa of the scaled contact operator growing like N (a discrete pressure Poisson problem at
large N), APGD iterations grow like N^(1/2) at best.  One gradient evaluation per iteration,
as BBPGD: the residual is tested at the extrapolated point y_k, whose gradient the step needs
anyway, and y_k is accepted only when it is feasible (y_k >= 0; else its projection
max(0, y_k) is tested, at the price of one extra gradient).

Measured (docs/measurements/contact_solvers.py, 2026-11-22, 2-core machine shared, load 1.5-4;
jammed states: ring packings grown by the engine for t = 0.2, N = 1.2e3, 1.1e4, 1.0e5, cold
start): iterations BBPGD / APGD at tol 1e-4: 281 / 329, 3019 / 1367, 9582 / 4182 (fitted
N^0.80 / N^0.58); at tol 5e-4 (the engine's default b/1000): 152 / 232, 878 / 602, 2420 / 3612;
at tol 1e-3: 112 / 143, 452 / 574, 1425 / 2682.  So APGD pays for tight tolerances only; at
loose ones BBPGD's non-monotone steps happen to land inside the tolerance sooner.  Engine
run lam = 1e-2 to radius 55 (N ~ 1.27e4, default tolerances): 276k / 323k iterations in total
(APGD / BBPGD), 100 s / 109 s, same radial stress profile within 3%.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..geometry import Contacts
from ..growth import largest_increment_slope
from .problem import _gradient as gap_kernel  # q(gam) = Phi + dt D^T M D gam - G^T dl
from .problem import _residual as residual  # max_k |min(a_kk gam_k, q_k)|
from .problem import finish, incidence, particle_sums, prepare, problem_arrays, residual_term


@njit(cache=True)
def hessian_apply(v, start, idx, coef, ci, cj, nx, ny, ti, tj, gi, gj, mt, mr, cmax, dt, pw, out):
    """Hessian product: out = (dt D^T M D + G^T diag(cmax) G) v (pw: (N, 4) work array)."""
    n = mt.shape[0]
    particle_sums(v, start, idx, coef, ci, cj, nx, ny, ti, tj, gi, gj, pw)
    for p in range(n):
        pw[p, 0] *= dt * mt[p]
        pw[p, 1] *= dt * mt[p]
        pw[p, 2] *= dt * mr[p]
        pw[p, 3] *= cmax[p]
    for k in range(v.shape[0]):
        i = ci[k]
        j = cj[k]
        out[k] = (nx[k] * (pw[j, 0] - pw[i, 0]) + ny[k] * (pw[j, 1] - pw[i, 1]) + pw[j, 2] * tj[k]
                  - pw[i, 2] * ti[k] + gi[k] * pw[i, 3] + gj[k] * pw[j, 3])


@njit(cache=True)
def lipschitz_kernel(start, idx, coef, ci, cj, nx, ny, ti, tj, gi, gj, mt, mr, cmax, dt, akk,
                     iters, seed, min_iters, rtol):
    """Power iteration for the largest eigenvalue of P^(1/2) H P^(1/2), P = diag(1/a_kk).

    At most ``iters`` products; stops after ``min_iters`` once the Rayleigh quotient (which
    increases monotonically towards lambda_max) grows by less than ``rtol`` relatively.
    """
    m = ci.shape[0]
    n = mt.shape[0]
    v = np.empty(m)
    for k in range(m):
        # deterministic start with components along every eigenvector (almost surely)
        v[k] = 1.0 + 0.5 * np.sin(1.0 + k * 0.7548776662 + seed)
    w = np.empty(m)
    u = np.empty(m)
    pw = np.empty((n, 4))
    sq = np.sqrt(akk)
    est = 0.0
    for it in range(iters):
        nv = np.sqrt(np.sum(v * v))
        for k in range(m):
            v[k] /= nv
            u[k] = v[k] / sq[k]
        hessian_apply(u, start, idx, coef, ci, cj, nx, ny, ti, tj, gi, gj, mt, mr, cmax, dt,
                      pw, w)
        prev = est
        est = 0.0
        for k in range(m):
            w[k] /= sq[k]
            est += w[k] * v[k]
        v[:] = w
        if it >= min_iters and est - prev <= rtol * est:
            break
    return est


@njit(cache=True)
def apgd_kernel(gam, start, idx, coef, ci, cj, nx, ny, ti, tj, gi, gj, phi, mt, mr, length, dt, law,
                growth, akk, step, tol, maxiter, hist):
    """APGD iterations in place on gam (module docstring); one gradient per iteration.

    Iteration k evaluates q(y_k) once; it serves the residual test of y_k (accepted when
    y_k >= 0 and res(y_k) <= tol, so the returned forces are feasible and their residual is
    exact; when res(y_k) <= tol but y_k has negative entries, max(0, y_k) is tested with one
    extra gradient), the curvature safeguard, the projected step and the restart test.  Returns the
    number of iterations when res <= tol, -1 after maxiter iterations.  hist[k] is res(y_k)
    (hist[0]: initial guess).  On return gam holds the accepted iterate (success) or the best
    one recorded (failure; recorded when the residual drops by 10%).
    """
    n = mt.shape[0]
    m = gam.shape[0]
    pw = np.empty((n, 4))
    x0 = np.empty(m)
    x1 = np.empty(m)
    y = np.empty(m)
    qy = np.empty(m)
    yp = np.empty(m)
    qp = np.empty(m)
    best = np.empty(m)
    for k in range(m):
        v = gam[k] if gam[k] > 0.0 else 0.0
        x0[k] = v
        y[k] = v
        best[k] = v
    best_res = np.inf
    theta = 1.0
    t = step
    for it in range(0, maxiter + 1):
        gap_kernel(y, start, idx, coef,
                   ci, cj, nx, ny, ti, tj, gi, gj, phi, mt, mr, length, dt, law,
                   growth, pw, qy)
        # one pass: residual, feasibility, curvature (q(y) - q(yp)).(y - yp) / |y - yp|_P^-1
        res = 0.0
        feasible = True
        num = 0.0
        den = 0.0
        for k in range(m):
            res = max(res, residual_term(qy[k], akk[k] * y[k]))
            if y[k] < 0.0:
                feasible = False
            if it > 0:
                d = y[k] - yp[k]
                num += (qy[k] - qp[k]) * d
                den += akk[k] * d * d
        if not feasible and res <= tol:
            # y passes the test but has negative entries: test its projection max(0, y)
            # instead (one extra gradient, only in the final phase)
            for k in range(m):
                x1[k] = y[k] if y[k] > 0.0 else 0.0
            gap_kernel(x1, start, idx, coef,
                       ci, cj, nx, ny, ti, tj, gi, gj, phi, mt, mr, length, dt, law,
                       growth, pw, qp)
            rp = residual(x1, qp, akk)
            if rp <= tol:
                hist[it] = rp
                gam[:] = x1
                return it
            num = 0.0
            den = 0.0  # qp was overwritten: skip this iteration's curvature test
        hist[it] = res
        if feasible:
            if res <= tol:
                gam[:] = y
                return it
            if res < 0.9 * best_res:
                best_res = res
                best[:] = y
        if it == maxiter:
            break
        if res > 1e3 * best_res:
            # runaway although the curvature test passed: halve the step, back to the best
            t *= 0.5
            x0[:] = best
            y[:] = best
            theta = 1.0
            continue
        restart = False
        if den > 0.0 and num * t > den * (1.0 + 1e-9):
            # the curvature bounds L from below: the step is provably too long
            t = den / (1.1 * num)
            restart = True
        # projected step from y in the Jacobi metric; gradient restart q(y).(x1 - x0) > 0
        dot = 0.0
        for k in range(m):
            v = y[k] - t * qy[k] / akk[k]
            v = v if v > 0.0 else 0.0
            dot += qy[k] * (v - x0[k])
            x1[k] = v
        yp, y = y, yp
        qp, qy = qy, qp
        if dot > 0.0 or restart:
            theta = 1.0
            y[:] = x1
        else:
            th1 = 0.5 * theta * (np.sqrt(theta * theta + 4.0) - theta)
            beta = theta * (1.0 - theta) / (theta * theta + th1)
            theta = th1
            for k in range(m):
                y[k] = x1[k] + beta * (x1[k] - x0[k])
        x0, x1 = x1, x0
    gam[:] = best
    return -1


def lipschitz_bound(c: Contacts, length: np.ndarray, dt: float, law: np.ndarray,
                    growth: bool = True, iters: int = 30, seed: int = 12345, min_iters: int = 8,
                    rtol: float = 1e-3) -> float:
    """Power-iteration estimate of lambda_max(P^(1/2) (dt D^T M D + G^T C G) P^(1/2)).

    P = diag(1/a_kk), C = diag(l_n lam_n a_n dt exp(a_n dt)) (0 without growth; ``law``:
    problem.law_rows, rows (lam_n, a_n dt, .)): the largest curvature
    of the Jacobi-scaled E over gamma >= 0.  At most ``iters`` Hessian products, fewer once
    the estimate grows by less than ``rtol`` (relative) after ``min_iters``.
    """
    length = np.ascontiguousarray(length, dtype=np.float64)
    mt, mr, ti, tj, akk = problem_arrays(c, length, dt)
    cmax = (largest_increment_slope(length, law[:, 0], law[:, 1]) if growth
            else np.zeros_like(length))
    start, idx, coef = incidence(c, ti, tj, length.shape[0])
    return float(lipschitz_kernel(start, idx, coef, c.i, c.j, c.nx, c.ny, ti, tj, c.gi, c.gj,
                                  mt, mr, cmax, float(dt), akk, int(iters), int(seed),
                                  int(min_iters), float(rtol)))


def solve_contacts_apgd(
    contacts: Contacts,
    length: np.ndarray,
    dt: float,
    lam: float,
    gamma0: np.ndarray | None = None,
    tol: float = 1e-4,
    maxiter: int = 100_000,
    growth: bool = True,
    *,
    rate=1.0,
    lipschitz_margin: float = 1.1,
    power_iterations: int = 30,
) -> tuple[np.ndarray, np.ndarray]:
    """Minimise E(gamma) over gamma >= 0 by Jacobi-scaled APGD with adaptive restart.

    Parameters, results and errors as :func:`particles.solvers.bbpgd.solve_contacts` (the same
    problem, residual and stopping test), and:

    Parameters
    ----------
    lipschitz_margin : float
        Step t = 1 / (margin * power-iteration estimate of L), margin >= 1 (ValueError
        otherwise).
    power_iterations : int
        Power iterations for L, at least 1.
    """
    if not lipschitz_margin >= 1.0 or power_iterations < 1:
        raise ValueError("lipschitz_margin must be >= 1 and power_iterations >= 1")
    length, gam, (mt, mr, ti, tj, akk), law = prepare(contacts, length, dt, lam, gamma0, rate)
    n, m, c = length.shape[0], len(contacts), contacts
    if m == 0:
        return gam, np.zeros(1)
    lip = lipschitz_bound(c, length, dt, law, growth, power_iterations)
    step = 1.0 / (lipschitz_margin * lip)
    hist = np.full(maxiter + 1, np.nan)
    start, idx, coef = incidence(c, ti, tj, n)
    it = apgd_kernel(gam, start, idx, coef, c.i, c.j, c.nx, c.ny, ti, tj, c.gi, c.gj, c.gap, mt, mr,
                     length, float(dt), law, bool(growth), akk, step, float(tol),
                     int(maxiter), hist)
    return finish("APGD", gam, hist, it, tol, n)
