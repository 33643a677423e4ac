"""Strains: an inherited growth trait carried by every cell (issue 32).

A colony of S strains i = 0..S-1 (``Config.strains``: pairs (lam_i, a_i)). Cell n of strain
s_n (``ParticleState.strain``) grows as ::

    dl_n/dt = a_{s_n} l_n exp(-lam_{s_n} sigma_n),

its stress sensitivity lam_i and growth factor a_i those of its strain, and a daughter inherits
its mother's strain (division.divide). No strains (the default) is one strain (``lam``, 1): the
model and the bits of a run as before. Identical strains give that run bit for bit: the per-cell
parameters are the same numbers, a_i dt = dt exactly for a_i = 1.

The engine carries the strain as data: the growth law reads (lam_n, a_n) per cell
(:func:`growth_law`), the contact solve predicts each cell's growth with them
(solvers/problem.py), the outputs carry s_n (particles.csv column ``strain``, trajectory.gsd's
particle types ``strain_i``). A layout is given as the fractions phi0(x, y) -> (n, S) of the
continuum's layouts (one specification for both engines): a cell draws its strain from the
fractions at its centre (:func:`draw_strains`; a pure layout decides it, a mixture draws it with
a generator of its own, so the division noise is that of a run without strains).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable

import numpy as np

__all__ = ["as_strains", "growth_law", "draw_strains", "STRAIN_SEED"]

STRAIN_SEED = 32
"""Second entry of the seed of the generator that draws a mixture's strains,
numpy.random.default_rng((Config.seed, STRAIN_SEED)): its own stream, not the division noise's."""


MAX_GROWTH = 100.0
"""Largest growth factor a of a strain: a cell of it doubles in ln 2 / a, and the step follows
the fastest strain (the continuum engine's twin constant is the same)."""

MAX_STRAINS = 64
"""Most strains of a colony (one particle type each in the trajectory)."""

MAX_LAM = 1e4
"""Largest stress sensitivity lam (``Config.lam``, a strain's lam): beyond it growth all but
stops. A disc colony's edge moves at most sqrt(2 / lam) per unit time (continuum.radial), 0.014
at 1e4: a cell length in 70 doubling times; the paper's lam are 0 to 0.1 (the continuum
engine's twin constant is the same)."""

LAM_CAP_WHY = (f"beyond {MAX_LAM:g} growth all but stops: a colony's edge moves at most "
               "sqrt(2/lam) per unit time, a cell length in 70 doubling times")
"""Why lam is capped at MAX_LAM, as the refusals say it."""


def as_strains(value) -> tuple[tuple[float, float], ...]:
    """The strains as a tuple of (lam_i, a_i) floats, checked (one-line ValueError).

    Each entry (lam,), (lam, growth) or {"lam": .., "growth": ..}; lam in [0, MAX_LAM], growth
    in (0, MAX_GROWTH] (default 1); at most MAX_STRAINS of them.
    """
    if isinstance(value, (str, bytes)) or not isinstance(value, (tuple, list)):
        raise ValueError(f"strains must be a list of (lam, growth) pairs, got {value!r}")
    if len(value) > MAX_STRAINS:
        raise ValueError(f"strains: {len(value)} given, at most {MAX_STRAINS}")
    return tuple(_strain(entry) for entry in value)


def _strain(entry) -> tuple[float, float]:
    """One strain (lam, growth), checked; the error names the field, as Config's others do."""
    if isinstance(entry, dict) and "lam" in entry and set(entry) <= {"lam", "growth"}:
        entry = (entry["lam"], entry.get("growth", 1.0))
    if not isinstance(entry, (tuple, list)) or len(entry) not in (1, 2):
        raise ValueError(f"strains must be (lam, growth) pairs, got {entry!r}")
    lam, growth = (*entry, 1.0)[:2]
    for name, v in (("lam", lam), ("growth", growth)):
        if isinstance(v, bool) or not isinstance(v, numbers.Real) or not math.isfinite(v):
            raise ValueError(f"strains must be valid: a strain's {name} must be a finite number, "
                             f"got {v!r}")
    if lam < 0:
        raise ValueError(f"strains must be valid: a strain's lam must be >= 0, got {lam!r}")
    if lam > MAX_LAM:
        raise ValueError(f"strains must be valid: a strain's lam must be in [0, {MAX_LAM:g}], "
                         f"got {lam!r} ({LAM_CAP_WHY})")
    if not 0 < growth <= MAX_GROWTH:
        raise ValueError(f"strains must be valid: a strain's growth must be in "
                         f"(0, {MAX_GROWTH:g}], got {growth!r}")
    return float(lam), float(growth)


def growth_law(strains, lam: float, strain: np.ndarray):
    """(lam_n, a_n): each cell's stress sensitivity and growth factor.

    No strains: (lam, 1.0), two numbers (the one strain of every cell); else two arrays (N,)
    indexed by the cells' strains.
    """
    if not strains:
        return lam, 1.0
    table = np.array(strains, dtype=np.float64)
    return table[strain, 0], table[strain, 1]


def draw_strains(fractions: Callable | np.ndarray, x: np.ndarray, y: np.ndarray,
                 n_strains: int, rng: np.random.Generator) -> np.ndarray:
    """Each cell's strain drawn from the fractions at its centre (int64 array (N,)).

    ``fractions``: phi0(x, y) -> (N, S) (rows in [0, 1] summing to 1, e.g. the continuum's
    layouts continuum.strains.core, sector, mixture), or the strains themselves, integers in
    [0, S). Cell n takes strain i with probability phi_i(x_n, y_n): one uniform draw per cell
    from ``rng`` in index order, compared with the cumulative fractions, so a pure layout
    (every phi 0 or 1) decides without chance.
    """
    n = len(x)
    if not callable(fractions):
        s = np.asarray(fractions)
        if s.shape != (n,) or s.dtype.kind not in "iu" or np.any(s < 0) or np.any(s >= n_strains):
            raise ValueError(f"strains must be {n} integers in [0, {n_strains}), got an array "
                             f"of shape {s.shape} and dtype {s.dtype}")
        return s.astype(np.int64)
    phi = np.asarray(fractions(np.asarray(x, float), np.asarray(y, float)), dtype=float)
    if phi.shape != (n, n_strains) or not np.all(np.isfinite(phi)):
        raise ValueError(f"the strain fractions must be finite, of shape ({n}, {n_strains}), "
                         f"got shape {phi.shape}")
    if np.any(phi < -1e-9) or np.any(phi > 1 + 1e-9) or np.any(np.abs(phi.sum(1) - 1) > 1e-9):
        raise ValueError("the strain fractions must lie in [0, 1] and sum to 1 at every cell")
    u = rng.uniform(size=n)
    cumulative = np.cumsum(phi, axis=1)
    return np.minimum((u[:, None] >= cumulative).sum(axis=1), n_strains - 1).astype(np.int64)
