"""The public API of the continuum engine (``import continuum``).

The names of ``continuum.__all__`` exist; ``Simulation.step`` returns a ``StepRecord`` (the
history row); ``Simulation.advance(radius=R)`` gives the bits of ``run(Config(radius=R))``,
with and without a run folder; ``save`` / ``load`` continue bit-identically (also across a
remesh, with the AMG matrix in the checkpoint); the README's example runs.

The small configuration is SMALL of tests/continuum/conftest.py: it remeshes at steps 14, 17
and 20 of its 21 steps to radius 3 (about 0.3 s a run).
"""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest

import continuum
from continuum import Config, Simulation, State, StepRecord, run

from .conftest import SMALL, SMALL_RADIUS, small_config, state_bytes

GOAL = SMALL_RADIUS


@pytest.fixture(scope="module")
def reference() -> Simulation:
    """``run`` of SMALL to radius GOAL (no folder)."""
    return run(Config(radius=GOAL, **SMALL))


def test_public_names():
    assert set(continuum.__all__) >= {"Config", "Simulation", "State", "StepRecord", "run",
                                      "PressureDivergence", "BudgetError", "PolygonError",
                                      "growth_rate", "mean_length", "radial_radius",
                                      "ring_radii", "ring_table", "__version__"}
    for name in continuum.__all__:
        assert getattr(continuum, name) is not None, name
    assert isinstance(continuum.__version__, str) and continuum.__version__
    assert issubclass(continuum.PolygonError, ValueError)
    assert issubclass(continuum.BudgetError, ValueError)


def test_readme_example(capsys):
    """The README's example, as written."""
    import continuum

    sim = continuum.Simulation(continuum.Config(lam=1e-2))
    record = sim.step()
    state = sim.advance(radius=5.0)
    print(state.t, state.fields["G"].max(), len(state.points))
    t, g_max, n = capsys.readouterr().out.split()
    assert isinstance(record, continuum.StepRecord)
    assert float(t) == state.t and int(n) == len(state.points)
    # the 1D reference R(t) of the disc, to the discretisation error
    assert state.radius == pytest.approx(5.0, rel=1e-3)  # the last step lands by Euler
    assert continuum.radial_radius(state.t, 1e-2) == pytest.approx(state.radius, rel=2e-3)


def test_step_returns_its_record():
    sim = Simulation(Config(**SMALL))
    assert isinstance(sim.state, State) and len(sim.history) == 1
    record = sim.step()
    assert isinstance(record, StepRecord)
    with pytest.raises(dataclasses.FrozenInstanceError):
        record.t = 0.0
    assert record.step == sim.state.step == 1 and record.t == sim.state.t > 0
    assert record.dt == record.t and record.remesh is None
    assert record.n_nodes == len(sim.state.points) and record.radius == sim.state.radius
    assert record.row() == sim.history[-1] and len(sim.history) == 2
    assert record.newton_iterations >= 2 and record.krylov_iterations >= record.newton_iterations
    assert set(sim.fields) == {"p", "u", "G", "mean_length", "mean_length_psi", "length_std_psi",
                               "number",
                               "total_length"}
    assert np.array_equal(sim.fields["mean_length"], continuum.mean_length(sim.state.G))


def test_advance_equals_run(reference):
    """advance(radius=R) of a Simulation without a goal lands exactly where run lands."""
    sim = Simulation(Config(**SMALL))
    state = sim.advance(radius=GOAL)
    assert state is sim.state
    assert state_bytes(sim) == state_bytes(reference)
    assert any(row["remesh"] for row in sim.history)  # the comparison covers remeshing
    # advancing to a goal already reached takes no step
    sim.advance(radius=GOAL)
    assert len(sim.history) == len(reference.history)


def test_advance_by_time_equals_run():
    t_end = 1.0
    ref = run(Config(time=t_end, **SMALL))
    sim = Simulation(Config(time=t_end, **SMALL))
    sim.advance()  # the configuration's goal
    assert sim.state.t == pytest.approx(t_end, rel=1e-12)
    assert state_bytes(sim) == state_bytes(ref)


