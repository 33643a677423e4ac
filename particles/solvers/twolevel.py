"""Per-step contact problem by a two-level method: BBPGD smoothing + coarse correction.

The coarse correction is a smooth multiplicative correction of the contact forces (issue 4).
Same problem, residual and stopping test as bbpgd.py (BBPGD, problem.py): minimise over
gamma >= 0 ::

    E(gamma) = gamma . Phi + (dt/2) gamma . (D^T M D) gamma + sum_n l_n H(sigma_n),
    sigma = G gamma,  grad E = q(gamma) (the linearised gap at t + dt),

and stop when ``res = max_k |min(a_kk gamma_k, q_k)| <= tol``.

Idea: at large N the stress behaves like a discretised pressure Poisson problem, so the error
left by projected-gradient iterations is smooth in space.  One cycle is

1. ``nu`` BBPGD iterations (the smoother; the BB step history restarts every cycle);
2. one coarse Newton step on c for  min_c E(gamma (1 + P c)),  P_kJ = phi_J(z_k) the
   bilinear hat functions of a coarse grid of spacing ``h`` evaluated at the contact points
   z_k::

       g_c = P^T (gamma * q),  H_c = A^T (dt D^T M D + G^T C G) A,  A = diag(gamma) P,
       C = diag(l_n lam r_n exp(r_n)),  r_n = dt exp(-lam sigma_n)

   (the growth term linearised at the current stress), c = -H_c^{-1} g_c by a sparse direct
   solve, gamma <- max(0, gamma + A c).  Multiplicative, so inactive contacts stay inactive and
   the correction acts only on the current load network.

Contact points need particle positions, which :class:`Contacts` does not carry: they are
rebuilt exactly (up to a translation per connected component) from the contact geometry by a
breadth-first walk, x_j - x_i = (phi_k + b) n_k + r_i - r_j; hat functions are put on the
largest connected component only (the rest are left to the smoother).

Measured: see cases/bench/contact_solvers.py (``python -m cases.bench.contact_solvers``).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit
from scipy.sparse.linalg import splu

from ..geometry import B, Contacts
from ..growth import growth_rate
from .bbpgd import bb_smooth
from .problem import finish, incidence, prepare

NAME = "twolevel"
"""Name under which the engine may register this solver (Config.solver)."""


@njit(cache=True)
def _walk(indptr, nbr, edge, sign, dx, dy, n):
    """Breadth-first positions: x_nb = x_p + sign * d_edge; component label per particle."""
    px = np.zeros(n)
    py = np.zeros(n)
    comp = -np.ones(n, dtype=np.int64)
    queue = np.empty(n, dtype=np.int64)
    nc = 0
    for s in range(n):
        if comp[s] >= 0:
            continue
        comp[s] = nc
        head = 0
        tail = 1
        queue[0] = s
        while head < tail:
            p = queue[head]
            head += 1
            for q in range(indptr[p], indptr[p + 1]):
                o = nbr[q]
                if comp[o] < 0:
                    comp[o] = nc
                    k = edge[q]
                    px[o] = px[p] + sign[q] * dx[k]
                    py[o] = py[p] + sign[q] * dy[k]
                    queue[tail] = o
                    tail += 1
        nc += 1
    return px, py, comp


def contact_points(c: Contacts, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Contact points z_k (midpoints of the closest points) and a mask of the largest component.

    Particle centres are rebuilt from the contacts by a breadth-first walk using
    x_j - x_i = (phi_k + b) n_k + r_i - r_j, exact up to one translation per connected
    component of the contact graph.

    Returns
    -------
    zx, zy : arrays (K,)
    main : bool array (K,)
        True on contacts of the largest connected component.
    """
    dx = (c.gap + B) * c.nx + c.rix - c.rjx
    dy = (c.gap + B) * c.ny + c.riy - c.rjy
    m = len(c)
    src = np.concatenate([c.i, c.j])
    nbr = np.concatenate([c.j, c.i])
    sign = np.concatenate([np.ones(m), -np.ones(m)])
    edge = np.concatenate([np.arange(m), np.arange(m)])
    order = np.argsort(src, kind="stable")
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(src, minlength=n), out=indptr[1:])
    px, py, comp = _walk(indptr, nbr[order], edge[order], sign[order], dx, dy, n)
    zx = px[c.i] + c.rix + 0.5 * (c.gap + B) * c.nx
    zy = py[c.i] + c.riy + 0.5 * (c.gap + B) * c.ny
    big = np.argmax(np.bincount(comp[c.i]))
    return zx, zy, comp[c.i] == big


def hat_prolongation(zx: np.ndarray, zy: np.ndarray, mask: np.ndarray, h: float) -> sp.csr_matrix:
    """Coarse prolongation P_kJ = phi_J(z_k): bilinear hat functions of a square grid.

    The grid has spacing h and covers the masked points (rows of unmasked contacts are zero;
    nodes without support are dropped).
    """
    if not h > 0:
        raise ValueError(f"coarse spacing h must be positive, got {h}")
    m = zx.shape[0]
    k = np.flatnonzero(mask)
    x0, y0 = zx[k].min(), zy[k].min()
    nx = int(np.floor((zx[k].max() - x0) / h)) + 2
    u = (zx[k] - x0) / h
    v = (zy[k] - y0) / h
    iu = np.minimum(np.floor(u).astype(np.int64), nx - 2)
    iv = np.floor(v).astype(np.int64)
    fu, fv = u - iu, v - iv
    rows = np.tile(k, 4)
    cols = np.concatenate([iv * nx + iu, iv * nx + iu + 1, (iv + 1) * nx + iu,
                           (iv + 1) * nx + iu + 1])
    vals = np.concatenate([(1 - fu) * (1 - fv), fu * (1 - fv), (1 - fu) * fv, fu * fv])
    used, cols = np.unique(cols, return_inverse=True)
    return sp.csr_matrix((vals, (rows, cols)), shape=(m, used.shape[0]))


