"""Contact geometry of sphero-cylinders: closest points, gaps, normals, arms, G coefficients.

Particle n has centre x_n, axis p_n = (cos theta_n, sin theta_n), tip-to-tip length l_n and
inner segment of length L_n = l_n - b.  For a candidate pair (i, j), i < j, the four
endpoint-to-segment distances are computed (in 2D the segment distance is always attained at
an endpoint of one of the two segments, unless they cross).  Up to two of them are kept as
contacts: the closest, and the next closest whose contact points differ from it by more than
b/4 on either rod (so near-parallel rods get one contact at each end, and the end-to-end
contact found from both sides is kept once).  Each contact k carries

- gap ``phi_k = |c_j - c_i| - b``, c the contact points on the two segments;
- normal ``n_k = (c_j - c_i) / |c_j - c_i|`` (from i to j; force gamma_k pushes j along +n_k);
- arms r_i = c_i - x_i, r_j = c_j - x_j (torque arms);
- growth coefficients G_ik = -d phi_k / d l_i = (s_i / L_i) p_i . n_k and
  G_jk = -d phi_k / d l_j = -(s_j / L_j) p_j . n_k, where s is the arc position of the contact
  point from the centre (the point moves by s/L per unit growth).  At a true closest point this is
  model.md's ``G = |s| |p . n| / L``: ``(1/2) |p . n|`` at a segment end, 0 at an interior
  point.  The signed form (the exact derivative of each constraint) differs from ``|.|`` only
  for the second contact of a pair; measured on a 3000-particle colony (lam = 1e-2) those negative
  entries carry 1e-4 of the total load;
- code in 0..3 naming the endpoint that generated it (i+, i-, j+, j-): with the particle ids it
  is the contact identity used to warm-start the solver.

Crossing segments (distance 0, which the overlap tolerance rules out in a run) are reported
with gap -b.

From contact forces gamma >= 0 this module gives the generalised forces F = D gamma
(:func:`generalised_forces`); the axial stress sigma = G gamma, the load that slows growth
(growth.py), is stress.axial_stress.  ``B`` is the particle diameter b of the whole package.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import njit, prange

from .neighbours import candidate_pairs

B = 0.5
"""Particle diameter b (model.md units l0 = tau = xi = 1, b = 1/2); the package's one definition."""


@njit(cache=True)
def point_segment(px, py, cx, cy, ux, uy, half):
    """Closest point of the segment c + t u, ``|t| <= half``, to the point (px, py).

    Returns (qx, qy, t) with t the arc position of the closest point from the centre c.
    """
    t = (px - cx) * ux + (py - cy) * uy
    if t > half:
        t = half
    elif t < -half:
        t = -half
    return cx + t * ux, cy + t * uy, t


@njit(cache=True)
def _orient(ax, ay, bx, by, cx, cy):
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@njit(cache=True)
def segments_cross(ax, ay, bx, by, cx, cy, dx, dy):
    """True when the open segments [a, b] and [c, d] properly intersect."""
    o1 = _orient(ax, ay, bx, by, cx, cy)
    o2 = _orient(ax, ay, bx, by, dx, dy)
    o3 = _orient(cx, cy, dx, dy, ax, ay)
    o4 = _orient(cx, cy, dx, dy, bx, by)
    return (o1 * o2 < 0.0) and (o3 * o4 < 0.0)


@njit(cache=True)
def segment_distance(x, y, theta, length, i, j, b):
    """Exact distance between the inner segments of particles i and j."""
    Li = length[i] - b
    Lj = length[j] - b
    ui = np.cos(theta[i])
    vi = np.sin(theta[i])
    uj = np.cos(theta[j])
    vj = np.sin(theta[j])
    ax = x[i] + 0.5 * Li * ui
    ay = y[i] + 0.5 * Li * vi
    bx = x[i] - 0.5 * Li * ui
    by = y[i] - 0.5 * Li * vi
    cx = x[j] + 0.5 * Lj * uj
    cy = y[j] + 0.5 * Lj * vj
    dx = x[j] - 0.5 * Lj * uj
    dy = y[j] - 0.5 * Lj * vj
    if segments_cross(ax, ay, bx, by, cx, cy, dx, dy):
        return 0.0
    best = 1e300
    for e in range(4):
        if e == 0:
            px, py = ax, ay
        elif e == 1:
            px, py = bx, by
        elif e == 2:
            px, py = cx, cy
        else:
            px, py = dx, dy
        if e < 2:
            qx, qy, _ = point_segment(px, py, x[j], y[j], uj, vj, 0.5 * Lj)
        else:
            qx, qy, _ = point_segment(px, py, x[i], y[i], ui, vi, 0.5 * Li)
        d = np.hypot(px - qx, py - qy)
        if d < best:
            best = d
    return best


