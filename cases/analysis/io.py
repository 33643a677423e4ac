"""Reading and writing what the runs leave on disk (docs/DESIGN.md, "Output contract").

- small CSVs with a header row (:func:`read_csv`, :func:`write_csv`, gzipped when the name ends in
  ``.gz``), thinned for figures (:func:`thin_rows`), and markdown tables (:func:`markdown_rows`);
- the frames of a continuum run (:func:`continuum_frames` from its ``fields.pvd`` index,
  :func:`read_continuum_frame` of one VTU) and of a particle run (:func:`particle_frames` from
  its ``trajectory.gsd``, with theta, so the colony measures of :mod:`particles.measures` apply).
"""

from __future__ import annotations

import gzip
import math
import os
import warnings
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np

__all__ = [
    "read_csv",
    "write_csv",
    "markdown_rows",
    "thin_rows",
    "continuum_frames",
    "read_continuum_frame",
    "particle_frames",
]


def read_csv(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Read a CSV (or gzipped ``.csv.gz``) with a header row into float columns {name: array}.

    Empty cells (a column that a run resumed from an older checkpoint lacks) read as NaN.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such CSV file: {path}")
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt") as f:
        header = f.readline().strip()
    names = [h.strip() for h in header.split(",")]
    with warnings.catch_warnings():  # a header-only file is an empty table, not a warning
        warnings.simplefilter("ignore", UserWarning)
        data = np.genfromtxt(path, delimiter=",", skip_header=1, ndmin=2, invalid_raise=True)
    if data.size == 0:
        return {n: np.empty(0) for n in names}
    if data.shape[1] != len(names):
        raise ValueError(f"{path}: {len(names)} header names but {data.shape[1]} columns")
    return {n: data[:, i] for i, n in enumerate(names)}


def write_csv(path: str | os.PathLike, columns: Mapping[str, np.ndarray], fmt: str = "%.8g"):
    """Write equal-length 1D columns as a CSV with a header row (parent folder created).

    A path ending in ``.gz`` is gzip-compressed with no time stamp, so equal data give equal
    bytes.
    """
    path = Path(path)
    names = list(columns)
    cols = [np.asarray(columns[n], dtype=float).ravel() for n in names]
    if len({c.size for c in cols}) > 1:
        raise ValueError(f"{path.name}: columns differ in length")
    path.parent.mkdir(parents=True, exist_ok=True)
    data = np.column_stack(cols) if cols else np.empty((0, 0))
    if path.suffix == ".gz":
        with open(path, "wb") as raw, gzip.GzipFile(fileobj=raw, mode="wb", mtime=0) as f:
            np.savetxt(f, data, delimiter=",", header=",".join(names), comments="", fmt=fmt)
    else:
        np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt=fmt)
    return path


def markdown_rows(header: Sequence[str], rows: Iterable[Sequence]) -> str:
    """A markdown table: the header, the ``|---|`` rule, one line per row of formatted cells."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join(lines + ["| " + " | ".join(map(str, r)) + " |" for r in rows])


def thin_rows(columns: Mapping[str, np.ndarray], max_rows: int = 400) -> dict[str, np.ndarray]:
    """Every k-th row (k the smallest giving <= max_rows) plus the last: small CSVs for figures."""
    n = len(next(iter(columns.values())))
    if n <= max_rows:
        return {k: np.asarray(v) for k, v in columns.items()}
    k = math.ceil(n / (max_rows - 1))
    idx = np.unique(np.append(np.arange(0, n, k), n - 1))
    return {name: np.asarray(v)[idx] for name, v in columns.items()}


def continuum_frames(folder: str | os.PathLike) -> list[tuple[float, Path]]:
    """(t, vtu path) of every output step of a continuum run, from its ``fields.pvd`` index."""
    import xml.etree.ElementTree as ET

    folder = Path(folder)
    pvd = folder / "fields.pvd"
    if not pvd.is_file():
        raise FileNotFoundError(f"no fields.pvd in {folder}")
    frames = [(float(ds.get("timestep")), folder / ds.get("file"))
              for ds in ET.parse(pvd).getroot().iter("DataSet")]
    return sorted(frames, key=lambda f: f[0])


def read_continuum_frame(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray, dict]:
    """(points (n, 2), triangles (m, 3), point data {name: array}) of one VTU output step."""
    import meshio

    mesh = meshio.read(path)
    tri = [c.data for c in mesh.cells if c.type == "triangle"]
    if not tri:
        raise ValueError(f"{path}: no triangles")
    data = {k: np.asarray(v) for k, v in mesh.point_data.items()}
    return np.asarray(mesh.points[:, :2], dtype=float), np.concatenate(tri), data


def particle_frames(folder: str | os.PathLike, last_only: bool = False):
    """Iterate (t, {x, y, theta, length, stress}) over the frames of a particle run's trajectory.

    ``last_only``: its last frame alone, the others not read.

    Positions and angles come from the HOOMD schema (theta = 2 atan2(q_z, q_w)); length and stress
    from ``log/particles/length`` and ``log/particles/stress``; t from history.csv's row of the
    frame's step (the step's index times the first dt when history has no ``step`` column).
    """
    import gsd.hoomd

    folder = Path(folder)
    hist = read_csv(folder / "history.csv")
    if "step" in hist:
        t_of_step = dict(zip(hist["step"].astype(int).tolist(), hist["t"].tolist(), strict=True))
    else:
        t_of_step = {}
    with gsd.hoomd.open(str(folder / "trajectory.gsd"), mode="r") as traj:
        for frame in (traj[-1:] if last_only else traj):
            step = int(frame.configuration.step)
            t = t_of_step.get(step, 0.0 if step == 0 else float("nan"))
            pos = np.asarray(frame.particles.position, dtype=float)
            q = np.asarray(frame.particles.orientation, dtype=float)
            yield t, {
                "x": pos[:, 0],
                "y": pos[:, 1],
                "theta": 2.0 * np.arctan2(q[:, 3], q[:, 0]),
                "length": np.asarray(frame.log["particles/length"], dtype=float),
                "stress": np.asarray(frame.log["particles/stress"], dtype=float),
            }

