"""The per-step contact problem that every solver solves, and its Numba kernels.

One time step of model.md is the convex problem over the contact forces gamma >= 0 ::

    minimise  E(gamma) = gamma . Phi + (dt/2) gamma . (D^T M D) gamma + sum_n l_n H(sigma_n),
    sigma = G gamma,   H'(s) = -(exp(dt exp(-lam s)) - 1),

whose gradient is the linearised gap at t + dt::

    grad_k = Phi_k + dt (D^T M D gamma)_k - sum_n G_nk l_n (exp(dt exp(-lam sigma_n)) - 1).

M = diag(1/l_n, 1/l_n, 12/l_n^3) is the mobility (xi = 1), D the contact Jacobian, G the
growth-load matrix (geometry.py).  The growth term is the one of model.md with its rate
dt l_n exp(-lam sigma_n) replaced by the exact exponential length increment
l_n (exp(dt exp(-lam sigma_n)) - 1) that the step then applies (stepping.py;
growth.length_increment, growth.grow), so the solve predicts exactly the growth that happens;
the two agree to O(dt^2).  The term is convex for any lam >= 0 (its gradient is monotone in
gamma), and lam = 0 is its linear limit.  Growth is thus coupled to the stress inside the
solve, not lagged.

Every solver (bbpgd.py, apgd.py) stops when the projected residual ::

    res = max_k |min(a_kk gamma_k, grad_k)|,   a_kk = dt (D^T M D)_kk,

is <= tol.  Both arguments of the min are gaps (a_kk gamma_k is the gap opened by gamma_k alone),
so tol is a length: every linearised gap is >= -tol and every loaded contact closes to within tol.

Threads: the loops run in parallel over contacts and particles (Numba prange,
``Config.threads``).  D gamma and G gamma are gathered particle by particle on two or
more threads (:func:`gather`) and scattered contact by contact on one (:func:`scatter`); both
add in increasing contact order, so the sums do not depend on the number of threads.

This module: ``ContactSolveError``; the shared kernels (``particle_sums`` = D gamma and G gamma,
``particle_moves``, the gradient ``_gradient``, the residual ``_residual``); the checked inputs
of a solve (``prepare``, ``problem_arrays``) and its result (``finish``); ``linearised_gap``.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import njit, prange

from ..geometry import Contacts, by_particle
from ..growth import length_increment


class ContactSolveError(RuntimeError):
    """The contact solver did not converge.

    Attributes
    ----------
    n_particles : int
    n_contacts : int
    residuals : numpy.ndarray
        Projected residual at every iteration.
    """

    def __init__(self, message: str, n_particles: int, n_contacts: int, residuals: np.ndarray):
        super().__init__(message)
        self.n_particles = int(n_particles)
        self.n_contacts = int(n_contacts)
        self.residuals = np.asarray(residuals)


@njit(cache=True, parallel=True)
def _coefficients(start, idx, ci, nx, ny, ti, tj, gi, gj):
    """The coefficients of the incidence lists, particle by particle in parallel.

    Row e, contact k = idx[e] listed under particle p: (-n, -t_i, G_i) if p is its i, else
    (n, t_j, G_j).
    """
    coef = np.empty((idx.shape[0], 4))
    for p in prange(start.shape[0] - 1):
        for e in range(start[p], start[p + 1]):
            k = idx[e]
            if ci[k] == p:
                coef[e, 0] = -nx[k]
                coef[e, 1] = -ny[k]
                coef[e, 2] = -ti[k]
                coef[e, 3] = gi[k]
            else:
                coef[e, 0] = nx[k]
                coef[e, 1] = ny[k]
                coef[e, 2] = tj[k]
                coef[e, 3] = gj[k]
    return coef


def incidence(c: Contacts, ti: np.ndarray, tj: np.ndarray, n: int, threads: int | None = None):
    """Contacts by particle (CSR) with their coefficients, for :func:`particle_sums`.

    The incidence lists of the parallel gather: the contacts of particle p are
    idx[start[p]:start[p + 1]] in increasing order, and row e of coef holds the coefficients of
    gamma_idx[e] in p's force (x, y), torque and load, (-n, -t_i, G_i) on particle i and
    (n, t_j, G_j) on particle j: the columns of D and G, stored particle by particle.

    On one thread (``threads``, default numba.get_num_threads()) the lists are left empty and
    the kernels scatter contact by contact instead: serially that is faster (fewer bytes per
    iteration; README "Threads"), and it adds in the same order.
    """
    if (numba.get_num_threads() if threads is None else threads) == 1:
        return np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros((0, 4))
    start, idx = by_particle(c.i, c.j, n)
    return start, idx, _coefficients(start, idx, c.i, c.nx, c.ny, ti, tj, c.gi, c.gj)


@njit(cache=True)
def scatter(gam, ci, cj, nx, ny, ti, tj, gi, gj, pw):
    """Serial :func:`particle_sums`, contact by contact.

    Adds each contact's force, torque and load to its two particles, contacts in increasing
    order.
    """
    pw[:] = 0.0
    for k in range(gam.shape[0]):
        g = gam[k]
        if g == 0.0:
            continue
        i = ci[k]
        j = cj[k]
        pw[j, 0] += g * nx[k]
        pw[j, 1] += g * ny[k]
        pw[j, 2] += g * tj[k]
        pw[i, 0] -= g * nx[k]
        pw[i, 1] -= g * ny[k]
        pw[i, 2] -= g * ti[k]
        pw[i, 3] += gi[k] * g
        pw[j, 3] += gj[k] * g


@njit(cache=True, parallel=True)
def gather(gam, start, idx, coef, pw):
    """Parallel :func:`particle_sums`, particle by particle.

    Each particle sums its contacts from the incidence lists (:func:`incidence`) in
    increasing order, so no two threads write one entry and the
    sums equal those of :func:`scatter` bit for bit (x - y = x + (-y) exactly).
    """
    for p in prange(pw.shape[0]):
        gather_row(p, gam, start, idx, coef, pw)


@njit(inline="always")
def gather_row(p, gam, start, idx, coef, pw):
    """Row p of :func:`gather`: particle p's force, torque and load, its contacts in order."""
    fx = 0.0
    fy = 0.0
    tq = 0.0
    s = 0.0
    for e in range(start[p], start[p + 1]):
        g = gam[idx[e]]
        if g == 0.0:
            continue
        fx += g * coef[e, 0]
        fy += g * coef[e, 1]
        tq += g * coef[e, 2]
        s += coef[e, 3] * g
    pw[p, 0] = fx
    pw[p, 1] = fy
    pw[p, 2] = tq
    pw[p, 3] = s


