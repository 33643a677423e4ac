"""The growth law of particles/growth.py against its closed forms."""

import numpy as np
import pytest

from particles.growth import grow, growth_rate, largest_increment_slope, length_increment


@pytest.mark.parametrize(("lam", "adt"), [(1e-3, 0.005), (1e-2, 0.01), (1.0, 0.02), (5.0, 0.1)])
def test_largest_slope_of_the_increment_is_at_zero_stress(lam, adt):
    """Max over sigma >= 0 of |d dl/d sigma| (central differences) = l lam a dt exp(a dt)."""
    length = 1.7
    sigma = np.linspace(0.0, 20.0 / lam, 4001)
    h = 1e-6 / lam
    slope = np.array([(length_increment(length, lam, s + h, adt)
                       - length_increment(length, lam, max(s - h, 0.0), adt))
                      / (s + h - max(s - h, 0.0)) for s in sigma])
    bound = largest_increment_slope(length, lam, adt)
    assert np.all(np.abs(slope) <= bound * (1 + 1e-6))
    # attained at sigma = 0: the one-sided difference there is O(h) from the bound
    assert abs(abs(slope[0]) - bound) <= 1e-5 * bound


def test_increment_and_grow_are_the_exponential_law():
    length, lam, sigma, dt = np.array([1.0, 1.5]), 1e-2, np.array([0.0, 30.0]), 0.01
    rate = np.exp(-lam * sigma)
    assert growth_rate(lam, 30.0) == pytest.approx(np.exp(-0.3), rel=1e-15)
    exact = length * np.exp(dt * rate)
    np.testing.assert_allclose(grow(length, sigma, lam, dt), exact, rtol=1e-15)
    inc = [length_increment(v, lam, s, dt) for v, s in zip(length, sigma, strict=True)]
    np.testing.assert_allclose(length + np.array(inc), exact, rtol=1e-14)
