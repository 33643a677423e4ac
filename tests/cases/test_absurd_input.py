"""Absurd values refused before any work, with an estimate (issue 28, "Absurd values").

Each case through ``cases.cli.main``: exit status 2, one ``colony: error:`` line stating the
estimate, and nothing written. The estimates against runs (steps, area, rods), the polygon
closed to round-off, and property-based tests (hypothesis) of the shape and init strings:
a shape, a state, or a one-line ValueError, never another exception.
"""

import logging
import math
import string
import time
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import continuum
import particles
from cases import shapes as case_shapes
from continuum import mesh, shapes
from continuum.budget import check_memory, least_area
from particles import packings
from particles.config import MAX_STEPS, SINGLE_CELL_RADIUS, least_steps

from .test_faults import one_line_error

P = ("particles", "--lam", "1e-2", "--quiet")
C = ("continuum", "--lam", "1e-2", "--quiet")


def circle_csv(path: Path, n: int, close=lambda first: first) -> Path:
    """A polygon file of n vertices on the circle of radius 10, closed by ``close(first)``."""
    t = 2 * np.pi * np.arange(n) / n
    xy = np.column_stack([10 * np.cos(t), 10 * np.sin(t)])
    rows = [f"{x!r},{y!r}" for x, y in xy.tolist()]
    last = close(xy[0].tolist())
    path.write_text("x,y\n" + "\n".join(rows) + f"\n{last[0]!r},{last[1]!r}\n")
    return path


@pytest.mark.parametrize("args,needles", [
    ((*P, "--radius", "2", "--dt", "1e-300"),
     ("dt = 1e-300 takes more than 1e+300 steps to radius 2", f"{MAX_STEPS:,}")),
    ((*P, "--time", "1e308"), ("takes more than 1e+300 steps to time 1e+308",)),
    ((*P, "--time", "1e5"), ("at least 5e+06 steps",)),
    ((*P, "--radius", "1e308"), ("more than 1e+300 particles", "max_particles = 500000")),
    ((*P, "--radius", "500"), ("at least 7.07e+05 particles", "max_particles")),
    ((*P, "--radius", "1e5", "--set", "max_particles=1000000000000"),
     ("GiB, more than the", "GiB of this machine's memory")),
    ((*C, "--radius", "1e308"), ("mesh nodes at its final size (radius 1e+308)", "GiB")),
    ((*C, "--time", "1e308"), ("mesh nodes at its final size (time 1e+308)", "GiB")),
    (("continuum", "--lam", "0", "--time", "40"), ("mesh nodes at its final size (time 40)",)),
    ((*P, "--time", "1", "--shape", "line:1000000000"),
     ("1,000,000,000 cells, more than max_particles = 500000",)),
    ((*P, "--time", "1", "--shape", "star:1e9,0.5"),
     ("K must be at most 312", "32,000,000,000 vertices")),
    ((*C, "--time", "1", "--shape", "star:1e9,0.5"), ("K must be at most 312",)),
    ((*P, "--time", "1", "--shape", "ellipse:1e-300,1"), ("must be in [1e-06, 1e+06]",)),
    ((*C, "--time", "1", "--shape", "ellipse:1e-300,1"), ("must be in [1e-06, 1e+06]",)),
    ((*C, "--time", "1", "--shape", "circle:1e308"), ("the radius R must be in",)),
    ((*C, "--time", "1", "--set", "initial_radius=1e-300"), ("initial_radius", "must be in")),
    ((*P, "--time", "1", "--shape", "circle:2000"),
     ("about 1.81e+07 rods, more than max_particles = 500000",)),
    ((*P, "--time", "1", "--shape", "rectangle:40000,1"), ("takes about", "h a fill may take")),
    ((*P, "--radius", "5", "--shape", "circle:3", "--dt", "1e-300"),
     ("steps to radius 5 from the initial radius 3.0",)),
])
def test_absurd_value_refused_before_any_work(colony, tmp_path, args, needles):
    start = time.perf_counter()
    status, err = colony(*args, "--out", str(tmp_path / "run"))
    one_line_error(status, err, *needles)
    assert not any(tmp_path.iterdir())
    assert time.perf_counter() - start < 60


def test_polygon_of_1e5_vertices(colony, tmp_path):
    f = circle_csv(tmp_path / "p.csv", 100_000)
    for engine in ("particles", "continuum"):
        status, err = colony(engine, "--lam", "1e-2", "--time", "1", "--shape", f"polygon:{f}",
                             "--out", str(tmp_path / "run"))
        one_line_error(status, err, str(f), "more than 10,000 vertices")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.csv"]


