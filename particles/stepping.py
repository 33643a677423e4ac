"""One time step of the particle colony: detect, solve, move and grow, re-solve; halving; dt.

One step of length dt from state (x, theta, l) (model.md, "Discrete model"):

1. candidate pairs by cell lists, contacts with gap phi_k <= ``contact_margin`` (geometry.py);
2. the convex problem E(gamma) solved by the selected solver (solvers/), warm-started
   from the previous step's forces matched by contact identity (particle ids + endpoint code);
3. update x += dt F / l, theta += dt 12 T / l^3 (F, T = D gamma, l at the start of the step),
   l <- l exp(dt exp(-lam sigma)), sigma = G gamma;
4. re-detect contacts on the new configuration; while the real overlap max(b - d) exceeds
   ``tol``, solve the overlap-removal problem (the same E without growth, Phi = the new gaps,
   mobility at the new lengths) and move by dt M D gamma'; those forces act over the same step and
   are added to the stress sigma.  At most ``max_passes`` passes, each of at most
   max(PASS_ITERATION_FLOOR, iterations of step 2) iterations, else OverlapError or
   ContactSolveError, upon which the step is redone from the same state as two steps of dt/2
   (``robust_step``, nested up to dt/16);
5. divide particles with l >= 2 and put them in spatial order (division.divide_in_order; done
   by ``Simulation.step`` after this module's :func:`robust_step`, with the time, step count
   and warm start).

The next step's length follows ``Config.step_control`` (:func:`next_dt`): "overlap" (the
default: keep the overlap the linearised step leaves near MAIN_OVERLAP), "fixed" (``dt``) or
"cost" (follow the cost of the re-solve passes); ``dt`` is the first and the largest step.

The step's diagnostics (``simulation.StepRecord``) are the real overlap after step 4, the
solver iterations of steps 2 and 4 together (``iterations``), those of step 4 alone
(``pass_iterations``), the iterations of attempts that failed and were redone as half steps
(``failed_iterations``); ``state.stress`` receives the stress sigma of steps 2 and 4.
"""

from __future__ import annotations

import math
import os
import time as _time
from typing import TYPE_CHECKING

import numba
import numpy as np

from .geometry import Contacts, find_contacts, generalised_forces
from .growth import grow
from .neighbours import candidate_pairs
from .nutrients import nutrient_at_cells, uptake
from .solvers import BY_NAME, ContactSolveError
from .state import ParticleState
from .strains import growth_law
from .stress import axial_stress

if TYPE_CHECKING:
    from .config import Config

THREADS_MIN_PARTICLES = 20_000
"""``Config.threads = "auto"``: more than one thread from this many particles on.  Measured on
this project's 2-core machine, one run alone (docs/benchmarks.md, "Threads"): two threads
1.34x faster at 32,768 particles (lam = 0), 0.94-1.6x at 1e4, 1.1-1.2x at 1e3."""


def solver_threads(threads: int | str, n: int) -> int:
    """Numba threads of a step of ``n`` particles.

    ``threads`` itself when it is a number; for "auto" one thread below
    THREADS_MIN_PARTICLES and every core the process may use (at most NUMBA_NUM_THREADS)
    from there on.  The iterates do not depend on it (solvers.bbpgd.BLOCK).
    """
    if threads != "auto":
        return threads
    if n < THREADS_MIN_PARTICLES:
        return 1
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return max(1, min(numba.config.NUMBA_NUM_THREADS, cores or 1))


class OverlapError(RuntimeError):
    """The re-solve passes could not bring the real overlap within tolerance."""


def warm_start(keys: np.ndarray, prev_keys: np.ndarray, prev_gamma: np.ndarray) -> np.ndarray:
    """Previous forces of the contacts whose identity persists, 0 for new contacts.

    The previous keys sorted (NumPy's argsort, serial: 0.25 % of a one-thread step at 1e5
    particles), then each key looked up in them by bisection, contact by contact in parallel
    (:func:`_lookup`; the same for any number of threads).
    """
    if prev_keys.size == 0 or keys.size == 0:
        return np.zeros(keys.shape[0])
    prev_keys = np.ascontiguousarray(prev_keys, dtype=np.int64)
    return _lookup(np.ascontiguousarray(keys, dtype=np.int64), prev_keys, np.argsort(prev_keys),
                   np.ascontiguousarray(prev_gamma, dtype=np.float64))


