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
pi R^2, for a ``time`` goal the least area the colony may have then (:func:`least_area`).
"""

from __future__ import annotations

import math
import os

import numpy as np

from continuum import mesh

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


def least_area(area: float, lam: float, time: float) -> float:
    """The least area at ``time`` of a colony of this area at t = 0: a lower bound for a disc.

    g = exp(-lam p) <= 1 gives p <= (R^2 - r^2) / 4 on a disc (the pressure at lam = 0, by the
    maximum principle), so dA/dt = int g dA >= (4 pi / lam) (1 - exp(-x)), x = lam A / (4 pi):
    e^x - 1 grows at least as e^t, A(t) >= (4 pi / lam) ln(1 + (e^x0 - 1) e^t); A0 e^t for
    lam <= 0 (its limit). Other shapes of the same area hold a lower pressure (Saint-Venant)
    and grow faster. inf where it overflows.
    """
    x0 = lam * area / (4.0 * math.pi)
    if x0 <= 0.0:  # lam <= 0, or lam * area below the smallest float
        return area * math.exp(time) if time < 700.0 else math.inf
    x = float(np.logaddexp(0.0, math.log(math.expm1(x0)) + time))
    return 4.0 * math.pi * x / lam


def largest_nodes(config) -> tuple[float, str]:
    """Largest estimated node count of the run and when it is reached ("initial" or "final").

    A ``radius`` run ends with area pi R^2, a ``time`` run with at least :func:`least_area`,
    and the initial shape's perimeter scaled by sqrt(A_final / A_initial); a configuration
    without a goal is estimated at its initial size only. inf where a size overflows.
    """
    polygon = config.initial_boundary()
    area = abs(mesh.polygon_area(polygon))
    perimeter = float(mesh.boundary_spacing(polygon).sum())
    n_initial = estimate_nodes(area, perimeter, config)
    if config.radius is not None:
        final_area = math.pi * config.radius * config.radius
    elif config.time is not None:
        final_area = least_area(area, config.lam, config.time)
    else:
        return n_initial, "initial"
    if not math.isfinite(final_area):
        return math.inf, "final"
    n_final = estimate_nodes(final_area, perimeter * math.sqrt(final_area / area), config)
    return (n_final, "final") if n_final > n_initial else (n_initial, "initial")


def check_memory(config, memory: int | None = None) -> float:
    """Raise BudgetError when the run's largest mesh would not fit in memory.

    ``memory`` in bytes, default the available memory. Returns the estimated node count.
    """
    try:
        nodes, when = largest_nodes(config)
    except OverflowError:  # an integer setting beyond the range of floats (n_nodes)
        nodes, when = math.inf, "initial"
    per_node = BYTES_PER_NODE + ELEMENT_BYTES_PER_NODE.get(getattr(config, "element", "P1"), 0)
    need = BASE_BYTES + per_node * nodes
    memory = available_memory() if memory is None else memory
    if not need <= memory:  # also NaN
        goal = ("" if when == "initial" else f" (radius {config.radius:g})"
                if config.radius is not None else f" (time {config.time:g})")
        about = f"about {nodes:.3g}" if nodes < 1e300 else "more than 1e+300"
        gib = f"~{need / 2**30:.3g} GiB" if nodes < 1e300 else "beyond any memory"
        raise BudgetError(
            f"shape {config.shape} needs {about} mesh nodes at its {when} size{goal} "
            f"({gib}) at h_max = {config.h_max:g}, more than the {memory / 2**30:.3g} GiB "
            "available; raise h_max or interior_coarsening, or take a smaller shape or a "
            "nearer goal")
    return nodes
