"""Initial configurations that fill an outline (packings.fill_outline) and lines of cells."""

import math

import numpy as np
import pytest
from scipy import stats

import particles
from particles import packings
from particles.geometry import B, detect_contacts


def star(k, eps, r, n=400):
    t = 2 * np.pi * np.arange(n) / n
    rho = r * (1 + eps * np.cos(k * t))
    return np.column_stack([rho * np.cos(t), rho * np.sin(t)])


def ellipse(a, b, n=256):
    t = 2 * np.pi * np.arange(n) / n
    return np.column_stack([a * np.cos(t), b * np.sin(t)])


def area(xy):
    x, y = xy[:, 0], xy[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def segment_clearance(state, outline):
    """Smallest distance from a rod's segment to the outline, and whether the centres are inside."""
    half = 0.5 * (state.length - B)
    axis = np.column_stack([np.cos(state.theta), np.sin(state.theta)])
    centre = np.column_stack([state.x, state.y])
    ends = [centre + half[:, None] * axis, centre - half[:, None] * axis]
    a, b = outline, np.roll(outline, -1, axis=0)
    best = np.inf
    # segment-to-segment distance without crossings: the least endpoint-to-segment distance
    for p in ends:  # rod endpoints to the outline's edges
        d = b - a
        t = np.clip(np.einsum("nkj,kj->nk", p[:, None, :] - a[None], d) / np.sum(d * d, 1),
                    0, 1)
        best = min(best, np.min(np.linalg.norm(p[:, None, :] - a[None] - t[..., None] * d,
                                               axis=2)))
    seg = ends[1] - ends[0]
    for q in (a,):  # outline vertices to the rod segments
        t = np.clip(np.einsum("knj,nj->kn", q[:, None, :] - ends[0][None], seg)
                    / np.maximum(np.sum(seg * seg, 1), 1e-300), 0, 1)
        best = min(best, np.min(np.linalg.norm(q[:, None, :] - ends[0][None]
                                               - t[..., None] * seg, axis=2)))
    from matplotlib.path import Path  # test-only helper (the engine does not plot)

    inside = Path(outline).contains_points(centre)
    return best, inside


@pytest.fixture(scope="module")
def star_fill():
    outline = star(5, 0.2, 8)
    return outline, packings.fill_outline(outline, seed=3)


def test_fill_has_no_overlap_and_stays_inside(star_fill):
    outline, state = star_fill
    c = detect_contacts(state.x, state.y, state.theta, state.length, 0.1)
    assert c.gap.size > state.n  # a packing: neighbours touch (gap 1e-3) everywhere
    assert c.gap.min() >= 0.5e-3 - 1e-12  # >= gap/2, far from the overlap tolerance b/500
    clearance, inside = segment_clearance(state, outline)
    assert clearance >= B / 2  # every capsule lies inside the outline
    assert inside.all()


def test_fill_packing_fractions(star_fill):
    """Length packing b sum l / A against the area: measured 0.851 (tangent), 0.911 (rows)."""
    outline, state = star_fill
    phi_l, phi_a = packings.packing_fractions(state.length, area(outline))
    assert 0.8 < phi_l < 1 and phi_a < phi_l
    rows = packings.fill_outline(outline, seed=3, orientation="rows")
    assert 0.9 < packings.packing_fractions(rows.length, area(outline))[0] < 1
    np.testing.assert_allclose(np.sin(rows.theta), 0, atol=1e-12)  # parallel to x


def stable_cdf(l):
    """CDF of the density ~ l^-2 on [1, 2]."""
    return np.clip(2 * (1 - 1 / np.asarray(l)), 0, 1)


def test_lengths_follow_the_stable_distribution(star_fill):
    """Kolmogorov-Smirnov against F(l) = 2 (1 - 1/l): the fill's lengths, and a large sample."""
    _, state = star_fill
    assert stats.kstest(state.length, stable_cdf).pvalue > 0.01
    big = packings.sample_lengths(20000, np.random.default_rng(0))
    assert stats.kstest(big, stable_cdf).pvalue > 0.01
    assert big.mean() == pytest.approx(2 * math.log(2), abs=0.01)
    # the test has power: uniform lengths of the same sample size fail it
    uniform = packings.sample_lengths(state.n, np.random.default_rng(0), "uniform")
    assert stats.kstest(uniform, stable_cdf).pvalue < 0.01


def test_fill_is_deterministic_and_seeded():
    outline = ellipse(4, 2)
    a = packings.fill_outline(outline, seed=1)
    b = packings.fill_outline(outline[::-1], seed=1)  # either orientation of the outline
    for name in ("x", "y", "theta", "length"):
        assert getattr(a, name).tobytes() == getattr(b, name).tobytes()
    c = packings.fill_outline(outline, seed=2)
    assert not np.array_equal(a.length[: min(a.n, c.n)], c.length[: min(a.n, c.n)])
    birth = packings.fill_outline(outline, seed=1, lengths="birth")
    assert np.all(birth.length == 1.0)


def test_tangent_layers_follow_the_outline():
    """Rods of the outer layer of a disc lie along the tangent (perpendicular to the radius)."""
    r = 6.0
    state = packings.fill_outline(ellipse(r, r), seed=0)
    rho = np.hypot(state.x, state.y)
    outer = rho > r - B - 0.1
    assert outer.sum() > 20  # about 2 pi (r - b/2) / (2 ln 2) rods
    radial = np.arctan2(state.y, state.x)
    assert np.all(np.abs(np.cos(state.theta[outer] - radial[outer])) < 0.2)


@pytest.mark.parametrize("kwargs,words", [
    (dict(outline=np.zeros((2, 2))), "at least 3 vertices"),
    (dict(outline=[[0, 0], [1, 0], [np.nan, 1]]), "non-finite"),
    (dict(outline=[[0, 0], [1, 0], [2, 0]]), "no area"),
    (dict(outline=ellipse(0.3, 0.3)), "too small"),
    (dict(outline=ellipse(3, 3), orientation="random"), "unknown orientation"),
    (dict(outline=ellipse(3, 3), lengths="normal"), "unknown length distribution"),
    (dict(outline=ellipse(3, 3), gap=0.0), "gap must be"),
])
def test_fill_bad_input(kwargs, words):
    with pytest.raises(ValueError, match=words):
        packings.fill_outline(**kwargs)


def test_line_of_cells():
    state = packings.line(4)
    np.testing.assert_allclose(state.x, [-1.5, -0.5, 0.5, 1.5])
    assert np.all(state.y == 0) and np.all(state.theta == 0) and np.all(state.length == 1)
    c = detect_contacts(state.x, state.y, state.theta, state.length, 0.1)
    np.testing.assert_allclose(c.gap, 0, atol=1e-12)  # tip to tip
    assert len(c.gap) == 3
    for bad in (0, 2.5, True):
        with pytest.raises(ValueError, match="integer number of cells"):
            packings.line(bad)


def test_shape_config_fields():
    config = particles.Config(lam=1e-2, time=1.0, shape="line:3", fill_orientation="rows")
    config.validate()
    with pytest.raises(ValueError, match="give its initial state"):
        particles.Simulation(config)
    sim = particles.Simulation(config, state=packings.line(3))
    assert sim.state.n == 3
    with pytest.raises(ValueError, match="init .* or shape"):
        particles.Config(lam=0.0, time=1.0, shape="line:3", init=__file__).validate()
    with pytest.raises(ValueError, match="fill_lengths"):
        particles.Config(lam=0.0, time=1.0, fill_lengths="normal").validate()