@numba.njit(cache=True, parallel=True)
def _lookup(keys, prev_keys, order, values):
    """values[order[p]] where prev_keys[order[p]] == keys[k] (the first such p), else 0, per k.

    ``order``: the permutation that sorts ``prev_keys``.
    """
    n = prev_keys.shape[0]
    sorted_keys = np.empty(n, dtype=np.int64)
    for p in numba.prange(n):
        sorted_keys[p] = prev_keys[order[p]]
    out = np.zeros(keys.shape[0])
    for k in numba.prange(keys.shape[0]):
        key = keys[k]
        lo = 0
        hi = n
        while lo < hi:  # the first p with sorted_keys[p] >= key (np.searchsorted, left)
            mid = (lo + hi) >> 1
            if sorted_keys[mid] < key:
                lo = mid + 1
            else:
                hi = mid
        if lo < n and sorted_keys[lo] == key:
            out[k] = values[order[lo]]
    return out


class Detections:
    """The contacts of the configuration last detected, kept while it stays the same.

    A step ends with a detection of its final configuration (the overlap check), and the next
    step begins with one of the same configuration unless a division (or the caller) changed
    it; :func:`detect` then returns the kept contacts.  The configuration is compared bit for
    bit (x, y, theta, length and the margin), so the contacts are those a new detection would
    find, and a run is the same with or without the cache.
    """

    def __init__(self):
        self.key: tuple | None = None
        self.contacts: Contacts | None = None

    @staticmethod
    def _config(state: ParticleState) -> tuple[np.ndarray, ...]:
        return tuple(np.ascontiguousarray(a, dtype=np.float64).view(np.int64)
                     for a in (state.x, state.y, state.theta, state.length))

    def get(self, state: ParticleState, margin: float) -> Contacts | None:
        """The kept contacts if ``state`` and ``margin`` are those of the last detection."""
        if self.key is None or self.key[0] != margin:
            return None
        same = all(np.array_equal(a, b) for a, b in zip(self.key[1:], self._config(state),
                                                        strict=True))
        return self.contacts if same else None

    def put(self, state: ParticleState, margin: float, contacts: Contacts) -> None:
        """Keep ``contacts`` as those of ``state`` (a copy of its configuration) at ``margin``."""
        self.key = (margin, *(a.copy() for a in self._config(state)))
        self.contacts = contacts


def detect(state: ParticleState, margin: float, timers: dict | None = None,
           detections: Detections | None = None) -> Contacts:
    """Contacts of the current configuration with gap <= margin (geometry.detect_contacts).

    ``timers`` (optional) accumulates wall seconds under "neighbours" and "geometry";
    ``detections`` (optional): the contacts of the last detection, reused when the
    configuration is the same (:class:`Detections`).
    """
    if detections is not None and (kept := detections.get(state, margin)) is not None:
        return kept
    t0 = _time.perf_counter()
    pairs = candidate_pairs(state.x, state.y, state.length, margin)
    t1 = _time.perf_counter()
    c = find_contacts(state.x, state.y, state.theta, state.length, pairs, margin, ids=state.ids)
    if timers is not None:
        timers["neighbours"] = timers.get("neighbours", 0.0) + t1 - t0
        timers["geometry"] = timers.get("geometry", 0.0) + _time.perf_counter() - t1
    if detections is not None:
        detections.put(state, margin, c)
    return c


def _tick(timers: dict | None, key: str, t0: float) -> float:
    t1 = _time.perf_counter()
    if timers is not None:
        timers[key] = timers.get(key, 0.0) + t1 - t0
    return t1


def _move(state: ParticleState, c: Contacts, gamma: np.ndarray, dt: float,
          length: np.ndarray) -> None:
    """Overdamped motion x += dt F / l, theta += dt 12 T / l^3, (F, T) = D gamma."""
    fx, fy, tz = generalised_forces(c, gamma, state.n)
    state.x += dt * fx / length
    state.y += dt * fy / length
    state.theta += dt * 12.0 * tz / length**3


PASS_ITERATION_FLOOR = 1000
"""A re-solve pass may take max(PASS_ITERATION_FLOOR, the step's main-solve iterations)
iterations; beyond, the step is redone as half steps.  Measured (lam = 1e-3 and 1e-4 to radius
40, dt = 0.0025-0.01, 2,600 passes): a pass that converges takes at most 0.3 of the main solve's
iterations in 99 % of cases and never more than 190 iterations where the step size is right;
at dt = 0.01 and lam = 1e-3 a few passes took 22,000 to 200,000 (the cap) before the step was
halved anyway."""


def motion(state: ParticleState, x0: np.ndarray, y0: np.ndarray, theta0: np.ndarray) -> dict:
    """Largest rotation ``max_n abs(theta_n - theta0_n)`` and displacement of a particle in a step.

    Diagnostics (history.csv): large turns were the suspected cause of failed steps at paper
    scale, but they are not a predictor (lam = 0, radius 40, dt = 0.01: median 0.14 rad, 1 %
    of the steps above 1.2 rad, none halved: rods at the edge turn freely); the step control
    uses the overlap the turns leave (``main_overlap``, :func:`next_dt`).
    """
    if state.n == 0:
        return {"max_rotation": 0.0, "max_displacement": 0.0}
    return {"max_rotation": float(np.abs(state.theta - theta0).max()),
            "max_displacement": float(np.hypot(state.x - x0, state.y - y0).max())}


