"""The public API of the particle engine (issue 15).

Names (``particles.__all__`` exactly, each public function called on a small input whose answer
is known in closed form), the step record, advance = run bit for bit, save/load continuing bit
for bit, and the README example.
"""

import math
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


#: The public names, each exercised in this file: a new name gets a test here.
PUBLIC = {"B", "Config", "ContactSolveError", "DishWallError", "OverlapError", "ParticleLimitError",
          "ParticleState", "Simulation", "StepRecord", "__version__", "axial_stress", "divide",
          "enclosing_radius", "fill_outline", "from_csv", "grow", "hull_radius", "line",
          "read_trajectory", "ring_packing", "run", "single_cell"}


def test_public_names_and_version():
    assert set(particles.__all__) == PUBLIC
    for name in particles.__all__:
        assert getattr(particles, name) is not None, name
    assert isinstance(particles.__version__, str) and particles.__version__
    assert particles.B == 0.5  # the rods' diameter b, in birth lengths
    for error in (particles.OverlapError, particles.ContactSolveError,
                  particles.ParticleLimitError):
        assert issubclass(error, RuntimeError)


def test_grow_is_the_exact_growth_law():
    """l(t + dt) = l exp(a dt exp(-lam sigma)); at lam = 0 every length grows by exp(a dt)."""
    length, stress = np.array([1.0, 1.5]), np.array([0.0, 2.0])
    np.testing.assert_allclose(particles.grow(length, stress, 0.5, 0.1, rate=2.0),
                               [math.exp(0.2), 1.5 * math.exp(0.2 * math.exp(-1.0))], rtol=1e-15)
    np.testing.assert_allclose(particles.grow(length, stress, 0.0, 0.3), length * math.exp(0.3),
                               rtol=1e-15)


def test_radii_of_rods_in_closed_form():
    """Enclosing radius: farthest segment end from the centroid + b/2; hull radius: sqrt(A/pi).

    Two rods of length 2 side by side, touching (y = -b/2, b/2): their hull is a rectangle
    1.5 x 1 with two half-stadium caps, area A = 1.5 + b (0.5 + pi b / 4) = 1.75 + pi/16.
    """
    b = particles.B
    x, theta, length = np.array([-1.0, 1.0]), np.zeros(2), np.full(2, 2.0)
    assert particles.enclosing_radius(x, np.zeros(2), theta, length) == 2.0
    assert particles.enclosing_radius(np.zeros(1), np.zeros(1), np.array([0.7]),
                                      np.array([2.0])) == pytest.approx(1.0, rel=1e-15)
    area = 1.75 + math.pi / 16
    assert particles.hull_radius(np.zeros(2), np.array([-b / 2, b / 2]), theta, length) == \
        pytest.approx(math.sqrt(area / math.pi), rel=1e-14)
    one = (1.5 * b + math.pi * b * b / 4) / math.pi  # a single rod's own area
    assert particles.hull_radius(np.zeros(1), np.zeros(1), np.zeros(1), np.array([2.0])) == \
        pytest.approx(math.sqrt(one), rel=1e-14)


def test_axial_stress_of_a_straight_chain():
    """line(3): two tip-to-tip contacts with G = 1/2 on each side, so sigma = G gamma exactly."""
    from particles.geometry import detect_contacts

    chain = particles.line(3)
    np.testing.assert_array_equal(chain.x, [-1.0, 0.0, 1.0])
    np.testing.assert_array_equal(chain.length, 1.0)
    assert particles.line(2, length=1.5).x.tolist() == [-0.75, 0.75]
    c = detect_contacts(chain.x, chain.y, chain.theta, chain.length, 0.1)
    np.testing.assert_array_equal(c.gap, 0.0)
    np.testing.assert_array_equal(particles.axial_stress(c, np.array([2.0, 4.0]), 3),
                                  [1.0, 3.0, 2.0])


def test_divide_splits_at_the_division_length():
    """A rod of length 2 at x = 1 becomes daughters of length 1 at x = 1 +- 1/2, new ids."""
    state = particles.ParticleState.from_arrays(np.array([1.0, 5.0]), np.zeros(2), np.zeros(2),
                                                np.array([2.0, 1.9]))
    assert particles.divide(state, np.random.default_rng(0), noise=0.0) == 1
    np.testing.assert_array_equal(state.x, [1.5, 5.0, 0.5])
    np.testing.assert_array_equal(state.length, [1.0, 1.9, 1.0])
    np.testing.assert_array_equal(state.theta, 0.0)
    np.testing.assert_array_equal(state.ids, [2, 1, 3])
    np.testing.assert_array_equal(state.parent, [0, -1, 0])
    np.testing.assert_array_equal(state.generation, [1, 0, 1])
    assert state.next_id == 4
    assert particles.divide(state, np.random.default_rng(0), noise=0.0) == 0