def test_1e5_rods_in_a_unit_square(colony, tmp_path):
    """Refused at once (was: MemoryError after minutes, the contacts of every pair)."""
    rng = np.random.default_rng(0)
    f = tmp_path / "crowd.csv"
    x, y, theta = rng.random(100_000), rng.random(100_000), rng.random(100_000)
    np.savetxt(f, np.column_stack([x, y, theta, np.full(100_000, 1.5)]), delimiter=",",
               header="x,y,theta,length", comments="")
    start = time.perf_counter()
    status, err = colony(*P, "--radius", "5", "--init", str(f), "--out", str(tmp_path / "r"))
    one_line_error(status, err, str(f), "100000 rods centred in the unit square at (0, 0)",
                   "they overlap")
    assert time.perf_counter() - start < 30
    assert sorted(p.name for p in tmp_path.iterdir()) == ["crowd.csv"]


def test_a_valid_dense_init_passes_the_crowding_check():
    x, y, theta, length = packings.ring_packing(400, seed=1)
    packings._check_crowding(x, y, length)


# --------------------------------------------------------------------------- polygons


def test_polygon_closed_to_round_off_is_closed(tmp_path):
    f = circle_csv(tmp_path / "p.csv", 400, lambda first: [first[0] * (1 + 1e-13), 1e-13])
    assert shapes.polygon_csv(f).shape == (400, 2)
    continuum.Config(lam=0.01, radius=12.0, shape=f"polygon:{f}").validate()
    assert case_shapes.initial_particles(f"polygon:{f}").n > 100
    g = circle_csv(tmp_path / "q.csv", 400, lambda first: [first[0] * (1 + 1e-9), 0.0])
    with pytest.raises(ValueError, match="not closed"):
        shapes.polygon_csv(g)


@pytest.mark.parametrize("content,needle", [
    (b"x,y\n0,0\n1,0\x00\n", "cannot read x,y"),
    (bytes(range(256)), "not a text CSV file"),
    (b"x,y\n0,0\n1e300,0\n0,1\n0,0\n", "within +-1e+06"),
    (b"x,y\n0,0\nnan,0\n0,1\n0,0\n", "finite numbers"),
    (b"x,y\n0,0\n1,0\n1,1\n0,1\n1,0.5\n0,0\n", "not simple"),
])
def test_bad_polygon_files_named(tmp_path, content, needle):
    f = tmp_path / "p.csv"
    f.write_bytes(content)
    with pytest.raises(ValueError) as err:
        shapes.polygon_csv(f)
    assert str(f) in str(err.value) and needle in str(err.value) and "\n" not in str(err.value)


# --------------------------------------------------------------------------- estimates


def test_budget_is_asked_apart_from_validity():
    """A configuration may name a far goal (a benchmark steps by hand); a run checks its budget."""
    config = particles.Config(lam=1e-2, time=1e9)
    config.validate()
    with pytest.raises(ValueError, match="at least 5e\\+10 steps to time 1e\\+09"):
        config.check_budget()
    shape = particles.Config(lam=1e-2, radius=5.0, shape="circle:3", dt=1e-300)
    shape.check_budget()  # the steps of a shape's radius goal: from its fill's radius
    with pytest.raises(ValueError, match="from the initial radius 3"):
        shape.check_budget(initial_radius=3.0)


def test_least_steps_below_a_run():
    config = particles.Config(lam=1e-2, radius=4.0, step_control="fixed")
    run = particles.run(config)
    assert len(run.history) - 1 >= least_steps(config, SINGLE_CELL_RADIUS) > 50


@pytest.mark.parametrize("lam,shape", [(0.0, "circle"), (1.0, "circle"), (10.0, "circle"),
                                       (1.0, "rectangle:4,0.5")])
def test_least_area_below_a_run(lam, shape):
    """A time run's area is at least continuum.budget.least_area (to the engine's 1.2 %)."""
    config = continuum.Config(lam=lam, time=3.0, shape=shape, n_nodes=200, write_fields=False)
    a0 = abs(mesh.polygon_area(config.initial_boundary()))
    assert continuum.run(config).state.area >= 0.985 * least_area(a0, lam, 3.0)


