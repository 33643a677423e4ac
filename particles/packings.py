"""Initial configurations of a colony, and dense packings to test the contact solvers on.

- :func:`single_cell`: one particle of length 1 at the origin (model.md's initial condition);
- :func:`from_csv`: the particles of a CSV file with columns x,y,theta,length (``Config.init``);
- :func:`ring_packing`: a dense, jammed, non-overlapping disc of rods on concentric rings: the
  synthetic states of ``python -m cases.bench.contact_solvers`` and of the solver tests, where
  growth along each ring pushes on the next ring out (a 2D-coupled, pressure-like load path);
- :func:`warm_problem`: from a solved packing, the warm-started problem of the next step.
"""

from __future__ import annotations

import os

import numpy as np

from .geometry import B, axial_stress, detect_contacts, generalised_forces
from .growth import grow
from .output import read_init
from .state import ParticleState
from .stepping import warm_start

__all__ = ["single_cell", "from_csv", "ring_packing", "warm_problem"]


def single_cell() -> ParticleState:
    """One particle of length l0 = 1 at the origin, angle 0 (t = 0).

    Returns
    -------
    ParticleState
        The one-cell colony, the default initial state of a run.
    """
    return ParticleState.from_arrays([0.0], [0.0], [0.0], [1.0])


def from_csv(path: str | os.PathLike) -> ParticleState:
    """The particles of a CSV file with a header and columns x,y,theta,length (t = 0).

    Parameters
    ----------
    path : str or path-like
        The CSV file (``Config.init``): one row per particle, centre (x, y), angle theta and
        tip-to-tip length l.

    Returns
    -------
    ParticleState
        The particles at t = 0.

    Raises
    ------
    ValueError
        With one line naming the file, when it is missing, not text, lacks a column, holds a
        non-numeric or non-finite value, or a length <= b.
    """
    try:
        arrays = read_init(path)
    except UnicodeDecodeError:
        raise ValueError(f"init file {path} is not a text CSV file") from None
    try:
        return ParticleState.from_arrays(*arrays)
    except ValueError as err:
        raise ValueError(f"init file {path}: {err}") from None


def ring_packing(n_target: int, seed: int = 0, gap: float = 1e-3, lmin: float = 1.0,
                 lmax: float = 1.9, r0: float = 3.0) -> tuple[np.ndarray, ...]:
    """Dense non-overlapping disc of rods on concentric rings (module docstring).

    Ring m has radius r_m (rod centre lines are chords of it); rods of segment length
    L = l - b subtend 2 asin(L / (2 r)); consecutive rods are separated along the ring so
    that their facing endpoints are b + g apart (g = gap * U(0.5, 1.5)); the leftover angle
    of each ring is spread over its end gaps.  The next ring lies at
    r_{m+1} = r_m + b + g + Lmax^2 / (8 r_m) (chord sagitta), so rods of adjacent rings
    never overlap.  Rings are added until n_target rods are placed.

    Parameters
    ----------
    n_target : int
        Least number of rods; the last ring is filled, so there may be more.
    seed : int
        Seed of the random lengths, gaps and ring phases (numpy.random.default_rng).
    gap : float
        Mean gap g between facing rod ends (g = gap * U(0.5, 1.5)).
    lmin, lmax : float
        Range of the tip-to-tip lengths l, drawn uniformly.
    r0 : float
        Radius of the first ring tried (a ring that holds fewer than three rods is skipped).

    Returns
    -------
    x, y, theta, length : arrays
        Centres, angles and tip-to-tip lengths of the rods.
    """
    rng = np.random.default_rng(seed)
    xs, ys, ts, ls = [], [], [], []
    r = r0
    count = 0
    while count < n_target:
        lengths, angles = [], []
        used = 0.0
        while True:
            ln = rng.uniform(lmin, lmax)
            seg = 2.0 * np.arcsin(min(1.0, (ln - B) / (2.0 * r)))
            sep = 2.0 * np.arcsin(min(1.0, (B + gap * rng.uniform(0.5, 1.5)) / (2.0 * r)))
            if used + seg + sep > 2.0 * np.pi:
                break
            lengths.append(ln)
            angles.append((seg, sep))
            used += seg + sep
        if len(lengths) < 3:
            r += B + gap + (lmax - B) ** 2 / (8.0 * r)
            continue
        extra = (2.0 * np.pi - used) / len(lengths)
        phi = rng.uniform(0.0, 2.0 * np.pi)
        for ln, (seg, sep) in zip(lengths, angles, strict=True):
            mid = phi + 0.5 * seg
            rc = r * np.cos(0.5 * seg)
            xs.append(rc * np.cos(mid))
            ys.append(rc * np.sin(mid))
            ts.append(mid + 0.5 * np.pi)
            ls.append(ln)
            phi += seg + sep + extra
        count += len(lengths)
        r += B + gap * rng.uniform(0.5, 1.5) + (lmax - B) ** 2 / (8.0 * r)
    return np.array(xs), np.array(ys), np.array(ts), np.array(ls)


# The state's four arrays, the solved contacts and forces, and the step: positional callers
# (cases/bench, tests) pass all nine.
def warm_problem(x, y, theta, length, c, gamma, dt, lam, margin):  # noqa: PLR0913
    """The warm-started problem of the next step: a contact solver's test problem.

    One engine update with forces gamma (x += dt F / l, theta += dt 12 T / l^3, (F, T) =
    D gamma; l <- l exp(dt exp(-lam sigma)), sigma = G gamma), the contacts of the new
    configuration with gap <= margin, and their warm start (the forces gamma of the contacts
    whose identity persists, 0 for new ones: stepping.warm_start), as the engine does
    (stepping.step).

    Returns
    -------
    (x2, y2, theta2, length2), contacts2, gamma0
    """
    n = x.shape[0]
    ids = np.arange(n, dtype=np.int64)
    fx, fy, tz = generalised_forces(c, gamma, n)
    stress = axial_stress(c, gamma, n)
    x2 = x + dt * fx / length
    y2 = y + dt * fy / length
    th2 = theta + dt * 12.0 * tz / length**3
    l2 = grow(length, stress, lam, dt)
    c2 = detect_contacts(x2, y2, th2, l2, margin)
    return (x2, y2, th2, l2), c2, warm_start(c2.keys(ids), c.keys(ids), gamma)
