"""Initial shapes of both engines: the shape specification joined with the particle fill.

The specification (``circle:R``, ``ellipse:A,B``, ``rectangle:W,H[,ROUND]``, ``star:K,EPS[,R]``,
``polygon:FILE.csv``, ``line:N``) is parsed once, by :mod:`continuum.shapes`, which also gives
the outline; :mod:`particles.packings` fills an outline with rods. ``continuum`` and
``particles`` may not import each other, so this module joins them: the continuum reads
``Config.shape`` itself, and the particle engine takes the state built here::

    import particles
    from cases.shapes import initial_state
    config = particles.Config(lam=1e-2, time=1.0, seed=1, shape="star:5,0.2,8")
    sim = particles.run(config, state=initial_state(config))

(``initial_particles("star:5,0.2,8", seed=1)`` builds the same state from the spec alone.)
"""

from __future__ import annotations

import logging

from continuum import shapes
from particles import packings
from particles.config import Config
from particles.state import ParticleState

__all__ = ["initial_particles", "initial_state"]

log = logging.getLogger(__name__)

#: A fill estimated (packings.fill_estimate) to take longer than this says so first.
ANNOUNCE_SECONDS = 10.0


def initial_particles(spec: str, seed: int = 0, orientation: str = "tangent",
                      lengths: str = "stable", max_rods: int | None = None) -> ParticleState:
    """The particles at t = 0 of a shape specification.

    ``line:N``: packings.line(N), N cells of length 1 end to end on the x axis; any other
    shape: continuum.shapes.outline(spec) (the default radius of ``circle`` and ``star:K,EPS``
    is R0 = sqrt(b/pi), as in the continuum) filled by packings.fill_outline with these
    ``seed``, ``orientation`` and ``lengths``. A fill estimated to take more than
    ANNOUNCE_SECONDS logs its rods and seconds first.

    ``max_rods``: the most particles (None: the particle engine's default ``max_particles``);
    a line of more cells or an outline whose fill takes more rods is refused before any work.

    Raises
    ------
    ValueError
        One line: a malformed spec (continuum.shapes.parse), a bad option, an outline too
        small to hold a rod, more than ``max_rods`` particles or a fill longer than
        packings.MAX_FILL_SECONDS.
    """
    shape = shapes.parse(spec)
    limit = Config.__dataclass_fields__["max_particles"].default if max_rods is None else max_rods
    if shape.kind == "line":
        if shape.values[0] > limit:
            raise ValueError(f"shape {spec!r}: {shape.values[0]:,} cells, more than "
                             f"max_particles = {limit}")
        return packings.line(shape.values[0])
    outline = shapes.outline(shape)
    try:
        rods, seconds = packings.fill_estimate(outline, lengths)
        if rods <= limit and ANNOUNCE_SECONDS < seconds <= packings.MAX_FILL_SECONDS:
            log.info("shape %s: filling with about %.3g rods, about %.0f s", spec, rods,
                     seconds)
        return packings.fill_outline(outline, seed=seed, orientation=orientation,
                                     lengths=lengths, max_rods=limit)
    except ValueError as err:
        raise ValueError(f"shape {spec!r}: {err}") from None


def initial_state(config) -> ParticleState | None:
    """The initial particles of a ``particles.Config`` with a ``shape`` or ``layout``, checked.

    Whether this machine can do the run (``config.check_budget``: its steps and its colony),
    before any work; with a ``shape``, ``initial_particles(config.shape, config.seed,
    config.fill_orientation, config.fill_lengths, config.max_particles)`` and the steps from
    the fill's radius. With a ``layout`` (strains) the cells' strains drawn from it
    (continuum.strains.parse_layout; particles.simulation.initial_strains), on the shape's fill
    or on the engine's own start (``init`` or one cell). Neither: None (the engine's start).
    """
    from particles.simulation import initial_state as engine_start
    from particles.simulation import initial_strains

    config.check_budget()  # a shape's steps to a radius goal: after its fill
    state = None
    if config.shape is not None:
        state = initial_particles(config.shape, config.seed, config.fill_orientation,
                                  config.fill_lengths, config.max_particles)
        config.check_budget(state.enclosing_radius())
    if config.layout is not None:
        from continuum.strains import parse_layout

        state = engine_start(config) if state is None else state
        initial_strains(config, state, parse_layout(config.layout, len(config.strains)))
    return state