@njit(cache=True)
def _pair_candidates_uv(x, y, length, i, j, b, ui, vi, uj, vj, out):
    """Fill out[4, 11] with the four endpoint-to-segment candidates of the pair (i, j).

    (ui, vi), (uj, vj): the axes of the two rods. Columns: gap, nx, ny, cix, ciy, cjx, cjy,
    s_i, s_j, code, d.
    """
    Li = length[i] - b
    Lj = length[j] - b
    for e in range(4):
        if e < 2:
            sgn = 1.0 if e == 0 else -1.0
            si = sgn * 0.5 * Li
            cix = x[i] + si * ui
            ciy = y[i] + si * vi
            cjx, cjy, sj = point_segment(cix, ciy, x[j], y[j], uj, vj, 0.5 * Lj)
        else:
            sgn = 1.0 if e == 2 else -1.0
            sj = sgn * 0.5 * Lj
            cjx = x[j] + sj * uj
            cjy = y[j] + sj * vj
            cix, ciy, si = point_segment(cjx, cjy, x[i], y[i], ui, vi, 0.5 * Li)
        dx = cjx - cix
        dy = cjy - ciy
        d = np.hypot(dx, dy)
        if d > 0.0:
            nx = dx / d
            ny = dy / d
        else:
            # degenerate: an endpoint on the other segment; push along that segment's normal
            if e < 2:
                nx, ny = -vj, uj
            else:
                nx, ny = vi, -ui
        out[e, 0] = d - b
        out[e, 1] = nx
        out[e, 2] = ny
        out[e, 3] = cix
        out[e, 4] = ciy
        out[e, 5] = cjx
        out[e, 6] = cjy
        out[e, 7] = si
        out[e, 8] = sj
        out[e, 9] = e
        out[e, 10] = d
    # crossing segments: distance 0, overlap b
    if segments_cross(
        x[i] + 0.5 * Li * ui, y[i] + 0.5 * Li * vi, x[i] - 0.5 * Li * ui, y[i] - 0.5 * Li * vi,
        x[j] + 0.5 * Lj * uj, y[j] + 0.5 * Lj * vj, x[j] - 0.5 * Lj * uj, y[j] - 0.5 * Lj * vj,
    ):
        for e in range(4):
            out[e, 0] = -b


@njit(inline="always")
def _sort4(g0, g1, g2, g3):
    """The order (i0, i1, i2, i3) of four gaps, ascending, ties in index order.

    The insertion sort of four items (an element moves left past strictly larger ones), in
    scalars.
    """
    a0, a1, a2, a3 = 0, 1, 2, 3
    v0, v1, v2, v3 = g0, g1, g2, g3
    if v1 < v0:
        a0, a1, v0, v1 = a1, a0, v1, v0
    if v2 < v1:
        a1, a2, v1, v2 = a2, a1, v2, v1
        if v1 < v0:
            a0, a1, v0, v1 = a1, a0, v1, v0
    if v3 < v2:
        a2, a3, v2, v3 = a3, a2, v3, v2
        if v2 < v1:
            a1, a2, v1, v2 = a2, a1, v2, v1
            if v1 < v0:
                a0, a1, v0, v1 = a1, a0, v1, v0
    return a0, a1, a2, a3


@njit(inline="always")
def _nth(a, i0, i1, i2, i3):
    """The a-th of (i0, i1, i2, i3)."""
    if a == 0:
        return i0
    if a == 1:
        return i1
    if a == 2:
        return i2
    return i3