@njit(cache=True)
def particle_sums(gam, start, idx, coef, ci, cj, nx, ny, ti, tj, gi, gj, pw):
    """Per-particle force, torque and load of contact forces gam: D gam and G gam.

    pw (N, 4), one row per particle (the two rows a contact reads share cache lines): columns
    (fx, fy, torque) = D gam and load = G gam; :func:`gather` when the incidence lists are
    given, else :func:`scatter`.
    """
    if idx.shape[0] > 0:
        gather(gam, start, idx, coef, pw)
    else:
        scatter(gam, ci, cj, nx, ny, ti, tj, gi, gj, pw)


@njit(cache=True)
def _law(lam, rate, dt):
    law = np.empty((lam.shape[0], 3))
    for q in range(lam.shape[0]):
        law[q, 0] = lam[q]
        law[q, 1] = rate[q] * dt
        law[q, 2] = np.expm1(law[q, 1])
    return law


def law_rows(lam, rate, dt: float, n: int) -> np.ndarray:
    """The growth law of a step as the kernels read it: rows (lam_n, a_n dt, exp(a_n dt) - 1).

    ``lam``, ``rate``: the cells' stress sensitivity lam_n and growth factor a_n
    (particles.strains), numbers (one row for every cell) or arrays (N,) (one row per cell).
    Made in Numba (its expm1), so one strain with a = 1 gives the rows' bits of dt and
    exp(dt) - 1 that the kernels computed before strains existed.
    """
    if np.ndim(lam) == 0 and np.ndim(rate) == 0:
        lam, rate = np.array([lam], dtype=np.float64), np.array([rate], dtype=np.float64)
    else:
        lam = np.broadcast_to(np.asarray(lam, dtype=np.float64), (n,)).copy()
        rate = np.broadcast_to(np.asarray(rate, dtype=np.float64), (n,)).copy()
    return _law(lam, rate, float(dt))


