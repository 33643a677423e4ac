"""Checkpoints of a continuum run and the deferred handling of SIGINT / SIGTERM / SIGHUP.

A checkpoint (``checkpoint.npz`` in the run folder) holds everything the following steps depend
on, so a simulation loaded from it continues bit-identically:

- the arrays of the :class:`~continuum.state.State`: ``points``, ``tris``, ``G``, ``p``,
  ``u``, ``g``, ``psi`` (Psi's cell values), ``psi_phase`` (the phase offsets of Psi's windows
  with ``psi_transport = "characteristics"``) or, for the delta Psi0 (``initial_sizes =
  "delta"``), ``psi_delta`` and ``psi_log_length`` (continuum.sizes.DeltaSizes), with strains
  ``phi`` and ``G_strains`` (n, S) (continuum.strains), ``p_prev`` (when set) and ``amg``, the
  CSR data of the matrix the pressure solver's AMG hierarchy was built from (when there is one; the
  loaded solver rebuilds the identical hierarchy, continuum.pressure.amg_hierarchy);
- ``frame_times``, the times of the VTU frames written (frame k is ``fields/frame_k.vtu``,
  its name made by continuum.output.frame_name, never read from the checkpoint);
- ``meta``, one JSON string: ``config`` (the Config fields), ``colony`` (the scalars t, nb,
  n_remesh, newton, krylov, h_mesh, hmean_mesh, dt_prev, step, timings), ``history``, and
  the run's output bookkeeping: ``next_frame`` (time of the next frame) and ``done`` (the goal
  was reached);
- ``sha256``, the checksum of all the other entries (:func:`arrays_digest`).

The history: a run folder's checkpoint keeps only ``{"rows": n, "sha256": ...}`` of the
history.csv written just before it (:func:`history_record`), so its size depends on the mesh,
not on how long the colony has grown; on load the first n rows of history.csv are checked
against it and read back (:func:`read_history`). A checkpoint saved elsewhere
(``Simulation.save(path)``), and every checkpoint written before this, holds the rows.

The functions, the particle engine's too: :func:`save_checkpoint` writes a :class:`Checkpoint`
(configuration, state, history, frames, and here the AMG matrix and the run's bookkeeping),
:func:`load_checkpoint` reads one back, :func:`resume_checkpoint` finds a run folder's.

Safety (:func:`write_arrays`, :func:`read_arrays`, :func:`resume_checkpoint`): a checkpoint is
written to a temporary file, flushed, read back and verified; only then the run folder's
``checkpoint.npz``, when intact, becomes ``checkpoint.prev.npz`` and the new file takes its name
(os.replace). Loading never unpickles (allow_pickle=False), verifies the checksum and refuses
anything damaged (emptied, cut short, bytes changed, an entry missing, an object array) with one
:class:`CheckpointError` line. A run resumes from ``checkpoint.prev.npz`` (with a warning) when
``checkpoint.npz`` is damaged, so a damaged checkpoint costs one checkpoint interval; the
frames and history rows after it are dropped as after any resume. The run folder's checkpoints
are never read through a symbolic link.

A checkpoint resumes under a configuration equal to the saved one up to ``EXECUTION_FIELDS``
(settings that do not change the result). Checkpoints of earlier versions load when intact
(their zip CRCs hold): without ``sha256``, with the history and the frames ((t, file) pairs,
whose names are ignored) in ``meta``, without ``step``, as finite volumes when their
configuration has no ``psi_transport``, and with the bump Psi0 when it has no
``initial_sizes``.

:class:`StopRequest` (a context manager) defers SIGINT, SIGTERM and SIGHUP to the end of the
current step, so that ``continuum.run`` can write a checkpoint of a whole step before stopping.
"""

from __future__ import annotations

import csv
import errno
import hashlib
import io
import json
import logging
import math
import os
import re
import signal
import stat
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from continuum.config import Config
from continuum.sizes import (
    TRANSPORT_REMAP,
    CharacteristicSizes,
    DeltaSizes,
    LengthGrid,
    SizeDistribution,
)
from continuum.state import State

