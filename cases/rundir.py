"""Run folders: where a run may write, what it may remove, what it records.

A run of ``colony continuum|particles --out DIR`` writes into ``DIR.partial/`` and renames it
to ``DIR`` when everything is written (:func:`publish`), so ``DIR`` is never half-written.
Every run folder holds ``run.json``, the run's provenance (:func:`record`), which also marks
the folder as written by this tool:

- ``engine``, ``config`` (resolved), ``package_version``, ``git_commit`` (when the sources are a
  git checkout), ``seed`` (particles), ``status`` (running, paused, stopped, failed, finished),
  ``error``;
- ``sessions``: one entry per command that worked on the run (a stopped run resumed is a second
  session): ``command``, ``start``, ``end`` (UTC, ISO 8601), ``wall_seconds``, ``cpu_seconds``,
  ``peak_memory_mb`` (the process's peak resident size), ``status``, ``error``,
  ``engine_sources`` (the engine's version, :func:`engine_sources`) and ``git_commit``.

Safety rules (:func:`check_target`, :func:`prepare_stage`), checked before any work:

- ``DIR`` may not be ``/``, the home folder, the working directory or one of its parents, nor a
  file; its parent must be writable;
- ``--overwrite`` removes only a folder this tool wrote: its ``run.json`` lists every entry
  (or, for folders written before ``run.json`` existed, it holds ``config.json`` and only names
  this tool writes), and it is removed only after the new run is complete;
- a ``DIR.partial/`` left by a stopped run is resumed only by a run of the same engine and
  configuration (execution settings such as ``threads`` may differ); another configuration is
  refused with a message saying how to start afresh (``--overwrite`` clears it); a stage that
  holds no checkpoint is cleared, so the published folder holds exactly what one run wrote;
  a checkpoint is resumed only by the version of the engine that wrote it (its sources'
  digest, :func:`engine_sources`), or by another when asked (``--other-engine``);
- the file system must have :data:`MIN_FREE_BYTES` free; a run that fills it ends with
  "no space left on DIR" (:func:`no_space_message`), its last checkpoint intact;
- one writer at a time: a run holds an exclusive ``flock`` on its stage folder ``DIR.partial``
  (the folder itself, so the lock moves with it when it is published) from before it looks
  into it until it is published (:func:`stage`); ``colony plot|movie`` hold the lock of the
  folder they write into (:func:`hold`). A second writer is refused with one line naming the
  holder's process (``run.json``); the operating system releases the lock when its holder
  dies, so a lock never goes stale, and ``colony info`` tells a dead run from a live one by it
  (:func:`is_held`);
- no links: colony never reads a checkpoint from, writes into or deletes through a symbolic
  link inside a run folder (:func:`links_inside`), and ``DIR`` itself may not be a link (one
  line naming it); a folder is cleared without following links (:func:`_clear`);
- the names ``DIR.partial`` and ``DIR.replaced`` must fit the file system's name limit, and
  the stage is created before any work, so an unusable ``DIR`` fails before the run, not
  after it.
"""

from __future__ import annotations

import errno
import fcntl
import hashlib
import importlib
import json
import os
import re
import resource
import secrets
import shutil
import signal
import subprocess
import sys
import threading
import time
from contextlib import ExitStack, contextmanager
from dataclasses import asdict
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path

RECORD = "run.json"
#: Entries either engine (or ``cases.cli``) writes into a run folder; temporary files included.
OUTPUT_NAMES = frozenset({
    RECORD, "config.json", "history.csv", "profile.csv", "boundary.csv", "rings.csv",
    "fields.pvd", "fields", "mean_length.png", "particles.csv", "trajectory.gsd", "colony.png",
    "checkpoint.npz", "checkpoint.prev.npz", "radius.png", "profile.png", "movie.mp4",
    "handoff.json", "outline.csv",
})
#: Checkpoint files of either engine in a stage (a stopped run resumes from them; from the
#: previous one when the last is damaged, or its process died while replacing it).
CHECKPOINTS = ("checkpoint.npz", "checkpoint.prev.npz")
#: Suffixes of the temporary files a writer replaces atomically (``x.tmp``, ``x.tmp.npz``).
TEMPORARY_SUFFIXES = (".tmp", ".tmp.npz", ".gsd.tmp")
#: A run refuses to start with less free space than this on the output's file system.
MIN_FREE_BYTES = 32 * 2**20
#: Configuration fields that do not change a run's result (a stopped run resumes under others).
EXECUTION_FIELDS = ("threads", "checkpoint_seconds", "max_hours")


