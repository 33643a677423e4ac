"""Tests of continuum.sizes against the exact shift solution and the exact moment identities."""

import math

import numpy as np
import pytest
import scipy.sparse as sp

from continuum.sizes import LengthGrid, SizeDistribution, exact_shift, lw_mc_step

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


def _order(errs):
    return -np.polyfit(np.log(NS), np.log(errs), 1)[0]


def _run(f0, n_cells, g, phase, seed=0, record=None):
    """Advance rows with speeds g by random dt until node 0 has growth phase G = phase.

    Returns (distribution, G per node, list of (G, number, total_length) if record).
    """
    grid = LengthGrid(n_cells)
    sd = SizeDistribution.from_function(grid, g.size, f0)
    rng = np.random.default_rng(seed)
    G = np.zeros(g.size)
    hist = [(G.copy(), sd.number(), sd.total_length())]
    while G[0] < phase:
        dt = min(rng.uniform(0.005, 0.04), (phase - G[0]) / g[0])
        sd.advance(g, dt)
        G += g * dt
        if record:
            hist.append((G.copy(), sd.number(), sd.total_length()))
    return sd, G, hist


def _exact_averages(grid, f0, G):
    return np.array([grid.cell_averages(exact_shift(f0, Gi / LN2), 16) for Gi in G])


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


def test_numba_kernel_is_the_numpy_reference_step():
    rng = np.random.default_rng(3)
    n = rng.uniform(0, 1, (5, 24))
    nu_total = np.array([0.0, 0.3, 0.9, 2.5, 7.1])
    sd = SizeDistribution(LengthGrid(24), n.copy(), courant=0.9)
    g = nu_total * LN2 * sd.grid.ds  # so that a dt / ds = nu_total at dt = 1
    sd.advance(g, 1.0)
    for j, nt in enumerate(nu_total):
        m = max(1, math.ceil(nt / 0.9 * (1 - 1e-12))) if nt > 0 else 0
        row = n[j : j + 1]
        for _ in range(m):
            row = lw_mc_step(row, np.array([nt / m]))
        np.testing.assert_allclose(sd.n[j], row[0], rtol=1e-14, atol=1e-16)
    assert np.all(sd.n >= 0)


def test_division_flux_reappears_doubled():
    """Mass leaving through s = 1 enters at s = 0 doubled (one step, no other flux)."""
    grid = LengthGrid(32)
    sd = SizeDistribution.from_function(grid, 1, lambda s: smooth_bump(s, 0.9, 0.15))
    upper_before = sd.n[0, 16:].sum()
    assert sd.n[0, :16].sum() == 0.0
    sd.advance(0.7, 0.02)
    gained = sd.n[0, :16].sum()
    lost = upper_before - sd.n[0, 16:].sum()
    assert gained > 0
    assert gained == pytest.approx(2 * lost, rel=1e-12)


@pytest.mark.parametrize("f0", [smooth_bump, twisted], ids=["bump", "twisted"])
def test_fv_converges_to_exact_shift_at_second_order(f0):
    g = np.array([1.0, 0.55, 0.2])
    errs = []
    for N in NS:
        sd, G, _ = _run(f0, N, g, 2.37 * LN2)
        exact = _exact_averages(sd.grid, f0, G)
        errs.append(np.abs(sd.n - exact).sum(axis=1) * sd.grid.ds)
    errs = np.array(errs)
    for j in range(g.size):
        assert _order(errs[:, j]) >= 1.5, errs[:, j]
    assert errs[-1, 0] < 1e-2 * np.abs(exact[0]).sum() * sd.grid.ds  # relative L1 < 1%


def test_total_length_grows_like_exp_G_to_scheme_accuracy():
    """L(t) = exp(G) L(0) exactly for the PDE; the scheme keeps it to error O(ds^1.5) or better."""
    g = np.array([1.0, 0.4])
    errs = []
    for N in NS:
        _, _, hist = _run(smooth_bump, N, g, 4.2 * LN2, record=True)
        L0 = hist[0][2]
        errs.append(max(np.max(np.abs(L / (np.exp(G) * L0) - 1)) for G, _, L in hist))
    assert _order(np.array(errs)) >= 1.5, errs
    assert errs[-1] < 1e-4


