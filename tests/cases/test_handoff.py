"""A particle colony handed to the continuum (cases.handoff, ``--from-particles``).

Known answers: the alpha shape of rods packed in a known outline (a disc of concentric rings,
a rectangle of rows) has its area and aspect ratio; Psi0's mean length at the nodes is the
kernel-weighted mean of the particle lengths exactly (lengths inside the cells' mean lengths)
and the local mean of a linear length field to the kernel's accuracy; the command runs from a
tiny particle run and refuses a bad run folder in one line (exit 2) before any work.
"""

import json
import math

import numpy as np
import pytest

from cases import handoff
from continuum import Config
from continuum.initial import state_from
from continuum.mesh import check_polygon, polygon_area
from continuum.sizes import LengthGrid
from particles import B, ring_packing


def rod_lattice(n_cols: int, n_rows: int, length) -> tuple[np.ndarray, ...]:
    """Horizontal rods on a lattice, columns 1.5 apart, rows b apart: (x, y, theta, length).

    The outline is the n_cols 1.5 x n_rows b rectangle with its corner x >= 0, y >= 0 (rods
    1.5 long touch end to end); ``length`` a number or a function of x. (The same lattice as
    docs/measurements/handoff.py's.)
    """
    i, j = np.meshgrid(np.arange(n_cols), np.arange(n_rows))
    x, y = (1.5 * i + 0.75).ravel(), (B * j + 0.5 * B).ravel()
    lengths = np.asarray(length(x) if callable(length) else length, dtype=float)
    return x, y, np.zeros(x.size), np.broadcast_to(lengths, x.shape).copy()


def test_outline_of_a_disc_packing():
    """Rods on concentric rings (radius 10.9): the disc's area and aspect ratio.

    Area within 1 % of the disc reaching the farthest rod outline (measured 0.2 %).
    """
    x, y, th, ln = ring_packing(400, seed=1)
    poly = handoff.particle_outline(x, y, th, ln)
    np.testing.assert_array_equal(check_polygon(poly), poly)  # simple, counter-clockwise
    R = np.hypot(*handoff.rod_outline_points(x, y, th, ln).T).max()
    area, aspect = handoff.polygon_moments(poly)
    assert area == pytest.approx(polygon_area(poly), rel=1e-12)
    assert area == pytest.approx(math.pi * R**2, rel=0.01)
    assert aspect == pytest.approx(1.0, abs=0.01)


def test_outline_of_a_rectangle_of_rods():
    """12 x 6 of rods 1.5 long: the rounded rod ends lose (1 - pi/4) b^2 / 2 per row end."""
    x, y, th, ln = rod_lattice(8, 12, 1.5)
    area, aspect = handoff.polygon_moments(handoff.particle_outline(x, y, th, ln))
    exact = 12 * 6 - 2 * 12 * (1 - math.pi / 4) * B**2 / 2  # 71.68 (the alpha shape's
    assert area == pytest.approx(exact, rel=0.01)           # chords cut less: 71.87)
    assert aspect == pytest.approx(2.0, rel=0.01)


def test_alpha_too_small_or_too_few_points():
    with pytest.raises(ValueError, match="at least three"):
        handoff.alpha_shape(np.zeros((2, 2)), 1.0)
    with pytest.raises(ValueError, match="keeps no triangle"):
        handoff.alpha_shape(np.array([[0, 0], [10, 0], [0, 10.0]]), 1.0)


def kernel_mean(xy, x, y, length, h):
    """The Gaussian-kernel-weighted mean of the lengths at the points xy (all particles)."""
    d2 = (xy[:, 0, None] - x[None]) ** 2 + (xy[:, 1, None] - y[None]) ** 2
    k = np.exp(-0.5 * d2 / h**2) * (d2 <= (4 * h) ** 2)
    return k @ length / k.sum(axis=1)


def test_psi0_mean_is_the_kernel_mean_of_the_lengths():
    """Lengths in [1.02, 1.95] (inside the cells' mean lengths): exact to round-off."""
    x, y, th, ln = ring_packing(300, seed=2, lmin=1.02, lmax=1.95)
    config = Config(lam=0.01, n_nodes=300)
    grid = LengthGrid(config.n_length_cells)
    psi0 = handoff.size_distribution(x, y, ln, grid)
    state = state_from(config, handoff.particle_outline(x, y, th, ln), psi0)
    f = state.fields
    np.testing.assert_allclose(f["mean_length_psi"],
                               kernel_mean(state.points, x, y, ln, handoff.BANDWIDTH),
                               rtol=1e-12)
    assert np.all(state.G == 0)
    # the packing: one rod width of length per unit area
    np.testing.assert_allclose(f["total_length"], 1 / B, rtol=1e-12)


def test_psi0_mean_is_the_local_mean_to_the_kernel_accuracy():
    """Lengths 1.2 + 0.02 x on a 30 x 30 lattice: Psi0's mean is l(x) 4 h inside, to 1e-3.

    The spread of the lengths at a node is that of l under the kernel, 0.02 h = 0.04.
    """
    x, y, th, ln = rod_lattice(20, 60, lambda x: 1.2 + 0.02 * x)
    config = Config(lam=0.01, n_nodes=400)
    psi0 = handoff.size_distribution(x, y, ln, LengthGrid(config.n_length_cells))
    state = state_from(config, handoff.particle_outline(x, y, th, ln), psi0)
    p = state.points
    inner = np.all((p > 4 * handoff.BANDWIDTH) & (p < 30 - 4 * handoff.BANDWIDTH), axis=1)
    assert inner.sum() > 20
    f = state.fields
    np.testing.assert_allclose(f["mean_length_psi"][inner], 1.2 + 0.02 * p[inner, 0], atol=1e-3)
    np.testing.assert_allclose(f["length_std_psi"][inner], 0.02 * handoff.BANDWIDTH, rtol=0.1)


