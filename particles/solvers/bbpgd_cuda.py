"""Contact solver: BBPGD on a CUDA GPU (``--solver bbpgd-cuda``; numba-cuda, the ``gpu`` extra).

The iteration of bbpgd.py, step for step, as plain kernels over the problem's arrays: the same
problem, starting step, Barzilai-Borwein alternation, safeguard and stopping test
``max_k |min(a_kk gamma_k, grad_k)| <= tol``.  The particle and contact arithmetic is the
CPU kernels' own (problem._move, problem._gap, growth.length_increment: Numba compiles them
for the device), so the two solvers differ only in the order of the Barzilai-Borwein sums and
in the device's rounding (fused multiply-adds, exp): the same iterates to round-off, not bit
for bit.  Contact detection, growth and division stay on the CPU; a solve copies its arrays to
the device (about 180 bytes per contact) and gamma back.

One iteration is four kernel launches:

1. :func:`_project`, per contact: x1 = max(0, x0 - alpha g0);
2. :func:`_moves`, per particle: D x1 and G x1 gathered in increasing contact order
   (problem.gather's order), times the mobility, and the length increment (problem._move);
3. :func:`_gradient`, per contact: g1 = q(x1) (problem._gap), and each block's partial sums
   s.s, s.y, y.y and max of the residual (s = x1 - x0, y = g1 - g0);
4. :func:`_update`, one block: the partials summed, residual recorded and tested, the next
   Barzilai-Borwein step.

Deterministic: every thread sums a fixed set of contacts in a fixed order and the blocks
reduce by a fixed tree (NBLOCKS x TPB threads, whatever the device), so a solve gives the
same bits every time.  The host reads the state once every CHECK iterations; after
convergence the remaining launches of a batch return at once.
"""

from __future__ import annotations

import math

import numpy as np
from numba import config, cuda, float64, types

from ..geometry import Contacts
from .problem import (
    _gap,
    _move,
    finish,
    gather_row,
    incidence,
    magnitude,
    prepare,
    residual_term,
)

TPB = 256
"""Threads per block of every kernel."""

NBLOCKS = 1024
"""Largest number of blocks of the contact kernels (a grid-stride loop covers the rest):
262,144 threads, as many as an H100/H200 keeps resident (132 SMs x 2048), so that the loads of
a solve at 3e5 contacts are all in flight at once."""

CHECK = 32
"""Iterations launched between two reads of the solver's state by the host."""

# the solver's scalar state on the device: scal[ALPHA], scal[PARITY], scal[DONE] (iteration
# that reached tol, -1 before), scal[AMAX] (max a_kk, the safeguard's step)
ALPHA, PARITY, DONE, AMAX = range(4)

if not config.ENABLE_CUDASIM:  # the simulator runs NumPy itself
    from numba.cuda.extending import overload

    @overload(np.exp, target="cuda")
    def _exp(x):
        """np.exp of a float on the device (the growth law's; numba-cuda lowers math.exp)."""
        if isinstance(x, types.Float):
            return lambda x: math.exp(x)

    @overload(np.expm1, target="cuda")
    def _expm1(x):
        """np.expm1 of a float on the device, as math.expm1."""
        if isinstance(x, types.Float):
            return lambda x: math.expm1(x)


# the CPU kernels' particle row and contact gap, compiled for the device from their Python
_gather_row = cuda.jit(device=True)(gather_row.py_func)
_move_row = cuda.jit(device=True)(_move.py_func)
_contact_gap = cuda.jit(device=True)(_gap.py_func)
_magnitude = cuda.jit(device=True)(magnitude.py_func)
_residual_term = cuda.jit(device=True)(residual_term.py_func)


