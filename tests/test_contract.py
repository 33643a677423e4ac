"""One contract for both engines (issue 29): the same names with the same meaning.

The two engines' public signatures are compared with ``inspect.signature`` and must be
identical: the common ``Config`` fields, ``Simulation.__init__``, ``step``, ``done``,
``advance``, ``save``, ``load``, ``run``, the checkpoint functions, ``StopRequest``, and the
common fields of ``StepRecord`` and ``Checkpoint``. Annotations are compared with the engines'
own state classes (``continuum.State``, ``particles.ParticleState``) taken as one. What only
one engine has is listed here (ENGINE_ONLY: keyword-only, with a default, so that a call of the
contract is the same in both), and so are the fields of the same name whose meaning differs
(CONFIG_DIFFERENT): a new shared name fails the test until it is classified.

Then the same behaviour, checked on both engines (docs/DESIGN.md, "One contract for both
engines"): a Config is validated when made and frozen; the initial state is copied; ``step``
does not pass ``time``; ``advance`` and ``done`` stop at the first goal reached (both None:
the configuration's); ``advance`` writes no final files, ``run`` does; ``run(max_steps=...)``
pauses with a checkpoint; ``save`` / ``load`` continue bit for bit; ``StopRequest`` is a context
manager. And what both need of a run's files and controls is one source (``runfiles``).
"""

from __future__ import annotations

import ast
import dataclasses
import importlib
import inspect
import os
import signal
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import continuum
import continuum.checkpoint
import continuum.runfiles
import continuum.simulation
import particles
import particles.checkpoint
import particles.runfiles
import particles.simulation
from tests.continuum.conftest import SMALL

ENGINES = {
    "continuum": SimpleNamespace(
        module=continuum, simulation=continuum.simulation, checkpoint=continuum.checkpoint,
        runfiles=continuum.runfiles,
        config=lambda **kw: continuum.Config(**{**SMALL, **kw}),
        initial=lambda config: continuum.simulation.initial_state(config),
        near_radius=1.2,  # reached at t = 2.2 (SMALL, 12 steps)
        final_files={"history.csv", "boundary.csv"}),
    "particles": SimpleNamespace(
        module=particles, simulation=particles.simulation, checkpoint=particles.checkpoint,
        runfiles=particles.runfiles,
        config=lambda **kw: particles.Config(lam=1e-2, seed=1, **kw),
        initial=lambda config: particles.single_cell(),
        near_radius=2.0,  # reached at t = 1.54 (77 steps)
        final_files={"history.csv", "particles.csv"}),
}
"""Each engine with a small configuration (``config(**goal)``), its default initial state and
a radius goal reached after t = 1 (the time goal NEAR_TIME comes first)."""

NEAR_TIME, FAR_TIME = 1.0, 5.0
FAR_RADIUS = 50.0

ENGINE_ONLY = {
    "particles": {
        "Simulation.__init__": {"change_step_policy"},
        "Simulation.load": {"change_step_policy"},
        "run": {"change_step_policy"},
        "load_checkpoint": {"change_step_policy"},
        "resume_checkpoint": {"change_step_policy"},
    },
}
"""Parameters of one engine only: resuming under another step policy (the continuum has none)."""

CONFIG_COMMON = ("lam", "radius", "time", "checkpoint_seconds", "max_hours", "strains",
                 "nutrient_length", "monod_k")
"""Config fields of the same name and meaning: the same annotation and default in both."""

CONFIG_OWN_DEFAULT = {"output_every": (1.0, 0.2)}
"""Config fields of the same name, meaning and annotation, with each engine's default
(continuum, particles): the time between output frames (until issue 43 the particles' was a
step count)."""

CONFIG_DIFFERENT = {
    "shape": "continuum: a spec it parses, default 'circle'; particles: the spec of a state "
             "built outside the engine (cases.shapes), default None",
    "layout": "continuum: a layout spec it parses; particles: the spec the cells' strains were "
              "drawn from outside the engine (cases.shapes.initial_state)",
}
"""Config fields of the same name whose meaning differs; renaming one would change the
config.json of every run (and the checkpoints' configurations)."""

