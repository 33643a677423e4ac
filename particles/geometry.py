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
def _pair_candidates(x, y, theta, length, i, j, b, out):
    """Fill out[4, 11] with the four endpoint-to-segment candidates of the pair (i, j).

    Columns: gap, nx, ny, cix, ciy, cjx, cjy, s_i, s_j, code, d.
    """
    Li = length[i] - b
    Lj = length[j] - b
    ui = np.cos(theta[i])
    vi = np.sin(theta[i])
    uj = np.cos(theta[j])
    vj = np.sin(theta[j])
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


SAME_GAP = 1e-10
"""Two endpoint candidates of a pair whose gaps differ by at most this (and whose contact
points are within b/4 on both rods) are one end-to-end contact found from both ends."""


@njit(cache=True)
def _pair_contacts(x, y, theta, length, i, j, b, margin, low_first, cand, res, ires, slot):
    """The (at most two) contacts of the pair (i, j) written to rows slot, slot + 1.

    res rows: gap, nx, ny, rix, riy, rjx, rjy, gi, gj; ires rows: i, j, code.  Returns how
    many were written (module docstring: the closest endpoint candidate within ``margin``, and
    the next one whose contact points differ from it by more than b/4).  An end-to-end contact
    is found from both rods' ends with gaps equal but for round-off (SAME_GAP); it is reported
    as found from particle i's end if ``low_first`` (i has the lower id), else from j's, so
    that its identity (code) does not depend on the particles' order in memory.
    """
    _pair_candidates(x, y, theta, length, i, j, b, cand)
    # order the four candidates by gap (insertion sort on 4 items)
    idx = np.arange(4)
    for a in range(1, 4):
        k = a
        while k > 0 and cand[idx[k], 0] < cand[idx[k - 1], 0]:
            t = idx[k]
            idx[k] = idx[k - 1]
            idx[k - 1] = t
            k -= 1
    first = idx[0]
    if cand[first, 0] > margin:
        return 0
    dup = 0.25 * b
    for a in range(1, 4):  # the same contact found from the other rod's end: the canonical side
        e = idx[a]
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
        e = idx[a]
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
        pin = np.cos(theta[i]) * nx + np.sin(theta[i]) * ny
        pjn = np.cos(theta[j]) * nx + np.sin(theta[j]) * ny
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

    Each pair writes its contacts into its own two rows of a work array (tasks of PAIR_BLOCK
    pairs in parallel), which are then gathered in pair order, so the result is the same for
    any number of threads; the columns of the result are the rows of ``ires`` and ``res``.
    """
    npairs = pi.shape[0]
    work = np.empty((2 * npairs, 9))
    iwork = np.empty((2 * npairs, 3), dtype=np.int64)
    count = np.zeros(npairs + 1, dtype=np.int64)
    for blk in prange((npairs + PAIR_BLOCK - 1) // PAIR_BLOCK):
        cand = np.empty((4, 11))
        for q in range(blk * PAIR_BLOCK, min(npairs, (blk + 1) * PAIR_BLOCK)):
            i = pi[q]
            j = pj[q]
            count[q + 1] = _pair_contacts(x, y, theta, length, i, j, b, margin, ids[i] < ids[j],
                                          cand, work, iwork, 2 * q)
    for q in range(npairs):
        count[q + 1] += count[q]
    m = count[npairs]
    res = np.empty((9, m))
    ires = np.empty((3, m), dtype=np.int64)
    for q in prange(npairs):
        for w in range(count[q + 1] - count[q]):
            k = count[q] + w
            for c in range(9):
                res[c, k] = work[2 * q + w, c]
            for c in range(3):
                ires[c, k] = iwork[2 * q + w, c]
    return ires, res


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
        """Contact identities (:func:`canonical_keys` of (id_i, id_j, code); ids < 2**29)."""
        return canonical_keys((ids[self.i] * (1 << 31) + ids[self.j] * 4
                               + self.code).astype(np.int64))


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
    if pi.size and np.any(np.asarray(length)[np.concatenate([pi, pj])] <= b):
        raise ValueError("every particle length must exceed the diameter b")
    return Contacts(*_contacts_kernel(np.ascontiguousarray(x, dtype=np.float64),
                                      np.ascontiguousarray(y, dtype=np.float64),
                                      np.ascontiguousarray(theta, dtype=np.float64),
                                      np.ascontiguousarray(length, dtype=np.float64),
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


def contact_points(c: Contacts, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, ...]:
    """Contact points (cix, ciy, cjx, cjy) on the two segments."""
    return x[c.i] + c.rix, y[c.i] + c.riy, x[c.j] + c.rjx, y[c.j] + c.rjy


def generalised_forces(c: Contacts, gamma: np.ndarray, n: int) -> tuple[np.ndarray, ...]:
    """Total contact force and torque on each particle: F = D gamma.

    F_j += gamma_k n_k, T_j += gamma_k (r_j x n_k); F_i -= gamma_k n_k, T_i -= gamma_k (r_i x n_k).
    """
    fx = np.bincount(c.j, gamma * c.nx, n) - np.bincount(c.i, gamma * c.nx, n)
    fy = np.bincount(c.j, gamma * c.ny, n) - np.bincount(c.i, gamma * c.ny, n)
    tj = c.rjx * c.ny - c.rjy * c.nx
    ti = c.rix * c.ny - c.riy * c.nx
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