class RunFolderError(ValueError):
    """An output folder that may not be used or replaced (one-line message)."""


class FolderInUseError(RunFolderError):
    """A run folder another process holds (:func:`hold`)."""


#: Signals that stop a run like Ctrl-C: checkpoint, status stopped, exit 128 + signal number
#: (SIGHUP: a closed terminal or ssh session).
STOP_SIGNALS = (signal.SIGTERM, signal.SIGHUP)


@contextmanager
def stop_signals_exit():
    """In the main thread, STOP_SIGNALS raise SystemExit(128 + signal), as Ctrl-C does.

    So ``finally`` blocks run (a run's record, a sweep's cluster); elsewhere nothing is
    installed. The previous handlers come back on leaving.
    """

    def stop(signum, frame):
        raise SystemExit(128 + signum)

    previous = ({sig: signal.signal(sig, stop) for sig in STOP_SIGNALS}
                if threading.current_thread() is threading.main_thread() else {})
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


PAUSED_STATUS = 75
"""Exit status of a run paused at its ``--max-hours`` (EX_TEMPFAIL of sysexits.h: not done,
not failed; the same command resumes it)."""


class RunPaused(Exception):  # noqa: N818 (not an error: a pause)
    """A run that paused at its wall-clock limit (``max_hours``) with a checkpoint written.

    One line: where it stands and that the same command resumes it.
    """


#: Longest suffix colony appends to ``DIR`` (``DIR.replaced``; ``DIR.partial`` is shorter).
LONGEST_SUFFIX = ".replaced"
#: Suffixes of the folders colony keeps beside ``DIR``: its stage and the run it replaces. No
#: ``--out`` may end in one (a later run of ``DIR`` would take that folder for its own).
OWN_SUFFIXES = (".partial", LONGEST_SUFFIX)


def _written_by_us(name: str) -> bool:
    return name in OUTPUT_NAMES or name.endswith(TEMPORARY_SUFFIXES)


def _replacing(name: str) -> bool:
    """A temporary file of :func:`replace_file` (``.NAME.PID.HEX.tmp``, NAME one of ours)."""
    match = re.fullmatch(r"\.(.+)\.[0-9]+\.[0-9a-f]{8}\.tmp", name)
    return match is not None and match[1] in OUTPUT_NAMES


def _frame_written_by_us(name: str) -> bool:
    """A name of ``fields/``: a frame (``.vtu``) or a frame being written (``.vtu.tmp``)."""
    return name.endswith((".vtu", ".vtu.tmp"))


def read_record(folder: Path) -> dict | None:
    """The ``run.json`` of ``folder``, or None when it has none (or it is not a JSON object)."""
    record = _load_record(folder)
    return record if isinstance(record, dict) else None


class _Unparsable:
    """A ``run.json`` that is not JSON (:func:`_load_record`); ``why`` in a few words."""

    def __init__(self, why: str):
        self.why = why


def _load_record(folder: Path):
    """The parsed ``run.json`` of ``folder`` whatever its shape; None when it cannot be read.

    A file that reads but does not parse (not text, not JSON, nested too deeply for the
    parser: RecursionError, which is no ValueError) is an :class:`_Unparsable`, which
    :func:`_record_shape` reports as damage.
    """
    try:
        text = (Path(folder) / RECORD).read_bytes()
    except OSError:
        return None
    try:
        return json.loads(text.decode())
    except UnicodeDecodeError:
        return _Unparsable("not UTF-8 text")
    except json.JSONDecodeError as err:
        return _Unparsable(f"not JSON ({err.msg} at line {err.lineno} column {err.colno})")
    except RecursionError:
        return _Unparsable("JSON nested too deeply to read")
    except ValueError as err:  # any other refusal of the parser, in one line
        return _Unparsable(f"not JSON ({' '.join(str(err).split())})")


def foreign_entries(folder: Path, follow: bool = True) -> list[str]:
    """Entries of ``folder`` this tool did not write (empty: the folder is recognisably ours).

    Ours: ``run.json`` lists every entry (published runs), or every entry has a name this
    tool writes and ``run.json`` or ``config.json`` is present (stages, older runs).
    ``follow=False``: a link named ``fields`` is not looked into.
    """
    folder = Path(folder)
    names = sorted(p.name for p in folder.iterdir())
    record = read_record(folder)
    listed = set(record["files"]) | {RECORD} if record and "files" in record else None
    if listed is not None:  # plus what ``colony plot|movie`` add later
        return [n for n in names if n not in listed and not _written_by_us(n)]
    if record is None and "config.json" not in names:  # ours only if all are our temporaries
        return [] if all(_replacing(n) for n in names) else names
    foreign = [n for n in names if not _written_by_us(n)]
    fields = folder / "fields"
    if fields.is_dir() and (follow or not fields.is_symlink()):
        foreign += [f"fields/{p.name}" for p in sorted(fields.iterdir())
                    if not _frame_written_by_us(p.name)]
    return foreign