STATE_CLASSES = {"State", "ParticleState"}


def annotation(text) -> frozenset:
    """An annotation's alternatives (``a | b``), the engines' state classes taken as one."""
    if text is inspect.Parameter.empty:
        return frozenset()
    parts = {part.strip() for part in str(text).split("|")}
    return frozenset("STATE" if part in STATE_CLASSES else part for part in parts)


def contract(signature: inspect.Signature, engine: str, name: str) -> list[tuple]:
    """(name, kind, default, annotation) of each parameter of the contract, and the return."""
    extra = ENGINE_ONLY.get(engine, {}).get(name, set())
    params = []
    for p in signature.parameters.values():
        if p.name in extra:
            assert p.kind is p.KEYWORD_ONLY and p.default is not p.empty, (engine, name, p)
            continue
        params.append((p.name, p.kind, p.default, annotation(p.annotation)))
    return [*params, ("return", annotation(signature.return_annotation))]


def member(engine: str, dotted: str):
    """``Simulation.step``, ``run``, ``save_checkpoint``, ... of one engine."""
    e = ENGINES[engine]
    head, *rest = dotted.split(".")
    for where in (e.module, e.simulation, e.checkpoint, e.runfiles):
        if hasattr(where, head):
            obj = getattr(where, head)
            break
    else:
        raise AssertionError(f"{engine} has no {head}")
    for attr in rest:
        obj = getattr(obj, attr)
    return obj


CALLABLES = ["Simulation.__init__", "Simulation.step", "Simulation.done", "Simulation.advance",
             "Simulation.save", "Simulation.load", "run", "Config.validate", "save_checkpoint",
             "load_checkpoint", "resume_checkpoint", "checkpoint_config", "checkpoint_files",
             "history_record", "StopRequest.__enter__", "StopRequest.__exit__",
             "StopRequest.install", "StopRequest.restore", "StopRequest.reraise"]


@pytest.mark.parametrize("name", CALLABLES)
def test_the_same_signatures(name):
    """Parameter names, order, kinds, defaults and annotations; the return annotation."""
    c, p = (contract(inspect.signature(member(e, name)), e, name) for e in ENGINES)
    assert c == p