@njit(cache=True, parallel=True)
def particle_moves(gam, start, idx, coef, ci, cj, nx, ny, ti, tj, gi, gj, mt, mr, length, dt, law,
                   growth, pw):
    """The particles' velocities M D gam and length increments l (exp(a dt exp(-lam G gam)) - 1).

    Written into pw (N, 4): (vx, vy, omega, dl) per particle; dl = 0 without growth.  ``law``:
    :func:`law_rows`, one row for all or one per particle.  Where lam = 0 the increment
    l (exp(a dt) - 1) does not depend on gam (the same bits as the general formula, without two
    exponentials per particle and iteration).
    """
    particle_sums(gam, start, idx, coef, ci, cj, nx, ny, ti, tj, gi, gj, pw)
    if law.shape[0] == 1:
        lam, dtg, e0 = law[0, 0], law[0, 1], law[0, 2]
        for p in prange(pw.shape[0]):
            _move(p, mt, mr, length, growth, lam, dtg, e0, pw)
    else:
        for p in prange(pw.shape[0]):
            _move(p, mt, mr, length, growth, law[p, 0], law[p, 1], law[p, 2], pw)


@njit(inline="always")
def _move(p, mt, mr, length, growth, lam, dtg, e0, pw):
    """Particle p's row of :func:`particle_moves`: M times its sums, and its length increment."""
    pw[p, 0] *= mt[p]
    pw[p, 1] *= mt[p]
    pw[p, 2] *= mr[p]
    if not growth:
        pw[p, 3] = 0.0
    elif lam == 0.0:
        pw[p, 3] = length[p] * e0
    else:
        pw[p, 3] = length_increment(length[p], lam, pw[p, 3], dtg)


@njit(inline="always")
def _gap(k, ci, cj, nx, ny, ti, tj, gi, gj, phi, dt, pw):
    """q_k = Phi_k + dt (relative normal velocity) - (G_ik dl_i + G_jk dl_j), pw: particle_moves."""
    i = ci[k]
    j = cj[k]
    rel = (nx[k] * (pw[j, 0] - pw[i, 0]) + ny[k] * (pw[j, 1] - pw[i, 1]) + pw[j, 2] * tj[k]
           - pw[i, 2] * ti[k])
    return phi[k] + dt * rel - (gi[k] * pw[i, 3] + gj[k] * pw[j, 3])


@njit(cache=True, parallel=True)
def _gradient(gam, start, idx, coef, ci, cj, nx, ny, ti, tj, gi, gj, phi, mt, mr, length, dt, law,
              growth, pw, out):
    """Gradient q(gam): out = Phi + dt D^T M D gam - G^T (l (exp(a dt exp(-lam G gam)) - 1))."""
    particle_moves(gam, start, idx, coef, ci, cj, nx, ny, ti, tj, gi, gj, mt, mr, length, dt, law,
                   growth, pw)
    for k in prange(gam.shape[0]):
        out[k] = _gap(k, ci, cj, nx, ny, ti, tj, gi, gj, phi, dt, pw)


@njit(inline="always")
def magnitude(v):
    """``abs(v)`` for the solvers' maxima, NaN as inf: a NaN never passes ``res <= tol``.

    (max(r, NaN) is r, and max(0, NaN) in a projection is 0, so a NaN gap or iterate would
    otherwise look converged.)
    """
    a = abs(v)
    return a if a == a else np.inf