def contact_operators(c: Contacts, length: np.ndarray, dt: float):
    """Sparse S = (dt M)^(1/2) D (3N x K) and G (N x K): dt D^T M D = S^T S."""
    n, m = length.shape[0], len(c)
    st = np.sqrt(dt / length)
    sr = np.sqrt(12.0 * dt / length**3)
    ti = c.rix * c.ny - c.riy * c.nx
    tj = c.rjx * c.ny - c.rjy * c.nx
    rows = np.concatenate([3 * c.j, 3 * c.j + 1, 3 * c.j + 2, 3 * c.i, 3 * c.i + 1, 3 * c.i + 2])
    vals = np.concatenate([st[c.j] * c.nx, st[c.j] * c.ny, sr[c.j] * tj,
                           -st[c.i] * c.nx, -st[c.i] * c.ny, -sr[c.i] * ti])
    s = sp.csr_matrix((vals, (rows, np.tile(np.arange(m), 6))), shape=(3 * n, m))
    g = sp.csr_matrix((np.concatenate([c.gi, c.gj]),
                       (np.concatenate([c.i, c.j]), np.tile(np.arange(m), 2))), shape=(n, m))
    return s, g


def coarse_correction(gam, q, p, s, g, length, law, growth):
    """Corrected forces max(0, gamma + A c), c = -H_c^{-1} P^T (gamma q) (module docstring)."""
    a = sp.diags(gam) @ p
    sa = (s @ a).tocsc()
    ga = (g @ a).tocsc()
    hc = sa.T @ sa
    if growth and law[:, 0].max() > 0:  # law: problem.law_rows, rows (lam_n, a_n dt, .)
        sig = g @ gam
        r = law[:, 1] * growth_rate.py_func(law[:, 0], sig)  # NumPy (growth.growth_rate)
        hc = hc + ga.T @ sp.diags(length * law[:, 0] * r * np.exp(r)) @ ga
    gc = a.T @ q
    d = hc.diagonal()
    act = np.flatnonzero(d > 0)
    if act.size == 0:
        return gam
    hc = hc[act][:, act].tocsc()
    hc = hc + sp.identity(act.size, format="csc") * (1e-12 * d[act].max())
    cc = np.zeros(p.shape[1])
    cc[act] = -splu(hc).solve(gc[act])
    return np.maximum(0.0, gam + a @ cc)


def solve_contacts_twolevel(
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
    smoothing: int = 200,
    coarse_h: float = 4.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Minimise E(gamma) over gamma >= 0 by BBPGD smoothing + multiplicative coarse correction.

    Same signature, problem, residual and stopping test as
    :func:`particles.solvers.bbpgd.solve_contacts`; ``maxiter`` counts smoothing iterations.
    The BB step carries over a coarse correction (it is not reset).

    Parameters
    ----------
    smoothing : int
        BBPGD iterations between coarse corrections (nu >= 1).
    coarse_h : float
        Coarse grid spacing (length units; l0 = 1).

    Returns
    -------
    gamma : array (K,)
    residuals : array
        Residual of the initial guess, then after every smoothing iteration and every coarse
        step: len - 1 gradient evaluations in all.

    Raises
    ------
    ValueError
        Bad dt, lam, gamma0 shape, smoothing or coarse_h.
    ContactSolveError
        When maxiter smoothing iterations do not reach tol.
    """
    if smoothing < 1:
        raise ValueError(f"smoothing must be >= 1, got {smoothing}")
    length, gam, (mt, mr, ti, tj, akk), law = prepare(contacts, length, dt, lam, gamma0, rate)
    n, m, c = length.shape[0], len(contacts), contacts
    if m == 0:
        return gam, np.zeros(1)
    np.maximum(gam, 0.0, out=gam)
    zx, zy, main = contact_points(c, n)
    p = hat_prolongation(zx, zy, main, coarse_h)
    s, g = contact_operators(c, length, dt)
    args = (*incidence(c, ti, tj, n), c.i, c.j, c.nx, c.ny, ti, tj, c.gi, c.gj, c.gap, mt, mr,
            length, float(dt), law, bool(growth), akk, float(tol))
    q = np.empty(m)
    buf = np.full(smoothing + 1, np.nan)
    hist = []
    alpha, parity, done = 0.0, 0, 0
    while done < maxiter:
        nu = min(smoothing, maxiter - done)
        it, alpha, parity = bb_smooth(gam, *args, nu, alpha, parity, buf, q)
        hist.append(buf[: (it if it >= 0 else nu) + 1].copy())
        if it >= 0:
            return gam, np.concatenate(hist)
        done += nu
        gam = coarse_correction(gam, q, p, s, g, length, law, growth)
    return finish("two-level", gam, np.concatenate(hist), -1, tol, n)
