"""Orientational order (cases.analysis.orientation) against exact answers; the smoke case."""

import math
from pathlib import Path

import meshio
import numpy as np
import pytest

from cases import analysis as A
from cases.analysis import orientation as O
from cases.studies import orientation as case
from tests.pictures import assert_figures


def _disc_points(R=10.0, spacing=0.25, center=(0.13, -0.21)):
    """Points of a square lattice inside a disc; the centre off the grid's lines."""
    g = np.arange(-R, R + spacing, spacing)
    x, y = (a.ravel() for a in np.meshgrid(g, g))
    keep = np.hypot(x - center[0], y - center[1]) < R
    return x[keep], y[keep], np.asarray(center)


def _charges(x, y, theta, cell=1.0):
    grid = O.orientation_grid(x, y, theta, cell=cell, smooth=0, min_count=1)
    return O.grid_defects(grid)


def test_aligned_rows_order_one():
    """Rods in parallel rows: S = 1 exactly, the director their angle, no defect."""
    x, y, _ = _disc_points(6.0, 0.5)
    theta = np.full(x.size, 0.3)
    qxx, qxy = O.order_tensor(theta)
    assert O.order_parameter(qxx, qxy) == pytest.approx(1.0, abs=1e-14)
    assert O.director_angle(qxx, qxy) == pytest.approx(0.3, abs=1e-14)
    grid = O.orientation_grid(x, y, theta + np.pi * (np.arange(x.size) % 2), cell=2.0)
    assert np.allclose(grid["S"][grid["valid"]], 1.0, atol=1e-14)  # head-tail symmetric
    assert O.grid_defects(grid)["charge"].size == 0


def test_isotropic_order_scaling():
    """Uniform random angles: mean S = sqrt(pi / 4n), fitted exponent within 0.03 of -1/2."""
    rng = np.random.default_rng(1)
    ns = np.array([16, 64, 256, 1024, 4096])
    mean_S = np.array([np.mean([O.order_parameter(*O.order_tensor(rng.uniform(0, np.pi, n)))
                                for _ in range(400)]) for n in ns])
    exponent = np.polyfit(np.log(ns), np.log(mean_S), 1)[0]
    assert abs(exponent + 0.5) < 0.03, exponent
    assert np.allclose(mean_S, O.isotropic_order(ns), rtol=0.06)


@pytest.mark.parametrize("turn", [np.pi / 2, 0.0], ids=["vortex", "aster"])
def test_plus_one_is_two_half_defects(turn):
    """A vortex (rods along circles) or an aster (along radii): a +1 defect.

    Each plaquette carries at most 1/2, so it is counted as TWO +1/2 defects, next to the core
    (within 1.5 cells), and no -1/2: total +1.
    """
    x, y, c = _disc_points()
    theta = np.arctan2(y - c[1], x - c[0]) + turn
    d = _charges(x, y, theta)
    assert np.sort(d["charge"]).tolist() == [0.5, 0.5]
    assert np.all(np.hypot(d["x"] - c[0], d["y"] - c[1]) < 1.5)
    ann = O.annulus_order(x, y, theta, c, 10.0, width=2.0)
    sign = -1.0 if turn else 1.0  # tangent: q_r = -1, radial: +1
    assert np.allclose(ann["q_r"], sign, atol=1e-12)
    assert np.allclose(ann["mean_abs_angle"], 90.0 if turn else 0.0, atol=1e-5)


@pytest.mark.parametrize("k", [0.5, -0.5])
def test_half_defects(k):
    """Director psi = k phi about the core: exactly one defect, of charge k, at the core."""
    x, y, c = _disc_points()
    theta = k * np.arctan2(y - c[1], x - c[0]) + 0.2
    d = _charges(x, y, theta)
    assert d["charge"].tolist() == [k]
    assert math.hypot(d["x"][0] - c[0], d["y"][0] - c[1]) < 1.0


def test_defect_pair_and_loop_sum():
    """A +1/2 and a -1/2 far apart (director psi = (phi_1 - phi_2)/2): both found, sum 0."""
    x, y, _ = _disc_points(12.0)
    theta = 0.5 * (np.arctan2(y - 0.1, x + 5.1) - np.arctan2(y - 0.1, x - 4.9))
    d = _charges(x, y, theta)
    assert sorted(d["charge"].tolist()) == [-0.5, 0.5]
    assert d["x"][d["charge"] > 0][0] == pytest.approx(-5.0, abs=1.0)