def _protected(path: Path) -> str | None:
    """Why ``path`` (resolved) may never be a run's output folder, or None."""
    cwd = Path.cwd().resolve()
    if path == Path(path.anchor):
        return "it is the root folder"
    if path == Path.home().resolve():
        return "it is the home folder"
    if cwd == path or path in cwd.parents:
        return "it is the working directory or one of its parents"
    return None


def check_target(out: Path, overwrite: bool) -> Path:
    """Check ``out`` as a run's output folder before any work; returns it resolved.

    Raises RunFolderError when ``out`` is protected (:func:`_protected`), a file, exists
    without ``overwrite``, or exists with ``overwrite`` but holds entries this tool did not
    write; or when its parent cannot be written.
    """
    target = absolute(out)
    target = target.parent.resolve() / target.name if target.name else target.resolve()
    _check_name_length(out, target)  # first: a longer name cannot even be looked up
    _check_own_suffix(out, target)
    if target.is_symlink():
        raise RunFolderError(
            f"refusing --out {out}: it is a symbolic link (to {os.readlink(target)}); colony "
            "never writes or deletes through links: give the folder itself")
    why = _protected(target.resolve() if target.exists() else target)
    if why:
        raise RunFolderError(f"refusing --out {out}: {why}; give a new folder for the run")
    if target.exists() and not target.is_dir():
        raise RunFolderError(f"--out {out} is a file, not a folder")
    if target.exists():
        if not overwrite:
            raise RunFolderError(f"output folder {out} exists (use --overwrite to replace it)")
        foreign = foreign_entries(target)
        if foreign:
            raise RunFolderError(
                f"refusing --overwrite of {out}: it holds {_names(foreign)}, which colony did "
                "not write; move them away or choose another --out")
    parent = _existing(target.parent)
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        raise RunFolderError(f"cannot write the output folder {out}: {parent} is not writable")
    return target


def absolute(path: str | os.PathLike) -> Path:
    """``path`` made absolute with its ``..`` taken lexically (``a/x/../b`` is ``a/b``).

    Every folder colony creates is created from this form, so ``a/x/..`` never leaves a stray
    ``a/x`` behind.
    """
    return Path(os.path.abspath(path))


def _check_own_suffix(out, target: Path, flag: str = "--out") -> None:
    """Refuse a name ending in one of :data:`OWN_SUFFIXES` (one line)."""
    if target.name.endswith(OWN_SUFFIXES):
        raise RunFolderError(
            f"refusing {flag} {out}: names ending in {' or '.join(OWN_SUFFIXES)} are colony's "
            "own (a run's stage, a run being replaced); give another name")


def check_output(out: str | os.PathLike, source: str | os.PathLike | None = None,
                 flag: str = "--out") -> Path:
    """The one rule for every folder a command writes into besides a run's own ``--out``.

    Pictures, a movie, a fit, a case's folder or its ``--runs``: returns ``out`` with its
    ``..`` taken lexically (``os.path.normpath``: relative stays relative). Refused in one
    line, before any work: a link, a file, a name ending in one of :data:`OWN_SUFFIXES`, a
    protected folder (:func:`_protected`: the root, the home
    folder, the working directory or one of its parents), and a folder that is, or lies inside,
    a run folder (one holding ``run.json``) other than ``source``, the run being drawn.
    """
    target = absolute(out)
    source = None if source is None else Path(source).resolve()
    if target.is_symlink():
        raise RunFolderError(f"refusing {flag} {out}: it is a symbolic link; colony never writes "
                             "through links: give the folder itself")
    if target.exists() and not target.is_dir():
        raise RunFolderError(f"{flag} {out} is a file, not a folder")
    if is_held(target):  # a run writing there: say so first
        check_source(target)
    resolved = target.resolve()
    if resolved != source:
        why = _protected(resolved)
        if why:
            raise RunFolderError(f"refusing {flag} {out}: {why}; give a folder of its own")
        _check_own_suffix(out, target, flag)
    for folder in (resolved, *resolved.parents):
        if folder != source and (folder / RECORD).is_file():
            check_source(folder)  # a run writing there: say so first
            own = "" if source is None else f" (or none: {source})"
            which = "a run" if source is None else "another run"
            raise RunFolderError(f"refusing to write into {folder}: it is the folder of "
                                 f"{which} ({flag} {out}); give a folder of its own{own}")
    return Path(os.path.normpath(out))


