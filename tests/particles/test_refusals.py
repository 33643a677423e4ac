"""From Python, the engine refuses what the CLI refuses, before any work, in one line."""

import re

import numpy as np
import pytest

import particles
from particles import Config, Simulation, run
from particles.output import read_init


def test_run_refuses_millions_of_steps_before_any_work(tmp_path):
    """Config(lam=1e-2, dt=1e-300) to a radius: Config.check_budget, as the CLI's."""
    config = Config(lam=1e-2, radius=8.0, dt=1e-300)
    with pytest.raises(ValueError, match=r"dt = 1e-300 takes .* steps to radius 8"):
        run(config, tmp_path)
    assert list(tmp_path.iterdir()) == []  # nothing written
    with pytest.raises(ValueError, match="steps to radius 8"):
        Simulation(config)
    with pytest.raises(ValueError, match="steps to time 1"):
        run(Config(lam=0.0, time=1.0, dt=1e-9))


def test_budget_of_a_given_state_and_an_init_file(tmp_path):
    """A radius goal's steps from the initial colony: a given state, an init file."""
    config = Config(lam=1e-2, radius=50.0, dt=1e-7)
    with pytest.raises(ValueError, match="steps to radius 50 from the initial radius 0.5"):
        run(config, state=particles.single_cell())
    init = tmp_path / "init.csv"
    init.write_text("x,y,theta,length\n0,0,0,1\n2,0,0,1\n")
    with pytest.raises(ValueError, match="steps to radius 50 from the initial radius 1.5"):
        Simulation(Config(lam=1e-2, radius=50.0, dt=1e-7, init=str(init)))


def test_a_simulation_stepped_by_hand_has_no_goal_to_refuse():
    """Without radius or time there is no budget: a tiny dt steps."""
    sim = Simulation(Config(lam=0.0, dt=1e-12))
    assert sim.step().dt == 1e-12


def test_init_row_shorter_than_its_header(tmp_path):
    init = tmp_path / "short.csv"
    init.write_text("x,y,theta,length\n0,0,0,1\n\n3,0,0\n")
    with pytest.raises(ValueError) as err:
        read_init(init)
    message = str(err.value)
    assert message == (f"init file {init}: row 2 (line 4) is shorter than the header, "
                       "no value for length")
    assert "\n" not in message
    with pytest.raises(ValueError, match=r"row 2 \(line 4\) is shorter"):
        run(Config(lam=0.0, time=0.1, init=str(init)))


def test_init_file_reads(tmp_path):
    """A well-formed file still reads (and a longer row's extra values are ignored)."""
    p = tmp_path / "ok.csv"
    p.write_text("x,y,theta,length\n0,0,0,1\n3,0,0.5,1.5,9\n")
    x, y, theta, length = read_init(p)
    np.testing.assert_array_equal(x, [0.0, 3.0])
    np.testing.assert_array_equal(length, [1.0, 1.5])


def test_advance_refuses_what_run_refuses():
    """``Simulation.advance`` checks the budget of its goal as ``run`` does (no hang)."""
    import particles

    sim = particles.Simulation(particles.Config(lam=0.0, dt=1e-300))
    with pytest.raises(ValueError, match=r"dt = 1e-300 takes more than 1e\+300 steps"):
        sim.advance(radius=8)
    assert sim.state.step == 0


@pytest.mark.parametrize("margin", [1e300, -0.1, 10.5])
def test_contact_margin_within_its_range(margin):
    with pytest.raises(ValueError, match=r"contact_margin must be in \[0, 10\]"):
        Config(lam=0.0, radius=3.0, contact_margin=margin)


@pytest.mark.parametrize("kw,match", [
    (dict(lam=1e300), r"lam must be in \[0, 10000\], got 1e\+300"),
    (dict(lam=0.0, strains=[(1e300, 1.0), (0.0, 1.0)]),
     r"a strain's lam must be in \[0, 10000\], got 1e\+300"),
    (dict(lam=0.0, solver_tol=1e300), r"solver_tol must be in \(0, tol = 0.001\], got 1e\+300"),
    (dict(lam=0.0, solver_tol=2e-3), r"solver_tol must be in \(0, tol = 0.001\]"),
    (dict(lam=0.0, solver_tol_factor=1e300), "solver_tol_factor must be positive and at most 1"),
])
def test_absurd_values_refused_when_made(kw, match):
    """Issue 54: each ran and failed late (OverlapError, a colony of max_particles)."""
    with pytest.raises(ValueError, match=match):
        Config(time=1.0, **kw)
    Config(lam=0.0, time=1.0, solver_tol=1e-3, solver_tol_factor=0.5)  # the bounds themselves


@pytest.mark.parametrize("rows,match", [
    ("0,0,0,1e300\n", r"row 1 has a rod of length 1e\+300"),
    ("0,0,0,1\n0,1e300,0,1\n", r"row 2 has a rod centred at \(0, 1e\+300\)"),
])
def test_init_file_of_absurd_sizes_named(tmp_path, rows, match):
    f = tmp_path / "init.csv"
    f.write_text("x,y,theta,length\n" + rows)
    with pytest.raises(ValueError, match=f"^init file {re.escape(str(f))}: {match}"):
        particles.from_csv(f)
    out = tmp_path / "out"
    out.mkdir()
    with pytest.raises(ValueError, match=match):
        run(Config(lam=0.0, time=1.0, init=str(f)), out)
    assert list(out.iterdir()) == []
