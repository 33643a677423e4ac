"""Reading and writing what the runs leave on disk (docs/DESIGN.md, "Output contract").

- small CSVs with a header row (:func:`read_csv`, :func:`write_csv`, gzipped when the name ends in
  ``.gz``), thinned for figures (:func:`thin_rows`), and markdown tables (:func:`markdown_rows`);
- the frames of a continuum run (:func:`continuum_frames` from its ``fields.pvd`` index,
  :func:`read_continuum_frame` of one VTU) and of a particle run (:func:`particle_frames` from
  its ``trajectory.gsd``, with theta, so the colony measures of :mod:`particles.measures` apply;
  :func:`read_particle_frames`, particles.output's frames).

Damaged files (a flipped bit, a cut, another file under the name) are refused with a one-line
:class:`DamagedFileError` naming the file and what is wrong, never used: a trajectory's layout is
checked before the gsd library reads it (:func:`check_trajectory`: gsd trusts its header and
index, and a flipped bit there crashes the process or asks for terabytes), and every frame's
arrays before they are used (:func:`check_particle_frame`, :func:`check_colony`).
"""

from __future__ import annotations

import gzip
import math
import os
import re
import struct
import warnings
import zlib
from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path

import numpy as np

__all__ = [
    "DamagedFileError",
    "read_csv",
    "write_csv",
    "markdown_rows",
    "thin_rows",
    "continuum_frames",
    "read_continuum_frame",
    "particle_frames",
    "check_trajectory",
    "check_particle_frame",
    "check_colony",
    "read_particle_frames",
]


class DamagedFileError(ValueError):
    """A run's file that cannot be used as it is (one line: the file and what is wrong)."""


def _reason(err: BaseException) -> str:
    """An exception in one line: its type's name and the first line of its message."""
    text = str(err).strip()
    return f"{type(err).__name__}: {text.splitlines()[0]}" if text else type(err).__name__


