"""Shapes for both engines: cases.shapes.initial_particles and ``colony ... --shape``."""

import json

import numpy as np
import pytest

import particles
from cases import rundir
from cases.shapes import initial_particles, initial_state
from continuum import mesh as M
from continuum import shapes
from particles.geometry import detect_contacts
from particles.packings import packing_fractions


def one_line_error(status, err, *needles):
    assert status == 2, err
    assert err.count("\n") == 1 and err.startswith("colony: error:"), err
    for needle in needles:
        assert needle in err, err


@pytest.mark.parametrize("spec", ["ellipse:4,2", "rectangle:6,2,0.5", "star:3,0.3,4",
                                  "circle:3"])
def test_initial_particles_fill_every_shape(spec):
    state = initial_particles(spec, seed=2)
    outline = shapes.outline(spec)
    c = detect_contacts(state.x, state.y, state.theta, state.length, 0.1)
    assert c.gap.min() > 0
    inside = M.Locator(*M.triangulate(outline, 0.3)).locate(np.column_stack([state.x,
                                                                               state.y]))[2]
    assert inside.all()
    assert packing_fractions(state.length, M.polygon_area(outline))[0] > 0.6


def test_initial_particles_polygon_and_line(tmp_path):
    f = tmp_path / "square.csv"
    f.write_text("x,y\n0,0\n5,0\n5,5\n0,5\n0,0\n")
    state = initial_particles(f"polygon:{f}", seed=0, orientation="rows")
    assert state.n > 10 and state.x.min() > 0 and state.y.max() < 5
    line = initial_particles("line:4")
    assert line.n == 4 and np.all(line.length == 1)
    assert initial_state(particles.Config(lam=0.0, time=1.0)) is None


def test_shape_errors_are_one_line():
    with pytest.raises(ValueError, match="too small to hold a rod"):
        initial_particles("circle")  # radius R0: one particle's area, less than a rod
    with pytest.raises(ValueError, match="EPS must be in"):
        initial_particles("star:5,1,8")


def test_particle_runs_from_a_star_and_a_line(colony, tmp_path):
    for spec, n0 in (("star:5,0.2,8", 200), ("line:4", 4)):
        out = tmp_path / spec.split(":")[0]
        status, err = colony("particles", "--lam", "1e-2", "--time", "0.03", "--shape", spec,
                             "--seed", "1", "--quiet", "--out", str(out))
        assert status == 0, err
        config = json.loads((out / "config.json").read_text())
        assert config["shape"] == spec and config["fill_orientation"] == "tangent"
        rows = (out / "particles.csv").read_text().splitlines()
        assert len(rows) - 1 >= n0
        assert f"shape={spec}" in rundir.describe(out)  # colony info


def test_continuum_run_from_a_rectangle(colony, tmp_path):
    out = tmp_path / "rect"
    status, err = colony("continuum", "--lam", "1e-2", "--time", "0.02", "--shape",
                         "rectangle:3,1,0.25", "--set", "n_nodes=200", "--quiet", "--out",
                         str(out))
    assert status == 0, err
    assert json.loads((out / "config.json").read_text())["shape"] == "rectangle:3,1,0.25"


@pytest.mark.parametrize("engine,spec,words", [
    ("particles", "star:5,1", "EPS must be in [0, 1)"),
    ("particles", "hexagon:2", "unknown shape"),
    ("particles", "circle", "too small to hold a rod"),
    ("particles", "rectangle:4,2,1.5", "ROUND must be in"),
    ("continuum", "line:4", "no outline"),
    ("continuum", "ellipse:1", "takes 2 numbers"),
    ("continuum", "star:5,0.2,-1", "R must be positive"),
])
def test_bad_shape_through_the_cli(colony, tmp_path, engine, spec, words):
    status, err = colony(engine, "--lam", "1e-2", "--time", "0.1", "--shape", spec,
                         "--out", str(tmp_path / "run"))
    one_line_error(status, err, words)
    assert not any(tmp_path.iterdir())  # no folder created


def test_shape_with_init_is_refused(colony, tmp_path):
    f = tmp_path / "init.csv"
    f.write_text("x,y,theta,length\n0,0,0,1\n")
    status, err = colony("particles", "--lam", "1e-2", "--time", "0.1", "--shape", "line:2",
                         "--init", str(f), "--out", str(tmp_path / "run"))
    one_line_error(status, err, "init (a CSV file) or shape")


def test_resume_checks_the_shape(colony, tmp_path):
    """A stopped run of one shape is not resumed by a command with another shape."""
    stage = rundir.partial_of(tmp_path / "run")
    stage.mkdir()
    config = particles.Config(lam=1e-2, time=1.0, shape="line:3")
    sim = particles.run(config, stage, max_steps=1, state=initial_particles("line:3"))
    assert not sim.finished and (stage / "checkpoint.npz").exists()
    status, err = colony("particles", "--lam", "1e-2", "--time", "1", "--shape", "line:4",
                         "--out", str(tmp_path / "run"))
    one_line_error(status, err, "differs in shape")
    with pytest.raises(ValueError, match="differs in shape"):  # and the engine's own check
        particles.Simulation(particles.Config(lam=1e-2, time=1.0, shape="line:4"), out=stage)


def test_sweep_runs_a_particle_shape(tmp_path):
    from cases.sweep import run_engine

    run = tmp_path / "run"
    run_engine({"engine": "particles", "lam": 1e-2, "time": 0.02, "shape": "line:3"}, run)
    assert json.loads((run / "config.json").read_text())["shape"] == "line:3"
