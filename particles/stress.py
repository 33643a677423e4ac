"""The particle stress: the axial stress sigma = G gamma, the load that slows growth.

A contact k between particles i and j carries a force gamma_k >= 0 (the step's contact solve,
solvers/) and growth coefficients G_ik = -d phi_k / d l_i, G_jk = -d phi_k / d l_j
(geometry.py: ``(1/2) |p . n_k|`` at a segment end, 0 at an interior point).  The axial stress
of particle n is the generalised force conjugate to its length (model.md),

    sigma_n = sum over n's contacts k of G_nk gamma_k        (:func:`axial_stress`),

and its growth rate is exp(-lam sigma_n) (growth.py).  The stress of a step
(``ParticleState.stress``) is that of the main solve plus that of every re-solve pass of the
step (stepping.step); daughters start at 0 until the next solve (division.py).  Called
``stress`` everywhere in the package (``ParticleState.stress``, particles.csv, the trajectory's
``log/particles/stress``).
"""

from __future__ import annotations

import numpy as np

from .geometry import Contacts


def axial_stress(c: Contacts, gamma: np.ndarray, n: int) -> np.ndarray:
    """Axial stress (load) sigma = G gamma of every particle, the quantity of the growth law.

    sigma_n = sum over n's contacts k of G_nk gamma_k, G_nk = -d phi_k / d l_n: the generalised
    force conjugate to the length l_n (model.md); ``(1/2) gamma_k |p_n . n_k|`` for a contact at
    a segment end.  Called ``stress`` everywhere in the package (``ParticleState.stress``,
    particles.csv, the trajectory's ``log/particles/stress``).

    Parameters
    ----------
    c : Contacts
        The contacts (pairs i, j and growth coefficients G_ik, G_jk) of the configuration.
    gamma : array (M,)
        Contact forces gamma_k >= 0.
    n : int
        Number of particles N.

    Returns
    -------
    sigma : array (N,)
        Axial stress sigma_n = sum_k G_nk gamma_k of every particle (0 without contacts).
    """
    return np.bincount(c.i, c.gi * gamma, n) + np.bincount(c.j, c.gj * gamma, n)