__all__ = ["CHECKPOINT", "PREVIOUS", "EXECUTION_FIELDS", "Checkpoint", "CheckpointError",
           "save_checkpoint", "load_checkpoint", "resume_checkpoint", "checkpoint_config",
           "checkpoint_files", "history_record", "check_resumable", "STOP_SIGNALS",
           "StopRequest", "WallLimit"]

log = logging.getLogger(__name__)

EXECUTION_FIELDS = ("checkpoint_seconds", "max_hours")
"""Configuration fields that do not change the result: a checkpoint resumes whatever they are."""

CHECKPOINT = "checkpoint.npz"
"""File name of the checkpoint in the run folder."""

PREVIOUS = "checkpoint.prev.npz"
"""File name of the checkpoint before it, kept until a new one is written and verified."""

HISTORY = "history.csv"
"""The history beside a run folder's checkpoint (continuum.output.write_history)."""

CHECKSUM = "sha256"
"""Entry of a checkpoint holding the checksum of all its other entries."""

# State attribute -> checkpoint name (the names of the format, kept from its first version)
_SCALARS = {"t": "t", "n_boundary": "nb", "n_remesh": "n_remesh", "newton": "newton",
            "krylov": "krylov", "h_mesh": "h_mesh", "h_mean_mesh": "hmean_mesh",
            "dt_prev": "dt_prev"}
_ARRAYS = {"points": "points", "triangles": "tris", "G": "G", "p": "p", "u": "u", "g": "g"}


# ------------------------------------------------------ safe files (twin of particles')


class CheckpointError(ValueError):
    """A checkpoint that cannot be used (damaged, or contradicted by history.csv).

    One line: which file is damaged and why, that the output written so far is intact, and how
    to start afresh.  ``damage`` is its first part ("FILE is damaged (WHY)"), ``remove`` the
    checkpoint files to remove to start afresh.
    """

    def __init__(self, damage: str, remove: list[Path]):
        self.damage, self.remove = damage, list(dict.fromkeys(remove))
        files = " and ".join(str(p) for p in self.remove)
        super().__init__(f"{damage}; the output written so far is intact; to start afresh, "
                         f"give --overwrite or remove {files}")


def damaged(path: Path, why: str, checkpoint: Path | None = None) -> CheckpointError:
    """The CheckpointError of ``path`` damaged for ``why`` (``checkpoint``: the one to remove)."""
    return CheckpointError(f"{path} is damaged ({why})",
                           [path if checkpoint is None else checkpoint])