def test_number_after_several_divisions_matches_exact():
    """Number per material element over ~5.5 divisions vs the exact shift.

    The scheme is conservative and the division flux is doubled exactly, so once the bump is
    away from s = 1 the number is 2^k N(0) up to the numerical tails left near s = 1; while it
    crosses s = 1 the error (max over the history) converges at order >= 1.5.
    """
    g = np.array([0.9])
    worst, after5 = [], []
    for N in NS:
        grid = LengthGrid(N)
        sd = SizeDistribution.from_function(grid, 1, smooth_bump, n_quad=16)
        N0 = sd.number()[0]
        G, err = 0.0, 0.0
        while G < 5.55 * LN2:
            dt = min(0.02, (5.55 * LN2 - G) / g[0])
            sd.advance(g, dt)
            G += g[0] * dt
            exact = grid.cell_averages(exact_shift(smooth_bump, G / LN2), 16).sum() * grid.ds
            err = max(err, abs(sd.number()[0] / exact - 1))
            if abs(G / LN2 - 5.2) < 0.5 * dt * g[0] / LN2:
                after5.append(abs(sd.number()[0] / (32 * N0) - 1))
        worst.append(err)
    assert _order(np.array(worst)) >= 1.5, worst
    assert worst[-1] < 2e-3, worst  # measured 1.0e-3 at 256 cells (1e-3 after the crossing)
    assert len(after5) == len(NS)
    assert after5[0] < 1e-3 and after5[2] < 1e-9 and after5[3] < 1e-9, after5


def test_stable_profile_number_grows_like_exp_G():
    """n0 = 2^-s (Psi ~ l^-2) is the stable profile: N(t) = exp(G) N(0), here to scheme accuracy."""
    g = np.array([1.0])
    errs = []
    for N in NS:
        _, _, hist = _run(lambda s: 2.0**-s, N, g, 3.3 * LN2, record=True)
        N0 = hist[0][1]
        errs.append(max(np.max(np.abs(num / (np.exp(G) * N0) - 1)) for G, num, _ in hist))
    assert _order(np.array(errs)) >= 1.5, errs


def _bump_profile(width):
    """The profile of SizeDistribution.bump (before normalisation)."""

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


def test_fv_bump_mean_length_converges_to_the_exact_bump():
    """The max over t of |lbar_FV - lbar_exact| over 3.5 divisions converges at order >= 1.5."""
    width = 0.15
    f0 = _bump_profile(width)
    errs = []
    for N in NS:
        grid = LengthGrid(N)
        sd = SizeDistribution.bump(grid, 2, width=width)
        assert sd.number() == pytest.approx(1.0, rel=1e-14)
        G, err = 0.0, 0.0
        while G < 3.5 * LN2:
            sd.advance(np.array([1.0, 1.0]), 0.02)
            G += 0.02
            assert np.all(sd.n >= 0)
            exact = _lbar(grid, grid.cell_averages(exact_shift(f0, G / LN2), 16))
            err = max(err, abs(sd.mean_length()[0] - exact))
        errs.append(err)
    assert _order(np.array(errs)) >= 1.5, errs


def test_rows_are_independent():
    grid = LengthGrid(48)
    rng = np.random.default_rng(7)
    n = rng.uniform(0, 1, (6, 48))
    g = np.array([0.0, 0.1, 0.5, 1.0, 3.0, 0.7])
    batch = SizeDistribution(grid, n)
    for _ in range(5):
        batch.advance(g, 0.03)
    for j in range(6):
        alone = SizeDistribution(grid, n[j : j + 1])
        for _ in range(5):
            alone.advance(g[j : j + 1], 0.03)
        assert np.array_equal(alone.n[0], batch.n[j])
    assert np.array_equal(batch.n[0], n[0])  # g = 0: no change


def test_transfer_and_take():
    grid = LengthGrid(16)
    sd = SizeDistribution.from_function(grid, 3, twisted)
    sd.n *= np.array([[1.0], [2.0], [3.0]])
    W = sp.csr_matrix(np.array([[0.5, 0.5, 0.0], [0.0, 0.25, 0.75], [1.0, 0.0, 0.0]]))
    new = sd.transfer(W)
    np.testing.assert_allclose(new.n, W @ sd.n)
    np.testing.assert_allclose(new.number(), W @ sd.number())
    np.testing.assert_allclose(new.total_length(), W @ sd.total_length())
    np.testing.assert_array_equal(sd.take([2, 0]).n, sd.n[[2, 0]])
    with pytest.raises(ValueError):
        sd.transfer(sp.identity(4, format="csr"))


def test_bad_input_is_rejected():
    grid = LengthGrid(16)
    sd = SizeDistribution.bump(grid, 2, width=0.2)
    with pytest.raises(ValueError, match="g"):
        sd.advance(np.array([1.0, -0.1]), 0.1)
    with pytest.raises(ValueError, match="shape"):
        sd.advance(np.ones(3), 0.1)
    with pytest.raises(ValueError, match="dt"):
        sd.advance(1.0, float("nan"))
    with pytest.raises(ValueError):
        SizeDistribution(grid, np.ones((2, 15)))
    with pytest.raises(ValueError):
        SizeDistribution(grid, np.ones((2, 16)), courant=1.5)
    with pytest.raises(ValueError):
        SizeDistribution.bump(grid, 2, width=0.05)  # narrower than two cells
