"""Run outputs of the continuum engine (docs/DESIGN.md, "Output contract").

- ``config.json``: the run's Config fields (``strains`` only when given: a one-strain run's
  file is as before);
- ``history.csv``: one row per time step (t, radius, area, max_pressure, n_nodes, ...);
- ``boundary.csv``: final boundary polygon, columns x,y;
- ``fields.pvd`` + ``fields/frame_NNNNN.vtu``: point data p, u, G, mean_length (delta initial
  condition, from G), mean_length_psi, length_std_psi, number, total_length (moments of Psi:
  mean length, standard deviation of the lengths, number and length per area), whenever G is
  written, ring_index = floor(G / ln 2) and, whenever u is written, the strain rate of the flow
  E = (grad u + grad u^T) / 2 (:mod:`continuum.strain_rate`, its FIELDS: e_xx, e_yy, e_xy; e_rr,
  e_tt, e_rt about the colony's area centroid; e_rr_minus_e_tt; shear, the difference of E's
  eigenvalues; axis_angle, the extension axis from the radius in radians); meshio VTU (binary,
  zlib), one file per output step;
- strains (continuum.strains; S >= 2 of them): history.csv's columns area_0, area_1, ... (the
  area int phi_i dA of each strain), the point data phi_i, G_i and mean_length_i of every
  strain i in the frames, and ``interfaces.csv`` (:func:`write_interfaces`): the contours
  phi_i = 1/2, one row per strain (strain, level, area, mean_radius, min_radius, max_radius,
  length, cx, cy, n_pieces);
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

Frame names are made from the frame's index (:func:`frame_name`), never read back from a file;
frames, fields.pvd and history.csv are written to a temporary file and renamed (os.replace), so
none is ever half written and none is written through a symbolic link; ``fields`` itself may
not be a link (:func:`fields_folder`). A resumed run removes the frames after its checkpoint
(:func:`remove_frames_from`: only names this module makes, never through a link). Like the
particle engine, a run keeps ``runfiles.RESERVE_BYTES`` free on its file system
(:func:`ensure_space`).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import os
import re
from pathlib import Path

import meshio
import numpy as np

from continuum import runfiles
from continuum.growth import ring_index
from continuum.strain_rate import FIELDS as STRAIN_FIELDS
from continuum.strain_rate import strain_rate_fields

__all__ = ["write_config", "write_history", "write_boundary", "write_rings", "write_interfaces",
           "FieldWriter",
           "ring_index", "read_frame_time", "frame_name", "fields_folder", "remove_frames_from",
           "ensure_space"]

#: Bytes of a VTU frame per mesh node, a bound (coordinates, connectivity, 21 fields; base64).
FRAME_BYTES_PER_NODE = 520
#: And per node and strain of a colony of strains (phi_i, G_i, mean_length_i: 3 more fields).
STRAIN_FRAME_BYTES_PER_NODE = 75

_FRAME = re.compile(r"frame_([0-9]{5,})\.vtu(\.tmp)?")


def _check_finite(name: str, values) -> None:
    if not np.all(np.isfinite(np.asarray(values, dtype=float))):
        raise ValueError(f"refusing to write non-finite values in {name}")


#: Config fields of the model's extensions, written to config.json only when set.
OPTIONAL_FIELDS = ("strains", "layout", "nutrient_length", "monod_k")


def write_config(out: Path, config) -> Path:
    """Write config.json with the dataclass fields of ``config``.

    The fields of a model extension left at their default (OPTIONAL_FIELDS: an empty
    ``strains``, no ``layout``, no nutrient) are left out, so a run without it writes the file
    it wrote before the extension existed (reading it back gives the same Config).
    """
    path = Path(out) / "config.json"
    fields = dataclasses.asdict(config)
    for name in OPTIONAL_FIELDS:
        if name in fields and fields[name] in ((), [], None):
            del fields[name]
    path.write_text(json.dumps(fields, indent=2) + "\n")
    return path


def _replace_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically: a new temporary file, then os.replace.

    Never through a link: a link at ``path`` is replaced, not followed.
    """
    tmp = path.with_name(path.name + ".tmp")
    tmp.unlink(missing_ok=True)
    try:
        with open(tmp, "x", newline="") as fh:
            fh.write(text)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_history(out: Path, history: list[dict]) -> Path:
    """Write history.csv (atomically), one row per dict (columns from the first row)."""
    path = Path(out) / "history.csv"
    if not history:
        raise ValueError("empty history")
    cols = list(history[0])
    for row in history:
        _check_finite("history", [row[c] for c in cols])
    text = io.StringIO(newline="")
    w = csv.writer(text)
    w.writerow(cols)
    for row in history:
        w.writerow([repr(float(row[c])) if isinstance(row[c], float) else row[c] for c in cols])
    _replace_text(path, text.getvalue())
    return path


def ensure_space(out: Path, n_nodes: int, checkpoint: Path | None = None,
                 n_strains: int = 0) -> None:
    """OSError(ENOSPC) unless ``out`` keeps its reserve after the next writes (runfiles).

    The next writes: a frame of ``n_nodes`` nodes (with the fields of ``n_strains`` strains,
    0 for a one-strain colony), a checkpoint (at most the last one's size twice) and a new copy
    of history.csv.
    """
    per_node = FRAME_BYTES_PER_NODE + STRAIN_FRAME_BYTES_PER_NODE * n_strains
    runfiles.ensure_space(Path(out), per_node * n_nodes,
                          ((checkpoint, 2), (Path(out) / "history.csv", 1)))


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
    return _write_table(Path(out) / "rings.csv", COLUMNS, table, ("k", "n_pieces"))