def arrays_digest(arrays: dict[str, np.ndarray]) -> str:
    """sha256 (hex) of the arrays' names, dtypes, shapes and bytes, in the order of the names."""
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = arrays[name]
        h.update(f"{name}\0{a.dtype.str}\0{a.shape}\0".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def _read_file(path: Path, follow: bool = True) -> bytes:
    """The bytes of the regular file ``path``; CheckpointError for another kind of entry.

    ``follow`` False: a symbolic link is refused, not read.
    """
    flags = os.O_RDONLY | os.O_NONBLOCK | (0 if follow else os.O_NOFOLLOW)
    try:
        fd = os.open(path, flags)
    except OSError as err:
        if err.errno == errno.ELOOP:
            raise damaged(path, "a symbolic link, not read") from None
        raise
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise damaged(path, "not a regular file")
    with os.fdopen(fd, "rb") as fh:
        return fh.read()


def _why(err: BaseException) -> str:
    """What a failed np.load says of a file, in a few words (never numpy's advice)."""
    text = str(err)
    if "CRC" in text:
        return "bytes changed: CRC check failed"
    if "pickle" in text:
        return "holds an object array, refused"
    if isinstance(err, MemoryError):
        return "impossible array sizes"
    if isinstance(err, EOFError) or "zip" in text.lower():
        return "not a complete npz archive"
    return "unreadable npz archive"


def read_arrays(path: Path, follow: bool = True) -> dict[str, np.ndarray]:
    """The arrays of the checkpoint ``path``, verified (CheckpointError when damaged).

    Read with allow_pickle=False; the checksum (entry CHECKSUM) is checked and removed;
    a checkpoint written before checksums has none (its zip CRCs are checked).  ``follow``
    False: a symbolic link is refused.
    """
    data = _read_file(path, follow)
    if not data:
        raise damaged(path, "empty file")
    if not data.startswith(b"PK\x03\x04"):  # else np.load tries an npy file, or a pickle
        raise damaged(path, "not an npz archive")
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as z:
            arrays = {name: z[name] for name in z.files}
    except Exception as err:  # anything numpy or zipfile raises on a damaged archive
        raise damaged(path, _why(err)) from None
    saved = arrays.pop(CHECKSUM, None)
    if saved is not None and (saved.shape != () or saved.dtype.kind != "U"
                              or str(saved) != arrays_digest(arrays)):
        raise damaged(path, "checksum mismatch")
    return arrays


def read_meta(path: Path, arrays: dict[str, np.ndarray]) -> dict:
    """The JSON ``meta`` entry of a checkpoint's arrays (CheckpointError when unreadable)."""
    meta = arrays.get("meta")
    if meta is None or meta.shape != () or meta.dtype.kind != "U":
        raise damaged(path, "no meta entry")
    try:
        meta = json.loads(str(meta))
    except (ValueError, RecursionError):
        raise damaged(path, "meta is not JSON") from None
    if not isinstance(meta, dict):
        raise damaged(path, "meta is not a JSON object")
    return meta


def checked(path: Path, build: Callable):
    """``build()``; a KeyError, TypeError, ValueError... of unexpected content: CheckpointError."""
    try:
        return build()
    except CheckpointError:
        raise
    except KeyError as err:
        raise damaged(path, f"no entry {err.args[0]}") from None
    except (TypeError, ValueError, IndexError, AttributeError, OverflowError):
        raise damaged(path, "unexpected content") from None


def _intact(path: Path) -> bool:
    """Whether ``path`` is a checkpoint that reads and verifies (not through a link)."""
    try:
        read_arrays(path, follow=False)
    except (CheckpointError, OSError):
        return False
    return True


def _sync_folder(folder: Path) -> None:
    """Flush a folder's entries (a rename) to disk."""
    fd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_arrays(path: Path, arrays: dict, previous: Path | None = None) -> None:
    """Write ``arrays`` and their checksum to ``path``, so that a verified checkpoint remains.

    Written to ``path.tmp.npz`` (created anew, never through a link), flushed to disk, read
    back and verified; then, with ``previous``, the checkpoint at ``path`` becomes
    ``previous`` when it is intact (a damaged one is replaced, the previous kept), and the new
    file takes the name ``path`` (os.replace).  A failed write (e.g. a full disk) leaves the
    checkpoints as they were.
    """
    arrays = {name: np.asarray(a) for name, a in arrays.items()}
    arrays[CHECKSUM] = np.array(arrays_digest(arrays))
    tmp = path.with_name(path.name + ".tmp.npz")
    try:
        tmp.unlink(missing_ok=True)
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, **arrays)
            fh.flush()
            os.fsync(fh.fileno())
        read_arrays(tmp, follow=False)
        if previous is not None and _intact(path):
            os.replace(path, previous)
        os.replace(tmp, path)
        _sync_folder(path.parent)
    finally:
        tmp.unlink(missing_ok=True)


def history_record(csv_path: Path, rows: int) -> dict:
    """What a checkpoint keeps of the history.csv written just before it: rows, sha256."""
    return {"rows": rows, "sha256": hashlib.sha256(_read_file(csv_path, follow=False)).hexdigest()}


def _number(text: str) -> int | float:
    """A history.csv value: an int when written as one, else a float (repr round-trips)."""
    return int(text) if re.fullmatch(r"-?[0-9]+", text) else float(text)


