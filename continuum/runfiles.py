"""A run's files and controls, written once for both engines (``continuum``, ``particles``).

Neither engine imports the other, so each has this module as its own: ``particles/runfiles.py``
is a symbolic link to ``continuum/runfiles.py`` (one source; a wheel holds a copy in each
package). It imports nothing but the standard library and numpy (and tqdm, for the bar).

Files. A checkpoint is an ``np.savez`` archive of named arrays with ``sha256``, the checksum of
all the others (:func:`arrays_digest`). :func:`write_arrays` writes it to a temporary file,
flushes, reads it back and verifies it; only then the run folder's ``checkpoint.npz``, when
intact, becomes ``checkpoint.prev.npz`` and the new file takes its name (os.replace).
:func:`read_arrays` never unpickles (allow_pickle=False), verifies the checksum and refuses
anything damaged with one :class:`CheckpointError` line; a file that is no checkpoint, or one of
the other engine, with one :class:`NotCheckpointError` line (never advising its removal).
:func:`resume_from` falls back to ``checkpoint.prev.npz`` (with a warning) when
``checkpoint.npz`` is damaged. A run folder's checkpoint keeps of the history only
``{"rows": n, "sha256": ...}`` of the history.csv written just before it
(:func:`history_record`), checked and read back by :func:`read_history`. What a checkpoint
contains is each engine's (``continuum.checkpoint``, ``particles.checkpoint``). A run keeps
RESERVE_BYTES free on its file system (:func:`ensure_space`).

Controls. :class:`StopRequest` defers SIGINT, SIGTERM and SIGHUP to the end of the current step,
so that a run writes a checkpoint of a whole step before it stops; :class:`WallLimit` pauses a
run before ``Config.max_hours`` of wall while a checkpoint still fits; :func:`reached`,
:func:`check_goal`, :func:`goal_of` and :func:`require_goal` are the goals' rules;
:func:`is_number`, :func:`type_mismatch` and :func:`check_types` those of a Config's field types
(both engines').

The run loop. :func:`drive` is the one loop of both engines' ``run`` (goal, progress,
checkpoints, pause, stop, final files) and :func:`advance` the loop of ``Simulation.advance``;
each engine's ``Simulation`` supplies only its step and its state: ``config``, ``state``,
``output``, ``label``, ``done(radius, time)``, ``step_toward(radius, time)``,
``check_budget(radius, time)``, ``save()``, ``finish()``, ``finished`` and ``paused``.
:class:`ProgressBar` shows either on a terminal, or logs a line every PROGRESS_SECONDS.
"""

from __future__ import annotations

import csv
import dataclasses
import errno
import hashlib
import io
import json
import logging
import math
import os
import re
import shutil
import signal
import stat
import sys
import threading
import time
from collections import deque
from collections.abc import Callable
from pathlib import Path

import numpy as np

__all__ = ["ENGINE", "CHECKPOINT", "PREVIOUS", "HISTORY", "CHECKSUM", "CheckpointError", "damaged",
           "NotCheckpointError",
           "arrays_digest", "read_arrays", "read_meta", "checked", "write_arrays",
           "history_record", "read_history", "checkpoint_files", "resume_from",
           "RESERVE_BYTES", "ensure_space",
           "STOP_SIGNALS", "StopRequest", "WallLimit", "RADIUS_RTOL", "TIME_TOL", "reached",
           "is_number", "FIELD_TYPES", "type_mismatch", "check_types", "check_goal",
           "require_goal", "check_state_type", "check_nutrient", "PROGRESS_SECONDS", "goal_of",
           "ProgressBar", "advance", "drive"]

log = logging.getLogger(__name__)
_now = time.monotonic

ENGINE = __name__.partition(".")[0]
"""The engine of this copy of the module: ``continuum`` or ``particles``."""

CHECKPOINT = "checkpoint.npz"
"""File name of the checkpoint in a run folder."""

PREVIOUS = "checkpoint.prev.npz"
"""File name of the checkpoint before it, kept until a new one is written and verified."""

HISTORY = "history.csv"
"""The history beside a run folder's checkpoint (each engine's output.write_history)."""

CHECKSUM = "sha256"
"""Entry of a checkpoint holding the checksum of all its other entries."""


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


class NotCheckpointError(ValueError):
    """A file given as a checkpoint that is none of this engine's (one line; nothing removed).

    Not a checkpoint at all (:func:`read_arrays`), or a checkpoint of the other engine
    (:func:`read_meta`).  Unlike :class:`CheckpointError`, it never advises removing the file.
    """


#: Entries and meta keys that mark a checkpoint of each engine (:func:`read_meta`).
_ENGINE_MARKS = {"continuum": ({"points", "tris"}, {"colony"}),
                 "particles": ({"theta", "warm_keys"}, {"next_id", "rng"})}


