"""Checkpoints that nothing can corrupt unnoticed (particles.checkpoint).

A catalogue of damaged checkpoints, each refused with one CheckpointError line naming the file
and leaving the run's outputs as they were; the previous checkpoint taking over from a damaged
one with the bytes of an uninterrupted run; a checkpoint whose size does not grow with the
number of steps; checkpoints of earlier versions (no checksum, history rows inside) resuming.
"""

import hashlib
import io
import json
import logging
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest

from particles import Config, Simulation, run
from particles.checkpoint import checkpoint_config, load_checkpoint
from particles.runfiles import CHECKPOINT, PREVIOUS, CheckpointError, NotCheckpointError

CFG = Config(lam=1e-2, time=1.2, dt=0.02, seed=3, output_every=0.04)
"""A small colony: 60 steps, a frame every 2 steps, well under a second."""

NOT_SHOWN = ("allow_pickle", "Traceback", "EOFError", "BadZipFile", "Bad CRC-32", "KeyError")


def digest(folder: Path) -> dict:
    """sha256 of every file of a folder except checkpoints, by name."""
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())
            if p.is_file() and not p.name.startswith("checkpoint")}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted run's folder."""
    out = tmp_path_factory.mktemp("reference")
    run(CFG, out)
    return out


@pytest.fixture(scope="module")
def stopped(tmp_path_factory):
    """A run stopped twice (steps 20 and 35): checkpoint.npz and checkpoint.prev.npz."""
    out = tmp_path_factory.mktemp("stopped")
    run(CFG, out, max_steps=20)
    run(CFG, out, max_steps=15)
    return out


@pytest.fixture
def folder(stopped, tmp_path):
    """A copy of the stopped run."""
    out = tmp_path / "run"
    shutil.copytree(stopped, out, symlinks=True)
    return out


def rewrite(path: Path, change) -> None:
    """Rewrite the npz at ``path`` with ``change(arrays)`` applied (np.savez, pickles allowed)."""
    with np.load(path) as z:
        arrays = dict(z)
    change(arrays)
    np.savez(path, **arrays)


def without_checksum_and(name):
    """A change: the checksum (an earlier version's checkpoint) and entry ``name`` removed."""
    return lambda a: (a.pop("sha256"), a.pop(name))


def with_meta(text):
    """A change: an earlier version's checkpoint whose meta is ``text``."""
    return lambda a: (a.pop("sha256"), a.update(meta=np.array(text)))