def read_csv(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Read a CSV (or gzipped ``.csv.gz``) with a header row into float columns {name: array}.

    Empty cells (a column that a run resumed from an older checkpoint lacks) read as NaN.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such CSV file: {path}")
    opener = gzip.open if path.suffix == ".gz" else open
    try:
        with opener(path, "rt") as f:
            header = f.readline().strip()
        with warnings.catch_warnings():  # a header-only file is an empty table, not a warning
            warnings.simplefilter("ignore", UserWarning)
            data = np.genfromtxt(path, delimiter=",", skip_header=1, ndmin=2,
                                 invalid_raise=True)
    except UnicodeDecodeError as err:
        raise DamagedFileError(f"{path} is damaged: not text (byte {err.start})") from None
    except (EOFError, gzip.BadGzipFile, zlib.error) as err:
        raise DamagedFileError(f"{path} is damaged: {_reason(err)}") from None
    except ValueError as err:  # numpy: "Some errors were detected !" then one line per row
        raise DamagedFileError(f"{path} is damaged or cut short: {_bad_row(err)}") from None
    names = [h.strip() for h in header.split(",")]
    if data.size == 0:
        return {n: np.empty(0) for n in names}
    if data.shape[1] != len(names):
        raise DamagedFileError(f"{path} is damaged: {len(names)} header names but "
                               f"{data.shape[1]} columns")
    return {n: data[:, i] for i, n in enumerate(names)}


def _bad_row(err: ValueError) -> str:
    """numpy.genfromtxt's first bad row as "line K has M columns instead of N"."""
    match = re.search(r"Line #(\d+) \(got (\d+) columns instead of (\d+)\)", str(err))
    if match is None:
        return _reason(err)
    line, got, want = match.groups()
    return f"line {line} has {got} columns instead of {want}"


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
    """(t, vtu path) of every output step of a continuum run, from its ``fields.pvd`` index.

    Raises DamagedFileError when fields.pvd is not XML, a data set lacks a finite timestep or
    a file, or names a file outside ``folder`` (an absolute path or one through ``..``).
    """
    import xml.etree.ElementTree as ET

    folder = Path(folder)
    pvd = folder / "fields.pvd"
    if not pvd.is_file():
        raise FileNotFoundError(f"no fields.pvd in {folder}")
    try:
        sets = list(ET.parse(pvd).getroot().iter("DataSet"))
    except ET.ParseError as err:
        raise DamagedFileError(f"{pvd} is damaged: not XML ({err})") from None
    frames = [_pvd_frame(pvd, ds.get("timestep"), ds.get("file")) for ds in sets]
    return sorted(frames, key=lambda f: f[0])


def _pvd_frame(pvd: Path, timestep: str | None, name: str | None) -> tuple[float, Path]:
    """(t, path) of one data set of ``pvd``: a finite time and a file inside its folder."""
    try:
        t = float(timestep)
    except (TypeError, ValueError):
        t = math.nan
    if not math.isfinite(t) or not name:
        raise DamagedFileError(f"{pvd} is damaged: a data set without a finite timestep and "
                               "a file")
    if Path(name).is_absolute() or ".." in Path(name).parts:
        raise DamagedFileError(f"{pvd} is damaged: it names {name!r}, outside its folder")
    return t, pvd.parent / name


def read_continuum_frame(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray, dict]:
    """(points (n, 2), triangles (m, 3), point data {name: array}) of one VTU output step.

    Raises DamagedFileError (one line naming the file) when meshio cannot read it, or its
    points are not finite, it has no triangles or triangles of points it does not have, or a
    point-data array has not one row per point.
    """
    import meshio

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such VTU file: {path}")
    try:  # meshio.read would print its errors and call sys.exit; its VTU reader raises
        mesh = meshio.vtu.read(str(path))
    except (Exception, SystemExit) as err:  # whatever the reader meets in a damaged file
        raise DamagedFileError(f"{path} is damaged: meshio cannot read it ({_reason(err)})"
                               ) from None
    points = np.asarray(mesh.points, dtype=float)
    tri = [np.asarray(c.data) for c in mesh.cells if c.type == "triangle"]
    triangles = np.concatenate(tri) if tri else np.empty((0, 3), dtype=np.int64)
    data = {k: np.asarray(v) for k, v in mesh.point_data.items()}
    _check_mesh(path, points, triangles, data)
    return points[:, :2], triangles, data


def _check_mesh(path: Path, points: np.ndarray, triangles: np.ndarray, data: dict) -> None:
    """Refuse a mesh of non-finite points, no triangles, or data not of its points.

    Triangles must name points the mesh has, point data have one row per point.
    """
    n = len(points)
    if points.ndim != 2 or points.shape[1] < 2 or not np.all(np.isfinite(points)):
        raise DamagedFileError(f"{path} is damaged: its points are not finite (x, y) pairs")
    if len(triangles) == 0:
        raise DamagedFileError(f"{path} is damaged: no triangles")
    if (triangles.dtype.kind not in "iu" or triangles.shape[1:] != (3,)
            or triangles.min() < 0 or triangles.max() >= n):
        raise DamagedFileError(f"{path} is damaged: its triangles name points it does not "
                               f"have ({n} points)")
    short = [k for k, v in data.items() if v.shape[:1] != (n,)]
    if short:
        raise DamagedFileError(f"{path} is damaged: point data {short[0]!r} has not one row "
                               f"per point ({n})")


def particle_frames(folder: str | os.PathLike, last_only: bool = False):
    """Iterate (t, {x, y, theta, length, stress}) over the frames of a particle run's trajectory.

    ``last_only``: its last frame alone, the others not read.

    Positions and angles come from the HOOMD schema (theta = 2 atan2(q_z, q_w)); length and stress
    from ``log/particles/length`` and ``log/particles/stress``; t from history.csv's row of the
    frame's step (the step's index times the first dt when history has no ``step`` column).
    The file and each frame are checked first (:func:`check_trajectory`,
    :func:`check_particle_frame`).
    """
    folder = Path(folder)
    hist = read_csv(folder / "history.csv")
    if "step" in hist:
        t_of_step = dict(zip(hist["step"].astype(int).tolist(), hist["t"].tolist(), strict=True))
    else:
        t_of_step = {}
    path = folder / "trajectory.gsd"
    n = check_trajectory(path)
    for _, frame in _raw_frames(path, [n - 1] if last_only and n else range(n)):
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


def read_particle_frames(path: str | os.PathLike, frames: Iterable[int] | None = None):
    """particles.output.read_trajectory's frames (all, or the indices ``frames``), each checked.

    The file is checked at once (:func:`check_trajectory`, and that every index exists), each
    frame when it is reached (:func:`check_particle_frame`), before it is returned; errors of
    the gsd library become DamagedFileError.
    """
    path = Path(path)
    n = check_trajectory(path)
    picks = list(range(n)) if frames is None else [int(i) for i in frames]
    missing = [i for i in picks if not 0 <= i < n]
    if missing:
        raise ValueError(f"{path} has {n} frames, no frame {missing[0]}")
    return _checked_frames(path, picks)


def _checked_frames(path: Path, picks: list[int]) -> Iterator:
    """read_trajectory's frames ``picks``, each after its raw frame passed the checks."""
    from particles.output import read_trajectory

    frames = read_trajectory(path, picks)
    try:
        for _ in _raw_frames(path, picks):
            with _gsd_errors(path):
                frame = next(frames)
            yield frame
    finally:
        frames.close()


# --------------------------------------------------------------------------- trajectory.gsd

#: The GSD file layer (gsd.h): header, index entry and name sizes; bytes of each type 1..11.
_GSD_HEADER = struct.Struct("<QQQQQII64s64s80s")
_GSD_MAGIC = 0x65DF65DF65DF65DF
_GSD_ENTRY = np.dtype([("frame", "<u8"), ("N", "<u8"), ("location", "<i8"), ("M", "<u4"),
                       ("id", "<u2"), ("type", "u1"), ("flags", "u1")])
_GSD_NAME_SIZE = 64
_GSD_ITEMSIZE = np.array([0, 1, 2, 4, 8, 1, 2, 4, 8, 4, 8, 1])
_GSD_UINT32 = 3
#: Bytes per particle a trajectory frame holds at least (its float32 lengths).
_MIN_BYTES_PER_PARTICLE = 4
#: Per-particle logs of integers (particles.output: identifiers and lineage), when present.
_INTEGER_LOGS = ("particles/Particle Identifier", "particles/parent", "particles/generation")


def _damaged(path: Path, what: str) -> DamagedFileError:
    return DamagedFileError(f"{path} is damaged: {what}")


def check_trajectory(path: str | os.PathLike) -> int:
    """Check the layout of a trajectory.gsd before the gsd library reads it; its frame count.

    gsd's reader trusts the file's header and index: a flipped bit there crashes the process,
    asks for terabytes ("Unable to allocate 1020 TiB") or fills the memory until the system
    kills it. Checked here (DamagedFileError "PATH is damaged: WHAT"): the header
    (:func:`_gsd_header`), the chunk names (:func:`_gsd_names`), every index entry
    (:func:`_gsd_index`) and each frame's particle count (:func:`_gsd_particle_counts`).
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"trajectory not found: {path}")
    with open(path, "rb") as f:
        size = os.fstat(f.fileno()).st_size
        header = _gsd_header(path, f.fileno(), size)
        names = _gsd_names(path, f.fileno(), header, size)
        index = _gsd_index(path, f.fileno(), header, size, len(names))
        _gsd_particle_counts(path, f.fileno(), index, names, size)
    return int(index["frame"][-1]) + 1 if len(index) else 0


def _gsd_header(path: Path, fd: int, size: int) -> tuple:
    """The header: GSD's magic number, a version 1.x or 2.x, index and name list in the file.

    The index and the name list hold at least one entry and lie after the header, inside the
    file.
    """
    if size < _GSD_HEADER.size:
        raise _damaged(path, f"{size} bytes, shorter than a GSD header")
    header = _GSD_HEADER.unpack(os.pread(fd, _GSD_HEADER.size, 0))
    magic, index_at, n_index, names_at, n_names, _, version = header[:7]
    if magic != _GSD_MAGIC:
        raise _damaged(path, "not a GSD file (no GSD magic number)")
    if not (1 << 16) <= version < (3 << 16):
        raise _damaged(path, f"unknown GSD file version {version >> 16}.{version & 0xFFFF}")
    for what, at, count, width in (("index", index_at, n_index, _GSD_ENTRY.itemsize),
                                   ("name list", names_at, n_names, _GSD_NAME_SIZE)):
        if count < 1 or at < _GSD_HEADER.size or at + count * width > size:
            raise _damaged(path, f"its {what} lies outside the file ({size} bytes)")
    return header


def _gsd_names(path: Path, fd: int, header: tuple, size: int) -> list[str]:
    """The chunk names: a name list ending in a zero byte, names of UTF-8 text.

    Names are packed in version 2 files, 64 bytes each in version 1.
    """
    _, _, _, names_at, n_names, _, version = header[:7]
    block = os.pread(fd, n_names * _GSD_NAME_SIZE, names_at)
    if not block.endswith(b"\0"):
        raise _damaged(path, "its name list does not end")
    if version < (2 << 16):
        raw = [block[i:i + _GSD_NAME_SIZE].split(b"\0")[0]
               for i in range(0, len(block), _GSD_NAME_SIZE)]
    else:
        raw = block.split(b"\0")
    names = []
    for name in raw:
        if not name:
            break
        try:
            names.append(name.decode("utf-8"))
        except UnicodeDecodeError:
            raise _damaged(path, f"chunk name {len(names)} is not text") from None
    return names


def _gsd_index(path: Path, fd: int, header: tuple, size: int, n_names: int) -> np.ndarray:
    """The used index entries, each of a known type and name with its data inside the file.

    Used: those before the first at location 0 (the rest must be empty). Each has a known
    type, a known name, M >= 1, no flags, its data after the header and inside the file, and
    the frames do not decrease.
    """
    _, index_at, n_index = header[:3]
    entries = np.frombuffer(os.pread(fd, n_index * _GSD_ENTRY.itemsize, index_at), _GSD_ENTRY)
    empty = np.flatnonzero(entries["location"] == 0)
    used = entries[:empty[0]] if len(empty) else entries
    if np.any(entries["location"][len(used):] != 0):
        raise _damaged(path, f"its index has entries after its end (entry {len(used)})")
    known = used["type"] < len(_GSD_ITEMSIZE)
    itemsize = np.where(known, _GSD_ITEMSIZE[np.where(known, used["type"], 0)], 0)
    end = used["location"] + used["N"].astype(float) * used["M"] * itemsize
    problems = (
        (itemsize == 0, "has an unknown data type"),
        (used["M"] == 0, "has no columns"),
        (used["flags"] != 0, "has unknown flags"),
        (used["id"] >= n_names, "names no chunk"),
        (used["frame"] >= n_index, "has an impossible frame number"),
        (np.r_[False, np.diff(used["frame"].astype(np.int64)) < 0], "is out of frame order"),
        ((used["location"] < _GSD_HEADER.size) | (end > size),
         f"lies outside the file ({size} bytes)"),
    )
    for bad, what in problems:
        if np.any(bad):
            k = int(np.argmax(bad))
            raise _damaged(path, f"index entry {k} (frame {used['frame'][k]}) {what}")
    return used


def _gsd_particle_counts(path: Path, fd: int, index: np.ndarray, names: list[str],
                         size: int) -> None:
    """Each frame's particle count N: one the file could hold, the rows of its chunks.

    N is the frame's particles/N, else frame 0's (as gsd.hoomd reads it), an unsigned 32-bit
    number; every per-particle chunk of the frame (``particles/...`` but N, types and
    type_shapes; ``log/particles/...``) has N rows.
    """
    if "particles/N" not in names or not len(index):
        return
    n_frames = int(index["frame"][-1]) + 1
    counts = np.full(n_frames, -1, dtype=np.int64)
    for e in index[index["id"] == names.index("particles/N")]:
        if e["type"] != _GSD_UINT32 or e["N"] < 1:
            raise _damaged(path, f"particles/N of frame {e['frame']} is not a count")
        counts[e["frame"]] = int.from_bytes(os.pread(fd, 4, int(e["location"])), "little")
    first = counts[0] if counts[0] >= 0 else 0
    counts[counts < 0] = first  # a frame without particles/N has frame 0's
    too_many = np.flatnonzero(counts > size // _MIN_BYTES_PER_PARTICLE)
    if len(too_many):
        k = int(too_many[0])
        raise _damaged(path, f"frame {k} claims {counts[k]} particles, more than a file of "
                             f"{size} bytes holds")
    per_particle = [i for i, name in enumerate(names)
                    if (name.startswith("particles/") and name not in (
                        "particles/N", "particles/types", "particles/type_shapes"))
                    or name.startswith("log/particles/")]
    rows = index[np.isin(index["id"], per_particle)]
    bad = np.flatnonzero(rows["N"].astype(np.int64) != counts[rows["frame"].astype(np.int64)])
    if len(bad):
        e = rows[bad[0]]
        raise _damaged(path, f"frame {e['frame']} has {counts[e['frame']]} particles but "
                             f"{e['N']} rows of {names[e['id']]}")


@contextmanager
def _gsd_errors(path: Path):
    """The gsd library's errors reading ``path`` as DamagedFileError (one line, the file)."""
    try:
        yield
    except DamagedFileError:
        raise
    except (RuntimeError, OSError, MemoryError, KeyError, IndexError, TypeError,
            ValueError) as err:  # what gsd.fl / gsd.hoomd raise on a file they cannot read
        raise _damaged(path, f"gsd cannot read it ({_reason(err)})") from None


def _raw_frames(path: Path, picks: Iterable[int]) -> Iterator[tuple[int, object]]:
    """(index, gsd.hoomd.Frame) of the frames ``picks`` of a checked trajectory.

    Each frame is checked (:func:`check_particle_frame`) before it is yielded.
    """
    import gsd.hoomd

    with _gsd_errors(path):
        traj = gsd.hoomd.open(str(path), mode="r")
    try:
        for i in picks:
            with _gsd_errors(path):
                frame = traj[int(i)]
            check_particle_frame(path, int(i), frame)
            yield int(i), frame
    finally:
        traj.close()


def check_particle_frame(path: str | os.PathLike, index: int, frame) -> None:
    """Check the arrays of frame ``index`` (a gsd.hoomd.Frame) of trajectory ``path`` before use.

    At least one particle; positions (N, 3), unit quaternions (N, 4) and the logs
    particles/length and particles/stress (N,), the integer logs (N,) where present; a finite
    box of positive edges holding every centre; then :func:`check_colony`. DamagedFileError
    "PATH is damaged: frame K has WHAT".
    """
    where = f"{path} is damaged: frame {index}"
    n = int(frame.particles.N)
    pos = np.asarray(frame.particles.position, dtype=float)
    q = np.asarray(frame.particles.orientation, dtype=float)
    logs = frame.log
    if n < 1:
        raise DamagedFileError(f"{where} has no particles")
    if pos.shape != (n, 3) or q.shape != (n, 4):
        raise DamagedFileError(f"{where} has positions or orientations not of its {n} particles")
    for name in ("particles/length", "particles/stress"):
        if name not in logs or np.shape(logs[name]) != (n,):
            raise DamagedFileError(f"{where} has no log/{name} of its {n} particles")
    for name in _INTEGER_LOGS:
        if name in logs and (np.shape(logs[name]) != (n,) or logs[name].dtype.kind not in "iu"):
            raise DamagedFileError(f"{where} has a log/{name} that is not one integer per "
                                   "particle")
    box = np.asarray(frame.configuration.box, dtype=float)
    if box.shape != (6,) or not np.all(np.isfinite(box)) or not np.all(box[:2] > 0):
        raise DamagedFileError(f"{where} has a box that is not finite with positive edges")
    if not np.all(np.isfinite(q)) or np.any(np.abs(np.linalg.norm(q, axis=1) - 1.0) > 1e-3):
        raise DamagedFileError(f"{where} has orientations that are not unit quaternions")
    theta = 2.0 * np.arctan2(q[:, 3], q[:, 0])
    check_colony(where, pos[:, 0], pos[:, 1], theta, logs["particles/length"])
    if np.any(np.abs(pos[:, :2]) > 0.5 * box[:2]):
        raise DamagedFileError(f"{where} has particles outside its box")


def check_colony(where: str, x, y, theta, length) -> None:
    """Refuse particles with centres or angles not finite, or lengths not positive.

    ``where`` begins the message: DamagedFileError "WHERE has lengths that are not positive",
    e.g. "PATH is damaged: frame 3" or "PATH is damaged: it".
    """
    for what, values in (("centres", (x, y)), ("angles", (theta,)), ("lengths", (length,))):
        if not all(np.all(np.isfinite(np.asarray(v, dtype=float))) for v in values):
            raise DamagedFileError(f"{where} has {what} that are not finite")
    if not np.all(np.asarray(length, dtype=float) > 0):
        raise DamagedFileError(f"{where} has lengths that are not positive")