def _refused(path: Path, why: str, any_npz: bool = True) -> ValueError:
    """A damaged checkpoint (CheckpointError) when ``path`` is named as one, else no checkpoint.

    Named as a checkpoint: a run folder's (CHECKPOINT, PREVIOUS), and with ``any_npz`` (a
    file that is no readable npz archive) any name ending in ``.npz``.  Anything else
    (history.csv, a picture, a folder, an npz of other arrays) is :class:`NotCheckpointError`:
    it may be good data, so its removal is never advised.
    """
    name = Path(path).name
    if name in (CHECKPOINT, PREVIOUS) or (any_npz and name.endswith(".npz")):
        return damaged(path, why)
    return NotCheckpointError(f"{path} is not a {ENGINE} checkpoint ({why}); give a "
                              f"checkpoint.npz written by a {ENGINE} run or Simulation.save")


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
        raise _refused(path, "not a regular file", any_npz=False)
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
    False: a symbolic link is refused.  A file that is no checkpoint is NotCheckpointError,
    not damaged (:func:`_refused`): no readable npz archive and a name not ending in ``.npz``,
    or a folder, or an intact archive with neither CHECKSUM nor ``meta``, not named as a run
    folder's checkpoint.
    """
    data = _read_file(path, follow)
    if not data:
        raise _refused(path, "empty file")
    if not data.startswith(b"PK\x03\x04"):  # else np.load tries an npy file, or a pickle
        raise _refused(path, "not an npz archive")
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as z:
            arrays = {name: z[name] for name in z.files}
    except Exception as err:  # anything numpy or zipfile raises on a damaged archive
        raise _refused(path, _why(err)) from None
    if CHECKSUM not in arrays and "meta" not in arrays:
        raise _refused(path, "an npz archive without a checkpoint's entries", any_npz=False)
    saved = arrays.pop(CHECKSUM, None)
    if saved is not None and (saved.shape != () or saved.dtype.kind != "U"
                              or str(saved) != arrays_digest(arrays)):
        raise damaged(path, "checksum mismatch")
    return arrays


def read_meta(path: Path, arrays: dict[str, np.ndarray]) -> dict:
    """The JSON ``meta`` entry of a checkpoint's arrays (CheckpointError when unreadable).

    NotCheckpointError for a checkpoint of the other engine (its entries and meta keys,
    _ENGINE_MARKS), before anything of its content is taken for this engine's.
    """
    meta = arrays.get("meta")
    if meta is None or meta.shape != () or meta.dtype.kind != "U":
        raise damaged(path, "no meta entry")
    try:
        meta = json.loads(str(meta))
    except (ValueError, RecursionError):
        raise damaged(path, "meta is not JSON") from None
    if not isinstance(meta, dict):
        raise damaged(path, "meta is not a JSON object")
    engines = [engine for engine, (entries, keys) in _ENGINE_MARKS.items()
               if entries & arrays.keys() or keys & meta.keys()]
    if len(engines) == 1 and engines[0] != ENGINE:  # of both: left to the engine's checks
        raise NotCheckpointError(f"{path} is a {engines[0]} checkpoint, not a {ENGINE} one "
                                 f"({engines[0]}.Simulation.load reads it)")
    return meta


def checked(path: Path, build: Callable):
    """``build()``; a KeyError, TypeError, ValueError... of unexpected content: CheckpointError."""
    try:
        return build()
    except (CheckpointError, NotCheckpointError):
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



#: Free space a run keeps on its output's file system: it stops with ENOSPC before a write
#: could fill it (a trajectory write into a full tmpfs can end the process with SIGBUS).
RESERVE_BYTES = 4 * 2**20


def ensure_space(out: Path, need: int, rewritten: tuple = ()) -> None:
    """Raise OSError(ENOSPC) unless ``out`` has RESERVE_BYTES free beyond the next writes.

    The next writes: ``need`` new bytes (a frame), and the files of ``rewritten``, pairs
    (path, times): each ``times`` its present size (a checkpoint 2, its temporary copy
    beside it; a history rewritten 1); a missing file counts 0.
    """
    need = RESERVE_BYTES + need
    for path, times in rewritten:
        if path is not None and Path(path).is_file():
            need += times * Path(path).stat().st_size
    free = shutil.disk_usage(out).free
    if free < need:
        raise OSError(errno.ENOSPC, f"no space left on {out} ({free / 2**20:.1f} MB free, "
                      f"{need / 2**20:.1f} MB needed for the next output)")


# ---------------------------------------------------------------------- controls


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


RADIUS_RTOL = 1e-7
"""A radius goal R is reached at a colony radius >= R (1 - RADIUS_RTOL).

