"""The growth law, written once: dl_n/dt = l_n exp(-lam sigma_n).

Between divisions a particle grows at the specific rate g_n = exp(-lam sigma_n)
(:func:`growth_rate`), sigma_n the axial stress (stress.axial_stress, ``ParticleState.stress``).
Over one step the stress sigma_n is that of the step's contact solve (held over the step), and
the length is updated exactly:

    l_n(t + dt) = l_n(t) exp(dt exp(-lam sigma_n))        (:func:`grow`),

so at lam = 0 the total length is exactly exp(t) times its initial value (division keeps length).
The contact solvers' kernels predict the same growth inside the solve, as the exact increment
l_n (exp(dt exp(-lam sigma_n)) - 1) (:func:`length_increment`; solvers/problem.py), and
its largest slope in the stress bounds the solvers' step (:func:`largest_increment_slope`).

:func:`growth_rate` is a Numba function (the kernels call it per particle); :func:`grow`
evaluates the same expression with NumPy on arrays (``growth_rate.py_func``).  The division
rule is in division.py.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def growth_rate(lam, sigma):
    """Specific growth rate g = (dl/dt) / l = exp(-lam sigma), the growth law.

    Parameters
    ----------
    lam : float
        Stress sensitivity lambda >= 0.
    sigma : float or array
        Axial stress sigma_n.

    Returns
    -------
    float or array
        exp(-lam sigma).  Numba; ``growth_rate.py_func(lam, sigma)`` is the same expression in
        NumPy (what :func:`grow` uses on arrays).
    """
    return np.exp(-lam * sigma)


@njit(cache=True)
def length_increment(length, lam, sigma, dt):
    """Exact length increment of a step, l (exp(dt exp(-lam sigma)) - 1), in Numba.

    The growth the contact solvers predict inside a solve (solvers/problem.particle_moves);
    :func:`grow` applies l + this (as l exp(dt exp(-lam sigma))).
    """
    return length * np.expm1(dt * growth_rate(lam, sigma))


def largest_increment_slope(length, lam, adt):
    """Largest slope of the step's increment in the stress: l lam a dt exp(a dt), at sigma = 0.

    dl = l (exp(a dt exp(-lam sigma)) - 1) is the step's length increment
    (:func:`length_increment` with growth factor a); its slope in the stress is
    -l lam a dt exp(-lam sigma) exp(a dt exp(-lam sigma)), largest in size at sigma = 0.  The
    curvature bound of the growth term of the contact problem (solvers/apgd.lipschitz_bound).
    Arrays: ``length``, ``lam`` and ``adt`` = a dt of each cell (or numbers).
    """
    return length * lam * adt * np.exp(adt)


def grow(length: np.ndarray, stress: np.ndarray, lam, dt: float, rate=1.0) -> np.ndarray:
    """Lengths after a step: l(t + dt) = l exp(a dt exp(-lam sigma)), sigma held over the step.

    Parameters
    ----------
    length : array (N,)
        l_n at the start of the step.
    stress : array (N,)
        Axial stress sigma_n of the step.
    lam : float or array (N,)
        Stress sensitivity lambda >= 0 (of every cell, or of each: strains, particles.strains).
    dt : float
        Step length.
    rate : float or array (N,)
        Growth factor a > 0 (1: the model of one strain; a dt = dt exactly).

    Returns
    -------
    array (N,)
        The lengths l_n(t + dt).
    """
    return length * np.exp((rate * dt) * growth_rate.py_func(lam, stress))