def read_history(csv_path: Path, record: dict, checkpoint: Path) -> list[dict]:
    """The first ``record["rows"]`` rows of ``csv_path``, checked against ``record``.

    The header and those rows must have the sha256 the checkpoint recorded (later rows, of
    steps after the checkpoint, are ignored); blank values (columns added later) are left out
    of the rows.  CheckpointError otherwise, naming ``csv_path``.
    """
    rows, digest = checked(checkpoint, lambda: (int(record["rows"]), str(record["sha256"])))
    try:
        lines = _read_file(csv_path, follow=False).splitlines(keepends=True)
    except FileNotFoundError:
        raise damaged(csv_path, "missing", checkpoint) from None
    head = b"".join(lines[: rows + 1])
    if len(lines) < rows + 1 or hashlib.sha256(head).hexdigest() != digest:
        raise damaged(csv_path, f"its first {rows} rows are not those {checkpoint.name} "
                      "recorded", checkpoint)
    reader = csv.reader(io.StringIO(head.decode()))
    names = next(reader)
    return checked(csv_path, lambda: [
        {k: _number(v) for k, v in zip(names, row, strict=True) if v != ""} for row in reader])


def checkpoint_files(out: Path) -> list[Path]:
    """The checkpoints present in the run folder ``out``, the newest first."""
    return [p for p in (Path(out) / CHECKPOINT, Path(out) / PREVIOUS) if os.path.lexists(p)]


def resume_from(out: Path, load: Callable[[Path], tuple]) -> tuple[Path, tuple]:
    """(path, ``load(path)``) of the run folder's newest checkpoint that loads.

    ``checkpoint.npz``, else ``checkpoint.prev.npz`` with a logged warning (the run resumes one
    checkpoint interval earlier); a CheckpointError naming both when neither loads.  Other
    errors of ``load`` (a checkpoint of another configuration) are raised as they come.
    """
    errors = []
    for path in checkpoint_files(out):
        try:
            result = load(path)
        except CheckpointError as err:
            errors.append(err)
            continue
        if path.name == PREVIOUS:
            why = errors[0].damage if errors else f"{path.with_name(CHECKPOINT)} is missing"
            log.warning("%s; resuming from %s, one checkpoint interval earlier", why, path)
        return path, result
    if not errors:
        raise FileNotFoundError(errno.ENOENT, "no checkpoint", str(Path(out) / CHECKPOINT))
    raise CheckpointError(", and ".join(e.damage for e in errors),
                          [p for e in errors for p in e.remove])


# ------------------------------------------------------------------ the continuum checkpoint


@dataclass
class Checkpoint:
    """What a checkpoint holds: everything the following steps of a run depend on.

    The first four attributes are the particle engine's ``Checkpoint``'s too.

    Attributes
    ----------
    config : Config
        The configuration it ran with.
    state : State
    history : list of dict, or dict
        The history rows so far; when saving into a run folder, the :func:`history_record` of
        the history.csv written beside it (then the checkpoint at the path becomes
        ``checkpoint.prev.npz``, :func:`write_arrays`). Loaded: the rows.
    frames : list of float
        The times of the VTU frames written.
    amg : ndarray or None
        The matrix of the pressure solver's AMG hierarchy (``PressureSolver.amg_state()``).
    next_frame : float
        Time of the next frame.
    done : bool
        Whether the run's goal was reached.
    """

    config: Config
    state: State
    history: list[dict] | dict
    frames: list[float] = field(default_factory=list)
    amg: np.ndarray | None = None
    next_frame: float = math.inf
    done: bool = False


def save_checkpoint(path: Path, checkpoint: Checkpoint) -> None:
    """Write ``checkpoint`` (format in the module docstring) to ``path`` safely.

    A failed write (e.g. a full disk) leaves the existing checkpoints as they were; a history
    record (a run folder) keeps the checkpoint at ``path`` as ``checkpoint.prev.npz``.
    """
    path, state = Path(path), checkpoint.state
    scalars = {name: getattr(state, attr) for attr, name in _SCALARS.items()}
    scalars["step"] = state.step
    scalars["timings"] = dict(state.timings)
    arrays = {name: getattr(state, attr) for attr, name in _ARRAYS.items()}
    if isinstance(state.sizes, DeltaSizes):
        arrays["psi_delta"] = state.sizes.n
        arrays["psi_log_length"] = state.sizes.log_length
    else:
        arrays["psi"] = state.sizes.n
    if isinstance(state.sizes, CharacteristicSizes):
        arrays["psi_phase"] = state.sizes.phase
    if state.phi is not None:
        arrays["phi"], arrays["G_strains"] = state.phi, state.G_strains
    if state.p_prev is not None:
        arrays["p_prev"] = state.p_prev
    if checkpoint.amg is not None:
        arrays["amg"] = checkpoint.amg
    arrays["frame_times"] = np.asarray(checkpoint.frames, dtype=float)
    meta = {"config": asdict(checkpoint.config), "colony": scalars,
            "history": checkpoint.history, "next_frame": checkpoint.next_frame,
            "done": checkpoint.done}
    previous = path.with_name(PREVIOUS) if isinstance(checkpoint.history, dict) else None
    write_arrays(path, {"meta": np.array(json.dumps(meta)), **arrays}, previous)
    log.debug("checkpoint at t = %.6g written to %s", state.t, path)