SAME_GAP = 1e-10
"""Two endpoint candidates of a pair whose gaps differ by at most this (and whose contact
points are within b/4 on both rods) are one end-to-end contact found from both ends."""


@njit(cache=True)
def _pair_contacts(x, y, theta, length, i, j, b, margin, low_first, cand, res, ires, slot):
    """The (at most two) contacts of the pair (i, j) written to rows slot, slot + 1.

    Each rod's axis is computed once.  res rows: gap, nx, ny, rix, riy, rjx,
    rjy, gi, gj; ires rows: i, j, code.  Returns how many were written (module docstring: the
    closest endpoint candidate within ``margin``, and the next one whose contact points differ
    from it by more than b/4).  An end-to-end contact is found from both rods' ends with gaps
    equal but for round-off (SAME_GAP); it is reported as found from particle i's end if
    ``low_first`` (i has the lower id), else from j's, so that its identity (code) does not
    depend on the particles' order in memory.
    """
    ui = np.cos(theta[i])
    vi = np.sin(theta[i])
    uj = np.cos(theta[j])
    vj = np.sin(theta[j])
    _pair_candidates_uv(x, y, length, i, j, b, ui, vi, uj, vj, cand)
    # order the four candidates by gap (the insertion sort of _sort4; no array is allocated
    # per pair, which on many threads would contend for Numba's allocator)
    i0, i1, i2, i3 = _sort4(cand[0, 0], cand[1, 0], cand[2, 0], cand[3, 0])
    first = i0
    if cand[first, 0] > margin:
        return 0
    dup = 0.25 * b
    for a in range(1, 4):  # the same contact found from the other rod's end: the canonical side
        e = _nth(a, i0, i1, i2, i3)
        if cand[e, 0] > margin:
            break
        if ((e < 2) == low_first and (first < 2) != low_first
                and abs(cand[e, 0] - cand[first, 0]) <= SAME_GAP
                and np.hypot(cand[e, 3] - cand[first, 3], cand[e, 4] - cand[first, 4]) <= dup
                and np.hypot(cand[e, 5] - cand[first, 5], cand[e, 6] - cand[first, 6]) <= dup):
            first = e
            break
    chosen1 = -1
    for a in range(4):
        e = _nth(a, i0, i1, i2, i3)
        if cand[e, 0] > margin:
            break
        if e == first:
            continue
        dci = np.hypot(cand[e, 3] - cand[first, 3], cand[e, 4] - cand[first, 4])
        dcj = np.hypot(cand[e, 5] - cand[first, 5], cand[e, 6] - cand[first, 6])
        if dci > dup or dcj > dup:
            chosen1 = e
            break
    m = 0
    for w in range(2):
        e = first if w == 0 else chosen1
        if e < 0:
            continue
        Li = length[i] - b
        Lj = length[j] - b
        nx = cand[e, 1]
        ny = cand[e, 2]
        pin = ui * nx + vi * ny
        pjn = uj * nx + vj * ny
        r = slot + m
        ires[r, 0] = i
        ires[r, 1] = j
        ires[r, 2] = e
        res[r, 0] = cand[e, 0]
        res[r, 1] = nx
        res[r, 2] = ny
        res[r, 3] = cand[e, 3] - x[i]
        res[r, 4] = cand[e, 4] - y[i]
        res[r, 5] = cand[e, 5] - x[j]
        res[r, 6] = cand[e, 6] - y[j]
        res[r, 7] = cand[e, 7] / Li * pin
        res[r, 8] = -cand[e, 8] / Lj * pjn
        m += 1
    return m


PAIR_BLOCK = 2048
"""Candidate pairs per parallel task of the contact search."""


