"""cases.viewer: pictures and movies redrawn from a run folder of either engine.

Tiny runs (particles to radius 4, 16 particles; continuum to radius 2, 17 VTU frames) are made
once per session (tests/conftest.py); the movies are read back with imageio-ffmpeg and hold one
frame per saved frame.
"""

from __future__ import annotations

import shutil

import imageio_ffmpeg
import numpy as np
import pytest

from cases.analysis import continuum_frames
from cases.viewer import boundary_edges, movie_run, plot_run, run_kind
from particles.output import count_frames


def _is_png(path):
    return path.is_file() and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plot_particle_run(particle_run, tmp_path):
    (particle_run / "profile.csv").write_text("r,mean_length\n0.5,1.3\n1.5,1.4\n")
    try:
        paths = plot_run(particle_run, out=tmp_path)
    finally:
        (particle_run / "profile.csv").unlink()
    assert [p.name for p in paths] == ["colony.png", "radius.png", "profile.png"]
    assert all(_is_png(p) for p in paths)


def test_plot_continuum_run(continuum_run, tmp_path):
    paths = plot_run(continuum_run, out=tmp_path)
    assert [p.name for p in paths] == ["mean_length.png", "radius.png"]
    assert all(_is_png(p) for p in paths)


def test_particle_movie_has_every_trajectory_frame(particle_run, tmp_path):
    mp4 = movie_run(particle_run, tmp_path / "p.mp4", fps=10, progress=False)
    n = count_frames(particle_run / "trajectory.gsd")
    assert n > 5
    assert imageio_ffmpeg.count_frames_and_secs(str(mp4))[0] == n


def test_continuum_movie_has_every_vtu_frame(continuum_run, tmp_path):
    mp4 = movie_run(continuum_run, tmp_path / "c.mp4", fps=10, progress=False)
    n = len(continuum_frames(continuum_run))
    assert n > 5
    assert imageio_ffmpeg.count_frames_and_secs(str(mp4))[0] == n
    few = movie_run(continuum_run, tmp_path / "few.mp4", max_frames=3, progress=False)
    assert imageio_ffmpeg.count_frames_and_secs(str(few))[0] == 3


def test_boundary_edges_of_a_square():
    tri = np.array([[0, 1, 2], [0, 2, 3]])
    assert sorted(map(tuple, boundary_edges(tri))) == [(0, 1), (0, 3), (1, 2), (2, 3)]


def test_bad_folders_are_one_line_value_errors(particle_run, continuum_run, tmp_path):
    cases = {}
    cases["missing"] = tmp_path / "missing"
    cases["empty"] = tmp_path / "empty"
    cases["empty"].mkdir()
    no_history = tmp_path / "no_history"
    shutil.copytree(particle_run, no_history)
    (no_history / "history.csv").unlink()
    cases["no_history"] = no_history
    no_vtu = tmp_path / "no_vtu"
    shutil.copytree(continuum_run, no_vtu)
    next((no_vtu / "fields").glob("*.vtu")).unlink()
    cases["no_vtu"] = no_vtu
    for name, folder in cases.items():
        for call in (lambda f: plot_run(f, out=tmp_path / "o"),
                     lambda f: movie_run(f, tmp_path / "o.mp4", progress=False)):
            with pytest.raises(ValueError) as err:
                call(folder)
            msg = str(err.value)
            assert str(folder) in msg and "\n" not in msg, (name, msg)
    assert run_kind(particle_run) == "particles" and run_kind(continuum_run) == "continuum"


def test_ovito_render_is_the_rod(tmp_path):
    """OVITO's picture of one rod (l = 1.8, theta = 0.5) has the rod's area and direction.

    render_ovito's top view spans 2 fov = 2.04 (positions +- 1) over the image height, so a
    pixel is (2.04 / 200)^2; the rod covers (l - b) b + pi b^2 / 4.
    """
    pytest.importorskip("ovito")
    from cases.viewer import render_ovito
    from particles.output import append_frame
    from particles.state import B, ParticleState

    length, theta = 1.8, 0.5
    path = tmp_path / "trajectory.gsd"
    append_frame(path, ParticleState.from_arrays([0.0], [0.0], [theta], [length]), 0, t=0.0)
    try:
        png = render_ovito(path, tmp_path / "o.png", size=(200, 200))
    except RuntimeError as e:  # no Vulkan loader / driver on this machine
        pytest.skip(f"OVITO cannot render here: {str(e).splitlines()[0]}")
    assert _is_png(png)
    import matplotlib.pyplot as plt

    img = plt.imread(png)[:, :, :3]
    rows, cols = np.nonzero(img.min(axis=2) < 0.98)  # not the white background
    area = rows.size * (2.04 / 200) ** 2
    assert area == pytest.approx((length - B) * B + np.pi * B * B / 4, rel=0.05)
    xy = np.column_stack([cols, -rows]).astype(float)  # image rows grow downwards
    w, v = np.linalg.eigh(np.cov(xy.T))
    angle = np.arctan2(v[1, -1], v[0, -1]) % np.pi
    assert angle == pytest.approx(theta, abs=0.02)


def test_ovito_beside_the_drawing_of_one_frame(tmp_path):
    """docs/measurements/ovito_vs_draw.py: OVITO's picture of the last frame and the pair."""
    pytest.importorskip("ovito")
    from particles.output import append_frame
    from particles.state import ParticleState
    from tests.measurements import measurement

    path = tmp_path / "trajectory.gsd"
    for step, x in enumerate((0.0, 0.5)):
        colony = ParticleState.from_arrays([x, -x], [0.0, 1.0], [0.3, 1.2], [1.2, 1.9])
        append_frame(path, colony, step, t=0.1 * step)
    try:
        png = measurement("ovito_vs_draw").ovito_vs_draw(path, tmp_path / "pair.png", size=120)
    except RuntimeError as e:  # no Vulkan loader / driver on this machine
        pytest.skip(f"OVITO cannot render here: {str(e).splitlines()[0]}")
    assert _is_png(png) and _is_png(tmp_path / "pair_ovito.png")