def test_the_same_modules_and_names():
    """Config in <engine>/config.py, StepRecord in <engine>/state.py; the same public names."""
    for engine, e in ENGINES.items():
        assert e.module.Config.__module__ == f"{engine}.config"
        assert e.module.StepRecord.__module__ == f"{engine}.state"
        assert e.simulation.Config is e.module.Config  # older imports
        assert e.simulation.StepRecord is e.module.StepRecord
        assert {"Config", "Simulation", "StepRecord", "run"} <= set(e.module.__all__)
        assert isinstance(inspect.getattr_static(e.module.Simulation, "load"), classmethod)
        assert e.runfiles.STOP_SIGNALS == (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


def test_the_run_files_are_one_source():
    """The run files and controls are written once, and each engine has them as its own module.

    ``particles/runfiles.py`` is a symbolic link to ``continuum/runfiles.py`` (neither engine
    imports the other); the module imports neither engine nor ``cases``.
    """
    link = Path(particles.runfiles.__file__)
    assert link.is_symlink() and os.readlink(link) == "../continuum/runfiles.py"
    assert link.resolve() == Path(continuum.runfiles.__file__).resolve()
    assert continuum.runfiles.__name__ != particles.runfiles.__name__
    for e in ENGINES.values():
        assert e.simulation.reached is e.runfiles.reached  # the engines use their own module
        assert e.checkpoint.read_arrays is e.runfiles.read_arrays
        config = importlib.import_module(e.module.Config.__module__)
        assert config.check_types is e.runfiles.check_types  # the rule of a field's type
    imported = {n.module for n in ast.walk(ast.parse(link.read_text()))
                if isinstance(n, ast.ImportFrom)} | {a.name for n in ast.walk(
                    ast.parse(link.read_text())) if isinstance(n, ast.Import) for a in n.names}
    assert not {m.split(".")[0] for m in imported if m} & {"continuum", "particles", "cases"}


def test_config_common_fields():
    c, p = ({f.name: f for f in dataclasses.fields(e.module.Config)} for e in ENGINES.values())
    assert set(c) & set(p) == set(CONFIG_COMMON) | set(CONFIG_OWN_DEFAULT) | set(CONFIG_DIFFERENT)
    for name in (*CONFIG_COMMON, *CONFIG_OWN_DEFAULT):
        assert annotation(c[name].type) == annotation(p[name].type), name
    for name in CONFIG_COMMON:
        assert c[name].default == p[name].default, name
    for name, defaults in CONFIG_OWN_DEFAULT.items():
        assert (c[name].default, p[name].default) == defaults, name
    for e in ENGINES.values():
        assert e.module.Config.__dataclass_params__.frozen
        assert list(dataclasses.fields(e.module.Config))[0].name == "lam"  # Config(lam) works


@pytest.mark.parametrize("cls", ["StepRecord", "Checkpoint"])
def test_records_share_their_first_fields(cls):
    """StepRecord: step, t, dt, radius; Checkpoint: config, state, history, frames."""
    first = {"StepRecord": ["step", "t", "dt", "radius"],
             "Checkpoint": ["config", "state", "history", "frames"]}[cls]
    c, p = ([(f.name, annotation(f.type)) for f in dataclasses.fields(member(e, cls))]
            for e in ENGINES)
    assert [name for name, _ in c[:4]] == [name for name, _ in p[:4]] == first
    if cls == "StepRecord":  # a Checkpoint's frames differ: frame times, or (count, last step)
        assert c[:4] == p[:4]


# ------------------------------------------------------------------------ behaviour


@pytest.fixture(params=list(ENGINES))
def engine(request) -> SimpleNamespace:
    return ENGINES[request.param]


def test_config_is_validated_when_made_and_frozen(engine):
    Config = engine.module.Config
    with pytest.raises(ValueError, match="^lam must be a number, got True"):
        Config(lam=True)
    with pytest.raises(ValueError, match="at most one of radius and time, not both"):
        engine.config(radius=2.0, time=1.0)
    config = engine.config()
    assert config.validate() is None and config.radius is None and config.time is None
    with pytest.raises(dataclasses.FrozenInstanceError):
        config.lam = 0.0
    with pytest.raises(ValueError, match="^time must be"):
        dataclasses.replace(config, time=-1.0)  # a changed copy is validated too
    with pytest.raises(ValueError, match="exactly one of radius and time"):
        engine.module.run(config)  # a run needs a goal


def test_the_initial_state_is_copied(engine):
    config = engine.config()
    start = engine.initial(config)
    sim = engine.module.Simulation(config, state=start)
    assert sim.state is not start
    sim.step()
    assert start.t == 0.0 and start.step == 0 and sim.state.step == 1
    done = engine.module.run(engine.config(time=0.2), state=start)
    assert done.state.t == pytest.approx(0.2) and start.t == 0.0 and start.step == 0


def test_step_does_not_pass_time(engine):
    sim = engine.module.Simulation(engine.config())
    while not sim.done(time=0.3):
        record = sim.step(time=0.3)
        assert record.t <= 0.3 + 1e-15 and (record.step, record.t) == (sim.state.step, sim.state.t)
    assert sim.state.t == pytest.approx(0.3, rel=1e-12)
    with pytest.raises(ValueError, match="reached already"):
        sim.step(time=0.3)
    with pytest.raises(ValueError, match="positive finite"):
        sim.step(time=float("nan"))


@pytest.mark.parametrize("first", ["time", "radius"])
def test_the_first_goal_reached_stops(engine, first):
    """advance(radius, time) stops at whichever comes first, with the bits of that goal alone."""
    both = ({"radius": FAR_RADIUS, "time": NEAR_TIME} if first == "time" else
            {"radius": engine.near_radius, "time": FAR_TIME})
    alone = {first: both[first]}
    sim, ref = (engine.module.Simulation(engine.config()) for _ in range(2))
    state = sim.advance(**both)
    ref.advance(**alone)
    assert state is sim.state and sim.history == ref.history
    assert sim.done(**both) and sim.done(**alone)
    if first == "time":
        assert state.t == pytest.approx(NEAR_TIME, rel=1e-12) and not sim.done(radius=FAR_RADIUS)
    else:
        assert state.t < FAR_TIME and sim.history[-1]["radius"] >= engine.near_radius * (1 - 1e-7)
    steps = len(sim.history)
    sim.advance(**both)  # reached already: no step
    assert len(sim.history) == steps


def test_without_goals_the_configurations(engine):
    sim = engine.module.Simulation(engine.config())
    for call in (sim.done, sim.advance):
        with pytest.raises(ValueError, match="give radius or time"):
            call()
    with pytest.raises(ValueError, match="radius must be a positive finite number"):
        sim.done(radius=-1.0)
    sim = engine.module.Simulation(engine.config(time=0.3))
    assert not sim.done()
    sim.advance()
    assert sim.done() and sim.state.t == pytest.approx(0.3, rel=1e-12)


def test_advance_writes_no_final_files_run_does(engine, tmp_path):
    a, b = tmp_path / "advance", tmp_path / "run"
    a.mkdir(), b.mkdir()
    sim = engine.module.Simulation(engine.config(time=0.3), out=a)
    sim.advance()
    assert not engine.final_files & {p.name for p in a.iterdir()}
    ran = engine.module.run(engine.config(time=0.3), out=b)
    assert engine.final_files <= {p.name for p in b.iterdir()}
    assert ran.finished and ran.history == sim.history


def test_run_pauses_after_max_steps_and_resumes(engine, tmp_path):
    whole = engine.module.run(engine.config(time=NEAR_TIME))  # 6 and 50 steps
    paused = engine.module.run(engine.config(time=NEAR_TIME), out=tmp_path, max_steps=2)
    assert not paused.finished and (tmp_path / "checkpoint.npz").is_file()
    assert paused.state.step == 2
    resumed = engine.module.run(engine.config(time=NEAR_TIME), out=tmp_path)
    assert resumed.finished and resumed.history == whole.history


def test_save_and_load_continue_bit_for_bit(engine, tmp_path):
    sim = engine.module.Simulation(engine.config())
    for _ in range(3):
        sim.step()
    path = sim.save(tmp_path / "sim.npz")
    assert path == tmp_path / "sim.npz"
    loaded = engine.module.Simulation.load(str(path))
    assert loaded.config == sim.config and loaded.output is None and loaded.finished
    assert loaded.step() == sim.step()
    assert loaded.history == sim.history
    saved = engine.checkpoint.load_checkpoint(path)
    assert isinstance(saved, engine.checkpoint.Checkpoint)
    assert saved.config == sim.config and saved.state.step == 3 and len(saved.history) >= 3
    assert engine.checkpoint.checkpoint_config(path) == sim.config
    other = dataclasses.replace(sim.config, lam=2e-2)
    for load in (lambda: engine.module.Simulation.load(path, other),
                 lambda: engine.checkpoint.load_checkpoint(path, other)):
        with pytest.raises(ValueError, match="differs in lam"):
            load()
    with pytest.raises(ValueError, match="no output folder"):
        sim.save()


def test_stop_request_defers_a_signal_to_the_end_of_a_step(engine):
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with engine.runfiles.StopRequest() as stop:
            assert stop.signum is None
            signal.raise_signal(signal.SIGINT)  # deferred: no KeyboardInterrupt here
            assert stop.signum == signal.SIGINT
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
        with pytest.raises(KeyboardInterrupt):
            stop.reraise()
        with engine.runfiles.StopRequest() as calm:
            pass
        calm.reraise()  # no signal: nothing
    finally:
        signal.signal(signal.SIGINT, previous)


def test_step_records_agree_with_the_state(engine):
    sim = engine.module.Simulation(engine.config())
    record = sim.step()
    assert isinstance(record, engine.module.StepRecord)
    assert (record.step, record.t) == (sim.state.step, sim.state.t) == (1, record.dt)
    radius = (sim.state.radius if hasattr(sim.state, "radius")
              else sim.state.enclosing_radius())
    assert record.radius == radius and record.row() == sim.history[-1]
    assert np.isfinite([record.t, record.dt, record.radius]).all()