@cuda.jit(device=True)
def _tree(sh, t, ss, sy, yy, r):
    """Block sums of (ss, sy, yy) and max of r over the threads, by a fixed tree.

    Thread t writes its values into column t of sh; the result is column 0.
    """
    sh[0, t] = ss
    sh[1, t] = sy
    sh[2, t] = yy
    sh[3, t] = r
    cuda.syncthreads()
    h = TPB // 2
    while h > 0:
        if t < h:
            sh[0, t] += sh[0, t + h]
            sh[1, t] += sh[1, t + h]
            sh[2, t] += sh[2, t + h]
            sh[3, t] = max(sh[3, t], sh[3, t + h])
        cuda.syncthreads()
        h //= 2


@cuda.jit(device=True)
def _block_out(sh, part):
    """Column 0 of sh (the block's reduction) into the block's row of part."""
    for c in range(4):
        part[cuda.blockIdx.x, c] = sh[c, 0]


@cuda.jit
def project(x0, g0, scal, x1):
    """x1 = max(0, x0 - alpha g0), alpha = scal[ALPHA]; nothing once scal[DONE] >= 0."""
    if scal[DONE] >= 0.0:
        return
    alpha = scal[ALPHA]
    for k in range(cuda.grid(1), x0.shape[0], cuda.gridsize(1)):
        v = x0[k] - alpha * g0[k]
        x1[k] = v if v > 0.0 else 0.0

@cuda.jit
def moves(gam, start, idx, coef, mt, mr, length, growth, law, scal, pw):
    """Row p of pw = (M D gam, dl) (problem.particle_moves), gathered in contact order."""
    if scal[DONE] >= 0.0:
        return
    p = cuda.grid(1)
    if p >= pw.shape[0]:
        return
    _gather_row(p, gam, start, idx, coef, pw)
    q = 0 if law.shape[0] == 1 else p
    _move_row(p, mt, mr, length, growth, law[q, 0], law[q, 1], law[q, 2], pw)

@cuda.jit
def gradient(x1, x0, g0, g1, ci, cj, nx, ny, ti, tj, gi, gj, phi, dt, pw, akk, scal, part):
    """g1 = q(x1); part[b] = block b's (s.s, s.y, y.y, residual max), s = x1 - x0."""
    if scal[DONE] >= 0.0:
        return
    sh = cuda.shared.array((4, TPB), dtype=float64)
    t = cuda.threadIdx.x
    ss = 0.0
    sy = 0.0
    yy = 0.0
    r = 0.0
    for k in range(cuda.grid(1), x1.shape[0], cuda.gridsize(1)):
        q = _contact_gap(k, ci, cj, nx, ny, ti, tj, gi, gj, phi, dt, pw)
        g1[k] = q
        a = akk[k] * x1[k]
        r = max(r, _residual_term(q, a))
        s = x1[k] - x0[k]
        y = q - g0[k]
        ss += s * s
        sy += s * y
        yy += y * y
    _tree(sh, t, ss, sy, yy, r)
    if t == 0:
        _block_out(sh, part)

@cuda.jit
def update(part, nb, it, tol, scal, hist):
    """Iteration it's residual into hist[it]; done, or the next Barzilai-Borwein step.

    it = 0: the start's residual only; it < 0: the first step from ``largest``'s partials.
    """
    if scal[DONE] >= 0.0:
        return
    sh = cuda.shared.array((4, TPB), dtype=float64)
    t = cuda.threadIdx.x
    ss = 0.0
    sy = 0.0
    yy = 0.0
    r = 0.0
    for b in range(t, nb, TPB):
        ss += part[b, 0]
        sy += part[b, 1]
        yy += part[b, 2]
        r = max(r, part[b, 3])
    _tree(sh, t, ss, sy, yy, r)
    if t != 0:
        return
    ss, sy, yy, r = sh[0, 0], sh[1, 0], sh[2, 0], sh[3, 0]
    if it < 0:  # the first step, 1 / max |projected gradient| (partials of ``largest``)
        scal[ALPHA] = 1.0 / r
        return
    hist[it] = r
    if r <= tol:
        scal[DONE] = it
        return
    if it == 0:
        return
    parity = 1.0 - scal[PARITY]
    scal[PARITY] = parity
    a, bb = (ss, sy) if parity == 0.0 else (sy, yy)
    if abs(bb) < 1e-300:
        bb = 1e-300
    alpha = a / bb
    if not (alpha > 0.0):
        alpha = 1.0 / max(1e-300, scal[AMAX])
    scal[ALPHA] = alpha

