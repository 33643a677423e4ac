"""Checkpoints of a particle simulation (``checkpoint.npz``) and deferred stop signals.

A checkpoint saves the one state object (``state.ParticleState``: particle arrays, t, step,
random generator, warm start, next dt) with the configuration it ran with and the trajectory
bookkeeping (frames written, step of the last frame).  Format: ``np.savez`` with a JSON ``meta``
(config, t, step, next_id, rng, history, frames, dt_next), ``warm_keys``, ``warm_gamma``, the
particle arrays and ``sha256``, the checksum of all the others (:func:`arrays_digest`).

The history: a run folder's checkpoint keeps only ``{"rows": n, "sha256": ...}`` of the
history.csv written just before it (the record of the steps; :func:`history_record`), so its
size depends on the colony, not on how long it has run; on load the first n rows of history.csv
are checked against it and read back (:func:`read_history`).  A checkpoint saved elsewhere
(``Simulation.save(path)``), and every checkpoint written before this, holds the rows in
``meta``.

The functions, the continuum engine's too: :func:`save_checkpoint` writes a :class:`Checkpoint`
(configuration, state, history, frames), :func:`load_checkpoint` reads one back,
:func:`resume_checkpoint` finds a run folder's.

Safety (:func:`write_arrays`, :func:`read_arrays`, :func:`resume_checkpoint`): a checkpoint is
written to a temporary file, flushed, read back and verified; only then the run folder's
``checkpoint.npz``, when intact, becomes ``checkpoint.prev.npz`` and the new file takes its name
(os.replace).  Loading never unpickles (allow_pickle=False), verifies the checksum and refuses
anything damaged (emptied, cut short, bytes changed, an entry missing, an object array) with one
:class:`CheckpointError` line.  A run resumes from ``checkpoint.prev.npz`` (with a warning) when
``checkpoint.npz`` is damaged, so a damaged checkpoint costs one checkpoint interval; the run's
resume then truncates the trajectory and the history to that earlier state.  Checkpoints
written before the checksum load when their zip CRCs hold.  The run folder's checkpoints are
never read through a symbolic link.

Older checkpoints load: without ``parent``/``generation`` (initial particles: -1, 0), without
``dt_next`` (``Config.dt``) or fields added to or renamed in ``Config`` since (``config.upgrade``).

SIGINT / SIGTERM / SIGHUP (a closed terminal or ssh session) during a run are deferred to the
end of the current step (:class:`StopRequest`) so that the run writes a checkpoint of a whole
step before stopping.
"""

from __future__ import annotations

import csv
import errno
import hashlib
import io
import json
import logging
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

from .config import EXECUTION_FIELDS, STEP_POLICY_FIELDS, Config, upgrade
from .geometry import canonical_keys
from .state import OPTIONAL_ARRAYS, PARTICLE_ARRAYS, ParticleState

__all__ = ["CHECKPOINT", "PREVIOUS", "EXECUTION_FIELDS", "Checkpoint", "CheckpointError",
           "save_checkpoint", "load_checkpoint", "resume_checkpoint", "checkpoint_config",
           "checkpoint_files", "history_record", "STOP_SIGNALS", "StopRequest", "WallLimit"]

log = logging.getLogger(__name__)

CHECKPOINT = "checkpoint.npz"
"""File name of the checkpoint in a run folder."""

PREVIOUS = "checkpoint.prev.npz"
"""File name of the checkpoint before it, kept until a new one is written and verified."""

HISTORY = "history.csv"
"""The history beside a run folder's checkpoint (output.write_history)."""

CHECKSUM = "sha256"
"""Entry of a checkpoint holding the checksum of all its other entries."""

NO_FRAMES = (0, -1)
"""Trajectory bookkeeping of a simulation without output: no frame written."""


# ------------------------------------------------------------- safe files (twin of continuum's)


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


# ------------------------------------------------------------------ the particle checkpoint


