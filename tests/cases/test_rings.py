"""The ring measurement of both models (cases.analysis.rings), on synthetic profiles.

Profiles are annulus means as the particle reduction writes them: N equal-area annuli of a disc
of radius R, n particles each, lengths of standard deviation s about the signal, so the
annulus mean has standard error s / sqrt(n).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from cases import analysis as A

R, N, PER_ANNULUS, SPREAD = 60.0, 150, 400, 0.3


def annuli() -> np.ndarray:
    """Centres of N equal-area annuli of the disc of radius R."""
    return R * np.sqrt((np.arange(N) + 0.5) / N)


def profile(signal: np.ndarray, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """A particle profile of annulus means of ``signal`` with their sampling noise."""
    se = SPREAD / math.sqrt(PER_ANNULUS)
    return {"r": annuli(), "mean_length": signal + rng.normal(0.0, se, N),
            "mean_length_std": np.full(N, SPREAD), "count": np.full(N, float(PER_ANNULUS))}


def sawtooth(r: np.ndarray, rings: np.ndarray) -> np.ndarray:
    """The model's mean length 2^frac(G / ln 2), G linear between rings.

    G increases outwards (the edge is the least inhibited): the mean length rises from 1 just
    beyond a ring to 2 just inside the next, where it drops (the peak).
    """
    edges = np.concatenate([[0.0], rings, [R + 1e-9]])
    k = np.searchsorted(rings, r, side="right")
    return 2.0 ** ((r - edges[k]) / (edges[k + 1] - edges[k]))


def test_pure_noise_gives_a_false_ring_in_at_most_5_percent_of_profiles():
    """200 ring-free profiles (noise only): at most 5 % have a ring, fewer a wavelength.

    The threshold was calibrated on real ring-free colonies (docs/validation.md, "Rings"); on
    white noise the largest z of 200 profiles stays below it.
    """
    rng = np.random.default_rng(57)
    results = [A.profile_rings(profile(np.full(N, 1.4), rng), R) for _ in range(200)]
    with_ring = np.mean([r.count >= 1 for r in results])
    with_wavelength = np.mean([np.isfinite(r.outer_pair) for r in results])
    assert with_ring <= 0.05 and with_wavelength <= with_ring
    assert all(r.reason for r in results if not np.isfinite(r.outer_pair))


def test_one_ring_has_no_wavelength_and_says_why():
    """One jump of the mean length (the lam = 1e-4 colonies at radius 150): one ring, nan.

    The smoothed drop peaks just inside the ring, within the smoother's reach (4 x 0.5).
    """
    rng = np.random.default_rng(1)
    rings = A.profile_rings(profile(sawtooth(annuli(), np.array([35.0])), rng), R)
    assert rings.count == 1 and 35.0 - 4 * 0.5 < rings.radii[0] < 35.0
    assert math.isnan(rings.outer_pair) and math.isnan(rings.mean_spacing)
    assert rings.reason.startswith("1 ring (r = 3") and "needs two" in rings.reason


@pytest.mark.parametrize("w", [6.0, 10.0])
def test_rings_under_noise_give_their_wavelength_within_its_interval(w):
    """Rings every w under the annulus noise: the outer pair is w within 3 spreads.

    The spread is :func:`ring_uncertainty`'s (the smoothed profile measured again under the
    annulus noise). Over 10 profiles the error of the outer pair is within 3 spreads every
    time, its root mean square within 1.5 median spreads (measured over 16 profiles: 0.75 at
    w = 6, 1.27 at w = 10, where the smoothed profile keeps some of the noise of a broad
    peak), and the spread is neither zero nor a quarter wavelength.
    """
    rng = np.random.default_rng(int(w))
    true = np.arange(w, R - 1.0, w)
    errors, spreads = [], []
    for _ in range(10):
        prof = profile(1.4 + 0.1 * np.cos(2 * np.pi * annuli() / w), rng)
        errors.append(A.profile_rings(prof, R).outer_pair - (true[-1] - true[-2]))
        spreads.append(A.ring_uncertainty(prof, R, draws=30)["outer_pair_sd"])
    errors, spreads = np.array(errors), np.array(spreads)
    assert np.all(np.abs(errors) <= 3 * spreads)
    assert np.sqrt(np.mean(errors**2)) <= 1.5 * np.median(spreads)
    assert np.all((spreads > 0) & (spreads < w / 4))


def test_crowding_rings_give_two_different_wavelengths_as_defined():
    """Ring spacings shrinking outwards (as the rings crowd when the colony grows).

    outer_pair is the last spacing; mean_spacing the mean over the rings of the outer half;
    a ring hidden by the noise (a spacing about twice its neighbour's) ends the run of rings
    the mean spacing is taken over; a ring in the edge layer is not counted.
    """
    radii = np.array([10.0, 24.0, 34.0, 42.0, 48.5, 54.0])
    rings = A.count_rings(radii, R)
    assert rings.outer_pair == pytest.approx(5.5)
    assert rings.mean_spacing == pytest.approx((54.0 - 34.0) / 3)  # rings at 34, 42, 48.5, 54
    assert rings.mean_spacing / rings.outer_pair == pytest.approx(1.2121, rel=1e-4)
    hidden = A.count_rings(np.delete(radii, 3), R)  # 42 missed: 14.5 before 5.5
    assert hidden.mean_spacing == pytest.approx(5.5)
    edge = A.count_rings(np.append(radii, R - 1.0), R)
    assert edge.count == radii.size and edge.outer_pair == rings.outer_pair
    weak = A.count_rings(radii, R, significance=np.array([9, 9, 9, 9, 9, 1.0]))
    assert weak.outer_pair == pytest.approx(6.5) and weak.count == 5
    none = A.count_rings(radii[-1:], R, significance=np.array([2.0]))
    assert none.reason.startswith("no significant peak (largest z 2")


def test_continuum_and_reference_follow_the_same_rule():
    """A ring table and the 1D reference go through one rule.

    The edge layer drops the newest ring at the edge for both.
    """
    lam, radius = 0.1, 150.0
    exact = A.exact_ring_measure(lam, radius)
    from continuum import radial

    all_rings = radial.ring_radii(lam, radius=radius)
    inside = all_rings[all_rings <= radius - A.EDGE_LAYER]
    assert exact.outer_pair == pytest.approx(inside[-1] - inside[-2], rel=1e-12)
    table = {"mean_radius": all_rings}
    contour = A.contour_rings(table, radius)
    np.testing.assert_array_equal(contour.radii, exact.radii)
    assert contour.reason == exact.reason == ""
    assert math.isnan(A.exact_wavelength(0.0, radius))


def test_power_law_interval_covers_the_exponent_at_its_level():
    """The 95 % interval of a power law covers its exponent at its level.

    Five points y = x^(-1/2) with known log-normal errors: the interval covers -1/2 in 93-97 %
    of 1000 draws (binomial sd 0.7 %); two points: the exponent, no interval from the scatter.
    """
    rng = np.random.default_rng(4)
    x = np.array([1e-4, 3e-4, 1e-3, 3e-3, 1e-2])
    sd_log = np.array([0.05, 0.05, 0.1, 0.1, 0.2])
    covered = []
    for _ in range(1000):
        y = x**-0.5 * np.exp(rng.normal(0.0, sd_log))
        a, lo, hi, _ = A.power_law_interval(x, y, sd=y * sd_log)
        covered.append(lo <= -0.5 <= hi)
    assert 0.93 <= np.mean(covered) <= 0.97
    a, lo, hi, C = A.power_law_interval(x[:2], x[:2] ** -0.5)
    assert a == pytest.approx(-0.5) and math.isnan(lo)
    with pytest.raises(ValueError, match="two positive"):
        A.power_law_interval(x[:1], x[:1])