def _write_table(path: Path, columns, table: dict, integers: tuple[str, ...]) -> Path:
    """A contour table as CSV: a header, then one row per entry.

    The ``integers`` columns as integers, the others by repr, so they read back exactly.
    """
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(columns)
        for i in range(len(table[columns[0]])):
            w.writerow([int(table[c][i]) if c in integers else repr(float(table[c][i]))
                        for c in columns])
    return path


def write_interfaces(out: Path, points: np.ndarray, triangles: np.ndarray, phi: np.ndarray,
                     center: np.ndarray | None = None) -> Path:
    """Write interfaces.csv: the contours phi_i = 1/2 of the strain fractions, one row per strain.

    continuum.strains.interface_table (columns INTERFACE_COLUMNS: strain, level, area,
    mean_radius, min_radius, max_radius, length, cx, cy, n_pieces); radii about the colony's
    area centroid, or ``center``; a header only when no fraction crosses 1/2.
    """
    from continuum.strains import INTERFACE_COLUMNS, interface_table

    _check_finite("phi", phi)
    table = interface_table(points, triangles, phi, center=center)
    return _write_table(Path(out) / "interfaces.csv", INTERFACE_COLUMNS, table,
                        ("strain", "n_pieces"))


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


def frame_name(index: int) -> str:
    """File name of the frame of this index in ``fields/``: ``frame_NNNNN.vtu``."""
    return f"frame_{index:05d}.vtu"


def fields_folder(out: Path) -> Path:
    """The run folder's ``fields`` folder, created when missing.

    ValueError (one line) when ``fields`` is a symbolic link or not a folder: frames are never
    written into, nor deleted from, a folder elsewhere.
    """
    folder = Path(out) / "fields"
    if folder.is_symlink():
        raise ValueError(f"{folder} is a symbolic link; colony neither writes nor deletes "
                         "frames through a link (remove it, or start afresh with --overwrite)")
    if os.path.lexists(folder) and not folder.is_dir():
        raise ValueError(f"{folder} is not a folder (remove it, or start afresh with "
                         "--overwrite)")
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def remove_frames_from(out: Path, count: int) -> None:
    """Delete the frames of ``fields/`` from index ``count`` on, and any temporary frame.

    Those a run wrote after its checkpoint (a resumed run writes them again).  Only entries
    named exactly as :func:`frame_name` names them (or their ``.tmp``) are touched; a link
    so named is removed itself (never followed); anything else so named is refused
    (ValueError), as is a ``fields`` that is a link (:func:`fields_folder`).
    """
    folder = fields_folder(out)
    for name in sorted(os.listdir(folder)):
        match = _FRAME.fullmatch(name)
        if match is None or name.removesuffix(".tmp") != frame_name(int(match[1])):
            continue
        if int(match[1]) < count and not match[2]:
            continue
        path = folder / name
        if not (path.is_symlink() or path.is_file()):
            raise ValueError(f"{path} is not a frame file (remove it, or start afresh with "
                             "--overwrite)")
        path.unlink()


class FieldWriter:
    """VTU series of the mesh and point fields, indexed by fields.pvd.

    Parameters
    ----------
    out : Path
        Run folder; frames go to ``out/fields/frame_NNNNN.vtu`` (:func:`frame_name`).

    Attributes
    ----------
    times : list of float
        The times of the frames written, frame k named ``frame_name(k)``.
    """

    def __init__(self, out: Path):
        self.out = Path(out)
        self.folder = fields_folder(self.out)
        self.times: list[float] = []

    @property
    def frames(self) -> list[tuple[float, str]]:
        """(t, file relative to the run folder) of each frame written."""
        return [(t, f"fields/{frame_name(k)}") for k, t in enumerate(self.times)]

    def resume(self, times: list[float]) -> None:
        """Continue the series of a checkpoint that wrote frames at ``times``.

        The frames after them are removed (:func:`remove_frames_from`) and fields.pvd lists
        these.
        """
        self.times = [float(t) for t in times]
        remove_frames_from(self.out, len(self.times))
        self._write_pvd()

    def write(self, t: float, points: np.ndarray, tris: np.ndarray, fields: dict) -> Path:
        """Write one frame at time t; vectors (N, 2) are padded to 3 components for ParaView.

        The frame carries t as FieldData ``TimeValue``; when ``fields`` has G (and no
        ring_index) the point data ``ring_index`` = floor(G / ln 2) is added, when it has u
        (and none of them) the strain-rate fields of continuum.strain_rate.strain_rate_fields.
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
        if "u" in data and not any(k in data for k in STRAIN_FIELDS) and len(tris):
            data |= strain_rate_fields(points, tris, data["u"])
        path = self.folder / frame_name(len(self.times))
        tmp = path.with_name(path.name + ".tmp")
        tmp.unlink(missing_ok=True)
        pts3 = np.column_stack([points, np.zeros(len(points))])
        try:
            meshio.write(tmp, meshio.Mesh(pts3, [("triangle", np.asarray(tris))],
                                          point_data=data), file_format="vtu")
            _add_time_value(tmp, t)
            os.replace(tmp, path)
        finally:
            tmp.unlink(missing_ok=True)
        self.times.append(float(t))
        self._write_pvd()
        return path

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
        _replace_text(self.out / "fields.pvd", "\n".join(lines))