@njit(cache=True, parallel=True)
def _contacts_kernel(x, y, theta, length, ids, pi, pj, b, margin):
    """Contacts of the candidate pairs (pi, pj), in pair order: (ires (3, m), res (9, m)).

    Two passes over the pairs, each in tasks of PAIR_BLOCK pairs in parallel: the first counts
    each pair's contacts, the second (after the counts' prefix sums) computes those of the
    pairs that have any again and writes them to their columns of the result.  So the result
    is the same for any number of threads, and no work array of two rows per pair is written
    (at 1e5 particles 115 MB, whose first touch costs more than the second pass); the columns
    of the result are the rows of ``ires`` and ``res``.
    """
    npairs = pi.shape[0]
    nblocks = (npairs + PAIR_BLOCK - 1) // PAIR_BLOCK
    count = np.zeros(npairs + 1, dtype=np.int64)
    for blk in prange(nblocks):
        cand = np.empty((4, 11))
        work = np.empty((2, 9))
        iwork = np.empty((2, 3), dtype=np.int64)
        for q in range(blk * PAIR_BLOCK, min(npairs, (blk + 1) * PAIR_BLOCK)):
            i = pi[q]
            j = pj[q]
            count[q + 1] = _pair_contacts(x, y, theta, length, i, j, b, margin, ids[i] < ids[j],
                                          cand, work, iwork, 0)
    for q in range(npairs):
        count[q + 1] += count[q]
    m = count[npairs]
    res = np.empty((9, m))
    ires = np.empty((3, m), dtype=np.int64)
    for blk in prange(nblocks):
        cand = np.empty((4, 11))
        work = np.empty((2, 9))
        iwork = np.empty((2, 3), dtype=np.int64)
        for q in range(blk * PAIR_BLOCK, min(npairs, (blk + 1) * PAIR_BLOCK)):
            if count[q + 1] == count[q]:
                continue
            i = pi[q]
            j = pj[q]
            got = _pair_contacts(x, y, theta, length, i, j, b, margin, ids[i] < ids[j], cand,
                                 work, iwork, 0)
            for w in range(got):
                k = count[q] + w
                for c in range(9):
                    res[c, k] = work[w, c]
                for c in range(3):
                    ires[c, k] = iwork[w, c]
    return ires, res


@njit(cache=True, parallel=True)
def _short_in_pairs(length, pi, pj, b):
    """Whether a particle of a pair (pi, pj) has length <= b (pairs in parallel)."""
    short = 0
    for q in prange(pi.shape[0]):
        if length[pi[q]] <= b or length[pj[q]] <= b:
            short += 1
    return short > 0


class Contacts:
    """Contacts of a configuration as flat arrays (one entry per contact k).

    Attributes
    ----------
    i, j : int64 arrays
        Particle indices, i < j; gamma_k pushes j along +n_k and i along -n_k.
    code : int64 array
        Generating endpoint (0: i+, 1: i-, 2: j+, 3: j-).
    gap : array
        phi_k = segment distance - b (negative: overlap).
    nx, ny : arrays
        Unit normal n_k from i to j.
    rix, riy, rjx, rjy : arrays
        Arms from the centres to the contact points.
    gi, gj : arrays
        Growth coefficients G_ik = -d phi_k / d l_i and G_jk = -d phi_k / d l_j (the entries
        of G in sigma = G gamma).
    """

    __slots__ = ("i", "j", "code", "gap", "nx", "ny", "rix", "riy", "rjx", "rjy", "gi", "gj")

    def __init__(self, ires: np.ndarray, res: np.ndarray):
        """Contacts from the rows of ``ires`` (3, m) and ``res`` (9, m).

        ``ires``: i, j, code; ``res``: gap, nx, ny, rix, riy, rjx, rjy, gi, gj (rows of
        C-contiguous arrays, so each attribute is a contiguous view).
        """
        self.i, self.j, self.code = ires
        (self.gap, self.nx, self.ny, self.rix, self.riy, self.rjx, self.rjy, self.gi,
         self.gj) = res

    def __len__(self) -> int:
        return int(self.i.shape[0])

    def keys(self, ids: np.ndarray) -> np.ndarray:
        """Contact identities (:func:`canonical_keys` of (id_i, id_j, code); ids < 2**29).

        Computed contact by contact in parallel (:func:`_canonical_keys_of`): integers, the
        same for any number of threads.
        """
        return _canonical_keys_of(self.i, self.j, self.code,
                                  np.ascontiguousarray(ids, dtype=np.int64))


