"""Run outputs of the continuum engine (docs/DESIGN.md, "Output contract").

- ``config.json``: the run's ContinuumConfig fields;
- ``history.csv``: one row per time step (t, radius, area, max_pressure, n_nodes, ...);
- ``boundary.csv``: final boundary polygon, columns x,y;
- ``fields.pvd`` + ``fields/frame_NNNNN.vtu``: point data p, u, G, mean_length (delta initial
  condition, from G), mean_length_psi, number, total_length (moments of Psi); meshio VTU,
  one file per output step; ParaView reads the .pvd time series.

Every writer refuses non-finite values (``ValueError``): NaN fields are never written.
"""

from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path

import meshio
import numpy as np

__all__ = ["write_config", "write_history", "write_boundary", "FieldWriter"]


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
        """Write one frame at time t; vectors (N, 2) are padded to 3 components for ParaView."""
        data = {}
        for name, v in fields.items():
            v = np.asarray(v, dtype=float)
            _check_finite(f"field {name}", v)
            if v.ndim == 2 and v.shape[1] == 2:
                v = np.column_stack([v, np.zeros(len(v))])
            data[name] = v
        name = f"frame_{len(self.frames):05d}.vtu"
        pts3 = np.column_stack([points, np.zeros(len(points))])
        meshio.write(
            self.out / "fields" / name,
            meshio.Mesh(pts3, [("triangle", np.asarray(tris))], point_data=data),
        )
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
