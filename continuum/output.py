"""Run outputs of the continuum engine (docs/DESIGN.md, "Output contract").

- ``config.json``: the run's Config fields;
- ``history.csv``: one row per time step (t, radius, area, max_pressure, n_nodes, ...);
- ``boundary.csv``: final boundary polygon, columns x,y;
- ``fields.pvd`` + ``fields/frame_NNNNN.vtu``: point data p, u, G, mean_length (delta initial
  condition, from G), mean_length_psi, length_std_psi, number, total_length (moments of Psi:
  mean length, standard deviation of the lengths, number and length per area) and, whenever G is
  written, ring_index = floor(G / ln 2); meshio VTU (binary, zlib), one file per output step;
- ``rings.csv`` (:func:`write_rings`): the rings G = k ln 2 of a final field, one row per ring
  (k, level, mean_radius, min_radius, max_radius, length, cx, cy, n_pieces;
  :mod:`continuum.rings`).

Viewing in ParaView. Open ``fields.pvd`` (the collection lists every frame with its time, and
each VTU also carries its time as the one-value FieldData array ``TimeValue``, the VTK
convention, so a lone frame knows its time too). The mean length lbar = 2^frac(G / ln 2) jumps
from 2 to 1 at every ring G = k ln 2; shading the nodal ``mean_length`` smears each jump over a
triangle. To draw the rings sharply use the smooth phase instead: Contour filter on ``G`` with
the values k ln 2 (0.693147, 1.386294, 2.079442, ...; ParaView's "Add a range of values" with
step ln 2), or on ``ring_index`` at half-integers k - 1/2 (ring_index is the piecewise constant
integer k between rings, so its P1 contour at k - 1/2 lies within a triangle of the ring; the G
contour is the accurate one, O(h^2)). Colouring by ``mean_length`` with the contour on top
shows the pattern.

Reading in Python: ``meshio.read`` on a frame, or PyVista (not a dependency):
``pyvista.PVDReader('fields.pvd')`` lists ``time_values`` and ``set_active_time_value(t)``
picks a frame; ``pyvista.read('fields.pvd')`` returns the FIRST time only (tested in
tests/continuum/test_output.py). :func:`read_frame_time` reads ``TimeValue`` back.

Every writer refuses non-finite values (``ValueError``): NaN fields are never written.
"""

from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path

import meshio
import numpy as np

from continuum.growth import ring_index

__all__ = ["write_config", "write_history", "write_boundary", "write_rings", "FieldWriter",
           "ring_index", "read_frame_time"]


def _check_finite(name: str, values) -> None:
    if not np.all(np.isfinite(np.asarray(values, dtype=float))):
        raise ValueError(f"refusing to write non-finite values in {name}")


def write_config(out: Path, config) -> Path:
    """Write config.json with the dataclass fields of ``config``."""
    path = Path(out) / "config.json"
    path.write_text(json.dumps(dataclasses.asdict(config), indent=2) + "\n")
    return path


def write_history(out: Path, history: list[dict]) -> Path:
    """Write history.csv, one row per dict (columns from the first row)."""
    path = Path(out) / "history.csv"
    if not history:
        raise ValueError("empty history")
    cols = list(history[0])
    for row in history:
        _check_finite("history", [row[c] for c in cols])
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for row in history:
            w.writerow([repr(float(row[c])) if isinstance(row[c], float) else row[c] for c in cols])
    return path


def write_boundary(out: Path, boundary: np.ndarray) -> Path:
    """Write boundary.csv (columns x,y), the closed boundary polygon without repeated vertex."""
    _check_finite("boundary", boundary)
    path = Path(out) / "boundary.csv"
    np.savetxt(path, boundary, delimiter=",", header="x,y", comments="", fmt="%.17g")
    return path


