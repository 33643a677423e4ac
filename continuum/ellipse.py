"""The exact lam = 0 ellipse (model.md), a reference for the moving boundary.

With lam = 0 the pressure in x^2/a^2 + y^2/b^2 < 1 is p = (1 - x^2/a^2 - y^2/b^2) / (2/a^2 +
2/b^2), so u = -grad p is linear and the colony stays an ellipse whose semi-axes follow

    da/dt = a b^2 / (a^2 + b^2),    db/dt = b a^2 / (a^2 + b^2).

:func:`semi_axes` integrates this system; :func:`moment_axes` measures the semi-axes of a
polygon (a computed boundary) by its area moments.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike
from scipy.integrate import solve_ivp

__all__ = ["moment_axes", "semi_axes"]


def semi_axes(a0: float, b0: float, t: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Semi-axes (a(t), b(t)) of the lam = 0 ellipse from (a0, b0), to rtol 1e-12.

    ``t`` is a time or an increasing array of times >= 0; the result has its shape.
    """
    times = np.atleast_1d(np.asarray(t, dtype=float))

    def rate(_, z):
        a, b = z
        return [a * b**2 / (a**2 + b**2), b * a**2 / (a**2 + b**2)]

    sol = solve_ivp(rate, (0.0, float(times[-1])), [a0, b0], t_eval=times, rtol=1e-12,
                    atol=1e-15)
    shape = np.shape(t)
    return sol.y[0].reshape(shape), sol.y[1].reshape(shape)


def moment_axes(boundary: np.ndarray) -> tuple[float, float]:
    """Semi-axes (a, b) of the ellipse with the polygon's area moments.

    About the area centroid, I_xx = int x^2 dA / A = a^2 / 4 and I_yy = b^2 / 4 for an ellipse
    with axes along x and y; the polygon's moments by the shoelace formulas.
    """
    x, y = boundary[:, 0], boundary[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cr = x * yn - xn * y
    area = cr.sum() / 2
    cx = ((x + xn) * cr).sum() / (6 * area)
    cy = ((y + yn) * cr).sum() / (6 * area)
    ixx = ((x * x + x * xn + xn * xn) * cr).sum() / (12 * area) - cx**2
    iyy = ((y * y + y * yn + yn * yn) * cr).sum() / (12 * area) - cy**2
    return 2 * math.sqrt(ixx), 2 * math.sqrt(iyy)
