"""Boundary polygons and triangle meshes (continuum.mesh)."""

import numpy as np
import pytest

from continuum import mesh as M
from continuum.shapes import polygon_csv


def test_polygon_orientation_and_closing_vertex():
    sq = np.array([[0, 0], [0, 1], [1, 1], [1, 0], [0, 0]], float)  # clockwise, explicitly closed
    out = M.check_polygon(sq)
    assert out.shape == (4, 2)
    assert M.polygon_area(out) == pytest.approx(1.0)


@pytest.mark.parametrize(
    "xy,match",
    [
        ([[0, 0], [1, 0]], "at least 3"),
        ([[0, 0], [1, 0], [np.nan, 1]], "non-finite"),
        ([[0, 0], [1, 0], [1, 0], [0, 1]], "repeated consecutive"),
        ([[0, 0], [1, 0], [2, 0]], "zero area"),
        ([[0, 0], [1, 1], [1, 0], [0, 1]], "not simple"),  # bow tie
        ([[0, 0], [2, 0], [2, 2], [1, -1], [0, 2]], "not simple"),
        (np.zeros((3, 3)), "shape"),
    ],
)
def test_bad_polygons(xy, match):
    with pytest.raises(M.PolygonError, match=match):
        M.check_polygon(np.asarray(xy, float))


def test_polygon_error_is_value_error():
    assert issubclass(M.PolygonError, ValueError)


def test_load_polygon_requires_closed(tmp_path):
    f = tmp_path / "p.csv"
    f.write_text("x,y\n0,0\n1,0\n1,1\n0,1\n")
    with pytest.raises(M.PolygonError, match="not closed"):
        polygon_csv(f)
    f.write_text("x,y\n0,0\n1,0\n1,1\n0,1\n0,0\n")
    assert M.polygon_area(polygon_csv(f)) == pytest.approx(1.0)


def test_resample_ellipse_stays_on_curve_fourth_order():
    """Spline resampling of an ellipse: distance to the curve converges at order ~4."""
    a, b = 2.0, 1.0
    errs, hs = [], []
    for n in (40, 80, 160):
        coarse = M.ellipse_polygon(a, b, n)
        fine = M.resample_polygon(coarse, n=3 * n + 1)
        # algebraic distance to the ellipse, scaled to a length
        errs.append(np.max(np.abs(np.sqrt((fine[:, 0] / a) ** 2 + (fine[:, 1] / b) ** 2) - 1)))
        hs.append(1.0 / n)
        spacing = M.boundary_spacing(fine)
        assert np.ptp(spacing) / spacing.mean() < 0.02
    order = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert order > 3.5, (errs, order)


def test_resample_spacing_argument():
    c = M.circle_polygon(5.0, 50)
    out = M.resample_polygon(c, spacing=0.5)
    assert len(out) == int(np.ceil(np.sum(M.boundary_spacing(c)) / 0.5))
    with pytest.raises(ValueError, match="positive"):
        M.resample_polygon(c, spacing=0.0)


@pytest.mark.parametrize("h", [0.5, 0.25, 0.02])
def test_triangulate_quality_and_boundary(h):
    """Also at a small h, whose area limit Triangle must read in fixed-point notation."""
    scale = 1.0 if h > 0.1 else 0.05
    bnd = M.resample_polygon(M.ellipse_polygon(3.0 * scale, 2.0 * scale, 200), spacing=h)
    pts, tri = M.triangulate(bnd, h)
    np.testing.assert_allclose(pts[: len(bnd)], bnd)
    area = M.triangle_areas(pts, tri)
    assert np.all(area > 0)
    assert area.sum() == pytest.approx(M.polygon_area(bnd), rel=1e-12)
    q = M.triangle_quality(pts, tri)
    assert q.min() > 0.45
    # every boundary edge is an edge of the mesh (no Steiner points on the boundary)
    edges = {tuple(sorted(e)) for t in tri for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
    k = len(bnd)
    assert all(tuple(sorted((i, (i + 1) % k))) in edges for i in range(k))
    # node count near the equilateral estimate
    n_est = 2 * M.polygon_area(bnd) / (np.sqrt(3) * h**2)
    assert 0.8 * n_est < len(pts) < 2.0 * n_est
    assert M.h_for_nodes(M.polygon_area(bnd), n_est) == pytest.approx(h, rel=1e-12)


def test_graded_mesh_is_coarser_inside():
    bnd = M.resample_polygon(M.circle_polygon(30.0, 400), spacing=1.0)
    pu, tu = M.triangulate(bnd, 1.0)
    pg, tg = M.triangulate(bnd, 1.0, h_interior=4.0)
    assert len(pg) < 0.5 * len(pu)
    assert M.triangle_quality(pg, tg).min() > 0.4
    assert M.triangle_areas(pg, tg).sum() == pytest.approx(M.polygon_area(bnd), rel=1e-12)
    # near the boundary the size is still about h
    cen = pg[tg].mean(axis=1)
    near = np.hypot(*cen.T) > 29.0
    assert np.sqrt(np.median(M.triangle_areas(pg, tg)[near]) * 4 / np.sqrt(3)) < 1.3


@pytest.mark.parametrize("h", [0.0, -1.0, np.inf, np.nan])
def test_triangulate_bad_size(h):
    with pytest.raises(ValueError, match="mesh size"):
        M.triangulate(M.circle_polygon(1.0, 20), h)


def test_resample_keeps_corners_of_a_polygon():
    """A square (turning angle pi/2 > corner_angle) is resampled piecewise linearly.

    Its area is kept exactly (a periodic spline through the corners would bulge out).
    """
    sq = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], float)
    out = M.resample_polygon(sq, spacing=0.1)
    assert len(out) == 80
    assert M.polygon_area(out) == pytest.approx(4.0, rel=1e-12)
    assert np.max(M.turning_angles(out)) == pytest.approx(np.pi / 2)
