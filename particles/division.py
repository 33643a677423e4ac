"""The division rule, in one place: when a particle divides, into what, and the order after.

A particle with l_n >= 2 becomes two of length l_n / 2 centred at x_n +- (l_n / 4) p_n
(their outer tips are the mother's, their inner tips touch at x_n), with angles
theta_n + eps * U(-1, 1), an independent uniform perturbation per daughter of amplitude
eps = ``division_noise`` (radians) drawn from the run's seeded generator.  Both daughters get
new ids, parent = the mother's id and generation = the mother's generation + 1 (initial
particles: parent -1, generation 0).  So g_n is the number of divisions on the line of n back
to its initial ancestor a, and since division halves the length,

    l_n(t) = l_a(0) 2^(-g_n) prod_steps exp(dt exp(-lam sigma)),

sigma at each step the stress of the ancestor of n then alive.

After the divisions of a step the particles are put in spatial order (:func:`divide_in_order`,
neighbours.spatial_order); ids, lineage and contact identities do not depend on that order.
The growth law between divisions is in growth.py.
"""

from __future__ import annotations

import numpy as np

from .neighbours import spatial_order
from .state import ParticleState

DIVISION_LENGTH = 2.0
"""Particles divide when l_n >= 2 (twice the birth length l0 = 1)."""


def divide(state: ParticleState, rng: np.random.Generator, noise: float) -> int:
    """The division rule: every particle with l_n >= 2 becomes two, in place.

    Daughters of length l_n / 2 centred at x_n +- (l_n / 4) p_n, angles theta_n + eps U(-1, 1)
    (eps = ``noise``), stress zero until the next solve.

    Daughter 1 takes the mother's index, daughter 2 is appended; both get new ids (for m
    divisions of mothers i_1 < ... < i_m, daughter 1 of i_k gets next_id + k - 1 and daughter 2
    next_id + m + k - 1), parent = the mother's id and generation = the mother's generation
    + 1; both inherit the mother's strain (particles.strains).  Random numbers are drawn in
    index order (two per dividing particle), so runs are reproducible.

    Parameters
    ----------
    state : ParticleState
        The colony, changed in place (N grows by the number of divisions).
    rng : numpy.random.Generator
        Source of the angle perturbations U(-1, 1) (the state's ``rng`` in a run).
    noise : float
        Amplitude eps of the angle perturbations, in radians.

    Returns
    -------
    int
        The number of divisions m.
    """
    idx = np.flatnonzero(state.length >= DIVISION_LENGTH)
    m = idx.size
    if m == 0:
        return 0
    eps = noise * rng.uniform(-1.0, 1.0, size=(m, 2))
    x = state.x[idx]
    y = state.y[idx]
    th = state.theta[idx]
    half = 0.5 * state.length[idx]
    ox = 0.5 * half * np.cos(th)
    oy = 0.5 * half * np.sin(th)
    new_ids = state.next_id + np.arange(2 * m, dtype=np.int64)
    mother = state.ids[idx]
    gen = state.generation[idx] + 1
    state.next_id += 2 * m
    state.x[idx] = x + ox
    state.y[idx] = y + oy
    state.theta[idx] = th + eps[:, 0]
    state.length[idx] = half
    state.ids[idx] = new_ids[:m]
    state.parent[idx] = mother
    state.generation[idx] = gen
    state.stress[idx] = 0.0
    strain = None if state.strain is None else state.strain[idx]
    state.append(x - ox, y - oy, th + eps[:, 1], half, new_ids[m:], mother, gen, strain)
    return m


def divide_in_order(state: ParticleState, rng: np.random.Generator, noise: float) -> int:
    """The division rule (:func:`divide`), then the particles in spatial order.

    Reordered (neighbours.spatial_order) only if a particle divided: the daughters that
    :func:`divide` appends are far in memory from their neighbours in space otherwise.
    Returns the number of divisions.
    """
    divisions = divide(state, rng, noise)
    if divisions:
        state.permute(spatial_order(state.x, state.y))
    return divisions
