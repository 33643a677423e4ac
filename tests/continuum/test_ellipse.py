"""The exact lam = 0 ellipse (continuum.ellipse): the reference of the moving-boundary tests."""

import math

import numpy as np
import pytest

from continuum import ellipse, mesh


def test_moment_axes_of_an_ellipse_polygon():
    a, b = ellipse.moment_axes(mesh.ellipse_polygon(3.0, 1.5, 4000) + [0.7, -0.2])
    assert a == pytest.approx(3.0, rel=1e-5) and b == pytest.approx(1.5, rel=1e-5)


def test_semi_axes():
    """A circle stays a circle, a = b = a0 exp(t/2); the area pi a b grows as exp(t)."""
    a, b = ellipse.semi_axes(1.0, 1.0, 2.0)
    assert (a, b) == pytest.approx((math.e, math.e), rel=1e-10)
    t = np.linspace(0.0, 1.5, 7)
    a, b = ellipse.semi_axes(2.0, 1.0, t)
    np.testing.assert_allclose(a * b, 2.0 * np.exp(t), rtol=1e-10)
    assert np.all(np.diff(a / b) < 0)  # the aspect ratio relaxes towards 1