def _check_name_length(out, target: Path) -> None:
    """Refuse a ``DIR`` whose ``DIR.replaced`` would not fit the file system's name limit."""
    parent = _existing(target.parent)
    try:
        limit = os.pathconf(parent, "PC_NAME_MAX")
    except (OSError, ValueError):
        limit = 255
    size = len(os.fsencode(target.name + LONGEST_SUFFIX))
    if size > limit:
        raise RunFolderError(
            f"--out name too long: {size - len(LONGEST_SUFFIX)} bytes, at most "
            f"{limit - len(LONGEST_SUFFIX)} (the file system allows {limit}, colony adds "
            f"{LONGEST_SUFFIX!r}); give a shorter name")


def links_inside(folder: Path) -> list[str]:
    """Symbolic links in ``folder`` and its sub-folders (relative names), not followed."""
    found = []
    with os.scandir(folder) as entries:
        for entry in sorted(entries, key=lambda e: e.name):
            if entry.is_symlink():
                found.append(entry.name)
            elif entry.is_dir(follow_symlinks=False):
                found += [f"{entry.name}/{name}" for name in links_inside(Path(entry.path))]
    return found


def check_no_links(folder: Path) -> None:
    """Refuse (one line naming the entry) a run folder that holds a symbolic link.

    The line offers --overwrite only when every link has a name colony writes (--overwrite
    removes those links, not what they point to, and refuses entries colony did not write).
    """
    links = links_inside(folder)
    if links:
        more = f" (and {len(links) - 1} more)" if len(links) > 1 else ""
        ours = all(_written_by_us(name) or (name.startswith("fields/")
                                            and _frame_written_by_us(name))
                   for name in links)
        remedy = ("remove it, or give --overwrite to start afresh (removes the links, not what "
                  "they point to)" if ours else
                  "colony did not write it: remove it or choose another --out")
        raise RunFolderError(
            f"{Path(folder) / links[0]} is a symbolic link{more}; colony never reads, writes or "
            f"deletes through links in a run folder: {remedy}")


def _names(names: list[str]) -> str:
    shown = ", ".join(names[:3])
    return shown + (f" and {len(names) - 3} more" if len(names) > 3 else "")


EMPTY = ([], (), {}, None)
"""Values of a configuration field that equal the field's absence (:func:`config_differences`)."""


def config_differences(saved: dict, config: dict, ignore=()) -> list[str]:
    """Names of the configuration fields whose values differ (execution fields ignored).

    A field the saved record lacks whose value now is empty ([], {}, None) is the same: a field
    added to a Config later with an empty default (e.g. the continuum's ``strains``) changes
    nothing in the runs recorded before it.
    """
    saved, config = (json.loads(json.dumps(c)) for c in (saved, config))  # tuples as lists
    keys = (set(saved) | set(config)) - set(EXECUTION_FIELDS) - set(ignore)
    return sorted(k for k in keys
                  if saved.get(k) != config.get(k) and (k in saved or config.get(k) not in EMPTY))


def _clear(folder: Path, keep_folder: bool = False) -> None:
    """Remove a folder whose every entry this tool wrote (checked by the caller).

    Links are removed, never followed (a link as ``folder`` is removed itself);
    ``keep_folder``: empty it but keep the folder (a stage whose lock is held).
    """
    if folder.is_symlink():
        folder.unlink()
        return
    for entry in folder.iterdir():
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry)
        else:
            entry.unlink()
    if not keep_folder:
        folder.rmdir()


def partial_of(out: Path) -> Path:
    """The staging folder ``DIR.partial`` of the output folder ``DIR``."""
    return out.with_name(out.name + ".partial")