def cut(data: bytes) -> bytes:
    return data[: len(data) // 2]


def flip(where):
    """A damage: the byte at ``where(data)`` flipped."""

    def flipped(data: bytes) -> bytes:
        k = where(data)
        return data[:k] + bytes([data[k] ^ 0xFF]) + data[k + 1:]

    return flipped


def zero(data: bytes) -> bytes:
    """64 bytes zeroed, the first 64 from a third of the file on that are not all zero."""
    k = len(data) // 3
    while not any(data[k:k + 64]):
        k += 64
    return data[:k] + bytes(64) + data[k + 64:]


def random_bytes(data: bytes) -> bytes:
    return np.random.default_rng(0).integers(0, 256, len(data), dtype=np.uint8).tobytes()


def npy(data: bytes) -> bytes:
    buf = io.BytesIO()
    np.save(buf, np.arange(3.0))
    return buf.getvalue()


def pickled(data: bytes) -> bytes:
    import pickle

    return pickle.dumps({"meta": "x"})


BYTES = {"emptied": lambda data: b"", "cut short": cut, "tail cut": lambda data: data[:-40],
         "byte flipped in the data": flip(lambda data: len(data) // 2),
         "byte flipped in an array header": flip(lambda data: data.index(b"{'descr'") + 2),
         "name flipped in the zip directory": flip(lambda data: data.rindex(b"PK\x01\x02") + 46),
         "bytes zeroed": zero,
         "random bytes": random_bytes, "an npy file": npy, "a pickle": pickled}

ENTRIES = {
    "an entry missing": lambda a: a.pop("x"),
    "an entry missing, no checksum": without_checksum_and("x"),
    "meta missing, no checksum": without_checksum_and("meta"),
    "an object array": lambda a: a.update(extra=np.array([{"a": 1}], dtype=object)),
    "an object array, no checksum": lambda a: (a.pop("sha256"),
                                               a.update(x=np.array([None], dtype=object))),
    "an array changed": lambda a: a.update(x=a["x"] + 1.0),
    "meta not JSON, no checksum": with_meta("{"),
    "meta a list, no checksum": with_meta("[]"),
    "rng missing, no checksum": lambda a: (a.pop("sha256"), a.update(
        meta=np.array(json.dumps({k: v for k, v in json.loads(str(a["meta"])).items()
                                  if k != "rng"})))),
    "arrays of unequal length, no checksum": lambda a: (a.pop("sha256"),
                                                        a.update(y=a["y"][:-1])),
    "checksum of another shape": lambda a: a.update(sha256=np.array(["0" * 64])),
}


def damage(path: Path, kind: str) -> None:
    """Damage the checkpoint at ``path`` as ``kind`` (a key of BYTES or ENTRIES)."""
    if kind in BYTES:
        path.write_bytes(BYTES[kind](path.read_bytes()))
    else:
        rewrite(path, ENTRIES[kind])


def assert_one_line(err: pytest.ExceptionInfo, *names: Path) -> None:
    """A one-line CheckpointError naming ``names``, saying the output is intact and what to do."""
    text = str(err.value)
    assert "\n" not in text and all(str(p) in text for p in names), text
    assert "output written so far is intact" in text and "--overwrite" in text, text
    assert not any(word in text for word in NOT_SHOWN), text


@pytest.mark.parametrize("kind", [*BYTES, *ENTRIES])
def test_a_damaged_checkpoint_is_refused_in_one_line(folder, kind):
    """Loading, reading its configuration, resuming without a previous checkpoint: refused."""
    path = folder / CHECKPOINT
    (folder / PREVIOUS).unlink()
    damage(path, kind)
    before = digest(folder)
    loads = [lambda: load_checkpoint(path, CFG), lambda: run(CFG, folder)]
    if "no checksum" not in kind:  # else the configuration in it may be intact
        loads += [lambda: checkpoint_config(path), lambda: Simulation.load(path)]
    for load in loads:
        with pytest.raises(CheckpointError) as err:
            load()
        assert_one_line(err, path)
    assert digest(folder) == before
    assert not list(folder.glob("*.tmp*"))


@pytest.mark.parametrize("entry", ["a symbolic link", "a directory"])
def test_a_checkpoint_that_is_no_file_is_refused(folder, tmp_path, entry):
    """A link (to an intact checkpoint elsewhere) is not read; nor a directory."""
    path = folder / CHECKPOINT
    (folder / PREVIOUS).unlink()
    if entry == "a symbolic link":
        target = tmp_path / "elsewhere.npz"
        path.rename(target)
        path.symlink_to(target)
    else:
        path.unlink()
        path.mkdir()
    with pytest.raises(CheckpointError) as err:
        run(CFG, folder)
    assert_one_line(err, path)


def no_checkpoint(folder: Path, name: str) -> Path:
    """A file of ``folder`` (a run's) that is no checkpoint, made when the run has none."""
    path = folder / name
    if name == "data.npz":  # an npz of other arrays
        np.savez(path, x=np.arange(3.0))
    elif name == "a folder":
        path.mkdir()
    elif name == "notes.zip":
        with zipfile.ZipFile(path, "w") as z:
            z.writestr("notes.txt", "kept")
    return path


NO_CHECKPOINTS = ["history.csv", "config.json", "trajectory.gsd", "data.npz", "a folder",
                  "notes.zip"]
"""Files that are no checkpoint (:func:`no_checkpoint`)."""


def assert_not_a_checkpoint(err: pytest.ExceptionInfo, path: Path, engine: str) -> None:
    """One line saying ``path`` is no checkpoint of ``engine``, never advising its removal."""
    text = str(err.value)
    assert err.type.__name__ == "NotCheckpointError", text  # either engine's runfiles
    assert "\n" not in text and text.startswith(f"{path} is not a {engine} checkpoint ("), text
    assert "damaged" not in text and "remove" not in text and "--overwrite" not in text, text
    assert not any(word in text for word in NOT_SHOWN), text


@pytest.mark.parametrize("name", NO_CHECKPOINTS)
def test_a_file_that_is_no_checkpoint_is_not_called_damaged(folder, name):
    """Issue 54: Simulation.load(history.csv) said "damaged ... remove it" of good data."""
    path = no_checkpoint(folder, name)
    before = digest(folder)
    for load in (lambda: Simulation.load(path), lambda: load_checkpoint(path, CFG),
                 lambda: checkpoint_config(path)):
        with pytest.raises(NotCheckpointError) as err:
            load()
        assert_not_a_checkpoint(err, path, "particles")
    assert digest(folder) == before


@pytest.mark.parametrize("change", ["a row changed", "rows missing", "missing"])
def test_history_that_does_not_match_the_checkpoint_is_refused(folder, change):
    history = folder / "history.csv"
    (folder / PREVIOUS).unlink()
    lines = history.read_bytes().splitlines(keepends=True)
    if change == "a row changed":
        history.write_bytes(b"".join(lines[:5] + [lines[5].replace(b",", b",1", 1)] + lines[6:]))
    elif change == "rows missing":
        history.write_bytes(b"".join(lines[:10]))
    else:
        history.unlink()
    with pytest.raises(CheckpointError) as err:
        run(CFG, folder)
    assert_one_line(err, history, folder / CHECKPOINT)


@pytest.mark.parametrize("fault", ["damaged", "missing", "history beyond it damaged"])
def test_previous_checkpoint_takes_over_with_the_uninterrupted_bytes(folder, reference, caplog,
                                                                    fault):
    """checkpoint.npz unusable: the run resumes from checkpoint.prev.npz (step 20).

    Its history rows after step 20 and trajectory frames after step 20 are dropped, and the
    finished run equals an uninterrupted one byte for byte.
    """
    path = folder / CHECKPOINT
    if fault == "damaged":
        damage(path, "byte flipped in the data")
    elif fault == "missing":
        path.unlink()
    else:  # a row of step 30 changed: checkpoint.npz (35 rows) refused, the previous one holds
        history = folder / "history.csv"
        lines = history.read_bytes().splitlines(keepends=True)
        history.write_bytes(b"".join(lines[:30] + [lines[30].replace(b",", b",1", 1)]
                                     + lines[31:]))
    with caplog.at_level(logging.WARNING, logger="particles.checkpoint"):
        sim = run(CFG, folder)
    assert f"resuming from {folder / PREVIOUS}" in caplog.text
    assert sim.finished and len(sim.history) == 60
    assert digest(folder) == digest(reference)


def test_a_damaged_checkpoint_is_not_kept_as_the_previous_one(folder):
    """After resuming from checkpoint.prev.npz the next checkpoint replaces the damaged one.

    The intact previous checkpoint stays.
    """
    damage(folder / CHECKPOINT, "bytes zeroed")
    previous = (folder / PREVIOUS).read_bytes()
    run(CFG, folder, max_steps=5)
    assert (folder / PREVIOUS).read_bytes() == previous
    assert load_checkpoint(folder / CHECKPOINT, CFG).state.step == 25
    run(CFG, folder, max_steps=5)  # now an intact checkpoint becomes the previous one
    assert load_checkpoint(folder / PREVIOUS, CFG).state.step == 25


def test_both_checkpoints_damaged_are_named(folder):
    damage(folder / CHECKPOINT, "cut short")
    damage(folder / PREVIOUS, "an entry missing")
    with pytest.raises(CheckpointError) as err:
        run(CFG, folder)
    assert_one_line(err, folder / CHECKPOINT, folder / PREVIOUS)


def meta_length(path: Path) -> tuple[int, int]:
    """(characters of the checkpoint's meta, bytes of the file beyond its arrays' data)."""
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    return len(str(arrays["meta"])), path.stat().st_size - sum(a.nbytes for a in arrays.values())


def test_checkpoint_size_does_not_grow_with_the_steps(tmp_path):
    """After 40 and after 160 steps the metadata (and all but the arrays) are the same size.

    The history (300 bytes a step) is in history.csv.
    """
    cfg = Config(lam=1e-2, time=10.0, dt=0.01, seed=1)
    run(cfg, tmp_path, max_steps=40)
    meta40, rest40 = meta_length(tmp_path / CHECKPOINT)
    run(cfg, tmp_path, max_steps=120)
    meta160, rest160 = meta_length(tmp_path / CHECKPOINT)
    assert abs(meta160 - meta40) < 50 and abs(rest160 - rest40) < 200
    assert (tmp_path / "history.csv").stat().st_size > 120 * 200


def test_checkpoint_of_the_previous_version_resumes(folder, reference):
    """A checkpoint as the previous version wrote it (no checksum, the history rows in meta).

    It resumes to the uninterrupted bytes; the history.csv beside it is not read.
    """
    path = folder / CHECKPOINT
    rows = Simulation.load(path).history

    def previous_version(arrays):
        del arrays["sha256"]
        meta = json.loads(str(arrays["meta"]))
        meta["history"] = rows
        arrays["meta"] = np.array(json.dumps(meta))

    rewrite(path, previous_version)
    (folder / PREVIOUS).unlink()
    with zipfile.ZipFile(path) as z:
        assert "sha256.npy" not in z.namelist()
    (folder / "history.csv").write_text("not read\n")
    assert run(CFG, folder).finished
    assert digest(folder) == digest(reference)
