"""How large a continuum run's mesh gets, and whether it fits in memory, before any meshing.

The mesh has boundary spacing h = min(h_max, h_N(A)) (``mesh.target_spacing``) and interior size
s(d) = min(c h, h + g d) at distance d from the edge (c = ``interior_coarsening``, g =
``grading``). An equilateral mesh of size s has 2 / (sqrt(3) s^2) nodes per unit area, so a domain
of area A and perimeter P has about

    N = 2 / sqrt(3) [ P / g (1/h - 1/(c h)) + max(A - P d*, 0) / (c h)^2 ],  d* = (c - 1) h / g

nodes (the graded band of width d* along the edge, then the coarse interior; c = 1: A / h^2),
and at least the P / h nodes of the boundary (a thin shape: ``ellipse:1e-6,1``).
Measured against runs at lam = 1e-2: 6 % above the run's node count at radius 12, 8 % above at
radius 40; ``tests/cases/test_faults.py::test_memory_estimate_against_a_run`` checks radius 12
(within 15 %).

The largest mesh is that of the initial or the final size: for a ``radius`` goal the area
pi R^2, for a ``time`` goal the least area the colony may have then (:func:`least_area`: the
exact disc's of continuum.radial; lam = 1e-2 to time 1000 is a radius of 14,000).
"""

from __future__ import annotations

import math
import os

import numpy as np

from continuum import mesh, radial

__all__ = ["BudgetError", "estimate_nodes", "available_memory", "check_memory", "least_area"]

#: Resident bytes per mesh node of a running solver (mesh, CSR matrices, AMG hierarchy, Psi on
#: the default 40 length cells, transfer matrices), measured: peak RSS minus the imported
#: modules' at radius 100 (lam = 1e-2, ~3.2e4 nodes), rounded up.
BYTES_PER_NODE = 8_000
#: Extra resident bytes per mesh node of the pressure's element (``Config.element``) over the
#: hand-written P1 assembly that BYTES_PER_NODE was measured with: the peak of two pressure
#: solves with velocity on a 46,577-node disc was 1.1 kB per node with P1 and 12.3 kB with P2
#: (scikit-fem; about 4 degrees of freedom and 46 matrix entries per node), rounded up.
ELEMENT_BYTES_PER_NODE = {"P1": 0, "P2": 12_000}
#: Resident bytes of the imported modules before any mesh (measured, rounded up).
BASE_BYTES = 400 * 2**20


class BudgetError(ValueError):
    """A run whose mesh cannot fit in this machine's memory (one-line message)."""


def estimate_nodes(area: float, perimeter: float, config) -> float:
    """Node count N of the graded mesh of a domain (formula in the module docstring)."""
    h = mesh.target_spacing(area, config.h_max, config.n_nodes)
    c, g = config.interior_coarsening, config.grading
    boundary = perimeter / h
    if c <= 1.0:
        return max(boundary, 2.0 / math.sqrt(3.0) * area / h**2)
    band = (c - 1.0) * h / g
    graded = perimeter / g * (1.0 / h - 1.0 / (c * h))
    interior = max(area - perimeter * band, 0.0) / (c * h) ** 2
    if perimeter * band > area:  # the band covers the domain: at most the uniform mesh
        return max(boundary, 2.0 / math.sqrt(3.0) * min(area / h**2, graded))
    return max(boundary, 2.0 / math.sqrt(3.0) * (graded + interior))