@contextmanager
def stage(out: Path, overwrite: bool, engine: str, config, resumable=(), step_policy=(),
          other_engine: bool = False):
    """Check ``out``, then hold its staging folder ``out.partial`` (created or reused).

    Yields the stage, locked (:func:`hold`) from before anything in it is read until the body
    ends (publish inside the body). A stage left by a stopped run is reused when it holds a
    checkpoint of the same engine and configuration (``resumable``: names of checkpoint files;
    ``step_policy``: fields that may differ, the engine checks them); a stage of another engine
    is refused, and one of another configuration when it holds a checkpoint, unless
    ``overwrite``, which clears it; any other stage of this engine without a checkpoint is
    cleared. A stage whose checkpoint another version of the engine wrote (:func:`engine_sources`
    differs, or was not recorded) is refused unless ``other_engine``. A stage held by another
    process, or holding links or entries this tool did not write, is refused. Nothing is
    removed that this tool did not write; a stage created here and refused is removed again.
    """
    out = check_target(out, overwrite)
    partial = partial_of(out)
    if partial.is_symlink():
        raise RunFolderError(f"{partial} is a symbolic link; colony never writes through links: "
                             "remove it or choose another --out")
    if partial.exists() and not partial.is_dir():
        raise RunFolderError(f"{partial} is a file; move it away or choose another --out")
    created = not partial.exists()
    if created:
        check_free_space(_existing(partial))
        try:
            partial.mkdir(parents=True)
        except FileExistsError:  # another run created it a moment ago: its lock decides
            created = False
        except OSError as err:
            raise RunFolderError(f"cannot create {partial}: {err.strerror}") from None
    with ExitStack() as held:
        try:
            held.enter_context(hold(partial))  # a stage another run holds is never removed
        except RunFolderError:
            if not os.path.lexists(partial):  # another run published it just now: say so
                check_target(out, overwrite)
            raise
        try:
            _check_stage(partial, overwrite, engine, config, resumable, step_policy,
                         other_engine)
            check_free_space(partial)
        except BaseException:
            if created and not any(partial.iterdir()):
                partial.rmdir()  # still held: no other run can have taken it up
            raise
        yield partial


def _check_stage(partial: Path, overwrite: bool, engine: str, config, resumable,  # noqa: PLR0913
                 step_policy, other_engine: bool) -> None:
    """Check a held stage (:func:`stage`) and clear it unless it is this run's to resume."""
    if not overwrite:
        check_no_links(partial)
    foreign = foreign_entries(partial, follow=False)
    if foreign:
        raise RunFolderError(
            f"{partial} holds {_names(foreign)}, which colony did not write; move them away or "
            "choose another --out")
    if "files" in (read_record(partial) or {}) and not overwrite:  # only publish lists them
        raise RunFolderError(
            f"{partial} is a finished run's folder, not a stage; move it away, or give "
            "--overwrite to start this run afresh (removes it)")
    saved_engine, saved = _stage_identity(partial)
    checkpoint = any((partial / name).is_file() for name in resumable)
    if saved_engine is not None and not overwrite:
        if saved_engine != engine:
            raise RunFolderError(
                f"{partial} holds a stopped {saved_engine} run; give its command to resume it, "
                "or --overwrite to start this run afresh (removes it)")
        diff = config_differences(saved, asdict(config), ignore=step_policy)
        if diff and checkpoint:
            hint = (" or --change-step-policy to resume it with the new step"
                    if engine == "particles" and set(diff) <= {"dt", "step_control"} else
                    " (its goal is part of it: resume it to that goal, then grow further "
                    "from its final state, --init DIR/particles.csv for particles)"
                    if set(diff) <= {"radius", "time"} else "")
            raise RunFolderError(
                f"{partial} holds a stopped run whose configuration differs in "
                f"{', '.join(diff)}; give its command to resume it{hint}, or --overwrite to "
                "start afresh (removes it)")
        if checkpoint and not other_engine:
            _check_engine_version(partial, engine)
    if overwrite or not checkpoint or saved_engine is None:
        _clear(partial, keep_folder=True)


@contextmanager
def hold(folder: Path, wait: bool = False):
    """Hold the exclusive lock of the run folder ``folder`` while the body runs.

    The lock is a ``flock`` on the folder itself (opened without following a link), so it
    follows the folder when it is renamed and ends with its holder, however that ends.
    Raises :class:`FolderInUseError` (one line naming the holder, :func:`holder`) when another
    process (or another open of this one) holds it, unless ``wait``.
    """
    try:
        fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW | os.O_CLOEXEC)
    except OSError as err:
        why = "a symbolic link" if err.errno == errno.ELOOP else err.strerror
        raise RunFolderError(f"cannot use the run folder {folder}: {why}") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX if wait else fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise FolderInUseError(f"{folder} is in use by {holder(folder)}; wait for it to end or "
                              "stop it (a stopped run resumes with its command)") from None
        if not _same_folder(fd, folder):  # removed or replaced between the open and the lock
            raise FolderInUseError(f"{folder} is in use by another run, which took it up just now; "
                                   "wait for it to end or stop it")
        yield folder
    finally:
        os.close(fd)


def _same_folder(fd: int, folder: Path) -> bool:
    """Whether the open folder ``fd`` is still the one at the path ``folder`` (same inode)."""
    try:
        here = os.lstat(folder)
    except OSError:
        return False
    there = os.fstat(fd)
    return (here.st_dev, here.st_ino) == (there.st_dev, there.st_ino)