def test_thin_shape_counts_its_boundary_nodes():
    config = continuum.Config(lam=0.01, radius=2.0, shape="ellipse:1e-6,1")
    config.validate()
    assert check_memory(config) > 4.0 / config.h_max
    with pytest.raises(ValueError, match="mesh nodes"):
        check_memory(config, memory=2**30)


def test_fill_estimate_against_a_fill(caplog, monkeypatch):
    rods, seconds = packings.fill_estimate(shapes.outline("circle:20"))
    monkeypatch.setattr(case_shapes, "ANNOUNCE_SECONDS", 0.0)
    with caplog.at_level(logging.INFO, logger="cases.shapes"):
        state = case_shapes.initial_particles("circle:20")
    assert 0.9 < state.n / rods < 1.0 and 0.2 < seconds < 30
    assert "shape circle:20: filling with about 1.81e+03 rods" in caplog.text


# --------------------------------------------------------------------------- properties


NUMBER = (st.floats().map(repr) | st.floats(1e-7, 1e7).map(repr) | st.floats(0, 1).map(repr)
          | st.integers(-3, 400).map(str) | st.sampled_from(["", " ", "1e-6", "1e6", "2", "0.5"])
          | st.text(max_size=4))
SIZE = (st.floats(1e-8, 1e8).map(repr) | st.floats(0.3, 20).map(repr)
        | st.sampled_from(["1e308", "0", "-1", "nan", "inf", "1e-300", "1e6", "1e-6"]))
WELL_FORMED = st.one_of(
    st.builds("circle:{}".format, SIZE),
    st.builds("ellipse:{},{}".format, SIZE, SIZE),
    st.builds(lambda w, h, r: f"rectangle:{w},{h}" + ("" if r is None else f",{r}"), SIZE, SIZE,
              st.none() | SIZE | st.floats(0, 1).map(repr)),
    st.builds(lambda k, eps, r: f"star:{k},{eps}" + ("" if r is None else f",{r}"),
              st.integers(-1, 400) | st.floats(0, 9).map(repr), st.floats(-0.5, 1.5).map(repr),
              st.none() | SIZE),
    st.builds("line:{}".format, st.integers(-2, 10**12) | st.floats().map(repr)))
SPECS = (st.text(max_size=30)
         | st.builds(lambda kind, numbers: f"{kind}:{','.join(numbers)}",
                     st.sampled_from([*shapes.KINDS, "Circle", "", " star"]),
                     st.lists(NUMBER, max_size=4))
         | st.sampled_from([*shapes.KINDS, "polygon:", "polygon:missing.csv", "line:0"])
         | WELL_FORMED | WELL_FORMED)


@settings(max_examples=150, deadline=None)
@given(spec=SPECS)
def test_random_shape_strings_never_a_traceback(spec):
    """parse, outline, the continuum's configuration and memory estimate: value or one line."""
    try:
        shape = shapes.parse(spec)
        polygon = shapes.outline(shape)
        assert polygon.ndim == 2 and np.all(np.isfinite(polygon))
        config = continuum.Config(lam=0.01, time=1.0, shape=spec)
        config.validate()
        check_memory(config)
    except ValueError as err:
        assert str(err).strip() and "\n" not in str(err), repr(str(err))


@settings(max_examples=60, deadline=None)
@given(spec=SPECS, lengths=st.sampled_from(packings.FILL_LENGTHS))
def test_random_shape_strings_filled_or_refused(spec, lengths):
    """The particles of a shape (fills of at most 300 rods and 2 s): a state or one line."""
    with mock.patch.object(packings, "MAX_FILL_SECONDS", 2.0):
        try:
            state = case_shapes.initial_particles(spec, lengths=lengths, max_rods=300)
        except ValueError as err:
            assert str(err).strip() and "\n" not in str(err), repr(str(err))
        else:
            assert 1 <= state.n <= 300


@settings(max_examples=80, deadline=None)
@given(init=st.text(max_size=40) | st.text(string.printable, max_size=300),
       shape=st.none() | SPECS)
def test_random_init_strings_never_a_traceback(init, shape):
    """``init`` (and a ``shape`` beside it) of a particle configuration: valid or one line."""
    try:
        particles.Config(lam=0.01, time=1.0, init=init, shape=shape).validate()
    except ValueError as err:
        assert str(err).strip() and "\n" not in str(err), repr(str(err))
    else:
        assert Path(init).is_file()


