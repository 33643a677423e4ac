"""Configuration of a continuum colony: ``Config`` (a frozen dataclass) and its validation.

One configuration object per run: the model parameter ``lam``, the stop of a run (``radius`` or
``time``), the initial shape, the mesh, the time step, the size grid, outputs and execution
settings; ``continuum.output.write_config`` writes it to config.json next to the results. A
``Config`` is checked once, when it is made (``__post_init__`` calls :meth:`Config.validate`):
a one-line ValueError names the field. It is frozen; a changed copy is
``dataclasses.replace(config, field=value)`` (validated again). Which fields a checkpoint may
resume under other values: ``continuum.checkpoint.EXECUTION_FIELDS``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from continuum import mesh, radial, shapes
from continuum.fem import ELEMENTS
from continuum.radial import R0
from continuum.runfiles import check_nutrient, check_types, type_mismatch
from continuum.sizes import INITIAL_SIZES, REMOVED_TRANSPORTS, TRANSPORTS
from continuum.strains import LAM_CAP_WHY, MAX_LAM, as_strains, parse_layout

__all__ = ["Config"]


_RULES = [  # (field, test, what the value must be), checked by Config.validate after the types
    ("n_nodes", lambda v: v >= 50, "an integer >= 50"),
    ("interior_coarsening", lambda v: v >= 1, ">= 1"),
    ("courant", lambda v: 0 < v <= 1.0, "in (0, 1]"),
    ("q_min", lambda v: 0 < v < 0.9, "in (0, 0.9)"),
    ("stretch", lambda v: v > 1.1, "> 1.1"),
    ("n_length_cells", lambda v: v >= 8, "an integer >= 8"),
    ("initial_sizes", lambda v: v in INITIAL_SIZES, " or ".join(map(repr, INITIAL_SIZES))),
    ("psi_transport", lambda v: v in TRANSPORTS, " or ".join(map(repr, TRANSPORTS))),
    ("element", lambda v: v in ELEMENTS, " or ".join(map(repr, ELEMENTS))),
    ("output_every", lambda v: v >= 0, ">= 0"),
    ("step_limit", lambda v: v > 0, "a positive integer"),
    ("checkpoint_seconds", lambda v: v >= 0, ">= 0"),
    ("max_hours", lambda v: v is None or 0 < v < math.inf, "positive and finite, or None"),
]

#: Values a field once took and no longer does, with why: a refusal names it.
_REMOVED = {"psi_transport": REMOVED_TRANSPORTS}


@dataclass(frozen=True)
class Config:
    """Configuration of a continuum colony: the model, the numerics and the stop of ``run``.

    Validated when made (:meth:`validate`; ValueError); frozen (``dataclasses.replace`` makes
    a changed copy).

    Attributes
    ----------
    lam : float
        Stress sensitivity lambda, in [-strains.MAX_LAM, strains.MAX_LAM]; required. lam < 0
        has no pressure solution beyond a critical size (a disc's radius ``sqrt(2/|lam|)``,
        continuum.radial): a disc whose goal lies there is refused when made.
    radius, time : float or None
        The goal of a run: the colony radius sqrt(area/pi) or the time t to reach. At most one;
        :func:`~continuum.simulation.run` needs one, a
        :class:`~continuum.simulation.Simulation` stepped by hand none (``advance()`` without
        arguments goes to this goal).
    shape : str
        Initial shape (continuum.shapes): "circle" (radius ``initial_radius``), "circle:R",
        "ellipse:A,B", "rectangle:W,H[,ROUND]", "star:K,EPS[,R]" (R default
        ``initial_radius``) or "polygon:FILE.csv" (closed polygon, columns x,y).
    initial_radius : float
        Radius of the initial ``circle`` and of ``star:K,EPS`` (default R0 = sqrt(b/pi), one
        particle's area); the other shapes give their own sizes.
    n_nodes : int
        Target node count while the colony is small (h = h_N(area)).
    h_max : float
        Cap on the boundary mesh spacing h.
    interior_coarsening : float
        Interior mesh size up to this multiple of h (1 = uniform mesh).
    grading : float
        Growth of the interior mesh size with the distance d to the edge: min(c h, h + grading d).
    courant : float
        dt = courant * h_boundary / max u_boundary.
    q_min : float
        Remesh when a triangle's quality drops below this.
    stretch : float
        Remesh when boundary edges or the mean element size leave [h/stretch, stretch h].
    initial_sizes : str
        Psi0, the initial size distribution (continuum.sizes.INITIAL_SIZES): "delta" (default:
        the model's delta(l - 1), carried exactly by its position, continuum.sizes.DeltaSizes:
        mean length 2^frac(G / ln 2) to round-off at every node, spread 0; ``n_length_cells``,
        ``bump_width`` and ``psi_transport`` do not apply), "bump" (the smooth bump of
        ``bump_width`` on the grid of ``n_length_cells``, carried by ``psi_transport``; the
        default before: its mean length is the shifted bump's, up to 0.34 from the
        delta's at the defaults) or "histogram" (Psi0 on the l grid given with the state,
        continuum.initial.state_from, e.g. the particle hand-off cases.handoff; a run from the
        configured shape alone refuses it).
    n_length_cells : int
        Cells of the log2-length grid of Psi (a "bump" or "histogram" Psi0).
    bump_width : float
        Half-width in s = log2 l of the initial bump (``initial_sizes = "bump"``).
    psi_transport : str
        Transport of Psi in l on the grid (a "bump" or "histogram" Psi0):
        "characteristics-labels", the one there is: exact shift of per-node windows in
        s = log2 l, continuum.sizes.CharacteristicSizes; a remesh interpolates the rows by
        label, continuum.remesh: from a uniform Psi0 exact to round-off at radius 150. The
        cell remap ("characteristics") and finite volumes ("finite-volume") were removed
        (continuum.sizes.REMOVED_TRANSPORTS).
    element : str
        Lagrange element of the pressure: "P1" (default: hand-written assembly, equal to
        scikit-fem's to round-off, 2x faster over a whole run; velocity by patch recovery and
        residual flux, continuum.velocity) or "P2" (scikit-fem, continuum.fem; isoparametric
        at the boundary; velocity from the element gradients at the vertices, one order more
        accurate; 15-24x the cost per solve on the same mesh, docs/benchmarks.md).
    output_every : float
        Time between field frames (VTU); 0 writes only the first and last.
    write_fields : bool
        Write the VTU series (history, boundary and config are always written).
    step_limit : int
        Safety limit on the number of time steps of the whole run: a ValueError when passed
        (not a pause: ``run(config, out, max_steps=N)`` pauses a call after N steps).
    checkpoint_seconds : float
        Wall time between checkpoints when writing to a folder (an execution setting,
        ``EXECUTION_FIELDS``: a checkpoint resumes under another value, with the same result).
    max_hours : float or None
        Wall-clock limit of one ``run`` call: before it passes, the run writes a checkpoint and
        pauses (``Simulation.paused``; runfiles.WallLimit); the same call resumes it. An
        execution setting like ``checkpoint_seconds`` (each leg of a chain may give its own).
        None (the default): no limit.
    strains : tuple of continuum.strains.Strain
        The strains i = 0..S-1 of the colony, each its stress sensitivity lam_i >= 0 and growth
        factor a_i > 0 (growth rate a_i exp(-lam_i p); given as Strain, (lam, growth) pairs or
        {"lam", "growth"} tables, stored as a tuple of Strain). Empty (default): one strain of
        stress sensitivity ``lam`` and growth 1, the model as before, bit for bit. With strains
        ``lam`` is not used by the model (each strain's lam_i is), and a simulation of S >= 2
        strains needs its initial fractions (``Simulation(config, layout=phi0)``,
        continuum.strains).
    layout : str or None
        The initial layout of the strains as a specification (continuum.strains.LAYOUTS:
        ``core:R1``, ``sector:THETA[,DIRECTION]``, ``mixture:F0,F1``, ``polygon:FILE.csv``),
        parsed by continuum.strains.parse_layout; what ``Simulation`` uses when not given
        ``layout=``. None: given to ``Simulation``, or one strain.
    nutrient_length : float or None
        ell, the nutrient's penetration length in cell lengths (model.md, "Nutrient
        limitation"): growth g = exp(-lam p) f(c), Laplace c = g / ell^2 in the colony, c = 1 on
        its edge (a well-mixed reservoir), so that c = 1 - p / ell^2 (continuum.pressure solves
        it); the nodal field ``c`` of the frames. None (the default): no nutrient limitation,
        the model as before, bit for bit.
    monod_k : float or None
        K > 0, the Monod half-saturation level over the reservoir's:
        f(c) = (1 + K) c / (K + c) (continuum.growth.uptake). None (or inf, stored as None):
        first order, f(c) = c. Only with ``nutrient_length``.
    """

    lam: float
    radius: float | None = None
    time: float | None = None
    shape: str = "circle"
    initial_radius: float = R0
    n_nodes: int = 2000
    h_max: float = 0.55
    interior_coarsening: float = 2.5
    grading: float = 0.05
    courant: float = 0.6
    q_min: float = 0.35
    stretch: float = 1.5
    n_length_cells: int = 40
    bump_width: float = 0.08
    initial_sizes: str = "delta"
    psi_transport: str = "characteristics-labels"
    element: str = "P1"
    output_every: float = 1.0
    write_fields: bool = True
    step_limit: int = 200_000
    checkpoint_seconds: float = 300.0
    max_hours: float | None = None
    strains: tuple = ()
    layout: str | None = None
    nutrient_length: float | None = None
    monod_k: float | None = None

    def __post_init__(self) -> None:
        if isinstance(self.strains, (tuple, list)):  # other types: validate names the field
            object.__setattr__(self, "strains", as_strains(self.strains))
        if isinstance(self.monod_k, float) and math.isinf(self.monod_k) and self.monod_k > 0:
            object.__setattr__(self, "monod_k", None)  # first order, one spelling
        self.validate()

    @property
    def nutrient(self) -> tuple[float, float] | None:
        """(ell, K) of the nutrient (K = inf: first order), or None without nutrients."""
        if self.nutrient_length is None:
            return None
        return self.nutrient_length, math.inf if self.monod_k is None else self.monod_k

    def validate(self) -> None:
        """Check the values; raises ValueError with a one-line message (called when made).

        Every field's type first (``type_mismatch``), then the goal (at most one of ``radius``
        and ``time``), the values and the shape.
        """
        check_types(self)
        if self.radius is not None and self.time is not None:
            raise ValueError("give at most one of radius and time, not both")
        if not -MAX_LAM <= self.lam <= MAX_LAM:
            why = LAM_CAP_WHY if self.lam > 0 else (
                f"below -{MAX_LAM:g} the critical radius sqrt(2/|lam|) of a colony with a "
                "pressure solution is below 0.015, far less than a cell")
            raise ValueError(f"lam must be in [-{MAX_LAM:g}, {MAX_LAM:g}], got {self.lam:g} "
                             f"({why})")
        positive = ["initial_radius", "h_max", "courant", "bump_width", "grading"]
        positive += [name for name in ("radius", "time") if getattr(self, name) is not None]
        rules = [(name, lambda v: v > 0, "a positive number") for name in positive]
        for name, ok, what in rules + _RULES:
            v = getattr(self, name)
            if not ok(v):
                why = _REMOVED.get(name, {}).get(v)
                raise ValueError(f"{name} must be {what}, got {v!r}"
                                 + (f" ({v} was removed: {why})" if why else ""))
        self._check_nutrient()
        if self.layout is not None:
            if len(self.strains) < 2:
                raise ValueError(f"layout {self.layout!r} needs two or more strains")
            parse_layout(self.layout, len(self.strains))
        polygon = self.initial_boundary()  # parses and checks the shape
        if self.radius is not None:
            r_init = mesh.colony_radius(polygon)
            if self.radius < r_init:
                raise ValueError(
                    f"radius {self.radius} is smaller than the initial radius {r_init:.6g}"
                )
        self._check_critical_size(polygon)

    def _check_nutrient(self) -> None:
        """The nutrient's fields (one line each): ell > 0 and finite, K > 0, with lam >= 0."""
        check_nutrient(self.nutrient_length, self.monod_k)
        if self.nutrient_length is None:
            return
        if self.lam < 0:
            raise ValueError(f"nutrients need lam >= 0, got lam = {self.lam:g}")
        if self.strains:
            raise ValueError("nutrients with strains are not supported yet in the continuum: "
                             "give one or the other")

    def _check_critical_size(self, polygon: np.ndarray) -> None:
        """Refuse a disc's goal at or beyond the critical radius (lam < 0, one strain).

        Beyond R_crit = ``sqrt(2/|lam|)`` a disc has no pressure solution (continuum.radial, the
        Bratu problem): the run would fail there (PressureDivergence). The time the disc takes
        to reach it is radial.critical_time. Other shapes of the same area have a solution
        beyond it and are left to the run.
        """
        if self.lam >= 0 or self.strains or shapes.parse(self.shape).kind != "circle":
            return
        r_crit = radial.critical_radius(self.lam)
        r_init = mesh.colony_radius(polygon)
        why = (f"lam = {self.lam:g} < 0: a disc has no pressure solution beyond the critical "
               f"radius sqrt(2/|lam|) = {r_crit:.4g}")
        if r_init >= r_crit:
            raise ValueError(f"{why}, and the initial disc's radius is {r_init:.4g}; give "
                             "lam >= 0, a lam nearer 0 or a smaller disc")
        if self.radius is not None and self.radius >= r_crit:
            raise ValueError(f"{why}: radius {self.radius:g} lies beyond it; give lam >= 0 or "
                             f"a radius below {r_crit:.4g}")
        if self.time is not None:
            t_crit = radial.critical_time(self.lam, r_init)
            if self.time >= t_crit:
                raise ValueError(f"{why}, which the disc reaches at t = {t_crit:.4g}: time "
                                 f"{self.time:g} lies beyond it; give lam >= 0 or a time "
                                 f"below {t_crit:.4g}")

    @classmethod
    def type_mismatch(cls, name: str, value) -> str | None:
        """What field ``name`` takes (e.g. "a number") when ``value`` is not of its type, else None.

        The type is the field's annotation (runfiles.type_mismatch); ``monod_k`` also takes
        inf (first order, stored as None).
        """
        if name == "monod_k" and value == math.inf and not isinstance(value, bool):
            return None
        return type_mismatch(cls.__dataclass_fields__[name].type, value)

    def initial_boundary(self) -> np.ndarray:
        """A dense polygon of the initial shape (checked, counter-clockwise).

        continuum.shapes.outline of ``shape`` (``circle`` of radius ``initial_radius``, and the
        default R of ``star:K,EPS``); 256 vertices for a circle or an ellipse, the file's for
        a polygon. ``line:N`` (particles only) is refused.
        """
        return shapes.outline(self.shape, radius=self.initial_radius)
