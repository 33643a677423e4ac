"""Motion of the colony: the material nodes, the growth phase and Psi over one time step.

Nodes are material points, dx/dt = u(x, t), integrated by Heun's method (RK2,
:func:`heun_step`)::

    x* = x^n + dt u(x^n),   x^{n+1} = x^n + dt/2 (u(x^n) + u(x*)),

with the growth phase advanced by the trapezoidal rule along the same paths::

    G^{n+1} = G^n + dt/2 (g(x^n) + g(x*)),

with every strain's growth phase likewise, G_i^{n+1} = G_i^n + dt/2 (g_i(p(x^n)) + g_i(p(x*))),
g_i = a_i exp(-lam_i p), and the strain fractions phi by the same increments
(continuum.strains.grown_fractions; the predictor's solve with the fractions grown by the Euler
increment dt g_i(p^n)), and Psi transported in l at the same mean growth rate
(continuum.sizes: exactly along the characteristics, a shift by dt g_avg / ln 2 in log2 l, or
by finite volumes). u and g
at x* come from a pressure solve on the moved mesh (continuum.darcy.darcy_flow), warm-started
from the linear extrapolation in time p^n + (p^n - p^{n-1}) dt / dt_prev; the solve at x^{n+1}
from the predictor's p* moved by its own gradient, p* - u(x*) . (x^{n+1} - x*) (measured: one
Newton iteration where p* alone needed two at radius 150). The step is halved (up to five
times) while the predictor or the corrector would invert an element or the predictor's
pressure solve fails.

Explicit node motion is stable only for dt <~ h / u_edge (short boundary wiggles grow,
elements invert), so ::

    dt = courant * h_boundary / max |u_boundary|     (:func:`stable_dt`),

h_boundary the shortest boundary edge. :func:`radius_rate` gives dR/dt of R = sqrt(A/pi) from
the boundary flux, for landing a run on a given radius.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from continuum.mesh import boundary_spacing, colony_radius, triangle_areas
from continuum.pressure import PressureDivergence
from continuum.state import State
from continuum.strains import grown_fractions, strain_rates
from continuum.velocity import boundary_normals

__all__ = ["Flow", "heun_step", "stable_dt", "radius_rate"]

Flow = Callable[..., tuple[np.ndarray, np.ndarray, np.ndarray]]
"""(points, p0[, fractions]) -> (p, u, g): the Darcy flow at these node positions (warm start
p0; with strains the fractions phi to solve with)."""


def stable_dt(boundary: np.ndarray, u_boundary: np.ndarray, courant: float) -> float:
    """Stable step ``dt = courant * min boundary edge / max |u|`` on the boundary.

    The limit of explicit node motion (module docstring).
    """
    umax = float(np.max(np.linalg.norm(u_boundary, axis=1)))
    return courant * float(boundary_spacing(boundary).min()) / max(umax, 1e-300)


def radius_rate(boundary: np.ndarray, u_boundary: np.ndarray) -> float:
    """dR/dt of R = sqrt(A/pi): dA/dt = sum_i (u_i . n_i) L_i over the boundary nodes.

    n_i, L_i the node normals and lumped lengths (continuum.velocity.boundary_normals), so
    dR/dt = (dA/dt) / (2 pi R).
    """
    n, L = boundary_normals(boundary)
    dA = float(np.sum(np.sum(u_boundary * n, axis=1) * L))
    return dA / (2 * math.pi * colony_radius(boundary))


def heun_step(state: State, flow: Flow, dt: float, lam: float, strains: tuple | None = None
              ) -> float:
    """Advance ``state`` by one Heun step of size dt (halved while it fails); returns the dt taken.

    In place: points, G, Psi, t, the step count, the warm start (p_prev, dt_prev), and p, u, g
    solved on the moved mesh; with strain fractions (``state.phi``) also each strain's G_i, of
    the ``strains`` (continuum.strains.Strain). ``flow`` is the Darcy solve (:data:`Flow`).

    Raises
    ------
    PressureDivergence
        Elements invert even for dt / 32, or the pressure solve fails for lam < 0 (no
        solution beyond the critical size: halving would not help).
    """
    tris = state.triangles
    for _ in range(6):
        x1 = state.points + dt * state.u
        guess = state.p
        if state.p_prev is not None:
            guess = state.p + (state.p - state.p_prev) * (dt / state.dt_prev)
        if np.all(triangle_areas(x1, tris) > 0):
            mixed = () if state.phi is None else (
                grown_fractions(state.phi, dt * strain_rates(state.p, strains)),)
            try:
                p1, u1, g1 = flow(x1, guess, *mixed)
            except PressureDivergence:
                if lam < 0:
                    raise
                dt *= 0.5
                continue
            x2 = state.points + 0.5 * dt * (state.u + u1)
            if np.all(triangle_areas(x2, tris) > 0):
                break
        dt *= 0.5
    else:
        raise PressureDivergence(f"mesh elements invert even for tiny steps at {state.where()}")
    t0 = time.perf_counter()
    g_avg = 0.5 * (state.g + g1)
    state.points = x2
    state.G = state.G + dt * g_avg
    if state.phi is not None:
        rates = 0.5 * (strain_rates(state.p, strains) + strain_rates(p1, strains))
        state.G_strains = state.G_strains + dt * rates
        state.phi = grown_fractions(state.phi, dt * rates)
    state.sizes.advance(g_avg, dt)
    state.timings["transport"] += time.perf_counter() - t0
    state.t += dt
    state.step += 1
    state.p_prev, state.dt_prev = state.p, dt
    # warm start at x2: p1 moved by its own gradient, p(x2) ~ p1 + grad p1 . (x2 - x1)
    mixed = () if state.phi is None else (state.phi,)
    state.p, state.u, state.g = flow(state.points, p1 - np.sum(u1 * (x2 - x1), axis=1), *mixed)
    return dt