def test_simulation_with_folder_writes_the_frames_run_writes(tmp_path):
    """Simulation(config, out=...).advance() writes run's frames, byte for byte.

    Not the final files (run's: history.csv, boundary.csv, the last frame); save() writes
    history.csv.
    """
    a, b = tmp_path / "run", tmp_path / "sim"
    a.mkdir(), b.mkdir()
    run(Config(radius=GOAL, **SMALL), out=a)
    sim = Simulation(Config(radius=GOAL, **SMALL), out=b)
    sim.advance()

    def files(folder):
        return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
                if p.is_file()}

    ran, advanced = files(a), files(b)
    last = max(name for name in ran if name.startswith("fields/frame_"))
    assert last == "fields/frame_00008.vtu"  # the frame at the goal
    assert set(ran) - set(advanced) == {"history.csv", "boundary.csv", last}
    assert all(advanced[name] == ran[name] for name in advanced if name != "fields.pvd")
    sim.save()
    assert (b / "history.csv").read_bytes() == ran["history.csv"]


@pytest.mark.parametrize("steps", [5, 14])  # an ordinary step; right after the first remesh
def test_save_load_continues_bit_identically(reference, tmp_path, steps):
    sim = Simulation(Config(**SMALL))
    for _ in range(steps):
        sim.step()
    path = sim.save(tmp_path / "colony.npz")
    copy = sim.state.copy()
    for config in (None, Config(**SMALL, checkpoint_seconds=1.0)):  # execution settings free
        loaded = Simulation.load(path, config)
        assert np.array_equal(loaded.state.points, copy.points) and loaded.state.step == steps
        loaded.advance(radius=GOAL)
        assert state_bytes(loaded) == state_bytes(reference)
    sim.advance(radius=GOAL)  # the saved simulation itself continues unchanged
    assert state_bytes(sim) == state_bytes(reference)
    assert copy.step == steps and copy.t < sim.state.t  # a copy is not changed by later steps
    with pytest.raises(ValueError, match="differs in lam"):
        Simulation.load(path, Config(**{**SMALL, "lam": 2e-2}))


def test_run_resumes_from_a_saved_simulation(reference, tmp_path):
    """A Simulation saved as out/checkpoint.npz is resumed by run(config, out)."""
    sim = Simulation(Config(radius=GOAL, **SMALL))
    for _ in range(10):
        sim.step()
    sim.save(tmp_path / "checkpoint.npz")
    resumed = run(Config(radius=GOAL, **SMALL), out=tmp_path)
    assert state_bytes(resumed) == state_bytes(reference)
    assert (tmp_path / "history.csv").is_file() and (tmp_path / "boundary.csv").is_file()


def test_goals_and_configuration():
    with pytest.raises(ValueError, match="exactly one"):
        run(Config(**SMALL))
    with pytest.raises(ValueError, match="not both"):
        Simulation(Config(radius=2.0, time=1.0, **SMALL))
    sim = Simulation(Config(**SMALL))
    with pytest.raises(ValueError, match="give radius or time"):
        sim.advance()
    with pytest.raises(ValueError, match="give radius or time"):
        sim.done()
    with pytest.raises(ValueError, match="positive"):
        sim.advance(time=math.nan)
    with pytest.raises(ValueError, match="no output folder"):
        sim.save()


@pytest.mark.parametrize("state", ["garbage", {"points": []}, 3, "a ParticleState"])
def test_a_state_of_another_type_is_refused_in_one_line(tmp_path, state):
    """Issue 54: state="garbage" raised AttributeError; a particle state is refused too."""
    name = type(state).__name__
    if state == "a ParticleState":
        import particles

        state = particles.Simulation(particles.Config(lam=1e-2)).state
        name = "particles.state.ParticleState"
    cfg = small_config()
    for make in (lambda s: Simulation(cfg, state=s),
                 lambda s: Simulation(cfg, state=s, out=tmp_path),
                 lambda s: run(cfg, state=s)):
        with pytest.raises(TypeError) as err:
            make(state)
        assert str(err.value) == ("state must be a continuum.State (e.g. of continuum.state_from;"
                                  f" or None: the configured shape), got {name}")
    assert list(tmp_path.iterdir()) == []


def test_growth_law_is_the_pressure_solvers():
    """The growth rate of the state is exp(-lam p) (continuum.growth.growth_rate), bit for bit."""
    sim = Simulation(Config(lam=0.3, **{k: v for k, v in SMALL.items() if k != "lam"}))
    sim.step()
    assert np.array_equal(sim.state.g, continuum.growth_rate(sim.state.p, 0.3))
    assert np.array_equal(sim.state.g, np.exp(-0.3 * sim.state.p))