@cuda.jit
def largest(gam, g, part):
    """part[b, 3] = block b's max_k |gam_k - max(0, gam_k - g_k)| (the first step's)."""
    sh = cuda.shared.array((4, TPB), dtype=float64)
    t = cuda.threadIdx.x
    r = 0.0
    for k in range(cuda.grid(1), gam.shape[0], cuda.gridsize(1)):
        v = gam[k] - g[k]
        v = v if v > 0.0 else 0.0
        r = max(r, _magnitude(gam[k] - v))
    _tree(sh, t, 0.0, 0.0, 0.0, r)
    if t == 0:
        _block_out(sh, part)


def solve_contacts_cuda(
    contacts: Contacts,
    length: np.ndarray,
    dt: float,
    lam,
    gamma0: np.ndarray | None = None,
    tol: float = 1e-4,
    maxiter: int = 100_000,
    growth: bool = True,
    *,
    rate=1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Minimise E(gamma) over gamma >= 0 by BBPGD on the GPU (module docstring).

    Parameters and results as :func:`particles.solvers.bbpgd.solve_contacts`: gamma (K,) and
    the residual at each iteration (first entry: the initial guess).

    Raises
    ------
    ContactSolveError
        When maxiter iterations do not reach tol.
    """
    length, gam, (mt, mr, ti, tj, akk), law = prepare(contacts, length, dt, lam, gamma0, rate)
    n, m, c = length.shape[0], len(contacts), contacts
    if m == 0:
        return gam, np.zeros(1)
    np.maximum(gam, 0.0, out=gam)
    start, idx, coef = incidence(c, ti, tj, n, threads=2)  # the gather's lists, always
    dev = cuda.to_device
    x = [dev(gam), dev(np.zeros(m))]  # x[1], g[1] zeroed: the start's unused sums stay finite
    g = [dev(np.zeros(m)), dev(np.zeros(m))]
    pw = cuda.device_array((n, 4))
    args = (dev(start), dev(idx), dev(coef), dev(mt), dev(mr), dev(length), bool(growth),
            dev(law))
    gap_args = tuple(dev(np.ascontiguousarray(a)) for a in (c.i, c.j, c.nx, c.ny, ti, tj, c.gi,
                                                             c.gj, c.gap)) + (float(dt), pw,
                                                                              dev(akk))
    scal = dev(np.array([0.0, 0.0, -1.0, float(np.max(akk))]))
    hist = dev(np.full(maxiter + 1, np.nan))
    nb = min(NBLOCKS, (m + TPB - 1) // TPB)
    part = cuda.device_array((nb, 4))
    pgrid = ((n + TPB - 1) // TPB, TPB)

    def gradient_at(it):
        """g[it % 2] = q(x[it % 2]), the sums against x, g[(it - 1) % 2], then update."""
        a, b = it % 2, (it + 1) % 2
        moves[pgrid](x[a], *args, scal, pw)
        gradient[nb, TPB](x[a], x[b], g[b], g[a], *gap_args, scal, part)
        update[1, TPB](part, nb, it, float(tol), scal, hist)

    gradient_at(0)  # hist[0]
    done = int(scal.copy_to_host()[DONE])
    if done < 0:
        largest[nb, TPB](x[0], g[0], part)
        update[1, TPB](part, nb, -1, tol, scal, hist)
    last = 0
    while done < 0 and last < maxiter:
        for it in range(last + 1, min(maxiter, last + CHECK) + 1):
            project[nb, TPB](x[(it + 1) % 2], g[(it + 1) % 2], scal, x[it % 2])
            gradient_at(it)
        last = min(maxiter, last + CHECK)
        done = int(scal.copy_to_host()[DONE])
    gam = x[max(done, 0) % 2].copy_to_host()
    return finish("BBPGD (CUDA)", gam, hist.copy_to_host(), done, tol, n)