def check_source(folder: Path) -> None:
    """Refuse to read a run folder that a run is still writing, or whose run.json is damaged.

    What ``colony plot|movie`` and ``--from-particles`` check first (one line naming the
    folder): a folder held by a run (:func:`is_held`; a stopped ``DIR.partial`` is not held)
    and a ``run.json`` of the wrong shape (:func:`_record_shape`).
    """
    folder = Path(folder)
    if is_held(folder):
        raise FolderInUseError(f"{folder} is in use by {holder(folder)}; wait for it to end or "
                               "stop it (a stopped run resumes with its command)")
    run = _load_record(folder) if (folder / RECORD).is_file() else None
    if run is not None:
        shape = _record_shape(run)
        if shape:
            raise RunFolderError(f"{folder / RECORD} is damaged: {shape}")


def is_held(folder: Path) -> bool:
    """Whether a process holds the lock of ``folder`` (:func:`hold`); False if unreadable."""
    try:
        fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW | os.O_CLOEXEC)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    finally:
        os.close(fd)
    return False


def holder(folder: Path) -> str:
    """Who holds ``folder``: "process PID since START" from its run.json, as far as known."""
    sessions = (read_record(folder) or {}).get("sessions")
    last = sessions[-1] if isinstance(sessions, list) and sessions else None
    if isinstance(last, dict) and last.get("pid") and last.get("status") == "running":
        return f"process {last['pid']} since {last.get('start')}"
    return "another process"


def _existing(path: Path) -> Path:
    """``path`` or its nearest existing parent."""
    while not path.exists():
        path = path.parent
    return path


def engine_sources(engine: str) -> str:
    """The version of an engine's code: sha256 (16 hex digits) of its package's Python sources.

    Over the files ``*.py`` of the package ``engine`` (``continuum`` or ``particles``), sorted
    by their names relative to it, each name and its bytes: any edit of the engine changes it,
    wherever the package is installed.
    """
    root = Path(importlib.import_module(engine).__file__).parent
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()[:16]


def _check_engine_version(partial: Path, engine: str) -> None:
    """Refuse to resume a checkpoint that another version of the engine wrote.

    The version is the ``engine_sources`` of the stage's last session (:func:`record`);
    a stage recorded before versions were, or by another version, is refused in one line
    naming both and the commit that wrote it. A stage without ``run.json`` (the engine's own
    ``run(config, out)`` into it) holds no record to check.
    """
    record = read_record(partial)
    if record is None:
        return
    sessions = [s for s in record.get("sessions", []) if isinstance(s, dict)]
    saved = sessions[-1].get("engine_sources") if sessions else None
    now = engine_sources(engine)
    if saved == now:
        return
    made = (f"engine sources {saved}" if saved else "an engine version not recorded") + (
        f", git {record['git_commit']}" if record.get("git_commit") else "")
    raise RunFolderError(
        f"{partial} holds a checkpoint of another version of the {engine} engine ({made}; "
        f"this one: {now}); resume it with that version (a git worktree of its commit), or "
        "give --other-engine to resume it with this one")


def _stage_identity(folder: Path) -> tuple[str | None, dict]:
    """(engine, configuration) of a stage from its run.json or config.json; (None, {})."""
    record = read_record(folder)
    if record and "engine" in record:
        engine, config = record["engine"], record.get("config", {})
    else:
        try:
            config = json.loads((folder / "config.json").read_text())
        except (OSError, ValueError):
            return None, {}
        config.pop("step_policy_changes", None)
        engine = "particles" if "solver" in config else "continuum"
    if engine == "particles":
        from particles.config import upgrade

        config = upgrade(config)
    return engine, config


def publish(partial: Path) -> Path:
    """Move the finished stage ``DIR.partial`` to ``DIR``, which it returns.

    A ``DIR`` there is checked again (it may have changed during the run: :func:`check_target`
    with overwrite), its lock awaited (a ``colony plot`` writing into it) and it is removed
    only afterwards. ``run.json`` gets the list of published entries (what a later
    ``--overwrite`` may remove).
    """
    out = partial.with_name(partial.name.removesuffix(".partial"))
    if out.exists() or out.is_symlink():  # still only what colony wrote, right before it goes
        check_target(out, overwrite=True)
    record = read_record(partial) or {}
    record["files"] = sorted(p.name for p in partial.iterdir() if p.name != RECORD)
    write_record(partial, record)
    if not out.exists():
        partial.rename(out)
        return out
    old = out.with_name(out.name + LONGEST_SUFFIX)
    with hold(out, wait=True):
        if old.exists() or old.is_symlink():
            if foreign_entries(old, follow=False):
                raise RunFolderError(f"{old} holds entries colony did not write; move it away "
                                     f"(the finished run is kept in {partial})")
            _clear(old)
        out.rename(old)
        partial.rename(out)
        _clear(old)
    return out