def test_length_shares_keep_number_and_length():
    """Between the first and the last cell's mean lengths both are kept.

    Those are 1.00871 and 1.98277 for 40 cells; beyond them the particle goes wholly to the
    end cell.
    """
    grid = LengthGrid(40)
    q = grid.length_integrals / grid.ds
    assert q[0] - 1 < 0.0088 and 2 - q[-1] < 0.0173
    ln = np.array([1.0, q[0], 1.3, 1.5, q[-1], 1.999])
    k, w = handoff.length_shares(ln, grid)
    kept = w * q[k] + (1 - w) * q[k + 1]
    np.testing.assert_allclose(kept[1:-1], ln[1:-1], rtol=1e-12)
    assert kept[0] == pytest.approx(q[0]) and kept[-1] == pytest.approx(q[-1])


# ---------------------------------------------------------------------------- the command


@pytest.fixture(scope="module")
def particle_run(tmp_path_factory):
    """A tiny particle run (lam = 0.01 to radius 4: 16 particles)."""
    import particles

    out = tmp_path_factory.mktemp("handoff") / "p"
    out.mkdir()
    particles.run(particles.Config(lam=0.01, radius=4.0, seed=0), out=out)
    return out


def test_from_particles_runs_and_compares(particle_run, colony, tmp_path):
    out = tmp_path / "c"
    status, err = colony("continuum", "--from-particles", str(particle_run), "--radius", "2.6",
                         "--set", "n_nodes=200", "--out", str(out), "--quiet")
    assert status == 0, err
    rec = json.loads((out / handoff.HANDOFF).read_text())
    assert rec["particle_lam"] == 0.01 and rec["n_particles"] >= 10 and rec["G0"] == 0
    assert json.loads((out / "config.json").read_text())["lam"] == 0.01  # the particles' lam
    outline = np.loadtxt(out / handoff.OUTLINE, delimiter=",", skiprows=1)
    assert polygon_area(outline) == pytest.approx(rec["outline_area"])
    rows = handoff.compare_runs(particle_run, out)
    cont = rows["engine"] == 0
    assert rows["t"][cont][0] == 0 and (rows["engine"] == 1).sum() == 1  # the hand-off frame
    # at t = 0 both engines have the same colony: area (the mesh resamples the outline) and
    # mean length (kernel means of nearly equal lengths)
    np.testing.assert_allclose(rows["area"][cont][0], rows["area"][~cont][0], rtol=0.01)
    np.testing.assert_allclose(rows["mean_length"][cont][0], rows["mean_length"][~cont][0],
                               rtol=1e-3)
    assert rows["area"][cont][-1] > 1.5 * rows["area"][cont][0]


@pytest.mark.parametrize("args,match", [
    (["--from-particles", "{missing}"], "particle run folder not found"),
    (["--from-particles", "{empty}"], "no trajectory.gsd"),
    (["--from-particles", "{run}", "--shape", "circle"], "either --shape or --from-particles"),
    (["--alpha", "1"], "--alpha needs --from-particles"),
    (["--from-particles", "{run}", "--bandwidth", "-1"], "--bandwidth must be a positive"),
    (["--from-particles", "{run}", "--radius", "1.5"], "is not beyond the particle colony"),
])
def test_bad_from_particles_is_one_line_before_work(args, match, particle_run, colony,
                                                   tmp_path):
    (tmp_path / "empty").mkdir()
    names = {"missing": tmp_path / "nope", "empty": tmp_path / "empty", "run": particle_run}
    args = [a.format(**names) for a in args]
    radius = [] if "--radius" in args else ["--radius", "3"]
    status, err = colony("continuum", "--lam", "0.01", *radius, *args,
                         "--out", str(tmp_path / "c"))
    assert status == 2
    assert err.count("\n") == 1 and match in err
    assert not (tmp_path / "c").exists() and not (tmp_path / "c.partial").exists()


def test_simulation_from_particles(particle_run):
    """The API: the same start as the command, the same bits every time; it steps."""
    config = Config(lam=0.01, n_nodes=200, initial_sizes="histogram")
    sim, record = handoff.simulation_from_particles(particle_run, config)
    again, _ = handoff.continuum_start(particle_run, config)
    with pytest.raises(ValueError, match="initial_sizes='histogram'"):
        handoff.continuum_start(particle_run, Config(lam=0.01, n_nodes=200))
    assert sim.state.points.tobytes() == again.points.tobytes()
    assert sim.state.sizes.n.tobytes() == again.sizes.n.tobytes()
    assert sim.state.area == pytest.approx(record["outline_area"], rel=0.01)
    assert np.all(sim.state.G == 0)
    sim.step()
    assert sim.state.t > 0 and sim.state.G.max() > 0


def test_a_stopped_run_resumes_from_its_own_start_only(particle_run, colony, tmp_path):
    stage = tmp_path / "c.partial"
    stage.mkdir()
    (stage / "checkpoint.npz").write_bytes(b"")
    args = ["continuum", "--lam", "0.01", "--radius", "3", "--out", str(tmp_path / "c")]
    status, err = colony(*args, "--from-particles", str(particle_run))
    assert status == 2 and "stopped continuum run of a run without --from-particles" in err
    (stage / handoff.HANDOFF).write_text(json.dumps(
        {"particle_run": "/elsewhere", "step": 3, "alpha": 1.0, "bandwidth": 2.0}))
    status, err = colony(*args, "--from-particles", str(particle_run))
    assert status == 2 and "a hand-off from /elsewhere (step 3)" in err
    status, err = colony(*args)
    assert status == 2 and "hand-off from /elsewhere" in err
    assert err.count("\n") == 1