@njit(inline="always")
def residual_term(q, a):
    """Contact k's residual term ``abs(min(a, q))``, a = a_kk gam_k, q = grad_k; NaN as inf."""
    if q != q or a != a:
        return np.inf
    return abs(q if q < a else a)


@njit(cache=True, parallel=True)
def _residual(gam, grad, akk):
    """Residual ``max_k |min(a_kk gam_k, grad_k)|``, NaN as inf (:func:`residual_term`).

    A max: independent of the order, so of the threads.
    """
    r = 0.0
    for k in prange(gam.shape[0]):
        r = max(r, residual_term(grad[k], akk[k] * gam[k]))
    return r


def problem_arrays(c: Contacts, length: np.ndarray, dt: float):
    """Mobilities mt = 1/l, mr = 12/l^3, torque arms t = r x n and a_kk = dt (D^T M D)_kk."""
    mt = 1.0 / length
    mr = 12.0 / length**3
    ti = c.rix * c.ny - c.riy * c.nx
    tj = c.rjx * c.ny - c.rjy * c.nx
    akk = dt * (mt[c.i] + mt[c.j] + mr[c.i] * ti**2 + mr[c.j] * tj**2)
    return mt, mr, ti, tj, akk


def prepare(contacts: Contacts, length, dt: float, lam, gamma0, rate=1.0):
    """Checked inputs of a solve: (length as float64, starting gamma, problem_arrays, law).

    ``lam``, ``rate``: numbers, or per-particle arrays (strains); law: :func:`law_rows`.
    """
    if dt <= 0 or not np.isfinite(dt):
        raise ValueError(f"dt must be positive and finite, got {dt}")
    if np.any(np.asarray(lam) < 0) or not np.all(np.isfinite(lam)):
        raise ValueError(f"lam must be >= 0 and finite in the particle engine, got {lam}")
    if np.any(np.asarray(rate) <= 0) or not np.all(np.isfinite(rate)):
        raise ValueError(f"the growth factor must be > 0 and finite, got {rate}")
    length = np.ascontiguousarray(length, dtype=np.float64)
    m = len(contacts)
    gam = np.zeros(m) if gamma0 is None else np.array(gamma0, dtype=np.float64)
    if gam.shape != (m,):
        raise ValueError(f"gamma0 must have shape ({m},), got {gam.shape}")
    return length, gam, problem_arrays(contacts, length, dt), law_rows(lam, rate, dt,
                                                                          length.shape[0])


def finish(name: str, gam: np.ndarray, hist: np.ndarray, it: int, tol: float, n: int):
    """(gamma, residual history) of a solve that took ``it`` iterations; it < 0: failure."""
    if it < 0:
        m = gam.shape[0]
        raise ContactSolveError(
            f"{name} did not reach residual {tol:g} in {hist.shape[0] - 1} iterations "
            f"(N={n}, contacts={m}, last residual {hist[-1]:.3g})",
            n, m, hist,
        )
    return gam, hist[: it + 1].copy()


def linearised_gap(
    contacts: Contacts, length: np.ndarray, dt: float, lam, gamma: np.ndarray,
    growth: bool = True, rate=1.0,
) -> np.ndarray:
    """The gradient of E at gamma: the linearised gap phi_k(t + dt) (module docstring).

    ``lam``, ``rate``: numbers or per-particle arrays (:func:`law_rows`).
    """
    length = np.ascontiguousarray(length, dtype=np.float64)
    n = length.shape[0]
    c = contacts
    m = len(c)
    out = np.empty(m)
    mt, mr, ti, tj, _ = problem_arrays(c, length, dt)
    start, idx, coef = incidence(c, ti, tj, n)
    _gradient(np.ascontiguousarray(gamma, dtype=np.float64), start, idx, coef, c.i, c.j, c.nx, c.ny,
              ti, tj, c.gi, c.gj, c.gap, mt, mr, length, float(dt),
              law_rows(lam, rate, dt, n), bool(growth), np.empty((n, 4)), out)
    return out
