"""VTU/PVD outputs of the continuum engine (continuum.output): times, G and ring_index read back.

meshio always; PyVista (VTK's own readers, what ParaView uses) when installed.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest

from continuum import mesh as M
from continuum.output import FieldWriter, read_frame_time, ring_index, write_rings

LN2 = math.log(2.0)
TIMES = [0.0, 0.37, 1.5, 2.25]


def phase(points: np.ndarray, t: float) -> np.ndarray:
    """A growth phase with rings: G = t + 0.4 r^2 (crosses several k ln 2 at the later times)."""
    return t + 0.4 * (points[:, 0] ** 2 + points[:, 1] ** 2)


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    bnd = M.resample_polygon(M.circle_polygon(2.0, 512), spacing=0.3, min_points=16)
    pts, tri = M.triangulate(bnd, 0.3)
    w = FieldWriter(out)
    for t in TIMES:
        G = phase(pts, t)
        q = G / LN2
        w.write(t, pts, tri, {"p": 4.0 - pts[:, 0] ** 2, "u": pts / 2, "G": G,
                              "mean_length": 2.0 ** (q - np.floor(q))})
    return out, pts, tri, w


def test_pvd_lists_every_frame(written):
    out, _, _, w = written
    root = ET.parse(out / "fields.pvd").getroot()
    sets = list(root.iter("DataSet"))
    assert [float(d.get("timestep")) for d in sets] == TIMES
    assert [d.get("file") for d in sets] == [f for _, f in w.frames]
    assert all((out / d.get("file")).is_file() for d in sets)


def test_meshio_reads_time_G_ring_index(written):
    out, pts, tri, w = written
    for t, f in w.frames:
        mesh = meshio.read(out / f)
        assert np.asarray(mesh.field_data["TimeValue"]).ravel().tolist() == [t]
        assert read_frame_time(out / f) == t
        G = mesh.point_data["G"]
        assert np.array_equal(G, phase(pts, t))
        k = mesh.point_data["ring_index"]
        assert k.dtype == np.int32
        assert np.array_equal(k, np.floor(G / LN2))
        assert np.array_equal(mesh.cells_dict["triangle"], tri)
        assert mesh.point_data["u"].shape == (len(pts), 3)
    assert meshio.read(out / w.frames[-1][1]).point_data["ring_index"].max() >= 4


def test_ring_index_and_rings_csv(tmp_path, written):
    _, pts, tri, _ = written
    assert ring_index(np.array([0.0, LN2 - 1e-12, LN2 + 1e-12, 5.0])).tolist() == [0, 0, 1, 7]
    path = write_rings(tmp_path, pts, tri, phase(pts, 0.37))
    lines = path.read_text().splitlines()
    assert lines[0] == "k,level,mean_radius,min_radius,max_radius,length,cx,cy,n_pieces"
    rows = np.genfromtxt(path, delimiter=",", skip_header=1, ndmin=2)
    # G = 0.37 + 0.4 r^2 = k ln 2 at r_k = sqrt((k ln 2 - 0.37) / 0.4) < R = 2: k = 1, 2
    rk = np.sqrt((np.array([1, 2]) * LN2 - 0.37) / 0.4)
    assert rows[:, 0].tolist() == [1, 2]
    assert np.allclose(rows[:, 2], rk, atol=0.02)
    with pytest.raises(ValueError):
        write_rings(tmp_path, pts, tri, np.full(len(pts), np.nan))


def test_refuses_non_finite_time(tmp_path):
    w = FieldWriter(tmp_path)
    pts = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    with pytest.raises(ValueError):
        w.write(math.nan, pts, np.array([[0, 1, 2]]), {"G": np.zeros(3)})


def test_pyvista_pvd_reader(written):
    """VTK's readers (as in ParaView): every time in PVDReader, TimeValue per frame.

    ``pyvista.read('fields.pvd')`` returns the first time only (documented in continuum.output).
    """
    pv = pytest.importorskip("pyvista")
    out, pts, _, _ = written
    reader = pv.PVDReader(str(out / "fields.pvd"))
    assert list(reader.time_values) == TIMES
    for t in TIMES:
        reader.set_active_time_value(t)
        block = reader.read()[0]
        assert block.field_data["TimeValue"].tolist() == [t]
        assert np.allclose(block.point_data["G"], phase(pts, t), rtol=0, atol=0)
        assert np.array_equal(block.point_data["ring_index"],
                              np.floor(block.point_data["G"] / LN2))
    first = pv.read(str(out / "fields.pvd"))[0]
    assert first.field_data["TimeValue"].tolist() == [TIMES[0]]


def test_vtk_contour_is_the_ring_table(written):
    """ParaView's Contour filter on G at k ln 2 (vtkContourFilter) draws the ring_table contours."""
    pv = pytest.importorskip("pyvista")
    from continuum.rings import ring_table

    out, pts, tri, w = written
    block = pv.read(str(out / w.frames[-1][1]))
    table = ring_table(pts, tri, phase(pts, TIMES[-1]))
    assert table["k"].size >= 2
    for k, length, r_max in zip(table["k"], table["length"], table["max_radius"], strict=True):
        line = block.contour([k * LN2], scalars="G")
        seg_len = line.compute_cell_sizes(length=True, area=False, volume=False)["Length"].sum()
        assert seg_len == pytest.approx(length, rel=1e-9)
        centre = np.array([table["cx"][0], table["cy"][0], 0.0])
        r_vtk = np.linalg.norm(line.points - centre, axis=1)
        assert r_vtk.max() == pytest.approx(r_max, rel=1e-9)