@njit(cache=True, parallel=True)
def _canonical_keys_of(ci, cj, code, ids):
    """:func:`canonical_keys` of ids[ci] * 2**31 + ids[cj] * 4 + code, contact by contact."""
    out = np.empty(ci.shape[0], dtype=np.int64)
    for k in prange(ci.shape[0]):
        a = ids[ci[k]]
        b = ids[cj[k]]
        if a > b:
            out[k] = (b << 31) | (a << 2) | (code[k] ^ 2)
        else:
            out[k] = a * (1 << 31) + b * 4 + code[k]
    return out


def canonical_keys(keys: np.ndarray) -> np.ndarray:
    """Contact identities a * 2**31 + b * 4 + code written with the lower id first.

    ``a``, ``b`` are the pair's ids, ``code`` its generating endpoint (0: a+, 1: a-, 2: b+,
    3: b-); when a > b the pair is written (b, a) and the code seen from it (code ^ 2: a+ <->
    b+, a- <-> b-).  So a contact keeps its identity when the particles are reordered in
    memory (division.divide_in_order), and keys saved by earlier versions (index order) read
    the same.
    """
    keys = np.asarray(keys, dtype=np.int64)
    a = keys >> 31
    b = (keys >> 2) & ((1 << 29) - 1)
    code = keys & 3
    return np.where(a > b, (b << 31) | (a << 2) | (code ^ 2), keys)


def find_contacts(
    x: np.ndarray,
    y: np.ndarray,
    theta: np.ndarray,
    length: np.ndarray,
    pairs: tuple[np.ndarray, np.ndarray],
    margin: float,
    b: float = B,
    ids: np.ndarray | None = None,
) -> Contacts:
    """Contacts with gap phi_k <= margin among candidate pairs (see module docstring).

    ``ids``: the particles' ids (default their indices), which decide the side an end-to-end
    contact is reported from (:func:`_pair_contacts`).
    """
    pi, pj = pairs
    pi = np.ascontiguousarray(pi, dtype=np.int64)
    pj = np.ascontiguousarray(pj, dtype=np.int64)
    length = np.ascontiguousarray(length, dtype=np.float64)
    if pi.size and _short_in_pairs(length, pi, pj, b):
        raise ValueError("every particle length must exceed the diameter b")
    return Contacts(*_contacts_kernel(np.ascontiguousarray(x, dtype=np.float64),
                                      np.ascontiguousarray(y, dtype=np.float64),
                                      np.ascontiguousarray(theta, dtype=np.float64),
                                      length,
                                      np.arange(len(x)) if ids is None
                                      else np.ascontiguousarray(ids, dtype=np.int64),
                                      pi, pj, b, margin))


def detect_contacts(x: np.ndarray, y: np.ndarray, theta: np.ndarray, length: np.ndarray,
                    margin: float) -> Contacts:
    """Contacts with gap phi_k <= margin: candidate pairs by cell lists, then :func:`find_contacts`.

    Parameters
    ----------
    x, y, theta, length : arrays (N,)
        Centres, angles and tip-to-tip lengths l_n > b.
    margin : float
        Largest gap phi_k kept.
    """
    pairs = candidate_pairs(x, y, length, margin)
    return find_contacts(x, y, theta, length, pairs, margin)


CSR_CHUNKS = 16
"""Fixed chunks of contacts of :func:`by_particle` (its tasks; not the number of threads)."""


@njit(cache=True, parallel=True)
def by_particle(ci, cj, n):
    """The contacts of each particle (CSR): idx[start[p]:start[p + 1]], increasing k.

    Contact k is listed under ci[k] and under cj[k].  A counting sort in CSR_CHUNKS fixed
    chunks of the contacts, in parallel: each chunk counts its particles, the counts are
    turned into offsets particle by particle (chunk order), and each chunk then writes its
    contacts in increasing k.  Integers only, so the lists are the same for any number of
    threads (those of problem.incidence, which builds them serially).
    """
    m = ci.shape[0]
    size = (m + CSR_CHUNKS - 1) // CSR_CHUNKS
    cnt = np.zeros((CSR_CHUNKS, n), dtype=np.int64)
    for c in prange(CSR_CHUNKS):
        for k in range(c * size, min(m, (c + 1) * size)):
            cnt[c, ci[k]] += 1
            cnt[c, cj[k]] += 1
    total = np.empty(n, dtype=np.int64)
    for p in prange(n):
        run = 0
        for c in range(CSR_CHUNKS):
            t = cnt[c, p]
            cnt[c, p] = run
            run += t
        total[p] = run
    start = np.zeros(n + 1, dtype=np.int64)
    for p in range(n):
        start[p + 1] = start[p] + total[p]
    idx = np.empty(2 * m, dtype=np.int64)
    for c in prange(CSR_CHUNKS):
        for k in range(c * size, min(m, (c + 1) * size)):
            for p in (ci[k], cj[k]):
                idx[start[p] + cnt[c, p]] = k
                cnt[c, p] += 1
    return start, idx