The continuum's last step of a radius goal lands on it by a linear extrapolation of dR/dt
(``continuum.simulation.Simulation._dt``), within about 1e-9 relative below it (measured:
-1.2e-9 for a disc at lam = 0 to radius 4.5); a tighter tolerance would add a step of that
size. The particle engine's last step lands at or beyond it."""

TIME_TOL = 1e-12
"""A time goal T is reached at t >= T - TIME_TOL max(1, T) (both engines)."""


def reached(radius_now, t: float, radius: float | None, time: float | None) -> bool:
    """Whether the first of the goals is reached (False when both goals are None).

    Time T: t >= T - TIME_TOL max(1, T); radius R_goal: R >= R_goal (1 - RADIUS_RTOL).
    ``radius_now``: the colony radius, or a function returning it (called only for a radius
    goal).
    """
    if time is not None and t >= time - TIME_TOL * max(1.0, time):
        return True
    if radius is None:
        return False
    return (radius_now() if callable(radius_now) else radius_now) >= radius * (1 - RADIUS_RTOL)


def is_number(v) -> bool:
    """A finite int or float (a bool is no number here): the rule of every numeric setting."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return False
    try:
        return math.isfinite(v)
    except OverflowError:  # an int beyond the range of floats
        return False


#: The types of a Config field's annotation: (test of a value, what the value must be).
FIELD_TYPES = {
    "float": (is_number, "a number"),
    "int": (lambda v: isinstance(v, int) and not isinstance(v, bool), "an integer"),
    "str": (lambda v: isinstance(v, str), "a string"),
    "bool": (lambda v: isinstance(v, bool), "true or false"),
    "None": (lambda v: v is None, "None"),
    "tuple": (lambda v: isinstance(v, (tuple, list)), "a list of strains [lam, growth]"),
}


def type_mismatch(annotation: str, value) -> str | None:
    """What a field of ``annotation`` takes (e.g. "a number") when ``value`` is not of it.

    None when it is. The annotation is the field's (``float | None``): float a finite int or
    float, never a bool; int an int, not a bool; str a string; bool True or False only; None.
    """
    kinds = [kind.strip() for kind in annotation.split("|")]
    if any(FIELD_TYPES[kind][0](value) for kind in kinds):
        return None
    if "float" in kinds and isinstance(value, float):
        return "a finite number"
    return " or ".join(FIELD_TYPES[kind][1] for kind in kinds if kind != "None")


def check_types(config) -> None:
    """ValueError (one line) naming the first field of the dataclass ``config`` not of its type."""
    for field in dataclasses.fields(config):
        value = getattr(config, field.name)
        what = type_mismatch(field.type, value)
        if what is not None:
            raise ValueError(f"{field.name} must be {what}, got {value!r}")


def check_goal(radius: float | None, time: float | None) -> None:
    """ValueError unless each given goal is a positive finite number."""
    for name, v in (("radius", radius), ("time", time)):
        if v is not None and not (is_number(v) and v > 0):
            raise ValueError(f"{name} must be a positive finite number, got {v!r}")


def check_nutrient(ell, K, others: tuple = ()) -> None:
    """The nutrient's fields of both Configs, one line each (model.md, "Nutrient limitation").

    ``ell`` (``nutrient_length``) None, or positive and finite; ``K`` (``monod_k``) None (first
    order) or positive; ``K`` and the engine's ``others`` ((name, value) pairs) only with ell.
    """
    if ell is None:
        for name, value in (("monod_k", K), *others):
            if value is not None:
                raise ValueError(f"{name} = {value:g} needs nutrient_length (the nutrient's "
                                 "penetration length ell): without it there is no nutrient")
        return
    if not (is_number(ell) and ell > 0):
        raise ValueError(f"nutrient_length must be a positive finite number (cell lengths), "
                         f"got {ell!r}; leave it unset for no nutrient limitation")
    if K is not None and not K > 0:
        raise ValueError(f"monod_k must be positive (inf: first order), got {K!r}")


def check_state_type(state, kind: type, what: str) -> None:
    """TypeError (one line) unless ``state`` is a ``kind`` or None; ``what`` names the choices.

    E.g. "state must be a particles.ParticleState (or None: config.init or one cell), got str".
    """
    if state is not None and not isinstance(state, kind):
        given = type(state)
        name = given.__qualname__ if given.__module__ == "builtins" else (
            f"{given.__module__}.{given.__qualname__}")
        raise TypeError(f"state must be a {what}, got {name}")


def require_goal(config) -> None:
    """ValueError unless ``config`` has a goal (``run`` needs one of ``radius`` and ``time``)."""
    if config.radius is None and config.time is None:
        raise ValueError("give exactly one of radius and time")


# ---------------------------------------------------------------------- the run loop


PROGRESS_SECONDS = 60.0
"""With ``progress`` and stderr not a terminal (a batch job's log), a run or an ``advance``
logs one line of progress at most this often (wall seconds)."""


def goal_of(config, radius: float | None, time: float | None) -> tuple:
    """The goal of ``advance`` and ``done``: the given one, else the configuration's (checked).

    ValueError when neither is given nor configured, or a goal is not a positive number.
    """
    if radius is None and time is None:
        radius, time = config.radius, config.time
        if radius is None and time is None:
            raise ValueError("give radius or time (or set one in the Config)")
    check_goal(radius, time)
    return radius, time


class ProgressBar:
    """Progress toward a goal: a tqdm bar of the radius (or the time) on a terminal.

    When asked and stderr is not a terminal (a batch job's log): no bar (no carriage returns in
    the log) but one INFO line every PROGRESS_SECONDS: where the run stands, its size (the step
    record's ``size``, e.g. "2,048 nodes"), step, dt and the wall seconds so far.
    """

    def __init__(self, label: str, radius: float | None, time: float | None, progress: bool):
        from tqdm import tqdm

        self.by_radius = radius is not None
        self.goal = radius if self.by_radius else time
        self.bar = tqdm(total=self.goal, disable=not (progress and sys.stderr.isatty()),
                        unit="R" if self.by_radius else "t", desc=label, leave=False)
        self.log_lines = progress and self.bar.disable
        self.started = self.last = _now()

    def show(self, record) -> None:
        """The radius or the time after the step of ``record``."""
        if self.log_lines:
            now = _now()
            if now - self.last >= PROGRESS_SECONDS:
                self.last = now
                where = (f"radius {record.radius:.2f} of {self.goal:g}, t = {record.t:.4f}"
                         if self.by_radius else
                         f"t = {record.t:.4f} of {self.goal:g}, radius {record.radius:.2f}")
                log.info("%s, %s, step %d, dt %.3g, %.0f s", where, record.size, record.step,
                         record.dt, now - self.started)
        if not self.bar.disable:
            self.bar.n = min(self.goal, record.radius if self.by_radius else record.t)
            self.bar.refresh()

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, *exc) -> None:
        self.bar.close()


def advance(sim, radius: float | None, time: float | None, progress: bool):
    """Step ``sim`` until its goal (:func:`goal_of`); the engines' ``Simulation.advance``.

    The engine's simulation supplies ``config``, ``state``, ``done(radius, time)``,
    ``step_toward(radius, time)`` (one step, not past the goal) and
    ``check_budget(radius, time)`` (a goal beyond the machine refused before any step).
    """
    radius, time = goal_of(sim.config, radius, time)
    sim.check_budget(radius, time)
    with ProgressBar(sim.label, radius, time, progress) as bar:
        while not sim.done(radius, time):
            bar.show(sim.step_toward(radius, time))
    return sim.state


def drive(sim, stop: StopRequest, max_steps: int | None = None,
          started: float | None = None, progress: bool = False) -> None:
    """The run loop of both engines' ``run``: step ``sim`` to its configuration's goal.

    Steps until the goal, a stop request (``stop``: a signal came), ``max_steps`` steps of this
    call, or ``config.max_hours`` (:class:`WallLimit`, from ``started``); with an output folder
    a checkpoint (``sim.save()``, history.csv first) every ``config.checkpoint_seconds`` of wall
    before the goal and when it stops (``finished`` False; ``paused`` True at max_hours), and
    the final files at the end (``sim.finish()``, the engine's). Besides :func:`advance`'s, the
    simulation supplies ``output``, ``save()``, ``finish()``, ``finished`` and ``paused``.
    """
    config = sim.config
    goal = {"radius": config.radius, "time": config.time}
    limit = WallLimit(config.max_hours, started)
    last_checkpoint = _now()
    steps = 0
    with ProgressBar(sim.label, progress=progress, **goal) as bar:
        while not sim.done(**goal):
            bar.show(sim.step_toward(**goal))
            limit.stepped()
            steps += 1
            done = sim.done(**goal)
            asked = stop.signum is not None or (max_steps is not None and steps >= max_steps)
            paused = not done and not asked and limit.due
            due = not done and _now() - last_checkpoint >= config.checkpoint_seconds
            if sim.output is not None and (asked or paused or due):
                start = _now()
                sim.save()
                last_checkpoint = _now()
                limit.saved(last_checkpoint - start)
            if (asked or paused) and not done:
                sim.finished, sim.paused = False, paused
                break
    if sim.output is not None:
        sim.finish()