def _solve(solver, spent: list, *args, **kwargs):
    """solver(*args, **kwargs), adding its iterations to spent[0] whether or not it converges."""
    try:
        gamma, hist = solver(*args, **kwargs)
    except ContactSolveError as e:
        spent[0] += len(e.residuals) - 1
        raise
    spent[0] += len(hist) - 1
    return gamma, hist


def step(state: ParticleState, config: Config, dt: float,  # noqa: PLR0913
         warm: tuple[np.ndarray, np.ndarray], timers: dict | None = None,
         spent: list | None = None, detections: Detections | None = None
         ) -> tuple[dict, tuple[np.ndarray, np.ndarray]]:
    """Advance the particles by one step of length dt in place (module docstring, items 1-4).

    No division, and t, step and the warm start of ``state`` are left to the caller
    (``Simulation.step``).

    Returns the step's diagnostics (iterations, pass_iterations, passes, n_contacts, residual,
    max_overlap, and the contacts and forces of the main solve) and the (keys, gamma) of the
    solve for the next warm start.  ``timers`` (optional dict) accumulates wall seconds per
    phase: neighbours, geometry, solver, update; ``spent`` (optional one-element list)
    accumulates the solver iterations, also of a step that raises; ``detections`` (optional)
    keeps the last detection for the next (:class:`Detections`).
    """
    solver = BY_NAME[config.solver]
    numba.set_num_threads(solver_threads(config.threads, state.n))
    stol = config.effective_solver_tol
    margin = config.contact_margin
    spent = [0] if spent is None else spent
    n = state.n
    start = (state.x.copy(), state.y.copy(), state.theta.copy())
    c = detect(state, margin, timers, detections)
    t0 = _time.perf_counter()
    keys = c.keys(state.ids)
    gamma0 = warm_start(keys, *warm)
    t0 = _tick(timers, "update", t0)
    lam, rate = growth_law(config.strains, config.lam, state.strain)
    if config.nutrient is not None:  # the nutrient's factor f(c_n) of the state at the start
        rate = rate * nutrient_factor(state, lam, rate, config.nutrient, config.dish_radius)
    gamma, hist = _solve(solver, spent, c, state.length, dt, lam, gamma0, stol,
                         config.max_iterations, True, rate=rate)
    t0 = _tick(timers, "solver", t0)
    main_iterations = len(hist) - 1
    pass_cap = min(config.max_iterations, max(PASS_ITERATION_FLOOR, main_iterations))
    stress = axial_stress(c, gamma, n)
    l0 = state.length
    _move(state, c, gamma, dt, l0)
    state.length = grow(l0, stress, lam, dt, rate)
    _tick(timers, "update", t0)
    passes = 0
    pass_iterations = 0
    while True:
        c2 = detect(state, margin, timers, detections)
        overlap = max(0.0, -float(c2.gap.min())) if len(c2) else 0.0
        if passes == 0:
            main_overlap = overlap
        if overlap <= config.tol:
            break
        if passes >= config.max_passes:
            raise OverlapError(
                f"overlap {overlap:.3g} > tol {config.tol:g} after {passes} re-solve passes "
                f"(N={n}, dt={dt:g}); decrease dt")
        t0 = _time.perf_counter()
        g2, h2 = _solve(solver, spent, c2, state.length, dt, lam, None, stol, pass_cap,
                        False)
        t0 = _tick(timers, "solver", t0)
        pass_iterations += len(h2) - 1
        _move(state, c2, g2, dt, state.length)
        stress = stress + axial_stress(c2, g2, n)
        _tick(timers, "update", t0)
        passes += 1
    state.stress = stress
    info = {"iterations": main_iterations + pass_iterations, "pass_iterations": pass_iterations,
            "failed_iterations": 0, "passes": passes, "n_contacts": len(c),
            "residual": float(hist[-1]), "max_overlap": overlap, "contacts": c, "gamma": gamma,
            "main_overlap": main_overlap, **motion(state, *start)}
    return info, (keys, gamma)


MAX_HALVINGS = 4
"""A step that fails (OverlapError or ContactSolveError) is retried as two half steps, up to
this many times nested (dt / 16), before the error is raised."""


def nutrient_factor(state, lam, rate, nutrient: tuple[float, float, float],
                    dish: float | None = None) -> np.ndarray:
    """Each cell's f(c_n): the nutrient solved for the state's cells (particles.nutrients).

    The source's growth exp(-lam sigma_n) a_n takes the last contact solve's stress. ``dish``:
    R_dish (``Config.dish_radius``), None for supply at the colony's edge.
    """
    ell, K, h = nutrient
    growth = rate * np.exp(-np.asarray(lam) * state.stress)
    c = nutrient_at_cells(state.x, state.y, state.length, growth, ell, K, h, dish)
    return uptake(c, K)