@dataclass
class Checkpoint:
    """What a checkpoint holds: everything the following steps of a run depend on.

    The first four attributes are the continuum engine's ``Checkpoint``'s too.

    Attributes
    ----------
    config : Config
        The configuration it ran with.
    state : ParticleState
    history : list of dict, or dict
        The history rows so far; when saving into a run folder, the :func:`history_record` of
        the history.csv written beside it (then the checkpoint at the path becomes
        ``checkpoint.prev.npz``, :func:`write_arrays`). Loaded: the rows.
    frames : list of int
        The trajectory bookkeeping: [frames written, step of the last frame, bytes of the
        trajectory] (NO_FRAMES: none; the bytes are missing in older checkpoints).
    """

    config: Config
    state: ParticleState
    history: list[dict] | dict
    frames: list[int] = field(default_factory=lambda: list(NO_FRAMES))


def save_checkpoint(path: Path, checkpoint: Checkpoint) -> None:
    """Write ``checkpoint`` (format in the module docstring) to ``path`` safely.

    A failed write (e.g. a full disk) leaves the existing checkpoints as they were; a history
    record (a run folder) keeps the checkpoint at ``path`` as ``checkpoint.prev.npz``.
    """
    path, config, state = Path(path), checkpoint.config, checkpoint.state
    dt_next = config.dt if state.dt_next is None else state.dt_next
    meta = {"config": asdict(config), "t": state.t, "step": state.step, "next_id": state.next_id,
            "rng": state.rng.bit_generator.state, "history": checkpoint.history,
            "frames": list(checkpoint.frames), "dt_next": dt_next}
    previous = path.with_name(PREVIOUS) if isinstance(checkpoint.history, dict) else None
    write_arrays(path, {"meta": np.array(json.dumps(meta)), "warm_keys": state.warm_keys,
                        "warm_gamma": state.warm_gamma, **state.arrays()}, previous)
    log.debug("checkpoint at t = %.6g (step %d) written to %s", state.t, state.step, path)


def _saved_config(path: Path, meta: dict) -> dict:
    """The configuration fields a checkpoint's metadata holds, in today's names (upgrade)."""
    saved = checked(path, lambda: upgrade(meta["config"]))
    if not isinstance(saved, dict):
        raise damaged(path, "unexpected content (config)")
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
    return _config(path, _saved_config(path, read_meta(path, read_arrays(path))))


def _check_config(path: Path, saved: dict, config: Config, change_step_policy: bool) -> None:
    """ValueError unless ``config`` equals the saved one up to the fields free on resume."""
    now = json.loads(json.dumps(asdict(config)))
    free = EXECUTION_FIELDS + (STEP_POLICY_FIELDS if change_step_policy else ())
    for k in free:
        saved.pop(k, None)
        now.pop(k)
    if saved != now:
        wrong = sorted(k for k in {*saved, *now} if saved.get(k) != now.get(k))
        hint = ("; a changed step policy resumes with change_step_policy=True "
                "(colony particles --change-step-policy)"
                if set(wrong) <= set(STEP_POLICY_FIELDS) else "")
        raise ValueError(f"checkpoint {path} belongs to a different configuration "
                         f"(differs in {', '.join(wrong)}){hint}")


def _particle_arrays(path: Path, arrays: dict) -> dict[str, np.ndarray]:
    """The particle arrays of a checkpoint (parent, generation, strain when saved), checked.

    One-dimensional, of one length, real numbers; the warm start's two arrays of one length.
    """
    optional = ("parent", "generation", *OPTIONAL_ARRAYS)
    names = [k for k in PARTICLE_ARRAYS if k in arrays or k not in optional]
    found = checked(path, lambda: {k: arrays[k] for k in [*names, "warm_keys", "warm_gamma"]})
    n, warm = found["x"].shape, found["warm_keys"].shape
    for k, a in found.items():
        if a.ndim != 1 or a.dtype.kind not in "iuf" or a.shape != (warm if "warm" in k else n):
            raise damaged(path, f"unexpected content ({k})")
    return found


