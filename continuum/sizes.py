"""Cell-size distribution Psi(x, l, t) carried by the material (model.md, "Continuum model").

Per material element (one mesh node) the particles are counted by length l in [1, 2]. In
s = log2 l in [0, 1] with n(s) = Psi dl/ds (number per material element per unit s), the
l-equation d(Psi)/dt + d(l g Psi)/dl = 0 along a material path becomes a pure shift ::

    dn/dt + a dn/ds = 0,     a = g / ln 2 >= 0,

and the division condition (ldot Psi)(1) = 2 (ldot Psi)(2) becomes the twisted-periodic condition ::

    n(0, t) = 2 n(1, t)

(the flux a n leaving at s = 1 comes back doubled at s = 0: each dividing particle gives two).
Extending n by n(s + 1) = n(s)/2, the exact solution is a shift by the phase sigma = G / ln 2,
G = int g dt (see :func:`exact_shift`).

Moments (per material element): number N = int n ds, total length L = int l n ds = int 2^s n ds,
mean length lbar = L / N, spread of the lengths sqrt(Q / N - lbar^2) with Q = int 4^s n ds the
sum of the squared lengths (``length_std``). Exact identities of the continuous problem::

    dN/dt = a n(1, t),        dL/dt = g L   =>   L(t) = exp(G) L(0)  for every initial n,

(integrate by parts: -int 2^s d_s(a n) ds = -a [2^s n]_0^1 + ln 2 a L and 2 n(1) - n(0) = 0).
So the total length grows exactly like the local area stretch exp(G) (per current area [l] is
conserved: the packing), while N grows like exp(G) only for the stable profile n ~ 2^-s
(Psi ~ l^-2), which the shift maps to 2^(sigma - s); for other profiles N oscillates about it.

The transport (``Config.psi_transport = "characteristics-labels"``), along the characteristics
(:class:`CharacteristicSizes`): the characteristics are parallel in s, so each node's grid moves
with them: a phase offset per node and values on a fixed-width window of one octave; advancing
is an exact shift, a division an exact doubling of the values that cross s = 1; a remesh
interpolates the rows by label (class docstring). The model's delta Psi0 is carried exactly by
its position instead (:class:`DeltaSizes`). Two transports measured against it were removed
(REMOVED_TRANSPORTS; their measurements are in docs/validation.md).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from continuum.growth import LN2

LN4 = 2.0 * LN2
"""ln 4: int 4^s ds = 4^s / ln 4."""

__all__ = [
    "LengthGrid",
    "CharacteristicSizes",
    "DeltaSizes",
    "INITIAL_SIZES",
    "TRANSPORTS",
    "REMOVED_TRANSPORTS",
    "bump_profile",
    "exact_shift",
    "split_phase",
    "spread",
]

INITIAL_SIZES = ("delta", "bump", "histogram")
"""Psi0 of a run (``Config.initial_sizes``): the model's delta(l - 1) carried exactly by its
position (:class:`DeltaSizes`, the default), the smooth bump of ``bump_width`` on the l grid
(:func:`bump_profile`), or a histogram on the l
grid given with the state (continuum.initial.state_from, e.g. the particle hand-off)."""

TRANSPORTS = ("characteristics-labels",)
"""Transports of Psi (``Config.psi_transport``): :class:`CharacteristicSizes`, remeshed by
labels."""

REMOVED_TRANSPORTS = {
    "characteristics": "it remapped the cells in s at a remesh and smeared across rings (median "
                       "error of the mean length 0.030 at radius 150); last in commit a216238",
    "finite-volume": "flux-limited Lax-Wendroff, error 1.8e-4 at 256 cells where the default's "
                     "is 8e-7; last in commit a216238",
}
"""Transports measured against the default and removed (docs/validation.md), with why."""


class LengthGrid:
    """Uniform finite-volume grid in s = log2 l on [0, 1] (l in [1, 2]).

    Attributes
    ----------
    n_cells : int
    edges : ndarray (n_cells + 1,)
        Cell edges s_{i-1/2}.
    centres : ndarray (n_cells,)
    ds : float
    lengths : ndarray (n_cells,)
        l at the cell centres, 2^s_i.
    length_integrals : ndarray (n_cells,)
        Exact cell integrals int_cell l ds = (2^s_{i+1/2} - 2^s_{i-1/2}) / ln 2, so that
        L = sum_i n_i * length_integrals_i is exact for piecewise-constant n.
    """

    def __init__(self, n_cells: int):
        if int(n_cells) != n_cells or n_cells < 4:
            raise ValueError(f"n_cells must be an integer >= 4, got {n_cells}")
        self.n_cells = int(n_cells)
        self.edges = np.linspace(0.0, 1.0, self.n_cells + 1)
        self.centres = 0.5 * (self.edges[1:] + self.edges[:-1])
        self.ds = 1.0 / self.n_cells
        self.lengths = 2.0**self.centres
        self.length_integrals = np.diff(2.0**self.edges) / LN2

    def __repr__(self) -> str:
        return f"LengthGrid(n_cells={self.n_cells})"

    def cell_averages(self, f: Callable[[NDArray], NDArray], n_quad: int = 8) -> NDArray:
        """Cell averages (1/ds) int_cell f(s) ds by n_quad-point Gauss-Legendre quadrature."""
        x, w = np.polynomial.legendre.leggauss(int(n_quad))
        s = self.edges[:-1, None] + 0.5 * self.ds * (x[None, :] + 1.0)
        vals = np.asarray(f(s), dtype=float)
        if vals.shape != s.shape:
            raise ValueError("f must map an array of s to an array of the same shape")
        return 0.5 * vals @ w


def _check_speed(g: ArrayLike, n_nodes: int) -> NDArray:
    g = np.asarray(g, dtype=float)
    if g.ndim == 0:
        g = np.full(n_nodes, float(g))
    if g.shape != (n_nodes,):
        raise ValueError(f"g must be a scalar or have shape ({n_nodes},), got {g.shape}")
    if not np.all(np.isfinite(g)) or np.any(g < 0):
        raise ValueError("growth rates g must be finite and >= 0")
    return g


def bump_profile(grid: LengthGrid, width: float = 0.08, number: float = 1.0) -> NDArray:
    """Cell values of a narrow smooth bump standing in for Psi0 = number * delta(l - 1).

    n0(s) = C exp(-1 / (1 - x^2)) for ``|x| < 1``, x = (s - width) / width: a C-infinity bump of
    half-width ``width`` in s centred at s = width, so its support (0, 2 width) lies inside
    (0, 1) (all lengths in (1, 2^(2 width)); mean length ~ 2^width). The cell averages
    (16-point Gauss-Legendre) are scaled so that the discrete number sum n ds equals
    ``number``. Its mean length follows the delta limit 2^frac(G/ln 2) to within the bump's
    spread, i.e. a factor 2^(+-2 width).
    """
    if not 0.0 < width < 0.5:
        raise ValueError(f"bump width must be in (0, 0.5), got {width}")
    if width < 2.0 * grid.ds:
        raise ValueError(f"bump width {width} is below two cells (2 ds = {2 * grid.ds})")

    def f(s):
        x = (s - width) / width
        inside = np.abs(x) < 1.0
        return np.where(inside, np.exp(-1.0 / np.where(inside, 1.0 - x * x, 1.0)), 0.0)

    row = grid.cell_averages(f, 16)
    return row * (number / (row.sum() * grid.ds))


def exact_shift(f0: Callable[[NDArray], NDArray], shift: float) -> Callable[[NDArray], NDArray]:
    """Exact solution n(s, t) of dn/dt + a dn/ds = 0, n(0) = 2 n(1), from n(s, 0) = f0(s) on [0, 1).

    With the twisted-periodic extension f(s + 1) = f(s) / 2 (i.e. f(s - k) = 2^k f(s) for the
    integer k), and sigma = ``shift`` = int a dt = G / ln 2:

        n(s, t) = f(s - sigma) = 2^k f0(s - sigma + k),   k = -floor(s - sigma),

    so that s - sigma + k = frac(s - sigma) in [0, 1). Returns the function s -> n(s, t).
    It is smooth in s when f0 is twisted-periodic compatible (f0 = 2^-s q(s), q smooth 1-periodic)
    or vanishes to all orders at both ends (a bump inside (0, 1)); otherwise it has a jump at
    s = frac(sigma).
    """
    sigma = float(shift)

    def n(s: NDArray) -> NDArray:
        y = np.asarray(s, dtype=float) - sigma
        k = -np.floor(y)
        return 2.0**k * np.asarray(f0(y + k), dtype=float)

    return n


def spread(number: ArrayLike, total: ArrayLike, square: ArrayLike) -> NDArray:
    """Standard deviation of the lengths from the moments N, L = sum l, Q = sum l^2.

    sqrt(max(Q / N - (L / N)^2, 0)): the cut removes the round-off of a one-cell distribution.
    """
    number = np.asarray(number, dtype=float)
    mean = np.asarray(total, dtype=float) / number
    return np.sqrt(np.maximum(np.asarray(square, dtype=float) / number - mean * mean, 0.0))


# ---------------------------------------------------------------------------- characteristics


def split_phase(x: NDArray) -> tuple[NDArray, NDArray]:
    """Whole and fractional parts (k, f) of x = k + f, k = floor(x) (float), f in [0, 1).

    An x just below an integer, whose x - floor(x) rounds up to 1, gives f = 0 and k + 1.
    """
    k = np.floor(x)
    f = x - k
    up = f >= 1.0
    k[up] += 1.0
    f[up] = 0.0
    return k, f


class CharacteristicSizes:
    r"""Psi per node carried exactly along its characteristics in s = log2 l (the default).

    In s every length of a material element moves at the same speed a = g / ln 2, so the
    characteristics are parallel and a grid that moves with them needs no interpolation in s.
    Node j holds a phase offset ``phase[j]`` = phi in [0, 1) and values ``n[j, i]`` on the
    window [phi, phi + 1) of the extended line (the twisted-periodic extension
    n(s + 1) = n(s) / 2 of the distribution on [0, 1), continuum.sizes module docstring)::

        n(s) = n[j, i]   on   [phi + i ds, phi + (i + 1) ds),   i = 0..N-1,   ds = 1 / N.

    Cells with s >= 1 hold lengths 2^s >= 2 in the extension: their particles have divided, and
    on [0, 1) they are twice as many at s - 1 (the division condition n(0) = 2 n(1)).

    Advance (exact for any dt): phi <- phi + a dt; when phi passes an integer k times (k
    divisions of every cell, a shift by whole octaves) phi <- phi - k and n <- 2^k n. The
    values change only by these exact doublings, so the mean length does not depend on dt.

    Moments, exact for piecewise-constant n (the cell integral of 2^s)::

        N = sum_i n_i (ds + |cell_i cap [1, 2)|)        (cells past s = 1 count twice),
        L = sum_i n_i int_cell_i 2^s ds = 2^phi sum_i n_i (2^((i+1) ds) - 2^(i ds)) / ln 2,
        Q = sum_i n_i (int_(cell_i, s<1) 4^s ds + int_(cell_i, s>=1) 4^s ds / 2)   (squares).

    L is the same in every window (a division keeps the length), so L = exp(G) L(0) exactly
    along a path; N is piecewise linear in phi (rising while a cell crosses s = 1).

    Remap by labels (:meth:`transfer_labels`). Along a path the solution
    is n(s) = 2^k n0(y) at the label y = s - sigma, sigma = G / ln 2 (+ the initial phase),
    k = floor(sigma): cell i of a window is label y_i = i ds whatever the phase, and
    n_hat = 2^-k n (the divisions undone) is the initial profile of the material element,
    constant in time. So a remesh interpolates n_hat (by cell index: no remap in s, no
    smearing) and the unwrapped phase sigma (from G), and sets n = 2^k_new n_hat_new on the
    window at frac(sigma_new). Per current area the total length is L exp(-G) = sum_i n_hat_i
    (2^((i+1) ds) - 2^(i ds)) / ln 2, linear in n_hat: it transfers with the weights of W
    exactly; the number per current area is a function of n_hat and the phase, so it follows
    the phase (second order where the phase is smooth, right across a ring where an
    interpolated number is not). From a spatially uniform Psi0 every n_hat is the same and the
    transfer is exact.

    Parameters
    ----------
    grid : LengthGrid
        The fixed-width grid (its ``edges`` and ``length_integrals`` at phi = 0).
    n : ndarray (n_nodes, n_cells)
        Non-negative values on the windows.
    phase : ndarray (n_nodes,), optional
        Phase offsets in [0, 1) (default 0: the window is [0, 1)).
    """

    def __init__(self, grid: LengthGrid, n: ArrayLike, phase: ArrayLike | None = None):
        n = np.array(n, dtype=float)
        if n.ndim != 2 or n.shape[1] != grid.n_cells:
            raise ValueError(f"n must have shape (n_nodes, {grid.n_cells}), got {n.shape}")
        if not np.all(np.isfinite(n)):
            raise ValueError("n must be finite")
        phase = np.zeros(n.shape[0]) if phase is None else np.array(phase, dtype=float)
        if phase.shape != (n.shape[0],) or not np.all((phase >= 0) & (phase < 1)):
            raise ValueError(f"phase must have shape ({n.shape[0]},) with values in [0, 1)")
        self.grid = grid
        self.n = n
        self.phase = phase

    @property
    def n_nodes(self) -> int:
        """Number of rows (material elements, mesh nodes)."""
        return self.n.shape[0]

    def __repr__(self) -> str:
        return f"CharacteristicSizes(n_nodes={self.n_nodes}, grid={self.grid!r})"

    @classmethod
    def from_function(cls, grid: LengthGrid, n_nodes: int, f: Callable[[NDArray], NDArray],
                      n_quad: int = 8) -> CharacteristicSizes:
        """Every node holds the cell averages of f(s) on [0, 1) (phase 0)."""
        return cls(grid, np.tile(grid.cell_averages(f, n_quad), (int(n_nodes), 1)))

    @classmethod
    def bump(cls, grid: LengthGrid, n_nodes: int, width: float = 0.08,
             number: float = 1.0) -> CharacteristicSizes:
        """Every node holds the bump of :func:`bump_profile` (phase 0)."""
        return cls(grid, np.tile(bump_profile(grid, width, number), (int(n_nodes), 1)))

    def advance(self, g: ArrayLike, dt: float) -> CharacteristicSizes:
        """Shift every row by a dt = g dt / ln 2 in s, exactly (in place; returns self)."""
        g = _check_speed(g, self.n_nodes)
        dt = float(dt)
        if not math.isfinite(dt) or dt < 0:
            raise ValueError(f"dt must be finite and >= 0, got {dt}")
        k, self.phase = split_phase(self.phase + g * dt / LN2)
        rows = np.flatnonzero(k > 0)
        if rows.size:
            self.n[rows] *= np.exp2(k[rows])[:, None]  # exact: powers of two
        return self

    def number(self) -> NDArray:
        """Number of particles per material element (class docstring)."""
        ds = self.grid.ds
        over = np.clip(self.phase[:, None] + self.grid.edges[None, 1:] - 1.0, 0.0, ds)
        return np.einsum("ij,ij->i", self.n, ds + over)

    def total_length(self) -> NDArray:
        """Total length per material element, L = 2^phi sum_i n_i int_(i ds)^((i+1) ds) 2^s ds."""
        return np.exp2(self.phase) * (self.n @ self.grid.length_integrals)

    def mean_length(self) -> NDArray:
        """Mean length lbar = L / N per node."""
        return self.total_length() / self.number()

    def square_length(self) -> NDArray:
        """Sum of the squared lengths per material element (class docstring), exact for cells.

        The part of cell i below s = 1, [a, min(b, 1)), holds lengths 2^s; the part past it,
        [max(a, 1), b), twice as many cells of length 2^(s - 1), i.e. 2 4^(s - 1) = 4^s / 2 per
        unit of n: Q = sum_i n_i (int_lo 4^s ds + int_hi 4^s ds / 2).
        """
        a = self.phase[:, None] + self.grid.edges[None, :-1]
        b = a + self.grid.ds
        mid = np.clip(1.0, a, b)
        lo = (4.0**mid - 4.0**a) / LN4
        hi = (4.0**b - 4.0**mid) / LN4
        return np.einsum("ij,ij->i", self.n, lo + 0.5 * hi)

    def length_std(self) -> NDArray:
        """Standard deviation of the lengths per node, sqrt(Q / N - lbar^2) (:func:`spread`)."""
        return spread(self.number(), self.total_length(), self.square_length())

    def take(self, index: ArrayLike) -> CharacteristicSizes:
        """A new distribution holding the rows ``index`` (copy)."""
        index = np.asarray(index)
        return CharacteristicSizes(self.grid, self.n[index], self.phase[index])

    def copy(self) -> CharacteristicSizes:
        """A copy with its own values and phases."""
        return CharacteristicSizes(self.grid, self.n.copy(), self.phase.copy())

    def transfer_labels(self, W, sigma_old: ArrayLike, sigma_new: ArrayLike
                        ) -> CharacteristicSizes:
        """Rows 2^k_i sum_j W_ij 2^-k_j n_j on windows at frac(sigma_new) (remap by labels).

        ``sigma_old`` (n_nodes,) the unwrapped phases of the rows (sigma = phase + an integer
        k, found as the nearest integer to sigma - phase), ``sigma_new`` (n_new,) those of the
        new rows, k_i = floor(sigma_new_i). Class docstring; W should be >= 0 (the new values
        are not cut).
        """
        if W.ndim != 2 or W.shape[1] != self.n_nodes:
            raise ValueError(f"W must have shape (n_new, {self.n_nodes}), got {W.shape}")
        sigma_old = np.asarray(sigma_old, dtype=float)
        sigma_new = np.asarray(sigma_new, dtype=float)
        if sigma_old.shape != (self.n_nodes,) or sigma_new.shape != (W.shape[0],):
            raise ValueError("sigma_old and sigma_new must have one value per old / new row")
        k_old = np.round(sigma_old - self.phase)
        n_hat = np.asarray(W @ (self.n * np.exp2(-k_old)[:, None]))
        k_new, phase = split_phase(sigma_new)
        return CharacteristicSizes(self.grid, n_hat * np.exp2(k_new)[:, None], phase)


class DeltaSizes:
    r"""Psi = n delta(l - lbar) per node, the model's Psi0 = delta(l - 1) carried exactly.

    Along a material path every length moves in s = log2 l by the same G / ln 2, so a delta
    stays a delta: at the position s = frac(x / ln 2) with x = ln l0 + G (l0 = 1 for the
    model), every particle of the element has the length 2^frac(x / ln 2), and the element
    holds 2^floor(x / ln 2) times its initial number (one doubling per crossing of s = 1, the
    division condition). A node holds two numbers: ``n``, the number per material element with
    its divisions undone (the initial number, constant in time), and ``log_length``, x. The
    moments are exact::

        N = n 2^k,  L = N 2^f,  Q = N 4^f,  spread 0,     k = floor(x / ln 2), f = x / ln 2 - k,

    so the mean length is 2^frac(x / ln 2), the closed form continuum.growth.mean_length of
    x = G. Advancing adds g dt to x, the same floating-point operation as G <- G + dt g
    (continuum.motion.heun_step), so x stays equal to G bit for bit between remeshes; a remesh
    (:meth:`transfer_labels`) interpolates n with the convex weights and sets x = G_new plus
    the interpolated offset x - G (zero for the model's delta). The mean length then equals
    2^frac(G / ln 2) to round-off at every node, across rings and remeshes, at the cost of two
    numbers per node (``Config.initial_sizes = "delta"``, the default).

    Parameters
    ----------
    n : ndarray (n_nodes,)
        Positive numbers per material element with the divisions undone.
    log_length : ndarray (n_nodes,), optional
        x = ln l0 + G, finite (default 0: all lengths 1).
    """

    def __init__(self, n: ArrayLike, log_length: ArrayLike | None = None):
        n = np.array(n, dtype=float)
        if n.ndim != 1 or not np.all(np.isfinite(n)) or np.any(n <= 0):
            raise ValueError("n must be a one-dimensional array of positive numbers")
        x = np.zeros(n.shape) if log_length is None else np.array(log_length, dtype=float)
        if x.shape != n.shape or not np.all(np.isfinite(x)):
            raise ValueError(f"log_length must have shape {n.shape} and finite values")
        self.n = n
        self.log_length = x

    @classmethod
    def delta(cls, n_nodes: int, number: float = 1.0) -> DeltaSizes:
        """Psi0 = number * delta(l - 1) at every node."""
        return cls(np.full(int(n_nodes), float(number)))

    @property
    def n_nodes(self) -> int:
        """Number of rows (material elements, mesh nodes)."""
        return self.n.shape[0]

    def __repr__(self) -> str:
        return f"DeltaSizes(n_nodes={self.n_nodes})"

    def _split(self) -> tuple[NDArray, NDArray]:
        """(k, f): the divisions floor(x / ln 2) and the position frac(x / ln 2) in s."""
        q = self.log_length / LN2
        k = np.floor(q)
        return k, q - k

    def advance(self, g: ArrayLike, dt: float) -> DeltaSizes:
        """Shift every delta by g dt / ln 2 in s: x <- x + dt g, exactly (in place; self)."""
        g = _check_speed(g, self.n_nodes)
        dt = float(dt)
        if not math.isfinite(dt) or dt < 0:
            raise ValueError(f"dt must be finite and >= 0, got {dt}")
        self.log_length = self.log_length + dt * g
        return self

    def number(self) -> NDArray:
        """Number of particles per material element, n 2^floor(x / ln 2)."""
        return self.n * np.exp2(self._split()[0])

    def total_length(self) -> NDArray:
        """Total length per material element, N 2^frac(x / ln 2)."""
        k, f = self._split()
        return self.n * np.exp2(k) * np.exp2(f)

    def mean_length(self) -> NDArray:
        """Mean length 2^frac(x / ln 2) per node."""
        return np.exp2(self._split()[1])

    def square_length(self) -> NDArray:
        """Sum of the squared lengths per material element, N 4^frac(x / ln 2)."""
        k, f = self._split()
        return self.n * np.exp2(k) * np.exp2(2.0 * f)

    def length_std(self) -> NDArray:
        """Standard deviation of the lengths per node: 0 (one length per material element)."""
        return np.zeros(self.n_nodes)

    def take(self, index: ArrayLike) -> DeltaSizes:
        """A new distribution holding the rows ``index`` (copy)."""
        index = np.asarray(index)
        return DeltaSizes(self.n[index], self.log_length[index])

    def copy(self) -> DeltaSizes:
        """A copy with its own arrays."""
        return DeltaSizes(self.n.copy(), self.log_length.copy())

    def transfer_labels(self, W, G_old: ArrayLike, G_new: ArrayLike) -> DeltaSizes:
        """The deltas on new nodes: n_new = W n, x_new = G_new + W (x - G_old).

        W an (n_new, n_nodes) matrix with W >= 0 and rows summing to 1 (the convex weights of
        continuum.remesh); G_old, G_new the growth phases of the old and new nodes. With
        x = G at every old node (the model's delta) x_new = G_new exactly.
        """
        if W.ndim != 2 or W.shape[1] != self.n_nodes:
            raise ValueError(f"W must have shape (n_new, {self.n_nodes}), got {W.shape}")
        G_old = np.asarray(G_old, dtype=float)
        G_new = np.asarray(G_new, dtype=float)
        if G_old.shape != (self.n_nodes,) or G_new.shape != (W.shape[0],):
            raise ValueError("G_old and G_new must have one value per old / new row")
        offset = self.log_length - G_old
        x = G_new + np.asarray(W @ offset) if np.any(offset) else G_new.copy()
        return DeltaSizes(np.asarray(W @ self.n), x)
