"""The public API of the particle engine (issue 15).

Names, the step record, advance = run bit for bit, save/load continuing bit for bit, and the
README example.
"""

from dataclasses import FrozenInstanceError, replace

import numpy as np
import pytest

import particles
from particles import Config, Simulation, StepRecord, run

ARRAYS = ("x", "y", "theta", "length", "stress", "ids", "parent", "generation")


def assert_same_state(a, b):
    for k in ARRAYS:
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k), err_msg=k)
    assert (a.t, a.step, a.next_id, a.dt_next) == (b.t, b.step, b.next_id, b.dt_next)
    assert a.rng.bit_generator.state == b.rng.bit_generator.state
    np.testing.assert_array_equal(a.warm_keys, b.warm_keys)
    np.testing.assert_array_equal(a.warm_gamma, b.warm_gamma)


def test_all_names_exist_and_version():
    for name in particles.__all__:
        assert hasattr(particles, name), name
    assert isinstance(particles.__version__, str) and particles.__version__
    for name in ("Config", "Simulation", "StepRecord", "ParticleState", "run", "OverlapError",
                 "ContactSolveError", "ParticleLimitError", "single_cell", "from_csv",
                 "ring_packing"):
        assert name in particles.__all__


def test_step_returns_a_frozen_record_and_divides_inside():
    sim = Simulation(Config(lam=1e-2, seed=1, dt=0.01))
    record = sim.step()
    assert isinstance(record, StepRecord)
    assert (record.step, record.t, record.dt, record.n_particles) == (1, 0.01, 0.01, 1)
    with pytest.raises(FrozenInstanceError):
        record.t = 0.0
    assert sim.history == [record.row()]
    records = [sim.step() for _ in range(80)]  # one cell divides at t = ln 2
    assert sum(r.divisions for r in records) == 1 and sim.state.n == 2
    assert sim.state.t == records[-1].t and sim.state.step == 81


@pytest.mark.parametrize("goal", [{"radius": 4.0}, {"time": 2.5}])
def test_advance_equals_run_bit_for_bit(goal):
    cfg = Config(lam=1e-2, seed=2, dt=0.02)
    state = Simulation(cfg).advance(**goal)
    done = run(replace(cfg, **goal))
    assert_same_state(state, done.state)
    assert done.finished


def test_save_load_continues_bit_for_bit(tmp_path):
    """Steps after save + load are those of the uninterrupted simulation.

    With the adaptive ("overlap") step, so the step length and the warm start are part of the
    saved state.
    """
    cfg = Config(lam=1e-2, seed=4, dt=0.02, step_control="overlap")
    whole = Simulation(cfg)
    for _ in range(120):
        whole.step()
    half = Simulation(cfg)
    for _ in range(70):
        half.step()
    path = half.save(tmp_path / "sim.npz")
    again = Simulation.load(path)
    assert again.config == cfg
    assert_same_state(again.state, half.state)
    for _ in range(50):
        again.step()
    assert_same_state(again.state, whole.state)
    assert again.history == whole.history


def test_a_run_checkpoint_loads_as_a_simulation(tmp_path):
    cfg = Config(lam=1e-2, seed=5, time=1.5, dt=0.02)
    run(cfg, tmp_path, max_steps=30)
    sim = Simulation.load(tmp_path / "checkpoint.npz")
    assert sim.state.step == 30 and len(sim.history) == 30
    sim.advance()
    assert_same_state(sim.state, run(cfg).state)


def test_config_stop_rules():
    Simulation(Config(lam=0.0))  # no stop: stepped by hand
    with pytest.raises(ValueError, match="exactly one"):
        run(Config(lam=0.0))
    with pytest.raises(ValueError, match="not both"):
        Simulation(Config(lam=0.0, radius=2.0, time=1.0))
    with pytest.raises(ValueError, match="give radius or time"):
        Simulation(Config(lam=0.0)).advance()


def test_initial_configurations(tmp_path):
    one = particles.single_cell()
    assert one.n == 1 and one.length[0] == 1.0 and one.enclosing_radius() == 0.5
    f = tmp_path / "init.csv"
    f.write_text("x,y,theta,length\n0,0,0,1.5\n1.5,0,0,1.5\n")
    two = particles.from_csv(f)
    assert two.n == 2
    sim = Simulation(Config(lam=0.0), state=two)
    sim.advance(time=0.1)
    assert sim.state.n == 2 and sim.state.x[1] - sim.state.x[0] > 1.5
    x, y, th, length = particles.ring_packing(100, seed=1)
    assert x.size >= 100 and length.min() >= 1.0


def test_readme_example(capsys):
    sim = particles.Simulation(particles.Config(lam=1e-2, seed=1))
    record = sim.step()
    state = sim.advance(radius=6.0)
    print(state.n, state.t, state.stress.max())
    n, t, smax = capsys.readouterr().out.split()
    assert record.step == 1 and int(n) == state.n > 40 and float(smax) > 0
    assert state.enclosing_radius() >= 6.0


def test_option_names_live_in_the_config():
    """config.py imports no engine module (no circle through stepping or packings).

    Only geometry (the diameter b) and strains (the strains' checks; it imports nothing local).

    The solvers by name are those of config.SOLVERS.
    """
    import ast
    from pathlib import Path

    import particles.config
    from particles.solvers import BY_NAME

    def local_imports(module):
        tree = ast.parse(Path(module.__file__).read_text())
        return {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.level == 1}

    assert local_imports(particles.config) == {"geometry", "strains"}
    assert local_imports(particles.strains) == set()
    assert tuple(BY_NAME) == particles.config.SOLVERS


def test_a_removed_solver_is_refused_with_a_note(tmp_path):
    """A configuration or checkpoint naming a removed solver (issue 43) fails in one line.

    ValueError from Config's validation, naming the solvers there are and why it went.
    """
    import json

    from particles.checkpoint import read_arrays

    with pytest.raises(ValueError, match=r"unknown solver 'twolevel'; choose from "
                                         r"\['apgd', 'bbpgd'\] \(twolevel was removed"):
        Config(lam=1e-2, solver="twolevel")
    sim = Simulation(Config(lam=1e-2, seed=1))
    sim.step()
    arrays = read_arrays(sim.save(tmp_path / "sim.npz"))
    meta = json.loads(str(arrays["meta"]))
    meta["config"]["solver"] = "twolevel"
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez(tmp_path / "old.npz", **arrays)  # no checksum entry: an older checkpoint's format
    with pytest.raises(ValueError, match="twolevel was removed") as err:
        Simulation.load(tmp_path / "old.npz")
    assert "\n" not in str(err.value)