def available_memory() -> int:
    """Bytes of memory available to a new allocation (MemAvailable, else physical memory)."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


#: Share of the exact disc's area that :func:`least_area` takes as the least area: the engine's
#: disc grows within 1.3 % of the exact one at n_nodes = 200 (lam = 0 to 10, to t = 3;
#: ``tests/cases/test_absurd_input.py::test_least_area_below_a_run``), 5 % kept.
LEAST_AREA_MARGIN = 0.95


def least_area(area: float, lam: float, time: float, growth: float = 1.0) -> float:
    """The least area at ``time`` of a colony of this area at t = 0: a lower bound for a disc.

    The disc of this area grown by the exact radial solution (continuum.radial.radius), less
    LEAST_AREA_MARGIN for the engine's discretisation; other shapes of the same area hold a
    lower pressure (Saint-Venant) and grow faster. At least the bound of the maximum
    principle: g = exp(-lam p) <= 1 gives p <= (R^2 - r^2) / 4 on a disc (the pressure at
    lam = 0), so dA/dt = int g dA >= (4 pi / lam) (1 - exp(-x)), x = lam A / (4 pi): e^x - 1
    grows at least as e^t, A(t) >= (4 pi / lam) ln(1 + (e^x0 - 1) e^t); A0 e^t for lam <= 0
    (its limit, and the exact disc's at lam = 0). inf where it overflows.

    ``growth``: a colony whose every growth rate is at least growth exp(-lam p) (strains: the
    least growth factor and the largest lam); the colony of rate a exp(-lam p) at time t is
    that of exp(-a lam p) at time a t (p = a q).
    """
    lam, time = lam * growth, time * growth
    x0 = lam * area / (4.0 * math.pi)
    if x0 <= 0.0:  # lam <= 0, or lam * area below the smallest float
        return area * math.exp(time) if time < 700.0 else math.inf
    x = float(np.logaddexp(0.0, math.log(math.expm1(x0)) + time))
    bound = 4.0 * math.pi * x / lam
    with np.errstate(all="ignore"):
        try:
            r = radial.radius(time, lam, math.sqrt(area / math.pi))
        except (ValueError, OverflowError, FloatingPointError):
            return bound
    disc = LEAST_AREA_MARGIN * math.pi * r * r if math.isfinite(r) else math.inf
    return max(bound, disc)


def _slowest_growth(config) -> tuple[float, float]:
    """(lam, a): the largest lam and the least growth factor of the colony's strains.

    Without strains (lam, 1): the model's one strain.
    """
    if not config.strains:
        return config.lam, 1.0
    return max(s.lam for s in config.strains), min(s.growth for s in config.strains)


def largest_nodes(config, start: tuple | None = None,
                  goal: tuple | None = None) -> tuple[float, str, float]:
    """Largest estimated node count of the run, when it is reached, and the final radius.

    ``start``: (boundary polygon, t) of the colony now, default the configuration's initial
    shape at t = 0; ``goal``: (radius, time), one of them None, default the configuration's.
    A ``radius`` goal ends with area pi R^2, a ``time`` goal with at least :func:`least_area`
    after time - t, and the start's perimeter scaled by sqrt(A_final / A_start); no goal is
    estimated at the start's size only. "initial" or "final"; inf where a size overflows.
    """
    polygon, t = (config.initial_boundary(), 0.0) if start is None else start
    radius, time = (config.radius, config.time) if goal is None else goal
    area = abs(mesh.polygon_area(polygon))
    perimeter = float(mesh.boundary_spacing(polygon).sum())
    n_initial = estimate_nodes(area, perimeter, config)
    if radius is not None:
        final_area = max(math.pi * radius * radius, area)
    elif time is not None and config.nutrient_length is not None:
        final_area = area  # a nutrient-limited colony may grow far slower: no bound is claimed
    elif time is not None:
        lam, growth = _slowest_growth(config)
        final_area = least_area(area, lam, max(time - t, 0.0), growth)
    else:
        return n_initial, "initial", math.sqrt(area / math.pi)
    final_radius = math.sqrt(final_area / math.pi)
    if not math.isfinite(final_area):
        return math.inf, "final", final_radius
    n_final = estimate_nodes(final_area, perimeter * math.sqrt(final_area / area), config)
    return (n_final, "final", final_radius) if n_final > n_initial else (n_initial, "initial",
                                                                           final_radius)


def check_memory(config, memory: int | None = None, *, start: tuple | None = None,
                 goal: tuple | None = None) -> float:
    """Raise BudgetError when the run's largest mesh would not fit in memory.

    ``memory`` in bytes, default the available memory; ``start`` and ``goal`` those of
    :func:`largest_nodes` (default: the configuration's shape at t = 0 and its goal). Returns
    the estimated node count.
    """
    radius, time = (config.radius, config.time) if goal is None else goal
    try:
        nodes, when, final_radius = largest_nodes(config, start, goal)
    except OverflowError:  # an integer setting beyond the range of floats (n_nodes)
        nodes, when, final_radius = math.inf, "initial", math.nan
    per_node = BYTES_PER_NODE + ELEMENT_BYTES_PER_NODE.get(getattr(config, "element", "P1"), 0)
    need = BASE_BYTES + per_node * nodes
    memory = available_memory() if memory is None else memory
    if not need <= memory:  # also NaN
        goal_text = ("" if when == "initial" else f" (radius {radius:g})"
                     if radius is not None else f" (time {time:g})")
        if when == "final" and radius is None:
            goal_text += (f", a radius of at least {final_radius:.3g}"
                          if final_radius < 1e300 else ", a radius beyond 1e+300")
        about = f"about {nodes:.3g}" if nodes < 1e300 else "more than 1e+300"
        gib = f"~{need / 2**30:.3g} GiB" if nodes < 1e300 else "beyond any memory"
        raise BudgetError(
            f"shape {config.shape} needs {about} mesh nodes at its {when} size{goal_text} "
            f"({gib}) at h_max = {config.h_max:g}, more than the {memory / 2**30:.3g} GiB "
            "available; raise h_max or interior_coarsening, or take a smaller shape or a "
            "nearer goal")
    return nodes