def write_rings(out: Path, points: np.ndarray, triangles: np.ndarray, G: np.ndarray,
                center: np.ndarray | None = None) -> Path:
    """Write rings.csv: the rings G = k ln 2 of the P1 growth phase G (continuum.rings.ring_table).

    One row per ring crossed by G, columns k, level, mean_radius, min_radius, max_radius, length,
    cx, cy, n_pieces (radii about the colony's area centroid (cx, cy), or ``center``); a header
    only when G crosses no level k ln 2, k >= 1.
    """
    from continuum.rings import COLUMNS, ring_table

    _check_finite("G", G)
    table = ring_table(points, triangles, G, center=center)
    path = Path(out) / "rings.csv"
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(COLUMNS)
        for i in range(len(table["k"])):
            w.writerow([int(table[c][i]) if c in ("k", "n_pieces") else repr(float(table[c][i]))
                        for c in COLUMNS])
    return path


def _add_time_value(path: Path, t: float) -> None:
    """Insert the VTK FieldData array TimeValue (one Float64) into a meshio-written VTU."""
    text = path.read_text()
    tag = "<UnstructuredGrid>"
    if text.count(tag) != 1:  # pragma: no cover - meshio's layout changed
        raise RuntimeError(f"{path}: unexpected VTU layout, cannot add TimeValue")
    field = ('<UnstructuredGrid>\n<FieldData>\n<DataArray type="Float64" Name="TimeValue" '
             f'NumberOfTuples="1" format="ascii">{float(t)!r}</DataArray>\n</FieldData>')
    path.write_text(text.replace(tag, field, 1))


def read_frame_time(path: Path) -> float:
    """The time stored in a VTU frame's FieldData array TimeValue."""
    mesh = meshio.read(path)
    if "TimeValue" not in mesh.field_data:
        raise ValueError(f"{path}: no TimeValue field data")
    return float(np.asarray(mesh.field_data["TimeValue"]).ravel()[0])


class FieldWriter:
    """VTU series of the mesh and point fields, indexed by fields.pvd.

    Parameters
    ----------
    out : Path
        Run folder; frames go to ``out/fields/frame_NNNNN.vtu``.
    """

    def __init__(self, out: Path):
        self.out = Path(out)
        (self.out / "fields").mkdir(parents=True, exist_ok=True)
        self.frames: list[tuple[float, str]] = []

    def write(self, t: float, points: np.ndarray, tris: np.ndarray, fields: dict) -> Path:
        """Write one frame at time t; vectors (N, 2) are padded to 3 components for ParaView.

        The frame carries t as FieldData ``TimeValue``; when ``fields`` has G (and no
        ring_index) the point data ``ring_index`` = floor(G / ln 2) is added.
        """
        _check_finite("t", [t])
        data = {}
        for name, v in fields.items():
            v = np.asarray(v, dtype=float)
            _check_finite(f"field {name}", v)
            if v.ndim == 2 and v.shape[1] == 2:
                v = np.column_stack([v, np.zeros(len(v))])
            data[name] = v
        if "G" in data and "ring_index" not in data:
            data["ring_index"] = ring_index(data["G"])
        name = f"frame_{len(self.frames):05d}.vtu"
        pts3 = np.column_stack([points, np.zeros(len(points))])
        meshio.write(
            self.out / "fields" / name,
            meshio.Mesh(pts3, [("triangle", np.asarray(tris))], point_data=data),
        )
        _add_time_value(self.out / "fields" / name, t)
        self.frames.append((float(t), f"fields/{name}"))
        self._write_pvd()
        return self.out / "fields" / name

    def _write_pvd(self) -> None:
        lines = [
            '<?xml version="1.0"?>',
            '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
            "  <Collection>",
        ]
        lines += [
            f'    <DataSet timestep="{t!r}" group="" part="0" file="{f}"/>' for t, f in self.frames
        ]
        lines += ["  </Collection>", "</VTKFile>", ""]
        (self.out / "fields.pvd").write_text("\n".join(lines))