def test_progress_lines_in_a_log(monkeypatch, caplog, capfd):
    """With progress on and stderr not a terminal (pytest's capture), run() logs lines, no bar.

    One line per PROGRESS_SECONDS (0 here: every step), in the particle engine's format; no
    carriage return reaches the redirected stderr; with progress off, nothing.
    """
    import continuum.runfiles as runfiles

    monkeypatch.setattr(runfiles, "PROGRESS_SECONDS", 0.0)
    with caplog.at_level("INFO", logger="continuum.runfiles"):
        sim = continuum.run(small_config(), progress=True)
    lines = [r.getMessage() for r in caplog.records if r.name == "continuum.runfiles"]
    assert len(lines) == len(sim.history) - 1
    pattern = (r"radius \d+\.\d\d of 3, t = \d+\.\d{4}, \d+ nodes, step \d+, dt [0-9.e-]+, "
               r"\d+ s")
    assert all(re.fullmatch(pattern, m) for m in lines), lines[:3]
    assert lines[-1].startswith(f"radius {sim.state.radius:.2f} of 3, ")
    assert "\r" not in capfd.readouterr().err
    caplog.clear()
    with caplog.at_level("INFO", logger="continuum.runfiles"):
        Simulation(Config(**SMALL)).advance(time=0.2, progress=True)
    lines = [r.getMessage() for r in caplog.records if r.name == "continuum.runfiles"]
    assert lines and all(re.fullmatch(r"t = \d+\.\d{4} of 0\.2, radius \d+\.\d\d, .* s", m)
                         for m in lines)
    caplog.clear()
    monkeypatch.setattr(runfiles, "PROGRESS_SECONDS", 3600.0)
    with caplog.at_level("INFO", logger="continuum.runfiles"):
        continuum.run(small_config(), progress=True)  # a short run: no line within the hour
        continuum.run(small_config())  # progress off
    assert not [r for r in caplog.records if r.name == "continuum.runfiles"]


@pytest.mark.parametrize("kw,match", [
    (dict(lam=1e300, time=1.0), r"lam must be in \[-10000, 10000\], got 1e\+300"),
    (dict(lam=-1e5, time=1.0), r"lam must be in \[-10000, 10000\]"),
    (dict(lam=0.0, time=1.0, strains=[(1e300, 1.0), (0.0, 1.0)]),
     r"a strain's lam must be in \[0, 10000\], got 1e\+300"),
    (dict(lam=-1.0, radius=5.0), r"critical radius sqrt\(2/\|lam\|\) = 1.414: radius 5"),
    (dict(lam=-1.0, time=5.0), r"reaches at t = 2.244: time 5 lies beyond it"),
    (dict(lam=-100.0, time=0.1), r"the initial disc's radius is 0.39"),
])
def test_absurd_lam_refused_when_made(kw, match):
    """Issue 54: lam in [-MAX_LAM, MAX_LAM]; lam < 0 and a disc's goal beyond its critical size."""
    with pytest.raises(ValueError, match=match):
        Config(**kw)


def test_a_negative_lam_short_of_the_critical_size_runs():
    sim = run(Config(lam=-1.0, time=1.0, n_nodes=100, write_fields=False))
    assert sim.state.radius < continuum.radial.critical_radius(-1.0)


def test_a_time_goal_beyond_the_memory_is_refused_before_any_file(tmp_path):
    """Issue 54: lam = 1e-2 to time 1e300 ran for ever (a radius ~1.4e300); fields/ was made."""
    with pytest.raises(continuum.BudgetError, match=r"final size \(time 1e\+300\)"):
        run(Config(lam=1e-2, time=1e300), tmp_path)
    assert list(tmp_path.iterdir()) == []
    sim = Simulation(Config(lam=1e-2))
    for goal in (dict(time=1e300), dict(time=1000.0), dict(radius=1e5)):
        with pytest.raises(continuum.BudgetError, match="mesh nodes at its final size"):
            sim.advance(**goal)
    assert sim.state.step == 0
    sim.advance(time=0.2)  # a near goal still steps
    assert sim.state.t == 0.2
