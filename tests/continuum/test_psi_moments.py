"""The spread of the lengths of the transported Psi (continuum.sizes ``length_std``).

Exact answers: the sum of the squared lengths Q of a piecewise-constant row on a window at any
phase, against a quadrature that divides the cells past s = 1 by hand; on a run (SMALL to
radius 6, lam = 1e-2, 6 remeshes by labels) the transported mean length is the closed form
2^frac(G / ln 2) shifted by the bump's centre w, and the spread of the lengths is the bump's
width l ln 2 sigma_s (sigma_s its standard deviation in s) wherever the bump has not reached
s = 1 (the synchronised colony: every cell of an element at one phase).
"""

import numpy as np

from continuum import Simulation
from continuum.growth import LN2
from continuum.sizes import CharacteristicSizes, LengthGrid, spread

from .conftest import small_config

WIDTH = 0.08  # the default bump (Config.bump_width)


def quadrature_moments(n: np.ndarray, phase: float, m: int = 2000) -> tuple[float, ...]:
    """(N, L, Q) of the window row n at ``phase``, by m-point midpoint sums per cell.

    A cell value v at s < 1 is v cells per unit s of length 2^s; at s >= 1 (divided) 2 v cells
    of length 2^(s - 1). Accurate to O(ds / m) (the sub-interval straddling s = 1).
    """
    N = len(n)
    s = phase + (np.arange(N)[:, None] + (np.arange(m)[None, :] + 0.5) / m) / N
    w = np.repeat(n[:, None], m, axis=1) / (N * m)
    divided = s >= 1.0
    count = np.where(divided, 2.0 * w, w)
    length = np.where(divided, 2.0 ** (s - 1.0), 2.0**s)
    return count.sum(), (count * length).sum(), (count * length**2).sum()


def test_square_length_is_exact_at_any_phase():
    grid = LengthGrid(16)
    rng = np.random.default_rng(3)
    n = rng.uniform(0.0, 1.0, (6, 16))
    phase = np.array([0.0, 0.03, 0.25, 0.5, 0.97, 0.999])
    sd = CharacteristicSizes(grid, n, phase)
    for j in range(6):
        N, L, Q = quadrature_moments(n[j], phase[j])
        np.testing.assert_allclose(sd.number()[j], N, rtol=2e-5)
        np.testing.assert_allclose(sd.total_length()[j], L, rtol=2e-5)
        np.testing.assert_allclose(sd.square_length()[j], Q, rtol=2e-5)
        np.testing.assert_allclose(sd.length_std()[j], np.sqrt(Q / N - (L / N) ** 2), rtol=1e-3)
    # at phase 0 (no cell past s = 1) Q = int 4^s n ds exactly: sum of n_i (4^b - 4^a) / ln 4
    exact_q = n[0] @ (np.diff(4.0**grid.edges) / (2 * LN2))
    np.testing.assert_allclose(sd.square_length()[0], exact_q, rtol=1e-13)


def test_one_cell_has_the_spread_of_its_lengths():
    """A single cell [a, a + ds): lengths 2^s, s uniform; spread^2 = Var 2^s, closed form."""
    grid = LengthGrid(8)
    n = np.zeros((1, 8))
    n[0, 3] = 1.0
    a, b = 3 / 8, 4 / 8
    m1 = (2**b - 2**a) / LN2 / (b - a)
    m2 = (4**b - 4**a) / (2 * LN2) / (b - a)
    np.testing.assert_allclose(CharacteristicSizes(grid, n).length_std(), np.sqrt(m2 - m1**2),
                               rtol=1e-10)
    assert spread(1.0, 1.0, 1.0 - 1e-17) == 0.0  # round-off below zero is cut


def bump_sigma_s(width: float) -> float:
    """Standard deviation in s of the smooth bump exp(-1 / (1 - x^2)), x = (s - w) / w."""
    x = np.linspace(-1.0, 1.0, 200_001)[1:-1]
    f = np.exp(-1.0 / (1.0 - x * x))
    return width * float(np.sqrt(np.sum(f * x * x) / np.sum(f)))


def test_run_mean_and_spread_follow_the_bump():
    """SMALL to radius 6: lbar_psi = 2^(frac(G/ln 2) + w), spread = lbar ln 2 sigma_s.

    Measured where the bump's cells lie below s = 1 (217 of 1561 nodes): max |lbar_psi -
    2^(phi + w)| 4.9e-4, |lbar_psi / 2^phi - 1| <= 0.0573 = 2^w - 1, and spread / (lbar ln 2
    sigma_s) = 1.0509 at every node (40 cells of 1/40 widen the smooth bump's sigma_s =
    0.0318); where it straddles s = 1 the element holds cells near 2 and near 1, spread up to
    0.47.
    """
    s = Simulation(small_config(radius=6.0, initial_sizes="bump")).advance()
    assert s.n_remesh == 6
    f = s.fields
    phi = np.mod(s.G / LN2, 1.0)
    row = CharacteristicSizes.bump(LengthGrid(40), 1, width=WIDTH).n[0]
    support = (np.flatnonzero(row).max() + 1) / 40  # the cells of the bump reach this s
    inside = phi + support < 1.0
    assert 200 < inside.sum() < len(phi)  # both kinds of node
    lbar, sd = f["mean_length_psi"], f["length_std_psi"]
    closed = f["mean_length"]
    np.testing.assert_array_equal(closed, 2.0**phi)
    # to the bump's width: within its half-width 2^w of the closed form, at its centre to 0.005
    assert np.all(np.abs(lbar / closed - 1)[inside] < 2**WIDTH - 1 + 1e-3)
    assert np.max(np.abs(lbar - 2.0 ** (phi + WIDTH))[inside]) < 1e-3
    ratio = (sd / (lbar * LN2 * bump_sigma_s(WIDTH)))[inside]
    assert 1.0 < ratio.min() and ratio.max() < 1.06
    assert sd[~inside].max() > 0.3  # bimodal where the bump straddles a division
