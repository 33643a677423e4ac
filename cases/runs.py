"""One run's lifecycle: every run of either engine, from the command line or a sweep.

:func:`run_continuum` and :func:`run_particles` run an engine into a staged folder
(``cases.rundir``: ``DIR.partial`` held by this process, ``run.json`` with the provenance,
resumed from its checkpoint after a stop, published by one rename), then add what the engines
do not write themselves: ``profile.csv`` (``cases.analysis``), ``rings.csv`` (continuum) and
the picture. ``colony continuum|particles`` and the sweeps of the cases (``cases.sweep.run_engine``)
both call them, so every run folder is the same, whoever made it, and ``colony info|plot|movie``
read any of them.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from cases.rundir import (
    CHECKPOINTS,
    RunPaused,
    check_target,
    partial_of,
    publish,
    record,
    stage,
)

#: Equal-area annuli no wider than this at the edge (continuum: resolves the rings, model.md).
CONTINUUM_EDGE_WIDTH = 0.05
#: Particle profiles: the outermost annulus about one particle diameter wide.
PARTICLE_EDGE_WIDTH = 0.5


def _staged_run(engine: str, config, out: Path, overwrite: bool, body, resumable=(),  # noqa: PLR0913
                step_policy=(), other_engine: bool = False):
    """Run ``body(partial)`` in the checked stage of ``out`` with its provenance, then publish.

    Everything that can be checked is checked before the stage is touched (rundir); the stage
    is held by this process alone (rundir.stage), records the run (run.json) and is renamed to
    ``out`` only when ``body`` returned.
    """
    with stage(out, overwrite, engine, config, resumable, step_policy,
               other_engine) as partial:
        with record(partial, engine, config):
            result = body(partial)
        publish(partial)
    return result


def run_continuum(config, out: Path, *, overwrite: bool = False, progress: bool = True,
                  other_engine: bool = False, started: float | None = None,
                  start: tuple | None = None):
    """Run the continuum engine into ``out`` (staged), then write profile.csv and the PNG.

    ``other_engine``: resume a checkpoint another version of the engine wrote (rundir.stage);
    ``started``: the time.monotonic() reading ``max_hours`` counts from (the command line's
    process start).

    ``start``: (state, record) of ``cases.handoff.continuum_start``, the state at t = 0 of a
    particle colony handed over (handoff.json and outline.csv written first; the picture then
    shows the transported mean length).
    """
    from cases.analysis import continuum_profile, write_csv
    from cases.figures.draw import continuum_picture
    from cases.handoff import check_resume, write_handoff
    from continuum.budget import check_memory
    from continuum.output import write_rings
    from continuum.simulation import run

    def body(partial):
        if start is not None:
            write_handoff(partial, start[1])
        sim = run(config, out=partial, progress=progress,
                  state=None if start is None else start[0], started=started)
        _check_paused(sim, partial)
        state = sim.state
        write_csv(partial / "profile.csv", continuum_profile(
            state.points, state.triangles, state.fields, edge_width=CONTINUUM_EDGE_WIDTH))
        write_rings(partial, state.points, state.triangles, state.fields["G"])
        continuum_picture(state, partial / "mean_length", config.lam,
                          transported=start is not None)
        _remove_checkpoints(partial)
        return state

    check_memory(config)  # before the stage is touched (the engine checks again on a fresh start)
    if not overwrite:  # a stopped run resumes from its own start only
        check_resume(partial_of(check_target(out, overwrite)), None if start is None else start[1])
    return _staged_run("continuum", config, Path(out), overwrite, body,
                       resumable=CHECKPOINTS, other_engine=other_engine)


def run_particles(config, out: Path, *, overwrite: bool = False, progress: bool = True,
                  other_engine: bool = False, started: float | None = None,
                  change_step_policy: bool = False):
    """Run the particle engine into ``out`` (staged, resumable), then profile.csv and the PNG.

    ``other_engine``: resume a checkpoint another version of the engine wrote (rundir.stage);
    ``started``: the time.monotonic() reading ``max_hours`` counts from (the command line's
    process start).
    """
    from cases.analysis import particle_profile, write_csv
    from cases.figures.draw import particles_picture
    from cases.shapes import initial_state
    from particles import run
    from particles.config import STEP_POLICY_FIELDS
    from particles.simulation import check_initial

    start = initial_state(config)  # the particles of config.shape (None: init or one cell)

    def body(partial):
        sim = run(config, out=partial, progress=progress,
                  change_step_policy=change_step_policy, state=start, started=started)
        _check_paused(sim, partial)
        colony = sim.state
        profile = particle_profile(colony.x, colony.y, colony.theta, colony.length, colony.stress,
                                   edge_width=PARTICLE_EDGE_WIDTH,
                                   radius=colony.enclosing_radius())
        write_csv(partial / "profile.csv", profile)
        particles_picture(colony, partial / "colony", config.lam)
        _remove_checkpoints(partial)  # the run is complete: nothing to resume
        return colony

    check_initial(config, state=start)
    return _staged_run("particles", config, Path(out), overwrite, body, resumable=CHECKPOINTS,
                       step_policy=STEP_POLICY_FIELDS if change_step_policy else (),
                       other_engine=other_engine)


def run(config, out: str | os.PathLike, *, overwrite: bool = False, progress: bool = False):
    """The command line's run from Python: the same folder as ``colony ENGINE --out out``.

    ``config`` a ``continuum.Config`` or ``particles.Config``; the folder (created, staged,
    resumed after a stop, published) holds run.json, the engine's files, profile.csv, rings.csv
    (continuum) and the picture, where the engines' own ``run(config, out)`` writes the engine's
    files into an existing folder only. Returns the final state.
    """
    return engine_of(config).run(config, Path(out), overwrite=overwrite, progress=progress)


@dataclass(frozen=True)
class Engine:
    """An engine by name: its package's ``Config`` (imported when asked for) and its run."""

    name: str
    run: Callable

    @property
    def config(self) -> type:
        """The engine's ``Config`` class (its package imported now, not with this module)."""
        return importlib.import_module(self.name).Config


#: The engines by name, the one place that maps a name to its Config class and run function
#: (the command line, the sweeps and :func:`run` choose from it).
ENGINES = {"continuum": Engine("continuum", run_continuum),
           "particles": Engine("particles", run_particles)}


def engine_of(config) -> Engine:
    """The engine of a ``continuum.Config`` or ``particles.Config`` (TypeError otherwise)."""
    engine = ENGINES.get(type(config).__module__.split(".")[0])
    if engine is None:
        raise TypeError(f"config must be a continuum.Config or particles.Config, got "
                        f"{type(config).__name__}")
    return engine




def _check_paused(sim, partial: Path) -> None:
    """RunPaused when the engine's run paused at ``config.max_hours`` (its checkpoint written)."""
    if not sim.paused:
        return
    row = sim.history[-1]
    n = row.get("n_particles")
    cells = "" if n is None else f", {n:,} cell{'' if n == 1 else 's'}"
    raise RunPaused(
        f"paused at max_hours = {sim.config.max_hours:g}: t = {row['t']:.4g}, radius "
        f"{row['radius']:.2f}{cells}; the checkpoint is kept in {partial}, give the same "
        "command to resume")


def _remove_checkpoints(partial: Path) -> None:
    for checkpoint in partial.glob("checkpoint*"):
        checkpoint.unlink()


