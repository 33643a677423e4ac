"""Tests of continuum.sizes: the length grid, the exact shift, the bump Psi0 and bad input.

The transport along characteristics is tested in test_psi_characteristics.py, its moments in
test_psi_moments.py.
"""

import math

import numpy as np
import pytest

from continuum.sizes import CharacteristicSizes, LengthGrid, bump_profile, exact_shift

LN2 = math.log(2.0)
NS = np.array([32, 64, 128, 256])


def smooth_bump(s, c=0.5, w=0.2):
    """C-infinity bump supported in (c - w, c + w), inside (0, 1)."""
    x = (s - c) / w
    inside = np.abs(x) < 1.0
    return np.where(inside, np.exp(-1.0 / np.where(inside, 1.0 - x * x, 1.0)), 0.0)


def twisted(s):
    """Smooth twisted-periodic profile 2^-s q(s), q 1-periodic: f(s + 1) = f(s)/2."""
    return 2.0**-s * (1.0 + 0.5 * np.sin(2 * np.pi * s) + 0.2 * np.cos(4 * np.pi * s))


def test_length_grid():
    grid = LengthGrid(40)
    assert grid.ds == pytest.approx(1 / 40)
    np.testing.assert_allclose(grid.lengths, 2.0**grid.centres)
    assert grid.length_integrals.sum() == pytest.approx(1 / LN2, rel=1e-14)  # int_0^1 2^s ds
    cubic = grid.cell_averages(lambda s: s**3)
    exact = np.diff(grid.edges**4) / 4 / grid.ds
    np.testing.assert_allclose(cubic, exact, rtol=1e-13)
    with pytest.raises(ValueError):
        LengthGrid(3)


def test_exact_shift_extension():
    """n(s, t) = f(s - sigma) with f(s - k) = 2^k f(s): one full period doubles every value."""
    s = np.linspace(0, 0.999, 7)
    np.testing.assert_allclose(exact_shift(twisted, 1.0)(s), 2 * twisted(s), rtol=1e-14)
    np.testing.assert_allclose(exact_shift(twisted, 3.0)(s), 8 * twisted(s), rtol=1e-14)
    # for the twisted-periodic profile the shift is the profile's own extension: smooth, and
    # the stable profile 2^-s grows exactly like 2^sigma = exp(G)
    sig = 0.37
    np.testing.assert_allclose(exact_shift(twisted, sig)(s), twisted(s - sig), rtol=1e-14)
    np.testing.assert_allclose(exact_shift(lambda s: 2.0**-s, sig)(s), 2.0 ** (sig - s), rtol=1e-14)
    # a bump moved past s = 1 reappears doubled at the bottom
    np.testing.assert_allclose(exact_shift(smooth_bump, 0.7)(s), 2 * smooth_bump(s + 0.3))


def _bump_profile(width):
    """The profile of continuum.sizes.bump_profile (before normalisation)."""

    def f(s):
        x = (s - width) / width
        inside = np.abs(x) < 1.0
        return np.where(inside, np.exp(-1.0 / np.where(inside, 1.0 - x * x, 1.0)), 0.0)

    return f


def _lbar(grid, n):
    return (n @ grid.length_integrals) / (n.sum() * grid.ds)


def test_exact_bump_mean_length_is_within_its_width_of_the_delta_limit():
    """Support (0, 2w) shifted by sigma: lbar / 2^frac(sigma) lies in (1, 2^(2w)).

    This holds while the support does not straddle s = 1 (all lengths lie in
    (2^frac(sigma), 2^(frac(sigma) + 2w))).
    """
    width = 0.06
    grid = LengthGrid(512)
    f0 = _bump_profile(width)
    checked = 0
    for sigma in np.linspace(0, 4, 401):
        phase = sigma % 1
        if phase > 1 - 2 * width:
            continue
        ratio = _lbar(grid, grid.cell_averages(exact_shift(f0, sigma), 16)) / 2**phase
        assert 1 < ratio < 2 ** (2 * width)
        checked += 1
    assert checked > 300


def test_bump_profile_holds_the_number_and_the_shape():
    """bump_profile: the cell averages of the C-infinity bump, scaled to sum n ds = number."""
    grid = LengthGrid(64)
    row = bump_profile(grid, width=0.15, number=3.0)
    assert row.sum() * grid.ds == pytest.approx(3.0, rel=1e-14)
    shape = grid.cell_averages(_bump_profile(0.15), 16)
    np.testing.assert_allclose(row, shape * 3.0 / (shape.sum() * grid.ds), rtol=1e-14)
    assert np.all(row[grid.edges[:-1] >= 0.3] == 0) and np.all(row[1:18] > 0)  # support (0, 0.3)
    sizes = CharacteristicSizes.bump(grid, 3, width=0.15, number=3.0)
    assert sizes.n.shape == (3, 64) and np.all(sizes.n == row) and np.all(sizes.phase == 0)


def test_bad_input_is_rejected():
    grid = LengthGrid(16)
    sd = CharacteristicSizes.bump(grid, 2, width=0.2)
    with pytest.raises(ValueError, match="g"):
        sd.advance(np.array([1.0, -0.1]), 0.1)
    with pytest.raises(ValueError, match="shape"):
        sd.advance(np.ones(3), 0.1)
    with pytest.raises(ValueError, match="dt"):
        sd.advance(1.0, float("nan"))
    with pytest.raises(ValueError):
        CharacteristicSizes(grid, np.ones((2, 15)))
    with pytest.raises(ValueError, match="two cells"):
        bump_profile(grid, width=0.05)  # narrower than two cells
    with pytest.raises(ValueError, match="bump width"):
        bump_profile(grid, width=0.5)