def _state(path: Path, arrays: dict, meta: dict, config: Config) -> ParticleState:
    """The ParticleState of a checkpoint's arrays and metadata."""
    found = _particle_arrays(path, arrays)
    warm_keys, warm_gamma = found.pop("warm_keys"), found.pop("warm_gamma")
    rng = np.random.default_rng(config.seed)
    rng.bit_generator.state = meta["rng"]
    return ParticleState(**found, next_id=int(meta["next_id"]), t=float(meta["t"]),
                         step=int(meta["step"]), rng=rng, warm_keys=canonical_keys(warm_keys),
                         warm_gamma=warm_gamma, dt_next=float(meta.get("dt_next", config.dt)))


def _history(path: Path, saved) -> list[dict]:
    """The history rows of a checkpoint: kept in it, or those of history.csv it recorded."""
    if isinstance(saved, dict):
        return read_history(path.parent / HISTORY, saved, path)
    if not (isinstance(saved, list) and all(isinstance(row, dict) for row in saved)):
        raise damaged(path, "unexpected content (history)")
    return saved


def _frames(path: Path, saved) -> list[int]:
    """The trajectory bookkeeping [frames written, step of the last frame(, bytes)], checked."""
    if not (isinstance(saved, list) and len(saved) in (2, 3)
            and all(type(v) is int for v in saved) and saved[0] >= 0):
        raise damaged(path, "unexpected content (frames)")
    return saved


def load_checkpoint(path: Path, config: Config | None = None, *, follow: bool = True,
                    change_step_policy: bool = False) -> Checkpoint:
    """The :class:`Checkpoint` written by :func:`save_checkpoint` at ``path``.

    ``config``: the configuration to continue with, equal to the checkpoint's up to
    ``EXECUTION_FIELDS`` (and ``STEP_POLICY_FIELDS`` with ``change_step_policy``; ValueError
    otherwise); None: the checkpoint's.  Raises CheckpointError when the file is damaged (or
    its history.csv does not hold the rows it recorded).  A checkpoint written before the
    lineage was tracked has no ``parent`` and ``generation`` arrays: the particles then
    present are loaded as initial ones (parent -1, generation 0), and their daughters count
    generations from them.  With ``change_step_policy`` the next step follows ``config``'s
    policy: ``dt_next`` is ``config.dt`` with a fixed step, else the saved ``dt_next`` capped
    at ``config.dt``.  ``follow`` False: a symbolic link is refused.
    """
    path = Path(path)
    arrays = read_arrays(path, follow)
    meta = read_meta(path, arrays)
    saved = _saved_config(path, meta)
    if config is None:
        config = _config(path, dict(saved))
    _check_config(path, saved, config, change_step_policy)
    state = checked(path, lambda: _state(path, arrays, meta, config))
    frames = _frames(path, checked(path, lambda: meta["frames"]))
    history = _history(path, checked(path, lambda: meta["history"]))
    if change_step_policy:
        state.dt_next = (config.dt if config.step_control == "fixed"
                         else min(state.dt_next, config.dt))
    return Checkpoint(config, state, history, frames)


def resume_checkpoint(out: Path, config: Config, *, change_step_policy: bool = False
                      ) -> tuple[Path, Checkpoint]:
    """(path, :func:`load_checkpoint` of it) of the run folder ``out``'s checkpoint.

    ``checkpoint.npz``, or ``checkpoint.prev.npz`` when that one is damaged (resume_from);
    never through a symbolic link.
    """
    return resume_from(Path(out), lambda path: load_checkpoint(
        path, config, follow=False, change_step_policy=change_step_policy))


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

    The twin of the continuum engine's (the two engines do not import each other).
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

    The twin of the continuum engine's (the two engines do not import each other).
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