@njit(cache=True, parallel=True)
def _forces(start, idx, ci, gamma, nx, ny, ti, tj, n):
    """(fx, fy, tz) of :func:`generalised_forces` from the lists of :func:`by_particle`.

    Particle by particle in parallel; each sum adds its contacts in increasing k from 0 (as j,
    then as i), the additions of np.bincount, so the bits are those of the NumPy formula.
    """
    fx = np.empty(n)
    fy = np.empty(n)
    tz = np.empty(n)
    for p in prange(n):
        jx = 0.0
        jy = 0.0
        jt = 0.0
        ix = 0.0
        iy = 0.0
        it = 0.0
        for e in range(start[p], start[p + 1]):
            k = idx[e]
            g = gamma[k]
            if ci[k] == p:
                ix += g * nx[k]
                iy += g * ny[k]
                it += g * ti[k]
            else:
                jx += g * nx[k]
                jy += g * ny[k]
                jt += g * tj[k]
        fx[p] = jx - ix
        fy[p] = jy - iy
        tz[p] = jt - it
    return fx, fy, tz


def generalised_forces(c: Contacts, gamma: np.ndarray, n: int,
                       threads: int | None = None) -> tuple[np.ndarray, ...]:
    """Total contact force and torque on each particle: F = D gamma.

    F_j += gamma_k n_k, T_j += gamma_k (r_j x n_k); F_i -= gamma_k n_k, T_i -= gamma_k (r_i x n_k).
    On one thread (``threads``, default numba.get_num_threads()) ``np.bincount(c.j, gamma *
    c.nx, n) - np.bincount(c.i, gamma * c.nx, n)`` (and so on); on more, the same sums (each
    particle's contacts as j and as i in increasing k, then subtracted: the same bits) in
    parallel by particle (:func:`by_particle`, :func:`_forces`), which on one thread takes 1.6x
    NumPy's time (1e5 particles).
    """
    tj = c.rjx * c.ny - c.rjy * c.nx
    ti = c.rix * c.ny - c.riy * c.nx
    if (numba.get_num_threads() if threads is None else threads) > 1:
        start, idx = by_particle(c.i, c.j, n)
        return _forces(start, idx, c.i, np.ascontiguousarray(gamma, dtype=np.float64), c.nx,
                       c.ny, ti, tj, n)
    fx = np.bincount(c.j, gamma * c.nx, n) - np.bincount(c.i, gamma * c.nx, n)
    fy = np.bincount(c.j, gamma * c.ny, n) - np.bincount(c.i, gamma * c.ny, n)
    tz = np.bincount(c.j, gamma * tj, n) - np.bincount(c.i, gamma * ti, n)
    return fx, fy, tz


def max_overlap(
    x: np.ndarray, y: np.ndarray, theta: np.ndarray, length: np.ndarray, b: float = B
) -> float:
    """Largest overlap b - (segment distance) over all pairs (0 when none overlap)."""
    pi, pj = candidate_pairs(x, y, length, 0.0)
    return float(_max_overlap_kernel(x, y, theta, length, pi, pj, b))


@njit(cache=True)
def _max_overlap_kernel(x, y, theta, length, pi, pj, b):
    worst = 0.0
    for q in range(pi.shape[0]):
        d = segment_distance(x, y, theta, length, pi[q], pj[q], b)
        if b - d > worst:
            worst = b - d
    return worst