def test_packings_fill_without_overlap():
    """fill_outline and ring_packing: rods inside the outline, apart by at least the gap."""
    from particles.geometry import detect_contacts
    from particles.measures import tips

    b = particles.B
    square = np.array([[0.0, 0.0], [6.0, 0.0], [6.0, 6.0], [0.0, 6.0]])
    fill = particles.fill_outline(square, seed=2, orientation="rows", gap=1e-3)
    ex, ey = tips(fill.x, fill.y, fill.theta, fill.length)
    assert fill.n > 30 and 1.0 <= fill.length.min() and fill.length.max() <= 2.0
    assert min(ex.min(), ey.min()) - b / 2 >= 1e-3 - 1e-12
    assert 6.0 - max(ex.max(), ey.max()) - b / 2 >= 1e-3 - 1e-12
    c = detect_contacts(fill.x, fill.y, fill.theta, fill.length, 0.1)
    assert c.gap.min() >= 0.5e-3 - 1e-12
    x, y, theta, length = particles.ring_packing(100, seed=1)
    assert x.size >= 100 and 1.0 <= length.min() and length.max() <= 1.9
    c = detect_contacts(x, y, theta, length, 0.1)
    assert c.gap.min() >= 0.5e-3 - 1e-12


def test_read_trajectory_gives_the_final_state(tmp_path):
    """The last frame of a run's trajectory.gsd is its final state (float32 positions)."""
    done = run(Config(lam=1e-2, seed=1, radius=2.0), tmp_path)
    frames = list(particles.read_trajectory(tmp_path / "trajectory.gsd"))
    last = frames[-1]
    assert (last.step, last.t) == (done.state.step, done.state.t)
    assert frames[0].step == 0 and frames[0].n == 1
    for k in ("x", "y", "length", "stress"):
        np.testing.assert_allclose(getattr(last, k), getattr(done.state, k), rtol=1e-6,
                                   atol=1e-6, err_msg=k)
    np.testing.assert_array_equal(last.ids, done.state.ids)


def test_particle_limit_is_refused():
    with pytest.raises(particles.ParticleLimitError, match="max_particles 4"):
        run(Config(lam=0.0, time=3.0, max_particles=4))


def test_a_colony_at_the_dish_wall_stops():
    """A ValueError of one line (tests/particles/test_nutrients.py: a run that reaches it)."""
    assert issubclass(particles.DishWallError, ValueError)
    config = Config(lam=0.0, radius=5.0, nutrient_length=3.0, dish_radius=3.2)
    with pytest.raises(particles.DishWallError, match=r"^the colony reached the dish's wall"):
        Simulation(config, state=particles.line(6))  # centres at 2.5, within 2 h of 3.2


@pytest.mark.parametrize("state", ["garbage", {"x": [0.0]}, 3, "a continuum State"])
def test_a_state_of_another_type_is_refused_in_one_line(tmp_path, state):
    """Issue 54: state="garbage" raised AttributeError; a continuum State is refused too."""
    name = type(state).__name__
    if state == "a continuum State":
        import continuum

        state = continuum.Simulation(continuum.Config(lam=1e-2, n_nodes=100)).state
        name = "continuum.state.State"
    cfg = Config(lam=1e-2, time=1.0)
    for make in (lambda s: Simulation(cfg, state=s),
                 lambda s: Simulation(cfg, state=s, out=tmp_path),
                 lambda s: run(cfg, state=s),
                 lambda s: particles.simulation.check_initial(cfg, state=s)):
        with pytest.raises(TypeError) as err:
            make(state)
        assert str(err.value) == ("state must be a particles.ParticleState (or None: "
                                  f"config.init or one cell), got {name}")
    assert list(tmp_path.iterdir()) == []


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

    Only geometry (the diameter b), strains (the strains' checks; it imports nothing local)
    and runfiles (the field-type rules; it imports nothing of the engine).

    The solvers by name are those of config.SOLVERS.
    """
    import ast
    from pathlib import Path

    import particles.config
    from particles.solvers import BY_NAME

    def local_imports(module):
        tree = ast.parse(Path(module.__file__).read_text())
        return {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.level == 1}

    assert local_imports(particles.config) == {"geometry", "strains", "runfiles"}
    assert local_imports(particles.strains) == set()
    assert tuple(BY_NAME) == particles.config.SOLVERS


def test_a_removed_solver_is_refused_with_a_note(tmp_path):
    """A configuration or checkpoint naming a removed solver (issue 43) fails in one line.

    ValueError from Config's validation, naming the solvers there are and why it went.
    """
    import json
    import re

    from particles.config import SOLVERS
    from particles.runfiles import read_arrays

    with pytest.raises(ValueError, match=re.escape(f"unknown solver 'twolevel'; choose from "
                                                   f"{sorted(SOLVERS)} (twolevel was removed")):
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