def check_free_space(folder: Path, need: int = MIN_FREE_BYTES) -> None:
    """Refuse (OSError ENOSPC, one line) when ``folder``'s file system has less than ``need``."""
    free = shutil.disk_usage(folder).free
    if free < need:
        raise OSError(errno.ENOSPC, no_space_message(folder, free, need))


def no_space_message(folder: Path, free: int | None = None, need: int | None = None) -> str:
    """The one-line message of a full file system."""
    if free is None:
        free = shutil.disk_usage(folder).free
    text = f"no space left on {folder} ({free / 2**20:.1f} MB free"
    if need is not None:
        text += f", a run needs at least {need / 2**20:.0f} MB"
    return text + ")"


def is_no_space(err: BaseException, folder: Path | None) -> bool:
    """Whether ``err`` comes from a full file system (ENOSPC, or a writer's vaguer error)."""
    if isinstance(err, OSError) and err.errno in (errno.ENOSPC, errno.EDQUOT):
        return True
    if folder is None:
        return False
    try:
        return shutil.disk_usage(folder).free < 2**20
    except OSError:
        return False


# --------------------------------------------------------------------------- provenance


def git_commit() -> str | None:
    """The git commit of the sources (``+dirty`` when they differ from it), or None.

    From the git checkout the sources are in, else the one recorded when the package was built
    from a checkout (``cases/_build.json``, written by setup.py).
    """
    root = Path(__file__).resolve().parent.parent
    if not (root / ".git").exists():
        try:
            return json.loads((Path(__file__).parent / "_build.json").read_text())["git_commit"]
        except (OSError, ValueError, KeyError, TypeError):
            return None
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True,
                              text=True, timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--",
                                "continuum", "particles", "cases"], capture_output=True,
                               text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return head + ("+dirty" if dirty else "")


def package_version() -> str:
    """The installed version of colony-mechanics ("unknown" in a checkout not installed)."""
    try:
        return metadata.version("colony-mechanics")
    except metadata.PackageNotFoundError:
        return "unknown"


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def replace_file(folder: Path, name: str, write) -> Path:
    """Write ``folder/name`` atomically: ``write(fh)`` into a new temporary file, os.replace.

    The temporary file is created exclusively (``"xb"``: never an existing file or link, the
    permissions of the umask) in ``folder``; os.replace then replaces ``folder/name``, a link
    there included, rather than writing through it.
    """
    tmp = folder / f".{name}.{os.getpid()}.{secrets.token_hex(4)}.tmp"
    try:
        with open(tmp, "xb") as fh:
            write(fh)
        os.replace(tmp, folder / name)
    finally:
        if os.path.lexists(tmp):
            os.unlink(tmp)
    return folder / name



def write_record(folder: Path, record: dict) -> None:
    """Write ``run.json`` atomically (:func:`replace_file`)."""
    text = (json.dumps(record, indent=2, default=str) + "\n").encode()
    replace_file(Path(folder), RECORD, lambda fh: fh.write(text))


def _cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


@contextmanager
def record(folder: Path, engine: str, config, argv: list[str] | None = None):
    """Record a session of the run in ``folder/run.json`` while the body runs.

    The status is ``running`` during the body, then ``finished``, ``paused`` (at ``max_hours``,
    :class:`RunPaused`), ``stopped`` (Ctrl-C, SIGTERM) or ``failed`` with the error's first
    line. A record that cannot be written at the
    end (e.g. a full disk) is left as it was.
    """
    folder = Path(folder)
    previous = read_record(folder) or {}
    config_dict = asdict(config)
    run = {
        "engine": engine, "config": config_dict, "package_version": package_version(),
        "git_commit": git_commit(), "seed": config_dict.get("seed"), "status": "running",
        "error": None, "sessions": previous.get("sessions", []),
    }
    session = {"command": list(sys.argv if argv is None else argv), "start": _now(),
               "pid": os.getpid(), "status": "running", "engine_sources": engine_sources(engine),
               "git_commit": run["git_commit"]}
    run["sessions"] = run["sessions"] + [session]
    write_record(folder, run)
    t0, cpu0 = time.monotonic(), _cpu_seconds()

    def close(status: str, error: str | None) -> None:
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # KiB on Linux
        session.update(end=_now(), wall_seconds=round(time.monotonic() - t0, 3),
                       cpu_seconds=round(_cpu_seconds() - cpu0, 3),
                       peak_memory_mb=round(peak, 1), status=status, error=error)
        run.update(status=status, error=error)
        try:
            write_record(folder, run)
        except OSError:
            pass

    try:
        yield run
    except (KeyboardInterrupt, SystemExit) as err:
        close("stopped", f"stopped by {_signal_name(err)}")
        raise
    except RunPaused:
        close("paused", None)
        raise
    except BaseException as err:
        close("failed", (str(err).strip().splitlines() or [type(err).__name__])[0])
        raise
    close("finished", None)