def _check_arrays(path: Path, arrays: dict, n_cells: int, n_strains: int = 0) -> None:
    """CheckpointError unless the state's arrays are there, of the shapes of one mesh.

    n nodes: points (n, 2), u (n, 2), G, p, g, psi_phase, p_prev (n,), psi (n, n_cells),
    with S = ``n_strains`` >= 1 strains phi and G_strains (n, S); triangles (m, 3) of node
    indices; amg and frame_times one-dimensional; all real numbers.
    """
    n = checked(path, lambda: arrays["points"].shape[0])
    shapes = {"points": (n, 2), "u": (n, 2), "G": (n,), "p": (n,), "g": (n,), "psi_phase": (n,),
              "p_prev": (n,), "psi": (n, n_cells), "psi_delta": (n,), "psi_log_length": (n,),
              "phi": (n, n_strains), "G_strains": (n, n_strains)}
    psi = ("psi_delta", "psi_log_length") if "psi_delta" in arrays else ("psi",)
    strains = ("phi", "G_strains") if n_strains else ()
    if not n_strains and arrays.keys() & {"phi", "G_strains"}:
        raise damaged(path, "unexpected content (phi)")
    for name in ("points", "tris", "G", "p", "u", "g", *psi, *strains):
        checked(path, lambda name=name: arrays[name])
    for name in sorted(arrays.keys() & {*shapes, "tris", "amg"}):
        a = arrays[name]
        shape = shapes.get(name, (a.size,) if name == "amg" else (a.size // 3, 3))
        if a.dtype.kind not in ("i" if name == "tris" else "f") or a.shape != shape:
            raise damaged(path, f"unexpected content ({name})")
    tris = arrays["tris"]
    if tris.size and not (0 <= tris.min() and tris.max() < n):
        raise damaged(path, "unexpected content (tris)")


def _state(arrays: dict, meta: dict, saved: dict, default_step: int) -> State:
    """The State of a checkpoint's (checked) arrays and metadata."""
    scalars = meta["colony"]
    grid = LengthGrid(saved["n_length_cells"])
    if "psi_delta" in arrays:
        sizes = DeltaSizes(arrays["psi_delta"], arrays["psi_log_length"])
    elif "psi_phase" in arrays:
        remap = TRANSPORT_REMAP.get(saved.get("psi_transport"), "cells")
        sizes = CharacteristicSizes(grid, arrays["psi"], arrays["psi_phase"], remap)
    else:
        sizes = SizeDistribution(grid, arrays["psi"])
    return State(
        **{attr: np.array(arrays[name]) for attr, name in _ARRAYS.items()},
        sizes=sizes,
        **{attr: scalars[name] for attr, name in _SCALARS.items()},
        step=scalars.get("step", default_step),
        timings=dict(scalars["timings"]),
        p_prev=np.array(arrays["p_prev"]) if "p_prev" in arrays else None,
        phi=np.array(arrays["phi"]) if "phi" in arrays else None,
        G_strains=np.array(arrays["G_strains"]) if "G_strains" in arrays else None,
    )


def _history(path: Path, saved) -> list[dict]:
    """The history rows of a checkpoint: kept in it, or those of history.csv it recorded."""
    if isinstance(saved, dict):
        return read_history(path.parent / HISTORY, saved, path)
    if not (isinstance(saved, list) and saved and all(isinstance(r, dict) for r in saved)):
        raise damaged(path, "unexpected content (history)")
    return saved


def _frame_times(path: Path, arrays: dict, meta: dict) -> list[float]:
    """The times of the frames written, checked.

    ``frame_times``, or the times of an earlier version's (t, file) pairs, whose names are
    ignored (frame k is always named by continuum.output.frame_name).
    """
    if "frame_times" in arrays:
        a = arrays["frame_times"]
        times = a.tolist() if a.ndim == 1 and a.dtype.kind == "f" else [math.nan]
    else:
        times = checked(path, lambda: [float(t) for t, _ in meta["frames"]])
    if not all(math.isfinite(t) for t in times):
        raise damaged(path, "unexpected content (frame_times)")
    return times


def _bookkeeping(path: Path, meta: dict) -> tuple[float, bool]:
    """(next_frame, done) of a checkpoint's metadata, checked."""
    next_frame, done = checked(path, lambda: (meta["next_frame"], meta["done"]))
    if type(done) is not bool or type(next_frame) not in (int, float) or math.isnan(next_frame):
        raise damaged(path, "unexpected content (next_frame, done)")
    return float(next_frame), done


def _saved_config(path: Path, arrays: dict) -> dict:
    """The configuration fields a checkpoint holds (older ones: ``element`` P1)."""
    meta = read_meta(path, arrays)
    saved = checked(path, lambda: meta["config"])
    if not isinstance(saved, dict):
        raise damaged(path, "unexpected content (config)")
    saved.setdefault("element", "P1")  # checkpoints from before Config.element solved with P1
    saved.setdefault("initial_sizes", "bump")  # and from before Config.initial_sizes the bump
    saved.setdefault("strains", [])  # and from before Config.strains one strain
    saved.setdefault("layout", None)
    if "max_steps" in saved:  # Config.step_limit's former name
        saved["step_limit"] = saved.pop("max_steps")
    return saved


def _config(path: Path, saved: dict) -> Config:
    """The Config of saved fields (CheckpointError when they are not Config's).

    A value Config refuses raises its ValueError.
    """
    try:
        return Config(**saved)
    except TypeError:
        raise damaged(path, "unexpected content (config)") from None


def checkpoint_config(path: Path) -> Config:
    """The configuration the checkpoint at ``path`` was written with."""
    path = Path(path)
    return _config(path, _saved_config(path, read_arrays(path)))


def load_checkpoint(path: Path, config: Config | None = None, *,
                    follow: bool = True) -> Checkpoint:
    """The :class:`Checkpoint` written by :func:`save_checkpoint` at ``path``.

    Parameters
    ----------
    path : Path
    config : Config, optional
        The configuration to continue with, checked against the saved one
        (:func:`check_resumable`); None: the saved one.
    follow : bool
        False: a symbolic link is refused.

    Returns
    -------
    Checkpoint
        ``config`` (the one given, else the saved one) and the saved state, history rows,
        frame times, AMG matrix and bookkeeping.

    Raises
    ------
    CheckpointError
        The file is damaged (or its history.csv does not hold the rows it recorded).
    ValueError
        ``config`` differs from the saved one (:func:`check_resumable`).
    """
    path = Path(path)
    arrays = read_arrays(path, follow)
    meta = read_meta(path, arrays)
    saved = _saved_config(path, arrays)
    if config is not None:
        check_resumable(path, saved, config)
    history = _history(path, checked(path, lambda: meta["history"]))
    times = _frame_times(path, arrays, meta)
    arrays.pop("frame_times", None)
    _check_arrays(path, arrays, checked(path, lambda: int(saved["n_length_cells"])),
                  checked(path, lambda: len(saved["strains"])))
    state = checked(path, lambda: _state(arrays, meta, saved, len(history) - 1))
    next_frame, done = _bookkeeping(path, meta)
    if config is None:
        config = _config(path, saved)
    return Checkpoint(config, state, history, times, arrays.get("amg"), next_frame, done)


def resume_checkpoint(out: Path, config: Config) -> tuple[Path, Checkpoint]:
    """(path, :func:`load_checkpoint` of it) of the run folder ``out``'s checkpoint.

    ``checkpoint.npz``, or ``checkpoint.prev.npz`` when that one is damaged (resume_from);
    never through a symbolic link.
    """
    return resume_from(Path(out), lambda path: load_checkpoint(path, config, follow=False))


def check_resumable(path: Path, saved: dict, config) -> None:
    """ValueError unless the saved configuration equals ``config`` up to EXECUTION_FIELDS."""
    now = json.loads(json.dumps(asdict(config)))
    wrong = sorted(
        k for k in {*saved, *now} if k not in EXECUTION_FIELDS and saved.get(k) != now.get(k)
    )
    if wrong:
        raise ValueError(
            f"checkpoint {path} belongs to a different configuration (differs in "
            f"{', '.join(wrong)}); delete it, or use another output folder, to start afresh"
        )


STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
"""Signals that end a run after its current step, with a checkpoint (:class:`StopRequest`)."""


class StopRequest:
    """SIGINT / SIGTERM / SIGHUP deferred to the end of the current step (main thread only).

    A context manager: entering installs the handlers; the first signal sets ``signum`` and
    puts the previous handlers back, so the run can finish its step and write a checkpoint,
    while a second signal acts at once; leaving puts them back. After the checkpoint,
    :meth:`reraise` raises for the signal that came::

        with StopRequest() as stop:
            while ... and stop.signum is None:
                ...  # steps
        stop.reraise()

    The twin of the particle engine's (the two engines do not import each other).
    """

    def __init__(self):
        self.signum = None
        self._previous = {}

    def install(self) -> StopRequest:
        """Catch STOP_SIGNALS (from the main thread only; elsewhere a no-op); returns self."""
        if threading.current_thread() is threading.main_thread():
            for sig in STOP_SIGNALS:
                self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def _handle(self, signum, frame):
        self.signum = signum
        self.restore()

    def restore(self) -> None:
        """Put the previous signal handlers back."""
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        self._previous = {}

    def __enter__(self) -> StopRequest:
        return self.install()

    def __exit__(self, *exc) -> None:
        self.restore()

    def reraise(self) -> None:
        """Re-raise the signal that came, after the final checkpoint.

        KeyboardInterrupt for SIGINT, SystemExit(128 + signal) for SIGTERM and SIGHUP, nothing
        when no signal came.
        """
        if self.signum == signal.SIGINT:
            raise KeyboardInterrupt
        if self.signum is not None:
            raise SystemExit(128 + self.signum)


class WallLimit:
    """The wall-clock limit of a run, ``Config.max_hours``: pause while a checkpoint still fits.

    From the run's start (``start``, a time.monotonic() reading: the process's start as the
    command line gives it; default: now), the run pauses before a step when

        elapsed + 2 max(recent step) + 2 (checkpoint write) >= 3600 max_hours,

    the recent steps being the last RECENT_STEPS (a checkpoint's write not counted in them);
    before the run's first checkpoint its write counts as long as a step.  The first step of a
    run is always taken, so every leg of a chain advances.  No limit (None): never due.

    The twin of the particles engine's (the two engines do not import each other).
    """

    RECENT_STEPS = 20

    def __init__(self, hours: float | None, start: float | None = None):
        self.limit = None if hours is None else 3600.0 * float(hours)
        self.last = time.monotonic()
        self.start = self.last if start is None else start
        self.steps: deque[float] = deque(maxlen=self.RECENT_STEPS)
        self.write: float | None = None

    def stepped(self) -> None:
        """A step ended now."""
        now = time.monotonic()
        self.steps.append(now - self.last)
        self.last = now

    def saved(self, seconds: float) -> None:
        """A checkpoint took ``seconds`` to write, just now."""
        self.write = seconds
        self.last = time.monotonic()

    @property
    def due(self) -> bool:
        """Whether the run pauses before its next step."""
        if self.limit is None or not self.steps:
            return False
        step = max(self.steps)
        write = step if self.write is None else self.write
        return time.monotonic() - self.start + 2 * step + 2 * write >= self.limit
