"""cases.figures.draw: geometry of the drawn sphero-cylinders, files written."""


import matplotlib.pyplot as plt
import numpy as np
import pytest

from cases.figures import draw
from tests.pictures import assert_figures


def test_spherocylinder_outline_is_at_distance_b_over_2_from_the_segment():
    rng = np.random.default_rng(0)
    n = 50
    x, y = rng.normal(size=(2, n))
    theta = rng.uniform(0, 2 * np.pi, n)
    length = rng.uniform(0.5, 2.0, n)
    b = 0.5
    v = draw.spherocylinder_polygons(x, y, theta, length, b=b, n_cap=8)
    assert v.shape == (n, 18, 2)
    # distance of every vertex to the particle's inner segment is b/2
    p = np.stack([np.cos(theta), np.sin(theta)], -1)[:, None, :]
    rel = v - np.stack([x, y], -1)[:, None, :]
    s = np.clip((rel * p).sum(-1), -(length[:, None] - b) / 2, (length[:, None] - b) / 2)
    d = np.linalg.norm(rel - s[..., None] * p, axis=-1)
    np.testing.assert_allclose(d, b / 2, atol=1e-12)
    # tip to tip extent along p is the length l
    proj = (rel * p).sum(-1)
    np.testing.assert_allclose(proj.max(1) - proj.min(1), length, atol=1e-12)


def test_draw_errors():
    with pytest.raises(ValueError, match=">= b"):
        draw.spherocylinder_polygons([0.0], [0.0], [0.0], [0.3])
    with pytest.raises(ValueError, match="shape"):
        draw.draw_field(np.zeros((3, 3)), np.zeros((1, 3), int), np.zeros(3))
    with pytest.raises(ValueError, match="out of range"):
        draw.draw_field(np.zeros((3, 2)), np.array([[0, 1, 3]]), np.zeros(3))
    plt.close("all")


def test_particles_and_field_files_written(tmp_path):
    rng = np.random.default_rng(1)
    n = 20000
    r = 60 * np.sqrt(rng.random(n))
    phi = rng.uniform(0, 2 * np.pi, n)
    fig, (a, b) = plt.subplots(1, 2, figsize=(8, 4))
    coll = draw.draw_particles(r * np.cos(phi), r * np.sin(phi), phi, 1 + rng.random(n), ax=a)
    assert coll.get_clim() == (1.0, 2.0)
    # a field on a structured triangulation of the square
    g = np.linspace(-1, 1, 21)
    X, Y = np.meshgrid(g, g)
    pts = np.column_stack([X.ravel(), Y.ravel()])
    i, j = np.meshgrid(np.arange(20), np.arange(20))
    k = (j * 21 + i).ravel()
    tri = np.concatenate([np.column_stack([k, k + 1, k + 22]),
                          np.column_stack([k, k + 22, k + 21])])
    draw.draw_field(pts, tri, 1.5 + 0.5 * np.cos(3 * pts[:, 0]), ax=b)
    draw.colorbar(fig, coll, [a, b])
    paths = draw.save_figure(fig, tmp_path / "sub" / "colony")
    assert [p.name for p in paths] == ["colony.png", "colony.pdf"]
    assert_figures(paths)