def _signal_name(err: BaseException) -> str:
    """The signal behind a KeyboardInterrupt (SIGINT) or ``SystemExit(128 + signum)``."""
    if isinstance(err, KeyboardInterrupt):
        return "SIGINT"
    code = getattr(err, "code", None)
    if isinstance(code, int) and code > 128:
        try:
            return signal.Signals(code - 128).name
        except ValueError:
            pass
    return "SIGTERM"


def describe(folder: Path) -> str:
    """Human-readable summary of a run folder's ``run.json`` (``colony info DIR``).

    An unfinished run also says where it stands and the wall it will take to its goal
    (:func:`cases.standing.standing`). A run whose record says ``running`` but whose folder no
    process holds (:func:`is_held`)
    ended without a word (killed, out of memory): it is reported as such.
    """
    folder = Path(folder)
    if not folder.is_dir() and partial_of(folder).is_dir():
        folder = partial_of(folder)
    if not folder.is_dir():
        raise RunFolderError(f"no run folder {folder}")
    run = _load_record(folder)
    if run is None:
        raise RunFolderError(f"{folder} has no readable {RECORD}: not a run folder of colony")
    shape = _record_shape(run)
    if shape:
        raise RunFolderError(f"{folder / RECORD} is damaged: {shape}")
    status = f"{run.get('status')}" + (f": {run['error']}" if run.get("error") else "")
    if run.get("status") == "running" and not is_held(folder):
        resume = ("resume it from the last checkpoint" if any(
            (folder / name).is_file() for name in CHECKPOINTS) else
                  "start it afresh (it wrote no checkpoint)")
        status = ("died: its process ended without a word (killed, out of memory); give its "
                  f"command to {resume}")
    lines = [f"run folder      {folder}",
             f"engine          {run.get('engine')}",
             f"status          {status}",
             f"package         colony-mechanics {run.get('package_version')}, git "
             f"{run.get('git_commit') or 'unknown'}"]
    config = run.get("config", {})
    lines.append("configuration   " + ", ".join(f"{k}={v}" for k, v in config.items()))
    for i, s in enumerate(run.get("sessions", []), 1):
        lines.append(
            f"session {i}       {s.get('start')} .. {s.get('end', '-')}, {s.get('status')}, wall "
            f"{s.get('wall_seconds', '-')} s, cpu {s.get('cpu_seconds', '-')} s, peak memory "
            f"{s.get('peak_memory_mb', '-')} MB")
        lines.append(f"  command       {' '.join(map(str, s.get('command', [])))}")
    last = _last_history_row(folder)
    if last:
        lines.append("last step       " + ", ".join(f"{k}={v}" for k, v in last.items()))
    from cases.standing import standing

    return "\n".join(lines + standing(folder, run))


def _record_shape(run) -> str | None:
    """What is wrong with the shape of a ``run.json`` (None: an object as :func:`record`)."""
    if isinstance(run, _Unparsable):
        return run.why
    if not isinstance(run, dict):
        return f"expected a JSON object, found {type(run).__name__}"
    if not isinstance(run.get("config", {}), dict):
        return "'config' is not an object"
    sessions = run.get("sessions", [])
    if not isinstance(sessions, list) or not all(isinstance(s, dict) for s in sessions):
        return "'sessions' is not a list of objects"
    if not all(isinstance(s.get("command", []), list) for s in sessions):
        return "a session's 'command' is not a list"
    return None


def _last_history_row(folder: Path) -> dict:
    path = folder / "history.csv"
    if not path.is_file():
        return {}
    lines = path.read_text().splitlines()
    if len(lines) < 2:
        return {}
    keys, values = lines[0].split(","), lines[-1].split(",")
    wanted = ("t", "radius", "n_particles", "n_nodes", "max_pressure", "max_stress")
    # strict=False: the last line may be one being written (fewer fields than the header).
    return {k: v for k, v in zip(keys, values, strict=False) if k in wanted}
