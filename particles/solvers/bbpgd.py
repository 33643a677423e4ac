"""Contact solver: Barzilai-Borwein projected gradient descent (BBPGD), in Numba (the default).

Minimises E(gamma) over gamma >= 0, the per-step problem of problem.py, to the projected
residual ``max_k |min(a_kk gamma_k, grad_k)| <= tol`` (a gap).

Iteration (SimToolbox BCQPSolver::solveBBPGD): gamma <- max(0, gamma - alpha grad), alpha
alternating the two Barzilai-Borwein steps, first step ``1 / max |projected gradient|``.

Threads: the loops of an iteration run in parallel over contacts and particles (Numba prange,
``Config.threads``); D gamma and G gamma add in increasing contact order
(problem.particle_sums), and the sums of the BB step run over fixed blocks (BLOCK), so the
iterates do not depend on the number of threads.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..geometry import Contacts
from .problem import _gap, finish, incidence, magnitude, particle_moves, prepare, residual_term

BLOCK = 4096
"""Block length of the solver's sums: each block is summed in order, then the blocks in order,
so the sums, hence the iterates, are the same for any number of threads."""


@njit(cache=True, parallel=True)
def _bb_gradient(x1, gam, g0, g1, start, idx, coef, ci, cj, nx, ny, ti, tj, gi, gj, phi, mt, mr,
                 length, dt, law, growth, pw, akk, part):
    """One BBPGD gradient: g1 = q(x1), with the residual of x1 and the Barzilai-Borwein sums.

    Returns (res, s.s, s.y, y.y): res = ``max_k |min(a_kk x1_k, g1_k)|``, s = x1 - gam,
    y = g1 - g0; the sums taken by blocks of BLOCK (part: work array of shape (nblocks, 4)),
    in the same pass over the contacts as the gradient.
    """
    particle_moves(x1, start, idx, coef, ci, cj, nx, ny, ti, tj, gi, gj, mt, mr, length, dt, law,
                   growth, pw)
    m = x1.shape[0]
    nb = part.shape[0]
    for b in prange(nb):
        ss = 0.0
        sy = 0.0
        yy = 0.0
        r = 0.0
        for k in range(b * BLOCK, min(m, (b + 1) * BLOCK)):
            q = _gap(k, ci, cj, nx, ny, ti, tj, gi, gj, phi, dt, pw)
            g1[k] = q
            a = akk[k] * x1[k]
            r = max(r, residual_term(q, a))
            s = x1[k] - gam[k]
            y = q - g0[k]
            ss += s * s
            sy += s * y
            yy += y * y
        part[b, 0] = ss
        part[b, 1] = sy
        part[b, 2] = yy
        part[b, 3] = r
    ss = 0.0
    sy = 0.0
    yy = 0.0
    r = 0.0
    for b in range(nb):
        ss += part[b, 0]
        sy += part[b, 1]
        yy += part[b, 2]
        r = max(r, part[b, 3])
    return r, ss, sy, yy


@njit(cache=True, parallel=True)
def _projected_step(gam, g, alpha, out):
    """Projected step out = max(0, gam - alpha g); returns ``max_k |gam_k - out_k|``.

    With alpha = 1 that is the largest projected gradient.
    """
    r = 0.0
    for k in prange(gam.shape[0]):
        v = gam[k] - alpha * g[k]
        v = v if v > 0.0 else 0.0
        out[k] = v
        r = max(r, magnitude(gam[k] - v))
    return r


@njit(cache=True)
def bb_smooth(gam, start, idx, coef, ci, cj, nx, ny, ti, tj, gi, gj, phi, mt, mr, length, dt, law,
              growth, akk, tol, nu, alpha, parity, hist, qout):
    """At most nu BBPGD iterations in place on gam (this module's iteration).

    Starts from the step alpha (alpha <= 0: the first step ``1 / max |projected gradient|``)
    and the BB alternation ``parity``.  Returns (iterations, alpha, parity); iterations = -1
    when tol is not reached.  hist[it] = residual after iteration it (hist[0]: start);
    qout = q(gam) on return.  (start, idx, coef): problem.incidence of the contacts.
    An iteration is two passes over the contacts: the projected step and
    :func:`_bb_gradient`; the iterate and its gradient then swap buffers with the previous.
    """
    n = mt.shape[0]
    m = gam.shape[0]
    pw = np.empty((n, 4))
    g0 = np.empty(m)
    g1 = np.empty(m)
    x1 = np.empty(m)
    part = np.empty(((m + BLOCK - 1) // BLOCK, 4))
    args = (start, idx, coef, ci, cj, nx, ny, ti, tj, gi, gj, phi, mt, mr, length, dt, law, growth,
            pw, akk, part)
    res = _bb_gradient(gam, gam, g1, g0, *args)[0]
    hist[0] = res
    if res <= tol:
        qout[:] = g0
        return 0, alpha, parity
    if not (alpha > 0.0):
        alpha = 1.0 / _projected_step(gam, g0, 1.0, x1)
    x0 = gam
    done = -1
    for it in range(1, nu + 1):
        _projected_step(x0, g0, alpha, x1)
        res, ss, sy, yy = _bb_gradient(x1, x0, g0, g1, *args)
        hist[it] = res
        x0, x1 = x1, x0
        g0, g1 = g1, g0
        if res <= tol:
            done = it
            break
        parity = 1 - parity
        if parity == 0:
            a, bb = ss, sy
        else:
            a, bb = sy, yy
        if abs(bb) < 1e-300:
            bb = 1e-300
        alpha = a / bb
        if not (alpha > 0.0):
            alpha = 1.0 / max(1e-300, np.max(akk))
    gam[:] = x0  # x0 is gam's buffer or x1's, after an even or odd number of swaps
    qout[:] = g0
    return done, alpha, parity


@njit(cache=True)
def _bbpgd(gam, start, idx, coef, ci, cj, nx, ny, ti, tj, gi, gj, phi, mt, mr, length, dt, law,
           growth, akk, tol, maxiter, hist):
    """BBPGD from max(0, gam) to the residual tol.

    :func:`bb_smooth` without an iteration cap short of maxiter, first step
    ``1 / max |projected gradient|`` (Dai & Fletcher 2005).
    """
    for k in range(gam.shape[0]):
        if gam[k] < 0.0:
            gam[k] = 0.0
    it, _, _ = bb_smooth(gam, start, idx, coef, ci, cj, nx, ny, ti, tj, gi, gj, phi, mt, mr, length,
                         dt, law, growth, akk, tol, maxiter, 0.0, 0, hist,
                         np.empty(gam.shape[0]))
    return it


def solve_contacts(
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
) -> tuple[np.ndarray, np.ndarray]:
    """Minimise E(gamma) over gamma >= 0 by BBPGD (module docstring).

    Parameters
    ----------
    contacts : Contacts
        Geometry of the current configuration (gaps Phi, normals, arms, G).
    length : array (N,)
        Lengths l_n at the start of the step (mobility and growth rate).
    dt : float
        Time step.
    lam : float or array (N,)
        Stress sensitivity lambda >= 0, of every cell or of each (strains, particles.strains).
    gamma0 : array (K,), optional
        Warm start (projected onto gamma >= 0).
    tol : float
        Stop when the projected residual (a gap, see module docstring) is <= tol.
    maxiter : int
        Iteration cap (each iteration: one gradient evaluation).
    growth : bool
        False drops the growth term (pure overlap-removal problem for re-solve passes).
    rate : float or array (N,)
        Growth factor a > 0 of every cell or of each: growth rate a exp(-lam sigma).

    Returns
    -------
    gamma : array (K,)
    residuals : array
        Residual at each iteration (first entry: initial guess); len - 1 iterations.

    Raises
    ------
    ContactSolveError
        When maxiter iterations do not reach tol.
    """
    length, gam, (mt, mr, ti, tj, akk), law = prepare(contacts, length, dt, lam, gamma0, rate)
    n, m, c = length.shape[0], len(contacts), contacts
    if m == 0:
        return gam, np.zeros(1)
    hist = np.full(maxiter + 1, np.nan)
    start, idx, coef = incidence(c, ti, tj, n)
    it = _bbpgd(gam, start, idx, coef,
                c.i, c.j, c.nx, c.ny, ti, tj, c.gi, c.gj, c.gap, mt, mr, length,
                float(dt), law, bool(growth), akk, float(tol), int(maxiter), hist)
    return finish("BBPGD", gam, hist, it, tol, n)