def robust_step(state: ParticleState, config: Config, dt: float,  # noqa: PLR0913
                warm: tuple[np.ndarray, np.ndarray], timers: dict | None = None,
                depth: int = 0, detections: Detections | None = None
                ) -> tuple[dict, tuple[np.ndarray, np.ndarray]]:
    """:func:`step`, retried from the same state as two steps of dt/2 when it fails.

    The returned info sums the iteration counts and passes over the sub-steps (the failed
    attempts' iterations under ``failed_iterations``), reports the largest overlap and residual,
    and counts the sub-steps (``substeps``).  Deterministic.  ``detections``: as in
    :func:`step`.
    """
    backup = {name: value.copy() for name, value in state.arrays().items()}
    spent = [0]
    try:
        info, warm2 = step(state, config, dt, warm, timers, spent, detections)
        info["substeps"] = 1
        return info, warm2
    except (OverlapError, ContactSolveError):
        if depth >= MAX_HALVINGS:
            raise
    for name, value in backup.items():
        setattr(state, name, value)
    a, warm = robust_step(state, config, dt / 2, warm, timers, depth + 1, detections)
    b, warm = robust_step(state, config, dt / 2, warm, timers, depth + 1, detections)
    info = dict(b)
    for k in ("iterations", "pass_iterations", "failed_iterations", "passes", "substeps"):
        info[k] = a[k] + b[k]
    info["failed_iterations"] += spent[0]
    for k in ("max_overlap", "residual", "max_rotation", "max_displacement", "main_overlap"):
        info[k] = max(a[k], b[k])
    return info, warm


DT_GROWTH, DT_SHRINK = 1.02, 0.7
"""Factors of the "cost" control of :func:`next_dt`."""

MAIN_OVERLAP = 0.15
"""Real overlap after the main move (0.3 b) that the "overlap" control aims at; see
:func:`next_dt` for the measurement behind it."""

DT_RISE = 1.25
"""The "overlap" control lengthens the step by at most this factor per step."""


def next_dt(dt: float, info: dict, dt_max: float, control: str = "overlap") -> float:
    """Length of the next step after a step of length dt with diagnostics ``info``.

    ``control`` = "fixed": dt_max.

    "overlap": a step moves the rods with contacts linearised about its start; the real overlap
    e after that move (``main_overlap``, before the re-solve passes) is the linearisation's
    error, second order in the motion, so e ~ dt^2.  Measured (lam = 0 to radius 40, dt = 0.02,
    N > 1000): the passes cost 2-9 % of the main solve where e < 0.1, 16 % where e is in
    [0.1, 0.3), 38 % above, and every halved step followed a step with e >= 0.35 (e saturates at
    b = 0.5: crossed rods, which the passes cannot separate).  At paper scale and small lam the
    same happens at any fixed dt the colony outgrows (docs/benchmarks.md).  The target
    MAIN_OVERLAP = 0.15 (measured to radius 40 against 0.05: 1.16x less CPU at lam = 1e-3,
    dt <= 0.01, docs/benchmarks.md) keeps a factor ~2.3 below the failures.  So

        dt' = min(dt_max, DT_RISE dt, dt sqrt(MAIN_OVERLAP / e)),

    and at most dt / 2 after a halved step.

    "cost": the main solve's work is nearly independent of dt (its iterations scale with dt),
    while the re-solve passes grow from a few percent of it to more than all of it, with failed
    attempts, once dt is too long for the colony's speeds (measured, lam = 1e-3 to radius 40:
    187,000 main iterations at dt = 0.005 and at 0.01; pass iterations 15,000 and 395,000).
    So, with r = pass_iterations / (main iterations):

        halved step (substeps > 1)  ->  dt / 2,
        r > 1/2                     ->  DT_SHRINK dt,
        r < 1/4                     ->  min(DT_GROWTH dt, dt_max),
        otherwise                   ->  dt.

    Both adaptive controls stay above dt_max / 2^(MAX_HALVINGS + 2).
    """
    if control == "fixed":
        return dt_max
    if control == "overlap":
        e = max(info["main_overlap"], 1e-300)
        new = min(dt_max, dt * min(DT_RISE, math.sqrt(MAIN_OVERLAP / e)))
        if info["substeps"] > 1:
            new = min(new, dt / 2)
    else:
        main = info["iterations"] - info["pass_iterations"]
        r = info["pass_iterations"] / max(main, 1)
        if info["substeps"] > 1:
            new = dt / 2
        elif r > 0.5:
            new = DT_SHRINK * dt
        elif r < 0.25:
            new = min(DT_GROWTH * dt, dt_max)
        else:
            new = dt
    return max(new, dt_max / 2 ** (MAX_HALVINGS + 2))