@settings(max_examples=60, deadline=None)
@given(xy=st.lists(st.tuples(st.floats(-20, 20), st.floats(-20, 20)), min_size=0, max_size=12),
       close=st.sampled_from(["exact", "round-off", "open"]))
def test_random_polygon_files_never_a_traceback(tmp_path_factory, xy, close):
    rows = list(xy)
    if rows and close != "open":
        x0, y0 = rows[0]
        rows.append((x0, y0) if close == "exact" else (x0 * (1 + 1e-14), y0 + 1e-14))
    f = tmp_path_factory.mktemp("poly") / "p.csv"
    f.write_text("x,y\n" + "".join(f"{x!r},{y!r}\n" for x, y in rows))
    try:
        polygon = shapes.polygon_csv(f)
    except ValueError as err:
        assert str(err).strip() and "\n" not in str(err), repr(str(err))
    else:
        assert len(polygon) >= 3 and mesh.polygon_area(polygon) > 0
        assert math.isfinite(mesh.polygon_area(polygon))


# --------------------------------------------------------------------------- issue 54


@pytest.mark.parametrize("args,needles", [
    (("continuum", "--lam", "-1", "--radius", "5", "--quiet"),
     ("critical radius sqrt(2/|lam|) = 1.414: radius 5 lies beyond it",)),
    (("continuum", "--lam", "-1", "--time", "5", "--quiet"),
     ("which the disc reaches at t = 2.244: time 5 lies beyond it",)),
    (("continuum", "--lam", "1e300", "--time", "1", "--quiet"),
     ("lam must be in [-10000, 10000], got 1e+300", "growth all but stops")),
    (("particles", "--lam", "1e300", "--time", "1", "--quiet"),
     ("lam must be in [0, 10000], got 1e+300", "growth all but stops")),
    ((*P, "--time", "1", "--set", "solver_tol=1e300"),
     ("solver_tol must be in (0, tol = 0.001], got 1e+300", "looser than tol")),
    ((*P, "--time", "1", "--set", "solver_tol_factor=1e300"),
     ("solver_tol_factor must be positive and at most 1, got 1e+300",)),
    (("continuum", "--time", "1", "--strains", "1e300,0", "--layout", "core:0.3", "--quiet"),
     ("a strain's lam must be in [0, 10000], got 1e+300",)),
    (("particles", "--time", "1", "--strains", "1e300,0", "--layout", "core:0.3", "--quiet"),
     ("a strain's lam must be in [0, 10000], got 1e+300",)),
    ((*C, "--time", "1000"),
     ("mesh nodes at its final size (time 1000), a radius of at least 1.36e+04", "GiB")),
])
def test_bad_values_refused_before_any_work(colony, tmp_path, args, needles):
    """Issue 54: each started a run that failed late (or never ended) and left DIR.partial."""
    status, err = colony(*args, "--out", str(tmp_path / "run"))
    one_line_error(status, err, *needles)
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("rows,needles", [
    ("0,0,0,1e300\n", ("row 1 has a rod of length 1e+300", "(b = 0.5, 1000]")),
    ("0,0,0,1\n1e300,0,0,1\n", ("row 2 has a rod centred at (1e+300, 0)", "within +-1000")),
])
def test_init_file_of_absurd_sizes(colony, tmp_path, rows, needles):
    """Issue 54: a rod of length 1e300 divided into max_particles cells; x = 1e300 crashed."""
    f = tmp_path / "init.csv"
    f.write_text("x,y,theta,length\n" + rows)
    status, err = colony(*P, "--radius", "5", "--init", str(f), "--out", str(tmp_path / "run"))
    one_line_error(status, err, f"init file {f}: ", *needles)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["init.csv"]


def test_bandwidth_beyond_its_range(colony, tmp_path, particle_run):
    """Issue 54: --bandwidth 1e300 was a 35-line OverflowError traceback."""
    status, err = colony("continuum", "--from-particles", str(particle_run), "--radius", "3",
                         "--bandwidth", "1e300", "--quiet", "--out", str(tmp_path / "run"))
    one_line_error(status, err, "bandwidth must be a positive number at most 10, got 1e+300")
    assert not any(tmp_path.iterdir())
    from cases import handoff

    handoff.check_bandwidth(handoff.MAX_BANDWIDTH)
    with pytest.raises(ValueError, match="at most 10"):
        handoff.continuum_start(particle_run, continuum.Config(lam=0.01, radius=3.0,
                                                               initial_sizes="histogram"),
                                bandwidth=1e300)
