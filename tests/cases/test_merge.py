"""cases.figures.merge: new particle data win lam by lam, the earlier data fill the rest."""

from __future__ import annotations

import numpy as np
import pytest

from cases import analysis as A
from cases import datasets
from cases.figures import merge

NAN = np.nan


def write(folder, files):
    for name, columns in files.items():
        A.write_csv(folder / name, columns)
    return folder


def test_merge_takes_new_particles_where_present_and_old_elsewhere(tmp_path):
    old = write(tmp_path / "old", {
        "summary.csv": {"lam": [0, 1e-3, 1e-2], "radius_continuum": [150, 150, 150],
                        "radius_particles": [151, 152, 153],
                        "max_stress_particles": [10, 20, 30],
                        "slope_particles": [1, 2, 3]},
        "radius_particles_lam=0.csv": {"t": [0, 1], "radius": [1, 2]},
        "radius_particles_lam=0.001.csv": {"t": [0, 1], "radius": [1, 3]},
        "radius_continuum_lam=0.csv": {"t": [0], "radius": [9]}})
    (old / "README.md").write_text("old\n")
    new = write(tmp_path / "new", {
        "summary.csv": {"lam": [0, 1e-3, 1e-2], "radius_continuum": [149, 149, 149],
                        "radius_particles": [150.5, NAN, NAN],
                        "max_stress_particles": [11, NAN, NAN],
                        "slope_particles": [1.5, NAN, NAN]},
        "radius_particles_lam=0.csv": {"t": [0, 1], "radius": [1, 2.5]},
        "radius_continuum_lam=0.csv": {"t": [0], "radius": [8]}})
    out = merge.merge("fig3", new, old, tmp_path / "out")
    s = A.read_csv(out / "summary.csv")
    np.testing.assert_array_equal(s["radius_continuum"], [149, 149, 149])
    np.testing.assert_array_equal(s["radius_particles"], [150.5, 152, 153])
    np.testing.assert_array_equal(s["max_stress_particles"], [11, 20, 30])
    assert A.read_csv(out / "radius_particles_lam=0.csv")["radius"][-1] == 2.5  # new
    assert A.read_csv(out / "radius_particles_lam=0.001.csv")["radius"][-1] == 3  # old
    assert A.read_csv(out / "radius_continuum_lam=0.csv")["radius"][0] == 8  # never old
    assert (out / "README.md").read_text() == "old\n"
    assert not (tmp_path / "out.partial").exists()
    with pytest.raises(ValueError, match="exists already"):
        merge.merge("fig3", new, old, out)
    assert merge.main(["fig5", str(new), str(old), str(tmp_path / "o2")]) == 2


def test_merge_snapshots_keep_old_particle_rows_of_lam_without_new_ones():
    old = {"engine": [0, 1, 1, 1], "lam": [0.01, 0.01, 0.001, 0.001], "k": [1, 1, 1, 2],
           "t": [1, 2, 3, 4], "radius": [5, 6, 7, 8]}
    new = {"engine": [0, 1], "lam": [0.01, 0.01], "k": [1, 1], "t": [1.5, 2.5],
           "radius": [5.5, 6.5]}
    m = merge.merge_snapshots(new, old)  # ordered by (engine, lam, k)
    np.testing.assert_array_equal(m["t"], [1.5, 3, 4, 2.5])
    np.testing.assert_array_equal(m["lam"], [0.01, 0.001, 0.001, 0.01])


def test_merge_of_a_reduction_of_some_lam_keeps_the_other_lam_whole(tmp_path):
    """NEW reduced for lam = 0 alone (``colony case fig3 --lams 0``): OLD keeps the others."""
    old = write(tmp_path / "old", {
        "summary.csv": {"lam": [0, 1e-3, 1e-2], "radius_continuum": [150, 150, 150],
                        "radius_particles": [151, 152, 153],
                        "max_stress_particles": [10, 20, 30], "slope_particles": [1, 2, 3]},
        "radius_particles_lam=0.csv": {"t": [0, 1], "radius": [1, 2]},
        "radius_continuum_lam=0.csv": {"t": [0], "radius": [9]},
        "radius_continuum_lam=0.001.csv": {"t": [0], "radius": [7]},
        "radius_particles_lam=0.01.csv": {"t": [0, 1], "radius": [1, 4]}})
    new = write(tmp_path / "new", {
        "summary.csv": {"lam": [0], "radius_continuum": [149], "radius_particles": [150.5],
                        "max_stress_particles": [11], "slope_particles": [1.5]},
        "radius_particles_lam=0.csv": {"t": [0, 1], "radius": [1, 2.5]},
        "radius_continuum_lam=0.csv": {"t": [0], "radius": [8]}})
    out = merge.merge("fig3", new, old, tmp_path / "out")
    s = A.read_csv(out / "summary.csv")
    np.testing.assert_array_equal(s["lam"], [0, 1e-3, 1e-2])
    np.testing.assert_array_equal(s["radius_continuum"], [149, 150, 150])
    np.testing.assert_array_equal(s["max_stress_particles"], [11, 20, 30])
    assert A.read_csv(out / "radius_continuum_lam=0.csv")["radius"][0] == 8  # new
    assert A.read_csv(out / "radius_continuum_lam=0.001.csv")["radius"][0] == 7  # old lam
    assert A.read_csv(out / "radius_particles_lam=0.01.csv")["radius"][-1] == 4
    assert datasets.lam_of("particles_lam=0.0001_k=3.csv.gz") == 1e-4
    assert datasets.lam_of("summary.csv") is None


def test_merge_snapshots_of_some_lam_keep_every_row_of_the_others():
    old = {"engine": [0, 1, 0, 1], "lam": [0.01, 0.01, 0.001, 0.001], "k": [1, 1, 1, 1],
           "t": [1, 2, 3, 4], "radius": [5, 6, 7, 8]}
    new = {"engine": [0, 1], "lam": [0.001, 0.001], "k": [1, 1], "t": [3.5, 4.5],
           "radius": [7.5, 8.5]}
    m = merge.merge_snapshots(new, old)
    np.testing.assert_array_equal(m["t"], [3.5, 1, 4.5, 2])