def test_vtu_round_trip(tmp_path):
    """The grid VTU holds the filled cells with their S and director; the defects their charge."""
    x, y, c = _disc_points(5.0)
    theta = np.arctan2(y - c[1], x - c[0]) + np.pi / 2
    grid = O.orientation_grid(x, y, theta, cell=1.0, smooth=0, min_count=1)
    paths = O.write_orientation_vtu(tmp_path / "g.vtu", grid, O.grid_defects(grid), t=2.5)
    m = meshio.read(paths[0])
    assert m.cells[0].type == "quad" and len(m.cells[0].data) == grid["valid"].sum()
    assert np.allclose(np.sort(m.cell_data["S"][0]), np.sort(grid["S"][grid["valid"]]))
    assert m.cell_data["director"][0].shape[1] == 3
    assert meshio.read(paths[1]).point_data["charge"].tolist() == [0.5, 0.5]


def test_smoke_case(tmp_path):
    """`colony case orientation` at smoke scale: radius 8, lam 0 and 1e-2, two seeds each.

    The runs are made in this process (cases.sweep.run_engine), then the case reduces them
    (finished runs only) and draws; every file of the module doc is there, the flow's
    anisotropy is 0 at lam = 0 and positive at 1e-2, the order lies between its floor and 1.
    """
    from cases.sweep import run_engine, run_name

    runs = tmp_path / "runs"
    for _, _, p in case.run_params("smoke"):
        run_engine(p, runs / run_name(p))
    data = case.compute("smoke", out=tmp_path / "out", runs=runs,
                        finished_only=("particles",))
    for name in ("annuli", "seeds", "series", "profile", "summary", "grid_lam=0",
                 "defects_lam=0.01"):
        assert (data / f"{name}.csv").is_file(), name
    s = A.read_csv(data / "summary.csv")
    assert s["seeds"].tolist() == [2, 2]
    assert s["anisotropy_edge"][0] == 0 and s["anisotropy_edge"][1] > 0
    assert np.all((s["S_local_mean"] > s["S_local_iso_mean"]) & (s["S_local_mean"] < 1))
    paths = case.plot(data, tmp_path / "out")
    assert_figures([p for p in paths if p.suffix == ".png"])
    assert "isotropic floor" in (tmp_path / "out" / "results.md").read_text()
    assert len(list(Path(tmp_path / "out" / "vtu").glob("*.vtu"))) == 4


def test_committed_medium(tmp_path):
    """cases/data/orientation (radius 40, 4 seeds per lam): redrawn; what docs/results.md says.

    Radial alignment beyond R/2 at lam = 1e-2 is more than 4 seed std above that at lam = 0;
    at every lam the edge annulus is tangent (q_r < -0.15) and the order above its floor.
    """
    data = Path(case.__file__).parents[1] / "data" / "orientation"
    assert (data / "README.md").is_file()
    paths = case.plot(data, tmp_path)
    assert_figures([p for p in paths if p.suffix == ".png"])
    s = A.read_csv(data / "summary.csv")
    assert s["seeds"].tolist() == [4, 4, 4, 4]
    gap = s["q_r_outer_mean"][3] - s["q_r_outer_mean"][0]
    assert gap > 4 * max(s["q_r_outer_std"][0], s["q_r_outer_std"][3])
    p = A.read_csv(data / "profile.csv")
    assert np.all(p["q_r_mean"][p["r"] == p["r"].max()] < -0.15)
    assert np.all(s["S_local_mean"] > 2 * s["S_local_iso_mean"])


def test_paper_colonies_reduce_given_run_folders(particle_run, tmp_path):
    """paper_colonies: the last frame's scalars per seed and the annuli, with the flow beside."""
    from cases.studies.orientation import paper_colonies

    data = paper_colonies({0: particle_run, 3: particle_run}, 1e-2, tmp_path)
    seeds = A.read_csv(data / "paper_seeds.csv")
    np.testing.assert_array_equal(seeds["seed"], [0, 3])
    ((_, last),) = A.particle_frames(particle_run, last_only=True)
    expected = O.frame_orientation(last)["scalars"]
    for k in ("q_r", "S_local", "n_plus", "radius"):
        assert seeds[k][0] == pytest.approx(expected[k], rel=1e-7) and seeds[k][1] == seeds[k][0]
    ann = A.read_csv(data / "paper_annuli.csv")
    assert ann["r"].size % 2 == 0 and np.all(ann["relative_anisotropy"] >= 0)
